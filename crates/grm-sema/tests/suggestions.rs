//! "Did you mean" suggestions for many unknown names in a file with many
//! definitions: each is what the plain rule gives (the closest of the
//! production's bindings, then the visible names in sorted order, within a
//! cap that grows with the name's length; ties to the first; a case-only
//! difference counts 0). The checker prepares the visible names once per
//! file; this checks the answers did not change.

use grm_sema::*;

fn levenshtein(a: &str, b: &str) -> usize {
    let (a, b): (Vec<char>, Vec<char>) = (a.chars().collect(), b.chars().collect());
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.iter().enumerate() {
        let mut cur = vec![i + 1; b.len() + 1];
        for (j, cb) in b.iter().enumerate() {
            cur[j + 1] = (prev[j] + usize::from(ca != cb))
                .min(prev[j + 1] + 1)
                .min(cur[j] + 1);
        }
        prev = cur;
    }
    prev[b.len()]
}

fn reference(name: &str, candidates: &[&str]) -> Option<String> {
    let cap = match name.chars().count() {
        0..=2 => 1,
        3..=5 => 2,
        _ => 3,
    };
    let mut best: Option<(usize, &str)> = None;
    for &c in candidates {
        if c == name || c.is_empty() {
            continue;
        }
        let d = if c.eq_ignore_ascii_case(name) {
            0
        } else {
            levenshtein(name, c)
        };
        if d <= cap && best.is_none_or(|(bd, _)| d < bd) {
            best = Some((d, c));
        }
    }
    best.map(|(_, c)| format!("did you mean `{c}`?"))
}

/// `n` constants and `n` distinct misspelt uses (in constants and in a
/// production that binds names too), with near-ties and case-only slips.
fn generated(n: usize) -> (String, Vec<String>, Vec<String>) {
    use std::fmt::Write;
    let mut s = String::new();
    let mut defined = Vec::new();
    let mut unknown = Vec::new();
    for i in 0..n {
        let name = format!("width_{i:04}");
        let _ = writeln!(s, "const {name} = {i};");
        defined.push(name);
    }
    let slip = |i: usize| -> String {
        match i % 6 {
            0 => format!("widht_{i:04}"),    // transposition
            1 => format!("Width_{i:04}"),    // case only
            2 => format!("wdth_{i:04}"),     // deletion
            3 => format!("width_{i:04}x"),   // insertion
            4 => format!("w_{i:04}"),        // too far from everything
            _ => format!("width{}", i % 97), // near several: ties
        }
    };
    for i in 0..n / 2 {
        let u = slip(i);
        let _ = writeln!(s, "const use_{i} = {u} + 1;");
        unknown.push(u);
    }
    let _ = writeln!(s, "system S {{\n    axiom A(1, 2);");
    for i in n / 2..n {
        let u = slip(i);
        let _ = writeln!(
            s,
            "    A(width_0, wid) : wid > {i} -> F({u}) A(width_0, wid);"
        );
        unknown.push(u);
    }
    let _ = writeln!(s, "}}");
    (s, defined, unknown)
}

#[test]
fn suggestions_for_many_unknown_names_are_the_plain_rules() {
    let (text, defined, unknown) = generated(600);
    let (_, c) = check_text("many.grm", &text);
    let mut sorted: Vec<&str> = defined.iter().map(String::as_str).collect();
    // `use_i` constants are visible names too.
    let uses: Vec<String> = (0..300).map(|i| format!("use_{i}")).collect();
    sorted.extend(uses.iter().map(String::as_str));
    sorted.sort_unstable();
    let got: Vec<(&str, Option<&str>)> = c
        .diagnostics
        .iter()
        .filter(|d| d.code.as_str() == "E0101")
        .map(|d| {
            let name = d
                .message
                .trim_start_matches("unknown name `")
                .trim_end_matches('`');
            let help = d.help.as_deref().filter(|h| h.starts_with("did you mean"));
            (name, help)
        })
        .collect();
    assert_eq!(got.len(), unknown.len());
    let mut suggested = 0;
    for (i, (name, help)) in got.iter().enumerate() {
        // Diagnostics are sorted by position, which is the order written.
        assert_eq!(*name, unknown[i]);
        let in_production = i >= 300;
        let mut cands: Vec<&str> = if in_production {
            vec!["width_0", "wid"]
        } else {
            Vec::new()
        };
        cands.extend(&sorted);
        let want = reference(name, &cands);
        assert_eq!(help.map(str::to_string), want, "{name}");
        suggested += usize::from(want.is_some());
    }
    assert!(suggested > 400, "{suggested}");
}

/// The help of each E0101, in order: `(name or message, help)`.
fn helps(text: &str) -> Vec<(String, Option<String>)> {
    let (_, c) = check_text("pinned.grm", text);
    c.diagnostics
        .iter()
        .filter(|d| d.code.as_str() == "E0101")
        .map(|d| (d.message.clone(), d.help.clone()))
        .collect()
}

fn mean(s: &str) -> Option<String> {
    Some(format!("did you mean `{s}`?"))
}

/// Suggestions pinned for a few slips of each kind: names in expressions
/// (bindings before globals on a tie, ties to the first in sorted order, a
/// case-only slip beating any edit, the cap growing with the length),
/// unknown symbols of a sample system, and an ignore list.
#[test]
fn pinned_suggestions() {
    let text = "\
const ratio = 0.9;
const Ratio2 = 1;
const rate = 2;
const length_scale = 3;
const ab = 4;
const ba = 5;
system S {
    axiom A(1);
    A(rat) -> F(rato) F(RATIO) F(ratio2) F(lenght_scale) F(lngth_scle) F(aa) F(rat_) F(xyz) A(rat);
}
";
    assert_eq!(
        helps(text),
        [
            // `rato`: 1 from `ratio`, `rate` and the binding `rat`: the binding.
            ("unknown name `rato`".to_string(), mean("rat")),
            // Case only: distance 0.
            ("unknown name `RATIO`".to_string(), mean("ratio")),
            ("unknown name `ratio2`".to_string(), mean("Ratio2")),
            // Transposition: 2, within the cap (3) of a long name.
            (
                "unknown name `lenght_scale`".to_string(),
                mean("length_scale")
            ),
            (
                "unknown name `lngth_scle`".to_string(),
                mean("length_scale")
            ),
            // Short: cap 1; `ab` and `ba` tie: the first in sorted order.
            ("unknown name `aa`".to_string(), mean("ab")),
            ("unknown name `rat_`".to_string(), mean("rat")),
            // Nothing close.
            (
                "unknown name `xyz`".to_string(),
                Some(
                    "bind it in the predecessor, e.g. `A(x) -> ...`, or define a `const`"
                        .to_string()
                )
            ),
        ]
    );

    let sample = "\
system S {
    mode = sample;
    axiom branch;
    skeleton branch;
    module twig;
    module twig2;
    branch -> F(1) branc twg Twig twig2 qqqq [ twig ] [ twig2 ];
    wrapup branch -> ;
}
";
    let got = helps(sample);
    assert_eq!(
        got,
        [
            ("unknown symbol `branc`".to_string(), mean("branch")),
            ("unknown symbol `twg`".to_string(), mean("twig")),
            ("unknown symbol `Twig`".to_string(), mean("twig")),
            (
                "unknown symbol `qqqq`".to_string(),
                Some("declare it (`geometry qqqq;` or `module qqqq;`) if it is meant to stay in the model".to_string())
            ),
        ],
        "{got:#?}"
    );

    let ignore = "\
system S {
    ignore Leaf lef Bud qq;
    axiom F A;
    A -> leaf A bud;
}
";
    let got = helps(ignore);
    assert_eq!(
        got,
        [
            (
                "`Leaf` in the ignore list never occurs in this system".to_string(),
                mean("leaf")
            ),
            (
                "`lef` in the ignore list never occurs in this system".to_string(),
                mean("leaf")
            ),
            (
                "`Bud` in the ignore list never occurs in this system".to_string(),
                mean("bud")
            ),
            (
                "`qq` in the ignore list never occurs in this system".to_string(),
                Some("remove it from the ignore list".to_string())
            ),
        ],
        "{got:#?}"
    );
}

/// 5,000 distinct misspelt names among 5,000 definitions, in expressions,
/// as unknown symbols of a sample system and in an ignore list: each check
/// completes with one E0101 per misspelling, and the suggestions follow
/// the plain rule (checked for a sample of them here; the whole rule on
/// 600 names above). Not timed: the time is in the report of the change.
#[test]
fn five_thousand_misspellings() {
    use std::fmt::Write;
    let n = 5000;
    let (text, defined, unknown) = generated(n);
    let (_, c) = check_text("many.grm", &text);
    let e0101: Vec<_> = c
        .diagnostics
        .iter()
        .filter(|d| d.code.as_str() == "E0101")
        .collect();
    assert_eq!(e0101.len(), n, "one diagnostic per misspelling");
    assert_eq!(c.diagnostics.len(), n, "and nothing else");
    let mut sorted: Vec<&str> = defined.iter().map(String::as_str).collect();
    let uses: Vec<String> = (0..n / 2).map(|i| format!("use_{i}")).collect();
    sorted.extend(uses.iter().map(String::as_str));
    sorted.sort_unstable();
    for i in (0..n).step_by(97) {
        let mut cands: Vec<&str> = if i >= n / 2 {
            vec!["width_0", "wid"]
        } else {
            Vec::new()
        };
        cands.extend(&sorted);
        let help = e0101[i]
            .help
            .clone()
            .filter(|h| h.starts_with("did you mean"));
        assert_eq!(help, reference(&unknown[i], &cands), "{}", unknown[i]);
    }
    // Every slip but most of the far ones (`w_0004`, 4 edits from its
    // constant, though some are near another name) has a suggestion: as
    // many as before the look-ups were prepared.
    let suggested = e0101
        .iter()
        .filter(|d| {
            d.help
                .as_deref()
                .is_some_and(|h| h.starts_with("did you mean"))
        })
        .count();
    assert_eq!(suggested, 4375);

    // Sample mode: 5,000 declared symbols, 5,000 distinct misspelt ones.
    let mut s =
        String::from("system S {\n    mode = sample;\n    axiom branch;\n    skeleton branch;\n");
    for i in 0..n {
        let _ = writeln!(s, "    module leaf_{i:04};");
    }
    for i in 0..n {
        let _ = writeln!(s, "    branch -> F(1) leaf_{i:04} lefa_{i:04};");
    }
    s.push_str("    wrapup branch -> ;\n}\n");
    let got = helps(&s);
    assert_eq!(got.len(), n);
    for (i, (msg, help)) in got.iter().enumerate() {
        assert_eq!(msg, &format!("unknown symbol `lefa_{i:04}`"));
        assert_eq!(help, &mean(&format!("leaf_{i:04}")), "{msg}");
    }

    // An ignore list of 5,000 misspelt symbols.
    let mut s = String::from("system S {\n    ignore");
    for i in 0..n {
        let _ = write!(s, " lefa_{i:04}");
    }
    s.push_str(";\n    axiom F A;\n");
    for i in 0..n {
        let _ = writeln!(s, "    A -> leaf_{i:04} A;");
    }
    s.push_str("}\n");
    let got = helps(&s);
    assert_eq!(got.len(), n);
    for (i, (_, help)) in got.iter().enumerate() {
        assert_eq!(help, &mean(&format!("leaf_{i:04}")), "lefa_{i:04}");
    }
}

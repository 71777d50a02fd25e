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

//! Hand-derived context matching cases (tests/derive_expect/context_matching.txt).

mod common;

use common::*;

struct Case {
    name: String,
    grammar: String,
    strs: Vec<(u32, Vec<Tok>)>,
}

fn cases() -> Vec<Case> {
    let text = std::fs::read_to_string(repo().join("tests/derive_expect/context_matching.txt"))
        .expect("context_matching.txt");
    let mut out: Vec<Case> = Vec::new();
    for line in text.lines() {
        if let Some(name) = line.strip_prefix("case ") {
            out.push(Case {
                name: name.to_string(),
                grammar: String::new(),
                strs: Vec::new(),
            });
        } else if let Some(g) = line.strip_prefix("grammar ") {
            out.last_mut().expect("case first").grammar = g.to_string();
        } else if let Some(rest) = line.strip_prefix("str ") {
            let (n, body) = rest.split_once(' ').unwrap_or((rest, ""));
            out.last_mut()
                .expect("case first")
                .strs
                .push((n.parse().expect("iteration"), parse_modules(body)));
        }
    }
    out
}

#[test]
fn hand_derived_context_cases() {
    let cases = cases();
    assert!(cases.len() >= 10, "only {} cases", cases.len());
    for case in &cases {
        let c = inline(&case.grammar);
        let last = case.strs.iter().map(|(n, _)| *n).max().unwrap_or(0);
        for threads in [1, 2] {
            let s = strings(&c, last, 0, threads);
            for (n, want) in &case.strs {
                assert_matches(
                    &c,
                    &s[*n as usize],
                    want,
                    &format!("{} (str {n})", case.name),
                );
            }
        }
    }
}

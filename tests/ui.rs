//! The ui suite: every `tests/ui/**/*.grm` is checked; the codes it
//! produces must be exactly those declared on its first line, and the
//! source with its rendered diagnostics is snapshotted with insta.

use std::collections::BTreeSet;
use std::path::Path;

#[test]
fn ui() {
    let mut failures = Vec::new();
    insta::glob!("ui/**/*.grm", |path| {
        let manifest = Path::new(env!("CARGO_MANIFEST_DIR"));
        let rel = path.strip_prefix(manifest).unwrap_or(path);
        let text = std::fs::read_to_string(path).unwrap_or_default();
        let Some(expected) = grm_tests::declared_codes(&text) else {
            failures.push(format!(
                "{}: first line must be `// expect: CODES` or `// expect: none`",
                rel.display()
            ));
            return;
        };
        let (rendered, got) = grm_tests::render_case(rel);
        if got != expected {
            failures.push(format!(
                "{}: expected codes {:?}, got {:?}\n{rendered}",
                rel.display(),
                expected,
                got
            ));
        }
        insta::assert_snapshot!(rendered);
    });
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

/// Every code has at least one case that produces it: a ui test
/// (`tests/ui/`) or a run test (`tests/run/`), except the codes of the
/// documented exemption list (`grm_tests::runner::EXEMPT`: internal codes
/// and the few no file-based case can reach), which must not have a case
/// (then the exemption is stale) and must say why.
#[test]
fn every_code_has_a_ui_test() {
    let mut covered = BTreeSet::new();
    for suite in ["ui", "run"] {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join(suite);
        let mut stack = vec![root];
        while let Some(dir) = stack.pop() {
            let entries = std::fs::read_dir(&dir)
                .unwrap_or_else(|e| panic!("tests/{suite} exists: {}: {e}", dir.display()));
            for entry in entries.flatten() {
                let p = entry.path();
                if p.is_dir() {
                    stack.push(p);
                } else if p.extension().is_some_and(|e| e == "grm") {
                    let text = std::fs::read_to_string(&p).unwrap_or_default();
                    covered.extend(grm_tests::declared_codes(&text).unwrap_or_default());
                }
            }
        }
    }
    let exempt: BTreeSet<&str> = grm_tests::runner::EXEMPT
        .iter()
        .map(|(c, why)| {
            assert!(!why.is_empty(), "{c}: an exemption says why");
            c.as_str()
        })
        .collect();
    assert_eq!(
        exempt.len(),
        grm_tests::runner::EXEMPT.len(),
        "a code is exempted twice"
    );
    let missing: Vec<&str> = grm_diag::Code::ALL
        .iter()
        .map(|c| c.as_str())
        .filter(|c| !covered.contains(*c) && !exempt.contains(c))
        .collect();
    assert!(
        missing.is_empty(),
        "codes without a ui or run test: {missing:?}"
    );
    let stale: Vec<&&str> = exempt.iter().filter(|c| covered.contains(**c)).collect();
    assert!(
        stale.is_empty(),
        "exempt codes that have a case (remove the exemption): {stale:?}"
    );
}

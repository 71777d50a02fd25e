//! The run suite: every `tests/run/**/*.grm` is checked and run through
//! the engines as `grmc` runs it (the command on its second line, `// run:
//! derive -n 4`); the codes it produces must be exactly those declared on
//! its first line, and the source with its rendered diagnostics is
//! snapshotted with insta. Coverage of the codes over this suite and the
//! ui suite is checked in `ui.rs`.

#[test]
fn run() {
    let mut failures = Vec::new();
    insta::glob!("run/**/*.grm", |path| {
        let manifest = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        let rel = path.strip_prefix(manifest).unwrap_or(path);
        let text = std::fs::read_to_string(path).unwrap_or_default();
        let (Some(expected), Some(_)) = (
            grm_tests::declared_codes(&text),
            grm_tests::runner::declared_command(&text),
        ) else {
            failures.push(format!(
                "{}: the first line must be `// expect: CODES`, the second `// run: COMMAND ARGS`",
                rel.display()
            ));
            return;
        };
        let (rendered, got) = grm_tests::runner::run_case(rel);
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

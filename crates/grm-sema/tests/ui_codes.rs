//! Every `tests/ui/**/*.grm` case produces exactly the codes declared on its
//! first line (`// expect: E0101 W0001` or `// expect: none`). The
//! workspace suite snapshots the rendering; this test keeps the checker's own
//! `cargo test` honest without insta (the compile errors, R01xx, that
//! `grmc check` adds are left to the workspace suite).

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

fn cases(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("tests/ui exists").flatten() {
        let p = entry.path();
        if p.is_dir() {
            cases(&p, out);
        } else if p.extension().is_some_and(|e| e == "grm") {
            out.push(p);
        }
    }
}

#[test]
fn ui_cases_produce_their_declared_codes() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/ui");
    let mut files = Vec::new();
    cases(&root, &mut files);
    files.sort();
    let mut failures = Vec::new();
    for path in &files {
        let text = std::fs::read_to_string(path).expect("ui case is UTF-8");
        let first = text.lines().next().unwrap_or("");
        let Some(rest) = first.trim().strip_prefix("// expect:") else {
            failures.push(format!("{}: no `// expect:` line", path.display()));
            continue;
        };
        // Compile errors (R01xx) come from grm-compile, which `grmc check`
        // runs after the checker: the workspace ui suite checks those.
        let want: BTreeSet<&str> = rest
            .split_whitespace()
            .filter(|c| *c != "none" && !c.starts_with("R01"))
            .collect();
        let (sources, checked) = grm_sema::check_text(&path.to_string_lossy(), &text);
        let got: BTreeSet<&str> = checked
            .diagnostics
            .iter()
            .map(|d| d.code.as_str())
            .collect();
        if got != want {
            let rendered: Vec<String> = checked
                .diagnostics
                .iter()
                .map(|d| grm_diag::render_plain(d, &sources))
                .collect();
            failures.push(format!(
                "{}: expected {want:?}, got {got:?}\n{}",
                path.display(),
                rendered.join("\n")
            ));
        }
    }
    assert!(files.len() > 50, "found only {} ui cases", files.len());
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

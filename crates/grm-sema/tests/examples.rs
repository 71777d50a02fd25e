//! The shipped examples check without any diagnostic.

use std::path::Path;

fn render(sources: &grm_sema::SourceMap, c: &grm_sema::Checked) -> String {
    c.diagnostics
        .iter()
        .map(|d| grm_diag::render_plain(d, sources))
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn examples_check_cleanly() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    let mut checked = 0;
    for entry in std::fs::read_dir(&dir).expect("examples/ exists") {
        let path = entry.expect("entry").path();
        if path.extension().is_none_or(|e| e != "grm") {
            continue;
        }
        let text = std::fs::read_to_string(&path).expect("read example");
        let (sources, c) = grm_sema::check_text(&path.to_string_lossy(), &text);
        let errors: Vec<_> = c.diagnostics.iter().filter(|d| d.is_error()).collect();
        assert!(
            errors.is_empty(),
            "{}:\n{}",
            path.display(),
            render(&sources, &c)
        );
        let codes: Vec<&str> = c.diagnostics.iter().map(|d| d.code.as_str()).collect();
        assert!(
            codes.is_empty(),
            "{}:\n{}",
            path.display(),
            render(&sources, &c)
        );
        if !path.ends_with("common.grm") {
            assert!(!c.program.systems.is_empty());
        }
        checked += 1;
    }
    assert!(checked >= 5);
}

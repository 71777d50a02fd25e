//! Every `.grm` file in the repository (examples/ and tests/ui/, globbed at
//! test time): files without syntax errors format idempotently to the same
//! tree with the same comments; files with syntax errors are refused.

mod common;

use grm_diag::FileId;

#[test]
fn corpus_formats_or_is_refused() {
    let root = common::root();
    let mut files = common::grm_files(&root.join("examples"));
    files.extend(common::grm_files(&root.join("tests/ui")));
    assert!(!files.is_empty(), "no .grm files found under {root:?}");
    let (mut formatted, mut refused) = (0, 0);
    for path in &files {
        let Ok(src) = std::fs::read_to_string(path) else {
            continue; // not UTF-8: not a .grm file the tools accept
        };
        if grm_syntax::parse(FileId(0), &src).has_errors() {
            match grm_fmt::format(&src) {
                Err(grm_fmt::FormatError::Syntax(d)) => assert!(!d.is_empty()),
                other => panic!("{}: expected a refusal, got {other:?}", path.display()),
            }
            refused += 1;
        } else {
            if std::env::var_os("GRM_FMT_SHOW").is_some() {
                println!("=== {}\n{}", path.display(), common::check(&src));
            }
            common::check(&src);
            formatted += 1;
        }
    }
    println!("{formatted} files formatted, {refused} refused");
    assert!(formatted > 0);
}

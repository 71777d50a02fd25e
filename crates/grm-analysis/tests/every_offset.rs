//! Every position query at every byte offset of every shipped grammar
//! (`examples/` and `tests/ui/`, the diagnostics' test inputs, many of them
//! broken on purpose): the stable stand-in for the `analysis` fuzz target
//! (`fuzz/`), run with the normal tests.
//!
//! An editor asks hover, completion and the rest at whatever position the
//! cursor is on, while the text is half typed; offsets inside a multi-byte
//! character come from clients that count positions differently. None of
//! these may panic, and the answers must stay inside the text.

use grm_analysis::{Analysis, Span};
use grm_sema::FsLoader;
use std::path::{Path, PathBuf};
use std::sync::Arc;

fn grammars() -> Vec<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut out = Vec::new();
    let mut dirs = vec![root.join("examples"), root.join("tests/ui")];
    while let Some(d) = dirs.pop() {
        for e in std::fs::read_dir(&d).expect("a shipped folder") {
            let p = e.expect("a folder entry").path();
            if p.is_dir() {
                dirs.push(p);
            } else if p.extension().is_some_and(|x| x == "grm") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

#[test]
fn every_query_at_every_offset_answers() {
    let files = grammars();
    assert!(files.len() > 50, "found only {} grammars", files.len());
    let mut asked = 0usize;
    for path in &files {
        let text = std::fs::read_to_string(path).expect("a UTF-8 grammar");
        let mut an = Analysis::new(Arc::new(FsLoader));
        an.set_document(path, 1, text.as_str());
        let fa = an.analyze(path).expect("an open document is analysed");
        let len = text.len() as u32;
        let inside = |s: Span, what: &str| {
            assert!(
                s.start <= s.end && s.end <= len,
                "{}: {what} span {s:?} outside the text ({len} bytes)",
                path.display()
            );
        };
        let whole = Span::new(0, len);
        for d in fa.diagnostics() {
            inside(d.span, "diagnostic");
            let _ = fa.code_actions(d.span);
        }
        for t in fa.semantic_tokens() {
            inside(t.span, "semantic token");
        }
        let _ = fa.document_symbols();
        let _ = fa.folding_ranges();
        for h in fa.inlay_hints(whole) {
            assert!(
                h.offset <= len,
                "{}: inlay hint at {}",
                path.display(),
                h.offset
            );
        }
        let _ = fa.code_actions(whole);
        let _ = fa.format();
        for o in 0..=len {
            if let Some(h) = fa.hover(o) {
                inside(h.span, "hover");
            }
            let _ = fa.completion(o);
            let _ = fa.signature_help(o);
            let _ = fa.definition(o);
            for r in fa.references(o, true) {
                if r.path == *path {
                    inside(r.span, "reference");
                }
            }
            if let Ok((s, _)) = fa.prepare_rename(o) {
                inside(s, "rename");
            }
            asked += 1;
        }
        // Renames go through the whole analysis (imports included); a
        // spread of offsets keeps the test short.
        for o in (0..=len).step_by(13) {
            let _ = an.rename(path, o, "renamed");
            let _ = an.rename(path, o, "1 bad");
        }
    }
    assert!(asked > 10_000, "asked at only {asked} offsets");
}

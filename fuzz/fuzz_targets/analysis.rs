//! Fuzz target `analysis`: what the language server asks of a document
//! while it is being typed.
//!
//! Arbitrary bytes (lossy UTF-8) become an open document of an
//! `Analysis` (imports from an in-memory loader). Then, on that document:
//! diagnostics, semantic tokens, the outline, folding ranges, inlay hints
//! and code actions over the whole text, formatting, and at every offset
//! (every character boundary for texts up to 1,500 bytes; a spread of 1,500
//! offsets in longer ones, and the end): hover, completion, signature
//! help, definition, references, prepare-rename and rename. Offsets that
//! are not character boundaries are asked too: a client's position can
//! fall inside a character after a conversion, and must not crash the
//! server.
//!
//! Nothing may panic; every answer that can be refused (a rename) must
//! refuse with an error.

#![no_main]

use grm_analysis::{Analysis, Span};
use grm_sema::MemLoader;
use libfuzzer_sys::fuzz_target;
use std::path::Path;
use std::sync::Arc;

fn loader() -> MemLoader {
    let mut l = MemLoader::new();
    l.add("/w/common.grm", include_str!("../../examples/common.grm"))
        .add(
            "/w/lib.grm",
            "const K = 2;\nsystem Lib { axiom F; F -> F F; }\n",
        )
        .add("/w/cycle.grm", "import \"main.grm\";\nconst C = 1;\n")
        .add_binary("/w/leaf.obj");
    l
}

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data).into_owned();
    let path = Path::new("/w/main.grm");
    let mut an = Analysis::new(Arc::new(loader()));
    an.set_document(path, 1, text.as_str());
    let Some(fa) = an.analyze(path) else { return };
    let len = text.len() as u32;
    let whole = Span::new(0, len);
    let diags = fa.diagnostics();
    let _ = fa.semantic_tokens();
    let _ = fa.document_symbols();
    let _ = fa.folding_ranges();
    let _ = fa.inlay_hints(whole);
    let _ = fa.code_actions(whole);
    for d in diags.iter().take(20) {
        let _ = fa.code_actions(d.span);
    }
    let _ = fa.format();
    let offsets: Vec<u32> = if len <= 1500 {
        (0..=len).collect()
    } else {
        (0..1500).map(|k| k * len / 1500).chain([len]).collect()
    };
    for &o in &offsets {
        let _ = fa.hover(o);
        let _ = fa.completion(o);
        let _ = fa.signature_help(o);
        let _ = fa.definition(o);
        let _ = fa.references(o, true);
        let _ = fa.prepare_rename(o);
    }
    let _ = an.workspace_symbols("a");
    for &o in offsets.iter().step_by(7).take(100) {
        let _ = an.references(path, o, false);
        let _ = an.rename(path, o, "renamed");
        let _ = an.rename(path, o, "1 bad name");
    }
});

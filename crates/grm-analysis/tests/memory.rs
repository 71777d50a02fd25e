//! Parsing memory (issue 32 item 4) in the language server: analysing an
//! open document (parse, check, compile check: what publishing its
//! diagnostics takes) holds under 32 bytes at once per source byte, as
//! `grmc check` does. Measured with a counting global allocator
//! (`memory_common`, shared with grm-sema's test). The editor's other
//! queries keep the tree and tokens too: `stages` (ignored) prints each.

#[path = "../../grm-sema/tests/memory_common/mod.rs"]
mod memory_common;

use grm_analysis::{Analysis, FileAnalysis};
use memory_common::*;
use std::path::Path;
use std::sync::Arc;

#[test]
fn analysis_stays_under_the_budget() {
    let _one = LOCK
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let loader = grm_sema::MemLoader::new();
    let mut failed = Vec::new();
    for (what, text) in inputs(1 << 19) {
        let (b, fa) = peak_during(|| {
            let fa = FileAnalysis::new(Path::new("gen.grm"), 1, &text, &loader);
            let d = fa.diagnostics();
            (fa, d)
        });
        let per = report(&format!("analysis, {what}"), &text, b);
        if what == "realistic" {
            assert!(fa.1.is_empty(), "{:?}", fa.1.first());
        }
        if per >= limit(what) {
            failed.push(format!("{what}: {per:.1} (limit {})", limit(what)));
        }
    }
    assert!(failed.is_empty(), "bytes per source byte: {failed:?}");
}

#[test]
#[ignore = "measurement: run with --ignored --nocapture"]
fn stages() {
    let _one = LOCK
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let text = realistic(4 << 20);
    let loader = grm_sema::MemLoader::new();
    let (b, fa) = peak_during(|| FileAnalysis::new(Path::new("gen.grm"), 1, &text, &loader));
    report("FileAnalysis::new", &text, b);
    let (b, d) = peak_during(|| fa.diagnostics());
    report("diagnostics (over the analysis)", &text, b);
    drop(d);
    let (b, _) = peak_during(|| fa.parsed().file.items.len());
    report("parsed (over the analysis)", &text, b);
    let (b, t) = peak_during(|| fa.semantic_tokens());
    report("semantic tokens (over the analysis and tree)", &text, b);
    drop(t);
    let (b, t) = peak_during(|| fa.document_symbols());
    report("document symbols (over ...)", &text, b);
    drop(t);
    drop(fa);
    let (b, n) = peak_during(|| {
        let mut a = Analysis::new(Arc::new(grm_sema::MemLoader::new()));
        a.set_document(Path::new("gen.grm"), 1, text.as_str());
        let fa = a.analyze(Path::new("gen.grm")).expect("open");
        fa.diagnostics().len() + fa.semantic_tokens().len() + fa.document_symbols().len()
    });
    let _ = n;
    report("open + diagnostics + semantic tokens + symbols", &text, b);
}

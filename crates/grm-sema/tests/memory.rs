//! Parsing memory (issue 32 item 4): `grmc check` of a large file (parse
//! and check) holds under 32 bytes at once per source byte. Measured with
//! a counting global allocator (`memory_common`), so the figures are
//! bytes, not time. Before session 19 a realistic 4 MiB grammar peaked at
//! 60.3 bytes per byte (the whole token list with its text, lists grown
//! by pushes at up to four times their length, the whole tree kept while
//! the program was built).

mod memory_common;

use memory_common::*;

/// Parse and check, as `grmc check` does (the compile check of each
/// system, which adds nothing at its peak, is measured in grm-analysis).
#[test]
fn check_stays_under_the_budget() {
    let _one = LOCK
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let mut failed = Vec::new();
    for (what, text) in inputs(1 << 19) {
        let (b, checked) = peak_during(|| grm_sema::check_text("gen.grm", &text));
        let per = report(&format!("check, {what}"), &text, b);
        if what == "realistic" {
            assert!(
                checked.1.diagnostics.is_empty(),
                "{:?}",
                checked.1.diagnostics.first()
            );
            assert!(checked.1.program.systems.len() > 100);
        }
        if per >= limit(what) {
            failed.push(format!("{what}: {per:.1} (limit {})", limit(what)));
        }
    }
    assert!(failed.is_empty(), "bytes per source byte: {failed:?}");
}

//! Parsing memory (issue 32 item 4): `grmc fmt` of a large file (parse,
//! print, parse the output again for the bug guard) holds under 32 bytes
//! at once per source byte. Measured with a counting global allocator
//! (`memory_common`, shared with grm-sema's test), so the figures are
//! bytes, not time. Before session 19 a realistic 4 MiB grammar peaked at
//! 90.2 bytes per byte (two trees and a copy of each for the guard).

#[path = "../../grm-sema/tests/memory_common/mod.rs"]
mod memory_common;

use memory_common::*;

#[test]
fn fmt_stays_under_the_budget() {
    let _one = LOCK
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let mut failed = Vec::new();
    for (what, text) in inputs(1 << 19) {
        let (b, out) = peak_during(|| grm_fmt::format(&text));
        let per = report(&format!("fmt, {what}"), &text, b);
        if what == "realistic" {
            let out = out.expect("the generated grammar formats");
            assert_eq!(grm_fmt::format(&out).as_deref(), Ok(out.as_str()));
        }
        if per >= limit(what) {
            failed.push(format!("{what}: {per:.1} (limit {})", limit(what)));
        }
    }
    assert!(failed.is_empty(), "bytes per source byte: {failed:?}");
}

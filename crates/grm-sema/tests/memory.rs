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

/// Parse and check of each input: bytes asked for, and glibc's chunks
/// ([`chunk`]: each block rounded up as glibc's malloc does).
#[test]
#[ignore = "measurement: run with --ignored --nocapture"]
fn stages() {
    let _one = LOCK
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    for (what, text) in inputs(1 << 19) {
        let (b, c, parsed) = peaks_during(|| grm_syntax::parse(grm_sema::FileId(0), &text));
        report(&format!("parse, {what}"), &text, b);
        report(&format!("parse (glibc chunks), {what}"), &text, c);
        drop(parsed);
        let (b, c, checked) = peaks_during(|| grm_sema::check_text("gen.grm", &text));
        report(&format!("check, {what}"), &text, b);
        report(&format!("check (glibc chunks), {what}"), &text, c);
        drop(checked);
    }
}

/// The resident set of this test process (VmHWM) over the file named by
/// `GRM_RSS_FILE` while it is checked, beside the counted peak and that of
/// glibc's chunks: where the three part, glibc's heap has holes (what
/// `grmc`'s whole-process figure adds). `GRM_RSS_FILE=big.grm cargo test
/// --release -p grm-sema --test memory -- --ignored --nocapture --exact rss`
#[test]
#[ignore = "measurement: names its file in GRM_RSS_FILE"]
fn rss() {
    let path = std::env::var("GRM_RSS_FILE").expect("GRM_RSS_FILE");
    let text = std::fs::read_to_string(&path).expect("read");
    let n = text.len() as f64;
    let hwm = || {
        let s = std::fs::read_to_string("/proc/self/status").unwrap();
        let l = s.lines().find(|l| l.starts_with("VmHWM:")).unwrap();
        l.split_whitespace().nth(1).unwrap().parse::<f64>().unwrap() * 1024.0
    };
    let h0 = hwm();
    use std::sync::atomic::Ordering;
    let a0 = ALLOCS.load(Ordering::SeqCst);
    let (_, c, checked) = peaks_during(|| grm_sema::check_text("gen.grm", &text));
    let a1 = ALLOCS.load(Ordering::SeqCst);
    eprintln!(
        "VmHWM {:.1} B/B (before {:.1}), chunks peak {:.1} at {} of {} allocs, diags {}",
        hwm() / n,
        h0 / n,
        c as f64 / n,
        PEAK_AT.load(Ordering::SeqCst) - a0,
        a1 - a0,
        checked.1.diagnostics.len()
    );
}

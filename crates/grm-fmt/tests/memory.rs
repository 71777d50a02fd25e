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

/// The resident set of this test process (VmHWM) over the file named by
/// `GRM_RSS_FILE` while it is fmted, beside the counted peak and that of
/// glibc's chunks: where the three part, glibc's heap has holes (what
/// `grmc`'s whole-process figure adds). `GRM_RSS_FILE=big.grm cargo test
/// --release -p grm-fmt --test memory -- --ignored --nocapture --exact rss`
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
    let (_, c, out) = peaks_during(|| grm_fmt::format(&text));
    let a1 = ALLOCS.load(Ordering::SeqCst);
    let (_, c1, p) = peaks_during(|| grm_syntax::parse(grm_diag::FileId(0), &text));
    drop(p);
    eprintln!(
        "VmHWM {:.1} B/B (before {:.1}), chunks peak {:.1} at {} of {} allocs, parse alone {:.1}, ok {}",
        hwm() / n,
        h0 / n,
        c as f64 / n,
        PEAK_AT.load(Ordering::SeqCst) - a0,
        a1 - a0,
        c1 as f64 / n,
        out.is_ok()
    );
}

//! Latency of diagnostics after a one-character edit of a 2,000-line file,
//! through the whole server (in-process, as a tower service): the time from
//! sending `didChange` to receiving `publishDiagnostics` for that version.
//! Also the analysis alone (parse + check + diagnostics) as the baseline.
//!
//! Run: `cargo bench -p grm-lsp --bench latency`.

#[path = "../tests/common/mod.rs"]
mod common;

use common::Client;
use grm_lsp::Config;
use serde_json::json;
use std::path::Path;
use std::time::{Duration, Instant};

fn stats(mut v: Vec<f64>) -> String {
    v.sort_by(f64::total_cmp);
    let q = |p: f64| v[((v.len() - 1) as f64 * p).round() as usize];
    format!(
        "median {:6.2} ms   p90 {:6.2} ms   max {:6.2} ms   (n = {})",
        q(0.5),
        q(0.9),
        q(1.0),
        v.len()
    )
}

fn main() {
    let text = grm_tests::generated_grammar(2000);
    let lines = text.lines().count();
    let runs = 40;

    // Baseline: the analysis alone.
    let mut alone = Vec::new();
    for i in 0..runs {
        let t = Instant::now();
        let fa = grm_analysis::FileAnalysis::new(
            Path::new("/bench/gen.grm"),
            i,
            &text,
            &grm_sema::MemLoader::new(),
        );
        let n = fa.diagnostics().len();
        alone.push(t.elapsed().as_secs_f64() * 1e3);
        assert_eq!(n, 0);
    }

    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .expect("runtime");
    for debounce in [0u64, 25] {
        let through = rt.block_on(async {
            let mut c = Client::with(Config {
                debounce: Duration::from_millis(debounce),
                ..Config::default()
            })
            .await;
            let p = Path::new("/bench/gen.grm");
            let u = c.open(p, &text).await;
            let _ = c.diagnostics(&u, 1).await;
            // Edit a line in the middle: insert a space, then remove it.
            let line = (lines / 2) as u32;
            let mut out = Vec::new();
            for v in 2..(2 + runs) {
                let (range, new) = if v % 2 == 0 {
                    (json!({ "start": { "line": line, "character": 4 }, "end": { "line": line, "character": 4 } }), " ")
                } else {
                    (json!({ "start": { "line": line, "character": 4 }, "end": { "line": line, "character": 5 } }), "")
                };
                let t = Instant::now();
                c.notify(
                    "textDocument/didChange",
                    json!({ "textDocument": { "uri": u, "version": v }, "contentChanges": [ { "range": range, "text": new } ] }),
                )
                .await;
                let d = c.diagnostics(&u, v).await;
                out.push(t.elapsed().as_secs_f64() * 1e3);
                assert_eq!(d["diagnostics"].as_array().map(Vec::len), Some(0));
                c.seen.clear();
            }
            out
        });
        println!(
            "edit -> publishDiagnostics, debounce {debounce:2} ms: {}",
            stats(through)
        );
    }
    println!("analysis alone ({lines} lines):         {}", stats(alone));
}

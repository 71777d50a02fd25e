//! Latency of diagnostics after a one-character edit of a 2,000-line file,
//! through the whole server (in-process, as a tower service): the time from
//! sending `didChange` to receiving `publishDiagnostics` for that version:
//! without debounce, with the default 25 ms debounce for a single edit
//! after a 100 ms pause (analysed at once), and for the last of a burst of
//! 5 edits 5 ms apart (typing: debounced). Also the analysis alone (check + diagnostics) as the
//! baseline, and semantic tokens right after an edit.
//!
//! Run: `cargo bench -p grm-lsp --bench latency`.

#[path = "../tests/common/mod.rs"]
mod common;

use common::Client;
use grm_lsp::Config;
use grm_testkit::bench::quantile;
use serde_json::json;
use std::path::Path;
use std::time::{Duration, Instant};

fn stats(v: Vec<f64>) -> String {
    let q = |p: f64| quantile(&v, p);
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
    // (debounce, edits per burst): a single edit after a 100 ms pause, or
    // the last of 5 edits 5 ms apart (typing), timed from that last edit.
    for (debounce, burst) in [(0u64, 1u32), (25, 1), (25, 5)] {
        let (through, tokens) = rt.block_on(async {
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
            let edit = |v: i32| {
                let end = if v % 2 == 0 { 4 } else { 5 };
                let new = if v % 2 == 0 { " " } else { "" };
                json!({
                    "textDocument": { "uri": u, "version": v },
                    "contentChanges": [ { "range": { "start": { "line": line, "character": 4 }, "end": { "line": line, "character": end } }, "text": new } ]
                })
            };
            let mut out = Vec::new();
            let mut v = 1;
            for _ in 0..runs {
                tokio::time::sleep(Duration::from_millis(100)).await;
                for k in 0..burst {
                    if k > 0 {
                        tokio::time::sleep(Duration::from_millis(5)).await;
                    }
                    v += 1;
                    if k + 1 < burst {
                        c.notify("textDocument/didChange", edit(v)).await;
                    }
                }
                let t = Instant::now();
                c.notify("textDocument/didChange", edit(v)).await;
                let d = c.diagnostics(&u, v).await;
                out.push(t.elapsed().as_secs_f64() * 1e3);
                assert_eq!(d["diagnostics"].as_array().map(Vec::len), Some(0));
                c.seen.clear();
            }
            // Semantic tokens of the whole file right after an edit (the
            // request re-checks, parses and lexes the new text).
            let mut tokens = Vec::new();
            for _ in 0..runs {
                v += 1;
                c.notify("textDocument/didChange", edit(v)).await;
                let t = Instant::now();
                let r = c
                    .ok("textDocument/semanticTokens/full", json!({ "textDocument": { "uri": u } }))
                    .await;
                tokens.push(t.elapsed().as_secs_f64() * 1e3);
                assert!(r["data"].as_array().is_some_and(|d| d.len() > 1000));
            }
            (out, tokens)
        });
        if debounce == 0 {
            println!(
                "semanticTokens/full right after an edit:       {}",
                stats(tokens)
            );
        }
        println!(
            "edit -> publishDiagnostics, debounce {debounce:2} ms, burst {burst}: {}",
            stats(through)
        );
    }
    println!(
        "analysis alone ({lines} lines):                 {}",
        stats(alone)
    );
}

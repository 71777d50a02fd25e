//! Regrow-to-preview latency of a 10,000-window building (issue 26,
//! "Interactive use needs a 10,000-window building to regrow and reach the
//! preview in under 50 ms"): `benches/tower_10k.grm`, a 25-floor tower
//! with four facades of 100 columns, each window a glass pane in a frame.
//!
//! The road the language server takes on an edit, stage by stage, with
//! the functions it calls:
//!
//! - analysis: parse + check + compile check (`FileAnalysis::new`, what
//!   the server runs on the new text);
//! - lower, derive, model: `grm_grow::shape::{lower, derive, model}` (what
//!   the preview's shape road calls; derive on one thread and on all);
//! - answer: `grm_lsp::preview::answer`, the server's own preview build
//!   (lower + derive + model + encode), its `stats` giving the encode;
//! - send: the `grm/previewUpdated` notification made JSON (`to_value`, as
//!   tower-lsp does, and the string the transport writes).
//!
//! An edit of the text costs analysis + answer + send; a slider (a
//! meta-parameter sent with the request, the analysis cached) costs
//! answer + send. Last, the whole server in-process: `didChange` to the
//! `grm/previewUpdated` that carries the new version (debounce 0), and
//! the same for a slider's `grm/preview` request, with the server's own
//! build (its answer's `stats`: derive, model, encode) and the rest of the
//! round trip (the server's road around the build, the transport and the
//! client) beside them. Each figure is the median of the rounds; the
//! ratios are over the 50 ms target.
//!
//! Protocol 2 (base64 in the JSON) and protocol 3 (`"binary": true`: the
//! buffers in a blob beside a small JSON message, `grm_lsp::blob`) in the
//! same run: the library stages for both, then the server in process for
//! both, rounds alternating (for protocol 3 the client reads the message
//! as JSON text and copies the blob once, as the stdio transport writes it).
//!
//! The bench runs with grmc's allocator (`grm_derive::HugePageAlloc`) in
//! the mode `grmc lsp` sets (`HugePageAlloc::serve`: the system
//! allocator's reuse, no fresh huge-page mappings).
//!
//! Run: `cargo bench -p grm-lsp --bench shape_regrow [-- ROUNDS]`.

#[path = "../tests/common/mod.rs"]
mod common;

use common::Client;
use grm_analysis::FileAnalysis;
use grm_grow::shape::{ShapeOptions, derive, lower, model};
use grm_lsp::Config;
use grm_lsp::preview::{PREVIEW_MAX_BYTES, PreviewParams, PreviewUpdatedParams, answer};
use serde_json::json;
use std::hint::black_box;
use std::path::Path;
use std::time::{Duration, Instant};

const TARGET_MS: f64 = 50.0;

/// The allocator the language server runs with (`grmc lsp`: grmc's
/// global allocator), so that its large buffers cost here what they cost
/// there.
#[global_allocator]
static ALLOC: grm_derive::HugePageAlloc = grm_derive::HugePageAlloc;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

fn row(name: &str, v: Vec<f64>) -> f64 {
    let m = median(v);
    println!("  {name:<44} {m:8.2} ms");
    m
}

fn total(name: &str, m: f64) {
    println!(
        "  {name:<44} {m:8.2} ms   {:.2}x the 50 ms target ({})",
        m / TARGET_MS,
        if m <= TARGET_MS { "met" } else { "not met" }
    );
}

fn main() {
    assert!(grm_derive::HugePageAlloc::serve(), "serving from the start");
    let rounds: usize = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(10);
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/tower_10k.grm");
    let text = std::fs::read_to_string(&path).expect("benches/tower_10k.grm");
    let uri = grm_lsp::uris::uri_of(&path).expect("a file URI");
    let loader = grm_sema::MemLoader::new();
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    // Two texts that differ in a comment: each edit is analysed afresh.
    let texts = [text.clone(), text.replace("// `floors`", "// The `floors`")];
    let params: PreviewParams =
        serde_json::from_value(json!({ "textDocument": { "uri": uri } })).expect("params");
    let slider = |floors: f64| -> PreviewParams {
        serde_json::from_value(
            json!({ "textDocument": { "uri": uri }, "params": { "floors": floors } }),
        )
        .expect("params")
    };

    // What is grown.
    let fa = FileAnalysis::new(&path, 1, &text, &loader);
    assert!(!fa.checked.has_errors(), "{:?}", fa.checked.diagnostics);
    let first = answer(&fa, &uri, &params).expect("preview");
    let shape = first.shape.as_ref().expect("a shape preview");
    let windows = {
        let prog = &fa.checked.program;
        let sys = prog.default_system().expect("system");
        let lowered = lower(prog, sys, &prog.default_params()).expect("lower");
        let tree = derive(&lowered, lowered.seed, &ShapeOptions::default()).expect("derive");
        let w = lowered.program.symbol("Window").expect("Window");
        tree.nodes()
            .iter()
            .filter(|n| matches!(n.kind, grm_shape::NodeKind::Shape { symbol, .. } if symbol == w))
            .count()
    };
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!(
        "shape regrow: {} ({windows} windows): {} nodes, {} shapes, {} groups, {} triangles, {} vertices, {} parts; {threads} hardware threads; load average {}; median of {rounds} rounds",
        path.file_name().unwrap_or_default().to_string_lossy(),
        shape.nodes,
        shape.shapes,
        shape.groups,
        first.stats.triangles,
        first.stats.vertices,
        first.parts.len(),
        load.split_whitespace()
            .take(3)
            .collect::<Vec<_>>()
            .join(" ")
    );
    assert_eq!(windows, 10_000, "the building has 10,000 windows");

    // Stage by stage, on the library calls.
    let mut analysis = Vec::new();
    let mut lowering = Vec::new();
    let mut derive_one = Vec::new();
    let mut derive_all = Vec::new();
    let mut building = Vec::new();
    let mut building_named = Vec::new();
    let mut answers = Vec::new();
    let mut a_derive = Vec::new();
    let mut a_build = Vec::new();
    let mut a_encode = Vec::new();
    let mut to_value = Vec::new();
    let mut to_string = Vec::new();
    let mut bytes = 0;
    let bin_params: PreviewParams = {
        let mut v = serde_json::to_value(&params).expect("json");
        v["binary"] = json!(true);
        serde_json::from_value(v).expect("params")
    };
    let mut bin_answers = Vec::new();
    let mut bin_encode = Vec::new();
    let mut bin_send = Vec::new();
    let (mut bin_bytes, mut blob_bytes) = (0, 0);
    for r in 0..rounds {
        let t = Instant::now();
        let fa = FileAnalysis::new(&path, r as i32 + 2, &texts[r % 2], &loader);
        analysis.push(ms(t));
        let prog = &fa.checked.program;
        let sys = prog.default_system().expect("system");
        let values = prog.default_params();
        let t = Instant::now();
        let lowered = lower(prog, sys, &values).expect("lower");
        lowering.push(ms(t));
        let t = Instant::now();
        let tree = derive(&lowered, lowered.seed, &ShapeOptions::default()).expect("derive");
        derive_one.push(ms(t));
        let t = Instant::now();
        let many = ShapeOptions {
            threads: 0,
            ..ShapeOptions::default()
        };
        black_box(derive(&lowered, lowered.seed, &many).expect("derive"));
        derive_all.push(ms(t));
        // As the preview builds it (no group names or locators), and as
        // an export does (with them).
        let build = grm_geom::BuildOptions {
            group_names: false,
            ..grm_geom::BuildOptions::limited(PREVIEW_MAX_BYTES, grm_geom::Output::Model)
        };
        let t = Instant::now();
        black_box(model(prog, &values, &lowered, &tree, None, &build).expect("model"));
        building.push(ms(t));
        if r < 3 {
            let named = grm_geom::BuildOptions {
                group_names: true,
                ..build
            };
            let t = Instant::now();
            black_box(model(prog, &values, &lowered, &tree, None, &named).expect("model"));
            building_named.push(ms(t));
        }
        drop(tree);

        let t = Instant::now();
        let result = answer(&fa, &uri, &params).expect("preview");
        answers.push(ms(t));
        a_derive.push(result.stats.derive_ms);
        a_build.push(result.stats.build_ms);
        a_encode.push(result.stats.encode_ms);
        let note = PreviewUpdatedParams {
            uri: uri.clone(),
            version: fa.version,
            result: Some(result),
            error: None,
        };
        let t = Instant::now();
        let v = serde_json::to_value(&note).expect("json");
        to_value.push(ms(t));
        let t = Instant::now();
        let s = serde_json::to_string(&v).expect("json");
        to_string.push(ms(t));
        bytes = s.len();
        drop((v, s, note));

        // Protocol 3: the same answer with its buffers in a blob.
        let t = Instant::now();
        let mut result = answer(&fa, &uri, &bin_params).expect("preview");
        bin_answers.push(ms(t));
        bin_encode.push(result.stats.encode_ms);
        let t = Instant::now();
        let blob = result.take_blob(r as u64 + 1).expect("a blob");
        let note = PreviewUpdatedParams {
            uri: uri.clone(),
            version: fa.version,
            result: Some(result),
            error: None,
        };
        let s = serde_json::to_string(&serde_json::to_value(&note).expect("json")).expect("json");
        // What the stdio transport writes: the message and the blob's bytes.
        black_box(blob.to_vec());
        bin_send.push(ms(t));
        (bin_bytes, blob_bytes) = (s.len(), blob.len());
    }
    println!("stages (library calls, one thread unless said):");
    let m_analysis = row("analysis (parse + check + compile check)", analysis);
    row("lower", lowering);
    row("derive, 1 thread", derive_one);
    row(&format!("derive, {threads} threads"), derive_all);
    row("model (meshes, picks, groups unnamed)", building);
    row(
        "model with group names (an export's; 3 rounds)",
        building_named,
    );
    println!("  the server's preview build (preview::answer):");
    row("  of which lower + derive (stats.deriveMs)", a_derive);
    row("  of which model (stats.buildMs)", a_build);
    row("  of which encode (stats.encodeMs)", a_encode);
    let m_answer = row("  answer in all", answers);
    let m_value = row("send: to_value (tower-lsp)", to_value);
    let m_string = row(
        &format!("send: to_string ({:.1} MB)", bytes as f64 / 1e6),
        to_string,
    );
    total(
        "edit: analysis + answer + send",
        m_analysis + m_answer + m_value + m_string,
    );
    total("slider: answer + send", m_answer + m_value + m_string);
    println!("  protocol 3 (binary: a blob beside the JSON):");
    row("  of which encode (stats.encodeMs)", bin_encode);
    let b_answer = row("  answer in all", bin_answers);
    let b_send = row(
        &format!(
            "send: take_blob + JSON ({:.1} kB) + the blob's bytes ({:.1} MB)",
            bin_bytes as f64 / 1e3,
            blob_bytes as f64 / 1e6
        ),
        bin_send,
    );
    total(
        "edit, protocol 3: analysis + answer + send",
        m_analysis + b_answer + b_send,
    );
    total("slider, protocol 3: answer + send", b_answer + b_send);

    // The whole server, in process.
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .expect("runtime");
    let store = std::sync::Arc::new(grm_lsp::blob::BlobStore::default());
    let mut results = Vec::new();
    for binary in [false, true] {
        let store = store.clone();
        let slider = |floors: f64| {
            let mut v = serde_json::to_value(slider(floors)).expect("json");
            if binary {
                v["binary"] = json!(true);
            }
            v
        };
        let (edits, sliders, builds) = rt.block_on(async {
        let mut c = Client::with_blobs(
            Config {
                debounce: Duration::ZERO,
                ..Config::default()
            },
            store.clone(),
        )
        .await;
        let u = c.open(&path, &text).await;
        // What the client does with a preview: read the JSON text, and
        // with protocol 3 take its blob (the stdio transport copies it
        // once into the pipe).
        let take = |v: &serde_json::Value| {
            black_box(serde_json::to_string(v).expect("json"));
            // The server's own build (its `stats`), the rest of the round
            // trip being the server's road around it and the transport.
            let st = &v["stats"];
            let built = ["deriveMs", "buildMs", "encodeMs"]
                .map(|k| st[k].as_f64().expect("stats"));
            if let Some(id) = v["blob"]["id"].as_u64() {
                black_box(store.get(id).expect("the blob is kept").to_vec());
            } else {
                assert!(!binary, "protocol 3 sends a blob");
            }
            built
        };
        let r = c
            .ok(
                "grm/preview",
                json!({ "textDocument": { "uri": u }, "live": true, "binary": binary }),
            )
            .await;
        assert_eq!(r["mode"], "shape");
        let mut edits = Vec::new();
        let mut builds = Vec::new();
        for v in 2..rounds as i32 + 2 {
            tokio::time::sleep(Duration::from_millis(50)).await;
            let t = Instant::now();
            c.notify(
                "textDocument/didChange",
                json!({ "textDocument": { "uri": u, "version": v }, "contentChanges": [ { "text": texts[v as usize % 2] } ] }),
            )
            .await;
            let n = c
                .wait_for(|r| {
                    r.method() == "grm/previewUpdated"
                        && r.params().is_some_and(|p| p["version"] == v)
                })
                .await;
            let p = n.params().expect("params");
            assert!(p["result"].is_object(), "{}", p["error"]);
            // The message's text, as `take` reads a slider's answer (once:
            // with protocol 2 a second copy of the base64 model cost the
            // edit's road 19 ms a round that the slider's did not pay).
            black_box(serde_json::to_string(&p["uri"]).expect("json"));
            let built = take(&p["result"]);
            let wall = ms(t);
            edits.push(wall);
            builds.push((built, wall));
            c.seen.clear();
        }
        // Sliders back to back, then each after the same 50 ms of idle
        // as an edit's round (an idle machine wakes up for it: the two
        // roads are compared under the same conditions).
        let mut sliders = Vec::new();
        let mut paused = Vec::new();
        for (pause, walls) in [(false, &mut sliders), (true, &mut paused)] {
            for k in 0..rounds {
                if pause {
                    tokio::time::sleep(Duration::from_millis(50)).await;
                }
                let floors = if k % 2 == 0 { 24.0 } else { 25.0 };
                let t = Instant::now();
                let r = c.ok("grm/preview", slider(floors)).await;
                let built = take(&r);
                let wall = ms(t);
                walls.push(wall);
                builds.push((built, wall));
            }
        }
        (edits, (sliders, paused), builds)
    });
        results.push((binary, edits, sliders, builds));
    }
    for (binary, edits, sliders, builds) in results {
        println!(
            "the server in process (debounce 0), protocol {}:",
            if binary { "3 (binary)" } else { "2 (base64)" }
        );
        total("didChange -> grm/previewUpdated", median(edits));
        let (sliders, paused) = sliders;
        total("grm/preview with a slider's value", median(sliders));
        total(
            "the same, each after 50 ms idle (as an edit)",
            median(paused),
        );
        // Where a round went, per road (the edits' rounds come first,
        // then the sliders'): the server's own build, as its answer's
        // `stats` time it, and the rest.
        let (on_edit, rest) = builds.split_at(rounds);
        let (on_slider, on_paused) = rest.split_at(rounds);
        for (road, builds) in [
            ("didChange", on_edit),
            ("slider", on_slider),
            ("slider after 50 ms idle", on_paused),
        ] {
            println!("  {road}:");
            let stage = |i: usize| builds.iter().map(|(b, _)| b[i]).collect();
            row("    of which lower + derive (stats.deriveMs)", stage(0));
            row("    of which model (stats.buildMs)", stage(1));
            row("    of which encode (stats.encodeMs)", stage(2));
            row(
                "    the rest: the server's road and the client",
                builds
                    .iter()
                    .map(|(b, wall)| wall - b.iter().sum::<f64>())
                    .collect(),
            );
        }
    }
}

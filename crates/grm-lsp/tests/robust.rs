//! The server under a long random edit session, stale-result ordering, and
//! the preview protocol end to end.

mod common;

use common::*;
use grm_diag::SourceFile;
use grm_lsp::Config;
use serde_json::{Value, json};
use std::time::Duration;

use grm_tests::Rng;

const PIECES: &[&str] = &[
    "F",
    "(",
    ")",
    "[",
    "]",
    ";",
    "->",
    "A(l)",
    "B",
    " ",
    "\n",
    "system X {",
    "}",
    "{",
    "@",
    "ä",
    "𝔸",
    "0.5",
    "*",
    "+",
    "const K = 1;",
    "\"",
    "/*",
    "*/",
    "//",
    "uniform(0, 1)",
    "wrapup ",
    "mode = sample;",
    "skeleton b;",
    ":",
    "l > 1",
    "(2)",
    "import \"lib.grm\";",
    "param p = 1 in 0 .. 2;",
    "axiom A(1);",
    "mix(",
    ",",
    "SHRINK",
    "spread",
    "\u{0}",
    "\r\n",
    "\r",
];

/// A random UTF-16 position, sometimes past the end of a line or the file
/// (lines end at `\n`, `\r\n` or a lone `\r`).
fn random_pos(rng: &mut Rng, text: &str) -> (u32, u32) {
    let src = SourceFile::new("", text);
    let line = rng.below(src.line_count() + 1) as u32;
    let len = match (src.line_start(line), src.line_end(line)) {
        (Some(a), Some(b)) => text[a as usize..b as usize].encode_utf16().count(),
        _ => 0,
    };
    (line, rng.below(len + 3) as u32)
}

/// Apply an LSP range edit to a local copy exactly as the server must.
fn apply_local(text: &str, a: (u32, u32), b: (u32, u32), new: &str) -> String {
    // As LSP defines positions: a character past a line's end is its end,
    // before its line break (`grm_lsp::convert::offset`).
    let src = SourceFile::new("", text);
    let o = |p: (u32, u32)| {
        grm_lsp::convert::offset(
            &src,
            tower_lsp_server::ls_types::Position {
                line: p.0,
                character: p.1,
            },
        ) as usize
    };
    let (x, y) = (o(a), o(b));
    let (x, y) = (x.min(y), x.max(y));
    let mut s = text.to_string();
    s.replace_range(x..y, new);
    s
}

fn lsp_pos(p: (u32, u32)) -> Value {
    json!({ "line": p.0, "character": p.1 })
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn random_edit_session_keeps_the_server_up() {
    let mut c = Client::with(Config {
        debounce: Duration::from_millis(2),
        ..Config::default()
    })
    .await;
    let (p, mut text) = fixture("plant.grm");
    let (lp, ltext) = fixture("lib.grm");
    c.open(&lp, &ltext).await;
    let u = c.open(&p, &text).await;
    let mut rng = Rng::seeded(0x9E37_79B9_7F4A_7C15);
    let mut version = 1;
    let mut answered = 0;
    for step in 0..400 {
        // An edit: insert, delete or replace at random UTF-16 positions.
        let a = random_pos(&mut rng, &text);
        let b = if rng.below(3) == 0 {
            random_pos(&mut rng, &text)
        } else {
            a
        };
        let new = if rng.below(4) == 0 {
            ""
        } else {
            PIECES[rng.below(PIECES.len())]
        };
        let (a, b) = if a <= b { (a, b) } else { (b, a) };
        text = apply_local(&text, a, b, new);
        version += 1;
        c.notify(
            "textDocument/didChange",
            json!({
                "textDocument": { "uri": u, "version": version },
                "contentChanges": [ { "range": { "start": lsp_pos(a), "end": lsp_pos(b) }, "text": new } ]
            }),
        )
        .await;
        // Now and then the whole text (full sync).
        if step % 97 == 0 {
            version += 1;
            c.notify(
                "textDocument/didChange",
                json!({ "textDocument": { "uri": u, "version": version }, "contentChanges": [ { "text": text } ] }),
            )
            .await;
        }
        for _ in 0..2 {
            let q = random_pos(&mut rng, &text);
            let here = at(&u, lsp_pos(q));
            let doc = json!({ "textDocument": { "uri": u } });
            let whole = json!({ "start": { "line": 0, "character": 0 }, "end": { "line": 1000, "character": 0 } });
            let (method, params): (&'static str, Value) = match rng.below(15) {
                0 => ("textDocument/hover", here),
                1 => ("textDocument/completion", here),
                2 => ("textDocument/definition", here),
                3 => {
                    let mut p = here;
                    p["context"] = json!({ "includeDeclaration": true });
                    ("textDocument/references", p)
                }
                4 => ("textDocument/semanticTokens/full", doc),
                5 => ("textDocument/documentSymbol", doc),
                6 => {
                    let mut d = doc;
                    d["range"] = whole;
                    d["context"] = json!({ "diagnostics": [] });
                    ("textDocument/codeAction", d)
                }
                7 => {
                    let mut d = doc;
                    d["options"] = json!({ "tabSize": 4, "insertSpaces": true });
                    ("textDocument/formatting", d)
                }
                8 => {
                    let mut d = doc;
                    d["range"] = whole;
                    ("textDocument/inlayHint", d)
                }
                9 => ("textDocument/foldingRange", doc),
                10 => ("textDocument/signatureHelp", here),
                11 => ("textDocument/prepareRename", here),
                12 => {
                    let mut p = here;
                    p["newName"] = json!(if rng.below(2) == 0 { "Zz" } else { "not valid" });
                    ("textDocument/rename", p)
                }
                13 => (
                    "grm/preview",
                    json!({ "textDocument": { "uri": u }, "maxModules": 20000 }),
                ),
                _ => ("workspace/symbol", json!({ "query": "a" })),
            };
            match c.request(method, params).await {
                Ok(_) => {}
                Err(e) => {
                    // Refusals are fine (RequestFailed, ContentModified);
                    // an internal error is a bug.
                    let code = e["code"].as_i64().unwrap_or(0);
                    assert!(
                        code == -32803 || code == -32801,
                        "step {step}: {method} failed: {e}\ntext:\n{text}"
                    );
                }
            }
            answered += 1;
        }
        c.drain();
    }
    assert_eq!(answered, 800);
    // The last version's diagnostics arrive.
    let _ = c.diagnostics(&u, version).await;
    tokio::time::sleep(Duration::from_millis(100)).await;
    c.drain();
    let want = serde_json::to_value(&u).unwrap();
    let later: Vec<i64> = c
        .seen
        .iter()
        .filter(|r| r.method() == "textDocument/publishDiagnostics")
        .filter_map(|r| r.params())
        .filter(|p| p["uri"] == want)
        .filter_map(|p| p["version"].as_i64())
        .collect();
    // Over the whole session: published in increasing version order, none
    // after the last version's.
    assert!(later.windows(2).all(|w| w[0] < w[1]), "{later:?}");
    assert!(later.iter().all(|&v| v < version as i64), "{later:?}");
    // The server's text is the client's: its tokens are those of the local copy.
    let r = c
        .ok(
            "textDocument/semanticTokens/full",
            json!({ "textDocument": { "uri": u } }),
        )
        .await;
    let local = grm_analysis::FileAnalysis::new(&p, version, &text, &grm_sema::FsLoader);
    let expect = grm_lsp::convert::semantic_tokens(local.source(), &local.semantic_tokens(), None);
    let expect = tower_lsp_server::ls_types::SemanticTokens {
        result_id: None,
        data: expect,
    };
    assert_eq!(r["data"], serde_json::to_value(expect).unwrap()["data"]);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn stale_diagnostics_never_overwrite_newer_ones() {
    let mut c = Client::with(Config {
        debounce: Duration::from_millis(20),
        ..Config::default()
    })
    .await;
    let (p, text) = fixture("plant.grm");
    let u = c.open(&p, &text).await;
    let _ = c.diagnostics(&u, 1).await;
    // A burst of edits faster than the debounce, each changing the error count.
    let mut t = text.clone();
    for v in 2..=30 {
        t.push_str(if v % 2 == 0 { "@" } else { "\n" });
        c.notify(
            "textDocument/didChange",
            json!({ "textDocument": { "uri": u, "version": v }, "contentChanges": [ { "text": t } ] }),
        )
        .await;
    }
    let last = c.diagnostics(&u, 30).await;
    tokio::time::sleep(Duration::from_millis(150)).await;
    c.drain();
    let want = serde_json::to_value(&u).unwrap();
    let published: Vec<i64> = c
        .seen
        .iter()
        .filter(|r| r.method() == "textDocument/publishDiagnostics")
        .filter_map(|r| r.params())
        .filter(|p| p["uri"] == want)
        .filter_map(|p| p["version"].as_i64())
        .collect();
    // Nothing after version 30, and what came before came in order.
    assert!(published.iter().all(|&v| v < 30), "{published:?}");
    assert!(published.windows(2).all(|w| w[0] < w[1]), "{published:?}");
    // Debounced: far fewer publications than edits.
    assert!(published.len() < 10, "{published:?}");
    let n = last["diagnostics"].as_array().unwrap().len();
    assert!(n >= 1, "the trailing `@` is reported");
}

/// Decode a base64 little-endian array.
fn b64(s: &str) -> Vec<[u8; 4]> {
    use base64::Engine as _;
    let bytes = base64::engine::general_purpose::STANDARD
        .decode(s)
        .expect("base64");
    assert_eq!(bytes.len() % 4, 0);
    bytes.chunks(4).map(|c| [c[0], c[1], c[2], c[3]]).collect()
}

/// A live `grm/preview` sent right after `didOpen` answers for version 1,
/// and the refresh the opening scheduled does not build and send the same
/// preview again as `grm/previewUpdated`.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn live_preview_right_after_open_is_sent_once() {
    for round in 0..5 {
        let mut c = Client::start().await;
        let (p, text) = fixture("plant.grm");
        let u = c.open(&p, &text).await;
        let r = c
            .ok(
                "grm/preview",
                json!({ "textDocument": { "uri": u }, "live": true }),
            )
            .await;
        assert_eq!(r["version"], 1);
        let _ = c.diagnostics(&u, 1).await;
        // The refresh runs right after the diagnostics are published.
        tokio::time::sleep(Duration::from_millis(300)).await;
        c.drain();
        let again = c
            .seen()
            .iter()
            .filter(|r| r.method() == "grm/previewUpdated")
            .count();
        assert_eq!(
            again, 0,
            "round {round}: the version-1 preview was sent twice"
        );
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn preview_pick_and_live_updates() {
    let mut c = Client::start().await;
    let (p, text) = fixture("plant.grm");
    let u = c.open(&p, &text).await;
    let _ = c.diagnostics(&u, 1).await;
    let r = c
        .ok(
            "grm/preview",
            json!({ "textDocument": { "uri": u }, "seed": 1, "live": true }),
        )
        .await;
    let mut out = String::new();
    use std::fmt::Write;
    let _ = writeln!(
        out,
        "system={} mode={} seed={} iterations={} encoding={}",
        r["system"], r["mode"], r["seed"], r["iterations"], r["encoding"]
    );
    let st = &r["stats"];
    let _ = writeln!(
        out,
        "modules={} bones={} instances={} polygons={} parts={} triangles={} vertices={} ambiguous={}",
        st["modules"],
        st["bones"],
        st["instances"],
        st["polygons"],
        st["parts"],
        st["triangles"],
        st["vertices"],
        st["ambiguousOrigins"]
    );
    for (i, o) in r["origins"].as_array().unwrap().iter().enumerate() {
        let _ = writeln!(
            out,
            "origin {i}: {} {}",
            o["symbol"],
            range_str(&o["range"])
        );
    }
    let mut triangles = 0;
    for part in r["parts"].as_array().unwrap() {
        let nv = part["vertexCount"].as_u64().unwrap() as usize;
        let nt = part["triangleCount"].as_u64().unwrap() as usize;
        let pos = b64(part["positions"].as_str().unwrap());
        let nor = b64(part["normals"].as_str().unwrap());
        let idx = b64(part["indices"].as_str().unwrap());
        if part["layout"] == "quads" {
            // Three corners per quad, nothing else (the client rebuilds).
            assert_eq!((nv % 4, nt), (0, nv / 2));
            assert_eq!(pos.len(), nv / 4 * 9);
            assert!(nor.is_empty() && idx.is_empty());
        } else {
            assert_eq!(pos.len(), nv * 3);
            // Flat normals are left out (the client computes them).
            assert!(
                nor.is_empty() || nor.len() == nv * 3,
                "{} normals",
                nor.len()
            );
            assert_eq!(idx.len(), nt * 3);
            assert!(idx.iter().all(|b| (u32::from_le_bytes(*b) as usize) < nv));
        }
        assert!(pos.iter().all(|b| f32::from_le_bytes(*b).is_finite()));
        triangles += nt;
        let mut by_origin = std::collections::BTreeMap::new();
        for pk in &picks(part) {
            *by_origin
                .entry(format!("{}:{}", pk["kind"], pk["origin"]))
                .or_insert(0) += pk["triangleCount"].as_u64().unwrap();
        }
        let _ = writeln!(
            out,
            "part material={} vertices={nv} triangles={nt} by origin {by_origin:?}",
            part["material"]
        );
    }
    assert_eq!(triangles as u64, st["triangles"].as_u64().unwrap());
    let bones = b64(r["skeleton"]["bones"].as_str().unwrap());
    assert_eq!(
        bones.len(),
        8 * r["skeleton"]["boneCount"].as_u64().unwrap() as usize
    );
    // Pick a triangle, then a bone: both lead to a production of the file.
    let pk = c
        .ok(
            "grm/pick",
            json!({ "textDocument": { "uri": u }, "part": 0, "triangle": 0 }),
        )
        .await;
    let _ = writeln!(
        out,
        "pick part 0 triangle 0: {} {} module {}",
        pk["symbol"],
        range_str(&pk["range"]),
        pk["module"]
    );
    let pk = c
        .ok(
            "grm/pick",
            json!({ "textDocument": { "uri": u }, "bone": 3 }),
        )
        .await;
    let _ = writeln!(
        out,
        "pick bone 3: {} {} module {}",
        pk["symbol"],
        range_str(&pk["range"]),
        pk["module"]
    );
    // Its identity: the key, and the ancestry from the axiom down to it
    // (symbol, place among its parent's children, production applied).
    let ancestry = pk["ancestry"].as_array().expect("ancestry");
    assert_eq!(ancestry.first().map(|a| &a["symbol"]), Some(&Value::Null));
    assert_eq!(ancestry.last().map(|a| &a["key"]), Some(&pk["key"]));
    assert_eq!(pk["key"].as_str().map(str::len), Some(8));
    let chain: Vec<String> = ancestry
        .iter()
        .map(|a| format!("{}@{}/{}", a["symbol"], a["child"], a["production"]))
        .collect();
    let _ = writeln!(out, "pick bone 3 ancestry: {}", chain.join(" > "));
    let none = c
        .ok(
            "grm/pick",
            json!({ "textDocument": { "uri": u }, "part": 0, "triangle": 999_999 }),
        )
        .await;
    assert!(none.is_null());
    // Focus on the second production of A: what it grows over 4 seeds.
    let f = c
        .ok(
            "grm/preview",
            json!({ "textDocument": { "uri": u }, "seed": 1, "focus": pos(&text, "(1) F(l)", 0, 4), "spreadSeeds": 4, "live": true }),
        )
        .await;
    let _ = writeln!(out, "focus: {}", f["focus"]);
    let focused: u64 = f["parts"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(picks)
        .filter(|pk| pk["focus"] == true)
        .map(|pk| pk["triangleCount"].as_u64().unwrap())
        .sum();
    let _ = writeln!(out, "focused triangles: {focused}");
    // Errors: a stale version, sample mode, an unknown parameter, one
    // outside its range, more iterations than the setting's bound.
    for params in [
        json!({ "textDocument": { "uri": u }, "version": 7 }),
        json!({ "textDocument": { "uri": u }, "mode": "sample" }),
        json!({ "textDocument": { "uri": u }, "params": { "nope": 1 } }),
        json!({ "textDocument": { "uri": u }, "params": { "spread": 1000 } }),
        json!({ "textDocument": { "uri": u }, "iterations": 4_000_000_000u64 }),
    ] {
        let e = c.request("grm/preview", params).await.unwrap_err();
        let _ = writeln!(out, "error {} {}", e["code"], e["message"]);
    }
    // Live: re-sent after an edit (with the last options), then an error.
    let edited = text.replace("iterations = 3", "iterations = 2");
    c.notify(
        "textDocument/didChange",
        json!({ "textDocument": { "uri": u, "version": 2 }, "contentChanges": [ { "text": edited } ] }),
    )
    .await;
    // The last grm/preview (the focus one) was live; the error ones
    // without `live` turned it off: turn it on again.
    let _ = c
        .ok(
            "grm/preview",
            json!({ "textDocument": { "uri": u }, "seed": 1, "live": true }),
        )
        .await;
    c.notify(
        "textDocument/didChange",
        json!({ "textDocument": { "uri": u, "version": 3 }, "contentChanges": [ { "text": edited.replace("iterations = 2", "iterations = 1") } ] }),
    )
    .await;
    let n = c
        .wait_for(|r| {
            r.method() == "grm/previewUpdated" && r.params().is_some_and(|p| p["version"] == 3)
        })
        .await;
    let p3 = n.params().unwrap();
    let _ = writeln!(
        out,
        "updated v3: iterations={} bones={} error={}",
        p3["result"]["iterations"], p3["result"]["stats"]["bones"], p3["error"]
    );
    c.notify(
        "textDocument/didChange",
        json!({ "textDocument": { "uri": u, "version": 4 }, "contentChanges": [ { "text": "system S { axiom A(Q); }" } ] }),
    )
    .await;
    let n = c
        .wait_for(|r| {
            r.method() == "grm/previewUpdated" && r.params().is_some_and(|p| p["version"] == 4)
        })
        .await;
    let p4 = n.params().unwrap();
    let _ = writeln!(
        out,
        "updated v4: result={} error={}",
        p4["result"], p4["error"]
    );
    insta::with_settings!({
        snapshot_path => concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/lsp/snapshots"),
        prepend_module_to_snapshot => false,
        omit_expression => true,
    }, {
        insta::assert_snapshot!("preview", scrub(&out));
    });
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn preview_sample_mode() {
    let mut c = Client::start().await;
    let (p, text) = fixture("guided.grm");
    let u = c.open(&p, &text).await;
    let _ = c.diagnostics(&u, 1).await;
    use std::fmt::Write;
    let mut out = String::new();
    // The system's own mode; curves from guided.curves.json next to it.
    let req = json!({ "textDocument": { "uri": u }, "budgetMs": 60000, "focus": pos(&text, "tip -> sphere", 0, 0) });
    let a = c.ok("grm/preview", req.clone()).await;
    let b = c.ok("grm/preview", req).await;
    assert_eq!(
        a["stats"]["triangles"], b["stats"]["triangles"],
        "deterministic"
    );
    assert_eq!(a["parts"], b["parts"], "deterministic");
    let s = &a["sample"];
    let _ = writeln!(
        out,
        "mode={} seed={} generations={} candidates={} stoppedEarly={} curves={}",
        a["mode"],
        a["seed"],
        s["generations"],
        s["candidates"],
        s["stoppedEarly"],
        s["curves"].as_str().unwrap().rsplit('/').next().unwrap()
    );
    assert!(s["objective"].as_f64().unwrap().is_finite());
    let st = &a["stats"];
    let _ = writeln!(
        out,
        "bones={} instances={} parts={}",
        st["bones"], st["instances"], st["parts"]
    );
    // Every picked run of triangles names the production that made it.
    let mut by_origin = std::collections::BTreeMap::new();
    for part in a["parts"].as_array().unwrap() {
        for pk in &picks(part) {
            let o = pk["origin"].as_u64().expect("sampler provenance is exact");
            let sym = a["origins"][o as usize]["symbol"]
                .as_str()
                .unwrap()
                .to_string();
            *by_origin
                .entry(format!("{}<{sym} focus={}", pk["kind"], pk["focus"]))
                .or_insert(0) += 1;
        }
    }
    let _ = writeln!(out, "picks by origin: {by_origin:?}");
    let _ = writeln!(out, "focus: {}", a["focus"]);
    // Curves in the request; a derive-mode request of a sample system fails.
    let curves: Value =
        serde_json::from_str(&std::fs::read_to_string(p.with_extension("curves.json")).unwrap())
            .unwrap();
    let r = c
        .ok(
            "grm/preview",
            json!({ "textDocument": { "uri": u }, "curves": curves, "budgetMs": 60000 }),
        )
        .await;
    let _ = writeln!(out, "inline curves: {}", r["sample"]["curves"]);
    assert_eq!(r["stats"]["bones"], a["stats"]["bones"]);
    // Coverage of each curve by the shown model (docs/curves.md 2.8).
    let cov = a["sample"]["coverage"].as_array().expect("coverage");
    assert_eq!(cov.len(), 1, "one entry per curve");
    for c in cov {
        let f = c["fraction"].as_f64().expect("fraction");
        assert!((0.0..=1.0).contains(&f));
        let gaps = c["gaps"].as_array().expect("gaps");
        assert_eq!(c["gapPoints"].as_array().map(Vec::len), Some(gaps.len()));
        let _ = writeln!(
            out,
            "coverage {}: {:.1}% unreached={} gaps={} note={}",
            c["name"],
            100.0 * f,
            c["unreached"],
            gaps.len(),
            c["note"]
        );
    }
    // A second curve far from anything the grammar can grow: not reached,
    // said so, and its one gap drawn from its start to its end.
    let mut far = curves.clone();
    far["curves"]
        .as_array_mut()
        .unwrap()
        .push(json!({ "name": "far", "points": [[40, 0, 0], [40, 1, 0], [40, 2, 0], [40, 3, 0]] }));
    let r = c
        .ok(
            "grm/preview",
            json!({ "textDocument": { "uri": u }, "curves": far, "budgetMs": 60000 }),
        )
        .await;
    let cov = r["sample"]["coverage"].as_array().expect("coverage");
    assert_eq!(cov.len(), 2);
    let f = &cov[1];
    assert_eq!(f["unreached"], true, "{f}");
    assert_eq!(f["fraction"], 0.0);
    assert_eq!(f["gaps"], json!([[0.0, 1.0]]));
    let pts = f["gapPoints"][0].as_array().expect("points");
    assert!(pts.len() >= 100, "{}", pts.len());
    let xyz = |v: &Value| -> Vec<f64> {
        v.as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect()
    };
    let (first, last) = (xyz(&pts[0]), xyz(pts.last().unwrap()));
    assert!(
        (first[0] - 40.0).abs() < 1e-4 && first[1].abs() < 1e-4,
        "{first:?}"
    );
    assert!((last[1] - 3.0).abs() < 1e-4, "{last:?}");
    assert!(f["nearest"].as_f64().unwrap() > 30.0);
    let _ = writeln!(out, "far curve: note={}", f["note"]);
    let e = c
        .request(
            "grm/preview",
            json!({ "textDocument": { "uri": u }, "mode": "derive" }),
        )
        .await
        .unwrap_err();
    let _ = writeln!(out, "derive mode: error {} {}", e["code"], e["message"]);
    let e = c
        .request(
            "grm/preview",
            json!({ "textDocument": { "uri": u }, "curves": { "version": 1, "curves": [] } }),
        )
        .await
        .unwrap_err();
    let _ = writeln!(out, "bad curves: error {}", e["code"]);
    insta::with_settings!({
        snapshot_path => concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/lsp/snapshots"),
        prepend_module_to_snapshot => false,
        omit_expression => true,
    }, {
        insta::assert_snapshot!("preview_sample", scrub(&out));
    });
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn preview_sample_generation_shows_the_search_after_it() {
    let mut c = Client::start().await;
    let (p, text) = fixture("guided.grm");
    let u = c.open(&p, &text).await;
    let _ = c.diagnostics(&u, 1).await;
    let at = |g: Option<u32>| {
        let mut req = json!({ "textDocument": { "uri": u }, "budgetMs": 60000 });
        if let Some(g) = g {
            req["generation"] = json!(g);
        }
        req
    };
    let result = c.ok("grm/preview", at(None)).await;
    assert!(result["sample"].get("generation").is_none());
    let generations = result["sample"]["generations"].as_u64().expect("count") as u32;
    assert!(generations > 2);
    // The last generation, and any past it, is the result.
    for g in [generations - 1, generations + 5] {
        let r = c.ok("grm/preview", at(Some(g))).await;
        assert_eq!(r["sample"]["generation"], u64::from(generations - 1));
        assert_eq!(r["parts"], result["parts"], "generation {g}");
        assert_eq!(r["sample"]["objective"], result["sample"]["objective"]);
    }
    // The first generation: an earlier, smaller tree, the same on every run.
    let first = c.ok("grm/preview", at(Some(0))).await;
    assert_eq!(first["sample"]["generation"], 0);
    assert_ne!(first["parts"], result["parts"]);
    assert!(
        first["stats"]["bones"].as_u64() < result["stats"]["bones"].as_u64(),
        "{} bones after generation 0, {} at the end",
        first["stats"]["bones"],
        result["stats"]["bones"]
    );
    let again = c.ok("grm/preview", at(Some(0))).await;
    assert_eq!(again["parts"], first["parts"]);
    // A picture of a generation says which it drew, and draws that model.
    let mut req = at(Some(0));
    req["width"] = json!(32);
    req["height"] = json!(32);
    let picture = c.ok("grm/picture", req).await;
    assert_eq!(picture["generation"], 0);
    assert_eq!(picture["bones"], first["stats"]["bones"]);
    let whole = c.ok("grm/picture", at(None)).await;
    assert!(whole.get("generation").is_none());
}

/// The answer of a spawned request, within `limit`.
async fn answer_within(
    task: tokio::task::JoinHandle<Option<tower_lsp_server::jsonrpc::Response>>,
    limit: Duration,
) -> Result<Value, Value> {
    let r = tokio::time::timeout(limit, task)
        .await
        .expect("answered in time")
        .expect("task")
        .expect("answered");
    let (_, body) = r.into_parts();
    body.map_err(|e| serde_json::to_value(e).unwrap_or(Value::Null))
}

/// A sample system whose search runs for ten million generations (minutes
/// in a debug build): only its wall-clock budget or a cancellation ends it.
fn endless_guided() -> (std::path::PathBuf, String, Value) {
    let (p, text) = fixture("guided.grm");
    let text = text.replace("generations = 6;", "generations = 100000;");
    let curves: Value =
        serde_json::from_str(&std::fs::read_to_string(p.with_extension("curves.json")).unwrap())
            .unwrap();
    (p.with_file_name("endless.grm"), text, curves)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_newer_live_preview_supersedes_the_one_in_flight() {
    let mut c = Client::start().await;
    let (p, text, curves) = endless_guided();
    let u = c.open(&p, &text).await;
    let _ = c.diagnostics(&u, 1).await;
    let req = |live: bool, budget: u64| json!({ "textDocument": { "uri": u }, "curves": curves, "live": live, "budgetMs": budget });
    // The first request would search for a minute.
    let first = c.spawn_request("grm/preview", req(true, 60_000)).await;
    tokio::time::sleep(Duration::from_millis(300)).await;
    assert!(
        !first.is_finished(),
        "the first preview is still being built"
    );
    // A request that is not live (a thumbnail) leaves it running.
    let once = c.ok("grm/preview", req(false, 20)).await;
    assert_eq!(once["sample"]["stoppedEarly"], true);
    tokio::time::sleep(Duration::from_millis(100)).await;
    assert!(
        !first.is_finished(),
        "a request without `live` superseded it"
    );
    // A newer live request for the same document supersedes it: the first
    // is answered with ServerCancelled at once, the second with its model.
    let t = std::time::Instant::now();
    let second = c.spawn_request("grm/preview", req(true, 20)).await;
    let e = answer_within(first, Duration::from_secs(10))
        .await
        .expect_err("superseded");
    let superseded_after = t.elapsed();
    assert_eq!(e["code"], -32802, "{e}");
    assert!(
        e["message"]
            .as_str()
            .is_some_and(|m| m.contains("superseded")),
        "{e}"
    );
    let model = answer_within(second, Duration::from_secs(30))
        .await
        .expect("the newer request's model");
    assert_eq!(model["mode"], "sample");
    assert_eq!(model["sample"]["stoppedEarly"], true);
    assert!(model["stats"]["bones"].as_u64().is_some_and(|b| b > 0));
    assert!(
        superseded_after < Duration::from_secs(5),
        "the superseded preview answered after {superseded_after:?}"
    );
    // The newer request's model is the one `grm/pick` refers to.
    let pick = c
        .ok(
            "grm/pick",
            json!({ "textDocument": { "uri": u }, "bone": 0 }),
        )
        .await;
    assert_eq!(pick["symbol"], "branch");
}

#[test]
fn a_preview_the_client_cancels_is_answered_request_cancelled_and_stops() {
    // A runtime of its own: dropping it waits for its blocking tasks, so
    // the time the drop takes tells whether the cancelled search stopped.
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .expect("runtime");
    rt.block_on(async {
        let mut c = Client::start().await;
        let (p, text, curves) = endless_guided();
        let u = c.open(&p, &text).await;
        let _ = c.diagnostics(&u, 1).await;
        let long = c
            .spawn_request(
                "grm/preview",
                json!({ "textDocument": { "uri": u }, "curves": curves, "live": true, "budgetMs": 60_000 }),
            )
            .await;
        let id = c.last_id();
        tokio::time::sleep(Duration::from_millis(200)).await;
        assert!(!long.is_finished());
        c.notify("$/cancelRequest", json!({ "id": id })).await;
        let e = answer_within(long, Duration::from_secs(5))
            .await
            .expect_err("cancelled");
        assert_eq!(e["code"], -32800, "{e}");
        // The server goes on previewing the document.
        let r = c
            .ok(
                "grm/preview",
                json!({ "textDocument": { "uri": u }, "curves": curves, "live": true, "budgetMs": 20 }),
            )
            .await;
        assert_eq!(r["mode"], "sample");
    });
    let t = std::time::Instant::now();
    drop(rt);
    assert!(
        t.elapsed() < Duration::from_secs(5),
        "the cancelled preview's search went on for {:?} after its answer",
        t.elapsed()
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn workspace_files_are_searched_without_being_open() {
    let root = common::root().join("tests/lsp");
    let mut c = Client::with_init(
        Config::default(),
        json!({ "capabilities": {}, "rootUri": uri(&root) }),
    )
    .await;
    // Nothing is open: symbols come from the scanned folder.
    let r = c.ok("workspace/symbol", json!({ "query": "zweig" })).await;
    let names: Vec<&str> = r
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["name"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["Zweig"]);
    // References to a constant of lib.grm include plant.grm, which is not open.
    let (lp, ltext) = fixture("lib.grm");
    let u = c.open(&lp, &ltext).await;
    let mut params = at(&u, pos(&ltext, "GOLDEN", 0, 0));
    params["context"] = json!({ "includeDeclaration": false });
    let r = c.ok("textDocument/references", params).await;
    let files: Vec<String> = r
        .as_array()
        .unwrap()
        .iter()
        .map(|l| {
            l["uri"]
                .as_str()
                .unwrap()
                .rsplit('/')
                .next()
                .unwrap()
                .to_string()
        })
        .collect();
    assert_eq!(files, ["plant.grm"]);
    // A deleted file is forgotten.
    let (up, _) = fixture("unicode.grm");
    c.notify(
        "workspace/didChangeWatchedFiles",
        json!({ "changes": [ { "uri": uri(&up), "type": 3 } ] }),
    )
    .await;
    let r = c.ok("workspace/symbol", json!({ "query": "zweig" })).await;
    assert_eq!(r, json!([]));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_large_preview_does_not_stall_other_requests() {
    let mut c = Client::start().await;
    let (dir, _) = fixture("lib.grm");
    let p = dir.with_file_name("big.grm");
    // 2^17 bones: seconds of mesh building in a debug build.
    let text = "system Big { iterations = 17; axiom F; F -> F F; }";
    let u = c.open(&p, text).await;
    let _ = c.diagnostics(&u, 1).await;
    let big = c
        .spawn_request("grm/preview", json!({ "textDocument": { "uri": u } }))
        .await;
    let t = std::time::Instant::now();
    let h = c
        .ok("textDocument/hover", at(&u, pos(text, "F;", 0, 0)))
        .await;
    let hover_time = t.elapsed();
    assert!(
        h["contents"]["value"]
            .as_str()
            .unwrap()
            .contains("turtle command")
    );
    assert!(
        !big.is_finished(),
        "the hover ({hover_time:?}) was answered while the preview was still being built"
    );
    let r = big.await.expect("task").expect("answered");
    let (_, body) = r.into_parts();
    let v = body.expect("preview");
    assert_eq!(v["stats"]["bones"], 1 << 17);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn untitled_buffers_are_analysed() {
    let mut c = Client::start().await;
    let text = "system S { axiom A(1); A(x) -> F(y); }";
    let u: tower_lsp_server::ls_types::Uri = "untitled:Untitled-1".parse().unwrap();
    c.notify(
        "textDocument/didOpen",
        json!({ "textDocument": { "uri": u, "languageId": "grm", "version": 1, "text": text } }),
    )
    .await;
    let d = c.diagnostics(&u, 1).await;
    let codes: Vec<&str> = d["diagnostics"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x["code"].as_str().unwrap())
        .collect();
    assert_eq!(codes, ["E0101"]);
    let h = c
        .ok("textDocument/hover", at(&u, pos(text, "F(y)", 0, 0)))
        .await;
    assert!(
        h["contents"]["value"]
            .as_str()
            .unwrap()
            .contains("turtle command")
    );
    let r = c
        .ok(
            "textDocument/codeAction",
            json!({ "textDocument": { "uri": u }, "range": { "start": { "line": 0, "character": 0 }, "end": { "line": 0, "character": 40 } }, "context": { "diagnostics": [] } }),
        )
        .await;
    let key = serde_json::to_value(&u).unwrap();
    assert!(
        r.as_array()
            .unwrap()
            .iter()
            .all(|a| a["edit"]["changes"][key.as_str().unwrap()].is_array())
    );
}

/// A slider moves a material that depends on its meta-parameter, not only
/// the geometry: the model is built with the preview's values.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn preview_materials_follow_the_sliders() {
    let mut c = Client::start().await;
    let p = root().join("tests/lsp/slider_material.grm");
    let text = "param red = 0.2 in 0 .. 1;\n\
                material m { color = rgb(red, 0, 0); metallic = 1 - red; }\n\
                system S { axiom material(m) F; }\n";
    let u = c.open(&p, text).await;
    let d = c.diagnostics(&u, 1).await;
    assert_eq!(d["diagnostics"], json!([]));
    let color = |r: &Value| {
        let m = r["materials"]
            .as_array()
            .expect("materials")
            .iter()
            .find(|m| m["name"] == "m")
            .unwrap_or_else(|| panic!("material m in {r}"))
            .clone();
        (
            m["color"][0].as_f64().unwrap(),
            m["metallic"].as_f64().unwrap(),
        )
    };
    let at_default = c
        .ok("grm/preview", json!({ "textDocument": { "uri": u } }))
        .await;
    let (r, m) = color(&at_default);
    assert!((r - 0.2).abs() < 1e-6 && (m - 0.8).abs() < 1e-6, "{r} {m}");
    let moved = c
        .ok(
            "grm/preview",
            json!({ "textDocument": { "uri": u }, "params": { "red": 0.9 } }),
        )
        .await;
    let (r, m) = color(&moved);
    assert!((r - 0.9).abs() < 1e-6 && (m - 0.1).abs() < 1e-6, "{r} {m}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn preview_generation_edge_cases() {
    let mut c = Client::start().await;
    // Derive mode ignores it.
    let (p, text) = fixture("plant.grm");
    let u = c.open(&p, &text).await;
    let _ = c.diagnostics(&u, 1).await;
    let req = |extra: Value| {
        let mut r = json!({ "textDocument": { "uri": u }, "seed": 1 });
        if let (Some(r), Some(e)) = (r.as_object_mut(), extra.as_object()) {
            r.extend(e.clone());
        }
        r
    };
    let plain = c.ok("grm/preview", req(json!({}))).await;
    let with = c.ok("grm/preview", req(json!({ "generation": 3 }))).await;
    assert_eq!(with["parts"], plain["parts"]);
    assert!(with["sample"].is_null());
    // Not a whole number from 0 to 2^32 - 1: InvalidParams, in either mode.
    for bad in [json!(-1), json!(1.5), json!(4_294_967_296u64), json!("3")] {
        let e = c
            .request("grm/preview", req(json!({ "generation": bad })))
            .await
            .expect_err("refused");
        assert_eq!(e["code"], -32602, "generation {bad}: {e}");
    }

    // Sample mode.
    let (p, text) = fixture("guided.grm");
    let u = c.open(&p, &text).await;
    let _ = c.diagnostics(&u, 1).await;
    let at = |extra: Value| {
        let mut r = json!({ "textDocument": { "uri": u }, "budgetMs": 60000 });
        if let (Some(r), Some(e)) = (r.as_object_mut(), extra.as_object()) {
            r.extend(e.clone());
        }
        r
    };
    let result = c.ok("grm/preview", at(json!({}))).await;
    let last = result["sample"]["generations"].as_u64().expect("count") - 1;
    let e = c
        .request("grm/preview", at(json!({ "generation": -1 })))
        .await
        .expect_err("refused");
    assert_eq!(e["code"], -32602, "{e}");
    let r = c
        .ok("grm/preview", at(json!({ "generation": u32::MAX })))
        .await;
    assert_eq!(r["sample"]["generation"], last);
    assert_eq!(r["parts"], result["parts"]);
    // Focus marks what the focused production made in the frame shown.
    let focus = pos(&text, "tip -> sphere", 0, 0);
    let f0 = c
        .ok(
            "grm/preview",
            at(json!({ "generation": 0, "focus": focus })),
        )
        .await;
    let fr = c.ok("grm/preview", at(json!({ "focus": focus }))).await;
    let origin = f0["focus"]["origin"].clone();
    assert_eq!(origin, fr["focus"]["origin"]);
    let mut focused = std::collections::HashSet::new();
    for part in f0["parts"].as_array().expect("parts") {
        for pk in &picks(part) {
            assert_eq!(pk["focus"], json!(pk["origin"] == origin), "{pk}");
            if pk["focus"] == true && pk["kind"] == "instance" {
                focused.insert(pk["index"].as_u64());
            }
        }
    }
    assert_eq!(
        Some(focused.len() as u64),
        f0["focus"]["instances"].as_u64()
    );
    assert!(
        f0["focus"]["instances"].as_u64() <= fr["focus"]["instances"].as_u64(),
        "{} tips after generation 0, {} at the end",
        f0["focus"]["instances"],
        fr["focus"]["instances"]
    );

    // A budget that stops the search: a generation past it shows the last
    // one run, the result.
    let (p, text, curves) = endless_guided();
    let u = c.open(&p, &text).await;
    let _ = c.diagnostics(&u, 1).await;
    let r = c
        .ok(
            "grm/preview",
            json!({ "textDocument": { "uri": u }, "curves": curves, "budgetMs": 50, "generation": 99_999 }),
        )
        .await;
    assert_eq!(r["sample"]["stoppedEarly"], true);
    let run = r["sample"]["generations"].as_u64().expect("count");
    assert!(run < 100_000);
    assert_eq!(r["sample"]["generation"], run - 1);
}

/// A sample system whose early particles cannot be wrapped up (the frames
/// tests' shared fixture).
const SHOOT: &str = include_str!("../../../tests/lsp/shoot.grm");

/// A generation whose model cannot be finished is that request's error,
/// saying which; the others, and the result, are shown.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn preview_of_a_generation_that_cannot_be_finished() {
    let mut c = Client::start().await;
    let (p, _) = fixture("guided.grm");
    let curves: Value =
        serde_json::from_str(&std::fs::read_to_string(p.with_extension("curves.json")).unwrap())
            .unwrap();
    let u = c.open(&p.with_file_name("shoot.grm"), SHOOT).await;
    let _ = c.diagnostics(&u, 1).await;
    let at = |g: Option<u32>| {
        let mut r = json!({ "textDocument": { "uri": u }, "curves": curves, "budgetMs": 60000 });
        if let Some(g) = g {
            r["generation"] = json!(g);
        }
        r
    };
    let result = c.ok("grm/preview", at(None)).await;
    assert_eq!(result["sample"]["generations"], 8);
    let e = c
        .request("grm/preview", at(Some(1)))
        .await
        .expect_err("generation 1 cannot be wrapped up");
    let m = e["message"].as_str().unwrap_or_default();
    assert!(m.contains("generation 1 cannot be finished"), "{e}");
    assert!(m.contains("NaN"), "{e}");
    let r = c.ok("grm/preview", at(Some(3))).await;
    assert_eq!(r["sample"]["generation"], 3);
    assert!(r["stats"]["bones"].as_u64() < result["stats"]["bones"].as_u64());
    let r = c.ok("grm/preview", at(Some(7))).await;
    assert_eq!(r["parts"], result["parts"]);
}

/// The first workspace-wide request analyses every workspace file; it does
/// so one file at a time without holding the server, so a hover on an open
/// document is answered while it runs (a chain of files importing each
/// other held every other request until all were analysed).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_workspace_search_does_not_stall_other_requests() {
    let dir = tempfile::tempdir().expect("temp dir");
    let n = 300;
    for k in 0..n {
        let import = if k + 1 < n {
            format!("import \"f{}.grm\";\n", k + 1)
        } else {
            String::new()
        };
        std::fs::write(
            dir.path().join(format!("f{k}.grm")),
            format!("{import}const c{k} = {k};\nsystem S{k} {{ axiom F(c{k}); }}\n"),
        )
        .expect("write");
    }
    let mut c = Client::with_init(
        Config::default(),
        json!({ "capabilities": {}, "rootUri": uri(dir.path()) }),
    )
    .await;
    let (lp, ltext) = fixture("lib.grm");
    let u = c.open(&lp, &ltext).await;
    let _ = c.diagnostics(&u, 1).await;
    let search = c
        .spawn_request("workspace/symbol", json!({ "query": "c1" }))
        .await;
    let h = c
        .ok("textDocument/hover", at(&u, pos(&ltext, "GOLDEN", 0, 0)))
        .await;
    assert!(h["contents"]["value"].as_str().is_some(), "{h}");
    assert!(
        !search.is_finished(),
        "the hover was answered only after the workspace search"
    );
    let r = search.await.expect("task").expect("answered");
    let (_, body) = r.into_parts();
    let found = body.expect("symbols");
    let mut names: Vec<&str> = found
        .as_array()
        .expect("a list")
        .iter()
        .map(|s| s["name"].as_str().expect("a name"))
        .collect();
    let all = names.len();
    names.sort_unstable();
    names.dedup();
    // Each constant once, though every file before it in the chain
    // imports it (the query is fuzzy: c1, c21, c150, ...).
    assert_eq!(names.len(), all, "{names:?}");
    for name in ["c1", "c150", "c291"] {
        assert!(names.contains(&name), "{name}: {names:?}");
    }
}

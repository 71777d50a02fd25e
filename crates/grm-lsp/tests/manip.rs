//! Direct manipulation in the language server (issue 28; docs/lsp-
//! extensions.md, "Direct manipulation"): a pick's split planes dragged
//! through `grm/drag` come back as one `workspace/applyEdit` of the
//! grammar at its version; `grm/provenance` names the numbers that place a
//! plane; a client that cannot apply edits gets the edited text;
//! `grm/writeParams` writes slider values as defaults; an unreachable drag
//! writes nothing and says why.

mod common;

use common::editor::Editor;
use common::*;
use serde_json::{Value, json};

const HOUSE: &str = "param floors = 2 in 1 .. 6;

const H = 3;

system House {
    mode = shape;
    seed = 1;
    lot = rect(10, 6);
    axiom Lot;

    Lot -> extrude(floors * 4) Mass;
    Mass -> split(z) { 3: Ground | ~1: Top };
    Ground -> split(x) { ~1: Wall | 2: Door | ~1: Wall };
    Top -> split(x) { ~1: Wall | H: Band | ~1: Wall };
}
";

fn house() -> (tempfile::TempDir, std::path::PathBuf) {
    let dir = tempfile::tempdir().expect("tempdir");
    let root = grm_sema::normalize(&std::fs::canonicalize(dir.path()).expect("canonical"));
    let p = root.join("house.grm");
    std::fs::write(&p, HOUSE).expect("write");
    (dir, p)
}

/// The `split.z` scope of the first pick's path, with its planes.
async fn split_z(pick: &Value) -> Value {
    pick["shape"]["scopes"]
        .as_array()
        .expect("scopes")
        .iter()
        .find(|s| s["label"] == "split.z")
        .cloned()
        .expect("a split.z scope on the path")
}

#[tokio::test]
async fn a_dragged_split_plane_is_one_apply_edit_of_the_grammar() {
    let (_dir, p) = house();
    let mut c = Editor::start().await;
    let u = c.open(&p, HOUSE, 4).await;
    c.ok("grm/preview", json!({ "textDocument": { "uri": u } }))
        .await;
    let pick = c
        .ok(
            "grm/pick",
            json!({ "textDocument": { "uri": u }, "part": 0, "triangle": 0 }),
        )
        .await;
    let split = split_z(&pick).await;
    let planes = split["planes"].as_array().expect("planes");
    assert_eq!(planes.len(), 1, "{split}");
    assert_eq!(planes[0]["edge"], 1);
    assert!((planes[0]["at"].as_f64().unwrap() - 3.0).abs() < 1e-5);
    let part = json!({ "kind": "plane", "command": split["key"], "edge": 1 });
    // Where it comes from: the literal 3 (the extrusion's height moves the
    // floating part, not this plane).
    let prov = c
        .ok(
            "grm/provenance",
            json!({ "textDocument": { "uri": u }, "part": part }),
        )
        .await;
    assert_eq!(prov["part"]["command"], split["key"], "{prov}");
    let sources = prov["sources"].as_array().expect("sources");
    assert_eq!(sources.len(), 1, "{prov}");
    assert_eq!(sources[0]["text"], "3");
    assert_eq!(sources[0]["range"]["start"]["line"], 11);
    // Dragged to 3.75: one edit, at the document's version.
    let out = c
        .ok(
            "grm/drag",
            json!({ "textDocument": { "uri": u }, "version": 4, "part": part,
                    "target": { "kind": "plane", "at": 3.75 } }),
        )
        .await;
    assert_eq!(out["outcome"], "solved", "{out}");
    assert_eq!(out["applied"], true);
    assert_eq!(out["changes"][0]["new"], "3.75");
    let sent = c.next_applied().await;
    assert_eq!(sent["label"], "grm: drag");
    let doc = &sent["edit"]["documentChanges"][0];
    assert_eq!(doc["textDocument"]["version"], 4);
    let edits = doc["edits"].as_array().unwrap();
    assert_eq!(edits.len(), 1);
    let edited = apply(HOUSE, edits);
    assert!(edited.contains("split(z) { 3.75: Ground"), "{edited}");
    // A drag of another version is refused.
    let stale = c
        .request(
            "grm/drag",
            json!({ "textDocument": { "uri": u }, "version": 3, "part": part,
                    "target": { "kind": "plane", "at": 3.5 } }),
        )
        .await
        .expect_err("stale");
    assert_eq!(stale["code"], -32801);
    // Beyond reach: nothing is sent, and the answer says why.
    let out = c
        .ok(
            "grm/drag",
            json!({ "textDocument": { "uri": u }, "part": part,
                    "target": { "kind": "plane", "at": -2 } }),
        )
        .await;
    assert_eq!(out["outcome"], "unreachable", "{out}");
    assert!(out["why"].as_str().unwrap().contains("no change"), "{out}");
    assert_eq!(out["applied"], false);
    // Slider values written back as defaults.
    let out = c
        .ok(
            "grm/writeParams",
            json!({ "textDocument": { "uri": u }, "params": { "floors": 3 } }),
        )
        .await;
    assert_eq!(out["changes"][0]["old"], "2");
    assert_eq!(out["changes"][0]["new"], "3");
    let sent = c.next_applied().await;
    let edited = apply(
        HOUSE,
        sent["edit"]["documentChanges"][0]["edits"]
            .as_array()
            .unwrap(),
    );
    assert!(
        edited.starts_with("param floors = 3 in 1 .. 6;"),
        "{edited}"
    );
    let bad = c
        .request(
            "grm/writeParams",
            json!({ "textDocument": { "uri": u }, "params": { "nope": 3 } }),
        )
        .await
        .expect_err("no such parameter");
    assert_eq!(bad["code"], -32602);
}

#[tokio::test]
async fn a_client_that_cannot_apply_edits_gets_the_text_and_sketches_a_slider() {
    let (_dir, p) = house();
    // `capabilities: {}`: no workspace.applyEdit (as `grmc view`).
    let mut c = Client::start().await;
    let u = c.open(&p, HOUSE).await;
    c.ok("grm/preview", json!({ "textDocument": { "uri": u } }))
        .await;
    let pick = c
        .ok(
            "grm/pick",
            json!({ "textDocument": { "uri": u }, "part": 0, "triangle": 0 }),
        )
        .await;
    let split = split_z(&pick).await;
    let part = json!({ "kind": "plane", "command": split["key"], "edge": 1 });
    let out = c
        .ok(
            "grm/sketch",
            json!({ "textDocument": { "uri": u }, "part": part, "name": "ground",
                    "keyframes": [ { "t": 1, "target": { "kind": "plane", "at": 5 } } ] }),
        )
        .await;
    assert_eq!(out["applied"], false, "{out}");
    assert_eq!(out["exactAtZero"], true, "{out}");
    assert!(out["residuals"][0][1].as_f64().unwrap() <= 1e-3, "{out}");
    let text = out["text"].as_str().expect("the edited text");
    assert!(text.contains("param ground = 0 in 0 .. 1;"), "{text}");
    assert!(
        text.contains("split(z) { mix(3, 5, ground): Ground"),
        "{text}"
    );
}

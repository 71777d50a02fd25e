//! Persistent edits in the derive-mode preview (docs/edits.md, "In the
//! editor"): `NAME.edits.json` beside the grammar is replayed by the CPU
//! engine as the model grows; the answer lists each edit's class; an
//! edit that is not replayed gets its warning on the edits file.

mod common;

use common::*;
use serde_json::json;

const PLANT: &str = "system Plant {
    iterations = 3;
    module A(len: float);
    axiom A(1);
    A(l) -> F(l) [ + A(l * 0.8) ] [ - A(l * 0.7) ] A(l * 0.9);
}
";

/// The plant written to a temporary directory, opened and previewed:
/// the directory, the grammar's path, the client, its URI and the
/// preview's answer.
async fn plant_previewed() -> (
    tempfile::TempDir,
    std::path::PathBuf,
    Client,
    tower_lsp_server::ls_types::Uri,
    serde_json::Value,
) {
    let dir = tempfile::tempdir().expect("tempdir");
    let root = grm_sema::normalize(&std::fs::canonicalize(dir.path()).expect("canonical"));
    let p = root.join("plant.grm");
    std::fs::write(&p, PLANT).expect("write");
    let mut c = Client::start().await;
    let u = c.open(&p, PLANT).await;
    let base = c
        .ok("grm/preview", json!({ "textDocument": { "uri": u } }))
        .await;
    (dir, p, c, u, base)
}

#[tokio::test]
async fn the_derive_preview_replays_key_edits_and_says_what_became_of_each() {
    let (_dir, p, mut c, u, base) = plant_previewed().await;
    assert!(base["edits"].is_null() || base["edits"]["found"] == false);
    let pick = c
        .ok(
            "grm/pick",
            json!({ "textDocument": { "uri": u }, "part": 0, "triangle": 0 }),
        )
        .await;
    // The picked segment's parent: an A whose branch the segment starts.
    let ancestry = pick["ancestry"].as_array().expect("ancestry");
    let branch = ancestry[ancestry.len() - 2]["key"].as_str().expect("key");
    let ep = grm_edits::edits_path(&p);
    std::fs::write(
        &ep,
        serde_json::to_string_pretty(&json!({ "version": 1, "edits": [
            { "id": 1, "system": "Plant", "target": { "key": branch }, "op": "remove" },
            { "id": 2, "system": "Plant", "target": { "key": "0badc0de" }, "op": "set", "name": "len", "value": 2 },
        ] }))
        .unwrap(),
    )
    .unwrap();
    let r = c
        .ok("grm/preview", json!({ "textDocument": { "uri": u } }))
        .await;
    assert!(triangles(&r) < triangles(&base), "the branch is gone");
    assert_eq!(classes(&r), "1:valid+ 2:structurally_invalid");
    // The edit not replayed: a warning on the edits file.
    let eu = serde_json::to_value(uri(&ep)).unwrap();
    let d = c
        .wait_for(|r| {
            r.method() == "textDocument/publishDiagnostics"
                && r.params().is_some_and(|p| {
                    p["uri"] == eu && p["diagnostics"].as_array().is_some_and(|d| !d.is_empty())
                })
        })
        .await;
    let d = d.params().unwrap()["diagnostics"].clone();
    assert_eq!(d.as_array().map(Vec::len), Some(1), "{d}");
    assert_eq!(d[0]["code"], "edit.structurally_invalid", "{d}");
    assert!(d[0]["message"].as_str().unwrap().contains("edit 2"), "{d}");
}

#[tokio::test]
async fn grm_edit_records_the_symbol_of_a_keys_module_in_the_derive_preview() {
    // As `grmc view`: the server writes the file.
    let (_dir, p, mut c, u, base) = plant_previewed().await;
    // A segment two levels below the axiom's A, and the A that wrote it.
    let mut found = None;
    'parts: for (i, part) in base["parts"].as_array().expect("parts").iter().enumerate() {
        for pk in picks(part) {
            let got = c
                .ok(
                    "grm/pick",
                    json!({ "textDocument": { "uri": u }, "part": i,
                            "triangle": pk["firstTriangle"] }),
                )
                .await;
            let a = got["ancestry"].as_array().expect("ancestry").clone();
            if a.len() >= 4 {
                found = Some(a[a.len() - 2].clone());
                break 'parts;
            }
        }
    }
    let branch = found.expect("a module two levels down");
    assert_eq!(branch["symbol"], "A", "{branch}");
    let key = branch["key"].as_str().expect("key").to_owned();
    c.ok(
        "grm/edit",
        json!({ "uri": u, "target": { "key": key }, "op": "remove" }),
    )
    .await;
    let ep = grm_edits::edits_path(&p);
    let text = std::fs::read_to_string(&ep).expect("written");
    assert!(text.contains("\"version\": 3"), "{text}");
    assert!(text.contains("\"symbol\": \"A\""), "{text}");
    let parsed = grm_edits::parse(&text);
    assert!(parsed.errors.is_empty(), "{text}");
    assert_eq!(parsed.file.edits[0].symbol.as_deref(), Some("A"));
    // The derivation replays it on that A (its branch is gone), and so
    // it does the same edit without the symbol (a version 1 file).
    let r = c
        .ok("grm/preview", json!({ "textDocument": { "uri": u } }))
        .await;
    assert_eq!(classes(&r), "1:valid+");
    assert!(triangles(&r) < triangles(&base), "the branch is gone");
    let plain = serde_json::to_string_pretty(&json!({ "version": 1, "edits": [
        { "id": 1, "system": "Plant", "target": { "key": key }, "op": "remove" },
    ] }))
    .unwrap();
    std::fs::write(&ep, &plain).unwrap();
    let r = c
        .ok("grm/preview", json!({ "textDocument": { "uri": u } }))
        .await;
    assert_eq!(classes(&r), "1:valid+");
    // A module an edit removed as it was made is no node, but the tree
    // keeps its symbol: a second edit of its key, made after this
    // preview, records it (the first, written without, stays so).
    c.ok(
        "grm/edit",
        json!({ "uri": u, "target": key, "op": { "op": "force", "alternative": 1 } }),
    )
    .await;
    let two = grm_edits::parse(&std::fs::read_to_string(&ep).unwrap()).file;
    let got: Vec<Option<&str>> = two.edits.iter().map(|e| e.symbol.as_deref()).collect();
    assert_eq!(got, [None, Some("A")]);
}

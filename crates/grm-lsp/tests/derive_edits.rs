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

#[tokio::test]
async fn the_derive_preview_replays_key_edits_and_says_what_became_of_each() {
    let dir = tempfile::tempdir().expect("tempdir");
    let root = grm_sema::normalize(&std::fs::canonicalize(dir.path()).expect("canonical"));
    let p = root.join("plant.grm");
    std::fs::write(&p, PLANT).expect("write");
    let mut c = Client::start().await;
    let u = c.open(&p, PLANT).await;
    let base = c
        .ok("grm/preview", json!({ "textDocument": { "uri": u } }))
        .await;
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

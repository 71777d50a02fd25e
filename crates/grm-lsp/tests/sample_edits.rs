//! Persistent edits in the sample-mode preview (docs/edits.md, "Sample
//! mode"; issue 27): `NAME.edits.json` beside the grammar is replayed by
//! the guided sampler; the answer lists each edit's class; an edit that is
//! not replayed gets its warning on the edits file. The grammar is the
//! Calder tree of examples/ with a short schedule.

mod common;

use common::*;
use serde_json::json;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_sample_preview_replays_key_edits_and_says_what_became_of_each() {
    let dir = tempfile::tempdir().expect("tempdir");
    let dir = grm_sema::normalize(&std::fs::canonicalize(dir.path()).expect("canonical"));
    for f in ["calder_tree.curves.json", "leaf.obj", "trunk.obj"] {
        std::fs::copy(root().join("examples").join(f), dir.join(f)).expect("copy");
    }
    // A short search: 6 generations, 12 -> 6 particles.
    let text = std::fs::read_to_string(root().join("examples/calder_tree.grm"))
        .expect("example")
        .replace("generations = 100;", "generations = 6;")
        .replace("particles_start = 25;", "particles_start = 12;")
        .replace("particles_end = 4;", "particles_end = 6;");
    assert!(text.contains("generations = 6;"));
    let p = dir.join("calder_tree.grm");
    std::fs::write(&p, &text).expect("write");
    let mut c = Client::start().await;
    let u = c.open(&p, &text).await;
    // A budget that stops nothing: the search is deterministic.
    let preview = json!({ "textDocument": { "uri": u }, "budgetMs": 300_000 });
    let base = c.ok("grm/preview", preview.clone()).await;
    assert_eq!(base["mode"], "sample");
    assert!(base["edits"].is_null() || base["edits"]["found"] == false);
    // The first branchOrLeaf (below START's branch: in every model), from
    // the ancestry of a picked leaf or branch.
    let parts = base["parts"].as_array().expect("parts").len();
    let mut key = None;
    'parts: for part in 0..parts {
        let pick = c
            .ok(
                "grm/pick",
                json!({ "textDocument": { "uri": u }, "part": part, "triangle": 0 }),
            )
            .await;
        for a in pick["ancestry"].as_array().expect("ancestry") {
            if a["symbol"] == "branchOrLeaf" {
                key = Some(a["key"].as_str().expect("key").to_owned());
                break 'parts;
            }
        }
    }
    let key = key.expect("a part below the first branchOrLeaf");
    let ep = grm_edits::edits_path(&p);
    std::fs::write(
        &ep,
        serde_json::to_string_pretty(&json!({ "version": 1, "edits": [
            { "id": 1, "system": "CalderTree", "target": { "key": key }, "op": "remove" },
            { "id": 2, "system": "CalderTree", "target": { "key": "0badf00d" }, "op": "remove" },
        ] }))
        .unwrap(),
    )
    .unwrap();
    let r = c.ok("grm/preview", preview.clone()).await;
    assert!(
        triangles(&r) < triangles(&base),
        "the tree above the first branch is gone: {} triangles, {} before",
        triangles(&r),
        triangles(&base)
    );
    assert_eq!(r["edits"]["found"], true);
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

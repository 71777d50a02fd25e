//! The layout view of a `.grm` file's `layout` item (issue 29, item 6;
//! docs/layout.md, "In the editor"): `grm/layout` on examples/city.grm
//! gives the item's layers merged with its sidecar's (the same city as
//! `grmc layout examples/city.grm`), a probe names the item without
//! building it, an edit lands in the sidecar beside the grammar (made when
//! there is none) without the item's generated sources, a change of the
//! grammar tells the view; `grm/layoutCity` answers the city's model as
//! mesh buffers (base64, or protocol 3's blob), grows it again after a
//! move from its building cache, and replays the building edits beside
//! the layout, an edit whose parcel is gone being R1032 on the edits file.

mod common;

use common::editor::Editor;
use common::*;
use serde_json::{Value, json};
use std::path::PathBuf;

/// examples/city.grm and what it reads, in a temporary folder; with the
/// sidecar or without.
fn city(with_sidecar: bool) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().expect("tempdir");
    let root = grm_sema::normalize(&std::fs::canonicalize(dir.path()).expect("canonical"));
    let ex = common::root().join("examples");
    for f in ["city.grm", "city_building.grm", "city_park.geojson"] {
        std::fs::copy(ex.join(f), root.join(f)).expect("copy");
    }
    if with_sidecar {
        std::fs::copy(ex.join("city.layout.json"), root.join("city.layout.json")).expect("copy");
    }
    (dir, root.join("city.grm"))
}

fn names(r: &Value) -> Vec<String> {
    r["layers"]
        .as_array()
        .unwrap()
        .iter()
        .map(|l| l["name"].as_str().unwrap().to_string())
        .collect()
}

#[tokio::test]
async fn a_grammars_layout_item_is_shown_merged_with_its_sidecar() {
    let (_dir, grm) = city(true);
    let mut c = Client::start().await;
    let text = std::fs::read_to_string(&grm).unwrap();
    let u = c.open(&grm, &text).await;
    let probe = c.ok("grm/layout", json!({ "uri": u, "probe": true })).await;
    assert_eq!(probe["item"], "City");
    assert_eq!(probe["streets"], json!([]), "a probe builds nothing");
    assert!(
        probe["sidecar"]
            .as_str()
            .unwrap()
            .ends_with("/city.layout.json")
    );
    let r = c.ok("grm/layout", json!({ "uri": u })).await;
    assert_eq!(r["item"], "City");
    // The item's layers bottom to top, then the sidecar's own (old town).
    assert_eq!(names(&r), ["base", "avenue", "park", "old town"]);
    assert_eq!(
        r["layers"][1]["source"], "features",
        "the L-system's streets"
    );
    assert_eq!(
        r["layers"][1]["merge"], "graph_cut",
        "the sidecar's merge mode"
    );
    assert_eq!(r["problems"], json!([]), "{}", r["problems"]);
    assert_eq!(r["invalid"], json!([]));
    // The same city as `grmc layout examples/city.grm` builds on the one road.
    let def = {
        let (_, checked) = grm_sema::check_text(
            &grm.display().to_string(),
            &std::fs::read_to_string(&grm).unwrap(),
        );
        assert!(!checked.has_errors());
        let (side, _) = grm_layout::sidecar::read(
            &std::fs::read_to_string(grm.with_extension("layout.json")).unwrap(),
        );
        let values = grm_compile::param_values(&checked.program, &[]).unwrap();
        let (doc, _) = grm_layout::program::document(
            &checked.program,
            &checked.program.layouts[0],
            &values,
            Some(&side),
        );
        let dir = grm.parent().unwrap().to_path_buf();
        doc.evaluate(&|p: &str| std::fs::read_to_string(dir.join(p)).map_err(|e| e.to_string()))
    };
    assert_eq!(
        r["streets"].as_array().unwrap().len(),
        def.merged.streets.len()
    );
    assert_eq!(
        r["parcels"].as_array().unwrap().len(),
        def.merged.parcels.len()
    );

    // A grammar without a layout item: no view is offered.
    let plain = grm.with_file_name("plain.grm");
    std::fs::write(&plain, "system A { axiom F; }\n").unwrap();
    let e = c
        .request("grm/layout", json!({ "uri": uri(&plain), "probe": true }))
        .await
        .expect_err("no layout item");
    assert!(e["message"].as_str().unwrap().contains("no `layout"), "{e}");
}

#[tokio::test]
async fn an_edit_of_a_grammars_layout_goes_to_the_sidecar_and_a_grammar_change_regrows_it() {
    let (_dir, grm) = city(true);
    let side = grm.with_extension("layout.json");
    let side_text = std::fs::read_to_string(&side).unwrap();
    let mut c = Editor::start().await;
    let text = std::fs::read_to_string(&grm).unwrap();
    let u = c.open(&grm, &text, 1).await;
    let r = c.ok("grm/layout", json!({ "uri": u })).await;
    let s = layout::base_street(&r);
    let res = c
        .ok(
            "grm/layoutEdit",
            json!({ "uri": u, "layer": 0,
                    "op": { "move": { "select": { "ids": [s["layerId"]] }, "translate": [3, 2] } } }),
        )
        .await;
    assert_eq!(res["applied"], true, "{res}");
    let sent = c.next_applied().await;
    let doc = &sent["edit"]["documentChanges"][0];
    assert_eq!(
        doc["textDocument"]["uri"],
        json!(uri(&side)),
        "the sidecar is edited, not the grammar"
    );
    let new = apply(&side_text, doc["edits"].as_array().unwrap());
    let (d, errs) = grm_layout::sidecar::read(&new);
    assert!(errs.is_empty(), "{errs:?}");
    let base = d.layers.iter().find(|l| l.name == "base").unwrap();
    assert_eq!(base.moves.len(), 1, "the move is the base layer's");
    let (before, _) = grm_layout::sidecar::read(&side_text);
    let order = |d: &grm_layout::layers::Document| -> Vec<String> {
        d.layers.iter().map(|l| l.name.clone()).collect()
    };
    assert_eq!(order(&d), order(&before), "the sidecar's order is kept");
    for (a, b) in d.layers.iter().zip(&before.layers) {
        assert_eq!(a.source, b.source, "{}: the sidecar's own source", a.name);
    }

    // The editor applies it (the sidecar opens): the grammar's view is told.
    c.open(&side, &new, 1).await;
    c.wait_for(|r| {
        r.method() == "grm/layoutUpdated" && r.params().is_some_and(|p| p["uri"] == json!(u))
    })
    .await;
    let moved = c.ok("grm/layout", json!({ "uri": u })).await;
    assert!(
        !moved["streets"]
            .as_array()
            .unwrap()
            .iter()
            .any(|x| x["points"] == s["points"]),
        "the street moved"
    );

    // A generator's argument changed in the grammar: told, and regrown.
    let bigger = text.replace("grid(7, 5, 80, 60, 11)", "grid(8, 5, 80, 60, 11)");
    assert_ne!(bigger, text);
    c.replace(&u, 2, &bigger).await;
    c.wait_for(|r| {
        r.method() == "grm/layoutUpdated"
            && r.params()
                .is_some_and(|p| p["uri"] == json!(u) && p["version"] == 2)
    })
    .await;
    let grown = c.ok("grm/layout", json!({ "uri": u })).await;
    assert!(
        grown["layers"][0]["streets"].as_u64().unwrap()
            > moved["layers"][0]["streets"].as_u64().unwrap(),
        "a wider grid"
    );
}

#[tokio::test]
async fn without_a_sidecar_the_first_edit_makes_it() {
    let (_dir, grm) = city(false);
    let side = grm.with_extension("layout.json");
    // As grmc view: no workspace.applyEdit, the server writes the file.
    let mut c = Client::start().await;
    let text = std::fs::read_to_string(&grm).unwrap();
    let u = c.open(&grm, &text).await;
    let r = c.ok("grm/layout", json!({ "uri": u })).await;
    assert_eq!(names(&r), ["base", "avenue", "park"]);
    let res = c
        .ok(
            "grm/layoutEdit",
            json!({ "uri": u, "layer": 1, "op": { "visible": false } }),
        )
        .await;
    assert_eq!(
        (res["applied"].clone(), res["written"].clone()),
        (json!(true), json!(true)),
        "{res}"
    );
    let (d, errs) = grm_layout::sidecar::read(&std::fs::read_to_string(&side).unwrap());
    assert!(errs.is_empty(), "{errs:?}");
    assert_eq!(d.layers.len(), 1, "only the edited layer");
    assert_eq!(d.layers[0].name, "avenue");
    assert!(!d.layers[0].visible);
    assert_eq!(
        d.layers[0].source,
        grm_layout::layers::Source::Empty,
        "the L-system's streets stay in the grammar"
    );
    let hidden = c.ok("grm/layout", json!({ "uri": u })).await;
    assert_eq!(hidden["layers"][1]["visible"], false);
    assert!(
        hidden["streets"]
            .as_array()
            .unwrap()
            .iter()
            .all(|s| s["layer"] != 1)
    );
}

/// The bytes of a part's buffer (base64 text in the answer, or a range of `blob`).
fn bytes(b: &Value, blob: &[u8]) -> Vec<u8> {
    let buf: grm_lsp::blob::Buf = serde_json::from_value(b.clone()).unwrap();
    buf.decode(blob).expect("decodes")
}

#[tokio::test]
async fn the_city_of_a_grammar_is_answered_as_mesh_buffers_with_its_building_edits() {
    let (_dir, grm) = city(true);
    let store = std::sync::Arc::new(grm_lsp::blob::BlobStore::default());
    let mut c = Client::with_blobs(grm_lsp::Config::default(), store.clone()).await;
    let text = std::fs::read_to_string(&grm).unwrap();
    let u = c.open(&grm, &text).await;
    let first = c.ok("grm/layoutCity", json!({ "uri": u })).await;
    assert_eq!(first["encoding"], "base64-le");
    assert_eq!(first["problems"], json!([]), "{}", first["problems"]);
    let parcels = first["parcels"].as_u64().unwrap();
    assert!(parcels > 50, "{parcels}");
    let buildings = first["buildings"].as_u64().unwrap();
    assert!(buildings > parcels / 2, "{buildings} buildings");
    let mut triangles = 0;
    for p in first["parts"].as_array().unwrap() {
        let pos = bytes(&p["positions"], &[]);
        assert!(!pos.is_empty() && pos.len().is_multiple_of(12));
        triangles += p["triangleCount"].as_u64().unwrap();
    }
    assert_eq!(triangles, first["triangles"].as_u64().unwrap());
    assert!(triangles > 10_000, "{triangles}");
    assert!(!first["materials"].as_array().unwrap().is_empty());

    // Protocol 3: the same buffers as ranges of a blob.
    let bin = c
        .ok("grm/layoutCity", json!({ "uri": u, "binary": true }))
        .await;
    assert_eq!(bin["encoding"], "blob-le");
    let id = bin["blob"]["id"].as_u64().unwrap();
    let blob = store.get(id).expect("the blob is kept").to_vec();
    assert_eq!(blob.len() as u64, bin["blob"]["bytes"].as_u64().unwrap());
    assert_eq!(bin["reused"], bin["buildings"], "all from the cache");
    for (a, b) in first["parts"]
        .as_array()
        .unwrap()
        .iter()
        .zip(bin["parts"].as_array().unwrap())
    {
        for k in ["positions", "normals", "indices"] {
            assert_eq!(bytes(&a[k], &[]), bytes(&b[k], &blob), "{k}");
        }
    }

    // Building edits beside the grammar: one on a parcel of the city, one
    // on a parcel it does not have (R1032 on the edits file).
    let r = c.ok("grm/layout", json!({ "uri": u })).await;
    let parcel = r["parcels"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["tags"]["building"] != false)
        .map(|p| p["id"].as_str().unwrap().to_string())
        .unwrap();
    let edit = |id: u32, parcel: &str| {
        format!(
            r#"{{"id": {id}, "system": "Building", "parcel": "{parcel}",
               "target": {{"semantic": "(floor = 1) Floor"}}, "op": "remove"}}"#
        )
    };
    let edits = grm.with_file_name("city.edits.json");
    let edits_text = format!(
        r#"{{"version": 1, "edits": [{}, {}]}}"#,
        edit(1, &parcel),
        edit(2, "00000000000000ff")
    );
    std::fs::write(&edits, &edits_text).unwrap();
    let ed = c.ok("grm/layoutCity", json!({ "uri": u })).await;
    assert_eq!(ed["edited"], 1, "the edit on its parcel replayed");
    assert_eq!(
        ed["reused"].as_u64().unwrap(),
        ed["buildings"].as_u64().unwrap() - 1,
        "only the edited building grew again"
    );
    let gone: Vec<&Value> = ed["problems"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|p| p["code"] == "R1032")
        .collect();
    assert_eq!(gone.len(), 1, "{}", ed["problems"]);
    assert!(
        gone[0]["message"]
            .as_str()
            .unwrap()
            .contains("edit 2: parcel 00000000000000ff")
    );
    assert_ne!(ed["triangles"], first["triangles"], "a floor removed");
    let d = r1032_published(&mut c, &edits, true).await;
    let diags = d.params().unwrap()["diagnostics"].clone();
    let r1032 = diags
        .as_array()
        .unwrap()
        .iter()
        .find(|d| d["code"] == "R1032")
        .unwrap();
    assert_eq!(r1032["severity"], 1, "an error");
    assert_eq!(r1032["data"]["edit"], 2);

    // The edit removed: its diagnostic goes.
    std::fs::write(
        &edits,
        format!(r#"{{"version": 1, "edits": [{}]}}"#, edit(1, &parcel)),
    )
    .unwrap();
    let alone = c.ok("grm/layoutCity", json!({ "uri": u })).await;
    assert!(
        alone["problems"]
            .as_array()
            .unwrap()
            .iter()
            .all(|p| p["code"] != "R1032")
    );
    r1032_published(&mut c, &edits, false).await;
}

/// The next diagnostics published on the edits file `edits` with an
/// R1032 among them (`present`), or with none.
async fn r1032_published(
    c: &mut Client,
    edits: &std::path::Path,
    present: bool,
) -> tower_lsp_server::jsonrpc::Request {
    c.wait_for(|r| {
        r.method() == "textDocument/publishDiagnostics"
            && r.params().is_some_and(|p| {
                p["uri"] == json!(uri(edits))
                    && p["diagnostics"]
                        .as_array()
                        .unwrap()
                        .iter()
                        .any(|d| d["code"] == "R1032")
                        == present
            })
    })
    .await
}

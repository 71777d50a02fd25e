//! The editor's layout view in the language server (issue 29;
//! docs/layout.md, "In the editor"): `grm/layout` answers a sidecar's
//! merged layout with its layers; `grm/layoutEdit` moves a street (the move
//! lands in the sidecar, through `workspace/applyEdit` or written by the
//! server for a client that cannot apply edits), reports a rejected move
//! with its code and writes nothing, hides a layer, protects, cuts to a new
//! layer and anchors an assignment; `grm/layoutCity` grows the buildings
//! on the parcels (answered as mesh buffers) and, after a move, takes the
//! unchanged ones from its cache.

mod common;

use common::editor::Editor;
use common::*;
use grm_layout::layers::Select;
use serde_json::{Value, json};
use std::path::PathBuf;

/// A small city: a 4 x 3 grid and, above it, one diagonal avenue.
const CITY: &str = r#"{
  "version": 1,
  "layers": [
    {"name": "base", "seed": 7,
     "source": {"grid": {"origin": [0, 0], "size": [4, 3], "spacing": [80, 60], "seed": 11}}},
    {"name": "avenue", "merge": "hard", "fill": false,
     "source": {"features": {"type": "FeatureCollection", "features": [
       {"type": "Feature", "id": "avenue", "properties": {"class": "highway"},
        "geometry": {"type": "LineString", "coordinates": [[-40, 200], [360, -20]]}}]}}}
  ]
}
"#;

fn city() -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().expect("tempdir");
    let root = grm_sema::normalize(&std::fs::canonicalize(dir.path()).expect("canonical"));
    let p = root.join("city.layout.json");
    std::fs::write(&p, CITY).expect("write");
    (dir, p)
}

fn street<'a>(r: &'a Value, id: &Value) -> Option<&'a Value> {
    r["streets"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["id"] == *id)
}

#[tokio::test]
async fn a_dragged_street_lands_in_the_sidecar_and_the_layout_follows() {
    let (_dir, p) = city();
    let mut c = Editor::start().await;
    let u = c.open(&p, CITY, 1).await;
    let r = c.ok("grm/layout", json!({ "uri": u })).await;
    assert_eq!(r["problems"], json!([]), "{}", r["problems"]);
    assert_eq!(r["invalid"], json!([]));
    let names: Vec<&str> = r["layers"]
        .as_array()
        .unwrap()
        .iter()
        .map(|l| l["name"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["base", "avenue"]);
    assert!(r["parcels"].as_array().unwrap().len() > 10);
    assert!(
        r["streets"]
            .as_array()
            .unwrap()
            .iter()
            .any(|s| s["layer"] == 1),
        "the avenue is the top layer's"
    );
    let s = layout::base_street(&r);
    let before = s["points"].clone();

    let res = c
        .ok(
            "grm/layoutEdit",
            json!({ "uri": u, "layer": 0,
                    "op": { "move": { "select": { "ids": [s["layerId"]] }, "translate": [3, 2] } } }),
        )
        .await;
    assert_eq!(res["applied"], true, "{res}");
    assert_eq!(res["written"], false);
    let sent = c.next_applied().await;
    assert_eq!(sent["edit"], res["edit"]);
    let doc = &sent["edit"]["documentChanges"][0];
    assert_eq!(doc["textDocument"]["version"], 1);
    let text = apply(CITY, doc["edits"].as_array().unwrap());
    let (d, errs) = grm_layout::sidecar::read(&text);
    assert!(errs.is_empty(), "{errs:?}");
    assert_eq!(text, grm_layout::sidecar::write(&d), "canonical");
    let m = &d.layers[0].moves;
    assert_eq!(m.len(), 1);
    let id = grm_layout::id::Id::parse(s["layerId"].as_str().unwrap()).unwrap();
    assert_eq!(m[0].select, Select::Ids(vec![id]));
    assert_eq!((m[0].translate.x, m[0].translate.y), (3.0, 2.0));

    // The editor changes the document: the view is told and the street moved.
    c.replace(&u, 2, &text).await;
    c.wait_for(|r| {
        r.method() == "grm/layoutUpdated" && r.params().is_some_and(|p| p["version"] == 2)
    })
    .await;
    let r2 = c.ok("grm/layout", json!({ "uri": u })).await;
    assert_eq!(r2["version"], 2);
    assert_eq!(r2["invalid"], json!([]));
    let moved = street(&r2, &s["id"]).expect("the same street");
    let shifted: Vec<Value> = before
        .as_array()
        .unwrap()
        .iter()
        .map(|p| json!([p[0].as_f64().unwrap() + 3.0, p[1].as_f64().unwrap() + 2.0]))
        .collect();
    assert_eq!(moved["points"], json!(shifted));
}

#[tokio::test]
async fn a_rejected_move_is_reported_with_its_code_and_nothing_is_written() {
    let (_dir, p) = city();
    let mut c = Editor::start().await;
    let u = c.open(&p, CITY, 1).await;
    let r = c.ok("grm/layout", json!({ "uri": u })).await;
    let s = layout::base_street(&r);
    // Two rows up: the street's neighbours would cross the grid.
    let res = c
        .ok(
            "grm/layoutEdit",
            json!({ "uri": u, "layer": 0,
                    "op": { "move": { "select": { "ids": [s["layerId"]] }, "translate": [0, 130] } } }),
        )
        .await;
    assert_eq!(res["applied"], false, "{res}");
    assert_eq!(res["rejected"]["code"], "R1013", "{res}");
    assert!(res.get("edit").is_none());
    // Bad operators are the file's problems, with their codes.
    let bad = c
        .request(
            "grm/layoutEdit",
            json!({ "uri": u, "layer": 0,
                    "op": { "move": { "select": { "ids": ["xyz"] }, "translate": [1, 0] } } }),
        )
        .await
        .expect_err("a bad identity");
    assert!(bad["message"].as_str().unwrap().contains("R1025"), "{bad}");
    let none = c
        .request(
            "grm/layoutEdit",
            json!({ "uri": u, "layer": 5, "op": { "visible": false } }),
        )
        .await
        .expect_err("no layer 5");
    assert!(none["message"].as_str().unwrap().contains("no layer 5"));
    assert_eq!(std::fs::read_to_string(&p).unwrap(), CITY);
}

#[tokio::test]
async fn a_client_that_cannot_apply_edits_gets_the_file_written_and_layers_toggle() {
    let (_dir, p) = city();
    // No workspace.applyEdit (as grmc view), the sidecar open as grmc opens it.
    let mut c = Client::start().await;
    let u = uri(&p);
    c.notify(
        "textDocument/didOpen",
        json!({ "textDocument": { "uri": u, "languageId": "json", "version": 1, "text": CITY } }),
    )
    .await;
    let r = c.ok("grm/layout", json!({ "uri": u })).await;
    let avenue: Vec<Value> = r["streets"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|s| s["layer"] == 1)
        .cloned()
        .collect();
    assert!(!avenue.is_empty());

    // Hide the avenue's layer: its streets leave the merged layout.
    let res = c
        .ok(
            "grm/layoutEdit",
            json!({ "uri": u, "layer": 1, "op": { "visible": false } }),
        )
        .await;
    assert_eq!(
        (res["applied"].clone(), res["written"].clone()),
        (json!(true), json!(true))
    );
    let (d, _) = grm_layout::sidecar::read(&std::fs::read_to_string(&p).unwrap());
    assert!(!d.layers[1].visible);
    let hidden = c.ok("grm/layout", json!({ "uri": u })).await;
    assert!(!hidden["layers"][1]["visible"].as_bool().unwrap());
    for s in &avenue {
        assert!(street(&hidden, &s["id"]).is_none(), "{} hidden", s["id"]);
    }
    assert!(
        hidden["streets"]
            .as_array()
            .unwrap()
            .iter()
            .all(|s| s["layer"] == 0),
        "only the base is left"
    );
    // And shown again: the same layout as at first.
    c.ok(
        "grm/layoutEdit",
        json!({ "uri": u, "layer": 1, "op": { "visible": true } }),
    )
    .await;
    let shown = c.ok("grm/layout", json!({ "uri": u })).await;
    assert_eq!(shown["streets"], r["streets"]);
    assert_eq!(shown["parcels"], r["parcels"]);

    // Protect a street, cut it to a new layer, anchor an assignment to it.
    let s = layout::base_street(&r);
    c.ok(
        "grm/layoutEdit",
        json!({ "uri": u, "layer": 0, "op": { "protect": { "ids": [s["layerId"]] } } }),
    )
    .await;
    let pr = c.ok("grm/layout", json!({ "uri": u })).await;
    assert_eq!(street(&pr, &s["id"]).unwrap()["protected"], true);
    assert_eq!(pr["layers"][0]["protected"], json!([s["layerId"]]));
    let cut = c
        .ok(
            "grm/layoutEdit",
            json!({ "uri": u, "layer": 0, "op": { "cut": { "ids": [s["layerId"]], "name": "lifted" } } }),
        )
        .await;
    assert_eq!(cut["newLayer"], 1);
    let after = c.ok("grm/layout", json!({ "uri": u })).await;
    assert_eq!(after["layers"][1]["name"], "lifted");
    let lifted = street(&after, &s["id"]).expect("kept above");
    assert_eq!(lifted["layer"], 1, "the street is now the new layer's");
    assert_eq!(lifted["protected"], true, "its protection went with it");
    assert_eq!(after["layers"][0]["protected"], json!([]));
    let a = c
        .ok(
            "grm/layoutEdit",
            json!({ "uri": u, "layer": 1, "op": { "assign": {
                "tags": { "height": 40 }, "kinds": ["parcel"], "radius": 50,
                "at": [40, 30], "anchor": s["id"] } } }),
        )
        .await;
    assert_eq!(a["applied"], true);
    let (d, errs) = grm_layout::sidecar::read(&std::fs::read_to_string(&p).unwrap());
    assert!(errs.is_empty(), "{errs:?}");
    let anchor = d.layers[1].assignments[0]
        .anchor
        .as_ref()
        .expect("anchored");
    assert_eq!(anchor.element.to_string(), s["id"].as_str().unwrap());
    let last = c.ok("grm/layout", json!({ "uri": u })).await;
    assert_eq!(last["problems"], json!([]), "{}", last["problems"]);
    assert_eq!(last["invalid"], json!([]));
    // Layers taken from the server's cache give what a fresh server builds.
    let mut fresh = Client::start().await;
    let f = fresh.ok("grm/layout", json!({ "uri": u })).await;
    for k in ["layers", "streets", "parcels", "problems"] {
        assert_eq!(f[k], last[k], "{k}");
    }
}

#[tokio::test]
async fn only_layout_files_are_answered() {
    let (dir, _) = city();
    let mut c = Client::start().await;
    let other = dir.path().join("city.json");
    let e = c
        .request("grm/layout", json!({ "uri": uri(&other) }))
        .await
        .expect_err("not a layout file");
    assert!(e["message"].as_str().unwrap().contains("not a layout file"));
}

#[tokio::test]
async fn the_city_grows_on_the_parcels_and_a_move_regrows_only_what_changed() {
    let (_dir, p) = city();
    let root = p.parent().unwrap().to_path_buf();
    std::fs::copy(
        common::root().join("examples/city_building.grm"),
        root.join("city_building.grm"),
    )
    .expect("copy the building grammar");
    let text = CITY.replacen(
        "\"version\": 1,",
        "\"version\": 1,\n  \"buildings\": {\"grammar\": \"city_building.grm\"},",
        1,
    );
    std::fs::write(&p, &text).unwrap();
    let mut c = Client::start().await;
    let u = uri(&p);
    let first = c.ok("grm/layoutCity", json!({ "uri": u })).await;
    assert_eq!(first["problems"], json!([]), "{}", first["problems"]);
    let parcels = first["parcels"].as_u64().unwrap();
    assert!(parcels > 10);
    assert_eq!(
        first["buildings"].as_u64().unwrap(),
        parcels,
        "a building on every parcel"
    );
    assert_eq!(first["reused"], 0);
    assert!(first["triangles"].as_u64().unwrap() > 1000);
    // The model as the preview's mesh buffers (base64 here: no blob sink).
    assert_eq!(first["encoding"], "base64-le");
    let parts = first["parts"].as_array().unwrap();
    assert!(!parts.is_empty());
    let triangles: u64 = parts
        .iter()
        .map(|p| p["triangleCount"].as_u64().unwrap())
        .sum();
    assert_eq!(triangles, first["triangles"].as_u64().unwrap());
    assert!(
        first["boundsMax"][1].as_f64().unwrap() > 3.0,
        "buildings stand up"
    );

    // A street moved: most buildings come from the cache.
    let r = c.ok("grm/layout", json!({ "uri": u })).await;
    let s = layout::base_street(&r);
    let res = c
        .ok(
            "grm/layoutEdit",
            json!({ "uri": u, "layer": 0,
                    "op": { "move": { "select": { "ids": [s["layerId"]] }, "translate": [2, 1] } } }),
        )
        .await;
    assert_eq!(res["written"], true);
    let again = c.ok("grm/layoutCity", json!({ "uri": u })).await;
    let (built, reused) = (
        again["buildings"].as_u64().unwrap(),
        again["reused"].as_u64().unwrap(),
    );
    assert!(reused > 0 && reused < built, "{reused} of {built} kept");
    assert!(
        built - reused < built / 2,
        "only the parcels near the move grew: {reused} of {built} kept"
    );
}

/// A city of one rotated and moved layer (`place`).
const PLACED: &str = r#"{
  "version": 1,
  "layers": [
    {"name": "base", "seed": 7, "place": {"translate": [500, 20], "rotate": 90, "about": [0, 0]},
     "source": {"grid": {"origin": [0, 0], "size": [4, 3], "spacing": [80, 60], "seed": 11}}}
  ]
}
"#;

fn points(s: &Value) -> Vec<(f64, f64)> {
    s["points"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| (p[0].as_f64().unwrap(), p[1].as_f64().unwrap()))
        .collect()
}

fn close(a: &[(f64, f64)], b: &[(f64, f64)]) -> bool {
    a.len() == b.len()
        && a.iter()
            .zip(b)
            .all(|(p, q)| (p.0 - q.0).abs() < 1e-3 && (p.1 - q.1).abs() < 1e-3)
}

#[tokio::test]
async fn moves_are_given_in_the_merged_coordinates_of_a_placed_layer() {
    let (_dir, p) = city();
    std::fs::write(&p, PLACED).unwrap();
    let mut c = Client::start().await;
    let u = uri(&p);
    let r = c.ok("grm/layout", json!({ "uri": u })).await;
    assert_eq!(r["problems"], json!([]), "{}", r["problems"]);
    // A street of the rotated grid, moved 3 m along the merged x axis.
    let s = r["streets"].as_array().unwrap()[0].clone();
    let before = points(&s);
    c.ok(
        "grm/layoutEdit",
        json!({ "uri": u, "layer": 0,
                "op": { "move": { "select": { "ids": [s["layerId"]] }, "translate": [3, 0] } } }),
    )
    .await;
    let (d, _) = grm_layout::sidecar::read(&std::fs::read_to_string(&p).unwrap());
    let t = d.layers[0].moves[0].translate;
    assert!(
        t.x.abs() < 1e-9 && (t.y + 3.0).abs() < 1e-9,
        "in the layer's own frame (turned 90 degrees back): {t:?}"
    );
    let r2 = c.ok("grm/layout", json!({ "uri": u })).await;
    let after = points(street(&r2, &s["id"]).expect("the same street"));
    let want: Vec<(f64, f64)> = before.iter().map(|(x, y)| (x + 3.0, *y)).collect();
    assert!(close(&after, &want), "{after:?} against {want:?}");

    // A soft selection around the grid's first crossing, and a region
    // around all of it: written as given, in the layer's frame.
    c.ok(
        "grm/layoutEdit",
        json!({ "uri": u, "layer": 0,
                "op": { "move": { "select": { "soft": { "centre": [500, 20], "radius": 30 } }, "translate": [0, 1] } } }),
    )
    .await;
    c.ok(
        "grm/layoutEdit",
        json!({ "uri": u, "layer": 0,
                "op": { "move": { "select": { "region": [[0, -100], [600, -100], [600, 400], [0, 400]] }, "translate": [-2, 0] } } }),
    )
    .await;
    let (d, errs) = grm_layout::sidecar::read(&std::fs::read_to_string(&p).unwrap());
    assert!(errs.is_empty());
    let m = &d.layers[0].moves;
    assert_eq!(m.len(), 3);
    match &m[1].select {
        Select::Soft { centre, radius } => {
            assert!(centre.x.abs() < 1e-9 && centre.y.abs() < 1e-9, "{centre:?}");
            assert_eq!(*radius, 30.0);
        }
        other => panic!("{other:?}"),
    }
    assert!(matches!(&m[2].select, Select::Region(r) if r.len() == 4));
    let r3 = c.ok("grm/layout", json!({ "uri": u })).await;
    assert_eq!(r3["problems"], json!([]), "{}", r3["problems"]);
    assert_eq!(r3["invalid"], json!([]));
    // The region held the whole layer: every street moved 2 m to -x.
    let whole = street(&r3, &s["id"]).expect("the same street");
    assert!((points(whole)[0].0 - (after[0].0 - 2.0)).abs() < 1.5);
}

//! `grmc layout` (issue 29): the example city merged from its sidecar's
//! layers into GeoJSON and SVG, byte-identical on a second run; a layer
//! naming a missing file and a bad sidecar entry are reported with their
//! codes (exit 1) while the other layers still merge; the city with its
//! buildings as a glb (the same twice) and a picture, the plan alone with
//! `--no-buildings`; a parcel without a building is R1031 (exit 1), a
//! missing grammar exit 2; building edits beside the layout apply to
//! their parcels, one whose parcel is gone is R1032.

mod common;

use common::*;

fn path(p: &std::path::Path) -> &str {
    p.to_str().expect("utf-8")
}

#[test]
fn the_example_city_writes_the_same_geojson_twice_and_an_svg() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (a, b, svg) = (
        dir.path().join("a.geojson"),
        dir.path().join("b.geojson"),
        dir.path().join("city.svg"),
    );
    let city = example("city.layout.json");
    for out in [&a, &b] {
        let o = grmc(&["layout", &city, "-o", path(out), "--blocks"]);
        assert!(o.status.success(), "{}", text(&o.stderr));
        assert!(text(&o.stdout).contains("4 layers:"), "{}", text(&o.stdout));
    }
    let (ga, gb) = (std::fs::read(&a).expect("a"), std::fs::read(&b).expect("b"));
    assert_eq!(ga, gb);
    let v: serde_json::Value = serde_json::from_slice(&ga).expect("GeoJSON");
    let kinds = |k: &str| {
        v["features"]
            .as_array()
            .expect("features")
            .iter()
            .filter(|f| f["properties"]["kind"] == k)
            .count()
    };
    assert!(kinds("street") > 100 && kinds("parcel") > 100 && kinds("block") > 50);
    // The park from the GeoJSON layer, a free parcel, is there with its tags.
    assert!(
        v["features"]
            .as_array()
            .unwrap()
            .iter()
            .any(|f| f["properties"]["use"] == "park")
    );
    let o = grmc(&["layout", &city, "-o", path(&svg)]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let s = std::fs::read_to_string(&svg).expect("svg");
    assert!(s.starts_with("<svg ") && s.ends_with("</svg>\n") && s.contains("<path id=\"s"));
}

#[test]
fn problems_are_reported_and_the_rest_still_merges() {
    let dir = tempfile::tempdir().expect("tempdir");
    let side = dir.path().join("town.layout.json");
    std::fs::write(
        &side,
        r#"{"layers": [
          {"name": "base", "source": {"grid": {"size": [3, 3]}}},
          {"name": "lake", "source": {"geojson": "lake.geojson"}},
          {"name": "bad", "source": {"grid": {"size": [0, 3]}}},
          {"name": "moves", "source": "empty", "moves": [{"select": {"ids": ["xyz"]}, "translate": [1, 1]}]}
        ]}"#,
    )
    .expect("write");
    let out = dir.path().join("town.geojson");
    let o = grmc(&["layout", path(&side), "-o", path(&out)]);
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("error[R1025]") && err.contains("$.layers[3].moves[0].select.ids[0]"),
        "{err}"
    );
    assert!(
        err.contains("error[R1022]") && err.contains("$.layers[2].source.grid.size"),
        "{err}"
    );
    assert!(
        err.contains("error[R1012]: layer `lake`: cannot read `lake.geojson`"),
        "{err}"
    );
    let v: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&out).expect("written")).expect("json");
    assert_eq!(
        v["features"]
            .as_array()
            .expect("features")
            .iter()
            .filter(|f| f["properties"]["kind"] == "street")
            .count(),
        24
    );
    // No such format, no such sidecar: usage errors.
    assert_eq!(
        grmc(&["layout", path(&side), "-o", "x.dxf"]).status.code(),
        Some(2)
    );
    assert_eq!(
        grmc(&["layout", "no/such.layout.json"]).status.code(),
        Some(2)
    );
}

/// The glTF JSON chunk of a glb file.
fn glb_json(bytes: &[u8]) -> serde_json::Value {
    assert_eq!(&bytes[..4], b"glTF");
    let len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    serde_json::from_slice(&bytes[20..20 + len]).expect("the JSON chunk")
}

#[test]
fn the_example_city_grows_its_buildings_into_a_glb_and_a_picture() {
    let dir = tempfile::tempdir().expect("tempdir");
    let city = example("city.layout.json");
    let (a, b, plan, png) = (
        dir.path().join("a.glb"),
        dir.path().join("b.glb"),
        dir.path().join("plan.glb"),
        dir.path().join("city.png"),
    );
    for out in [&a, &b] {
        let o = grmc(&["layout", &city, "-o", path(out)]);
        assert!(o.status.success(), "{}", text(&o.stderr));
        let s = text(&o.stdout);
        // Every parcel but the park grows a building.
        assert!(s.contains("195 buildings on 196 parcels"), "{s}");
        assert!(text(&o.stderr).contains("buildings: 196/196"));
    }
    let bytes = std::fs::read(&a).expect("a");
    assert_eq!(bytes, std::fs::read(&b).expect("b"));
    let v = glb_json(&bytes);
    let names: Vec<&str> = v["nodes"]
        .as_array()
        .expect("nodes")
        .iter()
        .filter_map(|n| n["name"].as_str())
        .collect();
    assert_eq!(
        names.iter().filter(|n| n.starts_with("parcel.")).count(),
        196
    );
    assert!(names.iter().filter(|n| n.starts_with("street.")).count() > 200);
    let materials: Vec<&str> = v["materials"]
        .as_array()
        .expect("materials")
        .iter()
        .filter_map(|m| m["name"].as_str())
        .collect();
    assert!(materials.contains(&"glass") && materials.contains(&"layout.street"));
    // The plan alone is a fraction of it.
    let o = grmc(&["layout", &city, "--no-buildings", "-o", path(&plan)]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(!text(&o.stdout).contains("buildings on"));
    assert!(std::fs::metadata(&plan).unwrap().len() * 10 < bytes.len() as u64);
    let o = grmc(&["layout", &city, "-o", path(&png)]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert_eq!(
        &std::fs::read(&png).expect("png")[..8],
        b"\x89PNG\r\n\x1a\n"
    );
}

#[test]
fn a_parcel_without_a_building_is_reported_and_a_missing_grammar_is_exit_2() {
    let dir = tempfile::tempdir().expect("tempdir");
    let grammar = std::fs::read_to_string(example("city_building.grm")).expect("grammar");
    std::fs::write(dir.path().join("house.grm"), grammar).expect("write");
    let side = dir.path().join("town.layout.json");
    let out = dir.path().join("town.glb");
    let write = |buildings: &str| {
        std::fs::write(
            &side,
            format!(
                r#"{{"buildings": {buildings}, "layers": [
                  {{"name": "base", "source": {{"grid": {{"size": [3, 3]}}}},
                   "assignments": [{{"tags": {{"height": 900}}, "kinds": ["parcel"], "at": [0, 0]}}]}}
                ]}}"#
            ),
        )
        .expect("write")
    };
    // One parcel (the nearest to the origin) gets a height past the
    // grammar's range: R1031 naming it, exit 1, the rest grown and written.
    write(r#"{"grammar": "house.grm"}"#);
    let o = grmc(&["layout", path(&side), "-o", path(&out)]);
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("error[R1031]: parcel ") && err.contains("outside its range 0 .. 300"),
        "{err}"
    );
    assert!(text(&o.stdout).contains("wrote "), "{}", text(&o.stdout));
    assert!(out.exists());
    // A grammar that is not there: exit 2, nothing written.
    std::fs::remove_file(&out).expect("rm");
    write(r#"{"grammar": "nowhere.grm"}"#);
    let o = grmc(&["layout", path(&side), "-o", path(&out)]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o.stderr));
    assert!(!out.exists());
    // --no-buildings needs no grammar.
    let o = grmc(&["layout", path(&side), "--no-buildings", "-o", path(&out)]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
}

/// `grmc layout FILE.grm`: the grammar's `layout` item (an L-system's
/// streets, a grid, a GeoJSON park; buildings from an imported shape
/// system) with the artist's sidecar beside it; the same bytes twice; a
/// grammar without a layout item is exit 2.
#[test]
fn a_grammar_with_a_layout_item_lays_out_and_grows_the_city() {
    let dir = tempfile::tempdir().expect("tempdir");
    for f in ["city.grm", "city_building.grm", "city_park.geojson"] {
        std::fs::copy(example(f), dir.path().join(f)).expect("copy");
    }
    let grm = dir.path().join("city.grm");
    let plan = dir.path().join("plan.geojson");
    let o = grmc(&["layout", path(&grm), "-o", path(&plan)]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    // Without the sidecar: the item's three layers.
    assert!(
        text(&o.stdout).starts_with("3 layers: "),
        "{}",
        text(&o.stdout)
    );
    let first = std::fs::read(&plan).expect("plan");
    // The avenue's streets are there: the plan without it has fewer.
    let no_avenue = std::fs::read_to_string(&grm)
        .expect("grm")
        .replace("avenue = lsystem(Avenues);", "");
    std::fs::write(dir.path().join("bare.grm"), no_avenue).expect("write");
    let bare = dir.path().join("bare.geojson");
    let o = grmc(&[
        "layout",
        path(&dir.path().join("bare.grm")),
        "-o",
        path(&bare),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let streets = |b: &[u8]| {
        let v: serde_json::Value = serde_json::from_slice(b).expect("json");
        v["features"]
            .as_array()
            .expect("features")
            .iter()
            .filter(|f| f["properties"]["kind"] == "street")
            .count()
    };
    assert!(
        streets(&first) > streets(&std::fs::read(&bare).expect("bare")),
        "the L-system's streets are in the plan"
    );
    // With the sidecar beside it, its layers add the artist's edits and
    // its hand-edited layer.
    std::fs::copy(
        example("city.layout.json"),
        dir.path().join("city.layout.json"),
    )
    .expect("copy");
    let glb = dir.path().join("city.glb");
    let o = grmc(&["layout", path(&grm), "-o", path(&glb)]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(
        text(&o.stdout).starts_with("4 layers: "),
        "{}",
        text(&o.stdout)
    );
    assert!(
        text(&o.stdout).contains(" buildings on "),
        "{}",
        text(&o.stdout)
    );
    let again = dir.path().join("again.glb");
    let o = grmc(&["layout", path(&grm), "-o", path(&again)]);
    assert!(o.status.success());
    assert_eq!(std::fs::read(&glb).unwrap(), std::fs::read(&again).unwrap());
    // No layout item: exit 2.
    let o = grmc(&[
        "layout",
        path(&dir.path().join("city_building.grm")),
        "-o",
        path(&plan),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o.stderr));
    assert!(
        text(&o.stderr).contains("has no `layout NAME"),
        "{}",
        text(&o.stderr)
    );
}

/// Building edits (docs/layout.md, "Building edits"): `NAME.edits.json`
/// beside the layout; an edit on a parcel of the layout is replayed in
/// its building (the glb changes), one on a parcel the layout does not
/// have is R1032 (exit 1) and changes nothing else; a bad edit is its
/// R09xx code.
#[test]
fn building_edits_beside_the_layout_apply_to_their_parcel_and_the_rest_are_reported() {
    let dir = tempfile::tempdir().expect("tempdir");
    let grammar = std::fs::read_to_string(example("city_building.grm")).expect("grammar");
    std::fs::write(dir.path().join("house.grm"), grammar).expect("write");
    let side = dir.path().join("town.layout.json");
    std::fs::write(
        &side,
        r#"{"buildings": {"grammar": "house.grm"}, "layers": [
          {"name": "base", "source": {"grid": {"size": [3, 3]}}}]}"#,
    )
    .expect("write");
    let plan = dir.path().join("town.geojson");
    let o = grmc(&["layout", path(&side), "-o", path(&plan)]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let v: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&plan).expect("plan")).expect("GeoJSON");
    let parcel = v["features"]
        .as_array()
        .expect("features")
        .iter()
        .find(|f| f["properties"]["kind"] == "parcel")
        .and_then(|f| f["id"].as_str())
        .expect("a parcel")
        .to_string();
    let glb = |name: &str| -> (std::process::Output, Vec<u8>) {
        let out = dir.path().join(name);
        let o = grmc(&["layout", path(&side), "-o", path(&out)]);
        let bytes = std::fs::read(&out).unwrap_or_default();
        (o, bytes)
    };
    let (o, plain) = glb("plain.glb");
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let edit = |id: u32, parcel: &str| {
        format!(
            r#"{{"id": {id}, "system": "Building", "parcel": "{parcel}",
               "target": {{"semantic": "(floor = 1) Floor"}}, "op": "remove"}}"#
        )
    };
    let edits = dir.path().join("town.edits.json");
    std::fs::write(
        &edits,
        format!(
            r#"{{"version": 1, "edits": [{}, {}]}}"#,
            edit(1, &parcel),
            edit(2, "00000000000000ff")
        ),
    )
    .expect("write");
    let (o, edited) = glb("edited.glb");
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("town.edits.json: error[R1032]: edit 2: parcel 00000000000000ff"),
        "{err}"
    );
    assert!(!err.contains("edit 1"), "{err}");
    assert!(
        text(&o.stdout).contains("1 buildings with building edits"),
        "{}",
        text(&o.stdout)
    );
    assert!(!edited.is_empty() && edited != plain);
    // The edit alone: exit 0, the same city as with the unplaced one.
    std::fs::write(
        &edits,
        format!(r#"{{"version": 1, "edits": [{}]}}"#, edit(1, &parcel)),
    )
    .expect("write");
    let (o, alone) = glb("alone.glb");
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    assert_eq!(alone, edited);
    // A parcel that is not 16 hex digits: R0911, the edit skipped.
    std::fs::write(
        &edits,
        format!(r#"{{"version": 1, "edits": [{}]}}"#, edit(1, "12")),
    )
    .expect("write");
    let (o, skipped) = glb("skipped.glb");
    assert_eq!(o.status.code(), Some(1), "{}", text(&o.stderr));
    assert!(
        text(&o.stderr).contains("error[R0911]"),
        "{}",
        text(&o.stderr)
    );
    assert_eq!(skipped, plain);
}

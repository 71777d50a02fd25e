//! `grmc layout` (issue 29): the example city merged from its sidecar's
//! layers into GeoJSON and SVG, byte-identical on a second run; a layer
//! naming a missing file and a bad sidecar entry are reported with their
//! codes (exit 1) while the other layers still merge.

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
        err.contains("error[S005]") && err.contains("$.layers[3].moves[0].select.ids[0]"),
        "{err}"
    );
    assert!(
        err.contains("error[S002]") && err.contains("$.layers[2].source.grid.size"),
        "{err}"
    );
    assert!(
        err.contains("layer `lake`: cannot read `lake.geojson`"),
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
        grmc(&["layout", path(&side), "-o", "x.png"]).status.code(),
        Some(2)
    );
    assert_eq!(
        grmc(&["layout", "no/such.layout.json"]).status.code(),
        Some(2)
    );
}

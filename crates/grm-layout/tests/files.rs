//! Files: GeoJSON input with bad elements (coded errors naming the
//! element, the rest loads), a layer naming a missing file (reported, the
//! other layers still merge), and the sidecar (tolerant typed reading,
//! canonical writing).

use grm_layout::geojson_io::{self, LoadErrorKind};
use grm_layout::layers::{LayerIssue, Source};
use grm_layout::merge::MergeMode;
use grm_layout::sidecar::{self, SidecarErrorKind};
use grm_layout::validity::check;

const BAD: &str = r#"{
  "type": "FeatureCollection",
  "features": [
    {"type": "Feature", "id": "main", "properties": {"class": "major", "name": "Main St"},
     "geometry": {"type": "LineString", "coordinates": [[0, 0], [100, 0], [200, 0]]}},
    {"type": "Feature", "id": "side", "properties": {},
     "geometry": {"type": "LineString", "coordinates": [[100, 0], [100, 100]]}},
    {"type": "Feature", "id": "stub", "properties": {},
     "geometry": {"type": "LineString", "coordinates": [[50, 50], [50, 50]]}},
    {"type": "Feature", "id": "bowtie", "properties": {},
     "geometry": {"type": "Polygon", "coordinates": [[[10, 10], [40, 40], [40, 10], [10, 30], [10, 10]]]}},
    {"type": "Feature", "id": "open", "properties": {},
     "geometry": {"type": "Polygon", "coordinates": [[[120, 10], [160, 10], [160, 40], [120, 40]]]}},
    {"type": "Feature", "id": "lot", "properties": {"height": 12},
     "geometry": {"type": "Polygon", "coordinates": [[[120, 10], [160, 10], [160, 40], [120, 40], [120, 10]]]}},
    {"type": "Feature", "id": "on-street", "properties": {},
     "geometry": {"type": "Polygon", "coordinates": [[[20, -2], [40, -2], [40, 20], [20, 20], [20, -2]]]}},
    {"type": "Feature", "id": "crossing", "properties": {},
     "geometry": {"type": "LineString", "coordinates": [[150, -50], [150, 50]]}},
    {"type": "Feature", "id": "wide", "properties": {"width": "wide"},
     "geometry": {"type": "LineString", "coordinates": [[0, 0], [0, -100]]}},
    {"type": "Feature", "id": "far", "properties": {},
     "geometry": {"type": "LineString", "coordinates": [[0, 0], [1e12, 0]]}},
    {"type": "Feature", "id": "dot", "properties": {},
     "geometry": {"type": "Point", "coordinates": [5, 5]}}
  ]
}"#;

#[test]
fn bad_elements_are_coded_and_named_and_the_rest_loads() {
    let r = geojson_io::read(BAD, "bad.geojson");
    let got: Vec<(String, &str)> = r
        .errors
        .iter()
        .map(|e| (e.element.clone(), e.kind.code()))
        .collect();
    let has = |name: &str, kind: LoadErrorKind| {
        r.errors
            .iter()
            .any(|e| e.element.contains(name) && e.kind == kind)
    };
    assert!(has("stub", LoadErrorKind::DegenerateStreet), "{got:?}");
    assert!(has("bowtie", LoadErrorKind::BadPolygon), "{got:?}");
    assert!(has("open", LoadErrorKind::OpenPolygon), "{got:?}");
    assert!(has("wide", LoadErrorKind::BadProperty), "{got:?}");
    assert!(has("dot", LoadErrorKind::UnsupportedGeometry), "{got:?}");
    assert!(has("far", LoadErrorKind::NotFinite), "{got:?}");
    // The parcel on the street and the street across another are dropped as conflicts.
    assert_eq!(
        r.errors
            .iter()
            .filter(|e| e.kind == LoadErrorKind::Conflict)
            .count(),
        2,
        "{got:?}"
    );
    // What loaded: main (cut in two where side starts at its vertex), side,
    // and the lot with its tag.
    assert_eq!(r.layout.streets.len(), 3, "{got:?}");
    assert_eq!(r.layout.nodes.len(), 4);
    assert_eq!(r.layout.parcels.len(), 1);
    let lot = r.layout.parcels.values().next().unwrap();
    assert_eq!(
        lot.tags.get("height"),
        Some(&grm_layout::model::TagValue::Num(12.0))
    );
    assert!(check(&r.layout).is_empty());
    // Codes are distinct and stable.
    assert_eq!(LoadErrorKind::OpenPolygon.code(), "R1005");
    let display = r.errors[0].to_string();
    assert!(display.starts_with("R10"), "{display}");
}

#[test]
fn text_that_is_not_geojson_is_one_error() {
    let r = geojson_io::read("{ not json", "x.geojson");
    assert_eq!(r.errors.len(), 1);
    assert_eq!(r.errors[0].kind, LoadErrorKind::NotGeoJson);
    assert_eq!(r.errors[0].element, "x.geojson");
}

const SIDECAR: &str = r#"{
  "version": 1,
  "layers": [
    {"name": "base", "seed": 4, "source": {"grid": {"size": [4, 3], "spacing": [80, 60], "seed": 9}}},
    {"name": "park", "merge": "graph_cut", "source": {"geojson": "missing.geojson"}},
    {"name": "centre", "merge": "hard",
     "source": {"radial": {"centre": [160, 90], "rings": 1, "ring_spacing": 45, "spokes": 6, "seed": 2}},
     "place": {"translate": [12, -4]},
     "moves": [
       {"select": {"soft": {"centre": [160, 90], "radius": 30}}, "translate": [3, 1]},
       {"select": {"continuation": {"street": "0123456789abcdef", "max_turn": 25}}, "rotate": 7.3, "scale": 1.05, "about": [160.5, 90.25], "translate": [0.1, -0.2]},
       {"select": {"ids": ["not-an-id"]}, "translate": [1, 1]},
       {"select": {"region": [[0, 0], [1, 0], [0, 1]]}, "translate": ["a", 1]}
     ],
     "assignments": [
       {"tags": {"height": 30, "style": "glass"}, "kinds": ["parcel"], "radius": 60, "falloff": "linear", "at": [160, 90]},
       {"tags": {"height": [1]}, "at": [0, 0]}
     ],
     "colour": "red"
    },
    {"merge": "hard"}
  ]
}"#;

#[test]
fn the_sidecar_is_read_tolerantly_with_typed_errors() {
    let (doc, errs) = sidecar::read(SIDECAR);
    let kinds: Vec<(String, &str)> = errs
        .iter()
        .map(|e| (e.path.clone(), e.kind.code()))
        .collect();
    let at =
        |path: &str, kind: SidecarErrorKind| errs.iter().any(|e| e.path == path && e.kind == kind);
    assert!(
        at(
            "$.layers[2].moves[2].select.ids[0]",
            SidecarErrorKind::BadId
        ),
        "{kinds:?}"
    );
    assert!(
        at(
            "$.layers[2].moves[3].translate[0]",
            SidecarErrorKind::BadValue
        ),
        "{kinds:?}"
    );
    assert!(
        at(
            "$.layers[2].assignments[1].tags.height",
            SidecarErrorKind::BadValue
        ),
        "{kinds:?}"
    );
    assert!(
        at("$.layers[2].colour", SidecarErrorKind::UnknownKey),
        "{kinds:?}"
    );
    assert!(
        at("$.layers[3].name", SidecarErrorKind::Missing),
        "{kinds:?}"
    );
    assert_eq!(errs.len(), 5, "{kinds:?}");
    // Three layers kept, with what was good in them.
    assert_eq!(doc.layers.len(), 3);
    assert_eq!(doc.layers[1].merge, MergeMode::GraphCut);
    assert_eq!(doc.layers[2].moves.len(), 2);
    let mv = &doc.layers[2].moves[1];
    assert_eq!((mv.rotate_deg, mv.scale, mv.about.x), (7.3, 1.05, 160.5));
    assert_eq!(doc.layers[2].assignments.len(), 1);
    assert!(matches!(doc.layers[1].source, Source::GeoJson(ref p) if p == "missing.geojson"));
    // The missing file is reported; the other layers still merge.
    let load = |p: &str| -> Result<String, String> { Err(format!("{p}: no such file")) };
    let ev = doc.evaluate(&load);
    assert!(
        ev.issues
            .iter()
            .any(|i| matches!(i, LayerIssue::MissingFile { layer, .. } if layer == "park")),
        "{:?}",
        ev.issues
    );
    assert!(ev.merged.streets.len() > 20);
    assert!(check(&ev.merged).is_empty());
    // The assignment reached the centre's parcels, scaled by the falloff.
    let tagged = ev
        .merged
        .parcels
        .values()
        .filter(|p| p.tags.contains_key("style"))
        .count();
    assert!(tagged > 0);
}

#[test]
fn the_sidecar_is_written_canonically() {
    let (doc, _) = sidecar::read(SIDECAR);
    let text = sidecar::write(&doc);
    let (again, errs) = sidecar::read(&text);
    assert!(errs.is_empty(), "{errs:?}");
    assert_eq!(again, doc);
    assert_eq!(sidecar::write(&again), text);
    assert!(text.ends_with("}\n"));
    let (_, errs) = sidecar::read("{\"layers\": [}");
    assert_eq!(errs[0].kind, SidecarErrorKind::Syntax);
    let (_, errs) = sidecar::read("{\"version\": 9}");
    assert_eq!(errs[0].kind, SidecarErrorKind::Version);
    // Knobs that would ask for unbounded work are refused.
    for bad in [
        r#"{"parcels": {"max_area": 0.5}}"#,
        r#"{"parcels": {"max_depth": 40}}"#,
    ] {
        let (doc, errs) = sidecar::read(bad);
        assert_eq!(errs.len(), 1, "{bad}: {errs:?}");
        assert_eq!(
            (errs[0].kind.clone(), errs[0].path.as_str()),
            (SidecarErrorKind::BadValue, "$.parcels")
        );
        assert_eq!(doc.parcels, grm_layout::subdivide::ParcelParams::default());
    }
}

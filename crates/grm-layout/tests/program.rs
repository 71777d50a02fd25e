//! A `.grm` file's `layout` item made into a document (`program`): the
//! layers in the item's order with their sources, an L-system's turtle
//! path as streets (connected where segments meet), the sidecar's edits
//! on the layers of the same name and its other layers on top, and the
//! buildings' system.

use grm_layout::layers::{Document, LayerSpec, Source};
use grm_layout::merge::MergeMode;
use grm_layout::program::{document, lsystem_streets};
use grm_layout::{geojson_io, validity};

const GRM: &str = r#"
system Avenue {
    iterations = 3;
    angle = 90;
    step = 50;
    axiom A;
    A -> F [ + F ] A;
}
system House {
    mode = shape;
    axiom Lot;
    Lot -> extrude(10) Mass;
}
layout Town {
    base = grid(4, 3, 80, 60, 7);
    avenue = lsystem(Avenue);
    sketch = edited();
    buildings = House;
    seed = 5;
}
"#;

fn checked() -> grm_sema::Checked {
    let (_, c) = grm_sema::check_text("town.grm", GRM);
    assert!(!c.has_errors(), "{:?}", c.diagnostics);
    c
}

#[test]
fn an_lsystems_turtle_path_becomes_connected_streets() {
    let c = checked();
    let values = grm_compile::param_values(&c.program, &[]).expect("defaults");
    let text = lsystem_streets(&c.program, 0, &values).expect("grows");
    let r = geojson_io::read(&text, "avenue");
    assert!(r.errors.is_empty(), "{:?}", r.errors);
    // Three runs of 50 m and three branches: six streets; the runs share
    // their joints, so 3 + 1 nodes along the run and a node per branch tip.
    assert_eq!(r.layout.streets.len(), 6);
    assert_eq!(r.layout.nodes.len(), 7);
    assert!(validity::check(&r.layout).is_empty());
    // Deterministic.
    assert_eq!(text, lsystem_streets(&c.program, 0, &values).unwrap());
}

#[test]
fn the_item_gives_the_layers_and_the_sidecar_its_edits() {
    let c = checked();
    let def = &c.program.layouts[0];
    let values = grm_compile::param_values(&c.program, &[]).expect("defaults");
    let (doc, issues) = document(&c.program, def, &values, None);
    assert!(issues.is_empty());
    let names: Vec<&str> = doc.layers.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, ["base", "avenue", "sketch"]);
    assert!(matches!(doc.layers[0].source, Source::Grid(ref g) if g.nx == 4 && g.seed == 7));
    assert!(matches!(doc.layers[1].source, Source::Features(_)));
    assert_eq!(doc.layers[2].source, Source::Empty);
    let b = doc.buildings.as_ref().expect("buildings");
    assert_eq!((b.system.as_deref(), b.seed), (Some("House"), 5));
    let merged = doc.evaluate(&|_| Err("no files".into()));
    assert!(merged.issues.is_empty(), "{:?}", merged.issues);
    assert!(!merged.merged.parcels.is_empty());

    // The sidecar: its `avenue` gives the merge mode, its `sketch` the
    // source of the edited layer, its `extra` goes on top.
    let mut side = Document::default();
    let mut avenue = LayerSpec::new("avenue", Source::Empty);
    avenue.merge = MergeMode::GraphCut;
    let sketch = LayerSpec::new(
        "sketch",
        Source::Features(
            r#"{"type": "LineString", "coordinates": [[-40, -40], [-40, 300]]}"#.into(),
        ),
    );
    side.layers = vec![
        LayerSpec::new("extra", Source::Empty),
        sketch.clone(),
        avenue,
    ];
    let (doc, _) = document(&c.program, def, &values, Some(&side));
    let names: Vec<&str> = doc.layers.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, ["base", "avenue", "sketch", "extra"]);
    assert_eq!(doc.layers[1].merge, MergeMode::GraphCut);
    assert!(matches!(doc.layers[1].source, Source::Features(_)));
    assert_eq!(doc.layers[2].source, sketch.source);
}

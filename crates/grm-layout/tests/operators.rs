//! Operators of 4.2-4.3: selections, anchored assignments (anchor moves,
//! re-anchoring, falloff, precedence), cutting a selection to a new layer
//! and dragging it (circular), regenerating a layer with protected
//! elements, insertion and deletion through layers.

use geo::Coord;
use grm_layout::assign::{self, Anchor, Assignment, Falloff, Target};
use grm_layout::blocks::blocks;
use grm_layout::generate::{GridParams, grid};
use grm_layout::geojson_io;
use grm_layout::geom::Affine;
use grm_layout::id::Id;
use grm_layout::layers::{Document, LayerSpec, Place, Source, layer_layout};
use grm_layout::merge::MergeMode;
use grm_layout::model::{ElementKind, Layout, PROTECTED, TagValue, Tags};
use grm_layout::select::Selection;
use grm_layout::subdivide::{ParcelParams, regrow};
use grm_layout::transform::{UpdateParams, transform};
use grm_layout::validity::check;
use std::collections::{BTreeMap, BTreeSet};

fn no_files(_: &str) -> Result<String, String> {
    Err("no files here".into())
}

fn straight_grid() -> Layout {
    let mut l = grid(&GridParams {
        nx: 5,
        ny: 4,
        jitter: 0.0,
        major_every: 0,
        ..GridParams::default()
    })
    .unwrap();
    let b = blocks(&l);
    regrow(&mut l, &b, 1, &ParcelParams::default(), None);
    l
}

fn node_at(l: &Layout, x: f64, y: f64) -> Id {
    *l.nodes
        .iter()
        .find(|(_, n)| n.pos == Coord { x, y })
        .unwrap()
        .0
}

fn street_between(l: &Layout, a: Id, b: Id) -> Id {
    *l.streets
        .iter()
        .find(|(_, s)| (s.a == a && s.b == b) || (s.a == b && s.b == a))
        .unwrap()
        .0
}

#[test]
fn a_street_continuation_follows_the_straight_line() {
    let l = straight_grid();
    // An inner horizontal minor street at y = 60 from x = 80 to 160.
    let s = street_between(&l, node_at(&l, 80.0, 60.0), node_at(&l, 160.0, 60.0));
    let sel = Selection::continuation(&l, s, 30.0);
    // Inner rows are minor; the line runs x = 0..400 but its first and last
    // segments are minor too: all five.
    let ids = sel.ids();
    assert_eq!(ids.len(), 5, "{ids:?}");
    for id in &ids {
        let st = &l.streets[id];
        assert_eq!(l.nodes[&st.a].pos.y, 60.0);
        assert_eq!(l.nodes[&st.b].pos.y, 60.0);
    }
    // A turn limit below 90 degrees never leaves the row.
    let w = sel.node_weights(&l);
    assert_eq!(w.len(), 6);
}

#[test]
fn soft_and_region_selections_weigh_by_place() {
    let l = straight_grid();
    let c = Coord { x: 160.0, y: 120.0 };
    let soft = Selection::soft(&l, c, 100.0);
    let centre = node_at(&l, 160.0, 120.0);
    assert_eq!(soft.weights.get(&centre), Some(&1.0));
    let near = node_at(&l, 240.0, 120.0);
    let w = soft.weights[&near];
    assert!(w > 0.0 && w < 1.0, "{w}");
    assert!(!soft.weights.contains_key(&node_at(&l, 0.0, 0.0)));
    let region = Selection::region(
        &l,
        &[
            Coord { x: 70.0, y: 50.0 },
            Coord { x: 250.0, y: 50.0 },
            Coord { x: 250.0, y: 130.0 },
            Coord { x: 70.0, y: 130.0 },
        ],
    );
    // Nodes (80|160|240, 60|120): 6, the streets between them: 3 + 4.
    let nodes = region
        .ids()
        .iter()
        .filter(|i| l.nodes.contains_key(i))
        .count();
    let streets = region
        .ids()
        .iter()
        .filter(|i| l.streets.contains_key(i))
        .count();
    assert_eq!((nodes, streets), (6, 7));
}

fn tags(k: &str, v: TagValue) -> Tags {
    Tags::from([(k.to_string(), v)])
}

#[test]
fn an_anchored_assignment_moves_with_its_anchor_and_reanchors() {
    let mut l = straight_grid();
    let s = street_between(&l, node_at(&l, 80.0, 60.0), node_at(&l, 160.0, 60.0));
    let at = l.position_of(s).unwrap();
    let a = Assignment {
        tags: tags("colour", TagValue::Text("red".into())),
        kinds: vec![ElementKind::Parcel],
        target: Target::Nearest,
        pos: Coord {
            x: at.x,
            y: at.y + 12.0,
        },
        anchor: Some(Anchor {
            element: s,
            kind: ElementKind::Street,
            at,
        }),
    };
    let mut first = l.clone();
    assign::apply(std::slice::from_ref(&a), &mut first);
    let red: Vec<Id> = first
        .parcels
        .values()
        .filter(|p| p.tags.contains_key("colour"))
        .map(|p| p.id)
        .collect();
    assert_eq!(red.len(), 1);
    // Move the street 10 m up: the assignment follows it.
    let st = &l.streets[&s];
    let w = BTreeMap::from([(st.a, 1.0), (st.b, 1.0)]);
    transform(
        &mut l,
        &Affine::translate(0.0, 10.0),
        &w,
        &UpdateParams::default(),
    )
    .unwrap();
    let p = a.position(&l);
    assert_eq!((p.x, p.y), (at.x, at.y + 22.0));
    // Delete the anchor: the assignment anchors to the nearest street.
    let mut b = a.clone();
    l.delete(s);
    assert!(b.reanchor(&l));
    let an = b.anchor.as_ref().unwrap();
    assert_ne!(an.element, s);
    assert_eq!(an.kind, ElementKind::Street);
    assert!(l.streets.contains_key(&an.element));
}

#[test]
fn region_assignments_fall_off_and_earlier_values_win() {
    let mut l = straight_grid();
    let c = Coord { x: 200.0, y: 120.0 };
    let first = Assignment {
        tags: tags("height", TagValue::Num(40.0)),
        kinds: vec![ElementKind::Parcel],
        target: Target::Region {
            radius: 100.0,
            falloff: Falloff::Linear,
        },
        pos: c,
        anchor: None,
    };
    let second = Assignment {
        tags: Tags::from([
            ("height".to_string(), TagValue::Num(5.0)),
            ("style".to_string(), TagValue::Text("brick".into())),
        ]),
        kinds: vec![ElementKind::Parcel],
        target: Target::Region {
            radius: 1000.0,
            falloff: Falloff::None,
        },
        pos: c,
        anchor: None,
    };
    assign::apply(&[first, second], &mut l);
    let mut heights = Vec::new();
    for p in l.parcels.values() {
        assert_eq!(p.tags.get("style"), Some(&TagValue::Text("brick".into())));
        if let Some(TagValue::Num(h)) = p.tags.get("height") {
            heights.push(*h);
        }
    }
    // Near the centre the first assignment's 40 scaled down; far away the second's 5.
    assert!(heights.iter().any(|h| *h > 20.0 && *h <= 40.0));
    assert!(heights.contains(&5.0));
    assert!(heights.iter().all(|h| *h <= 40.0));
}

fn base_doc() -> Document {
    let mut base = LayerSpec::new(
        "base",
        Source::Grid(GridParams {
            nx: 5,
            ny: 4,
            seed: 3,
            ..GridParams::default()
        }),
    );
    base.seed = 11;
    Document {
        layers: vec![base],
        parcels: ParcelParams::default(),
        buildings: None,
    }
}

#[test]
fn a_street_cut_to_a_new_layer_drags_and_comes_back() {
    let mut doc = base_doc();
    let start = doc.evaluate(&no_files);
    let built = &start.layers[0];
    let s = *built.streets.keys().nth(7).unwrap();
    let new = doc
        .cut_to_layer(0, &BTreeSet::from([s]), built, "moved street")
        .unwrap();
    doc.layers[new].merge = MergeMode::GraphCut;
    let cut = doc.evaluate(&no_files);
    assert!(cut.issues.is_empty(), "{:?}", cut.issues);
    // The street is in the merged layout with its identity, from the new layer.
    assert!(cut.merged.streets.contains_key(&s));
    assert!(!cut.layers[0].streets.contains_key(&s));
    let here = geojson_io::write(&cut.merged, None);
    for t in [Coord { x: 37.0, y: 21.0 }, Coord { x: -55.0, y: 90.0 }] {
        doc.layers[new].place = Place {
            translate: t,
            ..Place::default()
        };
        let away = doc.evaluate(&no_files);
        assert!(check(&away.merged).is_empty());
        assert_ne!(geojson_io::write(&away.merged, None), here);
    }
    doc.layers[new].place = Place::default();
    assert_eq!(
        geojson_io::write(&doc.evaluate(&no_files).merged, None),
        here
    );
}

#[test]
fn protected_elements_survive_regenerating_their_layer() {
    let mut doc = base_doc();
    let built = doc.evaluate(&no_files).layers[0].clone();
    let s = *built.streets.keys().nth(3).unwrap();
    let p = *built.parcels.keys().nth(10).unwrap();
    doc.layers[0].protected = vec![s, p];
    let built = layer_layout(&doc.layers[0], &doc.parcels, &no_files, &mut Vec::new());
    assert_eq!(
        built.streets[&s].tags.get(PROTECTED),
        Some(&TagValue::Bool(true))
    );
    let other = Source::Grid(GridParams {
        nx: 5,
        ny: 4,
        seed: 99,
        rotation_deg: 7.0,
        ..GridParams::default()
    });
    let kept = doc.regenerate(0, other, &built).unwrap();
    assert_eq!(kept, 1);
    let ev = doc.evaluate(&no_files);
    assert!(ev.issues.is_empty(), "{:?}", ev.issues);
    // The protected street is there, whole or cut where the new streets cross it.
    let whole = ev.merged.streets.contains_key(&s);
    let part = TagValue::Text(s.to_string());
    let pieces: f64 = ev
        .merged
        .streets
        .values()
        .filter(|t| t.tags.get(grm_layout::shared::PART_OF) == Some(&part))
        .map(|t| grm_layout::geom::polyline_length(&ev.merged.polyline(t).unwrap()))
        .sum();
    let len = grm_layout::geom::polyline_length(&built.polyline(&built.streets[&s]).unwrap());
    assert!(
        whole || (pieces - len).abs() < 1e-6,
        "the protected street: {pieces} of {len}"
    );
    assert_eq!(
        ev.merged.parcels.get(&p).map(|q| &q.ring),
        built.parcels.get(&p).map(|q| &q.ring),
        "the protected parcel"
    );
    assert!(check(&ev.merged).is_empty());
}

#[test]
fn insertion_and_deletion_go_through_layers() {
    let mut doc = base_doc();
    let built = doc.evaluate(&no_files).layers[0].clone();
    // Delete a street: the layer loses it, the merge stays valid.
    let s = *built.streets.keys().nth(5).unwrap();
    doc.layers[0].deleted.push(s);
    let ev = doc.evaluate(&no_files);
    assert!(!ev.merged.streets.contains_key(&s));
    assert!(check(&ev.merged).is_empty());
    // Insert a diagonal avenue on a layer of its own.
    let avenue = r#"{"type": "FeatureCollection", "features": [
      {"type": "Feature", "id": "avenue", "properties": {"class": "highway", "priority": 100},
       "geometry": {"type": "LineString", "coordinates": [[-20, -30], [150, 120], [330, 260]]}}]}"#;
    let mut ins = LayerSpec::new("avenue", Source::Features(avenue.to_string()));
    ins.merge = MergeMode::GraphCut;
    doc.layers.push(ins);
    let ev = doc.evaluate(&no_files);
    assert!(ev.issues.is_empty(), "{:?}", ev.issues);
    assert!(check(&ev.merged).is_empty());
    assert!(ev.reports[0].crossings > 5);
    // The highway outweighs every minor street it crosses: all of it stays.
    assert_eq!(ev.reports[0].upper_pieces_dropped, 0, "{:?}", ev.reports[0]);
    // The streets it crosses are cut at the crossings and mended to it.
    let cut = ev
        .merged
        .streets
        .values()
        .filter(|t| t.tags.contains_key(grm_layout::shared::PART_OF))
        .count();
    assert!(cut > 8, "{cut}");
    // With a low priority the cut goes through the avenue instead.
    let low = avenue.replace("\"priority\": 100", "\"priority\": 0.5");
    let last = doc.layers.len() - 1;
    doc.layers[last].source = Source::Features(low);
    let ev = doc.evaluate(&no_files);
    assert!(
        ev.reports[0].upper_pieces_dropped > 0,
        "{:?}",
        ev.reports[0]
    );
    assert!(check(&ev.merged).is_empty());
}

#[test]
fn parcels_regrown_by_a_merge_get_the_layers_assignments() {
    let mut doc = base_doc();
    doc.layers[0].assignments.push(Assignment {
        tags: tags("style", TagValue::Text("brick".into())),
        kinds: vec![ElementKind::Parcel],
        target: Target::Region {
            radius: 5000.0,
            falloff: Falloff::None,
        },
        pos: Coord { x: 200.0, y: 120.0 },
        anchor: None,
    });
    let avenue = r#"{"type": "FeatureCollection", "features": [
      {"type": "Feature", "id": "avenue", "properties": {"class": "highway", "priority": 100},
       "geometry": {"type": "LineString", "coordinates": [[-20, -30], [150, 120], [330, 260]]}}]}"#;
    let mut ins = LayerSpec::new("avenue", Source::Features(avenue.to_string()));
    ins.merge = MergeMode::GraphCut;
    ins.fill = false;
    doc.layers.push(ins);
    let ev = doc.evaluate(&no_files);
    assert!(ev.reports[0].blocks_regrown > 0);
    let base: BTreeSet<Id> = ev.layers[0].parcels.keys().copied().collect();
    let regrown = ev
        .merged
        .parcels
        .values()
        .filter(|p| !base.contains(&p.id))
        .count();
    assert!(regrown > 0);
    for p in ev.merged.parcels.values() {
        assert_eq!(
            p.tags.get("style"),
            Some(&TagValue::Text("brick".into())),
            "parcel {}",
            p.id
        );
    }
}

#[test]
fn a_move_that_would_cross_a_street_is_rejected_and_changes_nothing() {
    let l0 = straight_grid();
    let mut l = l0.clone();
    // Drag the node at (160, 120) past its neighbour's street at x = 240.
    let n = node_at(&l, 160.0, 120.0);
    let w = BTreeMap::from([(n, 1.0)]);
    let e = transform(
        &mut l,
        &Affine::translate(100.0, 7.0),
        &w,
        &UpdateParams::default(),
    )
    .unwrap_err();
    assert!(
        matches!(e, grm_layout::transform::TransformError::WouldIntersect(ref v) if !v.is_empty()),
        "{e}"
    );
    assert_eq!(l, l0);
    // A small move of the same node is applied, and the layout stays valid.
    let m = transform(
        &mut l,
        &Affine::translate(6.0, 4.0),
        &w,
        &UpdateParams::default(),
    )
    .unwrap();
    assert_eq!(m.nodes, 1);
    assert!(m.blocks_smoothed + m.blocks_regrown == 4, "{m:?}");
    assert!(check(&l).is_empty());
    // Weights and maps that are not finite are refused.
    let bad = BTreeMap::from([(n, f64::NAN)]);
    assert!(
        transform(
            &mut l,
            &Affine::translate(1.0, 1.0),
            &bad,
            &UpdateParams::default()
        )
        .is_err()
    );
    let unknown = BTreeMap::from([(Id::mint("nope").finish(), 1.0)]);
    assert!(
        transform(
            &mut l,
            &Affine::translate(1.0, 1.0),
            &unknown,
            &UpdateParams::default()
        )
        .is_err()
    );
}

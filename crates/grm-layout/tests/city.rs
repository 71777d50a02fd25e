//! Buildings grown on parcels (`grm_layout::city`): a building on every
//! parcel, keyed by the parcel's identity, so a street move leaves the
//! untouched parcels' buildings byte for byte; tags as meta-parameters
//! (a tag that does not fit is R1031, naming the parcel, and the rest
//! grow); a lot without area is E0509; the city's glb is the same for
//! the same layout, parses, and names every street and parcel; the
//! sidecar's `buildings` section reads and writes back.

use geo::Coord;
use grm_geom::BuildOptions;
use grm_layout::city::{
    BuildingCache, BuildingError, Buildings, Fronts, building, city, city_cached, parcel_seed,
};
use grm_layout::generate::GridParams;
use grm_layout::id::Id;
use grm_layout::layers::{Document, LayerSpec, Move, Select, Source};
use grm_layout::model::{Layout, Parcel, ParcelOrigin, TagValue, Tags};
use grm_layout::sidecar;
use grm_layout::subdivide::ParcelParams;
use std::path::Path;

fn no_files(_: &str) -> Result<String, String> {
    Err("no files here".into())
}

fn grammar() -> grm_sema::Checked {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/city_building.grm");
    let text = std::fs::read_to_string(&path).expect("the example");
    let (_, checked) = grm_sema::check_text(&path.display().to_string(), &text);
    assert!(!checked.has_errors());
    checked
}

fn with_buildings<R>(f: impl FnOnce(&Buildings) -> R) -> R {
    let c = grammar();
    let p = &c.program;
    let system = p.default_system().expect("a system");
    let params = p.default_params();
    let b = Buildings {
        program: p,
        system,
        params: &params,
        dir: None,
        seed: 0,
        options: Default::default(),
    };
    f(&b)
}

fn doc() -> Document {
    let mut base = LayerSpec::new(
        "base",
        Source::Grid(GridParams {
            nx: 4,
            ny: 3,
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

fn glb(m: &grm_geom::Model) -> Vec<u8> {
    grm_geom::export::glb_bytes(m).expect("a glb")
}

#[test]
fn every_parcel_grows_a_building_and_the_city_is_the_same_every_time() {
    let layout = doc().evaluate(&no_files).merged;
    assert!(layout.parcels.len() > 20, "{}", layout.parcels.len());
    with_buildings(|b| {
        let build = BuildOptions::default();
        let mut calls = 0;
        let c = city(&layout, Some(b), &build, &mut |done, total| {
            calls += 1;
            assert_eq!(total, layout.parcels.len());
            assert!(done <= total);
        })
        .expect("builds");
        assert_eq!(calls, layout.parcels.len());
        assert!(c.issues.is_empty(), "{:?}", c.issues);
        assert_eq!(c.buildings, layout.parcels.len());
        // Every parcel's node holds its ground and its building; every
        // street has one.
        let bytes = glb(&c.model);
        let doc = gltf::Gltf::from_slice(&bytes).expect("a valid glb");
        let names: std::collections::BTreeSet<String> = doc
            .nodes()
            .filter_map(|n| n.name().map(str::to_string))
            .collect();
        for p in layout.parcels.keys() {
            assert!(names.contains(&format!("parcel.{p}")), "parcel {p}");
        }
        for s in layout.streets.keys() {
            assert!(names.contains(&format!("street.{s}")), "street {s}");
        }
        // A building's triangles are in its parcel's node: more than the
        // ground's.
        let p = layout.parcels.values().next().unwrap();
        let own = building(b, p, Fronts::new(&layout).of(p), &build).expect("grows");
        let g = c
            .model
            .groups
            .iter()
            .find(|g| g.name == format!("parcel.{}", p.id))
            .unwrap();
        let tris: u32 = g.spans.iter().map(|s| s.triangle_count).sum();
        assert!(tris as usize > own.stats.triangles, "{tris}");
        // Tall enough to be buildings, on the ground.
        assert!(c.model.stats.bounds.max.y >= 12.0 - 1e-3);
        assert!(c.model.stats.bounds.min.y.abs() < 1e-3);
        // The same layout gives the same bytes.
        let again = city(&layout, Some(b), &build, &mut |_, _| {}).expect("builds");
        assert_eq!(glb(&again.model), bytes);
        // The plan alone: ground only.
        let plan = city(&layout, None, &build, &mut |_, _| {}).expect("builds");
        assert_eq!(plan.buildings, 0);
        assert!(plan.model.stats.triangles < c.model.stats.triangles / 10);
    });
}

#[test]
fn a_street_move_keeps_the_untouched_parcels_buildings_byte_for_byte() {
    let mut d = doc();
    let before = d.evaluate(&no_files).merged;
    // Move one node of the grid's inside: the streets at it move, the
    // blocks around it regrow their parcels; the rest stay.
    let incidence = before.incidence();
    let node = *incidence
        .iter()
        .find(|(_, s)| s.len() == 4)
        .map(|(n, _)| n)
        .expect("an inside crossing");
    d.layers[0].moves.push(Move::translation(
        Select::Ids(vec![node]),
        Coord { x: 6.0, y: -4.0 },
    ));
    let ev = d.evaluate(&no_files);
    assert!(ev.issues.is_empty(), "{:?}", ev.issues);
    let after = ev.merged;
    assert_ne!(before.nodes[&node].pos, after.nodes[&node].pos);
    with_buildings(|b| {
        let build = BuildOptions::default();
        let (f1, f2) = (Fronts::new(&before), Fronts::new(&after));
        let (mut kept, mut changed) = (0, 0);
        for (id, p) in &before.parcels {
            match after.parcels.get(id) {
                Some(q) if q == p => {
                    // The same street front, so the same building.
                    assert_eq!(f1.of(p), f2.of(q), "parcel {id}");
                    let one = building(b, p, f1.of(p), &build).expect("grows");
                    let two = building(b, q, f2.of(q), &build).expect("grows");
                    assert_eq!(glb(&one), glb(&two), "parcel {id}");
                    kept += 1;
                }
                _ => changed += 1,
            }
        }
        assert!(kept > before.parcels.len() / 2, "{kept} kept");
        assert!(changed > 0, "the move changed no parcel");
        // In the city too: an untouched parcel's node is the same.
        let one = city(&before, Some(b), &build, &mut |_, _| {}).unwrap();
        let two = city(&after, Some(b), &build, &mut |_, _| {}).unwrap();
        assert_ne!(glb(&one.model), glb(&two.model));
        let id = before
            .parcels
            .iter()
            .find(|(id, p)| after.parcels.get(id) == Some(p))
            .map(|(id, _)| *id)
            .unwrap();
        let triangles = |m: &grm_geom::Model| -> Vec<[[u32; 3]; 3]> {
            let g = m
                .groups
                .iter()
                .find(|g| g.name == format!("parcel.{id}"))
                .unwrap();
            let mut out = Vec::new();
            for s in &g.spans {
                let mesh = &m.parts[s.part].mesh;
                for t in s.first_triangle..s.first_triangle + s.triangle_count {
                    let k = 3 * t as usize;
                    out.push(std::array::from_fn(|i| {
                        mesh.positions[mesh.indices[k + i] as usize].map(f32::to_bits)
                    }));
                }
            }
            out
        };
        assert_eq!(triangles(&one.model), triangles(&two.model));
        // A cache regrows only the parcels the move changed, and the city
        // is the same as the one grown whole.
        let mut cache = BuildingCache::default();
        let first = city_cached(&before, Some(b), &build, &mut cache, &mut |_, _| {}).unwrap();
        assert_eq!(first.reused, 0);
        assert_eq!(glb(&first.model), glb(&one.model));
        assert_eq!(cache.len(), before.parcels.len());
        let second = city_cached(&after, Some(b), &build, &mut cache, &mut |_, _| {}).unwrap();
        assert_eq!(second.reused, kept);
        assert_eq!(glb(&second.model), glb(&two.model));
        assert_eq!(cache.len(), after.parcels.len());
        // Other values for the system: nothing is taken.
        let mut tall = b.params.to_vec();
        tall[0] = grm_sema::Value::Float(20.0);
        let other = Buildings {
            params: &tall,
            ..*b
        };
        let third = city_cached(&after, Some(&other), &build, &mut cache, &mut |_, _| {}).unwrap();
        assert_eq!(third.reused, 0);
    });
}

fn parcel(id: u64, ring: &[(f64, f64)], tags: &[(&str, TagValue)]) -> Parcel {
    Parcel {
        id: Id(id),
        ring: ring.iter().map(|&(x, y)| Coord { x, y }).collect(),
        origin: ParcelOrigin::Explicit,
        tags: tags
            .iter()
            .map(|(k, v)| (k.to_string(), v.clone()))
            .collect::<Tags>(),
    }
}

#[test]
fn tags_are_the_buildings_parameters_and_bad_ones_are_reported() {
    let square = |x: f64| [(x, 0.0), (x + 20.0, 0.0), (x + 20.0, 15.0), (x, 15.0)];
    let mut layout = Layout::default();
    for p in [
        parcel(1, &square(0.0), &[("height", TagValue::Num(40.0))]),
        parcel(2, &square(50.0), &[("height", TagValue::Num(500.0))]),
        parcel(
            3,
            &square(100.0),
            &[("height", TagValue::Text("tall".into()))],
        ),
        parcel(4, &[(150.0, 0.0), (160.0, 0.0), (170.0, 0.0)], &[]),
        parcel(
            5,
            &square(200.0),
            &[("style", TagValue::Text("brick".into()))],
        ),
        parcel(6, &square(250.0), &[("building", TagValue::Bool(false))]),
    ] {
        layout.parcels.insert(p.id, p);
    }
    with_buildings(|b| {
        let build = BuildOptions::default();
        let x = [1.0, 0.0];
        let tall = building(b, &layout.parcels[&Id(1)], x, &build).expect("grows");
        assert!((tall.stats.bounds.max.y - 40.0).abs() < 1e-3);
        // A tag that names no parameter is ignored: the default height.
        let plain = building(b, &layout.parcels[&Id(5)], x, &build).expect("grows");
        assert!((plain.stats.bounds.max.y - 12.0).abs() < 1e-3);
        let c = city(&layout, Some(b), &build, &mut |_, _| {}).expect("builds");
        assert_eq!(c.buildings, 2);
        let issues: Vec<(Id, String)> = c.issues.iter().map(|i| (i.parcel, i.code())).collect();
        assert_eq!(
            issues,
            [
                (Id(2), "R1031".to_string()),
                (Id(3), "R1031".to_string()),
                (Id(4), "E0509".to_string())
            ]
        );
        let text = c.issues[0].describe();
        assert!(
            text.contains("0000000000000002") && text.contains("height") && text.contains("range"),
            "{text}"
        );
        assert!(matches!(c.issues[1].error, BuildingError::Tag { .. }));
        // A parcel tagged `building: false` (a park) has ground only, the
        // open ground's.
        let park = c
            .model
            .groups
            .iter()
            .find(|g| g.name == "parcel.0000000000000006")
            .expect("the park's node");
        assert_eq!(park.spans.len(), 1);
        assert_eq!(
            c.model.materials[c.model.parts[park.spans[0].part].material].name,
            "layout.open"
        );
        // The parcels without a building keep their ground.
        assert!(
            c.model
                .groups
                .iter()
                .any(|g| g.name == "parcel.0000000000000002")
        );
    });
}

#[test]
fn a_parcels_seed_is_its_identity_and_the_specs_seed() {
    assert_eq!(parcel_seed(Id(7), 0), parcel_seed(Id(7), 0));
    assert_ne!(parcel_seed(Id(7), 0), parcel_seed(Id(8), 0));
    assert_ne!(parcel_seed(Id(7), 0), parcel_seed(Id(7), 1));
}

#[test]
fn the_sidecars_buildings_read_and_write_back() {
    let text = r#"{
  "version": 1,
  "buildings": {"grammar": "city_building.grm", "system": "Building", "seed": 4, "params": {"height": 20, "flat": true}},
  "layers": []
}"#;
    let (d, errs) = sidecar::read(text);
    assert!(errs.is_empty(), "{errs:?}");
    let b = d.buildings.clone().expect("buildings");
    assert_eq!(b.grammar, "city_building.grm");
    assert_eq!(b.system.as_deref(), Some("Building"));
    assert_eq!(b.seed, 4);
    assert_eq!(b.params.get("height"), Some(&TagValue::Num(20.0)));
    let out = sidecar::write(&d);
    assert_eq!(sidecar::read(&out).0, d);
    assert_eq!(sidecar::write(&sidecar::read(&out).0), out);
    // Bad sections are coded at their path, and the layers still read.
    for (bad, path, code) in [
        (r#"{"seed": 1}"#, "$.buildings.grammar", "R1023"),
        (r#"{"grammar": 3}"#, "$.buildings.grammar", "R1022"),
        (
            r#"{"grammar": "a.grm", "seed": -1}"#,
            "$.buildings.seed",
            "R1022",
        ),
        (
            r#"{"grammar": "a.grm", "params": {"h": "x"}}"#,
            "$.buildings.params.h",
            "R1022",
        ),
    ] {
        let text = format!(
            r#"{{"version": 1, "buildings": {bad}, "layers": [{{"name": "a", "source": {{"grid": {{}}}}}}]}}"#
        );
        let (d, errs) = sidecar::read(&text);
        assert_eq!(errs.len(), 1, "{bad}: {errs:?}");
        assert_eq!(
            (errs[0].path.as_str(), errs[0].kind.code()),
            (path, code),
            "{bad}"
        );
        assert!(d.buildings.is_none());
        assert_eq!(d.layers.len(), 1, "{bad}");
    }
}

#[test]
fn a_buildings_front_is_its_parcels_edge_on_the_street() {
    // A deep lot (10 m wide on the street, 30 m deep) south of an
    // east-west street, its ring starting at the back: the front is the
    // street edge, running so the lot lies on its left.
    let mut layout = doc().evaluate(&no_files).merged;
    layout.parcels.clear();
    let (a, b) = (Id(1), Id(2));
    layout.add_node(a, Coord { x: -100.0, y: 0.0 });
    layout.add_node(b, Coord { x: 100.0, y: 0.0 });
    layout.streets.clear();
    let s = grm_layout::model::Street::new(
        grm_layout::model::Street::mint_id(a, b, &[]),
        a,
        b,
        grm_layout::model::StreetClass::Minor,
    );
    layout.streets.insert(s.id, s);
    let deep = parcel(
        9,
        &[(0.0, -35.0), (10.0, -35.0), (10.0, -5.0), (0.0, -5.0)],
        &[],
    );
    let f = Fronts::new(&layout).of(&deep);
    assert!((f[0] + 1.0).abs() < 1e-12 && f[1].abs() < 1e-12, "{f:?}");
    // Clockwise, the same.
    let mut cw = deep.clone();
    cw.ring.reverse();
    assert_eq!(Fronts::new(&layout).of(&cw), f);
    // No street near: the longest edge.
    let far = parcel(
        10,
        &[(0.0, -500.0), (10.0, -500.0), (10.0, -470.0), (0.0, -470.0)],
        &[],
    );
    let f = Fronts::new(&layout).of(&far);
    assert!(
        f[0].abs() < 1e-12 && (f[1].abs() - 1.0).abs() < 1e-12,
        "{f:?}"
    );
}

//! Building edits on parcels (`grm_layout::building_edits`,
//! `city::city_edited`; docs/layout.md, "Building edits"): an edit with a
//! `parcel` is replayed in that parcel's building only; a street move
//! that leaves the parcel alone keeps the edit applied and the building
//! byte for byte; a move that regrows the parcel reports the edit (R1032)
//! and applies it nowhere, the other buildings as without it.

use geo::Coord;
use grm_edits::{EditsFile, Op, Target};
use grm_geom::{BuildOptions, Model};
use grm_layout::building_edits::{Unplaced, by_parcel};
use grm_layout::city::{
    BuildingCache, Buildings, Fronts, building, building_edited, city, city_edited,
};
use grm_layout::generate::GridParams;
use grm_layout::id::Id;
use grm_layout::layers::{Document, LayerSpec, Move, Select, Source};
use grm_layout::model::Layout;
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

/// The layout before and after moving one inside crossing.
fn before_and_after() -> (Layout, Layout) {
    let (before, after, _) = away_and_back();
    (before, after)
}

/// The layout before, after moving one inside crossing, and after moving
/// it back (circular editing: the same identities and geometry).
fn away_and_back() -> (Layout, Layout, Layout) {
    let mut d = doc();
    let before = d.evaluate(&no_files).merged;
    let incidence = before.incidence();
    let node = *incidence
        .iter()
        .find(|(_, s)| s.len() == 4)
        .map(|(n, _)| n)
        .expect("an inside crossing");
    d.layers[0].moves.push(Move::translation(
        Select::Ids(vec![node]),
        Coord { x: 30.0, y: -20.0 },
    ));
    let ev = d.evaluate(&no_files);
    assert!(ev.issues.is_empty(), "{:?}", ev.issues);
    d.layers[0].moves.push(Move::translation(
        Select::Ids(vec![node]),
        Coord { x: -30.0, y: 20.0 },
    ));
    let back = d.evaluate(&no_files);
    assert!(back.issues.is_empty(), "{:?}", back.issues);
    (before, ev.merged, back.merged)
}

/// A parcel's group in the city's model: its triangles' corners, bit for
/// bit.
fn triangles(m: &Model, id: Id) -> Vec<[[u32; 3]; 3]> {
    let Some(g) = m.groups.iter().find(|g| g.name == format!("parcel.{id}")) else {
        return Vec::new();
    };
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
}

fn edit(file: &mut EditsFile, system: &str, parcel: Id, target: &str, op: Op) -> u32 {
    let target = Target::Semantic(target.parse().expect("a query"));
    let id = file.add(system, target, op).expect("an id");
    let e = file.edits.iter_mut().find(|e| e.id == id).unwrap();
    e.parcel = Some(parcel.0);
    id
}

#[test]
fn a_parcels_building_edit_survives_a_move_that_keeps_the_parcel_and_is_reported_when_it_is_gone() {
    let (before, after, back) = away_and_back();
    let kept: Vec<Id> = before
        .parcels
        .iter()
        .filter(|(id, p)| after.parcels.get(id) == Some(p))
        .map(|(id, _)| *id)
        .collect();
    let gone: Vec<Id> = before
        .parcels
        .keys()
        .filter(|id| !after.parcels.contains_key(id))
        .copied()
        .collect();
    assert!(kept.len() >= 2 && !gone.is_empty(), "{kept:?} {gone:?}");
    let (k, other_k, g) = (kept[0], kept[1], gone[0]);

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
    let build = BuildOptions::default();
    let mut file = EditsFile::default();
    // On the kept parcel: no first upper floor; on the parcel the move
    // regrows: the same; on another kept parcel, an edit of a system the
    // parcels do not grow.
    let on_kept = edit(&mut file, "Building", k, "(floor = 1) Floor", Op::Remove);
    let on_gone = edit(&mut file, "Building", g, "(floor = 1) Floor", Op::Remove);
    let foreign = edit(&mut file, "Tower", other_k, "(floor = 1) Floor", Op::Remove);
    // An edit of the system itself (no parcel): not the city's.
    file.add(
        "Building",
        Target::Semantic("(floor = 2) Floor".parse().unwrap()),
        Op::Remove,
    );

    let plain_before = city(&before, Some(&b), &build, &mut |_, _| {}).unwrap();
    let plain_after = city(&after, Some(&b), &build, &mut |_, _| {}).unwrap();
    let one = city_edited(&before, Some(&b), &build, &file, None, &mut |_, _| {}).unwrap();
    let two = city_edited(&after, Some(&b), &build, &file, None, &mut |_, _| {}).unwrap();

    // Before the move: both parcel edits apply (the engine's replay: the
    // building is the one grown with the edit), the foreign one is
    // reported.
    assert_eq!(one.edited, 2);
    assert!(one.issues.is_empty(), "{:?}", one.issues);
    let [i] = one.edit_issues.as_slice() else {
        panic!("{:?}", one.edit_issues)
    };
    assert_eq!(
        (i.edit, i.parcel, i.code().as_str()),
        (foreign, other_k, "R1032")
    );
    assert!(
        matches!(&i.why, Unplaced::OtherSystem { system, grown } if system == "Tower" && grown == "Building")
    );
    assert_ne!(
        triangles(&one.model, k),
        triangles(&plain_before.model, k),
        "the edit changes the kept parcel's building"
    );
    let pk = &before.parcels[&k];
    let x = Fronts::new(&before).of(pk);
    let mine = by_parcel(&file);
    let alone = building_edited(&b, pk, x, &build, &mine[&k]).unwrap();
    let unedited = building(&b, pk, x, &build).unwrap();
    assert!(alone.stats.triangles < unedited.stats.triangles);

    // After the move: the kept parcel's edited building is the same, bit
    // for bit; the regrown parcel's edit is reported and applied to no
    // building: every other parcel is as without edits.
    assert_eq!(two.edited, 1);
    assert_eq!(triangles(&two.model, k), triangles(&one.model, k));
    let ids: Vec<(u32, Id, Unplaced)> = two
        .edit_issues
        .iter()
        .map(|i| (i.edit, i.parcel, i.why.clone()))
        .collect();
    assert!(ids.contains(&(on_gone, g, Unplaced::ParcelGone)), "{ids:?}");
    assert_eq!(ids.len(), 2, "{ids:?}");
    assert!(!ids.iter().any(|(e, _, _)| *e == on_kept));
    assert!(two.edit_issues[0].describe().contains(&g.to_string()));
    for id in after.parcels.keys().filter(|id| **id != k) {
        assert_eq!(
            triangles(&two.model, *id),
            triangles(&plain_after.model, *id),
            "parcel {id} took an edit that is not its own"
        );
    }
    // The same inputs give the same bytes.
    let again = city_edited(&after, Some(&b), &build, &file, None, &mut |_, _| {}).unwrap();
    assert_eq!(
        grm_geom::export::glb_bytes(&again.model).unwrap(),
        grm_geom::export::glb_bytes(&two.model).unwrap()
    );

    // Moving the crossing back brings the regrown parcel back with its
    // identity: its edit applies again.
    assert!(back.parcels.contains_key(&g));
    let three = city_edited(&back, Some(&b), &build, &file, None, &mut |_, _| {}).unwrap();
    assert_eq!(three.edited, 2);
    assert_eq!(three.edit_issues, one.edit_issues);

    // With a cache: the kept parcels' buildings (the edited one too) are
    // taken, and the city is the one grown whole; a changed edit regrows
    // its building.
    let mut cache = BuildingCache::default();
    let first = city_edited(
        &before,
        Some(&b),
        &build,
        &file,
        Some(&mut cache),
        &mut |_, _| {},
    )
    .unwrap();
    assert_eq!(first.reused, 0);
    let second = city_edited(
        &after,
        Some(&b),
        &build,
        &file,
        Some(&mut cache),
        &mut |_, _| {},
    )
    .unwrap();
    assert_eq!(second.reused, kept.len());
    assert_eq!(
        grm_geom::export::glb_bytes(&second.model).unwrap(),
        grm_geom::export::glb_bytes(&two.model).unwrap()
    );
    let mut changed = file.clone();
    let e = changed.edits.iter_mut().find(|e| e.id == on_kept).unwrap();
    e.target = Target::Semantic("(floor = 2) Floor".parse().unwrap());
    let third = city_edited(
        &after,
        Some(&b),
        &build,
        &changed,
        Some(&mut cache),
        &mut |_, _| {},
    )
    .unwrap();
    assert_eq!(third.reused, after.parcels.len() - 1);
    assert_ne!(triangles(&third.model, k), triangles(&two.model, k));
}

#[test]
fn edits_of_a_parcel_without_a_building_are_reported_and_the_plan_reports_none() {
    let (before, _) = before_and_after();
    let mut layout = before.clone();
    let (&id, p) = layout.parcels.iter_mut().next().unwrap();
    p.tags
        .insert("building".into(), grm_layout::model::TagValue::Bool(false));
    let mut file = EditsFile::default();
    let e = edit(&mut file, "Building", id, "(floor = 1) Floor", Op::Remove);
    let c = grammar();
    let p = &c.program;
    let params = p.default_params();
    let b = Buildings {
        program: p,
        system: p.default_system().unwrap(),
        params: &params,
        dir: None,
        seed: 0,
        options: Default::default(),
    };
    let build = BuildOptions::default();
    let got = city_edited(&layout, Some(&b), &build, &file, None, &mut |_, _| {}).unwrap();
    let [i] = got.edit_issues.as_slice() else {
        panic!("{:?}", got.edit_issues)
    };
    assert_eq!((i.edit, i.parcel, &i.why), (e, id, &Unplaced::NoBuilding));
    assert_eq!(got.edited, 0);
    // The plan alone grows nothing and reports nothing.
    let plan = city_edited(&layout, None, &build, &file, None, &mut |_, _| {}).unwrap();
    assert!(plan.edit_issues.is_empty());
}

/// A parcel's edit is not the system's: grown on its own (`grmc derive`,
/// the edits file beside the grammar), the building ignores it.
#[test]
fn a_parcel_edit_does_not_apply_to_the_system_grown_alone() {
    let c = grammar();
    let p = &c.program;
    let system = p.default_system().unwrap();
    let params = p.default_params();
    let mut file = EditsFile::default();
    edit(
        &mut file,
        "Building",
        Id(7),
        "(floor = 1) Floor",
        Op::Remove,
    );
    let grow = |f: Option<&EditsFile>| {
        let g = grm_grow::shape::grow(
            p,
            system,
            &params,
            &Default::default(),
            Some((&BuildOptions::default(), None)),
            f,
        )
        .unwrap();
        grm_geom::export::glb_bytes(&g.model.unwrap()).unwrap()
    };
    assert_eq!(grow(Some(&file)), grow(None));
    // Without its parcel the same edit applies.
    file.edits[0].parcel = None;
    assert_ne!(grow(Some(&file)), grow(None));
}

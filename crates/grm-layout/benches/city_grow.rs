//! Growing the example city's buildings (`examples/city.layout.json`, a
//! building from `examples/city_building.grm` on every parcel but the
//! park): `city::city` with the buildings, against baselines measured in
//! the same run: the same buildings grown one by one (`city::building` on
//! each parcel, with its street front: the growth without the city's
//! ground, fronts and joining), the plan alone (`city::city` without
//! buildings), and for scale the same number of buildings grown on the
//! grammar's own 20 m by 12 m lot (`grm_grow::shape::grow`). Prints the
//! times (median of 5 runs after one warm-up) and the ratios. Then a drag
//! with a `BuildingCache`: one crossing of the grid moved 6 m and back,
//! each update regrowing only the parcels the move changed, against the
//! whole city grown again. One thread.
//! Run: `cargo bench -p grm-layout --bench city_grow`.

use grm_geom::BuildOptions;
use grm_grow::shape::{ShapeOptions, grow};
use grm_layout::city::{BuildingCache, Buildings, Fronts, building, city, city_cached};
use grm_layout::sidecar;
use std::path::Path;
use std::time::{Duration, Instant};

fn median(mut v: Vec<Duration>) -> Duration {
    v.sort();
    v[v.len() / 2]
}

fn time(mut f: impl FnMut()) -> Duration {
    f();
    median(
        (0..5)
            .map(|_| {
                let t = Instant::now();
                f();
                t.elapsed()
            })
            .collect(),
    )
}

fn main() {
    let examples = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    let side = std::fs::read_to_string(examples.join("city.layout.json")).expect("the example");
    let (doc, errs) = sidecar::read(&side);
    assert!(errs.is_empty(), "{errs:?}");
    let load = |p: &str| std::fs::read_to_string(examples.join(p)).map_err(|e| e.to_string());
    let ev = doc.evaluate(&load);
    assert!(ev.issues.is_empty(), "{:?}", ev.issues);
    let layout = ev.merged;
    let path = examples.join("city_building.grm");
    let text = std::fs::read_to_string(&path).expect("the grammar");
    let (_, checked) = grm_sema::check_text(&path.display().to_string(), &text);
    assert!(!checked.has_errors());
    let p = &checked.program;
    let system = p.default_system().expect("a system");
    let params = p.default_params();
    let b = Buildings {
        program: p,
        system,
        params: &params,
        dir: None,
        seed: 0,
        options: ShapeOptions::default(),
    };
    let build = BuildOptions {
        group_names: false,
        ..BuildOptions::default()
    };
    let mut n = 0;
    let mut triangles = 0;
    let with = time(|| {
        let c = city(&layout, Some(&b), &build, &mut |_, _| {}).expect("builds");
        n = c.buildings;
        triangles = c.model.stats.triangles;
    });
    let plan = time(|| {
        city(&layout, None, &build, &mut |_, _| {}).expect("builds");
    });
    let one_by_one = time(|| {
        let fronts = Fronts::new(&layout);
        for p in layout.parcels.values() {
            if p.tags.get("building") == Some(&grm_layout::model::TagValue::Bool(false)) {
                continue;
            }
            let m = building(&b, p, fronts.of(p), &build).expect("grows");
            std::hint::black_box(m);
        }
    });
    let alone = time(|| {
        for _ in 0..n {
            let g = grow(
                p,
                system,
                &params,
                &ShapeOptions::default(),
                Some((&build, None)),
                None,
            )
            .expect("grows");
            std::hint::black_box(g.model);
        }
    });
    // A drag: one crossing of the base grid moved and back.
    let mut moved = doc.clone();
    let incidence = layout.incidence();
    let node = *incidence
        .iter()
        .find(|(n, s)| s.len() == 4 && ev.layers[0].nodes.contains_key(n))
        .map(|(n, _)| n)
        .expect("a crossing of the base grid");
    moved.layers[0]
        .moves
        .push(grm_layout::layers::Move::translation(
            grm_layout::layers::Select::Ids(vec![node]),
            geo::Coord { x: 6.0, y: -4.0 },
        ));
    let away = moved.evaluate(&load).merged;
    let changed = layout
        .parcels
        .iter()
        .filter(|(id, p)| away.parcels.get(id) != Some(p))
        .count();
    let mut cache = BuildingCache::default();
    city_cached(&layout, Some(&b), &build, &mut cache, &mut |_, _| {}).expect("builds");
    let mut reused = 0;
    let drag = time(|| {
        let c = city_cached(&away, Some(&b), &build, &mut cache, &mut |_, _| {}).expect("builds");
        reused = c.reused;
        city_cached(&layout, Some(&b), &build, &mut cache, &mut |_, _| {}).expect("builds");
    }) / 2;
    let ms = |d: Duration| d.as_secs_f64() * 1e3;
    println!(
        "city: {} parcels, {} streets; {n} buildings, {triangles} triangles",
        layout.parcels.len(),
        layout.streets.len()
    );
    println!(
        "city with buildings {:.1} ms ({:.3} ms a building); the plan alone {:.1} ms",
        ms(with),
        ms(with) / n.max(1) as f64,
        ms(plan)
    );
    println!(
        "the same buildings one by one {:.1} ms; {n} on the grammar's own lot {:.1} ms ({:.3} ms each)",
        ms(one_by_one),
        ms(alone),
        ms(alone) / n.max(1) as f64
    );
    println!(
        "drag (a crossing moved 6 m, {changed} parcels changed): {:.1} ms an update with the cache ({reused} buildings reused), {:.3}x the whole city",
        ms(drag),
        ms(drag) / ms(with)
    );
    println!(
        "ratio: city / the buildings one by one = {:.2}x (the ground, fronts and joining)",
        ms(with) / ms(one_by_one)
    );
}

//! Growing the example city's buildings (`examples/city.layout.json`, a
//! building from `examples/city_building.grm` on every parcel but the
//! park): `city::city` with the buildings, against baselines measured in
//! the same run: the same buildings grown one by one (`city::building` on
//! each parcel, with its street front: the growth without the city's
//! ground, fronts and joining), the plan alone (`city::city` without
//! buildings), and for scale the same number of buildings grown on the
//! grammar's own 20 m by 12 m lot (`grm_grow::shape::grow`). Prints the
//! times (median of 5 runs after one warm-up) and the ratios. One thread.
//! Run: `cargo bench -p grm-layout --bench city_grow`.

use grm_geom::BuildOptions;
use grm_grow::shape::{ShapeOptions, grow};
use grm_layout::city::{Buildings, Fronts, building, city};
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
        "ratio: city / the buildings one by one = {:.2}x (the ground, fronts and joining)",
        ms(with) / ms(one_by_one)
    );
}

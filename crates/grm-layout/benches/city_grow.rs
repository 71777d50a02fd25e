//! Growing the example city's buildings (`examples/city.layout.json`, a
//! building from `examples/city_building.grm` on every parcel but the
//! park): `city::city` with the buildings, against two baselines measured
//! in the same run: the plan alone (`city::city` without buildings) and
//! the same number of buildings grown alone on the grammar's own 20 m by
//! 12 m lot (`grm_grow::shape::grow`). Prints the times (median of 5 runs
//! after one warm-up) and the ratios: the cost of a building on a parcel
//! (its polygon lowered as the lot, its seed, the model joined into the
//! city) against a lone building's. One thread. Run:
//! `cargo bench -p grm-layout --bench city_grow`.

use grm_geom::BuildOptions;
use grm_grow::shape::{ShapeOptions, grow};
use grm_layout::city::{Buildings, city};
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
        "{n} lone buildings on the grammar's lot {:.1} ms ({:.3} ms each)",
        ms(alone),
        ms(alone) / n.max(1) as f64
    );
    println!(
        "ratio: (city - plan) / lone buildings = {:.2}x",
        (ms(with) - ms(plan)) / ms(alone)
    );
}

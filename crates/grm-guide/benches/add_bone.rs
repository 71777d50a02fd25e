//! Micro-benchmark of the per-bone cost (no external harness):
//! `cargo bench -p grm-guide --bench add_bone`.
//!
//! Bones are tree-like random bones around the benchmark curves
//! (`examples/calder_tree.curves.json`, utilization on); a particle's state
//! is restarted every 200 bones, and cloned before every bone as the
//! sampler does when it resamples.

use grm_testkit::Rng;
use std::hint::black_box;
use std::path::PathBuf;
use std::time::Instant;

use glam::Vec3;
use grm_guide::{CostModel, CostOptions, Curves, DensityParams};

fn bones(n: usize) -> Vec<(Vec3, Vec3)> {
    let mut rng = Rng::new(42);
    (0..n)
        .map(|_| {
            let base = Vec3::new(
                rng.range_f32(-2.5, 2.5),
                rng.range_f32(0.0, 4.8),
                rng.range_f32(-0.6, 0.6),
            );
            let dir = Vec3::new(
                rng.range_f32(-1., 1.),
                rng.range_f32(-0.2, 1.),
                rng.range_f32(-0.4, 0.4),
            );
            (base, base + dir * 0.5)
        })
        .collect()
}

fn time(label: &str, n: usize, mut f: impl FnMut() -> f64) {
    // The machine is shared: take the best of many short runs, which
    // filters out preemption.
    black_box(f());
    let mut best = f64::INFINITY;
    for _ in 0..300 {
        let t = Instant::now();
        black_box(f());
        best = best.min(t.elapsed().as_secs_f64());
    }
    println!("{label:<48} {:>8.1} ns", best * 1e9 / n as f64);
}

fn main() {
    let path =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples/calder_tree.curves.json");
    let curves = Curves::load(&path).expect("example curves load");
    let model = CostModel::new(&curves, CostOptions::from_curves(&curves));
    let dense = CostModel::new(
        &curves,
        CostOptions {
            density: Some(DensityParams {
                radius: 0.3,
                scale: 20.0,
            }),
        },
    );
    let n = 2_000;
    let bs = bones(n);
    println!("grm-guide micro-benchmark, {n} bones, 3 curves, per operation:");

    time("add_bone (3 curves, utilization on)", n, || {
        let mut s = model.new_state();
        let mut acc = 0.0;
        for (i, &(b, t)) in bs.iter().enumerate() {
            if i % 200 == 0 {
                s = model.new_state();
            }
            acc += model.add_bone(&mut s, b, t).total();
        }
        acc + model.total(&s).total()
    });
    time("state clone + add_bone (sampler pattern)", n, || {
        let mut s = model.new_state();
        let mut acc = 0.0;
        for (i, &(b, t)) in bs.iter().enumerate() {
            if i % 200 == 0 {
                s = model.new_state();
            }
            let mut c = s.clone();
            acc += model.add_bone(&mut c, b, t).total();
            s = c;
        }
        acc
    });
    time("state clone + add_bone, density on", n, || {
        let mut s = dense.new_state();
        let mut acc = 0.0;
        for (i, &(b, t)) in bs.iter().enumerate() {
            if i % 200 == 0 {
                s = dense.new_state();
            }
            let mut c = s.clone();
            acc += dense.add_bone(&mut c, b, t).total();
            s = c;
        }
        acc
    });
    time("heuristic term (eq. 10)", n, || {
        bs.iter().map(|&(b, t)| model.heuristic(b, t - b)).sum()
    });
    let trunk = curves.curves()[0].bezier;
    let cached = trunk.bracket_samples();
    time("Bezier3::closest_point_sampled (cached samples)", n, || {
        bs.iter()
            .map(|&(b, _)| trunk.closest_point_sampled(&cached, b.as_dvec3()).dist)
            .sum()
    });
    time("  of which the bracket scan (33 samples)", n, || {
        bs.iter()
            .map(|&(b, _)| {
                trunk
                    .closest_point_within(&cached, b.as_dvec3(), -1.0)
                    .map_or(1.0, |c| c.dist)
            })
            .sum()
    });
    time("Bezier3::closest_point (samples on the fly)", n, || {
        bs.iter()
            .map(|&(b, _)| trunk.closest_point(b.as_dvec3()).dist)
            .sum()
    });
}

//! The CPU prefix (`GpuDeriveOptions::cpu_prefix`): the first iterations
//! derived by `grm-derive` while the strings are small, the rest on the
//! GPU from the uploaded string. Whatever the threshold and the path
//! (batched, per iteration, several systems), the result is the GPU-only
//! derivation's: the same string bit for bit, the same figures, the same
//! errors; and the strings the CPU derived are marked as such.

mod common;
use common::*;
use grm_gpu::{
    DerivePath, DeriveStrategy, GpuDeriveOptions, GpuError, GpuJob, derive_many, derive_with,
};

fn opts(
    sys: &grm_compile::CompiledSystem,
    iterations: u32,
    seed: u32,
    prefix: u64,
) -> GpuDeriveOptions {
    GpuDeriveOptions {
        iterations,
        seed,
        cpu_prefix: prefix,
        ..GpuDeriveOptions::from_system(sys)
    }
}

/// How many strings after the axiom the CPU derived; they come first.
fn cpu_steps(d: &grm_gpu::GpuDerivation) -> usize {
    let k = d.stats.iter().skip(1).take_while(|s| s.on_cpu).count();
    assert!(
        d.stats.iter().skip(1 + k).all(|s| !s.on_cpu),
        "CPU strings after GPU strings"
    );
    k
}

#[test]
fn example_scenes_with_a_cpu_prefix_equal_the_gpu_only_derivation() {
    let g = gpu();
    let cases: &[(&str, Option<&str>, u32)] = &[
        ("hilbert3d.grm", None, 4),
        ("koch_island.grm", None, 4),
        ("bracketed_plant.grm", None, 4),
        ("row_of_trees.grm", None, 6),
        ("ternary_tree.grm", Some("TernaryTreeB"), 5),
        ("stochastic_plant.grm", None, 5),
        ("context_plant_a.grm", None, 24),
        ("context_plant_b.grm", None, 20),
    ];
    let (mut mixed, mut batched_mixed) = (0, 0);
    for &(file, system, iterations) in cases {
        let sys = example(file, system);
        let seed = sys.settings.seed;
        let what = format!("{file} {system:?}");
        let (gpu_only, _) = derive_with(
            g,
            &sys,
            &opts(&sys, iterations, seed, 0),
            DeriveStrategy::Auto,
        )
        .expect("derives");
        assert_eq!(cpu_steps(&gpu_only), 0, "{what}");
        let cpu = cpu_derive(&sys, iterations, seed).expect("cpu derives");
        assert_same(&what, &cpu, &gpu_only.string);
        // Thresholds: the first string only, a few, all of them.
        for prefix in [1, 300, 5_000, u64::MAX] {
            // Stepwise: past the prefix the direct path (tests/direct.rs)
            // would take the deterministic scenes.
            for strategy in [DeriveStrategy::Stepwise, DeriveStrategy::PerIteration] {
                let o = opts(&sys, iterations, seed, prefix);
                let (d, path) = derive_with(g, &sys, &o, strategy).expect("derives");
                let w = format!("{what} prefix {prefix} {strategy:?}");
                same_bits(&w, &gpu_only.string, &d.string);
                assert_eq!(figures(&d), figures(&gpu_only), "{w}: figures");
                let k = cpu_steps(&d);
                // The CPU took exactly the steps whose strings are within
                // the threshold (these systems' bounds are their lengths
                // or more).
                for s in &d.stats[1..=k] {
                    assert!(
                        s.modules <= prefix,
                        "{w}: string {} on the CPU",
                        s.iteration
                    );
                }
                if prefix == u64::MAX {
                    assert_eq!(k, iterations as usize, "{w}");
                }
                if k > 0 && k < iterations as usize {
                    mixed += 1;
                    batched_mixed += usize::from(path == DerivePath::Batched);
                }
            }
        }
    }
    // Both paths continued on the GPU from a CPU string many times.
    assert!(mixed >= 12, "only {mixed} mixed derivations");
    assert!(
        batched_mixed >= 6,
        "only {batched_mixed} batched after a prefix"
    );
}

#[test]
fn a_forest_with_a_cpu_prefix_equals_each_job_alone() {
    let g = gpu();
    let stochastic = example("stochastic_plant.grm", None);
    let hilbert = example("hilbert3d.grm", None);
    let context = example("context_plant_a.grm", None);
    let rows = example("row_of_trees.grm", None);
    // Different iteration counts, some below the steps the CPU takes.
    let mut jobs: Vec<GpuJob> = (0..5)
        .map(|k| GpuJob {
            system: &stochastic,
            iterations: 1 + k,
            seed: 10 + k,
        })
        .collect();
    jobs.push(GpuJob {
        system: &hilbert,
        iterations: 3,
        seed: 0,
    });
    jobs.push(GpuJob {
        system: &rows,
        iterations: 0,
        seed: 0,
    });
    jobs.push(GpuJob {
        system: &context,
        iterations: 9,
        seed: 3,
    });
    let mut forest_steps = Vec::new();
    for prefix in [0, 200, 2_000, u64::MAX] {
        let o = GpuDeriveOptions {
            cpu_prefix: prefix,
            ..GpuDeriveOptions::from_system(&stochastic)
        };
        let out = derive_many(g, &jobs, &o).expect("derives");
        for (k, (job, got)) in jobs.iter().zip(&out.strings).enumerate() {
            let want = cpu_derive(job.system, job.iterations, job.seed).expect("cpu derives");
            assert_same(&format!("prefix {prefix} job {k}"), &want, got);
        }
        forest_steps.push(out.stats.iter().skip(1).filter(|s| s.on_cpu).count());
    }
    assert_eq!(forest_steps[0], 0);
    assert!(
        forest_steps[1] > 0 && forest_steps[1] < 9,
        "the CPU took {} of 9 steps",
        forest_steps[1]
    );
    assert_eq!(forest_steps[3], 9);
}

/// Errors are the GPU-only derivation's: a bad parameter inside the
/// strings the CPU would take (the CPU stops, the GPU derives from the
/// axiom and reports it), or after them (the GPU reports it from the
/// uploaded string); random grammars give the same string or error.
#[test]
fn errors_with_a_cpu_prefix_are_the_gpu_only_errors() {
    let g = gpu();
    let bad = inline("system S { axiom A(4) A(5); A(x) -> A(x - 1) F(1 / (x - 1)) B; B -> B B; }")
        .expect("checks");
    let base = derive_with(g, &bad, &opts(&bad, 6, 0, 0), DeriveStrategy::Auto);
    let Err(e @ GpuError::Runtime { .. }) = &base else {
        panic!(
            "expected a runtime error: {:?}",
            base.map(|(d, _)| d.string.len())
        );
    };
    for prefix in [1, 6, 40, u64::MAX] {
        for strategy in [DeriveStrategy::Auto, DeriveStrategy::PerIteration] {
            let got = derive_with(g, &bad, &opts(&bad, 6, 0, prefix), strategy);
            match got {
                Err(got) => assert_eq!(&got, e, "prefix {prefix} {strategy:?}"),
                Ok(_) => panic!("prefix {prefix} {strategy:?}: no error"),
            }
        }
    }
    // The module limit is the GPU-only one too.
    let hilbert = example("hilbert3d.grm", None);
    let limited = |prefix| GpuDeriveOptions {
        max_modules: 1_000,
        ..opts(&hilbert, 4, 0, prefix)
    };
    let want = derive_with(g, &hilbert, &limited(0), DeriveStrategy::Auto).map(|(d, _)| d.string);
    assert!(
        matches!(want, Err(GpuError::ModuleLimit { .. })),
        "{want:?}"
    );
    for prefix in [300, u64::MAX] {
        let got =
            derive_with(g, &hilbert, &limited(prefix), DeriveStrategy::Auto).map(|(d, _)| d.string);
        assert_eq!(got, want, "prefix {prefix}");
    }
    let mut rng = Rng::seeded(4242);
    let (mut compared, mut errors, mut tried) = (0, 0, 0);
    while compared < 40 && tried < 300 {
        tried += 1;
        let src = random_grammar(&mut rng);
        let Some(sys) = inline(&src) else { continue };
        let iterations = 1 + rng.below(5) as u32;
        let seed = rng.below(1000) as u32;
        let prefix = [1, 20, 200][rng.below(3) as usize];
        let o = |prefix| GpuDeriveOptions {
            max_modules: 200_000,
            ..opts(&sys, iterations, seed, prefix)
        };
        let a = derive_with(g, &sys, &o(0), DeriveStrategy::Auto).map(|(d, _)| d);
        let b = derive_with(g, &sys, &o(prefix), DeriveStrategy::Auto).map(|(d, _)| d);
        match (&a, &b) {
            (Ok(a), Ok(b)) => {
                same_bits(&src, &a.string, &b.string);
                assert_eq!(figures(a), figures(b), "{src}");
            }
            (Err(ea), Err(eb)) => {
                assert_eq!(ea, eb, "{src}");
                errors += 1;
            }
            _ => panic!(
                "{src}\nGPU only: {:?}\nwith prefix {prefix}: {:?}",
                a.as_ref().map(|d| d.string.len()),
                b.as_ref().map(|d| d.string.len())
            ),
        }
        compared += 1;
    }
    assert!(compared >= 40, "only {compared} grammars compared");
    assert!(errors > 0, "no runtime error compared");
}

/// A batched run after a CPU prefix that the device reports as overflowed
/// (capacity check forced) is discarded and derived again iteration by
/// iteration from the same CPU string: the same result.
#[test]
fn a_device_overflow_after_a_cpu_prefix_falls_back_to_per_iteration() {
    let g = gpu();
    for (file, iterations) in [("hilbert3d.grm", 4), ("stochastic_plant.grm", 5)] {
        let sys = example(file, None);
        let seed = sys.settings.seed;
        let (want, _) = derive_with(
            g,
            &sys,
            &opts(&sys, iterations, seed, 0),
            DeriveStrategy::Auto,
        )
        .expect("derives");
        let o = opts(&sys, iterations, seed, 300);
        let (got, path) =
            derive_with(g, &sys, &o, DeriveStrategy::AutoShrunkCaps).expect("derives");
        assert_eq!(path, DerivePath::BatchedThenPerIteration, "{file}");
        assert!(
            cpu_steps(&got) > 0,
            "{file}: the CPU took the first strings"
        );
        same_bits(file, &want.string, &got.string);
        assert_eq!(figures(&got), figures(&want), "{file}");
    }
}

//! Several systems derived in the same dispatches (Lipp 5.4): each job's
//! string equals its own CPU derivation, whatever its neighbours (other
//! systems, other seeds, other iteration counts, context-sensitive or not).

mod common;
use common::*;
use grm_gpu::{GpuDeriveOptions, GpuError, GpuJob, derive_many};

#[test]
fn a_forest_of_systems_and_seeds_matches_each_cpu_derivation() {
    let g = gpu();
    let stochastic = example("stochastic_plant.grm", None);
    let context = example("context_plant_b.grm", None);
    let ternary = example("ternary_tree.grm", Some("TernaryTreeC"));
    let hilbert = example("hilbert3d.grm", None);
    let rows = example("row_of_trees.grm", None);
    let mut jobs = Vec::new();
    for seed in 0..12 {
        jobs.push(GpuJob {
            system: &stochastic,
            iterations: 2 + seed % 3,
            seed: seed * 7919,
        });
    }
    jobs.insert(
        3,
        GpuJob {
            system: &context,
            iterations: 14,
            seed: 0,
        },
    );
    jobs.insert(
        7,
        GpuJob {
            system: &ternary,
            iterations: 4,
            seed: 0,
        },
    );
    jobs.push(GpuJob {
        system: &hilbert,
        iterations: 2,
        seed: 0,
    });
    jobs.insert(
        0,
        GpuJob {
            system: &rows,
            iterations: 0,
            seed: 0,
        },
    );
    jobs.push(GpuJob {
        system: &context,
        iterations: 9,
        seed: 3,
    });
    let opts = GpuDeriveOptions::from_system(&stochastic);
    let out = derive_many(g, &jobs, &opts).expect("derives");
    assert_eq!(out.strings.len(), jobs.len());
    for (k, (job, got)) in jobs.iter().zip(&out.strings).enumerate() {
        let want = cpu_derive(job.system, job.iterations, job.seed).expect("cpu derives");
        assert_same(
            &format!("job {k} ({}, seed {})", job.system.name, job.seed),
            &want,
            got,
        );
    }
    let total: u64 = out.strings.iter().map(|s| s.len() as u64).sum();
    assert_eq!(out.stats.last().map(|s| s.modules), Some(total));
}

#[test]
fn a_runtime_error_names_its_system_and_local_position() {
    let g = gpu();
    let fine = example("bracketed_plant.grm", None);
    let bad =
        inline("system S { axiom A(2) A(3); A(x) -> A(x - 1) F(1 / (x - 1)); }").expect("checks");
    let cpu = cpu_derive(&bad, 3, 0);
    let Err(grm_derive::DeriveError::Runtime(e)) = cpu else {
        panic!("the CPU derives it: {cpu:?}");
    };
    let jobs = [
        GpuJob {
            system: &fine,
            iterations: 3,
            seed: 0,
        },
        GpuJob {
            system: &bad,
            iterations: 3,
            seed: 0,
        },
        GpuJob {
            system: &fine,
            iterations: 3,
            seed: 0,
        },
    ];
    match derive_many(g, &jobs, &GpuDeriveOptions::from_system(&fine)) {
        Err(GpuError::Runtime {
            system,
            iteration,
            position,
            ..
        }) => {
            assert_eq!((system, iteration, position), (1, e.iteration, e.position));
        }
        other => panic!(
            "expected a runtime error, got {:?}",
            other.map(|d| d.strings.len())
        ),
    }
}

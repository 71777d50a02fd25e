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
    let opts = GpuDeriveOptions {
        cpu_prefix: 0,
        ..GpuDeriveOptions::from_system(&stochastic)
    };
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
    let opts = GpuDeriveOptions {
        cpu_prefix: 0,
        ..GpuDeriveOptions::from_system(&fine)
    };
    match derive_many(g, &jobs, &opts) {
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

/// Derivation and interpretation of several systems in the same
/// dispatches: each job's bones are what the CPU turtle draws for its own
/// string (each system with its own commands, angle, step and tropism).
#[test]
fn a_forest_is_interpreted_per_system() {
    let g = gpu();
    let loaded: Vec<(grm_sema::Program, String, grm_compile::CompiledSystem)> = vec![
        example_program("stochastic_plant.grm", None),
        example_program("ternary_tree.grm", Some("TernaryTreeD")),
        example_program("hilbert3d.grm", None),
        example_program("context_plant_a.grm", None),
        example_program("bracketed_plant.grm", None),
    ];
    let programs: Vec<grm_gpu::TurtleProgram> = loaded
        .iter()
        .map(|(p, n, c)| grm_gpu::TurtleProgram::new(p.system(n).expect("system"), &c.settings))
        .collect();
    // All systems (branches walked: TernaryTreeD has tropism), then those
    // without tropism (the segmented matrix scan), then a forest without
    // brackets (straight: no depths, no sort; each system starts afresh).
    for subset in [vec![0usize, 1, 2, 3, 4], vec![3, 0, 4, 2], vec![2]] {
        forest(g, &loaded, &programs, &subset);
    }
}

fn forest(
    g: &grm_gpu::Gpu,
    loaded: &[(grm_sema::Program, String, grm_compile::CompiledSystem)],
    programs: &[grm_gpu::TurtleProgram],
    subset: &[usize],
) {
    let mut jobs = Vec::new();
    let mut turtles = Vec::new();
    let mut which = Vec::new();
    for &k in subset {
        let c = &loaded[k].2;
        for seed in 0..2u32 {
            which.push(k);
            jobs.push(GpuJob {
                system: c,
                iterations: [4, 3, 2, 12, 3][k],
                seed: seed * 31,
            });
            turtles.push(&programs[k]);
        }
    }
    // Both scans of a branching string (the forests with brackets).
    for branch_scan in [grm_gpu::BranchScan::Auto, grm_gpu::BranchScan::Fused] {
        let opts = grm_gpu::GpuRunOptions {
            derive: GpuDeriveOptions {
                cpu_prefix: 0,
                ..GpuDeriveOptions::from_system(&loaded[0].2)
            },
            interpret: true,
            read_string: true,
            read_bones: true,
            strategy: grm_gpu::DeriveStrategy::Auto,
            branch_scan,
            pipelined: false,
        };
        let out = grm_gpu::run_many(g, &jobs, &turtles, &opts, &mut |_| {}).expect("runs");
        let bones = out.bones.expect("bones read");
        let strings = out.strings.expect("strings read");
        assert_eq!(
            out.interpretation.expect("interpreted").walked,
            subset.contains(&1)
        );
        let scan = format!("{branch_scan:?}");
        for (k, job) in jobs.iter().enumerate() {
            let (p, name, c) = &loaded[which[k]];
            let sys = p.system(name).expect("system");
            let string = cpu_derive(c, job.iterations, job.seed).expect("cpu derives");
            assert_same(&format!("job {k} {scan}"), &string, &strings[k]);
            let want = grm_turtle::interpret(sys, &c.settings, &string).expect("cpu interprets");
            assert_eq!(want.bones.len(), bones[k].len(), "job {k} ({name}): bones");
            for (a, b) in want.bones.iter().zip(&bones[k]) {
                assert_eq!(
                    (a.module, a.parent.unwrap_or(u32::MAX)),
                    (b.module_index, b.parent),
                    "job {k} ({name})"
                );
                let d = (a.tip.x - b.tip_x).abs()
                    + (a.tip.y - b.tip_y).abs()
                    + (a.tip.z - b.tip_z).abs();
                let scale = 1.0 + a.tip.abs().max_element();
                assert!(
                    d <= 1e-3 * scale,
                    "job {k} ({name}): tip {:?} vs {b:?}",
                    a.tip
                );
                assert!(
                    (a.width_base - b.width).abs() <= 1e-4 * a.width_base.max(1.0),
                    "job {k} ({name}): width"
                );
            }
        }
    }
}

/// A forest of one tree is derived with that tree's seed, not the
/// options' (a derivation of one system takes the options' seed, and
/// `grmc forest --trees 1 --gpu` grew the seed-0 tree whatever its seed).
#[test]
fn a_forest_of_one_tree_uses_its_own_seed() {
    let g = gpu();
    let sys = example("stochastic_plant.grm", None);
    let jobs = [GpuJob {
        system: &sys,
        iterations: 5,
        seed: 7,
    }];
    let opts = GpuDeriveOptions {
        cpu_prefix: 0,
        seed: 0,
        ..GpuDeriveOptions::from_system(&sys)
    };
    let want = cpu_derive(&sys, 5, 7).expect("cpu derives");
    assert_ne!(
        want.symbols().collect::<Vec<_>>(),
        cpu_derive(&sys, 5, 0)
            .expect("cpu derives")
            .symbols()
            .collect::<Vec<_>>(),
        "the seeds give different plants"
    );
    let out = derive_many(g, &jobs, &opts).expect("derives");
    assert_same("derive_many", &want, &out.strings[0]);
    let turtle = grm_gpu::TurtleProgram::new(
        example_program("stochastic_plant.grm", None)
            .0
            .default_system()
            .expect("system"),
        &sys.settings,
    );
    let run = grm_gpu::GpuRunOptions {
        derive: opts,
        interpret: false,
        read_string: true,
        read_bones: false,
        strategy: grm_gpu::DeriveStrategy::Auto,
        branch_scan: grm_gpu::interp::BranchScan::Auto,
        pipelined: false,
    };
    let r = grm_gpu::run_many(g, &jobs, &[&turtle], &run, &mut |_| {}).expect("runs");
    assert_same("run_many", &want, &r.strings.expect("read")[0]);
}

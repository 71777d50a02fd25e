//! The GPU behind the same call (`grm_grow::Backend::Gpu`, the `gpu`
//! feature; Mesa lavapipe in the tests): the string, with the CPU's keys
//! where asked (a deterministic system's too: a glb's part table), the
//! run's report; a production's run-time error reported as the CPU
//! engine's; a GPU forest whose trees are the CPU forest's.

#![cfg(feature = "gpu")]

mod common;
use common::*;

use grm_derive::ModuleString;
use grm_grow::forest::{ForestOptions, ForestTree, Ran};
use grm_grow::gpu::GpuChoice;
use grm_grow::{Backend, Event, GrowError, Grower, Record};

fn on_gpu(cpu_prefix: u64) -> Backend {
    Backend::Gpu(GpuChoice {
        cpu_prefix,
        ..GpuChoice::default()
    })
}

#[test]
fn the_gpu_grows_the_cpus_string_with_its_keys() {
    for (file, n, keys) in [
        // Draws nothing: keys only because they are asked for.
        ("ternary_tree.grm", 4, true),
        ("hilbert3d.grm", 2, true),
        ("hilbert3d.grm", 2, false),
        // Draws: keyed either way.
        ("stochastic_plant.grm", 5, false),
    ] {
        let checked = checked(file);
        let c = compile(&checked);
        let record = Record {
            keys,
            ..Record::default()
        };
        let cpu = Grower::new(&c, 1, record)
            .expect("engine")
            .derive(&options(n, 3), &mut |_| {})
            .expect("derives");
        assert!(cpu.gpu.is_none());
        for prefix in [0, grm_gpu::derive::CPU_PREFIX_MODULES] {
            let what = format!("{file} keys {keys} prefix {prefix}");
            let g = Grower::with_backend(&c, system(&checked), 1, record, on_gpu(prefix))
                .expect("grower");
            assert!(g.engine().is_none(), "no CPU engine made");
            let mut events = Vec::new();
            let grown = g
                .derive(&options(n, 3), &mut |e| {
                    events.push(match e {
                        Event::Gpu(_) => "gpu".to_string(),
                        Event::Step { stats, .. } => format!("step {}", stats.iteration),
                        other => format!("{other:?}"),
                    })
                })
                .expect("derives");
            assert_eq!(events.first().map(String::as_str), Some("gpu"), "{what}");
            assert!(events.contains(&format!("step {n}")), "{what}: {events:?}");
            let run = grown.gpu.as_ref().expect("the GPU's report");
            assert!(run.string.is_none(), "{what}: the string moved out");
            assert_eq!(grown.string.parts().syms, cpu.string.parts().syms, "{what}");
            assert_eq!(
                grown.string.parts().starts,
                cpu.string.parts().starts,
                "{what}"
            );
            assert_eq!(grown.string.keys(), cpu.string.keys(), "{what}");
            assert_eq!(
                grown.string.keys().is_empty(),
                !keys && !c.draws_randomly(),
                "{what}"
            );
            // The figures are the CPU's (the time apart).
            assert_eq!(grown.stats.len(), cpu.stats.len());
            for (a, b) in grown.stats.iter().zip(&cpu.stats) {
                assert_eq!(
                    (
                        a.iteration,
                        a.modules,
                        a.param_words,
                        a.cumulative_modules,
                        a.processed_modules
                    ),
                    (
                        b.iteration,
                        b.modules,
                        b.param_words,
                        b.cumulative_modules,
                        b.processed_modules
                    ),
                    "{what}"
                );
            }
            assert!(
                run.interpretation
                    .as_ref()
                    .is_some_and(|i| i.bone_count > 0),
                "{what}: interpreted there"
            );
        }
    }
}

#[test]
fn what_only_the_cpu_records_or_reports() {
    let checked = checked("stochastic_plant.grm");
    let c = compile(&checked);
    let tree = Record {
        tree: true,
        ..Record::default()
    };
    assert!(matches!(
        Grower::with_backend(&c, system(&checked), 1, tree, on_gpu(0)),
        Err(GrowError::Unsupported(_))
    ));
    // A production's failing value: the CPU engine's report, with its
    // source (R0204), not the GPU's.
    let bad = inline("system S { axiom A(2) A(3); A(x) -> A(x - 1) F(1 / (x - 1)); }");
    let bc = compile(&bad);
    let cpu = Grower::new(&bc, 1, Record::default())
        .expect("engine")
        .derive(&options(3, 0), &mut |_| {})
        .expect_err("fails");
    let g =
        Grower::with_backend(&bc, system(&bad), 1, Record::default(), on_gpu(0)).expect("grower");
    let e = g.derive(&options(3, 0), &mut |_| {}).expect_err("fails");
    assert_eq!(e, cpu);
    assert!(matches!(e, GrowError::Derive(_)));
    // Without reading the string back, only its figures come back.
    let g = Grower::with_backend(
        &c,
        system(&checked),
        1,
        Record::default(),
        Backend::Gpu(GpuChoice {
            read_string: false,
            ..GpuChoice::default()
        }),
    )
    .expect("grower");
    let grown = g.derive(&options(4, 1), &mut |_| {}).expect("derives");
    assert!(grown.string.is_empty());
    assert!(grown.stats.last().expect("stats").modules > 0);
}

#[test]
fn a_gpu_forest_is_the_cpu_forest() {
    let plant = checked("stochastic_plant.grm");
    let hilbert = checked("hilbert3d.grm");
    let (cp, ch) = (compile(&plant), compile(&hilbert));
    let mut forest = Vec::new();
    for k in 0..5u32 {
        forest.push(ForestTree {
            system: system(&plant),
            compiled: &cp,
            iterations: 2 + k % 3,
            seed: k,
        });
        if k % 2 == 0 {
            forest.push(ForestTree {
                system: system(&hilbert),
                compiled: &ch,
                iterations: 2,
                seed: k,
            });
        }
    }
    let keep = |_: usize, s: &ModuleString| s.clone();
    let cpu_opts = ForestOptions {
        interpret: true,
        ..ForestOptions::default()
    };
    let cpu = grm_grow::forest::grow(&forest, &cpu_opts, &keep, &mut |_| {}).expect("cpu");
    let gpu_opts = ForestOptions {
        backend: Backend::Gpu(GpuChoice {
            cpu_prefix: 0,
            interpret: false,
            ..GpuChoice::default()
        }),
        ..cpu_opts
    };
    let gpu = grm_grow::forest::grow(&forest, &gpu_opts, &keep, &mut |_| {}).expect("gpu");
    assert!(matches!(gpu.ran, Ran::Gpu { bones: None, .. }));
    assert_eq!((gpu.modules, gpu.produced), (cpu.modules, cpu.produced));
    for (k, (a, b)) in cpu.trees.iter().zip(&gpu.trees).enumerate() {
        assert_eq!(a.kept.parts().syms, b.kept.parts().syms, "tree {k}");
        assert_eq!(a.kept.keys(), b.kept.keys(), "tree {k}");
        let (ia, ib) = (
            a.interpretation.as_ref().expect("cpu"),
            b.interpretation.as_ref().expect("gpu"),
        );
        assert_eq!(ia.bones.len(), ib.bones.len(), "tree {k}");
    }
    // Interpreted on the device and left there: the bone count only.
    let there = ForestOptions {
        interpret: false,
        backend: Backend::Gpu(GpuChoice {
            read_string: false,
            ..GpuChoice::default()
        }),
        ..ForestOptions::default()
    };
    let f = grm_grow::forest::grow(&forest, &there, &keep, &mut |_| {}).expect("gpu");
    assert!(f.trees.is_empty());
    let bones: usize = cpu
        .trees
        .iter()
        .map(|t| t.interpretation.as_ref().map_or(0, |i| i.bones.len()))
        .sum();
    assert!(matches!(f.ran, Ran::Gpu { bones: Some(b), .. } if b == bones as u64));
}

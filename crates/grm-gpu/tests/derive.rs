//! The GPU derivation against the CPU engine (grm-derive): the example
//! scenes, the hand-derived context-matching cases and many small random
//! grammars. Symbols and parameter starts must be identical; parameters
//! agree within `common::PARAM_TOLERANCE`.

mod common;
use common::*;
use grm_gpu::{GpuDeriveOptions, derive};

fn opts(sys: &grm_compile::CompiledSystem, iterations: u32, seed: u32) -> GpuDeriveOptions {
    GpuDeriveOptions {
        iterations,
        seed,
        ..GpuDeriveOptions::from_system(sys)
    }
}

/// Every derive-mode system of the examples, at iteration counts that keep
/// the strings small (lavapipe is slow), against the CPU.
#[test]
fn example_scenes_match_the_cpu() {
    let g = gpu();
    let cases: &[(&str, Option<&str>, u32)] = &[
        ("hilbert3d.grm", None, 3),
        ("koch_island.grm", None, 3),
        ("bracketed_plant.grm", None, 4),
        ("row_of_trees.grm", None, 6),
        ("ternary_tree.grm", None, 5),
        ("ternary_tree.grm", Some("TernaryTreeB"), 5),
        ("ternary_tree.grm", Some("TernaryTreeC"), 5),
        ("ternary_tree.grm", Some("TernaryTreeD"), 5),
        ("stochastic_plant.grm", None, 5),
        ("context_plant_a.grm", None, 24),
        ("context_plant_b.grm", None, 20),
    ];
    for &(file, system, iterations) in cases {
        let sys = example(file, system);
        for seed in [sys.settings.seed, 12345] {
            let cpu = cpu_derive(&sys, iterations, seed).expect("cpu derives");
            let gpu = derive(g, &sys, &opts(&sys, iterations, seed)).expect("gpu derives");
            assert_same(&format!("{file} {system:?} seed {seed}"), &cpu, &gpu.string);
            assert_eq!(gpu.stats.len(), iterations as usize + 1);
            assert_eq!(gpu.stats.last().map(|s| s.modules), Some(cpu.len() as u64));
        }
    }
}

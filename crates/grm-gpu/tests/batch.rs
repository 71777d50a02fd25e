//! The batched derivation (all iterations in one submission, buffers sized
//! from a bound computed from the tables) against the per-iteration one:
//! identical strings (bit for bit: the same kernels read the same input)
//! and identical errors, on the example scenes and random grammars; and
//! the fallbacks, when the bound is over a limit and when the device
//! reports an overflow.

mod common;
use common::*;
use grm_gpu::{DerivePath, DeriveStrategy, GpuDeriveOptions, derive_with};

#[test]
fn example_scenes_batched_equal_per_iteration() {
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
    let mut batched = 0;
    for &(file, system, iterations) in cases {
        let sys = example(file, system);
        for seed in [sys.settings.seed, 12345] {
            let o = gpu_opts(&sys, iterations, seed);
            let what = format!("{file} {system:?} seed {seed}");
            // Stepwise: the direct path would take the deterministic
            // context-free scenes (tests/direct.rs).
            let (a, pa) = derive_with(g, &sys, &o, DeriveStrategy::Stepwise).expect("derives");
            let (b, pb) = derive_with(g, &sys, &o, DeriveStrategy::PerIteration).expect("derives");
            assert_eq!(pb, DerivePath::PerIteration);
            // Context-sensitive systems need bracket matching per iteration.
            let expect = if sys.has_context() {
                DerivePath::PerIteration
            } else {
                DerivePath::Batched
            };
            assert_eq!(pa, expect, "{what}");
            batched += usize::from(pa == DerivePath::Batched);
            same_bits(&what, &a.string, &b.string);
            assert_eq!(figures(&a), figures(&b), "{what}: stats");
        }
    }
    assert!(batched >= 16, "only {batched} batched");
}

/// Random context-free grammars with conditions, constant and computed
/// weights, draws and parameter expressions that may go bad (division by
/// a counter that reaches zero): the batched path gives the per-iteration
/// path's string, or (after falling back) its exact error.
#[test]
fn random_grammars_batched_equal_per_iteration() {
    let g = gpu();
    let mut rng = Rng::seeded(77);
    let (mut compared, mut errors, mut batched) = (0, 0, 0);
    let mut tried = 0;
    while compared < 60 && tried < 400 {
        tried += 1;
        let src = random_grammar(&mut rng);
        let Some(sys) = inline(&src) else { continue };
        let iterations = 1 + rng.below(5) as u32;
        let seed = rng.below(1000) as u32;
        let o = GpuDeriveOptions {
            max_modules: 200_000,
            ..gpu_opts(&sys, iterations, seed)
        };
        let a = derive_with(g, &sys, &o, DeriveStrategy::Stepwise);
        let b = derive_with(g, &sys, &o, DeriveStrategy::PerIteration);
        match (&a, &b) {
            (Ok((a, pa)), Ok((b, _))) => {
                same_bits(&src, &a.string, &b.string);
                batched += usize::from(*pa == DerivePath::Batched);
            }
            (Err(ea), Err(eb)) => {
                assert_eq!(ea, eb, "{src}");
                errors += 1;
            }
            _ => panic!(
                "{src}\nauto: {:?}\nper iteration: {:?}",
                a.as_ref().map(|(d, p)| (d.string.len(), *p)),
                b.as_ref().map(|(d, p)| (d.string.len(), *p))
            ),
        }
        compared += 1;
    }
    eprintln!("{compared} compared of {tried}: {batched} batched, {errors} errors");
    assert!(compared >= 60, "only {compared} grammars");
    assert!(
        batched >= compared / 2,
        "only {batched} of {compared} batched"
    );
    assert!(errors > 0, "no runtime error exercised the fallback");
}

/// The device's overflow check (here forced: the last string's capacity
/// set to zero) discards the batched run; the per-iteration path gives the
/// string.
#[test]
fn a_device_overflow_falls_back_to_per_iteration() {
    let g = gpu();
    for (file, iterations) in [("hilbert3d.grm", 3), ("stochastic_plant.grm", 4)] {
        let sys = example(file, None);
        let o = gpu_opts(&sys, iterations, sys.settings.seed);
        let (a, pa) = derive_with(g, &sys, &o, DeriveStrategy::AutoShrunkCaps).expect("derives");
        assert_eq!(pa, DerivePath::BatchedThenPerIteration, "{file}");
        let (b, _) = derive_with(g, &sys, &o, DeriveStrategy::PerIteration).expect("derives");
        same_bits(file, &a.string, &b.string);
        assert_eq!(a.stats.len(), b.stats.len());
    }
}

/// A bound over the module limit (a conditional production that could
/// quadruple every module, though it never applies) derives iteration by
/// iteration, within the limit; a real excess is the per-iteration error.
#[test]
fn a_bound_over_a_limit_falls_back_to_per_iteration() {
    let g = gpu();
    let src = "system S { axiom A(1) A(2); A(x) : x > 100 -> A(x) A(x) A(x) A(x); A(x) -> A(x + 1) F(x); }";
    let sys = inline(src).expect("checks");
    let o = GpuDeriveOptions {
        max_modules: 100,
        ..gpu_opts(&sys, 6, 0)
    };
    let (a, pa) = derive_with(g, &sys, &o, DeriveStrategy::Auto).expect("derives");
    assert_eq!(pa, DerivePath::PerIteration);
    let (b, _) = derive_with(g, &sys, &o, DeriveStrategy::PerIteration).expect("derives");
    same_bits(src, &a.string, &b.string);
    assert_eq!(a.string.len(), 14);
    let cpu = cpu_derive(&sys, 6, 0).expect("cpu derives");
    assert_same(src, &cpu, &a.string);
    // With room for the bound, the same system is batched.
    let o = GpuDeriveOptions {
        max_modules: 1 << 20,
        ..o
    };
    let (c, pc) = derive_with(g, &sys, &o, DeriveStrategy::Auto).expect("derives");
    assert_eq!(pc, DerivePath::Batched);
    same_bits(src, &c.string, &b.string);
    // Over the limit for real: the per-iteration error, whichever path.
    let src = "system S { axiom A; A -> A A; }";
    let sys = inline(src).expect("checks");
    let o = GpuDeriveOptions {
        max_modules: 100,
        ..gpu_opts(&sys, 8, 0)
    };
    let ea = derive_with(g, &sys, &o, DeriveStrategy::Auto).map(|(_, p)| p);
    let eb = derive_with(g, &sys, &o, DeriveStrategy::PerIteration).map(|(_, p)| p);
    assert!(
        matches!(ea, Err(grm_gpu::GpuError::ModuleLimit { iteration: 7, .. })),
        "{ea:?}"
    );
    assert_eq!(ea, eb);
}

/// An input of more than SCAN_BLOCK^2 = 1,048,576 modules: three scan
/// levels (the fused count and first level, two levels of block sums and
/// an add), against the CPU, batched.
#[test]
fn an_input_past_a_million_modules_scans_three_levels() {
    let g = gpu();
    let sys = inline("system S { axiom A(0); A(x) -> A(x + 1) B(x * 2); B(x) -> A(x - 1); }")
        .expect("checks");
    // Fibonacci lengths: string 29 has 1,346,269 modules, string 30
    // 2,178,309.
    let o = GpuDeriveOptions {
        max_modules: 4_000_000,
        ..gpu_opts(&sys, 30, 0)
    };
    let (d, path) = derive_with(g, &sys, &o, DeriveStrategy::Stepwise).expect("derives");
    assert_eq!(path, DerivePath::Batched);
    assert_eq!(d.stats[29].modules, 1_346_269);
    let cpu = cpu_derive(&sys, 30, 0).expect("cpu derives");
    assert_same("fibonacci 30", &cpu, &d.string);
}

/// A loosely bounded system (one `F` in ten becomes ten: the bound takes
/// ten at every step, 1.9 are expected) after a CPU prefix of a few
/// thousand modules: its bound is far over the loose-bound budget, so it
/// used to derive iteration by iteration; sized from the expected sizes
/// (with a margin) it is batched, with the per-iteration string. Without
/// a prefix (nothing exact to project from) it still goes per iteration.
#[test]
fn a_loose_bound_is_batched_from_the_expected_sizes_after_a_cpu_prefix() {
    let g = gpu();
    let src =
        "system S { axiom F F F F F F F F F F; F -> (0.9) F; F -> (0.1) F F F F F F F F F F; }";
    let sys = inline(src).expect("checks");
    for seed in [1, 2, 3] {
        let o = GpuDeriveOptions {
            cpu_prefix: 20_000,
            max_modules: 1 << 30,
            ..gpu_opts(&sys, 14, seed)
        };
        let (a, pa) = derive_with(g, &sys, &o, DeriveStrategy::Stepwise).expect("derives");
        assert_eq!(pa, DerivePath::Batched, "seed {seed}");
        let k = a.stats.iter().filter(|s| s.on_cpu).count();
        assert!(
            a.stats[k - 1].modules >= grm_gpu::derive::PROJECT_MIN_MODULES,
            "seed {seed}: the prefix ended at {} modules",
            a.stats[k - 1].modules
        );
        let (b, _) = derive_with(g, &sys, &o, DeriveStrategy::PerIteration).expect("derives");
        same_bits(&format!("seed {seed}"), &a.string, &b.string);
        let cpu = cpu_derive(&sys, 14, seed).expect("cpu derives");
        assert_same(&format!("seed {seed}"), &cpu, &a.string);
        // A string over its projected size: the overflow flag, then the
        // per-iteration string (here forced: the last capacity zeroed).
        let (d, pd) = derive_with(g, &sys, &o, DeriveStrategy::AutoShrunkCaps).expect("derives");
        assert_eq!(pd, DerivePath::BatchedThenPerIteration, "seed {seed}");
        same_bits(&format!("seed {seed} overflow"), &d.string, &b.string);
        let o0 = GpuDeriveOptions { cpu_prefix: 0, ..o };
        let (c, pc) = derive_with(g, &sys, &o0, DeriveStrategy::Stepwise).expect("derives");
        assert_eq!(pc, DerivePath::PerIteration, "seed {seed}");
        same_bits(&format!("seed {seed} GPU only"), &c.string, &b.string);
    }
}

/// A long batched derivation is submitted in chunks of iterations (the host
/// holds one chunk of recorded commands, not all of them): across chunk
/// boundaries the string still equals the CPU's, stochastic choices and
/// parameters included.
#[test]
fn a_long_batched_derivation_crosses_submission_chunks() {
    let g = gpu();
    let sys = inline(
        "system S {
            axiom A(0) B;
            A(x) -> (1) A(x + 1);
            A(x) -> (2) A(x + 2);
            B -> B;
        }",
    )
    .expect("checks");
    let iterations = 2_500;
    let o = gpu_opts(&sys, iterations, 9);
    let (d, path) = derive_with(g, &sys, &o, DeriveStrategy::Stepwise).expect("derives");
    assert_eq!(path, DerivePath::Batched);
    let cpu = cpu_derive(&sys, iterations, 9).expect("CPU derives");
    assert_same("2,500 iterations", &cpu, &d.string);
    let x = cpu.params_of(0)[0];
    assert!(x > 2_500.0 && x < 5_000.0, "A({x})");
}

//! Identity keys on the GPU (`grm_compile::rng`, "Identity keys"): a
//! system that draws random numbers (stochastic alternatives, random
//! calls, a drawn axiom) derives on the GPU the CPU engine's string with
//! the CPU's keys, on every path (direct, batched, iteration by iteration,
//! from the CPU prefix or from the axiom on the device), alone and in a
//! forest with other systems; a system that draws nothing carries no keys
//! on either engine unless they are asked for (`GpuDeriveOptions::keys`,
//! the CPU's `Engine::with_keys`), and then the same keys on both, on every
//! path, the direct one included.

mod common;
use common::*;
use grm_compile::CompiledSystem;
use grm_gpu::{
    DerivePath, DeriveStrategy, GpuDeriveOptions, GpuJob, derive::CPU_PREFIX_MODULES, derive_many,
    derive_with,
};

/// CPU prefixes tried: none (every string on the device), a small one
/// (the device goes on from a short CPU string and its keys) and the
/// default.
const PREFIXES: [u64; 3] = [0, 40, CPU_PREFIX_MODULES];

fn opts(sys: &CompiledSystem, iterations: u32, seed: u32, cpu_prefix: u64) -> GpuDeriveOptions {
    GpuDeriveOptions {
        iterations,
        seed,
        cpu_prefix,
        ..GpuDeriveOptions::from_system(sys)
    }
}

/// `sys` derived on the GPU with each prefix and strategy is the CPU's
/// string, keys included; the keys are there exactly when the system
/// draws. Returns the paths taken.
fn check(what: &str, sys: &CompiledSystem, iterations: u32, seeds: &[u32]) -> Vec<DerivePath> {
    let g = gpu();
    let mut paths = Vec::new();
    for &seed in seeds {
        let cpu = cpu_derive(sys, iterations, seed).expect("cpu derives");
        assert_eq!(
            cpu.has_keys() && !cpu.keys().is_empty(),
            sys.draws_randomly() && !cpu.is_empty(),
            "{what}: the CPU carries keys where the system draws"
        );
        for prefix in PREFIXES {
            for strategy in [DeriveStrategy::Auto, DeriveStrategy::PerIteration] {
                let w = format!("{what} seed {seed} prefix {prefix} {strategy:?}");
                let o = opts(sys, iterations, seed, prefix);
                let (d, path) = derive_with(g, sys, &o, strategy).expect("gpu derives");
                assert_eq!(
                    d.string.keys().len(),
                    if sys.draws_randomly() {
                        d.string.len()
                    } else {
                        0
                    },
                    "{w}: keys"
                );
                assert_same(&w, &cpu, &d.string);
                paths.push(path);
            }
        }
    }
    paths
}

#[test]
fn stochastic_systems_carry_the_cpu_keys() {
    let plant = example("stochastic_plant.grm", None);
    assert!(plant.draws_randomly());
    let paths = check("stochastic plant", &plant, 5, &[0, 1, 77]);
    assert!(paths.contains(&DerivePath::Batched), "{paths:?}");
    assert!(paths.contains(&DerivePath::PerIteration), "{paths:?}");
    for (what, src, n) in [
        // Random calls only: keyed, no alternatives.
        (
            "random calls",
            "system R { axiom A(1); A(x) -> F(uniform(0, 1)) [ + A(x + 1) ] B(randint(0, 9)) A(x); B(y) -> B(y + normal(0, 1)); }",
            5,
        ),
        // Stochastic alternatives in context (rewritten by input module),
        // conditions that draw, copies.
        (
            "stochastic contexts",
            "system C { axiom F a F b F a F a; ignore F; a < b -> (1) b F b; a < b -> (2) a [ + b ]; b < a : chance(0.5) -> b a; a -> (3) a; a -> (1) F a; }",
            6,
        ),
        // A context-sensitive system with a successor over
        // LONG_SUCCESSOR modules (rewritten by output module with
        // contexts).
        (
            "long successor in context",
            &format!(
                "system L {{ axiom a b a; a < b -> (1) b {} ; a < b -> (1) a; b -> (1) b; b -> (1) a F(uniform(0, 2)); }}",
                "F(uniform(0, 1)) ".repeat(70)
            ),
            3,
        ),
    ] {
        let sys = inline(src).unwrap_or_else(|| panic!("{what} checks"));
        assert!(sys.draws_randomly(), "{what}");
        check(what, &sys, n, &[0, 5, 4242]);
    }
}

#[test]
fn deterministic_systems_carry_no_keys() {
    for (file, n) in [("hilbert3d.grm", 2), ("context_plant_b.grm", 12)] {
        let sys = example(file, None);
        assert!(!sys.draws_randomly(), "{file}");
        check(file, &sys, n, &[3]);
    }
}

/// A forest mixing systems that draw (alternatives, random calls, a drawn
/// axiom) and systems that draw nothing, with several seeds: each job's
/// string is its own CPU derivation, its keys included where its system
/// draws, with and without the CPU prefix, derived together
/// (`derive_many`) or derived and interpreted together (`run_many`).
#[test]
fn a_mixed_forest_carries_each_systems_keys() {
    let g = gpu();
    let program = |(p, c): (grm_sema::Program, CompiledSystem)| {
        let t = grm_gpu::TurtleProgram::new(p.default_system().expect("system"), &c.settings);
        (c, t)
    };
    let file = |f: &str| {
        let (p, _, c) = example_program(f, None);
        program((p, c))
    };
    let text = |src: &str| program(inline_program(src).expect("checks"));
    // 0: alternatives, 1: nothing drawn, 2: nothing drawn, contexts,
    // 3: random calls, 4: a drawn axiom.
    let loaded = [
        file("stochastic_plant.grm"),
        file("hilbert3d.grm"),
        file("context_plant_b.grm"),
        text("system R { axiom A(1); A(x) -> F(uniform(0, 1)) [ + A(x + 1) ] A(x * 0.5); }"),
        text("system D { axiom F(uniform(1, 2)) A +(uniform(0, 90)); A -> F [ + A ] A; }"),
    ];
    let mut jobs = Vec::new();
    let mut turtles = Vec::new();
    let mut add = |k: usize, iterations: u32, seed: u32| {
        jobs.push(GpuJob {
            system: &loaded[k].0,
            iterations,
            seed,
        });
        turtles.push(&loaded[k].1);
    };
    for seed in 0..6u32 {
        add(0, 2 + seed % 3, seed * 31);
        match seed {
            1 => add(1, 2, 0),
            2 => add(3, 5, 9),
            4 => add(2, 10, 0),
            _ => {}
        }
    }
    add(4, 4, 12);
    add(3, 4, 10);
    let want: Vec<_> = jobs
        .iter()
        .map(|j| cpu_derive(j.system, j.iterations, j.seed).expect("cpu derives"))
        .collect();
    let compare = |what: &str, strings: &[grm_derive::ModuleString]| {
        assert_eq!(strings.len(), jobs.len());
        for (k, ((job, got), want)) in jobs.iter().zip(strings).zip(&want).enumerate() {
            let what = format!("{what}: job {k} ({}, seed {})", job.system.name, job.seed);
            assert_eq!(
                !got.keys().is_empty(),
                job.system.draws_randomly() && !got.is_empty(),
                "{what}: keys"
            );
            assert_same(&what, want, got);
        }
    };
    for prefix in PREFIXES {
        let o = GpuDeriveOptions {
            cpu_prefix: prefix,
            ..GpuDeriveOptions::from_system(&loaded[0].0)
        };
        let out = derive_many(g, &jobs, &o).expect("derives");
        compare(&format!("derive_many, prefix {prefix}"), &out.strings);
        let run = grm_gpu::GpuRunOptions {
            derive: o,
            interpret: true,
            read_string: true,
            read_bones: false,
            strategy: DeriveStrategy::Auto,
            branch_scan: grm_gpu::interp::BranchScan::Auto,
            pipelined: false,
        };
        let r = grm_gpu::run_many(g, &jobs, &turtles, &run, &mut |_| {}).expect("runs");
        compare(
            &format!("run_many, prefix {prefix}"),
            &r.strings.expect("read"),
        );
    }
}

/// `sys` derived with keys asked for: the CPU engine's string and keys
/// (`Engine::with_keys`), on every path and prefix; returns the paths.
fn check_asked(what: &str, sys: &CompiledSystem, iterations: u32, seed: u32) -> Vec<DerivePath> {
    let g = gpu();
    let cpu = grm_derive::Engine::new(sys, 1)
        .expect("engine")
        .with_keys(true)
        .derive(
            &grm_derive::DeriveOptions {
                iterations,
                seed,
                limits: grm_derive::DeriveLimits::default(),
            },
            &mut |_| {},
        )
        .expect("cpu derives")
        .string;
    assert_eq!(
        cpu.keys().len(),
        cpu.len(),
        "{what}: the CPU keys every module"
    );
    let mut paths = Vec::new();
    for prefix in PREFIXES {
        for strategy in [DeriveStrategy::Auto, DeriveStrategy::PerIteration] {
            let w = format!("{what} seed {seed} prefix {prefix} {strategy:?}, keys asked for");
            let o = GpuDeriveOptions {
                keys: true,
                ..opts(sys, iterations, seed, prefix)
            };
            let (d, path) = derive_with(g, sys, &o, strategy).expect("gpu derives");
            assert_eq!(d.string.keys().len(), d.string.len(), "{w}: keys");
            assert_same(&w, &cpu, &d.string);
            paths.push(path);
        }
    }
    paths
}

/// `grmc derive --gpu -o x.glb` names a deterministic system's parts by
/// their keys: asked for, the GPU carries the CPU's keys, directly (the
/// final string in one pass), batched and iteration by iteration; one run
/// (`run`, as grm-grow calls it) and a forest (`derive_many`) too.
#[test]
fn deterministic_systems_carry_the_cpu_keys_when_asked() {
    let mut paths = Vec::new();
    for (file, n) in [
        ("hilbert3d.grm", 2),
        ("context_plant_b.grm", 12),
        ("ternary_tree.grm", 4),
    ] {
        let sys = example(file, None);
        assert!(!sys.draws_randomly(), "{file}");
        paths.extend(check_asked(file, &sys, n, 3));
    }
    assert!(paths.contains(&DerivePath::Direct), "{paths:?}");
    assert!(paths.contains(&DerivePath::PerIteration), "{paths:?}");
    // One run, derived and interpreted, its string read back.
    let (p, _, sys) = example_program("ternary_tree.grm", None);
    let turtle = grm_gpu::TurtleProgram::new(p.default_system().expect("system"), &sys.settings);
    let run = grm_gpu::GpuRunOptions {
        derive: GpuDeriveOptions {
            keys: true,
            ..opts(&sys, 4, 0, 0)
        },
        interpret: true,
        read_string: true,
        read_bones: false,
        strategy: DeriveStrategy::Auto,
        branch_scan: grm_gpu::interp::BranchScan::Auto,
        pipelined: true,
    };
    let r = grm_gpu::run(gpu(), &sys, &turtle, &run, &mut |_| {}).expect("runs");
    let want = grm_derive::Engine::new(&sys, 1)
        .expect("engine")
        .with_keys(true)
        .derive(
            &grm_derive::DeriveOptions {
                iterations: 4,
                seed: 0,
                limits: grm_derive::DeriveLimits::default(),
            },
            &mut |_| {},
        )
        .expect("cpu derives")
        .string;
    let got = r.string.expect("read");
    assert!(!got.keys().is_empty());
    assert_same("run, keys asked for", &want, &got);
    // A forest of seeds: every tree keyed, as derived alone.
    let jobs: Vec<GpuJob<'_>> = (0..3)
        .map(|seed| GpuJob {
            system: &sys,
            iterations: 3,
            seed,
        })
        .collect();
    let o = GpuDeriveOptions {
        keys: true,
        ..opts(&sys, 0, 0, 0)
    };
    let out = derive_many(gpu(), &jobs, &o).expect("derives");
    for (k, s) in out.strings.iter().enumerate() {
        let (d, _) = derive_with(
            gpu(),
            &sys,
            &GpuDeriveOptions {
                keys: true,
                ..opts(&sys, 3, k as u32, 0)
            },
            DeriveStrategy::PerIteration,
        )
        .expect("derives");
        assert_eq!(s.keys().len(), s.len(), "tree {k}: keys");
        assert_same(&format!("forest tree {k}, keys asked for"), &d.string, s);
    }
    // Without the option nothing changes: no keys.
    let (d, _) =
        derive_with(gpu(), &sys, &opts(&sys, 3, 0, 0), DeriveStrategy::Auto).expect("derives");
    assert!(d.string.keys().is_empty());
}

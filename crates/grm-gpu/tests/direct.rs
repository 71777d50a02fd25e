//! The direct derivation (the final string of deterministic, context-free
//! systems in one pass, `shaders/expand.wgsl`) against the
//! CPU and the stepwise GPU paths: the same string and the same figures
//! for every string, on the example scenes, random grammars (erasing
//! productions, symbols without productions, branches, constant and
//! computed parameters, faults) and forests; the
//! limits, the CPU prefix and the step cap send a derivation the stepwise
//! way, with the stepwise errors.

mod common;
use common::*;
use grm_gpu::{
    DIRECT_MAX_STEPS, DerivePath, DeriveStrategy, GpuDeriveOptions, GpuError, GpuJob, derive_many,
    derive_with,
};

fn opts(sys: &grm_compile::CompiledSystem, iterations: u32) -> GpuDeriveOptions {
    GpuDeriveOptions {
        iterations,
        cpu_prefix: 0,
        ..GpuDeriveOptions::from_system(sys)
    }
}

/// Direct, stepwise and CPU agree on `sys` at `iterations`; the path taken
/// by `Auto` is returned.
fn compare(what: &str, sys: &grm_compile::CompiledSystem, o: &GpuDeriveOptions) -> DerivePath {
    let g = gpu();
    let (a, pa) = derive_with(g, sys, o, DeriveStrategy::Auto).expect("derives");
    let (b, _) = derive_with(g, sys, o, DeriveStrategy::Stepwise).expect("derives");
    same_bits(what, &a.string, &b.string);
    assert_eq!(figures(&a), figures(&b), "{what}: figures");
    let cpu = cpu_derive(sys, o.iterations, o.seed).expect("cpu derives");
    assert_same(what, &cpu, &a.string);
    pa
}

#[test]
fn deterministic_example_scenes_derive_directly() {
    for (file, system, iterations) in [
        ("hilbert3d.grm", None, 4),
        ("koch_island.grm", None, 3),
        ("bracketed_plant.grm", None, 4),
        // Computed parameters (`F(l) -> F(l * lr)`).
        ("ternary_tree.grm", None, 5),
        ("ternary_tree.grm", Some("TernaryTreeB"), 5),
        ("ternary_tree.grm", Some("TernaryTreeC"), 5),
        ("ternary_tree.grm", Some("TernaryTreeD"), 5),
    ] {
        let sys = example(file, system);
        for n in [1, iterations] {
            let what = format!("{file} {system:?} at {n}");
            let path = compare(&what, &sys, &opts(&sys, n));
            assert_eq!(path, DerivePath::Direct, "{what}");
        }
    }
    // Stochastic and context-sensitive scenes are derived step by step;
    // so is the row of trees, whose every final `F` would evaluate its
    // whole chain `x * p * ...` (DIRECT_MAX_EVAL_RATIO).
    for (file, n) in [
        ("row_of_trees.grm", 6),
        ("stochastic_plant.grm", 3),
        ("context_plant_a.grm", 10),
        ("context_plant_b.grm", 10),
    ] {
        let sys = example(file, None);
        let path = compare(file, &sys, &opts(&sys, n));
        assert_ne!(path, DerivePath::Direct, "{file}");
    }
}

/// A random deterministic grammar with computed parameters: `A(x)` and
/// `B(x)` rewrite with expressions of `x` (some of which fault or leave
/// the finite range: `1 / (x - 2)`, `sqrt(x - 3)`, `x * 1e30`), constant
/// parameters and copies; sometimes a random draw (`uniform`), which the
/// direct path cannot take.
fn random_parametric(rng: &mut Rng) -> String {
    let exprs = [
        "x",
        "x * 0.5",
        "x + 1",
        "2",
        "x - 1",
        "1 / (x - 2)",
        "sqrt(x - 3)",
        "x * 1e30",
        "x * x",
        "-x",
    ];
    let module = |rng: &mut Rng| -> String {
        let e = exprs[rng.below(exprs.len() as u64) as usize];
        match rng.below(6) {
            0 => format!("F({e})"),
            1 => format!("+({e})"),
            2 => "F".into(),
            3 => format!("B({e})"),
            _ => format!("A({e})"),
        }
    };
    let mut src = String::from("system S {\n    axiom A(1) B(3);\n");
    for name in ["A", "B"] {
        src.push_str(&format!("    {name}(x) ->"));
        for k in 0..rng.below(6) {
            if k == 1 && rng.below(4) == 0 {
                src.push_str(" [ + A(x) ]");
            }
            src.push(' ');
            src.push_str(&module(rng));
        }
        if rng.below(12) == 0 {
            src.push_str(" F(uniform(0, x))");
        }
        src.push_str(";\n");
    }
    src.push_str("}\n");
    src
}

#[test]
fn random_parametric_grammars_derive_directly_or_fail_alike() {
    let g = gpu();
    let mut rng = Rng::seeded(99);
    let (mut direct, mut errors, mut drawn, mut tried) = (0, 0, 0, 0);
    while (direct < 40 || errors < 5) && tried < 600 {
        tried += 1;
        let src = random_parametric(&mut rng);
        let Some(sys) = inline(&src) else { continue };
        let iterations = 1 + rng.below(7) as u32;
        let o = GpuDeriveOptions {
            max_modules: 300_000,
            ..opts(&sys, iterations)
        };
        let auto = derive_with(g, &sys, &o, DeriveStrategy::Auto);
        let step = derive_with(g, &sys, &o, DeriveStrategy::Stepwise);
        let what = format!("{src} at {iterations}");
        match (auto, step) {
            (Ok((a, pa)), Ok((b, _))) => {
                same_bits(&what, &a.string, &b.string);
                assert_eq!(figures(&a), figures(&b), "{what}: figures");
                let cpu = cpu_derive(&sys, iterations, 0).expect("cpu derives");
                assert_same(&what, &cpu, &a.string);
                if src.contains("uniform") {
                    assert_ne!(pa, DerivePath::Direct, "{what}");
                    drawn += 1;
                } else {
                    // Direct unless the walks would evaluate too much.
                    direct += usize::from(pa == DerivePath::Direct);
                }
            }
            // A fault, a non-finite value or the module limit: the
            // stepwise error either way.
            (Err(ea), Err(eb)) => {
                assert_eq!(ea, eb, "{what}");
                errors += 1;
            }
            (a, b) => panic!(
                "{what}\nauto: {:?}\nstepwise: {:?}",
                a.map(|(_, p)| p),
                b.map(|(_, p)| p)
            ),
        }
    }
    eprintln!("{tried} tried: {direct} direct, {errors} errors, {drawn} with draws");
    assert!(direct >= 40, "only {direct} direct derivations");
    assert!(errors >= 5, "only {errors} errors");
    assert!(drawn > 0, "no grammar with draws");
}

/// A random deterministic grammar with constant parameters only: up to
/// six nonterminals, each with one production or none, successors of 0
/// to 7 modules (erasing ones included) with turtle symbols (their default
/// parameters or constants of their own, in the axiom too) and branches.
fn random_deterministic(rng: &mut Rng) -> String {
    let names = ["A", "B", "C", "D", "E", "G"];
    let k = 1 + rng.below(names.len() as u64) as usize;
    let pick = |rng: &mut Rng| -> String {
        match rng.below(8) {
            0 => "F".into(),
            1 => "+".into(),
            2 => "-".into(),
            // Constant parameters of their own.
            3 => format!("F({})", rng.below(9) as f32 / 4.0),
            4 => format!("+({})", 5 * rng.below(19)),
            _ => names[rng.below(k as u64) as usize].into(),
        }
    };
    let mut src = String::from("system S {\n    axiom");
    for _ in 0..1 + rng.below(3) {
        src.push(' ');
        src.push_str(&pick(rng));
    }
    src.push_str(";\n");
    for name in &names[..k] {
        if rng.below(5) == 0 {
            continue;
        }
        src.push_str(&format!("    {name} ->"));
        let len = rng.below(8);
        let mut open = false;
        for _ in 0..len {
            if !open && rng.below(6) == 0 {
                src.push_str(" [");
                open = true;
            }
            src.push(' ');
            src.push_str(&pick(rng));
            if open && rng.below(3) == 0 {
                src.push_str(" ]");
                open = false;
            }
        }
        if open {
            src.push_str(" ]");
        }
        src.push_str(";\n");
    }
    src.push_str("}\n");
    src
}

#[test]
fn random_deterministic_grammars_derive_directly() {
    let mut rng = Rng::seeded(2026);
    let (mut direct, mut tried) = (0, 0);
    while direct < 60 && tried < 400 {
        tried += 1;
        let src = random_deterministic(&mut rng);
        let Some(sys) = inline(&src) else { continue };
        let iterations = 1 + rng.below(9) as u32;
        let o = GpuDeriveOptions {
            max_modules: 300_000,
            ..opts(&sys, iterations)
        };
        let g = gpu();
        let auto = derive_with(g, &sys, &o, DeriveStrategy::Auto);
        let step = derive_with(g, &sys, &o, DeriveStrategy::Stepwise);
        match (auto, step) {
            (Ok((a, pa)), Ok((b, _))) => {
                let what = format!("{src} at {iterations}");
                same_bits(&what, &a.string, &b.string);
                assert_eq!(figures(&a), figures(&b), "{what}: figures");
                let cpu = cpu_derive(&sys, iterations, 0).expect("cpu derives");
                assert_same(&what, &cpu, &a.string);
                assert_eq!(pa, DerivePath::Direct, "{what}");
                direct += 1;
            }
            // Over the module limit: the stepwise error either way.
            (Err(ea), Err(eb)) => assert_eq!(ea, eb, "{src}"),
            (a, b) => panic!("{src}\nauto: {:?}\nstepwise: {:?}", a.is_ok(), b.is_ok()),
        }
    }
    assert!(direct >= 60, "only {direct} direct derivations in {tried}");
}

/// A forest of deterministic systems (constant and computed parameters)
/// with their own iteration counts in one direct dispatch: each string is
/// the CPU's for that system alone, and the directory gives each system's
/// range.
#[test]
fn a_deterministic_forest_derives_directly() {
    let g = gpu();
    let hilbert = example("hilbert3d.grm", None);
    let koch = example("koch_island.grm", None);
    let plant = example("bracketed_plant.grm", None);
    let erasing = inline("system S { axiom A B A; A -> A B [ + A ]; B -> ; }").expect("checks");
    let ternary = example("ternary_tree.grm", Some("TernaryTreeC"));
    let ternary_d = example("ternary_tree.grm", Some("TernaryTreeD"));
    let jobs = [
        (&hilbert, 3),
        (&ternary, 4),
        (&koch, 2),
        (&plant, 3),
        (&erasing, 5),
        (&hilbert, 1),
        (&ternary_d, 2),
        (&koch, 0),
    ]
    .map(|(system, iterations)| GpuJob {
        system,
        iterations,
        seed: 0,
    });
    let o = GpuDeriveOptions {
        iterations: 0,
        seed: 0,
        max_modules: 1 << 24,
        max_bytes: u64::MAX,
        sync_iterations: false,
        cpu_prefix: 0,
        keys: false,
    };
    let out = derive_many(g, &jobs, &o).expect("derives");
    assert_eq!(out.strings.len(), jobs.len());
    for (j, (job, s)) in jobs.iter().zip(&out.strings).enumerate() {
        let cpu = cpu_derive(job.system, job.iterations, 0).expect("cpu derives");
        assert_same(&format!("job {j}"), &cpu, s);
    }
    let total: u64 = out.strings.iter().map(|s| s.len() as u64).sum();
    assert_eq!(out.stats.last().map(|s| s.modules), Some(total));
}

/// Limits: a string of the stepwise derivation over the module limit, even
/// an intermediate one longer than the final string (an erasing
/// production), is the stepwise error.
#[test]
fn limits_are_the_stepwise_ones() {
    let g = gpu();
    // Strings: A; A A A A E (5); then every A erases: ... the longest is
    // string 1 with 5 modules, the final one has 1.
    let src = "system S { axiom A; A -> B B B B E; B -> ; }";
    let sys = inline(src).expect("checks");
    let o = GpuDeriveOptions {
        max_modules: 4,
        ..opts(&sys, 2)
    };
    let ea = derive_with(g, &sys, &o, DeriveStrategy::Auto).map(|(_, p)| p);
    let eb = derive_with(g, &sys, &o, DeriveStrategy::PerIteration).map(|(_, p)| p);
    assert!(
        matches!(ea, Err(GpuError::ModuleLimit { iteration: 1, .. })),
        "{ea:?}"
    );
    assert_eq!(ea, eb);
    let o = GpuDeriveOptions {
        max_modules: 5,
        ..o
    };
    assert_eq!(compare(src, &sys, &o), DerivePath::Direct);
    let sys = inline("system S { axiom A; A -> A A; }").expect("checks");
    let o = GpuDeriveOptions {
        max_modules: 1000,
        ..opts(&sys, 12)
    };
    let ea = derive_with(g, &sys, &o, DeriveStrategy::Auto).map(|(_, p)| p);
    assert!(
        matches!(ea, Err(GpuError::ModuleLimit { iteration: 10, .. })),
        "{ea:?}"
    );
    let eb = derive_with(g, &sys, &o, DeriveStrategy::PerIteration).map(|(_, p)| p);
    assert_eq!(ea, eb);
}

/// Within the CPU prefix the CPU derives the whole string; past the step
/// cap (a slowly growing string) the derivation is stepwise; both give the
/// direct path's string.
#[test]
fn the_cpu_prefix_and_the_step_cap_choose_stepwise() {
    let sys = example("hilbert3d.grm", None);
    let small = GpuDeriveOptions {
        cpu_prefix: 1 << 20,
        ..opts(&sys, 3)
    };
    assert_ne!(
        compare("hilbert3d in the prefix", &sys, &small),
        DerivePath::Direct
    );
    let large = GpuDeriveOptions {
        cpu_prefix: 1000,
        ..opts(&sys, 4)
    };
    assert_eq!(
        compare("hilbert3d past the prefix", &sys, &large),
        DerivePath::Direct
    );
    let slow = inline("system S { axiom A; A -> F A; }").expect("checks");
    let n = DIRECT_MAX_STEPS;
    assert_eq!(
        compare("linear at the cap", &slow, &opts(&slow, n)),
        DerivePath::Direct
    );
    assert_ne!(
        compare("linear past the cap", &slow, &opts(&slow, n + 1)),
        DerivePath::Direct
    );
}

/// A computed parameter that no walk evaluates (its module is erased, or
/// its descendants' parameters are all constants) can still fail: the
/// stepwise derivation and the CPU evaluate it and report the error, so
/// such a system is not derived directly (found by a `GRM_TEST_SEED` soak:
/// the direct path returned a string where the CPU reported
/// `sqrt(-2)`). Where every computed slot reaches the final string
/// through computed slots, the direct path stays.
#[test]
fn computed_parameters_no_walk_evaluates_go_stepwise() {
    let g = gpu();
    for (src, n) in [
        // Erased.
        (
            "system S { axiom A(1) B(3); A(x) -> +(x * x) B(sqrt(x - 3)); B(x) ->; }",
            4,
        ),
        // Only constant parameters below.
        (
            "system S { axiom A(1); A(x) -> F(x) B(sqrt(x - 3)); B(y) -> F +; }",
            3,
        ),
        // Below a branch, erased two steps later.
        (
            "system S { axiom A(1); A(x) -> F [ B(1 / (x - 1)) ]; B(y) -> C(y); C(z) ->; }",
            5,
        ),
    ] {
        let sys = inline(src).expect("checks");
        let o = opts(&sys, n);
        let cpu = cpu_derive(&sys, n, 0);
        let Err(grm_derive::DeriveError::Runtime(e)) = cpu else {
            panic!("{src}: the CPU derives {cpu:?}")
        };
        let (auto, step) = (
            derive_with(g, &sys, &o, DeriveStrategy::Auto),
            derive_with(g, &sys, &o, DeriveStrategy::Stepwise),
        );
        match (&auto, &step) {
            (
                Err(
                    a @ GpuError::Runtime {
                        iteration,
                        position,
                        ..
                    },
                ),
                Err(b),
            ) => {
                assert_eq!(a, b, "{src}");
                assert_eq!((e.iteration, e.position), (*iteration, *position), "{src}");
            }
            _ => panic!(
                "{src}\nauto: {:?}\nstepwise: {:?}",
                auto.map(|(_, p)| p),
                step.map(|(_, p)| p)
            ),
        }
    }
    // The same shapes with parameters that stay finite: stepwise where a
    // computation is walked by no final module, direct where all are.
    for (src, direct) in [
        (
            "system S { axiom A(1) B(3); A(x) -> +(x * x) B(x + 3); B(x) ->; }",
            false,
        ),
        (
            "system S { axiom A(1); A(x) -> F(x) B(x + 3); B(y) -> F +; }",
            false,
        ),
        (
            "system S { axiom A(1); A(x) -> F(x) B(x + 3); B(y) -> F(y) +; }",
            true,
        ),
        (
            "system S { axiom A(1); A(x) -> F(x) [ A(x * 0.5) ] B(x); B(y) -> F(y * 2); }",
            true,
        ),
    ] {
        let sys = inline(src).expect("checks");
        for n in [1, 4] {
            let path = compare(src, &sys, &opts(&sys, n));
            // At one step every computed module is final, so walked.
            assert_eq!(path == DerivePath::Direct, direct || n == 1, "{src} at {n}");
        }
    }
}

/// An axiom that draws (`F(uniform(1, 2))`) is evaluated by the CPU
/// engine, with the derivation's seed; a constant one is read from the
/// tables. Either way the direct string is the stepwise and CPU one.
#[test]
fn drawn_and_constant_axioms_derive_directly() {
    for src in [
        "system S { axiom F(uniform(1, 2)) A +(uniform(0, 90)); A -> F [ + A ] A; }",
        "system S { axiom F(2) A +(30); A -> F [ + A ] A; }",
    ] {
        let sys = inline(src).expect("checks");
        for seed in [0, 7, 1234] {
            let o = GpuDeriveOptions {
                seed,
                ..opts(&sys, 8)
            };
            assert_eq!(
                compare(src, &sys, &o),
                DerivePath::Direct,
                "{src} seed {seed}"
            );
        }
    }
}

/// Derive directly and interpret: the bones (read back) and whether they
/// came from the tables (the direct interpretation).
fn run_bones(
    sys: &grm_sema::System,
    c: &grm_compile::CompiledSystem,
    n: u32,
) -> (grm_gpu::GpuRun, Vec<grm_gpu::layout::GpuBone>) {
    let g = gpu();
    let opts = grm_gpu::GpuRunOptions {
        derive: opts(c, n),
        interpret: true,
        read_string: true,
        read_bones: true,
        strategy: DeriveStrategy::Auto,
        branch_scan: grm_gpu::interp::BranchScan::Auto,
        pipelined: false,
    };
    let turtle = grm_gpu::TurtleProgram::new(sys, &c.settings);
    let mut r = grm_gpu::run(g, c, &turtle, &opts, &mut |_| {}).expect("runs");
    let bones = std::mem::take(&mut r.interpretation.as_mut().expect("interpreted").bones);
    (r, bones)
}

/// A string of affine commands derived directly is interpreted from the
/// expansion tables (shaders/expand_turtle.wgsl), without reading the
/// string: the CPU turtle's bones (parents included), on Hilbert 3D, the
/// Koch island and the bracketed plant at every iteration count up to 5,
/// 4 and 4, and on random grammars with every affine command, constant
/// parameters and nested branches. Walked strings (tropism) are
/// interpreted from the string.
#[test]
fn direct_derivations_of_affine_turtles_are_interpreted_from_their_tables() {
    for (file, top) in [
        ("hilbert3d.grm", 5),
        ("koch_island.grm", 4),
        ("bracketed_plant.grm", 4),
    ] {
        let (p, name, c) = example_program(file, None);
        let sys = p.system(&name).expect("system");
        for n in 1..=top {
            let (r, bones) = run_bones(sys, &c, n);
            assert_eq!(r.path, DerivePath::Direct, "{file} {n}");
            let i = r.interpretation.as_ref().expect("interpreted");
            assert!(i.direct, "{file} {n}: interpreted from the tables");
            let string = cpu_derive(&c, n, c.settings.seed).expect("cpu derives");
            same_bits(file, &string, r.string.as_ref().expect("read"));
            let cpu = grm_turtle::interpret(sys, &c.settings, &string).expect("cpu interprets");
            assert_bones_match(&format!("{file} {n}"), &cpu, &bones);
        }
    }
    // Tropism: the turtle walks its branches, from the string.
    let (p, name, c) = example_program("ternary_tree.grm", None);
    let sys = p.system(&name).expect("system");
    let (r, _) = run_bones(sys, &c, 3);
    assert_eq!(r.path, DerivePath::Direct);
    assert!(!r.interpretation.expect("interpreted").direct);
    let mut rng = Rng::seeded(5150);
    let cmds = [
        "F",
        "F(0.5)",
        "f",
        "f(2)",
        "+",
        "-(30)",
        "&",
        "^(45)",
        "/",
        "\\(10)",
        "|",
        "!(0.3)",
        "!",
        "G(1.5)",
        "rotx(20)",
        "scale(1.1)",
    ];
    let mut done = 0;
    for _ in 0..200 {
        if done >= 25 {
            break;
        }
        let names = ["A", "B", "C"];
        let pick = |rng: &mut Rng| -> String {
            if rng.below(3) == 0 {
                names[rng.below(3) as usize].to_string()
            } else {
                cmds[rng.below(cmds.len() as u64) as usize].to_string()
            }
        };
        let mut src = String::from("system S {\n    angle = 37;\n    axiom");
        for _ in 0..1 + rng.below(3) {
            src.push(' ');
            src.push_str(&pick(&mut rng));
        }
        src.push_str(" A;\n");
        for name in names {
            src.push_str(&format!("    {name} ->"));
            // Balanced branches, nested up to three deep.
            let mut open = 0;
            for _ in 0..rng.below(8) {
                match rng.below(5) {
                    0 if open < 3 => {
                        src.push_str(" [");
                        open += 1;
                    }
                    1 if open > 0 => {
                        src.push_str(" ]");
                        open -= 1;
                    }
                    _ => {
                        src.push(' ');
                        src.push_str(&pick(&mut rng));
                    }
                }
            }
            for _ in 0..open {
                src.push_str(" ]");
            }
            src.push_str(";\n");
        }
        src.push_str("}\n");
        let Some((p, c)) = inline_program(&src) else {
            continue;
        };
        let sys = p.default_system().expect("system");
        let n = 1 + rng.below(6) as u32;
        let cpu_string = cpu_derive(&c, n, 0).expect("cpu derives");
        if cpu_string.len() as u64 > 200_000 {
            continue;
        }
        let (r, bones) = run_bones(sys, &c, n);
        if r.path != DerivePath::Direct {
            // Within the CPU prefix or otherwise stepwise: not this test.
            continue;
        }
        let i = r.interpretation.as_ref().expect("interpreted");
        assert!(i.direct, "{src}");
        let cpu = grm_turtle::interpret(sys, &c.settings, &cpu_string).expect("cpu interprets");
        assert_bones_match(&format!("{src} at {n}"), &cpu, &bones);
        done += 1;
    }
    assert!(done >= 25, "only {done} random grammars");
}

/// Pipelined (`GpuRunOptions::pipelined`): a direct derivation with
/// computed parameters is not waited for, its status is read with the
/// interpretation's results, and where a value failed the run is done
/// again unpipelined. Either way the outcome is the unpipelined run's:
/// the same string and bones, or the same error.
#[test]
fn pipelined_runs_give_the_unpipelined_outcome() {
    let g = gpu();
    let mut rng = Rng::seeded(4242);
    let (mut ok, mut errors, mut tried) = (0, 0, 0);
    while (ok < 20 || errors < 5) && tried < 400 {
        tried += 1;
        let src = random_parametric(&mut rng);
        if src.contains("uniform") {
            continue;
        }
        let Some((p, c)) = inline_program(&src) else {
            continue;
        };
        let sys = p.default_system().expect("system");
        let turtle = grm_gpu::TurtleProgram::new(sys, &c.settings);
        let iterations = 1 + rng.below(6) as u32;
        let mut o = grm_gpu::GpuRunOptions {
            derive: GpuDeriveOptions {
                max_modules: 300_000,
                ..opts(&c, iterations)
            },
            interpret: true,
            read_string: true,
            read_bones: true,
            strategy: DeriveStrategy::Auto,
            branch_scan: grm_gpu::BranchScan::Auto,
            pipelined: false,
        };
        let apart = grm_gpu::run(g, &c, &turtle, &o, &mut |_| {});
        o.pipelined = true;
        let together = grm_gpu::run(g, &c, &turtle, &o, &mut |_| {});
        let what = format!("{src} at {iterations}");
        match (apart, together) {
            (Ok(a), Ok(b)) => {
                let read = |r: &grm_gpu::GpuRun| r.string.clone().expect("read");
                same_bits(&what, &read(&a), &read(&b));
                let bones =
                    |r: &grm_gpu::GpuRun| r.interpretation.clone().expect("interpreted").bones;
                assert_eq!(bones(&a), bones(&b), "{what}: bones");
                ok += 1;
            }
            (Err(ea), Err(eb)) => {
                assert_eq!(ea, eb, "{what}");
                errors += 1;
            }
            (a, b) => panic!(
                "{what}\napart: {:?}\npipelined: {:?}",
                a.map(|r| r.path),
                b.map(|r| r.path)
            ),
        }
    }
    eprintln!("{tried} tried: {ok} alike, {errors} errors alike");
    assert!(ok >= 20 && errors >= 5, "{ok} ok, {errors} errors");
}

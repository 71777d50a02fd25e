//! The GPU derivation against the CPU engine (grm-derive): the example
//! scenes, the hand-derived context-matching cases and many small random
//! grammars. Symbols and parameter starts must be identical; parameters
//! agree within `common::PARAM_TOLERANCE`.

mod common;
use common::*;
use grm_gpu::derive;

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
            let gpu = derive(g, &sys, &gpu_opts(&sys, iterations, seed)).expect("gpu derives");
            assert_same(&format!("{file} {system:?} seed {seed}"), &cpu, &gpu.string);
            assert_eq!(gpu.stats.len(), iterations as usize + 1);
            assert_eq!(gpu.stats.last().map(|s| s.modules), Some(cpu.len() as u64));
        }
    }
}

/// Weights that add up past the f32 range (constant and computed): the
/// race needs no sum, so both engines draw a fair coin (2:3 for the
/// computed pair), not always the last alternative, and agree module for
/// module.
#[test]
fn weights_past_the_float_range_draw_fairly_on_both_engines() {
    let g = gpu();
    let axiom = |m: &str| vec![m; 200].join(" ");
    let constant = inline(&format!(
        "system S {{ iterations = 1; axiom {}; A -> (3e38) F; A -> (3e38) G; }}",
        axiom("A")
    ))
    .expect("compiles");
    let computed = inline(&format!(
        "system S {{ iterations = 1; axiom {}; A(x) -> (x) F; A(x) -> (x * 1.5) G; }}",
        axiom("A(2e38)")
    ))
    .expect("compiles");
    for (what, sys) in [("constant", &constant), ("computed", &computed)] {
        for seed in [1, 77] {
            let cpu = cpu_derive(sys, 1, seed).expect("cpu derives");
            let gpu = derive(g, sys, &gpu_opts(sys, 1, seed)).expect("gpu derives");
            assert_same(&format!("{what} seed {seed}"), &cpu, &gpu.string);
            let f = cpu.symbols().filter(|&s| s == cpu.sym(0)).count();
            let distinct: std::collections::HashSet<_> = cpu.symbols().collect();
            assert_eq!(distinct.len(), 2, "{what}: both alternatives are drawn");
            // 200 fair (1:1) or 2:3 draws: far from all one way.
            assert!((20..=180).contains(&f), "{what} seed {seed}: {f} of 200");
        }
    }
}

/// The race's exact comparison (`t_a * w_b < t_b * w_a`: f64 on the CPU,
/// 64-bit integers from u32s on the GPU) on weights from subnormals to
/// the f32 limit, neighbouring floats and equal weights (ties go to the
/// first): the same choice for every module on both engines.
#[test]
fn the_race_agrees_on_extreme_and_neighbouring_weights() {
    let g = gpu();
    let axiom = vec!["A(1)"; 3000].join(" ");
    let sets = [
        "(1e-45) F; A(x) -> (3e38) G; A(x) -> (1e-40) H",
        "(1) F; A(x) -> (1.0000001) G; A(x) -> (0.99999994) H",
        "(x) F; A(x) -> (x) G; A(x) -> (x) H",
        "(x * 1e-44) F; A(x) -> (x * 2e-44) G; A(x) -> (x * 1e-38) H",
        "(1e-38) F; A(x) -> (1.2e-38) G; A(x) -> (x * 5e-39) H",
        "(3.4028235e38) F; A(x) -> (x * 3.4e38) G; A(x) -> (1e-30) H",
    ];
    for set in sets {
        let sys = inline(&format!(
            "system S {{ iterations = 1; axiom {axiom}; A(x) -> {set}; }}"
        ))
        .expect("compiles");
        for seed in [1, 5, 900] {
            let cpu = cpu_derive(&sys, 1, seed).expect("cpu derives");
            let gpu = derive(g, &sys, &gpu_opts(&sys, 1, seed)).expect("gpu derives");
            assert_same(&format!("{set} seed {seed}"), &cpu, &gpu.string);
        }
    }
}

/// `uniform` and `randint` between bounds whose difference passes the f32
/// range: a value between them on both engines (it was infinite: R0204);
/// `choose` with weights that add up past it: each value drawn (it was
/// always the last).
#[test]
fn draws_between_huge_bounds_stay_between_them() {
    let g = gpu();
    let sys = inline(
        "system S { iterations = 1; axiom A A A A A A A A A A A A A A A A; \
         A -> F(uniform(-3e38, 3e38)) F(randint(-2e38, 2e38)) F(choose(1, 3e38, 2, 3e38)); }",
    )
    .expect("compiles");
    let cpu = cpu_derive(&sys, 1, 5).expect("cpu derives");
    let gpu = derive(g, &sys, &gpu_opts(&sys, 1, 5)).expect("gpu derives");
    assert_same("huge bounds", &cpu, &gpu.string);
    let mut signs = [0, 0];
    let mut chosen = [0, 0];
    for m in cpu.parts().params.chunks(3) {
        assert!(m.iter().all(|x| x.is_finite()), "{m:?}");
        assert!((-3e38..=3e38).contains(&m[0]) && (-2e38..=2e38).contains(&m[1]));
        assert_eq!(m[1], m[1].round());
        signs[usize::from(m[0] > 0.0)] += 1;
        assert!(m[2] == 1.0 || m[2] == 2.0, "{m:?}");
        chosen[usize::from(m[2] == 2.0)] += 1;
    }
    assert!(signs[0] > 0 && signs[1] > 0, "both halves drawn: {signs:?}");
    assert!(
        chosen[0] > 0 && chosen[1] > 0,
        "both choices drawn: {chosen:?}"
    );
}

/// The hand-derived context cases of tests/derive_expect/context_matching.txt
/// (which the CPU engine's tests check against the expected strings): the
/// GPU derives the same strings.
#[test]
fn hand_derived_context_cases_match_the_cpu() {
    let g = gpu();
    let text = std::fs::read_to_string(repo().join("tests/derive_expect/context_matching.txt"))
        .expect("context_matching.txt");
    let mut n = 0;
    let mut grammar: Option<String> = None;
    let mut last = 0u32;
    let run = |src: &str, iterations: u32| {
        let sys = inline(src).unwrap_or_else(|| panic!("case grammar checks: {src}"));
        for it in 0..=iterations {
            let cpu = cpu_derive(&sys, it, 0).expect("cpu derives");
            let gpu = derive(g, &sys, &gpu_opts(&sys, it, 0)).expect("gpu derives");
            assert_same(&format!("{src} (str {it})"), &cpu, &gpu.string);
        }
    };
    for line in text.lines() {
        if let Some(gr) = line.strip_prefix("grammar ") {
            if let Some(prev) = grammar.take() {
                run(&prev, last);
                n += 1;
            }
            grammar = Some(gr.to_string());
            last = 0;
        } else if let Some(rest) = line.strip_prefix("str ") {
            let it: u32 = rest
                .split(' ')
                .next()
                .and_then(|x| x.parse().ok())
                .expect("iteration");
            last = last.max(it);
        }
    }
    if let Some(prev) = grammar.take() {
        run(&prev, last);
        n += 1;
    }
    assert!(n >= 10, "only {n} cases");
}

/// A random grammar over counters `A B C` (one exact integer parameter:
/// conditions, contexts and weights read them, so CPU and GPU must take the
/// same decisions), a plain symbol `D`, and turtle terminals `F + - [ ]`
/// whose lengths take inexact expressions (sqrt, sin, division, draws, the
/// inverse trigonometry and logarithms).
struct GrammarGen {
    rng: Rng,
}

impl GrammarGen {
    fn pick<'a>(&mut self, xs: &[&'a str]) -> &'a str {
        xs[self.rng.below(xs.len() as u64) as usize]
    }

    fn counter_expr(&mut self, vars: &[&str]) -> String {
        let v = vars[self.rng.below(vars.len() as u64) as usize];
        match self.rng.below(10) {
            0 => format!("{v} + 1"),
            1 => format!("{v} - 1"),
            2 => format!("{v} * 2"),
            3 => "randint(0, 3)".into(),
            4 => "floor(uniform(0, 4))".into(),
            5 => format!("if {v} > 1 then {v} - 1 else {v} + 2"),
            6 => format!("{v} % 3"),
            7 => format!("choose(1, 1, {v}, 2)"),
            8 => "0".into(),
            _ => v.to_string(),
        }
    }

    fn length_expr(&mut self, vars: &[&str]) -> String {
        let v = vars[self.rng.below(vars.len() as u64) as usize];
        match self.rng.below(12) {
            0 => format!("sqrt(abs({v}) + 1)"),
            1 => format!("sin({v} * 10) + 2"),
            2 => format!("{v} / 3 + 0.5"),
            3 => "uniform(0.5, 1.5)".into(),
            4 => "normal(1, 0.1)".into(),
            5 => format!("pow(1.1, {v})"),
            6 => format!("exp({v} * 0.01)"),
            // The functions the interpreter computes itself (docs/gpu.md).
            7 => format!("asin(sin({v} * 7) * 0.9) / 60 + 1.5"),
            8 => format!("ln(abs({v}) * 0.001 + 1) * 100 + 1"),
            9 => format!("atan2({v}, 2) / 45 + 2"),
            // Infinite where the counter is 3: a runtime error, at the
            // CPU's iteration and position.
            10 => format!("1 / ({v} - 3) + 2"),
            _ => "1".into(),
        }
    }

    fn successor(&mut self, vars: &[&str], depth: u32) -> String {
        let len = self.rng.below(6);
        let mut out = Vec::new();
        for _ in 0..len {
            match self.rng.below(9) {
                0..=2 => {
                    let s = self.pick(&["A", "B", "C"]);
                    out.push(format!("{s}({})", self.counter_expr(vars)));
                }
                3 => out.push("D".into()),
                4 => out.push(format!("F({})", self.length_expr(vars))),
                5 => out.push(self.pick(&["+", "-"]).into()),
                6 if depth < 2 => out.push(format!("[ {} ]", self.successor(vars, depth + 1))),
                _ => {
                    let s = self.pick(&["A", "B", "C"]);
                    out.push(format!("{s}({})", self.counter_expr(vars)));
                }
            }
        }
        out.join(" ")
    }

    fn condition(&mut self, vars: &[&str]) -> String {
        let v = vars[self.rng.below(vars.len() as u64) as usize];
        match self.rng.below(6) {
            0 => format!(" : {v} < {}", self.rng.below(4)),
            1 => format!(" : {v} >= {}", self.rng.below(4)),
            2 => format!(" : {v} % 2 == 0"),
            3 => " : chance(0.5)".into(),
            4 if vars.len() > 1 => format!(" : {} > {}", vars[0], vars[vars.len() - 1]),
            _ => String::new(),
        }
    }

    fn grammar(&mut self, seed: u32) -> String {
        let mut s = format!("system R {{\n    seed = {seed};\n");
        if self.rng.below(2) == 0 {
            s.push_str("    ignore + - F;\n");
        }
        s.push_str(&format!(
            "    axiom A(0) F(1) B(1) [ C(2) ] D {};\n",
            self.successor(&["1"], 1)
        ));
        let nprod = 2 + self.rng.below(6);
        for _ in 0..nprod {
            let pred = self.pick(&["A", "B", "C", "D", "F"]);
            let (pat, mut vars) = match pred {
                "D" => ("D".to_string(), vec![]),
                "F" => ("F(l)".to_string(), vec!["l"]),
                p => (format!("{p}(x)"), vec!["x"]),
            };
            let mut left = String::new();
            let mut right = String::new();
            if pred != "F" && self.rng.below(3) == 0 {
                let c = self.pick(&["A", "B", "C"]);
                left = format!("{c}(y) < ");
                vars.push("y");
            }
            if pred != "F" && self.rng.below(3) == 0 {
                let c = self.pick(&["A", "B", "C"]);
                right = if self.rng.below(3) == 0 {
                    format!(" > [ {c}(z) ]")
                } else {
                    format!(" > {c}(z)")
                };
                vars.push("z");
            }
            let vars_ref: Vec<&str> = if vars.is_empty() {
                vec!["1"]
            } else {
                vars.clone()
            };
            if pred == "F" {
                s.push_str(&format!(
                    "    F(l) -> F(l * {});\n",
                    self.pick(&["0.9", "1.1", "1.5"])
                ));
                continue;
            }
            let counters: Vec<&str> = vars_ref.iter().copied().filter(|v| *v != "l").collect();
            let counters = if counters.is_empty() {
                vec!["1"]
            } else {
                counters
            };
            let cond = self.condition(&counters);
            let alts = 1 + self.rng.below(3);
            for _ in 0..alts {
                let weight = if alts == 1 {
                    String::new()
                } else {
                    match self.rng.below(4) {
                        0 => format!("({} + 1) ", counters[0]),
                        1 => format!("(abs({}) + 0.5) ", counters[0]),
                        _ => format!("({}) ", 1 + self.rng.below(3)),
                    }
                };
                let succ = self.successor(&counters, 0);
                s.push_str(&format!(
                    "    {left}{pat}{right}{cond} -> {weight}{succ};\n"
                ));
            }
        }
        s.push_str("}\n");
        s
    }
}

/// Many small random grammars: the GPU gives the CPU's strings, or the
/// CPU's runtime error (same iteration and position) when a weight or
/// parameter goes bad.
#[test]
fn random_grammars_match_the_cpu() {
    let g = gpu();
    let mut gen_ = GrammarGen {
        rng: Rng::seeded(2024),
    };
    let (mut compared, mut errors, mut tried) = (0, 0, 0);
    while compared < 120 && tried < 1000 {
        tried += 1;
        let seed = gen_.rng.below(1000) as u32;
        let src = gen_.grammar(seed);
        let Some(sys) = inline(&src) else { continue };
        // As many iterations as keep the string small.
        let mut iterations = 0;
        let mut cpu = cpu_derive(&sys, 0, seed);
        for it in 1..=6 {
            let next = cpu_derive(&sys, it, seed);
            match &next {
                Ok(s) if s.len() > 4000 => break,
                _ => {}
            }
            iterations = it;
            let stop = next.is_err();
            cpu = next;
            if stop {
                break;
            }
        }
        let gpu = derive(g, &sys, &gpu_opts(&sys, iterations, seed));
        match (&cpu, &gpu) {
            (Ok(c), Ok(d)) => assert_same(&src, c, &d.string),
            (
                Err(grm_derive::DeriveError::Runtime(e)),
                Err(grm_gpu::GpuError::Runtime {
                    iteration,
                    position,
                    ..
                }),
            ) => {
                assert_eq!((e.iteration, e.position), (*iteration, *position), "{src}");
                errors += 1;
            }
            _ => panic!(
                "{src}\ncpu: {cpu:?}\ngpu: {:?}",
                gpu.as_ref().map(|d| d.string.len())
            ),
        }
        compared += 1;
    }
    eprintln!("random grammars: {compared} compared of {tried} generated, {errors} runtime errors");
    assert!(
        compared >= 120,
        "only {compared} of {tried} random grammars checked"
    );
    assert!(
        errors > 0 && errors < compared / 2,
        "{errors} of {compared} ended in runtime errors"
    );
}

/// The count and rewrite kernels carry the bytecode interpreter only where
/// some system has code: the stochastic plant (constant weights and
/// parameters) and the context plant derive without it; the row of trees
/// (computed lengths), and a forest that holds it, with it. The count
/// matches contexts only where some system has them. Every build is
/// checked against the CPU by the tests above.
#[test]
fn only_systems_with_code_get_the_interpreter() {
    let g = gpu();
    let plant = example("stochastic_plant.grm", None);
    let context = example("context_plant_a.grm", None);
    let row = example("row_of_trees.grm", None);
    let job = |system| grm_gpu::GpuJob {
        system,
        iterations: 2,
        seed: 0,
    };
    // (interpreter, context matching) of the kernels loaded for `jobs`.
    let builds = |jobs: &[grm_gpu::GpuJob]| {
        let s = grm_gpu::derive::GpuSystem::load(g, jobs).expect("loads");
        (s.interprets_code(), s.matches_contexts())
    };
    assert_eq!(builds(&[job(&plant)]), (false, false));
    assert_eq!(builds(&[job(&context)]), (false, true));
    assert_eq!(builds(&[job(&row)]), (true, false));
    assert_eq!(builds(&[job(&plant), job(&row)]), (true, false));
    assert_eq!(builds(&[job(&plant), job(&context)]), (false, true));
}

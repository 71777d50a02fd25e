//! Long axioms and long successors: no kernel invocation writes one of
//! them alone. On Mesa's lavapipe (the CI's device) an invocation's loops
//! stop after 65,535 iterations in all; a thread writing a whole axiom of
//! about 1,500 one-parameter modules, or a context-sensitive successor as
//! long, stopped part-way, and the strings were wrong or the engine
//! reported internal faults. Each case here failed that way before the
//! axiom was written one module per thread and long successors of
//! context-sensitive systems by output module.

mod common;
use common::*;
use grm_gpu::{GpuJob, derive, derive_many};

fn modules(f: impl Fn(usize) -> String, n: usize) -> String {
    (0..n).map(f).collect::<Vec<_>>().join(" ")
}

fn check(what: &str, src: &str, iterations: u32) {
    let sys = inline(src).unwrap_or_else(|| panic!("{what}: compiles"));
    let g = gpu();
    for seed in [0, 7] {
        let want = cpu_derive(&sys, iterations, seed).expect("cpu derives");
        let got = derive(g, &sys, &gpu_opts(&sys, iterations, seed))
            .unwrap_or_else(|e| panic!("{what}: gpu derives: {e}"));
        assert_same(&format!("{what}, seed {seed}"), &want, &got.string);
    }
}

#[test]
fn long_axioms_are_written_whole() {
    // Conditions, weights and computed parameters read every axiom module.
    let ones = modules(|i| format!("A({})", i % 7 + 1), 2_000);
    check(
        "condition over 2,000 one-parameter modules",
        &format!("system S {{ axiom {ones}; A(x) : x > 3 -> E(x + 1); }}"),
        1,
    );
    check(
        "stochastic over 2,000 modules",
        &format!("system S {{ axiom {ones}; A(x) -> (1) E(x + 1); A(x) -> (2) E(x * 3); }}"),
        1,
    );
    let threes = modules(|i| format!("A({i}, 2, {})", i % 5), 900);
    check(
        "900 three-parameter modules",
        &format!("system S {{ axiom {threes}; A(x, y, z) : z > 1 -> E(x + y + z); }}"),
        1,
    );
    let plain = modules(|_| "B".to_string(), 4_000);
    check(
        "4,000 modules without parameters, then parametric ones",
        &format!("system S {{ axiom {plain} A(1) A(2) A(3); A(x) : x > 0 -> E(x + 1); }}"),
        1,
    );
    // A context-sensitive system reads its axiom's neighbours too.
    let pairs = modules(|i| format!("A({i}) B"), 1_100);
    check(
        "1,100 context pairs",
        &format!("system S {{ axiom {pairs}; B < A(x) -> E(x + 1); }}"),
        1,
    );
}

#[test]
fn long_successors_of_context_sensitive_systems_are_written_whole() {
    let succ = modules(|i| format!("A({})", i % 7), 2_000);
    check(
        "a 2,000-module successor with a parametric left context",
        &format!("system S {{ axiom T T; T -> {succ}; A(v) < A(x) -> E(x + v); }}"),
        2,
    );
}

/// Every system's axiom is evaluated at iteration 0, position 0, as the
/// CPU does, now that its modules are written by threads of their own: a
/// forest whose axioms draw gets the CPU's trees.
#[test]
fn drawn_axioms_of_a_forest_match_the_cpu() {
    let sys = inline(
        "system R { axiom A(uniform(1, 2)) B(normal(0, 1)); \
         A(x) -> F(x) [ + A(x * 0.7) ] A(x * 0.9); B(y) -> F(y + 1) B(y); }",
    )
    .expect("compiles");
    let jobs: Vec<GpuJob> = (0..5)
        .map(|k| GpuJob {
            system: &sys,
            iterations: 2,
            seed: 11 * k + 1,
        })
        .collect();
    let out = derive_many(gpu(), &jobs, &gpu_opts(&sys, 2, 0)).expect("derives");
    for (k, (job, got)) in jobs.iter().zip(&out.strings).enumerate() {
        let want = cpu_derive(job.system, job.iterations, job.seed).expect("cpu derives");
        assert_same(&format!("tree {k}"), &want, got);
    }
}

/// A long axiom interpreted on the GPU (from the expansion tables where
/// the derivation is direct, from the string otherwise): the CPU turtle's
/// bones.
#[test]
fn long_axioms_are_interpreted_whole() {
    for (what, body) in [
        ("direct", "F(x) -> F(x * 0.5) F(x * 0.5);"),
        ("stepwise", "F(x) : x > 0 -> F(x * 0.5) F(x * 0.5);"),
    ] {
        let units = modules(|i| format!("F({}) + F(2) [ - F(1) ]", i % 3 + 1), 1_500);
        let src = format!("system R {{ angle = 30; axiom {units}; {body} }}");
        let (_, checked) = grm_sema::check_with("long.grm", &src, &grm_sema::MemLoader::new());
        assert!(!checked.has_errors(), "{what}");
        let p = &checked.program;
        let sys = p.default_system().expect("system");
        let c = grm_compile::compile(p, sys, &p.default_params()).expect("compiles");
        let run = grm_gpu::GpuRunOptions {
            derive: gpu_opts(&c, 2, 0),
            interpret: true,
            read_string: true,
            read_bones: true,
            strategy: grm_gpu::DeriveStrategy::Auto,
            branch_scan: grm_gpu::interp::BranchScan::Auto,
            pipelined: false,
        };
        let turtle = grm_gpu::TurtleProgram::new(sys, &c.settings);
        let mut r = grm_gpu::run(gpu(), &c, &turtle, &run, &mut |_| {}).expect("runs");
        let bones = std::mem::take(&mut r.interpretation.as_mut().expect("interpreted").bones);
        let string = cpu_derive(&c, 2, 0).expect("cpu derives");
        assert_same(what, &string, r.string.as_ref().expect("read"));
        let cpu = grm_turtle::interpret(sys, &c.settings, &string).expect("cpu interprets");
        assert_bones_match(what, &cpu, &bones);
    }
}

/// A long string that must be walked (tropism) is refused on a software
/// device, whose loop limit would cut a long branch short, and interpreted
/// on a GPU.
#[test]
fn a_long_walked_string_is_refused_on_a_software_device() {
    let src = "system R { tropism = vec3(0, -1, 0); elasticity = 0.2; axiom F; F -> F F; }";
    let (_, checked) = grm_sema::check_with("walk.grm", src, &grm_sema::MemLoader::new());
    assert!(!checked.has_errors(), "{:?}", checked.diagnostics);
    let p = &checked.program;
    let sys = p.default_system().expect("system");
    let c = grm_compile::compile(p, sys, &p.default_params()).expect("compiles");
    let turtle = grm_gpu::TurtleProgram::new(sys, &c.settings);
    assert!(turtle.walks());
    let n = 17; // 131,072 modules in one branch
    let run = grm_gpu::GpuRunOptions {
        derive: gpu_opts(&c, n, 0),
        interpret: true,
        read_string: false,
        read_bones: true,
        strategy: grm_gpu::DeriveStrategy::Auto,
        branch_scan: grm_gpu::interp::BranchScan::Auto,
        pipelined: false,
    };
    let g = gpu();
    match grm_gpu::run(g, &c, &turtle, &run, &mut |_| {}) {
        Err(grm_gpu::GpuError::Unsupported(why)) if g.is_software() => {
            assert!(why.contains("65,535"), "{why}");
        }
        Ok(mut r) if !g.is_software() => {
            let bones = std::mem::take(&mut r.interpretation.as_mut().expect("interpreted").bones);
            let string = cpu_derive(&c, n, 0).expect("cpu derives");
            let cpu = grm_turtle::interpret(sys, &c.settings, &string).expect("cpu interprets");
            assert_bones_match("walked", &cpu, &bones);
        }
        other => panic!(
            "software device: {}, got {:?}",
            g.is_software(),
            other.map(|r| r.path)
        ),
    }
}

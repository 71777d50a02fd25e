//! How many times a derivation and interpretation wait for the device: on
//! a GPU each wait costs a round trip whatever the work, so the structure
//! is pinned here. A direct derivation waits once (for the kernel, and
//! its status where parameters are computed), a batched one once (its
//! totals and status); the interpretation of a direct derivation's affine
//! string (from its tables), or of a string whose bone count is known in
//! advance, once more: a branching string's depth range is bounded from
//! the tables and read with the bone count, not before; a bone count not
//! known in advance is expected (and the bones written again where it
//! was more than expected). A derivation
//! the CPU did entirely waits for nothing. Pipelined
//! (`GpuRunOptions::pipelined`), a direct derivation is not waited for at
//! all (its status, where it computes parameters, is read with the
//! interpretation's results): Hilbert 3D, the bracketed plant and the
//! ternary tree derive and interpret with one wait.

mod common;
use common::*;
use grm_gpu::{GpuDeriveOptions, GpuRunOptions, TurtleProgram, run};

/// The tests here count the shared device's waits: one at a time (the
/// test harness runs tests on parallel threads).
static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn one_at_a_time() -> std::sync::MutexGuard<'static, ()> {
    ONE_AT_A_TIME.lock().unwrap_or_else(|p| p.into_inner())
}

#[test]
fn runs_wait_for_the_device_as_few_times_as_their_structure_needs() {
    let _one = one_at_a_time();
    let g = gpu();
    // (file, iterations, CPU prefix, derivation's waits, interpretation's)
    let cases: &[(&str, u32, u64, u64, u64)] = &[
        // Deterministic, straight: direct, then one submission.
        ("hilbert3d.grm", 5, 0, 1, 1),
        (
            "hilbert3d.grm",
            5,
            grm_gpu::derive::CPU_PREFIX_MODULES,
            1,
            1,
        ),
        // Deterministic, branching, affine: direct, bones from the tables.
        ("bracketed_plant.grm", 5, 0, 1, 1),
        // Computed parameters: direct, its status read with the wait;
        // branching, its depth range bounded from the tables.
        ("ternary_tree.grm", 6, 0, 1, 1),
        // Stochastic, branching: batched; the bones sized from their
        // expected count and read with it.
        ("stochastic_plant.grm", 5, 0, 1, 1),
        // Context-sensitive, every string on the CPU: no wait to derive;
        // the bones sized from their expected count (the largest outcome
        // where a context decides).
        (
            "context_plant_a.grm",
            20,
            grm_gpu::derive::CPU_PREFIX_MODULES,
            0,
            1,
        ),
    ];
    for &(file, iterations, prefix, derive_waits, interp_waits) in cases {
        let (p, name, c) = example_program(file, None);
        let sys = p.system(&name).expect("system");
        let turtle = TurtleProgram::new(sys, &c.settings);
        let mut opts = GpuRunOptions {
            derive: GpuDeriveOptions {
                iterations,
                cpu_prefix: prefix,
                ..GpuDeriveOptions::from_system(&c)
            },
            interpret: false,
            read_string: false,
            read_bones: false,
            strategy: grm_gpu::DeriveStrategy::Auto,
            branch_scan: grm_gpu::interp::BranchScan::Auto,
            pipelined: false,
        };
        let what = format!("{file} n {iterations} prefix {prefix}");
        // Warm: pipelines compiled, pool filled.
        run(g, &c, &turtle, &opts, &mut |_| {}).expect("runs");
        let w = g.waits();
        run(g, &c, &turtle, &opts, &mut |_| {}).expect("runs");
        assert_eq!(g.waits() - w, derive_waits, "{what}: derivation");
        opts.interpret = true;
        run(g, &c, &turtle, &opts, &mut |_| {}).expect("runs");
        let w = g.waits();
        run(g, &c, &turtle, &opts, &mut |_| {}).expect("runs");
        assert_eq!(
            g.waits() - w,
            derive_waits + interp_waits,
            "{what}: derivation and interpretation"
        );
        // Pipelined: a derivation that reads nothing back (direct, constant
        // parameters) is not waited for; the interpretation's wait covers
        // it. The bones are the same.
        opts.read_bones = true;
        let apart = run(g, &c, &turtle, &opts, &mut |_| {}).expect("runs");
        opts.read_bones = false;
        opts.pipelined = true;
        run(g, &c, &turtle, &opts, &mut |_| {}).expect("runs");
        let w = g.waits();
        let r = run(g, &c, &turtle, &opts, &mut |_| {}).expect("runs");
        // (A direct derivation with computed parameters, the ternary
        // tree, has its status read with the interpretation's results.)
        let reads_nothing = r.path == grm_gpu::DerivePath::Direct;
        assert_eq!(
            g.waits() - w,
            derive_waits + interp_waits - u64::from(reads_nothing),
            "{what}: pipelined"
        );
        opts.read_bones = true;
        let together = run(g, &c, &turtle, &opts, &mut |_| {}).expect("runs");
        let bones = |r: &grm_gpu::GpuRun| r.interpretation.clone().expect("interpreted").bones;
        assert!(!bones(&apart).is_empty(), "{what}");
        assert_eq!(bones(&apart), bones(&together), "{what}: pipelined bones");
    }
}

/// A forest (several systems in one derivation, Lipp 5.4): the systems'
/// ranges come with the derivation's own read (batched) or from the host
/// (direct), so deriving and interpreting waits twice (batched: the
/// totals, then the bones with their guessed count) or once and once more
/// (direct: the kernel, then the bones from the string).
#[test]
fn forests_wait_for_their_ranges_with_the_derivation() {
    let _one = one_at_a_time();
    let g = gpu();
    for (file, derive_and_interp) in [("stochastic_plant.grm", 2), ("bracketed_plant.grm", 2)] {
        let (p, name, c) = example_program(file, None);
        let sys = p.system(&name).expect("system");
        let turtle = TurtleProgram::new(sys, &c.settings);
        let jobs: Vec<grm_gpu::GpuJob> = (0..4u32)
            .map(|seed| grm_gpu::GpuJob {
                system: &c,
                iterations: 4 + seed % 2,
                seed,
            })
            .collect();
        let turtles = vec![&turtle; jobs.len()];
        let mut opts = GpuRunOptions {
            derive: GpuDeriveOptions {
                cpu_prefix: 0,
                ..GpuDeriveOptions::from_system(&c)
            },
            interpret: true,
            read_string: false,
            read_bones: false,
            strategy: grm_gpu::DeriveStrategy::Auto,
            branch_scan: grm_gpu::interp::BranchScan::Auto,
            pipelined: false,
        };
        grm_gpu::run_many(g, &jobs, &turtles, &opts, &mut |_| {}).expect("runs");
        let w = g.waits();
        grm_gpu::run_many(g, &jobs, &turtles, &opts, &mut |_| {}).expect("runs");
        assert_eq!(g.waits() - w, derive_and_interp, "{file}");
        // The ranges are right: each job's bones are its own string's.
        opts.read_bones = true;
        opts.read_string = true;
        let out = grm_gpu::run_many(g, &jobs, &turtles, &opts, &mut |_| {}).expect("runs");
        let strings = out.strings.expect("strings");
        let bones = out.bones.expect("bones");
        for (k, job) in jobs.iter().enumerate() {
            let want = cpu_derive(&c, job.iterations, job.seed).expect("derives");
            same_bits(&format!("{file} job {k}"), &want, &strings[k]);
            let cpu = grm_turtle::interpret(sys, &c.settings, &want).expect("cpu");
            assert_bones_match(&format!("{file} job {k}"), &cpu, &bones[k]);
        }
    }
}

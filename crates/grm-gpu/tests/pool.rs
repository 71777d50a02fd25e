//! The buffer pool: a repeated run of the same work (a benchmark, a
//! preview regrowing) takes its large buffers from the pool and creates
//! only small ones (parameters, read-back staging). Creating and zeroing
//! hundreds of MiB per run cost more than the kernels of a large scene.

mod common;
use common::*;
use grm_gpu::{GpuDeriveOptions, GpuRunOptions, TurtleProgram, run};

#[test]
fn a_repeated_run_creates_only_small_buffers() {
    let g = gpu();
    for (file, system, iterations) in [
        ("hilbert3d.grm", None, 5),
        ("bracketed_plant.grm", None, 4),
        ("stochastic_plant.grm", None, 6),
        ("ternary_tree.grm", Some("TernaryTreeB"), 6),
    ] {
        let (p, name, c) = example_program(file, system);
        let sys = p.system(&name).expect("system");
        let turtle = TurtleProgram::new(sys, &c.settings);
        for prefix in [0, grm_gpu::derive::CPU_PREFIX_MODULES] {
            let opts = GpuRunOptions {
                derive: GpuDeriveOptions {
                    iterations,
                    cpu_prefix: prefix,
                    ..GpuDeriveOptions::from_system(&c)
                },
                interpret: true,
                // Read-backs create their staging buffers (sized to the
                // results) every time; they are not what is measured here.
                read_string: false,
                read_bones: false,
                strategy: grm_gpu::DeriveStrategy::Auto,
                branch_scan: grm_gpu::interp::BranchScan::Auto,
                pipelined: false,
            };
            let first = run(g, &c, &turtle, &opts, &mut |_| {}).expect("runs");
            // The pool takes the smallest buffer that fits: the buffers the
            // first run created can be a better fit for an earlier request
            // of the next run than the one it took before, which then
            // leaves a later request without one (the stochastic plant's
            // strings with their identity keys, from the device's axiom,
            // did so once). From the second run on, the requests meet the
            // same pool.
            run(g, &c, &turtle, &opts, &mut |_| {}).expect("runs");
            let before = g.allocated();
            let again = run(g, &c, &turtle, &opts, &mut |_| {}).expect("runs");
            let created = g.allocated() - before;
            let what = format!("{file} {system:?} prefix {prefix}");
            let figures = |r: &grm_gpu::GpuRun| {
                let bones = r.interpretation.as_ref().map(|i| i.bone_count);
                let s: Vec<_> = r.stats.iter().map(|s| (s.modules, s.param_words)).collect();
                (s, bones)
            };
            assert_eq!(figures(&first), figures(&again), "{what}");
            assert!(first.modules() > 1000, "{what}: a real workload");
            // The string and the bones alone are hundreds of KiB; what is
            // created again is parameters and staging buffers.
            assert!(
                created.bytes < 64 * 1024,
                "{what}: {} bytes in {} buffers created again",
                created.bytes,
                created.buffers
            );
        }
    }
}

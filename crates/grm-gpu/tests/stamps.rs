//! Device timestamps (`grm_gpu::stamps`): with profiling on, a batched
//! derivation reports each step's kernel time on the device, the stages
//! in order inside it where the device stamps inside passes, and a direct
//! one its single pass as the last string's (its kernel is the "rewrite"
//! stage); with it off it reports none; and the derived string is the
//! same either way.
//!
//! Its own test binary: profiling is a setting of the shared device, and
//! the other test binaries must not see it change.

mod common;
use common::*;
use grm_gpu::{DerivePath, DeriveStrategy, GpuDeriveOptions, Timestamps, derive_with};

#[test]
fn profiling_reports_device_time_per_step_and_changes_nothing() {
    let g = gpu();
    let sys = example("hilbert3d.grm", None);
    let o = GpuDeriveOptions {
        iterations: 3,
        cpu_prefix: 0,
        ..GpuDeriveOptions::from_system(&sys)
    };
    assert_eq!(
        g.profiling(),
        Timestamps::None,
        "profiling is off by default"
    );
    for (strategy, path) in [
        (DeriveStrategy::Stepwise, DerivePath::Batched),
        (DeriveStrategy::Auto, DerivePath::Direct),
    ] {
        check(g, &sys, &o, strategy, path);
    }
}

fn check(
    g: &grm_gpu::Gpu,
    sys: &grm_compile::CompiledSystem,
    o: &GpuDeriveOptions,
    strategy: DeriveStrategy,
    path: DerivePath,
) {
    let (plain, p) = derive_with(g, sys, o, strategy).expect("derives");
    assert_eq!(p, path);
    assert!(plain.stats.iter().all(|s| s.device.is_none()));

    for level in [Timestamps::Passes, Timestamps::InsidePasses] {
        let set = g.set_profiling(level);
        assert!(set <= level && set <= g.timestamps());
        let (timed, _) = derive_with(g, sys, o, strategy).expect("derives");
        g.set_profiling(Timestamps::None);
        assert_eq!(
            timed.string.parts().syms,
            plain.string.parts().syms,
            "{level:?}"
        );
        assert_eq!(
            timed.string.parts().starts,
            plain.string.parts().starts,
            "{level:?}"
        );
        assert_eq!(timed.stats.len(), plain.stats.len());
        assert!(timed.stats[0].device.is_none(), "the axiom is not a step");
        if set == Timestamps::None {
            assert!(timed.stats.iter().all(|s| s.device.is_none()));
            continue;
        }
        let mut end = std::time::Duration::ZERO;
        let last = timed.stats.len() - 1;
        for s in &timed.stats[1..] {
            if path == DerivePath::Direct && (s.iteration as usize) < last {
                assert!(s.device.is_none(), "no pass derives string {}", s.iteration);
                continue;
            }
            let d = s.device.expect("every step is stamped");
            assert!(
                !d.pass.is_zero(),
                "step {} took no device time",
                s.iteration
            );
            // Each pass ends after the previous one, and after its own length.
            assert!(
                d.end > end && d.end >= d.pass,
                "step {}: {d:?}",
                s.iteration
            );
            end = d.end;
            match (set, d.stages) {
                (Timestamps::InsidePasses, Some(st)) => {
                    let sum: std::time::Duration = st.iter().sum();
                    // Each span is rounded to a nanosecond on its own.
                    let gap = sum.abs_diff(d.pass);
                    assert!(gap.as_nanos() <= 5, "the stages partition the pass: {d:?}");
                    if path == DerivePath::Direct {
                        // Only the expand kernel ("rewrite") runs: its span
                        // is stamped and not empty. (Not compared with the
                        // empty spans around it: on a software device their
                        // length is the host's scheduling, and under load one
                        // of them can outlast a small kernel.)
                        assert!(!st[3].is_zero(), "{d:?}");
                    }
                }
                (Timestamps::Passes, None) => {}
                other => panic!("stages {other:?}"),
            }
        }
    }
}

//! The GPU engine behind [`crate::Grower`] and [`crate::forest::grow`]
//! (`grm_gpu`; the `gpu` feature): the choice of what the device does and
//! brings back, which of its errors let the CPU take over, and one run of
//! one system.
//!
//! A run derives on the device and, where asked, interprets the result
//! there (bones); the string is read back only when asked (the model is
//! then built from it as on the CPU path). Without an adapter, or when a
//! derivation outgrows the device, it stops with the reason, or with
//! [`GpuChoice::fallback`] the CPU derives instead (an [`Event::FellBack`]
//! says so first). A run-time error in a production (a non-finite
//! parameter, a bad weight) is derived again on the CPU, which reports it
//! with its source span (both engines stop at the same iteration and
//! module).

use std::time::Duration;

use grm_compile::CompiledSystem;
use grm_derive::{DeriveOptions, IterationStats};
use grm_gpu::{GpuDeriveOptions, GpuError, GpuIterationStats, GpuRunOptions, TurtleProgram};

use crate::{Event, Grown, Record};

/// What the GPU does and brings back.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GpuChoice {
    /// Derive the first iterations on the CPU while the strings have at
    /// most this many modules (0: every iteration on the GPU; the string
    /// is the same either way).
    pub cpu_prefix: u64,
    /// Derive on the CPU when no GPU can be used or the derivation
    /// outgrows the device ([`device_problem`]).
    pub fallback: bool,
    /// Interpret the string on the device (its bone count is in the run's
    /// report).
    pub interpret: bool,
    /// Read the final string back ([`Grown::string`]; else it stays on
    /// the device and only its figures come back).
    pub read_string: bool,
    /// Wait for each iteration, so that each string's time is its own
    /// (per-iteration figures).
    pub sync_iterations: bool,
}

impl Default for GpuChoice {
    fn default() -> Self {
        GpuChoice {
            cpu_prefix: grm_gpu::derive::CPU_PREFIX_MODULES,
            fallback: false,
            interpret: true,
            read_string: true,
            sync_iterations: false,
        }
    }
}

/// Whether the CPU may take over after this error
/// ([`GpuChoice::fallback`]): no device, or the device cannot hold the
/// derivation.
pub fn device_problem(e: &GpuError) -> bool {
    matches!(
        e,
        GpuError::NoAdapter(_)
            | GpuError::RequestDevice(_)
            | GpuError::BufferTooLarge { .. }
            | GpuError::TooManyWorkgroups { .. }
            | GpuError::Unsupported(_)
            | GpuError::Device(_)
            | GpuError::DeviceLost(_)
    )
}

/// Whether a GPU error is the derivation outgrowing a limit (the user's,
/// or the 32-bit indices) or an unbalanced string: the input's fault,
/// never a reason to fall back to the CPU.
pub fn input_limit(e: &GpuError) -> bool {
    matches!(
        e,
        GpuError::ModuleLimit { .. }
            | GpuError::MemoryLimit { .. }
            | GpuError::CountOverflow { .. }
            | GpuError::UnbalancedBrackets { .. }
    )
}

/// How a GPU attempt ended without a result.
#[derive(Debug)]
pub(crate) enum Failed {
    /// A production's value failed: the CPU derives it to report it.
    Runtime(GpuError),
    /// Stop with this error.
    Stop(GpuError),
    /// The CPU derives instead (reported as [`Event::FellBack`]).
    FellBack,
}

/// Classify a GPU error: a run-time error, a fall back (reported through
/// `progress`) or a stop.
pub(crate) fn failed(
    e: GpuError,
    choice: &GpuChoice,
    progress: &mut dyn FnMut(Event<'_>),
) -> Failed {
    match e {
        e @ GpuError::Runtime { .. } => Failed::Runtime(e),
        e if input_limit(&e) => Failed::Stop(e),
        e if choice.fallback && device_problem(&e) => {
            progress(Event::FellBack(&e));
            Failed::FellBack
        }
        e => Failed::Stop(e),
    }
}

/// The limits and options of a GPU run of `opts`.
pub(crate) fn derive_options(
    opts: &DeriveOptions,
    choice: &GpuChoice,
    keys: bool,
) -> GpuDeriveOptions {
    GpuDeriveOptions {
        iterations: opts.iterations,
        seed: opts.seed,
        max_modules: opts.limits.max_modules,
        max_bytes: opts.limits.max_bytes,
        sync_iterations: choice.sync_iterations,
        cpu_prefix: choice.cpu_prefix,
        keys,
    }
}

/// A GPU string's figures as the CPU engine's, the running totals
/// (`cumulative`: modules produced, `processed`: modules rewritten)
/// carried from string to string; its bytes are its arrays' (symbols,
/// starts, parameter words, keys where `keys`).
pub(crate) fn cpu_stats(
    s: &GpuIterationStats,
    keys: bool,
    cumulative: &mut u64,
    processed: &mut u64,
    previous: u64,
) -> IterationStats {
    if s.iteration > 0 {
        *cumulative = cumulative.saturating_add(s.modules);
        *processed = processed.saturating_add(previous);
    }
    let words = 2 * s.modules + 1 + s.param_words + if keys { s.modules } else { 0 };
    IterationStats {
        iteration: s.iteration,
        modules: s.modules,
        param_words: s.param_words,
        cumulative_modules: *cumulative,
        processed_modules: *processed,
        bytes: words.saturating_mul(4),
        elapsed: s.elapsed,
    }
}

/// One GPU run of `sys` (compiled from `system`).
pub(crate) fn derive(
    sys: &CompiledSystem,
    system: &grm_sema::System,
    choice: &GpuChoice,
    record: Record,
    opts: &DeriveOptions,
    progress: &mut dyn FnMut(Event<'_>),
) -> Result<Option<Grown>, Failed> {
    let gpu = match grm_gpu::shared() {
        Ok(g) => g,
        Err(e) => {
            return match failed(e, choice, progress) {
                Failed::FellBack => Ok(None),
                f => Err(f),
            };
        }
    };
    let keys = record.keys;
    let run = GpuRunOptions {
        derive: derive_options(opts, choice, keys),
        interpret: choice.interpret,
        read_string: choice.read_string,
        read_bones: false,
        strategy: grm_gpu::DeriveStrategy::Auto,
        branch_scan: grm_gpu::interp::BranchScan::Auto,
        pipelined: true,
    };
    let turtle = TurtleProgram::new(system, &sys.settings);
    progress(Event::Gpu(gpu));
    let (mut cumulative, mut processed, mut previous) = (0u64, 0u64, 0u64);
    let r = grm_gpu::run(gpu, sys, &turtle, &run, &mut |s| {
        let c = cpu_stats(s, keys, &mut cumulative, &mut processed, previous);
        previous = s.modules;
        progress(Event::Step {
            stats: &c,
            on_gpu: !s.on_cpu,
        });
    });
    let mut r = match r {
        Ok(r) => r,
        Err(e) => {
            return match failed(e, choice, progress) {
                Failed::FellBack => Ok(None),
                f => Err(f),
            };
        }
    };
    // The run's own figures (a run derived again after a failed pipelined
    // one reported its strings twice).
    let (mut cumulative, mut processed, mut previous) = (0u64, 0u64, 0u64);
    let stats = r
        .stats
        .iter()
        .map(|s| {
            let c = cpu_stats(s, keys, &mut cumulative, &mut processed, previous);
            previous = s.modules;
            c
        })
        .collect();
    Ok(Some(Grown {
        string: r.string.take().unwrap_or_default(),
        stats,
        gpu: Some(r),
        ..Grown::default()
    }))
}

/// Wall time of a GPU run on the device: its derivation and its
/// interpretation.
pub fn device_time(r: &grm_gpu::GpuRun) -> Duration {
    r.derive_elapsed
        + r.interpretation
            .as_ref()
            .map_or(Duration::ZERO, |i| i.elapsed)
}

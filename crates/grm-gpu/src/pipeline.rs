//! Derivation and interpretation in one go, the string staying on the
//! device in between: what `grmc derive --gpu` and the benchmarks run.

use std::time::{Duration, Instant};

use grm_compile::CompiledSystem;
use grm_derive::ModuleString;

use crate::derive::{GpuDeriveOptions, GpuIterationStats, GpuSystem};
use crate::device::Gpu;
use crate::error::GpuError;
use crate::interp::{GpuInterpretation, TurtleProgram, interpret_device, read_bones};

/// What to run and what to bring back.
#[derive(Clone, Copy, Debug)]
pub struct GpuRunOptions {
    pub derive: GpuDeriveOptions,
    /// Interpret the derived string (bones).
    pub interpret: bool,
    /// Read the derived string back to the host.
    pub read_string: bool,
    /// Read the bones back to the host.
    pub read_bones: bool,
}

/// The outcome of [`run`], with timings.
#[derive(Clone, Debug)]
pub struct GpuRun {
    /// One entry per string (the axiom first).
    pub stats: Vec<GpuIterationStats>,
    /// Wall time of the whole derivation (uploading the tables included).
    pub derive_elapsed: Duration,
    /// The interpretation (its bones only when read back).
    pub interpretation: Option<GpuInterpretation>,
    /// The derived string, when read back.
    pub string: Option<ModuleString>,
    /// Wall time of the read-backs.
    pub readback_elapsed: Duration,
}

impl GpuRun {
    /// Modules of the final string.
    pub fn modules(&self) -> u64 {
        self.stats.last().map_or(0, |s| s.modules)
    }

    /// Modules produced over the derivation: the sum of the lengths of the
    /// strings after each step (Lipp's figure; also the CPU engine's
    /// `cumulative_modules`).
    pub fn produced_modules(&self) -> u64 {
        self.stats.iter().skip(1).map(|s| s.modules).sum()
    }
}

/// Derive `sys` and (optionally) interpret the result with `turtle`.
pub fn run(
    gpu: &Gpu,
    sys: &CompiledSystem,
    turtle: &TurtleProgram,
    opts: &GpuRunOptions,
    progress: &mut dyn FnMut(&GpuIterationStats),
) -> Result<GpuRun, GpuError> {
    gpu.run(|| {
        let t = Instant::now();
        let job = crate::derive::GpuJob {
            system: sys,
            iterations: opts.derive.iterations,
            seed: opts.derive.seed,
        };
        let g = GpuSystem::load(gpu, &[job])?;
        let (string, stats) = g.derive(&opts.derive, progress)?;
        let derive_elapsed = t.elapsed();
        let mut interpretation = None;
        let mut readback_elapsed = Duration::ZERO;
        if opts.interpret {
            let (bones, count, mut out) = interpret_device(gpu, turtle, &string)?;
            if opts.read_bones {
                let t = Instant::now();
                out.bones = read_bones(gpu, &bones, count)?;
                readback_elapsed += t.elapsed();
            }
            gpu.recycle([bones]);
            interpretation = Some(out);
        }
        let mut host = None;
        if opts.read_string {
            let t = Instant::now();
            host = Some(string.read(gpu)?);
            readback_elapsed += t.elapsed();
        }
        gpu.recycle(string.into_buffers());
        Ok(GpuRun {
            stats,
            derive_elapsed,
            interpretation,
            string: host,
            readback_elapsed,
        })
    })
}

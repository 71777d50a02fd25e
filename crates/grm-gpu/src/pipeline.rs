//! Derivation and interpretation in one go, the string staying on the
//! device in between: what `grmc derive --gpu` and the benchmarks run.

use std::time::{Duration, Instant};

use grm_compile::CompiledSystem;
use grm_derive::ModuleString;

use crate::derive::{
    DerivePath, DeriveStrategy, GpuDeriveOptions, GpuIterationStats, GpuJob, GpuSystem,
    split_string,
};
use crate::device::Gpu;
use crate::error::GpuError;
use crate::interp::{
    BoneCount, BracketBounds, BranchScan, GpuInterpretation, InterpHints, TurtleProgram,
    interpret_device, read_bones,
};
use crate::layout::GpuBone;

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
    /// How the iterations are recorded ([`DeriveStrategy::Auto`]: the
    /// fastest path that applies).
    pub strategy: DeriveStrategy,
    /// How a branching string is scanned when it is interpreted from the
    /// string ([`BranchScan::Auto`]: a state per module where it fits).
    pub branch_scan: BranchScan,
    /// Record the interpretation right behind the derivation, without
    /// waiting for the derivation where it reads nothing back (a direct
    /// derivation of constant parameters): one wait for both. The
    /// derivation's `derive_elapsed` is then the time to record and
    /// submit it, and its kernel's time shows in the interpretation's.
    /// `false` waits between them, so that each is timed on its own (the
    /// benchmark's per-phase columns).
    pub pipelined: bool,
}

/// The outcome of [`run`], with timings.
#[derive(Clone, Debug)]
pub struct GpuRun {
    /// One entry per string (the axiom first).
    pub stats: Vec<GpuIterationStats>,
    /// How the derivation ran.
    pub path: DerivePath,
    /// Wall time of the whole derivation (uploading the tables included);
    /// where it was not waited for ([`GpuRun::derive_waited`]), the time
    /// to record and submit it.
    pub derive_elapsed: Duration,
    /// The derivation was waited for before the interpretation was
    /// recorded (else, pipelined, its kernels' time is in the
    /// interpretation's).
    pub derive_waited: bool,
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
    gpu.run(|| match run_once(gpu, sys, turtle, opts, progress)? {
        Some(r) => Ok(r),
        // A pipelined direct derivation whose computed values failed (read
        // with the interpretation's results): derived again, waited for,
        // so that the stepwise derivation reports the error exactly.
        None => {
            let apart = GpuRunOptions {
                pipelined: false,
                ..*opts
            };
            run_once(gpu, sys, turtle, &apart, progress)?.ok_or_else(|| {
                GpuError::Readback("a derivation failed without reporting an error".into())
            })
        }
    })
}

/// [`run`] inside [`Gpu::run`]. `None`: a pipelined derivation's status,
/// read with the interpretation's results, says a computed value failed;
/// nothing it wrote is returned.
fn run_once(
    gpu: &Gpu,
    sys: &CompiledSystem,
    turtle: &TurtleProgram,
    opts: &GpuRunOptions,
    progress: &mut dyn FnMut(&GpuIterationStats),
) -> Result<Option<GpuRun>, GpuError> {
    let t = Instant::now();
    let job = crate::derive::GpuJob {
        system: sys,
        iterations: opts.derive.iterations,
        seed: opts.derive.seed,
    };
    let g = GpuSystem::load_with(gpu, &[job], opts.derive.keys)?;
    let wait = !(opts.pipelined && opts.interpret);
    let (string, stats, path, derive_waited) =
        g.derive_then(&opts.derive, opts.strategy, wait, progress)?;
    let derive_elapsed = t.elapsed();
    // A direct derivation with computed parameters not waited for: its
    // status, read below with the interpretation's results.
    let status = g.take_pending_status();
    let mut interpretation = None;
    let mut readback_elapsed = Duration::ZERO;
    let mut failed = false;
    if opts.interpret {
        // A direct derivation's bones come from its tables where it can (a
        // straight string of affine commands), else from the string.
        let (bones, count, mut out, also) = match g.interpret_direct(turtle)? {
            Some((b, c, o)) => (b, c, o, None),
            None => {
                let hints = InterpHints {
                    bones: bone_count(&g, &opts.derive, &[turtle], string.len()),
                    brackets: brackets_at_most(&g, &opts.derive, &[turtle]),
                    also_read: status.as_ref(),
                };
                interpret_device(
                    gpu,
                    &[turtle],
                    &string,
                    &[(0, string.len())],
                    hints,
                    opts.branch_scan,
                )?
            }
        };
        failed = match (&status, also) {
            (None, _) => false,
            (Some(_), Some(word)) => word != 0,
            (Some(b), None) => read_status(gpu, b)?,
        };
        if opts.read_bones && !failed {
            let t = Instant::now();
            out.bones = read_bones(gpu, &bones, count)?;
            readback_elapsed += t.elapsed();
        }
        gpu.recycle([bones]);
        interpretation = Some(out);
    } else if let Some(b) = &status {
        failed = read_status(gpu, b)?;
    }
    gpu.recycle(status);
    if failed {
        gpu.recycle(string.into_buffers());
        return Ok(None);
    }
    let mut host = None;
    if opts.read_string {
        let t = Instant::now();
        host = Some(string.read(gpu)?);
        readback_elapsed += t.elapsed();
    }
    gpu.recycle(string.into_buffers());
    Ok(Some(GpuRun {
        stats,
        path,
        derive_elapsed,
        derive_waited,
        interpretation,
        string: host,
        readback_elapsed,
    }))
}

/// Whether a derivation's status word says a value failed (a wait).
fn read_status(gpu: &Gpu, status: &wgpu::Buffer) -> Result<bool, GpuError> {
    let words = gpu.read::<u32>(gpu.encoder(), &[(status, 0, 1)])?;
    Ok(words.first().is_none_or(|w| w.iter().any(|&x| x != 0)))
}

/// The outcome of [`run_many`]: per job, in job order.
#[derive(Clone, Debug)]
pub struct GpuManyRun {
    /// The combined string's figures (the axioms, then each step).
    pub stats: Vec<GpuIterationStats>,
    /// Each job's final string length (module count), in job order.
    pub job_modules: Vec<u64>,
    /// Lipp's figure for the forest: the modules each job produced over its
    /// own iterations, summed (a job that has done its iterations is copied
    /// along in the combined string, but produces nothing more).
    pub produced: u64,
    /// How the derivation ran.
    pub path: DerivePath,
    pub derive_elapsed: Duration,
    /// The interpretation of the combined string (its bones are in `bones`).
    pub interpretation: Option<GpuInterpretation>,
    /// Each job's string, when read back.
    pub strings: Option<Vec<ModuleString>>,
    /// Each job's bones (module and parent indices within the job), when
    /// read back.
    pub bones: Option<Vec<Vec<GpuBone>>>,
    pub readback_elapsed: Duration,
}

/// Derive several systems together (Lipp 5.4, see
/// [`crate::derive::derive_many`]) and interpret them together, each with
/// its own turtle program (`turtles[k]` for `jobs[k]`): every job's bones
/// are what interpreting its own string gives. `opts.derive.iterations`
/// and `seed` are ignored (each job has its own).
pub fn run_many(
    gpu: &Gpu,
    jobs: &[GpuJob<'_>],
    turtles: &[&TurtleProgram],
    opts: &GpuRunOptions,
    progress: &mut dyn FnMut(&GpuIterationStats),
) -> Result<GpuManyRun, GpuError> {
    if turtles.len() != jobs.len() {
        return Err(GpuError::InvalidInput("one turtle program per job".into()));
    }
    gpu.run(|| {
        let t = Instant::now();
        let g = GpuSystem::load_with(gpu, jobs, opts.derive.keys)?;
        let d = crate::derive::many_options(jobs, &opts.derive);
        let iterations = d.iterations;
        let (string, stats, path) = g.derive_with(&d, opts.strategy, progress)?;
        let dir = g.read_directory()?;
        let derive_elapsed = t.elapsed();
        let ranges: Vec<(u64, u64)> = dir
            .iter()
            .map(|e| (u64::from(e.start), u64::from(e.end)))
            .collect();
        let mut interpretation = None;
        let mut bones = None;
        let mut readback_elapsed = Duration::ZERO;
        if opts.interpret {
            let most = bone_count(&g, &d, turtles, string.len());
            let brackets = brackets_at_most(&g, &d, turtles);
            let hints = InterpHints {
                bones: most,
                brackets,
                also_read: None,
            };
            let (buf, count, out, _) =
                interpret_device(gpu, turtles, &string, &ranges, hints, opts.branch_scan)?;
            if opts.read_bones {
                let t = Instant::now();
                let all = read_bones(gpu, &buf, count)?;
                readback_elapsed += t.elapsed();
                bones = Some(split_bones(&all, &ranges));
            }
            gpu.recycle([buf]);
            interpretation = Some(out);
        }
        let mut strings = None;
        if opts.read_string {
            let t = Instant::now();
            let all = string.read(gpu)?;
            readback_elapsed += t.elapsed();
            strings = Some(split_string(&all, &dir, g.job_keyed())?);
        }
        gpu.recycle(string.into_buffers());
        let job_modules: Vec<u64> = ranges.iter().map(|&(a, b)| b - a).collect();
        let copied: u64 = jobs
            .iter()
            .zip(&job_modules)
            .map(|(j, &m)| m.saturating_mul(u64::from(iterations - j.iterations)))
            .sum();
        let combined: u64 = stats.iter().skip(1).map(|s| s.modules).sum();
        Ok(GpuManyRun {
            produced: combined.saturating_sub(copied),
            job_modules,
            stats,
            path,
            derive_elapsed,
            interpretation,
            strings,
            bones,
            readback_elapsed,
        })
    })
}

/// What is known of the number of bones of the derived string (of `n`
/// modules) without reading it: at most its `F` count where every system
/// is exact (deterministic and context-free: the symbol counts are
/// known); else the expected share of `F`s among the modules times `n`,
/// with a margin (each symbol's outcomes weighted by their probabilities,
/// `GpuSystem::expected_final_counts`: the share is far steadier than the
/// counts, which for a stochastic system vary from run to run with the
/// first steps' draws).
fn bone_count(
    g: &GpuSystem<'_>,
    opts: &GpuDeriveOptions,
    turtles: &[&TurtleProgram],
    n: u64,
) -> BoneCount {
    if let Some(counts) = g.exact_final_counts(opts) {
        return BoneCount::AtMost(
            counts
                .iter()
                .zip(turtles)
                .fold(0u64, |a, (c, t)| a.saturating_add(t.bones_at_most(c))),
        );
    }
    let Some(expected) = g.expected_final_counts(opts) else {
        return BoneCount::Unknown;
    };
    let bones: f64 = expected
        .iter()
        .zip(turtles)
        .map(|(c, t)| t.bones_expected(c))
        .sum();
    let modules: f64 = expected.iter().flatten().sum();
    let share = bones / modules;
    if !(share.is_finite() && share >= 0.0) {
        return BoneCount::Unknown;
    }
    let guess = (n as f64 * share.min(1.0) * BONES_MARGIN).ceil() as u64 + BONES_SLACK;
    BoneCount::Expected(guess.min(n))
}

/// The margin on an expected bone count (a string over it has its bones
/// written again).
const BONES_MARGIN: f64 = 1.25;
/// Added to the margin: the share strays the most in small strings.
const BONES_SLACK: u64 = 1024;

/// Bounds on the derived string's bracket depth and `[` count from the
/// derivation's tables (every outcome that may happen), so a branching
/// string is interpreted without first reading its depth range back.
fn brackets_at_most(
    g: &GpuSystem<'_>,
    opts: &GpuDeriveOptions,
    turtles: &[&TurtleProgram],
) -> Option<BracketBounds> {
    let kinds: Vec<Vec<i8>> = turtles.iter().map(|t| t.bracket_kinds()).collect();
    let (depth, opens) = g.bracket_bounds(opts, &kinds)?;
    Some(BracketBounds { depth, opens })
}

/// Cut the combined bones (in string order) by the systems' module ranges,
/// renumbering modules and parents within each system (a parent is always
/// in its bone's own system: each system starts from the initial turtle).
fn split_bones(all: &[GpuBone], ranges: &[(u64, u64)]) -> Vec<Vec<GpuBone>> {
    let mut out = Vec::with_capacity(ranges.len());
    let mut k = 0usize;
    for &(start, end) in ranges {
        let first = k;
        let mut mine = Vec::new();
        while k < all.len() && u64::from(all[k].module_index) < end {
            let mut b = all[k];
            if u64::from(b.module_index) >= start {
                b.module_index -= start as u32;
                if b.parent != u32::MAX {
                    b.parent -= first as u32;
                }
                mine.push(b);
            }
            k += 1;
        }
        out.push(mine);
    }
    out
}

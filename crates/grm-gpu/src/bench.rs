//! The GPU benchmark (`cargo run --release -p grm-gpu --example bench`,
//! `grmc bench gpu`): one scene's derivation and interpretation on the GPU,
//! with the CPU engines measured in the same run as the baseline.
//!
//! GPU times are host wall clock around complete submissions (one
//! synchronisation per iteration: the next buffer sizes come from the
//! scan). Pipeline compilation is excluded by a warm-up run; reading
//! results back is reported apart and not counted. "Produced" modules are
//! Lipp's count (the sum of the lengths of the strings after each step);
//! derivation modules/us divides it by the derivation time,
//! interpretation modules/us divides the final length by the
//! interpretation time.

use std::fmt::Write as _;
use std::time::{Duration, Instant};

use grm_compile::CompiledSystem;
use grm_derive::ModuleString;

use crate::derive::GpuDeriveOptions;
use crate::device::Gpu;
use crate::device::Timestamps;
use crate::interp::TurtleProgram;
use crate::pipeline::{GpuRunOptions, run};
use crate::stamps::DeviceTime;

/// The standard scenes: example name, system, iterations (Lipp's where he
/// has one).
pub const SCENES: &[(&str, &str, u32)] = &[
    ("hilbert3d", "Hilbert3D", 6),
    ("koch_island", "KochIsland", 6),
    ("bracketed_plant", "BracketedPlant", 7),
    ("row_of_trees", "RowOfTrees", 10),
    ("ternary_tree", "TernaryTreeB", 11),
    ("stochastic_plant", "StochasticPlant", 11),
    ("context_plant_a", "ContextPlantA", 30),
];

/// How to benchmark.
#[derive(Clone, Copy, Debug)]
pub struct BenchConfig {
    pub iterations: u32,
    pub seed: u32,
    /// Timed runs per engine (the best is reported).
    pub runs: u32,
    /// CPU threads for the parallel column (0: all cores).
    pub threads: usize,
    /// Measure the CPU engines too.
    pub cpu: bool,
    pub max_modules: u64,
    /// [`GpuDeriveOptions::cpu_prefix`] of the timed derivations (a
    /// GPU-only derivation is timed beside them).
    pub cpu_prefix: u64,
}

/// One row per string.
#[derive(Clone, Copy, Debug)]
pub struct IterRow {
    pub iteration: u32,
    pub modules: u64,
    pub param_words: u64,
    pub gpu: Duration,
    pub cpu1: Option<Duration>,
    pub cpun: Option<Duration>,
}

/// The figures of one scene.
#[derive(Clone, Debug)]
pub struct SceneReport {
    pub name: String,
    pub iterations: u32,
    pub seed: u32,
    pub adapter: String,
    pub warmup: Duration,
    pub rows: Vec<IterRow>,
    pub modules: u64,
    pub produced: u64,
    pub gpu_derive: Duration,
    /// How the timed derivation ran.
    pub path: crate::DerivePath,
    /// Where it ran directly (no intermediate string): the same
    /// derivation with every string derived ([`crate::DeriveStrategy::Stepwise`],
    /// the same CPU prefix), the baseline of the direct path.
    pub stepwise_derive: Option<Duration>,
    /// Buffers created on the device per timed run (derive + interpret);
    /// the large ones should come from the pool.
    pub allocated_per_run: crate::device::Allocations,
    /// Times the host waited for the device per timed run.
    pub waits_per_run: u64,
    /// Iterations the timed derivation ran on the CPU
    /// ([`BenchConfig::cpu_prefix`]; 0: none).
    pub cpu_steps: u32,
    /// The same derivation with every iteration on the GPU, and how it
    /// ran (also the path of the device timestamps).
    pub gpu_only_derive: Duration,
    pub gpu_only_path: crate::DerivePath,
    pub cpu1_derive: Option<Duration>,
    pub cpun_derive: Option<Duration>,
    pub cpu_threads: usize,
    pub bones: u64,
    pub depth: u32,
    pub walked: bool,
    /// The matrix scan was fused (no per-module states: a straight string
    /// of affine commands, or a branching one whose states did not fit).
    pub fused: bool,
    /// A branching string of affine commands interpreted with a state per
    /// module: the fused scan of the same string, timed in the same run
    /// (best of the runs), so a GPU's figures say which to prefer there.
    pub fused_interpret: Option<Duration>,
    /// The bones came from a direct derivation's tables.
    pub direct_interp: bool,
    pub gpu_interpret: Duration,
    /// Derivation and interpretation as one run, the interpretation
    /// recorded right behind the derivation ([`GpuRunOptions::pipelined`]):
    /// the run's wall time, best of the runs, and its waits per run.
    pub end_to_end: Option<(Duration, u64)>,
    pub cpu_interpret: Option<Duration>,
    /// Why the interpretation was not run (a device buffer limit), if so.
    pub interpret_skipped: Option<String>,
    pub readback: Duration,
    /// Device timestamps of the best timed derivation, per step after the
    /// axiom (`None` where the device writes none, the derivation was not
    /// batched, or no pass derived that string: a direct derivation has
    /// one pass, the last string's).
    pub device_rows: Vec<Option<DeviceTime>>,
    /// The same derivation on the device: from the first step's kernels
    /// beginning to the last step's ending.
    pub device_derive: Option<Duration>,
    /// The comparison of the GPU string with the CPU's: `None` when not
    /// compared, else equal or the first difference (reported, the timings
    /// are still printed).
    pub checked: Option<Result<(), String>>,
}

fn best<T>(
    runs: u32,
    mut f: impl FnMut() -> Result<(Duration, T), String>,
) -> Result<(Duration, T), String> {
    let mut out: Option<(Duration, T)> = None;
    for _ in 0..runs.max(1) {
        let (d, v) = f()?;
        if out.as_ref().is_none_or(|(b, _)| d < *b) {
            out = Some((d, v));
        }
    }
    out.ok_or_else(|| "no run".to_string())
}

/// Compare two derived strings: symbols, starts and identity keys
/// exactly, parameters within a relative 1e-4.
pub fn same_string(cpu: &ModuleString, gpu: &ModuleString) -> Result<(), String> {
    let (c, g) = (cpu.parts(), gpu.parts());
    if c.syms != g.syms || c.starts != g.starts {
        let at = c.syms.iter().zip(g.syms.iter()).position(|(a, b)| a != b);
        return Err(format!(
            "the GPU string differs from the CPU string ({} vs {} modules, first difference at {at:?})",
            gpu.len(),
            cpu.len()
        ));
    }
    for (k, (a, b)) in c.params.iter().zip(g.params.iter()).enumerate() {
        if a.to_bits() != b.to_bits() && (a - b).abs() > 1e-4 * a.abs().max(1.0) {
            return Err(format!("parameter word {k}: CPU {a}, GPU {b}"));
        }
    }
    if c.keys != g.keys {
        let at = c.keys.iter().zip(g.keys).position(|(a, b)| a != b);
        return Err(format!(
            "the GPU's identity keys differ from the CPU's ({} vs {} keys, first difference at {at:?})",
            g.keys.len(),
            c.keys.len()
        ));
    }
    Ok(())
}

/// Benchmark one compiled system of a checked program.
pub fn bench_scene(
    gpu: &Gpu,
    name: &str,
    system: &grm_sema::System,
    c: &CompiledSystem,
    cfg: &BenchConfig,
) -> Result<SceneReport, String> {
    let turtle = TurtleProgram::new(system, &c.settings);
    let mut ropts = GpuRunOptions {
        derive: GpuDeriveOptions {
            iterations: cfg.iterations,
            seed: cfg.seed,
            max_modules: cfg.max_modules,
            max_bytes: u64::MAX,
            sync_iterations: false,
            cpu_prefix: cfg.cpu_prefix,
            keys: false,
        },
        interpret: true,
        read_string: cfg.cpu,
        read_bones: false,
        strategy: crate::DeriveStrategy::Auto,
        branch_scan: crate::interp::BranchScan::Auto,
        // Each phase waited for, so each is timed on its own; the
        // end-to-end run below does not wait between them.
        pipelined: false,
    };
    let t = Instant::now();
    // A string the device cannot interpret (over a buffer limit: a
    // branching string's turtle states on lavapipe's 128 MiB bindings; a
    // long string walked on a software device, `interp::SOFTWARE_WALK_MAX`)
    // is still derived and timed; the interpretation is reported skipped.
    let mut interpret_skipped = None;
    let warm = match run(gpu, c, &turtle, &ropts, &mut |_| {}) {
        Ok(w) => w,
        Err(e @ (crate::GpuError::BufferTooLarge { .. } | crate::GpuError::Unsupported(_))) => {
            interpret_skipped = Some(e.to_string());
            ropts.interpret = false;
            run(gpu, c, &turtle, &ropts, &mut |_| {}).map_err(|e| e.to_string())?
        }
        Err(e) => return Err(e.to_string()),
    };
    let warmup = t.elapsed();
    ropts.read_string = false;
    // Per iteration and on the device: every iteration on the GPU.
    let mut gpu_only = ropts;
    gpu_only.derive.cpu_prefix = 0;
    gpu_only.derive.sync_iterations = true;
    // The per-iteration rows time the derivation only.
    gpu_only.interpret = false;
    let per_iter = run(gpu, c, &turtle, &gpu_only, &mut |_| {}).map_err(|e| e.to_string())?;
    gpu_only.derive.sync_iterations = false;
    // Untimed first: its pipelines compiled (the warm-up may have taken
    // another path).
    let gpu_only_path = run(gpu, c, &turtle, &gpu_only, &mut |_| {})
        .map_err(|e| e.to_string())?
        .path;
    let (gpu_only_derive, _) = best(cfg.runs, || {
        let r = run(gpu, c, &turtle, &gpu_only, &mut |_| {}).map_err(|e| e.to_string())?;
        Ok((r.derive_elapsed, ()))
    })?;
    let mut best_interp = Duration::MAX;
    let before = gpu.allocated();
    let waits_before = gpu.waits();
    let (gpu_derive, last) = best(cfg.runs, || {
        let r = run(gpu, c, &turtle, &ropts, &mut |_| {}).map_err(|e| e.to_string())?;
        if let Some(i) = &r.interpretation {
            best_interp = best_interp.min(i.elapsed);
        }
        Ok((r.derive_elapsed, r))
    })?;
    let created = gpu.allocated() - before;
    let runs = u64::from(cfg.runs.max(1));
    let waits_per_run = (gpu.waits() - waits_before) / runs;
    let allocated_per_run = crate::device::Allocations {
        buffers: created.buffers / runs,
        bytes: created.bytes / runs,
    };
    // End to end, as `grmc derive --gpu` runs it: the interpretation
    // recorded right behind the derivation (one wait for both where the
    // derivation reads nothing back), the run's whole wall time.
    let end_to_end = if interpret_skipped.is_none() {
        let mut e = ropts;
        e.pipelined = true;
        run(gpu, c, &turtle, &e, &mut |_| {}).map_err(|e| e.to_string())?;
        let waits = gpu.waits();
        let (t, _) = best(cfg.runs, || {
            let t = Instant::now();
            run(gpu, c, &turtle, &e, &mut |_| {}).map_err(|e| e.to_string())?;
            Ok((t.elapsed(), ()))
        })?;
        Some((t, (gpu.waits() - waits) / runs))
    } else {
        None
    };
    let stepwise_derive = if last.path == crate::DerivePath::Direct {
        let mut step = ropts;
        step.strategy = crate::DeriveStrategy::Stepwise;
        step.interpret = false;
        run(gpu, c, &turtle, &step, &mut |_| {}).map_err(|e| e.to_string())?;
        let (t, _) = best(cfg.runs, || {
            let r = run(gpu, c, &turtle, &step, &mut |_| {}).map_err(|e| e.to_string())?;
            Ok((r.derive_elapsed, ()))
        })?;
        Some(t)
    } else {
        None
    };
    let interp = match (&last.interpretation, &interpret_skipped) {
        (Some(i), _) => i.clone(),
        (None, Some(_)) => crate::GpuInterpretation::default(),
        (None, None) => return Err("no interpretation".into()),
    };
    let fused_interpret =
        if !interp.direct && !interp.walked && !interp.fused && turtle.has_brackets() {
            let mut f = ropts;
            f.branch_scan = crate::interp::BranchScan::Fused;
            // Untimed first: its pipelines compiled.
            run(gpu, c, &turtle, &f, &mut |_| {}).map_err(|e| e.to_string())?;
            let mut best_f = Duration::MAX;
            best(cfg.runs, || {
                let r = run(gpu, c, &turtle, &f, &mut |_| {}).map_err(|e| e.to_string())?;
                if let Some(i) = &r.interpretation {
                    best_f = best_f.min(i.elapsed);
                }
                Ok((r.derive_elapsed, ()))
            })?;
            Some(best_f)
        } else {
            None
        };
    let cpu_steps = last.stats.iter().skip(1).filter(|s| s.on_cpu).count() as u32;
    let (device_derive, device_rows) = device_profile(gpu, c, &turtle, &gpu_only, cfg.runs)?;

    let mut cpu1 = None;
    let mut cpun = None;
    let mut cpu_interpret = None;
    let mut checked = None;
    if cfg.cpu {
        let copts = grm_derive::DeriveOptions {
            iterations: cfg.iterations,
            seed: cfg.seed,
            limits: grm_derive::DeriveLimits {
                max_modules: cfg.max_modules,
                max_bytes: u64::MAX,
            },
        };
        for (threads, slot) in [(1usize, &mut cpu1), (cfg.threads, &mut cpun)] {
            let engine = grm_derive::Engine::new(c, threads).map_err(|e| e.to_string())?;
            *slot = Some(best(cfg.runs, || {
                let t = Instant::now();
                let d = engine
                    .derive(&copts, &mut |_| {})
                    .map_err(|e| e.to_string())?;
                Ok((t.elapsed(), d))
            })?);
        }
        if let (Some((_, d)), Some(gs)) = (&cpu1, &warm.string) {
            checked = Some(same_string(&d.string, gs));
        }
        if let (Some((_, d)), None) = (&cpu1, &interpret_skipped) {
            let (t, _) = best(cfg.runs, || {
                let t = Instant::now();
                let it = grm_turtle::interpret(system, &c.settings, &d.string)
                    .map_err(|e| e.to_string())?;
                Ok((t.elapsed(), it.bones.len()))
            })?;
            cpu_interpret = Some(t);
        }
    }
    let rows = per_iter
        .stats
        .iter()
        .enumerate()
        .map(|(k, s)| IterRow {
            iteration: s.iteration,
            modules: s.modules,
            param_words: s.param_words,
            gpu: s.elapsed,
            cpu1: cpu1
                .as_ref()
                .and_then(|(_, d)| d.stats.get(k))
                .map(|s| s.elapsed),
            cpun: cpun
                .as_ref()
                .and_then(|(_, d)| d.stats.get(k))
                .map(|s| s.elapsed),
        })
        .collect();
    Ok(SceneReport {
        name: name.to_string(),
        iterations: cfg.iterations,
        seed: cfg.seed,
        adapter: gpu.describe(),
        warmup,
        rows,
        modules: last.modules(),
        produced: last.produced_modules(),
        gpu_derive,
        path: last.path,
        stepwise_derive,
        allocated_per_run,
        waits_per_run,
        cpu_steps,
        gpu_only_derive,
        gpu_only_path,
        cpu1_derive: cpu1.map(|(t, _)| t),
        cpun_derive: cpun.map(|(t, _)| t),
        cpu_threads: if cfg.threads == 0 {
            std::thread::available_parallelism().map_or(1, |n| n.get())
        } else {
            cfg.threads
        },
        bones: interp.bone_count,
        depth: interp.max_depth,
        walked: interp.walked,
        fused: interp.fused,
        fused_interpret,
        direct_interp: interp.direct,
        gpu_interpret: best_interp,
        end_to_end,
        cpu_interpret,
        interpret_skipped,
        readback: warm.readback_elapsed,
        device_rows,
        device_derive,
        checked,
    })
}

/// Device timestamps of the derivation, from runs of their own (stamps
/// can slow the work they measure, so the wall-clock runs write none): the
/// best whole-derivation time over `runs` runs with stamps at the passes'
/// ends only, and per step the best run's pass times with, where the device
/// can stamp inside passes, one more run's time per kernel stage.
#[allow(clippy::type_complexity)]
fn device_profile(
    gpu: &Gpu,
    c: &CompiledSystem,
    turtle: &TurtleProgram,
    ropts: &GpuRunOptions,
    runs: u32,
) -> Result<(Option<Duration>, Vec<Option<DeviceTime>>), String> {
    let mut opts = *ropts;
    opts.interpret = false;
    let steps = |r: &crate::pipeline::GpuRun| -> Vec<Option<DeviceTime>> {
        r.stats.iter().skip(1).map(|s| s.device).collect()
    };
    // The last string's pass ends the derivation (a direct derivation
    // stamps only that one).
    let whole = |rows: &[Option<DeviceTime>]| match rows.last() {
        Some(Some(d)) => Some(d.end),
        _ => None,
    };
    let result = (|| {
        if gpu.set_profiling(Timestamps::Passes) == Timestamps::None {
            return Ok((None, Vec::new()));
        }
        let mut best: Option<(Duration, Vec<Option<DeviceTime>>)> = None;
        for _ in 0..runs.max(1) {
            let r = run(gpu, c, turtle, &opts, &mut |_| {}).map_err(|e| e.to_string())?;
            let rows = steps(&r);
            match whole(&rows) {
                Some(d) if best.as_ref().is_none_or(|(b, _)| d < *b) => best = Some((d, rows)),
                Some(_) => {}
                // Not batched: no stamps to take.
                None => return Ok((None, Vec::new())),
            }
        }
        let Some((total, mut rows)) = best else {
            return Ok((None, Vec::new()));
        };
        if gpu.set_profiling(Timestamps::InsidePasses) == Timestamps::InsidePasses {
            let r = run(gpu, c, turtle, &opts, &mut |_| {}).map_err(|e| e.to_string())?;
            for (row, staged) in rows.iter_mut().zip(steps(&r)) {
                if let (Some(row), Some(st)) = (row, staged) {
                    row.stages = st.stages;
                }
            }
        }
        Ok((Some(total), rows))
    })();
    gpu.set_profiling(Timestamps::None);
    result
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

/// Modules per microsecond.
pub fn rate(modules: u64, d: Duration) -> f64 {
    if d.is_zero() {
        0.0
    } else {
        modules as f64 / (d.as_secs_f64() * 1e6)
    }
}

fn speedup(cpu: Duration, gpu: Duration) -> f64 {
    if gpu.is_zero() {
        0.0
    } else {
        cpu.as_secs_f64() / gpu.as_secs_f64()
    }
}

impl SceneReport {
    /// The report as text (one block per scene).
    pub fn text(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "scene {}, {} iterations, seed {}",
            self.name, self.iterations, self.seed
        );
        let _ = writeln!(
            s,
            "  warm-up run (pipeline compilation included): {:.1} ms",
            ms(self.warmup)
        );
        match &self.checked {
            Some(Ok(())) => {
                let _ = writeln!(s, "  check: the GPU string equals the CPU string");
            }
            Some(Err(e)) => {
                let _ = writeln!(s, "  CHECK FAILED: {e}");
            }
            None => {}
        }
        let _ = writeln!(
            s,
            "  {:>9} {:>13} {:>13} {:>10} {:>10} {:>10}",
            "iteration", "modules", "params", "gpu ms", "cpu1 ms", "cpuN ms"
        );
        let f = |x: Option<Duration>| x.map_or("-".to_string(), |v| format!("{:.3}", ms(v)));
        for r in &self.rows {
            let _ = writeln!(
                s,
                "  {:>9} {:>13} {:>13} {:>10.3} {:>10} {:>10}",
                r.iteration,
                r.modules,
                r.param_words,
                ms(r.gpu),
                f(r.cpu1),
                f(r.cpun)
            );
        }
        let _ = writeln!(
            s,
            "  derive:    {} modules, {} produced; GPU {:.3} ms = {:.1} modules/us{}",
            self.modules,
            self.produced,
            ms(self.gpu_derive),
            rate(self.produced, self.gpu_derive),
            match self.cpu_steps {
                _ if self.path == crate::DerivePath::Direct => " (direct, on the GPU)".to_string(),
                0 => " (every iteration on the GPU)".to_string(),
                k if k >= self.iterations => {
                    " (every iteration on the CPU: the strings are within the CPU prefix)"
                        .to_string()
                }
                k => format!(
                    " (iterations 1-{k} on the CPU, then {} on the GPU)",
                    self.iterations - k
                ),
            }
        );
        if self.path == crate::DerivePath::Direct {
            let _ = writeln!(
                s,
                "             direct: the final string in one pass, no intermediate string ({:.1} final modules/us)",
                rate(self.modules, self.gpu_derive)
            );
        }
        if let Some(t) = self.stepwise_derive {
            let _ = writeln!(
                s,
                "             stepwise (every string derived, same CPU prefix) {:.3} ms = {:.1} modules/us (direct {:.2}x faster)",
                ms(t),
                rate(self.produced, t),
                speedup(t, self.gpu_derive)
            );
        }
        let _ = writeln!(
            s,
            "             GPU only (no CPU prefix; {:?}) {:.3} ms = {:.1} modules/us ({:.2}x the time above)",
            self.gpu_only_path,
            ms(self.gpu_only_derive),
            rate(self.produced, self.gpu_only_derive),
            speedup(self.gpu_only_derive, self.gpu_derive)
        );
        if let Some(d) = self.device_derive {
            let _ = writeln!(
                s,
                "             GPU only on the device (timestamps, first kernel to last; stage times from one more run): {:.3} ms = {:.1} modules/us",
                ms(d),
                rate(self.produced, d)
            );
            for (k, row) in self.device_rows.iter().enumerate() {
                let Some(t) = row else { continue };
                let mut line = format!("               step {:>2}: {:>8.3} ms", k + 1, ms(t.pass));
                if self.gpu_only_path == crate::DerivePath::Direct {
                    // One pass: the expand kernel (no count, scan or next).
                    line.push_str("  (the direct derivation's expand kernel)");
                } else if let Some(st) = t.stages {
                    let parts: Vec<String> = crate::stamps::KERNEL_STAGES
                        .iter()
                        .zip(st)
                        .map(|(n, d)| format!("{n} {:.3}", ms(d)))
                        .collect();
                    let _ = write!(line, "  ({})", parts.join(", "));
                }
                let _ = writeln!(s, "{line}");
            }
        }
        for (label, t) in [
            ("CPU 1 thread", self.cpu1_derive),
            (
                &*format!("CPU {} threads", self.cpu_threads),
                self.cpun_derive,
            ),
        ] {
            if let Some(t) = t {
                let _ = writeln!(
                    s,
                    "             {label} {:.3} ms = {:.1} modules/us (GPU {:.2}x)",
                    ms(t),
                    rate(self.produced, t),
                    speedup(t, self.gpu_derive)
                );
            }
        }
        if let Some(why) = &self.interpret_skipped {
            let _ = writeln!(s, "  interpret: not run: {why}");
        } else {
            self.interpretation_text(&mut s);
        }
        let _ = writeln!(
            s,
            "  readback (not counted): {:.3} ms for the string",
            ms(self.readback)
        );
        let _ = writeln!(
            s,
            "  per timed run (derive + interpret): {} waits for the device; {} device buffers created, {:.3} MiB",
            self.waits_per_run,
            self.allocated_per_run.buffers,
            self.allocated_per_run.bytes as f64 / (1024.0 * 1024.0)
        );
        s
    }

    /// The interpretation's lines of [`SceneReport::text`].
    fn interpretation_text(&self, s: &mut String) {
        let _ = writeln!(
            s,
            "  interpret: {} bones, {}{}; GPU {:.3} ms = {:.1} modules/us",
            self.bones,
            if self.direct_interp {
                String::new()
            } else {
                format!("depth {}, ", self.depth)
            },
            if self.direct_interp {
                "direct (from the derivation's tables; the string is not read)"
            } else if self.walked {
                "branches walked"
            } else if self.fused && self.depth == 0 {
                "matrix scan, fused (no brackets)"
            } else if self.fused {
                "matrix scan, fused (the states per module would not fit)"
            } else {
                "matrix scan, a state per module"
            },
            ms(self.gpu_interpret),
            rate(self.modules, self.gpu_interpret)
        );
        if let Some(t) = self.fused_interpret {
            let _ = writeln!(
                s,
                "             fused scan (block totals and states at `[` only) {:.3} ms = {:.1} modules/us ({:.2}x the time above)",
                ms(t),
                rate(self.modules, t),
                t.as_secs_f64() / self.gpu_interpret.as_secs_f64().max(1e-12)
            );
        }
        if let Some(t) = self.cpu_interpret {
            let _ = writeln!(
                s,
                "             CPU turtle {:.3} ms = {:.1} modules/us (GPU {:.2}x)",
                ms(t),
                rate(self.modules, t),
                speedup(t, self.gpu_interpret)
            );
        }
        let total = self.gpu_derive + self.gpu_interpret;
        let _ = writeln!(
            s,
            "  total:     GPU {:.3} ms = {:.1} modules/us (produced + final modules over derive + interpret)",
            ms(total),
            rate(self.produced + self.modules, total)
        );
        if let Some((t, waits)) = self.end_to_end {
            let _ = writeln!(
                s,
                "             end to end (one run, interpretation recorded behind the derivation, {waits} wait(s)) {:.3} ms = {:.1} modules/us",
                ms(t),
                rate(self.produced + self.modules, t)
            );
        }
        if let (Some(d), Some(t)) = (self.cpu1_derive, self.cpu_interpret) {
            let _ = writeln!(
                s,
                "             CPU 1 thread {:.3} ms (GPU {:.2}x)",
                ms(d + t),
                speedup(d + t, total)
            );
        }
    }
}

/// A forest: `copies` jobs of one system with seeds `seed, seed + 1, ...`
/// derived and interpreted in the same dispatches (Lipp 5.4), against the
/// CPU deriving and interpreting them one after the other.
pub fn bench_forest(
    gpu: &Gpu,
    name: &str,
    system: &grm_sema::System,
    c: &CompiledSystem,
    copies: u32,
    cfg: &BenchConfig,
) -> Result<String, String> {
    use crate::derive::GpuJob;
    let turtle = TurtleProgram::new(system, &c.settings);
    let jobs: Vec<GpuJob> = (0..copies)
        .map(|k| GpuJob {
            system: c,
            iterations: cfg.iterations,
            seed: cfg.seed.wrapping_add(k),
        })
        .collect();
    let turtles = vec![&turtle; jobs.len()];
    let opts = GpuRunOptions {
        derive: GpuDeriveOptions {
            iterations: cfg.iterations,
            seed: cfg.seed,
            max_modules: cfg.max_modules,
            max_bytes: u64::MAX,
            sync_iterations: false,
            cpu_prefix: cfg.cpu_prefix,
            keys: false,
        },
        interpret: true,
        read_string: false,
        read_bones: false,
        strategy: crate::DeriveStrategy::Auto,
        branch_scan: crate::interp::BranchScan::Auto,
        pipelined: false,
    };
    let warm = crate::pipeline::run_many(gpu, &jobs, &turtles, &opts, &mut |_| {})
        .map_err(|e| e.to_string())?;
    let modules = warm.stats.last().map_or(0, |s| s.modules);
    let produced: u64 = warm.stats.iter().skip(1).map(|s| s.modules).sum();
    let mut best_derive = Duration::MAX;
    let (gpu_time, _) = best(cfg.runs, || {
        let t = Instant::now();
        let r = crate::pipeline::run_many(gpu, &jobs, &turtles, &opts, &mut |_| {})
            .map_err(|e| e.to_string())?;
        best_derive = best_derive.min(r.derive_elapsed);
        Ok((t.elapsed(), ()))
    })?;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "forest {name}: {copies} seeds x {} iterations in one derivation: {modules} modules, {produced} produced",
        cfg.iterations
    );
    let _ = writeln!(
        s,
        "  GPU derive {:.3} ms = {:.1} modules/us ({:?}; {:.1} final modules/us)",
        ms(best_derive),
        rate(produced, best_derive),
        warm.path,
        rate(modules, best_derive)
    );
    let _ = writeln!(
        s,
        "  GPU derive + interpret {:.3} ms = {:.1} modules/us",
        ms(gpu_time),
        rate(produced + modules, gpu_time)
    );
    if cfg.cpu {
        let engine = grm_derive::Engine::new(c, cfg.threads).map_err(|e| e.to_string())?;
        let (cpu_time, _) = best(cfg.runs, || {
            let t = Instant::now();
            for j in &jobs {
                let o = grm_derive::DeriveOptions {
                    iterations: j.iterations,
                    seed: j.seed,
                    limits: grm_derive::DeriveLimits {
                        max_modules: cfg.max_modules,
                        max_bytes: u64::MAX,
                    },
                };
                let d = engine.derive(&o, &mut |_| {}).map_err(|e| e.to_string())?;
                grm_turtle::interpret(system, &c.settings, &d.string).map_err(|e| e.to_string())?;
            }
            Ok((t.elapsed(), ()))
        })?;
        let _ = writeln!(
            s,
            "  CPU ({} derivation threads, one job after the other) {:.3} ms = {:.1} modules/us (GPU {:.2}x)",
            if cfg.threads == 0 {
                "all".to_string()
            } else {
                cfg.threads.to_string()
            },
            ms(cpu_time),
            rate(produced + modules, cpu_time),
            speedup(cpu_time, gpu_time)
        );
    }
    Ok(s)
}

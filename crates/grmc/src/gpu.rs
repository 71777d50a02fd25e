//! The GPU engine (`grm-gpu`) from the command line: what `grmc derive
//! --gpu` prints of a GPU run (the run itself is `grm_grow`'s, behind the
//! same call as the CPU's: `grm_grow::Backend::Gpu`), the exit code of a
//! GPU error, and `grmc bench gpu`.
//!
//! `--gpu` derives on the GPU and interprets the result there (bones);
//! the string is read back only when it is printed or exported (the model
//! is then built from it as on the CPU path). Without an adapter, or when a
//! derivation outgrows the device, it stops with the reason; with
//! `--cpu-fallback` it derives on the CPU instead and says so. A run-time
//! error in a production (a non-finite parameter, a bad weight) is
//! re-derived on the CPU, which reports it with its source span (both
//! engines stop at the same iteration and module).

use std::path::PathBuf;
use std::time::Duration;

use grm_gpu::GpuError;

use crate::Outcome;

fn ms(d: std::time::Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

/// The exit outcome of a GPU error that stops the run: a production's
/// failing value, a derivation that outgrows a limit or the device, an
/// unbalanced string are the input's (exit 1, like the CPU's R0201/R0202);
/// no device or a failing one is the environment (exit 2).
pub(crate) fn error_outcome(e: &GpuError) -> Outcome {
    match e {
        GpuError::Runtime { .. }
        | GpuError::BufferTooLarge { .. }
        | GpuError::CountOverflow { .. }
        | GpuError::TooManyWorkgroups { .. } => Outcome::InputErrors,
        e if grm_grow::gpu::input_limit(e) => Outcome::InputErrors,
        _ => Outcome::Usage,
    }
}

/// `--stats` of a GPU run, before its first string: the adapter and the
/// table's header.
pub(crate) fn header(gpu: &grm_gpu::Gpu) {
    eprintln!("GPU: {}", gpu.describe());
    outln!(
        "{:>9} {:>14} {:>16} {:>12} {:>10} {:>6}",
        "iteration",
        "modules",
        "cumulative",
        "params",
        "ms",
        "engine"
    );
}

/// `--stats` of a GPU run: a string's row (the engine that made it last).
pub(crate) fn row(s: &grm_derive::IterationStats, on_gpu: bool) {
    outln!(
        "{:>9} {:>14} {:>16} {:>12} {:>10.3} {:>6}",
        s.iteration,
        s.modules,
        s.cumulative_modules,
        s.param_words,
        ms(s.elapsed),
        if on_gpu { "GPU" } else { "CPU" }
    );
}

/// The summary of a GPU run of `c` (`total`: its wall time, read-backs
/// included).
pub(crate) fn summary(
    c: &grm_compile::CompiledSystem,
    opts: &grm_derive::DeriveOptions,
    r: &grm_gpu::GpuRun,
    total: Duration,
    stats: bool,
) {
    let interp = r.interpretation.as_ref();
    let on_cpu = r.stats.iter().skip(1).filter(|s| s.on_cpu).count();
    let n = opts.iterations as usize;
    let engines = match on_cpu {
        _ if r.path == grm_gpu::DerivePath::Direct => {
            "on the GPU, directly (the final string in one pass)".to_string()
        }
        0 => "on the GPU".to_string(),
        k if k == n => "on the CPU (every string within --cpu-prefix)".to_string(),
        k => {
            let span = |a: usize, b: usize| match a == b {
                true => format!("{a}"),
                false => format!("{a}-{b}"),
            };
            format!("({} on the CPU, {} on the GPU)", span(1, k), span(k + 1, n))
        }
    };
    let bones = interp.map_or(0, |i| i.bone_count);
    let interp_elapsed = interp.map_or(Duration::ZERO, |i| i.elapsed);
    if r.derive_waited {
        eprintln!(
            "{}: {} {engines}: {} ({} produced in all) in {:.3} ms, {} modules/us; \
             {} on the GPU in {:.3} ms",
            c.name,
            crate::count(opts.iterations, "iteration"),
            crate::count(r.modules(), "module"),
            r.produced_modules(),
            ms(r.derive_elapsed),
            crate::rate(grm_gpu::bench::rate(r.produced_modules(), r.derive_elapsed)),
            crate::count(bones, "bone"),
            ms(interp_elapsed),
        );
    } else {
        // Pipelined: the derivation was not waited for, so its time is in
        // the interpretation's; only the sum is a measurement.
        let both = r.derive_elapsed + interp_elapsed;
        eprintln!(
            "{}: {} {engines}: {} ({} produced in all) and {} \
             on the GPU in {:.3} ms, derivation and interpretation together \
             ({} produced and final modules/us)",
            c.name,
            crate::count(opts.iterations, "iteration"),
            crate::count(r.modules(), "module"),
            r.produced_modules(),
            crate::count(bones, "bone"),
            ms(both),
            crate::rate(grm_gpu::bench::rate(
                r.produced_modules() + r.modules(),
                both
            )),
        );
    }
    if stats {
        eprintln!(
            "total {:.3} ms (with read-back {:.3} ms)",
            ms(total),
            ms(r.readback_elapsed)
        );
    }
}

#[derive(clap::Args, Debug)]
pub struct GpuBench {
    /// The examples folder.
    #[arg(long, default_value = "examples")]
    pub examples: PathBuf,
    /// Only these scenes (by name, e.g. `hilbert3d`; default: the standard set).
    #[arg(long = "scene")]
    pub scenes: Vec<String>,
    /// Iterations (default: each scene's standard count).
    #[arg(short = 'n', long)]
    pub iterations: Option<u32>,
    /// Timed runs per engine, at least 1 (the best is reported).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..))]
    pub runs: u32,
    /// Threads for the parallel CPU column (0: all cores; at most 1024).
    #[arg(long, default_value_t = 0, value_parser = crate::parse_threads)]
    pub threads: usize,
    /// Skip the CPU baselines.
    #[arg(long)]
    pub no_cpu: bool,
    /// Derive the first iterations on the CPU while the strings have at
    /// most this many modules (a GPU-only derivation is timed as well).
    #[arg(long, value_name = "MODULES", default_value_t = grm_gpu::derive::CPU_PREFIX_MODULES)]
    pub cpu_prefix: u64,
    /// Also time a forest of this many copies of each scene (seeds SEED,
    /// SEED + 1, ...) derived and interpreted together, against the CPU
    /// deriving them one after the other (1 to 4096).
    #[arg(long, value_name = "COPIES", value_parser = clap::value_parser!(u32).range(1..=i64::from(crate::forest::MAX_TREES)))]
    pub forest: Option<u32>,
}

/// `grmc bench gpu`: GPU rows (derivation, interpretation, both) against
/// the CPU engines measured in the same run.
pub fn bench(args: GpuBench) -> Outcome {
    let known = grm_gpu::bench::SCENES.iter().map(|s| s.0);
    if let Some(o) = crate::bench::unknown_scenes(&args.scenes, known) {
        return o;
    }
    if let Some(o) = crate::bench::examples_folder(&args.examples) {
        return o;
    }
    let gpu = match grm_gpu::shared() {
        Ok(g) => g,
        Err(e) => {
            eprintln!("error: GPU: {e}");
            return Outcome::Usage;
        }
    };
    outln!("adapter: {}", gpu.describe());
    if gpu.is_software() {
        outln!("warning: a software adapter (CPU): these are not GPU timings");
    }
    let mut outcome = Outcome::Ok;
    for &(file, system, n) in grm_gpu::bench::SCENES {
        if !args.scenes.is_empty() && !args.scenes.iter().any(|s| s == file) {
            continue;
        }
        let path = args.examples.join(format!("{file}.grm"));
        let loaded = match crate::derive::load(&path, Some(system), &[]) {
            Ok(l) => l,
            Err(o) => return o,
        };
        let c = &loaded.compiled;
        let cfg = grm_gpu::bench::BenchConfig {
            iterations: args.iterations.unwrap_or(n),
            seed: c.settings.seed,
            runs: args.runs,
            threads: args.threads,
            cpu: !args.no_cpu,
            max_modules: 200_000_000,
            cpu_prefix: args.cpu_prefix,
        };
        match grm_gpu::bench::bench_scene(
            gpu,
            &format!("{file} ({system})"),
            loaded.system(),
            c,
            &cfg,
        ) {
            Ok(r) => {
                outln!("\n{}", r.text());
                if let Some(copies) = args.forest {
                    let name = format!("{file} ({system})");
                    match grm_gpu::bench::bench_forest(gpu, &name, loaded.system(), c, copies, &cfg)
                    {
                        Ok(text) => out!("{text}"),
                        Err(e) => {
                            eprintln!("error: {file}: forest of {copies}: {e}");
                            outcome = Outcome::InputErrors;
                        }
                    }
                }
            }
            Err(e) => {
                eprintln!("error: {file}: {e}");
                outcome = Outcome::InputErrors;
            }
        }
    }
    outcome
}

//! The GPU engine (`grm-gpu`) from the command line: `grmc derive --gpu`
//! and `grmc bench gpu`.
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
use std::time::{Duration, Instant};

use grm_gpu::{GpuDeriveOptions, GpuError, GpuRunOptions, TurtleProgram};

use crate::Outcome;
use crate::derive::{DeriveArgs, Loaded, emit, limits, report_derive_error};

fn ms(d: std::time::Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

/// Whether the CPU may take over after this error (`--cpu-fallback`): no
/// device, or the device cannot hold the derivation.
pub(crate) fn device_problem(e: &GpuError) -> bool {
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
/// or the 32-bit indices) or an unbalanced string: the input's fault
/// (exit 1), reported as it is, never a reason to fall back to the CPU.
pub(crate) fn input_limit(e: &GpuError) -> bool {
    matches!(
        e,
        GpuError::ModuleLimit { .. }
            | GpuError::MemoryLimit { .. }
            | GpuError::CountOverflow { .. }
            | GpuError::UnbalancedBrackets { .. }
    )
}

/// The exit outcome of a GPU error that stops the run: a derivation that
/// outgrows the device is a limit, like the CPU's R0201/R0202 (exit 1); no
/// device or a failing one is the environment (exit 2).
pub(crate) fn error_outcome(e: &GpuError) -> Outcome {
    match e {
        GpuError::BufferTooLarge { .. }
        | GpuError::CountOverflow { .. }
        | GpuError::TooManyWorkgroups { .. } => Outcome::InputErrors,
        _ => Outcome::Usage,
    }
}

/// `grmc derive --gpu`. Returns `None` when the CPU path should run
/// instead (`--cpu-fallback` after a device problem, which was reported).
pub fn derive(args: &DeriveArgs, loaded: &Loaded) -> Option<Outcome> {
    let c = &loaded.compiled;
    let lim = limits(args.max_modules, args.max_memory);
    let opts = GpuRunOptions {
        derive: GpuDeriveOptions {
            iterations: args.iterations.unwrap_or(c.settings.iterations),
            seed: args.seed.unwrap_or(c.settings.seed),
            max_modules: lim.max_modules,
            max_bytes: lim.max_bytes,
            sync_iterations: args.stats,
            cpu_prefix: args.cpu_prefix,
            keys: false,
        },
        interpret: true,
        read_string: args.print || args.output.is_some(),
        read_bones: false,
        strategy: grm_gpu::DeriveStrategy::Auto,
        branch_scan: grm_gpu::interp::BranchScan::Auto,
        pipelined: true,
    };
    let fallback = |e: &GpuError| -> Option<Outcome> {
        if args.cpu_fallback && device_problem(e) {
            eprintln!("note: GPU: {e}; deriving on the CPU (--cpu-fallback)");
            None
        } else {
            emit(&loaded.sources, &e.to_diagnostic(c.file, c.span));
            Some(error_outcome(e))
        }
    };
    let gpu = match grm_gpu::shared() {
        Ok(g) => g,
        Err(e) => return fallback(&e),
    };
    let turtle = TurtleProgram::new(loaded.system(), &c.settings);
    if args.stats {
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
    let start = Instant::now();
    // Modules produced so far (strings 1 ..= iteration), as the CPU's
    // `--stats` prints it.
    let mut cumulative = 0u64;
    let mut progress = |s: &grm_gpu::GpuIterationStats| {
        if s.iteration > 0 {
            cumulative = cumulative.saturating_add(s.modules);
        }
        if args.stats {
            outln!(
                "{:>9} {:>14} {:>16} {:>12} {:>10.3} {:>6}",
                s.iteration,
                s.modules,
                cumulative,
                s.param_words,
                ms(s.elapsed),
                if s.on_cpu { "CPU" } else { "GPU" }
            );
        }
    };
    let r = match grm_gpu::run(gpu, c, &turtle, &opts, &mut progress) {
        Ok(r) => r,
        Err(e @ GpuError::Runtime { .. }) => {
            // The CPU engine stops at the same module and names the source.
            let cpu = grm_derive::DeriveOptions {
                iterations: opts.derive.iterations,
                seed: opts.derive.seed,
                limits: lim,
            };
            return Some(match grm_derive::derive(c, &cpu, 0, &mut |_| {}) {
                Err(ce) => report_derive_error(&loaded.sources, c, &ce),
                Ok(_) => {
                    emit(&loaded.sources, &e.to_diagnostic(c.file, c.span));
                    Outcome::InputErrors
                }
            });
        }
        Err(e) if input_limit(&e) => {
            emit(&loaded.sources, &e.to_diagnostic(c.file, c.span));
            return Some(Outcome::InputErrors);
        }
        Err(e) => return fallback(&e),
    };
    let total = start.elapsed();
    let interp = r.interpretation.as_ref();
    let on_cpu = r.stats.iter().skip(1).filter(|s| s.on_cpu).count();
    let n = opts.derive.iterations as usize;
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
            crate::count(opts.derive.iterations, "iteration"),
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
            crate::count(opts.derive.iterations, "iteration"),
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
    if args.stats {
        eprintln!(
            "total {:.3} ms (with read-back {:.3} ms)",
            ms(total),
            ms(r.readback_elapsed)
        );
    }
    let Some(string) = r.string else {
        return Some(Outcome::Ok);
    };
    if args.print {
        outln!(
            "{}",
            grm_compile::text::string_text(&loaded.program, loaded.system(), string.iter())
        );
    }
    if let Some(path) = &args.output {
        return Some(crate::derive::export_string(
            loaded,
            &string,
            path,
            &args.image,
            args.max_memory,
        ));
    }
    Some(Outcome::Ok)
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

//! GPU derivation and interpretation benchmark, with the CPU engines
//! measured in the same run as the baseline (see `grm_gpu::bench`).
//!
//!     cargo run --release -p grm-gpu --example bench                 # the standard scenes
//!     cargo run --release -p grm-gpu --example bench -- --scene hilbert3d -n 7
//!     cargo run --release -p grm-gpu --example bench -- --scene path/to/file.grm --system S -n 5
//!     cargo run --release -p grm-gpu --example bench -- --scene stochastic_plant -n 7 --forest 256
//!
//! `--scene` takes an example name (`examples/NAME.grm`) or a path and may
//! be repeated. `WGPU_ADAPTER_NAME=...` picks an adapter by name.

use std::path::PathBuf;

use clap::Parser;
use grm_gpu::bench::{BenchConfig, bench_scene};

#[derive(Parser, Debug)]
struct Args {
    /// Example name (examples/NAME.grm) or path to a .grm file; repeatable.
    #[arg(long = "scene")]
    scenes: Vec<String>,
    /// The system (default: the scene's standard one, or the file's first).
    #[arg(long)]
    system: Option<String>,
    /// Iterations (default: the scene's standard count, or the system's setting).
    #[arg(short = 'n', long)]
    iterations: Option<u32>,
    #[arg(long)]
    seed: Option<u32>,
    /// Timed runs per engine (the best is reported).
    #[arg(long, default_value_t = 3)]
    runs: u32,
    /// CPU threads for the parallel column (0: all cores).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Skip the CPU baselines (and the check against the CPU string).
    #[arg(long)]
    no_cpu: bool,
    /// Module limit of the derivations.
    #[arg(long, default_value_t = 200_000_000)]
    max_modules: u64,
    /// Derive the first iterations on the CPU while the strings have at
    /// most this many modules (a GPU-only derivation is timed as well).
    #[arg(long, default_value_t = grm_gpu::derive::CPU_PREFIX_MODULES)]
    cpu_prefix: u64,
    /// Also derive and interpret this many seeds of each scene together
    /// (several systems in one dispatch, Lipp 5.4).
    #[arg(long)]
    forest: Option<u32>,
}

/// Where `examples/` is: the current folder when it has one (a copied
/// binary run from a checkout elsewhere, as on a lent GPU machine), else
/// the checkout this was built in.
fn repo() -> PathBuf {
    if std::path::Path::new("examples").is_dir() {
        PathBuf::from(".")
    } else {
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
    }
}

fn main() {
    let args = Args::parse();
    let gpu = match grm_gpu::shared() {
        Ok(g) => g,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(2);
        }
    };
    println!("adapter: {}", gpu.describe());
    if gpu.is_software() {
        println!(
            "warning: a software adapter (CPU): these are not GPU timings; on a GPU machine check that its \
             Vulkan driver is installed (vulkaninfo), or pick it with WGPU_ADAPTER_NAME"
        );
    }
    println!(
        "cpu: {} threads available",
        std::thread::available_parallelism().map_or(1, |n| n.get())
    );
    let names: Vec<String> = if args.scenes.is_empty() {
        grm_gpu::bench::SCENES
            .iter()
            .map(|s| s.0.to_string())
            .collect()
    } else {
        args.scenes.clone()
    };
    let mut failed = false;
    // (scene, final modules, produced + final modules, phases apart, end to end)
    let mut summary: Vec<(
        String,
        u64,
        u64,
        std::time::Duration,
        Option<std::time::Duration>,
    )> = Vec::new();
    for scene in names {
        let std_scene = grm_gpu::bench::SCENES.iter().find(|s| s.0 == scene);
        let path = if scene.ends_with(".grm") {
            PathBuf::from(&scene)
        } else {
            repo().join(format!("examples/{scene}.grm"))
        };
        let system = args
            .system
            .clone()
            .or_else(|| std_scene.map(|s| s.1.to_string()));
        let result = (|| -> Result<String, String> {
            let text = std::fs::read_to_string(&path).map_err(|e| e.to_string())?;
            let (_, checked) = grm_sema::check_text(&path.display().to_string(), &text);
            if checked.has_errors() {
                return Err("the file has errors (run grmc check)".into());
            }
            let p = &checked.program;
            let sys = match &system {
                Some(n) => p.system(n).ok_or_else(|| format!("no system {n}"))?,
                None => p.default_system().ok_or("no system")?,
            };
            let c = grm_compile::compile(p, sys, &p.default_params()).map_err(|e| e.to_string())?;
            let cfg = BenchConfig {
                iterations: args
                    .iterations
                    .or(std_scene.map(|s| s.2))
                    .unwrap_or(c.settings.iterations),
                seed: args.seed.unwrap_or(c.settings.seed),
                runs: args.runs,
                threads: args.threads,
                cpu: !args.no_cpu,
                max_modules: args.max_modules,
                cpu_prefix: args.cpu_prefix,
            };
            let name = format!("{} ({})", path.display(), sys.name);
            let report = bench_scene(gpu, &name, sys, &c, &cfg)?;
            if report.interpret_skipped.is_none() {
                summary.push((
                    format!("{} n {}", scene, cfg.iterations),
                    report.modules,
                    report.produced + report.modules,
                    report.gpu_derive + report.gpu_interpret,
                    report.end_to_end.map(|e| e.0),
                ));
            }
            let mut text = report.text();
            if let Some(copies) = args.forest {
                text.push_str(&grm_gpu::bench::bench_forest(
                    gpu,
                    &name,
                    sys,
                    &c,
                    copies.max(1),
                    &cfg,
                )?);
            }
            Ok(text)
        })();
        match result {
            Ok(text) => println!("\n{text}"),
            Err(e) => {
                eprintln!("error: {}: {e}", path.display());
                failed = true;
            }
        }
    }
    if !summary.is_empty() {
        // The design target: derivation + interpretation of a
        // million-module scene at 20,000 modules/us or more on an H100
        // (produced and final modules over the wall time, as `total:`).
        println!(
            "\nsummary: derivation + interpretation, produced + final modules per microsecond"
        );
        println!(
            "{:<28} {:>12} {:>14} {:>14}  against 20,000 (scenes of 1 million modules or more)",
            "scene", "final", "phases apart", "end to end"
        );
        for (scene, modules, counted, apart, together) in &summary {
            let best = together.map_or(*apart, |t| t.min(*apart));
            let rate = grm_gpu::bench::rate(*counted, best);
            let verdict = match (*modules >= 1_000_000, rate >= 20_000.0) {
                (false, _) => "-",
                (true, true) => "met",
                (true, false) => "not met",
            };
            println!(
                "{scene:<28} {modules:>12} {:>14.1} {:>14}  {verdict}",
                grm_gpu::bench::rate(*counted, *apart),
                together.map_or("-".to_string(), |t| format!(
                    "{:.1}",
                    grm_gpu::bench::rate(*counted, t)
                )),
            );
        }
    }
    if failed {
        std::process::exit(1);
    }
}

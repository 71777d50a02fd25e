//! `grmc bench derive`: CPU derivation throughput on the ABoP scenes, with
//! a naive rewriter measured in the same run as the baseline; `grmc bench
//! render`: drawing `.png` pictures against writing glTF binary.
//!
//! Figure: modules per microsecond, Lipp's count (the sum over the
//! iterations of the length of the string each one produces) divided by the
//! wall time of the whole derivation (axiom and every iteration; compiling
//! is not timed). The engine runs on one thread and on all threads; the
//! baseline is a straightforward `Vec<{symbol, Vec<Value>}>` rewriter that
//! walks the checked expression trees (`grm_sema::eval`, f64) and allocates
//! every module. Its final string length is checked against the engine's.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use grm_derive::{DeriveOptions, Engine};
use grm_sema::{Program, System, TContextItem, Value};

use crate::Outcome;
use crate::derive::{load, report_derive_error};

#[derive(clap::Args, Debug)]
pub struct BenchArgs {
    #[command(subcommand)]
    pub what: BenchWhat,
}

#[derive(clap::Subcommand, Debug)]
pub enum BenchWhat {
    /// Derivation throughput (modules/us) on the ABoP scenes.
    Derive(DeriveBench),
    /// GPU derivation and interpretation against the CPU engines.
    Gpu(crate::gpu::GpuBench),
    /// Drawing `.png` pictures (grm_geom::render) against writing the same
    /// models as glTF binary.
    Render(RenderBench),
}

#[derive(clap::Args, Debug)]
pub struct RenderBench {
    /// The examples folder.
    #[arg(long, default_value = "examples")]
    pub examples: PathBuf,
    /// Timed runs per scene (the best is printed).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub runs: u32,
    /// Only these scenes (by name, e.g. `ternary_tree_8`).
    #[arg(long = "scene")]
    pub scenes: Vec<String>,
    #[command(flatten)]
    pub image: crate::derive::ImageArgs,
}

/// The picture scenes: name, example file, iterations (the file's first
/// system).
const RENDER_SCENES: &[(&str, &str, u32)] = &[
    ("hilbert3d_4", "hilbert3d", 4),
    ("koch_island_4", "koch_island", 4),
    ("bracketed_plant_5", "bracketed_plant", 5),
    ("ternary_tree_6", "ternary_tree", 6),
    ("ternary_tree_8", "ternary_tree", 8),
];

#[derive(clap::Args, Debug)]
pub struct DeriveBench {
    /// The examples folder.
    #[arg(long, default_value = "examples")]
    pub examples: PathBuf,
    /// Timed runs per configuration, at least 2 (fewer are raised to 2:
    /// the first run of a fresh engine is the cold column, the best of all
    /// is the warm one).
    #[arg(long, default_value_t = 5)]
    pub runs: u32,
    /// Threads for the parallel column (0: all cores; at most 1024).
    #[arg(long, default_value_t = 0, value_parser = crate::parse_threads)]
    pub threads: usize,
    /// Only these scenes (by name, e.g. `hilbert3d`).
    #[arg(long = "scene")]
    pub scenes: Vec<String>,
    /// Skip the naive baseline.
    #[arg(long)]
    pub no_baseline: bool,
    /// Carry identity keys in every string (as a derivation for a `.glb`,
    /// a `--tree` or a system that draws does), to measure what keys cost
    /// against the same run without them.
    #[arg(long)]
    pub keys: bool,
    /// The scenes and iterations of the peer comparison instead
    /// (`cargo bench -p grm-derive --bench peers`, `scripts/peers-js.sh`):
    /// Koch island 6, bracketed plant 6, Hilbert 3D 6, row of trees 9.
    #[arg(long)]
    pub peers: bool,
}

/// The peer comparison's scenes (the same names as [`SCENES`]).
const PEER_SCENES: &[(&str, &str, u32)] = &[
    ("koch_island", "KochIsland", 6),
    ("bracketed_plant", "BracketedPlant", 6),
    ("hilbert3d", "Hilbert3D", 6),
    ("row_of_trees", "RowOfTrees", 9),
];

/// The scenes: example file, system, iterations (Lipp's where he has one).
const SCENES: &[(&str, &str, u32)] = &[
    ("hilbert3d", "Hilbert3D", 6),
    ("koch_island", "KochIsland", 6),
    ("bracketed_plant", "BracketedPlant", 7),
    ("row_of_trees", "RowOfTrees", 10),
    ("ternary_tree", "TernaryTreeB", 11),
    // Stochastic: its strings carry identity keys (its draws are keyed by
    // them); the naive baseline does not draw, so it has none here.
    ("stochastic_plant", "StochasticPlant", 10),
];

pub fn run(args: BenchArgs) -> Outcome {
    match args.what {
        BenchWhat::Derive(a) => derive_bench(a),
        BenchWhat::Gpu(a) => crate::gpu::bench(a),
        BenchWhat::Render(a) => render_bench(a),
    }
}

/// `grmc bench render`: per scene, the model is built (timed), written as
/// glTF binary in memory (the baseline: what exporting the model costs
/// anyway), drawn and encoded as PNG; the best of `--runs` of each.
fn render_bench(args: RenderBench) -> Outcome {
    if let Some(o) = unknown_scenes(&args.scenes, RENDER_SCENES.iter().map(|s| s.0)) {
        return o;
    }
    if let Some(o) = examples_folder(&args.examples) {
        return o;
    }
    // The size and samples, checked once (a camera's default target is
    // each scene's own centre).
    let options = args.image.options(&grm_geom::Model::default());
    if let Err(e) = (grm_geom::render::RenderOptions {
        view: grm_geom::render::View::Auto,
        ..options
    })
    .validate()
    {
        eprintln!("error: {e}");
        return Outcome::Usage;
    }
    outln!(
        "grmc bench render: {} ({} threads available), {}x{} pixels, {}x{} samples per pixel, best of {} run{}",
        cpu_model(),
        std::thread::available_parallelism().map_or(1, |n| n.get()),
        options.width,
        options.height,
        options.effective_samples(),
        options.effective_samples(),
        args.runs,
        if args.runs == 1 { "" } else { "s" },
    );
    outln!(
        "{:<18} {:>9} {:>7} | {:>9} {:>8} | {:>9} {:>8} {:>9} | {:>8} | {:>8} {:>9}",
        "scene",
        "triangles",
        "bones",
        "build ms",
        "glb ms",
        "render ms",
        "png ms",
        "png KiB",
        "pic/glb",
        "persp ms",
        "glass ms",
    );
    let ms = |d: Duration| d.as_secs_f64() * 1e3;
    for &(name, file, n) in RENDER_SCENES {
        if !wanted(&args.scenes, name) {
            continue;
        }
        let (loaded, opts) = match load_scene(&args.examples, file, None, n) {
            Ok(r) => r,
            Err(o) => return o,
        };
        let c = &loaded.compiled;
        let derived = Engine::new(c, 0).and_then(|e| e.derive(&opts, &mut |_| {}));
        let string = match derived {
            Ok(d) => d.string,
            Err(e) => return report_derive_error(&loaded.sources, c, &e),
        };
        let build = || {
            grm_geom::build_model(
                &loaded.program,
                loaded.system(),
                &string,
                &c.settings,
                &c.param_values,
            )
        };
        let mut model = None;
        let mut png_len = 0;
        let mut times = [Duration::MAX; 6];
        for _ in 0..args.runs {
            let t = Instant::now();
            let m = match build() {
                Ok(m) => m,
                Err(e) => {
                    crate::derive::emit(
                        &loaded.sources,
                        &e.to_diagnostic(&loaded.program, c.file, c.span),
                    );
                    return Outcome::InputErrors;
                }
            };
            let t_build = t.elapsed();
            let t = Instant::now();
            std::hint::black_box(grm_geom::export::glb_bytes(&m));
            let t_glb = t.elapsed();
            let t = Instant::now();
            let img = match grm_geom::render::render(&m, &args.image.options(&m)) {
                Ok(i) => i,
                Err(e) => {
                    eprintln!("error: {e}");
                    return Outcome::Usage;
                }
            };
            let t_render = t.elapsed();
            let t = Instant::now();
            png_len = match grm_geom::render::png_bytes(&img) {
                Ok(b) => b.len(),
                Err(e) => {
                    eprintln!("error: {name}: the picture could not be encoded: {e}");
                    return Outcome::InputErrors;
                }
            };
            let t_png = t.elapsed();
            // The same picture through the perspective camera the preview
            // frames the model with (from the same direction), and with
            // every material at opacity 0.5 (the translucent pass).
            let options = args.image.options(&m);
            let f = grm_geom::render::framing(&m, options.view);
            let (az, el) = (f.azimuth, f.elevation);
            let t = Instant::now();
            if let Some(camera) = grm_geom::render::orbit_camera(&m, az, el, 45.0) {
                let o = grm_geom::render::RenderOptions {
                    view: camera,
                    ..options
                };
                std::hint::black_box(grm_geom::render::render(&m, &o).ok());
            }
            let t_persp = t.elapsed();
            let mut glass = m.clone();
            for material in &mut glass.materials {
                material.opacity = 0.5;
            }
            let t = Instant::now();
            std::hint::black_box(grm_geom::render::render(&glass, &options).ok());
            let t_glass = t.elapsed();
            for (best, t) in times
                .iter_mut()
                .zip([t_build, t_glb, t_render, t_png, t_persp, t_glass])
            {
                *best = (*best).min(t);
            }
            model = Some(m);
        }
        let Some(m) = model else {
            continue;
        };
        let [t_build, t_glb, t_render, t_png, t_persp, t_glass] = times;
        outln!(
            "{:<18} {:>9} {:>7} | {:>9.2} {:>8.2} | {:>9.2} {:>8.2} {:>9.0} | {:>7.1}x | {:>8.2} {:>9.2}",
            name,
            m.stats.triangles,
            m.stats.bones,
            ms(t_build),
            ms(t_glb),
            ms(t_render),
            ms(t_png),
            png_len as f64 / 1024.0,
            (t_render + t_png).as_secs_f64() / t_glb.as_secs_f64().max(1e-9),
            ms(t_persp),
            ms(t_glass),
        );
    }
    Outcome::Ok
}

/// Whether a scene is run: every one when no `--scene` is given.
fn wanted(scenes: &[String], name: &str) -> bool {
    scenes.is_empty() || scenes.iter().any(|s| s == name)
}

/// Load `examples/FILE.grm` (its `system`, or its first) and the options
/// that derive it `n` times.
fn load_scene(
    examples: &std::path::Path,
    file: &str,
    system: Option<&str>,
    n: u32,
) -> Result<(crate::derive::Loaded, DeriveOptions), Outcome> {
    let loaded = load(&examples.join(format!("{file}.grm")), system, &[])?;
    let opts = DeriveOptions {
        iterations: n,
        ..DeriveOptions::from_system(&loaded.compiled)
    };
    Ok((loaded, opts))
}

/// `--scene` names that are not among `known` are a usage error (a typo
/// would otherwise print an empty table and succeed); `Some` is the
/// outcome to exit with (the problem was printed).
pub fn unknown_scenes<'a>(
    requested: &[String],
    known: impl Iterator<Item = &'a str> + Clone,
) -> Option<Outcome> {
    let unknown: Vec<&str> = requested
        .iter()
        .map(String::as_str)
        .filter(|r| !known.clone().any(|k| k == *r))
        .collect();
    if unknown.is_empty() {
        return None;
    }
    eprintln!(
        "error: unknown scene{} {}; the scenes are: {}",
        if unknown.len() == 1 { "" } else { "s" },
        unknown
            .iter()
            .map(|u| format!("`{u}`"))
            .collect::<Vec<_>>()
            .join(", "),
        known.collect::<Vec<_>>().join(", ")
    );
    Some(Outcome::Usage)
}

fn best(
    runs: u32,
    mut f: impl FnMut() -> Result<u64, Outcome>,
) -> Result<(Duration, u64), Outcome> {
    let mut best = Duration::MAX;
    let mut produced = 0;
    for _ in 0..runs.max(1) {
        let t = Instant::now();
        produced = f()?;
        best = best.min(t.elapsed());
    }
    Ok((best, produced))
}

fn rate(modules: u64, d: Duration) -> f64 {
    modules as f64 / (d.as_secs_f64() * 1e6)
}

pub fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, v)| v.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into())
}

/// The fewest timed runs per configuration: the first run of a fresh
/// engine is the `1T cold` column, so the warm columns need a second.
const MIN_RUNS: u32 = 2;

/// The timed runs per configuration `--runs N` makes.
fn timed_runs(asked: u32) -> u32 {
    asked.max(MIN_RUNS)
}

/// The first line of `bench derive`'s table: the machine and how many runs
/// each figure is the best of (the runs actually made).
fn derive_header(cpu: &str, available: usize, asked_runs: u32) -> String {
    let runs = timed_runs(asked_runs);
    let raised = if runs == asked_runs {
        String::new()
    } else {
        format!(" (--runs {asked_runs} raised to {runs}: the first run is the cold one)")
    };
    format!("CPU derivation, {cpu} ({available} threads available), best of {runs} runs{raised}")
}

// `grmc --threads` accepts exactly what the sampler starts too.
const _: () = assert!(crate::MAX_THREADS == grm_sample::MAX_THREADS);

/// The examples folder the scenes are read from, checked before any table
/// is printed: run away from the repository root, the benchmark would
/// print its header and then fail on the first scene.
pub(crate) fn examples_folder(dir: &std::path::Path) -> Option<Outcome> {
    if dir.join("koch_island.grm").is_file() {
        return None;
    }
    eprintln!(
        "error: the benchmark scenes are read from `{}`, which holds no koch_island.grm: \
         run it from the repository root, or pass `--examples DIR` (the repository's examples/)",
        dir.display()
    );
    Some(Outcome::Usage)
}

fn derive_bench(args: DeriveBench) -> Outcome {
    if let Some(o) = unknown_scenes(&args.scenes, SCENES.iter().map(|s| s.0)) {
        return o;
    }
    if let Some(o) = examples_folder(&args.examples) {
        return o;
    }
    let threads = if args.threads == 0 {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    } else {
        args.threads
    };
    outln!(
        "{}",
        derive_header(
            &cpu_model(),
            std::thread::available_parallelism().map_or(1, |n| n.get()),
            args.runs
        )
    );
    if args.keys {
        outln!("every string carries identity keys (--keys)");
    }
    let nt = format!("{threads}T");
    outln!(
        "{:<16} {:>3} {:>9} {:>9} | {:>9} {:>9} {:>9} {:>9} | {:>8} {:>8} {:>8} {:>8} | {:>7} {:>7}",
        "scene",
        "n",
        "final",
        "produced",
        "naive ms",
        "1T cold",
        "1T ms",
        format!("{nt} ms"),
        "naive/us",
        "cold/us",
        "1T/us",
        format!("{nt}/us"),
        "1T/nv",
        format!("{nt}/1T"),
    );
    let mut failed = false;
    let scenes = if args.peers { PEER_SCENES } else { SCENES };
    for &(file, system, n) in scenes {
        if !wanted(&args.scenes, file) {
            continue;
        }
        let (loaded, opts) = match load_scene(&args.examples, file, Some(system), n) {
            Ok(r) => r,
            Err(o) => return o,
        };
        let c = &loaded.compiled;
        let mut final_len = 0u64;
        // Best of `timed_runs(runs)` (at least 2) with one engine (buffers
        // recycled between runs, as a preview regrowing a model does), and
        // the first run of a fresh engine (cold: every string in fresh
        // memory).
        let mut engine_run = |threads: usize| -> Result<(Duration, Duration, u64), Outcome> {
            let engine = Engine::new(c, threads)
                .map_err(|e| report_derive_error(&loaded.sources, c, &e))?
                .with_keys(args.keys);
            let mut cold = None;
            let (warm, produced) = best(timed_runs(args.runs), || {
                let t = Instant::now();
                let d = engine
                    .derive(&opts, &mut |_| {})
                    .map_err(|e| report_derive_error(&loaded.sources, c, &e))?;
                cold.get_or_insert(t.elapsed());
                final_len = d.string.len() as u64;
                let produced = d.stats.last().map_or(0, |s| s.cumulative_modules);
                engine.recycle(d.string);
                Ok(produced)
            })?;
            Ok((cold.unwrap_or(warm), warm, produced))
        };
        let (cold1, t1, produced) = match engine_run(1) {
            Ok(r) => r,
            Err(o) => return o,
        };
        let (_, tn, _) = match engine_run(threads) {
            Ok(r) => r,
            Err(o) => return o,
        };
        let naive = if args.no_baseline {
            None
        } else {
            let t = Instant::now();
            match naive_derive(&loaded.program, loaded.system(), n) {
                Some(len) => {
                    let d = t.elapsed();
                    if len != final_len {
                        eprintln!(
                            "error: {file}: the baseline derived {len} modules, the engine {final_len}"
                        );
                        failed = true;
                    }
                    Some(d)
                }
                None => None,
            }
        };
        let f = |x: Option<f64>, prec: usize| x.map_or("-".to_string(), |v| format!("{v:.prec$}"));
        let ms = |d: Duration| d.as_secs_f64() * 1e3;
        outln!(
            "{:<16} {:>3} {:>9} {:>9} | {:>9} {:>9.2} {:>9.2} {:>9.2} | {:>8} {:>8.0} {:>8.0} {:>8.0} | {:>7} {:>7.2}",
            file,
            n,
            final_len,
            produced,
            f(naive.map(ms), 1),
            ms(cold1),
            ms(t1),
            ms(tn),
            f(naive.map(|d| rate(produced, d)), 1),
            rate(produced, cold1),
            rate(produced, t1),
            rate(produced, tn),
            f(naive.map(|d| d.as_secs_f64() / t1.as_secs_f64()), 1),
            t1.as_secs_f64() / tn.as_secs_f64(),
        );
    }
    if failed {
        Outcome::InputErrors
    } else {
        Outcome::Ok
    }
}

/// One module of the naive baseline.
struct NaiveModule {
    sym: u32,
    params: Vec<Value>,
}

/// The naive baseline: context-free, deterministic systems only (`None`
/// otherwise). Returns the final string's length.
fn naive_derive(program: &Program, sys: &System, iterations: u32) -> Option<u64> {
    let params = program.default_params();
    let globals = program.global_values(&params).ok()?;
    let random_or_context = sys.groups.iter().any(|g| {
        g.left
            .iter()
            .chain(&g.right)
            .any(|c| matches!(c, TContextItem::Pattern(_)))
            || g.alternatives.len() > 1
    });
    if random_or_context {
        return None;
    }
    fn env<'e>(
        params: &'e [Value],
        globals: &'e [Value],
        bindings: &'e [Value],
    ) -> grm_sema::eval::Env<'e> {
        grm_sema::eval::Env {
            params,
            globals,
            bindings,
        }
    }
    let eval_module = |m: &grm_sema::TModule, bindings: &[Value]| -> Option<NaiveModule> {
        let mut ps = Vec::new();
        for a in &m.args {
            ps.push(grm_sema::eval::eval(a, &env(&params, &globals, bindings)).ok()?);
        }
        Some(NaiveModule {
            sym: m.symbol.0,
            params: ps,
        })
    };
    let mut string: Vec<NaiveModule> = sys
        .axiom
        .iter()
        .map(|m| eval_module(m, &[]))
        .collect::<Option<_>>()?;
    for _ in 0..iterations {
        let mut next = Vec::new();
        for m in &string {
            let mut applied = false;
            for g in sys.groups_of(grm_sema::SymbolId(m.sym)) {
                let bindings: &[Value] = if g.pred.binds > 0 { &m.params } else { &[] };
                if let Some(c) = &g.condition
                    && grm_sema::eval::eval(c, &env(&params, &globals, bindings))
                        .ok()?
                        .as_bool()
                        != Some(true)
                {
                    continue;
                }
                for s in &g.alternatives[0].successor {
                    next.push(eval_module(s, bindings)?);
                }
                applied = true;
                break;
            }
            if !applied {
                next.push(NaiveModule {
                    sym: m.sym,
                    params: m.params.clone(),
                });
            }
        }
        string = next;
    }
    // Touch the parameters so nothing is optimized away.
    let _ = string
        .iter()
        .filter(|m| matches!(m.params.first(), Some(Value::Float(x)) if x.is_nan()))
        .count();
    Some(string.len() as u64)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The header names the runs actually made: at least 2.
    #[test]
    fn header_counts_the_runs_made() {
        assert_eq!(
            derive_header("X", 2, 8),
            "CPU derivation, X (2 threads available), best of 8 runs"
        );
        assert_eq!(
            derive_header("X", 2, 2),
            "CPU derivation, X (2 threads available), best of 2 runs"
        );
        for asked in [0, 1] {
            let h = derive_header("X", 2, asked);
            assert!(
                h.contains(&format!(
                    "best of 2 runs (--runs {asked} raised to 2: the first run is the cold one)"
                )),
                "{h}"
            );
            assert_eq!(timed_runs(asked), 2);
        }
    }
}

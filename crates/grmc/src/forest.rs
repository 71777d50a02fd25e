//! `grmc forest FILE`: many trees of one file's systems, derived together
//! and planted on a grid in one model (the Lipp workflow: a forest of
//! different trees with different seeds, parameters and iteration counts).
//!
//! Tree `k` is system `--system[k % len]` (default: the file's first
//! system) with seed `SEED + k`, its own iteration count, the `--param`
//! values, and for each `--vary NAME=LO..HI` a value drawn for it from the
//! project's counter-based hash (`grm_compile::rng`). The forest grows
//! through `grm_grow::forest::grow`: with `--gpu` the whole forest is one
//! derivation and one interpretation on the device (Lipp 5.4: one count /
//! scan / rewrite per iteration for every tree); without it the trees are
//! derived on the CPU engine, one tree per worker thread. Either way every
//! tree's string is exactly what `grmc derive --system S --seed SEED+k`
//! gives. This front-end plans the trees (systems, seeds, drawn
//! parameters), reports the forest's errors, lays the trees out and builds
//! the model from the strings (the CPU turtle, as `grmc derive -o` does):
//! each tree interpreted alone, moved to its grid cell
//! (`Interpretation::append_translated`) and meshed once.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use grm_compile::CompiledSystem;
use grm_derive::ModuleString;
use grm_geom::grm_turtle::{self, Interpretation};
use grm_grow::forest::{Forest, ForestError, ForestOptions, ForestTree, GrownTree, Ran};

use crate::Outcome;
use crate::derive::{Loaded, emit, limits, report_derive_error};

/// The most trees in one forest: the GPU's directory of systems
/// (`grm_gpu::layout::MAX_SYSTEMS`), whichever engine derives them.
pub const MAX_TREES: u32 = grm_gpu::layout::MAX_SYSTEMS as u32;

/// The draw of `--vary` (the hash's fourth input): apart from every draw
/// a derivation makes, which uses small draw indices.
const VARY_DRAW: u32 = 0x7661_7279;

#[derive(clap::Args, Debug)]
pub struct ForestArgs {
    /// The .grm file.
    pub file: PathBuf,
    /// A system to plant; repeat it for a mixed forest (tree k is the
    /// (k mod count)-th). Default: the file's first system.
    #[arg(long = "system", value_name = "NAME")]
    pub systems: Vec<String>,
    /// How many trees (1 to 4096).
    #[arg(long, default_value_t = 16, value_parser = clap::value_parser!(u32).range(1..=i64::from(MAX_TREES)))]
    pub trees: u32,
    /// Iterations of every tree (default: each system's `iterations`
    /// setting; at most 100,000).
    #[arg(short = 'n', long = "iterations", value_parser = clap::value_parser!(u32).range(..=i64::from(grm_sema::MAX_ITERATIONS)))]
    pub iterations: Option<u32>,
    /// The first tree's seed; tree k has SEED + k, wrapping past
    /// 4294967295 to 0 (default: each system's `seed` setting, plus k).
    #[arg(long)]
    pub seed: Option<u32>,
    /// Override a meta-parameter for every tree: `NAME=VALUE`. Repeatable.
    #[arg(long = "param", value_name = "NAME=VALUE")]
    pub params: Vec<String>,
    /// Draw a number meta-parameter for each tree, uniformly in LO..HI
    /// (inside its declared range). Repeatable.
    #[arg(long = "vary", value_name = "NAME=LO..HI")]
    pub vary: Vec<String>,
    /// Trees per row of the grid (default: the square root of the count,
    /// rounded up).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    pub columns: Option<u32>,
    /// Distance between neighbouring trees (default: the widest tree's
    /// footprint plus 10%, so that no two trees overlap).
    #[arg(long, value_parser = parse_spacing)]
    pub spacing: Option<f32>,
    /// Build the forest's model and write it (.glb .obj .ply .svg, or
    /// .png for a picture of it).
    #[arg(short = 'o', long = "output")]
    pub output: Option<PathBuf>,
    #[command(flatten)]
    pub image: crate::derive::ImageArgs,
    /// Print a line per tree: system, seed, iterations, modules, bones,
    /// place and drawn parameters.
    #[arg(long)]
    pub stats: bool,
    /// Print each tree's derived string (grm source text), a line per
    /// tree in tree order, to stdout.
    #[arg(long)]
    pub print: bool,
    /// CPU worker threads (trees derive in parallel, one per thread): 0
    /// uses all cores (at most 1024).
    #[arg(long, default_value_t = 0, value_parser = crate::parse_threads)]
    pub threads: usize,
    /// Stop with an error before a tree's string, or the forest's final
    /// strings together, would exceed this many modules (default
    /// 50,000,000).
    #[arg(long)]
    pub max_modules: Option<u64>,
    /// Stop with an error before an iteration would need more than this
    /// many MiB (a tree's on the CPU, the forest's on the GPU; default
    /// 2048).
    #[arg(long, value_name = "MIB", value_parser = clap::value_parser!(u64).range(1..))]
    pub max_memory: Option<u64>,
    /// Derive and interpret the whole forest on the GPU, in one
    /// derivation (docs/gpu.md).
    #[arg(long)]
    pub gpu: bool,
    /// With `--gpu`: derive on the CPU when no GPU can be used or the
    /// forest outgrows the device.
    #[arg(long, requires = "gpu")]
    pub cpu_fallback: bool,
    /// With `--gpu`: derive the first iterations on the CPU while the
    /// combined string has at most this many modules.
    #[arg(long, requires = "gpu", value_name = "MODULES", default_value_t = grm_gpu::derive::CPU_PREFIX_MODULES)]
    pub cpu_prefix: u64,
}

/// The largest `--spacing`: beyond it a grid's far corners lose the
/// trees' detail to 32-bit float positions (a 1e30 spacing left nothing).
const MAX_SPACING: f32 = 1e6;

fn parse_spacing(s: &str) -> Result<f32, String> {
    match s.parse::<f32>() {
        Ok(x) if (0.0..=MAX_SPACING).contains(&x) => Ok(x),
        _ => Err(format!("`{s}` is not a distance from 0 to {MAX_SPACING:e}")),
    }
}

/// `--vary NAME=LO..HI`, parsed.
struct Vary {
    name: String,
    lo: f64,
    hi: f64,
}

fn parse_vary(text: &str) -> Result<Vary, String> {
    let bad = || format!("`--vary {text}`: write it as NAME=LO..HI (e.g. angle=20..30)");
    let (name, range) = text.split_once('=').ok_or_else(bad)?;
    let (lo, hi) = range.split_once("..").ok_or_else(bad)?;
    let number = |s: &str| {
        s.trim()
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| format!("`--vary {text}`: `{}` is not a finite number", s.trim()))
    };
    let (lo, hi) = (number(lo)?, number(hi)?);
    if lo > hi {
        return Err(format!("`--vary {text}`: the range is empty ({lo} > {hi})"));
    }
    Ok(Vary {
        name: name.trim().to_string(),
        lo,
        hi,
    })
}

/// One tree of the forest.
struct Tree {
    /// Index into `program.systems`.
    system: usize,
    /// Index into the compiled systems.
    compiled: usize,
    iterations: u32,
    seed: u32,
    /// The `--vary` values, in their order.
    drawn: Vec<f64>,
}

/// The trees' seeds for the summary line: `seed 5`, `seeds 0-255` when
/// they count up by one, else the list (`seeds 5, 1, 2, 3, 9, 5`; the
/// first eight and a count past that).
fn seeds_text(seeds: &[u32]) -> String {
    match seeds {
        [] => String::new(),
        [a] => format!("seed {a}"),
        [a, .., b] if seeds.windows(2).all(|w| w[0].checked_add(1) == Some(w[1])) => {
            format!("seeds {a}-{b}")
        }
        _ => {
            let shown: Vec<String> = seeds.iter().take(8).map(u32::to_string).collect();
            match seeds.len() {
                n if n > 8 => format!("seeds {}, ... ({n} in all)", shown.join(", ")),
                _ => format!("seeds {}", shown.join(", ")),
            }
        }
    }
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

pub fn run(args: ForestArgs) -> Outcome {
    let varies = match args
        .vary
        .iter()
        .map(|v| parse_vary(v))
        .collect::<Result<Vec<_>, _>>()
    {
        Ok(v) => v,
        Err(m) => {
            eprintln!("error: {m}");
            return Outcome::Usage;
        }
    };
    let first = args.systems.first().map(String::as_str);
    let loaded = match crate::derive::load(&args.file, first, &args.params) {
        Ok(l) => l,
        Err(o) => return o,
    };
    let program = &loaded.program;
    let mut systems = vec![loaded.system];
    for name in args.systems.iter().skip(1) {
        let i = match program.pick_system(Some(name)) {
            Ok(i) => i,
            Err(d) => {
                crate::derive::emit(&loaded.sources, &d);
                return Outcome::Usage;
            }
        };
        systems.push(i);
    }
    for &i in &systems {
        if program.systems[i].mode == grm_sema::Mode::Sample {
            let e = grm_derive::DeriveError::SampleSystem {
                system: program.systems[i].name.clone(),
            };
            return report_derive_error(&loaded.sources, &loaded.compiled, &e);
        }
    }
    if let Some(o) =
        crate::derive::check_output_format(&loaded, args.output.as_deref(), &args.image)
    {
        return o;
    }
    // Each range must be inside the parameter's own (checked as overrides).
    for (i, v) in varies.iter().enumerate() {
        let fixed = args
            .params
            .iter()
            .any(|p| p.split_once('=').is_some_and(|(n, _)| n.trim() == v.name));
        if fixed || varies[..i].iter().any(|w| w.name == v.name) {
            eprintln!(
                "error: `--vary {}`: the parameter is also given by {}",
                v.name,
                if fixed {
                    "`--param`"
                } else {
                    "another `--vary`"
                }
            );
            return Outcome::Usage;
        }
        if let Some(id) = program.param_by_name(&v.name)
            && program.params[id.index()].ty != grm_sema::Ty::Float
        {
            eprintln!(
                "error: `--vary {}`: `{}` is a `{}`; only a number can vary",
                v.name,
                v.name,
                program.params[id.index()].ty
            );
            return Outcome::Usage;
        }
        for end in [v.lo, v.hi] {
            let mut o = args.params.clone();
            o.push(format!("{}={end}", v.name));
            if let Err(m) = grm_compile::param_values(program, &o) {
                // Said of the flag as written, and of which end.
                let written = format!("`--param {}={end}`:", v.name);
                let flag = format!("`--vary {}={}..{}`:", v.name, v.lo, v.hi);
                match m.strip_prefix(&written) {
                    Some(rest) => eprintln!("error: {flag} {end} is{rest}"),
                    None => eprintln!("error: {flag} {m}"),
                }
                return Outcome::Usage;
            }
        }
    }

    let (compiled, trees) = match plan(&args, &loaded, &systems, &varies) {
        Ok(p) => p,
        Err(o) => return o,
    };
    let need_model = args.output.is_some() || args.stats;
    let forest: Vec<ForestTree<'_>> = trees
        .iter()
        .map(|t| ForestTree {
            system: &program.systems[t.system],
            compiled: &compiled[t.compiled],
            iterations: t.iterations,
            seed: t.seed,
        })
        .collect();
    let backend = if args.gpu {
        grm_grow::Backend::Gpu(grm_grow::gpu::GpuChoice {
            cpu_prefix: args.cpu_prefix,
            fallback: args.cpu_fallback,
            // The model is built from the strings by the CPU turtle (shapes
            // and polygons too), so the GPU interprets only a forest that
            // stays there: the summary's bone count.
            interpret: !need_model,
            read_string: need_model || args.print,
            sync_iterations: false,
        })
    } else {
        grm_grow::Backend::Cpu
    };
    let opts = ForestOptions {
        limits: limits(args.max_modules, args.max_memory),
        threads: args.threads,
        interpret: need_model,
        backend,
    };
    // What is kept of each tree's string: its text (`--print`).
    let keep = |k: usize, s: &ModuleString| args.print.then(|| text(&loaded, &trees[k], s));
    let start = Instant::now();
    let grown = grm_grow::forest::grow(&forest, &opts, &keep, &mut |e| {
        if let grm_grow::Event::FellBack(e) = e {
            eprintln!("note: GPU: {e}; deriving on the CPU (--cpu-fallback)");
        }
    });
    let grown = match grown {
        Ok(g) => g,
        Err(e) => return report_forest_error(&loaded, &compiled, &trees, &e),
    };
    let elapsed = start.elapsed();
    let engine_note = match &grown.ran {
        Ran::Cpu { workers } => format!("on the CPU ({})", crate::count(*workers as u64, "thread")),
        Ran::Gpu {
            stats,
            bones,
            elapsed,
        } => {
            let gpu_ms = ms(*elapsed);
            let all_on_cpu = stats.iter().skip(1).all(|s| s.on_cpu) && stats.len() > 1;
            match bones {
                _ if all_on_cpu => {
                    "on the CPU (every string within --cpu-prefix; --cpu-prefix 0 for the GPU)"
                        .to_string()
                }
                Some(b) => format!(
                    "on the GPU in one derivation and interpretation ({} there, {gpu_ms:.3} ms)",
                    crate::count(*b, "bone")
                ),
                None => format!("on the GPU in one derivation ({gpu_ms:.3} ms)"),
            }
        }
    };
    let Forest {
        trees: grown,
        modules,
        produced,
        ..
    } = grown;

    let mut names: Vec<&str> = Vec::new();
    for &i in &systems {
        let n = program.systems[i].name.as_str();
        if !names.contains(&n) {
            names.push(n);
        }
    }
    let seeds = seeds_text(&trees.iter().map(|t| t.seed).collect::<Vec<_>>());
    let per_us = if elapsed.as_secs_f64() > 0.0 {
        format!(
            ", {} modules/us",
            crate::rate(produced as f64 / (elapsed.as_secs_f64() * 1e6))
        )
    } else {
        String::new()
    };
    eprintln!(
        "{}: {} of {} ({seeds}): {} ({produced} produced in all) {engine_note} in {:.3} ms{per_us}",
        args.file.display(),
        crate::count(trees.len() as u64, "tree"),
        names.join(", "),
        crate::count(modules, "module"),
        ms(elapsed),
    );
    if args.print {
        for g in &grown {
            outln!("{}", g.kept.as_deref().unwrap_or_default());
        }
    }
    if !need_model {
        return Outcome::Ok;
    }

    let layout = Layout::new(args.columns, args.spacing, &grown);
    if args.stats {
        let mut head = format!(
            "{:>5} {:<20} {:>10} {:>10} {:>12} {:>10} {:>10} {:>10}",
            "tree", "system", "seed", "iterations", "modules", "bones", "x", "z"
        );
        for v in &varies {
            head.push_str(&format!(" {:>10}", v.name));
        }
        outln!("{head}");
        for (k, (t, g)) in trees.iter().zip(&grown).enumerate() {
            let at = layout.place(k);
            let mut line = format!(
                "{k:>5} {:<20} {:>10} {:>10} {:>12} {:>10} {:>10.3} {:>10.3}",
                program.systems[t.system].name,
                t.seed,
                t.iterations,
                g.modules,
                g.interpretation.as_ref().map_or(0, |i| i.bones.len()),
                at.x,
                at.z
            );
            // Exact (the shortest text that reads back), so that a tree
            // can be derived again with `--param NAME=VALUE`.
            for x in &t.drawn {
                line.push_str(&format!(" {x:>10}"));
            }
            outln!("{line}");
        }
    }
    let Some(path) = &args.output else {
        return Outcome::Ok;
    };
    let mut forest = Interpretation::default();
    {
        // Exactly the trees' sizes: the forest's arrays never grow by
        // doubling (the memory limit counted the trees, not twice that).
        let sum = |f: fn(&Interpretation) -> usize| -> usize {
            grown
                .iter()
                .filter_map(|g| g.interpretation.as_ref())
                .map(f)
                .sum()
        };
        forest.bones.reserve_exact(sum(|i| i.bones.len()));
        forest.instances.reserve_exact(sum(|i| i.instances.len()));
        forest.polygons.reserve_exact(sum(|i| i.polygons.len()));
        forest
            .polygon_vertices
            .reserve_exact(sum(|i| i.polygon_vertices.len()));
    }
    let mut module_base = 0u64;
    // Each tree's own interpretation is dropped once it is in the forest
    // (not both held to the end).
    for (k, g) in grown.into_iter().enumerate() {
        let Some(interp) = &g.interpretation else {
            continue;
        };
        let placed = u32::try_from(module_base)
            .ok()
            .and_then(|base| forest.append_translated(interp, layout.place(k), base));
        if placed.is_none() {
            eprintln!(
                "error: the forest has more than {} modules or parts; a model cannot number them (plant fewer or smaller trees)",
                u32::MAX
            );
            return Outcome::InputErrors;
        }
        module_base += g.modules;
    }
    eprintln!(
        "{} x {} grid, spacing {:.3} x {:.3}",
        layout.columns, layout.rows, layout.dx, layout.dz
    );
    let model = match grm_geom::build_from_interpretation(
        program,
        forest,
        &crate::derive::model_options(args.max_memory, path, &args.image),
        &loaded.compiled.param_values,
    ) {
        Ok(m) => m,
        Err(e) => {
            let c = &loaded.compiled;
            emit(&loaded.sources, &e.to_diagnostic(program, c.file, c.span));
            return Outcome::InputErrors;
        }
    };
    crate::derive::export_model(&loaded, &model, path, &args.image)
}

/// Compile what the trees need (one system per `--system` without
/// `--vary`, one per tree with it) and list the trees.
fn plan(
    args: &ForestArgs,
    loaded: &Loaded,
    systems: &[usize],
    varies: &[Vary],
) -> Result<(Vec<CompiledSystem>, Vec<Tree>), Outcome> {
    let program = &loaded.program;
    let compile = |system: usize, overrides: &[String]| {
        let values = grm_compile::param_values(program, overrides).map_err(|m| {
            eprintln!("error: {m}");
            Outcome::Usage
        })?;
        grm_compile::compile(program, &program.systems[system], &values).map_err(|e| {
            emit(&loaded.sources, &e.to_diagnostic());
            Outcome::InputErrors
        })
    };
    let mut compiled = Vec::new();
    if varies.is_empty() {
        for &s in systems {
            compiled.push(compile(s, &args.params)?);
        }
    }
    let base_seed = args.seed.unwrap_or(loaded.compiled.settings.seed);
    let mut trees = Vec::with_capacity(args.trees as usize);
    for k in 0..args.trees {
        let slot = k as usize % systems.len();
        let system = systems[slot];
        let mut drawn = Vec::with_capacity(varies.len());
        let index = if varies.is_empty() {
            slot
        } else {
            let mut overrides = args.params.clone();
            for (j, v) in varies.iter().enumerate() {
                let u = f64::from(grm_compile::rng::uniform(base_seed, k, j as u32, VARY_DRAW));
                // Six decimals, so that the value printed is the value used.
                let x = v.lo + (v.hi - v.lo) * u;
                let r: f64 = format!("{x:.6}").parse().unwrap_or(x);
                let x = if (v.lo..=v.hi).contains(&r) {
                    r
                } else {
                    x.clamp(v.lo, v.hi)
                };
                drawn.push(x);
                overrides.push(format!("{}={x}", v.name));
            }
            let drawn_text: Vec<String> = varies
                .iter()
                .zip(&drawn)
                .map(|(v, x)| format!("{}={x}", v.name))
                .collect();
            compiled.push(compile(system, &overrides).inspect_err(|_| {
                eprintln!(
                    "note: tree {k} ({}, drawn by --vary: {})",
                    program.systems[system].name,
                    drawn_text.join(", ")
                );
            })?);
            compiled.len() - 1
        };
        let c = &compiled[index];
        trees.push(Tree {
            system,
            compiled: index,
            iterations: args.iterations.unwrap_or(c.settings.iterations),
            seed: args.seed.unwrap_or(c.settings.seed).wrapping_add(k),
            drawn,
        });
    }
    Ok((compiled, trees))
}

/// A tree's string as grm source text.
fn text(loaded: &Loaded, t: &Tree, s: &ModuleString) -> String {
    let p = &loaded.program;
    grm_compile::text::string_text(p, &p.systems[t.system], s.iter())
}

/// Report a tree's turtle error (a string its own system did not make:
/// not expected of a checked system); the outcome to exit with.
fn report_turtle(
    loaded: &Loaded,
    c: &CompiledSystem,
    k: usize,
    e: grm_turtle::TurtleError,
) -> Outcome {
    eprintln!("error: tree {k}:");
    emit(
        &loaded.sources,
        &grm_geom::GeomError::Turtle(e).to_diagnostic(&loaded.program, c.file, c.span),
    );
    Outcome::InputErrors
}

/// Report why the forest stopped: a tree's error (said of that tree, at
/// its system), or the forest's limits; the outcome to exit with.
fn report_forest_error(
    loaded: &Loaded,
    compiled: &[CompiledSystem],
    trees: &[Tree],
    e: &ForestError,
) -> Outcome {
    let of = |k: usize| &compiled[trees[k].compiled];
    match e {
        ForestError::Derive { tree: k, error } => {
            eprintln!("error: tree {k} (seed {}):", trees[*k].seed);
            report_derive_error(&loaded.sources, of(*k), error)
        }
        ForestError::Turtle { tree: k, error } => report_turtle(loaded, of(*k), *k, error.clone()),
        ForestError::MemoryLimit {
            tree,
            footprint,
            limit,
        } => {
            // R0202: the trees' interpretations alone are over the limit
            // the forest's model must keep.
            let e = grm_geom::GeomError::MemoryLimit {
                footprint: *footprint,
                limit: *limit,
                output: grm_geom::Output::Model,
            };
            let d = match *tree {
                Some(k) => {
                    let c = of(k);
                    e.to_diagnostic(&loaded.program, c.file, c.span).with_note(format!(
                        "counted from the trees' strings, before their meshes: tree {k} (seed {}) took the forest over the limit",
                        trees[k].seed
                    ))
                }
                None => {
                    let c = &loaded.compiled;
                    e.to_diagnostic(&loaded.program, c.file, c.span)
                        .with_note("counted from the trees' strings, before their meshes")
                }
            };
            emit(&loaded.sources, &d);
            Outcome::InputErrors
        }
        ForestError::ModuleLimit {
            tree: k,
            modules,
            limit,
        } => {
            // R0201 as for one string: the forest's strings are bounded
            // together, as on the GPU where they are one string.
            let c = of(*k);
            emit(
                &loaded.sources,
                &grm_diag::Diagnostic::new(
                    grm_diag::Code::ModuleLimit,
                    format!(
                        "the forest's strings would hold {modules} modules or more together, more than the limit of {limit}"
                    ),
                    c.file,
                    c.span,
                    format!("tree {k} (seed {}) took the forest over the limit", trees[*k].seed),
                )
                .with_help("plant fewer trees (`--trees`), derive fewer iterations (`-n`), or raise the limit (`--max-modules`)"),
            );
            Outcome::InputErrors
        }
        ForestError::Gpu(g) => {
            // The GPU's error where the CPU did not take over, or a value
            // the GPU failed that the CPU engine computed (not a forest
            // the engines disagree on).
            let c = &loaded.compiled;
            emit(&loaded.sources, &g.to_diagnostic(c.file, c.span));
            crate::gpu::error_outcome(g)
        }
    }
}

/// What a tree's meshes can cover: its skeleton's bounds (bone ends,
/// shapes, polygons) grown by its thickest tube's radius; `None` when it
/// has no geometry.
fn footprint(i: &Interpretation) -> Option<grm_turtle::Aabb> {
    if i.bounds.is_empty() {
        return None;
    }
    let radius = i
        .bones
        .iter()
        .map(|b| b.width_base.max(b.width_tip))
        .filter(|w| w.is_finite())
        .fold(0.0f32, f32::max)
        / 2.0;
    let r = glam::Vec3::splat(radius);
    Some(grm_turtle::Aabb {
        min: i.bounds.min - r,
        max: i.bounds.max + r,
    })
}

/// The grid: tree `k` in column `k % columns`, row `k / columns`, the
/// grid centred on the origin (x across, z in depth; trees grow along +y).
struct Layout {
    columns: u32,
    rows: u32,
    dx: f32,
    dz: f32,
}

impl Layout {
    fn new<T>(columns: Option<u32>, spacing: Option<f32>, grown: &[GrownTree<T>]) -> Layout {
        let n = grown.len().max(1) as u32;
        let columns = columns
            .unwrap_or_else(|| (f64::from(n).sqrt().ceil()) as u32)
            .clamp(1, n);
        let rows = n.div_ceil(columns);
        let (dx, dz) = match spacing {
            Some(s) => (s, s),
            None => {
                // Tree k's x extent is [a_k, b_k] around its own origin;
                // cells max(b) - min(a) apart never overlap.
                let mut all = grm_turtle::Aabb::EMPTY;
                for i in grown.iter().filter_map(|g| g.interpretation.as_ref()) {
                    if let Some(b) = footprint(i) {
                        all = all.union(&b);
                    }
                }
                let size = all.size();
                // Square cells, as wide as the widest extent (a flat
                // plant's rows as far apart in depth as its columns).
                let d = (size.x.max(size.z) * 1.1).max(0.0);
                let d = if d > 0.0 { d } else { size.y.max(1.0) };
                (d, d)
            }
        };
        Layout {
            columns,
            rows,
            dx,
            dz,
        }
    }

    fn place(&self, k: usize) -> glam::Vec3 {
        let (c, r) = (k as u32 % self.columns, k as u32 / self.columns);
        // `+ 0.0` turns the centre's -0 into 0 (printed by `--stats`).
        let x = (c as f32 - (self.columns - 1) as f32 / 2.0) * self.dx + 0.0;
        let z = (r as f32 - (self.rows - 1) as f32 / 2.0) * self.dz + 0.0;
        glam::Vec3::new(x, 0.0, z)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn the_summary_names_the_seeds_the_trees_have() {
        assert_eq!(seeds_text(&[]), "");
        assert_eq!(seeds_text(&[7]), "seed 7");
        assert_eq!(seeds_text(&[0, 1, 2, 3]), "seeds 0-3");
        // Mixed systems with seeds of their own (`seed = 5`).
        assert_eq!(seeds_text(&[5, 1, 2, 3, 9, 5]), "seeds 5, 1, 2, 3, 9, 5");
        assert_eq!(seeds_text(&[5, 5]), "seeds 5, 5");
        assert_eq!(
            seeds_text(&(0..20).map(|k| k * 2).collect::<Vec<_>>()),
            "seeds 0, 2, 4, 6, 8, 10, 12, 14, ... (20 in all)"
        );
        assert_eq!(seeds_text(&[u32::MAX, 0]), "seeds 4294967295, 0");
    }

    fn tree(min: Vec3, max: Vec3) -> GrownTree<()> {
        GrownTree {
            modules: 1,
            interpretation: Some(Interpretation {
                bounds: grm_turtle::Aabb { min, max },
                ..Interpretation::default()
            }),
            kept: (),
        }
    }

    /// Trees off-centre around their own origins never overlap at the
    /// default spacing, and the grid is centred on the origin.
    #[test]
    fn default_spacing_keeps_neighbours_apart() {
        let grown = vec![
            tree(Vec3::new(-1.0, 0.0, -0.5), Vec3::new(3.0, 5.0, 0.5)),
            tree(Vec3::new(-2.0, 0.0, -1.0), Vec3::new(0.5, 4.0, 2.0)),
            tree(Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 1.0)),
            tree(Vec3::new(-0.5, 0.0, -2.0), Vec3::new(0.5, 2.0, 0.0)),
            tree(Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 1.0, 1.0)),
        ];
        let l = Layout::new(None, None, &grown);
        assert_eq!((l.columns, l.rows), (3, 2));
        // Square cells as wide as the widest extent (x: -2 .. 3).
        assert!((l.dx - 5.0 * 1.1).abs() < 1e-5, "{}", l.dx);
        assert_eq!(l.dx, l.dz);
        let boxes: Vec<grm_turtle::Aabb> = grown
            .iter()
            .enumerate()
            .map(|(k, g)| {
                let b = g
                    .interpretation
                    .as_ref()
                    .map(|i| i.bounds)
                    .unwrap_or_default();
                let at = l.place(k);
                grm_turtle::Aabb {
                    min: b.min + at,
                    max: b.max + at,
                }
            })
            .collect();
        for i in 0..boxes.len() {
            for j in i + 1..boxes.len() {
                let (a, b) = (&boxes[i], &boxes[j]);
                let overlap = a.min.x < b.max.x
                    && b.min.x < a.max.x
                    && a.min.z < b.max.z
                    && b.min.z < a.max.z;
                assert!(!overlap, "trees {i} and {j}: {a:?} {b:?}");
            }
        }
        // Centred: the first and last columns, rows mirror each other.
        assert!((l.place(0).x + l.place(2).x).abs() < 1e-5);
        assert!((l.place(0).z + l.place(3).z).abs() < 1e-5);
    }

    /// Flat trees get the spacing across in depth too; a thick tube widens
    /// the cell by its radius; `--spacing` and `--columns` are taken as
    /// given (columns at most the tree count).
    #[test]
    fn flat_trees_and_given_spacing() {
        let flat = vec![
            tree(Vec3::new(-1.0, 0.0, 0.0), Vec3::new(1.0, 3.0, 0.0)),
            tree(Vec3::new(-1.0, 0.0, 0.0), Vec3::new(1.0, 3.0, 0.0)),
        ];
        let l = Layout::new(None, None, &flat);
        assert_eq!((l.columns, l.rows), (2, 1));
        assert!((l.dx - 2.2).abs() < 1e-5 && (l.dz - 2.2).abs() < 1e-5);
        // One bone of width 4 (radius 2) from (0,0,0) to (0,1,0): the mesh
        // spans -2 .. 2 across.
        let mut thick = Interpretation::default();
        thick.bones.push(grm_turtle::Bone {
            base: Vec3::ZERO,
            tip: Vec3::Y,
            left: Vec3::X,
            parent: None,
            width_base: 4.0,
            width_tip: 4.0,
            paint: grm_turtle::Paint::Palette(0),
            module: 0,
            origin: 0,
        });
        thick.bounds = grm_turtle::Aabb {
            min: Vec3::ZERO,
            max: Vec3::Y,
        };
        let grown = vec![
            GrownTree {
                modules: 1,
                interpretation: Some(thick),
                kept: (),
            },
            tree(Vec3::ZERO, Vec3::Y),
        ];
        let l = Layout::new(None, None, &grown);
        assert!((l.dx - 4.4).abs() < 1e-5, "{}", l.dx);
        let l = Layout::new(Some(10), Some(7.0), &flat);
        assert_eq!((l.columns, l.rows, l.dx, l.dz), (2, 1, 7.0, 7.0));
        assert_eq!(l.place(1), Vec3::new(3.5, 0.0, 0.0));
    }

    #[test]
    fn vary_flags_parse_or_say_why() {
        let v = parse_vary("a = 1.5..2").expect("parses");
        assert_eq!((v.name.as_str(), v.lo, v.hi), ("a", 1.5, 2.0));
        assert!(parse_vary("a=2..1").is_err());
        assert!(parse_vary("a=1").is_err());
        assert!(parse_vary("a=x..2").is_err());
        assert!(parse_vary("a=1..inf").is_err());
        let v = parse_vary("a=3..3").expect("one value");
        assert_eq!(v.lo, v.hi);
    }
}

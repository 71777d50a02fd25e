//! `grmc derive FILE`: check, compile and derive one system; print
//! statistics or the string, or build and export the model. The system
//! grows through `grm_grow::Grower`, on the CPU or (`--gpu`) the GPU
//! behind the same call; this front-end prints and exports.
//!
//! Also the helpers `grmc disasm`, `grmc sample` and `grmc bench` share:
//! loading and compiling a system with `--param` overrides, and rendering
//! run-time errors (codes `R0xxx`, docs/diagnostics.md) through
//! `grm_diag::render_human`, like `grmc check` renders its diagnostics.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use grm_compile::CompiledSystem;
use grm_derive::{DeriveError, DeriveLimits, DeriveOptions, Engine};
use grm_diag::{Diagnostic, Severity, SourceMap};
use grm_sema::Program;

use crate::Outcome;

#[derive(clap::Args, Debug)]
pub struct DeriveArgs {
    /// The .grm file.
    pub file: PathBuf,
    /// The system to derive (default: the file's first system).
    #[arg(long)]
    pub system: Option<String>,
    /// Iterations (default: the system's `iterations` setting; at most
    /// 100,000).
    #[arg(short = 'n', long = "iterations", value_parser = clap::value_parser!(u32).range(..=i64::from(grm_sema::MAX_ITERATIONS)))]
    pub iterations: Option<u32>,
    /// Random seed (default: the system's `seed` setting).
    #[arg(long)]
    pub seed: Option<u32>,
    /// Worker threads: 1 runs on the main thread, 0 uses all cores (at
    /// most 1024).
    #[arg(long, default_value_t = 0, value_parser = crate::parse_threads)]
    pub threads: usize,
    /// Override a meta-parameter: `NAME=VALUE` (a number, `true`/`false`,
    /// or `x,y,z` for a vec3). Repeatable.
    #[arg(long = "param", value_name = "NAME=VALUE")]
    pub params: Vec<String>,
    /// Build the model and write it (format by extension: .glb .obj .ply
    /// .svg, or .png for a picture of it).
    #[arg(short = 'o', long = "output")]
    pub output: Option<PathBuf>,
    #[command(flatten)]
    pub image: ImageArgs,
    /// With -o: write the model of every iteration, 0 to N, as NAME-K.EXT
    /// (K zero-padded; at most 1,000 files); pictures share one view and
    /// framing, so the growth stays in place from frame to frame.
    #[arg(long, requires = "output", conflicts_with = "gpu")]
    pub frames: bool,
    /// Print each iteration's string length, cumulative modules and time.
    #[arg(long)]
    pub stats: bool,
    /// Print the derived string (as grm source text) to stdout.
    #[arg(long)]
    pub print: bool,
    /// Stop with an error before any string would exceed this many modules
    /// (default 50,000,000).
    #[arg(long)]
    pub max_modules: Option<u64>,
    /// Stop with an error before an iteration would need more than this
    /// many MiB (default 2048).
    #[arg(long, value_name = "MIB", value_parser = clap::value_parser!(u64).range(1..))]
    pub max_memory: Option<u64>,
    /// Derive (and interpret) on the GPU (grm-gpu; docs/gpu.md).
    #[arg(long)]
    pub gpu: bool,
    /// Write the derivation tree as JSON: every module that existed, its
    /// identity key, parent, symbol, the production that rewrote it (with
    /// its source range) and what the final string's modules drew
    /// (docs/engine.md, "Identity"). Not with --gpu.
    #[arg(long, value_name = "FILE.json", conflicts_with = "gpu")]
    pub tree: Option<PathBuf>,
    #[command(flatten)]
    pub edits: EditsArgs,
    /// With `--gpu`: derive on the CPU when no GPU can be used or the
    /// derivation outgrows the device.
    #[arg(long, requires = "gpu")]
    pub cpu_fallback: bool,
    /// With `--gpu`: derive the first iterations on the CPU while the
    /// strings have at most this many modules (0: every iteration on the
    /// GPU; the string is the same either way).
    #[arg(long, requires = "gpu", value_name = "MODULES", default_value_t = grm_gpu::derive::CPU_PREFIX_MODULES)]
    pub cpu_prefix: u64,
}

/// Which persistent edits a growth replays (`derive` and `sample` share
/// these flags; `crate::shape::edits_of` reads the file).
#[derive(clap::Args, Debug, Clone, Default)]
pub struct EditsArgs {
    /// Replay the persistent edits of this file instead of NAME.edits.json
    /// beside the grammar (docs/edits.md; derive mode replays key targets,
    /// on the CPU; sample mode replays them in the sampler).
    #[arg(long, value_name = "FILE.edits.json", conflicts_with = "no_edits")]
    pub edits: Option<PathBuf>,
    /// Grow without the persistent edits.
    #[arg(long)]
    pub no_edits: bool,
}

/// How a `.png` output is drawn (`derive`, `forest` and `sample` share
/// these flags; grm_geom::render says how the picture is made).
#[derive(clap::Args, Debug, Clone, Default)]
pub struct ImageArgs {
    /// For a picture (-o FILE.png): its size in pixels (default 1024x1024;
    /// each side 1 to 16384, at most 16,777,216 pixels in all).
    #[arg(long, value_name = "WIDTHxHEIGHT", value_parser = parse_image_size)]
    pub image_size: Option<ImageSize>,
    /// For a picture (-o FILE.png): look at the model from AZIMUTH,ELEVATION
    /// degrees: azimuth about +y from +z towards +x, elevation above the
    /// xz plane (default: from +z for a model flat in xy, else 35,20).
    #[arg(long, value_name = "AZIMUTH,ELEVATION", value_parser = parse_view, allow_hyphen_values = true)]
    pub view: Option<ViewAngles>,
    /// For a picture (-o FILE.png): a perspective camera at X,Y,Z (the
    /// preview's: +y up, not fitted to the model) instead of the fitted
    /// orthographic view.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_point, allow_hyphen_values = true, conflicts_with = "view")]
    pub camera: Option<[f64; 3]>,
    /// The point --camera looks at (default: the centre of the model's
    /// bounds).
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_point, allow_hyphen_values = true, requires = "camera")]
    pub look_at: Option<[f64; 3]>,
    /// The vertical field of view of --camera in degrees, more than 0 and
    /// at most 179 (default 45, the preview's).
    #[arg(long, value_name = "DEGREES", value_parser = parse_fov, requires = "camera")]
    pub fov: Option<f32>,
    /// For a picture (-o FILE.png): a transparent background instead of
    /// the grey gradient.
    #[arg(long)]
    pub transparent: bool,
}

/// `--image-size`'s value.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImageSize {
    pub width: u32,
    pub height: u32,
}

/// `--view`'s value, in degrees.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewAngles {
    pub azimuth: f32,
    pub elevation: f32,
}

/// `--image-size WIDTHxHEIGHT` (or a single number for a square).
fn parse_image_size(text: &str) -> Result<ImageSize, String> {
    let bad = || {
        format!(
            "`{text}` is not a picture size: write WIDTHxHEIGHT, e.g. 1920x1080 (each side 1 to {})",
            grm_geom::render::MAX_IMAGE_SIDE
        )
    };
    let (w, h) = match text.split_once(['x', 'X']) {
        Some((w, h)) => (w.trim(), h.trim()),
        None => (text.trim(), text.trim()),
    };
    let (width, height) = match (w.parse::<u32>(), h.parse::<u32>()) {
        (Ok(w), Ok(h)) => (w, h),
        _ => return Err(bad()),
    };
    let options = grm_geom::render::RenderOptions {
        width,
        height,
        ..Default::default()
    };
    match options.validate() {
        Ok(()) => Ok(ImageSize { width, height }),
        Err(grm_geom::render::RenderError::Size { .. })
            if width == 0
                || height == 0
                || width.max(height) > grm_geom::render::MAX_IMAGE_SIDE =>
        {
            Err(bad())
        }
        Err(e) => Err(e.to_string()),
    }
}

/// `--view AZIMUTH,ELEVATION` in degrees.
fn parse_view(text: &str) -> Result<ViewAngles, String> {
    let bad = || {
        format!(
            "`{text}` is not a view: write AZIMUTH,ELEVATION in degrees, e.g. 35,20 (elevation -90 to 90)"
        )
    };
    let (a, e) = text.split_once(',').ok_or_else(bad)?;
    let (azimuth, elevation) = match (a.trim().parse::<f32>(), e.trim().parse::<f32>()) {
        (Ok(a), Ok(e)) => (a, e),
        _ => return Err(bad()),
    };
    // Numbers, but not angles to draw from (`1e400` reads as infinity):
    // say which one is wrong.
    if !azimuth.is_finite() {
        return Err(format!(
            "`{text}` is not a view: the azimuth must be a finite number of degrees"
        ));
    }
    if !(-90.0..=90.0).contains(&elevation) {
        return Err(format!(
            "`{text}` is not a view: the elevation must be -90 to 90 degrees"
        ));
    }
    Ok(ViewAngles { azimuth, elevation })
}

/// `--camera` and `--look-at`: X,Y,Z, three finite numbers.
fn parse_point(text: &str) -> Result<[f64; 3], String> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    let numbers: Vec<f64> = parts.iter().filter_map(|p| p.parse().ok()).collect();
    match numbers[..] {
        [x, y, z] if parts.len() == 3 => {
            if x.is_finite() && y.is_finite() && z.is_finite() {
                Ok([x, y, z])
            } else {
                Err(format!(
                    "`{text}` is not a point: its coordinates must be finite numbers"
                ))
            }
        }
        _ => Err(format!(
            "`{text}` is not a point: write X,Y,Z, three numbers, e.g. 6,4,8"
        )),
    }
}

/// `--fov DEGREES`: more than 0, at most [`grm_geom::render::MAX_FOV`].
fn parse_fov(text: &str) -> Result<f32, String> {
    match text.trim().parse::<f32>() {
        Ok(f) if f > 0.0 && f <= grm_geom::render::MAX_FOV => Ok(f),
        _ => Err(format!(
            "`{text}` is not a field of view: write degrees, more than 0 and at most {}",
            grm_geom::render::MAX_FOV
        )),
    }
}

/// `--fov`'s default: the preview's camera.
pub const DEFAULT_FOV: f32 = 45.0;

impl ImageArgs {
    /// The first picture flag given, as written on the command line.
    fn given(&self) -> Option<&'static str> {
        if self.image_size.is_some() {
            Some("--image-size")
        } else if self.view.is_some() {
            Some("--view")
        } else if self.camera.is_some() {
            Some("--camera")
        } else if self.transparent {
            Some("--transparent")
        } else {
            None
        }
    }

    /// The renderer's options for a picture of `model` (`--camera`
    /// without `--look-at` looks at the centre of its bounds, or at the
    /// origin when it has none).
    pub fn options(&self, model: &grm_geom::Model) -> grm_geom::render::RenderOptions {
        let mut o = grm_geom::render::RenderOptions::default();
        if let Some(size) = self.image_size {
            o.width = size.width;
            o.height = size.height;
        }
        if let Some(v) = self.view {
            o.view = grm_geom::render::View::Angles {
                azimuth: v.azimuth,
                elevation: v.elevation,
            };
        }
        if let Some(eye) = self.camera {
            let target = match self.look_at {
                Some(t) => glam::DVec3::from_array(t),
                None => {
                    let b = &model.stats.bounds;
                    if b.is_empty() {
                        glam::DVec3::ZERO
                    } else {
                        // In f64: the mean of two f32 extremes may overflow f32.
                        (b.min.as_dvec3() + b.max.as_dvec3()) * 0.5
                    }
                }
            };
            o.view = grm_geom::render::View::Camera {
                eye: glam::DVec3::from_array(eye),
                target,
                fov: self.fov.unwrap_or(DEFAULT_FOV),
            };
        }
        o.transparent = self.transparent;
        o
    }
}

/// A system loaded, checked and compiled, with what it came from.
pub struct Loaded {
    pub sources: SourceMap,
    pub program: Program,
    /// Index into `program.systems`.
    pub system: usize,
    pub compiled: CompiledSystem,
}

impl Loaded {
    pub fn system(&self) -> &grm_sema::System {
        &self.program.systems[self.system]
    }
}

fn color() -> bool {
    std::io::stderr().is_terminal() && std::env::var_os("NO_COLOR").is_none()
}

/// Load, check (printing diagnostics), pick the system, apply `--param`s
/// and compile. `Err` is the outcome to exit with (the problem was printed).
pub fn load(path: &Path, system: Option<&str>, params: &[String]) -> Result<Loaded, Outcome> {
    load_checked(path, system, params)?.compile()
}

/// A system loaded and checked, with the run's meta-parameter values,
/// not compiled yet (a shape system is not compiled: `crate::shape`).
pub struct Checked {
    pub sources: SourceMap,
    pub program: Program,
    /// Index into `program.systems`.
    pub system: usize,
    /// The `--param` values (by `ParamId`).
    pub values: Vec<grm_sema::Value>,
}

impl Checked {
    pub fn system(&self) -> &grm_sema::System {
        &self.program.systems[self.system]
    }

    /// Compile the system (errors printed; the outcome to exit with).
    pub fn compile(self) -> Result<Loaded, Outcome> {
        let compiled = match grm_compile::compile(&self.program, self.system(), &self.values) {
            Ok(c) => c,
            Err(e) => {
                emit(&self.sources, &e.to_diagnostic());
                return Err(Outcome::InputErrors);
            }
        };
        Ok(Loaded {
            sources: self.sources,
            program: self.program,
            system: self.system,
            compiled,
        })
    }
}

/// Load, check (printing diagnostics), pick the system and apply
/// `--param`s. `Err` is the outcome to exit with (the problem was printed).
pub fn load_checked(
    path: &Path,
    system: Option<&str>,
    params: &[String],
) -> Result<Checked, Outcome> {
    let (sources, checked) = match crate::check::load_and_check(path) {
        Ok(r) => r,
        Err(u) => {
            eprint!("{}", u.render(color()));
            return Err(Outcome::Usage);
        }
    };
    {
        let mut human = grm_diag::HumanRenderer::new(&sources, color());
        for d in &checked.diagnostics {
            eprint!("{}", human.render(d));
        }
    }
    if checked
        .diagnostics
        .iter()
        .any(|d| d.severity == Severity::Error)
    {
        return Err(Outcome::InputErrors);
    }
    let program = checked.program;
    // R0701: no system to run (exit 2: the command names what to run).
    let index = match program.pick_system(system) {
        Ok(i) => i,
        Err(d) => {
            emit(&sources, &d);
            return Err(Outcome::Usage);
        }
    };
    let values = grm_compile::param_values(&program, params).map_err(|m| {
        eprintln!("error: {m}");
        Outcome::Usage
    })?;
    Ok(Checked {
        sources,
        program,
        system: index,
        values,
    })
}

/// Print a run-time error's diagnostic to stderr, like `grmc check` does.
pub fn emit(sources: &SourceMap, d: &Diagnostic) {
    eprint!("{}", grm_diag::render_human(d, sources, color()));
}

/// Render a derivation error of `system` (where errors that name no place
/// point); returns the outcome to exit with.
pub fn report_derive_error(
    sources: &SourceMap,
    system: &CompiledSystem,
    e: &DeriveError,
) -> Outcome {
    emit(sources, &e.to_diagnostic(system.file, system.span));
    match e {
        DeriveError::ThreadPool(_) | DeriveError::TooManyThreads { .. } => Outcome::Usage,
        _ => Outcome::InputErrors,
    }
}

pub fn limits(max_modules: Option<u64>, max_memory_mib: Option<u64>) -> DeriveLimits {
    let d = DeriveLimits::default();
    DeriveLimits {
        max_modules: max_modules.unwrap_or(d.max_modules),
        max_bytes: max_memory_mib.map_or(d.max_bytes, |m| m.saturating_mul(1 << 20)),
    }
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

pub fn run(args: DeriveArgs) -> Outcome {
    let mut checked = match load_checked(&args.file, args.system.as_deref(), &args.params) {
        Ok(c) => c,
        Err(o) => return o,
    };
    if checked.system().mode == grm_sema::Mode::Shape {
        return crate::shape::run(&args, checked);
    }
    // The persistent edits (docs/edits.md), read before compiling: a sample
    // system is refused below whatever its edits.
    let edits = if checked.system().mode == grm_sema::Mode::Derive {
        match crate::shape::edits_of(&args.edits, &mut checked) {
            Ok(e) => e,
            Err(o) => return o,
        }
    } else {
        None
    };
    let loaded = match checked.compile() {
        Ok(l) => l,
        Err(o) => return o,
    };
    if loaded.system().mode == grm_sema::Mode::Sample {
        // Rewriting a sample system in parallel grows nothing useful (its
        // skeleton symbols are meant to be searched for); the preview
        // refuses it too. R0210, the twin of `grmc sample`'s R0301.
        let e = grm_derive::DeriveError::SampleSystem {
            system: loaded.system().name.clone(),
        };
        return report_derive_error(&loaded.sources, &loaded.compiled, &e);
    }
    if let Some(o) = check_output_format(&loaded, args.output.as_deref(), &args.image) {
        return o;
    }
    if let Some(o) = args
        .tree
        .as_deref()
        .and_then(|p| crate::tree::check_path(&loaded, p))
    {
        return o;
    }
    let iterations = args
        .iterations
        .unwrap_or(loaded.compiled.settings.iterations);
    if args.frames && u64::from(iterations) + 1 > MAX_FRAMES {
        eprintln!(
            "error: --frames writes a file per iteration, 0 to {iterations}: at most {MAX_FRAMES} \
             files (derive fewer iterations with -n)"
        );
        return Outcome::Usage;
    }
    let c = &loaded.compiled;
    let opts = DeriveOptions {
        iterations: args.iterations.unwrap_or(c.settings.iterations),
        seed: args.seed.unwrap_or(c.settings.seed),
        limits: limits(args.max_modules, args.max_memory),
    };
    // A glb names its parts by their identity keys (`_PART`): the strings
    // carry keys then, on either engine, whether the system draws or not.
    let glb = args
        .output
        .as_deref()
        .and_then(grm_geom::ExportFormat::from_path)
        == Some(grm_geom::ExportFormat::Glb);
    let record = grm_grow::Record {
        tree: args.tree.is_some(),
        keys: glb,
        ..grm_grow::Record::default()
    };
    let backend = if args.gpu {
        grm_grow::Backend::Gpu(grm_grow::gpu::GpuChoice {
            cpu_prefix: args.cpu_prefix,
            fallback: args.cpu_fallback,
            interpret: true,
            read_string: args.print || args.output.is_some(),
            sync_iterations: args.stats,
        })
    } else {
        grm_grow::Backend::Cpu
    };
    let grower =
        match grm_grow::Grower::with_backend(c, loaded.system(), args.threads, record, backend) {
            Ok(g) => g,
            Err(e) => return report_grow_error(&loaded.sources, c, &e),
        };
    let mine: Vec<&grm_edits::Edit> = edits
        .as_ref()
        .map(|(f, _)| f.of_system(&c.name).collect())
        .unwrap_or_default();
    let plan = grm_grow::edits::edit_plan(loaded.system(), mine.iter().copied());
    let grower = match grower.with_edits(plan) {
        Ok(g) => g,
        Err(e) => return report_derive_error(&loaded.sources, c, &e),
    };
    if grower.on_cpu_for_edits() {
        eprintln!(
            "note: {}: persistent edits are replayed by the CPU engine: deriving on the CPU, not the GPU (--no-edits to derive on the GPU)",
            crate::count(mine.len() as u64, "edit")
        );
    }
    let mut bar: Option<indicatif::ProgressBar> = None;
    let mut start = Instant::now();
    // Which engine makes the strings (the table's columns differ).
    let mut on_gpu = false;
    let mut progress = |e: grm_grow::Event<'_>| match e {
        grm_grow::Event::Cpu => {
            on_gpu = false;
            bar = (!args.stats && std::io::stderr().is_terminal() && opts.iterations > 0).then(
                || {
                    let b = indicatif::ProgressBar::new(u64::from(opts.iterations));
                    b.set_style(
                        indicatif::ProgressStyle::with_template(
                            "{spinner} iteration {pos}/{len} [{bar:30}] {msg}",
                        )
                        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
                    );
                    b
                },
            );
            if args.stats {
                outln!(
                    "{:>9} {:>14} {:>16} {:>12} {:>10}",
                    "iteration",
                    "modules",
                    "cumulative",
                    "params",
                    "ms"
                );
            }
            start = Instant::now();
        }
        grm_grow::Event::Gpu(gpu) => {
            on_gpu = true;
            if args.stats {
                crate::gpu::header(gpu);
            }
            start = Instant::now();
        }
        grm_grow::Event::FellBack(e) => {
            eprintln!("note: GPU: {e}; deriving on the CPU (--cpu-fallback)");
        }
        grm_grow::Event::Step {
            stats: s,
            on_gpu: g,
        } => {
            if on_gpu {
                if args.stats {
                    crate::gpu::row(s, g);
                }
                return;
            }
            if args.stats {
                outln!(
                    "{:>9} {:>14} {:>16} {:>12} {:>10.3}",
                    s.iteration,
                    s.modules,
                    s.cumulative_modules,
                    s.param_words,
                    ms(s.elapsed)
                );
            }
            if let Some(b) = &bar {
                b.set_position(u64::from(s.iteration));
                b.set_message(format!("{} modules", s.modules));
            }
        }
    };
    let result = grower.derive(&opts, &mut progress);
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    let mut d = match result {
        Ok(d) => d,
        Err(e) => return report_grow_error(&loaded.sources, c, &e),
    };
    let total = start.elapsed();
    // What became of the edits (docs/edits.md, "Classes").
    let edit_problems = edits.as_ref().is_some_and(|(_, problems)| *problems);
    if edits.is_some() {
        let none = grm_derive::EditOutcome::default();
        let outcome = d.edits.as_ref().unwrap_or(&none);
        let reports = grm_grow::edits::classify(loaded.system(), c, outcome, mine.iter().copied());
        crate::edits::print_replayed(&c.name, &reports);
    }
    let done = |o: Outcome| crate::edits::after_edit_problems(o, edit_problems);
    if let Some(r) = d.gpu.take() {
        // The GPU's report: its engines, path and timings.
        crate::gpu::summary(c, &opts, &r, total, args.stats);
        if !args.print && args.output.is_none() {
            return done(Outcome::Ok);
        }
    } else if let Some(s) = d.stats.last().copied() {
        let rate = if total.as_secs_f64() > 0.0 {
            format!(
                ", {} modules/us",
                crate::rate(s.cumulative_modules as f64 / (total.as_secs_f64() * 1e6))
            )
        } else {
            String::new()
        };
        eprintln!(
            "{}: {}: {} ({} produced in all) in {:.3} ms{rate}",
            c.name,
            crate::count(s.iteration, "iteration"),
            crate::count(s.modules, "module"),
            s.cumulative_modules,
            ms(total)
        );
    }
    if args.print {
        outln!(
            "{}",
            grm_compile::text::string_text(&loaded.program, loaded.system(), d.string.iter())
        );
    }
    if let (Some(path), Some(tree)) = (&args.tree, &d.tree) {
        let interp = match grm_geom::grm_turtle::interpret(loaded.system(), &c.settings, &d.string)
        {
            Ok(i) => Some(i),
            Err(e) => {
                eprintln!("warning: the tree's bones are left out: {e}");
                None
            }
        };
        let o = crate::tree::write(&loaded, tree, interp.as_ref(), path);
        if o != Outcome::Ok {
            return o;
        }
    }
    if let Some(path) = &args.output {
        if args.frames
            && let Some(engine) = grower.engine()
        {
            return done(export_frames(
                &loaded,
                engine,
                &opts,
                &d.string,
                path,
                &args.image,
                args.max_memory,
            ));
        }
        // Only the final string is needed now: the engine's spare strings
        // and the derivation tree go before the model is built.
        let string = d.string;
        drop(d.tree);
        drop(grower);
        return done(export_string(
            &loaded,
            &string,
            path,
            &args.image,
            args.max_memory,
        ));
    }
    done(Outcome::Ok)
}

/// Render a growth's error (where errors that name no place point: the
/// system); returns the outcome to exit with: the CPU engine's as
/// [`report_derive_error`], the GPU's as [`crate::gpu::error_outcome`].
pub fn report_grow_error(
    sources: &SourceMap,
    system: &CompiledSystem,
    e: &grm_grow::GrowError,
) -> Outcome {
    match e {
        grm_grow::GrowError::Derive(e) => report_derive_error(sources, system, e),
        grm_grow::GrowError::Gpu(g) => {
            emit(sources, &e.to_diagnostic(system.file, system.span));
            crate::gpu::error_outcome(g)
        }
        grm_grow::GrowError::Unsupported(_) => {
            emit(sources, &e.to_diagnostic(system.file, system.span));
            Outcome::Usage
        }
    }
}

/// The model's limit: `--max-memory` MiB (default 2048, as a
/// derivation's), counting what writing to `path` needs (a picture's
/// size from `image`).
pub fn model_options(
    max_memory_mib: Option<u64>,
    path: &Path,
    image: &ImageArgs,
) -> grm_geom::BuildOptions {
    let max_bytes = limits(None, max_memory_mib).max_bytes;
    let mut picture = grm_geom::render::RenderOptions::default();
    if let Some(size) = image.image_size {
        picture.width = size.width;
        picture.height = size.height;
    }
    let format = grm_geom::ExportFormat::from_path(path);
    grm_geom::BuildOptions::limited(max_bytes, grm_geom::Output::of(format, &picture))
}

/// The most files `--frames` writes (iterations 0 to 999).
pub const MAX_FRAMES: u64 = 1000;

/// `NAME-K.EXT` for frame `k` of `0..=last`, K zero-padded to the width of
/// `last`.
pub fn frame_path(path: &Path, k: u32, last: u32) -> PathBuf {
    let width = last.to_string().len();
    let stem = path
        .file_stem()
        .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
    let name = match path.extension() {
        Some(ext) => format!("{stem}-{k:0width$}.{}", ext.to_string_lossy()),
        None => format!("{stem}-{k:0width$}"),
    };
    path.with_file_name(name)
}

/// `--frames`: the model of every iteration `0..=opts.iterations`, each
/// written to [`frame_path`]. The strings are derived again, one at a
/// time (the same seed gives the same strings; only one is held). A
/// picture's view is the final model's (`--view`, or the automatic view
/// of the final model) and its framing holds every frame, so the frames
/// line up; that takes one more pass, which builds each model without
/// drawing it.
fn export_frames(
    loaded: &Loaded,
    engine: &Engine<'_>,
    opts: &DeriveOptions,
    last: &grm_derive::ModuleString,
    path: &Path,
    image: &ImageArgs,
    max_memory: Option<u64>,
) -> Outcome {
    let c = &loaded.compiled;
    let options = model_options(max_memory, path, image);
    // Each frame's model is built while the final string, the frame's and
    // the engine's spare strings (at most three, none larger than the
    // frame's) are held.
    let build = |string: &grm_derive::ModuleString| {
        let held = (last.heap_bytes() + 3 * string.heap_bytes()) as u64;
        grm_geom::build_model_with(
            &loaded.program,
            loaded.system(),
            string,
            &c.settings,
            &c.param_values,
            &grm_geom::BuildOptions { held, ..options },
        )
        .map_err(|e| {
            emit(
                &loaded.sources,
                &e.to_diagnostic(&loaded.program, c.file, c.span),
            );
            Outcome::InputErrors
        })
    };
    // Every iteration's string in turn, handed to `f` (with the engine's
    // persistent edits replayed, when it has some: the plain steps else).
    let each = |f: &mut dyn FnMut(u32, &grm_derive::ModuleString) -> Result<(), Outcome>| {
        let fail = |e: DeriveError| report_derive_error(&loaded.sources, c, &e);
        let (mut s, mut state) = engine.edited_axiom(opts.seed).map_err(fail)?;
        f(0, &s)?;
        for it in 1..=opts.iterations {
            let next = engine
                .edited_step(&mut state, &s, it, opts.seed, &opts.limits, None)
                .map_err(fail)?;
            engine.recycle(std::mem::replace(&mut s, next));
            f(it, &s)?;
        }
        Ok(())
    };
    let picture = grm_geom::ExportFormat::from_path(path) == Some(grm_geom::ExportFormat::Png);
    let framing = if picture {
        let view = match build(last) {
            Ok(m) => match image.options(&m).view {
                grm_geom::render::View::Auto => {
                    let (azimuth, elevation) = grm_geom::render::auto_angles(&m);
                    grm_geom::render::View::Angles { azimuth, elevation }
                }
                v => v,
            },
            Err(o) => return o,
        };
        let mut all: Option<grm_geom::render::Framing> = None;
        let framed = each(&mut |_, s| {
            let f = grm_geom::render::framing(&build(s)?, view);
            all = Some(all.map_or(f, |a| a.union(&f)));
            Ok(())
        });
        if let Err(o) = framed {
            return o;
        }
        all
    } else {
        None
    };
    let written = each(&mut |k, s| {
        let model = build(s)?;
        match export_model_framed(
            loaded,
            &model,
            &frame_path(path, k, opts.iterations),
            image,
            framing.as_ref(),
        ) {
            Outcome::Ok => Ok(()),
            o => Err(o),
        }
    });
    match written {
        Ok(()) => Outcome::Ok,
        Err(o) => o,
    }
}

/// Write `models` (the frames of a run, in order) to [`frame_path`]s;
/// pictures share the last model's view (`--view`, `--camera`, or its
/// automatic view) and a framing that holds every frame, as
/// [`export_frames`] draws a derivation's.
pub fn export_frame_models(
    loaded: &Loaded,
    models: &[grm_geom::Model],
    path: &Path,
    image: &ImageArgs,
) -> Outcome {
    let Some(last) = models.last() else {
        return Outcome::Ok;
    };
    let picture = grm_geom::ExportFormat::from_path(path) == Some(grm_geom::ExportFormat::Png);
    let framing = picture.then(|| {
        let view = match image.options(last).view {
            grm_geom::render::View::Auto => {
                let (azimuth, elevation) = grm_geom::render::auto_angles(last);
                grm_geom::render::View::Angles { azimuth, elevation }
            }
            v => v,
        };
        let mut all = grm_geom::render::framing(last, view);
        for m in models {
            all = all.union(&grm_geom::render::framing(m, view));
        }
        all
    });
    let n = models.len() as u32 - 1;
    for (k, m) in models.iter().enumerate() {
        let o = export_model_framed(
            loaded,
            m,
            &frame_path(path, k as u32, n),
            image,
            framing.as_ref(),
        );
        if o != Outcome::Ok {
            return o;
        }
    }
    Outcome::Ok
}

/// `-o PATH` must name a format grm writes (R0406) in a directory that
/// exists and not be a directory itself (R0407), and the picture flags
/// need a `.png` output; checked before the work that the export would
/// waste. `Some` is the outcome to exit with (the problem was printed).
pub fn check_output_format(
    loaded: &Loaded,
    output: Option<&Path>,
    image: &ImageArgs,
) -> Option<Outcome> {
    let c = &loaded.compiled;
    check_output_at(&loaded.sources, c.file, c.span, output, image)
}

/// [`check_output_format`], its errors pointing at `span` of `file`.
pub fn check_output_at(
    sources: &SourceMap,
    file: grm_diag::FileId,
    span: grm_diag::Span,
    output: Option<&Path>,
    image: &ImageArgs,
) -> Option<Outcome> {
    if let (Some(eye), Some(target)) = (image.camera, image.look_at)
        && eye == target
    {
        eprintln!("error: --camera and --look-at name the same point: the camera has no direction");
        return Some(Outcome::Usage);
    }
    if let Some(flag) = image.given() {
        let png =
            output.and_then(grm_geom::ExportFormat::from_path) == Some(grm_geom::ExportFormat::Png);
        if !png {
            eprintln!(
                "error: {flag} draws a picture: it needs an output named -o FILE.png{}",
                output.map_or(String::new(), |p| format!(" (not {})", p.display()))
            );
            return Some(Outcome::Usage);
        }
    }
    let path = output?;
    let e = if grm_geom::ExportFormat::from_path(path).is_none() {
        grm_geom::ExportError::UnknownFormat {
            path: path.to_path_buf(),
        }
    } else if path.is_dir() {
        // A directory named like a file (`-o out.png` where out.png is a
        // folder): the export could only fail, after all the work.
        grm_geom::ExportError::Io {
            path: path.to_path_buf(),
            source: std::io::ErrorKind::IsADirectory.into(),
        }
    } else {
        let dir = path
            .parent()
            .filter(|d| !d.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        let source = match std::fs::metadata(dir) {
            Ok(m) if m.is_dir() => return None,
            Ok(_) => std::io::Error::other(format!("{} is not a directory", dir.display())),
            Err(e) => e,
        };
        grm_geom::ExportError::Io {
            path: path.to_path_buf(),
            source,
        }
    };
    emit(sources, &e.to_diagnostic(file, span));
    Some(Outcome::Usage)
}

/// Build the model of a derived string and write it to `path`; the
/// outcome to exit with (errors were printed).
pub fn export_string(
    loaded: &Loaded,
    string: &grm_derive::ModuleString,
    path: &Path,
    image: &ImageArgs,
    max_memory: Option<u64>,
) -> Outcome {
    let c = &loaded.compiled;
    let model = match grm_geom::build_model_with(
        &loaded.program,
        loaded.system(),
        string,
        &c.settings,
        &c.param_values,
        &model_options(max_memory, path, image),
    ) {
        Ok(m) => m,
        Err(e) => {
            emit(
                &loaded.sources,
                &e.to_diagnostic(&loaded.program, c.file, c.span),
            );
            return Outcome::InputErrors;
        }
    };
    export_model(loaded, &model, path, image)
}

/// Write a built model to `path` (a `.png` drawn as `image` says); the
/// outcome to exit with.
pub fn export_model(
    loaded: &Loaded,
    model: &grm_geom::Model,
    path: &Path,
    image: &ImageArgs,
) -> Outcome {
    export_model_framed(loaded, model, path, image, None)
}

/// [`export_model`], a picture drawn with `framing` when one is given
/// (`--frames`), else fitted to the model.
fn export_model_framed(
    loaded: &Loaded,
    model: &grm_geom::Model,
    path: &Path,
    image: &ImageArgs,
    framing: Option<&grm_geom::render::Framing>,
) -> Outcome {
    let c = &loaded.compiled;
    export_model_at(&loaded.sources, c.file, c.span, model, path, image, framing)
}

/// [`export_model_framed`], its errors and warnings pointing at `span`
/// of `file`.
pub fn export_model_at(
    sources: &SourceMap,
    file: grm_diag::FileId,
    span: grm_diag::Span,
    model: &grm_geom::Model,
    path: &Path,
    image: &ImageArgs,
    framing: Option<&grm_geom::render::Framing>,
) -> Outcome {
    let format = grm_geom::ExportFormat::from_path(path);
    let picture = format == Some(grm_geom::ExportFormat::Png);
    // SVG and PNG draw bones without width as lines.
    let lines = picture || format == Some(grm_geom::ExportFormat::Svg);
    for w in model.warnings(file, span, lines) {
        emit(sources, &w);
    }
    let options = image.options(model);
    if picture
        && let Some(w) =
            grm_geom::render::camera_warning(model, &options.view, options.width, options.height)
    {
        eprintln!("warning: {w}");
    }
    let written = match (picture, framing) {
        (true, Some(f)) => match grm_geom::render::render_framed(model, &options, f) {
            Ok(img) => grm_geom::write_image(&img, path),
            Err(e) => Err(grm_geom::ExportError::Io {
                path: path.to_path_buf(),
                source: std::io::Error::new(std::io::ErrorKind::InvalidInput, e.to_string()),
            }),
        },
        (true, None) => grm_geom::export_image(model, path, &options),
        (false, _) => grm_geom::export(model, path),
    };
    if let Err(e) = written {
        emit(sources, &e.to_diagnostic(file, span));
        return Outcome::Usage;
    }
    let s = &model.stats;
    if picture {
        eprintln!(
            "wrote {} ({}x{} picture of {}, {})",
            path.display(),
            options.width,
            options.height,
            crate::count(s.triangles as u64, "triangle"),
            crate::count(s.bones as u64, "bone"),
        );
    } else if lines {
        // An SVG draws the bones as lines and the polygons as paths; the
        // meshes are not in it.
        eprintln!(
            "wrote {} ({}, {})",
            path.display(),
            crate::count(s.bones as u64, "line"),
            crate::count(model.skeleton.polygons.len() as u64, "polygon"),
        );
    } else {
        eprintln!(
            "wrote {} ({}, {})",
            path.display(),
            crate::count(s.triangles as u64, "triangle"),
            crate::count(s.bones as u64, "bone"),
        );
    }
    Outcome::Ok
}

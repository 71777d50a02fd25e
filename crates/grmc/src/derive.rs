//! `grmc derive FILE`: check, compile and derive one system; print
//! statistics or the string, or build and export the model.
//!
//! Also the helpers `grmc disasm` and `grmc bench` share: loading and
//! compiling a system with `--param` overrides, and rendering run-time
//! errors (codes `R01xx` from the compiler, `R02xx` from the engine) with
//! the source span they name.

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use grm_compile::CompiledSystem;
use grm_derive::{DeriveError, DeriveLimits, DeriveOptions, Engine, IterationStats};
use grm_diag::{FileId, Severity, SourceMap, Span};
use grm_sema::{Program, Ty, Value};

use crate::Outcome;

#[derive(clap::Args, Debug)]
pub struct DeriveArgs {
    /// The .grm file.
    pub file: PathBuf,
    /// The system to derive (default: the file's first system).
    #[arg(long)]
    pub system: Option<String>,
    /// Iterations (default: the system's `iterations` setting).
    #[arg(short = 'n', long = "iterations")]
    pub iterations: Option<u32>,
    /// Random seed (default: the system's `seed` setting).
    #[arg(long)]
    pub seed: Option<u32>,
    /// Worker threads: 1 runs on the main thread, 0 uses all cores.
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Override a meta-parameter: `NAME=VALUE` (a number, `true`/`false`,
    /// or `x,y,z` for a vec3). Repeatable.
    #[arg(long = "param", value_name = "NAME=VALUE")]
    pub params: Vec<String>,
    /// Build the model and write it (format by extension: .glb .obj .ply .svg).
    #[arg(short = 'o', long = "output")]
    pub output: Option<PathBuf>,
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
    #[arg(long, value_name = "MIB")]
    pub max_memory: Option<u64>,
    /// Derive (and interpret) on the GPU (grm-gpu; docs/gpu.md).
    #[arg(long)]
    pub gpu: bool,
    /// With `--gpu`: derive on the CPU when no GPU can be used or the
    /// derivation outgrows the device.
    #[arg(long, requires = "gpu")]
    pub cpu_fallback: bool,
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
    let (sources, checked) = match crate::check::load_and_check(path) {
        Ok(r) => r,
        Err(msg) => {
            eprintln!("error: {msg}");
            return Err(Outcome::Usage);
        }
    };
    let color = color();
    for d in &checked.diagnostics {
        eprint!("{}", grm_diag::render_human(d, &sources, color));
    }
    if checked
        .diagnostics
        .iter()
        .any(|d| d.severity == Severity::Error)
    {
        return Err(Outcome::InputErrors);
    }
    let program = checked.program;
    let index = match system {
        Some(name) => program.systems.iter().position(|s| s.name == name),
        None => program
            .default_system()
            .and_then(|d| program.systems.iter().position(|s| s.name == d.name)),
    };
    let Some(index) = index else {
        let names: Vec<&str> = program.systems.iter().map(|s| s.name.as_str()).collect();
        match system {
            Some(name) => eprintln!(
                "error: {} has no system `{name}`; it has: {}",
                path.display(),
                names.join(", ")
            ),
            None => eprintln!("error: {} defines no system", path.display()),
        }
        return Err(Outcome::Usage);
    };
    let values = param_values(&program, params).map_err(|m| {
        eprintln!("error: {m}");
        Outcome::Usage
    })?;
    let compiled = match grm_compile::compile(&program, &program.systems[index], &values) {
        Ok(c) => c,
        Err(e) => {
            let span = e.span;
            let file = e.file;
            eprint!(
                "{}",
                render(
                    &sources,
                    &Report {
                        code: e.code(),
                        message: e.to_string(),
                        file: Some((file, span)),
                        label: "here".into(),
                        help: None,
                    }
                )
            );
            return Err(Outcome::InputErrors);
        }
    };
    Ok(Loaded {
        sources,
        program,
        system: index,
        compiled,
    })
}

/// The meta-parameter values: the defaults, with `NAME=VALUE` overrides.
pub fn param_values(program: &Program, overrides: &[String]) -> Result<Vec<Value>, String> {
    let mut values = program.default_params();
    for o in overrides {
        let Some((name, text)) = o.split_once('=') else {
            return Err(format!("`--param {o}`: write it as NAME=VALUE"));
        };
        let (name, text) = (name.trim(), text.trim());
        let Some(id) = program.param_by_name(name) else {
            let known: Vec<&str> = program.params.iter().map(|p| p.name.as_str()).collect();
            return Err(if known.is_empty() {
                format!("unknown meta-parameter `{name}`: the file declares none")
            } else {
                format!(
                    "unknown meta-parameter `{name}`; the file declares: {}",
                    known.join(", ")
                )
            });
        };
        let p = &program.params[id.index()];
        let number = |s: &str| -> Result<f64, String> {
            s.trim()
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| format!("`--param {name}={text}`: `{s}` is not a finite number"))
        };
        let v = match p.ty {
            Ty::Float => {
                let x = number(text)?;
                if let Some((lo, hi)) = p.range
                    && !(lo..=hi).contains(&x)
                {
                    return Err(format!(
                        "`--param {name}={text}`: outside its range {lo} .. {hi}"
                    ));
                }
                Value::Float(x)
            }
            Ty::Bool => match text {
                "true" => Value::Bool(true),
                "false" => Value::Bool(false),
                _ => return Err(format!("`--param {name}={text}`: expected true or false")),
            },
            Ty::Vec3 => {
                let parts: Vec<&str> = text.split(',').collect();
                if parts.len() != 3 {
                    return Err(format!("`--param {name}={text}`: expected x,y,z"));
                }
                Value::Vec3([number(parts[0])?, number(parts[1])?, number(parts[2])?])
            }
            other => return Err(format!("`{name}` is a `{other}`; it cannot be overridden")),
        };
        values[id.index()] = v;
    }
    Ok(values)
}

/// An error to render: a code, a message, and maybe a labelled span.
pub struct Report {
    pub code: &'static str,
    pub message: String,
    pub file: Option<(FileId, Span)>,
    pub label: String,
    pub help: Option<String>,
}

/// Render a run-time error like a diagnostic: code, message, the source
/// span with its label, help.
pub fn render(sources: &SourceMap, r: &Report) -> String {
    use ariadne::{Config, IndexType, Label, ReportKind, Source};
    let Some((file, span)) = r.file else {
        let mut s = format!("error[{}]: {}\n", r.code, r.message);
        if let Some(h) = &r.help {
            s.push_str(&format!("  help: {h}\n"));
        }
        return s;
    };
    let f = sources.get(file);
    let len = f.text.len();
    let start = (span.start as usize).min(len);
    let end = (span.end as usize).clamp(start, len);
    let mut report = ariadne::Report::build(ReportKind::Error, (f.path.clone(), start..end))
        .with_config(
            Config::default()
                .with_index_type(IndexType::Byte)
                .with_color(color()),
        )
        .with_code(r.code)
        .with_message(&r.message)
        .with_label(Label::new((f.path.clone(), start..end)).with_message(&r.label));
    if let Some(h) = &r.help {
        report = report.with_help(h);
    }
    let mut out = Vec::new();
    let cache = (f.path.clone(), Source::from(f.text.clone()));
    if report.finish().write(cache, &mut out).is_err() {
        let (line, col) = f.line_col(span.start);
        return format!(
            "{}:{}:{}: error[{}]: {}\n",
            f.path,
            line + 1,
            col + 1,
            r.code,
            r.message
        );
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Render a derivation error; returns the outcome to exit with.
pub fn report_derive_error(sources: &SourceMap, e: &DeriveError) -> Outcome {
    eprint!(
        "{}",
        render(
            sources,
            &Report {
                code: e.code(),
                message: e.to_string(),
                file: e.location(),
                label: e.label(),
                help: e.help(),
            }
        )
    );
    match e {
        DeriveError::ThreadPool(_) => Outcome::Usage,
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
    if let Some(out) = &args.output
        && grm_geom::ExportFormat::from_path(out).is_none()
    {
        eprintln!(
            "error: cannot tell the format of {}: use .glb, .obj, .ply or .svg",
            out.display()
        );
        return Outcome::Usage;
    }
    let loaded = match load(&args.file, args.system.as_deref(), &args.params) {
        Ok(l) => l,
        Err(o) => return o,
    };
    if args.gpu
        && let Some(o) = crate::gpu::derive(&args, &loaded)
    {
        return o;
    }
    let c = &loaded.compiled;
    let opts = DeriveOptions {
        iterations: args.iterations.unwrap_or(c.settings.iterations),
        seed: args.seed.unwrap_or(c.settings.seed),
        limits: limits(args.max_modules, args.max_memory),
    };
    let engine = match Engine::new(c, args.threads) {
        Ok(e) => e,
        Err(e) => return report_derive_error(&loaded.sources, &e),
    };
    let bar = (!args.stats && std::io::stderr().is_terminal() && opts.iterations > 0).then(|| {
        let b = indicatif::ProgressBar::new(u64::from(opts.iterations));
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "{spinner} iteration {pos}/{len} [{bar:30}] {msg}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b
    });
    if args.stats {
        println!(
            "{:>9} {:>14} {:>16} {:>12} {:>10}",
            "iteration", "modules", "cumulative", "params", "ms"
        );
    }
    let start = Instant::now();
    let mut progress = |s: &IterationStats| {
        if args.stats {
            println!(
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
    };
    let result = engine.derive(&opts, &mut progress);
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    let d = match result {
        Ok(d) => d,
        Err(e) => return report_derive_error(&loaded.sources, &e),
    };
    let total = start.elapsed();
    let last = d.stats.last().copied();
    if let Some(s) = last {
        let rate = if total.as_secs_f64() > 0.0 {
            format!(
                ", {:.0} modules/us",
                s.cumulative_modules as f64 / (total.as_secs_f64() * 1e6)
            )
        } else {
            String::new()
        };
        eprintln!(
            "{}: {} iterations: {} modules ({} produced in all) in {:.3} ms{rate}",
            c.name,
            s.iteration,
            s.modules,
            s.cumulative_modules,
            ms(total)
        );
    }
    if args.print {
        let mut out = std::io::stdout().lock();
        let _ = writeln!(out, "{}", d.string.to_text(&c.symbol_names));
    }
    if let Some(path) = &args.output {
        let system = loaded.system();
        let model = match grm_geom::build_model(&loaded.program, system, &d.string, &c.settings) {
            Ok(m) => m,
            Err(e) => {
                eprintln!("error: cannot build the model of `{}`: {e}", c.name);
                return Outcome::InputErrors;
            }
        };
        if let Err(e) = grm_geom::export(&model, path) {
            eprintln!("error: {e}");
            return Outcome::Usage;
        }
        eprintln!("wrote {}", path.display());
    }
    Outcome::Ok
}

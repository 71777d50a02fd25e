//! The run suite's driver: `tests/run/**/*.grm` are checked and then run
//! through the engines the way `grmc derive`, `grmc sample` and `grmc
//! disasm` run them, and the diagnostics are rendered as grmc renders them.
//!
//! A case declares the codes it must produce on its first line
//! (`// expect: R0201`) and the command on its second, without `grmc` and
//! the file: `// run: derive -n 30 --max-modules 1000`. Paths in the
//! command are relative to this crate's directory (the working directory
//! of cargo tests), as if `grmc` ran there: `--curves
//! ../examples/calder_tree.curves.json`. `// run: edits [--edits PATH]`
//! reads the grammar's edits file (NAME.edits.json beside it) as the
//! commands that grow a model read it, and reports its problems; `// run:
//! layout [--no-buildings]` merges the layout file beside it
//! (NAME.layout.json) and grows the case's shape system on its parcels,
//! with the building edits of NAME.edits.json beside it replayed.
//!
//! Invariants: the driver makes the same library calls as grmc in the same
//! order and stops at the first error, as grmc does; it never writes into
//! the source tree (an export to a relative path is refused: cases export
//! to paths that cannot be written, or to `$TMP/NAME`, which lands in a
//! fresh temporary directory removed after the export).

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use grm_compile::CompiledSystem;
use grm_diag::{Code, Diagnostic};
use grm_sema::Program;

/// Codes the run suite does not cover, with the reason. Every other code
/// has a case under `tests/ui/` or `tests/run/`; each of these is
/// documented as such in docs/diagnostics.md and, where feasible, has a
/// test in the crate that reports it (named in the reason).
pub const EXEMPT: &[(Code, &str)] = &[
    // Internal: only a bug in grm produces them.
    (
        Code::CompiledWithErrors,
        "internal: grmc never compiles a program with errors (grm-compile tests/errors.rs)",
    ),
    (
        Code::ParamValues,
        "internal: grmc and the preview validate --param values first (grm-compile tests/errors.rs)",
    ),
    (
        Code::LeftContextBracket,
        "internal: the parser allows no bracket in a left context (grm-compile tests/errors.rs)",
    ),
    (
        Code::AxiomBinding,
        "internal: the checker resolves no module parameter in an axiom (grm-compile tests/errors.rs)",
    ),
    (
        Code::BytecodeFault,
        "internal: verified bytecode cannot fault (grm-derive tests/limits.rs renders one)",
    ),
    (
        Code::InvalidTables,
        "internal: compiled tables are valid (grm-derive tests/limits.rs)",
    ),
    (
        Code::InvalidModuleString,
        "internal: only a library caller passes a foreign string (grm-derive tests/limits.rs)",
    ),
    (
        Code::SampleBytecodeFault,
        "internal: verified bytecode cannot fault (grm-sample tests/sampler.rs renders one)",
    ),
    (
        Code::SampleInterpret,
        "internal: the sampler's expansions are well formed (grm-sample tests/sampler.rs renders one)",
    ),
    (
        Code::InterpretString,
        "internal: derived strings are well formed (grm-geom tests/export.rs)",
    ),
    (
        Code::UnknownMeshId,
        "internal: mesh ids come from checked names (grm-geom tests/export.rs)",
    ),
    (
        Code::UnknownMaterialId,
        "internal: material ids come from checked names (grm-geom tests/export.rs)",
    ),
    (
        Code::GpuUnbalancedBrackets,
        "internal: checked systems balance their brackets (GPU only)",
    ),
    (
        Code::GpuInvalidInput,
        "internal: only a library caller passes malformed input (GPU only)",
    ),
    // Internal (environment): the machine, not the input, decides.
    (
        Code::ThreadPool,
        "internal (environment): the OS refuses threads (grm-derive tests/limits.rs renders one)",
    ),
    (
        Code::SampleThreadPool,
        "internal (environment): the OS refuses threads",
    ),
    (
        Code::GpuNoAdapter,
        "internal (environment): depends on the machine's GPU",
    ),
    (
        Code::GpuRequestDevice,
        "internal (environment): depends on the machine's GPU",
    ),
    (
        Code::GpuDevice,
        "internal (environment): a wgpu or driver error",
    ),
    (
        Code::GpuDeviceLost,
        "internal (environment): a wgpu or driver error",
    ),
    (
        Code::GpuReadback,
        "internal (environment): a wgpu or driver error",
    ),
    (
        Code::ShapeInternal,
        "internal: the lowering makes only programs the shape engine accepts, and the attribute \
         table's limit needs 65,536 distinct colours (grm-grow tests/shape.rs)",
    ),
    // Not internal, but not coverable by this CPU-only, file-based suite.
    (
        Code::FileUnreadable,
        "a case is a file that was read; grmc reports a file it cannot read \
         (grmc tests/cli_check.rs: missing, a directory, a device, a named pipe)",
    ),
    (
        Code::SampleOptions,
        "grmc refuses a bad --volume-weight as a usage error, as it does every sampling \
         option; library callers get it (grm-sample tests/sampler.rs)",
    ),
    (
        Code::SampleCancelled,
        "only a library caller cancels a run (the language server, for a superseded preview): \
         grm-sample tests/cancel.rs",
    ),
    (
        Code::GpuBufferTooLarge,
        "needs a GPU adapter, which this suite does not assume (grm-gpu tests/limits.rs)",
    ),
    (
        Code::GpuCountOverflow,
        "needs a GPU adapter, which this suite does not assume (grm-gpu tests/limits.rs)",
    ),
    (
        Code::GpuTooManyWorkgroups,
        "needs a GPU adapter and a dispatch of over 65535^2 workgroups, beyond any buffer limit",
    ),
    (
        Code::GpuUnsupported,
        "needs a GPU adapter, which this suite does not assume (grm-gpu tests/limits.rs)",
    ),
    (
        Code::MeshUnreadable,
        "needs a mesh file that is readable when checked and not when built (a race, or \
         permissions, which do not apply to root): grm-geom tests/export.rs removes one",
    ),
    (
        Code::TablesTooLarge,
        "needs a 65,536-control spline: too large for a snapshot (grm-compile tests/errors.rs)",
    ),
    (
        Code::LayoutMergeFailed,
        "internal: a merge leaves a valid layout or the layer's own error (grm-layout tests/properties.rs: 10,000 operations)",
    ),
    (
        Code::ModelTooLarge,
        "needs a model of over 4 GiB in memory: not tested",
    ),
];

/// The command a run case declares on its second line: `// run: ARGS`.
pub fn declared_command(text: &str) -> Option<Vec<String>> {
    let second = text.lines().nth(1)?;
    let rest = second.trim().strip_prefix("// run:")?;
    Some(rest.split_whitespace().map(str::to_string).collect())
}

/// Check and run a case (a path relative to this crate); the source with
/// the rendered diagnostics as one snapshot body, and the codes produced.
pub fn run_case(rel: &Path) -> (String, BTreeSet<String>) {
    let (mut sources, checked) = crate::check_file(rel);
    let text = sources.get(grm_diag::FileId(0)).text.clone();
    let mut out = String::new();
    for (i, line) in text.lines().enumerate() {
        out.push_str(&format!("{:>3} | {line}\n", i + 1));
    }
    out.push_str("\n----- diagnostics -----\n");
    let mut diags = checked.diagnostics.clone();
    let mut usage = None;
    if !checked.has_errors() {
        let args = declared_command(&text).unwrap_or_default();
        let mut warnings = Vec::new();
        let stop = run(rel, &mut sources, &checked.program, &args, &mut warnings);
        // The model's warnings come first, as grmc prints them before it
        // writes the file.
        diags.extend(warnings);
        match stop {
            Ok(()) => {}
            Err(Stop::Diagnostic(d)) => diags.push(*d),
            Err(Stop::Usage(m)) => usage = Some(m),
        }
    }
    if diags.is_empty() && usage.is_none() {
        out.push_str("(none)\n");
    }
    for d in &diags {
        out.push_str(&grm_diag::render_human(d, &sources, false));
    }
    if let Some(m) = usage {
        out.push_str(&format!("error: {m}\n"));
    }
    let codes = diags.iter().map(|d| d.code.as_str().to_string()).collect();
    (out, codes)
}

/// Why a run stopped: a coded diagnostic, or a usage problem grmc prints
/// as a plain `error:` line.
enum Stop {
    Diagnostic(Box<Diagnostic>),
    Usage(String),
}

impl From<Diagnostic> for Stop {
    fn from(d: Diagnostic) -> Stop {
        Stop::Diagnostic(Box::new(d))
    }
}

/// The options of a command line, by name; `-n` and `-o` are the short
/// forms grmc accepts.
#[derive(Default)]
struct Opts {
    values: Vec<(String, String)>,
}

impl Opts {
    fn parse(args: &[String], flags: &[&str], valued: &[&str]) -> Result<Opts, String> {
        let mut o = Opts::default();
        let mut it = args.iter();
        while let Some(a) = it.next() {
            let name = match a.as_str() {
                "-n" => "--iterations",
                "-o" => "--output",
                other => other,
            };
            if flags.contains(&name) {
                o.values.push((name.to_string(), String::new()));
            } else if valued.contains(&name) {
                let v = it.next().ok_or_else(|| format!("`{name}` needs a value"))?;
                o.values.push((name.to_string(), v.clone()));
            } else {
                return Err(format!("the run suite does not support `{a}`"));
            }
        }
        Ok(o)
    }

    fn get(&self, name: &str) -> Option<&str> {
        self.values
            .iter()
            .rev()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_str())
    }

    fn all(&self, name: &str) -> Vec<String> {
        self.values
            .iter()
            .filter(|(n, _)| n == name)
            .map(|(_, v)| v.clone())
            .collect()
    }

    fn has(&self, name: &str) -> bool {
        self.get(name).is_some()
    }

    fn number<T: std::str::FromStr>(&self, name: &str) -> Result<Option<T>, String> {
        self.get(name)
            .map(|v| {
                v.parse()
                    .map_err(|_| format!("`{name} {v}`: not a valid number"))
            })
            .transpose()
    }
}

fn run(
    rel: &Path,
    sources: &mut grm_diag::SourceMap,
    program: &Program,
    args: &[String],
    warnings: &mut Vec<Diagnostic>,
) -> Result<(), Stop> {
    let Some((command, rest)) = args.split_first() else {
        return Err(Stop::Usage(
            "second line must be `// run: derive|sample|disasm|edits|layout ARGS`".into(),
        ));
    };
    match command.as_str() {
        "edits" => edits(rel, sources, program, rest, warnings),
        "layout" => layout(rel, program, rest, warnings),
        "derive" => derive(program, rest, warnings),
        "sample" => sample(rel, program, rest, warnings),
        "disasm" => {
            let o = Opts::parse(rest, &[], &["--system", "--param"]).map_err(Stop::Usage)?;
            compile(program, &o).map(|_| ())
        }
        other => Err(Stop::Usage(format!("unknown command `{other}`"))),
    }
}

/// Reading the edits file (`grm_edits`, docs/edits.md) as every command
/// that grows a model reads it: `NAME.edits.json` beside the grammar, or
/// `--edits PATH`; a missing default file is no edits, a missing named
/// one R0901 (at the system). The file joins the source map and each of
/// its problems (R0902 to R0911) is a diagnostic in it; they are all
/// reported (the valid edits would still be replayed), so they go with
/// the warnings, before any stop.
fn edits(
    rel: &Path,
    sources: &mut grm_diag::SourceMap,
    program: &Program,
    args: &[String],
    diags: &mut Vec<Diagnostic>,
) -> Result<(), Stop> {
    let o = Opts::parse(args, &[], &["--edits", "--system"]).map_err(Stop::Usage)?;
    let index = program.pick_system(o.get("--system"))?;
    let system = &program.systems[index];
    let (path, named) = match o.get("--edits") {
        Some(p) => (PathBuf::from(p), true),
        None => (grm_edits::edits_path(rel), false),
    };
    let text = match grm_edits::read(&path) {
        Ok(text) => text,
        Err(e) if e.is_not_found() && !named => return Ok(()),
        Err(e) => return Err(e.to_diagnostic_at(system.file, system.loc.span).into()),
    };
    let shown = path.to_string_lossy().replace('\\', "/");
    let file = sources.add(shown, text.clone());
    let parsed = grm_edits::parse(&text);
    diags.extend(parsed.errors.iter().map(|e| e.to_diagnostic(file)));
    Ok(())
}

/// `grmc layout` on the case's layout file, `NAME.layout.json` beside
/// it (docs/layout.md): the sidecar's problems (R1021-R1026), each
/// layer's (R1001-R1015), and, unless `--no-buildings`, each parcel's
/// without a building (R1031, the shape engine's codes) when the sidecar
/// has a `buildings` section: its grammar is the case itself (the system
/// `--system` or the default, the case's defaults with the section's
/// `params`). All of them are reported and the rest still merges and
/// grows, so they go with the warnings; labelled at the system.
fn layout(
    rel: &Path,
    program: &Program,
    args: &[String],
    diags: &mut Vec<Diagnostic>,
) -> Result<(), Stop> {
    use grm_layout::diag::{building_diagnostic, layer_diagnostic, sidecar_diagnostic};
    let o = Opts::parse(args, &["--no-buildings"], &["--system"]).map_err(Stop::Usage)?;
    let index = program.pick_system(o.get("--system"))?;
    let system = &program.systems[index];
    let at = (system.file, system.loc.span);
    let path = rel.with_extension("layout.json");
    let shown = path.to_string_lossy().replace('\\', "/");
    let text = std::fs::read_to_string(&path)
        .map_err(|e| Stop::Usage(format!("cannot read {shown}: {e}")))?;
    let (doc, errs) = grm_layout::sidecar::read(&text);
    diags.extend(
        errs.iter()
            .map(|e| sidecar_diagnostic(e, &shown, at.0, at.1)),
    );
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let load = |p: &str| std::fs::read_to_string(dir.join(p)).map_err(|e| e.to_string());
    let ev = doc.evaluate(&load);
    diags.extend(
        ev.issues
            .iter()
            .map(|i| layer_diagnostic(i, &shown, at.0, at.1)),
    );
    let Some(spec) = doc.buildings.as_ref().filter(|_| !o.has("--no-buildings")) else {
        return Ok(());
    };
    let params: Vec<String> = spec
        .params
        .iter()
        .map(|(k, v)| match v {
            grm_layout::model::TagValue::Num(x) => format!("{k}={x}"),
            grm_layout::model::TagValue::Bool(b) => format!("{k}={b}"),
            grm_layout::model::TagValue::Text(t) => format!("{k}={t}"),
        })
        .collect();
    let values = grm_compile::param_values(program, &params).map_err(Stop::Usage)?;
    let buildings = grm_layout::city::Buildings {
        program,
        system,
        params: &values,
        dir: rel.parent(),
        seed: spec.seed,
        options: grm_grow::shape::ShapeOptions::default(),
    };
    let build = grm_geom::BuildOptions::default();
    // The building edits of NAME.edits.json beside the case, when there
    // is one (docs/layout.md, "Building edits").
    let edits_path = rel.with_extension("edits.json");
    let edits_shown = edits_path.to_string_lossy().replace('\\', "/");
    let edits = match std::fs::read_to_string(&edits_path) {
        Ok(text) => {
            let parsed = grm_edits::parse(&text);
            if !parsed.errors.is_empty() {
                return Err(Stop::Usage(format!("{edits_shown}: {:?}", parsed.errors)));
            }
            parsed.file
        }
        Err(_) => grm_edits::EditsFile::default(),
    };
    let city = grm_layout::city::city_edited(
        &ev.merged,
        Some(&buildings),
        &build,
        &edits,
        None,
        &mut |_, _| {},
    )
    .map_err(|e| Stop::Usage(e.to_string()))?;
    diags.extend(
        city.issues
            .iter()
            .map(|b| building_diagnostic(b, at.0, at.1)),
    );
    diags.extend(
        city.edit_issues
            .iter()
            .map(|e| grm_layout::diag::edit_diagnostic(e, &edits_shown, at.0, at.1)),
    );
    Ok(())
}

/// grmc's `load` after checking: pick the system (R0701), apply `--param`s,
/// compile (R01xx).
fn compile(program: &Program, o: &Opts) -> Result<(usize, CompiledSystem), Stop> {
    let index = program.pick_system(o.get("--system"))?;
    let values = grm_compile::param_values(program, &o.all("--param")).map_err(Stop::Usage)?;
    let compiled = grm_compile::compile(program, &program.systems[index], &values)
        .map_err(|e| e.to_diagnostic())?;
    Ok((index, compiled))
}

/// grmc's `check_output_format` (R0406).
fn output_format(c: &CompiledSystem, output: Option<&str>) -> Result<(), Stop> {
    let Some(path) = output else { return Ok(()) };
    if grm_geom::ExportFormat::from_path(Path::new(path)).is_some() {
        return Ok(());
    }
    let e = grm_geom::ExportError::UnknownFormat {
        path: PathBuf::from(path),
    };
    Err(e.to_diagnostic(c.file, c.span).into())
}

/// grmc's `export_model` (its warnings, W0013 and W0014; R0407, R0408),
/// refusing to write into the tree.
fn export(
    at: (grm_diag::FileId, grm_diag::Span),
    model: &grm_geom::Model,
    path: &str,
    warnings: &mut Vec<Diagnostic>,
) -> Result<(), Stop> {
    let (file, span) = at;
    if let Some(name) = path.strip_prefix("$TMP/") {
        static NEXT: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
        let n = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let dir = std::env::temp_dir().join(format!("grm-run-{}-{n}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("a temporary directory");
        let out = export(at, model, &dir.join(name).to_string_lossy(), warnings);
        let _ = std::fs::remove_dir_all(&dir);
        return out;
    }
    let path = Path::new(path);
    let lines = grm_geom::ExportFormat::from_path(path) == Some(grm_geom::ExportFormat::Svg);
    warnings.extend(model.warnings(file, span, lines));
    assert!(
        path.is_absolute(),
        "run cases export only to absolute paths that cannot be written, not {}",
        path.display()
    );
    grm_geom::export(model, path).map_err(|e| e.to_diagnostic(file, span).into())
}

/// `grmc derive` on the CPU.
fn derive(program: &Program, args: &[String], warnings: &mut Vec<Diagnostic>) -> Result<(), Stop> {
    let o = Opts::parse(
        args,
        &[],
        &[
            "--system",
            "--param",
            "--iterations",
            "--seed",
            "--threads",
            "--output",
            "--max-modules",
            "--max-memory",
        ],
    )
    .map_err(Stop::Usage)?;
    let index = program.pick_system(o.get("--system"))?;
    if program.systems[index].mode == grm_sema::Mode::Shape {
        return shape_derive(program, index, &o, warnings);
    }
    let (index, c) = compile(program, &o)?;
    let at = |e: grm_derive::DeriveError| Stop::from(e.to_diagnostic(c.file, c.span));
    if program.systems[index].mode == grm_sema::Mode::Sample {
        return Err(at(grm_derive::DeriveError::SampleSystem {
            system: program.systems[index].name.clone(),
        }));
    }
    output_format(&c, o.get("--output"))?;
    let d = grm_derive::DeriveLimits::default();
    let max_mib: Option<u64> = o.number("--max-memory").map_err(Stop::Usage)?;
    let opts = grm_derive::DeriveOptions {
        iterations: o
            .number("--iterations")
            .map_err(Stop::Usage)?
            .unwrap_or(c.settings.iterations),
        seed: o
            .number("--seed")
            .map_err(Stop::Usage)?
            .unwrap_or(c.settings.seed),
        limits: grm_derive::DeriveLimits {
            max_modules: o
                .number("--max-modules")
                .map_err(Stop::Usage)?
                .unwrap_or(d.max_modules),
            max_bytes: max_mib.map_or(d.max_bytes, |m| m.saturating_mul(1 << 20)),
        },
    };
    let threads = o.number("--threads").map_err(Stop::Usage)?.unwrap_or(1);
    let engine = grm_derive::Engine::new(&c, threads).map_err(at)?;
    let derivation = engine.derive(&opts, &mut |_| {}).map_err(at)?;
    if let Some(path) = o.get("--output") {
        let system = &program.systems[index];
        // grmc's `model_options`: the same limit, and what the format needs.
        let format = grm_geom::ExportFormat::from_path(Path::new(path));
        let output = grm_geom::Output::of(format, &grm_geom::render::RenderOptions::default());
        let model = grm_geom::build_model_with(
            program,
            system,
            &derivation.string,
            &c.settings,
            &c.param_values,
            &grm_geom::BuildOptions::limited(opts.limits.max_bytes, output),
        )
        .map_err(|e| Stop::from(e.to_diagnostic(program, c.file, c.span)))?;
        export((c.file, c.span), &model, path, warnings)?;
    }
    Ok(())
}

/// `grmc derive` of a shape system: grm-grow's road, as grmc's shape
/// module takes it (lower, derive, build and export the model).
fn shape_derive(
    program: &Program,
    index: usize,
    o: &Opts,
    warnings: &mut Vec<Diagnostic>,
) -> Result<(), Stop> {
    let system = &program.systems[index];
    let (file, span) = (system.file, system.loc.span);
    let at = |e: grm_grow::shape::ShapeGrowError| Stop::from(e.to_diagnostic(program, file, span));
    let values = grm_compile::param_values(program, &o.all("--param")).map_err(Stop::Usage)?;
    if let Some(path) = o.get("--output")
        && grm_geom::ExportFormat::from_path(Path::new(path)).is_none()
    {
        let e = grm_geom::ExportError::UnknownFormat {
            path: PathBuf::from(path),
        };
        return Err(e.to_diagnostic(file, span).into());
    }
    let mut options = grm_grow::shape::ShapeOptions {
        seed: o.number("--seed").map_err(Stop::Usage)?,
        threads: o.number("--threads").map_err(Stop::Usage)?.unwrap_or(1),
        ..Default::default()
    };
    if let Some(m) = o.number::<usize>("--max-modules").map_err(Stop::Usage)? {
        options.limits.max_nodes = m;
    }
    let lowered = grm_grow::shape::lower(program, system, &values).map_err(|e| at(e.into()))?;
    let seed = options.seed.unwrap_or(lowered.seed);
    let tree = grm_grow::shape::derive(&lowered, seed, &options).map_err(at)?;
    if let Some(path) = o.get("--output") {
        let max_mib: Option<u64> = o.number("--max-memory").map_err(Stop::Usage)?;
        let d = grm_derive::DeriveLimits::default();
        let format = grm_geom::ExportFormat::from_path(Path::new(path));
        let output = grm_geom::Output::of(format, &grm_geom::render::RenderOptions::default());
        let build = grm_geom::BuildOptions::limited(
            max_mib.map_or(d.max_bytes, |m| m.saturating_mul(1 << 20)),
            output,
        );
        let model =
            grm_grow::shape::model(program, &values, &lowered, &tree, None, &build).map_err(at)?;
        export((file, span), &model, path, warnings)?;
    }
    Ok(())
}

/// `grmc sample`.
fn sample(
    rel: &Path,
    program: &Program,
    args: &[String],
    warnings: &mut Vec<Diagnostic>,
) -> Result<(), Stop> {
    let o = Opts::parse(
        args,
        &["--no-heuristic"],
        &[
            "--system",
            "--param",
            "--curves",
            "--seed",
            "--generations",
            "--particles",
            "--threads",
            "--cost",
            "--volume-weight",
            "--max-memory",
            "--output",
        ],
    )
    .map_err(Stop::Usage)?;
    let particles = match o.get("--particles") {
        Some(s) => {
            let num = |t: &str| t.trim().parse::<u32>().ok().filter(|&n| n > 0);
            let (a, b) = s.split_once("..").unwrap_or((s, s));
            match (num(a), num(b)) {
                (Some(a), Some(b)) => Some((a, b)),
                _ => return Err(Stop::Usage(format!("`--particles {s}`: not A..B"))),
            }
        }
        None => None,
    };
    let curves_path = match o.get("--curves") {
        Some(p) => PathBuf::from(p),
        None => {
            let stem = rel
                .file_stem()
                .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
            rel.with_file_name(format!("{stem}.curves.json"))
        }
    };
    let (index, c) = compile(program, &o)?;
    output_format(&c, o.get("--output"))?;
    let curves = grm_guide::Curves::load(&curves_path)
        .map_err(|e| Stop::from(e.to_diagnostic(c.file, c.span)))?;
    let mut schedule = grm_sample::Schedule::from_settings(&c.settings);
    if let Some(g) = o.number("--generations").map_err(Stop::Usage)? {
        schedule = schedule.with_generations(g);
    }
    if let Some((a, b)) = particles {
        schedule.particles_start = a;
        schedule.particles_end = b;
    }
    let volume = match o.get("--cost") {
        None | Some("curves") => false,
        Some("volume") => true,
        Some(other) => return Err(Stop::Usage(format!("`--cost {other}`"))),
    };
    let objective = if volume {
        grm_sample::Objective::Volume {
            options: grm_guide::VolumeOptions::default(),
            weight: o
                .number("--volume-weight")
                .map_err(Stop::Usage)?
                .unwrap_or(20000.0),
        }
    } else {
        grm_sample::Objective::Curves
    };
    let at = |e: grm_sample::SampleError| Stop::from(e.to_diagnostic(c.file, c.span));
    let sampler = grm_sample::Sampler::new(
        &program.systems[index],
        &c,
        &curves,
        objective,
        grm_sample::ExpectedOptions::default(),
    )
    .map_err(at)?;
    let opts = grm_sample::SampleOptions {
        seed: o
            .number("--seed")
            .map_err(Stop::Usage)?
            .unwrap_or(c.settings.seed),
        schedule,
        heuristic: !o.has("--no-heuristic") && !volume,
        temperature: 1.0,
        ess_target: grm_sample::DEFAULT_ESS_TARGET,
        candidates: grm_sample::DEFAULT_CANDIDATES,
        guide: grm_sample::Guide::default(),
        threads: o.number("--threads").map_err(Stop::Usage)?.unwrap_or(1),
        budget: None,
        best: 1,
        max_expansions_per_step: 1000,
        limits: grm_sample::FinishLimits::default(),
        reach: grm_sample::Reach::default(),
        refine: grm_sample::Refine::default(),
        max_bytes: o
            .number::<u64>("--max-memory")
            .map_err(Stop::Usage)?
            .map_or(grm_sample::DEFAULT_MAX_BYTES, |m| m.saturating_mul(1 << 20)),
        cancel: None,
        frames: false,
    };
    let result = sampler.sample(&opts).map_err(at)?;
    if let Some(path) = o.get("--output") {
        for m in &result.models {
            let model = m
                .build(program, &grm_geom::BuildOptions::default())
                .map_err(|e| Stop::from(e.to_diagnostic(program, c.file, c.span)))?;
            export((c.file, c.span), &model, path, warnings)?;
        }
    }
    Ok(())
}

//! `grmc edits check|list FILE.grm`: the grammar's persistent edits
//! (`NAME.edits.json` beside it, or `--edits PATH`; docs/edits.md).
//!
//! - `list` prints each edit (id, system, target, operation) after the
//!   file's own problems (R0901-R0911, rendered in the edits file);
//! - `check` also grows each system that has edits with its edits
//!   replayed and classifies every edit (`grm_grow::shape::edits` against
//!   the shape tree, `grm_grow::edits` from what the CPU engine or, in
//!   sample mode, the guided sampler met: a sample system is sampled once
//!   with its own schedule and seed, guided by `NAME.curves.json` beside
//!   the grammar): valid, structurally
//!   or semantically invalid, ambiguous, stale. Exit 0 when the file has
//!   no problems and every edit was replayed, 1 otherwise.
//!
//! `--format json` prints one JSON object instead of the table.

use std::path::PathBuf;

use clap::{Args, Subcommand};
use grm_edits::{Edit, EditClass};
use grm_grow::shape::ShapeOptions;
use serde_json::json;

use crate::derive::emit;
use crate::{Outcome, OutputFormat};

#[derive(Debug, Args)]
pub struct EditsArgs {
    #[command(subcommand)]
    pub command: EditsCommand,
}

#[derive(Debug, Subcommand)]
pub enum EditsCommand {
    /// Classify every edit against the grammar's model now (exit 1 unless
    /// every edit is valid).
    Check(EditsFileArgs),
    /// List the edits.
    List(EditsFileArgs),
}

#[derive(Debug, Args)]
pub struct EditsFileArgs {
    /// The grammar (.grm).
    pub file: PathBuf,
    /// The edits file (default: NAME.edits.json beside the grammar).
    #[arg(long, value_name = "PATH")]
    pub edits: Option<PathBuf>,
    /// Grow with this seed instead of each system's own.
    #[arg(long)]
    pub seed: Option<u32>,
    /// Meta-parameter values, `NAME=VALUE` (repeatable).
    #[arg(long = "param", value_name = "NAME=VALUE")]
    pub params: Vec<String>,
    /// Output format.
    #[arg(long, value_enum, default_value = "human")]
    pub format: OutputFormat,
}

pub fn run(args: EditsArgs) -> Outcome {
    match args.command {
        EditsCommand::Check(a) => go(&a, true),
        EditsCommand::List(a) => go(&a, false),
    }
}

/// One edit's line of the report.
struct Row<'a> {
    edit: &'a Edit,
    class: Option<EditClass>,
    parts: usize,
    detail: String,
    /// Whether the derivation replayed it.
    replayed: bool,
}

fn go(a: &EditsFileArgs, check: bool) -> Outcome {
    let checked = match crate::derive::load_checked(&a.file, None, &a.params) {
        Ok(c) => c,
        Err(o) => return o,
    };
    let mut sources = checked.sources;
    let program = checked.program;
    let values = checked.values;
    let root = program.systems[checked.system].file;
    let (path, named) = match &a.edits {
        Some(p) => (p.clone(), true),
        None => (grm_edits::edits_path(&a.file), false),
    };
    let text = match grm_edits::read(&path) {
        Ok(t) => t,
        Err(e) if e.is_not_found() && !named => {
            if a.format == OutputFormat::Json {
                outln!(
                    "{}",
                    json!({ "edits": path.display().to_string(), "found": false, "problems": [], "list": [] })
                );
            } else {
                eprintln!("{}: no edits file ({})", a.file.display(), path.display());
            }
            return Outcome::Ok;
        }
        Err(e) => {
            emit(&sources, &e.to_diagnostic(root));
            return Outcome::Usage;
        }
    };
    let file = sources.add(path.to_string_lossy().replace('\\', "/"), text.clone());
    let parsed = grm_edits::parse(&text);
    let problems: Vec<grm_diag::Diagnostic> = parsed
        .errors
        .iter()
        .map(|e| e.to_diagnostic(file))
        .collect();
    let mut rows: Vec<Row> = parsed
        .file
        .edits
        .iter()
        .map(|edit| Row {
            edit,
            class: None,
            parts: 0,
            detail: String::new(),
            replayed: false,
        })
        .collect();
    if check {
        // Sample mode's curves: NAME.curves.json beside the grammar, as
        // `grmc sample` reads them.
        let stem = a.file.file_stem().unwrap_or_default().to_string_lossy();
        let curves = a.file.with_file_name(format!("{stem}.curves.json"));
        classify(&program, &values, a.seed, &curves, &parsed.file, &mut rows);
    }
    let all_valid = problems.is_empty() && rows.iter().all(|r| r.replayed);
    match a.format {
        OutputFormat::Human => {
            for d in &problems {
                emit(&sources, d);
            }
            for r in &rows {
                let class = r.class.map_or("-", EditClass::as_str);
                // A key edit's recorded symbol beside its key.
                let symbol = match (&r.edit.target, &r.edit.symbol) {
                    (grm_edits::Target::Key(_), Some(s)) => format!(" ({s})"),
                    _ => String::new(),
                };
                let mut line = format!(
                    "{:>4}  {:<12} {}{symbol}  {}",
                    r.edit.id, r.edit.system, r.edit.target, r.edit.op
                );
                if check {
                    line.push_str(&format!("  [{class}"));
                    if r.parts > 1 {
                        line.push_str(&format!(", {} parts", r.parts));
                    }
                    line.push(']');
                    if !r.detail.is_empty() {
                        line.push_str(&format!(": {}", r.detail));
                    }
                }
                outln!("{line}");
            }
            let invalid = rows
                .iter()
                .filter(|r| r.class.is_some_and(|c| !c.is_valid()))
                .count();
            if check {
                eprintln!(
                    "{}: {}, {} valid, {invalid} not, {} not classified; {}",
                    path.display(),
                    crate::count(rows.len() as u64, "edit"),
                    rows.iter()
                        .filter(|r| r.class == Some(EditClass::Valid))
                        .count(),
                    rows.iter().filter(|r| r.class.is_none()).count(),
                    crate::count(problems.len() as u64, "problem"),
                );
            }
        }
        OutputFormat::Json => {
            let list: Vec<serde_json::Value> = rows
                .iter()
                .map(|r| {
                    let mut v = json!({
                        "id": r.edit.id,
                        "system": r.edit.system,
                        "target": { r.edit.target.kind(): r.edit.target.text() },
                        "op": r.edit.op.to_string(),
                        "class": r.class.map(EditClass::as_str),
                        "parts": r.parts,
                        "detail": r.detail,
                        "replayed": r.replayed,
                    });
                    // A key edit's recorded symbol, where it has one.
                    if let (grm_edits::Target::Key(_), Some(sym)) = (&r.edit.target, &r.edit.symbol)
                    {
                        v["symbol"] = sym.as_str().into();
                    }
                    v
                })
                .collect();
            let problems: Vec<serde_json::Value> = problems
                .iter()
                .map(|d| {
                    serde_json::from_str(&grm_diag::render_json(d, &sources))
                        .unwrap_or(serde_json::Value::Null)
                })
                .collect();
            outln!(
                "{}",
                json!({
                    "edits": path.display().to_string(),
                    "found": true,
                    "problems": problems,
                    "list": list,
                    "valid": all_valid,
                })
            );
        }
    }
    let ok = if check {
        all_valid
    } else {
        problems.is_empty()
    };
    if ok {
        Outcome::Ok
    } else {
        Outcome::InputErrors
    }
}

/// Grow each shape system with edits once and classify its edits.
fn classify(
    program: &grm_sema::Program,
    values: &[grm_sema::Value],
    seed: Option<u32>,
    curves: &std::path::Path,
    file: &grm_edits::EditsFile,
    rows: &mut [Row],
) {
    let mut systems: Vec<&str> = rows.iter().map(|r| r.edit.system.as_str()).collect();
    systems.sort_unstable();
    systems.dedup();
    for name in systems {
        let mine = |r: &&mut Row| r.edit.system == name;
        let Some(sys) = program.systems.iter().find(|s| s.name == name) else {
            for r in rows.iter_mut().filter(|r| r.edit.system == name) {
                r.class = Some(EditClass::Stale);
                r.detail = format!("the grammar has no system `{name}`");
            }
            continue;
        };
        if sys.mode == grm_sema::Mode::Derive {
            classify_derive(program, sys, values, seed, rows);
            continue;
        }
        if sys.mode == grm_sema::Mode::Sample {
            classify_sample(program, sys, values, seed, curves, rows);
            continue;
        }
        let grown = grm_grow::shape::lower(program, sys, values)
            .map_err(grm_grow::shape::ShapeGrowError::from)
            .and_then(|lowered| {
                let options = ShapeOptions::default();
                let plan = grm_grow::shape::edit_plan(&lowered, file);
                let seed = seed.unwrap_or(lowered.seed);
                let tree =
                    grm_grow::shape::derive_with_edits(&lowered, seed, &options, Some(&plan))?;
                Ok((lowered, tree))
            });
        let (lowered, tree) = match grown {
            Ok(g) => g,
            Err(e) => {
                for r in rows.iter_mut().filter(|r| r.edit.system == name) {
                    r.detail = format!("not classified: the system does not grow: {e}");
                }
                continue;
            }
        };
        let reports = grm_grow::shape::edits::classify(
            program,
            &lowered,
            &tree,
            rows.iter()
                .filter(|r| r.edit.system == name)
                .map(|r| r.edit),
        );
        for (r, rep) in rows.iter_mut().filter(mine).zip(reports) {
            r.class = Some(rep.class);
            r.replayed = rep.replayed;
            r.parts = rep.parts.len();
            r.detail = rep.detail;
        }
    }
}

/// Grow a derive-mode system once with its edits replayed (the CPU
/// engine, every core) and classify them (`grm_grow::edits`).
fn classify_derive(
    program: &grm_sema::Program,
    sys: &grm_sema::System,
    values: &[grm_sema::Value],
    seed: Option<u32>,
    rows: &mut [Row],
) {
    let name = sys.name.as_str();
    let mine: Vec<&Edit> = rows
        .iter()
        .filter(|r| r.edit.system == name)
        .map(|r| r.edit)
        .collect();
    let grown = grm_compile::compile(program, sys, values)
        .map_err(|e| e.to_string())
        .and_then(|c| {
            let opts = grm_derive::DeriveOptions {
                seed: seed.unwrap_or(c.settings.seed),
                ..grm_derive::DeriveOptions::from_system(&c)
            };
            let plan = grm_grow::edits::edit_plan(sys, mine.iter().copied());
            let grown = grm_grow::Grower::new(&c, 0, grm_grow::Record::default())
                .and_then(|g| g.with_edits(plan))
                .map_err(|e| grm_grow::GrowError::from(e).to_string())?
                .derive(&opts, &mut |_| {})
                .map_err(|e| e.to_string())?;
            let outcome = grown.edits.unwrap_or_default();
            Ok(grm_grow::edits::classify(
                sys,
                &c,
                &outcome,
                mine.iter().copied(),
            ))
        });
    fill_rows(rows, name, grown);
}

/// The rows of system `name`'s edits filled from its classification
/// (`reports`, in the rows' order), or each marked not classified with why
/// the system did not grow.
fn fill_rows(
    rows: &mut [Row],
    name: &str,
    grown: Result<Vec<grm_grow::edits::EditReport>, String>,
) {
    match grown {
        Ok(reports) => {
            for (r, rep) in rows
                .iter_mut()
                .filter(|r| r.edit.system == name)
                .zip(reports)
            {
                r.class = Some(rep.class);
                r.replayed = rep.replayed;
                r.parts = rep.modules as usize;
                r.detail = rep.detail;
            }
        }
        Err(e) => {
            for r in rows.iter_mut().filter(|r| r.edit.system == name) {
                r.detail = format!("not classified: the system does not grow: {e}");
            }
        }
    }
}

/// Sample a sample-mode system once (its own schedule and seed, every
/// core) with its edits replayed, guided by `curves`, and classify them
/// against the model it returns (`grm_grow::sample`).
fn classify_sample(
    program: &grm_sema::Program,
    sys: &grm_sema::System,
    values: &[grm_sema::Value],
    seed: Option<u32>,
    curves: &std::path::Path,
    rows: &mut [Row],
) {
    let name = sys.name.as_str();
    let mine: Vec<Edit> = rows
        .iter()
        .filter(|r| r.edit.system == name)
        .map(|r| r.edit.clone())
        .collect();
    let grown = grm_compile::compile(program, sys, values)
        .map_err(|e| e.to_string())
        .and_then(|c| {
            let curves = grm_guide::Curves::load(curves)
                .map_err(|e| format!("cannot read the curves {}: {e}", curves.display()))?;
            let opts = grm_sample::SampleOptions {
                seed: seed.unwrap_or(c.settings.seed),
                schedule: grm_sample::Schedule::from_settings(&c.settings),
                ..grm_sample::SampleOptions::default()
            };
            let request = grm_grow::sample::SampleRequest {
                edits: Some(&mine),
                ..grm_grow::sample::SampleRequest::new(&curves, opts)
            };
            let sampled = grm_grow::sample::sample(sys, &c, &request).map_err(|e| e.to_string())?;
            Ok(sampled.edits.unwrap_or_default())
        });
    fill_rows(rows, name, grown);
}

/// An edit's report after a growth, as either engine family classifies
/// it (`grm_grow::edits` for derive and sample mode, `grm_grow::shape::edits`
/// for shape mode).
pub trait Reported {
    /// (id, class, detail, whether the growth replayed it).
    fn row(&self) -> (u32, EditClass, &str, bool);
}

impl Reported for grm_grow::edits::EditReport {
    fn row(&self) -> (u32, EditClass, &str, bool) {
        (self.id, self.class, self.detail.as_str(), self.replayed)
    }
}

impl Reported for grm_grow::shape::edits::EditReport {
    fn row(&self) -> (u32, EditClass, &str, bool) {
        (self.id, self.class, self.detail.as_str(), self.replayed)
    }
}

/// After a growth: how many of the system's edits were replayed, and the
/// class of each one that was not (on stderr; `grmc derive` of any mode
/// and `grmc sample`).
pub fn print_replayed<R: Reported>(system: &str, reports: &[R]) {
    let rows: Vec<_> = reports.iter().map(Reported::row).collect();
    let replayed = rows.iter().filter(|r| r.3).count();
    eprintln!(
        "{}: replayed {} of {}{}",
        system,
        replayed,
        crate::count(rows.len() as u64, "edit"),
        if replayed < rows.len() {
            " (the others are listed by `grmc edits check`)"
        } else {
            ""
        }
    );
    for (id, class, detail, _) in rows.iter().filter(|r| !r.3) {
        eprintln!(
            "  edit {}: {}{}{}",
            id,
            class.as_str(),
            if detail.is_empty() { "" } else { ": " },
            detail
        );
    }
}

/// What a run that grew its model exits with when its edits file had
/// problems (printed, R09xx): input errors once it has written what it was
/// asked for, else `o`.
pub fn after_edit_problems(o: Outcome, problems: bool) -> Outcome {
    if o == Outcome::Ok && problems {
        Outcome::InputErrors
    } else {
        o
    }
}

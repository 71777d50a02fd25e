//! `grmc manip parts|provenance|drag|sketch FILE.grm`: direct manipulation
//! from the command line (issue 28; `grm-manip`, docs/manipulation.md),
//! what the preview's handles do:
//!
//! - `parts` lists what a drag can move: shapes and the planes of splits
//!   and repeats (shape mode), bones (derive mode), with their keys and
//!   measures;
//! - `provenance --part PART` prints the source numbers that place it,
//!   with the derivative of its measures by each;
//! - `drag --part PART --to TARGET [--write]` solves the fewest source
//!   edits that put it there (exit 1 when none does, with the reason);
//! - `sketch --part PART --name NAME --key T:TARGET... [--write]` proposes
//!   a meta-parameter that sweeps the part through the keyframes.
//!
//! PART: `plane:KEY:EDGE`, `shape:KEY`, `bone:KEY` (keys: 8 hex digits, as
//! `parts` and `grmc derive --tree` print them). TARGET: `plane:AT`,
//! `size.x|y|z:SIZE`, `corner:X,Y,Z` (shape frame, z up), `tip:X,Y,Z`,
//! `length:L`, `width:W`. Without `--write` nothing is written: the
//! changes are printed. The persistent edits beside the grammar are
//! replayed, as `grmc derive` replays them.

use std::path::PathBuf;

use clap::{Args, Subcommand};
use grm_manip::{DragOutcome, Keyframe, Manip, Part, Setup, Target};
use serde_json::json;

use crate::{Outcome, OutputFormat};

#[derive(Debug, Args)]
pub struct ManipArgs {
    #[command(subcommand)]
    pub command: ManipCommand,
}

#[derive(Debug, Subcommand)]
pub enum ManipCommand {
    /// List the parts a drag can move, with their keys and measures.
    Parts(CommonArgs),
    /// The source numbers that place a part, with derivatives.
    Provenance(PartArgs),
    /// Solve the fewest source edits that put a part at a target.
    Drag(DragArgs),
    /// Propose a meta-parameter that sweeps a part through keyframes.
    Sketch(SketchArgs),
}

#[derive(Debug, Args)]
pub struct CommonArgs {
    /// The grammar (.grm).
    pub file: PathBuf,
    /// The system (default: the file's first).
    #[arg(long)]
    pub system: Option<String>,
    /// Grow with this seed instead of the system's own.
    #[arg(long)]
    pub seed: Option<u32>,
    /// Meta-parameter values, `NAME=VALUE` (repeatable).
    #[arg(long = "param", value_name = "NAME=VALUE")]
    pub params: Vec<String>,
    /// Output format.
    #[arg(long, value_enum, default_value = "human")]
    pub format: OutputFormat,
}

#[derive(Debug, Args)]
pub struct PartArgs {
    #[command(flatten)]
    pub common: CommonArgs,
    /// `plane:KEY:EDGE`, `shape:KEY` or `bone:KEY`.
    #[arg(long, value_name = "PART")]
    pub part: String,
}

#[derive(Debug, Args)]
pub struct DragArgs {
    #[command(flatten)]
    pub part: PartArgs,
    /// `plane:AT`, `size.x|y|z:SIZE`, `corner:X,Y,Z`, `tip:X,Y,Z`,
    /// `length:L` or `width:W`.
    #[arg(long, value_name = "TARGET", allow_hyphen_values = true)]
    pub to: String,
    /// Write the edited grammar (through a file renamed over it).
    #[arg(long)]
    pub write: bool,
}

#[derive(Debug, Args)]
pub struct SketchArgs {
    #[command(flatten)]
    pub part: PartArgs,
    /// The new meta-parameter's name.
    #[arg(long)]
    pub name: String,
    /// A keyframe `T:TARGET` (0 < T <= 1; T = 1 required; repeatable).
    #[arg(
        long = "key",
        value_name = "T:TARGET",
        required = true,
        allow_hyphen_values = true
    )]
    pub keys: Vec<String>,
    /// Write the edited grammar.
    #[arg(long)]
    pub write: bool,
}

fn key(s: &str) -> Result<u32, String> {
    grm_edits::file::parse_key(s).ok_or_else(|| format!("`{s}` is not a key (8 hex digits)"))
}

/// `plane:KEY:EDGE`, `shape:KEY`, `bone:KEY`.
pub fn parse_part(s: &str) -> Result<Part, String> {
    let f: Vec<&str> = s.split(':').collect();
    match f.as_slice() {
        ["plane", k, e] => Ok(Part::Plane {
            command: key(k)?,
            edge: e
                .parse()
                .map_err(|_| format!("`{e}` is not an edge number"))?,
        }),
        ["shape", k] => Ok(Part::Shape { key: key(k)? }),
        ["bone", k] => Ok(Part::Bone { key: key(k)? }),
        _ => Err(format!(
            "`{s}` is not a part: plane:KEY:EDGE, shape:KEY or bone:KEY"
        )),
    }
}

fn number(s: &str) -> Result<f64, String> {
    s.trim()
        .parse::<f64>()
        .ok()
        .filter(|x| x.is_finite())
        .ok_or_else(|| format!("`{s}` is not a number"))
}

fn point(s: &str) -> Result<[f64; 3], String> {
    let v: Vec<f64> = s.split(',').map(number).collect::<Result<_, _>>()?;
    v.try_into().map_err(|_| format!("`{s}` is not X,Y,Z"))
}

/// `plane:AT`, `size.z:SIZE`, `corner:X,Y,Z`, `tip:X,Y,Z`, `length:L`, `width:W`.
pub fn parse_target(s: &str) -> Result<Target, String> {
    let (kind, v) = s
        .split_once(':')
        .ok_or_else(|| format!("`{s}` is not a target: KIND:VALUE"))?;
    Ok(match kind {
        "plane" => Target::Plane { at: number(v)? },
        "size.x" | "size.y" | "size.z" => Target::Size {
            axis: usize::from(kind.as_bytes()[5] - b'x'),
            size: number(v)?,
        },
        "corner" => Target::Corner { at: point(v)? },
        "tip" => Target::Tip { at: point(v)? },
        "length" => Target::Length { length: number(v)? },
        "width" => Target::Width { width: number(v)? },
        _ => {
            return Err(format!(
                "`{kind}` is not a target kind: plane, size.x, size.y, size.z, corner, tip, length, width"
            ));
        }
    })
}

/// What every subcommand reads: the grammar's text, path and edits.
struct Input {
    path: String,
    text: String,
    edits: Option<grm_edits::EditsFile>,
}

fn input(file: &std::path::Path) -> Result<Input, Outcome> {
    let path = std::fs::canonicalize(file)
        .map(|p| grm_sema::normalize(&p))
        .map_err(|e| {
            eprintln!("error: cannot read {}: {e}", file.display());
            Outcome::Usage
        })?;
    let text = grm_diag::input::read_bounded_string(&path, grm_sema::MAX_SOURCE_BYTES, "a grammar")
        .map_err(|e| {
            eprintln!("error: cannot read {}: {e}", file.display());
            Outcome::Usage
        })?;
    let edits = match grm_edits::read(&grm_edits::edits_path(&path)) {
        Ok(t) => {
            let parsed = grm_edits::parse(&t);
            if let Some(e) = parsed.errors.first() {
                eprintln!(
                    "error: the edits file beside the grammar has problems (the first: {e}); `grmc edits list` shows them"
                );
                return Err(Outcome::InputErrors);
            }
            Some(parsed.file)
        }
        Err(e) if e.is_not_found() => None,
        Err(e) => {
            eprintln!("error: {e}");
            return Err(Outcome::Usage);
        }
    };
    Ok(Input {
        path: path.to_string_lossy().into_owned(),
        text,
        edits,
    })
}

fn manip(c: &CommonArgs, i: &Input) -> Result<Manip, Outcome> {
    let setup = Setup {
        system: c.system.clone(),
        params: c.params.clone(),
        seed: c.seed,
        edits: i.edits.clone(),
        ..Setup::new(i.path.clone(), std::sync::Arc::new(grm_sema::FsLoader))
    };
    Manip::new(setup, &i.text).map_err(|e| {
        eprintln!("error: {e}");
        match e {
            grm_manip::ManipError::Invalid { .. } | grm_manip::ManipError::Grow { .. } => {
                Outcome::InputErrors
            }
            _ => Outcome::Usage,
        }
    })
}

fn key_text(p: &Part) -> String {
    match *p {
        Part::Plane { command, edge } => format!("plane:{command:08x}:{edge}"),
        Part::Shape { key } => format!("shape:{key:08x}"),
        Part::Bone { key } => format!("bone:{key:08x}"),
    }
}

fn nums(v: &[f64]) -> String {
    v.iter()
        .map(|x| grm_manip::format_number(*x, 4))
        .collect::<Vec<_>>()
        .join(", ")
}

/// `line:column` (from 1) of a byte offset.
fn line_col(text: &str, at: u32) -> String {
    let before = &text[..(at as usize).min(text.len())];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    format!("{line}:{col}")
}

/// Write `text` to `path` through a file beside it, renamed over it.
fn write(path: &str, text: &str) -> Result<(), Outcome> {
    let tmp = format!("{path}.tmp");
    std::fs::write(&tmp, text)
        .and_then(|()| std::fs::rename(&tmp, path))
        .map_err(|e| {
            let _ = std::fs::remove_file(&tmp);
            eprintln!("error: cannot write {path}: {e}");
            Outcome::Usage
        })
}

pub fn run(args: ManipArgs) -> Outcome {
    let r = match args.command {
        ManipCommand::Parts(c) => parts(&c),
        ManipCommand::Provenance(p) => provenance(&p),
        ManipCommand::Drag(d) => drag(&d),
        ManipCommand::Sketch(s) => sketch(&s),
    };
    r.unwrap_or_else(|o| o)
}

fn part_of(p: &PartArgs) -> Result<Part, Outcome> {
    parse_part(&p.part).map_err(|e| {
        eprintln!("error: --part: {e}");
        Outcome::Usage
    })
}

fn parts(c: &CommonArgs) -> Result<Outcome, Outcome> {
    let i = input(&c.file)?;
    let m = manip(c, &i)?;
    let ps = m.parts();
    match c.format {
        OutputFormat::Json => outln!("{}", json!({ "parts": ps })),
        OutputFormat::Human => {
            for p in &ps {
                outln!(
                    "{:<24} {}  [{}]",
                    key_text(&p.part),
                    p.label,
                    nums(&p.measures)
                );
            }
        }
    }
    Ok(Outcome::Ok)
}

fn provenance(p: &PartArgs) -> Result<Outcome, Outcome> {
    let part = part_of(p)?;
    let i = input(&p.common.file)?;
    let m = manip(&p.common, &i)?;
    let pv = m.provenance(&part).map_err(|e| {
        eprintln!("error: {e}");
        Outcome::InputErrors
    })?;
    match p.common.format {
        OutputFormat::Json => outln!("{}", serde_json::to_string(&pv).unwrap_or_default()),
        OutputFormat::Human => {
            outln!(
                "{} now [{}]; {} of {} source numbers move it{}",
                key_text(&part),
                nums(&pv.measures),
                pv.sources.len(),
                pv.probed,
                if pv.random {
                    "; it also moves with the seed (a random draw)"
                } else {
                    ""
                }
            );
            for s in &pv.sources {
                let c = &s.candidate;
                let what = match (&c.kind, &c.constant) {
                    (grm_manip::CandidateKind::Name { name }, _) => format!("a use of {name}"),
                    (_, Some(k)) => format!("constant {k}"),
                    _ => "literal".to_string(),
                };
                outln!(
                    "  {:<8} {:<10} {:<16} d/dv [{}]{}  moves {} part{}{}",
                    line_col(&i.text, c.span.start),
                    c.text,
                    what,
                    nums(&s.derivative),
                    if s.smooth {
                        ""
                    } else {
                        " (a jump: it changes a count or a choice)"
                    },
                    s.moves,
                    if s.moves == 1 { "" } else { "s" },
                    c.random
                        .as_ref()
                        .map(|r| format!("  (in {r})"))
                        .unwrap_or_default()
                );
            }
        }
    }
    Ok(Outcome::Ok)
}

fn print_changes(text: &str, changes: &[grm_manip::Change]) {
    for c in changes {
        outln!(
            "  {:<8} {} -> {}",
            line_col(text, c.span.start),
            c.old,
            c.new
        );
    }
}

fn drag(d: &DragArgs) -> Result<Outcome, Outcome> {
    let part = part_of(&d.part)?;
    let target = parse_target(&d.to).map_err(|e| {
        eprintln!("error: --to: {e}");
        Outcome::Usage
    })?;
    let i = input(&d.part.common.file)?;
    let m = manip(&d.part.common, &i)?;
    let out = m.drag(&part, &target).map_err(|e| {
        eprintln!("error: {e}");
        Outcome::Usage
    })?;
    if d.part.common.format == OutputFormat::Json {
        outln!("{}", serde_json::to_string(&out).unwrap_or_default());
    }
    match out {
        DragOutcome::Unchanged => {
            eprintln!("{} is there already: nothing to change", key_text(&part));
            Ok(Outcome::Ok)
        }
        DragOutcome::Unreachable { why, .. } => {
            eprintln!("error: {why}");
            Ok(Outcome::InputErrors)
        }
        DragOutcome::Solved(s) => {
            if d.part.common.format == OutputFormat::Human {
                outln!(
                    "{} change{} (grown again: {} from the target; {} part{} move):",
                    s.changes.len(),
                    if s.changes.len() == 1 { "" } else { "s" },
                    grm_manip::format_number(s.residual, 6),
                    s.moved,
                    if s.moved == 1 { "" } else { "s" }
                );
                print_changes(&i.text, &s.changes);
            }
            if d.write {
                write(&i.path, &s.text)?;
                eprintln!("wrote {}", d.part.common.file.display());
            } else {
                eprintln!("(not written: add --write to apply)");
            }
            Ok(Outcome::Ok)
        }
    }
}

fn sketch(s: &SketchArgs) -> Result<Outcome, Outcome> {
    let part = part_of(&s.part)?;
    let keys = s
        .keys
        .iter()
        .map(|k| {
            let (t, target) = k
                .split_once(':')
                .ok_or_else(|| format!("`{k}` is not T:TARGET"))?;
            Ok(Keyframe {
                t: number(t)?,
                target: parse_target(target)?,
            })
        })
        .collect::<Result<Vec<_>, String>>()
        .map_err(|e| {
            eprintln!("error: --key: {e}");
            Outcome::Usage
        })?;
    let i = input(&s.part.common.file)?;
    let m = manip(&s.part.common, &i)?;
    let out = m.sketch(&part, &keys, &s.name).map_err(|e| {
        eprintln!("error: {e}");
        match e {
            grm_manip::ManipError::Unsupported { .. } => Outcome::InputErrors,
            _ => Outcome::Usage,
        }
    })?;
    match s.part.common.format {
        OutputFormat::Json => outln!("{}", serde_json::to_string(&out).unwrap_or_default()),
        OutputFormat::Human => {
            outln!(
                "param {} = 0 in 0 .. 1; t = 0 grows the model as it is{}",
                out.name,
                if out.exact_at_zero {
                    " (bit for bit)"
                } else {
                    " (NOT bit for bit)"
                }
            );
            for (t, r) in &out.residuals {
                outln!(
                    "  t = {t}: {} from the sketched pose",
                    grm_manip::format_number(*r, 6)
                );
            }
            for e in &out.edits {
                outln!("  {:<8} {}", line_col(&i.text, e.span.start), e.text.trim());
            }
        }
    }
    if s.write {
        write(&i.path, &out.text)?;
        eprintln!("wrote {}", s.part.common.file.display());
    } else {
        eprintln!("(not written: add --write to apply)");
    }
    Ok(Outcome::Ok)
}

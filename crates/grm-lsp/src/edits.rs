//! Persistent edits in the editor (issue 27; docs/edits.md, "In the
//! editor"; docs/lsp-extensions.md, "Persistent edits").
//!
//! - The shape preview replays `NAME.edits.json` beside the system's
//!   grammar: the client's buffer when it has the file open, else the file
//!   on disk ([`Source`]); its answer lists each edit's class
//!   ([`EditsOut`]).
//! - The edits file gets diagnostics: its problems (R0901-R0911,
//!   `grm_edits::EditsError::to_diagnostic`) and, after each shape
//!   preview, a warning on every edit the derivation did not replay
//!   ("never applied silently"). A quick fix deletes an edit.
//! - A change to the edits file (its buffer, or the file on disk) refreshes
//!   the live previews that read it, as a change to the grammar does.
//! - `grm/edit` and `grm/removeEdit` change the file through a
//!   `workspace/applyEdit` computed with grm-edits' canonical writer, so
//!   the client's undo reverts them.
//!
//! The edits documents are kept here, not in the analysis host: they are
//! JSON, not grm, and no grm request (hover, tokens, formatting) answers
//! for them.

pub(crate) use crate::edit_requests::EditCaps;
pub use crate::edit_requests::{EditParams, EditResult, RemoveEditParams, RetargetEditParams};
use crate::{Backend, Shared, convert};
use grm_diag::{FileId, SourceFile, Span};
use grm_edits::{Edit, EditClass, EditsError, Parsed};
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Duration;
use tower_lsp_server::Client;
use tower_lsp_server::ls_types::*;

/// The end of an edits file's name.
const SUFFIX: &str = ".edits.json";

/// Whether `path` names an edits file (`NAME.edits.json`).
pub(crate) fn is_edits_path(path: &Path) -> bool {
    path.file_name()
        .and_then(|n| n.to_str())
        .is_some_and(|n| n.len() > SUFFIX.len() && n.ends_with(SUFFIX))
}

/// The grammar an edits file belongs to: `x/NAME.edits.json` -> `x/NAME.grm`.
pub(crate) fn grammar_of(path: &Path) -> Option<PathBuf> {
    let name = path.file_name()?.to_str()?;
    let stem = name.strip_suffix(SUFFIX).filter(|s| !s.is_empty())?;
    Some(path.with_file_name(format!("{stem}.grm")))
}

/// The diagnostics last published per edits file, with its version.
pub(crate) type Published = HashMap<PathBuf, (Option<i32>, Vec<Diagnostic>)>;

/// The server's state of the edits files.
#[derive(Debug, Default)]
pub(crate) struct EditsState {
    /// The edits files open in the client: version and text.
    docs: HashMap<PathBuf, (i32, Arc<str>)>,
    /// Per edits file, per system: what the last shape preview of the
    /// system made of each edit (the edit as it was read, and its report).
    reports: HashMap<PathBuf, BTreeMap<String, Vec<(Edit, EditOut)>>>,
    /// Per previewed document: the edits file its last shape preview read.
    read_by: HashMap<PathBuf, PathBuf>,
    /// The last print of each edit's part while it was valid.
    prints: Arc<Prints>,
    /// Per edits file: its building edits (those with a `parcel`) that
    /// the last `grm/layoutCity` applied to no building (layout_city.rs):
    /// edit id, code (R1032) and message.
    pub(crate) layout_issues: HashMap<PathBuf, Vec<(u32, String, String)>>,
}

/// Where a preview reads edits files from: the client's buffers (a
/// snapshot), else the disk.
#[derive(Clone, Debug, Default)]
pub struct Source {
    pub(crate) open: HashMap<PathBuf, (i32, Arc<str>)>,
    /// The last print of each edit's part while it was valid.
    prints: Arc<Prints>,
}

/// An edit as a print is kept for: its edits file, system, id and
/// target's text (a retargeted edit starts again).
pub(crate) type PrintKey = (PathBuf, String, u32, String);

/// What each edit named when last valid (`grm_grow::retarget`): shape
/// mode's ordering values and place, derive and sample mode's symbol,
/// ancestry and place, which its retarget candidates are ranked by. Kept
/// while the server runs.
pub(crate) type Prints = HashMap<PrintKey, grm_grow::retarget::PartPrint>;

/// An edits file as a preview read it.
#[derive(Debug)]
pub(crate) struct Loaded {
    pub(crate) path: PathBuf,
    /// Its text; `None` when there is no such file (no edits).
    pub(crate) text: Option<Arc<str>>,
    pub(crate) parsed: Parsed,
}

impl Source {
    /// The edits file at `path`: its buffer, or the file on disk; a file
    /// that cannot be read is one R0901 problem and no edits.
    pub(crate) fn load(&self, path: &Path) -> Loaded {
        let (text, parsed) = match read(&self.open, path) {
            Ok(Some((_, text))) => {
                let parsed = grm_edits::parse(&text);
                (Some(text), parsed)
            }
            Ok(None) => (None, Parsed::default()),
            Err(e) => (
                Some(Arc::from("")),
                Parsed {
                    errors: vec![e],
                    ..Parsed::default()
                },
            ),
        };
        Loaded {
            path: path.to_path_buf(),
            text,
            parsed,
        }
    }
}

/// An edits file's text, and its version when it is open in the client.
type Text = (Option<i32>, Arc<str>);

/// The text of the edits file at `path`: the open buffer (with its
/// version), else the file on disk (`None` for the version); `Ok(None)`
/// when neither exists.
pub(crate) fn read(
    open: &HashMap<PathBuf, (i32, Arc<str>)>,
    path: &Path,
) -> std::result::Result<Option<Text>, EditsError> {
    if let Some((v, t)) = open.get(path) {
        return Ok(Some((Some(*v), t.clone())));
    }
    match grm_edits::read(path) {
        Ok(t) => Ok(Some((None, Arc::from(t)))),
        Err(e) if e.is_not_found() => Ok(None),
        Err(e) => Err(e),
    }
}

/// What a shape preview made of the edits file (`PreviewResult::edits`).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct EditsOut {
    /// The edits file, `NAME.edits.json` beside the system's grammar.
    pub uri: Uri,
    /// Whether it exists (open in the editor or on disk); without it
    /// there are no edits.
    pub found: bool,
    /// Its problems (R0901-R0911, the diagnostics on it): an edit with a
    /// problem is skipped, the others replayed.
    pub problems: usize,
    /// The system's edits, and those of systems the grammar lacks, in
    /// the file's order.
    pub list: Vec<EditOut>,
}

/// One edit after a shape preview's derivation.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct EditOut {
    pub id: u32,
    pub system: String,
    /// As in the file: `{ "exact": "{Lot, 1, Mass}" }`, `{ "semantic": ... }`
    /// or `{ "key": ... }`.
    pub target: serde_json::Value,
    /// The operation in words: `remove`, `material brick`, `force
    /// alternative 2` (`grm_edits::Op`'s `Display`).
    pub op: String,
    /// `valid`, `structurally_invalid`, `semantically_invalid`,
    /// `ambiguous` or `stale` (docs/edits.md, "Classes").
    pub class: String,
    /// Why, in one line (empty for a valid edit that was replayed).
    pub detail: String,
    /// Whether the derivation applied it.
    pub replayed: bool,
    /// The tree nodes its target names now (`grm/pick`'s `shape.node`).
    pub parts: Vec<u32>,
    /// Targets it could be given instead, best first (shape mode: an
    /// edit that is structurally or semantically invalid or ambiguous;
    /// derive and sample mode: a key no module has; docs/edits.md,
    /// "Retargeting"): the quick fixes on its diagnostic.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub retarget: Vec<RetargetOut>,
}

/// A target an edit could be given (`EditOut::retarget`).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct RetargetOut {
    /// As in the file: `{ "exact": "..." }`, `{ "semantic": "..." }` or
    /// `{ "key": "..." }`.
    pub target: serde_json::Value,
    /// Why it is proposed: `ordering` (the same label and ordering
    /// values), `symbol_and_tags`, `ancestry` (derive and sample mode:
    /// the same symbol and chain of producing symbols), `nearest` (of the
    /// same symbol), `one_of_matched` (a part an ambiguous target
    /// matches).
    pub reason: String,
    /// The tree nodes it names (shape mode: the shape tree's; derive and
    /// sample mode: the derivation tree's).
    pub parts: Vec<u32>,
    /// For a key target: the symbol of the part it names, which the
    /// retargeted edit records (`symbol` in the edits file, docs/edits.md);
    /// absent for other targets, and for a key whose part has no symbol
    /// (a shape mode command or insert).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub symbol: Option<String>,
}

impl RetargetOut {
    /// The target as the file reads it.
    pub(crate) fn target(&self) -> Option<grm_edits::Target> {
        let (kind, text) = self.target.as_object()?.iter().next()?;
        let text = text.as_str()?;
        match kind.as_str() {
            "key" => grm_edits::file::parse_key(text).map(grm_edits::Target::Key),
            "exact" => text.parse().ok().map(grm_edits::Target::Exact),
            "semantic" => text.parse().ok().map(grm_edits::Target::Semantic),
            _ => None,
        }
    }
}

/// The one item of `items`: the first, when every other equals it;
/// `None` when there is none or two differ.
fn the_one<T: PartialEq>(mut items: impl Iterator<Item = T>) -> Option<T> {
    let first = items.next()?;
    items.all(|x| x == first).then_some(first)
}

/// The symbol of the shapes of `tree` whose identity key is `key` (the
/// parts a key target names in shape mode, which matches keys on shapes
/// only): `None` when no shape has the key or shapes of two symbols share
/// it.
pub(crate) fn shape_key_symbol(
    tree: &grm_shape::ShapeTree,
    program: &grm_shape::Program,
    key: u32,
) -> Option<String> {
    let symbols = tree
        .nodes()
        .iter()
        .filter(|n| n.key == key)
        .filter_map(|n| match n.kind {
            grm_shape::NodeKind::Shape { symbol, .. } => Some(symbol),
            _ => None,
        });
    the_one(symbols).map(|s| program.symbol_name(s).to_owned())
}

/// The symbol of the shape `node` of `tree` (`None` for a command or an
/// insert, or a node the tree lacks).
fn shape_symbol(
    tree: &grm_shape::ShapeTree,
    program: &grm_shape::Program,
    node: grm_shape::NodeId,
) -> Option<String> {
    match tree.node(node)?.kind {
        grm_shape::NodeKind::Shape { symbol, .. } => Some(program.symbol_name(symbol).to_owned()),
        _ => None,
    }
}

/// The symbol of the modules of the derivation tree `tree` whose identity
/// key is `key`, the modules an edit removed as they were made included
/// (`symbols`: the compiled system's names): `None` when no module has the
/// key, modules of two symbols share it, or the root has it.
pub(crate) fn tree_key_symbol(
    tree: &grm_grow::Tree,
    symbols: &[String],
    key: u32,
) -> Option<String> {
    let nodes = tree.nodes.iter().filter(|n| n.key == key).map(|n| n.symbol);
    let removed = tree
        .removed
        .iter()
        .filter(|r| r.key == key)
        .map(|r| Some(r.symbol));
    the_one(nodes.chain(removed))
        .flatten()
        .and_then(|s| symbols.get(s as usize))
        .cloned()
}

/// What a shape preview keeps of its edits for the diagnostics.
#[derive(Debug)]
pub(crate) struct EditsRun {
    pub(crate) path: PathBuf,
    pub(crate) system: String,
    pub(crate) reports: Vec<(Edit, EditOut)>,
    /// The prints of the parts valid edits named.
    pub(crate) prints: Vec<(PrintKey, grm_grow::retarget::PartPrint)>,
}

fn edit_out(
    e: &Edit,
    class: EditClass,
    detail: String,
    replayed: bool,
    parts: Vec<u32>,
) -> EditOut {
    EditOut {
        id: e.id,
        system: e.system.clone(),
        target: serde_json::json!({ e.target.kind(): e.target.text() }),
        op: e.op.to_string(),
        class: class.as_str().to_owned(),
        detail,
        replayed,
        parts,
        retarget: Vec::new(),
    }
}

/// How many retarget candidates an edit gets.
const CANDIDATES: usize = 4;

/// How many edits of one preview get candidates (the first, in the file's
/// order): each is a search of the tree.
const PROPOSED: usize = 32;

/// Classify the edits of `system` (and of systems the grammar lacks)
/// against the tree a preview grew with them; an edit whose target no
/// longer names what it did gets retarget candidates, ranked by the print
/// `source` kept of its part (else by what its target says), and a valid
/// edit on one part leaves that part's print.
pub(crate) fn classify(
    source: &Source,
    loaded: &Loaded,
    uri: Uri,
    prog: &grm_sema::Program,
    lowered: &grm_grow::shape::Lowered,
    tree: &grm_shape::ShapeTree,
    system: &str,
) -> (EditsOut, EditsRun) {
    use grm_grow::shape::retarget;
    let file = &loaded.parsed.file;
    let mine: Vec<&Edit> = file.of_system(system).collect();
    let mut orderings = retarget::Orderings::new(lowered, tree);
    let mut prints = Vec::new();
    let mut proposed = 0usize;
    let key = |e: &Edit| (loaded.path.clone(), e.system.clone(), e.id, e.target.text());
    let by_id: HashMap<u32, EditOut> =
        grm_grow::shape::edits::classify(prog, lowered, tree, mine.iter().copied())
            .into_iter()
            .zip(&mine)
            .map(|(r, e)| {
                let mut out = edit_out(
                    e,
                    r.class,
                    r.detail,
                    r.replayed,
                    r.parts.iter().map(|n| n.0).collect(),
                );
                if r.class == EditClass::Valid && r.parts.len() == 1 {
                    prints.push((key(e), orderings.print(r.parts[0])));
                } else if retarget::wants_candidates(r.class) && proposed < PROPOSED {
                    proposed += 1;
                    let print = source
                        .prints
                        .get(&key(e))
                        .cloned()
                        .unwrap_or_else(|| retarget::print_of_target(lowered, tree, e));
                    out.retarget =
                        retarget::candidates_with(&mut orderings, e, &print, &r.parts, CANDIDATES)
                            .into_iter()
                            .map(|c| RetargetOut {
                                target: serde_json::json!({ c.target.kind(): c.target.text() }),
                                reason: c.reason.as_str().to_owned(),
                                parts: c.parts.iter().map(|n| n.0).collect(),
                                symbol: match (&c.target, c.parts.as_slice()) {
                                    (grm_edits::Target::Key(_), &[n]) => {
                                        shape_symbol(tree, &lowered.program, n)
                                    }
                                    _ => None,
                                },
                            })
                            .collect();
                }
                (r.id, out)
            })
            .collect();
    let (out, mut run) = collect(loaded, uri, prog, system, by_id);
    run.prints = prints;
    (out, run)
}

/// What a derive- or sample-mode preview grew, for the edits' prints and
/// retarget candidates: the derivation tree of the model shown, the
/// compiled system's symbol names, and what the turtle drew.
#[derive(Clone, Copy)]
pub(crate) struct KeyTree<'a> {
    pub(crate) tree: &'a grm_grow::Tree,
    pub(crate) symbols: &'a [String],
    pub(crate) drawn: &'a grm_geom::grm_turtle::Interpretation,
}

/// Classify the edits of the derive-mode system `sys` (and of systems the
/// grammar lacks) from what a preview's derivation met replaying them
/// (`grm_grow::edits::classify`). A report's `parts` is empty: derive mode
/// names modules by key. With the preview's tree (`grown`), a valid key
/// edit leaves its module's print and a key no module has gets retarget
/// candidates ([`key_reports`]).
pub(crate) fn classify_derive(
    source: &Source,
    loaded: &Loaded,
    uri: Uri,
    prog: &grm_sema::Program,
    (sys, compiled): (&grm_sema::System, &grm_compile::CompiledSystem),
    outcome: &grm_derive::EditOutcome,
    grown: Option<KeyTree<'_>>,
) -> (EditsOut, EditsRun) {
    let file = &loaded.parsed.file;
    let mine: Vec<&Edit> = file.of_system(&sys.name).collect();
    let reports = grm_grow::edits::classify(sys, compiled, outcome, mine.iter().copied());
    key_reports(source, loaded, uri, prog, &sys.name, reports, grown)
}

/// Classify the edits of the sample-mode system `sys` (and of systems the
/// grammar lacks) from the reports of a preview's sampled run
/// (`grm_grow::sample::Sampled::edits`, in the order of the system's edits
/// in the file). A report's `parts` is empty: sample mode names modules by
/// key. Prints and candidates as [`classify_derive`]'s.
pub(crate) fn classify_sampled(
    source: &Source,
    loaded: &Loaded,
    uri: Uri,
    prog: &grm_sema::Program,
    sys: &grm_sema::System,
    reports: Vec<grm_grow::edits::EditReport>,
    grown: Option<KeyTree<'_>>,
) -> (EditsOut, EditsRun) {
    key_reports(source, loaded, uri, prog, &sys.name, reports, grown)
}

/// The reports of the derive- or sample-mode `system`'s edits (`reports`,
/// in the file's order of its edits) as the preview lists them. With the
/// tree grown (`grown`, docs/edits.md "Retargeting"): a valid edit whose
/// key one module has leaves that module's print (symbol, ancestry,
/// place), and a key target no module has (structurally invalid) gets up
/// to [`CANDIDATES`] keys of modules of the print's symbol, the same
/// ancestry first, then nearest (`grm_grow::retarget`), for the first
/// [`PROPOSED`] such edits.
fn key_reports(
    source: &Source,
    loaded: &Loaded,
    uri: Uri,
    prog: &grm_sema::Program,
    system: &str,
    reports: Vec<grm_grow::edits::EditReport>,
    grown: Option<KeyTree<'_>>,
) -> (EditsOut, EditsRun) {
    use grm_grow::retarget;
    let file = &loaded.parsed.file;
    let key = |e: &Edit| (loaded.path.clone(), e.system.clone(), e.id, e.target.text());
    let mine: Vec<(grm_grow::edits::EditReport, &Edit)> =
        reports.into_iter().zip(file.of_system(system)).collect();
    // The tree's places, computed when an edit needs them.
    let needed = mine.iter().any(|(r, e)| {
        matches!(e.target, grm_edits::Target::Key(_))
            && (r.class == EditClass::Valid || retarget::wants_key_candidates(e, r.class))
    });
    let parts = grown
        .filter(|_| needed)
        .map(|g| retarget::TreeParts::new(g.tree, g.symbols, g.drawn));
    let mut prints = Vec::new();
    let mut proposed = 0usize;
    let mut by_id: HashMap<u32, EditOut> = HashMap::new();
    for (r, e) in mine {
        let mut out = edit_out(e, r.class, r.detail, r.replayed, Vec::new());
        if let grm_edits::Target::Key(k) = e.target
            && r.class == EditClass::Valid
            && let Some(p) = parts.as_ref().and_then(|t| t.print_of_key(k))
        {
            prints.push((key(e), p));
        } else if retarget::wants_key_candidates(e, r.class)
            && proposed < PROPOSED
            && let Some(print) = source.prints.get(&key(e))
            && let Some(t) = &parts
        {
            proposed += 1;
            out.retarget = retarget::candidates(t, e, print, CANDIDATES)
                .into_iter()
                .map(|c| RetargetOut {
                    target: serde_json::json!({ c.target.kind(): c.target.text() }),
                    reason: c.reason.as_str().to_owned(),
                    parts: vec![c.node],
                    symbol: match (&c.target, grown) {
                        (grm_edits::Target::Key(_), Some(g)) => g
                            .tree
                            .nodes
                            .get(c.node as usize)
                            .and_then(|n| n.symbol)
                            .and_then(|s| g.symbols.get(s as usize))
                            .cloned(),
                        _ => None,
                    },
                })
                .collect();
        }
        by_id.insert(r.id, out);
    }
    let (out, mut run) = collect(loaded, uri, prog, system, by_id);
    run.prints = prints;
    (out, run)
}

/// The reports of `system`'s edits (`by_id`) and of the edits of systems
/// the grammar lacks, in the file's order.
fn collect(
    loaded: &Loaded,
    uri: Uri,
    prog: &grm_sema::Program,
    system: &str,
    mut by_id: HashMap<u32, EditOut>,
) -> (EditsOut, EditsRun) {
    let file = &loaded.parsed.file;
    let mut reports = Vec::new();
    for e in &file.edits {
        let out = if e.system == system {
            by_id.remove(&e.id)
        } else if prog.system(&e.system).is_none() {
            Some(edit_out(
                e,
                EditClass::Stale,
                format!("the grammar has no system `{}`", e.system),
                false,
                Vec::new(),
            ))
        } else {
            None
        };
        if let Some(o) = out {
            reports.push((e.clone(), o));
        }
    }
    let out = EditsOut {
        uri,
        found: loaded.text.is_some(),
        problems: loaded.parsed.errors.len(),
        list: reports.iter().map(|(_, o)| o.clone()).collect(),
    };
    let run = EditsRun {
        path: loaded.path.clone(),
        system: system.to_owned(),
        reports,
        prints: Vec::new(),
    };
    (out, run)
}

/// A grm diagnostic in one file (the edits file) as LSP's: the message
/// with its primary label, notes and help on their own lines, as the
/// server writes the grammar's (`grm_analysis::FileAnalysis::diagnostics`).
fn lsp_diagnostic(uri: &Uri, src: &SourceFile, d: &grm_diag::Diagnostic) -> Diagnostic {
    let p = d.primary();
    let mut message = d.message.clone();
    if !p.message.is_empty() && p.message != d.message {
        message.push_str(&format!("\n{}", p.message));
    }
    for n in &d.notes {
        message.push_str(&format!("\nnote: {n}"));
    }
    if let Some(h) = &d.help {
        message.push_str(&format!("\nhelp: {h}"));
    }
    let related: Vec<DiagnosticRelatedInformation> = d
        .labels
        .iter()
        .skip(1)
        .map(|l| DiagnosticRelatedInformation {
            location: Location {
                uri: uri.clone(),
                range: convert::range(src, clamp(l.span, &src.text)),
            },
            message: l.message.clone(),
        })
        .collect();
    Diagnostic {
        range: convert::range(src, clamp(p.span, &src.text)),
        severity: Some(match d.severity {
            grm_diag::Severity::Error => DiagnosticSeverity::ERROR,
            grm_diag::Severity::Warning => DiagnosticSeverity::WARNING,
        }),
        code: Some(NumberOrString::String(d.code.to_string())),
        source: Some("grm".into()),
        message,
        related_information: (!related.is_empty()).then_some(related),
        ..Diagnostic::default()
    }
}

fn clamp(span: Span, text: &str) -> Span {
    let n = u32::try_from(text.len()).unwrap_or(u32::MAX);
    Span::new(span.start.min(n), span.end.min(n).max(span.start.min(n)))
}

/// The diagnostics of an edits file whose text is `text`: its problems,
/// then a warning on each edit a preview did not replay (`reports`; an
/// edit is matched by its id and must still read the same).
fn diagnostics<'a>(
    uri: &Uri,
    path: &Path,
    text: &str,
    read_error: Option<&EditsError>,
    reports: impl Iterator<Item = &'a (Edit, EditOut)>,
) -> Vec<Diagnostic> {
    let src = SourceFile::new(path.to_string_lossy(), text);
    let parsed = match read_error {
        Some(e) => Parsed {
            errors: vec![e.clone()],
            ..Parsed::default()
        },
        None => grm_edits::parse(text),
    };
    let mut out: Vec<Diagnostic> = parsed
        .errors
        .iter()
        .map(|e| lsp_diagnostic(uri, &src, &e.to_diagnostic(FileId(0))))
        .collect();
    let mut seen = HashSet::new();
    for (edit, r) in reports {
        if r.replayed || !seen.insert(r.id) {
            continue;
        }
        let Some(now) = parsed.file.get(r.id) else {
            continue;
        };
        if now != edit {
            continue; // changed since: the next preview says
        }
        let mut message = format!("edit {} ({}) is not applied: {}", r.id, r.op, r.class);
        if !r.detail.is_empty() {
            message.push_str(&format!(": {}", r.detail));
        }
        if let Some(c) = EditClass::from_name(&r.class)
            && !c.is_valid()
        {
            message.push_str(&format!("\nnote: {}", c.explanation()));
        }
        if r.retarget.is_empty() {
            message.push_str(
                "\nhelp: retarget it, or delete it (quick fix); `grmc edits check` lists every edit's class",
            );
        } else {
            message.push_str(&format!(
                "\nhelp: retarget it to one of {} parts found for it (quick fixes, best first), or delete it",
                r.retarget.len()
            ));
        }
        out.push(Diagnostic {
            range: convert::range(&src, clamp(now.span, text)),
            severity: Some(DiagnosticSeverity::WARNING),
            code: Some(NumberOrString::String(format!("edit.{}", r.class))),
            source: Some("grm".into()),
            message,
            data: Some(if r.retarget.is_empty() {
                serde_json::json!({ "edit": r.id, "class": r.class })
            } else {
                serde_json::json!({ "edit": r.id, "class": r.class, "retarget": r.retarget })
            }),
            ..Diagnostic::default()
        });
    }
    out
}

/// An error on each building edit a city applied to no building
/// (`EditsState::layout_issues`: R1032, its parcel gone), at the edit, if
/// the file still has it.
fn layout_diagnostics(
    path: &Path,
    text: &str,
    issues: &[(u32, String, String)],
) -> Vec<Diagnostic> {
    if issues.is_empty() {
        return Vec::new();
    }
    let src = SourceFile::new(path.to_string_lossy(), text);
    let parsed = grm_edits::parse(text);
    issues
        .iter()
        .filter_map(|(id, code, message)| {
            let now = parsed.file.get(*id)?;
            Some(Diagnostic {
                range: convert::range(&src, clamp(now.span, text)),
                severity: Some(DiagnosticSeverity::ERROR),
                code: Some(NumberOrString::String(code.clone())),
                source: Some("grm".into()),
                message: message.clone(),
                data: Some(serde_json::json!({ "edit": id })),
                ..Diagnostic::default()
            })
        })
        .collect()
}

/// The kind of name the edits file uses, for a kind the analysis renames.
fn name_kind(k: grm_analysis::RenamedKind) -> grm_edits::NameKind {
    use grm_analysis::RenamedKind as R;
    use grm_edits::NameKind as N;
    match k {
        R::System => N::System,
        R::Symbol => N::Symbol,
        R::Material => N::Material,
        R::Mesh => N::Mesh,
        R::Parameter => N::Parameter,
        R::Tag => N::Tag,
    }
}

/// An edits file a rename changes: its path, its text now, the changes.
pub(crate) type RenamedFile = (PathBuf, Arc<str>, Vec<(Span, String)>);

/// The edits files' share of a rename (docs/edits.md, "In the editor"):
/// per edits file beside a system that may use the name (`renamed`), its
/// text now and the changes that rename `renamed.old` to `new` in the
/// edits of those systems: the file written again canonically
/// (`grm_edits::write`, one change over the lines that differ) when it has
/// no problems, else each renamed edit's element written again
/// (`grm_edits::write_edit`; a rewrite would drop the edits that do not
/// read). A file without such an edit, or none, has no entry.
pub(crate) fn renamed_in_edits(
    source: &Source,
    renamed: &grm_analysis::RenamedName,
    new: &str,
) -> Vec<RenamedFile> {
    let kind = name_kind(renamed.kind);
    // Per edits file, the systems whose edits may use the name.
    let mut files: BTreeMap<PathBuf, Vec<&str>> = BTreeMap::new();
    for s in &renamed.systems {
        // A set or offset names a module's parameter in derive mode.
        if kind == grm_edits::NameKind::Parameter && !s.shape {
            continue;
        }
        files
            .entry(grm_edits::edits_path(&s.file))
            .or_default()
            .push(&s.name);
    }
    let mut out = Vec::new();
    for (path, systems) in files {
        let Ok(Some((_, text))) = read(&source.open, &path) else {
            continue;
        };
        let parsed = grm_edits::parse(&text);
        let mut file = parsed.file;
        let mut changed = Vec::new();
        for e in &mut file.edits {
            if systems.contains(&e.system.as_str()) && e.rename(kind, &renamed.old, new) {
                changed.push((e.span, grm_edits::write_edit(e)));
            }
        }
        if changed.is_empty() {
            continue;
        }
        let changes = if parsed.errors.is_empty() {
            let (span, t) = crate::edit_fixes::minimal_edit(&text, &grm_edits::write(&file));
            vec![(span, t)]
        } else {
            changed
        };
        out.push((path, text, changes));
    }
    out
}

/// Add the edits files' share of a rename ([`renamed_in_edits`]) to the
/// rename's workspace edit (its `changes`, one entry per edits file).
pub(crate) fn rename_edits_files(
    shared: &Shared,
    renamed: Option<&grm_analysis::RenamedName>,
    new: &str,
    edit: &mut WorkspaceEdit,
) {
    let Some(renamed) = renamed else {
        return;
    };
    let source = shared.edits_source();
    let uris = shared.uris();
    for (path, text, changes) in renamed_in_edits(&source, renamed, new) {
        let Some(uri) = uris.uri_of(&path) else {
            continue;
        };
        let src = SourceFile::new("", &*text);
        let edits = changes
            .into_iter()
            .map(|(span, new_text)| TextEdit {
                range: convert::range(&src, span),
                new_text,
            })
            .collect();
        edit.changes
            .get_or_insert_with(HashMap::new)
            .insert(uri, edits);
    }
}

// ---------------------------------------------------------------------
// The server's side.

impl Shared {
    pub(crate) fn edits_state(&self) -> std::sync::MutexGuard<'_, EditsState> {
        self.edits
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// The open edits files and the prints kept, for a preview.
    pub(crate) fn edits_source(&self) -> Source {
        let st = self.edits_state();
        Source {
            open: st.docs.clone(),
            prints: st.prints.clone(),
        }
    }

    /// What the last preview of the edits file `path` made of edit `id`
    /// (as it read it).
    pub(crate) fn edit_report(&self, path: &Path, id: u32) -> Option<(Edit, EditOut)> {
        let st = self.edits_state();
        st.reports
            .get(path)?
            .values()
            .flatten()
            .find(|(_, o)| o.id == id)
            .cloned()
    }

    /// Whether the client has the edits file `path` open.
    pub(crate) fn edits_state_is_open(&self, path: &Path) -> bool {
        self.edits_state().docs.contains_key(path)
    }

    /// How many times an edits file changed (its buffer or on disk).
    pub(crate) fn edits_generation(&self) -> u64 {
        self.edits_gen.load(Ordering::SeqCst)
    }

    fn edits_changed(&self) {
        self.edits_gen.fetch_add(1, Ordering::SeqCst);
    }
}

/// After a preview of `doc` was built: keep what it made of the edits and
/// publish the edits file's diagnostics.
pub(crate) async fn after_preview(
    shared: &Arc<Shared>,
    client: &Client,
    doc: &Path,
    table: &crate::preview::PickTable,
) {
    let Some(run) = table
        .shape
        .as_ref()
        .and_then(|s| s.edits.as_ref())
        .or(table.edits.as_deref())
    else {
        return;
    };
    {
        let mut st = shared.edits_state();
        st.read_by.insert(doc.to_path_buf(), run.path.clone());
        st.reports
            .entry(run.path.clone())
            .or_default()
            .insert(run.system.clone(), run.reports.clone());
        if !run.prints.is_empty() {
            let prints = Arc::make_mut(&mut st.prints);
            for (k, p) in &run.prints {
                prints.insert(k.clone(), p.clone());
            }
        }
    }
    publish(shared, client, &run.path).await;
}

/// Publish the diagnostics of the edits file `path` when it is open, or
/// beside (or read by the preview of) an open grammar; clear them
/// otherwise.
pub(crate) async fn publish(shared: &Arc<Shared>, client: &Client, path: &Path) {
    let mut published = shared.edits_published.lock().await;
    let (open, reports) = {
        let st = shared.edits_state();
        let beside = grammar_of(path).is_some_and(|g| shared.version(&g).is_some());
        let read = st
            .read_by
            .iter()
            .any(|(d, e)| e == path && shared.version(d).is_some());
        let layout = st.layout_issues.get(path).cloned().unwrap_or_default();
        let shown = st.docs.contains_key(path) || beside || read || !layout.is_empty();
        let reports: Vec<(Edit, EditOut)> = st
            .reports
            .get(path)
            .map(|m| m.values().flatten().cloned().collect())
            .unwrap_or_default();
        let open = st.docs.clone();
        (shown.then_some(open), (reports, layout))
    };
    let (reports, layout) = reports;
    let Some(uri) = shared.uris().uri_of(path) else {
        return;
    };
    let (version, diags) = match open {
        None => (None, Vec::new()),
        Some(open) => {
            let p = path.to_path_buf();
            let u = uri.clone();
            let computed = tokio::task::spawn_blocking(move || match read(&open, &p) {
                Ok(Some((v, text))) => {
                    let mut d = diagnostics(&u, &p, &text, None, reports.iter());
                    d.extend(layout_diagnostics(&p, &text, &layout));
                    (v, d)
                }
                Ok(None) => (None, Vec::new()),
                Err(e) => (None, diagnostics(&u, &p, "", Some(&e), reports.iter())),
            })
            .await;
            match computed {
                Ok(c) => c,
                Err(_) => return,
            }
        }
    };
    // Sent when they differ from what was (nothing sent yet counts as
    // empty diagnostics).
    let changed = match published.get(path) {
        Some(last) => *last != (version, diags.clone()),
        None => !diags.is_empty(),
    };
    if !changed {
        return;
    }
    published.insert(path.to_path_buf(), (version, diags.clone()));
    client.publish_diagnostics(uri, diags, version).await;
}

/// The live previews that read the edits file `path` (or whose document
/// is the grammar beside it), with their documents' versions.
fn previews_reading(shared: &Shared, path: &Path) -> Vec<(PathBuf, i32)> {
    let beside = grammar_of(path);
    let docs: Vec<PathBuf> = shared.previews().keys().cloned().collect();
    let st = shared.edits_state();
    docs.into_iter()
        .filter(|d| Some(d) == beside.as_ref() || st.read_by.get(d).is_some_and(|e| e == path))
        .filter_map(|d| shared.version(&d).map(|v| (d, v)))
        .collect()
}

/// After the edits file `path` changed (its buffer, or on disk): publish
/// its diagnostics and regrow the live previews that read it.
pub(crate) fn changed(shared: &Arc<Shared>, client: &Client, path: PathBuf, delay: Duration) {
    shared.edits_changed();
    let generation = shared.edits_generation();
    let shared = shared.clone();
    let client = client.clone();
    tokio::spawn(async move {
        if !delay.is_zero() {
            tokio::time::sleep(delay).await;
            if shared.edits_generation() != generation {
                return; // a later change has its own task
            }
        }
        publish(&shared, &client, &path).await;
        for (doc, version) in previews_reading(&shared, &path) {
            crate::preview::refresh(&shared, &client, doc, version).await;
        }
    });
}

impl Backend {
    /// `didOpen` of an edits file.
    pub(crate) async fn edits_opened(&self, path: PathBuf, uri: Uri, version: i32, text: String) {
        self.shared.uris_mut().open(path.clone(), uri);
        self.shared
            .edits_state()
            .docs
            .insert(path.clone(), (version, Arc::from(text)));
        changed(&self.shared, &self.client, path, Duration::ZERO);
    }

    /// `didChange` of an edits file (debounced as the grammar's edits are).
    pub(crate) async fn edits_edited(&self, params: DidChangeTextDocumentParams, path: PathBuf) {
        let version = params.text_document.version;
        let applied = {
            let mut st = self.shared.edits_state();
            match st.docs.get(&path) {
                Some((_, old)) => {
                    let text = convert::apply_changes(old, &params.content_changes);
                    st.docs.insert(path.clone(), (version, Arc::from(text)));
                    true
                }
                None => false,
            }
        };
        if !applied {
            return;
        }
        let delay = self.shared.edit_delay(&path);
        changed(&self.shared, &self.client, path, delay);
    }

    /// `didClose` of an edits file: the file on disk counts again.
    pub(crate) async fn edits_closed(&self, path: PathBuf) {
        self.shared.uris_mut().close(&path);
        self.shared.edits_state().docs.remove(&path);
        changed(&self.shared, &self.client, path, Duration::ZERO);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn edits_paths_and_their_grammars() {
        assert!(is_edits_path(Path::new("/x/tower.edits.json")));
        assert!(!is_edits_path(Path::new("/x/.edits.json")));
        assert!(!is_edits_path(Path::new("/x/tower.grm")));
        assert_eq!(
            grammar_of(Path::new("/x/a.b.edits.json")),
            Some(PathBuf::from("/x/a.b.grm"))
        );
        assert_eq!(
            grm_edits::edits_path(&grammar_of(Path::new("/x/t.edits.json")).unwrap()),
            Path::new("/x/t.edits.json")
        );
    }
}

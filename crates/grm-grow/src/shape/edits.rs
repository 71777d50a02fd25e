//! A shape system's persistent edits (`grm_edits`, docs/edits.md) against
//! its derived tree: where each edit's target leads now and its class
//! (Lipp, 3.2.2), what `grmc edits check` reports and the editor shows.
//!
//! - **exact** target: [`ShapeTree::resolve`]: found (valid), a path whose
//!   edge number is past the children there (structurally invalid: its
//!   place does not exist now, and may come back), a step that fits two or
//!   more parts through an inserted level (ambiguous), or a path whose
//!   labels do not fit the tree (semantically invalid);
//! - **semantic** target: [`ShapeTree::select`]: the shapes it selects
//!   (valid), more than the edit's `selected` count (ambiguous: the query
//!   widened, reported rather than applied silently to the new parts), or
//!   none (structurally invalid: the tagged places it names are not there
//!   now);
//! - **key** target: the nodes with that identity key: one (valid), none
//!   (structurally invalid), several (ambiguous).
//!
//! The tree is the one grown with the edits replayed
//! ([`crate::shape::derive_with_edits`]): a removed part is still in it
//! (its locators resolve), so its edit stays valid.
//!
//! An edit whose target is found is then **stale** when its operation
//! names what is gone: a material, mesh, parameter or constant the
//! program does not declare, an alternative past the target's rule's, or a
//! rule's alternative on a node that is not a shape. Edits of a system the
//! program does not have are stale too.

use crate::shape::Lowered;
use grm_edits::{Edit, EditClass, Op, Target};
use grm_shape::{NodeId, NodeKind, Resolution, ShapeTree};
use std::collections::HashMap;

/// What became of one edit.
#[derive(Clone, Debug, PartialEq)]
pub struct EditReport {
    /// The edit's id.
    pub id: u32,
    pub class: EditClass,
    /// The parts its target names now (empty unless found).
    pub parts: Vec<NodeId>,
    /// Why, in one line (`floor 12 of 10`, `no material \`gold\``).
    pub detail: String,
    /// Whether the derivation replayed it: a valid edit, but for `set`
    /// and `offset`, which shape mode does not replay.
    pub replayed: bool,
}

/// Classify `edits` (those of one shape system) against `tree`, the
/// system's derived tree (`lowered` its program). `program` is the checked
/// program (its declared materials, meshes, parameters and constants).
pub fn classify<'e>(
    program: &grm_sema::Program,
    lowered: &Lowered,
    tree: &ShapeTree,
    edits: impl IntoIterator<Item = &'e Edit>,
) -> Vec<EditReport> {
    let edits: Vec<&Edit> = edits.into_iter().collect();
    // Nodes by key, only when a key target asks and the replay did not
    // record what it matched.
    let by_key: HashMap<u32, Vec<NodeId>> =
        if !tree.replayed() && edits.iter().any(|e| matches!(e.target, Target::Key(_))) {
            let mut m: HashMap<u32, Vec<NodeId>> = HashMap::new();
            for (i, n) in tree.nodes().iter().enumerate() {
                m.entry(n.key).or_default().push(NodeId(i as u32));
            }
            m
        } else {
            HashMap::new()
        };
    let shape_program = &lowered.program;
    edits
        .into_iter()
        .map(|e| {
            let (class, parts, detail) = match &e.target {
                Target::Exact(loc) => match tree.resolve(shape_program, loc) {
                    Resolution::Found(n) => (EditClass::Valid, vec![n], String::new()),
                    Resolution::StructurallyInvalid { matched } => (
                        EditClass::StructurallyInvalid,
                        Vec::new(),
                        format!(
                            "the path's first {matched} labels are there, but the edge after `{}` is past the parts there now",
                            loc.labels.get(matched.saturating_sub(1)).map_or("", String::as_str)
                        ),
                    ),
                    Resolution::Ambiguous {
                        matched,
                        candidates,
                    } => (
                        EditClass::Ambiguous,
                        Vec::new(),
                        format!(
                            "the path's first {matched} labels are there, then {candidates} parts fit the next step through an inserted level: not applied"
                        ),
                    ),
                    Resolution::Invalid => (
                        EditClass::SemanticallyInvalid,
                        Vec::new(),
                        "the path's labels do not fit the tree".to_owned(),
                    ),
                },
                Target::Semantic(q) => {
                    // What the replay matched, when the tree was grown with
                    // the edits (no string per shape per query); else found.
                    // No hits may be an edit the replay did not plan (a
                    // `set`, a material that is gone): found, too.
                    let found = tree
                        .edit_hits(e.id)
                        .filter(|h| !h.is_empty())
                        .unwrap_or_else(|| tree.select(shape_program, q));
                    if found.is_empty() {
                        (
                            EditClass::StructurallyInvalid,
                            found,
                            "the query selects no part now".to_owned(),
                        )
                    } else if let Some(made) = e.selected.filter(|&n| found.len() > n as usize) {
                        let n = found.len();
                        (
                            EditClass::Ambiguous,
                            found,
                            format!(
                                "the query selects {n} parts now, {made} when the edit was made (the replay reached all {n})"
                            ),
                        )
                    } else {
                        (EditClass::Valid, found, String::new())
                    }
                }
                Target::Key(k) => match tree
                    .edit_hits(e.id)
                    .or_else(|| {
                        // Of the recorded symbol only (`Edit::symbol`), as
                        // the replay matches.
                        by_key.get(k).map(|parts| {
                            parts
                                .iter()
                                .copied()
                                .filter(|&n| {
                                    e.symbol.as_ref().is_none_or(|s| {
                                        matches!(tree.node(n).map(|n| n.kind),
                                            Some(NodeKind::Shape { .. }))
                                            && tree.label(shape_program, n) == *s
                                    })
                                })
                                .collect()
                        })
                    })
                    .as_deref()
                {
                    None | Some([]) => (
                        EditClass::StructurallyInvalid,
                        Vec::new(),
                        match &e.symbol {
                            Some(s) if shape_program.symbol(s).is_none() => {
                                format!("no part has this key now: the grammar has no `{s}`")
                            }
                            Some(s) => format!("no `{s}` has this key now"),
                            None => "no part has this key now".to_owned(),
                        },
                    ),
                    Some([one]) => (EditClass::Valid, vec![*one], String::new()),
                    Some(many) => (
                        EditClass::Ambiguous,
                        many.to_vec(),
                        format!("{} parts have this key", many.len()),
                    ),
                },
            };
            let (class, mut detail) = match stale(program, lowered, tree, &e.op, &parts) {
                Some(why) if !parts.is_empty() => (EditClass::Stale, why),
                _ => (class, detail),
            };
            let unsupported = matches!(e.op, Op::Set { .. } | Op::Offset { .. });
            if unsupported && class == EditClass::Valid {
                detail = format!(
                    "not replayed: `{}` is not replayed in shape mode yet (meta-parameters are numbers once lowered)",
                    e.op.kind().as_str()
                );
            }
            EditReport {
                id: e.id,
                class,
                parts,
                detail,
                // A widened query is still replayed (on all its parts).
                replayed: !unsupported
                    && (class == EditClass::Valid
                        || (class == EditClass::Ambiguous
                            && matches!(e.target, Target::Semantic(_)))),
            }
        })
        .collect()
}

/// Why `op` on `parts` names what is gone, if it does.
fn stale(
    program: &grm_sema::Program,
    lowered: &Lowered,
    tree: &ShapeTree,
    op: &Op,
    parts: &[NodeId],
) -> Option<String> {
    match op {
        Op::Material { name } => (!program.materials.iter().any(|m| m.name == *name))
            .then(|| format!("the grammar declares no material `{name}`")),
        Op::Mesh { name } => (!program.meshes.iter().any(|m| m.name == *name))
            .then(|| format!("the grammar declares no mesh `{name}`")),
        Op::Set { name, .. } | Op::Offset { name, .. } => {
            (!program.params.iter().any(|p| p.name == *name)
                && !program.consts.iter().any(|c| c.name == *name))
            .then(|| format!("the grammar has no parameter or constant `{name}`"))
        }
        Op::Force { alternative } => parts.iter().find_map(|&n| {
            let node = tree.node(n)?;
            let NodeKind::Shape { symbol, .. } = node.kind else {
                return Some(format!(
                    "`{}` is not a shape: it has no rule to force",
                    tree.label(&lowered.program, n)
                ));
            };
            let count = lowered
                .alternatives
                .get(symbol.0 as usize)
                .map_or(0, Vec::len);
            (*alternative as usize > count).then(|| {
                format!(
                    "`{}` has {count} alternative{}, not {alternative}",
                    lowered.program.symbol_name(symbol),
                    if count == 1 { "" } else { "s" }
                )
            })
        }),
        Op::Pin { .. } | Op::Remove => None,
    }
}

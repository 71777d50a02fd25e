//! Instance locators (Lipp, 3.2.1): how a shape is named so that it can be
//! found again after the building is regrown.
//!
//! - The **exact locator** is the path from the axiom: every node's label
//!   (symbol, command or insert) and the number of the edge taken out of
//!   it, `{Lot, #1, comp.faces, front 1, Facade, #1, repeat.y, #3, Floor, ...}`.
//!   A component split's edges are named by selector and index within it,
//!   never by a raw face index; every other edge by its ordinal among the
//!   siblings of the next label (`#3`: the third `Floor`), so a part of
//!   another symbol inserted before it does not shift it (version 1 files
//!   wrote raw edge numbers, which still resolve). A step that no longer
//!   matches may match through a level a wrapping inserted, when exactly
//!   one node there fits ([`ShapeTree::resolve`]). Labels are names, not ids, so a locator
//!   outlives a renumbering of the program.
//! - The **semantic locator** lists, along the same path, each tagged
//!   command with the number of the child taken (the part of a split,
//!   the tile of a repeat, the component within its case) and how many
//!   there were: `(facade = 1/4, floor = 3/40, column = 5/50)`. A
//!   [`SemanticQuery`] matches it counting from the start, the end or the
//!   centre, and ignores the tags it does not name (all windows of column
//!   5 on every floor).
//!
//! The locator types and their text forms are `grm_edits::locator`'s (one
//! definition for every engine and the edits file), re-exported here; this
//! module finds them in a [`ShapeTree`].

pub use grm_edits::locator::{
    Anchor, EdgeRef, ExactLocator, SemanticEntry, SemanticLocator, SemanticQuery,
};

use crate::ir::Program;
use crate::tree::{Command, NodeId, NodeKind, ShapeTree};

/// How many nodes a wrapping may have inserted between a locator's node
/// and its next one, a command (the command and the shape it made: a
/// split wrapped in another; or a successor shape): [`ShapeTree::resolve`]
/// looks this deep for a step to a command that no longer matches
/// directly, and so does the replay. Only commands are matched so: a
/// shape found one level deeper is as likely another part (a window's
/// wall under a split where it was bricked up) as the same one.
pub const WRAP_DEPTH: u32 = 2;

/// Where an exact locator leads in a tree (Lipp's classes, 3.2.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Resolution {
    /// The node it names.
    Found(NodeId),
    /// Its first `matched` labels match, but the next edge's number is past
    /// the edges there (a repeat that now lays fewer tiles, say): it may
    /// become valid again when the scope grows.
    StructurallyInvalid { matched: usize },
    /// Its first `matched` labels match, then the next step matches no
    /// child directly but `candidates` (two or more) nodes through an
    /// inserted level: it is not applied (never a guess).
    Ambiguous { matched: usize, candidates: usize },
    /// It does not fit the tree.
    Invalid,
}

/// How a node's edge compares with a locator's edge.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum EdgeFit {
    /// The same edge.
    Same,
    /// Another edge before it (a lower number, ordinal or index of the
    /// same kind).
    Before,
    /// Another.
    Other,
}

impl ShapeTree {
    /// The edge a node was reached by, as locators are made: a component
    /// split's child by selector and index, every other by its ordinal
    /// among the siblings of its label (`#k`).
    fn edge_ref(&self, id: NodeId) -> EdgeRef {
        match self.node(id) {
            Some(n) => match n.selector {
                Some(selector) => EdgeRef::Component {
                    selector,
                    index: n.index,
                },
                None => EdgeRef::Ordinal(self.ordinal(id)),
            },
            None => EdgeRef::Ordinal(1),
        }
    }

    /// Whether node `c`, reached from its parent, fits `edge` (its
    /// label compared separately). An ordinal counts `c`'s label's
    /// siblings: the caller compares the label first.
    fn edge_fit(&self, c: NodeId, edge: &EdgeRef) -> EdgeFit {
        let Some(n) = self.node(c) else {
            return EdgeFit::Other;
        };
        let order = |a: u32, b: u32| match a.cmp(&b) {
            std::cmp::Ordering::Equal => EdgeFit::Same,
            std::cmp::Ordering::Less => EdgeFit::Before,
            std::cmp::Ordering::Greater => EdgeFit::Other,
        };
        match (n.selector, edge) {
            (Some(s), EdgeRef::Component { selector, index }) if s == *selector => {
                order(n.index, *index)
            }
            (None, EdgeRef::Number(k)) => order(n.edge, *k),
            (None, EdgeRef::Ordinal(k)) => order(self.ordinal(c), *k),
            _ => EdgeFit::Other,
        }
    }

    /// The exact locator of a node.
    pub fn exact_locator(&self, program: &Program, id: NodeId) -> ExactLocator {
        let path = self.path(id);
        ExactLocator {
            labels: path.iter().map(|&n| self.label(program, n)).collect(),
            edges: path.iter().skip(1).map(|&n| self.edge_ref(n)).collect(),
        }
    }

    /// The semantic locator of a node.
    pub fn semantic_locator(&self, program: &Program, id: NodeId) -> SemanticLocator {
        let mut entries = Vec::new();
        for n in self.path(id) {
            let Some(parent) = self.parent(n) else {
                continue;
            };
            if let Some(NodeKind::Command { tag: Some(tag), .. }) =
                self.node(parent).map(|p| p.kind)
            {
                let node = &self.nodes[n.0 as usize];
                entries.push(SemanticEntry {
                    tag: program.tag_name(tag).to_owned(),
                    index: node.index,
                    count: node.count,
                });
            }
        }
        SemanticLocator {
            entries,
            label: self.label(program, id),
        }
    }

    /// Find the node an exact locator names. Each step takes the child
    /// whose edge and label are the locator's (an ordinal edge `#k`: the
    /// k-th child of that label; a number: the raw edge, as version 1
    /// files wrote). A step to a command that matches no child directly
    /// may match through an inserted level (a split wrapped around the
    /// old one): the commands 2 to [`WRAP_DEPTH`] + 1 levels down whose
    /// label and edge (from their own parent) are the step's; exactly one
    /// is taken, two or more are [`Resolution::Ambiguous`].
    pub fn resolve(&self, program: &Program, loc: &ExactLocator) -> Resolution {
        if self.is_empty() || loc.labels.len() != loc.edges.len() + 1 {
            return Resolution::Invalid;
        }
        let mut cur = NodeId(0);
        if self.label(program, cur) != loc.labels[0] {
            return Resolution::Invalid;
        }
        for (i, edge) in loc.edges.iter().enumerate() {
            let want = &loc.labels[i + 1];
            let fits = |c: NodeId| {
                self.label(program, c) == *want && self.edge_fit(c, edge) == EdgeFit::Same
            };
            if let Some(c) = self.children(cur).find(|&c| fits(c)) {
                cur = c;
                continue;
            }
            // Through an inserted level: the commands 2.. levels down.
            let mut level: Vec<NodeId> = self.children(cur).collect();
            let mut found = Vec::new();
            for _ in 0..WRAP_DEPTH {
                level = level.iter().flat_map(|&n| self.children(n)).collect();
                found.extend(level.iter().copied().filter(|&c| {
                    matches!(self.node(c).map(|n| n.kind), Some(NodeKind::Command { .. }))
                        && fits(c)
                }));
            }
            match found[..] {
                [one] => {
                    cur = one;
                    continue;
                }
                [] => {}
                _ => {
                    return Resolution::Ambiguous {
                        matched: i + 1,
                        candidates: found.len(),
                    };
                }
            }
            // Past the children there? An ordinal: fewer children of the
            // label than it (or no child at all: a repeat laying no
            // tile); a number or component index: every child's (of the
            // case) before it.
            let past = match edge {
                EdgeRef::Ordinal(_) => {
                    self.children(cur).next().is_none()
                        || self.children(cur).any(|c| self.label(program, c) == *want)
                }
                EdgeRef::Component { selector, .. } => self.children(cur).all(|c| {
                    self.node(c).and_then(|n| n.selector) != Some(*selector)
                        || self.edge_fit(c, edge) == EdgeFit::Before
                }),
                EdgeRef::Number(_) => self
                    .children(cur)
                    .all(|c| self.edge_fit(c, edge) == EdgeFit::Before),
            };
            if past && self.command_matches(program, cur, edge) {
                return Resolution::StructurallyInvalid { matched: i + 1 };
            }
            return Resolution::Invalid;
        }
        Resolution::Found(cur)
    }

    /// Whether an edge of this kind could leave `id` (a numbered edge out
    /// of a split or repeat or shape, a component edge out of a component
    /// split).
    fn command_matches(&self, _program: &Program, id: NodeId, edge: &EdgeRef) -> bool {
        match (self.node(id).map(|n| n.kind), edge) {
            (
                Some(NodeKind::Command {
                    command: Command::Comp(_),
                    ..
                }),
                EdgeRef::Component { .. },
            ) => true,
            (
                Some(NodeKind::Command {
                    command: Command::Comp(_),
                    ..
                }),
                _,
            ) => false,
            (Some(_), EdgeRef::Number(_) | EdgeRef::Ordinal(_)) => true,
            _ => false,
        }
    }

    /// The nodes a semantic query selects, in tree order.
    pub fn select(&self, program: &Program, query: &SemanticQuery) -> Vec<NodeId> {
        (0..self.len() as u32)
            .map(NodeId)
            .filter(|&id| self.nodes[id.0 as usize].is_shape())
            .filter(|&id| query.matches(&self.semantic_locator(program, id)))
            .collect()
    }
}

//! Instance locators (Lipp, 3.2.1): how a shape is named so that it can be
//! found again after the building is regrown.
//!
//! - The **exact locator** is the path from the axiom: every node's label
//!   (symbol, command or insert) and the number of the edge taken out of
//!   it, `{Lot, 1, comp.faces, front 1, Facade, 1, repeat.y, 3, Floor, ...}`.
//!   A component split's edges are named by selector and index within it,
//!   never by a raw face index. Labels are names, not ids, so a locator
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

/// Where an exact locator leads in a tree (Lipp's classes, 3.2.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Resolution {
    /// The node it names.
    Found(NodeId),
    /// Its first `matched` labels match, but the next edge's number is past
    /// the edges there (a repeat that now lays fewer tiles, say): it may
    /// become valid again when the scope grows.
    StructurallyInvalid { matched: usize },
    /// It does not fit the tree.
    Invalid,
}

impl ShapeTree {
    fn edge_ref(&self, id: NodeId) -> EdgeRef {
        match self.node(id) {
            Some(n) => match n.selector {
                Some(selector) => EdgeRef::Component {
                    selector,
                    index: n.index,
                },
                None => EdgeRef::Number(n.edge),
            },
            None => EdgeRef::Number(0),
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

    /// Find the node an exact locator names.
    pub fn resolve(&self, program: &Program, loc: &ExactLocator) -> Resolution {
        if self.is_empty() || loc.labels.len() != loc.edges.len() + 1 {
            return Resolution::Invalid;
        }
        let mut cur = NodeId(0);
        if self.label(program, cur) != loc.labels[0] {
            return Resolution::Invalid;
        }
        for (i, edge) in loc.edges.iter().enumerate() {
            let mut found = None;
            let mut past = true;
            for c in self.children(cur) {
                let r = self.edge_ref(c);
                if r == *edge {
                    found = Some(c);
                    break;
                }
                past &= match (&r, edge) {
                    (EdgeRef::Number(a), EdgeRef::Number(b)) => a < b,
                    (
                        EdgeRef::Component {
                            selector: s,
                            index: a,
                        },
                        EdgeRef::Component {
                            selector: t,
                            index: b,
                        },
                    ) => s != t || a < b,
                    _ => false,
                };
            }
            match found {
                Some(c) if self.label(program, c) == loc.labels[i + 1] => cur = c,
                Some(_) => return Resolution::Invalid,
                None if past && self.command_matches(program, cur, edge) => {
                    return Resolution::StructurallyInvalid { matched: i + 1 };
                }
                None => return Resolution::Invalid,
            }
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
            (Some(_), EdgeRef::Number(_)) => true,
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

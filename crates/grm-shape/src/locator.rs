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

use crate::ir::{Program, Selector};
use crate::tree::{Command, NodeId, NodeKind, ShapeTree};
use std::fmt;

/// The edge taken out of a node.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum EdgeRef {
    /// The edge's number, from 1.
    Number(u32),
    /// A component split's child: its case's selector and its index within
    /// that case, from 1.
    Component { selector: Selector, index: u32 },
}

impl fmt::Display for EdgeRef {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            EdgeRef::Number(n) => write!(f, "{n}"),
            EdgeRef::Component { selector, index } => write!(f, "{} {index}", selector.name()),
        }
    }
}

/// The exact path from the axiom to a node: `labels[i]`, then `edges[i]`
/// out of it, ..., the node's own label last (`labels.len() == edges.len() + 1`).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct ExactLocator {
    pub labels: Vec<String>,
    pub edges: Vec<EdgeRef>,
}

impl fmt::Display for ExactLocator {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{{")?;
        for (i, l) in self.labels.iter().enumerate() {
            if i > 0 {
                write!(f, ", {}, ", self.edges[i - 1])?;
            }
            write!(f, "{l}")?;
        }
        write!(f, "}}")
    }
}

impl std::str::FromStr for EdgeRef {
    type Err = String;

    /// `3` or `front 2` (the [`fmt::Display`] form).
    fn from_str(s: &str) -> Result<EdgeRef, String> {
        let s = s.trim();
        if let Ok(n) = s.parse::<u32>() {
            return Ok(EdgeRef::Number(n));
        }
        let bad = || format!("`{s}` is not an edge (a number, or a selector and an index)");
        let (name, index) = s.split_once(' ').ok_or_else(bad)?;
        // Every selector, the roof's included (`slope 2`, `eave 1`).
        let selector = Selector::from_name(name).ok_or_else(bad)?;
        let index = index.trim().parse::<u32>().map_err(|_| bad())?;
        Ok(EdgeRef::Component { selector, index })
    }
}

impl std::str::FromStr for ExactLocator {
    type Err = String;

    /// The [`fmt::Display`] form, `{Lot, 1, comp.faces, front 1, Facade}`:
    /// labels and edges alternate, separated by `, ` (a label holding
    /// `, ` does not read back).
    fn from_str(s: &str) -> Result<ExactLocator, String> {
        let inner = s
            .trim()
            .strip_prefix('{')
            .and_then(|r| r.strip_suffix('}'))
            .ok_or_else(|| format!("`{s}` is not a locator in braces"))?;
        let mut labels = Vec::new();
        let mut edges = Vec::new();
        for (i, word) in inner.split(", ").enumerate() {
            if i % 2 == 0 {
                labels.push(word.to_owned());
            } else {
                edges.push(word.parse()?);
            }
        }
        if labels.len() != edges.len() + 1 || labels.iter().any(String::is_empty) {
            return Err(format!("`{s}` does not end with a label"));
        }
        Ok(ExactLocator { labels, edges })
    }
}

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

/// One tagged command on the path: its tag, the number of the child
/// taken (from 1) and how many there were.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct SemanticEntry {
    pub tag: String,
    pub index: u32,
    pub count: u32,
}

/// The tagged commands on the path from the axiom, and the node's label.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct SemanticLocator {
    pub entries: Vec<SemanticEntry>,
    pub label: String,
}

impl fmt::Display for SemanticLocator {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "(")?;
        for (i, e) in self.entries.iter().enumerate() {
            if i > 0 {
                write!(f, ", ")?;
            }
            write!(f, "{} = {}/{}", e.tag, e.index, e.count)?;
        }
        write!(f, ") {}", self.label)
    }
}

/// Which end a semantic index counts from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Anchor {
    /// `1` is the first (left or bottom).
    Start,
    /// `1` is the last (right or top).
    End,
    /// `0` is the middle one (`(count + 1) / 2`, rounded down: the left of
    /// two middles); negative before it, positive after.
    Centre,
}

impl Anchor {
    /// The index of child `index` (from 1) of `count`, counted from this anchor.
    pub fn index(self, index: u32, count: u32) -> i64 {
        match self {
            Anchor::Start => i64::from(index),
            Anchor::End => i64::from(count) + 1 - i64::from(index),
            Anchor::Centre => i64::from(index) - i64::from(count.div_ceil(2).max(1)),
        }
    }
}

/// A selection by semantic locator: the tags it names must appear on the
/// path in this order, with these indices; tags it does not name are
/// ignored; `label`, when given, must be the node's.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct SemanticQuery {
    pub entries: Vec<(String, Anchor, i64)>,
    pub label: Option<String>,
}

impl SemanticQuery {
    /// Whether `loc` is selected.
    pub fn matches(&self, loc: &SemanticLocator) -> bool {
        if self.label.as_ref().is_some_and(|l| *l != loc.label) {
            return false;
        }
        let named = |t: &str| self.entries.iter().any(|(q, _, _)| q == t);
        let mut kept = loc.entries.iter().filter(|e| named(&e.tag));
        for (tag, anchor, want) in &self.entries {
            match kept.next() {
                Some(e) if e.tag == *tag && anchor.index(e.index, e.count) == *want => {}
                _ => return false,
            }
        }
        kept.next().is_none()
    }
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

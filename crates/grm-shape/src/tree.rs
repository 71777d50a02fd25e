//! The derivation tree: every shape, command and insert the rules made,
//! with numbered edges, scopes, geometry and identity keys.
//!
//! Nodes are stored in **expansion order**: the axiom first, then each
//! shape's block (everything its rule made: successor shapes, commands each
//! followed by its children, inserts) in the order shapes were expanded,
//! depth-first. So a command's children are contiguous, every parent comes
//! before its children, and the order is the same for any thread count.

use crate::attributes::{AttrId, Attributes};
use crate::geometry::{Geom, Geometry, Outline, OutlineId};
use crate::ir::{AssetId, Axis, CompTarget, Program, Selector, SymbolId, TagId};
use crate::scope::Scope;
use grm_compile::rng;
use std::sync::Arc;

/// A node's index in [`ShapeTree::nodes`] (expansion order; the axiom is 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct NodeId(pub u32);

/// The command a command node ran.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Command {
    Split(Axis),
    Repeat(Axis),
    Comp(CompTarget),
}

impl Command {
    /// `split.x`, `repeat.y`, `comp.faces`...: the command's label in locators.
    pub fn label(self) -> String {
        match self {
            Command::Split(a) => format!("split.{}", a.name()),
            Command::Repeat(a) => format!("repeat.{}", a.name()),
            Command::Comp(t) => format!("comp.{}", t.name()),
        }
    }
}

/// What a node is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum NodeKind {
    /// A shape of `symbol`; `alternative` is the rule alternative applied
    /// (`None`: the symbol has no rule, a terminal shape).
    Shape {
        symbol: SymbolId,
        alternative: Option<u32>,
    },
    /// A split, repeat or component split; its children are the shapes it made.
    Command {
        command: Command,
        tag: Option<TagId>,
    },
    /// An inserted primitive or mesh, fitted to the node's scope (a leaf).
    Insert { asset: AssetId },
}

/// One node of the tree.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Node {
    pub kind: NodeKind,
    /// The shape's scope: the one it was made with, or for a shape whose
    /// rule made nothing (no successor, command or insert) the one its
    /// rule left, which it is drawn with (docs/shapes.md, "The tree"). A
    /// command's: the scope it divided; an insert's: the scope it fills.
    pub scope: Scope,
    /// The shape's geometry, likewise (a command's: what it divided); its
    /// outline, if any, is in [`ShapeTree::outline`].
    pub geometry: Geometry,
    /// The identity key (docs/shapes.md, "Identity").
    pub key: u32,
    /// The number of the edge from the parent, from 1 (0 for the axiom):
    /// a shape's outgoing edges are numbered in the order its rule made
    /// them; a split's children by part (`part + 1`), a repeat's by
    /// `tile * parts + part + 1`, a component split's within their case.
    pub edge: u32,
    /// For a component split's child: the index of the case (selector)
    /// that took it; 0 otherwise.
    pub case: u32,
    /// For a component split's child: the selector of that case.
    pub selector: Option<Selector>,
    /// The attributes the node is drawn with ([`crate::attributes`]; read
    /// them with [`ShapeTree::attributes`]).
    pub attrs: AttrId,
    /// The child's semantic number, from 1: the part of a split, the tile
    /// of a repeat, the component within its case; the edge otherwise.
    pub index: u32,
    /// How many of those there are (parts, tiles laid, components of the
    /// case), for counting from the other end; the parent's edge count otherwise.
    pub count: u32,
    /// Depth: 0 for the axiom.
    pub depth: u32,
    pub(crate) parent_offset: u32,
    /// Forward offset to the first node of the block (a shape) or to the
    /// first child (a command); 0 when there is none.
    pub(crate) children_offset: u32,
    /// The block's length (a shape) or the number of children (a command).
    pub(crate) children_len: u32,
}

impl NodeKind {
    /// Whether two nodes have one label (the same symbol, command or
    /// asset; a shape's alternative and a command's tag aside): what an
    /// ordinal edge (`#k`) counts.
    pub fn same_label(&self, other: &NodeKind) -> bool {
        match (self, other) {
            (NodeKind::Shape { symbol: a, .. }, NodeKind::Shape { symbol: b, .. }) => a == b,
            (NodeKind::Command { command: a, .. }, NodeKind::Command { command: b, .. }) => a == b,
            (NodeKind::Insert { asset: a }, NodeKind::Insert { asset: b }) => a == b,
            _ => false,
        }
    }
}

impl Node {
    /// Whether this node is a shape.
    pub fn is_shape(&self) -> bool {
        matches!(self.kind, NodeKind::Shape { .. })
    }
    /// Whether the node has children.
    pub fn has_children(&self) -> bool {
        self.children_len > 0
    }
}

/// A derived building: the whole tree.
#[derive(Clone, Debug, PartialEq)]
pub struct ShapeTree {
    pub(crate) nodes: Vec<Node>,
    pub(crate) outlines: Vec<Arc<Outline>>,
    pub(crate) seed: u32,
    /// The distinct attribute sets, numbered by first use in node order
    /// (entry 0: none).
    pub(crate) attributes: Vec<Attributes>,
    /// The shapes a persistent edit removed, ascending (`crate::replay`).
    pub(crate) removed: Vec<u32>,
    /// Grown with a plan of edits: (edit id, shape) for every shape an
    /// edit's target named while deriving, ascending.
    pub(crate) edit_hits: Option<Vec<(u32, u32)>>,
}

impl ShapeTree {
    /// Whether a persistent edit removed the shape: it stays in the tree
    /// (its locators resolve) but was not expanded and draws nothing.
    pub fn is_removed(&self, id: NodeId) -> bool {
        self.removed.binary_search(&id.0).is_ok()
    }

    /// Whether the tree was grown with a plan of persistent edits.
    pub fn replayed(&self) -> bool {
        self.edit_hits.is_some()
    }

    /// When the tree was grown with a plan of edits: the shapes edit `id`'s
    /// target named while deriving (before a pin changed a key), ascending.
    pub fn edit_hits(&self, id: u32) -> Option<Vec<NodeId>> {
        let hits = self.edit_hits.as_ref()?;
        let from = hits.partition_point(|h| h.0 < id);
        Some(
            hits[from..]
                .iter()
                .take_while(|h| h.0 == id)
                .map(|h| NodeId(h.1))
                .collect(),
        )
    }

    /// The shapes persistent edits removed, ascending.
    pub fn removed(&self) -> &[u32] {
        &self.removed
    }

    /// All nodes, in expansion order (module documentation).
    pub fn nodes(&self) -> &[Node] {
        &self.nodes
    }

    /// The attributes a node is drawn with (none for an unknown node).
    pub fn attributes(&self, id: NodeId) -> Attributes {
        self.node(id)
            .and_then(|n| self.attributes.get(usize::from(n.attrs.0)))
            .copied()
            .unwrap_or_default()
    }

    /// The tree's distinct attribute sets (index: [`AttrId`]; entry 0 is
    /// "none").
    pub fn attribute_table(&self) -> &[Attributes] {
        &self.attributes
    }

    /// An outline of the tree's table.
    pub fn outline(&self, id: OutlineId) -> Option<&Outline> {
        self.outlines.get(id.0 as usize).map(|a| &**a)
    }

    /// A node's geometry with its outline in hand.
    pub fn geom(&self, id: NodeId) -> Option<Geom> {
        let n = self.node(id)?;
        let get = |o: OutlineId| self.outlines.get(o.0 as usize).cloned();
        Some(match n.geometry {
            Geometry::Box => Geom::Box,
            Geometry::Rect => Geom::Rect,
            Geometry::Edge => Geom::Edge,
            Geometry::Prism(o) => Geom::Prism(get(o)?),
            Geometry::Polygon(o) => Geom::Polygon(get(o)?),
            Geometry::Roof(o) => Geom::Roof(get(o)?),
        })
    }

    /// The area of a node's face, or of its mass's footprint.
    pub fn area(&self, id: NodeId) -> f64 {
        match (self.geom(id), self.node(id)) {
            (Some(g), Some(n)) => g.area(&n.scope),
            _ => 0.0,
        }
    }

    /// The volume of a node's mass (0 for faces and edges).
    pub fn volume(&self, id: NodeId) -> f64 {
        match (self.geom(id), self.node(id)) {
            (Some(g), Some(n)) => g.volume(&n.scope),
            _ => 0.0,
        }
    }

    /// The number of nodes.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Never true for a derived tree (the axiom is always there).
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// One node.
    pub fn node(&self, id: NodeId) -> Option<&Node> {
        self.nodes.get(id.0 as usize)
    }

    /// A node's parent (`None` for the axiom).
    pub fn parent(&self, id: NodeId) -> Option<NodeId> {
        let n = self.nodes.get(id.0 as usize)?;
        (id.0 > 0).then(|| NodeId(id.0 - n.parent_offset))
    }

    /// A node's children, in order.
    pub fn children(&self, id: NodeId) -> impl Iterator<Item = NodeId> + '_ {
        let (start, len, command) = match self.nodes.get(id.0 as usize) {
            Some(n) if n.children_len > 0 => (
                id.0 + n.children_offset,
                n.children_len,
                matches!(n.kind, NodeKind::Command { .. }),
            ),
            _ => (0, 0, false),
        };
        // A command's children are all of its range; a shape's block also
        // holds its commands' children, which are skipped.
        let mut next = start;
        let end = start + len;
        std::iter::from_fn(move || {
            if next >= end {
                return None;
            }
            let c = next;
            let n = &self.nodes[c as usize];
            next += if !command && matches!(n.kind, NodeKind::Command { .. }) {
                1 + n.children_len
            } else {
                1
            };
            Some(NodeId(c))
        })
    }

    /// A node's ordinal among its parent's children: 1 + how many of the
    /// children before it have its label (the axiom's is 1). What an
    /// exact locator's ordinal edge (`#k`) names.
    pub fn ordinal(&self, id: NodeId) -> u32 {
        let Some(n) = self.node(id) else { return 1 };
        let Some(parent) = self.parent(id) else {
            return 1;
        };
        1 + self
            .children(parent)
            .take_while(|&c| c != id)
            .filter(|&c| self.nodes[c.0 as usize].kind.same_label(&n.kind))
            .count() as u32
    }

    /// The path from the axiom to `id`, both included.
    pub fn path(&self, id: NodeId) -> Vec<NodeId> {
        let mut path = vec![id];
        let mut cur = id;
        while let Some(p) = self.parent(cur) {
            path.push(p);
            cur = p;
        }
        path.reverse();
        path
    }

    /// The shapes that no rule rewrote, and the inserts: what a model is
    /// built from.
    pub fn leaves(&self) -> impl Iterator<Item = NodeId> + '_ {
        self.nodes
            .iter()
            .enumerate()
            .filter(|(_, n)| n.children_len == 0 && !matches!(n.kind, NodeKind::Command { .. }))
            .map(|(i, _)| NodeId(i as u32))
    }

    /// The inserts, in tree order.
    pub fn inserts(&self) -> impl Iterator<Item = (NodeId, AssetId, &Scope)> + '_ {
        self.nodes
            .iter()
            .enumerate()
            .filter_map(|(i, n)| match n.kind {
                NodeKind::Insert { asset } => Some((NodeId(i as u32), asset, &n.scope)),
                _ => None,
            })
    }

    /// The seed the tree was derived with.
    pub fn seed(&self) -> u32 {
        self.seed
    }

    /// The uniform draw `draw` of a node, in `[0, 1)`: keyed by its
    /// identity (what expressions in rules will draw).
    pub fn uniform(&self, id: NodeId, draw: u32) -> Option<f32> {
        let n = self.node(id)?;
        Some(rng::uniform(self.seed, 0, n.key, draw))
    }

    /// A node's label: its symbol, its command (`split.y`) or its asset
    /// (`insert:window`).
    pub fn label(&self, program: &Program, id: NodeId) -> String {
        match self.node(id).map(|n| n.kind) {
            Some(NodeKind::Shape { symbol, .. }) => program.symbol_name(symbol).to_owned(),
            Some(NodeKind::Command { command, .. }) => command.label(),
            Some(NodeKind::Insert { asset }) => format!("insert:{}", program.asset_name(asset)),
            None => String::new(),
        }
    }
}

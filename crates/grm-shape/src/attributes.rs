//! Shape attributes: the material, colour and texture a shape is drawn
//! with (docs/shapes.md, "Attributes").
//!
//! `material(m)`, `color(r, g, b)` and `texture(t)` set an attribute of
//! the current shape for the rest of its rule run: every node the rule
//! makes after the operation (successor shapes, commands and their
//! children, inserts) inherits it, and so does everything below them
//! until a rule sets it again. `push` saves the attributes with the scope
//! and `pop` restores them. A shape whose rule makes nothing is drawn with
//! the attributes its rule left (`Wall --> color(0.8, 0.2, 0.1)` paints the
//! wall).
//!
//! Storage: a node holds an [`AttrId`] (two bytes, in the padding of the
//! `Copy` node, so the node stays 104 bytes) into the tree's table of
//! distinct [`Attributes`] ([`crate::ShapeTree::attributes`]). Id 0 is
//! always "no attributes". The table is numbered by first use in the
//! tree's node order, so it is the same for any thread count; it holds at
//! most [`MAX_ATTRIBUTES`] distinct sets (past that the derivation stops
//! with [`crate::ShapeError::TooManyAttributes`]).

use crate::ir::{MaterialId, TextureId};
use std::collections::HashMap;

/// An index into a tree's attribute table (0: no attributes).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct AttrId(pub u16);

/// The most distinct attribute sets a tree may hold.
pub const MAX_ATTRIBUTES: usize = u16::MAX as usize;

/// What a shape is drawn with. Unset fields fall back to the exporter's
/// defaults (a grey material).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Attributes {
    /// A material of the program's table ([`crate::Program::material_name`]).
    pub material: Option<MaterialId>,
    /// A linear RGB colour in `[0, 1]`; with a material, it overrides the
    /// material's base colour.
    pub color: Option<[f32; 3]>,
    /// An image of the program's texture table
    /// ([`crate::Program::texture_name`]), mapped by the faces' UV
    /// coordinates.
    pub texture: Option<TextureId>,
}

impl Attributes {
    /// Whether nothing is set.
    pub fn is_empty(&self) -> bool {
        *self == Attributes::default()
    }

    fn key(&self) -> [u32; 6] {
        let c = self.color.map_or([u32::MAX; 3], |c| c.map(f32::to_bits));
        [
            self.material.map_or(u32::MAX, |m| m.0),
            self.texture.map_or(u32::MAX, |t| t.0),
            u32::from(self.color.is_some()),
            c[0],
            c[1],
            c[2],
        ]
    }
}

/// The table of distinct attribute sets of a derivation in progress
/// (shared by its workers; numbered again in node order at the end).
#[derive(Debug)]
pub(crate) struct AttrTable {
    list: Vec<Attributes>,
    index: HashMap<[u32; 6], u16>,
    /// Set when a new set did not fit.
    pub full: bool,
}

impl Default for AttrTable {
    fn default() -> Self {
        let none = Attributes::default();
        AttrTable {
            list: vec![none],
            index: HashMap::from([(none.key(), 0)]),
            full: false,
        }
    }
}

impl AttrTable {
    /// The set with id `id` (none for an id past the table).
    pub fn get(&self, id: AttrId) -> Attributes {
        self.list
            .get(usize::from(id.0))
            .copied()
            .unwrap_or_default()
    }

    /// The id of `a`, added if new; `None` (and `full` set) when the table
    /// holds [`MAX_ATTRIBUTES`] sets already.
    pub fn intern(&mut self, a: Attributes) -> Option<AttrId> {
        let key = a.key();
        if let Some(&i) = self.index.get(&key) {
            return Some(AttrId(i));
        }
        if self.list.len() >= MAX_ATTRIBUTES {
            self.full = true;
            return None;
        }
        let i = self.list.len() as u16;
        self.list.push(a);
        self.index.insert(key, i);
        Some(AttrId(i))
    }

    /// Number the sets by first use in `ids` (the nodes' ids, in node
    /// order), dropping unused ones, and rewrite the ids; id 0 stays "no
    /// attributes". Returns the final table.
    pub fn canonical<'a>(self, ids: impl Iterator<Item = &'a mut AttrId>) -> Vec<Attributes> {
        if self.list.len() <= 1 {
            return self.list;
        }
        let mut map = vec![u16::MAX; self.list.len()];
        map[0] = 0;
        let mut out = vec![self.list[0]];
        for id in ids {
            let slot = &mut map[usize::from(id.0)];
            if *slot == u16::MAX {
                *slot = out.len() as u16;
                out.push(self.list[usize::from(id.0)]);
            }
            id.0 = *slot;
        }
        out
    }
}

//! The data model: nodes (crossings), streets (polylines between two nodes
//! with a class, a width and a priority), parcels (simple polygons) and tags
//! on all of them, kept in maps ordered by identity so every walk over a
//! layout is deterministic. Blocks are not stored: they are the faces of the
//! street graph ([`crate::blocks`]).

use crate::id::Id;
use geo::Coord;
use std::collections::BTreeMap;

/// A tag's value.
#[derive(Debug, Clone, PartialEq)]
pub enum TagValue {
    Num(f64),
    Text(String),
    Bool(bool),
}

impl TagValue {
    /// The value scaled by a weight when it is a number (anchored
    /// assignments with a falloff), unchanged otherwise.
    pub fn scaled(&self, w: f64) -> TagValue {
        match self {
            TagValue::Num(v) => TagValue::Num(v * w),
            other => other.clone(),
        }
    }
}

/// Key -> value pairs on any element.
pub type Tags = BTreeMap<String, TagValue>;

/// The tag that marks an element as protected (4.2.3).
pub const PROTECTED: &str = "protected";

/// A street's type (Lipp's `streetType`), which sets its default width and
/// priority.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum StreetClass {
    Minor,
    Major,
    Highway,
}

impl StreetClass {
    pub fn name(self) -> &'static str {
        match self {
            StreetClass::Minor => "minor",
            StreetClass::Major => "major",
            StreetClass::Highway => "highway",
        }
    }

    pub fn parse(s: &str) -> Option<StreetClass> {
        match s {
            "minor" => Some(StreetClass::Minor),
            "major" => Some(StreetClass::Major),
            "highway" => Some(StreetClass::Highway),
            _ => None,
        }
    }

    /// Default width in metres.
    pub fn default_width(self) -> f64 {
        match self {
            StreetClass::Minor => 8.0,
            StreetClass::Major => 14.0,
            StreetClass::Highway => 24.0,
        }
    }

    /// Default priority (the graph cut's capacity).
    pub fn default_priority(self) -> f64 {
        match self {
            StreetClass::Minor => 1.0,
            StreetClass::Major => 4.0,
            StreetClass::Highway => 16.0,
        }
    }
}

/// A crossing or an end of a street.
#[derive(Debug, Clone, PartialEq)]
pub struct Node {
    pub id: Id,
    pub pos: Coord,
    pub tags: Tags,
}

/// A street: a polyline from node `a` through `interior` to node `b`.
#[derive(Debug, Clone, PartialEq)]
pub struct Street {
    pub id: Id,
    pub a: Id,
    pub b: Id,
    /// The points between the end nodes (often none).
    pub interior: Vec<Coord>,
    pub class: StreetClass,
    /// Full width in metres; a parcel keeps `width / 2` from the centre line.
    pub width: f64,
    /// The street's weight in a graph-cut merge (4.1.3).
    pub priority: f64,
    pub tags: Tags,
}

/// Where a parcel's polygon comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum ParcelOrigin {
    /// Subdivided from the block with this identity (regrown when the
    /// block changes).
    Generated { block: Id },
    /// Given (a GeoJSON polygon, a hand-made parcel); moved smoothly with
    /// its block.
    Explicit,
}

/// The pose a block's parcels were first moved from: the block's ring
/// then and its parcels then. The non-topological transform computes a
/// moved block's parcels from it alone (smoothly, or regrown past the
/// thresholds), so they depend on the block's ring, not on the path of
/// moves: moving a block away and back restores its parcels exactly.
#[derive(Debug, Clone, PartialEq)]
pub struct BlockRest {
    pub ring: Vec<Coord>,
    pub parcels: Vec<Parcel>,
}

/// A simple polygon (open ring, counter-clockwise, at least 3 vertices).
#[derive(Debug, Clone, PartialEq)]
pub struct Parcel {
    pub id: Id,
    pub ring: Vec<Coord>,
    pub origin: ParcelOrigin,
    pub tags: Tags,
}

/// One urban layout: a street graph and parcels.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Layout {
    pub nodes: BTreeMap<Id, Node>,
    pub streets: BTreeMap<Id, Street>,
    pub parcels: BTreeMap<Id, Parcel>,
    /// Rest poses of moved blocks, by block identity (derived state the
    /// transform keeps; not part of the layout's content or its files).
    pub rests: BTreeMap<Id, BlockRest>,
}

/// What kind of element an identity names.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum ElementKind {
    Node,
    Street,
    Parcel,
}

impl ElementKind {
    pub fn name(self) -> &'static str {
        match self {
            ElementKind::Node => "node",
            ElementKind::Street => "street",
            ElementKind::Parcel => "parcel",
        }
    }

    pub fn parse(s: &str) -> Option<ElementKind> {
        match s {
            "node" => Some(ElementKind::Node),
            "street" => Some(ElementKind::Street),
            "parcel" => Some(ElementKind::Parcel),
            _ => None,
        }
    }
}

impl Street {
    /// A street of a class with the class's width and priority.
    pub fn new(id: Id, a: Id, b: Id, class: StreetClass) -> Street {
        Street {
            id,
            a,
            b,
            interior: Vec::new(),
            class,
            width: class.default_width(),
            priority: class.default_priority(),
            tags: Tags::new(),
        }
    }

    /// The identity of a street minted from its end nodes (unordered) and
    /// its interior points.
    pub fn mint_id(a: Id, b: Id, interior: &[Coord]) -> Id {
        let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
        let mut m = Id::mint("street").id(lo).id(hi);
        let pts: Vec<Coord> = if a <= b {
            interior.to_vec()
        } else {
            interior.iter().rev().copied().collect()
        };
        for p in pts {
            m = m.f64(p.x).f64(p.y);
        }
        m.finish()
    }

    /// The other end of the street.
    pub fn other(&self, n: Id) -> Id {
        if n == self.a { self.b } else { self.a }
    }
}

impl Layout {
    /// The polyline of a street, end node to end node (None when an end
    /// node is missing).
    pub fn polyline(&self, s: &Street) -> Option<Vec<Coord>> {
        let a = self.nodes.get(&s.a)?;
        let b = self.nodes.get(&s.b)?;
        let mut pts = Vec::with_capacity(s.interior.len() + 2);
        pts.push(a.pos);
        pts.extend_from_slice(&s.interior);
        pts.push(b.pos);
        Some(pts)
    }

    /// Adds a node unless one with its identity exists; returns its id.
    pub fn add_node(&mut self, id: Id, pos: Coord) -> Id {
        self.nodes.entry(id).or_insert_with(|| Node {
            id,
            pos,
            tags: Tags::new(),
        });
        id
    }

    /// Streets at each node, in identity order.
    pub fn incidence(&self) -> BTreeMap<Id, Vec<Id>> {
        let mut inc: BTreeMap<Id, Vec<Id>> = BTreeMap::new();
        for s in self.streets.values() {
            inc.entry(s.a).or_default().push(s.id);
            if s.b != s.a {
                inc.entry(s.b).or_default().push(s.id);
            }
        }
        inc
    }

    /// Removes nodes no street uses.
    pub fn drop_isolated_nodes(&mut self) {
        let mut used: Vec<Id> = self.streets.values().flat_map(|s| [s.a, s.b]).collect();
        used.sort_unstable();
        used.dedup();
        self.nodes.retain(|id, _| used.binary_search(id).is_ok());
    }

    /// The kind of element an identity names in this layout.
    pub fn kind_of(&self, id: Id) -> Option<ElementKind> {
        if self.nodes.contains_key(&id) {
            Some(ElementKind::Node)
        } else if self.streets.contains_key(&id) {
            Some(ElementKind::Street)
        } else if self.parcels.contains_key(&id) {
            Some(ElementKind::Parcel)
        } else {
            None
        }
    }

    /// The tags of an element.
    pub fn tags_mut(&mut self, id: Id) -> Option<&mut Tags> {
        if let Some(n) = self.nodes.get_mut(&id) {
            return Some(&mut n.tags);
        }
        if let Some(s) = self.streets.get_mut(&id) {
            return Some(&mut s.tags);
        }
        self.parcels.get_mut(&id).map(|p| &mut p.tags)
    }

    /// A representative position of an element (a node's position, a
    /// street's midpoint along its polyline, a parcel's vertex centroid).
    pub fn position_of(&self, id: Id) -> Option<Coord> {
        if let Some(n) = self.nodes.get(&id) {
            return Some(n.pos);
        }
        if let Some(s) = self.streets.get(&id) {
            let pl = self.polyline(s)?;
            return Some(crate::geom::polyline_midpoint(&pl));
        }
        self.parcels
            .get(&id)
            .map(|p| crate::geom::vertex_centroid(&p.ring))
    }

    /// Removes an element (a node takes its streets with it); true when it
    /// was there.
    pub fn delete(&mut self, id: Id) -> bool {
        if self.nodes.remove(&id).is_some() {
            self.streets.retain(|_, s| s.a != id && s.b != id);
            return true;
        }
        if self.streets.remove(&id).is_some() {
            return true;
        }
        self.parcels.remove(&id).is_some()
    }

    /// The street count, node count and parcel count.
    pub fn counts(&self) -> (usize, usize, usize) {
        (self.streets.len(), self.nodes.len(), self.parcels.len())
    }
}

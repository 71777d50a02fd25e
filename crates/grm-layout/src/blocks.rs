//! Blocks: the bounded faces of the planar street graph, computed, never
//! stored (4.1.1). Each node's streets are sorted by the angle they leave
//! it at; walking every street side and turning to the next street
//! clockwise from the one we came by traces each face once, bounded faces
//! counter-clockwise (positive area). A component of the graph lying inside
//! another's block is that block's hole. A block's identity is minted from
//! the set of streets around it, so it survives moving its nodes.

use crate::geom::{point_in_ring, signed_area};
use crate::id::Id;
use crate::model::Layout;
use geo::Coord;
use std::collections::{BTreeMap, BTreeSet};

/// A face of the street graph.
#[derive(Debug, Clone, PartialEq)]
pub struct Block {
    pub id: Id,
    /// Counter-clockwise open ring along the streets' centre lines
    /// (a dead-end street inside the face appears twice, both sides).
    pub ring: Vec<Coord>,
    /// Outer rings (counter-clockwise) of street components inside it.
    pub holes: Vec<Vec<Coord>>,
    /// The streets around it, sorted, each once.
    pub streets: Vec<Id>,
    /// The nodes around it, sorted, each once.
    pub nodes: Vec<Id>,
    pub area: f64,
    /// Whether streets of another component lie inside (a hole, or a tree
    /// of streets that encloses nothing).
    pub inner: bool,
    /// Streets with the block on both sides (dead ends and bridges inside it).
    pub both_sides: Vec<Id>,
}

impl Block {
    /// Whether a point lies in the block (inside its ring, outside its holes).
    pub fn contains(&self, p: Coord) -> bool {
        point_in_ring(p, &self.ring) && !self.holes.iter().any(|h| point_in_ring(p, h))
    }
}

/// The blocks of a layout, in identity order.
pub fn blocks(layout: &Layout) -> Vec<Block> {
    // Outgoing half-edges per node: (angle, street, forward).
    let mut out: BTreeMap<Id, Vec<(f64, Id, bool)>> = BTreeMap::new();
    let mut polys: BTreeMap<Id, Vec<Coord>> = BTreeMap::new();
    for s in layout.streets.values() {
        let Some(pl) = layout.polyline(s) else {
            continue;
        };
        if s.a == s.b || pl.len() < 2 {
            continue;
        }
        let n = pl.len();
        let fa = (pl[1].y - pl[0].y).atan2(pl[1].x - pl[0].x);
        let fb = (pl[n - 2].y - pl[n - 1].y).atan2(pl[n - 2].x - pl[n - 1].x);
        out.entry(s.a).or_default().push((fa, s.id, true));
        out.entry(s.b).or_default().push((fb, s.id, false));
        polys.insert(s.id, pl);
    }
    for v in out.values_mut() {
        v.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)).then(x.2.cmp(&y.2)));
    }
    // Position of each outgoing half-edge in its node's list.
    let mut slot: BTreeMap<(Id, bool), (Id, usize)> = BTreeMap::new();
    for (&node, v) in &out {
        for (i, &(_, s, fwd)) in v.iter().enumerate() {
            slot.insert((s, fwd), (node, i));
        }
    }
    let mut seen: BTreeSet<(Id, bool)> = BTreeSet::new();
    let mut bounded = Vec::new();
    let mut outers: Vec<(Vec<Coord>, Id)> = Vec::new();
    // Components (union-find over nodes) to tell holes from their own faces.
    let comp = components(layout);
    for &start in slot.keys() {
        if seen.contains(&start) {
            continue;
        }
        let mut ring = Vec::new();
        let mut streets = BTreeSet::new();
        let mut twice = BTreeSet::new();
        let mut nodes = BTreeSet::new();
        let mut h = start;
        let mut guard = 0usize;
        loop {
            if !seen.insert(h) {
                break;
            }
            guard += 1;
            if guard > slot.len() + 1 {
                break;
            }
            let (s, fwd) = h;
            let pl = &polys[&s];
            if !streets.insert(s) {
                twice.insert(s);
            }
            let st = &layout.streets[&s];
            let (from, to) = if fwd { (st.a, st.b) } else { (st.b, st.a) };
            nodes.insert(from);
            if fwd {
                ring.extend_from_slice(&pl[..pl.len() - 1]);
            } else {
                ring.extend(pl[1..].iter().rev());
            }
            // At `to`, the twin leaves along (s, !fwd); turn to the next
            // half-edge clockwise from it.
            let Some(&(node, i)) = slot.get(&(s, !fwd)) else {
                break;
            };
            debug_assert_eq!(node, to);
            let list = &out[&node];
            let j = (i + list.len() - 1) % list.len();
            h = (list[j].1, list[j].2);
        }
        let area = signed_area(&ring);
        if area > 1e-9 {
            let streets: Vec<Id> = streets.into_iter().collect();
            bounded.push(Block {
                id: block_id(&streets),
                ring,
                holes: Vec::new(),
                streets,
                nodes: nodes.into_iter().collect(),
                area,
                inner: false,
                both_sides: twice.into_iter().collect(),
            });
        } else if let Some(&n) = nodes.iter().next() {
            ring.reverse();
            outers.push((ring, comp.get(&n).copied().unwrap_or(n)));
        }
    }
    // Each component's outer ring is a hole of the smallest block of another
    // component that contains it.
    let block_comp: Vec<Id> = bounded
        .iter()
        .map(|b| {
            b.nodes
                .first()
                .and_then(|n| comp.get(n).copied())
                .unwrap_or_default()
        })
        .collect();
    for (ring, c) in outers {
        let Some(&p) = ring.first() else { continue };
        let mut best: Option<usize> = None;
        for (i, b) in bounded.iter().enumerate() {
            if block_comp[i] == c || !point_in_ring(p, &b.ring) {
                continue;
            }
            if best.is_none_or(|k| bounded[k].area > b.area) {
                best = Some(i);
            }
        }
        if let Some(i) = best {
            bounded[i].inner = true;
            if signed_area(&ring).abs() > 1e-9 {
                bounded[i].holes.push(ring);
            }
        }
    }
    // Holes inside holes: keep only the outermost per block (an inner
    // component's own blocks cover the rest).
    for b in &mut bounded {
        let hs = std::mem::take(&mut b.holes);
        let keep: Vec<Vec<Coord>> = hs
            .iter()
            .filter(|h| {
                !hs.iter().any(|o| {
                    !std::ptr::eq(*h, o) && h.first().is_some_and(|p| point_in_ring(*p, o))
                })
            })
            .cloned()
            .collect();
        b.holes = keep;
    }
    bounded.sort_by_key(|b| b.id);
    bounded
}

/// A block's identity: minted from the sorted set of its streets.
pub fn block_id(sorted_streets: &[Id]) -> Id {
    let mut m = Id::mint("block");
    for s in sorted_streets {
        m = m.id(*s);
    }
    m.finish()
}

/// The component (smallest node id) of every node.
pub fn components(layout: &Layout) -> BTreeMap<Id, Id> {
    let mut parent: BTreeMap<Id, Id> = layout.nodes.keys().map(|&k| (k, k)).collect();
    fn find(p: &mut BTreeMap<Id, Id>, x: Id) -> Id {
        let mut r = x;
        while let Some(&q) = p.get(&r) {
            if q == r {
                break;
            }
            r = q;
        }
        let mut y = x;
        while let Some(&q) = p.get(&y) {
            if q == r {
                break;
            }
            p.insert(y, r);
            y = q;
        }
        r
    }
    for s in layout.streets.values() {
        if !parent.contains_key(&s.a) || !parent.contains_key(&s.b) {
            continue;
        }
        let ra = find(&mut parent, s.a);
        let rb = find(&mut parent, s.b);
        if ra != rb {
            let (lo, hi) = if ra < rb { (ra, rb) } else { (rb, ra) };
            parent.insert(hi, lo);
        }
    }
    let keys: Vec<Id> = parent.keys().copied().collect();
    keys.into_iter()
        .map(|k| (k, find(&mut parent, k)))
        .collect()
}

/// The block owning each parcel (4.1.1: a parcel completely inside a block;
/// tested with its vertex centroid and every vertex).
pub fn ownership(layout: &Layout, blocks: &[Block]) -> BTreeMap<Id, Id> {
    ownership_of(layout, blocks, false)
}

/// The block owning each explicit parcel (a generated parcel names its
/// block itself).
pub fn explicit_ownership(layout: &Layout, blocks: &[Block]) -> BTreeMap<Id, Id> {
    ownership_of(layout, blocks, true)
}

fn ownership_of(layout: &Layout, blocks: &[Block], explicit_only: bool) -> BTreeMap<Id, Id> {
    let asks = |p: &crate::model::Parcel| {
        !explicit_only || p.origin == crate::model::ParcelOrigin::Explicit
    };
    if !layout.parcels.values().any(asks) {
        // No parcel to place (a merge's layers often have only generated
        // ones): no index either.
        return BTreeMap::new();
    }
    let tree = rstar::RTree::bulk_load(
        blocks
            .iter()
            .enumerate()
            .map(|(i, b)| {
                let (min, max) = crate::index::bounds(&b.ring);
                crate::index::Boxed {
                    id: Id(i as u64),
                    min,
                    max,
                }
            })
            .collect(),
    );
    let mut own = BTreeMap::new();
    for p in layout.parcels.values() {
        if !asks(p) {
            continue;
        }
        let c = crate::geom::vertex_centroid(&p.ring);
        let mut best: Option<&Block> = None;
        for bx in tree.locate_in_envelope_intersecting(&rstar::AABB::from_point([c.x, c.y])) {
            let Some(b) = blocks.get(bx.id.0 as usize) else {
                continue;
            };
            if b.contains(c)
                && p.ring.iter().all(|v| point_in_ring(*v, &b.ring))
                && best.is_none_or(|k| k.area > b.area)
            {
                best = Some(b);
            }
        }
        if let Some(b) = best {
            own.insert(p.id, b.id);
        }
    }
    own
}

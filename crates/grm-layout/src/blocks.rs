//! Blocks: the bounded faces of the planar street graph, computed, never
//! stored (4.1.1). Each node's streets are sorted by the angle they leave
//! it at; walking every street side and turning to the next street
//! clockwise from the one we came by traces each face once, bounded faces
//! counter-clockwise (positive area). A component of the graph lying inside
//! another's block is that block's hole. A block's identity is minted from
//! the set of streets around it, so it survives moving its nodes.

use crate::geom::{point_in_ring, signed_area};
use crate::id::Id;
use crate::index::same_bits;
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

/// One face of the street graph as [`blocks`] traces it, before holes are
/// assigned: a bounded face is a block (no holes, not `inner`), the other
/// kind is a component's outline (its ring reversed, its smallest node).
#[derive(Debug, Clone)]
enum Face {
    Bounded(Block),
    Outline {
        ring: Vec<Coord>,
        node: Id,
        /// Its nodes, sorted.
        nodes: Vec<Id>,
    },
}

/// A street walked one way (forward: from its `a` to its `b`).
type HalfEdge = (Id, bool);

/// The faces of a layout's street graph kept between calls, so that the
/// blocks of the next layout reuse every face no changed street touches
/// (an editor dragging a layer changes a seam of the city, not the city).
///
/// [`Faces::update`] gives exactly what [`blocks`] gives for the new
/// layout, whatever layout the faces were kept from: a street is changed
/// when it is new, gone, or has other end nodes or points; a node is
/// dirty when a changed street ends at it. The half-edges leaving a clean
/// node keep their order (the same streets at the same angles), so a face
/// with no dirty node is the same walk as before (the same half-edges, the
/// same ring from the same smallest half-edge), and every other face of
/// the new graph passes a dirty node: it is traced again from there and
/// its ring rotated to start at its smallest half-edge, where [`blocks`]
/// starts it. Holes are assigned again over all faces, as [`blocks`] does.
///
/// A rigid move (a dragged layer) changes every street of the moved part
/// but none of its faces' walks: a face whose every node keeps its
/// half-edges in the same order (the same streets leaving in the same
/// cyclic order, whatever their angles now) is the same walk as before,
/// so it is not traced again but re-placed: its ring and area are read
/// again from the new polylines along the kept walk (the bits [`blocks`]
/// reads), its identity, streets and nodes kept. Only the faces through a
/// node whose order changed (a street added, gone, or turned past
/// another) are traced again.
#[derive(Debug, Clone, Default)]
pub struct Faces {
    /// Street -> its end nodes and polyline (streets [`blocks`] walks).
    /// This map and the next three are looked up, never walked in order.
    polys: crate::id::IdMap<Id, (Id, Id, Vec<Coord>)>,
    /// Node -> its outgoing half-edges (angle, street, forward), sorted.
    out: crate::id::IdMap<Id, Vec<(f64, Id, bool)>>,
    /// Half-edge -> (its node, its place in that node's list).
    slot: crate::id::IdMap<(Id, bool), (Id, usize)>,
    /// Faces (their half-edges and the face) by their smallest half-edge.
    faces: BTreeMap<HalfEdge, (Vec<HalfEdge>, Face)>,
    /// Half-edge -> the face it belongs to (the face's smallest half-edge).
    edge_face: crate::id::IdMap<(Id, bool), (Id, bool)>,
    /// Faces traced again by the last update (for tests and reports).
    pub retraced: usize,
    /// Faces the last update re-placed (the same walk, new coordinates).
    pub replaced: usize,
}

fn same_poly(layout: &Layout, s: &crate::model::Street, old: &(Id, Id, Vec<Coord>)) -> bool {
    if old.0 != s.a || old.1 != s.b || old.2.len() != s.interior.len() + 2 {
        return false;
    }
    let (Some(a), Some(b)) = (layout.nodes.get(&s.a), layout.nodes.get(&s.b)) else {
        return false;
    };
    let n = old.2.len();
    same_bits(&old.2[..1], &[a.pos])
        && same_bits(&old.2[n - 1..], &[b.pos])
        && same_bits(&old.2[1..n - 1], &s.interior)
}

impl Faces {
    /// The blocks of `layout` (equal to [`blocks`]`(layout)`), reusing the
    /// faces kept from the last call; keeps the new faces for the next.
    pub fn update(&mut self, layout: &Layout) -> Vec<Block> {
        // Streets [`blocks`] walks, and which of them changed.
        let mut changed: BTreeMap<Id, Option<(Id, Id, Vec<Coord>)>> = BTreeMap::new();
        for s in layout.streets.values() {
            let pl = match self.polys.get(&s.id) {
                Some(old) if same_poly(layout, s, old) => continue,
                _ => layout.polyline(s),
            };
            let new = pl
                .filter(|pl| s.a != s.b && pl.len() >= 2)
                .map(|pl| (s.a, s.b, pl));
            if new.is_some() || self.polys.contains_key(&s.id) {
                changed.insert(s.id, new);
            }
        }
        for id in self.polys.keys() {
            if !layout.streets.contains_key(id) {
                changed.insert(*id, None);
            }
        }
        let mut dirty: BTreeSet<Id> = BTreeSet::new();
        for (id, new) in &changed {
            if let Some(old) = self.polys.get(id) {
                dirty.extend([old.0, old.1]);
            }
            if let Some(new) = new {
                dirty.extend([new.0, new.1]);
            }
        }
        // Faces through a dirty node may change (every face leaves each of
        // its nodes by one of its half-edges): each is kept as a walk or
        // traced again once the dirty nodes' orders are known.
        let mut touched: BTreeSet<HalfEdge> = BTreeSet::new();
        for n in &dirty {
            for &(_, s, fwd) in self.out.get(n).map(Vec::as_slice).unwrap_or(&[]) {
                if let Some(key) = self.edge_face.get(&(s, fwd)).copied() {
                    touched.insert(key);
                }
            }
        }
        // The changed streets' polylines, then the dirty nodes' lists.
        for (id, new) in &changed {
            match new {
                Some(v) => {
                    self.polys.insert(*id, v.clone());
                }
                None => {
                    self.polys.remove(id);
                }
            }
        }
        // The changed streets' half-edges by the node they leave.
        let mut leaving: BTreeMap<Id, Vec<(f64, Id, bool)>> = BTreeMap::new();
        for (id, new) in &changed {
            let Some((a, b, pl)) = new else { continue };
            let k = pl.len();
            leaving.entry(*a).or_default().push((
                (pl[1].y - pl[0].y).atan2(pl[1].x - pl[0].x),
                *id,
                true,
            ));
            leaving.entry(*b).or_default().push((
                (pl[k - 2].y - pl[k - 1].y).atan2(pl[k - 2].x - pl[k - 1].x),
                *id,
                false,
            ));
        }
        // Dirty nodes whose half-edges now leave in another order (or are
        // other half-edges): the faces through them are traced again.
        let mut reordered: BTreeSet<Id> = BTreeSet::new();
        // Every dirty node's list first, then the places of the half-edges
        // that moved (a half-edge may leave another node now: all old
        // places go before any new one is written).
        let mut placed: Vec<Id> = Vec::new();
        for n in &dirty {
            let old = self.out.remove(n).unwrap_or_default();
            let before: Vec<HalfEdge> = old.iter().map(|&(_, s, f)| (s, f)).collect();
            let mut v: Vec<(f64, Id, bool)> = old
                .into_iter()
                .filter(|(_, s, _)| !changed.contains_key(s))
                .collect();
            v.extend(leaving.remove(n).unwrap_or_default());
            v.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)).then(x.2.cmp(&y.2)));
            // The same half-edges in the same cyclic order (a turn may
            // carry one across the angles' cut: the list is then rotated,
            // and each half-edge's clockwise neighbour is the same).
            let k = v.iter().position(|x| before.first() == Some(&(x.1, x.2)));
            let same = v.len() == before.len()
                && k.is_some_and(|k| {
                    (0..v.len()).all(|i| {
                        let x = &v[(k + i) % v.len()];
                        (x.1, x.2) == before[i]
                    })
                });
            if !same {
                reordered.insert(*n);
            }
            // Not rotated: every half-edge keeps its place.
            if k != Some(0) || !same {
                for h in &before {
                    self.slot.remove(h);
                }
                placed.push(*n);
            }
            if !v.is_empty() {
                self.out.insert(*n, v);
            }
        }
        for n in placed {
            for (i, &(_, s, fwd)) in self
                .out
                .get(&n)
                .map(Vec::as_slice)
                .unwrap_or(&[])
                .iter()
                .enumerate()
            {
                self.slot.insert((s, fwd), (n, i));
            }
        }
        // A touched face whose walk turns at no reordered node (and whose
        // half-edges are all still there) is the same walk: re-placed.
        // The others are gone, and traced again below.
        let mut replaced = 0;
        for key in touched {
            let Some((seq, old)) = self.faces.remove(&key) else {
                continue;
            };
            let intact = seq.iter().all(|&(s, fwd)| {
                self.slot.contains_key(&(s, fwd))
                    && self
                        .slot
                        .get(&(s, !fwd))
                        .is_some_and(|(to, _)| !reordered.contains(to))
            });
            if intact {
                let face = self.replace(&seq, old);
                replaced += 1;
                self.faces.insert(key, (seq, face));
            } else {
                for e in seq {
                    self.edge_face.remove(&e);
                }
            }
        }
        self.replaced = replaced;
        // Trace the faces through dirty nodes again.
        let mut retraced = 0;
        for n in &dirty {
            let starts: Vec<(Id, bool)> = self
                .out
                .get(n)
                .map(|v| v.iter().map(|&(_, s, f)| (s, f)).collect())
                .unwrap_or_default();
            for h in starts {
                if self.edge_face.contains_key(&h) {
                    continue;
                }
                let Some(seq) = self.orbit(h) else { continue };
                retraced += 1;
                let key = seq[0];
                for e in &seq {
                    self.edge_face.insert(*e, key);
                }
                let face = self.face(&seq);
                self.faces.insert(key, (seq, face));
            }
        }
        self.retraced = retraced;
        self.blocks(layout)
    }

    /// The half-edges of the face through `h`, from the smallest.
    fn orbit(&self, start: (Id, bool)) -> Option<Vec<(Id, bool)>> {
        let mut seq = Vec::new();
        let mut h = start;
        loop {
            seq.push(h);
            if seq.len() > self.slot.len() + 1 {
                return None;
            }
            let (node, i) = *self.slot.get(&(h.0, !h.1))?;
            let list = &self.out[&node];
            let j = (i + list.len() - 1) % list.len();
            h = (list[j].1, list[j].2);
            if h == start {
                break;
            }
        }
        let k = (0..seq.len()).min_by_key(|&i| seq[i])?;
        seq.rotate_left(k);
        Some(seq)
    }

    /// The ring along a face's half-edges, as [`blocks`] builds it.
    fn ring(&self, seq: &[HalfEdge]) -> Vec<Coord> {
        let mut ring = Vec::new();
        for &(s, fwd) in seq {
            let (_, _, pl) = &self.polys[&s];
            if fwd {
                ring.extend_from_slice(&pl[..pl.len() - 1]);
            } else {
                ring.extend(pl[1..].iter().rev());
            }
        }
        ring
    }

    /// A face whose walk is the same as before, at its new coordinates
    /// (equal to [`Faces::face`] of the walk: the streets and nodes of a
    /// walk are the walk's, only the ring and the area are read again; a
    /// face whose area changed sign is built again).
    fn replace(&self, seq: &[HalfEdge], old: Face) -> Face {
        let mut ring = self.ring(seq);
        let area = signed_area(&ring);
        match old {
            Face::Bounded(b) if area > 1e-9 => Face::Bounded(Block { ring, area, ..b }),
            Face::Outline { node, nodes, .. } if area <= 1e-9 => {
                ring.reverse();
                Face::Outline { ring, node, nodes }
            }
            _ => self.face(seq),
        }
    }

    /// A face from its half-edges, as [`blocks`] builds it.
    fn face(&self, seq: &[(Id, bool)]) -> Face {
        let mut ring = Vec::new();
        let mut streets = BTreeSet::new();
        let mut twice = BTreeSet::new();
        let mut nodes = BTreeSet::new();
        for &(s, fwd) in seq {
            let (a, b, pl) = &self.polys[&s];
            if !streets.insert(s) {
                twice.insert(s);
            }
            nodes.insert(if fwd { *a } else { *b });
            if fwd {
                ring.extend_from_slice(&pl[..pl.len() - 1]);
            } else {
                ring.extend(pl[1..].iter().rev());
            }
        }
        let area = signed_area(&ring);
        if area > 1e-9 {
            let streets: Vec<Id> = streets.into_iter().collect();
            Face::Bounded(Block {
                id: block_id(&streets),
                ring,
                holes: Vec::new(),
                streets,
                nodes: nodes.into_iter().collect(),
                area,
                inner: false,
                both_sides: twice.into_iter().collect(),
            })
        } else {
            ring.reverse();
            Face::Outline {
                ring,
                node: nodes.iter().next().copied().unwrap_or_default(),
                nodes: nodes.into_iter().collect(),
            }
        }
    }

    /// The blocks with their holes, in identity order (as [`blocks`]).
    fn blocks(&self, layout: &Layout) -> Vec<Block> {
        let mut bounded: Vec<Block> = Vec::new();
        let mut outers: Vec<(&[Coord], Id, &[Id])> = Vec::new();
        for (_, f) in self.faces.values() {
            match f {
                Face::Bounded(b) => bounded.push(b.clone()),
                Face::Outline { ring, node, nodes } => outers.push((ring, *node, nodes)),
            }
        }
        // Holes as in [`blocks`]. A block sharing a node with the outline
        // is of its component; the components are computed only when some
        // other block contains an outline's first point.
        let mut comp: Option<BTreeMap<Id, Id>> = None;
        for (ring, node, nodes) in outers {
            let Some(&p) = ring.first() else { continue };
            let mut best: Option<usize> = None;
            for i in 0..bounded.len() {
                if !point_in_ring(p, &bounded[i].ring) || shares(nodes, &bounded[i].nodes) {
                    continue;
                }
                let comp = comp.get_or_insert_with(|| components(layout));
                let c = comp.get(&node).copied().unwrap_or(node);
                let bc = bounded[i]
                    .nodes
                    .first()
                    .and_then(|n| comp.get(n).copied())
                    .unwrap_or_default();
                if bc == c {
                    continue;
                }
                if best.is_none_or(|k| bounded[k].area > bounded[i].area) {
                    best = Some(i);
                }
            }
            if let Some(i) = best {
                bounded[i].inner = true;
                if signed_area(ring).abs() > 1e-9 {
                    bounded[i].holes.push(ring.to_vec());
                }
            }
        }
        for b in &mut bounded {
            if b.holes.len() < 2 {
                continue;
            }
            let hs = std::mem::take(&mut b.holes);
            b.holes = hs
                .iter()
                .filter(|h| {
                    !hs.iter().any(|o| {
                        !std::ptr::eq(*h, o) && h.first().is_some_and(|p| point_in_ring(*p, o))
                    })
                })
                .cloned()
                .collect();
        }
        bounded.sort_by_key(|b| b.id);
        bounded
    }
}

/// Whether two sorted lists share an element.
fn shares(a: &[Id], b: &[Id]) -> bool {
    let (mut i, mut j) = (0, 0);
    while i < a.len() && j < b.len() {
        match a[i].cmp(&b[j]) {
            std::cmp::Ordering::Less => i += 1,
            std::cmp::Ordering::Greater => j += 1,
            std::cmp::Ordering::Equal => return true,
        }
    }
    false
}

//! The shared graph of two layouts (4.1.3, step 2): the lower layout's
//! streets and the upper's in one planar graph, each street split where it
//! meets a street of the other layout. Nodes at the same place become one
//! (the upper's identity); an intersection node's identity is minted from
//! the two streets and the place; a piece's from its street and its end
//! nodes (an unsplit street keeps its identity). A lower street running
//! along an upper one is dropped (coincident streets are deleted).

use crate::geom::{self, Meet};
use crate::id::Id;
use crate::index;
use crate::model::{Layout, Street};
use geo::Coord;
use std::collections::{BTreeMap, BTreeSet};

/// The tag a piece of a cut street carries: the whole street's identity.
pub const PART_OF: &str = "part_of";

/// Which input a piece or node comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Side {
    /// The lower layout (`U_a`).
    A,
    /// The upper layout (`U_b`).
    B,
}

/// The shared graph and where each piece came from.
#[derive(Debug, Clone, Default)]
pub struct Shared {
    pub layout: Layout,
    /// Piece -> (side, the original street's identity).
    pub origin: BTreeMap<Id, (Side, Id)>,
    /// Original street -> its pieces, in order along it.
    pub pieces: BTreeMap<(Side, Id), Vec<Id>>,
    /// Nodes where a street of one side meets a street of the other.
    pub crossings: BTreeSet<Id>,
    /// Nodes where a street was cut (a subset of the crossings): empty
    /// when the two layouts only touch at shared nodes.
    pub splits: BTreeSet<Id>,
    /// Lower streets dropped because they run along upper ones.
    pub coincident: Vec<Id>,
    /// The lower layout's nodes and streets renamed: old -> new identity.
    pub renamed: BTreeMap<Id, Id>,
    /// The original streets (after renaming), by side.
    pub originals: BTreeMap<(Side, Id), Street>,
}

/// Where a street is cut: its segment, the parameter along it, the node.
type Cut = (usize, f64, Id);

fn bits(c: Coord) -> (u64, u64) {
    let z = |v: f64| {
        if v == 0.0 {
            0.0f64.to_bits()
        } else {
            v.to_bits()
        }
    };
    (z(c.x), z(c.y))
}

/// One meeting of a lower street with an upper street: the node, its
/// place, and the cut it makes on either street (none at an end node).
#[derive(Debug, Clone)]
struct Meeting {
    node: Id,
    p: Coord,
    on_lower: Option<(usize, f64)>,
    on_upper: Option<(Id, usize, f64)>,
}

/// A lower street's meetings with the upper streets, in the order the
/// shared graph makes them, and whether it runs along an upper street
/// (the meetings then stop there).
#[derive(Debug, Clone)]
struct Meetings {
    events: Vec<Meeting>,
    overlap: bool,
}

fn poly_of(base: &Layout, s: &Street) -> Option<Vec<Coord>> {
    let mut v = vec![base.nodes.get(&s.a)?.pos];
    v.extend_from_slice(&s.interior);
    v.push(base.nodes.get(&s.b)?.pos);
    Some(v)
}

/// A lower street's meetings with the upper streets (the shared graph's
/// walk over its segments, each segment's hits in street and segment order).
fn meetings(
    s: &Street,
    pl: &[Coord],
    useg: &rstar::RTree<index::Seg>,
    upper: &crate::id::IdMap<Id, &Street>,
    base: &Layout,
) -> Meetings {
    let mut events = Vec::new();
    let mut overlap = false;
    'segs: for (k, w) in pl.windows(2).enumerate() {
        let env = rstar::AABB::from_corners([w[0].x, w[0].y], [w[1].x, w[1].y]);
        let mut hits: Vec<&index::Seg> = useg.locate_in_envelope_intersecting(&env).collect();
        hits.sort_by(|x, y| x.street.cmp(&y.street).then(x.k.cmp(&y.k)));
        for o in hits {
            let Some(t) = upper.get(&o.street) else {
                continue;
            };
            match geom::meet(w[0], w[1], o.a, o.b) {
                None => {}
                Some(Meet::Overlap) => {
                    overlap = true;
                    break 'segs;
                }
                Some(Meet::Point(p)) => {
                    let ends = [s.a, s.b, t.a, t.b];
                    let node = ends
                        .iter()
                        .copied()
                        .find(|n| base.nodes.get(n).is_some_and(|m| m.pos == p))
                        .unwrap_or_else(|| {
                            Id::mint("x").id(s.id).id(t.id).f64(p.x).f64(p.y).finish()
                        });
                    events.push(Meeting {
                        node,
                        p,
                        on_lower: (node != s.a && node != s.b).then(|| (k, param(w[0], w[1], p))),
                        on_upper: (node != t.a && node != t.b)
                            .then(|| (t.id, o.k, param(o.a, o.b, p))),
                    });
                }
            }
        }
    }
    Meetings { events, overlap }
}

/// Builds the shared graph of `a` (lower) and `b` (upper).
pub fn shared(a: &Layout, b: &Layout) -> Shared {
    shared_graph(a, b, true)
}

/// [`shared`], its layout's isolated nodes left in when `tidy` is false
/// (a merge drops them from its result anyway, after leaving pieces out).
pub(crate) fn shared_graph(a: &Layout, b: &Layout, tidy: bool) -> Shared {
    let mut sh = Shared::default();
    let mut base = Layout::default();
    // Looked up only (never walked): hash maps.
    let mut at: crate::id::IdMap<(u64, u64), Id> = crate::id::IdMap::with_capacity_and_hasher(
        a.nodes.len() + b.nodes.len(),
        Default::default(),
    );
    for n in b.nodes.values() {
        base.nodes.insert(n.id, n.clone());
        at.insert(bits(n.pos), n.id);
    }
    let mut node_map: crate::id::IdMap<Id, Id> =
        crate::id::IdMap::with_capacity_and_hasher(a.nodes.len(), Default::default());
    for n in a.nodes.values() {
        if let Some(&id) = at.get(&bits(n.pos)) {
            node_map.insert(n.id, id);
            continue;
        }
        let mut id = n.id;
        if base.nodes.contains_key(&id) {
            id = Id::mint("under").id(n.id).finish();
            sh.renamed.insert(n.id, id);
        }
        let mut m = n.clone();
        m.id = id;
        base.nodes.insert(id, m);
        at.insert(bits(n.pos), id);
        node_map.insert(n.id, id);
    }
    let mut streets: Vec<(Side, Street)> =
        b.streets.values().map(|s| (Side::B, s.clone())).collect();
    for s in a.streets.values() {
        let mut t = s.clone();
        t.a = node_map.get(&s.a).copied().unwrap_or(s.a);
        t.b = node_map.get(&s.b).copied().unwrap_or(s.b);
        if b.streets.contains_key(&t.id) {
            let same = b.streets.get(&t.id).is_some_and(|u| {
                (u.a == t.a && u.b == t.b && u.interior == t.interior)
                    || (u.a == t.b && u.b == t.a && u.interior.iter().rev().eq(t.interior.iter()))
            });
            if same {
                sh.coincident.push(s.id);
                continue;
            }
            let id = Id::mint("under").id(s.id).finish();
            sh.renamed.insert(s.id, id);
            t.id = id;
        }
        streets.push((Side::A, t));
    }
    // Each street's polyline (read once: the nodes added below are new
    // places, the streets' ends keep theirs).
    let polys: Vec<Option<Vec<Coord>>> = streets.iter().map(|(_, s)| poly_of(&base, s)).collect();
    // The upper streets by identity, and their segments' index.
    let upper: crate::id::IdMap<Id, &Street> = streets
        .iter()
        .filter(|(side, _)| *side == Side::B)
        .map(|(_, s)| (s.id, s))
        .collect();
    let useg = {
        let mut v = Vec::new();
        for ((side, s), pl) in streets.iter().zip(&polys) {
            if *side != Side::B {
                continue;
            }
            if let Some(pl) = pl {
                for (k, w) in pl.windows(2).enumerate() {
                    v.push(index::Seg {
                        street: s.id,
                        k,
                        a: w[0],
                        b: w[1],
                    });
                }
            }
        }
        rstar::RTree::bulk_load(v)
    };
    // Cuts per street: (segment, parameter, node).
    let mut cuts: crate::id::IdMap<(Side, Id), Vec<Cut>> = crate::id::IdMap::default();
    let mut drop_a: BTreeSet<Id> = BTreeSet::new();
    let mut new_nodes: BTreeMap<Id, Coord> = BTreeMap::new();
    for ((side, s), pl) in streets.iter().zip(&polys) {
        if *side != Side::A {
            continue;
        }
        let Some(pl) = pl else { continue };
        let rec = meetings(s, pl, &useg, &upper, &base);
        for ev in &rec.events {
            if !base.nodes.contains_key(&ev.node) {
                new_nodes.insert(ev.node, ev.p);
            }
            if let Some((k, t)) = ev.on_lower {
                cuts.entry((Side::A, s.id))
                    .or_default()
                    .push((k, t, ev.node));
            }
            if let Some((street, k, t)) = ev.on_upper {
                cuts.entry((Side::B, street))
                    .or_default()
                    .push((k, t, ev.node));
            }
            sh.crossings.insert(ev.node);
        }
        if rec.overlap {
            drop_a.insert(s.id);
        }
    }
    drop(upper);
    for id in &drop_a {
        sh.coincident.push(*id);
        cuts.remove(&(Side::A, *id));
    }
    for (id, p) in new_nodes {
        base.add_node(id, p);
    }
    let mut out = Layout {
        nodes: std::mem::take(&mut base.nodes),
        ..Layout::default()
    };
    // The pieces' end nodes with their side (a node both sides use is a
    // crossing).
    let mut ends: Vec<(Id, Side)> = Vec::new();
    let mut pieces: Vec<Street> = Vec::new();
    // Every street is kept as an original (after renaming), split or not.
    for ((side, s), pl) in streets.into_iter().zip(&polys) {
        if let Some(pl) = pl
            && !(side == Side::A && drop_a.contains(&s.id))
        {
            let mut c = cuts.remove(&(side, s.id)).unwrap_or_default();
            c.sort_by(|x, y| x.0.cmp(&y.0).then(x.1.total_cmp(&y.1)));
            c.dedup_by(|x, y| x.2 == y.2);
            sh.splits.extend(c.iter().map(|x| x.2));
            split_street(&s, pl, &c, &out.nodes, &mut pieces);
            let mut ids = Vec::with_capacity(pieces.len());
            for p in pieces.drain(..) {
                sh.origin.insert(p.id, (side, s.id));
                ends.extend([(p.a, side), (p.b, side)]);
                ids.push(p.id);
                out.streets.insert(p.id, p);
            }
            sh.pieces.insert((side, s.id), ids);
        }
        sh.originals.insert((side, s.id), s);
    }
    ends.sort_unstable();
    ends.dedup();
    for w in ends.windows(2) {
        if w[0].0 == w[1].0 {
            sh.crossings.insert(w[0].0);
        }
    }
    if tidy {
        out.drop_isolated_nodes();
    }
    sh.layout = out;
    sh
}

fn param(a: Coord, b: Coord, p: Coord) -> f64 {
    let (dx, dy) = (b.x - a.x, b.y - a.y);
    let l2 = dx * dx + dy * dy;
    if l2 == 0.0 {
        0.0
    } else {
        ((p.x - a.x) * dx + (p.y - a.y) * dy) / l2
    }
}

/// A street cut at the given (segment, parameter, node) points, in order
/// (the pieces pushed on `out`).
fn split_street(
    s: &Street,
    pl: &[Coord],
    cuts: &[(usize, f64, Id)],
    nodes: &BTreeMap<Id, crate::model::Node>,
    out: &mut Vec<Street>,
) {
    if cuts.is_empty() {
        out.push(s.clone());
        return;
    }
    let mut start = s.a;
    let mut pts: Vec<Coord> = vec![pl[0]];
    let mut ci = 0;
    // Every piece carries the whole street's identity (written once).
    let part_of = crate::model::TagValue::Text(s.id.to_string());
    let push_piece = |from: Id, to: Id, pts: &[Coord], out: &mut Vec<Street>| {
        if from == to || pts.len() < 2 {
            return;
        }
        let mut t = s.clone();
        t.id = Id::mint("piece").id(s.id).id(from).id(to).finish();
        t.tags.insert(PART_OF.to_string(), part_of.clone());
        t.a = from;
        t.b = to;
        t.interior = pts[1..pts.len() - 1].to_vec();
        out.push(t);
    };
    for k in 0..pl.len() - 1 {
        while ci < cuts.len() && cuts[ci].0 == k {
            let node = cuts[ci].2;
            let p = nodes.get(&node).map_or(pl[k], |n| n.pos);
            if pts.last() != Some(&p) {
                pts.push(p);
            }
            push_piece(start, node, &pts, out);
            start = node;
            pts = vec![p];
            ci += 1;
        }
        let q = pl[k + 1];
        if pts.last() != Some(&q) {
            pts.push(q);
        }
    }
    push_piece(start, s.b, &pts, out);
}

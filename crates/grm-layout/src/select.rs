//! Selections (4.2.2): a weight in [0, 1] per element. Simple (named
//! elements), region (inside a polygon), soft (falling off with the
//! distance from a point) and street continuation (from a street along
//! the straightest street of the same class at each end, while the turn
//! stays under a limit).

use crate::geom::{self, point_in_ring};
use crate::id::Id;
use crate::model::Layout;
use geo::Coord;
use std::collections::{BTreeMap, BTreeSet};

/// Weights per element (nodes, streets, parcels); missing means 0.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Selection {
    pub weights: BTreeMap<Id, f64>,
}

impl Selection {
    /// The elements with weight 1.
    pub fn simple(ids: impl IntoIterator<Item = Id>) -> Selection {
        Selection {
            weights: ids.into_iter().map(|i| (i, 1.0)).collect(),
        }
    }

    /// Nodes inside the ring, streets with both ends inside, parcels
    /// with every vertex inside.
    pub fn region(layout: &Layout, ring: &[Coord]) -> Selection {
        let mut w = BTreeMap::new();
        for n in layout.nodes.values() {
            if point_in_ring(n.pos, ring) {
                w.insert(n.id, 1.0);
            }
        }
        for s in layout.streets.values() {
            if w.contains_key(&s.a) && w.contains_key(&s.b) {
                w.insert(s.id, 1.0);
            }
        }
        for p in layout.parcels.values() {
            if p.ring.iter().all(|c| point_in_ring(*c, ring)) {
                w.insert(p.id, 1.0);
            }
        }
        Selection { weights: w }
    }

    /// Every element weighted by `1 - (d / radius)^2` squared (a smooth
    /// falloff to 0 at `radius`) from its representative position.
    pub fn soft(layout: &Layout, centre: Coord, radius: f64) -> Selection {
        let mut w = BTreeMap::new();
        if !(radius.is_finite() && radius > 0.0) {
            return Selection { weights: w };
        }
        let ids = layout
            .nodes
            .keys()
            .chain(layout.streets.keys())
            .chain(layout.parcels.keys());
        for &id in ids {
            if let Some(p) = layout.position_of(id) {
                let t = geom::dist(p, centre) / radius;
                if t < 1.0 {
                    let k = 1.0 - t * t;
                    w.insert(id, k * k);
                }
            }
        }
        Selection { weights: w }
    }

    /// The street and its continuation: at each end, the street of the
    /// same class that turns least, while the turn is under
    /// `max_turn_deg`, repeatedly.
    pub fn continuation(layout: &Layout, street: Id, max_turn_deg: f64) -> Selection {
        let mut chosen: BTreeSet<Id> = BTreeSet::new();
        let Some(s0) = layout.streets.get(&street) else {
            return Selection::default();
        };
        chosen.insert(street);
        let inc = layout.incidence();
        // Walk from each end: (street we came along, node we are at).
        let mut work = vec![(s0.id, s0.a), (s0.id, s0.b)];
        while let Some((from, node)) = work.pop() {
            let Some(fs) = layout.streets.get(&from) else {
                continue;
            };
            let Some(din) = direction_at(layout, fs, node, true) else {
                continue;
            };
            let mut best: Option<(f64, Id)> = None;
            for &o in inc.get(&node).map(Vec::as_slice).unwrap_or(&[]) {
                if o == from || chosen.contains(&o) {
                    continue;
                }
                let os = &layout.streets[&o];
                if os.class != fs.class {
                    continue;
                }
                let Some(dout) = direction_at(layout, os, node, false) else {
                    continue;
                };
                let turn = (din.x * dout.y - din.y * dout.x)
                    .atan2(din.x * dout.x + din.y * dout.y)
                    .abs()
                    .to_degrees();
                if turn <= max_turn_deg && best.is_none_or(|b| turn < b.0) {
                    best = Some((turn, o));
                }
            }
            if let Some((_, o)) = best {
                chosen.insert(o);
                work.push((o, layout.streets[&o].other(node)));
            }
        }
        Selection::simple(chosen)
    }

    /// Each node's weight for a transform: its own, or the largest of
    /// the selected streets at it, or of a selected parcel's block... (a
    /// parcel's weight moves nothing by itself).
    pub fn node_weights(&self, layout: &Layout) -> BTreeMap<Id, f64> {
        let mut w: BTreeMap<Id, f64> = BTreeMap::new();
        for (id, x) in &self.weights {
            if layout.nodes.contains_key(id) {
                let e = w.entry(*id).or_default();
                *e = e.max(*x);
            } else if let Some(s) = layout.streets.get(id) {
                for n in [s.a, s.b] {
                    let e = w.entry(n).or_default();
                    *e = e.max(*x);
                }
            }
        }
        w.retain(|_, x| *x > 0.0);
        w
    }

    /// The selected elements (weight above 0).
    pub fn ids(&self) -> BTreeSet<Id> {
        self.weights
            .iter()
            .filter(|(_, w)| **w > 0.0)
            .map(|(k, _)| *k)
            .collect()
    }
}

/// The unit direction of a street at one of its end nodes: travelling
/// into the node (`arriving`) or out of it.
fn direction_at(
    layout: &Layout,
    s: &crate::model::Street,
    node: Id,
    arriving: bool,
) -> Option<Coord> {
    let pl = layout.polyline(s)?;
    let n = pl.len();
    let (p, q) = if node == s.a {
        (pl[1], pl[0])
    } else {
        (pl[n - 2], pl[n - 1])
    };
    // p -> q arrives at the node.
    let (dx, dy) = if arriving {
        (q.x - p.x, q.y - p.y)
    } else {
        (p.x - q.x, p.y - q.y)
    };
    let l = dx.hypot(dy);
    (l > 0.0).then_some(Coord {
        x: dx / l,
        y: dy / l,
    })
}

//! The validity check (4.1.1): no street crosses or touches another street
//! except at a node they share, no street crosses itself, no parcel comes
//! nearer a street's centre line than half its width, no two parcels
//! overlap, every parcel is a simple polygon. Every operator runs it on
//! what it changed before it returns.

use crate::geom::{self, Meet, check_ring, point_in_ring, point_segment_dist, segment_ring_dist};
use crate::id::Id;
use crate::index::{self, Boxed, Seg, bounds, grown};
use crate::model::Layout;
use geo::Coord;
use rstar::RTree;
use std::collections::BTreeSet;

/// One way a layout is not valid.
#[derive(Debug, Clone, PartialEq)]
pub enum Violation {
    /// A street names a node the layout lacks.
    MissingNode { street: Id, node: Id },
    /// A street has no length, the same node at both ends, or a non-finite point.
    DegenerateStreet { street: Id },
    /// Two streets meet away from a node they share.
    StreetsCross { a: Id, b: Id, at: Coord },
    /// Two streets run along each other.
    StreetsOverlap { a: Id, b: Id },
    /// A street crosses itself.
    StreetSelfCrossing { street: Id },
    /// A parcel's polygon is not simple.
    BadParcel {
        parcel: Id,
        problem: geom::RingProblem,
    },
    /// A parcel comes within half a street's width of its centre line.
    ParcelOnStreet { parcel: Id, street: Id },
    /// Two parcels overlap.
    ParcelsOverlap { a: Id, b: Id },
}

impl Violation {
    /// A one-line description naming the elements.
    pub fn describe(&self) -> String {
        match self {
            Violation::MissingNode { street, node } => {
                format!("street {street} names node {node}, which is not in the layout")
            }
            Violation::DegenerateStreet { street } => format!("street {street} is degenerate"),
            Violation::StreetsCross { a, b, at } => {
                format!(
                    "streets {a} and {b} cross at ({}, {}) without a shared node",
                    at.x, at.y
                )
            }
            Violation::StreetsOverlap { a, b } => format!("streets {a} and {b} overlap"),
            Violation::StreetSelfCrossing { street } => format!("street {street} crosses itself"),
            Violation::BadParcel { parcel, problem } => {
                format!("parcel {parcel} is not a simple polygon ({problem:?})")
            }
            Violation::ParcelOnStreet { parcel, street } => {
                format!("parcel {parcel} overlaps street {street}")
            }
            Violation::ParcelsOverlap { a, b } => format!("parcels {a} and {b} overlap"),
        }
    }
}

/// Tolerance (m) by which a parcel may come nearer a street than half its width.
pub const STREET_TOLERANCE: f64 = 1e-6;

/// Depth (m) by which two parcels may overlap before it counts: the
/// clipper rounds, and a smooth transform bends an edge that has another
/// parcel's vertex in its middle by far less.
pub const OVERLAP_TOLERANCE: f64 = 1e-3;

/// Every violation in a layout.
pub fn check(layout: &Layout) -> Vec<Violation> {
    let segs = index::segments(layout);
    let mut v = check_streets(layout, &segs, None);
    v.extend(check_parcels(layout, &segs, None));
    v
}

/// Street violations; with `only`, just those involving these streets.
pub fn check_streets(
    layout: &Layout,
    segs: &RTree<Seg>,
    only: Option<&BTreeSet<Id>>,
) -> Vec<Violation> {
    let mut out = Vec::new();
    let mut reported: BTreeSet<(Id, Id)> = BTreeSet::new();
    for s in layout.streets.values() {
        if only.is_some_and(|o| !o.contains(&s.id)) {
            continue;
        }
        let mut missing = false;
        for n in [s.a, s.b] {
            if !layout.nodes.contains_key(&n) {
                out.push(Violation::MissingNode {
                    street: s.id,
                    node: n,
                });
                missing = true;
            }
        }
        if missing {
            continue;
        }
        let Some(pl) = layout.polyline(s) else {
            continue;
        };
        if s.a == s.b
            || pl.windows(2).any(|w| w[0] == w[1])
            || pl.iter().any(|c| !c.x.is_finite() || !c.y.is_finite())
            || !(s.width.is_finite() && s.width >= 0.0)
        {
            out.push(Violation::DegenerateStreet { street: s.id });
            continue;
        }
        for (k, w) in pl.windows(2).enumerate() {
            let env = rstar::AABB::from_corners([w[0].x, w[0].y], [w[1].x, w[1].y]);
            for o in segs.locate_in_envelope_intersecting(&env) {
                if o.street == s.id {
                    if o.k <= k {
                        continue;
                    }
                    let adjacent = o.k == k + 1;
                    match geom::meet(w[0], w[1], o.a, o.b) {
                        None => {}
                        Some(Meet::Point(p)) if adjacent && p == w[1] => {}
                        Some(_) if reported.insert((s.id, s.id)) => {
                            out.push(Violation::StreetSelfCrossing { street: s.id });
                        }
                        Some(_) => {}
                    }
                    continue;
                }
                let key = if s.id < o.street {
                    (s.id, o.street)
                } else {
                    (o.street, s.id)
                };
                if reported.contains(&key) {
                    continue;
                }
                let Some(t) = layout.streets.get(&o.street) else {
                    continue;
                };
                match geom::meet(w[0], w[1], o.a, o.b) {
                    None => {}
                    Some(Meet::Overlap) => {
                        reported.insert(key);
                        out.push(Violation::StreetsOverlap { a: key.0, b: key.1 });
                    }
                    Some(Meet::Point(p)) => {
                        let shared = [s.a, s.b]
                            .into_iter()
                            .filter(|n| *n == t.a || *n == t.b)
                            .any(|n| layout.nodes[&n].pos == p);
                        if !shared {
                            reported.insert(key);
                            out.push(Violation::StreetsCross {
                                a: key.0,
                                b: key.1,
                                at: p,
                            });
                        }
                    }
                }
            }
        }
    }
    out
}

/// The parcels' boxes.
pub fn parcel_boxes(layout: &Layout) -> RTree<Boxed> {
    RTree::bulk_load(
        layout
            .parcels
            .values()
            .map(|p| {
                let (min, max) = bounds(&p.ring);
                Boxed { id: p.id, min, max }
            })
            .collect(),
    )
}

/// Parcel violations; with `only`, just those involving these parcels.
pub fn check_parcels(
    layout: &Layout,
    segs: &RTree<Seg>,
    only: Option<&BTreeSet<Id>>,
) -> Vec<Violation> {
    let mut out = Vec::new();
    let max_half = layout
        .streets
        .values()
        .map(|s| s.width * 0.5)
        .fold(0.0, f64::max);
    let boxes = parcel_boxes(layout);
    for p in layout.parcels.values() {
        if only.is_some_and(|o| !o.contains(&p.id)) {
            continue;
        }
        if let Err(problem) = check_ring(&p.ring) {
            out.push(Violation::BadParcel {
                parcel: p.id,
                problem,
            });
            continue;
        }
        if let Some(s) = parcel_street_hit(layout, segs, &p.ring, max_half) {
            out.push(Violation::ParcelOnStreet {
                parcel: p.id,
                street: s,
            });
        }
        let (min, max) = bounds(&p.ring);
        for o in boxes.locate_in_envelope_intersecting(&grown(min, max, 0.0)) {
            if o.id == p.id || (only.is_none() && o.id < p.id) {
                continue;
            }
            if only.is_some_and(|s| s.contains(&o.id) && o.id < p.id) {
                continue;
            }
            let q = &layout.parcels[&o.id];
            if rings_overlap(&p.ring, &q.ring) {
                let (a, b) = if p.id < o.id {
                    (p.id, o.id)
                } else {
                    (o.id, p.id)
                };
                out.push(Violation::ParcelsOverlap { a, b });
            }
        }
    }
    out
}

/// The first street (by identity) a ring comes within half the width of.
pub fn parcel_street_hit(
    layout: &Layout,
    segs: &RTree<Seg>,
    ring: &[Coord],
    max_half: f64,
) -> Option<Id> {
    parcel_street_hit_where(layout, segs, ring, max_half, |_| true)
}

/// [`parcel_street_hit`] among the streets `keep` accepts.
pub fn parcel_street_hit_where(
    layout: &Layout,
    segs: &RTree<Seg>,
    ring: &[Coord],
    max_half: f64,
    keep: impl Fn(Id) -> bool,
) -> Option<Id> {
    let (min, max) = bounds(ring);
    let mut hits: Vec<Id> = Vec::new();
    for sg in segs.locate_in_envelope_intersecting(&grown(min, max, max_half)) {
        if !keep(sg.street) {
            continue;
        }
        if segment_hits_ring(layout, sg.street, sg.a, sg.b, ring, min, max) {
            hits.push(sg.street);
        }
    }
    hits.into_iter().min()
}

/// Whether a segment of a street comes within the street's half width
/// (less the tolerance) of a ring whose bounds are `min`, `max`: the test
/// [`parcel_street_hit_where`] makes of each segment near the ring.
fn segment_hits_ring(
    layout: &Layout,
    street: Id,
    a: Coord,
    b: Coord,
    ring: &[Coord],
    min: [f64; 2],
    max: [f64; 2],
) -> bool {
    let Some(st) = layout.streets.get(&street) else {
        return false;
    };
    let half = st.width * 0.5 - STREET_TOLERANCE;
    let (smin, smax) = bounds(&[a, b]);
    if smin[0] - half > max[0]
        || smax[0] + half < min[0]
        || smin[1] - half > max[1]
        || smax[1] + half < min[1]
    {
        return false;
    }
    segment_ring_dist(a, b, ring) < half
}

/// Whether a street (its polyline `pl`) comes within its half width of a
/// ring (bounds `min`, `max`): [`parcel_street_hit_where`]'s test over the
/// street's segments (its segments far from the ring, which an index
/// would not return, fail the test too).
pub fn street_hits_ring(
    layout: &Layout,
    street: Id,
    pl: &[Coord],
    ring: &[Coord],
    min: [f64; 2],
    max: [f64; 2],
) -> bool {
    pl.windows(2)
        .any(|w| segment_hits_ring(layout, street, w[0], w[1], ring, min, max))
}

/// Whether segments p-q and r-s cross with each end more than `eps` off
/// the other's line (a crossing the clipper's rounding cannot explain).
fn crosses_clearly(p: Coord, q: Coord, r: Coord, s: Coord, eps: f64) -> bool {
    let side = |a: Coord, b: Coord, c: Coord| {
        let l = geom::dist(a, b);
        if l == 0.0 {
            return 0.0;
        }
        ((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x)) / l
    };
    let (d1, d2) = (side(r, s, p), side(r, s, q));
    let (d3, d4) = (side(p, q, r), side(p, q, s));
    ((d1 > eps && d2 < -eps) || (d1 < -eps && d2 > eps))
        && ((d3 > eps && d4 < -eps) || (d3 < -eps && d4 > eps))
}

/// A point strictly inside a ring, away from its boundary by more than `eps`.
fn strictly_inside(p: Coord, ring: &[Coord], eps: f64) -> bool {
    if !point_in_ring(p, ring) {
        return false;
    }
    let n = ring.len();
    (0..n).all(|i| point_segment_dist(p, ring[i], ring[(i + 1) % n]) > eps)
}

/// Whether the interiors of two simple rings overlap: an edge of one
/// properly crosses an edge of the other, or a vertex, an edge midpoint or
/// an inner point of one lies strictly inside the other.
pub fn rings_overlap(a: &[Coord], b: &[Coord]) -> bool {
    let (amin, amax) = bounds(a);
    let (bmin, bmax) = bounds(b);
    if amax[0] <= bmin[0] || bmax[0] <= amin[0] || amax[1] <= bmin[1] || bmax[1] <= amin[1] {
        return false;
    }
    let eps = OVERLAP_TOLERANCE;
    let na = a.len();
    let nb = b.len();
    for i in 0..na {
        let (p, q) = (a[i], a[(i + 1) % na]);
        for j in 0..nb {
            let (r, s) = (b[j], b[(j + 1) % nb]);
            if crosses_clearly(p, q, r, s, eps) {
                return true;
            }
        }
    }
    let probes = |x: &[Coord], y: &[Coord]| {
        let n = x.len();
        (0..n).any(|i| {
            let m = geom::lerp(x[i], x[(i + 1) % n], 0.5);
            strictly_inside(x[i], y, eps) || strictly_inside(m, y, eps)
        }) || inner_point(x).is_some_and(|c| strictly_inside(c, y, eps))
    };
    probes(a, b) || probes(b, a)
}

/// A point inside a simple ring (the centroid of an ear-ish triangle: the
/// vertex centroid when inside, else the midpoint of the first inside
/// diagonal-probe).
pub fn inner_point(ring: &[Coord]) -> Option<Coord> {
    let c = geom::vertex_centroid(ring);
    if point_in_ring(c, ring) {
        return Some(c);
    }
    let n = ring.len();
    for i in 0..n {
        let t = geom::vertex_centroid(&[ring[(i + n - 1) % n], ring[i], ring[(i + 1) % n]]);
        if point_in_ring(t, ring) {
            return Some(t);
        }
    }
    None
}

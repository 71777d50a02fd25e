//! Context queries (`overlaps`, `touches`, `inside` a symbol's shapes):
//! the first pass's shapes of each queried symbol, as oriented boxes in an
//! R-tree (docs/shapes.md, "Context queries").
//!
//! A shape's box is its scope (the oriented box it was made with, or for a
//! shape whose rule made nothing the one its rule left), not its
//! exact geometry: a prism's footprint and a polygon's outline are
//! answered by their scope's box. Boxes are compared with the separating
//! axis test on the 15 axes of two oriented boxes, with a tolerance of
//! [`TOLERANCE`] world units, so that shapes laid side by side by a split
//! touch and do not overlap.

use crate::expr::Query;
use crate::ir::{Program, SymbolId};
use crate::scope::Scope;
use crate::tree::{Node, NodeKind};
use glam::Vec3;
use rstar::primitives::{GeomWithData, Rectangle};
use rstar::{AABB, RTree};

/// How far apart (world units) two boundaries may be and still meet, and
/// how deep boxes must go into each other to overlap.
pub const TOLERANCE: f32 = 1e-4;

type Entry = GeomWithData<Rectangle<[f32; 3]>, u32>;

/// One indexed shape of the first pass.
#[derive(Clone, Copy, Debug)]
struct Target {
    scope: Scope,
    key: u32,
    /// Its path keys (itself and its ancestors) in [`Queries::paths`].
    path: (u32, u32),
}

/// The first pass's shapes of every queried symbol.
#[derive(Debug)]
pub(crate) struct Queries {
    trees: Vec<(SymbolId, RTree<Entry>)>,
    targets: Vec<Target>,
    paths: Vec<u32>,
}

/// A scope's world-space axis-aligned bounds, `None` if not finite.
fn bounds(s: &Scope) -> Option<([f32; 3], [f32; 3])> {
    let c = s.corners();
    let mut lo = c[0];
    let mut hi = c[0];
    for p in &c[1..] {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    (lo.is_finite() && hi.is_finite()).then(|| (lo.to_array(), hi.to_array()))
}

impl Queries {
    /// Index the shapes of the queried symbols among `nodes` (a derived
    /// tree's nodes, parents before children).
    pub fn build(program: &Program, nodes: &[Node]) -> Queries {
        let queried = &program.exprs.uses.queried;
        let mut per: Vec<Vec<Entry>> = queried.iter().map(|_| Vec::new()).collect();
        let mut targets = Vec::new();
        let mut paths = Vec::new();
        for (i, n) in nodes.iter().enumerate() {
            let NodeKind::Shape { symbol, .. } = n.kind else {
                continue;
            };
            let Ok(q) = queried.binary_search(&symbol) else {
                continue;
            };
            let Some((lo, hi)) = bounds(&n.scope) else {
                continue;
            };
            let start = paths.len() as u32;
            let mut j = i;
            loop {
                paths.push(nodes[j].key);
                let up = nodes[j].parent_offset as usize;
                if j == 0 || up == 0 || up > j {
                    break;
                }
                j -= up;
            }
            let t = targets.len() as u32;
            targets.push(Target {
                scope: n.scope,
                key: n.key,
                path: (start, paths.len() as u32),
            });
            per[q].push(GeomWithData::new(Rectangle::from_corners(lo, hi), t));
        }
        Queries {
            trees: queried
                .iter()
                .zip(per)
                .map(|(s, v)| (*s, RTree::bulk_load(v)))
                .collect(),
            targets,
            paths,
        }
    }

    /// Whether `scope` (of the shape whose path keys, itself first, are
    /// `path`) stands in relation `q` to some indexed shape of `symbol`
    /// other than itself, its ancestors and its descendants.
    pub fn ask(&self, q: Query, symbol: SymbolId, scope: &Scope, path: &[u32]) -> bool {
        let Some((_, tree)) = self.trees.iter().find(|(s, _)| *s == symbol) else {
            return false;
        };
        let Some((lo, hi)) = bounds(scope) else {
            return false;
        };
        let t = TOLERANCE;
        let env = AABB::from_corners(
            [lo[0] - t, lo[1] - t, lo[2] - t],
            [hi[0] + t, hi[1] + t, hi[2] + t],
        );
        let me = path.first().copied();
        tree.locate_in_envelope_intersecting(&env).any(|e| {
            let Some(target) = self.targets.get(e.data as usize) else {
                return false;
            };
            let their_path = self
                .paths
                .get(target.path.0 as usize..target.path.1 as usize)
                .unwrap_or(&[]);
            let related = path.contains(&target.key) || me.is_some_and(|k| their_path.contains(&k));
            !related && relation(q, scope, &target.scope)
        })
    }
}

/// The centre, half-extents and axes of a scope.
fn frame(s: &Scope) -> (Vec3, [Vec3; 3], Vec3) {
    let m = s.axes();
    let half = s.size * 0.5;
    (s.world(half), [m.x_axis, m.y_axis, m.z_axis], half)
}

/// Whether `a` stands in relation `q` to `b`.
pub(crate) fn relation(q: Query, a: &Scope, b: &Scope) -> bool {
    match q {
        Query::Inside => inside(a, b),
        Query::Overlaps => meet(a, b) == Some(true),
        Query::Touches => meet(a, b) == Some(false),
    }
}

/// Every corner of `a` within `b` (grown by the tolerance).
fn inside(a: &Scope, b: &Scope) -> bool {
    let m = b.axes();
    let axes = [m.x_axis, m.y_axis, m.z_axis];
    a.corners().iter().all(|p| {
        let d = *p - b.origin;
        (0..3).all(|i| {
            let x = d.dot(axes[i]);
            x >= -TOLERANCE && x <= b.size[i] + TOLERANCE
        })
    })
}

/// `None` if the boxes are apart (a gap wider than the tolerance along
/// some separating axis); `Some(true)` if they overlap: on every axis
/// along which both have extent, they go into each other deeper than the
/// tolerance (so two flat faces in one plane overlap where they share
/// area, and a face against a box's side overlaps it where they share
/// area); `Some(false)` if they meet on boundaries only.
fn meet(a: &Scope, b: &Scope) -> Option<bool> {
    let (ca, aa, ha) = frame(a);
    let (cb, ab, hb) = frame(b);
    let mut axes = [Vec3::ZERO; 15];
    axes[..3].copy_from_slice(&aa);
    axes[3..6].copy_from_slice(&ab);
    let mut len = 6;
    for u in aa {
        for v in ab {
            let c = u.cross(v);
            if c.length_squared() > 1e-8 {
                axes[len] = c.normalize();
                len += 1;
            }
        }
    }
    let mut overlap = true;
    for &n in &axes[..len] {
        let ra: f32 = (0..3).map(|i| (aa[i].dot(n) * ha[i]).abs()).sum();
        let rb: f32 = (0..3).map(|i| (ab[i].dot(n) * hb[i]).abs()).sum();
        let d = (ca - cb).dot(n).abs();
        let depth = ra + rb - d;
        if depth < -TOLERANCE {
            return None;
        }
        if ra > TOLERANCE && rb > TOLERANCE && depth <= TOLERANCE {
            overlap = false;
        }
    }
    Some(overlap)
}

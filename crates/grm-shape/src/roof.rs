//! Roofs and taper: a solid of planar faces over a footprint outline.
//!
//! Sloped roofs stand on the footprint's **weighted straight skeleton**:
//! every edge of the outline moves inward, parallel to itself, at its
//! weight (1 for a slope, 0 for a vertical gable end) while the time `t`
//! runs; the face of an edge is the region it sweeps, lifted to height
//! `t * tan(angle)`. So every sloped face rises from its eave at the
//! roof's angle, and faces meet in ridges, hips and valleys
//! (docs/shapes.md, "Roofs and taper").
//!
//! The skeleton is computed by simulating the wavefront (edge events: an
//! edge shrinks to nothing and its neighbours meet; split events: a reflex
//! vertex runs into an edge and cuts the wavefront in two; a vertex event,
//! two reflex vertices meeting, is a split at an edge's end followed by an
//! edge event). Each step finds the earliest event over the whole
//! wavefront, so the work is bounded: at most [`MAX_VERTICES`] footprint
//! vertices, a fixed number of steps per vertex, `O(n * r)` per step.
//! Nothing here panics; what cannot be built is a typed [`RoofError`].
//!
//! Coordinates are `f64` in the outline's local frame; a roof's points have
//! z = 0 at its eaves (an overhang lowers the eaves: [`build`]).

use crate::geometry::{Geom, Outline};
use crate::scope::Scope;
use geo::{Coord, LineString, MultiPolygon, Polygon};
use glam::Vec3;
use std::fmt;
use std::sync::Arc;

mod skeleton;

pub use skeleton::{Skeleton, skeleton};

/// What kind of roof: the language's word (`grm_sema::shape::vocab`).
pub use grm_sema::shape::RoofKind;

/// The most footprint vertices a roof is built on (per polygon).
pub const MAX_VERTICES: usize = 256;

/// Why a roof (or a taper) cannot be built on an outline.
#[derive(Clone, Debug, PartialEq)]
pub enum RoofError {
    /// The footprint has a hole (a courtyard): not supported.
    Holes,
    /// The footprint has no area (or no finite size).
    Empty,
    /// A footprint polygon has more than [`MAX_VERTICES`] corners.
    TooManyVertices { count: usize, max: usize },
    /// The angle (degrees) is not in `[0, 90)`.
    BadAngle(f64),
    /// The overhang (or taper height) is not finite, or the outline offset
    /// by it is not a simple polygon any more (a notch narrower than twice
    /// the overhang).
    BadOverhang(f64),
    /// A pyramid or taper over a footprint that is not star-shaped from its
    /// centroid (the faces would overlap).
    NotStarShaped,
    /// The skeleton of this footprint could not be completed (a degenerate
    /// or self-touching outline).
    Degenerate,
}

impl fmt::Display for RoofError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RoofError::Holes => write!(f, "a roof over a footprint with holes is not supported"),
            RoofError::Empty => write!(f, "the footprint has no area"),
            RoofError::TooManyVertices { count, max } => write!(
                f,
                "the footprint has {count} corners, more than the {max} a roof is built on"
            ),
            RoofError::BadAngle(a) => {
                write!(f, "the roof angle is {a} degrees, not in [0, 90)")
            }
            RoofError::BadOverhang(d) => write!(
                f,
                "the footprint offset by the overhang {d} is not a simple polygon"
            ),
            RoofError::NotStarShaped => write!(
                f,
                "the footprint is not star-shaped from its centroid, so a pyramid or taper over it would overlap itself"
            ),
            RoofError::Degenerate => {
                write!(f, "the footprint's straight skeleton could not be built")
            }
        }
    }
}

impl std::error::Error for RoofError {}

/// What a roof face is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FaceKind {
    /// A sloped face rising from an eave.
    Slope,
    /// A vertical face over a gable edge (and a shed's other edges).
    Gable,
    /// A flat roof's top face.
    Flat,
    /// The underside: the footprint (offset by the overhang) seen from below.
    Bottom,
}

/// One planar face: its kind and its corners (indices into
/// [`Roof::points`]), counter-clockwise seen from outside the solid.
#[derive(Clone, Debug, PartialEq)]
pub struct RoofFace {
    pub kind: FaceKind,
    pub vertices: Vec<u32>,
}

/// A roof (or a tapered solid): planar faces sharing a table of points.
/// Sloped and gable faces come in footprint edge order (each ring from its
/// vertex of least (y, x), counter-clockwise), the face of an edge starting
/// with that edge; the bottom comes last.
#[derive(Clone, Debug, PartialEq)]
pub struct Roof {
    kind: RoofKind,
    points: Vec<[f64; 3]>,
    faces: Vec<RoofFace>,
}

impl Roof {
    /// The kind it was built as (a taper is a [`RoofKind::Pyramid`]).
    pub fn kind(&self) -> RoofKind {
        self.kind
    }

    /// The points.
    pub fn points(&self) -> &[[f64; 3]] {
        &self.points
    }

    /// The faces.
    pub fn faces(&self) -> &[RoofFace] {
        &self.faces
    }

    /// A face's corners as points.
    pub fn face_points(&self, face: &RoofFace) -> Vec<[f64; 3]> {
        face.vertices
            .iter()
            .filter_map(|&i| self.points.get(i as usize).copied())
            .collect()
    }

    /// The bounding box `(min, max)` (zeros when empty).
    pub fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in &self.points {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        if self.points.is_empty() {
            ([0.0; 3], [0.0; 3])
        } else {
            (lo, hi)
        }
    }

    /// Moved by `d`.
    pub fn translated(&self, d: [f64; 3]) -> Roof {
        self.mapped(|p| [p[0] + d[0], p[1] + d[1], p[2] + d[2]])
    }

    /// Scaled by `f` about the origin (planar faces stay planar).
    pub fn scaled(&self, f: [f64; 3]) -> Roof {
        self.mapped(|p| [p[0] * f[0], p[1] * f[1], p[2] * f[2]])
    }

    fn mapped(&self, m: impl Fn([f64; 3]) -> [f64; 3]) -> Roof {
        Roof {
            kind: self.kind,
            points: self.points.iter().map(|&p| m(p)).collect(),
            faces: self.faces.clone(),
        }
    }

    /// The area of the footprint it covers (its faces projected on xy, the
    /// bottom left out).
    pub fn footprint_area(&self) -> f64 {
        self.faces
            .iter()
            .filter(|f| f.kind != FaceKind::Bottom)
            .map(|f| shoelace_xy(&self.face_points(f)))
            .sum()
    }

    /// The volume between the faces and the eave plane z = 0: each face's
    /// projected area times its height at the projection's centroid (the
    /// mean of a plane over a polygon).
    pub fn volume(&self) -> f64 {
        self.faces
            .iter()
            .filter(|f| matches!(f.kind, FaceKind::Slope | FaceKind::Flat))
            .map(|f| {
                let pts = self.face_points(f);
                let (a, c) = centroid_xy(&pts);
                if a.abs() <= 0.0 {
                    return 0.0;
                }
                a * plane_z(&pts, c).unwrap_or(0.0)
            })
            .sum()
    }

    /// The total area of the faces of `kind`, in 3D.
    pub fn face_area(&self, kind: FaceKind) -> f64 {
        self.faces
            .iter()
            .filter(|f| f.kind == kind)
            .map(|f| norm(newell(&self.face_points(f))) * 0.5)
            .sum()
    }
}

/// The signed area of the polygon's projection on xy.
fn shoelace_xy(p: &[[f64; 3]]) -> f64 {
    let n = p.len();
    (0..n)
        .map(|i| {
            let (a, b) = (p[i], p[(i + 1) % n]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum::<f64>()
        * 0.5
}

/// The signed projected area and the projection's centroid.
fn centroid_xy(p: &[[f64; 3]]) -> (f64, [f64; 2]) {
    let n = p.len();
    let (mut a, mut cx, mut cy) = (0.0, 0.0, 0.0);
    for i in 0..n {
        let (u, v) = (p[i], p[(i + 1) % n]);
        let c = u[0] * v[1] - v[0] * u[1];
        a += c;
        cx += (u[0] + v[0]) * c;
        cy += (u[1] + v[1]) * c;
    }
    if a.abs() <= f64::MIN_POSITIVE {
        return (0.0, [0.0, 0.0]);
    }
    (a * 0.5, [cx / (3.0 * a), cy / (3.0 * a)])
}

/// The height at `c` of the plane through the polygon (`None`: vertical).
fn plane_z(p: &[[f64; 3]], c: [f64; 2]) -> Option<f64> {
    let n = newell(p);
    let q = p.first()?;
    if n[2].abs() <= 1e-12 * norm(n) {
        return None;
    }
    Some(q[2] - (n[0] * (c[0] - q[0]) + n[1] * (c[1] - q[1])) / n[2])
}

/// Newell's normal: twice the area vector of a planar polygon.
pub(crate) fn newell(p: &[[f64; 3]]) -> [f64; 3] {
    let n = p.len();
    let mut out = [0.0; 3];
    for i in 0..n {
        let (u, v) = (p[i], p[(i + 1) % n]);
        out[0] += (u[1] - v[1]) * (u[2] + v[2]);
        out[1] += (u[2] - v[2]) * (u[0] + v[0]);
        out[2] += (u[0] - v[0]) * (u[1] + v[1]);
    }
    out
}

fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

fn sub2(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] - b[0], a[1] - b[1]]
}

fn dot2(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

fn cross2(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

fn ring_area(r: &[[f64; 2]]) -> f64 {
    let n = r.len();
    (0..n).map(|i| cross2(r[i], r[(i + 1) % n])).sum::<f64>() * 0.5
}

// ---------------------------------------------------------------------------
// The weighted straight skeleton.

/// Which edges of a ring a gable roof makes vertical gable ends: an edge
/// whose two corners are both convex and turn by 90 degrees (within 10), and
/// which is no longer than either neighbour; when it is exactly as long as
/// a neighbour (a square), only if it faces left or right (its outward
/// normal is more along x than y), so that a square's ridge runs along x.
pub fn gable_edges(ring: &[[f64; 2]]) -> Vec<bool> {
    let n = ring.len();
    let dir = |i: usize| {
        let d = sub2(ring[(i + 1) % n], ring[i % n]);
        let l = d[0].hypot(d[1]);
        (
            if l > 0.0 {
                [d[0] / l, d[1] / l]
            } else {
                [0.0, 0.0]
            },
            l,
        )
    };
    let tol = (10f64).to_radians().sin();
    (0..n)
        .map(|i| {
            let (d, len) = dir(i);
            let (dp, lp) = dir(i + n - 1);
            let (dn, ln) = dir(i + 1);
            // A left turn of about 90 degrees at both corners.
            let square = |a: [f64; 2], b: [f64; 2]| cross2(a, b) > 0.0 && dot2(a, b).abs() < tol;
            if !(square(dp, d) && square(d, dn)) {
                return false;
            }
            let same = |a: f64, b: f64| (a - b).abs() <= 1e-6 * a.max(b);
            let shorter = |o: f64| len < o && !same(len, o);
            let tie_ok = d[1].abs() > d[0].abs(); // the edge runs along y: faces +-x
            (shorter(lp) || (same(len, lp) && tie_ok)) && (shorter(ln) || (same(len, ln) && tie_ok))
        })
        .collect()
}

/// The index of a ring's front edge: its outward normal points most along
/// -y (the first such edge on a tie).
pub fn front_edge(ring: &[[f64; 2]]) -> usize {
    let n = ring.len();
    let mut best = (f64::INFINITY, 0);
    for i in 0..n {
        let d = sub2(ring[(i + 1) % n], ring[i]);
        let l = d[0].hypot(d[1]);
        if l > 0.0 {
            // Outward normal of a counter-clockwise ring: (dy, -dx) / l.
            let ny = -d[0] / l;
            if ny < best.0 - 1e-9 {
                best = (ny, i);
            }
        }
    }
    best.1
}

/// The ring offset outward by `d` (negative: inward) with mitred corners,
/// or `None` when the result is not a simple counter-clockwise polygon.
pub fn offset_ring(ring: &[[f64; 2]], d: f64) -> Option<Vec<[f64; 2]>> {
    let n = ring.len();
    if d == 0.0 {
        return Some(ring.to_vec());
    }
    if n < 3 || !d.is_finite() {
        return None;
    }
    let mut lines = Vec::with_capacity(n);
    for i in 0..n {
        let e = sub2(ring[(i + 1) % n], ring[i]);
        let l = e[0].hypot(e[1]);
        if l.is_nan() || l <= 0.0 {
            return None;
        }
        let dir = [e[0] / l, e[1] / l];
        let out = [dir[1], -dir[0]];
        lines.push(([ring[i][0] + out[0] * d, ring[i][1] + out[1] * d], dir));
    }
    let mut pts = Vec::with_capacity(n);
    for i in 0..n {
        let (p, u) = lines[(i + n - 1) % n];
        let (q, v) = lines[i];
        let det = cross2(u, v);
        if det.abs() < 1e-12 {
            return None;
        }
        let s = cross2(sub2(q, p), v) / det;
        let x = [p[0] + u[0] * s, p[1] + u[1] * s];
        if !(x[0].is_finite() && x[1].is_finite()) {
            return None;
        }
        pts.push(x);
    }
    // Each edge keeps its direction and the ring stays simple.
    for i in 0..n {
        let e = sub2(pts[(i + 1) % n], pts[i]);
        if dot2(e, lines[i].1) <= 0.0 {
            return None;
        }
    }
    if ring_area(&pts) <= 0.0 || !simple(&pts) {
        return None;
    }
    Some(pts)
}

/// No two edges of the ring cross or touch, but neighbours at their
/// shared corner.
fn simple(r: &[[f64; 2]]) -> bool {
    let n = r.len();
    let orient = |a: [f64; 2], b: [f64; 2], c: [f64; 2]| cross2(sub2(b, a), sub2(c, a));
    for i in 0..n {
        let (a, b) = (r[i], r[(i + 1) % n]);
        for j in i + 1..n {
            if j == i + 1 || (i == 0 && j == n - 1) {
                continue;
            }
            let (c, d) = (r[j], r[(j + 1) % n]);
            let (o1, o2) = (orient(a, b, c), orient(a, b, d));
            let (o3, o4) = (orient(c, d, a), orient(c, d, b));
            if o1 * o2 <= 0.0 && o3 * o4 <= 0.0 {
                return false;
            }
        }
    }
    true
}

/// The rings of an outline's polygons, each canonical (straight corners
/// and repeated points dropped, from its vertex of least (y, x)); an error
/// for holes or no area.
fn exteriors(outline: &Outline) -> Result<Vec<Vec<[f64; 2]>>, RoofError> {
    let scale = outline
        .bounds()
        .map_or(0.0, |(lo, hi)| (hi[0] - lo[0]).max(hi[1] - lo[1]));
    if !(scale > 0.0 && scale.is_finite()) {
        return Err(RoofError::Empty);
    }
    let mut out = Vec::new();
    for p in &outline.polygons().0 {
        if !p.interiors().is_empty() {
            return Err(RoofError::Holes);
        }
        let mut ring: Vec<[f64; 2]> = p.exterior().coords().map(|c| [c.x, c.y]).collect();
        if ring.len() > 1 && ring.first() == ring.last() {
            ring.pop();
        }
        let ring = crate::component::canonical(ring, scale.max(1.0));
        if ring.len() >= 3 && ring_area(&ring) > 0.0 {
            out.push(ring);
        }
    }
    if out.is_empty() {
        return Err(RoofError::Empty);
    }
    Ok(out)
}

/// Builds faces into one point table.
struct Builder {
    points: Vec<[f64; 3]>,
    faces: Vec<RoofFace>,
}

impl Builder {
    fn point(&mut self, p: [f64; 3]) -> u32 {
        self.points.push(p);
        self.points.len() as u32 - 1
    }

    fn face(&mut self, kind: FaceKind, vertices: Vec<u32>) {
        if vertices.len() >= 3 {
            self.faces.push(RoofFace { kind, vertices });
        }
    }
}

/// A roof of `kind` over `outline` (its local xy): the angle in degrees
/// (ignored by a flat roof), the overhang `d` (the outline is offset
/// outward by `d` with mitred corners before the roof is built on it, and
/// the whole roof is lowered by `d * tan(angle)`, so sloped faces still
/// pass through the footprint's edges at height 0). The result has its
/// eaves at z = -d * tan(angle) (0 without overhang); each polygon of the
/// outline gets its own roof.
pub fn build(
    outline: &Outline,
    kind: RoofKind,
    angle: f64,
    overhang: f64,
) -> Result<Roof, RoofError> {
    if !(angle.is_finite() && (0.0..90.0).contains(&angle)) {
        return Err(RoofError::BadAngle(angle));
    }
    if !overhang.is_finite() {
        return Err(RoofError::BadOverhang(overhang));
    }
    let slope = if kind == RoofKind::Flat {
        0.0
    } else {
        angle.to_radians().tan()
    };
    let drop = overhang * slope;
    let mut b = Builder {
        points: Vec::new(),
        faces: Vec::new(),
    };
    let mut bottoms = Vec::new();
    for ring in exteriors(outline)? {
        if ring.len() > MAX_VERTICES {
            return Err(RoofError::TooManyVertices {
                count: ring.len(),
                max: MAX_VERTICES,
            });
        }
        let ring = offset_ring(&ring, overhang).ok_or(RoofError::BadOverhang(overhang))?;
        let base: Vec<u32> = match kind {
            RoofKind::Flat => {
                let ids: Vec<u32> = ring.iter().map(|p| b.point([p[0], p[1], 0.0])).collect();
                b.face(FaceKind::Flat, ids.clone());
                continue;
            }
            RoofKind::Pyramid => {
                let c = centroid_xy(&ring.iter().map(|p| [p[0], p[1], 0.0]).collect::<Vec<_>>()).1;
                let nearest = nearest_line(&ring, c);
                pyramid(&mut b, &ring, c, nearest * slope)?
            }
            RoofKind::Hip | RoofKind::Gable | RoofKind::Shed => {
                let weights: Vec<f64> = match kind {
                    RoofKind::Gable => gable_edges(&ring)
                        .into_iter()
                        .map(|g| if g { 0.0 } else { 1.0 })
                        .collect(),
                    RoofKind::Shed => {
                        let f = front_edge(&ring);
                        (0..ring.len())
                            .map(|i| if i == f { 1.0 } else { 0.0 })
                            .collect()
                    }
                    _ => vec![1.0; ring.len()],
                };
                let sk = skeleton(&ring, &weights)?;
                let ids: Vec<u32> = sk
                    .nodes
                    .iter()
                    .map(|p| b.point([p[0], p[1], p[2] * slope]))
                    .collect();
                for (face, &w) in sk.faces.iter().zip(&weights) {
                    let mut v: Vec<u32> = face
                        .iter()
                        .filter_map(|&k| ids.get(k as usize).copied())
                        .collect();
                    v.dedup();
                    let k = if w > 0.0 {
                        FaceKind::Slope
                    } else {
                        FaceKind::Gable
                    };
                    b.face(k, v);
                }
                ids[..ring.len()].to_vec()
            }
        };
        bottoms.push(base);
    }
    for base in bottoms {
        b.face(FaceKind::Bottom, base.into_iter().rev().collect());
    }
    let roof = Roof {
        kind,
        points: b.points,
        faces: b.faces,
    };
    Ok(if drop != 0.0 {
        roof.translated([0.0, 0.0, -drop])
    } else {
        roof
    })
}

/// The distance from `c` to the nearest edge's line.
fn nearest_line(ring: &[[f64; 2]], c: [f64; 2]) -> f64 {
    let n = ring.len();
    (0..n)
        .filter_map(|i| {
            let d = sub2(ring[(i + 1) % n], ring[i]);
            let l = d[0].hypot(d[1]);
            (l > 0.0).then(|| (cross2(d, sub2(c, ring[i])) / l).abs())
        })
        .fold(f64::INFINITY, f64::min)
}

/// A fan of triangles from each edge to the apex `c` at height `h`;
/// returns the base corners' ids.
fn pyramid(b: &mut Builder, ring: &[[f64; 2]], c: [f64; 2], h: f64) -> Result<Vec<u32>, RoofError> {
    let n = ring.len();
    let scale = ring
        .iter()
        .map(|p| (p[0] - c[0]).abs().max((p[1] - c[1]).abs()))
        .fold(0.0, f64::max);
    // Star-shaped from c: every triangle (edge, c) turns counter-clockwise.
    for i in 0..n {
        let (p, q) = (ring[i], ring[(i + 1) % n]);
        if cross2(sub2(q, p), sub2(c, p)) <= 1e-12 * scale * scale {
            return Err(RoofError::NotStarShaped);
        }
    }
    if !h.is_finite() {
        return Err(RoofError::BadOverhang(h));
    }
    let ids: Vec<u32> = ring.iter().map(|p| b.point([p[0], p[1], 0.0])).collect();
    let apex = b.point([c[0], c[1], h.max(0.0)]);
    for i in 0..n {
        b.face(FaceKind::Slope, vec![ids[i], ids[(i + 1) % n], apex]);
    }
    Ok(ids)
}

/// A taper: the outline's walls lean in to meet at height `h` over its
/// centroid (a pyramid, each polygon of the outline its own); the base at
/// z = 0.
pub fn taper(outline: &Outline, h: f64) -> Result<Roof, RoofError> {
    if !h.is_finite() {
        return Err(RoofError::BadOverhang(h));
    }
    let mut b = Builder {
        points: Vec::new(),
        faces: Vec::new(),
    };
    let mut bottoms = Vec::new();
    for ring in exteriors(outline)? {
        let c = centroid_xy(&ring.iter().map(|p| [p[0], p[1], 0.0]).collect::<Vec<_>>()).1;
        bottoms.push(pyramid(&mut b, &ring, c, h.max(0.0))?);
    }
    for base in bottoms {
        b.face(FaceKind::Bottom, base.into_iter().rev().collect());
    }
    Ok(Roof {
        kind: RoofKind::Pyramid,
        points: b.points,
        faces: b.faces,
    })
}

impl Roof {
    /// The part of the roof in the slab `lo <= p[axis] <= hi`, moved so that
    /// the slab starts at 0 (each face clipped; `None` when nothing of it is
    /// left). Points cut from an edge are computed from the edge's ends in
    /// a fixed order, so faces sharing the edge share the point.
    pub fn clipped(&self, axis: usize, lo: f64, hi: f64) -> Option<Roof> {
        if axis > 2 || !(lo.is_finite() && hi.is_finite() && lo < hi) {
            return None;
        }
        let mut table: Vec<[f64; 3]> = Vec::new();
        let mut index = std::collections::HashMap::new();
        let mut id = |p: [f64; 3]| -> u32 {
            let key = p.map(f64::to_bits);
            *index.entry(key).or_insert_with(|| {
                table.push(p);
                table.len() as u32 - 1
            })
        };
        let mut faces = Vec::new();
        for f in &self.faces {
            let mut poly = self.face_points(f);
            for (bound, keep_below) in [(lo, false), (hi, true)] {
                poly = clip_plane(&poly, axis, bound, keep_below);
                if poly.len() < 3 {
                    break;
                }
            }
            if poly.len() < 3 {
                continue;
            }
            let mut vertices: Vec<u32> = poly
                .into_iter()
                .map(|mut p| {
                    p[axis] -= lo;
                    id(p)
                })
                .collect();
            vertices.dedup();
            while vertices.len() > 1 && vertices.first() == vertices.last() {
                vertices.pop();
            }
            if vertices.len() >= 3 {
                faces.push(RoofFace {
                    kind: f.kind,
                    vertices,
                });
            }
        }
        (!faces.is_empty()).then_some(Roof {
            kind: self.kind,
            points: table,
            faces,
        })
    }
}

/// Sutherland-Hodgman: the polygon's part on one side of the plane
/// `p[axis] = bound` (below it when `keep_below`).
fn clip_plane(poly: &[[f64; 3]], axis: usize, bound: f64, keep_below: bool) -> Vec<[f64; 3]> {
    let inside = |p: &[f64; 3]| {
        if keep_below {
            p[axis] <= bound
        } else {
            p[axis] >= bound
        }
    };
    let cut = |a: [f64; 3], b: [f64; 3]| {
        // The same point whichever way round the edge is walked.
        let (a, b) = if a.map(f64::to_bits) <= b.map(f64::to_bits) {
            (a, b)
        } else {
            (b, a)
        };
        let t = (bound - a[axis]) / (b[axis] - a[axis]);
        let mut p = [0.0; 3];
        for k in 0..3 {
            p[k] = a[k] + (b[k] - a[k]) * t;
        }
        p[axis] = bound;
        p
    };
    let n = poly.len();
    let mut out = Vec::with_capacity(n + 2);
    for i in 0..n {
        let (a, b) = (poly[i], poly[(i + 1) % n]);
        match (inside(&a), inside(&b)) {
            (true, true) => out.push(b),
            (true, false) => out.push(cut(a, b)),
            (false, true) => {
                out.push(cut(a, b));
                out.push(b);
            }
            (false, false) => {}
        }
    }
    out
}

impl Roof {
    /// The footprint it stands on: its bottom faces (a flat roof's face)
    /// projected on xy, as polygons.
    pub fn base_polygons(&self) -> MultiPolygon<f64> {
        let rings = self.faces.iter().filter_map(|f| {
            let pts = self.face_points(f);
            let ring: Vec<Coord<f64>> = match f.kind {
                FaceKind::Bottom => pts
                    .iter()
                    .rev()
                    .map(|p| Coord { x: p[0], y: p[1] })
                    .collect(),
                FaceKind::Flat => pts.iter().map(|p| Coord { x: p[0], y: p[1] }).collect(),
                _ => return None,
            };
            Some(Polygon::new(LineString::new(ring), vec![]))
        });
        MultiPolygon::new(rings.collect())
    }
}

/// A roof or taper made on a shape: on a face (a rectangle or outline) it
/// stands on the face, rising along the face's z; on a mass it stands on
/// the mass's top (`on_top`; a taper replaces the mass from its bottom).
/// The new scope is the solid's bounding box, with the shape's axes; the
/// geometry holds its faces in that scope. `Err(None)`: the geometry takes
/// no roof (an edge, a roof).
pub(crate) fn on_shape(
    scope: &Scope,
    geometry: &Geom,
    on_top: bool,
    make: impl FnOnce(&Outline) -> Result<Roof, RoofError>,
) -> Result<(Scope, Geom), Option<RoofError>> {
    if matches!(geometry, Geom::Roof(_)) {
        return Err(None);
    }
    let outline = crate::component::outline_of(scope, geometry).ok_or(None)?;
    let lift = if geometry.is_mass() && on_top {
        f64::from(scope.size.z)
    } else {
        0.0
    };
    let roof = make(&outline).map_err(Some)?;
    let (lo, hi) = roof.bounds();
    if !lo
        .iter()
        .chain(&hi)
        .all(|v| v.is_finite() && v.abs() < 1e30)
    {
        return Err(Some(RoofError::Degenerate));
    }
    let roof = roof.translated([-lo[0], -lo[1], -lo[2]]);
    let footprint = roof.base_polygons();
    let size = Vec3::new(
        (hi[0] - lo[0]) as f32,
        (hi[1] - lo[1]) as f32,
        (hi[2] - lo[2]) as f32,
    );
    let origin = scope.world(Vec3::new(lo[0] as f32, lo[1] as f32, (lift + lo[2]) as f32));
    Ok((
        Scope::with_rotation(origin, scope.rotation(), size),
        Geom::Roof(Arc::new(Outline::with_roof(footprint, roof))),
    ))
}

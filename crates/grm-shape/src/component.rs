//! Component split: a mass into its faces or edges, a face into its edges,
//! each with its own scope and named by orientation (never by a raw face
//! index).
//!
//! Frames (docs/shapes.md, "Component split"):
//!
//! - a **wall** (a side face of a mass, one per straight run of its
//!   footprint's outline) has its origin at the run's start corner on the
//!   ground, x along the run, y up (the mass's z) and z its outward normal;
//!   its size is (run length, mass height, 0) and its geometry the
//!   rectangle;
//! - the **top** face is the footprint at the mass's height, axes as the
//!   mass; the **bottom** face is the footprint seen from below (x as the
//!   mass, y and z reversed, so z points down and out);
//! - an **edge** has its origin at its start, x along it and z outward
//!   (the wall's normal for a horizontal edge, the bisector of the two
//!   walls' normals for a vertical one, the in-plane normal for a face's
//!   edge); its size is (length, 0, 0).
//!
//! Orientation: a wall whose outward normal, in the mass's xy, points
//! more along -y than along x is `front`, +y `back`, -x `left`, +x `right`
//! (a tie at 45 degrees goes to front / back). Order: each ring of the
//! outline (exteriors, then their holes) from its vertex of least (y, x),
//! counter-clockwise around the solid; walls in that order, then the top,
//! then the bottom; a case's components are numbered in this order.

use crate::geometry::{Geom, Outline};
use crate::ir::{CompTarget, Selector};
use crate::roof::{FaceKind, Roof, newell};
use crate::scope::Scope;
use glam::{DVec3, Mat3, Vec3};
use std::sync::Arc;

/// Which selectors (besides `all`) take a component: a bit per
/// [`Selector`] variant.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Classes(u16);

impl Classes {
    fn bit(s: Selector) -> u16 {
        match s {
            Selector::Front => 1,
            Selector::Back => 2,
            Selector::Left => 4,
            Selector::Right => 8,
            Selector::Side => 16,
            Selector::Top => 32,
            Selector::Bottom => 64,
            Selector::All => 0,
            Selector::Slope => 128,
            Selector::Gable => 256,
            Selector::Eave => 512,
            Selector::Ridge => 1024,
            Selector::Hip => 2048,
            Selector::Valley => 4096,
            Selector::Rake => 8192,
        }
    }

    fn of(sel: &[Selector]) -> Classes {
        Classes(sel.iter().fold(0, |a, &s| a | Self::bit(s)))
    }

    /// These and `s`, if any.
    fn with(self, s: Option<Selector>) -> Classes {
        Classes(self.0 | s.map_or(0, Self::bit))
    }

    /// Whether `selector` takes this component.
    pub fn matches(self, selector: Selector) -> bool {
        selector == Selector::All || self.0 & Self::bit(selector) != 0
    }

    /// The orientation word among front / back / left / right / top / bottom.
    pub fn facing(self) -> Option<Selector> {
        [
            Selector::Front,
            Selector::Back,
            Selector::Left,
            Selector::Right,
            Selector::Top,
            Selector::Bottom,
        ]
        .into_iter()
        .find(|&s| self.0 & Self::bit(s) != 0)
    }
}

/// One component: its classes, scope and geometry.
#[derive(Clone, Debug, PartialEq)]
pub struct Component {
    pub classes: Classes,
    pub scope: Scope,
    pub geometry: Geom,
}

/// Why a component split does not apply.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NotApplicable;

/// The components of a shape, in canonical order.
pub fn components(
    scope: &Scope,
    geometry: &Geom,
    target: CompTarget,
) -> Result<Vec<Component>, NotApplicable> {
    if let Geom::Roof(o) = geometry {
        let roof = o.roof().ok_or(NotApplicable)?;
        let mut out = Vec::new();
        match target {
            CompTarget::Faces => roof_faces(scope, roof, &mut out),
            CompTarget::Edges => roof_edges(scope, roof, &mut out),
        }
        return Ok(out);
    }
    let rings = rings_of(scope, geometry).ok_or(NotApplicable)?;
    let mut out = Vec::new();
    match (target, geometry.is_mass()) {
        (CompTarget::Faces, true) => mass_faces(scope, geometry, &rings, &mut out),
        (CompTarget::Edges, true) => mass_edges(scope, &rings, &mut out),
        (CompTarget::Edges, false) => face_edges(scope, &rings, &mut out),
        (CompTarget::Faces, false) => return Err(NotApplicable),
    }
    Ok(out)
}

/// The outline's rings in canonical order (each from its least (y, x)
/// vertex, straight runs merged), or `None` for an edge.
fn rings_of(scope: &Scope, geometry: &Geom) -> Option<Vec<Vec<[f64; 2]>>> {
    let raw: Vec<Vec<[f64; 2]>> = match geometry {
        Geom::Box | Geom::Rect => {
            let (x, y) = (f64::from(scope.size.x), f64::from(scope.size.y));
            vec![vec![[0.0, 0.0], [x, 0.0], [x, y], [0.0, y]]]
        }
        Geom::Prism(o) | Geom::Polygon(o) => o.rings().collect(),
        Geom::Edge | Geom::Roof(_) => return None,
    };
    let scale = f64::from(scope.size.x.max(scope.size.y)).max(1.0);
    Some(
        raw.into_iter()
            .map(|r| canonical(r, scale))
            .filter(|r| r.len() >= 3)
            .collect(),
    )
}

pub(crate) fn canonical(ring: Vec<[f64; 2]>, scale: f64) -> Vec<[f64; 2]> {
    let tol = 1e-9 * scale * scale;
    // Merge straight runs and drop repeated points.
    let mut pts: Vec<[f64; 2]> = Vec::with_capacity(ring.len());
    for p in ring {
        if pts
            .last()
            .is_some_and(|q: &[f64; 2]| (q[0] - p[0]).abs() + (q[1] - p[1]).abs() <= 1e-12 * scale)
        {
            continue;
        }
        pts.push(p);
    }
    loop {
        let n = pts.len();
        if n < 3 {
            return pts;
        }
        let straight = (0..n).find(|&i| {
            let a = pts[(i + n - 1) % n];
            let b = pts[i];
            let c = pts[(i + 1) % n];
            let cross = (b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0]);
            let dot = (b[0] - a[0]) * (c[0] - b[0]) + (b[1] - a[1]) * (c[1] - b[1]);
            cross.abs() <= tol && dot >= 0.0
        });
        match straight {
            Some(i) => {
                pts.remove(i);
            }
            None => break,
        }
    }
    let start = (0..pts.len())
        .min_by(|&i, &j| {
            pts[i][1]
                .total_cmp(&pts[j][1])
                .then(pts[i][0].total_cmp(&pts[j][0]))
        })
        .unwrap_or(0);
    pts.rotate_left(start);
    pts
}

/// Each edge of a ring: start, unit direction, length, outward normal.
fn runs(ring: &[[f64; 2]]) -> impl Iterator<Item = ([f64; 2], Vec3, f32, Vec3)> + '_ {
    let n = ring.len();
    (0..n).filter_map(move |i| {
        let a = ring[i];
        let b = ring[(i + 1) % n];
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let len = (dx * dx + dy * dy).sqrt();
        (len > 0.0).then(|| {
            let d = Vec3::new((dx / len) as f32, (dy / len) as f32, 0.0);
            (a, d, len as f32, Vec3::new(d.y, -d.x, 0.0))
        })
    })
}

fn wall_facing(n: Vec3) -> Selector {
    if n.x.abs() > n.y.abs() {
        if n.x > 0.0 {
            Selector::Right
        } else {
            Selector::Left
        }
    } else if n.y < 0.0 {
        Selector::Front
    } else {
        Selector::Back
    }
}

fn local_frame(scope: &Scope, origin: Vec3, x: Vec3, y: Vec3, z: Vec3, size: Vec3) -> Scope {
    Scope::with_rotation(
        scope.world(origin),
        scope.rotation() * glam::Quat::from_mat3(&Mat3::from_cols(x, y, z)),
        size,
    )
}

fn mass_faces(scope: &Scope, geometry: &Geom, rings: &[Vec<[f64; 2]>], out: &mut Vec<Component>) {
    let h = scope.size.z;
    for ring in rings {
        for (a, d, len, n) in runs(ring) {
            let facing = wall_facing(n);
            out.push(Component {
                classes: Classes::of(&[facing, Selector::Side]),
                scope: local_frame(
                    scope,
                    Vec3::new(a[0] as f32, a[1] as f32, 0.0),
                    d,
                    Vec3::Z,
                    n,
                    Vec3::new(len, h, 0.0),
                ),
                geometry: Geom::Rect,
            });
        }
    }
    let flat = Vec3::new(scope.size.x, scope.size.y, 0.0);
    let (top, bottom) = match geometry {
        Geom::Prism(o) => (
            Geom::Polygon(Arc::clone(o)),
            Geom::Polygon(Arc::new(o.flipped_y(f64::from(scope.size.y)))),
        ),
        _ => (Geom::Rect, Geom::Rect),
    };
    out.push(Component {
        classes: Classes::of(&[Selector::Top]),
        scope: local_frame(
            scope,
            Vec3::new(0.0, 0.0, h),
            Vec3::X,
            Vec3::Y,
            Vec3::Z,
            flat,
        ),
        geometry: top,
    });
    out.push(Component {
        classes: Classes::of(&[Selector::Bottom]),
        scope: local_frame(
            scope,
            Vec3::new(0.0, scope.size.y, 0.0),
            Vec3::X,
            -Vec3::Y,
            -Vec3::Z,
            flat,
        ),
        geometry: bottom,
    });
}

fn mass_edges(scope: &Scope, rings: &[Vec<[f64; 2]>], out: &mut Vec<Component>) {
    let h = scope.size.z;
    for ring in rings {
        let walls: Vec<_> = runs(ring).collect();
        for (level, z) in [(Selector::Bottom, 0.0), (Selector::Top, h)] {
            for &(a, d, len, n) in &walls {
                out.push(Component {
                    classes: Classes::of(&[level, wall_facing(n)]),
                    scope: local_frame(
                        scope,
                        Vec3::new(a[0] as f32, a[1] as f32, z),
                        d,
                        Vec3::Z,
                        n,
                        Vec3::new(len, 0.0, 0.0),
                    ),
                    geometry: Geom::Edge,
                });
            }
        }
        for (i, &(a, _, _, n)) in walls.iter().enumerate() {
            let prev = walls[(i + walls.len() - 1) % walls.len()].3;
            let b = (prev + n).try_normalize().unwrap_or(n);
            out.push(Component {
                classes: Classes::of(&[Selector::Side]),
                scope: local_frame(
                    scope,
                    Vec3::new(a[0] as f32, a[1] as f32, 0.0),
                    Vec3::Z,
                    b.cross(Vec3::Z),
                    b,
                    Vec3::new(h, 0.0, 0.0),
                ),
                geometry: Geom::Edge,
            });
        }
    }
}

fn face_edges(scope: &Scope, rings: &[Vec<[f64; 2]>], out: &mut Vec<Component>) {
    for ring in rings {
        for (a, d, len, n) in runs(ring) {
            let classes = if n.x.abs() > n.y.abs() {
                Classes::of(&[
                    if n.x > 0.0 {
                        Selector::Right
                    } else {
                        Selector::Left
                    },
                    Selector::Side,
                ])
            } else {
                Classes::of(&[if n.y > 0.0 {
                    Selector::Top
                } else {
                    Selector::Bottom
                }])
            };
            out.push(Component {
                classes,
                scope: local_frame(
                    scope,
                    Vec3::new(a[0] as f32, a[1] as f32, 0.0),
                    d,
                    Vec3::Z.cross(d),
                    Vec3::Z,
                    Vec3::new(len, 0.0, 0.0),
                ),
                geometry: Geom::Edge,
            });
        }
    }
}

/// The outline of a mass's footprint or a face, for callers that want it
/// as polygons whatever the geometry (a box's or rectangle's is its
/// scope's rectangle).
pub fn outline_of(scope: &Scope, geometry: &Geom) -> Option<Outline> {
    match geometry {
        Geom::Box | Geom::Rect => Some(Outline::rect(
            f64::from(scope.size.x),
            f64::from(scope.size.y),
        )),
        Geom::Prism(o) | Geom::Polygon(o) => Some((**o).clone()),
        Geom::Edge | Geom::Roof(_) => None,
    }
}

fn v3(p: [f64; 3]) -> DVec3 {
    DVec3::new(p[0], p[1], p[2])
}

/// A frame from f64 axes (orthonormal) at the roof-local point `origin`.
fn roof_frame(scope: &Scope, origin: DVec3, x: DVec3, y: DVec3, z: DVec3, size: Vec3) -> Scope {
    local_frame(
        scope,
        origin.as_vec3(),
        x.as_vec3(),
        y.as_vec3(),
        z.as_vec3(),
        size,
    )
}

/// The facing of a horizontal direction (`None` when it has none).
fn facing_of(d: DVec3) -> Option<Selector> {
    let h = DVec3::new(d.x, d.y, 0.0);
    (h.length() > 1e-6).then(|| wall_facing(h.normalize().as_vec3()))
}

/// A roof's faces, in its order (faces by footprint edge, then the
/// bottom): a slope is `slope` and faces the way its outward normal leans;
/// a gable end `gable`, `side` and its facing; a flat roof's face `top`; the
/// underside `bottom`. A sloped or vertical face's scope has its origin at
/// a corner, x along its eave (its first edge), y up the face and z its
/// outward normal; a flat face's and the bottom's axes are as a mass's top
/// and bottom.
fn roof_faces(scope: &Scope, roof: &Roof, out: &mut Vec<Component>) {
    for face in roof.faces() {
        let pts: Vec<DVec3> = roof.face_points(face).into_iter().map(v3).collect();
        let normal = v3(newell(&roof.face_points(face)));
        let Some(z) = normal.try_normalize() else {
            continue;
        };
        let (x, y, z) = match face.kind {
            FaceKind::Flat => (DVec3::X, DVec3::Y, DVec3::Z),
            FaceKind::Bottom => (DVec3::X, -DVec3::Y, -DVec3::Z),
            FaceKind::Slope | FaceKind::Gable => {
                let e = pts[1] - pts[0];
                let Some(x) = (e - z * e.dot(z)).try_normalize() else {
                    continue;
                };
                (x, z.cross(x), z)
            }
        };
        let local: Vec<[f64; 2]> = pts
            .iter()
            .map(|p| [(*p - pts[0]).dot(x), (*p - pts[0]).dot(y)])
            .collect();
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in &local {
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let moved: Vec<[f64; 2]> = local.iter().map(|p| [p[0] - lo[0], p[1] - lo[1]]).collect();
        let Ok(outline) = Outline::from_ring(&moved) else {
            continue;
        };
        let size = Vec3::new((hi[0] - lo[0]) as f32, (hi[1] - lo[1]) as f32, 0.0);
        let facing = facing_of(z);
        let classes = match face.kind {
            FaceKind::Slope => Classes::of(&[Selector::Slope]).with(facing),
            FaceKind::Gable => Classes::of(&[Selector::Gable, Selector::Side]).with(facing),
            FaceKind::Flat => Classes::of(&[Selector::Top]),
            FaceKind::Bottom => Classes::of(&[Selector::Bottom]),
        };
        out.push(Component {
            classes,
            scope: roof_frame(scope, pts[0] + x * lo[0] + y * lo[1], x, y, z, size),
            geometry: Geom::from_outline(outline, size.x, size.y, false),
        });
    }
}

/// A roof's edges, each once, in the order the faces meet them: a
/// horizontal edge at the eaves is `bottom` (and `eave` under a slope or a
/// flat roof; and faces the way its face does); a horizontal edge above
/// them `ridge`; an inclined edge beside a gable end `rake`, else `hip`
/// where the two slopes meet convex and `valley` where they meet concave.
/// An edge's scope: origin at its start, x along it, z the mean of its
/// faces' outward normals.
fn roof_edges(scope: &Scope, roof: &Roof, out: &mut Vec<Component>) {
    let points = roof.points();
    let (lo, hi) = roof.bounds();
    let tol = 1e-6
        * (hi[0] - lo[0])
            .max(hi[1] - lo[1])
            .max(hi[2] - lo[2])
            .max(1.0);
    // Each edge: its ends as first walked, and its faces.
    let mut edges: Vec<(u32, u32, Vec<usize>)> = Vec::new();
    let mut seen = std::collections::HashMap::new();
    for (fi, face) in roof.faces().iter().enumerate() {
        let n = face.vertices.len();
        for k in 0..n {
            let (a, b) = (face.vertices[k], face.vertices[(k + 1) % n]);
            if a == b {
                continue;
            }
            let key = (a.min(b), a.max(b));
            match seen.get(&key) {
                Some(&i) => {
                    let e: &mut (u32, u32, Vec<usize>) = &mut edges[i];
                    e.2.push(fi);
                }
                None => {
                    seen.insert(key, edges.len());
                    edges.push((a, b, vec![fi]));
                }
            }
        }
    }
    let faces = roof.faces();
    let normals: Vec<DVec3> = faces
        .iter()
        .map(|f| {
            v3(newell(&roof.face_points(f)))
                .try_normalize()
                .unwrap_or(DVec3::Z)
        })
        .collect();
    for (a, b, adjacent) in edges {
        let (Some(&pa), Some(&pb)) = (points.get(a as usize), points.get(b as usize)) else {
            continue;
        };
        let (pa, pb) = (v3(pa), v3(pb));
        let Some(x) = (pb - pa).try_normalize() else {
            continue;
        };
        let len = (pb - pa).length();
        let upper: Vec<usize> = adjacent
            .iter()
            .copied()
            .filter(|&f| faces[f].kind != FaceKind::Bottom)
            .collect();
        let kinds = |k: FaceKind| upper.iter().any(|&f| faces[f].kind == k);
        let horizontal = (pa.z - pb.z).abs() <= tol;
        let classes = if horizontal && pa.z.max(pb.z) <= lo[2] + tol {
            let mut c = Classes::of(&[Selector::Bottom]);
            if kinds(FaceKind::Slope) || kinds(FaceKind::Flat) {
                c = c.with(Some(Selector::Eave));
            }
            // Outward: along the face, away from it (x cross its normal).
            let outward = upper.first().map(|&f| x.cross(normals[f]));
            c.with(outward.and_then(facing_of))
        } else if horizontal {
            Classes::of(&[Selector::Ridge])
        } else if kinds(FaceKind::Gable) {
            Classes::of(&[Selector::Rake])
        } else {
            let concave = match upper.as_slice() {
                [f1, f2, ..] => {
                    let c2 = roof
                        .face_points(&faces[*f2])
                        .into_iter()
                        .map(v3)
                        .fold(DVec3::ZERO, |s, p| s + p)
                        / faces[*f2].vertices.len().max(1) as f64;
                    (c2 - pa).dot(normals[*f1]) > tol
                }
                _ => false,
            };
            Classes::of(&[if concave {
                Selector::Valley
            } else {
                Selector::Hip
            }])
        };
        let mean = upper.iter().fold(DVec3::ZERO, |s, &f| s + normals[f]);
        let z = (mean - x * mean.dot(x))
            .try_normalize()
            .or_else(|| x.any_orthonormal_vector().try_normalize())
            .unwrap_or(DVec3::Z);
        out.push(Component {
            classes,
            scope: roof_frame(scope, pa, x, z.cross(x), z, Vec3::new(len as f32, 0.0, 0.0)),
            geometry: Geom::Edge,
        });
    }
}

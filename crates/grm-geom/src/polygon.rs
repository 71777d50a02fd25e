//! Polygons from `{ . }`: triangulated by ear clipping in their best-fit
//! plane (Newell normal), emitted two-sided (leaves are seen from both
//! sides). Repeated vertices and vertices on a straight edge (`{ . f . f
//! . }`) are skipped without a triangle. A polygon whose ears run out
//! (self-intersecting) is finished as a fan.

use glam::{Vec2, Vec3};

use crate::mesh::MeshData;

/// The Newell normal (unnormalised; its length is twice the area).
pub fn newell_normal(vs: &[Vec3]) -> Vec3 {
    let mut n = Vec3::ZERO;
    for (i, a) in vs.iter().enumerate() {
        let b = vs[(i + 1) % vs.len()];
        n.x += (a.y - b.y) * (a.z + b.z);
        n.y += (a.z - b.z) * (a.x + b.x);
        n.z += (a.x - b.x) * (a.y + b.y);
    }
    n
}

/// Polygons with more vertices than this are triangulated as fans.
pub const EAR_CLIP_MAX: usize = 512;

fn cross2(a: Vec2, b: Vec2) -> f32 {
    a.x * b.y - a.y * b.x
}

fn in_triangle(p: Vec2, a: Vec2, b: Vec2, c: Vec2) -> bool {
    let d1 = cross2(b - a, p - a);
    let d2 = cross2(c - b, p - b);
    let d3 = cross2(a - c, p - c);
    d1 >= 0.0 && d2 >= 0.0 && d3 >= 0.0
}

/// Triangles (indices into `vs`) counter-clockwise about `normal`, which
/// must be the polygon's Newell normal, normalised.
///
/// A simple polygon gives at most `n - 2` triangles that cover it exactly:
/// flat corners (a vertex repeated, or on the line through its
/// neighbours) are dropped without a triangle, and a vertex at the same
/// place as an ear's corner does not block the ear. Only a polygon whose
/// ears run out (self-intersecting) is finished as a fan.
pub fn triangulate(vs: &[Vec3], normal: Vec3, out: &mut Vec<[u32; 3]>) {
    out.clear();
    let n = vs.len();
    if n < 3 {
        return;
    }
    // 2D coordinates in the plane, with u x v = normal so CCW stays CCW.
    let u = normal.any_orthonormal_vector();
    let v = normal.cross(u);
    let pts: Vec<Vec2> = vs.iter().map(|p| Vec2::new(p.dot(u), p.dot(v))).collect();
    // Corners whose doubled area is below this are flat (f32 rounding of
    // the coordinates is about 1e-7 of the extent).
    let (lo, hi) = pts
        .iter()
        .fold((pts[0], pts[0]), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
    let extent = (hi - lo).max_element();
    let flat = 1e-6 * extent * extent;
    let mut idx: Vec<u32> = (0..n as u32).collect();
    // Ear clipping is quadratic or worse; very large polygons are fanned.
    let mut guard = if n > EAR_CLIP_MAX { 0 } else { n * n };
    while idx.len() > 3 && guard > 0 {
        guard -= 1;
        let m = idx.len();
        let mut clipped = false;
        for i in 0..m {
            let (ia, ib, ic) = (idx[(i + m - 1) % m], idx[i], idx[(i + 1) % m]);
            let (a, b, c) = (pts[ia as usize], pts[ib as usize], pts[ic as usize]);
            let corner = cross2(b - a, c - b);
            if corner.abs() <= flat {
                // A flat corner or a repeated vertex: no area to cover.
                idx.remove(i);
                clipped = true;
                break;
            }
            if corner < 0.0 {
                continue; // reflex
            }
            let blocked = idx.iter().any(|&j| {
                let p = pts[j as usize];
                j != ia
                    && j != ib
                    && j != ic
                    && p != a
                    && p != b
                    && p != c
                    && in_triangle(p, a, b, c)
            });
            if !blocked {
                out.push([ia, ib, ic]);
                idx.remove(i);
                clipped = true;
                break;
            }
        }
        if !clipped {
            break;
        }
    }
    if idx.len() == 3 {
        let [a, b, c] = [idx[0], idx[1], idx[2]].map(|i| pts[i as usize]);
        if cross2(b - a, c - b).abs() > flat {
            out.push([idx[0], idx[1], idx[2]]);
        }
        return;
    }
    // Whatever is left (a knot of a self-intersecting polygon) as a fan.
    for k in 1..idx.len().saturating_sub(1) {
        out.push([idx[0], idx[k], idx[k + 1]]);
    }
}

/// Append a two-sided polygon to `m`. Returns `false` (and appends
/// nothing) for a degenerate polygon.
pub fn emit_polygon(vs: &[Vec3], m: &mut MeshData, tris: &mut Vec<[u32; 3]>) -> bool {
    let n = newell_normal(vs);
    let len = n.length();
    if vs.len() < 3 || len <= 1e-12 || !len.is_finite() {
        return false;
    }
    let n = n / len;
    triangulate(vs, n, tris);
    let front = m.positions.len() as u32;
    for p in vs {
        m.vertex(*p, n);
    }
    let back = m.positions.len() as u32;
    for p in vs {
        m.vertex(*p, -n);
    }
    for [a, b, c] in tris.iter().copied() {
        m.triangle(front + a, front + b, front + c);
        m.triangle(back + a, back + c, back + b);
    }
    true
}

//! Indexed triangle meshes and the unit primitives.
//!
//! Conventions: triangles are counter-clockwise seen from the side their
//! normal points to; normals are unit length; every unit primitive is
//! closed (each edge of the welded surface is shared by exactly two
//! triangles), except the disc, which is two-sided (a front and a back face
//! with their own vertices). The unit shapes are those of
//! [`grm_turtle::InstanceKind`].

use glam::{Affine3A, Mat3A, Vec3, Vec3A};

/// An indexed triangle mesh.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshData {
    pub positions: Vec<[f32; 3]>,
    /// One per position, unit length.
    pub normals: Vec<[f32; 3]>,
    /// Three per triangle, each `< positions.len()`.
    pub indices: Vec<u32>,
    /// Texture coordinates: empty, or one per position (shape mode;
    /// exported as glTF `TEXCOORD_0` and OBJ `vt` only when there is one
    /// per position).
    pub uvs: Vec<[f32; 2]>,
}

impl MeshData {
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }

    pub fn is_empty(&self) -> bool {
        self.indices.is_empty()
    }

    /// Append a vertex; returns its index.
    #[inline]
    pub fn vertex(&mut self, p: Vec3, n: Vec3) -> u32 {
        let i = self.positions.len() as u32;
        self.positions.push(p.to_array());
        self.normals.push(n.to_array());
        i
    }

    /// Append a vertex with texture coordinates; returns its index. (Keep
    /// a mesh's vertices all with or all without them.)
    #[inline]
    pub fn vertex_uv(&mut self, p: Vec3, n: Vec3, uv: [f32; 2]) -> u32 {
        self.uvs.push(uv);
        self.vertex(p, n)
    }

    /// Whether the normals are the flat ones: every triangle has area and
    /// each of its vertices' normals points along its own (counter-clockwise)
    /// normal, to within 0.8 degrees. Then the normals carry nothing the
    /// triangles do not: a viewer that sums each vertex's face normals
    /// (three.js `computeVertexNormals`) gets them back, so the preview
    /// leaves them out of its answer (a third of a building's bytes).
    pub fn flat_normals(&self) -> bool {
        if self.normals.len() != self.positions.len() || !self.indices.len().is_multiple_of(3) {
            return false;
        }
        let (p, n) = (&self.positions, &self.normals);
        self.indices.chunks_exact(3).all(|t| {
            let [Some(a), Some(b), Some(c)] = [0, 1, 2].map(|k| p.get(t[k] as usize)) else {
                return false;
            };
            let [a, b, c] = [a, b, c].map(|v| Vec3::from_array(*v));
            let Some(face) = (b - a).cross(c - a).try_normalize() else {
                return false;
            };
            t.iter()
                .all(|&v| Vec3::from_array(n[v as usize]).dot(face) > 0.9999)
        })
    }

    /// Whether the mesh is parallelogram quads, each as [`MeshData::quad`]
    /// writes one: four vertices `a b c d` of their own, triangles `a b c`
    /// and `a c d`, `d = a + c - b` (to within 1e-5 of the coordinates'
    /// size), and flat normals ([`MeshData::flat_normals`]). Then three
    /// corners per quad say it all: the preview sends them alone (a
    /// building's walls, windows and boxes; a third of its bytes).
    pub fn is_quads(&self) -> bool {
        self.quad_indices() && self.quad_geometry()
    }

    /// The index half of [`MeshData::is_quads`]: four vertices a quad
    /// and its triangles `a b c`, `a c d` in order (what the indices say;
    /// the positions and normals are [`MeshData::quad_geometry`]'s). The
    /// preview checks the two halves on different threads.
    pub fn quad_indices(&self) -> bool {
        let q = self.positions.len() / 4;
        if q == 0 || self.positions.len() != 4 * q || self.indices.len() != 6 * q {
            return false;
        }
        self.indices.chunks_exact(6).enumerate().all(|(k, t)| {
            let b = 4 * k as u32;
            t == [b, b + 1, b + 2, b, b + 2, b + 3]
        })
    }

    /// The geometry half of [`MeshData::is_quads`]: each run of four
    /// vertices a parallelogram with one normal, its face's.
    pub fn quad_geometry(&self) -> bool {
        // Per quad: a parallelogram, one normal for its four vertices, and
        // that normal its face's (what `flat_normals` asks of each
        // triangle: both triangles of a parallelogram share the face's
        // normal), compared squared (no root per quad).
        !self.positions.is_empty()
            && self.positions.len().is_multiple_of(4)
            && self.normals.len() == self.positions.len()
            && self
                .positions
                .chunks_exact(4)
                .zip(self.normals.chunks_exact(4))
                .all(|(p, n)| {
                    let [a, b, c, d] = [p[0], p[1], p[2], p[3]].map(Vec3::from_array);
                    let size = a.abs().max(c.abs()).max_element().max(1.0);
                    let face = (b - a).cross(c - a);
                    let normal = Vec3::from_array(n[0]);
                    let along = face.dot(normal);
                    (a + c - b - d).abs().max_element() <= 1e-5 * size
                        && n[1..].iter().all(|m| *m == n[0])
                        && along > 0.0
                        && along * along > 0.9998 * face.length_squared() * normal.length_squared()
                        && (normal.length_squared() - 1.0).abs() < 1e-3
                })
    }

    /// Append the quad `a b c d` (counter-clockwise seen from `n`), as
    /// [`MeshData::is_quads`] reads it.
    pub fn quad(&mut self, corners: [Vec3; 4], n: Vec3) {
        let i = corners.map(|p| self.vertex(p, n));
        self.triangle(i[0], i[1], i[2]);
        self.triangle(i[0], i[2], i[3]);
    }

    /// Whether every vertex has texture coordinates (and there are vertices).
    pub fn has_uvs(&self) -> bool {
        !self.positions.is_empty() && self.uvs.len() == self.positions.len()
    }

    #[inline]
    pub fn triangle(&mut self, a: u32, b: u32, c: u32) {
        self.indices.extend_from_slice(&[a, b, c]);
    }

    /// Append `other` transformed by `t` (normals by its inverse
    /// transpose; the winding is flipped when `t` mirrors). Returns `false`
    /// and appends nothing when `t` is singular or not finite.
    pub fn append_transformed(&mut self, other: &MeshData, t: &Affine3A) -> bool {
        let det = t.matrix3.determinant();
        if !(det.is_finite() && det.abs() > 1e-18 && t.translation.is_finite()) {
            return false;
        }
        let normal_matrix: Mat3A = t.matrix3.inverse().transpose();
        let base = self.positions.len() as u32;
        self.positions.reserve(other.positions.len());
        self.normals.reserve(other.normals.len());
        for (p, n) in other.positions.iter().zip(&other.normals) {
            let p = t.transform_point3a(Vec3A::from_array(*p));
            let n = (normal_matrix * Vec3A::from_array(*n)).normalize_or(Vec3A::Y);
            self.positions.push(p.to_array());
            self.normals.push(n.to_array());
        }
        self.indices.reserve(other.indices.len());
        for tri in other.indices.chunks_exact(3) {
            if det < 0.0 {
                self.triangle(base + tri[0], base + tri[2], base + tri[1]);
            } else {
                self.triangle(base + tri[0], base + tri[1], base + tri[2]);
            }
        }
        true
    }

    /// Whether all positions and normals are finite.
    pub fn is_finite(&self) -> bool {
        self.positions
            .iter()
            .chain(&self.normals)
            .all(|v| v.iter().all(|x| x.is_finite()))
    }
}

/// A ring of `sides` directions `cos(a) e1 + sin(a) e2` in the plane
/// perpendicular to `d` (with `e2 = d x e1`), counter-clockwise seen from `+d`.
pub(crate) fn ring_dirs(e1: Vec3, d: Vec3, sides: u32) -> impl Iterator<Item = Vec3> {
    let e2 = d.cross(e1);
    (0..sides).map(move |k| {
        let a = std::f32::consts::TAU * k as f32 / sides as f32;
        let (s, c) = a.sin_cos();
        e1 * c + e2 * s
    })
}

/// A flat cap: a centre and a ring at `centre + r * dirs`, facing `normal`.
/// `ccw` says whether the ring runs counter-clockwise seen from `normal`.
fn cap(m: &mut MeshData, centre: Vec3, dirs: &[Vec3], r: f32, normal: Vec3, ccw: bool) {
    let c = m.vertex(centre, normal);
    let first = m.positions.len() as u32;
    for d in dirs {
        m.vertex(centre + *d * r, normal);
    }
    let n = dirs.len() as u32;
    for k in 0..n {
        let a = first + k;
        let b = first + (k + 1) % n;
        if ccw {
            m.triangle(c, a, b);
        } else {
            m.triangle(c, b, a);
        }
    }
}

/// Unit cylinder: radius 1, y from 0 to 1, closed with caps.
pub fn unit_cylinder(segments: u32) -> MeshData {
    let n = segments.max(3);
    let dirs: Vec<Vec3> = ring_dirs(Vec3::Z, Vec3::Y, n).collect();
    let mut m = MeshData::default();
    for d in &dirs {
        m.vertex(*d, *d);
    }
    for d in &dirs {
        m.vertex(*d + Vec3::Y, *d);
    }
    for k in 0..n {
        let (b0, b1) = (k, (k + 1) % n);
        let (t0, t1) = (n + b0, n + b1);
        m.triangle(b0, b1, t1);
        m.triangle(b0, t1, t0);
    }
    cap(&mut m, Vec3::ZERO, &dirs, 1.0, -Vec3::Y, false);
    cap(&mut m, Vec3::Y, &dirs, 1.0, Vec3::Y, true);
    m
}

/// Unit cone: radius 1 at y = 0, apex at (0, 1, 0), closed with a base cap.
pub fn unit_cone(segments: u32) -> MeshData {
    let n = segments.max(3);
    let dirs: Vec<Vec3> = ring_dirs(Vec3::Z, Vec3::Y, n).collect();
    let mut m = MeshData::default();
    // Side normal for radius 1, height 1: (cos, 1, sin) normalised.
    let side = |d: Vec3| (d + Vec3::Y).normalize();
    for d in &dirs {
        m.vertex(*d, side(*d));
    }
    // One apex vertex per segment, with the normal of the segment's middle.
    for k in 0..n {
        let mid = (dirs[k as usize] + dirs[((k + 1) % n) as usize]).normalize_or(Vec3::X);
        m.vertex(Vec3::Y, side(mid));
    }
    for k in 0..n {
        m.triangle(k, (k + 1) % n, n + k);
    }
    cap(&mut m, Vec3::ZERO, &dirs, 1.0, -Vec3::Y, false);
    m
}

/// Unit UV sphere about the origin: `segments` around, `segments / 2`
/// stacks, one vertex at each pole.
pub fn unit_sphere(segments: u32) -> MeshData {
    let slices = segments.max(3);
    let stacks = (segments / 2).max(2);
    let mut m = MeshData::default();
    let top = m.vertex(Vec3::Y, Vec3::Y);
    for i in 1..stacks {
        let phi = std::f32::consts::PI * i as f32 / stacks as f32;
        let (sp, cp) = phi.sin_cos();
        for j in 0..slices {
            let th = std::f32::consts::TAU * j as f32 / slices as f32;
            let (st, ct) = th.sin_cos();
            let p = Vec3::new(sp * st, cp, sp * ct);
            m.vertex(p, p);
        }
    }
    let bottom = m.vertex(-Vec3::Y, -Vec3::Y);
    let ring = |i: u32, j: u32| 1 + (i - 1) * slices + j % slices;
    for j in 0..slices {
        m.triangle(top, ring(1, j), ring(1, j + 1));
    }
    for i in 1..stacks - 1 {
        for j in 0..slices {
            let (a, b) = (ring(i, j), ring(i, j + 1));
            let (c, d) = (ring(i + 1, j), ring(i + 1, j + 1));
            m.triangle(a, c, d);
            m.triangle(a, d, b);
        }
    }
    for j in 0..slices {
        m.triangle(bottom, ring(stacks - 1, j + 1), ring(stacks - 1, j));
    }
    m
}

/// Unit box `[-0.5, 0.5] x [0, 1] x [-0.5, 0.5]`: 24 vertices, 12 triangles.
pub fn unit_box() -> MeshData {
    let mut m = MeshData::default();
    let centre = Vec3::new(0.0, 0.5, 0.0);
    for axis in 0..3 {
        for sign in [1.0f32, -1.0] {
            let mut n = Vec3::ZERO;
            n[axis] = sign;
            // In-face axes with u x v = n, so (a, b) below runs counter-clockwise.
            let mut u = Vec3::ZERO;
            u[(axis + 1) % 3] = 1.0;
            let v = n.cross(u);
            let first = m.positions.len() as u32;
            for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                m.vertex(centre + 0.5 * (n + u * a + v * b), n);
            }
            m.triangle(first, first + 1, first + 2);
            m.triangle(first, first + 2, first + 3);
        }
    }
    m
}

/// Unit disc: radius 1 in the XZ plane, two-sided (front faces +Y).
pub fn unit_disc(segments: u32) -> MeshData {
    let n = segments.max(3);
    let dirs: Vec<Vec3> = ring_dirs(Vec3::Z, Vec3::Y, n).collect();
    let mut m = MeshData::default();
    cap(&mut m, Vec3::ZERO, &dirs, 1.0, Vec3::Y, true);
    cap(&mut m, Vec3::ZERO, &dirs, 1.0, -Vec3::Y, false);
    m
}

/// Smooth normals for a mesh that has none (`+Y` where a vertex has no
/// triangle with an area).
pub(crate) fn compute_normals(positions: &[[f32; 3]], indices: &[u32]) -> Vec<[f32; 3]> {
    let mut normals = vec![Vec3::Y.to_array(); positions.len()];
    smooth_normals(positions, indices, &mut normals);
    normals
}

/// Sets each vertex's normal to the mean of the normals of the triangles
/// around it, each weighted by its angle at the vertex (so splitting a
/// quad into two triangles does not tilt it). A vertex keeps its normal
/// where those cancel or there are none; triangles with an index out of
/// range are skipped.
pub(crate) fn smooth_normals(positions: &[[f32; 3]], indices: &[u32], normals: &mut [[f32; 3]]) {
    let mut sum = vec![Vec3::ZERO; positions.len()];
    for t in indices.chunks_exact(3) {
        if t.iter().any(|&i| i as usize >= positions.len()) {
            continue;
        }
        let p = |k: usize| Vec3::from_array(positions[t[k] as usize]);
        let g = (p(1) - p(0)).cross(p(2) - p(0));
        // Scaled first: a tiny model's areas square to below f32's range.
        let big = g.abs().max_element();
        if !(big > 0.0 && big.is_finite()) {
            continue;
        }
        let face = (g / big).normalize();
        for k in 0..3 {
            let angle = (p((k + 1) % 3) - p(k)).angle_between(p((k + 2) % 3) - p(k));
            if angle.is_finite() {
                sum[t[k] as usize] += face * angle;
            }
        }
    }
    for (normal, s) in normals.iter_mut().zip(sum) {
        if let Some(u) = s.try_normalize() {
            *normal = u.to_array();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit square in the xy plane, counter-clockwise seen from +z.
    fn square(normal: Vec3) -> MeshData {
        let mut m = MeshData::default();
        for p in [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]] {
            m.vertex(Vec3::new(p[0], p[1], 0.0), normal);
        }
        m.triangle(0, 1, 2);
        m.triangle(0, 2, 3);
        m
    }

    #[test]
    fn flat_normals_are_the_faces_own() {
        assert!(square(Vec3::Z).flat_normals());
        // Pointing away from the winding's side, or tilted: not flat.
        assert!(!square(-Vec3::Z).flat_normals());
        assert!(!square(Vec3::new(0.0, 0.1, 1.0).normalize()).flat_normals());
        // A vertex shared by two planes (a folded square) cannot be flat.
        let mut folded = square(Vec3::Z);
        folded.positions[2] = [1.0, 1.0, 1.0];
        assert!(!folded.flat_normals());
        // A triangle without area, or an index past the vertices.
        let mut thin = square(Vec3::Z);
        thin.triangle(0, 0, 1);
        assert!(!thin.flat_normals());
        let mut bad = square(Vec3::Z);
        bad.indices[5] = 9;
        assert!(!bad.flat_normals());
        // A smooth tube's normals are not its faces'.
        let mut m = MeshData::default();
        m.vertex(Vec3::ZERO, Vec3::new(-1.0, 0.0, 1.0).normalize());
        m.vertex(Vec3::X, Vec3::new(1.0, 0.0, 1.0).normalize());
        m.vertex(Vec3::Y, Vec3::Z);
        m.triangle(0, 1, 2);
        assert!(!m.flat_normals());
        assert!(MeshData::default().flat_normals());
    }

    #[test]
    fn parallelogram_quads_are_told_from_other_meshes() {
        let mut m = MeshData::default();
        m.quad(
            [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y],
            Vec3::Z,
        );
        // A sheared one far from the origin.
        let o = Vec3::new(1000.0, -2000.0, 5.0);
        let (u, v) = (Vec3::new(2.0, 0.5, 0.0), Vec3::new(0.25, 3.0, 0.0));
        m.quad([o, o + u, o + u + v, o + v], Vec3::Z);
        assert!(m.is_quads());
        assert!(square(Vec3::Z).is_quads());
        // Not a parallelogram, another index order, a triangle, no quad.
        let mut kite = square(Vec3::Z);
        kite.positions[3] = [0.0, 1.5, 0.0];
        assert!(!kite.is_quads());
        assert!(kite.quad_indices() && !kite.quad_geometry());
        let mut order = square(Vec3::Z);
        order.indices = vec![0, 1, 3, 1, 2, 3];
        assert!(!order.is_quads());
        assert!(!order.quad_indices() && order.quad_geometry());
        let mut tri = MeshData::default();
        tri.vertex(Vec3::ZERO, Vec3::Z);
        tri.vertex(Vec3::X, Vec3::Z);
        tri.vertex(Vec3::Y, Vec3::Z);
        tri.vertex(Vec3::ONE, Vec3::Z);
        tri.triangle(0, 1, 2);
        assert!(!tri.is_quads());
        assert!(!MeshData::default().is_quads());
        // Normals that are not the faces' own, or not one per quad.
        assert!(!square(-Vec3::Z).is_quads());
        let mut bent = square(Vec3::Z);
        bent.normals[2] = Vec3::new(0.0, 0.1, 1.0).normalize().to_array();
        assert!(!bent.is_quads());
        // No area.
        let mut flat = MeshData::default();
        flat.quad([Vec3::ZERO, Vec3::X, Vec3::X, Vec3::ZERO], Vec3::Z);
        assert!(!flat.is_quads());
    }
}

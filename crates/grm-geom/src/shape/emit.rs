//! Geometry emitted for one shape (see the parent module): masses,
//! prisms, faces and roofs as triangles in the scope's frame, outlines
//! with holes cut into hole-free pieces, and assets fitted to a scope.

use super::*;

/// A scope whose placement is finite.
pub(super) fn scope_ok(s: &Scope) -> bool {
    s.origin.is_finite() && s.size.is_finite() && s.rotation().is_finite()
}

/// Writes a scope's local geometry into a mesh, in the model's frame.
pub(super) struct Emitter<'m> {
    pub(super) mesh: &'m mut MeshData,
    pub(super) scope: &'m Scope,
    pub(super) rot: Quat,
}

impl Emitter<'_> {
    /// A local normal in the model's frame (what each vertex with that
    /// normal is given).
    #[inline]
    pub(super) fn normal(&self, normal: Vec3) -> Vec3 {
        to_model(self.rot * normal).normalize_or(Vec3::Y)
    }

    /// A vertex with its normal already in the model's frame.
    #[inline]
    pub(super) fn vertex(&mut self, local: Vec3, n: Vec3, uv: [f32; 2]) -> u32 {
        let p = to_model(self.scope.origin + self.rot * local);
        self.mesh.vertex_uv(p, n, uv)
    }

    /// A quad `a b c d` (counter-clockwise seen from `normal`).
    /// The four vertices go in with one append per buffer (the same
    /// arithmetic per corner as [`Emitter::vertex`]: the same bytes).
    #[inline]
    pub(super) fn quad(&mut self, corners: [Vec3; 4], normal: Vec3, uvs: [[f32; 2]; 4]) {
        let n = self.normal(normal).to_array();
        let (o, rot) = (self.scope.origin, self.rot);
        let at = |p: Vec3| to_model(o + rot * p).to_array();
        let [a, b, c, d] = [
            at(corners[0]),
            at(corners[1]),
            at(corners[2]),
            at(corners[3]),
        ];
        let m = &mut *self.mesh;
        let i = m.positions.len() as u32;
        m.positions.extend_from_slice(&[a, b, c, d]);
        m.normals.extend_from_slice(&[n; 4]);
        m.uvs.extend_from_slice(&uvs);
        m.indices
            .extend_from_slice(&[i, i + 1, i + 2, i, i + 2, i + 3]);
    }

    /// The box `[0, s]`: six quads, those of zero area left out.
    pub(super) fn cuboid(&mut self, s: Vec3) {
        for a in 0..3 {
            let (b, c) = ((a + 1) % 3, (a + 2) % 3);
            if !(s[b] > 0.0 && s[c] > 0.0) {
                continue;
            }
            for positive in [true, false] {
                let mut n = Vec3::ZERO;
                n[a] = if positive { 1.0 } else { -1.0 };
                let at = |u: f32, v: f32| {
                    let mut p = Vec3::ZERO;
                    p[a] = if positive { s[a] } else { 0.0 };
                    p[b] = u * s[b];
                    p[c] = v * s[c];
                    p
                };
                // Counter-clockwise about +a in (b, c); reversed for -a,
                // with u mirrored so the texture reads the right way.
                if positive {
                    self.quad(
                        [at(0., 0.), at(1., 0.), at(1., 1.), at(0., 1.)],
                        n,
                        [[0., 0.], [1., 0.], [1., 1.], [0., 1.]],
                    );
                } else {
                    self.quad(
                        [at(1., 0.), at(0., 0.), at(0., 1.), at(1., 1.)],
                        n,
                        [[0., 0.], [1., 0.], [1., 1.], [0., 1.]],
                    );
                }
            }
        }
    }

    /// The rectangle `[0, s.x] x [0, s.y]`, facing +z.
    pub(super) fn rect(&mut self, s: Vec3) {
        if !(s.x > 0.0 && s.y > 0.0) {
            return;
        }
        self.quad(
            [
                Vec3::ZERO,
                Vec3::new(s.x, 0.0, 0.0),
                Vec3::new(s.x, s.y, 0.0),
                Vec3::new(0.0, s.y, 0.0),
            ],
            Vec3::Z,
            [[0., 0.], [1., 0.], [1., 1.], [0., 1.]],
        );
    }

    /// The outline triangulated at height `z`, facing +z (or -z when
    /// `down`); UVs `x / s.x`, `y / s.y`.
    pub(super) fn outline(
        &mut self,
        o: &Outline,
        z: f32,
        down: bool,
        s: Vec3,
        tris: &mut Vec<[u32; 3]>,
    ) {
        let normal = if down { -Vec3::Z } else { Vec3::Z };
        let uv = |p: [f64; 2]| {
            let f = |x: f64, len: f32| {
                if len > 0.0 {
                    (x / f64::from(len)).clamp(0.0, 1.0) as f32
                } else {
                    0.0
                }
            };
            [f(p[0], s.x), f(p[1], s.y)]
        };
        for ring in hole_free(o) {
            let vs: Vec<Vec3> = ring
                .iter()
                .map(|p| Vec3::new(p[0] as f32, p[1] as f32, 0.0))
                .collect();
            crate::polygon::triangulate(&vs, Vec3::Z, tris);
            if tris.is_empty() {
                continue;
            }
            let first = self.mesh.vertex_count() as u32;
            let n = self.normal(normal);
            for p in &ring {
                self.vertex(Vec3::new(p[0] as f32, p[1] as f32, z), n, uv(*p));
            }
            for t in tris.iter() {
                if down {
                    self.mesh.triangle(first + t[0], first + t[2], first + t[1]);
                } else {
                    self.mesh.triangle(first + t[0], first + t[1], first + t[2]);
                }
            }
        }
    }

    /// A planar face (a roof's; corners counter-clockwise seen from
    /// outside), ear-clipped in its plane; UVs by its own bounds in the
    /// plane: `u` horizontal, `v` up the slope (a horizontal face: `x`,
    /// `y`). A face of no area draws nothing.
    pub(super) fn planar(&mut self, points: &[[f64; 3]], tris: &mut Vec<[u32; 3]>) {
        let vs: Vec<Vec3> = points
            .iter()
            .map(|p| Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32))
            .collect();
        let Some(normal) = crate::polygon::newell_normal(&vs).try_normalize() else {
            return;
        };
        crate::polygon::triangulate(&vs, normal, tris);
        if tris.is_empty() {
            return;
        }
        let u = Vec3::Z.cross(normal).try_normalize().unwrap_or(Vec3::X);
        let v = normal.cross(u);
        let (lo, hi) = vs.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), p| {
                let q = Vec3::new(p.dot(u), p.dot(v), 0.0);
                (lo.min(q), hi.max(q))
            },
        );
        let ext = hi - lo;
        let norm = |x: f32, lo: f32, e: f32| {
            if e > 0.0 {
                ((x - lo) / e).clamp(0.0, 1.0)
            } else {
                0.0
            }
        };
        let first = self.mesh.vertex_count() as u32;
        let n = self.normal(normal);
        for p in &vs {
            let uv = [norm(p.dot(u), lo.x, ext.x), norm(p.dot(v), lo.y, ext.y)];
            self.vertex(*p, n, uv);
        }
        for t in tris.iter() {
            self.mesh.triangle(first + t[0], first + t[1], first + t[2]);
        }
    }

    /// One quad per edge of each ring, `h` high, facing out of the solid.
    pub(super) fn walls(&mut self, o: &Outline, h: f32) {
        if h <= 0.0 {
            return;
        }
        for ring in o.rings() {
            let n = ring.len();
            for k in 0..n {
                let a = ring[k];
                let b = ring[(k + 1) % n];
                let (dx, dy) = ((b[0] - a[0]) as f32, (b[1] - a[1]) as f32);
                let Some(normal) = Vec3::new(dy, -dx, 0.0).try_normalize() else {
                    continue;
                };
                let pa = Vec3::new(a[0] as f32, a[1] as f32, 0.0);
                let pb = Vec3::new(b[0] as f32, b[1] as f32, 0.0);
                let up = Vec3::new(0.0, 0.0, h);
                self.quad(
                    [pa, pb, pb + up, pa + up],
                    normal,
                    [[0., 0.], [1., 0.], [1., 1.], [0., 1.]],
                );
            }
        }
    }
}

/// The outline's polygons as rings without holes (counter-clockwise, no
/// closing point): a polygon with holes is cut by vertical lines through
/// the middle of each hole, so that every piece is simple.
pub(super) fn hole_free(o: &Outline) -> Vec<Vec<[f64; 2]>> {
    let mut out = Vec::new();
    let mut work: Vec<(Outline, u32)> = vec![(o.clone(), 0)];
    while let Some((piece, depth)) = work.pop() {
        let mut cuts: Vec<f64> = Vec::new();
        for p in &piece.polygons().0 {
            if p.interiors().is_empty() || depth >= 4 {
                let mut pts: Vec<[f64; 2]> = p.exterior().coords().map(|c| [c.x, c.y]).collect();
                if pts.len() > 1 && pts.first() == pts.last() {
                    pts.pop();
                }
                out.push(pts);
                // Past the depth limit (a hole the cuts never opened, only
                // numerically possible), holes are left filled.
                continue;
            }
            for hole in p.interiors() {
                let (lo, hi) = hole
                    .coords()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), c| {
                        (lo.min(c.x), hi.max(c.x))
                    });
                if lo.is_finite() && hi.is_finite() {
                    cuts.push(0.5 * (lo + hi));
                }
            }
        }
        if cuts.is_empty() {
            continue;
        }
        // Only the polygons with holes are cut; the others are out already.
        let holed: Vec<_> = piece
            .polygons()
            .0
            .iter()
            .filter(|p| !p.interiors().is_empty())
            .cloned()
            .collect();
        let holed = Outline::new(holed.into());
        let Some((lo, hi)) = holed.bounds() else {
            continue;
        };
        cuts.sort_by(f64::total_cmp);
        cuts.dedup();
        let mut edges = vec![lo[0]];
        edges.extend(cuts.into_iter().filter(|&x| x > lo[0] && x < hi[0]));
        edges.push(hi[0]);
        for w in edges.windows(2) {
            if let Some(slab) = holed.clip_slab(0, w[0], w[1] - w[0]) {
                work.push((slab.translated(w[0], 0.0), depth + 1));
            }
        }
    }
    out
}

/// Append `m` (with bounds `lo`, `hi`) fitted to `scope` (module
/// documentation), with box-projected UVs. `false` (nothing appended)
/// when the fit is degenerate.
pub(super) fn append_fitted(
    out: &mut MeshData,
    m: &MeshData,
    lo: Vec3,
    hi: Vec3,
    scope: &Scope,
) -> bool {
    let ext = hi - lo;
    let size = scope.size;
    if !(ext.is_finite() && size.is_finite()) {
        return false;
    }
    // Scale per axis: the scope's size over the asset's; a zero-size scope
    // axis takes the mean of the others; a flat asset axis stays flat.
    let mut scale = [None::<f32>; 3];
    for i in 0..3 {
        if ext[i] > 0.0 && size[i] > 0.0 {
            scale[i] = Some(size[i] / ext[i]);
        }
    }
    let known: Vec<f32> = scale.iter().flatten().copied().collect();
    if known.is_empty() {
        return false;
    }
    let mean = known.iter().sum::<f32>() / known.len() as f32;
    let s = Vec3::from_array(std::array::from_fn(|i| match scale[i] {
        Some(x) => x,
        None if ext[i] > 0.0 => mean,
        None => 1.0,
    }));
    let rot = scope.rotation();
    let base = out.positions.len() as u32;
    for (p, n) in m.positions.iter().zip(&m.normals) {
        let p = Vec3::from_array(*p);
        let n = Vec3::from_array(*n);
        let local = (p - lo) * s;
        let normal = (n / s).normalize_or(n);
        // Box projection: the plane the normal leans to most.
        let t = Vec3::from_array(std::array::from_fn(|i| {
            if ext[i] > 0.0 {
                ((p[i] - lo[i]) / ext[i]).clamp(0.0, 1.0)
            } else {
                0.0
            }
        }));
        let a = normal.abs();
        let uv = if a.x >= a.y && a.x >= a.z {
            [t.z, t.y]
        } else if a.y >= a.z {
            [t.x, t.z]
        } else {
            [t.x, t.y]
        };
        let world = scope.origin + rot * local;
        out.vertex_uv(
            to_model(world),
            to_model(rot * normal).normalize_or(Vec3::Y),
            uv,
        );
    }
    for t in m.indices.chunks_exact(3) {
        out.triangle(base + t[0], base + t[1], base + t[2]);
    }
    true
}

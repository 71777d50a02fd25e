//! Generalized cylinders along the skeleton.
//!
//! Each bone with a width gets a tube: a ring of `sides` vertices at its
//! tip, joined to a ring at its base. A bone **continues** its parent when
//! it starts at the parent's tip and is the parent's most aligned such
//! child (at most 120 degrees off): then its base ring is the parent's tip
//! ring, mitred in the plane that bisects the two directions, so a chain of
//! bones is one continuous tube (the ring orientation is carried along the
//! chain by the minimal rotation between directions, so it does not
//! twist). A continuing tube tapers from the parent's tip width to its own
//! tip width. Other bones (lateral branches, bones after an `f`) start with
//! their own ring and a cap; a tube ends with a cap where no bone continues
//! it, so every tube is closed. Bones of width 0, of zero length or with
//! non-finite ends get no tube.
//!
//! Side normals are the mesh's own: each ring vertex takes the
//! area-weighted mean of the normals of the side quads around it (each
//! quad's from its diagonals, so the split into two triangles does not
//! tilt it), summed while the quads are made and normalised by
//! `finish_normals` once a part's tubes are all made. So a cylinder's
//! normals are radial, a tapering tube's lean with its taper, and a mitred
//! ring shared by two tubes takes both tubes' quads; caps are flat. (Where
//! a chain changes paint, each part's copy of the shared ring sees only
//! its own tube's quads.)
//!
//! Mitre limit: on the inner side of a bend a mitred ring reaches back
//! into both tubes, by `r tan(angle / 2)`. Where that is more than
//! [`MITRE_DEPTH`] of the shorter tube's length, the ring's points there
//! are drawn towards the axis (within the bisecting plane) until it is
//! not, so a short thick bone between two bends never folds inside out;
//! the elbow is pinched instead.

use glam::{Quat, Vec3};
use grm_turtle::Bone;

use crate::mesh::MeshData;

/// The most a continuing bone may turn away from its parent (cosine).
const MIN_CONTINUE_COS: f32 = -0.5;

/// The deepest a mitred ring may reach into either of its tubes, as a
/// share of the shorter one's length (under a half, so the two rings of a
/// tube never cross).
pub const MITRE_DEPTH: f32 = 0.25;

/// Per-bone tube layout, computed once before emitting geometry.
#[derive(Debug)]
pub(crate) struct TubePlan {
    /// Unit direction, or `None` for bones without a tube.
    pub dir: Vec<Option<Vec3>>,
    /// The child that continues each bone.
    pub next: Vec<Option<u32>>,
    /// Whether each bone continues its parent.
    pub continues: Vec<bool>,
    /// Ring reference direction (unit, perpendicular to `dir`).
    pub e1: Vec<Vec3>,
}

fn perpendicular(d: Vec3, hint: Vec3) -> Vec3 {
    let p = hint - d * hint.dot(d);
    if p.length_squared() > 1e-8 {
        p.normalize()
    } else {
        d.any_orthonormal_vector()
    }
}

impl TubePlan {
    pub fn new(bones: &[Bone]) -> TubePlan {
        let n = bones.len();
        let mut dir = Vec::with_capacity(n);
        for b in bones {
            let v = b.tip - b.base;
            let len = v.length();
            let scale = b.base.abs().max_element().max(1.0);
            let ok = b.base.is_finite()
                && b.tip.is_finite()
                && len > 1e-6 * scale
                && len.is_finite()
                && b.width_base.is_finite()
                && b.width_tip.is_finite()
                && (b.width_base > 0.0 || b.width_tip > 0.0);
            dir.push(ok.then(|| v / len));
        }
        // The most aligned child starting at the parent's tip continues it.
        let mut best: Vec<Option<(u32, f32)>> = vec![None; n];
        for (i, b) in bones.iter().enumerate() {
            let (Some(p), Some(d)) = (b.parent, dir[i]) else {
                continue;
            };
            let p = p as usize;
            if p >= i {
                continue; // parents come first; anything else is not a chain
            }
            let Some(dp) = dir[p] else { continue };
            let parent = &bones[p];
            let tol = 1e-4 * parent.length().max(1e-3);
            if parent.tip.distance(b.base) > tol || parent.width_tip <= 0.0 {
                continue;
            }
            let c = dp.dot(d);
            if c >= MIN_CONTINUE_COS && best[p].is_none_or(|(_, bc)| c > bc) {
                best[p] = Some((i as u32, c));
            }
        }
        let next: Vec<Option<u32>> = best.iter().map(|b| b.map(|(i, _)| i)).collect();
        let mut continues = vec![false; n];
        for c in next.iter().flatten() {
            continues[*c as usize] = true;
        }
        // Ring frames, carried along chains (parents first).
        let mut e1 = Vec::with_capacity(n);
        for (i, b) in bones.iter().enumerate() {
            let v = match dir[i] {
                None => Vec3::X,
                Some(d) if continues[i] => {
                    // `continues` implies a parent with a direction.
                    let p = b.parent.map_or(0, |p| p as usize);
                    let dp = dir[p].unwrap_or(d);
                    let carried = Quat::from_rotation_arc(dp, d) * e1[p];
                    perpendicular(d, carried)
                }
                Some(d) => perpendicular(d, b.left),
            };
            e1.push(v);
        }
        TubePlan {
            dir,
            next,
            continues,
            e1,
        }
    }
}

/// The continuing tube at a mitred ring: its direction, and how deep the
/// ring may reach into either tube.
#[derive(Clone, Copy)]
struct Joint {
    dir: Vec3,
    depth: f32,
}

impl Joint {
    /// The joint between bone `i` and its continuing child `c`.
    fn new(plan: &TubePlan, bones: &[Bone], i: usize, c: usize) -> Option<Joint> {
        Some(Joint {
            dir: plan.dir[c]?,
            depth: MITRE_DEPTH * bones[i].length().min(bones[c].length()),
        })
    }
}

/// A ring at `centre` around direction `d` (frame `e1`), radius `r`,
/// mitred into the plane bisecting `d` and the continuing tube's direction
/// when `next` gives it. Returns the positions through `out`.
fn ring(
    centre: Vec3,
    d: Vec3,
    e1: Vec3,
    r: f32,
    next: Option<Joint>,
    circle: &[(f32, f32)],
    out: &mut Vec<Vec3>,
) {
    out.clear();
    let mitre = next.and_then(|j| {
        let n = d + j.dir;
        (n.length_squared() > 1e-6).then(|| (n.normalize(), j))
    });
    let e2 = d.cross(e1);
    for &(c, s) in circle {
        let q = e1 * c + e2 * s;
        match mitre {
            Some((n, j)) => {
                let off = q * r;
                // `t < 0` on the inner side: the point lies `-t` back in
                // this tube and `-t` on in the next (the plane bisects).
                let t = -off.dot(n) / d.dot(n);
                let pinch = if -t > j.depth { j.depth / -t } else { 1.0 };
                out.push(centre + (off + d * t) * pinch);
            }
            None => out.push(centre + q * r),
        }
    }
}

/// `(cos, sin)` of `sides` angles around the circle.
pub(crate) fn circle(sides: u32) -> Vec<(f32, f32)> {
    let n = sides.max(3);
    (0..n)
        .map(|k| {
            let (s, c) = (std::f32::consts::TAU * k as f32 / n as f32).sin_cos();
            (c, s)
        })
        .collect()
}

/// Emits the tube of bone `i` into `m`. `shared_base` is the first vertex
/// of the parent's tip ring when it lies in the same mesh. Returns the
/// first vertex of this bone's tip ring (for its continuing child), or
/// `None` when the bone has no tube.
pub(crate) fn emit_bone(
    plan: &TubePlan,
    bones: &[Bone],
    i: usize,
    circle: &[(f32, f32)],
    shared_base: Option<u32>,
    m: &mut MeshData,
    scratch: &mut Vec<Vec3>,
) -> Option<u32> {
    let d = plan.dir[i]?;
    let b = &bones[i];
    let e1 = plan.e1[i];
    let sides = circle.len() as u32;
    let r_tip = 0.5 * b.width_tip.max(0.0);
    // The base ring: the parent's tip ring, or a fresh ring with a cap.
    let base_first = if plan.continues[i] {
        let p = b.parent.map_or(0, |p| p as usize);
        let parent = &bones[p];
        let r = 0.5 * parent.width_tip.max(0.0);
        match shared_base {
            Some(first) => first,
            None => {
                let dp = plan.dir[p].unwrap_or(d);
                let next = Joint::new(plan, bones, p, i);
                ring(b.base, dp, plan.e1[p], r, next, circle, scratch);
                push_ring(m, scratch)
            }
        }
    } else {
        let r = 0.5 * b.width_base.max(0.0);
        ring(b.base, d, e1, r, None, circle, scratch);
        let first = push_ring(m, scratch);
        cap(m, b.base, scratch, -d, false);
        first
    };
    // The tip ring, mitred towards the continuing child.
    let next = plan.next[i].and_then(|c| Joint::new(plan, bones, i, c as usize));
    ring(b.tip, d, e1, r_tip, next, circle, scratch);
    let tip_first = push_ring(m, scratch);
    if next.is_none() {
        cap(m, b.tip, scratch, d, true);
    }
    for k in 0..sides {
        let (b0, b1) = (base_first + k, base_first + (k + 1) % sides);
        let (t0, t1) = (tip_first + k, tip_first + (k + 1) % sides);
        m.triangle(b0, b1, t1);
        m.triangle(b0, t1, t0);
        // The quad's normal (twice its area) from its diagonals, summed
        // into its corners' normals (see finish_normals).
        let p = |i: u32| Vec3::from_array(m.positions[i as usize]);
        let n = (p(t1) - p(b0)).cross(p(t0) - p(b1));
        if n.is_finite() {
            for v in [b0, b1, t0, t1] {
                let s = &mut m.normals[v as usize];
                *s = (Vec3::from_array(*s) + n).to_array();
            }
        }
    }
    Some(tip_first)
}

/// The vertices and triangles [`emit_bone`] makes for bone `i` with
/// `sides` ring vertices; `shared` when its base ring is its parent's tip
/// ring in the same mesh.
pub(crate) fn bone_size(plan: &TubePlan, i: usize, sides: u64, shared: bool) -> (u64, u64) {
    if plan.dir.get(i).is_none_or(Option::is_none) {
        return (0, 0);
    }
    let cap = (1 + sides, sides);
    let (mut v, mut t) = (sides, 2 * sides); // the tip ring and the sides
    if !plan.continues[i] {
        v += sides + cap.0; // a ring and a cap at the base
        t += cap.1;
    } else if !shared {
        v += sides;
    }
    if plan.next[i].is_none() {
        v += cap.0;
        t += cap.1;
    }
    (v, t)
}

/// Pushes a ring's vertices with zero normals, the sums its quads add to.
fn push_ring(m: &mut MeshData, ring: &[Vec3]) -> u32 {
    let first = m.positions.len() as u32;
    for p in ring {
        m.vertex(*p, Vec3::ZERO);
    }
    first
}

/// Normalises the normals of a mesh holding only tubes: the ring
/// vertices' sums of their quads' normals, and the caps' (already unit).
/// A ring vertex whose quads all have no area (a ring of f32-rounded
/// points) gets +Y.
pub(crate) fn finish_normals(m: &mut MeshData) {
    for n in &mut m.normals {
        let v = Vec3::from_array(*n);
        // Scaled first: a tiny model's sums square to below f32's range.
        let big = v.abs().max_element();
        *n = if big > 0.0 && big.is_finite() {
            (v / big).normalize().to_array()
        } else {
            Vec3::Y.to_array()
        };
    }
}

/// A flat cap over ring positions, facing `normal`; `ccw` when the ring
/// runs counter-clockwise seen from `normal`.
fn cap(m: &mut MeshData, centre: Vec3, ring: &[Vec3], normal: Vec3, ccw: bool) {
    let c = m.vertex(centre, normal);
    let first = m.positions.len() as u32;
    for p in ring {
        m.vertex(*p, normal);
    }
    let n = ring.len() as u32;
    for k in 0..n {
        let (a, b) = (first + k, first + (k + 1) % n);
        if ccw {
            m.triangle(c, a, b);
        } else {
            m.triangle(c, b, a);
        }
    }
}

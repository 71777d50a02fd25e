//! Property tests over random skeletons and polygons (grm-testkit's seeded
//! generator; `GRM_TEST_SEED=n` draws other inputs, `scripts/soak.sh`).
//!
//! * Tubes: for random bone trees (chains that turn by up to 180 degrees,
//!   lateral branches, jumps, zero-length bones, widths from 0 up), every
//!   part is an indexed mesh with indices in range, finite positions and
//!   unit normals; at moderate scales the model is a union of closed,
//!   consistently oriented surfaces and every tube triangle faces away
//!   from its bone's axis (no tube folds inside out at a bend); the picks
//!   cover the triangles in order.
//! * Polygons: a random simple (star-shaped) polygon in a random plane,
//!   with collinear and repeated vertices, triangulates into at most
//!   `n - 2` triangles that all face the Newell normal and whose areas add
//!   up to the polygon's (so they do not overlap).

mod common;

use common::edges_balanced;
use glam::{Quat, Vec3};
use grm_geom::{BuildOptions, MeshData, Model, PartSource, build_from_interpretation, polygon};
use grm_testkit::Rng;
use grm_turtle::{Bone, Interpretation, NO_ORIGIN, Paint};

fn unit_vector(rng: &mut Rng) -> Vec3 {
    loop {
        let v = Vec3::new(
            rng.range_f32(-1.0, 1.0),
            rng.range_f32(-1.0, 1.0),
            rng.range_f32(-1.0, 1.0),
        );
        let l = v.length();
        if l > 0.1 && l <= 1.0 {
            return v / l;
        }
    }
}

/// `d` turned by `angle` radians about a random axis perpendicular to it.
fn turned(rng: &mut Rng, d: Vec3, angle: f32) -> Vec3 {
    let axis = d
        .cross(unit_vector(rng))
        .normalize_or(d.any_orthonormal_vector());
    (Quat::from_axis_angle(axis, angle) * d).normalize()
}

/// A random skeleton as a turtle would make one: each bone continues the
/// current bone, starts a branch at an earlier bone's tip, or starts after
/// a jump; `scale` sets the lengths and `widths` the range of widths.
fn skeleton(rng: &mut Rng, n: usize, scale: f32, widths: (f32, f32)) -> Vec<Bone> {
    let mut bones: Vec<Bone> = Vec::with_capacity(n);
    let mut dirs: Vec<Vec3> = Vec::with_capacity(n);
    let width = |rng: &mut Rng| {
        if rng.below(8u32) == 0 {
            0.0
        } else {
            rng.range_f32(widths.0, widths.1)
        }
    };
    for i in 0..n {
        let kind = if i == 0 { 9 } else { rng.below(10u32) };
        let (base, parent, from_dir, width_base) = match kind {
            // Continue the last bone, or branch off an earlier one.
            0..=6 => {
                let p = if kind <= 4 { i - 1 } else { rng.below(i) };
                let b = &bones[p];
                (b.tip, Some(p as u32), dirs[p], b.width_tip)
            }
            // A jump (after `f`): a new base, the last bone still current.
            7 | 8 => {
                let p = i - 1;
                let off = unit_vector(rng) * rng.range_f32(0.1, 2.0) * scale;
                (bones[p].tip + off, Some(p as u32), dirs[p], width(rng))
            }
            _ => (
                Vec3::new(
                    rng.range_f32(-5.0, 5.0),
                    rng.range_f32(-5.0, 5.0),
                    rng.range_f32(-5.0, 5.0),
                ) * scale,
                None,
                unit_vector(rng),
                width(rng),
            ),
        };
        // Mostly small turns, sometimes sharp ones, reversals and exact
        // repeats (zero angle).
        let angle = match rng.below(10u32) {
            0 => 0.0,
            1 => std::f32::consts::PI,
            2 => rng.range_f32(1.5, 3.1),
            3 => std::f32::consts::FRAC_PI_2,
            _ => rng.range_f32(0.0, 0.8),
        };
        let d = turned(rng, from_dir, angle);
        let len = match rng.below(12u32) {
            0 => 0.0,
            1 => 1e-7 * scale,
            _ => rng.range_f32(0.05, 1.5) * scale,
        };
        let left = d.any_orthonormal_vector();
        bones.push(Bone {
            base,
            tip: base + d * len,
            left,
            parent,
            width_base,
            width_tip: width(rng),
            paint: Paint::Palette(rng.below(3u32)),
            module: i as u32,
            origin: NO_ORIGIN,
        });
        dirs.push(d);
    }
    bones
}

fn build(bones: Vec<Bone>) -> Model {
    let program = common::program("mem.grm", "system S { axiom F; }");
    let skeleton = Interpretation {
        bones,
        ..Interpretation::default()
    };
    build_from_interpretation(&program, skeleton, &BuildOptions::default(), &[]).expect("builds")
}

/// Indices in range, finite positions, one unit normal per position, and
/// the picks cover every triangle in order.
fn well_formed(model: &Model) -> Result<(), String> {
    for (k, part) in model.parts.iter().enumerate() {
        let m = &part.mesh;
        if m.normals.len() != m.positions.len() {
            return Err(format!("part {k}: normals and positions differ in number"));
        }
        if m.indices.len() % 3 != 0 {
            return Err(format!("part {k}: {} indices", m.indices.len()));
        }
        if let Some(i) = m.indices.iter().find(|&&i| i as usize >= m.positions.len()) {
            return Err(format!("part {k}: index {i} out of range"));
        }
        if let Some(p) = m
            .positions
            .iter()
            .find(|p| !p.iter().all(|x| x.is_finite()))
        {
            return Err(format!("part {k}: position {p:?}"));
        }
        if let Some(n) = m
            .normals
            .iter()
            .find(|n| (Vec3::from_array(**n).length() - 1.0).abs() > 1e-3)
        {
            return Err(format!("part {k}: normal {n:?}"));
        }
        let mut next = 0;
        for p in &part.picks {
            if p.first_triangle != next {
                return Err(format!("part {k}: picks not contiguous at {next}"));
            }
            next = p.first_triangle + p.triangle_count;
        }
        if next as usize != m.indices.len() / 3 {
            return Err(format!("part {k}: picks cover {next} triangles"));
        }
    }
    Ok(())
}

/// All parts as one mesh.
fn union(model: &Model) -> MeshData {
    let mut all = MeshData::default();
    for part in &model.parts {
        let first = all.positions.len() as u32;
        all.positions.extend_from_slice(&part.mesh.positions);
        all.normals.extend_from_slice(&part.mesh.normals);
        all.indices
            .extend(part.mesh.indices.iter().map(|i| i + first));
    }
    all
}

/// The first tube triangle that faces its bone's axis (a tube folded
/// inside out, as a mitre deeper than its tube is long makes one).
fn folded(model: &Model, bones: &[Bone]) -> Option<String> {
    for (k, part) in model.parts.iter().enumerate() {
        let m = &part.mesh;
        for pick in &part.picks {
            let PartSource::Bone(i) = pick.source else {
                continue;
            };
            let b = &bones[i as usize];
            let d = (b.tip - b.base).normalize();
            let first = pick.first_triangle as usize;
            for t in first..first + pick.triangle_count as usize {
                let p = |j: usize| Vec3::from_array(m.positions[m.indices[3 * t + j] as usize]);
                let g = (p(1) - p(0)).cross(p(2) - p(0));
                let c = (p(0) + p(1) + p(2)) / 3.0 - b.base;
                let radial = c - d * c.dot(d);
                // Triangles near a pinched elbow may stand almost edge-on
                // to the axis; a folded one faces it.
                let facing = g.normalize().dot(radial.normalize());
                if g.length() > 1e-9 && radial.length() > 1e-5 && facing < -0.25 {
                    return Some(format!(
                        "part {k}: triangle {t} of bone {i}'s tube faces its axis ({facing})"
                    ));
                }
            }
        }
    }
    None
}

fn describe(bones: &[Bone]) -> String {
    bones
        .iter()
        .enumerate()
        .map(|(i, b)| {
            format!(
                "  {i}: {:?} -> {:?} parent {:?} widths {} {}\n",
                b.base, b.tip, b.parent, b.width_base, b.width_tip
            )
        })
        .collect()
}

#[test]
fn random_skeletons_give_closed_well_formed_tubes() {
    let mut rng = Rng::seeded(0x6e0_7be5);
    for case in 0..300 {
        let n = 1 + rng.below(24usize);
        let bones = skeleton(&mut rng, n, 1.0, (0.02, 0.3));
        let model = build(bones.clone());
        if let Err(e) = well_formed(&model) {
            panic!("case {case}: {e}\n{}", describe(&bones));
        }
        // A chain whose paint changes is split between two parts at a
        // shared ring, and tubes may touch: the union is closed.
        let all = union(&model);
        assert!(
            edges_balanced(&all),
            "case {case}: the tubes are not closed\n{}",
            describe(&bones)
        );
        if let Some(e) = folded(&model, &bones) {
            panic!("case {case}: {e}\n{}", describe(&bones));
        }
    }
}

#[test]
fn extreme_skeletons_stay_finite() {
    let mut rng = Rng::seeded(0xe87_7e3e);
    for case in 0..200 {
        let n = 1 + rng.below(16usize);
        let scale = *rng.pick(&[1e-4f32, 1e-2, 1.0, 1e3, 1e5]);
        let widths = *rng.pick(&[(1e-7f32, 1e-5), (1e-3, 1.0), (10.0, 1e4)]);
        let bones = skeleton(&mut rng, n, scale, (widths.0 * scale, widths.1 * scale));
        let model = build(bones.clone());
        if let Err(e) = well_formed(&model) {
            panic!("case {case} (scale {scale}): {e}\n{}", describe(&bones));
        }
        // Finite, or empty when no bone got a tube (min > max).
        let b = model.stats.bounds;
        assert!(
            (b.min.is_finite() && b.max.is_finite())
                || (model.stats.triangles == 0 && b.min.x > b.max.x),
            "case {case}: bounds {b:?}"
        );
    }
}

/// Twice the signed area of triangle `t` of `vs`, along `normal`.
fn signed_area2(vs: &[Vec3], t: [u32; 3], normal: Vec3) -> f32 {
    let p = |i: u32| vs[i as usize];
    (p(t[1]) - p(t[0])).cross(p(t[2]) - p(t[0])).dot(normal)
}

/// A simple star-shaped polygon around the origin of the plane through
/// `centre` with normal `n`, counter-clockwise about `n`; some vertices lie
/// on the segment between their neighbours (collinear) and some repeat.
fn star_polygon(rng: &mut Rng, centre: Vec3, n: Vec3) -> Vec<Vec3> {
    let u = n.any_orthonormal_vector();
    let v = n.cross(u);
    let count = 3 + rng.below(14usize);
    // Gaps under half a turn (at most 1.4 / 3 of one), so the centre sees
    // every edge from inside and the polygon is simple.
    let step = std::f32::consts::TAU / count as f32;
    let angles: Vec<f32> = (0..count)
        .map(|k| (k as f32 + rng.range_f32(0.0, 0.4)) * step)
        .collect();
    let mut pts: Vec<Vec3> = angles
        .iter()
        .map(|&a| {
            let r = if rng.below(3u32) == 0 {
                1.0
            } else {
                rng.range_f32(0.2, 1.0)
            };
            centre + (u * a.cos() + v * a.sin()) * r
        })
        .collect();
    // Collinear points: the midpoint of a random edge; repeats.
    for _ in 0..rng.below(3usize) {
        let i = rng.below(pts.len());
        let j = (i + 1) % pts.len();
        let t = *rng.pick(&[0.5f32, 0.25]);
        let m = pts[i].lerp(pts[j], t);
        // Between `i` and `j`: at `j`, or at the end when `j` wraps to 0.
        if j == 0 {
            pts.push(m);
        } else {
            pts.insert(j, m);
        }
    }
    if rng.below(4u32) == 0 && pts.len() > 3 {
        let i = rng.below(pts.len());
        let p = pts[i];
        pts.insert(i, p);
    }
    pts
}

/// Area of a polygon in its plane from its 2D shoelace formula, which is
/// what `newell_normal` computes; checked independently by fanning from
/// the star's centre, which lies inside.
fn star_area(pts: &[Vec3], centre: Vec3, n: Vec3) -> f32 {
    (0..pts.len())
        .map(|i| {
            let (a, b) = (pts[i] - centre, pts[(i + 1) % pts.len()] - centre);
            0.5 * a.cross(b).dot(n)
        })
        .sum()
}

#[test]
fn random_simple_polygons_triangulate_exactly() {
    let mut rng = Rng::seeded(0x9017_90e5);
    let mut tris = Vec::new();
    for case in 0..2000 {
        let n = unit_vector(&mut rng);
        let centre = Vec3::new(
            rng.range_f32(-3.0, 3.0),
            rng.range_f32(-3.0, 3.0),
            rng.range_f32(-3.0, 3.0),
        );
        let pts = star_polygon(&mut rng, centre, n);
        if pts.len() < 3 {
            continue;
        }
        let want = star_area(&pts, centre, n);
        let newell = polygon::newell_normal(&pts);
        let normal = newell.normalize();
        assert!(
            (0.5 * newell.length() - want).abs() < 1e-4 * want.max(1.0),
            "case {case}: Newell area {} against {want}",
            0.5 * newell.length()
        );
        polygon::triangulate(&pts, normal, &mut tris);
        let got: f32 = tris
            .iter()
            .map(|t| 0.5 * signed_area2(&pts, *t, normal))
            .sum();
        let flipped = tris
            .iter()
            .filter(|t| signed_area2(&pts, **t, normal) < -1e-5)
            .count();
        assert!(
            tris.len() <= pts.len() - 2
                && flipped == 0
                && (got - want).abs() < 1e-4 * want.max(1.0),
            "case {case}: {} triangles for {} vertices, {flipped} facing away, area {got} against {want}\n{pts:?}\n{tris:?}",
            tris.len(),
            pts.len()
        );
    }
}

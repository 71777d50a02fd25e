//! Roofs and taper (docs/shapes.md, "Roofs and taper"): the straight
//! skeleton on rectangles, L, U and T footprints and random ones (every
//! face planar at its pitch, the faces tiling the footprint, heights never
//! negative), the roof kinds with hand-checked values, and roofs in
//! derivations (named faces and edges, overhang, determinism).
//! (`GRM_TEST_SEED=n` draws other random footprints.)

use grm_shape::Outline;
use grm_shape::roof::{self, FaceKind, Roof, RoofError, RoofKind, Skeleton, skeleton};
use grm_testkit::Rng;

const EPS: f64 = 1e-7;

fn close(a: f64, b: f64, what: &str) {
    assert!(
        (a - b).abs() <= EPS * a.abs().max(b.abs()).max(1.0),
        "{what}: {a} != {b}"
    );
}

fn area2(r: &[[f64; 2]]) -> f64 {
    let n = r.len();
    (0..n)
        .map(|i| r[i][0] * r[(i + 1) % n][1] - r[(i + 1) % n][0] * r[i][1])
        .sum::<f64>()
        * 0.5
}

/// The signed distance of `p` from edge `i`'s line, positive inside.
fn inside_dist(ring: &[[f64; 2]], i: usize, p: [f64; 2]) -> f64 {
    let n = ring.len();
    let (a, b) = (ring[i], ring[(i + 1) % n]);
    let d = [b[0] - a[0], b[1] - a[1]];
    let l = d[0].hypot(d[1]);
    (d[0] * (p[1] - a[1]) - d[1] * (p[0] - a[0])) / l
}

fn in_polygon(p: [f64; 2], poly: &[[f64; 2]]) -> bool {
    let n = poly.len();
    let mut inside = false;
    for i in 0..n {
        let (a, b) = (poly[i], poly[(i + 1) % n]);
        if (a[1] > p[1]) != (b[1] > p[1]) {
            let x = a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
            if p[0] < x {
                inside = !inside;
            }
        }
    }
    inside
}

fn seg_dist(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let d = [b[0] - a[0], b[1] - a[1]];
    let l2 = d[0] * d[0] + d[1] * d[1];
    let t = if l2 > 0.0 {
        (((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p[0] - a[0] - t * d[0]).hypot(p[1] - a[1] - t * d[1])
}

/// The skeleton's invariants for `ring` with `weights`: each face starts
/// with its edge, every node of face `i` is at height `t` with `w_i * t`
/// its distance inside edge `i`'s line (planar at the pitch; a weight-0
/// face stands on its edge's line), no height is negative, the faces of
/// moving edges turn counter-clockwise and their areas add up to the
/// footprint's, and sample points of the footprint lie in exactly one of
/// them.
fn check(ring: &[[f64; 2]], weights: &[f64], sk: &Skeleton, rng: &mut Rng, what: &str) {
    let n = ring.len();
    assert_eq!(sk.faces.len(), n, "{what}: one face per edge");
    let scale = ring
        .iter()
        .flat_map(|p| [p[0].abs(), p[1].abs()])
        .fold(1.0, f64::max);
    let tol = 1e-6 * scale;
    let mut total = 0.0;
    let mut polys = Vec::new();
    for (i, face) in sk.faces.iter().enumerate() {
        assert_eq!(face[0] as usize, i, "{what}: face {i} starts at its edge");
        assert_eq!(face[1] as usize, (i + 1) % n, "{what}: face {i}");
        let pts: Vec<[f64; 3]> = face.iter().map(|&k| sk.nodes[k as usize]).collect();
        for p in &pts {
            assert!(p[2] >= -tol, "{what}: face {i} has a negative height {p:?}");
            let d = inside_dist(ring, i, [p[0], p[1]]);
            assert!(
                (d - weights[i] * p[2]).abs() <= tol,
                "{what}: face {i} point {p:?} is {d} inside its edge's line, not {}",
                weights[i] * p[2]
            );
        }
        let flat: Vec<[f64; 2]> = pts.iter().map(|p| [p[0], p[1]]).collect();
        let a = area2(&flat);
        if weights[i] > 0.0 {
            assert!(a > -tol * tol, "{what}: face {i} turns clockwise ({a})");
            polys.push(flat);
        } else {
            assert!(
                a.abs() <= tol * scale,
                "{what}: gable face {i} has area {a}"
            );
        }
        total += a;
    }
    let whole = area2(ring);
    assert!(
        (total - whole).abs() <= 1e-6 * whole.max(1.0),
        "{what}: the faces cover {total}, the footprint {whole}"
    );
    // Sample points: each interior point in exactly one face.
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in ring {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let margin = 1e-5 * scale;
    let mut sampled = 0;
    for _ in 0..400 {
        let p = [rng.range(lo[0], hi[0]), rng.range(lo[1], hi[1])];
        if !in_polygon(p, ring) {
            continue;
        }
        let near = polys.iter().any(|poly| {
            (0..poly.len()).any(|k| seg_dist(p, poly[k], poly[(k + 1) % poly.len()]) < margin)
        });
        if near {
            continue;
        }
        sampled += 1;
        let count = polys.iter().filter(|poly| in_polygon(p, poly)).count();
        assert_eq!(count, 1, "{what}: point {p:?} lies in {count} faces");
    }
    assert!(sampled > 0 || whole < 1e-9, "{what}: no point sampled");
}

fn hip(ring: &[[f64; 2]]) -> Skeleton {
    skeleton(ring, &vec![1.0; ring.len()]).unwrap_or_else(|e| panic!("{ring:?}: {e}"))
}

fn rect(w: f64, h: f64) -> Vec<[f64; 2]> {
    vec![[0.0, 0.0], [w, 0.0], [w, h], [0.0, h]]
}

fn l_shape() -> Vec<[f64; 2]> {
    vec![
        [0.0, 0.0],
        [10.0, 0.0],
        [10.0, 4.0],
        [4.0, 4.0],
        [4.0, 10.0],
        [0.0, 10.0],
    ]
}

fn u_shape() -> Vec<[f64; 2]> {
    vec![
        [0.0, 0.0],
        [12.0, 0.0],
        [12.0, 10.0],
        [8.0, 10.0],
        [8.0, 4.0],
        [4.0, 4.0],
        [4.0, 10.0],
        [0.0, 10.0],
    ]
}

fn t_shape() -> Vec<[f64; 2]> {
    vec![
        [4.0, 0.0],
        [8.0, 0.0],
        [8.0, 6.0],
        [12.0, 6.0],
        [12.0, 10.0],
        [0.0, 10.0],
        [0.0, 6.0],
        [4.0, 6.0],
    ]
}

#[test]
fn rectangle_hip_skeleton_has_a_ridge_of_length_4_at_height_3() {
    let ring = rect(10.0, 6.0);
    let sk = hip(&ring);
    check(&ring, &[1.0; 4], &sk, &mut Rng::new(1), "10x6");
    // Front face: a trapezoid up to the ridge (7,3)-(3,3) at t = 3.
    let front: Vec<[f64; 3]> = sk.faces[0].iter().map(|&k| sk.nodes[k as usize]).collect();
    assert_eq!(
        front,
        vec![
            [0.0, 0.0, 0.0],
            [10.0, 0.0, 0.0],
            [7.0, 3.0, 3.0],
            [3.0, 3.0, 3.0]
        ]
    );
    // The right end: a triangle.
    assert_eq!(sk.faces[1].len(), 3);
    let top = sk.nodes.iter().map(|p| p[2]).fold(0.0, f64::max);
    close(top, 3.0, "height");
}

#[test]
fn square_hip_meets_in_one_apex() {
    let ring = rect(8.0, 8.0);
    let sk = hip(&ring);
    check(&ring, &[1.0; 4], &sk, &mut Rng::new(2), "square");
    for f in &sk.faces {
        assert_eq!(f.len(), 3);
        assert_eq!(sk.nodes[f[2] as usize], [4.0, 4.0, 4.0]);
    }
}

#[test]
fn l_u_t_skeletons_are_planar_and_tile() {
    let mut rng = Rng::new(3);
    for (name, ring) in [("L", l_shape()), ("U", u_shape()), ("T", t_shape())] {
        let sk = hip(&ring);
        check(&ring, &vec![1.0; ring.len()], &sk, &mut rng, name);
    }
    // The L (arms 4 wide): 6 faces, ridge height 2 everywhere.
    let sk = hip(&l_shape());
    let top = sk.nodes.iter().map(|p| p[2]).fold(0.0, f64::max);
    close(top, 2.0, "L ridge");
}

#[test]
fn gable_weights_make_vertical_ends() {
    let ring = rect(10.0, 6.0);
    let w = [1.0, 0.0, 1.0, 0.0];
    let sk = skeleton(&ring, &w).unwrap();
    check(&ring, &w, &sk, &mut Rng::new(4), "gable 10x6");
    let right: Vec<[f64; 3]> = sk.faces[1].iter().map(|&k| sk.nodes[k as usize]).collect();
    assert_eq!(
        right,
        vec![[10.0, 0.0, 0.0], [10.0, 6.0, 0.0], [10.0, 3.0, 3.0]]
    );
}

#[test]
fn skeleton_refuses_bad_input_without_panicking() {
    assert!(skeleton(&[[0.0, 0.0], [1.0, 0.0]], &[1.0, 1.0]).is_err());
    assert!(skeleton(&rect(1.0, 1.0), &[0.0; 4]).is_err());
    assert!(skeleton(&rect(f64::NAN, 1.0), &[1.0; 4]).is_err());
    // Clockwise.
    let mut cw = rect(2.0, 1.0);
    cw.reverse();
    assert!(skeleton(&cw, &[1.0; 4]).is_err());
    let many: Vec<[f64; 2]> = (0..300)
        .map(|i| {
            let a = i as f64 / 300.0 * std::f64::consts::TAU;
            [a.cos(), a.sin()]
        })
        .collect();
    assert!(matches!(
        skeleton(&many, &vec![1.0; 300]),
        Err(RoofError::TooManyVertices { count: 300, .. })
    ));
}

// ---------------------------------------------------------------------------
// Random footprints.

/// Drops straight corners (the skeleton's input has none).
fn clean(ring: Vec<[f64; 2]>) -> Vec<[f64; 2]> {
    let mut r = ring;
    loop {
        let n = r.len();
        if n < 3 {
            return r;
        }
        let straight = (0..n).find(|&i| {
            let (a, b, c) = (r[(i + n - 1) % n], r[i], r[(i + 1) % n]);
            let cross = (b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0]);
            cross.abs() < 1e-12 || (a == b)
        });
        match straight {
            Some(i) => {
                r.remove(i);
            }
            None => return r,
        }
    }
}

/// A star-shaped polygon around the origin.
fn star(rng: &mut Rng) -> Vec<[f64; 2]> {
    // Jittered angles: no gap reaches half a turn, so the origin is inside.
    let n = 4 + rng.below(12u32) as usize;
    let angles: Vec<f64> = (0..n)
        .map(|i| (i as f64 + rng.range(0.0, 0.5)) / n as f64 * std::f64::consts::TAU)
        .collect();
    angles
        .iter()
        .map(|a| {
            let r = rng.range(3.0, 10.0);
            [r * a.cos(), r * a.sin()]
        })
        .collect()
}

/// A skyline: a flat base and a rectilinear top (on integers half the
/// time, where events coincide).
fn skyline(rng: &mut Rng) -> Vec<[f64; 2]> {
    let k = 1 + rng.below(6u32) as usize;
    let int = rng.below(2u32) == 0;
    let mut draw = |lo: f64, hi: f64| {
        let v = rng.range(lo, hi);
        if int { v.round().max(lo.ceil()) } else { v }
    };
    let mut xs = vec![0.0];
    for _ in 0..k {
        let last = *xs.last().unwrap_or(&0.0);
        xs.push(last + draw(1.0, 6.0));
    }
    let heights: Vec<f64> = (0..k).map(|_| draw(1.0, 8.0)).collect();
    let mut ring = vec![[0.0, 0.0], [xs[k], 0.0]];
    for i in (0..k).rev() {
        ring.push([xs[i + 1], heights[i]]);
        ring.push([xs[i], heights[i]]);
    }
    clean(ring)
}

/// An L, U or T with random arms.
fn letter(rng: &mut Rng) -> Vec<[f64; 2]> {
    let w = rng.range(6.0, 14.0);
    let h = rng.range(6.0, 14.0);
    let a = rng.range(1.0, 5.0);
    // Arms narrower than half the width, so a U's notch stays open.
    let b = rng.range(1.0, w / 2.0 - 0.2);
    match rng.below(3u32) {
        0 => vec![[0.0, 0.0], [w, 0.0], [w, a], [b, a], [b, h], [0.0, h]],
        1 => vec![
            [0.0, 0.0],
            [w, 0.0],
            [w, h],
            [w - b, h],
            [w - b, a],
            [b, a],
            [b, h],
            [0.0, h],
        ],
        _ => {
            let s = (w - b) / 2.0;
            vec![
                [s, 0.0],
                [s + b, 0.0],
                [s + b, h - a],
                [w, h - a],
                [w, h],
                [0.0, h],
                [0.0, h - a],
                [s, h - a],
            ]
        }
    }
}

#[test]
fn random_footprints_skeletons_hold_their_invariants() {
    let mut rng = Rng::seeded(2626);
    let mut built = 0;
    for case in 0..300 {
        let ring = match case % 3 {
            0 => star(&mut rng),
            1 => skyline(&mut rng),
            _ => letter(&mut rng),
        };
        if ring.len() < 3 || area2(&ring) <= 0.0 {
            continue;
        }
        let what = format!("case {case}: {ring:?}");
        let weights: Vec<f64> = if rng.below(3u32) == 0 {
            roof::gable_edges(&ring)
                .into_iter()
                .map(|g| if g { 0.0 } else { 1.0 })
                .collect()
        } else {
            vec![1.0; ring.len()]
        };
        match skeleton(&ring, &weights) {
            Ok(sk) => {
                built += 1;
                check(&ring, &weights, &sk, &mut rng, &what);
            }
            Err(e) => panic!("{what}: {e}"),
        }
    }
    assert!(built > 250, "{built} built");
}

#[test]
fn random_rings_never_panic() {
    let mut rng = Rng::seeded(2627);
    for _ in 0..300 {
        let n = 3 + rng.below(10u32) as usize;
        let ring: Vec<[f64; 2]> = (0..n)
            .map(|_| [rng.range(0.0, 10.0), rng.range(0.0, 10.0)])
            .collect();
        let w: Vec<f64> = (0..n).map(|_| f64::from(rng.below(2u32))).collect();
        let _ = skeleton(&ring, &w);
        if let Ok(o) = Outline::from_ring(&ring) {
            for kind in [
                RoofKind::Flat,
                RoofKind::Hip,
                RoofKind::Gable,
                RoofKind::Shed,
                RoofKind::Pyramid,
            ] {
                let _ = roof::build(&o, kind, rng.range(0.0, 89.0), rng.range(-1.0, 2.0));
            }
            let _ = roof::taper(&o, rng.range(0.0, 5.0));
        }
    }
}

// ---------------------------------------------------------------------------
// Roof kinds.

fn outline(ring: &[[f64; 2]]) -> Outline {
    Outline::from_ring(ring).unwrap()
}

fn faces_of(r: &Roof, kind: FaceKind) -> Vec<Vec<[f64; 3]>> {
    r.faces()
        .iter()
        .filter(|f| f.kind == kind)
        .map(|f| r.face_points(f))
        .collect()
}

fn top(r: &Roof) -> f64 {
    r.points()
        .iter()
        .map(|p| p[2])
        .fold(f64::NEG_INFINITY, f64::max)
}

#[test]
fn hip_roof_on_10x6_at_45_degrees() {
    let r = roof::build(&outline(&rect(10.0, 6.0)), RoofKind::Hip, 45.0, 0.0).unwrap();
    close(top(&r), 3.0, "height");
    assert_eq!(faces_of(&r, FaceKind::Slope).len(), 4);
    assert_eq!(faces_of(&r, FaceKind::Bottom).len(), 1);
    // The ridge: the points at the top, 4 apart.
    let ridge: Vec<[f64; 3]> = r
        .points()
        .iter()
        .copied()
        .filter(|p| (p[2] - 3.0).abs() < 1e-9)
        .collect();
    let (lo, hi) = ridge
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |a, p| {
            (a.0.min(p[0]), a.1.max(p[0]))
        });
    close(hi - lo, 4.0, "ridge length");
    close(r.footprint_area(), 60.0, "footprint");
    // A prism 4 long of section 9 and two half pyramids of 3 x 6 x 3.
    close(r.volume(), 36.0 + 2.0 * 18.0, "volume");
}

#[test]
fn gable_roof_on_10x6_has_two_vertical_ends() {
    let r = roof::build(&outline(&rect(10.0, 6.0)), RoofKind::Gable, 45.0, 0.0).unwrap();
    let gables = faces_of(&r, FaceKind::Gable);
    assert_eq!(gables.len(), 2);
    for g in &gables {
        assert!(g.iter().all(|p| p[0] == 0.0 || p[0] == 10.0), "{g:?}");
    }
    close(
        r.face_area(FaceKind::Gable),
        2.0 * 0.5 * 6.0 * 3.0,
        "gable ends",
    );
    assert_eq!(faces_of(&r, FaceKind::Slope).len(), 2);
    // Two slopes of 10 x 3 * sqrt(2).
    close(
        r.face_area(FaceKind::Slope),
        2.0 * 10.0 * 18f64.sqrt(),
        "slopes",
    );
    close(r.volume(), 0.5 * 6.0 * 3.0 * 10.0, "volume");
}

#[test]
fn gable_rule_on_square_l_and_hexagon() {
    // A square: the left and right edges are the gables (ridge along x).
    assert_eq!(
        roof::gable_edges(&rect(8.0, 8.0)),
        vec![false, true, false, true]
    );
    // An L: its two wing ends.
    assert_eq!(
        roof::gable_edges(&l_shape()),
        vec![false, true, false, false, true, false]
    );
    // No right angles: no gables, the gable roof is the hip roof.
    let hex: Vec<[f64; 2]> = (0..6)
        .map(|i| {
            let a = f64::from(i) * std::f64::consts::TAU / 6.0;
            [5.0 + 4.0 * a.cos(), 5.0 + 4.0 * a.sin()]
        })
        .collect();
    let g = roof::build(&outline(&hex), RoofKind::Gable, 30.0, 0.0).unwrap();
    let h = roof::build(&outline(&hex), RoofKind::Hip, 30.0, 0.0).unwrap();
    assert_eq!((g.points(), g.faces()), (h.points(), h.faces()));
}

#[test]
fn shed_roof_rises_from_the_front_edge() {
    let r = roof::build(&outline(&rect(10.0, 6.0)), RoofKind::Shed, 45.0, 0.0).unwrap();
    let slopes = faces_of(&r, FaceKind::Slope);
    assert_eq!(slopes.len(), 1);
    for p in &slopes[0] {
        close(p[2], p[1], "one plane rising with y at 45 degrees");
    }
    close(top(&r), 6.0, "height");
    // The back wall 10 x 6 and two side triangles 6 x 6 / 2.
    assert_eq!(faces_of(&r, FaceKind::Gable).len(), 3);
    close(r.face_area(FaceKind::Gable), 60.0 + 2.0 * 18.0, "walls");
}

#[test]
fn pyramid_of_a_square() {
    let r = roof::build(&outline(&rect(8.0, 8.0)), RoofKind::Pyramid, 45.0, 0.0).unwrap();
    assert_eq!(faces_of(&r, FaceKind::Slope).len(), 4);
    close(top(&r), 4.0, "apex");
    close(r.volume(), 64.0 * 4.0 / 3.0, "volume");
    let apex = r.points().iter().find(|p| p[2] > 3.9).copied().unwrap();
    for v in apex {
        close(v, 4.0, "apex");
    }
    // Not star-shaped from its centroid: refused.
    let c = vec![
        [0.0, 0.0],
        [10.0, 0.0],
        [10.0, 1.0],
        [1.0, 1.0],
        [1.0, 9.0],
        [10.0, 9.0],
        [10.0, 10.0],
        [0.0, 10.0],
    ];
    assert_eq!(
        roof::build(&outline(&c), RoofKind::Pyramid, 30.0, 0.0),
        Err(RoofError::NotStarShaped)
    );
}

#[test]
fn flat_roof_and_overhang() {
    let r = roof::build(&outline(&rect(10.0, 6.0)), RoofKind::Flat, 30.0, 0.5).unwrap();
    assert_eq!(r.faces().len(), 1);
    close(r.footprint_area(), 11.0 * 7.0, "flat with overhang");
    close(top(&r), 0.0, "flat");
    // A hip with overhang 1 at 45 degrees: eaves 1 lower and 1 out; the
    // slopes still pass through the walls' tops at height 0.
    let r = roof::build(&outline(&rect(10.0, 6.0)), RoofKind::Hip, 45.0, 1.0).unwrap();
    let (lo, hi) = r.bounds();
    close(lo[2], -1.0, "eaves lowered by d tan(angle)");
    close(lo[0], -1.0, "out by d");
    close(hi[2], 3.0, "ridge height unchanged");
    close(hi[0] - lo[0], 12.0, "width");
}

#[test]
fn l_shaped_hip_faces_are_planar() {
    let r = roof::build(&outline(&l_shape()), RoofKind::Hip, 30.0, 0.0).unwrap();
    let slopes = faces_of(&r, FaceKind::Slope);
    assert_eq!(slopes.len(), 6);
    let t = 30f64.to_radians().tan();
    let ring = l_shape();
    for (i, f) in slopes.iter().enumerate() {
        for p in f {
            close(p[2], t * inside_dist(&ring, i, [p[0], p[1]]), "pitch");
        }
    }
    close(r.footprint_area(), area2(&ring), "tiles");
}

#[test]
fn taper_meets_over_the_centroid() {
    let r = roof::taper(&outline(&rect(10.0, 6.0)), 7.0).unwrap();
    assert_eq!(faces_of(&r, FaceKind::Slope).len(), 4);
    assert!(r.points().contains(&[5.0, 3.0, 7.0]));
    close(r.volume(), 60.0 * 7.0 / 3.0, "volume");
}

#[test]
fn holes_are_refused() {
    use geo::{LineString, MultiPolygon, Polygon};
    let ring = |pts: &[(f64, f64)]| LineString::from(pts.to_vec());
    let court = Polygon::new(
        ring(&[
            (0.0, 0.0),
            (10.0, 0.0),
            (10.0, 10.0),
            (0.0, 10.0),
            (0.0, 0.0),
        ]),
        vec![ring(&[
            (3.0, 3.0),
            (3.0, 7.0),
            (7.0, 7.0),
            (7.0, 3.0),
            (3.0, 3.0),
        ])],
    );
    let o = Outline::new(MultiPolygon::new(vec![court]));
    assert_eq!(
        roof::build(&o, RoofKind::Hip, 30.0, 0.0),
        Err(RoofError::Holes)
    );
    assert_eq!(
        roof::build(&outline(&rect(1.0, 1.0)), RoofKind::Hip, 90.0, 0.0),
        Err(RoofError::BadAngle(90.0))
    );
}

// ---------------------------------------------------------------------------
// Roofs in derivations.

mod derive {
    use super::{close, l_shape};
    use glam::Vec3;
    use grm_shape::roof::RoofKind;
    use grm_shape::{
        Axis, Comp, CompCase, CompTarget, Geom, Lot, NodeId, NodeKind, Op, Options, Param, Part,
        Program, ProgramBuilder, RoofError, Selector, ShapeError, ShapeTree, Split, SymbolId,
        derive,
    };

    fn roof_op(kind: RoofKind, angle: f32, overhang: f32) -> Op {
        Op::Roof {
            kind,
            angle: Param::Const(angle),
            overhang: Param::Const(overhang),
        }
    }

    fn comp(target: CompTarget, cases: &[(Selector, SymbolId)]) -> Op {
        Op::Comp(Comp {
            target,
            cases: cases
                .iter()
                .map(|&(selector, s)| CompCase {
                    selector,
                    target: Some(s),
                })
                .collect(),
            tag: None,
        })
    }

    fn of(tree: &ShapeTree, program: &Program, name: &str) -> Vec<NodeId> {
        let s = program.symbol(name).unwrap();
        tree.nodes()
            .iter()
            .enumerate()
            .filter(|(_, n)| matches!(n.kind, NodeKind::Shape { symbol, .. } if symbol == s))
            .map(|(i, _)| NodeId(i as u32))
            .collect()
    }

    /// `Lot -> extrude(5) Roof; Roof -> roof(kind, 45, d) comp(faces) {
    /// slope: Slope | gable: Gable | bottom: Under } comp(edges) { eave:
    /// Eave | ridge: Ridge | hip: Hip | valley: Valley | rake: Rake }`.
    fn house(kind: RoofKind, overhang: f32) -> Program {
        let mut b = ProgramBuilder::new("house");
        let lot = b.symbol("Lot");
        let roof = b.symbol("Roof");
        let names = [
            "Slope", "Gable", "Under", "Eave", "Ridge", "Hip", "Valley", "Rake",
        ];
        let s: Vec<SymbolId> = names.iter().map(|n| b.symbol(n)).collect();
        b.rule(lot, vec![Op::Extrude(Param::Const(5.0)), Op::Emit(roof)]);
        b.rule(
            roof,
            vec![
                roof_op(kind, 45.0, overhang),
                comp(
                    CompTarget::Faces,
                    &[
                        (Selector::Slope, s[0]),
                        (Selector::Gable, s[1]),
                        (Selector::Bottom, s[2]),
                    ],
                ),
                comp(
                    CompTarget::Edges,
                    &[
                        (Selector::Eave, s[3]),
                        (Selector::Ridge, s[4]),
                        (Selector::Hip, s[5]),
                        (Selector::Valley, s[6]),
                        (Selector::Rake, s[7]),
                    ],
                ),
            ],
        );
        b.build(lot).unwrap()
    }

    fn grow(p: &Program, lot: &Lot) -> ShapeTree {
        derive(p, lot, &Options::default()).unwrap()
    }

    /// Every node's exact locator, roof faces and edges included (`slope
    /// 2`, `eave 1`, `rake 3`), reads back from its text and finds the
    /// node (the form glb extras and `--tree` carry).
    #[test]
    fn roof_components_locators_read_back() {
        use grm_shape::{ExactLocator, Resolution};
        for kind in [RoofKind::Hip, RoofKind::Gable] {
            let p = house(kind, 0.3);
            let tree = grow(&p, &Lot::footprint(&l_shape()).unwrap());
            let mut roof_parts = 0;
            for i in 0..tree.len() as u32 {
                let id = NodeId(i);
                let loc = tree.exact_locator(&p, id);
                let text = loc.to_string();
                let back: ExactLocator = text.parse().unwrap_or_else(|e| panic!("{text}: {e}"));
                assert_eq!(back, loc, "{text}");
                assert_eq!(tree.resolve(&p, &back), Resolution::Found(id), "{text}");
                roof_parts += usize::from(
                    ["slope ", "eave ", "rake ", "hip ", "gable "]
                        .iter()
                        .any(|s| text.contains(s)),
                );
            }
            assert!(roof_parts > 5, "{kind:?}: {roof_parts} roof components");
        }
    }

    fn near(a: Vec3, b: Vec3) {
        assert!((a - b).length() < 1e-4, "{a} != {b}");
    }

    #[test]
    fn hip_roof_on_a_mass_stands_on_its_top() {
        let p = house(RoofKind::Hip, 0.0);
        let tree = grow(&p, &Lot::rectangle(10.0, 6.0));
        // The roof shape keeps the mass it was made with; its rule turned
        // that into the roof solid, which the component split divided.
        let roof = of(&tree, &p, "Roof")[0];
        near(
            tree.node(roof).unwrap().scope.size,
            Vec3::new(10.0, 6.0, 5.0),
        );
        let slopes = of(&tree, &p, "Slope");
        let split = tree.parent(slopes[0]).unwrap();
        assert!(matches!(tree.geom(split), Some(Geom::Roof(_))));
        let n = tree.node(split).unwrap();
        near(n.scope.origin, Vec3::new(0.0, 0.0, 5.0));
        near(n.scope.size, Vec3::new(10.0, 6.0, 3.0));
        close(tree.volume(split), 72.0, "roof volume");
        assert_eq!(slopes.len(), 4);
        assert_eq!(of(&tree, &p, "Gable").len(), 0);
        assert_eq!(of(&tree, &p, "Under").len(), 1);
        // Slope 1: the front, a trapezoid 10 wide at the eave, 3 * sqrt 2 up.
        let front = tree.node(slopes[0]).unwrap();
        assert_eq!(front.selector, Some(Selector::Slope));
        assert_eq!((front.index, front.count), (1, 4));
        near(front.scope.origin, Vec3::new(0.0, 0.0, 5.0));
        near(front.scope.axis(Axis::X), Vec3::X);
        near(
            front.scope.axis(Axis::Z),
            Vec3::new(0.0, -1.0, 1.0).normalize(),
        );
        near(front.scope.size, Vec3::new(10.0, 18f32.sqrt(), 0.0));
        close(
            tree.area(slopes[0]),
            0.5 * (10.0 + 4.0) * 18f64.sqrt(),
            "front slope",
        );
        // Right end: a triangle 6 wide.
        close(tree.area(slopes[1]), 0.5 * 6.0 * 18f64.sqrt(), "hip end");
        // Edges: 4 eaves, 1 ridge of length 4 at height 8, 4 hips.
        assert_eq!(of(&tree, &p, "Eave").len(), 4);
        let ridge = of(&tree, &p, "Ridge");
        assert_eq!(ridge.len(), 1);
        let r = tree.node(ridge[0]).unwrap();
        close(f64::from(r.scope.size.x), 4.0, "ridge length");
        close(f64::from(r.scope.origin.z), 8.0, "ridge height");
        assert_eq!(of(&tree, &p, "Hip").len(), 4);
        assert_eq!(of(&tree, &p, "Valley").len(), 0);
    }

    #[test]
    fn gable_roof_names_its_ends() {
        let p = house(RoofKind::Gable, 0.0);
        let tree = grow(&p, &Lot::rectangle(10.0, 6.0));
        let gables = of(&tree, &p, "Gable");
        assert_eq!(gables.len(), 2);
        for (k, &g) in gables.iter().enumerate() {
            let n = tree.node(g).unwrap();
            assert_eq!(
                (n.selector, n.index, n.count),
                (Some(Selector::Gable), k as u32 + 1, 2)
            );
            close(tree.area(g), 0.5 * 6.0 * 3.0, "gable end");
            // A wall's frame: y up, z horizontal.
            near(n.scope.axis(Axis::Y), Vec3::Z);
        }
        // The right gable faces +x.
        near(tree.node(gables[0]).unwrap().scope.axis(Axis::Z), Vec3::X);
        assert_eq!(of(&tree, &p, "Slope").len(), 2);
        assert_eq!(of(&tree, &p, "Rake").len(), 4);
        assert_eq!(of(&tree, &p, "Ridge").len(), 1);
        assert_eq!(of(&tree, &p, "Eave").len(), 2);
    }

    #[test]
    fn overhang_lowers_the_eaves() {
        let p = house(RoofKind::Hip, 1.0);
        let tree = grow(&p, &Lot::rectangle(10.0, 6.0));
        let front = tree.node(of(&tree, &p, "Slope")[0]).unwrap();
        // d * tan(45) = 1 lower, 1 out.
        near(front.scope.origin, Vec3::new(-1.0, -1.0, 4.0));
        let ridge = tree.node(of(&tree, &p, "Ridge")[0]).unwrap();
        close(f64::from(ridge.scope.origin.z), 8.0, "ridge height");
    }

    #[test]
    fn l_shaped_hip_roof_has_a_valley() {
        let p = house(RoofKind::Hip, 0.0);
        let tree = grow(&p, &Lot::footprint(&l_shape()).unwrap());
        assert_eq!(of(&tree, &p, "Slope").len(), 6);
        assert_eq!(of(&tree, &p, "Valley").len(), 1);
        assert_eq!(of(&tree, &p, "Eave").len(), 6);
        let total: f64 = of(&tree, &p, "Slope").iter().map(|&s| tree.area(s)).sum();
        // Every slope at 45 degrees: the footprint's area times sqrt 2.
        close(total, 64.0 * 2f64.sqrt(), "slopes");
    }

    #[test]
    fn taper_and_roof_on_a_face() {
        let mut b = ProgramBuilder::new("t");
        let lot = b.symbol("Lot");
        let side = b.symbol("Side");
        b.rule(
            lot,
            vec![
                Op::Taper(Param::Const(7.0)),
                comp(CompTarget::Faces, &[(Selector::Slope, side)]),
            ],
        );
        let p = b.build(lot).unwrap();
        let tree = grow(&p, &Lot::rectangle(10.0, 6.0));
        assert_eq!(of(&tree, &p, "Side").len(), 4);
        close(tree.volume(NodeId(0)), 0.0, "the lot node keeps its face");
        // The pyramid roof of a face: on the face itself.
        let mut b = ProgramBuilder::new("t");
        let lot = b.symbol("Lot");
        let top = b.symbol("Top");
        b.rule(
            lot,
            vec![roof_op(RoofKind::Pyramid, 45.0, 0.0), Op::Emit(top)],
        );
        let p = b.build(lot).unwrap();
        let tree = grow(&p, &Lot::rectangle(8.0, 8.0));
        let t = of(&tree, &p, "Top")[0];
        near(tree.node(t).unwrap().scope.size, Vec3::new(8.0, 8.0, 4.0));
        close(tree.volume(t), 64.0 * 4.0 / 3.0, "pyramid volume");
    }

    #[test]
    fn roofs_refuse_what_they_cannot_roof() {
        let one = |ops: Vec<Op>, lot: &Lot| {
            let mut b = ProgramBuilder::new("e");
            let s = b.symbol("S");
            let e = b.symbol("E");
            b.rule(s, ops);
            b.rule(e, vec![roof_op(RoofKind::Hip, 30.0, 0.0)]);
            derive(&b.build(s).unwrap(), lot, &Options::default())
        };
        let rect = Lot::rectangle(4.0, 3.0);
        // A roof of an edge.
        let mut b = ProgramBuilder::new("x");
        let s = b.symbol("S");
        let e = b.symbol("E");
        b.rule(s, vec![comp(CompTarget::Edges, &[(Selector::All, e)])]);
        b.rule(e, vec![roof_op(RoofKind::Hip, 30.0, 0.0)]);
        let r = derive(&b.build(s).unwrap(), &rect, &Options::default());
        assert!(
            matches!(
                r,
                Err(ShapeError::WrongGeometry {
                    op: "roof",
                    geometry: "an edge",
                    ..
                })
            ),
            "{r:?}"
        );
        // Extruding a roof.
        let r = one(
            vec![
                roof_op(RoofKind::Hip, 30.0, 0.0),
                Op::Extrude(Param::Const(1.0)),
            ],
            &rect,
        );
        assert!(
            matches!(
                r,
                Err(ShapeError::WrongGeometry {
                    geometry: "a roof",
                    ..
                })
            ),
            "{r:?}"
        );
        // A bad angle and a NaN.
        let r = one(vec![roof_op(RoofKind::Hip, 95.0, 0.0)], &rect);
        assert!(
            matches!(
                r,
                Err(ShapeError::Roof {
                    error: RoofError::BadAngle(_),
                    ..
                })
            ),
            "{r:?}"
        );
        let r = one(vec![roof_op(RoofKind::Hip, f32::NAN, 0.0)], &rect);
        assert!(matches!(r, Err(ShapeError::BadValue { .. })), "{r:?}");
    }

    /// A street: the lot split into 24 houses, each extruded, roofed
    /// (gable), its slopes tiled by a repeat, its gables split.
    fn street() -> Program {
        let mut b = ProgramBuilder::new("street");
        let lot = b.symbol("Lot");
        let house = b.symbol("House");
        let roof = b.symbol("Roof");
        let slope = b.symbol("Slope");
        let tile = b.symbol("Tile");
        let gable = b.symbol("Gable");
        let half = b.symbol("Half");
        let part = |w: f32, s| Part::float(w, Some(s));
        b.rule(
            lot,
            vec![Op::Repeat(Split {
                axis: Axis::X,
                parts: vec![part(8.0, house)],
                tag: None,
            })],
        );
        b.rule(house, vec![Op::Extrude(Param::Const(6.0)), Op::Emit(roof)]);
        b.rule(
            roof,
            vec![
                roof_op(RoofKind::Gable, 40.0, 0.4),
                comp(
                    CompTarget::Faces,
                    &[(Selector::Slope, slope), (Selector::Gable, gable)],
                ),
            ],
        );
        b.rule(
            slope,
            vec![Op::Repeat(Split {
                axis: Axis::X,
                parts: vec![part(1.0, tile)],
                tag: None,
            })],
        );
        b.rule(
            gable,
            vec![Op::Split(Split {
                axis: Axis::Y,
                parts: vec![Part::rel(0.5, Some(half)), Part::float(1.0, Some(half))],
                tag: None,
            })],
        );
        b.build(lot).unwrap()
    }

    #[test]
    fn roofed_street_is_the_same_with_1_and_4_threads() {
        let p = street();
        let lot = Lot::rectangle(192.0, 10.0);
        let one = derive(&p, &lot, &Options::default()).unwrap();
        let four = derive(
            &p,
            &lot,
            &Options {
                threads: 4,
                ..Options::default()
            },
        )
        .unwrap();
        assert_eq!(one, four);
        // 24 houses 8 wide and 10 deep: the gables are the 8 m front and
        // back, the slopes 10.8 m along y with the overhang (10 tiles each).
        assert_eq!(of(&one, &p, "House").len(), 24);
        assert_eq!(of(&one, &p, "Tile").len(), 24 * 2 * 10);
        assert_eq!(of(&one, &p, "Half").len(), 24 * 2 * 2);
    }
}

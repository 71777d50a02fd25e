//! Each cost equation of Calder section 3.3-3.4 against values computed by
//! hand (the computation is in the comments).
//!
//! Most cases use straight curves with evenly spaced collinear control
//! points, so that `B(t) = P0 + t (P3 - P0)` exactly, the tangent is the
//! constant unit vector along the line, and closest points are orthogonal
//! projections clamped to the ends.

use glam::{Affine3A, DVec3, Vec3};
use grm_guide::{
    Bezier3, CostModel, CostOptions, CurveParams, Curves, DensityParams, GuideCurve,
    expected_direction, utilization_sum,
};

const EPS: f64 = 1e-6;

fn v(x: f32, y: f32, z: f32) -> Vec3 {
    Vec3::new(x, y, z)
}

/// A straight curve from `a` to `b` (control points at thirds).
fn line(name: &str, a: DVec3, b: DVec3, params: CurveParams) -> GuideCurve {
    GuideCurve {
        name: Some(name.into()),
        bezier: Bezier3::new([a, a.lerp(b, 1.0 / 3.0), a.lerp(b, 2.0 / 3.0), b]),
        params,
    }
}

fn model(curves: Vec<GuideCurve>, density: Option<DensityParams>) -> CostModel {
    let c = Curves::new("test", curves, density).expect("valid curves");
    CostModel::new(&c, CostOptions::from_curves(&c))
}

fn params(distance: [f64; 3]) -> CurveParams {
    CurveParams {
        distance,
        ..CurveParams::default()
    }
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= EPS * b.abs().max(1.0)
}

macro_rules! assert_close {
    ($a:expr, $b:expr) => {{
        let (a, b) = ($a, $b);
        assert!(close(a, b), "{} = {a}, expected {b}", stringify!($a));
    }};
}

/// The unit y axis from 0 to 3, and a second line at x = 2.
fn two_lines(p: CurveParams) -> CostModel {
    model(
        vec![
            line("a", DVec3::ZERO, DVec3::new(0., 3., 0.), p),
            line("b", DVec3::new(2., 0., 0.), DVec3::new(2., 3., 0.), p),
        ],
        None,
    )
}

#[test]
fn eq1_nearest_curve_to_the_base() {
    let m = two_lines(CurveParams::default());
    let mut s = m.new_state();
    // Base (0.5, 1, 0): |to a| = 0.5, |to b| = 1.5 -> a.
    assert_eq!(
        m.add_bone(&mut s, v(0.5, 1., 0.), v(3., 1., 0.)).curve,
        Some(0)
    );
    // Base (1.2, 1, 0): 1.2 vs 0.8 -> b, although the tip is on a.
    assert_eq!(
        m.add_bone(&mut s, v(1.2, 1., 0.), v(0., 1., 0.)).curve,
        Some(1)
    );
    // Base (1, 1, 0): a tie, 1 vs 1 -> the lower index.
    assert_eq!(
        m.add_bone(&mut s, v(1., 1., 0.), v(1., 2., 0.)).curve,
        Some(0)
    );
    // In 3D: base (1.9, 1, 5): |to a| = sqrt(1.9^2 + 25), |to b| =
    // sqrt(0.1^2 + 25) -> b.
    assert_eq!(
        m.add_bone(&mut s, v(1.9, 1., 5.), v(1.9, 2., 5.)).curve,
        Some(1)
    );
}

#[test]
fn eq2_3_distance_polynomial() {
    // m = [1, 2, 100]: COST_d = 1 + 2 d + 100 d^2.
    let m = two_lines(params([1., 2., 100.]));
    let mut s = m.new_state();
    // d = 0.5: 1 + 1 + 25 = 27.
    assert_close!(
        m.add_bone(&mut s, v(0.5, 1., 0.), v(0.5, 2., 0.)).distance,
        27.0
    );
    // Below the start: closest point is the endpoint (0,0,0), d = 1:
    // 1 + 2 + 100 = 103.
    assert_close!(
        m.add_bone(&mut s, v(0., -1., 0.), v(0., 0., 0.)).distance,
        103.0
    );
    // Off in z only: d = 0.3: 1 + 0.6 + 9 = 10.6 (z is not ignored).
    assert_close!(
        m.add_bone(&mut s, v(0., 1., 0.3), v(0., 2., 0.3)).distance,
        10.6
    );
    // On the curve: d = 0: m0 = 1.
    assert_close!(
        m.add_bone(&mut s, v(0., 2., 0.), v(0., 3., 0.)).distance,
        1.0
    );
    // Calder's default [0, 0, 100] at d = 0.5: 25.
    let c = two_lines(CurveParams::default());
    let mut s = c.new_state();
    assert_close!(
        c.add_bone(&mut s, v(-0.5, 1., 0.), v(-0.5, 2., 0.))
            .distance,
        25.0
    );
}

#[test]
fn eq4_6_alignment_sign_convention() {
    // scale_a = 400, delta_a = 0.6 (Calder's defaults); the curve runs +y.
    // d_bone = -(tip - base)/|tip - base| (eq. 4), d_guide = (0, 1, 0).
    let m = two_lines(CurveParams::default());
    let mut s = m.new_state();
    // Along the curve: d_bone . d_guide = -1 -> (-1 + 0.6) 400 = -160.
    assert_close!(
        m.add_bone(&mut s, v(0., 1., 0.), v(0., 2., 0.)).alignment,
        -160.0
    );
    // The length of the bone does not matter: still -160.
    assert_close!(
        m.add_bone(&mut s, v(0., 1., 0.), v(0., 1.01, 0.)).alignment,
        -160.0
    );
    // Perpendicular: 0 -> (0 + 0.6) 400 = 240.
    assert_close!(
        m.add_bone(&mut s, v(0., 1., 0.), v(1., 1., 0.)).alignment,
        240.0
    );
    assert_close!(
        m.add_bone(&mut s, v(0., 1., 0.), v(0., 1., -2.)).alignment,
        240.0
    );
    // Against the curve: +1 -> (1 + 0.6) 400 = 640.
    assert_close!(
        m.add_bone(&mut s, v(0., 2., 0.), v(0., 1., 0.)).alignment,
        640.0
    );
    // 60 degrees off: dir = (sin 60, cos 60, 0), -cos 60 = -0.5 ->
    // (-0.5 + 0.6) 400 = 40.
    let (sn, cs) = 60f32.to_radians().sin_cos();
    assert_close!(
        m.add_bone(&mut s, v(0., 1., 0.), v(sn, 1. + cs, 0.))
            .alignment,
        40.0
    );
    // Zero-length bone: no direction, costed as perpendicular: 240.
    assert_close!(
        m.add_bone(&mut s, v(0., 1., 0.), v(0., 1., 0.)).alignment,
        240.0
    );

    // A negative offset is lenient: delta = -0.2, scale 100: aligned
    // (-1 - 0.2) 100 = -120, perpendicular -20 (still rewarded), opposite 80.
    let lenient = two_lines(CurveParams {
        alignment_scale: 100.0,
        alignment_offset: -0.2,
        ..CurveParams::default()
    });
    let mut s = lenient.new_state();
    assert_close!(
        lenient
            .add_bone(&mut s, v(0., 1., 0.), v(0., 2., 0.))
            .alignment,
        -120.0
    );
    assert_close!(
        lenient
            .add_bone(&mut s, v(0., 1., 0.), v(1., 1., 0.))
            .alignment,
        -20.0
    );
    assert_close!(
        lenient
            .add_bone(&mut s, v(0., 2., 0.), v(0., 1., 0.))
            .alignment,
        80.0
    );

    // The curve's direction is the direction of growth: the same line drawn
    // top-down makes an upward bone cost (1 + 0.6) 400 = 640.
    let down = model(
        vec![line(
            "down",
            DVec3::new(0., 3., 0.),
            DVec3::ZERO,
            CurveParams::default(),
        )],
        None,
    );
    let mut s = down.new_state();
    assert_close!(
        down.add_bone(&mut s, v(0., 1., 0.), v(0., 2., 0.))
            .alignment,
        640.0
    );
}

#[test]
fn eq6_uses_the_tangent_at_the_closest_point_of_a_curved_guide() {
    // Quarter-circle-like curve from (1,0,0) towards (0,1,0):
    // P = (1,0,0), (1,0.5,0), (0.5,1,0), (0,1,0), symmetric about x = y.
    // B(0.5) = (P0 + 3 P1 + 3 P2 + P3) / 8
    //        = ((1 + 3 + 1.5 + 0) / 8, (0 + 1.5 + 3 + 1) / 8, 0)
    //        = (0.6875, 0.6875, 0),
    // B'(0.5) = 0.75 (P1-P0) + 1.5 (P2-P1) + 0.75 (P3-P2)
    //         = (0,0.375,0) + (-0.75,0.75,0) + (-0.375,0,0) = (-1.125, 1.125, 0):
    // tangent (-1, 1, 0)/sqrt 2.
    let p = CurveParams::default();
    let c = GuideCurve {
        name: None,
        bezier: Bezier3::new([
            DVec3::new(1., 0., 0.),
            DVec3::new(1., 0.5, 0.),
            DVec3::new(0.5, 1., 0.),
            DVec3::new(0., 1., 0.),
        ]),
        params: p,
    };
    let m = model(vec![c], None);
    let mut s = m.new_state();
    // Base on the diagonal beyond B(0.5): the closest point is B(0.5) by
    // symmetry. Bone along (-1, 1, 0): dot = -1 -> -160.
    let cost = m.add_bone(&mut s, v(0.8, 0.8, 0.), v(0.7, 0.9, 0.));
    assert_close!(cost.alignment, -160.0);
    // Distance: |(0.8,0.8) - (0.6875,0.6875)| = 0.1125 sqrt 2 = 0.159099;
    // 100 d^2 = 100 * 0.0253125 = 2.53125.
    assert_close!(cost.distance, 2.53125);
}

/// One line of length 3 along +y, segments of 0.5 (six: [0,0.5), ...,
/// [2.5,3]), scale_u = 10.
fn util_model() -> CostModel {
    model(
        vec![line(
            "a",
            DVec3::ZERO,
            DVec3::new(0., 3., 0.),
            CurveParams {
                utilization_scale: 10.0,
                segment_length: 0.5,
                ..CurveParams::default()
            },
        )],
        None,
    )
}

#[test]
fn eq7_utilization_over_segments() {
    let m = util_model();
    assert_eq!(m.segment_count(0), 6);
    let mut s = m.new_state();
    let e1 = (-1f64).exp(); // 0.36788
    let e2 = (-2f64).exp(); // 0.13534
    // Bone 1: base y=0.1 (segment 0), tip y=1.2 (segment 2): S = {0,1,2},
    // all unused: -10 (1 + 1 + 1) = -30.
    assert_close!(
        m.add_bone(&mut s, v(0., 0.1, 0.), v(0., 1.2, 0.))
            .utilization,
        -30.0
    );
    assert_eq!(m.segment_uses(&s, 0), [1, 1, 1, 0, 0, 0]);
    // Bone 2, the same: each used once: -10 * 3 e^-1 = -11.0364.
    assert_close!(
        m.add_bone(&mut s, v(0., 0.1, 0.), v(0., 1.2, 0.))
            .utilization,
        -30.0 * e1
    );
    // Bone 3, base y=1.1 (segment 2, used twice), tip y=1.7 (segment 3,
    // unused): -10 (e^-2 + 1) = -11.3534.
    assert_close!(
        m.add_bone(&mut s, v(0., 1.1, 0.), v(0., 1.7, 0.))
            .utilization,
        -10.0 * (e2 + 1.0)
    );
    // Bone 4 points down, from y=2.9 (segment 5) to y=2.4 (segment 4): the
    // range is taken between the two, whatever the order: -10 * 2 = -20.
    assert_close!(
        m.add_bone(&mut s, v(0., 2.9, 0.), v(0., 2.4, 0.))
            .utilization,
        -20.0
    );
    // Bone 5, tip past the end: its closest point is the end (segment 5),
    // base y=2.6 (segment 5): S = {5}, used once: -10 e^-1.
    assert_close!(
        m.add_bone(&mut s, v(0., 2.6, 0.), v(0., 4.0, 0.))
            .utilization,
        -10.0 * e1
    );
    assert_eq!(m.segment_uses(&s, 0), [2, 2, 3, 1, 1, 2]);
    // Total: -10 (G(2) + G(2) + G(3) + G(1) + G(1) + G(2)), G(1) = 1,
    // G(2) = 1 + e^-1, G(3) = 1 + e^-1 + e^-2:
    // -10 (3 (1.36788) + 1.50321 + 2) = -76.0685, which is also the sum of
    // the five per-bone values: -30 - 11.0364 - 11.3534 - 20 - 3.6788.
    let g = |n| utilization_sum(n);
    assert_close!(g(1), 1.0);
    assert_close!(g(2), 1.0 + e1);
    assert_close!(g(3), 1.0 + e1 + e2);
    let want = -10.0 * (3.0 * g(2) + g(3) + 2.0 * g(1));
    assert_close!(m.total(&s).utilization, want);
    assert_close!(
        want,
        -30.0 - 30.0 * e1 - 10.0 * (e2 + 1.0) - 20.0 - 10.0 * e1
    );
    assert_close!(m.utilization_from_counts(&s), want);
}

#[test]
fn eq7_utilization_is_off_with_scale_zero() {
    let m = two_lines(CurveParams::default()); // utilization_scale 0
    let mut s = m.new_state();
    assert_eq!(
        m.add_bone(&mut s, v(0., 0.1, 0.), v(0., 2.9, 0.))
            .utilization,
        0.0
    );
    assert!(m.segment_uses(&s, 0).iter().all(|&n| n == 0));
}

#[test]
fn eq8_total_is_the_sum_of_the_terms() {
    // Curve [1, 2, 100], scale_a 400, delta 0.6, scale_u 10, segment 0.5.
    let m = model(
        vec![line(
            "a",
            DVec3::ZERO,
            DVec3::new(0., 3., 0.),
            CurveParams {
                distance: [1., 2., 100.],
                utilization_scale: 10.0,
                segment_length: 0.5,
                ..CurveParams::default()
            },
        )],
        None,
    );
    let mut s = m.new_state();
    // Base (0.5, 0.2, 0): d = 0.5 -> 27; bone along +y -> -160; closest
    // points y = 0.2 and 1.2: segments 0..=2 -> -30. Total -163.
    let c = m.add_bone(&mut s, v(0.5, 0.2, 0.), v(0.5, 1.2, 0.));
    assert_close!(c.distance, 27.0);
    assert_close!(c.alignment, -160.0);
    assert_close!(c.utilization, -30.0);
    assert_eq!(c.density, 0.0);
    assert_close!(c.total(), -163.0);
    let t = m.total(&s);
    assert_close!(t.total(), -163.0);
    assert_eq!(t.bones, 1);
}

#[test]
fn thick_curves_cost_nothing_inside_the_tube() {
    // Thickness 0.2, m = [1, 2, 100].
    let p = CurveParams {
        distance: [1., 2., 100.],
        thickness: 0.2,
        ..CurveParams::default()
    };
    let m = model(
        vec![line("a", DVec3::ZERO, DVec3::new(0., 3., 0.), p)],
        None,
    );
    let mut s = m.new_state();
    // Raw distance 0.5 -> 0.3 beyond the surface: 1 + 0.6 + 9 = 10.6.
    assert_close!(
        m.add_bone(&mut s, v(0.5, 1., 0.), v(0.5, 2., 0.)).distance,
        10.6
    );
    // Inside the tube (0.1 < 0.2): d = 0 -> m0 = 1.
    assert_close!(
        m.add_bone(&mut s, v(0.1, 1., 0.), v(0.1, 2., 0.)).distance,
        1.0
    );

    // Curve choice uses the tube surface: thin a at x = 0, b at x = 2 with
    // thickness 1. Base x = 0.9: a is 0.9 away, b's surface 1.1 - 1 = 0.1
    // -> b, distance cost 100 * 0.1^2 = 1.
    let thin = CurveParams::default();
    let thick = CurveParams {
        thickness: 1.0,
        ..CurveParams::default()
    };
    let m = model(
        vec![
            line("a", DVec3::ZERO, DVec3::new(0., 3., 0.), thin),
            line("b", DVec3::new(2., 0., 0.), DVec3::new(2., 3., 0.), thick),
        ],
        None,
    );
    let mut s = m.new_state();
    let c = m.add_bone(&mut s, v(0.9, 1., 0.), v(0.9, 2., 0.));
    assert_eq!(c.curve, Some(1));
    assert_close!(c.distance, 1.0);
}

#[test]
fn density_penalizes_crowded_bone_midpoints() {
    // radius 1, scale 8: a pair at distance r costs 8 (1 - r)^2.
    let m = model(
        vec![line(
            "a",
            DVec3::ZERO,
            DVec3::new(0., 3., 0.),
            CurveParams::default(),
        )],
        Some(DensityParams {
            radius: 1.0,
            scale: 8.0,
        }),
    );
    let mut s = m.new_state();
    // Midpoints: (0,1,0), (0.5,1,0), (0.75,1,0), (3,1,0).
    let bone = |x: f32| (v(x, 0.5, 0.), v(x, 1.5, 0.));
    let (b, t) = bone(0.0);
    assert_eq!(m.add_bone(&mut s, b, t).density, 0.0);
    // Pair at 0.5: 8 * 0.25 = 2.
    let (b, t) = bone(0.5);
    assert_close!(m.add_bone(&mut s, b, t).density, 2.0);
    // Pairs at 0.75 and 0.25: 8 (0.0625 + 0.5625) = 5.
    let (b, t) = bone(0.75);
    assert_close!(m.add_bone(&mut s, b, t).density, 5.0);
    // Far away: nothing.
    let (b, t) = bone(3.0);
    assert_eq!(m.add_bone(&mut s, b, t).density, 0.0);
    assert_close!(m.total(&s).density, 7.0);
    // Without the density option the term stays 0.
    let off = two_lines(CurveParams::default());
    let mut s = off.new_state();
    off.add_bone(&mut s, v(0., 0.5, 0.), v(0., 1.5, 0.));
    assert_eq!(
        off.add_bone(&mut s, v(0., 0.5, 0.), v(0., 1.5, 0.)).density,
        0.0
    );
}

#[test]
fn non_finite_bones_make_the_model_infinitely_bad() {
    let m = two_lines(CurveParams::default());
    let mut s = m.new_state();
    m.add_bone(&mut s, v(0., 0., 0.), v(0., 1., 0.));
    let c = m.add_bone(&mut s, v(f32::NAN, 0., 0.), v(0., 1., 0.));
    assert_eq!(c.curve, None);
    assert_eq!(m.total(&s).total(), f64::INFINITY);
    assert_eq!(m.total(&s).non_finite, 1);
    assert_eq!(
        m.heuristic(v(f32::INFINITY, 0., 0.), v(0., 1., 0.)),
        f64::INFINITY
    );
}

#[test]
fn cloned_states_are_independent() {
    let m = util_model();
    let mut a = m.new_state();
    m.add_bone(&mut a, v(0., 0.1, 0.), v(0., 1.2, 0.));
    let before = m.total(&a);
    let mut b = a.clone();
    m.add_bone(&mut b, v(0., 0.1, 0.), v(0., 1.2, 0.));
    assert_eq!(m.total(&a), before);
    assert_eq!(m.segment_uses(&a, 0), [1, 1, 1, 0, 0, 0]);
    assert_eq!(m.segment_uses(&b, 0), [2, 2, 2, 0, 0, 0]);
    assert_eq!(b.bones(), 2);
}

#[test]
fn eq9_expected_direction_averages_raw_bone_vectors_per_model() {
    // Model A: bones (0,0,0)->(0,1,0) and (0,1,0)->(1,1,0): mean (0.5,0.5,0).
    // Model B: (0,0,0)->(0,3,0): mean (0,3,0). Model C: no bones (adds 0,
    // counts in |X|). EXPECTED = ((0.5,0.5,0) + (0,3,0)) / 3 = (1/6, 7/6, 0).
    let a = [
        (v(0., 0., 0.), v(0., 1., 0.)),
        (v(0., 1., 0.), v(1., 1., 0.)),
    ];
    let b = [(v(0., 0., 0.), v(0., 3., 0.))];
    let c: [(Vec3, Vec3); 0] = [];
    let e = expected_direction([&a[..], &b[..], &c[..]]);
    assert!((e - v(1. / 6., 7. / 6., 0.)).length() < 1e-6, "{e}");
    // Not normalized, and not zero for a grammar that grows upwards (the
    // reference implementation's heuristic averaged to zero).
    let up = [(v(0., 0., 0.), v(0.2, 2., 0.))];
    let e = expected_direction([&up[..]]);
    assert!((e - v(0.2, 2., 0.)).length() < 1e-6);
    assert_eq!(expected_direction(std::iter::empty()), Vec3::ZERO);
}

#[test]
fn eq10_heuristic_term() {
    let m = two_lines(CurveParams::default());
    // Position (0.5, 1, 0) is nearest to a (tangent +y). Expected (0,2,0)
    // normalizes to +y: (-1 + 0.6) 400 = -160.
    assert_close!(m.heuristic(v(0.5, 1., 0.), v(0., 2., 0.)), -160.0);
    // Expected along x: perpendicular: 0.6 * 400 = 240.
    assert_close!(m.heuristic(v(0.5, 1., 0.), v(3., 0., 0.)), 240.0);
    // A zero world vector (a degenerate frame) is costed as perpendicular:
    // 240; a symbol whose own expected direction is zero grows no bone and
    // adds nothing, as in the sampler.
    assert_close!(m.heuristic(v(0.5, 1., 0.), Vec3::ZERO), 240.0);
    assert_close!(
        m.heuristic_in_frame(&Affine3A::from_translation(v(0.5, 1., 0.)), Vec3::ZERO),
        0.0
    );
    // In a frame: M = translate(0,1,0) * rotate_z(-90 deg) maps the local y
    // axis to world +x: perpendicular to a, 240. With rotate_z(0) it is +y:
    // -160. With rotate_z(180 deg) it is -y: (1 + 0.6) 400 = 640.
    let at = |deg: f32| {
        Affine3A::from_translation(v(0., 1., 0.)) * Affine3A::from_rotation_z(deg.to_radians())
    };
    assert_close!(m.heuristic_in_frame(&at(-90.), Vec3::Y), 240.0);
    assert_close!(m.heuristic_in_frame(&at(0.), Vec3::Y), -160.0);
    assert_close!(m.heuristic_in_frame(&at(180.), Vec3::Y * 5.0), 640.0);
    // The position picks the curve: at (1.6, 1, 0) curve b (also +y) ->
    // -160; b drawn downwards instead -> 640.
    let m2 = model(
        vec![
            line(
                "a",
                DVec3::ZERO,
                DVec3::new(0., 3., 0.),
                CurveParams::default(),
            ),
            line(
                "b",
                DVec3::new(2., 3., 0.),
                DVec3::new(2., 0., 0.),
                CurveParams::default(),
            ),
        ],
        None,
    );
    assert_close!(m2.heuristic(v(0.4, 1., 0.), Vec3::Y), -160.0);
    assert_close!(m2.heuristic(v(1.6, 1., 0.), Vec3::Y), 640.0);
}

#[test]
fn segment_counts_do_not_grow_slivers() {
    // 2.1 / 0.3 is 7.000000000000001 in floating point: still 7 segments,
    // not an eighth sliver.
    assert!(std::hint::black_box(2.1f64) / 0.3 > 7.0);
    assert_eq!(grm_guide::curves::segment_count(2.1, 0.3), 7);
    assert_eq!(grm_guide::curves::segment_count(2.11, 0.3), 8);
    assert_eq!(grm_guide::curves::segment_count(0.0, 0.3), 1);
    // A trunk of length 4 with segments of 0.2: 20.
    let m = model(
        vec![line(
            "trunk",
            DVec3::ZERO,
            DVec3::new(0., 4., 0.),
            CurveParams::default(),
        )],
        None,
    );
    assert_eq!(m.segment_count(0), 20);
    // 3.1 / 0.5 = 6.2 -> 7 segments, the last 0.1 long.
    let m = model(
        vec![line(
            "a",
            DVec3::ZERO,
            DVec3::new(0., 3.1, 0.),
            CurveParams {
                segment_length: 0.5,
                ..CurveParams::default()
            },
        )],
        None,
    );
    assert_eq!(m.segment_count(0), 7);
    assert_eq!(m.segment_count(5), 0);
}

#[test]
fn states_and_models_can_cross_threads() {
    fn send_sync<T: Send + Sync>() {}
    send_sync::<CostModel>();
    send_sync::<grm_guide::CostState>();
    send_sync::<Curves>();
    send_sync::<grm_guide::VolumeTarget>();
    send_sync::<grm_guide::VolumeState>();
}

//! The per-segment coverage the sampler keeps per particle
//! (`CostModel::covered_segments`, `cover_gain`, `covered_ahead`) and the
//! utilization look-ahead (`utilization_ahead`), against hand counts on a
//! straight curve.

use glam::{DVec3, Vec3};
use grm_guide::{Bezier3, CostModel, CostOptions, CurveParams, Curves, GuideCurve};

/// A straight curve from (0,0,0) to (0,2,0): 10 segments of 0.2, with
/// utilization on (scale 100).
fn model() -> CostModel {
    let (a, b) = (DVec3::ZERO, DVec3::new(0.0, 2.0, 0.0));
    let c = GuideCurve {
        name: Some("line".into()),
        bezier: Bezier3::new([a, a.lerp(b, 1.0 / 3.0), a.lerp(b, 2.0 / 3.0), b]),
        params: CurveParams {
            utilization_scale: 100.0,
            ..CurveParams::default()
        },
    };
    let c = Curves::new("test", vec![c], None).expect("valid curves");
    CostModel::new(&c, CostOptions::from_curves(&c))
}

fn v(x: f32, y: f32) -> Vec3 {
    Vec3::new(x, y, 0.0)
}

#[test]
fn bones_near_the_curve_cover_the_segments_they_span_and_far_ones_none() {
    let m = model();
    let mut s = m.new_state();
    assert_eq!(m.covered_segments(&s, 0), (0, 10));
    // From y = 0.1 (segment 0) to y = 0.5 (segment 2), 0.1 off the axis:
    // within the covering radius 0.15, three segments.
    let plan = m.plan_bone(v(0.1, 0.1), v(0.1, 0.5));
    assert_eq!(m.cover_gain(&s, &plan), Some((0, 3)));
    m.add_planned(&mut s, &plan);
    assert_eq!(m.covered_segments(&s, 0), (3, 10));
    // The same span again covers nothing new.
    let again = m.plan_bone(v(0.0, 0.1), v(0.0, 0.5));
    assert_eq!(m.cover_gain(&s, &again), None);
    // A bone 0.3 off the axis uses segments 5..=7 (eq. 7) but covers none.
    let far = m.plan_bone(v(0.3, 1.1), v(0.3, 1.5));
    assert_eq!(m.cover_gain(&s, &far), None);
    m.add_planned(&mut s, &far);
    assert_eq!(m.covered_segments(&s, 0), (3, 10));
    assert_eq!(m.segment_uses(&s, 0)[5..8], [1, 1, 1]);
    // One end inside, the other outside: no cover either.
    let half = m.plan_bone(v(0.0, 1.1), v(0.4, 1.5));
    assert_eq!(m.cover_gain(&s, &half), None);
    // An index out of range is empty.
    assert_eq!(m.covered_segments(&s, 7), (0, 0));
}

#[test]
fn the_look_ahead_sees_the_next_segment() {
    let m = model();
    let mut s = m.new_state();
    // At t = 0.25 (y = 0.5, segment 2) the next segment, 3, is unused:
    // the next bone there would gain the full -scale_u.
    assert!((m.utilization_ahead(&s, 0, 0.25) - -100.0).abs() < 1e-6);
    assert!(!m.covered_ahead(&s, 0, 0.25));
    m.add_bone(&mut s, v(0.0, 0.5), v(0.0, 0.9));
    // Segments 2..=4 used once: the look-ahead gains -100 / e, and the
    // next segment is covered.
    let e = (-1.0f64).exp();
    assert!((m.utilization_ahead(&s, 0, 0.25) - -100.0 * e).abs() < 1e-6);
    assert!(m.covered_ahead(&s, 0, 0.25));
    // At the curve's end there is nothing ahead.
    assert_eq!(m.utilization_ahead(&s, 0, 1.0), 0.0);
    assert!(m.covered_ahead(&s, 0, 1.0));
}

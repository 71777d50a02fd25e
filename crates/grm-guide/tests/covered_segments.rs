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

/// A trunk from (0,0,0) to (0,2,0) (10 segments) and an arm that starts on
/// it at y = 1 and runs to (1,1,0) (5 segments), both straight.
fn fork() -> CostModel {
    let line = |name: &str, a: DVec3, b: DVec3| GuideCurve {
        name: Some(name.into()),
        bezier: Bezier3::new([a, a.lerp(b, 1.0 / 3.0), a.lerp(b, 2.0 / 3.0), b]),
        params: CurveParams {
            utilization_scale: 100.0,
            ..CurveParams::default()
        },
    };
    let c = Curves::new(
        "test",
        vec![
            line("trunk", DVec3::ZERO, DVec3::new(0.0, 2.0, 0.0)),
            line("arm", DVec3::new(0.0, 1.0, 0.0), DVec3::new(1.0, 1.0, 0.0)),
        ],
        None,
    )
    .expect("valid curves");
    CostModel::new(&c, CostOptions::from_curves(&c))
}

#[test]
fn a_bone_leaving_a_fork_covers_the_arm_it_runs_along() {
    let mut m = fork();
    let s = m.new_state();
    // Based at the fork (eq. 1 picks the trunk, the lower index), along the
    // arm to x = 0.5: the trunk's tube does not hold its tip, the arm's
    // holds both ends: it covers arm segments 0..=2.
    let plan = m.plan_bone(v(0.0, 1.0), v(0.5, 1.0));
    assert_eq!(plan.curve(), Some(0));
    assert_eq!(m.cover_gain(&s, &plan), None);
    let mut gains = Vec::new();
    m.cover_gains(&s, &plan, |c, n| gains.push((c, n)));
    assert_eq!(gains, vec![(1, 3)]);
    let mut t = m.new_state();
    m.add_planned(&mut t, &plan);
    assert_eq!(m.covered_segments(&t, 1), (3, 5));
    assert_eq!(m.covered_segments(&t, 0), (0, 10));
    // The cost is eq. 1-8's either way: the same as a model that covers
    // eq. 1's curve alone.
    m.set_cover_others(false);
    let alone = m.plan_bone(v(0.0, 1.0), v(0.5, 1.0));
    let mut u = m.new_state();
    m.add_planned(&mut u, &alone);
    assert_eq!(m.covered_segments(&u, 1), (0, 5));
    assert_eq!(m.total(&u), m.total(&t));
}

#[test]
fn the_reach_look_ahead_counts_uncovered_segments_within_reach() {
    let m = fork();
    let mut s = m.new_state();
    let p = DVec3::new(0.0, 0.5, 0.0);
    let tubes = m.tubes_at(p, None);
    assert_eq!(tubes.iter().map(|&(c, _)| c).collect::<Vec<_>>(), vec![0]);
    // Segments 3..=4 of the trunk (after the one holding y = 0.5, up to
    // y = 0.95), each worth the whole share (nothing covered yet).
    assert_eq!(m.uncovered_within_reach(&s, &tubes, 0.45, None), 2.0);
    // Cover segments 3..=4: they no longer count, and the others are
    // worth the trunk's uncovered share, 8 / 10.
    m.add_planned(&mut s, &m.plan_bone(v(0.0, 0.61), v(0.0, 0.99)));
    assert_eq!(m.covered_segments(&s, 0), (2, 10));
    let ahead = m.uncovered_within_reach(&s, &tubes, 0.85, None);
    assert!((ahead - 2.0 * 0.8).abs() < 1e-12, "{ahead}");
    // With branches, what is left of the reach past the fork (y = 1) runs
    // along the arm from its start: 0.35 of it, arm segments 0..=1.
    let branched = m.uncovered_within_reach(&s, &tubes, 0.85, Some(0.0));
    assert!((branched - (ahead + 2.0)).abs() < 1e-12, "{branched}");
    // Not when the fork is nearer than the gap asked for.
    let gapped = m.uncovered_within_reach(&s, &tubes, 0.85, Some(0.6));
    assert_eq!(gapped, ahead);
    // A place outside every tube has nothing ahead.
    let off = m.tubes_at(DVec3::new(0.5, 0.2, 0.0), None);
    assert!(off.is_empty());
    assert_eq!(m.uncovered_within_reach(&s, &off, 5.0, Some(0.0)), 0.0);
    // At the fork both tubes hold the place.
    let both = m.tubes_at(DVec3::new(0.0, 1.0, 0.0), None);
    assert_eq!(both.iter().count(), 2);
}

//! Property: a model's cost does not depend on the order its bones were
//! added (SOSMC expands symbols in random order, Calder section 3.3).
//!
//! Random bone sets around the benchmark curves, every term on (distance,
//! alignment, utilization, thick curve, density), inserted in many shuffled
//! orders: the totals must be bit-for-bit equal. The utilization total must
//! also equal the sum over bones of eq. 7 evaluated literally (a reference
//! implementation written here) for every order, and match the count-based
//! formula.

use grm_testkit::Rng;
use std::path::PathBuf;

use glam::Vec3;
use grm_guide::{
    CostBreakdown, CostModel, CostOptions, Curves, DensityParams, VolumeOptions, VolumeTarget,
};

/// The benchmark curves with utilization on, a thick arm and density on.
fn benchmark_curves() -> Curves {
    let path =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples/calder_tree.curves.json");
    let text = std::fs::read_to_string(path).expect("example exists");
    // Make the left arm thick and turn density on, via the format itself.
    let text = text.replacen(
        "\"name\": \"left_arm\",",
        "\"name\": \"left_arm\", \"thickness\": 0.25,",
        1,
    );
    let text = text.replacen(
        "\"version\": 1,",
        "\"version\": 1, \"density\": { \"radius\": 0.4, \"scale\": 30 },",
        1,
    );
    let c = Curves::from_json_str("bench.curves.json", &text).expect("valid");
    assert_eq!(c.curves()[1].params.thickness, 0.25);
    assert_eq!(
        c.density(),
        Some(DensityParams {
            radius: 0.4,
            scale: 30.0
        })
    );
    c
}

/// A random tree-like set of bones in the curves' neighbourhood, including
/// repeated and zero-length bones.
fn random_bones(rng: &mut Rng, n: usize) -> Vec<(Vec3, Vec3)> {
    let mut bones = Vec::with_capacity(n);
    let mut tips = vec![Vec3::ZERO];
    for _ in 0..n {
        let base = tips[rng.below(tips.len())];
        let dir = Vec3::new(
            rng.range_f32(-1., 1.),
            rng.range_f32(-0.3, 1.),
            rng.range_f32(-0.5, 0.5),
        );
        let tip = base + dir * rng.range_f32(0.0, 0.9);
        let tip = if rng.below(20) == 0 { base } else { tip };
        bones.push((base, tip));
        if tip.y < 5.0 && tip.x.abs() < 3.5 {
            tips.push(tip);
        }
        if rng.below(10) == 0 {
            bones.push((base, tip)); // an exact duplicate
        }
    }
    bones
}

fn run(model: &CostModel, bones: &[(Vec3, Vec3)]) -> (CostBreakdown, f64, f64) {
    let mut s = model.new_state();
    let mut per_bone_util = 0.0;
    for &(b, t) in bones {
        per_bone_util += model.add_bone(&mut s, b, t).utilization;
    }
    (
        model.total(&s),
        per_bone_util,
        model.utilization_from_counts(&s),
    )
}

/// Eq. 7 literally: for each bone in order, choose the curve (eq. 1), take
/// the segment range between the closest points to base and tip, add
/// `-scale_u e^{-uses}` per segment, then increment. Uses the library's
/// closest point and segment counts, but none of its utilization code.
fn eq7_reference(curves: &Curves, model: &CostModel, bones: &[(Vec3, Vec3)]) -> f64 {
    const K: usize = 4096;
    let mut uses: Vec<Vec<u32>> = (0..model.curve_count())
        .map(|c| vec![0; model.segment_count(c)])
        .collect();
    // Arc length by dense chords.
    let arcs: Vec<Vec<f64>> = curves
        .curves()
        .iter()
        .map(|g| g.bezier.arc_length_table(K))
        .collect();
    let mut total = 0.0;
    for &(b, t) in bones {
        let (ci, cb) = model.nearest_curve(b.as_dvec3());
        let g = &curves.curves()[ci];
        let ct = g.bezier.closest_point(t.as_dvec3());
        let n = model.segment_count(ci);
        // Segment of a parameter: arc length from the start over the
        // segment length, clamped.
        let seg = |u: f64| {
            let s = &arcs[ci];
            let x = u * K as f64;
            let i = (x.floor() as usize).min(K - 1);
            let len = s[i] + (s[i + 1] - s[i]) * (x - i as f64);
            ((len / g.params.segment_length).floor() as usize).min(n - 1)
        };
        let (a, z) = (seg(cb.t), seg(ct.t));
        for s in &mut uses[ci][a.min(z)..=a.max(z)] {
            total += -g.params.utilization_scale * (-(*s as f64)).exp();
            *s += 1;
        }
    }
    total
}

#[test]
fn totals_are_bitwise_equal_for_any_insertion_order() {
    let curves = benchmark_curves();
    let model = CostModel::new(&curves, CostOptions::from_curves(&curves));
    let mut rng = Rng::seeded(0xC0FFEE);
    for trial in 0..12 {
        let mut bones = random_bones(&mut rng, 60 + 20 * trial);
        let (want, per_bone, from_counts) = run(&model, &bones);
        assert!(want.bones as usize == bones.len());
        // Every term is exercised.
        assert!(want.distance > 0.0, "{want:?}");
        assert!(want.alignment != 0.0);
        assert!(want.utilization < 0.0);
        assert!(want.density > 0.0, "{want:?}");
        assert_eq!(from_counts, want.utilization);
        assert!((per_bone - want.utilization).abs() < 1e-6 * want.utilization.abs());
        let reference = eq7_reference(&curves, &model, &bones);
        assert!(
            (reference - want.utilization).abs() < 1e-6 * want.utilization.abs(),
            "eq. 7 literal {reference} vs {}",
            want.utilization
        );
        for _ in 0..10 {
            rng.shuffle(&mut bones);
            let (got, _, _) = run(&model, &bones);
            assert_eq!(got, want, "trial {trial}: totals differ after a shuffle");
            assert_eq!(got.total().to_bits(), want.total().to_bits());
            // eq. 7 literally, in this order, sums to the same total.
            let reference = eq7_reference(&curves, &model, &bones);
            assert!((reference - want.utilization).abs() < 1e-6 * want.utilization.abs());
        }
    }
}

#[test]
fn per_bone_utilization_depends_on_order_but_total_does_not() {
    // Two bones over the same segments: the first gets -scale_u per
    // segment, the second -scale_u e^-1 per segment, whichever comes first.
    let curves = benchmark_curves();
    let model = CostModel::new(&curves, CostOptions::default());
    let a = (Vec3::new(0., 0.1, 0.), Vec3::new(0., 0.5, 0.));
    let b = (Vec3::new(0.1, 0.1, 0.), Vec3::new(0.1, 0.5, 0.));
    let mut s1 = model.new_state();
    let a1 = model.add_bone(&mut s1, a.0, a.1);
    let b1 = model.add_bone(&mut s1, b.0, b.1);
    let mut s2 = model.new_state();
    let b2 = model.add_bone(&mut s2, b.0, b.1);
    let a2 = model.add_bone(&mut s2, a.0, a.1);
    assert!((a1.utilization - b2.utilization).abs() < 1e-9);
    assert!((b1.utilization - a2.utilization).abs() < 1e-9);
    assert!(a1.utilization < a2.utilization);
    assert_eq!(model.total(&s1), model.total(&s2));
}

#[test]
fn volume_baseline_is_order_independent() {
    let curves = benchmark_curves();
    let target = VolumeTarget::from_curves(&curves, VolumeOptions::default()).expect("valid");
    let mut rng = Rng::seeded(0xBA5E);
    let mut bones = random_bones(&mut rng, 150);
    let want = target.evaluate(&bones);
    for _ in 0..5 {
        rng.shuffle(&mut bones);
        assert_eq!(target.evaluate(&bones), want);
    }
}

/// Pricing a bone before adding it (the sampler's candidates): `peek`
/// returns exactly what `add_planned` then returns and changes nothing,
/// `add_planned` is `add_bone` bit for bit (with eq. 1 computed by the plan
/// or given), and `nearest_curve_known` with a plan's tip point is
/// `nearest_curve` at the tip.
#[test]
fn planned_bones_cost_what_added_bones_cost() {
    let curves = benchmark_curves();
    let model = CostModel::new(&curves, CostOptions::from_curves(&curves));
    let mut rng = Rng::seeded(0x05EE_DCA7);
    for trial in 0..6 {
        let mut bones = random_bones(&mut rng, 80 + 10 * trial);
        bones.push((Vec3::new(f32::NAN, 0.0, 0.0), Vec3::ONE));
        bones.push((Vec3::ZERO, Vec3::new(0.0, f32::INFINITY, 0.0)));
        let (mut direct, mut planned, mut given) =
            (model.new_state(), model.new_state(), model.new_state());
        let mut known_used = 0;
        for &(b, t) in &bones {
            let want = model.add_bone(&mut direct, b, t);
            let plan = model.plan_bone(b, t);
            let finite = b.is_finite() && t.is_finite();
            if finite {
                assert_eq!(plan.ends(), (b.as_dvec3(), t.as_dvec3()));
            } else {
                assert_eq!(plan.curve(), None);
            }
            let before = model.total(&planned);
            let peeked = model.peek(&planned, &plan);
            assert_eq!(model.total(&planned), before, "peek changed the state");
            let got = model.add_planned(&mut planned, &plan);
            assert_eq!(got, want);
            if want.curve.is_some() {
                assert_eq!(peeked.to_bits(), got.total().to_bits(), "{b} {t}");
            } else {
                assert_eq!(peeked, f64::INFINITY);
            }
            // Eq. 1 given by the caller.
            let plan2 = if finite {
                let (ci, cp) = model.nearest_curve(b.as_dvec3());
                let p2 = model.plan_bone_near(b, t, ci, &cp);
                assert_eq!(p2, plan);
                p2
            } else {
                model.plan_bone(b, t)
            };
            assert_eq!(model.add_planned(&mut given, &plan2), want);
            // The tip's closest point on the bone's curve, reused.
            if let Some((ci, cp)) = plan.tip_closest() {
                assert_eq!(plan.curve(), Some(ci));
                let tip = t.as_dvec3();
                let (a, pa) = model.nearest_curve(tip);
                let (k, pk) = model.nearest_curve_known(tip, Some((ci, cp)));
                assert_eq!((a, pa), (k, pk), "{t}");
                known_used += 1;
            }
        }
        assert_eq!(model.total(&planned), model.total(&direct));
        assert_eq!(model.total(&given), model.total(&direct));
        assert!(known_used > bones.len() / 2);
    }
}

/// Bones absurdly far from every curve (extreme meta-parameters put them
/// there) have huge but finite costs: the fixed-point sums clamp each one
/// and saturate instead of overflowing, and the order still does not
/// matter. (Two such bones overflowed the `i128` sum before.)
#[test]
fn far_bones_cost_huge_amounts_without_overflow() {
    let curves = benchmark_curves();
    let model = CostModel::new(&curves, CostOptions::from_curves(&curves));
    let far = |k: f32| (Vec3::new(1e30 * k, 0.0, 0.0), Vec3::new(1e30 * k, 1.0, 0.0));
    let bones: Vec<(Vec3, Vec3)> = (1..=6)
        .map(|k| far(k as f32))
        .chain([(Vec3::ZERO, Vec3::Y)])
        .collect();
    let (forward, _, _) = run(&model, &bones);
    let mut back = bones.clone();
    back.reverse();
    let (backward, _, _) = run(&model, &back);
    assert_eq!(forward, backward);
    assert!(
        forward.distance.is_finite() && forward.distance > 1e20,
        "{forward:?}"
    );
    assert!(forward.total().is_finite(), "{forward:?}");
}

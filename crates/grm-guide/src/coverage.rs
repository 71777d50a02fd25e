//! Coverage: how much of each guiding curve the model follows.
//!
//! The point of drawing guiding curves is that the model follows them; the
//! cost of eq. 1-8 rewards bones near and along curves but does not say
//! whether every curve got some. Coverage does: a point of a curve is
//! **covered** when some bone (a segment from base to tip) passes within
//! the covering radius of it, and a curve's coverage is the covered share
//! of its arc length. The covering radius is the curve's thickness (its
//! tube, docs/curves.md) plus [`CoverageOptions::radius`] (0.15 by
//! default: the measure of the curve-coverage issue, in the curves' units).
//!
//! The curve is sampled at [`CoverageOptions::samples`] points evenly
//! spaced in arc length (from an arc-length table), each standing for an
//! equal share of the length; the uncovered runs of samples are the
//! **gaps**, reported as arc-length fractions `[from, to)` (the preview
//! tints them). A curve no bone comes near has coverage 0 and one gap
//! `[0, 1)`.

use glam::{DVec3, Vec3};

use crate::Curves;

/// How coverage is measured.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CoverageOptions {
    /// Added to each curve's thickness: a point within this distance of a
    /// bone is covered.
    pub radius: f64,
    /// Sample points per curve, evenly spaced in arc length (at least 2).
    pub samples: usize,
}

impl Default for CoverageOptions {
    /// Radius 0.15, 256 samples per curve.
    fn default() -> Self {
        CoverageOptions {
            radius: 0.15,
            samples: 256,
        }
    }
}

/// The coverage of one curve.
#[derive(Clone, Debug, PartialEq)]
pub struct CurveCoverage {
    /// The curve's name, if it has one.
    pub name: Option<String>,
    /// Its arc length.
    pub length: f64,
    /// The covered share of its arc length, in `[0, 1]`.
    pub fraction: f64,
    /// The uncovered stretches, as arc-length fractions `[from, to)`, in
    /// order along the curve.
    pub gaps: Vec<(f64, f64)>,
    /// The covering radius used: the curve's thickness plus
    /// [`CoverageOptions::radius`].
    pub radius: f64,
    /// How close the nearest bone comes to the curve (to its sample
    /// points); `f64::INFINITY` without bones. A curve with coverage 0 has
    /// this above [`Self::radius`]: how far the model stays from it.
    pub nearest: f64,
}

/// Distance from `p` to the segment `a`-`b` (a point when they coincide).
fn segment_distance(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let ab = b - a;
    let len2 = ab.length_squared();
    if len2 <= 0.0 || !len2.is_finite() {
        return p.distance(a);
    }
    let t = ((p - a).dot(ab) / len2).clamp(0.0, 1.0);
    p.distance(a + ab * t)
}

/// The coverage of every curve of `curves` by `bones` (`(base, tip)` in
/// world space, as the turtle makes them). Bones with a non-finite end are
/// ignored.
pub fn coverage(
    curves: &Curves,
    bones: &[(Vec3, Vec3)],
    options: &CoverageOptions,
) -> Vec<CurveCoverage> {
    let n = options.samples.max(2);
    let bones = finite_bones(bones);
    curves
        .curves()
        .iter()
        .map(|c| {
            let radius = c.params.thickness + options.radius;
            let (length, points) = sample_points(c, n);
            let mut covered = Vec::with_capacity(n);
            let mut nearest = f64::INFINITY;
            for p in points {
                let d = bones
                    .iter()
                    .map(|&(a, b)| segment_distance(p, a, b))
                    .fold(f64::INFINITY, f64::min);
                nearest = nearest.min(d);
                covered.push(d <= radius);
            }
            let mut gaps = Vec::new();
            let mut start = None;
            for (i, &cov) in covered.iter().chain(std::iter::once(&true)).enumerate() {
                match (cov, start) {
                    (false, None) => start = Some(i),
                    (true, Some(s)) => {
                        gaps.push((s as f64 / n as f64, i as f64 / n as f64));
                        start = None;
                    }
                    _ => {}
                }
            }
            let fraction = covered.iter().filter(|&&c| c).count() as f64 / n as f64;
            CurveCoverage {
                name: c.name.clone(),
                length,
                fraction,
                gaps,
                radius,
                nearest,
            }
        })
        .collect()
}

/// The share of a curve's length a model must cover for the curve to count
/// as followed (the curve-coverage issue's measure; `grmc sample --stats`
/// and the coverage benchmark use it).
pub const FOLLOWED: f64 = 0.8;

/// The bones with both ends finite, in `f64`.
fn finite_bones(bones: &[(Vec3, Vec3)]) -> Vec<(DVec3, DVec3)> {
    bones
        .iter()
        .filter(|(a, b)| a.is_finite() && b.is_finite())
        .map(|&(a, b)| (a.as_dvec3(), b.as_dvec3()))
        .collect()
}

/// Curve `c`'s arc length and its `n` sample points, evenly spaced in arc
/// length (the middle of each of `n` equal stretches), from a finer
/// arc-length table (linear between its entries).
fn sample_points(c: &crate::GuideCurve, n: usize) -> (f64, impl Iterator<Item = DVec3> + '_) {
    let fine = 8 * n;
    let table = c.bezier.arc_length_table(fine);
    let length = table.last().copied().unwrap_or(0.0);
    let mut j = 0usize;
    let points = (0..n).map(move |i| {
        let s = length * (i as f64 + 0.5) / n as f64;
        while j + 1 < fine && table[j + 1] < s {
            j += 1;
        }
        let (s0, s1) = (table[j], table[(j + 1).min(fine)]);
        let f = if s1 > s0 { (s - s0) / (s1 - s0) } else { 0.0 };
        let t = (j as f64 + f.clamp(0.0, 1.0)) / fine as f64;
        c.bezier.eval(t)
    });
    (length, points)
}

/// Whether [`coverage`] gives every curve a fraction of [`FOLLOWED`] or
/// more, decided with the same sample points and distances but without
/// measuring more than the verdict needs: a sample is covered at the first
/// bone within the radius, and a curve is decided once its covered samples
/// reach the share or its uncovered ones make the share out of reach. The
/// same answer as `coverage(..).iter().all(|c| c.fraction >= FOLLOWED)`
/// (a test checks it), at a fraction of the cost where curves are covered:
/// the refinement rounds' check (`grm-sample`, `docs/sampling.md` 4.5).
pub fn follows_every_curve(
    curves: &Curves,
    bones: &[(Vec3, Vec3)],
    options: &CoverageOptions,
) -> bool {
    let n = options.samples.max(2);
    let bones = finite_bones(bones);
    let share = |k: usize| k as f64 / n as f64 >= FOLLOWED;
    curves.curves().iter().all(|c| {
        let radius = c.params.thickness + options.radius;
        let (_, points) = sample_points(c, n);
        let mut k = 0usize;
        for (i, p) in points.enumerate() {
            if bones
                .iter()
                .any(|&(a, b)| segment_distance(p, a, b) <= radius)
            {
                k += 1;
                if share(k) {
                    return true;
                }
            } else if !share(k + (n - 1 - i)) {
                return false;
            }
        }
        share(k)
    })
}

/// How many of the bones' ends meet no other bone's end: a chain's root
/// and tip, each end of a lone bone (a fork's bones meet at their base). A
/// chain covers at most its length plus the covering radius at its two
/// free ends, not at every joint.
fn free_ends(bones: &[(DVec3, DVec3)]) -> usize {
    let key = |p: &DVec3| (p.x.to_bits(), p.y.to_bits(), p.z.to_bits());
    let mut ends: Vec<(u64, u64, u64)> = bones.iter().flat_map(|(a, b)| [key(a), key(b)]).collect();
    ends.sort_unstable();
    ends.chunk_by(|x, y| x == y)
        .filter(|g| g.len() == 1)
        .count()
}

/// The coverage report of `grmc sample --stats`: a line per curve (its
/// covered share and its gaps as arc-length percentages, or, for a curve
/// no bone comes near, how far the nearest one stays), then, when some
/// curve is followed over less than [`FOLLOWED`] of its length and the
/// bones are too few to cover the curves even laid end to end along them
/// (covering at most their length plus the covering radius at each free
/// end: a chain's root and tip, not its joints), a line that says so: the
/// grammar cannot reach every curve with the bones its schedule grows,
/// whatever the search does. Otherwise, a line for each curve under
/// [`FOLLOWED`] that the bones left over by the other curves' coverage
/// (the most they cover in all, less what they cover already) cannot
/// bring to it: the curves compete for the bones, and this one loses. A
/// curve either verdict names ends its own line with "too few bones for
/// it" (the preview shows the curves' lines).
pub fn describe(curves: &Curves, bones: &[(Vec3, Vec3)], options: &CoverageOptions) -> Vec<String> {
    let cov = coverage(curves, bones, options);
    let names: Vec<String> = cov
        .iter()
        .enumerate()
        .map(|(k, c)| match &c.name {
            Some(n) => format!("`{n}`"),
            None => format!("curve {k}"),
        })
        .collect();
    let width = names.iter().map(String::len).max().unwrap_or(0);
    let mut out = vec![format!(
        "coverage (share of each curve's length with a bone within its thickness + {}):",
        options.radius
    )];
    // The verdicts first: a curve they name says so on its own line too
    // (the preview shows each curve's line, not the report's last ones).
    let curve_length: f64 = cov.iter().map(|c| c.length).sum();
    let finite: Vec<(DVec3, DVec3)> = bones
        .iter()
        .filter(|(a, b)| a.is_finite() && b.is_finite())
        .map(|&(a, b)| (a.as_dvec3(), b.as_dvec3()))
        .collect();
    let bone_length: f64 = finite.iter().map(|(a, b)| a.distance(*b)).sum();
    let radius = cov.iter().map(|c| c.radius).fold(0.0, f64::max);
    let ends = free_ends(&finite);
    let reach = bone_length + radius * ends as f64;
    let mut verdicts = Vec::new();
    let mut short = vec![false; cov.len()];
    if cov.iter().any(|c| c.fraction < FOLLOWED) && reach < FOLLOWED * curve_length {
        for (k, c) in cov.iter().enumerate() {
            short[k] = c.fraction < FOLLOWED;
        }
        verdicts.push(format!(
            "  too few bones: {} bones, {bone_length:.2} long in all, cannot cover {:.0}% of the curves' {curve_length:.2} even laid along them (with the covering radius at their {ends} free ends: more generations grow more bones; fewer curves need fewer)",
            finite.len(),
            100.0 * FOLLOWED
        ));
    } else {
        // Enough bones for the curves together, but those that follow
        // some curves are not free for another: a curve the rest cannot
        // bring to FOLLOWED is named (the curves compete for the bones).
        let covered: Vec<f64> = cov.iter().map(|c| c.fraction * c.length).collect();
        let all: f64 = covered.iter().sum();
        for (k, (c, name)) in cov.iter().zip(&names).enumerate() {
            let lacks = FOLLOWED * c.length - covered[k];
            let free = reach - all;
            if c.fraction < FOLLOWED && free < lacks {
                short[k] = true;
                verdicts.push(format!(
                    "  too few bones for {name}: the {} bones cover at most {reach:.2} of curve length (their {bone_length:.2} and the covering radius at each of their {ends} free ends), {:.2} of it along the other curves; the {:.2} left is short of the {lacks:.2} it lacks for {:.0}% (the curves compete for the bones: more generations grow more bones; fewer curves need fewer)",
                    finite.len(),
                    all - covered[k],
                    free.max(0.0),
                    100.0 * FOLLOWED
                ));
            }
        }
    }
    for ((c, name), &short) in cov.iter().zip(&names).zip(&short) {
        let pct = 100.0 * c.fraction;
        let tail = if c.fraction == 0.0 {
            if c.nearest.is_finite() {
                format!(
                    "not reached: the nearest bone stays {:.2} from it (covering radius {:.2})",
                    c.nearest, c.radius
                )
            } else {
                "not reached: the model has no bones".to_string()
            }
        } else if c.gaps.is_empty() {
            "no gaps".to_string()
        } else {
            let shown: Vec<String> = c
                .gaps
                .iter()
                .take(6)
                .map(|&(a, b)| format!("{:.0}-{:.0}%", 100.0 * a, 100.0 * b))
                .collect();
            let more = c.gaps.len() - shown.len();
            format!(
                "gaps at {}{}",
                shown.join(", "),
                if more > 0 {
                    format!(" and {more} more")
                } else {
                    String::new()
                }
            )
        };
        let verdict = if short { "; too few bones for it" } else { "" };
        out.push(format!("  {name:<width$} {pct:>5.1}%  {tail}{verdict}"));
    }
    out.extend(verdicts);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn curves(json: &str) -> Curves {
        Curves::from_json_str("t.curves.json", json).expect("curves")
    }

    fn line() -> Curves {
        // A straight curve from (0,0,0) to (0,4,0), evenly parametrised.
        curves(
            r#"{ "version": 1, "curves": [
                { "name": "trunk", "points": [[0,0,0], [0,1.3333333333333333,0], [0,2.6666666666666665,0], [0,4,0]] } ] }"#,
        )
    }

    #[test]
    fn follows_every_curve_is_coverages_verdict() {
        // Two curves; a bone up the trunk to a varying height, and one
        // along the arm to another: around 80% of either, each side.
        let two = curves(
            r#"{ "version": 1, "curves": [
                { "name": "trunk", "points": [[0,0,0], [0,1,0], [0,2,0], [0,3,0]] },
                { "name": "arm", "points": [[0,3,0], [0.5,3.5,0], [1.2,4,0], [2,4.3,0]] } ] }"#,
        );
        let opts = CoverageOptions::default();
        let (mut yes, mut no) = (0, 0);
        for i in 0..=40 {
            for j in [0.0f32, 0.3, 0.6, 0.7, 0.75, 0.8, 0.9, 1.0] {
                let h = 1.5 + 1.5 * i as f32 / 40.0;
                let arm = two.curves()[1].bezier.eval(f64::from(j)).as_vec3();
                let bones = [
                    (Vec3::ZERO, Vec3::new(0.0, h, 0.0)),
                    (Vec3::new(0.0, 3.0, 0.0), arm),
                ];
                let all = coverage(&two, &bones, &opts)
                    .iter()
                    .all(|c| c.fraction >= FOLLOWED);
                assert_eq!(follows_every_curve(&two, &bones, &opts), all, "{h} {j}");
                if all { yes += 1 } else { no += 1 }
            }
        }
        // Both verdicts are exercised.
        assert!(yes > 10 && no > 10, "{yes} {no}");
        assert!(!follows_every_curve(&two, &[], &opts));
    }

    #[test]
    fn a_bone_along_half_the_curve_covers_half_of_it() {
        let bones = [(Vec3::new(0.0, 0.0, 0.0), Vec3::new(0.0, 2.0, 0.0))];
        let c = &coverage(&line(), &bones, &CoverageOptions::default())[0];
        assert_eq!(c.name.as_deref(), Some("trunk"));
        assert!((c.length - 4.0).abs() < 1e-9);
        // Covered to y = 2 + 0.15: 2.15 / 4.
        assert!(
            (c.fraction - 2.15 / 4.0).abs() < 2.0 / 256.0,
            "{}",
            c.fraction
        );
        assert_eq!(c.gaps.len(), 1);
        assert!((c.gaps[0].0 - 2.15 / 4.0).abs() < 2.0 / 256.0);
        assert_eq!(c.gaps[0].1, 1.0);
    }

    #[test]
    fn no_bones_cover_nothing_and_bones_far_away_neither() {
        let c = &coverage(&line(), &[], &CoverageOptions::default())[0];
        assert_eq!(c.fraction, 0.0);
        assert_eq!(c.gaps, vec![(0.0, 1.0)]);
        let far = [(Vec3::new(1.0, 0.0, 0.0), Vec3::new(1.0, 4.0, 0.0))];
        let c = &coverage(&line(), &far, &CoverageOptions::default())[0];
        assert_eq!(c.fraction, 0.0);
        // Within the radius: parallel at 0.1 covers it all.
        let near = [(Vec3::new(0.1, 0.0, 0.0), Vec3::new(0.1, 4.0, 0.0))];
        let c = &coverage(&line(), &near, &CoverageOptions::default())[0];
        assert_eq!(c.fraction, 1.0);
        assert!(c.gaps.is_empty());
    }

    #[test]
    fn gaps_in_the_middle_and_thickness_widens_the_radius() {
        // Bones on [0, 1] and [3, 4]: a gap from about 1.15 to 2.85.
        let bones = [
            (Vec3::new(0.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0)),
            (Vec3::new(0.0, 3.0, 0.0), Vec3::new(0.0, 4.0, 0.0)),
        ];
        let c = &coverage(&line(), &bones, &CoverageOptions::default())[0];
        assert_eq!(c.gaps.len(), 1);
        let (a, b) = c.gaps[0];
        assert!((a - 1.15 / 4.0).abs() < 2.0 / 256.0, "{a}");
        assert!((b - 2.85 / 4.0).abs() < 2.0 / 256.0, "{b}");
        // A thick curve (radius 1) is covered by a bone 1.1 away.
        let thick = curves(
            r#"{ "version": 1, "defaults": { "thickness": 1 }, "curves": [
                { "points": [[0,0,0], [0,1.3333333333333333,0], [0,2.6666666666666665,0], [0,4,0]] } ] }"#,
        );
        let side = [(Vec3::new(1.1, 0.0, 0.0), Vec3::new(1.1, 4.0, 0.0))];
        assert_eq!(
            coverage(&thick, &side, &CoverageOptions::default())[0].fraction,
            1.0
        );
        assert_eq!(
            coverage(&line(), &side, &CoverageOptions::default())[0].fraction,
            0.0
        );
    }

    #[test]
    fn the_report_names_gaps_unreached_curves_and_too_few_bones() {
        let two = curves(
            r#"{ "version": 1, "curves": [
                { "name": "trunk", "points": [[0,0,0], [0,1.3333333333333333,0], [0,2.6666666666666665,0], [0,4,0]] },
                { "name": "far", "points": [[5,0,0], [5,1,0], [5,2,0], [5,3,0]] } ] }"#,
        );
        let bones = [(Vec3::new(0.0, 0.0, 0.0), Vec3::new(0.0, 2.0, 0.0))];
        let lines = describe(&two, &bones, &CoverageOptions::default());
        assert_eq!(lines.len(), 4, "{lines:#?}");
        assert!(lines[1].contains("`trunk`"), "{}", lines[1]);
        assert!(lines[1].contains(" 53.9%"), "{}", lines[1]);
        assert!(lines[1].contains("gaps at 54-100%"), "{}", lines[1]);
        assert!(
            lines[2].contains("`far`")
                && lines[2].contains("  0.0%")
                && lines[2].contains("not reached: the nearest bone stays 5.00 from it"),
            "{}",
            lines[2]
        );
        assert!(
            lines[3].contains("too few bones: 1 bones, 2.00 long"),
            "{}",
            lines[3]
        );
        // A chain of 8 bones along the trunk covers at most its 4 and the
        // radius at its 2 free ends (4.3), short of 80% of the curves' 7:
        // too few, and the curve left short says so on its line too.
        let chain: Vec<(Vec3, Vec3)> = (0..8)
            .map(|k| {
                (
                    Vec3::new(0.0, k as f32 * 0.5, 0.0),
                    Vec3::new(0.0, k as f32 * 0.5 + 0.5, 0.0),
                )
            })
            .collect();
        let lines = describe(&two, &chain, &CoverageOptions::default());
        assert_eq!(lines.len(), 4, "{lines:#?}");
        assert!(lines[1].contains("100.0%  no gaps"), "{}", lines[1]);
        assert!(
            lines[2].ends_with("; too few bones for it") && !lines[1].contains("too few"),
            "{lines:#?}"
        );
        assert!(
            lines[3].contains("too few bones: 8 bones, 4.00 long in all")
                && lines[3].contains("at their 2 free ends"),
            "{}",
            lines[3]
        );
        // Twelve bones apart (24 free ends) could cover 3.6 + 24 * 0.15 =
        // 7.2: enough for the curves (but badly placed): no such line.
        let apart: Vec<(Vec3, Vec3)> = (0..12)
            .map(|k| {
                (
                    Vec3::new(0.0, k as f32 / 3.0, 0.0),
                    Vec3::new(0.0, k as f32 / 3.0 + 0.3, 0.0),
                )
            })
            .collect();
        let lines = describe(&two, &apart, &CoverageOptions::default());
        assert_eq!(lines.len(), 3, "{lines:#?}");
        assert!(lines[1].contains("100.0%  no gaps"), "{}", lines[1]);
        assert!(!lines[2].contains("too few"), "{}", lines[2]);
        // Enough in all for a far curve as long as the trunk (10 bones
        // apart can cover at most 3.5 + 20 * 0.15 = 6.5, 80% of the
        // curves' 8 is 6.4), but they all cover the trunk: the 2.5 left
        // cannot give `far` the 3.2 it lacks.
        let long_far = curves(
            r#"{ "version": 1, "curves": [
                { "name": "trunk", "points": [[0,0,0], [0,1.3333333333333333,0], [0,2.6666666666666665,0], [0,4,0]] },
                { "name": "far", "points": [[5,0,0], [5,1.3333333333333333,0], [5,2.6666666666666665,0], [5,4,0]] } ] }"#,
        );
        let ten: Vec<(Vec3, Vec3)> = (0..10)
            .map(|k| {
                (
                    Vec3::new(0.0, k as f32 * 0.4, 0.0),
                    Vec3::new(0.0, k as f32 * 0.4 + 0.35, 0.0),
                )
            })
            .collect();
        let lines = describe(&long_far, &ten, &CoverageOptions::default());
        assert_eq!(lines.len(), 4, "{lines:#?}");
        assert!(lines[2].ends_with("; too few bones for it"), "{}", lines[2]);
        assert!(
            lines[3].contains("too few bones for `far`: the 10 bones cover at most 6.50")
                && lines[3].contains("each of their 20 free ends")
                && lines[3].contains("4.00 of it along the other curves")
                && lines[3].contains("the 2.50 left is short of the 3.20 it lacks"),
            "{}",
            lines[3]
        );
        // No bones at all.
        let lines = describe(&two, &[], &CoverageOptions::default());
        assert!(lines[1].contains("not reached: the model has no bones"));
    }

    #[test]
    fn non_finite_bones_are_ignored() {
        let bones = [(Vec3::NAN, Vec3::new(0.0, 4.0, 0.0))];
        let c = &coverage(&line(), &bones, &CoverageOptions::default())[0];
        assert_eq!(c.fraction, 0.0);
    }
}

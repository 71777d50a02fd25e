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
    let bones: Vec<(DVec3, DVec3)> = bones
        .iter()
        .filter(|(a, b)| a.is_finite() && b.is_finite())
        .map(|&(a, b)| (a.as_dvec3(), b.as_dvec3()))
        .collect();
    curves
        .curves()
        .iter()
        .map(|c| {
            let radius = c.params.thickness + options.radius;
            // Parameters of n points evenly spaced in arc length, from a
            // finer arc-length table (linear between its entries).
            let fine = 8 * n;
            let table = c.bezier.arc_length_table(fine);
            let length = table.last().copied().unwrap_or(0.0);
            let mut covered = Vec::with_capacity(n);
            let mut j = 0usize;
            for i in 0..n {
                // The middle of the i-th of n equal stretches.
                let s = length * (i as f64 + 0.5) / n as f64;
                while j + 1 < fine && table[j + 1] < s {
                    j += 1;
                }
                let (s0, s1) = (table[j], table[(j + 1).min(fine)]);
                let f = if s1 > s0 { (s - s0) / (s1 - s0) } else { 0.0 };
                let t = (j as f64 + f.clamp(0.0, 1.0)) / fine as f64;
                let p = c.bezier.eval(t);
                covered.push(
                    bones
                        .iter()
                        .any(|&(a, b)| segment_distance(p, a, b) <= radius),
                );
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
            }
        })
        .collect()
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
    fn non_finite_bones_are_ignored() {
        let bones = [(Vec3::NAN, Vec3::new(0.0, 4.0, 0.0))];
        let c = &coverage(&line(), &bones, &CoverageOptions::default())[0];
        assert_eq!(c.fraction, 0.0);
    }
}

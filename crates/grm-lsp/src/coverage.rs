//! The preview's curve coverage: how much of each guiding curve the shown
//! sample-mode model follows (`grm_guide::coverage`, docs/curves.md 2.8),
//! with each gap as points along the curve so the page can tint the
//! uncovered stretches without arc-length arithmetic of its own.
//!
//! Inputs: the curves the search used and the model's bones. Output: one
//! [`CoverageOut`] per curve, in the curves' order. The measure and the
//! wording are `grm_guide`'s (the same as `grmc sample --stats`).

use grm_guide::{CoverageOptions, Curves};
use serde::{Deserialize, Serialize};

/// Points per whole curve when a gap is drawn (a gap gets its share, at
/// least two).
const GAP_POINTS_PER_CURVE: usize = 128;

/// The coverage of one curve by the shown model.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct CoverageOut {
    /// The curve's name, if it has one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// The covered share of its arc length, in `[0, 1]`.
    pub fraction: f64,
    /// The covering radius (the curve's thickness plus 0.15).
    pub radius: f64,
    /// How close the nearest bone comes; absent without bones.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nearest: Option<f64>,
    /// No bone comes within the covering radius anywhere along it.
    pub unreached: bool,
    /// The uncovered stretches as arc-length fractions `[from, to)`.
    pub gaps: Vec<[f64; 2]>,
    /// Each gap as points along the curve (world space), for drawing.
    pub gap_points: Vec<Vec<[f32; 3]>>,
    /// What `grmc sample --stats` says of it: "no gaps", "gaps at ...",
    /// or why it is not reached.
    pub note: String,
}

/// The coverage of every curve of `curves` by `bones` (`(base, tip)`).
pub fn coverage(curves: &Curves, bones: &[(glam::Vec3, glam::Vec3)]) -> Vec<CoverageOut> {
    let options = CoverageOptions::default();
    let measured = grm_guide::coverage(curves, bones, &options);
    // `describe`'s first line is its heading; then one line per curve,
    // whose tail after the percentage is the note.
    let lines = grm_guide::describe_coverage(curves, bones, &options);
    measured
        .iter()
        .zip(curves.curves())
        .enumerate()
        .map(|(k, (c, curve))| {
            let note = lines
                .get(k + 1)
                .and_then(|l| l.split_once("%  "))
                .map_or_else(String::new, |(_, tail)| tail.to_string());
            let table = curve.bezier.arc_length_table(8 * GAP_POINTS_PER_CURVE);
            let gap_points = c
                .gaps
                .iter()
                .map(|&(from, to)| points_between(&curve.bezier, &table, from, to))
                .collect();
            CoverageOut {
                name: c.name.clone(),
                fraction: c.fraction,
                radius: c.radius,
                nearest: c.nearest.is_finite().then_some(c.nearest),
                unreached: c.fraction == 0.0,
                gaps: c.gaps.iter().map(|&(a, b)| [a, b]).collect(),
                gap_points,
                note,
            }
        })
        .collect()
}

/// Points of `bezier` from arc-length fraction `from` to `to`, evenly
/// spaced in arc length (from its arc-length `table`, linear between
/// entries).
fn points_between(bezier: &grm_guide::Bezier3, table: &[f64], from: f64, to: f64) -> Vec<[f32; 3]> {
    let length = table.last().copied().unwrap_or(0.0);
    let fine = table.len().saturating_sub(1).max(1);
    let n = (((to - from) * GAP_POINTS_PER_CURVE as f64).ceil() as usize).max(1) + 1;
    let mut j = 0usize;
    (0..n)
        .map(|i| {
            let s = length * (from + (to - from) * i as f64 / (n - 1) as f64);
            while j + 1 < fine && table[j + 1] < s {
                j += 1;
            }
            let (s0, s1) = (table[j], table[(j + 1).min(fine)]);
            let f = if s1 > s0 { (s - s0) / (s1 - s0) } else { 0.0 };
            let t = (j as f64 + f.clamp(0.0, 1.0)) / fine as f64;
            bezier.eval(t.clamp(0.0, 1.0)).as_vec3().to_array()
        })
        .collect()
}

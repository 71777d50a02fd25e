//! `grm-guide`: guiding curves and the guided sampler's cost.
//!
//! **Role.** The parts of the SOSMC guided sampler (Calder, DESIGN.md
//! section 5) that do not depend on the derivation engine: the guiding
//! curves file, closest points on 3D cubic Béziers, the per-bone cost of
//! equations 1-8, the heuristic term of equations 9-10, the thick-curve and
//! density extensions, and a volume-matching baseline cost for comparison.
//!
//! **Inputs.** A curves file (`*.curves.json`, format in `docs/curves.md`,
//! loaded by [`Curves::load`]); bones as world-space `(base, tip)` pairs
//! from the turtle, added one at a time by the sampler; for the heuristic,
//! a symbol's frame and expected direction.
//!
//! **Outputs.** [`BoneCost`] per bone and [`CostBreakdown`] per model (lower
//! is better, negative allowed), from a shared read-only [`CostModel`] and a
//! per-particle [`CostState`]; [`VolumeCost`] for the baseline; per curve,
//! the share of its arc length the model's bones follow and the gaps
//! ([`coverage`]).
//!
//! **Invariants.**
//! * A loaded [`Curves`] is valid: at least one curve, finite control
//!   points, no zero-length curve, parameters in range (alignment offset in
//!   `[-1, 1]`, scales `>= 0`, segment length `> 0`), bounded segment count.
//!   Errors name the file, the curve and the field; nothing panics on input.
//! * A model's cost does not depend on the order its bones were added, bit
//!   for bit: every term is a sum over bones, pairs or segment use counts,
//!   accumulated in fixed point.
//! * [`CostState`] clones are cheap (a small counter vector and an `Arc`).
//! * Everything is deterministic: no clocks, no global state, no hashing
//!   with random seeds.
//!
//! ```
//! use grm_guide::{CostModel, CostOptions, Curves};
//! use glam::Vec3;
//!
//! let curves = Curves::from_json_str("tree.curves.json", r#"{
//!     "version": 1,
//!     "curves": [{ "name": "trunk", "points": [[0,0,0], [0,1,0], [0,2,0], [0,3,0]] }]
//! }"#).unwrap();
//! let model = CostModel::new(&curves, CostOptions::from_curves(&curves));
//! let mut state = model.new_state();
//! // A bone straight up the trunk: distance 0, alignment (0.6 - 1) * 400.
//! let cost = model.add_bone(&mut state, Vec3::ZERO, Vec3::Y);
//! assert_eq!(cost.distance, 0.0);
//! assert!((cost.alignment - -160.0).abs() < 1e-9);
//! assert!((model.total(&state).total() - -160.0).abs() < 1e-9);
//! ```

pub mod bezier;
pub mod cost;
pub mod coverage;
pub mod curves;
mod density;
mod fixed;
pub mod volume;

pub use bezier::{BRACKET_SAMPLES, Bezier3, BracketSamples, ClosestPoint};
pub use cost::{
    BoneCost, BonePlan, CostBreakdown, CostModel, CostOptions, CostState, ExpectedDirection, Tubes,
    alignment_cost, distance_cost, expected_direction, utilization_sum,
};
pub use coverage::{
    CoverageOptions, CurveCoverage, FOLLOWED, coverage, describe as describe_coverage,
    follows_every_curve,
};
pub use curves::{
    CurveParams, Curves, CurvesError, CurvesErrorKind, DensityParams, FORMAT_VERSION, GuideCurve,
    Location, MAX_CURVES_BYTES, MAX_SEGMENTS_PER_CURVE, MAX_SEGMENTS_TOTAL,
};
pub use volume::{VolumeCost, VolumeError, VolumeOptions, VolumeState, VolumeTarget};

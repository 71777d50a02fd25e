//! The guiding-curve cost of Calder section 3.3 (equations 1-8), the
//! heuristic term of equation 10, thick curves and the density term.
//!
//! Conventions (also in `docs/curves.md`):
//!
//! * Lower is better; costs may be negative (a bone that follows a curve
//!   lowers the model's cost).
//! * Curve choice (eq. 1): the curve whose tube surface is nearest to the
//!   bone's base, i.e. the argmin of `|base - closest| - thickness`; with
//!   thickness 0 this is eq. 1 exactly. Ties go to the lower curve index.
//! * Distance (eq. 2-3): `d = max(0, |base - closest| - thickness)`, cost
//!   `m0 + m1 d + m2 d^2`.
//! * Alignment (eq. 4-6): `d_bone = -(tip - base) / |tip - base|` (the
//!   paper's minus sign), `d_guide` = unit tangent at the closest point, cost
//!   `(d_bone . d_guide + delta_a) * scale_a`. A bone along the curve's
//!   direction costs `(delta_a - 1) scale_a` (negative), a perpendicular one
//!   `delta_a scale_a`, an opposite one `(delta_a + 1) scale_a`. A
//!   zero-length bone has no direction and is costed as perpendicular.
//! * Utilization (eq. 7): see [`CostModel::add_bone`] and `docs/curves.md`:
//!   the total is `-sum_curves scale_u sum_segments G(n_s)` with
//!   `G(n) = sum_{k<n} e^-k`, a function of the use counts alone.
//! * Density: `scale (1 - r / radius)^2` per unordered pair of bone
//!   midpoints at distance `r < radius`.
//!
//! Every term is order-independent, and the totals are accumulated in fixed
//! point (`crate::fixed`), so a model's [`CostBreakdown`] is bit-for-bit
//! the same whatever order its bones were added in.

use glam::{Affine3A, DVec3, Vec3};

use crate::bezier::{Bezier3, BracketSamples, ClosestPoint};
use crate::curves::{CurveParams, Curves, DensityParams, segment_count};
use crate::density::PersistentGrid;
use crate::fixed::{to_f64, to_fixed};

/// Entries in the arc-length table used to map a curve parameter to a
/// utilization segment.
const ARC_TABLE: usize = 256;

/// Use counts past this contribute less than 1e-27 of the first use, below
/// the fixed-point resolution for any sane `scale_u`: the utilization table
/// stops here and counts saturate in effect (order independence is kept,
/// since the contribution is a function of the count alone).
const UTIL_TABLE: usize = 64;

/// Options of the cost that are not per curve.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CostOptions {
    /// The density term; `None` (the default) turns it off.
    pub density: Option<DensityParams>,
}

impl CostOptions {
    /// The options a curves file asks for (its `density` object).
    pub fn from_curves(curves: &Curves) -> Self {
        Self {
            density: curves.density(),
        }
    }
}

/// The cost of one bone, by term (eq. 3, 6, 7 and the density term).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BoneCost {
    /// Index of the guiding curve chosen by eq. 1; `None` for a bone whose
    /// base or tip is not finite (its cost is infinite).
    pub curve: Option<usize>,
    /// `COST_d` (eq. 3).
    pub distance: f64,
    /// `COST_a` (eq. 6).
    pub alignment: f64,
    /// `COST_u` (eq. 7) given the segment uses before this bone.
    pub utilization: f64,
    /// Density: the pairs this bone forms with the bones already there.
    pub density: f64,
}

impl BoneCost {
    /// Sum of the terms (eq. 8 plus density).
    pub fn total(&self) -> f64 {
        self.distance + self.alignment + self.utilization + self.density
    }
}

/// A bone's geometric cost terms, computed before it is added to a state
/// ([`CostModel::plan_bone`]): eq. 1's curve, eq. 3 and eq. 6, and the range
/// of utilization segments eq. 7 will count. What depends on the state
/// (segment counts, density neighbours) is evaluated when it is peeked at
/// or added.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BonePlan {
    base: DVec3,
    tip: DVec3,
    /// `None` for a bone with a non-finite end.
    curve: Option<usize>,
    distance: f64,
    alignment: f64,
    /// Distance from the base to the curve's axis (eq. 2's
    /// `|base - CLOSEST|`).
    base_dist: f64,
    /// First and last utilization segment of the curve (inclusive), when
    /// the curve's utilization is on.
    segments: Option<(u32, u32)>,
    /// The closest point of the curve to the tip (searched for the
    /// utilization segments).
    tip_closest: Option<ClosestPoint>,
    /// Other curves whose covering tube holds both ends (a bone at a fork
    /// covers the branch it leaves along, not only eq. 1's curve): the
    /// curve and the first and last segment spanned, for
    /// [`CostModel::covered_segments`] (coverage only, no cost).
    also: [Option<(u32, u32, u32)>; MAX_ALSO],
}

/// How many curves besides eq. 1's a bone plan records as covered.
const MAX_ALSO: usize = 3;

impl BonePlan {
    fn non_finite(base: Vec3, tip: Vec3) -> BonePlan {
        BonePlan {
            base: base.as_dvec3(),
            tip: tip.as_dvec3(),
            curve: None,
            distance: f64::INFINITY,
            alignment: 0.0,
            base_dist: f64::INFINITY,
            segments: None,
            tip_closest: None,
            also: [None; MAX_ALSO],
        }
    }

    /// The curve eq. 1 chose; `None` for a bone with a non-finite end.
    pub fn curve(&self) -> Option<usize> {
        self.curve
    }

    /// The world-space base and tip it was planned for.
    pub fn ends(&self) -> (DVec3, DVec3) {
        (self.base, self.tip)
    }

    /// The chosen curve and its closest point to the tip, when the plan
    /// searched it (the curve's utilization is on): reusable as
    /// [`CostModel::nearest_curve_known`]'s `known` at the tip.
    pub fn tip_closest(&self) -> Option<(usize, &ClosestPoint)> {
        Some((self.curve?, self.tip_closest.as_ref()?))
    }
}

/// The covering tubes that hold a point ([`CostModel::tubes_at`]): up to
/// [`Tubes::MAX`] curves, each with the arc length of the point's closest
/// point on it. Small and `Copy`, so that an open symbol can keep its own.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Tubes {
    n: u8,
    at: [(u32, f64); Tubes::MAX],
}

impl Tubes {
    /// The most tubes recorded.
    pub const MAX: usize = 8;

    /// (curve, arc length) of each tube.
    pub fn iter(&self) -> impl Iterator<Item = &(u32, f64)> {
        self.at[..self.n as usize].iter()
    }

    /// Whether no tube holds the point.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }
}

/// The cost of a whole model, by term.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CostBreakdown {
    /// Sum of `COST_d` over bones.
    pub distance: f64,
    /// Sum of `COST_a` over bones.
    pub alignment: f64,
    /// Utilization total, `-sum scale_u G(n_s)`.
    pub utilization: f64,
    /// Density total over pairs.
    pub density: f64,
    /// Bones added.
    pub bones: u64,
    /// Bones with a non-finite base or tip; any makes [`Self::total`] `+inf`.
    pub non_finite: u64,
    total_fixed: i128,
}

impl CostBreakdown {
    /// `COST(x)`: the sum of all terms (exact fixed-point sum, then rounded
    /// once), or `+inf` if a bone was not finite.
    pub fn total(&self) -> f64 {
        if self.non_finite > 0 {
            f64::INFINITY
        } else {
            to_f64(self.total_fixed)
        }
    }
}

/// The cost state of one particle (one partial model): segment use counts,
/// running fixed-point totals and, with the density term on, the bone
/// midpoints.
///
/// Cloning is cheap: one `Vec<u16>` with a counter per utilization segment
/// of all curves (tens to a few hundred; validation caps it at
/// [`crate::MAX_SEGMENTS_TOTAL`]) copied with one allocation, plus an `Arc`
/// increment for the density grid. A flat vector beats a persistent map
/// here: each bone reads and writes several adjacent counters, which is a
/// few contiguous loads and stores in a vector and a hash/pointer walk per
/// counter in a map, while the clone it saves is a single small `memcpy`.
/// The density set, which grows with the model, is persistent instead
/// (`crate::density`).
#[derive(Clone, Debug)]
pub struct CostState {
    /// The use count of each utilization segment (`total_segments` of
    /// them), then each curve's count of covered segments (`covered`'s
    /// `true` flags in its range, kept as flags are set, so the coverage
    /// term and the look-ahead read it without a scan; at most
    /// [`crate::MAX_SEGMENTS_TOTAL`], so a `u16` holds it): one
    /// allocation for both.
    uses: Vec<u16>,
    /// Per utilization segment: whether a bone within the covering radius
    /// of the curve spans it ([`CostModel::covered_segments`]).
    covered: Vec<bool>,
    distance: i128,
    alignment: i128,
    utilization: i128,
    density: i128,
    bones: u64,
    non_finite: u64,
    grid: Option<PersistentGrid>,
}

impl CostState {
    /// Heap bytes this state owns (its segment counters; the density
    /// grid is shared between the states cloned from one another).
    pub fn heap_bytes(&self) -> usize {
        self.uses.capacity() * std::mem::size_of::<u16>() + self.covered.capacity()
    }

    /// Bones added so far.
    pub fn bones(&self) -> u64 {
        self.bones
    }
}

#[derive(Clone, Debug)]
struct CurveData {
    bez: Bezier3,
    samples: BracketSamples,
    lo: DVec3,
    hi: DVec3,
    params: CurveParams,
    seg_offset: usize,
    n_seg: usize,
    /// Arc length at `i / ARC_TABLE`.
    arc: Vec<f64>,
    /// `util[n] = fixed(scale_u * G(n))`, `G(n) = sum_{k<n} e^-k`.
    util: [i128; UTIL_TABLE + 1],
}

impl CurveData {
    /// Utilization segment of parameter `t`: arc length from the start over
    /// the segment length, clamped to the last segment.
    fn segment(&self, t: f64) -> usize {
        self.segment_at_arc(self.arc_at(t))
    }

    /// Arc length from the start to parameter `t` (linear in the table).
    fn arc_at(&self, t: f64) -> f64 {
        let x = t.clamp(0.0, 1.0) * ARC_TABLE as f64;
        // `x >= 0` (or NaN, which casts to 0): the cast truncates, which is
        // `floor` there, without a call to libm's `floor` (the baseline
        // x86-64 target has no rounding instruction).
        let i = (x as usize).min(ARC_TABLE - 1);
        self.arc[i] + (self.arc[i + 1] - self.arc[i]) * (x - i as f64)
    }

    /// Utilization segment holding arc length `s`, clamped to the last.
    fn segment_at_arc(&self, s: f64) -> usize {
        // Saturating cast, truncating: `floor` for the non-negative values
        // `max` leaves (NaN casts to 0), without a call to libm's `floor`.
        let k = (s / self.params.segment_length).max(0.0);
        (k as usize).min(self.n_seg - 1)
    }

    #[inline]
    fn util(&self, n: u16) -> i128 {
        self.util[(n as usize).min(UTIL_TABLE)]
    }
}

/// The cost function for one set of curves: precomputed per-curve data
/// (bracket samples, bounds, arc-length tables, utilization tables). Shared
/// read-only by all particles; per-particle data lives in [`CostState`].
#[derive(Clone, Debug)]
pub struct CostModel {
    curves: Vec<CurveData>,
    /// Added to a curve's thickness: a bone with both ends within that
    /// distance of the curve covers the segments it spans
    /// ([`Self::covered_segments`]).
    cover_radius: f64,
    total_segments: usize,
    density: Option<DensityParams>,
    /// Curves that start in another curve's covering tube (an arm drawn
    /// from a trunk): (the branch, the curve it starts on, the arc length
    /// there), for the reach look-ahead's branches
    /// ([`Self::uncovered_within_reach`]).
    attached: Vec<(usize, usize, f64)>,
    /// Whether a bone also covers the other curves whose tube holds both
    /// its ends (`BonePlan::also`; default on).
    cover_others: bool,
}

/// Eq. 4-6: `(d_bone . d_guide + offset) * scale` with
/// `d_bone = -(dir / |dir|)` and `guide` a unit tangent. A zero-length `dir`
/// is costed as perpendicular (`offset * scale`).
pub fn alignment_cost(dir: DVec3, guide: DVec3, scale: f64, offset: f64) -> f64 {
    let len = dir.length();
    let d_bone_dot_guide = if len > 0.0 && len.is_finite() {
        -(dir / len).dot(guide)
    } else {
        0.0
    };
    (d_bone_dot_guide + offset) * scale
}

/// Eq. 2-3 with thickness: `d = max(0, dist - thickness)`,
/// `m0 + m1 d + m2 d^2`.
pub fn distance_cost(dist: f64, params: &CurveParams) -> f64 {
    let d = (dist - params.thickness).max(0.0);
    let [m0, m1, m2] = params.distance;
    m0 + (m1 + m2 * d) * d
}

/// `G(n) = sum_{k=0}^{n-1} e^-k`: the utilization of a segment used `n`
/// times, in units of `scale_u` (with the sign left out).
pub fn utilization_sum(n: u32) -> f64 {
    (0..n).map(|k| (-(k as f64)).exp()).sum()
}

impl CostModel {
    /// Precomputes the per-curve data for `curves`.
    pub fn new(curves: &Curves, options: CostOptions) -> Self {
        let mut seg_offset = 0;
        let data = curves
            .curves()
            .iter()
            .map(|c| {
                let bez = c.bezier;
                let arc = bez.arc_length_table(ARC_TABLE);
                let length = arc[ARC_TABLE];
                let n_seg = segment_count(length, c.params.segment_length);
                let (lo, hi) = bez.bounds();
                let mut util = [0i128; UTIL_TABLE + 1];
                for (n, u) in util.iter_mut().enumerate() {
                    *u = to_fixed(c.params.utilization_scale * utilization_sum(n as u32));
                }
                let d = CurveData {
                    bez,
                    samples: bez.bracket_samples(),
                    lo,
                    hi,
                    params: c.params,
                    seg_offset,
                    n_seg,
                    arc,
                    util,
                };
                seg_offset += n_seg;
                d
            })
            .collect();
        let mut m = Self {
            curves: data,
            cover_radius: crate::coverage::CoverageOptions::default().radius,
            total_segments: seg_offset,
            density: options.density,
            attached: Vec::new(),
            cover_others: true,
        };
        m.attach();
        m
    }

    /// Finds the curves that start in another curve's covering tube
    /// (`attached`).
    fn attach(&mut self) {
        let mut attached = Vec::new();
        for (j, b) in self.curves.iter().enumerate() {
            let start = b.bez.eval(0.0);
            for (c, on) in self.curves.iter().enumerate() {
                if c == j || on.params.utilization_scale <= 0.0 {
                    continue;
                }
                let cp = on.bez.closest_point_sampled(&on.samples, start);
                if cp.dist <= on.params.thickness + self.cover_radius {
                    attached.push((j, c, on.arc_at(cp.t)));
                }
            }
        }
        self.attached = attached;
    }

    /// A fresh state: no bones.
    pub fn new_state(&self) -> CostState {
        CostState {
            uses: vec![0; self.total_segments + self.curves.len()],
            covered: vec![false; self.total_segments],
            distance: 0,
            alignment: 0,
            utilization: 0,
            density: 0,
            bones: 0,
            non_finite: 0,
            grid: self.density.map(|d| PersistentGrid::new(d.radius)),
        }
    }

    /// Number of curves.
    pub fn curve_count(&self) -> usize {
        self.curves.len()
    }

    /// Number of utilization segments of curve `curve` (0 if out of range).
    pub fn segment_count(&self, curve: usize) -> usize {
        self.curves.get(curve).map_or(0, |c| c.n_seg)
    }

    /// How many bones have used each segment of `curve` in `state` (empty
    /// if out of range): for the preview and for tests.
    pub fn segment_uses<'s>(&self, state: &'s CostState, curve: usize) -> &'s [u16] {
        match self.curves.get(curve) {
            Some(c) => state
                .uses
                .get(c.seg_offset..c.seg_offset + c.n_seg)
                .unwrap_or(&[]),
            None => &[],
        }
    }

    /// Whether a planned bone covers the segments it spans: both its ends
    /// within the curve's thickness plus the covering radius of the curve
    /// (the measure of [`crate::coverage`], taken per utilization segment).
    fn plan_covers(&self, plan: &BonePlan) -> bool {
        let (Some(ci), Some(tip)) = (plan.curve, plan.tip_closest.as_ref()) else {
            return false;
        };
        let Some(c) = self.curves.get(ci) else {
            return false;
        };
        let r = c.params.thickness + self.cover_radius;
        plan.base_dist <= r && tip.dist <= r
    }

    /// The covering radius added to each curve's thickness for
    /// [`Self::covered_segments`] (default 0.15, `CoverageOptions`'s).
    pub fn set_cover_radius(&mut self, radius: f64) {
        self.cover_radius = radius;
        self.attach();
    }

    /// Whether a bone covers, besides eq. 1's curve, every other curve
    /// whose covering tube holds both its ends (on by default: a bone that
    /// leaves a fork along an arm covers the arm; off, only eq. 1's curve,
    /// as before issue 30's fork fix). Coverage only: the cost is the same.
    pub fn set_cover_others(&mut self, on: bool) {
        self.cover_others = on;
    }

    /// How many of `curve`'s utilization segments `state` covers: spanned
    /// (as eq. 7 spans them) by a bone whose base and tip both lie within
    /// the curve's thickness plus the covering radius of its axis. A
    /// per-segment stand-in for [`crate::coverage`] that the sampler can
    /// keep per particle; needs the curve's utilization on (0 otherwise,
    /// and for an index out of range). Returns (covered, segments).
    pub fn covered_segments(&self, state: &CostState, curve: usize) -> (usize, usize) {
        let Some(c) = self.curves.get(curve) else {
            return (0, 0);
        };
        if c.params.utilization_scale <= 0.0 {
            return (0, c.n_seg);
        }
        (usize::from(self.covered_count(state, curve)), c.n_seg)
    }

    /// How many segments of its curve `plan` would newly cover in `state`
    /// ([`Self::covered_segments`]), and that curve; `None` when it covers
    /// none.
    pub fn cover_gain(&self, state: &CostState, plan: &BonePlan) -> Option<(usize, usize)> {
        if !self.plan_covers(plan) {
            return None;
        }
        let (ci, (s0, s1)) = (plan.curve?, plan.segments?);
        let c = self.curves.get(ci)?;
        let (a, b) = (c.seg_offset + s0 as usize, c.seg_offset + s1 as usize);
        let new = state
            .covered
            .get(a..=b)
            .map_or(0, |f| f.iter().filter(|&&x| !x).count());
        (new > 0).then_some((ci, new))
    }

    /// Every curve whose segments `plan` would newly cover in `state`, with
    /// how many: eq. 1's curve as [`Self::cover_gain`] gives it, and the
    /// other curves whose covering tube holds both of the bone's ends (a
    /// bone leaving a fork along a branch covers that branch). At most
    /// four entries; `f` is called once per curve with a gain.
    pub fn cover_gains(&self, state: &CostState, plan: &BonePlan, mut f: impl FnMut(usize, usize)) {
        if let Some((c, new)) = self.cover_gain(state, plan) {
            f(c, new);
        }
        for &(ci, s0, s1) in plan.also.iter().flatten() {
            let Some(c) = self.curves.get(ci as usize) else {
                continue;
            };
            let (a, b) = (c.seg_offset + s0 as usize, c.seg_offset + s1 as usize);
            let new = state
                .covered
                .get(a..=b)
                .map_or(0, |f| f.iter().filter(|&&x| !x).count());
            if new > 0 {
                f(ci as usize, new);
            }
        }
    }

    /// Whether the segment of `curve` just past parameter `t` (in the
    /// curve's direction) is covered in `state`; `true` past the last
    /// segment (nothing left to cover there) and with utilization off.
    pub fn covered_ahead(&self, state: &CostState, curve: usize, t: f64) -> bool {
        let Some(c) = self.curves.get(curve) else {
            return true;
        };
        if c.params.utilization_scale <= 0.0 {
            return true;
        }
        let s = c.segment(t) + 1;
        s >= c.n_seg || state.covered.get(c.seg_offset + s).copied().unwrap_or(true)
    }

    /// The covering tubes that hold `p` (the reach look-ahead's places,
    /// `docs/sampling.md` section 4.4): every curve whose covering tube
    /// (its thickness plus the covering radius of
    /// [`Self::covered_segments`]) holds `p`, with the arc length of `p`'s
    /// closest point on it; at most [`Tubes::MAX`] (the nearest first are
    /// not preferred: curves in index order). Empty for a non-finite `p`.
    /// `known`: one curve's closest point to `p` when the caller has it
    /// (eq. 1 at a spawn, a bone plan's tip), not searched again.
    pub fn tubes_at(&self, p: DVec3, known: Option<(usize, &ClosestPoint)>) -> Tubes {
        let mut out = Tubes::default();
        if !p.is_finite() {
            return out;
        }
        for (i, c) in self.curves.iter().enumerate() {
            if out.n as usize == Tubes::MAX {
                break;
            }
            if c.params.utilization_scale <= 0.0 {
                continue;
            }
            let r = c.params.thickness + self.cover_radius;
            if (p.clamp(c.lo, c.hi) - p).length() > r {
                continue;
            }
            let cp = match known {
                Some((k, cp)) if k == i => Some(*cp),
                _ => c.bez.closest_point_within(&c.samples, p, r),
            };
            if let Some(cp) = cp.filter(|cp| cp.dist <= r) {
                out.at[out.n as usize] = (i as u32, c.arc_at(cp.t));
                out.n += 1;
            }
        }
        out
    }

    /// [`Self::tubes_at`] given eq. 1 at `p` (`nearest`: the curve whose
    /// tube surface is nearest to `p`, as [`Self::nearest_curve`] answers,
    /// and its closest point): empty at once when that tube is beyond the
    /// covering radius, since every other one is further.
    pub fn tubes_near(&self, p: DVec3, nearest: (usize, &ClosestPoint)) -> Tubes {
        let (i, cp) = nearest;
        match self.curves.get(i) {
            Some(c) if cp.dist - c.params.thickness <= self.cover_radius => {
                self.tubes_at(p, Some(nearest))
            }
            _ => Tubes::default(),
        }
    }

    /// The reach look-ahead: what a subtree grown from a place in `tubes`
    /// ([`Self::tubes_at`]) could still cover, were it to reach `reach`
    /// units of arc length along a curve. Per tube, the utilization
    /// segments not yet covered in `state` after the one holding the place
    /// (a bone that ends there covers that one) up to the one `reach`
    /// further along the curve (in its direction), each counted as the
    /// curve's uncovered share `1 - k_c / n_c` (the coverage term's gain
    /// for one more segment is `2 W` times that); summed over the tubes (a
    /// tip at a fork can grow along each). With `branches: Some(gap)`, what
    /// is left of `reach` where a curve that starts on this one (an arm
    /// drawn from a trunk) leaves it, more than `gap` ahead, is followed
    /// along that curve too (one level, the best such curve; a curve whose
    /// tube holds the place is counted once). 0 without tubes or for
    /// `reach <= 0`.
    pub fn uncovered_within_reach(
        &self,
        state: &CostState,
        tubes: &Tubes,
        reach: f64,
        branches: Option<f64>,
    ) -> f64 {
        if reach.is_nan() || reach <= 0.0 {
            return 0.0;
        }
        let mut sum = 0.0;
        for &(i, a) in tubes.iter() {
            sum += self.uncovered_along(state, i as usize, a, reach);
            let Some(gap) = branches else {
                continue;
            };
            // One chain follows one branch: the best of them counts.
            let mut best = 0.0f64;
            for &(j, on, at) in &self.attached {
                if on == i as usize
                    && at - a > gap.max(0.0)
                    && at - a < reach
                    && !tubes.iter().any(|&(k, _)| k as usize == j)
                {
                    // From before the branch's first segment: it counts.
                    best = best.max(self.uncovered_along(state, j, -1.0, reach - (at - a)));
                }
            }
            sum += best;
        }
        sum
    }

    /// The uncovered segments of curve `i` after the one holding arc
    /// length `a` (before the start for `a < 0`) up to the one holding
    /// `a + reach`, each counted as the curve's uncovered share.
    fn uncovered_along(&self, state: &CostState, i: usize, a: f64, reach: f64) -> f64 {
        let Some(c) = self.curves.get(i) else {
            return 0.0;
        };
        let Some(flags) = state.covered.get(c.seg_offset..c.seg_offset + c.n_seg) else {
            return 0.0;
        };
        let from = if a < 0.0 { 0 } else { c.segment_at_arc(a) + 1 };
        let to = c.segment_at_arc(a.max(0.0) + reach);
        if from > to {
            return 0.0;
        }
        let ahead = flags[from..=to].iter().filter(|&&x| !x).count();
        if ahead == 0 {
            return 0.0;
        }
        let k = self.covered_count(state, i);
        ahead as f64 * (1.0 - f64::from(k) / c.n_seg as f64)
    }

    /// Curve `i`'s covered segments, as counted when their flags were set
    /// (`CostState::uses`' tail); 0 for an index out of range.
    #[inline]
    fn covered_count(&self, state: &CostState, i: usize) -> u16 {
        state
            .uses
            .get(self.total_segments + i)
            .copied()
            .unwrap_or(0)
    }

    /// Sets the covered flags of segments `a..=b` (indices into all
    /// curves' segments, within curve `curve`'s range), counting the newly
    /// set ones in the curve's count.
    fn set_covered(&self, state: &mut CostState, curve: usize, a: usize, b: usize) {
        let mut new = 0u16;
        for f in state.covered.get_mut(a..=b).unwrap_or_default() {
            new += u16::from(!*f);
            *f = true;
        }
        if let Some(n) = state.uses.get_mut(self.total_segments + curve) {
            *n += new;
        }
    }

    /// What the next bone would gain in utilization (eq. 7, so `<= 0`) by
    /// using the segment of `curve` just past parameter `t` in the curve's
    /// direction (the one after the segment holding `t`), given `state`'s
    /// use counts: `-scale_u e^(-n)` for a segment used `n` times; 0 past
    /// the curve's last segment, with utilization off, or for an index out
    /// of range. A look-ahead for the sampler's expansion order: an open
    /// symbol where a curve goes on unused is worth growing first.
    pub fn utilization_ahead(&self, state: &CostState, curve: usize, t: f64) -> f64 {
        let Some(c) = self.curves.get(curve) else {
            return 0.0;
        };
        if c.params.utilization_scale <= 0.0 {
            return 0.0;
        }
        let s = c.segment(t) + 1;
        if s >= c.n_seg {
            return 0.0;
        }
        let n = state.uses.get(c.seg_offset + s).copied().unwrap_or(0);
        -to_f64(c.util(n.saturating_add(1)) - c.util(n))
    }

    /// Eq. 1 (with thickness): the curve whose tube is nearest to `p`, and
    /// the closest point on its axis. Ties go to the lower index.
    pub fn nearest_curve(&self, p: DVec3) -> (usize, ClosestPoint) {
        self.nearest_curve_known(p, None)
    }

    /// [`Self::nearest_curve`] given the closest point of one curve to `p`
    /// already (`known`: that curve's index and
    /// `closest_point_sampled` answer at `p`, as [`BonePlan::tip_closest`]
    /// gives for a bone's tip), which is then not searched again. The
    /// answer is the same, bit for bit: the search of a curve either gives
    /// that point or proves the curve cannot win.
    pub fn nearest_curve_known(
        &self,
        p: DVec3,
        known: Option<(usize, &ClosestPoint)>,
    ) -> (usize, ClosestPoint) {
        let search = |i: usize, c: &CurveData, bound: f64| -> Option<ClosestPoint> {
            match known {
                Some((k, cp)) if k == i => Some(*cp),
                _ => c.bez.closest_point_within(&c.samples, p, bound),
            }
        };
        // Start with the curve whose box is nearest; a later curve is only
        // refined if its samples show it may still win (see
        // `Bezier3::closest_point_within`).
        let lower = |c: &CurveData| (p.clamp(c.lo, c.hi) - p).length() - c.params.thickness;
        let mut first = 0;
        let mut first_lb = f64::INFINITY;
        for (i, c) in self.curves.iter().enumerate() {
            let lb = lower(c);
            if lb < first_lb {
                first = i;
                first_lb = lb;
            }
        }
        let c0 = &self.curves[first]; // `Curves` is never empty (validated).
        let mut best_i = first;
        let mut best = match known {
            Some((k, cp)) if k == first => *cp,
            _ => c0.bez.closest_point_sampled(&c0.samples, p),
        };
        let mut best_key = best.dist - c0.params.thickness;
        for (i, c) in self.curves.iter().enumerate() {
            if i == first {
                continue;
            }
            let lb = lower(c);
            if lb > best_key || (lb == best_key && i > best_i) {
                continue;
            }
            let bound = best_key + c.params.thickness;
            let Some(cp) = search(i, c, bound) else {
                continue;
            };
            let key = cp.dist - c.params.thickness;
            if key < best_key || (key == best_key && i < best_i) {
                best_i = i;
                best = cp;
                best_key = key;
            }
        }
        (best_i, best)
    }

    /// Eq. 1-6 for a bone from `base` to `tip` (world space), before it is
    /// added to any state: the chosen curve, the distance and alignment
    /// costs and the range of utilization segments it covers. The state
    /// dependent parts (utilization counts, density neighbours) are
    /// evaluated by [`Self::peek`] and [`Self::add_planned`].
    /// [`Self::add_bone`] is `add_planned(state, &plan_bone(base, tip))`.
    pub fn plan_bone(&self, base: Vec3, tip: Vec3) -> BonePlan {
        let b = base.as_dvec3();
        if !(b.is_finite() && tip.as_dvec3().is_finite()) {
            return BonePlan::non_finite(base, tip);
        }
        let (ci, cp) = self.nearest_curve(b);
        self.plan_bone_near(base, tip, ci, &cp)
    }

    /// [`Self::plan_bone`] given eq. 1's answer for the base: `curve` and
    /// `closest` must be `nearest_curve(base)` (as the caller computed it,
    /// e.g. once for several bones sharing a base); the plan is then the
    /// same, bit for bit.
    pub fn plan_bone_near(
        &self,
        base: Vec3,
        tip: Vec3,
        curve: usize,
        closest: &ClosestPoint,
    ) -> BonePlan {
        self.plan_bone_near_in(base, tip, curve, closest, None)
    }

    /// [`Self::plan_bone_near`] given also the covering tubes that hold the
    /// base (`base_tubes`: [`Self::tubes_at`] or [`Self::tubes_near`] of
    /// the base, as the caller computed it once for several bones sharing
    /// it): the other curves' closest points to the base are not searched
    /// again. The plan is the same, bit for bit.
    pub fn plan_bone_near_in(
        &self,
        base: Vec3,
        tip: Vec3,
        curve: usize,
        closest: &ClosestPoint,
        base_tubes: Option<&Tubes>,
    ) -> BonePlan {
        // A full list may have left tubes out: search then.
        let base_tubes = base_tubes.filter(|t| (t.n as usize) < Tubes::MAX);
        let (b, t) = (base.as_dvec3(), tip.as_dvec3());
        let Some(c) = self.curves.get(curve) else {
            return BonePlan::non_finite(base, tip);
        };
        if !(b.is_finite() && t.is_finite()) {
            return BonePlan::non_finite(base, tip);
        }
        let p = &c.params;
        let distance = distance_cost(closest.dist, p);
        let guide = c.bez.tangent(closest.t);
        let alignment = alignment_cost(t - b, guide, p.alignment_scale, p.alignment_offset);
        let (segments, tip_closest) = if p.utilization_scale > 0.0 {
            let tip_cp = c.bez.closest_point_sampled(&c.samples, t);
            let (s0, s1) = (c.segment(closest.t), c.segment(tip_cp.t));
            (Some((s0.min(s1) as u32, s0.max(s1) as u32)), Some(tip_cp))
        } else {
            (None, None)
        };
        let mut also = [None; MAX_ALSO];
        if segments.is_some() && self.cover_others && self.curves.len() > 1 {
            let mut n = 0;
            for (i, o) in self.curves.iter().enumerate() {
                if i == curve || n == MAX_ALSO || o.params.utilization_scale <= 0.0 {
                    continue;
                }
                let r = o.params.thickness + self.cover_radius;
                if (b.clamp(o.lo, o.hi) - b).length() > r || (t.clamp(o.lo, o.hi) - t).length() > r
                {
                    continue;
                }
                let near = |p: DVec3| {
                    o.bez
                        .closest_point_within(&o.samples, p, r)
                        .filter(|cp| cp.dist <= r)
                };
                // The base's segment on this curve, from the tubes when
                // given (the same closest point, so the same segment).
                let s_base = match base_tubes {
                    Some(tubes) => tubes
                        .iter()
                        .find(|&&(k, _)| k as usize == i)
                        .map(|&(_, a)| o.segment_at_arc(a)),
                    None => near(b).map(|cb| o.segment(cb.t)),
                };
                if let (Some(s0), Some(ct)) = (s_base, near(t)) {
                    let s1 = o.segment(ct.t);
                    also[n] = Some((i as u32, s0.min(s1) as u32, s0.max(s1) as u32));
                    n += 1;
                }
            }
        }
        BonePlan {
            base: b,
            tip: t,
            curve: Some(curve),
            distance,
            alignment,
            base_dist: closest.dist,
            segments,
            tip_closest,
            also,
        }
    }

    /// Utilization change (fixed point, the total's increase in
    /// `scale_u G` units) of the plan's segments given `uses`, and the
    /// counter range; `None` when the plan has no segments.
    fn utilization_delta(&self, uses: &[u16], plan: &BonePlan) -> (i128, Option<(usize, usize)>) {
        let (Some(ci), Some((s0, s1))) = (plan.curve, plan.segments) else {
            return (0, None);
        };
        let Some(c) = self.curves.get(ci) else {
            return (0, None);
        };
        // `segment` clamps to `n_seg - 1`, and a state made by this model
        // holds `n_seg` counters from `seg_offset` for this curve; a state
        // from another model (a caller bug) gets no utilization rather than
        // a panic.
        let (a, b) = (c.seg_offset + s0 as usize, c.seg_offset + s1 as usize);
        debug_assert_eq!(
            uses.len(),
            self.total_segments + self.curves.len(),
            "state from another model"
        );
        let mut delta = 0i128;
        for &n in uses.get(a..=b).unwrap_or_default() {
            delta += c.util(n.saturating_add(1)) - c.util(n);
        }
        (delta, Some((a, b)))
    }

    /// The density of the bone's midpoint against the bones in `state`
    /// (fixed point), when the density term is on.
    fn density_sum(&self, state: &CostState, plan: &BonePlan) -> i128 {
        let (Some(d), Some(grid)) = (self.density, state.grid.as_ref()) else {
            return 0;
        };
        let mid = 0.5 * (plan.base + plan.tip);
        let mut sum = 0i128;
        grid.for_each_within(mid, d.radius, |q| {
            let w = 1.0 - mid.distance(q) / d.radius;
            // Quantized per pair: the pair's value does not depend on
            // which of the two bones came first.
            sum = sum.saturating_add(to_fixed(d.scale * w * w));
        });
        sum
    }

    /// The cost [`Self::add_planned`] would return for `plan` in `state`
    /// (its `total()`, bit for bit), without changing the state: for
    /// comparing candidate bones before choosing one. `+inf` for a
    /// non-finite bone.
    pub fn peek(&self, state: &CostState, plan: &BonePlan) -> f64 {
        if plan.curve.is_none() {
            return f64::INFINITY;
        }
        let (delta, _) = self.utilization_delta(&state.uses, plan);
        let utilization = if plan.segments.is_some() {
            -to_f64(delta)
        } else {
            0.0
        };
        let density = if self.density.is_some() && state.grid.is_some() {
            to_f64(self.density_sum(state, plan))
        } else {
            0.0
        };
        plan.distance + plan.alignment + utilization + density
    }

    /// Adds a bone (world-space base and tip) to `state` and returns its cost.
    ///
    /// Distance and alignment follow eq. 1-6 (with thickness). Utilization
    /// follows eq. 7: `S` is the range of segments of the chosen curve from
    /// the one holding the closest point to the base to the one holding the
    /// closest point to the tip, inclusive; each `s` in `S` that `n_s` bones
    /// used before contributes `-scale_u e^(-n_s)`, then `n_s` grows by one.
    /// The returned per-bone utilization depends on the insertion order, as
    /// in the paper, but the state's total does not: it is
    /// `-scale_u sum_s G(n_s)` with `G(n) = sum_{k<n} e^-k`, and this bone's
    /// value is exactly the change of that total (fixed-point).
    ///
    /// A bone with a non-finite base or tip makes the model's total `+inf`
    /// and changes nothing else.
    pub fn add_bone(&self, state: &mut CostState, base: Vec3, tip: Vec3) -> BoneCost {
        let plan = self.plan_bone(base, tip);
        self.add_planned(state, &plan)
    }

    /// Adds the bone `plan` was made for ([`Self::plan_bone`] or
    /// [`Self::plan_bone_near`] of this model) to `state`: exactly
    /// [`Self::add_bone`] of the same base and tip.
    pub fn add_planned(&self, state: &mut CostState, plan: &BonePlan) -> BoneCost {
        state.bones += 1;
        let Some(ci) = plan.curve else {
            state.non_finite += 1;
            return BoneCost {
                curve: None,
                distance: f64::INFINITY,
                ..BoneCost::default()
            };
        };
        state.distance = state.distance.saturating_add(to_fixed(plan.distance));
        state.alignment = state.alignment.saturating_add(to_fixed(plan.alignment));

        let mut utilization = 0.0;
        let (delta, range) = self.utilization_delta(&state.uses, plan);
        if let Some((a, b)) = range {
            for n in state.uses.get_mut(a..=b).unwrap_or_default() {
                *n = n.saturating_add(1);
            }
            if self.plan_covers(plan) {
                self.set_covered(state, ci, a, b);
            }
            for &(ci, s0, s1) in plan.also.iter().flatten() {
                if let Some(c) = self.curves.get(ci as usize) {
                    let (a, b) = (c.seg_offset + s0 as usize, c.seg_offset + s1 as usize);
                    self.set_covered(state, ci as usize, a, b);
                }
            }
        }
        if plan.segments.is_some() {
            state.utilization = state.utilization.saturating_sub(delta);
            utilization = -to_f64(delta);
        }

        let mut density = 0.0;
        if self.density.is_some() && state.grid.is_some() {
            let sum = self.density_sum(state, plan);
            if let Some(grid) = state.grid.as_mut() {
                grid.insert(0.5 * (plan.base + plan.tip));
            }
            state.density = state.density.saturating_add(sum);
            density = to_f64(sum);
        }

        BoneCost {
            curve: Some(ci),
            distance: plan.distance,
            alignment: plan.alignment,
            utilization,
            density,
        }
    }

    /// The cost of the model `state` holds, by term.
    pub fn total(&self, state: &CostState) -> CostBreakdown {
        CostBreakdown {
            distance: to_f64(state.distance),
            alignment: to_f64(state.alignment),
            utilization: to_f64(state.utilization),
            density: to_f64(state.density),
            bones: state.bones,
            non_finite: state.non_finite,
            total_fixed: state
                .distance
                .saturating_add(state.alignment)
                .saturating_add(state.utilization)
                .saturating_add(state.density),
        }
    }

    /// The utilization total recomputed from the use counts alone,
    /// `-sum_c scale_u(c) sum_s G(n_s)`; equal to `total(state).utilization`.
    pub fn utilization_from_counts(&self, state: &CostState) -> f64 {
        let mut sum = 0i128;
        for c in &self.curves {
            let counts = state.uses.get(c.seg_offset..c.seg_offset + c.n_seg);
            for &n in counts.unwrap_or_default() {
                sum += c.util(n);
            }
        }
        to_f64(-sum)
    }

    /// One term of the heuristic cost, eq. 10: the alignment cost (eq. 6) of
    /// a symbol's expected direction `expected` (already transformed to
    /// world space, `M_i EXPECTED(Z[i])`) at the world position `position`
    /// of its frame (`M_i [0,0,0]^T`), against the curve nearest to that
    /// position. A zero vector (a degenerate frame) is costed as
    /// perpendicular (`delta_a scale_a`), as a zero bone is; a non-finite
    /// position gives `+inf`. [`Self::heuristic_in_frame`] gives 0 for a
    /// symbol whose own expected direction is zero.
    pub fn heuristic(&self, position: Vec3, expected: Vec3) -> f64 {
        let p = position.as_dvec3();
        if !p.is_finite() {
            return f64::INFINITY;
        }
        let (ci, cp) = self.nearest_curve(p);
        let c = &self.curves[ci]; // index from `nearest_curve`
        let guide = c.bez.tangent(cp.t);
        alignment_cost(
            expected.as_dvec3(),
            guide,
            c.params.alignment_scale,
            c.params.alignment_offset,
        )
    }

    /// [`Self::heuristic`] for a symbol whose frame is `frame` (`M_i`) and
    /// whose expected direction in its own frame is `expected`: position =
    /// `frame`'s origin, direction = `frame`'s linear part times `expected`.
    /// A symbol whose expected direction is zero (it grows no bone) adds
    /// 0: no future alignment cost, as in the sampler.
    pub fn heuristic_in_frame(&self, frame: &Affine3A, expected: Vec3) -> f64 {
        if expected == Vec3::ZERO {
            return 0.0;
        }
        self.heuristic(
            Vec3::from(frame.translation),
            frame.transform_vector3(expected),
        )
    }
}

/// Accumulates Calder's eq. 9, the expected direction of a skeleton symbol:
/// the mean over sampled models (grown from the symbol with `M` = identity)
/// of the mean bone vector `TIP - BASE` of each model. Vectors are not
/// normalized (eq. 9 averages raw bone vectors); a model with no bones adds
/// nothing to the sum but counts in `|X|`, as the equation says.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ExpectedDirection {
    sum: DVec3,
    models: u64,
}

impl ExpectedDirection {
    /// An empty accumulator.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds one sampled model, given as its bones `(base, tip)`.
    pub fn add_model(&mut self, bones: &[(Vec3, Vec3)]) {
        self.models += 1;
        if bones.is_empty() {
            return;
        }
        let s: DVec3 = bones.iter().map(|(b, t)| t.as_dvec3() - b.as_dvec3()).sum();
        self.sum += s / bones.len() as f64;
    }

    /// Models added so far.
    pub fn models(&self) -> u64 {
        self.models
    }

    /// `EXPECTED(n_s)`; zero when no model was added.
    pub fn finish(&self) -> Vec3 {
        if self.models == 0 {
            Vec3::ZERO
        } else {
            (self.sum / self.models as f64).as_vec3()
        }
    }
}

/// Eq. 9 over a set of sampled models, each a slice of bones `(base, tip)`.
pub fn expected_direction<'a>(models: impl IntoIterator<Item = &'a [(Vec3, Vec3)]>) -> Vec3 {
    let mut acc = ExpectedDirection::new();
    for m in models {
        acc.add_model(m);
    }
    acc.finish()
}

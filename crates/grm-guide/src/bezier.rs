//! Cubic Bézier curves in 3D and a robust closest-point query.
//!
//! All geometry here is computed in `f64` ([`DVec3`]): the closest-point
//! refinement resolves the curve parameter to 1e-10 and distances to
//! rounding, which `f32` could not (points near a curve need small relative
//! errors). The sampler-facing API ([`crate::CostModel`]) takes
//! `f32` [`glam::Vec3`] like the turtle and converts once per bone.
//!
//! # Closest point
//!
//! The squared distance `f(t) = |B(t) - p|^2` of a cubic is a sextic in `t`
//! whose derivative `g(t) = 2 (B(t) - p) . B'(t)` is a quintic, so `f` has at
//! most three local minima on `[0, 1]`. [`Bezier3::closest_point`]:
//!
//! 1. samples `f` at [`BRACKET_SAMPLES`]` + 1` evenly spaced parameters
//!    (cached per curve by [`Bezier3::bracket_samples`]);
//! 2. takes every discrete local minimum of the samples (the endpoints
//!    included) as a candidate, bracketed by its two neighbouring samples,
//!    the best sample first; a candidate is skipped when the samples prove
//!    it cannot beat the best point found so far (every point of the curve
//!    is within `h/2 * max|B'|` of a sample, and `max|B'|` is bounded by the
//!    hodograph's control points);
//! 3. in each bracket, starts at the vertex of the parabola through the
//!    three samples, finds a sign change of `g` from `-` to `+` (a local
//!    minimum of `f`) and polishes it with safeguarded Newton steps on `g`
//!    (Newton while it stays inside the bracket, bisection otherwise); an
//!    endpoint where `g` points outwards is a minimum as it stands; a bracket
//!    with no usable sign change falls back to golden-section search on `f`;
//! 4. makes that exact: the samples miss a minimum when one bracket holds
//!    two (near a sharp turn), so the roots of `g` are isolated in its
//!    Bernstein form (Descartes' rule of signs: halve until a piece has at
//!    most one sign change), pieces the samples prove too far dropped, and
//!    every remaining `-` to `+` root polished with the same Newton steps;
//!    the best point moves only when a strictly nearer one turns up;
//! 5. returns the best candidate, never worse than the best sample nor than
//!    either endpoint (the endpoint checks).
//!
//! It is tested against dense brute-force sampling on thousands of random
//! curves and points (`tests/closest_point.rs`).

use glam::DVec3;

/// Number of intervals the closest-point search samples to bracket minima.
///
/// The squared distance of a cubic has at most three local minima; the
/// brute-force tests (random curves with loops and cusps) pass with 16
/// intervals and fail with 8, so 32 leaves a margin. Sampling is cheap
/// (about a quarter of a query); refinement is the main cost.
pub const BRACKET_SAMPLES: usize = 32;

/// The most pieces of `[0, 1]` the exact closest-point search looks at
/// for one query. Isolating the at most five roots of the derivative
/// quintic takes a few dozen at most (the benchmark's queries: one, 0.24%
/// of them a few); the bound only matters where the coefficients are
/// rounding noise, which could otherwise halve to the depth limit
/// everywhere.
const ISOLATE_BUDGET: u32 = 256;

/// Newton stops when a step moves `t` by less than this. Quadratic
/// convergence means the error is then far smaller still (about the square
/// of the previous step), and the distance, being stationary at the
/// minimum, is exact to rounding.
const NEWTON_TOL: f64 = 1e-10;

/// The closest point on a curve to a query point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClosestPoint {
    /// Curve parameter of the closest point, in `[0, 1]`.
    pub t: f64,
    /// The closest point, `B(t)`.
    pub point: DVec3,
    /// Euclidean distance from the query point to `point`.
    pub dist: f64,
}

/// Cached bracket samples of a curve ([`Bezier3::bracket_samples`]),
/// stored as structure of arrays.
#[derive(Clone, Debug, PartialEq)]
pub struct BracketSamples {
    x: [f64; BRACKET_SAMPLES + 1],
    y: [f64; BRACKET_SAMPLES + 1],
    z: [f64; BRACKET_SAMPLES + 1],
    /// The two parts of `g(t) = (B(t) - p) . B'(t)` in the Bernstein basis
    /// of degree 5: `g_s - p . (g_vx, g_vy, g_vz)` are its coefficients for a query
    /// point `p`.
    g_s: [f64; 6],
    g_vx: [f64; 6],
    g_vy: [f64; 6],
    g_vz: [f64; 6],
}

/// Degree-5 Bernstein coefficients of `(R - p) . R'` as `(s, v)` with
/// `c_k = s_k - p . v_k`, for the cubic with control points `r`: its
/// hodograph `D_j = 3 (r_{j+1} - r_j)` and `c_k = sum_{i+j=k} C(3,i)
/// C(2,j) / C(5,k) (r_i - p) . D_j`.
fn g_parts(r: [DVec3; 4]) -> ([f64; 6], [DVec3; 6]) {
    let d = [
        3.0 * (r[1] - r[0]),
        3.0 * (r[2] - r[1]),
        3.0 * (r[3] - r[2]),
    ];
    // (i, j, weight) by k.
    const TERMS: [&[(usize, usize, f64)]; 6] = [
        &[(0, 0, 1.0)],
        &[(0, 1, 0.4), (1, 0, 0.6)],
        &[(0, 2, 0.1), (1, 1, 0.6), (2, 0, 0.3)],
        &[(1, 2, 0.3), (2, 1, 0.6), (3, 0, 0.1)],
        &[(2, 2, 0.6), (3, 1, 0.4)],
        &[(3, 2, 1.0)],
    ];
    let mut s = [0.0; 6];
    let mut v = [DVec3::ZERO; 6];
    for (k, terms) in TERMS.iter().enumerate() {
        for &(i, j, w) in *terms {
            s[k] += w * r[i].dot(d[j]);
            v[k] += w * d[j];
        }
    }
    (s, v)
}

/// A cubic Bézier curve in 3D, `B(t) = sum_i C(3, i) (1-t)^(3-i) t^i P_i`.
///
/// Stores the control points and the power-basis coefficients
/// `B(t) = ((a t + b) t + c) t + d` used for evaluation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bezier3 {
    points: [DVec3; 4],
    a: DVec3,
    b: DVec3,
    c: DVec3,
    d: DVec3,
    /// `3 a`, `2 b` and `6 a`, for [`Self::derivative`] and
    /// [`Self::second_derivative`] (the same products those formulas
    /// compute first, so the same values bit for bit).
    a3: DVec3,
    b2: DVec3,
    a6: DVec3,
    /// Control polygon length (size scale for tolerances).
    polygon: f64,
    /// Bound on how far the curve strays from its nearest bracket sample:
    /// half a sample step times the maximum speed, which the hodograph's
    /// control points `3 (P_{k+1} - P_k)` bound (convex hull).
    slack: f64,
}

impl Bezier3 {
    /// A curve from its four control points `P0..P3` (`P0` = start, `P3` = end).
    pub fn new(points: [DVec3; 4]) -> Self {
        let [p0, p1, p2, p3] = points;
        let (l0, l1, l2) = (p0.distance(p1), p1.distance(p2), p2.distance(p3));
        let max_speed = 3.0 * l0.max(l1).max(l2);
        let a = p3 - p0 + 3.0 * (p1 - p2);
        let b = 3.0 * (p0 - 2.0 * p1 + p2);
        Self {
            points,
            a,
            b,
            a3: 3.0 * a,
            b2: 2.0 * b,
            a6: 6.0 * a,
            c: 3.0 * (p1 - p0),
            d: p0,
            polygon: l0 + l1 + l2,
            // 1e-12 relative margin for rounding in the sample distances.
            slack: 0.5 / BRACKET_SAMPLES as f64 * max_speed * (1.0 + 1e-12),
        }
    }

    /// The control points `P0..P3`.
    pub fn points(&self) -> [DVec3; 4] {
        self.points
    }

    /// `B(t)`.
    #[inline]
    pub fn eval(&self, t: f64) -> DVec3 {
        ((self.a * t + self.b) * t + self.c) * t + self.d
    }

    /// `B'(t)`, the (unnormalized) derivative.
    #[inline]
    pub fn derivative(&self, t: f64) -> DVec3 {
        (self.a3 * t + self.b2) * t + self.c
    }

    /// `B''(t)`.
    #[inline]
    pub fn second_derivative(&self, t: f64) -> DVec3 {
        self.a6 * t + self.b2
    }

    /// Axis-aligned box of the control points; by the convex-hull property
    /// it contains the whole curve.
    pub fn bounds(&self) -> (DVec3, DVec3) {
        let [p0, p1, p2, p3] = self.points;
        (p0.min(p1).min(p2).min(p3), p0.max(p1).max(p2).max(p3))
    }

    /// Length of the control polygon, an upper bound of the arc length and
    /// the curve's size scale.
    pub fn polygon_length(&self) -> f64 {
        self.polygon
    }

    /// The unit tangent `DIR` at `t` (Calder's `DIR(g, p)`).
    ///
    /// Where `B'(t)` vanishes (coincident control points at an end, or a
    /// cusp) the direction of the short chord `B(t+h) - B(t-h)` is used,
    /// which is the one-sided limit of the tangent; failing that, the chord
    /// `P3 - P0`. Returns zero only for a curve that is a single point.
    pub fn tangent(&self, t: f64) -> DVec3 {
        let scale = self.polygon;
        let d = self.derivative(t);
        if d.length_squared() > 1e-18 * scale * scale {
            return d.normalize();
        }
        let h = 1e-4;
        let chord = self.eval((t + h).min(1.0)) - self.eval((t - h).max(0.0));
        if chord.length_squared() > 1e-24 * scale * scale {
            return chord.normalize();
        }
        let [p0, p1, p2, p3] = self.points;
        [p3 - p0, p2 - p0, p1 - p0]
            .into_iter()
            .map(DVec3::normalize_or_zero)
            .find(|v| *v != DVec3::ZERO)
            .unwrap_or(DVec3::ZERO)
    }

    /// The `BRACKET_SAMPLES + 1` points `B(i / BRACKET_SAMPLES)`, cached by
    /// callers that query one curve many times.
    pub fn bracket_samples(&self) -> BracketSamples {
        const N: usize = BRACKET_SAMPLES;
        let mut out = BracketSamples {
            x: [0.0; N + 1],
            y: [0.0; N + 1],
            z: [0.0; N + 1],
            g_s: [0.0; 6],
            g_vx: [0.0; 6],
            g_vy: [0.0; 6],
            g_vz: [0.0; 6],
        };
        let h = 1.0 / N as f64;
        for i in 0..=N {
            let p = self.eval(i as f64 * h);
            (out.x[i], out.y[i], out.z[i]) = (p.x, p.y, p.z);
        }
        let (g_s, g_v) = g_parts(self.points);
        out.g_s = g_s;
        for (i, v) in g_v.iter().enumerate() {
            (out.g_vx[i], out.g_vy[i], out.g_vz[i]) = (v.x, v.y, v.z);
        }
        out
    }

    /// The closest point on the curve to `p` (see the module docs).
    pub fn closest_point(&self, p: DVec3) -> ClosestPoint {
        self.closest_point_sampled(&self.bracket_samples(), p)
    }

    /// [`Self::closest_point`] with precomputed [`Self::bracket_samples`].
    pub fn closest_point_sampled(&self, samples: &BracketSamples, p: DVec3) -> ClosestPoint {
        // An infinite bound never prunes, so this is always `Some`.
        self.closest_point_within(samples, p, f64::INFINITY)
            .unwrap_or(ClosestPoint {
                t: 0.0,
                point: self.points[0],
                dist: self.points[0].distance(p),
            })
    }

    /// The closest point if the curve may come within `bound` of `p`;
    /// `None` when the samples prove it cannot (every point of the curve
    /// is further than `bound`). Used to skip curves that cannot win.
    pub fn closest_point_within(
        &self,
        samples: &BracketSamples,
        p: DVec3,
        bound: f64,
    ) -> Option<ClosestPoint> {
        const N: usize = BRACKET_SAMPLES;
        // Structure-of-arrays so that this loop vectorizes.
        let mut d2 = [0.0f64; N + 1];
        for (((o, x), y), z) in d2
            .iter_mut()
            .zip(&samples.x)
            .zip(&samples.y)
            .zip(&samples.z)
        {
            let (dx, dy, dz) = (x - p.x, y - p.y, z - p.z);
            *o = dx * dx + dy * dy + dz * dz;
        }
        let (mut min_i, mut min_d2) = (0, f64::INFINITY);
        for (i, &v) in d2.iter().enumerate() {
            if v < min_d2 {
                (min_i, min_d2) = (i, v);
            }
        }
        // Every point of the curve is within `slack` of a sample.
        if min_d2.sqrt() - self.slack > bound {
            return None;
        }
        // Endpoint checks: both ends are always candidates.
        let (mut best_t, mut best_d2) = if d2[N] < d2[0] {
            (1.0, d2[N])
        } else {
            (0.0, d2[0])
        };
        // Refine the best sample's bracket first, then every other discrete
        // local minimum that could still beat the best found so far (the
        // endpoints count as local minima when their one neighbour is not
        // nearer).
        let (t, f) = self.refine_sample(p, &d2, min_i);
        if f < best_d2 {
            (best_t, best_d2) = (t, f);
        }
        for i in 0..=N {
            let here = d2[i];
            if i == min_i || (i > 0 && here > d2[i - 1]) || (i < N && here > d2[i + 1]) {
                continue;
            }
            // In this bracket every point is within `slack` of one of the
            // three samples, the nearest of which is sample i.
            if here.sqrt() - self.slack > best_d2.sqrt() {
                continue;
            }
            let (t, f) = self.refine_sample(p, &d2, i);
            if f < best_d2 {
                (best_t, best_d2) = (t, f);
            }
        }
        self.certify(samples, p, &d2, &mut best_t, &mut best_d2);
        let point = self.eval(best_t);
        Some(ClosestPoint {
            t: best_t,
            point,
            dist: point.distance(p),
        })
    }

    /// Makes the sampled search exact: the samples can miss a minimum when
    /// one bracket holds two (near a sharp turn, an endpoint minimum and an
    /// interior one 0.02 apart; a soak of the brute-force test found one,
    /// 2% further than the true nearest point). The critical points of `f`
    /// are the roots of the quintic `g`; in Bernstein form the number of
    /// sign changes of the coefficients bounds the number of roots in an
    /// interval (Descartes). The coefficients on `[0, 1]` come from the
    /// cached parts (six dot products); a piece with no sign change holds
    /// no critical point; one with a single change from `-` to `+` holds
    /// one local minimum, which is the best point itself when that lies
    /// there and is critical (the usual case: nothing to do) and is
    /// otherwise found by safeguarded Newton if the samples do not prove
    /// the piece too far; one with more changes is halved (de Casteljau)
    /// until each piece has at most one. The best point changes only when
    /// a strictly nearer minimum turns up, so results are unchanged
    /// wherever the samples were enough.
    fn certify(
        &self,
        samples: &BracketSamples,
        p: DVec3,
        d2: &[f64; BRACKET_SAMPLES + 1],
        best_t: &mut f64,
        best_d2: &mut f64,
    ) {
        let mut c = samples.g_s;
        for (i, c) in c.iter_mut().enumerate() {
            *c -= p.x * samples.g_vx[i] + p.y * samples.g_vy[i] + p.z * samples.g_vz[i];
        }
        // The usual case, decided without a branch per coefficient: no
        // zero, and at most one sign change with a minimum's signs or none
        // (`isolate`'s first cases, here on the whole curve).
        let pos = c.map(|x| x > 0.0);
        let changes = pos.windows(2).filter(|w| w[0] != w[1]).count();
        if c.iter().all(|&x| x != 0.0) && (changes == 0 || (changes == 1 && !pos[0])) {
            return;
        }
        let mut budget = ISOLATE_BUDGET;
        self.isolate(p, d2, (0.0, 1.0), &c, 0, &mut budget, best_t, best_d2);
    }

    /// [`Self::certify`] on the piece `[a, b]` of `[0, 1]` where `c` are
    /// `g`'s Bernstein coefficients.
    #[allow(clippy::too_many_arguments)]
    fn isolate(
        &self,
        p: DVec3,
        d2: &[f64; BRACKET_SAMPLES + 1],
        (a, b): (f64, f64),
        c: &[f64; 6],
        depth: u32,
        budget: &mut u32,
        best_t: &mut f64,
        best_d2: &mut f64,
    ) {
        const N: usize = BRACKET_SAMPLES;
        const MAX_DEPTH: u32 = 40;
        // Coefficients that are rounding noise (a curve that is nearly a
        // point) could keep changing sign at every depth: the pieces looked
        // at are bounded, and `[a, b]` then counts as searched.
        if *budget == 0 {
            return;
        }
        *budget -= 1;
        let mut last = 0.0f64;
        let mut v = 0;
        for &x in c {
            if x != 0.0 && !x.is_nan() {
                if last != 0.0 && (x > 0.0) != (last > 0.0) {
                    v += 1;
                }
                last = x;
            }
        }
        if v == 0 {
            return;
        }
        if v == 1 {
            if !(c[0] < 0.0 && c[5] > 0.0) {
                // The one root is a maximum of f.
                return;
            }
            if depth == 0 {
                // f falls to one minimum and rises after it: the best
                // sample brackets it, and its refinement found it.
                return;
            }
            if *best_t > a && *best_t < b {
                // Whether the best point is critical (`B - p` perpendicular
                // to `B'` to 1e-6): then it is this piece's one root.
                let (q, d1) = (self.eval(*best_t) - p, self.derivative(*best_t));
                let g = q.dot(d1);
                if g * g <= 1e-12 * q.length_squared() * d1.length_squared() {
                    return;
                }
            }
        }
        // Every point of [a, b] is within `slack` of a sample in this index
        // range: a piece that cannot beat the best is dropped.
        let lo = ((a * N as f64).floor() as usize).min(N);
        let hi = ((b * N as f64).ceil() as usize).min(N);
        let near = d2[lo..=hi].iter().copied().fold(f64::INFINITY, f64::min);
        if near.sqrt() - self.slack > best_d2.sqrt() {
            return;
        }
        if v == 1 || depth >= MAX_DEPTH {
            let start = 0.5 * (a + b);
            let q = self.eval(start) - p;
            let (t, f) = if v == 1 {
                self.newton_bisect(p, a, b, start, q, self.derivative(start))
            } else {
                (start, q.length_squared())
            };
            if f < *best_d2 * (1.0 - 1e-12) {
                (*best_t, *best_d2) = (t, f);
            }
            return;
        }
        // Halve (de Casteljau) and look at both halves.
        let mut l = [0.0; 6];
        let mut r = [0.0; 6];
        let mut w = *c;
        for k in 0..6 {
            l[k] = w[0];
            r[5 - k] = w[5 - k];
            for j in 0..5 - k {
                w[j] = 0.5 * (w[j] + w[j + 1]);
            }
        }
        let m = 0.5 * (a + b);
        self.isolate(p, d2, (a, m), &l, depth + 1, budget, best_t, best_d2);
        self.isolate(p, d2, (m, b), &r, depth + 1, budget, best_t, best_d2);
    }

    /// `(f, g)` with `f = |B(t) - p|^2` and `g = (B(t) - p) . B'(t)` (half of
    /// `f'`).
    #[inline]
    fn f_g(&self, p: DVec3, t: f64) -> (f64, f64) {
        let q = self.eval(t) - p;
        (q.length_squared(), q.dot(self.derivative(t)))
    }

    /// Refines the discrete local minimum at sample `i` (squared sample
    /// distances `d2`) within its neighbours' bracket; never worse than the
    /// sample itself.
    fn refine_sample(&self, p: DVec3, d2: &[f64; BRACKET_SAMPLES + 1], i: usize) -> (f64, f64) {
        const N: usize = BRACKET_SAMPLES;
        let step = 1.0 / N as f64;
        let here = d2[i];
        let t0 = i as f64 * step;
        let (lo, hi, start) = if i == 0 {
            (0.0, step, 0.0)
        } else if i == N {
            (1.0 - step, 1.0, 1.0)
        } else {
            let (lo, hi) = ((i - 1) as f64 * step, (i + 1) as f64 * step);
            // Start at the vertex of the parabola through the three samples
            // (within h/2 of t0 since f(t0) is the least), which leaves
            // Newton two or three steps.
            let (left, right) = (d2[i - 1], d2[i + 1]);
            let curv = left - 2.0 * here + right;
            let start = if curv > 0.0 {
                (t0 + 0.5 * step * (left - right) / curv).clamp(lo, hi)
            } else {
                t0
            };
            (lo, hi, start)
        };
        let (t, f) = self.refine(p, lo, hi, start);
        if f <= here { (t, f) } else { (t0, here) }
    }

    /// A local minimum of `f` in `[lo, hi]` starting from `t0`: `(t, f(t))`.
    fn refine(&self, p: DVec3, lo: f64, hi: f64, t0: f64) -> (f64, f64) {
        let q = self.eval(t0) - p;
        let d1 = self.derivative(t0);
        let g0 = q.dot(d1);
        if g0 == 0.0 {
            return (t0, q.length_squared());
        }
        // A sub-bracket where g goes from - to +, starting from t0.
        let bracket = if g0 > 0.0 {
            if t0 == 0.0 {
                // f increases away from the start: the endpoint is a minimum.
                return (t0, q.length_squared());
            }
            (self.f_g(p, lo).1 < 0.0).then_some((lo, t0))
        } else {
            if t0 == 1.0 {
                // f decreases towards the end: the endpoint is a minimum.
                return (t0, q.length_squared());
            }
            (self.f_g(p, hi).1 > 0.0).then_some((t0, hi))
        };
        match bracket {
            Some((a, b)) => self.newton_bisect(p, a, b, t0, q, d1),
            None => self.golden(p, lo, hi),
        }
    }

    /// Safeguarded Newton on `g` in a bracket with `g(lo) < 0 < g(hi)`,
    /// from `start` where `B - p = q` and `B' = d1` are already known.
    fn newton_bisect(
        &self,
        p: DVec3,
        mut lo: f64,
        mut hi: f64,
        start: f64,
        mut q: DVec3,
        mut d1: DVec3,
    ) -> (f64, f64) {
        let mut t = start;
        for _ in 0..64 {
            let g = q.dot(d1);
            if g < 0.0 {
                lo = t;
            } else if g > 0.0 {
                hi = t;
            } else {
                break;
            }
            let gp = d1.length_squared() + q.dot(self.second_derivative(t));
            let newton = t - g / gp;
            // Rejects NaN from a zero `gp` too.
            let next = if gp > 0.0 && newton > lo && newton < hi {
                newton
            } else {
                0.5 * (lo + hi)
            };
            let done = (next - t).abs() <= NEWTON_TOL || hi - lo <= NEWTON_TOL;
            t = next;
            q = self.eval(t) - p;
            if done {
                break;
            }
            d1 = self.derivative(t);
        }
        (t, q.length_squared())
    }

    /// Golden-section search for a minimum of `f` on `[lo, hi]` (fallback).
    fn golden(&self, p: DVec3, mut lo: f64, mut hi: f64) -> (f64, f64) {
        const INV_PHI: f64 = 0.618_033_988_749_894_8;
        let f = |t: f64| self.eval(t).distance_squared(p);
        let mut x1 = hi - INV_PHI * (hi - lo);
        let mut x2 = lo + INV_PHI * (hi - lo);
        let (mut f1, mut f2) = (f(x1), f(x2));
        while hi - lo > 1e-12 {
            if f1 <= f2 {
                hi = x2;
                x2 = x1;
                f2 = f1;
                x1 = hi - INV_PHI * (hi - lo);
                f1 = f(x1);
            } else {
                lo = x1;
                x1 = x2;
                f1 = f2;
                x2 = lo + INV_PHI * (hi - lo);
                f2 = f(x2);
            }
        }
        let t = 0.5 * (lo + hi);
        (t, f(t))
    }

    /// Cumulative chord lengths at `n + 1` evenly spaced parameters: an
    /// arc-length table (`table[i]` = length of the curve from 0 to `i / n`).
    pub fn arc_length_table(&self, n: usize) -> Vec<f64> {
        let n = n.max(1);
        let mut out = Vec::with_capacity(n + 1);
        let mut acc = 0.0;
        let mut prev = self.eval(0.0);
        out.push(0.0);
        for i in 1..=n {
            let cur = self.eval(i as f64 / n as f64);
            acc += cur.distance(prev);
            prev = cur;
            out.push(acc);
        }
        out
    }

    /// Arc length of the whole curve (1024-chord approximation, relative
    /// error below 1e-6 for curves without cusps).
    pub fn length(&self) -> f64 {
        self.arc_length_table(1024).last().copied().unwrap_or(0.0)
    }
}

//! Log-space particle weights: normalization, effective sample size,
//! adaptive tempering, systematic resampling, and the choice among an
//! expansion's candidates.
//!
//! Weights are kept as logarithms from start to end. They are only
//! exponentiated after subtracting their maximum (the log-sum-exp trick),
//! so the largest normalized weight is exactly 1 and nothing overflows,
//! however negative the costs get (the reference implementation computed
//! `exp(-cost)` directly, which is `+inf` below a cost of about -709).
//!
//! **Why systematic resampling.** One uniform draw `u` places `n` evenly
//! spaced pointers `(u + k) / n`, `k = 0 .. n`, on the cumulative weights;
//! particle `i` is copied once per pointer that falls in its interval. Each
//! particle gets `floor(n w_i)` or `ceil(n w_i)` copies, so the extra noise
//! resampling adds is as low as it gets among the standard schemes
//! (multinomial resampling copies a particle `Binomial(n, w_i)` times;
//! residual resampling is close to systematic but draws its remainder
//! multinomially, with `n` draws), it is O(n), and it needs one random
//! number per generation, which keeps the run a simple function of the
//! seed. The pointers are matched with a binary search on the cumulative
//! sums (first index whose cumulative weight exceeds the pointer), so
//! every particle, the last one included, is reachable, and a particle of
//! weight zero is never chosen.

/// Normalized weights `exp(log_w - max)` in `out` (the largest is 1) and
/// their sum. Non-finite or NaN log-weights count as zero weight. When no
/// weight is positive (every particle is impossible) all get weight 1: the
/// population is then resampled uniformly rather than not at all.
pub fn normalized(log_w: &[f64], out: &mut Vec<f64>) -> f64 {
    out.clear();
    let max = log_w
        .iter()
        .copied()
        .filter(|x| !x.is_nan())
        .fold(f64::NEG_INFINITY, f64::max);
    if !max.is_finite() {
        // All -inf/NaN (or +inf, which only a broken cost could give):
        // +inf particles share the weight, otherwise uniform.
        let inf: Vec<bool> = log_w.iter().map(|&x| x == f64::INFINITY).collect();
        let any = inf.iter().any(|&b| b);
        out.extend(inf.iter().map(|&b| if b || !any { 1.0 } else { 0.0 }));
        return out.iter().sum();
    }
    out.extend(log_w.iter().map(|&x| {
        let w = (x - max).exp();
        if w.is_nan() { 0.0 } else { w }
    }));
    out.iter().sum()
}

/// `log(sum(exp(log_w)))`, computed without overflow; `-inf` for an empty
/// slice or when every weight is zero.
pub fn log_sum_exp(log_w: &[f64]) -> f64 {
    let max = log_w
        .iter()
        .copied()
        .filter(|x| !x.is_nan())
        .fold(f64::NEG_INFINITY, f64::max);
    if max.is_infinite() {
        return max;
    }
    let s: f64 = log_w
        .iter()
        .map(|&x| (x - max).exp())
        .filter(|w| !w.is_nan())
        .sum();
    max + s.ln()
}

/// Effective sample size `(sum w)^2 / sum w^2` of normalized weights: `n`
/// for equal weights, 1 when one particle holds all the weight.
pub fn ess(weights: &[f64]) -> f64 {
    let s: f64 = weights.iter().sum();
    let s2: f64 = weights.iter().map(|w| w * w).sum();
    if s2 > 0.0 { s * s / s2 } else { 0.0 }
}

/// ESS of the log-weights `log_w` tempered by `beta > 0` (finite ones
/// multiplied by `beta`; the others are zero weight), `max` the largest
/// finite log-weight: `(sum w)^2 / sum w^2` with `w = exp(beta (x - max))`,
/// summed in particle order. Equals `ess` of [`normalized`] of the
/// tempered weights when they are all finite or `-inf`.
fn tempered_ess(log_w: &[f64], beta: f64, max: f64) -> f64 {
    let (mut s, mut s2) = (0.0f64, 0.0f64);
    for &x in log_w {
        if x.is_finite() {
            let w = (beta * (x - max)).exp();
            s += w;
            s2 += w * w;
        }
    }
    if s2 > 0.0 { s * s / s2 } else { 0.0 }
}

/// Iterations of the bisection in [`temper`], on `log2(beta)` over
/// `[TEMPER_MIN_LOG2, 0]`: `beta` to within a factor `2^(40 / 2^16)`, about
/// 0.04%.
pub const TEMPER_ITERATIONS: u32 = 16;

/// The smallest `log2(beta)` [`temper`] tries: `beta >= 2^-40`.
pub const TEMPER_MIN_LOG2: f64 = -40.0;

/// Adaptive tempering: the largest `beta` in `(0, 1]` (to within a factor
/// of about 1.0004) such that the log-weights `beta * log_w` keep an
/// effective sample size of at least `target` (a particle count). Returns 1
/// when the untempered weights already reach it (or `target <= 0`, or
/// fewer than two weights are finite: nothing to flatten). The target is
/// capped at the number of finite weights, the ESS as `beta -> 0`.
///
/// Found by bisection on `log2(beta)` over `[TEMPER_MIN_LOG2, 0]`,
/// [`TEMPER_ITERATIONS`] steps (one `exp` per weight each), a pure
/// function of `log_w` in particle order (no randomness, no dependence on
/// threads). ESS is non-increasing in `beta` for tempered weights, so the
/// bisection keeps `lo` (meets the target) and `hi` (misses it) and
/// returns `2^lo`; if even `2^TEMPER_MIN_LOG2` misses it, that is returned.
pub fn temper(log_w: &[f64], target: f64) -> f64 {
    let finite = log_w.iter().filter(|x| x.is_finite()).count();
    if target.is_nan() || target <= 0.0 || finite < 2 {
        return 1.0;
    }
    // Slightly below the limit so that the cap is reachable with beta > 0.
    let target = target.min(finite as f64 * (1.0 - 1e-9));
    if log_w.contains(&f64::INFINITY) {
        // Only a broken cost gives +inf; `normalized` then keeps those.
        return 1.0;
    }
    let max = log_w
        .iter()
        .copied()
        .filter(|x| x.is_finite())
        .fold(f64::NEG_INFINITY, f64::max);
    if tempered_ess(log_w, 1.0, max) >= target {
        return 1.0;
    }
    let (mut lo, mut hi) = (TEMPER_MIN_LOG2, 0.0f64);
    for _ in 0..TEMPER_ITERATIONS {
        let mid = 0.5 * (lo + hi);
        if tempered_ess(log_w, mid.exp2(), max) >= target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo.exp2()
}

/// `log_w` multiplied in place by `beta` (finite entries only).
pub fn scale(log_w: &mut [f64], beta: f64) {
    if beta != 1.0 {
        for x in log_w.iter_mut().filter(|x| x.is_finite()) {
            *x *= beta;
        }
    }
}

/// Systematic resampling: `n_out` ancestor indices into `weights`
/// (non-negative, not all zero; see [`normalized`]) for the pointers
/// `(u + k) / n_out`, `u` in `[0, 1)`. Indices come out in increasing
/// order.
pub fn systematic(weights: &[f64], n_out: usize, u: f64, out: &mut Vec<usize>) {
    out.clear();
    if weights.is_empty() || n_out == 0 {
        return;
    }
    let mut cum = Vec::with_capacity(weights.len());
    let mut acc = 0.0f64;
    for &w in weights {
        acc += w.max(0.0);
        cum.push(acc);
    }
    let total = acc;
    // The last index of positive weight: where a pointer lands if rounding
    // carried it to the total.
    let last = weights
        .iter()
        .rposition(|&w| w > 0.0)
        .unwrap_or(weights.len() - 1);
    if total <= 0.0 || !total.is_finite() {
        // Degenerate input: spread evenly.
        out.extend((0..n_out).map(|k| k * weights.len() / n_out));
        return;
    }
    let u = u.clamp(0.0, 1.0);
    for k in 0..n_out {
        let t = (u + k as f64) / n_out as f64 * total;
        let i = cum.partition_point(|&c| c <= t);
        out.push(if i < weights.len() { i } else { last });
    }
}

/// Sampling-importance-resampling among the candidates of one expansion:
/// candidate `k` has the log selection weight `log_v[k]`; the one chosen
/// is the first whose cumulative weight exceeds `u` times the total (`u` in
/// `[0, 1)`: the inverse of the selection distribution, so candidate `k`
/// is chosen with probability `v_k / sum v`, and never one of weight 0).
/// Returns it and the log-weight correction `log(mean v) - log v_chosen`:
/// the importance weight of a step proposed this way is the step's target
/// ratio times `mean v / v_chosen` (for `v` the target ratio of each
/// candidate itself, just `mean v`). When every weight is 0 (or NaN) the
/// choice is uniform and the correction 0.
pub fn choose_candidate(log_v: &[f64], u: f64) -> (usize, f64) {
    let n = log_v.len();
    if n == 0 {
        return (0, 0.0);
    }
    let max = log_v
        .iter()
        .copied()
        .filter(|x| !x.is_nan())
        .fold(f64::NEG_INFINITY, f64::max);
    if !max.is_finite() {
        // All impossible (or a broken +inf): uniform.
        let c = ((u.clamp(0.0, 1.0) * n as f64) as usize).min(n - 1);
        return (c, 0.0);
    }
    // exp(x - max) is at most 1, and exactly 1 for the largest.
    let w = |x: f64| {
        let e = (x - max).exp();
        if e.is_nan() { 0.0 } else { e }
    };
    let total: f64 = log_v.iter().map(|&x| w(x)).sum();
    let t = u.clamp(0.0, 1.0) * total;
    let mut acc = 0.0;
    let mut chosen = None;
    let mut last = 0;
    for (k, &x) in log_v.iter().enumerate() {
        let v = w(x);
        if v > 0.0 {
            last = k;
        }
        acc += v;
        if acc > t && v > 0.0 {
            chosen = Some(k);
            break;
        }
    }
    let c = chosen.unwrap_or(last);
    let log_mean = max + (total / n as f64).ln();
    (c, log_mean - log_v[c])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn huge_negative_costs_do_not_overflow() {
        // Costs of -1e6 and -1e6 + 1: log-weights 1e6 and 1e6 - 1.
        let lw = [1e6, 1e6 - 1.0, f64::NEG_INFINITY];
        let mut w = Vec::new();
        let total = normalized(&lw, &mut w);
        assert_eq!(w[0], 1.0);
        assert!((w[1] - (-1.0f64).exp()).abs() < 1e-15);
        assert_eq!(w[2], 0.0);
        assert!((total - (1.0 + (-1.0f64).exp())).abs() < 1e-15);
        assert!((log_sum_exp(&lw) - (1e6 + (1.0 + (-1.0f64).exp()).ln())).abs() < 1e-6);
        let e = ess(&w);
        assert!(e > 1.0 && e < 2.0, "{e}");
    }

    #[test]
    fn impossible_populations_resample_uniformly() {
        let mut w = Vec::new();
        normalized(&[f64::NEG_INFINITY, f64::NAN, f64::NEG_INFINITY], &mut w);
        assert_eq!(w, vec![1.0, 1.0, 1.0]);
        assert_eq!(log_sum_exp(&[]), f64::NEG_INFINITY);
    }

    #[test]
    fn the_last_particle_can_be_chosen() {
        // All the weight on the last particle: every pointer lands on it.
        let mut out = Vec::new();
        for u in [0.0, 0.3, 0.999_999] {
            systematic(&[0.0, 0.0, 0.0, 1.0], 5, u, &mut out);
            assert_eq!(out, vec![3; 5]);
        }
        // Weight zero after it: never chosen, even at the end of the range.
        systematic(&[0.5, 0.5, 0.0], 4, 0.999_999_9, &mut out);
        assert!(out.iter().all(|&i| i < 2), "{out:?}");
        assert_eq!(out.iter().filter(|&&i| i == 1).count(), 2);
    }

    #[test]
    fn copies_are_floor_or_ceil_of_n_w() {
        let weights = [0.1, 0.25, 0.05, 0.4, 0.2];
        let n = 17;
        let mut out = Vec::new();
        for k in 0..50 {
            let u = k as f64 / 50.0;
            systematic(&weights, n, u, &mut out);
            assert_eq!(out.len(), n);
            assert!(out.windows(2).all(|p| p[0] <= p[1]));
            for (i, &w) in weights.iter().enumerate() {
                let c = out.iter().filter(|&&j| j == i).count() as f64;
                let e = w * n as f64;
                assert!(
                    c == e.floor() || c == e.ceil(),
                    "particle {i}: {c} copies for {e}"
                );
            }
        }
    }

    #[test]
    fn equal_weights_keep_everyone_when_counts_match() {
        let mut out = Vec::new();
        systematic(&[1.0; 8], 8, 0.5, &mut out);
        assert_eq!(out, (0..8).collect::<Vec<_>>());
        let mut w = Vec::new();
        normalized(&[-3.0; 8], &mut w);
        assert!((ess(&w) - 8.0).abs() < 1e-12);
    }

    #[test]
    fn tempering_reaches_the_target_ess() {
        // Peaked weights: one bone moves the log-weight by hundreds.
        let lw: Vec<f64> = (0..100).map(|i| -((i * 37) % 100) as f64 * 13.0).collect();
        let mut w = Vec::new();
        normalized(&lw, &mut w);
        assert!(ess(&w) < 1.1);
        let beta = temper(&lw, 50.0);
        assert!(beta > 0.0 && beta < 1.0, "{beta}");
        let mut t = lw.clone();
        scale(&mut t, beta);
        normalized(&t, &mut w);
        let e = ess(&w);
        assert!((50.0..50.5).contains(&e), "{e}");
        // Deterministic, and 1 when the target is met already or disabled.
        assert_eq!(temper(&lw, 50.0).to_bits(), beta.to_bits());
        assert_eq!(temper(&lw, 0.0), 1.0);
        assert_eq!(temper(&[0.0; 10], 5.0), 1.0);
        assert_eq!(temper(&[-3.0, f64::NEG_INFINITY], 1.5), 1.0);
        // Impossible particles stay impossible; the target is capped at
        // the finite count.
        let lw = [0.0, -500.0, -900.0, f64::NEG_INFINITY];
        let beta = temper(&lw, 4.0);
        let mut t = lw.to_vec();
        scale(&mut t, beta);
        normalized(&t, &mut w);
        assert_eq!(w[3], 0.0);
        assert!(ess(&w) > 2.99, "{}", ess(&w));
    }
    #[test]
    fn candidates_are_chosen_in_proportion_to_their_weights() {
        // v = (1, 3, 0, 4) up to a common factor.
        let lv = [0.0, 3f64.ln(), f64::NEG_INFINITY, 4f64.ln()];
        let mut counts = [0usize; 4];
        for k in 0..8000 {
            let u = (k as f64 + 0.5) / 8000.0;
            let (c, corr) = choose_candidate(&lv, u);
            counts[c] += 1;
            // log(mean v) - log(v_c), mean v = 8 / 4 = 2.
            assert!((corr - (2f64.ln() - lv[c])).abs() < 1e-12, "{c} {corr}");
        }
        assert_eq!(counts, [1000, 3000, 0, 4000]);
        // Huge log-weights do not overflow; the largest can be chosen at
        // the end of the range.
        let (c, corr) = choose_candidate(&[1e6, 1e6 - 800.0], 0.999_999);
        assert_eq!(c, 0);
        assert!((corr - (0.5f64).ln()).abs() < 1e-9, "{corr}");
        // All impossible: uniform, no correction.
        let bad = [f64::NEG_INFINITY; 3];
        assert_eq!(choose_candidate(&bad, 0.0), (0, 0.0));
        assert_eq!(choose_candidate(&bad, 0.99), (2, 0.0));
        assert_eq!(choose_candidate(&[], 0.5), (0, 0.0));
        // One candidate: chosen, correction 0 (the plain proposal).
        assert_eq!(choose_candidate(&[-123.0], 0.7), (0, 0.0));
    }

    /// The correction makes the weighted candidates a proper importance
    /// sample of the target, whatever the selection weights: over many
    /// proposals (`K` candidates from the prior, one chosen in proportion
    /// to `v`), `sum w [x = j] / sum w` with `w = target ratio * mean v /
    /// v_chosen` converges to the target's probability of `j`. Without the
    /// correction it converges elsewhere.
    #[test]
    fn candidate_weights_target_the_posterior() {
        let prior = [0.4, 0.3, 0.2, 0.1];
        // Log target ratio (the likelihood) and a different selection score.
        let log_g = [-2.0, 0.0, -1.0, -3.0];
        let log_v = [0.0, 0.0, -2.0, -1.0];
        let z: f64 = (0..4).map(|j| prior[j] * f64::exp(log_g[j])).sum();
        let target: Vec<f64> = (0..4).map(|j| prior[j] * f64::exp(log_g[j]) / z).collect();
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut uniform = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let draw = |u: f64| {
            let mut acc = 0.0;
            for (j, p) in prior.iter().enumerate() {
                acc += p;
                if u < acc {
                    return j;
                }
            }
            3
        };
        for (select, corrected) in [(&log_v, true), (&log_g, true), (&log_v, false)] {
            let (mut w, mut total) = ([0.0f64; 4], 0.0);
            for _ in 0..200_000 {
                let xs = [draw(uniform()), draw(uniform()), draw(uniform())];
                let lv: Vec<f64> = xs.iter().map(|&x| select[x]).collect();
                let (c, corr) = choose_candidate(&lv, uniform());
                let lw = log_g[xs[c]] + if corrected { corr } else { 0.0 };
                w[xs[c]] += lw.exp();
                total += lw.exp();
            }
            let err = (0..4)
                .map(|j| (w[j] / total - target[j]).abs())
                .fold(0.0, f64::max);
            if corrected {
                assert!(err < 0.01, "{select:?}: {err}");
            } else {
                assert!(err > 0.05, "uncorrected should be off: {err}");
            }
        }
    }
}

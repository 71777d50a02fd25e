//! Fixed-point cost accumulation, so that a model's total cost is
//! bit-for-bit independent of the order its bones were added.
//!
//! Floating-point addition is not associative, so summing the same per-bone
//! costs in two orders can differ in the last bits. Each contribution is
//! instead rounded once to a multiple of 2^-32 (an error below 1.2e-10 per
//! contribution) and summed as an `i128`, which is exact and associative.
//! The range (about ±4e28) is far beyond any cost a model can reach.

/// One unit is 2^-32 cost.
pub(crate) const ONE: f64 = 4_294_967_296.0;

/// A cost rounded to the fixed-point grid. Callers pass finite values
/// (costs of finite bones from validated parameters); a non-finite value
/// saturates (`as` casts saturate and map NaN to 0) instead of panicking.
#[inline]
pub(crate) fn to_fixed(x: f64) -> i128 {
    (x * ONE).round() as i128
}

/// Back to `f64` (exact for magnitudes below 2^21, rounded above).
#[inline]
pub(crate) fn to_f64(x: i128) -> f64 {
    x as f64 / ONE
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_resolution() {
        assert_eq!(to_f64(to_fixed(1.5)), 1.5);
        assert_eq!(to_f64(to_fixed(-160.0)), -160.0);
        // Resolution 2^-32: 1e-10 rounds to 0, 3e-10 to one unit.
        assert_eq!(to_fixed(1e-10), 0);
        assert_eq!(to_fixed(3e-10), 1);
        assert!((to_f64(to_fixed(0.1)) - 0.1).abs() < 1.2e-10);
    }

    #[test]
    fn summation_is_order_independent() {
        // In f64, (a + b) + c != a + (b + c) for these; in fixed point it is.
        let (a, b, c) = (0.1, 0.2, 0.3);
        assert_ne!((a + b) + c, a + (b + c));
        let (fa, fb, fc) = (to_fixed(a), to_fixed(b), to_fixed(c));
        assert_eq!((fa + fb) + fc, fa + (fb + fc));
    }
}

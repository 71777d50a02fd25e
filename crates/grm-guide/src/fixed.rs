//! Fixed-point cost accumulation, so that a model's total cost is
//! bit-for-bit independent of the order its bones were added.
//!
//! Floating-point addition is not associative, so summing the same per-bone
//! costs in two orders can differ in the last bits. Each contribution is
//! instead rounded once to a multiple of 2^-32 (an error below 1.2e-10 per
//! contribution) and summed as an `i128`, which is exact and associative.
//!
//! A contribution is clamped to ±2^100 units (a cost of ±2^68, about
//! ±3e20: a bone placed absurdly far from every curve, from extreme
//! parameters). The sum of up to 2^26 such contributions stays within the
//! `i128` range, so the order independence holds for every model the
//! sampler's limits let through; the accumulations saturate instead of
//! overflowing past that.

/// One unit is 2^-32 cost.
pub(crate) const ONE: f64 = 4_294_967_296.0;

/// A cost rounded to the fixed-point grid and clamped to ±2^100 units
/// (an infinity clamps too; a NaN, which stays NaN through `clamp`, casts
/// to 0).
#[inline]
pub(crate) fn to_fixed(x: f64) -> i128 {
    (x * ONE).round().clamp(-MAX_UNITS, MAX_UNITS) as i128
}

/// The largest magnitude of one contribution, in units (2^100).
const MAX_UNITS: f64 = 1_267_650_600_228_229_401_496_703_205_376.0;

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
        // Huge costs clamp (2^68); sums of 2^26 of them stay in range.
        assert_eq!(to_fixed(1e300), 1i128 << 100);
        assert_eq!(to_fixed(-f64::INFINITY), -(1i128 << 100));
        assert_eq!(to_fixed(f64::NAN), 0);
        assert!((1i128 << 100).checked_mul(1 << 26).is_some());
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

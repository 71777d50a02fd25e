//! The 32-bit float semantics of the language's operators and built-in
//! functions: the one definition that the checker's constant folding
//! ([`crate::eval`]) and the CPU engines' bytecode VM
//! (`grm_compile::vm`) both call, so a folded constant and the same
//! expression evaluated at run time give the same bits.
//!
//! Angles are in degrees; `%` is the floored remainder. The GPU kernels
//! implement the same formulas in WGSL (agreement within the tolerance of
//! docs/gpu.md).

/// Degrees to radians, as an f32 factor.
pub const DEG: f32 = std::f32::consts::PI / 180.0;

/// `x - y * floor(x / y)`: the result has the sign of the divisor.
#[inline]
pub fn floored_rem(x: f32, y: f32) -> f32 {
    x - y * (x / y).floor()
}

/// -1, 0 or 1 (0 for NaN).
#[inline]
pub fn sign(x: f32) -> f32 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        0.0
    }
}

/// `x - floor(x)`.
#[inline]
pub fn fract(x: f32) -> f32 {
    x - x.floor()
}

/// 0 below the edge, else 1.
#[inline]
pub fn step(edge: f32, x: f32) -> f32 {
    if x < edge { 0.0 } else { 1.0 }
}

/// Hermite interpolation between 0 and 1 over `[e0, e1]`.
#[inline]
pub fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// `clamp` that never panics (`f32::clamp` asserts `lo <= hi`).
#[inline]
pub fn clamp(x: f32, lo: f32, hi: f32) -> f32 {
    x.max(lo).min(hi)
}

/// Linear interpolation `x * (1 - t) + y * t`.
#[inline]
pub fn mix(x: f32, y: f32, t: f32) -> f32 {
    x * (1.0 - t) + y * t
}

#[inline]
pub fn sin_deg(x: f32) -> f32 {
    (x * DEG).sin()
}

#[inline]
pub fn cos_deg(x: f32) -> f32 {
    (x * DEG).cos()
}

#[inline]
pub fn tan_deg(x: f32) -> f32 {
    (x * DEG).tan()
}

#[inline]
pub fn asin_deg(x: f32) -> f32 {
    x.asin().to_degrees()
}

#[inline]
pub fn acos_deg(x: f32) -> f32 {
    x.acos().to_degrees()
}

#[inline]
pub fn atan_deg(x: f32) -> f32 {
    x.atan().to_degrees()
}

#[inline]
pub fn atan2_deg(y: f32, x: f32) -> f32 {
    y.atan2(x).to_degrees()
}

#[inline]
pub fn dot(u: [f32; 3], v: [f32; 3]) -> f32 {
    u[0] * v[0] + u[1] * v[1] + u[2] * v[2]
}

#[inline]
pub fn cross(u: [f32; 3], v: [f32; 3]) -> [f32; 3] {
    [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ]
}

#[inline]
pub fn length(u: [f32; 3]) -> f32 {
    (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt()
}

/// The unit vector along `u`; the zero vector normalizes to itself rather
/// than to NaN.
#[inline]
pub fn normalize(u: [f32; 3]) -> [f32; 3] {
    let l = length(u);
    if l > 0.0 {
        [u[0] / l, u[1] / l, u[2] / l]
    } else {
        [0.0; 3]
    }
}

#[inline]
pub fn distance(u: [f32; 3], v: [f32; 3]) -> f32 {
    length([u[0] - v[0], u[1] - v[1], u[2] - v[2]])
}

/// Uniform cubic B-spline over `n >= 4` control values, `t` clamped to
/// [0, 1] (NaN reads as 0) and spread evenly over the `n - 3` segments:
/// the first of the four controls used and their weights. The value is
/// `0 + c[i] * w[0] + c[i + 1] * w[1] + c[i + 2] * w[2] + c[i + 3] * w[3]`,
/// summed in that order.
#[inline]
pub fn spline_weights(t: f32, n: usize) -> (usize, [f32; 4]) {
    let segments = (n - 3) as f32;
    let u = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) } * segments;
    let i = (u.floor() as usize).min(n - 4);
    let s = u - i as f32;
    let s2 = s * s;
    let s3 = s2 * s;
    (
        i,
        [
            (1.0 - 3.0 * s + 3.0 * s2 - s3) / 6.0,
            (4.0 - 6.0 * s2 + 3.0 * s3) / 6.0,
            (1.0 + 3.0 * s + 3.0 * s2 - 3.0 * s3) / 6.0,
            s3 / 6.0,
        ],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floored_remainder_has_divisor_sign() {
        assert_eq!(floored_rem(-1.0, 360.0), 359.0);
        assert_eq!(floored_rem(370.0, 360.0), 10.0);
    }

    #[test]
    fn trig_is_in_degrees() {
        assert!((sin_deg(90.0) - 1.0).abs() < 1e-6);
        assert!((atan2_deg(1.0, 1.0) - 45.0).abs() < 1e-5);
    }

    #[test]
    fn spline_weights_sum_to_one() {
        for t in [0.0, 0.3, 0.5, 1.0, f32::NAN] {
            let (i, w) = spline_weights(t, 6);
            assert!(i <= 2);
            assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-6);
        }
    }

    #[test]
    fn the_zero_vector_normalizes_to_itself() {
        assert_eq!(normalize([0.0; 3]), [0.0; 3]);
    }
}

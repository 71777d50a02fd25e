//! What the workspace's test suites share: the generator of their random
//! inputs (random grammars, strings, edits, curves, points), and
//! [`renamed`], the scripted rename of a grammar's identifier.
//!
//! Input: a test's own fixed seed, and optionally the `GRM_TEST_SEED`
//! environment variable. Output: a splitmix64 stream and the draws the
//! suites take from it (`below`, `unit`, `range`, `pick`, `shuffle`).
//!
//! [`bench`]: what the benchmarks share (median, load average, cachegrind
//! instruction counts of the benchmark's own binary).
//!
//! Invariants: without `GRM_TEST_SEED` every test draws the same inputs on
//! every run and machine (CI is reproducible); with it, every test that
//! seeds with [`Rng::seeded`] draws other inputs for the same properties
//! (a soak: `GRM_TEST_SEED=1 ./scripts/test.sh`, then 2, 3, ...), and says
//! so on stderr. Tests print a failing case's input itself (the grammar,
//! the string), so a failure found by a soak reproduces without the seed.
//! Used only as a dev-dependency; nothing here panics but on a malformed
//! `GRM_TEST_SEED`.

pub mod bench;

/// A small deterministic generator (splitmix64).
#[derive(Debug, Clone)]
pub struct Rng(u64);

/// An integer type the generator draws below a bound in.
pub trait Bound: Copy {
    /// The bound as u64 (0 for a negative one).
    fn to_u64(self) -> u64;
    /// A draw below the bound back in the bound's type (it fits).
    fn from_u64(v: u64) -> Self;
}

macro_rules! bound {
    ($($t:ty),*) => {$(
        impl Bound for $t {
            fn to_u64(self) -> u64 {
                u64::try_from(self).unwrap_or(0)
            }
            fn from_u64(v: u64) -> Self {
                // Invariant: v is below a bound of this type.
                <$t>::try_from(v).unwrap_or(0)
            }
        }
    )*};
}
bound!(u8, u16, u32, u64, usize, i32, i64);

/// The environment variable that turns a run into a soak.
pub const SEED_VAR: &str = "GRM_TEST_SEED";

impl Rng {
    /// A generator with exactly this seed, whatever the environment (for
    /// inputs that must not change: an expected value computed from them).
    pub fn new(seed: u64) -> Rng {
        Rng(seed)
    }

    /// The generator of a random test: seeded with `default`, or, when
    /// `GRM_TEST_SEED` is set, with `default` mixed with it.
    pub fn seeded(default: u64) -> Rng {
        match std::env::var(SEED_VAR) {
            Ok(v) => {
                let n: u64 = v
                    .trim()
                    .parse()
                    .unwrap_or_else(|_| panic!("{SEED_VAR}={v:?} is not a whole number"));
                eprintln!("{SEED_VAR}={n}");
                let mut mix = Rng(default ^ n.wrapping_mul(0x2545_f491_4f6c_dd1d));
                Rng(mix.next_u64())
            }
            Err(_) => Rng(default),
        }
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in `0..n`, in `n`'s type; 0 when `n` is 0 or negative.
    pub fn below<N: Bound>(&mut self, n: N) -> N {
        let n = n.to_u64();
        let v = self.next_u64();
        N::from_u64(if n == 0 { 0 } else { v % n })
    }

    /// A whole number in `lo..=hi` (`lo` when `hi < lo`).
    pub fn int(&mut self, lo: i64, hi: i64) -> i64 {
        if hi < lo {
            return lo;
        }
        let span = hi.abs_diff(lo).saturating_add(1);
        lo.wrapping_add(self.below(span) as i64)
    }

    /// Uniform in `[0, 1)`, 53 bits.
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in `[lo, hi)`.
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }

    /// Uniform in `[lo, hi)` as f32 (24 bits).
    pub fn range_f32(&mut self, lo: f32, hi: f32) -> f32 {
        let u = (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32;
        lo + (hi - lo) * u
    }

    /// One of `xs` (which must not be empty).
    pub fn pick<'a, T>(&mut self, xs: &'a [T]) -> &'a T {
        &xs[self.below(xs.len())]
    }

    /// Fisher-Yates.
    pub fn shuffle<T>(&mut self, v: &mut [T]) {
        for i in (1..v.len()).rev() {
            let j = self.below(i + 1);
            v.swap(i, j);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_stay_in_their_bounds() {
        let mut r = Rng::new(1);
        for n in 1..200u32 {
            assert!(r.below(n) < n);
            assert!(r.below(n as usize) < n as usize);
            let k = r.int(-3, i64::from(n));
            assert!((-3..=i64::from(n)).contains(&k));
            let u = r.unit();
            assert!((0.0..1.0).contains(&u));
            let f = r.range_f32(-2.0, 5.0);
            assert!((-2.0..5.0).contains(&f));
        }
        assert_eq!(r.below(0u64), 0);
        assert_eq!(r.below(-5), 0);
        assert_eq!(r.int(5, 1), 5);
        assert!((i64::MIN..=i64::MAX).contains(&r.int(i64::MIN, i64::MAX)));
    }

    #[test]
    fn the_same_seed_draws_the_same_stream() {
        let a: Vec<u64> = (0..8)
            .scan(Rng::new(42), |r, _| Some(r.next_u64()))
            .collect();
        let b: Vec<u64> = (0..8)
            .scan(Rng::new(42), |r, _| Some(r.next_u64()))
            .collect();
        let c: Vec<u64> = (0..8)
            .scan(Rng::new(43), |r, _| Some(r.next_u64()))
            .collect();
        assert_eq!(a, b);
        assert_ne!(a, c);
    }

    #[test]
    fn shuffle_is_a_permutation() {
        let mut r = Rng::new(7);
        let mut v: Vec<u32> = (0..50).collect();
        r.shuffle(&mut v);
        let mut s = v.clone();
        s.sort_unstable();
        assert_eq!(s, (0..50).collect::<Vec<_>>());
        assert_ne!(v, s, "50 elements shuffled into their own order");
    }
}

/// `text` with the identifier `from` renamed `to` (whole words only: a
/// word is a run of alphanumerics and `_`).
pub fn renamed(text: &str, from: &str, to: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut word = String::new();
    for c in text.chars().chain(std::iter::once(' ')) {
        if c.is_alphanumeric() || c == '_' {
            word.push(c);
            continue;
        }
        out.push_str(if word == from { to } else { &word });
        word.clear();
        out.push(c);
    }
    out.pop();
    out
}

#[cfg(test)]
mod rename_tests {
    #[test]
    fn only_whole_words_are_renamed() {
        assert_eq!(
            super::renamed("Floor -> FloorTop Floor(1) _Floor", "Floor", "Storey"),
            "Storey -> FloorTop Storey(1) _Floor"
        );
    }
}

//! The random draws: one counter-based hash, defined once here.
//!
//! Every random number in a derivation is a pure function of four `u32`s:
//! the run's **seed**, the **iteration** (the index of the string being
//! produced: 0 for the axiom, `k` for the string after `k` rewriting steps),
//! the **key** of the module being rewritten (its stable identity, below;
//! the system's root key for the axiom) and the **draw index** (each
//! random call site has its own index, see [`draw_index`]; each
//! alternative of a stochastic group has its own race draw,
//! [`choice_draw`]). Nothing depends on evaluation
//! order, on threads or on a module's position in the string, so the CPU
//! engine with any number of threads and the GPU kernels draw the same
//! numbers, and a module that is inserted upstream re-rolls nothing else.
//!
//! # Identity keys
//!
//! Every module carries a 32-bit **key** minted from the structure of the
//! derivation, never from positions or creation order:
//!
//! - the system's **root key** is `hash(seed, ROOT_TAG, name_hash(system
//!   name), 0)` ([`root_key`]);
//! - each successor module (and each axiom module) has a compile-time
//!   **salt**, `hash(name_hash(symbol name), occurrence, alternative,
//!   SALT_TAG)` ([`salt`]): `occurrence` counts the modules of the same
//!   symbol before it in that successor, `alternative` is the production's
//!   index among its group's alternatives (0 for the axiom);
//! - a module written by a rewrite gets `child_key(parent key, salt)`
//!   ([`child_key`]: MurmurHash3 of the 4-byte key `salt` with the
//!   parent's key as the seed); an axiom module's parent is the root key;
//!   a module that no production rewrites keeps its key.
//!
//! So a module's key depends on its ancestry only (the chain of symbols,
//! occurrence indices and alternatives from the axiom, the system's name
//! and the seed): inserting a module that draws nothing changes no other
//! key, and editing one production changes only the keys (and so the
//! draws) of what descends from its applications. Keys are not unique by
//! construction (32 bits); two modules that share one draw the same
//! numbers, which is all a collision can do.
//!
//! # Formula
//!
//! `hash(seed, iteration, position, draw)` is MurmurHash3 x86_32 of the
//! 12-byte key `iteration, position, draw` (three little-endian `u32`
//! words) with `seed` as the hash seed:
//!
//! ```text
//! h = seed
//! for k in [iteration, position, draw]:
//!     k = k * 0xcc9e2d51;  k = rotl(k, 15);  k = k * 0x1b873593
//!     h = h ^ k;  h = rotl(h, 13);  h = h * 5 + 0xe6546b64
//! h = h ^ 12
//! h = h ^ (h >> 16);  h = h * 0x85ebca6b
//! h = h ^ (h >> 13);  h = h * 0xc2b2ae35
//! h = h ^ (h >> 16)
//! ```
//!
//! All operations are on `u32` with wrapping multiplication and addition
//! (WGSL `u32` arithmetic wraps the same way; `rotl(x, r)` is
//! `(x << r) | (x >> (32 - r))`).
//!
//! The uniform float is `u = f32(h >> 8) * 2^-24`: a multiple of `2^-24` in
//! `[0, 1)`. Both steps are exact in f32 (an integer below `2^24` converts
//! exactly and the scale is a power of two), so `u` is bit-identical
//! everywhere.
//!
//! # Choosing among weighted alternatives: a race
//!
//! A stochastic group does not compare one uniform against cumulative
//! weights (that would let an edit of one production's weight change the
//! choice between two *other* productions). Each alternative `k` draws
//! its own number, `h_k = hash(seed, iteration, key, choice_draw(k))`, and
//! runs an exponential race: its time is `-ln(u_k) / w_k` and the earliest
//! wins (the first alternative on a tie). The winner is alternative `k`
//! with probability `w_k / sum(w)`, exactly as before, and changing one
//! weight `w_p` can only make `p` win where it lost or lose where it won:
//! every module whose choice changes chose `p` before or chooses it now
//! (the rule behind weighted rendezvous hashing).
//!
//! The race is decided exactly so that the CPU and the GPU agree bit for
//! bit: an alternative's time is [`race_time`], `-log2(u_k)` in 16.16
//! fixed point (an integer from [`log2_fixed`]: a 257-entry table of
//! `log2(1 + i/256)`, [`LOG2_TABLE`], and rounded linear interpolation,
//! within 1.5/65536 of the true logarithm) for `u_k = ((h_k >> 8) + 1) /
//! 2^24` in `(0, 1]`; alternative `a` is earlier than `b` when
//! `time_a * w_b < time_b * w_a`, compared exactly ([`race_earlier`]); the
//! earliest wins, the first alternative on a tie. (The constant factor
//! between `ln` and `log2` is the same for every alternative and drops
//! out.)
//!
//! `normal(mean, sd)` is Box-Muller in f32 on `u1 = u(draw)` and
//! `u2 = u(draw + 1)`: `mean + sd * sqrt(-2 ln(1 - u1)) * cos(2 PI u2)`
//! (`1 - u1` is in `(0, 1]`, so the logarithm is finite). It uses `ln`,
//! `sqrt` and `cos`, which are not correctly rounded: CPU and GPU agree to a
//! few ulps there, not bit for bit (the GPU computes `ln` near 1 itself, as
//! WGSL's `log` has no relative accuracy there: docs/gpu.md).

/// The tag word of [`root_key`].
pub const ROOT_TAG: u32 = 0x726f_6f74;
/// The tag word of [`salt`].
pub const SALT_TAG: u32 = 0x7361_6c74;

/// MurmurHash3 x86_32 of a name's UTF-8 bytes with seed 0: how a system or
/// symbol name enters a key (names, not ids, so renumbering symbols
/// re-rolls nothing).
pub fn name_hash(name: &str) -> u32 {
    let bytes = name.as_bytes();
    let mut h = 0u32;
    let mut chunks = bytes.chunks_exact(4);
    for c in &mut chunks {
        h = mix(h, u32::from_le_bytes([c[0], c[1], c[2], c[3]]));
    }
    let tail = chunks.remainder();
    if !tail.is_empty() {
        let mut k = 0u32;
        for (i, b) in tail.iter().enumerate() {
            k |= u32::from(*b) << (8 * i);
        }
        h ^= k
            .wrapping_mul(0xcc9e_2d51)
            .rotate_left(15)
            .wrapping_mul(0x1b87_3593);
    }
    fmix(h ^ bytes.len() as u32)
}

/// The root key of a system's derivation with `seed`: the parent of its
/// axiom's modules, and the key the axiom's own draws use.
#[inline]
pub const fn root_key(seed: u32, system_name_hash: u32) -> u32 {
    hash(seed, ROOT_TAG, system_name_hash, 0)
}

/// The compile-time salt of a successor module: its symbol's
/// [`name_hash`], its occurrence index among the successor's modules of
/// that symbol, and its production's index among its group's alternatives.
#[inline]
pub const fn salt(symbol_name_hash: u32, occurrence: u32, alternative: u32) -> u32 {
    hash(symbol_name_hash, occurrence, alternative, SALT_TAG)
}

/// The key of a module written by a rewrite: MurmurHash3 x86_32 of the
/// 4-byte key `salt` with the parent's key as the seed.
#[inline]
pub const fn child_key(parent: u32, salt: u32) -> u32 {
    child_key_premixed(parent, premix(salt))
}

/// The half of [`child_key`] that depends on the salt alone (MurmurHash3's
/// block scramble), for engines that compute it once per successor module
/// instead of once per module written.
#[inline]
pub const fn premix(salt: u32) -> u32 {
    salt.wrapping_mul(0xcc9e_2d51)
        .rotate_left(15)
        .wrapping_mul(0x1b87_3593)
}

/// [`child_key`] from the salt's [`premix`]: the same value.
#[inline]
pub const fn child_key_premixed(parent: u32, premixed: u32) -> u32 {
    fmix(
        (parent ^ premixed)
            .rotate_left(13)
            .wrapping_mul(5)
            .wrapping_add(0xe654_6b64)
            ^ 4,
    )
}

/// The draw index of the `local`-th draw (from 1; 0 is unused) of the
/// group at `ordinal` among its symbol's groups (normal groups, then
/// wrap-up groups): `ordinal << 16 | local`. Indices are local to a group
/// so that adding a random call to one production moves no other
/// production's draws; the ordinal keeps two groups of one symbol (a
/// condition tried, then the next group) from sharing a number. The
/// axiom's draws are ordinal 0 with the root key.
#[inline]
pub const fn draw_index(ordinal: u32, local: u32) -> u32 {
    ordinal << 16 | local
}

/// The draw index of alternative `k`'s race draw in a stochastic group
/// (module documentation, "a race"): the high bit set, so it is never a
/// call site's [`draw_index`] (whose ordinal stays below `2^15`). `k` is
/// the alternative's index among its group's alternatives, so an edit of
/// one weight leaves every other alternative's draw as it was.
#[inline]
pub const fn choice_draw(k: u32) -> u32 {
    0x8000_0000 | k
}

/// `round(log2(1 + i / 256) * 65536)` for `i` in `0..=256`: the table
/// behind [`log2_fixed`]. The GPU kernels read this same table (packed
/// after the system's tables, [`crate::CompiledSystem::pack`]).
pub static LOG2_TABLE: [u32; 257] = [
    0, 369, 736, 1102, 1466, 1829, 2190, 2551, 2909, 3267, 3623, 3978, 4331, 4683, 5034, 5384,
    5732, 6079, 6425, 6769, 7112, 7454, 7795, 8134, 8473, 8810, 9146, 9480, 9814, 10146, 10477,
    10807, 11136, 11464, 11791, 12116, 12440, 12764, 13086, 13407, 13727, 14046, 14363, 14680,
    14996, 15310, 15624, 15937, 16248, 16559, 16868, 17177, 17484, 17791, 18096, 18401, 18704,
    19007, 19308, 19609, 19909, 20207, 20505, 20802, 21098, 21393, 21687, 21980, 22272, 22564,
    22854, 23144, 23433, 23720, 24007, 24293, 24579, 24863, 25146, 25429, 25711, 25992, 26272,
    26551, 26830, 27108, 27384, 27660, 27936, 28210, 28484, 28757, 29029, 29300, 29571, 29840,
    30109, 30378, 30645, 30912, 31178, 31443, 31707, 31971, 32234, 32496, 32758, 33019, 33279,
    33538, 33797, 34055, 34312, 34569, 34825, 35080, 35334, 35588, 35841, 36094, 36346, 36597,
    36847, 37097, 37346, 37595, 37842, 38090, 38336, 38582, 38827, 39072, 39316, 39559, 39802,
    40044, 40286, 40527, 40767, 41006, 41246, 41484, 41722, 41959, 42196, 42432, 42667, 42902,
    43137, 43370, 43603, 43836, 44068, 44300, 44530, 44761, 44990, 45220, 45448, 45676, 45904,
    46131, 46357, 46583, 46809, 47034, 47258, 47482, 47705, 47928, 48150, 48372, 48593, 48813,
    49034, 49253, 49472, 49691, 49909, 50127, 50344, 50560, 50776, 50992, 51207, 51422, 51636,
    51850, 52063, 52276, 52488, 52700, 52911, 53122, 53332, 53542, 53751, 53960, 54169, 54377,
    54584, 54791, 54998, 55204, 55410, 55615, 55820, 56025, 56229, 56432, 56635, 56838, 57040,
    57242, 57443, 57644, 57845, 58045, 58245, 58444, 58643, 58841, 59039, 59237, 59434, 59631,
    59827, 60023, 60219, 60414, 60609, 60803, 60997, 61190, 61384, 61576, 61769, 61961, 62152,
    62343, 62534, 62725, 62915, 63104, 63294, 63483, 63671, 63859, 64047, 64234, 64421, 64608,
    64794, 64980, 65166, 65351, 65536,
];

/// `log2(x / 2^31)` in 0.16 fixed point for `x` in `[2^31, 2^32)` (the top
/// bit set): the table entry below and linear interpolation on the next 16
/// bits, rounded. At most 65536.
#[inline]
pub fn log2_frac(x: u32) -> u32 {
    let i = ((x >> 23) & 0xff) as usize;
    let t = (x >> 7) & 0xffff;
    let (a, b) = (LOG2_TABLE[i], LOG2_TABLE[i + 1]);
    a + (((b - a) * t + 0x8000) >> 16)
}

/// `log2(v)` in 16.16 fixed point, for `v > 0` (0 for `v == 0`, which no
/// caller passes).
#[inline]
pub fn log2_fixed(v: u32) -> i32 {
    if v == 0 {
        return 0;
    }
    let n = 31 - v.leading_zeros();
    ((n << 16) + log2_frac(v << (31 - n))) as i32
}

/// An alternative's time in the race (module documentation): `-log2(u)`
/// in 16.16 fixed point for the draw `u = ((h >> 8) + 1) / 2^24` in
/// `(0, 1]`, an integer in `0 ..= 24 * 2^16` (0 when `u = 1`). The time
/// that the race compares is this over the alternative's weight.
#[inline]
pub fn race_time(h: u32) -> u32 {
    ((24 << 16) - log2_fixed((h >> 8) + 1)) as u32
}

/// Whether time `ta` at weight `wa` is strictly earlier than time `tb` at
/// weight `wb` (weights finite and positive): `ta / wa < tb / wb`, decided
/// exactly as `ta * wb < tb * wa`. Both products are exact in `f64` (at
/// most 21 + 24 significant bits, well inside its range), so this is the
/// exact comparison of the real numbers; the GPU decides the same exact
/// comparison on 64-bit integers built from `u32`s.
#[inline]
pub fn race_earlier(ta: u32, wa: f32, tb: u32, wb: f32) -> bool {
    f64::from(ta) * f64::from(wb) < f64::from(tb) * f64::from(wa)
}

/// MurmurHash3 x86_32 of the key `iteration, position, draw` (three
/// little-endian words) with `seed`. See the module documentation.
#[inline]
pub const fn hash(seed: u32, iteration: u32, position: u32, draw: u32) -> u32 {
    hash_finish(hash_prefix(seed, iteration, position), draw)
}

/// The part of [`hash`] that does not depend on the draw index, for
/// callers that take several draws of one module (the race).
#[inline]
pub const fn hash_prefix(seed: u32, iteration: u32, position: u32) -> u32 {
    mix(mix(seed, iteration), position)
}

/// [`hash`] from its [`hash_prefix`]: the same value.
#[inline]
pub const fn hash_finish(prefix: u32, draw: u32) -> u32 {
    fmix(mix(prefix, draw) ^ 12)
}

/// One MurmurHash3 block step.
#[inline]
const fn mix(h: u32, k: u32) -> u32 {
    let k = k
        .wrapping_mul(0xcc9e_2d51)
        .rotate_left(15)
        .wrapping_mul(0x1b87_3593);
    (h ^ k)
        .rotate_left(13)
        .wrapping_mul(5)
        .wrapping_add(0xe654_6b64)
}

/// The MurmurHash3 finalizer.
#[inline]
const fn fmix(mut h: u32) -> u32 {
    h ^= h >> 16;
    h = h.wrapping_mul(0x85eb_ca6b);
    h ^= h >> 13;
    h = h.wrapping_mul(0xc2b2_ae35);
    h ^ (h >> 16)
}

/// The uniform float of a hash: `f32(h >> 8) * 2^-24`, in `[0, 1)`.
#[inline]
pub fn unit(h: u32) -> f32 {
    (h >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// The uniform draw `u(seed, iteration, position, draw)` in `[0, 1)`.
#[inline]
pub fn uniform(seed: u32, iteration: u32, position: u32, draw: u32) -> f32 {
    unit(hash(seed, iteration, position, draw))
}

/// Where the draws of one module's rewrite come from: everything but the
/// draw index.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct DrawCtx {
    pub seed: u32,
    pub iteration: u32,
    /// The key of the module whose rewrite draws (see the module
    /// documentation; named `position` in the hash formula's history).
    pub position: u32,
}

impl DrawCtx {
    /// The hash behind draw `draw` (what [`race_time`] takes).
    #[inline]
    pub fn bits(&self, draw: u32) -> u32 {
        hash(self.seed, self.iteration, self.position, draw)
    }

    /// [`hash_prefix`] of this context: with [`hash_finish`], the hash of
    /// any of its draws.
    #[inline]
    pub fn prefix(&self) -> u32 {
        hash_prefix(self.seed, self.iteration, self.position)
    }

    /// The uniform draw with this index.
    #[inline]
    pub fn uniform(&self, draw: u32) -> f32 {
        uniform(self.seed, self.iteration, self.position, draw)
    }

    /// A standard normal deviate from draws `draw` and `draw + 1`
    /// (Box-Muller in f32).
    #[inline]
    pub fn standard_normal(&self, draw: u32) -> f32 {
        let u1 = self.uniform(draw);
        let u2 = self.uniform(draw.wrapping_add(1));
        (-2.0 * (1.0 - u1).ln()).sqrt() * (std::f32::consts::TAU * u2).cos()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Reference MurmurHash3 x86_32 over bytes, written independently of
    /// [`hash`], to check the word-key version against it and against
    /// published vectors.
    fn murmur3_bytes(key: &[u8], seed: u32) -> u32 {
        let mut h = seed;
        let mut chunks = key.chunks_exact(4);
        for c in &mut chunks {
            let k = u32::from_le_bytes([c[0], c[1], c[2], c[3]]);
            h = mix(h, k);
        }
        let tail = chunks.remainder();
        let mut k = 0u32;
        for (i, b) in tail.iter().enumerate() {
            k |= u32::from(*b) << (8 * i);
        }
        if !tail.is_empty() {
            k = k
                .wrapping_mul(0xcc9e_2d51)
                .rotate_left(15)
                .wrapping_mul(0x1b87_3593);
            h ^= k;
        }
        fmix(h ^ key.len() as u32)
    }

    #[test]
    fn murmur3_published_vectors() {
        assert_eq!(murmur3_bytes(b"", 0), 0);
        assert_eq!(murmur3_bytes(b"", 1), 0x514E_28B7);
        assert_eq!(murmur3_bytes(b"", 0xffff_ffff), 0x81F1_6F39);
        assert_eq!(murmur3_bytes(&[0, 0, 0, 0], 0), 0x2362_F9DE);
        assert_eq!(murmur3_bytes(b"aaaa", 0x9747_b28c), 0x5A97_808A);
        assert_eq!(murmur3_bytes(b"Hello, world!", 0x9747_b28c), 0x2488_4CBA);
        assert_eq!(
            murmur3_bytes(b"The quick brown fox jumps over the lazy dog", 0x9747_b28c),
            0x2FA8_26CD
        );
    }

    #[test]
    fn word_key_is_murmur3_of_twelve_bytes() {
        for (s, i, p, d) in [
            (0, 0, 0, 0),
            (7, 3, 12345, 1),
            (u32::MAX, 1, 2, 3),
            (42, 9, 0, 77),
        ] {
            let mut key = Vec::new();
            for w in [i, p, d] {
                key.extend_from_slice(&u32::to_le_bytes(w));
            }
            assert_eq!(hash(s, i, p, d), murmur3_bytes(&key, s));
        }
    }

    /// Frozen values: changing the hash changes every stochastic model.
    #[test]
    fn frozen_values() {
        assert_eq!(hash(0, 0, 0, 0), murmur3_bytes(&[0; 12], 0));
        let u = uniform(1, 1, 0, 0);
        assert!((0.0..1.0).contains(&u));
        assert_eq!(unit(0), 0.0);
        assert_eq!(unit(u32::MAX), 16_777_215.0 / 16_777_216.0);
    }

    #[test]
    fn uniform_is_roughly_uniform() {
        let n = 100_000u32;
        let mut buckets = [0u32; 10];
        let mut sum = 0.0f64;
        for p in 0..n {
            let u = uniform(7, 3, p, 0);
            buckets[(u * 10.0) as usize] += 1;
            sum += f64::from(u);
        }
        for b in buckets {
            assert!((9_500..10_500).contains(&b), "{buckets:?}");
        }
        assert!((sum / f64::from(n) - 0.5).abs() < 0.005);
    }

    #[test]
    fn draws_differ_by_each_coordinate() {
        let base = hash(1, 2, 3, 4);
        assert_ne!(base, hash(0, 2, 3, 4));
        assert_ne!(base, hash(1, 0, 3, 4));
        assert_ne!(base, hash(1, 2, 0, 4));
        assert_ne!(base, hash(1, 2, 3, 0));
    }

    #[test]
    fn name_hash_is_murmur3_of_the_bytes() {
        for name in ["", "F", "Fo", "Foo", "Tree", "Branch", "ω", "KochIsland"] {
            assert_eq!(name_hash(name), murmur3_bytes(name.as_bytes(), 0), "{name}");
        }
    }

    #[test]
    fn child_key_is_murmur3_of_the_salt() {
        for (p, s) in [(0, 0), (1, 2), (u32::MAX, 7), (0xdead_beef, 0x1234_5678)] {
            assert_eq!(child_key(p, s), murmur3_bytes(&s.to_le_bytes(), p));
            assert_eq!(child_key(p, s), fmix(mix(p, s) ^ 4));
        }
    }

    #[test]
    fn keys_differ_by_each_coordinate() {
        let f = name_hash("F");
        assert_ne!(f, name_hash("G"));
        assert_ne!(salt(f, 0, 0), salt(f, 1, 0));
        assert_ne!(salt(f, 0, 0), salt(f, 0, 1));
        assert_ne!(salt(f, 0, 0), salt(name_hash("G"), 0, 0));
        assert_ne!(root_key(1, f), root_key(2, f));
        assert_ne!(child_key(1, 5), child_key(2, 5));
        assert_ne!(child_key(1, 5), child_key(1, 6));
        assert_eq!(draw_index(0, 3), 3);
        assert_eq!(draw_index(2, 3), 0x2_0003);
    }

    #[test]
    fn normal_has_unit_variance() {
        let ctx = |p| DrawCtx {
            seed: 5,
            iteration: 1,
            position: p,
        };
        let n = 50_000u32;
        let (mut s, mut s2) = (0.0f64, 0.0f64);
        for p in 0..n {
            let z = f64::from(ctx(p).standard_normal(1));
            assert!(z.is_finite());
            s += z;
            s2 += z * z;
        }
        let mean = s / f64::from(n);
        let var = s2 / f64::from(n) - mean * mean;
        assert!(mean.abs() < 0.02, "mean {mean}");
        assert!((var - 1.0).abs() < 0.03, "var {var}");
    }

    #[test]
    fn log2_table_is_log2() {
        for (i, &t) in LOG2_TABLE.iter().enumerate() {
            let exact = (1.0 + i as f64 / 256.0).log2() * 65536.0;
            assert!(
                (f64::from(t) - exact).abs() <= 0.5,
                "entry {i}: {t} vs {exact}"
            );
        }
    }

    #[test]
    fn fixed_logarithms_are_within_a_unit() {
        let mut v = 1u64;
        while v < u64::from(u32::MAX) / 2 {
            for w in [v, v + 1, v * 3 / 2 + 7].map(|w| w as u32) {
                let exact = f64::from(w).log2() * 65536.0;
                let got = f64::from(log2_fixed(w));
                assert!((got - exact).abs() <= 1.5, "log2({w}): {got} vs {exact}");
            }
            v = v * 5 / 4 + 1;
        }
    }

    /// The race picks each alternative with probability weight / total.
    fn race(ctx: &DrawCtx, weights: &[f32]) -> usize {
        let mut best: Option<(u32, f32, usize)> = None;
        for (k, &w) in weights.iter().enumerate() {
            let t = race_time(ctx.bits(choice_draw(k as u32)));
            if best.is_none_or(|(bt, bw, _)| race_earlier(t, w, bt, bw)) {
                best = Some((t, w, k));
            }
        }
        best.map_or(0, |b| b.2)
    }

    #[test]
    fn race_comparisons_are_exact() {
        // Products that differ in the last of 45 bits, and weights at the
        // ends of the f32 range.
        let t = (24 << 16) - 1;
        let w = f32::from_bits(0x3fff_ffff);
        let w_next = f32::from_bits(0x4000_0000);
        assert!(race_earlier(t, w_next, t, w));
        assert!(!race_earlier(t, w, t, w));
        assert!(race_earlier(t - 1, w, t, w));
        assert!(race_earlier(0, 1e-45, 1, f32::MAX));
        assert!(!race_earlier(1, f32::MAX, 0, 1e-45));
        assert!(race_earlier(1, f32::MAX, 1_572_864, 1e-45));
        assert!(!race_earlier(1_572_864, 1e-45, 1, f32::MAX));
        assert_eq!(race_time(u32::MAX), 0);
        assert_eq!(race_time(0), 24 << 16);
    }

    #[test]
    fn the_race_draws_in_proportion_to_the_weights() {
        let weights = [1.0f32, 2.0, 3.0, 0.25, 1e-30];
        let total: f64 = weights.iter().map(|&w| f64::from(w)).sum();
        let n = 200_000u32;
        let mut counts = [0u32; 5];
        for p in 0..n {
            let ctx = DrawCtx {
                seed: 9,
                iteration: 3,
                position: p,
            };
            counts[race(&ctx, &weights)] += 1;
        }
        for (k, &c) in counts.iter().enumerate() {
            let expected = f64::from(n) * f64::from(weights[k]) / total;
            let sd = (expected * (1.0 - expected / f64::from(n))).sqrt().max(1.0);
            assert!(
                (f64::from(c) - expected).abs() < 5.0 * sd,
                "alternative {k}: {c} draws, {expected:.0} expected"
            );
        }
    }

    #[test]
    fn editing_one_weight_moves_choices_to_or_from_it_only() {
        let before = [1.0f32, 2.0, 3.0, 0.5];
        for (p, w) in [(1usize, 5.0f32), (1, 0.1), (3, 7.0), (0, 1e-3)] {
            let mut after = before;
            after[p] = w;
            let mut moved = 0;
            for key in 0..20_000u32 {
                let ctx = DrawCtx {
                    seed: 1,
                    iteration: 2,
                    position: key,
                };
                let (a, b) = (race(&ctx, &before), race(&ctx, &after));
                if a != b {
                    moved += 1;
                    assert!(a == p || b == p, "key {key}: {a} -> {b}, edited {p}");
                }
            }
            assert!(moved > 0, "editing alternative {p} moved nothing");
        }
    }
}

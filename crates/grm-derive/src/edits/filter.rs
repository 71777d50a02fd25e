//! The key filter of an edit plan: two bits per key in one 32-bit word
//! (a blocked Bloom filter: the word from the key's bits 5-15, the bits
//! from its bits 0-4 and 16-20), set for every key with edits, so that a
//! module whose key has none is told apart without the map. Tested eight
//! keys at a time: with AVX2 one gather of the filter's words per eight
//! keys, else a branch-free OR of the eight tests; the map is asked only
//! where both bits are set (about 0.1% of the keys with 1,000 keys in the
//! plan; one bit per key passed 1.5%).

/// Bits of the filter (a power of two).
pub(super) const FILTER_BITS: usize = 1 << 16;

/// The filter's 32-bit words.
const WORDS: usize = FILTER_BITS / 32;

#[derive(Clone, Debug)]
pub(super) struct KeyFilter {
    words: Box<[u32; WORDS]>,
    /// The CPU has AVX2 (the gathers).
    avx2: bool,
}

impl KeyFilter {
    pub(super) fn new() -> KeyFilter {
        #[cfg(target_arch = "x86_64")]
        let avx2 = crate::cpu::avx2();
        #[cfg(not(target_arch = "x86_64"))]
        let avx2 = false;
        KeyFilter {
            words: Box::new([0; WORDS]),
            avx2,
        }
    }

    pub(super) fn insert(&mut self, key: u32) {
        let w = (key as usize >> 5) % WORDS;
        self.words[w] |= (1 << (key % 32)) | (1 << ((key >> 16) % 32));
    }

    /// 1 where `key` may have edits (both its bits set), else 0.
    #[inline(always)]
    fn bit(&self, key: u32) -> u32 {
        // In bounds by construction: no check in the loops that call it.
        let w = self.words[(key as usize >> 5) % WORDS];
        (w >> (key % 32)) & (w >> ((key >> 16) % 32)) & 1
    }

    /// Whether `key` may have edits.
    #[inline(always)]
    pub(super) fn maybe(&self, key: u32) -> bool {
        self.bit(key) != 0
    }

    /// Whether any key of `keys` may have edits.
    #[inline(always)]
    pub(super) fn any(&self, keys: &[u32]) -> bool {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 && keys.len() >= 8 {
            // SAFETY: the CPU has AVX2 (`new` checked it).
            #[allow(unsafe_code)]
            return unsafe { self.any_avx2(keys) };
        }
        keys.iter().fold(0, |a, &k| a | self.bit(k)) != 0
    }

    /// `hit(j)` for every `j` whose `keys[j]` may have edits, in order.
    pub(super) fn scan(&self, keys: &[u32], mut hit: impl FnMut(usize)) {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: the CPU has AVX2 (`new` checked it).
            #[allow(unsafe_code)]
            unsafe {
                self.scan_avx2(keys, &mut hit)
            };
            return;
        }
        let mut blocks = keys.chunks_exact(8);
        let mut at = 0;
        for block in &mut blocks {
            if block.iter().fold(0, |a, &k| a | self.bit(k)) != 0 {
                self.scan_one(block, at, &mut hit);
            }
            at += 8;
        }
        self.scan_one(blocks.remainder(), at, &mut hit);
    }

    #[inline(always)]
    fn scan_one(&self, keys: &[u32], at: usize, hit: &mut impl FnMut(usize)) {
        for (j, &k) in keys.iter().enumerate() {
            if self.maybe(k) {
                hit(at + j);
            }
        }
    }

    /// The filter's tests of the eight keys at `keys[at..at + 8]` (in
    /// bounds: the callers' loops): 1 in a lane whose key may have edits,
    /// else 0.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline]
    fn test8(&self, keys: &[u32], at: usize) -> std::arch::x86_64::__m256i {
        use std::arch::x86_64::*;
        let eight: &[u32; 8] = keys[at..at + 8].try_into().unwrap_or(&[0; 8]);
        // SAFETY: `eight` is 32 readable bytes (an unaligned load); every
        // gathered index is below `WORDS` (masked), inside `words`.
        #[allow(unsafe_code)]
        unsafe {
            let k = _mm256_loadu_si256(eight.as_ptr().cast());
            let idx = _mm256_and_si256(
                _mm256_srli_epi32::<5>(k),
                _mm256_set1_epi32(WORDS as i32 - 1),
            );
            let w = _mm256_i32gather_epi32::<4>(self.words.as_ptr().cast(), idx);
            let low = _mm256_and_si256(k, _mm256_set1_epi32(31));
            let high = _mm256_and_si256(_mm256_srli_epi32::<16>(k), _mm256_set1_epi32(31));
            let both = _mm256_and_si256(_mm256_srlv_epi32(w, low), _mm256_srlv_epi32(w, high));
            _mm256_and_si256(both, _mm256_set1_epi32(1))
        }
    }

    /// [`KeyFilter::any`] for eight keys or more: blocks of eight, the
    /// last one overlapping the one before.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn any_avx2(&self, keys: &[u32]) -> bool {
        use std::arch::x86_64::*;
        let n = keys.len();
        let mut acc = _mm256_setzero_si256();
        let mut at = 0;
        while at + 8 < n {
            acc = _mm256_or_si256(acc, self.test8(keys, at));
            at += 8;
        }
        acc = _mm256_or_si256(acc, self.test8(keys, n - 8));
        _mm256_testz_si256(acc, acc) == 0
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn scan_avx2(&self, keys: &[u32], hit: &mut impl FnMut(usize)) {
        use std::arch::x86_64::*;
        let n = keys.len();
        let mut at = 0;
        while at + 8 <= n {
            let m = self.test8(keys, at);
            if _mm256_testz_si256(m, m) == 0 {
                let zero = _mm256_cmpeq_epi32(m, _mm256_setzero_si256());
                let mut lanes = !(_mm256_movemask_ps(_mm256_castsi256_ps(zero)) as u32) & 0xff;
                while lanes != 0 {
                    hit(at + lanes.trailing_zeros() as usize);
                    lanes &= lanes - 1;
                }
            }
            at += 8;
        }
        self.scan_one(&keys[at..], at, hit);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The vector roads find the same keys as the bit-by-bit test, for
    /// every length around the blocks of eight.
    #[test]
    fn vector_and_scalar_agree() {
        let mut f = KeyFilter::new();
        let mut x = 0x1234_5678u32;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            x
        };
        for _ in 0..12000 {
            f.insert(next());
        }
        let keys: Vec<u32> = (0..300).map(|_| next()).collect();
        let expect: Vec<usize> = (0..keys.len()).filter(|&j| f.maybe(keys[j])).collect();
        assert!(!expect.is_empty() && expect.len() < keys.len());
        for len in 0..40 {
            for start in [0, 3, 17] {
                let ks = &keys[start..start + len];
                let mut got = Vec::new();
                f.scan(ks, |j| got.push(j));
                let want: Vec<usize> = (0..len).filter(|&j| f.maybe(ks[j])).collect();
                assert_eq!(got, want, "scan of {len} keys at {start}");
                assert_eq!(f.any(ks), !want.is_empty(), "any of {len} keys at {start}");
                let mut plain = f.clone();
                plain.avx2 = false;
                let mut got = Vec::new();
                plain.scan(ks, |j| got.push(j));
                assert_eq!(got, want);
                assert_eq!(plain.any(ks), !want.is_empty());
            }
        }
        let mut got = Vec::new();
        f.scan(&keys, |j| got.push(j));
        assert_eq!(got, expect);
    }
}

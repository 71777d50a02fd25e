//! Fans: a successor whose every stored word is one arithmetic patch of
//! the same binding word.
//!
//! `F(x) -> F(x * p) + F(x * h) - - F(x * h) + F(x * q)` (the row of
//! trees), `F(l) -> F(l * r) [ + F(l * s) ]`: the successor's words are
//! `x * m[j] + a[j]` for one input word `x` and per-word constants (the
//! forms of [`Patch::Arith`](crate::engine): `x * k`, `x + k`, `x - k`).
//! The rewrite computes all `PAD` lanes at once, a multiply and an add the
//! compiler turns into a few vector instructions (no fused multiply-add,
//! so the same single rounding per word as the VM and the GPU), and tests
//! finiteness with one mask instead of a loop over the patches.

use crate::engine::{PAD, Plan};

/// One alternative's fan (see the module doc); lanes past its words have
/// `m = a = 0` and are not tested.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Fan {
    pub(crate) plan: Plan,
    /// The binding word every patch reads.
    pub(crate) src: u32,
    m: [f32; PAD],
    a: [f32; PAD],
    /// All ones on the successor's words, zero past them.
    live: [u32; PAD],
}

impl Fan {
    /// The fan of `plan` when every one of its `plan.words` stored words
    /// (at most `PAD`) is exactly one of `patches`, each `(dst, src, m,
    /// a)` reading the same `src` (below `bind_words`), with at most `PAD`
    /// successor modules; `None` otherwise.
    pub(crate) fn of(
        plan: Plan,
        patches: impl Iterator<Item = Option<(u32, u32, f32, f32)>>,
        bind_words: u32,
    ) -> Option<Fan> {
        let words = plan.words as usize;
        if words == 0 || words > PAD || plan.len as usize > PAD {
            return None;
        }
        let mut fan = Fan {
            plan,
            src: u32::MAX,
            m: [0.0; PAD],
            a: [0.0; PAD],
            live: [0; PAD],
        };
        for p in patches {
            let (dst, src, m, a) = p?;
            let d = dst as usize;
            if d >= words || fan.live[d] != 0 || src >= bind_words {
                return None;
            }
            if fan.src != u32::MAX && fan.src != src {
                return None;
            }
            fan.src = src;
            fan.m[d] = m;
            fan.a[d] = a;
            fan.live[d] = u32::MAX;
        }
        // Every word patched (no constant among them).
        fan.live[..words].iter().all(|&l| l != 0).then_some(fan)
    }

    /// The successor's words (`PAD` lanes, those past its words zero for
    /// a finite `x`) and whether one of its words is not finite.
    #[inline(always)]
    pub(crate) fn apply(&self, x: f32) -> ([f32; PAD], bool) {
        let mut v = [0.0f32; PAD];
        let mut bad = 0u32;
        for (((y, &m), &a), &live) in v.iter_mut().zip(&self.m).zip(&self.a).zip(&self.live) {
            *y = x * m + a;
            // Bit 31 set where a value is not finite: its exponent is all
            // ones, and one more carries into bit 31.
            bad |= ((y.to_bits() & 0x7f80_0000) + 0x0080_0000) & live;
        }
        (v, bad & 0x8000_0000 != 0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan(len: u32, words: u32) -> Plan {
        Plan {
            len,
            words,
            ..Plan::default()
        }
    }

    #[test]
    fn a_fan_is_the_same_single_rounding_per_word() {
        let p = [
            Some((0, 0, 0.3f32, -0.0f32)),
            Some((1, 0, 0.458_257_56, -0.0)),
            Some((2, 0, 2.0, 0.25)),
            Some((3, 0, 1.0, -0.7)),
        ];
        let fan = Fan::of(plan(7, 4), p.into_iter(), 1).expect("a fan");
        for x in [1.0f32, -0.0, 0.0, 3.3e-39, 1.0e38, -2.5] {
            let (v, bad) = fan.apply(x);
            assert!(!bad, "{x}");
            for (j, &(_, _, m, a)) in p.iter().flatten().enumerate() {
                assert_eq!(v[j].to_bits(), (x * m + a).to_bits(), "{x} word {j}");
            }
            assert!(v[4..].iter().all(|&y| y == 0.0));
        }
        // Overflow in one word is caught, lanes past the words never.
        assert!(fan.apply(f32::MAX).1);
        assert!(fan.apply(f32::NAN).1);
    }

    #[test]
    fn only_a_successor_of_one_source_patched_everywhere_is_a_fan() {
        let one = |d, s| Some((d, s, 2.0f32, -0.0f32));
        assert!(Fan::of(plan(2, 2), [one(0, 1), one(1, 1)].into_iter(), 2).is_some());
        // Two sources.
        assert!(Fan::of(plan(2, 2), [one(0, 0), one(1, 1)].into_iter(), 2).is_none());
        // A constant word (word 1 unpatched).
        assert!(Fan::of(plan(2, 2), [one(0, 0)].into_iter(), 1).is_none());
        // A word patched twice, a source out of range, a non-arithmetic
        // patch, too many words.
        assert!(Fan::of(plan(2, 2), [one(0, 0), one(0, 0)].into_iter(), 1).is_none());
        assert!(Fan::of(plan(1, 1), [one(0, 1)].into_iter(), 1).is_none());
        assert!(Fan::of(plan(1, 1), [None].into_iter(), 1).is_none());
        let many = (0..9).map(|d| one(d, 0));
        assert!(Fan::of(plan(9, 9), many, 1).is_none());
    }
}

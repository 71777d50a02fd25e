//! Chunk counts from carried histograms: a parallel step without a count
//! pass.
//!
//! Where no symbol needs a decision (the engine's `succ_hist` case), a
//! chunk's output length is the sum of its modules' successor lengths,
//! known per symbol: the chunk's symbol histogram gives its counts (output
//! modules, stored and implicit words, the input words it walks) with one
//! multiply-add per symbol instead of a table lookup per module. And the
//! histogram of the chunk's output is the input's times the successor
//! table (`succ_hist`), so the next step's chunks are the images of this
//! step's (chunk `i`'s output is the next string's range `offsets[i] ..
//! offsets[i + 1]`), their histograms known without reading the string.
//! The chunks are split afresh (one histogram pass over the string, in
//! parallel, what the count pass cost) only when the images would not
//! balance the threads: fewer chunks than [`Engine::chunks`] asks for,
//! more than twice as many, or one over twice the mean length.

use std::ops::Range;

use rayon::prelude::*;

use crate::engine::Engine;

/// One chunk's counts: output modules, stored output words, implicit
/// output words, stored input words.
pub(crate) type Counts = (u64, u64, u64, u64);

/// The chunking of the string a step produced, with each chunk's symbol
/// histogram: what the next step counts from.
#[derive(Debug, Default)]
pub(crate) struct Carried {
    chunks: Vec<Range<usize>>,
    hists: Vec<Vec<u64>>,
}

impl Engine<'_> {
    /// The chunks of an input of `n` modules and their counts from
    /// histograms (carried from the previous step when they balance,
    /// else from one histogram pass over `syms`); `carried` is advanced to
    /// the output's chunks. `None` where a symbol needs a decision.
    pub(crate) fn counts_carried(
        &self,
        syms: &[u32],
        carried: &mut Carried,
    ) -> Option<(Vec<Range<usize>>, Vec<Counts>)> {
        let succ = self.succ_hist.as_ref()?;
        let n = syms.len();
        let want = self.chunks(n);
        if !carried.fits(n, want.len()) {
            carried.hists = self.in_pool(|| {
                want.par_iter()
                    .map(|r| histogram(&syms[r.clone()], self.sym_words.len()))
                    .collect()
            });
            carried.chunks = want;
        }
        let compact = self.compact();
        let mut counts = Vec::with_capacity(carried.chunks.len());
        let mut next_chunks = Vec::with_capacity(carried.chunks.len());
        let mut next_hists = Vec::with_capacity(carried.chunks.len());
        let mut at = 0usize;
        for h in &carried.hists {
            let ((m, w, iw, wi), next) = self.image(h, succ, compact);
            counts.push((m, w, iw, wi));
            // Past `usize` only beyond the limits, which the caller checks
            // before anything is written; the chunks are then dropped.
            let len = usize::try_from(m).unwrap_or(usize::MAX);
            next_chunks.push(at..at.saturating_add(len));
            at = at.saturating_add(len);
            next_hists.push(next);
        }
        let chunks = std::mem::replace(&mut carried.chunks, next_chunks);
        carried.hists = next_hists;
        Some((chunks, counts))
    }
}

impl Engine<'_> {
    /// The counts of a string whose symbol histogram is `h` (output
    /// modules, stored and, with `implicit`, implicit output words, stored
    /// input words), and the histogram of its output (`succ`: the
    /// engine's `succ_hist`): one multiply-add per symbol.
    pub(crate) fn image(
        &self,
        h: &[u64],
        succ: &[Vec<(u32, u64)>],
        implicit: bool,
    ) -> (Counts, Vec<u64>) {
        let (mut m, mut w, mut iw, mut wi) = (0u64, 0u64, 0u64, 0u64);
        let mut next = vec![0u64; h.len()];
        for (s, &c) in h.iter().enumerate() {
            if c == 0 {
                continue;
            }
            let (_, len, words) = self.counts[s];
            m += c * u64::from(len);
            w += c * u64::from(words);
            if implicit {
                iw += c * u64::from(self.implicit_words_of(s));
            }
            wi += c * u64::from(self.sym_words[s]);
            for &(t, k) in &succ[s] {
                next[t as usize] += c * k;
            }
        }
        ((m, w, iw, wi), next)
    }
}

impl Carried {
    /// Whether the carried chunks cover `0..n` and balance: between
    /// `want` and `2 * want` of them, none longer than twice the mean.
    fn fits(&self, n: usize, want: usize) -> bool {
        let k = self.chunks.len();
        if k < want.max(2) || k > 2 * want || self.chunks.last().map(|r| r.end) != Some(n) {
            return false;
        }
        let longest = self.chunks.iter().map(|r| r.len()).max().unwrap_or(0);
        longest <= 2 * n.div_ceil(k)
    }
}

/// The symbol histogram of `syms` (`symbols` entries). Four partial
/// histograms, so a run of one symbol does not wait on its own previous
/// increment.
fn histogram(syms: &[u32], symbols: usize) -> Vec<u64> {
    let mut part = vec![[0u32; 4]; symbols];
    let mut quads = syms.chunks_exact(4);
    for q in &mut quads {
        for (lane, &s) in q.iter().enumerate() {
            if let Some(p) = part.get_mut(s as usize) {
                p[lane] += 1;
            }
        }
    }
    for &s in quads.remainder() {
        if let Some(p) = part.get_mut(s as usize) {
            p[0] += 1;
        }
    }
    part.iter()
        .map(|p| p.iter().map(|&c| u64::from(c)).sum())
        .collect()
}

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
//!
//! What is carried is finer than what runs: [`FINE`] pieces for each of
//! the most chunks a step runs (`Engine::most_chunks`, a few per thread),
//! grouped each step into the chunks [`Engine::chunks`] asks for, contiguous
//! and of about equal input length. A step's
//! pieces are the images of the last one's, so the string is split with a
//! histogram pass (in parallel) only at the first step on several chunks,
//! and again only when the images would not balance: fewer pieces than
//! chunks, or one longer than a chunk's share (one symbol grows much faster
//! than the others). Before, the carried chunks were the chunks that ran,
//! which the short scenes' first parallel step (the shortest chunks, 8192
//! modules) left too few and too long for the next: Hilbert 3D's last step
//! split its input afresh.

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

/// Carried pieces for each of the most chunks a step runs.
const FINE: usize = 4;

impl Engine<'_> {
    /// The chunks of an input of `n` modules and their counts from
    /// histograms (carried from the previous step when they balance,
    /// else from one histogram pass over `syms`); `carried` is advanced to
    /// the output's pieces. `None` where a symbol needs a decision.
    pub(crate) fn counts_carried(
        &self,
        syms: &[u32],
        carried: &mut Carried,
    ) -> Option<(Vec<Range<usize>>, Vec<Counts>)> {
        let succ = self.succ_hist.as_ref()?;
        let n = syms.len();
        let want = self.chunks(n).len();
        if !carried.fits(n, want) {
            let k = self.most_chunks() * FINE;
            let len = n.div_ceil(k).max(1);
            let pieces: Vec<Range<usize>> = (0..n.div_ceil(len))
                .map(|c| c * len..((c + 1) * len).min(n))
                .collect();
            carried.hists = self.in_pool(|| {
                pieces
                    .par_iter()
                    .map(|r| histogram(&syms[r.clone()], self.sym_words.len()))
                    .collect()
            });
            carried.chunks = pieces;
        }
        let compact = self.compact();
        let k = carried.chunks.len();
        let mut next_chunks = Vec::with_capacity(k);
        let mut next_hists = Vec::with_capacity(k);
        // Pieces grouped into chunks: chunk `j - 1` ends at the first
        // piece boundary at or past `j * n / want`.
        let mut chunks = Vec::with_capacity(want);
        let mut counts: Vec<Counts> = Vec::with_capacity(want);
        let (mut at, mut from) = (0usize, 0usize);
        let mut sum = (0u64, 0u64, 0u64, 0u64);
        let mut j = 1usize;
        // `j * n / want` without overflow where `usize` is 32 bits.
        let bound = |j: usize| (j as u64 * n as u64 / want as u64) as usize;
        for (r, h) in carried.chunks.iter().zip(&carried.hists) {
            let ((m, w, iw, wi), next) = self.image(h, succ, compact);
            sum = (sum.0 + m, sum.1 + w, sum.2 + iw, sum.3 + wi);
            // Past `usize` only beyond the limits, which the caller checks
            // before anything is written; the pieces are then dropped.
            let len = usize::try_from(m).unwrap_or(usize::MAX);
            next_chunks.push(at..at.saturating_add(len));
            at = at.saturating_add(len);
            next_hists.push(next);
            // (An empty piece closes nothing: no chunk is empty.)
            if r.end > from && (r.end == n || r.end >= bound(j)) {
                chunks.push(from..r.end);
                counts.push(sum);
                sum = (0, 0, 0, 0);
                from = r.end;
                while bound(j) <= r.end && j < want {
                    j += 1;
                }
            }
        }
        carried.chunks = next_chunks;
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
    /// Whether the carried pieces cover `0..n` and group into `want`
    /// balanced chunks: at least `want` of them, none longer than a
    /// chunk's share.
    fn fits(&self, n: usize, want: usize) -> bool {
        if self.chunks.len() < want.max(2) || self.chunks.last().map(|r| r.end) != Some(n) {
            return false;
        }
        let longest = self.chunks.iter().map(|r| r.len()).max().unwrap_or(0);
        longest <= n.div_ceil(want)
    }
}

/// The symbol histogram of `syms` (`symbols` entries). Four partial
/// histograms, so a run of one symbol does not wait on its own previous
/// increment.
pub(crate) fn histogram(syms: &[u32], symbols: usize) -> Vec<u64> {
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

//! A derivation's remaining steps as one fork and one join.
//!
//! Where no symbol needs a decision (the engine's `succ_hist` case), what
//! a module becomes in every following step depends on its symbol alone:
//! a piece of a string can be derived on its own through all the steps
//! that remain, its length and words at each step are the images of its
//! symbol histogram (times the per-engine table [`Response`]), and its
//! last string belongs at the offset where the pieces before it end. So
//! `Engine::derive` cuts the string once into pieces of equal length (16
//! per thread, up to 32 steps a fork) and runs them all at once: the calling
//! thread and one spawned task per other thread take pieces, the most
//! work first, each deriving its pieces' intermediate strings in two
//! buffers of its own and writing the last step straight into its slice
//! of the shared output. That is one fork and one join for the whole
//! derivation, where the step-by-step road (`step.rs`) forks and joins
//! once per phase of every step; and the caller works instead of
//! sleeping, so the fork costs one worker's wake-up, overlapped with the
//! caller's own share.
//!
//! Every piece is rewritten by the same loop (`rewrite_chunk`), module by
//! module with the same arithmetic, and its output lands where the whole
//! string's rewrite would have put it: the result is bit-identical for
//! every thread count and piece size. The limits are checked for every
//! step from the histograms before anything is allocated (a step over
//! them is left to the step-by-step road, which reports it); the first
//! runtime error is the one of the earliest step at the lowest position,
//! as on the step-by-step road.

use std::sync::Mutex;
use std::sync::atomic::{AtomicU32, AtomicUsize, Ordering};

use super::*;
use crate::expand::{Counts, histogram};

/// Pieces per thread: enough for the most-work-first order to balance
/// pieces that grow unevenly.
const PIECES_PER_THREAD: usize = 16;

/// The most pieces a fork cuts (a pool of hundreds of threads gets fewer
/// than [`PIECES_PER_THREAD`] each: every piece keeps its counts per step).
const MAX_PIECES: usize = 4096;

/// The most steps one fork runs (each piece keeps its counts per step).
const MAX_FORK_STEPS: u32 = 32;

/// A string shorter than two `min_chunk`s (where the step-by-step road
/// goes parallel) is forked only when the fork's steps produce at least
/// this many `min_chunk`s of modules: less work does not pay for waking a
/// worker.
const FORK_WORK: u64 = 16;

/// Of a fork not yet forced by the string's length, how many steps ahead
/// its work is looked for.
const LOOK_AHEAD: u32 = 8;

/// The steps `first ..= last` of a derivation, planned.
pub(super) struct Fork {
    first: u32,
    last: u32,
    pieces: Vec<Piece>,
    /// Piece indices, the most work first.
    order: Vec<usize>,
    /// Per step: the string's counts (output modules, stored words,
    /// implicit words, stored input words).
    totals: Vec<Counts>,
    /// The symbol histogram of the last step's string, where more steps
    /// follow.
    hist: Option<Vec<u64>>,
}

impl Fork {
    /// The most modules and stored words of a piece's intermediate
    /// string, and whether any such string keeps starts.
    fn scratch_size(&self, e: &Engine<'_>) -> (usize, usize, bool) {
        let inner = self.totals.len() - 1;
        let (mut m, mut w) = (0u64, 0u64);
        for p in &self.pieces {
            for c in &p.counts[..inner] {
                m = m.max(c.0);
                w = w.max(c.1);
            }
        }
        let starts = self.totals[..inner].iter().any(|c| e.keeps_starts(c.1));
        (m as usize, w as usize, starts)
    }
}

/// A piece of the fork's input string and its counts.
struct Piece {
    range: Range<usize>,
    /// Where its stored words begin in the input.
    word_in: usize,
    /// Per step of the fork, the piece's counts.
    counts: Vec<Counts>,
    /// The modules it produces over the fork.
    work: u64,
}

/// What a piece stopped at: the step (from the fork's first) and the
/// error, its position the step's input's.
type PieceError = (usize, RuntimeError);

/// Two strings a thread derives its pieces' steps in, ping-pong.
pub(crate) type Scratch = [ModuleString; 2];

/// Resize `v` to at least `n` elements: longer is left long (what lies
/// past a piece's string is never read but by the rewrite's fixed-size
/// look-ahead, whose words the following modules overwrite), so a thread's
/// buffers are zeroed only where they grow.
fn grow<T: Copy + Default>(v: &mut Vec<T>, n: usize) {
    if v.len() < n {
        fit(v, n);
    }
}

impl Engine<'_> {
    /// The threads a fork runs on: the caller and the pool's other
    /// workers.
    pub(super) fn participants(&self) -> usize {
        match self.threads {
            0 => rayon::current_num_threads(),
            t => t,
        }
    }

    /// The fork of `run`'s next steps, or `None` where the derivation does
    /// not fork here: a symbol needs a decision, one thread, a string too
    /// short to be worth it (under two `min_chunk`s, whose steps ahead
    /// produce less than [`FORK_WORK`] `min_chunk`s or whose pieces would
    /// not balance), or a step over the limits (the step-by-step road
    /// reports it, after the steps before it).
    pub(super) fn fork_plan(&self, run: &Run, opts: &DeriveOptions) -> Option<Fork> {
        let succ = self.succ_hist.as_ref()?;
        let hist = run.hist.as_ref()?;
        let threads = self.participants();
        let input = &run.string;
        let n = input.len();
        if threads < 2 || n < 2 {
            return None;
        }
        let forced = self.chunks(n).len() > 1;
        if !forced && (n < 2 * threads || n <= run.declined) {
            return None;
        }
        let first = run.iteration;
        let last = opts
            .iterations
            .min(first.saturating_add(MAX_FORK_STEPS - 1));
        let steps = (last - first + 1) as usize;
        let mut response = self.response.lock().unwrap_or_else(|p| p.into_inner());
        response.extend(self, succ, steps);
        let rows = &response.rows[..steps];
        // Every step's counts from the string's histogram, checked against
        // the limits (the input's bytes: the fork's input as it is, then
        // each string as this engine's `take` lays it out).
        let mut totals = Vec::with_capacity(steps);
        let mut in_bytes = input.heap_bytes() as u64;
        let mut work = 0u64;
        let enough = FORK_WORK.saturating_mul(self.min_chunk as u64);
        for (k, row) in rows.iter().enumerate() {
            let c = counts_of(hist, row);
            let t = first + k as u32;
            self.check_limits_bytes(in_bytes, t, c.0, c.1, &opts.limits)
                .ok()?;
            in_bytes = self.string_bytes(c.0, c.1);
            work = work.saturating_add(c.0);
            totals.push(c);
            if !forced && k as u32 + 1 >= LOOK_AHEAD && work < enough {
                return None;
            }
        }
        if !forced && work < enough {
            return None;
        }
        // The pieces: equal input lengths, each one's counts per step.
        let k = (threads * PIECES_PER_THREAD).min(MAX_PIECES).min(n);
        let len = n.div_ceil(k);
        let walks = input.walks();
        let mut pieces = Vec::with_capacity(k);
        let mut words = 0usize;
        for c in 0..n.div_ceil(len) {
            let range = c * len..((c + 1) * len).min(n);
            let h = piece_histogram(&input.syms[range.clone()], self.sym_words.len());
            let word_in = if walks {
                words
            } else {
                input.start(range.start)
            };
            let counts: Vec<Counts> = rows.iter().map(|row| counts_of(&h, row)).collect();
            words += counts[0].3 as usize;
            let work = counts.iter().fold(0u64, |a, c| a.saturating_add(c.0));
            pieces.push(Piece {
                range,
                word_in,
                counts,
                work,
            });
        }
        drop(response);
        let mut order: Vec<usize> = (0..pieces.len()).collect();
        order.sort_by_key(|&i| std::cmp::Reverse(pieces[i].work));
        if !forced {
            // Balanced: no piece holds more than a quarter of a thread's
            // share (so a worker that wakes late still finds enough left to
            // even out: Koch's first string, four `F`s, forks one step
            // later), and the most work first onto the least loaded thread
            // ends within a tenth of an even share.
            let largest = order.first().map_or(0, |&i| pieces[i].work);
            if largest.saturating_mul(4 * threads as u64) > work {
                return None;
            }
            let mut load = vec![0u64; threads];
            for &i in &order {
                if let Some(l) = load.iter_mut().min() {
                    *l = l.saturating_add(pieces[i].work);
                }
            }
            let span = load.iter().copied().max().unwrap_or(0);
            if span.saturating_mul(threads as u64 * 10) > work.saturating_mul(11) {
                return None;
            }
        }
        // The histogram after the fork, where more steps follow it.
        let hist = (last < opts.iterations).then(|| {
            let mut h = hist.clone();
            for _ in 0..steps {
                h = self.image(&h, succ, true).1;
            }
            h
        });
        Some(Fork {
            first,
            last,
            pieces,
            order,
            totals,
            hist,
        })
    }

    /// Run fork `f` over `run` (begun at `began`): its steps' figures go to
    /// `progress` (after the join, in order), its last string becomes
    /// `run`'s.
    pub(super) fn run_fork(
        &self,
        run: &mut Run,
        opts: &DeriveOptions,
        f: Fork,
        began: Instant,
        progress: &mut dyn FnMut(&IterationStats),
    ) -> Result<(), DeriveError> {
        let steps = f.totals.len();
        let (m, w, iw, _) = f.totals[steps - 1];
        let (m, w) = (m as usize, w as usize);
        let mut out = self.take(m, w);
        out.implicit_words = iw as usize;
        let errors: Mutex<Vec<(usize, PieceError)>> = Mutex::new(Vec::new());
        {
            // Each piece's slice of the output, in string order.
            let with_starts = !out.starts.is_empty();
            let (mut syms, mut starts, mut params, mut keys) = out.parts_mut(m);
            let mut slots = Vec::with_capacity(f.pieces.len());
            let mut word_base = 0u32;
            for p in &f.pieces {
                let (cm, cw) = (
                    p.counts[steps - 1].0 as usize,
                    p.counts[steps - 1].1 as usize,
                );
                let (s, rest) = syms.split_at_mut(cm);
                syms = rest;
                let (k, rest) = keys.split_at_mut(if self.keyed { cm } else { 0 });
                keys = rest;
                let (st, rest) = starts.split_at_mut(if with_starts { cm } else { 0 });
                starts = rest;
                let (pw, rest) = params.split_at_mut(cw);
                params = rest;
                slots.push(Mutex::new(Some(ChunkOut {
                    range: 0..0,
                    syms: s,
                    keys: k,
                    starts: st,
                    params: pw,
                    word_base,
                    word_in: 0,
                })));
                word_base += cw as u32;
            }
            let next = AtomicUsize::new(0);
            let fail = AtomicU32::new(u32::MAX);
            let input = &run.string;
            // Each thread's buffers sized once for the longest intermediate
            // string of any piece (grown piece by piece, they were
            // allocated again and again, each time in fresh pages).
            let (sm, sw, sstarts) = f.scratch_size(self);
            let body = || {
                let mut bufs = self.take_scratch();
                for b in &mut bufs {
                    grow(&mut b.syms, sm);
                    if self.keyed {
                        grow(&mut b.keys, sm);
                    }
                    if sstarts {
                        grow(&mut b.starts, sm + 1);
                    }
                    if sw > 0 {
                        grow(&mut b.params, sw);
                    }
                }
                while let Some(&p) = f.order.get(next.fetch_add(1, Ordering::Relaxed)) {
                    let slot = slots[p].lock().unwrap_or_else(|e| e.into_inner()).take();
                    let Some(out) = slot else { continue };
                    let ctx = (&f, input, opts.seed, &fail);
                    if let Err((k, e)) = self.run_piece(ctx, p, out, &mut bufs) {
                        fail.fetch_min(f.first + k as u32, Ordering::Relaxed);
                        let mut errs = errors.lock().unwrap_or_else(|e| e.into_inner());
                        errs.push((p, (k, e)));
                    }
                }
                self.give_scratch(bufs);
            };
            let body = &body;
            let helpers = threads_for(self.participants(), f.pieces.len()) - 1;
            // The caller takes pieces too; a spawned task that starts after
            // the last piece is taken ends at once. (`in_place_scope` is a
            // method of a pool and a free function for the global one; a
            // caller that is itself a rayon worker waits for the spawned
            // tasks by running them or other jobs, never blocking.)
            macro_rules! fork {
                () => {
                    |scope| {
                        for _ in 0..helpers {
                            scope.spawn(move |_| body());
                        }
                        body();
                    }
                };
            }
            match &self.pool {
                Some(p) => p.in_place_scope(fork!()),
                None => rayon::in_place_scope(fork!()),
            }
        }
        // The first error: the earliest step's, at the lowest position of
        // that step's input (a piece's own positions shifted by the pieces
        // before it).
        let errs = errors.into_inner().unwrap_or_else(|e| e.into_inner());
        let first_err = errs
            .into_iter()
            .map(|(p, (k, mut e))| {
                if k > 0 {
                    let before: u64 = f.pieces[..p].iter().map(|q| q.counts[k - 1].0).sum();
                    e.position += before;
                }
                (k, e)
            })
            .min_by_key(|(k, e)| (*k, e.position));
        let done = first_err.as_ref().map_or(steps, |(k, _)| *k);
        // Each step's time: the fork's wall time shared out in proportion
        // to the modules the step reads and writes (its pieces' steps are
        // not timed one by one: a clock read per piece and step cost more
        // than 1% of a short derivation).
        let wall = began.elapsed();
        let moved: Vec<u64> = (0..steps)
            .map(|k| {
                let read = if k == 0 {
                    run.string.len() as u64
                } else {
                    f.totals[k - 1].0
                };
                read + f.totals[k].0
            })
            .collect();
        let all: u64 = moved.iter().sum();
        for (k, &(cm, cw, ciw, _)) in f.totals.iter().enumerate().take(done) {
            run.processed += if k == 0 {
                run.string.len() as u64
            } else {
                f.totals[k - 1].0
            };
            run.cumulative += cm;
            let elapsed = if all == 0 {
                wall / steps as u32
            } else {
                wall.mul_f64(moved[k] as f64 / all as f64)
            };
            let s = IterationStats {
                iteration: f.first + k as u32,
                modules: cm,
                param_words: cw + ciw,
                cumulative_modules: run.cumulative,
                processed_modules: run.processed,
                bytes: if k + 1 == steps {
                    out.heap_bytes() as u64
                } else {
                    self.string_bytes(cm, cw)
                },
                elapsed,
            };
            run.stats.push(s);
            progress(&s);
        }
        if let Some((_, e)) = first_err {
            self.recycle(out);
            return Err(DeriveError::Runtime(e));
        }
        if let Some(end) = out.starts.get_mut(m) {
            *end = w as u32;
        }
        self.recycle(std::mem::replace(&mut run.string, out));
        run.iteration = f.last + 1;
        run.hist = f.hist;
        run.carried = Carried::default();
        Ok(())
    }

    /// Derive piece `p` of fork `f` through the fork's steps (stopping at
    /// a step past `fail`, where another piece failed earlier): the
    /// intermediate strings in `bufs`, the last into `out`.
    fn run_piece(
        &self,
        (f, input, seed, fail): (&Fork, &ModuleString, u32, &AtomicU32),
        p: usize,
        out: ChunkOut<'_>,
        bufs: &mut Scratch,
    ) -> Result<(), PieceError> {
        let piece = &f.pieces[p];
        let steps = piece.counts.len();
        let mut last = Some(out);
        // The modules of the piece's string in `bufs[0]`.
        let mut len = 0usize;
        for (k, counts) in piece.counts.iter().enumerate() {
            let t = f.first + k as u32;
            if t > fail.load(Ordering::Relaxed) {
                return Ok(());
            }
            let [a, b] = &mut *bufs;
            let (src, range, word_in) = if k == 0 {
                (input, piece.range.clone(), piece.word_in)
            } else {
                (&*a, 0..len, 0)
            };
            let step = Step {
                input: src,
                keys: if self.keyed { &src.keys } else { &[] },
                mate: &[],
                seed,
                iteration: t,
            };
            let (m, w) = (counts.0 as usize, counts.1 as usize);
            let res = if k + 1 == steps {
                match last.take() {
                    Some(mut o) => {
                        o.range = range;
                        o.word_in = word_in;
                        self.rewrite(&step, o)
                    }
                    None => Ok(()),
                }
            } else {
                grow(&mut b.syms, m);
                if self.keyed {
                    grow(&mut b.keys, m);
                } else {
                    b.keys.clear();
                }
                let with_starts = self.keeps_starts(f.totals[k].1);
                if with_starts {
                    grow(&mut b.starts, m + 1);
                } else {
                    b.starts.clear();
                }
                if w == 0 {
                    b.params.clear();
                } else {
                    grow(&mut b.params, w);
                }
                let res = self.rewrite(
                    &step,
                    ChunkOut {
                        range,
                        syms: &mut b.syms[..m],
                        keys: if self.keyed {
                            &mut b.keys[..m]
                        } else {
                            &mut []
                        },
                        starts: if with_starts {
                            &mut b.starts[..m]
                        } else {
                            &mut []
                        },
                        params: &mut b.params[..w],
                        word_base: 0,
                        word_in,
                    },
                );
                if with_starts {
                    b.starts[m] = w as u32;
                }
                res
            };
            res.map_err(|e| (k, e))?;
            bufs.swap(0, 1);
            len = m;
        }
        Ok(())
    }

    /// Rewrite one chunk without edits.
    fn rewrite(&self, step: &Step<'_>, out: ChunkOut<'_>) -> Result<(), RuntimeError> {
        if self.keyed {
            self.rewrite_chunk_best::<true, ()>(step, out, &mut ())
        } else {
            self.rewrite_chunk_best::<false, ()>(step, out, &mut ())
        }
    }

    /// A thread's two buffers for a fork: recycled from an earlier one
    /// where there are any.
    fn take_scratch(&self) -> Scratch {
        let mut s = self.scratch.lock().unwrap_or_else(|p| p.into_inner());
        s.pop()
            .unwrap_or_else(|| [ModuleString::new(), ModuleString::new()])
    }

    fn give_scratch(&self, bufs: Scratch) {
        let mut s = self.scratch.lock().unwrap_or_else(|p| p.into_inner());
        if s.len() < self.participants().max(2) {
            s.push(bufs);
        }
    }
}

/// Per step of a fork and symbol, what one module of the symbol adds to
/// the step's counts: the counts of that step over the string the module
/// has become by then. A piece's counts at step `k` are its histogram
/// times row `k`, one multiply-add per symbol, where the images of every
/// piece's histogram took a pass over the successor table per step. Built
/// as far as the forks ask, once per engine (the successor table is the
/// same in every step); counts past `u64` saturate, which only symbols
/// that no string within the limits holds can reach.
#[derive(Debug, Default)]
pub(crate) struct Response {
    /// Per symbol, what one module of it has become after `rows.len()`
    /// steps (sparse: symbol, modules).
    hists: Vec<Vec<(u32, u64)>>,
    rows: Vec<Vec<Counts>>,
}

impl Response {
    /// At least `steps` rows.
    fn extend(&mut self, e: &Engine<'_>, succ: &[Vec<(u32, u64)>], steps: usize) {
        let symbols = e.sym_words.len();
        if self.rows.is_empty() {
            self.hists = (0..symbols as u32).map(|s| vec![(s, 1)]).collect();
        }
        // What one symbol's string becomes, summed densely; `touched`: the
        // symbols it holds (a pass over the whole alphabet per symbol and
        // step would be its square).
        let mut dense = vec![0u64; symbols];
        let mut touched: Vec<u32> = Vec::new();
        while self.rows.len() < steps {
            let mut row = Vec::with_capacity(symbols);
            for h in &mut self.hists {
                let mut c: Counts = (0, 0, 0, 0);
                for &(s, n) in h.iter() {
                    let s = s as usize;
                    let (_, len, words) = e.counts[s];
                    let add = |x: &mut u64, per: u32| {
                        *x = x.saturating_add(n.saturating_mul(u64::from(per)));
                    };
                    add(&mut c.0, len);
                    add(&mut c.1, words);
                    add(&mut c.2, e.implicit_words_of(s));
                    add(&mut c.3, e.sym_words[s]);
                    for &(t, k) in &succ[s] {
                        let d = &mut dense[t as usize];
                        if *d == 0 {
                            touched.push(t);
                        }
                        *d = d.saturating_add(n.saturating_mul(k));
                    }
                }
                row.push(c);
                h.clear();
                for t in touched.drain(..) {
                    h.push((t, std::mem::take(&mut dense[t as usize])));
                }
            }
            self.rows.push(row);
        }
    }
}

/// The counts of a string whose symbol histogram is `h` in a step whose
/// row of [`Response`] is `row`.
fn counts_of(h: &[u64], row: &[Counts]) -> Counts {
    let mut c: Counts = (0, 0, 0, 0);
    for (&n, r) in h.iter().zip(row) {
        if n == 0 {
            continue;
        }
        c.0 = c.0.saturating_add(n.saturating_mul(r.0));
        c.1 = c.1.saturating_add(n.saturating_mul(r.1));
        c.2 = c.2.saturating_add(n.saturating_mul(r.2));
        c.3 = c.3.saturating_add(n.saturating_mul(r.3));
    }
    c
}

/// The symbol histogram of a piece: [`histogram`]'s four lanes where the
/// piece is long, one count per module where it is a few modules (a fork
/// from an early step cuts pieces of one to a few dozen).
fn piece_histogram(syms: &[u32], symbols: usize) -> Vec<u64> {
    if syms.len() >= 256 {
        return histogram(syms, symbols);
    }
    let mut h = vec![0u64; symbols];
    for &s in syms {
        if let Some(c) = h.get_mut(s as usize) {
            *c += 1;
        }
    }
    h
}

/// The threads a fork of `pieces` pieces runs on, of `threads`.
fn threads_for(threads: usize, pieces: usize) -> usize {
    threads.min(pieces).max(1)
}

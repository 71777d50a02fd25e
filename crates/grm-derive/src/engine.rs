//! The derivation engine: count / exclusive scan / rewrite over chunks.
//!
//! One iteration rewrites every module of the input string at once:
//!
//! 1. **Count.** Each chunk of the input decides, module by module, which
//!    production applies (the first group whose contexts match and whose
//!    condition holds; among its alternatives the one drawn with draw index
//!    0) and sums the output modules and parameter words.
//! 2. **Scan.** An exclusive prefix sum over the chunks' counts gives each
//!    chunk its output offsets. The totals are checked against the
//!    [`DeriveLimits`] *before* anything is allocated.
//! 3. **Rewrite.** Each chunk decides again (the decision is a pure
//!    function of the input, so it is the same) and writes its successors
//!    into its own disjoint slice of the output.
//!
//! With one thread the chunk is the whole string and nothing touches rayon;
//! with several, chunks are processed in parallel. Every decision, random
//! draw and value depends only on the input string, the seed, the iteration
//! and the module's position, never on the chunking, so the output is
//! byte-identical for any number of threads. If several modules fail, the
//! error reported is the one at the lowest position, also independent of
//! the chunking.
//!
//! Hot-path rules: no allocation per module (per-chunk scratch is allocated
//! once per chunk); a run of modules that are copied unchanged is moved
//! whole; every symbol has one precomputed action (`Act`: copy,
//! one-word unit, plan, short arithmetic plan, group search), so symbols
//! with one unconditional, context-free production (or none) take a table
//! lookup instead of the group search; constant and copied parameters skip
//! the VM, and the arithmetic forms `x * k`, `x + k`, `x - k` are one
//! branch-free `x * m + a`; short successors are written as fixed-size
//! moves from padded tables (`PAD`), which may write ahead of the
//! successor into positions the following ones overwrite, never past the
//! chunk's slice.

use std::borrow::Cow;
use std::ops::Range;
use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::expand::Carried;
use crate::fan::Fan;
use grm_compile::CompiledSystem;
use grm_compile::rng::{self, DrawCtx};
use grm_compile::select::{self, AltError};
use grm_compile::table::*;
use grm_compile::vm::Vm;
use rayon::prelude::*;

use crate::brackets::{self, UNMATCHED};
use crate::error::{DeriveError, RuntimeError, RuntimeErrorKind};
use crate::string::{Implicit, ModuleString};

mod build;
mod fork;
mod rewrite;
mod step;

/// Limits that stop a runaway grammar before it exhausts the machine.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DeriveLimits {
    /// The most modules a derived string may have.
    pub max_modules: u64,
    /// The most bytes an iteration may hold at once (input string, bracket
    /// table, output string).
    pub max_bytes: u64,
}

impl Default for DeriveLimits {
    /// 50 million modules, 2 GiB.
    fn default() -> Self {
        DeriveLimits {
            max_modules: 50_000_000,
            max_bytes: 2 << 30,
        }
    }
}

/// How to run a derivation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DeriveOptions {
    /// Rewriting steps.
    pub iterations: u32,
    /// The seed of every random draw.
    pub seed: u32,
    pub limits: DeriveLimits,
}

impl DeriveOptions {
    /// The system's own settings (iterations, seed) and default limits.
    pub fn from_system(sys: &CompiledSystem) -> DeriveOptions {
        DeriveOptions {
            iterations: sys.settings.iterations,
            seed: sys.settings.seed,
            limits: DeriveLimits::default(),
        }
    }
}

/// Figures of one iteration.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct IterationStats {
    /// The index of the string: 0 is the axiom, `k` the string after `k`
    /// rewriting steps.
    pub iteration: u32,
    /// Its length in modules.
    pub modules: u64,
    /// Its parameter words.
    pub param_words: u64,
    /// Modules produced so far: the sum of the lengths of strings 1 ..=
    /// `iteration` (Lipp's "modules" figure for a derivation).
    pub cumulative_modules: u64,
    /// Modules rewritten so far: the sum of the lengths of strings 0 ..
    /// `iteration` (the inputs of the steps).
    pub processed_modules: u64,
    /// Bytes of the string's arrays.
    pub bytes: u64,
    /// Time taken by this iteration.
    pub elapsed: Duration,
}

impl IterationStats {
    /// The figures of string `s`, number `iteration`, made in `elapsed`,
    /// with the running totals `cumulative` (modules produced) and
    /// `processed` (modules rewritten).
    pub fn of(
        s: &ModuleString,
        iteration: u32,
        cumulative: u64,
        processed: u64,
        elapsed: Duration,
    ) -> IterationStats {
        IterationStats {
            iteration,
            modules: s.len() as u64,
            param_words: s.param_words() as u64,
            cumulative_modules: cumulative,
            processed_modules: processed,
            bytes: s.heap_bytes() as u64,
            elapsed,
        }
    }
}

/// The result of a derivation.
#[derive(Clone, Debug)]
pub struct Derivation {
    /// The final string.
    pub string: ModuleString,
    /// One entry per string: the axiom (iteration 0), then each step.
    pub stats: Vec<IterationStats>,
}

/// A derivation under way: the latest string and what the steps carry.
struct Run {
    string: ModuleString,
    stats: Vec<IterationStats>,
    /// The next step's iteration.
    iteration: u32,
    cumulative: u64,
    processed: u64,
    carried: Carried,
    /// The string's symbol histogram (see `succ_hist`).
    hist: Option<Vec<u64>>,
    /// The longest string a fork was declined for (`fork.rs`): a string
    /// no longer is not planned again.
    declined: usize,
}

/// `fast[sym]`: the module is copied unchanged.
pub(crate) const COPY: u32 = u32::MAX;
/// `fast[sym]`: groups must be tried (context, condition or several groups
/// or alternatives).
pub(crate) const SLOW: u32 = u32::MAX - 1;

/// Chunks smaller than this are not worth a task.
const MIN_CHUNK: usize = 8192;

/// The most worker threads [`Engine::new`] starts; asking for more is
/// [`DeriveError::TooManyThreads`] (R0209), checked before any thread
/// starts. Far more threads than cores only costs memory, and tens of
/// thousands exhaust it: the operating system then fails *inside* the new
/// threads (their stack guard pages), which no caller could recover from.
/// `grmc --threads` accepts the same maximum (its `MAX_THREADS`, checked
/// equal to this one at compile time).
pub const MAX_THREADS: usize = 1024;

/// A compiled system prepared for derivation, with its thread pool.
#[derive(Debug)]
pub struct Engine<'a> {
    pub(crate) sys: &'a CompiledSystem,
    /// Per symbol: `(fast, output modules, output words)`, the count pass's
    /// table (one load per module); `fast` is `COPY`, `SLOW`, or the one
    /// alternative that always applies.
    pub(crate) counts: Vec<(u32, u32, u32)>,
    /// Per symbol: parameter words.
    pub(crate) sym_words: Vec<u32>,
    /// Per symbol: 1 for `[`, 2 for `]`, 0 otherwise.
    pub(crate) bracket: Vec<u8>,
    /// Per symbol: in the ignore list.
    ignored: Vec<bool>,
    /// When no symbol needs the group search: per symbol, the symbols it
    /// becomes and how many of each. The derivation then carries the
    /// string's symbol histogram from one iteration to the next and the
    /// one-chunk path counts from it instead of scanning the string.
    pub(crate) succ_hist: Option<Vec<Vec<(u32, u64)>>>,
    /// Per successor module (parallel to `sys.succ`, then `2 * PAD`
    /// zeros): symbol, word offset.
    pub(crate) succ_syms: Vec<u32>,
    succ_words: Vec<u32>,
    /// Per successor module (parallel to `sys.succ`): its identity salt,
    /// premixed (`rng::premix`: the half of `child_key` that depends on
    /// the salt alone, computed once here instead of per module written).
    pub(crate) succ_salts: Vec<u32>,
    /// Whether strings carry identity keys (`ModuleString::keys`): always
    /// when the system draws random numbers (the draws are keyed by
    /// them), else when asked for ([`Engine::with_keys`]).
    pub(crate) keyed: bool,
    /// Per alternative: its parameter words with the constants filled in
    /// (`tpl[plan.tpl ..][.. plan.words]`), then `2 * PAD` zeros.
    tpl: Vec<f32>,
    /// The parameters that are not constants, per alternative.
    patches: Vec<Patch>,
    /// Parallel to `patches`: the arithmetic ones, compact (the others
    /// zero).
    ariths: Vec<Arith>,
    /// Per alternative.
    pub(crate) plans: Vec<Plan>,
    /// The successors of [`Act::Fan`].
    fans: Vec<Fan>,
    /// Per symbol: what the rewrite does with it ([`Act`]).
    pub(crate) acts: Vec<Act>,
    /// Per symbol: its action is a copy ([`Act::Copy0`], [`Act::Copy`]).
    /// The rewrite moves a run of such modules whole.
    pub(crate) copies: Vec<bool>,
    pub(crate) has_context: bool,
    pub(crate) threads: usize,
    pub(crate) min_chunk: usize,
    pub(crate) pool: Option<rayon::ThreadPool>,
    /// Recycled string buffers (at most [`SPARES`]), so repeated iterations
    /// and derivations reuse memory instead of faulting in fresh pages.
    spare: std::sync::Mutex<Vec<ModuleString>>,
    /// Recycled buffers of the threads of a fork (`fork.rs`), so repeated
    /// derivations reuse them.
    scratch: std::sync::Mutex<Vec<fork::Scratch>>,
    /// What a fork counts pieces with (`fork.rs`), built on first use.
    response: std::sync::Mutex<fork::Response>,
    /// The persistent edits replayed while deriving ([`Engine::with_edits`];
    /// `None`: none, the plain derivation).
    pub(crate) edits: Option<Box<crate::edits::EditPlan>>,
    /// The words this engine's strings do not store ([`Implicit`]; `None`:
    /// every module stores its words, as an engine with edits does).
    pub(crate) implicit: Option<Arc<Implicit>>,
    /// Per symbol: its implicit words; per alternative: those of its
    /// successor (what the count pass adds up for
    /// [`ModuleString::param_words`]).
    implicit_sym: Vec<u32>,
    implicit_alt: Vec<u32>,
}

/// How many recycled buffers an engine keeps.
const SPARES: usize = 3;

/// Resize `v` to `n` elements, reusing its memory when it is large enough
/// (the contents are overwritten by the caller).
fn fit<T: Copy + Default>(v: &mut Vec<T>, n: usize) {
    if v.len() >= n {
        v.truncate(n);
    } else if v.capacity() >= n {
        v.resize(n, T::default());
    } else {
        // Fresh zeroed memory (lazily zeroed by the OS for large sizes),
        // backed by huge pages where the OS offers them on request.
        *v = vec![T::default(); n];
        crate::pages::advise_huge(v);
    }
}

/// Where the binding words of a decision are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Binds {
    /// The predecessor's own parameters (no copy needed).
    Direct,
    /// The worker's binding buffer.
    Buffer,
}

/// Everything the rewrite needs about one alternative, in one record.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Plan {
    /// First successor module (index into `succ_syms` / `succ_words`).
    pub(crate) succ: u32,
    pub(crate) len: u32,
    pub(crate) words: u32,
    /// Start of its parameter template in `tpl`.
    pub(crate) tpl: u32,
    /// Its patches: `patches[patch_lo .. patch_hi]`.
    pub(crate) patch_lo: u32,
    pub(crate) patch_hi: u32,
    /// Every patch is [`Patch::Arith`] (none can fault but by a
    /// non-finite value).
    pub(crate) arith: bool,
}

/// A symbol whose one production always applies and rewrites it into one
/// module whose one word is one arithmetic patch of its own word:
/// `F(l) -> F(l * lr)`, `!(w) -> !(w * vr)`, most of a parametric tree's
/// string. The rewrite loop writes it inline instead of through the
/// general `emit` (the same single f32 operation, the same error).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Unit {
    pub(crate) sym: u32,
    /// Its successor module (index into `succ_salts`).
    pub(crate) succ: u32,
    /// The patch, `x * m + a` ([`Patch::Arith`]).
    pub(crate) m: f32,
    pub(crate) a: f32,
    pub(crate) span: u32,
}

/// What the rewrite does with a module, per symbol: one load and one
/// branch for the common cases.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Act {
    /// Copied unchanged; the symbol has no parameters.
    Copy0,
    /// Copied unchanged with its `words` parameter words.
    Copy(u32),
    /// [`Unit`].
    Unit(Unit),
    /// Rewritten by this one alternative (its plan), which always applies,
    /// the predecessor's own words as its bindings.
    Plan(u32),
    /// [`Act::Plan`] for a short successor of arithmetic patches only: at
    /// most `PAD` modules and words, a predecessor of at most `PAD` words,
    /// every patch index in range and the constants finite, checked when
    /// the engine is built. Its template is written as one `PAD`-word
    /// move and its patches into that window without bounds checks, the
    /// non-finite test folded into one bit for the whole successor.
    Small(u32),
    /// [`Act::Small`] where every stored word of the successor is an
    /// arithmetic patch of the same binding word (the row of trees' `F`):
    /// `fans[i]`, its words computed as one vector multiply-add
    /// (`fan.rs`).
    Fan(u32),
    /// The groups must be tried ([`Engine::decide`]).
    Slow,
}

/// Padding after the template table (`2 * PAD` words) and the successor
/// tables (`2 * PAD` modules): a successor of at most `PAD` (or `2 * PAD`)
/// modules or words is copied as `PAD` (`2 * PAD`) of them in fixed-size
/// moves where the output has room. The words past its end land on
/// positions of the chunk's output that the following modules' successors
/// overwrite (the rewrite writes its output in order, every position
/// once), or are never reached when the output has no room.
pub(crate) const PAD: usize = 8;

/// How one non-constant successor parameter is computed. The arithmetic
/// forms are the bytecode `load a; const k; mul|add|sub w1; ret` (or
/// `const k; load a; mul|add w1; ret`) recognized once, so the most common
/// parameter expressions skip the interpreter; the result is the same single
/// IEEE f32 operation the VM (and the GPU) performs.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Patch {
    Copy {
        dst: u32,
        src: u32,
        words: u32,
    },
    /// `x * m + a` of binding word `src`: `x * k` is `m = k, a = -0.0`
    /// (adding -0.0 leaves every value, -0.0 included, unchanged), `x + k`
    /// is `m = 1, a = k` (`x * 1` is exact), `x - k` is `m = 1, a = -k`
    /// (IEEE subtraction is the addition of the negation). So each is the
    /// same single rounding the VM performs, without a branch on the kind.
    Arith {
        dst: u32,
        src: u32,
        m: f32,
        a: f32,
        span: u32,
    },
    Code {
        dst: u32,
        entry: u32,
        words: u32,
        span: u32,
    },
}

impl Patch {
    fn of(sys: &CompiledSystem, p: &ParamExpr, dst: u32) -> Patch {
        use grm_compile::op::Op;
        if p.kind == PARAM_COPY {
            return Patch::Copy {
                dst,
                src: p.a,
                words: p.words,
            };
        }
        let code = sys.code.get(p.a as usize..p.a as usize + 4);
        let span = p.span;
        if let (1, Some(&[w0, w1, w2, w3])) = (p.words, code) {
            let dec = |w: u32| (Op::from_code(w & 0xFF), w >> 8);
            let (o0, a0) = dec(w0);
            let (o1, a1) = dec(w1);
            let (o2, a2) = dec(w2);
            let (o3, _) = dec(w3);
            let operands = match (o0, o1) {
                (Some(Op::Load), Some(Op::Const)) => Some((a0, a1, false)),
                (Some(Op::Const), Some(Op::Load)) => Some((a1, a0, true)),
                _ => None,
            };
            if let (Some((src, kidx, swapped)), Some(Op::Ret), 1) = (operands, o3, a2)
                && let Some(&k) = sys.consts.get(kidx as usize)
            {
                let form = match o2 {
                    Some(Op::Mul) => Some((k, -0.0)),
                    Some(Op::Add) => Some((1.0, k)),
                    Some(Op::Sub) if !swapped => Some((1.0, -k)),
                    _ => None,
                };
                if let Some((m, a)) = form {
                    return Patch::Arith {
                        dst,
                        src,
                        m,
                        a,
                        span,
                    };
                }
            }
        }
        Patch::Code {
            dst,
            entry: p.a,
            words: p.words,
            span,
        }
    }
}

/// [`Patch::Arith`] without its span, in a table parallel to the patches
/// (`ariths[i]` is `patches[i]` where that is arithmetic).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Arith {
    dst: u32,
    src: u32,
    m: f32,
    a: f32,
}

/// Per-chunk scratch: the VM and the binding buffer.
pub(crate) struct Worker {
    vm: Vm,
    pub(crate) buf: Vec<f32>,
    weights: Vec<f32>,
}

/// Everything one iteration reads.
pub(crate) struct Step<'s> {
    pub(crate) input: &'s ModuleString,
    /// The input's keys (empty when the engine is not keyed).
    pub(crate) keys: &'s [u32],
    /// Bracket partners (context-sensitive systems only).
    pub(crate) mate: &'s [u32],
    pub(crate) seed: u32,
    pub(crate) iteration: u32,
}

impl Step<'_> {
    /// The draws of module `i`'s rewrite: keyed by its identity (by its
    /// position in an engine without keys, whose system draws nothing).
    #[inline]
    fn draws(&self, i: usize) -> DrawCtx {
        DrawCtx {
            seed: self.seed,
            iteration: self.iteration,
            position: self.keys.get(i).copied().unwrap_or(i as u32),
        }
    }
}

/// Where a successor is written: a chunk's output slices and the module
/// and word positions in them.
pub(crate) struct Out<'o> {
    pub(crate) syms: &'o mut [u32],
    pub(crate) starts: &'o mut [u32],
    pub(crate) params: &'o mut [f32],
    pub(crate) word_base: u32,
    pub(crate) o: usize,
    pub(crate) wo: usize,
}

/// The successor modules one input module became in a chunk's output
/// (for [`Replay::made`]): their keys, symbols and starts (empty when the
/// output stores no word), and the chunk's first word's position.
pub(crate) struct Made<'m> {
    /// Its successor list (index into `succ_syms`).
    pub(crate) succ: u32,
    pub(crate) keys: &'m [u32],
    pub(crate) syms: &'m [u32],
    pub(crate) starts: &'m [u32],
    pub(crate) word_base: u32,
}

/// What a persistent-edits replay adds to the engine's keyed rewrite loop
/// (`edits.rs`); `()` adds nothing, and the loop compiles to the plain
/// one. Positions are the chunk's (input: the string's, output: from the
/// chunk's first module).
pub(crate) trait Replay {
    /// The alternative an edit forces on input module `i` (from 1; 0:
    /// none, the engine's own decision). Called for every module the loop
    /// takes one by one, before [`Replay::made`] or [`Replay::copied`] for
    /// it.
    fn force(&mut self, i: usize) -> u32;
    /// Input modules `i` were copied to output `o..` (their keys kept).
    fn copied(&mut self, i: Range<usize>, o: usize);
    /// Input module `i` was rewritten to output modules `o..o +
    /// made.keys.len()` (keys written); `params` the chunk's words.
    fn made(
        &mut self,
        i: usize,
        o: usize,
        made: Made<'_>,
        params: &mut [f32],
    ) -> Result<(), RuntimeError>;
}

impl Replay for () {
    #[inline(always)]
    fn force(&mut self, _: usize) -> u32 {
        0
    }
    #[inline(always)]
    fn copied(&mut self, _: Range<usize>, _: usize) {}
    #[inline(always)]
    fn made(&mut self, _: usize, _: usize, _: Made<'_>, _: &mut [f32]) -> Result<(), RuntimeError> {
        Ok(())
    }
}

/// One chunk's output slices.
pub(crate) struct ChunkOut<'o> {
    pub(crate) range: Range<usize>,
    pub(crate) syms: &'o mut [u32],
    /// The chunk's output keys (empty when the engine is not keyed).
    pub(crate) keys: &'o mut [u32],
    pub(crate) starts: &'o mut [u32],
    pub(crate) params: &'o mut [f32],
    pub(crate) word_base: u32,
    /// Where the chunk's first input module's stored words begin.
    pub(crate) word_in: usize,
}

impl<'a> Engine<'a> {
    /// Prepare `sys` for derivation with `threads` threads: 1 runs
    /// everything on the calling thread, 0 uses rayon's global pool (all
    /// cores), `n > 1` a pool of `n` threads, at most [`MAX_THREADS`]
    /// (more is [`DeriveError::TooManyThreads`]; a pool the operating
    /// system refuses is [`DeriveError::ThreadPool`]).
    pub fn new(sys: &'a CompiledSystem, threads: usize) -> Result<Engine<'a>, DeriveError> {
        Engine::build(sys, threads, true)
    }

    /// Give a string back to the engine: its memory is reused for the next
    /// strings it derives. Callers that derive repeatedly (a preview, a
    /// benchmark) hand back each result when done with it.
    pub fn recycle(&self, s: ModuleString) {
        let mut spare = self.spare.lock().unwrap_or_else(|p| p.into_inner());
        spare.push(s);
        if spare.len() > SPARES {
            // Keep the largest buffers.
            if let Some(i) = (0..spare.len()).min_by_key(|&i| spare[i].syms.capacity()) {
                spare.swap_remove(i);
            }
        }
    }

    /// A string of `m` modules and `w` parameter words whose contents will
    /// be overwritten: a recycled buffer that fits without waste, else fresh
    /// memory.
    pub(crate) fn take(&self, m: usize, w: usize) -> ModuleString {
        let mut spare = self.spare.lock().unwrap_or_else(|p| p.into_inner());
        let fits = |s: &ModuleString| s.syms.capacity() >= m && s.params.capacity() >= w;
        // A buffer that fits and is not more than 4x too large (a much
        // larger one is kept for the larger strings to come): preferably one
        // already that long (nothing to zero), then the smallest, then among
        // equally large ones the shortest (a longer one is kept for the
        // longer strings to come, which then need nothing zeroed either).
        let pick = (0..spare.len())
            .filter(|&i| fits(&spare[i]) && spare[i].syms.capacity() <= 4 * m.max(4096))
            .min_by_key(|&i| {
                let s = &spare[i].syms;
                (s.len() < m, s.capacity(), s.len())
            });
        let mut s = match pick {
            Some(i) => spare.swap_remove(i),
            None => ModuleString::new(),
        };
        drop(spare);
        fit(&mut s.syms, m);
        // A compact string whose modules store no word keeps no starts.
        // A walked string neither.
        fit(
            &mut s.starts,
            if self.keeps_starts(w as u64) {
                m + 1
            } else {
                0
            },
        );
        s.marks = std::sync::OnceLock::new();
        fit(&mut s.params, w);
        s.implicit = self.implicit.clone();
        s.implicit_words = 0;
        if self.keyed {
            fit(&mut s.keys, m);
        } else {
            s.keys.clear();
        }
        s
    }

    /// Whether a string of `w` stored words keeps `starts` in this
    /// engine's layout.
    pub(crate) fn keeps_starts(&self, w: u64) -> bool {
        !((w == 0 && self.compact()) || self.walks())
    }

    /// The bytes of a string of `m` modules and `w` stored words as
    /// [`Engine::take`] lays it out in fresh memory (what
    /// [`ModuleString::heap_bytes`] says of it).
    pub(crate) fn string_bytes(&self, m: u64, w: u64) -> u64 {
        let starts = if self.keeps_starts(w) { m + 1 } else { 0 };
        let keys = if self.keyed { m } else { 0 };
        4 * (m + starts + w + keys)
    }

    /// Set the smallest chunk (in input modules) worth a parallel task
    /// (default 8192). For tuning and tests: the output never depends on it.
    pub fn with_min_chunk(mut self, modules: usize) -> Engine<'a> {
        self.min_chunk = modules.max(1);
        self
    }

    /// Carry identity keys in every string even when the system draws
    /// nothing (`true`), for callers that name parts (derivation trees,
    /// part ids). A system that draws random numbers always carries them:
    /// `false` changes nothing there.
    pub fn with_keys(mut self, keys: bool) -> Engine<'a> {
        self.keyed = keys || self.sys.draws_randomly();
        self
    }

    /// Whether the strings this engine derives carry identity keys.
    pub fn keyed(&self) -> bool {
        self.keyed
    }

    /// The compiled system.
    pub fn system(&self) -> &'a CompiledSystem {
        self.sys
    }

    /// Derive `opts.iterations` steps from the axiom. `progress` is called
    /// once per string (the axiom first), in order, always on the calling
    /// thread: as soon as the string is complete (on several threads,
    /// while the pool already runs the next step), or, for the steps of a
    /// fork (a system without decisions on several threads: `fork.rs`),
    /// when the fork ends.
    pub fn derive(
        &self,
        opts: &DeriveOptions,
        progress: &mut dyn FnMut(&IterationStats),
    ) -> Result<Derivation, DeriveError> {
        if self.edits.is_some() {
            return self.derive_edited(opts, progress).map(|(d, _)| d);
        }
        let t = Instant::now();
        let string = self.axiom(opts.seed)?;
        // Not sized by `opts.iterations` (any u32): a string that stops
        // growing can run many steps, a limit can end it after a few.
        let mut stats = Vec::with_capacity(opts.iterations.min(64) as usize + 1);
        let first = IterationStats::of(&string, 0, 0, 0, t.elapsed());
        progress(&first);
        stats.push(first);
        let hist = self.succ_hist.as_ref().map(|_| {
            let mut h = vec![0u64; self.sym_words.len()];
            for &s in &string.syms {
                h[s as usize] += 1;
            }
            h
        });
        let mut run = Run {
            string,
            stats,
            iteration: 1,
            cumulative: 0,
            processed: 0,
            carried: Carried::default(),
            hist,
            declined: 0,
        };
        // Where no symbol needs a decision, the rest of the derivation (up
        // to 32 steps at a time) as one fork from the first step worth it,
        // the caller taking its share (`fork.rs`). Otherwise the steps of
        // one chunk on this thread; from the first step of several, the
        // rest of the derivation on the pool in one piece (`hand_off`).
        // Not from a thread that is itself a rayon worker (a forest's
        // trees derived in parallel): its phases already run as its own
        // jobs, and it must not block waiting on a task that may sit in
        // its own queue.
        let handed = rayon::current_thread_index().is_none();
        while run.iteration <= opts.iterations {
            let began = Instant::now();
            if self.succ_hist.is_some() {
                match self.fork_plan(&run, opts) {
                    Some(f) => {
                        self.run_fork(&mut run, opts, f, began, progress)?;
                        continue;
                    }
                    None => run.declined = run.declined.max(run.string.len()),
                }
            }
            if handed && self.chunks(run.string.len()).len() > 1 {
                self.hand_off(
                    |sent| {
                        while run.iteration <= opts.iterations {
                            sent(self.advance(&mut run, opts)?);
                        }
                        Ok(())
                    },
                    progress,
                )?;
                break;
            }
            let s = self.advance(&mut run, opts)?;
            progress(&s);
        }
        Ok(Derivation {
            string: run.string,
            stats: run.stats,
        })
    }

    /// One step of `run`: its string replaced by the next, whose figures
    /// are returned (and kept in `run.stats`).
    fn advance(&self, run: &mut Run, opts: &DeriveOptions) -> Result<IterationStats, DeriveError> {
        let t = Instant::now();
        let iteration = run.iteration;
        run.processed += run.string.len() as u64;
        let next = self.step_counted(
            &run.string,
            iteration,
            opts.seed,
            &opts.limits,
            run.hist.as_mut(),
            Some(&mut run.carried),
        )?;
        // Recycle the input before reporting, so the peak stays at one
        // input plus one output (and the spares).
        self.recycle(std::mem::replace(&mut run.string, next));
        run.cumulative += run.string.len() as u64;
        let s = IterationStats::of(
            &run.string,
            iteration,
            run.cumulative,
            run.processed,
            t.elapsed(),
        );
        run.stats.push(s);
        run.iteration += 1;
        Ok(s)
    }

    /// Run `job` on the pool (this engine's, or rayon's global one) as one
    /// task, while this thread passes the figures it sends on to
    /// `progress`, as each string is complete. Each parallel phase of a
    /// step started from outside the pool is a hand-over of its own (this
    /// thread wakes a worker, sleeps, and is woken when the phase ends),
    /// about three thread wake-ups a phase, which on a virtual machine
    /// whose idle cores halt cost tens of microseconds each: as much as a
    /// short derivation's whole parallel gain (docs/benchmarks.md, "Two
    /// threads that pay on short scenes"). Inside one task, each phase's
    /// chunks are the worker's own jobs, which the other workers steal.
    fn hand_off<'j>(
        &'j self,
        job: impl FnOnce(&dyn Fn(IterationStats)) -> Result<(), DeriveError> + Send + 'j,
        progress: &'j mut dyn FnMut(&IterationStats),
    ) -> Result<(), DeriveError> {
        let (tx, rx) = std::sync::mpsc::channel();
        let mut result = Ok(());
        {
            let slot = &mut result;
            // The same body for either pool (`in_place_scope` is a method
            // of a pool and a free function for the global one).
            macro_rules! body {
                () => {
                    |scope| {
                        scope.spawn(move |_| {
                            // The receiver lives until this task ends.
                            let sent = |s: IterationStats| {
                                let _ = tx.send(s);
                            };
                            *slot = job(&sent);
                        });
                        // Until the task drops its sender.
                        for s in rx {
                            progress(&s);
                        }
                    }
                };
            }
            match &self.pool {
                Some(p) => p.in_place_scope(body!()),
                None => rayon::in_place_scope(body!()),
            }
        }
        result
    }

    /// The axiom (string 0): its parameters evaluated with iteration 0 and
    /// the system's root key ([`CompiledSystem::root_key`]); its modules'
    /// keys are children of the root key.
    pub fn axiom(&self, seed: u32) -> Result<ModuleString, DeriveError> {
        let sys = self.sys;
        let alt = &sys.alts[sys.axiom_alt as usize];
        let n = alt.succ_len as usize;
        let w = self.plans[sys.axiom_alt as usize].words as usize;
        let root = sys.root_key(seed);
        let mut out =
            ModuleString::from_parts(vec![0; n], vec![0; n + 1], vec![0.0; w], Vec::new());
        out.implicit = self.implicit.clone();
        out.implicit_words = self.implicit_alt[sys.axiom_alt as usize] as usize;
        if self.keyed {
            let salts = &self.succ_salts[alt.succ_offset as usize..][..n];
            out.keys = salts
                .iter()
                .map(|&s| rng::child_key_premixed(root, s))
                .collect();
        }
        // The axiom's draws use the root key (as module 0 of a one-module
        // string keyed by it).
        let empty = ModuleString::new();
        let root_keys = [root];
        let step = Step {
            input: &empty,
            keys: &root_keys,
            mate: &[],
            seed,
            iteration: 0,
        };
        let mut worker = self.worker();
        let ModuleString {
            syms,
            starts,
            params,
            ..
        } = &mut out;
        self.emit(
            &step,
            &mut worker,
            sys.axiom_alt,
            &[],
            0,
            &mut Out {
                syms,
                starts,
                params,
                word_base: 0,
                o: 0,
                wo: 0,
            },
        )
        .map_err(DeriveError::Runtime)?;
        out.starts[n] = w as u32;
        Ok(out)
    }
}

/// Copy a short slice without a call to `memcpy`: successors are a few to
/// a few dozen words, where the call costs more than the copy.
#[inline(always)]
pub(crate) fn copy_small<T: Copy>(dst: &mut [T], src: &[T]) {
    let n = dst.len().min(src.len());
    let (mut d, mut s) = (&mut dst[..n], &src[..n]);
    while d.len() >= 8 {
        let (dh, dt) = d.split_at_mut(8);
        dh.copy_from_slice(&s[..8]);
        d = dt;
        s = &s[8..];
    }
    for (x, y) in d.iter_mut().zip(s) {
        *x = *y;
    }
}

pub(crate) fn keep_first(slot: &mut Option<RuntimeError>, e: RuntimeError) {
    if slot.as_ref().is_none_or(|f| e.position < f.position) {
        *slot = Some(e);
    }
}

/// Derive with the system's compiled tables: [`Engine::new`] with `threads`,
/// then [`Engine::derive`].
pub fn derive(
    sys: &CompiledSystem,
    opts: &DeriveOptions,
    threads: usize,
    progress: &mut dyn FnMut(&IterationStats),
) -> Result<Derivation, DeriveError> {
    Engine::new(sys, threads)?.derive(opts, progress)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn compiled(src: &str) -> CompiledSystem {
        let (_, checked) = grm_sema::check_with("inline.grm", src, &grm_sema::MemLoader::new());
        assert!(!checked.has_errors(), "{:?}", checked.diagnostics);
        let p = &checked.program;
        let sys = p.default_system().expect("a system");
        grm_compile::compile(p, sys, &p.default_params()).expect("compiles")
    }

    fn spare(len: usize, cap: usize) -> ModuleString {
        let mut syms = Vec::with_capacity(cap);
        syms.resize(len, 0);
        let mut starts = Vec::with_capacity(cap + 1);
        starts.resize(len + 1, 0);
        let mut params = Vec::with_capacity(cap);
        params.resize(len, 0.0);
        ModuleString::from_parts(syms, starts, params, Vec::new())
    }

    /// Of two recycled buffers as large as each other, a string takes the
    /// shorter one that is long enough, so the longer one is left, with
    /// nothing to zero, for the longer string to come (a derivation's
    /// last two steps, when the previous result came back: the ternary
    /// tree zeroed a million-module buffer per run before).
    #[test]
    fn a_string_takes_the_shortest_long_enough_buffer() {
        let c = compiled("system S { axiom A; A -> A A A; }");
        let e = Engine::new(&c, 1).expect("engine");
        // Either order of recycling.
        for first_long in [true, false] {
            let (a, b) = (spare(1_000_000, 1_000_000), spare(300_000, 1_000_000));
            let (a, b) = if first_long { (a, b) } else { (b, a) };
            e.recycle(a);
            e.recycle(b);
            let mid = e.take(300_000, 300_000);
            assert_eq!(mid.syms.capacity(), 1_000_000);
            // The buffer already that long is left for the longer string.
            assert_eq!(spare_lens(&e), [1_000_000], "first_long {first_long}");
            let big = e.take(1_000_000, 1_000_000);
            assert_eq!(big.syms.len(), 1_000_000);
            assert!(spare_lens(&e).is_empty());
        }
    }

    fn spare_lens(e: &Engine<'_>) -> Vec<usize> {
        let s = e.spare.lock().unwrap_or_else(|p| p.into_inner());
        s.iter().map(|x| x.syms.len()).collect()
    }
}

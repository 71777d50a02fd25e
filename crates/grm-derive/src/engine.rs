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

    /// [`Engine::new`]; `compact`: strings leave implicit words unstored
    /// ([`Implicit`]).
    pub(crate) fn build(
        sys: &'a CompiledSystem,
        threads: usize,
        compact: bool,
    ) -> Result<Engine<'a>, DeriveError> {
        if threads > MAX_THREADS {
            return Err(DeriveError::TooManyThreads {
                threads,
                max: MAX_THREADS,
            });
        }
        sys.validate()
            .map_err(|e| DeriveError::InvalidTables(e.0))?;
        let n = sys.symbols.len();
        let implicit = if compact {
            crate::compact::implicit_words(sys)
        } else {
            None
        };
        // Per symbol, the words its modules store.
        let stored = |s: u32| -> u32 {
            let w = sys.symbols.get(s as usize).map_or(0, |e| e.param_words);
            match &implicit {
                Some(t) if t.width(s) > 0 => 0,
                _ => w,
            }
        };
        let implicit_sym: Vec<u32> = (0..n as u32)
            .map(|s| implicit.as_ref().map_or(0, |t| t.width(s) as u32))
            .collect();
        // Per alternative, the words its successor stores and the implicit
        // ones.
        let alt_words: Vec<(u32, u32)> = sys
            .alts
            .iter()
            .map(|a| {
                sys.successor(a).iter().fold((0, 0), |(w, i), m| {
                    (w + stored(m.symbol), i + implicit_sym[m.symbol as usize])
                })
            })
            .collect();
        let mut fast = vec![COPY; n];
        let mut fast_len = vec![1; n];
        let mut fast_words = vec![0; n];
        let mut bracket = vec![0u8; n];
        let mut ignored = vec![false; n];
        let mut sym_words = vec![0; n];
        for (i, s) in sys.symbols.iter().enumerate() {
            sym_words[i] = stored(i as u32);
            fast_words[i] = stored(i as u32);
            ignored[i] = s.flags & SYM_IGNORED != 0;
            if s.flags & SYM_PUSH != 0 {
                bracket[i] = 1;
            } else if s.flags & SYM_POP != 0 {
                bracket[i] = 2;
            }
            let groups = sys.groups_of(i as u32);
            if groups.is_empty() {
                continue;
            }
            let g = &groups[0];
            let simple = groups.len() == 1
                && g.flags & GROUP_CONTEXT == 0
                && g.cond_code == NONE
                && g.alt_count == 1
                && g.pred_bind_offset == 0
                && g.bind_words == g.pred_bind_words;
            if simple {
                let alt = &sys.alts[g.first_alt as usize];
                fast[i] = g.first_alt;
                fast_len[i] = alt.succ_len;
                fast_words[i] = alt_words[g.first_alt as usize].0;
            } else {
                fast[i] = SLOW;
            }
        }
        let counts = (0..n)
            .map(|i| (fast[i], fast_len[i], fast_words[i]))
            .collect();
        let succ_hist = fast.iter().all(|&f| f != SLOW).then(|| {
            (0..n)
                .map(|i| {
                    let mut h: Vec<(u32, u64)> = Vec::new();
                    let syms: Vec<u32> = if fast[i] == COPY {
                        vec![i as u32]
                    } else {
                        let a = &sys.alts[fast[i] as usize];
                        sys.successor(a).iter().map(|m| m.symbol).collect()
                    };
                    for t in syms {
                        match h.iter_mut().find(|(x, _)| *x == t) {
                            Some((_, c)) => *c += 1,
                            None => h.push((t, 1)),
                        }
                    }
                    h
                })
                .collect()
        });
        let succ_syms: Vec<u32> = sys.succ.iter().map(|m| m.symbol).collect();
        let succ_salts: Vec<u32> = sys.succ.iter().map(|m| rng::premix(m.salt)).collect();
        // Each successor module's offset among the words its successor
        // stores.
        let mut succ_words: Vec<u32> = sys.succ.iter().map(|m| m.word_offset).collect();
        for a in &sys.alts {
            let mut off = 0;
            let o = a.succ_offset as usize;
            for (k, m) in sys.successor(a).iter().enumerate() {
                if let Some(x) = succ_words.get_mut(o + k) {
                    *x = off;
                }
                off += stored(m.symbol);
            }
        }
        let mut tpl = Vec::new();
        let mut patches = Vec::new();
        let mut plans = Vec::with_capacity(sys.alts.len());
        for (ai, a) in sys.alts.iter().enumerate() {
            let tpl_start = tpl.len() as u32;
            let first_patch = patches.len() as u32;
            let mut dst = 0u32;
            for m in sys.successor(a) {
                if implicit_sym[m.symbol as usize] > 0 {
                    // Constants, not stored.
                    continue;
                }
                for p in sys.module_params(m) {
                    let w = p.words as usize;
                    match p.kind {
                        PARAM_CONST => {
                            tpl.extend_from_slice(&sys.consts[p.a as usize..p.a as usize + w]);
                        }
                        _ => {
                            tpl.extend(std::iter::repeat_n(0.0, w));
                            patches.push(Patch::of(sys, p, dst));
                        }
                    }
                    dst += p.words;
                }
            }
            plans.push(Plan {
                succ: a.succ_offset,
                len: a.succ_len,
                words: alt_words[ai].0,
                tpl: tpl_start,
                patch_lo: first_patch,
                patch_hi: patches.len() as u32,
                arith: patches[first_patch as usize..]
                    .iter()
                    .all(|p| matches!(p, Patch::Arith { .. })),
            });
        }
        let mut fans = Vec::new();
        let acts: Vec<Act> = (0..n)
            .map(|i| {
                let alt = fast[i];
                match alt {
                    COPY if sym_words[i] == 0 => return Act::Copy0,
                    COPY => return Act::Copy(sym_words[i]),
                    SLOW => return Act::Slow,
                    _ => {}
                }
                let plan = plans[alt as usize];
                if sym_words[i] == 1
                    && plan.len == 1
                    && plan.words == 1
                    && plan.patch_hi == plan.patch_lo + 1
                    && let Patch::Arith {
                        dst: 0,
                        src: 0,
                        m,
                        a,
                        span,
                    } = patches[plan.patch_lo as usize]
                {
                    return Act::Unit(Unit {
                        sym: succ_syms[plan.succ as usize],
                        succ: plan.succ,
                        m,
                        a,
                        span,
                    });
                }
                let (t, words) = (plan.tpl as usize, plan.words as usize);
                let small = plan.arith
                    && plan.len as usize <= PAD
                    && words <= PAD
                    && sym_words[i] as usize <= PAD
                    && tpl[t..t + words].iter().all(|x| x.is_finite())
                    && patches[plan.patch_lo as usize..plan.patch_hi as usize]
                        .iter()
                        .all(|p| match *p {
                            Patch::Arith { dst, src, .. } => {
                                (dst as usize) < words && src < sym_words[i]
                            }
                            _ => false,
                        });
                let arith = |p: &Patch| match *p {
                    Patch::Arith { dst, src, m, a, .. } => Some((dst, src, m, a)),
                    _ => None,
                };
                let fan = Fan::of(
                    plan,
                    patches[plan.patch_lo as usize..plan.patch_hi as usize]
                        .iter()
                        .map(arith),
                    sym_words[i],
                );
                if let (true, Some(fan)) = (small, fan) {
                    fans.push(fan);
                    Act::Fan(fans.len() as u32 - 1)
                } else if small {
                    Act::Small(alt)
                } else {
                    Act::Plan(alt)
                }
            })
            .collect();
        let ariths = patches
            .iter()
            .map(|p| match *p {
                Patch::Arith { dst, src, m, a, .. } => Arith { dst, src, m, a },
                _ => Arith::default(),
            })
            .collect();
        // The padded tables (see `PAD`).
        let mut succ_syms = succ_syms;
        succ_syms.extend([0; 2 * PAD]);
        succ_words.extend([0; 2 * PAD]);
        tpl.extend([0.0; 2 * PAD]);
        // Strings walk their stored words (no `starts`) where every symbol
        // is rewritten without a decision: nothing then reads a module's
        // words out of order while deriving ([`ModuleString`], "Walked
        // words").
        let mut implicit = implicit;
        if let Some(t) = &mut implicit
            && succ_hist.is_some()
        {
            t.widths = sym_words.clone();
        }
        let pool = if threads > 1 {
            Some(
                rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .map_err(|e| DeriveError::ThreadPool(e.to_string()))?,
            )
        } else {
            None
        };
        Ok(Engine {
            sys,
            counts,
            sym_words,
            bracket,
            ignored,
            succ_hist,
            succ_syms,
            succ_words,
            succ_salts,
            keyed: sys.draws_randomly(),
            tpl,
            patches,
            ariths,
            plans,
            fans,
            copies: acts
                .iter()
                .map(|a| matches!(a, Act::Copy0 | Act::Copy(_)))
                .collect(),
            acts,
            has_context: sys.has_context(),
            threads,
            min_chunk: MIN_CHUNK,
            pool,
            spare: std::sync::Mutex::new(Vec::new()),
            edits: None,
            implicit: implicit.map(Arc::new),
            implicit_sym,
            implicit_alt: alt_words.iter().map(|&(_, i)| i).collect(),
        })
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
            if (w == 0 && self.compact()) || self.walks() {
                0
            } else {
                m + 1
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
    /// once per string (the axiom first) as soon as it is complete, always
    /// on the calling thread (on several threads, while the pool already
    /// runs the next step).
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
        };
        // The steps of one chunk on this thread; from the first step of
        // several, the rest of the derivation on the pool in one piece
        // (`hand_off`). Not from a thread that is itself a rayon worker
        // (a forest's trees derived in parallel): its phases already run
        // as its own jobs, and it must not block waiting on a task that
        // may sit in its own queue.
        let handed = rayon::current_thread_index().is_none();
        while run.iteration <= opts.iterations {
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

    /// One rewriting step: the string that follows `input` (which must be a
    /// string of this system) in iteration `iteration`.
    pub fn step(
        &self,
        input: &ModuleString,
        iteration: u32,
        seed: u32,
        limits: &DeriveLimits,
    ) -> Result<ModuleString, DeriveError> {
        let input = self.check_input(input)?;
        self.step_counted(&input, iteration, seed, limits, None, None)
    }

    /// The productions applied by step `iteration` to `input`: per input
    /// module, the global index of the alternative that rewrites it
    /// (into `CompiledSystem::alts`), or `None` where the module is copied
    /// unchanged. The same decisions [`Engine::step`] makes (a pure
    /// function of the input, seed and iteration), taken on one thread,
    /// for callers that build the derivation tree: module `i`'s successor
    /// is the next `succ_len` modules of the output (one for a copy).
    pub fn decisions(
        &self,
        input: &ModuleString,
        iteration: u32,
        seed: u32,
    ) -> Result<Vec<Option<u32>>, DeriveError> {
        let input = &*self.check_input(input)?;
        let n = input.len();
        let mate = self.mates(input, n, false);
        let step = self.step_of(input, &mate, iteration, seed);
        let mut worker = self.worker();
        let mut out = Vec::with_capacity(n);
        for i in 0..n {
            let (f, _, _) = self.counts[input.syms[i] as usize];
            out.push(match f {
                COPY => None,
                SLOW => self
                    .decide(&step, &mut worker, i)
                    .map_err(DeriveError::Runtime)?
                    .map(|(alt, _)| alt),
                alt => Some(alt),
            });
        }
        Ok(out)
    }

    /// The bracket partners of `input` (context-sensitive systems only;
    /// empty otherwise), in chunks of `chunk` modules.
    pub(crate) fn mates(&self, input: &ModuleString, chunk: usize, parallel: bool) -> Vec<u32> {
        if !self.has_context {
            return Vec::new();
        }
        let bracket = &self.bracket;
        let kind = |s: u32| bracket.get(s as usize).copied().unwrap_or(0);
        brackets::mates(kind, &input.syms, chunk, parallel)
    }

    /// What step `iteration` over `input` reads.
    pub(crate) fn step_of<'s>(
        &self,
        input: &'s ModuleString,
        mate: &'s [u32],
        iteration: u32,
        seed: u32,
    ) -> Step<'s> {
        Step {
            input,
            keys: if self.keyed { &input.keys } else { &[] },
            mate,
            seed,
            iteration,
        }
    }

    /// Check that `s` is a string of this system, in this engine's layout
    /// (implicit words or not): a string in the other layout is brought
    /// into it, which fails where a module's words differ from the
    /// constants that this engine leaves implicit.
    pub(crate) fn check_input<'s>(
        &self,
        s: &'s ModuleString,
    ) -> Result<Cow<'s, ModuleString>, DeriveError> {
        if !s.is_well_formed() {
            return Err(DeriveError::InvalidInput("offsets are inconsistent".into()));
        }
        if s.len() >= u32::MAX as usize {
            return Err(DeriveError::InvalidInput("too many modules".into()));
        }
        if self.keyed && !s.has_keys() {
            return Err(DeriveError::InvalidInput(
                "the string carries no identity keys, and this engine's draws are keyed by them"
                    .into(),
            ));
        }
        if s.implicit != self.implicit {
            return self.relayout(s).map(Cow::Owned);
        }
        if s.walks() {
            // Its widths are this engine's (the same table), and
            // `is_well_formed` checked them.
            return Ok(Cow::Borrowed(s));
        }
        for i in 0..s.len() {
            let sym = s.syms[i] as usize;
            let Some(&w) = self.sym_words.get(sym) else {
                return Err(DeriveError::InvalidInput(format!(
                    "module {i} has unknown symbol {sym}"
                )));
            };
            let stored = s.stored(i).len();
            if stored != w as usize {
                return Err(DeriveError::InvalidInput(format!(
                    "module {i} (`{}`) has {stored} parameter words, not {w}",
                    self.sys.symbol_names[sym],
                )));
            }
        }
        Ok(Cow::Borrowed(s))
    }

    /// Chunk ranges for an input of `n` modules.
    pub(crate) fn chunks(&self, n: usize) -> Vec<Range<usize>> {
        if self.threads == 1 || n <= self.min_chunk {
            return std::iter::once(0..n).collect();
        }
        // A few chunks per thread balance uneven successors; none shorter
        // than `min_chunk`, all of about the same length (a short last
        // chunk left one thread idle for a third of a step split 8192,
        // 8192 and 947).
        let k = (n / self.min_chunk).clamp(1, self.most_chunks());
        let len = n.div_ceil(k);
        (0..n.div_ceil(len))
            .map(|c| c * len..((c + 1) * len).min(n))
            .collect()
    }

    /// The most chunks a step is split into: a few per thread.
    pub(crate) fn most_chunks(&self) -> usize {
        let threads = match self.threads {
            0 => rayon::current_num_threads(),
            t => t,
        };
        threads * 4
    }

    pub(crate) fn in_pool<R: Send>(&self, f: impl FnOnce() -> R + Send) -> R {
        match &self.pool {
            Some(p) => p.install(f),
            None => f(),
        }
    }

    pub(crate) fn worker(&self) -> Worker {
        Worker {
            vm: Vm::new(),
            buf: vec![0.0; self.sys.max_bind_words as usize],
            weights: Vec::new(),
        }
    }

    /// One step; `hist`, when given, is the input's symbol histogram (see
    /// `succ_hist`) and is advanced to the output's.
    fn step_counted(
        &self,
        input: &ModuleString,
        iteration: u32,
        seed: u32,
        limits: &DeriveLimits,
        hist: Option<&mut Vec<u64>>,
        carried: Option<&mut Carried>,
    ) -> Result<ModuleString, DeriveError> {
        let n = input.len();
        let mut chunks = self.chunks(n);
        let parallel = chunks.len() > 1;
        // Several chunks: their counts from carried histograms (no count
        // pass; `expand.rs`) where no symbol needs a decision.
        let mut from_chunks = None;
        if let Some(c) = carried {
            if !parallel {
                *c = Carried::default();
            } else if let Some((ch, counts)) = self.counts_carried(&input.syms, c) {
                chunks = ch;
                from_chunks = Some(counts);
            }
        }
        // Counts from the histogram (exact: no symbol needs a decision).
        let mut from_hist = None;
        if let (Some(h), Some(sh)) = (hist, &self.succ_hist) {
            let ((m, w, iw, _), next) = self.image(h, sh, true);
            *h = next;
            if !parallel {
                from_hist = Some((m, w, iw));
            }
        }
        let chunk = chunks.first().map_or(n, |c| c.len());
        let mate = if self.has_context {
            self.in_pool(|| self.mates(input, chunk, parallel))
        } else {
            Vec::new()
        };
        let step = self.step_of(input, &mate, iteration, seed);

        // 1. Count.
        let counts: Vec<Result<(u64, u64, u64, u64), RuntimeError>> =
            if let Some((m, w, iw)) = from_hist {
                vec![Ok((m, w, iw, 0))]
            } else if let Some(counts) = from_chunks {
                counts.into_iter().map(Ok).collect()
            } else if parallel {
                self.in_pool(|| {
                    chunks
                        .par_iter()
                        .map(|r| self.count_chunk(&step, r.clone()))
                        .collect()
                })
            } else {
                chunks
                    .iter()
                    .map(|r| self.count_chunk(&step, r.clone()))
                    .collect()
            };
        let mut totals = Vec::with_capacity(counts.len());
        let mut first_err: Option<RuntimeError> = None;
        for c in counts {
            match c {
                Ok(t) => totals.push(t),
                Err(e) => keep_first(&mut first_err, e),
            }
        }
        if let Some(e) = first_err {
            return Err(DeriveError::Runtime(e));
        }

        // 2. Scan, and the limits before allocating.
        let mut offsets = Vec::with_capacity(totals.len());
        let (mut m, mut w, mut iw, mut wi) = (0u64, 0u64, 0u64, 0u64);
        for (&(cm, cw, ciw, cwi), r) in totals.iter().zip(&chunks) {
            // Where the chunk's input words begin: a walked input's from
            // the counts (one chunk: at 0), another's from its starts.
            let word_in = if input.walks() {
                wi
            } else {
                input.start(r.start) as u64
            };
            offsets.push((m, w, word_in as usize));
            m += cm;
            w += cw;
            iw += ciw;
            wi += cwi;
        }
        self.check_limits(input, &mate, iteration, m, w, limits)?;
        let (m, w) = (m as usize, w as usize);

        // 3. Rewrite into disjoint slices.
        let mut out = self.take(m, w);
        out.implicit_words = iw as usize;
        {
            let mut parts = Vec::with_capacity(chunks.len());
            let with_starts = !out.starts.is_empty();
            let (mut syms, mut starts, mut params) = (
                &mut out.syms[..],
                &mut out.starts[..if with_starts { m } else { 0 }],
                &mut out.params[..],
            );
            let mut keys = &mut out.keys[..];
            for ((r, &(cm, cw, _, _)), &(_, word_base, word_in)) in
                chunks.iter().zip(&totals).zip(&offsets)
            {
                let (s, rest) = syms.split_at_mut(cm as usize);
                syms = rest;
                let (k, rest) = keys.split_at_mut(if self.keyed { cm as usize } else { 0 });
                keys = rest;
                let (st, rest) = starts.split_at_mut(if with_starts { cm as usize } else { 0 });
                starts = rest;
                let (p, rest) = params.split_at_mut(cw as usize);
                params = rest;
                parts.push(ChunkOut {
                    range: r.clone(),
                    syms: s,
                    keys: k,
                    starts: st,
                    params: p,
                    word_base: word_base as u32,
                    word_in,
                });
            }
            let work = |out: ChunkOut<'_>| {
                if self.keyed {
                    self.rewrite_chunk_best::<true, ()>(&step, out, &mut ())
                } else {
                    self.rewrite_chunk_best::<false, ()>(&step, out, &mut ())
                }
            };
            let results: Vec<Result<(), RuntimeError>> = if parallel {
                self.in_pool(|| parts.into_par_iter().map(work).collect())
            } else {
                parts.into_iter().map(work).collect()
            };
            let mut first_err = None;
            for r in results {
                if let Err(e) = r {
                    keep_first(&mut first_err, e);
                }
            }
            if let Some(e) = first_err {
                return Err(DeriveError::Runtime(e));
            }
        }
        if let Some(last) = out.starts.get_mut(m) {
            *last = w as u32;
        }
        Ok(out)
    }

    /// The implicit words a module of symbol `s` leaves behind when the
    /// fast path rewrites or copies it (`counts`).
    #[inline]
    pub(crate) fn implicit_words_of(&self, s: usize) -> u32 {
        match self.counts[s].0 {
            COPY => self.implicit_sym[s],
            SLOW => 0,
            alt => self.implicit_alt[alt as usize],
        }
    }

    pub(crate) fn check_limits(
        &self,
        input: &ModuleString,
        mate: &[u32],
        iteration: u32,
        m: u64,
        w: u64,
        limits: &DeriveLimits,
    ) -> Result<(), DeriveError> {
        let (file, span) = (self.sys.file, self.sys.span);
        if m > limits.max_modules {
            return Err(DeriveError::ModuleLimit {
                iteration,
                modules: m,
                limit: limits.max_modules,
                file,
                span,
            });
        }
        if m >= u64::from(u32::MAX) || w >= u64::from(u32::MAX) {
            return Err(DeriveError::TooLarge {
                iteration,
                modules: m,
                words: w,
                file,
                span,
            });
        }
        let key_bytes = if self.keyed { 4 * m } else { 0 };
        let out_bytes = 4 * m + 4 * (m + 1) + 4 * w + key_bytes;
        let bytes = input.heap_bytes() as u64 + 4 * mate.len() as u64 + out_bytes;
        if bytes > limits.max_bytes {
            return Err(DeriveError::MemoryLimit {
                iteration,
                bytes,
                limit: limits.max_bytes,
                modules: m,
                words: w,
                file,
                span,
            });
        }
        Ok(())
    }

    pub(crate) fn count_chunk(
        &self,
        step: &Step<'_>,
        range: Range<usize>,
    ) -> Result<(u64, u64, u64, u64), RuntimeError> {
        let syms = &step.input.syms[range.clone()];
        let (mut m, mut w, mut iw, mut wi) = (0u64, 0u64, 0u64, 0u64);
        let mut worker: Option<Worker> = None;
        let compact = self.compact();
        // A walked input's words of the chunk (where the next chunk's
        // begin).
        let walks = step.input.walks();
        for (k, &sym) in syms.iter().enumerate() {
            let s = sym as usize;
            if walks {
                wi += u64::from(self.sym_words[s]);
            }
            let (f, len, words) = self.counts[s];
            if f != SLOW {
                m += u64::from(len);
                w += u64::from(words);
                if compact {
                    iw += u64::from(self.implicit_words_of(s));
                }
                continue;
            }
            let wk = worker.get_or_insert_with(|| self.worker());
            match self.decide(step, wk, range.start + k)? {
                Some((alt, _)) => {
                    let plan = &self.plans[alt as usize];
                    m += u64::from(plan.len);
                    w += u64::from(plan.words);
                    iw += u64::from(self.implicit_alt[alt as usize]);
                }
                None => {
                    m += 1;
                    w += u64::from(self.sym_words[s]);
                    iw += u64::from(self.implicit_sym[s]);
                }
            }
        }
        Ok((m, w, iw, wi))
    }

    /// [`Engine::rewrite_chunk`] compiled for AVX2 where the CPU has it
    /// (its fixed-size moves in 32-byte registers), else for the baseline.
    /// The same f32 operations either way (Rust never fuses a multiply
    /// and an add), so the same bits.
    pub(crate) fn rewrite_chunk_best<const K: bool, R: Replay>(
        &self,
        step: &Step<'_>,
        out: ChunkOut<'_>,
        replay: &mut R,
    ) -> Result<(), RuntimeError> {
        #[cfg(target_arch = "x86_64")]
        if crate::cpu::avx2() {
            // SAFETY: the CPU has AVX2 (checked just above), the only
            // feature `rewrite_chunk_avx2` is compiled for beyond the
            // baseline.
            #[allow(unsafe_code)]
            return unsafe { self.rewrite_chunk_avx2::<K, R>(step, out, replay) };
        }
        self.rewrite_chunk::<K, R>(step, out, replay)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn rewrite_chunk_avx2<const K: bool, R: Replay>(
        &self,
        step: &Step<'_>,
        out: ChunkOut<'_>,
        replay: &mut R,
    ) -> Result<(), RuntimeError> {
        self.rewrite_chunk::<K, R>(step, out, replay)
    }

    /// Rewrite one chunk; `K`: the engine is keyed (write every output
    /// module's identity key: a copied module keeps its key, a successor
    /// module gets `child_key(parent key, salt)`). `replay`: the edits'
    /// hooks (`()`: none, the plain loop; see [`Replay`]).
    #[inline(always)]
    fn rewrite_chunk<const K: bool, R: Replay>(
        &self,
        step: &Step<'_>,
        out: ChunkOut<'_>,
        replay: &mut R,
    ) -> Result<(), RuntimeError> {
        let ChunkOut {
            range,
            syms: osyms,
            keys: okeys,
            starts: ostarts,
            params: oparams,
            word_base,
            word_in,
        } = out;
        let input = step.input;
        let mut worker = self.worker();
        let (mut o, mut wo) = (0usize, 0usize);
        // The input's words are walked with the modules: every module has
        // its symbol's word count (`check_input`, and the engine's own
        // strings), so `starts` is not read.
        let mut wi = word_in;
        // The tables, hoisted out of the loop (the compiler reloads fields
        // behind `self` after every store otherwise).
        let (acts, plans, sym_words) = (&self.acts[..], &self.plans[..], &self.sym_words[..]);
        let (ariths, tpls, fans) = (&self.ariths[..], &self.tpl[..], &self.fans[..]);
        let (ikeys, salts) = (step.keys, &self.succ_salts[..]);
        /// `ksucc`: the module was copied (keeps its key).
        const KCOPY: u32 = u32::MAX;
        // Where the next successor goes: the chunk's slices, reborrowed.
        macro_rules! out_at {
            ($o:expr, $wo:expr) => {
                Out {
                    syms: &mut *osyms,
                    starts: &mut *ostarts,
                    params: &mut *oparams,
                    word_base,
                    o: $o,
                    wo: $wo,
                }
            };
        }
        let (isyms, istarts, iparams) = (&input.syms[..], &input.starts[..], &input.params[..]);
        // The input stores no word (no starts) or walks them, the output
        // stores none or walks them.
        let (ino, ono) = (istarts.is_empty(), ostarts.is_empty());
        let iwalk = ino && !iparams.is_empty();
        let copies = &self.copies[..];
        let end = range.end;
        let mut i = range.start;
        while i < end {
            let sym = isyms[i];
            let s = sym as usize;
            if copies[s] {
                // A run of copied modules, moved whole: one branch per run
                // instead of a dispatch per module (Hilbert 3D's `F` and
                // turns between its rewritten symbols).
                let mut j = i + 1;
                let wj = if iwalk {
                    // Walked words: the widths added up while the run is
                    // found (one pass over it).
                    let mut wj = wi + sym_words[s] as usize;
                    while j < end {
                        let t = isyms[j] as usize;
                        if !copies[t] {
                            break;
                        }
                        wj += sym_words[t] as usize;
                        j += 1;
                    }
                    wj
                } else {
                    while j < end && copies[isyms[j] as usize] {
                        j += 1;
                    }
                    if ino { wi } else { istarts[j] as usize }
                };
                let len = j - i;
                let words = wj - wi;
                if len == 1 {
                    // One module (a turn between two rewritten `F`s):
                    // three stores, not three block moves.
                    osyms[o] = sym;
                    if !ono {
                        ostarts[o] = word_base + wo as u32;
                    }
                    if words == 1 {
                        oparams[wo] = iparams[wi];
                    } else {
                        copy_small(&mut oparams[wo..wo + words], &iparams[wi..wj]);
                    }
                    if K {
                        okeys[o] = ikeys[i];
                        replay.copied(i..j, o);
                    }
                    o += 1;
                    wo += words;
                    wi = wj;
                    i = j;
                    continue;
                }
                if ono {
                    // Symbols only.
                    if len <= PAD && i + PAD <= isyms.len() && o + PAD <= osyms.len() {
                        osyms[o..o + PAD].copy_from_slice(&isyms[i..i + PAD]);
                    } else {
                        copy_small(&mut osyms[o..o + len], &isyms[i..j]);
                    }
                } else if ino {
                    // No input word: every start is the output's position;
                    // walked input words: the widths added up.
                    copy_small(&mut osyms[o..o + len], &isyms[i..j]);
                    if iwalk {
                        let mut at = word_base + wo as u32;
                        for (d, &t) in ostarts[o..o + len].iter_mut().zip(&isyms[i..j]) {
                            *d = at;
                            at += sym_words[t as usize];
                        }
                    } else {
                        ostarts[o..o + len].fill(word_base + wo as u32);
                    }
                } else {
                    // The input's starts shifted to the output's words.
                    let delta = (word_base + wo as u32).wrapping_sub(istarts[i]);
                    if len <= PAD && i + PAD <= isyms.len() && o + PAD <= osyms.len() {
                        // Fixed-size moves (see `PAD`; the chunk's `starts`
                        // is as long as its `syms`, the input's one longer).
                        osyms[o..o + PAD].copy_from_slice(&isyms[i..i + PAD]);
                        for (d, &st) in ostarts[o..o + PAD].iter_mut().zip(&istarts[i..i + PAD]) {
                            *d = st.wrapping_add(delta);
                        }
                    } else {
                        copy_small(&mut osyms[o..o + len], &isyms[i..j]);
                        for (d, &st) in ostarts[o..o + len].iter_mut().zip(&istarts[i..j]) {
                            *d = st.wrapping_add(delta);
                        }
                    }
                }
                if words > 0 {
                    if words <= PAD && wi + PAD <= iparams.len() && wo + PAD <= oparams.len() {
                        oparams[wo..wo + PAD].copy_from_slice(&iparams[wi..wi + PAD]);
                    } else {
                        copy_small(&mut oparams[wo..wo + words], &iparams[wi..wj]);
                    }
                }
                if K {
                    copy_small(&mut okeys[o..o + len], &ikeys[i..j]);
                    replay.copied(i..j, o);
                }
                o += len;
                wo += words;
                wi = wj;
                i = j;
                continue;
            }
            // Keyed: the output position of this module's successor and its
            // first successor module (or `KCOPY`).
            let o0 = o;
            let mut ksucc = KCOPY;
            // An edit's forced alternative: the general road (`()`: never).
            let forced = replay.force(i);
            match if forced != 0 { Act::Slow } else { acts[s] } {
                // Copies are moved as runs above; these two arms keep the
                // per-module form of the same writes.
                Act::Copy0 => {
                    osyms[o] = sym;
                    if !ono {
                        ostarts[o] = word_base + wo as u32;
                    }
                    o += 1;
                }
                Act::Copy(n) => {
                    let n = n as usize;
                    osyms[o] = sym;
                    if !ono {
                        ostarts[o] = word_base + wo as u32;
                    }
                    if n == 1 {
                        oparams[wo] = input.params[wi];
                    } else {
                        copy_small(&mut oparams[wo..wo + n], &input.params[wi..wi + n]);
                    }
                    o += 1;
                    wo += n;
                    wi += n;
                }
                Act::Unit(u) => {
                    let v = input.params[wi] * u.m + u.a;
                    if !v.is_finite() {
                        return Err(self.runtime(
                            step,
                            i,
                            RuntimeErrorKind::NonFinite { value: v },
                            self.sys.param_spans[u.span as usize],
                        ));
                    }
                    osyms[o] = u.sym;
                    if !ono {
                        ostarts[o] = word_base + wo as u32;
                    }
                    oparams[wo] = v;
                    o += 1;
                    wo += 1;
                    wi += 1;
                    ksucc = u.succ;
                }
                Act::Plan(alt) => {
                    let plan = plans[alt as usize];
                    let n = sym_words[s] as usize;
                    let mut out = out_at!(o, wo);
                    ksucc = plan.succ;
                    if plan.words == 0 {
                        // Symbols only (Koch curves, Hilbert curves).
                        self.emit_syms(plan, &mut out);
                    } else {
                        let bind = &input.params[wi..wi + n];
                        if plan.arith {
                            self.emit_arith(step, plan, bind, i, &mut out)?;
                        } else {
                            self.emit(step, &mut worker, alt, bind, i, &mut out)?;
                        }
                    }
                    o += plan.len as usize;
                    wo += plan.words as usize;
                    wi += n;
                }
                Act::Small(alt) => {
                    let plan = plans[alt as usize];
                    ksucc = plan.succ;
                    let n = sym_words[s] as usize;
                    let mut spare = [0.0f32; PAD];
                    let b: &[f32; PAD] = match input.params.get(wi..wi + PAD) {
                        // A slice of `PAD` words.
                        Some(w) => w.try_into().unwrap_or(&spare),
                        None => {
                            spare[..n].copy_from_slice(&input.params[wi..wi + n]);
                            &spare
                        }
                    };
                    let mut out = out_at!(o, wo);
                    self.emit_syms(plan, &mut out);
                    let words = plan.words as usize;
                    let ariths = &ariths[plan.patch_lo as usize..plan.patch_hi as usize];
                    let t = plan.tpl as usize;
                    // `tpl` is padded with `PAD` words.
                    let tpl: &[f32; PAD] = tpls[t..t + PAD].try_into().unwrap_or(&[0.0; PAD]);
                    // Bit 31 set where a value is not finite: its exponent
                    // is all ones, and one more carries into bit 31.
                    let mut bad = 0u32;
                    let room = oparams
                        .get_mut(wo..wo + PAD)
                        .and_then(|d| <&mut [f32; PAD]>::try_from(d).ok());
                    match room {
                        Some(d) => {
                            *d = *tpl;
                            for p in ariths {
                                // In range (`Act::Small`); the masks only
                                // spare the bounds checks.
                                let v = b[p.src as usize % PAD] * p.m + p.a;
                                bad |= (v.to_bits() & 0x7f80_0000) + 0x0080_0000;
                                d[p.dst as usize % PAD] = v;
                            }
                        }
                        None => {
                            let d = &mut oparams[wo..wo + words];
                            d.copy_from_slice(&tpl[..words]);
                            for p in ariths {
                                let v = b[p.src as usize % PAD] * p.m + p.a;
                                bad |= (v.to_bits() & 0x7f80_0000) + 0x0080_0000;
                                d[p.dst as usize] = v;
                            }
                        }
                    }
                    if bad & 0x8000_0000 != 0 {
                        let patches = &self.patches[plan.patch_lo as usize..plan.patch_hi as usize];
                        return Err(self.non_finite(step, i, &oparams[wo..wo + words], patches));
                    }
                    o += plan.len as usize;
                    wo += words;
                    wi += n;
                }
                Act::Fan(f) => {
                    let fan = &fans[f as usize];
                    let plan = fan.plan;
                    ksucc = plan.succ;
                    let (v, bad) = fan.apply(iparams[wi + fan.src as usize]);
                    let mut out = out_at!(o, wo);
                    self.emit_syms(plan, &mut out);
                    let words = plan.words as usize;
                    match oparams.get_mut(wo..wo + PAD) {
                        Some(d) => d.copy_from_slice(&v),
                        None => oparams[wo..wo + words].copy_from_slice(&v[..words]),
                    }
                    if bad {
                        let patches = &self.patches[plan.patch_lo as usize..plan.patch_hi as usize];
                        return Err(self.non_finite(step, i, &oparams[wo..wo + words], patches));
                    }
                    o += plan.len as usize;
                    wo += words;
                    wi += sym_words[s] as usize;
                }
                Act::Slow => {
                    let n = sym_words[s] as usize;
                    let decided = if forced != 0 {
                        self.decide_in::<true>(step, &mut worker, i, forced)?
                    } else {
                        self.decide(step, &mut worker, i)?
                    };
                    match decided {
                        None => {
                            osyms[o] = sym;
                            if !ono {
                                ostarts[o] = word_base + wo as u32;
                            }
                            copy_small(&mut oparams[wo..wo + n], &input.params[wi..wi + n]);
                            o += 1;
                            wo += n;
                        }
                        Some((alt, binds)) => {
                            let mut out = out_at!(o, wo);
                            if binds == Binds::Buffer {
                                // The bindings live in the worker; move the
                                // buffer out for the call (no allocation: a
                                // swap).
                                let buf = std::mem::take(&mut worker.buf);
                                let r = self.emit(step, &mut worker, alt, &buf, i, &mut out);
                                worker.buf = buf;
                                r?;
                            } else {
                                let bind = &input.params[wi..wi + n];
                                self.emit(step, &mut worker, alt, bind, i, &mut out)?;
                            }
                            let plan = plans[alt as usize];
                            o += plan.len as usize;
                            wo += plan.words as usize;
                            ksucc = plan.succ;
                        }
                    }
                    wi += n;
                }
            }
            if K {
                let key = ikeys[i];
                if ksucc == KCOPY {
                    okeys[o0] = key;
                    replay.copied(i..i + 1, o0);
                } else {
                    let salts = &salts[ksucc as usize..][..o - o0];
                    for (k, &salt) in okeys[o0..o].iter_mut().zip(salts) {
                        *k = rng::child_key_premixed(key, salt);
                    }
                    let made = Made {
                        succ: ksucc,
                        keys: &okeys[o0..o],
                        syms: &osyms[o0..o],
                        starts: if ono { &[] } else { &ostarts[o0..o] },
                        word_base,
                    };
                    replay.made(i, o0, made, oparams)?;
                }
            }
            i += 1;
        }
        Ok(())
    }

    /// Write alternative `plan`'s symbols, starts and constant words at
    /// `out.o` / `out.wo` (the patches are the caller's).
    #[inline(always)]
    fn emit_template(&self, plan: Plan, out: &mut Out<'_>) {
        self.emit_syms(plan, out);
        let (t, words, wo) = (plan.tpl as usize, plan.words as usize, out.wo);
        if words == 0 {
            return;
        }
        if words <= PAD && wo + PAD <= out.params.len() {
            out.params[wo..wo + PAD].copy_from_slice(&self.tpl[t..t + PAD]);
        } else if words <= 2 * PAD && wo + 2 * PAD <= out.params.len() {
            // The same in `2 * PAD` (the Koch island's 15 words, the
            // bracketed plant's 12).
            out.params[wo..wo + 2 * PAD].copy_from_slice(&self.tpl[t..t + 2 * PAD]);
        } else {
            copy_small(&mut out.params[wo..wo + words], &self.tpl[t..t + words]);
        }
    }

    /// Write alternative `plan`'s symbols and starts at `out.o`.
    #[inline(always)]
    fn emit_syms(&self, plan: Plan, out: &mut Out<'_>) {
        let (so, len) = (plan.succ as usize, plan.len as usize);
        let (o, wo) = (out.o, out.wo);
        let base = out.word_base + wo as u32;
        if out.starts.is_empty() {
            // The output stores no word: symbols only.
            if len <= PAD && o + PAD <= out.syms.len() {
                out.syms[o..o + PAD].copy_from_slice(&self.succ_syms[so..so + PAD]);
            } else if len <= 2 * PAD && o + 2 * PAD <= out.syms.len() {
                out.syms[o..o + 2 * PAD].copy_from_slice(&self.succ_syms[so..so + 2 * PAD]);
            } else {
                copy_small(&mut out.syms[o..o + len], &self.succ_syms[so..so + len]);
            }
            return;
        }
        if len <= PAD && o + PAD <= out.syms.len() {
            // Fixed-size moves (see `PAD`); `starts` has the same length.
            out.syms[o..o + PAD].copy_from_slice(&self.succ_syms[so..so + PAD]);
            let offs = &self.succ_words[so..so + PAD];
            for (st, off) in out.starts[o..o + PAD].iter_mut().zip(offs) {
                *st = base + off;
            }
        } else if len <= 2 * PAD && o + 2 * PAD <= out.syms.len() {
            // The same in `2 * PAD` (Koch curves, bracketed plants).
            out.syms[o..o + 2 * PAD].copy_from_slice(&self.succ_syms[so..so + 2 * PAD]);
            let starts = &mut out.starts[o..o + 2 * PAD];
            if plan.words == 0 {
                starts.fill(base);
            } else {
                for (st, off) in starts.iter_mut().zip(&self.succ_words[so..so + 2 * PAD]) {
                    *st = base + off;
                }
            }
        } else {
            copy_small(&mut out.syms[o..o + len], &self.succ_syms[so..so + len]);
            let starts = &mut out.starts[o..o + len];
            if plan.words == 0 {
                starts.fill(base);
            } else {
                for (st, off) in starts.iter_mut().zip(&self.succ_words[so..so + len]) {
                    *st = base + off;
                }
            }
        }
    }

    /// [`Engine::emit`] for a plan whose patches are all [`Patch::Arith`]:
    /// no dispatch per patch, one test for non-finite values.
    #[inline(always)]
    fn emit_arith(
        &self,
        step: &Step<'_>,
        plan: Plan,
        bind: &[f32],
        position: usize,
        out: &mut Out<'_>,
    ) -> Result<(), RuntimeError> {
        self.emit_template(plan, out);
        let patches = &self.patches[plan.patch_lo as usize..plan.patch_hi as usize];
        let params = &mut out.params[out.wo..out.wo + plan.words as usize];
        let mut finite = true;
        for p in patches {
            if let Patch::Arith { dst, src, m, a, .. } = *p {
                let v = bind[src as usize] * m + a;
                finite &= v.is_finite();
                params[dst as usize] = v;
            }
        }
        if finite {
            return Ok(());
        }
        Err(self.non_finite(step, position, params, patches))
    }

    /// The error for the first of `patches` (arithmetic, in the
    /// successor's order, as `emit` reports it) whose word in `params` is
    /// not finite.
    #[cold]
    fn non_finite(
        &self,
        step: &Step<'_>,
        position: usize,
        params: &[f32],
        patches: &[Patch],
    ) -> RuntimeError {
        let bad = patches.iter().find_map(|p| match *p {
            Patch::Arith { dst, span, .. } => params
                .get(dst as usize)
                .filter(|v| !v.is_finite())
                .map(|&v| (v, span)),
            _ => None,
        });
        // Unreachable: the callers found a non-finite patched word. The
        // fallback still names the module.
        let (value, span) = bad.unwrap_or((f32::NAN, 0));
        self.runtime(
            step,
            position,
            RuntimeErrorKind::NonFinite { value },
            self.sys
                .param_spans
                .get(span as usize)
                .copied()
                .unwrap_or_default(),
        )
    }

    /// Write alternative `alt`'s successor for the module at `position`.
    #[inline(always)]
    pub(crate) fn emit(
        &self,
        step: &Step<'_>,
        worker: &mut Worker,
        alt: u32,
        bind: &[f32],
        position: usize,
        out: &mut Out<'_>,
    ) -> Result<(), RuntimeError> {
        let sys = self.sys;
        let plan = self.plans[alt as usize];
        self.emit_template(plan, out);
        if plan.patch_lo == plan.patch_hi {
            return Ok(());
        }
        let params = &mut out.params[out.wo..out.wo + plan.words as usize];
        for p in &self.patches[plan.patch_lo as usize..plan.patch_hi as usize] {
            let (dst, value, span) = match *p {
                Patch::Copy { dst, src, words } => {
                    let (d, s, w) = (dst as usize, src as usize, words as usize);
                    params[d..d + w].copy_from_slice(&bind[s..s + w]);
                    continue;
                }
                Patch::Arith {
                    dst,
                    src,
                    m,
                    a,
                    span,
                } => (dst, bind[src as usize] * m + a, span),
                Patch::Code {
                    dst,
                    entry,
                    words,
                    span,
                } => {
                    let draws = step.draws(position);
                    let v = worker
                        .vm
                        .run(&sys.code, &sys.consts, entry, bind, &draws)
                        .map_err(|e| self.fault(step, position, e))?;
                    let d = dst as usize;
                    for (o, &x) in params[d..d + words as usize].iter_mut().zip(v) {
                        if !x.is_finite() {
                            return Err(self.runtime(
                                step,
                                position,
                                RuntimeErrorKind::NonFinite { value: x },
                                sys.param_spans[span as usize],
                            ));
                        }
                        *o = x;
                    }
                    continue;
                }
            };
            if !value.is_finite() {
                return Err(self.runtime(
                    step,
                    position,
                    RuntimeErrorKind::NonFinite { value },
                    sys.param_spans[span as usize],
                ));
            }
            params[dst as usize] = value;
        }
        Ok(())
    }

    pub(crate) fn runtime(
        &self,
        step: &Step<'_>,
        position: usize,
        kind: RuntimeErrorKind,
        span: grm_diag::Span,
    ) -> RuntimeError {
        let symbol = step
            .input
            .syms
            .get(position)
            .and_then(|&s| self.sys.symbol_names.get(s as usize))
            .cloned()
            .unwrap_or_else(|| "axiom".to_string());
        RuntimeError {
            iteration: step.iteration,
            position: position as u64,
            symbol,
            kind,
            file: self.sys.file,
            span,
        }
    }

    fn fault(&self, step: &Step<'_>, position: usize, e: grm_compile::vm::VmError) -> RuntimeError {
        let span = self.sys.span_at(e.pc).unwrap_or(self.sys.span);
        self.runtime(step, position, RuntimeErrorKind::Fault(e), span)
    }

    /// Decide the production for the module at `i`: the alternative and
    /// where its bindings are, or `None` to copy the module.
    pub(crate) fn decide(
        &self,
        step: &Step<'_>,
        worker: &mut Worker,
        i: usize,
    ) -> Result<Option<(u32, Binds)>, RuntimeError> {
        self.decide_in::<false>(step, worker, i, 0)
    }

    /// [`Engine::decide`]; `F`: a persistent edit forces alternative
    /// `force` (from 1) of the group that applies, when it has that many
    /// (else the group races as written).
    #[inline(always)]
    pub(crate) fn decide_in<const F: bool>(
        &self,
        step: &Step<'_>,
        worker: &mut Worker,
        i: usize,
        force: u32,
    ) -> Result<Option<(u32, Binds)>, RuntimeError> {
        let sys = self.sys;
        let input = step.input;
        let sym = input.syms[i];
        let std::ops::Range { start: ps, end: pe } = input.stored(i);
        let draws = step.draws(i);
        for g in sys.groups_of(sym) {
            let direct = g.pred_bind_offset == 0 && g.bind_words == g.pred_bind_words;
            if g.flags & GROUP_CONTEXT != 0 {
                let left = &sys.context[g.left_offset as usize..][..g.left_len as usize];
                let right = &sys.context[g.right_offset as usize..][..g.right_len as usize];
                if !self.match_left(step, &mut worker.buf, i, left)
                    || !self.match_right(step, &mut worker.buf, i, right)
                {
                    continue;
                }
            }
            if !direct && g.pred_bind_words > 0 {
                let o = g.pred_bind_offset as usize;
                worker.buf[o..o + (pe - ps)].copy_from_slice(&input.params[ps..pe]);
            }
            let bind: &[f32] = if direct {
                &input.params[ps..pe]
            } else {
                &worker.buf[..g.bind_words as usize]
            };
            if g.cond_code != NONE {
                let c = worker
                    .vm
                    .run1(&sys.code, &sys.consts, g.cond_code, bind, &draws)
                    .map_err(|e| self.fault(step, i, e))?;
                if c == 0.0 {
                    continue;
                }
            }
            let binds = if direct { Binds::Direct } else { Binds::Buffer };
            if F && force >= 1 && force <= g.alt_count {
                return Ok(Some((g.first_alt + force - 1, binds)));
            }
            if g.alt_count == 1 {
                return Ok(Some((g.first_alt, binds)));
            }
            let alt = select::choose_alternative(
                sys,
                g,
                &mut worker.vm,
                bind,
                &draws,
                &mut worker.weights,
            )
            .map_err(|e| match e {
                AltError::Fault(e) => self.fault(step, i, e),
                AltError::BadWeight { value, alt } => self.runtime(
                    step,
                    i,
                    RuntimeErrorKind::BadWeight { value },
                    sys.weight_spans[alt as usize],
                ),
            })?;
            return Ok(Some((alt, binds)));
        }
        Ok(None)
    }

    /// Bind a matched context module's parameters.
    fn bind(&self, step: &Step<'_>, buf: &mut [f32], pos: usize, item: &ContextItem) {
        if item.bind_words > 0 {
            let input = step.input;
            let std::ops::Range { start: s, end: e } = input.stored(pos);
            let o = item.bind_offset as usize;
            buf[o..o + (e - s)].copy_from_slice(&input.params[s..e]);
        }
    }

    /// Left context: the nearest modules on the path towards the root,
    /// stepping over complete branches `[ ... ]` (and out of the enclosing
    /// `[`), skipping ignored symbols. Items are matched nearest first.
    fn match_left(
        &self,
        step: &Step<'_>,
        buf: &mut [f32],
        i: usize,
        items: &[ContextItem],
    ) -> bool {
        let syms = &step.input.syms;
        let mut pos = i;
        for item in items.iter().rev() {
            // Find the next candidate before `pos`.
            loop {
                if pos == 0 {
                    return false;
                }
                pos -= 1;
                let s = syms[pos] as usize;
                match self.bracket[s] {
                    2 => {
                        let m = step.mate[pos];
                        if m == UNMATCHED {
                            return false;
                        }
                        // Continue before the branch's `[`.
                        pos = m as usize;
                    }
                    1 => {} // leave the enclosing branch: its parent is before it
                    _ if self.ignored[s] => {}
                    _ => break,
                }
            }
            if item.kind != CTX_SYMBOL || syms[pos] != item.symbol {
                return false;
            }
            self.bind(step, buf, pos, item);
        }
        true
    }

    /// Right context: the next modules forward in the current branch,
    /// stepping over lateral branches `[ ... ]` unless the context itself
    /// has `[` there, skipping ignored symbols; the branch ending (`]` or the
    /// end of the string) fails the match.
    fn match_right(
        &self,
        step: &Step<'_>,
        buf: &mut [f32],
        i: usize,
        items: &[ContextItem],
    ) -> bool {
        let syms = &step.input.syms;
        let n = syms.len();
        let mut pos = i + 1;
        for item in items {
            match item.kind {
                CTX_SYMBOL => {
                    loop {
                        if pos >= n {
                            return false;
                        }
                        let s = syms[pos] as usize;
                        match self.bracket[s] {
                            1 => {
                                let m = step.mate[pos];
                                if m == UNMATCHED {
                                    return false;
                                }
                                pos = m as usize + 1;
                            }
                            2 => return false,
                            _ if self.ignored[s] => pos += 1,
                            _ => break,
                        }
                    }
                    if syms[pos] != item.symbol {
                        return false;
                    }
                    self.bind(step, buf, pos, item);
                    pos += 1;
                }
                CTX_PUSH => {
                    // Enter the next lateral branch (ignored symbols may
                    // come before it).
                    loop {
                        if pos >= n {
                            return false;
                        }
                        let s = syms[pos] as usize;
                        if self.bracket[s] == 1 {
                            pos += 1;
                            break;
                        }
                        if self.bracket[s] == 0 && self.ignored[s] {
                            pos += 1;
                            continue;
                        }
                        return false;
                    }
                }
                _ => {
                    // `]`: the rest of the current branch is skipped, up to
                    // and including its `]`.
                    loop {
                        if pos >= n {
                            return false;
                        }
                        match self.bracket[syms[pos] as usize] {
                            2 => {
                                pos += 1;
                                break;
                            }
                            1 => {
                                let m = step.mate[pos];
                                if m == UNMATCHED {
                                    return false;
                                }
                                pos = m as usize + 1;
                            }
                            _ => pos += 1,
                        }
                    }
                }
            }
        }
        true
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

//! `grm-grow`: one road from a checked program to a grown model.
//!
//! Role: the library call that front-ends (`grmc`, the language server)
//! make to grow a system, instead of each assembling engine calls. It
//! derives with the CPU engine ([`Grower`]), records what names the parts
//! of the result (the modules' identity keys, the production that made
//! each module, the derivation tree), and writes the tree as JSON
//! ([`json`]). Sample-mode results (`grm_sample`) come in through
//! [`Tree::from_sampled`], so both modes give one tree type.
//!
//! Inputs: a compiled system (`grm_compile`), [`grm_derive::DeriveOptions`]
//! (iterations, seed, limits), a thread count and a [`Record`] (what to
//! record besides the string). Outputs: [`Grown`]: the final string (with
//! keys where asked or needed), per-iteration statistics, and optionally
//! the derivation [`Tree`] and the per-module origins.
//!
//! Invariants:
//! - Identity is the engines' (`grm_compile::rng`, "Identity keys"): a
//!   node's key is the key its module carries in the string; the tree is
//!   built from the engine's own decisions ([`grm_derive::Engine::
//!   decisions`]), never by aligning strings after the fact.
//! - Recording costs nothing when not asked for: without a tree or
//!   origins, [`Grower::derive`] is the engine's own derivation.
//! - The tree is held to the run's memory limit with the strings (a tree
//!   that would pass it stops the run with the engine's own
//!   `DeriveError::MemoryLimit`, R0202); its file is written whole or not
//!   at all.

pub mod json;
mod tree;

use std::time::Instant;

use grm_compile::CompiledSystem;
use grm_derive::{DeriveError, DeriveOptions, Engine, IterationStats, ModuleString};

pub use tree::{Tree, TreeMode, TreeNode};

/// What to record besides the final string.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Record {
    /// The derivation tree (implies keys).
    pub tree: bool,
    /// Per module of the final string, the compiled alternative that
    /// wrote it (the axiom's for the axiom's modules).
    pub origins: bool,
    /// Identity keys in the string even when the system draws nothing.
    pub keys: bool,
    /// Per module of the final string, whether it descends from an
    /// application of this compiled alternative (the preview's focus).
    pub focus: Option<u32>,
}

/// A grown string and what was recorded with it.
#[derive(Clone, Debug, Default)]
pub struct Grown {
    /// The final string; it carries keys when the system draws or when
    /// keys or a tree were asked for.
    pub string: ModuleString,
    /// One entry per string: the axiom, then each step.
    pub stats: Vec<IterationStats>,
    /// The derivation tree ([`Record::tree`]).
    pub tree: Option<Tree>,
    /// Per module of the final string: the compiled alternative that
    /// wrote it ([`Record::origins`]).
    pub origins: Option<Vec<u32>>,
    /// Per module of the final string: it descends from an application of
    /// [`Record::focus`].
    pub focus: Option<Vec<bool>>,
}

/// The CPU engine prepared for one system, with what to record.
#[derive(Debug)]
pub struct Grower<'a> {
    engine: Engine<'a>,
    record: Record,
}

impl<'a> Grower<'a> {
    /// `threads` as [`Engine::new`] takes it.
    pub fn new(
        sys: &'a CompiledSystem,
        threads: usize,
        record: Record,
    ) -> Result<Self, DeriveError> {
        let engine = Engine::new(sys, threads)?.with_keys(record.keys || record.tree);
        Ok(Grower { engine, record })
    }

    /// The engine (for callers that derive again, such as frames).
    pub fn engine(&self) -> &Engine<'a> {
        &self.engine
    }

    /// Derive `opts.iterations` steps; `progress` sees each string's
    /// figures (the axiom's first) as soon as it is complete.
    pub fn derive(
        &self,
        opts: &DeriveOptions,
        progress: &mut dyn FnMut(&IterationStats),
    ) -> Result<Grown, DeriveError> {
        let never = || false;
        // Never stopped: always grown.
        self.derive_until(opts, progress, &never)
            .map(Option::unwrap_or_default)
    }

    /// [`Grower::derive`], asking `stop` before each step (and before the
    /// tree or origins are recorded): `Ok(None)` when it said stop (a
    /// preview superseded by a newer one). Without anything to record the
    /// whole derivation is the engine's, and `stop` is asked once.
    pub fn derive_until(
        &self,
        opts: &DeriveOptions,
        progress: &mut dyn FnMut(&IterationStats),
        stop: &dyn Fn() -> bool,
    ) -> Result<Option<Grown>, DeriveError> {
        let r = self.record;
        if !r.tree && !r.origins && r.focus.is_none() {
            if stop() {
                return Ok(None);
            }
            let d = self.engine.derive(opts, progress)?;
            return Ok(Some(Grown {
                string: d.string,
                stats: d.stats,
                tree: None,
                origins: None,
                focus: None,
            }));
        }
        let sys = self.engine.system();
        let t = Instant::now();
        let mut string = self.engine.axiom(opts.seed)?;
        let mut stats = vec![IterationStats::of(&string, 0, 0, 0, t.elapsed())];
        progress(&stats[0]);
        let mut tree = self
            .record
            .tree
            .then(|| Tree::axiom(sys, opts.seed, &string));
        let mut origins = self
            .record
            .origins
            .then(|| vec![sys.axiom_alt; string.len()]);
        let mut focus = r.focus.map(|f| vec![f == sys.axiom_alt; string.len()]);
        let (mut cumulative, mut processed) = (0u64, 0u64);
        for iteration in 1..=opts.iterations {
            if stop() {
                return Ok(None);
            }
            let t = Instant::now();
            let decided = self.engine.decisions(&string, iteration, opts.seed)?;
            let next = self
                .engine
                .step(&string, iteration, opts.seed, &opts.limits)?;
            if let Some(tree) = &mut tree {
                // The tree grows by the new string's rewritten modules.
                let grown = tree.nodes.len() as u64 + next.len() as u64;
                let bytes = grown * tree::NODE_BYTES
                    + string.heap_bytes() as u64
                    + next.heap_bytes() as u64;
                if bytes > opts.limits.max_bytes {
                    return Err(DeriveError::MemoryLimit {
                        iteration,
                        bytes,
                        limit: opts.limits.max_bytes,
                        modules: next.len() as u64,
                        words: next.params.len() as u64,
                        file: sys.file,
                        span: sys.span,
                    });
                }
                tree.advance(sys, iteration, &decided, &next);
            }
            if let Some(o) = &mut origins {
                let mut out = Vec::with_capacity(next.len());
                for (i, d) in decided.iter().enumerate() {
                    match *d {
                        None => out.push(o[i]),
                        Some(a) => {
                            let n = sys.alts[a as usize].succ_len as usize;
                            out.extend(std::iter::repeat_n(a, n));
                        }
                    }
                }
                *o = out;
            }
            if let (Some(f), Some(alt)) = (&mut focus, r.focus) {
                let mut out = Vec::with_capacity(next.len());
                for (i, d) in decided.iter().enumerate() {
                    match *d {
                        None => out.push(f[i]),
                        Some(a) => {
                            let n = sys.alts[a as usize].succ_len as usize;
                            out.extend(std::iter::repeat_n(f[i] || a == alt, n));
                        }
                    }
                }
                *f = out;
            }
            processed += string.len() as u64;
            self.engine.recycle(std::mem::replace(&mut string, next));
            cumulative += string.len() as u64;
            let s = IterationStats::of(&string, iteration, cumulative, processed, t.elapsed());
            progress(&s);
            stats.push(s);
        }
        if let Some(tree) = &mut tree {
            tree.finish(&string);
        }
        Ok(Some(Grown {
            string,
            stats,
            tree,
            origins,
            focus,
        }))
    }
}

//! `grm-grow`: one road from a checked program to a grown model.
//!
//! Role: the library call that front-ends (`grmc`, the language server)
//! make to grow a system, instead of each assembling engine calls (as
//! rust-analyzer's `ide` crate serves its LSP). Every mode plugs in here
//! once, and the identity of the parts (the modules' keys, the production
//! that made each module, the derivation tree) is recorded here once:
//!
//! - derive mode, one tree ([`Grower`]): the CPU engine (`grm_derive`) or,
//!   behind the same call, the GPU engine (`grm_gpu`, `Backend::Gpu`,
//!   with the `gpu` feature), with the fall back to the CPU and the CPU's
//!   report of a production's run-time error;
//! - sample mode ([`sample::sample`]): the guided sampler (`grm_sample`)
//!   with curves, particle schedule, budget, cancellation and limits, the
//!   model shown (the result or one generation's frame) and its tree;
//! - a forest ([`forest::grow`]): many trees (systems, seeds, parameter
//!   values) on the CPU, one tree per worker, or as one GPU derivation,
//!   each tree interpreted, held to the forest's module and memory limits.
//!
//! The derivation tree is one type for both modes ([`Tree`]), written as
//! JSON by [`json`] (`--tree`). Persistent edits: derive mode's plan and
//! classes in [`edits`], shape mode's in [`shape`]; an edit that lost its
//! part gets retarget candidates ([`retarget`]: derive and sample mode by
//! symbol, ancestry and place in the tree; [`shape::retarget`]: Lipp's
//! ordering values).
//!
//! Inputs: a compiled system (`grm_compile`; its `param_values` are the
//! run's parameters) and the checked system it came from, the options of
//! the mode (iterations, seed, limits; curves and the sampler's options;
//! the trees of a forest), a [`Backend`] and a [`Record`] (what to record
//! besides the string). Outputs: [`Grown`] (the final string, with keys
//! where asked or needed, per-string statistics, optionally the tree, the
//! per-module origins and focus flags, and the GPU's report of its run),
//! [`sample::Sampled`] (the search's result, the models shown, the tree),
//! [`forest::Forest`] (each tree's modules, interpretation and whatever the
//! caller kept of its string). Errors are typed ([`GrowError`],
//! `grm_sample::SampleError`, [`forest::ForestError`]); how they are shown
//! and which exit code they give is the front-end's.
//!
//! Invariants:
//! - Identity is the engines' (`grm_compile::rng`, "Identity keys"): a
//!   node's key is the key its module carries in the string; the tree is
//!   built from the engine's own decisions ([`grm_derive::Engine::
//!   decisions`]), never by aligning strings after the fact. Keys asked for
//!   ([`Record::keys`]) are the same on either engine (the GPU is asked to
//!   carry them: `grm_gpu::GpuDeriveOptions::keys`).
//! - Recording costs nothing when not asked for: without a tree or
//!   origins, [`Grower::derive`] is the engine's own derivation.
//! - The tree is held to the run's memory limit with the strings (a tree
//!   that would pass it stops the run with the engine's own
//!   `DeriveError::MemoryLimit`, R0202); its file is written whole or not
//!   at all.
//! - Either backend gives the same string (the engines agree module for
//!   module; docs/gpu.md): the choice changes the time, never the model.

mod derive;
pub mod edits;
pub mod forest;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod json;
pub mod retarget;
pub mod sample;
pub mod shape;
mod tree;

use grm_derive::{DeriveError, IterationStats, ModuleString};
use grm_diag::{Diagnostic, FileId, Span};

pub use derive::Grower;
pub use tree::{RemovedPart, Tree, TreeMode, TreeNode};

/// What to record besides the final string.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Record {
    /// The derivation tree (implies keys; the CPU engine only).
    pub tree: bool,
    /// Per module of the final string, the compiled alternative that
    /// wrote it (the axiom's for the axiom's modules; the CPU engine only).
    pub origins: bool,
    /// Identity keys in the string even when the system draws nothing
    /// (either engine).
    pub keys: bool,
    /// Per module of the final string, whether it descends from an
    /// application of this compiled alternative (the preview's focus; the
    /// CPU engine only).
    pub focus: Option<u32>,
}

impl Record {
    /// Whether anything is asked for that only the CPU engine records
    /// (the engine's decisions, step by step).
    pub fn needs_decisions(&self) -> bool {
        self.tree || self.origins || self.focus.is_some()
    }
}

/// Which engine derives.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Backend {
    /// The CPU engine (`grm_derive`).
    #[default]
    Cpu,
    /// The GPU engine (`grm_gpu`), with what to do when it cannot.
    #[cfg(feature = "gpu")]
    Gpu(gpu::GpuChoice),
}

/// What a growth reports while it runs.
#[derive(Debug)]
pub enum Event<'e> {
    /// The CPU engine starts deriving (also after a fall back from the
    /// GPU).
    Cpu,
    /// The GPU engine starts deriving on this device.
    #[cfg(feature = "gpu")]
    Gpu(&'e grm_gpu::Gpu),
    /// The GPU cannot derive this (no device, or the derivation outgrows
    /// it): the CPU derives instead ([`gpu::GpuChoice::fallback`]).
    #[cfg(feature = "gpu")]
    FellBack(&'e grm_gpu::GpuError),
    /// A string is complete (the axiom's first): its figures, and whether
    /// the GPU made it (a GPU run derives its first, small strings on the
    /// CPU).
    Step {
        stats: &'e IterationStats,
        on_gpu: bool,
    },
}

/// A grown string and what was recorded with it.
#[derive(Clone, Debug, Default)]
pub struct Grown {
    /// The final string; it carries keys when the system draws or when
    /// keys or a tree were asked for. Empty when a GPU run left it on the
    /// device (`gpu::GpuChoice::read_string` false; `stats` has its
    /// size).
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
    /// What the persistent edits met, when the grower replayed some
    /// ([`Grower::with_edits`]; classify them with [`edits::classify`]).
    pub edits: Option<grm_derive::EditOutcome>,
    /// The GPU's run (its path, timings, interpretation; the string moved
    /// to [`Grown::string`]) when the GPU derived it.
    #[cfg(feature = "gpu")]
    pub gpu: Option<grm_gpu::GpuRun>,
}

/// Why a growth stopped.
#[derive(Clone, Debug, PartialEq)]
pub enum GrowError {
    /// The CPU engine's error (a limit, a production's run-time error,
    /// threads), also the CPU's report of a run-time error the GPU met.
    Derive(DeriveError),
    /// The GPU's error, where the CPU did not take over.
    #[cfg(feature = "gpu")]
    Gpu(grm_gpu::GpuError),
    /// Something was asked that the backend does not record (a tree,
    /// origins or focus flags of a GPU run).
    Unsupported(&'static str),
}

impl From<DeriveError> for GrowError {
    fn from(e: DeriveError) -> Self {
        GrowError::Derive(e)
    }
}

impl std::fmt::Display for GrowError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            GrowError::Derive(e) => e.fmt(f),
            #[cfg(feature = "gpu")]
            GrowError::Gpu(e) => e.fmt(f),
            GrowError::Unsupported(what) => write!(f, "{what}"),
        }
    }
}

impl std::error::Error for GrowError {}

impl GrowError {
    /// The error as a diagnostic; those that name no place point at
    /// `span` of `file` (the system).
    pub fn to_diagnostic(&self, file: FileId, span: Span) -> Diagnostic {
        match self {
            GrowError::Derive(e) => e.to_diagnostic(file, span),
            #[cfg(feature = "gpu")]
            GrowError::Gpu(e) => e.to_diagnostic(file, span),
            GrowError::Unsupported(what) => Diagnostic::new(
                grm_diag::Code::GpuUnsupported,
                (*what).to_string(),
                file,
                span,
                "in this system",
            ),
        }
    }
}

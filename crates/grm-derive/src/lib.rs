//! `grm-derive`: the CPU derivation engine.
//!
//! Role: classic parallel L-system rewriting of a compiled system
//! ([`grm_compile::CompiledSystem`]) for N iterations: parametric,
//! stochastic, conditional and context-sensitive productions (bracket-aware,
//! with the ignore list; the matching rules are in docs/language.md,
//! "Context matching").
//!
//! Inputs: a compiled system, [`DeriveOptions`] (iterations, seed, limits)
//! and a thread count. Outputs: the derived [`ModuleString`] (the type the
//! turtle interpreter and the GPU engine share) with per-iteration
//! [`IterationStats`], or a typed [`DeriveError`] (limits exceeded, a NaN
//! parameter, a bad weight) that names the iteration, the module and the
//! source span.
//!
//! Invariants:
//! - Each iteration is count / exclusive scan / rewrite over chunks
//!   ([`engine`]); the output is byte-identical for any number of threads.
//! - The limits ([`DeriveLimits`]) are checked from the count pass, before
//!   the next string is allocated: a runaway grammar stops with an error,
//!   never by exhausting memory.
//! - No allocation per module in the hot loops; never a panic on any
//!   grammar the checker accepts.

mod brackets;
mod compact;
mod cpu;
pub mod edits;
pub mod engine;
mod error;
mod expand;
mod fan;
mod pages;
pub mod string;

pub use edits::{
    EditAction, EditOutcome, EditPlan, EditState, KeyEdits, KeyHits, KeyPlan, RemovedModule,
    SlotTarget, StepRecord, ValueOp,
};
pub use engine::{
    Derivation, DeriveLimits, DeriveOptions, Engine, IterationStats, MAX_THREADS, derive,
};
pub use error::{DeriveError, RuntimeError, RuntimeErrorKind};
pub use pages::{HugePageAlloc, LARGE_BYTES};
pub use string::ModuleString;

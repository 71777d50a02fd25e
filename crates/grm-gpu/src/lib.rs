//! `grm-gpu`: the GPU L-system engine (Lipp, chapter 5) on wgpu.
//!
//! Role: derive module strings and interpret them with compute kernels
//! written in WGSL (`shaders/` at the repository root).
//!
//! Inputs: a compiled program (packed production tables, expression
//! bytecode and constant pool from `grm-compile`) and an axiom; or a
//! [`grm_derive::ModuleString`]-shaped string to interpret.
//!
//! Outputs: the derived module string (the same flat arrays as the CPU
//! engine: symbols, parameter starts, parameters) and bones.
//!
//! Invariants:
//! - One device per process ([`device::shared`]); engine calls are
//!   serialised on it.
//! - Every buffer size is computed and checked against the device limits
//!   before a dispatch; a derivation that outgrows them returns
//!   [`GpuError::BufferTooLarge`] (or another typed error), never a device
//!   loss. Dispatches of more than `max_compute_workgroups_per_dimension`
//!   workgroups are split over a 2D grid.
//! - No atomics on the hot path: every pass is count / scan / write, or
//!   (the direct derivation of deterministic context-free systems,
//!   `derive/direct.rs`) one write of the final string whose layout the
//!   host computed from the tables.
//! - The derived string does not depend on who derives a step: the first,
//!   small strings are derived on the CPU by default
//!   ([`GpuDeriveOptions::cpu_prefix`]) and the GPU goes on from the CPU's
//!   string; every result and error is the GPU-only derivation's.
//! - Constants and struct layouts shared with WGSL are defined in Rust and
//!   emitted as a generated header ([`layout::wgsl_header`]); tests check
//!   both sides with naga.
//! - A kernel build without a feature (the bytecode interpreter, context
//!   matching: [`kernels::DeriveKernels`]) is picked only for tables that
//!   cannot need it, and faults, never answers, if it is reached anyway.

pub mod bench;
pub mod brackets;
pub mod derive;
pub mod device;
pub mod error;
pub mod interp;
pub mod kernels;
pub mod layout;
pub mod pipeline;
pub mod scan;
pub mod shader;
pub mod stamps;
pub mod vmeval;

pub use derive::{
    DIRECT_MAX_EVAL_RATIO, DIRECT_MAX_STEPS, DerivePath, DeriveStrategy, DeviceString,
    GpuDerivation, GpuDeriveOptions, GpuIterationStats, GpuJob, GpuManyDerivation, derive,
    derive_many, derive_with,
};
pub use device::{Allocations, Gpu, Timestamps, shared};
pub use error::{GpuError, RuntimeKind};
pub use interp::{BranchScan, GpuInterpretation, TurtleProgram, interpret, interpret_with};
pub use pipeline::{GpuManyRun, GpuRun, GpuRunOptions, run, run_many};
pub use stamps::{DeviceTime, KERNEL_STAGES};

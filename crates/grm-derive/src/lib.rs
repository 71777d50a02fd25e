//! `grm-derive`: the CPU derivation engine.
//!
//! (Being written: see the issue for the compiler back end and CPU engine.)
//! Today it holds the [`ModuleString`] type shared by the derivation, the
//! turtle interpreter and the GPU engine.

pub mod string;

pub use string::ModuleString;

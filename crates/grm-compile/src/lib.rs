//! `grm-compile`: the compiler back end.
//!
//! Role: lower one checked system into the compiled form every engine
//! reads: a symbol table, packed production tables ([`table`]), expression
//! bytecode ([`op`]) with its constant pool and span table, run by the CPU
//! [`vm`] and, unchanged, by the GPU kernels. The random hash ([`rng`]) is
//! defined here once.
//!
//! Invariants: the op set, the table layout and the hash are defined only
//! here; every emitted expression is verified ([`verify`]) before use.

pub mod op;
pub mod rng;
pub mod table;
pub mod verify;
pub mod vm;

//! `grm-compile`: the compiler back end.
//!
//! Role: lower one checked system ([`grm_sema::System`] of a
//! [`grm_sema::Program`] checked without errors, plus the meta-parameter
//! values of the run) into a [`CompiledSystem`], the form every engine
//! reads: a symbol table, packed production tables ([`table`]), expression
//! bytecode ([`op`]) with its constant pool, and a span table mapping code
//! back to source. The CPU [`vm`] runs the bytecode; the GPU kernels upload
//! the same tables ([`CompiledSystem::pack`]) and interpret the same ops.
//! The random hash ([`rng`]) is defined here once.
//!
//! Inputs: `&Program`, `&System`, meta-parameter values. Outputs:
//! [`CompiledSystem`] or a [`CompileError`] naming a span.
//!
//! Invariants:
//! - The op set ([`op::Op::ALL`]), the table layout ([`table`]) and the hash
//!   ([`rng::hash`]) are defined only here; the GPU side is generated from
//!   or checked against them.
//! - Every emitted expression is verified ([`verify`]): its stack depth is
//!   at most [`op::STACK_SIZE`] and it leaves exactly its value, so the VM
//!   never faults on compiled code (it still checks, and never panics).
//! - Meta-parameters and constants are folded into the constant pool: a
//!   compiled system is specific to one set of meta-parameter values.
//! - Compiling is deterministic: the same input gives the same words.

mod compiled;
pub mod disasm;
mod lower;
pub mod op;
mod params;
pub mod rng;
pub mod select;
pub mod table;
pub mod text;
pub mod verify;
pub mod vm;

pub use compiled::{CompiledSystem, InvalidTables};
pub use disasm::disassemble;
pub use lower::{CompileError, CompileErrorKind, check, compile};
pub use params::param_values;

//! grm-shape: the shape-grammar engine for buildings (`mode = shape`,
//! issue 26; Lipp's dissertation 2.2 and 3.1-3.2, CGA shape).
//!
//! **Role.** Grow a building from a lot: rules rewrite shapes (a symbol, a
//! scope and geometry) by extruding, splitting, repeating, breaking masses
//! into faces and edges, moving scopes and inserting assets, and the whole
//! derivation tree is kept, command nodes included, so that every shape
//! can be named again after the building is regrown.
//!
//! **Input.** A [`Program`] (the IR a `.grm` front-end lowers to: symbols
//! with weighted, possibly conditional rule alternatives of [`Op`]s;
//! numbers are [`Param`]s, constants or [`Expr`]essions evaluated per
//! shape, which may read its scope, index, tags and context queries), a
//! [`Lot`] (the axiom's scope and geometry: a
//! footprint polygon, possibly non-convex, or a face) and [`Options`]
//! (seed, threads, [`Limits`]).
//!
//! **Output.** A [`ShapeTree`]: every node (shape, command, insert), in
//! expansion order (each shape's block as its rule wrote it), with its
//! scope, geometry, numbered edge and identity key; [`ShapeTree::exact_locator`], [`ShapeTree::semantic_locator`],
//! [`ShapeTree::resolve`] and [`ShapeTree::select`] name and find nodes;
//! [`ShapeTree::inserts`] lists the terminals to instance.
//!
//! **Invariants.**
//! - Split and repeat sizes follow one written rule ([`split`],
//!   docs/shapes.md), checked by hand-computed golden cases.
//! - Splits cut the real geometry: a split of an L- or U-shaped mass cuts
//!   its footprint polygon (`geo`'s boolean intersection), so the pieces
//!   tile the whole and each lies in its slab.
//! - Identity: a node's key is `child_key(parent key, salt(label hash,
//!   ordinal, alternative))` with `grm_compile::rng`'s functions (the root
//!   from the seed and the program's name), so keys depend on ancestry
//!   only; every random draw is keyed by them.
//! - Determinism: the same program, lot and options give the same tree,
//!   byte for byte, with any number of threads; and the same error.
//! - Bounded: past [`Limits::max_nodes`] nodes or [`Limits::max_depth`]
//!   levels a derivation stops with a typed [`ShapeError`]; library code
//!   never panics on user input.

pub mod attributes;
pub mod component;
mod engine;
pub mod error;
pub mod expr;
pub mod geometry;
pub mod ir;
mod locator;
mod query;
pub mod replay;
mod rewrap;
pub mod roof;
pub mod scope;
pub mod split;
mod tree;

pub use attributes::{AttrId, Attributes};
pub use engine::{Limits, Lot, Options, derive, derive_with_edits};
pub use error::{ProgramError, ShapeError, SizeError};
pub use expr::{Binary, Expr, ExprId, Query, Type, Unary};
pub use geometry::{Geom, Geometry, Outline, OutlineId};
pub use ir::{
    Alternative, AssetId, Axis, Comp, CompCase, CompTarget, MaterialId, Op, Param, Part, PartSize,
    Program, ProgramBuilder, Rule, Selector, Split, SymbolId, SymbolInfo, TagId, TextureId,
};
pub use locator::{
    Anchor, EdgeRef, ExactLocator, Resolution, SemanticEntry, SemanticLocator, SemanticQuery,
};
pub use replay::EditPlan;
pub use roof::{FaceKind, Roof, RoofError, RoofFace, RoofKind};
pub use scope::Scope;
pub use split::{RepeatLayout, Span, SplitSize};
pub use tree::{Command, Node, NodeId, NodeKind, ShapeTree};

//! Shape systems (`mode = shape;`, docs/language.md section 8): the
//! checked form of a split grammar's lot and rules, which `grm-grow`
//! lowers to the shape engine's IR (`grm_shape::Program`).
//!
//! A shape system is checked apart from derive and sample systems: its
//! successors are operations (`extrude(3)`, `split(y) { ... }`), not
//! modules, and its symbols take no arguments. [`check`] reads the
//! syntax tree; [`analysis`] runs the whole-grammar checks (sizes that can
//! never fit, component splits of shapes without faces, a tag twice on one
//! path); [`lot`] checks the lot (and reads a GeoJSON footprint).
//!
//! Invariants: in a program checked without errors every rule's symbol,
//! every successor and part target is an index into the system's
//! symbols (`System::symbols`), every operation has its arguments, every
//! expression is typed (numbers `float`, conditions `bool`, colours
//! `vec3`) and uses only what the shape engine evaluates (E0513 reports
//! the rest), and the lot is a usable footprint for the meta-parameters'
//! defaults.

pub(crate) mod analysis;
pub(crate) mod check;
pub(crate) mod lot;
pub mod vocab;

use grm_diag::Span;
use grm_syntax::ast::Name;

use crate::program::{MaterialId, MeshId, TExpr};

pub use grm_syntax::ast::PartKind;
pub use lot::{LotKind, Rings, ShapeLot, footprint_problem, lot_rings};
pub use vocab::{Axis, CENTER_AXES, CompTarget, Primitive, RoofKind, Selector, ShapeQuery};

/// A value of the shape being rewritten, read by an expression of a
/// shape rule ([`crate::TExprKind::Shape`]).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum ShapeValue {
    /// `scope`: the scope's size (a `vec3`).
    Scope,
    /// `index`: which part, tile or component the shape is (from 1).
    Index,
    /// `count`: of how many.
    Count,
    /// `depth`: the shape's depth in the tree (the axiom's is 0).
    Depth,
    /// `tagged(tag)`: whether a command with this tag is above the shape.
    Tagged(Name),
    /// `index(tag)`: which child of the nearest command with this tag
    /// above the shape its path goes through (from 1; 0 when none is).
    TagIndex(Name),
    /// `count(tag)`: how many children that command made (0 when none).
    TagCount(Name),
    /// `overlaps(Sym)`, `touches(Sym)`, `inside(Sym)`: a context query
    /// against the shapes of a symbol (named; the checker makes sure it is
    /// a symbol of the system).
    Query(ShapeQuery, Name),
}

/// A shape system's lot and rules.
#[derive(Clone, Debug)]
pub struct ShapeSystem {
    /// The axiom's footprint (`rect(10, 10)` when not set).
    pub lot: ShapeLot,
    /// The axiom symbol (an index into `symbols`); `None` only in a
    /// system with errors.
    pub axiom: Option<u32>,
    /// Every rule, in source order; the rules of one symbol are its
    /// alternatives, in that order.
    pub rules: Vec<ShapeRule>,
}

impl ShapeSystem {
    /// The rules of symbol `s`, in source order.
    pub fn rules_of(&self, s: u32) -> impl Iterator<Item = &ShapeRule> {
        self.rules.iter().filter(move |r| r.symbol == s)
    }
}

/// One rule: `Symbol [: condition] -> [(weight)] operations;`. Its
/// symbol indexes the system's symbols (`grm_sema::System::symbols`: a
/// shape system's symbols are user symbols without parameters).
#[derive(Clone, Debug)]
pub struct ShapeRule {
    /// The symbol it rewrites (an index into [`ShapeSystem::symbols`]).
    pub symbol: u32,
    /// A `bool`; `None` when not written.
    pub condition: Option<TExpr>,
    /// A `float`; `Lit(1.0)` when not written.
    pub weight: TExpr,
    pub weight_written: bool,
    pub ops: Vec<ShapeOp>,
    /// The predecessor.
    pub pred: Span,
    /// The `->`.
    pub arrow: Span,
    /// The whole rule.
    pub span: Span,
}

/// What `insert` places.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Asset {
    Primitive(Primitive),
    /// A declared `mesh`.
    Mesh(MeshId),
}

/// A semantic tag as written.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Tag {
    pub name: String,
    pub span: Span,
}

/// One part of a split or repeated tile.
#[derive(Clone, Debug)]
pub struct ShapePartT {
    pub kind: PartKind,
    /// A `float`: a length, a percentage (`25` for `25%`) or a weight.
    pub size: TExpr,
    /// The shape made there; `None` for `nil`.
    pub target: Option<u32>,
    pub span: Span,
}

/// A split or repeat.
#[derive(Clone, Debug)]
pub struct SplitT {
    pub axis: Axis,
    pub tag: Option<Tag>,
    pub parts: Vec<ShapePartT>,
}

/// One case of a component split.
#[derive(Clone, Debug)]
pub struct CaseT {
    pub selector: Selector,
    /// `None` for `nil`.
    pub target: Option<u32>,
    pub span: Span,
}

/// A component split.
#[derive(Clone, Debug)]
pub struct CompT {
    pub target: CompTarget,
    pub tag: Option<Tag>,
    pub cases: Vec<CaseT>,
}

/// One operation of a rule, with where it is written.
#[derive(Clone, Debug)]
pub struct ShapeOp {
    pub kind: OpKind,
    pub span: Span,
}

/// The operations (docs/language.md 8, "Rules"). Numbers are `float`
/// expressions.
#[derive(Clone, Debug)]
pub enum OpKind {
    /// A successor shape.
    Emit(u32),
    Extrude(TExpr),
    Taper(TExpr),
    Roof {
        kind: RoofKind,
        angle: TExpr,
        overhang: Option<TExpr>,
    },
    Translate([TExpr; 3]),
    Rotate {
        axis: Axis,
        degrees: TExpr,
    },
    /// `_` keeps an axis.
    Size([Option<TExpr>; 3]),
    Center([bool; 3]),
    /// `[`
    Push,
    /// `]`
    Pop,
    Offset(TExpr),
    Insert(Asset),
    Material(MaterialId),
    /// A `vec3` (linear RGB).
    Color(TExpr),
    /// The image as written (a path relative to the file).
    Texture(String),
    Split(SplitT),
    Repeat(SplitT),
    Comp(CompT),
}

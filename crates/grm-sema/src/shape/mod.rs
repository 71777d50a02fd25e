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

use grm_diag::Span;
use grm_syntax::ast::Name;

use crate::program::{MaterialId, MeshId, TExpr};

pub use grm_syntax::ast::PartKind;
pub use lot::{LotKind, Rings, ShapeLot, footprint_problem, lot_rings};

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
    /// `overlaps(Sym)`, `touches(Sym)`, `inside(Sym)`: a context query
    /// against the shapes of a symbol (named; the checker makes sure it is
    /// a symbol of the system).
    Query(ShapeQuery, Name),
}

/// A context query's relation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ShapeQuery {
    Overlaps,
    Touches,
    Inside,
}

impl ShapeQuery {
    pub fn name(self) -> &'static str {
        match self {
            ShapeQuery::Overlaps => "overlaps",
            ShapeQuery::Touches => "touches",
            ShapeQuery::Inside => "inside",
        }
    }

    pub fn from_name(s: &str) -> Option<ShapeQuery> {
        match s {
            "overlaps" => Some(ShapeQuery::Overlaps),
            "touches" => Some(ShapeQuery::Touches),
            "inside" => Some(ShapeQuery::Inside),
            _ => None,
        }
    }
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

/// A scope axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Axis {
    X,
    Y,
    Z,
}

impl Axis {
    pub fn from_name(s: &str) -> Option<Axis> {
        match s {
            "x" => Some(Axis::X),
            "y" => Some(Axis::Y),
            "z" => Some(Axis::Z),
            _ => None,
        }
    }

    pub fn index(self) -> usize {
        self as usize
    }
}

/// The kind of a roof.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RoofKind {
    Flat,
    Gable,
    Hip,
    Shed,
    Pyramid,
}

impl RoofKind {
    pub const ALL: &'static [RoofKind] = &[
        RoofKind::Flat,
        RoofKind::Gable,
        RoofKind::Hip,
        RoofKind::Shed,
        RoofKind::Pyramid,
    ];

    pub fn name(self) -> &'static str {
        match self {
            RoofKind::Flat => "flat",
            RoofKind::Gable => "gable",
            RoofKind::Hip => "hip",
            RoofKind::Shed => "shed",
            RoofKind::Pyramid => "pyramid",
        }
    }

    pub fn from_name(s: &str) -> Option<RoofKind> {
        RoofKind::ALL.iter().copied().find(|k| k.name() == s)
    }
}

/// What a component split breaks a shape into.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CompTarget {
    Faces,
    Edges,
}

/// Which components a case takes (docs/shapes.md, "Component split").
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Selector {
    Front,
    Back,
    Left,
    Right,
    Side,
    Top,
    Bottom,
    All,
    /// A roof's sloped faces.
    Slope,
    /// A roof's gable ends.
    Gable,
    /// A roof's eaves (edges).
    Eave,
    /// A roof's ridge (edges).
    Ridge,
    /// A roof's hips (edges).
    Hip,
    /// A roof's valleys (edges, where two slopes meet inward).
    Valley,
    /// A roof's rakes (the sloped edges of a gable).
    Rake,
}

impl Selector {
    pub const ALL: &'static [Selector] = &[
        Selector::Front,
        Selector::Back,
        Selector::Left,
        Selector::Right,
        Selector::Side,
        Selector::Top,
        Selector::Bottom,
        Selector::All,
        Selector::Slope,
        Selector::Gable,
        Selector::Eave,
        Selector::Ridge,
        Selector::Hip,
        Selector::Valley,
        Selector::Rake,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Selector::Front => "front",
            Selector::Back => "back",
            Selector::Left => "left",
            Selector::Right => "right",
            Selector::Side => "side",
            Selector::Top => "top",
            Selector::Bottom => "bottom",
            Selector::All => "all",
            Selector::Slope => "slope",
            Selector::Gable => "gable",
            Selector::Eave => "eave",
            Selector::Ridge => "ridge",
            Selector::Hip => "hip",
            Selector::Valley => "valley",
            Selector::Rake => "rake",
        }
    }

    pub fn from_name(s: &str) -> Option<Selector> {
        Selector::ALL.iter().copied().find(|k| k.name() == s)
    }
}

/// A primitive `insert` places.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Primitive {
    Box,
    Cylinder,
    Cone,
    Sphere,
    Disc,
}

impl Primitive {
    pub const ALL: &'static [Primitive] = &[
        Primitive::Box,
        Primitive::Cylinder,
        Primitive::Cone,
        Primitive::Sphere,
        Primitive::Disc,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Primitive::Box => "box",
            Primitive::Cylinder => "cylinder",
            Primitive::Cone => "cone",
            Primitive::Sphere => "sphere",
            Primitive::Disc => "disc",
        }
    }

    pub fn from_name(s: &str) -> Option<Primitive> {
        Primitive::ALL.iter().copied().find(|k| k.name() == s)
    }
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

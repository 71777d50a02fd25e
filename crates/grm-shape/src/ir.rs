//! The shape-grammar program: what a `mode = shape` system lowers to.
//!
//! A [`Program`] is a table of symbols, each with at most one [`Rule`];
//! a rule has one or more weighted [`Alternative`]s (chosen by the race of
//! `grm_compile::rng`, keyed by the shape's identity); an alternative is a
//! list of [`Op`]s run in order on the shape. A symbol without a rule is a
//! terminal shape.
//!
//! Numbers are [`Param`]s: constants, or expressions ([`Expr`], compiled
//! by [`ProgramBuilder::expr`]) evaluated per shape; an alternative may
//! have a condition and an expression weight (docs/shapes.md,
//! "Expressions" and "Conditions").

use crate::error::ProgramError;
use crate::expr::{
    CompileError, DRAW_ALTERNATIVES, DRAW_LOCALS, DRAW_SITES, Expr, ExprId, Exprs, SITE_OPS, Type,
};
use crate::roof::RoofKind;
use crate::split::SplitSize;
use grm_compile::rng::name_hash;

/// The shape-mode words (axes, component-split targets and selectors) are
/// the language's, defined once in `grm_sema::shape::vocab`.
pub use grm_sema::shape::{Axis, CompTarget, Selector};

/// A symbol of the program (an index into its symbol table).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct SymbolId(pub u32);

/// A semantic tag (`floor`, `column`, `facade`), attached to a command.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct TagId(pub u32);

/// The name of an inserted primitive or mesh.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct AssetId(pub u32);

/// The name of a material (resolved by the exporter: a declared grm
/// material of that name).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct MaterialId(pub u32);

/// The name of a texture (an image; the exporter resolves the name to a
/// file).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct TextureId(pub u32);

/// A number in an operation: a constant, or an expression evaluated for
/// each shape (with the shape's scope at that point of the rule, its
/// index, tags and key for its random draws).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Param {
    /// A constant.
    Const(f32),
    /// A number-typed expression of the program ([`ProgramBuilder::expr`]).
    Expr(ExprId),
}

impl Param {
    /// The constant, if this is one.
    #[inline]
    pub fn constant(&self) -> Option<f32> {
        match *self {
            Param::Const(v) => Some(v),
            Param::Expr(_) => None,
        }
    }
}

impl From<ExprId> for Param {
    fn from(e: ExprId) -> Self {
        Param::Expr(e)
    }
}

impl From<f32> for Param {
    fn from(v: f32) -> Self {
        Param::Const(v)
    }
}

/// How a part is sized: the kinds of [`SplitSize`], with a [`Param`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PartSize {
    /// A length in scope units.
    Absolute(Param),
    /// A fraction of the scope's extent along the axis (`25%` lowers to 0.25).
    Relative(Param),
    /// A floating weight (`~w`): shares the rest in proportion.
    Floating(Param),
}

impl PartSize {
    /// The size for one shape, its number read by `value`.
    #[inline]
    pub(crate) fn eval(&self, mut value: impl FnMut(&Param) -> f32) -> SplitSize {
        match self {
            PartSize::Absolute(p) => SplitSize::Absolute(value(p)),
            PartSize::Relative(p) => SplitSize::Relative(value(p)),
            PartSize::Floating(p) => SplitSize::Floating(value(p)),
        }
    }

    /// The size's number.
    pub fn param(&self) -> &Param {
        match self {
            PartSize::Absolute(p) | PartSize::Relative(p) | PartSize::Floating(p) => p,
        }
    }
}

/// One part of a split or of a repeated tile: its size and the symbol of
/// the shape made there (`None`: the part is left empty, CGA's `NIL`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Part {
    pub size: PartSize,
    pub target: Option<SymbolId>,
}

impl Part {
    /// An absolute part.
    pub fn abs(len: f32, target: Option<SymbolId>) -> Self {
        Part {
            size: PartSize::Absolute(Param::Const(len)),
            target,
        }
    }
    /// A relative part (a fraction of the extent).
    pub fn rel(fraction: f32, target: Option<SymbolId>) -> Self {
        Part {
            size: PartSize::Relative(Param::Const(fraction)),
            target,
        }
    }
    /// A floating part.
    pub fn float(weight: f32, target: Option<SymbolId>) -> Self {
        Part {
            size: PartSize::Floating(Param::Const(weight)),
            target,
        }
    }
}

/// A split (or a repeat: the same data, the parts forming one tile).
#[derive(Clone, Debug, PartialEq)]
pub struct Split {
    pub axis: Axis,
    pub parts: Vec<Part>,
    pub tag: Option<TagId>,
}

/// One case of a component split.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CompCase {
    pub selector: Selector,
    pub target: Option<SymbolId>,
}

/// A component split.
#[derive(Clone, Debug, PartialEq)]
pub struct Comp {
    pub target: CompTarget,
    pub cases: Vec<CompCase>,
    pub tag: Option<TagId>,
}

/// One operation of a rule, run in order on the current shape.
#[derive(Clone, Debug, PartialEq)]
pub enum Op {
    /// Extrude a face or footprint along its scope's z by the height (a
    /// mass's height is set anew).
    Extrude(Param),
    /// Move the scope along its own axes.
    Translate([Param; 3]),
    /// Turn the scope about one of its own axes through its origin, in degrees.
    Rotate { axis: Axis, degrees: Param },
    /// Set the scope's size on the axes given (`None` keeps it); the
    /// geometry is scaled with it.
    Size([Option<Param>; 3]),
    /// Centre the scope, on the axes set, in the scope saved by the last
    /// `push` (or the shape's scope when nothing is pushed).
    Center([bool; 3]),
    /// Save the scope and geometry.
    Push,
    /// Restore the last saved scope and geometry.
    Pop,
    /// Offset the face or footprint outline by the distance (negative: inset).
    Offset(Param),
    /// Place a primitive or mesh fitted to the scope (a terminal in the tree).
    Insert(AssetId),
    /// A successor shape of this symbol with the current scope and geometry.
    Emit(SymbolId),
    /// Split the shape along an axis.
    Split(Split),
    /// Repeat the parts as a tile along an axis.
    Repeat(Split),
    /// Break the shape into faces or edges.
    Comp(Comp),
    /// Make a roof of `kind` on the shape (on a face: standing on it; on a
    /// mass: on its top), its slopes at `angle` degrees, its outline
    /// offset outward by `overhang` and its eaves lowered to match
    /// ([`crate::roof`], docs/shapes.md "Roofs and taper").
    Roof {
        kind: RoofKind,
        angle: Param,
        overhang: Param,
    },
    /// Lean the walls of the face (or of the mass, from its bottom) in to
    /// an apex this high over the centroid: a pyramid ([`crate::roof::taper`]).
    Taper(Param),
    /// Draw the shape and everything made after this in the rule with a
    /// material (an attribute, inherited: [`crate::attributes`]).
    Material(MaterialId),
    /// Draw with a linear RGB colour (each channel clamped to `[0, 1]`).
    Color([Param; 3]),
    /// Map a texture (an image) on the faces, by their UV coordinates.
    Texture(TextureId),
}

impl Op {
    /// Every number of the operation, in the order the engine reads them
    /// (the order of their random draws: docs/shapes.md, "Identity"). An
    /// operation with numbers must list them here (the match is exhaustive
    /// on purpose), so that [`ProgramBuilder::build`] checks their
    /// expressions.
    pub fn params(&self, mut f: impl FnMut(&Param)) {
        match self {
            Op::Extrude(p) | Op::Offset(p) | Op::Rotate { degrees: p, .. } | Op::Taper(p) => f(p),
            Op::Roof {
                angle, overhang, ..
            } => {
                f(angle);
                f(overhang);
            }
            Op::Translate(v) | Op::Color(v) => v.iter().for_each(f),
            Op::Size(v) => v.iter().flatten().for_each(f),
            Op::Split(s) | Op::Repeat(s) => s.parts.iter().for_each(|p| f(p.size.param())),
            Op::Center(_)
            | Op::Push
            | Op::Pop
            | Op::Insert(_)
            | Op::Emit(_)
            | Op::Comp(_)
            | Op::Material(_)
            | Op::Texture(_) => {}
        }
    }
}

/// One weighted way to rewrite a symbol: it competes for a shape when
/// its condition holds there (docs/shapes.md, "Conditions").
#[derive(Clone, Debug, PartialEq)]
pub struct Alternative {
    /// The weight in the race: a constant must be finite and positive; an
    /// expression that comes out NaN, infinite or not positive for a shape
    /// drops the alternative there (`+inf` counts as `f32::MAX`).
    pub weight: Param,
    /// A boolean expression; `None` always holds.
    pub condition: Option<ExprId>,
    pub ops: Vec<Op>,
}

impl Alternative {
    /// An alternative of weight 1 with no condition.
    pub fn new(ops: Vec<Op>) -> Self {
        Alternative {
            weight: Param::Const(1.0),
            condition: None,
            ops,
        }
    }

    /// An alternative of weight `weight` (a constant or an expression).
    pub fn weighted(weight: impl Into<Param>, ops: Vec<Op>) -> Self {
        Alternative {
            weight: weight.into(),
            condition: None,
            ops,
        }
    }

    /// This alternative, competing only where `condition` holds.
    pub fn when(mut self, condition: ExprId) -> Self {
        self.condition = Some(condition);
        self
    }

    /// Whether choosing among alternatives like this one needs no
    /// expression (a constant weight, no condition).
    #[inline]
    pub(crate) fn is_plain(&self) -> bool {
        self.condition.is_none() && matches!(self.weight, Param::Const(_))
    }
}

/// A symbol's rule.
#[derive(Clone, Debug, PartialEq)]
pub struct Rule {
    pub alternatives: Vec<Alternative>,
}

/// A symbol's entry in the program.
#[derive(Clone, Debug, PartialEq)]
pub struct SymbolInfo {
    pub name: String,
    /// `grm_compile::rng::name_hash(name)`: how the symbol enters keys.
    pub name_hash: u32,
    pub rule: Option<Rule>,
}

/// Label hashes of the commands (for identity keys).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct CommandHashes {
    pub split: u32,
    pub repeat: u32,
    pub comp: u32,
}

/// A checked shape-grammar program (build one with [`ProgramBuilder`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Program {
    pub(crate) name: String,
    pub(crate) name_hash: u32,
    pub(crate) symbols: Vec<SymbolInfo>,
    pub(crate) tags: Vec<String>,
    pub(crate) assets: Vec<(String, u32)>,
    pub(crate) materials: Vec<String>,
    pub(crate) textures: Vec<String>,
    pub(crate) axiom: SymbolId,
    pub(crate) commands: CommandHashes,
    pub(crate) exprs: Exprs,
}

impl Program {
    /// The system's name (it enters the root key).
    pub fn name(&self) -> &str {
        &self.name
    }
    /// The axiom symbol.
    pub fn axiom(&self) -> SymbolId {
        self.axiom
    }
    /// A symbol's name.
    pub fn symbol_name(&self, s: SymbolId) -> &str {
        self.symbols
            .get(s.0 as usize)
            .map_or("?", |i| i.name.as_str())
    }
    /// A symbol by name.
    pub fn symbol(&self, name: &str) -> Option<SymbolId> {
        self.symbols
            .iter()
            .position(|s| s.name == name)
            .map(|i| SymbolId(i as u32))
    }
    /// A tag's name.
    pub fn tag_name(&self, t: TagId) -> &str {
        self.tags.get(t.0 as usize).map_or("?", String::as_str)
    }
    /// A tag by name.
    pub fn tag(&self, name: &str) -> Option<TagId> {
        self.tags
            .iter()
            .position(|s| s == name)
            .map(|i| TagId(i as u32))
    }
    /// An asset's name.
    pub fn asset_name(&self, a: AssetId) -> &str {
        self.assets.get(a.0 as usize).map_or("?", |a| a.0.as_str())
    }
    /// A material's name.
    pub fn material_name(&self, m: MaterialId) -> &str {
        self.materials.get(m.0 as usize).map_or("?", String::as_str)
    }
    /// The materials' names, in id order.
    pub fn materials(&self) -> &[String] {
        &self.materials
    }
    /// A texture's name.
    pub fn texture_name(&self, t: TextureId) -> &str {
        self.textures.get(t.0 as usize).map_or("?", String::as_str)
    }
    /// The textures' names, in id order.
    pub fn textures(&self) -> &[String] {
        &self.textures
    }
    /// The assets' names, in id order.
    pub fn asset_names(&self) -> impl Iterator<Item = &str> {
        self.assets.iter().map(|a| a.0.as_str())
    }
    /// The symbols, in id order.
    pub fn symbols(&self) -> &[SymbolInfo] {
        &self.symbols
    }
    /// A symbol's rule, if it has one.
    pub fn rule(&self, s: SymbolId) -> Option<&Rule> {
        self.symbols.get(s.0 as usize).and_then(|i| i.rule.as_ref())
    }
    /// The symbols that context queries ask about (a program with none is
    /// derived in one pass).
    pub fn queried_symbols(&self) -> &[SymbolId] {
        &self.exprs.uses.queried
    }
    /// The type of an expression, if the program has it.
    pub fn expr_type(&self, e: ExprId) -> Option<Type> {
        self.exprs.entry(e).map(|e| e.ty)
    }
}

/// Builds a [`Program`]: declare symbols, tags and assets, compile
/// expressions, give rules, then [`build`](ProgramBuilder::build) checks
/// every id, weight and expression type.
///
/// ```
/// use grm_shape::{Alternative, Axis, Expr, Op, Part, PartSize, Param, ProgramBuilder, Split};
/// let mut b = ProgramBuilder::new("facade");
/// let floor = b.symbol("Floor");
/// let (ground, upper) = (b.symbol("Ground"), b.symbol("Upper"));
/// let facade = b.symbol("Facade");
/// let floor_tag = b.tag("floor");
/// // Floor -> case index == 1: Ground | else: Upper
/// let first = b.expr(&Expr::Index.eq(Expr::Num(1.0)));
/// let not_first = b.expr(&!Expr::Index.eq(Expr::Num(1.0)));
/// b.rule_alternatives(floor, vec![
///     Alternative::new(vec![Op::Emit(ground)]).when(first),
///     Alternative::new(vec![Op::Emit(upper)]).when(not_first),
/// ]);
/// // Facade -> repeat(y) { uniform(2.8, 3.2): Floor } floor
/// let h = b.expr(&Expr::uniform(Expr::Num(2.8), Expr::Num(3.2)));
/// b.rule(facade, vec![Op::Repeat(Split {
///     axis: Axis::Y,
///     parts: vec![Part { size: PartSize::Absolute(Param::Expr(h)), target: Some(floor) }],
///     tag: Some(floor_tag),
/// })]);
/// let program = b.build(facade).unwrap();
/// # let _ = program;
/// ```
#[derive(Debug)]
pub struct ProgramBuilder {
    exprs: Exprs,
    name: String,
    symbols: Vec<SymbolInfo>,
    tags: Vec<String>,
    assets: Vec<String>,
    materials: Vec<String>,
    textures: Vec<String>,
    first_error: Option<ProgramError>,
}

impl ProgramBuilder {
    /// A new program named `name` (the system's name: it enters the root key).
    pub fn new(name: &str) -> Self {
        ProgramBuilder {
            name: name.to_owned(),
            symbols: Vec::new(),
            tags: Vec::new(),
            assets: Vec::new(),
            materials: Vec::new(),
            textures: Vec::new(),
            exprs: Exprs::default(),
            first_error: None,
        }
    }

    /// Compile an expression (type-checked here; its tags and symbols must
    /// be declared already). An ill-typed expression is reported by
    /// [`build`](ProgramBuilder::build) (the id returned then is past the
    /// program's expressions); use [`try_expr`](ProgramBuilder::try_expr)
    /// to see the error at once.
    pub fn expr(&mut self, e: &Expr) -> ExprId {
        match self.try_expr(e) {
            Ok(id) => id,
            Err(err) => {
                if self.first_error.is_none() {
                    self.first_error = Some(err);
                }
                ExprId(u32::MAX)
            }
        }
    }

    /// [`expr`](ProgramBuilder::expr), with its error.
    pub fn try_expr(&mut self, e: &Expr) -> Result<ExprId, ProgramError> {
        self.exprs
            .compile(e, self.tags.len(), self.symbols.len())
            .map_err(|err| match err {
                CompileError::Type(why) => ProgramError::BadExpr { why },
                CompileError::TooDeep => ProgramError::BadExpr {
                    why: format!(
                        "the expression nests deeper than {}",
                        crate::expr::MAX_EXPR_DEPTH
                    ),
                },
                CompileError::UnknownTag(id) => ProgramError::UnknownId { what: "tag", id },
                CompileError::UnknownSymbol(id) => ProgramError::UnknownId { what: "symbol", id },
            })
    }

    /// The symbol named `name`, declared on first use.
    pub fn symbol(&mut self, name: &str) -> SymbolId {
        if let Some(i) = self.symbols.iter().position(|s| s.name == name) {
            return SymbolId(i as u32);
        }
        self.symbols.push(SymbolInfo {
            name: name.to_owned(),
            name_hash: name_hash(name),
            rule: None,
        });
        SymbolId(self.symbols.len() as u32 - 1)
    }

    /// The tag named `name`, declared on first use.
    pub fn tag(&mut self, name: &str) -> TagId {
        if let Some(i) = self.tags.iter().position(|s| s == name) {
            return TagId(i as u32);
        }
        self.tags.push(name.to_owned());
        TagId(self.tags.len() as u32 - 1)
    }

    /// The asset named `name`, declared on first use.
    pub fn asset(&mut self, name: &str) -> AssetId {
        if let Some(i) = self.assets.iter().position(|s| s == name) {
            return AssetId(i as u32);
        }
        self.assets.push(name.to_owned());
        AssetId(self.assets.len() as u32 - 1)
    }

    /// The material named `name`, declared on first use.
    pub fn material(&mut self, name: &str) -> MaterialId {
        MaterialId(declare(&mut self.materials, name))
    }

    /// The texture named `name` (an image), declared on first use.
    pub fn texture(&mut self, name: &str) -> TextureId {
        TextureId(declare(&mut self.textures, name))
    }

    /// Give `symbol` a rule with one alternative.
    pub fn rule(&mut self, symbol: SymbolId, ops: Vec<Op>) -> &mut Self {
        self.rule_alternatives(symbol, vec![Alternative::new(ops)])
    }

    /// Give `symbol` a rule with weighted alternatives.
    pub fn rule_alternatives(
        &mut self,
        symbol: SymbolId,
        alternatives: Vec<Alternative>,
    ) -> &mut Self {
        let error = match self.symbols.get_mut(symbol.0 as usize) {
            Some(info) if info.rule.is_some() => Some(ProgramError::DuplicateRule {
                symbol: info.name.clone(),
            }),
            Some(info) => {
                info.rule = Some(Rule { alternatives });
                None
            }
            None => Some(ProgramError::UnknownId {
                what: "symbol",
                id: symbol.0,
            }),
        };
        if self.first_error.is_none() {
            self.first_error = error;
        }
        self
    }

    /// Check the expressions of alternative `k` of `symbol`'s rule: each
    /// id known, numbers where numbers go and booleans as conditions, and
    /// its draws within the draw index's fields (docs/shapes.md, "Identity").
    fn check_exprs(&self, symbol: &str, k: usize, alt: &Alternative) -> Result<(), ProgramError> {
        let mut draws_here = false;
        let mut check = |e: ExprId, want: Type, what: &'static str| -> Result<u32, ProgramError> {
            let entry = self.exprs.entry(e).ok_or(ProgramError::UnknownId {
                what: "expression",
                id: e.0,
            })?;
            if entry.ty != want {
                return Err(ProgramError::ExprType {
                    symbol: symbol.to_owned(),
                    alternative: k,
                    what,
                    expected: want.name(),
                });
            }
            draws_here |= entry.draws > 0;
            Ok(entry.draws)
        };
        let too_many = || ProgramError::TooManyDraws {
            symbol: symbol.to_owned(),
            alternative: k,
        };
        let within = |n: u32| {
            if n < DRAW_LOCALS {
                Ok(())
            } else {
                Err(too_many())
            }
        };
        if let Some(c) = alt.condition {
            within(check(c, Type::Bool, "a condition")?)?;
        }
        if let Param::Expr(w) = alt.weight {
            within(check(w, Type::Num, "a weight")?)?;
        }
        let mut last_drawing_op = None;
        for (i, op) in alt.ops.iter().enumerate() {
            let mut n = 0u32;
            let mut first_err = None;
            op.params(|p| {
                if let Param::Expr(e) = p {
                    match check(*e, Type::Num, "a number of an operation") {
                        Ok(d) => n = n.saturating_add(d),
                        Err(err) => {
                            first_err.get_or_insert(err);
                        }
                    }
                }
            });
            if let Some(err) = first_err {
                return Err(err);
            }
            within(n)?;
            if n > 0 {
                last_drawing_op = Some(i as u32);
            }
        }
        if draws_here
            && (k as u32 >= DRAW_ALTERNATIVES
                || last_drawing_op.is_some_and(|i| SITE_OPS + i >= DRAW_SITES))
        {
            return Err(too_many());
        }
        Ok(())
    }

    /// Check and finish the program, with `axiom` as its start symbol.
    pub fn build(self, axiom: SymbolId) -> Result<Program, ProgramError> {
        if let Some(e) = self.first_error {
            return Err(e);
        }
        let n_sym = self.symbols.len() as u32;
        let sym_ok = |s: SymbolId| {
            if s.0 < n_sym {
                Ok(())
            } else {
                Err(ProgramError::UnknownId {
                    what: "symbol",
                    id: s.0,
                })
            }
        };
        let target_ok = |t: Option<SymbolId>| t.map_or(Ok(()), sym_ok);
        let tag_ok = |t: Option<TagId>| match t {
            Some(t) if t.0 as usize >= self.tags.len() => Err(ProgramError::UnknownId {
                what: "tag",
                id: t.0,
            }),
            _ => Ok(()),
        };
        sym_ok(axiom)?;
        for info in &self.symbols {
            let Some(rule) = &info.rule else { continue };
            if rule.alternatives.is_empty() {
                return Err(ProgramError::NoAlternatives {
                    symbol: info.name.clone(),
                });
            }
            for (k, alt) in rule.alternatives.iter().enumerate() {
                if let Param::Const(w) = alt.weight
                    && !(w.is_finite() && w > 0.0)
                {
                    return Err(ProgramError::BadWeight {
                        symbol: info.name.clone(),
                        alternative: k,
                        weight: w,
                    });
                }
                self.check_exprs(&info.name, k, alt)?;
                for op in &alt.ops {
                    match op {
                        Op::Emit(s) => sym_ok(*s)?,
                        Op::Insert(a) if a.0 as usize >= self.assets.len() => {
                            return Err(ProgramError::UnknownId {
                                what: "asset",
                                id: a.0,
                            });
                        }
                        Op::Material(m) if m.0 as usize >= self.materials.len() => {
                            return Err(ProgramError::UnknownId {
                                what: "material",
                                id: m.0,
                            });
                        }
                        Op::Texture(t) if t.0 as usize >= self.textures.len() => {
                            return Err(ProgramError::UnknownId {
                                what: "texture",
                                id: t.0,
                            });
                        }
                        Op::Split(s) | Op::Repeat(s) => {
                            if s.parts.is_empty() {
                                let command = if matches!(op, Op::Split(_)) {
                                    "split"
                                } else {
                                    "repeat"
                                };
                                return Err(ProgramError::EmptyCommand {
                                    symbol: info.name.clone(),
                                    command,
                                });
                            }
                            tag_ok(s.tag)?;
                            for p in &s.parts {
                                target_ok(p.target)?;
                            }
                        }
                        Op::Comp(c) => {
                            if c.cases.is_empty() {
                                return Err(ProgramError::EmptyCommand {
                                    symbol: info.name.clone(),
                                    command: "component split",
                                });
                            }
                            tag_ok(c.tag)?;
                            for case in &c.cases {
                                target_ok(case.target)?;
                            }
                        }
                        _ => {}
                    }
                }
            }
        }
        let assets = self.assets.into_iter().map(|a| {
            let h = name_hash(&a);
            (a, h)
        });
        Ok(Program {
            name_hash: name_hash(&self.name),
            name: self.name,
            symbols: self.symbols,
            tags: self.tags,
            assets: assets.collect(),
            materials: self.materials,
            textures: self.textures,
            axiom,
            commands: CommandHashes {
                split: name_hash("split"),
                repeat: name_hash("repeat"),
                comp: name_hash("comp"),
            },
            exprs: self.exprs,
        })
    }
}

/// The index of `name` in `names`, appended on first use.
fn declare(names: &mut Vec<String>, name: &str) -> u32 {
    match names.iter().position(|s| s == name) {
        Some(i) => i as u32,
        None => {
            names.push(name.to_owned());
            names.len() as u32 - 1
        }
    }
}

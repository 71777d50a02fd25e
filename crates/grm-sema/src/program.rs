//! The checked program: the typed, resolved output of the checker.
//!
//! Everything a later stage needs is here, resolved to ids and concrete
//! types, so the compiler, the engines, the guided sampler and the language
//! server never look at the syntax tree or re-resolve a name.
//!
//! Conventions:
//! - Ids are indices into the vector that owns the item ([`ConstId`] into
//!   [`Program::consts`], [`SymbolId`] into [`System::symbols`], ...).
//! - Items that can live in any file carry a [`Loc`] (file and span). Spans
//!   inside a system (expressions, modules, productions) are in the system's
//!   [`System::file`], except inlined default arguments, which keep the span
//!   of the module they were filled in for.
//! - In a program checked without error diagnostics there is no
//!   [`Ty::Error`] and no [`TExprKind::Error`]; every module has exactly
//!   `symbols[id].arity` arguments whose types are `symbols[id].params`.
//!   With errors, the program is best-effort (good for hover and
//!   go-to-definition) and must not be lowered.

use grm_diag::{FileId, Span};
pub use grm_syntax::ast::{BinaryOp, Phase, UnaryOp};

use crate::builtins::{Builtin, MaterialProp, RandomFn, Terminal};
use crate::index::RefIndex;

/// A file and a span in it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub struct Loc {
    pub file: FileId,
    pub span: Span,
}

impl Loc {
    pub fn new(file: FileId, span: Span) -> Loc {
        Loc { file, span }
    }
}

macro_rules! id_type {
    ($(#[$m:meta])* $name:ident) => {
        $(#[$m])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
        pub struct $name(pub u32);

        impl $name {
            /// The index into the owning vector.
            pub fn index(self) -> usize {
                self.0 as usize
            }
        }
    };
}

id_type!(
    /// A global constant: index into [`Program::consts`].
    ConstId
);
id_type!(
    /// A meta-parameter: index into [`Program::params`].
    ParamId
);
id_type!(
    /// A mesh: index into [`Program::meshes`].
    MeshId
);
id_type!(
    /// A material: index into [`Program::materials`].
    MaterialId
);
id_type!(
    /// A system: index into [`Program::systems`].
    SystemId
);
id_type!(
    /// A module symbol of one system: index into [`System::symbols`].
    SymbolId
);
id_type!(
    /// A production group of one system: index into [`System::groups`].
    GroupId
);

/// A value type.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Ty {
    /// 32-bit float at run time (folded in f64 by the checker).
    Float,
    Vec3,
    Bool,
    /// A declared mesh name (only as the argument of the `mesh` terminal).
    Mesh,
    /// A declared material name (only as the argument of the `material` terminal).
    Material,
    /// The type of an expression that has already been reported as broken.
    Error,
}

impl Ty {
    pub fn name(self) -> &'static str {
        match self {
            Ty::Float => "float",
            Ty::Vec3 => "vec3",
            Ty::Bool => "bool",
            Ty::Mesh => "mesh",
            Ty::Material => "material",
            Ty::Error => "{error}",
        }
    }

    /// Whether arithmetic works on it (`float` or `vec3`).
    pub fn is_numeric(self) -> bool {
        matches!(self, Ty::Float | Ty::Vec3)
    }
}

impl std::fmt::Display for Ty {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// A constant value. Floats are folded in f64; the engines run in f32.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Value {
    Float(f64),
    Vec3([f64; 3]),
    Bool(bool),
    Mesh(MeshId),
    Material(MaterialId),
}

impl Value {
    pub fn ty(&self) -> Ty {
        match self {
            Value::Float(_) => Ty::Float,
            Value::Vec3(_) => Ty::Vec3,
            Value::Bool(_) => Ty::Bool,
            Value::Mesh(_) => Ty::Mesh,
            Value::Material(_) => Ty::Material,
        }
    }

    pub fn as_float(&self) -> Option<f64> {
        match self {
            Value::Float(x) => Some(*x),
            _ => None,
        }
    }

    pub fn as_vec3(&self) -> Option<[f64; 3]> {
        match self {
            Value::Vec3(v) => Some(*v),
            _ => None,
        }
    }

    pub fn as_bool(&self) -> Option<bool> {
        match self {
            Value::Bool(b) => Some(*b),
            _ => None,
        }
    }

    /// The zero value of a type (used as a placeholder).
    pub fn zero(ty: Ty) -> Value {
        match ty {
            Ty::Vec3 => Value::Vec3([0.0; 3]),
            Ty::Bool => Value::Bool(false),
            Ty::Mesh => Value::Mesh(MeshId(0)),
            Ty::Material => Value::Material(MaterialId(0)),
            Ty::Float | Ty::Error => Value::Float(0.0),
        }
    }
}

impl std::fmt::Display for Value {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            // Floats are 32-bit at run time: shown as the f32 they are.
            Value::Float(x) => write!(f, "{}", *x as f32),
            Value::Vec3([x, y, z]) => {
                write!(f, "vec3({}, {}, {})", *x as f32, *y as f32, *z as f32)
            }
            Value::Bool(b) => write!(f, "{b}"),
            Value::Mesh(m) => write!(f, "mesh#{}", m.0),
            Value::Material(m) => write!(f, "material#{}", m.0),
        }
    }
}

/// A typed expression with resolved references.
///
/// Constant subtrees are folded to [`TExprKind::Lit`]. A reference to a
/// constant that depends on meta-parameters stays a [`TExprKind::Global`]
/// (its value is fixed for one run; see [`Program::global_values`]).
#[derive(Clone, Debug, PartialEq)]
pub struct TExpr {
    pub kind: TExprKind,
    pub ty: Ty,
    /// Where the expression was written (for run-time error reports).
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub enum TExprKind {
    /// A folded constant.
    Lit(Value),
    /// A meta-parameter (overridable per run).
    Param(ParamId),
    /// A constant whose value depends on meta-parameters.
    Global(ConstId),
    /// A parameter bound by the production's patterns: the binding slot
    /// (see [`Group::slots`]).
    ModuleParam(u32),
    Unary(UnaryOp, Box<TExpr>),
    Binary(BinaryOp, Box<TExpr>, Box<TExpr>),
    /// Component 0, 1 or 2 (`.x`, `.y`, `.z`) of a vec3.
    Field(Box<TExpr>, u8),
    If(Box<TExpr>, Box<TExpr>, Box<TExpr>),
    /// A pure built-in function.
    Call(Builtin, Vec<TExpr>),
    /// A random draw (never folded).
    Random(RandomFn, Vec<TExpr>),
    /// A value of the shape being rewritten (shape systems only; never
    /// folded).
    Shape(crate::shape::ShapeValue),
    /// Already reported; only in programs with errors.
    Error,
}

impl TExpr {
    pub fn lit(value: Value, span: Span) -> TExpr {
        TExpr {
            ty: value.ty(),
            kind: TExprKind::Lit(value),
            span,
        }
    }

    pub fn error(span: Span) -> TExpr {
        TExpr {
            kind: TExprKind::Error,
            ty: Ty::Error,
            span,
        }
    }

    /// The folded value, if the expression is a constant.
    pub fn constant(&self) -> Option<Value> {
        match &self.kind {
            TExprKind::Lit(v) => Some(*v),
            _ => None,
        }
    }

    /// Visit this expression and all subexpressions, parents first.
    pub fn walk(&self, f: &mut dyn FnMut(&TExpr)) {
        f(self);
        match &self.kind {
            TExprKind::Unary(_, a) | TExprKind::Field(a, _) => a.walk(f),
            TExprKind::Binary(_, a, b) => {
                a.walk(f);
                b.walk(f);
            }
            TExprKind::If(a, b, c) => {
                a.walk(f);
                b.walk(f);
                c.walk(f);
            }
            TExprKind::Call(_, args) | TExprKind::Random(_, args) => {
                for a in args {
                    a.walk(f);
                }
            }
            TExprKind::Lit(_)
            | TExprKind::Param(_)
            | TExprKind::Global(_)
            | TExprKind::ModuleParam(_)
            | TExprKind::Shape(_)
            | TExprKind::Error => {}
        }
    }

    /// Whether the expression contains a random draw.
    pub fn has_random(&self) -> bool {
        let mut found = false;
        self.walk(&mut |e| found |= matches!(e.kind, TExprKind::Random(..)));
        found
    }

    /// Structural equality: same shape, operators, references and
    /// constants; spans are ignored.
    pub fn same_as(&self, other: &TExpr) -> bool {
        use TExprKind as K;
        if self.ty != other.ty {
            return false;
        }
        match (&self.kind, &other.kind) {
            (K::Lit(a), K::Lit(b)) => lit_eq(a, b),
            (K::Param(a), K::Param(b)) => a == b,
            (K::Global(a), K::Global(b)) => a == b,
            (K::ModuleParam(a), K::ModuleParam(b)) => a == b,
            (K::Unary(o1, a), K::Unary(o2, b)) => o1 == o2 && a.same_as(b),
            (K::Binary(o1, a1, b1), K::Binary(o2, a2, b2)) => {
                o1 == o2 && a1.same_as(a2) && b1.same_as(b2)
            }
            (K::Field(a, i), K::Field(b, j)) => i == j && a.same_as(b),
            (K::If(a1, b1, c1), K::If(a2, b2, c2)) => {
                a1.same_as(a2) && b1.same_as(b2) && c1.same_as(c2)
            }
            (K::Call(f1, a1), K::Call(f2, a2)) => f1 == f2 && args_same(a1, a2),
            (K::Random(f1, a1), K::Random(f2, a2)) => f1 == f2 && args_same(a1, a2),
            (K::Shape(a), K::Shape(b)) => a == b,
            (K::Error, K::Error) => true,
            _ => false,
        }
    }

    /// A hash consistent with [`TExpr::same_as`].
    pub fn structural_hash<H: std::hash::Hasher>(&self, h: &mut H) {
        use std::hash::Hash;
        self.walk(&mut |e| {
            std::mem::discriminant(&e.kind).hash(h);
            e.ty.hash(h);
            match &e.kind {
                TExprKind::Lit(v) => hash_value(v, h),
                TExprKind::Param(p) => p.hash(h),
                TExprKind::Global(c) => c.hash(h),
                TExprKind::ModuleParam(s) => s.hash(h),
                TExprKind::Unary(op, _) => op.hash(h),
                TExprKind::Binary(op, ..) => op.hash(h),
                TExprKind::Field(_, i) => i.hash(h),
                TExprKind::Call(f, a) => {
                    f.hash(h);
                    a.len().hash(h);
                }
                TExprKind::Random(f, a) => {
                    f.hash(h);
                    a.len().hash(h);
                }
                TExprKind::Shape(v) => v.hash(h),
                TExprKind::If(..) | TExprKind::Error => {}
            }
        });
    }
}

fn args_same(a: &[TExpr], b: &[TExpr]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.same_as(y))
}

fn lit_eq(a: &Value, b: &Value) -> bool {
    match (a, b) {
        (Value::Float(x), Value::Float(y)) => x.to_bits() == y.to_bits(),
        (Value::Vec3(x), Value::Vec3(y)) => {
            x.iter().zip(y).all(|(p, q)| p.to_bits() == q.to_bits())
        }
        _ => a == b,
    }
}

fn hash_value<H: std::hash::Hasher>(v: &Value, h: &mut H) {
    use std::hash::Hash;
    match v {
        Value::Float(x) => x.to_bits().hash(h),
        Value::Vec3(xs) => {
            for x in xs {
                x.to_bits().hash(h);
            }
        }
        Value::Bool(b) => b.hash(h),
        Value::Mesh(m) => m.hash(h),
        Value::Material(m) => m.hash(h),
    }
}

/// The whole checked program: the root file and everything it imports.
#[derive(Clone, Debug)]
pub struct Program {
    /// The file that was checked.
    pub root: FileId,
    /// Global constants, in dependency order: a constant's value refers only
    /// to constants with a smaller id (and to meta-parameters).
    pub consts: Vec<Const>,
    /// Meta-parameters (sliders), in load order.
    pub params: Vec<MetaParam>,
    pub meshes: Vec<Mesh>,
    pub materials: Vec<Material>,
    /// All systems: the root file's first, in source order, then those of
    /// imported files in load order.
    pub systems: Vec<System>,
    /// The `layout` items of every file (docs/layout.md), in load order.
    pub layouts: Vec<crate::layout::LayoutDef>,
    /// Name occurrences and their definitions, for the language server.
    pub index: RefIndex,
    /// Every import that loaded a file: where it is written (the path
    /// string) and the file it loads, in load order.
    pub imports: Vec<(Loc, FileId)>,
}

impl Program {
    /// The default system: the first system of the root file (or, when the
    /// root defines none, the first system at all).
    pub fn default_system(&self) -> Option<&System> {
        self.systems
            .iter()
            .find(|s| s.loc.file == self.root)
            .or_else(|| self.systems.first())
    }

    /// The index of the system a run derives: the one named `name`, or
    /// without a name the [default](Program::default_system). `Err` is the
    /// R0701 diagnostic (no system at all, or none of that name), on the
    /// start of the root file.
    pub fn pick_system(&self, name: Option<&str>) -> Result<usize, grm_diag::Diagnostic> {
        let found = match name {
            Some(name) => self.systems.iter().position(|s| s.name == name),
            None => self
                .default_system()
                .and_then(|d| self.systems.iter().position(|s| std::ptr::eq(s, d))),
        };
        found.ok_or_else(|| {
            let code = grm_diag::Code::NoSystemToRun;
            let at = Span::new(0, 0);
            match name {
                None => grm_diag::Diagnostic::new(
                    code,
                    "this file defines no system to run",
                    self.root,
                    at,
                    "no `system NAME { ... }` in this file or its imports",
                )
                .with_help("add a `system NAME { ... }` block; see docs/language.md"),
                Some(name) => {
                    let names: Vec<String> = self
                        .systems
                        .iter()
                        .map(|s| format!("`{}`", s.name))
                        .collect();
                    let d = grm_diag::Diagnostic::new(
                        code,
                        format!("this file has no system `{name}`"),
                        self.root,
                        at,
                        format!("no system `{name}` in this file or its imports"),
                    );
                    if names.is_empty() {
                        d.with_note("this file defines no system")
                    } else {
                        d.with_help(format!("the systems are {}", names.join(", ")))
                    }
                }
            }
        })
    }

    pub fn system(&self, name: &str) -> Option<&System> {
        self.systems.iter().find(|s| s.name == name)
    }

    pub fn param_by_name(&self, name: &str) -> Option<ParamId> {
        self.params
            .iter()
            .position(|p| p.name == name)
            .map(|i| ParamId(i as u32))
    }

    /// The meta-parameters' default values, indexed by [`ParamId`].
    pub fn default_params(&self) -> Vec<Value> {
        self.params.iter().map(|p| p.default).collect()
    }

    /// The value of every constant for one run, given the meta-parameter
    /// values (indexed by [`ParamId`]). Constants are evaluated in id order,
    /// which is dependency order.
    pub fn global_values(&self, params: &[Value]) -> Result<Vec<Value>, crate::eval::EvalError> {
        let mut globals = Vec::with_capacity(self.consts.len());
        for c in &self.consts {
            let env = crate::eval::Env {
                params,
                globals: &globals,
                bindings: &[],
            };
            let v = crate::eval::eval(&c.value, &env)?;
            globals.push(v);
        }
        Ok(globals)
    }
}

/// `const NAME [: ty] = value;`
#[derive(Clone, Debug)]
pub struct Const {
    pub name: String,
    pub loc: Loc,
    pub ty: Ty,
    /// Folded to a [`TExprKind::Lit`] unless it depends on meta-parameters.
    pub value: TExpr,
}

/// `param NAME [: ty] = default [in lo .. hi];`: a slider.
#[derive(Clone, Debug)]
pub struct MetaParam {
    pub name: String,
    pub loc: Loc,
    pub ty: Ty,
    pub default: Value,
    /// `lo .. hi` (floats only), with `lo < hi` and the default inside.
    pub range: Option<(f64, f64)>,
}

/// `mesh NAME = "file.obj";`
#[derive(Clone, Debug)]
pub struct Mesh {
    pub name: String,
    pub loc: Loc,
    /// The path as written.
    pub written: String,
    /// The path resolved against the declaring file's directory.
    pub path: std::path::PathBuf,
}

/// `material NAME { prop = value; ... }`
#[derive(Clone, Debug)]
pub struct Material {
    pub name: String,
    pub loc: Loc,
    pub fields: Vec<MaterialField>,
}

impl Material {
    pub fn get(&self, prop: MaterialProp) -> Option<&TExpr> {
        self.fields
            .iter()
            .find(|f| f.prop == prop)
            .map(|f| &f.value)
    }
}

#[derive(Clone, Debug)]
pub struct MaterialField {
    pub prop: MaterialProp,
    /// Folded unless it depends on meta-parameters.
    pub value: TExpr,
    pub span: Span,
}

/// How a system is run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum Mode {
    /// Parallel L-system rewriting for `iterations` steps.
    #[default]
    Derive,
    /// Guided SOSMC search, then wrap-up, then the geometry phase.
    Sample,
    /// A split grammar for buildings (`mode = shape;`): rules rewrite
    /// shapes from a lot ([`System::shape`]).
    Shape,
}

impl Mode {
    /// `derive`, `sample` or `shape`, as written.
    pub fn name(self) -> &'static str {
        match self {
            Mode::Derive => "derive",
            Mode::Sample => "sample",
            Mode::Shape => "shape",
        }
    }
}

/// A system's settings, evaluated with the meta-parameters' defaults.
/// [`System::settings_with`] re-evaluates them for other parameter values.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// Default 1.
    pub iterations: u32,
    /// Degrees; default 90.
    pub angle: f32,
    /// Default 0.
    pub seed: u32,
    /// Default length of `F f G g`; default 1.
    pub step: f32,
    /// Initial width; default 0.1.
    pub width: f32,
    /// Tropism vector; `None` when not set.
    pub tropism: Option<[f32; 3]>,
    /// Tropism susceptibility; default 0.
    pub elasticity: f32,
    /// Sample systems: SOSMC generations; default 100.
    pub generations: u32,
    /// Sample systems: particles at the first generation; default 100.
    pub particles_start: u32,
    /// Sample systems: particles at the last generation; default 15.
    pub particles_end: u32,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            iterations: 1,
            angle: 90.0,
            seed: 0,
            step: 1.0,
            width: 0.1,
            tropism: None,
            elasticity: 0.0,
            generations: 100,
            particles_start: 100,
            particles_end: 15,
        }
    }
}

/// A setting as written, kept for re-evaluation with other meta-parameter
/// values and for the language server.
#[derive(Clone, Debug)]
pub struct SettingExpr {
    pub key: crate::builtins::SettingKey,
    pub value: TExpr,
    /// The whole `name = value;` statement.
    pub span: Span,
}

/// One grammar.
#[derive(Clone, Debug)]
pub struct System {
    pub name: String,
    /// The name's location.
    pub loc: Loc,
    /// The file the system is written in (all spans below are in it).
    pub file: FileId,
    /// The whole `system NAME { ... }`.
    pub span: Span,
    pub mode: Mode,
    /// Evaluated with the meta-parameters' defaults.
    pub settings: Settings,
    /// The settings as written (except `mode`), in source order.
    pub setting_exprs: Vec<SettingExpr>,
    /// The start string. Empty only when the system has none (E0310).
    pub axiom: Vec<TModule>,
    /// Symbols skipped while matching contexts.
    pub ignore: Vec<SymbolId>,
    pub symbols: Vec<SymbolInfo>,
    /// Production groups in source order (by first production); wrap-up
    /// groups are included with [`Group::wrapup`] set. Empty in a shape
    /// system.
    pub groups: Vec<Group>,
    /// A shape system's lot and rules (`Some` exactly when
    /// [`System::mode`] is [`Mode::Shape`]; then `axiom`, `symbols` and
    /// `groups` are empty).
    pub shape: Option<Box<crate::shape::ShapeSystem>>,
}

impl System {
    /// Per symbol (by [`SymbolId`] index): its built-in terminal, or `None`
    /// for a user symbol. The table the turtle, the sampler and the model
    /// budget interpret strings with.
    pub fn terminals(&self) -> Vec<Option<Terminal>> {
        self.symbols
            .iter()
            .map(|s| match s.kind {
                SymbolKind::Terminal(t) => Some(t),
                SymbolKind::User => None,
            })
            .collect()
    }

    pub fn symbol(&self, id: SymbolId) -> &SymbolInfo {
        &self.symbols[id.index()]
    }

    pub fn symbol_by_name(&self, name: &str) -> Option<SymbolId> {
        self.symbols
            .iter()
            .position(|s| s.name == name)
            .map(|i| SymbolId(i as u32))
    }

    /// The groups for a symbol, normal ones in try order (wrap-up groups excluded).
    pub fn groups_of(&self, id: SymbolId) -> impl Iterator<Item = &Group> {
        self.symbol(id)
            .groups
            .iter()
            .map(|g| &self.groups[g.index()])
    }

    /// Per symbol: whether it is a skeleton symbol that can draw a bone or
    /// finish, i.e. some production (wrap-ups excluded) draws one (`F`,
    /// `G`), emits a skeleton symbol that can, or emits no skeleton symbol
    /// at all; conditions are not evaluated. A skeleton symbol with
    /// productions that is `false` here can never lead to a bone (W0015),
    /// and the guided sampler stops expanding a particle whose open
    /// symbols are all such. `false` for every other symbol.
    pub fn skeleton_grows(&self) -> Vec<bool> {
        let is_skeleton = |i: usize| self.symbols[i].phase == Phase::Skeleton;
        let draws = |i: usize| {
            matches!(
                self.symbols[i].terminal(),
                Some(Terminal::Forward | Terminal::ForwardNoVertex)
            )
        };
        let mut grows = vec![false; self.symbols.len()];
        loop {
            let mut changed = false;
            for g in self.groups.iter().filter(|g| !g.wrapup) {
                let pred = g.pred.symbol.index();
                if grows[pred] || !is_skeleton(pred) {
                    continue;
                }
                let way_out = g.alternatives.iter().any(|a| {
                    let succ = || a.successor.iter().map(|m| m.symbol.index());
                    succ().any(|m| draws(m) || (is_skeleton(m) && grows[m]))
                        || !succ().any(is_skeleton)
                });
                if way_out {
                    grows[pred] = true;
                    changed = true;
                }
            }
            if !changed {
                return grows;
            }
        }
    }

    /// The wrap-up groups for a symbol, in try order.
    pub fn wrapups_of(&self, id: SymbolId) -> impl Iterator<Item = &Group> {
        self.symbol(id)
            .wrapup_groups
            .iter()
            .map(|g| &self.groups[g.index()])
    }

    /// Re-evaluate the settings for the given meta-parameter values
    /// (indexed by [`ParamId`]) and global values (from
    /// [`Program::global_values`]).
    pub fn settings_with(&self, params: &[Value], globals: &[Value]) -> Result<Settings, String> {
        self.settings_at(params, globals).map_err(|(m, _)| m)
    }

    /// [`System::settings_with`], the error with the span of the setting
    /// statement that failed.
    pub fn settings_at(
        &self,
        params: &[Value],
        globals: &[Value],
    ) -> Result<Settings, (String, Span)> {
        let env = crate::eval::Env {
            params,
            globals,
            bindings: &[],
        };
        let mut s = Settings::default();
        for se in &self.setting_exprs {
            let v =
                crate::eval::eval_setting(&se.value, &env).map_err(|e| (e.to_string(), se.span))?;
            se.key.apply(&mut s, v).map_err(|m| (m, se.span))?;
        }
        Ok(s)
    }
}

/// What a module symbol is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SymbolKind {
    /// A user symbol (rewritten by productions, or inert).
    User,
    /// A built-in turtle, transform or geometry terminal.
    Terminal(Terminal),
}

/// A module symbol of one system.
#[derive(Clone, Debug)]
pub struct SymbolInfo {
    /// As written (for terminals: the canonical spelling, e.g. `[` for `push`).
    pub name: String,
    pub kind: SymbolKind,
    /// Number of parameters every module of this symbol carries.
    pub arity: usize,
    /// Parameter types (inferred, declared, or fixed for terminals).
    pub params: Vec<Ty>,
    /// Parameter names from a declaration (`module A(len, w)`), if any.
    pub param_names: Vec<Option<String>>,
    /// Declared phase (`Phase::None` when undeclared or for terminals).
    pub phase: Phase,
    /// Where the phase or signature was declared.
    pub decl: Option<Span>,
    /// The first occurrence in the system (declaration or use).
    pub first: Span,
    /// Normal production groups with this predecessor, in try order.
    pub groups: Vec<GroupId>,
    /// Wrap-up groups with this predecessor, in try order.
    pub wrapup_groups: Vec<GroupId>,
}

impl SymbolInfo {
    pub fn terminal(&self) -> Option<Terminal> {
        match self.kind {
            SymbolKind::Terminal(t) => Some(t),
            SymbolKind::User => None,
        }
    }

    pub fn is_terminal(&self) -> bool {
        self.terminal().is_some()
    }

    /// A terminal that draws geometry (primitives, meshes, materials).
    pub fn is_geometry_terminal(&self) -> bool {
        self.terminal().is_some_and(Terminal::is_geometry)
    }
}

/// A module in an axiom or successor.
#[derive(Clone, Debug)]
pub struct TModule {
    pub symbol: SymbolId,
    /// Exactly `arity` arguments (omitted arguments of terminals are filled
    /// in: `F` becomes `F(step)`).
    pub args: Vec<TExpr>,
    pub span: Span,
}

/// A predecessor or context pattern: it matches modules of `symbol` and
/// binds their parameters to slots `first_slot .. first_slot + binds`.
#[derive(Clone, Debug)]
pub struct TPattern {
    pub symbol: SymbolId,
    pub first_slot: u32,
    /// How many parameters it binds: the symbol's arity, or 0 for a terminal
    /// written without parameters (`F` matches every `F(l)`).
    pub binds: u32,
    pub span: Span,
}

/// An element of a context.
#[derive(Clone, Debug)]
pub enum TContextItem {
    Pattern(TPattern),
    Push(Span),
    Pop(Span),
}

/// Productions with the same predecessor, contexts and condition: one of
/// the alternatives is drawn with probability weight / sum of weights.
///
/// Binding slots are numbered in text order: the left context's patterns,
/// then the predecessor, then the right context's patterns.
#[derive(Clone, Debug)]
pub struct Group {
    pub wrapup: bool,
    pub left: Vec<TContextItem>,
    pub pred: TPattern,
    pub right: Vec<TContextItem>,
    /// Over the binding slots; `None` when absent.
    pub condition: Option<TExpr>,
    /// Number of binding slots.
    pub slots: u32,
    /// In source order; never empty.
    pub alternatives: Vec<Alternative>,
}

impl Group {
    pub fn has_context(&self) -> bool {
        !self.left.is_empty() || !self.right.is_empty()
    }

    /// The probability of each alternative when all weights are constant.
    pub fn probabilities(&self) -> Option<Vec<f64>> {
        let ws: Option<Vec<f64>> = self
            .alternatives
            .iter()
            .map(|a| a.weight.constant().and_then(|v| v.as_float()))
            .collect();
        let ws = ws?;
        let sum: f64 = ws.iter().sum();
        if sum.is_nan() || sum <= 0.0 {
            return None;
        }
        Some(ws.iter().map(|w| w / sum).collect())
    }
}

/// One production of a group.
#[derive(Clone, Debug)]
pub struct Alternative {
    /// `Lit(1.0)` when not written.
    pub weight: TExpr,
    pub weight_written: bool,
    pub successor: Vec<TModule>,
    /// The names this production binds, one per slot, in slot order.
    pub bindings: Vec<Binding>,
    /// This production's own predecessor pattern.
    pub pred: Span,
    /// The whole production.
    pub span: Span,
    /// The `->`.
    pub arrow: Span,
}

/// A name bound by a pattern.
#[derive(Clone, Debug)]
pub struct Binding {
    pub name: grm_syntax::ast::Name,
    pub span: Span,
    pub ty: Ty,
}

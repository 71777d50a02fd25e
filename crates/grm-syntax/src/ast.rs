//! The abstract syntax tree of a `.grm` file.
//!
//! Every node carries the byte [`Span`] of the text it came from. The parser
//! never fails: where the text is broken it inserts `Error` nodes
//! ([`Item::Error`], [`SystemItem::Error`], [`ExprKind::Error`]) and reports
//! a diagnostic, so later phases see a complete tree and skip the holes
//! silently (the hole has already been reported once).

pub use grm_diag::Span;

/// The text of a name, symbol or number as written: kept inline up to 24
/// bytes (every name of a real grammar), on the heap only past that. A
/// `String` each was a heap block of a few bytes, which the allocator
/// rounds up to 32: a large file's tree held one per name (issue 32).
pub type Name = compact_str::CompactString;

/// A whole file.
#[derive(Clone, Debug, PartialEq)]
pub struct File {
    pub items: Vec<Item>,
    pub span: Span,
}

/// A name as written, with its span.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Ident {
    pub name: Name,
    pub span: Span,
}

/// A string literal: `value` is the unescaped content, `span` includes the quotes.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StrLit {
    pub value: String,
    pub span: Span,
}

/// A top-level item.
#[derive(Clone, Debug, PartialEq)]
pub enum Item {
    /// `import "path.grm";`
    Import(Import),
    /// `const NAME [: type] = expr;`
    Const(ConstDecl),
    /// `param NAME [: type] = default [in lo .. hi];`
    Param(ParamDecl),
    /// `mesh NAME = "file.obj";`
    Mesh(MeshDecl),
    /// `material NAME { key = expr; ... }`
    Material(MaterialDecl),
    /// `system NAME { ... }`
    System(System),
    /// `layout NAME { key = expr; ... }`: a city layout (docs/layout.md).
    Layout(LayoutDecl),
    /// Text the parser could not make sense of (already reported).
    Error(Span),
}

impl Item {
    pub fn span(&self) -> Span {
        match self {
            Item::Import(i) => i.span,
            Item::Const(c) => c.span,
            Item::Param(p) => p.span,
            Item::Mesh(m) => m.span,
            Item::Material(m) => m.span,
            Item::System(s) => s.span,
            Item::Layout(l) => l.span,
            Item::Error(s) => *s,
        }
    }
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Import {
    pub path: StrLit,
    pub span: Span,
}

/// A type annotation: a name that the checker resolves (`float`, `vec3`, `bool`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TypeAnn {
    pub name: Ident,
}

#[derive(Clone, Debug, PartialEq)]
pub struct ConstDecl {
    pub name: Ident,
    pub ty: Option<TypeAnn>,
    pub value: Expr,
    pub span: Span,
}

/// A meta-parameter: shown as a slider in the preview, overridable from the CLI.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamDecl {
    pub name: Ident,
    pub ty: Option<TypeAnn>,
    pub default: Expr,
    /// `in lo .. hi`
    pub range: Option<(Expr, Expr)>,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MeshDecl {
    pub name: Ident,
    pub path: StrLit,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub struct MaterialDecl {
    pub name: Ident,
    pub fields: Vec<Field>,
    pub span: Span,
}

/// `layout NAME { key = expr; ... }`: a city layout. `layout` is a
/// keyword only before a name and `{`. Each field is a layer, bottom to
/// top (`base = grid(9, 6, 80, 60);`), except `buildings = System;`, the
/// shape system every parcel grows, and `seed = N;`; the checker gives
/// them their meaning (grm-sema, docs/layout.md).
#[derive(Clone, Debug, PartialEq)]
pub struct LayoutDecl {
    pub name: Ident,
    pub fields: Vec<Field>,
    pub span: Span,
}

/// `key = expr;` inside a material or a layout.
#[derive(Clone, Debug, PartialEq)]
pub struct Field {
    pub name: Ident,
    pub value: Expr,
    pub span: Span,
}

/// `system NAME { items }`: one grammar with its settings.
#[derive(Clone, Debug, PartialEq)]
pub struct System {
    pub name: Ident,
    pub items: Vec<SystemItem>,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub enum SystemItem {
    /// `axiom MODULES;`
    Axiom(Axiom),
    /// `NAME = expr;` (iterations, angle, seed, mode, step, width, tropism, ...)
    Setting(Setting),
    /// `ignore SYMBOLS;` the context ignore list.
    Ignore(Ignore),
    /// `module A(x: float), B;` / `skeleton ...;` / `geometry ...;`
    ModuleDecl(ModuleDecl),
    /// `[wrapup] [LEFT <] PRED [> RIGHT] [: COND] -> [(WEIGHT)] SUCCESSOR;`
    Production(Production),
    /// Text the parser could not make sense of (already reported).
    Error(Span),
}

impl SystemItem {
    pub fn span(&self) -> Span {
        match self {
            SystemItem::Axiom(a) => a.span,
            SystemItem::Setting(s) => s.span,
            SystemItem::Ignore(i) => i.span,
            SystemItem::ModuleDecl(m) => m.span,
            SystemItem::Production(p) => p.span,
            SystemItem::Error(s) => *s,
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct Axiom {
    pub modules: Vec<Module>,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Setting {
    pub name: Ident,
    pub value: Expr,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Ignore {
    pub symbols: Vec<Symbol>,
    pub span: Span,
}

/// Which keyword introduced a module declaration.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Phase {
    /// `module`: no phase (derive systems).
    None,
    /// `skeleton`: expanded during the guided search; may not emit geometry.
    Skeleton,
    /// `geometry`: expanded to completion after the search.
    Geometry,
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ModuleDecl {
    pub phase: Phase,
    /// Span of the introducing keyword.
    pub keyword: Span,
    pub modules: Vec<ModuleSig>,
    pub span: Span,
}

/// `A(x: float, y)` in a declaration. `params` is `None` when no
/// parentheses were written (arity left to inference).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ModuleSig {
    pub symbol: Symbol,
    pub params: Option<Vec<ParamSig>>,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ParamSig {
    pub name: Ident,
    pub ty: Option<TypeAnn>,
    pub span: Span,
}

/// A module symbol: an identifier (`A`, `branch`, `F`) or one of the
/// turtle punctuation symbols (`+ - & ^ \ / | [ ] ! ' { . } $ %`).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Symbol {
    pub name: Name,
    pub span: Span,
}

impl Symbol {
    /// Whether the symbol is punctuation rather than an identifier.
    pub fn is_punct(&self) -> bool {
        !self
            .name
            .chars()
            .next()
            .is_some_and(|c| c.is_alphabetic() || c == '_')
    }
}

/// A production. Several productions with the same predecessor symbol,
/// contexts and condition form one stochastic group; their weights are
/// normalized within the group.
#[derive(Clone, Debug, PartialEq)]
pub struct Production {
    /// Introduced by `wrapup` (sample systems: closes a skeleton symbol).
    pub wrapup: bool,
    /// Left context, `L <`; empty when absent.
    pub left: Vec<ContextItem>,
    /// The predecessor.
    pub pred: Pattern,
    /// Right context, `> R`; empty when absent.
    pub right: Vec<ContextItem>,
    /// `: cond`
    pub condition: Option<Expr>,
    /// `(weight)` right after the arrow.
    pub weight: Option<Expr>,
    /// The successor: possibly empty.
    pub successor: Vec<Module>,
    /// Span of `->`.
    pub arrow: Span,
    pub span: Span,
}

/// A module pattern in a predecessor or context: `A(x, y)` binds x and y.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Pattern {
    pub symbol: Symbol,
    pub params: Vec<Ident>,
    pub span: Span,
}

/// An element of a context: a pattern, or a bracket (`[` / `]`) in a right
/// context.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ContextItem {
    Pattern(Pattern),
    Push(Span),
    Pop(Span),
}

impl ContextItem {
    pub fn span(&self) -> Span {
        match self {
            ContextItem::Pattern(p) => p.span,
            ContextItem::Push(s) | ContextItem::Pop(s) => *s,
        }
    }
}

/// A module in a successor or axiom: `F(l * 0.5)`, `[`, `+`, `branch`;
/// in a shape system also an operation, and a shape command with its
/// parts: `split(y) { 4: Ground | ~3.5: Floor }`.
#[derive(Clone, Debug, PartialEq)]
pub struct Module {
    pub symbol: Symbol,
    /// Held at their number (a boxed slice: a module stays 64 bytes with
    /// the parts' slot beside it; issue 32).
    pub args: Box<[Expr]>,
    pub span: Span,
    /// The parts of a shape command (`{ ... }` after its arguments).
    pub parts: Option<Box<ShapeParts>>,
}

/// The parts of a shape command: `{ 4: Ground | 25%: Band | ~1: Floor }`,
/// or the cases of a component split, `{ front: Facade | side: Wall }`.
#[derive(Clone, Debug, PartialEq)]
pub struct ShapeParts {
    pub parts: Vec<ShapePart>,
    /// From `{` to `}`.
    pub span: Span,
}

/// How a part's size is written.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PartKind {
    /// `4: A`: a length (for a component split, a selector name: `front: A`).
    Absolute,
    /// `25%: A`: a percentage of the scope.
    Relative,
    /// `~1: A`: a floating size, sharing what the others leave.
    Floating,
}

/// One part: `~3.5: Floor`.
#[derive(Clone, Debug, PartialEq)]
pub struct ShapePart {
    pub kind: PartKind,
    /// The size (or the selector of a component split's case).
    pub value: Expr,
    /// The shape made there (`nil`: nothing).
    pub target: Symbol,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Expr {
    pub kind: ExprKind,
    pub span: Span,
}

/// Expressions are dropped without recursion: the parser builds trees as
/// deep as the text nests before it can refuse them (a statement rejected
/// after a deeply nested expression drops the parser's stack, holding that
/// tree), and a recursive drop of such a tree would overflow the stack.
impl Drop for Expr {
    fn drop(&mut self) {
        if matches!(
            self.kind,
            ExprKind::Number { .. }
                | ExprKind::Bool(_)
                | ExprKind::Str(_)
                | ExprKind::Name(_)
                | ExprKind::Error
        ) {
            return;
        }
        let mut stack = Vec::new();
        self.kind.take_children(&mut stack);
        // Each popped node's children are taken before it drops, so its
        // own `drop` finds a leaf.
        while let Some(mut e) = stack.pop() {
            e.kind.take_children(&mut stack);
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub enum ExprKind {
    /// A number literal; `text` is as written (the formatter keeps it).
    Number {
        value: f64,
        text: Name,
    },
    Bool(bool),
    /// A string literal, unescaped: a file name where one is taken (a
    /// shape system's `lot = "block.geojson";`, `texture("brick.png")`);
    /// not a value anywhere else.
    Str(String),
    /// A constant, meta-parameter, module parameter, mesh or material name.
    Name(Ident),
    /// `f(a, b)`: built-in functions and random draws.
    Call {
        func: Ident,
        args: Vec<Expr>,
    },
    Unary {
        op: UnaryOp,
        operand: Box<Expr>,
    },
    Binary {
        op: BinaryOp,
        lhs: Box<Expr>,
        rhs: Box<Expr>,
    },
    /// `v.x`
    Field {
        base: Box<Expr>,
        field: Ident,
    },
    /// `if c then a else b`
    If {
        cond: Box<Expr>,
        then: Box<Expr>,
        els: Box<Expr>,
    },
    /// `(e)`: kept so spans and formatting follow the text.
    Paren(Box<Expr>),
    /// An expression the parser could not read (already reported).
    Error,
}

impl ExprKind {
    /// Move the sub-expressions onto `out`, leaving `Error` behind.
    fn take_children(&mut self, out: &mut Vec<Expr>) {
        match std::mem::replace(self, ExprKind::Error) {
            ExprKind::Call { args, .. } => out.extend(args),
            ExprKind::Unary { operand, .. } => out.push(*operand),
            ExprKind::Binary { lhs, rhs, .. } => out.extend([*lhs, *rhs]),
            ExprKind::Field { base, .. } => out.push(*base),
            ExprKind::If { cond, then, els } => out.extend([*cond, *then, *els]),
            ExprKind::Paren(inner) => out.push(*inner),
            ExprKind::Number { .. }
            | ExprKind::Bool(_)
            | ExprKind::Str(_)
            | ExprKind::Name(_)
            | ExprKind::Error => {}
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum UnaryOp {
    Neg,
    Not,
}

impl UnaryOp {
    pub fn as_str(self) -> &'static str {
        match self {
            UnaryOp::Neg => "-",
            UnaryOp::Not => "!",
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BinaryOp {
    Add,
    Sub,
    Mul,
    Div,
    Rem,
    Lt,
    Le,
    Gt,
    Ge,
    Eq,
    Ne,
    And,
    Or,
}

impl BinaryOp {
    pub fn as_str(self) -> &'static str {
        match self {
            BinaryOp::Add => "+",
            BinaryOp::Sub => "-",
            BinaryOp::Mul => "*",
            BinaryOp::Div => "/",
            BinaryOp::Rem => "%",
            BinaryOp::Lt => "<",
            BinaryOp::Le => "<=",
            BinaryOp::Gt => ">",
            BinaryOp::Ge => ">=",
            BinaryOp::Eq => "==",
            BinaryOp::Ne => "!=",
            BinaryOp::And => "&&",
            BinaryOp::Or => "||",
        }
    }

    /// Binding strength: higher binds tighter.
    pub fn precedence(self) -> u8 {
        match self {
            BinaryOp::Or => 1,
            BinaryOp::And => 2,
            BinaryOp::Eq | BinaryOp::Ne => 3,
            BinaryOp::Lt | BinaryOp::Le | BinaryOp::Gt | BinaryOp::Ge => 4,
            BinaryOp::Add | BinaryOp::Sub => 5,
            BinaryOp::Mul | BinaryOp::Div | BinaryOp::Rem => 6,
        }
    }
}

/// A comment kept for the formatter and the language server.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Comment {
    /// Including the `//` or `/* */` delimiters. Inline up to 24 bytes
    /// (most line comments), as a [`Name`] is.
    pub text: Name,
    pub span: Span,
}

//! Expressions in shape rules: numbers and conditions evaluated per shape
//! (docs/shapes.md, "Expressions").
//!
//! The front-end lowers a checked expression into an [`Expr`] (a tree,
//! built once) and hands it to [`ProgramBuilder::expr`](crate::ProgramBuilder::expr),
//! which type-checks it and compiles it into the program's one flat
//! postfix code array; the [`ExprId`] it returns goes into a
//! [`Param::Expr`](crate::Param::Expr) (a number), an alternative's
//! condition or weight. Evaluation is a small stack machine over `f32`
//! (a boolean is 1 or 0), run for one shape with its context: the scope
//! at the point of the rule where the number is read, the shape's index
//! and count, its depth, the tags on its path, its identity key (for
//! random draws) and, in the second pass of a program with context
//! queries, the shapes of the first pass.
//!
//! Every operation is total: arithmetic follows IEEE (a division by zero is
//! an infinity or NaN, never a panic), and what a NaN does is decided where
//! the number is used (docs/shapes.md, "Expressions").

use crate::ir::{Axis, SymbolId, TagId};
use crate::query::Queries;
use crate::scope::Scope;
use grm_compile::rng;
use grm_compile::table::WEIGHT_SCALE;
use grm_compile::vm::{floored_rem, rand_int, rand_uniform};

/// A context query: how the asking shape's box relates to the boxes of
/// the first pass's shapes of a symbol (docs/shapes.md, "Context
/// queries"); the language's word, `grm_sema::shape::ShapeQuery`.
pub use grm_sema::shape::ShapeQuery as Query;

/// An expression of a program (made by [`ProgramBuilder::expr`](crate::ProgramBuilder::expr)).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ExprId(pub u32);

/// An expression's type.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Type {
    /// An `f32`.
    Num,
    /// A boolean.
    Bool,
}

impl Type {
    /// `number` or `boolean`.
    pub fn name(self) -> &'static str {
        match self {
            Type::Num => "number",
            Type::Bool => "boolean",
        }
    }
}

/// A function of one argument.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Unary {
    /// `-x` (number).
    Neg,
    /// `!b` (boolean).
    Not,
    Abs,
    Floor,
    Ceil,
    /// Half away from zero (`f32::round`, as grm's `round`).
    Round,
    /// NaN below 0.
    Sqrt,
    /// Radians.
    Sin,
    /// Radians.
    Cos,
}

/// An operator or function of two arguments.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Binary {
    Add,
    Sub,
    Mul,
    Div,
    /// Floored remainder (`x - y * floor(x / y)`, as grm's `%`).
    Rem,
    Pow,
    Min,
    Max,
    Lt,
    Le,
    Gt,
    Ge,
    /// Equal (numbers: exactly; booleans: the same).
    Eq,
    Ne,
    /// `&&` (booleans; both sides are evaluated: nothing has side effects).
    And,
    /// `||`.
    Or,
}

/// An expression as the front-end builds it (a tree; compiled to flat code
/// by [`ProgramBuilder::expr`](crate::ProgramBuilder::expr)).
///
/// ```
/// use grm_shape::{Axis, Expr};
/// // scope.x > 3 && index == count
/// let wide_top = Expr::Size(Axis::X)
///     .gt(Expr::Num(3.0))
///     .and(Expr::Index.eq(Expr::Count));
/// // uniform(0.8, 1.2) * scope.y
/// let h = Expr::uniform(Expr::Num(0.8), Expr::Num(1.2)) * Expr::Size(Axis::Y);
/// # let _ = (wide_top, h);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub enum Expr {
    Num(f32),
    Bool(bool),
    /// The scope's size along an axis (the current scope: after the
    /// rule's earlier scope operations).
    Size(Axis),
    /// The world position of the scope's origin (a corner), one coordinate.
    Position(Axis),
    /// The shape's semantic index (from 1): its part in a split, its tile
    /// in a repeat, its index within its component case, its edge
    /// otherwise; 0 for the axiom.
    Index,
    /// The count that goes with [`Expr::Index`]: parts, tiles, components
    /// of the case, or its parent's edges; 0 for the axiom.
    Count,
    /// The shape's depth in the tree (the axiom is 0; a split's child is
    /// two deeper than its parent: the command node is between).
    Depth,
    /// Whether a command tagged so is on the shape's path.
    Tagged(TagId),
    /// The semantic index under the nearest command tagged so on the
    /// shape's path (its child's index there), 0 when there is none.
    TagIndex(TagId),
    /// The count that goes with [`Expr::TagIndex`], 0 when there is none.
    TagCount(TagId),
    Unary(Unary, Box<Expr>),
    Binary(Binary, Box<Expr>, Box<Expr>),
    /// `clamp(x, lo, hi)`: `min(max(x, lo), hi)`.
    Clamp(Box<Expr>, Box<Expr>, Box<Expr>),
    /// `if c then a else b` (`a` and `b` of one type).
    If(Box<Expr>, Box<Expr>, Box<Expr>),
    /// `uniform(a, b)`: `a + (b - a) * u` (grm's `rand.uniform`).
    Uniform(Box<Expr>, Box<Expr>),
    /// `randint(a, b)`: a whole number between `round(a)` and `round(b)`,
    /// both included (grm's `rand.int`).
    RandInt(Box<Expr>, Box<Expr>),
    /// `normal(mean, sd)`: Box-Muller on two draws (grm's `rand.normal`).
    Normal(Box<Expr>, Box<Expr>),
    /// `chance(p)`: `u < p` (boolean).
    Chance(Box<Expr>),
    /// `choose(v0: w0, v1: w1, ...)`: a value with probability in
    /// proportion to its weight (negative and NaN weights count as 0; NaN
    /// when no weight is positive), as grm's `rand.choose`.
    Choose(Vec<(Expr, Expr)>),
    /// A context query against the shapes of a symbol (boolean).
    Query(Query, SymbolId),
}

fn bx(e: Expr) -> Box<Expr> {
    Box::new(e)
}

impl Expr {
    fn bin(op: Binary, a: Expr, b: Expr) -> Expr {
        Expr::Binary(op, bx(a), bx(b))
    }
    /// `self < o`.
    pub fn lt(self, o: Expr) -> Expr {
        Expr::bin(Binary::Lt, self, o)
    }
    /// `self <= o`.
    pub fn le(self, o: Expr) -> Expr {
        Expr::bin(Binary::Le, self, o)
    }
    /// `self > o`.
    pub fn gt(self, o: Expr) -> Expr {
        Expr::bin(Binary::Gt, self, o)
    }
    /// `self >= o`.
    pub fn ge(self, o: Expr) -> Expr {
        Expr::bin(Binary::Ge, self, o)
    }
    /// `self == o`.
    #[allow(clippy::should_implement_trait)]
    pub fn eq(self, o: Expr) -> Expr {
        Expr::bin(Binary::Eq, self, o)
    }
    /// `self != o`.
    pub fn ne(self, o: Expr) -> Expr {
        Expr::bin(Binary::Ne, self, o)
    }
    /// `self && o`.
    pub fn and(self, o: Expr) -> Expr {
        Expr::bin(Binary::And, self, o)
    }
    /// `self || o`.
    pub fn or(self, o: Expr) -> Expr {
        Expr::bin(Binary::Or, self, o)
    }
    /// `min(self, o)`.
    pub fn min(self, o: Expr) -> Expr {
        Expr::bin(Binary::Min, self, o)
    }
    /// `max(self, o)`.
    pub fn max(self, o: Expr) -> Expr {
        Expr::bin(Binary::Max, self, o)
    }
    /// `pow(self, o)`.
    pub fn pow(self, o: Expr) -> Expr {
        Expr::bin(Binary::Pow, self, o)
    }
    /// A function of one argument applied to `self`.
    pub fn apply(self, f: Unary) -> Expr {
        Expr::Unary(f, bx(self))
    }
    /// `if self then a else b`.
    pub fn then(self, a: Expr, b: Expr) -> Expr {
        Expr::If(bx(self), bx(a), bx(b))
    }
    /// `clamp(self, lo, hi)`.
    pub fn clamp(self, lo: Expr, hi: Expr) -> Expr {
        Expr::Clamp(bx(self), bx(lo), bx(hi))
    }
    /// `uniform(a, b)`.
    pub fn uniform(a: Expr, b: Expr) -> Expr {
        Expr::Uniform(bx(a), bx(b))
    }
    /// `randint(a, b)`.
    pub fn randint(a: Expr, b: Expr) -> Expr {
        Expr::RandInt(bx(a), bx(b))
    }
    /// `normal(mean, sd)`.
    pub fn normal(mean: Expr, sd: Expr) -> Expr {
        Expr::Normal(bx(mean), bx(sd))
    }
    /// `chance(p)`.
    pub fn chance(p: Expr) -> Expr {
        Expr::Chance(bx(p))
    }
}

macro_rules! arith {
    ($tr:ident, $f:ident, $op:ident) => {
        impl std::ops::$tr for Expr {
            type Output = Expr;
            fn $f(self, o: Expr) -> Expr {
                Expr::bin(Binary::$op, self, o)
            }
        }
    };
}
arith!(Add, add, Add);
arith!(Sub, sub, Sub);
arith!(Mul, mul, Mul);
arith!(Div, div, Div);
arith!(Rem, rem, Rem);

impl std::ops::Neg for Expr {
    type Output = Expr;
    fn neg(self) -> Expr {
        self.apply(Unary::Neg)
    }
}

impl std::ops::Not for Expr {
    type Output = Expr;
    fn not(self) -> Expr {
        self.apply(Unary::Not)
    }
}

impl From<f32> for Expr {
    fn from(v: f32) -> Self {
        Expr::Num(v)
    }
}

/// One instruction of the postfix code.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Instr {
    Const(f32),
    Size(u8),
    Position(u8),
    Index,
    Count,
    Depth,
    Tagged(TagId),
    TagIndex(TagId),
    TagCount(TagId),
    Un(Unary),
    Bin(Binary),
    Clamp,
    Select,
    /// The operand is the draw's local number within the expression (from 1).
    Uniform(u32),
    RandInt(u32),
    Normal(u32),
    Chance(u32),
    Choose {
        n: u32,
        local: u32,
    },
    Query(Query, SymbolId),
}

/// One compiled expression: its code range and what it needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Entry {
    start: u32,
    len: u32,
    pub ty: Type,
    /// How many draw numbers it uses (`normal` uses two).
    pub draws: u32,
    /// The deepest its stack goes.
    stack: u32,
}

/// Why an expression could not be compiled.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum CompileError {
    Type(String),
    TooDeep,
    UnknownTag(u32),
    UnknownSymbol(u32),
}

/// The deepest an expression tree may nest.
pub const MAX_EXPR_DEPTH: usize = 256;

/// What a program's expressions use (so that a program without them pays
/// nothing).
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Uses {
    /// Some expression reads tags.
    pub tags: bool,
    /// The symbols some expression queries, sorted, each once.
    pub queried: Vec<SymbolId>,
}

/// The program's expressions: one flat code array.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Exprs {
    code: Vec<Instr>,
    entries: Vec<Entry>,
    pub uses: Uses,
}

impl Exprs {
    pub fn entry(&self, id: ExprId) -> Option<&Entry> {
        self.entries.get(id.0 as usize)
    }

    /// Compile `e`, with `n_tags` tags and `n_symbols` symbols declared.
    pub fn compile(
        &mut self,
        e: &Expr,
        n_tags: usize,
        n_symbols: usize,
    ) -> Result<ExprId, CompileError> {
        let start = self.code.len();
        let mut c = Compiler {
            code: &mut self.code,
            uses: &mut self.uses,
            n_tags,
            n_symbols,
            draws: 0,
            sp: 0,
            max_sp: 0,
        };
        let r = c.expr(e, 0);
        let (draws, stack) = (c.draws, c.max_sp);
        match r {
            Ok(ty) => {
                self.entries.push(Entry {
                    start: start as u32,
                    len: (self.code.len() - start) as u32,
                    ty,
                    draws,
                    stack,
                });
                Ok(ExprId(self.entries.len() as u32 - 1))
            }
            Err(err) => {
                self.code.truncate(start);
                Err(err)
            }
        }
    }
}

struct Compiler<'a> {
    code: &'a mut Vec<Instr>,
    uses: &'a mut Uses,
    n_tags: usize,
    n_symbols: usize,
    draws: u32,
    sp: u32,
    max_sp: u32,
}

impl Compiler<'_> {
    fn emit(&mut self, i: Instr, pops: u32) {
        self.code.push(i);
        self.sp = self.sp - pops + 1;
        self.max_sp = self.max_sp.max(self.sp);
    }

    fn draw(&mut self, n: u32) -> u32 {
        let local = self.draws + 1;
        self.draws += n;
        local
    }

    fn want(&mut self, e: &Expr, ty: Type, depth: usize, what: &str) -> Result<(), CompileError> {
        let got = self.expr(e, depth + 1)?;
        if got == ty {
            Ok(())
        } else {
            Err(CompileError::Type(format!(
                "{what} must be a {}, not a {}",
                ty.name(),
                got.name()
            )))
        }
    }

    fn tag(&mut self, t: TagId) -> Result<TagId, CompileError> {
        if (t.0 as usize) < self.n_tags {
            self.uses.tags = true;
            Ok(t)
        } else {
            Err(CompileError::UnknownTag(t.0))
        }
    }

    fn expr(&mut self, e: &Expr, depth: usize) -> Result<Type, CompileError> {
        use Type::{Bool, Num};
        if depth > MAX_EXPR_DEPTH {
            return Err(CompileError::TooDeep);
        }
        Ok(match e {
            Expr::Num(v) => {
                self.emit(Instr::Const(*v), 0);
                Num
            }
            Expr::Bool(b) => {
                self.emit(Instr::Const(if *b { 1.0 } else { 0.0 }), 0);
                Bool
            }
            Expr::Size(a) => {
                self.emit(Instr::Size(a.index() as u8), 0);
                Num
            }
            Expr::Position(a) => {
                self.emit(Instr::Position(a.index() as u8), 0);
                Num
            }
            Expr::Index => {
                self.emit(Instr::Index, 0);
                Num
            }
            Expr::Count => {
                self.emit(Instr::Count, 0);
                Num
            }
            Expr::Depth => {
                self.emit(Instr::Depth, 0);
                Num
            }
            Expr::Tagged(t) => {
                let t = self.tag(*t)?;
                self.emit(Instr::Tagged(t), 0);
                Bool
            }
            Expr::TagIndex(t) => {
                let t = self.tag(*t)?;
                self.emit(Instr::TagIndex(t), 0);
                Num
            }
            Expr::TagCount(t) => {
                let t = self.tag(*t)?;
                self.emit(Instr::TagCount(t), 0);
                Num
            }
            Expr::Unary(f, a) => {
                let ty = if *f == Unary::Not { Bool } else { Num };
                self.want(a, ty, depth, "the operand")?;
                self.emit(Instr::Un(*f), 1);
                ty
            }
            Expr::Binary(op, a, b) => {
                use Binary::*;
                let out = match op {
                    Add | Sub | Mul | Div | Rem | Pow | Min | Max => {
                        self.want(a, Num, depth, "an arithmetic operand")?;
                        self.want(b, Num, depth, "an arithmetic operand")?;
                        Num
                    }
                    Lt | Le | Gt | Ge => {
                        self.want(a, Num, depth, "a compared operand")?;
                        self.want(b, Num, depth, "a compared operand")?;
                        Bool
                    }
                    Eq | Ne => {
                        let ta = self.expr(a, depth + 1)?;
                        self.want(b, ta, depth, "the right side of == or !=")?;
                        Bool
                    }
                    And | Or => {
                        self.want(a, Bool, depth, "an operand of && or ||")?;
                        self.want(b, Bool, depth, "an operand of && or ||")?;
                        Bool
                    }
                };
                self.emit(Instr::Bin(*op), 2);
                out
            }
            Expr::Clamp(x, lo, hi) => {
                for v in [x, lo, hi] {
                    self.want(v, Num, depth, "an argument of clamp")?;
                }
                self.emit(Instr::Clamp, 3);
                Num
            }
            Expr::If(c, a, b) => {
                self.want(c, Bool, depth, "the condition of if")?;
                let ta = self.expr(a, depth + 1)?;
                self.want(b, ta, depth, "the else branch")?;
                self.emit(Instr::Select, 3);
                ta
            }
            Expr::Uniform(a, b) | Expr::RandInt(a, b) | Expr::Normal(a, b) => {
                self.want(a, Num, depth, "an argument of a random function")?;
                self.want(b, Num, depth, "an argument of a random function")?;
                let i = match e {
                    Expr::Uniform(..) => Instr::Uniform(self.draw(1)),
                    Expr::RandInt(..) => Instr::RandInt(self.draw(1)),
                    _ => Instr::Normal(self.draw(2)),
                };
                self.emit(i, 2);
                Num
            }
            Expr::Chance(p) => {
                self.want(p, Num, depth, "the probability of chance")?;
                let l = self.draw(1);
                self.emit(Instr::Chance(l), 1);
                Bool
            }
            Expr::Choose(pairs) => {
                let Some(((first, w0), rest)) = pairs.split_first() else {
                    return Err(CompileError::Type("choose needs at least one value".into()));
                };
                // The first value sets the type the others must have.
                let ty = self.expr(first, depth + 1)?;
                self.want(w0, Num, depth, "a weight of choose")?;
                for (v, w) in rest {
                    self.want(v, ty, depth, "every value of choose")?;
                    self.want(w, Num, depth, "a weight of choose")?;
                }
                let local = self.draw(1);
                let n = pairs.len() as u32;
                self.emit(Instr::Choose { n, local }, 2 * n);
                ty
            }
            Expr::Query(q, s) => {
                if s.0 as usize >= self.n_symbols {
                    return Err(CompileError::UnknownSymbol(s.0));
                }
                if let Err(at) = self.uses.queried.binary_search(s) {
                    self.uses.queried.insert(at, *s);
                }
                self.emit(Instr::Query(*q, *s), 0);
                Bool
            }
        })
    }
}

/// The shape an expression is evaluated for: everything but the scope and
/// the draw site.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Shape<'a> {
    pub seed: u32,
    pub key: u32,
    pub index: u32,
    pub count: u32,
    pub depth: u32,
    /// `(tag, index, count)` of the tagged commands on the path, innermost first.
    pub tags: &'a [(TagId, u32, u32)],
    /// The keys of the shape and of its ancestors, innermost first.
    pub path: &'a [u32],
    /// The first pass's shapes, in the second pass of a program with queries.
    pub queries: Option<&'a Queries>,
}

/// The number of alternatives whose expressions may draw.
pub const DRAW_ALTERNATIVES: u32 = 1 << 8;
/// The number of draw sites in an alternative (condition, weight, ops).
pub const DRAW_SITES: u32 = 1 << 12;
/// The number of draws one site may use.
pub const DRAW_LOCALS: u32 = 1 << 11;

/// Where a rule's draws come from: the alternative and the site (0 the
/// condition, 1 the weight, `2 + i` the alternative's operation `i`), and
/// the next draw number within the site.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Site {
    base: u32,
    next: u32,
}

impl Site {
    /// Site `site` of alternative `alt`: draw indices `alt << 23 | site <<
    /// 11 | local` (local from 1; the high bit clear, so never a race draw).
    #[inline]
    pub fn new(alt: u32, site: u32) -> Site {
        Site {
            base: (alt % DRAW_ALTERNATIVES) << 23 | (site % DRAW_SITES) << 11,
            next: 0,
        }
    }
    #[inline]
    fn draw(&self, local: u32) -> u32 {
        self.base | ((self.next + local) % DRAW_LOCALS)
    }
}

/// The site of condition draws.
pub const SITE_CONDITION: u32 = 0;
/// The site of weight draws.
pub const SITE_WEIGHT: u32 = 1;
/// The site of operation `i`'s draws: `SITE_OPS + i`.
pub const SITE_OPS: u32 = 2;

#[inline]
fn b2f(b: bool) -> f32 {
    if b { 1.0 } else { 0.0 }
}

impl Exprs {
    /// Evaluate `id` for `shape` with `scope`, taking draws from `site`
    /// (which then moves past them). An unknown id (a program not from the
    /// builder) is NaN.
    pub fn eval(
        &self,
        id: ExprId,
        shape: &Shape<'_>,
        scope: &Scope,
        site: &mut Site,
        stack: &mut Vec<f32>,
    ) -> f32 {
        let Some(entry) = self.entries.get(id.0 as usize) else {
            return f32::NAN;
        };
        let code = &self.code[entry.start as usize..(entry.start + entry.len) as usize];
        stack.clear();
        stack.reserve(entry.stack as usize);
        let draws = rng::hash_prefix(shape.seed, 0, shape.key);
        let u = |local: u32| rng::unit(rng::hash_finish(draws, site.draw(local)));
        for &i in code {
            match i {
                Instr::Const(v) => stack.push(v),
                Instr::Size(a) => stack.push(scope.size[a as usize]),
                Instr::Position(a) => stack.push(scope.origin[a as usize]),
                Instr::Index => stack.push(shape.index as f32),
                Instr::Count => stack.push(shape.count as f32),
                Instr::Depth => stack.push(shape.depth as f32),
                Instr::Tagged(t) => stack.push(b2f(shape.tags.iter().any(|e| e.0 == t))),
                Instr::TagIndex(t) => stack.push(
                    shape
                        .tags
                        .iter()
                        .find(|e| e.0 == t)
                        .map_or(0.0, |e| e.1 as f32),
                ),
                Instr::TagCount(t) => stack.push(
                    shape
                        .tags
                        .iter()
                        .find(|e| e.0 == t)
                        .map_or(0.0, |e| e.2 as f32),
                ),
                Instr::Un(f) => {
                    let Some(x) = stack.last_mut() else { break };
                    *x = match f {
                        Unary::Neg => -*x,
                        Unary::Not => b2f(*x == 0.0),
                        Unary::Abs => x.abs(),
                        Unary::Floor => x.floor(),
                        Unary::Ceil => x.ceil(),
                        Unary::Round => x.round(),
                        Unary::Sqrt => x.sqrt(),
                        Unary::Sin => x.sin(),
                        Unary::Cos => x.cos(),
                    };
                }
                Instr::Bin(op) => {
                    let (Some(b), Some(a)) = (stack.pop(), stack.pop()) else {
                        break;
                    };
                    use Binary::*;
                    stack.push(match op {
                        Add => a + b,
                        Sub => a - b,
                        Mul => a * b,
                        Div => a / b,
                        Rem => floored_rem(a, b),
                        Pow => a.powf(b),
                        Min => a.min(b),
                        Max => a.max(b),
                        Lt => b2f(a < b),
                        Le => b2f(a <= b),
                        Gt => b2f(a > b),
                        Ge => b2f(a >= b),
                        Eq => b2f(a == b),
                        Ne => b2f(a != b),
                        And => b2f(a != 0.0 && b != 0.0),
                        Or => b2f(a != 0.0 || b != 0.0),
                    });
                }
                Instr::Clamp | Instr::Select => {
                    let (Some(c), Some(b), Some(a)) = (stack.pop(), stack.pop(), stack.pop())
                    else {
                        break;
                    };
                    stack.push(if i == Instr::Clamp {
                        a.max(b).min(c)
                    } else if a != 0.0 {
                        b
                    } else {
                        c
                    });
                }
                Instr::Uniform(l) | Instr::RandInt(l) | Instr::Normal(l) => {
                    let (Some(b), Some(a)) = (stack.pop(), stack.pop()) else {
                        break;
                    };
                    stack.push(match i {
                        Instr::Uniform(_) => rand_uniform(a, b, u(l)),
                        Instr::RandInt(_) => rand_int(a, b, u(l)),
                        _ => {
                            let (u1, u2) = (u(l), u(l + 1));
                            let z = (-2.0 * (1.0 - u1).ln()).sqrt()
                                * (std::f32::consts::TAU * u2).cos();
                            a + b * z
                        }
                    });
                }
                Instr::Chance(l) => {
                    let Some(p) = stack.last_mut() else { break };
                    *p = b2f(u(l) < *p);
                }
                Instr::Choose { n, local } => {
                    let n = n as usize;
                    if stack.len() < 2 * n {
                        break;
                    }
                    let base = stack.len() - 2 * n;
                    let v = choose(&stack[base..], u(local));
                    stack.truncate(base);
                    stack.push(v);
                }
                Instr::Query(q, s) => {
                    let hit = shape
                        .queries
                        .is_some_and(|qs| qs.ask(q, s, scope, shape.path));
                    stack.push(b2f(hit));
                }
            }
        }
        site.next += entry.draws;
        if stack.len() == 1 { stack[0] } else { f32::NAN }
    }
}

/// `choose` over `(value, weight)` pairs laid flat, with the uniform draw
/// `u`: grm's `rand.choose` (`grm_compile::op::Op::RandChoose`): the first
/// value whose running weight passes `u * total`, weights `max(w, 0)` (NaN
/// as 0), all scaled by `WEIGHT_SCALE` when their sum passes the f32
/// range; NaN when no weight is positive; the last positive one if
/// rounding leaves none.
fn choose(pairs: &[f32], u: f32) -> f32 {
    let n = pairs.len() / 2;
    let weight = |j: usize| {
        let x = pairs[2 * j + 1];
        if x > 0.0 { x } else { 0.0 }
    };
    let mut total: f32 = (0..n).map(weight).sum();
    if total.is_nan() || total <= 0.0 {
        return f32::NAN;
    }
    let mut scale = 1.0f32;
    if total.is_infinite() && (0..n).all(|j| weight(j).is_finite()) {
        scale = WEIGHT_SCALE;
        total = (0..n).map(|j| weight(j) * scale).sum();
    }
    let target = u * total;
    let mut acc = 0.0f32;
    let mut last = 0;
    for j in 0..n {
        let wj = weight(j);
        if wj > 0.0 {
            last = j;
            acc += wj * scale;
            if target < acc {
                return pairs[2 * j];
            }
        }
    }
    pairs[2 * last]
}

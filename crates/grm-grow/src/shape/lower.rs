//! Lowering a checked shape system (`grm_sema::ShapeSystem`) to the shape
//! engine's IR: a `grm_shape::Program` and its `grm_shape::Lot`, with the
//! run's meta-parameter values (a meta-parameter or a constant that
//! depends on one is a number here; shape values, random draws and the
//! rest stay expressions the engine evaluates per shape).
//!
//! Vectors are lowered component by component (`scope * 2` is three
//! numbers; `length(scope)` their root sum of squares), so the engine's
//! expressions are numbers and booleans only. grm's trigonometry takes
//! degrees, the engine's radians: `sin(x)` lowers to `sin(x * pi / 180)`.

use grm_diag::Span;
use grm_sema::shape::{Asset, LotKind, OpKind, PartKind, ShapeRule, ShapeValue, SplitT};
use grm_sema::{BinaryOp, Builtin, RandomFn, TExpr, TExprKind, UnaryOp, Value};
use grm_shape::{
    Alternative, Axis, Binary, Comp, CompCase, Expr, Lot, Op, Param, Part, PartSize, Program,
    ProgramBuilder, Split, SymbolId, Unary,
};

use super::LowerError;

/// A shape system lowered for one run.
#[derive(Clone, Debug)]
pub struct Lowered {
    pub program: Program,
    pub lot: Lot,
    /// The system's `seed` setting for the run's values.
    pub seed: u32,
    /// The rules in source order: each is one alternative of its symbol's
    /// engine rule.
    pub rules: Vec<RuleSource>,
    /// Per engine symbol (by `SymbolId`), the index in `rules` of each of
    /// its alternatives.
    pub alternatives: Vec<Vec<u32>>,
}

/// Where a rule is written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RuleSource {
    pub symbol: SymbolId,
    /// The whole rule.
    pub span: Span,
}

impl Lowered {
    /// The span of the first rule of the symbol named `name`.
    pub fn rule_span(&self, name: &str) -> Option<Span> {
        let s = self.program.symbol(name)?;
        let r = *self.alternatives.get(s.0 as usize)?.first()?;
        self.rules.get(r as usize).map(|r| r.span)
    }

    /// The index in `rules` of alternative `alt` of `symbol`'s rule.
    pub fn rule_of(&self, symbol: SymbolId, alt: u32) -> Option<u32> {
        self.alternatives
            .get(symbol.0 as usize)?
            .get(alt as usize)
            .copied()
    }
}

/// Lower `system` (a shape system of `program` checked without errors)
/// with the meta-parameter values `params` (by `ParamId`).
pub fn lower(
    program: &grm_sema::Program,
    system: &grm_sema::System,
    params: &[Value],
) -> Result<Lowered, LowerError> {
    lower_on(program, system, params, None)
}

/// A lot the caller gives instead of the system's `lot` setting (a city
/// parcel): rings of `[x, y]` metres in the shape world, the outer ring
/// then holes, and the direction of the lot's x axis (`[1, 0]`: the
/// world's; a parcel's street front, so its `front` face looks at the
/// street). The lot's scope is the polygon's bounding box in that frame.
#[derive(Clone, Copy, Debug)]
pub struct GivenLot<'a> {
    pub rings: &'a [Vec<[f64; 2]>],
    pub x_axis: [f64; 2],
}

/// [`lower`] on a lot the caller gives (`Some`) instead of the system's
/// `lot` setting; such a lot's problems are E0509 with no span.
pub fn lower_on(
    program: &grm_sema::Program,
    system: &grm_sema::System,
    params: &[Value],
    given: Option<GivenLot>,
) -> Result<Lowered, LowerError> {
    let Some(shape) = system.shape.as_deref() else {
        return Err(LowerError::NotShape {
            system: system.name.clone(),
        });
    };
    if params.len() != program.params.len() {
        return Err(LowerError::Internal(format!(
            "{} values given for {} meta-parameters",
            params.len(),
            program.params.len()
        )));
    }
    let globals = program
        .global_values(params)
        .map_err(|e| LowerError::Internal(format!("a constant cannot be evaluated: {e}")))?;
    let lot = match given {
        Some(given) => {
            let rings = given.rings.to_vec();
            let why = grm_sema::shape::footprint_problem(&rings);
            if let Some(why) = why {
                return Err(LowerError::Lot { why, span: None });
            }
            footprint_along(&rings, given.x_axis)
                .map_err(|why| LowerError::Lot { why, span: None })?
        }
        None => lot(shape, params, &globals)?,
    };
    let mut b = ProgramBuilder::new(&system.name);
    // The system's symbols first, in their order: engine ids are the
    // checker's ids.
    for s in &system.symbols {
        b.symbol(&s.name);
    }
    let mut cx = Cx {
        params,
        globals: &globals,
        b: &mut b,
        program,
    };
    let n = system.symbols.len();
    let mut by_symbol: Vec<Vec<Alternative>> = vec![Vec::new(); n];
    let mut alternatives: Vec<Vec<u32>> = vec![Vec::new(); n];
    let mut rules = Vec::with_capacity(shape.rules.len());
    for (i, rule) in shape.rules.iter().enumerate() {
        let alt = cx.rule(rule)?;
        let s = rule.symbol as usize;
        if s >= n {
            return Err(LowerError::Internal(format!(
                "rule symbol {s} out of range"
            )));
        }
        by_symbol[s].push(alt);
        alternatives[s].push(i as u32);
        rules.push(RuleSource {
            symbol: SymbolId(rule.symbol),
            span: rule.span,
        });
    }
    for (s, alts) in by_symbol.into_iter().enumerate() {
        if !alts.is_empty() {
            b.rule_alternatives(SymbolId(s as u32), alts);
        }
    }
    let seed = system
        .settings_with(params, &globals)
        .map(|s| s.seed)
        .unwrap_or(system.settings.seed);
    let axiom = shape
        .axiom
        .ok_or_else(|| LowerError::Internal("the system has no axiom".into()))?;
    // Every declared material and mesh, after those the rules use (their
    // ids unchanged): persistent edits may name any of them.
    for m in &program.materials {
        b.material(&m.name);
    }
    for m in &program.meshes {
        b.asset(&m.name);
    }
    let program = b.build(SymbolId(axiom)).map_err(|e| LowerError::Program {
        error: e.to_string(),
    })?;
    Ok(Lowered {
        program,
        lot,
        seed,
        rules,
        alternatives,
    })
}

/// The lot for these values (E0509 where they make it unusable).
fn lot(
    shape: &grm_sema::ShapeSystem,
    params: &[Value],
    globals: &[Value],
) -> Result<Lot, LowerError> {
    let span = shape.lot.span;
    let rings = grm_sema::shape::lot_rings(&shape.lot, params, globals)
        .map_err(|why| LowerError::Lot { why, span })?;
    if let Some(why) = grm_sema::shape::footprint_problem(&rings) {
        return Err(LowerError::Lot { why, span });
    }
    if let (LotKind::Rect { .. } | LotKind::Default, Some(r)) = (&shape.lot.kind, rings.first())
        && let [_, [w, _], [_, d], _] = r[..]
    {
        return Ok(Lot::rectangle(w as f32, d as f32));
    }
    footprint(&rings).map_err(|why| LowerError::Lot { why, span })
}

/// [`footprint`] in the frame whose x axis is `x_axis` (z up): the rings
/// turned into that frame, the scope turned back (the building stands
/// where the rings are).
fn footprint_along(rings: &[Vec<[f64; 2]>], x_axis: [f64; 2]) -> Result<Lot, String> {
    let len = x_axis[0].hypot(x_axis[1]);
    if !(len.is_finite() && len > 0.0) {
        return Err("the lot's x axis has no direction".into());
    }
    let (c, s) = (x_axis[0] / len, x_axis[1] / len);
    if s == 0.0 && c > 0.0 {
        return footprint(rings);
    }
    let local: Vec<Vec<[f64; 2]>> = rings
        .iter()
        .map(|r| {
            r.iter()
                .map(|p| [c * p[0] + s * p[1], -s * p[0] + c * p[1]])
                .collect()
        })
        .collect();
    let mut lot = footprint(&local)?;
    let o = lot.scope.origin;
    let (ox, oy) = (f64::from(o.x), f64::from(o.y));
    let origin = glam::Vec3::new((c * ox - s * oy) as f32, (s * ox + c * oy) as f32, 0.0);
    let turn = glam::Quat::from_rotation_z(s.atan2(c) as f32);
    lot.scope = grm_shape::Scope::with_rotation(origin, turn, lot.scope.size);
    Ok(lot)
}

/// A footprint with holes (courtyards) as a lot: as
/// `grm_shape::Lot::footprint`, its scope the polygon's bounding box.
fn footprint(rings: &[Vec<[f64; 2]>]) -> Result<Lot, String> {
    let ring = |r: &Vec<[f64; 2]>| {
        geo::LineString::new(r.iter().map(|p| geo::Coord { x: p[0], y: p[1] }).collect())
    };
    let Some(outer) = rings.first() else {
        return Err("the footprint has no corners".into());
    };
    let poly = geo::Polygon::new(ring(outer), rings[1..].iter().map(ring).collect());
    let outline = grm_shape::Outline::new(geo::MultiPolygon::new(vec![poly]));
    let (lo, hi) = outline
        .bounds()
        .ok_or_else(|| "the footprint is empty".to_string())?;
    let local = outline.translated(-lo[0], -lo[1]);
    let size = glam::Vec3::new((hi[0] - lo[0]) as f32, (hi[1] - lo[1]) as f32, 0.0);
    Ok(Lot {
        scope: grm_shape::Scope::new(glam::Vec3::new(lo[0] as f32, lo[1] as f32, 0.0), size),
        geometry: grm_shape::Geom::from_outline(local, size.x, size.y, false),
    })
}

struct Cx<'a, 'b> {
    params: &'a [Value],
    globals: &'a [Value],
    b: &'b mut ProgramBuilder,
    program: &'a grm_sema::Program,
}

fn internal(what: &str) -> LowerError {
    LowerError::Internal(format!("a checked shape system has {what}"))
}

const DEG: f32 = std::f32::consts::PI / 180.0;

impl Cx<'_, '_> {
    fn rule(&mut self, r: &ShapeRule) -> Result<Alternative, LowerError> {
        let weight = self.param(&r.weight)?;
        let condition = match &r.condition {
            Some(c) => {
                let e = self.scalar(c)?;
                Some(self.compile(&e)?)
            }
            None => None,
        };
        let mut ops = Vec::with_capacity(r.ops.len());
        for op in &r.ops {
            ops.push(self.op(&op.kind)?);
        }
        Ok(Alternative {
            weight,
            condition,
            ops,
        })
    }

    fn compile(&mut self, e: &Expr) -> Result<grm_shape::ExprId, LowerError> {
        self.b.try_expr(e).map_err(|e| LowerError::Program {
            error: e.to_string(),
        })
    }

    /// A number: a constant when the expression folds to one here (with
    /// the run's values), else an expression.
    fn param(&mut self, e: &TExpr) -> Result<Param, LowerError> {
        let x = self.scalar(e)?;
        if let Expr::Num(v) = x {
            return Ok(Param::Const(v));
        }
        Ok(Param::Expr(self.compile(&x)?))
    }

    fn split(&mut self, s: &SplitT) -> Result<Split, LowerError> {
        let mut parts = Vec::with_capacity(s.parts.len());
        for p in &s.parts {
            let size = match p.kind {
                PartKind::Absolute => PartSize::Absolute(self.param(&p.size)?),
                PartKind::Relative => {
                    // `25%` is a quarter.
                    let x = self.scalar(&p.size)?;
                    let x = match x {
                        Expr::Num(v) => Param::Const(v / 100.0),
                        other => Param::Expr(self.compile(&(other / Expr::Num(100.0)))?),
                    };
                    PartSize::Relative(x)
                }
                PartKind::Floating => PartSize::Floating(self.param(&p.size)?),
            };
            parts.push(Part {
                size,
                target: p.target.map(SymbolId),
            });
        }
        Ok(Split {
            axis: s.axis,
            parts,
            tag: s.tag.as_ref().map(|t| self.b.tag(&t.name)),
        })
    }

    fn op(&mut self, op: &OpKind) -> Result<Op, LowerError> {
        Ok(match op {
            OpKind::Emit(s) => Op::Emit(SymbolId(*s)),
            OpKind::Extrude(h) => Op::Extrude(self.param(h)?),
            OpKind::Taper(h) => Op::Taper(self.param(h)?),
            OpKind::Roof {
                kind,
                angle,
                overhang,
            } => Op::Roof {
                kind: *kind,
                angle: self.param(angle)?,
                overhang: match overhang {
                    Some(o) => self.param(o)?,
                    None => Param::Const(0.0),
                },
            },
            OpKind::Translate(v) => {
                Op::Translate([self.param(&v[0])?, self.param(&v[1])?, self.param(&v[2])?])
            }
            OpKind::Rotate { axis: a, degrees } => Op::Rotate {
                axis: *a,
                degrees: self.param(degrees)?,
            },
            OpKind::Size(v) => {
                let mut out = [None, None, None];
                for (o, e) in out.iter_mut().zip(v) {
                    if let Some(e) = e {
                        *o = Some(self.param(e)?);
                    }
                }
                Op::Size(out)
            }
            OpKind::Center(c) => Op::Center(*c),
            OpKind::Push => Op::Push,
            OpKind::Pop => Op::Pop,
            OpKind::Offset(d) => Op::Offset(self.param(d)?),
            OpKind::Insert(Asset::Primitive(p)) => Op::Insert(self.b.asset(p.name())),
            OpKind::Insert(Asset::Mesh(m)) => {
                let mesh = self
                    .program
                    .meshes
                    .get(m.index())
                    .ok_or_else(|| internal("an unknown mesh"))?;
                Op::Insert(self.b.asset(&mesh.name))
            }
            OpKind::Material(m) => {
                let material = self
                    .program
                    .materials
                    .get(m.index())
                    .ok_or_else(|| internal("an unknown material"))?;
                Op::Material(self.b.material(&material.name))
            }
            OpKind::Color(c) => {
                let [r, g, b] = self.vec(c)?;
                let mut p = |e: Expr| -> Result<Param, LowerError> {
                    Ok(match e {
                        Expr::Num(v) => Param::Const(v),
                        other => Param::Expr(self.compile(&other)?),
                    })
                };
                Op::Color([p(r)?, p(g)?, p(b)?])
            }
            OpKind::Texture(t) => Op::Texture(self.b.texture(t)),
            OpKind::Split(s) => Op::Split(self.split(s)?),
            OpKind::Repeat(s) => Op::Repeat(self.split(s)?),
            OpKind::Comp(c) => Op::Comp(Comp {
                target: c.target,
                cases: c
                    .cases
                    .iter()
                    .map(|k| CompCase {
                        selector: k.selector,
                        target: k.target.map(SymbolId),
                    })
                    .collect(),
                tag: c.tag.as_ref().map(|t| self.b.tag(&t.name)),
            }),
        })
    }

    /// A value's lowering (a constant of the run).
    fn value(v: Value) -> Result<Val, LowerError> {
        Ok(match v {
            Value::Float(x) => Val::S(Expr::Num(x as f32)),
            Value::Bool(b) => Val::S(Expr::Bool(b)),
            Value::Vec3(u) => Val::V(u.map(|x| Expr::Num(x as f32))),
            Value::Mesh(_) | Value::Material(_) => return Err(internal("a name as a number")),
        })
    }

    /// A number or boolean expression.
    fn scalar(&mut self, e: &TExpr) -> Result<Expr, LowerError> {
        match self.lower(e)? {
            Val::S(x) => Ok(fold(x)),
            Val::V(_) => Err(internal("a vector where a number goes")),
        }
    }

    /// A vector expression, component by component.
    fn vec(&mut self, e: &TExpr) -> Result<[Expr; 3], LowerError> {
        match self.lower(e)? {
            Val::V(v) => Ok(v.map(fold)),
            Val::S(_) => Err(internal("a number where a vector goes")),
        }
    }

    fn lower(&mut self, e: &TExpr) -> Result<Val, LowerError> {
        use TExprKind as K;
        Ok(match &e.kind {
            K::Lit(v) => Self::value(*v)?,
            K::Param(p) => Self::value(
                *self
                    .params
                    .get(p.index())
                    .ok_or_else(|| internal("an unknown meta-parameter"))?,
            )?,
            K::Global(c) => Self::value(
                *self
                    .globals
                    .get(c.index())
                    .ok_or_else(|| internal("an unknown constant"))?,
            )?,
            K::ModuleParam(_) | K::Error => return Err(internal("a module parameter or an error")),
            K::Unary(op, a) => match (op, self.lower(a)?) {
                (UnaryOp::Neg, Val::S(x)) => Val::S(-x),
                (UnaryOp::Neg, Val::V(v)) => Val::V(v.map(|x| -x)),
                (UnaryOp::Not, Val::S(x)) => Val::S(!x),
                (UnaryOp::Not, Val::V(_)) => return Err(internal("`!` of a vector")),
            },
            K::Binary(op, a, b) => {
                let (a, b) = (self.lower(a)?, self.lower(b)?);
                binary(*op, a, b)?
            }
            K::Field(a, i) => match self.lower(a)? {
                Val::V(v) => {
                    let [x, y, z] = v;
                    Val::S(match i {
                        0 => x,
                        1 => y,
                        _ => z,
                    })
                }
                Val::S(_) => return Err(internal("a field of a number")),
            },
            K::If(c, a, b) => {
                let c = self.scalar(c)?;
                match (self.lower(a)?, self.lower(b)?) {
                    (Val::S(x), Val::S(y)) => Val::S(c.then(x, y)),
                    (Val::V(x), Val::V(y)) => {
                        let [x0, x1, x2] = x;
                        let [y0, y1, y2] = y;
                        Val::V([
                            c.clone().then(x0, y0),
                            c.clone().then(x1, y1),
                            c.then(x2, y2),
                        ])
                    }
                    _ => return Err(internal("`if` with branches of two types")),
                }
            }
            K::Call(f, args) => {
                let mut vs = Vec::with_capacity(args.len());
                for a in args {
                    vs.push(self.lower(a)?);
                }
                call(*f, vs)?
            }
            K::Random(r, args) => {
                let mut xs = Vec::with_capacity(args.len());
                for a in args {
                    xs.push(self.scalar(a)?);
                }
                Val::S(random(*r, xs)?)
            }
            K::Shape(v) => match v {
                ShapeValue::Scope => Val::V([
                    Expr::Size(Axis::X),
                    Expr::Size(Axis::Y),
                    Expr::Size(Axis::Z),
                ]),
                ShapeValue::Index => Val::S(Expr::Index),
                ShapeValue::Count => Val::S(Expr::Count),
                ShapeValue::Depth => Val::S(Expr::Depth),
                ShapeValue::Tagged(t) => Val::S(Expr::Tagged(self.b.tag(t))),
                ShapeValue::TagIndex(t) => Val::S(Expr::TagIndex(self.b.tag(t))),
                ShapeValue::TagCount(t) => Val::S(Expr::TagCount(self.b.tag(t))),
                ShapeValue::Query(q, sym) => {
                    // Every symbol of the system is declared already.
                    Val::S(Expr::Query(*q, self.b.symbol(sym)))
                }
            },
        })
    }
}

/// A lowered value: a number or boolean, or a vector's three numbers.
enum Val {
    S(Expr),
    V([Expr; 3]),
}

/// Fold constant arithmetic (so that constant sizes stay constants in the
/// IR, which splits them without evaluating anything).
fn fold(e: Expr) -> Expr {
    match e {
        Expr::Unary(Unary::Neg, a) => match fold(*a) {
            Expr::Num(x) => Expr::Num(-x),
            a => Expr::Unary(Unary::Neg, Box::new(a)),
        },
        Expr::Binary(op, a, b) => {
            let (a, b) = (fold(*a), fold(*b));
            match (op, &a, &b) {
                (Binary::Add, Expr::Num(x), Expr::Num(y)) => Expr::Num(x + y),
                (Binary::Sub, Expr::Num(x), Expr::Num(y)) => Expr::Num(x - y),
                (Binary::Mul, Expr::Num(x), Expr::Num(y)) => Expr::Num(x * y),
                (Binary::Div, Expr::Num(x), Expr::Num(y)) => Expr::Num(x / y),
                _ => Expr::Binary(op, Box::new(a), Box::new(b)),
            }
        }
        other => other,
    }
}

fn bin(op: Binary, a: Expr, b: Expr) -> Expr {
    Expr::Binary(op, Box::new(a), Box::new(b))
}

fn un(op: Unary, a: Expr) -> Expr {
    Expr::Unary(op, Box::new(a))
}

/// `a` and `b` as vectors (a number broadcast to three).
fn pair(a: Val, b: Val) -> ([Expr; 3], [Expr; 3]) {
    let v = |x: Val| match x {
        Val::V(v) => v,
        Val::S(s) => [s.clone(), s.clone(), s],
    };
    (v(a), v(b))
}

fn zip3(a: [Expr; 3], b: [Expr; 3], f: impl Fn(Expr, Expr) -> Expr) -> [Expr; 3] {
    let [a0, a1, a2] = a;
    let [b0, b1, b2] = b;
    [f(a0, b0), f(a1, b1), f(a2, b2)]
}

fn binary(op: BinaryOp, a: Val, b: Val) -> Result<Val, LowerError> {
    let o = match op {
        BinaryOp::Add => Binary::Add,
        BinaryOp::Sub => Binary::Sub,
        BinaryOp::Mul => Binary::Mul,
        BinaryOp::Div => Binary::Div,
        BinaryOp::Rem => Binary::Rem,
        BinaryOp::Lt => Binary::Lt,
        BinaryOp::Le => Binary::Le,
        BinaryOp::Gt => Binary::Gt,
        BinaryOp::Ge => Binary::Ge,
        BinaryOp::Eq => Binary::Eq,
        BinaryOp::Ne => Binary::Ne,
        BinaryOp::And => Binary::And,
        BinaryOp::Or => Binary::Or,
    };
    Ok(match (a, b) {
        (Val::S(x), Val::S(y)) => Val::S(bin(o, x, y)),
        (a, b) => {
            let (x, y) = pair(a, b);
            match op {
                BinaryOp::Eq => {
                    let [e0, e1, e2] = zip3(x, y, |p, q| bin(Binary::Eq, p, q));
                    Val::S(e0.and(e1).and(e2))
                }
                BinaryOp::Ne => {
                    let [e0, e1, e2] = zip3(x, y, |p, q| bin(Binary::Ne, p, q));
                    Val::S(e0.or(e1).or(e2))
                }
                BinaryOp::Add | BinaryOp::Sub | BinaryOp::Mul | BinaryOp::Div | BinaryOp::Rem => {
                    Val::V(zip3(x, y, |p, q| bin(o, p, q)))
                }
                _ => return Err(internal("a comparison of vectors")),
            }
        }
    })
}

/// Apply `f` to a number, or to each component of a vector.
fn map1(v: Val, f: impl Fn(Expr) -> Expr) -> Val {
    match v {
        Val::S(x) => Val::S(f(x)),
        Val::V(v) => Val::V(v.map(f)),
    }
}

/// Apply `f` to numbers or, when any is a vector, to each component
/// (numbers broadcast).
fn mapn(vs: Vec<Val>, f: impl Fn(Vec<Expr>) -> Expr) -> Val {
    if vs.iter().all(|v| matches!(v, Val::S(_))) {
        return Val::S(f(vs
            .into_iter()
            .filter_map(|v| match v {
                Val::S(x) => Some(x),
                Val::V(_) => None,
            })
            .collect()));
    }
    let comps: Vec<[Expr; 3]> = vs
        .into_iter()
        .map(|v| match v {
            Val::V(v) => v,
            Val::S(s) => [s.clone(), s.clone(), s],
        })
        .collect();
    let at = |i: usize| comps.iter().map(|c| c[i].clone()).collect::<Vec<_>>();
    Val::V([f(at(0)), f(at(1)), f(at(2))])
}

fn arg(xs: &[Expr], i: usize) -> Expr {
    xs.get(i).cloned().unwrap_or(Expr::Num(f32::NAN))
}

fn call(f: Builtin, vs: Vec<Val>) -> Result<Val, LowerError> {
    use Builtin as B;
    let one = |vs: Vec<Val>| {
        vs.into_iter()
            .next()
            .ok_or_else(|| internal("a call without arguments"))
    };
    let vec_of = |v: Val| match v {
        Val::V(v) => Ok(v),
        Val::S(_) => Err(internal("a number where a vector goes")),
    };
    Ok(match f {
        B::Sin => map1(one(vs)?, |x| un(Unary::Sin, x * Expr::Num(DEG))),
        B::Cos => map1(one(vs)?, |x| un(Unary::Cos, x * Expr::Num(DEG))),
        B::Tan => map1(one(vs)?, |x| {
            let r = x * Expr::Num(DEG);
            un(Unary::Sin, r.clone()) / un(Unary::Cos, r)
        }),
        B::Sqrt => map1(one(vs)?, |x| un(Unary::Sqrt, x)),
        B::Abs => map1(one(vs)?, |x| un(Unary::Abs, x)),
        B::Floor => map1(one(vs)?, |x| un(Unary::Floor, x)),
        B::Ceil => map1(one(vs)?, |x| un(Unary::Ceil, x)),
        B::Round => map1(one(vs)?, |x| un(Unary::Round, x)),
        B::Fract => map1(one(vs)?, |x| x.clone() - un(Unary::Floor, x)),
        B::Sign => map1(one(vs)?, |x| {
            x.clone().gt(Expr::Num(0.0)).then(
                Expr::Num(1.0),
                x.lt(Expr::Num(0.0)).then(Expr::Num(-1.0), Expr::Num(0.0)),
            )
        }),
        B::Pow => mapn(vs, |a| arg(&a, 0).pow(arg(&a, 1))),
        B::Min => mapn(vs, |a| arg(&a, 0).min(arg(&a, 1))),
        B::Max => mapn(vs, |a| arg(&a, 0).max(arg(&a, 1))),
        B::Clamp => mapn(vs, |a| arg(&a, 0).max(arg(&a, 1)).min(arg(&a, 2))),
        B::Mix => mapn(vs, |a| {
            let t = arg(&a, 2);
            arg(&a, 0) * (Expr::Num(1.0) - t.clone()) + arg(&a, 1) * t
        }),
        B::Step => mapn(vs, |a| {
            arg(&a, 1)
                .lt(arg(&a, 0))
                .then(Expr::Num(0.0), Expr::Num(1.0))
        }),
        B::Smoothstep => mapn(vs, |a| {
            let (e0, e1, x) = (arg(&a, 0), arg(&a, 1), arg(&a, 2));
            let t = ((x - e0.clone()) / (e1 - e0))
                .max(Expr::Num(0.0))
                .min(Expr::Num(1.0));
            t.clone() * t.clone() * (Expr::Num(3.0) - Expr::Num(2.0) * t)
        }),
        B::Vec3 | B::Rgb => {
            let mut it = vs.into_iter().map(|v| match v {
                Val::S(x) => Ok(x),
                Val::V(_) => Err(internal("a vector as a component")),
            });
            let mut next = || it.next().unwrap_or_else(|| Err(internal("a short vector")));
            Val::V([next()?, next()?, next()?])
        }
        B::Dot | B::Length | B::Distance | B::Cross | B::Normalize => {
            let mut it = vs.into_iter();
            let mut next = || {
                it.next()
                    .ok_or_else(|| internal("a short call"))
                    .and_then(vec_of)
            };
            match f {
                B::Dot => Val::S(dot(next()?, next()?)),
                B::Length => {
                    let v = next()?;
                    Val::S(un(Unary::Sqrt, dot(v.clone(), v)))
                }
                B::Distance => {
                    let d = zip3(next()?, next()?, |p, q| p - q);
                    Val::S(un(Unary::Sqrt, dot(d.clone(), d)))
                }
                B::Cross => {
                    let ([a0, a1, a2], [b0, b1, b2]) = (next()?, next()?);
                    Val::V([
                        a1.clone() * b2.clone() - a2.clone() * b1.clone(),
                        a2 * b0.clone() - a0.clone() * b2,
                        a0 * b1 - a1 * b0,
                    ])
                }
                _ => {
                    let v = next()?;
                    let l = un(Unary::Sqrt, dot(v.clone(), v.clone()));
                    Val::V(v.map(|x| {
                        l.clone()
                            .gt(Expr::Num(0.0))
                            .then(x / l.clone(), Expr::Num(0.0))
                    }))
                }
            }
        }
        B::Asin | B::Acos | B::Atan | B::Atan2 | B::Exp | B::Ln | B::Log10 | B::Spline => {
            return Err(internal(&format!("`{}` in a shape rule", f.name())));
        }
    })
}

fn dot(a: [Expr; 3], b: [Expr; 3]) -> Expr {
    let [p0, p1, p2] = zip3(a, b, |x, y| x * y);
    p0 + p1 + p2
}

fn random(r: RandomFn, xs: Vec<Expr>) -> Result<Expr, LowerError> {
    Ok(match r {
        RandomFn::Uniform => Expr::uniform(arg(&xs, 0), arg(&xs, 1)),
        RandomFn::Normal => Expr::normal(arg(&xs, 0), arg(&xs, 1)),
        RandomFn::RandInt => Expr::randint(arg(&xs, 0), arg(&xs, 1)),
        RandomFn::Chance => Expr::chance(arg(&xs, 0)),
        RandomFn::Choose => {
            let pairs = xs
                .chunks(2)
                .map(|c| (arg(c, 0), arg(c, 1)))
                .collect::<Vec<_>>();
            Expr::Choose(pairs)
        }
    })
}

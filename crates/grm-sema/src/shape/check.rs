//! Checking a shape system's syntax tree: the lot, the axiom, the rules
//! and their operations, into a [`ShapeSystem`].

use std::collections::HashMap;

use grm_diag::{Code, Diagnostic, FileId, Span};
use grm_syntax::ast::{self, ExprKind, Name, PartKind};

use super::*;
use crate::builtins::Builtin;
use crate::check::{Checker, GlobalKind, GlobalName};
use crate::expr::Scope;
use crate::index::Def;
use crate::program::{
    Phase, SymbolId, SymbolInfo, SymbolKind, SystemId, TExpr, TExprKind, Ty, Value,
};
use crate::suggest;

/// The operations, with the argument counts they take.
const OPS: &[(&str, &[usize])] = &[
    ("extrude", &[1]),
    ("taper", &[1]),
    ("roof", &[2, 3]),
    ("translate", &[3]),
    ("rotate", &[2]),
    ("size", &[3]),
    ("center", &[1]),
    ("offset", &[1]),
    ("insert", &[1]),
    ("material", &[1]),
    ("color", &[1, 3]),
    ("texture", &[1]),
    ("split", &[1, 2]),
    ("repeat", &[1, 2]),
    ("comp", &[1, 2]),
];

fn op_counts(name: &str) -> Option<&'static [usize]> {
    OPS.iter().find(|(n, _)| *n == name).map(|(_, c)| *c)
}

fn counts_text(c: &[usize]) -> String {
    match c {
        [a] => a.to_string(),
        [a, b] => format!("{a} or {b}"),
        _ => c
            .iter()
            .map(usize::to_string)
            .collect::<Vec<_>>()
            .join(", "),
    }
}

fn plural(n: usize) -> &'static str {
    if n == 1 { "" } else { "s" }
}

/// The name an argument is, through parentheses.
fn name_arg(e: &ast::Expr) -> Option<&ast::Ident> {
    match &e.kind {
        ExprKind::Name(id) => Some(id),
        ExprKind::Paren(inner) => name_arg(inner),
        _ => None,
    }
}

/// The checker of one shape system.
pub(crate) struct ShapeCheck<'c, 'a> {
    pub cx: &'c mut Checker<'a>,
    pub fi: usize,
    pub file: FileId,
    pub sid: SystemId,
    pub symbols: Vec<SymbolInfo>,
    by_name: HashMap<Name, u32>,
    occurrences: Vec<(Span, u32, bool)>,
}

impl<'c, 'a> ShapeCheck<'c, 'a> {
    pub(crate) fn new(cx: &'c mut Checker<'a>, fi: usize, sid: SystemId) -> Self {
        let file = cx.file_id(fi);
        ShapeCheck {
            cx,
            fi,
            file,
            sid,
            symbols: Vec::new(),
            by_name: HashMap::new(),
            occurrences: Vec::new(),
        }
    }

    pub(super) fn err(&mut self, d: Diagnostic) {
        self.cx.error(d);
    }

    /// The symbol named so, declared on first use; `is_def` marks a
    /// rule's predecessor.
    fn symbol(&mut self, name: &Name, span: Span, is_def: bool) -> u32 {
        let id = match self.by_name.get(name) {
            Some(&id) => id,
            None => {
                let id = self.symbols.len() as u32;
                self.symbols.push(SymbolInfo {
                    name: name.to_string(),
                    kind: SymbolKind::User,
                    arity: 0,
                    params: Vec::new(),
                    param_names: Vec::new(),
                    phase: Phase::None,
                    decl: None,
                    first: span,
                    groups: Vec::new(),
                    wrapup_groups: Vec::new(),
                });
                self.by_name.insert(name.clone(), id);
                id
            }
        };
        self.occurrences.push((span, id, is_def));
        id
    }

    fn scope(&self) -> Scope {
        let mut sc = Scope::global(self.fi, true, "a shape rule");
        sc.allow_random = true;
        sc.shape = true;
        sc
    }

    /// Check the whole system. `lots` are its `lot` settings, `axioms` its
    /// axioms (the first counts; the checker of settings reports the
    /// others), `extra` the items shape systems do not use.
    pub(crate) fn run(
        mut self,
        name: &ast::Ident,
        lots: &[&ast::Setting],
        axiom: Option<&ast::Axiom>,
        prods: &[&ast::Production],
        extra: &[Span],
        holes: bool,
    ) -> (ShapeSystem, Vec<SymbolInfo>) {
        for &span in extra {
            self.err(
                Diagnostic::new(
                    Code::NotInShapeSystem,
                    "shape systems have no module declarations or ignore lists",
                    self.file,
                    span,
                    "not used by a shape system",
                )
                .with_help(
                    "remove it: shape symbols are declared by their use and take no parameters",
                ),
            );
        }
        let lot = self.lot(lots);
        // Every rule's symbol first, so that rules may be written in any
        // order and queries may name any symbol.
        for p in prods {
            if p.pred.symbol.is_punct() {
                continue;
            }
            self.declare_pred(p);
        }
        self.occurrences.clear();
        let axiom_sym = match axiom {
            Some(a) => self.axiom(a),
            None => {
                if !holes {
                    self.err(
                        Diagnostic::new(
                            Code::MissingAxiom,
                            format!("system `{}` has no axiom", name.name),
                            self.file,
                            name.span,
                            "no `axiom` in this system",
                        )
                        .with_help("add the start shape, e.g. `axiom Lot;`"),
                    );
                }
                None
            }
        };
        let mut rules = Vec::with_capacity(prods.len());
        for p in prods {
            if let Some(r) = self.rule(p) {
                rules.push(r);
            }
        }
        for (span, id, is_def) in std::mem::take(&mut self.occurrences) {
            let info = &self.symbols[id as usize];
            let is_def = is_def && span == info.first;
            self.cx.program.index.push(
                self.file,
                span,
                Def::Symbol(self.sid, SymbolId(id)),
                is_def,
            );
        }
        let system = ShapeSystem {
            lot,
            axiom: axiom_sym,
            rules,
        };
        (system, self.symbols)
    }

    fn declare_pred(&mut self, p: &ast::Production) {
        let name = &p.pred.symbol.name;
        if op_counts(name).is_none() && name != "nil" {
            self.symbol(name, p.pred.symbol.span, true);
        }
    }

    // ---- the axiom ----------------------------------------------------------

    fn axiom(&mut self, a: &ast::Axiom) -> Option<u32> {
        let bad = |this: &mut Self, span: Span, label: &str| {
            this.err(
                Diagnostic::new(
                    Code::ShapeAxiom,
                    "a shape system's axiom is one shape symbol",
                    this.file,
                    span,
                    label.to_string(),
                )
                .with_help("write the start shape, e.g. `axiom Lot;`, and give it a rule"),
            );
        };
        match &a.modules[..] {
            [m] if !m.symbol.is_punct()
                && m.args.is_empty()
                && m.parts.is_none()
                && op_counts(&m.symbol.name).is_none()
                && m.symbol.name != "nil" =>
            {
                Some(self.symbol(&m.symbol.name, m.symbol.span, false))
            }
            [] => {
                bad(self, a.span, "no symbol");
                None
            }
            [m] => {
                bad(self, m.span, "not a shape symbol");
                None
            }
            [_, second, ..] => {
                let span = Span::new(second.span.start, a.modules[a.modules.len() - 1].span.end);
                bad(self, span, "more than one");
                None
            }
        }
    }

    // ---- rules --------------------------------------------------------------

    fn rule(&mut self, p: &ast::Production) -> Option<ShapeRule> {
        let file = self.file;
        if p.wrapup || !p.left.is_empty() || !p.right.is_empty() {
            let (span, what) = if p.wrapup {
                (p.pred.span, "a wrap-up")
            } else {
                let all = p.left.iter().chain(&p.right).map(|c| c.span());
                let span = all
                    .reduce(|a, b| Span::new(a.start.min(b.start), a.end.max(b.end)))
                    .unwrap_or(p.pred.span);
                (span, "a context")
            };
            self.err(
                Diagnostic::new(
                    Code::NotInShapeSystem,
                    format!("{what} in a shape system"),
                    file,
                    span,
                    "not used by a shape system",
                )
                .with_note("a shape rule rewrites one shape; conditions may read its neighbours with `overlaps`, `touches` and `inside`")
                .with_help("remove it"),
            );
        }
        let pred = &p.pred.symbol;
        let symbol = if pred.is_punct() || pred.name == "nil" || op_counts(&pred.name).is_some() {
            self.err(
                Diagnostic::new(
                    Code::UnknownShapeOperation,
                    format!(
                        "`{}` cannot be rewritten: it is not a shape symbol",
                        pred.name
                    ),
                    file,
                    pred.span,
                    "not a shape symbol",
                )
                .with_help("a rule rewrites a shape symbol, a capitalised name such as `Facade`"),
            );
            None
        } else {
            Some(self.symbol(&pred.name, pred.span, true))
        };
        if !p.pred.params.is_empty() {
            self.err(
                Diagnostic::new(
                    Code::ShapeSymbolArguments,
                    format!("shape symbol `{}` takes no parameters", pred.name),
                    file,
                    p.pred.span,
                    "parameters",
                )
                .with_note("a shape's values are its scope, index and tags: `scope.x`, `index`, `tagged(floor)`")
                .with_help(format!("write `{}`", pred.name)),
            );
        }
        let condition = p.condition.as_ref().map(|c| {
            let mut sc = self.scope();
            let e = self.cx.expr(c, &mut sc);
            if e.ty != Ty::Bool && e.ty != Ty::Error {
                self.err(
                    Diagnostic::new(
                        Code::ConditionNotBool,
                        format!("a condition must be `bool`, found `{}`", e.ty),
                        file,
                        e.span,
                        format!("this is `{}`", e.ty),
                    )
                    .with_help("compare it, e.g. `scope.x > 3`"),
                );
                return TExpr::error(e.span);
            }
            self.supported(&e);
            e
        });
        let (weight, weight_written) = match &p.weight {
            Some(w) => {
                let mut sc = self.scope();
                let e = self.cx.expr(w, &mut sc);
                let e = self.cx.expect(file, e, Ty::Float, "a weight");
                if let Some(Value::Float(x)) = e.constant()
                    && !(x > 0.0 && x.is_finite())
                {
                    self.err(
                        Diagnostic::new(
                            Code::NonPositiveWeight,
                            format!("weight {} is not positive", x as f32),
                            file,
                            e.span,
                            "this weight",
                        )
                        .with_help(
                            "weights are positive: the chance of a rule is its weight over the sum",
                        ),
                    );
                }
                self.supported(&e);
                (e, true)
            }
            None => (TExpr::lit(Value::Float(1.0), p.arrow), false),
        };
        let mut ops = Vec::with_capacity(p.successor.len());
        for m in &p.successor {
            if let Some(op) = self.op(m) {
                ops.push(op);
            }
        }
        Some(ShapeRule {
            symbol: symbol?,
            condition,
            weight,
            weight_written,
            ops,
            pred: p.pred.span,
            arrow: p.arrow,
            span: p.span,
        })
    }

    /// A number argument.
    fn num(&mut self, e: &ast::Expr, what: &str) -> TExpr {
        let mut sc = self.scope();
        let t = self.cx.expr(e, &mut sc);
        let t = self.cx.expect(self.file, t, Ty::Float, what);
        self.supported(&t);
        t
    }

    /// Report what the shape engine does not evaluate (E0513) in `e`.
    fn supported(&mut self, e: &TExpr) {
        let mut found: Option<(Span, String)> = None;
        e.walk(&mut |x| {
            if found.is_some() {
                return;
            }
            match &x.kind {
                TExprKind::Call(b, _) if !builtin_supported(*b) => {
                    found = Some((x.span, format!("`{}`", b.name())));
                }
                TExprKind::Random(r, args)
                    if x.ty == Ty::Vec3 || args.iter().any(|a| a.ty == Ty::Vec3) =>
                {
                    found = Some((x.span, format!("`{}` of vectors", r.name())));
                }
                _ => {}
            }
        });
        if let Some((span, what)) = found {
            self.err(
                Diagnostic::new(
                    Code::ShapeUnsupportedFunction,
                    format!("{what} is not available in shape rules"),
                    self.file,
                    span,
                    "the shape engine does not evaluate this",
                )
                .with_note("shape rules evaluate arithmetic, comparisons, `if`, `sin`, `cos`, `tan`, `sqrt`, `pow`, `abs`, `floor`, `ceil`, `round`, `fract`, `sign`, `min`, `max`, `clamp`, `mix`, `step`, `smoothstep`, vectors and the random draws of numbers")
                .with_help("compute it in a `const` (outside the rules), or write it with these"),
            );
        }
        // Context queries name symbols of this system.
        let mut unknown: Vec<(Span, Name)> = Vec::new();
        e.walk(&mut |x| {
            if let TExprKind::Shape(ShapeValue::Query(_, name)) = &x.kind
                && !self.by_name.contains_key(name)
            {
                unknown.push((x.span, name.clone()));
            }
        });
        for (span, name) in unknown {
            let mut d = Diagnostic::new(
                Code::UnknownName,
                format!("`{name}` is not a shape symbol of this system"),
                self.file,
                span,
                "no shape of this symbol",
            );
            if let Some(h) = suggest::did_you_mean(&name, self.by_name.keys().map(|k| k.as_str())) {
                d = d.with_help(h);
            }
            self.err(d);
        }
    }

    /// One operation or successor.
    fn op(&mut self, m: &ast::Module) -> Option<ShapeOp> {
        let file = self.file;
        let name = m.symbol.name.as_str();
        let span = m.span;
        let k = m.args.len();
        let counts = op_counts(name);
        // Parts only on split, repeat and comp; those need them.
        let takes_parts = matches!(name, "split" | "repeat" | "comp");
        if let Some(parts) = &m.parts
            && !takes_parts
        {
            self.err(
                Diagnostic::new(
                    Code::MisplacedParts,
                    format!("`{name}` takes no parts"),
                    file,
                    parts.span,
                    "parts block",
                )
                .with_help("only `split`, `repeat` and `comp` have parts: `split(y) { 4: Ground | ~1: Upper }`"),
            );
        }
        if takes_parts && m.parts.is_none() && counts.is_some_and(|c| c.contains(&k)) {
            self.err(
                Diagnostic::new(
                    Code::MissingParts,
                    format!("`{name}` without parts"),
                    file,
                    span,
                    "no `{ ... }` after it",
                )
                .with_help(if name == "comp" {
                    "give its cases: `comp(faces) { front: Facade | side: Wall }`"
                } else {
                    "give its parts: `split(y) { 4: Ground | ~1: Upper }`"
                }),
            );
            return None;
        }
        match name {
            "[" | "]" => {
                return Some(ShapeOp {
                    kind: if name == "[" {
                        OpKind::Push
                    } else {
                        OpKind::Pop
                    },
                    span,
                });
            }
            "nil" if k == 0 => return None,
            _ => {}
        }
        let Some(counts) = counts else {
            if m.symbol.is_punct() {
                self.err(
                    Diagnostic::new(
                        Code::UnknownShapeOperation,
                        format!("`{name}` is not a shape operation"),
                        file,
                        m.symbol.span,
                        "a turtle command",
                    )
                    .with_note(
                        "shape systems have no turtle: `[` and `]` save and restore the scope",
                    )
                    .with_help("use `translate`, `rotate` and `size` to move the scope"),
                );
                return None;
            }
            if k > 0 {
                let lower = name.chars().next().is_some_and(char::is_lowercase);
                let near = suggest::did_you_mean(name, OPS.iter().map(|(n, _)| *n));
                if lower || near.is_some() {
                    let mut d = Diagnostic::new(
                        Code::UnknownShapeOperation,
                        format!("unknown shape operation `{name}`"),
                        file,
                        m.symbol.span,
                        "not an operation",
                    );
                    d = match near {
                        Some(h) => d.with_help(h),
                        None => d.with_help(format!(
                            "the operations are {}",
                            OPS.iter()
                                .map(|(n, _)| format!("`{n}`"))
                                .collect::<Vec<_>>()
                                .join(", ")
                        )),
                    };
                    self.err(d);
                } else {
                    self.err(
                        Diagnostic::new(
                            Code::ShapeSymbolArguments,
                            format!("shape symbol `{name}` takes no arguments"),
                            file,
                            span,
                            format!("{k} argument{}", plural(k)),
                        )
                        .with_note("a shape carries its scope and geometry, not parameters")
                        .with_help(format!(
                            "write `{name}`; its rules read `scope`, `index` and `tagged(...)`"
                        )),
                    );
                }
                self.symbol(&m.symbol.name, m.symbol.span, false);
                return None;
            }
            let s = self.symbol(&m.symbol.name, m.symbol.span, false);
            return Some(ShapeOp {
                kind: OpKind::Emit(s),
                span,
            });
        };
        if !counts.contains(&k) {
            self.err(
                Diagnostic::new(
                    Code::ShapeOperationArity,
                    format!(
                        "`{name}` takes {} argument{}, but {k} {} given",
                        counts_text(counts),
                        plural(*counts.last().unwrap_or(&0)),
                        if k == 1 { "was" } else { "were" }
                    ),
                    file,
                    span,
                    format!("{k} argument{}", plural(k)),
                )
                .with_help(op_help(name)),
            );
            return None;
        }
        let a = &m.args;
        let kind = match name {
            "extrude" => OpKind::Extrude(self.num(&a[0], "a height")),
            "taper" => OpKind::Taper(self.num(&a[0], "a height")),
            "offset" => OpKind::Offset(self.num(&a[0], "a distance")),
            "roof" => {
                let kind = self.named(&a[0], "roof kind", RoofKind::from_name, RoofKind::names());
                let angle = self.num(&a[1], "a roof's pitch");
                let overhang = a.get(2).map(|o| self.num(o, "a roof's overhang"));
                OpKind::Roof {
                    kind: kind?,
                    angle,
                    overhang,
                }
            }
            "translate" => OpKind::Translate([
                self.num(&a[0], "a distance"),
                self.num(&a[1], "a distance"),
                self.num(&a[2], "a distance"),
            ]),
            "rotate" => {
                let axis = self.named(&a[0], "axis", Axis::from_name, Axis::names());
                let degrees = self.num(&a[1], "an angle");
                OpKind::Rotate {
                    axis: axis?,
                    degrees,
                }
            }
            "size" => {
                let mut v: [Option<TExpr>; 3] = [None, None, None];
                for (i, e) in a.iter().enumerate() {
                    let keep = name_arg(e).is_some_and(|id| id.name == "_");
                    if !keep {
                        v[i] = Some(self.num(e, "a size"));
                    }
                }
                OpKind::Size(v)
            }
            "center" => {
                let axes = self.named(&a[0], "axes", center_axes, CENTER_AXES.iter().copied());
                OpKind::Center(axes?)
            }
            "insert" => OpKind::Insert(self.asset(&a[0])?),
            "material" => OpKind::Material(self.material(&a[0])?),
            "color" => OpKind::Color(self.color(a, span)),
            "texture" => match &a[0].kind {
                ExprKind::Str(path) => OpKind::Texture(path.clone()),
                _ => {
                    let id = self.plain_name(&a[0], "an image file name (`\"brick.png\"`)")?;
                    OpKind::Texture(id.name.to_string())
                }
            },
            "split" | "repeat" => {
                let axis = self.named(&a[0], "axis", Axis::from_name, Axis::names());
                let tag = a.get(1).and_then(|t| self.tag(t));
                let parts = m
                    .parts
                    .as_deref()
                    .map(|p| self.parts(p))
                    .unwrap_or_default();
                let s = SplitT {
                    axis: axis?,
                    tag,
                    parts,
                };
                if name == "split" {
                    OpKind::Split(s)
                } else {
                    OpKind::Repeat(s)
                }
            }
            "comp" => {
                let target = self.named(
                    &a[0],
                    "component",
                    CompTarget::from_name,
                    CompTarget::names(),
                );
                let tag = a.get(1).and_then(|t| self.tag(t));
                let cases = m
                    .parts
                    .as_deref()
                    .map(|p| self.cases(p))
                    .unwrap_or_default();
                OpKind::Comp(CompT {
                    target: target?,
                    tag,
                    cases,
                })
            }
            _ => return None,
        };
        Some(ShapeOp { kind, span })
    }

    /// A name argument from a fixed set (E0504 otherwise).
    fn named<T>(
        &mut self,
        e: &ast::Expr,
        what: &str,
        parse: impl Fn(&str) -> Option<T>,
        names: impl Iterator<Item = &'static str> + Clone,
    ) -> Option<T> {
        let list = || {
            names
                .clone()
                .map(|n| format!("`{n}`"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let Some(id) = name_arg(e) else {
            if !matches!(e.kind, ExprKind::Error) {
                self.err(
                    Diagnostic::new(
                        Code::UnknownShapeName,
                        format!("expected a {what} name"),
                        self.file,
                        e.span,
                        format!("not a {what}"),
                    )
                    .with_help(format!("the {what} names are {}", list())),
                );
            }
            return None;
        };
        if let Some(v) = parse(&id.name) {
            return Some(v);
        }
        let mut d = Diagnostic::new(
            Code::UnknownShapeName,
            format!("unknown {what} `{}`", id.name),
            self.file,
            id.span,
            format!("not a {what}"),
        );
        d = match suggest::did_you_mean(&id.name, names.clone()) {
            Some(h) => d.with_help(h),
            None => d.with_help(format!("the {what} names are {}", list())),
        };
        self.err(d);
        None
    }

    fn plain_name<'e>(&mut self, e: &'e ast::Expr, what: &str) -> Option<&'e ast::Ident> {
        let id = name_arg(e);
        if id.is_none() && !matches!(e.kind, ExprKind::Error) {
            self.err(
                Diagnostic::new(
                    Code::UnknownShapeName,
                    format!("expected {what}"),
                    self.file,
                    e.span,
                    "not a name",
                )
                .with_help(format!("write {what}, a plain name")),
            );
        }
        id
    }

    fn tag(&mut self, e: &ast::Expr) -> Option<Tag> {
        let id = self.plain_name(e, "a tag name (`floor`, `column`, ...)")?;
        Some(Tag {
            name: id.name.to_string(),
            span: id.span,
        })
    }

    fn asset(&mut self, e: &ast::Expr) -> Option<Asset> {
        let id = self.plain_name(e, "a primitive or mesh name")?;
        if let Some(p) = Primitive::from_name(&id.name) {
            return Some(Asset::Primitive(p));
        }
        if let Some(GlobalName {
            kind: GlobalKind::Mesh(m),
            ..
        }) = self.cx.lookup(self.fi, &id.name)
        {
            self.cx
                .program
                .index
                .push(self.file, id.span, Def::Mesh(m), false);
            return Some(Asset::Mesh(m));
        }
        let prims = Primitive::names();
        let mut d = Diagnostic::new(
            Code::UnknownShapeName,
            format!("unknown primitive or mesh `{}`", id.name),
            self.file,
            id.span,
            "not a primitive or declared mesh",
        );
        d = match suggest::did_you_mean(&id.name, prims.clone()) {
            Some(h) => d.with_help(h),
            None => d.with_help(format!(
                "the primitives are {}; a mesh is declared with `mesh NAME = \"file.obj\";`",
                prims
                    .map(|n| format!("`{n}`"))
                    .collect::<Vec<_>>()
                    .join(", ")
            )),
        };
        self.err(d);
        None
    }

    fn material(&mut self, e: &ast::Expr) -> Option<MaterialId> {
        let id = self.plain_name(e, "a material name")?;
        if let Some(GlobalName {
            kind: GlobalKind::Material(m),
            ..
        }) = self.cx.lookup(self.fi, &id.name)
        {
            self.cx
                .program
                .index
                .push(self.file, id.span, Def::Material(m), false);
            return Some(m);
        }
        let sc = self.scope();
        self.cx.unknown_name(self.file, id, &sc);
        None
    }

    fn color(&mut self, a: &[ast::Expr], span: Span) -> TExpr {
        if let [r, g, b] = a {
            let args = vec![
                self.num(r, "a colour channel"),
                self.num(g, "a colour channel"),
                self.num(b, "a colour channel"),
            ];
            if args.iter().any(|x| x.ty == Ty::Error) {
                return TExpr::error(span);
            }
            return crate::expr::node(TExprKind::Call(Builtin::Rgb, args), Ty::Vec3, span);
        }
        let mut sc = self.scope();
        let t = self.cx.expr(&a[0], &mut sc);
        let t = self
            .cx
            .expect(self.file, t, Ty::Vec3, "a colour (`rgb(r, g, b)`)");
        self.supported(&t);
        t
    }

    fn target(&mut self, s: &ast::Symbol) -> Option<u32> {
        if s.name == "nil" {
            return None;
        }
        Some(self.symbol(&s.name, s.span, false))
    }

    fn parts(&mut self, p: &ast::ShapeParts) -> Vec<ShapePartT> {
        if p.parts.is_empty() {
            self.err(
                Diagnostic::new(
                    Code::MissingParts,
                    "a split or repeat without parts",
                    self.file,
                    p.span,
                    "no parts",
                )
                .with_help("give its parts: `{ 4: Ground | ~1: Upper }`"),
            );
        }
        p.parts
            .iter()
            .map(|part| {
                let what = match part.kind {
                    PartKind::Absolute => "a part's length",
                    PartKind::Relative => "a part's percentage",
                    PartKind::Floating => "a part's weight",
                };
                let size = self.num(&part.value, what);
                ShapePartT {
                    kind: part.kind,
                    size,
                    target: self.target(&part.target),
                    span: part.span,
                }
            })
            .collect()
    }

    fn cases(&mut self, p: &ast::ShapeParts) -> Vec<CaseT> {
        if p.parts.is_empty() {
            self.err(
                Diagnostic::new(
                    Code::MissingParts,
                    "a component split without cases",
                    self.file,
                    p.span,
                    "no cases",
                )
                .with_help("give its cases: `{ front: Facade | side: Wall }`"),
            );
        }
        let mut out = Vec::with_capacity(p.parts.len());
        for case in &p.parts {
            let target = self.target(&case.target);
            if case.kind != PartKind::Absolute {
                self.err(
                    Diagnostic::new(
                        Code::UnknownShapeName,
                        "a case of a component split is `selector: Symbol`",
                        self.file,
                        case.span,
                        "a size, not a selector",
                    )
                    .with_help("write a selector: `front: Facade`"),
                );
                continue;
            }
            let sel = self.named(
                &case.value,
                "selector",
                Selector::from_name,
                Selector::names(),
            );
            if let Some(selector) = sel {
                out.push(CaseT {
                    selector,
                    target,
                    span: case.span,
                });
            }
        }
        out
    }
}

fn center_axes(s: &str) -> Option<[bool; 3]> {
    if !CENTER_AXES.contains(&s) {
        return None;
    }
    Some([s.contains('x'), s.contains('y'), s.contains('z')])
}

fn op_help(name: &str) -> &'static str {
    match name {
        "extrude" => "write `extrude(height)`",
        "taper" => "write `taper(height)`",
        "roof" => "write `roof(kind, angle)` or `roof(kind, angle, overhang)`",
        "translate" => "write `translate(x, y, z)`",
        "rotate" => "write `rotate(axis, degrees)`",
        "size" => "write `size(x, y, z)`; `_` keeps an axis",
        "center" => "write `center(axes)`, e.g. `center(xy)`",
        "offset" => "write `offset(distance)`",
        "insert" => "write `insert(name)`: a primitive or a declared mesh",
        "material" => "write `material(name)`",
        "color" => "write `color(rgb(r, g, b))`",
        "texture" => "write `texture(name)`",
        "split" => "write `split(axis) { parts }` or `split(axis, tag) { parts }`",
        "repeat" => "write `repeat(axis) { parts }` or `repeat(axis, tag) { parts }`",
        _ => "write `comp(faces) { cases }` or `comp(edges, tag) { cases }`",
    }
}

/// Whether the shape engine evaluates a built-in (directly or written
/// with its operations).
pub(crate) fn builtin_supported(b: Builtin) -> bool {
    !matches!(
        b,
        Builtin::Asin
            | Builtin::Acos
            | Builtin::Atan
            | Builtin::Atan2
            | Builtin::Exp
            | Builtin::Ln
            | Builtin::Log10
            | Builtin::Spline
    )
}

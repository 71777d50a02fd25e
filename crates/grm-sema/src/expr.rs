//! Typing expressions (with concrete types) into [`TExpr`], resolving names
//! and folding constants. Module parameter types are already known here:
//! inference ([`crate::infer`]) runs first.

use grm_diag::{Code, Diagnostic, FileId, Span};
use grm_syntax::ast::{BinaryOp, Expr, ExprKind, UnaryOp};

use crate::builtins::{Builtin, PTy, RandomFn, SettingKey, function_names, terminal_forms};
use crate::check::{Checker, GlobalKind, GlobalName, ValueInfo};
use crate::eval;
use crate::index::Def;
use crate::program::{Loc, TExpr, TExprKind, Ty, Value};
use crate::shape::{ShapeQuery, ShapeValue};
use crate::suggest;

/// A shape value read by name in a shape rule.
fn shape_name(name: &str) -> Option<ShapeValue> {
    match name {
        "scope" => Some(ShapeValue::Scope),
        "index" => Some(ShapeValue::Index),
        "count" => Some(ShapeValue::Count),
        "depth" => Some(ShapeValue::Depth),
        _ => None,
    }
}

/// How deep the checker follows nested expressions: the language's one
/// limit ([`grm_syntax::MAX_EXPR_DEPTH`]), which the parser enforces
/// already; this guards trees that did not come from the parser.
pub(crate) const MAX_DEPTH: u32 = grm_syntax::MAX_EXPR_DEPTH as u32;

/// A name bound by a pattern, as seen by the expressions of its production.
#[derive(Clone, Debug)]
pub(crate) struct ScopeBinding {
    pub name: grm_syntax::ast::Name,
    pub span: Span,
    pub slot: u32,
    pub ty: Ty,
    pub used: bool,
}

/// What an expression may refer to.
#[derive(Debug)]
pub(crate) struct Scope {
    pub file_idx: usize,
    pub bindings: Vec<ScopeBinding>,
    pub allow_random: bool,
    pub allow_params: bool,
    /// For messages: "a constant", "a setting", ...
    pub what: &'static str,
    /// A shape rule: `scope`, `index`, `count`, `depth`, `tagged(t)` and
    /// the context queries are values ([`crate::shape::ShapeValue`]).
    pub shape: bool,
}

impl Scope {
    /// Outside productions: no bindings and no random draws.
    pub(crate) fn global(file_idx: usize, allow_params: bool, what: &'static str) -> Scope {
        Scope {
            file_idx,
            bindings: Vec::new(),
            allow_random: false,
            allow_params,
            what,
            shape: false,
        }
    }
}

pub(crate) fn node(kind: TExprKind, ty: Ty, span: Span) -> TExpr {
    let e = TExpr { kind, ty, span };
    let foldable = match &e.kind {
        TExprKind::Unary(_, a) | TExprKind::Field(a, _) => a.constant().is_some(),
        TExprKind::Binary(_, a, b) => a.constant().is_some() && b.constant().is_some(),
        TExprKind::Call(_, args) => args.iter().all(|a| a.constant().is_some()),
        _ => false,
    };
    if foldable {
        let env = eval::Env {
            params: &[],
            globals: &[],
            bindings: &[],
        };
        if let Ok(v) = eval::eval(&e, &env) {
            return TExpr::lit(v, span);
        }
    }
    e
}

fn is_zero(v: Value) -> bool {
    match v {
        Value::Float(x) => x == 0.0,
        Value::Vec3(u) => u.contains(&0.0),
        _ => false,
    }
}

impl Checker<'_> {
    /// Require a type; reports E0201 and returns an error expression on mismatch.
    pub(crate) fn expect(&mut self, file: FileId, e: TExpr, ty: Ty, what: &str) -> TExpr {
        if e.ty == ty || e.ty == Ty::Error || ty == Ty::Error {
            return e;
        }
        let mut d = Diagnostic::new(
            Code::TypeMismatch,
            format!("expected `{ty}`, found `{}`", e.ty),
            file,
            e.span,
            format!("this is `{}`", e.ty),
        )
        .with_note(format!("{what} must be `{ty}`"));
        d = match (ty, e.ty) {
            (Ty::Float, Ty::Vec3) => {
                d.with_help("take a component with `.x`, `.y` or `.z`, or `length(...)`")
            }
            (Ty::Vec3, Ty::Float) => d.with_help("build a vector with `vec3(x, y, z)`"),
            (Ty::Bool, Ty::Float) => d.with_help("compare it, e.g. `... > 0`"),
            (Ty::Mesh, _) => {
                d.with_help("write the name of a declared mesh: `mesh name = \"file.obj\";`")
            }
            (Ty::Material, _) => {
                d.with_help("write the name of a declared material: `material name { ... }`")
            }
            (_, Ty::Mesh | Ty::Material) => d.with_help(
                "mesh and material names can only be used as `mesh(name)` and `material(name)`",
            ),
            _ => d,
        };
        self.error(d);
        TExpr::error(e.span)
    }

    /// Type an expression. Nesting deeper than [`MAX_DEPTH`] is reported
    /// once (E0211) and becomes an error expression, which bounds every
    /// recursion over typed expressions later on.
    pub(crate) fn expr(&mut self, e: &Expr, sc: &mut Scope) -> TExpr {
        if self.depth == 0 {
            self.deep_reported = false;
        }
        if self.depth >= MAX_DEPTH {
            if !self.deep_reported {
                self.deep_reported = true;
                let file = self.file_id(sc.file_idx);
                self.error(grm_syntax::expr_too_deep(file, e.span));
            }
            return TExpr::error(e.span);
        }
        self.depth += 1;
        let r = self.expr_inner(e, sc);
        self.depth -= 1;
        r
    }

    fn expr_inner(&mut self, e: &Expr, sc: &mut Scope) -> TExpr {
        let file = self.file_id(sc.file_idx);
        let span = e.span;
        match &e.kind {
            ExprKind::Number { value, .. } => TExpr::lit(Value::Float(*value), span),
            ExprKind::Bool(b) => TExpr::lit(Value::Bool(*b), span),
            ExprKind::Str(_) => {
                self.error(
                    Diagnostic::new(
                        Code::TypeMismatch,
                        "a string is not a value",
                        file,
                        span,
                        "a string",
                    )
                    .with_note("strings name files: `import`, `mesh`, a shape system's `lot` and `texture`")
                    .with_help("write a number, a vector or a name"),
                );
                TExpr::error(span)
            }
            ExprKind::Paren(inner) => self.expr(inner, sc),
            ExprKind::Error => TExpr::error(span),
            ExprKind::Name(id) => {
                if sc.shape
                    && let Some(v) = shape_name(&id.name)
                {
                    let ty = if v == ShapeValue::Scope {
                        Ty::Vec3
                    } else {
                        Ty::Float
                    };
                    return TExpr {
                        kind: TExprKind::Shape(v),
                        ty,
                        span,
                    };
                }
                self.name(file, id, sc)
            }
            ExprKind::Unary { op, operand } => {
                let a = self.expr(operand, sc);
                if a.ty == Ty::Error {
                    return TExpr::error(span);
                }
                let ok = match op {
                    UnaryOp::Neg => a.ty.is_numeric(),
                    UnaryOp::Not => a.ty == Ty::Bool,
                };
                if !ok {
                    let want = if *op == UnaryOp::Neg {
                        "`float` or `vec3`"
                    } else {
                        "`bool`"
                    };
                    self.error(
                        Diagnostic::new(
                            Code::TypeMismatch,
                            format!("`{}` cannot be applied to `{}`", op.as_str(), a.ty),
                            file,
                            span,
                            format!("operand is `{}`", a.ty),
                        )
                        .with_note(format!("`{}` needs {want}", op.as_str())),
                    );
                    return TExpr::error(span);
                }
                let ty = a.ty;
                node(TExprKind::Unary(*op, Box::new(a)), ty, span)
            }
            ExprKind::Binary { op, lhs, rhs } => {
                let a = self.expr(lhs, sc);
                let b = self.expr(rhs, sc);
                self.binary(file, *op, a, b, span)
            }
            ExprKind::Field { base, field } => {
                let b = self.expr(base, sc);
                if b.ty == Ty::Error {
                    return TExpr::error(span);
                }
                if b.ty != Ty::Vec3 {
                    self.error(
                        Diagnostic::new(
                            Code::TypeMismatch,
                            format!("`.{}` needs a `vec3`, found `{}`", field.name, b.ty),
                            file,
                            b.span,
                            format!("this is `{}`", b.ty),
                        )
                        .with_note("only vectors have fields"),
                    );
                    return TExpr::error(span);
                }
                let i = match field.name.as_str() {
                    "x" => 0,
                    "y" => 1,
                    "z" => 2,
                    other => {
                        let mut d = Diagnostic::new(
                            Code::UnknownField,
                            format!("`vec3` has no field `{other}`"),
                            file,
                            field.span,
                            "unknown field",
                        );
                        d = match other {
                            "r" => d.with_help("colours are vectors: write `.x` for red"),
                            "g" => d.with_help("colours are vectors: write `.y` for green"),
                            "b" => d.with_help("colours are vectors: write `.z` for blue"),
                            _ => d.with_help("the fields are `x`, `y` and `z`"),
                        };
                        self.error(d);
                        return TExpr::error(span);
                    }
                };
                node(TExprKind::Field(Box::new(b), i), Ty::Float, span)
            }
            ExprKind::If { cond, then, els } => {
                let c = self.expr(cond, sc);
                let c = self.expect(file, c, Ty::Bool, "the condition of `if`");
                let t = self.expr(then, sc);
                let f = self.expr(els, sc);
                if t.ty == Ty::Error || f.ty == Ty::Error {
                    return TExpr::error(span);
                }
                if t.ty != f.ty {
                    self.error(
                        Diagnostic::new(
                            Code::TypeMismatch,
                            format!(
                                "the branches of `if` have different types: `{}` and `{}`",
                                t.ty, f.ty
                            ),
                            file,
                            f.span,
                            format!("this is `{}`", f.ty),
                        )
                        .with_label(file, t.span, format!("this is `{}`", t.ty))
                        .with_note("both branches must have the same type"),
                    );
                    return TExpr::error(span);
                }
                match c.constant() {
                    Some(Value::Bool(true)) => t,
                    Some(Value::Bool(false)) => f,
                    _ if c.ty == Ty::Error => TExpr::error(span),
                    _ => {
                        let ty = t.ty;
                        TExpr {
                            kind: TExprKind::If(Box::new(c), Box::new(t), Box::new(f)),
                            ty,
                            span,
                        }
                    }
                }
            }
            ExprKind::Call { func, args }
                if sc.shape
                    && (func.name == "tagged"
                        || (matches!(func.name.as_str(), "index" | "count")
                            && args.len() == 1)
                        || ShapeQuery::from_name(&func.name).is_some()) =>
            {
                self.shape_call(file, func, args, span)
            }
            ExprKind::Call { func, args } => {
                let targs: Vec<TExpr> = args.iter().map(|a| self.expr(a, sc)).collect();
                if let Some(b) = Builtin::from_name(&func.name) {
                    self.builtin_call(file, b, targs, func.span, span)
                } else if let Some(r) = RandomFn::from_name(&func.name) {
                    if !sc.allow_random {
                        self.error(
                            Diagnostic::new(
                                Code::NotConstant,
                                format!("random draws are not allowed in {}", sc.what),
                                file,
                                span,
                                format!("`{}` draws a random number", r.name()),
                            )
                            .with_note("constants, meta-parameters, settings and materials are fixed for a whole run")
                            .with_help("draw random numbers in productions (conditions, weights, module arguments)"),
                        );
                        return TExpr::error(span);
                    }
                    self.random_call(file, r, targs, func.span, span)
                } else {
                    let mut d = Diagnostic::new(
                        Code::UnknownFunction,
                        format!("unknown function `{}`", func.name),
                        file,
                        func.span,
                        "not a built-in function",
                    );
                    if func.name == "not" {
                        // `not (x > 2)`, from other tools' notation.
                        d = d.with_help("write `!` for not: `!(x > 2)`");
                    } else if terminal_forms(&func.name).is_some() {
                        d = d.with_help(format!(
                            "`{}` is a module: it can appear in a successor or axiom, not inside an expression",
                            func.name
                        ));
                    } else if let Some(h) = suggest::did_you_mean(&func.name, function_names()) {
                        d = d.with_help(h);
                    }
                    self.error(d);
                    TExpr::error(span)
                }
            }
        }
    }

    /// `tagged(tag)`, `index(tag)`, `count(tag)`, `overlaps(Sym)`,
    /// `touches(Sym)`, `inside(Sym)` in a shape rule: one plain name, not
    /// an expression.
    fn shape_call(
        &mut self,
        file: FileId,
        func: &grm_syntax::ast::Ident,
        args: &[Expr],
        span: Span,
    ) -> TExpr {
        let what = if matches!(func.name.as_str(), "tagged" | "index" | "count") {
            "a tag name"
        } else {
            "a shape symbol"
        };
        let name = match args {
            [a] => match &a.kind {
                ExprKind::Name(id) => Some(id.name.clone()),
                _ => None,
            },
            _ => None,
        };
        let Some(name) = name else {
            if args.len() != 1 {
                self.error(
                    Diagnostic::new(
                        Code::FunctionArity,
                        format!(
                            "`{}` takes 1 argument, but {} were given",
                            func.name,
                            args.len()
                        ),
                        file,
                        span,
                        format!("{} arguments", args.len()),
                    )
                    .with_help(format!("write `{}(name)` with {what}", func.name)),
                );
            } else {
                self.error(
                    Diagnostic::new(
                        Code::TypeMismatch,
                        format!("`{}` takes {what}", func.name),
                        file,
                        args[0].span,
                        "not a name",
                    )
                    .with_help(format!("write `{}(name)` with {what}", func.name)),
                );
            }
            return TExpr::error(span);
        };
        let (v, ty) = match (ShapeQuery::from_name(&func.name), func.name.as_str()) {
            (Some(q), _) => (ShapeValue::Query(q, name), Ty::Bool),
            (None, "index") => (ShapeValue::TagIndex(name), Ty::Float),
            (None, "count") => (ShapeValue::TagCount(name), Ty::Float),
            (None, _) => (ShapeValue::Tagged(name), Ty::Bool),
        };
        TExpr {
            kind: TExprKind::Shape(v),
            ty,
            span,
        }
    }

    fn name(&mut self, file: FileId, id: &grm_syntax::ast::Ident, sc: &mut Scope) -> TExpr {
        let span = id.span;
        if let Some(b) = sc.bindings.iter_mut().find(|b| b.name == id.name) {
            b.used = true;
            let (slot, ty, bspan) = (b.slot, b.ty, b.span);
            self.program.index.push(
                file,
                span,
                Def::Binding {
                    binding: Loc::new(file, bspan),
                },
                false,
            );
            return TExpr {
                kind: if ty == Ty::Error {
                    TExprKind::Error
                } else {
                    TExprKind::ModuleParam(slot)
                },
                ty,
                span,
            };
        }
        match self.lookup(sc.file_idx, &id.name) {
            Some(GlobalName {
                kind: GlobalKind::Value(j),
                ..
            }) => {
                self.values[j].uses += 1;
                match self.values[j].info {
                    ValueInfo::Pending => TExpr::error(span),
                    ValueInfo::Const {
                        id: cid,
                        ty,
                        folded,
                        broken,
                    } => {
                        self.program.index.push(file, span, Def::Const(cid), false);
                        if broken {
                            return TExpr::error(span);
                        }
                        if let Some(v) = folded {
                            return TExpr::lit(v, span);
                        }
                        if !sc.allow_params {
                            self.not_constant_param(file, span, &id.name, sc.what, true);
                            return TExpr::error(span);
                        }
                        TExpr {
                            kind: TExprKind::Global(cid),
                            ty,
                            span,
                        }
                    }
                    ValueInfo::Param { id: pid, ty } => {
                        self.program.index.push(file, span, Def::Param(pid), false);
                        if !sc.allow_params {
                            self.not_constant_param(file, span, &id.name, sc.what, false);
                            return TExpr::error(span);
                        }
                        if ty == Ty::Error {
                            return TExpr::error(span);
                        }
                        TExpr {
                            kind: TExprKind::Param(pid),
                            ty,
                            span,
                        }
                    }
                }
            }
            Some(GlobalName {
                kind: GlobalKind::Mesh(m),
                ..
            }) => {
                self.program.index.push(file, span, Def::Mesh(m), false);
                TExpr::lit(Value::Mesh(m), span)
            }
            Some(GlobalName {
                kind: GlobalKind::Material(m),
                ..
            }) => {
                self.program.index.push(file, span, Def::Material(m), false);
                TExpr::lit(Value::Material(m), span)
            }
            None => {
                self.unknown_name(file, id, sc);
                TExpr::error(span)
            }
        }
    }

    fn not_constant_param(
        &mut self,
        file: FileId,
        span: Span,
        name: &str,
        what: &str,
        via_const: bool,
    ) {
        let label = if via_const {
            format!("`{name}` depends on a meta-parameter")
        } else {
            format!("`{name}` is a meta-parameter")
        };
        self.error(
            Diagnostic::new(
                Code::NotConstant,
                format!("{what} must be a constant, but `{name}` can change from run to run"),
                file,
                span,
                label,
            )
            .with_help("use a number or a constant that does not depend on meta-parameters"),
        );
    }

    pub(crate) fn unknown_name(&mut self, file: FileId, id: &grm_syntax::ast::Ident, sc: &Scope) {
        if self.files.get(sc.file_idx).is_some_and(|f| f.failed_import) {
            // It may be defined in the import that could not be read: that
            // one error (E0401) stands for it.
            return;
        }
        let mut d = Diagnostic::new(
            Code::UnknownName,
            format!("unknown name `{}`", id.name),
            file,
            id.span,
            "not found in this scope",
        );
        if let Some(g) = self.names.get(id.name.as_str()) {
            let other = g.loc.file;
            d = d.with_label(
                other,
                g.loc.span,
                "defined in a file this one does not import",
            );
            d = d.with_help("add an `import` of the file that defines it");
        } else {
            let bindings = sc.bindings.iter().map(|b| b.name.as_str());
            let globals = self.visible_names(sc.file_idx);
            if let Some(h) = suggest::did_you_mean_in(&id.name, bindings, globals) {
                d = d.with_help(h);
            } else if SettingKey::from_name(&id.name).is_some() {
                d = d.with_help("settings cannot be read in expressions; define a `const` and use it in both places");
            } else if sc.what == "a production" {
                d = d.with_help(
                    "bind it in the predecessor, e.g. `A(x) -> ...`, or define a `const`",
                );
            } else if sc.what == "the axiom" {
                d = d.with_help("the axiom binds no names: use a number, a `const` or a `param`");
            }
        }
        self.error(d);
    }

    fn binary(&mut self, file: FileId, op: BinaryOp, a: TExpr, b: TExpr, span: Span) -> TExpr {
        use BinaryOp::*;
        if a.ty == Ty::Error || b.ty == Ty::Error {
            return TExpr::error(span);
        }
        let ty = match op {
            Add | Sub => (a.ty == b.ty && a.ty.is_numeric()).then_some(a.ty),
            Mul | Div | Rem => (a.ty.is_numeric() && b.ty.is_numeric()).then(|| {
                if a.ty == Ty::Vec3 || b.ty == Ty::Vec3 {
                    Ty::Vec3
                } else {
                    Ty::Float
                }
            }),
            Lt | Le | Gt | Ge => (a.ty == Ty::Float && b.ty == Ty::Float).then_some(Ty::Bool),
            Eq | Ne => (a.ty == b.ty && matches!(a.ty, Ty::Float | Ty::Vec3 | Ty::Bool))
                .then_some(Ty::Bool),
            And | Or => (a.ty == Ty::Bool && b.ty == Ty::Bool).then_some(Ty::Bool),
        };
        let Some(ty) = ty else {
            let note = match op {
                Add | Sub => "`+` and `-` need two floats or two vectors",
                Mul | Div | Rem => {
                    "`*`, `/` and `%` need floats or vectors (a float on either side scales a vector)"
                }
                Lt | Le | Gt | Ge => "comparisons need two floats",
                Eq | Ne => "`==` and `!=` need two values of the same type",
                And | Or => "`&&` and `||` need two booleans",
            };
            self.error(
                Diagnostic::new(
                    Code::TypeMismatch,
                    format!(
                        "`{}` cannot be applied to `{}` and `{}`",
                        op.as_str(),
                        a.ty,
                        b.ty
                    ),
                    file,
                    span,
                    "mismatched operands",
                )
                .with_label(file, a.span, format!("`{}`", a.ty))
                .with_label(file, b.span, format!("`{}`", b.ty))
                .with_note(note),
            );
            return TExpr::error(span);
        };
        if matches!(op, And | Or) {
            // `false && x` is false, `true && x` is x (and the mirror
            // cases), so a condition switched off by a constant folds.
            let absorbing = op == Or;
            match (a.constant(), b.constant()) {
                (Some(Value::Bool(x)), _) if x == absorbing => {
                    return TExpr::lit(Value::Bool(x), span);
                }
                (_, Some(Value::Bool(y))) if y == absorbing => {
                    return TExpr::lit(Value::Bool(y), span);
                }
                (Some(Value::Bool(_)), _) => return b,
                (_, Some(Value::Bool(_))) => return a,
                _ => {}
            }
        }
        if matches!(op, Div | Rem) && b.constant().is_some_and(is_zero) {
            let what = if op == Div { "division" } else { "remainder" };
            self.error(
                Diagnostic::new(
                    Code::DivisionByZero,
                    format!("{what} by zero"),
                    file,
                    b.span,
                    "this is always zero",
                )
                .with_label(file, span, format!("this {what} has no finite value"))
                .with_help("divide by a value that is never zero"),
            );
            // Reported: typed as an error, so the checks of whatever holds
            // it (a setting, a material value) do not report it again.
            return TExpr {
                kind: TExprKind::Binary(op, Box::new(a), Box::new(b)),
                ty: Ty::Error,
                span,
            };
        }
        node(TExprKind::Binary(op, Box::new(a), Box::new(b)), ty, span)
    }

    fn arity_error(
        &mut self,
        file: FileId,
        name: &str,
        want: &str,
        got: usize,
        span: Span,
        sig: &str,
    ) {
        let plural = if want == "1" { "argument" } else { "arguments" };
        let given = if got == 1 {
            "1 was given".to_string()
        } else {
            format!("{got} were given")
        };
        self.error(
            Diagnostic::new(
                Code::FunctionArity,
                format!("`{name}` takes {want} {plural}, but {given}"),
                file,
                span,
                format!("{got} argument{}", if got == 1 { "" } else { "s" }),
            )
            .with_help(format!("write it as `{sig}`")),
        );
    }

    /// Check generic positions: the first non-error generic argument fixes
    /// `T`; the others must be `T`, or `float` when `T` is `vec3`.
    fn generic(
        &mut self,
        file: FileId,
        fname: &str,
        args: &mut [TExpr],
        is_gen: impl Fn(usize) -> bool,
        numeric: bool,
    ) -> Option<Ty> {
        let t = args
            .iter()
            .enumerate()
            .find(|(i, a)| is_gen(*i) && a.ty != Ty::Error)
            .map(|(_, a)| a.ty)?;
        if numeric && !t.is_numeric() {
            let first = args
                .iter()
                .enumerate()
                .find(|(i, a)| is_gen(*i) && a.ty != Ty::Error)
                .map(|(_, a)| a.span);
            self.error(Diagnostic::new(
                Code::TypeMismatch,
                format!("`{fname}` works on `float` or `vec3`, found `{t}`"),
                file,
                first.unwrap_or_default(),
                format!("this is `{t}`"),
            ));
            return None;
        }
        for (i, a) in args.iter_mut().enumerate() {
            if !is_gen(i) || a.ty == Ty::Error || a.ty == t || (t == Ty::Vec3 && a.ty == Ty::Float)
            {
                continue;
            }
            let taken = std::mem::replace(a, TExpr::error(Span::default()));
            *a = self.expect(file, taken, t, &format!("this argument of `{fname}`"));
        }
        Some(t)
    }

    fn builtin_call(
        &mut self,
        file: FileId,
        b: Builtin,
        mut args: Vec<TExpr>,
        fspan: Span,
        span: Span,
    ) -> TExpr {
        let (ok, want) = b.arity();
        if !ok(args.len()) {
            let sig = builtin_signature(b);
            self.arity_error(file, b.name(), want, args.len(), fspan.to(span), &sig);
            return TExpr::error(span);
        }
        for (i, a) in args.iter_mut().enumerate() {
            let want = match b.param(i) {
                PTy::F => Ty::Float,
                PTy::V => Ty::Vec3,
                PTy::Gen => continue,
            };
            let taken = std::mem::replace(a, TExpr::error(Span::default()));
            *a = self.expect(
                file,
                taken,
                want,
                &format!("argument {} of `{}`", i + 1, b.name()),
            );
        }
        let t = self.generic(file, b.name(), &mut args, |i| b.param(i) == PTy::Gen, true);
        if args.iter().any(|a| a.ty == Ty::Error) {
            return TExpr::error(span);
        }
        let ret = match b.signature().1 {
            PTy::F => Ty::Float,
            PTy::V => Ty::Vec3,
            PTy::Gen => match t {
                Some(t) => t,
                None => return TExpr::error(span),
            },
        };
        node(TExprKind::Call(b, args), ret, span)
    }

    fn random_call(
        &mut self,
        file: FileId,
        r: RandomFn,
        mut args: Vec<TExpr>,
        fspan: Span,
        span: Span,
    ) -> TExpr {
        let n = args.len();
        let (ok, want, sig) = match r {
            RandomFn::Uniform => (n == 2, "2", "uniform(low, high)"),
            RandomFn::Normal => (n == 2, "2", "normal(mean, sd)"),
            RandomFn::RandInt => (n == 2, "2", "randint(low, high)"),
            RandomFn::Chance => (n == 1, "1", "chance(p)"),
            RandomFn::Choose => (
                n >= 2 && n.is_multiple_of(2),
                "an even number of (at least 2)",
                "choose(v0, w0, v1, w1, ...)",
            ),
        };
        if !ok {
            self.arity_error(file, r.name(), want, n, fspan.to(span), sig);
            return TExpr::error(span);
        }
        let ret = match r {
            RandomFn::Choose => {
                for (i, a) in args.iter_mut().enumerate().filter(|(i, _)| i % 2 == 1) {
                    let taken = std::mem::replace(a, TExpr::error(Span::default()));
                    *a = self.expect(
                        file,
                        taken,
                        Ty::Float,
                        &format!("weight {} of `choose`", i / 2 + 1),
                    );
                    // As for production weights (E0207): a constant weight
                    // must be positive; parametric ones are checked at run
                    // time.
                    if let Some(Value::Float(x)) = a.constant()
                        && !(x.is_finite() && x > 0.0)
                    {
                        self.error(
                            Diagnostic::new(
                                Code::NonPositiveWeight,
                                format!(
                                    "weight {} of `choose` must be a positive number, but this is {x}",
                                    i / 2 + 1
                                ),
                                file,
                                a.span,
                                "not positive",
                            )
                            .with_help("use a weight > 0; to drop a value, remove it and its weight"),
                        );
                    }
                }
                match self.generic(file, "choose", &mut args, |i| i % 2 == 0, false) {
                    Some(t) => t,
                    None => return TExpr::error(span),
                }
            }
            _ => {
                for (i, a) in args.iter_mut().enumerate() {
                    let taken = std::mem::replace(a, TExpr::error(Span::default()));
                    *a = self.expect(
                        file,
                        taken,
                        Ty::Float,
                        &format!("argument {} of `{}`", i + 1, r.name()),
                    );
                }
                if r == RandomFn::Chance {
                    Ty::Bool
                } else {
                    Ty::Float
                }
            }
        };
        if args.iter().any(|a| a.ty == Ty::Error) {
            return TExpr::error(span);
        }
        TExpr {
            kind: TExprKind::Random(r, args),
            ty: ret,
            span,
        }
    }
}

/// The call as documented, for help lines.
fn builtin_signature(b: Builtin) -> String {
    use Builtin::*;
    let args = match b {
        Sin | Cos | Tan => "degrees",
        Asin | Acos | Atan => "x",
        Atan2 => "y, x",
        Sqrt | Exp | Ln | Log10 | Abs | Floor | Ceil | Round | Fract | Sign => "x",
        Pow => "base, exponent",
        Min | Max => "a, b",
        Clamp => "x, low, high",
        Mix => "a, b, t",
        Step => "edge, x",
        Smoothstep => "edge0, edge1, x",
        Vec3 => "x, y, z",
        Rgb => "r, g, b",
        Dot | Cross | Distance => "u, v",
        Length | Normalize => "v",
        Spline => "t, c0, c1, c2, c3, ...",
    };
    format!("{}({args})", b.name())
}

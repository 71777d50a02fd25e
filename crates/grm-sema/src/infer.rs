//! Type inference for module parameters.
//!
//! Each parameter of a user symbol is a type variable. Every use unifies:
//! a successor argument with the parameter, a pattern binding's uses inside
//! expressions with the operators and functions they meet. Unification is
//! union-find; `*`, `/` and `%`, which accept a float on either side of a
//! vector, are solved lazily: once one operand is known to be `float` the
//! result is the other operand's type, once one is `vec3` the result is
//! `vec3`. Whatever stays open is defaulted to `float`, one variable at a
//! time, re-solving after each, so the result does not depend on the order
//! of productions in the file more than unavoidable.
//!
//! This pass reports nothing: conflicts keep the first type found, and the
//! typing pass ([`crate::expr`]) then reports every mismatch against the
//! final types with precise spans.

use grm_diag::Span;
use grm_syntax::ast::{BinaryOp, Expr, ExprKind, UnaryOp};

use crate::builtins::{Builtin, PTy, RandomFn};
use crate::program::Ty;

/// An inferred type: known, a variable, or unconstrained (errors, names that
/// do not resolve).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum It {
    K(Ty),
    V(u32),
    Any,
}

/// A deferred `r = a (*|/|%) b`.
#[derive(Clone, Copy, Debug)]
struct MulC {
    a: It,
    b: It,
    r: u32,
}

#[derive(Debug, Default)]
pub(crate) struct Infer {
    parent: Vec<u32>,
    ty: Vec<Option<Ty>>,
    /// Where a variable first got a concrete type (for messages).
    origin: Vec<Option<Span>>,
    deferred: Vec<MulC>,
}

impl Infer {
    pub(crate) fn fresh(&mut self) -> u32 {
        let v = self.parent.len() as u32;
        self.parent.push(v);
        self.ty.push(None);
        self.origin.push(None);
        v
    }

    fn find(&mut self, mut v: u32) -> u32 {
        // Path halving keeps the trees flat without recursion.
        while self.parent[v as usize] != v {
            let p = self.parent[v as usize];
            self.parent[v as usize] = self.parent[p as usize];
            v = p;
        }
        v
    }

    /// The resolved form: a known type if the variable has one.
    pub(crate) fn resolve(&mut self, t: It) -> It {
        match t {
            It::V(v) => {
                let r = self.find(v);
                match self.ty[r as usize] {
                    Some(k) => It::K(k),
                    None => It::V(r),
                }
            }
            other => other,
        }
    }

    /// The type of a variable, if known.
    pub(crate) fn get(&mut self, v: u32) -> Option<Ty> {
        let r = self.find(v);
        self.ty[r as usize]
    }

    /// Where a variable got its type.
    pub(crate) fn origin(&mut self, v: u32) -> Option<Span> {
        let r = self.find(v);
        self.origin[r as usize]
    }

    /// Fix a variable's type if it has none; the first type wins.
    pub(crate) fn set(&mut self, v: u32, ty: Ty, at: Span) {
        if ty == Ty::Error {
            return;
        }
        let r = self.find(v) as usize;
        if self.ty[r].is_none() {
            self.ty[r] = Some(ty);
            self.origin[r] = Some(at);
        }
    }

    pub(crate) fn unify(&mut self, a: It, b: It, at: Span) {
        match (self.resolve(a), self.resolve(b)) {
            (It::V(x), It::V(y)) if x != y => self.parent[x as usize] = y,
            (It::V(x), It::K(t)) | (It::K(t), It::V(x)) => self.set(x, t, at),
            _ => {}
        }
    }

    /// Solve the deferred constraints, defaulting stuck variables to float.
    pub(crate) fn solve(&mut self) {
        let mut pending = std::mem::take(&mut self.deferred);
        loop {
            let before = pending.len();
            pending.retain(|c| !self.step(*c));
            if pending.is_empty() {
                break;
            }
            if pending.len() == before {
                // Stuck: default one open operand and go on.
                let c = pending[0];
                for x in [c.a, c.b, It::V(c.r)] {
                    if let It::V(v) = self.resolve(x) {
                        self.set(v, Ty::Float, Span::default());
                        break;
                    }
                }
            }
        }
    }

    /// Default every variable still open to `float`.
    pub(crate) fn default_all(&mut self) {
        for v in 0..self.parent.len() as u32 {
            let r = self.find(v) as usize;
            if self.ty[r].is_none() {
                self.ty[r] = Some(Ty::Float);
            }
        }
    }

    /// Try to solve one constraint; true when it is done.
    fn step(&mut self, c: MulC) -> bool {
        let (a, b, r) = (
            self.resolve(c.a),
            self.resolve(c.b),
            self.resolve(It::V(c.r)),
        );
        match (a, b) {
            (It::K(Ty::Float), x) | (x, It::K(Ty::Float)) => {
                self.unify(It::V(c.r), x, Span::default());
                true
            }
            (It::K(Ty::Vec3), _) | (_, It::K(Ty::Vec3)) => {
                self.unify(It::V(c.r), It::K(Ty::Vec3), Span::default());
                true
            }
            (It::K(_), _) | (_, It::K(_)) | (It::Any, _) | (_, It::Any) => true,
            (It::V(_), It::V(_)) => {
                if r == It::K(Ty::Float) {
                    self.unify(a, It::K(Ty::Float), Span::default());
                    self.unify(b, It::K(Ty::Float), Span::default());
                    true
                } else {
                    false
                }
            }
        }
    }

    /// Infer an expression's type. `lookup` gives the type of a name.
    pub(crate) fn expr(&mut self, e: &Expr, lookup: &dyn Fn(&str) -> It) -> It {
        self.expr_at(e, lookup, 0)
    }

    fn expr_at(&mut self, e: &Expr, lookup: &dyn Fn(&str) -> It, depth: u32) -> It {
        if depth >= crate::expr::MAX_DEPTH {
            return It::Any; // reported by the typing pass
        }
        let d = depth + 1;
        let span = e.span;
        match &e.kind {
            ExprKind::Number { .. } => It::K(Ty::Float),
            ExprKind::Bool(_) => It::K(Ty::Bool),
            ExprKind::Error | ExprKind::Str(_) => It::Any,
            ExprKind::Paren(inner) => self.expr_at(inner, lookup, d),
            ExprKind::Name(id) => lookup(&id.name),
            ExprKind::Unary { op, operand } => {
                let a = self.expr_at(operand, lookup, d);
                match op {
                    UnaryOp::Neg => a,
                    UnaryOp::Not => {
                        self.unify(a, It::K(Ty::Bool), operand.span);
                        It::K(Ty::Bool)
                    }
                }
            }
            ExprKind::Binary { op, lhs, rhs } => {
                let a = self.expr_at(lhs, lookup, d);
                let b = self.expr_at(rhs, lookup, d);
                use BinaryOp::*;
                match op {
                    Add | Sub => {
                        self.unify(a, b, span);
                        if a == It::Any { b } else { a }
                    }
                    Mul | Div | Rem => {
                        let r = self.fresh();
                        let c = MulC { a, b, r };
                        if !self.step(c) {
                            self.deferred.push(c);
                        }
                        It::V(r)
                    }
                    Lt | Le | Gt | Ge => {
                        self.unify(a, It::K(Ty::Float), lhs.span);
                        self.unify(b, It::K(Ty::Float), rhs.span);
                        It::K(Ty::Bool)
                    }
                    Eq | Ne => {
                        self.unify(a, b, span);
                        It::K(Ty::Bool)
                    }
                    And | Or => {
                        self.unify(a, It::K(Ty::Bool), lhs.span);
                        self.unify(b, It::K(Ty::Bool), rhs.span);
                        It::K(Ty::Bool)
                    }
                }
            }
            ExprKind::Field { base, .. } => {
                let b = self.expr_at(base, lookup, d);
                self.unify(b, It::K(Ty::Vec3), base.span);
                It::K(Ty::Float)
            }
            ExprKind::If { cond, then, els } => {
                let c = self.expr_at(cond, lookup, d);
                self.unify(c, It::K(Ty::Bool), cond.span);
                let t = self.expr_at(then, lookup, d);
                let f = self.expr_at(els, lookup, d);
                self.unify(t, f, span);
                if t == It::Any { f } else { t }
            }
            ExprKind::Call { func, args } => {
                let ts: Vec<It> = args.iter().map(|a| self.expr_at(a, lookup, d)).collect();
                if let Some(b) = Builtin::from_name(&func.name) {
                    let mut first_gen = None;
                    for (i, (t, a)) in ts.iter().zip(args).enumerate() {
                        match b.param(i) {
                            PTy::F => self.unify(*t, It::K(Ty::Float), a.span),
                            PTy::V => self.unify(*t, It::K(Ty::Vec3), a.span),
                            PTy::Gen => {
                                if first_gen.is_none() {
                                    first_gen = Some(*t);
                                }
                            }
                        }
                    }
                    match b.signature().1 {
                        PTy::F => It::K(Ty::Float),
                        PTy::V => It::K(Ty::Vec3),
                        PTy::Gen => first_gen.unwrap_or(It::Any),
                    }
                } else if let Some(r) = RandomFn::from_name(&func.name) {
                    match r {
                        RandomFn::Choose => {
                            for (t, a) in ts.iter().zip(args).skip(1).step_by(2) {
                                self.unify(*t, It::K(Ty::Float), a.span);
                            }
                            ts.first().copied().unwrap_or(It::Any)
                        }
                        _ => {
                            for (t, a) in ts.iter().zip(args) {
                                self.unify(*t, It::K(Ty::Float), a.span);
                            }
                            if r == RandomFn::Chance {
                                It::K(Ty::Bool)
                            } else {
                                It::K(Ty::Float)
                            }
                        }
                    }
                } else {
                    It::Any
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use grm_syntax::ast::{Expr, Ident};

    fn sp() -> Span {
        Span::new(0, 0)
    }
    fn name(n: &str) -> Expr {
        Expr {
            kind: ExprKind::Name(Ident {
                name: n.into(),
                span: sp(),
            }),
            span: sp(),
        }
    }
    fn num(v: f64) -> Expr {
        Expr {
            kind: ExprKind::Number {
                value: v,
                text: v.to_string().into(),
            },
            span: sp(),
        }
    }
    fn bin(op: BinaryOp, a: Expr, b: Expr) -> Expr {
        Expr {
            kind: ExprKind::Binary {
                op,
                lhs: Box::new(a),
                rhs: Box::new(b),
            },
            span: sp(),
        }
    }
    fn field(a: Expr, f: &str) -> Expr {
        Expr {
            kind: ExprKind::Field {
                base: Box::new(a),
                field: Ident {
                    name: f.into(),
                    span: sp(),
                },
            },
            span: sp(),
        }
    }

    #[test]
    fn addition_with_float_fixes_variable() {
        let mut inf = Infer::default();
        let x = inf.fresh();
        let lookup = move |n: &str| if n == "x" { It::V(x) } else { It::Any };
        inf.expr(&bin(BinaryOp::Add, name("x"), num(1.0)), &lookup);
        assert_eq!(inf.get(x), Some(Ty::Float));
    }

    #[test]
    fn field_access_makes_vector() {
        let mut inf = Infer::default();
        let v = inf.fresh();
        let lookup = move |n: &str| if n == "v" { It::V(v) } else { It::Any };
        inf.expr(&field(name("v"), "y"), &lookup);
        assert_eq!(inf.get(v), Some(Ty::Vec3));
    }

    #[test]
    fn scaling_is_deferred_until_operand_known() {
        // r = x * 2 first; later x is known to be a vector: r must be vec3.
        let mut inf = Infer::default();
        let x = inf.fresh();
        let r = inf.fresh();
        let lookup = move |n: &str| if n == "x" { It::V(x) } else { It::Any };
        let t = inf.expr(&bin(BinaryOp::Mul, name("x"), num(2.0)), &lookup);
        inf.unify(It::V(r), t, sp());
        assert_eq!(inf.get(r), None, "still open");
        inf.expr(&field(name("x"), "x"), &lookup);
        inf.solve();
        assert_eq!(inf.get(r), Some(Ty::Vec3));
    }

    #[test]
    fn unconstrained_product_defaults_to_float() {
        let mut inf = Infer::default();
        let x = inf.fresh();
        let y = inf.fresh();
        let lookup = move |n: &str| match n {
            "x" => It::V(x),
            "y" => It::V(y),
            _ => It::Any,
        };
        let t = inf.expr(&bin(BinaryOp::Mul, name("x"), name("y")), &lookup);
        inf.solve();
        assert_eq!(
            inf.get(x),
            Some(Ty::Float),
            "the stuck operand is defaulted"
        );
        inf.default_all();
        assert_eq!(inf.resolve(t), It::K(Ty::Float));
        assert_eq!(inf.get(y), Some(Ty::Float));
    }

    #[test]
    fn unification_chains_through_variables() {
        let mut inf = Infer::default();
        let a = inf.fresh();
        let b = inf.fresh();
        let c = inf.fresh();
        inf.unify(It::V(a), It::V(b), sp());
        inf.unify(It::V(b), It::V(c), sp());
        inf.unify(It::V(c), It::K(Ty::Vec3), sp());
        assert_eq!(inf.get(a), Some(Ty::Vec3));
    }

    #[test]
    fn first_type_wins_on_conflict() {
        let mut inf = Infer::default();
        let a = inf.fresh();
        inf.unify(It::V(a), It::K(Ty::Bool), Span::new(1, 2));
        inf.unify(It::V(a), It::K(Ty::Float), Span::new(3, 4));
        assert_eq!(inf.get(a), Some(Ty::Bool));
        assert_eq!(inf.origin(a), Some(Span::new(1, 2)));
    }
}

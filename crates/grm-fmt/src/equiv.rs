//! Tree equality with spans ignored: what "the formatter does not change
//! meaning" means.

use grm_syntax::ast::*;

/// Whether two files have the same syntax tree, ignoring every span.
pub fn same_tree(a: &File, b: &File) -> bool {
    let mut a = a.clone();
    let mut b = b.clone();
    file(&mut a);
    file(&mut b);
    a == b
}

const Z: Span = Span::new(0, 0);

fn file(f: &mut File) {
    f.span = Z;
    for i in &mut f.items {
        item(i);
    }
}

fn ident(i: &mut Ident) {
    i.span = Z;
}

fn strlit(s: &mut StrLit) {
    s.span = Z;
}

fn ty(t: &mut Option<TypeAnn>) {
    if let Some(t) = t {
        ident(&mut t.name);
    }
}

fn item(i: &mut Item) {
    match i {
        Item::Import(x) => {
            strlit(&mut x.path);
            x.span = Z;
        }
        Item::Const(c) => {
            ident(&mut c.name);
            ty(&mut c.ty);
            expr(&mut c.value);
            c.span = Z;
        }
        Item::Param(p) => {
            ident(&mut p.name);
            ty(&mut p.ty);
            expr(&mut p.default);
            if let Some((lo, hi)) = &mut p.range {
                expr(lo);
                expr(hi);
            }
            p.span = Z;
        }
        Item::Mesh(m) => {
            ident(&mut m.name);
            strlit(&mut m.path);
            m.span = Z;
        }
        Item::Material(m) => {
            ident(&mut m.name);
            for f in &mut m.fields {
                ident(&mut f.name);
                expr(&mut f.value);
                f.span = Z;
            }
            m.span = Z;
        }
        Item::System(s) => {
            ident(&mut s.name);
            for i in &mut s.items {
                sys_item(i);
            }
            s.span = Z;
        }
        Item::Error(s) => *s = Z,
    }
}

fn symbol(s: &mut Symbol) {
    s.span = Z;
}

fn module(m: &mut Module) {
    symbol(&mut m.symbol);
    for a in &mut m.args {
        expr(a);
    }
    m.span = Z;
}

fn pattern(p: &mut Pattern) {
    symbol(&mut p.symbol);
    for i in &mut p.params {
        ident(i);
    }
    p.span = Z;
}

fn ctx(c: &mut ContextItem) {
    match c {
        ContextItem::Pattern(p) => pattern(p),
        ContextItem::Push(s) | ContextItem::Pop(s) => *s = Z,
    }
}

fn sys_item(i: &mut SystemItem) {
    match i {
        SystemItem::Axiom(a) => {
            a.modules.iter_mut().for_each(module);
            a.span = Z;
        }
        SystemItem::Setting(s) => {
            ident(&mut s.name);
            expr(&mut s.value);
            s.span = Z;
        }
        SystemItem::Ignore(ig) => {
            ig.symbols.iter_mut().for_each(symbol);
            ig.span = Z;
        }
        SystemItem::ModuleDecl(d) => {
            d.keyword = Z;
            for m in &mut d.modules {
                symbol(&mut m.symbol);
                for p in m.params.iter_mut().flatten() {
                    ident(&mut p.name);
                    ty(&mut p.ty);
                    p.span = Z;
                }
                m.span = Z;
            }
            d.span = Z;
        }
        SystemItem::Production(p) => {
            p.left.iter_mut().for_each(ctx);
            pattern(&mut p.pred);
            p.right.iter_mut().for_each(ctx);
            if let Some(c) = &mut p.condition {
                expr(c);
            }
            if let Some(w) = &mut p.weight {
                expr(w);
            }
            p.successor.iter_mut().for_each(module);
            p.arrow = Z;
            p.span = Z;
        }
        SystemItem::Error(s) => *s = Z,
    }
}

fn expr(e: &mut Expr) {
    e.span = Z;
    match &mut e.kind {
        ExprKind::Number { .. } | ExprKind::Bool(_) | ExprKind::Error => {}
        ExprKind::Name(n) => ident(n),
        ExprKind::Call { func, args } => {
            ident(func);
            args.iter_mut().for_each(expr);
        }
        ExprKind::Unary { operand, .. } => expr(operand),
        ExprKind::Binary { lhs, rhs, .. } => {
            expr(lhs);
            expr(rhs);
        }
        ExprKind::Field { base, field } => {
            expr(base);
            ident(field);
        }
        ExprKind::If { cond, then, els } => {
            expr(cond);
            expr(then);
            expr(els);
        }
        ExprKind::Paren(inner) => expr(inner),
    }
}

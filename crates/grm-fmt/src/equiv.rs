//! Tree equality with spans ignored: what "the formatter does not change
//! meaning" means.

use grm_syntax::ast::*;

/// Whether two files have the same syntax tree, ignoring every span.
/// Item by item: only one item of each is copied at a time.
pub fn same_tree(a: &File, b: &File) -> bool {
    a.items.len() == b.items.len()
        && a.items.iter().zip(&b.items).all(|(x, y)| {
            let (mut x, mut y) = (x.clone(), y.clone());
            item(&mut x);
            item(&mut y);
            x == y
        })
}

/// A fingerprint of a file's syntax tree with spans ignored, and of its
/// comments' texts as printed: two files with the same tree and comments
/// have the same fingerprint, and two that differ have the same one only
/// by a 128-bit hash collision. It lets [`crate::format`] drop the tree it
/// printed before it parses what it printed (issue 32: both trees at once,
/// and a copy of each, were most of `grmc fmt`'s memory).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Fingerprint {
    pub tree: [u64; 2],
    pub comments: [u64; 2],
}

/// Two independent 64-bit hashes of what is written into it.
struct Hash2([std::collections::hash_map::DefaultHasher; 2]);

impl Hash2 {
    fn new() -> Hash2 {
        use std::hash::Hasher;
        let mut h = [
            std::collections::hash_map::DefaultHasher::new(),
            std::collections::hash_map::DefaultHasher::new(),
        ];
        // The second hash starts from another state.
        h[1].write_u64(0x9e37_79b9_7f4a_7c15);
        Hash2(h)
    }

    fn bytes(&mut self, b: &[u8]) {
        use std::hash::Hasher;
        for h in &mut self.0 {
            h.write(b);
        }
    }

    fn finish(&self) -> [u64; 2] {
        use std::hash::Hasher;
        [self.0[0].finish(), self.0[1].finish()]
    }
}

impl std::fmt::Write for Hash2 {
    fn write_str(&mut self, s: &str) -> std::fmt::Result {
        self.bytes(s.as_bytes());
        Ok(())
    }
}

impl Fingerprint {
    /// The fingerprint of a parsed file: its items through [`TreeHash`],
    /// and its comments' texts as printed (`comment_text`).
    pub(crate) fn of<'c>(
        f: &File,
        comments: impl Iterator<Item = std::borrow::Cow<'c, str>>,
    ) -> Fingerprint {
        let mut t = TreeHash::new();
        for i in &f.items {
            t.add(i);
        }
        Fingerprint::from_parts(t, comments)
    }

    /// The fingerprint of a tree hashed item by item, and of its comments.
    pub(crate) fn from_parts<'c>(
        tree: TreeHash,
        comments: impl Iterator<Item = std::borrow::Cow<'c, str>>,
    ) -> Fingerprint {
        use std::fmt::Write;
        let mut c = Hash2::new();
        for text in comments {
            let _ = write!(c, "{}:", text.len());
            c.bytes(text.as_bytes());
        }
        Fingerprint {
            tree: tree.finish(),
            comments: c.finish(),
        }
    }
}

/// The hash of a file's items, given one at a time (each copied alone):
/// each item through its `Debug` form with spans cleared (the `Debug`
/// form shows every field, numbers exactly), then their number.
pub(crate) struct TreeHash {
    hash: Hash2,
    items: usize,
}

impl TreeHash {
    pub(crate) fn new() -> TreeHash {
        TreeHash {
            hash: Hash2::new(),
            items: 0,
        }
    }

    pub(crate) fn add(&mut self, i: &Item) {
        use std::fmt::Write;
        let mut i = i.clone();
        item(&mut i);
        let _ = write!(self.hash, "{i:?};");
        self.items += 1;
    }

    fn finish(mut self) -> [u64; 2] {
        use std::fmt::Write;
        let _ = write!(self.hash, "{};", self.items);
        self.hash.finish()
    }
}

const Z: Span = Span::new(0, 0);

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
        Item::Layout(m) => {
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
    if let Some(ps) = &mut m.parts {
        for p in &mut ps.parts {
            expr(&mut p.value);
            symbol(&mut p.target);
            p.span = Z;
        }
        ps.span = Z;
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
        ExprKind::Number { .. } | ExprKind::Bool(_) | ExprKind::Str(_) | ExprKind::Error => {}
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

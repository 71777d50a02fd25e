//! The printer: walks the tree in source order and writes each token, and
//! puts the comments back between the tokens by span position.
//!
//! Every token written carries the source position it came from (a node's
//! span, or the position of the unnamed token `=`, `,`, `)`, ... found in the
//! token stream). Before a token is written, every comment that started
//! before it in the source is written first. Tokens are written in source
//! order, so each comment keeps its place relative to the tokens around it.
//! Between statements, comments are placed by lines: on the statement's line
//! after it (trailing), on lines of their own (standalone), or on the line
//! of the next statement before it (leading, written inline).

use grm_diag::{FileId, count_line_breaks, has_line_break};
use grm_syntax::Parsed;
use grm_syntax::ast::*;
use grm_syntax::lexer::{self, Tok};

/// Spaces per indentation level.
const INDENT: usize = 4;

/// Print a parsed file in canonical style.
pub(crate) fn print(parsed: &Parsed, text: &str) -> String {
    // Compact tokens (no text): where the unnamed tokens are.
    let toks = lexer::lex_toks(FileId(0), text).tokens;
    let mut p = Printer {
        text,
        toks: &toks,
        comments: &parsed.comments,
        next: 0,
        out: String::with_capacity(text.len() + text.len() / 8),
        indent: 0,
        hang: INDENT,
        space: false,
        after_comment: false,
        line_empty: true,
    };
    let stmts: Vec<Stmt<'_>> = parsed.file.items.iter().map(Stmt::Item).collect();
    let end = u32::try_from(text.len()).unwrap_or(u32::MAX);
    p.block(&stmts, 0, end, true);
    // Anything left over (only possible for a tree with errors whose spans
    // overlap oddly): keep it rather than drop it.
    while let Some(c) = p.comments.get(p.next) {
        p.next += 1;
        p.inline_comment(c);
    }
    if !p.out.is_empty() {
        p.nl();
    }
    p.out
}

/// A comment as printed: line comments lose trailing whitespace (a `\r`
/// before the newline included); block comments are kept byte for byte
/// except their line breaks, which become `\n` as everywhere in the
/// output (a CRLF file's block comment kept its `\r\n` among `\n`s).
pub(crate) fn comment_text(text: &str) -> std::borrow::Cow<'_, str> {
    if is_line_comment(text) {
        text.trim_end().into()
    } else if text.contains('\r') {
        text.replace("\r\n", "\n").replace('\r', "\n").into()
    } else {
        text.into()
    }
}

fn is_line_comment(text: &str) -> bool {
    text.starts_with("//")
}

/// One statement of a block.
#[derive(Clone, Copy)]
enum Stmt<'a> {
    Item(&'a Item),
    Sys(&'a SystemItem),
    Field(&'a Field),
}

impl Stmt<'_> {
    fn span(self) -> Span {
        match self {
            Stmt::Item(i) => i.span(),
            Stmt::Sys(i) => i.span(),
            Stmt::Field(f) => f.span,
        }
    }
}

/// Top-level item kinds, for the blank-line rule.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Kind {
    Import,
    Const,
    Param,
    Mesh,
    Block,
    Error,
}

fn kind(s: Stmt<'_>) -> Kind {
    match s {
        Stmt::Item(Item::Import(_)) => Kind::Import,
        Stmt::Item(Item::Const(_)) => Kind::Const,
        Stmt::Item(Item::Param(_)) => Kind::Param,
        Stmt::Item(Item::Mesh(_)) => Kind::Mesh,
        Stmt::Item(Item::Material(_) | Item::System(_) | Item::Layout(_)) => Kind::Block,
        Stmt::Item(Item::Error(_)) | Stmt::Sys(_) | Stmt::Field(_) => Kind::Error,
    }
}

/// A blank line always separates a system or material from its
/// neighbours, and declarations of different kinds from each other.
fn blank_forced(prev: Kind, next: Kind) -> bool {
    prev == Kind::Block || next == Kind::Block || prev != next
}

/// Where the block printer is.
struct BlockState {
    top: bool,
    /// Something was written in this block.
    wrote: bool,
    /// End of the last thing written (statement or comment) in the source.
    prev_end: u32,
    /// The last thing written was a standalone block comment: a comment
    /// right after it on the same source line stays on its line.
    join: bool,
    /// The kind of the last item written, if nothing but the item's trailing
    /// comments was written after it.
    after_item: Option<Kind>,
}

struct Printer<'a> {
    text: &'a str,
    toks: &'a [Tok],
    comments: &'a [Comment],
    /// Index of the first comment not yet written.
    next: usize,
    out: String,
    /// Indentation of the current block's statements.
    indent: usize,
    /// Indentation of a statement's continuation lines (after a line
    /// comment inside the statement).
    hang: usize,
    /// A space is due before the next token.
    space: bool,
    /// A block comment was just written inside a statement.
    after_comment: bool,
    /// The current output line holds nothing but indentation.
    line_empty: bool,
}

impl<'a> Printer<'a> {
    // ---- output primitives ------------------------------------------------

    fn nl(&mut self) {
        while self.out.ends_with(' ') {
            self.out.pop();
        }
        self.out.push('\n');
        self.line_empty = true;
        self.space = false;
        self.after_comment = false;
    }

    fn pad(&mut self, n: usize) {
        self.out.extend(std::iter::repeat_n(' ', n));
    }

    fn push(&mut self, s: &str) {
        if !s.is_empty() {
            self.out.push_str(s);
            self.line_empty = false;
        }
    }

    /// The column (in chars) the next character will be written at.
    fn column(&self) -> usize {
        let line = self.out.rsplit('\n').next().unwrap_or("");
        line.chars().count()
    }

    fn sp(&mut self) {
        self.space = true;
    }

    /// Write a token that stood at source offset `pos`, after the comments
    /// that came before it.
    fn word(&mut self, pos: u32, s: &str) {
        self.comments_before(pos);
        let closing = matches!(s, ")" | "," | ";");
        if !self.line_empty && (self.space || self.after_comment && !closing) {
            self.out.push(' ');
        }
        self.push(s);
        self.space = false;
        self.after_comment = false;
    }

    fn comments_before(&mut self, pos: u32) {
        while let Some(c) = self.comments.get(self.next) {
            if c.span.start >= pos {
                break;
            }
            self.next += 1;
            self.inline_comment(c);
        }
    }

    /// A comment inside a statement.
    fn inline_comment(&mut self, c: &Comment) {
        let t = comment_text(&c.text);
        // `f(/* a */ x)`, but `f( // a`.
        if !self.line_empty && (is_line_comment(&t) || !self.out.ends_with('(')) {
            self.out.push(' ');
        }
        self.push(&t);
        if is_line_comment(&t) {
            self.nl();
            self.pad(self.hang);
        } else {
            self.after_comment = true;
        }
        self.space = false;
    }

    /// The source text of a span ("" if the span is not in the text, which
    /// the parser never produces).
    fn src(&self, span: Span) -> &'a str {
        self.text.get(span.range()).unwrap_or("")
    }

    /// The start of the token `s` if it is the first token at or after
    /// `from`; else `from`. Used to place the unnamed tokens (`=`, `,`,
    /// `)`, ...), which directly follow the node before them.
    fn at(&self, from: u32, s: &str) -> u32 {
        let i = self.toks.partition_point(|t| t.span.start < from);
        match self.toks.get(i) {
            Some(t) if t.text(self.text) == s => t.span.start,
            _ => from,
        }
    }

    /// Copy a span verbatim (a statement the parser could not read); the
    /// comments in it are part of the copy.
    fn verbatim(&mut self, span: Span) {
        self.comments_before(span.start);
        let s = self.src(span);
        self.word(span.start, s);
        while self
            .comments
            .get(self.next)
            .is_some_and(|c| c.span.start < span.end)
        {
            self.next += 1;
        }
    }

    // ---- blocks -----------------------------------------------------------

    /// Print the statements of a block and the comments among them. `open`
    /// is the source offset just after the `{` (0 for the file), `close`
    /// the offset of the `}` (the text's length for the file). Returns
    /// whether anything was written.
    fn block(&mut self, stmts: &[Stmt<'_>], open: u32, close: u32, top: bool) -> bool {
        let mut st = BlockState {
            top,
            wrote: false,
            prev_end: open,
            join: false,
            after_item: None,
        };
        if !top {
            let bound = stmts.first().map_or(close, |s| s.span().start);
            self.trailing(&mut st, bound);
        }
        for (i, &stmt) in stmts.iter().enumerate() {
            let span = stmt.span();
            let next_kind = Some(kind(stmt));
            // Comments on lines of their own before the statement.
            while let Some(c) = self.comments.get(self.next) {
                if c.span.start >= span.start {
                    break;
                }
                let rest = self.text.get(c.span.end as usize..span.start as usize);
                if !rest.is_some_and(has_line_break) {
                    // On the statement's line: written inline before it.
                    break;
                }
                self.next += 1;
                self.standalone(&mut st, c, next_kind);
            }
            let first = match self.comments.get(self.next) {
                Some(c) if c.span.start < span.start => c.span.start,
                _ => span.start,
            };
            self.separate(&mut st, first, next_kind);
            self.hang = self.indent + INDENT;
            self.stmt(stmt);
            st.prev_end = span.end;
            st.after_item = Some(kind(stmt));
            st.join = false;
            let bound = stmts.get(i + 1).map_or(close, |s| s.span().start);
            self.trailing(&mut st, bound);
        }
        while let Some(c) = self.comments.get(self.next) {
            if c.span.start >= close {
                break;
            }
            self.next += 1;
            self.standalone(&mut st, c, None);
        }
        st.wrote
    }

    /// Comments on the same line after what was written last.
    fn trailing(&mut self, st: &mut BlockState, bound: u32) {
        while let Some(c) = self.comments.get(self.next) {
            if c.span.start >= bound {
                break;
            }
            let gap = self.text.get(st.prev_end as usize..c.span.start as usize);
            if gap.is_none_or(has_line_break) {
                break;
            }
            self.next += 1;
            self.out.push(' ');
            self.push(&comment_text(&c.text));
            st.prev_end = c.span.end;
            st.wrote = true;
        }
    }

    fn standalone(&mut self, st: &mut BlockState, c: &Comment, next_kind: Option<Kind>) {
        self.separate(st, c.span.start, next_kind);
        let t = comment_text(&c.text);
        self.push(&t);
        st.prev_end = c.span.end;
        st.join = !is_line_comment(&t);
        st.after_item = None;
    }

    /// Start a new entity (statement or standalone comment) whose source
    /// starts at `to`: a new line, a blank line, or (after a standalone block
    /// comment on the same source line) a space.
    fn separate(&mut self, st: &mut BlockState, to: u32, next_kind: Option<Kind>) {
        let gap = self
            .text
            .get(st.prev_end as usize..to as usize)
            .unwrap_or("\n");
        let newlines = count_line_breaks(gap);
        if !st.wrote {
            if !st.top {
                self.nl();
                self.pad(self.indent);
            }
        } else if st.join && newlines == 0 {
            self.out.push(' ');
        } else {
            let forced = st.top
                && match (st.after_item, next_kind) {
                    (Some(a), Some(b)) => blank_forced(a, b),
                    _ => false,
                };
            self.nl();
            if newlines >= 2 || forced {
                self.nl();
            }
            self.pad(self.indent);
        }
        st.wrote = true;
    }

    // ---- statements -------------------------------------------------------

    fn stmt(&mut self, s: Stmt<'_>) {
        match s {
            Stmt::Item(i) => self.item(i),
            Stmt::Sys(i) => self.sys_item(i),
            Stmt::Field(f) => self.field(f),
        }
    }

    /// `;` ending a statement whose span ends with it.
    fn semi(&mut self, span: Span) {
        self.word(span.end.saturating_sub(1), ";");
    }

    fn ident(&mut self, i: &Ident) {
        self.word(i.span.start, &i.name);
    }

    fn strlit(&mut self, s: &StrLit) {
        // As written: the escapes stay the user's.
        let text = self.src(s.span);
        if text.starts_with('"') {
            self.word(s.span.start, text);
        } else {
            let escaped = format!("\"{}\"", escape(&s.value));
            self.word(s.span.start, &escaped);
        }
    }

    /// `: type` after `after`.
    fn type_ann(&mut self, after: u32, ty: &Option<TypeAnn>) -> u32 {
        match ty {
            Some(t) => {
                self.word(self.at(after, ":"), ":");
                self.sp();
                self.ident(&t.name);
                t.name.span.end
            }
            None => after,
        }
    }

    fn item(&mut self, i: &Item) {
        match i {
            Item::Import(x) => {
                self.word(x.span.start, "import");
                self.sp();
                self.strlit(&x.path);
                self.semi(x.span);
            }
            Item::Const(c) => {
                self.word(c.span.start, "const");
                self.sp();
                self.ident(&c.name);
                let end = self.type_ann(c.name.span.end, &c.ty);
                self.sp();
                self.word(self.at(end, "="), "=");
                self.sp();
                self.expr(&c.value, 0);
                self.semi(c.span);
            }
            Item::Param(p) => {
                self.word(p.span.start, "param");
                self.sp();
                self.ident(&p.name);
                let end = self.type_ann(p.name.span.end, &p.ty);
                self.sp();
                self.word(self.at(end, "="), "=");
                self.sp();
                self.expr(&p.default, 0);
                if let Some((lo, hi)) = &p.range {
                    self.sp();
                    self.word(self.at(p.default.span.end, "in"), "in");
                    self.sp();
                    self.expr(lo, 0);
                    self.sp();
                    self.word(self.at(lo.span.end, ".."), "..");
                    self.sp();
                    self.expr(hi, 0);
                }
                self.semi(p.span);
            }
            Item::Mesh(m) => {
                self.word(m.span.start, "mesh");
                self.sp();
                self.ident(&m.name);
                self.sp();
                self.word(self.at(m.name.span.end, "="), "=");
                self.sp();
                self.strlit(&m.path);
                self.semi(m.span);
            }
            Item::Material(m) => {
                let stmts: Vec<Stmt<'_>> = m.fields.iter().map(Stmt::Field).collect();
                self.braced("material", m.span, &m.name, &stmts);
            }
            Item::System(s) => {
                let stmts: Vec<Stmt<'_>> = s.items.iter().map(Stmt::Sys).collect();
                self.braced("system", s.span, &s.name, &stmts);
            }
            Item::Layout(l) => {
                let stmts: Vec<Stmt<'_>> = l.fields.iter().map(Stmt::Field).collect();
                self.braced("layout", l.span, &l.name, &stmts);
            }
            Item::Error(span) => self.verbatim(*span),
        }
    }

    /// `KEYWORD NAME { statements }`.
    fn braced(&mut self, keyword: &str, span: Span, name: &Ident, stmts: &[Stmt<'_>]) {
        self.word(span.start, keyword);
        self.sp();
        self.ident(name);
        self.sp();
        let open = self.at(name.span.end, "{");
        self.word(open, "{");
        let close = if span.end > span.start && self.src(span).ends_with('}') {
            span.end - 1
        } else {
            span.end
        };
        self.indent += INDENT;
        let wrote = self.block(stmts, open.saturating_add(1).min(close), close, false);
        self.indent -= INDENT;
        if wrote {
            self.nl();
            self.pad(self.indent);
        }
        self.word(close, "}");
    }

    fn field(&mut self, f: &Field) {
        self.ident(&f.name);
        self.sp();
        self.word(self.at(f.name.span.end, "="), "=");
        self.sp();
        self.expr(&f.value, 0);
        self.semi(f.span);
    }

    fn sys_item(&mut self, i: &SystemItem) {
        match i {
            SystemItem::Axiom(a) => {
                self.word(a.span.start, "axiom");
                self.hang = self.column() + 1;
                self.modules(&a.modules);
                self.semi(a.span);
            }
            SystemItem::Setting(s) => {
                self.ident(&s.name);
                self.sp();
                self.word(self.at(s.name.span.end, "="), "=");
                self.sp();
                self.expr(&s.value, 0);
                self.semi(s.span);
            }
            SystemItem::Ignore(ig) => {
                self.word(ig.span.start, "ignore");
                for s in &ig.symbols {
                    self.sp();
                    self.word(s.span.start, &s.name);
                }
                self.semi(ig.span);
            }
            SystemItem::ModuleDecl(d) => {
                let kw = match d.phase {
                    Phase::None => "module",
                    Phase::Skeleton => "skeleton",
                    Phase::Geometry => "geometry",
                };
                self.word(d.keyword.start, kw);
                for (i, m) in d.modules.iter().enumerate() {
                    if i > 0 {
                        let prev = d.modules[i - 1].span.end;
                        self.word(self.at(prev, ","), ",");
                    }
                    self.sp();
                    self.module_sig(m);
                }
                self.semi(d.span);
            }
            SystemItem::Production(p) => self.production(p),
            SystemItem::Error(span) => self.verbatim(*span),
        }
    }

    fn module_sig(&mut self, m: &ModuleSig) {
        self.word(m.symbol.span.start, &m.symbol.name);
        if let Some(params) = &m.params {
            self.word(self.at(m.symbol.span.end, "("), "(");
            for (i, p) in params.iter().enumerate() {
                if i > 0 {
                    self.word(self.at(params[i - 1].span.end, ","), ",");
                    self.sp();
                }
                self.ident(&p.name);
                self.type_ann(p.name.span.end, &p.ty);
            }
            self.word(m.span.end.saturating_sub(1), ")");
        }
    }

    fn production(&mut self, p: &Production) {
        if p.wrapup {
            self.word(p.span.start, "wrapup");
            self.sp();
        }
        if let Some(last) = p.left.last() {
            for c in &p.left {
                self.ctx_item(c);
                self.sp();
            }
            self.word(self.at(last.span().end, "<"), "<");
            self.sp();
        }
        self.pattern(&p.pred);
        let mut end = p.pred.span.end;
        if let Some(last) = p.right.last() {
            self.sp();
            self.word(self.at(end, ">"), ">");
            for c in &p.right {
                self.sp();
                self.ctx_item(c);
            }
            end = last.span().end;
        }
        if let Some(cond) = &p.condition {
            self.sp();
            self.word(self.at(end, ":"), ":");
            self.sp();
            self.expr(cond, 0);
        }
        self.sp();
        self.word(p.arrow.start, "->");
        if let Some(w) = &p.weight {
            self.sp();
            self.word(self.at(p.arrow.end, "("), "(");
            self.expr(w, 0);
            self.word(self.at(w.span.end, ")"), ")");
        }
        // Continuation lines line up with the first successor module.
        self.hang = self.column() + 1;
        self.modules(&p.successor);
        if p.successor.is_empty() {
            // `A -> ;`: the empty successor is visible.
            self.sp();
        }
        self.semi(p.span);
    }

    fn ctx_item(&mut self, c: &ContextItem) {
        match c {
            ContextItem::Pattern(p) => self.pattern(p),
            ContextItem::Push(s) => self.word(s.start, "["),
            ContextItem::Pop(s) => self.word(s.start, "]"),
        }
    }

    fn pattern(&mut self, p: &Pattern) {
        self.word(p.symbol.span.start, &p.symbol.name);
        if !p.params.is_empty() {
            self.word(self.at(p.symbol.span.end, "("), "(");
            for (i, x) in p.params.iter().enumerate() {
                if i > 0 {
                    self.word(self.at(p.params[i - 1].span.end, ","), ",");
                    self.sp();
                }
                self.ident(x);
            }
            self.word(p.span.end.saturating_sub(1), ")");
        }
    }

    /// A module string, each module preceded by a space. A line break the
    /// text had between two modules is kept (the continuation lines up
    /// with `hang`).
    fn modules(&mut self, ms: &[Module]) {
        for (i, m) in ms.iter().enumerate() {
            if i > 0 {
                let gap = self
                    .text
                    .get(ms[i - 1].span.end as usize..m.span.start as usize);
                if gap.is_some_and(has_line_break) {
                    self.comments_before(m.span.start);
                    if !self.line_empty {
                        self.nl();
                        self.pad(self.hang);
                    }
                }
            }
            self.sp();
            self.word(m.symbol.span.start, &m.symbol.name);
            if !m.args.is_empty() || m.parts.is_some() {
                self.word(self.at(m.symbol.span.end, "("), "(");
                self.args(&m.args);
                let close = match &m.parts {
                    None => m.span.end.saturating_sub(1),
                    Some(_) => {
                        self.at(m.args.last().map_or(m.symbol.span.end, |a| a.span.end), ")")
                    }
                };
                self.word(close, ")");
            }
            if let Some(parts) = &m.parts {
                self.parts(parts);
            }
        }
    }

    /// A shape command's parts, ` { 4: Ground | ~3.5: Floor }`, on one
    /// line; when the text broke the block across lines, one part a line,
    /// the bars lined up under the statement's first indent step:
    ///
    /// ```text
    /// Mass -> comp(faces) {
    ///       front: Facade
    ///     | side: Wall
    /// };
    /// ```
    fn parts(&mut self, parts: &ShapeParts) {
        let multi = self
            .text
            .get(parts.span.range())
            .is_some_and(has_line_break);
        self.sp();
        self.word(parts.span.start, "{");
        for (i, p) in parts.parts.iter().enumerate() {
            if i > 0 {
                let bar = self.at(parts.parts[i - 1].span.end, "|");
                if multi {
                    self.comments_before(bar);
                    if !self.line_empty {
                        self.nl();
                    }
                    self.pad(self.indent + INDENT);
                }
                self.sp();
                self.word(bar, "|");
            } else if multi {
                self.comments_before(p.span.start);
                if !self.line_empty {
                    self.nl();
                }
                self.pad(self.indent + INDENT + 2);
            }
            self.sp();
            match p.kind {
                PartKind::Absolute => self.expr(&p.value, 0),
                PartKind::Relative => {
                    self.expr(&p.value, 0);
                    self.word(self.at(p.value.span.end, "%"), "%");
                }
                PartKind::Floating => {
                    self.word(p.span.start, "~");
                    self.expr(&p.value, 0);
                }
            }
            self.word(self.at(p.value.span.end, ":"), ":");
            self.sp();
            self.word(p.target.span.start, &p.target.name);
        }
        let close = parts.span.end.saturating_sub(1);
        if multi {
            self.comments_before(close);
            if !self.line_empty {
                self.nl();
            }
            self.pad(self.indent);
        } else {
            self.sp();
        }
        self.word(close, "}");
    }

    /// Comma-separated expressions (the parentheses are the caller's).
    fn args(&mut self, args: &[Expr]) {
        for (i, a) in args.iter().enumerate() {
            if i > 0 {
                self.word(self.at(args[i - 1].span.end, ","), ",");
                self.sp();
            }
            self.expr(a, 0);
        }
    }

    // ---- expressions ------------------------------------------------------

    /// Print `e` where an expression binding at least as tightly as `min`
    /// is expected (see [`level`]); parenthesize it if it binds looser
    /// (never the case for a tree from the parser).
    fn expr(&mut self, e: &Expr, min: u8) {
        let wrap = level(e) < min;
        if wrap {
            self.word(e.span.start, "(");
        }
        match &e.kind {
            ExprKind::Number { text, .. } => self.word(e.span.start, text),
            ExprKind::Bool(b) => self.word(e.span.start, if *b { "true" } else { "false" }),
            ExprKind::Str(value) => self.strlit(&grm_syntax::ast::StrLit {
                value: value.clone(),
                span: e.span,
            }),
            ExprKind::Name(n) => self.ident(n),
            ExprKind::Call { func, args } => {
                self.ident(func);
                self.word(self.at(func.span.end, "("), "(");
                self.args(args);
                self.word(e.span.end.saturating_sub(1), ")");
            }
            ExprKind::Unary { op, operand } => {
                self.word(e.span.start, op.as_str());
                self.expr(operand, UNARY);
            }
            ExprKind::Binary { op, lhs, rhs } => {
                let p = op.precedence();
                // Left-associative: the right operand must bind tighter.
                self.expr(lhs, p);
                self.sp();
                self.word(self.at(lhs.span.end, op.as_str()), op.as_str());
                self.sp();
                self.expr(rhs, p + 1);
            }
            ExprKind::Field { base, field } => {
                self.expr(base, POSTFIX);
                self.word(self.at(base.span.end, "."), ".");
                self.ident(field);
            }
            ExprKind::If { cond, then, els } => {
                self.word(e.span.start, "if");
                self.sp();
                self.expr(cond, 0);
                self.sp();
                self.word(self.at(cond.span.end, "then"), "then");
                self.sp();
                self.expr(then, 0);
                self.sp();
                self.word(self.at(then.span.end, "else"), "else");
                self.sp();
                self.expr(els, 0);
            }
            ExprKind::Paren(inner) => {
                self.word(e.span.start, "(");
                self.expr(inner, 0);
                self.word(e.span.end.saturating_sub(1), ")");
            }
            ExprKind::Error => self.verbatim(e.span),
        }
        if wrap {
            self.word(e.span.end, ")");
        }
    }
}

/// Binding strength of unary operators (tighter than every binary one).
const UNARY: u8 = 7;
/// Binding strength of field access.
const POSTFIX: u8 = 8;
/// Binding strength of atoms (literals, names, calls, parentheses).
const ATOM: u8 = 9;

/// How tightly an expression binds: `if` 0, binary operators their
/// precedence (1..=6), then unary, postfix and atoms.
fn level(e: &Expr) -> u8 {
    match &e.kind {
        ExprKind::If { .. } => 0,
        ExprKind::Binary { op, .. } => op.precedence(),
        ExprKind::Unary { .. } => UNARY,
        ExprKind::Field { .. } => POSTFIX,
        ExprKind::Number { .. }
        | ExprKind::Bool(_)
        | ExprKind::Str(_)
        | ExprKind::Name(_)
        | ExprKind::Call { .. }
        | ExprKind::Paren(_)
        | ExprKind::Error => ATOM,
    }
}

/// Escape a string value for a literal (only for a literal whose source text
/// is unavailable).
fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\t' => out.push_str("\\t"),
            c => out.push(c),
        }
    }
    out
}

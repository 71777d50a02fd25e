//! The parser driver: reads the block structure of a file by hand and hands
//! each statement to the lalrpop grammar (`grammar/grm.lalrpop`).
//!
//! Recovery rules (each costs exactly one diagnostic):
//! - a statement the grammar rejects becomes an `Error` item spanning the
//!   statement; parsing resumes after its `;`;
//! - a statement missing its `;` before `}`, before the next top-level
//!   keyword, at the end of the file, or before a line that starts a new
//!   statement is kept, and the missing `;` is reported;
//! - text between top-level items that starts no item is skipped up to the
//!   next top-level keyword;
//! - a `system` or `material` left open at the end of the file (or at the
//!   next top-level keyword) is closed there.

use crate::ast::*;
use crate::grm;
use crate::lexer::{self, Tok, TokKind, Token, starts_item_at};
use grm_diag::{Code, Diagnostic, FileId};
use lalrpop_util::ParseError;

mod errors;
mod recovery;
use errors::*;
use recovery::*;

/// The result of parsing one file. Parsing never fails.
#[derive(Clone, Debug)]
pub struct Parsed {
    pub file: File,
    pub comments: Vec<Comment>,
    /// Lexical and syntax diagnostics, in source order.
    pub diagnostics: Vec<Diagnostic>,
}

impl Parsed {
    pub fn has_errors(&self) -> bool {
        self.diagnostics.iter().any(Diagnostic::is_error)
    }
}

/// Parse a whole file.
pub fn parse(file: FileId, text: &str) -> Parsed {
    let mut items = Vec::new();
    let (comments, diagnostics) = parse_items(file, text, &mut |i| items.push(i));
    Parsed {
        file: File {
            items: shrink(items),
            span: Span::from_range(0..text.len()),
        },
        comments,
        diagnostics,
    }
}

/// [`parse`], each top-level item given to `sink` as it is read. Returns
/// the comments and the diagnostics (sorted). Not public: a sink runs
/// while the file's tokens are still held, so a reader that keeps only
/// one item at a time gained little on real files and lost on a file of
/// one large item (the tokens beside it; issue 32).
fn parse_items(
    file: FileId,
    text: &str,
    sink: &mut dyn FnMut(Item),
) -> (Vec<Comment>, Vec<Diagnostic>) {
    let mut lexed = lexer::lex_toks(file, text);
    let mut diags = std::mem::take(&mut lexed.diagnostics);
    misspelt_item_keywords(file, text, &mut lexed.tokens, &mut diags);
    let mut p = Driver {
        file,
        text,
        toks: &lexed.tokens,
        pos: 0,
        diags,
        hoisted: Vec::new(),
    };
    p.items(sink);
    let mut diagnostics = p.diags;
    grm_diag::sort(&mut diagnostics);
    (lexed.comments, diagnostics)
}

/// Parse a lone expression (for tests and tools). Returns `None` with
/// diagnostics when the text is not exactly one expression, or one nested
/// deeper than [`MAX_EXPR_DEPTH`].
pub fn parse_expr(file: FileId, text: &str) -> (Option<Expr>, Vec<Diagnostic>) {
    let lexed = lexer::lex(file, text);
    let mut diags = lexed.diagnostics;
    let mut errs = Vec::new();
    let res = grm::ExprOnlyParser::new().parse(&mut errs, stream(&lexed.tokens));
    push_value_errors(file, &mut diags, errs);
    match res {
        Ok(e) => {
            let Some(at) = too_deep_at(&e) else {
                return (Some(e), diags);
            };
            diags.push(expr_too_deep(file, at));
            (None, diags)
        }
        Err(e) => {
            diags.push(syntax_error(file, text, e, None));
            (None, diags)
        }
    }
}

// ---- helpers used by the generated grammar ---------------------------------

pub(crate) fn sp(l: usize, r: usize) -> Span {
    Span::from_range(l..r)
}

pub(crate) fn sym(text: &str, l: usize, r: usize) -> Symbol {
    Symbol {
        name: text.into(),
        span: sp(l, r),
    }
}

/// A list at its length: lists grown by pushes hold up to twice their
/// length (four elements for one), most of a large file's syntax tree.
pub(crate) fn shrink<T>(mut v: Vec<T>) -> Vec<T> {
    v.shrink_to_fit();
    v
}

/// Parse a number literal; out-of-range literals are reported.
pub(crate) fn number(text: &str) -> (f64, Option<String>) {
    let well_formed = text
        .bytes()
        .all(|b| b.is_ascii_digit() || matches!(b, b'.' | b'e' | b'E' | b'+' | b'-'));
    match text.parse::<f64>() {
        // Any literal that rounds to a finite 32-bit float (`3.4028235e38`,
        // how f32::MAX prints, is just above it and rounds down to it).
        Ok(v) if (v as f32).is_finite() => (v, None),
        Err(_) if !well_formed => (
            0.0,
            Some(format!(
                "`{text}` is not a number: a number is digits with an optional fraction and exponent (`1.5e3`)"
            )),
        ),
        Err(_) => (
            0.0,
            Some(format!(
                "`{text}` is not a number: an exponent needs digits (`1e3`, `2.5e-4`)"
            )),
        ),
        Ok(_) => (
            0.0,
            Some(format!(
                "number literal `{text}` does not fit in a 32-bit float"
            )),
        ),
    }
}

/// The content of a string literal token (quotes removed, `\"`, `\\`, `\n`
/// and `\t` unescaped; an unterminated string has no closing quote).
pub(crate) fn string_value(text: &str) -> String {
    let inner = text.strip_prefix('"').unwrap_or(text);
    let inner = inner.strip_suffix('"').unwrap_or(inner);
    let mut out = String::with_capacity(inner.len());
    let mut chars = inner.chars();
    while let Some(c) = chars.next() {
        if c == '\\' {
            match chars.next() {
                Some('n') => out.push('\n'),
                Some('t') => out.push('\t'),
                Some(o) => out.push(o),
                None => out.push('\\'),
            }
        } else {
            out.push(c);
        }
    }
    out
}

/// Build a left-associative binary tree from `first (op operand)*` by
/// precedence climbing (higher [`BinaryOp::precedence`] binds tighter).
pub(crate) fn climb(first: Expr, rest: Vec<(BinaryOp, Expr)>) -> Expr {
    if rest.is_empty() {
        return first;
    }
    let mut items = rest.into_iter().peekable();
    climb_from(first, &mut items, 0)
}

fn climb_from(
    mut lhs: Expr,
    items: &mut std::iter::Peekable<std::vec::IntoIter<(BinaryOp, Expr)>>,
    min_prec: u8,
) -> Expr {
    while let Some(&(op, _)) = items.peek() {
        if op.precedence() < min_prec {
            break;
        }
        // `peek` just returned an item.
        let Some((op, mut rhs)) = items.next() else {
            break;
        };
        while let Some(&(next, _)) = items.peek() {
            if next.precedence() <= op.precedence() {
                break;
            }
            rhs = climb_from(rhs, items, op.precedence() + 1);
        }
        let span = lhs.span.to(rhs.span);
        lhs = Expr {
            kind: ExprKind::Binary {
                op,
                lhs: Box::new(lhs),
                rhs: Box::new(rhs),
            },
            span,
        };
    }
    lhs
}

// ---- the driver ---------------------------------------------------------------

type Spanned<'a> = Result<(usize, Token<'a>, usize), ()>;

/// A statement's compact tokens as the grammar reads them, each given its
/// text on the way (no copy of the statement with its text: a statement
/// can be most of a file).
fn stream_toks<'a, 'b>(toks: &'b [Tok], text: &'a str) -> impl Iterator<Item = Spanned<'a>> + 'b
where
    'a: 'b,
{
    toks.iter().map(move |&t| {
        let t = with_text(t, text);
        Ok((t.span.start as usize, t, t.span.end as usize))
    })
}

/// A compact token with its text; a `;` the driver added (an empty span)
/// reads `;`.
fn with_text(t: Tok, text: &str) -> Token<'_> {
    if t.kind == TokKind::Semi && t.span.start == t.span.end {
        Token {
            kind: t.kind,
            text: ";",
            span: t.span,
        }
    } else {
        t.with_text(text)
    }
}

fn stream<'a, 'b>(toks: &'b [Token<'a>]) -> impl Iterator<Item = Spanned<'a>> + 'b {
    toks.iter()
        .map(|t| Ok((t.span.start as usize, *t, t.span.end as usize)))
}

fn push_value_errors(file: FileId, diags: &mut Vec<Diagnostic>, errs: Vec<(Span, String)>) {
    for (span, msg) in errs {
        let label = if msg.contains("does not fit") {
            "out of range"
        } else {
            "malformed"
        };
        diags.push(Diagnostic::new(Code::InvalidNumber, msg, file, span, label));
    }
}

/// Which grammar entry point a statement goes to.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Entry {
    Top,
    Sys,
    Mat,
}

enum Stmt {
    Item(Item),
    SysItem(SystemItem),
    Field(Field),
}

struct Driver<'a, 't> {
    file: FileId,
    text: &'a str,
    /// The file's tokens; each statement's are given their text
    /// ([`Driver::take_stmt`]) only for its own parse.
    toks: &'t [Tok],
    pos: usize,
    diags: Vec<Diagnostic>,
    /// Top-level declarations written inside a system block (E0007): kept
    /// as items of the file, so the names they define still resolve and
    /// their uses are not reported again.
    hoisted: Vec<Item>,
}

impl<'a, 't> Driver<'a, 't> {
    fn peek(&self) -> Option<&Tok> {
        self.toks.get(self.pos)
    }

    /// The tokens from `self.pos` up to `end`, and move past them.
    fn take_stmt(&mut self, end: usize) -> &'t [Tok] {
        let all = self.toks;
        let toks = &all[self.pos..end];
        self.pos = end;
        toks
    }

    fn peek_kind(&self) -> Option<TokKind> {
        self.peek().map(|t| t.kind)
    }

    fn eof_span(&self) -> Span {
        let n = self.text.len() as u32;
        Span::new(n, n)
    }

    /// Each top-level item, in order, to `sink`.
    fn items(&mut self, sink: &mut dyn FnMut(Item)) {
        while let Some(t) = self.peek().copied() {
            match t.kind {
                TokKind::Import | TokKind::Const | TokKind::Param | TokKind::Mesh => {
                    let end = self.stmt_end(false);
                    let toks = self.take_stmt(end);
                    for s in self.statement(toks, Entry::Top) {
                        if let Stmt::Item(i) = s {
                            sink(i);
                        }
                    }
                }
                TokKind::System => {
                    let system = self.system();
                    sink(system);
                    for i in std::mem::take(&mut self.hoisted) {
                        sink(i);
                    }
                }
                TokKind::Material => {
                    let material = self.material();
                    sink(material);
                }
                TokKind::Ident if self.layout_at(self.pos) => {
                    let layout = self.layout();
                    sink(layout);
                }
                _ => {
                    // Garbage between items: skip to the next item keyword at
                    // brace depth 0, one diagnostic for the whole run.
                    let start = self.pos;
                    let mut depth = 0i32;
                    while let Some(k) = self.peek_kind() {
                        if depth <= 0
                            && (starts_item_at(self.toks, self.pos) || self.layout_at(self.pos))
                            && self.pos > start
                        {
                            break;
                        }
                        match k {
                            TokKind::LBrace => depth += 1,
                            TokKind::RBrace => depth -= 1,
                            _ => {}
                        }
                        self.pos += 1;
                    }
                    let last = self.toks[self.pos - 1].span;
                    let span = t.span.to(last);
                    let mut d = Diagnostic::new(
                        Code::UnexpectedToken,
                        match t.kind {
                            TokKind::Ident => {
                                format!("expected an item, found `{}`", t.text(self.text))
                            }
                            k => format!("expected an item, found {}", k.describe()),
                        },
                        self.file,
                        t.span,
                        "items start with `system`, `const`, `param`, `mesh`, `material`, `layout` or `import`",
                    );
                    match (t.kind == TokKind::Ident)
                        .then(|| item_keyword_for(t.text(self.text)))
                        .flatten()
                    {
                        Some(kw) => d = d.with_help(format!("did you mean `{kw}`?")),
                        None => {
                            d = d.with_note(
                                "productions and settings go inside a `system NAME { ... }` block",
                            )
                        }
                    }
                    self.diags.push(d);
                    sink(Item::Error(span));
                }
            }
        }
    }

    /// Index one past the end of the statement starting at `self.pos`: after
    /// its `;`, or before a `}` / top-level keyword / EOF that ends it early.
    fn stmt_end(&self, in_block: bool) -> usize {
        let mut i = self.pos;
        let mut first = true;
        while let Some(t) = self.toks.get(i) {
            match t.kind {
                TokKind::Semi => return i + 1,
                TokKind::RBrace if in_block => return i,
                // `mesh`/`material` are also terminals inside module strings
                // (`mesh(leaf)`); they start an item only as `mesh NAME =`.
                // A keyword in a declaration's name place (`const system =
                // 1;`) is a misused name, not the next item.
                _ if !first
                    && (starts_item_at(self.toks, i) && !self.keyword_as_name(i)
                        || !in_block && self.layout_at(i)) =>
                {
                    return i;
                }
                _ => {}
            }
            first = false;
            i += 1;
        }
        i
    }

    /// Whether token `i` is a keyword written where the declaration
    /// starting just before it names what it declares: `const system = 1;`.
    fn keyword_as_name(&self, i: usize) -> bool {
        let kind = |j: usize| self.toks.get(j).map(|t| t.kind);
        i == self.pos + 1
            && matches!(kind(self.pos), Some(TokKind::Const | TokKind::Param))
            && kind(i).is_some_and(TokKind::starts_top_item)
            && kind(i + 1) == Some(TokKind::Assign)
    }

    /// Parse one statement (tokens up to and including `;` if present).
    /// May yield two statements when a missing `;` is repaired.
    fn statement(&mut self, toks: &[Tok], entry: Entry) -> Vec<Stmt> {
        if toks.is_empty() {
            return Vec::new();
        }
        // `const system = 1;`: one diagnostic saying so (the grammar would
        // only say it expected a name).
        if toks.len() >= 2
            && matches!(toks[0].kind, TokKind::Const | TokKind::Param)
            && (toks[1].kind.starts_top_item()
                || toks[1].kind.is_keyword()
                    && toks.get(2).is_some_and(|t| t.kind == TokKind::Assign))
        {
            let what = if toks[0].kind == TokKind::Const {
                "a constant"
            } else {
                "a parameter"
            };
            self.diags.push(
                Diagnostic::new(
                    Code::UnexpectedToken,
                    format!(
                        "`{}` is a keyword: it cannot name {what}",
                        toks[1].text(self.text)
                    ),
                    self.file,
                    toks[1].span,
                    "a keyword here",
                )
                .with_help(format!(
                    "choose another name, e.g. `{}_`",
                    toks[1].text(self.text)
                )),
            );
            let span = toks[0].span.to(toks[toks.len() - 1].span);
            return vec![match entry {
                Entry::Top => Stmt::Item(Item::Error(span)),
                Entry::Sys => Stmt::SysItem(SystemItem::Error(span)),
                Entry::Mat => return Vec::new(),
            }];
        }
        let terminated = toks.last().is_some_and(|t| t.kind == TokKind::Semi);
        let mut owned;
        let full: &[Tok] = if terminated {
            toks
        } else {
            owned = toks.to_vec();
            let end = toks[toks.len() - 1].span.end;
            owned.push(Tok {
                kind: TokKind::Semi,
                span: Span::new(end, end),
            });
            &owned
        };
        match self.run(full, entry) {
            Ok((stmt, errs)) => {
                push_value_errors(self.file, &mut self.diags, errs);
                let stmt = self.depth_guard(stmt);
                if !terminated {
                    self.missing_semi(toks[toks.len() - 1].span);
                }
                vec![stmt]
            }
            Err(err) => {
                // Maybe a `;` is missing at a line break before the error
                // (at several, one statement per line): try splitting there.
                if let Some(parts) = self.repair(full, err.clone(), entry) {
                    let mut out = Vec::with_capacity(parts.len());
                    let last = parts.len() - 1;
                    for (k, (stmt, errs, semi_after)) in parts.into_iter().enumerate() {
                        push_value_errors(self.file, &mut self.diags, errs);
                        if let Some(at) = semi_after {
                            self.missing_semi(at);
                        }
                        // The last one lacks its `;` too when the
                        // statement ended at `}` or the next item.
                        if k == last && !terminated {
                            self.missing_semi(toks[toks.len() - 1].span);
                        }
                        out.push(self.depth_guard(stmt));
                    }
                    return out;
                }
                // At an unterminated string the lexer's E0004 is the
                // mistake (its missing quote took the rest of the line).
                let at_open_string = matches!(
                    &err,
                    ParseError::UnrecognizedToken { token: (_, t, _), .. }
                        if t.kind == TokKind::Str && !(t.text.len() >= 2 && t.text.ends_with('"'))
                );
                // The statement with its text, for the messages.
                let text = self.text;
                let toks: Vec<Token<'a>> = toks.iter().map(|&t| with_text(t, text)).collect();
                let d = syntax_error(self.file, self.text, err, Some(&toks));
                if !at_open_string {
                    self.diags.push(d);
                }
                if entry == Entry::Top
                    && let Some(item) = recover_decl(&toks)
                {
                    return vec![Stmt::Item(item)];
                }
                let span = toks[0].span.to(toks[toks.len() - 1].span);
                vec![match entry {
                    Entry::Top => Stmt::Item(Item::Error(span)),
                    Entry::Sys => Stmt::SysItem(SystemItem::Error(span)),
                    Entry::Mat => return Vec::new(),
                }]
            }
        }
    }

    /// Replace each expression of a statement that nests deeper than
    /// [`MAX_EXPR_DEPTH`] by an `Error` expression over the same text, and
    /// report it (E0211): every later phase walks expressions recursively
    /// (only dropping one is safe: `Expr` drops without recursion). The
    /// statement itself stays, so the name it defines is still known and
    /// its uses are not reported again.
    fn depth_guard(&mut self, mut stmt: Stmt) -> Stmt {
        for e in stmt_exprs_mut(&mut stmt) {
            if let Some(at) = too_deep_at(e) {
                self.diags.push(expr_too_deep(self.file, at));
                let error = Expr {
                    kind: ExprKind::Error,
                    span: e.span,
                };
                // `Expr` drops without recursion.
                drop(std::mem::replace(e, error));
            }
        }
        stmt
    }

    fn missing_semi(&mut self, after: Span) {
        let mut d = Diagnostic::new(
            Code::UnexpectedToken,
            "expected `;`",
            self.file,
            Span::new(after.end, after.end),
            "add `;` here",
        )
        .with_help("every statement ends with `;`");
        // ABoP writes two roll-right turns as `//`: here that starts a
        // comment, which hides the rest of the line (its `;` included).
        let rest = &self.text[after.end as usize..];
        let line = &rest[..grm_diag::first_line_len(rest)];
        if line.trim_start().starts_with("//") {
            d = d.with_note(
                "`//` starts a comment, which runs to the end of the line; two roll-right turns are written `/ /`",
            );
        }
        self.diags.push(d);
    }

    /// Split `full` (which fails with `err`) into statements at line breaks
    /// where a `;` is missing: each piece before a split must parse with a
    /// `;` added; the rest is split again until it parses. The pieces with
    /// their value errors and the token after which a `;` is missing, or
    /// `None` when no such split explains the error.
    #[allow(clippy::type_complexity)]
    fn repair(
        &self,
        full: &[Tok],
        mut err: ParseError<usize, Token<'a>, ()>,
        entry: Entry,
    ) -> Option<Vec<(Stmt, Vec<(Span, String)>, Option<Span>)>> {
        /// Missing `;`s repaired in one statement at most.
        const MAX_SPLITS: usize = 64;
        let mut parts = Vec::new();
        let mut rest = full;
        for _ in 0..MAX_SPLITS {
            let split = self.split_point(rest, &err)?;
            let mut head = rest[..split].to_vec();
            let after = rest[split - 1].span;
            head.push(Tok {
                kind: TokKind::Semi,
                span: Span::new(after.end, after.end),
            });
            let (stmt, errs) = self.run(&head, entry).ok()?;
            parts.push((stmt, errs, Some(after)));
            rest = &rest[split..];
            match self.run(rest, entry) {
                Ok((stmt, errs)) => {
                    parts.push((stmt, errs, None));
                    return Some(parts);
                }
                Err(e) => err = e,
            }
        }
        None
    }

    /// The index of the first token of the last line break at or before
    /// the error token, if the error is past the first line of the statement.
    fn split_point(&self, toks: &[Tok], err: &ParseError<usize, Token<'a>, ()>) -> Option<usize> {
        let at = match err {
            ParseError::UnrecognizedToken {
                token: (l, _, _), ..
            }
            | ParseError::ExtraToken { token: (l, _, _) } => *l,
            _ => return None,
        };
        let err_idx = toks.iter().position(|t| t.span.start as usize >= at)?;
        (1..=err_idx).rev().find(|&j| {
            let gap = &self.text[toks[j - 1].span.end as usize..toks[j].span.start as usize];
            grm_diag::has_line_break(gap)
        })
    }

    #[allow(clippy::type_complexity)]
    fn run(
        &self,
        toks: &[Tok],
        entry: Entry,
    ) -> Result<(Stmt, Vec<(Span, String)>), ParseError<usize, Token<'a>, ()>> {
        let mut errs = Vec::new();
        let text = self.text;
        let stmt = match entry {
            Entry::Top => {
                Stmt::Item(*grm::TopDeclParser::new().parse(&mut errs, stream_toks(toks, text))?)
            }
            Entry::Sys => {
                Stmt::SysItem(*grm::SysStmtParser::new().parse(&mut errs, stream_toks(toks, text))?)
            }
            Entry::Mat => {
                Stmt::Field(grm::MatFieldParser::new().parse(&mut errs, stream_toks(toks, text))?)
            }
        };
        Ok((stmt, errs))
    }

    /// `KEYWORD NAME {` — returns the name and whether the brace was found.
    fn block_header(&mut self, what: &str) -> (Ident, bool) {
        let kw = self.toks[self.pos];
        self.pos += 1;
        let name = match self.peek().copied() {
            Some(t) if t.kind == TokKind::Ident => {
                self.pos += 1;
                Ident {
                    name: t.text(self.text).into(),
                    span: t.span,
                }
            }
            other => {
                let (span, found) = match other {
                    Some(t) => (t.span, t.kind.describe()),
                    None => (self.eof_span(), "end of file"),
                };
                let code = if other.is_none() {
                    Code::UnexpectedEof
                } else {
                    Code::UnexpectedToken
                };
                self.diags.push(
                    Diagnostic::new(
                        code,
                        format!("expected a {what} name, found {found}"),
                        self.file,
                        span,
                        "name expected here",
                    )
                    .with_label(
                        self.file,
                        kw.span,
                        format!("this {what} needs a name"),
                    ),
                );
                // `system if { ... }`: the token in the name's place is
                // taken for the (missing) name, and the block is read.
                if let Some(t) = other
                    && t.kind != TokKind::LBrace
                    && self.toks.get(self.pos + 1).map(|n| n.kind) == Some(TokKind::LBrace)
                {
                    self.pos += 1;
                }
                Ident {
                    name: Name::default(),
                    span: Span::new(kw.span.end, kw.span.end),
                }
            }
        };
        match self.peek().copied() {
            Some(t) if t.kind == TokKind::LBrace => {
                self.pos += 1;
                (name, true)
            }
            _ if name.name.is_empty() => {
                // No name and no block: one mistake, already reported;
                // what follows up to the next item is skipped unreported.
                while self.peek_kind().is_some() && !starts_item_at(self.toks, self.pos) {
                    self.pos += 1;
                }
                (name, false)
            }
            other => {
                let (span, found) = match other {
                    Some(t) => (t.span, t.kind.describe()),
                    None => (self.eof_span(), "end of file"),
                };
                let code = if other.is_none() {
                    Code::UnexpectedEof
                } else {
                    Code::UnexpectedToken
                };
                self.diags.push(Diagnostic::new(
                    code,
                    format!("expected `{{` after the {what} name, found {found}"),
                    self.file,
                    span,
                    "`{` expected here",
                ));
                (name, false)
            }
        }
    }

    /// After the block's items: consume `}` or report the unclosed block.
    fn block_close(&mut self, open: Span, what: &str) -> Span {
        match self.peek().copied() {
            Some(t) if t.kind == TokKind::RBrace => {
                self.pos += 1;
                t.span
            }
            other => {
                // The token the block should have closed before (a
                // zero-width span at a line start renders on the line above).
                let span = other.map(|t| t.span).unwrap_or(self.eof_span());
                let code = if other.is_none() {
                    Code::UnexpectedEof
                } else {
                    Code::UnexpectedToken
                };
                self.diags.push(
                    Diagnostic::new(
                        code,
                        format!("this {what} is not closed"),
                        self.file,
                        open,
                        "opened here",
                    )
                    .with_label(self.file, span, "expected `}` before this")
                    .with_help("add `}` at the end of the block"),
                );
                Span::new(span.start, span.start)
            }
        }
    }

    fn system(&mut self) -> Item {
        let start = self.toks[self.pos].span;
        let (name, braced) = self.block_header("system");
        let mut items = Vec::new();
        if braced {
            while let Some(k) = self.peek_kind() {
                if k == TokKind::RBrace {
                    break;
                }
                let decl = starts_item_at(self.toks, self.pos);
                if decl {
                    // A declaration inside the block: if the block still
                    // closes after it, it was written inside by mistake
                    // (one E0007); otherwise the block was left open.
                    if k != TokKind::System && self.block_closes_after(self.pos) {
                        self.hoist(&name);
                        continue;
                    }
                    break;
                }
                let end = self.stmt_end(true).max(self.pos + 1);
                let toks = self.take_stmt(end);
                let relabelled =
                    misspelt_statement_keyword(self.file, self.text, toks, &mut self.diags);
                for s in self.statement(relabelled.as_deref().unwrap_or(toks), Entry::Sys) {
                    if let Stmt::SysItem(i) = s {
                        items.push(i);
                    }
                }
            }
        }
        let close = if braced {
            self.block_close(start, "system")
        } else {
            name.span
        };
        Item::System(System {
            name,
            items: shrink(items),
            span: start.to(close),
        })
    }

    /// Whether, scanning on from token `i`, a `}` closes the enclosing block
    /// before the next `system` or the end of the file (braces of blocks in
    /// between, a `material`'s, are balanced on the way).
    fn block_closes_after(&self, i: usize) -> bool {
        let mut depth = 0i32;
        for t in &self.toks[i..] {
            match t.kind {
                TokKind::LBrace => depth += 1,
                TokKind::RBrace if depth == 0 => return true,
                TokKind::RBrace => depth -= 1,
                TokKind::System => return false,
                _ => {}
            }
        }
        false
    }

    /// Parse the top-level declaration at `self.pos`, found inside `system`,
    /// report it (E0007) and keep it as an item of the file.
    fn hoist(&mut self, system: &Ident) {
        let kw = self.toks[self.pos];
        let what = kw.text(self.text);
        let before = self.diags.len();
        if kw.kind == TokKind::Material {
            let item = self.material();
            self.hoisted.push(item);
        } else {
            let end = self.stmt_end(true).max(self.pos + 1);
            let toks = self.take_stmt(end);
            for s in self.statement(toks, Entry::Top) {
                if let Stmt::Item(i) = s {
                    self.hoisted.push(i);
                }
            }
        }
        let (kind, scope) = match kw.kind {
            TokKind::Param => ("parameters", "every system of the file"),
            TokKind::Const => ("constants", "every system of the file"),
            TokKind::Material => ("materials", "every system of the file"),
            TokKind::Mesh => ("meshes", "every system of the file"),
            _ => ("imports", "the whole file"),
        };
        let header = if system.name.is_empty() {
            "system NAME {".to_string()
        } else {
            format!("system {} {{", system.name)
        };
        let d = Diagnostic::new(
            Code::DeclInsideSystem,
            format!("`{what}` declarations go at the top level, not inside a system"),
            self.file,
            kw.span,
            format!("`{what}` inside a system"),
        )
        .with_help(format!(
            "move it above `{header}`: {kind} are declared once and seen by {scope}"
        ));
        // Source order: before any error inside the declaration itself.
        self.diags.insert(before, d);
    }

    /// Whether token `i` starts a `layout NAME {` item. `layout` is a
    /// keyword only there (a contextual keyword): anywhere else it is a
    /// name, so grammars that use it as one keep their meaning.
    fn layout_at(&self, i: usize) -> bool {
        let kind = |j: usize| self.toks.get(j).map(|t| t.kind);
        kind(i) == Some(TokKind::Ident)
            && self.toks[i].text(self.text) == "layout"
            && kind(i + 1) == Some(TokKind::Ident)
            && kind(i + 2) == Some(TokKind::LBrace)
    }

    /// `layout NAME { key = expr; ... }` (docs/layout.md): its fields are
    /// read as a material's are; the checker gives them their meaning.
    fn layout(&mut self) -> Item {
        let (name, fields, span) = self.field_block("layout", true);
        Item::Layout(LayoutDecl { name, fields, span })
    }

    fn material(&mut self) -> Item {
        let (name, fields, span) = self.field_block("material", false);
        Item::Material(MaterialDecl { name, fields, span })
    }

    /// A `KEYWORD NAME { key = expr; ... }` block of fields (a material, a
    /// layout): its name, fields and span. The fields end at its `}`, at
    /// the start of another item, or (`stop_at_layout`) at a `layout NAME {`.
    fn field_block(&mut self, keyword: &str, stop_at_layout: bool) -> (Ident, Vec<Field>, Span) {
        let start = self.toks[self.pos].span;
        let (name, braced) = self.block_header(keyword);
        let mut fields = Vec::new();
        if braced {
            while let Some(k) = self.peek_kind() {
                if k == TokKind::RBrace
                    || starts_item_at(self.toks, self.pos)
                    || stop_at_layout && self.layout_at(self.pos)
                {
                    break;
                }
                let end = self.stmt_end(true).max(self.pos + 1);
                let toks = self.take_stmt(end);
                for s in self.statement(toks, Entry::Mat) {
                    if let Stmt::Field(f) = s {
                        fields.push(f);
                    }
                }
            }
        }
        let close = if braced {
            self.block_close(start, keyword)
        } else {
            name.span
        };
        (name, shrink(fields), start.to(close))
    }
}

/// The deepest expression the language accepts, in levels (a lone number
/// or name is 1 level, `(1)` is 2, `-(1)` is 3). The parser rejects a
/// statement nesting deeper (E0211) and the checker stops following an
/// expression at the same depth (`grm-sema` derives its limit from this
/// one), so every later phase may walk expressions recursively. Hand-written
/// grammars stay far below it.
pub const MAX_EXPR_DEPTH: usize = 200;

/// The E0211 diagnostic, the same wherever the limit is hit (the parser,
/// [`parse_expr`], the checker for trees not built by the parser). `span`
/// is the first subexpression past the limit.
pub fn expr_too_deep(file: FileId, span: Span) -> Diagnostic {
    Diagnostic::new(
        Code::ExprTooDeep,
        format!("expression nested more than {MAX_EXPR_DEPTH} levels deep"),
        file,
        span,
        "too deep from here on",
    )
    .with_help("split the expression with constants")
}

/// The span of the first subexpression (in text order) at level
/// `MAX_EXPR_DEPTH + 1`, if the expression nests that deep. Without
/// recursion.
fn too_deep_at(e: &Expr) -> Option<Span> {
    let mut stack = vec![(e, 1usize)];
    while let Some((e, d)) = stack.pop() {
        if d > MAX_EXPR_DEPTH {
            return Some(e.span);
        }
        stack.extend(children(e).into_iter().rev().map(|c| (c, d + 1)));
    }
    None
}

/// The top-level expressions of a statement (those the checker types).
fn stmt_exprs_mut(stmt: &mut Stmt) -> Vec<&mut Expr> {
    fn modules(ms: &mut [Module]) -> impl Iterator<Item = &mut Expr> {
        ms.iter_mut().flat_map(|m| m.args.iter_mut())
    }
    match stmt {
        Stmt::Item(Item::Const(c)) => vec![&mut c.value],
        Stmt::Item(Item::Param(p)) => std::iter::once(&mut p.default)
            .chain(p.range.iter_mut().flat_map(|(a, b)| [a, b]))
            .collect(),
        Stmt::Item(_) => Vec::new(),
        Stmt::Field(f) => vec![&mut f.value],
        Stmt::SysItem(SystemItem::Axiom(a)) => modules(&mut a.modules).collect(),
        Stmt::SysItem(SystemItem::Setting(s)) => vec![&mut s.value],
        Stmt::SysItem(SystemItem::Production(p)) => p
            .condition
            .iter_mut()
            .chain(p.weight.iter_mut())
            .chain(modules(&mut p.successor))
            .collect(),
        Stmt::SysItem(_) => Vec::new(),
    }
}

fn children(e: &Expr) -> Vec<&Expr> {
    match &e.kind {
        ExprKind::Call { args, .. } => args.iter().collect(),
        ExprKind::Unary { operand, .. } => vec![operand],
        ExprKind::Binary { lhs, rhs, .. } => vec![lhs, rhs],
        ExprKind::Field { base, .. } => vec![base],
        ExprKind::If { cond, then, els } => vec![cond, then, els],
        ExprKind::Paren(inner) => vec![inner],
        ExprKind::Number { .. }
        | ExprKind::Bool(_)
        | ExprKind::Str(_)
        | ExprKind::Name(_)
        | ExprKind::Error => Vec::new(),
    }
}

/// Depth of an expression tree, computed without recursion.
pub fn expr_depth(e: &Expr) -> usize {
    let mut max = 0;
    let mut stack = vec![(e, 1usize)];
    while let Some((e, d)) = stack.pop() {
        max = max.max(d);
        stack.extend(children(e).into_iter().map(|c| (c, d + 1)));
    }
    max
}

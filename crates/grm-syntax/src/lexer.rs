//! The lexer: logos turns text into tokens; a second pass splits comments
//! out and tells polygon braces (`{` / `}` turtle commands inside a module
//! string) from block braces.
//!
//! Lexing never fails: an invalid character, an unterminated string or
//! comment becomes a diagnostic and the lexer continues after it.

use grm_diag::{Code, Diagnostic, FileId, Span};
use logos::Logos;

/// A raw token as logos sees it.
#[derive(Logos, Clone, Copy, Debug, PartialEq, Eq)]
#[logos(skip r"[ \t\r\n\f\u{FEFF}]+")]
enum Raw {
    #[token("import")]
    Import,
    #[token("const")]
    Const,
    #[token("param")]
    Param,
    #[token("mesh")]
    Mesh,
    #[token("material")]
    Material,
    #[token("system")]
    System,
    #[token("module")]
    Module,
    #[token("skeleton")]
    Skeleton,
    #[token("geometry")]
    Geometry,
    #[token("wrapup")]
    Wrapup,
    #[token("axiom")]
    Axiom,
    #[token("ignore")]
    Ignore,
    #[token("in")]
    In,
    #[token("if")]
    If,
    #[token("then")]
    Then,
    #[token("else")]
    Else,
    #[token("true")]
    True,
    #[token("false")]
    False,

    #[regex(r"[\p{XID_Start}_][\p{XID_Continue}]*")]
    Ident,
    // A digit starts a number, and the letters and digits run on with it
    // (`1e`, `1e+`, `1ee3`, `2x`): one malformed literal (E0006), not a
    // number followed by a name.
    #[regex(r"[0-9]+(\.[0-9]+)?([eE][+-]?[0-9]*)?[\p{XID_Continue}]*")]
    Number,
    /// The flag says whether the string was closed.
    #[token("\"", lex_string)]
    Str(bool),
    #[token("//", lex_line_comment)]
    LineComment,
    /// The flag says whether the comment was closed.
    #[token("/*", lex_block_comment)]
    BlockComment(bool),

    #[token(";")]
    Semi,
    #[token(",")]
    Comma,
    #[token(":")]
    Colon,
    #[token("=")]
    Assign,
    #[token("(")]
    LParen,
    #[token(")")]
    RParen,
    #[token("{")]
    LBrace,
    #[token("}")]
    RBrace,
    #[token("[")]
    LBracket,
    #[token("]")]
    RBracket,
    #[token("->")]
    Arrow,
    /// Arrows of other L-system tools and of books: reported, then read
    /// as `->` so the production is still checked.
    #[token("=>")]
    #[token("\u{2192}")]
    #[token("\u{21D2}")]
    #[token("\u{27F6}")]
    OtherArrow,
    #[token("<")]
    Lt,
    #[token(">")]
    Gt,
    #[token("<=")]
    Le,
    #[token(">=")]
    Ge,
    #[token("==")]
    EqEq,
    #[token("!=")]
    Ne,
    #[token("&&")]
    AndAnd,
    #[token("||")]
    OrOr,
    #[token("+")]
    Plus,
    #[token("-")]
    Minus,
    #[token("*")]
    Star,
    #[token("/")]
    Slash,
    #[token("\\")]
    Backslash,
    #[token("%")]
    Percent,
    #[token("~")]
    Tilde,
    #[token("!")]
    Bang,
    #[token("&")]
    Amp,
    #[token("^")]
    Caret,
    #[token("|")]
    Pipe,
    #[token("'")]
    Quote,
    #[token(".")]
    Dot,
    #[token("..")]
    DotDot,
    #[token("$")]
    Dollar,
}

fn lex_string(lex: &mut logos::Lexer<Raw>) -> bool {
    let rest = lex.remainder();
    let mut closed = false;
    let mut len = rest.len();
    let mut escaped = false;
    for (i, c) in rest.char_indices() {
        if escaped {
            escaped = false;
            continue;
        }
        match c {
            '\\' => escaped = true,
            '"' => {
                len = i + 1;
                closed = true;
                break;
            }
            '\n' | '\r' => {
                // Unterminated: stop at the line end (a line break is `\n`,
                // `\r\n` or a lone `\r`), leaving a trailing `;` to the
                // statement so the one typo costs one diagnostic.
                let line = rest[..i].trim_end();
                len = if line.ends_with(';') {
                    line.len() - 1
                } else {
                    i
                };
                break;
            }
            _ => {}
        }
    }
    lex.bump(len);
    closed
}

/// A line comment runs to the end of its line, before its line break
/// (`\n`, `\r\n` or a lone `\r`, as `grm_diag::SourceFile` counts lines).
fn lex_line_comment(lex: &mut logos::Lexer<Raw>) {
    let len = grm_diag::first_line_len(lex.remainder());
    lex.bump(len);
}

fn lex_block_comment(lex: &mut logos::Lexer<Raw>) -> bool {
    let rest = lex.remainder();
    match rest.find("*/") {
        Some(i) => {
            lex.bump(i + 2);
            true
        }
        None => {
            lex.bump(rest.len());
            false
        }
    }
}

/// A token kind as the parser sees it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TokKind {
    Import,
    Const,
    Param,
    Mesh,
    Material,
    System,
    Module,
    Skeleton,
    Geometry,
    Wrapup,
    Axiom,
    Ignore,
    In,
    If,
    Then,
    Else,
    True,
    False,
    Ident,
    Number,
    Str,
    Semi,
    Comma,
    Colon,
    Assign,
    LParen,
    RParen,
    /// `{` opening a block (system, material).
    LBrace,
    /// `}` closing a block.
    RBrace,
    /// `{` turtle command: start a polygon.
    PolyOpen,
    /// `}` turtle command: close a polygon.
    PolyClose,
    /// `{` opening the parts of a shape command (`split(y) { 4: A | ~1: B }`):
    /// a `{` in a module string whose block holds a `:` at its own depth.
    PartsOpen,
    /// `}` closing the parts of a shape command.
    PartsClose,
    /// `%` written right before a part's `:` (`25%: A`): a relative size.
    PercentSize,
    /// `~` before a part's size: a floating size.
    Tilde,
    LBracket,
    RBracket,
    Arrow,
    Lt,
    Gt,
    Le,
    Ge,
    EqEq,
    Ne,
    AndAnd,
    OrOr,
    Plus,
    Minus,
    Star,
    Slash,
    Backslash,
    Percent,
    Bang,
    Amp,
    Caret,
    Pipe,
    Quote,
    Dot,
    DotDot,
    Dollar,
}

impl TokKind {
    /// How the token is written, for messages ("expected `;`").
    pub fn describe(self) -> &'static str {
        use TokKind::*;
        match self {
            Import => "`import`",
            Const => "`const`",
            Param => "`param`",
            Mesh => "`mesh`",
            Material => "`material`",
            System => "`system`",
            Module => "`module`",
            Skeleton => "`skeleton`",
            Geometry => "`geometry`",
            Wrapup => "`wrapup`",
            Axiom => "`axiom`",
            Ignore => "`ignore`",
            In => "`in`",
            If => "`if`",
            Then => "`then`",
            Else => "`else`",
            True => "`true`",
            False => "`false`",
            Ident => "a name",
            Number => "a number",
            Str => "a string",
            Semi => "`;`",
            Comma => "`,`",
            Colon => "`:`",
            Assign => "`=`",
            LParen => "`(`",
            RParen => "`)`",
            LBrace => "`{`",
            RBrace => "`}`",
            PolyOpen => "`{`",
            PolyClose => "`}`",
            PartsOpen => "`{`",
            PartsClose => "`}`",
            PercentSize => "`%`",
            Tilde => "`~`",
            LBracket => "`[`",
            RBracket => "`]`",
            Arrow => "`->`",
            Lt => "`<`",
            Gt => "`>`",
            Le => "`<=`",
            Ge => "`>=`",
            EqEq => "`==`",
            Ne => "`!=`",
            AndAnd => "`&&`",
            OrOr => "`||`",
            Plus => "`+`",
            Minus => "`-`",
            Star => "`*`",
            Slash => "`/`",
            Backslash => "`\\`",
            Percent => "`%`",
            Bang => "`!`",
            Amp => "`&`",
            Caret => "`^`",
            Pipe => "`|`",
            Quote => "`'`",
            Dot => "`.`",
            DotDot => "`..`",
            Dollar => "`$`",
        }
    }

    /// Keywords that can start a top-level item. `mesh` and `material` are
    /// also terminals inside module strings (`mesh(leaf)`): ask
    /// [`starts_item_at`] whether a token really starts one.
    /// A reserved word (docs/language.md): never a name.
    pub fn is_keyword(self) -> bool {
        self.starts_top_item()
            || matches!(
                self,
                TokKind::Module
                    | TokKind::Skeleton
                    | TokKind::Geometry
                    | TokKind::Wrapup
                    | TokKind::Axiom
                    | TokKind::Ignore
                    | TokKind::In
                    | TokKind::If
                    | TokKind::Then
                    | TokKind::Else
                    | TokKind::True
                    | TokKind::False
            )
    }

    pub fn starts_top_item(self) -> bool {
        matches!(
            self,
            TokKind::Import
                | TokKind::Const
                | TokKind::Param
                | TokKind::Mesh
                | TokKind::Material
                | TokKind::System
        )
    }
}

/// A token's kind, whether or not it carries its text.
pub trait Kind {
    fn kind(&self) -> TokKind;
}

impl Kind for Token<'_> {
    fn kind(&self) -> TokKind {
        self.kind
    }
}

impl Kind for Tok {
    fn kind(&self) -> TokKind {
        self.kind
    }
}

/// Whether `tokens[i]` starts a top-level item: an item keyword, where
/// `mesh` and `material` count only as `mesh NAME =` / `material NAME {`
/// (followed by anything else, they are the module-string terminals).
pub fn starts_item_at<T: Kind>(tokens: &[T], i: usize) -> bool {
    let kind = |j: usize| tokens.get(j).map(Kind::kind);
    match kind(i) {
        Some(TokKind::Mesh | TokKind::Material) => {
            kind(i + 1) == Some(TokKind::Ident)
                && matches!(kind(i + 2), Some(TokKind::Assign | TokKind::LBrace))
        }
        Some(k) => k.starts_top_item(),
        None => false,
    }
}

/// A token with its text and byte span.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Token<'a> {
    pub kind: TokKind,
    pub text: &'a str,
    pub span: Span,
}

/// A token without its text, which is the source's text over `span`
/// ([`Tok::text`]): 12 bytes where a [`Token`] takes 32. The parser keeps
/// a whole file's tokens in this form (issue 32: the token list was the
/// largest part of parsing's memory).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tok {
    pub kind: TokKind,
    pub span: Span,
}

impl Tok {
    /// The token's text in `source`, the text it was lexed from.
    pub fn text(self, source: &str) -> &str {
        source.get(self.span.range()).unwrap_or("")
    }

    /// The token with its text in `source`, the text it was lexed from.
    pub fn with_text(self, source: &str) -> Token<'_> {
        Token {
            kind: self.kind,
            text: self.text(source),
            span: self.span,
        }
    }
}

/// The lexer's output.
#[derive(Clone, Debug, Default)]
pub struct Lexed<'a> {
    pub tokens: Vec<Token<'a>>,
    pub comments: Vec<crate::ast::Comment>,
    pub diagnostics: Vec<Diagnostic>,
}

/// The lexer's output with tokens in their compact form ([`Tok`]).
#[derive(Clone, Debug, Default)]
pub struct LexedToks {
    pub tokens: Vec<Tok>,
    pub comments: Vec<crate::ast::Comment>,
    pub diagnostics: Vec<Diagnostic>,
}

fn convert(raw: Raw) -> Option<TokKind> {
    use TokKind as T;
    Some(match raw {
        Raw::Import => T::Import,
        Raw::Const => T::Const,
        Raw::Param => T::Param,
        Raw::Mesh => T::Mesh,
        Raw::Material => T::Material,
        Raw::System => T::System,
        Raw::Module => T::Module,
        Raw::Skeleton => T::Skeleton,
        Raw::Geometry => T::Geometry,
        Raw::Wrapup => T::Wrapup,
        Raw::Axiom => T::Axiom,
        Raw::Ignore => T::Ignore,
        Raw::In => T::In,
        Raw::If => T::If,
        Raw::Then => T::Then,
        Raw::Else => T::Else,
        Raw::True => T::True,
        Raw::False => T::False,
        Raw::Ident => T::Ident,
        Raw::Number => T::Number,
        Raw::Str(_) => T::Str,
        Raw::LineComment | Raw::BlockComment(_) => return None,
        Raw::Semi => T::Semi,
        Raw::Comma => T::Comma,
        Raw::Colon => T::Colon,
        Raw::Assign => T::Assign,
        Raw::LParen => T::LParen,
        Raw::RParen => T::RParen,
        Raw::LBrace => T::LBrace,
        Raw::RBrace => T::RBrace,
        Raw::LBracket => T::LBracket,
        Raw::RBracket => T::RBracket,
        Raw::Arrow => T::Arrow,
        Raw::OtherArrow => T::Arrow,
        Raw::Lt => T::Lt,
        Raw::Gt => T::Gt,
        Raw::Le => T::Le,
        Raw::Ge => T::Ge,
        Raw::EqEq => T::EqEq,
        Raw::Ne => T::Ne,
        Raw::AndAnd => T::AndAnd,
        Raw::OrOr => T::OrOr,
        Raw::Plus => T::Plus,
        Raw::Minus => T::Minus,
        Raw::Star => T::Star,
        Raw::Slash => T::Slash,
        Raw::Backslash => T::Backslash,
        Raw::Percent => T::Percent,
        Raw::Tilde => T::Tilde,
        Raw::Bang => T::Bang,
        Raw::Amp => T::Amp,
        Raw::Caret => T::Caret,
        Raw::Pipe => T::Pipe,
        Raw::Quote => T::Quote,
        Raw::Dot => T::Dot,
        Raw::DotDot => T::DotDot,
        Raw::Dollar => T::Dollar,
    })
}

/// Lex a whole file.
pub fn lex(file: FileId, text: &str) -> Lexed<'_> {
    let l = lex_toks(file, text);
    Lexed {
        tokens: l.tokens.iter().map(|t| t.with_text(text)).collect(),
        comments: l.comments,
        diagnostics: l.diagnostics,
    }
}

/// Lex a whole file into compact tokens ([`Tok`]), held at their number
/// (no spare room).
pub fn lex_toks(file: FileId, text: &str) -> LexedToks {
    let mut out = LexedToks::default();
    // The tokens are counted first and the list made at that size: a list
    // grown by doubling is copied each time once glibc serves it from its
    // heap (after the first large block it frees), which left holes of up
    // to half the list in `grmc fmt`'s second parse (issue 32). Lexing
    // twice costs a few percent of parsing.
    // The comments' list too.
    let (mut tokens, mut comments) = (0, 0);
    for r in Raw::lexer(text) {
        match r {
            Ok(Raw::LineComment | Raw::BlockComment(_)) => comments += 1,
            Ok(_) => tokens += 1,
            Err(()) => {}
        }
    }
    out.tokens.reserve_exact(tokens);
    out.comments.reserve_exact(comments);
    let mut lexer = Raw::lexer(text);
    // A run of invalid characters is reported once.
    let mut bad_run: Option<Span> = None;
    let flush_bad = |bad: &mut Option<Span>, diags: &mut Vec<Diagnostic>| {
        if let Some(s) = bad.take() {
            let what = &text[s.range()];
            let shown: String = what.chars().take(12).collect();
            diags.push(
                Diagnostic::new(
                    Code::InvalidCharacter,
                    format!(
                        "invalid character{} `{}`",
                        if what.chars().count() > 1 { "s" } else { "" },
                        shown.escape_debug()
                    ),
                    file,
                    s,
                    "not part of any token",
                )
                .with_help(if what.chars().all(|c| c == '°') {
                    "remove it: angles are written in degrees without a sign (`25.7`)"
                } else {
                    "remove it; strings go in double quotes and comments start with `//`"
                }),
            );
        }
    };
    while let Some(res) = lexer.next() {
        let span = Span::from_range(lexer.span());
        let slice = lexer.slice();
        match res {
            Err(()) => {
                bad_run = Some(match bad_run {
                    Some(b) if b.end == span.start => b.to(span),
                    Some(b) => {
                        let mut tmp = Some(b);
                        flush_bad(&mut tmp, &mut out.diagnostics);
                        span
                    }
                    None => span,
                });
            }
            Ok(raw) => {
                flush_bad(&mut bad_run, &mut out.diagnostics);
                match raw {
                    Raw::LineComment | Raw::BlockComment(_) => {
                        if raw == Raw::BlockComment(false) {
                            out.diagnostics.push(
                                Diagnostic::new(
                                    Code::UnterminatedComment,
                                    "unterminated block comment",
                                    file,
                                    Span::new(span.start, span.start + 2),
                                    "this comment is never closed",
                                )
                                .with_help("close it with `*/`"),
                            );
                        }
                        bidi_controls(file, slice, span, "comment", &mut out.diagnostics);
                        out.comments.push(crate::ast::Comment {
                            text: slice.into(),
                            span,
                        });
                    }
                    Raw::Str(terminated) => {
                        bidi_controls(file, slice, span, "string", &mut out.diagnostics);
                        if !terminated {
                            out.diagnostics.push(
                                Diagnostic::new(
                                    Code::UnterminatedString,
                                    "unterminated string",
                                    file,
                                    span,
                                    "this string has no closing quote",
                                )
                                .with_help("add a `\"` before the end of the line"),
                            );
                        }
                        // An unterminated one is kept as a string token too,
                        // so the item still parses.
                        out.tokens.push(Tok {
                            kind: TokKind::Str,
                            span,
                        });
                    }
                    Raw::OtherArrow => {
                        let ascii = slice.is_ascii();
                        out.diagnostics.push(
                            Diagnostic::new(
                                if ascii {
                                    Code::UnexpectedToken
                                } else {
                                    Code::InvalidCharacter
                                },
                                format!("`{slice}` is not an arrow in grm"),
                                file,
                                span,
                                "read as `->`",
                            )
                            .with_help("productions are written with `->`: `F -> F F;`"),
                        );
                        out.tokens.push(Tok {
                            kind: TokKind::Arrow,
                            span,
                        });
                    }
                    _ => {
                        if let Some(kind) = convert(raw) {
                            out.tokens.push(Tok { kind, span });
                        }
                    }
                }
            }
        }
    }
    flush_bad(&mut bad_run, &mut out.diagnostics);
    mark_polygon_braces(&mut out.tokens);
    out.tokens.shrink_to_fit();
    out.comments.shrink_to_fit();
    out
}

/// The W0017 warning of a comment or string (`what`) at `span` whose text
/// `slice` holds bidirectional formatting characters: one warning, a label
/// on each character (the first primary). Such a character can make the
/// line display in another order than grm reads it (CVE-2021-42574,
/// "Trojan Source"), as rustc warns.
fn bidi_controls(file: FileId, slice: &str, span: Span, what: &str, diags: &mut Vec<Diagnostic>) {
    let mut found = slice
        .char_indices()
        .filter(|&(_, c)| grm_diag::is_bidi_control(c));
    let Some(first) = found.next() else {
        return;
    };
    let at = |(i, c): (usize, char)| {
        let start = span.start + i as u32;
        (Span::new(start, start + c.len_utf8() as u32), bidi_name(c))
    };
    let (s, name) = at(first);
    let mut d = Diagnostic::new(
        Code::BidiControl,
        format!("bidirectional control character in a {what}"),
        file,
        s,
        name,
    );
    for c in found {
        let (s, name) = at(c);
        d = d.with_label(file, s, name);
    }
    diags.push(
        d.with_note(
            "this character can make the line display in another order than grm reads it \
             (\"Trojan Source\")",
        )
        .with_help("remove it"),
    );
}

/// The Unicode name of a bidirectional formatting character, with its
/// code point.
fn bidi_name(c: char) -> &'static str {
    match c {
        '\u{202A}' => "U+202A LEFT-TO-RIGHT EMBEDDING",
        '\u{202B}' => "U+202B RIGHT-TO-LEFT EMBEDDING",
        '\u{202C}' => "U+202C POP DIRECTIONAL FORMATTING",
        '\u{202D}' => "U+202D LEFT-TO-RIGHT OVERRIDE",
        '\u{202E}' => "U+202E RIGHT-TO-LEFT OVERRIDE",
        '\u{2066}' => "U+2066 LEFT-TO-RIGHT ISOLATE",
        '\u{2067}' => "U+2067 RIGHT-TO-LEFT ISOLATE",
        '\u{2068}' => "U+2068 FIRST STRONG ISOLATE",
        '\u{2069}' => "U+2069 POP DIRECTIONAL ISOLATE",
        _ => "a bidirectional control character",
    }
}

/// Inside a module string (after `->`, `axiom` or `ignore`, up to `;`), a
/// `{` is the polygon turtle command, and so is a `}` that closes one. A
/// `}` with no open polygon ends the module string: it closes the block, so
/// a forgotten `;` before a system's closing brace is one diagnostic, not a
/// broken system.
///
/// A brace pair whose block holds a `:` at its own depth is the parts of a
/// shape command instead (`split(y) { 4: A | ~1: B }`; a polygon never
/// holds a `:`): both braces become [`TokKind::PartsOpen`] and
/// [`TokKind::PartsClose`]. A `%` right before a `:` in a module string is
/// a relative part size ([`TokKind::PercentSize`]). One pass: an open
/// brace is settled when its `}` is met, so nesting costs nothing extra.
fn mark_polygon_braces(tokens: &mut [Tok]) {
    let mut in_string = false;
    // Open braces of the module string: (token index, holds a `:`).
    let mut open: Vec<(usize, bool)> = Vec::new();
    for i in 0..tokens.len() {
        let item = starts_item_at(tokens, i);
        let next_is_colon = tokens.get(i + 1).is_some_and(|t| t.kind == TokKind::Colon);
        let t = &mut tokens[i];
        match t.kind {
            TokKind::Arrow | TokKind::Axiom | TokKind::Ignore => {
                in_string = true;
                open.clear();
            }
            TokKind::Semi => {
                in_string = false;
                open.clear();
            }
            TokKind::LBrace if in_string => {
                t.kind = TokKind::PolyOpen;
                open.push((i, false));
            }
            TokKind::RBrace if in_string => match open.pop() {
                Some((at, parts)) => {
                    if parts {
                        t.kind = TokKind::PartsClose;
                        tokens[at].kind = TokKind::PartsOpen;
                    } else {
                        t.kind = TokKind::PolyClose;
                    }
                }
                None => in_string = false,
            },
            TokKind::Colon if in_string => {
                if let Some(top) = open.last_mut() {
                    top.1 = true;
                }
            }
            TokKind::Percent if in_string && next_is_colon => t.kind = TokKind::PercentSize,
            _ if item => {
                in_string = false;
                open.clear();
            }
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn kinds(s: &str) -> Vec<TokKind> {
        lex(FileId(0), s).tokens.iter().map(|t| t.kind).collect()
    }

    /// A bidirectional formatting character in a comment or a string
    /// (terminated or not) is one W0017 per comment or string, labelled at
    /// each character; elsewhere it is an invalid character, and text
    /// without one has no warning.
    #[test]
    fn bidi_controls_in_comments_and_strings_warn() {
        let codes = |t: &str| -> Vec<Code> {
            let mut c: Vec<Code> = lex(FileId(0), t)
                .diagnostics
                .iter()
                .map(|d| d.code)
                .collect();
            c.sort();
            c
        };
        for c in [
            '\u{202A}', '\u{202B}', '\u{202C}', '\u{202D}', '\u{202E}', '\u{2066}', '\u{2067}',
            '\u{2068}', '\u{2069}',
        ] {
            assert_eq!(codes(&format!("// a{c}b\nF")), [Code::BidiControl], "{c:?}");
            assert_eq!(codes(&format!("/* {c} */ F")), [Code::BidiControl], "{c:?}");
            assert_eq!(
                codes(&format!("mesh m = \"a{c}.obj\";")),
                [Code::BidiControl],
                "{c:?}"
            );
            assert_eq!(
                codes(&format!("mesh m = \"a{c}.obj\n")),
                [Code::UnterminatedString, Code::BidiControl],
                "{c:?}"
            );
            assert_eq!(
                codes(&format!("F {c} F")),
                [Code::InvalidCharacter],
                "{c:?}"
            );
        }
        let text = "axiom F; // \u{202E} x \u{2066}y\u{2069}\n";
        let l = lex(FileId(0), text);
        assert_eq!(l.diagnostics.len(), 1);
        let d = &l.diagnostics[0];
        assert_eq!(d.code, Code::BidiControl);
        assert_eq!(d.severity, grm_diag::Severity::Warning);
        let at: Vec<(usize, &str)> = d
            .labels
            .iter()
            .map(|l| (l.span.start as usize, &text[l.span.range()]))
            .collect();
        assert_eq!(at, [(12, "\u{202E}"), (18, "\u{2066}"), (22, "\u{2069}")],);
        assert!(d.labels[0].message.contains("RIGHT-TO-LEFT OVERRIDE"));
        assert!(codes("// \u{200F} right-to-left mark, é, עברית\nF").is_empty());
    }

    #[test]
    fn numbers_and_ranges() {
        use TokKind::*;
        assert_eq!(kinds("1..2"), vec![Number, DotDot, Number]);
        assert_eq!(kinds("1.5e3 .5"), vec![Number, Dot, Number]);
    }

    #[test]
    fn polygon_braces() {
        use TokKind::*;
        assert_eq!(
            kinds("system S { A -> { . F } ; }"),
            vec![
                System, Ident, LBrace, Ident, Arrow, PolyOpen, Dot, Ident, PolyClose, Semi, RBrace
            ]
        );
        // `material(..)` / `mesh(..)` are terminals of the string, not items:
        // the polygon after them is still a polygon.
        assert_eq!(
            kinds("system S { axiom material(m) { . } ; }"),
            vec![
                System, Ident, LBrace, Axiom, Material, LParen, Ident, RParen, PolyOpen, Dot,
                PolyClose, Semi, RBrace
            ]
        );
        // A declaration does end the string (its `{` is a block).
        assert_eq!(
            kinds("system S { A -> F material m { }"),
            vec![
                System, Ident, LBrace, Ident, Arrow, Ident, Material, Ident, LBrace, RBrace
            ]
        );
        // Forgotten `;`: the `}` still closes the block.
        assert_eq!(
            kinds("system S { A -> F }"),
            vec![System, Ident, LBrace, Ident, Arrow, Ident, RBrace]
        );
    }

    #[test]
    fn comments_and_errors() {
        let l = lex(FileId(0), "a // x\n/* y */ b @@ \"s");
        assert_eq!(l.comments.len(), 2);
        let codes: Vec<_> = l.diagnostics.iter().map(|d| d.code).collect();
        assert_eq!(
            codes,
            vec![Code::InvalidCharacter, Code::UnterminatedString]
        );
        let l = lex(FileId(0), "a /* never");
        assert_eq!(l.diagnostics[0].code, Code::UnterminatedComment);
    }

    /// A line comment or an unterminated string ends at a line break:
    /// `\n`, `\r\n` or a lone `\r` (old Mac line endings).
    #[test]
    fn line_comments_and_strings_end_at_every_line_break() {
        use TokKind::*;
        for nl in ["\n", "\r\n", "\r"] {
            let text = format!("a // x{nl}b");
            let l = lex(FileId(0), &text);
            assert_eq!(l.comments.len(), 1, "{nl:?}");
            assert_eq!(l.comments[0].span, Span::new(2, 6), "{nl:?}");
            assert_eq!(kinds(&text), vec![Ident, Ident], "{nl:?}");
            let text = format!("a \"s;{nl}b;");
            let l = lex(FileId(0), &text);
            let codes: Vec<_> = l.diagnostics.iter().map(|d| d.code).collect();
            assert_eq!(codes, vec![Code::UnterminatedString], "{nl:?}");
            assert_eq!(kinds(&text), vec![Ident, Str, Semi, Ident, Semi], "{nl:?}");
        }
    }

    #[test]
    fn unicode_identifiers() {
        use TokKind::*;
        assert_eq!(kinds("Zweig ästchen"), vec![Ident, Ident]);
    }
}

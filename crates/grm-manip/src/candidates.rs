//! The source numbers a drag may change, found by the lexer: the number
//! literals of the system's text and of the root file's constant
//! declarations, and each use of a constant or meta-parameter inside the
//! system (which a drag rewrites as `NAME + offset`, leaving the other
//! uses alone: Lipp's "variable + offset", section 3.3.2).
//!
//! Nothing here decides whether a number matters: every candidate is
//! probed through the real engines ([`crate::probe`]), and one whose
//! probe does not check is simply not a way to move anything.

use grm_diag::{FileId, Span};
use grm_syntax::lexer::{TokKind, lex};
use serde::Serialize;

/// What a candidate is.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(rename_all = "camelCase", tag = "kind")]
pub enum CandidateKind {
    /// A number literal (a leading unary minus included).
    Literal,
    /// A use of the constant or meta-parameter `name`; its value is the
    /// offset added at this use (0 as written).
    Name { name: String },
}

/// One source number a drag may change.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct Candidate {
    /// Its number in [`crate::Manip::candidates`].
    pub index: usize,
    /// Where it is written in the root file (bytes).
    pub span: Span,
    /// The text there.
    pub text: String,
    /// The literal's value, or 0 (the offset) for a name.
    pub value: f64,
    #[serde(flatten)]
    pub kind: CandidateKind,
    /// The random draw whose arguments it is in (`uniform`, `normal`...),
    /// if any: a part placed by a draw moves with it, but not only with it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub random: Option<String>,
    /// Written without a fraction or exponent (an integer where the
    /// checker wants one: a drag then only takes whole values).
    pub integer: bool,
    /// The constant whose declaration it is written in, if any (changing
    /// it changes every use).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub constant: Option<String>,
    /// The replacement needs no parentheses at this place.
    #[serde(skip)]
    pub(crate) bare: bool,
}

const RANDOM: [&str; 5] = ["uniform", "normal", "randint", "choose", "chance"];

/// Settings whose numbers are not geometry (a drag never rewrites them).
const NOT_GEOMETRY: [&str; 4] = ["seed", "iterations", "mode", "axiom"];

/// The candidates of `text` (the root file): numbers inside `system`
/// (the whole `system NAME { ... }`) and inside `consts` (each constant's
/// whole declaration), and uses of `names` inside `system`.
pub(crate) fn find(text: &str, system: Span, consts: &[Span], names: &[String]) -> Vec<Candidate> {
    let lexed = lex(FileId(0), text);
    let toks = &lexed.tokens;
    let inside = |s: Span, r: Span| s.start >= r.start && s.end <= r.end;
    let mut out = Vec::new();
    // Open parentheses: the called name before each, if any.
    let mut parens: Vec<Option<&str>> = Vec::new();
    for (i, t) in toks.iter().enumerate() {
        match t.kind {
            TokKind::LParen => {
                let callee = i
                    .checked_sub(1)
                    .map(|j| &toks[j])
                    .filter(|p| p.kind == TokKind::Ident)
                    .map(|p| p.text);
                parens.push(callee);
                continue;
            }
            TokKind::RParen => {
                parens.pop();
                continue;
            }
            TokKind::Number | TokKind::Ident => {}
            _ => continue,
        }
        let in_system = inside(t.span, system);
        if !(in_system || consts.iter().any(|c| inside(t.span, *c))) {
            continue;
        }
        let prev = i.checked_sub(1).map(|j| &toks[j]);
        let next = toks.get(i + 1);
        // `seed = 3;`: not a number a drag changes.
        let setting = i
            .checked_sub(2)
            .map(|j| &toks[j])
            .filter(|p| p.kind == TokKind::Ident && prev.is_some_and(|q| q.kind == TokKind::Assign))
            .map(|p| p.text);
        if setting.is_some_and(|s| NOT_GEOMETRY.contains(&s)) {
            continue;
        }
        let random = parens
            .iter()
            .rev()
            .flatten()
            .find(|n| RANDOM.contains(n))
            .map(|n| n.to_string());
        match t.kind {
            TokKind::Number => {
                let Ok(mut value) = t.text.parse::<f64>() else {
                    continue;
                };
                let mut span = t.span;
                let mut before = prev;
                // A unary minus belongs to the number.
                if let Some(m) = prev.filter(|p| p.kind == TokKind::Minus) {
                    let pp = i.checked_sub(2).map(|j| &toks[j]);
                    if pp.is_none_or(|p| opens(p.kind) || operator(p.kind)) {
                        value = -value;
                        span = Span::new(m.span.start, t.span.end);
                        before = pp;
                    }
                }
                let constant = consts.iter().find(|c| inside(t.span, **c)).map(|c| {
                    let rest = &text[c.start as usize..];
                    let end = rest
                        .find(|ch: char| !(ch.is_alphanumeric() || ch == '_'))
                        .unwrap_or(rest.len());
                    rest[..end].to_string()
                });
                out.push(Candidate {
                    index: out.len(),
                    constant,
                    span,
                    text: text[span.start as usize..span.end as usize].to_string(),
                    value,
                    kind: CandidateKind::Literal,
                    random,
                    integer: !t.text.contains(['.', 'e', 'E']),
                    bare: before.is_none_or(|p| opens(p.kind)),
                });
            }
            TokKind::Ident => {
                if !in_system || !names.iter().any(|n| n == t.text) {
                    continue;
                }
                // A call, a field, a declaration (`NAME =`): not a use.
                if next.is_some_and(|n| matches!(n.kind, TokKind::LParen | TokKind::Assign))
                    || prev.is_some_and(|p| p.kind == TokKind::Dot)
                {
                    continue;
                }
                let bare = prev.is_none_or(|p| opens(p.kind) || p.kind == TokKind::Plus)
                    && next.is_none_or(|n| closes(n.kind));
                out.push(Candidate {
                    index: out.len(),
                    span: t.span,
                    text: t.text.to_string(),
                    value: 0.0,
                    kind: CandidateKind::Name {
                        name: t.text.to_string(),
                    },
                    random,
                    integer: false,
                    constant: None,
                    bare,
                });
            }
            _ => {}
        }
    }
    out
}

/// Tokens after which an operand starts a new expression.
fn opens(k: TokKind) -> bool {
    matches!(
        k,
        TokKind::LParen
            | TokKind::Comma
            | TokKind::Assign
            | TokKind::Colon
            | TokKind::LBrace
            | TokKind::PartsOpen
            | TokKind::PolyOpen
            | TokKind::LBracket
            | TokKind::Pipe
            | TokKind::Arrow
            | TokKind::Semi
    )
}

/// Binary operators (a minus after one is unary).
fn operator(k: TokKind) -> bool {
    matches!(
        k,
        TokKind::Plus
            | TokKind::Minus
            | TokKind::Star
            | TokKind::Slash
            | TokKind::Percent
            | TokKind::Caret
            | TokKind::Lt
            | TokKind::Gt
            | TokKind::Le
            | TokKind::Ge
            | TokKind::EqEq
            | TokKind::Ne
            | TokKind::AndAnd
            | TokKind::OrOr
            | TokKind::Then
            | TokKind::Else
            | TokKind::If
    )
}

/// Tokens that end an operand's expression (a `+ offset` may precede them).
fn closes(k: TokKind) -> bool {
    matches!(
        k,
        TokKind::RParen
            | TokKind::Comma
            | TokKind::Semi
            | TokKind::RBrace
            | TokKind::PartsClose
            | TokKind::PolyClose
            | TokKind::RBracket
            | TokKind::Pipe
            | TokKind::Colon
            | TokKind::Plus
            | TokKind::Minus
    )
}

/// A number as the tool writes it: at most `decimals` decimals, no
/// trailing zeros, a whole number without a point.
pub fn format_number(v: f64, decimals: u32) -> String {
    let mut s = format!("{:.*}", decimals as usize, v);
    if s.contains('.') {
        while s.ends_with('0') {
            s.pop();
        }
        if s.ends_with('.') {
            s.pop();
        }
    }
    if s == "-0" { "0".to_string() } else { s }
}

/// A number written at full precision (probes): the shortest text that
/// reads back as `v`.
pub(crate) fn exact_number(v: f64) -> String {
    let s = format!("{v}");
    if s.contains(['e', 'E']) {
        format!("{v:.12}")
    } else {
        s
    }
}

impl Candidate {
    /// The text that gives this candidate `value` (a literal's value, a
    /// name's offset), written with `number`.
    pub(crate) fn replacement(&self, value: f64, number: &dyn Fn(f64) -> String) -> String {
        match &self.kind {
            CandidateKind::Literal => {
                let n = number(value);
                if n.starts_with('-') && !self.bare {
                    format!("({n})")
                } else {
                    n
                }
            }
            CandidateKind::Name { name } => {
                let n = number(value.abs());
                if n == "0" {
                    return name.clone();
                }
                let sign = if value < 0.0 { '-' } else { '+' };
                if self.bare {
                    format!("{name} {sign} {n}")
                } else {
                    format!("({name} {sign} {n})")
                }
            }
        }
    }
}

/// `text` with each `(span, replacement)` applied (spans disjoint).
pub fn apply(text: &str, edits: &[(Span, String)]) -> String {
    let mut sorted: Vec<&(Span, String)> = edits.iter().collect();
    sorted.sort_by_key(|(s, _)| s.start);
    let mut out = String::with_capacity(text.len() + 64);
    let mut at = 0usize;
    for (s, r) in sorted {
        let (a, b) = (s.start as usize, s.end as usize);
        if a < at || b > text.len() {
            continue;
        }
        out.push_str(&text[at..a]);
        out.push_str(r);
        at = b;
    }
    out.push_str(&text[at..]);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_and_names_are_found_with_their_context() {
        let text = "const W = 2.5;\nsystem S {\n  seed = 3;\n  A -> F(-1) F(W * 2) F(uniform(1, W)) F(x - W);\n}\n";
        let sys = Span::new(text.find("system").unwrap() as u32, text.len() as u32);
        let c = Span::new(0, text.find(';').unwrap() as u32 + 1);
        let cs = find(text, sys, &[c], &["W".to_string()]);
        let shown: Vec<(String, bool, Option<String>, bool)> = cs
            .iter()
            .map(|c| (c.text.clone(), c.integer, c.random.clone(), c.bare))
            .collect();
        assert_eq!(
            shown,
            vec![
                ("2.5".into(), false, None, true),
                ("-1".into(), true, None, true),
                ("W".into(), false, None, false),
                ("2".into(), true, None, false),
                ("1".into(), true, Some("uniform".into()), true),
                ("W".into(), false, Some("uniform".into()), true),
                ("W".into(), false, None, false),
            ]
        );
        assert_eq!(cs[1].value, -1.0);
    }

    #[test]
    fn replacements_keep_the_meaning() {
        let text = "system S { A -> F(x - W) F(2 * -1); }";
        let sys = Span::new(0, text.len() as u32);
        let cs = find(text, sys, &[], &["W".to_string()]);
        let w = &cs[0];
        assert_eq!(w.replacement(0.25, &|v| format_number(v, 3)), "(W + 0.25)");
        let lit = cs.iter().find(|c| c.text == "-1").unwrap();
        assert_eq!(lit.replacement(-3.0, &|v| format_number(v, 3)), "(-3)");
        assert_eq!(format_number(2.50001, 3), "2.5");
        assert_eq!(format_number(-0.0001, 2), "0");
        assert_eq!(
            apply(
                "abcdef",
                &[
                    (Span::new(4, 5), "X".into()),
                    (Span::new(1, 2), "YY".into())
                ]
            ),
            "aYYcdXf"
        );
    }
}

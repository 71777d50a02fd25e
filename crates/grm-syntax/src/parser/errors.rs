//! Syntax errors as coded diagnostics: how an unexpected token is named,
//! the grm way to write another notation's token, and a lalrpop error
//! turned into a diagnostic (see the parent module).

use super::*;

/// How an unexpected token is named in "unexpected ...": names and numbers
/// with their text (`unexpected name `foo``), the rest as described.
pub(super) fn unexpected(t: &Token<'_>) -> String {
    match t.kind {
        TokKind::Ident => format!("name `{}`", t.text),
        TokKind::Number => format!("number `{}`", t.text),
        TokKind::Str => "string".to_string(),
        k => k.describe().to_string(),
    }
}

/// The grm way to write what an unexpected token says in another notation:
/// `=` or `and` in a condition, a weight before the arrow.
pub(super) fn other_notation(
    t: &Token<'_>,
    at: usize,
    stmt: Option<&[Token<'_>]>,
) -> Option<String> {
    let s = stmt?;
    let i = s.iter().position(|x| x.span.start as usize == at)?;
    let arrow_after = s[i..].iter().any(|x| x.kind == TokKind::Arrow);
    let colon_before = s[..i].iter().any(|x| x.kind == TokKind::Colon);
    // `axiom: F;`, ABoP's `ω: F` / `w: F`.
    if s.len() > 2
        && s[1].kind == TokKind::Colon
        && (s[0].kind == TokKind::Axiom || matches!(s[0].text, "w" | "ω" | "omega"))
        && !s.iter().any(|x| x.kind == TokKind::Arrow)
    {
        let rest: Vec<&str> = s[2..]
            .iter()
            .filter(|x| x.kind != TokKind::Semi)
            .map(|x| x.text)
            .collect();
        return Some(format!(
            "the axiom is written without `:`: `axiom {};`",
            rest.join(" ")
        ));
    }
    // `not x > 2`: `not` read as a name, then the operand unexpected.
    if i > 0 && s[i - 1].kind == TokKind::Ident && s[i - 1].text == "not" && colon_before {
        return Some("write `!` for not: `!(x > 2)`".into());
    }
    match t.kind {
        TokKind::Assign if colon_before && arrow_after => {
            Some("to compare, write `==` (`=` only gives a setting or a constant its value)".into())
        }
        TokKind::Ident if colon_before || !arrow_after => match t.text {
            "and" => Some("write `&&` for and".into()),
            "or" => Some("write `||` for or".into()),
            "not" => Some("write `!` for not".into()),
            _ => None,
        },
        // `F (0.5) -> ...`: ABoP and other tools write the probability
        // after the predecessor.
        TokKind::Number
            if arrow_after
                && i == 2
                && s[0].kind == TokKind::Ident
                && s[1].kind == TokKind::LParen
                && s.get(3).is_some_and(|x| x.kind == TokKind::RParen) =>
        {
            Some(format!(
                "a production's weight goes after the arrow: `{} -> ({}) ...`",
                s[0].text, t.text
            ))
        }
        _ => None,
    }
}

/// Turn a lalrpop error into a coded diagnostic.
pub(super) fn syntax_error(
    file: FileId,
    text: &str,
    err: ParseError<usize, Token<'_>, ()>,
    stmt: Option<&[Token<'_>]>,
) -> Diagnostic {
    let pretty = |expected: &[String]| -> String {
        let mut names: Vec<String> = expected
            .iter()
            .map(|e| match e.as_str() {
                "IDENT" => "a name".to_string(),
                "NUMBER" => "a number".to_string(),
                "STRING" => "a string".to_string(),
                s => {
                    let inner = s.trim_matches('"').replace("\\\\", "\\");
                    format!("`{inner}`")
                }
            })
            .collect();
        names.dedup();
        if names.len() > 8 {
            names.truncate(8);
            names.push("...".into());
        }
        names.join(", ")
    };
    match err {
        ParseError::UnrecognizedToken {
            token: (l, t, r),
            expected,
        } => {
            // A virtual `;` we appended has an empty span: the statement
            // simply ended too early.
            let virtual_end = t.kind == TokKind::Semi && l == r;
            let (code, msg, span, label) = if virtual_end {
                (
                    Code::UnexpectedToken,
                    "unexpected end of statement".to_string(),
                    Span::from_range(l..r),
                    "the statement is incomplete here".to_string(),
                )
            } else {
                (
                    Code::UnexpectedToken,
                    format!("unexpected {}", unexpected(&t)),
                    Span::from_range(l..r),
                    "unexpected here".to_string(),
                )
            };
            let mut d = Diagnostic::new(code, msg, file, span, label);
            match other_notation(&t, l, stmt) {
                Some(help) => d = d.with_help(help),
                None if !expected.is_empty() => {
                    d = d.with_help(format!("expected {}", pretty(&expected)));
                }
                None => {}
            }
            if t.kind == TokKind::Ident
                && let Some(s) = stmt
                && s.first().is_some_and(|f| f.kind == TokKind::Ident)
                && !s
                    .iter()
                    .any(|x| x.kind == TokKind::Arrow || x.kind == TokKind::Assign)
            {
                d = d.with_note("a production needs `->`, a setting needs `=`");
            }
            d
        }
        ParseError::UnrecognizedEof { location, expected } => {
            let span = Span::from_range(location.min(text.len())..location.min(text.len()));
            let mut d = Diagnostic::new(
                Code::UnexpectedEof,
                "unexpected end of file",
                file,
                span,
                "the file ends here",
            );
            if !expected.is_empty() {
                d = d.with_help(format!("expected {}", pretty(&expected)));
            }
            d
        }
        ParseError::ExtraToken { token: (l, t, r) } => Diagnostic::new(
            Code::UnexpectedToken,
            format!("unexpected {}", unexpected(&t)),
            file,
            Span::from_range(l..r),
            "extra token",
        ),
        ParseError::InvalidToken { location } => Diagnostic::new(
            Code::InvalidCharacter,
            "invalid token",
            file,
            Span::from_range(location..location),
            "here",
        ),
        ParseError::User { error: () } => Diagnostic::new(
            Code::UnexpectedToken,
            "syntax error",
            file,
            Span::from_range(0..0),
            "here",
        ),
    }
}

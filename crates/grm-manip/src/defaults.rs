//! Sliders that write (issue 28, item 5): meta-parameter values written
//! back as their `param` declarations' defaults.

use std::collections::BTreeMap;

use grm_diag::{FileId, Span};
use grm_syntax::lexer::{TokKind, lex};

use crate::candidates::format_number;
use crate::{ManipError, TextEdit};

/// The edits of `text` that make each of `values` its parameter's
/// default: the number after `param NAME [: TYPE] =` (a leading minus
/// included) rewritten. A parameter not declared in `text`, or whose
/// default is not a number written there, is refused.
pub fn rewrite(text: &str, values: &BTreeMap<String, f64>) -> Result<Vec<TextEdit>, ManipError> {
    let toks = lex(FileId(0), text).tokens;
    let mut edits = Vec::new();
    for (name, &value) in values {
        if !value.is_finite() {
            return Err(ManipError::Mismatch {
                why: format!("`{name}`: {value} is not a number a file can hold"),
            });
        }
        let at = toks
            .windows(2)
            .position(|w| {
                w[0].kind == TokKind::Param && w[1].kind == TokKind::Ident && w[1].text == name
            })
            .ok_or_else(|| ManipError::Mismatch {
                why: format!("no `param {name}` is declared in this file"),
            })?;
        // `param NAME = ...` or `param NAME: float = ...`.
        let assign = toks[at + 2..]
            .iter()
            .take(4)
            .position(|t| t.kind == TokKind::Assign)
            .map(|i| at + 2 + i)
            .ok_or_else(|| ManipError::Mismatch {
                why: format!("`param {name}` has no default"),
            })?;
        let (first, number) = match (toks.get(assign + 1), toks.get(assign + 2)) {
            (Some(m), Some(n)) if m.kind == TokKind::Minus && n.kind == TokKind::Number => (m, n),
            (Some(n), _) if n.kind == TokKind::Number => (n, n),
            _ => {
                return Err(ManipError::Mismatch {
                    why: format!("the default of `{name}` is not a number written there"),
                });
            }
        };
        // The default must be the whole expression: `= 2 * PI` is not rewritten.
        let after = toks.get(
            toks.iter()
                .position(|t| std::ptr::eq(t, number))
                .unwrap_or(0)
                + 1,
        );
        if after.is_some_and(|t| !matches!(t.kind, TokKind::In | TokKind::Semi)) {
            return Err(ManipError::Mismatch {
                why: format!("the default of `{name}` is an expression, not a number"),
            });
        }
        edits.push(TextEdit {
            span: Span::new(first.span.start, number.span.end),
            text: format_number(value, 6),
        });
    }
    Ok(edits)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_rewritten_in_place() {
        let text = "param floors = 4 in 1 .. 20;\nparam tilt: float = -2.5;\nparam k = 2 * 3;\n";
        let v = BTreeMap::from([("floors".to_string(), 6.0), ("tilt".to_string(), 1.25)]);
        let e = rewrite(text, &v).unwrap();
        let out = crate::candidates::apply(
            text,
            &e.iter()
                .map(|e| (e.span, e.text.clone()))
                .collect::<Vec<_>>(),
        );
        assert_eq!(
            out,
            "param floors = 6 in 1 .. 20;\nparam tilt: float = 1.25;\nparam k = 2 * 3;\n"
        );
        assert!(rewrite(text, &BTreeMap::from([("k".to_string(), 1.0)])).is_err());
        assert!(rewrite(text, &BTreeMap::from([("nope".to_string(), 1.0)])).is_err());
    }
}

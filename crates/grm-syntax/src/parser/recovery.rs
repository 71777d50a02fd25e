//! Recovery from likely typing slips before the grammar runs: a misspelt
//! item or statement keyword read as the keyword it nearly spells (one
//! E0001), ABoP's axiom notation, and a declaration whose value does not
//! parse kept as a declaration (see the parent module).

use super::*;

/// A name at the start of a top-level item, shaped like an item whose
/// keyword it nearly spells (`sytem P {`, `Const x =`, `include "f.grm"`), is
/// read as that keyword, with one E0001: the item parses, its names resolve,
/// and nothing else is reported for it.
pub(super) fn misspelt_item_keywords(
    file: FileId,
    text: &str,
    toks: &mut [Tok],
    diags: &mut Vec<Diagnostic>,
) {
    let mut depth = 0i32;
    let mut at_start = true;
    for i in 0..toks.len() {
        let k = toks[i].kind;
        if depth == 0 && at_start && k == TokKind::Ident {
            let next = |j: usize| toks.get(i + j).map(|t| t.kind);
            let kind = item_keyword_for(toks[i].text(text)).and_then(|kw| {
                let (kind, fits) = match kw {
                    "system" => (
                        TokKind::System,
                        next(1) == Some(TokKind::Ident) && next(2) == Some(TokKind::LBrace),
                    ),
                    "material" => (
                        TokKind::Material,
                        next(1) == Some(TokKind::Ident) && next(2) == Some(TokKind::LBrace),
                    ),
                    "import" => (TokKind::Import, next(1) == Some(TokKind::Str)),
                    kw => (
                        match kw {
                            "const" => TokKind::Const,
                            "param" => TokKind::Param,
                            _ => TokKind::Mesh,
                        },
                        next(1) == Some(TokKind::Ident)
                            && matches!(next(2), Some(TokKind::Assign | TokKind::Colon)),
                    ),
                };
                fits.then_some((kw, kind))
            });
            if let Some((kw, kind)) = kind {
                let t = &mut toks[i];
                diags.push(read_as_keyword(file, t.span, t.text(text), kw));
                t.kind = kind;
            }
        }
        match k {
            TokKind::LBrace => depth += 1,
            TokKind::RBrace => depth = (depth - 1).max(0),
            _ => {}
        }
        at_start = depth == 0 && matches!(k, TokKind::Semi | TokKind::RBrace);
    }
}

/// E0001 for a name read as the keyword `kw` it nearly spells (the quick
/// fix reads the help's "did you mean").
pub(super) fn read_as_keyword(file: FileId, span: Span, word: &str, kw: &str) -> Diagnostic {
    Diagnostic::new(
        Code::UnexpectedToken,
        format!("`{word}` is not a keyword; read as `{kw}`"),
        file,
        span,
        "not a keyword",
    )
    .with_help(format!("did you mean `{kw}`?"))
}

/// The item keyword a name at the start of an item probably means: a
/// keyword misspelt by one letter or in another case (`sytem`, `System`), or
/// another language's word for it (`include`, `let`).
pub(super) fn item_keyword_for(word: &str) -> Option<&'static str> {
    const KEYWORDS: [&str; 6] = ["system", "const", "param", "mesh", "material", "import"];
    let lower = word.to_lowercase();
    match lower.as_str() {
        "include" | "use" | "require" | "from" => return Some("import"),
        "let" | "var" | "define" | "constant" => return Some("const"),
        "lsystem" | "grammar" | "rules" => return Some("system"),
        "parameter" => return Some("param"),
        _ => {}
    }
    KEYWORDS
        .into_iter()
        .find(|kw| lower == *kw || (word.chars().count() >= 4 && within_one_edit(&lower, kw)))
}

/// A statement inside a system whose first word nearly spells a statement
/// keyword (`axion F;`, `Axiom F;`, `skeleon a;`, `geometri leaf, stem;`,
/// `wrapUp a -> ;`) and that could not parse otherwise (no arrow, not a
/// setting; or, for `wrapup`, two patterns before the arrow with no left
/// context) is read as that keyword's statement, with one E0001: the
/// declaration takes effect, so nothing that depends on it is reported
/// too. Returns the relabelled tokens.
///
/// The axiom in ABoP's notation (`ω: F;`, `w: F;`, `axiom: F;`) is read
/// as `axiom F;` the same way, its E0001 on the `ω:`.
pub(super) fn misspelt_statement_keyword(
    file: FileId,
    text: &str,
    toks: &[Tok],
    diags: &mut Vec<Diagnostic>,
) -> Option<Vec<Tok>> {
    let first = with_text(*toks.first()?, text);
    let first = &first;
    let second = toks.get(1)?;
    let no_arrow = !toks.iter().any(|t| t.kind == TokKind::Arrow);
    if second.kind == TokKind::Colon
        && (first.kind == TokKind::Axiom || matches!(first.text, "w" | "ω" | "omega"))
        && no_arrow
        && toks.len() > 2
    {
        let last = toks[toks.len() - 1];
        let end = if last.kind == TokKind::Semi {
            last.span.start
        } else {
            last.span.end
        };
        let rest = text
            .get(toks[2].span.start as usize..end as usize)
            .unwrap_or("")
            .trim();
        diags.push(
            Diagnostic::new(
                Code::UnexpectedToken,
                if first.kind == TokKind::Axiom {
                    "`axiom:`: the axiom is written without `:`".to_string()
                } else {
                    format!(
                        "`{}:` is ABoP's notation for the axiom; read as `axiom`",
                        first.text
                    )
                },
                file,
                first.span.to(second.span),
                "not grm's notation",
            )
            .with_help(format!("the axiom is written without `:`: `axiom {rest};`")),
        );
        let mut out = Vec::with_capacity(toks.len() - 1);
        out.push(Tok {
            kind: TokKind::Axiom,
            span: first.span,
        });
        out.extend_from_slice(&toks[2..]);
        return Some(out);
    }
    if first.kind != TokKind::Ident {
        return None;
    }
    if matches!(second.kind, TokKind::Assign | TokKind::Semi) {
        return None;
    }
    let arrow = toks.iter().position(|t| t.kind == TokKind::Arrow);
    let lower = first.text.to_lowercase();
    let near =
        |kw: &str| lower == kw || (first.text.chars().count() >= 4 && within_one_edit(&lower, kw));
    let symbol_like = |t: &Tok| {
        t.kind == TokKind::Ident
            || matches!(
                t.text(text),
                "+" | "-" | "&" | "^" | "\\" | "/" | "|" | "$" | "%" | "!" | "'" | "." | "{" | "}"
            )
    };
    let (kw, kind) = match arrow {
        None => [
            ("axiom", TokKind::Axiom),
            ("skeleton", TokKind::Skeleton),
            ("geometry", TokKind::Geometry),
            ("module", TokKind::Module),
            ("ignore", TokKind::Ignore),
        ]
        .into_iter()
        .find(|(kw, _)| near(kw))?,
        Some(at) => {
            let plain_lhs =
                symbol_like(second) && !toks[..at].iter().any(|t| t.kind == TokKind::Lt);
            if !(plain_lhs && (near("wrapup") || lower == "wrap_up")) {
                return None;
            }
            ("wrapup", TokKind::Wrapup)
        }
    };
    diags.push(read_as_keyword(file, first.span, first.text, kw));
    let mut out = toks.to_vec();
    out[0].kind = kind;
    Some(out)
}

/// Whether `a` becomes `b` by one insertion, deletion, substitution or swap
/// of neighbours.
pub(super) fn within_one_edit(a: &str, b: &str) -> bool {
    let (a, b): (Vec<char>, Vec<char>) = (a.chars().collect(), b.chars().collect());
    let pre = a.iter().zip(&b).take_while(|(x, y)| x == y).count();
    let suf = a[pre..]
        .iter()
        .rev()
        .zip(b[pre..].iter().rev())
        .take_while(|(x, y)| x == y)
        .count();
    let (ra, rb) = (&a[pre..a.len() - suf], &b[pre..b.len() - suf]);
    match (ra.len(), rb.len()) {
        (0, 0) | (1, 0) | (0, 1) | (1, 1) => true,
        (2, 2) => ra[0] == rb[1] && ra[1] == rb[0],
        _ => false,
    }
}

/// A `const NAME [: TYPE] = ...` or `param NAME [: TYPE] = ...` whose value
/// does not parse, kept as a declaration with an `Error` value (its syntax
/// error is reported): the name is still defined, so its uses are not
/// reported as unknown names too.
pub(super) fn recover_decl(toks: &[Token<'_>]) -> Option<Item> {
    let kw = toks.first()?;
    let name = toks.get(1).filter(|t| t.kind == TokKind::Ident)?;
    let name = Ident {
        name: name.text.into(),
        span: name.span,
    };
    let assign = toks.iter().position(|t| t.kind == TokKind::Assign)?;
    let ty = match &toks[2..assign] {
        [] => None,
        [c, t] if c.kind == TokKind::Colon && t.kind == TokKind::Ident => Some(TypeAnn {
            name: Ident {
                name: t.text.into(),
                span: t.span,
            },
        }),
        _ => return None,
    };
    let last = toks[toks.len() - 1].span;
    let value_start = toks.get(assign + 1).map_or(last.end, |t| t.span.start);
    let value = Expr {
        kind: ExprKind::Error,
        span: Span::new(value_start, last.end.max(value_start)),
    };
    let span = kw.span.to(last);
    match kw.kind {
        TokKind::Const => Some(Item::Const(ConstDecl {
            name,
            ty,
            value,
            span,
        })),
        TokKind::Param => Some(Item::Param(ParamDecl {
            name,
            ty,
            default: value,
            range: None,
            span,
        })),
        _ => None,
    }
}

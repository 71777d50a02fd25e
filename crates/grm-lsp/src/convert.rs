//! Plain analysis results to LSP types and back. The only place that
//! converts between byte offsets and LSP (line, UTF-16 column) positions.

use grm_analysis as an;
use grm_analysis::{FileAnalysis, SourceFile, Span};
use std::collections::HashMap;
use tower_lsp_server::ls_types::*;

pub use crate::uris::{Uris, path_of, uri_of};

/// The LSP position of a byte offset. Lines end at `\n`, `\r\n` or a lone
/// `\r`, as LSP defines them ([`SourceFile`] counts them so); an offset
/// inside a `\r\n` is its line's end, before the `\r`: LSP has no position
/// inside a line break.
pub fn pos(src: &SourceFile, offset: u32) -> Position {
    let (line, character) = src.line_col_utf16(offset);
    Position { line, character }
}

pub fn range(src: &SourceFile, span: Span) -> Range {
    Range {
        start: pos(src, span.start),
        end: pos(src, span.end),
    }
}

/// The byte offset of an LSP position in a file (clamped to its lines; a
/// character past the end of a line is the line's end, before its line
/// break: before the `\r` of a `\r\n` or of a lone `\r`).
pub fn offset(src: &SourceFile, p: Position) -> u32 {
    src.offset_of_utf16(p.line, p.character)
}

/// A byte span of an LSP range.
pub fn span(src: &SourceFile, r: Range) -> Span {
    let a = offset(src, r.start);
    let b = offset(src, r.end);
    Span::new(a.min(b), a.max(b))
}

/// A location, its file named as the client names it.
pub fn location(uris: &Uris, l: &an::Location) -> Option<Location> {
    Some(Location {
        uri: uris.uri_of(&l.path)?,
        range: Range {
            start: Position {
                line: l.start.line,
                character: l.start.col,
            },
            end: Position {
                line: l.end.line,
                character: l.end.col,
            },
        },
    })
}

pub fn diagnostic(uris: &Uris, src: &SourceFile, d: &an::Diagnostic) -> Diagnostic {
    let related: Vec<DiagnosticRelatedInformation> = d
        .related
        .iter()
        .filter_map(|r| {
            Some(DiagnosticRelatedInformation {
                location: location(uris, &r.location)?,
                message: r.message.clone(),
            })
        })
        .collect();
    Diagnostic {
        range: range(src, d.span),
        severity: Some(match d.severity {
            an::Severity::Error => DiagnosticSeverity::ERROR,
            an::Severity::Warning => DiagnosticSeverity::WARNING,
        }),
        code: Some(NumberOrString::String(d.code.to_string())),
        code_description: None,
        source: Some("grm".into()),
        message: d.message.clone(),
        related_information: (!related.is_empty()).then_some(related),
        tags: d.unnecessary.then(|| vec![DiagnosticTag::UNNECESSARY]),
        data: None,
    }
}

pub fn diagnostics(uris: &Uris, fa: &FileAnalysis) -> Vec<Diagnostic> {
    let src = fa.source();
    fa.diagnostics()
        .iter()
        .map(|d| diagnostic(uris, src, d))
        .collect()
}

pub fn text_edit(src: &SourceFile, e: &an::TextEdit) -> TextEdit {
    TextEdit {
        range: range(src, e.span),
        new_text: e.new_text.clone(),
    }
}

/// The token types, in [`an::TokenKind`] order.
pub const TOKEN_TYPES: &[(an::TokenKind, &str)] = &[
    (an::TokenKind::Keyword, "keyword"),
    (an::TokenKind::Module, "class"),
    (an::TokenKind::Turtle, "macro"),
    (an::TokenKind::Parameter, "parameter"),
    (an::TokenKind::Constant, "variable"),
    (an::TokenKind::MetaParameter, "enumMember"),
    (an::TokenKind::Function, "function"),
    (an::TokenKind::Number, "number"),
    (an::TokenKind::String, "string"),
    (an::TokenKind::Comment, "comment"),
    (an::TokenKind::Operator, "operator"),
    (an::TokenKind::System, "namespace"),
    (an::TokenKind::Resource, "struct"),
    (an::TokenKind::Property, "property"),
    (an::TokenKind::Type, "type"),
    (an::TokenKind::Punctuation, "punctuation"),
    (an::TokenKind::Unresolved, "variable"),
    (an::TokenKind::EnumMember, "enumMember"),
    (an::TokenKind::Tag, "decorator"),
    (an::TokenKind::ShapeValue, "variable"),
];

/// Token modifiers: bit 0 declaration, 1 readonly, 2 defaultLibrary.
pub const TOKEN_MODIFIERS: &[&str] = &["declaration", "readonly", "defaultLibrary"];

pub fn legend() -> SemanticTokensLegend {
    let mut types: Vec<SemanticTokenType> = Vec::new();
    for (_, name) in TOKEN_TYPES {
        let t = SemanticTokenType::new(name);
        if !types.contains(&t) {
            types.push(t);
        }
    }
    SemanticTokensLegend {
        token_types: types,
        token_modifiers: TOKEN_MODIFIERS
            .iter()
            .map(|m| SemanticTokenModifier::new(m))
            .collect(),
    }
}

fn type_index(kind: an::TokenKind) -> u32 {
    let name = TOKEN_TYPES
        .iter()
        .find(|(k, _)| *k == kind)
        .map_or("variable", |(_, n)| *n);
    let mut seen: Vec<&str> = Vec::new();
    for (_, n) in TOKEN_TYPES {
        if !seen.contains(n) {
            seen.push(n);
        }
    }
    seen.iter().position(|n| *n == name).unwrap_or(0) as u32
}

/// Encode tokens relative to each other (LSP's five-integer form); a token
/// spanning lines (a block comment) is split into one token per line.
pub fn semantic_tokens(
    src: &SourceFile,
    toks: &[an::SemanticToken],
    within: Option<Span>,
) -> Vec<SemanticToken> {
    let mut out = Vec::with_capacity(toks.len());
    let (mut last_line, mut last_col) = (0u32, 0u32);
    let text = &src.text;
    // Where the previous piece started (byte offset, line, UTF-16 column):
    // the tokens come sorted, so each column is counted on from there, not
    // from the line's start (linear in the text, even on one long line).
    let mut cursor: Option<(usize, u32, u32)> = None;
    for t in toks {
        if let Some(w) = within
            && (t.span.end < w.start || t.span.start > w.end)
        {
            continue;
        }
        let m = t.modifiers;
        let bits = u32::from(m.declaration)
            | (u32::from(m.readonly) << 1)
            | (u32::from(m.default_library) << 2);
        let ty = type_index(t.kind);
        // Split at line breaks (`\n`, `\r\n` or a lone `\r`).
        let mut start = t.span.start as usize;
        let end = (t.span.end as usize).min(text.len());
        while start < end {
            let line = src.line_of(start as u32);
            let line_end = src.line_end(line).map_or(end, |e| (e as usize).min(end));
            // Empty when `start` is in a line break (`start >= line_end`).
            let piece = text.get(start..line_end).unwrap_or("");
            if !piece.is_empty() {
                let p = match cursor {
                    Some((at, l, col)) if l == line && at <= start => {
                        let more: u32 = text
                            .get(at..start)
                            .map_or(0, |s| s.chars().map(|c| c.len_utf16() as u32).sum());
                        Position {
                            line,
                            character: col + more,
                        }
                    }
                    _ => pos(src, start as u32),
                };
                cursor = Some((start, p.line, p.character));
                let len: u32 = piece.chars().map(|c| c.len_utf16() as u32).sum();
                // Tokens come sorted and never overlap; saturate anyway.
                let delta_line = p.line.saturating_sub(last_line);
                let delta_start = if delta_line == 0 {
                    p.character.saturating_sub(last_col)
                } else {
                    p.character
                };
                out.push(SemanticToken {
                    delta_line,
                    delta_start,
                    length: len,
                    token_type: ty,
                    token_modifiers_bitset: bits,
                });
                last_line = p.line;
                last_col = p.character;
            }
            // The next line starts after `start` (which is on this line).
            match src.line_start(line + 1) {
                Some(next) => start = next as usize,
                None => break,
            }
        }
    }
    out
}

pub fn completion_kind(k: an::CompletionKind) -> CompletionItemKind {
    use an::CompletionKind as K;
    match k {
        K::Keyword => CompletionItemKind::KEYWORD,
        K::Snippet => CompletionItemKind::SNIPPET,
        K::Module => CompletionItemKind::CLASS,
        K::Turtle => CompletionItemKind::OPERATOR,
        K::Parameter => CompletionItemKind::VARIABLE,
        K::Constant => CompletionItemKind::CONSTANT,
        K::MetaParameter => CompletionItemKind::ENUM_MEMBER,
        K::Function => CompletionItemKind::FUNCTION,
        K::Setting => CompletionItemKind::PROPERTY,
        K::Resource => CompletionItemKind::STRUCT,
        K::System => CompletionItemKind::MODULE,
        K::Value => CompletionItemKind::VALUE,
    }
}

pub fn completion(c: &an::CompletionItem) -> CompletionItem {
    CompletionItem {
        label: c.label.clone(),
        kind: Some(completion_kind(c.kind)),
        detail: c.detail.clone(),
        documentation: c.documentation.as_ref().map(|d| {
            Documentation::MarkupContent(MarkupContent {
                kind: MarkupKind::Markdown,
                value: d.clone(),
            })
        }),
        insert_text: c.insert_text.clone(),
        insert_text_format: Some(if c.snippet {
            InsertTextFormat::SNIPPET
        } else {
            InsertTextFormat::PLAIN_TEXT
        }),
        ..CompletionItem::default()
    }
}

pub fn symbol_kind(k: an::SymbolKind) -> SymbolKind {
    use an::SymbolKind as K;
    match k {
        K::Import => SymbolKind::FILE,
        K::Const => SymbolKind::CONSTANT,
        K::Param => SymbolKind::VARIABLE,
        K::Mesh => SymbolKind::FILE,
        K::Material => SymbolKind::OBJECT,
        K::System => SymbolKind::NAMESPACE,
        K::Setting => SymbolKind::PROPERTY,
        K::Axiom | K::Ignore => SymbolKind::FIELD,
        K::Declaration => SymbolKind::INTERFACE,
        K::Production => SymbolKind::FUNCTION,
        K::Module => SymbolKind::CLASS,
    }
}

#[allow(deprecated)] // `DocumentSymbol::deprecated` must still be written.
pub fn document_symbol(src: &SourceFile, n: &an::SymbolNode) -> DocumentSymbol {
    DocumentSymbol {
        name: if n.name.is_empty() {
            "?".into()
        } else {
            n.name.clone()
        },
        detail: n.detail.clone(),
        kind: symbol_kind(n.kind),
        tags: None,
        deprecated: None,
        range: range(src, n.span),
        selection_range: range(src, n.selection),
        children: (!n.children.is_empty())
            .then(|| n.children.iter().map(|c| document_symbol(src, c)).collect()),
    }
}

#[allow(deprecated)] // `SymbolInformation::deprecated` must still be written.
pub fn workspace_symbol(uris: &Uris, s: &an::WorkspaceSymbol) -> Option<SymbolInformation> {
    Some(SymbolInformation {
        name: s.name.clone(),
        kind: symbol_kind(s.kind),
        tags: None,
        deprecated: None,
        location: location(uris, &s.location)?,
        container_name: s.container.clone(),
    })
}

pub fn folding_range(src: &SourceFile, f: &an::FoldingRange) -> FoldingRange {
    let start = pos(src, f.span.start).line;
    let mut end = pos(src, f.span.end).line;
    // Keep a block's closing brace visible.
    if f.kind == an::FoldKind::Region && end > start {
        end -= 1;
    }
    FoldingRange {
        start_line: start,
        start_character: None,
        end_line: end,
        end_character: None,
        kind: Some(match f.kind {
            an::FoldKind::Region => FoldingRangeKind::Region,
            an::FoldKind::Comment => FoldingRangeKind::Comment,
            an::FoldKind::Imports => FoldingRangeKind::Imports,
        }),
        collapsed_text: None,
    }
}

pub fn inlay_hint(src: &SourceFile, h: &an::InlayHint) -> InlayHint {
    InlayHint {
        position: pos(src, h.offset),
        label: InlayHintLabel::String(h.label.clone()),
        kind: Some(match h.kind {
            an::InlayHintKind::Type => InlayHintKind::TYPE,
            an::InlayHintKind::Probability => InlayHintKind::PARAMETER,
        }),
        text_edits: None,
        tooltip: h.tooltip.clone().map(InlayHintTooltip::String),
        padding_left: Some(h.kind == an::InlayHintKind::Probability),
        padding_right: None,
        data: None,
    }
}

pub fn signature_help(s: &an::SignatureHelp) -> SignatureHelp {
    SignatureHelp {
        signatures: s
            .signatures
            .iter()
            .map(|sig| SignatureInformation {
                label: sig.label.clone(),
                documentation: Some(Documentation::MarkupContent(MarkupContent {
                    kind: MarkupKind::Markdown,
                    value: sig.doc.clone(),
                })),
                parameters: Some(
                    sig.params
                        .iter()
                        .map(|&(a, b)| {
                            // Labels are ASCII: byte offsets are UTF-16 offsets.
                            let u = |x: usize| {
                                sig.label[..x]
                                    .chars()
                                    .map(|c| c.len_utf16() as u32)
                                    .sum::<u32>()
                            };
                            ParameterInformation {
                                label: ParameterLabel::LabelOffsets([u(a), u(b)]),
                                documentation: None,
                            }
                        })
                        .collect(),
                ),
                active_parameter: None,
            })
            .collect(),
        active_signature: Some(s.active_signature as u32),
        active_parameter: Some(s.active_parameter as u32),
    }
}

/// Edits of several files as a workspace edit, each file named as the
/// client names it.
pub fn workspace_edit(uris: &Uris, files: &[an::FileEdits]) -> WorkspaceEdit {
    let mut changes: HashMap<Uri, Vec<TextEdit>> = HashMap::new();
    for f in files {
        let Some(uri) = uris.uri_of(&f.path) else {
            continue;
        };
        let edits = changes.entry(uri).or_default();
        for (l, text) in &f.edits {
            edits.push(TextEdit {
                range: Range {
                    start: Position {
                        line: l.start.line,
                        character: l.start.col,
                    },
                    end: Position {
                        line: l.end.line,
                        character: l.end.col,
                    },
                },
                new_text: text.clone(),
            });
        }
    }
    WorkspaceEdit {
        changes: Some(changes),
        document_changes: None,
        change_annotations: None,
    }
}

/// Apply LSP content changes to a text (incremental or full sync).
pub fn apply_changes(text: &str, changes: &[TextDocumentContentChangeEvent]) -> String {
    let mut text = text.to_string();
    for c in changes {
        match c.range {
            None => text = c.text.clone(),
            Some(r) => {
                let src = SourceFile::new("", text.as_str());
                let s = span(&src, r);
                text.replace_range(s.range(), &c.text);
            }
        }
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;
    use std::sync::Arc;

    /// Each token's absolute start, counted from its line's start.
    fn starts_from_line(src: &SourceFile, toks: &[an::SemanticToken]) -> Vec<Position> {
        toks.iter().map(|t| pos(src, t.span.start)).collect()
    }

    #[test]
    fn semantic_token_columns_on_long_lines_with_wide_characters() {
        // One long line of modules, with characters of 1, 2 (U+03B4) and
        // 4 (U+1F33F) UTF-8 bytes in comments and names, then a second line.
        let mut text = String::from("system S { axiom ");
        for i in 0..200 {
            text.push_str(match i % 3 {
                0 => "F ",
                1 => "/* \u{03B4}\u{1F33F} */ + ",
                _ => "A\u{03B4} ",
            });
        }
        text.push_str(";\n  A\u{03B4} -> F; }\n");
        let mut a = an::Analysis::new(Arc::new(grm_sema::MemLoader::new()));
        a.set_document(Path::new("t.grm"), 1, text.as_str());
        let fa = a.analyze(Path::new("t.grm")).expect("analysed");
        let toks = fa.semantic_tokens();
        assert!(toks.len() > 250, "{}", toks.len());
        let src = fa.source();
        let want = starts_from_line(src, &toks);
        let got = semantic_tokens(src, &toks, None);
        assert_eq!(got.len(), want.len());
        let (mut line, mut col) = (0u32, 0u32);
        for (g, w) in got.iter().zip(&want) {
            if g.delta_line > 0 {
                line += g.delta_line;
                col = g.delta_start;
            } else {
                col += g.delta_start;
            }
            assert_eq!((line, col), (w.line, w.character));
        }
    }
}

//! `grm-fmt`: the canonical layout of `.grm` files.
//!
//! Role: `grmc fmt` and the language server's "format document". The
//! formatter prints the syntax tree from [`grm_syntax::parse`] in one
//! canonical style and puts every comment back where it was, by span
//! position.
//!
//! Inputs: the text of one file ([`format()`]), or an already parsed file and
//! its text ([`format_file`]). Output: the formatted text, or a
//! [`FormatError`] listing the syntax errors that make formatting unsafe.
//!
//! Invariants:
//! - Meaning is never changed: the formatted text parses without errors to
//!   the same tree, spans aside. [`format()`] re-parses its own output and
//!   refuses ([`FormatError::Internal`]) rather than return text that breaks
//!   this (a bug guard; it has never fired on the tests or the fuzzer).
//! - No text is dropped: every comment is kept, in source order relative to
//!   the tokens around it. Line comments lose trailing whitespace only.
//! - Idempotent: `format(format(x)) == format(x)`.
//! - Text with syntax errors is refused by [`format()`]: a recovering parser
//!   has guessed at it, and printing that guess could change meaning.
//!
//! Style:
//! - 4-space indent inside `system { }` and `material { }`; one statement
//!   per line; a blank line around systems and materials and between
//!   declarations of different kinds; elsewhere at most one blank line,
//!   kept where the text had one or more.
//! - Single spaces around `->`, context `<` / `>`, condition `:`, `=`, and
//!   binary operators; modules in successors, axioms and ignore lists are
//!   separated by single spaces (`F [ + F ] F`, `&&` printed as `& &`).
//! - Expressions are printed with the parentheses the user wrote and no
//!   others (parentheses are only added for a tree that did not come from
//!   the parser and needs them). Number literals and string literals are
//!   kept as written.
//! - Comments on the line after a statement stay there (one space before
//!   them); a line comment inside a statement breaks the statement there and
//!   the rest continues on the next line, aligned after `->` for a
//!   production or indented 4 spaces for anything else.

mod equiv;
mod printer;

pub use equiv::same_tree;

use grm_diag::{Diagnostic, FileId};
use grm_syntax::Parsed;

/// Why a text was not formatted.
#[derive(Clone, Debug, PartialEq)]
pub enum FormatError {
    /// The text has syntax errors (listed, in source order); formatting it
    /// could change its meaning or drop text.
    Syntax(Vec<Diagnostic>),
    /// The formatter would have produced text that does not mean the same
    /// or lost a comment. A bug in the formatter; the text is left alone.
    Internal(String),
}

impl std::fmt::Display for FormatError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            FormatError::Syntax(diags) => {
                write!(
                    f,
                    "not formatted: the file has {} syntax error{}",
                    diags.len(),
                    if diags.len() == 1 { "" } else { "s" }
                )?;
                for d in diags {
                    let s = d.primary().span;
                    write!(
                        f,
                        "\n  {} at bytes {}..{}: {}",
                        d.code.as_str(),
                        s.start,
                        s.end,
                        d.message
                    )?;
                }
                Ok(())
            }
            FormatError::Internal(msg) => write!(f, "internal formatter error: {msg}"),
        }
    }
}

impl std::error::Error for FormatError {}

/// Format a whole file.
///
/// Returns [`FormatError::Syntax`] with the error diagnostics when the text
/// does not parse cleanly. On success the result parses to the same tree
/// (spans aside) with the same comments; that is checked here.
pub fn format(text: &str) -> Result<String, FormatError> {
    let parsed = grm_syntax::parse(FileId(0), text);
    if parsed.has_errors() {
        return Err(FormatError::Syntax(
            parsed
                .diagnostics
                .into_iter()
                .filter(Diagnostic::is_error)
                .collect(),
        ));
    }
    let out = format_file(&parsed, text);
    // Only a fingerprint of the tree is kept while the output is parsed
    // again: never two trees at once (issue 32).
    let before = fingerprint(&parsed);
    drop(parsed);
    check(before, &out)?;
    Ok(out)
}

fn fingerprint(p: &Parsed) -> equiv::Fingerprint {
    equiv::Fingerprint::of(
        &p.file,
        p.comments.iter().map(|c| printer::comment_text(&c.text)),
    )
}

/// Print an already parsed file.
///
/// Meant for text without syntax errors (check [`Parsed::has_errors`]
/// first, as [`format()`] does). Given a file with errors it still never
/// panics: statements the parser could not read are copied verbatim, but
/// text the parser skipped inside a statement may be lost.
pub fn format_file(parsed: &Parsed, text: &str) -> String {
    printer::print(parsed, text)
}

/// The bug guard of [`format`]: `out` must parse cleanly to the same tree
/// with the same comments (as the fingerprint `before` of the tree and
/// comments it was printed from says).
fn check(before: equiv::Fingerprint, out: &str) -> Result<(), FormatError> {
    // Parsed whole, then fingerprinted one item at a time: read item by
    // item into a sink instead, the parser still held the file's tokens
    // beside the item being hashed and its copy (2-12 bytes per source
    // byte more for a file of one large system; issue 32).
    let after = grm_syntax::parse(FileId(0), out);
    let mut tree = equiv::TreeHash::new();
    for i in &after.file.items {
        tree.add(i);
    }
    let (comments, diagnostics) = (after.comments, after.diagnostics);
    if let Some(d) = diagnostics.iter().find(|d| d.is_error()) {
        return Err(FormatError::Internal(format!(
            "the formatted text has a syntax error: {} at {}..{}",
            d.message,
            d.primary().span.start,
            d.primary().span.end
        )));
    }
    let after = equiv::Fingerprint::from_parts(
        tree,
        comments.iter().map(|c| printer::comment_text(&c.text)),
    );
    if before.tree != after.tree {
        return Err(FormatError::Internal(
            "the formatted text parses to a different tree".into(),
        ));
    }
    if before.comments != after.comments {
        return Err(FormatError::Internal(
            "the formatted text lost or changed a comment".into(),
        ));
    }
    Ok(())
}

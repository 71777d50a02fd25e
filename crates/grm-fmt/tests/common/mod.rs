//! Helpers shared by the formatter tests: a span-insensitive tree
//! comparison written independently of the library's, and the corpus walk.

#![allow(dead_code)]

use grm_diag::FileId;
use std::path::{Path, PathBuf};

/// `s` with every `Span { start: N, end: M }` replaced by `Span`.
pub fn strip_spans(s: &str) -> String {
    const OPEN: &str = "Span { start: ";
    let mut out = String::with_capacity(s.len());
    let mut rest = s;
    while let Some(i) = rest.find(OPEN) {
        out.push_str(&rest[..i]);
        out.push_str("Span");
        let after = &rest[i..];
        // The Debug form of a span ends at its first `}`.
        let end = after.find('}').map_or(after.len(), |j| j + 1);
        rest = &after[end..];
    }
    out.push_str(rest);
    out
}

/// The syntax tree of `text` as Debug text with the spans taken out: two
/// texts mean the same exactly when these are equal.
pub fn tree(text: &str) -> String {
    let p = grm_syntax::parse(FileId(0), text);
    strip_spans(&format!("{:?}", p.file))
}

/// The comments of `text`, as the formatter must keep them (line comments
/// may lose trailing whitespace).
pub fn comments(text: &str) -> Vec<String> {
    grm_syntax::parse(FileId(0), text)
        .comments
        .iter()
        .map(|c| {
            if c.text.starts_with("//") {
                c.text.trim_end().to_string()
            } else {
                // Line breaks inside a block comment are written as `\n`.
                c.text.replace("\r\n", "\n").replace('\r', "\n")
            }
        })
        .collect()
}

/// Format `src` and check every promise of the formatter; returns the
/// formatted text.
pub fn check(src: &str) -> String {
    let out = match grm_fmt::format(src) {
        Ok(out) => out,
        Err(e) => panic!("format failed: {e}\n--- input ---\n{src}"),
    };
    let reparsed = grm_syntax::parse(FileId(0), &out);
    assert!(
        !reparsed.has_errors(),
        "formatted text has errors: {:#?}\n--- output ---\n{out}",
        reparsed.diagnostics
    );
    assert!(
        tree(src) == tree(&out),
        "meaning changed\n--- input ---\n{src}\n--- output ---\n{out}"
    );
    assert_eq!(
        comments(src),
        comments(&out),
        "comments changed\n--- output ---\n{out}"
    );
    let again = grm_fmt::format(&out).unwrap_or_else(|e| panic!("second format failed: {e}"));
    assert_eq!(
        out, again,
        "not idempotent\n--- first ---\n{out}\n--- second ---\n{again}"
    );
    for (n, line) in out.lines().enumerate() {
        assert!(
            line.trim_end() == line || in_block_comment(&out, n, line.trim_end().len()),
            "trailing whitespace on line {}: {line:?}\n--- output ---\n{out}",
            n + 1
        );
    }
    out
}

/// Whether byte `col` of line `n` of `text` lies in a block comment (whose
/// bytes are kept, trailing spaces included: `/* ` ending a line).
fn in_block_comment(text: &str, n: usize, col: usize) -> bool {
    let at = text.lines().take(n).map(|l| l.len() + 1).sum::<usize>() + col;
    grm_syntax::parse(FileId(0), text)
        .comments
        .iter()
        .any(|c| c.text.starts_with("/*") && c.span.range().contains(&at))
}

/// The repository root.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Every `.grm` file under `dir`, recursively, sorted.
pub fn grm_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&d) else {
            continue;
        };
        for e in entries.flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "grm") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

//! Fuzz target `parse_check`: arbitrary bytes through the front end.
//!
//! 1. `grm_syntax::parse` must not panic (on any input).
//! 2. `grm_fmt::format_file` must not panic, even on a tree with errors.
//! 3. `grm_fmt::format`: either it refuses a text with syntax errors, or its
//!    output parses without errors to the same tree (spans aside) with the
//!    same comments, and formatting it again changes nothing. It must never
//!    report an internal error. A clean text is also formatted with a
//!    comment stuffed between every two tokens (block comments, then line
//!    comments), which exercises comment placement far more than random
//!    bytes do.
//! 4. `grm_sema::check_with` must not panic; imports and meshes come from an
//!    in-memory loader (no file system access).

#![no_main]

use grm_diag::FileId;
use grm_fmt::FormatError;
use grm_sema::MemLoader;
use libfuzzer_sys::fuzz_target;
use std::sync::OnceLock;

fn loader() -> &'static MemLoader {
    static LOADER: OnceLock<MemLoader> = OnceLock::new();
    LOADER.get_or_init(|| {
        let mut l = MemLoader::new();
        l.add("common.grm", include_str!("../../examples/common.grm"))
            .add(
                "lib.grm",
                "const K = 2;\nsystem Lib { axiom F; F -> F F; }\n",
            )
            .add("cycle.grm", "import \"main.grm\";\nconst C = 1;\n")
            .add_binary("leaf.obj")
            .add_binary("trunk.obj")
            .add_binary("broken.grm");
        l
    })
}

fn comment_texts(p: &grm_syntax::Parsed) -> Vec<&str> {
    p.comments
        .iter()
        .map(|c| {
            if c.text.starts_with("//") {
                c.text.trim_end()
            } else {
                c.text.as_str()
            }
        })
        .collect()
}

/// `text` with a comment after the whitespace before every token but the
/// first: the token stream, hence the tree, is unchanged.
fn stuff_comments(text: &str, line: bool) -> String {
    let toks = grm_syntax::lexer::lex(FileId(0), text).tokens;
    let mut out = String::with_capacity(text.len() * 2);
    let mut pos = 0usize;
    for (i, t) in toks.iter().enumerate() {
        let start = t.span.start as usize;
        out.push_str(&text[pos..start]);
        if i > 0 {
            out.push_str(&if line {
                format!("//{i}\n")
            } else {
                format!("/*{i}*/")
            });
        }
        pos = start;
    }
    out.push_str(&text[pos..]);
    out
}

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let parsed = grm_syntax::parse(FileId(0), &text);
    let _ = grm_fmt::format_file(&parsed, &text);
    if round_trip(&text, &parsed) {
        for line in [false, true] {
            let stuffed = stuff_comments(&text, line);
            let p = grm_syntax::parse(FileId(0), &stuffed);
            if !p.has_errors() {
                round_trip(&stuffed, &p);
            }
        }
    }
    let _ = grm_sema::check_with("main.grm", &text, loader());
});

/// Check `format` on `text` (parsed as `parsed`); returns whether it formatted.
fn round_trip(text: &str, parsed: &grm_syntax::Parsed) -> bool {
    match grm_fmt::format(text) {
        Ok(out) => {
            assert!(!parsed.has_errors(), "formatted a text with syntax errors");
            let again = grm_syntax::parse(FileId(0), &out);
            assert!(
                !again.has_errors(),
                "formatted text has syntax errors: {:?}\n--- output ---\n{out}",
                again.diagnostics
            );
            assert!(
                grm_fmt::same_tree(&parsed.file, &again.file),
                "formatting changed the tree\n--- output ---\n{out}"
            );
            assert_eq!(
                comment_texts(parsed),
                comment_texts(&again),
                "comments changed"
            );
            match grm_fmt::format(&out) {
                Ok(twice) => assert_eq!(out, twice, "formatting is not idempotent"),
                Err(e) => panic!("formatted text does not format: {e}"),
            }
            true
        }
        Err(FormatError::Syntax(diags)) => {
            assert!(
                parsed.has_errors() && !diags.is_empty(),
                "refused a clean text"
            );
            false
        }
        Err(FormatError::Internal(msg)) => panic!("formatter bug: {msg}"),
    }
}

//! A stable, deterministic stand-in for the fuzzer (fuzz/ needs nightly):
//! mutate the repository's `.grm` files with a fixed-seed PRNG and check
//! that formatting never panics, never reports an internal error, and that
//! whatever it formats keeps its meaning and comments and is a fixed point.
//! Inputs the fuzzer found are replayed from fuzz/regressions/fmt/.

mod common;

use grm_diag::FileId;
use grm_testkit::Rng;

/// Fragments that make mutants likely to stay (almost) valid.
const FRAGMENTS: &[&str] = &[
    " ",
    "\n",
    "\n\n",
    ";",
    "// c\n",
    "/* c */",
    "/* a\n b */",
    "->",
    " -> ",
    "(",
    ")",
    "[",
    "]",
    "{",
    "}",
    ".",
    ",",
    ":",
    " < ",
    " > ",
    "&&",
    "||",
    "+",
    "-",
    "/ /",
    "!",
    "'",
    "$",
    "%",
    "^",
    "\\",
    "|",
    "F",
    "F(1)",
    "A(x)",
    "x",
    "1",
    "2.5",
    "1e-3",
    "(2)",
    "\"s\\\"t\"",
    "if a then b else c",
    "v.x",
    "wrapup ",
    "axiom ",
    "ignore ",
    "module ",
    "system S { ",
    "const C = 1;",
    "param p = 1 in 0 .. 2;",
    "material m { color = rgb(1, 2, 3); }",
    "mesh m = \"m.obj\";",
    "import \"common.grm\";",
    "ä",
    "Zweig",
];

fn mutate(rng: &mut Rng, src: &str) -> String {
    let mut bytes = src.as_bytes().to_vec();
    for _ in 0..=rng.below(4) {
        let at = rng.below(bytes.len() + 1);
        match rng.below(4) {
            0 => {
                let frag = FRAGMENTS[rng.below(FRAGMENTS.len())];
                bytes.splice(at..at, frag.bytes());
            }
            1 if !bytes.is_empty() => {
                let end = (at + 1 + rng.below(8)).min(bytes.len());
                bytes.drain(at.min(end)..end);
            }
            2 if !bytes.is_empty() => {
                let from = rng.below(bytes.len());
                let end = (from + 1 + rng.below(40)).min(bytes.len());
                let chunk: Vec<u8> = bytes[from..end].to_vec();
                bytes.splice(at..at, chunk);
            }
            _ => {
                // Whitespace and comments are where a formatter goes wrong.
                let ws = [" ", "\n", "\t", "/**/", "//x\n"][rng.below(5)];
                bytes.splice(at..at, ws.bytes());
            }
        }
    }
    String::from_utf8_lossy(&bytes).into_owned()
}

fn exercise(text: &str) -> bool {
    let parsed = grm_syntax::parse(FileId(0), text);
    // Never panics, even with errors.
    let _ = grm_fmt::format_file(&parsed, text);
    match grm_fmt::format(text) {
        Ok(_) => {
            common::check(text);
            // The riskiest part is comment placement: put a comment in
            // every gap between two tokens and format again.
            for kind in [Stuff::Block, Stuff::Line] {
                let stuffed = stuff_comments(text, kind);
                if !grm_syntax::parse(FileId(0), &stuffed).has_errors() {
                    common::check(&stuffed);
                }
            }
            true
        }
        Err(grm_fmt::FormatError::Syntax(d)) => {
            assert!(parsed.has_errors() && !d.is_empty());
            false
        }
        Err(grm_fmt::FormatError::Internal(msg)) => {
            panic!("formatter bug: {msg}\n--- input ---\n{text}")
        }
    }
}

#[derive(Clone, Copy)]
enum Stuff {
    Block,
    Line,
}

/// `text` with a numbered comment after the whitespace before every token
/// but the first (the token stream, hence the tree, is unchanged).
fn stuff_comments(text: &str, kind: Stuff) -> String {
    let toks = grm_syntax::lexer::lex(FileId(0), text).tokens;
    let mut out = String::with_capacity(text.len() * 2);
    let mut pos = 0usize;
    for (i, t) in toks.iter().enumerate() {
        let start = t.span.start as usize;
        out.push_str(&text[pos..start]);
        if i > 0 {
            match kind {
                Stuff::Block => out.push_str(&format!("/*{i}*/")),
                Stuff::Line => out.push_str(&format!("//{i}\n")),
            }
        }
        pos = start;
    }
    out.push_str(&text[pos..]);
    out
}

#[test]
fn comments_between_all_tokens() {
    let root = common::root();
    for p in common::grm_files(&root.join("examples")) {
        let Ok(text) = std::fs::read_to_string(p) else {
            continue;
        };
        exercise(&text);
    }
}

#[test]
fn mutated_corpus() {
    let root = common::root();
    let mut seeds: Vec<String> = common::grm_files(&root.join("examples"))
        .into_iter()
        .chain(common::grm_files(&root.join("tests/ui")))
        .filter_map(|p| std::fs::read_to_string(p).ok())
        .collect();
    seeds.push("system S { A -> B; }".into());
    let mut rng = Rng::seeded(0x9E37_79B9_7F4A_7C15);
    let (mut clean, mut total) = (0, 0);
    for _ in 0..1500 {
        let seed = &seeds[rng.below(seeds.len())];
        let text = mutate(&mut rng, seed);
        total += 1;
        if exercise(&text) {
            clean += 1;
        }
    }
    println!("{total} mutants, {clean} formatted");
    assert!(clean > 0);
}

#[test]
fn fuzz_regressions() {
    let dir = common::root().join("fuzz/regressions/fmt");
    let Ok(entries) = std::fs::read_dir(&dir) else {
        return;
    };
    for e in entries.flatten() {
        if let Ok(bytes) = std::fs::read(e.path()) {
            exercise(&String::from_utf8_lossy(&bytes));
        }
    }
}

//! The checker never panics: thousands of mutated grammars (deterministic
//! pseudo-random edits of the examples and ui cases) are checked, and every
//! diagnostic's labels stay inside their file.

use grm_sema::{FileId, MemLoader, check_with};
use grm_testkit::Rng;
use std::path::Path;

const TOKENS: &[&str] = &[
    "(",
    ")",
    "[",
    "]",
    "->",
    ";",
    ":",
    "<",
    ">",
    ",",
    "{",
    "}",
    "A",
    "B(x)",
    "F(",
    "x",
    "0",
    "1e9",
    "-1",
    "/",
    "%",
    " wrapup ",
    " skeleton ",
    " geometry ",
    "module A(v: vec3);",
    "mode = sample;",
    "mode = derive;",
    "iterations = 2.5;",
    "axiom ",
    "ignore + F;",
    "import \"lib.grm\";",
    "import \"main.grm\";",
    "mesh m = \"nope.obj\";",
    "const K = K;",
    "param p = 1 in 2 .. 0;",
    ".x",
    ".w",
    "if true then 1 else 2",
    "uniform(0, 1)",
    "choose(1)",
    "spline(0, 1)",
    "vec3(1, 2, 3)",
    "true",
    "&&",
    "!",
    "'",
    "$",
    "|",
    "system T { axiom A; A -> A; }",
    "é",
    "\"",
    "//",
    "/*",
    "\n",
];

fn corpus() -> Vec<String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut out = Vec::new();
    let mut stack = vec![root.join("examples"), root.join("tests/ui")];
    while let Some(dir) = stack.pop() {
        let Ok(rd) = std::fs::read_dir(&dir) else {
            continue;
        };
        for e in rd.flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "grm")
                && let Ok(t) = std::fs::read_to_string(&p)
            {
                out.push(t);
            }
        }
    }
    out.sort();
    out
}

fn boundary(s: &str, mut i: usize) -> usize {
    i = i.min(s.len());
    while !s.is_char_boundary(i) {
        i -= 1;
    }
    i
}

fn mutate(rng: &mut Rng, text: &str) -> String {
    let mut s = text.to_string();
    for _ in 0..1 + rng.below(4) {
        let a = boundary(&s, rng.below(s.len() + 1));
        let b = boundary(&s, a + rng.below(40));
        match rng.below(4) {
            0 => s.replace_range(a..b, ""),
            1 => {
                let t = TOKENS[rng.below(TOKENS.len())];
                s.insert_str(a, t);
            }
            2 => {
                let piece = s[a..b].to_string();
                s.insert_str(b, &piece);
            }
            _ => {
                let t = TOKENS[rng.below(TOKENS.len())];
                s.replace_range(a..b, t);
            }
        }
    }
    s
}

#[test]
fn mutated_grammars_never_panic() {
    let corpus = corpus();
    assert!(corpus.len() > 20);
    let mut files = MemLoader::new();
    files.add("lib.grm", "const L = 1;\nimport \"main.grm\";");
    let mut rng = Rng::seeded(0x9E37_79B9_7F4A_7C15);
    // GRM_FUZZ_RUNS=200000 for a longer run.
    let runs = std::env::var("GRM_FUZZ_RUNS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(if cfg!(debug_assertions) { 2000 } else { 20000 });
    for i in 0..runs {
        let base = &corpus[rng.below(corpus.len())];
        let text = mutate(&mut rng, base);
        let result = std::panic::catch_unwind(|| check_with("main.grm", &text, &files));
        let Ok((sources, checked)) = result else {
            panic!("run {i}: the checker panicked on:\n{text}");
        };
        for d in &checked.diagnostics {
            for l in &d.labels {
                let len = sources.get(l.file).text.len() as u32;
                assert!(
                    l.span.start <= l.span.end && l.span.end <= len,
                    "run {i}: label {:?} outside its file ({len} bytes) in {}:\n{text}",
                    l.span,
                    d.code
                );
            }
        }
        // Rendering must not panic either.
        for d in checked.diagnostics.iter().take(3) {
            let _ = grm_diag::render_plain(d, &sources);
        }
        let _ = checked.program.index.at(FileId(0), 5);
    }
}

#[test]
fn long_import_chain_does_not_overflow() {
    // Imports are loaded depth first; a chain of thousands of files must not
    // exhaust the stack (the test thread has 2 MiB).
    let n = 5000;
    let mut files = MemLoader::new();
    for i in 1..n {
        files.add(
            format!("f{i}.grm"),
            format!("import \"f{}.grm\";\nconst C{i} = 1;\n", i + 1),
        );
    }
    files.add(format!("f{n}.grm"), format!("const C{n} = 1;\n"));
    let main = format!("import \"f1.grm\";\nsystem S {{ axiom F(C{n}); }}\n");
    let (sources, checked) = check_with("main.grm", &main, &files);
    assert!(!checked.has_errors(), "{:?}", checked.diagnostics);
    assert_eq!(sources.iter().count(), n + 1);
}

/// The file-system loader reads only regular files of at most
/// `MAX_SOURCE_BYTES`: an import of a device (`/dev/zero` would be read
/// forever, `/dev/stdin` would eat the language server's protocol stream),
/// a directory or a huge file is an E0401 saying why, at once.
#[test]
fn imports_of_devices_directories_and_huge_files_are_refused() {
    let dir = std::env::temp_dir().join(format!("grm-sema-imports-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("sub")).expect("tempdir");
    let huge = dir.join("huge.grm");
    let f = std::fs::File::create(&huge).expect("create");
    f.set_len(grm_sema::MAX_SOURCE_BYTES + 1)
        .expect("sparse file");
    std::fs::write(dir.join("ok.grm"), "const A = 1;\n").expect("write");
    let main = dir.join("main.grm");
    let text = "import \"/dev/zero\";\nimport \"/dev/null\";\nimport \"sub\";\n\
                import \"huge.grm\";\nimport \"ok.grm\";\nsystem S { axiom F(A); }\n";
    let (_sources, checked) = grm_sema::check_text(&main.to_string_lossy(), text);
    let got = codes_and_first_labels(&checked.diagnostics);
    let _ = std::fs::remove_dir_all(&dir);
    let want = |m: &str| ("E0401".to_string(), m.to_string());
    assert_eq!(
        got,
        vec![
            want("it is not a regular file"),
            want("it is not a regular file"),
            want("it is a directory"),
            want("it is larger than 16 MiB, the most a grammar file may be"),
        ],
        "{:#?}",
        checked.diagnostics
    );
}

/// A mesh path that names a directory or a device says so, not "no such
/// file".
#[test]
fn mesh_paths_that_are_not_files_say_what_they_are() {
    let dir = std::env::temp_dir().join(format!("grm-sema-meshes-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("leaves")).expect("tempdir");
    let main = dir.join("main.grm");
    let text = "mesh a = \"leaves\";\nmesh b = \"/dev/null\";\nmesh c = \"gone.obj\";\n\
                system S { axiom mesh(a) mesh(b) mesh(c); }\n";
    let (_sources, checked) = grm_sema::check_text(&main.to_string_lossy(), text);
    let got = codes_and_first_labels(&checked.diagnostics);
    let _ = std::fs::remove_dir_all(&dir);
    let want = |m: &str| ("E0402".to_string(), m.to_string());
    assert_eq!(
        got,
        vec![
            want("it is a directory"),
            want("it is not a regular file"),
            want("no such file"),
        ],
        "{:#?}",
        checked.diagnostics
    );
}

/// Each diagnostic's code and its primary label's message.
fn codes_and_first_labels(diags: &[grm_diag::Diagnostic]) -> Vec<(String, String)> {
    diags
        .iter()
        .map(|d| (d.code.as_str().to_string(), d.labels[0].message.clone()))
        .collect()
}

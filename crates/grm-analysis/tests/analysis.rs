//! Analysis-level tests: each query on small files held in memory.

use grm_analysis::*;
use grm_sema::MemLoader;
use std::path::Path;
use std::sync::Arc;

const PLANT: &str = "// Branch length scale.
const SHRINK = 0.5 + 0.25;
param spread = 30 in 10 .. 60;

system Plant {
    iterations = 3;
    angle = spread;
    axiom A(1);
    A(l) : l > 0.1 -> (2) F(l) [ + A(l * SHRINK) ] A(l * SHRINK);
    A(l) : l > 0.1 -> (1) F(l) [ - A(l * SHRINK) ];
    B(x, y) -> F(sin(y));
}
";

fn analyze(text: &str) -> Arc<FileAnalysis> {
    let mut a = Analysis::new(Arc::new(MemLoader::new()));
    a.set_document(Path::new("main.grm"), 1, text);
    a.analyze(Path::new("main.grm")).unwrap()
}

/// Byte offset of the `n`-th occurrence of `needle` (plus `delta`).
fn at(text: &str, needle: &str, n: usize, delta: u32) -> u32 {
    let mut from = 0;
    let mut pos = 0;
    for _ in 0..=n {
        pos = from + text[from..].find(needle).expect(needle);
        from = pos + 1;
    }
    pos as u32 + delta
}

#[test]
fn diagnostics_carry_code_help_and_span() {
    let fa = analyze("system S { axiom A; A -> B(1); B(x) -> F; }");
    let d = fa.diagnostics();
    assert_eq!(d.len(), 1, "{d:?}");
    assert_eq!(d[0].code, "W0001");
    assert!(d[0].unnecessary);
    assert!(
        d[0].message.contains("help: prefix it with `_`"),
        "{}",
        d[0].message
    );
    assert_eq!(&fa.text()[d[0].span.range()], "x");
}

#[test]
fn diagnostics_include_what_compiling_finds() {
    // Clean for the checker, refused by the compiler (R0104): the editor
    // shows it where it is, as `grmc check` does.
    let text = "system S { axiom F(acos(2)); }";
    let d = analyze(text).diagnostics();
    assert_eq!(d.len(), 1, "{d:?}");
    assert_eq!(d[0].code, "R0104");
    assert_eq!(&text[d[0].span.range()], "acos(2)");
}

#[test]
fn errors_in_imported_files_show_on_the_import() {
    let mut loader = MemLoader::new();
    loader
        .add("lib.grm", "const LEN = 2 +;\nconst W = 1;\n")
        .add("mid.grm", "import \"lib.grm\";\nconst M = W;\n")
        .add("cycle_b.grm", "import \"main.grm\";\nconst B = 2;\n")
        .add("clean.grm", "const C = 2;\n");
    let mut a = Analysis::new(Arc::new(loader));
    // A syntax error two imports away, in a file that is not open.
    let main = "import \"mid.grm\";\nsystem S { axiom F(M); }\n";
    a.set_document(Path::new("main.grm"), 1, main);
    let d = a.analyze(Path::new("main.grm")).unwrap().diagnostics();
    assert_eq!(d.len(), 1, "{d:?}");
    assert_eq!(d[0].code, "E0001");
    assert_eq!(&main[d[0].span.range()], "\"mid.grm\"");
    assert!(
        d[0].message.contains("imported file `lib.grm` (line 1)"),
        "{}",
        d[0].message
    );
    assert_eq!(d[0].related.len(), 1);
    // An import cycle closed in the other file.
    let main = "import \"cycle_b.grm\";\nsystem S { axiom F(B); }\n";
    a.set_document(Path::new("main.grm"), 2, main);
    let d = a.analyze(Path::new("main.grm")).unwrap().diagnostics();
    assert_eq!(d.len(), 1, "{d:?}");
    assert_eq!(d[0].code, "E0403");
    assert_eq!(&main[d[0].span.range()], "\"cycle_b.grm\"");
    // A clean import adds nothing.
    let main = "import \"clean.grm\";\nsystem S { axiom F(C); }\n";
    a.set_document(Path::new("main.grm"), 3, main);
    let d = a.analyze(Path::new("main.grm")).unwrap().diagnostics();
    assert!(d.is_empty(), "{d:?}");
}

#[test]
fn hover_shows_types_values_docs_and_probabilities() {
    let fa = analyze(PLANT);
    // A constant's folded value and its leading comment.
    let h = fa.hover(at(PLANT, "SHRINK", 1, 1)).unwrap();
    assert!(h.markdown.contains("const SHRINK: float"), "{}", h.markdown);
    assert!(h.markdown.contains("value: `0.75`"), "{}", h.markdown);
    assert!(
        h.markdown.contains("Branch length scale."),
        "{}",
        h.markdown
    );
    // A meta-parameter with its range.
    let h = fa.hover(at(PLANT, "spread", 1, 0)).unwrap();
    assert!(
        h.markdown.contains("param spread: float = 30 in 10 .. 60"),
        "{}",
        h.markdown
    );
    // A module parameter's inferred type.
    let h = fa.hover(at(PLANT, "l * SHRINK", 0, 0)).unwrap();
    assert!(h.markdown.contains("l: float"), "{}", h.markdown);
    assert!(h.markdown.contains("parameter of `A`"), "{}", h.markdown);
    // A turtle command's documentation.
    let h = fa.hover(at(PLANT, "F(l)", 0, 0)).unwrap();
    assert!(h.markdown.contains("turtle command"), "{}", h.markdown);
    assert!(h.markdown.contains("carries (float)"), "{}", h.markdown);
    // A built-in function.
    let h = fa.hover(at(PLANT, "sin", 0, 1)).unwrap();
    assert!(
        h.markdown.contains("sin(a: float) -> float"),
        "{}",
        h.markdown
    );
    // Each alternative's probability, on the predecessor and on the weight.
    let h = fa.hover(at(PLANT, "A(l) :", 1, 0)).unwrap();
    assert!(h.markdown.contains("33.3%"), "{}", h.markdown);
    assert!(h.markdown.contains("66.7%"), "{}", h.markdown);
    let h = fa.hover(at(PLANT, "(2)", 0, 1)).unwrap();
    assert!(h.markdown.contains("66.7%"), "{}", h.markdown);
    // A setting: documentation and value.
    let h = fa.hover(at(PLANT, "iterations", 0, 2)).unwrap();
    assert!(h.markdown.contains("rewriting steps"), "{}", h.markdown);
    assert!(h.markdown.contains("value: `3`"), "{}", h.markdown);
    // A keyword.
    let h = fa.hover(at(PLANT, "axiom", 0, 1)).unwrap();
    assert!(h.markdown.contains("start string"), "{}", h.markdown);
    // An expression's type.
    let h = fa.hover(at(PLANT, "0.1", 0, 1)).unwrap();
    assert!(h.markdown.contains("`float`"), "{}", h.markdown);
    // Nothing in comments.
    assert!(fa.hover(2).is_none());
}

#[test]
fn definition_and_references() {
    let fa = analyze(PLANT);
    let use_at = at(PLANT, "SHRINK", 2, 0);
    let def = fa.definition(use_at).unwrap();
    assert_eq!(def.span.start, at(PLANT, "SHRINK", 0, 0));
    assert_eq!(def.start.line, 1);
    let refs = fa.references(use_at, true);
    assert_eq!(refs.len(), 4);
    let refs = fa.references(use_at, false);
    assert_eq!(refs.len(), 3);
    // Terminals have no definition.
    assert!(fa.definition(at(PLANT, "F(l)", 0, 0)).is_none());
    // A binding's definition is in its predecessor.
    let d = fa.definition(at(PLANT, "sin(y)", 0, 4)).unwrap();
    assert_eq!(d.span.start, at(PLANT, "y)", 0, 0));
}

#[test]
fn references_and_rename_across_open_documents() {
    let mut a = Analysis::new(Arc::new(MemLoader::new()));
    let lib = "const K = 2;\n";
    let main = "import \"lib.grm\";\nsystem S { axiom F(K); }\n";
    let other = "import \"lib.grm\";\nsystem T { axiom F(K * K); }\n";
    a.set_document(Path::new("lib.grm"), 1, lib);
    a.set_document(Path::new("main.grm"), 1, main);
    a.set_document(Path::new("other.grm"), 1, other);
    let refs = a.references(Path::new("main.grm"), at(main, "K", 0, 0), true);
    let files: Vec<String> = refs.iter().map(|l| l.path.display().to_string()).collect();
    assert_eq!(files, ["lib.grm", "main.grm", "other.grm", "other.grm"]);
    let edits = a
        .rename(Path::new("main.grm"), at(main, "K", 0, 0), "Scale")
        .unwrap();
    assert_eq!(edits.len(), 3);
    assert!(
        edits
            .iter()
            .all(|f| f.edits.iter().all(|(_, t)| t == "Scale"))
    );
    // Unsaved edits of an imported document are seen by its importers.
    a.set_document(Path::new("lib.grm"), 2, "const K = 2;\nconst J = 3;\n");
    let fa = a.analyze(Path::new("main.grm")).unwrap();
    assert!(
        fa.diagnostics().iter().any(|d| d.code == "W0004") || fa.checked.program.consts.len() == 2
    );
}

/// A rename started in the imported file is checked in every importer
/// as one started there is: a global of the new name there, or a
/// production there binding it (which would capture the use), refuses it.
#[test]
fn rename_from_an_imported_file_is_checked_in_its_importers() {
    let mut a = Analysis::new(Arc::new(MemLoader::new()));
    let lib = "const K = 2;\n";
    let main = "import \"lib.grm\";\nconst vr = 1;\nsystem S {\n    axiom A(1);\n    A(n) -> F(K * n);\n}\n";
    a.set_document(Path::new("lib.grm"), 1, lib);
    a.set_document(Path::new("main.grm"), 1, main);
    let k = at(lib, "K", 0, 0);
    let e = a.rename(Path::new("lib.grm"), k, "vr").unwrap_err();
    assert!(
        e.0.contains("already defined") && e.0.contains("main.grm"),
        "{e}"
    );
    let e = a.rename(Path::new("lib.grm"), k, "n").unwrap_err();
    assert!(e.0.contains("binds `n`"), "{e}");
    // Started from the importer, the same refusals.
    let use_k = at(main, "K *", 0, 0);
    assert!(a.rename(Path::new("main.grm"), use_k, "vr").is_err());
    assert!(a.rename(Path::new("main.grm"), use_k, "n").is_err());
    // A free name renames both files.
    let edits = a.rename(Path::new("lib.grm"), k, "Scale").unwrap();
    assert_eq!(edits.len(), 2);
}

#[test]
fn rename_validity() {
    let fa = analyze(PLANT);
    assert!(fa.prepare_rename(at(PLANT, "F(l)", 0, 0)).is_err());
    assert!(fa.prepare_rename(at(PLANT, "iterations", 0, 0)).is_err());
    let (span, text) = fa.prepare_rename(at(PLANT, "A(1)", 0, 0)).unwrap();
    assert_eq!(text, "A");
    assert_eq!(span.len(), 1);
    let mut a = Analysis::new(Arc::new(MemLoader::new()));
    a.set_document(Path::new("main.grm"), 1, PLANT);
    let p = Path::new("main.grm");
    let a_at = at(PLANT, "A(1)", 0, 0);
    assert!(a.rename(p, a_at, "F").is_err(), "terminal name");
    assert!(a.rename(p, a_at, "B").is_err(), "existing symbol");
    assert!(a.rename(p, a_at, "axiom").is_err(), "keyword");
    assert!(a.rename(p, a_at, "two words").is_err(), "not a name");
    let ok = a.rename(p, a_at, "Apex").unwrap();
    assert_eq!(ok[0].edits.len(), 6);
    // A binding may not be renamed to a global it would hide.
    let l_at = at(PLANT, "l) :", 0, 0);
    assert!(a.rename(p, l_at, "SHRINK").is_err());
    assert_eq!(a.rename(p, l_at, "len").unwrap()[0].edits.len(), 5);
    // A constant may not be captured by a binding.
    assert!(a.rename(p, at(PLANT, "SHRINK", 0, 0), "l").is_err());
}

#[test]
fn completion_by_context() {
    let text = "const K = 1;\nsystem S {\n    axiom A(1);\n    A(len) : len > 0 -> F(le) A(len * K) ;\n    \n}\n";
    let fa = analyze(text);
    let labels =
        |o: u32| -> Vec<String> { fa.completion(o).into_iter().map(|c| c.label).collect() };
    // In a module argument: bindings, constants, functions.
    let l = labels(at(text, "le)", 0, 2));
    assert!(l.contains(&"len".to_string()), "{l:?}");
    assert!(l.contains(&"K".to_string()), "{l:?}");
    assert!(l.contains(&"uniform".to_string()), "{l:?}");
    assert!(!l.contains(&"iterations".to_string()), "{l:?}");
    // In the successor: symbols and turtle commands.
    let l = labels(at(text, "A(len * K)", 0, 0));
    assert!(
        l.contains(&"A".to_string()) && l.contains(&"F".to_string()),
        "{l:?}"
    );
    assert!(l.contains(&"cylinder".to_string()), "{l:?}");
    // At a statement start: settings, keywords, the production snippet.
    let l = labels(at(text, "    \n}", 0, 4));
    assert!(l.contains(&"iterations".to_string()), "{l:?}");
    assert!(l.contains(&"axiom".to_string()), "{l:?}");
    assert!(l.contains(&"production".to_string()), "{l:?}");
    // At the top level: item keywords.
    let l = labels(0);
    assert!(
        l.contains(&"system".to_string()) && l.contains(&"import".to_string()),
        "{l:?}"
    );
}

fn labels_at(fa: &FileAnalysis, offset: u32) -> Vec<String> {
    fa.completion(offset).into_iter().map(|c| c.label).collect()
}

/// The labels at `offset`, sorted.
fn sorted_labels_at(fa: &FileAnalysis, offset: u32) -> Vec<String> {
    let mut l = labels_at(fa, offset);
    l.sort();
    l
}

#[test]
fn completion_offers_nothing_for_a_system_name() {
    let text = "system Other { axiom B; B -> F; }\nsystem Tree {\n    axiom A;\n    A -> F A;\n}\n";
    let fa = analyze(text);
    for o in [
        at(text, "Tree", 0, 0),
        at(text, "Tree", 0, 2),
        at(text, "Tree", 0, 4),
    ] {
        let l = labels_at(&fa, o);
        assert!(l.is_empty(), "{o}: {l:?}");
    }
    // Typed with no body yet.
    let text = "system Tr";
    let fa = analyze(text);
    assert!(labels_at(&fa, 9).is_empty());
    // Right after the brace the body starts.
    let text = "system Tree { axiom A; A -> F A; }";
    let fa = analyze(text);
    let l = labels_at(&fa, at(text, "{", 0, 1));
    assert!(l.contains(&"axiom".to_string()), "{l:?}");
}

#[test]
fn completion_in_declarations_offers_undeclared_symbols() {
    let text = "system S {\n    mode = sample;\n    skeleton branch;\n    geometry ;\n    module A(len: float);\n    axiom branch;\n    branch -> F [ + branch ] leaf A(1) B;\n    wrapup branch -> leaf;\n    leaf -> ;\n    A(l) -> ;\n    B -> ;\n}\n";
    let fa = analyze(text);
    // `geometry |`: user symbols without a phase yet, no terminals.
    let l = sorted_labels_at(&fa, at(text, "geometry ", 0, 9));
    assert_eq!(l, ["A", "B", "leaf"]);
    // `skeleton |` before the name already there: that name is the word at
    // the cursor, the others are already declared or phase-less.
    let l = labels_at(&fa, at(text, "skeleton ", 0, 9));
    assert!(
        !l.contains(&"F".to_string()) && !l.contains(&"[".to_string()),
        "{l:?}"
    );
    assert!(l.contains(&"leaf".to_string()), "{l:?}");
    // `module |`: symbols in no declaration at all.
    let text2 = text.replace("module A(len: float);", "module ;");
    let fa2 = analyze(&text2);
    let l = sorted_labels_at(&fa2, at(&text2, "module ", 0, 7));
    assert_eq!(l, ["A", "B", "leaf"]);
    // Names already in the list being written, parsed or not, are left
    // out, and the partial word itself is not proposed.
    let text3 = text.replace("geometry ;", "geometry leaf, A, l");
    let fa3 = analyze(&text3);
    let l = labels_at(&fa3, at(&text3, "A, l", 0, 4));
    assert_eq!(l, ["B"]);
    let text4 = text.replace("geometry ;", "geometry leaf, ");
    let fa4 = analyze(&text4);
    let l = sorted_labels_at(&fa4, at(&text4, "leaf, ", 0, 6));
    assert_eq!(l, ["A", "B"]);
    // A declared signature's parameter list takes names and types.
    let l = labels_at(&fa, at(text, "len: float", 0, 0));
    assert!(l.is_empty(), "{l:?}");
    let l = labels_at(&fa, at(text, "float)", 0, 0));
    assert!(l.is_empty(), "{l:?}");
    // The axiom and successors still take any module.
    let l = labels_at(&fa, at(text, "leaf A(1)", 0, 0));
    assert!(
        l.contains(&"F".to_string()) && l.contains(&"branch".to_string()),
        "{l:?}"
    );
    // Half-written declarations: any offset is fine.
    for t in [
        "system S { skeleton",
        "system S { module A(x: , B) ), C; geometry ,, (",
        "system S { skeleton ] F [; A -> ",
    ] {
        let fa = analyze(t);
        for o in 0..=t.len() as u32 {
            let _ = fa.completion(o);
        }
    }
}

#[test]
fn completion_in_a_global_value_leaves_out_cycles() {
    let text = "const A = K * 2;\nconst B = A + 1;\nconst C = 3;\nparam p = 1 in 0 .. 2;\nparam q = K in 0 .. 5;\nconst K = 2;\nconst L = C;\n";
    let fa = analyze(text);
    // K's value: not K, nor A, B, q (defined through K).
    let l = labels_at(&fa, at(text, "K = 2", 0, 4));
    for n in ["K", "A", "B", "q"] {
        assert!(!l.contains(&n.to_string()), "{n}: {l:?}");
    }
    for n in ["C", "p", "L", "sin"] {
        assert!(l.contains(&n.to_string()), "{n}: {l:?}");
    }
    // Before the value is there (the statement does not parse yet).
    let text2 = text.replace("const K = 2;", "const K = ");
    let fa2 = analyze(&text2);
    let l = labels_at(&fa2, at(&text2, "K = ", 0, 4));
    assert!(!l.contains(&"K".to_string()), "{l:?}");
    assert!(l.contains(&"C".to_string()), "{l:?}");
    // A meta-parameter's range too; elsewhere every global is offered.
    let l = labels_at(&fa, at(text, "0 .. 5", 0, 5));
    assert!(!l.contains(&"q".to_string()), "{l:?}");
    assert!(
        l.contains(&"K".to_string()) && l.contains(&"p".to_string()),
        "{l:?}"
    );
    let l = labels_at(&fa, at(text, "C;", 0, 0));
    assert!(
        !l.contains(&"L".to_string()) && l.contains(&"K".to_string()),
        "{l:?}"
    );
}

#[test]
fn completion_offers_nothing_for_pattern_parameters() {
    let text = "const K = 1;\nsystem S {\n    axiom A(1);\n    B(u) < A(len, w) > C(v) : len > (K) -> F(len);\n}\n";
    let fa = analyze(text);
    for (needle, d) in [
        ("len, w", 0),
        ("len, w", 3),
        ("w)", 0),
        ("u)", 0),
        ("v)", 1),
    ] {
        let l = labels_at(&fa, at(text, needle, 0, d));
        assert!(l.is_empty(), "{needle}+{d}: {l:?}");
    }
    // While the pattern is typed.
    let text2 = "system S {\n    axiom A(1);\n    A(";
    let fa2 = analyze(text2);
    assert!(labels_at(&fa2, text2.len() as u32).is_empty());
    // The condition and the successor's arguments are expressions.
    let l = labels_at(&fa, at(text, "K) ->", 0, 0));
    assert!(
        l.contains(&"len".to_string()) && l.contains(&"K".to_string()),
        "{l:?}"
    );
    let l = labels_at(&fa, at(text, "len);", 0, 0));
    assert!(
        l.contains(&"len".to_string()) && l.contains(&"sin".to_string()),
        "{l:?}"
    );
}

#[test]
fn signature_help_for_builtins_and_terminals() {
    let text = "system S { axiom A; A -> F(mix(1, 2, 0.5)) cylinder(1, 2); }";
    let fa = analyze(text);
    let s = fa.signature_help(at(text, "2, 0.5", 0, 0)).unwrap();
    assert_eq!(s.signatures[0].label, "mix(a: T, b: T, t: float) -> T");
    assert_eq!(s.active_parameter, 1);
    let s = fa.signature_help(at(text, "2); }", 0, 0)).unwrap();
    assert_eq!(s.signatures[0].label, "cylinder(r: float, h: float)");
    assert_eq!(s.active_parameter, 1);
    assert!(fa.signature_help(at(text, "axiom", 0, 0)).is_none());
}

#[test]
fn document_symbols_nest_systems() {
    let fa = analyze(PLANT);
    let s = fa.document_symbols();
    let names: Vec<&str> = s.iter().map(|n| n.name.as_str()).collect();
    assert_eq!(names, ["SHRINK", "spread", "Plant"]);
    let plant = &s[2];
    assert_eq!(plant.kind, SymbolKind::System);
    let kids: Vec<(&str, SymbolKind)> = plant
        .children
        .iter()
        .map(|c| (c.name.as_str(), c.kind))
        .collect();
    assert_eq!(kids[0], ("iterations", SymbolKind::Setting));
    assert_eq!(kids[2], ("axiom", SymbolKind::Axiom));
    assert_eq!(kids[3], ("A(l) : l > 0.1", SymbolKind::Production));
    assert_eq!(kids.len(), 6);
}

#[test]
fn workspace_symbols_search_open_documents() {
    let mut a = Analysis::new(Arc::new(MemLoader::new()));
    a.set_document(Path::new("a.grm"), 1, PLANT);
    a.set_document(Path::new("b.grm"), 1, "system Other { axiom Apex; }");
    let found: Vec<String> = a
        .workspace_symbols("pl")
        .into_iter()
        .map(|s| s.name)
        .collect();
    assert_eq!(found, ["Plant"]);
    let found = a.workspace_symbols("ap");
    assert_eq!(found.len(), 1);
    assert_eq!(found[0].container.as_deref(), Some("Other"));
}

#[test]
fn semantic_tokens_classify_every_token() {
    let fa = analyze(PLANT);
    let toks = fa.semantic_tokens();
    let kind_of = |needle: &str, n: usize| {
        let o = at(PLANT, needle, n, 0);
        toks.iter().find(|t| t.span.start == o).map(|t| t.kind)
    };
    assert_eq!(kind_of("// Branch", 0), Some(TokenKind::Comment));
    assert_eq!(kind_of("const", 0), Some(TokenKind::Keyword));
    assert_eq!(kind_of("SHRINK", 1), Some(TokenKind::Constant));
    assert_eq!(kind_of("spread", 1), Some(TokenKind::MetaParameter));
    assert_eq!(kind_of("Plant", 0), Some(TokenKind::System));
    assert_eq!(kind_of("iterations", 0), Some(TokenKind::Property));
    assert_eq!(kind_of("A(1)", 0), Some(TokenKind::Module));
    assert_eq!(kind_of("F(l)", 0), Some(TokenKind::Turtle));
    assert_eq!(kind_of("+ A", 0), Some(TokenKind::Turtle));
    assert_eq!(kind_of("+ 0.25", 0), Some(TokenKind::Operator));
    assert_eq!(kind_of("l) :", 0), Some(TokenKind::Parameter));
    assert_eq!(kind_of("sin", 0), Some(TokenKind::Function));
    assert_eq!(kind_of("0.1", 0), Some(TokenKind::Number));
    assert_eq!(kind_of("->", 0), Some(TokenKind::Operator));
    assert_eq!(kind_of(";", 0), Some(TokenKind::Punctuation));
    // Every token is there once, in order, without overlap.
    assert!(toks.windows(2).all(|w| w[0].span.end <= w[1].span.start));
    assert!(!toks.iter().any(|t| t.kind == TokenKind::Unresolved));
}

#[test]
fn inlay_hints_probabilities_and_types() {
    let fa = analyze(PLANT);
    let hints = fa.inlay_hints(Span::new(0, PLANT.len() as u32));
    let labels: Vec<&str> = hints.iter().map(|h| h.label.as_str()).collect();
    assert!(
        labels.contains(&"66.7%") && labels.contains(&"33.3%"),
        "{labels:?}"
    );
    assert_eq!(
        labels.iter().filter(|l| **l == ": float").count(),
        4,
        "{labels:?}"
    );
    let p = hints.iter().find(|h| h.label == "66.7%").unwrap();
    assert_eq!(p.offset, at(PLANT, "(2)", 0, 3));
}

#[test]
fn folding_ranges() {
    let text = "/* a\n b */\n// one\n// two\nmaterial m {\n  roughness = 1;\n}\nsystem S {\n  axiom F;\n}\n";
    let fa = analyze(text);
    let kinds: Vec<(FoldKind, u32)> = fa
        .folding_ranges()
        .iter()
        .map(|f| (f.kind, f.span.start))
        .collect();
    assert_eq!(
        kinds,
        [
            (FoldKind::Comment, 0),
            (FoldKind::Comment, at(text, "// one", 0, 0)),
            (FoldKind::Region, at(text, "material", 0, 0)),
            (FoldKind::Region, at(text, "system", 0, 0)),
        ]
    );
}

fn apply(text: &str, edits: &[TextEdit]) -> String {
    let mut edits = edits.to_vec();
    edits.sort_by_key(|e| std::cmp::Reverse(e.span.start));
    let mut s = text.to_string();
    for e in edits {
        s.replace_range(e.span.range(), &e.new_text);
    }
    s
}

/// Apply the first fix for `code` and return the new text and its diagnostics' codes.
fn fix(text: &str, code: &str, title_has: &str) -> (String, Vec<&'static str>) {
    let fa = analyze(text);
    let all = fa.code_actions(Span::new(0, text.len() as u32));
    let a = all
        .iter()
        .find(|a| a.code == code && a.title.contains(title_has))
        .unwrap_or_else(|| panic!("no fix for {code} in {all:?}\n{:?}", fa.diagnostics()));
    let out = apply(text, &a.edits);
    let codes = analyze(&out).diagnostics().iter().map(|d| d.code).collect();
    (out, codes)
}

#[test]
fn code_actions_fix_their_diagnostics() {
    // Unknown name with a suggestion.
    let (t, c) = fix(
        "const SHRINK = 1;\nsystem S { axiom F(SHRNK); }",
        "E0101",
        "Replace",
    );
    assert!(t.contains("F(SHRINK)"), "{t}");
    assert!(c.is_empty(), "{c:?}");
    // An unreachable production whose symbol is misspelt where it is
    // written: the written name is replaced, not the production's.
    let (t, c) = fix(
        "system S {\n    axiom Plant;\n    plant -> F plant;\n}",
        "W0002",
        "Replace with `plant`",
    );
    assert_eq!(t, "system S {\n    axiom plant;\n    plant -> F plant;\n}");
    assert!(c.is_empty(), "{c:?}");
    // Another notation's operators in a condition.
    let (t, c) = fix(
        "system S {\n    axiom A(1);\n    A(t) : t = 5 -> B;\n}",
        "E0001",
        "`==`",
    );
    assert!(t.contains("A(t) : t == 5 -> B;"), "{t}");
    assert!(c.is_empty(), "{c:?}");
    let (t, c) = fix(
        "system S {\n    axiom A(1);\n    A(t) : t > 0 and t < 5 -> B;\n}",
        "E0001",
        "`&&`",
    );
    assert!(t.contains("t > 0 && t < 5"), "{t}");
    assert!(c.is_empty(), "{c:?}");
    // Python's `not`: its operand wrapped, up to `&&`/`||` or the arrow.
    let (t, c) = fix(
        "system S {\n    axiom X(1);\n    X(t) : not t > 5 -> F X(t + 1);\n}",
        "E0001",
        "`!(...)`",
    );
    assert!(t.contains("X(t) : !(t > 5) -> F"), "{t}");
    assert!(c.is_empty(), "{c:?}\n{t}");
    let (t, c) = fix(
        "system S {\n    axiom X(1);\n    X(t) : t > 1 && not t > 5 && t < 9 -> F X(t + 1);\n}",
        "E0001",
        "`!(...)`",
    );
    assert!(t.contains("t > 1 && !(t > 5) && t < 9 ->"), "{t}");
    assert!(c.is_empty(), "{c:?}\n{t}");
    // `not (...)`, read as a call.
    let (t, c) = fix(
        "system S {\n    axiom X(1);\n    X(t) : t > 1 && not (t > 5) -> F X(t + 1);\n}",
        "E0103",
        "`!`",
    );
    assert!(t.contains("t > 1 && ! (t > 5) ->"), "{t}");
    assert!(c.is_empty(), "{c:?}\n{t}");
    // Missing `;`.
    let (t, c) = fix("system S {\n    axiom F\n    F -> F F;\n}", "E0001", "`;`");
    assert!(t.contains("axiom F;"), "{t}");
    assert!(c.is_empty(), "{c:?}");
    // Unused parameter.
    let (t, c) = fix("system S { axiom A(1); A(x) -> F; }", "W0001", "_");
    assert!(t.contains("A(_x)"), "{t}");
    assert!(c.is_empty(), "{c:?}");
    // Unknown setting.
    let (t, c) = fix("system S { iteration = 2; axiom F; }", "E0105", "Replace");
    assert!(t.contains("iterations = 2"), "{t}");
    assert!(c.is_empty(), "{c:?}");
    // Missing wrap-up.
    let sample =
        "system T {\n    mode = sample;\n    axiom b;\n    skeleton b;\n    b -> F b;\n}\n";
    let (t, c) = fix(sample, "E0306", "wrapup");
    assert!(t.contains("    wrapup b -> ;\n}"), "{t}");
    assert!(c.is_empty(), "{c:?}\n{t}");
    // Missing phase.
    let sample = "system T {\n    mode = sample;\n    axiom b;\n    skeleton b;\n    b -> F b c;\n    wrapup b -> ;\n    c -> F;\n}\n";
    let (t, c) = fix(sample, "E0304", "geometry");
    assert!(t.contains("geometry c;"), "{t}");
    assert!(c.is_empty(), "{c:?}\n{t}");
    let (t, _) = fix(sample, "E0304", "skeleton");
    assert!(t.contains("skeleton b, c;"), "{t}");
    // A symbol that emits geometry and ends a wrap-up can only be a
    // geometry symbol: that fix comes first and is the preferred one.
    let sample = "system T {\n    mode = sample;\n    axiom b;\n    skeleton b;\n    b -> F(1) leaf b;\n    wrapup b -> leaf;\n    leaf -> sphere(0.2);\n}\n";
    let fa = analyze(sample);
    let fixes: Vec<_> = fa
        .code_actions(Span::new(0, sample.len() as u32))
        .into_iter()
        .filter(|a| a.code == "E0304")
        .collect();
    assert_eq!(fixes.len(), 2, "{fixes:?}");
    assert!(
        fixes[0].title.contains("as geometry") && fixes[0].preferred,
        "{fixes:?}"
    );
    assert!(!fixes[1].preferred, "{fixes:?}");
    let (t, c) = fix(sample, "E0304", "geometry");
    assert!(t.contains("geometry leaf;"), "{t}");
    assert!(c.is_empty(), "{c:?}\n{t}");
    // A phase in a derive system: `module` keeps the declaration.
    let (t, c) = fix(
        "system S {\n    axiom A;\n    skeleton A;\n    A -> F A;\n}",
        "W0006",
        "`module`",
    );
    assert!(t.contains("    module A;\n"), "{t}");
    assert!(c.is_empty(), "{c:?}\n{t}");
    // Missing axiom.
    let (t, c) = fix("system S {\n    A -> F A;\n}", "E0310", "axiom");
    assert!(t.contains("    axiom A;\n    A -> F A;"), "{t}");
    assert!(c.is_empty(), "{c:?}\n{t}");
    // Duplicate setting.
    let (t, c) = fix(
        "system S {\n    angle = 1;\n    angle = 2;\n    axiom F;\n}",
        "E0106",
        "Remove",
    );
    assert_eq!(t, "system S {\n    angle = 1;\n    axiom F;\n}");
    assert!(c.is_empty(), "{c:?}");
    // Unknown type, function, material property and field.
    let (t, c) = fix(
        "const A: flot = 1;\nsystem S { axiom F(A); }",
        "E0104",
        "Replace",
    );
    assert!(t.contains("A: float"), "{t}");
    assert!(c.is_empty(), "{c:?}");
    let (t, c) = fix("system S { axiom F(sinn(1)); }", "E0103", "Replace");
    assert!(t.contains("F(sin(1))"), "{t}");
    assert!(c.is_empty(), "{c:?}");
    let (t, c) = fix(
        "material m { rougness = 1; }\nsystem S { axiom material(m); }",
        "E0108",
        "Replace",
    );
    assert!(t.contains("roughness = 1"), "{t}");
    assert!(c.is_empty(), "{c:?}");
    let (t, c) = fix("system S { axiom F(rgb(1, 0, 0).r); }", "E0107", ".x");
    assert!(t.contains("rgb(1, 0, 0).x"), "{t}");
    assert!(c.is_empty(), "{c:?}");
    // Ambiguous unweighted alternatives: the implicit weights written out.
    let (t, c) = fix(
        "system S {\n    axiom A;\n    A -> F A;\n    A -> F F A;\n}",
        "W0005",
        "weights",
    );
    assert!(t.contains("A -> (1) F A;\n    A -> (1) F F A;"), "{t}");
    assert!(c.is_empty(), "{c:?}");
    // A material value outside 0..1: the value the model uses written in.
    let (t, c) = fix(
        "material m { emissive = rgb(2, 0.5, -1); }\nsystem S { axiom material(m) F; }",
        "W0010",
        "Replace",
    );
    assert!(t.contains("emissive = rgb(1, 0.5, 0);"), "{t}");
    assert!(c.is_empty(), "{c:?}");
    // A colour on a 0..255 scale: divided by 255.
    let (t, c) = fix(
        "system S { axiom color(255, 128, 0) F; }",
        "W0010",
        "Replace",
    );
    assert!(t.contains("axiom color(1, 0.502, 0) F;"), "{t}");
    assert!(c.is_empty(), "{c:?}");
    // ... but not where it depends on a meta-parameter.
    let fa =
        analyze("param p = 2;\nmaterial m { metallic = p; }\nsystem S { axiom material(m) F; }");
    let all = fa.code_actions(Span::new(0, 80));
    assert!(fa.diagnostics().iter().any(|d| d.code == "W0010"));
    assert!(all.iter().all(|a| a.code != "W0010"), "{all:?}");
    // Arrows of other tools.
    for arrow in ["=>", "\u{2192}"] {
        let (t, c) = fix(
            &format!("system S {{\n    axiom F;\n    F {arrow} F F;\n}}"),
            if arrow == "=>" { "E0001" } else { "E0003" },
            "->",
        );
        assert!(t.contains("F -> F F;"), "{t}");
        assert!(c.is_empty(), "{c:?}");
    }
    // A misspelt statement keyword inside a system, and ABoP's axiom.
    let (t, c) = fix(
        "system S {\n    mode = sample;\n    axiom a;\n    skeleon a;\n    a -> F a;\n    wrapup a -> ;\n}",
        "E0001",
        "Replace",
    );
    assert!(t.contains("    skeleton a;"), "{t}");
    assert!(c.is_empty(), "{c:?}");
    for axiom in ["\u{3c9}:", "axiom:", "w:"] {
        let (t, c) = fix(
            &format!("system S {{\n    {axiom} F A(1);\n    F -> F F;\n}}"),
            "E0001",
            "axiom",
        );
        assert!(t.contains("    axiom F A(1);"), "{t}");
        assert!(c.is_empty(), "{c:?}");
    }
    // A declaration written inside a system: moved above it, dedented.
    let (t, c) = fix(
        "system S {\n    param size = 2;\n    axiom F(size);\n    material m {\n        roughness = 1;\n    }\n}\n",
        "E0007",
        "Move",
    );
    assert_eq!(
        t,
        "param size = 2;\n\nsystem S {\n    axiom F(size);\n    material m {\n        roughness = 1;\n    }\n}\n"
    );
    assert_eq!(c, ["E0007"], "{t}");
    let (t, c) = fix(&t, "E0007", "Move");
    assert_eq!(
        t,
        "param size = 2;\n\nmaterial m {\n    roughness = 1;\n}\n\nsystem S {\n    axiom F(size);\n}\n"
    );
    assert!(c.is_empty(), "{c:?}\n{t}");
    // Modules written without spaces, as the books print them: every
    // occurrence spaced out (the E0101 of a sample system too).
    let (t, c) = fix(
        "system S {\n    axiom FF;\n    F -> FF + F;\n}",
        "W0011",
        "Replace",
    );
    assert_eq!(t, "system S {\n    axiom F F;\n    F -> F F + F;\n}");
    assert!(c.is_empty(), "{c:?}");
    let (t, c) = fix(
        "system T {\n    mode = sample;\n    axiom b;\n    skeleton b;\n    b -> F bF;\n    wrapup b -> ;\n}",
        "E0101",
        "Replace",
    );
    assert!(t.contains("b -> F b F;"), "{t}");
    assert!(c.is_empty(), "{c:?}\n{t}");
    // Unterminated string.
    let (t, _) = fix("import \"lib.grm;\n", "E0004", "Close");
    assert_eq!(t, "import \"lib.grm\";\n");
    // A wrap-up in a derive system.
    let (t, c) = fix(
        "system S {\n    axiom A;\n    A -> F;\n    wrapup A -> ;\n}",
        "E0309",
        "Remove",
    );
    assert_eq!(t, "system S {\n    axiom A;\n    A -> F;\n}");
    assert!(c.is_empty(), "{c:?}");
}

/// Fixes that delete or insert whole lines find the lines of a file with
/// old Mac (lone `\r`) or Windows line endings, and end inserted lines as
/// the file ends its lines.
#[test]
fn code_actions_on_lone_carriage_return_and_crlf_lines() {
    for nl in ["\r", "\r\n", "\n"] {
        let l = |s: &str| s.replace('\n', nl);
        let (t, c) = fix(
            &l("system S {\n    angle = 1;\n    angle = 2;\n    axiom F;\n}"),
            "E0106",
            "Remove",
        );
        assert_eq!(
            t,
            l("system S {\n    angle = 1;\n    axiom F;\n}"),
            "{nl:?}"
        );
        assert!(c.is_empty(), "{nl:?}: {c:?}");
        let (t, c) = fix(
            &l("system S {\n    axiom A;\n    A -> F;\n    wrapup A -> ;\n}"),
            "E0309",
            "Remove",
        );
        assert_eq!(t, l("system S {\n    axiom A;\n    A -> F;\n}"), "{nl:?}");
        assert!(c.is_empty(), "{nl:?}: {c:?}");
        let (t, c) = fix(&l("system S {\n    A -> F A;\n}"), "E0310", "axiom");
        assert_eq!(t, l("system S {\n    axiom A;\n    A -> F A;\n}"), "{nl:?}");
        assert!(c.is_empty(), "{nl:?}: {c:?}");
    }
}

#[test]
fn formatting() {
    let fa = analyze("system S{axiom F;F->F F;}");
    let e = fa.format().unwrap().unwrap();
    assert_eq!(e.new_text, "system S {\n    axiom F;\n    F -> F F;\n}\n");
    let fa = analyze(&e.new_text);
    assert_eq!(fa.format(), Ok(None));
    let fa = analyze("system S { axiom F F -> ; ");
    assert!(fa.format().is_err());
}

#[test]
fn caching_by_version_and_imports() {
    let mut a = Analysis::new(Arc::new(MemLoader::new()));
    let p = Path::new("main.grm");
    a.set_document(Path::new("lib.grm"), 1, "const K = 1;");
    a.set_document(p, 1, "import \"lib.grm\";\nsystem S { axiom F(K); }");
    let one = a.analyze(p).unwrap();
    let again = a.analyze(p).unwrap();
    assert!(Arc::ptr_eq(&one, &again), "same version: cached");
    // A client reusing a version number with new text is still seen.
    a.set_document(p, 1, "import \"lib.grm\";\nsystem S { axiom F(K) F(K); }");
    let reused = a.analyze(p).unwrap();
    assert!(!Arc::ptr_eq(&one, &reused));
    assert!(reused.text().contains("F(K) F(K)"));
    // Unrelated documents keep their cached analysis.
    a.set_document(Path::new("other.grm"), 1, "system O { axiom F; }");
    assert!(Arc::ptr_eq(&reused, &a.analyze(p).unwrap()));
    a.set_document(Path::new("lib.grm"), 2, "const J = 1;");
    let two = a.analyze(p).unwrap();
    assert!(!Arc::ptr_eq(&one, &two), "an import changed: re-checked");
    assert!(two.diagnostics().iter().any(|d| d.code == "E0101"));
    // A missing import that gets opened later.
    a.set_document(p, 2, "import \"new.grm\";\nsystem S { axiom F(N); }");
    assert!(
        a.analyze(p)
            .unwrap()
            .diagnostics()
            .iter()
            .any(|d| d.code == "E0401")
    );
    a.set_document(Path::new("new.grm"), 1, "const N = 2;");
    assert!(a.analyze(p).unwrap().diagnostics().is_empty());
}

#[test]
fn utf16_positions_in_locations() {
    let text = "const Ä𝔸 = 1;\nsystem S { axiom F(Ä𝔸); }";
    let fa = analyze(text);
    let d = fa.definition(at(text, "Ä𝔸)", 0, 0)).unwrap();
    assert_eq!((d.start.line, d.start.col), (0, 6));
    assert_eq!((d.end.line, d.end.col), (0, 9));
}

#[test]
fn queries_survive_any_offset_and_garbage() {
    let texts = [
        "",
        "system",
        "system S { A -> F( ; }",
        "@@@ \u{0} \"unterminated",
        "/* open",
        PLANT,
        "system S { axiom A(; A(x, -> [ [ ; wrapup",
    ];
    for t in texts {
        let fa = analyze(t);
        for o in 0..=t.len() as u32 + 2 {
            let _ = fa.hover(o);
            let _ = fa.definition(o);
            let _ = fa.references(o, true);
            let _ = fa.completion(o);
            let _ = fa.signature_help(o);
            let _ = fa.prepare_rename(o);
            let _ = fa.code_actions(Span::new(o, o));
        }
        let _ = fa.semantic_tokens();
        let _ = fa.document_symbols();
        let _ = fa.folding_ranges();
        let _ = fa.inlay_hints(Span::new(0, u32::MAX));
        let _ = fa.format();
    }
}

#[test]
fn examples_are_fully_classified_and_queryable() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    let mut n = 0;
    for e in std::fs::read_dir(&dir).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_none_or(|x| x != "grm") {
            continue;
        }
        n += 1;
        let mut a = Analysis::default();
        let text = std::fs::read_to_string(&p).unwrap();
        let p = std::path::absolute(&p).unwrap();
        a.set_document(&p, 1, text.as_str());
        let fa = a.analyze(&p).unwrap();
        assert!(
            !fa.checked.has_errors(),
            "{}: {:?}",
            p.display(),
            fa.diagnostics()
        );
        let unresolved: Vec<&str> = fa
            .semantic_tokens()
            .iter()
            .filter(|t| t.kind == TokenKind::Unresolved)
            .map(|t| &text[t.span.range()])
            .collect();
        assert!(unresolved.is_empty(), "{}: {unresolved:?}", p.display());
        assert!(!fa.document_symbols().is_empty());
        for o in (0..text.len() as u32).step_by(5) {
            let _ = fa.hover(o);
            let _ = fa.completion(o);
            let _ = fa.definition(o);
            let _ = fa.signature_help(o);
        }
        let _ = fa.inlay_hints(Span::new(0, text.len() as u32));
        assert!(fa.format().is_ok(), "{} can be formatted", p.display());
    }
    assert!(n >= 10);
}

#[test]
fn jobs_run_outside_the_host_and_stale_results_are_not_cached() {
    let mut a = Analysis::new(Arc::new(MemLoader::new()));
    let p = Path::new("main.grm");
    a.set_document(p, 1, "system S { axiom F; }");
    let Lookup::Run(job) = a.lookup(p) else {
        panic!("nothing cached yet")
    };
    // The document moves on while the job runs.
    a.set_document(p, 2, "system S { axiom F F; }");
    let old = a.store(job.run().unwrap());
    assert_eq!(old.version, 1);
    // Version 1's result is handed out but not cached: version 2 is computed.
    let new = a.analyze(p).unwrap();
    assert_eq!(new.version, 2);
    assert!(new.text().contains("F F"));
    assert!(matches!(a.lookup(p), Lookup::Ready(fa) if Arc::ptr_eq(&fa, &new)));
}

#[test]
fn a_lone_weight_is_removed_by_its_fix() {
    let (t, c) = fix(
        "system S {\n    axiom A;\n    A -> ( 0.3 ) F A;\n}",
        "W0016",
        "Remove the weight",
    );
    assert_eq!(t, "system S {\n    axiom A;\n    A -> F A;\n}");
    assert!(c.is_empty(), "{c:?}");
}

/// The language server refuses a document larger than a grammar file may
/// be (`grm_sema::MAX_SOURCE_BYTES`, 16 MiB: `grmc check` and `grmc fmt`
/// refuse such a file) with the CLI's E0405 and does not parse it; a
/// document of exactly the limit is analysed. An import of an open
/// document over the limit is refused as the file would be.
#[test]
fn documents_over_the_cli_limit_are_refused() {
    let max = grm_sema::MAX_SOURCE_BYTES as usize;
    assert_eq!(max, 16 << 20);
    // A line comment: cheap to lex, one token.
    let comment = |n: usize| format!("//{}", "x".repeat(n - 2));
    let over = comment(max + 1);
    let fa = analyze(&over);
    let d = fa.diagnostics();
    assert_eq!(d.len(), 1, "{d:?}");
    assert_eq!(d[0].code, "E0405");
    assert!(
        d[0].message
            .contains("it is larger than 16 MiB, the most a grammar file may be"),
        "{}",
        d[0].message
    );
    assert_eq!(d[0].span, Span::new(0, 0));
    assert!(fa.semantic_tokens().is_empty());
    assert!(fa.parsed().comments.is_empty());

    let at_limit = comment(max);
    let fa = analyze(&at_limit);
    assert!(fa.diagnostics().iter().all(|d| d.code != "E0405"));
    assert_eq!(fa.semantic_tokens().len(), 1);

    let mut a = Analysis::new(Arc::new(MemLoader::new()));
    a.set_document(Path::new("big.grm"), 1, over.as_str());
    a.set_document(
        Path::new("main.grm"),
        1,
        "import \"big.grm\";\nsystem S { axiom F; }\n",
    );
    let fa = a.analyze(Path::new("main.grm")).unwrap();
    let d = fa.diagnostics();
    assert!(
        d.iter().any(|d| d.message.contains("larger than 16 MiB")),
        "{d:?}"
    );
}

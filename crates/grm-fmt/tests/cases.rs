//! Focused formatter cases: each input formats to exactly the expected text,
//! and (through `common::check`) the result means the same, keeps every
//! comment and is a fixed point.

mod common;

use common::check;
use grm_diag::FileId;
use grm_syntax::ast::{ExprKind, Item, SystemItem};

fn fmt(src: &str, expected: &str) {
    let out = check(src);
    assert_eq!(
        out, expected,
        "\n--- got ---\n{out}\n--- expected ---\n{expected}"
    );
    // The expected text is itself canonical.
    assert_eq!(check(expected), expected);
}

#[test]
fn spacing_and_one_statement_per_line() {
    fmt(
        "system S{iterations=3;angle = 90 ;axiom F-F;F->F+F;}",
        "system S {\n    iterations = 3;\n    angle = 90;\n    axiom F - F;\n    F -> F + F;\n}\n",
    );
}

#[test]
fn contexts_and_conditions() {
    fmt(
        "system S {\n a b<c(x)>[d]e:x==1->X(x) ;\n A(t):t>5->B;\n a<b->c;\n b>c->d;\n}\n",
        "system S {\n    a b < c(x) > [ d ] e : x == 1 -> X(x);\n    A(t) : t > 5 -> B;\n    a < b -> c;\n    b > c -> d;\n}\n",
    );
}

#[test]
fn weights_and_empty_successors() {
    fmt(
        "system S {\n F->(0.33)F[+F]F;\n F -> (2)  ;\n A->;\n wrapup B->C;\n axiom;\n ignore;\n}\n",
        "system S {\n    F -> (0.33) F [ + F ] F;\n    F -> (2) ;\n    A -> ;\n    wrapup B -> C;\n    axiom;\n    ignore;\n}\n",
    );
}

#[test]
fn double_turtle_commands_are_split() {
    // `&&` and `||` lex as one token; in a module string they are two
    // modules and print as such.
    fmt(
        "system S { A -> F&&F||G; axiom &&; }",
        "system S {\n    A -> F & & F | | G;\n    axiom & &;\n}\n",
    );
    // In an expression they stay operators.
    fmt(
        "const A = true&&false||true;",
        "const A = true && false || true;\n",
    );
}

#[test]
fn polygons_and_punctuation_modules() {
    fmt(
        "system S { P -> {.f.f.}%$|'!\\(10)/(2)^&/ /+(a)-[]; Q -> . .; }",
        "system S {\n    P -> { . f . f . } % $ | ' ! \\(10) /(2) ^ & / / +(a) - [ ];\n    Q -> . .;\n}\n",
    );
}

#[test]
fn punctuation_predecessors_and_ignore() {
    fmt(
        "system S { ignore +-F[]; +->-; !(w)->!(w*2); }",
        "system S {\n    ignore + - F [ ];\n    + -> -;\n    !(w) -> !(w * 2);\n}\n",
    );
}

#[test]
fn strings_keep_their_escapes() {
    fmt(
        "import   \"dir\\\\a \\\"b\\\".grm\" ;\nmesh m=\"x\\ty.obj\";",
        "import \"dir\\\\a \\\"b\\\".grm\";\n\nmesh m = \"x\\ty.obj\";\n",
    );
}

#[test]
fn unicode_identifiers() {
    fmt(
        "system Bäume{Zweig(länge)->Blatt(länge*0.5)F; // Ästchen\naxiom Zweig(1);}",
        "system Bäume {\n    Zweig(länge) -> Blatt(länge * 0.5) F; // Ästchen\n    axiom Zweig(1);\n}\n",
    );
}

#[test]
fn expressions_keep_user_parens_and_literals() {
    fmt(
        "const A=((1+2))*3-(4-5)+-(-x)- -1;\nconst B=1e-3+2.50+007;\nconst C=if a then b else if c then d else e;\nconst D=v.x.y+(v).x+f(a,b,)+g();\nconst E=!(a<b)==c;",
        "const A = ((1 + 2)) * 3 - (4 - 5) + -(-x) - -1;\nconst B = 1e-3 + 2.50 + 007;\nconst C = if a then b else if c then d else e;\nconst D = v.x.y + (v).x + f(a, b) + g();\nconst E = !(a < b) == c;\n",
    );
}

#[test]
fn declarations() {
    fmt(
        "const UP:vec3=vec3(0,1,0);\nparam on : bool = true;\nparam s=30 in 10..60;\nsystem S{module A(len:float,w),B,C();skeleton x,y;geometry z;}",
        "const UP: vec3 = vec3(0, 1, 0);\n\nparam on: bool = true;\nparam s = 30 in 10 .. 60;\n\nsystem S {\n    module A(len: float, w), B, C();\n    skeleton x, y;\n    geometry z;\n}\n",
    );
}

#[test]
fn materials() {
    fmt(
        "material bark{color=rgb(0.45,0.3,0.2);roughness=0.9;}material e{}",
        "material bark {\n    color = rgb(0.45, 0.3, 0.2);\n    roughness = 0.9;\n}\n\nmaterial e {}\n",
    );
}

#[test]
fn blank_lines() {
    // Inside blocks: at most one, kept where there was one or more; none
    // after `{` or before `}`.
    fmt(
        "system S {\n\n\n    A -> B;\n    B -> C;\n\n\n\n    C -> D;\n\n}\n",
        "system S {\n    A -> B;\n    B -> C;\n\n    C -> D;\n}\n",
    );
    // Top level: blocks and different kinds of declarations are separated;
    // the same kind keeps the user's choice.
    fmt(
        "\n\nimport \"a.grm\";\nconst A = 1;\nconst B = 2;\n\n\nconst C = 3;\nsystem S {}\nsystem T {}\n\n\n",
        "import \"a.grm\";\n\nconst A = 1;\nconst B = 2;\n\nconst C = 3;\n\nsystem S {}\n\nsystem T {}\n",
    );
}

#[test]
fn comments_keep_their_places() {
    fmt(
        "// header\n\n// about S\nsystem S { // opens\n  A -> B;   // trailing\n\n  // between\n  B -> C; /* block */\n  /* before */ C -> D;\n  // last\n}\n// end\n",
        "// header\n\n// about S\nsystem S { // opens\n    A -> B; // trailing\n\n    // between\n    B -> C; /* block */\n    /* before */ C -> D;\n    // last\n}\n// end\n",
    );
}

#[test]
fn comments_inside_statements() {
    fmt(
        "system /* a */ S /* b */ {\n A /* d */ -> /* e */ B /* f */ ;\n X -> F // one\n   G // two\n   H;\n}",
        "system /* a */ S /* b */ {\n    A /* d */ -> /* e */ B /* f */;\n    X -> F // one\n         G // two\n         H;\n}\n",
    );
    fmt(
        "const X = f( // open\n 1, /* one */ 2);\nconst Y = 1 + // c\n 2;",
        "const X = f( // open\n    1, /* one */ 2);\nconst Y = 1 + // c\n    2;\n",
    );
}

#[test]
fn line_breaks_between_modules_are_kept() {
    fmt(
        "system S {\n  branch -> scale(0.7)\n     F(1)   leaf\n  trunk;\n}",
        "system S {\n    branch -> scale(0.7)\n              F(1) leaf\n              trunk;\n}\n",
    );
}

#[test]
fn multi_line_block_comments_are_kept_verbatim() {
    fmt(
        "system S {\n/* one\n     two\n   three */\nA -> B;\n}",
        "system S {\n    /* one\n     two\n   three */\n    A -> B;\n}\n",
    );
}

#[test]
fn crlf_and_trailing_whitespace() {
    fmt(
        "system S {\r\n    A -> B; // crlf   \r\n}\r\n",
        "system S {\n    A -> B; // crlf\n}\n",
    );
}

/// A block comment's own line breaks become `\n` like every other one
/// (a CRLF file's block comment kept its `\r\n`s: mixed line endings).
#[test]
fn line_breaks_inside_block_comments_become_newlines() {
    fmt(
        "system S {\r\n    /* a\r\n    b\r    c */\r\n    A -> B;\r\n}\r\n",
        "system S {\n    /* a\n    b\n    c */\n    A -> B;\n}\n",
    );
}

/// Old Mac (lone `\r`) and mixed line endings format as `\n` ones do:
/// comments end at the line break, blank lines are kept, statements and
/// the line breaks of a module string stay on their lines.
#[test]
fn lone_carriage_returns_and_mixed_line_endings() {
    let unix = "// head\n\nconst A = 1; // trailing\n\nsystem S {\n    // own line\n    axiom F\n        F;\n\n    F -> F F; // t\n}\n";
    let expected = check(unix);
    fmt(&unix.replace('\n', "\r"), &expected);
    fmt(&unix.replace('\n', "\r\n"), &expected);
    let mut mixed = String::new();
    for (i, line) in unix.split_inclusive('\n').enumerate() {
        let nl = ["\n", "\r", "\r\n"][i % 3];
        mixed.push_str(line.strip_suffix('\n').unwrap_or(line));
        mixed.push_str(nl);
    }
    fmt(&mixed, &expected);
}

#[test]
fn empty_and_comment_only_files() {
    assert_eq!(check(""), "");
    assert_eq!(check("  \n\n\t\n"), "");
    fmt("\n\n// only\n\n\n", "// only\n");
    fmt("/* a */ /* b */\n// c", "/* a */ /* b */\n// c\n");
}

#[test]
fn syntax_errors_are_refused() {
    for src in [
        "system S { A -> B }",
        "system S { A B; }",
        "system S { A -> B;",
        "const A = ;",
        "const A = 1e999;",
        "@",
        "import \"unterminated;",
        "/* unterminated",
        "A -> B;",
    ] {
        match grm_fmt::format(src) {
            Err(grm_fmt::FormatError::Syntax(diags)) => {
                assert!(!diags.is_empty(), "{src:?}");
                assert!(diags.iter().all(|d| d.is_error()));
                let msg = grm_fmt::FormatError::Syntax(diags).to_string();
                assert!(msg.contains("syntax error"), "{msg}");
            }
            other => panic!("{src:?}: expected a refusal, got {other:?}"),
        }
    }
}

/// A tree that did not come from the parser (here: parentheses taken out)
/// is printed with the parentheses its structure needs.
#[test]
fn synthetic_trees_get_needed_parens() {
    let src = "const A = (a + b) * c;\nconst B = a - (b - c);\nconst C = (-v).x;\nconst D = (if a then b else c) + 1;\nconst E = -(a * b);\nconst F = (a || b) && c;\n";
    let mut parsed = grm_syntax::parse(FileId(0), src);
    assert!(!parsed.has_errors());
    for item in &mut parsed.file.items {
        if let Item::Const(c) = item {
            strip_parens(&mut c.value);
        }
    }
    let out = grm_fmt::format_file(&parsed, src);
    assert_eq!(out, src);
    // And the printed text parses back to the stripped tree, modulo the
    // parentheses that are now explicit again.
    assert!(!grm_syntax::parse(FileId(0), &out).has_errors());
}

fn strip_parens(e: &mut grm_syntax::ast::Expr) {
    while matches!(e.kind, ExprKind::Paren(_)) {
        if let ExprKind::Paren(inner) = std::mem::replace(&mut e.kind, ExprKind::Error) {
            *e = *inner;
        }
    }
    match &mut e.kind {
        ExprKind::Unary { operand, .. } => strip_parens(operand),
        ExprKind::Binary { lhs, rhs, .. } => {
            strip_parens(lhs);
            strip_parens(rhs);
        }
        ExprKind::Field { base, .. } => strip_parens(base),
        ExprKind::If { cond, then, els } => {
            strip_parens(cond);
            strip_parens(then);
            strip_parens(els);
        }
        ExprKind::Call { args, .. } => args.iter_mut().for_each(strip_parens),
        _ => {}
    }
}

#[test]
fn same_tree_ignores_spans_only() {
    let a = grm_syntax::parse(FileId(0), "system S { A -> B C; }");
    let b = grm_syntax::parse(FileId(0), "system   S {\n\n A->B   C;}");
    let c = grm_syntax::parse(FileId(0), "system S { A -> B D; }");
    assert!(grm_fmt::same_tree(&a.file, &b.file));
    assert!(!grm_fmt::same_tree(&a.file, &c.file));
    let Item::System(s) = &a.file.items[0] else {
        panic!("expected a system")
    };
    assert!(matches!(s.items[0], SystemItem::Production(_)));
}

//! Parser behaviour: the whole language parses, and recovery costs one
//! diagnostic per typo.

use grm_diag::{Code, FileId};
use grm_syntax::ast::*;
use grm_syntax::{MAX_EXPR_DEPTH, parse};

fn codes(src: &str) -> Vec<&'static str> {
    parse(FileId(0), src)
        .diagnostics
        .iter()
        .map(|d| d.code.as_str())
        .collect()
}

const FULL: &str = r#"
import "common.grm";
const R = 1.456;
const UP: vec3 = vec3(0, 1, 0);
param spread = 30 in 10 .. 60;
param on: bool = true;
mesh leaf = "leaf.obj";
material bark { color = rgb(0.45, 0.3, 0.2); roughness = 0.9; }
/* a block
   comment */
system Plant {
    mode = derive;
    iterations = 5;
    angle = 25.7;
    tropism = vec3(0, -1, 0);
    ignore + - F;
    axiom X;
    module A(len: float, w), B;
    X -> F [ + X ] F [ - X ] + X;
    F -> (0.5) F F;
    F -> (0.5) F;
    A(l, w) : l > 1 && !(w < 0) -> F(l) A(l * 0.9, if w > 1 then w else -w);
    a < b > [ c ] d : true -> ;
    P -> { . f . f . } % $ | ' ! && || \(10) /(2) ^ & mesh(leaf) material(bark);
    Q -> rotate(UP, spread) translate(1, 2, 3) v(UP.x);
}
system Tree {
    mode = sample;
    axiom branch;
    skeleton branch, bl;
    geometry leaf2;
    branch -> F(1) leaf2 bl;
    wrapup branch -> leaf2;
    leaf2 -> sphere(0.1);
}
"#;

#[test]
fn full_language_parses_clean() {
    let p = parse(FileId(0), FULL);
    assert!(p.diagnostics.is_empty(), "{:#?}", p.diagnostics);
    assert_eq!(p.file.items.len(), 9);
    assert_eq!(p.comments.len(), 1);
    let Item::System(s) = &p.file.items[7] else {
        panic!()
    };
    assert_eq!(s.name.name, "Plant");
    let prods: Vec<&Production> = s
        .items
        .iter()
        .filter_map(|i| {
            if let SystemItem::Production(p) = i {
                Some(p)
            } else {
                None
            }
        })
        .collect();
    assert_eq!(prods.len(), 7);
    // weights
    assert!(prods[1].weight.is_some());
    // context
    assert_eq!(prods[4].left.len(), 1);
    assert_eq!(prods[4].right.len(), 4);
    assert!(prods[4].successor.is_empty());
    // && and || in a module string are two turtle commands each
    let syms: Vec<&str> = prods[5]
        .successor
        .iter()
        .map(|m| m.symbol.name.as_str())
        .collect();
    assert_eq!(
        syms,
        [
            "{", ".", "f", ".", "f", ".", "}", "%", "$", "|", "'", "!", "&", "&", "|", "|", "\\",
            "/", "^", "&", "mesh", "material"
        ]
    );
    let Item::System(t) = &p.file.items[8] else {
        panic!()
    };
    assert!(
        t.items
            .iter()
            .any(|i| matches!(i, SystemItem::Production(p) if p.wrapup))
    );
}

#[test]
fn missing_semicolon_before_brace_is_one_diagnostic() {
    let src = "system S { axiom A; A -> B C }";
    let p = parse(FileId(0), src);
    assert_eq!(codes(src), ["E0001"]);
    let Item::System(s) = &p.file.items[0] else {
        panic!()
    };
    assert_eq!(s.items.len(), 2, "the production is kept");
}

#[test]
fn missing_semicolon_between_lines_is_one_diagnostic() {
    let src = "system S {\n  axiom A;\n  A -> B C\n  B -> A;\n  C -> ;\n}";
    let p = parse(FileId(0), src);
    assert_eq!(codes(src), ["E0001"], "{:#?}", p.diagnostics);
    let Item::System(s) = &p.file.items[0] else {
        panic!()
    };
    assert_eq!(s.items.len(), 4);
}

#[test]
fn broken_statement_costs_one_diagnostic_and_rest_parses() {
    let src = "system S {\n  axiom A;\n  A -> B(1 + );\n  B -> A;\n}\nconst X = 1;";
    let p = parse(FileId(0), src);
    assert_eq!(codes(src), ["E0001"], "{:#?}", p.diagnostics);
    let Item::System(s) = &p.file.items[0] else {
        panic!()
    };
    assert!(matches!(s.items[1], SystemItem::Error(_)));
    assert!(matches!(s.items[2], SystemItem::Production(_)));
    assert!(matches!(p.file.items[1], Item::Const(_)));
}

#[test]
fn unclosed_system_at_eof() {
    let src = "system S {\n  axiom A;\n  A -> B;\n";
    let p = parse(FileId(0), src);
    assert_eq!(p.diagnostics.len(), 1);
    assert_eq!(p.diagnostics[0].code, Code::UnexpectedEof);
    let Item::System(s) = &p.file.items[0] else {
        panic!()
    };
    assert_eq!(s.items.len(), 2);
}

#[test]
fn unclosed_system_before_next_item() {
    let src = "system S {\n  axiom A;\nsystem T { axiom B; }";
    let p = parse(FileId(0), src);
    assert_eq!(codes(src), ["E0001"]);
    assert_eq!(p.file.items.len(), 2);
}

#[test]
fn garbage_at_top_level_is_one_diagnostic() {
    let src = "A -> B;\nC -> D;\nsystem S { axiom A; }";
    assert_eq!(codes(src), ["E0001"]);
}

#[test]
fn garbage_never_panics() {
    let inputs: &[&[u8]] = &[
        b"",
        b"\xff\xfe\x00\x01",
        b"system",
        b"system {",
        b"system S { -> -> ; } } }",
        b"material m { = ; ",
        b"param p = 1 in ;",
        b"const = ;;;;",
        b"\"",
        b"/*",
        b"system S { A -> (((((((( ; }",
        b"system S { axiom { { { ; A -> } } } ; }",
    ];
    for i in inputs {
        let s = String::from_utf8_lossy(i);
        let p = parse(FileId(0), &s);
        if !s.trim().is_empty() && !s.starts_with("/*") {
            assert!(
                !p.diagnostics.is_empty() || !p.file.items.is_empty(),
                "{s:?}"
            );
        }
    }
}

#[test]
fn mesh_terminal_on_its_own_line_stays_in_the_successor() {
    let src = "mesh m = \"a.obj\";\nsystem S {\n  axiom A;\n  A -> [ F\n    mesh(m) ];\n}";
    let p = parse(FileId(0), src);
    assert!(p.diagnostics.is_empty(), "{:#?}", p.diagnostics);
}

#[test]
fn invalid_number_is_reported() {
    assert_eq!(codes("const X = 1e999;"), ["E0006"]);
    // Just past the f32 range (half an ulp above f32::MAX rounds up).
    assert_eq!(codes("const X = 3.4028236e38;"), ["E0006"]);
}

/// Every literal that rounds to a finite 32-bit float is a number: the
/// largest float as Rust prints it (`3.4028235e38`, just above f32::MAX)
/// and as `grmc derive --print` writes it in full.
#[test]
fn the_largest_float_is_a_literal_in_every_spelling() {
    for text in [
        "3.4028235e38",
        "340282350000000000000000000000000000000",
        "-3.4028235e38",
        "1e-50",
    ] {
        assert!(codes(&format!("const X = {text};")).is_empty(), "{text}");
    }
}

#[test]
fn absurdly_deep_expressions_are_refused_not_overflowing() {
    for (open, close) in [("(", ")"), ("-", ""), ("!", "")] {
        let n = 200_000;
        let src = format!(
            "const X = {}1{};\nsystem S {{ axiom A; }}",
            open.repeat(n),
            close.repeat(n)
        );
        let p = parse(FileId(0), &src);
        assert!(
            p.diagnostics.iter().any(|d| d.code == Code::ExprTooDeep),
            "{open}"
        );
        // The statement stays (its name is still defined); the expression
        // is an error node over the same text.
        let Item::Const(c) = &p.file.items[0] else {
            panic!("{:?}", p.file.items[0])
        };
        assert!(matches!(c.value.kind, ExprKind::Error));
        assert_eq!(c.value.span.start, 10);
        assert!(matches!(p.file.items[1], Item::System(_)));
        assert_eq!(p.diagnostics.len(), 1, "{:?}", p.diagnostics);
    }
    let chain = format!("system S {{ axiom F({}1); }}", "1 + ".repeat(100_000));
    let p = parse(FileId(0), &chain);
    assert!(p.diagnostics.iter().any(|d| d.code == Code::ExprTooDeep));
    // Deep but reasonable nesting is fine.
    let ok = format!("const X = {}1{};", "(".repeat(100), ")".repeat(100));
    assert!(parse(FileId(0), &ok).diagnostics.is_empty());
}

#[test]
fn the_depth_limit_is_exact() {
    // `1` is one level, each parenthesis one more.
    let nested = |levels: usize| {
        format!(
            "const X = {}1{};",
            "(".repeat(levels - 1),
            ")".repeat(levels - 1)
        )
    };
    assert!(codes(&nested(MAX_EXPR_DEPTH)).is_empty());
    assert_eq!(codes(&nested(MAX_EXPR_DEPTH + 1)), ["E0211"]);
    let p = parse(FileId(0), &nested(MAX_EXPR_DEPTH + 1));
    assert_eq!(
        p.diagnostics[0].message,
        format!("expression nested more than {MAX_EXPR_DEPTH} levels deep")
    );
}

#[test]
fn every_too_deep_expression_is_reported_once_where_it_is() {
    let deep = format!("{}1{}", "-".repeat(MAX_EXPR_DEPTH), "");
    let srcs = [
        format!("param p = {deep} in 0 .. 1;"),
        format!("param p = 0 in {deep} .. 1;"),
        format!("material m {{ roughness = {deep}; }}"),
        format!("system S {{ angle = {deep}; axiom F; }}"),
        format!("system S {{ axiom F(1) F({deep}); }}"),
        format!("system S {{ axiom A; A : {deep} -> F; }}"),
        format!("system S {{ axiom A; A -> ({deep}) F; }}"),
        format!("system S {{ axiom A; A -> F(1) [ F({deep}) ]; }}"),
    ];
    for src in &srcs {
        let p = parse(FileId(0), src);
        let c: Vec<&str> = p.diagnostics.iter().map(|d| d.code.as_str()).collect();
        assert_eq!(c, ["E0211"], "{:.60}", src);
        // The label is on the part past the limit: the `1`, at level 201.
        let at = src.find(&deep).unwrap() + MAX_EXPR_DEPTH;
        assert_eq!(
            p.diagnostics[0].primary().span,
            grm_diag::Span::new(at as u32, at as u32 + 1),
            "{:.60}",
            src
        );
        assert!(
            !p.file.items.iter().any(|i| match i {
                Item::Error(_) => true,
                Item::System(s) => s.items.iter().any(|i| matches!(i, SystemItem::Error(_))),
                _ => false,
            }),
            "{:.60}",
            src
        );
    }
}

#[test]
fn deep_expressions_in_rejected_or_split_statements_do_not_overflow() {
    let n = 100_000;
    let parens = format!("{}1{}", "(".repeat(n), ")".repeat(n));
    // A syntax error after a complete deep expression: the parser drops the
    // tree it built; the const stays declared with an error value.
    for src in [
        format!("const X = {parens} 2;"),
        format!("const X = {parens});"),
        format!("const X = v{} 1;", ".x".repeat(n)),
        format!("const X = {}1{} 2;", "f(".repeat(n), ")".repeat(n)),
    ] {
        let p = parse(FileId(0), &src);
        assert!(
            matches!(
                &p.file.items[..],
                [Item::Const(c)] if c.name.name == "X" && matches!(c.value.kind, ExprKind::Error)
            ),
            "{:.40}",
            src
        );
        assert!(
            p.diagnostics
                .iter()
                .any(|d| d.code == Code::UnexpectedToken)
        );
    }
    // A missing `;` repaired by splitting the statement at a line break:
    // both halves are checked for depth.
    for src in [
        format!("system S {{ axiom A\nA -> F({parens}); }}"),
        format!("system S {{ axiom F({parens})\nA -> F; }}"),
        format!("system S {{ axiom F(1{})\nA -> F; }}", " + 1".repeat(n)),
    ] {
        let p = parse(FileId(0), &src);
        let c: Vec<Code> = p.diagnostics.iter().map(|d| d.code).collect();
        assert!(c.contains(&Code::ExprTooDeep), "{c:?}");
        assert_eq!(
            c.iter().filter(|c| **c == Code::ExprTooDeep).count(),
            1,
            "{c:?}"
        );
        let Item::System(s) = &p.file.items[0] else {
            panic!()
        };
        // Both statements stay; the deep expression is an error node.
        assert_eq!(s.items.len(), 2);
        assert!(!s.items.iter().any(|i| matches!(i, SystemItem::Error(_))));
    }
}

#[test]
fn operator_precedence_and_associativity() {
    fn show(e: &Expr) -> String {
        match &e.kind {
            ExprKind::Binary { op, lhs, rhs } => {
                format!("({} {} {})", show(lhs), op.as_str(), show(rhs))
            }
            ExprKind::Unary { op, operand } => format!("({}{})", op.as_str(), show(operand)),
            ExprKind::Number { text, .. } => text.to_string(),
            ExprKind::Name(n) => n.name.to_string(),
            ExprKind::Paren(e) => format!("[{}]", show(e)),
            _ => "?".into(),
        }
    }
    let cases = [
        ("1 + 2 * 3", "(1 + (2 * 3))"),
        ("1 - 2 - 3", "((1 - 2) - 3)"),
        ("a * b + c * d", "((a * b) + (c * d))"),
        ("a < b && c >= d || e", "(((a < b) && (c >= d)) || e)"),
        ("a || b && c", "(a || (b && c))"),
        ("a == b != c", "((a == b) != c)"),
        ("-a * b", "((-a) * b)"),
        ("1 + 2 * 3 - 4 / 5 % 6", "((1 + (2 * 3)) - ((4 / 5) % 6))"),
        ("(1 + 2) * 3", "([(1 + 2)] * 3)"),
        ("a + b < c * d == e", "(((a + b) < (c * d)) == e)"),
    ];
    for (src, want) in cases {
        let (e, d) = grm_syntax::parse_expr(FileId(0), src);
        assert!(d.is_empty(), "{src}: {d:?}");
        let e = e.expect("parses");
        assert_eq!(show(&e), want, "{src}");
        assert_eq!(e.span, Span::new(0, src.len() as u32), "{src}");
    }
}

#[test]
fn parse_expr_refuses_absurdly_deep_expressions() {
    let src = format!("{}1{}", "(".repeat(100_000), ")".repeat(100_000));
    let (e, d) = grm_syntax::parse_expr(FileId(0), &src);
    assert!(e.is_none());
    assert!(d.iter().any(|d| d.code == Code::ExprTooDeep), "{d:?}");
}

/// Shape commands read their parts: absolute, percentage and floating
/// sizes, selectors, `nil`; a brace pair without a `:` stays a polygon.
#[test]
fn shape_command_parts() {
    let src = "system H {\n    mode = shape;\n    axiom Lot;\n    \
        F -> split(y, floor) { 4: A | 25%: B | ~ 2 * x: C } { . G . } comp(faces) { front: D | side: nil };\n}\n";
    let parsed = parse(FileId(0), src);
    assert!(parsed.diagnostics.is_empty(), "{:?}", parsed.diagnostics);
    let Item::System(sys) = &parsed.file.items[0] else {
        panic!("a system")
    };
    let prod = sys
        .items
        .iter()
        .find_map(|i| match i {
            SystemItem::Production(p) => Some(p),
            _ => None,
        })
        .expect("a production");
    let names: Vec<&str> = prod.successor.iter().map(|m| &*m.symbol.name).collect();
    assert_eq!(names, ["split", "{", ".", "G", ".", "}", "comp"]);
    let split = prod.successor[0].parts.as_ref().expect("split's parts");
    let kinds: Vec<PartKind> = split.parts.iter().map(|p| p.kind).collect();
    assert_eq!(
        kinds,
        [PartKind::Absolute, PartKind::Relative, PartKind::Floating]
    );
    let targets: Vec<&str> = split.parts.iter().map(|p| &*p.target.name).collect();
    assert_eq!(targets, ["A", "B", "C"]);
    assert_eq!(&src[split.span.range()], "{ 4: A | 25%: B | ~ 2 * x: C }");
    assert_eq!(&src[split.parts[2].value.span.range()], "2 * x");
    assert_eq!(prod.successor[0].args.len(), 2);
    assert!(prod.successor[1].parts.is_none());
    let comp = prod.successor[6].parts.as_ref().expect("comp's cases");
    assert_eq!(comp.parts.len(), 2);
    assert_eq!(&*comp.parts[1].target.name, "nil");
    // `%` elsewhere is still the remainder, and a part with no size is one
    // syntax error, the rest of the system read.
    assert!(codes("system S { X -> F(a % 2) { . }; }").is_empty());
    assert_eq!(
        codes("system S { mode = shape; X -> split(y) { : A | 1: B }; Y -> Z; }").len(),
        1
    );
}

/// `layout NAME { ... }` is an item; `layout` elsewhere is a name; a
/// broken field costs one diagnostic and the rest of the layout, and the
/// items after it, still parse; every prefix of a layout parses (with
/// diagnostics) without failing.
#[test]
fn layout_items_parse_and_recover() {
    let src = "param layout = 2;\nlayout Town {\n  base = grid(4, 3, 80, 60);\n  avenue = lsystem(Streets);\n  buildings = House;\n}\nsystem S { axiom A(layout); }\n";
    let p = parse(FileId(0), src);
    assert!(p.diagnostics.is_empty(), "{:#?}", p.diagnostics);
    assert!(matches!(p.file.items[0], Item::Param(ref d) if &*d.name.name == "layout"));
    let Item::Layout(l) = &p.file.items[1] else {
        panic!("{:#?}", p.file.items[1])
    };
    assert_eq!(&*l.name.name, "Town");
    let keys: Vec<&str> = l.fields.iter().map(|f| &*f.name.name).collect();
    assert_eq!(keys, ["base", "avenue", "buildings"]);
    assert!(matches!(p.file.items[2], Item::System(_)));

    let broken =
        "layout Town {\n  base = grid(4, ;\n  park = geojson(\"p.geojson\");\n}\nconst X = 1;";
    let p = parse(FileId(0), broken);
    assert_eq!(codes(broken), ["E0001"], "{:#?}", p.diagnostics);
    let Item::Layout(l) = &p.file.items[0] else {
        panic!()
    };
    assert_eq!(l.fields.last().map(|f| &*f.name.name), Some("park"));
    assert!(matches!(p.file.items[1], Item::Const(_)));

    for end in 0..=src.len() {
        if src.is_char_boundary(end) {
            let _ = parse(FileId(0), &src[..end]);
        }
    }
}

//! Shape systems (`mode = shape`): what the checker accepts, the checked
//! rules it produces, and the codes of what it refuses.

use grm_sema::shape::{Asset, Axis, CompTarget, LotKind, OpKind, PartKind, Selector};
use grm_sema::*;

fn check(text: &str) -> (SourceMap, Checked) {
    let mut files = MemLoader::new();
    files.add("box.obj", "v 0 0 0");
    files.add(
        "block.geojson",
        r#"{"type":"Polygon","coordinates":[[[0,0],[12,0],[12,4],[4,4],[4,9],[0,9],[0,0]]]}"#,
    );
    files.add(
        "line.geojson",
        r#"{"type":"Polygon","coordinates":[[[0,0],[1,1],[2,2],[0,0]]]}"#,
    );
    files.add("point.geojson", r#"{"type":"Point","coordinates":[1,2]}"#);
    check_with("main.grm", text, &files)
}

fn codes(text: &str) -> Vec<&'static str> {
    let (_, c) = check(text);
    c.diagnostics.iter().map(|d| d.code.as_str()).collect()
}

fn check_ok(text: &str) -> Program {
    let (sources, c) = check(text);
    let rendered: Vec<String> = c
        .diagnostics
        .iter()
        .map(|d| grm_diag::render_plain(d, &sources))
        .collect();
    assert!(c.diagnostics.is_empty(), "{}", rendered.join("\n"));
    c.program
}

fn shape(text: &str) -> String {
    format!("system S {{ mode = shape; axiom A; {text} }}")
}

#[test]
fn the_townhouse_example_checks_clean() {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../examples/townhouse.grm"
    ))
    .unwrap();
    let p = check_ok(&text);
    let sys = &p.systems[0];
    assert_eq!(sys.mode, Mode::Shape);
    assert!(sys.groups.is_empty() && sys.axiom.is_empty());
    let shape = sys.shape.as_ref().unwrap();
    assert_eq!(sys.symbols[shape.axiom.unwrap() as usize].name, "Lot");
    assert!(matches!(shape.lot.kind, LotKind::Rect { .. }));
}

#[test]
fn operations_and_parts_are_checked_into_rules() {
    let p = check_ok(&shape(
        "A -> extrude(3) [ translate(1, 0, 0) ] B; \
         B -> comp(faces, facade) { front: C | side: nil }; \
         C : scope.x > 3 && index == 1 -> (2) split(y, floor) { 4: D | 25%: E | ~1: D }; \
         C -> repeat(x) { ~2: D }; \
         D -> size(_, 2, 0.5) center(xy) insert(box) color(rgb(1, 0, 0));",
    ));
    let sys = &p.systems[0];
    let shape = sys.shape.as_ref().unwrap();
    assert_eq!(shape.rules.len(), 5);
    let a = &shape.rules[0];
    assert!(matches!(a.ops[0].kind, OpKind::Extrude(_)));
    assert!(matches!(a.ops[1].kind, OpKind::Push));
    assert!(matches!(a.ops[3].kind, OpKind::Pop));
    let OpKind::Comp(c) = &shape.rules[1].ops[0].kind else {
        panic!()
    };
    assert_eq!(c.target, CompTarget::Faces);
    assert_eq!(c.tag.as_ref().unwrap().name, "facade");
    assert_eq!(c.cases[0].selector, Selector::Front);
    assert_eq!(c.cases[1].target, None);
    let r = &shape.rules[2];
    assert!(r.condition.is_some() && r.weight_written);
    let OpKind::Split(s) = &r.ops[0].kind else {
        panic!()
    };
    assert_eq!(s.axis, Axis::Y);
    assert_eq!(
        s.parts.iter().map(|p| p.kind).collect::<Vec<_>>(),
        [PartKind::Absolute, PartKind::Relative, PartKind::Floating]
    );
    let OpKind::Size(v) = &shape.rules[4].ops[0].kind else {
        panic!()
    };
    assert!(v[0].is_none() && v[1].is_some());
    assert!(matches!(
        shape.rules[4].ops[2].kind,
        OpKind::Insert(Asset::Primitive(_))
    ));
}

#[test]
fn lots() {
    for lot in [
        "rect(24, 10)",
        "polygon(0, 0, 10, 0, 10, 6, 4, 6, 4, 10, 0, 10)",
        "\"block.geojson\"",
    ] {
        check_ok(&format!(
            "system S {{ mode = shape; lot = {lot}; axiom A; }}"
        ));
    }
    check_ok("param w = 4; system S { mode = shape; lot = rect(w * 2, 10); axiom A; }");
    for (lot, code) in [
        ("rect(0, 10)", "E0509"),
        ("rect(4)", "E0509"),
        ("polygon(0, 0, 1, 1)", "E0509"),
        ("polygon(0, 0, 1, 1, 2, 2)", "E0509"),
        ("polygon(0, 0, 4, 4, 4, 0, 0, 4)", "E0509"),
        ("circle(3)", "E0509"),
        ("3", "E0509"),
        ("\"line.geojson\"", "E0509"),
        ("\"missing.geojson\"", "E0510"),
        ("\"point.geojson\"", "E0510"),
    ] {
        assert_eq!(
            codes(&format!(
                "system S {{ mode = shape; lot = {lot}; axiom A; }}"
            )),
            [code],
            "{lot}"
        );
    }
}

#[test]
fn codes_of_what_is_refused() {
    for (rules, code) in [
        ("A -> extrud(3);", "E0501"),
        ("A -> + B;", "E0501"),
        ("A -> B(3);", "E0502"),
        ("A(x) -> B;", "E0502"),
        ("A -> extrude(1, 2);", "E0503"),
        ("A -> split(w) { 1: B };", "E0504"),
        ("A -> extrude(3) B; B -> comp(faces) { frnt: C };", "E0504"),
        ("A -> roof(tent, 30);", "E0504"),
        ("A -> insert(teapot);", "E0504"),
        ("A -> extrude(3) { 1: B };", "E0505"),
        ("A -> split(x);", "E0506"),
        ("A -> split(x) { 60%: B | 50%: C };", "E0507"),
        ("A -> repeat(x) { 0: B };", "E0507"),
        ("A -> split(x) { -1: B };", "E0507"),
        ("A -> size(-1, _, _);", "E0507"),
        ("A -> comp(faces) { all: B };", "E0508"),
        (
            "A -> extrude(3) B; B -> comp(faces) { side: C }; C -> comp(faces) { all: D };",
            "E0508",
        ),
        (
            "A -> extrude(3) B; B -> comp(edges) { all: C }; C -> comp(edges) { all: D };",
            "E0508",
        ),
        ("A < B -> C;", "E0512"),
        ("A -> extrude(atan(scope.x));", "E0513"),
        (
            "A -> repeat(y, floor) { 3: B }; B -> repeat(x, floor) { 1: C };",
            "W0501",
        ),
        ("A : scope.x -> B;", "E0204"),
        ("A -> (0) B;", "E0207"),
        ("A : overlaps(Nope) -> B;", "E0101"),
        ("A -> material(nope);", "E0101"),
    ] {
        assert_eq!(codes(&shape(rules)), [code], "{rules}");
    }
    // Axioms.
    assert_eq!(codes("system S { mode = shape; axiom A B; }"), ["E0511"]);
    assert_eq!(
        codes("system S { mode = shape; axiom extrude(3); }"),
        ["E0511"]
    );
    // Settings of other modes, and the lot outside shape mode.
    assert_eq!(
        codes("system S { mode = shape; iterations = 3; axiom A; }"),
        ["E0105"]
    );
    assert_eq!(codes("system S { lot = rect(3, 3); axiom A; }"), ["E0105"]);
    // Parts outside shape mode.
    assert_eq!(
        codes("system S { axiom A; A -> B(1) { 1: C }; }"),
        ["E0505"]
    );
    assert_eq!(
        codes("system S { mode = shape; axiom A; module B; }"),
        ["E0512"]
    );
}

#[test]
fn shape_values_and_random_draws_are_typed() {
    let p = check_ok(&shape(
        "A : tagged(floor) && depth < 3 && !inside(B) -> (uniform(1, 2)) \
         extrude(scope.x * randint(1, 3) + count) B; \
         B -> color(rgb(0.5, 0.5, 0.5) * 2) C;",
    ));
    let shape = p.systems[0].shape.as_ref().unwrap();
    let cond = shape.rules[0].condition.as_ref().unwrap();
    let mut found = Vec::new();
    cond.walk(&mut |e| {
        if let TExprKind::Shape(v) = &e.kind {
            found.push(v.clone());
        }
    });
    assert_eq!(found.len(), 3);
    assert!(found.contains(&ShapeValue::Depth));
}

#[test]
fn a_tags_index_and_count_are_numbers() {
    let p = check_ok(&shape(
        "A : tagged(floor) && index(floor) == 2 && count(floor) - index(floor) > index -> B;",
    ));
    let sys = p.systems[0].shape.as_ref().unwrap();
    let cond = sys.rules[0].condition.as_ref().unwrap();
    let mut found = Vec::new();
    cond.walk(&mut |e| {
        if let TExprKind::Shape(v) = &e.kind {
            found.push((v.clone(), e.ty));
        }
    });
    let floor = |v: &ShapeValue| match v {
        ShapeValue::TagIndex(n) | ShapeValue::TagCount(n) => n.as_str() == "floor",
        _ => true,
    };
    assert!(found.iter().all(|(v, _)| floor(v)));
    let kinds: Vec<(String, Ty)> = found
        .iter()
        .map(|(v, t)| (format!("{v:?}").split('(').next().unwrap().to_owned(), *t))
        .collect();
    assert_eq!(
        kinds,
        [
            ("Tagged".to_owned(), Ty::Bool),
            ("TagIndex".to_owned(), Ty::Float),
            ("TagCount".to_owned(), Ty::Float),
            ("TagIndex".to_owned(), Ty::Float),
            ("Index".to_owned(), Ty::Float),
        ]
    );
    // A tag is a name, not a number; `index(floor)` is not a condition.
    assert_eq!(codes(&shape("A : index(2) == 1 -> B;")), ["E0201"]);
    assert_eq!(codes(&shape("A : index(floor) -> B;")), ["E0204"]);
}

#[test]
fn derive_systems_do_not_know_shape_values() {
    assert_eq!(
        codes("system S { axiom A; A : depth > 1 -> B; }"),
        ["E0101"]
    );
}

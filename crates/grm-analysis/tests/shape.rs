//! Shape systems (`mode = shape`) in the editor: semantic tokens, hover,
//! completion and signature help of the shape syntax (docs/language.md
//! section 8), on tests/lsp/shape.grm and texts being typed.

use grm_analysis::*;
use grm_sema::MemLoader;
use std::path::Path;
use std::sync::Arc;

fn fixture() -> String {
    std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../tests/lsp/shape.grm"
    ))
    .expect("fixture")
}

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

/// The token at a byte offset.
fn token(fa: &FileAnalysis, offset: u32) -> SemanticToken {
    *fa.semantic_tokens()
        .iter()
        .find(|t| t.span.start == offset)
        .unwrap_or_else(|| panic!("no token at {offset}"))
}

#[test]
fn semantic_tokens_of_shape_rules() {
    let text = fixture();
    let fa = analyze(&text);
    let lib = TokenModifier {
        default_library: true,
        ..TokenModifier::default()
    };
    let none = TokenModifier::default();
    for (what, needle, n, delta, kind, mods) in [
        ("operation", "extrude", 0, 0, TokenKind::Turtle, lib),
        ("split", "split(y)", 0, 0, TokenKind::Turtle, lib),
        ("repeat", "repeat(y", 0, 0, TokenKind::Turtle, lib),
        ("comp", "comp(", 0, 0, TokenKind::Turtle, lib),
        ("roof", "roof(hip", 0, 0, TokenKind::Turtle, lib),
        ("push", "[ size", 0, 0, TokenKind::Turtle, lib),
        ("axis", "split(y)", 0, 6, TokenKind::EnumMember, lib),
        ("component kind", "faces", 0, 0, TokenKind::EnumMember, lib),
        ("selector", "front", 0, 0, TokenKind::EnumMember, lib),
        ("roof kind", "hip", 0, 0, TokenKind::EnumMember, lib),
        ("primitive", "box", 0, 0, TokenKind::EnumMember, lib),
        ("keep an axis", "_,", 0, 0, TokenKind::EnumMember, lib),
        ("command tag", "facade", 0, 0, TokenKind::Tag, none),
        (
            "tag in tagged()",
            "tagged(floor",
            0,
            7,
            TokenKind::Tag,
            none,
        ),
        ("tagged", "tagged", 0, 0, TokenKind::Function, lib),
        ("lot shape", "rect", 0, 0, TokenKind::Function, lib),
        ("parts open", "{ 4:", 0, 0, TokenKind::Punctuation, none),
        (
            "part colon",
            "4: Ground",
            0,
            1,
            TokenKind::Punctuation,
            none,
        ),
        ("part bar", "| ~1", 0, 0, TokenKind::Punctuation, none),
        (
            "parts close",
            "Upper };",
            0,
            6,
            TokenKind::Punctuation,
            none,
        ),
        ("floating", "~1: Upper", 0, 0, TokenKind::Operator, none),
        ("relative", "25%", 0, 2, TokenKind::Operator, none),
        ("nil", "nil", 0, 0, TokenKind::Keyword, none),
        ("target", "Ground", 0, 0, TokenKind::Module, none),
        ("mode value", "shape;", 0, 0, TokenKind::Keyword, none),
    ] {
        let t = token(&fa, at(&text, needle, n, delta));
        assert_eq!((t.kind, t.modifiers), (kind, mods), "{what}");
    }
    let scope = token(&fa, at(&text, "scope", 0, 0));
    assert_eq!(scope.kind, TokenKind::ShapeValue);
    assert!(scope.modifiers.readonly && scope.modifiers.default_library);
    // No word of the shape rules is left unresolved.
    let body = at(&text, "Lot ->", 0, 0);
    for t in fa.semantic_tokens() {
        assert!(
            t.span.start < body || t.kind != TokenKind::Unresolved,
            "unresolved `{}`",
            &text[t.span.range()]
        );
    }
}

#[test]
fn derive_systems_keep_their_tokens() {
    // The same words in a derive system are what they always were.
    let text = "system S {\n    axiom A;\n    A -> split F [ + A ] translate(1, 0, 0);\n}\n";
    let fa = analyze(text);
    assert_eq!(token(&fa, at(text, "split", 0, 0)).kind, TokenKind::Module);
    assert_eq!(
        token(&fa, at(text, "translate", 0, 0)).kind,
        TokenKind::Turtle
    );
    let h = fa.hover(at(text, "translate", 0, 0)).unwrap();
    assert!(h.markdown.contains("turtle command"), "{}", h.markdown);
}

#[test]
fn hover_documents_every_shape_word() {
    let text = fixture();
    let fa = analyze(&text);
    for (needle, n, delta, has) in [
        (
            "extrude",
            0,
            0,
            "*shape operation*: a footprint or face becomes a mass",
        ),
        ("comp(", 0, 0, "comp(faces, tag) { selector: Symbol | ... }"),
        ("split(y)", 0, 0, "divides the scope along"),
        ("repeat(y", 0, 0, "lays the parts as one tile"),
        (
            "roof(hip",
            0,
            0,
            "roof(kind, angle: float, overhang: float)",
        ),
        ("size(", 0, 0, "`_` keeps an axis"),
        ("insert(", 0, 0, "fitted to the scope"),
        ("[ size", 0, 0, "saves the scope and geometry"),
        ("material(glass)", 0, 0, "*shape operation*"),
        ("split(y)", 0, 6, "*axis*: the scope's y axis"),
        ("faces", 0, 0, "*component kind*"),
        (
            "front",
            0,
            0,
            "*component selector*: the walls (or edges) facing -y",
        ),
        ("side:", 0, 0, "*component selector*: every wall"),
        ("hip", 0, 0, "*roof kind*: slopes on every side"),
        ("box", 0, 0, "*primitive*"),
        ("~1: Upper", 0, 0, "*part size*: a floating part"),
        ("25%", 0, 2, "*part size*: a relative part"),
        ("nil", 0, 0, "makes nothing there"),
        ("scope", 0, 0, "*shape value*: the shape's scope size"),
        (
            "tagged",
            0,
            0,
            "whether a command with this tag is above the shape",
        ),
        ("rect", 0, 0, "*lot*: a `w` by `d` rectangle"),
        (
            "lot =",
            0,
            0,
            "*system setting*: shape systems: the axiom's footprint",
        ),
        ("shape;", 0, 0, "*system mode*: `mode = shape;`"),
        ("facade", 0, 0, "tag facade"),
        ("floor)", 0, 0, "on 1 command (line 15)"),
        ("tagged(floor", 0, 7, "`floor 1`, `floor 2`"),
        ("Facade ->", 0, 0, "shape Facade"),
        ("Window :", 0, 0, "2 rules (lines 19, 20)"),
        ("Wall |", 0, 0, "no rules: a terminal shape"),
        ("Lot;", 0, 0, "the axiom: grown from the lot"),
    ] {
        let o = at(&text, needle, n, delta);
        let h = fa
            .hover(o)
            .unwrap_or_else(|| panic!("no hover at `{needle}`"));
        assert!(h.markdown.contains(has), "`{needle}`: {}", h.markdown);
        assert!(h.span.contains(o) || h.span.end == o, "`{needle}`");
    }
    // A part's separator has nothing to say.
    assert!(fa.hover(at(&text, "| ~1", 0, 0)).is_none());
}

fn labels(fa: &FileAnalysis, offset: u32) -> Vec<String> {
    fa.completion(offset).into_iter().map(|c| c.label).collect()
}

#[test]
fn completion_in_shape_rules() {
    let text = "param floors = 4 in 1 .. 20;\nmesh door = \"door.obj\";\nsystem S {\n    mode = shape;\n    lot = ;\n    axiom Lot;\n    Lot -> extrude(floors * 3) Mass;\n    Mass -> comp(faces, facade) { front: Facade | side: Wall };\n    Facade -> repeat(y, floor) { 3: Floor };\n    Floor -> split(x, ) { ~1: Wall | 2: Win };\n    Win :  -> rotate(, 90) center() insert() ;\n    Wall -> roof(, 30) comp() {  };\n    Tile -> split(x) { ~1:  | 1.2 };\n    \n}\n";
    let mut loader = MemLoader::new();
    loader.add_binary("door.obj");
    let mut a = Analysis::new(Arc::new(loader));
    a.set_document(Path::new("main.grm"), 1, text);
    let fa = a.analyze(Path::new("main.grm")).unwrap();
    let has = |l: &[String], want: &[&str]| {
        for w in want {
            assert!(l.iter().any(|x| x == w), "{w} in {l:?}");
        }
    };
    let lacks = |l: &[String], not: &[&str]| {
        for w in not {
            assert!(!l.iter().any(|x| x == w), "{w} not in {l:?}");
        }
    };
    // Between operations: the operations and the shape symbols, not turtle commands.
    let ops = labels(&fa, at(text, " ;\n    Wall ->", 0, 1));
    has(
        &ops,
        &[
            "extrude", "split", "repeat", "comp", "roof", "insert", "offset", "[", "Facade", "Wall",
        ],
    );
    lacks(&ops, &["F", "cylinder", "nil", "+"]);
    let split = fa
        .completion(at(text, " ;\n    Wall ->", 0, 1))
        .into_iter()
        .find(|c| c.label == "split")
        .unwrap();
    assert!(split.snippet && split.insert_text.unwrap().starts_with("split(${1|x,y,z|})"));
    // Arguments.
    has(
        &labels(&fa, at(text, "split(x, )", 0, 9)),
        &["facade", "floor", "column"],
    );
    let tags = fa.completion(at(text, "split(x, )", 0, 9));
    assert_eq!(tags[0].label, "facade", "tags used in the file first");
    assert!(tags[0].detail.as_deref().unwrap().contains("used 1 time"));
    has(&labels(&fa, at(text, "rotate(", 0, 7)), &["x", "y", "z"]);
    lacks(&labels(&fa, at(text, "rotate(", 0, 7)), &["xy"]);
    has(&labels(&fa, at(text, "center(", 0, 7)), &["xy", "xyz", "z"]);
    has(
        &labels(&fa, at(text, "insert(", 0, 7)),
        &["box", "cylinder", "door"],
    );
    has(
        &labels(&fa, at(text, "roof(", 0, 5)),
        &["flat", "gable", "hip", "shed", "pyramid"],
    );
    has(&labels(&fa, at(text, "comp()", 0, 5)), &["faces", "edges"]);
    let size = labels(&fa, at(text, "extrude(", 0, 8));
    has(
        &size,
        &["floors", "scope", "index", "count", "depth", "uniform"],
    );
    lacks(&size, &["x", "Facade"]);
    // Parts: a selector of a component split, a symbol (or nil) after `:`.
    has(
        &labels(&fa, at(text, "comp() {  }", 0, 9)),
        &[
            "front", "back", "left", "right", "side", "top", "bottom", "all", "slope",
        ],
    );
    let target = labels(&fa, at(text, "~1:  |", 0, 4));
    has(&target, &["Wall", "Facade", "nil"]);
    lacks(&target, &["split", "scope"]);
    has(&labels(&fa, at(text, "| 1.2", 0, 5)), &["scope", "floors"]);
    // A condition: shape values and context queries.
    has(
        &labels(&fa, at(text, "Win :  ->", 0, 6)),
        &["scope", "tagged", "overlaps", "touches", "inside", "floors"],
    );
    // Statements: the shape settings and the symbols.
    let stmt = labels(&fa, at(text, "    \n}", 0, 4));
    has(&stmt, &["lot", "mode", "seed", "axiom", "Facade", "rule"]);
    lacks(&stmt, &["iterations", "angle", "skeleton"]);
    has(
        &labels(&fa, at(text, "lot = ;", 0, 6)),
        &["rect", "polygon"],
    );
    // A derive system is not offered `lot`.
    let d = analyze("system D {\n    \n}\n");
    lacks(&labels(&d, 15), &["lot"]);
    has(&labels(&d, 15), &["iterations"]);
}

#[test]
fn tags_used_in_tagged_calls_are_offered() {
    let text = "system S {\n    mode = shape;\n    axiom A;\n    A : tagged(storey) -> split(y, ) { ~1: B };\n    B : tagged() -> nil;\n}\n";
    let fa = analyze(text);
    let l = labels(&fa, at(text, "split(y, )", 0, 9));
    assert_eq!(l[0], "storey", "{l:?}");
    assert!(labels(&fa, at(text, "tagged()", 0, 7)).contains(&"storey".to_string()));
}

#[test]
fn signature_help_of_shape_operations() {
    let text = "system S {\n    mode = shape;\n    axiom A;\n    A -> roof(hip, ) split(y, ) { ~1: B };\n    B : tagged( -> nil;\n}\n";
    let fa = analyze(text);
    let h = fa.signature_help(at(text, "roof(hip, ", 0, 10)).unwrap();
    assert_eq!(h.signatures[0].label, "roof(kind, angle: float)");
    assert_eq!(h.active_parameter, 1);
    let h = fa.signature_help(at(text, "split(y, ", 0, 9)).unwrap();
    assert_eq!(h.active_signature, 1, "{h:?}");
    assert_eq!(
        h.signatures[1].label,
        "split(axis, tag) { size: Symbol | ... }"
    );
    let h = fa.signature_help(at(text, "tagged(", 0, 7)).unwrap();
    assert_eq!(h.signatures[0].label, "tagged(tag) -> bool");
}

#[test]
fn formatting_a_shape_system() {
    let text = "system S { mode = shape; axiom A;\nA -> split(y,floor){4:B|~1 : C|25 %:nil}; }\n";
    let fa = analyze(text);
    let e = fa.format().unwrap().expect("not formatted yet");
    let out = e.new_text;
    assert!(
        out.contains("split(y, floor) { 4: B | ~1: C | 25%: nil }"),
        "{out}"
    );
    assert!(analyze(&out).format().unwrap().is_none(), "idempotent");
}

/// The townhouse of docs/language.md without its tags.
const UNTAGGED: &str = "system Townhouse {
    mode = shape;
    lot = rect(24, 10);
    axiom Lot;
    Lot -> extrude(12.8) Mass;
    Mass -> comp(faces) { front: Facade | side: Wall | top: Roof };
    Roof -> roof(hip, 30, 0.4);
    Facade -> split(y) { 4: Ground | ~1: Upper };
    Upper -> repeat(y) { 3.2: Floor };
    Floor -> repeat(x) { ~3: Tile };
    Tile -> split(x) { ~1: Wall | 1.2: Window | ~1: Wall };
    Window -> split(y) { 0.9: Sill | ~1: Glass };
}
";

fn suggested(text: &str) -> Vec<(String, &'static str)> {
    analyze(text)
        .tag_suggestions()
        .into_iter()
        .map(|s| (s.written, s.tag))
        .collect()
}

/// Apply text edits (any order, not overlapping).
fn apply(text: &str, edits: &[TextEdit]) -> String {
    let mut es = edits.to_vec();
    es.sort_by_key(|e| std::cmp::Reverse(e.span.start));
    let mut s = text.to_string();
    for e in es {
        s.replace_range(e.span.range(), &e.new_text);
    }
    s
}

#[test]
fn tags_are_suggested_by_lipps_heuristic() {
    // The comp of the mass is the facades, the vertical repeat of single
    // floors (not the ground/upper split above it) the floors, the
    // repeat of 3-unit tiles along x the columns; the tile's split
    // (1.2-unit window) and the window's (0.9-unit sill) are within one
    // column and one floor.
    assert_eq!(
        suggested(UNTAGGED),
        [
            ("comp(faces)".to_string(), "facade"),
            ("repeat(y)".to_string(), "floor"),
            ("repeat(x)".to_string(), "column"),
        ]
    );
}

#[test]
fn applying_every_suggestion_leaves_nothing_to_suggest_and_no_warning() {
    let fa = analyze(UNTAGGED);
    let before: Vec<&str> = fa.diagnostics().iter().map(|d| d.code).collect();
    let all = fa.code_actions(Span::new(0, UNTAGGED.len() as u32));
    let every = all
        .iter()
        .find(|a| a.title == "Add the 3 suggested semantic tags")
        .expect("an action for all of them");
    assert_eq!(every.code, "");
    let tagged = apply(UNTAGGED, &every.edits);
    assert!(tagged.contains("comp(faces, facade) {"), "{tagged}");
    assert!(tagged.contains("repeat(y, floor) {"), "{tagged}");
    assert!(tagged.contains("repeat(x, column) {"), "{tagged}");
    let after = analyze(&tagged);
    let codes: Vec<&str> = after.diagnostics().iter().map(|d| d.code).collect();
    assert_eq!(
        codes, before,
        "no new diagnostic (W0501: a tag twice on one path)"
    );
    assert!(after.tag_suggestions().is_empty());
    assert!(
        after.format().unwrap().is_none(),
        "formatted as the formatter writes it"
    );
}

#[test]
fn one_quick_fix_per_command_under_the_cursor() {
    let fa = analyze(UNTAGGED);
    let o = at(UNTAGGED, "repeat(y)", 0, 3);
    let acts = fa.code_actions(Span::new(o, o));
    let titles: Vec<&str> = acts.iter().map(|a| a.title.as_str()).collect();
    assert_eq!(
        titles,
        [
            "Tag `repeat(y)` as `floor`",
            "Add the 3 suggested semantic tags"
        ]
    );
    let fixed = apply(UNTAGGED, &acts[0].edits);
    assert!(fixed.contains("Upper -> repeat(y, floor) { 3.2: Floor };"));
    // Nothing on a command with no suggestion, nor on the rule's symbol.
    let o = at(UNTAGGED, "split(x)", 0, 1);
    assert!(fa.code_actions(Span::new(o, o)).is_empty());
    // A derive system has none.
    let d = "system D { axiom A; A -> F A; }";
    assert!(
        analyze(d)
            .code_actions(Span::new(0, d.len() as u32))
            .is_empty()
    );
}

#[test]
fn a_tag_is_never_suggested_twice_on_one_path() {
    // Written above: the repeat below gets no second floor.
    let t = UNTAGGED.replace("split(y) { 4:", "split(y, floor) { 4:");
    assert_eq!(
        suggested(&t),
        [
            ("comp(faces)".to_string(), "facade"),
            ("repeat(x)".to_string(), "column")
        ]
    );
    // Written below: the split above is not suggested either (nor is the
    // repeat, already tagged).
    let t = UNTAGGED.replace("repeat(y) {", "repeat(y, floor) {");
    assert!(!suggested(&t).iter().any(|s| s.1 == "floor"));
    // A command that reaches itself would carry its tag twice.
    let t = "system S {\n    mode = shape;\n    axiom Lot;\n    Lot -> extrude(30) comp(faces) { side: Floors };\n    Floors -> split(y) { 3: Floor | ~1: Floors };\n}\n";
    assert_eq!(suggested(t), [("comp(faces)".to_string(), "facade")]);
}

#[test]
fn floors_of_a_mass_run_along_z() {
    let t = "system S {\n    mode = shape;\n    axiom Lot;\n    Lot -> extrude(30) Mass;\n    Mass -> split(z) { 4: Base | ~1: Tower };\n    Tower -> repeat(z) { 3.5: Storey };\n    Storey -> comp(faces) { side: Wall | top: nil };\n    Base -> split(y) { 5: Wing | ~1: Court };\n}\n";
    // The storeys (deepest), their facades; a mass's y split is no floor.
    assert_eq!(
        suggested(t),
        [
            ("repeat(z)".to_string(), "floor"),
            ("comp(faces)".to_string(), "facade")
        ]
    );
}

#[test]
fn kinds_that_disagree_get_no_tag() {
    // `Part` is a wall (from the comp) and a footprint (the axiom's own
    // split): its y axis is up on one path and not on the other.
    let t = "system S {\n    mode = shape;\n    axiom Part;\n    Part -> split(y) { 4: Part2 | ~1: Mass };\n    Mass -> extrude(9) comp(faces) { side: Part };\n}\n";
    let s = suggested(t);
    assert!(!s.iter().any(|x| x.1 == "floor"), "{s:?}");
    // A rule for `nil` (which names no shape) is no symbol's.
    let t = "system S {\n    mode = shape;\n    axiom A;\n    nil -> split(y) { 3: nil };\n    A -> extrude(9) comp(faces) { side: W };\n    W -> repeat(y) { 3: nil | 4: B };\n}\n";
    assert_eq!(
        suggested(t),
        [
            ("comp(faces)".to_string(), "facade"),
            ("repeat(y)".to_string(), "floor")
        ]
    );
    // Facade rules on their own count as a facade's.
    let t = "system S {\n    mode = shape;\n    axiom F;\n    G -> repeat(y) { 3: Fl };\n}\n";
    assert_eq!(suggested(t), [("repeat(y)".to_string(), "floor")]);
}

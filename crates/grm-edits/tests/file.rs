//! The edits file: reading (valid, tolerant, each error coded with its
//! span), canonical writing, round trips (table and seeded property
//! tests), the editor's helpers, diagnostics.

use grm_diag::Code;
use grm_edits::{
    Anchor, EdgeRef, Edit, EditsErrorKind, EditsFile, ExactLocator, Op, SemanticQuery, Target,
    parse, write,
};
use grm_sema::shape::Selector;

const EXAMPLE: &str = r#"{
  "version": 1,
  "edits": [
    {
      "id": 1,
      "system": "Tower",
      "target": { "exact": "{Lot, 1, comp.faces, front 1, Facade, 1, repeat.y, 3, Floor}" },
      "op": "material",
      "name": "brick"
    }
  ]
}
"#;

fn codes(text: &str) -> Vec<&'static str> {
    parse(text)
        .errors
        .iter()
        .map(|e| e.code().as_str())
        .collect()
}

#[test]
fn the_documented_example_reads_and_is_canonical() {
    let p = parse(EXAMPLE);
    assert!(p.errors.is_empty(), "{:?}", p.errors);
    assert_eq!(p.file.version, 1);
    let [e] = p.file.edits.as_slice() else {
        panic!("{:?}", p.file.edits)
    };
    assert_eq!(e.id, 1);
    assert_eq!(e.system, "Tower");
    let Target::Exact(l) = &e.target else {
        panic!("{:?}", e.target)
    };
    assert_eq!(
        l.labels,
        ["Lot", "comp.faces", "Facade", "repeat.y", "Floor"]
    );
    assert_eq!(
        l.edges[1],
        EdgeRef::Component {
            selector: Selector::Front,
            index: 1
        }
    );
    assert_eq!(
        e.op,
        Op::Material {
            name: "brick".into()
        }
    );
    // The span is the edit's object.
    let text = &EXAMPLE[e.span.range()];
    assert!(text.starts_with('{') && text.ends_with('}'), "{text}");
    assert!(text.contains("\"brick\""));
    assert_eq!(write(&p.file), EXAMPLE);
}

/// Every operation and target kind, with a note, written canonically.
fn every_kind() -> EditsFile {
    let exact: ExactLocator = "{Lot, 1, comp.faces, side 2, Facade}".parse().unwrap();
    let query: SemanticQuery = "(floor = 3, column = end 1, bay = centre -1) Window"
        .parse()
        .unwrap();
    let mut f = EditsFile::default();
    let ops = [
        Op::Set {
            name: "height".into(),
            value: 3.25,
        },
        Op::Offset {
            name: "angle".into(),
            by: -12.5,
        },
        Op::Force { alternative: 2 },
        Op::Pin { key: 0x0a1b_2c3d },
        Op::Material {
            name: "brick".into(),
        },
        Op::Mesh {
            name: "window_arched".into(),
        },
        Op::Remove,
    ];
    for (i, op) in ops.into_iter().enumerate() {
        let target = match i % 3 {
            0 => Target::Exact(exact.clone()),
            1 => Target::Semantic(query.clone()),
            _ => Target::Key(0xdead_beef),
        };
        let system = if i % 2 == 0 { "Tower" } else { "Annex" };
        f.add(system, target, op).unwrap();
    }
    f.edits[2].note = Some("the \"corner\" bay\nasked by A.".into());
    f
}

#[test]
fn every_kind_round_trips() {
    let f = every_kind();
    let text = write(&f);
    let back = parse(&text);
    assert!(back.errors.is_empty(), "{:?}\n{text}", back.errors);
    assert_eq!(back.file, f, "{text}");
    assert_eq!(write(&back.file), text);
    // Sorted by (system, id): Annex's 2, 4, 6, then Tower's 1, 3, 5, 7.
    let ids: Vec<u32> = back.file.edits.iter().map(|e| e.id).collect();
    assert_eq!(ids, [2, 4, 6, 1, 3, 5, 7]);
    // Fixed key order in each block.
    assert!(text.contains(
        "      \"id\": 1,\n      \"system\": \"Tower\",\n      \"target\": { \"exact\": \"{Lot, 1, comp.faces, side 2, Facade}\" },\n      \"op\": \"set\",\n      \"name\": \"height\",\n      \"value\": 3.25\n"
    ), "{text}");
    assert!(text.contains("\"key\": \"0a1b2c3d\""), "{text}");
    assert!(text.contains("{ \"key\": \"deadbeef\" }"), "{text}");
    assert!(text.ends_with("  ]\n}\n"));
}

/// Replacing one edit's span with its new canonical text (a quick fix)
/// changes that edit only, and the file stays canonical.
#[test]
fn one_edit_is_replaced_in_place() {
    let text = write(&every_kind());
    let p = parse(&text);
    let mut e = p.file.get(5).unwrap().clone();
    e.target = Target::Semantic("(floor = 2) Window".parse().unwrap());
    e.note = Some("moved".into());
    let r = e.span.range();
    let fixed = format!(
        "{}{}{}",
        &text[..r.start],
        grm_edits::write_edit(&e),
        &text[r.end..]
    );
    let mut want = p.file.clone();
    *want.edits.iter_mut().find(|x| x.id == 5).unwrap() = e;
    assert_eq!(fixed, write(&want));
    assert_eq!(parse(&fixed).file, want);
}

#[test]
fn targets_and_operations_list_in_one_line() {
    let f = every_kind();
    let lines: Vec<String> = f
        .edits
        .iter()
        .map(|e| format!("{} {}: {} on {}", e.system, e.id, e.op, e.target))
        .collect();
    assert_eq!(
        lines,
        [
            "Annex 2: offset angle by -12.5 on semantic (floor = 3, column = end 1, bay = centre -1) Window",
            "Annex 4: pin 0a1b2c3d on exact {Lot, 1, comp.faces, side 2, Facade}",
            "Annex 6: mesh window_arched on key deadbeef",
            "Tower 1: set height = 3.25 on exact {Lot, 1, comp.faces, side 2, Facade}",
            "Tower 3: force alternative 2 on key deadbeef",
            "Tower 5: material brick on semantic (floor = 3, column = end 1, bay = centre -1) Window",
            "Tower 7: remove on exact {Lot, 1, comp.faces, side 2, Facade}",
        ]
    );
}

#[test]
fn an_empty_file_writes_and_reads() {
    let text = write(&EditsFile::default());
    assert_eq!(text, "{\n  \"version\": 1,\n  \"edits\": []\n}\n");
    let p = parse(&text);
    assert!(p.errors.is_empty());
    assert_eq!(p.file, EditsFile::default());
}

#[test]
fn a_file_in_another_layout_is_written_canonically() {
    let loose = r#"{"edits":[{"op":"remove","target":{"key":"0000002A"},"system":"S","id":9,"note":"x"},
        {"name":"w","system":"S","id":3,"value":1e2,"target":{"semantic":"(floor=2)"},"op":"set"}],
        "version":1}"#;
    let p = parse(loose);
    assert!(p.errors.is_empty(), "{:?}", p.errors);
    let text = write(&p.file);
    assert_eq!(
        text,
        r#"{
  "version": 1,
  "edits": [
    {
      "id": 3,
      "system": "S",
      "target": { "semantic": "(floor = 2)" },
      "op": "set",
      "name": "w",
      "value": 100.0
    },
    {
      "id": 9,
      "system": "S",
      "target": { "key": "0000002a" },
      "op": "remove",
      "note": "x"
    }
  ]
}
"#
    );
    assert_eq!(write(&parse(&text).file), text);
}

#[test]
fn bad_files_are_refused_whole() {
    for (text, code) in [
        ("", "R0902"),
        ("   ", "R0902"),
        ("{", "R0902"),
        ("{\"version\": 1, \"edits\": [],}", "R0902"),
        ("// c\n{\"version\": 1, \"edits\": []}", "R0902"),
        ("{\"version\": 1, \"edits\": []} {}", "R0902"),
        ("[]", "R0904"),
        ("{\"edits\": []}", "R0903"),
        ("{\"version\": 4, \"edits\": []}", "R0903"),
        ("{\"version\": 0, \"edits\": []}", "R0903"),
        ("{\"version\": \"1\", \"edits\": []}", "R0903"),
        ("{\"version\": 1}", "R0904"),
        ("{\"version\": 1, \"edits\": {}}", "R0904"),
    ] {
        let p = parse(text);
        assert_eq!(
            p.errors
                .iter()
                .map(|e| e.code().as_str())
                .collect::<Vec<_>>(),
            [code],
            "{text:?}"
        );
        assert!(p.errors[0].is_fatal());
        assert!(p.file.edits.is_empty());
        // Spans lie in the text (a diagnostic can point at them).
        assert!(p.errors[0].span.range().end <= text.len(), "{text:?}");
    }
}

/// One edit with a problem among valid ones: it is reported with its
/// code and skipped; the others are kept.
#[test]
fn each_problem_has_its_code_and_the_valid_edits_stay() {
    let good = r#"{"id": 1, "system": "S", "target": {"key": "00000001"}, "op": "remove"}"#;
    let cases: &[(&str, &str)] = &[
        (
            r#"{"id": 2, "system": "S", "target": {"key": "00000001"}, "op": "remove", "colour": 1}"#,
            "R0905",
        ),
        (
            r#"{"id": 2, "system": "S", "target": {"key": "00000001"}, "op": "remove", "value": 1}"#,
            "R0905",
        ),
        (
            r#"{"id": 2, "id": 3, "system": "S", "target": {"key": "00000001"}, "op": "remove"}"#,
            "R0905",
        ),
        (
            r#"{"system": "S", "target": {"key": "00000001"}, "op": "remove"}"#,
            "R0906",
        ),
        (
            r#"{"id": 2, "target": {"key": "00000001"}, "op": "remove"}"#,
            "R0906",
        ),
        (r#"{"id": 2, "system": "S", "op": "remove"}"#, "R0906"),
        (
            r#"{"id": 2, "system": "S", "target": {"key": "00000001"}}"#,
            "R0906",
        ),
        (
            r#"{"id": 2, "system": "S", "target": {"key": "00000001"}, "op": "set", "name": "w"}"#,
            "R0906",
        ),
        (
            r#"{"id": 2, "system": "S", "target": {"key": "00000001"}, "op": "force"}"#,
            "R0906",
        ),
        (
            r#"{"id": "2", "system": "S", "target": {"key": "00000001"}, "op": "remove"}"#,
            "R0907",
        ),
        (
            r#"{"id": 2, "system": 5, "target": {"key": "00000001"}, "op": "remove"}"#,
            "R0907",
        ),
        (
            r#"{"id": 2, "system": "S", "target": "{Lot}", "op": "remove"}"#,
            "R0907",
        ),
        (
            r#"{"id": 2, "system": "S", "target": {"exact": 3}, "op": "remove"}"#,
            "R0907",
        ),
        (
            r#"{"id": 2, "system": "S", "target": {"key": "00000001"}, "op": "set", "name": "w", "value": "3"}"#,
            "R0907",
        ),
        (
            r#"{"id": 2, "system": "S", "target": {"key": "00000001"}, "op": "remove", "note": 7}"#,
            "R0907",
        ),
        (
            r#"{"id": 2, "system": "S", "target": {"key": "00000001"}, "op": "paint"}"#,
            "R0908",
        ),
        (
            r#"{"id": 2, "system": "S", "target": {}, "op": "remove"}"#,
            "R0909",
        ),
        (
            r#"{"id": 2, "system": "S", "target": {"exact": "{Lot}", "key": "00000001"}, "op": "remove"}"#,
            "R0909",
        ),
        (
            r#"{"id": 2, "system": "S", "target": {"path": "{Lot}"}, "op": "remove"}"#,
            "R0909",
        ),
        (
            r#"{"id": 2, "system": "S", "target": {"exact": "{Lot, x, A}"}, "op": "remove"}"#,
            "R0909",
        ),
        (
            r#"{"id": 2, "system": "S", "target": {"semantic": "(floor = 0)"}, "op": "remove"}"#,
            "R0909",
        ),
        (
            r#"{"id": 2, "system": "S", "target": {"key": "xyz"}, "op": "remove"}"#,
            "R0909",
        ),
        (
            r#"{"id": 1, "system": "S", "target": {"key": "00000002"}, "op": "remove"}"#,
            "R0910",
        ),
        (
            r#"{"id": 0, "system": "S", "target": {"key": "00000001"}, "op": "remove"}"#,
            "R0911",
        ),
        (
            r#"{"id": 2.5, "system": "S", "target": {"key": "00000001"}, "op": "remove"}"#,
            "R0911",
        ),
        (
            r#"{"id": 4294967296, "system": "S", "target": {"key": "00000001"}, "op": "remove"}"#,
            "R0911",
        ),
        (
            r#"{"id": 2, "system": "", "target": {"key": "00000001"}, "op": "remove"}"#,
            "R0911",
        ),
        (
            r#"{"id": 2, "system": "S", "target": {"key": "00000001"}, "op": "set", "name": "w", "value": 1e999}"#,
            "R0911",
        ),
        (
            r#"{"id": 2, "system": "S", "target": {"key": "00000001"}, "op": "offset", "name": "w", "by": -1e400}"#,
            "R0911",
        ),
        (
            r#"{"id": 2, "system": "S", "target": {"key": "00000001"}, "op": "force", "alternative": 0}"#,
            "R0911",
        ),
        (
            r#"{"id": 2, "system": "S", "target": {"key": "00000001"}, "op": "pin", "key": "123"}"#,
            "R0911",
        ),
        (
            r#"{"id": 2, "system": "S", "target": {"key": "00000001"}, "op": "material", "name": ""}"#,
            "R0911",
        ),
        ("3", "R0904"),
        ("[]", "R0904"),
    ];
    for (bad, code) in cases {
        let text =
            format!("{{\n  \"version\": 1,\n  \"edits\": [\n    {good},\n    {bad}\n  ]\n}}\n");
        let p = parse(&text);
        let got: Vec<&str> = p.errors.iter().map(|e| e.code().as_str()).collect();
        assert_eq!(got, [*code], "{bad}: {:?}", p.errors);
        assert_eq!(p.file.edits.len(), 1, "{bad}: the valid edit stays");
        assert_eq!(p.file.edits[0].id, 1);
        let e = &p.errors[0];
        assert!(!e.is_fatal());
        // The span lies inside the bad edit's text.
        let start = text.find(bad).unwrap();
        let r = e.span.range();
        assert!(
            r.start >= start && r.end <= start + bad.len(),
            "{bad}: span {r:?} = {:?}",
            &text[r.clone()]
        );
        // The message names the edit where it has a readable id.
        let msg = e.to_string();
        if *code != "R0910" && bad.starts_with(r#"{"id": 2,"#) {
            assert!(msg.starts_with("edit 2: "), "{msg}");
        }
    }
}

#[test]
fn every_problem_of_one_edit_is_reported() {
    let text = r#"{"version": 1, "edits": [
        {"id": 0, "system": 3, "target": {}, "op": "set", "value": "x", "colour": 1}
    ]}"#;
    let got = codes(text);
    // id 0, system a number, empty target, no name, value a string, unknown field.
    assert_eq!(
        got,
        ["R0911", "R0907", "R0909", "R0905", "R0906", "R0907"],
        "{:?}",
        parse(text).errors
    );
    // An unknown operation: its fields are not also reported, only what
    // no operation has.
    let text = r#"{"version": 1, "edits": [
        {"id": 2, "system": "S", "target": {"key": "00000001"}, "op": "paint", "name": "x", "colour": 1}
    ]}"#;
    assert_eq!(codes(text), ["R0908", "R0905"]);
}

#[test]
fn top_level_unknown_fields_are_reported_and_the_edits_kept() {
    let text = r#"{"version": 1, "author": "A", "edits": [
        {"id": 2, "system": "S", "target": {"key": "00000001"}, "op": "remove"}
    ]}"#;
    let p = parse(text);
    assert_eq!(codes(text), ["R0905"]);
    assert_eq!(p.file.edits.len(), 1);
    assert!(!p.errors[0].is_fatal());
}

#[test]
fn duplicate_ids_keep_the_first_and_point_at_it() {
    let text = r#"{"version": 1, "edits": [
        {"id": 4, "system": "S", "target": {"key": "00000001"}, "op": "remove"},
        {"id": 4, "system": "S", "target": {"key": "00000002"}, "op": "remove"}
    ]}"#;
    let p = parse(text);
    assert_eq!(p.file.edits.len(), 1);
    assert_eq!(p.file.edits[0].target, Target::Key(1));
    let EditsErrorKind::DuplicateId { id: 4, first } = p.errors[0].kind else {
        panic!("{:?}", p.errors)
    };
    assert_eq!(first, p.file.edits[0].span);
    let d = p.errors[0].to_diagnostic(grm_diag::FileId(3));
    assert_eq!(d.code, Code::EditsDuplicateId);
    assert_eq!(d.labels.len(), 2);
}

#[test]
fn diagnostics_point_into_the_edits_file() {
    let text = r#"{"version": 1, "edits": [{"id": 2, "system": "S", "target": {"key": "00000001"}, "op": "paint"}]}"#;
    let mut sources = grm_diag::SourceMap::new();
    let file = sources.add("t.edits.json", text);
    let p = parse(text);
    let d = p.errors[0].to_diagnostic(file);
    assert_eq!(d.code, Code::EditsUnknownOp);
    assert_eq!(&text[d.primary().span.range()], "\"paint\"");
    let shown = grm_diag::render_human(&d, &sources, false);
    assert!(
        shown.contains("edit 2: unknown operation `paint`"),
        "{shown}"
    );
    assert!(shown.contains("t.edits.json"), "{shown}");
}

#[test]
fn editor_helpers() {
    let mut f = EditsFile::default();
    let a = f.add("S", Target::Key(1), Op::Remove).unwrap();
    let b = f
        .add("A", Target::Key(2), Op::Force { alternative: 1 })
        .unwrap();
    let c = f.add("S", Target::Key(3), Op::Remove).unwrap();
    assert_eq!((a, b, c), (1, 2, 3));
    // Kept in the written order.
    let ids: Vec<u32> = f.edits.iter().map(|e| e.id).collect();
    assert_eq!(ids, [2, 1, 3]);
    assert_eq!(f.of_system("S").count(), 2);
    let q: SemanticQuery = "(floor = end 1)".parse().unwrap();
    assert_eq!(
        f.retarget(1, Target::Semantic(q.clone())),
        Some(Target::Key(1))
    );
    assert_eq!(f.get(1).unwrap().target, Target::Semantic(q));
    assert_eq!(f.retarget(9, Target::Key(0)), None);
    assert_eq!(f.remove(3).map(|e| e.id), Some(3));
    assert_eq!(f.remove(3), None);
    // A new edit is later than every edit there (the largest id plus 1).
    assert_eq!(f.add("S", Target::Key(4), Op::Remove), Some(3));
    assert_eq!(f.remove(3).map(|e| e.id), Some(3));
    assert_eq!(f.next_id(), Some(3));
    f.edits.push(Edit {
        id: u32::MAX,
        ..f.edits[0].clone()
    });
    assert_eq!(f.next_id(), None);
    assert_eq!(f.add("S", Target::Key(5), Op::Remove), None);
}

/// A random file (every operation, target and anchor, odd names and
/// notes) written and read back is the same file, sorted; writing it
/// again gives the same text (seeded: `GRM_TEST_SEED` soaks it).
#[test]
fn random_files_round_trip() {
    let mut rng = grm_testkit::Rng::seeded(0x00ed_1750);
    for _ in 0..300 {
        let f = random_file(&mut rng);
        let text = write(&f);
        let p = parse(&text);
        assert!(p.errors.is_empty(), "{:?}\n{text}", p.errors);
        let mut sorted = f.clone();
        sorted.sort();
        sorted.version = f.written_version();
        assert_eq!(p.file, sorted, "{text}");
        assert_eq!(write(&p.file), text);
        for e in &p.file.edits {
            let block = &text[e.span.range()];
            assert!(block.starts_with('{') && block.ends_with('}'), "{block}");
            assert!(block.contains(&format!("\"id\": {},", e.id)), "{block}");
        }
    }
}

#[test]
fn random_queries_round_trip() {
    let mut rng = grm_testkit::Rng::seeded(0x0005_e3a1);
    for _ in 0..1000 {
        let q = random_query(&mut rng);
        let text = q.to_string();
        let back: SemanticQuery = text.parse().unwrap_or_else(|e| panic!("{text}: {e}"));
        assert_eq!(back, q, "{text}");
    }
}

/// Mangled texts never panic the reader, and its spans stay in the text.
#[test]
fn mangled_texts_never_panic() {
    let mut rng = grm_testkit::Rng::seeded(0x0bad_7e47);
    let base = write(&every_kind());
    for _ in 0..2000 {
        let mut bytes = base.clone().into_bytes();
        for _ in 0..rng.below(4usize) + 1 {
            let at = rng.below(bytes.len());
            match rng.below(3u32) {
                0 => {
                    bytes.remove(at);
                }
                1 => bytes.insert(at, *rng.pick(b"{}[]\",:0-e. ax\\")),
                _ => bytes[at] = *rng.pick(b"{}[]\",:0-e. ax\\"),
            }
        }
        let Ok(text) = String::from_utf8(bytes) else {
            continue;
        };
        let p = parse(&text);
        for e in &p.errors {
            assert!(e.span.range().end <= text.len(), "{text}");
            let _ = e.to_diagnostic(grm_diag::FileId(0));
        }
        // What was kept writes and reads back cleanly.
        let again = parse(&write(&p.file));
        assert!(again.errors.is_empty(), "{text}");
    }
}

fn random_word(rng: &mut grm_testkit::Rng) -> String {
    let alphabet: Vec<char> = "abcXYZ_09.:+-".chars().collect();
    let n = rng.below(6usize) + 1;
    (0..n).map(|_| *rng.pick(&alphabet)).collect()
}

fn random_query(rng: &mut grm_testkit::Rng) -> SemanticQuery {
    let entries = (0..rng.below(4usize))
        .map(|_| {
            let anchor = *rng.pick(&[Anchor::Start, Anchor::End, Anchor::Centre]);
            let n = match anchor {
                Anchor::Centre => rng.int(-20, 20),
                _ => rng.int(1, 1000),
            };
            (random_word(rng), anchor, n)
        })
        .collect();
    let label = (rng.below(2u32) == 0).then(|| random_word(rng));
    SemanticQuery { entries, label }
}

fn random_exact(rng: &mut grm_testkit::Rng) -> ExactLocator {
    let n = rng.below(6usize);
    let labels = (0..=n).map(|_| random_word(rng)).collect();
    let edges = (0..n)
        .map(|_| {
            if rng.below(3u32) == 0 {
                EdgeRef::Component {
                    selector: *rng.pick(Selector::ALL),
                    index: rng.below(9u32) + 1,
                }
            } else if rng.below(2u32) == 0 {
                EdgeRef::Ordinal(rng.below(100u32) + 1)
            } else {
                EdgeRef::Number(rng.below(100u32) + 1)
            }
        })
        .collect();
    ExactLocator { labels, edges }
}

fn random_file(rng: &mut grm_testkit::Rng) -> EditsFile {
    let mut f = EditsFile::default();
    let names = ["Tower", "Facade", "A", "Ünïcode \"q\"", "b\\c"];
    for _ in 0..rng.below(8usize) {
        let target = match rng.below(3u32) {
            0 => Target::Exact(random_exact(rng)),
            1 => Target::Semantic(random_query(rng)),
            _ => Target::Key(rng.next_u64() as u32),
        };
        let op = match rng.below(7u32) {
            0 => Op::Set {
                name: random_word(rng),
                value: rng.range(-1e6, 1e6),
            },
            1 => Op::Offset {
                name: random_word(rng),
                by: *rng.pick(&[0.1, -0.0, 1e300, -2.5e-12, 7.0]),
            },
            2 => Op::Force {
                alternative: rng.below(5u32) + 1,
            },
            3 => Op::Pin {
                key: rng.next_u64() as u32,
            },
            4 => Op::Material {
                name: random_word(rng),
            },
            5 => Op::Mesh {
                name: random_word(rng),
            },
            _ => Op::Remove,
        };
        let system = *rng.pick(&names);
        let semantic = matches!(target, Target::Semantic(_));
        let id = f.add(system, target, op).unwrap();
        if semantic && rng.below(2u32) == 0 {
            let n = rng.below(50u32) + 1;
            f.edits.iter_mut().find(|e| e.id == id).unwrap().selected = Some(n);
        }
        if rng.below(3u32) == 0 {
            let note =
                (*rng.pick(&["", "tab\there", "line\nbreak", "quote \" and \\", "é✓"])).to_owned();
            f.edits.iter_mut().find(|e| e.id == id).unwrap().note = Some(note);
        }
    }
    // Shuffle the order, as a file written by hand may have it.
    rng.shuffle(&mut f.edits);
    f
}

/// A building edit on a city parcel (docs/layout.md, "Building edits"):
/// the `parcel` field reads, is written after `system`, and reads back the
/// same; an identity that is not 16 hex digits is R0911, a number R0907,
/// and the edit is skipped.
#[test]
fn parcel_edits_read_write_and_reject_bad_identities() {
    let text = r#"{
  "version": 1,
  "edits": [
    {
      "id": 3,
      "system": "House",
      "parcel": "00ab00cd00ef0012",
      "target": { "semantic": "(floor = 2) Window" },
      "op": "remove"
    }
  ]
}
"#;
    let p = parse(text);
    assert!(p.errors.is_empty(), "{:?}", p.errors);
    assert_eq!(p.file.edits[0].parcel, Some(0x00ab_00cd_00ef_0012));
    assert_eq!(write(&p.file), text);
    // Without the field: an edit of the system itself.
    assert_eq!(parse(EXAMPLE).file.edits[0].parcel, None);
    let mut other = p.file.clone();
    other.edits[0].parcel = Some(1);
    assert_ne!(other, p.file, "the parcel is part of the edit");
    for (bad, code) in [
        (r#""parcel": "ab","#, "R0911"),
        (r#""parcel": "00ab00cd00ef001g","#, "R0911"),
        (r#""parcel": 12,"#, "R0907"),
    ] {
        let t = text.replace(r#""parcel": "00ab00cd00ef0012","#, bad);
        assert_eq!(codes(&t), [code], "{bad}");
        assert!(parse(&t).file.edits.is_empty(), "{bad}");
    }
}

/// Version 2 (docs/edits.md, "Versions"): ordinal edges (`#k`) and a
/// semantic edit's `selected` count read and write; a file that uses
/// neither is written as the version it was read (1 stays 1); one that
/// uses either is written as version 2; `selected` on a target that is
/// not semantic, or not a whole number from 1, is R0911 and the edit is
/// skipped; an ordinal `#0` is R0909; a version grm does not read is R0903.
#[test]
fn version_2_ordinal_edges_and_selected_counts() {
    let text = r#"{
  "version": 2,
  "edits": [
    {
      "id": 1,
      "system": "Tower",
      "target": { "exact": "{Lot, #1, comp.faces, front 1, Facade, #1, split.y, #2, Upper}" },
      "op": "remove"
    },
    {
      "id": 2,
      "system": "Tower",
      "target": { "semantic": "(floor = 2) Window" },
      "selected": 3,
      "op": "remove"
    }
  ]
}
"#;
    let p = parse(text);
    assert!(p.errors.is_empty(), "{:?}", p.errors);
    assert_eq!(p.file.version, 2);
    let Target::Exact(l) = &p.file.edits[0].target else {
        panic!("{:?}", p.file.edits[0].target)
    };
    assert_eq!(l.edges[0], EdgeRef::Ordinal(1));
    assert_eq!(l.edges[3], EdgeRef::Ordinal(2));
    assert_eq!(p.file.edits[1].selected, Some(3));
    assert_eq!(p.file.edits[0].selected, None);
    assert_eq!(write(&p.file), text);
    // A version-1 file keeps its version until an edit needs version 2.
    let mut f = parse(EXAMPLE).file;
    assert_eq!(f.version, 1);
    assert!(write(&f).contains("\"version\": 1,"));
    f.edits[0].target = Target::Exact("{Lot, #1, A}".parse().unwrap());
    assert!(write(&f).contains("\"version\": 2,"));
    let mut f = parse(EXAMPLE).file;
    f.edits[0].target = Target::Semantic("(floor = 1)".parse().unwrap());
    f.edits[0].selected = Some(1);
    let written = write(&f);
    assert!(written.contains("\"version\": 2,"), "{written}");
    assert!(written.contains("\"selected\": 1,"), "{written}");
    // Retargeting drops the old target's count.
    f.retarget(1, Target::Key(7));
    assert_eq!(f.edits[0].selected, None);
    for (from, to, code) in [
        (r#""selected": 3,"#, r#""selected": 0,"#, "R0911"),
        (r#""selected": 3,"#, r#""selected": 1.5,"#, "R0911"),
        (r#""selected": 3,"#, r#""selected": "3","#, "R0907"),
        (
            r#""semantic": "(floor = 2) Window" },"#,
            r#""key": "00000001" },"#,
            "R0911",
        ),
        (r#""version": 2,"#, r#""version": 4,"#, "R0903"),
        (r#"#2, Upper"#, r#"#0, Upper"#, "R0909"),
    ] {
        assert!(text.contains(from), "{from}");
        let t = text.replace(from, to);
        assert_eq!(codes(&t), [code], "{to}");
    }
}

/// Version 3 (docs/edits.md, "Versions"): a key edit's `symbol` reads and
/// writes; a file that has one is written as version 3, one without keeps
/// its version; `symbol` on a target that is not a key, or empty, is
/// R0911; a later edit of the same key that records another symbol is
/// R0911 and skipped (the earlier stays); retargeting drops the symbol.
#[test]
fn version_3_key_symbols() {
    let text = r#"{
  "version": 3,
  "edits": [
    {
      "id": 1,
      "system": "Tower",
      "target": { "key": "0a1b2c3d" },
      "symbol": "Window",
      "op": "remove"
    },
    {
      "id": 2,
      "system": "Tower",
      "target": { "key": "0a1b2c3d" },
      "op": "pin",
      "key": "00000007"
    }
  ]
}
"#;
    let p = parse(text);
    assert!(p.errors.is_empty(), "{:?}", p.errors);
    assert_eq!(p.file.version, 3);
    assert_eq!(p.file.edits[0].symbol.as_deref(), Some("Window"));
    assert_eq!(p.file.edits[1].symbol, None);
    assert_eq!(write(&p.file), text);
    // A version-1 file keeps its version until a key edit records a symbol.
    let mut f = parse(EXAMPLE).file;
    assert!(write(&f).contains("\"version\": 1,"));
    f.edits[0].target = Target::Key(0x0a1b_2c3d);
    f.edits[0].symbol = Some("Window".into());
    let written = write(&f);
    assert!(written.contains("\"version\": 3,"), "{written}");
    assert!(written.contains("\"symbol\": \"Window\","), "{written}");
    let back = parse(&written).file;
    assert_eq!((back.version, &back.edits), (3, &f.edits), "{written}");
    // A symbol beside a target that is not a key is not written.
    f.edits[0].target = Target::Semantic("(floor = 1)".parse().unwrap());
    assert!(!write(&f).contains("\"symbol\""));
    let mut f = parse(text).file;
    f.retarget(1, Target::Key(9));
    assert_eq!(f.edits[0].symbol, None);
    for (from, to, code) in [
        (r#""symbol": "Window","#, r#""symbol": "","#, "R0911"),
        (r#""symbol": "Window","#, r#""symbol": 3,"#, "R0907"),
        (
            r#""key": "0a1b2c3d" },
      "symbol""#,
            r#""semantic": "(floor = 2) Window" },
      "symbol""#,
            "R0911",
        ),
        (
            r#""op": "pin","#,
            r#""symbol": "Leaf",
      "op": "pin","#,
            "R0911",
        ),
    ] {
        assert!(text.contains(from), "{from}");
        let t = text.replace(from, to);
        assert_eq!(codes(&t), [code], "{to}");
        assert_eq!(parse(&t).file.edits.len(), 1, "{to}");
    }
    // The same symbol twice is no conflict; another system's key is not
    // the same key.
    let same = text.replace(
        r#""op": "pin","#,
        r#""symbol": "Window",
      "op": "pin","#,
    );
    assert!(parse(&same).errors.is_empty());
    let other = text
        .replace(
            r#""op": "pin","#,
            r#""symbol": "Leaf",
      "op": "pin","#,
        )
        .replace(
            r#""id": 2,
      "system": "Tower","#,
            r#""id": 2,
      "system": "Other","#,
        );
    assert!(parse(&other).errors.is_empty(), "{other}");
}

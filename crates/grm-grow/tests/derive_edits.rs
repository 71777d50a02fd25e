//! Derive mode's persistent edits on the one road (`grm_grow::edits`,
//! `Grower::with_edits`; docs/edits.md): an edits file's key targets
//! replayed by the CPU engine, the same string whether the tree is
//! recorded or not, the tree without the removed branch, and every edit
//! classified (valid, dormant, ambiguous, stale, not replayed); the edits
//! survive another slider value, and a key target sleeps under another
//! seed and wakes with its own.

mod common;

use common::*;
use grm_edits::EditClass;
use grm_grow::{Grower, Record};

const PLANT: &str = "param spread = 25 in 0 .. 90;
system Plant {
    iterations = 4;
    seed = 1;
    module A(len: float, w: float);
    axiom A(1, 0.2);
    A(l, w) -> (1) F(l) [ +(spread) A(l * 0.8, w * 0.7) ] [ -(spread) A(l * 0.7, w * 0.7) ] A(l * 0.9, w);
    A(l, w) -> (1) F(l) A(l * 0.9, w * 0.9);
    F(l) -> F(l * 1.1);
}";

fn compiled(checked: &grm_sema::Checked, spread: f64) -> grm_compile::CompiledSystem {
    let p = &checked.program;
    let mut values = p.default_params();
    values[0] = grm_sema::Value::Float(spread);
    grm_compile::compile(p, system(checked), &values).expect("compiles")
}

fn grow(
    c: &grm_compile::CompiledSystem,
    record: Record,
    file: &grm_edits::EditsFile,
    system: &grm_sema::System,
    seed: u32,
) -> grm_grow::Grown {
    let plan = grm_grow::edits::edit_plan(system, &file.edits);
    Grower::new(c, 2, record)
        .expect("grower")
        .with_edits(plan)
        .expect("edits")
        .derive(&options(4, seed), &mut |_| {})
        .expect("grows")
}

#[test]
fn a_key_edits_file_is_replayed_and_classified() {
    let checked = inline(PLANT);
    let system = system(&checked);
    let c = compiled(&checked, 25.0);
    let tree_rec = Record {
        tree: true,
        origins: true,
        ..Record::default()
    };
    let plain = Grower::new(&c, 1, tree_rec)
        .expect("grower")
        .derive(&options(4, 1), &mut |_| {})
        .expect("grows");
    let tree = plain.tree.as_ref().expect("tree");
    let sym = |n: &str| c.symbol_names.iter().position(|s| s == n).expect("symbol") as u32;
    // An A of string 2 that branches (its production is the first; to
    // remove), an A of string 3 outside its subtree (to force), an F of
    // the final string outside both.
    let node = |i: usize| &tree.nodes[i];
    let under = |i: usize, a: usize| tree.ancestry(i as u32).contains(&(a as u32));
    let branch_i = (0..tree.nodes.len())
        .find(|&i| {
            let n = node(i);
            n.iteration == 2
                && n.symbol == Some(sym("A"))
                && n.production == Some(c.groups_of(sym("A"))[0].first_alt)
        })
        .expect("a branching A");
    let other_i = (0..tree.nodes.len())
        .find(|&i| {
            node(i).iteration == 3 && node(i).symbol == Some(sym("A")) && !under(i, branch_i)
        })
        .expect("an A");
    let leaf_i = (0..tree.nodes.len())
        .rev()
        .find(|&i| {
            let n = node(i);
            n.symbol == Some(sym("F"))
                && !n.modules.is_empty()
                && !under(i, other_i)
                && !under(i, branch_i)
        })
        .expect("an F");
    let (branch, leaf, other) = (node(branch_i), node(leaf_i), node(other_i));
    let text = format!(
        r#"{{ "version": 1, "edits": [
  {{ "id": 1, "system": "Plant", "target": {{ "key": "{b}" }}, "op": "remove" }},
  {{ "id": 2, "system": "Plant", "target": {{ "key": "{l}" }}, "op": "set", "name": "1", "value": 7.5 }},
  {{ "id": 3, "system": "Plant", "target": {{ "key": "{o}" }}, "op": "force", "alternative": 2 }},
  {{ "id": 4, "system": "Plant", "target": {{ "key": "{o}" }}, "op": "offset", "name": "w", "by": 1 }},
  {{ "id": 5, "system": "Plant", "target": {{ "key": "0badc0de" }}, "op": "remove" }},
  {{ "id": 6, "system": "Plant", "target": {{ "key": "{o}" }}, "op": "set", "name": "girth", "value": 1 }},
  {{ "id": 7, "system": "Plant", "target": {{ "key": "{l}" }}, "op": "force", "alternative": 2 }},
  {{ "id": 8, "system": "Plant", "target": {{ "key": "{b}" }}, "op": "force", "alternative": 3 }},
  {{ "id": 9, "system": "Plant", "target": {{ "exact": "{{A}}" }}, "op": "remove" }},
  {{ "id": 10, "system": "Plant", "target": {{ "key": "{o}" }}, "op": "material", "name": "bark" }},
  {{ "id": 11, "system": "Other", "target": {{ "key": "{o}" }}, "op": "remove" }}
] }}"#,
        b = grm_edits::key_text(branch.key),
        l = grm_edits::key_text(leaf.key),
        o = grm_edits::key_text(other.key),
    );
    let parsed = grm_edits::parse(&text);
    assert!(parsed.errors.is_empty(), "{:?}", parsed.errors);
    let file = parsed.file;
    let mine: Vec<&grm_edits::Edit> = file.of_system("Plant").collect();

    // The same string with and without the tree (both roads of the
    // engine), and on one thread or two.
    let with_tree = grow(&c, tree_rec, &file, system, 1);
    let without = grow(&c, Record::default(), &file, system, 1);
    assert_eq!(with_tree.string, without.string);
    let one = Grower::new(&c, 1, Record::default())
        .expect("grower")
        .with_edits(grm_grow::edits::edit_plan(system, mine.iter().copied()))
        .expect("edits")
        .derive(&options(4, 1), &mut |_| {})
        .expect("grows");
    assert_eq!(one.string, without.string);
    assert_ne!(without.string, plain.string);

    // The tree: one leaf per module, the removed branch's key nowhere, the
    // forced A rewritten by the second alternative.
    let t = with_tree.tree.as_ref().expect("tree");
    let leaves: usize = t.nodes.iter().map(|n| n.modules.len()).sum();
    assert_eq!(leaves, with_tree.string.len());
    assert!(t.nodes.iter().all(|n| n.key != branch.key));
    let forced = t
        .nodes
        .iter()
        .find(|n| n.key == other.key)
        .expect("forced A");
    assert_eq!(
        forced.production,
        Some(c.groups_of(sym("A"))[0].first_alt + 1)
    );
    assert_eq!(
        with_tree.origins.as_ref().map(Vec::len),
        Some(with_tree.string.len())
    );
    // The set F: 7.5 in the final string.
    let f = (0..without.string.len())
        .find(|&i| without.string.keys()[i] == leaf.key)
        .expect("the F");
    assert_eq!(without.string.get(f).1, &[7.5]);

    let outcome = without.edits.as_ref().expect("outcome");
    let reports = grm_grow::edits::classify(system, &c, outcome, mine.iter().copied());
    let class = |id: u32| {
        let r = reports.iter().find(|r| r.id == id).expect("report");
        (r.class, r.replayed)
    };
    assert_eq!(class(1), (EditClass::Valid, true));
    assert_eq!(class(2), (EditClass::Valid, true));
    assert_eq!(class(3), (EditClass::Valid, true));
    assert_eq!(class(4), (EditClass::Valid, true));
    assert_eq!(class(5), (EditClass::StructurallyInvalid, false));
    assert_eq!(class(6), (EditClass::Stale, false));
    assert_eq!(class(7), (EditClass::Stale, false), "F has one alternative");
    assert_eq!(
        class(8),
        (EditClass::Stale, false),
        "A has two alternatives"
    );
    assert_eq!(class(9), (EditClass::SemanticallyInvalid, false));
    assert_eq!(class(10), (EditClass::Valid, false));
    assert_eq!(reports.len(), 10, "edit 11 is another system's");
    let r8 = reports.iter().find(|r| r.id == 8).expect("8");
    assert!(r8.detail.contains("2 alternatives, not 3"), "{}", r8.detail);

    // Another slider value: the keys are the same, the edits still apply.
    let c30 = compiled(&checked, 30.0);
    let moved = grow(&c30, Record::default(), &file, system, 1);
    let reports30 = grm_grow::edits::classify(
        system,
        &c30,
        moved.edits.as_ref().expect("outcome"),
        mine.iter().copied(),
    );
    assert_eq!(
        reports30.iter().map(|r| r.class).collect::<Vec<_>>(),
        reports.iter().map(|r| r.class).collect::<Vec<_>>()
    );
    // Another seed: keys are minted from it, the key targets sleep.
    let reseeded = grow(&c, Record::default(), &file, system, 2);
    let asleep = grm_grow::edits::classify(
        system,
        &c,
        reseeded.edits.as_ref().expect("outcome"),
        mine.iter().copied(),
    );
    assert!(
        asleep
            .iter()
            .filter(|r| r.id <= 4)
            .all(|r| r.class == EditClass::StructurallyInvalid)
    );
    let plain2 = Grower::new(&c, 1, Record::default())
        .expect("grower")
        .derive(&options(4, 2), &mut |_| {})
        .expect("grows");
    assert_eq!(reseeded.string, plain2.string);
    // And back: the same model as before.
    assert_eq!(
        grow(&c, Record::default(), &file, system, 1).string,
        without.string
    );
}

#[test]
fn parameters_are_named_by_declaration_position_and_component() {
    let checked = inline(
        "system V { module P(d: vec3, on: bool, x: float); axiom P(vec3(1, 2, 3), true, 4) F(2); }",
    );
    let system = system(&checked);
    let words = |name: &str| {
        grm_grow::edits::parameter_slot(system, name)
            .iter()
            .zip(&system.symbols)
            .filter(|(t, _)| t.words > 0)
            .map(|(t, s)| (s.name.clone(), t.word, t.words, t.boolean))
            .collect::<Vec<_>>()
    };
    assert_eq!(words("d"), [("P".to_string(), 0, 3, false)]);
    assert_eq!(words("d.y"), [("P".to_string(), 1, 1, false)]);
    assert_eq!(words("on"), [("P".to_string(), 3, 1, true)]);
    assert_eq!(words("x"), [("P".to_string(), 4, 1, false)]);
    assert_eq!(words("3"), [("P".to_string(), 4, 1, false)]);
    assert_eq!(
        words("1"),
        [
            ("P".to_string(), 0, 3, false),
            ("F".to_string(), 0, 1, false)
        ]
    );
    assert!(words("x.y").is_empty());
    assert!(words("0").is_empty());
    assert!(words("nothing").is_empty());
}

/// A key edit's recorded symbol (`Edit::symbol`, version 3): with the
/// module's own symbol the edit replays as without one; with another the
/// module made with the key is not its part: left as it is (the string is
/// the plain one), the edit reported, with and without the tree.
#[test]
fn a_key_edit_with_another_symbol_names_nothing() {
    let checked = inline(PLANT);
    let system = system(&checked);
    let c = compiled(&checked, 25.0);
    let rec = Record {
        tree: true,
        ..Record::default()
    };
    let plain = Grower::new(&c, 1, rec)
        .expect("grower")
        .derive(&options(4, 1), &mut |_| {})
        .expect("grows");
    let tree = plain.tree.as_ref().expect("tree");
    let sym = |n: &str| c.symbol_names.iter().position(|s| s == n).expect("symbol") as u32;
    let a = tree
        .nodes
        .iter()
        .find(|n| n.iteration == 2 && n.symbol == Some(sym("A")))
        .expect("an A");
    let file = |symbol: &str| {
        let text = format!(
            r#"{{ "version": 3, "edits": [
  {{ "id": 1, "system": "Plant", "target": {{ "key": "{k}" }}, "symbol": "{symbol}", "op": "remove" }}
] }}"#,
            k = grm_edits::key_text(a.key),
        );
        let parsed = grm_edits::parse(&text);
        assert!(parsed.errors.is_empty(), "{:?}", parsed.errors);
        parsed.file
    };
    let unsymbolled = {
        let mut f = file("A");
        f.edits[0].symbol = None;
        f
    };
    let removed = grow(&c, Record::default(), &unsymbolled, system, 1);
    assert_ne!(removed.string, plain.string);
    let classify = |g: &grm_grow::Grown, f: &grm_edits::EditsFile| {
        let r = grm_grow::edits::classify(system, &c, g.edits.as_ref().expect("outcome"), &f.edits);
        (r[0].class, r[0].replayed, r[0].detail.clone())
    };
    let f = file("A");
    for record in [Record::default(), rec] {
        let g = grow(&c, record, &f, system, 1);
        assert_eq!(g.string, removed.string);
        assert_eq!(classify(&g, &f).0, EditClass::Valid);
    }
    for (symbol, detail) in [
        ("F", "no `F` module has this key now"),
        (
            "Nope",
            "no module has this key now: the system has no `Nope`",
        ),
    ] {
        let f = file(symbol);
        for record in [Record::default(), rec] {
            let g = grow(&c, record, &f, system, 1);
            assert_eq!(g.string, plain.string, "{symbol}");
            let (class, replayed, why) = classify(&g, &f);
            assert_eq!((class, replayed), (EditClass::StructurallyInvalid, false));
            assert!(why.starts_with(detail), "{why}");
        }
    }
}

//! Retarget candidates of derive mode's key edits (`grm_grow::retarget`;
//! docs/edits.md, "Retargeting"): an alternative inserted before a
//! symbol's production changes the alternative its modules are rewritten
//! by, and so every key below them, while the model stays the same. An
//! edit's key is then gone; the first candidate is the key of the same
//! module, found by its symbol and ancestry, then by where it was drawn.

mod common;

use common::*;
use grm_edits::{Edit, EditClass, Op, Target};
use grm_grow::retarget::{PartPrint, Reason, TreeParts, candidates, wants_key_candidates};
use grm_grow::{Grower, Record};

const PLANT: &str = "system Plant {
    iterations = 4;
    seed = 3;
    module A(len: float);
    axiom A(1);
    A(l) -> F(l) [ +(30) A(l * 0.8) ] [ -(25) A(l * 0.7) ] A(l * 0.9);
}";

/// The plant with an alternative of next to no weight inserted before
/// A's production (which is now its group's second alternative: the keys
/// below every A change; the model does not).
fn guarded() -> String {
    PLANT.replace(
        "    A(l) -> F(l)",
        "    A(l) -> (1e-20) F(l);\n    A(l) -> (1) F(l)",
    )
}

struct Run {
    c: grm_compile::CompiledSystem,
    grown: grm_grow::Grown,
    interp: grm_turtle::Interpretation,
}

fn run(src: &str) -> Run {
    run_removing(src, None)
}

/// `src` grown, with one edit removing the module keyed `removed`.
fn run_removing(src: &str, removed: Option<u32>) -> Run {
    let checked = inline(src);
    let c = compile(&checked);
    let mut file = grm_edits::EditsFile::default();
    if let Some(key) = removed {
        file.add("Plant", Target::Key(key), Op::Remove);
    }
    let plan = grm_grow::edits::edit_plan(system(&checked), &file.edits);
    let grown = Grower::new(
        &c,
        1,
        Record {
            tree: true,
            ..Record::default()
        },
    )
    .expect("grower")
    .with_edits(plan)
    .expect("edits")
    .derive(&options(4, 3), &mut |_| {})
    .expect("grows");
    let interp =
        grm_turtle::interpret(system(&checked), &c.settings, &grown.string).expect("interprets");
    Run { c, grown, interp }
}

fn key_edit(key: u32) -> Edit {
    let mut file = grm_edits::EditsFile::default();
    file.add("Plant", Target::Key(key), Op::Remove);
    file.edits.remove(0)
}

/// Per module of the final string: its owner's parent, the A whose
/// production wrote it (the same module in both runs: the strings agree).
fn writer(t: &grm_grow::Tree, m: u32) -> u32 {
    let n = t.node_of_module(m).expect("node");
    t.nodes[n as usize].parent.expect("parent")
}

#[test]
fn a_key_lost_to_an_inserted_rule_is_found_again_by_ancestry_and_place() {
    let before = run(PLANT);
    let after = run(&guarded());
    assert_eq!(
        before.grown.string.symbols().collect::<Vec<_>>(),
        after.grown.string.symbols().collect::<Vec<_>>(),
        "the same model"
    );
    let (t0, t1) = (
        before.grown.tree.as_ref().unwrap(),
        after.grown.tree.as_ref().unwrap(),
    );
    let p0 = TreeParts::new(t0, &before.c.symbol_names, &before.interp);
    let p1 = TreeParts::new(t1, &after.c.symbol_names, &after.interp);

    // Every A of the third string that wrote a module of the final one:
    // its key is gone, and the first candidate is the same A again.
    let mut tried = 0;
    for m in 0..before.grown.string.len() as u32 {
        let (a0, a1) = (writer(t0, m), writer(t1, m));
        let n0 = &t0.nodes[a0 as usize];
        if n0.iteration != 3 || m % 7 != 0 {
            continue;
        }
        let key = n0.key;
        assert_ne!(key, t1.nodes[a1 as usize].key, "the key changed");
        assert!(p1.node_of_key(key).is_none(), "no module has it now");
        let print = p0.print_of_key(key).expect("one module had it");
        assert_eq!(print.label.as_deref(), Some("A"));
        assert_eq!(
            print.ancestry.as_deref(),
            Some(&["A".to_owned(), "A".to_owned(), "A".to_owned()][..]),
            "the axiom's A, then two more"
        );
        assert!(print.centre.is_some(), "its subtree drew bones");
        let e = key_edit(key);
        assert!(wants_key_candidates(&e, EditClass::StructurallyInvalid));
        let c = candidates(&p1, &e, &print, 4);
        assert_eq!(c.len(), 4, "{c:?}");
        assert_eq!(c[0].node, a1, "module {m}: the same A");
        assert_eq!(c[0].target, Target::Key(t1.nodes[a1 as usize].key));
        assert_eq!(c[0].reason, Reason::Ancestry);
        tried += 1;
    }
    assert!(tried >= 3, "{tried}");
}

#[test]
fn without_the_ancestry_the_nearest_module_of_the_symbol_comes_first() {
    let after = run(&guarded());
    let t1 = after.grown.tree.as_ref().unwrap();
    let p1 = TreeParts::new(t1, &after.c.symbol_names, &after.interp);
    // An A of the third string (its subtree drew bones), whose print
    // says another chain of symbols.
    let is_a = |i: usize| {
        t1.nodes[i]
            .symbol
            .is_some_and(|s| after.c.symbol_names[s as usize] == "A")
    };
    let a = (1..t1.nodes.len())
        .rev()
        .find(|&i| t1.nodes[i].iteration == 3 && is_a(i))
        .expect("an A of the third string") as u32;
    let mut print = p1.print(a);
    print.ancestry = Some(vec!["B".to_owned()]);
    let e = key_edit(0x0bad_c0de);
    let c = candidates(&p1, &e, &print, 3);
    assert_eq!(c.len(), 3);
    assert!(c.iter().all(|x| x.reason == Reason::Nearest), "{c:?}");
    assert_eq!(c[0].node, a, "itself is nearest");
    // The same print with its own ancestry: the ancestry tier.
    let own = p1.print(a);
    let c = candidates(&p1, &e, &own, 3);
    assert_eq!((c[0].node, c[0].reason), (a, Reason::Ancestry));
    // No symbol, or one the system lacks: nothing to propose.
    assert!(candidates(&p1, &e, &PartPrint::default(), 3).is_empty());
    let gone = PartPrint {
        label: Some("Q".into()),
        ..own
    };
    assert!(candidates(&p1, &e, &gone, 3).is_empty());
    // A key edit that is valid or ambiguous, or a target of another kind,
    // gets none.
    assert!(!wants_key_candidates(&e, EditClass::Ambiguous));
    let mut exact = e.clone();
    exact.target = Target::Exact("{A, #1, F}".parse().expect("locator"));
    assert!(!wants_key_candidates(
        &exact,
        EditClass::StructurallyInvalid
    ));
}

#[test]
fn a_removed_module_leaves_a_print_and_is_found_again_after_an_inserted_rule() {
    // An A of the third string (its subtree drew bones), removed.
    let plain = run(PLANT);
    let t = plain.grown.tree.as_ref().unwrap();
    let is_a = |i: usize| {
        t.nodes[i]
            .symbol
            .is_some_and(|s| plain.c.symbol_names[s as usize] == "A")
    };
    let a = (1..t.nodes.len())
        .find(|&i| t.nodes[i].iteration == 3 && is_a(i) && i % 3 == 0)
        .expect("an A of the third string");
    let key = t.nodes[a].key;
    let parent = t.nodes[a].parent.expect("its parent");

    let removed = run_removing(PLANT, Some(key));
    let tr = removed.grown.tree.as_ref().unwrap();
    assert!(
        removed.grown.string.len() < plain.grown.string.len(),
        "its subtree is gone"
    );
    assert!(tr.nodes.iter().all(|n| n.key != key), "no node has its key");
    let part = tr
        .removed
        .iter()
        .find(|r| r.key == key)
        .expect("the tree lists it as removed");
    assert_eq!(
        (part.parent, part.iteration),
        (parent, 3),
        "made by its parent's production in step 3"
    );
    assert_eq!(tr.nodes[parent as usize].key, t.nodes[parent as usize].key);
    // Its print: its symbol, its ancestry, and (having drawn nothing) its
    // parent's place.
    let pr = TreeParts::new(tr, &removed.c.symbol_names, &removed.interp);
    let print = pr.print_of_key(key).expect("a print of the removed module");
    let p0 = TreeParts::new(t, &plain.c.symbol_names, &plain.interp);
    let whole = p0.print_of_key(key).expect("a print without the edit");
    assert_eq!(print.label, whole.label);
    assert_eq!(print.ancestry, whole.ancestry);
    assert!(print.centre.is_some(), "its parent's subtree drew bones");

    // After an inserted rule the key is gone; the first candidate is the
    // same A, by its ancestry.
    let after = run_removing(&guarded(), Some(key));
    let t1 = after.grown.tree.as_ref().unwrap();
    assert_eq!(
        after.grown.string.len(),
        plain.grown.string.len(),
        "the edit no longer applies"
    );
    let p1 = TreeParts::new(t1, &after.c.symbol_names, &after.interp);
    assert!(p1.print_of_key(key).is_none(), "no module has it now");
    let e = key_edit(key);
    let c = candidates(&p1, &e, &print, 4);
    assert!(!c.is_empty());
    assert_eq!(c[0].reason, Reason::Ancestry, "{c:?}");
    // The same A: both trees grow the same nodes in the same order (the
    // same model), so it is node `a` again.
    assert_eq!(c[0].node, a as u32);
    assert_eq!(c[0].target, Target::Key(t1.nodes[a].key));
}

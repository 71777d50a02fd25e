//! Retarget candidates for an edit that no longer finds its part (issue
//! 27; docs/edits.md, "Retargeting"): Lipp's ordering values, and the
//! candidates' order (ordering values, then symbol and tags, then the
//! nearest part of the same symbol). Ground truth by construction: a
//! window picked on the example townhouse, the grammar then changed so
//! its exact locator breaks, the part that is the same window found by
//! its world position (the change moves nothing).

mod common;

use common::*;
use grm_edits::{EditClass, EditsFile, Op, Target};
use grm_grow::shape::retarget::{self, Reason};
use grm_grow::shape::{ShapeOptions, derive, edits, lower};
use grm_shape::{NodeId, NodeKind, ShapeTree};

struct Grown {
    checked: grm_sema::Checked,
    lowered: grm_grow::shape::Lowered,
    tree: ShapeTree,
}

fn grow(text: &str) -> Grown {
    let (_, checked) = grm_sema::check_text("townhouse.grm", text);
    assert!(!checked.has_errors(), "{:?}", checked.diagnostics);
    let p = &checked.program;
    let sys = p.default_system().expect("a system");
    let lowered = lower(p, sys, &p.default_params()).expect("lowers");
    let tree = derive(&lowered, lowered.seed, &ShapeOptions::default()).expect("derives");
    Grown {
        checked,
        lowered,
        tree,
    }
}

fn townhouse() -> String {
    std::fs::read_to_string(example_path("townhouse.grm")).expect("example")
}

impl Grown {
    fn shapes(&self, symbol: &str) -> Vec<NodeId> {
        (0..self.tree.len() as u32)
            .map(NodeId)
            .filter(|&id| match self.tree.node(id).map(|n| n.kind) {
                Some(NodeKind::Shape { symbol: s, .. }) => {
                    self.lowered.program.symbol_name(s) == symbol
                }
                _ => false,
            })
            .collect()
    }

    fn centre(&self, n: NodeId) -> [f32; 3] {
        self.tree.node(n).unwrap().scope.center().to_array()
    }

    /// The window of house 2, the front facade, floor `floor`, column `column`.
    fn window(&self, floor: u32, column: u32) -> NodeId {
        let q: grm_edits::locator::SemanticQuery =
            format!("(house = 2, facade = 1, floor = {floor}, column = {column}) Window")
                .parse()
                .unwrap();
        let all = self.tree.select(&self.lowered.program, &q);
        // The front facade is the first of the two `facade = 1`.
        all[0]
    }
}

fn one_edit(target: Target) -> EditsFile {
    let mut f = EditsFile {
        version: 1,
        edits: Vec::new(),
    };
    f.add(
        "Townhouse",
        target,
        Op::Material {
            name: "brick".into(),
        },
    )
    .unwrap();
    f
}

#[test]
fn ordering_values_count_per_floor_and_facade_not_across() {
    let g = grow(&townhouse());
    let w = g.window(2, 2);
    let print = retarget::print_of(&g.lowered, &g.tree, w);
    assert_eq!(print.label.as_deref(), Some("Window"));
    // house 2 of 3; the front facade is the block's first face (its back
    // is a later one: semantic index 1 of its case too, but another
    // ordering value); the second floor of the upper floors; column 4:
    // the houses are laid along x as the columns are, so the count goes
    // on from the first house's two (only a tagged command across
    // another axis, or a component split, splits it).
    assert_eq!(
        print.order,
        [
            ("house".to_owned(), 2),
            ("facade".to_owned(), 1),
            ("floor".to_owned(), 2),
            ("column".to_owned(), 4)
        ]
    );
    let back = g
        .tree
        .select(
            &g.lowered.program,
            &"(house = 2, facade = 1, floor = 2, column = 2) Window"
                .parse()
                .unwrap(),
        )
        .into_iter()
        .nth(1)
        .expect("the back facade's window");
    let bp = retarget::print_of(&g.lowered, &g.tree, back);
    assert_eq!(bp.order[1].0, "facade");
    assert!(bp.order[1].1 > 1, "{bp:?}");
    assert_eq!(bp.order[2..], print.order[2..]);
    // Every window of the third house's first floor: the row's columns
    // 5.. in order (floors split the count: every floor starts there).
    let mut ord = retarget::Orderings::new(&g.lowered, &g.tree);
    let column = g.lowered.program.tag("column").unwrap();
    let mut floor1: Vec<u32> = Vec::new();
    for n in g.shapes("Window") {
        let p = ord.print(n);
        if p.order[0].1 == 3 && p.order[1].1 == 1 && p.order[2].1 == 1 {
            floor1.push(ord.value(column, n));
        }
    }
    assert!(floor1.len() >= 2, "{floor1:?}");
    assert_eq!(floor1, (5..5 + floor1.len() as u32).collect::<Vec<_>>());
}

#[test]
fn a_wrapped_split_is_gone_through_and_a_renamed_floor_gets_the_same_window_first() {
    let before = grow(&townhouse());
    let w = before.window(2, 2);
    let loc = before.tree.exact_locator(&before.lowered.program, w);
    let print = retarget::print_of(&before.lowered, &before.tree, w);
    let f = one_edit(Target::Exact(loc));

    // The upper floors' repeat wrapped in a one-part split: the windows
    // are where they were, and the exact locator's step to the repeat
    // goes through the inserted level (one repeat fits there).
    let text = townhouse().replace(
        "Upper -> repeat(y, floor) { STOREY: Floor };",
        "Upper -> split(y) { ~1: Uppers };\n    Uppers -> repeat(y, floor) { STOREY: Floor };",
    );
    let wrapped = grow(&text);
    let r = edits::classify(
        &wrapped.checked.program,
        &wrapped.lowered,
        &wrapped.tree,
        &f.edits,
    );
    assert_eq!(r[0].class, EditClass::Valid, "{}", r[0].detail);
    let [n] = r[0].parts[..] else {
        panic!("{:?}", r[0].parts)
    };
    assert_eq!(wrapped.centre(n), before.centre(w), "the same window");

    // `Floor` renamed: the label on the path no longer fits, and the
    // first quick fix is the same window.
    let after = grow(&grm_testkit::renamed(&townhouse(), "Floor", "Storey"));
    let r = edits::classify(
        &after.checked.program,
        &after.lowered,
        &after.tree,
        &f.edits,
    );
    assert_eq!(r[0].class, EditClass::SemanticallyInvalid);
    assert!(retarget::wants_candidates(r[0].class));
    let c = retarget::candidates(&after.lowered, &after.tree, &f.edits[0], &print, &[], 4);
    assert_eq!(c.len(), 4);
    assert_eq!(c[0].reason, Reason::Ordering);
    let Target::Exact(new) = &c[0].target else {
        panic!("an exact target stays exact: {:?}", c[0].target);
    };
    let found = match after.tree.resolve(&after.lowered.program, new) {
        grm_shape::Resolution::Found(n) => n,
        r => panic!("{new}: {r:?}"),
    };
    assert_eq!(c[0].parts, [found]);
    assert_eq!(after.centre(found), before.centre(w), "the same window");
    assert_eq!(
        retarget::print_of(&after.lowered, &after.tree, found).order,
        print.order
    );
    // Ordered by tier, and within the ordering tier by distance.
    let tiers: Vec<Reason> = c.iter().map(|x| x.reason).collect();
    let mut sorted = tiers.clone();
    sorted.sort();
    assert_eq!(tiers, sorted);
    for x in &c {
        assert_eq!(x.parts.len(), 1);
        let p = retarget::print_of(&after.lowered, &after.tree, x.parts[0]);
        assert_eq!(p.label.as_deref(), Some("Window"));
    }
    // Retargeted, the edit is valid again.
    let mut fixed = f.clone();
    fixed.retarget(1, c[0].target.clone()).unwrap();
    let r = edits::classify(
        &after.checked.program,
        &after.lowered,
        &after.tree,
        &fixed.edits,
    );
    assert_eq!(r[0].class, EditClass::Valid);
    assert_eq!(r[0].parts, [found]);
}

#[test]
fn without_a_print_the_target_itself_says_what_it_named() {
    let g = grow(&townhouse());
    // Floor 99 of a 3-floor facade: the query selects nothing; its
    // candidates keep its tags, the nearest ordering value first (the top
    // floor), as queries of the same form.
    let f = one_edit(Target::Semantic("(floor = 99) Window".parse().unwrap()));
    let r = edits::classify(&g.checked.program, &g.lowered, &g.tree, &f.edits);
    assert_eq!(r[0].class, EditClass::StructurallyInvalid);
    let print = retarget::print_of_target(&g.lowered, &g.tree, &f.edits[0]);
    assert_eq!(print.order, [("floor".to_owned(), 99)]);
    let c = retarget::candidates(&g.lowered, &g.tree, &f.edits[0], &print, &[], 3);
    let texts: Vec<String> = c.iter().map(|x| x.target.text()).collect();
    assert_eq!(
        texts,
        [
            "(floor = 3) Window",
            "(floor = 2) Window",
            "(floor = 1) Window"
        ]
    );
    assert!(c.iter().all(|x| x.reason == Reason::SymbolAndTags));
    assert_eq!(
        c[0].parts,
        g.tree
            .select(&g.lowered.program, &"(floor = 3) Window".parse().unwrap())
    );
    // An exact locator past the floors there: the nearest windows to the
    // deepest place its path reaches (the upper floors' repeat).
    let w = g.window(3, 1);
    let mut loc = g.tree.exact_locator(&g.lowered.program, w);
    let at = loc.labels.iter().position(|l| l == "repeat.y").unwrap();
    loc.edges[at] = grm_edits::locator::EdgeRef::Number(12);
    let f = one_edit(Target::Exact(loc));
    let r = edits::classify(&g.checked.program, &g.lowered, &g.tree, &f.edits);
    assert_eq!(r[0].class, EditClass::StructurallyInvalid);
    let print = retarget::print_of_target(&g.lowered, &g.tree, &f.edits[0]);
    let c = retarget::candidates(&g.lowered, &g.tree, &f.edits[0], &print, &[], 2);
    assert_eq!(c.len(), 2);
    assert!(c.iter().all(|x| x.reason == Reason::Nearest));
    // A key nothing has, without a print: nothing to go by.
    let f = one_edit(Target::Key(0x0bad_cafe));
    let print = retarget::print_of_target(&g.lowered, &g.tree, &f.edits[0]);
    assert!(retarget::candidates(&g.lowered, &g.tree, &f.edits[0], &print, &[], 3).is_empty());
    // The same key, its edit recording the symbol of the part it named:
    // parts of that symbol (no place to go by: in the tree's order).
    let mut f = one_edit(Target::Key(0x0bad_cafe));
    f.edits[0].symbol = Some("Window".into());
    let print = retarget::print_of_target(&g.lowered, &g.tree, &f.edits[0]);
    assert_eq!(print.label.as_deref(), Some("Window"));
    let c = retarget::candidates(&g.lowered, &g.tree, &f.edits[0], &print, &[], 3);
    assert_eq!(c.len(), 3);
    for x in &c {
        assert_eq!(x.reason, Reason::Nearest);
        assert!(matches!(x.target, Target::Key(_)), "{:?}", x.target);
        assert!(
            x.parts
                .iter()
                .all(|&n| g.tree.label(&g.lowered.program, n) == "Window")
        );
    }
}

#[test]
fn an_ambiguous_target_offers_each_part_it_matches_first() {
    let g = grow(&townhouse());
    let a = g.window(2, 1);
    let b = g.window(2, 2);
    let print = retarget::print_of(&g.lowered, &g.tree, b);
    // The example's keys do not collide: the parts an ambiguous target
    // matched are given (what classification found).
    let f = one_edit(Target::Key(0x0bad_cafe));
    let c = retarget::candidates(&g.lowered, &g.tree, &f.edits[0], &print, &[a, b], 3);
    let reasons: Vec<Reason> = c.iter().map(|x| x.reason).collect();
    assert_eq!(
        reasons,
        [
            Reason::OneOfMatched,
            Reason::OneOfMatched,
            Reason::SymbolAndTags
        ]
    );
    assert_eq!(c[0].parts, [b], "the one where the part was first");
    assert_eq!(c[1].parts, [a]);
    assert_eq!(c[0].target, Target::Key(g.tree.node(b).unwrap().key));
}

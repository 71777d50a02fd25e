//! Persistent edits replayed while a shape system derives (issue 27;
//! docs/edits.md, "Replay"): each operation's effect on the tree and the
//! model, scoping (a deeper target over an ancestor's, a later edit over
//! an earlier one), zero cost in shape when there are no edits, and the
//! classification of the edited tree. Targets come from the unedited tree
//! (ground truth by construction).

mod common;

use common::*;
use grm_edits::{EditsFile, Op, Target};
use grm_grow::shape::{ShapeOptions, derive, derive_with_edits, edit_plan, edits, lower};
use grm_shape::{NodeId, NodeKind, ShapeTree};

struct House {
    checked: grm_sema::Checked,
    lowered: grm_grow::shape::Lowered,
    plain: ShapeTree,
}

fn house() -> House {
    let checked = checked("townhouse.grm");
    let p = &checked.program;
    let sys = p.default_system().expect("a system");
    let lowered = lower(p, sys, &p.default_params()).expect("lowers");
    let plain = derive(&lowered, lowered.seed, &ShapeOptions::default()).expect("derives");
    House {
        checked,
        lowered,
        plain,
    }
}

impl House {
    fn symbol(&self, id: NodeId) -> &str {
        match self.plain.node(id).map(|n| n.kind) {
            Some(NodeKind::Shape { symbol, .. }) => self.lowered.program.symbol_name(symbol),
            _ => "",
        }
    }

    /// The shapes of `symbol` in the unedited tree.
    fn shapes(&self, symbol: &str) -> Vec<NodeId> {
        (0..self.plain.len() as u32)
            .map(NodeId)
            .filter(|&id| self.symbol(id) == symbol)
            .collect()
    }

    fn exact(&self, id: NodeId) -> Target {
        Target::Exact(self.plain.exact_locator(&self.lowered.program, id))
    }

    fn grow(&self, file: &EditsFile) -> ShapeTree {
        let plan = edit_plan(&self.lowered, file);
        derive_with_edits(
            &self.lowered,
            self.lowered.seed,
            &ShapeOptions::default(),
            Some(&plan),
        )
        .expect("derives with edits")
    }

    /// The node the unedited tree's `id` is in `tree`, by exact locator.
    fn find(&self, tree: &ShapeTree, id: NodeId) -> NodeId {
        let loc = self.plain.exact_locator(&self.lowered.program, id);
        match tree.resolve(&self.lowered.program, &loc) {
            grm_shape::Resolution::Found(n) => n,
            r => panic!("{loc}: {r:?}"),
        }
    }
}

fn file(edits: &[(Target, Op)]) -> EditsFile {
    let mut f = EditsFile {
        version: 1,
        edits: Vec::new(),
    };
    for (t, o) in edits {
        f.add("Townhouse", t.clone(), o.clone()).expect("an id");
    }
    f
}

fn subtree_size(tree: &ShapeTree, id: NodeId) -> usize {
    1 + tree
        .children(id)
        .map(|c| subtree_size(tree, c))
        .sum::<usize>()
}

#[test]
fn no_edits_grow_the_same_tree() {
    let h = house();
    let empty = file(&[]);
    assert_eq!(h.grow(&empty), h.plain);
    // Edits of another system are not this one's.
    let mut other = file(&[(h.exact(h.shapes("Window")[0]), Op::Remove)]);
    other.edits[0].system = "Elsewhere".into();
    assert_eq!(h.grow(&other), h.plain);
}

#[test]
fn remove_drops_the_subtree_and_draws_nothing() {
    let h = house();
    let window = h.shapes("Window")[0];
    let before = subtree_size(&h.plain, window);
    assert!(before > 1);
    let tree = h.grow(&file(&[(h.exact(window), Op::Remove)]));
    let w = h.find(&tree, window);
    assert!(tree.is_removed(w));
    assert_eq!(tree.children(w).count(), 0);
    assert_eq!(tree.len(), h.plain.len() - (before - 1));
    // The model has fewer triangles, and the classification says valid.
    let p = &h.checked.program;
    let b = grm_geom::BuildOptions::default();
    let values = p.default_params();
    let plain = grm_grow::shape::model(p, &values, &h.lowered, &h.plain, None, &b).unwrap();
    let edited = grm_grow::shape::model(p, &values, &h.lowered, &tree, None, &b).unwrap();
    assert!(edited.stats.triangles < plain.stats.triangles);
    let f = file(&[(h.exact(window), Op::Remove)]);
    let r = edits::classify(p, &h.lowered, &tree, &f.edits);
    assert_eq!(r[0].class, grm_edits::EditClass::Valid);
    assert!(r[0].replayed);
}

#[test]
fn force_picks_the_alternative_and_pin_keeps_the_draws() {
    let h = house();
    // Window has two alternatives (a blank wall, weight 1; a framed
    // window, weight 4): force each on every window in turn.
    for alt in [1u32, 2] {
        let windows = h.shapes("Window");
        let f = file(
            &windows
                .iter()
                .map(|&w| (h.exact(w), Op::Force { alternative: alt }))
                .collect::<Vec<_>>(),
        );
        let tree = h.grow(&f);
        for &w in &windows {
            let n = tree.node(h.find(&tree, w)).unwrap();
            assert!(
                matches!(n.kind, NodeKind::Shape { alternative: Some(a), .. } if a == alt - 1),
                "{:?}",
                n.kind
            );
        }
    }
    // Pin: the part's key is the pinned one, and its children's keys
    // follow from it.
    let window = h.shapes("Window")[1];
    let tree = h.grow(&file(&[(h.exact(window), Op::Pin { key: 0x1234_5678 })]));
    let w = h.find(&tree, window);
    assert_eq!(tree.node(w).unwrap().key, 0x1234_5678);
    let kids: Vec<u32> = tree
        .children(w)
        .map(|c| tree.node(c).unwrap().key)
        .collect();
    let plain: Vec<u32> = h
        .plain
        .children(window)
        .map(|c| h.plain.node(c).unwrap().key)
        .collect();
    if !kids.is_empty() {
        assert_ne!(kids, plain);
    }
}

#[test]
fn material_reaches_the_subtree_over_the_rules_and_deeper_edits_win() {
    let h = house();
    let p = &h.lowered.program;
    let floor = h.shapes("Floor")[0];
    let material = |name: &str| {
        p.materials()
            .iter()
            .position(|m| m == name)
            .map(|i| grm_shape::MaterialId(i as u32))
    };
    let drawn = |tree: &ShapeTree, id: NodeId| -> Vec<Option<grm_shape::MaterialId>> {
        fn leaves(t: &ShapeTree, id: NodeId, out: &mut Vec<NodeId>) {
            if t.children(id).count() == 0 {
                out.push(id);
            }
            for c in t.children(id) {
                leaves(t, c, out);
            }
        }
        let mut out = Vec::new();
        leaves(tree, id, &mut out);
        out.iter().map(|&l| tree.attributes(l).material).collect()
    };
    // The rules give the floor's parts glass, wood, plaster...: the edit
    // makes every part of this floor wood, and no other floor's.
    let tree = h.grow(&file(&[(
        h.exact(floor),
        Op::Material {
            name: "wood".into(),
        },
    )]));
    let f = h.find(&tree, floor);
    let parts = drawn(&tree, f);
    assert!(parts.len() > 3);
    assert!(parts.iter().all(|&m| m == material("wood")), "{parts:?}");
    let other = h.shapes("Floor")[1];
    assert_eq!(drawn(&tree, h.find(&tree, other)), drawn(&h.plain, other));
    // A window of that floor edited to glass: deeper wins, whatever the
    // order of the edits' ids.
    let window = h
        .shapes("Window")
        .into_iter()
        .find(|&w| h.plain.path(w).contains(&floor))
        .expect("a window on the floor");
    for order in [false, true] {
        let mut edits = vec![
            (
                h.exact(floor),
                Op::Material {
                    name: "wood".into(),
                },
            ),
            (
                h.exact(window),
                Op::Material {
                    name: "glass".into(),
                },
            ),
        ];
        if order {
            edits.reverse();
        }
        let tree = h.grow(&file(&edits));
        let w = h.find(&tree, window);
        assert!(drawn(&tree, w).iter().all(|&m| m == material("glass")));
        let f = h.find(&tree, floor);
        assert!(drawn(&tree, f).contains(&material("wood")));
    }
    // On one part, the later edit wins.
    let tree = h.grow(&file(&[
        (
            h.exact(window),
            Op::Material {
                name: "glass".into(),
            },
        ),
        (
            h.exact(window),
            Op::Material {
                name: "brick".into(),
            },
        ),
    ]));
    let w = h.find(&tree, window);
    assert!(drawn(&tree, w).iter().all(|&m| m == material("brick")));
}

#[test]
fn semantic_and_key_targets_replay_too() {
    let h = house();
    // Every window of the top upper floor, removed by a semantic query.
    let q: grm_edits::SemanticQuery = "(floor = end 1) Window".parse().expect("a query");
    let selected = h.plain.select(&h.lowered.program, &q);
    assert!(selected.len() > 2);
    let tree = h.grow(&file(&[(Target::Semantic(q), Op::Remove)]));
    for &w in &selected {
        assert!(tree.is_removed(h.find(&tree, w)));
    }
    assert_eq!(tree.removed().len(), selected.len());
    // One window by its key.
    let window = h.shapes("Window")[2];
    let key = h.plain.node(window).unwrap().key;
    let tree = h.grow(&file(&[(Target::Key(key), Op::Remove)]));
    assert_eq!(tree.removed(), [h.find(&tree, window).0]);
}

/// A key edit's recorded symbol (`Edit::symbol`, version 3): the key
/// names a part of that symbol only. The right symbol replays as without
/// one; another symbol's, or one the grammar lacks, matches nothing and
/// is reported, the part left as it is.
#[test]
fn a_key_edit_with_its_symbol_names_that_symbol_only() {
    let h = house();
    let p = &h.checked.program;
    let window = h.shapes("Window")[2];
    let key = h.plain.node(window).unwrap().key;
    let with = |symbol: &str| {
        let mut f = file(&[(Target::Key(key), Op::Remove)]);
        f.edits[0].symbol = Some(symbol.to_owned());
        f
    };
    let f = with("Window");
    let tree = h.grow(&f);
    assert_eq!(tree.removed(), [h.find(&tree, window).0]);
    let r = edits::classify(p, &h.lowered, &tree, &f.edits);
    assert_eq!(r[0].class, grm_edits::EditClass::Valid, "{}", r[0].detail);
    for (symbol, detail) in [
        ("Door", "no `Door` has this key now"),
        (
            "Nope",
            "no part has this key now: the grammar has no `Nope`",
        ),
    ] {
        let f = with(symbol);
        let tree = h.grow(&f);
        assert!(tree.removed().is_empty(), "{symbol}");
        assert_eq!(tree.nodes(), h.plain.nodes(), "{symbol}");
        let r = edits::classify(p, &h.lowered, &tree, &f.edits);
        assert_eq!(r[0].class, grm_edits::EditClass::StructurallyInvalid);
        assert_eq!(r[0].detail, detail);
        assert!(!r[0].replayed);
        // The same against a tree the replay did not grow (the nodes'
        // keys looked up instead of its hits).
        let r = edits::classify(p, &h.lowered, &h.plain, &f.edits);
        assert_eq!(r[0].detail, detail);
    }
    let r = edits::classify(p, &h.lowered, &h.plain, &with("Window").edits);
    assert_eq!(r[0].class, grm_edits::EditClass::Valid);
    assert_eq!(r[0].parts, [window]);
}

#[test]
fn edits_inside_a_removed_or_pinned_part_are_reported_not_applied() {
    let h = house();
    let floor = h.shapes("Floor")[0];
    let window = h
        .shapes("Window")
        .into_iter()
        .find(|&w| h.plain.path(w).contains(&floor))
        .expect("a window on the floor");
    let key = Target::Key(h.plain.node(window).unwrap().key);
    let wood = Op::Material {
        name: "wood".into(),
    };
    let p = &h.checked.program;
    for (outer, what) in [(Op::Remove, "removed"), (Op::Pin { key: 7 }, "pinned")] {
        let f = file(&[
            (h.exact(floor), outer),
            (key.clone(), wood.clone()),
            (h.exact(window), wood.clone()),
        ]);
        let tree = h.grow(&f);
        let r = edits::classify(p, &h.lowered, &tree, &f.edits);
        assert_eq!(r[0].class, grm_edits::EditClass::Valid, "{what}");
        // The key names nothing now: the part is gone or its key changed.
        assert_eq!(
            r[1].class,
            grm_edits::EditClass::StructurallyInvalid,
            "{what}"
        );
        assert!(!r[1].replayed);
        // The exact locator: gone under a removal, found under a pin.
        let exact = if what == "removed" {
            grm_edits::EditClass::StructurallyInvalid
        } else {
            grm_edits::EditClass::Valid
        };
        assert_eq!(r[2].class, exact, "{what}: {:?}", r[2]);
    }
}

/// A semantic edit records how many parts its query selected when made
/// (`selected`, edits file version 2): a derivation where the query
/// selects more (here: the count says 1, the query names every window of
/// a floor) classifies it ambiguous, reported rather than applied
/// silently to parts it did not name; where it selects as many or fewer
/// it is valid; without a count any number is valid (version 1).
#[test]
fn a_semantic_edit_selecting_more_than_it_did_is_ambiguous() {
    let h = house();
    let q: grm_edits::SemanticQuery = "(house = 1, floor = 2) Window".parse().unwrap();
    let n = h.plain.select(&h.lowered.program, &q).len();
    assert!(n > 1, "{n}");
    let material = Op::Material {
        name: "brick".into(),
    };
    for (selected, class) in [
        (None, grm_edits::EditClass::Valid),
        (Some(n as u32), grm_edits::EditClass::Valid),
        (Some(n as u32 + 3), grm_edits::EditClass::Valid),
        (Some(1), grm_edits::EditClass::Ambiguous),
    ] {
        let mut f = file(&[(Target::Semantic(q.clone()), material.clone())]);
        f.edits[0].selected = selected;
        assert_eq!(f.written_version(), if selected.is_some() { 2 } else { 1 });
        let tree = h.grow(&f);
        let r = edits::classify(&h.checked.program, &h.lowered, &tree, &f.edits);
        assert_eq!(r[0].class, class, "{selected:?}: {}", r[0].detail);
        assert_eq!(r[0].parts.len(), n);
        // The replay reached the query's parts either way.
        assert!(r[0].replayed);
        if class == grm_edits::EditClass::Ambiguous {
            assert!(
                r[0].detail
                    .contains(&format!("selects {n} parts now, 1 when")),
                "{}",
                r[0].detail
            );
        }
    }
}

/// Queries whose shapes lie deep below the tagged commands (panes, posts
/// and the glass inside them), alone and together, on one thread and
/// several: the replay removes exactly the shapes `ShapeTree::select`
/// finds in the unedited tree. The subtrees no query can name are handed
/// down as quiet (`EditPlan::quiet_children`); a wrongly quiet one would
/// lose a match here, a wrongly looked-at one costs time only.
#[test]
fn deep_queries_find_what_select_finds() {
    let h = house();
    let queries = [
        "(column = 2) Glass",
        "(floor = 1, column = end 1) Pane",
        "(house = 2, floor = 2) Wood",
        "(facade = 1) Glass",
        "(house = 1, column = 2) Post",
        "(floor = 2) Floor",
        "(house = 2) Tile",
        "(column = 1) Ledge",
    ];
    let mut all = Vec::new();
    let mut expected = std::collections::BTreeSet::new();
    for q in queries {
        let q: grm_edits::SemanticQuery = q.parse().expect("a query");
        let selected = h.plain.select(&h.lowered.program, &q);
        assert!(!selected.is_empty(), "{q} selects nothing");
        for threads in [1, 2] {
            let plan = edit_plan(
                &h.lowered,
                &file(&[(Target::Semantic(q.clone()), Op::Remove)]),
            );
            let options = ShapeOptions {
                threads,
                ..ShapeOptions::default()
            };
            let tree = derive_with_edits(&h.lowered, h.lowered.seed, &options, Some(&plan))
                .expect("derives with edits");
            let mut want: Vec<u32> = selected.iter().map(|&s| h.find(&tree, s).0).collect();
            want.sort_unstable();
            let mut got = tree.removed().to_vec();
            got.sort_unstable();
            assert_eq!(got, want, "{q} on {threads} threads");
        }
        expected.extend(selected.iter().map(|s| s.0));
        all.push((Target::Semantic(q), Op::Remove));
    }
    // Together: a removed part's subtree is not grown, so the parts
    // removed are those selected with no selected ancestor.
    let tree = h.grow(&file(&all));
    let mut want: Vec<u32> = expected
        .iter()
        .map(|&s| NodeId(s))
        .filter(|&s| {
            !h.plain
                .path(s)
                .iter()
                .any(|a| *a != s && expected.contains(&a.0))
        })
        .map(|s| h.find(&tree, s).0)
        .collect();
    want.sort_unstable();
    let mut got = tree.removed().to_vec();
    got.sort_unstable();
    assert_eq!(got, want);
}

/// Exact targets on many siblings: thirty of one floor's hundred tiles
/// and every other floor of one facade, whose trie states have more than
/// sixteen edges (looked up by binary search among a state's sorted
/// edges): each tile pinned to a key of its own, each floor removed, and
/// exactly those parts have them. The tower of the replay bench, four
/// storeys high (1,600 windows).
#[test]
fn exact_targets_on_many_siblings_are_all_found() {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../grm-lsp/benches/tower_10k.grm");
    let text = std::fs::read_to_string(&path).expect("tower_10k.grm");
    let (_, checked) = grm_sema::check_text(&path.display().to_string(), &text);
    assert!(!checked.has_errors(), "{:?}", checked.diagnostics);
    let p = &checked.program;
    let sys = p.default_system().expect("a system");
    let mut values = p.default_params();
    values[0] = grm_sema::Value::Float(4.0);
    let lowered = lower(p, sys, &values).expect("lowers");
    let plain = derive(&lowered, lowered.seed, &ShapeOptions::default()).expect("derives");
    let of = |symbol: &str| -> Vec<NodeId> {
        let s = lowered.program.symbol(symbol).expect("a symbol");
        (0..plain.len() as u32)
            .map(NodeId)
            .filter(|&id| matches!(plain.node(id).map(|n| n.kind), Some(NodeKind::Shape { symbol, .. }) if symbol == s))
            .collect()
    };
    let (tiles, floors) = (of("Tile"), of("Floor"));
    assert_eq!(tiles.len(), 1600);
    // The shape `up` levels above `id`.
    let above = |id: NodeId, up: usize| {
        let path = plain.path(id);
        assert_eq!(path.last(), Some(&id), "a path ends at its node");
        path[path.len() - 1 - up]
    };
    let first_floor = above(tiles[0], 2);
    let pinned: Vec<NodeId> = tiles
        .iter()
        .copied()
        .filter(|&t| above(t, 2) == first_floor)
        .step_by(3)
        .collect();
    assert!(pinned.len() > 16);
    let first_facade = above(floors[0], 2);
    let removed: Vec<NodeId> = floors
        .iter()
        .copied()
        .filter(|&f| above(f, 2) == first_facade && f != first_floor)
        .collect();
    assert!(removed.len() >= 3);
    let mut f = EditsFile {
        version: 1,
        edits: Vec::new(),
    };
    let exact = |id: NodeId| Target::Exact(plain.exact_locator(&lowered.program, id));
    for (i, &t) in pinned.iter().enumerate() {
        f.add(
            "Tower10k",
            exact(t),
            Op::Pin {
                key: 1000 + i as u32,
            },
        )
        .expect("an id");
    }
    for &t in &removed {
        f.add("Tower10k", exact(t), Op::Remove).expect("an id");
    }
    for threads in [1, 2] {
        let plan = edit_plan(&lowered, &f);
        let options = ShapeOptions {
            threads,
            ..ShapeOptions::default()
        };
        let tree =
            derive_with_edits(&lowered, lowered.seed, &options, Some(&plan)).expect("derives");
        let find = |id: NodeId| match tree
            .resolve(&lowered.program, &plain.exact_locator(&lowered.program, id))
        {
            grm_shape::Resolution::Found(n) => n,
            r => panic!("{r:?}"),
        };
        for (i, &t) in pinned.iter().enumerate() {
            assert_eq!(
                tree.node(find(t)).map(|n| n.key),
                Some(1000 + i as u32),
                "tile {i}, {threads} threads"
            );
        }
        let pins = (0..tree.len() as u32)
            .filter(|&n| {
                tree.node(NodeId(n))
                    .is_some_and(|n| (1000..1000 + pinned.len() as u32).contains(&n.key))
            })
            .count();
        assert_eq!(pins, pinned.len(), "{threads} threads");
        let mut want: Vec<u32> = removed.iter().map(|&t| find(t).0).collect();
        want.sort_unstable();
        let mut got = tree.removed().to_vec();
        got.sort_unstable();
        assert_eq!(got, want, "{threads} threads");
    }
}

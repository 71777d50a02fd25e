//! The engine: the tree with command nodes and numbered edges, exact and
//! semantic locators, identity keys from `grm_compile::rng`, stochastic
//! rules keyed by them, byte-identical results for any thread count, and
//! typed errors for grammars past their limits.

use glam::Vec3;
use grm_compile::rng::{child_key, name_hash, root_key, salt};
use grm_shape::{
    Alternative, Anchor, Axis, Comp, CompCase, CompTarget, EdgeRef, ExactLocator, Limits, Lot,
    NodeId, NodeKind, Op, Options, Part, Program, ProgramBuilder, Resolution, Scope, Selector,
    SemanticQuery, ShapeError, ShapeTree, Split, SymbolId, derive,
};

struct Facade {
    program: Program,
    window: SymbolId,
}

/// `Facade -> repeat(y){3: Floor} floor; Floor -> repeat(x){~0.4 Wall |
/// 1.2 Window | ~0.4 Wall} column; Window -> insert(window)`, plus `extra`
/// ops at the start of Facade's rule.
fn facade(extra: Vec<Op>) -> Facade {
    let mut b = ProgramBuilder::new("facade");
    let floor_tag = b.tag("floor");
    let column_tag = b.tag("column");
    let facade = b.symbol("Facade");
    let floor = b.symbol("Floor");
    let wall = b.symbol("Wall");
    let window = b.symbol("Window");
    let glass = b.asset("window");
    let mut ops = extra;
    ops.push(Op::Repeat(Split {
        axis: Axis::Y,
        parts: vec![Part::abs(3.0, Some(floor))],
        tag: Some(floor_tag),
    }));
    b.rule(facade, ops);
    b.rule(
        floor,
        vec![Op::Repeat(Split {
            axis: Axis::X,
            parts: vec![
                Part::float(0.4, Some(wall)),
                Part::abs(1.2, Some(window)),
                Part::float(0.4, Some(wall)),
            ],
            tag: Some(column_tag),
        })],
    );
    b.rule(window, vec![Op::Insert(glass)]);
    // `Marker`, used by one test, draws nothing and makes nothing.
    b.symbol("Marker");
    Facade {
        program: b.build(facade).unwrap(),
        window,
    }
}

fn face(w: f32, h: f32) -> Lot {
    Lot::face(Scope::new(Vec3::ZERO, Vec3::new(w, h, 0.0)))
}

fn of_symbol(tree: &ShapeTree, s: SymbolId) -> Vec<NodeId> {
    tree.nodes()
        .iter()
        .enumerate()
        .filter(|(_, n)| matches!(n.kind, NodeKind::Shape { symbol, .. } if symbol == s))
        .map(|(i, _)| NodeId(i as u32))
        .collect()
}

#[test]
fn tree_keeps_command_nodes_and_numbered_edges() {
    let f = facade(vec![]);
    let tree = derive(&f.program, &face(20.0, 9.0), &Options::default()).unwrap();
    // Facade, repeat.y, 3 floors each with a repeat.x and 10 tiles of 3
    // parts (30 shapes) and 10 inserts: 1 + 1 + 3 * (1 + 1 + 30 + 10).
    assert_eq!(tree.len(), 2 + 3 * 42);
    let windows = of_symbol(&tree, f.window);
    assert_eq!(windows.len(), 30);
    let w = windows[10 + 4]; // floor 2, column 5
    let loc = tree.exact_locator(&f.program, w);
    assert_eq!(
        loc.to_string(),
        "{Facade, #1, repeat.y, #2, Floor, #1, repeat.x, #5, Window}"
    );
    // The raw edge numbers (edits files of version 1) still resolve.
    let v1: ExactLocator = "{Facade, 1, repeat.y, 2, Floor, 1, repeat.x, 14, Window}"
        .parse()
        .unwrap();
    assert_eq!(tree.resolve(&f.program, &v1), Resolution::Found(w));
    let sem = tree.semantic_locator(&f.program, w);
    assert_eq!(sem.to_string(), "(floor = 2/3, column = 5/10) Window");
    // Every node's exact locator leads back to it.
    for i in 0..tree.len() as u32 {
        let loc = tree.exact_locator(&f.program, NodeId(i));
        assert_eq!(
            tree.resolve(&f.program, &loc),
            Resolution::Found(NodeId(i)),
            "{loc}"
        );
    }
    // Children are in order, parents link back.
    let floor_cmd = tree.children(NodeId(2)).next().unwrap();
    let edges: Vec<u32> = tree
        .children(floor_cmd)
        .map(|c| tree.node(c).unwrap().edge)
        .collect();
    assert_eq!(edges, (1..=30).collect::<Vec<_>>());
    assert!(
        tree.children(floor_cmd)
            .all(|c| tree.parent(c) == Some(floor_cmd))
    );
}

#[test]
fn semantic_queries_count_from_either_end_and_ignore_other_tags() {
    let f = facade(vec![]);
    let p = &f.program;
    let tree = derive(p, &face(20.0, 9.0), &Options::default()).unwrap();
    let q = |entries: Vec<(&str, Anchor, i64)>| SemanticQuery {
        entries: entries
            .into_iter()
            .map(|(t, a, i)| (t.to_owned(), a, i))
            .collect(),
        label: Some("Window".to_owned()),
    };
    let column5 = tree.select(p, &q(vec![("column", Anchor::Start, 5)]));
    assert_eq!(column5.len(), 3, "one per floor");
    let from_end = tree.select(p, &q(vec![("column", Anchor::End, 6)]));
    assert_eq!(
        column5, from_end,
        "column 5 of 10 is the 6th from the right"
    );
    let centre = tree.select(p, &q(vec![("column", Anchor::Centre, 0)]));
    assert_eq!(
        centre, column5,
        "the middle of 10 is the 5th (the left of the two)"
    );
    let one = tree.select(
        p,
        &q(vec![
            ("floor", Anchor::End, 1),
            ("column", Anchor::Start, 1),
        ]),
    );
    assert_eq!(one.len(), 1);
    assert_eq!(
        tree.semantic_locator(p, one[0]).to_string(),
        "(floor = 3/3, column = 1/10) Window"
    );
    // Walls are not windows.
    assert!(
        tree.select(p, &q(vec![("floor", Anchor::Start, 4)]))
            .is_empty()
    );
}

#[test]
fn shrinking_the_scope_makes_locators_structurally_invalid() {
    let f = facade(vec![]);
    let p = &f.program;
    let wide = derive(p, &face(20.0, 9.0), &Options::default()).unwrap();
    let last = *of_symbol(&wide, f.window).last().unwrap();
    let loc = wide.exact_locator(p, last);
    let narrow = derive(p, &face(12.0, 9.0), &Options::default()).unwrap();
    assert_eq!(
        narrow.resolve(p, &loc),
        Resolution::StructurallyInvalid { matched: 4 }
    );
    let mut wrong = loc.clone();
    wrong.labels[2] = "Storey".to_owned();
    assert_eq!(narrow.resolve(p, &wrong), Resolution::Invalid);
    // Grown back, the locator finds the same window (same key).
    let again = derive(p, &face(20.0, 9.0), &Options::default()).unwrap();
    let Resolution::Found(id) = again.resolve(p, &loc) else {
        panic!("not found")
    };
    assert_eq!(again.node(id).unwrap().key, wide.node(last).unwrap().key);
}

#[test]
fn keys_follow_grm_compile_identity_rules() {
    let f = facade(vec![]);
    let seed = 7;
    let tree = derive(
        &f.program,
        &face(20.0, 9.0),
        &Options {
            seed,
            ..Options::default()
        },
    )
    .unwrap();
    let root = child_key(
        root_key(seed, name_hash("facade")),
        salt(name_hash("Facade"), 0, 0),
    );
    assert_eq!(tree.nodes()[0].key, root);
    let repeat = child_key(root, salt(name_hash("repeat"), 0, 0));
    assert_eq!(tree.nodes()[1].key, repeat);
    // Floor 2 is edge 2 of the repeat.
    let floor2 = child_key(repeat, salt(name_hash("Floor"), 2, 0));
    let floors = of_symbol(&tree, f.program.symbol("Floor").unwrap());
    assert_eq!(tree.node(floors[1]).unwrap().key, floor2);
    // All keys in this tree differ.
    let mut keys: Vec<u32> = tree.nodes().iter().map(|n| n.key).collect();
    keys.sort();
    keys.dedup();
    assert_eq!(keys.len(), tree.len());
}

#[test]
fn a_shape_that_makes_nothing_moves_no_key() {
    let plain = facade(vec![]);
    let marker = plain.program.symbol("Marker").unwrap();
    let marked = facade(vec![Op::Emit(marker)]);
    let a = derive(&plain.program, &face(20.0, 9.0), &Options::default()).unwrap();
    let b = derive(&marked.program, &face(20.0, 9.0), &Options::default()).unwrap();
    let ka: Vec<u32> = of_symbol(&a, plain.window)
        .iter()
        .map(|&i| a.node(i).unwrap().key)
        .collect();
    let kb: Vec<u32> = of_symbol(&b, marked.window)
        .iter()
        .map(|&i| b.node(i).unwrap().key)
        .collect();
    assert_eq!(ka, kb);
    // The repeat is now edge 2, but still the first `repeat.y`: the
    // exact locator (ordinal edges) does not move, nor does the semantic one.
    let wa = of_symbol(&a, plain.window)[0];
    let wb = of_symbol(&b, marked.window)[0];
    assert_eq!(
        a.exact_locator(&plain.program, wa),
        b.exact_locator(&marked.program, wb)
    );
    assert_eq!(
        a.semantic_locator(&plain.program, wa),
        b.semantic_locator(&marked.program, wb)
    );
}

fn stochastic(weights: [f32; 2]) -> (Program, [SymbolId; 2]) {
    let mut b = ProgramBuilder::new("stochastic");
    let facade = b.symbol("Facade");
    let tile = b.symbol("Tile");
    let a = b.symbol("A");
    let c = b.symbol("B");
    b.rule(
        facade,
        vec![Op::Repeat(Split {
            axis: Axis::X,
            parts: vec![Part::abs(1.0, Some(tile))],
            tag: None,
        })],
    );
    b.rule_alternatives(
        tile,
        vec![
            Alternative::weighted(weights[0], vec![Op::Emit(a)]),
            Alternative::weighted(weights[1], vec![Op::Emit(c)]),
        ],
    );
    (b.build(facade).unwrap(), [a, c])
}

#[test]
fn stochastic_rules_follow_weights_and_seed() {
    let (p, [a, b]) = stochastic([1.0, 3.0]);
    let lot = face(4000.0, 1.0);
    let t = derive(&p, &lot, &Options::default()).unwrap();
    let (na, nb) = (of_symbol(&t, a).len(), of_symbol(&t, b).len());
    assert_eq!(na + nb, 4000);
    let share = na as f64 / 4000.0;
    assert!((share - 0.25).abs() < 0.03, "share of A {share}");
    // Same seed, same choices; another seed, other choices.
    assert_eq!(derive(&p, &lot, &Options::default()).unwrap(), t);
    let other = derive(
        &p,
        &lot,
        &Options {
            seed: 99,
            ..Options::default()
        },
    )
    .unwrap();
    assert_ne!(of_symbol(&other, a), of_symbol(&t, a));
    // The alternative taken is recorded on the shape.
    let tile = p.symbol("Tile").unwrap();
    for id in of_symbol(&t, tile) {
        let NodeKind::Shape {
            alternative: Some(k),
            ..
        } = t.node(id).unwrap().kind
        else {
            panic!()
        };
        let child = t.children(id).next().unwrap();
        let want = if k == 0 { a } else { b };
        assert!(
            matches!(t.node(child).unwrap().kind, NodeKind::Shape { symbol, .. } if symbol == want)
        );
    }
}

/// A tower: extrude, comp(faces) {side: Facade | top: Roof} tagged
/// facade, each facade floors and columns.
fn tower() -> (Program, Lot) {
    let mut b = ProgramBuilder::new("tower");
    let ft = b.tag("facade");
    let fl = b.tag("floor");
    let co = b.tag("column");
    let lot = b.symbol("Lot");
    let facade = b.symbol("Facade");
    let floor = b.symbol("Floor");
    let window = b.symbol("Window");
    let roof = b.symbol("Roof");
    b.rule(
        lot,
        vec![
            Op::Extrude(30.0.into()),
            Op::Comp(Comp {
                target: CompTarget::Faces,
                cases: vec![
                    CompCase {
                        selector: Selector::Side,
                        target: Some(facade),
                    },
                    CompCase {
                        selector: Selector::Top,
                        target: Some(roof),
                    },
                ],
                tag: Some(ft),
            }),
        ],
    );
    b.rule(
        facade,
        vec![Op::Repeat(Split {
            axis: Axis::Y,
            parts: vec![Part::abs(3.0, Some(floor))],
            tag: Some(fl),
        })],
    );
    b.rule(
        floor,
        vec![Op::Repeat(Split {
            axis: Axis::X,
            parts: vec![Part::float(2.0, Some(window))],
            tag: Some(co),
        })],
    );
    let program = b.build(lot).unwrap();
    let l = Lot::footprint(&[
        [0.0, 0.0],
        [20.0, 0.0],
        [20.0, 8.0],
        [8.0, 8.0],
        [8.0, 16.0],
        [0.0, 16.0],
    ])
    .unwrap();
    (program, l)
}

#[test]
fn any_thread_count_gives_the_same_bytes() {
    let (p, lot) = tower();
    let one = derive(&p, &lot, &Options::default()).unwrap();
    let dump = format!("{one:?}");
    for threads in [2, 3, 4, 7, 16, 0] {
        let t = derive(
            &p,
            &lot,
            &Options {
                threads,
                ..Options::default()
            },
        )
        .unwrap();
        assert_eq!(format!("{t:?}"), dump, "{threads} threads");
    }
    // Facades are named by selector and index within it.
    let window = p.symbol("Window").unwrap();
    let w = of_symbol(&one, window)[0];
    let loc = one.exact_locator(&p, w);
    assert_eq!(
        loc.edges[1],
        EdgeRef::Component {
            selector: Selector::Side,
            index: 1
        }
    );
    assert_eq!(
        one.semantic_locator(&p, w).to_string(),
        "(facade = 1/6, floor = 1/10, column = 1/10) Window"
    );
}

#[test]
fn errors_are_the_same_for_any_thread_count() {
    // One facade's rule pops without a push; it is the fourth side wall in
    // tree order, while the others derive normally.
    let mut b = ProgramBuilder::new("errors");
    let lot = b.symbol("Lot");
    let wall = b.symbol("Wall");
    let bad = b.symbol("Bad");
    let tile = b.symbol("Tile");
    b.rule(
        lot,
        vec![
            Op::Extrude(10.0.into()),
            Op::Comp(Comp {
                target: CompTarget::Faces,
                cases: vec![
                    CompCase {
                        selector: Selector::Left,
                        target: Some(bad),
                    },
                    CompCase {
                        selector: Selector::Side,
                        target: Some(wall),
                    },
                ],
                tag: None,
            }),
        ],
    );
    b.rule(
        wall,
        vec![Op::Repeat(Split {
            axis: Axis::X,
            parts: vec![Part::abs(0.5, Some(tile))],
            tag: None,
        })],
    );
    b.rule(bad, vec![Op::Emit(tile), Op::Pop]);
    let p = b.build(lot).unwrap();
    let l = Lot::rectangle(20.0, 20.0);
    for threads in [1, 2, 3, 8] {
        let e = derive(
            &p,
            &l,
            &Options {
                threads,
                ..Options::default()
            },
        )
        .unwrap_err();
        assert_eq!(
            e,
            ShapeError::PopWithoutPush {
                symbol: "Bad".into()
            },
            "{threads} threads"
        );
    }
    // Past the node limit: the same typed error for every thread count.
    let limits = Limits {
        max_nodes: 100,
        max_depth: 100,
    };
    for threads in [1, 2, 5] {
        let e = derive(
            &p,
            &l,
            &Options {
                threads,
                limits,
                ..Options::default()
            },
        )
        .unwrap_err();
        assert_eq!(
            e,
            ShapeError::TooManyShapes { max: 100 },
            "{threads} threads"
        );
    }
}

#[test]
fn endless_grammars_stop_with_typed_errors() {
    // A -> split(x){~1: A | ~1: A}: doubles forever.
    let mut b = ProgramBuilder::new("endless");
    let a = b.symbol("A");
    b.rule(
        a,
        vec![Op::Split(Split {
            axis: Axis::X,
            parts: vec![Part::float(1.0, Some(a)), Part::float(1.0, Some(a))],
            tag: None,
        })],
    );
    let p = b.build(a).unwrap();
    let limits = Limits {
        max_nodes: 50_000,
        max_depth: 1_000,
    };
    for threads in [1, 2] {
        let e = derive(
            &p,
            &face(1.0, 1.0),
            &Options {
                threads,
                limits,
                ..Options::default()
            },
        )
        .unwrap_err();
        assert_eq!(e, ShapeError::TooManyShapes { max: 50_000 });
    }
    // A -> A: deeper forever.
    let mut b = ProgramBuilder::new("deep");
    let a = b.symbol("A");
    b.rule(
        a,
        vec![
            Op::Translate([1.0.into(), 0.0.into(), 0.0.into()]),
            Op::Emit(a),
        ],
    );
    let p = b.build(a).unwrap();
    for threads in [1, 3] {
        let e = derive(
            &p,
            &face(1.0, 1.0),
            &Options {
                threads,
                ..Options::default()
            },
        )
        .unwrap_err();
        assert_eq!(
            e,
            ShapeError::TooDeep {
                max: 1_000,
                symbol: "A".into()
            }
        );
    }
    // A billion tiles: refused before anything is laid.
    let mut b = ProgramBuilder::new("tiles");
    let a = b.symbol("A");
    let t = b.symbol("T");
    b.rule(
        a,
        vec![Op::Repeat(Split {
            axis: Axis::X,
            parts: vec![Part::abs(1e-3, Some(t))],
            tag: None,
        })],
    );
    let p = b.build(a).unwrap();
    let e = derive(&p, &face(1e6, 1.0), &Options::default()).unwrap_err();
    assert_eq!(
        e,
        ShapeError::TooManyShapes {
            max: Limits::default().max_nodes
        }
    );
}

#[test]
fn bad_values_and_wrong_geometry_are_typed_errors() {
    let one = |ops: Vec<Op>, lot: Lot| {
        let mut b = ProgramBuilder::new("bad");
        let a = b.symbol("A");
        let t = b.symbol("T");
        let ops = ops.into_iter().map(|op| match op {
            Op::Emit(_) => Op::Emit(t),
            op => op,
        });
        b.rule(a, ops.collect());
        derive(&b.build(a).unwrap(), &lot, &Options::default())
    };
    let split_nan = Op::Split(Split {
        axis: Axis::X,
        parts: vec![Part::abs(f32::NAN, None)],
        tag: None,
    });
    assert!(matches!(
        one(vec![split_nan], face(2.0, 2.0)),
        Err(ShapeError::Size { .. })
    ));
    assert!(matches!(
        one(vec![Op::Extrude(f32::INFINITY.into())], face(2.0, 2.0)),
        Err(ShapeError::BadValue { .. })
    ));
    let faces = Op::Comp(Comp {
        target: CompTarget::Faces,
        cases: vec![CompCase {
            selector: Selector::All,
            target: None,
        }],
        tag: None,
    });
    assert!(matches!(
        one(vec![faces], face(2.0, 2.0)),
        Err(ShapeError::WrongGeometry { .. })
    ));
    // An edge cannot be extruded.
    let mut b = ProgramBuilder::new("edges");
    let a = b.symbol("A");
    let e = b.symbol("E");
    b.rule(
        a,
        vec![Op::Comp(Comp {
            target: CompTarget::Edges,
            cases: vec![CompCase {
                selector: Selector::All,
                target: Some(e),
            }],
            tag: None,
        })],
    );
    b.rule(e, vec![Op::Extrude(1.0.into())]);
    let err = derive(&b.build(a).unwrap(), &face(2.0, 2.0), &Options::default()).unwrap_err();
    assert_eq!(
        err,
        ShapeError::WrongGeometry {
            symbol: "E".into(),
            op: "extrude",
            geometry: "an edge"
        }
    );
    assert!(matches!(
        one(vec![Op::Pop], face(2.0, 2.0)),
        Err(ShapeError::PopWithoutPush { .. })
    ));
    assert!(matches!(
        Lot::footprint(&[[0.0, 0.0], [1.0, 1.0]]),
        Err(ShapeError::BadLot { .. })
    ));
    assert!(matches!(
        Lot::footprint(&[[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]),
        Err(ShapeError::BadLot { .. })
    ));
    assert!(matches!(
        Lot::footprint(&[[0.0, 0.0], [f64::NAN, 0.0], [2.0, 1.0]]),
        Err(ShapeError::BadLot { .. })
    ));
    // Program errors.
    let mut b = ProgramBuilder::new("p");
    let a = b.symbol("A");
    b.rule(a, vec![]);
    b.rule(a, vec![]);
    assert!(matches!(
        b.build(a),
        Err(grm_shape::ProgramError::DuplicateRule { .. })
    ));
    let mut b = ProgramBuilder::new("p");
    let a = b.symbol("A");
    b.rule(a, vec![Op::Emit(SymbolId(9))]);
    assert!(matches!(
        b.build(a),
        Err(grm_shape::ProgramError::UnknownId { .. })
    ));
    let mut b = ProgramBuilder::new("p");
    let a = b.symbol("A");
    b.rule_alternatives(a, vec![Alternative::weighted(0.0, vec![])]);
    assert!(matches!(
        b.build(a),
        Err(grm_shape::ProgramError::BadWeight { .. })
    ));
}

#[test]
fn scope_operations() {
    let mut b = ProgramBuilder::new("scope");
    let a = b.symbol("A");
    let t = b.symbol("T");
    let u = b.symbol("U");
    let door = b.asset("door");
    b.rule(
        a,
        vec![
            Op::Push,
            Op::Size([Some(2.0.into()), Some(1.0.into()), None]),
            Op::Center([true, false, false]),
            Op::Insert(door),
            Op::Emit(t),
            Op::Pop,
            Op::Translate([1.0.into(), 2.0.into(), 0.0.into()]),
            Op::Rotate {
                axis: Axis::Z,
                degrees: 90.0.into(),
            },
            Op::Emit(u),
        ],
    );
    let p = b.build(a).unwrap();
    let tree = derive(&p, &face(10.0, 4.0), &Options::default()).unwrap();
    let (_, asset, scope) = tree.inserts().next().unwrap();
    assert_eq!(p.asset_name(asset), "door");
    assert_eq!(scope.size, Vec3::new(2.0, 1.0, 0.0));
    assert!(
        (scope.origin - Vec3::new(4.0, 0.0, 0.0)).length() < 1e-5,
        "centred on x: {}",
        scope.origin
    );
    let tn = tree.node(of_symbol(&tree, t)[0]).unwrap();
    assert_eq!(tn.scope, *scope);
    let un = tree.node(of_symbol(&tree, u)[0]).unwrap();
    assert_eq!(un.scope.size, Vec3::new(10.0, 4.0, 0.0), "popped");
    assert!((un.scope.origin - Vec3::new(1.0, 2.0, 0.0)).length() < 1e-5);
    assert!(
        (un.scope.axes().col(0) - Vec3::Y).length() < 1e-5,
        "turned a quarter about z"
    );
    // Edge numbers: insert 1, T 2, U 3; ordinals per label.
    let edges: Vec<u32> = tree
        .children(NodeId(0))
        .map(|c| tree.node(c).unwrap().edge)
        .collect();
    assert_eq!(edges, vec![1, 2, 3]);
}

#[test]
fn threads_agree_on_cut_footprints_too() {
    // A U mass in 12 floors, each cut into 4 pieces along x (outlines made
    // by geo inside the workers' subtrees), each piece broken into faces.
    let mut b = ProgramBuilder::new("cut");
    let lot = b.symbol("Lot");
    let floor = b.symbol("Floor");
    let piece = b.symbol("Piece");
    let wall = b.symbol("Wall");
    let roof = b.symbol("Roof");
    let f = b.tag("floor");
    b.rule(
        lot,
        vec![
            Op::Extrude(36.0.into()),
            Op::Repeat(Split {
                axis: Axis::Z,
                parts: vec![Part::abs(3.0, Some(floor))],
                tag: Some(f),
            }),
        ],
    );
    b.rule(
        floor,
        vec![Op::Repeat(Split {
            axis: Axis::X,
            parts: vec![Part::float(3.0, Some(piece))],
            tag: None,
        })],
    );
    b.rule(
        piece,
        vec![Op::Comp(Comp {
            target: CompTarget::Faces,
            cases: vec![
                CompCase {
                    selector: Selector::Side,
                    target: Some(wall),
                },
                CompCase {
                    selector: Selector::Top,
                    target: Some(roof),
                },
            ],
            tag: None,
        })],
    );
    let p = b.build(lot).unwrap();
    let u = Lot::footprint(&[
        [0.0, 0.0],
        [12.0, 0.0],
        [12.0, 8.0],
        [8.0, 8.0],
        [8.0, 3.0],
        [4.0, 3.0],
        [4.0, 8.0],
        [0.0, 8.0],
    ])
    .unwrap();
    let one = derive(&p, &u, &Options::default()).unwrap();
    let roofs = of_symbol(&one, roof);
    assert_eq!(roofs.len(), 12 * 4);
    let roof_area: f64 = roofs.iter().take(4).map(|&r| one.area(r)).sum();
    assert!((roof_area - 76.0).abs() < 1e-3, "{roof_area}");
    let dump = format!("{one:?}");
    for threads in [2, 3, 5, 8] {
        let t = derive(
            &p,
            &u,
            &Options {
                threads,
                ..Options::default()
            },
        )
        .unwrap();
        assert_eq!(format!("{t:?}"), dump, "{threads} threads");
    }
}

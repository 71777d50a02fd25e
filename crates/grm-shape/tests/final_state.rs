//! A shape whose rule makes nothing (no successor, command or insert) is a
//! leaf drawn as its rule left it: its node holds the final scope and
//! geometry (docs/shapes.md, "The tree"); a shape whose rule made
//! something keeps the state it was made with. The outline table stays
//! one entry per node with an outline, in node order, and the tree is the
//! same bytes for any thread count.

use glam::Vec3;
use grm_shape::{
    Alternative, Axis, Comp, CompCase, CompTarget, Geom, Lot, NodeId, NodeKind, Op, Options, Param,
    Part, Program, ProgramBuilder, RoofKind, Selector, ShapeTree, Split, SymbolId, derive,
};

fn c(v: f32) -> Param {
    Param::Const(v)
}

fn roof(kind: RoofKind, angle: f32, overhang: f32) -> Op {
    Op::Roof {
        kind,
        angle: c(angle),
        overhang: c(overhang),
    }
}

fn comp(cases: &[(Selector, SymbolId)]) -> Op {
    Op::Comp(Comp {
        target: CompTarget::Faces,
        cases: cases
            .iter()
            .map(|&(selector, s)| CompCase {
                selector,
                target: Some(s),
            })
            .collect(),
        tag: None,
    })
}

fn of(tree: &ShapeTree, s: SymbolId) -> Vec<NodeId> {
    tree.nodes()
        .iter()
        .enumerate()
        .filter(|(_, n)| matches!(n.kind, NodeKind::Shape { symbol, .. } if symbol == s))
        .map(|(i, _)| NodeId(i as u32))
        .collect()
}

fn near(a: Vec3, b: Vec3) {
    assert!((a - b).length() < 1e-4, "{a} != {b}");
}

fn close(a: f64, b: f64, what: &str) {
    assert!((a - b).abs() < 1e-3, "{what}: {a} != {b}");
}

fn grow(p: &Program, lot: &Lot) -> ShapeTree {
    derive(p, lot, &Options::default()).unwrap()
}

/// The outline table: one entry per node with an outline, in node order.
fn outlines_in_node_order(tree: &ShapeTree) {
    let ids: Vec<u32> = tree
        .nodes()
        .iter()
        .filter_map(|n| n.geometry.outline_id())
        .map(|o| o.0)
        .collect();
    assert_eq!(ids, (0..ids.len() as u32).collect::<Vec<_>>());
    assert!(
        tree.outline(grm_shape::OutlineId(ids.len() as u32))
            .is_none()
    );
}

const L: [[f64; 2]; 6] = [
    [0.0, 0.0],
    [20.0, 0.0],
    [20.0, 8.0],
    [8.0, 8.0],
    [8.0, 16.0],
    [0.0, 16.0],
];

#[test]
fn an_extrusion_with_no_successor_is_a_mass() {
    let mut b = ProgramBuilder::new("box");
    let lot = b.symbol("Lot");
    b.rule(lot, vec![Op::Extrude(c(10.0))]);
    let p = b.build(lot).unwrap();
    let tree = grow(&p, &Lot::rectangle(10.0, 6.0));
    assert_eq!(tree.len(), 1);
    assert_eq!(tree.leaves().collect::<Vec<_>>(), [NodeId(0)]);
    assert!(matches!(tree.geom(NodeId(0)), Some(Geom::Box)));
    near(
        tree.node(NodeId(0)).unwrap().scope.size,
        Vec3::new(10.0, 6.0, 10.0),
    );
    close(tree.volume(NodeId(0)), 600.0, "box volume");
    // On a footprint: a prism over the same outline (its entry replaced in
    // place).
    let tree = grow(&p, &Lot::footprint(&L).unwrap());
    assert!(matches!(tree.geom(NodeId(0)), Some(Geom::Prism(_))));
    close(
        tree.volume(NodeId(0)),
        10.0 * (20.0 * 8.0 + 8.0 * 8.0),
        "prism volume",
    );
    outlines_in_node_order(&tree);
}

#[test]
fn a_roof_with_no_successor_is_the_roof() {
    let mut b = ProgramBuilder::new("roof");
    let lot = b.symbol("Lot");
    let top = b.symbol("Top");
    let wall = b.symbol("Wall");
    b.rule(
        lot,
        vec![
            Op::Extrude(c(5.0)),
            comp(&[(Selector::Top, top), (Selector::Side, wall)]),
        ],
    );
    b.rule(top, vec![roof(RoofKind::Hip, 45.0, 0.0)]);
    let p = b.build(lot).unwrap();
    let tree = grow(&p, &Lot::rectangle(10.0, 6.0));
    let t = of(&tree, top)[0];
    assert!(tree.leaves().any(|l| l == t));
    let Some(Geom::Roof(o)) = tree.geom(t) else {
        panic!("not a roof: {:?}", tree.geom(t));
    };
    assert_eq!(o.roof().unwrap().kind(), RoofKind::Hip);
    let n = tree.node(t).unwrap();
    near(n.scope.origin, Vec3::new(0.0, 0.0, 5.0));
    near(n.scope.size, Vec3::new(10.0, 6.0, 3.0));
    close(tree.volume(t), 72.0, "roof volume");
    // The face had no outline; the roof's took an entry, in node order.
    outlines_in_node_order(&tree);
    // The axiom's roof (a rectangle lot, no outline before) and an
    // outline's (its entry replaced).
    let mut b = ProgramBuilder::new("roof");
    let lot = b.symbol("Lot");
    b.rule(lot, vec![roof(RoofKind::Hip, 45.0, 0.0)]);
    let p = b.build(lot).unwrap();
    let tree = grow(&p, &Lot::rectangle(10.0, 6.0));
    assert!(matches!(tree.geom(NodeId(0)), Some(Geom::Roof(_))));
    near(
        tree.node(NodeId(0)).unwrap().scope.size,
        Vec3::new(10.0, 6.0, 3.0),
    );
    outlines_in_node_order(&tree);
    let tree = grow(&p, &Lot::footprint(&L).unwrap());
    assert!(matches!(tree.geom(NodeId(0)), Some(Geom::Roof(_))));
    assert!(tree.volume(NodeId(0)) > 0.0);
    outlines_in_node_order(&tree);
}

#[test]
fn push_and_pop_with_no_successor_end_in_the_popped_state() {
    let mut b = ProgramBuilder::new("pop");
    let lot = b.symbol("Lot");
    b.rule(
        lot,
        vec![
            Op::Extrude(c(4.0)),
            Op::Push,
            Op::Translate([c(1.0), c(2.0), c(3.0)]),
            Op::Size([None, None, Some(c(1.0))]),
            roof(RoofKind::Gable, 30.0, 0.0),
            Op::Pop,
            Op::Translate([c(0.0), c(0.0), c(1.0)]),
        ],
    );
    let p = b.build(lot).unwrap();
    let tree = grow(&p, &Lot::rectangle(10.0, 6.0));
    let n = tree.node(NodeId(0)).unwrap();
    assert!(matches!(tree.geom(NodeId(0)), Some(Geom::Box)));
    near(n.scope.origin, Vec3::new(0.0, 0.0, 1.0));
    near(n.scope.size, Vec3::new(10.0, 6.0, 4.0));
    // An inset that leaves nothing ends the rule quietly: the state
    // before it stays.
    let mut b = ProgramBuilder::new("inset");
    let lot = b.symbol("Lot");
    b.rule(lot, vec![Op::Extrude(c(2.0)), Op::Offset(c(-10.0))]);
    let p = b.build(lot).unwrap();
    let tree = grow(&p, &Lot::rectangle(10.0, 6.0));
    assert!(matches!(tree.geom(NodeId(0)), Some(Geom::Box)));
    near(
        tree.node(NodeId(0)).unwrap().scope.size,
        Vec3::new(10.0, 6.0, 2.0),
    );
}

#[test]
fn a_rule_that_makes_something_keeps_the_state_it_was_made_with() {
    let mut b = ProgramBuilder::new("made");
    let lot = b.symbol("Lot");
    let mass = b.symbol("Mass");
    let block = b.asset("box");
    b.rule(lot, vec![Op::Extrude(c(10.0)), Op::Insert(block)]);
    b.rule(mass, vec![]);
    let p = b.build(lot).unwrap();
    let tree = grow(&p, &Lot::rectangle(10.0, 6.0));
    // The lot is not drawn (it has a child); the insert fills the mass.
    assert_eq!(tree.leaves().collect::<Vec<_>>(), [NodeId(1)]);
    assert!(matches!(tree.geom(NodeId(0)), Some(Geom::Rect)));
    near(
        tree.node(NodeId(0)).unwrap().scope.size,
        Vec3::new(10.0, 6.0, 0.0),
    );
    near(
        tree.node(NodeId(1)).unwrap().scope.size,
        Vec3::new(10.0, 6.0, 10.0),
    );
    // A successor likewise: the lot keeps its face, the successor is the mass.
    let mut b = ProgramBuilder::new("made");
    let lot = b.symbol("Lot");
    let mass = b.symbol("Mass");
    b.rule(lot, vec![Op::Extrude(c(10.0)), Op::Emit(mass)]);
    let p = b.build(lot).unwrap();
    let tree = grow(&p, &Lot::rectangle(10.0, 6.0));
    assert!(matches!(tree.geom(NodeId(0)), Some(Geom::Rect)));
    assert!(matches!(tree.geom(NodeId(1)), Some(Geom::Box)));
    // A split whose parts make nothing is a child all the same.
    let mut b = ProgramBuilder::new("split");
    let lot = b.symbol("Lot");
    b.rule(
        lot,
        vec![
            Op::Extrude(c(10.0)),
            Op::Split(Split {
                axis: Axis::X,
                parts: vec![Part::float(1.0, None)],
                tag: None,
            }),
        ],
    );
    let p = b.build(lot).unwrap();
    let tree = grow(&p, &Lot::rectangle(10.0, 6.0));
    assert!(matches!(tree.geom(NodeId(0)), Some(Geom::Rect)));
}

/// An L-shaped tower whose facades are tiled; each tile, by chance, is a
/// box, a gable roof, an inset face, a pyramid, a turned face or a rule that
/// only paints it; the top is a hip roof. A row of such tiles straight
/// under the axiom makes them the roots of the parallel jobs.
fn town() -> Program {
    let mut b = ProgramBuilder::new("town");
    let lot = b.symbol("Lot");
    let facade = b.symbol("Facade");
    let floor = b.symbol("Floor");
    let tile = b.symbol("Tile");
    let top = b.symbol("Top");
    let row = b.symbol("Row");
    let red = b.material("red");
    b.rule(
        lot,
        vec![
            Op::Push,
            Op::Size([Some(c(20.0)), Some(c(2.0)), None]),
            Op::Translate([c(0.0), c(-4.0), c(0.0)]),
            Op::Emit(row),
            Op::Pop,
            Op::Extrude(c(30.0)),
            comp(&[(Selector::Side, facade), (Selector::Top, top)]),
        ],
    );
    b.rule(
        row,
        vec![Op::Repeat(Split {
            axis: Axis::X,
            parts: vec![Part::abs(0.5, Some(tile))],
            tag: None,
        })],
    );
    b.rule(
        facade,
        vec![Op::Repeat(Split {
            axis: Axis::Y,
            parts: vec![Part::abs(1.5, Some(floor))],
            tag: None,
        })],
    );
    b.rule(
        floor,
        vec![Op::Repeat(Split {
            axis: Axis::X,
            parts: vec![Part::float(1.0, Some(tile))],
            tag: None,
        })],
    );
    b.rule_alternatives(
        tile,
        vec![
            Alternative::new(vec![Op::Extrude(c(0.3))]),
            Alternative::new(vec![roof(RoofKind::Gable, 30.0, 0.1)]),
            Alternative::new(vec![Op::Offset(c(-0.2))]),
            Alternative::new(vec![Op::Taper(c(0.5))]),
            Alternative::new(vec![Op::Rotate {
                axis: Axis::Z,
                degrees: c(10.0),
            }]),
            Alternative::new(vec![Op::Material(red)]),
            Alternative::new(vec![Op::Offset(c(-0.2)), Op::Extrude(c(0.2))]),
        ],
    );
    b.rule(top, vec![roof(RoofKind::Hip, 30.0, 0.4)]);
    b.build(lot).unwrap()
}

#[test]
fn any_thread_count_gives_the_same_bytes_with_such_leaves() {
    let p = town();
    let lot = Lot::footprint(&L).unwrap();
    let one = grow(&p, &lot);
    assert!(one.len() > 1000, "{} nodes", one.len());
    outlines_in_node_order(&one);
    // The tiles took every kind of final state.
    let tile = p.symbol("Tile").unwrap();
    let tiles = of(&one, tile);
    let kinds = |f: fn(&Geom) -> bool| tiles.iter().filter(|&&t| f(&one.geom(t).unwrap())).count();
    assert!(kinds(|g| matches!(g, Geom::Box)) > 0);
    assert!(kinds(|g| matches!(g, Geom::Roof(_))) > 0);
    assert!(kinds(|g| matches!(g, Geom::Polygon(_))) > 0);
    assert!(kinds(|g| matches!(g, Geom::Prism(_))) > 0);
    assert!(kinds(|g| matches!(g, Geom::Rect)) > 0);
    let top = of(&one, p.symbol("Top").unwrap());
    assert!(matches!(one.geom(top[0]), Some(Geom::Roof(_))));
    let dump = format!("{one:?}");
    for threads in [2, 3, 4, 8, 0] {
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
}

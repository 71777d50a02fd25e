//! Shape attributes (material, colour, texture): set by a rule for what it
//! makes after them, inherited down the tree, saved by push and restored
//! by pop, kept by a shape whose rule makes nothing; numbered the same for
//! any thread count; and the node stays small.

use glam::Vec3;
use grm_shape::{
    AttrId, Attributes, Axis, Lot, NodeId, NodeKind, Op, Options, Param, Part, ProgramBuilder,
    Scope, ShapeError, ShapeTree, Split, SymbolId, derive,
};

fn shapes_of(tree: &ShapeTree, s: SymbolId) -> Vec<NodeId> {
    (0..tree.len() as u32)
        .map(NodeId)
        .filter(|&id| {
            matches!(tree.node(id).map(|n| n.kind),
                Some(NodeKind::Shape { symbol, .. }) if symbol == s)
        })
        .collect()
}

fn rgb(r: f32, g: f32, b: f32) -> Op {
    Op::Color([Param::Const(r), Param::Const(g), Param::Const(b)])
}

#[test]
fn the_node_stays_104_bytes() {
    assert!(std::mem::size_of::<grm_shape::Node>() <= 104);
}

#[test]
fn attributes_are_inherited_set_in_order_and_restored_by_pop() {
    let mut b = ProgramBuilder::new("attrs");
    let lot = b.symbol("Lot");
    let floor = b.symbol("Floor");
    let wall = b.symbol("Wall");
    let plain = b.symbol("Plain");
    let painted = b.symbol("Painted");
    let brick = b.material("brick");
    let tex = b.texture("bricks.png");
    // Lot: Plain (no attributes), material, Floor (brick), push, colour,
    // Painted (brick + red), pop, Plain again (brick).
    b.rule(
        lot,
        vec![
            Op::Emit(plain),
            Op::Material(brick),
            Op::Split(Split {
                axis: Axis::X,
                parts: vec![Part::rel(0.5, Some(floor)), Part::rel(0.5, Some(floor))],
                tag: None,
            }),
            Op::Push,
            rgb(1.0, 0.0, 0.0),
            Op::Emit(painted),
            Op::Pop,
            Op::Emit(plain),
        ],
    );
    // Floor: Wall inherits brick and gets the texture; Wall's rule sets a
    // colour and makes nothing: the wall keeps it.
    b.rule(floor, vec![Op::Texture(tex), Op::Emit(wall)]);
    b.rule(wall, vec![rgb(2.0, 0.5, -1.0)]);
    let program = b.build(lot).unwrap();
    let l = Lot::face(Scope::new(Vec3::ZERO, Vec3::new(10.0, 4.0, 0.0)));
    let tree = derive(&program, &l, &Options::default()).unwrap();
    assert_eq!(tree.attributes(NodeId(0)), Attributes::default());
    let plains = shapes_of(&tree, plain);
    assert_eq!(plains.len(), 2);
    assert!(tree.attributes(plains[0]).is_empty());
    let brick_only = Attributes {
        material: Some(brick),
        ..Attributes::default()
    };
    assert_eq!(tree.attributes(plains[1]), brick_only);
    for f in shapes_of(&tree, floor) {
        assert_eq!(tree.attributes(f), brick_only);
    }
    let painted = shapes_of(&tree, painted);
    assert_eq!(
        tree.attributes(painted[0]),
        Attributes {
            material: Some(brick),
            color: Some([1.0, 0.0, 0.0]),
            texture: None
        }
    );
    let walls = shapes_of(&tree, wall);
    assert_eq!(walls.len(), 2);
    for w in walls {
        // Clamped to [0, 1].
        assert_eq!(
            tree.attributes(w),
            Attributes {
                material: Some(brick),
                color: Some([1.0, 0.5, 0.0]),
                texture: Some(tex)
            }
        );
    }
    // Numbered by first use: none, brick, brick + texture, ...
    assert_eq!(tree.attribute_table()[0], Attributes::default());
    assert_eq!(tree.attribute_table()[1], brick_only);
    assert_eq!(program.material_name(brick), "brick");
    assert_eq!(program.texture_name(tex), "bricks.png");
}

#[test]
fn attributes_are_the_same_for_any_thread_count() {
    let mut b = ProgramBuilder::new("facade");
    let facade = b.symbol("Facade");
    let floor = b.symbol("Floor");
    let tile = b.symbol("Tile");
    let window = b.symbol("Window");
    let glass = b.material("glass");
    let asset = b.asset("box");
    b.rule(
        facade,
        vec![Op::Repeat(Split {
            axis: Axis::Y,
            parts: vec![Part::abs(3.0, Some(floor))],
            tag: None,
        })],
    );
    b.rule(
        floor,
        vec![Op::Repeat(Split {
            axis: Axis::X,
            parts: vec![Part::abs(2.0, Some(tile))],
            tag: None,
        })],
    );
    // Tiles pick one of three colours at random; windows are glass.
    b.rule_alternatives(
        tile,
        (0..3)
            .map(|k| {
                grm_shape::Alternative::new(vec![
                    rgb(0.2 * k as f32, 0.5, 0.5),
                    Op::Emit(window),
                    Op::Material(glass),
                    Op::Insert(asset),
                ])
            })
            .collect(),
    );
    let program = b.build(facade).unwrap();
    let l = Lot::face(Scope::new(Vec3::ZERO, Vec3::new(40.0, 60.0, 0.0)));
    let one = derive(&program, &l, &Options::default()).unwrap();
    assert_eq!(
        one.attribute_table().len(),
        7,
        "{:?}",
        one.attribute_table()
    );
    for threads in [2, 3, 8] {
        let t = derive(
            &program,
            &l,
            &Options {
                threads,
                ..Options::default()
            },
        )
        .unwrap();
        assert_eq!(t, one, "{threads} threads");
    }
    // Every insert has the glass material and its tile's colour.
    for (id, _, _) in one.inserts() {
        let a = one.attributes(id);
        assert_eq!(a.material, Some(glass));
        assert!(a.color.is_some());
        let w = one.attributes(NodeId(id.0 - 1));
        assert_eq!(w.material, None);
        assert_eq!(w.color, a.color);
    }
    assert!(one.nodes().iter().all(|n| n.attrs.0 < 7));
    assert!(one.nodes().iter().any(|n| n.attrs != AttrId(0)));
}

#[test]
fn a_nan_colour_is_a_typed_error_and_unknown_ids_are_refused() {
    let mut b = ProgramBuilder::new("bad");
    let lot = b.symbol("Lot");
    b.rule(lot, vec![rgb(f32::NAN, 0.0, 0.0)]);
    let program = b.build(lot).unwrap();
    let e = derive(&program, &Lot::rectangle(1.0, 1.0), &Options::default()).unwrap_err();
    assert!(
        matches!(e, ShapeError::BadValue { what, .. } if what.contains("colour")),
        "{e:?}"
    );
    let mut b = ProgramBuilder::new("bad");
    let lot = b.symbol("Lot");
    b.rule(lot, vec![Op::Material(grm_shape::MaterialId(3))]);
    assert!(b.build(lot).is_err());
    let mut b = ProgramBuilder::new("bad");
    let lot = b.symbol("Lot");
    b.rule(lot, vec![Op::Texture(grm_shape::TextureId(0))]);
    assert!(b.build(lot).is_err());
}

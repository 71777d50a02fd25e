//! Splits cut the real geometry: L- and U-shaped masses split into pieces
//! whose footprints and volumes add up to the whole, each inside its slab;
//! a component split names walls by orientation with their own frames.

use glam::Vec3;
use grm_shape::{
    Axis, Comp, CompCase, CompTarget, Geom, Geometry, Lot, NodeId, NodeKind, Op, Options, Part,
    ProgramBuilder, Selector, ShapeTree, Split, derive,
};

const L: [[f64; 2]; 6] = [
    [0.0, 0.0],
    [10.0, 0.0],
    [10.0, 4.0],
    [4.0, 4.0],
    [4.0, 10.0],
    [0.0, 10.0],
];
const U: [[f64; 2]; 8] = [
    [0.0, 0.0],
    [12.0, 0.0],
    [12.0, 8.0],
    [8.0, 8.0],
    [8.0, 3.0],
    [4.0, 3.0],
    [4.0, 8.0],
    [0.0, 8.0],
];

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-4 * b.abs().max(1.0)
}

/// `Lot -> extrude(h) Mass; Mass -> <ops>`; returns the tree and the
/// leaves of symbol `Piece`.
fn grow(lot: &[[f64; 2]], h: f32, mass_ops: Vec<Op>, piece: &str) -> (ShapeTree, Vec<usize>) {
    let mut b = ProgramBuilder::new("geometry");
    let lot_s = b.symbol("Lot");
    let mass = b.symbol("Mass");
    let p = b.symbol(piece);
    b.rule(lot_s, vec![Op::Extrude(h.into()), Op::Emit(mass)]);
    b.rule(mass, mass_ops);
    let program = b.build(lot_s).unwrap();
    let tree = derive(&program, &Lot::footprint(lot).unwrap(), &Options::default()).unwrap();
    let leaves = tree
        .nodes()
        .iter()
        .enumerate()
        .filter(|(_, n)| matches!(n.kind, NodeKind::Shape { symbol, .. } if symbol == p))
        .map(|(i, _)| i)
        .collect();
    (tree, leaves)
}

fn split_op(axis: Axis, parts: Vec<Part>) -> Op {
    Op::Split(Split {
        axis,
        parts,
        tag: None,
    })
}

/// Every vertex of a piece's footprint, in world coordinates.
fn world_points(tree: &ShapeTree, i: usize) -> Vec<Vec3> {
    let n = &tree.nodes()[i];
    let outline =
        grm_shape::component::outline_of(&n.scope, &tree.geom(NodeId(i as u32)).unwrap()).unwrap();
    outline
        .rings()
        .flatten()
        .map(|p| n.scope.world(Vec3::new(p[0] as f32, p[1] as f32, 0.0)))
        .collect()
}

#[test]
fn l_mass_split_along_x_tiles_the_volume_and_stays_in_slabs() {
    // L area = 10*4 + 4*6 = 64; volume at height 6 = 384.
    let p = Some(grm_shape::SymbolId(2));
    let (tree, pieces) = grow(
        &L,
        6.0,
        vec![split_op(
            Axis::X,
            vec![
                Part::float(1.0, p),
                Part::float(1.0, p),
                Part::float(1.0, p),
            ],
        )],
        "Piece",
    );
    assert_eq!(pieces.len(), 3);
    let vols: Vec<f64> = pieces
        .iter()
        .map(|&i| tree.volume(NodeId(i as u32)))
        .collect();
    // Slab x in [0, 10/3]: the full 10-deep arm: 10/3 * 10 = 33.33;
    // [10/3, 4]: 2/3 * 10 = 6.67 plus... (4 - 10/3) * 10 = 6.667;
    // [4, 20/3]: (20/3 - 4) * 4 = 10.667: each times 6.
    let a1 = 10.0 / 3.0 * 10.0;
    let a2 = (4.0 - 10.0 / 3.0) * 10.0 + (20.0 / 3.0 - 4.0) * 4.0;
    let a3 = (10.0 - 20.0 / 3.0) * 4.0;
    for (v, a) in vols.iter().zip([a1, a2, a3]) {
        assert!(close(*v, a * 6.0), "volumes {vols:?}");
    }
    assert!(close(vols.iter().sum::<f64>(), 384.0));
    for (k, &i) in pieces.iter().enumerate() {
        let lo = k as f32 * 10.0 / 3.0;
        for p in world_points(&tree, i) {
            assert!(
                p.x >= lo - 1e-4 && p.x <= lo + 10.0 / 3.0 + 1e-4,
                "piece {k} point {p}"
            );
        }
        // The middle piece keeps the L's corner: not a rectangle.
        if k == 1 {
            assert!(matches!(tree.nodes()[i].geometry, Geometry::Prism(_)));
        }
    }
    // The last slab (x in [6.67, 10]) holds only the 4-deep arm: a box in
    // a 10-deep scope is a prism with a rectangular outline 4 deep.
    let (lo, hi) = tree
        .geom(NodeId(pieces[2] as u32))
        .unwrap()
        .outline()
        .unwrap()
        .bounds()
        .unwrap();
    assert!(close(lo[1], 0.0) && close(hi[1], 4.0), "{lo:?} {hi:?}");
}

#[test]
fn u_mass_split_along_y_separates_the_arms_into_one_piece() {
    // U area = 12*3 + 2*4*5 = 76; split y at 5: below 12*3 + 2*4*2 = 52,
    // above the two arms 2*4*3 = 24.
    let p = Some(grm_shape::SymbolId(2));
    let (tree, pieces) = grow(
        &U,
        3.0,
        vec![split_op(
            Axis::Y,
            vec![Part::abs(5.0, p), Part::float(1.0, p)],
        )],
        "Piece",
    );
    assert_eq!(pieces.len(), 2);
    let areas: Vec<f64> = pieces
        .iter()
        .map(|&i| tree.area(NodeId(i as u32)))
        .collect();
    assert!(close(areas[0], 52.0) && close(areas[1], 24.0), "{areas:?}");
    let top_geom = tree.geom(NodeId(pieces[1] as u32)).unwrap();
    let top = top_geom.outline().unwrap();
    assert_eq!(top.polygons().0.len(), 2, "the two arms");
    for p in world_points(&tree, pieces[1]) {
        assert!(p.y >= 5.0 - 1e-4 && p.y <= 8.0 + 1e-4);
    }
    let total: f64 = pieces.iter().map(|&i| tree.volume(NodeId(i as u32))).sum();
    assert!(close(total, 76.0 * 3.0));
}

#[test]
fn u_mass_repeat_along_x_and_z_split_add_up() {
    let p = Some(grm_shape::SymbolId(2));
    // Repeat 1.5-wide slabs across 12: 8 tiles; each then keeps its footprint.
    let (tree, pieces) = grow(
        &U,
        9.0,
        vec![Op::Repeat(Split {
            axis: Axis::X,
            parts: vec![Part::abs(1.5, p)],
            tag: None,
        })],
        "Piece",
    );
    assert_eq!(pieces.len(), 8);
    let total: f64 = pieces.iter().map(|&i| tree.volume(NodeId(i as u32))).sum();
    assert!(close(total, 76.0 * 9.0), "{total}");
    // A z split keeps the footprint and divides the height.
    let (tree, floors) = grow(
        &U,
        9.0,
        vec![Op::Repeat(Split {
            axis: Axis::Z,
            parts: vec![Part::abs(3.0, p)],
            tag: None,
        })],
        "Piece",
    );
    assert_eq!(floors.len(), 3);
    for (k, &i) in floors.iter().enumerate() {
        let n = &tree.nodes()[i];
        assert!(close(tree.area(NodeId(i as u32)), 76.0));
        assert!(close(f64::from(n.scope.origin.z), 3.0 * k as f64));
        assert!(close(f64::from(n.scope.size.z), 3.0));
    }
}

#[test]
fn rectangular_lot_splits_stay_boxes() {
    let p = Some(grm_shape::SymbolId(2));
    let (tree, pieces) = grow(
        &[[0.0, 0.0], [8.0, 0.0], [8.0, 5.0], [0.0, 5.0]],
        3.0,
        vec![split_op(
            Axis::X,
            vec![Part::abs(2.0, p), Part::float(1.0, p)],
        )],
        "Piece",
    );
    assert!(
        pieces
            .iter()
            .all(|&i| tree.nodes()[i].geometry == Geometry::Box)
    );
    let sizes: Vec<Vec3> = pieces.iter().map(|&i| tree.nodes()[i].scope.size).collect();
    assert_eq!(
        sizes,
        vec![Vec3::new(2.0, 5.0, 3.0), Vec3::new(6.0, 5.0, 3.0)]
    );
}

fn comp_all(cases: Vec<CompCase>) -> Vec<Op> {
    vec![Op::Comp(Comp {
        target: CompTarget::Faces,
        cases,
        tag: None,
    })]
}

#[test]
fn l_mass_component_split_names_walls_by_orientation() {
    let mut b = ProgramBuilder::new("comp");
    let lot = b.symbol("Lot");
    let mass = b.symbol("Mass");
    let names = ["Front", "Back", "Left", "Right", "Top", "Bottom"];
    let ids: Vec<_> = names.iter().map(|n| b.symbol(n)).collect();
    let sels = [
        Selector::Front,
        Selector::Back,
        Selector::Left,
        Selector::Right,
        Selector::Top,
        Selector::Bottom,
    ];
    b.rule(lot, vec![Op::Extrude(6.0.into()), Op::Emit(mass)]);
    b.rule(
        mass,
        comp_all(
            sels.iter()
                .zip(&ids)
                .map(|(&selector, &t)| CompCase {
                    selector,
                    target: Some(t),
                })
                .collect(),
        ),
    );
    let program = b.build(lot).unwrap();
    let tree = derive(&program, &Lot::footprint(&L).unwrap(), &Options::default()).unwrap();
    let faces: Vec<(String, u32, u32, &grm_shape::Node, NodeId)> = tree
        .nodes()
        .iter()
        .enumerate()
        .filter_map(|(i, n)| match n.kind {
            NodeKind::Shape { symbol, .. } if ids.contains(&symbol) => Some((
                program.symbol_name(symbol).to_owned(),
                n.index,
                n.count,
                n,
                NodeId(i as u32),
            )),
            _ => None,
        })
        .collect();
    let summary: Vec<(String, u32, u32)> = faces.iter().map(|f| (f.0.clone(), f.1, f.2)).collect();
    // Ring from (0,0) counter-clockwise: front 10, right 4, back 6,
    // right 6, back 4, left 10; then top and bottom.
    let want = [
        ("Front", 1, 1),
        ("Right", 1, 2),
        ("Back", 1, 2),
        ("Right", 2, 2),
        ("Back", 2, 2),
        ("Left", 1, 1),
        ("Top", 1, 1),
        ("Bottom", 1, 1),
    ];
    assert_eq!(
        summary,
        want.iter()
            .map(|w| (w.0.to_owned(), w.1, w.2))
            .collect::<Vec<_>>()
    );
    let widths: Vec<f32> = faces.iter().take(6).map(|f| f.3.scope.size.x).collect();
    assert_eq!(widths, vec![10.0, 4.0, 6.0, 6.0, 4.0, 10.0]);
    // Wall area = perimeter * height = 40 * 6.
    let wall_area: f64 = faces.iter().take(6).map(|f| tree.area(f.4)).sum();
    assert!(close(wall_area, 240.0));
    // The inner right wall: origin at its start corner (4, 4, 0), x along
    // it (+y), y up, z its outward normal (+x).
    let inner = faces[3].3;
    assert!((inner.scope.origin - Vec3::new(4.0, 4.0, 0.0)).length() < 1e-5);
    assert!((inner.scope.axes().col(0) - Vec3::Y).length() < 1e-5);
    assert!((inner.scope.axes().col(1) - Vec3::Z).length() < 1e-5);
    assert!((inner.scope.axes().col(2) - Vec3::X).length() < 1e-5);
    assert_eq!(inner.scope.size, Vec3::new(6.0, 6.0, 0.0));
    // Front: z points out of the building (-y).
    assert!((faces[0].3.scope.axes().col(2) + Vec3::Y).length() < 1e-5);
    // Top at the roof, bottom facing down, both the L's area.
    let (top, bottom) = (faces[6].3, faces[7].3);
    assert!(close(f64::from(top.scope.origin.z), 6.0) && close(tree.area(faces[6].4), 64.0));
    assert!(close(tree.area(faces[7].4), 64.0));
    let bottom_geom = tree.geom(faces[7].4).unwrap();
    assert!((bottom.scope.axes().col(2) + Vec3::Z).length() < 1e-5);
    // The bottom's outline, mapped to the world, is the L itself.
    let mut pts: Vec<(i32, i32)> = bottom_geom
        .outline()
        .unwrap()
        .rings()
        .flatten()
        .map(|p| {
            let w = bottom.scope.world(Vec3::new(p[0] as f32, p[1] as f32, 0.0));
            (w.x.round() as i32, w.y.round() as i32)
        })
        .collect();
    pts.sort();
    assert_eq!(
        pts,
        vec![(0, 0), (0, 10), (4, 4), (4, 10), (10, 0), (10, 4)]
    );
}

#[test]
fn courtyard_walls_face_into_the_court() {
    let outer = [[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]];
    let mut b = ProgramBuilder::new("court");
    let lot = b.symbol("Lot");
    let inset = b.symbol("Inset");
    b.rule(lot, vec![Op::Offset((-3.0).into()), Op::Emit(inset)]);
    b.rule(inset, vec![]);
    let program = b.build(lot).unwrap();
    let tree = derive(
        &program,
        &Lot::footprint(&outer).unwrap(),
        &Options::default(),
    )
    .unwrap();
    // The inset is the 4x4 square in the middle.
    let inset_node = tree
        .nodes()
        .iter()
        .position(|n| matches!(n.kind, NodeKind::Shape { symbol, .. } if symbol == inset))
        .unwrap();
    assert!(close(tree.area(NodeId(inset_node as u32)), 16.0));
    // A courtyard: a footprint with a hole, made by geo from two rings.
    let ring =
        |r: &[[f64; 2]]| geo::LineString::from(r.iter().map(|p| (p[0], p[1])).collect::<Vec<_>>());
    let court = geo::Polygon::new(
        ring(&outer),
        vec![ring(&[[4.0, 4.0], [6.0, 4.0], [6.0, 6.0], [4.0, 6.0]])],
    );
    let outline = grm_shape::Outline::new(geo::MultiPolygon::new(vec![court]));
    let scope = grm_shape::Scope::new(Vec3::ZERO, Vec3::new(10.0, 10.0, 5.0));
    let geometry = Geom::Prism(std::sync::Arc::new(outline));
    let comps = grm_shape::component::components(&scope, &geometry, CompTarget::Faces).unwrap();
    assert_eq!(comps.len(), 10, "4 outer walls, 4 court walls, top, bottom");
    for c in &comps[4..8] {
        // Each court wall's normal points to the court's centre.
        let mid = c.scope.world(Vec3::new(c.scope.size.x / 2.0, 0.0, 0.0));
        let to_centre = Vec3::new(5.0, 5.0, 0.0) - mid;
        assert!(c.scope.axes().col(2).dot(to_centre) > 0.0);
    }
    assert!(close(comps[8].geometry.area(&comps[8].scope), 96.0));
}

#[test]
fn edges_of_a_box_and_of_a_face() {
    let scope = grm_shape::Scope::new(Vec3::ZERO, Vec3::new(4.0, 3.0, 2.0));
    let edges = grm_shape::component::components(&scope, &Geom::Box, CompTarget::Edges).unwrap();
    assert_eq!(edges.len(), 12);
    let total: f32 = edges.iter().map(|e| e.scope.size.x).sum();
    assert!((total - 4.0 * (4.0 + 3.0 + 2.0)).abs() < 1e-5);
    assert_eq!(
        edges
            .iter()
            .filter(|e| e.classes.matches(Selector::Side))
            .count(),
        4
    );
    assert_eq!(
        edges
            .iter()
            .filter(|e| e.classes.matches(Selector::Top))
            .count(),
        4
    );
    let face = grm_shape::Scope::new(Vec3::ZERO, Vec3::new(4.0, 3.0, 0.0));
    let fe = grm_shape::component::components(&face, &Geom::Rect, CompTarget::Edges).unwrap();
    let classes: Vec<_> = fe.iter().map(|e| e.classes.facing()).collect();
    assert_eq!(
        classes,
        vec![
            Some(Selector::Bottom),
            Some(Selector::Right),
            Some(Selector::Top),
            Some(Selector::Left)
        ]
    );
    assert!(grm_shape::component::components(&face, &Geom::Rect, CompTarget::Faces).is_err());
    assert!(grm_shape::component::components(&face, &Geom::Edge, CompTarget::Edges).is_err());
}

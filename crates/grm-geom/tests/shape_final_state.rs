//! Shape mode: a shape whose rule makes nothing is drawn as its rule left
//! it (docs/shapes.md, "The tree"): `Lot -> extrude(10);` is a box, a leaf
//! `roof(hip, ...)` its slopes, and every triangle lies in the scope of
//! the node that picks it.

use glam::{Quat, Vec3};
use grm_geom::shape::{ShapeAssets, build_shape_model};
use grm_geom::{BuildOptions, Model, PartSource};
use grm_shape::{
    Comp, CompCase, CompTarget, Lot, NodeId, Op, Options, Param, ProgramBuilder, RoofKind,
    Selector, ShapeTree, derive,
};

fn model(tree: &ShapeTree, program: &grm_shape::Program) -> Model {
    build_shape_model(
        tree,
        program,
        &ShapeAssets::default(),
        &BuildOptions::default(),
    )
    .expect("model")
}

/// Every triangle lies in the scope of the node that picks it (the model
/// is y-up: world z is model y).
fn inside_scopes(model: &Model, tree: &ShapeTree) {
    for part in &model.parts {
        let m = &part.mesh;
        for pick in &part.picks {
            let PartSource::Shape(node) = pick.source else {
                panic!("a shape model's pick is {:?}", pick.source);
            };
            let scope = tree.node(NodeId(node)).expect("node").scope;
            let inv: Quat = scope.rotation().inverse();
            let tris =
                pick.first_triangle as usize..(pick.first_triangle + pick.triangle_count) as usize;
            for t in tris {
                for &i in &m.indices[3 * t..3 * t + 3] {
                    let p = m.positions[i as usize];
                    let local = inv * (Vec3::new(p[0], -p[2], p[1]) - scope.origin);
                    let eps = 1e-3;
                    assert!(
                        local.cmpge(Vec3::splat(-eps)).all()
                            && local.cmple(scope.size + Vec3::splat(eps)).all(),
                        "node {node}: local {local} outside {}",
                        scope.size
                    );
                }
            }
        }
    }
}

#[test]
fn an_extrusion_with_no_successor_draws_a_box() {
    let mut b = ProgramBuilder::new("box");
    let lot = b.symbol("Lot");
    b.rule(lot, vec![Op::Extrude(Param::Const(10.0))]);
    let program = b.build(lot).expect("program");
    let tree = derive(&program, &Lot::rectangle(10.0, 6.0), &Options::default()).expect("tree");
    let m = model(&tree, &program);
    assert_eq!(m.stats.triangles, 12);
    inside_scopes(&m, &tree);
    // 10 high: the model's y (world z) spans [0, 10].
    let ys: Vec<f32> = m.parts[0].mesh.positions.iter().map(|p| p[1]).collect();
    let top = ys.iter().copied().fold(f32::MIN, f32::max);
    let bottom = ys.iter().copied().fold(f32::MAX, f32::min);
    assert!(
        (top - 10.0).abs() < 1e-5 && bottom.abs() < 1e-5,
        "{bottom}..{top}"
    );
}

/// `Lot -> extrude(5) comp(faces) { top: Top }; Top -> roof(hip, 30, 0);`
/// on a 10 x 6 lot: the top face draws as the roof, two trapezoid slopes,
/// two hip ends and the underside.
#[test]
fn a_hip_roof_leaf_draws_its_slopes() {
    let mut b = ProgramBuilder::new("roof");
    let lot = b.symbol("Lot");
    let top = b.symbol("Top");
    b.rule(
        lot,
        vec![
            Op::Extrude(Param::Const(5.0)),
            Op::Comp(Comp {
                target: CompTarget::Faces,
                cases: vec![CompCase {
                    selector: Selector::Top,
                    target: Some(top),
                }],
                tag: None,
            }),
        ],
    );
    b.rule(
        top,
        vec![Op::Roof {
            kind: RoofKind::Hip,
            angle: Param::Const(30.0),
            overhang: Param::Const(0.0),
        }],
    );
    let program = b.build(lot).expect("program");
    let tree = derive(&program, &Lot::rectangle(10.0, 6.0), &Options::default()).expect("tree");
    let m = model(&tree, &program);
    assert_eq!(m.stats.triangles, 2 * 2 + 2 + 2);
    inside_scopes(&m, &tree);
    let mesh = &m.parts[0].mesh;
    let mut up = 0.0f32;
    for t in mesh.indices.chunks_exact(3) {
        let p = |k: usize| Vec3::from_array(mesh.positions[t[k] as usize]);
        // Everything stands on the mass's top, 5 up.
        for k in 0..3 {
            assert!(p(k).y >= 5.0 - 1e-4, "{}", p(k));
        }
        let n = (p(1) - p(0)).cross(p(2) - p(0));
        if n.y > 0.0 {
            up += 0.5 * n.length();
        }
    }
    let slopes = 60.0 / 30f32.to_radians().cos();
    assert!((up - slopes).abs() < 1e-2, "slopes {up}, expected {slopes}");
}

//! Shape mode on the one road (`grm_grow::shape`): a checked shape system
//! lowered, derived and built; the same tree for any thread count;
//! meta-parameters and expressions lowered with the run's values; the
//! engine's errors as coded diagnostics at the rule; the tree's JSON.

mod common;

use common::*;
use grm_diag::Code;
use grm_grow::shape::{ShapeGrowError, ShapeOptions, derive, grow, json, lower};
use grm_shape::NodeKind;

fn system(c: &grm_sema::Checked) -> &grm_sema::System {
    c.program.default_system().expect("a system")
}

#[test]
fn the_townhouse_grows_into_a_model_with_a_group_per_drawn_shape() {
    let c = checked("townhouse.grm");
    let p = &c.program;
    let build = grm_geom::BuildOptions::default();
    let g = grow(
        p,
        system(&c),
        &p.default_params(),
        &ShapeOptions::default(),
        Some((&build, None)),
        None,
    )
    .expect("grows");
    assert_eq!(g.seed, 1);
    let model = g.model.expect("a model");
    assert!(model.stats.triangles > 500, "{}", model.stats.triangles);
    // Three houses, each with a roof.
    let roofs = g
        .tree
        .nodes()
        .iter()
        .filter(|n| matches!(n.kind, NodeKind::Shape { symbol, .. } if g.lowered.program.symbol_name(symbol) == "Roof"))
        .count();
    assert_eq!(roofs, 3);
    // Every rewritten shape's rule is a rule of its symbol.
    for n in g.tree.nodes() {
        if let NodeKind::Shape {
            symbol,
            alternative: Some(a),
        } = n.kind
        {
            let r = g.lowered.rule_of(symbol, a).expect("a rule") as usize;
            assert_eq!(g.lowered.rules[r].symbol, symbol);
        }
    }
}

#[test]
fn any_thread_count_gives_the_same_tree() {
    let c = checked("townhouse.grm");
    let p = &c.program;
    let lowered = lower(p, system(&c), &p.default_params()).expect("lowers");
    let one = derive(&lowered, 5, &ShapeOptions::default()).expect("derives");
    for threads in [2, 3, 0] {
        let opts = ShapeOptions {
            threads,
            ..ShapeOptions::default()
        };
        assert_eq!(
            derive(&lowered, 5, &opts).expect("derives"),
            one,
            "{threads}"
        );
    }
}

#[test]
fn parameters_and_expressions_are_lowered_with_the_runs_values() {
    let c = inline(
        "param h = 6 in 1 .. 20;\n\
         const W = 2 * 3;\n\
         system S {\n\
             mode = shape;\n\
             lot = rect(W * 2, 4);\n\
             axiom A;\n\
             A -> extrude(h) B;\n\
             B -> comp(faces) { front: F };\n\
             F : scope.x > 10 && index == 1 -> split(x) { 25%: G | ~1: H | length(vec3(1, 0, 0)) * 2: G };\n\
         }\n",
    );
    let p = &c.program;
    let mut values = p.default_params();
    values[0] = grm_sema::Value::Float(9.0);
    let lowered = lower(p, system(&c), &values).expect("lowers");
    let tree = derive(&lowered, 0, &ShapeOptions::default()).expect("derives");
    let sym = |name: &str| lowered.program.symbol(name).expect("symbol");
    // The mass is 9 high (the parameter's run value) on a 12 by 4 lot.
    let mass = tree
        .nodes()
        .iter()
        .find(|n| matches!(n.kind, NodeKind::Shape { symbol, .. } if symbol == sym("B")))
        .expect("the mass");
    assert_eq!(mass.scope.size.to_array(), [12.0, 4.0, 9.0]);
    // The front (12 wide) is split: 3, then 7, then 2.
    let widths: Vec<f32> = tree
        .nodes()
        .iter()
        .filter(|n| {
            matches!(n.kind, NodeKind::Shape { symbol, .. } if symbol == sym("G") || symbol == sym("H"))
        })
        .map(|n| n.scope.size.x)
        .collect();
    assert_eq!(widths, [3.0, 7.0, 2.0]);
}

#[test]
fn engine_errors_are_coded_at_the_rule() {
    let c =
        inline("system S {\n    mode = shape;\n    axiom A;\n    A -> translate(1, 0, 0) A;\n}\n");
    let p = &c.program;
    let sys = system(&c);
    let e = grow(
        p,
        sys,
        &p.default_params(),
        &ShapeOptions::default(),
        None,
        None,
    )
    .unwrap_err();
    assert_eq!(e.code(), Code::ShapeTooDeep);
    let d = e.to_diagnostic(p, sys.file, sys.loc.span);
    assert_eq!(d.code, Code::ShapeTooDeep);
    let rule = "A -> translate(1, 0, 0) A;";
    let text = "system S {\n    mode = shape;\n    axiom A;\n    A -> translate(1, 0, 0) A;\n}\n";
    let start = text.find(rule).unwrap() as u32;
    assert_eq!(
        d.labels[0].span,
        grm_diag::Span::new(start, start + rule.len() as u32)
    );

    let c = inline(
        "system S {\n    mode = shape;\n    axiom A;\n    A -> split(x) { ~1: A | ~1: A };\n}\n",
    );
    let opts = ShapeOptions {
        limits: grm_shape::Limits {
            max_nodes: 2000,
            ..Default::default()
        },
        ..ShapeOptions::default()
    };
    let p = &c.program;
    let e = grow(p, system(&c), &p.default_params(), &opts, None, None).unwrap_err();
    assert_eq!(e.code(), Code::TooManyShapes);
    assert!(matches!(e, ShapeGrowError::Shape { .. }));
}

#[test]
fn a_lot_the_runs_values_make_unusable_is_e0509() {
    let c = inline(
        "param w = 10 in 0 .. 20;\nsystem S {\n    mode = shape;\n    lot = rect(w, 5);\n    axiom A;\n}\n",
    );
    let p = &c.program;
    let e = lower(p, system(&c), &[grm_sema::Value::Float(0.0)]).unwrap_err();
    assert_eq!(ShapeGrowError::from(e).code(), Code::BadLot);
}

#[test]
fn derive_systems_are_not_lowered() {
    let c = inline("system S {\n    axiom F;\n}\n");
    let p = &c.program;
    let e = lower(p, system(&c), &p.default_params()).unwrap_err();
    assert_eq!(ShapeGrowError::from(e).code(), Code::NotShapeRunnable);
}

#[test]
fn the_tree_json_has_every_node_with_locators() {
    let c = checked("townhouse.grm");
    let p = &c.program;
    let sys = system(&c);
    let lowered = lower(p, sys, &p.default_params()).expect("lowers");
    let tree = derive(&lowered, lowered.seed, &ShapeOptions::default()).expect("derives");
    let path = example_path("townhouse.grm");
    let text = std::fs::read_to_string(&path).unwrap();
    let mut sources = grm_diag::SourceMap::new();
    let file = sources.add(path.display().to_string(), &text);
    let v: serde_json::Value = serde_json::from_str(&json::to_json(
        &lowered,
        &tree,
        lowered.seed,
        file,
        &sources,
    ))
    .unwrap();
    assert_eq!(v["mode"], "shape");
    let nodes = v["nodes"].as_array().unwrap();
    assert_eq!(nodes.len(), tree.len());
    assert_eq!(
        v["productions"].as_array().unwrap().len(),
        lowered.rules.len()
    );
    assert_eq!(nodes[0]["exact"], "{Lot}");
    let children: usize = nodes
        .iter()
        .map(|n| n["children"].as_array().unwrap().len())
        .sum();
    assert_eq!(children, tree.len() - 1);
}

/// The shapes of `symbol` in a grown tree, with their semantic locators.
fn shapes_of(g: &grm_grow::shape::ShapeGrown, symbol: &str) -> Vec<(grm_shape::NodeId, String)> {
    let program = &g.lowered.program;
    (0..g.tree.len() as u32)
        .map(grm_shape::NodeId)
        .filter(|&id| {
            matches!(g.tree.node(id).map(|n| n.kind), Some(NodeKind::Shape { symbol: s, .. })
                if program.symbol_name(s) == symbol)
        })
        .map(|id| (id, g.tree.semantic_locator(program, id).to_string()))
        .collect()
}

fn grown(file: &str) -> grm_grow::shape::ShapeGrown {
    let c = checked(file);
    let p = &c.program;
    let build = grm_geom::BuildOptions::default();
    let dir = example_path(file).parent().map(|d| d.to_path_buf());
    grow(
        p,
        system(&c),
        &p.default_params(),
        &ShapeOptions::default(),
        Some((&build, dir.as_deref())),
        None,
    )
    .expect("grows")
}

/// examples/office_tower.grm does what its header says: the L of
/// office_tower.geojson (756 m²) with six facades of 16 floors each.
#[test]
fn the_office_tower_stands_on_its_footprint_file() {
    let g = grown("office_tower.grm");
    let lot = grm_shape::NodeId(0);
    assert!(
        (g.tree.area(lot) - 756.0).abs() < 1e-6,
        "{}",
        g.tree.area(lot)
    );
    let facades = shapes_of(&g, "Facade");
    let names: Vec<&str> = facades.iter().map(|f| f.1.as_str()).collect();
    assert_eq!(
        names,
        (1..=6)
            .map(|k| format!("(facade = {k}/6) Facade"))
            .collect::<Vec<_>>()
    );
    let floors = shapes_of(&g, "Floor");
    assert_eq!(floors.len(), 6 * 16);
    assert!(floors.iter().any(|f| f.1.contains("floor = 16/16")));
    // The tower is 6 + 16 * 3.8 + 1.2 = 68 m tall.
    assert_eq!(
        g.tree.node(grm_shape::NodeId(1)).unwrap().scope.size.z,
        68.0
    );
    assert!(g.model.expect("a model").stats.triangles > 2000);
}

/// examples/facade_variety.grm: the corner bays of every floor are blank,
/// the others hold a window whose type is drawn by weight (5 : 3 : 2).
#[test]
fn the_facade_varies_its_windows_by_weight_and_blanks_its_corners() {
    let g = grown("facade_variety.grm");
    let program = &g.lowered.program;
    let bays = shapes_of(&g, "Bay");
    assert_eq!(bays.len(), 2 * 5 * 11, "two facades of 5 floors by 11 bays");
    let mut types = [0usize; 3];
    for (id, _) in &bays {
        let n = g.tree.node(*id).unwrap();
        let corner = n.index == 1 || n.index == n.count;
        let made: Vec<String> = g
            .tree
            .children(*id)
            .map(|c| g.tree.label(program, c))
            .collect();
        if corner {
            assert_eq!(made, ["Wall"], "a corner bay is wall");
        } else {
            assert_eq!(made, ["split.x"], "a bay is split around its window");
        }
    }
    for (id, _) in shapes_of(&g, "Window") {
        if let Some(NodeKind::Shape {
            alternative: Some(a),
            ..
        }) = g.tree.node(id).map(|n| n.kind)
        {
            types[a as usize] += 1;
        }
    }
    assert_eq!(types.iter().sum::<usize>(), 2 * 5 * 9);
    // 90 draws at 5 : 3 : 2: each type well represented, plain the most.
    assert!(types.iter().all(|&t| t >= 8), "{types:?}");
    assert!(types[0] > types[2], "{types:?}");
}

#[test]
fn a_system_grows_on_a_lot_the_caller_gives() {
    use grm_grow::shape::{GivenLot, LowerError, grow_on_lot};
    let c = checked("city_building.grm");
    let p = &c.program;
    let build = grm_geom::BuildOptions::default();
    // A parcel far from the origin, not a rectangle: the building stands
    // on it (the model is y-up: world (x, y, z) is (x, z, -y)).
    let parcel = vec![vec![
        [500.0, 200.0],
        [530.0, 205.0],
        [525.0, 230.0],
        [498.0, 222.0],
    ]];
    let world = |rings| GivenLot {
        rings,
        x_axis: [1.0, 0.0],
    };
    let options = ShapeOptions {
        seed: Some(9),
        ..ShapeOptions::default()
    };
    let g = grow_on_lot(
        p,
        system(&c),
        &p.default_params(),
        world(&parcel),
        &options,
        Some((&build, None)),
    )
    .expect("grows");
    assert_eq!(g.seed, 9);
    let m = g.model.expect("a model");
    let b = m.stats.bounds;
    assert!(
        (b.min.x - 498.0).abs() < 1e-3 && (b.max.x - 530.0).abs() < 1e-3,
        "{b:?}"
    );
    assert!(
        (b.min.z + 230.0).abs() < 1e-3 && (b.max.z + 200.0).abs() < 1e-3,
        "{b:?}"
    );
    assert!((b.max.y - 12.0).abs() < 1e-3, "{b:?}");
    // The same lot and seed give the same model; the system's own lot
    // gives another.
    let again = grow_on_lot(
        p,
        system(&c),
        &p.default_params(),
        world(&parcel),
        &options,
        Some((&build, None)),
    )
    .expect("grows");
    assert_eq!(again.model.as_ref(), Some(&m));
    // A lot without area is E0509, naming no place.
    let flat = vec![vec![[0.0, 0.0], [10.0, 0.0], [20.0, 0.0]]];
    let e = grow_on_lot(
        p,
        system(&c),
        &p.default_params(),
        world(&flat),
        &options,
        None,
    )
    .expect_err("no area");
    assert!(
        matches!(
            &e,
            ShapeGrowError::Lower(LowerError::Lot { span: None, .. })
        ),
        "{e:?}"
    );
    assert_eq!(e.code(), Code::BadLot);
}

#[test]
fn a_given_lot_turns_its_scope_to_its_x_axis() {
    use grm_grow::shape::{GivenLot, grow_on_lot};
    let c = checked("city_building.grm");
    let p = &c.program;
    // A 20 m by 12 m rectangle turned 30 degrees, at (100, 50).
    let (cos, sin) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
    let at = |x: f64, y: f64| [100.0 + cos * x - sin * y, 50.0 + sin * x + cos * y];
    let rings = vec![vec![
        at(0.0, 0.0),
        at(20.0, 0.0),
        at(20.0, 12.0),
        at(0.0, 12.0),
    ]];
    let grow = |x_axis| {
        grow_on_lot(
            p,
            system(&c),
            &p.default_params(),
            GivenLot {
                rings: &rings,
                x_axis,
            },
            &ShapeOptions::default(),
            None,
        )
        .expect("grows")
    };
    // Along its front edge the lot's scope is the rectangle itself, at
    // its corner; along the world's axes it is the larger bounding box.
    let along = grow([cos, sin]);
    let root = along.tree.nodes()[0].scope;
    assert!(
        (root.size.x - 20.0).abs() < 1e-3 && (root.size.y - 12.0).abs() < 1e-3,
        "{root:?}"
    );
    assert!(
        (root.origin.x - 100.0).abs() < 1e-3 && (root.origin.y - 50.0).abs() < 1e-3,
        "{root:?}"
    );
    let x = root.rotation() * glam::Vec3::X;
    assert!((x.x - cos as f32).abs() < 1e-5 && (x.y - sin as f32).abs() < 1e-5);
    let world = grow([1.0, 0.0]).tree.nodes()[0].scope;
    assert!(world.size.x > 20.0 && world.size.y > 12.0, "{world:?}");
    // Ground floor bays: about 20 / 4 on each long facade along the front
    // edge; the world-aligned scope's facades are the same walls.
    let count = |g: &grm_grow::shape::ShapeGrown| {
        g.tree
            .nodes()
            .iter()
            .filter(|n| matches!(n.kind, NodeKind::Shape { symbol, .. } if g.lowered.program.symbol_name(symbol) == "Shop"))
            .count()
    };
    assert_eq!(count(&along), count(&grow([1.0, 0.0])));
}

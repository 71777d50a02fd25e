//! Expressions, conditional and weighted alternatives, random draws keyed
//! by identity and context queries (docs/shapes.md, "Expressions",
//! "Conditions", "Context queries"). Every expected value is worked out
//! by hand in the comments.

use glam::Vec3;
use grm_compile::rng::{child_key, name_hash, root_key, salt, uniform};
use grm_shape::{
    Alternative, Axis, Expr, ExprId, Lot, NodeId, NodeKind, Op, Options, Param, Part, PartSize,
    Program, ProgramBuilder, ProgramError, Query, Scope, ShapeError, ShapeTree, Split, SymbolId,
    Unary, derive,
};

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

fn n(v: f32) -> Expr {
    Expr::Num(v)
}

fn part(size: Param, target: Option<SymbolId>) -> Part {
    Part {
        size: PartSize::Absolute(size),
        target,
    }
}

/// The value of `e` read by `translate(x = e)` in the axiom's rule (the
/// successor `T`'s origin x), on a 6 x 4 face; `prep` may declare tags.
fn value_with(e: impl FnOnce(&mut ProgramBuilder) -> Expr) -> Result<f32, ShapeError> {
    let mut b = ProgramBuilder::new("value");
    let a = b.symbol("A");
    let t = b.symbol("T");
    let e = e(&mut b);
    let id = b.expr(&e);
    b.rule(
        a,
        vec![
            Op::Translate([Param::Expr(id), 0.0.into(), 0.0.into()]),
            Op::Emit(t),
        ],
    );
    let p = b.build(a)?;
    let tree = derive(&p, &face(6.0, 4.0), &Options::default())?;
    Ok(tree.node(of_symbol(&tree, t)[0]).unwrap().scope.origin.x)
}

fn value(e: Expr) -> f32 {
    value_with(|_| e).unwrap()
}

/// A boolean as 1 or 0.
fn truth(e: Expr) -> f32 {
    value(e.then(n(1.0), n(0.0)))
}

#[test]
fn arithmetic_and_functions_by_hand() {
    assert_eq!(value(n(2.0) + n(3.0) * n(4.0)), 14.0);
    assert_eq!(value(n(2.0) - n(5.0)), -3.0);
    assert_eq!(value(n(7.0) / n(2.0)), 3.5);
    // Floored remainder: -7 - 3 * floor(-7/3) = -7 + 9 = 2.
    assert_eq!(value(n(-7.0) % n(3.0)), 2.0);
    assert_eq!(value(n(2.0).pow(n(10.0))), 1024.0);
    assert_eq!(value(n(2.0).min(n(-1.0))), -1.0);
    assert_eq!(value(n(2.0).max(n(-1.0))), 2.0);
    assert_eq!(value(-n(2.5)), -2.5);
    assert_eq!(value(n(-2.5).apply(Unary::Abs)), 2.5);
    assert_eq!(value(n(-2.5).apply(Unary::Floor)), -3.0);
    assert_eq!(value(n(-2.5).apply(Unary::Ceil)), -2.0);
    // Half away from zero.
    assert_eq!(value(n(-2.5).apply(Unary::Round)), -3.0);
    assert_eq!(value(n(2.5).apply(Unary::Round)), 3.0);
    assert_eq!(value(n(9.0).apply(Unary::Sqrt)), 3.0);
    assert_eq!(value(n(0.0).apply(Unary::Sin)), 0.0);
    assert_eq!(value(n(0.0).apply(Unary::Cos)), 1.0);
    assert_eq!(value(n(5.0).clamp(n(0.0), n(2.0))), 2.0);
    assert_eq!(value(n(-5.0).clamp(n(0.0), n(2.0))), 0.0);
    // The scope: the face is 6 x 4 x 0 at the origin.
    assert_eq!(value(Expr::Size(Axis::X)), 6.0);
    assert_eq!(value(Expr::Size(Axis::Y)), 4.0);
    assert_eq!(value(Expr::Size(Axis::Z)), 0.0);
    assert_eq!(value(Expr::Position(Axis::X)), 0.0);
    // The axiom: index, count and depth 0.
    assert_eq!(value(Expr::Index + Expr::Count + Expr::Depth), 0.0);
}

#[test]
fn comparisons_logic_and_if_by_hand() {
    assert_eq!(truth(n(1.0).lt(n(2.0))), 1.0);
    assert_eq!(truth(n(2.0).lt(n(2.0))), 0.0);
    assert_eq!(truth(n(2.0).le(n(2.0))), 1.0);
    assert_eq!(truth(n(3.0).gt(n(2.0))), 1.0);
    assert_eq!(truth(n(2.0).ge(n(3.0))), 0.0);
    assert_eq!(truth(n(2.0).eq(n(2.0))), 1.0);
    assert_eq!(truth(n(2.0).ne(n(2.0))), 0.0);
    assert_eq!(truth(Expr::Bool(true).eq(Expr::Bool(true))), 1.0);
    assert_eq!(truth(Expr::Bool(true).and(Expr::Bool(false))), 0.0);
    assert_eq!(truth(Expr::Bool(true).or(Expr::Bool(false))), 1.0);
    assert_eq!(truth(!Expr::Bool(false)), 1.0);
    // NaN compares false every way but !=.
    let nan = || n(0.0) / n(0.0);
    assert_eq!(truth(nan().lt(n(1.0))), 0.0);
    assert_eq!(truth(nan().ge(n(1.0))), 0.0);
    assert_eq!(truth(nan().eq(nan())), 0.0);
    assert_eq!(truth(nan().ne(nan())), 1.0);
    // if on the scope: the face is 6 wide.
    assert_eq!(
        value(Expr::Size(Axis::X).gt(n(3.0)).then(n(10.0), n(20.0))),
        10.0
    );
    // A boolean `if`.
    assert_eq!(
        truth(Expr::Bool(false).then(Expr::Bool(false), Expr::Bool(true))),
        1.0
    );
}

/// The axiom `A`'s key in program "value" with seed 0.
fn axiom_key() -> u32 {
    child_key(root_key(0, name_hash("value")), salt(name_hash("A"), 0, 0))
}

/// The draw index of local draw `local` at `site` of alternative `alt`
/// (docs/shapes.md, "Identity").
fn draw(alt: u32, site: u32, local: u32) -> u32 {
    alt << 23 | site << 11 | local
}

#[test]
fn random_functions_draw_as_documented() {
    let key = axiom_key();
    // translate is op 0 of alternative 0: site 2; the first call is local 1.
    let u1 = uniform(0, 0, key, draw(0, 2, 1));
    let u2 = uniform(0, 0, key, draw(0, 2, 2));
    assert_eq!(
        value(Expr::uniform(n(10.0), n(20.0))),
        10.0 + 10.0 * u1,
        "uniform(a, b) = a + (b - a) * u"
    );
    // Two calls in one expression: locals 1 and 2.
    assert_eq!(
        value(Expr::uniform(n(0.0), n(1.0)) + Expr::uniform(n(0.0), n(100.0))),
        u1 + 100.0 * u2
    );
    // randint(1, 6) = 1 + min(floor(u * 6), 5).
    assert_eq!(
        value(Expr::randint(n(1.0), n(6.0))),
        1.0 + (u1 * 6.0).floor().min(5.0)
    );
    // chance(p) = u < p.
    assert_eq!(truth(Expr::chance(n(1.0))), 1.0);
    assert_eq!(truth(Expr::chance(n(0.0))), 0.0);
    assert_eq!(
        truth(Expr::chance(n(0.5))),
        if u1 < 0.5 { 1.0 } else { 0.0 }
    );
    // normal(m, sd): Box-Muller on locals 1 and 2.
    let z = (-2.0 * (1.0 - u1).ln()).sqrt() * (std::f32::consts::TAU * u2).cos();
    assert_eq!(value(Expr::normal(n(5.0), n(2.0))), 5.0 + 2.0 * z);
    // choose(10: 1, 20: 3): 10 when u * 4 < 1.
    let pick = if u1 * 4.0 < 1.0 { 10.0 } else { 20.0 };
    assert_eq!(
        value(Expr::Choose(vec![(n(10.0), n(1.0)), (n(20.0), n(3.0))])),
        pick
    );
    // A zero weight is never chosen; no positive weight is NaN (an error
    // where a translation reads it).
    assert_eq!(
        value(Expr::Choose(vec![(n(10.0), n(0.0)), (n(20.0), n(2.0))])),
        20.0
    );
    assert!(matches!(
        value_with(|_| Expr::Choose(vec![(n(10.0), n(0.0)), (n(20.0), n(-1.0))])),
        Err(ShapeError::BadValue { .. })
    ));
}

/// `Facade -> repeat(y) { 3: Floor } floor`; `Floor -> repeat(x) { w: Tile }
/// column` when `tile_width` is `Some(w)` (else the closure gives Floor's
/// rule), and the closure's rules.
struct Building {
    program: Program,
    b: Vec<SymbolId>,
}

fn building(
    tile_width: Option<f32>,
    rules: impl FnOnce(&mut ProgramBuilder, SymbolId, SymbolId) -> Vec<SymbolId>,
) -> Building {
    let mut b = ProgramBuilder::new("building");
    let floor_tag = b.tag("floor");
    let column_tag = b.tag("column");
    let facade = b.symbol("Facade");
    let floor = b.symbol("Floor");
    let tile = b.symbol("Tile");
    b.rule(
        facade,
        vec![Op::Repeat(Split {
            axis: Axis::Y,
            parts: vec![Part::abs(3.0, Some(floor))],
            tag: Some(floor_tag),
        })],
    );
    let out = rules(&mut b, floor, tile);
    if let Some(tile_width) = tile_width {
        b.rule(
            floor,
            vec![Op::Repeat(Split {
                axis: Axis::X,
                parts: vec![Part::abs(tile_width, Some(tile))],
                tag: Some(column_tag),
            })],
        );
    }
    Building {
        program: b.build(facade).unwrap(),
        b: out,
    }
}

#[test]
fn a_condition_on_scope_width_picks_the_rule_per_tile() {
    // Floor -> split(x) { 2: Tile | 4: Tile | 1.5: Tile }; Tile -> case
    // scope.x > 3: Wide | else: Narrow.
    let p = building(None, |b, floor, tile| {
        let (wide, narrow) = (b.symbol("Wide"), b.symbol("Narrow"));
        b.rule(
            floor,
            vec![Op::Split(Split {
                axis: Axis::X,
                parts: vec![
                    Part::abs(2.0, Some(tile)),
                    Part::abs(4.0, Some(tile)),
                    Part::abs(1.5, Some(tile)),
                ],
                tag: None,
            })],
        );
        let is_wide = b.expr(&Expr::Size(Axis::X).gt(n(3.0)));
        let not_wide = b.expr(&!Expr::Size(Axis::X).gt(n(3.0)));
        b.rule_alternatives(
            tile,
            vec![
                Alternative::new(vec![Op::Emit(wide)]).when(is_wide),
                Alternative::new(vec![Op::Emit(narrow)]).when(not_wide),
            ],
        );
        vec![wide, narrow]
    });
    let tree = derive(&p.program, &face(7.5, 3.0), &Options::default()).unwrap();
    let wide = of_symbol(&tree, p.b[0]);
    let narrow = of_symbol(&tree, p.b[1]);
    assert_eq!(wide.len(), 1);
    assert_eq!(narrow.len(), 2);
    assert_eq!(tree.node(wide[0]).unwrap().scope.size.x, 4.0);
    let xs: Vec<f32> = narrow
        .iter()
        .map(|&i| tree.node(i).unwrap().scope.origin.x)
        .collect();
    assert_eq!(xs, vec![0.0, 6.0]);
}

#[test]
fn index_and_count_pick_ground_middle_and_top_floors() {
    let p = building(None, |b, floor, _| {
        let (ground, middle, top) = (b.symbol("Ground"), b.symbol("Middle"), b.symbol("Top"));
        let first = b.expr(&Expr::Index.eq(n(1.0)));
        let last = b.expr(&Expr::Index.eq(Expr::Count).and(Expr::Index.gt(n(1.0))));
        let between = b.expr(&Expr::Index.gt(n(1.0)).and(Expr::Index.lt(Expr::Count)));
        b.rule_alternatives(
            floor,
            vec![
                Alternative::new(vec![Op::Emit(ground)]).when(first),
                Alternative::new(vec![Op::Emit(top)]).when(last),
                Alternative::new(vec![Op::Emit(middle)]).when(between),
            ],
        );
        vec![ground, middle, top]
    });
    // 12 high: four floors of 3.
    let tree = derive(&p.program, &face(5.0, 12.0), &Options::default()).unwrap();
    let y = |s: SymbolId| -> Vec<f32> {
        of_symbol(&tree, s)
            .iter()
            .map(|&i| tree.node(i).unwrap().scope.origin.y)
            .collect()
    };
    assert_eq!(y(p.b[0]), vec![0.0]);
    assert_eq!(y(p.b[1]), vec![3.0, 6.0]);
    assert_eq!(y(p.b[2]), vec![9.0]);
    // One floor: it is the first, and no condition but the first holds.
    let tree = derive(&p.program, &face(5.0, 3.0), &Options::default()).unwrap();
    assert_eq!(of_symbol(&tree, p.b[0]).len(), 1);
    assert_eq!(of_symbol(&tree, p.b[2]).len(), 0);
}

#[test]
fn tags_on_the_path_and_their_indices() {
    // Tile (under floor and column) reads tagged(floor), index(floor),
    // count(column): translate(x = index(floor) * 100 + count(column)),
    // then T. Facade 4 x 6: floors 1..2, 4 columns of 1.
    let mut b = ProgramBuilder::new("tags");
    let floor_tag = b.tag("floor");
    let column_tag = b.tag("column");
    let other = b.tag("other");
    let facade = b.symbol("Facade");
    let floor = b.symbol("Floor");
    let tile = b.symbol("Tile");
    let t = b.symbol("T");
    b.rule(
        facade,
        vec![Op::Repeat(Split {
            axis: Axis::Y,
            parts: vec![Part::abs(3.0, Some(floor))],
            tag: Some(floor_tag),
        })],
    );
    b.rule(
        floor,
        vec![Op::Repeat(Split {
            axis: Axis::X,
            parts: vec![Part::abs(1.0, Some(tile))],
            tag: Some(column_tag),
        })],
    );
    let x = b.expr(
        &(Expr::TagIndex(floor_tag) * n(100.0)
            + Expr::TagCount(column_tag)
            + Expr::TagIndex(other)),
    );
    let cond = b.expr(&Expr::Tagged(floor_tag).and(!Expr::Tagged(other)));
    b.rule_alternatives(
        tile,
        vec![
            Alternative::new(vec![
                Op::Translate([Param::Expr(x), 0.0.into(), 0.0.into()]),
                Op::Emit(t),
            ])
            .when(cond),
        ],
    );
    let p = b.build(facade).unwrap();
    let tree = derive(&p, &face(4.0, 6.0), &Options::default()).unwrap();
    let mut xs: Vec<f32> = of_symbol(&tree, t)
        .iter()
        .map(|&i| tree.node(i).unwrap().scope.origin.x)
        .collect();
    xs.sort_by(f32::total_cmp);
    // Column c (origin c - 1) on floor f: c - 1 + 100 f + 4.
    let mut want = vec![];
    for f in 1..=2 {
        for c in 1..=4 {
            want.push((c - 1) as f32 + 100.0 * f as f32 + 4.0);
        }
    }
    want.sort_by(f32::total_cmp);
    assert_eq!(xs, want);
    // Depth: T is at 5 (Facade 0, repeat 1, Floor 2, repeat 3, Tile 4).
    let d = tree.node(of_symbol(&tree, t)[0]).unwrap().depth;
    assert_eq!(d, 5);
}

#[test]
fn no_alternative_holding_leaves_a_terminal_and_weights_may_drop_one() {
    // Tile -> case index == 2: W (weight 1) | else: V with weight
    // `if index == 3 then 0 else 1`: tile 2 is W, tile 3 is a terminal
    // Tile (V's weight is 0, W's condition fails), others V.
    let p = building(Some(1.0), |b, _, tile| {
        let (w, v) = (b.symbol("W"), b.symbol("V"));
        let two = b.expr(&Expr::Index.eq(n(2.0)));
        let not_two = b.expr(&Expr::Index.ne(n(2.0)));
        let weight = b.expr(&Expr::Index.eq(n(3.0)).then(n(0.0), n(1.0)));
        b.rule_alternatives(
            tile,
            vec![
                Alternative::new(vec![Op::Emit(w)]).when(two),
                Alternative::weighted(weight, vec![Op::Emit(v)]).when(not_two),
            ],
        );
        vec![w, v]
    });
    let tree = derive(&p.program, &face(5.0, 3.0), &Options::default()).unwrap();
    let tile = p.program.symbol("Tile").unwrap();
    let alts: Vec<Option<u32>> = of_symbol(&tree, tile)
        .iter()
        .map(|&i| match tree.node(i).unwrap().kind {
            NodeKind::Shape { alternative, .. } => alternative,
            _ => unreachable!(),
        })
        .collect();
    assert_eq!(alts, vec![Some(1), Some(0), None, Some(1), Some(1)]);
    assert_eq!(of_symbol(&tree, p.b[0]).len(), 1);
    assert_eq!(of_symbol(&tree, p.b[1]).len(), 3);
}

/// Tiles choose among three alternatives with expression weights
/// `1`, `w1 * (1 + 0 * index)` and `1`.
fn raced(w1: f32) -> (Program, SymbolId) {
    let p = building(Some(1.0), |b, _, tile| {
        let outs: Vec<SymbolId> = (0..3).map(|k| b.symbol(&format!("O{k}"))).collect();
        let w = b.expr(&(n(w1) * (n(1.0) + n(0.0) * Expr::Index)));
        b.rule_alternatives(
            tile,
            vec![
                Alternative::new(vec![Op::Emit(outs[0])]),
                Alternative::weighted(w, vec![Op::Emit(outs[1])]),
                Alternative::weighted(1.0, vec![Op::Emit(outs[2])]),
            ],
        );
        outs
    });
    let tile = p.program.symbol("Tile").unwrap();
    (p.program, tile)
}

fn choices(p: &Program, tile: SymbolId) -> Vec<u32> {
    // 10 floors of 100 tiles.
    let tree = derive(p, &face(100.0, 30.0), &Options::default()).unwrap();
    of_symbol(&tree, tile)
        .iter()
        .map(|&i| match tree.node(i).unwrap().kind {
            NodeKind::Shape {
                alternative: Some(a),
                ..
            } => a,
            _ => unreachable!(),
        })
        .collect()
}

#[test]
fn expression_weights_keep_the_rendezvous_property() {
    let (p1, tile) = raced(1.0);
    let (p3, _) = raced(3.0);
    let a = choices(&p1, tile);
    let b = choices(&p3, tile);
    assert_eq!(a.len(), 1000);
    // Raising alternative 1's weight only moves tiles to it.
    let mut moved = 0;
    for (x, y) in a.iter().zip(&b) {
        if x != y {
            assert_eq!(
                *y, 1,
                "a tile moved from {x} to {y}, not to the edited alternative"
            );
            moved += 1;
        }
    }
    // About 1/3 -> 3/5 of the tiles: 267 expected.
    assert!((150..400).contains(&moved), "{moved}");
    // The same weights as constants choose the same.
    let constant = building(Some(1.0), |b, _, tile| {
        let outs: Vec<SymbolId> = (0..3).map(|k| b.symbol(&format!("O{k}"))).collect();
        b.rule_alternatives(
            tile,
            (0..3)
                .map(|k| {
                    Alternative::weighted(if k == 1 { 3.0 } else { 1.0 }, vec![Op::Emit(outs[k])])
                })
                .collect(),
        );
        outs
    });
    assert_eq!(choices(&constant.program, tile), b);
}

/// `Facade -> [extra] repeat(y) { 3: Floor }`; `Floor -> repeat(x) { 1: Tile }`;
/// `Tile -> size(x = uniform(0.2, 0.8)) Win`.
fn random_widths(extra: bool) -> (Program, SymbolId) {
    let mut b = ProgramBuilder::new("random");
    let facade = b.symbol("Facade");
    let floor = b.symbol("Floor");
    let tile = b.symbol("Tile");
    let win = b.symbol("Win");
    let marker = b.symbol("Marker");
    let mut ops = vec![];
    if extra {
        // An unrelated shape, and an unrelated drawing rule.
        ops.push(Op::Emit(marker));
        let u = b.expr(&Expr::uniform(n(0.0), n(1.0)));
        b.rule(marker, vec![Op::Extrude(Param::Expr(u))]);
    }
    ops.push(Op::Repeat(Split {
        axis: Axis::Y,
        parts: vec![Part::abs(3.0, Some(floor))],
        tag: None,
    }));
    b.rule(facade, ops);
    b.rule(
        floor,
        vec![Op::Repeat(Split {
            axis: Axis::X,
            parts: vec![Part::abs(1.0, Some(tile))],
            tag: None,
        })],
    );
    let w = b.expr(&Expr::uniform(n(0.2), n(0.8)));
    b.rule(
        tile,
        vec![Op::Size([Some(Param::Expr(w)), None, None]), Op::Emit(win)],
    );
    (b.build(facade).unwrap(), win)
}

fn widths(p: &Program, win: SymbolId, seed: u32) -> Vec<f32> {
    let tree = derive(
        p,
        &face(10.0, 9.0),
        &Options {
            seed,
            ..Options::default()
        },
    )
    .unwrap();
    of_symbol(&tree, win)
        .iter()
        .map(|&i| tree.node(i).unwrap().scope.size.x)
        .collect()
}

#[test]
fn random_values_are_reproducible_and_keyed_by_identity() {
    let (plain, win) = random_widths(false);
    let (extra, win2) = random_widths(true);
    let a = widths(&plain, win, 5);
    assert_eq!(a.len(), 30);
    assert!(a.iter().all(|w| (0.2..0.8).contains(w)));
    // Not all the same.
    assert!(a.iter().any(|w| *w != a[0]));
    // Reproducible.
    assert_eq!(widths(&plain, win, 5), a);
    // An unrelated shape added elsewhere (with its own draws) moves none.
    assert_eq!(widths(&extra, win2, 5), a);
    // Another seed draws others.
    assert_ne!(widths(&plain, win, 6), a);
    // Each is the documented draw of its tile: the Tile's key, alternative
    // 0, op 0 (site 2), local 1.
    let tree = derive(
        &plain,
        &face(10.0, 9.0),
        &Options {
            seed: 5,
            ..Options::default()
        },
    )
    .unwrap();
    let tile = plain.symbol("Tile").unwrap();
    for &t in &of_symbol(&tree, tile) {
        let u = tree.uniform(t, draw(0, 2, 1)).unwrap();
        let child = tree.children(t).next().unwrap();
        assert_eq!(
            tree.node(child).unwrap().scope.size.x,
            0.2 + (0.8f32 - 0.2) * u
        );
    }
}

#[test]
fn conditions_and_weights_draw_at_their_own_sites() {
    // A -> case chance(0.5): X | else (weight uniform(1, 2)): Y. The
    // condition's draw is site 0 of alternative 0; the race then uses the
    // weight, site 1 of alternative 1.
    for seed in 0..40 {
        let mut b = ProgramBuilder::new("value");
        let a = b.symbol("A");
        let (x, y) = (b.symbol("X"), b.symbol("Y"));
        let c = b.expr(&Expr::chance(n(0.5)));
        let not_c = b.expr(&!Expr::chance(n(0.5)));
        let w = b.expr(&Expr::uniform(n(1.0), n(2.0)));
        b.rule_alternatives(
            a,
            vec![
                Alternative::new(vec![Op::Emit(x)]).when(c),
                Alternative::weighted(w, vec![Op::Emit(y)]).when(not_c),
            ],
        );
        let p = b.build(a).unwrap();
        let opts = Options {
            seed,
            ..Options::default()
        };
        let tree = derive(&p, &face(1.0, 1.0), &opts).unwrap();
        let key = tree.nodes()[0].key;
        let c0 = uniform(seed, 0, key, draw(0, 0, 1)) < 0.5;
        let c1 = uniform(seed, 0, key, draw(1, 0, 1)) >= 0.5;
        let got = (of_symbol(&tree, x).len(), of_symbol(&tree, y).len());
        match (c0, c1) {
            (true, false) => assert_eq!(got, (1, 0)),
            (false, true) => assert_eq!(got, (0, 1)),
            (false, false) => assert_eq!(got, (0, 0)),
            // Both hold: the race decides; one of them.
            (true, true) => assert_eq!(got.0 + got.1, 1),
        }
    }
}

/// A one-floor facade 10 x 3 with a balcony box in front of x 4..6, y
/// 0..1 (depth 1) and tiles of 2: `Tile -> case !<query>(Balcony):
/// insert(window)`. Returns the tiles' x origins that got a window.
fn windows_beside_balcony(q: Query, negate: bool) -> Vec<f32> {
    let mut b = ProgramBuilder::new("balcony");
    let facade = b.symbol("Facade");
    let balcony = b.symbol("Balcony");
    let tile = b.symbol("Tile");
    let window = b.asset("window");
    b.rule(
        facade,
        vec![
            Op::Push,
            Op::Translate([4.0.into(), 0.0.into(), 0.0.into()]),
            Op::Size([Some(2.0.into()), Some(1.0.into()), Some(1.0.into())]),
            Op::Emit(balcony),
            Op::Pop,
            Op::Repeat(Split {
                axis: Axis::X,
                parts: vec![Part::abs(2.0, Some(tile))],
                tag: None,
            }),
        ],
    );
    let mut e = Expr::Query(q, balcony);
    if negate {
        e = !e;
    }
    let cond = b.expr(&e);
    b.rule_alternatives(
        tile,
        vec![Alternative::new(vec![Op::Insert(window)]).when(cond)],
    );
    let p = b.build(facade).unwrap();
    assert_eq!(p.queried_symbols(), &[balcony]);
    let tree = derive(&p, &face(10.0, 3.0), &Options::default()).unwrap();
    tree.inserts().map(|(_, _, s)| s.origin.x).collect()
}

#[test]
fn a_window_that_overlaps_a_balcony_is_dropped() {
    // Tiles at 0, 2, 4, 6, 8; the balcony covers x 4..6 in front of the
    // wall: tile 4 overlaps it (the flat tile lies on its back face over
    // 2 x 1), tiles 2 and 6 touch its sides.
    assert_eq!(
        windows_beside_balcony(Query::Overlaps, true),
        vec![0.0, 2.0, 6.0, 8.0]
    );
    assert_eq!(windows_beside_balcony(Query::Overlaps, false), vec![4.0]);
    assert_eq!(
        windows_beside_balcony(Query::Touches, false),
        vec![2.0, 6.0]
    );
    // No tile (3 high) lies inside the balcony (1 high).
    assert_eq!(
        windows_beside_balcony(Query::Inside, false),
        Vec::<f32>::new()
    );
}

#[test]
fn queries_skip_the_asking_shape_its_ancestors_and_descendants() {
    // Facade -> Balcony (x 0..2) and Balcony (x 5..7); each Balcony ->
    // Rail, a copy of its scope; Rail -> case overlaps(Balcony): insert.
    // Its own Balcony is an ancestor: only a Rail in another balcony
    // counts, so none is inserted; then a third balcony over x 1..3
    // overlaps the first: the rails of both get one.
    let run = |third: bool| {
        let mut b = ProgramBuilder::new("rails");
        let facade = b.symbol("Facade");
        let balcony = b.symbol("Balcony");
        let rail = b.symbol("Rail");
        let asset = b.asset("rail");
        let mut ops = vec![];
        let mut xs = vec![0.0, 5.0];
        if third {
            xs.push(1.0);
        }
        for x in xs {
            ops.extend([
                Op::Push,
                Op::Translate([x.into(), 0.0.into(), 0.0.into()]),
                Op::Size([Some(2.0.into()), Some(1.0.into()), Some(1.0.into())]),
                Op::Emit(balcony),
                Op::Pop,
            ]);
        }
        b.rule(facade, ops);
        b.rule(balcony, vec![Op::Emit(rail)]);
        let q = b.expr(&Expr::Query(Query::Overlaps, balcony));
        b.rule_alternatives(
            rail,
            vec![Alternative::new(vec![Op::Insert(asset)]).when(q)],
        );
        let p = b.build(facade).unwrap();
        let tree = derive(&p, &face(10.0, 3.0), &Options::default()).unwrap();
        let mut xs: Vec<f32> = tree.inserts().map(|(_, _, s)| s.origin.x).collect();
        xs.sort_by(f32::total_cmp);
        xs
    };
    assert_eq!(run(false), Vec::<f32>::new());
    assert_eq!(run(true), vec![0.0, 1.0]);
}

#[test]
fn queries_read_the_first_pass_so_order_does_not_matter() {
    // Two shapes ask about each other: A (x 0..2) exists only where
    // !overlaps(B), B (x 1..3) only where !overlaps(A). In the first pass
    // both exist (queries false); in the second each sees the other, so
    // neither inserts. Swapping their order in the rule changes nothing.
    let run = |a_first: bool| {
        let mut b = ProgramBuilder::new("mutual");
        let facade = b.symbol("Facade");
        let sa = b.symbol("A");
        let sb = b.symbol("B");
        let asset = b.asset("x");
        let place = |s: SymbolId, x: f32| {
            vec![
                Op::Push,
                Op::Translate([x.into(), 0.0.into(), 0.0.into()]),
                Op::Size([Some(2.0.into()), None, Some(1.0.into())]),
                Op::Emit(s),
                Op::Pop,
            ]
        };
        let mut ops = place(sa, 0.0);
        if a_first {
            ops.extend(place(sb, 1.0));
        } else {
            ops.splice(0..0, place(sb, 1.0));
        }
        b.rule(facade, ops);
        let qa = b.expr(&!Expr::Query(Query::Overlaps, sb));
        let qb = b.expr(&!Expr::Query(Query::Overlaps, sa));
        b.rule_alternatives(sa, vec![Alternative::new(vec![Op::Insert(asset)]).when(qa)]);
        b.rule_alternatives(sb, vec![Alternative::new(vec![Op::Insert(asset)]).when(qb)]);
        let p = b.build(facade).unwrap();
        derive(&p, &face(10.0, 3.0), &Options::default())
            .unwrap()
            .inserts()
            .count()
    };
    assert_eq!(run(true), 0);
    assert_eq!(run(false), 0);
}

/// A 40 x 60 facade: floors of 3 tagged floor, tiles of 2 tagged column;
/// every third floor's odd columns hold a balcony (a box in front of the
/// tile, 3 wide from 0.5 left of it, 1.2 high); every other tile that
/// does not overlap a balcony gets a window of random width
/// `uniform(0.8, 1.4)`.
fn balcony_facade() -> Program {
    let mut b = ProgramBuilder::new("balconies");
    let floor_tag = b.tag("floor");
    let column_tag = b.tag("column");
    let facade = b.symbol("Facade");
    let floor = b.symbol("Floor");
    let tile = b.symbol("Tile");
    let balcony = b.symbol("Balcony");
    let win = b.symbol("Win");
    let window = b.asset("window");
    let slab = b.asset("slab");
    b.rule(
        facade,
        vec![Op::Repeat(Split {
            axis: Axis::Y,
            parts: vec![Part::abs(3.0, Some(floor))],
            tag: Some(floor_tag),
        })],
    );
    b.rule(
        floor,
        vec![Op::Repeat(Split {
            axis: Axis::X,
            parts: vec![Part::abs(2.0, Some(tile))],
            tag: Some(column_tag),
        })],
    );
    let has = (Expr::TagIndex(floor_tag) % n(3.0))
        .eq(n(0.0))
        .and((Expr::TagIndex(column_tag) % n(2.0)).eq(n(1.0)));
    let has_balcony = b.expr(&has);
    let free = b.expr(&(!Expr::Query(Query::Overlaps, balcony)).and(!has));
    let width = b.expr(&Expr::uniform(n(0.8), n(1.4)));
    b.rule_alternatives(
        tile,
        vec![
            Alternative::new(vec![
                Op::Push,
                Op::Translate([(-0.5).into(), 0.0.into(), 0.0.into()]),
                Op::Size([Some(3.0.into()), Some(1.2.into()), Some(1.0.into())]),
                Op::Emit(balcony),
                Op::Pop,
            ])
            .when(has_balcony),
            Alternative::new(vec![
                Op::Size([Some(Param::Expr(width)), None, None]),
                Op::Emit(win),
            ])
            .when(free),
        ],
    );
    b.rule(win, vec![Op::Insert(window)]);
    b.rule(balcony, vec![Op::Insert(slab)]);
    b.build(facade).unwrap()
}

#[test]
fn queries_give_the_same_bytes_for_any_thread_count() {
    let p = balcony_facade();
    let lot = face(40.0, 60.0);
    let one = derive(&p, &lot, &Options::default()).unwrap();
    // 20 floors x 20 tiles; floors 3, 6, ..., 18 (6 floors) have 10
    // balconies each (60). On those floors every even column overlaps its
    // neighbours' balconies by 0.5 (and a balcony tile's own balcony is
    // its descendant, not counted: its second alternative fails on
    // `has_balcony` only); the floors above and below only touch them: 14
    // floors of 20 windows.
    let win = p.symbol("Win").unwrap();
    let balcony = p.symbol("Balcony").unwrap();
    assert_eq!(of_symbol(&one, balcony).len(), 60);
    assert_eq!(of_symbol(&one, win).len(), 280);
    let dump = format!("{one:?}");
    for threads in [2, 3, 4, 8] {
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

#[test]
fn nan_infinity_and_division_by_zero_never_panic() {
    // A translation of 1/0 or 0/0 is the typed BadValue error.
    for e in [n(1.0) / n(0.0), n(0.0) / n(0.0), n(-1.0).apply(Unary::Sqrt)] {
        assert!(matches!(
            value_with(|_| e),
            Err(ShapeError::BadValue { .. })
        ));
    }
    // x % 0 is NaN; pow overflows to infinity: errors, not panics.
    assert!(value_with(|_| n(1.0) % n(0.0)).is_err());
    assert!(value_with(|_| n(10.0).pow(n(100.0))).is_err());
    // A NaN split size is the split's SizeError.
    let mut b = ProgramBuilder::new("nan");
    let a = b.symbol("A");
    let t = b.symbol("T");
    let nan = b.expr(&(n(0.0) / n(0.0)));
    b.rule(
        a,
        vec![Op::Split(Split {
            axis: Axis::X,
            parts: vec![part(Param::Expr(nan), Some(t))],
            tag: None,
        })],
    );
    let p = b.build(a).unwrap();
    assert!(matches!(
        derive(&p, &face(4.0, 4.0), &Options::default()),
        Err(ShapeError::Size { .. })
    ));
    // A NaN or infinite weight drops its alternative (`+inf` counts as
    // the largest weight); a NaN condition cannot be built (conditions
    // are booleans), and a comparison with NaN is false.
    let mut b = ProgramBuilder::new("nanweight");
    let a = b.symbol("A");
    let (x, y) = (b.symbol("X"), b.symbol("Y"));
    let nan = b.expr(&(n(0.0) / n(0.0)));
    let cond = b.expr(&(n(0.0) / n(0.0)).gt(n(0.0)));
    b.rule_alternatives(
        a,
        vec![
            Alternative::weighted(nan, vec![Op::Emit(x)]),
            Alternative::new(vec![Op::Emit(x)]).when(cond),
            Alternative::new(vec![Op::Emit(y)]),
        ],
    );
    let p = b.build(a).unwrap();
    let tree = derive(&p, &face(1.0, 1.0), &Options::default()).unwrap();
    assert_eq!(of_symbol(&tree, y).len(), 1);
    let mut b = ProgramBuilder::new("infweight");
    let a = b.symbol("A");
    let (x, y) = (b.symbol("X"), b.symbol("Y"));
    let inf = b.expr(&(n(1.0) / n(0.0)));
    b.rule_alternatives(
        a,
        vec![
            Alternative::new(vec![Op::Emit(y)]),
            Alternative::weighted(inf, vec![Op::Emit(x)]),
        ],
    );
    let p = b.build(a).unwrap();
    for seed in 0..20 {
        let opts = Options {
            seed,
            ..Options::default()
        };
        let tree = derive(&p, &face(1.0, 1.0), &opts).unwrap();
        assert_eq!(of_symbol(&tree, x).len(), 1, "seed {seed}");
    }
}

#[test]
fn bad_expressions_are_program_errors() {
    let mut b = ProgramBuilder::new("bad");
    let a = b.symbol("A");
    // Ill-typed: a number as an operand of &&, a boolean in arithmetic.
    assert!(matches!(
        b.try_expr(&n(1.0).and(Expr::Bool(true))),
        Err(ProgramError::BadExpr { .. })
    ));
    assert!(matches!(
        b.try_expr(&(Expr::Bool(true) + n(1.0))),
        Err(ProgramError::BadExpr { .. })
    ));
    assert!(matches!(
        b.try_expr(&Expr::Bool(true).then(n(1.0), Expr::Bool(false))),
        Err(ProgramError::BadExpr { .. })
    ));
    assert!(matches!(
        b.try_expr(&Expr::Choose(vec![])),
        Err(ProgramError::BadExpr { .. })
    ));
    // Unknown tag and symbol ids.
    assert!(matches!(
        b.try_expr(&Expr::Tagged(grm_shape::TagId(7))),
        Err(ProgramError::UnknownId { what: "tag", .. })
    ));
    assert!(matches!(
        b.try_expr(&Expr::Query(Query::Inside, SymbolId(9))),
        Err(ProgramError::UnknownId { what: "symbol", .. })
    ));
    // Nested too deep.
    let mut deep = n(1.0);
    for _ in 0..300 {
        deep = -deep;
    }
    assert!(matches!(
        b.try_expr(&deep),
        Err(ProgramError::BadExpr { .. })
    ));
    // A boolean where a number goes, a number as a condition, an unknown id.
    let boolean = b.expr(&Expr::Bool(true));
    let number = b.expr(&n(1.0));
    let check = |alt: Alternative| {
        let mut b = ProgramBuilder::new("bad");
        let a = b.symbol("A");
        let _ = b.expr(&Expr::Bool(true));
        let _ = b.expr(&n(1.0));
        b.rule_alternatives(a, vec![alt]);
        b.build(a)
    };
    assert!(matches!(
        check(Alternative::new(vec![Op::Extrude(Param::Expr(boolean))])),
        Err(ProgramError::ExprType { .. })
    ));
    assert!(matches!(
        check(Alternative::new(vec![]).when(number)),
        Err(ProgramError::ExprType { .. })
    ));
    assert!(matches!(
        check(Alternative::weighted(boolean, vec![])),
        Err(ProgramError::ExprType { .. })
    ));
    assert!(matches!(
        check(Alternative::new(vec![Op::Extrude(Param::Expr(ExprId(99)))])),
        Err(ProgramError::UnknownId {
            what: "expression",
            ..
        })
    ));
    // `expr` keeps the first error for `build`.
    let _ = b.expr(&(Expr::Bool(true) + n(1.0)));
    b.rule(a, vec![]);
    assert!(matches!(b.build(a), Err(ProgramError::BadExpr { .. })));
}

/// A random expression of type number (`boolean: false`) or boolean, at
/// most `depth` deep, over `tags` and `symbols`.
fn random_expr(
    rng: &mut grm_testkit::Rng,
    boolean: bool,
    depth: u32,
    tags: &[grm_shape::TagId],
    symbols: &[SymbolId],
) -> Expr {
    use grm_shape::Binary;
    let leaf = depth == 0 || rng.below(3u32) == 0;
    let k = rng.below(8u32);
    let op = *rng.pick(&[
        Binary::Add,
        Binary::Sub,
        Binary::Mul,
        Binary::Div,
        Binary::Rem,
        Binary::Pow,
    ]);
    let mut sub = |b| random_expr(rng, b, depth.saturating_sub(1), tags, symbols);
    match (boolean, leaf) {
        (true, true) => match k % 4 {
            0 => Expr::Bool(k < 4),
            1 => Expr::Tagged(tags[k as usize % tags.len()]),
            2 => Expr::Query(
                [Query::Overlaps, Query::Touches, Query::Inside][k as usize % 3],
                symbols[k as usize % symbols.len()],
            ),
            _ => Expr::chance(n(0.5)),
        },
        (true, false) => match k % 3 {
            0 => sub(false).lt(sub(false)),
            1 => sub(false).eq(sub(false)),
            _ => (!sub(true)).and(sub(true)).or(sub(true)),
        },
        (false, true) => match k {
            0 => n([0.0, -1.0, 1e30, f32::NAN, f32::INFINITY][op as usize % 5]),
            1 => Expr::Size([Axis::X, Axis::Y, Axis::Z][op as usize % 3]),
            2 => Expr::Position(Axis::X),
            3 => Expr::Index,
            4 => Expr::Count,
            5 => Expr::Depth,
            6 => Expr::TagIndex(tags[op as usize % tags.len()]),
            _ => Expr::TagCount(tags[0]) + n(1.5),
        },
        (false, false) => match k {
            0 => Expr::Binary(op, Box::new(sub(false)), Box::new(sub(false))),
            1 => sub(false).apply(Unary::Sqrt),
            2 => sub(true).then(sub(false), sub(false)),
            3 => Expr::uniform(sub(false), sub(false)),
            4 => Expr::randint(sub(false), sub(false)),
            5 => Expr::normal(sub(false), sub(false)),
            6 => Expr::Choose(vec![(sub(false), sub(false)), (sub(false), sub(false))]),
            _ => sub(false).clamp(sub(false), sub(false)),
        },
    }
}

#[test]
fn random_expressions_never_panic_and_agree_across_threads() {
    let mut rng = grm_testkit::Rng::seeded(2026);
    let mut trees = 0;
    for case in 0..80 {
        let mut b = ProgramBuilder::new("random-expr");
        let tags = [b.tag("floor"), b.tag("column")];
        let s: Vec<SymbolId> = (0..5).map(|i| b.symbol(&format!("S{i}"))).collect();
        // Most numbers are clamped into a range (NaN clamps to its low
        // end), so that most programs derive; one in six is raw.
        let num = |b: &mut ProgramBuilder, rng: &mut grm_testkit::Rng| {
            let mut e = random_expr(rng, false, 3, &tags, &s);
            if rng.below(6u32) != 0 {
                e = e.clamp(n(0.5), n(4.0));
            }
            Param::Expr(b.expr(&e))
        };
        // S0 -> repeat(y) { e: S1 } floor; S1 -> repeat(x) { e: S2 | ~1: S3 }
        // column; S2, S3 -> random alternatives with conditions, weights
        // and scope operations that read expressions.
        let p0 = num(&mut b, &mut rng);
        b.rule(
            s[0],
            vec![Op::Repeat(Split {
                axis: Axis::Y,
                parts: vec![part(p0, Some(s[1]))],
                tag: Some(tags[0]),
            })],
        );
        let p1 = num(&mut b, &mut rng);
        b.rule(
            s[1],
            vec![Op::Repeat(Split {
                axis: Axis::X,
                parts: vec![
                    part(p1, Some(s[2])),
                    Part {
                        size: PartSize::Floating(1.0.into()),
                        target: Some(s[3]),
                    },
                ],
                tag: Some(tags[1]),
            })],
        );
        for &sym in &s[2..4] {
            let mut alts = vec![];
            for _ in 0..1 + rng.below(3u32) {
                let c = random_expr(&mut rng, true, 2, &tags, &s);
                let c = b.expr(&c);
                let w = num(&mut b, &mut rng);
                let (t, x, sz) = (
                    num(&mut b, &mut rng),
                    num(&mut b, &mut rng),
                    num(&mut b, &mut rng),
                );
                let target = *rng.pick(&s[3..]);
                alts.push(
                    Alternative::weighted(
                        w,
                        vec![
                            Op::Translate([t, 0.0.into(), 0.0.into()]),
                            Op::Size([Some(x), None, Some(sz)]),
                            Op::Emit(target),
                        ],
                    )
                    .when(c),
                );
            }
            b.rule_alternatives(sym, alts);
        }
        let program = b.build(s[0]).unwrap();
        let limits = grm_shape::Limits {
            max_nodes: 3_000,
            max_depth: 14,
        };
        let lot = face(12.0, 9.0);
        let run = |threads| {
            derive(
                &program,
                &lot,
                &Options {
                    limits,
                    threads,
                    seed: case,
                },
            )
        };
        let one = run(1);
        let three = run(3);
        assert!(
            one == three || format!("{one:?}") == format!("{three:?}"),
            "case {case}"
        );
        trees += usize::from(one.is_ok());
    }
    assert!(trees > 20, "only {trees} programs derived without error");
}

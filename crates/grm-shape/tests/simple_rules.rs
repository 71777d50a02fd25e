//! A rule of inserts and successors only (one plain alternative) is run by
//! the derivation loop's short road, without the rule run's set-up: it
//! must write exactly what the general road writes. The same rule with a
//! second alternative whose condition is false (never chosen, but it takes
//! the general road) gives the same tree, byte for byte: on boxes, rectangles, prisms
//! of an L-shaped footprint (outlines), under inherited attributes, with
//! repeated labels, for any thread count, and at the depth limit.

use grm_shape::{
    Alternative, Axis, Comp, CompCase, CompTarget, Expr, Lot, Op, Options, Part, ProgramBuilder,
    Selector, Split, derive,
};

/// The test grammar; with `general`, every leaf rule has a second
/// alternative that never holds.
fn program(general: bool) -> grm_shape::Program {
    let mut b = ProgramBuilder::new("simple");
    let lot = b.symbol("Lot");
    let block = b.symbol("Block");
    let facade = b.symbol("Facade");
    let bay = b.symbol("Bay");
    let cap = b.symbol("Cap");
    let roof = b.symbol("Roof");
    let brick = b.material("brick");
    let window = b.asset("window");
    let sill = b.asset("sill");
    let slab = b.asset("slab");
    let never = b.expr(&Expr::Bool(false));
    let leaf = |b: &mut ProgramBuilder, s, ops: Vec<Op>| {
        let mut alts = vec![Alternative::new(ops.clone())];
        if general {
            alts.push(Alternative::new(ops).when(never));
        }
        b.rule_alternatives(s, alts);
    };
    b.rule(
        lot,
        vec![
            Op::Extrude(12.0.into()),
            Op::Split(Split {
                axis: Axis::X,
                parts: vec![Part::float(1.0, Some(block)), Part::abs(4.0, Some(block))],
                tag: None,
            }),
        ],
    );
    // A prism (the L's pieces) takes the general road even when simple.
    leaf(&mut b, block, vec![Op::Emit(cap), Op::Insert(slab)]);
    b.rule(
        cap,
        vec![Op::Comp(Comp {
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
            tag: None,
        })],
    );
    b.rule(
        facade,
        vec![
            Op::Material(brick),
            Op::Repeat(Split {
                axis: Axis::X,
                parts: vec![Part::float(2.0, Some(bay))],
                tag: None,
            }),
        ],
    );
    // Repeated labels: the ordinals of window and sill count up.
    leaf(
        &mut b,
        bay,
        vec![
            Op::Insert(window),
            Op::Insert(sill),
            Op::Insert(window),
            Op::Emit(roof),
        ],
    );
    leaf(&mut b, roof, vec![Op::Insert(slab)]);
    b.build(lot).expect("program")
}

fn l_lot() -> Lot {
    Lot::footprint(&[
        [0.0, 0.0],
        [20.0, 0.0],
        [20.0, 8.0],
        [8.0, 8.0],
        [8.0, 16.0],
        [0.0, 16.0],
    ])
    .expect("lot")
}

#[test]
fn simple_rules_write_what_the_general_road_writes() {
    let (short, general) = (program(false), program(true));
    for lot in [l_lot(), Lot::rectangle(30.0, 10.0)] {
        for threads in [1, 3] {
            for seed in [0, 9] {
                let options = Options {
                    seed,
                    threads,
                    ..Options::default()
                };
                let a = derive(&short, &lot, &options).expect("short road");
                let b = derive(&general, &lot, &options).expect("general road");
                assert!(a.len() > 100, "{} nodes", a.len());
                assert_eq!(a, b, "threads {threads}, seed {seed}");
            }
        }
    }
}

#[test]
fn simple_rules_stop_at_the_depth_limit_as_the_general_road_does() {
    let (short, general) = (program(false), program(true));
    for max_depth in 1..9 {
        let options = Options {
            limits: grm_shape::Limits {
                max_depth,
                ..Default::default()
            },
            ..Options::default()
        };
        let a = derive(&short, &Lot::rectangle(30.0, 10.0), &options);
        let b = derive(&general, &Lot::rectangle(30.0, 10.0), &options);
        assert_eq!(a, b, "max depth {max_depth}");
    }
}

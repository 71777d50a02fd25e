//! Random lots and random programs never make the engine panic: every
//! outcome is a tree or a typed error, and the same with any thread count.
//! (`GRM_TEST_SEED=n` draws other inputs: docs/ARCHITECTURE.md, invariant 10.)

use grm_shape::{
    Axis, Comp, CompCase, CompTarget, Limits, Lot, Op, Options, Part, ProgramBuilder, RoofKind,
    Selector, Split, SymbolId, derive,
};
use grm_testkit::Rng;

fn number(rng: &mut Rng) -> f32 {
    match rng.below(10u32) {
        0 => f32::NAN,
        1 => -rng.range_f32(0.0, 5.0),
        2 => 0.0,
        3 => 1e30,
        4 => 1e-30,
        _ => rng.range_f32(0.1, 6.0),
    }
}

fn part(rng: &mut Rng, symbols: &[SymbolId]) -> Part {
    let v = number(rng);
    let target = if rng.below(5u32) == 0 {
        None
    } else {
        Some(*rng.pick(symbols))
    };
    match rng.below(3u32) {
        0 => Part::abs(v, target),
        1 => Part::rel(v, target),
        _ => Part::float(v, target),
    }
}

fn op(rng: &mut Rng, symbols: &[SymbolId]) -> Op {
    let axis = *rng.pick(&[Axis::X, Axis::Y, Axis::Z]);
    let parts = |rng: &mut Rng| {
        (0..1 + rng.below(3u32))
            .map(|_| part(rng, symbols))
            .collect::<Vec<_>>()
    };
    match rng.below(14u32) {
        0 => Op::Extrude(number(rng).into()),
        1 => Op::Translate([number(rng).into(), number(rng).into(), number(rng).into()]),
        2 => Op::Rotate {
            axis,
            degrees: number(rng).into(),
        },
        3 => Op::Size([Some(number(rng).into()), None, Some(number(rng).into())]),
        4 => Op::Center([true, rng.below(2u32) == 0, false]),
        5 => Op::Push,
        6 => Op::Pop,
        7 => Op::Offset((-number(rng)).into()),
        8 => Op::Emit(*rng.pick(symbols)),
        9 => Op::Split(Split {
            axis,
            parts: parts(rng),
            tag: None,
        }),
        10 => Op::Repeat(Split {
            axis,
            parts: parts(rng),
            tag: None,
        }),
        11 => Op::Roof {
            kind: *rng.pick(&[
                RoofKind::Flat,
                RoofKind::Hip,
                RoofKind::Gable,
                RoofKind::Shed,
                RoofKind::Pyramid,
            ]),
            angle: (number(rng) * 10.0).into(),
            overhang: (number(rng) * 0.2).into(),
        },
        12 => Op::Taper(number(rng).into()),
        _ => Op::Comp(Comp {
            target: *rng.pick(&[CompTarget::Faces, CompTarget::Edges]),
            cases: vec![
                CompCase {
                    selector: *rng.pick(&[
                        Selector::Front,
                        Selector::Side,
                        Selector::Top,
                        Selector::All,
                        Selector::Slope,
                        Selector::Ridge,
                    ]),
                    target: Some(*rng.pick(symbols)),
                },
                CompCase {
                    selector: Selector::All,
                    target: Some(*rng.pick(symbols)),
                },
            ],
            tag: None,
        }),
    }
}

fn polygon(rng: &mut Rng) -> Vec<[f64; 2]> {
    let n = 3 + rng.below(7u32) as usize;
    let scale = *rng.pick(&[1e-3, 1.0, 30.0, 1e6]);
    (0..n)
        .map(|_| [rng.range(0.0, 1.0) * scale, rng.range(0.0, 1.0) * scale])
        .collect()
}

#[test]
fn random_programs_and_lots_never_panic() {
    let mut rng = Rng::seeded(26);
    let mut trees = 0;
    for case in 0..150 {
        let mut b = ProgramBuilder::new("random");
        let symbols: Vec<SymbolId> = (0..4).map(|i| b.symbol(&format!("S{i}"))).collect();
        for &s in &symbols[..3] {
            let ops = (0..1 + rng.below(4u32))
                .map(|_| op(&mut rng, &symbols))
                .collect();
            b.rule(s, ops);
        }
        let program = b.build(symbols[0]).unwrap();
        let points = polygon(&mut rng);
        let Ok(lot) = Lot::footprint(&points) else {
            continue;
        };
        // Small limits: a rule that offsets outward and calls itself grows
        // its outline at every level, and each level's offset costs more.
        let limits = Limits {
            max_nodes: 2_000,
            max_depth: 12,
        };
        let one = derive(
            &program,
            &lot,
            &Options {
                limits,
                ..Options::default()
            },
        );
        let two = derive(
            &program,
            &lot,
            &Options {
                limits,
                threads: 3,
                ..Options::default()
            },
        );
        // Equal, or equal to the bit where floats are NaN (compared as text).
        assert!(
            one == two || format!("{one:?}") == format!("{two:?}"),
            "case {case}: {points:?}"
        );
        trees += usize::from(one.is_ok());
    }
    assert!(trees > 20, "only {trees} programs derived without error");
}

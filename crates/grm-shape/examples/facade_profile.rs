//! The facade benchmark's workloads for instruction counts
//! (`valgrind --tool=callgrind`), which do not suffer a shared machine's
//! noise as wall-clock times do: `facade_profile grm|peer facade|tower N`
//! derives the workload N times with one engine (the grammar of
//! `benches/facade.rs`). Run the binary once with N = 0 and once with N
//! to subtract the set-up. `facade_profile digest` prints a hash of
//! the whole tree (its `Debug` text) of both workloads and of a mixed
//! grammar (an L-shaped mass, weighted alternatives, repeated successors,
//! push / pop, attributes), on one thread and on three, to check that a
//! change to the engine keeps its output byte for byte.

use grm_shape::{
    Axis, Comp, CompCase, CompTarget, Lot, Op, Options, Part, Program, ProgramBuilder, Scope,
    Selector, Split, derive,
};
use std::hint::black_box;
use symbios_shape::{Quat, Scope as PeerScope, Vec3 as PeerVec3};

#[path = "../benches/workloads/mod.rs"]
mod workloads;
use workloads::{grm_program, peer};

/// A grammar that exercises more of the engine than the benchmark's.
fn mixed_program() -> Program {
    let mut b = ProgramBuilder::new("mixed");
    let lot = b.symbol("Lot");
    let facade = b.symbol("Facade");
    let floor = b.symbol("Floor");
    let ledge = b.symbol("Ledge");
    let window = b.symbol("Window");
    let roof = b.symbol("Roof");
    let brick = b.material("brick");
    let glass = b.material("glass");
    let win = b.asset("window");
    let slab = b.asset("slab");
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
                tag: None,
            }),
        ],
    );
    b.rule_alternatives(
        facade,
        vec![
            grm_shape::Alternative::weighted(
                2.0,
                vec![
                    Op::Material(brick),
                    Op::Repeat(Split {
                        axis: Axis::Y,
                        parts: vec![Part::abs(3.0, Some(floor))],
                        tag: None,
                    }),
                ],
            ),
            grm_shape::Alternative::weighted(
                1.0,
                vec![Op::Split(Split {
                    axis: Axis::Y,
                    parts: vec![
                        Part::rel(0.25, Some(floor)),
                        Part::float(1.0, Some(floor)),
                        Part::abs(2.0, None),
                    ],
                    tag: None,
                })],
            ),
        ],
    );
    b.rule(
        floor,
        vec![
            Op::Emit(ledge),
            Op::Push,
            Op::Material(glass),
            Op::Repeat(Split {
                axis: Axis::X,
                parts: vec![Part::float(1.5, Some(window)), Part::abs(0.5, None)],
                tag: None,
            }),
            Op::Pop,
            Op::Emit(ledge),
        ],
    );
    b.rule(ledge, vec![Op::Insert(slab), Op::Insert(slab)]);
    b.rule(window, vec![Op::Insert(win)]);
    b.build(lot).expect("mixed program")
}

fn digest() {
    use std::hash::{DefaultHasher, Hash, Hasher};
    let facade = Lot::face(Scope::new(
        glam::Vec3::ZERO,
        glam::Vec3::new(100.0, 120.0, 0.0),
    ));
    let l_shape = Lot::footprint(&[
        [0.0, 0.0],
        [40.0, 0.0],
        [40.0, 15.0],
        [15.0, 15.0],
        [15.0, 35.0],
        [0.0, 35.0],
    ])
    .expect("L");
    let cases = [
        ("facade", grm_program(false), facade),
        ("tower", grm_program(true), Lot::rectangle(100.0, 100.0)),
        ("mixed", mixed_program(), l_shape),
    ];
    for (name, program, lot) in cases {
        for threads in [1, 3] {
            let options = Options {
                threads,
                seed: 7,
                ..Options::default()
            };
            let tree = derive(&program, &lot, &options).expect("derive");
            let mut h = DefaultHasher::new();
            format!("{tree:?}").hash(&mut h);
            println!(
                "{name}, {threads} thread(s): {} nodes, digest {:016x}",
                tree.len(),
                h.finish()
            );
        }
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.get(1).is_some_and(|a| a == "digest") {
        return digest();
    }
    let usage = "usage: facade_profile grm|peer facade|tower N";
    let (engine, workload, n) = match args.as_slice() {
        [_, e, w, n] => (e.as_str(), w.as_str(), n.parse::<usize>().expect(usage)),
        _ => panic!("{usage}"),
    };
    let tower = match workload {
        "facade" => false,
        "tower" => true,
        _ => panic!("{usage}"),
    };
    match engine {
        "grm" => {
            let program = grm_program(tower);
            let lot = if tower {
                Lot::rectangle(100.0, 100.0)
            } else {
                Lot::face(Scope::new(
                    glam::Vec3::ZERO,
                    glam::Vec3::new(100.0, 120.0, 0.0),
                ))
            };
            for _ in 0..n {
                black_box(derive(&program, &lot, &Options::default()).expect("derive"));
            }
        }
        "peer" => {
            let interp = peer(tower);
            let size = if tower {
                PeerVec3::new(100.0, 0.0, 100.0)
            } else {
                PeerVec3::new(100.0, 120.0, 0.0)
            };
            let scope = PeerScope::new(PeerVec3::ZERO, Quat::IDENTITY, size);
            let root = if tower { "Tower" } else { "Facade" };
            for _ in 0..n {
                black_box(interp.derive(scope, root).expect("peer derive"));
            }
        }
        _ => panic!("{usage}"),
    }
}

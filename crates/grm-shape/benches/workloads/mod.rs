//! The facade benchmark's workloads (docs/shapes.md, "Benchmark"), one
//! definition for `benches/facade.rs` and `examples/facade_profile.rs`:
//! the grammar for grm-shape (the facade, or the tower `height` high) and
//! the same rules for the `symbios-shape` peer.

use grm_shape::{
    Axis, Comp, CompCase, CompTarget, Op, Part, Program, ProgramBuilder, Selector, Split,
};
use symbios_shape::Interpreter;
use symbios_shape::grammar::parse_ops;

pub fn grm_program(tower: bool) -> Program {
    grm_program_of(tower, 120.0)
}

/// The bench grammar with the tower `height` high.
pub fn grm_program_of(tower: bool, height: f32) -> Program {
    let mut b = ProgramBuilder::new("bench");
    let floor_tag = b.tag("floor");
    let column_tag = b.tag("column");
    let facade_tag = b.tag("facade");
    let tower_s = b.symbol("Tower");
    let facade = b.symbol("Facade");
    let floor = b.symbol("Floor");
    let tile = b.symbol("Tile");
    let strip = b.symbol("WinStrip");
    let window = b.symbol("Window");
    let wall = b.symbol("Wall");
    let roof = b.symbol("Roof");
    let window_asset = b.asset("window");
    let wall_asset = b.asset("wall");
    let roof_asset = b.asset("roof");
    b.rule(
        tower_s,
        vec![
            Op::Extrude(height.into()),
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
                tag: Some(facade_tag),
            }),
        ],
    );
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
    b.rule(
        tile,
        vec![Op::Split(Split {
            axis: Axis::X,
            parts: vec![
                Part::float(0.4, Some(wall)),
                Part::abs(1.2, Some(strip)),
                Part::float(0.4, Some(wall)),
            ],
            tag: None,
        })],
    );
    b.rule(
        strip,
        vec![Op::Split(Split {
            axis: Axis::Y,
            parts: vec![
                Part::float(1.0, Some(wall)),
                Part::abs(1.5, Some(window)),
                Part::float(0.5, Some(wall)),
            ],
            tag: None,
        })],
    );
    b.rule(window, vec![Op::Insert(window_asset)]);
    b.rule(wall, vec![Op::Insert(wall_asset)]);
    b.rule(roof, vec![Op::Insert(roof_asset)]);
    b.build(if tower { tower_s } else { facade })
        .expect("bench program")
}

pub fn peer(tower: bool) -> Interpreter {
    let mut i = Interpreter::new();
    let rules = [
        (
            "Tower",
            "Extrude(120) Comp(Faces) { Side: Facade | Top: Roof }",
        ),
        ("Facade", "Repeat(Y, 3) { Floor }"),
        ("Floor", "Repeat(X, 2) { Tile }"),
        (
            "Tile",
            "Split(X) { ~0.4: Wall | 1.2: WinStrip | ~0.4: Wall }",
        ),
        (
            "WinStrip",
            "Split(Y) { ~1: Wall | 1.5: Window | ~0.5: Wall }",
        ),
        ("Window", r#"I("window")"#),
        ("Wall", r#"I("wall")"#),
        ("Roof", r#"I("roof")"#),
    ];
    for (name, text) in rules {
        if name == "Tower" && !tower {
            continue;
        }
        i.add_rule(name, parse_ops(text).expect("peer rule"));
    }
    i
}

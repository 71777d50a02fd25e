//! Exact locators that survive an insertion and a wrapping (issue 27,
//! docs/edits.md, "Targets"): ordinal edges (`#k`, the k-th child of the
//! next label) do not shift when a part of another symbol is inserted
//! before; a step to a command that no longer matches goes through an
//! inserted level when exactly one command fits there (resolved, and
//! replayed: `grm_shape::derive_with_edits`), is ambiguous and never
//! applied when two fit, and a shape is never matched one level deeper.

use glam::Vec3;
use grm_edits::{Edit, Op as EditOp, Target};
use grm_shape::{
    Axis, EditPlan, ExactLocator, Lot, NodeId, NodeKind, Op, Options, Part, Program,
    ProgramBuilder, Resolution, Scope, ShapeTree, Split, derive, derive_with_edits,
};

/// How the facade's upper part is built.
#[derive(Clone, Copy, PartialEq)]
enum Variant {
    /// `Facade -> split(y) { 3: Ground | ~1: Upper }; Upper -> repeat(y) { 3: Floor }`.
    Plain,
    /// A mezzanine inserted: `split(y) { 3: Ground | 3: Mezzanine | ~1: Upper }`.
    Mezzanine,
    /// Upper's repeat wrapped: `Upper -> split(y) { ~1: Floors | 1: Cornice }`,
    /// `Floors -> repeat(y) { 3: Floor }`.
    Wrapped,
    /// Wrapped twice alike: `Upper -> split(y) { ~1: Floors | ~1: Floors }`.
    Twice,
    /// The windows' glass one level deeper: `Window -> split(y) { ~1: Glass | ~1: Glass }`.
    GlassSplit,
}

fn program(v: Variant) -> Program {
    let mut b = ProgramBuilder::new("facade");
    let facade = b.symbol("Facade");
    let ground = b.symbol("Ground");
    let mezzanine = b.symbol("Mezzanine");
    let upper = b.symbol("Upper");
    let floors = b.symbol("Floors");
    let cornice = b.symbol("Cornice");
    let floor = b.symbol("Floor");
    let window = b.symbol("Window");
    let glass = b.symbol("Glass");
    let mut parts = vec![Part::abs(3.0, Some(ground))];
    if v == Variant::Mezzanine {
        parts.push(Part::abs(3.0, Some(mezzanine)));
    }
    parts.push(Part::float(1.0, Some(upper)));
    let split = |parts| {
        Op::Split(Split {
            axis: Axis::Y,
            parts,
            tag: None,
        })
    };
    b.rule(facade, vec![split(parts)]);
    let floors_repeat = Op::Repeat(Split {
        axis: Axis::Y,
        parts: vec![Part::abs(3.0, Some(floor))],
        tag: None,
    });
    match v {
        Variant::Wrapped => {
            b.rule(
                upper,
                vec![split(vec![
                    Part::float(1.0, Some(floors)),
                    Part::abs(1.0, Some(cornice)),
                ])],
            );
            b.rule(floors, vec![floors_repeat]);
        }
        Variant::Twice => {
            b.rule(
                upper,
                vec![split(vec![
                    Part::float(1.0, Some(floors)),
                    Part::float(1.0, Some(floors)),
                ])],
            );
            b.rule(floors, vec![floors_repeat]);
        }
        _ => {
            b.rule(upper, vec![floors_repeat]);
        }
    }
    b.rule(
        floor,
        vec![Op::Repeat(Split {
            axis: Axis::X,
            parts: vec![Part::float(3.0, Some(window))],
            tag: None,
        })],
    );
    if v == Variant::GlassSplit {
        b.rule(
            window,
            vec![split(vec![
                Part::float(1.0, Some(glass)),
                Part::float(1.0, Some(glass)),
            ])],
        );
    } else {
        b.rule(window, vec![Op::Emit(glass)]);
    }
    b.build(facade).unwrap()
}

fn lot() -> Lot {
    Lot::face(Scope::new(Vec3::ZERO, Vec3::new(12.0, 30.0, 0.0)))
}

fn grow(p: &Program) -> ShapeTree {
    derive(p, &lot(), &Options::default()).unwrap()
}

/// The shapes of `name`, in tree order.
fn shapes(p: &Program, t: &ShapeTree, name: &str) -> Vec<NodeId> {
    let s = p.symbol(name).unwrap();
    (0..t.len() as u32)
        .map(NodeId)
        .filter(
            |&n| matches!(t.node(n).unwrap().kind, NodeKind::Shape { symbol, .. } if symbol == s),
        )
        .collect()
}

/// The first shape of `name` whose box's lower corner is `at` (x, y).
fn at(p: &Program, t: &ShapeTree, name: &str, x: f32, y: f32) -> NodeId {
    shapes(p, t, name)
        .into_iter()
        .find(|&n| {
            let o = t.node(n).unwrap().scope.origin;
            (o.x - x).abs() < 1e-3 && (o.y - y).abs() < 1e-3
        })
        .unwrap_or_else(|| panic!("no {name} at {x}, {y}"))
}

/// The shapes edit 1 (target `loc`) reached when `p` is grown with it.
fn replayed(p: &Program, loc: &ExactLocator) -> Vec<NodeId> {
    let edit = Edit {
        id: 1,
        system: "facade".into(),
        parcel: None,
        target: Target::Exact(loc.clone()),
        selected: None,
        symbol: None,
        op: EditOp::Remove,
        note: None,
        span: Default::default(),
    };
    let plan = EditPlan::new(p, [&edit]);
    let t = derive_with_edits(p, &lot(), &Options::default(), Some(&plan)).unwrap();
    t.edit_hits(1).unwrap()
}

#[test]
fn an_inserted_part_does_not_shift_an_ordinal_edge() {
    let (a, b) = (program(Variant::Plain), program(Variant::Mezzanine));
    let (ta, tb) = (grow(&a), grow(&b));
    // Floor 2's third window: y = 3 + 3 (floor 2 starts 3 above Upper).
    let wa = at(&a, &ta, "Window", 6.0, 6.0);
    let loc = ta.exact_locator(&a, wa);
    assert_eq!(
        loc.to_string(),
        "{Facade, #1, split.y, #1, Upper, #1, repeat.y, #2, Floor, #1, repeat.x, #3, Window}"
    );
    // After the mezzanine, the same window is 3 higher.
    let wb = at(&b, &tb, "Window", 6.0, 9.0);
    assert_eq!(tb.resolve(&b, &loc), Resolution::Found(wb));
    assert_eq!(replayed(&b, &loc), [wb]);
    // A raw edge number (version 1) names the second part, the mezzanine
    // now: the label does not fit, nothing is applied.
    let v1: ExactLocator =
        "{Facade, 1, split.y, 2, Upper, 1, repeat.y, 2, Floor, 1, repeat.x, 3, Window}"
            .parse()
            .unwrap();
    assert_eq!(ta.resolve(&a, &v1), Resolution::Found(wa));
    assert_eq!(replayed(&a, &v1), [wa]);
    assert_eq!(tb.resolve(&b, &v1), Resolution::Invalid);
    assert_eq!(replayed(&b, &v1), []);
}

#[test]
fn a_wrapped_split_is_gone_through_when_one_command_fits() {
    let (a, b) = (program(Variant::Plain), program(Variant::Wrapped));
    let (ta, tb) = (grow(&a), grow(&b));
    let wa = at(&a, &ta, "Window", 3.0, 9.0);
    let loc = ta.exact_locator(&a, wa);
    let wb = at(&b, &tb, "Window", 3.0, 9.0);
    assert_eq!(tb.resolve(&b, &loc), Resolution::Found(wb));
    assert_eq!(
        tb.exact_locator(&b, wb).to_string(),
        "{Facade, #1, split.y, #1, Upper, #1, split.y, #1, Floors, #1, repeat.y, #3, Floor, #1, repeat.x, #2, Window}"
    );
    // The replay reaches it too (a second derivation with its new path),
    // and only it.
    assert_eq!(replayed(&b, &loc), [wb]);
    // A part below it: its whole path after the wrapping is direct.
    let ga = at(&a, &ta, "Glass", 3.0, 9.0);
    let gb = at(&b, &tb, "Glass", 3.0, 9.0);
    let gloc = ta.exact_locator(&a, ga);
    assert_eq!(tb.resolve(&b, &gloc), Resolution::Found(gb));
    assert_eq!(replayed(&b, &gloc), [gb]);
}

#[test]
fn two_commands_through_an_inserted_level_are_ambiguous_and_never_applied() {
    let (a, b) = (program(Variant::Plain), program(Variant::Twice));
    let ta = grow(&a);
    let tb = grow(&b);
    let loc = ta.exact_locator(&a, at(&a, &ta, "Window", 3.0, 6.0));
    assert_eq!(
        tb.resolve(&b, &loc),
        Resolution::Ambiguous {
            matched: 3,
            candidates: 2
        }
    );
    assert_eq!(replayed(&b, &loc), []);
}

#[test]
fn a_shape_is_not_matched_one_level_deeper() {
    let (a, b) = (program(Variant::Plain), program(Variant::GlassSplit));
    let ta = grow(&a);
    let tb = grow(&b);
    // The window's glass was its successor; now two glass panes of a
    // split: the first is not taken for it.
    let loc = ta.exact_locator(&a, at(&a, &ta, "Glass", 3.0, 6.0));
    assert!(loc.to_string().ends_with("Window, #1, Glass}"), "{loc}");
    assert_eq!(tb.resolve(&b, &loc), Resolution::Invalid);
    assert_eq!(replayed(&b, &loc), []);
}

//! Baking a persistent edit into the grammar (issue 27; docs/edits.md,
//! "Baking"): the baked grammar alone grows what the grammar and the edit
//! grew: the same tree (keys, scopes, alternatives) for a forced
//! alternative, the same model for a material on a terminal shape; what
//! cannot be baked exactly is refused with a reason.

mod common;

use common::*;
use grm_edits::{EditsFile, Op, Target};
use grm_grow::shape::bake::bake;
use grm_grow::shape::{ShapeOptions, derive, derive_with_edits, edit_plan, lower};
use grm_shape::ShapeTree;

struct Grown {
    checked: grm_sema::Checked,
    lowered: grm_grow::shape::Lowered,
    tree: ShapeTree,
}

fn grow(text: &str, edits: Option<&EditsFile>) -> Grown {
    let (_, checked) = grm_sema::check_text("townhouse.grm", text);
    assert!(!checked.has_errors(), "{text}\n{:?}", checked.diagnostics);
    let p = &checked.program;
    let sys = p.default_system().expect("a system");
    let lowered = lower(p, sys, &p.default_params()).expect("lowers");
    let tree = match edits {
        Some(f) => derive_with_edits(
            &lowered,
            lowered.seed,
            &ShapeOptions::default(),
            Some(&edit_plan(&lowered, f)),
        ),
        None => derive(&lowered, lowered.seed, &ShapeOptions::default()),
    }
    .expect("derives");
    Grown {
        checked,
        lowered,
        tree,
    }
}

impl Grown {
    fn model(&self) -> grm_geom::Model {
        let p = &self.checked.program;
        grm_grow::shape::model(
            p,
            &p.default_params(),
            &self.lowered,
            &self.tree,
            None,
            &grm_geom::BuildOptions::default(),
        )
        .expect("builds")
    }
}

fn townhouse() -> String {
    std::fs::read_to_string(example_path("townhouse.grm")).expect("example")
}

fn one(query: &str, op: Op) -> EditsFile {
    let mut f = EditsFile {
        version: 1,
        edits: Vec::new(),
    };
    f.add("Townhouse", Target::Semantic(query.parse().unwrap()), op)
        .unwrap();
    f
}

/// The grammar with `f`'s edit baked in.
fn baked(text: &str, f: &EditsFile) -> Result<String, String> {
    let g = grow(text, None);
    let sys = g.checked.program.default_system().unwrap();
    bake(sys, &g.lowered, &g.tree, text, &f.edits[0]).map(|b| b.apply(text))
}

#[test]
fn a_forced_alternative_baked_grows_the_same_tree() {
    let text = townhouse();
    let plain = grow(&text, None);
    for (query, alt) in [
        ("(floor = 2, column = end 1) Window", 1),
        ("(floor = 2) Window", 2),
        ("(house = centre 0, facade = 1, floor = 3) Window", 1),
    ] {
        let f = one(query, Op::Force { alternative: alt });
        let edited = grow(&text, Some(&f));
        assert_ne!(
            edited.tree.nodes(),
            plain.tree.nodes(),
            "{query}: the edit changes something"
        );
        let new = baked(&text, &f).unwrap_or_else(|e| panic!("{query}: {e}"));
        // The other rule holds no more for the selected windows.
        assert!(new.contains(&format!(
            "Window : !({}) ->",
            grm_grow::shape::bake::condition(&query.parse().unwrap())
        )));
        let b = grow(&new, None);
        assert_eq!(b.tree.nodes(), edited.tree.nodes(), "{query} {alt}\n{new}");
        assert_eq!(b.model(), edited.model(), "{query} {alt}");
    }
}

#[test]
fn a_material_on_a_terminal_shape_baked_grows_the_same_model() {
    let text = townhouse();
    let f = one(
        "(floor = 1, column = 2) Glass",
        Op::Material {
            name: "wood".into(),
        },
    );
    let edited = grow(&text, Some(&f));
    let plain = grow(&text, None);
    assert_ne!(edited.model(), plain.model());
    let new = baked(&text, &f).unwrap();
    assert!(
        new.contains(
            "\n    Glass : tagged(floor) && index(floor) == 1 && tagged(column) && index(column) == 2 -> material(wood);"
        ),
        "{new}"
    );
    assert_eq!(grow(&new, None).model(), edited.model());
}

#[test]
fn what_cannot_be_baked_exactly_is_refused_with_a_reason() {
    let text = townhouse();
    let cases = [
        (
            one(
                "(floor = 2) Window",
                Op::Material {
                    name: "wood".into(),
                },
            ),
            "has rules",
        ),
        (one("(floor = 2) Window", Op::Remove), "not baked"),
        (
            one("(floor = 2)", Op::Force { alternative: 1 }),
            "no symbol",
        ),
        (
            one("(floor = 2) Window", Op::Force { alternative: 3 }),
            "not 3",
        ),
        (
            one(
                "(floor = 2, floor = 1) Window",
                Op::Force { alternative: 1 },
            ),
            "twice",
        ),
    ];
    for (f, why) in cases {
        let e = baked(&text, &f).expect_err(why);
        assert!(e.contains(why), "{e}");
    }
    let mut f = one("(floor = 2) Window", Op::Remove);
    f.edits[0].target = Target::Key(7);
    assert!(baked(&text, &f).unwrap_err().contains("semantic"));
    // A weight that is not a number.
    let weighted = text.replace("Window -> (1) material", "Window -> (floors) material");
    let f = one("(floor = 2) Window", Op::Force { alternative: 1 });
    assert!(baked(&weighted, &f).unwrap_err().contains("weight"));
}

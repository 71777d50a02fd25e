//! The solver over random grammars (issue 28): a solved drag, written and
//! grown again, puts the part where it was dropped (within the stated
//! tolerance, 1e-3), and the parts it reports as moving are exactly the
//! terminal parts that moved; parts it does not report did not move.
//! Inputs from `grm_testkit::Rng::seeded` (GRM_TEST_SEED=n draws others).

use grm_manip::{DragOutcome, Manip, Part, Setup, Target};
use grm_sema::MemLoader;
use grm_shape::{Command, NodeKind};
use grm_testkit::Rng;
use std::collections::HashMap;

fn setup(loader: &MemLoader) -> Setup {
    Setup::new("/m/r.grm", std::sync::Arc::new(loader.clone()))
}

/// A random facade: a lot, a mass, nested splits with absolute and
/// floating parts, sizes sometimes through a shared constant.
fn facade(rng: &mut Rng) -> String {
    let w = rng.int(6, 20);
    let d = rng.int(4, 10);
    let h = rng.int(5, 15);
    let c = format!("{:.1}", rng.range(0.5, 2.0));
    let mut rules = vec![format!("Lot -> extrude({h}) Mass;")];
    let size = |rng: &mut Rng| -> String {
        match rng.below(4u32) {
            0 => "~1".to_string(),
            1 => format!("~{}", rng.int(1, 3)),
            2 => "C".to_string(),
            _ => format!("{:.1}", rng.range(0.3, 2.0)),
        }
    };
    let parts = rng.int(2, 4);
    let mut top = Vec::new();
    for i in 0..parts {
        let s = if i == 0 { "~1".to_string() } else { size(rng) };
        top.push(format!("{s}: P{i}"));
    }
    rules.push(format!("Mass -> split(z) {{ {} }};", top.join(" | ")));
    for i in 0..parts {
        let n = rng.int(2, 4);
        let mut ps = Vec::new();
        for j in 0..n {
            let s = if j == n - 1 {
                "~1".to_string()
            } else {
                size(rng)
            };
            ps.push(format!("{s}: Q"));
        }
        let axis = if rng.below(2u32) == 0 { "x" } else { "y" };
        rules.push(format!("P{i} -> split({axis}) {{ {} }};", ps.join(" | ")));
    }
    format!(
        "const C = {c};\n\nsystem R {{\n    mode = shape;\n    seed = 1;\n    lot = rect({w}, {d});\n    axiom Lot;\n\n    {}\n}}\n",
        rules.join("\n    ")
    )
}

/// Every split plane of the text's tree: (command key, edge, position,
/// the command's extent along its axis).
fn planes(text: &str) -> Vec<(u32, u32, f64, f64)> {
    let (_, checked) = grm_sema::check_text("/m/r.grm", text);
    assert!(!checked.has_errors(), "{text}\n{:?}", checked.diagnostics);
    let p = &checked.program;
    let g = grm_grow::shape::grow(p, &p.systems[0], &[], &Default::default(), None, None)
        .expect("grows");
    let t = &g.tree;
    let mut out = Vec::new();
    for (i, n) in t.nodes().iter().enumerate() {
        let NodeKind::Command {
            command: Command::Split(a),
            ..
        } = n.kind
        else {
            continue;
        };
        let len = n.scope.size[a.index()] as f64;
        for c in t.children(grm_shape::NodeId(i as u32)) {
            let k = t.node(c).unwrap();
            let end = ((k.scope.origin - n.scope.origin).dot(n.scope.axis(a))
                + k.scope.size[a.index()]) as f64;
            if end > 1e-3 && end < len - 1e-3 {
                out.push((n.key, k.edge, end, len));
            }
        }
    }
    out
}

/// Terminal shapes by key: corner and size (shape frame).
fn leaves(text: &str) -> HashMap<u32, [f32; 6]> {
    let (_, checked) = grm_sema::check_text("/m/r.grm", text);
    let p = &checked.program;
    let g = grm_grow::shape::grow(p, &p.systems[0], &[], &Default::default(), None, None)
        .expect("grows");
    g.tree
        .nodes()
        .iter()
        .filter(|n| n.is_shape() && !n.has_children())
        .map(|n| {
            let (o, s) = (n.scope.origin, n.scope.size);
            (n.key, [o.x, o.y, o.z, s.x, s.y, s.z])
        })
        .collect()
}

#[test]
fn solved_drags_land_where_dropped_and_report_what_moves() {
    let mut rng = Rng::seeded(28);
    let loader = MemLoader::default();
    let (mut solved, mut unreachable) = (0, 0);
    for case in 0..60 {
        let text = facade(&mut rng);
        let ps = planes(&text);
        if ps.is_empty() {
            continue;
        }
        let &(command, edge, at, len) = rng.pick(&ps);
        let to = (at + rng.range(-0.4, 0.4) * len.min(4.0)).clamp(0.05 * len, 0.95 * len);
        let m = Manip::new(setup(&loader), &text).expect("manip");
        let part = Part::Plane { command, edge };
        let out = m
            .drag(&part, &Target::Plane { at: to })
            .unwrap_or_else(|e| panic!("case {case}: {e}\n{text}"));
        match out {
            DragOutcome::Solved(s) => {
                solved += 1;
                // Grown again from the written text: where it was dropped.
                let after = planes(&s.text);
                let got = after
                    .iter()
                    .find(|p| p.0 == command && p.1 == edge)
                    .map(|p| p.2)
                    .unwrap_or_else(|| panic!("case {case}: the plane is gone\n{}", s.text));
                assert!(
                    (got - to).abs() <= 1e-3,
                    "case {case}: dropped at {to}, grown at {got}\n{}",
                    s.text
                );
                // What it reports as moving is what moved.
                let (a, b) = (leaves(&text), leaves(&s.text));
                let moved = a
                    .iter()
                    .filter(|(k, v)| {
                        b.get(k)
                            .is_none_or(|w| v.iter().zip(w).any(|(x, y)| (x - y).abs() > 1e-4))
                    })
                    .count()
                    + b.keys().filter(|k| !a.contains_key(k)).count();
                assert_eq!(moved, s.moved, "case {case}\n{text}\n{}", s.text);
                assert!(s.changes.len() <= 2);
            }
            DragOutcome::Unreachable { why, .. } => {
                unreachable += 1;
                assert!(!why.is_empty());
            }
            DragOutcome::Unchanged => assert!((at - to).abs() <= 1e-3),
        }
    }
    // Most planes inside their scope can be moved by their sizes.
    assert!(solved >= 30, "{solved} solved, {unreachable} unreachable");
}

/// The bones of a derive-mode text: (key, base, tip).
fn bones(text: &str) -> Vec<(u32, glam::Vec3, glam::Vec3)> {
    let (_, checked) = grm_sema::check_text("/m/r.grm", text);
    assert!(!checked.has_errors(), "{text}\n{:?}", checked.diagnostics);
    let p = &checked.program;
    let c = grm_compile::compile(p, &p.systems[0], &[]).expect("compiles");
    let rec = grm_grow::Record {
        keys: true,
        ..Default::default()
    };
    let opts = grm_derive::DeriveOptions {
        iterations: c.settings.iterations,
        seed: c.settings.seed,
        limits: Default::default(),
    };
    let g = grm_grow::Grower::new(&c, 1, rec)
        .expect("engine")
        .derive(&opts, &mut |_| {})
        .expect("derives");
    let it = grm_turtle::interpret(&p.systems[0], &c.settings, &g.string).expect("turtle");
    it.bones
        .iter()
        .map(|b| (g.string.key(b.module as usize).unwrap(), b.base, b.tip))
        .collect()
}

#[test]
fn dragged_bone_tips_land_where_dropped() {
    let mut rng = Rng::seeded(2828);
    let loader = MemLoader::default();
    let mut solved = 0;
    for case in 0..30 {
        let n = rng.int(2, 5);
        let mut succ = Vec::new();
        for i in 0..n {
            if i > 0 {
                let turn = if rng.below(2u32) == 0 { "+" } else { "-" };
                succ.push(format!("{turn}({:.0})", rng.range(5.0, 80.0)));
            }
            succ.push(format!("F({:.1})", rng.range(0.5, 3.0)));
        }
        let text = format!(
            "system T {{\n    iterations = 1;\n    axiom A;\n    A -> {};\n}}\n",
            succ.join(" ")
        );
        let bs = bones(&text);
        let &(key, base, tip) = rng.pick(&bs);
        // Along the bone: its own length literal reaches it.
        let k = rng.range(0.6, 1.6) as f32;
        let to = base + (tip - base) * k;
        let m = Manip::new(setup(&loader), &text).expect("manip");
        let part = Part::Bone { key };
        let target = Target::Tip {
            at: to.to_array().map(f64::from),
        };
        match m.drag(&part, &target).expect("drag") {
            DragOutcome::Solved(s) => {
                solved += 1;
                let got = bones(&s.text)
                    .into_iter()
                    .find(|b| b.0 == key)
                    .unwrap_or_else(|| panic!("case {case}: the bone is gone\n{}", s.text));
                assert!(
                    (got.2 - to).length() <= 1e-3,
                    "case {case}: dropped at {to}, grown at {}\n{text}\n{}",
                    got.2,
                    s.text
                );
            }
            DragOutcome::Unchanged => assert!((k - 1.0).abs() < 1e-3),
            DragOutcome::Unreachable { why, .. } => {
                panic!("case {case}: along the bone is always reachable: {why}\n{text}")
            }
        }
    }
    assert!(solved >= 25, "{solved}");
}

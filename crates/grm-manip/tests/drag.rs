//! Drags and sketches solved through the real engines: the edit is
//! grown again and the part is where it was dropped.

use grm_manip::{DragOutcome, Keyframe, Manip, Part, Setup, Target};
use grm_sema::MemLoader;
use grm_shape::{Command, NodeKind};

fn setup(loader: &MemLoader, params: &[String]) -> Setup {
    Setup {
        params: params.to_vec(),
        ..Setup::new("/m/house.grm", std::sync::Arc::new(loader.clone()))
    }
}

/// The key of the first split (or repeat) command along `axis` in a
/// shape system's tree, and its children's edges.
fn split_key(text: &str, axis: &str) -> u32 {
    let (_, checked) = grm_sema::check_text("/m/house.grm", text);
    assert!(!checked.has_errors(), "{:?}", checked.diagnostics);
    let p = &checked.program;
    let values = grm_compile::param_values(p, &[]).unwrap();
    let g =
        grm_grow::shape::grow(p, &p.systems[0], &values, &Default::default(), None, None).unwrap();
    g.tree
        .nodes()
        .iter()
        .find(|n| match n.kind {
            NodeKind::Command {
                command: Command::Split(a) | Command::Repeat(a),
                ..
            } => a.name() == axis,
            _ => false,
        })
        .map(|n| n.key)
        .expect("a split")
}

const HOUSE: &str = "const H = 3;

system House {
    mode = shape;
    seed = 1;
    lot = rect(10, 6);
    axiom Lot;

    Lot -> extrude(8) Mass;
    Mass -> split(z) { H: Ground | ~1: Top };
    Ground -> split(x) { ~1: Wall | 2: Door | ~1: Wall };
    Top -> split(x) { ~1: Wall | H: Band | ~1: Wall };
}
";

fn solved(o: DragOutcome) -> grm_manip::Solution {
    match o {
        DragOutcome::Solved(s) => s,
        other => panic!("not solved: {other:?}"),
    }
}

#[test]
fn dragging_a_split_plane_rewrites_its_size() {
    let loader = MemLoader::default();
    let text = HOUSE.replace("{ H: Ground", "{ 3: Ground");
    let m = Manip::new(setup(&loader, &[]), &text).unwrap();
    let key = split_key(&text, "z");
    let part = Part::Plane {
        command: key,
        edge: 1,
    };
    assert_eq!(m.measures(&part).unwrap(), vec![3.0]);
    let s = solved(m.drag(&part, &Target::Plane { at: 3.5 }).unwrap());
    assert_eq!(s.changes.len(), 1);
    assert_eq!(
        (s.changes[0].old.as_str(), s.changes[0].new.as_str()),
        ("3", "3.5")
    );
    assert!(s.residual <= 1e-3, "{s:?}");
    assert!(s.text.contains("split(z) { 3.5: Ground"), "{}", s.text);
    // Growing the edited text puts the plane there.
    let again = Manip::new(setup(&loader, &[]), &s.text).unwrap();
    assert!((again.measures(&part).unwrap()[0] - 3.5).abs() < 1e-4);
}

#[test]
fn a_shared_constant_gets_an_offset_at_this_use_only() {
    let loader = MemLoader::default();
    let m = Manip::new(setup(&loader, &[]), HOUSE).unwrap();
    let key = split_key(HOUSE, "z");
    let part = Part::Plane {
        command: key,
        edge: 1,
    };
    let s = solved(m.drag(&part, &Target::Plane { at: 2.5 }).unwrap());
    assert_eq!(s.changes.len(), 1, "{s:?}");
    assert_eq!(s.changes[0].new, "H - 0.5", "{s:?}");
    assert!(s.text.contains("{ H - 0.5: Ground"), "{}", s.text);
    // The band (the other use of H) keeps its width.
    assert!(s.text.contains("H: Band"));
    let prov = m.provenance(&part).unwrap();
    let written: Vec<&str> = prov
        .sources
        .iter()
        .map(|s| s.candidate.text.as_str())
        .collect();
    // The constant's declaration, the use, and the extrusion's height
    // (which moves the floating part, not this plane) : only the first two.
    assert_eq!(written, ["3", "H"], "{prov:?}");
    for s in &prov.sources {
        assert!((s.derivative[0] - 1.0).abs() < 1e-3, "{s:?}");
    }
}

#[test]
fn a_plane_past_its_scope_is_unreachable_and_says_why() {
    let loader = MemLoader::default();
    let m = Manip::new(setup(&loader, &[]), HOUSE).unwrap();
    let key = split_key(HOUSE, "x");
    // The door's far plane cannot go below zero: no lot, door width or
    // weight puts it there.
    let part = Part::Plane {
        command: key,
        edge: 2,
    };
    match m.drag(&part, &Target::Plane { at: -5.0 }).unwrap() {
        DragOutcome::Unreachable { why, .. } => assert!(why.contains("no change"), "{why}"),
        other => panic!("reached: {other:?}"),
    }
}

const TREE: &str = "system T {
    iterations = 1;
    axiom A;
    A -> F(2) +(30) F(1);
}
";

#[test]
fn a_bone_tip_is_dragged_by_its_length_and_angle() {
    let loader = MemLoader::default();
    let m = Manip::new(setup(&loader, &[]), TREE).unwrap();
    // The second bone: find its key from the provenance of every bone.
    let (_, checked) = grm_sema::check_text("/m/house.grm", TREE);
    let p = &checked.program;
    let c = grm_compile::compile(p, &p.systems[0], &[]).unwrap();
    let rec = grm_grow::Record {
        keys: true,
        ..Default::default()
    };
    let g = grm_grow::Grower::new(&c, 1, rec)
        .unwrap()
        .derive(
            &grm_derive::DeriveOptions {
                iterations: 1,
                seed: c.settings.seed,
                limits: Default::default(),
            },
            &mut |_| {},
        )
        .unwrap();
    let interp = grm_turtle::interpret(&p.systems[0], &c.settings, &g.string).unwrap();
    let second = &interp.bones[1];
    let part = Part::Bone {
        key: g.string.key(second.module as usize).unwrap(),
    };
    // Longer, same direction: the length literal alone.
    let dir = (second.tip - second.base).normalize();
    let tip = second.base + dir * 1.5;
    let s = solved(
        m.drag(
            &part,
            &Target::Tip {
                at: tip.to_array().map(f64::from),
            },
        )
        .unwrap(),
    );
    assert_eq!(s.changes.len(), 1, "{s:?}");
    assert_eq!(
        (s.changes[0].old.as_str(), s.changes[0].new.as_str()),
        ("1", "1.5")
    );
    // A tip off the bone's line needs the angle too: two numbers.
    let turned = glam::Quat::from_axis_angle(glam::Vec3::Z, 0.2) * dir;
    let tip = second.base + turned * 1.2;
    let s = solved(
        m.drag(
            &part,
            &Target::Tip {
                at: tip.to_array().map(f64::from),
            },
        )
        .unwrap(),
    );
    assert!(s.changes.len() <= 2 && s.residual <= 1e-3, "{s:?}");
}

#[test]
fn a_sketched_parameter_is_exact_at_zero_and_reaches_the_pose_at_one() {
    let loader = MemLoader::default();
    let text = HOUSE.replace("{ H: Ground", "{ 3: Ground");
    let m = Manip::new(setup(&loader, &[]), &text).unwrap();
    let key = split_key(&text, "z");
    let part = Part::Plane {
        command: key,
        edge: 1,
    };
    let keys = [
        Keyframe {
            t: 0.5,
            target: Target::Plane { at: 3.2 },
        },
        Keyframe {
            t: 1.0,
            target: Target::Plane { at: 4.0 },
        },
    ];
    let s = m.sketch(&part, &keys, "ground").unwrap();
    assert!(s.exact_at_zero, "{s:?}");
    for (t, r) in &s.residuals {
        assert!(*r <= 1e-3, "t = {t}: {r}");
    }
    assert!(s.text.contains("param ground = 0 in 0 .. 1;"), "{}", s.text);
    assert!(
        s.text.contains("(if ground < 0.5 then mix(3, 3.2, ground / 0.5) else mix(4, 3.2, (1 - ground) / 0.5)): Ground"),
        "{}",
        s.text
    );
    // A second sketch on the edited text combines with the first.
    let m2 = Manip::new(setup(&loader, &[]), &s.text).unwrap();
    let s2 = m2
        .sketch(
            &part,
            &[Keyframe {
                t: 1.0,
                target: Target::Plane { at: 2.0 },
            }],
            "low",
        )
        .unwrap();
    assert!(s2.exact_at_zero, "{s2:?}");
    assert!(s2.residuals[0].1 <= 1e-3);
    // Taken names and bad names are refused.
    assert!(m2.sketch(&part, &keys, "ground").is_err());
    assert!(m2.sketch(&part, &keys, "if").is_err());
}

#[test]
fn a_drag_after_a_provenance_reuses_its_probes() {
    let loader = MemLoader::default();
    let m = Manip::new(setup(&loader, &[]), HOUSE).unwrap();
    let key = split_key(HOUSE, "z");
    let part = Part::Plane {
        command: key,
        edge: 1,
    };
    m.provenance(&part).unwrap();
    let probed = m.growths();
    // Every number once forward and, for the sources, once back.
    assert!(probed >= m.candidates().len(), "{probed}");
    let s = solved(m.drag(&part, &Target::Plane { at: 2.5 }).unwrap());
    let trials = m.growths() - probed;
    // Only the trials of the refined numbers are grown, no probe again.
    assert!(
        trials < m.candidates().len(),
        "{trials} growths for the drag"
    );
    assert!(s.residual <= 1e-3);
}

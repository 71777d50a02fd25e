//! Seed 004's examples (Merz et al., "Procedural Modeling by Sketching")
//! rebuilt as grm grammars: a vase whose belly is sketched wider, and a
//! building whose height, and with it its number of floors and windows,
//! follows one sketched parameter. t = 0 grows the original model bit for
//! bit; t = 1 (and every keyframe) grows the sketched pose within 1e-3.

use grm_manip::{Keyframe, Manip, Part, Setup, Target};
use grm_sema::FsLoader;
use grm_shape::NodeKind;
use std::path::PathBuf;

fn example(name: &str) -> (String, String) {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples")
        .join(name);
    let p = grm_sema::normalize(&std::fs::canonicalize(p).expect("example"));
    let text = std::fs::read_to_string(&p).expect("read");
    (p.to_string_lossy().into_owned(), text)
}

fn setup(path: &str, params: &[String]) -> Setup {
    Setup {
        params: params.to_vec(),
        ..Setup::new(path, std::sync::Arc::new(FsLoader))
    }
}

#[test]
fn the_vase_belly_becomes_a_slider() {
    let (path, text) = example("vase.grm");
    let (_, checked) = grm_sema::check_text(&path, &text);
    let p = &checked.program;
    let c = grm_compile::compile(p, &p.systems[0], &[]).unwrap();
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
        .unwrap()
        .derive(&opts, &mut |_| {})
        .unwrap();
    let it = grm_turtle::interpret(&p.systems[0], &c.settings, &g.string).unwrap();
    // The belly: the widest segment.
    let belly = it
        .bones
        .iter()
        .max_by(|a, b| a.width_base.total_cmp(&b.width_base))
        .unwrap();
    assert!((belly.width_base - 2.4).abs() < 1e-5);
    let part = Part::Bone {
        key: g.string.key(belly.module as usize).unwrap(),
    };
    let m = Manip::new(setup(&path, &[]), &text).unwrap();
    let keys = [
        Keyframe {
            t: 0.5,
            target: Target::Width { width: 3.0 },
        },
        Keyframe {
            t: 1.0,
            target: Target::Width { width: 3.4 },
        },
    ];
    let s = m.sketch(&part, &keys, "belly").unwrap();
    assert!(s.exact_at_zero, "{s:?}");
    for (t, r) in &s.residuals {
        assert!(*r <= 1e-3, "t = {t}: {r}");
    }
    assert!(
        s.text.contains(
            "!((if belly < 0.5 then mix(2.4, 3, belly / 0.5) else mix(3.4, 3, (1 - belly) / 0.5)))"
        ),
        "{}",
        s.text
    );
}

#[test]
fn the_townhouse_height_and_its_floors_follow_one_sketched_parameter() {
    let (path, text) = example("townhouse.grm");
    let (_, checked) = grm_sema::check_text(&path, &text);
    let p = &checked.program;
    let values = grm_compile::param_values(p, &[]).unwrap();
    let g =
        grm_grow::shape::grow(p, &p.systems[0], &values, &Default::default(), None, None).unwrap();
    let block = g
        .tree
        .nodes()
        .iter()
        .find(|n| {
            matches!(n.kind, NodeKind::Shape { symbol, .. } if g.lowered.program.symbol_name(symbol) == "Block")
        })
        .unwrap();
    assert!((block.scope.size.z - 13.6).abs() < 1e-4);
    let part = Part::Shape { key: block.key };
    let m = Manip::new(setup(&path, &[]), &text).unwrap();
    let s = m
        .sketch(
            &part,
            &[Keyframe {
                t: 1.0,
                target: Target::Size {
                    axis: 2,
                    size: 20.0,
                },
            }],
            "height",
        )
        .unwrap();
    assert!(s.exact_at_zero, "{s:?}");
    assert!(s.residuals[0].1 <= 1e-3, "{s:?}");
    // More floors, so more windows, at t = 1.
    let windows = |t: f64| {
        let (_, checked) = grm_sema::check_text(&path, &s.text);
        assert!(!checked.has_errors(), "{:?}", checked.diagnostics);
        let p = &checked.program;
        let values = grm_compile::param_values(p, &[format!("height={t}")]).unwrap();
        let g = grm_grow::shape::grow(p, &p.systems[0], &values, &Default::default(), None, None)
            .unwrap();
        g.tree
            .nodes()
            .iter()
            .filter(|n| {
                matches!(n.kind, NodeKind::Shape { symbol, .. } if g.lowered.program.symbol_name(symbol) == "Window")
            })
            .count()
    };
    let (w0, w1) = (windows(0.0), windows(1.0));
    assert!(w1 > w0, "{w0} windows at t = 0, {w1} at t = 1");
}

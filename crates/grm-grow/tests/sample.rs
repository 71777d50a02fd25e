//! Sample mode through grm-grow (`grm_grow::sample`): the Calder tree of
//! examples/ sampled with its curves, the model shown (the result or a
//! generation's frame), its derivation tree keyed by the run's root key,
//! and the sampler's limits and cancellation coming back as its errors.

mod common;
use common::*;

use grm_grow::TreeMode;
use grm_grow::sample::{SampleRequest, Sampled, Shown, sample};
use grm_sample::{CancelToken, SampleError, SampleOptions, Schedule};

/// A short search: 6 generations, 12 -> 6 particles.
fn short(seed: u32) -> SampleOptions {
    SampleOptions {
        seed,
        schedule: Schedule {
            generations: 6,
            particles_start: 12,
            particles_end: 6,
            heuristic_scale: 0.013,
            heuristic_until: 3,
        },
        ..SampleOptions::default()
    }
}

fn curves() -> grm_guide::Curves {
    grm_guide::Curves::load(example_path("calder_tree.curves.json")).expect("curves")
}

fn run(checked: &grm_sema::Checked, request: &SampleRequest<'_>) -> Sampled {
    let c = compile(checked);
    sample(system(checked), &c, request).expect("samples")
}

#[test]
fn the_result_is_shown_with_its_tree() {
    let checked = checked("calder_tree.grm");
    let c = compile(&checked);
    let curves = curves();
    let request = SampleRequest {
        tree: true,
        ..SampleRequest::new(&curves, short(7))
    };
    let s = run(&checked, &request);
    assert_eq!(s.result.generations.len(), 6);
    let Shown::Models(models) = s.shown() else {
        panic!("the result is shown: {:?}", s.shown());
    };
    assert_eq!(models.len(), 1);
    let m = &models[0];
    assert!(m.interpretation.bones.len() > 1, "a tree grew");
    // The tree is the shown model's, keyed by the run's root key.
    let tree = s.tree.as_ref().expect("a tree was asked for");
    assert_eq!(tree.mode, TreeMode::Sample);
    assert_eq!((s.seed, s.root_key), (7, c.root_key(7)));
    assert_eq!(tree.root_key, c.root_key(7));
    assert_eq!(tree.nodes[0].key, tree.root_key);
    assert_eq!(tree, &s.tree_of(m));
    // Every module of the string is its expansion's, and carries a key.
    assert_eq!(m.string.keys().len(), m.string.len());
    for k in 0..m.string.len() as u32 {
        let n = tree.node_of_module(k).expect("an owner");
        assert!(tree.nodes[n as usize].modules.contains(&k), "module {k}");
        assert_eq!(tree.ancestry(n).first(), Some(&0));
    }
    // The same seed, the same model (no budget: deterministic); another
    // seed, another model.
    let again = run(&checked, &request);
    let a = again.shown().models()[0].string.clone();
    assert_eq!(a.into_parts(), m.string.clone().into_parts());
    let other = run(&checked, &SampleRequest::new(&curves, short(8)));
    assert!(other.tree.is_none(), "no tree asked for");
    assert_ne!(other.shown().models()[0].string.keys(), m.string.keys());
}

#[test]
fn a_generation_shows_its_frame() {
    let checked = checked("calder_tree.grm");
    let curves = curves();
    for (asked, shown) in [(2, 2), (99, 5)] {
        let request = SampleRequest {
            generation: Some(asked),
            tree: true,
            ..SampleRequest::new(&curves, short(7))
        };
        let s = run(&checked, &request);
        match s.shown() {
            Shown::Frame(g, m) => {
                assert_eq!(g, shown, "asked {asked}");
                let tree = s.tree.as_ref().expect("the frame's tree");
                assert_eq!(tree, &s.tree_of(m));
                assert_eq!(s.shown().models().len(), 1);
            }
            other => panic!("asked {asked}: {other:?}"),
        }
    }
    // Past the end the frame is the result's model.
    let full = run(&checked, &SampleRequest::new(&curves, short(7)));
    let last = run(
        &checked,
        &SampleRequest {
            generation: Some(99),
            ..SampleRequest::new(&curves, short(7))
        },
    );
    assert_eq!(
        full.shown().models()[0].string.keys(),
        last.shown().models()[0].string.keys()
    );
}

#[test]
fn limits_and_cancellation_are_the_samplers_errors() {
    let checked = checked("calder_tree.grm");
    let c = compile(&checked);
    let curves = curves();
    // Cancelled before it starts: stops at its first check.
    let token = CancelToken::new();
    token.cancel();
    let request = SampleRequest::new(
        &curves,
        SampleOptions {
            cancel: Some(token),
            ..short(1)
        },
    );
    assert!(matches!(
        sample(system(&checked), &c, &request),
        Err(SampleError::Cancelled)
    ));
    // A search held to 1 KiB stops after its first generation (R0310).
    let request = SampleRequest::new(
        &curves,
        SampleOptions {
            max_bytes: 1024,
            ..short(1)
        },
    );
    match sample(system(&checked), &c, &request) {
        Err(SampleError::MemoryLimit { generations, .. }) => assert!(!generations.is_empty()),
        other => panic!("{other:?}"),
    }
    // A derive-mode system is not sampled.
    let plant = common::checked("ternary_tree.grm");
    let pc = compile(&plant);
    assert!(matches!(
        sample(system(&plant), &pc, &SampleRequest::new(&curves, short(1))),
        Err(SampleError::NotSampleSystem { .. })
    ));
}

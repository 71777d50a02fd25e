//! `SampleOptions::frames`: a model per generation, what the search would
//! return had it stopped there; the search itself is the same with or
//! without them.

mod common;

use common::*;
use grm_sample::*;

fn small() -> Schedule {
    Schedule {
        generations: 30,
        particles_start: 30,
        particles_end: 10,
        heuristic_scale: 0.013,
        heuristic_until: 12,
    }
}

#[test]
fn a_frame_per_generation_and_the_last_is_the_result() {
    let p = example("calder_tree.grm");
    let c = compile(&p, 0);
    let curves = calder_curves();
    let s = curves_sampler(&p, &c, &curves);
    let run = |frames: bool, threads: usize| {
        s.sample(&SampleOptions {
            seed: 3,
            schedule: small(),
            threads,
            frames,
            ..SampleOptions::default()
        })
        .expect("samples")
    };
    let plain = run(false, 1);
    assert!(plain.frames.is_empty());
    let framed = run(true, 1);
    assert_eq!(framed.frames.len(), 30);
    assert_eq!(framed.frames.len(), framed.generations.len());

    // The search is untouched: the same models, candidates and weights.
    let best = framed.best().expect("a model");
    let plain_best = plain.best().expect("a model");
    assert_eq!(best.string, plain_best.string);
    assert_eq!(best.bone_list(), plain_best.bone_list());
    assert_eq!(framed.candidates, plain.candidates);
    assert_eq!(framed.ess(), plain.ess());

    // The last frame is the returned model.
    let last = framed.frames.last().expect("frames");
    assert_eq!(last.string, best.string);
    assert_eq!(last.objective, best.objective);

    // Every frame is a complete model (wrapped up: it builds), and the
    // search moves: the early frames differ from the last; a frame's
    // objective is what its bones cost.
    for (g, f) in framed.frames.iter().enumerate() {
        let m = f.build(&p, &grm_geom::BuildOptions::default());
        assert!(m.is_ok(), "frame {g}: {:?}", m.err());
        assert!(f.objective.is_finite(), "frame {g}");
        assert!(f.skeleton_bones > 0, "frame {g}");
    }
    assert_ne!(framed.frames[0].bone_list(), best.bone_list());
    let bones: Vec<u32> = framed.frames.iter().map(|f| f.skeleton_bones).collect();
    assert!(
        bones.first() < bones.last(),
        "the tree grows along the curves: {bones:?}"
    );

    // The same frames with any number of threads.
    let threaded = run(true, 3);
    assert_eq!(threaded.frames.len(), framed.frames.len());
    for (a, b) in framed.frames.iter().zip(&threaded.frames) {
        assert_eq!(a.string, b.string);
        assert_eq!(a.bone_list(), b.bone_list());
    }
}

#[test]
fn a_search_stopped_by_its_budget_has_a_frame_per_generation_run() {
    let p = example("calder_tree.grm");
    let c = compile(&p, 0);
    let curves = calder_curves();
    let s = curves_sampler(&p, &c, &curves);
    let r = s
        .sample(&SampleOptions {
            seed: 1,
            schedule: small(),
            budget: Some(std::time::Duration::ZERO),
            frames: true,
            ..SampleOptions::default()
        })
        .expect("samples");
    assert!(r.stopped_early);
    assert_eq!(r.generations.len(), 1);
    assert_eq!(r.frames.len(), 1);
    assert_eq!(r.frames[0].string, r.best().expect("a model").string);
}

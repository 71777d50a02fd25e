//! `SampleOptions::frames` and `Sampler::sample_frame`: a model per
//! generation, exactly what the run returns when its budget stops it
//! there; the search itself is the same with or without them, a frame
//! that cannot be finished does not stop it, and the frames kept count
//! towards the memory bound.

mod common;

use std::time::{Duration, Instant};

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

/// A schedule whose first generations are the same whatever its length:
/// a constant particle count and a heuristic ramp that ends at a fixed
/// generation (a ramped schedule spreads its ramps over its length).
fn prefix(generations: u32) -> Schedule {
    Schedule {
        generations,
        particles_start: 12,
        particles_end: 12,
        heuristic_scale: 0.013,
        heuristic_until: 4,
    }
}

/// `Sampler::sample`, or `Sampler::sample_frame` of `frame`.
fn sample(
    s: &Sampler,
    opts: &SampleOptions,
    frame: Option<u32>,
) -> Result<SampleResult, SampleError> {
    match frame {
        Some(k) => s.sample_frame(opts, k),
        None => s.sample(opts),
    }
}

/// The frame's model (the test fails on a frame that could not be made).
fn model(f: &(u32, Result<SampledModel, SampleError>)) -> &SampledModel {
    match &f.1 {
        Ok(m) => m,
        Err(e) => panic!("frame {}: {e}", f.0),
    }
}

/// The same model: string, tree, bones, costs and candidate.
fn assert_same(a: &SampledModel, b: &SampledModel, what: &str) {
    assert_eq!(a.string, b.string, "{what}");
    assert_eq!(a.tree, b.tree, "{what}");
    assert_eq!(a.bone_list(), b.bone_list(), "{what}");
    assert_eq!(a.cost, b.cost, "{what}");
    assert_eq!(a.objective.to_bits(), b.objective.to_bits(), "{what}");
    assert_eq!(a.candidate, b.candidate, "{what}");
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
    assert!(plain.frame(0).is_none());
    let framed = run(true, 1);
    assert_eq!(framed.frames.len(), 30);
    assert_eq!(framed.frames.len(), framed.generations.len());
    for (g, f) in framed.frames.iter().enumerate() {
        assert_eq!(f.0, g as u32);
    }

    // The search is untouched: the same models, candidates and weights.
    let best = framed.best().expect("a model");
    let plain_best = plain.best().expect("a model");
    assert_same(best, plain_best, "the result");
    assert_eq!(framed.candidates, plain.candidates);
    assert_eq!(framed.ess(), plain.ess());

    // The last frame is the returned model.
    let last = model(framed.frames.last().expect("frames"));
    assert_same(last, best, "the last frame");

    // Every frame is a complete model (wrapped up: it builds), and the
    // search moves: the early frames differ from the last.
    for f in &framed.frames {
        let m = model(f);
        let built = m.build(&p, &grm_geom::BuildOptions::default());
        assert!(built.is_ok(), "frame {}: {:?}", f.0, built.err());
        assert!(m.objective.is_finite(), "frame {}", f.0);
        assert!(m.skeleton_bones > 0, "frame {}", f.0);
    }
    assert_ne!(model(&framed.frames[0]).bone_list(), best.bone_list());
    let bones: Vec<u32> = framed
        .frames
        .iter()
        .map(|f| model(f).skeleton_bones)
        .collect();
    assert!(
        bones.first() < bones.last(),
        "the tree grows along the curves: {bones:?}"
    );

    // The same frames with any number of threads.
    let threaded = run(true, 3);
    assert_eq!(threaded.frames.len(), framed.frames.len());
    for (a, b) in framed.frames.iter().zip(&threaded.frames) {
        assert_same(model(a), model(b), &format!("frame {}, 3 threads", a.0));
    }
}

/// The claim the frames make, exactly: frame K is the model the run
/// returns when it stops after generation K. A run of K + 1 generations
/// stops there too, and with a schedule that is the same over its first
/// K + 1 generations whatever its length, it returns frame K: whatever
/// the objective, candidates, temperature, heuristic, `best` or threads.
/// (The frame of the generation's best particle before wrap-up, wrapped
/// up with the first candidate's draws, is another model.)
#[test]
fn frame_k_is_the_result_of_the_run_stopped_after_generation_k() {
    let p = example("calder_tree.grm");
    let c = compile(&p, 0);
    let curves = calder_curves();
    let curve_sampler = curves_sampler(&p, &c, &curves);
    let volume_sampler = Sampler::new(
        &p.systems[0],
        &c,
        &curves,
        Objective::Volume {
            options: grm_guide::VolumeOptions::default(),
            weight: 2000.0,
        },
        ExpectedOptions::default(),
    )
    .expect("sampler");
    let base = SampleOptions {
        seed: 5,
        // The reach look-ahead's cap by the generations left is the one
        // part of the search that depends on the run's length.
        reach: Reach {
            budget: false,
            ..Reach::default()
        },
        // So are refinement rounds, run when a run ends (a frame is the
        // model of the run stopped there by its budget, which runs none).
        refine: Refine::off(),
        ..SampleOptions::default()
    };
    let cases: Vec<(&str, &Sampler, SampleOptions)> = vec![
        ("defaults", &curve_sampler, base.clone()),
        (
            "one candidate, untempered",
            &curve_sampler,
            SampleOptions {
                candidates: 1,
                ess_target: 0.0,
                ..base.clone()
            },
        ),
        (
            "infinite temperature",
            &curve_sampler,
            SampleOptions {
                temperature: f64::INFINITY,
                ..base.clone()
            },
        ),
        (
            "no heuristic",
            &curve_sampler,
            SampleOptions {
                heuristic: false,
                ..base.clone()
            },
        ),
        (
            "best 2, 3 threads",
            &curve_sampler,
            SampleOptions {
                best: 2,
                threads: 3,
                ..base.clone()
            },
        ),
        (
            "volume",
            &volume_sampler,
            SampleOptions {
                heuristic: false,
                ..base.clone()
            },
        ),
    ];
    for (what, s, opts) in cases {
        let framed = s
            .sample(&SampleOptions {
                schedule: prefix(8),
                frames: true,
                ..opts.clone()
            })
            .expect("samples");
        assert_eq!(framed.frames.len(), 8, "{what}");
        for k in 0..8u32 {
            let stopped = s
                .sample(&SampleOptions {
                    schedule: prefix(k + 1),
                    ..opts.clone()
                })
                .expect("samples");
            assert_same(
                model(&framed.frames[k as usize]),
                stopped.best().expect("a model"),
                &format!("{what}: frame {k}"),
            );
        }
    }
}

#[test]
fn a_search_stopped_by_its_budget_has_a_frame_per_generation_run() {
    let p = example("calder_tree.grm");
    let c = compile(&p, 0);
    let curves = calder_curves();
    let s = curves_sampler(&p, &c, &curves);
    let opts = SampleOptions {
        seed: 1,
        schedule: small(),
        ..SampleOptions::default()
    };
    let stopped = |frames: bool, frame: Option<u32>| {
        let o = SampleOptions {
            budget: Some(Duration::ZERO),
            frames,
            ..opts.clone()
        };
        sample(&s, &o, frame).expect("samples")
    };
    let r = stopped(true, None);
    assert!(r.stopped_early);
    assert_eq!(r.generations.len(), 1);
    assert_eq!(r.frames.len(), 1);
    let best = r.best().expect("a model");
    assert_same(model(&r.frames[0]), best, "the only frame");
    // A frame asked for past where the budget stopped: the result.
    let one = stopped(false, Some(20));
    assert_eq!(one.frames.len(), 1);
    let (g, f) = one.frame(20).expect("kept");
    assert_eq!(g, 0);
    assert_same(f.as_ref().expect("a model"), best, "frame 20 of 1");
    // And this is what the unstopped run's frame 0 is, though its
    // schedule ramps over 30 generations.
    let full = s
        .sample(&SampleOptions {
            frames: true,
            ..opts.clone()
        })
        .expect("samples");
    assert_same(model(&full.frames[0]), best, "frame 0 of the full run");
}

/// `Sampler::sample_frame(K)` keeps frame K alone (the cost of one frame, not one per
/// generation), the same model as among all of them; past the last
/// generation, the result; the search unchanged.
#[test]
fn one_frame_alone_is_the_same_as_among_all() {
    let p = example("calder_tree.grm");
    let c = compile(&p, 0);
    let curves = calder_curves();
    let s = curves_sampler(&p, &c, &curves);
    let run = |frames: bool, frame: Option<u32>| {
        let o = SampleOptions {
            seed: 7,
            schedule: small(),
            frames,
            ..SampleOptions::default()
        };
        sample(&s, &o, frame).expect("samples")
    };
    let all = run(true, None);
    for k in [0u32, 13, 28, 29, 30, u32::MAX] {
        let one = run(false, Some(k));
        assert_eq!(one.frames.len(), 1, "frame {k}");
        let (g, f) = one.frame(k).expect("kept");
        assert_eq!(g, k.min(29));
        let (ga, fa) = all.frame(k).expect("kept");
        assert_eq!(ga, g);
        assert_same(
            f.as_ref().expect("a model"),
            fa.as_ref().expect("a model"),
            &format!("frame {k}"),
        );
        assert_same(
            one.best().expect("a model"),
            all.best().expect("a model"),
            &format!("the result with frame {k}"),
        );
        assert_eq!(one.candidates, all.candidates);
        // Asked for another generation: not kept.
        if g != 5 {
            assert!(one.frame(5).is_none());
        }
    }
    // With `frames` every frame is kept anyway.
    assert_eq!(run(true, Some(3)).frames.len(), 30);
}

/// A sample system whose early generations' particles cannot be wrapped
/// up (the frames tests' shared fixture; its schedule is the test's).
const SHOOT: &str = include_str!("../../../tests/lsp/shoot.grm");

/// A frame that cannot be finished is that frame's error, not the run's:
/// the run with frames returns what the run without them returns.
#[test]
fn a_frame_that_cannot_be_finished_does_not_stop_the_search() {
    let p = program("shoot.grm", SHOOT);
    let c = compile(&p, 0);
    let curves = calder_curves();
    let s = curves_sampler(&p, &c, &curves);
    let opts = SampleOptions {
        schedule: prefix(8),
        ..SampleOptions::default()
    };
    let plain = s.sample(&opts).expect("the run finishes");
    for (frames, frame) in [(true, None), (false, Some(0))] {
        let o = SampleOptions {
            frames,
            ..opts.clone()
        };
        let framed = sample(&s, &o, frame).expect("frames do not fail the run");
        assert_same(
            framed.best().expect("a model"),
            plain.best().expect("a model"),
            "the result",
        );
        let (g, f) = framed.frame(0).expect("kept");
        assert_eq!(g, 0);
        let e = f.as_ref().expect_err("frame 0 cannot be wrapped up");
        assert_eq!(e.code(), grm_diag::Code::SampleNonFinite, "{e}");
        assert!(e.to_string().contains("wrap-up"), "{e}");
        // A search stopped there fails the same way.
        let stopped = s
            .sample(&SampleOptions {
                budget: Some(Duration::ZERO),
                ..opts.clone()
            })
            .expect_err("stopped after generation 0");
        // (The errors carry a NaN: compare what they say.)
        assert_eq!(stopped.code(), e.code());
        assert_eq!(stopped.to_string(), e.to_string());
        assert_eq!(stopped.location(), e.location());
    }
    let all = s
        .sample(&SampleOptions {
            frames: true,
            ..opts.clone()
        })
        .expect("samples");
    let ok: Vec<bool> = all.frames.iter().map(|f| f.1.is_ok()).collect();
    assert_eq!(
        ok,
        [false, false, true, true, true, true, true, true],
        "grow(1) and grow(2) cannot be wrapped up, grow(3) on can"
    );
}

/// The frames kept are models the run holds: with a frame per generation
/// the memory figure grows by them, and `max_bytes` bounds them with the
/// search (a long run's frames are as many models).
#[test]
fn the_frames_kept_count_towards_the_memory_bound() {
    let p = example("calder_tree.grm");
    let c = compile(&p, 0);
    let curves = calder_curves();
    let s = curves_sampler(&p, &c, &curves);
    let run = |frames: bool, max_bytes: u64| {
        s.sample(&SampleOptions {
            seed: 2,
            schedule: small(),
            frames,
            max_bytes,
            ..SampleOptions::default()
        })
    };
    let plain = run(false, DEFAULT_MAX_BYTES).expect("samples");
    let framed = run(true, DEFAULT_MAX_BYTES).expect("samples");
    let mut kept = 0u64;
    for (g, (a, b)) in plain
        .generations
        .iter()
        .zip(&framed.generations)
        .enumerate()
    {
        if g + 1 < framed.frames.len() {
            kept += model(&framed.frames[g]).heap_bytes() as u64;
        }
        assert_eq!(b.memory_bytes, a.memory_bytes + kept, "generation {g}");
    }
    assert!(kept > 0);
    // A bound the search alone stays within, but not with its frames.
    let peak = plain
        .generations
        .iter()
        .map(|g| g.memory_bytes)
        .max()
        .expect("generations");
    assert!(run(false, peak).is_ok());
    let e = run(true, peak).expect_err("over the bound with the frames");
    assert!(matches!(e, SampleError::MemoryLimit { .. }), "{e:?}");
    // One frame asked for: one model kept.
    let one = s
        .sample_frame(
            &SampleOptions {
                seed: 2,
                schedule: small(),
                ..SampleOptions::default()
            },
            3,
        )
        .expect("samples");
    let f = model(&one.frames[0]).heap_bytes() as u64;
    assert_eq!(
        one.generations[10].memory_bytes,
        plain.generations[10].memory_bytes + f
    );
}

/// A sample system whose search is cheap and whose frames are not: every
/// wrap-up grows a bush of 2^(n+1) - 1 geometry expansions.
fn bushes(n: u32) -> String {
    format!(
        r#"
system Bushes {{
    mode = sample;
    axiom grow(0);
    skeleton grow;
    geometry bush;
    grow(k) -> F(1) grow(k + 1);
    wrapup grow(k) -> bush({n});
    bush(n) : n > 0 -> bush(n - 1) bush(n - 1);
    bush(n) : n <= 0 -> sphere(0.01);
}}
"#
    )
}

/// The budget bounds the search, not the frames: frames that take longer
/// than the budget do not stop the search sooner.
#[test]
fn frames_do_not_spend_the_search_budget() {
    let p = program("bushes.grm", &bushes(14));
    let c = compile(&p, 0);
    let curves = calder_curves();
    let s = curves_sampler(&p, &c, &curves);
    let schedule = Schedule {
        generations: 6,
        particles_start: 2,
        particles_end: 2,
        heuristic_scale: 0.0,
        heuristic_until: 0,
    };
    // How long one frame takes here (a wrap-up and a geometry phase).
    let t = Instant::now();
    let one = s
        .sample(&SampleOptions {
            schedule: Schedule {
                generations: 1,
                ..schedule
            },
            ..SampleOptions::default()
        })
        .expect("samples");
    let frame = t.elapsed();
    assert!(one.best().expect("a model").interpretation.instances.len() > 10_000);
    // A budget the search needs a fraction of, and that 5 frames exceed.
    let budget = frame * 2;
    let r = s
        .sample(&SampleOptions {
            schedule,
            budget: Some(budget),
            frames: true,
            ..SampleOptions::default()
        })
        .expect("samples");
    assert!(
        !r.stopped_early,
        "stopped after {} generations (a frame takes {frame:?}, the budget is {budget:?})",
        r.generations.len()
    );
    assert_eq!(r.frames.len(), 6);
    assert!(r.frames.iter().all(|f| f.1.is_ok()));
}

/// A cancellation while a frame is being finished stops the run (it is
/// not that frame's error).
#[test]
fn a_token_set_during_a_frame_stops_the_run() {
    // 2^23 geometry expansions a frame: seconds, unless cancelled.
    let p = program("bushes.grm", &bushes(22));
    let c = compile(&p, 0);
    let curves = calder_curves();
    let s = curves_sampler(&p, &c, &curves);
    let token = CancelToken::new();
    let setter = {
        let t = token.clone();
        std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(150));
            t.cancel();
        })
    };
    let t0 = Instant::now();
    let opts = SampleOptions {
        schedule: prefix(3),
        limits: FinishLimits {
            max_depth: 64,
            max_expansions: 1 << 30,
        },
        cancel: Some(token),
        ..SampleOptions::default()
    };
    let r = s.sample_frame(&opts, 0);
    setter.join().expect("setter");
    assert_eq!(r.err(), Some(SampleError::Cancelled));
    assert!(
        t0.elapsed() < Duration::from_secs(5),
        "stopped after {:?}",
        t0.elapsed()
    );
}

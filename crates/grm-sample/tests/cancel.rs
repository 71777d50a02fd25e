//! Cooperative cancellation (`SampleOptions::cancel`): a token set before or
//! during a run stops it with `SampleError::Cancelled` (in the search and in
//! the geometry phase), and a token that is never set changes nothing.

mod common;

use std::time::{Duration, Instant};

use common::*;
use grm_sample::*;

fn calder_sampler_parts() -> (grm_sema::Program, grm_compile::CompiledSystem) {
    let p = example("calder_tree.grm");
    let c = compile(&p, 0);
    (p, c)
}

fn small() -> Schedule {
    Schedule {
        generations: 30,
        particles_start: 30,
        particles_end: 10,
        heuristic_scale: 0.013,
        heuristic_until: 12,
    }
}

/// Set `token` after `delay`, from another thread.
fn cancel_after(token: &CancelToken, delay: Duration) -> std::thread::JoinHandle<()> {
    let t = token.clone();
    std::thread::spawn(move || {
        std::thread::sleep(delay);
        t.cancel();
    })
}

#[test]
fn a_token_set_before_the_run_stops_it() {
    let (p, c) = calder_sampler_parts();
    let curves = calder_curves();
    let s = curves_sampler(&p, &c, &curves);
    let token = CancelToken::new();
    token.cancel();
    for threads in [1, 2] {
        let e = s
            .sample(&SampleOptions {
                schedule: small(),
                threads,
                cancel: Some(token.clone()),
                ..SampleOptions::default()
            })
            .expect_err("cancelled");
        assert_eq!(e, SampleError::Cancelled, "{threads} threads");
        assert_eq!(e.code(), grm_diag::Code::SampleCancelled);
        assert_eq!(e.to_string(), "sampling was cancelled");
    }
}

#[test]
fn a_token_set_while_searching_stops_the_run() {
    let (p, c) = calder_sampler_parts();
    let curves = calder_curves();
    let s = curves_sampler(&p, &c, &curves);
    // A million generations of 100 particles: hours, unless cancelled.
    let endless = Schedule {
        generations: grm_sema::MAX_GENERATIONS,
        particles_start: 100,
        particles_end: 100,
        ..Schedule::calder_playground()
    };
    for threads in [1, 2] {
        let token = CancelToken::new();
        // Before the setter starts its wait, so that the token cannot be
        // set less than 150 ms after it (under load the setter thread may
        // start sleeping before the sampler does).
        let t0 = Instant::now();
        let setter = cancel_after(&token, Duration::from_millis(150));
        let r = s.sample(&SampleOptions {
            schedule: endless,
            threads,
            cancel: Some(token.clone()),
            ..SampleOptions::default()
        });
        let took = t0.elapsed();
        setter.join().expect("setter");
        assert!(
            matches!(r, Err(SampleError::Cancelled)),
            "{threads} threads: {:?}",
            r.map(|r| r.generations.len())
        );
        assert!(
            took >= Duration::from_millis(150),
            "stopped before the token was set: {took:?}"
        );
        assert!(
            took < Duration::from_secs(30),
            "{threads} threads: took {took:?} to notice"
        );
    }
}

#[test]
fn a_token_set_during_the_geometry_phase_stops_it() {
    // `Deep` doubles 40 levels deep: 2^40 geometry expansions, more than
    // the limit below; the skeleton phase is one generation of 2.
    let src = r#"
system Bushy {
    mode = sample;
    axiom A;
    skeleton A;
    geometry Deep;
    A -> F(1) Deep(0);
    wrapup A -> ;
    Deep(n) : n < 0 -> ;
    Deep(n) : n < 40 -> sphere(0.1) Deep(n + 1) Deep(n + 1);
}
"#;
    let p = program("bushy.grm", src);
    let c = compile(&p, 0);
    let curves = calder_curves();
    let s = curves_sampler(&p, &c, &curves);
    let opts = SampleOptions {
        schedule: Schedule {
            generations: 1,
            particles_start: 2,
            particles_end: 2,
            ..Schedule::calder_playground()
        },
        limits: FinishLimits {
            max_depth: 100,
            // Seconds of expansions (tens of seconds in a debug build).
            max_expansions: 100_000,
        },
        ..SampleOptions::default()
    };
    // Uncancelled, it runs into the expansion limit.
    let e = s
        .sample(&SampleOptions {
            limits: FinishLimits {
                max_depth: 100,
                max_expansions: 20_000,
            },
            ..opts.clone()
        })
        .expect_err("runs away");
    assert!(
        matches!(
            e,
            SampleError::GeometryLimit {
                what: LimitKind::Expansions,
                ..
            }
        ),
        "{e:?}"
    );
    // Cancelled while expanding: stopped long before the limit.
    let token = CancelToken::new();
    let setter = cancel_after(&token, Duration::from_millis(50));
    let e = s
        .sample(&SampleOptions {
            cancel: Some(token),
            ..opts
        })
        .expect_err("cancelled");
    setter.join().expect("setter");
    assert_eq!(e, SampleError::Cancelled);
}

#[test]
fn a_token_that_is_never_set_changes_nothing() {
    let (p, c) = calder_sampler_parts();
    let curves = calder_curves();
    let s = curves_sampler(&p, &c, &curves);
    let glb = |cancel: Option<CancelToken>, threads: usize| {
        let r = s
            .sample(&SampleOptions {
                seed: 3,
                schedule: small(),
                threads,
                cancel,
                ..SampleOptions::default()
            })
            .expect("samples");
        let model = r
            .best()
            .expect("model")
            .build(&p, &grm_geom::BuildOptions::default())
            .expect("builds");
        grm_geom::export::glb_bytes(&model).expect("small")
    };
    let plain = glb(None, 1);
    assert_eq!(glb(Some(CancelToken::new()), 1), plain);
    assert_eq!(glb(Some(CancelToken::new()), 3), plain);
}

//! The memory bound (`SampleOptions::max_bytes`): the figure each
//! generation reports is deterministic, the same for any thread count, and
//! grows with the search; a bound below it stops the run after the first
//! generation past it with `SampleError::MemoryLimit`.

mod common;

use common::*;
use grm_sample::*;

fn schedule() -> Schedule {
    Schedule {
        generations: 30,
        particles_start: 60,
        particles_end: 20,
        heuristic_scale: 0.013,
        heuristic_until: 12,
    }
}

#[test]
fn the_memory_figure_is_deterministic_and_grows() {
    let p = example("calder_tree.grm");
    let c = compile(&p, 0);
    let curves = calder_curves();
    let s = curves_sampler(&p, &c, &curves);
    let run = |threads| {
        s.sample(&SampleOptions {
            schedule: schedule(),
            threads,
            ..SampleOptions::default()
        })
        .expect("samples")
    };
    let one = run(1);
    let figures: Vec<u64> = one.generations.iter().map(|g| g.memory_bytes).collect();
    assert_eq!(figures.len(), 30);
    for threads in [2, 4] {
        let other: Vec<u64> = run(threads)
            .generations
            .iter()
            .map(|g| g.memory_bytes)
            .collect();
        assert_eq!(other, figures, "{threads} threads");
    }
    // Every kept expansion stays: the figure never falls by much (the kept
    // particles' own state shrinks with the schedule) and ends well above
    // where it started.
    assert!(figures[0] > 0);
    assert!(figures[29] > 3 * figures[0], "{figures:?}");
    // The default bound is far above a small run: the model is unchanged.
    // (Without refinement rounds, which hold more than the search's last
    // generation; the population they restart from is counted with it.)
    let pass = SampleOptions {
        schedule: schedule(),
        refine: Refine::off(),
        ..SampleOptions::default()
    };
    let bounded = s
        .sample(&SampleOptions {
            max_bytes: figures[29],
            ..pass.clone()
        })
        .expect("at the bound is within it");
    let unbounded = s.sample(&pass).expect("samples");
    assert_eq!(bounded.models[0].cost, unbounded.models[0].cost);
    // Refinement rounds count towards the bound: this seed's pass leaves
    // a curve, and its rounds grow past the pass's last figure.
    assert!(one.refinements > 0);
    let rounds = s.sample(&SampleOptions {
        schedule: schedule(),
        max_bytes: figures[29],
        ..SampleOptions::default()
    });
    assert!(
        matches!(rounds, Err(SampleError::MemoryLimit { .. })),
        "{rounds:?}"
    );
}

#[test]
fn a_bound_below_the_figure_stops_after_that_generation() {
    let p = example("calder_tree.grm");
    let c = compile(&p, 0);
    let curves = calder_curves();
    let s = curves_sampler(&p, &c, &curves);
    let full = s
        .sample(&SampleOptions {
            schedule: schedule(),
            ..SampleOptions::default()
        })
        .expect("samples");
    let figures: Vec<u64> = full.generations.iter().map(|g| g.memory_bytes).collect();
    let limit = figures[10] - 1;
    // The first generation whose figure passes the bound.
    let first = figures.iter().position(|&b| b > limit).expect("passes") as u32;
    for threads in [1, 3] {
        let e = s
            .sample(&SampleOptions {
                schedule: schedule(),
                max_bytes: limit,
                threads,
                ..SampleOptions::default()
            })
            .expect_err("over the bound");
        let SampleError::MemoryLimit {
            generation,
            bytes,
            limit: l,
            particles,
            ref generations,
        } = e
        else {
            panic!("{e:?}");
        };
        assert_eq!(generation, first, "{threads} threads");
        assert_eq!(bytes, figures[first as usize]);
        assert_eq!(l, limit);
        assert!(particles > 0);
        assert_eq!(generations.len() as u32, first + 1);
        assert_eq!(generations.last().map(|g| g.memory_bytes), Some(bytes));
        assert_eq!(e.code(), grm_diag::Code::SampleMemoryLimit);
        assert!(
            e.to_string()
                .starts_with(&format!("after generation {}, the search holds", first + 1)),
            "{e}"
        );
    }
}

/// A particle whose open symbols can none ever draw a bone or finish
/// (W0015: `b -> +(10) b b;`) stops searching: before, each step expanded
/// `b`s up to the per-step limit, doubling them, until the search ran out
/// of memory (R0310). The bones drawn before `b` took over are kept.
#[test]
fn particles_left_with_symbols_that_never_draw_stop_searching() {
    let p = program(
        "never_draws.grm",
        "system S {
            mode = sample;
            axiom A;
            skeleton A, b;
            A -> (1) F(1) A;
            A -> (1) F(1) b;
            b -> +(10) b b;
            wrapup A -> ;
            wrapup b -> ;
        }",
    );
    let c = compile(&p, 0);
    let curves = calder_curves();
    let s = curves_sampler(&p, &c, &curves);
    let r = s
        .sample(&SampleOptions {
            schedule: schedule(),
            ..SampleOptions::default()
        })
        .expect("samples");
    let last = r.generations.last().expect("generations");
    assert_eq!(last.expanding, 0, "{last:?}");
    assert_eq!(last.expansions, 0, "{last:?}");
    // The whole run expanded about one symbol per bone.
    let expansions: u64 = r.generations.iter().map(|g| g.expansions).sum();
    let bones: f64 = r.generations.iter().map(|g| g.mean_bones).sum();
    assert!(expansions < 20 * 60, "{expansions} expansions");
    assert!(bones > 0.0);
    assert!(last.memory_bytes < 4 << 20, "{} bytes", last.memory_bytes);
    assert!(
        r.models[0].skeleton_bones > 0,
        "the bones drawn before `b` stay"
    );
}

/// Issue 32: a search whose generations add no bones held a 72-byte step
/// per particle per generation and a record per generation that the
/// figure did not count (1.4 GB under a bound of 16 MiB, the figure under
/// 1 MiB). What it holds now is counted, and steps that made nothing are
/// dropped: the figure covers every generation's record, and stays small.
#[test]
fn a_search_whose_generations_add_nothing_counts_what_it_holds() {
    let p = program(
        "nothing.grm",
        "system S {\n    mode = sample;\n    axiom b;\n    skeleton b;\n    b -> F(1);\n    wrapup b -> ;\n}\n",
    );
    let c = compile(&p, 0);
    let curves = calder_curves();
    let s = curves_sampler(&p, &c, &curves);
    let gens = 5000u32;
    let r = s
        .sample(&SampleOptions {
            schedule: Schedule {
                generations: gens,
                particles_start: 20,
                particles_end: 20,
                heuristic_scale: 0.013,
                heuristic_until: 0,
            },
            ..SampleOptions::default()
        })
        .expect("samples");
    let last = r.generations.last().expect("generations").memory_bytes;
    let records = u64::from(gens) * std::mem::size_of::<GenerationStats>() as u64;
    assert!(
        last >= records,
        "{last} bytes counted, {records} of records"
    );
    // Not a step per particle per generation (72 bytes each: 7 MB here).
    assert!(last < 4 * records, "{last}");
}

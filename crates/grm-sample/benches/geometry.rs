//! `cargo bench -p grm-sample --bench geometry`: how the geometry phase
//! scales with the number of geometry expansions.
//!
//! A sample-mode system whose one skeleton bone carries a geometry symbol
//! that expands into a binary tree of depth `d` (2^(d+1) - 1 geometry
//! expansions, 2^d bones); the search itself is two generations of two
//! particles, so the time is the wrap-up and the geometry phase. For each
//! depth it prints the best wall time of a few runs, the time per geometry
//! expansion, and the ratio to the previous depth: about 2 when the phase
//! is linear in the expansions (each depth doubles them), about 4 if it
//! were quadratic (it was, until the turtle checked the whole string
//! before interpreting each expansion's few modules).

use std::time::{Duration, Instant};

use grm_sample::{ExpectedOptions, Objective, SampleOptions, Sampler, Schedule};

const CURVES: &str =
    r#"{"version": 1, "curves": [{"name": "t", "points": [[0,0,0],[0,1,0],[0,2,0],[0,3,0]]}]}"#;

fn grammar(depth: u32) -> String {
    format!(
        "system Bush {{
    mode = sample;
    axiom S;
    skeleton S;
    geometry Deco;

    S -> F(1) Deco({depth});
    wrapup S -> ;
    Deco(n) : n > 0 -> F(0.01) [ + Deco(n - 1) ] [ - Deco(n - 1) ];
    Deco(_n) -> ;
}}
"
    )
}

fn main() {
    let curves = grm_guide::Curves::from_json_str("bench", CURVES).expect("curves");
    let runs = 5;
    println!(
        "geometry phase scaling (best of {runs} runs, one thread, {})",
        std::env::consts::ARCH
    );
    println!(
        "{:>5} {:>12} {:>8} {:>10} {:>12} {:>8}",
        "depth", "expansions", "bones", "ms", "ns/expansion", "ratio"
    );
    let mut previous: Option<Duration> = None;
    for depth in 10..=16 {
        let text = grammar(depth);
        let (_, checked) = grm_sema::check_text("bush.grm", &text);
        assert!(!checked.has_errors(), "{:?}", checked.diagnostics);
        let program = &checked.program;
        let system = &program.systems[0];
        let compiled =
            grm_compile::compile(program, system, &program.default_params()).expect("compiles");
        let sampler = Sampler::new(
            system,
            &compiled,
            &curves,
            Objective::Curves,
            ExpectedOptions::default(),
        )
        .expect("sampler");
        let opts = SampleOptions {
            schedule: Schedule {
                generations: 2,
                particles_start: 2,
                particles_end: 2,
                heuristic_scale: 0.0,
                heuristic_until: 0,
            },
            ..SampleOptions::default()
        };
        let mut best = Duration::MAX;
        let mut bones = 0;
        for _ in 0..runs {
            let t = Instant::now();
            let run = sampler.sample(&opts).expect("samples");
            best = best.min(t.elapsed());
            bones = run.best().map_or(0, |m| m.interpretation.bones.len());
        }
        let expansions = (1u64 << (depth + 1)) - 1;
        println!(
            "{depth:>5} {expansions:>12} {bones:>8} {:>10.2} {:>12.0} {:>8}",
            best.as_secs_f64() * 1e3,
            best.as_secs_f64() * 1e9 / expansions as f64,
            previous.map_or("-".to_string(), |p| format!(
                "{:.2}",
                best.as_secs_f64() / p.as_secs_f64()
            )),
        );
        previous = Some(best);
    }
}

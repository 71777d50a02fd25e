//! Edge-case numbers in the shipped examples, all the way down the
//! pipeline: the stable, deterministic stand-in for the `pipeline` fuzz
//! target (`fuzz/`), run with the normal tests.
//!
//! Each mutant is an example (`examples/*.grm`) with one to three of its
//! number literals replaced by an edge value (zero, tiny, huge, past f32,
//! whole numbers past the limits of counts). A mutant that the checker
//! refuses must be refused with diagnostics; one that it accepts is
//! compiled, derived on the CPU (at most 10 iterations, 50,000 modules),
//! interpreted, meshed and drawn as a small picture, or for a sample-mode
//! system grown by the guided sampler with its guiding curves file (a tiny
//! schedule) and its best model drawn. Nothing may panic: every failure
//! comes back as a typed error.

use grm_derive::{DeriveLimits, Engine};
use grm_sample::{ExpectedOptions, FinishLimits, Objective, SampleOptions, Sampler, Schedule};
use grm_sema::Mode;
use grm_syntax::lexer::TokKind;
use grm_tests::Rng;
use std::ops::Range;
use std::path::{Path, PathBuf};

const EDGES: &[&str] = &[
    "0",
    "0.0",
    "1e-30",
    "1e-45",
    "0.5",
    "3",
    "64",
    "1000",
    "100000",
    "4294967296",
    "1e30",
    "3.4e38",
    "1e39",
    "1e300",
    "-1",
    "-0.5",
    "-1e30",
    "0.001",
];

fn examples() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples");
    let mut out: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("examples/")
        .map(|e| e.expect("an entry").path())
        .filter(|p| p.extension().is_some_and(|x| x == "grm"))
        .collect();
    out.sort();
    out
}

/// `text` with up to three of its number literals replaced.
fn mutate(text: &str, r: &mut Rng) -> String {
    let lexed = grm_syntax::lexer::lex(grm_diag::FileId(0), text);
    let numbers: Vec<_> = lexed
        .tokens
        .iter()
        .filter(|t| t.kind == TokKind::Number)
        .map(|t| t.span.start as usize..t.span.end as usize)
        .collect();
    replace_some(text, &numbers, r)
}

/// `text` with one to three of the ranges `numbers` (sorted, disjoint)
/// replaced by edge values.
fn replace_some(text: &str, numbers: &[Range<usize>], r: &mut Rng) -> String {
    let mut picked: Vec<_> = (0..1 + r.below(3))
        .filter_map(|_| numbers.get(r.below(numbers.len())).cloned())
        .collect();
    picked.sort_by_key(|s| s.start);
    picked.dedup();
    let mut out = String::with_capacity(text.len() + 64);
    let mut pos = 0usize;
    for s in picked {
        out.push_str(&text[pos..s.start]);
        out.push_str(EDGES[r.below(EDGES.len())]);
        pos = s.end;
    }
    out.push_str(&text[pos..]);
    out
}

/// What happened to the mutants.
#[derive(Debug, Default)]
struct Tally {
    refused: usize,
    derived: usize,
    sampled: usize,
    failed_typed: usize,
}

fn grow(path: &Path, text: &str, t: &mut Tally) {
    let (_, checked) = grm_sema::check_text(&path.to_string_lossy(), text);
    if checked.has_errors() {
        t.refused += 1;
        return;
    }
    let program = &checked.program;
    let values = program.default_params();
    for sys in &program.systems {
        let compiled = match grm_compile::compile(program, sys, &values) {
            Ok(c) => c,
            Err(_) => {
                t.failed_typed += 1;
                continue;
            }
        };
        let _ = grm_compile::disassemble(&compiled, Some(text));
        if sys.mode == Mode::Sample {
            sample(path, program, sys, &compiled, t);
            continue;
        }
        let limits = DeriveLimits {
            max_modules: 50_000,
            max_bytes: 1 << 24,
        };
        let Ok(engine) = Engine::new(&compiled, 1) else {
            t.failed_typed += 1;
            continue;
        };
        let settings = &compiled.settings;
        let mut s = match engine.axiom(settings.seed) {
            Ok(s) => s,
            Err(_) => {
                t.failed_typed += 1;
                continue;
            }
        };
        let mut ok = true;
        for it in 1..=settings.iterations.min(10) {
            match engine.step(&s, it, settings.seed, &limits) {
                Ok(next) => s = next,
                Err(_) => {
                    ok = false;
                    break;
                }
            }
        }
        if !ok {
            t.failed_typed += 1;
            continue;
        }
        match grm_geom::build_model(program, sys, &s, settings, &compiled.param_values) {
            Ok(model) => {
                picture(&model);
                t.derived += 1;
            }
            Err(_) => t.failed_typed += 1,
        }
    }
}

/// A model built from edge numbers is drawn too (`-o x.png`): small, from
/// the automatic view, from straight above, and through perspective
/// cameras at a corner of its bounds (geometry around and behind the eye:
/// clipping) and far off; it must draw, not panic, whenever the view is
/// one the renderer takes (a camera of non-finite numbers is an error).
fn picture(model: &grm_geom::Model) {
    use grm_geom::render::{DVec3, RenderOptions, View, render};
    let b = model.stats.bounds;
    let (lo, hi) = (b.min.as_dvec3(), b.max.as_dvec3());
    let centre = (lo + hi) * 0.5;
    let cameras = [lo, centre + (hi - lo) * 3.0 + DVec3::ONE].map(|eye| View::Camera {
        eye,
        target: centre,
        fov: 60.0,
    });
    for view in [
        View::Auto,
        View::Angles {
            azimuth: 30.0,
            elevation: 90.0,
        },
    ]
    .into_iter()
    .chain(cameras.into_iter().filter(|v| v.validate().is_ok()))
    {
        let o = RenderOptions {
            width: 24,
            height: 16,
            view,
            samples: 2,
            transparent: false,
        };
        let image = render(model, &o).expect("valid options draw");
        assert_eq!(image.rgba.len(), 24 * 16 * 4);
    }
}

fn sample(
    path: &Path,
    program: &grm_sema::Program,
    sys: &grm_sema::System,
    compiled: &grm_compile::CompiledSystem,
    t: &mut Tally,
) {
    let curves_path = path.with_extension("curves.json");
    let Ok(text) = std::fs::read_to_string(&curves_path) else {
        return;
    };
    let curves = grm_guide::Curves::from_json_str(&curves_path.to_string_lossy(), &text)
        .expect("the shipped curves file reads");
    let sampler = match Sampler::new(
        sys,
        compiled,
        &curves,
        Objective::Curves,
        ExpectedOptions::default(),
    ) {
        Ok(s) => s,
        Err(_) => {
            t.failed_typed += 1;
            return;
        }
    };
    let mut schedule = Schedule::from_settings(&compiled.settings).with_generations(4);
    schedule.particles_start = 4;
    schedule.particles_end = 2;
    let opts = SampleOptions {
        seed: compiled.settings.seed,
        schedule,
        threads: 1,
        candidates: 2,
        max_expansions_per_step: 200,
        limits: FinishLimits {
            max_depth: 64,
            max_expansions: 20_000,
        },
        ..SampleOptions::default()
    };
    match sampler.sample(&opts) {
        Ok(run) => {
            if let Some(best) = run.best()
                && let Ok(model) = best.build(program, &grm_geom::BuildOptions::default())
            {
                picture(&model);
            }
            t.sampled += 1;
        }
        Err(_) => t.failed_typed += 1,
    }
}

#[test]
fn edge_numbers_in_the_examples_never_panic() {
    let files = examples();
    assert!(files.len() >= 10, "{files:?}");
    let mut r = Rng::seeded(0x005e_ed0f_ed9e);
    let mut t = Tally::default();
    for path in &files {
        let text = std::fs::read_to_string(path).expect("an example");
        for _ in 0..40 {
            let m = mutate(&text, &mut r);
            grow(path, &m, &mut t);
        }
    }
    eprintln!("{t:?}");
    // The mutants must reach every stage, or the test tests nothing.
    assert!(t.derived >= 20, "{t:?}");
    assert!(t.sampled >= 3, "{t:?}");
    assert!(t.refused >= 5, "{t:?}");
}

/// `json` with up to three of its numbers replaced.
fn mutate_json(json: &str, r: &mut Rng) -> String {
    let b = json.as_bytes();
    let mut numbers = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let starts = (b[i].is_ascii_digit() || b[i] == b'-')
            && (i == 0 || !(b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'.'));
        if starts {
            let j = i
                + 1
                + b[i + 1..]
                    .iter()
                    .take_while(|c| {
                        c.is_ascii_digit() || matches!(c, b'.' | b'e' | b'E' | b'-' | b'+')
                    })
                    .count();
            numbers.push(i..j);
            i = j;
        } else {
            i += 1;
        }
    }
    replace_some(json, &numbers, r)
}

/// The same for the guiding curves: edge numbers in the shipped curves
/// files (points, distances, scales, segment lengths, thickness, density),
/// then the guided sampler on the unchanged grammar. A file it refuses
/// must be refused with a typed error.
#[test]
fn edge_numbers_in_the_curves_files_never_panic() {
    let mut r = Rng::seeded(0x0c0f_fee0_c0de);
    let (mut read, mut refused, mut sampled) = (0usize, 0usize, 0usize);
    for path in examples() {
        let curves_path = path.with_extension("curves.json");
        let Ok(json) = std::fs::read_to_string(&curves_path) else {
            continue;
        };
        let text = std::fs::read_to_string(&path).expect("an example");
        let (_, checked) = grm_sema::check_text(&path.to_string_lossy(), &text);
        assert!(!checked.has_errors(), "{}", path.display());
        let program = &checked.program;
        let sys = program
            .systems
            .iter()
            .find(|s| s.mode == Mode::Sample)
            .expect("a sample-mode system beside its curves file");
        let compiled =
            grm_compile::compile(program, sys, &program.default_params()).expect("compiles");
        for _ in 0..60 {
            let m = mutate_json(&json, &mut r);
            let Ok(curves) = grm_guide::Curves::from_json_str("mutant.curves.json", &m) else {
                refused += 1;
                continue;
            };
            read += 1;
            let Ok(sampler) = Sampler::new(
                sys,
                &compiled,
                &curves,
                Objective::Curves,
                ExpectedOptions::default(),
            ) else {
                continue;
            };
            let mut schedule = Schedule::from_settings(&compiled.settings).with_generations(4);
            schedule.particles_start = 4;
            schedule.particles_end = 2;
            let opts = SampleOptions {
                seed: 1,
                schedule,
                threads: 1,
                candidates: 2,
                ..SampleOptions::default()
            };
            if let Ok(run) = sampler.sample(&opts) {
                if let Some(best) = run.best() {
                    let _ = best.build(program, &grm_geom::BuildOptions::default());
                }
                sampled += 1;
            }
        }
    }
    eprintln!("curves mutants: {read} read, {refused} refused, {sampled} sampled");
    assert!(
        read >= 20 && refused >= 5 && sampled >= 20,
        "{read} {refused} {sampled}"
    );
}

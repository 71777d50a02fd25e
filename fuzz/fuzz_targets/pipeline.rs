//! Fuzz target `pipeline`: what `grmc derive`, `grmc sample`, `grmc disasm`
//! and the preview do with a text that checks cleanly.
//!
//! Arbitrary bytes (lossy UTF-8) are checked with an in-memory loader. When
//! the check reports no error, every system (at most four) is compiled with
//! the default meta-parameters, disassembled, and then grown as the preview
//! grows it, with small limits so that one input stays fast:
//!
//! - derive mode: the CPU engine for at most 6 iterations and 20,000
//!   modules (one thread, then two, which must give the same string), then
//!   the turtle and the meshes (`grm_geom::build_model`), then a small
//!   picture of the model (`grm_geom::render`);
//! - sample mode: the guided sampler with one curve, 4 particles and at most
//!   4 generations, then the meshes and a picture of its best model.
//!
//! Nothing may panic. Every failure must come back as a typed error (a
//! limit, a run-time error of the program): those are fine.

#![no_main]

use grm_derive::{DeriveLimits, Engine};
use grm_sample::{ExpectedOptions, FinishLimits, Objective, SampleOptions, Sampler, Schedule};
use grm_sema::{MemLoader, Mode};
use libfuzzer_sys::fuzz_target;
use std::sync::OnceLock;

fn loader() -> &'static MemLoader {
    static LOADER: OnceLock<MemLoader> = OnceLock::new();
    LOADER.get_or_init(|| {
        let mut l = MemLoader::new();
        l.add("common.grm", include_str!("../../examples/common.grm"))
            .add(
                "lib.grm",
                "const K = 2;\nsystem Lib { axiom F; F -> F F; }\n",
            )
            .add_binary("leaf.obj")
            .add_binary("trunk.obj");
        l
    })
}

fn curves() -> &'static grm_guide::Curves {
    static CURVES: OnceLock<grm_guide::Curves> = OnceLock::new();
    CURVES.get_or_init(|| {
        grm_guide::Curves::from_json_str(
            "fuzz.curves.json",
            r#"{"version": 1, "curves": [{"name": "up", "points": [[0,0,0],[0,1,0],[0,2,0],[0,3,0]]}]}"#,
        )
        .expect("a valid curves file")
    })
}

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let (_, checked) = grm_sema::check_with("main.grm", &text, loader());
    if checked.has_errors() {
        return;
    }
    let program = &checked.program;
    let values = program.default_params();
    for sys in program.systems.iter().take(4) {
        let Ok(compiled) = grm_compile::compile(program, sys, &values) else {
            continue;
        };
        let _ = grm_compile::disassemble(&compiled, Some(&text));
        let mut settings = compiled.settings.clone();
        match sys.mode {
            Mode::Sample => sample(program, sys, &compiled),
            _ => {
                settings.iterations = settings.iterations.min(6);
                derive(program, sys, &compiled, &settings);
            }
        }
    }
});

fn derive(
    program: &grm_sema::Program,
    sys: &grm_sema::System,
    compiled: &grm_compile::CompiledSystem,
    settings: &grm_sema::Settings,
) {
    let limits = DeriveLimits {
        max_modules: 20_000,
        max_bytes: 1 << 22,
    };
    let grow = |threads: usize| {
        let engine = Engine::new(compiled, threads).ok()?;
        let mut s = engine.axiom(settings.seed).ok()?;
        for it in 1..=settings.iterations {
            match engine.step(&s, it, settings.seed, &limits) {
                Ok(next) => s = next,
                Err(_) => return None,
            }
        }
        Some(s)
    };
    let Some(one) = grow(1) else { return };
    let two = grow(2).expect("two threads fail where one succeeds");
    assert_eq!(one, two, "two threads derive another string");
    if let Ok(model) = grm_geom::build_model(program, sys, &one, settings, &compiled.param_values) {
        picture(&model);
    }
}

/// The model drawn as `-o x.png` draws it, small, fitted and through a
/// perspective camera at a corner of its bounds (clipping): it must not
/// panic, and a view the renderer takes must draw.
fn picture(model: &grm_geom::Model) {
    use grm_geom::render::{RenderOptions, View, render};
    let b = model.stats.bounds;
    let (lo, hi) = (b.min.as_dvec3(), b.max.as_dvec3());
    let camera = View::Camera {
        eye: lo,
        target: (lo + hi) * 0.5,
        fov: 60.0,
    };
    for view in [View::Auto, camera] {
        let o = RenderOptions {
            width: 16,
            height: 12,
            samples: 2,
            view,
            ..Default::default()
        };
        if view.validate().is_err() {
            continue;
        }
        let image = render(model, &o).expect("valid options draw");
        assert_eq!(image.rgba.len(), 16 * 12 * 4);
    }
}

fn sample(
    program: &grm_sema::Program,
    sys: &grm_sema::System,
    compiled: &grm_compile::CompiledSystem,
) {
    let Ok(sampler) = Sampler::new(
        sys,
        compiled,
        curves(),
        Objective::Curves,
        ExpectedOptions::default(),
    ) else {
        return;
    };
    let mut schedule = Schedule::from_settings(&compiled.settings)
        .with_generations(compiled.settings.iterations.clamp(1, 4));
    schedule.particles_start = 4;
    schedule.particles_end = 4;
    let opts = SampleOptions {
        seed: compiled.settings.seed,
        schedule,
        threads: 1,
        max_expansions_per_step: 200,
        candidates: 2,
        limits: FinishLimits {
            max_depth: 64,
            max_expansions: 5_000,
        },
        ..SampleOptions::default()
    };
    if let Ok(run) = sampler.sample(&opts) {
        if let Some(best) = run.best()
            && let Ok(model) = best.build(program, &grm_geom::BuildOptions::default())
        {
            picture(&model);
        }
    }
}

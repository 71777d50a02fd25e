//! Helpers shared by the grm-sample test files.
#![allow(dead_code)]

use std::path::PathBuf;

use grm_compile::CompiledSystem;
use grm_guide::Curves;
use grm_sema::Program;

pub fn examples() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples")
}

/// Check a program text (imports and meshes relative to `path`).
pub fn program(path: &str, text: &str) -> Program {
    let (_sources, checked) = grm_sema::check_text(path, text);
    let errors: Vec<String> = checked
        .diagnostics
        .iter()
        .filter(|d| d.is_error())
        .map(|d| format!("{d:?}"))
        .collect();
    assert!(errors.is_empty(), "check errors: {errors:#?}");
    checked.program
}

pub fn example(name: &str) -> Program {
    let path = examples().join(name);
    let text = std::fs::read_to_string(&path).expect("example exists");
    program(path.to_str().expect("utf-8 path"), &text)
}

pub fn compile(program: &Program, system: usize) -> CompiledSystem {
    grm_compile::compile(program, &program.systems[system], &program.default_params())
        .expect("compiles")
}

pub fn calder_curves() -> Curves {
    Curves::load(examples().join("calder_tree.curves.json")).expect("curves load")
}

/// Percentile (0..=100) of a sample, by nearest rank on the sorted values.
pub fn percentile(xs: &[f64], p: f64) -> f64 {
    let mut v: Vec<f64> = xs.to_vec();
    v.sort_by(|a, b| a.total_cmp(b));
    let i = ((p / 100.0) * (v.len() - 1) as f64).round() as usize;
    v[i]
}

pub fn median(xs: &[f64]) -> f64 {
    percentile(xs, 50.0)
}

/// The sampler of `program`'s first system with `curves`, the curve
/// objective and the default heuristic: what most tests sample with.
pub fn curves_sampler<'a>(
    program: &'a Program,
    compiled: &'a CompiledSystem,
    curves: &'a Curves,
) -> grm_sample::Sampler<'a> {
    grm_sample::Sampler::new(
        &program.systems[0],
        compiled,
        curves,
        grm_sample::Objective::Curves,
        grm_sample::ExpectedOptions::default(),
    )
    .expect("sampler")
}

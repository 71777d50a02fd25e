//! Shared helpers of grm-grow's tests: the examples, checked and compiled.

#![allow(dead_code)]

use std::path::{Path, PathBuf};

use grm_compile::CompiledSystem;

pub fn repo() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
}

pub fn example_path(file: &str) -> PathBuf {
    repo().join("examples").join(file)
}

/// An example, checked without errors.
pub fn checked(file: &str) -> grm_sema::Checked {
    let path = example_path(file);
    let text = std::fs::read_to_string(&path).expect("example");
    let (_, checked) = grm_sema::check_text(&path.display().to_string(), &text);
    assert!(!checked.has_errors(), "{file}: {:?}", checked.diagnostics);
    checked
}

/// The default system of `checked`, compiled with the default parameters.
pub fn compile(checked: &grm_sema::Checked) -> CompiledSystem {
    let p = &checked.program;
    grm_compile::compile(p, system(checked), &p.default_params()).expect("compiles")
}

pub fn system(checked: &grm_sema::Checked) -> &grm_sema::System {
    checked.program.default_system().expect("a system")
}

/// An inline grammar, checked without errors.
pub fn inline(src: &str) -> grm_sema::Checked {
    let (_, checked) = grm_sema::check_with("inline.grm", src, &grm_sema::MemLoader::new());
    assert!(!checked.has_errors(), "{:?}", checked.diagnostics);
    checked
}

pub fn options(iterations: u32, seed: u32) -> grm_derive::DeriveOptions {
    grm_derive::DeriveOptions {
        iterations,
        seed,
        limits: grm_derive::DeriveLimits::default(),
    }
}

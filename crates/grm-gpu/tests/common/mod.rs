#![allow(dead_code)]
//! Shared helpers of the GPU tests.

/// The shared GPU. GPU tests never skip: without an adapter they fail here
/// with the reason and the fix.
pub fn gpu() -> &'static grm_gpu::Gpu {
    match grm_gpu::shared() {
        Ok(g) => g,
        Err(e) => panic!(
            "GPU tests need a GPU adapter and found none: {e}\n\
             (scripts/test.sh installs Mesa's lavapipe: apt-get install mesa-vulkan-drivers libvulkan1)"
        ),
    }
}

/// A small deterministic PRNG for test inputs (splitmix64).
#[derive(Debug)]
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in `0..n`.
    pub fn below(&mut self, n: u64) -> u64 {
        self.next() % n.max(1)
    }
}

pub fn repo() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Check and compile `system` (or the default one) of an example file.
pub fn example(file: &str, system: Option<&str>) -> grm_compile::CompiledSystem {
    let path = repo().join("examples").join(file);
    let text = std::fs::read_to_string(&path).expect("example exists");
    let (_, checked) = grm_sema::check_text(&path.display().to_string(), &text);
    assert!(!checked.has_errors(), "{file}: {:?}", checked.diagnostics);
    let p = &checked.program;
    let sys = match system {
        Some(n) => p.system(n).expect("system exists"),
        None => p.default_system().expect("a system"),
    };
    grm_compile::compile(p, sys, &p.default_params()).expect("compiles")
}

/// Check and compile the first system of an inline grammar, or `None` when
/// it has errors.
pub fn inline(src: &str) -> Option<grm_compile::CompiledSystem> {
    let (_, checked) = grm_sema::check_with("inline.grm", src, &grm_sema::MemLoader::new());
    if checked.has_errors() {
        return None;
    }
    let p = &checked.program;
    let sys = p.default_system()?;
    grm_compile::compile(p, sys, &p.default_params()).ok()
}

/// The CPU derivation (one thread).
pub fn cpu_derive(
    sys: &grm_compile::CompiledSystem,
    iterations: u32,
    seed: u32,
) -> Result<grm_derive::ModuleString, grm_derive::DeriveError> {
    let opts = grm_derive::DeriveOptions {
        iterations,
        seed,
        limits: grm_derive::DeriveLimits::default(),
    };
    grm_derive::derive(sys, &opts, 1, &mut |_| {}).map(|d| d.string)
}

/// Relative tolerance of GPU parameters against the CPU's (see the crate
/// docs: arithmetic agrees exactly; transcendental functions to a few ulps,
/// which iterated expressions can grow).
pub const PARAM_TOLERANCE: f32 = 1e-4;

/// Assert that two derived strings are the same: symbols and starts
/// exactly, parameters within [`PARAM_TOLERANCE`].
pub fn assert_same(what: &str, cpu: &grm_derive::ModuleString, gpu: &grm_derive::ModuleString) {
    assert_eq!(cpu.len(), gpu.len(), "{what}: lengths");
    if let Some(i) = (0..cpu.len()).find(|&i| cpu.syms[i] != gpu.syms[i]) {
        panic!(
            "{what}: module {i}: symbol {} on the CPU, {} on the GPU",
            cpu.syms[i], gpu.syms[i]
        );
    }
    assert_eq!(cpu.starts, gpu.starts, "{what}: parameter starts");
    for (k, (c, g)) in cpu.params.iter().zip(&gpu.params).enumerate() {
        let ok = c.to_bits() == g.to_bits() || (c - g).abs() <= PARAM_TOLERANCE * c.abs().max(1.0);
        assert!(
            ok,
            "{what}: parameter word {k}: {c} on the CPU, {g} on the GPU"
        );
    }
}

/// An example's checked program, its system (by name or the default) and
/// the compiled system.
pub fn example_program(
    file: &str,
    system: Option<&str>,
) -> (grm_sema::Program, String, grm_compile::CompiledSystem) {
    let path = repo().join("examples").join(file);
    let text = std::fs::read_to_string(&path).expect("example exists");
    let (_, checked) = grm_sema::check_text(&path.display().to_string(), &text);
    assert!(!checked.has_errors(), "{file}: {:?}", checked.diagnostics);
    let p = checked.program;
    let sys = match system {
        Some(n) => p.system(n).expect("system exists"),
        None => p.default_system().expect("a system"),
    };
    let c = grm_compile::compile(&p, sys, &p.default_params()).expect("compiles");
    let name = sys.name.clone();
    (p, name, c)
}

/// As [`inline`], keeping the checked program.
pub fn inline_program(src: &str) -> Option<(grm_sema::Program, grm_compile::CompiledSystem)> {
    let (_, checked) = grm_sema::check_with("inline.grm", src, &grm_sema::MemLoader::new());
    if checked.has_errors() {
        return None;
    }
    let p = checked.program;
    let c = {
        let sys = p.default_system()?;
        grm_compile::compile(&p, sys, &p.default_params()).ok()?
    };
    Some((p, c))
}

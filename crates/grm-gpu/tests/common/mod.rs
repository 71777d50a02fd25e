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

/// The suites' generator of random inputs (`GRM_TEST_SEED` soaks them).
pub use grm_testkit::Rng;

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

/// The two strings carry the same identity keys (`grm_compile::rng`,
/// "Identity keys"), or neither carries any.
pub fn assert_same_keys(what: &str, a: &grm_derive::ModuleString, b: &grm_derive::ModuleString) {
    assert_eq!(
        a.keys().is_empty(),
        b.keys().is_empty(),
        "{what}: one string carries identity keys ({} and {} keys)",
        a.keys().len(),
        b.keys().len()
    );
    if let Some(i) = (0..a.keys().len().min(b.keys().len())).find(|&i| a.keys()[i] != b.keys()[i]) {
        panic!(
            "{what}: module {i}: identity key {:#010x}, then {:#010x}",
            a.keys()[i],
            b.keys()[i]
        );
    }
    assert_eq!(a.keys().len(), b.keys().len(), "{what}: identity keys");
}

/// Relative tolerance of GPU parameters against the CPU's (see the crate
/// docs: arithmetic agrees exactly; transcendental functions to a few ulps,
/// which iterated expressions can grow).
pub const PARAM_TOLERANCE: f32 = 1e-4;

/// Assert that two derived strings are the same: symbols, starts and
/// identity keys exactly (both carry keys or neither does: a string of a
/// system that draws carries them on both engines), parameters within
/// [`PARAM_TOLERANCE`].
pub fn assert_same(what: &str, cpu: &grm_derive::ModuleString, gpu: &grm_derive::ModuleString) {
    assert_eq!(cpu.len(), gpu.len(), "{what}: lengths");
    if let Some(i) = (0..cpu.len()).find(|&i| cpu.sym(i) != gpu.sym(i)) {
        panic!(
            "{what}: module {i}: symbol {} on the CPU, {} on the GPU",
            cpu.sym(i),
            gpu.sym(i)
        );
    }
    assert_eq!(
        cpu.parts().starts,
        gpu.parts().starts,
        "{what}: parameter starts"
    );
    assert_same_keys(what, cpu, gpu);
    for (k, (c, g)) in cpu
        .parts()
        .params
        .iter()
        .zip(gpu.parts().params.iter())
        .enumerate()
    {
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

/// The two strings are identical, parameters bit for bit, identity keys
/// included.
pub fn same_bits(what: &str, a: &grm_derive::ModuleString, b: &grm_derive::ModuleString) {
    assert_eq!(a.parts().syms, b.parts().syms, "{what}: symbols");
    assert_eq!(a.parts().starts, b.parts().starts, "{what}: starts");
    assert_same_keys(what, a, b);
    let bits = |s: &grm_derive::ModuleString| {
        s.parts()
            .params
            .iter()
            .map(|x| x.to_bits())
            .collect::<Vec<_>>()
    };
    assert_eq!(bits(a), bits(b), "{what}: parameters");
}

/// A random context-free grammar with conditions, constant and computed
/// weights, draws, branches and parameter expressions that may go bad
/// (division by a counter that reaches zero).
pub fn random_grammar(rng: &mut Rng) -> String {
    let pick = |rng: &mut Rng, xs: &[&'static str]| xs[rng.below(xs.len() as u64) as usize];
    let succ = |rng: &mut Rng| {
        let mut out = Vec::new();
        for _ in 0..rng.below(6) {
            out.push(match rng.below(8) {
                0 => "A(x + 1)".to_string(),
                1 => "B(x - 1)".to_string(),
                2 => "C(randint(0, 4))".to_string(),
                3 => format!(
                    "F({})",
                    pick(rng, &["x / 2", "uniform(0.5, 1)", "1", "10 / x"])
                ),
                4 => pick(rng, &["+", "-"]).to_string(),
                5 => "[ B(x) F(1) ]".to_string(),
                _ => "D".to_string(),
            });
        }
        out.join(" ")
    };
    let mut s = String::from("system R {\n    axiom A(1) B(2) F(1) C(3) D;\n");
    for _ in 0..2 + rng.below(5) {
        let pred = pick(rng, &["A", "B", "C", "D"]);
        let pat = if pred == "D" {
            "D"
        } else {
            &format!("{pred}(x)")
        };
        let cond = if pred == "D" {
            ""
        } else {
            pick(
                rng,
                &["", "", " : x < 3", " : x % 2 == 0", " : chance(0.5)"],
            )
        };
        let alts = 1 + rng.below(3);
        for _ in 0..alts {
            let weight = match (alts, rng.below(3), pred) {
                (1, _, _) => String::new(),
                (_, 0, p) if p != "D" => "(abs(x) + 1) ".into(),
                (_, 1, p) if p != "D" => "(x) ".into(),
                _ => format!("({}) ", 1 + rng.below(3)),
            };
            let body = succ(rng).replace('x', if pred == "D" { "1" } else { "x" });
            s.push_str(&format!("    {pat}{cond} -> {weight}{body};\n"));
        }
    }
    s.push_str("}\n");
    s
}

/// Absolute tolerance, relative to 1 + the largest coordinate of the scene:
/// the GPU composes the same f32 transforms in a different order (a scan),
/// and its sin/cos are not correctly rounded.
pub const TOL: f32 = 2e-4;

/// The GPU bones are the CPU turtle's: the same bones in the same order,
/// with the same parents and modules; positions within [`TOL`] of the
/// scene's extent, directions within 1e-3, widths within a relative 1e-4.
pub fn assert_bones_match(
    what: &str,
    cpu: &grm_turtle::Interpretation,
    gpu: &[grm_gpu::layout::GpuBone],
) {
    assert_eq!(cpu.bones.len(), gpu.len(), "{what}: bone count");
    let extent = cpu
        .bones
        .iter()
        .flat_map(|b| [b.base.abs().max_element(), b.tip.abs().max_element()])
        .fold(0.0f32, f32::max);
    let tol = TOL * (1.0 + extent);
    for (k, (c, g)) in cpu.bones.iter().zip(gpu).enumerate() {
        assert_eq!(c.module, g.module_index, "{what}: bone {k}: module");
        assert_eq!(
            c.parent.unwrap_or(u32::MAX),
            g.parent,
            "{what}: bone {k}: parent"
        );
        let close =
            |a: glam::Vec3, b: [f32; 3], t: f32| (a - glam::Vec3::from(b)).abs().max_element() <= t;
        assert!(
            close(c.base, [g.base_x, g.base_y, g.base_z], tol)
                && close(c.tip, [g.tip_x, g.tip_y, g.tip_z], tol),
            "{what}: bone {k}: cpu {:?} -> {:?}, gpu {:?}",
            c.base,
            c.tip,
            g
        );
        assert!(
            close(c.left, [g.left_x, g.left_y, g.left_z], 1e-3),
            "{what}: bone {k}: left {:?} vs {g:?}",
            c.left
        );
        assert!(
            (c.width_base - g.width).abs() <= 1e-4 * c.width_base.abs().max(1.0),
            "{what}: bone {k}: width {} vs {}",
            c.width_base,
            g.width
        );
    }
}

/// Each string's (index, modules, parameter words) of a derivation.
pub fn figures(d: &grm_gpu::GpuDerivation) -> Vec<(u32, u64, u64)> {
    d.stats
        .iter()
        .map(|s| (s.iteration, s.modules, s.param_words))
        .collect()
}

/// Derive options for kernel tests: every iteration on the GPU (no CPU
/// prefix).
pub fn gpu_opts(
    sys: &grm_compile::CompiledSystem,
    iterations: u32,
    seed: u32,
) -> grm_gpu::GpuDeriveOptions {
    grm_gpu::GpuDeriveOptions {
        iterations,
        seed,
        cpu_prefix: 0,
        ..grm_gpu::GpuDeriveOptions::from_system(sys)
    }
}

//! GPU turtle interpretation against grm-turtle (the CPU interpreter): the
//! same bones in the same order, with the same parents and modules;
//! positions, directions and widths within `TOL` of the scene's extent.

mod common;
use common::*;
use grm_gpu::{BranchScan, TurtleProgram, interpret, interpret_with};

#[test]
fn example_scenes_match_the_cpu_turtle() {
    let g = gpu();
    let cases: &[(&str, Option<&str>, u32, bool)] = &[
        ("hilbert3d.grm", None, 3, false),
        ("koch_island.grm", None, 3, false),
        ("bracketed_plant.grm", None, 4, false),
        ("row_of_trees.grm", None, 5, false),
        ("ternary_tree.grm", None, 5, true),
        ("ternary_tree.grm", Some("TernaryTreeD"), 4, true),
        ("stochastic_plant.grm", None, 5, false),
        ("context_plant_a.grm", None, 20, false),
    ];
    for &(file, system, iterations, walks) in cases {
        let (p, name, c) = example_program(file, system);
        let sys = p.system(&name).expect("system");
        let string = cpu_derive(&c, iterations, c.settings.seed).expect("derives");
        let cpu = grm_turtle::interpret(sys, &c.settings, &string).expect("cpu interprets");
        let prog = TurtleProgram::new(sys, &c.settings);
        assert_eq!(prog.walks(), walks, "{file}");
        let gpu = interpret(g, &prog, &string).expect("gpu interprets");
        assert!(!cpu.bones.is_empty());
        // Straight strings of affine commands take the fused scan; a
        // branching one keeps a state per module where it fits.
        assert_eq!(gpu.fused, !prog.has_brackets() && !walks, "{file}");
        if matches!(file, "hilbert3d.grm" | "koch_island.grm") {
            assert!(gpu.fused, "{file}: Lipp's straight scenes");
        }
        assert_bones_match(&format!("{file} {name}"), &cpu, &gpu.bones);
        if prog.has_brackets() && !walks {
            let fused = interpret_with(g, &prog, &string, BranchScan::Fused).expect("fused");
            assert!(fused.fused, "{file}");
            assert_bones_match(&format!("{file} {name} fused"), &cpu, &fused.bones);
        }
    }
}

/// A random balanced string over every symbol of `sys`, with parameters in
/// ranges that keep the scene bounded.
fn random_string(
    sys: &grm_sema::System,
    rng: &mut Rng,
    len: usize,
    cuts: bool,
) -> grm_derive::ModuleString {
    use grm_sema::{SymbolKind, Terminal as T};
    let mut s = grm_derive::ModuleString::new();
    let mut depth = 0;
    let ids: Vec<usize> = (0..sys.symbols.len()).collect();
    let f =
        |rng: &mut Rng, lo: f32, hi: f32| lo + (hi - lo) * (rng.below(10_001) as f32 / 10_000.0);
    while s.len() < len {
        let id = ids[rng.below(ids.len() as u64) as usize];
        let info = &sys.symbols[id];
        let words: usize = info
            .params
            .iter()
            .map(|t| if *t == grm_sema::Ty::Vec3 { 3 } else { 1 })
            .sum();
        let term = match info.kind {
            SymbolKind::Terminal(t) => Some(t),
            SymbolKind::User => None,
        };
        match term {
            Some(T::Push) => depth += 1,
            Some(T::Pop) if depth == 0 => continue,
            Some(T::Pop) => depth -= 1,
            Some(T::Cut) if !cuts || rng.below(8) != 0 => continue,
            Some(T::ScaleUniform | T::Scale) if rng.below(4) != 0 => continue,
            _ => {}
        }
        let p: Vec<f32> = match term {
            Some(T::Forward | T::ForwardNoVertex | T::Move | T::MoveNoVertex) => {
                vec![f(rng, 0.1, 2.0)]
            }
            Some(T::ScaleUniform) => vec![f(rng, 0.8, 1.25)],
            Some(T::Scale) => (0..3).map(|_| f(rng, 0.8, 1.25)).collect(),
            Some(T::SetWidth) => vec![f(rng, 0.0, 2.0)],
            Some(T::Translate) => (0..3).map(|_| f(rng, -1.0, 1.0)).collect(),
            Some(T::Rotate) => vec![
                f(rng, -1.0, 1.0),
                f(rng, -1.0, 1.0),
                f(rng, 0.2, 1.0),
                f(rng, -90.0, 90.0),
            ],
            _ => (0..words).map(|_| f(rng, -90.0, 90.0)).collect(),
        };
        assert_eq!(p.len(), words, "{}", info.name);
        s.push(id as u32, &p);
    }
    for _ in 0..depth {
        let pop = sys.symbol_by_name("]").expect("]");
        s.push(pop.0, &[]);
    }
    s
}

const ALL_TERMINALS: &str = "F(1) f(1) G(1) g(1) + - & ^ \\ / | [ ] !(1) ! '(1) ' { . } \
    translate(1, 2, 3) rotate(vec3(0, 0, 1), 30) rotx(10) roty(10) rotz(10) scale(2) scale(1, 2, 3) \
    cylinder(1, 1) sphere(1) A B(1)";

/// Every terminal but the brackets: straight strings (depth 0, in depth
/// order already: interpreted without depths or a sort).
fn straight_terminals() -> String {
    ALL_TERMINALS.replace(" [ ]", "")
}

/// Random strings over every terminal: scanned (affine commands only) and
/// walked (with `$`, `%` and tropism), with brackets and without, against
/// the CPU turtle.
#[test]
fn random_strings_match_the_cpu_turtle() {
    let g = gpu();
    let straight = straight_terminals();
    assert!(!straight.contains('[') && straight.len() < ALL_TERMINALS.len());
    let systems = [
        (
            format!("system S {{ angle = 30; width = 0.5; axiom {straight}; }}"),
            false,
            false,
        ),
        (
            format!(
                "system S {{ angle = 30; tropism = vec3(0.3, -1, 0); elasticity = 0.2; axiom {straight} $; }}"
            ),
            true,
            false,
        ),
        (
            format!("system S {{ angle = 30; width = 0.5; axiom {ALL_TERMINALS}; }}"),
            false,
            false,
        ),
        (
            format!("system S {{ angle = 30; axiom {ALL_TERMINALS} $ %; }}"),
            true,
            true,
        ),
        (
            format!(
                "system S {{ angle = 30; tropism = vec3(0.3, -1, 0); elasticity = 0.2; axiom {ALL_TERMINALS}; }}"
            ),
            true,
            false,
        ),
    ];
    let mut rng = Rng::seeded(17);
    for (src, walks, cuts) in &systems {
        let (p, c) = inline_program(src).unwrap_or_else(|| panic!("checks: {src}"));
        let sys = p.default_system().expect("system");
        let prog = TurtleProgram::new(sys, &c.settings);
        assert_eq!(prog.walks(), *walks, "{src}");
        for k in 0..25 {
            let len = [10, 300, 2000, 5000][k % 4];
            let string = random_string(sys, &mut rng, len, *cuts);
            let cpu = grm_turtle::interpret(sys, &c.settings, &string).expect("cpu interprets");
            let gpu = interpret(g, &prog, &string).expect("gpu interprets");
            assert_bones_match(&format!("{src} #{k}"), &cpu, &gpu.bones);
            if !prog.has_brackets() {
                assert_eq!(gpu.max_depth, 0);
            }
            // Straight strings of affine commands take the fused scan.
            assert_eq!(gpu.fused, !prog.has_brackets() && !walks, "{src}");
            // Both scans of a branching string of affine commands.
            if prog.has_brackets() && !walks {
                let fused = interpret_with(g, &prog, &string, BranchScan::Fused).expect("fused");
                assert!(fused.fused);
                assert_bones_match(&format!("{src} #{k} fused"), &cpu, &fused.bones);
            }
        }
    }
}

/// A derived branching string is interpreted with its depth range bounded
/// from the tables (not read back first): the bones are the CPU turtle's
/// and the reported depth is the string's own, for deterministic,
/// stochastic and context-sensitive scenes and both scans.
#[test]
fn derived_strings_interpret_with_table_bounds() {
    let g = gpu();
    let cases: &[(&str, Option<&str>, u32)] = &[
        ("ternary_tree.grm", None, 4),
        ("stochastic_plant.grm", None, 5),
        ("context_plant_a.grm", None, 12),
        ("context_plant_b.grm", None, 12),
        ("bracketed_plant.grm", None, 3),
    ];
    for &(file, system, iterations) in cases {
        let (p, name, c) = example_program(file, system);
        let sys = p.system(&name).expect("system");
        let string = cpu_derive(&c, iterations, c.settings.seed).expect("derives");
        let cpu = grm_turtle::interpret(sys, &c.settings, &string).expect("cpu interprets");
        let depth = string
            .symbols()
            .scan(0i64, |d, s| {
                match sys.symbols[s as usize].name.as_str() {
                    "[" => *d += 1,
                    "]" => *d -= 1,
                    _ => {}
                }
                Some(*d)
            })
            .max()
            .unwrap_or(0);
        let turtle = TurtleProgram::new(sys, &c.settings);
        for scan in [BranchScan::Auto, BranchScan::Fused] {
            let opts = grm_gpu::GpuRunOptions {
                derive: grm_gpu::GpuDeriveOptions {
                    iterations,
                    cpu_prefix: 0,
                    ..grm_gpu::GpuDeriveOptions::from_system(&c)
                },
                interpret: true,
                read_string: false,
                read_bones: true,
                strategy: grm_gpu::DeriveStrategy::Auto,
                branch_scan: scan,
                pipelined: false,
            };
            let run = grm_gpu::run(g, &c, &turtle, &opts, &mut |_| {}).expect("runs");
            let i = run.interpretation.expect("interpreted");
            let what = format!("{file} {scan:?}");
            assert_bones_match(&what, &cpu, &i.bones);
            if !i.direct {
                assert_eq!(i.max_depth as i64, depth, "{what}: depth");
            }
        }
    }
}

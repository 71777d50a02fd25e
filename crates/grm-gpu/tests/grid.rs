//! Dispatches split over 2D grids: with the grid width lowered to 3
//! workgroups, every dispatch of more than 768 threads takes the 2D path
//! (`wg_linear` in the kernels, indirect round dispatches and the direct
//! derivation included), and
//! the results must not change. Its own test binary, so the lowered width
//! does not reach the other tests.

mod common;
use common::*;
use grm_gpu::{DeriveStrategy, GpuDeriveOptions, TurtleProgram, derive_with, interpret, scan};

#[test]
fn two_dimensional_grids_give_the_same_results() {
    let g = gpu();
    g.limit_dispatch_width(3);
    assert_eq!(g.grid_width(), 3);
    assert_eq!(g.grid("t", 10).expect("grid"), (3, 4));

    let v: Vec<u32> = (0..50_000u32).map(|i| i % 7).collect();
    let got = scan::exclusive_scan_u32(g, &v).expect("scan");
    let mut s = 0;
    for (k, x) in v.iter().enumerate() {
        assert_eq!(got[k], s, "scan element {k}");
        s += x;
    }

    for (file, system, n) in [
        ("bracketed_plant.grm", None, 4),
        ("context_plant_a.grm", None, 22),
        ("ternary_tree.grm", None, 5),
        ("hilbert3d.grm", None, 3),
    ] {
        let (p, name, c) = example_program(file, system);
        let sys = p.system(&name).expect("system");
        let cpu = cpu_derive(&c, n, c.settings.seed).expect("cpu derives");
        let opts = GpuDeriveOptions {
            iterations: n,
            seed: c.settings.seed,
            cpu_prefix: 0,
            ..GpuDeriveOptions::from_system(&c)
        };
        // Direct where it applies, and stepwise (batched or per iteration).
        for strategy in [DeriveStrategy::Auto, DeriveStrategy::Stepwise] {
            let (d, path) = derive_with(g, &c, &opts, strategy).expect("gpu derives");
            assert_same(&format!("{file} {path:?}"), &cpu, &d.string);
        }
        let bones =
            interpret(g, &TurtleProgram::new(sys, &c.settings), &cpu).expect("gpu interprets");
        let want = grm_turtle::interpret(sys, &c.settings, &cpu).expect("cpu interprets");
        assert_eq!(bones.bones.len(), want.bones.len(), "{file}");
        for (a, b) in want.bones.iter().zip(&bones.bones) {
            assert_eq!(
                (a.module, a.parent.unwrap_or(u32::MAX)),
                (b.module_index, b.parent),
                "{file}"
            );
            assert!(
                (a.tip.x - b.tip_x).abs() + (a.tip.y - b.tip_y).abs() + (a.tip.z - b.tip_z).abs()
                    < 1e-2,
                "{file}"
            );
        }
    }
}

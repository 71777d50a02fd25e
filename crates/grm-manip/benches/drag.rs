//! A drag's solve, as the language server answers a release: fresh (the
//! text grown, every number probed, the trials) against after the grab's
//! provenance (the probes kept: only the trials), alternating, on the
//! townhouse example (a window's plane moved 0.2). Prints medians and the
//! ratio of the same run.
//!
//!     cargo bench -p grm-manip --bench drag [-- ROUNDS]

use std::sync::Arc;
use std::time::Instant;

use grm_manip::{Manip, Part, Setup, Target};

fn plane_of(m: &Manip, label: &str) -> (Part, f64) {
    let p = m
        .parts()
        .into_iter()
        .find(|p| matches!(p.part, Part::Plane { .. }) && p.label.contains(label))
        .unwrap_or_else(|| panic!("no plane {label}"));
    (p.part, p.measures[0])
}

fn median(mut xs: Vec<f64>) -> f64 {
    xs.sort_by(f64::total_cmp);
    xs[xs.len() / 2]
}

fn main() {
    let rounds: usize = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(15);
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let townhouse = std::fs::read_to_string(root.join("examples/townhouse.grm")).expect("example");
    let scenes = [(
        "townhouse (window's plane)",
        townhouse,
        "Tile split.x: after part 2",
    )];
    println!("rounds {rounds}; medians in ms");
    println!(
        "{:<28} {:>8} {:>10} {:>8} {:>8}",
        "scene", "fresh", "after grab", "ratio", "numbers"
    );
    for (name, text, label) in scenes {
        let setup = Setup::new(
            root.join("examples/x.grm").to_string_lossy().into_owned(),
            Arc::new(grm_sema::FsLoader),
        );
        let probe = Manip::new(setup.clone(), &text).expect("grows");
        let (part, at) = plane_of(&probe, label);
        let target = Target::Plane { at: at + 0.2 };
        let (mut fresh, mut kept) = (Vec::new(), Vec::new());
        for _ in 0..rounds {
            let t = Instant::now();
            let m = Manip::new(setup.clone(), &text).expect("grows");
            m.drag(&part, &target).expect("drag");
            fresh.push(t.elapsed().as_secs_f64() * 1e3);
            let m = Manip::new(setup.clone(), &text).expect("grows");
            m.provenance(&part).expect("provenance");
            let t = Instant::now();
            m.drag(&part, &target).expect("drag");
            kept.push(t.elapsed().as_secs_f64() * 1e3);
        }
        let (f, k) = (median(fresh), median(kept));
        println!(
            "{name:<28} {f:>8.1} {k:>10.1} {:>8.2} {:>8}",
            k / f,
            probe.candidates().len()
        );
    }
}

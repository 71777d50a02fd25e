//! The deterministic ABoP examples against tests/derive_expect: every
//! per-iteration length (up to 2.5 million modules) and every written string.

mod common;

use common::*;

/// Longest string derived here (debug builds are slow).
const MAX_LEN: u64 = 2_500_000;

fn check(file: &str, example_file: &str, system: Option<&str>) {
    let e = expect(file);
    let c = example(example_file, system);
    let last = e
        .lens
        .iter()
        .filter(|(_, l)| *l <= MAX_LEN)
        .map(|(n, _)| *n)
        .max()
        .expect("some lengths");
    let strings = strings(&c, last, c.settings.seed, 1);
    for (n, l) in e.lens.iter().filter(|(n, _)| *n <= last) {
        assert_eq!(
            strings[*n as usize].len() as u64,
            *l,
            "{file}: length after {n} iterations"
        );
    }
    for (n, toks) in &e.strs {
        assert_matches(&c, &strings[*n as usize], toks, &format!("{file} str {n}"));
    }
}

#[test]
fn hilbert3d() {
    check("hilbert3d.txt", "hilbert3d.grm", None);
}

#[test]
fn koch_island() {
    check("koch_island.txt", "koch_island.grm", None);
}

#[test]
fn bracketed_plant() {
    check("bracketed_plant.txt", "bracketed_plant.grm", None);
}

#[test]
fn row_of_trees() {
    check("row_of_trees.txt", "row_of_trees.grm", None);
}

#[test]
fn ternary_tree() {
    check("ternary_tree.txt", "ternary_tree.grm", None);
    // The same lengths hold for the other three variants.
    for v in ["TernaryTreeB", "TernaryTreeC", "TernaryTreeD"] {
        let e = expect("ternary_tree.txt");
        let c = example("ternary_tree.grm", Some(v));
        let s = strings(&c, 6, 0, 1);
        for (n, l) in e.lens.iter().filter(|(n, _)| *n <= 6) {
            assert_eq!(s[*n as usize].len() as u64, *l, "{v} after {n}");
        }
    }
}

#[test]
fn context_plant_a() {
    check("context_plant_a.txt", "context_plant_a.grm", None);
}

#[test]
fn context_plant_b() {
    check("context_plant_b.txt", "context_plant_b.grm", None);
}

/// Lipp's Table 5.2 module counts for the deterministic scenes, as the sum
/// of string lengths (see tests/derive_expect/README.md).
#[test]
fn lipp_module_counts() {
    let sum = |file: &str, range: std::ops::RangeInclusive<u32>| -> u64 {
        expect(file)
            .lens
            .iter()
            .filter(|(n, _)| range.contains(n))
            .map(|(_, l)| l)
            .sum()
    };
    let c = example("hilbert3d.grm", None);
    let d = grm_derive::derive(
        &c,
        &grm_derive::DeriveOptions {
            iterations: 6,
            ..grm_derive::DeriveOptions::from_system(&c)
        },
        1,
        &mut |_| {},
    )
    .expect("derives");
    let last = d.stats.last().expect("stats");
    // Produced modules (strings 1..=6) = Lipp's 1,266,864.
    assert_eq!(last.cumulative_modules, 1_266_864);
    assert_eq!(last.cumulative_modules, sum("hilbert3d.txt", 1..=6));
    assert_eq!(last.processed_modules, sum("hilbert3d.txt", 0..=5));
}

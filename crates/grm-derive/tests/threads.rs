//! The same output, bit for bit, for 1, 2 and 8 threads and any chunking.

mod common;

use common::*;
use grm_derive::{DeriveLimits, Engine, ModuleString};

fn bits(s: &ModuleString) -> (Vec<u32>, Vec<u32>, Vec<u32>) {
    (
        s.symbols().collect(),
        s.parts().starts.to_vec(),
        s.parts().params.iter().map(|x| x.to_bits()).collect(),
    )
}

fn derive_with(
    c: &grm_compile::CompiledSystem,
    n: u32,
    seed: u32,
    threads: usize,
    chunk: Option<usize>,
) -> Vec<ModuleString> {
    let mut engine = Engine::new(c, threads).expect("engine");
    if let Some(k) = chunk {
        engine = engine.with_min_chunk(k);
    }
    let mut out = vec![engine.axiom(seed).expect("axiom")];
    for it in 1..=n {
        let next = engine
            .step(
                out.last().expect("nonempty"),
                it,
                seed,
                &DeriveLimits::default(),
            )
            .expect("step");
        out.push(next);
    }
    out
}

fn same_for_all_threads(file: &str, system: Option<&str>, n: u32, seed: u32) {
    let c = example(file, system);
    let base = derive_with(&c, n, seed, 1, None);
    assert!(
        base.last().expect("strings").len() > 2000,
        "{file}: too short to split: {}",
        base.last().expect("strings").len()
    );
    for (threads, chunk) in [
        (2, None),
        (8, None),
        (2, Some(97)),
        (8, Some(13)),
        (8, Some(1)),
    ] {
        let got = derive_with(&c, n, seed, threads, chunk);
        for (k, (a, b)) in base.iter().zip(&got).enumerate() {
            assert!(
                bits(a) == bits(b),
                "{file}: iteration {k} differs with {threads} threads, chunk {chunk:?}"
            );
        }
    }
}

#[test]
fn stochastic_plant() {
    same_for_all_threads("stochastic_plant.grm", None, 6, 1);
}

#[test]
fn context_plants() {
    same_for_all_threads("context_plant_a.grm", None, 26, 0);
    same_for_all_threads("context_plant_b.grm", None, 24, 0);
}

#[test]
fn parametric() {
    same_for_all_threads("row_of_trees.grm", None, 6, 0);
    same_for_all_threads("ternary_tree.grm", None, 6, 0);
}

#[test]
fn bracketed_and_curves() {
    same_for_all_threads("bracketed_plant.grm", None, 4, 0);
    same_for_all_threads("hilbert3d.grm", None, 4, 0);
}

/// A sample-mode grammar run as a derivation: conditions, `normal`,
/// `choose`, `randint`, `uniform`, stochastic groups with conditions.
#[test]
fn random_draws_everywhere() {
    same_for_all_threads("vine_wall.grm", None, 60, 3);
}

/// With big chunks the default path splits too: a large string.
#[test]
fn default_chunking_large_string() {
    let c = example("koch_island.grm", None);
    let one = derive_with(&c, 5, 0, 1, None);
    let eight = derive_with(&c, 5, 0, 8, None);
    assert!(one[5].len() > 200_000);
    assert!(bits(&one[5]) == bits(&eight[5]));
}

/// The seed matters, and the same seed gives the same plant.
#[test]
fn seeds() {
    let c = example("stochastic_plant.grm", None);
    let a = derive_with(&c, 5, 1, 1, None);
    let b = derive_with(&c, 5, 1, 2, None);
    let d = derive_with(&c, 5, 2, 1, None);
    assert!(bits(&a[5]) == bits(&b[5]));
    assert!(bits(&a[5]) != bits(&d[5]));
}

/// An engine that reuses the memory of earlier results (`recycle`) gives
/// the same strings as a fresh one: every word of a reused buffer is
/// overwritten.
#[test]
fn recycled_buffers_are_fully_overwritten() {
    for (file, n, seeds) in [
        ("stochastic_plant.grm", 6, [1u32, 2, 3]),
        ("vine_wall.grm", 60, [3, 4, 5]),
        ("context_plant_b.grm", 24, [0, 0, 0]),
    ] {
        let c = example(file, None);
        for threads in [1, 2] {
            let engine = Engine::new(&c, threads).expect("engine").with_min_chunk(64);
            for &seed in &seeds {
                let opts = grm_derive::DeriveOptions {
                    iterations: n,
                    seed,
                    limits: DeriveLimits::default(),
                };
                let reused = engine.derive(&opts, &mut |_| {}).expect("derives");
                let fresh = grm_derive::derive(&c, &opts, threads, &mut |_| {}).expect("derives");
                assert!(
                    bits(&reused.string) == bits(&fresh.string),
                    "{file}: seed {seed}, {threads} threads"
                );
                engine.recycle(reused.string);
            }
        }
    }
}

/// `derive` (which counts from the symbol histogram when no symbol needs a
/// decision) gives the same strings as stepping one iteration at a time
/// (which counts by scanning).
#[test]
fn derive_matches_single_steps() {
    for (file, n) in [
        ("hilbert3d.grm", 4),
        ("row_of_trees.grm", 6),
        ("ternary_tree.grm", 6),
        ("stochastic_plant.grm", 5),
        ("context_plant_a.grm", 20),
    ] {
        let c = example(file, None);
        let steps = derive_with(&c, n, 7, 1, None);
        for threads in [1, 2] {
            let d = grm_derive::derive(
                &c,
                &grm_derive::DeriveOptions {
                    iterations: n,
                    seed: 7,
                    limits: DeriveLimits::default(),
                },
                threads,
                &mut |_| {},
            )
            .expect("derives");
            assert!(bits(&d.string) == bits(&steps[n as usize]), "{file}");
            for (s, st) in d.stats.iter().zip(&steps) {
                assert_eq!(s.modules, st.len() as u64, "{file}");
            }
        }
    }
}

/// `Engine::derive` called from rayon's own workers (a forest's trees
/// derived in parallel), on rayon's global pool and on a pool of its own,
/// on both roads: a system without decisions (the bracketed plant) forks
/// its pieces with the caller taking its share, and its wait for the
/// spawned tasks runs them or other jobs; one with decisions (the
/// stochastic plant) is not handed to the pool as one task there (the
/// caller would wait on a task that may sit in its own queue). The
/// strings and the progress figures are one thread's.
#[test]
fn derive_from_rayon_workers() {
    use rayon::prelude::*;
    for file in ["bracketed_plant.grm", "stochastic_plant.grm"] {
        let c = example(file, None);
        let mut opts = grm_derive::DeriveOptions::from_system(&c);
        opts.iterations = 4;
        let run = |threads: usize| {
            let engine = Engine::new(&c, threads).expect("engine").with_min_chunk(16);
            let mut lens = Vec::new();
            let d = engine
                .derive(&opts, &mut |s| lens.push(s.modules))
                .expect("derives");
            (bits(&d.string), lens)
        };
        let base = run(1);
        assert!(base.0.0.len() > 64, "{file}: {}", base.0.0.len());
        let got: Vec<_> = (0..8).into_par_iter().map(|i| run([0, 2][i % 2])).collect();
        for g in got {
            assert!(
                g == base,
                "{file}: a string or its figures differ from one thread's"
            );
        }
    }
}

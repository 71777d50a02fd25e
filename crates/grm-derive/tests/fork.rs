//! `Engine::derive` where no symbol needs a decision runs the remaining
//! steps as one fork of pieces, each derived through all the steps on its
//! own (`src/engine/fork.rs`). What one thread derives step by step, the
//! fork must give for any thread count and piece size: the strings with
//! their identity keys, the progress figures, and the same error (the
//! earliest step's, at the lowest position) when a step fails or would
//! pass a limit.

mod common;

use common::*;
use grm_compile::CompiledSystem;
use grm_derive::{DeriveError, DeriveLimits, DeriveOptions, Engine};

/// Strings in order (length, words) as progress reports them, the final
/// string's symbols, words and keys, or the error.
type Outcome = (
    Vec<(u32, u64, u64, u64)>,
    Result<(Vec<u32>, Vec<u32>, Vec<u32>), DeriveError>,
);

fn derive(
    c: &CompiledSystem,
    n: u32,
    limits: DeriveLimits,
    threads: usize,
    chunk: Option<usize>,
    keys: bool,
) -> Outcome {
    let mut engine = Engine::new(c, threads).expect("engine").with_keys(keys);
    if let Some(k) = chunk {
        engine = engine.with_min_chunk(k);
    }
    let opts = DeriveOptions {
        iterations: n,
        seed: 3,
        limits,
    };
    let mut seen = Vec::new();
    let r = engine.derive(&opts, &mut |s| {
        seen.push((s.iteration, s.modules, s.param_words, s.cumulative_modules))
    });
    let r = r.map(|d| {
        (
            d.string.symbols().collect(),
            d.string
                .iter()
                .flat_map(|(_, p)| p.iter().map(|x| x.to_bits()))
                .collect(),
            d.string.keys().to_vec(),
        )
    });
    (seen, r)
}

fn same_as_one_thread(c: &CompiledSystem, what: &str, n: u32, limits: DeriveLimits, keys: bool) {
    let base = derive(c, n, limits, 1, None, keys);
    for threads in [2, 3, 4] {
        for chunk in [None, Some(1), Some(3), Some(16), Some(200)] {
            let got = derive(c, n, limits, threads, chunk, keys);
            assert!(
                got.0 == base.0,
                "{what}: progress differs with {threads} threads, chunk {chunk:?}:\n{:?}\n{:?}",
                got.0,
                base.0
            );
            assert!(
                got.1 == base.1,
                "{what}: the result differs with {threads} threads, chunk {chunk:?}: {:?} against {:?}",
                got.1.as_ref().err(),
                base.1.as_ref().err()
            );
        }
    }
}

/// Identity keys written by every piece as one thread writes them.
#[test]
fn keys_match_one_thread() {
    for (file, n) in [("hilbert3d.grm", 3), ("row_of_trees.grm", 6)] {
        let c = example(file, None);
        same_as_one_thread(&c, file, n, DeriveLimits::default(), true);
    }
}

/// The last `A` overflows first (at step 14) and all its descendants
/// with it, in many pieces; the `A`s before it would overflow later: the
/// error is step 14's first module, as on one thread.
#[test]
fn the_earliest_step_and_lowest_position_fail() {
    let c = inline(
        "system S { angle = 30; axiom A(1) B A(1e8) B B A(1e4) B A(1e12); \
         A(x) -> A(x * 100) B A(x * 10) +; B -> B B; }",
    );
    let base = derive(&c, 18, DeriveLimits::default(), 1, None, false);
    let Err(DeriveError::Runtime(e)) = &base.1 else {
        panic!("{:?}", base.1.as_ref().map(|r| r.0.len()))
    };
    assert_eq!(e.iteration, 14);
    assert!(e.position > 0);
    same_as_one_thread(&c, "overflow", 18, DeriveLimits::default(), false);
    same_as_one_thread(&c, "overflow, keyed", 18, DeriveLimits::default(), true);
}

/// A limit passed in the middle of the steps a fork would run: the
/// steps before it are reported, then the same error.
#[test]
fn limits_inside_the_fork() {
    let c = inline(
        "system S { angle = 30; axiom A(1) B + A(2); A(x) -> A(x * 0.5) [ + B ] A(x * 0.5); B -> B; }",
    );
    for limits in [
        DeriveLimits {
            max_modules: 30_000,
            ..DeriveLimits::default()
        },
        DeriveLimits {
            max_bytes: 400_000,
            ..DeriveLimits::default()
        },
    ] {
        let base = derive(&c, 16, limits, 1, None, false);
        assert!(base.1.is_err(), "{limits:?}");
        same_as_one_thread(&c, "limits", 16, limits, false);
    }
}

/// Many more steps than one fork runs (32), on a string that grows by
/// one module a step: forks follow each other.
#[test]
fn long_derivations() {
    let c = inline("system S { angle = 30; axiom A B B B B B B B B; A -> A +; B -> B; }");
    same_as_one_thread(&c, "long", 100, DeriveLimits::default(), false);
    let c =
        inline("system S { angle = 30; axiom A A A A A A A A A A A A A A A A; A -> A [ - ] A; }");
    same_as_one_thread(&c, "doubling", 11, DeriveLimits::default(), false);
}

//! `Engine::derive` on several threads where no symbol needs a decision:
//! each chunk's counts come from symbol histograms carried from the step
//! before (no count pass; `src/expand.rs`), the next step's chunks being
//! the images of this step's. The same strings as one thread, bit for bit,
//! for 1 to 4 threads and any chunking: chunks whose images balance, ones
//! that must be split afresh (one symbol grows, its neighbour does not),
//! and a string that shrinks.

mod common;

use common::*;
use grm_compile::CompiledSystem;
use grm_derive::{DeriveOptions, Engine, ModuleString};

type Bits = (Vec<u32>, Vec<u32>, Vec<u32>);

fn bits(s: &ModuleString) -> Bits {
    (
        s.symbols().collect(),
        s.parts().starts.to_vec(),
        s.parts().params.iter().map(|x| x.to_bits()).collect(),
    )
}

/// The final string's bits and every string's (length, parameter words).
fn derive(
    c: &CompiledSystem,
    n: u32,
    threads: usize,
    chunk: Option<usize>,
) -> (Bits, Vec<(u64, u64)>) {
    let mut engine = Engine::new(c, threads).expect("engine");
    if let Some(k) = chunk {
        engine = engine.with_min_chunk(k);
    }
    let mut opts = DeriveOptions::from_system(c);
    opts.iterations = n;
    // Twice: the second derivation reuses the first's buffers.
    let mut lens = Vec::new();
    let first = engine.derive(&opts, &mut |_| {}).expect("derives");
    engine.recycle(first.string);
    let d = engine
        .derive(&opts, &mut |s| lens.push((s.modules, s.param_words)))
        .expect("derives");
    (bits(&d.string), lens)
}

fn same_for_all_threads(c: &CompiledSystem, what: &str, n: u32, min_len: usize) {
    let base = derive(c, n, 1, None);
    assert!(base.0.0.len() >= min_len, "{what}: {}", base.0.0.len());
    for threads in [2, 3, 4] {
        for chunk in [None, Some(1), Some(7), Some(64), Some(1000)] {
            let got = derive(c, n, threads, chunk);
            assert!(
                got.1 == base.1,
                "{what}: lengths differ with {threads} threads, chunk {chunk:?}"
            );
            assert!(
                got.0 == base.0,
                "{what}: the string differs with {threads} threads, chunk {chunk:?}"
            );
        }
    }
}

#[test]
fn examples() {
    for (file, n) in [
        ("row_of_trees.grm", 6),
        ("koch_island.grm", 3),
        ("hilbert3d.grm", 3),
        ("bracketed_plant.grm", 4),
        ("ternary_tree.grm", 6),
    ] {
        same_for_all_threads(&example(file, None), file, n, 2000);
    }
}

/// `A` doubles, `B` stays: the chunks' images drift apart and are split
/// afresh. The turns' angles are implicit, so the strings walk their
/// stored words (no starts): each chunk's first word comes from its
/// histogram too.
#[test]
fn uneven_growth() {
    let c = inline(
        "system S { angle = 30; axiom B(1) + A(1) B(2) B(3) - A(2) B(4); \
         A(x) -> A(x * 2) + A(x + 1); B(x) -> B(x * 0.5) -; }",
    );
    same_for_all_threads(&c, "uneven", 12, 8000);
}

/// Modules that vanish: every chunk shrinks (some to nothing) while
/// others grow.
#[test]
fn shrinking() {
    let c = inline(
        "system S { angle = 30; axiom A(1) C C C A(2) C; \
         A(x) -> A(x * 2) C + A(x + 1) C C; C -> ; }",
    );
    same_for_all_threads(&c, "shrinking", 12, 4000);
}

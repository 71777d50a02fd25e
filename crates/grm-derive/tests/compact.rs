//! Compact strings (`ModuleString`, "Compact storage"): the words every
//! production writes as the same constants are not stored, and a string
//! that then stores no word keeps no starts. They read exactly as the
//! strings of an engine that stores every word.

mod common;

use common::*;
use grm_derive::{DeriveError, DeriveLimits, DeriveOptions, Engine, ModuleString};

/// Everything a reader can see, parameters as bits.
fn seen(s: &ModuleString) -> (Vec<u32>, Vec<u32>, Vec<u32>, Vec<u32>, usize) {
    let p = s.parts();
    (
        p.syms.to_vec(),
        p.starts.to_vec(),
        p.params.iter().map(|x| x.to_bits()).collect(),
        p.keys.to_vec(),
        s.param_words(),
    )
}

const CASES: &[(&str, u32)] = &[
    ("koch_island.grm", 3),
    ("bracketed_plant.grm", 3),
    ("hilbert3d.grm", 2),
    ("row_of_trees.grm", 5),
    ("stochastic_plant.grm", 4),
    ("ternary_tree.grm", 4),
    ("context_plant_a.grm", 5),
    ("calder_tree.grm", 5),
];

#[test]
fn compact_strings_read_as_stored_ones() {
    for &(file, n) in CASES {
        let c = example(file, None);
        for threads in [1, 2] {
            let compact = Engine::new(&c, threads).expect("engine").with_min_chunk(7);
            let flat = Engine::new(&c, threads)
                .expect("engine")
                .with_min_chunk(7)
                .with_implicit_words(false);
            let opts = DeriveOptions {
                iterations: n,
                ..DeriveOptions::from_system(&c)
            };
            let a = compact.derive(&opts, &mut |_| {}).expect("derives");
            let b = flat.derive(&opts, &mut |_| {}).expect("derives");
            let what = format!("{file} n={n}, {threads} threads");
            assert_eq!(seen(&a.string), seen(&b.string), "{what}");
            assert_eq!(a.string, b.string, "{what}");
            assert_eq!(
                a.string.to_text(&c.symbol_names),
                b.string.to_text(&c.symbol_names)
            );
            for (x, y) in a.stats.iter().zip(&b.stats) {
                assert_eq!(
                    (x.modules, x.param_words),
                    (y.modules, y.param_words),
                    "{what}"
                );
            }
            for i in 0..a.string.len() {
                assert_eq!(a.string.get(i), b.string.get(i), "{what}: module {i}");
            }
            // Step by step, in either layout, into either engine.
            let (mut sa, mut sb) = (
                compact.axiom(opts.seed).unwrap(),
                flat.axiom(opts.seed).unwrap(),
            );
            for it in 1..=n.min(3) {
                let l = DeriveLimits::default();
                let next_a = compact
                    .step(&sb, it, opts.seed, &l)
                    .expect("flat into compact");
                let next_b = flat
                    .step(&sa, it, opts.seed, &l)
                    .expect("compact into flat");
                assert_eq!(seen(&next_a), seen(&next_b), "{what}: step {it}");
                (sa, sb) = (next_a, next_b);
            }
        }
    }
}

/// The classic scenes store no word at all (every word is a constant of
/// its symbol: `F`'s default length, the turns' angle), so a module costs
/// its symbol word alone; the row of trees stores `F`'s computed length
/// and no start (its words are walked).
#[test]
fn the_classic_scenes_store_their_symbols_alone() {
    for (file, n, stored_max) in [
        ("koch_island.grm", 4, 4.1),
        ("bracketed_plant.grm", 4, 4.1),
        ("hilbert3d.grm", 3, 4.1),
        // `F`'s length, walked (no start a module).
        ("row_of_trees.grm", 6, 6.0),
    ] {
        let c = example(file, None);
        let e = Engine::new(&c, 1).expect("engine");
        let opts = DeriveOptions {
            iterations: n,
            ..DeriveOptions::from_system(&c)
        };
        let d = e.derive(&opts, &mut |_| {}).expect("derives");
        let per = d.string.heap_bytes() as f64 / d.string.len() as f64;
        assert!(per <= stored_max, "{file}: {per:.2} bytes a module");
        let flat = Engine::new(&c, 1)
            .expect("engine")
            .with_implicit_words(false)
            .derive(&opts, &mut |_| {})
            .expect("derives");
        let flat_per = flat.string.heap_bytes() as f64 / flat.string.len() as f64;
        assert!(
            flat_per >= 10.0,
            "{file}: stored, {flat_per:.2} bytes a module"
        );
    }
}

/// A string whose module carries other words than the constants the
/// compact engine leaves implicit is refused (R0208) there; the engine that
/// stores every word rewrites it, copying the words.
#[test]
fn other_constants_are_refused_by_the_compact_engine() {
    let c = inline("system S { angle = 90; axiom F + F; F -> F - F; }");
    let plus = c.symbol_names.iter().position(|n| n == "+").unwrap() as u32;
    let f = c.symbol_names.iter().position(|n| n == "F").unwrap() as u32;
    let e = Engine::new(&c, 1).expect("engine");
    let ax = e.axiom(0).expect("axiom");
    let fw = ax.params_of(0).to_vec();
    let mut s = ModuleString::new();
    s.push(f, &fw);
    s.push(plus, &[45.0]);
    let err = e
        .step(&s, 1, 0, &DeriveLimits::default())
        .expect_err("other angle");
    assert!(matches!(err, DeriveError::InvalidInput(_)), "{err:?}");
    let flat = Engine::new(&c, 1)
        .expect("engine")
        .with_implicit_words(false);
    let out = flat
        .step(&s, 1, 0, &DeriveLimits::default())
        .expect("stored");
    assert_eq!(out.get(out.len() - 1), (plus, &[45.0][..]));
    // The same angle as the productions write is taken.
    let mut s = ModuleString::new();
    s.push(f, &fw);
    s.push(plus, &[90.0]);
    let out = e
        .step(&s, 1, 0, &DeriveLimits::default())
        .expect("same angle");
    assert_eq!(out, flat.step(&s, 1, 0, &DeriveLimits::default()).unwrap());
}

/// A module pushed onto a compact string with other words than its
/// symbol's implicit ones turns the string into the stored layout; the
/// modules before it read the same.
#[test]
fn pushing_other_words_stores_every_word() {
    let c = example("bracketed_plant.grm", None);
    let e = Engine::new(&c, 1).expect("engine");
    let opts = DeriveOptions {
        iterations: 2,
        ..DeriveOptions::from_system(&c)
    };
    let mut s = e.derive(&opts, &mut |_| {}).expect("derives").string;
    let before = seen(&s);
    let small = s.heap_bytes();
    let (sym, p) = s.get(1);
    let p: Vec<f32> = p.iter().map(|x| x + 1.0).collect();
    s.push(sym, &p);
    assert!(s.is_well_formed());
    assert_eq!(s.get(s.len() - 1), (sym, &p[..]));
    let after = seen(&s);
    assert_eq!(after.0[..before.0.len()], before.0[..]);
    assert_eq!(after.2[..before.2.len()], before.2[..]);
    assert!(s.heap_bytes() > small);
    // Extending by another compact string keeps every module.
    let mut t = ModuleString::new();
    t.push(sym, &p);
    let other = e.derive(&opts, &mut |_| {}).expect("derives").string;
    t.extend_from(&other);
    assert_eq!(t.len(), 1 + other.len());
    for i in 0..other.len() {
        assert_eq!(t.get(i + 1), other.get(i));
    }
}

/// A walked string (the row of trees: `F` stores its length, the turns
/// nothing, no starts) read in any order, stepped on from the middle of a
/// derivation, and grown by `push`, reads as the stored layout does.
#[test]
fn walked_strings_read_in_any_order() {
    let c = example("row_of_trees.grm", None);
    let opts = DeriveOptions {
        iterations: 4,
        ..DeriveOptions::from_system(&c)
    };
    let e = Engine::new(&c, 1).expect("engine");
    let flat = Engine::new(&c, 1)
        .expect("engine")
        .with_implicit_words(false);
    let a = e.derive(&opts, &mut |_| {}).expect("derives").string;
    let b = flat.derive(&opts, &mut |_| {}).expect("derives").string;
    assert!(a.is_well_formed());
    assert!(a.heap_bytes() < b.heap_bytes() * 6 / 10);
    // Backwards, then every 7th: the marks give the same words as the walk.
    for i in (0..a.len()).rev().chain((0..a.len()).step_by(7)) {
        assert_eq!(a.get(i), b.get(i), "module {i}");
    }
    // On from the walked string, into either engine, 1 and 3 threads.
    for threads in [1, 3] {
        let e3 = Engine::new(&c, threads).expect("engine").with_min_chunk(5);
        let l = DeriveLimits::default();
        let x = e3.step(&a, 5, opts.seed, &l).expect("walked into compact");
        let y = flat.step(&a, 5, opts.seed, &l).expect("walked into flat");
        assert_eq!(seen(&x), seen(&y), "{threads} threads");
    }
    // Pushing a module of the right width keeps it walked; another width
    // stores starts; both read the same.
    let mut s = a.clone();
    let (f, p) = a.get(0);
    s.push(f, p);
    assert_eq!(s.get(s.len() - 1), (f, p));
    assert!(s.is_well_formed());
    let mut t = s.clone();
    t.push(f, &[1.0, 2.0]);
    assert!(t.is_well_formed());
    assert_eq!(t.get(t.len() - 1), (f, &[1.0, 2.0][..]));
    for i in 0..s.len() {
        assert_eq!(t.get(i), s.get(i), "module {i}");
    }
}

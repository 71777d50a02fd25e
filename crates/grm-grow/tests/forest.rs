//! Forests through grm-grow (`grm_grow::forest::grow`) on the CPU: every
//! tree's string is what deriving it alone gives, interpreted as its own
//! turtle interprets it, whatever the threads; the forest's module and
//! memory limits stop it with the tree that took it over; a tree's own
//! error names the tree.

mod common;
use common::*;

use grm_derive::{DeriveLimits, ModuleString};
use grm_grow::forest::{Forest, ForestError, ForestOptions, ForestTree, Ran, grow, parallel_map};
use grm_grow::{Grower, Record};

fn trees<'a>(
    system: &'a grm_sema::System,
    compiled: &'a grm_compile::CompiledSystem,
    n: u32,
    iterations: u32,
) -> Vec<ForestTree<'a>> {
    (0..n)
        .map(|k| ForestTree {
            system,
            compiled,
            iterations,
            seed: 10 + k,
        })
        .collect()
}

fn keep_string(_: usize, s: &ModuleString) -> ModuleString {
    s.clone()
}

fn grow_cpu(
    trees: &[ForestTree<'_>],
    opts: &ForestOptions,
) -> Result<Forest<ModuleString>, ForestError> {
    grow(trees, opts, &keep_string, &mut |_| {})
}

#[test]
fn every_tree_is_its_own_derivation() {
    let checked = checked("stochastic_plant.grm");
    let c = compile(&checked);
    let sys = system(&checked);
    let forest = trees(sys, &c, 7, 4);
    for threads in [1, 3, 0] {
        let opts = ForestOptions {
            threads,
            interpret: true,
            ..ForestOptions::default()
        };
        let f = grow_cpu(&forest, &opts).expect("grows");
        assert_eq!(f.trees.len(), 7);
        let mut modules = 0;
        let mut produced = 0;
        for (k, (t, g)) in forest.iter().zip(&f.trees).enumerate() {
            let alone = Grower::new(&c, 1, Record::default())
                .expect("engine")
                .derive(&options(t.iterations, t.seed), &mut |_| {})
                .expect("derives");
            assert_eq!(g.kept.parts().syms, alone.string.parts().syms, "tree {k}");
            assert_eq!(
                g.kept.parts().params,
                alone.string.parts().params,
                "tree {k}"
            );
            assert_eq!(g.kept.keys(), alone.string.keys(), "tree {k}");
            assert_eq!(g.modules, alone.string.len() as u64);
            let i = grm_turtle::interpret(sys, &c.settings, &alone.string).expect("interprets");
            let gi = g.interpretation.as_ref().expect("interpreted");
            assert_eq!(gi.bones.len(), i.bones.len(), "tree {k}");
            assert_eq!(gi.bounds, i.bounds, "tree {k}");
            modules += g.modules;
            produced += alone.stats.last().expect("stats").cumulative_modules;
        }
        assert_eq!((f.modules, f.produced), (modules, produced));
        let workers = if threads == 0 {
            std::thread::available_parallelism()
                .map_or(1, |c| c.get())
                .min(7)
        } else {
            threads
        };
        assert!(matches!(f.ran, Ran::Cpu { workers: w } if w == workers));
    }
    // Without interpretation none is made.
    let f = grow_cpu(&forest, &ForestOptions::default()).expect("grows");
    assert!(f.trees.iter().all(|t| t.interpretation.is_none()));
}

#[test]
fn the_forests_limits_name_the_tree_that_passed_them() {
    let checked = checked("stochastic_plant.grm");
    let c = compile(&checked);
    let sys = system(&checked);
    let forest = trees(sys, &c, 6, 4);
    let f = grow_cpu(&forest, &ForestOptions::default()).expect("grows");
    let largest = f.trees.iter().map(|t| t.modules).max().expect("trees");
    // Each tree fits; all of them together do not (R0201 of the forest).
    let opts = ForestOptions {
        threads: 1,
        limits: DeriveLimits {
            max_modules: f.modules - 1,
            ..DeriveLimits::default()
        },
        ..ForestOptions::default()
    };
    match grow_cpu(&forest, &opts) {
        Err(ForestError::ModuleLimit {
            tree,
            modules,
            limit,
        }) => {
            assert_eq!(tree, 5, "one thread: the last tree takes it over");
            assert_eq!((modules, limit), (f.modules, f.modules - 1));
        }
        other => panic!("{other:?}"),
    }
    // One tree alone over it: that tree's own derivation error (a small
    // tree first, within the limit, then the largest).
    let big = f
        .trees
        .iter()
        .position(|t| t.modules == largest)
        .expect("the largest");
    let small = f
        .trees
        .iter()
        .position(|t| t.modules < largest)
        .expect("a smaller tree");
    let two = [forest[small], forest[big]];
    let opts = ForestOptions {
        threads: 1,
        limits: DeriveLimits {
            max_modules: largest - 1,
            ..DeriveLimits::default()
        },
        ..ForestOptions::default()
    };
    match grow_cpu(&two, &opts) {
        Err(ForestError::Derive { tree, error }) => {
            assert_eq!(tree, 1);
            assert!(
                matches!(error, grm_derive::DeriveError::ModuleLimit { .. }),
                "{error}"
            );
        }
        other => panic!("{other:?}"),
    }
    // The interpretations together over the memory limit (each string
    // and derivation far under it): R0202, counted from the strings.
    let need: u64 = f
        .trees
        .iter()
        .map(|t| grm_geom::budget::count_string(sys, &t.kept).bytes)
        .sum();
    let opts = ForestOptions {
        threads: 1,
        interpret: true,
        limits: DeriveLimits {
            max_bytes: need - 1,
            ..DeriveLimits::default()
        },
        ..ForestOptions::default()
    };
    match grow_cpu(&forest, &opts) {
        Err(ForestError::MemoryLimit {
            tree,
            footprint,
            limit,
        }) => {
            assert_eq!(tree, Some(5));
            assert_eq!((footprint.bytes, limit), (need, need - 1));
        }
        other => panic!("{other:?}"),
    }
    // Not interpreted, the same limit holds nothing back.
    let opts = ForestOptions {
        interpret: false,
        ..opts
    };
    grow_cpu(&forest, &opts).expect("the strings alone fit");
}

#[test]
fn a_mixed_forest_keeps_each_trees_system_and_text() {
    let plant = checked("stochastic_plant.grm");
    let hilbert = checked("hilbert3d.grm");
    let (cp, ch) = (compile(&plant), compile(&hilbert));
    let forest = vec![
        ForestTree {
            system: system(&plant),
            compiled: &cp,
            iterations: 3,
            seed: 1,
        },
        ForestTree {
            system: system(&hilbert),
            compiled: &ch,
            iterations: 2,
            seed: 0,
        },
    ];
    let text = |k: usize, s: &ModuleString| {
        grm_compile::text::string_text(
            if k == 0 {
                &plant.program
            } else {
                &hilbert.program
            },
            forest[k].system,
            s.iter(),
        )
    };
    let f = grow(
        &forest,
        &ForestOptions {
            interpret: true,
            ..ForestOptions::default()
        },
        &text,
        &mut |_| {},
    )
    .expect("grows");
    for (k, t) in forest.iter().enumerate() {
        let alone = Grower::new(t.compiled, 1, Record::default())
            .expect("engine")
            .derive(&options(t.iterations, t.seed), &mut |_| {})
            .expect("derives");
        assert_eq!(f.trees[k].kept, text(k, &alone.string), "tree {k}");
    }
}

#[test]
fn parallel_map_keeps_the_order() {
    for threads in [0, 1, 2, 7] {
        let got = parallel_map(50, threads, |i| i * i);
        assert_eq!(got, (0..50).map(|i| i * i).collect::<Vec<_>>());
    }
    assert!(parallel_map(0, 3, |i| i).is_empty());
}

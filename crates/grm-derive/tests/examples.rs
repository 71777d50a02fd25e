//! Every derive-mode system of every example derives with its own settings,
//! and the stochastic plant keeps its documented bounds.

mod common;

use common::*;
use grm_derive::{DeriveOptions, derive};

#[test]
fn every_derive_example_derives() {
    let mut n = 0;
    for entry in std::fs::read_dir(repo().join("examples"))
        .expect("examples/")
        .flatten()
    {
        let path = entry.path();
        if path.extension().is_none_or(|e| e != "grm") {
            continue;
        }
        let text = std::fs::read_to_string(&path).expect("readable");
        let (_, checked) = grm_sema::check_text(&path.display().to_string(), &text);
        assert!(!checked.has_errors(), "{}", path.display());
        let p = &checked.program;
        for sys in p.systems.iter().filter(|s| s.loc.file == p.root) {
            if sys.mode != grm_sema::Mode::Derive {
                continue;
            }
            let c = grm_compile::compile(p, sys, &p.default_params()).expect("compiles");
            let d = derive(&c, &DeriveOptions::from_system(&c), 2, &mut |_| {})
                .unwrap_or_else(|e| panic!("{}: {}: {e}", path.display(), sys.name));
            assert!(d.string.is_well_formed());
            assert!(!d.string.is_empty());
            assert_eq!(d.stats.len() as u32, c.settings.iterations + 1);
            n += 1;
        }
    }
    assert!(n >= 10, "only {n} derive systems");
}

#[test]
fn stochastic_plant_bounds() {
    let c = example("stochastic_plant.grm", None);
    let names = &c.symbol_names;
    for seed in 0..20 {
        let s = strings(&c, 5, seed, 1);
        let last = &s[5];
        // 3^n + 3 (3^n - 1) / 2 ..= 5^n + 6 (5^n - 1) / 4 at n = 5.
        assert!(
            (606..=7811).contains(&last.len()),
            "seed {seed}: {}",
            last.len()
        );
        let mut depth = 0i64;
        for i in 0..last.len() {
            let name = &names[last.sym(i) as usize];
            match name.as_str() {
                "[" => {
                    depth += 1;
                    let next = &names[last.sym(i + 1) as usize];
                    assert!(next == "+" || next == "-", "seed {seed}: `[` then {next}");
                }
                "]" => depth -= 1,
                _ => {}
            }
            assert!(depth >= 0);
        }
        assert_eq!(depth, 0);
    }
}

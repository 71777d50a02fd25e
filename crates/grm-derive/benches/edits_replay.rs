//! Replay cost of persistent edits in derive mode (issue 27: near zero with
//! no edits, small with many; docs/benchmarks.md, "Persistent edits").
//!
//! The tree: a stochastic, parametric, bracketed plant (below) derived to
//! about 100,000 modules. Cases, in alternating order round by round, each
//! on one thread (and `none` and `mix` on two):
//!
//! - `none`: `Engine::derive`, no plan: the plain engine;
//! - `one`: one edit (remove a module of the last string but one);
//! - `absent`: 1,000 edits whose keys no module has (the lookup's cost:
//!   every module written tests a filter bit);
//! - `mix`: 1,000 edits on keys drawn from every string of the plain
//!   derivation (seeded): 200 each of remove, set (`w`), offset (`len`),
//!   force (alternative 1 or 2) and pin (another drawn key);
//!
//! Each figure is the median of the rounds; the ratio is the median of the
//! per-round ratios to `none` (paired, robust to a busy machine). With
//! `--instructions` the bench runs itself under `valgrind --tool=
//! cachegrind` per case with 1 and 3 derivations and prints the difference
//! over 2: one derivation's instructions without the setup.
//!
//! Run: `cargo bench -p grm-derive --bench edits_replay [-- ROUNDS]
//! [--instructions]`.

use grm_testkit::bench::{
    arg_value, cachegrind_instructions, load, print_instructions, print_medians,
};
use std::hint::black_box;
use std::time::Instant;

use grm_compile::CompiledSystem;
use grm_derive::{DeriveLimits, DeriveOptions, EditAction, EditPlan, Engine, SlotTarget, ValueOp};
use grm_testkit::Rng;

/// The plant: ~107,000 modules at 9 iterations.
pub const PLANT: &str = "system Plant {
    seed = 7;
    module A(len: float, w: float);
    axiom A(1, 0.1);
    A(l, w) -> (2) !(w) F(l) [ +(30) A(l * 0.8, w * 0.7) ] [ -(25) A(l * 0.7, w * 0.7) ] /(137) A(l * 0.9, w * 0.9);
    A(l, w) -> (1) !(w) F(l) /(90) A(l * 0.95, w * 0.9);
    F(l) -> F(l * 1.05);
}";

pub const ITERATIONS: u32 = 14;

pub fn compiled() -> CompiledSystem {
    let (_, checked) = grm_sema::check_with("plant.grm", PLANT, &grm_sema::MemLoader::new());
    assert!(!checked.has_errors(), "{:?}", checked.diagnostics);
    let p = &checked.program;
    grm_compile::compile(
        p,
        p.default_system().expect("a system"),
        &p.default_params(),
    )
    .expect("compiles")
}

fn options(c: &CompiledSystem) -> DeriveOptions {
    DeriveOptions {
        iterations: ITERATIONS,
        seed: c.settings.seed,
        limits: DeriveLimits::default(),
    }
}

const CASES: &[&str] = &["none", "one", "absent", "mix", "none/2", "mix/2"];

/// The plans of the cases.
fn plans(c: &CompiledSystem) -> Vec<(&'static str, EditPlan, usize)> {
    // Every string's keys, the plain derivation's.
    let e = Engine::new(c, 1).expect("engine");
    let mut strings = vec![e.axiom(c.settings.seed).expect("axiom")];
    for it in 1..=ITERATIONS {
        let next = e
            .step(
                strings.last().expect("a string"),
                it,
                c.settings.seed,
                &DeriveLimits::default(),
            )
            .expect("step");
        strings.push(next);
    }
    let mut keys: Vec<u32> = strings.iter().flat_map(|s| s.keys().to_vec()).collect();
    keys.sort_unstable();
    keys.dedup();
    let mut rng = Rng::new(27);
    rng.shuffle(&mut keys);
    let slot = |name: &str| -> Vec<SlotTarget> {
        c.symbol_names
            .iter()
            .map(|n| match (n.as_str(), name) {
                ("A", "len") | ("F", "len") => SlotTarget {
                    word: 0,
                    words: 1,
                    boolean: false,
                },
                ("A", "w") => SlotTarget {
                    word: 1,
                    words: 1,
                    boolean: false,
                },
                _ => SlotTarget::default(),
            })
            .collect()
    };
    let mut mix = EditPlan::new();
    let (len, w) = (mix.add_slot(slot("len")), mix.add_slot(slot("w")));
    for (i, &k) in keys[..1000].iter().enumerate() {
        let id = i as u32 + 1;
        let action = match i % 5 {
            0 => EditAction::Remove,
            1 => EditAction::Value {
                slot: w,
                op: ValueOp::Set(0.05),
            },
            2 => EditAction::Value {
                slot: len,
                op: ValueOp::Offset(0.25),
            },
            3 => EditAction::Force(1 + (i as u32 / 5) % 2),
            _ => EditAction::Pin(keys[1000 + i]),
        };
        mix.add(k, id, action);
    }
    let mut absent = EditPlan::new();
    let have: std::collections::HashSet<u32> = keys.iter().copied().collect();
    let mut k = 0x9e37_79b9u32;
    let mut n = 0;
    while n < 1000 {
        k = k.wrapping_mul(0x0100_0193).wrapping_add(0x6b43_a9b5);
        if !have.contains(&k) {
            absent.add(k, n + 1, EditAction::Remove);
            n += 1;
        }
    }
    let before_last = &strings[ITERATIONS as usize - 1];
    let mut one = EditPlan::new();
    one.add(
        before_last.keys()[before_last.len() / 2],
        1,
        EditAction::Remove,
    );
    vec![
        ("none", EditPlan::new(), 1),
        ("one", one, 1),
        ("absent", absent, 1),
        ("mix", mix.clone(), 1),
        ("none/2", EditPlan::new(), 2),
        ("mix/2", mix, 2),
    ]
}

/// One derivation of `plan` on `threads`: the final length and the edits
/// that met a module.
fn run(engine: &Engine<'_>, opts: &DeriveOptions) -> usize {
    let (d, outcome) = engine.derive_edited(opts, &mut |_| {}).expect("derives");
    let n = d.string.len();
    engine.recycle(d.string);
    black_box(outcome);
    n
}

/// This bench's instructions for one case and `n` derivations (cachegrind).
fn instructions(case: &str, n: usize) -> Option<u64> {
    cachegrind_instructions(&["--only", case, "--derivations", &n.to_string()])
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let value = |name: &str| arg_value(&args, name);
    let c = compiled();
    let opts = options(&c);
    let plans = plans(&c);
    let engines: Vec<(&str, Engine<'_>)> = plans
        .iter()
        .map(|(name, plan, threads)| {
            let e = Engine::new(&c, *threads)
                .expect("engine")
                .with_edits(plan.clone());
            (*name, e)
        })
        .collect();
    if let Some(case) = value("--only") {
        // One case, `--derivations` times (under cachegrind).
        let n: usize = value("--derivations")
            .and_then(|s| s.parse().ok())
            .unwrap_or(1);
        let (_, e) = engines
            .iter()
            .find(|(name, _)| *name == case)
            .expect("case");
        for _ in 0..n {
            black_box(run(e, &opts));
        }
        return;
    }
    let rounds: usize = args.iter().find_map(|a| a.parse().ok()).unwrap_or(21);
    println!(
        "derive-mode edits replay: {} iterations, load {}",
        ITERATIONS,
        load()
    );
    for (name, e) in &engines {
        let (d, outcome) = e.derive_edited(&opts, &mut |_| {}).expect("derives");
        let met = e.edit_plan().map_or(0, |p| {
            p.keys().filter(|&k| outcome.hits(k).is_some()).count()
        });
        println!(
            "  {name:<8} {:>8} modules, {:>4} keys with edits, {met:>4} met",
            d.string.len(),
            e.edit_plan().map_or(0, EditPlan::len)
        );
    }
    let mut times: Vec<Vec<f64>> = vec![Vec::new(); engines.len()];
    let mut ratios: Vec<Vec<f64>> = vec![Vec::new(); engines.len()];
    for round in 0..rounds {
        let mut order: Vec<usize> = (0..engines.len()).collect();
        if round % 2 == 1 {
            order.reverse();
        }
        let mut t = vec![0.0; engines.len()];
        for &k in &order {
            let start = Instant::now();
            black_box(run(&engines[k].1, &opts));
            t[k] = start.elapsed().as_secs_f64() * 1e3;
        }
        for k in 0..engines.len() {
            times[k].push(t[k]);
            let base = if engines[k].0.ends_with("/2") {
                t[4]
            } else {
                t[0]
            };
            ratios[k].push(t[k] / base);
        }
    }
    let names: Vec<&str> = engines.iter().map(|(name, _)| *name).collect();
    print_medians(rounds, "none on as many threads", &names, &times, &ratios);
    if args.iter().any(|a| a == "--instructions") {
        print_instructions(
            "derivation",
            CASES.iter().copied().filter(|c| !c.ends_with("/2")),
            instructions,
        );
    }
}

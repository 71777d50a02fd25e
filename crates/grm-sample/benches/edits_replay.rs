//! Replay cost of persistent edits in sample mode with many edits (issue
//! 27; docs/benchmarks.md, "Persistent edits"), as grm-derive's
//! `edits_replay` bench measures derive mode.
//!
//! The model: the Calder tree (examples/calder_tree.grm with its curves),
//! Calder's playground schedule, default weights, seed 0, one thread.
//! Cases:
//!
//! - `none`: the sampler without a plan;
//! - `absent`: 1,000 edits whose keys no module has (the lookups' cost:
//!   every module written tests a filter bit; the same search and model
//!   as `none`);
//! - `remove`: up to 1,000 removals of modules the geometry phase wrote
//!   (each a leaf's or trunk's transform, material or mesh): the search
//!   is `none`'s, every edit meets its module;
//! - `mix`: 1,000 edits on the keys of the model `none` samples (its
//!   string's modules and its tree's expansions, shuffled, seeded): 200
//!   each of remove (a module the geometry phase wrote: a leaf's or a
//!   trunk's transform, material or mesh), set and offset (`F`'s length:
//!   of a bone, or of every bone below an expansion), force (a
//!   `branchOrLeaf` or `maybeBranch` to the alternative it took) and pin
//!   (an expansion to its own key: its draws then come from its key, not
//!   the particle's place in the search). The edits
//!   change the model, so the search differs from `none`'s: the ratio is
//!   the replay's cost and the edited search's together.
//!
//! One run is one `Sampler::sample`. With `--instructions` the bench runs
//! itself under `valgrind --tool=cachegrind` per case with 1 and 3 runs
//! and prints the difference over 2: one run's instructions without the
//! setup (`Sampler::new`, which computes the expected directions, and the
//! plan, drawn from a plain run). Without it: the median wall time of
//! alternating rounds and the median per-round ratio to `none`.
//!
//! Run: `cargo bench -p grm-sample --bench edits_replay [-- ROUNDS]
//! [--instructions]`.

use grm_testkit::bench::{
    arg_value, cachegrind_instructions, load, print_instructions, print_medians,
};
use std::hint::black_box;
use std::path::PathBuf;
use std::time::Instant;

use grm_compile::CompiledSystem;
use grm_guide::Curves;
use grm_sample::{
    EditPlan, ExpectedOptions, NodeKind, Objective, SampleOptions, SampleResult, Sampler, Schedule,
    edits::{EditAction, SlotTarget, ValueOp},
};
use grm_testkit::Rng;

const CASES: &[&str] = &["none", "absent", "remove", "mix"];
const EDITS: usize = 1000;

fn options() -> SampleOptions {
    SampleOptions {
        seed: 0,
        schedule: Schedule::calder_playground(),
        threads: 1,
        ..SampleOptions::default()
    }
}

/// The model `result` shows, as the edits' targets: per group, keys in a
/// seeded shuffle.
struct Keys {
    /// The modules the geometry phase wrote (a leaf's or a trunk's
    /// transforms, material and mesh): removing one leaves the skeleton.
    geometry: Vec<u32>,
    /// The bones (`F`).
    bones: Vec<u32>,
    /// Expansions of a symbol with two or more alternatives, each with
    /// the alternative it took (from 1).
    choices: Vec<(u32, u32)>,
    /// Expansions but the axiom's.
    expanded: Vec<u32>,
    /// Every key of the model.
    all: Vec<u32>,
}

fn model_keys(c: &CompiledSystem, result: &SampleResult) -> Keys {
    let m = &result.models[0];
    let f = c.symbol_names.iter().position(|n| n == "F").expect("F") as u32;
    let keys = m.string.keys();
    let mut k = Keys {
        geometry: Vec::new(),
        bones: (0..m.string.len())
            .filter(|&i| m.string.sym(i) == f)
            .map(|i| keys[i])
            .collect(),
        choices: Vec::new(),
        expanded: Vec::new(),
        all: keys.to_vec(),
    };
    for n in &m.tree.nodes {
        k.all.push(n.key);
        if n.kind == NodeKind::Geometry {
            k.geometry
                .extend(n.modules.clone().filter_map(|i| keys.get(i as usize)));
        }
        if n.parent.is_none() {
            continue;
        }
        k.expanded.push(n.key);
        if let Some(alt) = n.alt
            && let Some(g) = c
                .groups_of(n.symbol)
                .iter()
                .find(|g| (g.first_alt..g.first_alt + g.alt_count).contains(&alt))
            && g.alt_count > 1
        {
            k.choices.push((n.key, alt - g.first_alt + 1));
        }
    }
    let mut rng = Rng::new(27);
    for v in [&mut k.geometry, &mut k.bones, &mut k.expanded, &mut k.all] {
        v.sort_unstable();
        v.dedup();
        rng.shuffle(v);
    }
    k.choices.sort_unstable();
    k.choices.dedup();
    rng.shuffle(&mut k.choices);
    k
}

/// The plans of the cases, from the keys of the plain run's model.
fn plans(c: &CompiledSystem, k: &Keys) -> Vec<(&'static str, Option<EditPlan>)> {
    // `F`'s first parameter, its length.
    let f = c
        .symbol_names
        .iter()
        .position(|n| n == "F")
        .expect("the tree draws F");
    let length: Vec<SlotTarget> = (0..c.symbol_names.len())
        .map(|s| {
            if s == f {
                SlotTarget {
                    word: 0,
                    words: 1,
                    boolean: false,
                }
            } else {
                SlotTarget::default()
            }
        })
        .collect();
    let mut mix = EditPlan::new();
    let slot = mix.add_slot(length);
    let pick = |v: &[u32], j: usize| v[j % v.len()];
    for i in 0..EDITS {
        let j = i / 5;
        let (key, action) = match i % 5 {
            // A leaf's or trunk's part.
            0 => (pick(&k.geometry, j), EditAction::Remove),
            // A bone's length, or every bone's below an expansion.
            1 => (
                if j % 2 == 0 {
                    pick(&k.bones, j / 2)
                } else {
                    pick(&k.expanded, j / 2)
                },
                EditAction::Value {
                    slot,
                    op: ValueOp::Set(0.8),
                },
            ),
            2 => (
                if j % 2 == 1 {
                    pick(&k.bones, j / 2 + 1)
                } else {
                    pick(&k.expanded, j / 2 + 1)
                },
                EditAction::Value {
                    slot,
                    op: ValueOp::Offset(0.1),
                },
            ),
            // A choice forced to the alternative it took.
            3 => {
                let (key, alt) = k.choices[j % k.choices.len()];
                (key, EditAction::Force(alt))
            }
            // An expansion pinned to its own key.
            _ => {
                let key = pick(&k.expanded, j + 3);
                (key, EditAction::Pin(key))
            }
        };
        mix.add(key, i as u32 + 1, action);
    }
    let have: std::collections::HashSet<u32> = k.all.iter().copied().collect();
    let mut absent = EditPlan::new();
    let mut x = 0x9e37_79b9u32;
    let mut n = 0u32;
    while (n as usize) < EDITS {
        x = x.wrapping_mul(0x0100_0193).wrapping_add(0x6b43_a9b5);
        if !have.contains(&x) {
            absent.add(x, n + 1, EditAction::Remove);
            n += 1;
        }
    }
    let mut remove = EditPlan::new();
    for (i, &key) in k.geometry.iter().take(EDITS).enumerate() {
        remove.add(key, i as u32 + 1, EditAction::Remove);
    }
    vec![
        ("none", None),
        ("absent", Some(absent)),
        ("remove", Some(remove)),
        ("mix", Some(mix)),
    ]
}

/// This bench's instructions for one case and `n` runs (cachegrind).
fn instructions(case: &str, n: usize) -> Option<u64> {
    cachegrind_instructions(&["--only", case, "--runs", &n.to_string()])
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let value = |name: &str| arg_value(&args, name);
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    let path = root.join("calder_tree.grm");
    let text = std::fs::read_to_string(&path).expect("example");
    let (_s, checked) = grm_sema::check_text(path.to_str().expect("path"), &text);
    assert!(!checked.has_errors(), "calder_tree.grm has errors");
    let program = checked.program;
    let system = &program.systems[0];
    let c = grm_compile::compile(&program, system, &program.default_params()).expect("compiles");
    let curves = Curves::load(root.join("calder_tree.curves.json")).expect("curves");
    let sampler = || {
        Sampler::new(
            system,
            &c,
            &curves,
            Objective::Curves,
            ExpectedOptions::default(),
        )
        .expect("sampler")
    };
    let opts = options();
    let plain = sampler();
    let keys = model_keys(&c, &plain.sample(&opts).expect("samples"));
    let plans = plans(&c, &keys);
    let only = value("--only");
    let samplers: Vec<(&str, Sampler<'_>)> = plans
        .into_iter()
        .filter(|(name, _)| only.as_deref().is_none_or(|o| o == *name))
        .map(|(name, plan)| {
            let s = match plan {
                None => sampler(),
                Some(p) => sampler().with_edits(p),
            };
            (name, s)
        })
        .collect();
    if only.is_some() {
        // One case, `--runs` times (under cachegrind).
        let n: usize = value("--runs").and_then(|s| s.parse().ok()).unwrap_or(1);
        let (_, s) = samplers.first().expect("case");
        for _ in 0..n {
            black_box(s.sample(&opts).expect("samples"));
        }
        return;
    }
    let rounds: usize = args.iter().find_map(|a| a.parse().ok()).unwrap_or(5);
    println!(
        "sample-mode edits replay: calder_tree.grm, playground schedule, seed 0, 1 thread; the model's keys: {}; load {}",
        keys.all.len(),
        load()
    );
    for (name, s) in &samplers {
        let r = s.sample(&opts).expect("samples");
        let m = &r.models[0];
        let met = m.edits.as_ref().map_or(0, |h| {
            keys.all.iter().filter(|&&k| h.hits(k).is_some()).count()
        });
        println!(
            "  {name:<7} {:>5} modules, {:>4} bones, {:>4} model keys met, objective {:.1}",
            m.string.len(),
            m.skeleton_bones,
            met,
            m.objective
        );
    }
    let mut times: Vec<Vec<f64>> = vec![Vec::new(); samplers.len()];
    let mut ratios: Vec<Vec<f64>> = vec![Vec::new(); samplers.len()];
    for round in 0..rounds {
        let mut order: Vec<usize> = (0..samplers.len()).collect();
        if round % 2 == 1 {
            order.reverse();
        }
        let mut t = vec![0.0; samplers.len()];
        for &k in &order {
            let start = Instant::now();
            black_box(samplers[k].1.sample(&opts).expect("samples"));
            t[k] = start.elapsed().as_secs_f64() * 1e3;
        }
        for k in 0..samplers.len() {
            times[k].push(t[k]);
            ratios[k].push(t[k] / t[0]);
        }
    }
    let names: Vec<&str> = samplers.iter().map(|(name, _)| *name).collect();
    print_medians(rounds, "none", &names, &times, &ratios);
    if args.iter().any(|a| a == "--instructions") {
        print_instructions("run", CASES.iter().copied(), instructions);
    }
}

//! Replay cost of persistent edits in shape mode (issue 27: "1,000 edits on
//! a 10,000-window building add at most 10% to the derivation"; "near zero
//! when there are no edits"). The building is the shape-regrow benchmark's
//! tower (`crates/grm-lsp/benches/tower_10k.grm`: 25 floors, four facades
//! of 100 columns, 10,000 windows).
//!
//! Cases, each derived on one thread (the honest comparison: the same
//! work against the same work), in alternating order round by round:
//!
//! - `none`: `derive` (no plan), the baseline;
//! - `empty`: `derive_with_edits` with an empty plan;
//! - `one`: one edit (a window's material): the fixed cost of a plan;
//! - `exact`, `key`, `semantic`: the mix's edits of that kind of target
//!   alone (700, 200, 100); `no-material`: the mix without its material
//!   edits (what forcing a material costs);
//! - `mix`: 1,000 edits, the mix below; `mix-anykey` the same with the
//!   key targets' symbols left out;
//! - `mix+plan`: the same with the plan built from the edits file each
//!   time (what a regrow does after lowering: the plan's ids are the
//!   lowered program's).
//!
//! Also `none` and `mix` on every core (`threads = 0`, what the preview
//! derives with; each parallel job starts from its root's replay state, so
//! edits keep the parallel derivation: `mix/all` over `none/all` is the
//! ratio the preview sees), and the classification of the 1,000 edits
//! against the edited tree (`grm_grow::shape::edits::classify`, what
//! `grmc edits check` and the editor run after a derivation).
//!
//! The mix (seeded, `grm_testkit::Rng::new(27)`), targets taken from the
//! unedited tree as the preview's picks make them:
//!
//! - 550 exact locators of windows (distinct), 80 of floors, 70 of leaves
//!   (glass panes and frame bars: what a click hits);
//! - 200 identity keys (150 windows, 50 tiles), each with its part's
//!   symbol as a pick records it (`Edit::symbol`: only windows and tiles
//!   then test their keys); `mix-anykey` is the mix with the keys
//!   recording no symbol (a version 1 or 2 file: every shape tests its
//!   key);
//! - 100 semantic queries: 40 `(floor = F, column = C) Window` (four
//!   windows each, one per facade), 30 `(facade = K, floor = F, column =
//!   end C) Window` (one each), 20 `(facade = K, floor = F) Floor`, 10
//!   `(column = C) Window` (100 windows each);
//! - operations: windows and keys draw `material` 40%, `pin` 25%, `remove`
//!   20%, `force` 15%; floors, leaves and semantic queries `material`
//!   (steel, glass or concrete) but for a fifth of the window queries,
//!   `remove`.
//!
//! Removed windows are not expanded, so the edited tree is smaller: the
//! node counts are printed beside the times.
//!
//! Each figure is the median of the rounds; the ratios are of medians and
//! the median of the per-round ratios (paired, robust to a busy machine);
//! the load average is printed with each. Instruction counts
//! (`--instructions`): the bench runs itself under `valgrind --tool=
//! cachegrind` per case with 1 and 3 derivations and prints the difference
//! over 2, one derivation's instructions without the setup.
//!
//! `--digest` prints, per case, a digest of the whole tree it derives (its
//! debug text: nodes, attributes, removed parts, hits), to compare two
//! builds of the replay: a change to how edits are found must leave every
//! line the same.
//!
//! `--pair A B [--rounds N]` times two cases only, alternating (which
//! runs first alternates too) for N rounds (default 101), and prints the
//! median and quartiles of the per-round ratio B / A: the figure to
//! compare two builds of the replay by (`--pair none mix`).
//!
//! Run: `cargo bench -p grm-grow --bench edits_replay [-- ROUNDS]
//! [--instructions] [--digest] [--pair A B [--rounds N]]`.

use grm_edits::{EditsFile, Op, SemanticQuery, Target};
use grm_grow::shape::{Lowered, ShapeOptions, derive, derive_with_edits, edit_plan, edits, lower};
use grm_shape::{EditPlan, NodeId, NodeKind, ShapeTree};
use grm_testkit::Rng;
use grm_testkit::bench::{arg_value, cachegrind_instructions, load, median, quantile};
use std::collections::HashMap;
use std::hint::black_box;
use std::path::Path;
use std::time::Instant;

const SYSTEM: &str = "Tower10k";

struct Building {
    checked: grm_sema::Checked,
    lowered: Lowered,
    plain: ShapeTree,
}

fn building() -> Building {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../grm-lsp/benches/tower_10k.grm");
    let text = std::fs::read_to_string(&path).expect("tower_10k.grm");
    let (_, checked) = grm_sema::check_text(&path.display().to_string(), &text);
    assert!(!checked.has_errors(), "{:?}", checked.diagnostics);
    let p = &checked.program;
    let sys = p.default_system().expect("a system");
    let lowered = lower(p, sys, &p.default_params()).expect("lowers");
    let plain = derive(&lowered, lowered.seed, &ShapeOptions::default()).expect("derives");
    Building {
        checked,
        lowered,
        plain,
    }
}

impl Building {
    fn shapes(&self, symbol: &str) -> Vec<NodeId> {
        let s = self.lowered.program.symbol(symbol).expect("a symbol");
        self.plain
            .nodes()
            .iter()
            .enumerate()
            .filter(|(_, n)| matches!(n.kind, NodeKind::Shape { symbol, .. } if symbol == s))
            .map(|(i, _)| NodeId(i as u32))
            .collect()
    }

    fn exact(&self, id: NodeId) -> Target {
        Target::Exact(self.plain.exact_locator(&self.lowered.program, id))
    }

    fn key(&self, id: NodeId) -> Target {
        Target::Key(self.plain.node(id).expect("a node").key)
    }

    /// The symbol of shape `id` (what a pick records with its key).
    fn symbol(&self, id: NodeId) -> String {
        self.plain.label(&self.lowered.program, id)
    }

    fn grow(&self, plan: Option<&EditPlan>, threads: usize) -> ShapeTree {
        let options = ShapeOptions {
            threads,
            ..ShapeOptions::default()
        };
        derive_with_edits(&self.lowered, self.lowered.seed, &options, plan).expect("derives")
    }
}

/// `n` distinct draws of `from`.
fn distinct(rng: &mut Rng, from: &[NodeId], n: usize) -> Vec<NodeId> {
    let mut v = from.to_vec();
    rng.shuffle(&mut v);
    v.truncate(n);
    v
}

fn material(rng: &mut Rng) -> Op {
    Op::Material {
        name: rng.pick(&["steel", "glass", "concrete"]).to_string(),
    }
}

/// A window's or key's operation: material 40%, pin 25%, remove 20%,
/// force 15%.
fn window_op(rng: &mut Rng) -> Op {
    match rng.below(20u32) {
        0..=7 => material(rng),
        8..=12 => Op::Pin {
            key: rng.next_u64() as u32,
        },
        13..=16 => Op::Remove,
        _ => Op::Force { alternative: 1 },
    }
}

/// The 1,000 edits of the mix, and how many of each kind.
fn mix(b: &Building) -> (EditsFile, Vec<(&'static str, usize)>) {
    let mut rng = Rng::new(27);
    let mut f = EditsFile {
        version: 1,
        edits: Vec::new(),
    };
    // (target, operation, the symbol a key target records).
    let mut edits: Vec<(Target, Op, Option<String>)> = Vec::new();
    let windows = b.shapes("Window");
    let floors = b.shapes("Floor");
    let tiles = b.shapes("Tile");
    let mut leaves = b.shapes("Glass");
    leaves.extend(b.shapes("Frame"));
    assert_eq!(windows.len(), 10_000, "the building has 10,000 windows");
    for w in distinct(&mut rng, &windows, 550) {
        edits.push((b.exact(w), window_op(&mut rng), None));
    }
    for fl in distinct(&mut rng, &floors, 80) {
        edits.push((b.exact(fl), material(&mut rng), None));
    }
    for l in distinct(&mut rng, &leaves, 70) {
        edits.push((b.exact(l), material(&mut rng), None));
    }
    for w in distinct(&mut rng, &windows, 150) {
        edits.push((b.key(w), window_op(&mut rng), Some(b.symbol(w))));
    }
    for t in distinct(&mut rng, &tiles, 50) {
        edits.push((b.key(t), window_op(&mut rng), Some(b.symbol(t))));
    }
    let q = |s: String| -> Target { Target::Semantic(s.parse::<SemanticQuery>().expect(&s)) };
    for _ in 0..40 {
        let s = format!(
            "(floor = {}, column = {}) Window",
            1 + rng.below(25u32),
            1 + rng.below(100u32)
        );
        let op = if rng.below(5u32) == 0 {
            Op::Remove
        } else {
            material(&mut rng)
        };
        edits.push((q(s), op, None));
    }
    for _ in 0..30 {
        let s = format!(
            "(facade = {}, floor = {}, column = end {}) Window",
            1 + rng.below(4u32),
            1 + rng.below(25u32),
            1 + rng.below(100u32)
        );
        let op = if rng.below(5u32) == 0 {
            Op::Remove
        } else {
            material(&mut rng)
        };
        edits.push((q(s), op, None));
    }
    for _ in 0..20 {
        let s = format!(
            "(facade = {}, floor = {}) Floor",
            1 + rng.below(4u32),
            1 + rng.below(25u32)
        );
        edits.push((q(s), material(&mut rng), None));
    }
    for _ in 0..10 {
        let s = format!("(column = {}) Window", 1 + rng.below(100u32));
        edits.push((q(s), material(&mut rng), None));
    }
    let mut counts: Vec<(&'static str, usize)> = Vec::new();
    for (t, o, symbol) in edits {
        let kind = match (&t, &o) {
            (_, Op::Material { .. }) => "material",
            (_, Op::Pin { .. }) => "pin",
            (_, Op::Remove) => "remove",
            (_, Op::Force { .. }) => "force",
            _ => "other",
        };
        match counts.iter_mut().find(|(k, _)| *k == kind) {
            Some(c) => c.1 += 1,
            None => counts.push((kind, 1)),
        }
        let id = f.add(SYSTEM, t, o).expect("an id");
        if let Some(e) = f.edits.iter_mut().find(|e| e.id == id) {
            e.symbol = symbol;
        }
    }
    assert_eq!(f.edits.len(), 1000);
    (f, counts)
}

const CASES: [&str; 12] = [
    "none",
    "empty",
    "one",
    "exact",
    "key",
    "semantic",
    "no-material",
    "mix",
    "mix-anykey",
    "mix+plan",
    "none/all",
    "mix/all",
];

/// The plans of the cases: one edit; the mix's exact, key and semantic
/// targets alone; the mix without its material edits; the whole mix.
struct Plans {
    one: EditPlan,
    exact: EditPlan,
    key: EditPlan,
    semantic: EditPlan,
    no_material: EditPlan,
    mix: EditPlan,
    mix_anykey: EditPlan,
}

/// The edits of `file` that `keep` keeps.
fn only(file: &EditsFile, keep: impl Fn(&grm_edits::Edit) -> bool) -> EditsFile {
    EditsFile {
        version: 1,
        edits: file.edits.iter().filter(|e| keep(e)).cloned().collect(),
    }
}

/// One derivation of `case`; the tree's length.
fn run(b: &Building, case: &str, plans: &Plans, file: &EditsFile) -> usize {
    let empty = EditPlan::default();
    let tree = match case {
        "none" => b.grow(None, 1),
        "empty" => b.grow(Some(&empty), 1),
        "one" => b.grow(Some(&plans.one), 1),
        "exact" => b.grow(Some(&plans.exact), 1),
        "key" => b.grow(Some(&plans.key), 1),
        "semantic" => b.grow(Some(&plans.semantic), 1),
        "no-material" => b.grow(Some(&plans.no_material), 1),
        "mix" => b.grow(Some(&plans.mix), 1),
        "mix-anykey" => b.grow(Some(&plans.mix_anykey), 1),
        "mix+plan" => {
            let plan = edit_plan(&b.lowered, black_box(file));
            b.grow(Some(&plan), 1)
        }
        "none/all" => b.grow(None, 0),
        "mix/all" => b.grow(Some(&plans.mix), 0),
        _ => panic!("unknown case {case}"),
    };
    black_box(&tree).len()
}

/// This bench's instructions for one case and `n` derivations (cachegrind).
fn instructions(case: &str, n: usize) -> Option<u64> {
    cachegrind_instructions(&["--only", case, "--derivations", &n.to_string()])
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let value = |name: &str| arg_value(&args, name);
    let b = building();
    let (file, counts) = mix(&b);
    let window = b.shapes("Window")[4321];
    let mut one = EditsFile {
        version: 1,
        edits: Vec::new(),
    };
    one.add(
        SYSTEM,
        b.exact(window),
        Op::Material {
            name: "steel".into(),
        },
    )
    .expect("an id");
    let by_target = |kind: &'static str| only(&file, move |e| e.target.kind() == kind);
    let plans = Plans {
        one: edit_plan(&b.lowered, &one),
        exact: edit_plan(&b.lowered, &by_target("exact")),
        key: edit_plan(&b.lowered, &by_target("key")),
        semantic: edit_plan(&b.lowered, &by_target("semantic")),
        no_material: edit_plan(
            &b.lowered,
            &only(&file, |e| !matches!(e.op, Op::Material { .. })),
        ),
        mix: edit_plan(&b.lowered, &file),
        mix_anykey: edit_plan(&b.lowered, &{
            let mut f = file.clone();
            f.edits.iter_mut().for_each(|e| e.symbol = None);
            f
        }),
    };

    // Under valgrind: one case, n derivations, nothing printed.
    if let Some(case) = value("--only") {
        let n: usize = value("--derivations")
            .and_then(|v| v.parse().ok())
            .unwrap_or(1);
        for _ in 0..n {
            run(&b, &case, &plans, &file);
        }
        return;
    }

    // Two cases only, many rounds (the pair alternating which runs first):
    // the median and quartiles of the per-round ratio, the figure to
    // compare two builds by in a quiet minute (the default run's 15
    // rounds of eleven cases move by several points between calls).
    if let Some(a) = value("--pair") {
        let pos = args.iter().position(|x| x == "--pair").unwrap_or(0);
        let b_case = args.get(pos + 2).cloned().unwrap_or_else(|| "mix".into());
        let rounds: usize = value("--rounds")
            .and_then(|v| v.parse().ok())
            .unwrap_or(101)
            .max(1);
        let (mut ta, mut tb, mut ratio) = (Vec::new(), Vec::new(), Vec::new());
        for r in 0..rounds {
            let one = |case: &str| {
                let t = Instant::now();
                run(&b, case, &plans, &file);
                t.elapsed().as_secs_f64() * 1e3
            };
            let (x, y) = if r % 2 == 0 {
                let x = one(&a);
                (x, one(&b_case))
            } else {
                let y = one(&b_case);
                (one(&a), y)
            };
            ta.push(x);
            tb.push(y);
            ratio.push(y / x);
        }
        let q = |f: f64| quantile(&ratio, f);
        println!(
            "  {b_case} over {a}: {:.3}x (median of {rounds} per-round ratios; quartiles {:.3}-{:.3}); {a} {:.2} ms, {b_case} {:.2} ms; load {}",
            q(0.5),
            q(0.25),
            q(0.75),
            median(&ta),
            median(&tb),
            load()
        );
        return;
    }

    // The trees every case derives, as digests of their full debug text
    // (nodes, attributes, removed parts, hits): compare two builds' lines
    // to show a change to the replay leaves every tree bit-identical.
    if args.iter().any(|a| a == "--digest") {
        for case in CASES {
            let tree = match case {
                "none/all" => b.grow(None, 0),
                "mix/all" => b.grow(Some(&plans.mix), 0),
                "mix+plan" => b.grow(Some(&edit_plan(&b.lowered, &file)), 1),
                _ => {
                    let plan = match case {
                        "none" => None,
                        "empty" => Some(EditPlan::default()),
                        "one" => Some(plans.one.clone()),
                        "exact" => Some(plans.exact.clone()),
                        "key" => Some(plans.key.clone()),
                        "semantic" => Some(plans.semantic.clone()),
                        "no-material" => Some(plans.no_material.clone()),
                        "mix" => Some(plans.mix.clone()),
                        "mix-anykey" => Some(plans.mix_anykey.clone()),
                        _ => panic!("unknown case {case}"),
                    };
                    b.grow(plan.as_ref(), 1)
                }
            };
            let text = format!("{tree:?}");
            let mut h = std::collections::hash_map::DefaultHasher::new();
            std::hash::Hash::hash(&text, &mut h);
            println!(
                "{case:<12} {:016x} {} nodes {} bytes",
                std::hash::Hasher::finish(&h),
                tree.len(),
                text.len()
            );
        }
        return;
    }

    let rounds: usize = args
        .iter()
        .find_map(|a| a.parse().ok())
        .unwrap_or(15)
        .max(1);
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let edited = b.grow(Some(&plans.mix), 1);
    println!(
        "edits replay: tower_10k (10,000 windows): {} nodes unedited, {} with the 1,000 edits ({} removed parts); {threads} hardware threads; median of {rounds} rounds; load average {}",
        b.plain.len(),
        edited.len(),
        edited.removed().len(),
        load()
    );
    println!(
        "  the mix: {}",
        counts
            .iter()
            .map(|(k, n)| format!("{n} {k}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    // Same tree with no plan and an empty one; the edited tree's edits
    // are all found.
    assert_eq!(b.grow(Some(&EditPlan::default()), 1), b.plain);
    let reports = edits::classify(&b.checked.program, &b.lowered, &edited, &file.edits);
    let valid = reports
        .iter()
        .filter(|r| r.class == grm_edits::EditClass::Valid)
        .count();
    let mut classes: Vec<(&str, usize)> = Vec::new();
    for r in &reports {
        match classes.iter_mut().find(|(c, _)| *c == r.class.as_str()) {
            Some(c) => c.1 += 1,
            None => classes.push((r.class.as_str(), 1)),
        }
    }
    // The edits not valid: their targets by kind, and whether another
    // edit of the mix (exact or key) removes an ancestor of the part or
    // pins it or an ancestor (which changes the keys below), in the
    // unedited tree.
    let by_key: HashMap<u32, NodeId> = b
        .plain
        .nodes()
        .iter()
        .enumerate()
        .map(|(i, n)| (n.key, NodeId(i as u32)))
        .collect();
    let node_of = |t: &Target| match t {
        Target::Exact(l) => match b.plain.resolve(&b.lowered.program, l) {
            grm_shape::Resolution::Found(n) => Some(n),
            _ => None,
        },
        Target::Key(k) => by_key.get(k).copied(),
        Target::Semantic(_) => None,
    };
    let hiding: Vec<(NodeId, bool)> = file
        .edits
        .iter()
        .filter_map(|e| match e.op {
            Op::Remove => Some((node_of(&e.target)?, false)),
            Op::Pin { .. } => Some((node_of(&e.target)?, true)),
            _ => None,
        })
        .collect();
    let shared = b.plain.len() - by_key.len();
    println!(
        "  identity keys: {shared} of the {} nodes share their 32-bit key with another (a key target there is ambiguous)",
        b.plain.len()
    );
    let mut explained = 0;
    let mut invalid: Vec<(&str, usize)> = Vec::new();
    for (e, r) in file.edits.iter().zip(&reports) {
        if r.class == grm_edits::EditClass::Valid {
            continue;
        }
        let kind = e.target.kind();
        match invalid.iter_mut().find(|(k, _)| *k == kind) {
            Some(c) => c.1 += 1,
            None => invalid.push((kind, 1)),
        }
        if let Some(n) = node_of(&e.target) {
            let path = b.plain.path(n);
            let under = hiding.iter().any(|&(h, pin)| {
                (h != n && path.contains(&h))
                    || (pin && h == n && matches!(e.target, Target::Key(_)))
            });
            explained += usize::from(under);
        }
    }
    println!(
        "  classified after replay: {valid} of 1000 valid ({}); not valid by target: {}; {explained} of them inside a part another edit removes or pins, or a key another edit pins (edit interactions, not misses)",
        classes
            .iter()
            .map(|(c, n)| format!("{n} {c}"))
            .collect::<Vec<_>>()
            .join(", "),
        invalid
            .iter()
            .map(|(c, n)| format!("{n} {c}"))
            .collect::<Vec<_>>()
            .join(", ")
    );

    let mut times: Vec<Vec<f64>> = vec![Vec::new(); CASES.len()];
    let mut plan_ms = Vec::new();
    for r in 0..rounds {
        // Alternate the order: each case runs first in turn.
        for k in 0..CASES.len() {
            let c = (k + r) % CASES.len();
            let t = Instant::now();
            run(&b, CASES[c], &plans, &file);
            times[c].push(t.elapsed().as_secs_f64() * 1e3);
        }
        let t = Instant::now();
        black_box(edit_plan(&b.lowered, &file));
        plan_ms.push(t.elapsed().as_secs_f64() * 1e3);
    }
    let base = median(&times[0]);
    for (c, name) in CASES.iter().enumerate() {
        let m = median(&times[c]);
        let paired: Vec<f64> = times[c].iter().zip(&times[0]).map(|(a, b)| a / b).collect();
        println!(
            "  {name:<10} {m:8.2} ms   {:.3}x none (median of per-round ratios {:.3}x)   load {}",
            m / base,
            median(&paired),
            load()
        );
    }
    // The preview's ratio: the mix on every core over no edits on every core.
    let (all, mix_all) = (CASES.len() - 2, CASES.len() - 1);
    let paired: Vec<f64> = times[mix_all]
        .iter()
        .zip(&times[all])
        .map(|(a, b)| a / b)
        .collect();
    println!(
        "  mix/all over none/all: {:.3}x (median of per-round ratios {:.3}x)   load {}",
        median(&times[mix_all]) / median(&times[all]),
        median(&paired),
        load()
    );
    println!(
        "  plan of the 1,000 edits (EditPlan::new) {:8.3} ms = {:.3}x a derivation; load {}",
        median(&plan_ms),
        median(&plan_ms) / base,
        load()
    );
    // The classification after the derivation (once: it is slow), by kind
    // of target.
    for kind in ["exact", "key", "semantic"] {
        let f = by_target(kind);
        let t = Instant::now();
        black_box(edits::classify(
            &b.checked.program,
            &b.lowered,
            &edited,
            &f.edits,
        ));
        let ms = t.elapsed().as_secs_f64() * 1e3;
        println!(
            "  classify the {} {kind} edits (edits::classify, once) {ms:10.2} ms = {:.2}x a derivation; load {}",
            f.edits.len(),
            ms / base,
            load()
        );
    }

    if args.iter().any(|a| a == "--instructions") {
        println!("  instructions (cachegrind; one derivation = (3 derivations - 1) / 2):");
        let mut base = None;
        for case in CASES.iter().filter(|c| !c.ends_with("/all")) {
            let (Some(a), Some(c)) = (instructions(case, 1), instructions(case, 3)) else {
                println!("  valgrind did not run");
                break;
            };
            let one = c.saturating_sub(a) as f64 / 2.0;
            let base = *base.get_or_insert(one);
            println!(
                "  {case:<10} {:8.2} M instructions   {:.3}x none",
                one / 1e6,
                one / base
            );
        }
    }
}

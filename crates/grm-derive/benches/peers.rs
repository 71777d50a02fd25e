//! grm's CPU derivation against the Rust L-system crates on the classic
//! scenes, in one run: `cargo bench -p grm-derive --bench peers`.
//!
//! Peers: `symbios` (a structure-of-arrays parametric engine) and
//! `lindenmayer-system` (parametric, a `Vec` of symbols with parameter
//! vectors). Each scene is the same L-system in each engine: the same
//! axiom, productions and iterations, and the final lengths are checked
//! equal. The peers' turn symbols carry no parameter (their default angle),
//! as in a string rewriter; grm's carry the angle the grammar gives them.
//!
//! Columns (medians of interleaved runs, milliseconds):
//! - `grm fresh`: `Engine::new` and a whole derivation on one thread, fresh
//!   memory every run (a user's one-shot derivation: this bench installs
//!   `grmc`'s allocator, [`grm_derive::HugePageAlloc`], whose large blocks
//!   are fresh mappings every time, as in a new process);
//! - `grm warm`: one engine deriving again and again, its strings handed
//!   back (`Engine::recycle`), as a preview regrows a model;
//! - `symbios`, `lsys`: a fresh system per run (rules parsed or built,
//!   axiom set, derived);
//! - `memcpy`: copying the bytes of grm's final string once (symbols,
//!   starts, parameters): the floor memory bandwidth sets for writing it;
//! - ratios: grm's time over the best peer's (below 1: grm is faster), and
//!   grm warm over the memcpy floor;
//! - `warm/us`: modules produced (the sum of the lengths of strings 1..=n)
//!   per microsecond of `grm warm`.
//!
//! The npm `lindenmayer` library (JavaScript) is timed by
//! `scripts/peers-js.sh`.

use std::hint::black_box;
use std::time::{Duration, Instant};

use expression::cond::Cond;
use expression_num::NumExpr as Expr;
use grm_derive::{DeriveLimits, DeriveOptions, Engine};
use lindenmayer_system::parametric::{PRule, PSym, PSystem, ParametricSymbol, ParametricSystem};

/// The allocator `grmc` runs with, so `grm fresh` pays what a new process
/// pays for fresh memory (the peers run with it too).
#[global_allocator]
static ALLOC: grm_derive::HugePageAlloc = grm_derive::HugePageAlloc;

type SymExpr = PSym<char, Expr<f32>>;
type SymR = PSym<char, f32>;
type Rule = PRule<char, SymExpr, SymR, Cond<Expr<f32>>>;

/// A scene: grm example (file, iterations), and the same system for the
/// peers: symbios axiom and rules, lindenmayer-system axiom and rules.
struct Scene {
    name: &'static str,
    file: &'static str,
    n: u32,
    axiom: &'static str,
    rules: &'static [&'static str],
}

/// The row of trees' constants (ABoP 1.37a, p = 0.3): q = 1 - p, h = sqrt(p q).
const P: f32 = 0.3;
const Q: f32 = 0.7;
const H: f32 = 0.458_257_6;

const SCENES: &[Scene] = &[
    Scene {
        name: "koch_island",
        file: "koch_island.grm",
        n: 6,
        axiom: "F - F - F - F",
        rules: &["F -> F - F + F + F F - F - F + F"],
    },
    Scene {
        name: "bracketed_plant",
        file: "bracketed_plant.grm",
        n: 6,
        axiom: "F",
        rules: &["F -> F F - [ - F + F + F ] + [ + F - F - F ]"],
    },
    Scene {
        name: "hilbert3d",
        file: "hilbert3d.grm",
        n: 6,
        axiom: "A",
        rules: &[
            "A -> B - F + C F C + F - D & F ^ D - F + & & C F C + F + B / /",
            "B -> A & F ^ C F B ^ F ^ D ^ ^ - F - D ^ | F ^ B | F C ^ F ^ A / /",
            "C -> | D ^ | F ^ B - F + C ^ F ^ A & & F A & F ^ C + F + B ^ F ^ D / /",
            "D -> | C F B - F + B | F A & F ^ A & & F B - F + B | F C / /",
        ],
    },
    Scene {
        name: "row_of_trees",
        file: "row_of_trees.grm",
        n: 9,
        axiom: "F(1)",
        rules: &["F(x) -> F(x * 0.3) + F(x * 0.4582576) - - F(x * 0.4582576) + F(x * 0.7)"],
    },
];

fn compile(file: &str) -> grm_compile::CompiledSystem {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples")
        .join(file);
    let text = std::fs::read_to_string(&path).expect("example");
    let (_, checked) = grm_sema::check_text(&path.display().to_string(), &text);
    assert!(!checked.has_errors(), "{file}");
    let p = &checked.program;
    let sys = p.default_system().expect("system");
    grm_compile::compile(p, sys, &p.default_params()).expect("compiles")
}

fn symbios_run(s: &Scene) -> usize {
    let mut sys = symbios::System::new();
    sys.max_capacity = 200_000_000;
    for r in s.rules {
        sys.add_rule(r).expect("symbios rule");
    }
    sys.set_axiom(s.axiom).expect("symbios axiom");
    sys.derive(s.n as usize).expect("symbios derives");
    sys.state.len()
}

/// The scene for lindenmayer-system: symbols without parameters, but for
/// the row of trees' `F(x)`.
fn lsys_system(s: &Scene) -> (PSystem<Rule>, Vec<SymR>) {
    let mut sys: PSystem<Rule> = PSystem::new();
    let plain = |c: char| SymExpr::new_from_vec(c, vec![]).expect("symbol");
    if s.name == "row_of_trees" {
        let f = |k: f32| {
            SymExpr::new_from_vec(
                'F',
                vec![Expr::Mul(Box::new(Expr::Var(0)), Box::new(Expr::Const(k)))],
            )
            .expect("symbol")
        };
        let succ = vec![
            f(P),
            plain('+'),
            f(H),
            plain('-'),
            plain('-'),
            f(H),
            plain('+'),
            f(Q),
        ];
        sys.add_rule(Rule::new('F', Cond::True, succ, 1));
        return (
            sys,
            vec![SymR::new_from_vec('F', vec![1.0]).expect("axiom")],
        );
    }
    for r in s.rules {
        let (pred, succ) = r.split_once("->").expect("rule");
        let pred = pred.trim().chars().next().expect("predecessor");
        let succ = succ
            .split_whitespace()
            .map(|t| plain(t.chars().next().expect("symbol")));
        sys.add_rule(Rule::new(pred, Cond::True, succ.collect(), 0));
    }
    let axiom = s
        .axiom
        .split_whitespace()
        .map(|t| SymR::new_from_vec(t.chars().next().expect("symbol"), vec![]).expect("axiom"))
        .collect();
    (sys, axiom)
}

fn lsys_run(s: &Scene) -> usize {
    let (sys, axiom) = lsys_system(s);
    let (out, _) = sys.develop(axiom, s.n as usize);
    out.len()
}

fn median(mut v: Vec<Duration>) -> f64 {
    v.sort();
    v[v.len() / 2].as_secs_f64() * 1e3
}

fn time<R>(f: impl FnOnce() -> R) -> (Duration, R) {
    let t = Instant::now();
    let r = black_box(f());
    (t.elapsed(), r)
}

fn main() {
    // `cargo bench` passes `--bench`; a number sets the rounds.
    let rounds: usize = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(15);
    println!(
        "grm against Rust L-system crates, one thread, median of {rounds} interleaved rounds (ms)"
    );
    println!(
        "{:<16} {:>2} {:>9} | {:>9} {:>9} {:>9} {:>9} {:>8} | {:>10} {:>10} {:>10} {:>8}",
        "scene",
        "n",
        "final",
        "grm fresh",
        "grm warm",
        "symbios",
        "lsys",
        "memcpy",
        "fresh/best",
        "warm/best",
        "warm/copy",
        "warm/us"
    );
    for s in SCENES {
        let c = compile(s.file);
        let opts = DeriveOptions {
            iterations: s.n,
            seed: 0,
            limits: DeriveLimits::default(),
        };
        let warm_engine = Engine::new(&c, 1).expect("engine");
        let mut times: [Vec<Duration>; 5] = Default::default();
        let mut len = 0usize;
        let mut dst = None;
        let mut produced = 0u64;
        for _ in 0..rounds {
            let (t, n) = time(|| {
                let e = Engine::new(&c, 1).expect("engine");
                e.derive(&opts, &mut |_| {}).expect("derives").string.len()
            });
            times[0].push(t);
            len = n;
            let (t, d) = time(|| warm_engine.derive(&opts, &mut |_| {}).expect("derives"));
            times[1].push(t);
            produced = d.stats.last().map_or(0, |x| x.cumulative_modules);
            // The memcpy floor: the final string's stored bytes, copied
            // once into memory already written (as the warm engine's
            // recycled strings are; a fresh destination would time its
            // page faults, not the bandwidth).
            let bytes = d.string.heap_bytes();
            let (src, dst) = dst.get_or_insert_with(|| (vec![1u8; bytes], vec![2u8; bytes]));
            let (t, ()) = time(|| dst.copy_from_slice(src));
            times[4].push(t);
            black_box(&*dst);
            warm_engine.recycle(d.string);
            let (t, n) = time(|| symbios_run(s));
            assert_eq!(n, len, "{}: symbios derived another string", s.name);
            times[2].push(t);
            let (t, n) = time(|| lsys_run(s));
            assert_eq!(
                n, len,
                "{}: lindenmayer-system derived another string",
                s.name
            );
            times[3].push(t);
        }
        let [fresh, warm, sym, lsys, copy] = times.map(median);
        let best = sym.min(lsys);
        println!(
            "{:<16} {:>2} {:>9} | {:>9.2} {:>9.2} {:>9.2} {:>9.2} {:>8.2} | {:>10.2} {:>10.2} {:>10.1} {:>8.0}",
            s.name,
            s.n,
            len,
            fresh,
            warm,
            sym,
            lsys,
            copy,
            fresh / best,
            warm / best,
            warm / copy,
            produced as f64 / (warm * 1e3)
        );
    }
}

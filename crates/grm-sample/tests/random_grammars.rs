//! Property test over generated sample-mode grammars: for each grammar and
//! seed, the sampled model's derivation tree replayed in many random
//! expansion orders costs exactly the same; 1 and 2 threads give the same
//! model; the returned model is the cheapest candidate; nothing panics.

mod common;

use common::*;
use grm_sample::*;
use grm_testkit::Rng;

const SKELETON: [&str; 3] = ["A", "B", "C"];

/// A random successor for a skeleton production: transforms, bones,
/// brackets, skeleton symbols (with a depth counter `n`) and decoration.
fn successor(g: &mut Rng, wrapup: bool) -> String {
    let mut out = Vec::new();
    let mut open = 0;
    for _ in 0..g.int(2, 8) {
        match g.below(11) {
            0 => out.push(format!("rotz({})", g.int(-90, 90))),
            1 => out.push(format!(
                "rotx(uniform({}, {}))",
                g.int(-60, 0),
                g.int(0, 60)
            )),
            2 => out.push(format!("roty({})", g.int(0, 360))),
            3 => out.push(format!("scale({:.2})", 0.6 + 0.1 * g.below(5) as f64)),
            4 | 5 => out.push(format!(
                "F(uniform(0.2, {:.1}))",
                0.3 + 0.2 * g.below(5) as f64
            )),
            6 if open < 2 => {
                out.push("[".to_string());
                open += 1;
            }
            7 if open > 0 => {
                out.push("]".to_string());
                open -= 1;
            }
            8 | 9 if !wrapup => {
                let s = SKELETON[g.below(3) as usize];
                out.push(format!("{s}(n - 1)"));
            }
            _ => out.push("Deco(2)".to_string()),
        }
    }
    out.extend(std::iter::repeat_n("]".to_string(), open));
    out.join(" ")
}

fn grammar(g: &mut Rng) -> String {
    let mut s = String::from(
        "system R {\n    mode = sample;\n    axiom F(0.5) A(6);\n    skeleton A, B, C;\n    geometry Deco;\n",
    );
    for sym in SKELETON {
        let alts = g.int(1, 3);
        for _ in 0..alts {
            s.push_str(&format!(
                "    {sym}(n) : n > 0 -> ({}) {};\n",
                g.int(1, 4),
                successor(g, false)
            ));
        }
        s.push_str(&format!("    {sym}(n) : n <= 0 -> F(0.3);\n"));
        s.push_str(&format!("    wrapup {sym}(n) -> {};\n", successor(g, true)));
    }
    s.push_str("    Deco(k) : k > 0 -> rotz(30) sphere(0.05) Deco(k - 1);\n");
    s.push_str("    Deco(k) : k <= 0 -> ;\n}\n");
    s
}

#[test]
fn generated_grammars_cost_the_same_in_every_expansion_order() {
    let curves = calder_curves();
    let mut g = Rng::seeded(0x9E37_79B9_7F4A_7C15);
    let mut models = 0;
    let mut expansions = 0;
    for k in 0..25 {
        let src = grammar(&mut g);
        let p = program(&format!("random{k}.grm"), &src);
        let c = compile(&p, 0);
        let s = Sampler::new(
            &p.systems[0],
            &c,
            &curves,
            Objective::Curves,
            ExpectedOptions::default(),
        )
        .unwrap_or_else(|e| panic!("{e}\n{src}"));
        for seed in 0..2 {
            let o = SampleOptions {
                seed,
                schedule: Schedule {
                    generations: 20,
                    particles_start: 8,
                    particles_end: 3,
                    ..Schedule::calder_playground()
                },
                best: 2,
                ..SampleOptions::default()
            };
            let r = s.sample(&o).unwrap_or_else(|e| panic!("{e}\n{src}"));
            let r2 = s
                .sample(&SampleOptions { threads: 2, ..o })
                .expect("samples");
            let min = r.candidates.iter().copied().fold(f64::INFINITY, f64::min);
            assert_eq!(r.best().expect("model").objective, min, "{src}");
            for (m, m2) in r.models.iter().zip(&r2.models) {
                assert_eq!(m.bone_list(), m2.bone_list(), "{src}");
                for order in 0..5 {
                    let cost = s.cost_in_order(&m.tree, order).expect("replays");
                    assert_eq!(
                        cost, m.cost,
                        "grammar {k}, seed {seed}, order {order}\n{src}"
                    );
                }
                models += 1;
                let (_, skeleton, wrapup, _) = m.tree.counts();
                expansions += skeleton + wrapup;
            }
        }
    }
    assert!(models >= 50, "{models}");
    // The grammars grow: several skeleton and wrap-up expansions a model.
    eprintln!("{expansions} expansions in {models} models");
    assert!(
        expansions >= 5 * models,
        "{expansions} expansions in {models} models"
    );
}

//! Same seed, same model, byte for byte, with one thread or several; and
//! the cost of a model does not depend on the order of its expansions.

mod common;

use common::*;
use glam::Vec3;
use grm_sample::*;

fn small() -> Schedule {
    Schedule {
        generations: 40,
        particles_start: 40,
        particles_end: 10,
        heuristic_scale: 0.013,
        heuristic_until: 16,
    }
}

#[test]
fn same_seed_same_model_for_any_thread_count() {
    let p = example("calder_tree.grm");
    let c = compile(&p, 0);
    let curves = calder_curves();
    let s = curves_sampler(&p, &c, &curves);
    let run_with = |seed: u32, threads: usize, ess_target: f64| {
        let r = s
            .sample(&SampleOptions {
                seed,
                schedule: small(),
                threads,
                ess_target,
                best: 3,
                ..SampleOptions::default()
            })
            .expect("samples");
        let m = r.best().expect("model");
        let model = m
            .build(&p, &grm_geom::BuildOptions::default())
            .expect("builds");
        let glb = grm_geom::export::glb_bytes(&model).expect("small");
        (r, glb)
    };
    let run = |seed: u32, threads: usize| run_with(seed, threads, 0.0);
    // Adaptive tempering: beta is a function of the generation's weights
    // alone, so tempered runs are as reproducible.
    for seed in [0, 7] {
        let (a, glb_a) = run_with(seed, 1, 0.5);
        let (b, glb_b) = run_with(seed, 3, 0.5);
        assert_eq!(glb_a, glb_b, "seed {seed}, tempered: 1 vs 3 threads");
        assert_eq!(a.candidates, b.candidates);
        assert_eq!(a.ess(), b.ess());
        let beta = |r: &SampleResult| -> Vec<u64> {
            r.generations.iter().map(|g| g.beta.to_bits()).collect()
        };
        assert_eq!(beta(&a), beta(&b));
        assert!(a.generations.iter().any(|g| g.beta < 1.0));
    }
    for seed in [0, 7] {
        let (a, glb_a) = run(seed, 1);
        let (b, glb_b) = run(seed, 3);
        let (c2, glb_c) = run(seed, 1);
        assert_eq!(glb_a, glb_b, "seed {seed}: 1 vs 3 threads");
        assert_eq!(glb_a, glb_c, "seed {seed}: repeated run");
        for (x, y) in a.models.iter().zip(&b.models) {
            assert_eq!(x.bone_list(), y.bone_list());
            assert_eq!(x.cost, y.cost);
            assert_eq!(x.tree, y.tree);
            assert_eq!(x.string, y.string);
        }
        assert_eq!(a.candidates, b.candidates);
        assert_eq!(a.ess(), b.ess());
        assert_eq!(a.candidates, c2.candidates);
    }
    let (a, _) = run(0, 1);
    let (b, _) = run(1, 1);
    assert_ne!(
        a.best().expect("model").bone_list(),
        b.best().expect("model").bone_list(),
        "different seeds give different models"
    );
}

/// The order-independence property: the same derivation tree replayed in
/// many different expansion orders costs exactly the same (bit for bit),
/// and the same as the cost computed from the finished model's skeleton
/// bones in tree order.
#[test]
fn cost_does_not_depend_on_expansion_order() {
    let p = example("calder_tree.grm");
    let c = compile(&p, 0);
    let curves = calder_curves();
    let s = curves_sampler(&p, &c, &curves);
    for seed in 0..4 {
        let r = s
            .sample(&SampleOptions {
                seed,
                schedule: small(),
                ..SampleOptions::default()
            })
            .expect("samples");
        let m = r.best().expect("model");
        let (axiom, skeleton, wrapup, geometry) = m.tree.counts();
        assert_eq!(axiom, 1);
        assert!(skeleton > 20 && wrapup > 0 && geometry > 0);
        let mut distinct_orders = 0;
        for order in 0..12 {
            let cost = s.cost_in_order(&m.tree, order).expect("replays");
            assert_eq!(cost, m.cost, "seed {seed}, order {order}");
            assert_eq!(cost.total().to_bits(), m.cost.total().to_bits());
            distinct_orders += 1;
        }
        assert_eq!(distinct_orders, 12);
        // From the bones of the finished model, in tree order.
        let model = s.cost_model();
        let mut state = model.new_state();
        let mut n = 0;
        for node in &m.tree.nodes {
            if node.kind == NodeKind::Geometry {
                continue;
            }
            for b in &m.interpretation.bones[node.bones.start as usize..node.bones.end as usize] {
                model.add_bone(&mut state, b.base, b.tip);
                n += 1;
            }
        }
        assert_eq!(n, m.skeleton_bones);
        assert_eq!(model.total(&state), m.cost);
    }
}

/// A grammar with brackets, parameters, a cut, conditions, bones in the
/// wrap-up and geometry that recurses: replays in any order still cost the
/// same, and the flat string interpreted as a whole (each expansion's
/// frame-local successor wrapped in brackets) gives the same bones.
#[test]
fn order_independence_on_a_richer_grammar() {
    let src = r#"
system Rich {
    mode = sample;
    axiom F(0.5) A(3);
    skeleton A, B;
    geometry Dec;
    A(n) : n > 0 -> (2) [ rotz(uniform(-40, 40)) F(1) A(n - 1) ] rotx(20) F(0.5) B(n);
    A(n) : n > 0 -> (1) rotz(30) F(uniform(0.5, 1)) Dec(2) A(n - 1) B(n);
    A(n) : n <= 0 -> Dec(1);
    B(n) -> (1) [ roty(90) F(0.3) ] % F(9) A(n - 1);
    B(n) -> (1) rotz(-25) F(0.4) A(n - 2) A(n - 3);
    wrapup A(n) -> F(0.25) Dec(1);
    wrapup B(n) -> ;
    Dec(k) : k > 0 -> rotx(10) translate(0, 0.1, 0) sphere(0.05) Dec(k - 1);
    Dec(k) : k <= 0 -> ;
}
"#;
    let p = program("rich.grm", src);
    let c = compile(&p, 0);
    let curves = calder_curves();
    let s = curves_sampler(&p, &c, &curves);
    let mut checked = 0;
    for seed in 0..6 {
        let r = s
            .sample(&SampleOptions {
                seed,
                schedule: Schedule {
                    generations: 6,
                    particles_start: 10,
                    particles_end: 4,
                    ..Schedule::calder_playground()
                },
                best: 4,
                ..SampleOptions::default()
            })
            .expect("samples");
        for m in &r.models {
            for order in 0..6 {
                assert_eq!(s.cost_in_order(&m.tree, order).expect("replays"), m.cost);
            }
            checked += 1;
        }
    }
    assert!(checked >= 6);
}

#[test]
fn frame_locality() {
    // A's expansion turns and moves; B, emitted after A by the same
    // production, must still grow straight up from the origin.
    let src = r#"
system Local {
    mode = sample;
    axiom S;
    skeleton S, A, B;
    S -> A B;
    A -> rotz(90) F(1) F(1);
    B -> F(2);
    wrapup S -> ;
    wrapup A -> ;
    wrapup B -> ;
}
"#;
    let p = program("local.grm", src);
    let c = compile(&p, 0);
    let curves = calder_curves();
    let s = curves_sampler(&p, &c, &curves);
    for seed in 0..5 {
        let r = s
            .sample(&SampleOptions {
                seed,
                schedule: Schedule {
                    generations: 5,
                    particles_start: 3,
                    particles_end: 3,
                    ..Schedule::calder_playground()
                },
                ..SampleOptions::default()
            })
            .expect("samples");
        let m = r.best().expect("model");
        let bones = &m.interpretation.bones;
        assert_eq!(bones.len(), 3);
        let b = bones
            .iter()
            .find(|b| (b.tip - b.base).length() > 1.5)
            .expect("B's bone");
        assert!(b.base.abs_diff_eq(Vec3::ZERO, 1e-6), "{:?}", b.base);
        assert!(
            b.tip.abs_diff_eq(Vec3::new(0.0, 2.0, 0.0), 1e-6),
            "{:?}",
            b.tip
        );
        // A's two bones chain along -x (rotz(90) turns +y to -x).
        let a: Vec<_> = bones
            .iter()
            .filter(|b| (b.tip - b.base).length() < 1.5)
            .collect();
        assert!(a[0].base.abs_diff_eq(Vec3::ZERO, 1e-6));
        assert!(
            a[1].tip.abs_diff_eq(Vec3::new(-2.0, 0.0, 0.0), 1e-5),
            "{:?}",
            a[1].tip
        );
        let first = bones.iter().position(|x| x == a[0]).expect("bone") as u32;
        assert_eq!(a[1].parent, Some(first));
        assert_eq!(b.parent, None, "B hangs off no bone: its frame is S's");
    }
}

#[test]
fn replaying_a_broken_tree_is_an_error_not_a_panic() {
    let p = example("calder_tree.grm");
    let c = compile(&p, 0);
    let curves = calder_curves();
    let s = curves_sampler(&p, &c, &curves);
    let r = s
        .sample(&SampleOptions {
            seed: 1,
            schedule: small(),
            ..SampleOptions::default()
        })
        .expect("samples");
    let tree = &r.best().expect("model").tree;
    let mut bad = tree.clone();
    bad.nodes[1].alt = Some(u32::MAX - 1);
    assert!(matches!(
        s.cost_in_order(&bad, 0),
        Err(SampleError::Options(_))
    ));
    let mut bad = tree.clone();
    bad.nodes[1].params.push(1.0);
    assert!(s.cost_in_order(&bad, 0).is_err());
    let mut bad = tree.clone();
    bad.nodes[0].params.push(1.0);
    assert!(s.cost_in_order(&bad, 0).is_err());
    let mut bad = tree.clone();
    bad.nodes.truncate(bad.nodes.len() / 2);
    assert!(s.cost_in_order(&bad, 0).is_err());
    assert!(s.cost_in_order(&DerivationTree::default(), 0).is_err());
    // Nodes that name themselves or the wrong node as parent.
    let mut cyclic = tree.clone();
    cyclic.nodes[1].parent = Some((1, 0));
    cyclic.nodes[2].parent = Some((0, 0));
    assert!(s.cost_in_order(&cyclic, 0).is_err());
}

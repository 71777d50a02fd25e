//! The derivation tree: built from the engine's decisions, its keys are
//! the string's, every key is its parent's child by the rule, and its
//! file is written whole or not at all.

use std::path::Path;

use grm_compile::{CompiledSystem, rng};
use grm_derive::{DeriveLimits, DeriveOptions};
use grm_grow::{Grower, Record, Tree, TreeMode};

fn repo() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
}

fn load(file: &str) -> (grm_diag::SourceMap, grm_sema::Checked) {
    let path = repo().join("examples").join(file);
    let text = std::fs::read_to_string(&path).expect("example");
    grm_sema::check_text(&path.display().to_string(), &text)
}

fn compile(checked: &grm_sema::Checked) -> CompiledSystem {
    let p = &checked.program;
    let sys = p.default_system().expect("a system");
    grm_compile::compile(p, sys, &p.default_params()).expect("compiles")
}

fn options(c: &CompiledSystem, iterations: u32) -> DeriveOptions {
    DeriveOptions {
        iterations,
        seed: c.settings.seed,
        limits: DeriveLimits::default(),
    }
}

/// Every node's key is `child_key(parent's key, salt)` of its place in
/// the parent's successor; the root's is the root key; a leaf's is its
/// module's key in the string.
fn check_keys(c: &CompiledSystem, tree: &Tree, string: &grm_derive::ModuleString) {
    assert_eq!(tree.nodes[0].key, tree.root_key);
    assert_eq!(tree.root_key, c.root_key(tree.seed));
    let children = tree.children();
    for (p, kids) in children.iter().enumerate() {
        if kids.is_empty() {
            continue;
        }
        let alt = tree.nodes[p].production.expect("a parent was rewritten");
        let succ = c.successor(&c.alts[alt as usize]);
        assert_eq!(
            succ.len(),
            kids.len(),
            "node {p}: one child per successor module"
        );
        for (j, &k) in kids.iter().enumerate() {
            let want = rng::child_key(tree.nodes[p].key, succ[j].salt);
            assert_eq!(tree.nodes[k as usize].key, want, "node {k}");
            assert_eq!(tree.nodes[k as usize].symbol, Some(succ[j].symbol));
        }
    }
    for m in 0..string.len() as u32 {
        let n = tree.node_of_module(m).expect("every module has a node");
        assert_eq!(tree.nodes[n as usize].key, string.keys()[m as usize]);
        assert_eq!(tree.nodes[n as usize].modules, m..m + 1);
        let path = tree.ancestry(n);
        assert_eq!(path.first(), Some(&0));
        assert_eq!(path.last(), Some(&n));
    }
}

#[test]
fn the_tree_of_a_derivation_is_keyed_by_the_rule() {
    for file in [
        "stochastic_plant.grm",
        "ternary_tree.grm",
        "context_plant_a.grm",
    ] {
        let (_, checked) = load(file);
        let c = compile(&checked);
        let opts = options(&c, c.settings.iterations.min(5));
        let plain = Grower::new(&c, 1, Record::default())
            .expect("engine")
            .derive(&opts, &mut |_| {})
            .expect("derives");
        let record = Record {
            tree: true,
            origins: true,
            ..Record::default()
        };
        let g = Grower::new(&c, 2, record)
            .expect("engine")
            .derive(&opts, &mut |_| {})
            .expect("derives");
        // Recording changes nothing in the string.
        assert_eq!(g.string.parts().syms, plain.string.parts().syms, "{file}");
        assert_eq!(
            g.string.parts().params,
            plain.string.parts().params,
            "{file}"
        );
        assert_eq!(g.stats.len(), plain.stats.len());
        let tree = g.tree.as_ref().expect("a tree");
        assert_eq!(tree.mode, TreeMode::Derive);
        check_keys(&c, tree, &g.string);
        // Nodes: the root, the axiom's modules, and every module a
        // production wrote.
        let written: u64 = g.stats.iter().map(|s| s.modules).sum();
        assert!(tree.nodes.len() as u64 <= 1 + written, "{file}");
        // Origins: the production of each leaf's parent.
        let origins = g.origins.as_ref().expect("origins");
        for (m, &o) in origins.iter().enumerate() {
            let n = tree.node_of_module(m as u32).expect("node");
            let parent = tree.nodes[n as usize].parent.expect("a leaf has a parent");
            assert_eq!(
                Some(o),
                tree.nodes[parent as usize].production,
                "{file} module {m}"
            );
        }
    }
}

#[test]
fn the_tree_file_is_json_with_every_node() {
    let (sources, checked) = load("stochastic_plant.grm");
    let c = compile(&checked);
    let record = Record {
        tree: true,
        ..Record::default()
    };
    let g = Grower::new(&c, 1, record)
        .expect("engine")
        .derive(&options(&c, 3), &mut |_| {})
        .expect("derives");
    let tree = g.tree.as_ref().expect("tree");
    let p = &checked.program;
    let sys = p.default_system().expect("system");
    let model =
        grm_geom::build_model(p, sys, &g.string, &c.settings, &c.param_values).expect("model");
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("tree.json");
    grm_grow::json::write(&path, tree, &c, &sources, Some(&model.skeleton)).expect("written");
    let v: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&path).expect("read")).expect("json");
    assert_eq!(v["format"], "grm-tree");
    assert_eq!(v["mode"], "derive");
    assert_eq!(v["system"], "StochasticPlant");
    let nodes = v["nodes"].as_array().expect("nodes");
    assert_eq!(nodes.len(), tree.nodes.len());
    assert_eq!(nodes[0]["parent"], serde_json::Value::Null);
    // Productions carry their source place: the three of the plant on
    // lines 30-32, and the axiom.
    let prods = v["productions"].as_array().expect("productions");
    assert_eq!(prods.len(), c.alts.len());
    let lines: Vec<u64> = prods
        .iter()
        .map(|p| p["line"].as_u64().expect("line"))
        .collect();
    assert_eq!(lines, [30, 31, 32, 28]);
    assert_eq!(prods[0]["symbol"], "F");
    assert_eq!(prods[3]["symbol"], serde_json::Value::Null);
    // Every bone belongs to exactly one leaf.
    let bones: u64 = nodes
        .iter()
        .map(|n| n["bones"][1].as_u64().expect("b") - n["bones"][0].as_u64().expect("a"))
        .sum();
    assert_eq!(bones, model.skeleton.bones.len() as u64);
    assert!(bones > 0);
}

#[test]
fn a_tree_file_that_cannot_be_written_leaves_nothing() {
    let (sources, checked) = load("stochastic_plant.grm");
    let c = compile(&checked);
    let record = Record {
        tree: true,
        ..Record::default()
    };
    let g = Grower::new(&c, 1, record)
        .expect("engine")
        .derive(&options(&c, 2), &mut |_| {})
        .expect("derives");
    let tree = g.tree.as_ref().expect("tree");
    let dir = tempfile::tempdir().expect("tempdir");
    // A missing folder, and a folder in the file's place.
    let missing = dir.path().join("no/such/dir/tree.json");
    let e = grm_grow::json::write(&missing, tree, &c, &sources, None).expect_err("no folder");
    assert_eq!(e.code().as_str(), "R0407");
    let e = grm_grow::json::write(dir.path(), tree, &c, &sources, None).expect_err("a folder");
    assert_eq!(e.code().as_str(), "R0407");
    let left: Vec<_> = std::fs::read_dir(dir.path()).expect("dir").collect();
    assert!(left.is_empty(), "nothing half-written: {left:?}");
}

#[test]
fn a_tree_over_the_memory_limit_stops_the_run() {
    let (_, checked) = load("stochastic_plant.grm");
    let c = compile(&checked);
    let record = Record {
        tree: true,
        ..Record::default()
    };
    let mut opts = options(&c, 6);
    // Room for the strings of 6 iterations, not for their tree.
    opts.limits.max_bytes = 200_000;
    Grower::new(&c, 1, Record::default())
        .expect("engine")
        .derive(&opts, &mut |_| {})
        .expect("the strings alone fit");
    match Grower::new(&c, 1, record)
        .expect("engine")
        .derive(&opts, &mut |_| {})
    {
        Err(e) => assert!(
            matches!(
                e,
                grm_grow::GrowError::Derive(grm_derive::DeriveError::MemoryLimit { .. })
            ),
            "{e}"
        ),
        Ok(g) => panic!(
            "the tree fits: {} modules, {} nodes",
            g.string.len(),
            g.tree.map_or(0, |t| t.nodes.len())
        ),
    }
}

/// Focus and context in derive mode: a module is in the window of node
/// `at` with `depth` exactly when `at` is on its path from the root at
/// most `depth` levels above it (checked against `ancestry` for every
/// node and depths 0 to 3); an unknown key has no window.
#[test]
fn the_focus_window_is_the_subtree_a_few_levels_down() {
    let (_, checked) = load("ternary_tree.grm");
    let c = compile(&checked);
    let record = Record {
        tree: true,
        ..Record::default()
    };
    let g = Grower::new(&c, 1, record)
        .expect("engine")
        .derive(&options(&c, 3), &mut |_| {})
        .expect("derives");
    let tree = g.tree.as_ref().expect("a tree");
    let mut sizes = Vec::new();
    for at in 0..tree.nodes.len() {
        // Keys are unique in a tree: the node is found by its key.
        let key = tree.nodes[at].key;
        for depth in 0..4 {
            let w = tree.focus_window(key, depth).expect("a window");
            assert_eq!(w.len(), g.string.len());
            for (m, &inside) in w.iter().enumerate() {
                let path = tree.ancestry(tree.node_of_module(m as u32).unwrap());
                let want = path
                    .iter()
                    .position(|&n| n as usize == at)
                    .is_some_and(|i| path.len() - 1 - i <= depth as usize);
                assert_eq!(inside, want, "node {at} depth {depth} module {m}");
            }
            sizes.push(w.iter().filter(|&&x| x).count());
        }
    }
    // The root at depth 3 and more holds every module; some windows are partial.
    assert!(sizes.iter().any(|&n| n > 0 && n < g.string.len()));
    assert_eq!(
        tree.focus_window(tree.root_key, 100).unwrap(),
        vec![true; g.string.len()]
    );
    let unused = (0..u32::MAX)
        .find(|k| tree.nodes.iter().all(|n| n.key != *k))
        .unwrap();
    assert!(tree.focus_window(unused, 1).is_none());
}

//! `--tree FILE.json`: the derivation tree as a new user writes it, and a
//! path that cannot be written.

mod common;

use common::*;

fn json(path: &std::path::Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(path).expect("tree written")).expect("json")
}

#[test]
fn derive_writes_the_tree_with_every_node_keyed() {
    let dir = tempfile::tempdir().expect("tempdir");
    let tree = dir.path().join("plant.json");
    let plant = example("stochastic_plant.grm");
    let out = grmc(&[
        "derive",
        &plant,
        "--tree",
        tree.to_str().expect("utf-8"),
        "--print",
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(
        text(&out.stderr).contains("nodes)"),
        "{}",
        text(&out.stderr)
    );
    let v = json(&tree);
    assert_eq!(v["mode"], "derive");
    let nodes = v["nodes"].as_array().expect("nodes");
    // The leaves are the printed string's modules, in order.
    let printed = text(&out.stdout);
    let words = printed.split_whitespace().count();
    let leaves: Vec<&serde_json::Value> = nodes
        .iter()
        .filter(|n| n["modules"][1].as_u64() > n["modules"][0].as_u64())
        .collect();
    assert_eq!(leaves.len(), words);
    // Every key is 8 hex digits; a node's parent comes before it.
    for (i, n) in nodes.iter().enumerate() {
        assert_eq!(n["key"].as_str().expect("key").len(), 8);
        if let Some(p) = n["parent"].as_u64() {
            assert!((p as usize) < i);
        }
    }
    // The same run gives the same file.
    let again = dir.path().join("again.json");
    let out = grmc(&["derive", &plant, "--tree", again.to_str().expect("utf-8")]);
    assert!(out.status.success());
    assert_eq!(
        std::fs::read(&tree).expect("first"),
        std::fs::read(&again).expect("second")
    );
}

#[test]
fn sample_writes_the_best_models_tree() {
    let dir = tempfile::tempdir().expect("tempdir");
    let tree = dir.path().join("tree.json");
    let out = grmc(&[
        "sample",
        &example("calder_tree.grm"),
        "--generations",
        "6",
        "--tree",
        tree.to_str().expect("utf-8"),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let v = json(&tree);
    assert_eq!(v["mode"], "sample");
    assert_eq!(v["system"], "CalderTree");
    let nodes = v["nodes"].as_array().expect("nodes");
    assert!(nodes.len() > 3);
    assert_eq!(nodes[0]["parent"], serde_json::Value::Null);
    let bones: u64 = nodes
        .iter()
        .map(|n| n["bones"][1].as_u64().expect("end") - n["bones"][0].as_u64().expect("start"))
        .sum();
    assert!(bones > 0);
}

#[test]
fn a_tree_path_that_cannot_be_written_is_r0407_before_any_work() {
    let dir = tempfile::tempdir().expect("tempdir");
    let missing = dir.path().join("no/such/folder/tree.json");
    let model = dir.path().join("model.glb");
    for bad in [
        missing.to_str().expect("utf-8"),
        dir.path().to_str().expect("utf-8"),
    ] {
        let out = grmc(&[
            "derive",
            &example("stochastic_plant.grm"),
            "--tree",
            bad,
            "-o",
            model.to_str().expect("utf-8"),
        ]);
        assert_eq!(out.status.code(), Some(2), "{bad}");
        assert!(text(&out.stderr).contains("R0407"), "{}", text(&out.stderr));
        // Refused before deriving: no model either.
        assert!(!model.exists());
    }
    let left: Vec<_> = std::fs::read_dir(dir.path()).expect("dir").collect();
    assert!(left.is_empty(), "nothing half-written: {left:?}");
}

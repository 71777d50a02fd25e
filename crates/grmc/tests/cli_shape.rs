//! Shape systems (`mode = shape`) from the command line: `grmc check`,
//! `grmc derive -o model.glb` (one named glTF node per terminal shape
//! group, with its locators), `--tree` (every node with its exact and
//! semantic locator and key), `--param` and `--seed`, the flags that do
//! not apply, run-time errors as coded diagnostics, and `grmc disasm`'s
//! refusal.

mod common;

use common::*;

fn json(path: &std::path::Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(path).expect("tree written")).expect("json")
}

fn path(p: &std::path::Path) -> &str {
    p.to_str().expect("utf-8")
}

#[test]
fn check_accepts_the_townhouse() {
    let out = grmc(&["check", &example("townhouse.grm")]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(text(&out.stderr).contains("0 errors, 0 warnings"));
}

#[test]
fn derive_writes_a_glb_with_named_groups_and_a_tree_with_locators() {
    let dir = tempfile::tempdir().expect("tempdir");
    let glb = dir.path().join("townhouse.glb");
    let tree = dir.path().join("townhouse.json");
    let house = example("townhouse.grm");
    let out = grmc(&["derive", &house, "-o", path(&glb), "--tree", path(&tree)]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let err = text(&out.stderr);
    assert!(err.contains("Townhouse: "), "{err}");
    assert!(err.contains("triangles"), "{err}");

    // The glb: one named node per terminal shape group, its locators in
    // the node's extras.
    let doc =
        gltf::Gltf::from_slice(&std::fs::read(&glb).expect("glb written")).expect("a valid glb");
    let named: Vec<gltf::Node> = doc.nodes().filter(|n| n.name().is_some()).collect();
    assert!(named.len() > 50, "{} named nodes", named.len());
    let pane = named
        .iter()
        .find(|n| n.name().is_some_and(|x| x.starts_with("Glass.")))
        .expect("a pane's glass");
    let extras = pane.extras().as_ref().expect("extras").get();
    assert!(
        extras.contains("\"exact\"") && extras.contains("\"semantic\""),
        "{extras}"
    );

    // The tree: every node keyed, with both locators.
    let v = json(&tree);
    assert_eq!(v["format"], "grm-tree");
    assert_eq!(v["mode"], "shape");
    assert_eq!(v["system"], "Townhouse");
    let nodes = v["nodes"].as_array().expect("nodes");
    assert_eq!(nodes[0]["symbol"], "Lot");
    assert_eq!(nodes[0]["exact"], "{Lot}");
    for (i, n) in nodes.iter().enumerate() {
        assert_eq!(n["key"].as_str().expect("key").len(), 8);
        assert!(n["exact"].as_str().expect("exact").starts_with("{Lot"));
        assert!(n["semantic"].is_string());
        if let Some(p) = n["parent"].as_u64() {
            assert!((p as usize) < i);
        }
    }
    let window = nodes
        .iter()
        .find(|n| n["symbol"] == "Window")
        .expect("a window");
    let semantic = window["semantic"].as_str().expect("semantic");
    for tag in ["house", "facade", "floor", "column"] {
        assert!(semantic.contains(tag), "{semantic}");
    }
    let prod = window["production"].as_u64().expect("a rule rewrote it") as usize;
    assert_eq!(v["productions"][prod]["symbol"], "Window");
    assert!(
        nodes
            .iter()
            .any(|n| n["kind"] == "command" && n["command"] == "repeat.y")
    );
    assert!(
        nodes
            .iter()
            .any(|n| n["kind"] == "insert" && n["asset"] == "box")
    );

    // The same run writes the same tree, with any number of threads.
    let again = dir.path().join("again.json");
    let out = grmc(&["derive", &house, "--threads", "3", "--tree", path(&again)]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert_eq!(
        std::fs::read(&tree).unwrap(),
        std::fs::read(&again).unwrap()
    );
}

#[test]
fn params_and_seeds_change_the_building() {
    let dir = tempfile::tempdir().expect("tempdir");
    let house = example("townhouse.grm");
    let count = |extra: &[&str], name: &str| {
        let tree = dir.path().join(name);
        let mut args = vec!["derive", house.as_str(), "--tree", path(&tree)];
        args.extend_from_slice(extra);
        let out = grmc(&args);
        assert!(out.status.success(), "{}", text(&out.stderr));
        let v = json(&tree);
        let floors = v["nodes"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|n| n["symbol"] == "Floor")
            .count();
        (
            floors,
            v["seed"].as_u64().unwrap(),
            v["nodes"].as_array().unwrap().len(),
        )
    };
    let (floors4, seed, _) = count(&[], "a.json");
    assert_eq!(seed, 1);
    let (floors7, _, _) = count(&["--param", "floors=7"], "b.json");
    // Three houses, two facades each: 3 upper floors each, then 6.
    assert_eq!(floors4, 3 * 2 * 3);
    assert_eq!(floors7, 3 * 2 * 6);
    let (_, seed, _) = count(&["--seed", "9"], "c.json");
    assert_eq!(seed, 9);
}

#[test]
fn flags_that_do_not_apply_are_usage_errors() {
    let house = example("townhouse.grm");
    for flag in [&["-n", "3"][..], &["--print"], &["--gpu"]] {
        let mut args = vec!["derive", house.as_str()];
        args.extend_from_slice(flag);
        let out = grmc(&args);
        assert_eq!(
            out.status.code(),
            Some(2),
            "{flag:?}: {}",
            text(&out.stderr)
        );
    }
}

#[test]
fn run_time_errors_are_coded_and_point_at_the_rule() {
    let dir = tempfile::tempdir().expect("tempdir");
    let file = dir.path().join("forever.grm");
    std::fs::write(
        &file,
        "system Forever {\n    mode = shape;\n    axiom A;\n    A -> split(x) { ~1: A | ~1: A };\n}\n",
    )
    .unwrap();
    let out = grmc(&["derive", path(&file), "--max-modules", "5000"]);
    assert_eq!(out.status.code(), Some(1));
    let err = text(&out.stderr);
    assert!(err.contains("R0801") || err.contains("R0802"), "{err}");

    // A lot that a --param makes degenerate.
    let file = dir.path().join("lot.grm");
    std::fs::write(
        &file,
        "param w = 10 in 0 .. 20;\nsystem S {\n    mode = shape;\n    lot = rect(w, 5);\n    axiom A;\n}\n",
    )
    .unwrap();
    let out = grmc(&["derive", path(&file), "--param", "w=0"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(text(&out.stderr).contains("E0509"), "{}", text(&out.stderr));
}

#[test]
fn disasm_says_a_shape_system_has_no_bytecode() {
    let out = grmc(&["disasm", &example("townhouse.grm")]);
    assert_eq!(out.status.code(), Some(1));
    let err = text(&out.stderr);
    assert!(
        err.contains("R0806") && err.contains("no bytecode"),
        "{err}"
    );
}

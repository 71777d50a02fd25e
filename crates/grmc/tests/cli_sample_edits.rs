//! `grmc edits check` of a sample-mode system (issue 27): the Calder tree
//! sampled once with its edits replayed and each edit classified. The
//! target is taken from the tree `grmc sample --tree` writes (the same
//! seed, so the same keys).

mod common;

use common::*;

#[test]
fn check_classifies_sample_mode_edits() {
    let dir = calder_copy();
    let grm = dir.path().join("calder_tree.grm");
    let tree = dir.path().join("tree.json");
    let out = grmc(&["sample", path(&grm), "--tree", path(&tree)]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let t: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&tree).expect("tree")).expect("json");
    let nodes = t["nodes"].as_array().expect("nodes");
    let symbol = |n: &serde_json::Value| n["symbol"].as_str().unwrap_or("").to_owned();
    // The first branchOrLeaf (below START's branch: in every model).
    let bol = nodes
        .iter()
        .find(|n| symbol(n) == "branchOrLeaf")
        .expect("a branchOrLeaf");
    let key = bol["key"].as_str().expect("key");
    let edits = dir.path().join("calder_tree.edits.json");
    let write = |body: &str| {
        std::fs::write(&edits, format!("{{\"version\": 2, \"edits\": [{body}]}}")).unwrap()
    };
    let force = format!(
        "{{\"id\": 1, \"system\": \"CalderTree\", \"target\": {{\"key\": \"{key}\"}}, \"op\": \"force\", \"alternative\": 1}}"
    );
    let check = || {
        let out = grmc(&["edits", "check", path(&grm), "--format", "json"]);
        let v: serde_json::Value = serde_json::from_slice(&out.stdout)
            .unwrap_or_else(|e| panic!("{e}: {}{}", text(&out.stdout), text(&out.stderr)));
        let classes: Vec<(u64, String)> = v["list"]
            .as_array()
            .expect("list")
            .iter()
            .map(|e| {
                (
                    e["id"].as_u64().unwrap(),
                    e["class"].as_str().unwrap_or("-").to_owned(),
                )
            })
            .collect();
        (out.status.success(), classes)
    };
    write(&force);
    assert_eq!(check(), (true, vec![(1, "valid".to_owned())]));
    let gone = "{\"id\": 2, \"system\": \"CalderTree\", \"target\": {\"key\": \"0badf00d\"}, \"op\": \"remove\"}";
    write(&format!("{force}, {gone}"));
    assert_eq!(
        check(),
        (
            false,
            vec![
                (1, "valid".to_owned()),
                (2, "structurally_invalid".to_owned())
            ]
        )
    );
}

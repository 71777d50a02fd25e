//! `grmc edits check|list` (issue 27): the edits file beside a grammar,
//! classified against the model grown now. Targets are taken from the
//! tree `grmc derive --tree` writes (ground truth by construction), then
//! the grammar's parameters change under them.

mod common;

use common::*;

fn path(p: &std::path::Path) -> &str {
    p.to_str().expect("utf-8")
}

/// A copy of the townhouse in a temporary directory, its tree's nodes,
/// and the grammar's path there.
fn townhouse() -> (
    tempfile::TempDir,
    std::path::PathBuf,
    Vec<serde_json::Value>,
) {
    let dir = tempfile::tempdir().expect("tempdir");
    let grm = dir.path().join("townhouse.grm");
    std::fs::copy(example("townhouse.grm"), &grm).expect("copy");
    let tree = dir.path().join("tree.json");
    let out = grmc(&["derive", path(&grm), "--tree", path(&tree)]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let v: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&tree).expect("tree")).expect("json");
    let nodes = v["nodes"].as_array().expect("nodes").clone();
    (dir, grm, nodes)
}

fn node<'a>(nodes: &'a [serde_json::Value], symbol: &str, semantic: &str) -> &'a serde_json::Value {
    nodes
        .iter()
        .find(|n| {
            n["symbol"] == symbol && n["semantic"].as_str().is_some_and(|s| s.contains(semantic))
        })
        .unwrap_or_else(|| panic!("no {symbol} with {semantic}"))
}

fn check(grm: &std::path::Path, extra: &[&str]) -> (bool, serde_json::Value) {
    let mut args = vec!["edits", "check", path(grm), "--format", "json"];
    args.extend_from_slice(extra);
    let out = grmc(&args);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout)
        .unwrap_or_else(|e| panic!("{e}: {}{}", text(&out.stdout), text(&out.stderr)));
    (out.status.success(), v)
}

fn classes(v: &serde_json::Value) -> Vec<(u64, String)> {
    v["list"]
        .as_array()
        .expect("list")
        .iter()
        .map(|e| {
            (
                e["id"].as_u64().unwrap(),
                e["class"].as_str().unwrap_or("-").to_owned(),
            )
        })
        .collect()
}

#[test]
fn check_classifies_each_edit_and_follows_the_parameters() {
    let (dir, grm, nodes) = townhouse();
    let window = node(&nodes, "Window", "floor = 1/");
    let top_floor = node(&nodes, "Floor", "floor = 3/3");
    let exact = |n: &serde_json::Value| n["exact"].as_str().unwrap().to_owned();
    let edits = serde_json::json!({
        "version": 1,
        "edits": [
            { "id": 1, "system": "Townhouse", "target": { "exact": exact(window) }, "op": "material", "name": "wood" },
            { "id": 2, "system": "Townhouse", "target": { "key": window["key"] }, "op": "remove" },
            { "id": 3, "system": "Townhouse", "target": { "semantic": "(column = end 1) Window" }, "op": "force", "alternative": 1 },
            { "id": 4, "system": "Townhouse", "target": { "exact": exact(top_floor) }, "op": "material", "name": "plaster" },
        ]
    });
    std::fs::write(
        dir.path().join("townhouse.edits.json"),
        serde_json::to_string_pretty(&edits).unwrap(),
    )
    .unwrap();
    let (ok, v) = check(&grm, &[]);
    assert!(ok, "{v}");
    assert_eq!(v["valid"], true);
    assert!(classes(&v).iter().all(|(_, c)| c == "valid"), "{v}");
    // Semantic: the last column of every floor of every house.
    assert!(v["list"][2]["parts"].as_u64().unwrap() > 1, "{v}");

    // Two storeys (one upper floor): the third upper floor's place is gone (dormant), the rest
    // still found; exit 1.
    let (ok, v) = check(&grm, &["--param", "floors=2"]);
    assert!(!ok);
    assert_eq!(
        classes(&v),
        [
            (1, "valid".to_owned()),
            (2, "valid".to_owned()),
            (3, "valid".to_owned()),
            (4, "structurally_invalid".to_owned())
        ]
    );
    // Six storeys: the edit applies again.
    let (ok, v) = check(&grm, &["--param", "floors=6"]);
    assert!(ok, "{v}");

    // Stale operations and another system's edits.
    let edits = serde_json::json!({
        "version": 1,
        "edits": [
            { "id": 1, "system": "Townhouse", "target": { "exact": exact(window) }, "op": "material", "name": "gold" },
            { "id": 2, "system": "Townhouse", "target": { "key": window["key"] }, "op": "force", "alternative": 7 },
            { "id": 3, "system": "Nowhere", "target": { "key": window["key"] }, "op": "remove" },
            { "id": 4, "system": "Townhouse", "target": { "exact": "{Lot, 1, Garden}" }, "op": "remove" },
        ]
    });
    let other = dir.path().join("other.edits.json");
    std::fs::write(&other, edits.to_string()).unwrap();
    let (ok, v) = check(&grm, &["--edits", path(&other)]);
    assert!(!ok);
    assert_eq!(
        classes(&v),
        [
            (1, "stale".to_owned()),
            (2, "stale".to_owned()),
            (3, "stale".to_owned()),
            (4, "semantically_invalid".to_owned())
        ]
    );
    assert!(
        v["list"][1]["detail"].as_str().unwrap().contains("not 7"),
        "{v}"
    );
}

#[test]
fn malformed_edits_are_coded_and_the_valid_ones_still_listed() {
    let (dir, grm, _) = townhouse();
    std::fs::write(
        dir.path().join("townhouse.edits.json"),
        r#"{"version": 1, "edits": [
  {"id": 1, "system": "Townhouse", "target": {"key": "zz"}, "op": "remove"},
  {"id": 2, "system": "Townhouse", "target": {"exact": "{Lot}"}, "op": "material", "name": "brick"}
]}"#,
    )
    .unwrap();
    let out = grmc(&["edits", "list", path(&grm)]);
    assert!(!out.status.success());
    let err = text(&out.stderr);
    assert!(err.contains("R0909"), "{err}");
    let list = text(&out.stdout);
    assert!(
        list.contains("material brick") && !list.contains("zz"),
        "{list}"
    );
    // No edits file: nothing to check, exit 0.
    std::fs::remove_file(dir.path().join("townhouse.edits.json")).unwrap();
    let out = grmc(&["edits", "check", path(&grm)]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(text(&out.stderr).contains("no edits file"));
}

/// A key edit's recorded symbol (version 3): `check` classifies the key
/// on that symbol's parts only and both commands show it beside the key;
/// a second edit of the key recording another symbol is R0911, exit 1.
#[test]
fn key_edits_show_and_keep_their_symbols() {
    let (dir, grm, nodes) = townhouse();
    let window = nodes
        .iter()
        .find(|n| n["symbol"] == "Window")
        .expect("a window");
    let key = window["key"].as_str().expect("key");
    let write = |edits: &str| {
        std::fs::write(
            dir.path().join("townhouse.edits.json"),
            format!(r#"{{ "version": 3, "edits": [ {edits} ] }}"#),
        )
        .expect("write")
    };
    write(&format!(
        r#"{{ "id": 1, "system": "Townhouse", "target": {{ "key": "{key}" }}, "symbol": "Window", "op": "remove" }},
           {{ "id": 2, "system": "Townhouse", "target": {{ "key": "{key}" }}, "op": "material", "name": "glass" }}"#
    ));
    let (ok, v) = check(&grm, &[]);
    assert!(ok, "{v}");
    assert_eq!(v["list"][0]["symbol"], "Window");
    assert!(v["list"][1].get("symbol").is_none(), "{v}");
    let out = grmc(&["edits", "list", path(&grm)]);
    assert!(
        text(&out.stdout).contains(&format!("key {key} (Window)  remove")),
        "{}",
        text(&out.stdout)
    );
    // Another symbol: nothing of it has the key.
    write(&format!(
        r#"{{ "id": 1, "system": "Townhouse", "target": {{ "key": "{key}" }}, "symbol": "Door", "op": "remove" }}"#
    ));
    let (ok, v) = check(&grm, &[]);
    assert!(!ok);
    assert_eq!(classes(&v), [(1, "structurally_invalid".to_owned())]);
    assert_eq!(v["list"][0]["detail"], "no `Door` has this key now");
    // Two symbols for one key: the second edit is refused, the first kept.
    write(&format!(
        r#"{{ "id": 1, "system": "Townhouse", "target": {{ "key": "{key}" }}, "symbol": "Window", "op": "remove" }},
           {{ "id": 2, "system": "Townhouse", "target": {{ "key": "{key}" }}, "symbol": "Door", "op": "remove" }}"#
    ));
    let (ok, v) = check(&grm, &[]);
    assert!(!ok);
    assert_eq!(classes(&v), [(1, "valid".to_owned())]);
    assert_eq!(v["problems"][0]["code"], "R0911", "{v}");
}

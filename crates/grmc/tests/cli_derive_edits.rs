//! Persistent edits of a derive-mode system from the command line
//! (docs/edits.md): `grmc derive` replays NAME.edits.json beside the
//! grammar (`--edits`, `--no-edits`), says what it replayed and what not,
//! derives on the CPU when `--gpu` meets edits; `grmc edits check`
//! classifies them. Targets are keys from the tree `grmc derive --tree`
//! writes.

mod common;

use common::*;

fn path(p: &std::path::Path) -> &str {
    p.to_str().expect("utf-8")
}

/// The modules of the final string under node `i` (itself included).
fn leaves(nodes: &[serde_json::Value], i: usize) -> u64 {
    let n = &nodes[i];
    let own = n["modules"][1].as_u64().unwrap() - n["modules"][0].as_u64().unwrap();
    own + n["children"]
        .as_array()
        .expect("children")
        .iter()
        .map(|c| leaves(nodes, c.as_u64().unwrap() as usize))
        .sum::<u64>()
}

fn modules(printed: &str) -> usize {
    printed.split_whitespace().count()
}

#[test]
fn derive_replays_key_edits_and_check_classifies_them() {
    let dir = tempfile::tempdir().expect("tempdir");
    let grm = dir.path().join("plant.grm");
    std::fs::copy(example("stochastic_plant.grm"), &grm).expect("copy");
    let tree = dir.path().join("tree.json");
    let base = grmc(&[
        "derive",
        path(&grm),
        "-n",
        "3",
        "--tree",
        path(&tree),
        "--print",
    ]);
    assert!(base.status.success(), "{}", text(&base.stderr));
    let plain = text(&base.stdout);
    let v: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&tree).expect("tree")).expect("json");
    let nodes = v["nodes"].as_array().expect("nodes").clone();
    let system = v["system"].as_str().expect("system").to_owned();
    // An F of string 1 that was rewritten: a branch to remove.
    let branch = (0..nodes.len())
        .find(|&i| {
            nodes[i]["iteration"] == 1
                && nodes[i]["symbol"] == "F"
                && nodes[i]["production"].is_u64()
        })
        .expect("a rewritten F");
    let gone = leaves(&nodes, branch);
    assert!(gone > 1);
    let edits = serde_json::json!({
        "version": 1,
        "edits": [
            { "id": 1, "system": system, "target": { "key": nodes[branch]["key"] }, "op": "remove" },
            { "id": 2, "system": system, "target": { "key": "0badc0de" }, "op": "remove" },
            { "id": 3, "system": system, "target": { "key": nodes[branch]["key"] }, "op": "set", "name": "nothing", "value": 1 },
        ]
    });
    std::fs::write(
        dir.path().join("plant.edits.json"),
        serde_json::to_string_pretty(&edits).unwrap(),
    )
    .unwrap();

    let out = grmc(&["derive", path(&grm), "-n", "3", "--print"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let err = text(&out.stderr);
    assert!(err.contains("replayed 1 of 3 edits"), "{err}");
    assert!(err.contains("edit 2: structurally_invalid"), "{err}");
    assert!(
        err.contains("edit 3: stale: no module has a number parameter `nothing`"),
        "{err}"
    );
    let edited = text(&out.stdout);
    assert_eq!(modules(&edited) as u64, modules(&plain) as u64 - gone);

    // The same with the tree recorded; none with --no-edits; another file
    // with --edits.
    let out = grmc(&[
        "derive",
        path(&grm),
        "-n",
        "3",
        "--print",
        "--tree",
        path(&tree),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert_eq!(text(&out.stdout), edited);
    let out = grmc(&["derive", path(&grm), "-n", "3", "--print", "--no-edits"]);
    assert_eq!(text(&out.stdout), plain);
    let other = dir.path().join("other.edits.json");
    std::fs::write(&other, r#"{"version": 1, "edits": []}"#).unwrap();
    let out = grmc(&[
        "derive",
        path(&grm),
        "-n",
        "3",
        "--print",
        "--edits",
        path(&other),
    ]);
    assert_eq!(text(&out.stdout), plain);

    // --frames replays them too: the last frame is the edited model (an
    // OBJ names its material file on line 2).
    let obj = dir.path().join("a.obj");
    let out = grmc(&["derive", path(&grm), "-n", "3", "-o", path(&obj)]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let frames = dir.path().join("f.obj");
    let out = grmc(&[
        "derive",
        path(&grm),
        "-n",
        "3",
        "--frames",
        "-o",
        path(&frames),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let body = |p: std::path::PathBuf| {
        let t = std::fs::read_to_string(p).expect("obj");
        t.lines().skip(2).collect::<Vec<_>>().join("\n")
    };
    assert_eq!(body(dir.path().join("f-3.obj")), body(obj.clone()));
    let plain_obj = dir.path().join("p.obj");
    let out = grmc(&[
        "derive",
        path(&grm),
        "-n",
        "3",
        "--no-edits",
        "-o",
        path(&plain_obj),
    ]);
    assert!(out.status.success());
    assert_ne!(body(plain_obj), body(obj));

    // --gpu with edits: derived on the CPU, said so, the same string (no
    // GPU is needed).
    let out = grmc(&["derive", path(&grm), "-n", "3", "--print", "--gpu"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let err = text(&out.stderr);
    assert!(err.contains("deriving on the CPU, not the GPU"), "{err}");
    assert_eq!(text(&out.stdout), edited);

    // `edits check` at the system's own 5 iterations: the branch is there,
    // the key is not; exit 1 (not every edit replayed).
    let out = grmc(&["edits", "check", path(&grm), "--format", "json"]);
    assert!(!out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout)
        .unwrap_or_else(|e| panic!("{e}: {}{}", text(&out.stdout), text(&out.stderr)));
    let classes: Vec<(u64, String, bool)> = v["list"]
        .as_array()
        .expect("list")
        .iter()
        .map(|e| {
            (
                e["id"].as_u64().unwrap(),
                e["class"].as_str().unwrap_or("-").to_owned(),
                e["replayed"].as_bool().unwrap(),
            )
        })
        .collect();
    assert_eq!(
        classes,
        [
            (1, "valid".to_owned(), true),
            (2, "structurally_invalid".to_owned(), false),
            (3, "stale".to_owned(), false),
        ]
    );
    // Only the valid edit: exit 0; another seed: the key sleeps.
    let edits = serde_json::json!({
        "version": 1,
        "edits": [ { "id": 1, "system": system, "target": { "key": nodes[branch]["key"] }, "op": "remove" } ]
    });
    std::fs::write(
        dir.path().join("plant.edits.json"),
        serde_json::to_string_pretty(&edits).unwrap(),
    )
    .unwrap();
    let out = grmc(&["edits", "check", path(&grm)]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let out = grmc(&["edits", "check", path(&grm), "--seed", "12345"]);
    assert!(!out.status.success());
    assert!(text(&out.stdout).contains("structurally_invalid"));
}

//! `grmc sample` replays the persistent edits beside the grammar (issue
//! 27, docs/edits.md "Sample mode"): `--edits FILE` for another,
//! `--no-edits` for none, and the "replayed" lines after the run. The
//! target is a key from the tree `grmc sample --tree` writes (the same
//! seed, so the same keys).

mod common;

use common::*;

#[test]
fn sample_replays_the_edits_beside_the_grammar() {
    let dir = calder_copy();
    let grm = dir.path().join("calder_tree.grm");
    // A short search (the model is the same for the same seed and edits).
    let sample = |out: &std::path::Path, more: &[&str]| {
        let mut args = vec![
            "sample",
            path(&grm),
            "--generations",
            "6",
            "--particles",
            "12..6",
            "-o",
            path(out),
        ];
        args.extend_from_slice(more);
        let o = grmc(&args);
        assert!(o.status.success(), "{}", text(&o.stderr));
        (std::fs::read(out).expect("glb"), text(&o.stderr))
    };
    let tree = dir.path().join("tree.json");
    let (plain, err) = sample(&dir.path().join("plain.glb"), &["--tree", path(&tree)]);
    assert!(!err.contains("replayed"), "no edits file, no lines: {err}");
    let t: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&tree).expect("tree")).expect("json");
    // The first branchOrLeaf (below START's branch: in every model):
    // removed, the model is that one branch.
    let bol = t["nodes"]
        .as_array()
        .expect("nodes")
        .iter()
        .find(|n| n["symbol"] == "branchOrLeaf")
        .expect("a branchOrLeaf");
    let key = bol["key"].as_str().expect("key");
    let remove = format!(
        "{{\"id\": 1, \"system\": \"CalderTree\", \"target\": {{\"key\": \"{key}\"}}, \"op\": \"remove\"}}"
    );
    let dormant = "{\"id\": 2, \"system\": \"CalderTree\", \"target\": {\"key\": \"0badf00d\"}, \"op\": \"remove\"}";
    let file = |name: &str, body: &str| {
        let p = dir.path().join(name);
        std::fs::write(&p, format!("{{\"version\": 1, \"edits\": [{body}]}}")).unwrap();
        p
    };
    file("calder_tree.edits.json", &format!("{remove}, {dormant}"));

    let (edited, err) = sample(&dir.path().join("edited.glb"), &[]);
    assert!(
        edited.len() < plain.len(),
        "the removed subtree is gone: {} bytes, plain {}",
        edited.len(),
        plain.len()
    );
    assert!(err.contains("CalderTree: replayed 1 of 2 edits"), "{err}");
    assert!(err.contains("edit 2: structurally_invalid"), "{err}");
    assert!(!err.contains("edit 1:"), "{err}");

    // --no-edits: the plain model, no lines.
    let (none, err) = sample(&dir.path().join("none.glb"), &["--no-edits"]);
    assert_eq!(none, plain);
    assert!(!err.contains("replayed"), "{err}");

    // --edits: that file instead (the removal alone; an empty one is the
    // plain model).
    let other = file("other.json", &remove);
    let (again, err) = sample(&dir.path().join("again.glb"), &["--edits", path(&other)]);
    assert_eq!(again, edited);
    assert!(err.contains("CalderTree: replayed 1 of 1 edit"), "{err}");
    assert!(!err.contains("structurally_invalid"), "{err}");
    let empty = file("empty.json", "");
    let (same, _) = sample(&dir.path().join("same.glb"), &["--edits", path(&empty)]);
    assert_eq!(same, plain);

    // --edits and --no-edits together: a usage error.
    let o = grmc(&["sample", path(&grm), "--edits", path(&other), "--no-edits"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o.stderr));
}

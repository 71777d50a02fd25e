//! Retarget quick fixes in the derive-mode preview (docs/edits.md,
//! "Retargeting"): a key edit whose module's key changed (an alternative
//! inserted before the production that made it re-mints every key below)
//! is proposed the keys of modules of the same symbol, the same ancestry
//! first, nearest to where its part was drawn (the print the server kept
//! while the edit was valid); the first is the same module, and the quick
//! fix makes the edit valid again.

mod common;

use common::editor::Editor;
use common::*;
use serde_json::{Value, json};
use tower_lsp_server::ls_types::Uri;

const PLANT: &str = "system Plant {
    iterations = 3;
    seed = 5;
    module A(len: float);
    axiom A(1);
    A(l) -> F(l) [ +(30) A(l * 0.8) ] [ -(25) A(l * 0.7) ] A(l * 0.9);
}
";

/// The plant with an alternative of next to no weight before A's
/// production: the same model, every key below the axiom's A re-minted.
fn reordered() -> String {
    let t = PLANT.replace(
        "    A(l) -> F(l)",
        "    A(l) -> (1e-20) F(l);\n    A(l) -> (1) F(l)",
    );
    assert_ne!(t, PLANT);
    t
}

/// The first pick (part, triangle) whose module lies four levels below
/// the root, and the key of the module that wrote it (an A of string 2).
async fn deep_pick(c: &mut Editor, u: &Value, r: &Value) -> (usize, Value, String) {
    for (i, part) in r["parts"].as_array().expect("parts").iter().enumerate() {
        for pk in picks(part) {
            let got = c
                .ok(
                    "grm/pick",
                    json!({ "textDocument": { "uri": u }, "part": i,
                            "triangle": pk["firstTriangle"] }),
                )
                .await;
            let a = got["ancestry"].as_array().expect("ancestry");
            if a.len() == 5 {
                let key = a[3]["key"].as_str().expect("key").to_owned();
                assert_eq!(a[3]["symbol"], "A");
                return (i, pk["firstTriangle"].clone(), key);
            }
        }
    }
    panic!("no module four levels down")
}

/// The key of the module that wrote the pick (`part`, `triangle`).
async fn writer_key(c: &mut Editor, u: &Value, part: usize, triangle: &Value) -> String {
    let got = c
        .ok(
            "grm/pick",
            json!({ "textDocument": { "uri": u }, "part": part, "triangle": triangle }),
        )
        .await;
    let a = got["ancestry"].as_array().expect("ancestry");
    assert_eq!(a.len(), 5, "{got}");
    a[3]["key"].as_str().expect("key").to_owned()
}

/// A plant open in an editor with one key edit (`op` and its fields, on
/// the A four levels down) that was valid and replayed, then the
/// alternative inserted before A's production: the edit's key is gone.
struct Broken {
    c: Editor,
    _dir: tempfile::TempDir,
    /// The edits file's uri and text.
    eu: Uri,
    one: String,
    /// The previews: before the edit, with it (valid), after the change.
    base: Value,
    edited: Value,
    after: Value,
    /// The edit's key, and the key of the same A now.
    key: String,
    want: String,
}

async fn broken(op: Value) -> Broken {
    let dir = tempfile::tempdir().expect("tempdir");
    let root = grm_sema::normalize(&std::fs::canonicalize(dir.path()).expect("canonical"));
    let p = root.join("plant.grm");
    std::fs::write(&p, PLANT).expect("write");
    let mut c = Editor::start().await;
    let u = c.open(&p, PLANT, 1).await;
    let uv = serde_json::to_value(&u).unwrap();
    let base = c
        .ok(
            "grm/preview",
            json!({ "textDocument": { "uri": u }, "live": true }),
        )
        .await;
    let (part, triangle, key) = deep_pick(&mut c, &uv, &base).await;

    let ep = grm_edits::edits_path(&p);
    let mut edit = json!({ "id": 1, "system": "Plant", "target": { "key": key } });
    for (k, v) in op.as_object().expect("op fields") {
        edit[k] = v.clone();
    }
    let one = serde_json::to_string_pretty(&json!({ "version": 1, "edits": [edit] })).unwrap();
    let eu = c.open(&ep, &one, 1).await;
    let edited = c
        .updated(|r| r["edits"]["list"][0]["class"] == "valid")
        .await;
    assert_eq!(edited["edits"]["list"][0]["replayed"], true);
    assert!(
        edited["edits"]["list"][0].get("retarget").is_none(),
        "{edited}"
    );

    c.replace(&u, 2, &reordered()).await;
    let after = c
        .updated(|r| r["edits"]["list"][0]["class"] == "structurally_invalid")
        .await;
    let want = writer_key(&mut c, &uv, part, &triangle).await;
    assert_ne!(want, key, "re-minted");
    Broken {
        c,
        _dir: dir,
        eu,
        one,
        base,
        edited,
        after,
        key,
        want,
    }
}

/// The broken edit's diagnostic and code actions, and the edits file as
/// the first one (the best candidate) leaves it.
async fn first_fix(b: &mut Broken) -> (Value, Vec<Value>, String) {
    let ev = serde_json::to_value(&b.eu).unwrap();
    let d =
        b.c.diagnostics(&b.eu, |d| {
            d.len() == 1 && d[0]["code"] == "edit.structurally_invalid"
        })
        .await;
    let a =
        b.c.ok(
            "textDocument/codeAction",
            json!({ "textDocument": { "uri": ev }, "range": d[0]["range"],
                    "context": { "diagnostics": [d[0].clone()] } }),
        )
        .await;
    let a = a.as_array().expect("actions").clone();
    let fixed = apply(
        &b.one,
        a[0]["edit"]["changes"][ev.as_str().unwrap()]
            .as_array()
            .expect("the edits file's change"),
    );
    (d[0].clone(), a, fixed)
}

#[tokio::test]
async fn a_key_lost_to_a_reordered_alternative_is_offered_the_same_module_first() {
    // A small offset of the A's length: valid, replayed, its print kept.
    let mut b = broken(json!({ "op": "offset", "name": "len", "by": 0.001 })).await;
    let (r, want) = (&b.after, &b.want);
    assert_eq!(triangles(r), triangles(&b.base), "the same model");
    let cands = r["edits"]["list"][0]["retarget"]
        .as_array()
        .expect("candidates");
    assert_eq!(cands.len(), 4, "{cands:?}");
    assert_eq!(cands[0]["target"], json!({ "key": want }), "{cands:?}");
    assert_eq!(cands[0]["reason"], "ancestry");
    assert_eq!(cands[0]["parts"].as_array().map(Vec::len), Some(1));
    // Each key names an A: the fix records it (the edit's `symbol`).
    assert!(cands.iter().all(|c| c["symbol"] == "A"), "{cands:?}");

    // The diagnostic carries them; the first quick fix retargets the edit.
    let want = want.clone();
    let (d, a, fixed) = first_fix(&mut b).await;
    assert!(
        d["message"]
            .as_str()
            .unwrap()
            .contains("retarget it to one of 4 parts"),
        "{d}"
    );
    assert_eq!(a.len(), 5, "{a:?}");
    assert_eq!(
        a[0]["title"],
        format!("Retarget edit 1 to {want} (same symbol and ancestry)")
    );
    assert_eq!(a[4]["title"], "Delete edit 1");
    let parsed = grm_edits::parse(&fixed);
    assert!(parsed.errors.is_empty(), "{fixed}");
    assert_eq!(parsed.file.edits[0].target.text(), want);
    assert_eq!(parsed.file.edits[0].symbol.as_deref(), Some("A"), "{fixed}");
    assert!(fixed.contains("\"version\": 3"), "{fixed}");
    b.c.replace(&b.eu, 2, &fixed).await;
    let r =
        b.c.updated(|r| r["edits"]["list"][0]["class"] == "valid")
            .await;
    assert_eq!(r["edits"]["list"][0]["replayed"], true);
    b.c.diagnostics(&b.eu, <[Value]>::is_empty).await;
}

#[tokio::test]
async fn a_removed_module_lost_to_a_reordered_alternative_is_offered_the_same_module_first() {
    // The A removed: valid, its subtree gone, its print kept (the module
    // is in no tree, but the derivation recorded what it removed).
    let mut b = broken(json!({ "op": "remove" })).await;
    assert!(
        triangles(&b.edited) < triangles(&b.base),
        "its subtree is gone"
    );
    // The key is gone, so nothing is removed.
    let r = &b.after;
    assert_eq!(triangles(r), triangles(&b.base), "the whole plant again");
    assert_ne!(b.key, b.want);
    let cands = r["edits"]["list"][0]["retarget"]
        .as_array()
        .expect("candidates");
    assert!(!cands.is_empty(), "{r}");
    assert_eq!(cands[0]["target"], json!({ "key": b.want }), "{cands:?}");
    assert_eq!(cands[0]["reason"], "ancestry");

    // The first quick fix's target removes the same A again.
    let (_, _, fixed) = first_fix(&mut b).await;
    b.c.replace(&b.eu, 2, &fixed).await;
    let r =
        b.c.updated(|r| r["edits"]["list"][0]["class"] == "valid")
            .await;
    assert_eq!(triangles(&r), triangles(&b.edited), "removed again");
}

//! `grm/tree` (issue 28, item 4): the last preview's derivation tree a
//! level at a time, linked to picks (by key: the path to a picked part)
//! and to the source (each node's rule), in shape and derive mode.

mod common;

use common::*;
use serde_json::json;

const HOUSE: &str = "system House {
    mode = shape;
    seed = 1;
    lot = rect(10, 6);
    axiom Lot;

    Lot -> extrude(8) Mass;
    Mass -> split(z) { 3: Ground | ~1: Top };
    Ground -> split(x) { ~1: Wall | 2: Door | ~1: Wall };
}
";

const TREE: &str = "system T {
    iterations = 2;
    axiom A;
    A -> F(1) [ + A ] A;
}
";

/// A client with `text` open as NAME in a fresh folder, previewed once;
/// the folder (kept while the test runs), the client, the URI and the
/// preview.
async fn previewed(
    name: &str,
    text: &str,
) -> (
    tempfile::TempDir,
    Client,
    tower_lsp_server::ls_types::Uri,
    serde_json::Value,
) {
    let dir = tempfile::tempdir().expect("tempdir");
    let p = dir.path().join(name);
    std::fs::write(&p, text).unwrap();
    let mut c = Client::start().await;
    let u = c.open(&p, text).await;
    let r = c
        .ok("grm/preview", json!({ "textDocument": { "uri": u } }))
        .await;
    (dir, c, u, r)
}

#[tokio::test]
async fn the_shape_tree_is_walked_a_level_at_a_time_and_reveals_a_pick() {
    let (_dir, mut c, u, _) = previewed("house.grm", HOUSE).await;
    let root = c
        .ok("grm/tree", json!({ "textDocument": { "uri": u } }))
        .await;
    assert_eq!(root["mode"], "shape");
    assert_eq!(root["node"]["label"], "Lot");
    assert_eq!(root["node"]["node"], 0);
    let kids = root["children"].as_array().unwrap();
    assert_eq!(kids.len(), 1);
    assert_eq!(kids[0]["label"], "Mass");
    // The node's range is the operation that made it: in `Lot -> extrude(8) Mass;`.
    assert_eq!(kids[0]["range"]["start"]["line"], 6);
    let mass = c
        .ok(
            "grm/tree",
            json!({ "textDocument": { "uri": u }, "node": kids[0]["node"] }),
        )
        .await;
    let labels: Vec<&str> = mass["children"]
        .as_array()
        .unwrap()
        .iter()
        .map(|k| k["label"].as_str().unwrap())
        .collect();
    assert_eq!(labels, ["split.z"]);
    // A pick's key reveals its path, ending at the picked shape.
    let pick = c
        .ok(
            "grm/pick",
            json!({ "textDocument": { "uri": u }, "part": 0, "triangle": 0 }),
        )
        .await;
    let found = c
        .ok(
            "grm/tree",
            json!({ "textDocument": { "uri": u }, "key": pick["key"] }),
        )
        .await;
    let path = found["path"].as_array().unwrap();
    assert_eq!(path.first(), Some(&json!(0)));
    assert_eq!(path.last(), Some(&pick["shape"]["node"]));
    assert_eq!(found["node"]["key"], pick["key"]);
    assert_eq!(found["node"]["range"], pick["range"]);
    // No such node: null.
    let none = c
        .ok(
            "grm/tree",
            json!({ "textDocument": { "uri": u }, "node": 100000 }),
        )
        .await;
    assert!(none.is_null());
}

#[tokio::test]
async fn the_derive_tree_links_picks_and_productions() {
    let (_dir, mut c, u, _) = previewed("t.grm", TREE).await;
    let root = c
        .ok("grm/tree", json!({ "textDocument": { "uri": u } }))
        .await;
    assert_eq!(root["mode"], "derive");
    assert_eq!(root["node"]["label"], "axiom");
    let kids = root["children"].as_array().unwrap();
    assert_eq!(kids.len(), 1);
    assert_eq!(kids[0]["label"], "A (iteration 0)");
    // A was rewritten by `A -> ...` on line 3: its six children.
    assert_eq!(kids[0]["range"]["start"]["line"], 3);
    assert_eq!(kids[0]["children"], 6);
    let pick = c
        .ok(
            "grm/pick",
            json!({ "textDocument": { "uri": u }, "bone": 2 }),
        )
        .await;
    let found = c
        .ok(
            "grm/tree",
            json!({ "textDocument": { "uri": u }, "key": pick["key"] }),
        )
        .await;
    let path = found["path"].as_array().unwrap();
    assert_eq!(path.len(), pick["ancestry"].as_array().unwrap().len());
    assert_eq!(found["node"]["key"], pick["key"]);
}

/// The drawn parts' triangle count of a preview.
fn triangles(r: &serde_json::Value) -> u64 {
    r["stats"]["triangles"].as_u64().expect("triangles")
}

/// House's tree read down to the ground floor: the root's answer, the
/// answer of the split that made the floors (its children), and the
/// ground floor's node.
async fn house_ground(
    c: &mut Client,
    u: &tower_lsp_server::ls_types::Uri,
) -> (serde_json::Value, serde_json::Value, serde_json::Value) {
    let root = c
        .ok("grm/tree", json!({ "textDocument": { "uri": u } }))
        .await;
    let mass = &root["children"][0];
    let split = &c
        .ok(
            "grm/tree",
            json!({ "textDocument": { "uri": u }, "node": mass["node"] }),
        )
        .await["children"][0];
    let kids = c
        .ok(
            "grm/tree",
            json!({ "textDocument": { "uri": u }, "node": split["node"] }),
        )
        .await;
    let ground = kids["children"]
        .as_array()
        .unwrap()
        .iter()
        .find(|n| n["label"] == "Ground")
        .unwrap()
        .clone();
    (root, kids, ground)
}

#[tokio::test]
async fn focus_and_context_draws_the_rest_as_proxies() {
    let (_dir, mut c, u, whole) = previewed("house.grm", HOUSE).await;
    // The ground floor's key, from the tree.
    let (root, _, ground) = house_ground(&mut c, &u).await;
    // Depth 0: the ground floor is one proxy box (its wall, door, wall not drawn).
    let focused = c
        .ok(
            "grm/preview",
            json!({ "textDocument": { "uri": u }, "context": { "key": ground["key"], "depth": 0 } }),
        )
        .await;
    assert_eq!(
        triangles(&whole) - triangles(&focused),
        24,
        "{}",
        focused["stats"]
    );
    // The proxy is picked as the ground floor itself.
    let (part, tri) = focused["parts"]
        .as_array()
        .unwrap()
        .iter()
        .enumerate()
        .find_map(|(i, part)| {
            picks(part)
                .into_iter()
                .find(|p| p["module"] == ground["node"])
                .map(|p| (i, p["firstTriangle"].clone()))
        })
        .expect("the proxy's triangles");
    let pick = c
        .ok(
            "grm/pick",
            json!({ "textDocument": { "uri": u }, "part": part, "triangle": tri }),
        )
        .await;
    assert_eq!(pick["symbol"], "Ground", "{pick}");
    assert_eq!(pick["key"], ground["key"]);
    // Deep enough: the whole building again.
    let deep = c
        .ok(
            "grm/preview",
            json!({ "textDocument": { "uri": u }, "context": { "key": ground["key"], "depth": 5 } }),
        )
        .await;
    assert_eq!(triangles(&deep), triangles(&whole));
    // Focus on the lot at depth 1: only the mass, as one proxy box.
    let top = c
        .ok(
            "grm/preview",
            json!({ "textDocument": { "uri": u }, "context": { "key": root["node"]["key"], "depth": 1 } }),
        )
        .await;
    assert_eq!(triangles(&top), 12, "{}", top["stats"]);
}

/// Whether the drawn runs (part, first, count triples) hold triangle `tri` of `part`.
fn holds(triangles: &[serde_json::Value], part: usize, tri: u64) -> bool {
    triangles.chunks_exact(3).any(|r| {
        r[0].as_u64() == Some(part as u64)
            && r[1].as_u64().unwrap() <= tri
            && tri < r[1].as_u64().unwrap() + r[2].as_u64().unwrap()
    })
}

/// A node's drawn parts are exactly the picks whose ancestry holds its key:
/// every pick of the preview is asked for (`grm/pick`) and compared.
async fn check_drawn(
    c: &mut Client,
    u: &tower_lsp_server::ls_types::Uri,
    r: &serde_json::Value,
    node: &serde_json::Value,
) -> usize {
    let asked = c
        .ok(
            "grm/tree",
            json!({ "textDocument": { "uri": u }, "node": node["node"], "drawn": true }),
        )
        .await;
    let drawn = &asked["drawn"];
    let tris = drawn["triangles"].as_array().expect("triangles");
    assert_eq!(tris.len() % 3, 0);
    let mut inside = 0;
    for (i, part) in r["parts"].as_array().unwrap().iter().enumerate() {
        for p in picks(part) {
            let first = p["firstTriangle"].as_u64().unwrap();
            let pick = c
                .ok(
                    "grm/pick",
                    json!({ "textDocument": { "uri": u }, "part": i, "triangle": first }),
                )
                .await;
            let under = pick["ancestry"]
                .as_array()
                .unwrap()
                .iter()
                .any(|a| a["key"] == node["key"]);
            assert_eq!(holds(tris, i, first), under, "pick {p} of part {i}: {pick}");
            let last = first + p["triangleCount"].as_u64().unwrap() - 1;
            assert_eq!(holds(tris, i, last), under);
            inside += usize::from(under);
        }
    }
    for b in 0..r["skeleton"]["boneCount"].as_u64().unwrap() {
        let pick = c
            .ok(
                "grm/pick",
                json!({ "textDocument": { "uri": u }, "bone": b }),
            )
            .await;
        let under = pick["ancestry"]
            .as_array()
            .unwrap()
            .iter()
            .any(|a| a["key"] == node["key"]);
        let listed = drawn["bones"].as_array().unwrap().contains(&json!(b));
        assert_eq!(listed, under, "bone {b}: {pick}");
        inside += usize::from(under);
    }
    inside
}

#[tokio::test]
async fn a_node_names_the_parts_its_subtree_drew() {
    // Derive mode: the axiom's A drew everything; the A in the branch (iteration 1) only its branch.
    let (_dir, mut c, u, r) = previewed("t.grm", TREE).await;
    let root = c
        .ok("grm/tree", json!({ "textDocument": { "uri": u } }))
        .await;
    let a = root["children"][0].clone();
    let all = check_drawn(&mut c, &u, &r, &a).await;
    let bones = r["skeleton"]["boneCount"].as_u64().unwrap() as usize;
    assert!(all >= bones && bones > 1, "{all} of {bones} bones");
    let level = c
        .ok(
            "grm/tree",
            json!({ "textDocument": { "uri": u }, "node": a["node"] }),
        )
        .await;
    let branch = level["children"]
        .as_array()
        .unwrap()
        .iter()
        .find(|n| n["label"] == "A (iteration 1)")
        .unwrap()
        .clone();
    let some = check_drawn(&mut c, &u, &r, &branch).await;
    assert!(some > 0 && some < all, "{some} of {all}");
    // Shape mode: the ground floor drew its wall, door and wall, and nothing else.
    let (_dir, mut c, u, r) = previewed("house.grm", HOUSE).await;
    let (root, kids, ground) = house_ground(&mut c, &u).await;
    assert_eq!(check_drawn(&mut c, &u, &r, &ground).await, 3);
    let lot = root["node"].clone();
    let everything = check_drawn(&mut c, &u, &r, &lot).await;
    assert!(everything > 3);
    // Without `drawn`, none.
    assert!(kids.get("drawn").is_none());
}

#[tokio::test]
async fn derive_mode_focus_and_context_meshes_a_few_levels_and_leaves_the_rest_to_lines() {
    let (_dir, mut c, u, whole) = previewed("t.grm", TREE).await;
    let root = c
        .ok("grm/tree", json!({ "textDocument": { "uri": u } }))
        .await;
    let a = &root["children"][0];
    let level = c
        .ok(
            "grm/tree",
            json!({ "textDocument": { "uri": u }, "node": a["node"] }),
        )
        .await;
    let branch = level["children"]
        .as_array()
        .unwrap()
        .iter()
        .find(|n| n["label"] == "A (iteration 1)")
        .unwrap()
        .clone();
    let bones = |r: &serde_json::Value| r["skeleton"]["boneCount"].as_u64().unwrap();
    // One level below the branch's A: its F (and the A's below it: no bones) meshed, the rest lines.
    let focused = c
        .ok(
            "grm/preview",
            json!({ "textDocument": { "uri": u }, "context": { "key": branch["key"], "depth": 1 } }),
        )
        .await;
    assert_eq!(bones(&focused), bones(&whole), "the skeleton stays whole");
    assert!(triangles(&focused) > 0 && triangles(&focused) < triangles(&whole));
    let mut meshed = 0;
    for (i, part) in focused["parts"].as_array().unwrap().iter().enumerate() {
        for p in picks(part) {
            let pick = c
                .ok(
                    "grm/pick",
                    json!({ "textDocument": { "uri": u }, "part": i, "triangle": p["firstTriangle"] }),
                )
                .await;
            let path = pick["ancestry"].as_array().unwrap();
            let at = path.iter().position(|x| x["key"] == branch["key"]);
            assert!(
                at.is_some_and(|k| path.len() - 1 - k <= 1),
                "a meshed bone outside the window: {pick}"
            );
            meshed += 1;
        }
    }
    assert_eq!(meshed, 1, "the branch's own F");
    // Depth 0: the branch's A was rewritten, so nothing of it is meshed.
    let none = c
        .ok(
            "grm/preview",
            json!({ "textDocument": { "uri": u }, "context": { "key": branch["key"], "depth": 0 } }),
        )
        .await;
    assert_eq!(triangles(&none), 0);
    // The root deep enough, or an unknown key: the whole model.
    for key in [root["node"]["key"].clone(), json!("00000000")] {
        let all = c
            .ok(
                "grm/preview",
                json!({ "textDocument": { "uri": u }, "context": { "key": key, "depth": 10 } }),
            )
            .await;
        assert_eq!(triangles(&all), triangles(&whole));
    }
}

//! Quick fixes on the edits file beyond "Delete edit N" (issue 27;
//! docs/edits.md, "In the editor"): an edit whose target no longer names
//! its part gets "Retarget edit N to ..." actions, best first (Lipp 3.2.2:
//! ordering values, then symbol and tags, then the nearest part of the
//! same symbol), each a code action the artist picks; nothing changes by
//! itself.

mod common;

use common::editor::Editor;
use common::*;
use grm_shape::{NodeId, ShapeTree};
use serde_json::{Value, json};

fn edits_text(edits: Value) -> String {
    serde_json::to_string_pretty(&json!({ "version": 1, "edits": edits })).unwrap()
}

/// A grammar's default system grown here (the ground truth).
struct Grown {
    lowered: grm_grow::shape::Lowered,
    tree: ShapeTree,
}

fn grow(text: &str) -> Grown {
    let (_, checked) = grm_sema::check_text("house.grm", text);
    assert!(!checked.has_errors(), "{:?}", checked.diagnostics);
    let p = &checked.program;
    let sys = p.default_system().unwrap();
    let lowered = grm_grow::shape::lower(p, sys, &p.default_params()).unwrap();
    let tree = grm_grow::shape::derive(
        &lowered,
        lowered.seed,
        &grm_grow::shape::ShapeOptions::default(),
    )
    .unwrap();
    Grown { lowered, tree }
}

impl Grown {
    fn select(&self, q: &str) -> Vec<NodeId> {
        self.tree
            .select(&self.lowered.program, &q.parse().expect("a query"))
    }
    fn exact(&self, n: NodeId) -> String {
        self.tree
            .exact_locator(&self.lowered.program, n)
            .to_string()
    }
    fn centre(&self, n: NodeId) -> [f32; 3] {
        self.tree.node(n).unwrap().scope.center().to_array()
    }
}

/// The actions offered on diagnostic `d` of the edits file `eu`.
async fn actions(c: &mut Editor, eu: &Value, d: &Value) -> Vec<Value> {
    c.ok(
        "textDocument/codeAction",
        json!({ "textDocument": { "uri": eu }, "range": d["range"],
                "context": { "diagnostics": [d.clone()] } }),
    )
    .await
    .as_array()
    .cloned()
    .unwrap_or_default()
}

fn titles(a: &[Value]) -> Vec<String> {
    a.iter()
        .map(|x| x["title"].as_str().unwrap().to_owned())
        .collect()
}

#[tokio::test]
async fn an_edit_whose_path_broke_is_offered_its_part_again_first() {
    let (_dir, p, text) = house();
    let before = grow(&text);
    // The second floor's first window of the front facade.
    let w = before.select("(facade = 1, floor = 2) Window")[0];
    let exact = before.exact(w);

    let mut c = Editor::start().await;
    let u = c.open(&p, &text, 1).await;
    c.ok(
        "grm/preview",
        json!({ "textDocument": { "uri": u }, "live": true }),
    )
    .await;
    let ep = grm_edits::edits_path(&p);
    let one = edits_text(json!([
        { "id": 1, "system": "Townhouse", "target": { "exact": exact }, "op": "material", "name": "glass" }
    ]));
    let eu = c.open(&ep, &one, 1).await;
    let r = c
        .updated(|r| r["edits"]["list"][0]["class"] == "valid")
        .await;
    assert!(r["edits"]["list"][0].get("retarget").is_none(), "{r}");
    let eu = serde_json::to_value(&eu).unwrap();

    // `Floor` renamed `Storey`: the windows stay where they are, the
    // exact locator's label on the path breaks. (A wrapped split no longer
    // breaks it: the step goes through the inserted level.)
    let wrapped = grm_testkit::renamed(&text, "Floor", "Storey");
    assert_ne!(wrapped, text);
    let after = grow(&wrapped);
    let same = after
        .select("(facade = 1, floor = 2) Window")
        .into_iter()
        .find(|&n| after.centre(n) == before.centre(w))
        .expect("the same window");
    let want = after.exact(same);
    assert_ne!(want, exact);
    c.replace(&u, 2, &wrapped).await;
    let r = c
        .updated(|r| r["edits"]["list"][0]["class"] == "semantically_invalid")
        .await;
    // The preview names the candidates, best first: the same window (the
    // print kept while the edit was valid: its ordering values and place).
    let cands = r["edits"]["list"][0]["retarget"]
        .as_array()
        .expect("candidates");
    assert!(cands.len() > 1, "{cands:?}");
    assert_eq!(cands[0]["target"], json!({ "exact": want }));
    assert_eq!(cands[0]["reason"], "ordering");
    assert_eq!(cands[0]["parts"], json!([same.0]));

    // The diagnostic says so, and its quick fixes retarget the edit.
    let d = c
        .diagnostics(&serde_json::from_value(eu.clone()).unwrap(), |d| {
            d.len() == 1 && d[0]["code"] == "edit.semantically_invalid"
        })
        .await;
    assert!(
        d[0]["message"]
            .as_str()
            .unwrap()
            .contains("retarget it to one of"),
        "{}",
        d[0]
    );
    assert_eq!(d[0]["data"]["retarget"][0]["target"]["exact"], json!(want));
    let a = actions(&mut c, &eu, &d[0]).await;
    let t = titles(&a);
    assert_eq!(t.len(), cands.len() + 1, "{t:?}");
    assert_eq!(
        t[0],
        format!("Retarget edit 1 to {want} (same ordering values)")
    );
    assert_eq!(t.last().unwrap(), "Delete edit 1");
    assert!(a.iter().all(|x| x["kind"] == "quickfix"));
    assert!(
        a.iter().all(|x| x.get("isPreferred").is_none()),
        "never applied by itself"
    );
    // Applied (the artist's pick): the file is written canonically with
    // the new target, and the next preview applies it again.
    let fixed = apply(
        &one,
        a[0]["edit"]["changes"][eu.as_str().unwrap()]
            .as_array()
            .unwrap(),
    );
    let parsed = grm_edits::parse(&fixed);
    assert!(parsed.errors.is_empty(), "{fixed}");
    assert_eq!(parsed.file.edits[0].target.text(), want);
    assert_eq!(fixed, grm_edits::write(&parsed.file));
    c.replace(&serde_json::from_value(eu.clone()).unwrap(), 2, &fixed)
        .await;
    let r = c
        .updated(|r| r["edits"]["list"][0]["class"] == "valid")
        .await;
    assert_eq!(r["edits"]["list"][0]["replayed"], true);
    assert_eq!(r["edits"]["list"][0]["parts"], json!([same.0]));
    c.diagnostics(&serde_json::from_value(eu).unwrap(), <[Value]>::is_empty)
        .await;
}

#[tokio::test]
async fn a_query_into_nothing_is_offered_queries_of_its_form() {
    let (_dir, p, text) = house();
    let g = grow(&text);
    let top = (1..100)
        .rev()
        .find(|f| !g.select(&format!("(floor = {f}) Window")).is_empty())
        .expect("floors");
    let mut c = Editor::start().await;
    let u = c.open(&p, &text, 1).await;
    c.ok(
        "grm/preview",
        json!({ "textDocument": { "uri": u }, "live": true }),
    )
    .await;
    // With a problem elsewhere in the file (an unknown operation), a
    // retarget writes just that edit again.
    let two = edits_text(json!([
        { "id": 1, "system": "Townhouse", "target": { "semantic": "(floor = 99) Window" }, "op": "remove", "note": "kept" },
        { "id": 2, "system": "Townhouse", "target": { "key": "0a1b2c3d" }, "op": "paint" }
    ]));
    let eu = c.open(&grm_edits::edits_path(&p), &two, 1).await;
    c.updated(|r| r["edits"]["list"][0]["class"] == "structurally_invalid")
        .await;
    let d = c
        .diagnostics(&eu, |d| {
            d.iter().any(|x| x["code"] == "edit.structurally_invalid")
        })
        .await;
    let d = d
        .iter()
        .find(|x| x["code"] == "edit.structurally_invalid")
        .unwrap();
    let eu = serde_json::to_value(&eu).unwrap();
    let a = actions(&mut c, &eu, d).await;
    let t = titles(&a);
    assert_eq!(
        t[0],
        format!(
            "Retarget edit 1 to (floor = {top}) Window (same symbol and tags; {} parts)",
            g.select(&format!("(floor = {top}) Window")).len()
        )
    );
    assert_eq!(t.last().unwrap(), "Delete edit 1");
    let fixed = apply(
        &two,
        a[0]["edit"]["changes"][eu.as_str().unwrap()]
            .as_array()
            .unwrap(),
    );
    let parsed = grm_edits::parse(&fixed);
    assert_eq!(parsed.errors.len(), 1, "the other problem stays: {fixed}");
    let e = parsed.file.get(1).unwrap();
    assert_eq!(e.target.text(), format!("(floor = {top}) Window"));
    assert_eq!(e.note.as_deref(), Some("kept"));
    assert!(fixed.contains("\"op\": \"paint\""));
}

/// The actions offered at the start of edit `id`'s element, without a
/// diagnostic (a refactoring at the cursor).
async fn actions_at(c: &mut Editor, eu: &Value, text: &str, id: u32) -> Vec<Value> {
    let e = grm_edits::parse(text).file.get(id).unwrap().span;
    let src = grm_diag::SourceFile::new("", text);
    let (line, col) = src.line_col_utf16(e.start + 1);
    let p = json!({ "line": line, "character": col });
    c.ok(
        "textDocument/codeAction",
        json!({ "textDocument": { "uri": eu }, "range": { "start": p, "end": p },
                "context": { "diagnostics": [] } }),
    )
    .await
    .as_array()
    .cloned()
    .unwrap_or_default()
}

#[tokio::test]
async fn bake_writes_the_edit_into_the_rules_and_deletes_it_in_one_workspace_edit() {
    let (_dir, p, text) = house();
    let mut c = Editor::start().await;
    let u = c.open(&p, &text, 1).await;
    let base = c
        .ok(
            "grm/preview",
            json!({ "textDocument": { "uri": u }, "live": true }),
        )
        .await;
    let ep = grm_edits::edits_path(&p);
    // The second floor's windows forced to their second rule (a wall), and
    // a material on windows (which have rules: not baked exactly).
    let two = edits_text(json!([
        { "id": 1, "system": "Townhouse", "target": { "semantic": "(floor = 2) Window" }, "op": "force", "alternative": 2 },
        { "id": 2, "system": "Townhouse", "target": { "semantic": "(floor = 1) Window" }, "op": "material", "name": "glass" }
    ]));
    let eu = c.open(&ep, &two, 1).await;
    let edited = c
        .updated(|r| r["edits"]["list"].as_array().is_some_and(|l| l.len() == 2))
        .await;
    assert_ne!(edited["stats"]["triangles"], base["stats"]["triangles"]);
    let eu = serde_json::to_value(&eu).unwrap();

    let a = actions_at(&mut c, &eu, &two, 1).await;
    assert_eq!(a.len(), 1, "{a:?}");
    assert_eq!(a[0]["kind"], "refactor.rewrite");
    assert_eq!(
        a[0]["title"],
        "Bake edit 1 into the grammar (Window : tagged(floor) && index(floor) == 2 -> ...)"
    );
    let changes = &a[0]["edit"]["changes"];
    let gu = serde_json::to_value(&u).unwrap();
    let grammar = apply(&text, changes[gu.as_str().unwrap()].as_array().unwrap());
    let edits = apply(&two, changes[eu.as_str().unwrap()].as_array().unwrap());
    assert!(
        grammar.contains(
            "Window : !(tagged(floor) && index(floor) == 2) && (scope.x > 1 && tagged(floor)) ->"
        ),
        "{grammar}"
    );
    let left = grm_edits::parse(&edits);
    assert!(left.errors.is_empty());
    assert_eq!(
        left.file.edits.iter().map(|e| e.id).collect::<Vec<_>>(),
        [2]
    );
    // Ground truth: the baked grammar alone grows the tree the grammar
    // grows with the edit.
    let mut f = grm_edits::parse(&two).file;
    f.remove(2);
    let g = grow(&text);
    let with_edit = grm_grow::shape::derive_with_edits(
        &g.lowered,
        g.lowered.seed,
        &grm_grow::shape::ShapeOptions::default(),
        Some(&grm_grow::shape::edit_plan(&g.lowered, &f)),
    )
    .unwrap();
    assert_eq!(grow(&grammar).tree.nodes(), with_edit.nodes());

    // The material on windows with rules: offered, disabled, with why.
    let a = actions_at(&mut c, &eu, &two, 2).await;
    assert_eq!(a.len(), 1, "{a:?}");
    assert_eq!(a[0]["title"], "Bake edit 2 into the grammar");
    assert!(a[0].get("edit").is_none());
    assert!(
        a[0]["disabled"]["reason"]
            .as_str()
            .unwrap()
            .contains("has rules"),
        "{}",
        a[0]
    );
    // Only quick fixes asked for: no bake.
    let e1 = grm_edits::parse(&two).file.get(1).unwrap().span;
    let src = grm_diag::SourceFile::new("", &two);
    let (line, col) = src.line_col_utf16(e1.start + 1);
    let at = json!({ "line": line, "character": col });
    let only = c
        .ok(
            "textDocument/codeAction",
            json!({ "textDocument": { "uri": eu }, "range": { "start": at, "end": at },
                    "context": { "diagnostics": [], "only": ["quickfix"] } }),
        )
        .await;
    assert_eq!(only, json!([]));

    // Both files changed as the action says: the preview is the edited one.
    c.replace(&serde_json::from_value(eu).unwrap(), 2, &edits)
        .await;
    c.replace(&u, 2, &grammar).await;
    let r = c
        .updated(|r| {
            r["edits"]["list"].as_array().is_some_and(|l| l.len() == 1)
                && r["edits"]["list"][0]["id"] == 2
        })
        .await;
    let plain_material = grm_edits::parse(&edits).file;
    assert_eq!(plain_material.edits.len(), 1);
    // Edit 2 (a material on floor 1) is still replayed; edit 1's effect is
    // in the rules: the same triangles as with both edits.
    assert_eq!(r["stats"]["triangles"], edited["stats"]["triangles"]);
}

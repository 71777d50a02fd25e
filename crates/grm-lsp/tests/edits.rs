//! Persistent edits in the language server (issue 27; docs/edits.md, "In
//! the editor"): the shape preview replays `NAME.edits.json` beside the
//! grammar and lists each edit's class; the edits file gets its problems
//! (R09xx) and a warning per edit not replayed; a change to it regrows the
//! live preview; `grm/edit` / `grm/removeEdit` change it through
//! `workspace/applyEdit` (or write it, for a client that cannot apply
//! edits); a quick fix deletes an edit.

mod common;

use common::editor::Editor;
use common::*;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use tower_lsp_server::ls_types::Uri;

fn edits_path(grammar: &Path) -> PathBuf {
    grm_edits::edits_path(grammar)
}

/// An edits file's text: version 1 and these edits.
fn edits_text(edits: Value) -> String {
    serde_json::to_string_pretty(&json!({ "version": 1, "edits": edits })).unwrap()
}

/// The exact locator of the shape drawn by the first triangle of part 0.
async fn first_exact(c: &mut impl Lsp, u: &Uri) -> String {
    let pk = c
        .call_ok(
            "grm/pick",
            json!({ "textDocument": { "uri": u }, "part": 0, "triangle": 0 }),
        )
        .await;
    pk["shape"]["exact"].as_str().expect("exact").to_string()
}

/// What both clients below can do.
trait Lsp {
    async fn call_ok(&mut self, method: &'static str, params: Value) -> Value;
}

impl Lsp for Client {
    async fn call_ok(&mut self, method: &'static str, params: Value) -> Value {
        self.ok(method, params).await
    }
}

impl Lsp for Editor {
    async fn call_ok(&mut self, method: &'static str, params: Value) -> Value {
        self.ok(method, params).await
    }
}

/// The codes of diagnostics, in order.
fn codes(d: &[Value]) -> Vec<String> {
    d.iter()
        .map(|x| x["code"].as_str().unwrap_or("").to_string())
        .collect()
}

#[tokio::test]
async fn the_preview_replays_the_open_edits_file_and_says_what_became_of_each_edit() {
    let (_dir, p, text) = house();
    let mut c = Editor::start().await;
    let u = c.open(&p, &text, 1).await;
    let base = c
        .ok(
            "grm/preview",
            json!({ "textDocument": { "uri": u }, "live": true }),
        )
        .await;
    assert_eq!(
        (base["edits"]["found"].clone(), classes(&base)),
        (json!(false), String::new()),
        "no edits file: none replayed"
    );
    assert_eq!(base["edits"]["uri"], json!(uri(&edits_path(&p))));
    let exact = first_exact(&mut c, &u).await;

    // The edits file opened with one removal: the live preview regrows
    // without the part, and the edit is valid and replayed.
    let ep = edits_path(&p);
    let one = edits_text(json!([
        { "id": 1, "system": "Townhouse", "target": { "exact": exact }, "op": "remove" }
    ]));
    let eu = c.open(&ep, &one, 1).await;
    let r = c.updated(|r| r["edits"]["found"] == true).await;
    assert!(
        triangles(&r) < triangles(&base),
        "{} !< {}",
        triangles(&r),
        triangles(&base)
    );
    assert_eq!(classes(&r), "1:valid+");
    assert_eq!(r["edits"]["uri"], json!(eu));
    assert_eq!(r["edits"]["found"], true);
    assert_eq!(r["edits"]["problems"], 0);
    let e1 = &r["edits"]["list"][0];
    assert_eq!(e1["op"], "remove");
    assert_eq!(e1["target"]["exact"], json!(exact));
    assert_eq!(e1["parts"].as_array().unwrap().len(), 1);
    let removed = triangles(&r);

    // Grm features do not answer for the JSON file.
    let hover = c
        .ok(
            "textDocument/hover",
            json!({ "textDocument": { "uri": eu }, "position": { "line": 1, "character": 3 } }),
        )
        .await;
    assert!(hover.is_null(), "{hover}");
    let tokens = c
        .ok(
            "textDocument/semanticTokens/full",
            json!({ "textDocument": { "uri": eu } }),
        )
        .await;
    assert!(tokens.is_null(), "{tokens}");

    // Edits that are not replayed: a material the grammar lacks (stale),
    // a floor that is not there (structurally invalid), a system it lacks.
    let three = edits_text(json!([
        { "id": 1, "system": "Townhouse", "target": { "exact": exact }, "op": "remove" },
        { "id": 2, "system": "Townhouse", "target": { "exact": exact }, "op": "material", "name": "gold" },
        { "id": 3, "system": "Townhouse", "target": { "semantic": "(floor = 99) Window" }, "op": "remove" },
        { "id": 4, "system": "Villa", "target": { "key": "0a1b2c3d" }, "op": "remove" }
    ]));
    c.replace(&eu, 2, &three).await;
    let r = c
        .updated(|r| r["edits"]["list"].as_array().is_some_and(|l| l.len() == 4))
        .await;
    assert_eq!(
        classes(&r),
        "1:valid+ 2:stale 3:structurally_invalid 4:stale"
    );
    assert_eq!(triangles(&r), removed, "the valid removal still applies");
    assert!(
        r["edits"]["list"][1]["detail"]
            .as_str()
            .unwrap()
            .contains("gold")
    );
    // One warning per edit not replayed, on the edit.
    let d = c.diagnostics(&eu, |d| d.len() == 3).await;
    assert_eq!(
        codes(&d),
        ["edit.stale", "edit.structurally_invalid", "edit.stale"]
    );
    for (x, id) in d.iter().zip([2, 3, 4]) {
        assert_eq!(x["severity"], 2, "warning");
        assert_eq!(x["data"]["edit"], id);
        assert!(
            x["message"]
                .as_str()
                .unwrap()
                .starts_with(&format!("edit {id} ")),
            "{x}"
        );
        let covered = common_text(&three, &x["range"]);
        assert!(
            covered.starts_with('{') && covered.ends_with('}'),
            "{covered}"
        );
        assert!(covered.contains(&format!("\"id\": {id}")), "{covered}");
    }
    assert!(
        d[1]["message"]
            .as_str()
            .unwrap()
            .contains("selects no part")
    );

    // Its quick fix deletes the edit: canonical text without it.
    let actions = c
        .ok(
            "textDocument/codeAction",
            json!({ "textDocument": { "uri": eu }, "range": d[0]["range"],
                    "context": { "diagnostics": [d[0].clone()] } }),
        )
        .await;
    let a = &actions[0];
    assert_eq!(a["title"], "Delete edit 2");
    assert_eq!(a["kind"], "quickfix");
    let fixed = apply(
        &three,
        a["edit"]["changes"][eu.as_str()].as_array().unwrap(),
    );
    let parsed = grm_edits::parse(&fixed);
    assert!(parsed.errors.is_empty());
    let ids: Vec<u32> = parsed.file.edits.iter().map(|e| e.id).collect();
    assert_eq!(ids, [1, 3, 4]);
    assert_eq!(fixed, grm_edits::write(&parsed.file));

    // A malformed edit: an R09xx error on it, the others still replayed.
    let bad = edits_text(json!([
        { "id": 1, "system": "Townhouse", "target": { "exact": exact }, "op": "remove" },
        { "id": 2, "system": "Townhouse", "target": { "exact": exact }, "op": "paint", "name": "gold" }
    ]));
    c.replace(&eu, 3, &bad).await;
    let r = c.updated(|r| r["edits"]["problems"] == 1).await;
    assert_eq!(classes(&r), "1:valid+");
    assert_eq!(triangles(&r), removed);
    let d = c.diagnostics(&eu, |d| codes(d) == ["R0908"]).await;
    assert_eq!(d[0]["severity"], 1, "error");
    assert!(
        d[0]["message"].as_str().unwrap().contains("paint"),
        "{}",
        d[0]
    );
    // Its quick fix takes that element out and leaves the rest as it is.
    let actions = c
        .ok(
            "textDocument/codeAction",
            json!({ "textDocument": { "uri": eu }, "range": d[0]["range"],
                    "context": { "diagnostics": [d[0].clone()] } }),
        )
        .await;
    assert_eq!(actions[0]["title"], "Delete this edit");
    let fixed = apply(
        &bad,
        actions[0]["edit"]["changes"][eu.as_str()]
            .as_array()
            .unwrap(),
    );
    let parsed = grm_edits::parse(&fixed);
    assert!(parsed.errors.is_empty(), "{fixed}");
    assert_eq!(parsed.file.edits.len(), 1);

    // Not JSON: no edits replayed, the whole model back.
    c.replace(&eu, 4, "{ \"version\": 1, \"edits\": [").await;
    let r = c
        .updated(|r| r["edits"]["problems"] == 1 && triangles(r) == triangles(&base))
        .await;
    assert_eq!(classes(&r), "");
    c.diagnostics(&eu, |d| codes(d) == ["R0902"]).await;

    // Closed: the file on disk counts (there is none): no list, no problems.
    c.notify(
        "textDocument/didClose",
        json!({ "textDocument": { "uri": eu } }),
    )
    .await;
    let r = c.updated(|r| r["edits"]["found"] == false).await;
    assert_eq!(triangles(&r), triangles(&base));
    c.diagnostics(&eu, <[Value]>::is_empty).await;
}

/// The text an LSP range covers.
fn common_text<'a>(text: &'a str, r: &Value) -> &'a str {
    let src = grm_diag::SourceFile::new("", text);
    let o = |p: &Value| {
        src.offset_of_utf16(
            p["line"].as_u64().unwrap() as u32,
            p["character"].as_u64().unwrap() as u32,
        ) as usize
    };
    &text[o(&r["start"])..o(&r["end"])]
}

#[tokio::test]
async fn the_edits_file_on_disk_is_replayed_and_watched() {
    let (_dir, p, text) = house();
    let mut c = Client::start().await;
    let u = c.open(&p, &text).await;
    let base = c
        .ok("grm/preview", json!({ "textDocument": { "uri": u } }))
        .await;
    let exact = first_exact(&mut c, &u).await;
    let ep = edits_path(&p);
    std::fs::write(
        &ep,
        edits_text(json!([
            { "id": 7, "system": "Townhouse", "target": { "exact": exact }, "op": "remove" }
        ])),
    )
    .unwrap();
    let r = c
        .ok(
            "grm/preview",
            json!({ "textDocument": { "uri": u }, "live": true }),
        )
        .await;
    assert!(triangles(&r) < triangles(&base));
    assert_eq!(classes(&r), "7:valid+");
    // Changed on disk and reported by the watcher: the live preview
    // regrows, and the problems are published on it (beside an open grammar).
    std::fs::write(&ep, "{ \"version\": 4, \"edits\": [] }").unwrap();
    c.notify(
        "workspace/didChangeWatchedFiles",
        json!({ "changes": [{ "uri": uri(&ep), "type": 2 }] }),
    )
    .await;
    let eu = serde_json::to_value(uri(&ep)).unwrap();
    let up = c
        .wait_for(|r| {
            r.method() == "grm/previewUpdated"
                && r.params()
                    .is_some_and(|p| p["result"]["edits"]["problems"] == 1)
        })
        .await;
    assert_eq!(triangles(&up.params().unwrap()["result"]), triangles(&base));
    let d = c
        .wait_for(|r| {
            r.method() == "textDocument/publishDiagnostics"
                && r.params().is_some_and(|p| p["uri"] == eu)
        })
        .await;
    let d = d.params().unwrap()["diagnostics"].clone();
    assert_eq!(d[0]["code"], "R0903", "{d}");
    assert!(d[0]["range"].is_object());
}

#[tokio::test]
async fn grm_edit_adds_through_apply_edit_and_remove_edit_takes_out() {
    let (_dir, p, text) = house();
    let mut c = Editor::start().await;
    let u = c.open(&p, &text, 1).await;
    let base = c
        .ok("grm/preview", json!({ "textDocument": { "uri": u } }))
        .await;
    let exact = first_exact(&mut c, &u).await;
    let ep = edits_path(&p);
    let eu = uri(&ep);

    // No edits file yet: created (CreateFile, then its text).
    let res = c
        .ok(
            "grm/edit",
            json!({ "uri": u, "system": "Townhouse", "target": exact, "op": { "op": "remove" } }),
        )
        .await;
    assert_eq!(res["id"], 1);
    assert_eq!(res["applied"], true);
    assert_eq!(res["written"], false);
    assert_eq!(res["uri"], json!(eu));
    let sent = c.next_applied().await;
    assert_eq!(sent["edit"], res["edit"], "the answer is what was applied");
    let ops = sent["edit"]["documentChanges"].as_array().unwrap();
    assert_eq!(ops[0]["kind"], "create");
    assert_eq!(ops[0]["uri"], json!(eu));
    let created = apply("", ops[1]["edits"].as_array().unwrap());
    let parsed = grm_edits::parse(&created);
    assert!(parsed.errors.is_empty());
    assert_eq!(created, grm_edits::write(&parsed.file), "canonical");
    let e = &parsed.file.edits[0];
    assert_eq!((e.id, e.system.as_str()), (1, "Townhouse"));
    assert_eq!(e.target.text(), exact);
    assert_eq!(e.op, grm_edits::Op::Remove);
    // The editor opens the new document: the next preview has the edit.
    c.open(&ep, &created, 1).await;
    let r = c
        .ok("grm/preview", json!({ "textDocument": { "uri": u } }))
        .await;
    assert!(triangles(&r) < triangles(&base));
    assert_eq!(classes(&r), "1:valid+");

    // A second edit, to the open document (its version named), with a
    // note; the system is the file's first.
    let res = c
        .ok(
            "grm/edit",
            json!({ "uri": u, "target": { "semantic": "(floor = 1) Window" },
                    "op": { "op": "material", "name": "glass" }, "note": "all glass" }),
        )
        .await;
    assert_eq!(res["id"], 2);
    let sent = c.next_applied().await;
    let doc = &sent["edit"]["documentChanges"][0];
    assert_eq!(doc["textDocument"]["version"], 1);
    let two = apply(&created, doc["edits"].as_array().unwrap());
    let parsed = grm_edits::parse(&two);
    assert!(parsed.errors.is_empty());
    assert_eq!(parsed.file.edits.len(), 2);
    assert_eq!(parsed.file.edits[1].note.as_deref(), Some("all glass"));
    assert_eq!(two, grm_edits::write(&parsed.file));
    c.replace(&eu, 2, &two).await;

    // Bad requests: the file's own problems.
    let e = c
        .request(
            "grm/edit",
            json!({ "uri": u, "target": exact, "op": { "op": "force", "alternative": 0 } }),
        )
        .await
        .unwrap_err();
    assert!(e["message"].as_str().unwrap().contains("R0911"), "{e}");
    let e = c
        .request(
            "grm/edit",
            json!({ "uri": u, "target": "somewhere", "op": "remove" }),
        )
        .await
        .unwrap_err();
    assert_eq!(e["code"], -32602, "{e}");
    let e = c
        .request(
            "grm/edit",
            json!({ "uri": u, "system": "Villa", "target": exact, "op": "remove" }),
        )
        .await
        .unwrap_err();
    assert!(e["message"].as_str().unwrap().contains("Villa"), "{e}");

    // Removed again: the file without edit 1, and the whole model back.
    let res = c.ok("grm/removeEdit", json!({ "uri": u, "id": 1 })).await;
    assert_eq!(res["id"], 1);
    let sent = c.next_applied().await;
    let doc = &sent["edit"]["documentChanges"][0];
    let after = apply(&two, doc["edits"].as_array().unwrap());
    let parsed = grm_edits::parse(&after);
    assert!(parsed.errors.is_empty());
    let ids: Vec<u32> = parsed.file.edits.iter().map(|e| e.id).collect();
    assert_eq!(ids, [2]);
    c.replace(&eu, 3, &after).await;
    let r = c
        .ok("grm/preview", json!({ "textDocument": { "uri": u } }))
        .await;
    assert_eq!(triangles(&r), triangles(&base));
    assert_eq!(classes(&r), "2:valid+");
    let e = c
        .request("grm/removeEdit", json!({ "uri": u, "id": 1 }))
        .await
        .unwrap_err();
    assert!(e["message"].as_str().unwrap().contains("no edit 1"), "{e}");
}

#[tokio::test]
async fn a_client_that_cannot_apply_edits_gets_the_file_written() {
    let (_dir, p, text) = house();
    // `capabilities: {}`: no workspace.applyEdit (as `grmc view`).
    let mut c = Client::start().await;
    let u = c.open(&p, &text).await;
    let base = c
        .ok(
            "grm/preview",
            json!({ "textDocument": { "uri": u }, "live": true }),
        )
        .await;
    let exact = first_exact(&mut c, &u).await;
    let res = c
        .ok(
            "grm/edit",
            json!({ "uri": u, "system": "Townhouse", "target": { "exact": exact }, "op": "remove" }),
        )
        .await;
    assert_eq!(
        (res["written"].clone(), res["applied"].clone()),
        (json!(true), json!(true))
    );
    let on_disk = std::fs::read_to_string(edits_path(&p)).expect("written");
    let parsed = grm_edits::parse(&on_disk);
    assert!(parsed.errors.is_empty());
    assert_eq!(parsed.file.edits.len(), 1);
    // And the live preview regrows with it.
    let up = c
        .wait_for(|r| {
            r.method() == "grm/previewUpdated"
                && r.params()
                    .is_some_and(|p| p["result"]["edits"]["found"] == true)
        })
        .await;
    let r = &up.params().unwrap()["result"];
    assert!(triangles(r) < triangles(&base));
    assert_eq!(classes(r), "1:valid+");
    let res = c.ok("grm/removeEdit", json!({ "uri": u, "id": 1 })).await;
    assert_eq!(res["written"], true);
    let parsed = grm_edits::parse(&std::fs::read_to_string(edits_path(&p)).unwrap());
    assert!(parsed.file.edits.is_empty());
}

#[tokio::test]
async fn retarget_edit_keeps_the_id_and_a_pick_names_each_shape_of_its_path() {
    let (_dir, p, text) = house();
    // As `grmc view`: the server writes the file.
    let mut c = Client::start().await;
    let u = c.open(&p, &text).await;
    c.ok("grm/preview", json!({ "textDocument": { "uri": u } }))
        .await;
    let pk = c
        .call_ok(
            "grm/pick",
            json!({ "textDocument": { "uri": u }, "part": 0, "triangle": 0 }),
        )
        .await;
    // The edit panel goes up a level with these: every shape of the path has
    // its exact and semantic locator, a command neither.
    let scopes = pk["shape"]["scopes"].as_array().expect("scopes");
    let last = scopes.last().expect("the shape");
    assert_eq!(last["exact"], pk["shape"]["exact"]);
    assert_eq!(last["semantic"], pk["shape"]["semantic"]);
    for s in scopes {
        assert_eq!(
            s["exact"].is_string(),
            s["command"] == false && s["label"] != "insert",
            "{s}"
        );
    }
    let parent = scopes[..scopes.len() - 1]
        .iter()
        .rev()
        .find(|s| s["command"] == false)
        .expect("a shape above");
    let exact = pk["shape"]["exact"].as_str().unwrap();
    let up = parent["exact"].as_str().unwrap();
    assert!(
        exact.starts_with(&up[..up.len() - 1]),
        "{up} is a prefix of {exact}"
    );

    for op in [
        json!("remove"),
        json!({ "op": "material", "name": "glass" }),
    ] {
        c.ok(
            "grm/edit",
            json!({ "uri": u, "target": { "exact": exact }, "op": op }),
        )
        .await;
    }
    let res = c
        .ok(
            "grm/retargetEdit",
            json!({ "uri": u, "id": 1, "target": { "exact": up } }),
        )
        .await;
    assert_eq!(
        (res["id"].clone(), res["written"].clone()),
        (json!(1), json!(true))
    );
    let parsed = grm_edits::parse(&std::fs::read_to_string(edits_path(&p)).unwrap());
    assert!(parsed.errors.is_empty());
    let ids: Vec<(u32, String)> = parsed
        .file
        .edits
        .iter()
        .map(|e| (e.id, e.target.to_string()))
        .collect();
    assert_eq!(ids.len(), 2);
    assert_eq!(ids[0].0, 1, "the id stays: {ids:?}");
    assert!(ids[0].1.contains(up), "{ids:?}");
    assert!(ids[1].1.contains(exact), "edit 2 untouched: {ids:?}");
    // No such edit, and a target that does not read: refused, the file as it was.
    let before = std::fs::read_to_string(edits_path(&p)).unwrap();
    for (id, target) in [(9, json!({ "exact": up })), (1, json!("not a target"))] {
        let r = c
            .request(
                "grm/retargetEdit",
                json!({ "uri": u, "id": id, "target": target }),
            )
            .await;
        assert!(r.is_err(), "{id} {target}: {r:?}");
    }
    assert_eq!(std::fs::read_to_string(edits_path(&p)).unwrap(), before);
}

//! Rename in a grammar that has an edits file beside it (issue 27;
//! docs/edits.md, "In the editor"): the workspace edit changes the names
//! the edits use too (a symbol in exact locators and semantic queries, a
//! parameter in `set`, a material, the system), written by grm-edits'
//! canonical writer, so that every edit the grammar's preview classified
//! valid before the rename is valid after it. Without the edits file's
//! share, the same grammar classifies them invalid or stale (checked too).

mod common;

use common::editor::Editor;
use common::*;
use serde_json::{Value, json};
use tower_lsp_server::ls_types::Uri;

/// The classes of a preview's edits, `id:class`.
fn classes(r: &Value) -> String {
    r["edits"]["list"]
        .as_array()
        .expect("edits")
        .iter()
        .map(|e| format!("{}:{}", e["id"], e["class"].as_str().unwrap()))
        .collect::<Vec<_>>()
        .join(" ")
}

/// The exact locator of a picked shape whose own label is `label`.
async fn exact_of(c: &mut Editor, u: &Uri, r: &Value, label: &str) -> String {
    let want = format!(", {label}}}");
    for (i, part) in r["parts"].as_array().expect("parts").iter().enumerate() {
        for pk in picks(part) {
            let got = c
                .ok(
                    "grm/pick",
                    json!({ "textDocument": { "uri": u }, "part": i,
                            "triangle": pk["firstTriangle"] }),
                )
                .await;
            if let Some(e) = got["shape"]["exact"].as_str()
                && e.ends_with(&want)
            {
                return e.to_owned();
            }
        }
    }
    panic!("no pick of a {label}")
}

/// The rename of the `n`-th `needle` in `text` to `new`: the grammar's new
/// text, and the edits file's (as it was when there is no change to it).
async fn rename(
    c: &mut Editor,
    (u, text): (&Uri, &str),
    (eu, edits): (&Uri, &str),
    needle: &str,
    new: &str,
) -> (String, String) {
    let mut params = at(u, pos(text, needle, 0, 0));
    params["newName"] = json!(new);
    let r = c.ok("textDocument/rename", params).await;
    let changes = &r["changes"];
    let key = |u: &Uri| {
        serde_json::to_value(u)
            .unwrap()
            .as_str()
            .unwrap()
            .to_owned()
    };
    let grammar = apply(
        text,
        changes[key(u)].as_array().expect("the grammar's changes"),
    );
    let edits = match changes[key(eu)].as_array() {
        Some(e) => apply(edits, e),
        None => edits.to_owned(),
    };
    (grammar, edits)
}

#[tokio::test]
async fn a_rename_renames_what_the_edits_name_and_they_stay_valid() {
    let (_dir, p, text) = house();
    let mut c = Editor::start().await;
    let u = c.open(&p, &text, 1).await;
    let base = c
        .ok("grm/preview", json!({ "textDocument": { "uri": u } }))
        .await;
    let window = exact_of(&mut c, &u, &base, "Window").await;

    // A window by its path, the top floor's windows by a query (with the
    // count they select), and a `set` of the floors on the second
    // floor's windows (not replayed in shape mode, but classified: stale
    // when its parameter is gone).
    let ep = grm_edits::edits_path(&p);
    let mut file = grm_edits::EditsFile::default();
    let target = |t: Value| {
        let text = json!({ "version": 2, "edits": [
            { "id": 1, "system": "S", "target": t, "op": "remove" }
        ] })
        .to_string();
        grm_edits::parse(&text).file.edits.remove(0).target
    };
    let glass = || grm_edits::Op::Material {
        name: "glass".into(),
    };
    file.add("Townhouse", target(json!({ "exact": window })), glass());
    file.add(
        "Townhouse",
        target(json!({ "semantic": "(floor = end 1) Window" })),
        glass(),
    );
    file.add(
        "Townhouse",
        target(json!({ "semantic": "(floor = 2) Window" })),
        grm_edits::Op::Set {
            name: "floors".into(),
            value: 5.0,
        },
    );
    let edits = grm_edits::write(&file);
    let eu = c.open(&ep, &edits, 1).await;
    let r = c
        .ok("grm/preview", json!({ "textDocument": { "uri": u } }))
        .await;
    assert_eq!(classes(&r), "1:valid 2:valid 3:valid", "{}", r["edits"]);
    let mut version = 1;
    let (mut text, mut edits) = (text, edits);

    // Each rename: the grammar alone breaks the edits; with the edits
    // file's share they are all valid again, and the file is canonical.
    for (needle, new, broken) in [
        // A symbol: the labels of the path and of the queries.
        (
            "Window :",
            "Pane",
            "1:semantically_invalid 2:structurally_invalid 3:structurally_invalid",
        ),
        // A meta-parameter: the `set`'s name.
        ("floors =", "storeys", "1:valid 2:valid 3:stale"),
        // A material: the operations' name.
        ("glass {", "clear", "1:stale 2:stale 3:valid"),
    ] {
        let (grammar, renamed) = rename(&mut c, (&u, &text), (&eu, &edits), needle, new).await;
        assert_ne!(renamed, edits, "{needle}: the edits file changes");
        let parsed = grm_edits::parse(&renamed);
        assert!(parsed.errors.is_empty(), "{renamed}");
        assert_eq!(renamed, grm_edits::write(&parsed.file), "canonical");
        let old = needle.split(' ').next().unwrap();
        assert!(!renamed.contains(&format!("{old}\"")), "{renamed}");
        assert!(!renamed.contains(&format!("{old},")), "{renamed}");
        // The grammar renamed, the edits file not (yet).
        version += 1;
        c.replace(&u, version, &grammar).await;
        let r = c
            .ok("grm/preview", json!({ "textDocument": { "uri": u } }))
            .await;
        assert_eq!(classes(&r), broken, "{needle}: {}", r["edits"]);
        // Both.
        c.replace(&eu, version, &renamed).await;
        let r = c
            .ok("grm/preview", json!({ "textDocument": { "uri": u } }))
            .await;
        assert_eq!(
            classes(&r),
            "1:valid 2:valid 3:valid",
            "{needle}: {}",
            r["edits"]
        );
        (text, edits) = (grammar, renamed);
    }
    // What the edits name now.
    let f = grm_edits::parse(&edits).file;
    assert!(f.edits[0].target.text().ends_with(", Pane}"), "{edits}");
    assert_eq!(f.edits[1].target.text(), "(floor = end 1) Pane");
    assert!(f.edits[1].selected.is_none());
    assert_eq!(
        f.edits[2].op,
        grm_edits::Op::Set {
            name: "storeys".into(),
            value: 5.0
        }
    );
    assert_eq!(
        f.edits[0].op,
        grm_edits::Op::Material {
            name: "clear".into()
        }
    );
}

#[tokio::test]
async fn a_system_rename_renames_the_edits_system_and_a_binding_rename_no_edit() {
    let (_dir, p, text) = house();
    let mut c = Editor::start().await;
    let u = c.open(&p, &text, 1).await;
    let ep = grm_edits::edits_path(&p);
    // One edit of the system, one of another system (untouched), one that
    // does not read (kept as written: the file is not rewritten whole).
    let edits = serde_json::to_string_pretty(&json!({ "version": 1, "edits": [
        { "id": 1, "system": "Townhouse", "target": { "semantic": "(floor = 1) Window" }, "op": "remove" },
        { "id": 2, "system": "Villa", "target": { "semantic": "(floor = 1) Window" }, "op": "remove" },
        { "id": 3, "system": "Townhouse", "target": { "key": "0a1b2c3d" }, "op": "paint" }
    ] }))
    .unwrap();
    let eu = c.open(&ep, &edits, 1).await;
    let (grammar, renamed) =
        rename(&mut c, (&u, &text), (&eu, &edits), "Townhouse {", "Terrace").await;
    assert!(grammar.contains("system Terrace {"), "{grammar}");
    let parsed = grm_edits::parse(&renamed);
    assert_eq!(parsed.errors.len(), 1, "{renamed}");
    let systems: Vec<(u32, &str)> = parsed
        .file
        .edits
        .iter()
        .map(|e| (e.id, e.system.as_str()))
        .collect();
    assert_eq!(systems, [(1, "Terrace"), (2, "Villa")], "{renamed}");
    assert!(
        renamed.contains("\"op\": \"paint\"") && renamed.matches("Townhouse").count() == 1,
        "the edit that does not read is as it was: {renamed}"
    );
    c.replace(&u, 2, &grammar).await;
    c.replace(&eu, 2, &renamed).await;
    let r = c
        .ok("grm/preview", json!({ "textDocument": { "uri": u } }))
        .await;
    let one = r["edits"]["list"]
        .as_array()
        .unwrap()
        .iter()
        .find(|e| e["id"] == 1)
        .cloned()
        .expect("edit 1");
    assert_eq!(one["class"], "valid", "{one}");
    assert_eq!(one["system"], "Terrace");
}

//! Renaming a semantic tag in a shape grammar with an edits file beside
//! it (issue 27; docs/edits.md, "In the editor"): F2 on a tag, where a
//! command carries it or where a rule reads it (`tagged`, `index`,
//! `count`), renames it in the whole system and in every semantic query of
//! the edits file that names it, in one workspace edit, so that the edits
//! stay valid. The grammar's share alone leaves the queries naming a tag
//! no command carries (checked too).

mod common;

use common::editor::Editor;
use common::*;
use serde_json::{Value, json};
use tower_lsp_server::ls_types::Uri;

fn key(u: &Uri) -> String {
    serde_json::to_value(u)
        .unwrap()
        .as_str()
        .unwrap()
        .to_owned()
}

/// The townhouse with its floors read by `index` and `count` too.
fn grammar(text: &str) -> String {
    let t = text.replace(
        "Tile -> split(x)",
        "Tile : index(floor) <= count(floor) -> split(x)",
    );
    assert_ne!(t, text, "the fixture has the Tile rule");
    t
}

#[tokio::test]
async fn a_tag_rename_renames_the_queries_that_name_it_and_they_stay_valid() {
    let (_dir, p, text) = house();
    let text = grammar(&text);
    std::fs::write(&p, &text).unwrap();
    let mut c = Editor::start().await;
    let u = c.open(&p, &text, 1).await;

    // Two queries on the `floor` tag, one on a window's key (no tag).
    let ep = grm_edits::edits_path(&p);
    let edits = serde_json::to_string_pretty(&json!({ "version": 2, "edits": [
        { "id": 1, "system": "Townhouse", "target": { "semantic": "(floor = end 1) Window" }, "op": "material", "name": "glass" },
        { "id": 2, "system": "Townhouse", "target": { "semantic": "(floor = 2) Window" }, "op": "remove" },
        { "id": 3, "system": "Villa", "target": { "semantic": "(floor = 2) Window" }, "op": "remove" }
    ] }))
    .unwrap()
        + "\n";
    let edits = grm_edits::write(&grm_edits::parse(&edits).file);
    let eu = c.open(&ep, &edits, 1).await;
    let r = c
        .ok("grm/preview", json!({ "textDocument": { "uri": u } }))
        .await;
    assert_eq!(classes(&r), "1:valid+ 2:valid+ 3:stale", "{}", r["edits"]);

    // F2 where the command carries the tag: the name's range.
    let prep = c
        .ok(
            "textDocument/prepareRename",
            at(&u, pos(&text, "floor) {", 0, 2)),
        )
        .await;
    assert_eq!(prep["placeholder"], "floor", "{prep}");

    // Rename from a use (`tagged(floor)`): every occurrence of the system.
    let mut params = at(&u, pos(&text, "tagged(floor)", 0, 8));
    params["newName"] = json!("storey");
    let ws = c.ok("textDocument/rename", params).await;
    let changes = &ws["changes"];
    let g = changes[key(&u)].as_array().expect("the grammar's changes");
    assert_eq!(g.len(), 4, "repeat, tagged, index, count: {g:?}");
    let renamed_grammar = apply(&text, g);
    assert!(!renamed_grammar.contains("floor)"), "{renamed_grammar}");
    assert!(renamed_grammar.contains("repeat(y, storey)"));
    assert!(renamed_grammar.contains("tagged(storey)"));
    assert!(renamed_grammar.contains("index(storey) <= count(storey)"));
    assert!(renamed_grammar.contains("param floors"), "not a tag");
    let e = changes[key(&eu)]
        .as_array()
        .expect("the edits file's changes");
    let renamed_edits = apply(&edits, e);
    let parsed = grm_edits::parse(&renamed_edits);
    assert!(parsed.errors.is_empty(), "{renamed_edits}");
    assert_eq!(renamed_edits, grm_edits::write(&parsed.file), "canonical");
    let targets: Vec<(u32, String)> = parsed
        .file
        .edits
        .iter()
        .map(|e| (e.id, e.target.text()))
        .collect();
    assert_eq!(
        targets,
        [
            (1, "(storey = end 1) Window".to_owned()),
            (2, "(storey = 2) Window".to_owned()),
            // Another system's edit names another system's tag.
            (3, "(floor = 2) Window".to_owned()),
        ]
    );

    // The grammar alone: the queries name a tag no command carries.
    c.replace(&u, 2, &renamed_grammar).await;
    let r = c
        .ok("grm/preview", json!({ "textDocument": { "uri": u } }))
        .await;
    assert_eq!(
        classes(&r),
        "1:structurally_invalid 2:structurally_invalid 3:stale",
        "{}",
        r["edits"]
    );
    // Both: valid again, the same parts.
    c.replace(&eu, 2, &renamed_edits).await;
    let r = c
        .ok("grm/preview", json!({ "textDocument": { "uri": u } }))
        .await;
    assert_eq!(classes(&r), "1:valid+ 2:valid+ 3:stale", "{}", r["edits"]);
}

#[tokio::test]
async fn a_tag_rename_onto_a_tag_in_use_is_refused_and_references_list_the_tag() {
    let (_dir, p, text) = house();
    let text = grammar(&text);
    let mut c = Editor::start().await;
    let u = c.open(&p, &text, 1).await;
    // `facade` is the comp's tag: two tags would become one.
    let mut params = at(&u, pos(&text, "floor) {", 0, 1));
    params["newName"] = json!("facade");
    let err: Value = c
        .request("textDocument/rename", params)
        .await
        .expect_err("refused");
    let msg = err["message"].as_str().unwrap_or_default();
    assert!(msg.contains("already has a tag `facade`"), "{err}");
    // Not a name.
    let mut params = at(&u, pos(&text, "floor) {", 0, 1));
    params["newName"] = json!("two words");
    assert!(c.request("textDocument/rename", params).await.is_err());

    // References: every place the system writes the tag.
    let mut params = at(&u, pos(&text, "count(floor)", 0, 7));
    params["context"] = json!({ "includeDeclaration": true });
    let refs = c.ok("textDocument/references", params).await;
    assert_eq!(refs.as_array().map(Vec::len), Some(4), "{refs}");
}

//! The symbol the language server records with a key target (issue 27;
//! docs/edits.md, "Targets"): `grm/edit` and `grm/retargetEdit` write a
//! key edit's `symbol`, the symbol of the key's part in the system's last
//! preview (or the request's), so that the key names a part of that symbol
//! only; a key no part has gets none, never a guess.

mod common;

use common::editor::Editor;
use common::*;
use serde_json::json;

/// The edits file `old` after the change `grm/edit` or
/// `grm/retargetEdit` just sent (`""`: it did not exist).
async fn applied(c: &mut Editor, old: &str) -> String {
    let sent = c.next_applied().await;
    let changes = sent["edit"]["documentChanges"].as_array().unwrap();
    let doc = changes.last().unwrap();
    let text = apply(old, doc["edits"].as_array().unwrap());
    let parsed = grm_edits::parse(&text);
    assert!(parsed.errors.is_empty(), "{text}");
    assert_eq!(text, grm_edits::write(&parsed.file), "canonical");
    text
}

/// Each edit's id and recorded symbol.
fn symbols(text: &str) -> Vec<(u32, Option<String>)> {
    grm_edits::parse(text)
        .file
        .edits
        .iter()
        .map(|e| (e.id, e.symbol.clone()))
        .collect()
}

#[tokio::test]
async fn grm_edit_records_the_symbol_of_a_keys_shape_in_the_last_preview() {
    let (_dir, p, text) = house();
    let mut c = Editor::start().await;
    let u = c.open(&p, &text, 1).await;
    c.ok("grm/preview", json!({ "textDocument": { "uri": u } }))
        .await;
    let pk = c
        .ok(
            "grm/pick",
            json!({ "textDocument": { "uri": u }, "part": 0, "triangle": 0 }),
        )
        .await;
    let key = pk["key"].as_str().expect("key").to_owned();
    let symbol = pk["symbol"].as_str().expect("a shape's symbol").to_owned();

    // The picked key, as text: the file records its shape's symbol, and is
    // version 3.
    let res = c
        .ok(
            "grm/edit",
            json!({ "uri": u, "target": key, "op": { "op": "material", "name": "glass" } }),
        )
        .await;
    assert_eq!(res["id"], 1);
    let one = applied(&mut c, "").await;
    assert!(one.contains("\"version\": 3"), "{one}");
    assert!(one.contains(&format!("\"symbol\": \"{symbol}\"")), "{one}");
    assert_eq!(symbols(&one), [(1, Some(symbol.clone()))]);
    // The preview replays it on that shape.
    let ep = grm_edits::edits_path(&p);
    let eu = c.open(&ep, &one, 1).await;
    let r = c
        .ok("grm/preview", json!({ "textDocument": { "uri": u } }))
        .await;
    assert_eq!(classes(&r), "1:valid+", "{}", r["edits"]);
    assert_eq!(r["edits"]["list"][0]["parts"], json!([pk["shape"]["node"]]));

    // A key no shape has: no symbol (never guessed); an exact target none.
    c.ok(
        "grm/edit",
        json!({ "uri": u, "target": { "key": "0badc0de" }, "op": "remove" }),
    )
    .await;
    let two = applied(&mut c, &one).await;
    c.replace(&eu, 2, &two).await;
    let exact = pk["shape"]["exact"].as_str().unwrap().to_owned();
    c.ok(
        "grm/edit",
        json!({ "uri": u, "target": { "exact": exact }, "op": "remove" }),
    )
    .await;
    let three = applied(&mut c, &two).await;
    c.replace(&eu, 3, &three).await;
    assert_eq!(
        symbols(&three),
        [(1, Some(symbol.clone())), (2, None), (3, None)]
    );

    // Retargeted to the picked key, edit 3 gets its symbol; back to an
    // exact locator, it drops it.
    c.ok(
        "grm/retargetEdit",
        json!({ "uri": u, "id": 3, "target": { "key": key } }),
    )
    .await;
    let four = applied(&mut c, &three).await;
    c.replace(&eu, 4, &four).await;
    assert_eq!(symbols(&four)[2], (3, Some(symbol.clone())));
    c.ok(
        "grm/retargetEdit",
        json!({ "uri": u, "id": 3, "target": { "exact": exact } }),
    )
    .await;
    let five = applied(&mut c, &four).await;
    c.replace(&eu, 5, &five).await;
    assert_eq!(symbols(&five)[2], (3, None));

    // A symbol the request gives is kept (here for the unknown key).
    c.ok(
        "grm/retargetEdit",
        json!({ "uri": u, "id": 2, "target": "0badc0de", "symbol": "Door" }),
    )
    .await;
    let six = applied(&mut c, &five).await;
    c.replace(&eu, 6, &six).await;
    assert_eq!(symbols(&six)[1], (2, Some("Door".to_owned())));

    // Refused (InvalidParams), the file as it was: a symbol for a target
    // that is not a key, and a key's symbol other than the one another
    // edit of that key records.
    for (method, params) in [
        (
            "grm/edit",
            json!({ "uri": u, "target": { "exact": exact }, "op": "remove", "symbol": symbol }),
        ),
        (
            "grm/edit",
            json!({ "uri": u, "target": key, "op": "remove", "symbol": "NotIt" }),
        ),
        (
            "grm/retargetEdit",
            json!({ "uri": u, "id": 3, "target": "0badc0de", "symbol": "Window" }),
        ),
    ] {
        let e = c.request(method, params.clone()).await.unwrap_err();
        assert_eq!(e["code"], -32602, "{params}: {e}");
        assert!(
            e["message"].as_str().unwrap().contains("R0911"),
            "{params}: {e}"
        );
    }

    // A key no shape has, that another edit records a symbol for: the
    // file's record.
    c.ok(
        "grm/edit",
        json!({ "uri": u, "target": "0badc0de", "op": "remove" }),
    )
    .await;
    let seven = applied(&mut c, &six).await;
    assert_eq!(symbols(&seven)[3], (4, Some("Door".to_owned())));
}

#[tokio::test]
async fn without_a_preview_a_key_gets_no_symbol() {
    let (_dir, p, text) = house();
    let mut c = Editor::start().await;
    let u = c.open(&p, &text, 1).await;
    c.ok(
        "grm/edit",
        json!({ "uri": u, "target": "0a1b2c3d", "op": "remove" }),
    )
    .await;
    let one = applied(&mut c, "").await;
    assert_eq!(symbols(&one), [(1, None)]);
    assert!(one.contains("\"version\": 1"), "{one}");
    // Listed as the preview finds it: no shape has the key.
    c.open(&grm_edits::edits_path(&p), &one, 1).await;
    let r = c
        .ok("grm/preview", json!({ "textDocument": { "uri": u } }))
        .await;
    assert_eq!(listed(&r, 1)["class"], "structurally_invalid");
}

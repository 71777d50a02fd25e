//! What the language server records about an edit the preview's edit
//! panel makes (issue 27; docs/edits.md, "In the editor"): `grm/edit` and
//! `grm/retargetEdit` write a semantic target's `selected` count, the
//! parts its query selects in the last preview, so that a later model
//! where it selects more classifies the edit `ambiguous`.

mod common;

use common::editor::Editor;
use common::*;
use serde_json::json;

#[tokio::test]
async fn grm_edit_records_how_many_parts_a_query_selects_in_the_preview() {
    let (_dir, p, text) = house();
    let mut c = Editor::start().await;
    let u = c.open(&p, &text, 1).await;
    c.ok("grm/preview", json!({ "textDocument": { "uri": u } }))
        .await;

    // Every window of the top floor, and one exact part: only the query
    // gets a count.
    let res = c
        .ok(
            "grm/edit",
            json!({ "uri": u, "target": "(floor = end 1) Window",
                    "op": { "op": "material", "name": "glass" } }),
        )
        .await;
    assert_eq!(res["id"], 1);
    let sent = c.next_applied().await;
    let ops = sent["edit"]["documentChanges"].as_array().unwrap();
    let created = apply("", ops[1]["edits"].as_array().unwrap());
    let parsed = grm_edits::parse(&created);
    assert!(parsed.errors.is_empty(), "{created}");
    assert_eq!(created, grm_edits::write(&parsed.file), "canonical");
    let made = parsed.file.edits[0].selected.expect("a count") as usize;
    assert!(
        created.contains(&format!("\"selected\": {made}")),
        "{created}"
    );
    assert!(made > 1, "a row of windows: {made}");

    // The preview replays it on as many parts as it counted: valid.
    let ep = grm_edits::edits_path(&p);
    let eu = c.open(&ep, &created, 1).await;
    let r = c
        .ok("grm/preview", json!({ "textDocument": { "uri": u } }))
        .await;
    let e1 = listed(&r, 1);
    assert_eq!(e1["class"], "valid", "{e1}");
    assert_eq!(e1["parts"].as_array().unwrap().len(), made, "{e1}");

    // Narrower tiles: the same query selects more windows now, and the
    // edit is reported ambiguous (replayed on all of them, not silently).
    let narrow = text.replace("repeat(x) { ~3: Tile }", "repeat(x) { ~2: Tile }");
    assert_ne!(narrow, text);
    c.replace(&u, 2, &narrow).await;
    let r = c
        .ok("grm/preview", json!({ "textDocument": { "uri": u } }))
        .await;
    let e1 = listed(&r, 1);
    assert_eq!(e1["class"], "ambiguous", "{e1}");
    assert!(e1["parts"].as_array().unwrap().len() > made, "{e1}");
    assert!(
        e1["detail"]
            .as_str()
            .unwrap()
            .contains(&format!("{made} when the edit was made")),
        "{e1}"
    );

    // Retargeted to the bottom upper floor of the model as it is now: the
    // count is the new query's, in that model.
    let res = c
        .ok(
            "grm/retargetEdit",
            json!({ "uri": u, "id": 1, "target": { "semantic": "(floor = 1) Window" } }),
        )
        .await;
    assert_eq!(res["id"], 1);
    let sent = c.next_applied().await;
    let doc = &sent["edit"]["documentChanges"][0];
    let moved = apply(&created, doc["edits"].as_array().unwrap());
    let parsed = grm_edits::parse(&moved);
    assert!(parsed.errors.is_empty(), "{moved}");
    let now = parsed.file.edits[0].selected.expect("a count") as usize;
    c.replace(&eu, 2, &moved).await;
    let r = c
        .ok("grm/preview", json!({ "textDocument": { "uri": u } }))
        .await;
    let e1 = listed(&r, 1);
    assert_eq!(e1["class"], "valid", "{e1}");
    assert_eq!(e1["parts"].as_array().unwrap().len(), now, "{e1}");
    assert!(
        now > made,
        "narrower tiles, more windows a floor: {now} > {made}"
    );

    // An exact target and a key get none; a count the request gives is kept.
    let pk = c
        .ok(
            "grm/pick",
            json!({ "textDocument": { "uri": u }, "part": 0, "triangle": 0 }),
        )
        .await;
    let exact = pk["shape"]["exact"].as_str().unwrap().to_owned();
    c.ok(
        "grm/edit",
        json!({ "uri": u, "target": { "exact": exact }, "op": "remove" }),
    )
    .await;
    let sent = c.next_applied().await;
    let three = apply(
        &moved,
        sent["edit"]["documentChanges"][0]["edits"]
            .as_array()
            .unwrap(),
    );
    c.replace(&eu, 3, &three).await;
    c.ok(
        "grm/edit",
        json!({ "uri": u, "target": "(floor = 1) Tile",
                "op": { "op": "remove", "selected": 7 } }),
    )
    .await;
    let sent = c.next_applied().await;
    let four = apply(
        &three,
        sent["edit"]["documentChanges"][0]["edits"]
            .as_array()
            .unwrap(),
    );
    let parsed = grm_edits::parse(&four);
    assert!(parsed.errors.is_empty(), "{four}");
    let counts: Vec<(u32, Option<u32>)> = parsed
        .file
        .edits
        .iter()
        .map(|e| (e.id, e.selected))
        .collect();
    assert_eq!(
        counts,
        [(1, Some(now as u32)), (2, None), (3, Some(7))],
        "{four}"
    );
}

#[tokio::test]
async fn without_a_preview_a_query_gets_no_count() {
    let (_dir, p, text) = house();
    let mut c = Editor::start().await;
    let u = c.open(&p, &text, 1).await;
    c.ok(
        "grm/edit",
        json!({ "uri": u, "target": "(floor = end 1) Window", "op": "remove" }),
    )
    .await;
    let sent = c.next_applied().await;
    let ops = sent["edit"]["documentChanges"].as_array().unwrap();
    let created = apply("", ops[1]["edits"].as_array().unwrap());
    let parsed = grm_edits::parse(&created);
    assert!(parsed.errors.is_empty(), "{created}");
    assert_eq!(parsed.file.edits[0].selected, None, "{created}");
    // A query that selects nothing in the preview: no count either (a
    // count is from 1).
    c.ok("grm/preview", json!({ "textDocument": { "uri": u } }))
        .await;
    c.open(&grm_edits::edits_path(&p), &created, 1).await;
    c.ok(
        "grm/edit",
        json!({ "uri": u, "target": "(floor = 40) Window", "op": "remove" }),
    )
    .await;
    let sent = c.next_applied().await;
    let two = apply(
        &created,
        sent["edit"]["documentChanges"][0]["edits"]
            .as_array()
            .unwrap(),
    );
    let parsed = grm_edits::parse(&two);
    assert_eq!(parsed.file.edits[1].selected, None, "{two}");
}

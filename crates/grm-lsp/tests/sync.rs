//! Text synchronisation edge cases an editor runs into: positions past the
//! end of a CRLF line, old Mac (lone `\r`) and mixed line endings, closing
//! an imported buffer without saving it, and a client that sends edits for
//! a document it never opened.

mod common;

use common::*;
use serde_json::{Value, json};
use std::time::Duration;

fn change(u: &tower_lsp_server::ls_types::Uri, version: i32, at: Value, text: &str) -> Value {
    json!({
        "textDocument": { "uri": u, "version": version },
        "contentChanges": [ { "range": { "start": at, "end": at }, "text": text } ]
    })
}

/// The (line, character, length) of each semantic token.
fn tokens(data: &Value) -> Vec<(u64, u64, u64)> {
    let d: Vec<u64> = data
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_u64().unwrap())
        .collect();
    let (mut line, mut col) = (0, 0);
    d.chunks(5)
        .map(|t| {
            if t[0] > 0 {
                line += t[0];
                col = t[1];
            } else {
                col += t[1];
            }
            (line, col, t[2])
        })
        .collect()
}

fn codes(d: &Value) -> Vec<String> {
    d["diagnostics"]
        .as_array()
        .unwrap()
        .iter()
        .map(|d| d["code"].as_str().unwrap_or("-").to_string())
        .collect()
}

/// LSP: a character past the end of a line means the line's end, which
/// is before its terminator. In a CRLF file that is before the `\r`: an
/// insertion there must not split the `\r\n`.
#[tokio::test]
async fn a_position_past_the_end_of_a_crlf_line_is_the_line_end() {
    let mut c = Client::start().await;
    let root = root().join("tests/lsp/crlf.grm");
    let text = "const A = 1;\r\nsystem S {\r\n    axiom F(A);\r\n}\r\n";
    let u = c.open(&root, text).await;
    let d = c.diagnostics(&u, 1).await;
    assert_eq!(codes(&d), Vec::<String>::new());
    // The client appends a comment to line 0 with a large character (as
    // "insert at end of line" commands do): its line 0 is now
    // `const A = 1; // note`.
    c.notify(
        "textDocument/didChange",
        change(&u, 2, json!({ "line": 0, "character": 999 }), " // note"),
    )
    .await;
    let _ = c.diagnostics(&u, 2).await;
    let r = c
        .ok(
            "textDocument/semanticTokens/full",
            json!({ "textDocument": { "uri": u } }),
        )
        .await;
    let toks = tokens(&r["data"]);
    // The comment starts at UTF-16 column 13 and is 7 units long, on line 0.
    assert!(toks.contains(&(0, 13, 7)), "{toks:?}");
    // Then it deletes the comment again by the range it sees.
    c.notify(
        "textDocument/didChange",
        json!({
            "textDocument": { "uri": u, "version": 3 },
            "contentChanges": [ { "range": {
                "start": { "line": 0, "character": 12 },
                "end": { "line": 0, "character": 20 } }, "text": "" } ]
        }),
    )
    .await;
    let d = c.diagnostics(&u, 3).await;
    assert_eq!(codes(&d), Vec::<String>::new(), "{d}");
    let r = c
        .ok(
            "textDocument/semanticTokens/full",
            json!({ "textDocument": { "uri": u } }),
        )
        .await;
    // Line 0 is `const A = 1;` again: its last token, `;`, ends at 12.
    let toks = tokens(&r["data"]);
    let last = toks.iter().filter(|t| t.0 == 0).max().copied();
    assert_eq!(last, Some((0, 11, 1)), "{toks:?}");
    // A hover past the end of line 1 is the hover at its end (after `{`),
    // never one on the next line.
    let h = c
        .ok(
            "textDocument/hover",
            at(&u, json!({ "line": 1, "character": 50 })),
        )
        .await;
    if !h.is_null() {
        assert_eq!(h["range"]["start"]["line"], 1, "{h}");
    }
}

/// The diagnostics with `code`, as `line:char-line:char` ranges.
fn ranges_of(d: &Value, code: &str) -> Vec<String> {
    d["diagnostics"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|d| d["code"] == code)
        .map(|d| range_str(&d["range"]))
        .collect()
}

fn replace(
    u: &tower_lsp_server::ls_types::Uri,
    version: i32,
    r: [(u32, u32); 2],
    text: &str,
) -> Value {
    json!({
        "textDocument": { "uri": u, "version": version },
        "contentChanges": [ { "range": {
            "start": { "line": r[0].0, "character": r[0].1 },
            "end": { "line": r[1].0, "character": r[1].1 } }, "text": text } ]
    })
}

/// LSP: a line ends at `\n`, `\r\n` or a lone `\r` (old Mac line
/// endings). In a lone-`\r` document diagnostics are on the lines the
/// editor shows, and incremental edits apply where the editor made them.
#[tokio::test]
async fn lone_carriage_return_line_endings() {
    let mut c = Client::start().await;
    let path = root().join("tests/lsp/lone-cr.grm");
    // Line 1 is a comment: it ends at its `\r`, as the line does.
    let text = "const A = 1;\r// comment\rsystem S {\r    axiom F(B);\r}\r";
    let u = c.open(&path, text).await;
    let d = c.diagnostics(&u, 1).await;
    assert_eq!(codes(&d), vec!["E0101"], "{d}");
    assert_eq!(ranges_of(&d, "E0101"), vec!["3:12-3:13"], "{d}");

    // Replace `B` by `A`: no diagnostic left.
    c.notify(
        "textDocument/didChange",
        replace(&u, 2, [(3, 12), (3, 13)], "A"),
    )
    .await;
    let d = c.diagnostics(&u, 2).await;
    assert_eq!(codes(&d), Vec::<String>::new(), "{d}");
    // `A` of the axiom is defined on line 0.
    let def = c
        .ok(
            "textDocument/definition",
            at(&u, json!({ "line": 3, "character": 12 })),
        )
        .await;
    assert_eq!(range_str(&def["range"]), "0:6-0:7", "{def}");

    // Append to line 0 past its end: before its `\r`, not on line 1.
    c.notify(
        "textDocument/didChange",
        change(&u, 3, json!({ "line": 0, "character": 999 }), " // note"),
    )
    .await;
    let d = c.diagnostics(&u, 3).await;
    assert_eq!(codes(&d), Vec::<String>::new(), "{d}");
    let r = c
        .ok(
            "textDocument/semanticTokens/full",
            json!({ "textDocument": { "uri": u } }),
        )
        .await;
    let toks = tokens(&r["data"]);
    // Two comments: ` // note` at the end of line 0, `// comment` on line 1.
    assert!(toks.contains(&(0, 13, 7)), "{toks:?}");
    assert!(toks.contains(&(1, 0, 10)), "{toks:?}");
    // `axiom` is still on line 3, at column 4.
    assert!(toks.contains(&(3, 4, 5)), "{toks:?}");

    // Insert a line before the comment, then break the axiom on line 4.
    c.notify(
        "textDocument/didChange",
        change(
            &u,
            4,
            json!({ "line": 1, "character": 0 }),
            "const B = 2;\r",
        ),
    )
    .await;
    c.notify(
        "textDocument/didChange",
        replace(&u, 5, [(4, 12), (4, 13)], "Q"),
    )
    .await;
    let d = c.diagnostics(&u, 5).await;
    assert_eq!(ranges_of(&d, "E0101"), vec!["4:12-4:13"], "{d}");
    let h = c
        .ok(
            "textDocument/hover",
            at(&u, json!({ "line": 1, "character": 6 })),
        )
        .await;
    assert_eq!(range_str(&h["range"]), "1:6-1:7", "{h}");

    // Delete the inserted line (a range across its lone `\r`): the axiom
    // is back on line 3.
    c.notify(
        "textDocument/didChange",
        replace(&u, 6, [(1, 0), (2, 0)], ""),
    )
    .await;
    let d = c.diagnostics(&u, 6).await;
    assert_eq!(codes(&d), vec!["E0101"], "{d}");
    assert_eq!(ranges_of(&d, "E0101"), vec!["3:12-3:13"], "{d}");
    let h = c
        .ok(
            "textDocument/hover",
            at(&u, json!({ "line": 0, "character": 6 })),
        )
        .await;
    assert_eq!(range_str(&h["range"]), "0:6-0:7", "{h}");
}

/// Mixed line endings (`\r\n`, a lone `\r`, `\n`) in one document: each
/// is one line break.
#[tokio::test]
async fn mixed_line_endings() {
    let mut c = Client::start().await;
    let path = root().join("tests/lsp/mixed-eol.grm");
    let text = "const A = 1;\r\n// c\rsystem S {\n    axiom F(B);\r\r\n}";
    let u = c.open(&path, text).await;
    let d = c.diagnostics(&u, 1).await;
    assert_eq!(ranges_of(&d, "E0101"), vec!["3:12-3:13"], "{d}");
    // Lines 4 (empty, between the lone `\r` and the `\r\n`) and 5 (`}`).
    c.notify(
        "textDocument/didChange",
        change(
            &u,
            2,
            json!({ "line": 4, "character": 0 }),
            "    G -> F(C);",
        ),
    )
    .await;
    let d = c.diagnostics(&u, 2).await;
    assert_eq!(
        ranges_of(&d, "E0101"),
        vec!["3:12-3:13", "4:11-4:12"],
        "{d}"
    );
}

/// Closing an imported document that has unsaved edits reverts it to the
/// file on disk: the open files that import it are checked again.
#[tokio::test]
async fn closing_an_edited_import_republishes_its_importers() {
    let mut c = Client::start().await;
    let (lp, ltext) = fixture("lib.grm");
    let (pp, ptext) = fixture("plant.grm");
    let lu = c.open(&lp, &ltext).await;
    let pu = c.open(&pp, &ptext).await;
    let before = codes(&c.diagnostics(&pu, 1).await);
    assert!(!before.contains(&"E0101".to_string()), "{before:?}");
    // Rename the constant plant.grm uses, without saving.
    let at_golden = pos(&ltext, "GOLDEN", 0, 0);
    let mut end = at_golden.clone();
    end["character"] = json!(end["character"].as_u64().unwrap() + 6);
    c.notify(
        "textDocument/didChange",
        json!({
            "textDocument": { "uri": lu, "version": 2 },
            "contentChanges": [ { "range": { "start": at_golden, "end": end }, "text": "GOLDEQ" } ]
        }),
    )
    .await;
    let want = serde_json::to_value(&pu).unwrap();
    let broken = c
        .wait_for(|r| {
            r.method() == "textDocument/publishDiagnostics"
                && r.params().is_some_and(|p| {
                    p["uri"] == want
                        && p["diagnostics"]
                            .as_array()
                            .is_some_and(|d| d.iter().any(|d| d["code"] == "E0101"))
                })
        })
        .await;
    assert_eq!(broken.params().unwrap()["version"], 1);
    // Close lib.grm without saving: plant.grm sees the file on disk again.
    c.notify(
        "textDocument/didClose",
        json!({ "textDocument": { "uri": lu } }),
    )
    .await;
    let fixed = c
        .wait_for(|r| {
            r.method() == "textDocument/publishDiagnostics"
                && r.params().is_some_and(|p| p["uri"] == want)
        })
        .await;
    assert_eq!(codes(fixed.params().unwrap()), before);
}

/// `didChange` for a document that is not open (a client bug) is ignored:
/// it must not turn the edit applied to an empty text into an open
/// document that hides the file on disk from its importers.
#[tokio::test]
async fn a_change_to_a_document_that_is_not_open_is_ignored() {
    let mut c = Client::start().await;
    let (lp, _) = fixture("lib.grm");
    let lu = uri(&lp);
    c.notify(
        "textDocument/didChange",
        change(&lu, 2, json!({ "line": 0, "character": 0 }), "x"),
    )
    .await;
    let (pp, ptext) = fixture("plant.grm");
    let pu = c.open(&pp, &ptext).await;
    let d = c.diagnostics(&pu, 1).await;
    assert!(!codes(&d).contains(&"E0101".to_string()), "{d}");
    tokio::time::sleep(Duration::from_millis(50)).await;
    c.drain();
    let lib = serde_json::to_value(&lu).unwrap();
    assert!(
        !c.seen
            .iter()
            .any(|r| r.method() == "textDocument/publishDiagnostics"
                && r.params().is_some_and(|p| p["uri"] == lib)),
        "diagnostics published for a document that is not open"
    );
}

/// A client whose versions go backwards (against the protocol, but seen
/// after a reconnect) still gets the diagnostics of the text it sent:
/// the server holds that text, so the older-looking version is current.
#[tokio::test]
async fn diagnostics_follow_a_version_that_goes_backwards() {
    let mut c = Client::start().await;
    let p = root().join("tests/lsp/backwards.grm");
    let u = uri(&p);
    let bad = "system S {\n    axiom X;\n    X -> F(q) X;\n}\n";
    c.notify(
        "textDocument/didOpen",
        json!({ "textDocument": { "uri": u, "languageId": "grm", "version": 50, "text": bad } }),
    )
    .await;
    let d = c.diagnostics(&u, 50).await;
    assert_eq!(codes(&d), ["E0101"], "{d}");
    let good = bad.replace("F(q)", "F");
    c.notify(
        "textDocument/didChange",
        json!({
            "textDocument": { "uri": u, "version": 3 },
            "contentChanges": [ { "text": good } ]
        }),
    )
    .await;
    let d = c.diagnostics(&u, 3).await;
    assert_eq!(codes(&d), Vec::<String>::new(), "{d}");
}

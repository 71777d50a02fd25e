//! Shape systems (`mode = shape`) over LSP: semantic tokens, hover,
//! completion and formatting of tests/lsp/shape.grm and
//! tests/lsp/shape_messy.grm, one snapshot each.

#[macro_use]
mod common;

use common::*;
use serde_json::{Value, json};
use std::fmt::Write;

#[tokio::test]
async fn shape_semantic_tokens() {
    let mut c = Client::start().await;
    let (p, text) = fixture("shape.grm");
    let legend = serde_json::to_value(grm_lsp::convert::legend()).unwrap();
    let u = c.open(&p, &text).await;
    let r = c
        .ok(
            "textDocument/semanticTokens/full",
            json!({ "textDocument": { "uri": u } }),
        )
        .await;
    let out = decode_tokens(&text, &legend, &r["data"]);
    // The shape system's own words have types of their own.
    for (word, ty) in [
        ("split", "macro"),
        ("front", "enumMember"),
        ("floor", "decorator"),
        ("scope", "variable"),
    ] {
        assert!(
            out.lines()
                .any(|l| l.ends_with(&format!(" {word}")) && l.contains(ty)),
            "{word}: {ty}"
        );
    }
    snap!("shape_semantic_tokens", out);
}

#[tokio::test]
async fn shape_hover() {
    let mut c = Client::start().await;
    let (p, text) = fixture("shape.grm");
    let u = c.open(&p, &text).await;
    let mut out = String::new();
    for (what, needle, n, d) in [
        ("mode value", "shape;", 0, 0),
        ("lot setting", "lot =", 0, 0),
        ("lot shape", "rect", 0, 0),
        ("operation", "extrude", 0, 0),
        ("component split", "comp(", 0, 0),
        ("component kind", "faces", 0, 0),
        ("command tag", "facade", 0, 0),
        ("selector", "front", 0, 0),
        ("roof kind", "hip", 0, 0),
        ("axis", "split(y)", 0, 6),
        ("floating size", "~1: Upper", 0, 0),
        ("relative size", "25%", 0, 2),
        ("nil", "nil", 0, 0),
        ("shape value", "scope", 0, 0),
        ("tag query", "tagged", 0, 0),
        ("tag", "tagged(floor", 0, 7),
        ("primitive", "box", 0, 0),
        ("shape symbol", "Window :", 0, 0),
        ("terminal shape", "Door", 0, 0),
    ] {
        let h = c
            .ok("textDocument/hover", at(&u, pos(&text, needle, n, d)))
            .await;
        let range = if h.is_null() {
            "-".into()
        } else {
            range_str(&h["range"])
        };
        let md = h["contents"]["value"].as_str().unwrap_or("-");
        let _ = writeln!(out, "## {what} ({range})\n{md}\n");
    }
    snap!("shape_hover", out);
}

#[tokio::test]
async fn shape_completion() {
    let mut c = Client::start().await;
    let text = "system S {\n    mode = shape;\n    axiom Lot;\n    Lot -> extrude(10) Mass;\n    Mass -> comp(faces, ) {  };\n    Facade : tagged() -> repeat() { 3:  };\n    \n}\n";
    let (dir, _) = fixture("shape.grm");
    let p = dir.with_file_name("shape_completion.grm");
    let u = c.open(&p, text).await;
    let mut out = String::new();
    for (what, needle, n, d) in [
        ("operations", "Mass;", 0, 0),
        ("tag argument", "faces, )", 0, 7),
        ("selector", "{  }", 0, 2),
        ("tag query", "tagged()", 0, 7),
        ("axis", "repeat()", 0, 7),
        ("part target", "3:  }", 0, 3),
        ("statement", "    \n}", 0, 4),
    ] {
        let labels = c.completion_labels(&u, pos(text, needle, n, d)).await;
        let _ = writeln!(out, "## {what}\n{labels}\n");
    }
    snap!("shape_completion", out);
}

#[tokio::test]
async fn shape_formatting() {
    let mut c = Client::start().await;
    let (p, text) = fixture("shape_messy.grm");
    let u = c.open(&p, &text).await;
    let params = |u: &tower_lsp_server::ls_types::Uri| json!({ "textDocument": { "uri": u }, "options": { "tabSize": 4, "insertSpaces": true } });
    let r = c.ok("textDocument/formatting", params(&u)).await;
    let edits = r.as_array().unwrap();
    assert_eq!(edits.len(), 1);
    let formatted = edits[0]["newText"].as_str().unwrap().to_string();
    // Formatted text is left as it is.
    let fp = p.with_file_name("shape_formatted.grm");
    let fu = c.open(&fp, &formatted).await;
    let again: Value = c.ok("textDocument/formatting", params(&fu)).await;
    assert_eq!(again, json!([]), "idempotent");
    let mut out = format!("range {}\n", range_str(&edits[0]["range"]));
    out.push_str(&formatted);
    snap!("shape_formatting", out);
}

#[tokio::test]
async fn shape_code_actions() {
    let mut c = Client::start().await;
    let (p, text) = fixture("shape_untagged.grm");
    let u = c.open(&p, &text).await;
    let key = serde_json::to_value(&u).unwrap();
    let key = key.as_str().unwrap().to_string();
    let mut out = String::new();
    for (what, needle) in [
        ("the component split", "comp(faces)"),
        ("the vertical repeat", "repeat(y)"),
        ("the tile's split", "split(x)"),
    ] {
        let at = pos(&text, needle, 0, 1);
        let r = c
            .ok(
                "textDocument/codeAction",
                json!({ "textDocument": { "uri": u }, "range": { "start": at, "end": at }, "context": { "diagnostics": [] } }),
            )
            .await;
        let _ = writeln!(out, "## {what}");
        for a in r.as_array().unwrap() {
            let edits = a["edit"]["changes"][&key].as_array().unwrap();
            let fixed = apply(&text, edits);
            let changed: Vec<String> = fixed
                .lines()
                .filter(|l| !text.lines().any(|o| o == *l))
                .map(|l| format!("    + {l}"))
                .collect();
            let _ = writeln!(
                out,
                "{} [{}] preferred={} diagnostics={}\n{}",
                a["title"].as_str().unwrap(),
                a["kind"].as_str().unwrap(),
                a["isPreferred"],
                a["diagnostics"],
                changed.join("\n")
            );
        }
        out.push('\n');
    }
    snap!("shape_code_actions", out);
}

//! One snapshot per LSP feature, over the files in tests/lsp/, with the
//! server driven in-process as a tower service.

#[macro_use]
mod common;

use common::*;
use serde_json::{Value, json};
use std::fmt::Write;

/// The first line of each markdown hover, and the rest indented.
fn md(v: &Value) -> String {
    v["contents"]["value"].as_str().unwrap_or("-").to_string()
}

#[tokio::test]
async fn diagnostics() {
    let mut c = Client::start().await;
    let (p, text) = fixture("fixes.grm");
    let u = c.open(&p, &text).await;
    let d = c.diagnostics(&u, 1).await;
    let mut out = String::new();
    for x in d["diagnostics"].as_array().unwrap() {
        let _ = writeln!(
            out,
            "{} {} sev={} tags={} related={}\n    {}",
            range_str(&x["range"]),
            x["code"].as_str().unwrap(),
            x["severity"],
            x["tags"],
            x["relatedInformation"].as_array().map_or(0, |r| r.len()),
            x["message"].as_str().unwrap().replace('\n', "\n    ")
        );
    }
    snap!("diagnostics", out);
}

#[tokio::test]
async fn hover() {
    let mut c = Client::start().await;
    let (p, text) = fixture("plant.grm");
    let u = c.open(&p, &text).await;
    let mut out = String::new();
    for (what, needle, n, d) in [
        ("constant use", "SHRINK", 1, 2),
        ("meta-parameter use", "spread", 1, 0),
        ("module parameter", "l * SHRINK", 0, 0),
        ("turtle command", "F(l)", 0, 0),
        ("bracket", "[ +", 0, 0),
        ("built-in function", "mix", 0, 1),
        ("imported constant", "GOLDEN", 0, 0),
        ("predecessor: probabilities", "A(l) :", 1, 0),
        ("weight", "(2)", 0, 1),
        ("arrow", "->", 1, 0),
        ("setting", "iterations", 0, 2),
        ("keyword", "axiom", 0, 1),
        ("expression", "0.1", 0, 1),
        ("system", "Plant", 0, 1),
        ("user symbol", "B(x", 0, 0),
    ] {
        let h = c
            .ok("textDocument/hover", at(&u, pos(&text, needle, n, d)))
            .await;
        let range = if h.is_null() {
            "-".into()
        } else {
            range_str(&h["range"])
        };
        let _ = writeln!(out, "## {what} ({range})\n{}\n", md(&h));
    }
    let h = c
        .ok("textDocument/hover", at(&u, pos(&text, "stochastic", 0, 0)))
        .await;
    assert!(h.is_null(), "no hover in comments");
    snap!("hover", out);
}

#[tokio::test]
async fn definition_and_references() {
    let mut c = Client::start().await;
    let (p, text) = fixture("plant.grm");
    let (lp, ltext) = fixture("lib.grm");
    let u = c.open(&p, &text).await;
    c.open(&lp, &ltext).await;
    let mut out = String::new();
    for (what, needle, n) in [
        ("constant", "SHRINK", 2),
        ("imported constant", "GOLDEN", 0),
        ("module parameter", "l * SHRINK", 0),
        ("symbol", "A(1)", 0),
        ("import path", "lib.grm", 0),
    ] {
        let d = c
            .ok("textDocument/definition", at(&u, pos(&text, needle, n, 1)))
            .await;
        let _ = writeln!(
            out,
            "definition of {what}: {} {}",
            d["uri"],
            range_str(&d["range"])
        );
    }
    let d = c
        .ok("textDocument/definition", at(&u, pos(&text, "F(l)", 0, 0)))
        .await;
    let _ = writeln!(out, "definition of a terminal: {d}");
    for (what, needle, n, decl) in [
        ("constant", "SHRINK", 1, true),
        ("constant without declaration", "SHRINK", 1, false),
        ("imported constant (both files)", "GOLDEN", 0, true),
        ("module parameter", "l) :", 0, true),
    ] {
        let mut params = at(&u, pos(&text, needle, n, 0));
        params["context"] = json!({ "includeDeclaration": decl });
        let r = c.ok("textDocument/references", params).await;
        let _ = writeln!(out, "references of {what}:");
        for l in r.as_array().unwrap() {
            let _ = writeln!(out, "    {} {}", l["uri"], range_str(&l["range"]));
        }
    }
    snap!("definition_references", out);
}

#[tokio::test]
async fn rename() {
    let mut c = Client::start().await;
    let (p, text) = fixture("plant.grm");
    let u = c.open(&p, &text).await;
    let mut out = String::new();
    for (needle, n) in [("A(1)", 0), ("F(l)", 0), ("iterations", 0), ("l) :", 0)] {
        let r = c
            .request(
                "textDocument/prepareRename",
                at(&u, pos(&text, needle, n, 0)),
            )
            .await;
        let _ = writeln!(
            out,
            "prepare at `{needle}`: {}",
            match r {
                Ok(v) => format!(
                    "{} placeholder={}",
                    range_str(&v["range"]),
                    v["placeholder"]
                ),
                Err(e) => format!("error {} {}", e["code"], e["message"]),
            }
        );
    }
    for (needle, n, new) in [
        ("A(1)", 0, "Apex"),
        ("A(1)", 0, "B"),
        ("A(1)", 0, "F"),
        ("l) :", 0, "SHRINK"),
        ("l) :", 0, "len"),
    ] {
        let mut params = at(&u, pos(&text, needle, n, 0));
        params["newName"] = json!(new);
        match c.request("textDocument/rename", params).await {
            Ok(v) => {
                let _ = writeln!(out, "rename `{needle}` to `{new}`:");
                let changes = v["changes"].as_object().unwrap();
                for (file, edits) in changes {
                    for e in edits.as_array().unwrap() {
                        let _ = writeln!(
                            out,
                            "    {file} {} -> {}",
                            range_str(&e["range"]),
                            e["newText"]
                        );
                    }
                }
            }
            Err(e) => {
                let _ = writeln!(
                    out,
                    "rename `{needle}` to `{new}`: error {} {}",
                    e["code"], e["message"]
                );
            }
        }
    }
    snap!("rename", out);
}

#[tokio::test]
async fn completion_and_signature_help() {
    let mut c = Client::start().await;
    let text = "import \"lib.grm\";\nconst K = 1;\nmesh leaf = \"leaf.obj\";\nsystem S {\n    mode = derive;\n    axiom A(1);\n    A(len) : len > 0 -> F(len * ) A(len) mesh(leaf) cylinder(1, 2);\n    \n}\n";
    let (dir, _) = fixture("lib.grm");
    let p = dir.with_file_name("completion.grm");
    let u = c.open(&p, text).await;
    let mut out = String::new();
    for (what, needle, n, d) in [
        ("expression", "len * ", 0, 6),
        ("module string", "A(len) mesh", 0, 0),
        ("statement start", "    \n}", 0, 4),
        ("mode value", "derive", 0, 0),
        ("mesh name", "leaf) cyl", 0, 0),
        ("top level", "const", 0, 0),
    ] {
        let labels = c.completion_labels(&u, pos(text, needle, n, d)).await;
        let _ = writeln!(out, "## {what}\n{labels}\n");
    }
    for (what, needle, n, d) in [
        ("terminal, second argument", "2);", 0, 0),
        ("function-like terminal argument", "leaf)", 0, 0),
        ("turtle command", "len * ", 0, 0),
    ] {
        let r = c
            .ok(
                "textDocument/signatureHelp",
                at(&u, pos(text, needle, n, d)),
            )
            .await;
        let _ = writeln!(
            out,
            "## signature: {what}\n{}\n",
            serde_json::to_string_pretty(&r).unwrap()
        );
    }
    snap!("completion_signature_help", out);
}

#[tokio::test]
async fn symbols() {
    let mut c = Client::start().await;
    let (p, text) = fixture("plant.grm");
    let (fp, ftext) = fixture("fixes.grm");
    let u = c.open(&p, &text).await;
    c.open(&fp, &ftext).await;
    let r = c
        .ok(
            "textDocument/documentSymbol",
            json!({ "textDocument": { "uri": u } }),
        )
        .await;
    let mut out = String::from("## document symbols\n");
    fn tree(out: &mut String, v: &Value, depth: usize) {
        for s in v.as_array().into_iter().flatten() {
            let _ = writeln!(
                out,
                "{}{} [kind {}] {} sel {} {}",
                "    ".repeat(depth),
                s["name"].as_str().unwrap(),
                s["kind"],
                range_str(&s["range"]),
                range_str(&s["selectionRange"]),
                s["detail"].as_str().unwrap_or("")
            );
            tree(out, &s["children"], depth + 1);
        }
    }
    tree(&mut out, &r, 0);
    out.push_str("\n## workspace symbols `a`\n");
    let r = c.ok("workspace/symbol", json!({ "query": "a" })).await;
    for s in r.as_array().unwrap() {
        let _ = writeln!(
            out,
            "{} [kind {}] in {} at {} {}",
            s["name"].as_str().unwrap(),
            s["kind"],
            s["containerName"].as_str().unwrap_or("-"),
            s["location"]["uri"],
            range_str(&s["location"]["range"])
        );
    }
    snap!("symbols", out);
}

#[tokio::test]
async fn semantic_tokens() {
    let mut c = Client::start().await;
    let (p, text) = fixture("plant.grm");
    let legend = serde_json::to_value(grm_lsp::convert::legend()).unwrap();
    let u = c.open(&p, &text).await;
    let r = c
        .ok(
            "textDocument/semanticTokens/full",
            json!({ "textDocument": { "uri": u } }),
        )
        .await;
    let out = decode_tokens(&text, &legend, &r["data"]);
    // Every token of the lexer is classified: no gaps between words.
    let r2 = c
        .ok(
            "textDocument/semanticTokens/range",
            json!({ "textDocument": { "uri": u }, "range": { "start": { "line": 14, "character": 0 }, "end": { "line": 15, "character": 0 } } }),
        )
        .await;
    let ranged = decode_tokens(&text, &legend, &r2["data"]);
    assert!(ranged.lines().count() > 10 && ranged.lines().count() < out.lines().count());
    snap!("semantic_tokens", out);
}

#[tokio::test]
async fn formatting() {
    let mut c = Client::start().await;
    let (p, text) = fixture("messy.grm");
    let u = c.open(&p, &text).await;
    let r = c.ok("textDocument/formatting", json!({ "textDocument": { "uri": u }, "options": { "tabSize": 4, "insertSpaces": true } })).await;
    let edits = r.as_array().unwrap();
    assert_eq!(edits.len(), 1);
    let mut out = format!("range {}\n", range_str(&edits[0]["range"]));
    out.push_str(edits[0]["newText"].as_str().unwrap());
    // Broken text is not formatted.
    let (fp, ftext) = fixture("fixes.grm");
    let fu = c.open(&fp, &ftext).await;
    let r = c.ok("textDocument/formatting", json!({ "textDocument": { "uri": fu }, "options": { "tabSize": 4, "insertSpaces": true } })).await;
    assert!(r.is_null());
    snap!("formatting", out);
}

#[tokio::test]
async fn code_actions() {
    let mut c = Client::start().await;
    let (p, text) = fixture("fixes.grm");
    let u = c.open(&p, &text).await;
    let r = c
        .ok(
            "textDocument/codeAction",
            json!({ "textDocument": { "uri": u }, "range": { "start": { "line": 0, "character": 0 }, "end": { "line": 100, "character": 0 } }, "context": { "diagnostics": [] } }),
        )
        .await;
    let mut out = String::new();
    let key = serde_json::to_value(&u).unwrap();
    let key = key.as_str().unwrap();
    for a in r.as_array().unwrap() {
        let edits = a["edit"]["changes"][key].as_array().unwrap();
        let fixed = apply(&text, edits);
        // Show the changed lines only.
        let changed: Vec<String> = fixed
            .lines()
            .filter(|l| !text.lines().any(|o| o == *l))
            .map(|l| format!("    + {l}"))
            .collect();
        let removed: Vec<String> = text
            .lines()
            .filter(|l| !fixed.lines().any(|o| o == *l))
            .map(|l| format!("    - {l}"))
            .collect();
        let _ = writeln!(
            out,
            "{} [{}] preferred={} fixes {}\n{}\n{}",
            a["title"].as_str().unwrap(),
            a["kind"].as_str().unwrap(),
            a["isPreferred"],
            a["diagnostics"][0]["code"],
            removed.join("\n"),
            changed.join("\n")
        );
    }
    snap!("code_actions", out);
}

#[tokio::test]
async fn inlay_hints_and_folding() {
    let mut c = Client::start().await;
    let (p, text) = fixture("plant.grm");
    let u = c.open(&p, &text).await;
    let r = c
        .ok(
            "textDocument/inlayHint",
            json!({ "textDocument": { "uri": u }, "range": { "start": { "line": 0, "character": 0 }, "end": { "line": 100, "character": 0 } } }),
        )
        .await;
    let mut out = String::from("## inlay hints\n");
    for h in r.as_array().unwrap() {
        let _ = writeln!(
            out,
            "{}:{} {:?} kind={} padLeft={}",
            h["position"]["line"],
            h["position"]["character"],
            h["label"].as_str().unwrap(),
            h["kind"],
            h["paddingLeft"]
        );
    }
    out.push_str("\n## folding ranges\n");
    let r = c
        .ok(
            "textDocument/foldingRange",
            json!({ "textDocument": { "uri": u } }),
        )
        .await;
    for f in r.as_array().unwrap() {
        let _ = writeln!(out, "{}..{} {}", f["startLine"], f["endLine"], f["kind"]);
    }
    snap!("inlay_hints_folding", out);
}

#[tokio::test]
async fn utf16_positions() {
    let mut c = Client::start().await;
    let (p, text) = fixture("unicode.grm");
    let legend = serde_json::to_value(grm_lsp::convert::legend()).unwrap();
    let u = c.open(&p, &text).await;
    let mut out = String::new();
    // Hover and definition on the use of `Länge𝔸` (after a 2-unit char).
    let use_at = pos(&text, "Länge𝔸)", 0, 0);
    let h = c.ok("textDocument/hover", at(&u, use_at.clone())).await;
    let _ = writeln!(
        out,
        "hover at {use_at}: {} {}",
        range_str(&h["range"]),
        md(&h).replace('\n', " | ")
    );
    let d = c
        .ok("textDocument/definition", at(&u, use_at.clone()))
        .await;
    let _ = writeln!(out, "definition: {}", range_str(&d["range"]));
    // A position inside the surrogate pair is clamped, never a crash.
    let mut inside = use_at.clone();
    inside["character"] = json!(inside["character"].as_u64().unwrap() + 6);
    let h = c.ok("textDocument/hover", at(&u, inside)).await;
    let _ = writeln!(
        out,
        "hover inside 𝔸: {}",
        if h.is_null() {
            "-".into()
        } else {
            range_str(&h["range"])
        }
    );
    let mut params = at(&u, pos(&text, "ä)", 0, 0));
    params["context"] = json!({ "includeDeclaration": true });
    let r = c.ok("textDocument/references", params).await;
    for l in r.as_array().unwrap() {
        let _ = writeln!(out, "reference of ä: {}", range_str(&l["range"]));
    }
    let d = c.diagnostics(&u, 1).await;
    let _ = writeln!(
        out,
        "diagnostics: {}",
        d["diagnostics"].as_array().unwrap().len()
    );
    // An incremental edit after the non-ASCII text: rename Äst's use `ä * 0.5` to `ä * 0.25`.
    let edit_at = pos(&text, "0.5", 0, 3);
    c.notify(
        "textDocument/didChange",
        json!({ "textDocument": { "uri": u, "version": 2 }, "contentChanges": [ { "range": { "start": edit_at, "end": edit_at }, "text": "5" } ] }),
    )
    .await;
    let _ = c.diagnostics(&u, 2).await;
    let r = c
        .ok(
            "textDocument/semanticTokens/full",
            json!({ "textDocument": { "uri": u } }),
        )
        .await;
    let edited = text.replacen("0.5", "0.55", 1);
    out.push_str(&decode_tokens(&edited, &legend, &r["data"]));
    snap!("utf16", out);
}

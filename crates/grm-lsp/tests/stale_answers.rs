//! Answers of an older document version never replace a newer one's.
//!
//! Typing `seed = 2;` over `seed = 1;` sends the server every text on the
//! way, `seed = 2` (a missing `;`: the program has an error) just before
//! the finished one. On a busy machine the answers for those texts can be
//! late; the editor and the preview page must end on the finished text's
//! diagnostics and model, never on the error of the text before it (the
//! code-server test's seed step read "the program has 1 error" once after
//! the seed-2 model had come). The server's side of that: its
//! notifications come in version order and end on the last version's,
//! and a failed `grm/preview` names the version whose text failed
//! (`data.version`) so that a client can drop it when it has shown a
//! newer model.

mod common;

use common::*;
use grm_lsp::Config;
use serde_json::{Value, json};
use std::time::Duration;

/// plant.grm with a `seed` setting, the text the user edits.
fn seeded() -> (std::path::PathBuf, String) {
    let (p, text) = fixture("plant.grm");
    let text = text.replace("iterations = 3;", "iterations = 3;\n    seed = 1;");
    assert!(text.contains("seed = 1;"));
    (p, text)
}

/// The texts typing `typed` over `seed = 1;` passes through, the finished
/// one last (each keystroke one version, as an editor sends them).
fn keystrokes(text: &str, typed: &str) -> Vec<String> {
    (1..=typed.len())
        .map(|n| text.replace("seed = 1;", &typed[..n]))
        .collect()
}

fn change(u: &tower_lsp_server::ls_types::Uri, version: i32, text: &str) -> Value {
    json!({ "textDocument": { "uri": u, "version": version }, "contentChanges": [ { "text": text } ] })
}

/// The `method` notifications about `u` seen so far, in order.
fn notes<'a>(c: &'a Client, method: &str, u: &tower_lsp_server::ls_types::Uri) -> Vec<&'a Value> {
    let want = serde_json::to_value(u).unwrap();
    c.seen()
        .iter()
        .filter(|r| r.method() == method)
        .filter_map(|r| r.params())
        .filter(|p| p["uri"] == want)
        .collect()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn typing_a_seed_ends_on_the_finished_texts_model_and_diagnostics() {
    // Keystrokes at once, a few milliseconds apart (each then past the
    // debounce: the intermediate texts are analysed and answered too), and
    // (None) each after the update of the text before it came: the error
    // of `seed = 2` is then surely sent, just before the finished text's.
    let pauses = [Some(0u64), Some(3), Some(8), Some(20), None];
    for (round, pause) in pauses.into_iter().enumerate() {
        let mut c = Client::with(Config {
            debounce: Duration::from_millis(2),
            ..Config::default()
        })
        .await;
        let (p, text) = seeded();
        let u = c.open(&p, &text).await;
        let opened = c.diagnostics(&u, 1).await;
        // The page's live preview: its options are the updates' after each edit.
        let first = c
            .ok(
                "grm/preview",
                json!({ "textDocument": { "uri": u }, "live": true }),
            )
            .await;
        assert_eq!(first["seed"], 1, "round {round}");
        let texts = keystrokes(&text, "seed = 2;");
        let mut version = 1;
        for t in &texts {
            version += 1;
            c.notify("textDocument/didChange", change(&u, version, t))
                .await;
            match pause {
                Some(0) => {}
                Some(ms) => tokio::time::sleep(Duration::from_millis(ms)).await,
                None if version < texts.len() as i32 + 1 => {
                    let v = version;
                    let n = c
                        .wait_for(|r| {
                            r.method() == "grm/previewUpdated"
                                && r.params().is_some_and(|p| p["version"] == v)
                        })
                        .await;
                    // Kept for the checks below.
                    c.seen.push(n);
                }
                None => {}
            }
        }
        let last = version;
        if pause.is_none() {
            let errors = notes(&c, "grm/previewUpdated", &u).len();
            assert_eq!(
                errors,
                texts.len() - 1,
                "every text before the last answered"
            );
        }
        // The finished text's update and diagnostics come; then nothing more.
        let _ = c
            .wait_for(|r| {
                r.method() == "grm/previewUpdated"
                    && r.params().is_some_and(|p| p["version"] == last)
            })
            .await;
        // No errors: the warnings of the text as opened (the seed changes none).
        let diags = c.diagnostics(&u, last).await;
        assert_eq!(
            diags["diagnostics"], opened["diagnostics"],
            "round {round}: the finished text's diagnostics"
        );
        tokio::time::sleep(Duration::from_millis(300)).await;
        c.drain();
        let updates = notes(&c, "grm/previewUpdated", &u);
        let versions: Vec<i64> = updates
            .iter()
            .filter_map(|p| p["version"].as_i64())
            .collect();
        assert!(
            versions.windows(2).all(|w| w[0] < w[1]),
            "round {round}: updates in version order: {versions:?}"
        );
        assert!(
            versions.iter().all(|&v| v < i64::from(last)),
            "round {round}: an update after the finished text's: {versions:?}"
        );
        // Every text before the finished one (`seed = 2`, no `;`, the last of
        // them) has an error: each update answered for one is an error, and
        // came before the finished text's model.
        for n in &updates {
            assert!(
                n["result"].is_null() && n["error"].is_string(),
                "round {round}: {n}"
            );
        }
        let published: Vec<i64> = notes(&c, "textDocument/publishDiagnostics", &u)
            .iter()
            .filter_map(|p| p["version"].as_i64())
            .collect();
        assert!(
            published.iter().all(|&v| v < i64::from(last)),
            "round {round}: diagnostics after the finished text's: {published:?}"
        );
        // The model the page asks for now is the finished text's, seed 2.
        let now = c
            .ok(
                "grm/preview",
                json!({ "textDocument": { "uri": u }, "live": true }),
            )
            .await;
        assert_eq!(now["version"], last, "round {round}");
        assert_eq!(now["seed"], 2, "round {round}");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_failed_preview_names_the_version_whose_text_failed() {
    let mut c = Client::start().await;
    let (p, text) = seeded();
    let u = c.open(&p, &text).await;
    let _ = c.diagnostics(&u, 1).await;
    // `seed = 2` typed, its `;` not yet: version 2 has an error.
    let broken = text.replace("seed = 1;", "seed = 2");
    c.notify("textDocument/didChange", change(&u, 2, &broken))
        .await;
    let e = c
        .request(
            "grm/preview",
            json!({ "textDocument": { "uri": u }, "live": true }),
        )
        .await
        .expect_err("the program has an error");
    assert_eq!(e["code"], -32803, "RequestFailed: {e}");
    assert!(
        e["message"]
            .as_str()
            .is_some_and(|m| m.starts_with("the program has 1 error")),
        "{e}"
    );
    assert_eq!(e["data"], json!({ "version": 2 }), "{e}");
    // The finished text (version 3): its model, of version 3. A client
    // that shows it drops the version-2 failure should it come later.
    c.notify(
        "textDocument/didChange",
        change(&u, 3, &text.replace("seed = 1;", "seed = 2;")),
    )
    .await;
    let r = c
        .ok(
            "grm/preview",
            json!({ "textDocument": { "uri": u }, "live": true }),
        )
        .await;
    assert_eq!(r["version"], 3);
    assert_eq!(r["seed"], 2);
    // A request for a version the document is not at is ContentModified,
    // with no version of a failed text.
    let stale = c
        .request(
            "grm/preview",
            json!({ "textDocument": { "uri": u }, "version": 2, "live": true }),
        )
        .await
        .expect_err("stale");
    assert_eq!(stale["code"], -32801, "{stale}");
    assert!(stale.get("data").is_none_or(Value::is_null), "{stale}");
}

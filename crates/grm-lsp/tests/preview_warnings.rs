//! `grm/preview` carries the model's own warnings (W0013 no triangles,
//! W0014 geometry left out), which depend on the seed and parameters and
//! so come with the model, not with the file's diagnostics.

mod common;

use common::*;
use serde_json::{Value, json};

async fn preview(c: &mut Client, name: &str, text: &str) -> Value {
    let path = std::env::temp_dir().join(format!(
        "grm-preview-warnings-{}-{name}",
        std::process::id()
    ));
    let u = c.open(&path, text).await;
    c.ok(
        "grm/preview",
        json!({ "textDocument": { "uri": u.as_str() } }),
    )
    .await
}

fn codes(r: &Value) -> Vec<String> {
    r["warnings"]
        .as_array()
        .unwrap_or_else(|| panic!("no warnings array: {r}"))
        .iter()
        .map(|w| w["code"].as_str().unwrap_or_default().to_string())
        .collect()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn previews_carry_the_models_warnings() {
    let mut c = Client::start().await;
    let r = preview(
        &mut c,
        "bare.grm",
        "system S {\n    width = 0;\n    axiom F F;\n}\n",
    )
    .await;
    assert_eq!(codes(&r), ["W0013"], "{}", r["warnings"]);
    let w = &r["warnings"][0];
    assert!(w["message"].as_str().is_some_and(|m| !m.is_empty()), "{w}");
    assert!(w["help"].as_str().is_some(), "{w}");
    assert!(
        w["notes"][0]
            .as_str()
            .is_some_and(|n| n.contains("2 bones have no tube")),
        "{w}"
    );
    assert_eq!(r["stats"]["triangles"], 0);

    let r = preview(
        &mut c,
        "dropped.grm",
        "system S {\n    axiom F [ scale(0) sphere(1) ];\n}\n",
    )
    .await;
    assert_eq!(codes(&r), ["W0014"], "{}", r["warnings"]);

    let r = preview(
        &mut c,
        "fine.grm",
        "system S {\n    axiom F [ + F ] F;\n}\n",
    )
    .await;
    assert!(codes(&r).is_empty(), "{}", r["warnings"]);
}

//! Every `grm/preview` is answered (issue 32): a model whose answer would
//! be larger than a message may be (`grm_lsp::stdio::MAX_BODY`, 256 MiB)
//! is refused before it is encoded, with a coded message (R0408) that
//! names the limit; before, the transport dropped the answer and the
//! editor waited forever.

mod common;

use common::*;
use serde_json::json;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_preview_too_large_to_send_is_refused_with_a_coded_error() {
    let mut c = Client::start().await;
    let path = std::env::temp_dir().join(format!("grm-preview-limits-{}.grm", std::process::id()));
    // 2^19 boxes: 24 vertices and 12 triangles each, about 500 MiB of
    // base64 in the answer (and under the preview's 1 GiB to build).
    let text = "system Boxes {\n    iterations = 19;\n    axiom box(1, 1, 1);\n    box(x, y, z) -> box(x, y, z) box(x, y, z);\n}\n";
    let u = c.open(&path, text).await;
    let e = c
        .request(
            "grm/preview",
            json!({ "textDocument": { "uri": u.as_str() } }),
        )
        .await
        .expect_err("refused");
    assert_eq!(e["code"], -32803, "{e}");
    let m = e["message"].as_str().unwrap_or_default();
    assert!(m.contains("R0408"), "{m}");
    assert!(m.contains("over the limit of 256 MiB"), "{m}");
    assert!(m.contains("6291456 triangles"), "{m}");
    // A smaller one of the same file is answered.
    let r = c
        .ok(
            "grm/preview",
            json!({ "textDocument": { "uri": u.as_str() }, "iterations": 10 }),
        )
        .await;
    assert_eq!(r["stats"]["triangles"], 12 * 1024);
}

//! The shape preview's answer for `benches/tower_10k.grm`, `N` times (for a
//! profiler: `valgrind --tool=callgrind target/release/examples/answer_profile 1`
//! or `perf record`): what `shape_regrow`'s "answer" row times, plus the
//! JSON text the transport writes, nothing else. With `binary` (preview
//! protocol 3): the answer with its buffers in a blob, the small JSON text
//! and one copy of the blob's bytes (what the stdio transport writes).
//!
//! Run: `cargo run -p grm-lsp --release --example answer_profile [-- N [binary]]`.

use grm_analysis::FileAnalysis;
use grm_lsp::preview::{PreviewParams, PreviewUpdatedParams, answer};
use serde_json::json;
use std::path::Path;

/// The allocator `grmc lsp` serves with.
#[global_allocator]
static ALLOC: grm_derive::HugePageAlloc = grm_derive::HugePageAlloc;

fn main() {
    assert!(grm_derive::HugePageAlloc::serve(), "serving from the start");
    let n: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(1);
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/tower_10k.grm");
    let text = std::fs::read_to_string(&path).expect("benches/tower_10k.grm");
    let uri = grm_lsp::uris::uri_of(&path).expect("a file URI");
    let loader = grm_sema::MemLoader::new();
    let fa = FileAnalysis::new(&path, 1, &text, &loader);
    let binary = std::env::args().nth(2).as_deref() == Some("binary");
    let params: PreviewParams =
        serde_json::from_value(json!({ "textDocument": { "uri": uri }, "binary": binary }))
            .expect("params");
    let mut bytes = 0;
    let mut blob_bytes = 0;
    for i in 0..n {
        let mut result = answer(&fa, &uri, &params).expect("preview");
        if let Some(blob) = result.take_blob(i as u64 + 1) {
            blob_bytes = std::hint::black_box(blob.to_vec()).len();
        }
        let note = PreviewUpdatedParams {
            uri: uri.clone(),
            version: fa.version,
            result: Some(result),
            error: None,
        };
        let v = serde_json::to_value(&note).expect("json");
        bytes = serde_json::to_string(&v).expect("json").len();
    }
    println!("{n} answers of {bytes} bytes (and a blob of {blob_bytes} bytes)");
}

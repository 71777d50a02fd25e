//! Preview protocol 3 (docs/lsp-extensions.md, "Binary buffers"): the
//! buffers of a `binary` answer, read back from its blob, are the bytes of
//! the base64 answer's, for a building (quads, picks) and a tree (bones,
//! smooth normals, indices); the rest of the answer is the same.

use grm_analysis::FileAnalysis;
use grm_lsp::preview::{PreviewParams, PreviewResult, answer};
use serde_json::{Value, json};
use std::path::Path;

fn answers(example: &str, extra: Value) -> (PreviewResult, PreviewResult) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples")
        .join(example);
    let text = std::fs::read_to_string(&path).expect("example");
    let uri = grm_lsp::uris::uri_of(&path).expect("a file URI");
    let loader = grm_sema::FsLoader;
    let fa = FileAnalysis::new(&path, 1, &text, &loader);
    let mut p = json!({ "textDocument": { "uri": uri } });
    for (k, v) in extra.as_object().expect("object") {
        p[k] = v.clone();
    }
    let text_params: PreviewParams = serde_json::from_value(p.clone()).expect("params");
    p["binary"] = json!(true);
    let bin_params: PreviewParams = serde_json::from_value(p).expect("params");
    (
        answer(&fa, &uri, &text_params).expect("preview"),
        answer(&fa, &uri, &bin_params).expect("preview"),
    )
}

/// Every buffer of `a` (base64) and of `b` (blob ranges, after
/// `take_blob`) decoded, in the same order.
fn check_same(text: &PreviewResult, mut bin: PreviewResult) {
    let blob = bin.take_blob(41).expect("a blob");
    assert_eq!(blob.id, 41);
    let bytes = blob.to_vec();
    assert_eq!(bin.encoding, "blob-le");
    assert_eq!(bin.blob.expect("blob ref").bytes, bytes.len() as u64);
    assert_eq!(text.encoding, "base64-le");
    assert!(text.blob.is_none());
    assert_eq!(text.parts.len(), bin.parts.len());
    let mut buffers = 0;
    for (a, b) in text.parts.iter().zip(&bin.parts) {
        for (x, y) in [
            (&a.positions, &b.positions),
            (&a.normals, &b.normals),
            (&a.indices, &b.indices),
            (&a.picks, &b.picks),
        ] {
            assert!(x.text().is_some(), "base64 text");
            assert!(y.text().is_none_or(str::is_empty), "a range, or empty");
            assert_eq!(x.decode(&[]), y.decode(&bytes));
            buffers += usize::from(!x.is_empty());
        }
        assert_eq!(
            (a.vertex_count, a.triangle_count, a.pick_count, &a.layout),
            (b.vertex_count, b.triangle_count, b.pick_count, &b.layout)
        );
    }
    let (s, t) = (&text.skeleton, &bin.skeleton);
    for (x, y) in [
        (&s.bones, &t.bones),
        (&s.parents, &t.parents),
        (&s.origins, &t.origins),
    ] {
        assert_eq!(x.decode(&[]), y.decode(&bytes));
        buffers += usize::from(!x.is_empty());
    }
    assert!(buffers > 0);
    // Everything else is the same (timings aside).
    let strip = |r: &PreviewResult| {
        let mut v = serde_json::to_value(r).expect("json");
        for k in ["parts", "skeleton", "stats", "encoding", "blob"] {
            v.as_object_mut().expect("object").remove(k);
        }
        v
    };
    assert_eq!(strip(text), strip(&bin));
}

#[test]
fn a_buildings_blob_holds_its_base64_buffers() {
    let (text, bin) = answers("townhouse.grm", json!({}));
    assert!(text.parts.iter().any(|p| p.layout.is_some()), "quads");
    check_same(&text, bin);
}

#[test]
fn a_trees_blob_holds_its_base64_buffers() {
    let (text, bin) = answers("ternary_tree.grm", json!({ "iterations": 4 }));
    assert!(text.skeleton.bone_count > 0);
    assert!(
        text.parts.iter().any(|p| !p.normals.is_empty()),
        "smooth normals"
    );
    check_same(&text, bin);
}

#[test]
fn bytes_never_placed_in_a_blob_go_as_base64() {
    let (text, bin) = answers("townhouse.grm", json!({}));
    let j = |r: &PreviewResult| serde_json::to_value(&r.parts).expect("json");
    assert_eq!(j(&text), j(&bin));
}

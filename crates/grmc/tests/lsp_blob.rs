//! Preview protocol 3 over `grmc lsp`'s stdio (docs/lsp-extensions.md,
//! "Binary buffers"): the server announces version 3; a `grm/preview` with
//! `"binary": true` is answered with buffer ranges, after a frame of its
//! own (`Content-Type: application/vnd.grm.blob`, `Grm-Blob: ID`) holding
//! the bytes; each buffer read from it is the base64 answer's. The live
//! preview's `grm/previewUpdated` after an edit comes the same way.

use grm_lsp::blob::Buf;
use serde_json::{Value, json};
use std::collections::HashMap;
use std::io::{BufRead, Write};
use std::process::{Command, Stdio};

/// One frame of the server's output: its headers (lower-cased names) and body.
fn read_frame(r: &mut impl BufRead) -> (HashMap<String, String>, Vec<u8>) {
    let mut headers = HashMap::new();
    let mut line = String::new();
    loop {
        line.clear();
        assert!(
            r.read_line(&mut line).expect("read") > 0,
            "the server ended"
        );
        let l = line.trim_end();
        if l.is_empty() {
            break;
        }
        let (k, v) = l.split_once(':').expect("a header");
        headers.insert(k.trim().to_lowercase(), v.trim().to_string());
    }
    let len: usize = headers["content-length"].parse().expect("length");
    let mut body = vec![0; len];
    r.read_exact(&mut body).expect("body");
    (headers, body)
}

fn send(w: &mut impl Write, v: &Value) {
    let b = v.to_string();
    write!(w, "Content-Length: {}\r\n\r\n{b}", b.len()).expect("write");
    w.flush().expect("flush");
}

/// The buffers of a preview result, decoded (`blob`: the bytes its ranges are in).
fn buffers(r: &Value, blob: &[u8]) -> Vec<Option<Vec<u8>>> {
    let buf = |v: &Value| serde_json::from_value::<Buf>(v.clone()).expect("a buffer");
    let mut out = Vec::new();
    for p in r["parts"].as_array().expect("parts") {
        for k in ["positions", "normals", "indices", "picks"] {
            out.push(buf(&p[k]).decode(blob));
        }
    }
    for k in ["bones", "parents", "origins"] {
        out.push(buf(&r["skeleton"][k]).decode(blob));
    }
    out
}

#[test]
fn binary_previews_travel_as_blob_frames_before_their_messages() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let path = std::fs::canonicalize(root.join("examples/townhouse.grm")).expect("example");
    let text = std::fs::read_to_string(&path).expect("read");
    let uri = format!("file://{}", path.display());
    let mut child = Command::new(env!("CARGO_BIN_EXE_grmc"))
        .arg("lsp")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("grmc lsp starts");
    let mut w = child.stdin.take().expect("stdin");
    let mut r = std::io::BufReader::new(child.stdout.take().expect("stdout"));
    let mut blobs: HashMap<u64, Vec<u8>> = HashMap::new();
    // The next JSON message matching `f`, keeping the blob frames read before it.
    let mut next = |r: &mut std::io::BufReader<_>, f: &dyn Fn(&Value) -> bool| loop {
        let (h, body) = read_frame(r);
        if h.get("content-type").map(String::as_str) == Some("application/vnd.grm.blob") {
            blobs.insert(h["grm-blob"].parse().expect("id"), body);
            continue;
        }
        let v: Value = serde_json::from_slice(&body).expect("JSON");
        if f(&v) {
            return (v, std::mem::take(&mut blobs));
        }
    };
    send(
        &mut w,
        &json!({"jsonrpc": "2.0", "id": 1, "method": "initialize", "params": {"capabilities": {}}}),
    );
    let (init, _) = next(&mut r, &|v| v["id"] == 1);
    assert_eq!(
        init["result"]["capabilities"]["experimental"]["grmPreview"]["version"],
        3
    );
    send(
        &mut w,
        &json!({"jsonrpc": "2.0", "method": "initialized", "params": {}}),
    );
    send(
        &mut w,
        &json!({"jsonrpc": "2.0", "method": "textDocument/didOpen", "params": {
        "textDocument": {"uri": uri, "languageId": "grm", "version": 1, "text": text}}}),
    );
    send(
        &mut w,
        &json!({"jsonrpc": "2.0", "id": 2, "method": "grm/preview", "params": {"textDocument": {"uri": uri}}}),
    );
    let (plain, none) = next(&mut r, &|v| v["id"] == 2);
    assert!(none.is_empty(), "no blob without binary");
    let plain = &plain["result"];
    assert_eq!(plain["encoding"], "base64-le");
    send(
        &mut w,
        &json!({"jsonrpc": "2.0", "id": 3, "method": "grm/preview", "params": {
        "textDocument": {"uri": uri}, "binary": true, "live": true}}),
    );
    let (bin, got) = next(&mut r, &|v| v["id"] == 3);
    let bin = &bin["result"];
    assert_eq!(bin["encoding"], "blob-le", "{bin}");
    let id = bin["blob"]["id"].as_u64().expect("blob id");
    let blob = got.get(&id).expect("the blob came before its answer");
    assert_eq!(Some(blob.len() as u64), bin["blob"]["bytes"].as_u64());
    assert!(bin["parts"][0]["positions"].is_object(), "a range");
    let want = buffers(plain, &[]);
    assert!(
        want.iter()
            .any(|b| b.as_ref().is_some_and(|b| !b.is_empty()))
    );
    assert_eq!(buffers(bin, blob), want);
    // An edit: the live preview's notification names a blob sent before it.
    send(
        &mut w,
        &json!({"jsonrpc": "2.0", "method": "textDocument/didChange", "params": {
        "textDocument": {"uri": uri, "version": 2}, "contentChanges": [{"text": format!("{text}\n")}]}}),
    );
    let (note, got) = next(&mut r, &|v| v["method"] == "grm/previewUpdated");
    let res = &note["params"]["result"];
    assert_eq!(res["encoding"], "blob-le", "{note}");
    let id2 = res["blob"]["id"].as_u64().expect("blob id");
    assert!(id2 > id);
    assert_eq!(buffers(res, got.get(&id2).expect("its blob first")), want);
    send(
        &mut w,
        &json!({"jsonrpc": "2.0", "id": 4, "method": "shutdown"}),
    );
    next(&mut r, &|v| v["id"] == 4);
    send(&mut w, &json!({"jsonrpc": "2.0", "method": "exit"}));
    assert!(child.wait().expect("exit").success());
}

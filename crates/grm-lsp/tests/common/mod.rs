//! An in-process LSP client: drives the server as a tower `Service` with
//! JSON-RPC requests and collects what it sends back.

#![allow(dead_code)]

pub mod editor;
pub mod layout;

use futures::StreamExt;
use grm_diag::SourceFile;
use grm_lsp::Config;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Duration;
use tower::{Service, ServiceExt};
use tower_lsp_server::LspService;
use tower_lsp_server::jsonrpc::Request;
use tower_lsp_server::ls_types::Uri;

/// Asserts a snapshot (scrubbed of the machine's paths) in
/// tests/lsp/snapshots, named `$name`.
#[allow(unused_macros)]
macro_rules! snap {
    ($name:expr, $value:expr) => {
        insta::with_settings!({
            snapshot_path => concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/lsp/snapshots"),
            prepend_module_to_snapshot => false,
            omit_expression => true,
        }, {
            insta::assert_snapshot!($name, $crate::common::scrub(&$value));
        });
    };
}

pub struct Client {
    service: LspService<grm_lsp::Backend>,
    notes: tokio::sync::mpsc::UnboundedReceiver<Request>,
    /// Notifications received and not yet consumed.
    pub seen: Vec<Request>,
    id: i64,
    /// The server's answer to `initialize`.
    pub initialized: Value,
}

/// A notification matching `f`: one already `seen` (taken from it), else
/// the next of `notes` to match (10 s at most), keeping the others in
/// `seen`. Shared by the test clients.
pub async fn wait_for_in(
    seen: &mut Vec<Request>,
    notes: &mut tokio::sync::mpsc::UnboundedReceiver<Request>,
    f: impl Fn(&Request) -> bool,
) -> Request {
    if let Some(i) = seen.iter().position(&f) {
        return seen.remove(i);
    }
    let deadline = tokio::time::Instant::now() + Duration::from_secs(10);
    loop {
        let r = tokio::time::timeout_at(deadline, notes.recv())
            .await
            .expect("notification in time")
            .expect("socket open");
        if f(&r) {
            return r;
        }
        seen.push(r);
    }
}

/// The repository root.
pub fn root() -> PathBuf {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    grm_sema::normalize(&std::fs::canonicalize(&p).unwrap_or(p))
}

/// A fixture of tests/lsp.
pub fn fixture(name: &str) -> (PathBuf, String) {
    let p = root().join("tests/lsp").join(name);
    let text = std::fs::read_to_string(&p).expect("fixture");
    (p, text)
}

pub fn uri(p: &Path) -> Uri {
    Uri::from_file_path(p).expect("absolute path")
}

/// Text with the repository root replaced, for snapshots.
pub fn scrub(s: &str) -> String {
    let r = root().display().to_string();
    s.replace(&format!("file://{r}"), "file://$ROOT")
        .replace(&r, "$ROOT")
}

/// The LSP position of the `n`-th `needle` in `text`, plus `delta` bytes.
pub fn pos(text: &str, needle: &str, n: usize, delta: usize) -> Value {
    let mut from = 0;
    let mut at = 0;
    for _ in 0..=n {
        at = from
            + text[from..]
                .find(needle)
                .unwrap_or_else(|| panic!("{needle}"));
        from = at + 1;
    }
    let src = SourceFile::new("", text);
    let (line, character) = src.line_col_utf16((at + delta) as u32);
    json!({ "line": line, "character": character })
}

pub fn range_str(r: &Value) -> String {
    format!(
        "{}:{}-{}:{}",
        r["start"]["line"], r["start"]["character"], r["end"]["line"], r["end"]["character"]
    )
}

impl Client {
    pub async fn start() -> Client {
        Client::with(Config {
            debounce: Duration::from_millis(5),
            ..Config::default()
        })
        .await
    }

    pub async fn with(config: Config) -> Client {
        Client::with_init(config, json!({ "capabilities": {} })).await
    }

    /// A client whose `initialize` sends `init`.
    pub async fn with_init(config: Config, init: Value) -> Client {
        Client::with_service(grm_lsp::service(config), init).await
    }

    /// A client of a server whose protocol-3 previews leave their blobs
    /// in `store` (as `grmc view`'s does).
    #[allow(dead_code)]
    pub async fn with_blobs(
        config: Config,
        store: std::sync::Arc<grm_lsp::blob::BlobStore>,
    ) -> Client {
        Client::with_service(
            grm_lsp::service_with_blobs(config, store),
            json!({ "capabilities": {} }),
        )
        .await
    }

    async fn with_service(
        (service, socket): (LspService<grm_lsp::Backend>, tower_lsp_server::ClientSocket),
        init: Value,
    ) -> Client {
        let (tx, rx) = tokio::sync::mpsc::unbounded_channel();
        tokio::spawn(async move {
            let mut socket = socket;
            while let Some(r) = socket.next().await {
                if tx.send(r).is_err() {
                    break;
                }
            }
        });
        let mut c = Client {
            service,
            notes: rx,
            seen: Vec::new(),
            id: 0,
            initialized: Value::Null,
        };
        let init = c.request("initialize", init).await;
        assert!(init.is_ok(), "{init:?}");
        c.initialized = init.unwrap_or_default();
        c.notify("initialized", json!({})).await;
        c
    }

    async fn call(&mut self, req: Request) -> Option<tower_lsp_server::jsonrpc::Response> {
        let svc = self.service.ready().await.expect("service ready");
        svc.call(req).await.expect("service call")
    }

    /// A request; `Err` carries the JSON-RPC error as JSON.
    pub async fn request(&mut self, method: &'static str, params: Value) -> Result<Value, Value> {
        self.id += 1;
        let req = Request::build(method).id(self.id).params(params).finish();
        let resp = self.call(req).await.expect("a request is always answered");
        let (_, body) = resp.into_parts();
        body.map_err(|e| serde_json::to_value(e).unwrap_or(Value::Null))
    }

    /// Send a request and return its pending answer as a task (to run
    /// other requests while it is being computed).
    pub async fn spawn_request(
        &mut self,
        method: &'static str,
        params: Value,
    ) -> tokio::task::JoinHandle<Option<tower_lsp_server::jsonrpc::Response>> {
        self.id += 1;
        let req = Request::build(method).id(self.id).params(params).finish();
        let svc = self.service.ready().await.expect("service ready");
        let fut = svc.call(req);
        tokio::spawn(async move { fut.await.expect("service call") })
    }

    /// The id of the last request sent.
    pub fn last_id(&self) -> i64 {
        self.id
    }

    pub async fn ok(&mut self, method: &'static str, params: Value) -> Value {
        match self.request(method, params).await {
            Ok(v) => v,
            Err(e) => panic!("{method} failed: {e}"),
        }
    }

    /// The labels of a completion at `p` (a position), in order, with `*`
    /// after a snippet's, separated by spaces.
    pub async fn completion_labels(&mut self, u: &Uri, p: Value) -> String {
        let r = self.ok("textDocument/completion", at(u, p)).await;
        let labels: Vec<String> = r
            .as_array()
            .unwrap()
            .iter()
            .map(|i| {
                let snippet = if i["insertTextFormat"] == 2 { "*" } else { "" };
                format!("{}{snippet}", i["label"].as_str().unwrap())
            })
            .collect();
        labels.join(" ")
    }

    pub async fn notify(&mut self, method: &'static str, params: Value) {
        let req = Request::build(method).params(params).finish();
        assert!(self.call(req).await.is_none());
    }

    pub async fn open(&mut self, path: &Path, text: &str) -> Uri {
        let u = uri(path);
        self.notify(
            "textDocument/didOpen",
            json!({ "textDocument": { "uri": u, "languageId": "grm", "version": 1, "text": text } }),
        )
        .await;
        u
    }

    /// Open a document under `uri` exactly as written (the client's own
    /// spelling: percent-encoded or not, any hex case).
    pub async fn open_as(&mut self, uri: &str, text: &str) -> Uri {
        let u: Uri = uri.parse().expect("a valid URI");
        assert_eq!(u.as_str(), uri, "parsing keeps the spelling");
        self.notify(
            "textDocument/didOpen",
            json!({ "textDocument": { "uri": uri, "languageId": "grm", "version": 1, "text": text } }),
        )
        .await;
        u
    }

    /// Wait for a notification matching `f` (10 s at most).
    pub async fn wait_for(&mut self, f: impl Fn(&Request) -> bool) -> Request {
        wait_for_in(&mut self.seen, &mut self.notes, f).await
    }

    /// The diagnostics published for `u` at `version`.
    pub async fn diagnostics(&mut self, u: &Uri, version: i32) -> Value {
        let want = serde_json::to_value(u).unwrap_or(Value::Null);
        let r = self
            .wait_for(|r| {
                r.method() == "textDocument/publishDiagnostics"
                    && r.params()
                        .is_some_and(|p| p["uri"] == want && p["version"] == version)
            })
            .await;
        r.params().cloned().unwrap_or(Value::Null)
    }

    /// The notifications received and not yet waited for (after `drain`).
    pub fn seen(&self) -> &[Request] {
        &self.seen
    }

    /// Drain what has arrived so far without waiting.
    pub fn drain(&mut self) {
        while let Ok(r) = self.notes.try_recv() {
            self.seen.push(r);
        }
    }
}

/// A whole-document position argument.
pub fn at(u: &Uri, p: Value) -> Value {
    json!({ "textDocument": { "uri": u }, "position": p })
}

/// Decode LSP semantic tokens into lines of `line:col len type [mods] text`.
pub fn decode_tokens(text: &str, legend: &Value, data: &Value) -> String {
    use std::fmt::Write as _;
    let types: Vec<&str> = legend["tokenTypes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t.as_str().unwrap())
        .collect();
    let mods: Vec<&str> = legend["tokenModifiers"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t.as_str().unwrap())
        .collect();
    let d: Vec<u64> = data
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_u64().unwrap())
        .collect();
    let lines: Vec<Vec<u16>> = text
        .split('\n')
        .map(|l| l.encode_utf16().collect())
        .collect();
    let (mut line, mut col) = (0u64, 0u64);
    let mut out = String::new();
    for t in d.chunks(5) {
        if t[0] > 0 {
            line += t[0];
            col = t[1];
        } else {
            col += t[1];
        }
        let l = &lines[line as usize];
        let s = String::from_utf16_lossy(&l[col as usize..(col + t[2]) as usize]);
        let m: Vec<&str> = (0..mods.len())
            .filter(|b| t[4] & (1 << b) != 0)
            .map(|b| mods[b])
            .collect();
        let _ = writeln!(
            out,
            "{line}:{col} {} {} [{}] {s}",
            t[2],
            types[t[3] as usize],
            m.join(",")
        );
    }
    out
}

/// Apply LSP text edits to a text.
pub fn apply(text: &str, edits: &[Value]) -> String {
    let src = grm_diag::SourceFile::new("", text);
    let mut es: Vec<(u32, u32, String)> = edits
        .iter()
        .map(|e| {
            let r = &e["range"];
            let o = |p: &Value| {
                src.offset_of_utf16(
                    p["line"].as_u64().unwrap() as u32,
                    p["character"].as_u64().unwrap() as u32,
                )
            };
            (
                o(&r["start"]),
                o(&r["end"]),
                e["newText"].as_str().unwrap().to_string(),
            )
        })
        .collect();
    es.sort_by_key(|e| std::cmp::Reverse(e.0));
    let mut s = text.to_string();
    for (a, b, t) in es {
        s.replace_range(a as usize..b as usize, &t);
    }
    s
}

/// A preview part's picks (base64 of six `u32`s each on the wire) as
/// JSON records: `firstTriangle`, `triangleCount`, `kind`, `index`,
/// `module`, `origin` (null: unknown), `focus`.
pub fn picks(part: &Value) -> Vec<Value> {
    let s = part["picks"].as_str().expect("picks: base64");
    let picks = grm_lsp::preview::decode_picks(s).expect("picks: whole records");
    assert_eq!(part["pickCount"].as_u64(), Some(picks.len() as u64));
    picks
        .iter()
        .map(|p| serde_json::to_value(p).expect("json"))
        .collect()
}

/// A preview answer's triangle count (its `stats`).
pub fn triangles(r: &Value) -> u64 {
    r["stats"]["triangles"].as_u64().expect("triangles")
}

/// The classes of a preview's edits, `id:class` (`+` when replayed).
pub fn classes(r: &Value) -> String {
    r["edits"]["list"]
        .as_array()
        .map(|l| {
            l.iter()
                .map(|e| {
                    format!(
                        "{}:{}{}",
                        e["id"],
                        e["class"].as_str().unwrap(),
                        if e["replayed"] == true { "+" } else { "" }
                    )
                })
                .collect::<Vec<_>>()
                .join(" ")
        })
        .unwrap_or_default()
}

/// Edit `id` of a preview's `edits.list`.
pub fn listed(r: &Value, id: u32) -> Value {
    r["edits"]["list"]
        .as_array()
        .and_then(|l| l.iter().find(|e| e["id"] == id))
        .cloned()
        .unwrap_or_else(|| panic!("edit {id} in {}", r["edits"]))
}

/// The townhouse of tests/lsp/shape.grm, written in a fresh folder.
pub fn house() -> (tempfile::TempDir, PathBuf, String) {
    let dir = tempfile::tempdir().expect("tempdir");
    let root = grm_sema::normalize(&std::fs::canonicalize(dir.path()).expect("canonical"));
    let (_, text) = fixture("shape.grm");
    let p = root.join("house.grm");
    std::fs::write(&p, &text).expect("write");
    (dir, p, text)
}

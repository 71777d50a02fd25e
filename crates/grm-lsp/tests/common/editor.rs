//! An in-process editor: a client that declares `workspace.applyEdit`
//! (with document changes and file creation), answers the server's
//! `workspace/applyEdit` as applied and hands its edits to the test,
//! which then does what the editor would (writes the file, changes the
//! document). Shared by the edits and manipulation tests.

use super::{uri, wait_for_in};
use futures::{SinkExt, StreamExt};
use serde_json::{Value, json};
use std::path::Path;
use std::time::Duration;
use tower::{Service, ServiceExt};
use tower_lsp_server::LspService;
use tower_lsp_server::jsonrpc::{Request, Response};
use tower_lsp_server::ls_types::Uri;

/// An in-process client that answers the server's `workspace/applyEdit`
/// (applied) and hands its edits to the test, which then does what the
/// editor would: writes the file, opens or changes the document.
pub struct Editor {
    service: LspService<grm_lsp::Backend>,
    notes: tokio::sync::mpsc::UnboundedReceiver<Request>,
    applied: tokio::sync::mpsc::UnboundedReceiver<Value>,
    seen: Vec<Request>,
    id: i64,
}

impl Editor {
    pub async fn start() -> Editor {
        let (service, socket) = grm_lsp::service(grm_lsp::Config {
            debounce: Duration::from_millis(5),
            ..grm_lsp::Config::default()
        });
        let (tx, notes) = tokio::sync::mpsc::unbounded_channel();
        let (atx, applied) = tokio::sync::mpsc::unbounded_channel();
        tokio::spawn(async move {
            let (mut requests, mut responses) = socket.split();
            while let Some(r) = requests.next().await {
                if r.method() == "workspace/applyEdit"
                    && let Some(id) = r.id().cloned()
                {
                    let _ = atx.send(r.params().cloned().unwrap_or(Value::Null));
                    let _ = responses
                        .send(Response::from_ok(id, json!({ "applied": true })))
                        .await;
                    continue;
                }
                if tx.send(r).is_err() {
                    break;
                }
            }
        });
        let mut e = Editor {
            service,
            notes,
            applied,
            seen: Vec::new(),
            id: 0,
        };
        let caps = json!({ "capabilities": { "workspace": {
            "applyEdit": true,
            "workspaceEdit": { "documentChanges": true, "resourceOperations": ["create"] }
        } } });
        e.ok("initialize", caps).await;
        e.notify("initialized", json!({})).await;
        e
    }

    pub async fn request(&mut self, method: &'static str, params: Value) -> Result<Value, Value> {
        self.id += 1;
        let req = Request::build(method).id(self.id).params(params).finish();
        let svc = self.service.ready().await.expect("ready");
        let resp = svc.call(req).await.expect("call").expect("answered");
        let (_, body) = resp.into_parts();
        body.map_err(|e| serde_json::to_value(e).unwrap_or(Value::Null))
    }

    pub async fn ok(&mut self, method: &'static str, params: Value) -> Value {
        match self.request(method, params).await {
            Ok(v) => v,
            Err(e) => panic!("{method} failed: {e}"),
        }
    }

    pub async fn notify(&mut self, method: &'static str, params: Value) {
        let req = Request::build(method).params(params).finish();
        let svc = self.service.ready().await.expect("ready");
        assert!(svc.call(req).await.expect("call").is_none());
    }

    pub async fn open(&mut self, path: &Path, text: &str, version: i32) -> Uri {
        let u = uri(path);
        self.notify(
            "textDocument/didOpen",
            json!({ "textDocument": { "uri": u, "languageId": "json", "version": version, "text": text } }),
        )
        .await;
        u
    }

    pub async fn replace(&mut self, u: &Uri, version: i32, text: &str) {
        self.notify(
            "textDocument/didChange",
            json!({ "textDocument": { "uri": u, "version": version }, "contentChanges": [{ "text": text }] }),
        )
        .await;
    }

    /// A notification matching `f` (10 s at most).
    pub async fn wait_for(&mut self, f: impl Fn(&Request) -> bool) -> Request {
        wait_for_in(&mut self.seen, &mut self.notes, f).await
    }

    /// The next `grm/previewUpdated` whose result satisfies `f`.
    pub async fn updated(&mut self, f: impl Fn(&Value) -> bool) -> Value {
        let r = self
            .wait_for(|r| {
                r.method() == "grm/previewUpdated" && r.params().is_some_and(|p| f(&p["result"]))
            })
            .await;
        r.params().unwrap()["result"].clone()
    }

    /// The next diagnostics published for `u` satisfying `f`.
    pub async fn diagnostics(&mut self, u: &Uri, f: impl Fn(&[Value]) -> bool) -> Vec<Value> {
        let want = serde_json::to_value(u).unwrap();
        let r = self
            .wait_for(|r| {
                r.method() == "textDocument/publishDiagnostics"
                    && r.params().is_some_and(|p| {
                        p["uri"] == want && f(p["diagnostics"].as_array().unwrap())
                    })
            })
            .await;
        r.params().unwrap()["diagnostics"]
            .as_array()
            .unwrap()
            .clone()
    }

    /// The next `workspace/applyEdit` the server sent.
    pub async fn next_applied(&mut self) -> Value {
        tokio::time::timeout(Duration::from_secs(10), self.applied.recv())
            .await
            .expect("applyEdit in time")
            .expect("open")
    }
}

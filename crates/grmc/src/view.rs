//! `grmc view FILE`: the live preview page in a browser, for artists on
//! other editors and for tests.
//!
//! Role: serves the built preview page (`editors/preview/dist`, embedded at
//! compile time) on 127.0.0.1 and answers its requests with the language
//! server itself, run in-process (`grm_lsp::service`): `POST /api/preview`
//! is `grm/preview` and `POST /api/pick` is `grm/pick`, with the same
//! parameters and results (docs/lsp-extensions.md), so the page, the
//! protocol and the model building are exactly those of the VS Code
//! preview. The file is watched: when it changes on disk, the server gets
//! a `didChange` and its `grm/previewUpdated` reaches the page.
//!
//! HTTP, by hand on `std::net` (one thread per connection, `Connection:
//! close`). Requests are not serialised: each connection's thread hands its
//! request to the server and waits for its own answer, and the server works
//! on several at once, so a newer `grm/preview` reaches the server while an
//! older one is being built, supersedes it, and the older one is answered
//! at once (docs/lsp-extensions.md):
//!
//! | request | answer |
//! |---|---|
//! | `GET /`, `/preview.js`, `/preview.css` | the page |
//! | `POST /api/preview`, `/api/pick` | 200 with `{"result": ...}` or `{"error": "...", "code": N, "version": V}` (`code`: the language server's JSON-RPC error code, where it gave one: a preview a newer one superseded is -32802, a cancelled one -32800; `version`: the document version whose text failed, where the server named it, so the page drops a failure older than what it shows); every call that reached the server is answered 200, as a JSON-RPC reply is, since a grammar that cannot be previewed is no HTTP failure (browsers log every 4xx answer in the console); 4xx only for a request that is not a call (bad JSON, too large, another origin) |
//! | `POST /api/picture` | `grm/picture`: the preview's model drawn as a PNG (base64 in the JSON), for the page's "Save picture" |
//! | `POST /api/symbols` | `textDocument/documentSymbol` (the page reads the meta-parameters' ranges) |
//! | `POST /api/tree` | `grm/tree`: the last preview's derivation tree, a level at a time (the page's tree panel) |
//! | `POST /api/provenance`, `/api/drag`, `/api/sketch`, `/api/writeParams` | `grm/provenance`, `grm/drag`, ... (direct manipulation): an edit of the grammar is written here (the server answers the edited text to this client, which cannot apply edits) and sent to the server at once, which regrows the live preview; the answer says `written` |
//! | `POST /api/layout`, `/api/layoutEdit`, `/api/layoutCity` | `grm/layout`, `grm/layoutEdit`, `grm/layoutCity`: the layout view of a served `NAME.layout.json`, or of a served grammar's `layout` item (its edits go to the sidecar beside it; the city's buffers as a blob when asked with `binary`) (the server writes the sidecar; `grm/layoutUpdated` becomes the `layoutUpdated` event) |
//! | `POST /api/loadCurves`, `/api/saveCurves` | the curves file next to the grammar (`tree.grm` -> `tree.curves.json`); saved only if `grm-guide` accepts it |
//! | `GET /api/events?after=N[&wait=MS]` | long poll (20 s at most): `{"seq": M, "events": [{"method", "params"}]}` |
//! | `GET /api/blob/ID` | a preview's or a city's buffers asked with `"binary": true` (protocol 3): `application/octet-stream`, the newest previews' kept |
//!
//! Every `POST /api/...` answer carries `Server-Timing: app;dur=MS`: the
//! milliseconds from the request read to the answer ready to write (the
//! page reports it in its edit-to-screen breakdown).
//!
//! Invariants: binds only to the loopback address; refuses requests whose
//! `Host` is not this server (DNS rebinding) and cross-origin POSTs; only
//! the served grammar's curves file can be read or written.

use std::collections::VecDeque;
use std::io::{BufRead, BufReader, Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Condvar, Mutex, MutexGuard, PoisonError};
use std::time::{Duration, Instant, SystemTime};

use futures::StreamExt;
use serde_json::{Value, json};
use tower::{Service, ServiceExt};
use tower_lsp_server::jsonrpc::Request;

use crate::Outcome;

mod http;
use http::*;

static INDEX_HTML: &str = include_str!("../../../editors/preview/dist/index.html");
static PREVIEW_JS: &str = include_str!("../../../editors/preview/dist/preview.js");
static PREVIEW_CSS: &str = include_str!("../../../editors/preview/dist/preview.css");

/// What the page may load and do (every answer carries it): its own
/// script and stylesheet, calls to this server, pictures of its own making
/// (`data:`, `blob:`), and nothing else: no inline or foreign script, no
/// other server, no frame. The VS Code webview's policy is as strict
/// (`editors/vscode/src/webviewHtml.ts`). `frame-ancestors` works only as a
/// header, so the page's `<meta>` copy leaves it out.
const CSP: &str = "default-src 'none'; script-src 'self'; style-src 'self' 'unsafe-inline'; img-src 'self' data: blob:; connect-src 'self'; base-uri 'none'; form-action 'none'";
const CSP_FRAMES: &str = "frame-ancestors 'none'";

/// The page with its policy in the `<!--CSP-->` slot.
fn index_html() -> &'static str {
    static HTML: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    HTML.get_or_init(|| {
        INDEX_HTML.replace(
            "<!--CSP-->",
            &format!("<meta http-equiv=\"Content-Security-Policy\" content=\"{CSP}\">"),
        )
    })
}

/// Largest request body accepted (curves files and preview parameters are small).
const MAX_BODY: usize = 16 << 20;
/// Largest request head (request line and headers).
const MAX_HEAD: usize = 16 << 10;
/// How long an events request waits for something to happen.
const POLL_WAIT: Duration = Duration::from_secs(20);
/// How often the file is checked for changes: two `stat` calls, cheap
/// enough to take at most 50 ms (25 on average) of a save's way to the
/// screen (150 ms took 75 on average).
const WATCH_EVERY: Duration = Duration::from_millis(50);
/// Events kept for pollers that fell behind.
const EVENT_LOG: usize = 64;

#[derive(clap::Args, Debug)]
pub struct ViewArgs {
    /// The .grm file to preview (or a NAME.layout.json: the layout view).
    pub file: PathBuf,
    /// Port on 127.0.0.1 (0: a free one, printed).
    #[arg(long, default_value_t = 0)]
    pub port: u16,
    /// Sample mode: the preview's search time budget in milliseconds
    /// (default 5000; a search stopped by it says so, and its model depends
    /// on the machine's speed). For slow machines, and for tests that
    /// compare models.
    #[arg(long, value_name = "MS", value_parser = clap::value_parser!(u64).range(1..=600_000))]
    pub budget_ms: Option<u64>,
}

pub fn run(args: ViewArgs) -> Outcome {
    let path = match std::fs::canonicalize(&args.file) {
        Ok(p) if p.is_file() => grm_sema::normalize(&p),
        Ok(p) => {
            eprintln!("error: {} is not a file", p.display());
            return Outcome::Usage;
        }
        Err(e) => {
            eprintln!("error: cannot read {}: {e}", args.file.display());
            return Outcome::Usage;
        }
    };
    let listener = match TcpListener::bind(("127.0.0.1", args.port)) {
        Ok(l) => l,
        Err(e) => {
            eprintln!("error: cannot listen on 127.0.0.1:{}: {e}", args.port);
            return Outcome::Usage;
        }
    };
    let server = match Server::start(&path, listener, args.budget_ms) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("error: {e}");
            return Outcome::Usage;
        }
    };
    outln!(
        "grmc view: http://{}/ previews {} (Ctrl-C to stop)",
        server.addr,
        path.display()
    );
    let _ = std::io::stdout().flush();
    server.wait();
    Outcome::Ok
}

// ------------------------------------------------------------------ events

/// Notifications for the page, numbered from 1.
#[derive(Default)]
struct Events {
    seq: u64,
    log: VecDeque<(u64, Value)>,
    /// The `document` event: given to every new poller (`after=0`), however
    /// many events came since.
    document: Option<Value>,
}

struct EventQueue {
    events: Mutex<Events>,
    changed: Condvar,
}

impl EventQueue {
    fn lock(&self) -> MutexGuard<'_, Events> {
        self.events.lock().unwrap_or_else(PoisonError::into_inner)
    }

    fn push(&self, method: &str, params: Value) {
        let mut e = self.lock();
        e.seq += 1;
        let seq = e.seq;
        let event = json!({ "method": method, "params": params });
        if method == "document" {
            e.document = Some(event);
        } else {
            e.log.push_back((seq, event));
            while e.log.len() > EVENT_LOG {
                e.log.pop_front();
            }
        }
        self.changed.notify_all();
    }

    /// The events after `after`, waiting up to `wait` for one. A new
    /// poller (`after` 0) gets the document event first; one that fell
    /// behind the log gets what is left of it.
    fn after(&self, after: u64, wait: Duration) -> Value {
        let deadline = Instant::now() + wait;
        let mut e = self.lock();
        while e.seq <= after {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                break;
            }
            e = self
                .changed
                .wait_timeout(e, left)
                .unwrap_or_else(PoisonError::into_inner)
                .0;
        }
        let document = e.document.iter().filter(|_| after == 0);
        let events: Vec<Value> = document
            .chain(e.log.iter().filter(|(s, _)| *s > after).map(|(_, v)| v))
            .cloned()
            .collect();
        json!({ "seq": e.seq, "events": events })
    }
}

// ------------------------------------------------------------------ the in-process language server

/// A failed API request: the message for the page, and the language
/// server's JSON-RPC error code when it answered with one, with the
/// document version a failed `grm/preview` names (its `data.version`).
#[derive(Debug)]
struct ApiError {
    message: String,
    code: Option<i64>,
    version: Option<u64>,
}

impl From<String> for ApiError {
    fn from(message: String) -> ApiError {
        ApiError {
            message,
            code: None,
            version: None,
        }
    }
}

impl From<&str> for ApiError {
    fn from(message: &str) -> ApiError {
        ApiError::from(message.to_string())
    }
}

type Reply = std::sync::mpsc::SyncSender<Option<tower_lsp_server::jsonrpc::Response>>;

/// Requests and notifications for the language server, answered by a task
/// that owns the service (one `call` at a time, answers concurrently).
struct Lsp {
    tx: tokio::sync::mpsc::UnboundedSender<(Request, Option<Reply>)>,
    next_id: Mutex<i64>,
}

impl Lsp {
    fn start(
        rt: &tokio::runtime::Runtime,
        events: Arc<EventQueue>,
        uri: Value,
        blobs: Arc<grm_lsp::blob::BlobStore>,
    ) -> Lsp {
        // A preview asked with `binary` (protocol 3) leaves its buffers in
        // `blobs`, served as `GET /api/blob/ID`.
        let (service, socket) = grm_lsp::service_with_blobs(grm_lsp::Config::default(), blobs);
        let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel::<(Request, Option<Reply>)>();
        rt.spawn(async move {
            let mut service = service;
            while let Some((req, reply)) = rx.recv().await {
                let Ok(svc) = service.ready().await else {
                    break;
                };
                let fut = svc.call(req);
                tokio::spawn(async move {
                    let resp = fut.await.ok().flatten();
                    if let Some(reply) = reply {
                        let _ = reply.send(resp);
                    }
                });
            }
        });
        // What the server sends: the live preview goes to the page; the
        // diagnostics are the editor's business (the preview reports errors).
        rt.spawn(async move {
            let mut socket = socket;
            while let Some(msg) = socket.next().await {
                if msg.method() == "grm/previewUpdated"
                    && let Some(p) = msg.params()
                    && p.get("uri") == Some(&uri)
                {
                    events.push("previewUpdated", p.clone());
                }
                // A layout file served (docs/layout.md, "In the editor"):
                // it changed, the page asks for its layout again.
                if msg.method() == "grm/layoutUpdated"
                    && let Some(p) = msg.params()
                    && p.get("uri") == Some(&uri)
                {
                    events.push("layoutUpdated", p.clone());
                }
            }
        });
        Lsp {
            tx,
            next_id: Mutex::new(0),
        }
    }

    /// A request; `Err` is the error for the page. Called from many
    /// threads at once: each waits for its own answer only.
    fn request(&self, method: &str, params: Value) -> Result<Value, ApiError> {
        let id = {
            let mut n = self.next_id.lock().unwrap_or_else(PoisonError::into_inner);
            *n += 1;
            *n
        };
        let req = Request::build(method.to_string())
            .id(id)
            .params(params)
            .finish();
        let (reply, answer) = std::sync::mpsc::sync_channel(1);
        self.tx
            .send((req, Some(reply)))
            .map_err(|_| "the language server stopped".to_string())?;
        let resp = answer
            .recv()
            .map_err(|_| "the language server stopped".to_string())?
            .ok_or_else(|| format!("{method}: no answer"))?;
        let (_, body) = resp.into_parts();
        body.map_err(|e| ApiError {
            message: e.message.to_string(),
            code: Some(e.code.code()),
            version: e.data.as_ref().and_then(|d| d["version"].as_u64()),
        })
    }

    fn notify(&self, method: &str, params: Value) {
        let req = Request::build(method.to_string()).params(params).finish();
        let _ = self.tx.send((req, None));
    }
}

// ------------------------------------------------------------------ the server

/// What the handlers share.
struct State {
    path: PathBuf,
    uri: String,
    curves_path: PathBuf,
    lsp: Lsp,
    /// Previews' blobs (protocol 3), for `GET /api/blob/ID`.
    blobs: Arc<grm_lsp::blob::BlobStore>,
    events: Arc<EventQueue>,
    /// The file as last sent to the server: (modified, length, version).
    seen: Mutex<(Option<SystemTime>, u64, i32)>,
    /// The curves file as last seen or written by the page: (modified, length).
    curves_seen: Mutex<(Option<SystemTime>, u64)>,
    /// Where this server listens (the only `Host` it answers).
    addr: SocketAddr,
    /// `--budget-ms`: the `budgetMs` of previews and pictures that name none.
    budget_ms: Option<u64>,
    /// Looks in a row that found the grammar empty (see [`settled`]).
    empty_looks: std::sync::atomic::AtomicU32,
}

/// Looks that must find the grammar empty before it is taken as emptied
/// (200 ms): a file saved in place is empty for a moment, truncated and
/// not yet written (`fs.writeFileSync`, many editors), and a look then
/// would show "the file defines no system" until the next one.
const EMPTY_LOOKS: u32 = 4;

/// Whether a changed grammar's `text` is taken now: any text at once, an
/// empty one only after [`EMPTY_LOOKS`] looks in a row found it empty.
fn settled(text: &str, empty_looks: &std::sync::atomic::AtomicU32) -> bool {
    use std::sync::atomic::Ordering::Relaxed;
    if !text.is_empty() {
        empty_looks.store(0, Relaxed);
        return true;
    }
    if empty_looks.fetch_add(1, Relaxed) + 1 < EMPTY_LOOKS {
        return false;
    }
    empty_looks.store(0, Relaxed);
    true
}

/// A running `grmc view` server.
pub struct Server {
    pub addr: SocketAddr,
    accept: std::thread::JoinHandle<()>,
    _rt: tokio::runtime::Runtime,
}

impl std::fmt::Debug for Server {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Server").field("addr", &self.addr).finish()
    }
}

/// The served grammar's text, read as every grammar file is
/// (`check::read_source`: a regular file, bounded).
fn read_grammar(path: &Path) -> std::io::Result<String> {
    String::from_utf8(crate::check::read_source(path)?).map_err(|_| {
        std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            "it is not valid UTF-8 text",
        )
    })
}

/// `tree.grm` -> `tree.curves.json` beside it (docs/curves.md).
pub fn curves_path_for(grammar: &Path) -> PathBuf {
    grammar.with_extension("curves.json")
}

fn stat(path: &Path) -> (Option<SystemTime>, u64) {
    match std::fs::metadata(path) {
        Ok(m) => (m.modified().ok(), m.len()),
        Err(_) => (None, 0),
    }
}

impl Server {
    /// Open `path` in an in-process language server and serve the page on
    /// `listener`, in background threads; `budget_ms` is the search time
    /// budget of the previews that name none (`--budget-ms`).
    pub fn start(
        path: &Path,
        listener: TcpListener,
        budget_ms: Option<u64>,
    ) -> Result<Server, String> {
        let text =
            read_grammar(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
        let uri = grm_lsp::convert::uri_of(path)
            .ok_or_else(|| format!("{} has no file URI", path.display()))?;
        let uri_json = serde_json::to_value(&uri).map_err(|e| e.to_string())?;
        let uri_str = uri_json.as_str().unwrap_or_default().to_string();
        let addr = listener.local_addr().map_err(|e| e.to_string())?;
        let rt = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .enable_all()
            .build()
            .map_err(|e| format!("cannot start the runtime: {e}"))?;
        let events = Arc::new(EventQueue {
            events: Mutex::new(Events::default()),
            changed: Condvar::new(),
        });
        let blobs = Arc::new(grm_lsp::blob::BlobStore::default());
        let lsp = Lsp::start(&rt, events.clone(), uri_json.clone(), blobs.clone());
        lsp.request("initialize", json!({ "capabilities": {} }))
            .map_err(|e| e.message)?;
        lsp.notify("initialized", json!({}));
        let (modified, len) = stat(path);
        // A layout sidecar is served by the page's layout view.
        let language = if grm_lsp::layout::is_layout_path(path) {
            "json"
        } else {
            "grm"
        };
        lsp.notify(
            "textDocument/didOpen",
            json!({ "textDocument": { "uri": uri_json, "languageId": language, "version": 1, "text": text } }),
        );
        let title = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        events.push("document", json!({ "uri": uri_str, "title": title }));
        let curves_path = curves_path_for(path);
        let state = Arc::new(State {
            path: path.to_path_buf(),
            uri: uri_str,
            curves_seen: Mutex::new(stat(&curves_path)),
            curves_path,
            lsp,
            blobs,
            events,
            seen: Mutex::new((modified, len, 1)),
            addr,
            budget_ms,
            empty_looks: std::sync::atomic::AtomicU32::new(0),
        });
        let watch = state.clone();
        std::thread::spawn(move || {
            loop {
                std::thread::sleep(WATCH_EVERY);
                watch.check_file();
            }
        });
        let accept = std::thread::spawn(move || {
            for stream in listener.incoming().flatten() {
                let st = state.clone();
                std::thread::spawn(move || {
                    let _ = handle(&st, stream);
                });
            }
        });
        Ok(Server {
            addr,
            accept,
            _rt: rt,
        })
    }

    /// Serve until the process is stopped.
    pub fn wait(self) {
        let _ = self.accept.join();
    }
}

impl State {
    /// If the grammar changed on disk, send its text to the server (which
    /// then regrows the live preview and notifies the page); if the curves
    /// file changed (not by the page), tell the page to reload it.
    fn check_file(&self) {
        {
            let mut seen = self
                .curves_seen
                .lock()
                .unwrap_or_else(PoisonError::into_inner);
            // Read under the lock a save holds while it writes: a look taken
            // before a save and compared after it would report the page's
            // own save as a change, twice (the old state, then the new).
            let curves = stat(&self.curves_path);
            if curves != *seen {
                *seen = curves;
                self.events
                    .push("curvesChanged", json!({ "uri": self.uri }));
            }
        }
        let (modified, len) = stat(&self.path);
        let mut seen = self.seen.lock().unwrap_or_else(PoisonError::into_inner);
        if (modified, len) == (seen.0, seen.1) {
            return;
        }
        let Ok(text) = read_grammar(&self.path) else {
            return;
        };
        if !settled(&text, &self.empty_looks) {
            return;
        }
        seen.0 = modified;
        seen.1 = len;
        seen.2 += 1;
        self.lsp.notify(
            "textDocument/didChange",
            json!({
                "textDocument": { "uri": self.uri, "version": seen.2 },
                "contentChanges": [{ "text": text }],
            }),
        );
    }

    /// Write the grammar (through a file beside it, renamed over it) and
    /// send its text to the server at once, which regrows the live
    /// preview: the page's own edit (a drag) is not left for the watcher.
    fn write_grammar(&self, text: &str) -> Result<(), String> {
        let mut seen = self.seen.lock().unwrap_or_else(PoisonError::into_inner);
        let mut tmp = self.path.as_os_str().to_os_string();
        tmp.push(".tmp");
        let tmp = PathBuf::from(tmp);
        std::fs::write(&tmp, text)
            .and_then(|()| std::fs::rename(&tmp, &self.path))
            .map_err(|e| {
                let _ = std::fs::remove_file(&tmp);
                format!("cannot write {}: {e}", self.path.display())
            })?;
        let (modified, len) = stat(&self.path);
        seen.0 = modified;
        seen.1 = len;
        seen.2 += 1;
        self.lsp.notify(
            "textDocument/didChange",
            json!({
                "textDocument": { "uri": self.uri, "version": seen.2 },
                "contentChanges": [{ "text": text }],
            }),
        );
        Ok(())
    }

    /// The document a request is about: only the served one.
    fn check_uri(&self, params: &Value) -> Result<(), String> {
        let uri = params
            .get("textDocument")
            .and_then(|d| d.get("uri"))
            .or_else(|| params.get("uri"))
            .and_then(Value::as_str)
            .ok_or("the request names no document")?;
        if uri == self.uri {
            Ok(())
        } else {
            Err(format!("this server previews {}, not {uri}", self.uri))
        }
    }

    fn api(&self, method: &str, mut params: Value) -> Result<Value, ApiError> {
        self.check_uri(&params)?;
        if let (Some(budget), "preview" | "picture", Some(p)) =
            (self.budget_ms, method, params.as_object_mut())
        {
            p.entry("budgetMs").or_insert(json!(budget));
        }
        match method {
            "preview" => self.lsp.request("grm/preview", params),
            "pick" => self.lsp.request("grm/pick", params),
            "provenance" => self.lsp.request("grm/provenance", params),
            "tree" => self.lsp.request("grm/tree", params),
            // Edits of the grammar: this client cannot apply them, so the
            // server answers the edited text, which is written here.
            "drag" | "sketch" | "writeParams" => {
                let mut out = self.lsp.request(&format!("grm/{method}"), params)?;
                if let Some(text) = out.get("text").and_then(Value::as_str).map(str::to_owned) {
                    self.write_grammar(&text)?;
                    out["applied"] = json!(true);
                    out["written"] = json!(true);
                    if let Some(o) = out.as_object_mut() {
                        o.remove("text");
                    }
                }
                Ok(out)
            }
            // Persistent edits (the page's edit panel): this client declares
            // no workspace.applyEdit, so the server writes the edits file
            // itself and regrows the live preview.
            "edit" | "removeEdit" | "retargetEdit" => {
                self.lsp.request(&format!("grm/{method}"), params)
            }
            "picture" => self.lsp.request("grm/picture", params),
            // The layout view of a `NAME.layout.json` (grm-lsp layout.rs):
            // the server writes the sidecar itself (no workspace.applyEdit).
            "layout" | "layoutEdit" | "layoutCity" => {
                self.lsp.request(&format!("grm/{method}"), params)
            }
            "symbols" => self.lsp.request(
                "textDocument/documentSymbol",
                json!({ "textDocument": { "uri": self.uri } }),
            ),
            "loadCurves" => {
                let text = match grm_diag::input::read_bounded_string(
                    &self.curves_path,
                    grm_guide::MAX_CURVES_BYTES,
                    "a curves file",
                ) {
                    Ok(t) => Value::String(t),
                    Err(e) if e.kind() == std::io::ErrorKind::NotFound => Value::Null,
                    Err(e) => return Err(format!("{}: {e}", self.curves_path.display()).into()),
                };
                Ok(json!({ "path": self.curves_path, "text": text }))
            }
            "saveCurves" => {
                let text = params
                    .get("text")
                    .and_then(Value::as_str)
                    .ok_or("saveCurves: no text")?;
                let name = self
                    .curves_path
                    .file_name()
                    .map(|n| n.to_string_lossy().into_owned())
                    .unwrap_or_default();
                // Never write a file the sampler would refuse.
                grm_guide::Curves::from_json_str(&name, text).map_err(|e| e.to_string())?;
                let tmp = self.curves_path.with_extension("json.tmp");
                // Held while writing, so the watcher does not report the page's own save.
                let mut seen = self
                    .curves_seen
                    .lock()
                    .unwrap_or_else(PoisonError::into_inner);
                std::fs::write(&tmp, text)
                    .and_then(|()| std::fs::rename(&tmp, &self.curves_path))
                    .map_err(|e| {
                        let _ = std::fs::remove_file(&tmp);
                        format!("cannot write {}: {e}", self.curves_path.display())
                    })?;
                *seen = stat(&self.curves_path);
                Ok(json!({ "path": self.curves_path }))
            }
            _ => Err(format!("unknown method {method}").into()),
        }
    }
}

#[cfg(test)]
mod tests;

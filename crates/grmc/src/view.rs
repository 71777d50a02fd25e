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
//! | `POST /api/preview`, `/api/pick` | 200 with `{"result": ...}` or `{"error": "...", "code": N}` (`code`: the language server's JSON-RPC error code, where it gave one: a preview a newer one superseded is -32802, a cancelled one -32800); every call that reached the server is answered 200, as a JSON-RPC reply is, since a grammar that cannot be previewed is no HTTP failure (browsers log every 4xx answer in the console); 4xx only for a request that is not a call (bad JSON, too large, another origin) |
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
/// server's JSON-RPC error code when it answered with one.
#[derive(Debug)]
struct ApiError {
    message: String,
    code: Option<i64>,
}

impl From<String> for ApiError {
    fn from(message: String) -> ApiError {
        ApiError {
            message,
            code: None,
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

// ------------------------------------------------------------------ HTTP

/// A parsed request.
#[derive(Debug, PartialEq, Eq)]
struct HttpRequest {
    method: String,
    target: String,
    headers: Vec<(String, String)>,
    body: Vec<u8>,
}

impl HttpRequest {
    fn header(&self, name: &str) -> Option<&str> {
        self.headers
            .iter()
            .find(|(k, _)| k.eq_ignore_ascii_case(name))
            .map(|(_, v)| v.as_str())
    }

    /// How many times the header `name` comes.
    fn count(&self, name: &str) -> usize {
        self.headers
            .iter()
            .filter(|(k, _)| k.eq_ignore_ascii_case(name))
            .count()
    }
}

/// An HTTP token (a header field name): visible characters but delimiters.
fn is_token(s: &str) -> bool {
    !s.is_empty()
        && s.bytes()
            .all(|b| b.is_ascii_alphanumeric() || b"!#$%&'*+-.^_`|~".contains(&b))
}

/// Read one request: request line, headers, a `Content-Length` body.
fn read_request(r: &mut impl BufRead) -> Result<HttpRequest, (u16, String)> {
    let bad = |m: &str| (400, m.to_string());
    let mut head = 0usize;
    let mut line = String::new();
    let mut read_line = |line: &mut String| -> Result<(), (u16, String)> {
        line.clear();
        let n = r
            .by_ref()
            .take((MAX_HEAD - head.min(MAX_HEAD)) as u64 + 1)
            .read_line(line)
            .map_err(|e| (400, e.to_string()))?;
        head += n;
        if head > MAX_HEAD {
            return Err((431, "request head too large".into()));
        }
        if n == 0 {
            return Err(bad("connection closed"));
        }
        Ok(())
    };
    read_line(&mut line)?;
    let mut parts = line.split_whitespace();
    let (Some(method), Some(target), Some(version)) = (parts.next(), parts.next(), parts.next())
    else {
        return Err(bad("malformed request line"));
    };
    if !version.starts_with("HTTP/1.") {
        return Err((505, "HTTP/1.x only".into()));
    }
    let (method, target) = (method.to_string(), target.to_string());
    let mut headers = Vec::new();
    loop {
        read_line(&mut line)?;
        let l = line.trim_end_matches(['\r', '\n']);
        if l.is_empty() {
            break;
        }
        let (k, v) = l.split_once(':').ok_or_else(|| bad("malformed header"))?;
        // A field name is a token: no space before the colon, no folded
        // continuation line (RFC 9112 5.1, 5.2: a server must refuse them;
        // a proxy in front could read them otherwise).
        if !is_token(k) {
            return Err(bad("malformed header name"));
        }
        headers.push((k.to_string(), v.trim().to_string()));
    }
    let mut req = HttpRequest {
        method,
        target,
        headers,
        body: Vec::new(),
    };
    // One Host, one Content-Length, at most one Transfer-Encoding: two (the
    // same or not) are how requests are smuggled past a proxy, and which
    // one counts is ambiguous (RFC 9112 3.2, 6.3).
    for name in ["host", "content-length", "transfer-encoding"] {
        if req.count(name) > 1 {
            return Err(bad(&format!("more than one {name} header")));
        }
    }
    if req
        .header("transfer-encoding")
        .is_some_and(|t| !t.eq_ignore_ascii_case("identity"))
    {
        return Err((411, "send a Content-Length".into()));
    }
    if let Some(len) = req.header("content-length") {
        // Digits only (`+5`, `5, 5` and ` ` are not lengths).
        if len.is_empty() || !len.bytes().all(|b| b.is_ascii_digit()) {
            return Err(bad("bad Content-Length"));
        }
        let len: usize = len.parse().map_err(|_| bad("bad Content-Length"))?;
        if len > MAX_BODY {
            return Err((413, "request body too large".into()));
        }
        req.body = vec![0; len];
        r.read_exact(&mut req.body)
            .map_err(|e| (400, e.to_string()))?;
    }
    Ok(req)
}

fn respond(
    w: &mut impl Write,
    status: u16,
    content_type: &str,
    body: &[u8],
) -> std::io::Result<()> {
    respond_with(w, status, content_type, body, "")
}

/// An answer with `extra` headers (each line ending in CRLF).
fn respond_with(
    w: &mut impl Write,
    status: u16,
    content_type: &str,
    body: &[u8],
    extra: &str,
) -> std::io::Result<()> {
    let reason = match status {
        200 => "OK",
        400 => "Bad Request",
        403 => "Forbidden",
        404 => "Not Found",
        405 => "Method Not Allowed",
        411 => "Length Required",
        413 => "Payload Too Large",
        431 => "Request Header Fields Too Large",
        _ => "Error",
    };
    // One write for head and body: small writes on a socket would wait for
    // the client's delayed ACK (Nagle), about 40 ms each.
    let mut out = format!(
        "HTTP/1.1 {status} {reason}\r\nContent-Type: {content_type}\r\nContent-Length: {}\r\nCache-Control: no-store\r\nX-Content-Type-Options: nosniff\r\nContent-Security-Policy: {CSP}; {CSP_FRAMES}\r\n{extra}Connection: close\r\n\r\n",
        body.len()
    )
    .into_bytes();
    out.extend_from_slice(body);
    w.write_all(&out)?;
    w.flush()
}

/// A preview's blob (protocol 3) as `application/octet-stream`.
fn respond_blob(w: &mut impl Write, blob: &grm_lsp::blob::Blob) -> std::io::Result<()> {
    let head = format!(
        "HTTP/1.1 200 OK\r\nContent-Type: application/octet-stream\r\nContent-Length: {}\r\nCache-Control: no-store\r\nX-Content-Type-Options: nosniff\r\nContent-Security-Policy: {CSP}; {CSP_FRAMES}\r\nConnection: close\r\n\r\n",
        blob.len()
    );
    // One buffer: small writes would wait for the client's delayed ACK.
    let mut out = Vec::with_capacity(head.len() + blob.len());
    out.extend_from_slice(head.as_bytes());
    for c in &blob.chunks {
        out.extend_from_slice(c);
    }
    w.write_all(&out)?;
    w.flush()
}

fn respond_json(w: &mut impl Write, status: u16, v: &Value) -> std::io::Result<()> {
    respond(w, status, "application/json", v.to_string().as_bytes())
}

/// `Host` must name this server: a page from elsewhere that resolves its
/// own name to 127.0.0.1 (DNS rebinding) is refused.
fn host_ok(req: &HttpRequest, addr: SocketAddr) -> bool {
    let port = addr.port();
    req.header("host")
        .is_some_and(|h| h == format!("127.0.0.1:{port}") || h == format!("localhost:{port}"))
}

/// A POST from a page of another origin is refused (no CORS).
fn origin_ok(req: &HttpRequest, addr: SocketAddr) -> bool {
    let port = addr.port();
    req.header("origin").is_none_or(|o| {
        o == format!("http://127.0.0.1:{port}") || o == format!("http://localhost:{port}")
    })
}

fn handle(st: &State, stream: TcpStream) -> std::io::Result<()> {
    // A client that connects and says nothing does not hold a thread forever.
    stream.set_read_timeout(Some(Duration::from_secs(30)))?;
    stream.set_nodelay(true)?;
    let mut reader = BufReader::new(stream.try_clone()?);
    let mut w = stream;
    let req = match read_request(&mut reader) {
        Ok(r) => r,
        Err((status, msg)) => return respond_json(&mut w, status, &json!({ "error": msg })),
    };
    if !host_ok(&req, st.addr) {
        return respond_json(&mut w, 403, &json!({ "error": "wrong Host" }));
    }
    let (path, query) = req
        .target
        .split_once('?')
        .unwrap_or((req.target.as_str(), ""));
    match (req.method.as_str(), path) {
        ("GET", "/" | "/index.html") => respond(
            &mut w,
            200,
            "text/html; charset=utf-8",
            index_html().as_bytes(),
        ),
        ("GET", "/preview.js") => respond(
            &mut w,
            200,
            "text/javascript; charset=utf-8",
            PREVIEW_JS.as_bytes(),
        ),
        ("GET", "/preview.css") => respond(
            &mut w,
            200,
            "text/css; charset=utf-8",
            PREVIEW_CSS.as_bytes(),
        ),
        ("GET", "/api/events") => {
            let arg = |name: &str| -> Option<u64> {
                query
                    .split('&')
                    .find_map(|kv| kv.strip_prefix(name)?.strip_prefix('='))
                    .and_then(|v| v.parse().ok())
            };
            let wait = arg("wait").map_or(POLL_WAIT, |ms| Duration::from_millis(ms).min(POLL_WAIT));
            respond_json(
                &mut w,
                200,
                &st.events.after(arg("after").unwrap_or(0), wait),
            )
        }
        ("GET", p) if p.starts_with("/api/blob/") => {
            match p["/api/blob/".len()..]
                .parse()
                .ok()
                .and_then(|id| st.blobs.get(id))
            {
                Some(blob) => respond_blob(&mut w, &blob),
                None => respond_json(
                    &mut w,
                    404,
                    &json!({ "error": "no such blob (kept: the newest previews')" }),
                ),
            }
        }
        ("POST", p) if p.starts_with("/api/") => {
            if !origin_ok(&req, st.addr) {
                return respond_json(&mut w, 403, &json!({ "error": "cross-origin request" }));
            }
            let params: Value = match serde_json::from_slice(&req.body) {
                Ok(v) => v,
                Err(e) => {
                    return respond_json(
                        &mut w,
                        400,
                        &json!({ "error": format!("invalid JSON: {e}") }),
                    );
                }
            };
            let started = Instant::now();
            // A call the request reached is answered 200 whatever its
            // outcome, like a JSON-RPC reply: a grammar that cannot be
            // previewed is the page's everyday state, not an HTTP failure
            // (browsers log every 4xx answer in the console).
            let answer = match st.api(&p["/api/".len()..], params) {
                Ok(result) => json!({ "result": result }),
                Err(ApiError {
                    message,
                    code: Some(code),
                }) => json!({ "error": message, "code": code }),
                Err(ApiError {
                    message,
                    code: None,
                }) => json!({ "error": message }),
            };
            let status = 200;
            let body = answer.to_string();
            let timing = format!(
                "Server-Timing: app;dur={:.2}\r\n",
                started.elapsed().as_secs_f64() * 1e3
            );
            respond_with(&mut w, status, "application/json", body.as_bytes(), &timing)
        }
        ("GET" | "POST", _) => respond_json(&mut w, 404, &json!({ "error": "not found" })),
        _ => respond_json(&mut w, 405, &json!({ "error": "GET or POST" })),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A classic grammar small enough for every request.
    const KOCH: &str = "system Koch {\n    iterations = 2;\n    angle = 90;\n    width = 0.1;\n    axiom F - F - F - F;\n    F -> F - F + F + F F - F - F + F;\n}\n";

    /// `text` written to `name` in a fresh folder (which lives as long as
    /// the first value) and a server started on it; the grammar's path as
    /// the server names it.
    fn serve(name: &str, text: &str) -> (tempfile::TempDir, PathBuf, Server) {
        let dir = tempfile::tempdir().expect("tempdir");
        let grammar = dir.path().join(name);
        std::fs::write(&grammar, text).expect("write");
        let grammar = grm_sema::normalize(&std::fs::canonicalize(&grammar).expect("canonical"));
        let listener = TcpListener::bind("127.0.0.1:0").expect("bind");
        let server = Server::start(&grammar, listener, None).expect("start");
        (dir, grammar, server)
    }

    fn parse(raw: &str) -> Result<HttpRequest, (u16, String)> {
        read_request(&mut BufReader::new(raw.as_bytes()))
    }

    #[test]
    fn requests_are_parsed_with_their_body() {
        let r = parse(
            "POST /api/pick HTTP/1.1\r\nHost: 127.0.0.1:9\r\nContent-Length: 4\r\n\r\n{}\r\nextra",
        )
        .expect("parses");
        assert_eq!(r.method, "POST");
        assert_eq!(r.target, "/api/pick");
        assert_eq!(r.header("HOST"), Some("127.0.0.1:9"));
        assert_eq!(r.body, b"{}\r\n");
    }

    #[test]
    fn malformed_and_oversized_requests_are_refused() {
        assert_eq!(parse("GARBAGE\r\n\r\n").unwrap_err().0, 400);
        assert_eq!(parse("GET / HTTP/2\r\n\r\n").unwrap_err().0, 505);
        assert_eq!(
            parse("GET / HTTP/1.1\r\nNoColon\r\n\r\n").unwrap_err().0,
            400
        );
        let big = format!(
            "POST / HTTP/1.1\r\nContent-Length: {}\r\n\r\n",
            MAX_BODY + 1
        );
        assert_eq!(parse(&big).unwrap_err().0, 413);
        let long = format!("GET / HTTP/1.1\r\nX: {}\r\n\r\n", "a".repeat(MAX_HEAD));
        assert_eq!(parse(&long).unwrap_err().0, 431);
        assert_eq!(
            parse("POST / HTTP/1.1\r\nTransfer-Encoding: chunked\r\n\r\n")
                .unwrap_err()
                .0,
            411
        );
        assert_eq!(
            parse("POST / HTTP/1.1\r\nContent-Length: 10\r\n\r\nshort")
                .unwrap_err()
                .0,
            400
        );
    }

    #[test]
    fn duplicate_conflicting_and_malformed_framing_headers_are_refused() {
        let req = |headers: &str| format!("POST /api/pick HTTP/1.1\r\n{headers}\r\n{{}}\r\n");
        let ok = "Host: 127.0.0.1:9\r\nContent-Length: 2\r\n";
        assert_eq!(parse(&req(ok)).expect("one of each").body, b"{}");
        for bad in [
            // Two Hosts: which one was checked against DNS rebinding?
            "Host: 127.0.0.1:9\r\nHost: evil.example\r\nContent-Length: 2\r\n",
            "Host: 127.0.0.1:9\r\nhost: 127.0.0.1:9\r\nContent-Length: 2\r\n",
            // Two lengths, conflicting or not: where does the next request begin?
            "Host: 127.0.0.1:9\r\nContent-Length: 2\r\nContent-Length: 4\r\n",
            "Host: 127.0.0.1:9\r\nContent-Length: 2\r\nContent-Length: 2\r\n",
            "Host: 127.0.0.1:9\r\nContent-Length: 2, 2\r\n",
            "Host: 127.0.0.1:9\r\nContent-Length: +2\r\n",
            "Host: 127.0.0.1:9\r\nContent-Length: \r\n",
            "Host: 127.0.0.1:9\r\nTransfer-Encoding: identity\r\nTransfer-Encoding: identity\r\nContent-Length: 2\r\n",
            // A space before the colon, a folded line.
            "Host : 127.0.0.1:9\r\nContent-Length: 2\r\n",
            "Host: 127.0.0.1:9\r\nContent-Length: 2\r\nX-A: 1\r\n  folded\r\n",
        ] {
            assert_eq!(
                parse(&req(bad)).map(|r| r.headers).unwrap_err().0,
                400,
                "{bad:?}"
            );
        }
    }

    #[test]
    fn host_and_origin_must_be_this_server() {
        let addr: SocketAddr = "127.0.0.1:4321".parse().expect("addr");
        let req = |h: &[(&str, &str)]| HttpRequest {
            method: "POST".into(),
            target: "/".into(),
            headers: h
                .iter()
                .map(|(k, v)| (k.to_string(), v.to_string()))
                .collect(),
            body: vec![],
        };
        assert!(host_ok(&req(&[("Host", "127.0.0.1:4321")]), addr));
        assert!(host_ok(&req(&[("host", "localhost:4321")]), addr));
        assert!(!host_ok(&req(&[("Host", "evil.example:4321")]), addr));
        assert!(!host_ok(&req(&[]), addr));
        assert!(origin_ok(&req(&[]), addr));
        assert!(origin_ok(
            &req(&[("Origin", "http://127.0.0.1:4321")]),
            addr
        ));
        assert!(!origin_ok(&req(&[("Origin", "http://evil.example")]), addr));
    }

    #[test]
    fn events_wait_and_report_what_came_after() {
        let q = EventQueue {
            events: Mutex::new(Events::default()),
            changed: Condvar::new(),
        };
        q.push("document", json!({ "uri": "u" }));
        let first = q.after(0, Duration::ZERO);
        assert_eq!(first["seq"], 1);
        assert_eq!(first["events"][0]["method"], "document");
        // Nothing new: an empty answer after the wait.
        let t = Instant::now();
        let none = q.after(1, Duration::from_millis(50));
        assert!(t.elapsed() >= Duration::from_millis(50));
        assert_eq!(none["events"].as_array().map(Vec::len), Some(0));
        for i in 0..(EVENT_LOG + 10) {
            q.push("previewUpdated", json!({ "n": i }));
        }
        let behind = q.after(1, Duration::ZERO);
        assert_eq!(behind["events"].as_array().map(Vec::len), Some(EVENT_LOG));
        assert_eq!(behind["seq"], (EVENT_LOG + 11) as u64);
        assert_eq!(behind["events"][0]["params"]["n"], 10);
        // A page opened late still learns its document first.
        let late = q.after(0, Duration::ZERO);
        assert_eq!(late["events"][0]["method"], "document");
        assert_eq!(late["events"].as_array().map(Vec::len), Some(EVENT_LOG + 1));
    }

    #[test]
    fn an_empty_grammar_is_taken_only_once_it_stays_empty() {
        let looks = std::sync::atomic::AtomicU32::new(0);
        // Saved in place: truncated (one look finds it empty), then written.
        assert!(!settled("", &looks));
        assert!(settled("system A { axiom F; }", &looks));
        // Emptied for good: taken at the fourth look in a row, once.
        assert_eq!(
            (0..EMPTY_LOOKS)
                .map(|_| settled("", &looks))
                .collect::<Vec<_>>(),
            [false, false, false, true]
        );
        assert!(settled("x", &looks));
        assert!(!settled("", &looks), "counted afresh");
    }

    #[test]
    fn the_curves_file_is_named_after_the_grammar() {
        assert_eq!(
            curves_path_for(Path::new("/a/calder_tree.grm")),
            PathBuf::from("/a/calder_tree.curves.json")
        );
    }

    /// One HTTP exchange with a running server: the answer's head and body.
    fn exchange_raw(addr: SocketAddr, raw: &str) -> (String, String) {
        let mut s = TcpStream::connect(addr).expect("connect");
        s.write_all(raw.as_bytes()).expect("send");
        let mut out = String::new();
        s.read_to_string(&mut out).expect("read");
        let (head, body) = out.split_once("\r\n\r\n").unwrap_or((out.as_str(), ""));
        (head.to_string(), body.to_string())
    }

    /// One HTTP exchange with a running server.
    fn exchange(addr: SocketAddr, raw: &str) -> (u16, Value) {
        let (head, body) = exchange_raw(addr, raw);
        let status = head[9..12].parse().expect("status");
        (
            status,
            serde_json::from_str(&body).unwrap_or(Value::String(body)),
        )
    }

    fn post(addr: SocketAddr, path: &str, body: &Value) -> (u16, Value) {
        let b = body.to_string();
        exchange(
            addr,
            &format!(
                "POST {path} HTTP/1.1\r\nHost: {addr}\r\nContent-Type: application/json\r\nContent-Length: {}\r\n\r\n{b}",
                b.len()
            ),
        )
    }

    /// A server for a sample grammar of a hundred thousand generations
    /// (minutes, unless a budget or a newer request stops it), its
    /// document's URI and one guiding curve; the folder lives as long as
    /// the first value.
    fn endless_server() -> (tempfile::TempDir, Server, Value, Value) {
        let (dir, _, server) = serve(
            "endless.grm",
            "system Endless {\n    mode = sample;\n    generations = 100000;\n    particles_start = 8;\n    particles_end = 4;\n    axiom branch;\n    skeleton branch, maybe;\n    geometry tip;\n    branch -> roty(uniform(0, 360)) rotz(uniform(0, 40)) F(1) maybe;\n    maybe -> (3) branch;\n    maybe -> (1) tip;\n    wrapup branch -> tip;\n    wrapup maybe -> tip;\n    tip -> sphere(0.1);\n}\n",
        );
        let addr = server.addr;
        let (_, ev) = exchange(
            addr,
            &format!("GET /api/events?after=0 HTTP/1.1\r\nHost: {addr}\r\n\r\n"),
        );
        let uri = ev["events"][0]["params"]["uri"].clone();
        let curves = json!({ "version": 1, "curves": [{ "points": [[0,0,0],[0,1.3,0],[0,2.7,0],[0,4,0]] }] });
        (dir, server, uri, curves)
    }

    /// Two overlapping previews of one document: the second is not queued
    /// behind the first, supersedes it, and the first is answered at once
    /// with the server's ServerCancelled code.
    #[test]
    fn a_newer_preview_supersedes_the_one_in_flight() {
        let (_dir, server, uri, curves) = endless_server();
        let addr = server.addr;
        let req = |budget: u64| json!({ "textDocument": { "uri": uri }, "curves": curves, "live": true, "budgetMs": budget });
        let first_req = req(60_000);
        let first = std::thread::spawn(move || {
            let r = post(addr, "/api/preview", &first_req);
            (r, Instant::now())
        });
        std::thread::sleep(Duration::from_millis(300));
        assert!(!first.is_finished(), "the first preview is being built");
        let t = Instant::now();
        let (status, second) = post(addr, "/api/preview", &req(20));
        assert_eq!(status, 200, "{second}");
        assert_eq!(second["result"]["sample"]["stoppedEarly"], true);
        let ((status, e), answered) = first.join().expect("first");
        // Not a failure (no 4xx for the browser to log), but no model.
        assert_eq!(status, 200, "{e}");
        assert_eq!(e.get("result"), None, "{e}");
        assert_eq!(e["code"], -32802, "{e}");
        assert!(
            e["error"]
                .as_str()
                .is_some_and(|m| m.contains("superseded")),
            "{e}"
        );
        assert!(
            answered.duration_since(t) < Duration::from_secs(5),
            "the superseded preview was answered {:?} after the newer one was sent",
            answered.duration_since(t)
        );
    }

    /// The page's older request reaching the server after its newer one
    /// (two connections, two threads): answered superseded at once, and
    /// the newer one is not stopped.
    #[test]
    fn a_pages_older_preview_arriving_late_supersedes_nothing() {
        let (_dir, server, uri, curves) = endless_server();
        let addr = server.addr;
        let req = |order: u64, budget: u64| json!({ "textDocument": { "uri": uri }, "curves": curves, "live": true, "client": "page", "order": order, "budgetMs": budget });
        let newer_req = req(2, 1500);
        let newer = std::thread::spawn(move || post(addr, "/api/preview", &newer_req));
        std::thread::sleep(Duration::from_millis(300));
        assert!(!newer.is_finished(), "the newer preview is being built");
        let t = Instant::now();
        let (status, older) = post(addr, "/api/preview", &req(1, 60_000));
        assert_eq!(status, 200, "{older}");
        assert_eq!(older["code"], -32802, "{older}");
        assert!(t.elapsed() < Duration::from_secs(5), "{:?}", t.elapsed());
        let (status, newer) = newer.join().expect("newer");
        assert_eq!(status, 200, "{newer}");
        // Not stopped by the older request: a model, built until its
        // search ended or its own budget stopped it (which of the two
        // depends on the machine's speed, not on the older request).
        assert!(newer.get("code").is_none(), "{newer}");
        let sample = &newer["result"]["sample"];
        assert!(sample.is_object(), "{newer}");
        if sample["stoppedEarly"] == true {
            let ms = newer["result"]["stats"]["deriveMs"]
                .as_f64()
                .expect("deriveMs");
            assert!(
                ms >= 1400.0,
                "stopped after {ms} ms, before its budget: {newer}"
            );
        }
    }

    #[test]
    fn serves_the_page_and_the_language_servers_preview() {
        let (_dir, grammar, server) = serve("koch.grm", KOCH);
        let addr = server.addr;

        let (status, page) = exchange(addr, &format!("GET / HTTP/1.1\r\nHost: {addr}\r\n\r\n"));
        assert_eq!(status, 200);
        assert!(page.as_str().is_some_and(|p| p.contains("preview.js")));
        let (status, _) = exchange(addr, "GET / HTTP/1.1\r\nHost: evil.example\r\n\r\n");
        assert_eq!(status, 403);
        // A second Host after this server's own is no way in.
        let (status, _) = exchange(
            addr,
            &format!("GET / HTTP/1.1\r\nHost: {addr}\r\nHost: evil.example\r\n\r\n"),
        );
        assert_eq!(status, 400);
        // The page comes with its content security policy, in the header and in its slot.
        let (head, html) = exchange_raw(addr, &format!("GET / HTTP/1.1\r\nHost: {addr}\r\n\r\n"));
        assert!(
            head.contains(&format!(
                "\r\nContent-Security-Policy: {CSP}; frame-ancestors 'none'\r\n"
            )),
            "{head}"
        );
        assert!(!html.contains("<!--CSP-->"), "the placeholder is left in");
        assert!(
            html.contains(&format!(
                "<meta http-equiv=\"Content-Security-Policy\" content=\"{CSP}\">"
            )),
            "{html}"
        );
        assert!(CSP.contains("script-src 'self';") && !CSP.contains("unsafe-eval"));

        // The document event names the URI the page must use.
        let (_, ev) = exchange(
            addr,
            &format!("GET /api/events?after=0 HTTP/1.1\r\nHost: {addr}\r\n\r\n"),
        );
        assert_eq!(ev["events"][0]["method"], "document");
        let uri = ev["events"][0]["params"]["uri"].clone();

        let (status, r) = post(
            addr,
            "/api/preview",
            &json!({ "textDocument": { "uri": uri }, "live": true }),
        );
        assert_eq!(status, 200, "{r}");
        let result = &r["result"];
        assert_eq!(result["system"], "Koch");
        assert_eq!(result["encoding"], "base64-le");
        // Koch island, 2 iterations: 4 * 8^2 = 256 segments, one bone each.
        assert_eq!(result["skeleton"]["boneCount"], 256);
        assert!(result["stats"]["triangles"].as_u64().is_some_and(|t| t > 0));

        // API answers say how long the server took (Server-Timing).
        let body = json!({ "textDocument": { "uri": uri }, "live": true }).to_string();
        let (head, _) = exchange_raw(
            addr,
            &format!(
                "POST /api/preview HTTP/1.1\r\nHost: {addr}\r\nContent-Length: {}\r\n\r\n{body}",
                body.len()
            ),
        );
        let dur: f64 = head
            .lines()
            .find_map(|l| l.strip_prefix("Server-Timing: app;dur="))
            .and_then(|d| d.parse().ok())
            .unwrap_or_else(|| panic!("no Server-Timing in {head}"));
        assert!(dur.is_finite() && dur >= 0.0, "{head}");
        let (page_head, _) = exchange_raw(addr, &format!("GET / HTTP/1.1\r\nHost: {addr}\r\n\r\n"));
        assert!(!page_head.contains("Server-Timing"), "{page_head}");

        let (status, p) = post(
            addr,
            "/api/pick",
            &json!({ "textDocument": { "uri": uri }, "bone": 0 }),
        );
        assert_eq!(status, 200, "{p}");
        assert_eq!(p["result"]["symbol"], "F");

        // The page's "Save picture": the same model, drawn as a PNG.
        let (status, p) = post(
            addr,
            "/api/picture",
            &json!({ "textDocument": { "uri": uri }, "width": 64, "height": 48 }),
        );
        assert_eq!(status, 200, "{p}");
        assert_eq!(
            (
                p["result"]["width"].as_u64(),
                p["result"]["height"].as_u64()
            ),
            (Some(64), Some(48))
        );
        assert_eq!(p["result"]["bones"], 256);
        let png = base64::Engine::decode(
            &base64::engine::general_purpose::STANDARD,
            p["result"]["png"].as_str().expect("png"),
        )
        .expect("base64");
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");

        let (status, e) = post(
            addr,
            "/api/preview",
            &json!({ "textDocument": { "uri": "file:///etc/passwd" } }),
        );
        assert_eq!(status, 200);
        assert!(
            e["error"]
                .as_str()
                .is_some_and(|m| m.contains("not file:///etc/passwd"))
        );

        // Curves: none yet; an invalid file is refused, a valid one written.
        let (_, c) = post(addr, "/api/loadCurves", &json!({ "uri": uri }));
        assert_eq!(c["result"]["text"], Value::Null);
        let (status, e) = post(
            addr,
            "/api/saveCurves",
            &json!({ "uri": uri, "text": "{\"version\": 1, \"curves\": []}" }),
        );
        assert_eq!(status, 200, "{e}");
        assert!(e["error"].is_string(), "{e}");
        assert!(!curves_path_for(&grammar).exists());
        let curves =
            "{\"version\": 1, \"curves\": [{\"points\": [[0,0,0],[0,1,0],[0,2,0],[0,3,0]]}]}";
        let (status, _) = post(
            addr,
            "/api/saveCurves",
            &json!({ "uri": uri, "text": curves }),
        );
        assert_eq!(status, 200);
        assert_eq!(
            std::fs::read_to_string(curves_path_for(&grammar))
                .ok()
                .as_deref(),
            Some(curves)
        );

        // The page's own save is not a change to report; a write by someone else is.
        std::thread::sleep(WATCH_EVERY * 3);
        let (_, quiet) = exchange(
            addr,
            &format!("GET /api/events?after=1&wait=0 HTTP/1.1\r\nHost: {addr}\r\n\r\n"),
        );
        assert!(
            !quiet["events"]
                .as_array()
                .is_some_and(|es| es.iter().any(|e| e["method"] == "curvesChanged")),
            "{quiet}"
        );
        let mut after = quiet["seq"].as_u64().unwrap_or(1);
        std::fs::write(
            curves_path_for(&grammar),
            curves.replace("[0,3,0]", "[0,4,0]"),
        )
        .expect("write curves");
        let deadline = Instant::now() + Duration::from_secs(20);
        loop {
            assert!(Instant::now() < deadline, "no curvesChanged");
            let (_, ev) = exchange(
                addr,
                &format!("GET /api/events?after={after} HTTP/1.1\r\nHost: {addr}\r\n\r\n"),
            );
            after = ev["seq"].as_u64().unwrap_or(after);
            if ev["events"].as_array().is_some_and(|es| {
                es.iter()
                    .any(|e| e["method"] == "curvesChanged" && e["params"]["uri"] == uri)
            }) {
                break;
            }
        }

        // An edit on disk reaches the page as the server's live preview.
        std::thread::sleep(Duration::from_millis(20));
        std::fs::write(
            &grammar,
            "system Koch {\n    iterations = 1;\n    angle = 90;\n    width = 0.1;\n    axiom F - F - F - F;\n    F -> F - F + F + F F - F - F + F;\n}\n",
        )
        .expect("write");
        let deadline = Instant::now() + Duration::from_secs(20);
        let updated = loop {
            assert!(Instant::now() < deadline, "no previewUpdated");
            let (_, ev) = exchange(
                addr,
                &format!("GET /api/events?after={after} HTTP/1.1\r\nHost: {addr}\r\n\r\n"),
            );
            after = ev["seq"].as_u64().unwrap_or(after);
            if let Some(u) = ev["events"]
                .as_array()
                .and_then(|es| es.iter().find(|e| e["method"] == "previewUpdated"))
            {
                break u["params"].clone();
            }
        };
        assert_eq!(updated["result"]["skeleton"]["boneCount"], 32);
    }

    #[test]
    fn a_drag_through_the_page_rewrites_the_file_and_regrows_the_preview() {
        let text =
            "system Bar {\n    iterations = 1;\n    axiom A;\n    A -> F(2) +(30) F(1);\n}\n";
        let (_dir, grammar, server) = serve("bar.grm", text);
        let addr = server.addr;
        let (_, ev) = exchange(
            addr,
            &format!("GET /api/events?after=0 HTTP/1.1\r\nHost: {addr}\r\n\r\n"),
        );
        let uri = ev["events"][0]["params"]["uri"].clone();
        let mut after = ev["seq"].as_u64().unwrap_or(0);
        let (status, r) = post(
            addr,
            "/api/preview",
            &json!({ "textDocument": { "uri": uri }, "live": true }),
        );
        assert_eq!(status, 200, "{r}");
        let (_, p) = post(
            addr,
            "/api/pick",
            &json!({ "textDocument": { "uri": uri }, "bone": 1 }),
        );
        let key = p["result"]["key"].clone();
        assert_eq!(key.as_str().map(str::len), Some(8), "{p}");
        // The second bone, 1 long, dragged along itself to 1.5.
        let bones = base64::Engine::decode(
            &base64::engine::general_purpose::STANDARD,
            r["result"]["skeleton"]["bones"].as_str().expect("bones"),
        )
        .expect("base64");
        let f = |i: usize| f32::from_le_bytes(bones[i * 4..i * 4 + 4].try_into().unwrap()) as f64;
        let (base, tip) = ([f(8), f(9), f(10)], [f(11), f(12), f(13)]);
        let at: Vec<f64> = (0..3).map(|i| base[i] + (tip[i] - base[i]) * 1.5).collect();
        let (status, d) = post(
            addr,
            "/api/drag",
            &json!({ "textDocument": { "uri": uri }, "part": { "kind": "bone", "key": key },
                     "target": { "kind": "tip", "at": at } }),
        );
        assert_eq!(status, 200, "{d}");
        assert_eq!(d["result"]["outcome"], "solved", "{d}");
        assert_eq!(d["result"]["written"], true, "{d}");
        assert!(d["result"].get("text").is_none());
        let on_disk = std::fs::read_to_string(&grammar).expect("read");
        assert!(on_disk.contains("A -> F(2) +(30) F(1.5);"), "{on_disk}");
        // The live preview regrows from the written text.
        let deadline = Instant::now() + Duration::from_secs(20);
        loop {
            assert!(Instant::now() < deadline, "no previewUpdated");
            let (_, ev) = exchange(
                addr,
                &format!("GET /api/events?after={after} HTTP/1.1\r\nHost: {addr}\r\n\r\n"),
            );
            after = ev["seq"].as_u64().unwrap_or(after);
            if ev["events"]
                .as_array()
                .is_some_and(|es| es.iter().any(|e| e["method"] == "previewUpdated"))
            {
                break;
            }
        }
    }

    /// Protocol 3 over HTTP: a preview asked with `binary` names a blob
    /// that `GET /api/blob/ID` serves, and each buffer read from it is the
    /// base64 answer's; an unknown blob is 404.
    #[test]
    fn a_binary_previews_blob_holds_the_base64_previews_buffers() {
        use grm_lsp::blob::Buf;
        let (_dir, _, server) = serve("koch.grm", KOCH);
        let addr = server.addr;
        let (_, ev) = exchange(
            addr,
            &format!("GET /api/events?after=0 HTTP/1.1\r\nHost: {addr}\r\n\r\n"),
        );
        let uri = ev["events"][0]["params"]["uri"].clone();
        let (_, text) = post(
            addr,
            "/api/preview",
            &json!({ "textDocument": { "uri": uri } }),
        );
        let (_, bin) = post(
            addr,
            "/api/preview",
            &json!({ "textDocument": { "uri": uri }, "binary": true }),
        );
        let (text, bin) = (&text["result"], &bin["result"]);
        assert_eq!(text["encoding"], "base64-le");
        assert_eq!(bin["encoding"], "blob-le", "{bin}");
        let id = bin["blob"]["id"].as_u64().expect("blob id");
        let mut s = TcpStream::connect(addr).expect("connect");
        s.write_all(format!("GET /api/blob/{id} HTTP/1.1\r\nHost: {addr}\r\n\r\n").as_bytes())
            .expect("send");
        let mut out = Vec::new();
        s.read_to_end(&mut out).expect("read");
        let at = out.windows(4).position(|w| w == b"\r\n\r\n").expect("head") + 4;
        let head = String::from_utf8_lossy(&out[..at]);
        assert!(head.starts_with("HTTP/1.1 200"), "{head}");
        assert!(head.contains("application/octet-stream"), "{head}");
        let blob = &out[at..];
        assert_eq!(Some(blob.len() as u64), bin["blob"]["bytes"].as_u64());
        let buf = |v: &Value| serde_json::from_value::<Buf>(v.clone()).expect("a buffer");
        let mut compared = 0;
        let (tp, bp) = (
            text["parts"].as_array().expect("parts"),
            bin["parts"].as_array().expect("parts"),
        );
        assert_eq!(tp.len(), bp.len());
        for (a, b) in tp.iter().zip(bp) {
            for k in ["positions", "normals", "indices", "picks"] {
                assert_eq!(buf(&a[k]).decode(&[]), buf(&b[k]).decode(blob), "{k}");
                compared += 1;
            }
        }
        for k in ["bones", "parents", "origins"] {
            let (a, b) = (&text["skeleton"][k], &bin["skeleton"][k]);
            assert!(b.is_object(), "{k}: a range");
            assert_eq!(buf(a).decode(&[]), buf(b).decode(blob), "{k}");
            compared += 1;
        }
        assert!(compared > 3);
        let (status, _) = exchange(
            addr,
            &format!(
                "GET /api/blob/{} HTTP/1.1\r\nHost: {addr}\r\n\r\n",
                id + 100
            ),
        );
        assert_eq!(status, 404);
    }
}

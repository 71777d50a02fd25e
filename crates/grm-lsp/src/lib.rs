//! `grm-lsp`: the grm language server.
//!
//! Role: the only crate that knows the Language Server Protocol. It keeps
//! the open documents in a [`grm_analysis::Analysis`], answers the editor's
//! requests with its plain results converted to LSP types ([`convert`]),
//! publishes diagnostics as the user types, and serves the live-preview
//! extension (`grm/preview`, `grm/previewUpdated`, `grm/pick`,
//! `grm/picture`; a city layout's view: `grm/layout`, `grm/layoutEdit`,
//! [`layout`]; see docs/lsp-extensions.md). Built on `tower-lsp-server`, the maintained
//! community fork of `tower-lsp`. Started by `grmc lsp` over stdio
//! ([`run_stdio`]).
//!
//! Inputs: JSON-RPC messages (stdio, or a tower `Service` in tests).
//! Outputs: responses and notifications.
//!
//! Invariants:
//! - Positions are converted with UTF-16 columns at this edge only; the
//!   analyses work in byte offsets.
//! - Documents are known by their path, whatever spelling of its URI a
//!   message uses; every URI the server sends is spelt as the client spelt
//!   it: an open document's as it was opened, a workspace file's under its
//!   folder's URI ([`uris`]).
//! - Analysis runs off the async executor (`spawn_blocking`), and without
//!   holding the host's lock (a [`grm_analysis::Job`] works on a snapshot),
//!   so a long check or a large preview never stalls reading messages or
//!   applying edits.
//! - Diagnostics of an edit after a pause are computed at once; edits in
//!   quick succession are debounced. Diagnostics carry the document version
//!   they were computed for; a result is published only if its version is
//!   still the document's current one when it is published (stale results
//!   never overwrite newer ones; a client whose versions go backwards
//!   still gets the diagnostics of the text it sent). Preview answers
//!   name their version too: a model's `version`, `grm/previewUpdated`'s,
//!   and a failed `grm/preview`'s `data.version`.
//! - No request can bring the server down: user input never panics, a
//!   failed task becomes an error response, a poisoned lock is recovered.
//!   Over stdio no message can either: [`stdio`] frames and checks every
//!   message before the server reads it, and answers a malformed one
//!   (tower-lsp-server's reader ends the session at the first).

mod b64;
pub mod blob;
pub mod convert;
pub mod coverage;
mod edit_fixes;
mod edit_requests;
pub mod edits;
pub mod layout;
pub mod layout_city;
pub mod layout_grm;
pub mod manip;
pub mod picture;
pub mod preview;
pub mod shape_preview;
pub mod stdio;
pub mod tree_view;
pub mod uris;

use grm_analysis::{Analysis, FileAnalysis, Lookup};
use grm_sema::FileLoader;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicU64;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};
use tower_lsp_server::jsonrpc::{Error, ErrorCode, Result};
use tower_lsp_server::ls_types::*;
use tower_lsp_server::{Client, ClientSocket, LanguageServer, LspService, Server};

/// Server settings.
#[derive(Clone)]
pub struct Config {
    /// Edits closer together than this are debounced: diagnostics (and a
    /// live preview) wait this long after each of them. An edit after a
    /// longer pause is analysed at once.
    pub debounce: Duration,
    /// Where files that are not open are read from.
    pub loader: Arc<dyn FileLoader + Send + Sync>,
}

impl std::fmt::Debug for Config {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Config")
            .field("debounce", &self.debounce)
            .finish()
    }
}

impl Default for Config {
    fn default() -> Self {
        Config {
            debounce: Duration::from_millis(25),
            loader: Arc::new(grm_sema::FsLoader),
        }
    }
}

/// A live `grm/preview` in progress: its ticket's id, its cancel token,
/// the document's version when it began, and the edits files' generation
/// then ([`Shared::edits_generation`]).
pub(crate) type RunningPreview = (u64, grm_sample::CancelToken, Option<i32>, u64);

/// What a preview was built from: the identity of the document's analysis
/// and the edits files' generation ([`Shared::edits_generation`]).
pub(crate) type PreviewKey = (usize, u64);

/// State shared by the handlers and the background tasks.
pub(crate) struct Shared {
    pub(crate) analysis: Mutex<Analysis>,
    /// The last version whose diagnostics were published, and what was
    /// published, per file.
    published: tokio::sync::Mutex<HashMap<PathBuf, (i32, Vec<Diagnostic>)>>,
    /// Documents with a live preview: the options of the last request.
    pub(crate) previews: Mutex<HashMap<PathBuf, preview::PreviewParams>>,
    /// The last preview version sent per file (stale ones are dropped).
    /// (version, what it was built from) per file.
    pub(crate) preview_sent: tokio::sync::Mutex<HashMap<PathBuf, (i32, PreviewKey)>>,
    /// Provenance of the last preview per file, for `grm/pick`.
    pub(crate) picks: Mutex<HashMap<PathBuf, preview::PickTable>>,
    /// The live `grm/preview` in progress per file (its ticket's id, cancel
    /// token, and the document's version when it began): a newer live
    /// request for the file cancels it.
    pub(crate) running: Mutex<HashMap<PathBuf, RunningPreview>>,
    /// Ids of `grm/preview` requests, in the order they started.
    pub(crate) preview_seq: AtomicU64,
    /// The latest `order` of a live `grm/preview` per (file, client).
    pub(crate) live_orders: Mutex<HashMap<(PathBuf, String), u64>>,
    debounce: Duration,
    /// Workspace folders to scan for `.grm` files.
    roots: Mutex<Vec<PathBuf>>,
    /// The client's spelling of the open documents' and folders' URIs.
    uris: Mutex<uris::Uris>,
    /// When each document was last edited (for the debounce).
    last_edit: Mutex<HashMap<PathBuf, Instant>>,
    /// Per file: held while its analysis is computed.
    computing: Mutex<HashMap<PathBuf, Arc<Mutex<()>>>>,
    /// The edits files: open buffers, what the previews made of them.
    pub(crate) edits: Mutex<edits::EditsState>,
    /// Bumped on every change of an edits file (buffer or disk).
    pub(crate) edits_gen: AtomicU64,
    /// The diagnostics last published per edits file (and its version).
    pub(crate) edits_published: tokio::sync::Mutex<edits::Published>,
    /// What the client can do with a workspace edit (from `initialize`).
    pub(crate) edit_caps: Mutex<edits::EditCaps>,
    /// The last document's direct manipulation, kept between requests
    /// (a drag's grab and release).
    pub(crate) manips: Mutex<manip::ManipCache>,
    /// Where protocol 3's blobs go (none: buffers stay base64 text), and
    /// the next blob's id.
    pub(crate) blobs: Option<blob::BlobSink>,
    pub(crate) blob_seq: AtomicU64,
    /// The layout sidecars: open buffers, merge caches (layout.rs).
    pub(crate) layouts: Mutex<layout::LayoutState>,
}

/// The `.grm` files under `roots` (hidden directories, `target` and
/// `node_modules` skipped; at most 2,000 files, 12 levels deep).
fn scan(roots: &[PathBuf]) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack: Vec<(PathBuf, u32)> = roots.iter().map(|r| (r.clone(), 0)).collect();
    while let Some((dir, depth)) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        for e in entries.flatten() {
            let p = e.path();
            let name = e.file_name();
            let name = name.to_string_lossy();
            let Ok(ft) = e.file_type() else { continue };
            if ft.is_dir() {
                if depth < 12
                    && !name.starts_with('.')
                    && name != "target"
                    && name != "node_modules"
                {
                    stack.push((p, depth + 1));
                }
            } else if ft.is_file() && name.ends_with(".grm") {
                out.push(p);
                if out.len() >= 2000 {
                    return out;
                }
            }
        }
    }
    out.sort();
    out
}

impl Shared {
    pub(crate) fn new(config: Config) -> Shared {
        Shared {
            analysis: Mutex::new(Analysis::new(config.loader)),
            published: tokio::sync::Mutex::new(HashMap::new()),
            previews: Mutex::new(HashMap::new()),
            preview_sent: tokio::sync::Mutex::new(HashMap::new()),
            picks: Mutex::new(HashMap::new()),
            running: Mutex::new(HashMap::new()),
            preview_seq: AtomicU64::new(0),
            live_orders: Mutex::new(HashMap::new()),
            debounce: config.debounce,
            roots: Mutex::new(Vec::new()),
            uris: Mutex::new(uris::Uris::default()),
            last_edit: Mutex::new(HashMap::new()),
            computing: Mutex::new(HashMap::new()),
            edits: Mutex::new(edits::EditsState::default()),
            edits_gen: AtomicU64::new(0),
            edits_published: tokio::sync::Mutex::new(HashMap::new()),
            edit_caps: Mutex::new(edits::EditCaps::default()),
            manips: Mutex::new(None),
            blobs: None,
            blob_seq: AtomicU64::new(1),
            layouts: Mutex::new(layout::LayoutState::default()),
        }
    }

    /// The analysis host (a panic in another thread while holding the lock
    /// leaves it usable: its state is only ever replaced whole).
    pub(crate) fn analysis(&self) -> MutexGuard<'_, Analysis> {
        self.analysis
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// The current analysis of `path`; when it must be computed, the work
    /// runs without holding the host's lock (edits keep being applied).
    pub(crate) fn analyze(&self, path: &Path) -> Option<Arc<FileAnalysis>> {
        // One computation per file at a time: a second request for the same
        // version waits for the first and takes its result from the cache.
        let gate = self
            .computing
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .entry(path.to_path_buf())
            .or_default()
            .clone();
        let _one = gate
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let job = match self.analysis().lookup(path) {
            Lookup::Ready(fa) => return Some(fa),
            Lookup::Run(job) => job,
        };
        let fa = job.run()?;
        Some(self.analysis().store(fa))
    }

    /// The client's spellings of URIs (a snapshot).
    pub(crate) fn uris(&self) -> uris::Uris {
        self.uris_mut().clone()
    }

    fn uris_mut(&self) -> MutexGuard<'_, uris::Uris> {
        self.uris
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    pub(crate) fn version(&self, path: &Path) -> Option<i32> {
        self.analysis().document(path).map(|(v, _)| v)
    }

    pub(crate) fn previews(&self) -> MutexGuard<'_, HashMap<PathBuf, preview::PreviewParams>> {
        self.previews
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    pub(crate) fn live_orders(&self) -> MutexGuard<'_, HashMap<(PathBuf, String), u64>> {
        self.live_orders
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    pub(crate) fn running(&self) -> MutexGuard<'_, HashMap<PathBuf, RunningPreview>> {
        self.running
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// How long to wait before analysing an edit of `path` just made:
    /// nothing after a pause (leading-edge debounce), the debounce after
    /// an edit closer than it to the one before (all but the last of a
    /// burst are then skipped by the version check).
    pub(crate) fn edit_delay(&self, path: &Path) -> Duration {
        let now = Instant::now();
        let previous = self
            .last_edit
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .insert(path.to_path_buf(), now);
        match previous {
            Some(t) if now.duration_since(t) < self.debounce => self.debounce,
            _ => Duration::ZERO,
        }
    }
}

/// The language server.
pub struct Backend {
    client: Client,
    shared: Arc<Shared>,
    /// Set by `shutdown`: an `exit` after it is a clean one (exit code 0).
    shut_down: Arc<std::sync::atomic::AtomicBool>,
}

impl std::fmt::Debug for Backend {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Backend").finish_non_exhaustive()
    }
}

/// The server as a tower service (for stdio, sockets or in-process tests).
pub fn service(config: Config) -> (LspService<Backend>, ClientSocket) {
    build(config, Arc::default(), None)
}

/// [`service`] whose protocol-3 previews (`"binary": true`) put their
/// buffers in `store` (`grmc view` serves them from there).
pub fn service_with_blobs(
    config: Config,
    store: Arc<blob::BlobStore>,
) -> (LspService<Backend>, ClientSocket) {
    build(config, Arc::default(), Some(blob::BlobSink::Store(store)))
}

fn build(
    config: Config,
    shut_down: Arc<std::sync::atomic::AtomicBool>,
    blobs: Option<blob::BlobSink>,
) -> (LspService<Backend>, ClientSocket) {
    LspService::build(|client| Backend::new(client, config, shut_down, blobs))
        .custom_method("grm/preview", Backend::preview)
        .custom_method("grm/pick", Backend::pick)
        .custom_method("grm/picture", Backend::picture)
        .custom_method("grm/edit", Backend::edit)
        .custom_method("grm/removeEdit", Backend::remove_edit)
        .custom_method("grm/retargetEdit", Backend::retarget_edit)
        .custom_method("grm/provenance", Backend::provenance)
        .custom_method("grm/tree", Backend::tree)
        .custom_method("grm/drag", Backend::drag)
        .custom_method("grm/sketch", Backend::sketch)
        .custom_method("grm/writeParams", Backend::write_params)
        .custom_method("grm/layout", Backend::layout)
        .custom_method("grm/layoutEdit", Backend::layout_edit)
        .custom_method("grm/layoutCity", Backend::layout_city)
        .finish()
}

/// Serve LSP on stdin/stdout until the client exits (`exit`, or the end of
/// its input). `Ok(true)` when a `shutdown` request came first: LSP asks
/// for exit code 0 then, and 1 otherwise.
pub fn run_stdio() -> std::io::Result<bool> {
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()?;
    let shut_down = Arc::new(std::sync::atomic::AtomicBool::new(false));
    rt.block_on(async {
        let (blobs, blobs_rx) = tokio::sync::mpsc::unbounded_channel();
        let (service, socket) = build(
            Config::default(),
            shut_down.clone(),
            Some(blob::BlobSink::Frames(blobs)),
        );
        // The server reads and writes through the guard ([`stdio`]): a
        // malformed message is answered, not the end of the session.
        let (server_in, to_server) = tokio::io::duplex(1 << 16);
        let (from_server, server_out) = tokio::io::duplex(1 << 16);
        let (answers, answers_rx) = tokio::sync::mpsc::unbounded_channel();
        // Not awaited: after `exit` its read of stdin cannot be cancelled
        // (tokio reads stdin on a blocking thread); the runtime is shut
        // down without waiting for it.
        tokio::spawn(stdio::guard_input(tokio::io::stdin(), to_server, answers));
        let serve = Server::new(server_in, from_server, socket).serve(service);
        let write = stdio::merge_output(server_out, tokio::io::stdout(), answers_rx, blobs_rx);
        tokio::join!(serve, write);
    });
    rt.shutdown_background();
    Ok(shut_down.load(std::sync::atomic::Ordering::SeqCst))
}

fn internal(e: impl std::fmt::Display) -> Error {
    Error {
        code: ErrorCode::InternalError,
        message: e.to_string().into(),
        data: None,
    }
}

/// LSP's RequestFailed (-32803): a valid request that cannot be honoured.
pub(crate) fn failed(msg: impl Into<String>) -> Error {
    Error {
        code: ErrorCode::ServerError(-32803),
        message: msg.into().into(),
        data: None,
    }
}

impl Backend {
    fn new(
        client: Client,
        config: Config,
        shut_down: Arc<std::sync::atomic::AtomicBool>,
        blobs: Option<blob::BlobSink>,
    ) -> Backend {
        let mut shared = Shared::new(config);
        shared.blobs = blobs;
        Backend {
            client,
            shared: Arc::new(shared),
            shut_down,
        }
    }

    /// Run `f` on the current analysis of `uri`, off the executor.
    async fn with_file<R: Send + 'static>(
        &self,
        uri: &Uri,
        f: impl FnOnce(&FileAnalysis) -> R + Send + 'static,
    ) -> Result<Option<R>> {
        let Some(path) = convert::path_of(uri) else {
            return Ok(None);
        };
        if edits::is_edits_path(&path) {
            return Ok(None); // JSON, not grm
        }
        let shared = self.shared.clone();
        tokio::task::spawn_blocking(move || {
            let fa = shared.analyze(&path)?;
            Some(f(&fa))
        })
        .await
        .map_err(internal)
    }

    /// Run `f` on the analysis host, off the executor.
    async fn with_host<R: Send + 'static>(
        &self,
        f: impl FnOnce(&mut Analysis) -> R + Send + 'static,
    ) -> Result<R> {
        let shared = self.shared.clone();
        tokio::task::spawn_blocking(move || f(&mut shared.analysis()))
            .await
            .map_err(internal)
    }

    /// Bring the analysis of every known file (open documents and workspace
    /// files) up to date, one file at a time, running each analysis without
    /// holding the host: a workspace-wide request (symbols, references,
    /// rename) then finds them all current, and requests about single
    /// documents are answered between two files rather than after all of
    /// them (a workspace of 1,000 files importing each other in a chain
    /// held every other request for 8 seconds on the first
    /// `workspace/symbol`).
    async fn warm_workspace(&self) -> Result<()> {
        let shared = self.shared.clone();
        tokio::task::spawn_blocking(move || {
            let files = shared.analysis().known_files();
            for f in files {
                let job = match shared.analysis().lookup(&f) {
                    grm_analysis::Lookup::Ready(_) => continue,
                    grm_analysis::Lookup::Run(job) => job,
                };
                if let Some(fa) = job.run() {
                    shared.analysis().store(fa);
                }
            }
        })
        .await
        .map_err(internal)
    }

    /// Compute and publish diagnostics for `path` after `delay`, if its
    /// version is then still `version`; also refresh a live preview.
    fn schedule(&self, path: PathBuf, version: i32, delay: Duration) {
        let shared = self.shared.clone();
        let client = self.client.clone();
        tokio::spawn(async move {
            if !delay.is_zero() {
                tokio::time::sleep(delay).await;
            }
            publish(&shared, &client, path.clone(), version).await;
            preview::refresh(&shared, &client, path, version).await;
        });
    }

    /// After `path` changed: its own diagnostics, and those of the open
    /// documents that import it.
    async fn changed(&self, path: PathBuf, version: i32, delay: Duration) {
        self.schedule(path.clone(), version, delay);
        let deps = {
            let p = path.clone();
            self.with_host(move |a| {
                a.dependents(&p)
                    .into_iter()
                    .filter_map(|d| a.document(&d).map(|(v, _)| (d, v)))
                    .collect::<Vec<_>>()
            })
            .await
            .unwrap_or_default()
        };
        for (d, v) in deps {
            self.schedule(d, v, delay);
        }
    }
}

/// Publish the diagnostics of `path` at `version` unless outdated.
async fn publish(shared: &Arc<Shared>, client: &Client, path: PathBuf, version: i32) {
    if shared.version(&path) != Some(version) {
        return; // a newer edit has its own task
    }
    let s = shared.clone();
    let p = path.clone();
    let computed = tokio::task::spawn_blocking(move || {
        let fa = s.analyze(&p)?;
        Some((fa.version, convert::diagnostics(&s.uris(), &fa)))
    })
    .await;
    let Ok(Some((v, diags))) = computed else {
        return;
    };
    // The URI the document is open under (it is open: its version is).
    let Some(uri) = shared.uris().uri_of(&path) else {
        return;
    };
    let mut published = shared.published.lock().await;
    // Re-check under the publish lock: the text is still current (a task
    // for an older version stops here), and the same diagnostics are not
    // sent twice for one version (they are sent again for the same
    // version when an import changed them). A version lower than one
    // published before is still published when it is the document's: a
    // client that counts backwards would otherwise keep the diagnostics of
    // a text the server no longer holds.
    let last = published.get(&path);
    if shared.version(&path) != Some(v) || last.is_some_and(|(p, d)| *p == v && *d == diags) {
        return;
    }
    published.insert(path, (v, diags.clone()));
    client.publish_diagnostics(uri, diags, Some(v)).await;
}

impl LanguageServer for Backend {
    async fn initialize(&self, params: InitializeParams) -> Result<InitializeResult> {
        let mut folders: Vec<Uri> = params
            .workspace_folders
            .unwrap_or_default()
            .into_iter()
            .map(|f| f.uri)
            .collect();
        #[allow(deprecated)] // `root_uri` is still what older clients send.
        if folders.is_empty()
            && let Some(u) = params.root_uri
        {
            folders.push(u);
        }
        let roots = self.shared.uris_mut().set_roots(&folders);
        *self
            .shared
            .edit_caps
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner) =
            edits::EditCaps::of(&params.capabilities);
        *self
            .shared
            .roots
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner) = roots;
        Ok(InitializeResult {
            offset_encoding: None,
            server_info: Some(ServerInfo {
                name: "grm-lsp".into(),
                version: Some(env!("CARGO_PKG_VERSION").into()),
            }),
            capabilities: ServerCapabilities {
                position_encoding: Some(PositionEncodingKind::UTF16),
                text_document_sync: Some(TextDocumentSyncCapability::Options(
                    TextDocumentSyncOptions {
                        open_close: Some(true),
                        change: Some(TextDocumentSyncKind::INCREMENTAL),
                        ..TextDocumentSyncOptions::default()
                    },
                )),
                hover_provider: Some(HoverProviderCapability::Simple(true)),
                definition_provider: Some(OneOf::Left(true)),
                references_provider: Some(OneOf::Left(true)),
                rename_provider: Some(OneOf::Right(RenameOptions {
                    prepare_provider: Some(true),
                    work_done_progress_options: WorkDoneProgressOptions::default(),
                })),
                completion_provider: Some(CompletionOptions {
                    trigger_characters: Some(vec!["(".into(), ",".into()]),
                    ..CompletionOptions::default()
                }),
                signature_help_provider: Some(SignatureHelpOptions {
                    trigger_characters: Some(vec!["(".into(), ",".into()]),
                    retrigger_characters: None,
                    work_done_progress_options: WorkDoneProgressOptions::default(),
                }),
                document_symbol_provider: Some(OneOf::Left(true)),
                workspace_symbol_provider: Some(OneOf::Left(true)),
                semantic_tokens_provider: Some(
                    SemanticTokensServerCapabilities::SemanticTokensOptions(
                        SemanticTokensOptions {
                            legend: convert::legend(),
                            range: Some(true),
                            full: Some(SemanticTokensFullOptions::Bool(true)),
                            work_done_progress_options: WorkDoneProgressOptions::default(),
                        },
                    ),
                ),
                document_formatting_provider: Some(OneOf::Left(true)),
                code_action_provider: Some(CodeActionProviderCapability::Options(
                    CodeActionOptions {
                        code_action_kinds: Some(vec![
                            CodeActionKind::QUICKFIX,
                            CodeActionKind::REFACTOR_REWRITE,
                        ]),
                        ..CodeActionOptions::default()
                    },
                )),
                inlay_hint_provider: Some(OneOf::Left(true)),
                folding_range_provider: Some(FoldingRangeProviderCapability::Simple(true)),
                experimental: Some(serde_json::json!({
                    "grmPreview": { "version": preview::PROTOCOL_VERSION, "picture": true }
                })),
                ..ServerCapabilities::default()
            },
        })
    }

    async fn initialized(&self, _: InitializedParams) {
        // Index the workspace's `.grm` files for workspace symbols,
        // references and rename (off the executor).
        let roots = self
            .shared
            .roots
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .clone();
        if roots.is_empty() {
            return;
        }
        let _ = self
            .with_host(move |a| {
                for f in scan(&roots) {
                    a.set_workspace_file(&f, true);
                }
            })
            .await;
    }

    async fn shutdown(&self) -> Result<()> {
        self.shut_down
            .store(true, std::sync::atomic::Ordering::SeqCst);
        Ok(())
    }

    async fn did_open(&self, params: DidOpenTextDocumentParams) {
        let Some(path) = convert::path_of(&params.text_document.uri) else {
            return;
        };
        let version = params.text_document.version;
        if edits::is_edits_path(&path) {
            let d = params.text_document;
            self.edits_opened(path, d.uri, version, d.text).await;
            return;
        }
        if layout::is_layout_path(&path) {
            self.layout_opened(path, params.text_document, version)
                .await;
            return;
        }
        // Its spelling first: what is published for it is named so.
        self.shared
            .uris_mut()
            .open(path.clone(), params.text_document.uri);
        self.shared
            .analysis()
            .set_document(&path, version, params.text_document.text);
        self.changed(path.clone(), version, Duration::ZERO).await;
        // The problems of its edits file (beside an open grammar).
        let beside = grm_edits::edits_path(&path);
        edits::publish(&self.shared, &self.client, &beside).await;
    }

    async fn did_change(&self, params: DidChangeTextDocumentParams) {
        let Some(path) = convert::path_of(&params.text_document.uri) else {
            return;
        };
        let version = params.text_document.version;
        if edits::is_edits_path(&path) {
            self.edits_edited(params, path).await;
            return;
        }
        if layout::is_layout_path(&path) {
            self.layout_changed(&path, &params).await;
            return;
        }
        let open = {
            // Applied before any await: edits are taken in arrival order.
            let mut a = self.shared.analysis();
            // A change to a document that is not open (a client bug) has no
            // text to apply to: taking it as an edit of an empty text would
            // open a document that hides the file from its importers.
            match a.document(&path) {
                Some((_, old)) => {
                    let text = convert::apply_changes(&old, &params.content_changes);
                    a.set_document(&path, version, text);
                    true
                }
                None => false,
            }
        };
        if !open {
            self.client
                .log_message(
                    MessageType::WARNING,
                    format!(
                        "didChange for {} ignored: the document is not open",
                        params.text_document.uri.as_str()
                    ),
                )
                .await;
            return;
        }
        // Leading-edge debounce: an edit after a pause is analysed at once;
        // edits that follow each other closer than the debounce wait it out
        // (and all but the last are then skipped by the version check).
        let delay = self.shared.edit_delay(&path);
        // A layout view of its `layout` item regrows (layout_grm.rs).
        self.layout_grammar_changed(&path, params.text_document.uri.clone(), version)
            .await;
        self.changed(path, version, delay).await;
    }

    async fn did_close(&self, params: DidCloseTextDocumentParams) {
        let Some(path) = convert::path_of(&params.text_document.uri) else {
            return;
        };
        if edits::is_edits_path(&path) {
            self.edits_closed(path).await;
            return;
        }
        if layout::is_layout_path(&path) {
            self.shared.layout_closed(&path);
            return;
        }
        // Its importers now read the file on disk (the buffer may have had
        // unsaved edits): check them again.
        self.shared.uris_mut().close(&path);
        let deps: Vec<(PathBuf, i32)> = {
            let mut a = self.shared.analysis();
            a.close_document(&path);
            a.dependents(&path)
                .into_iter()
                .filter_map(|d| a.document(&d).map(|(v, _)| (d, v)))
                .collect()
        };
        for (d, v) in deps {
            self.schedule(d, v, Duration::ZERO);
        }
        self.shared.previews().remove(&path);
        self.shared
            .picks
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .remove(&path);
        self.shared.preview_sent.lock().await.remove(&path);
        self.shared.published.lock().await.remove(&path);
        self.client
            .publish_diagnostics(params.text_document.uri, Vec::new(), None)
            .await;
        // Its edits file's problems go with it, unless that file is open.
        let beside = grm_edits::edits_path(&path);
        edits::publish(&self.shared, &self.client, &beside).await;
    }

    async fn did_change_watched_files(&self, params: DidChangeWatchedFilesParams) {
        for c in params.changes {
            if let Some(p) = convert::path_of(&c.uri) {
                if edits::is_edits_path(&p) {
                    // Its buffer, when open, is what counts.
                    if self.shared.edits_state_is_open(&p) {
                        continue;
                    }
                    edits::changed(&self.shared, &self.client, p, Duration::ZERO);
                    continue;
                }
                {
                    let mut a = self.shared.analysis();
                    if p.extension().is_some_and(|e| e == "grm") {
                        a.set_workspace_file(&p, c.typ != FileChangeType::DELETED);
                    }
                    a.file_changed(&p);
                }
                let deps: Vec<(PathBuf, i32)> = {
                    let a = self.shared.analysis();
                    a.dependents(&p)
                        .into_iter()
                        .filter_map(|d| a.document(&d).map(|(v, _)| (d, v)))
                        .collect()
                };
                for (d, v) in deps {
                    self.schedule(d, v, Duration::ZERO);
                }
            }
        }
    }

    async fn hover(&self, params: HoverParams) -> Result<Option<Hover>> {
        let p = params.text_document_position_params;
        let at = p.position;
        Ok(self
            .with_file(&p.text_document.uri, move |fa| {
                let src = fa.source();
                let h = fa.hover(convert::offset(src, at))?;
                Some(Hover {
                    contents: HoverContents::Markup(MarkupContent {
                        kind: MarkupKind::Markdown,
                        value: h.markdown,
                    }),
                    range: Some(convert::range(src, h.span)),
                })
            })
            .await?
            .flatten())
    }

    async fn goto_definition(
        &self,
        params: GotoDefinitionParams,
    ) -> Result<Option<GotoDefinitionResponse>> {
        let p = params.text_document_position_params;
        let at = p.position;
        let uris = self.shared.uris();
        Ok(self
            .with_file(&p.text_document.uri, move |fa| {
                let l = fa.definition(convert::offset(fa.source(), at))?;
                convert::location(&uris, &l).map(GotoDefinitionResponse::Scalar)
            })
            .await?
            .flatten())
    }

    async fn references(&self, params: ReferenceParams) -> Result<Option<Vec<Location>>> {
        let p = params.text_document_position;
        let Some(path) = convert::path_of(&p.text_document.uri) else {
            return Ok(None);
        };
        if edits::is_edits_path(&path) {
            return Ok(None);
        }
        let at = p.position;
        let include = params.context.include_declaration;
        self.warm_workspace().await?;
        let locs = self
            .with_host(move |a| {
                let fa = a.analyze(&path)?;
                let off = convert::offset(fa.source(), at);
                Some(a.references(&path, off, include))
            })
            .await?;
        let uris = self.shared.uris();
        Ok(locs.map(|v| {
            v.iter()
                .filter_map(|l| convert::location(&uris, l))
                .collect()
        }))
    }

    async fn prepare_rename(
        &self,
        params: TextDocumentPositionParams,
    ) -> Result<Option<PrepareRenameResponse>> {
        let at = params.position;
        let r = self
            .with_file(&params.text_document.uri, move |fa| {
                let src = fa.source();
                fa.prepare_rename(convert::offset(src, at))
                    .map(|(span, text)| PrepareRenameResponse::RangeWithPlaceholder {
                        range: convert::range(src, span),
                        placeholder: text,
                    })
            })
            .await?;
        match r {
            None => Ok(None),
            Some(Ok(x)) => Ok(Some(x)),
            Some(Err(e)) => Err(failed(e.0)),
        }
    }

    async fn rename(&self, params: RenameParams) -> Result<Option<WorkspaceEdit>> {
        let p = params.text_document_position;
        let Some(path) = convert::path_of(&p.text_document.uri) else {
            return Ok(None);
        };
        if edits::is_edits_path(&path) {
            return Ok(None);
        }
        let at = p.position;
        let new_name = params.new_name;
        self.warm_workspace().await?;
        let name = new_name.clone();
        let r = self
            .with_host(move |a| {
                let fa = a.analyze(&path)?;
                let off = convert::offset(fa.source(), at);
                // And what the edits files beside the grammars use of it.
                Some(
                    a.rename(&path, off, &name)
                        .map(|files| (files, a.renamed_name(&path, off))),
                )
            })
            .await?;
        match r {
            None => Ok(None),
            Some(Ok((files, renamed))) => {
                let mut edit = convert::workspace_edit(&self.shared.uris(), &files);
                edits::rename_edits_files(&self.shared, renamed.as_ref(), &new_name, &mut edit);
                Ok(Some(edit))
            }
            Some(Err(e)) => Err(failed(e.0)),
        }
    }

    async fn completion(&self, params: CompletionParams) -> Result<Option<CompletionResponse>> {
        let p = params.text_document_position;
        let at = p.position;
        self.with_file(&p.text_document.uri, move |fa| {
            let items = fa.completion(convert::offset(fa.source(), at));
            CompletionResponse::Array(items.iter().map(convert::completion).collect())
        })
        .await
    }

    async fn signature_help(&self, params: SignatureHelpParams) -> Result<Option<SignatureHelp>> {
        let p = params.text_document_position_params;
        let at = p.position;
        Ok(self
            .with_file(&p.text_document.uri, move |fa| {
                fa.signature_help(convert::offset(fa.source(), at))
                    .map(|s| convert::signature_help(&s))
            })
            .await?
            .flatten())
    }

    async fn document_symbol(
        &self,
        params: DocumentSymbolParams,
    ) -> Result<Option<DocumentSymbolResponse>> {
        self.with_file(&params.text_document.uri, |fa| {
            let src = fa.source();
            DocumentSymbolResponse::Nested(
                fa.document_symbols()
                    .iter()
                    .map(|n| convert::document_symbol(src, n))
                    .collect(),
            )
        })
        .await
    }

    async fn symbol(
        &self,
        params: WorkspaceSymbolParams,
    ) -> Result<Option<WorkspaceSymbolResponse>> {
        let q = params.query;
        self.warm_workspace().await?;
        let found = self.with_host(move |a| a.workspace_symbols(&q)).await?;
        let uris = self.shared.uris();
        Ok(Some(WorkspaceSymbolResponse::Flat(
            found
                .iter()
                .filter_map(|s| convert::workspace_symbol(&uris, s))
                .collect(),
        )))
    }

    async fn semantic_tokens_full(
        &self,
        params: SemanticTokensParams,
    ) -> Result<Option<SemanticTokensResult>> {
        self.with_file(&params.text_document.uri, |fa| {
            SemanticTokensResult::Tokens(SemanticTokens {
                result_id: None,
                data: convert::semantic_tokens(fa.source(), &fa.semantic_tokens(), None),
            })
        })
        .await
    }

    async fn semantic_tokens_range(
        &self,
        params: SemanticTokensRangeParams,
    ) -> Result<Option<SemanticTokensRangeResult>> {
        let r = params.range;
        self.with_file(&params.text_document.uri, move |fa| {
            let src = fa.source();
            SemanticTokensRangeResult::Tokens(SemanticTokens {
                result_id: None,
                data: convert::semantic_tokens(
                    src,
                    &fa.semantic_tokens(),
                    Some(convert::span(src, r)),
                ),
            })
        })
        .await
    }

    async fn formatting(&self, params: DocumentFormattingParams) -> Result<Option<Vec<TextEdit>>> {
        let r = self
            .with_file(&params.text_document.uri, |fa| {
                fa.format()
                    .map(|e| e.map(|e| vec![convert::text_edit(fa.source(), &e)]))
            })
            .await?;
        match r {
            None => Ok(None),
            Some(Ok(Some(edits))) => Ok(Some(edits)),
            Some(Ok(None)) => Ok(Some(Vec::new())),
            Some(Err(why)) => {
                // Refusing to format broken text is not an error to pop up.
                self.client.log_message(MessageType::INFO, why).await;
                Ok(None)
            }
        }
    }

    async fn code_action(&self, params: CodeActionParams) -> Result<Option<CodeActionResponse>> {
        if let Some(path) = convert::path_of(&params.text_document.uri)
            && edits::is_edits_path(&path)
        {
            return self.edits_code_actions(params, path).await;
        }
        let uri = params.text_document.uri.clone();
        let r = params.range;
        let uris = self.shared.uris();
        self.with_file(&params.text_document.uri, move |fa| {
            let src = fa.source();
            let diags = fa.diagnostics();
            fa.code_actions(convert::span(src, r))
                .iter()
                .map(|a| {
                    let d = diags
                        .iter()
                        .find(|d| d.code == a.code && d.span == a.diagnostic)
                        .map(|d| convert::diagnostic(&uris, src, d));
                    let edits = a.edits.iter().map(|e| convert::text_edit(src, e)).collect();
                    CodeActionOrCommand::CodeAction(CodeAction {
                        title: a.title.clone(),
                        kind: Some(CodeActionKind::QUICKFIX),
                        diagnostics: d.map(|d| vec![d]),
                        edit: Some(WorkspaceEdit {
                            changes: Some(HashMap::from([(uri.clone(), edits)])),
                            document_changes: None,
                            change_annotations: None,
                        }),
                        command: None,
                        is_preferred: Some(a.preferred),
                        disabled: None,
                        data: None,
                    })
                })
                .collect()
        })
        .await
    }

    async fn inlay_hint(&self, params: InlayHintParams) -> Result<Option<Vec<InlayHint>>> {
        let r = params.range;
        self.with_file(&params.text_document.uri, move |fa| {
            let src = fa.source();
            fa.inlay_hints(convert::span(src, r))
                .iter()
                .map(|h| convert::inlay_hint(src, h))
                .collect()
        })
        .await
    }

    async fn folding_range(&self, params: FoldingRangeParams) -> Result<Option<Vec<FoldingRange>>> {
        self.with_file(&params.text_document.uri, |fa| {
            let src = fa.source();
            fa.folding_ranges()
                .iter()
                .map(|f| convert::folding_range(src, f))
                .collect()
        })
        .await
    }
}

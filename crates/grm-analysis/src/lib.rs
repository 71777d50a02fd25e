//! `grm-analysis`: the editor analyses of `.grm` files, free of any
//! protocol types.
//!
//! Role: everything a language server, the CLI or a test asks about a file
//! while it is being edited: diagnostics, hover, definition, references,
//! rename, completion, signature help, document and workspace symbols,
//! semantic tokens, formatting, code actions, inlay hints and folding
//! ranges. `grm-lsp` maps these plain results to LSP; nothing here knows
//! LSP.
//!
//! Inputs: file texts with a version ([`Analysis::set_document`]), an
//! optional [`FileLoader`] for files that are not open (the file system by
//! default), and queries that take byte offsets into a file's text.
//!
//! Outputs: plain structs ([`Diagnostic`], [`Hover`], [`Location`],
//! [`TextEdit`], [`CompletionItem`], [`SemanticToken`], ...) whose
//! positions are byte [`Span`]s into the queried file, plus for locations
//! in other files a zero-based (line, UTF-16 column) range so a caller
//! never needs those files' texts.
//!
//! Invariants:
//! - Open documents form an overlay over the loader: imports resolve to the
//!   open buffer when there is one, so unsaved edits of an imported file
//!   are seen by the files that import it.
//! - A file is re-parsed and re-checked only when its own version, or the
//!   version of an open document it imports, changed
//!   ([`Analysis::analyze`] hands out the cached [`FileAnalysis`]
//!   otherwise). A file whose imports failed to load is re-checked after
//!   any document change (the missing file may have appeared).
//! - Nothing panics on user input: every query accepts any offset (clamped)
//!   and any text, including text that does not parse.

mod actions;
mod complete;
pub mod docs;
mod hints;
mod hover;
mod nav;
mod outline;
mod shape;
mod tags;
mod tokens;

pub use actions::CodeAction;
pub use complete::{CompletionItem, CompletionKind, Signature, SignatureHelp};
pub use hints::{InlayHint, InlayHintKind};
pub use hover::Hover;
pub use nav::{RenameError, RenamedKind, RenamedName, RenamedSystem};
pub use outline::{FoldKind, FoldingRange, SymbolKind, SymbolNode, WorkspaceSymbol};
pub use tags::{COLUMN_WIDTH, FLOOR_HEIGHT, TagSuggestion};
pub use tokens::{SemanticToken, TokenKind, TokenModifier};

use grm_diag::{FileId, SourceMap};
pub use grm_diag::{Severity, SourceFile, Span};
use grm_sema::{Checked, FileLoader, FsLoader, LoadError, normalize};
use grm_syntax::Parsed;
use grm_syntax::lexer::TokKind;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};

/// A zero-based line and a zero-based column in UTF-16 code units.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct LineCol {
    pub line: u32,
    pub col: u32,
}

/// A place in some file: its path, its byte span, and the same span as
/// UTF-16 line/column positions.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Location {
    pub path: PathBuf,
    pub span: Span,
    pub start: LineCol,
    pub end: LineCol,
}

impl Location {
    pub(crate) fn new(path: &str, file: &SourceFile, span: Span) -> Location {
        let (l0, c0) = file.line_col_utf16(span.start);
        let (l1, c1) = file.line_col_utf16(span.end);
        Location {
            path: PathBuf::from(path),
            span,
            start: LineCol { line: l0, col: c0 },
            end: LineCol { line: l1, col: c1 },
        }
    }
}

/// Replace `span` of a file's text by `new_text`.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct TextEdit {
    pub span: Span,
    pub new_text: String,
}

/// Edits of one file (for rename and code actions). `start`/`end` of each
/// edit's location give the UTF-16 positions.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FileEdits {
    pub path: PathBuf,
    pub edits: Vec<(Location, String)>,
}

/// A secondary label of a diagnostic.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Related {
    pub location: Location,
    pub message: String,
}

/// A diagnostic of the analysed file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Diagnostic {
    /// The stable code, e.g. `E0101`.
    pub code: &'static str,
    pub severity: Severity,
    /// The message, with the primary label's text, the notes and the help
    /// appended on their own lines.
    pub message: String,
    /// Primary span in the analysed file.
    pub span: Span,
    /// The other labels (possibly in other files).
    pub related: Vec<Related>,
    /// Whether the diagnostic marks unused code (for faded rendering).
    pub unnecessary: bool,
}

/// The analysis of one file at one version: its text, syntax tree, checked
/// program and diagnostics. Immutable; queries are methods.
#[derive(Debug)]
pub struct FileAnalysis {
    /// The path the file was opened under (normalized).
    pub path: PathBuf,
    pub version: i32,
    /// The file and everything it imports.
    pub sources: SourceMap,
    /// The analysed file in [`FileAnalysis::sources`].
    pub root: FileId,
    /// The analysed file's own parse (syntax tree and comments), made on
    /// first use: publishing diagnostics needs only the check.
    parsed: OnceLock<Parsed>,
    pub checked: Checked,
    /// Tokens of the analysed file (kind and span), made on first use.
    tokens: OnceLock<Vec<(TokKind, Span)>>,
    /// Imported files and the document version each had (None: read
    /// through the loader).
    deps: Vec<(PathBuf, Option<i32>)>,
    /// An import could not be read: re-check after any document change.
    broken_imports: bool,
}

impl FileAnalysis {
    /// Parse and check `text` as the file `path`, reading imports through
    /// `loader`.
    ///
    /// A text larger than [`grm_sema::MAX_SOURCE_BYTES`] (16 MiB, the most
    /// `grmc` reads of a grammar file) is not parsed: its analysis is of an
    /// empty text, with the one E0405 `grmc check` gives such a file.
    pub fn new(path: &Path, version: i32, text: &str, loader: &dyn FileLoader) -> FileAnalysis {
        let display = path.to_string_lossy().replace('\\', "/");
        let mut sources = SourceMap::new();
        let too_large = text.len() as u64 > grm_sema::MAX_SOURCE_BYTES;
        let root = sources.add(display, if too_large { "" } else { text });
        let mut checked = grm_sema::check(&mut sources, root, loader);
        if too_large {
            checked.diagnostics = vec![document_too_large(path, root)];
        }
        // What compiling finds (R01xx), as `grmc check` reports it.
        checked.diagnostics.extend(grm_compile::check(&checked));
        let deps = sources
            .iter()
            .filter(|(id, _)| *id != root)
            .map(|(_, f)| (normalize(Path::new(&f.path)), None))
            .collect();
        let broken_imports = checked.diagnostics.iter().any(|d| {
            matches!(
                d.code,
                grm_diag::Code::ImportNotFound | grm_diag::Code::InvalidEncoding
            )
        });
        FileAnalysis {
            path: path.to_path_buf(),
            version,
            sources,
            root,
            parsed: OnceLock::new(),
            checked,
            tokens: OnceLock::new(),
            deps,
            broken_imports,
        }
    }

    /// The analysed file's syntax tree and comments.
    pub fn parsed(&self) -> &Parsed {
        self.parsed
            .get_or_init(|| grm_syntax::parse(self.root, &self.sources.get(self.root).text))
    }

    /// The analysed file's tokens: kind and span, in order.
    pub(crate) fn tokens(&self) -> &[(TokKind, Span)] {
        self.tokens.get_or_init(|| {
            grm_syntax::lexer::lex_toks(self.root, &self.sources.get(self.root).text)
                .tokens
                .iter()
                .map(|t| (t.kind, t.span))
                .collect()
        })
    }

    /// The analysed file's text.
    pub fn text(&self) -> &str {
        &self.sources.get(self.root).text
    }

    /// The analysed file (text and line table).
    pub fn source(&self) -> &SourceFile {
        self.sources.get(self.root)
    }

    pub(crate) fn loc(&self, file: FileId, span: Span) -> Location {
        let f = self.sources.get(file);
        Location::new(&f.path, f, span)
    }

    /// The diagnostics whose primary label is in this file, in source order,
    /// then one for each import that leads to errors in other files (an
    /// import cycle closed there, a syntax error in a file that is not
    /// open): on the import, with the first such error's code and message
    /// and its place as related information.
    pub fn diagnostics(&self) -> Vec<Diagnostic> {
        let mut out = self.own_diagnostics();
        out.extend(self.import_diagnostics());
        out
    }

    /// Errors in imported files, reported on the root's import that
    /// (directly or through other imports) loads each file.
    fn import_diagnostics(&self) -> Vec<Diagnostic> {
        let edges = &self.checked.program.imports;
        let mut out = Vec::new();
        for (at, to) in edges
            .iter()
            .filter(|(at, to)| at.file == self.root && *to != self.root)
        {
            // The files this import reaches.
            let mut reach = vec![*to];
            let mut i = 0;
            while let Some(&f) = reach.get(i) {
                for (from, next) in edges {
                    if from.file == f && !reach.contains(next) && *next != self.root {
                        reach.push(*next);
                    }
                }
                i += 1;
            }
            let errors: Vec<&grm_diag::Diagnostic> = self
                .checked
                .diagnostics
                .iter()
                .filter(|d| d.is_error() && reach.contains(&d.primary().file))
                .collect();
            let Some(first) = errors.first() else {
                continue;
            };
            let p = first.primary();
            let file = &self.sources.get(p.file).path;
            let line = self.sources.get(p.file).line_of(p.span.start) + 1;
            let mut message = format!(
                "error in the imported file `{file}` (line {line}): {}",
                first.message
            );
            if errors.len() > 1 {
                message.push_str(&format!(
                    "\nnote: {} more error{} in imported files",
                    errors.len() - 1,
                    if errors.len() == 2 { "" } else { "s" }
                ));
            }
            message.push_str("\nhelp: open that file to see and fix it");
            out.push(Diagnostic {
                code: first.code.as_str(),
                severity: grm_diag::Severity::Error,
                message,
                span: clamp(at.span, self.text()),
                related: vec![Related {
                    location: self.loc(p.file, clamp(p.span, &self.sources.get(p.file).text)),
                    message: first.message.clone(),
                }],
                unnecessary: false,
            });
        }
        out
    }

    /// The diagnostics whose primary label is in this file, in source order.
    fn own_diagnostics(&self) -> Vec<Diagnostic> {
        self.checked
            .diagnostics
            .iter()
            .filter(|d| d.primary().file == self.root)
            .map(|d| {
                let p = d.primary();
                let mut message = d.message.clone();
                if !p.message.is_empty() && p.message != d.message {
                    message.push_str(&format!("\n{}", p.message));
                }
                for n in &d.notes {
                    message.push_str(&format!("\nnote: {n}"));
                }
                if let Some(h) = &d.help {
                    message.push_str(&format!("\nhelp: {h}"));
                }
                let related = d
                    .labels
                    .iter()
                    .skip(1)
                    .map(|l| Related {
                        location: self.loc(l.file, clamp(l.span, &self.sources.get(l.file).text)),
                        message: l.message.clone(),
                    })
                    .collect();
                Diagnostic {
                    code: d.code.as_str(),
                    severity: d.severity,
                    message,
                    span: clamp(p.span, self.text()),
                    related,
                    unnecessary: matches!(
                        d.code,
                        grm_diag::Code::UnusedParameter
                            | grm_diag::Code::UnusedDefinition
                            | grm_diag::Code::UnreachableProduction
                            | grm_diag::Code::ShadowedProduction
                    ),
                }
            })
            .collect()
    }

    /// The whole file formatted by `grm_fmt` as one edit, `Ok(None)` when
    /// it is already formatted, `Err` with the reason when it cannot be
    /// formatted (syntax errors).
    pub fn format(&self) -> Result<Option<TextEdit>, String> {
        match grm_fmt::format(self.text()) {
            Ok(out) if out == self.text() => Ok(None),
            Ok(out) => Ok(Some(TextEdit {
                span: Span::from_range(0..self.text().len()),
                new_text: out,
            })),
            Err(e) => Err(e.to_string()),
        }
    }

    /// The token (kind, span) at or just before a byte offset.
    pub(crate) fn token_at(&self, offset: u32) -> Option<(TokKind, Span)> {
        let i = self.tokens().partition_point(|(_, s)| s.start <= offset);
        let (k, s) = *self.tokens().get(i.checked_sub(1)?)?;
        (s.contains(offset) || s.end == offset).then_some((k, s))
    }

    pub(crate) fn slice(&self, span: Span) -> &str {
        self.text().get(span.range()).unwrap_or("")
    }
}

/// Clamp a span to a text's length (spans from the checker are valid; this
/// keeps a caller safe if one is not).
pub(crate) fn clamp(span: Span, text: &str) -> Span {
    let n = u32::try_from(text.len()).unwrap_or(u32::MAX);
    Span::new(span.start.min(n), span.end.min(n).max(span.start.min(n)))
}

/// An open document.
#[derive(Clone, Debug)]
struct Doc {
    version: i32,
    text: Arc<str>,
}

/// The open documents over a fallback loader.
struct Overlay<'a> {
    docs: &'a HashMap<PathBuf, Doc>,
    base: &'a dyn FileLoader,
}

/// Why a text larger than [`grm_sema::MAX_SOURCE_BYTES`] is not read, in
/// the words of `grmc` ("it is larger than 16 MiB, the most a grammar file
/// may be").
fn too_large_reason() -> String {
    format!(
        "it is larger than {} MiB, the most a grammar file may be",
        grm_sema::MAX_SOURCE_BYTES >> 20
    )
}

/// The E0405 of an open document larger than [`grm_sema::MAX_SOURCE_BYTES`]:
/// what `grmc check` says of such a file.
fn document_too_large(path: &Path, file: FileId) -> grm_diag::Diagnostic {
    grm_diag::Diagnostic::new(
        grm_diag::Code::FileUnreadable,
        format!("cannot read {}: {}", path.display(), too_large_reason()),
        file,
        Span::new(0, 0),
        "this document is not analysed",
    )
    .with_note(format!(
        "grm reads grammar files of at most {} MiB",
        grm_sema::MAX_SOURCE_BYTES >> 20
    ))
}

impl FileLoader for Overlay<'_> {
    /// An open document is read as its text, refused over
    /// [`grm_sema::MAX_SOURCE_BYTES`] as the file would be.
    fn read(&self, path: &Path) -> Result<String, LoadError> {
        match self.docs.get(&normalize(path)) {
            Some(d) if d.text.len() as u64 > grm_sema::MAX_SOURCE_BYTES => {
                Err(LoadError::Other(too_large_reason()))
            }
            Some(d) => Ok(d.text.to_string()),
            None => self.base.read(path),
        }
    }

    fn exists(&self, path: &Path) -> bool {
        self.docs.contains_key(&normalize(path)) || self.base.exists(path)
    }

    fn resolve(&self, from: &Path, written: &str) -> PathBuf {
        self.base.resolve(from, written)
    }
}

/// The analysis host: open documents and cached analyses.
pub struct Analysis {
    docs: HashMap<PathBuf, Doc>,
    cache: HashMap<PathBuf, Arc<FileAnalysis>>,
    base: Arc<dyn FileLoader + Send + Sync>,
    /// `.grm` files of the workspace that may not be open (read through
    /// the loader): searched by workspace symbols, references and rename.
    workspace: std::collections::BTreeSet<PathBuf>,
}

/// The cached analysis, or the work to make it (see [`Analysis::lookup`]).
#[derive(Debug)]
pub enum Lookup {
    Ready(Arc<FileAnalysis>),
    Run(Job),
}

/// Parsing and checking one file against a snapshot of the open documents.
#[must_use = "a job does nothing until it is run"]
pub struct Job {
    key: PathBuf,
    /// The open document's version and text; `None` to read the file
    /// through the loader (as version -1).
    text: Option<(i32, Arc<str>)>,
    docs: HashMap<PathBuf, Doc>,
    base: Arc<dyn FileLoader + Send + Sync>,
}

impl std::fmt::Debug for Job {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Job")
            .field("key", &self.key)
            .finish_non_exhaustive()
    }
}

impl Job {
    /// Do the work; `None` when the file is not open and cannot be read.
    pub fn run(self) -> Option<FileAnalysis> {
        let (version, text) = match self.text {
            Some(t) => t,
            None => (-1, Arc::from(self.base.read(&self.key).ok()?)),
        };
        let overlay = Overlay {
            docs: &self.docs,
            base: &*self.base,
        };
        let mut fa = FileAnalysis::new(&self.key, version, &text, &overlay);
        for (p, v) in &mut fa.deps {
            *v = self.docs.get(p).map(|d| d.version);
        }
        Some(fa)
    }
}

impl std::fmt::Debug for Analysis {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Analysis")
            .field("docs", &self.docs.len())
            .field("cached", &self.cache.len())
            .finish()
    }
}

impl Default for Analysis {
    fn default() -> Self {
        Analysis::new(Arc::new(FsLoader))
    }
}

impl Analysis {
    /// A host reading files that are not open through `base`.
    pub fn new(base: Arc<dyn FileLoader + Send + Sync>) -> Analysis {
        Analysis {
            docs: HashMap::new(),
            cache: HashMap::new(),
            base,
            workspace: std::collections::BTreeSet::new(),
        }
    }

    /// Open a document or replace its text.
    pub fn set_document(&mut self, path: &Path, version: i32, text: impl Into<Arc<str>>) {
        let key = normalize(path);
        self.docs.insert(
            key.clone(),
            Doc {
                version,
                text: text.into(),
            },
        );
        // The text changed: never serve the old analysis, even if a client
        // reuses a version number.
        self.cache.remove(&key);
        self.changed(&key);
    }

    /// Close a document: imports of it are read through the loader again.
    pub fn close_document(&mut self, path: &Path) {
        let key = normalize(path);
        self.docs.remove(&key);
        self.cache.remove(&key);
        self.changed(&key);
    }

    /// A file changed outside the editor (e.g. on disk).
    pub fn file_changed(&mut self, path: &Path) {
        let key = normalize(path);
        if !self.docs.contains_key(&key) {
            self.cache.remove(&key);
        }
        self.changed(&key);
    }

    fn changed(&mut self, key: &Path) {
        self.cache
            .retain(|_, fa| !fa.broken_imports && !fa.deps.iter().any(|(p, _)| p == key));
    }

    /// The version and text of an open document.
    pub fn document(&self, path: &Path) -> Option<(i32, Arc<str>)> {
        self.docs
            .get(&normalize(path))
            .map(|d| (d.version, d.text.clone()))
    }

    /// The open documents' paths.
    pub fn documents(&self) -> Vec<PathBuf> {
        let mut v: Vec<PathBuf> = self.docs.keys().cloned().collect();
        v.sort();
        v
    }

    /// Make a workspace file known (or forget it): it is searched even when
    /// it is not open.
    pub fn set_workspace_file(&mut self, path: &Path, present: bool) {
        let key = normalize(path);
        if present {
            self.workspace.insert(key);
        } else {
            self.workspace.remove(&key);
        }
    }

    /// The open documents and the known workspace files, sorted.
    pub fn known_files(&self) -> Vec<PathBuf> {
        let mut v: Vec<PathBuf> = self
            .docs
            .keys()
            .chain(self.workspace.iter())
            .cloned()
            .collect();
        v.sort();
        v.dedup();
        v
    }

    /// The analysis of an open document (or of a file the loader can read,
    /// as version -1), computed now if the cached one is stale.
    pub fn analyze(&mut self, path: &Path) -> Option<Arc<FileAnalysis>> {
        match self.lookup(path) {
            Lookup::Ready(fa) => Some(fa),
            Lookup::Run(job) => Some(self.store(job.run()?)),
        }
    }

    /// The cached analysis of `path` if it is current, or the work to make
    /// it: run the [`Job`] without holding the host (it has its own
    /// snapshot of the open documents), then [`Analysis::store`] the result.
    pub fn lookup(&self, path: &Path) -> Lookup {
        let key = normalize(path);
        let cached = self.cache.get(&key);
        let text = match self.docs.get(&key) {
            Some(d) => {
                if let Some(fa) = cached
                    && fa.version == d.version
                    && fa
                        .deps
                        .iter()
                        .all(|(p, v)| self.docs.get(p).map(|d| d.version) == *v)
                {
                    return Lookup::Ready(fa.clone());
                }
                Some((d.version, d.text.clone()))
            }
            // A file that is not open: cached until it changes on disk.
            None => match cached {
                Some(fa) => return Lookup::Ready(fa.clone()),
                None => None,
            },
        };
        Lookup::Run(Job {
            key,
            text,
            docs: self.docs.clone(),
            base: self.base.clone(),
        })
    }

    /// Keep a finished analysis (unless its document moved on meanwhile)
    /// and hand it out.
    pub fn store(&mut self, fa: FileAnalysis) -> Arc<FileAnalysis> {
        let fa = Arc::new(fa);
        let current = match self.docs.get(&fa.path) {
            Some(d) => d.version == fa.version,
            None => fa.version == -1,
        };
        let deps_current = fa
            .deps
            .iter()
            .all(|(p, v)| self.docs.get(p).map(|d| d.version) == *v);
        if current && deps_current {
            self.cache.insert(fa.path.clone(), fa.clone());
        }
        fa
    }

    /// Open documents other than `path` whose last analysis read `path`
    /// (their diagnostics may change when it does).
    pub fn dependents(&self, path: &Path) -> Vec<PathBuf> {
        let key = normalize(path);
        let mut v: Vec<PathBuf> = self
            .docs
            .keys()
            .filter(|d| **d != key)
            .filter(|d| {
                self.cache
                    .get(*d)
                    .is_none_or(|fa| fa.broken_imports || fa.deps.iter().any(|(p, _)| *p == key))
            })
            .cloned()
            .collect();
        v.sort();
        v
    }

    /// The loader used for files that are not open.
    pub fn loader(&self) -> Arc<dyn FileLoader + Send + Sync> {
        self.base.clone()
    }
}

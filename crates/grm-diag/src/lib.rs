//! `grm-diag`: the diagnostics every grm phase reports.
//!
//! Role: the bottom of the crate graph. It owns byte spans, the table of
//! source files, the coded [`Diagnostic`] type and its two renderings (human
//! text through ariadne, and JSON for tools).
//!
//! Inputs: spans and messages built by the phases (lexer, parser, checker,
//! engine). Outputs: rendered text or JSON.
//!
//! Invariants:
//! - Spans are byte offsets into the UTF-8 text of one file (`start <= end
//!   <= text.len()`); rendering clamps out-of-range spans instead of
//!   panicking, so a bug elsewhere can never crash the reporter.
//! - Every diagnostic carries a stable [`Code`] from the one list in
//!   [`codes`]; its severity comes from that code.
//! - Exactly one label of a diagnostic is primary (the first one pushed by
//!   [`Diagnostic::new`]).

pub mod codes;
mod render;

pub use codes::Code;
pub use render::{render_human, render_json, render_plain, to_json};

use serde::Serialize;

/// A half-open byte range `start..end` in one source file.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Default, Serialize)]
pub struct Span {
    pub start: u32,
    pub end: u32,
}

impl Span {
    pub const fn new(start: u32, end: u32) -> Span {
        Span { start, end }
    }

    /// Build a span from `usize` offsets (saturating at `u32::MAX`; grm
    /// refuses files larger than 4 GiB before they get here).
    pub fn from_range(r: std::ops::Range<usize>) -> Span {
        let c = |x: usize| u32::try_from(x).unwrap_or(u32::MAX);
        Span::new(c(r.start), c(r.end))
    }

    /// The smallest span covering both.
    pub fn to(self, other: Span) -> Span {
        Span::new(self.start.min(other.start), self.end.max(other.end))
    }

    pub fn len(self) -> u32 {
        self.end.saturating_sub(self.start)
    }

    pub fn is_empty(self) -> bool {
        self.len() == 0
    }

    pub fn range(self) -> std::ops::Range<usize> {
        self.start as usize..self.end as usize
    }

    pub fn contains(self, offset: u32) -> bool {
        self.start <= offset && offset < self.end
    }
}

/// Identifies a file in a [`SourceMap`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Default, Serialize)]
pub struct FileId(pub u32);

/// One source file: its display path and its text.
#[derive(Clone, Debug)]
pub struct SourceFile {
    pub path: String,
    pub text: String,
    line_starts: Vec<u32>,
}

impl SourceFile {
    pub fn new(path: impl Into<String>, text: impl Into<String>) -> SourceFile {
        let text = text.into();
        let mut line_starts = vec![0u32];
        for (i, b) in text.bytes().enumerate() {
            if b == b'\n' {
                line_starts.push(u32::try_from(i + 1).unwrap_or(u32::MAX));
            }
        }
        SourceFile {
            path: path.into(),
            text,
            line_starts,
        }
    }

    /// Zero-based line and zero-based column in Unicode scalar values of a
    /// byte offset (clamped to the text, and to a char boundary).
    pub fn line_col(&self, offset: u32) -> (u32, u32) {
        let offset = clamp_to_boundary(&self.text, offset as usize);
        let line = match self.line_starts.binary_search(&(offset as u32)) {
            Ok(i) => i,
            Err(i) => i - 1, // line_starts[0] == 0 <= offset, so i >= 1
        };
        let start = self.line_starts[line] as usize;
        let col = self.text[start..offset].chars().count();
        (line as u32, col as u32)
    }

    /// Zero-based line and zero-based column in UTF-16 code units, as the
    /// Language Server Protocol counts them.
    pub fn line_col_utf16(&self, offset: u32) -> (u32, u32) {
        let offset = clamp_to_boundary(&self.text, offset as usize);
        let (line, _) = self.line_col(offset as u32);
        let start = self.line_starts[line as usize] as usize;
        let col: usize = self.text[start..offset].chars().map(char::len_utf16).sum();
        (line, col as u32)
    }

    /// Byte offset of a zero-based (line, UTF-16 column) position, clamped
    /// to the line's end.
    pub fn offset_of_utf16(&self, line: u32, col: u32) -> u32 {
        let Some(&start) = self.line_starts.get(line as usize) else {
            return self.text.len() as u32;
        };
        let end = self
            .line_starts
            .get(line as usize + 1)
            .map(|&e| e as usize)
            .unwrap_or(self.text.len());
        let mut units = 0u32;
        for (i, c) in self.text[start as usize..end].char_indices() {
            if units >= col || c == '\n' {
                return start + i as u32;
            }
            units += c.len_utf16() as u32;
        }
        end as u32
    }

    pub fn line_count(&self) -> usize {
        self.line_starts.len()
    }
}

fn clamp_to_boundary(text: &str, mut offset: usize) -> usize {
    offset = offset.min(text.len());
    while !text.is_char_boundary(offset) {
        offset -= 1;
    }
    offset
}

/// The files of one run: the file given on the command line and all it
/// imports.
#[derive(Clone, Debug, Default)]
pub struct SourceMap {
    files: Vec<SourceFile>,
}

impl SourceMap {
    pub fn new() -> SourceMap {
        SourceMap::default()
    }

    pub fn add(&mut self, path: impl Into<String>, text: impl Into<String>) -> FileId {
        let id = FileId(self.files.len() as u32);
        self.files.push(SourceFile::new(path, text));
        id
    }

    /// The file with this id. Ids are only made by [`SourceMap::add`], so a
    /// foreign id is a programming error; it falls back to an empty file
    /// rather than panicking.
    pub fn get(&self, id: FileId) -> &SourceFile {
        static EMPTY: std::sync::OnceLock<SourceFile> = std::sync::OnceLock::new();
        self.files
            .get(id.0 as usize)
            .unwrap_or_else(|| EMPTY.get_or_init(|| SourceFile::new("<unknown>", "")))
    }

    pub fn find(&self, path: &str) -> Option<FileId> {
        self.files
            .iter()
            .position(|f| f.path == path)
            .map(|i| FileId(i as u32))
    }

    pub fn iter(&self) -> impl Iterator<Item = (FileId, &SourceFile)> {
        self.files
            .iter()
            .enumerate()
            .map(|(i, f)| (FileId(i as u32), f))
    }
}

/// How bad a diagnostic is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Severity {
    Error,
    Warning,
}

/// A labelled span.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct Label {
    pub file: FileId,
    pub span: Span,
    pub message: String,
    pub primary: bool,
}

/// A coded diagnostic: what is wrong, where, and how to fix it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Diagnostic {
    pub code: Code,
    pub severity: Severity,
    pub message: String,
    /// The first label is the primary one.
    pub labels: Vec<Label>,
    pub notes: Vec<String>,
    pub help: Option<String>,
}

impl Diagnostic {
    /// A diagnostic with its primary label.
    pub fn new(
        code: Code,
        message: impl Into<String>,
        file: FileId,
        span: Span,
        label: impl Into<String>,
    ) -> Diagnostic {
        Diagnostic {
            code,
            severity: code.severity(),
            message: message.into(),
            labels: vec![Label {
                file,
                span,
                message: label.into(),
                primary: true,
            }],
            notes: Vec::new(),
            help: None,
        }
    }

    /// Add a secondary label.
    pub fn with_label(mut self, file: FileId, span: Span, message: impl Into<String>) -> Self {
        self.labels.push(Label {
            file,
            span,
            message: message.into(),
            primary: false,
        });
        self
    }

    pub fn with_note(mut self, note: impl Into<String>) -> Self {
        self.notes.push(note.into());
        self
    }

    pub fn with_help(mut self, help: impl Into<String>) -> Self {
        self.help = Some(help.into());
        self
    }

    pub fn primary(&self) -> &Label {
        // `new` always pushes the primary label first and labels are never removed.
        &self.labels[0]
    }

    pub fn is_error(&self) -> bool {
        self.severity == Severity::Error
    }
}

/// Sort diagnostics by file, then position, then code, so output is stable.
pub fn sort(diags: &mut [Diagnostic]) {
    diags.sort_by(|a, b| {
        let (pa, pb) = (a.primary(), b.primary());
        (pa.file, pa.span.start, pa.span.end, a.code).cmp(&(
            pb.file,
            pb.span.start,
            pb.span.end,
            b.code,
        ))
    });
}

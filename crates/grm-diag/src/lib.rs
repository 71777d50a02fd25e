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
//! - Lines end at `\n`, `\r\n` (one line break) or a lone `\r`, as the
//!   Language Server Protocol defines them: [`SourceFile`]'s line table is
//!   the one count of lines, for the human and JSON renderings and for the
//!   LSP positions alike.

pub mod codes;
pub mod input;
mod render;

pub use codes::Code;
pub use render::{
    HumanRenderer, is_bidi_control, render_human, render_json, render_plain, to_json,
};

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

/// One source file: its display path, its text, and an index of where
/// its lines start.
///
/// A line ends at `\n`, at `\r\n` (one line break) or at a lone `\r`, as
/// the Language Server Protocol defines it; the compiler's rendered
/// diagnostics, the JSON output and the LSP positions all count lines this
/// way. No position is inside a line break: an offset between the `\r` and
/// the `\n` of a `\r\n` is the end of its line, before the `\r`.
#[derive(Clone, Debug)]
pub struct SourceFile {
    pub path: String,
    pub text: String,
    /// The byte offset of each line's first byte; `line_starts[0] == 0`,
    /// and every other entry directly follows a line break.
    line_starts: Vec<u32>,
}

/// The byte offset of each line's first byte in `text` (lines end at `\n`,
/// `\r\n` or a lone `\r`).
fn line_starts(text: &str) -> Vec<u32> {
    let bytes = text.as_bytes();
    let mut starts = vec![0u32];
    for (i, &b) in bytes.iter().enumerate() {
        // A `\r` followed by `\n` is the first half of one `\r\n`: the
        // line starts after the `\n`, which pushes it.
        let brk = b == b'\n' || (b == b'\r' && bytes.get(i + 1) != Some(&b'\n'));
        if brk {
            starts.push(u32::try_from(i + 1).unwrap_or(u32::MAX));
        }
    }
    starts
}

/// Whether `text` contains a line break (`\n`, `\r\n` or a lone `\r`).
/// A byte count in MiB for a message, the one format every limit message
/// uses: two decimals below 10 MiB (so 1 MiB and 0.01 MiB are told
/// apart), whole MiB from there.
pub fn mib(bytes: u64) -> String {
    let m = bytes as f64 / f64::from(1u32 << 20);
    if m < 10.0 {
        format!("{m:.2} MiB")
    } else {
        format!("{m:.0} MiB")
    }
}

pub fn has_line_break(text: &str) -> bool {
    text.bytes().any(|b| b == b'\n' || b == b'\r')
}

/// The number of line breaks in `text`; a `\r\n` is one.
pub fn count_line_breaks(text: &str) -> usize {
    let bytes = text.as_bytes();
    bytes
        .iter()
        .enumerate()
        .filter(|&(i, &b)| b == b'\n' || (b == b'\r' && bytes.get(i + 1) != Some(&b'\n')))
        .count()
}

/// The byte offset of the first line break in `text` (of the `\r` of a
/// `\r\n`), or its length if it has none: the length of its first line.
pub fn first_line_len(text: &str) -> usize {
    text.bytes()
        .position(|b| b == b'\n' || b == b'\r')
        .unwrap_or(text.len())
}

impl SourceFile {
    pub fn new(path: impl Into<String>, text: impl Into<String>) -> SourceFile {
        let text = text.into();
        let line_starts = line_starts(&text);
        SourceFile {
            path: path.into(),
            text,
            line_starts,
        }
    }

    /// The zero-based line of a byte offset (clamped to the text).
    pub fn line_of(&self, offset: u32) -> u32 {
        // `line_starts[0] == 0 <= offset`, so the count is at least 1.
        let after = self.line_starts.partition_point(|&s| s <= offset);
        after.saturating_sub(1) as u32
    }

    /// The byte offset where a zero-based line starts, if the file has it.
    pub fn line_start(&self, line: u32) -> Option<u32> {
        self.line_starts.get(line as usize).copied()
    }

    /// The byte offset where the text of a zero-based line ends, before its
    /// line break (the text's length for the last line), if the file has it.
    pub fn line_end(&self, line: u32) -> Option<u32> {
        let line = line as usize;
        if line >= self.line_starts.len() {
            return None;
        }
        let Some(&next) = self.line_starts.get(line + 1) else {
            return Some(self.text.len() as u32);
        };
        // `next` directly follows a `\n` or a lone `\r`; a `\n` may be the
        // second half of a `\r\n`.
        let b = self.text.as_bytes();
        let n = next as usize;
        let len = if n >= 2 && b.get(n - 1) == Some(&b'\n') && b.get(n - 2) == Some(&b'\r') {
            2
        } else {
            1
        };
        Some(next.saturating_sub(len))
    }

    /// An offset as a position: clamped to the text and to a char boundary,
    /// and moved out of a `\r\n` to its line's end. Returns the line, the
    /// byte offset of its start, and the offset.
    fn locate(&self, offset: u32) -> (u32, usize, usize) {
        let offset = clamp_to_boundary(&self.text, offset as usize);
        let line = self.line_of(offset as u32);
        let start = self.line_start(line).unwrap_or(0) as usize;
        let end = self.line_end(line).map_or(offset, |e| e as usize);
        // `start <= offset` by the search; `end` is at a char boundary (just
        // before an ASCII line break, or the text's end).
        (line, start, offset.min(end).max(start))
    }

    /// Zero-based line and zero-based column in Unicode scalar values of a
    /// byte offset (clamped to the text, and to a char boundary).
    pub fn line_col(&self, offset: u32) -> (u32, u32) {
        let (line, start, offset) = self.locate(offset);
        let col = self
            .text
            .get(start..offset)
            .map_or(0, |s| s.chars().count());
        (line, col as u32)
    }

    /// Zero-based line and zero-based column in UTF-16 code units, as the
    /// Language Server Protocol counts them.
    pub fn line_col_utf16(&self, offset: u32) -> (u32, u32) {
        let (line, start, offset) = self.locate(offset);
        let col: usize = self
            .text
            .get(start..offset)
            .map_or(0, |s| s.chars().map(char::len_utf16).sum());
        (line, col as u32)
    }

    /// Byte offset of a zero-based (line, UTF-16 column) position, clamped
    /// to the line's end (before its line break); a line past the last one
    /// is the end of the text.
    pub fn offset_of_utf16(&self, line: u32, col: u32) -> u32 {
        let (Some(start), Some(end)) = (self.line_start(line), self.line_end(line)) else {
            return self.text.len() as u32;
        };
        let Some(text) = self.text.get(start as usize..end as usize) else {
            return end;
        };
        let mut units = 0u32;
        for (i, c) in text.char_indices() {
            if units >= col {
                return start + i as u32;
            }
            units += c.len_utf16() as u32;
        }
        end
    }

    pub fn line_count(&self) -> usize {
        self.line_starts.len()
    }
}

/// `offset` clamped to the text and moved back to a char boundary.
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

#[cfg(test)]
mod tests {
    use super::*;

    fn sf(text: &str) -> SourceFile {
        SourceFile::new("t.grm", text)
    }

    /// Every line's (start, end) as the index has it.
    fn lines(f: &SourceFile) -> Vec<(u32, u32)> {
        (0..f.line_count() as u32)
            .map(|l| (f.line_start(l).unwrap(), f.line_end(l).unwrap()))
            .collect()
    }

    #[test]
    fn line_feed_lines() {
        let f = sf("ab\ncd\n");
        assert_eq!(lines(&f), vec![(0, 2), (3, 5), (6, 6)]);
        assert_eq!(f.line_col(4), (1, 1));
        assert_eq!(f.line_col_utf16(6), (2, 0));
        assert_eq!(f.offset_of_utf16(1, 1), 4);
    }

    #[test]
    fn a_lone_carriage_return_ends_a_line() {
        let f = sf("ab\rcd\ref");
        assert_eq!(f.line_count(), 3);
        assert_eq!(lines(&f), vec![(0, 2), (3, 5), (6, 8)]);
        assert_eq!(f.line_col(3), (1, 0));
        assert_eq!(f.line_col_utf16(4), (1, 1));
        assert_eq!(f.line_col_utf16(7), (2, 1));
        assert_eq!(f.offset_of_utf16(1, 0), 3);
        assert_eq!(f.offset_of_utf16(2, 2), 8);
        // The `\r` itself is the end of its line.
        assert_eq!(f.line_col_utf16(2), (0, 2));
        assert_eq!(f.line_of(2), 0);
        assert_eq!(f.line_of(3), 1);
    }

    #[test]
    fn crlf_is_one_line_break() {
        let f = sf("ab\r\ncd\r\n");
        assert_eq!(f.line_count(), 3);
        assert_eq!(lines(&f), vec![(0, 2), (4, 6), (8, 8)]);
        assert_eq!(f.line_col_utf16(4), (1, 0));
        // No position inside a `\r\n`: between its `\r` and `\n` is the
        // line's end, before the `\r`.
        assert_eq!(f.line_col_utf16(3), (0, 2));
        assert_eq!(f.line_col(3), (0, 2));
        assert_eq!(f.line_col_utf16(7), (1, 2));
        assert_eq!(count_line_breaks(&f.text), 2);
    }

    #[test]
    fn mixed_line_breaks() {
        // `\r\r\n` is a lone `\r` and then a `\r\n`: two breaks, and an
        // empty line between them; `\n\r` is two breaks too.
        let text = "a\nb\r\nc\rd\r\r\ne\n\rf";
        let f = sf(text);
        assert_eq!(
            lines(&f),
            vec![
                (0, 1),   // a \n
                (2, 3),   // b \r\n
                (5, 6),   // c \r
                (7, 8),   // d \r
                (9, 9),   // (empty) \r\n
                (11, 12), // e \n
                (13, 13), // (empty) \r
                (14, 15), // f
            ]
        );
        assert_eq!(count_line_breaks(text), 7);
        for (line, &(s, e)) in lines(&f).iter().enumerate() {
            assert_eq!(f.line_col_utf16(s), (line as u32, 0));
            assert_eq!(f.line_col_utf16(e), (line as u32, e - s));
            assert_eq!(f.offset_of_utf16(line as u32, 0), s);
            assert_eq!(f.offset_of_utf16(line as u32, 99), e);
        }
    }

    #[test]
    fn carriage_return_at_end_of_file() {
        let f = sf("ab\r");
        assert_eq!(lines(&f), vec![(0, 2), (3, 3)]);
        assert_eq!(f.line_col_utf16(3), (1, 0));
        assert_eq!(f.offset_of_utf16(1, 0), 3);
        assert_eq!(f.offset_of_utf16(1, 5), 3);
        // A line past the last one is the end of the text.
        assert_eq!(f.offset_of_utf16(2, 0), 3);
        let f = sf("ab\r\n");
        assert_eq!(lines(&f), vec![(0, 2), (4, 4)]);
        let f = sf("\r");
        assert_eq!(lines(&f), vec![(0, 0), (1, 1)]);
        let f = sf("");
        assert_eq!(lines(&f), vec![(0, 0)]);
        assert_eq!(f.line_col_utf16(10), (0, 0));
        assert_eq!(f.offset_of_utf16(0, 3), 0);
    }

    #[test]
    fn a_position_past_the_end_of_a_line_is_before_its_break() {
        for (text, end) in [("abc\nx", 3), ("abc\r\nx", 3), ("abc\rx", 3)] {
            let f = sf(text);
            assert_eq!(f.offset_of_utf16(0, 3), end, "{text:?}");
            assert_eq!(f.offset_of_utf16(0, 4), end, "{text:?}");
            assert_eq!(f.offset_of_utf16(0, u32::MAX), end, "{text:?}");
            assert_eq!(f.line_col_utf16(end), (0, 3), "{text:?}");
            // The next line's start is never reached from line 0.
            assert_eq!(f.offset_of_utf16(1, 0), text.len() as u32 - 1);
        }
    }

    #[test]
    fn utf16_columns_after_a_lone_carriage_return() {
        // `é` is 2 bytes and 1 UTF-16 unit, `𝄞` 4 bytes and 2 units.
        let text = "é\r𝄞é=x\r";
        let f = sf(text);
        let x = text.find('x').unwrap() as u32;
        assert_eq!(f.line_col_utf16(x), (1, 4));
        assert_eq!(f.line_col(x), (1, 3));
        assert_eq!(f.offset_of_utf16(1, 4), x);
        assert_eq!(f.offset_of_utf16(1, 2), text.find("é=").unwrap() as u32);
        // The end of line 1 is before its `\r`.
        assert_eq!(f.offset_of_utf16(1, 50), x + 1);
        assert_eq!(f.line_col_utf16(x + 1), (1, 5));
        // Offsets inside a character are moved back to its start.
        assert_eq!(f.line_col_utf16(4), (1, 0));
    }

    #[test]
    fn position_round_trips() {
        let text = "a é\r\n𝄞 b\rc\n\rd\r";
        let f = sf(text);
        for (i, _) in text.char_indices() {
            let i = i as u32;
            let (l, c) = f.line_col_utf16(i);
            let back = f.offset_of_utf16(l, c);
            // Every offset but the `\n` of a `\r\n` is a position of its own.
            let inside_crlf = text.as_bytes()[i as usize] == b'\n'
                && i > 0
                && text.as_bytes()[i as usize - 1] == b'\r';
            if inside_crlf {
                assert_eq!(back, i - 1);
            } else {
                assert_eq!(back, i, "offset {i}: ({l}, {c})");
            }
        }
    }

    #[test]
    fn line_break_helpers() {
        assert!(!has_line_break("a b\x0c"));
        assert!(has_line_break("a\rb"));
        assert!(has_line_break("a\nb"));
        assert_eq!(count_line_breaks("a\r\n\r\n"), 2);
        assert_eq!(count_line_breaks("\r\r"), 2);
        assert_eq!(count_line_breaks("\n\r"), 2);
        assert_eq!(first_line_len("ab\r\ncd"), 2);
        assert_eq!(first_line_len("ab\rcd"), 2);
        assert_eq!(first_line_len("ab\ncd"), 2);
        assert_eq!(first_line_len("abc"), 3);
    }
}

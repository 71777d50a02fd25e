//! What can be wrong with an edits file: one [`EditsError`] per problem,
//! each with a stable code (R0901 to R0911) and the byte range in the
//! file it is about.

use grm_diag::{Code, Diagnostic, FileId, Span};
use std::fmt;

/// A problem with an edits file. `span` is a byte range of the file's
/// text (empty for [`EditsErrorKind::Io`], which has no text); `edit` the
/// id of the edit it is in, when that edit has a readable id.
#[derive(Clone, Debug, PartialEq)]
pub struct EditsError {
    pub kind: EditsErrorKind,
    pub span: Span,
    pub edit: Option<u32>,
}

/// The kinds of problem, one code each (several kinds may share one).
#[derive(Clone, Debug, PartialEq)]
pub enum EditsErrorKind {
    /// R0901: the file could not be read; `path` and the reason.
    Io { path: String, message: String },
    /// R0902: not JSON (the parser's message).
    Syntax { message: String },
    /// R0903: `version` missing (`found: None`) or not one this crate
    /// reads (its text).
    Version { found: Option<String> },
    /// R0904: the top level is not an object with an `edits` array (the
    /// whole file is refused).
    Structure { problem: String },
    /// R0904: an element of `edits` that is not an object (it is skipped).
    NotAnObject,
    /// R0905: a field no edit has (`op: None`, or at the top level), or
    /// that an edit of operation `op` does not have.
    UnknownField { field: String, op: Option<String> },
    /// R0905: a field given twice in one object.
    RepeatedField { field: String },
    /// R0906: a field the edit needs.
    MissingField { field: &'static str },
    /// R0907: a field of the wrong JSON type.
    FieldType {
        field: String,
        expected: &'static str,
    },
    /// R0908: an operation that does not exist.
    UnknownOp { op: String },
    /// R0909: a target that is not exactly one of the three forms, or
    /// whose text does not read (`problem` says which).
    BadTarget { problem: String },
    /// R0910: an id used by an earlier edit (at `first`); this one is skipped.
    DuplicateId { id: u32, first: Span },
    /// R0911: a value out of its range.
    BadValue { field: String, problem: String },
}

impl EditsError {
    pub(crate) fn new(kind: EditsErrorKind, span: Span) -> EditsError {
        EditsError {
            kind,
            span,
            edit: None,
        }
    }

    /// The stable code.
    pub fn code(&self) -> Code {
        match self.kind {
            EditsErrorKind::Io { .. } => Code::EditsIo,
            EditsErrorKind::Syntax { .. } => Code::EditsSyntax,
            EditsErrorKind::Version { .. } => Code::EditsVersion,
            EditsErrorKind::Structure { .. } | EditsErrorKind::NotAnObject => Code::EditsStructure,
            EditsErrorKind::UnknownField { .. } | EditsErrorKind::RepeatedField { .. } => {
                Code::EditsUnknownField
            }
            EditsErrorKind::MissingField { .. } => Code::EditsMissingField,
            EditsErrorKind::FieldType { .. } => Code::EditsFieldType,
            EditsErrorKind::UnknownOp { .. } => Code::EditsUnknownOp,
            EditsErrorKind::BadTarget { .. } => Code::EditsBadTarget,
            EditsErrorKind::DuplicateId { .. } => Code::EditsDuplicateId,
            EditsErrorKind::BadValue { .. } => Code::EditsBadValue,
        }
    }

    /// Whether the whole file was refused (read, JSON, version or top
    /// level), rather than one edit skipped.
    pub fn is_fatal(&self) -> bool {
        matches!(
            self.kind,
            EditsErrorKind::Io { .. }
                | EditsErrorKind::Syntax { .. }
                | EditsErrorKind::Version { .. }
                | EditsErrorKind::Structure { .. }
        )
    }

    /// Whether this is a read error for a file that does not exist (the
    /// default edits file beside a grammar may well not exist: no edits).
    pub fn is_not_found(&self) -> bool {
        matches!(&self.kind, EditsErrorKind::Io { message, .. } if message == NOT_FOUND)
    }

    /// The error as a diagnostic in the edits file `file` (its text added
    /// to the source map), labelled at [`EditsError::span`]. A read error
    /// (R0901) has no text to point into: give it
    /// [`EditsError::to_diagnostic_at`] the grammar's system instead.
    pub fn to_diagnostic(&self, file: FileId) -> Diagnostic {
        self.to_diagnostic_at(file, self.span)
    }

    /// The error as a diagnostic labelled at `file`/`span`.
    pub fn to_diagnostic_at(&self, file: FileId, span: Span) -> Diagnostic {
        let (label, help) = match &self.kind {
            EditsErrorKind::Io { .. } => (
                "edited by this file",
                "the edits file is NAME.edits.json beside NAME.grm; `--edits FILE` names another, `--no-edits` skips it",
            ),
            EditsErrorKind::Syntax { .. } => ("here", "the edits file is JSON: fix it here"),
            EditsErrorKind::Version { .. } => (
                "here",
                "write `\"version\": 3`, the format docs/edits.md describes",
            ),
            EditsErrorKind::Structure { .. } => (
                "here",
                "an edits file is `{ \"version\": 2, \"edits\": [ { ... }, ... ] }` (docs/edits.md)",
            ),
            EditsErrorKind::NotAnObject => (
                "this element is skipped",
                "each element of `edits` is an object: `{ \"id\": 1, \"system\": ..., \"target\": ..., \"op\": ... }`",
            ),
            EditsErrorKind::UnknownField { .. } | EditsErrorKind::RepeatedField { .. } => (
                "this edit is skipped",
                "docs/edits.md lists each operation's fields",
            ),
            EditsErrorKind::MissingField { .. } => (
                "this edit is skipped",
                "every edit has `id`, `system`, `target` and `op`, and its operation's fields (docs/edits.md)",
            ),
            EditsErrorKind::FieldType { .. } => (
                "this edit is skipped",
                "docs/edits.md gives each field's type",
            ),
            EditsErrorKind::UnknownOp { .. } => (
                "this edit is skipped",
                "the operations are set, offset, force, pin, material, mesh and remove",
            ),
            EditsErrorKind::BadTarget { .. } => (
                "this edit is skipped",
                "a target is one of { \"exact\": \"{Lot, 1, Facade}\" }, { \"semantic\": \"(floor = 3) Window\" }, { \"key\": \"0a1b2c3d\" }",
            ),
            EditsErrorKind::DuplicateId { .. } => (
                "this edit is skipped",
                "give it an id no other edit has (the largest id plus 1)",
            ),
            EditsErrorKind::BadValue { .. } => (
                "this edit is skipped",
                "docs/edits.md gives each field's range",
            ),
        };
        let mut d =
            Diagnostic::new(self.code(), self.to_string(), file, span, label).with_help(help);
        if let EditsErrorKind::DuplicateId { first, .. } = &self.kind {
            d = d.with_label(file, *first, "the first edit with this id");
        }
        d
    }
}

/// The message of a read error for a missing file.
pub(crate) const NOT_FOUND: &str = "it does not exist";

impl fmt::Display for EditsError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(id) = self.edit {
            write!(f, "edit {id}: ")?;
        }
        match &self.kind {
            EditsErrorKind::Io { path, message } => write!(f, "cannot read {path}: {message}"),
            EditsErrorKind::Syntax { message } => write!(f, "invalid JSON: {message}"),
            EditsErrorKind::Version { found: None } => {
                write!(
                    f,
                    "the edits file has no `version` (this grm reads versions 1 to 3)"
                )
            }
            EditsErrorKind::Version { found: Some(v) } => write!(
                f,
                "version {v} is not supported (this grm reads versions 1 to 3)"
            ),
            EditsErrorKind::Structure { problem } => f.write_str(problem),
            EditsErrorKind::NotAnObject => f.write_str("an element of `edits` is not an object"),
            EditsErrorKind::UnknownField { field, op: None } => {
                write!(f, "unknown field `{field}`")
            }
            EditsErrorKind::UnknownField {
                field,
                op: Some(op),
            } => write!(f, "a `{op}` edit has no field `{field}`"),
            EditsErrorKind::RepeatedField { field } => write!(f, "field `{field}` is given twice"),
            EditsErrorKind::MissingField { field } => write!(f, "no `{field}` field"),
            EditsErrorKind::FieldType { field, expected } => {
                write!(f, "`{field}` must be {expected}")
            }
            EditsErrorKind::UnknownOp { op } => write!(f, "unknown operation `{op}`"),
            EditsErrorKind::BadTarget { problem } => write!(f, "invalid target: {problem}"),
            EditsErrorKind::DuplicateId { id, .. } => {
                write!(f, "id {id} is already used by an earlier edit")
            }
            EditsErrorKind::BadValue { field, problem } => write!(f, "`{field}` {problem}"),
        }
    }
}

impl std::error::Error for EditsError {}

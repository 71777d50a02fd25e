//! The edits file: its types, the tolerant reader ([`parse`]), the
//! canonical writer ([`write`]) and the changes an editor makes
//! ([`EditsFile::add`], [`EditsFile::remove`], [`EditsFile::retarget`]).

use crate::FORMAT_VERSION;
use crate::error::{EditsError, EditsErrorKind as K};
use crate::locator::{ExactLocator, SemanticQuery};
use grm_diag::Span;
use jsonc_parser::ast::{Object, ObjectProp, Value};
use jsonc_parser::common::Ranged;
use std::fmt;
use std::fmt::Write as _;

/// A whole edits file.
#[derive(Clone, Debug, PartialEq)]
pub struct EditsFile {
    /// The format version read (1 to 3; a new file is 1): [`write`]
    /// writes it, or the version an edit needs
    /// ([`EditsFile::written_version`]: 2 for an ordinal edge or a
    /// `selected` count, 3 for a key edit's `symbol`), so that a file
    /// without them stays readable by a grm that reads older versions.
    pub version: u32,
    /// The edits; [`write`] sorts them by (system, id), [`parse`] keeps
    /// the file's order.
    pub edits: Vec<Edit>,
}

impl Default for EditsFile {
    fn default() -> EditsFile {
        EditsFile {
            version: 1,
            edits: Vec::new(),
        }
    }
}

/// One edit: an operation on the part(s) a target names, in one system.
#[derive(Clone, Debug)]
pub struct Edit {
    /// Positive, unique in the file; a larger id is a later edit.
    pub id: u32,
    /// The system's name in the grammar.
    pub system: String,
    /// The city parcel whose building the edit belongs to (its identity,
    /// 16 hex digits in the file; docs/layout.md, "Building edits"):
    /// such an edit is replayed only in that parcel's building, by
    /// `grm_layout::city`, never in the system grown on its own. `None`:
    /// an edit of the system itself.
    pub parcel: Option<u64>,
    pub target: Target,
    /// For a semantic target: how many parts its query selected when the
    /// edit was made (`selected` in the file, version 2). A derivation
    /// where it selects more classifies the edit `ambiguous`. `None`: not
    /// recorded (any number is accepted, as in version 1).
    pub selected: Option<u32>,
    /// For a key target: the symbol of the part its key named when the
    /// edit was made (`symbol` in the file, version 3). The key then names
    /// a part of that symbol only (a part of another symbol made with the
    /// same 32-bit key is not it), and an engine looks for the key among
    /// that symbol's parts alone. Edits of one key in one system that
    /// record a symbol record the same one (the file is refused an edit
    /// that does not: R0911). `None`: any symbol (all a version 1 or 2 file can say).
    pub symbol: Option<String>,
    pub op: Op,
    /// Free text, kept as written.
    pub note: Option<String>,
    /// The byte range of the edit's object in the text it was read from
    /// (empty for an edit made in memory). Not part of the edit: equality
    /// ignores it.
    pub span: Span,
}

impl PartialEq for Edit {
    fn eq(&self, other: &Edit) -> bool {
        self.id == other.id
            && self.system == other.system
            && self.parcel == other.parcel
            && self.target == other.target
            && self.selected == other.selected
            && self.symbol == other.symbol
            && self.op == other.op
            && self.note == other.note
    }
}

/// What an edit applies to.
#[derive(Clone, Debug, PartialEq)]
pub enum Target {
    /// One part by its path (shape mode; in derive and sample mode the
    /// labels are module symbols and the edges child numbers).
    Exact(ExactLocator),
    /// Every shape whose semantic locator the query matches (shape mode).
    Semantic(SemanticQuery),
    /// The part with this identity key (every mode).
    Key(u32),
}

impl Target {
    /// The field name the file uses: `exact`, `semantic` or `key`.
    pub fn kind(&self) -> &'static str {
        match self {
            Target::Exact(_) => "exact",
            Target::Semantic(_) => "semantic",
            Target::Key(_) => "key",
        }
    }

    /// The target's text, as the file writes it.
    pub fn text(&self) -> String {
        match self {
            Target::Exact(l) => l.to_string(),
            Target::Semantic(q) => q.to_string(),
            Target::Key(k) => key_text(*k),
        }
    }
}

impl fmt::Display for Target {
    /// `exact {Lot, 1, Mass}`, `semantic (floor = 3) Window`, `key 0a1b2c3d`
    /// (for listings; the file writes JSON).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} {}", self.kind(), self.text())
    }
}

impl fmt::Display for Op {
    /// `set width = 2.5`, `offset width by -0.25`, `force alternative 2`,
    /// `pin 0a1b2c3d`, `material brick`, `mesh arched`, `remove` (for
    /// listings).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Op::Set { name, value } => write!(f, "set {name} = {value}"),
            Op::Offset { name, by } => write!(f, "offset {name} by {by}"),
            Op::Force { alternative } => write!(f, "force alternative {alternative}"),
            Op::Pin { key } => write!(f, "pin {}", key_text(*key)),
            Op::Material { name } => write!(f, "material {name}"),
            Op::Mesh { name } => write!(f, "mesh {name}"),
            Op::Remove => f.write_str("remove"),
        }
    }
}

/// An identity key as the file (and `grm_grow::json::key_text`) writes
/// it: 8 lowercase hex digits.
pub fn key_text(key: u32) -> String {
    format!("{key:08x}")
}

/// A key's text read back: exactly 8 hex digits (either case).
pub fn parse_key(s: &str) -> Option<u32> {
    if s.len() == 8 && s.bytes().all(|b| b.is_ascii_hexdigit()) {
        u32::from_str_radix(s, 16).ok()
    } else {
        None
    }
}

/// A parcel's identity as the file writes it (`grm_layout::id::Id`'s
/// form): 16 lowercase hex digits.
pub fn parcel_text(parcel: u64) -> String {
    format!("{parcel:016x}")
}

/// A parcel identity's text read back: exactly 16 hex digits (either
/// case).
pub fn parse_parcel(s: &str) -> Option<u64> {
    if s.len() == 16 && s.bytes().all(|b| b.is_ascii_hexdigit()) {
        u64::from_str_radix(s, 16).ok()
    } else {
        None
    }
}

/// The operation of an edit (one per edit).
#[derive(Clone, Debug, PartialEq)]
pub enum Op {
    /// Set parameter or variable `name` to `value` in the target's subtree.
    Set { name: String, value: f64 },
    /// Add `by` to the generated value of `name` in the target's subtree.
    Offset { name: String, by: f64 },
    /// Use the `alternative`-th alternative (from 1) of the target's rule.
    Force { alternative: u32 },
    /// Draw the target's random numbers from `key` (the key it had when
    /// pinned), whatever its identity key is now.
    Pin { key: u32 },
    /// Give the subtree material `name`.
    Material { name: String },
    /// Insert mesh `name` in place of what the target inserts.
    Mesh { name: String },
    /// Remove the target and its subtree.
    Remove,
}

/// The kinds of operation, in the file's words.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum OpKind {
    Set,
    Offset,
    Force,
    Pin,
    Material,
    Mesh,
    Remove,
}

impl OpKind {
    pub const ALL: &'static [OpKind] = &[
        OpKind::Set,
        OpKind::Offset,
        OpKind::Force,
        OpKind::Pin,
        OpKind::Material,
        OpKind::Mesh,
        OpKind::Remove,
    ];

    /// `set`, `offset`, `force`, `pin`, `material`, `mesh`, `remove`.
    pub fn as_str(self) -> &'static str {
        match self {
            OpKind::Set => "set",
            OpKind::Offset => "offset",
            OpKind::Force => "force",
            OpKind::Pin => "pin",
            OpKind::Material => "material",
            OpKind::Mesh => "mesh",
            OpKind::Remove => "remove",
        }
    }

    pub fn from_name(s: &str) -> Option<OpKind> {
        OpKind::ALL.iter().copied().find(|k| k.as_str() == s)
    }

    /// The operation's own fields, in the order the file writes them.
    pub fn fields(self) -> &'static [&'static str] {
        match self {
            OpKind::Set => &["name", "value"],
            OpKind::Offset => &["name", "by"],
            OpKind::Force => &["alternative"],
            OpKind::Pin => &["key"],
            OpKind::Material | OpKind::Mesh => &["name"],
            OpKind::Remove => &[],
        }
    }
}

impl Op {
    pub fn kind(&self) -> OpKind {
        match self {
            Op::Set { .. } => OpKind::Set,
            Op::Offset { .. } => OpKind::Offset,
            Op::Force { .. } => OpKind::Force,
            Op::Pin { .. } => OpKind::Pin,
            Op::Material { .. } => OpKind::Material,
            Op::Mesh { .. } => OpKind::Mesh,
            Op::Remove => OpKind::Remove,
        }
    }
}

/// What [`parse`] read: the valid edits, and every problem found.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Parsed {
    pub file: EditsFile,
    pub errors: Vec<EditsError>,
}

/// The edits file that `text` holds. Tolerant: an edit with a problem is
/// reported and skipped, the others kept; text that is not JSON, has no
/// or another `version`, or is not an object with an `edits` array gives
/// an empty file and that one error. Strict JSON (no comments, trailing
/// commas or unquoted names). Never panics.
pub fn parse(text: &str) -> Parsed {
    let mut out = Parsed::default();
    let strict = jsonc_parser::ParseOptions {
        allow_comments: false,
        allow_loose_object_property_names: false,
        allow_trailing_commas: false,
        allow_missing_commas: false,
        allow_single_quoted_strings: false,
        allow_hexadecimal_numbers: false,
        allow_unary_plus_numbers: false,
        allow_bare_decimal_point_numbers: false,
        allow_non_finite_numbers: false,
        allow_extended_string_escapes: false,
    };
    let root = match jsonc_parser::parse_to_ast(text, &Default::default(), &strict) {
        Ok(r) => r.value,
        Err(e) => {
            let message = format!(
                "line {}, column {}: {}",
                e.line_display(),
                e.column_display(),
                e.kind()
            );
            out.errors
                .push(EditsError::new(K::Syntax { message }, span(e.range())));
            return out;
        }
    };
    let Some(root) = root else {
        let message = "the file holds no JSON value".to_owned();
        let end = text.len();
        out.errors.push(EditsError::new(
            K::Syntax { message },
            Span::from_range(end..end),
        ));
        return out;
    };
    let Value::Object(obj) = &root else {
        let problem = "the edits file is not a JSON object".to_owned();
        out.errors.push(EditsError::new(
            K::Structure { problem },
            span(root.range()),
        ));
        return out;
    };
    let whole = span(obj.range);
    // The version first: a file of another version is not read further.
    match field(obj, "version") {
        None => {
            let e = EditsError::new(
                K::Version { found: None },
                Span::from_range(whole.range().start..whole.range().start + 1),
            );
            out.errors.push(e);
            return out;
        }
        Some(p) => {
            let read = crate::READ_VERSIONS.iter().copied().find(|&v| {
                matches!(&p.value, Value::NumberLit(n) if n.value.parse::<f64>() == Ok(f64::from(v)))
            });
            if let Some(v) = read {
                out.file.version = v;
            } else {
                let found = Some(p.value.text(text).to_owned());
                out.errors
                    .push(EditsError::new(K::Version { found }, span(p.value.range())));
                return out;
            }
        }
    }
    let mut list = None;
    let mut top_errors = Vec::new();
    let mut seen: Vec<&str> = Vec::new();
    for p in &obj.properties {
        let name = p.name.as_str();
        if seen.contains(&name) {
            top_errors.push(EditsError::new(
                K::RepeatedField {
                    field: name.to_owned(),
                },
                span(p.range),
            ));
            continue;
        }
        seen.push(name);
        match name {
            "version" => {}
            "edits" => list = Some(p),
            _ => top_errors.push(EditsError::new(
                K::UnknownField {
                    field: name.to_owned(),
                    op: None,
                },
                span(p.range),
            )),
        }
    }
    let items = match list {
        Some(ObjectProp {
            value: Value::Array(a),
            ..
        }) => &a.elements,
        Some(p) => {
            let problem = "`edits` is not an array".to_owned();
            out.errors.push(EditsError::new(
                K::Structure { problem },
                span(p.value.range()),
            ));
            return out;
        }
        None => {
            let problem = "the edits file has no `edits` array".to_owned();
            let at = whole.range().start;
            out.errors.push(EditsError::new(
                K::Structure { problem },
                Span::from_range(at..at + 1),
            ));
            return out;
        }
    };
    out.errors.extend(top_errors);
    for item in items {
        let Value::Object(o) = item else {
            out.errors
                .push(EditsError::new(K::NotAnObject, span(item.range())));
            continue;
        };
        match read_edit(text, o) {
            Ok(edit) => {
                if let Some((sym, other)) = symbol_conflict(&out.file.edits, &edit) {
                    let mut e = EditsError::new(
                        K::BadValue {
                            field: "symbol".into(),
                            problem: format!(
                                "is {}: edit {} of the same key records {} (a key names one part, of one symbol)",
                                json_string(sym),
                                other.id,
                                json_string(other.symbol.as_deref().unwrap_or_default())
                            ),
                        },
                        edit.span,
                    );
                    e.edit = Some(edit.id);
                    out.errors.push(e);
                } else if let Some(first) = out.file.edits.iter().find(|e| e.id == edit.id) {
                    let mut e = EditsError::new(
                        K::DuplicateId {
                            id: edit.id,
                            first: first.span,
                        },
                        edit.span,
                    );
                    e.edit = Some(edit.id);
                    out.errors.push(e);
                } else {
                    out.file.edits.push(edit);
                }
            }
            Err(errs) => out.errors.extend(errs),
        }
    }
    out
}

/// The symbol `edit` records for its key and the earlier edit of the same
/// key and system that records another, if there is one.
fn symbol_conflict<'a>(earlier: &'a [Edit], edit: &'a Edit) -> Option<(&'a str, &'a Edit)> {
    let (Target::Key(k), Some(sym)) = (&edit.target, &edit.symbol) else {
        return None;
    };
    let other = earlier.iter().find(|e| {
        e.system == edit.system
            && e.parcel == edit.parcel
            && matches!(e.target, Target::Key(j) if j == *k)
            && e.symbol.as_ref().is_some_and(|s| s != sym)
    })?;
    Some((sym, other))
}

fn span(r: jsonc_parser::common::Range) -> Span {
    Span::from_range(r.start..r.end)
}

fn field<'o, 'a>(obj: &'o Object<'a>, name: &str) -> Option<&'o ObjectProp<'a>> {
    obj.properties.iter().find(|p| p.name.as_str() == name)
}

/// The fields every edit has, beside its operation's.
const COMMON: &[&str] = &[
    "id", "system", "parcel", "target", "selected", "symbol", "op", "note",
];

/// One edit, or every problem found in it (all reported, the edit skipped).
fn read_edit(text: &str, o: &Object<'_>) -> Result<Edit, Vec<EditsError>> {
    let mut errors = Vec::new();
    let whole = span(o.range);
    let at_edit = |kind, at: Span| EditsError::new(kind, at);
    // Repeated fields.
    let mut seen: Vec<&str> = Vec::new();
    for p in &o.properties {
        let name = p.name.as_str();
        if seen.contains(&name) {
            errors.push(at_edit(
                K::RepeatedField {
                    field: name.to_owned(),
                },
                span(p.range),
            ));
        }
        seen.push(name);
    }
    let id = match field(o, "id") {
        None => {
            errors.push(at_edit(K::MissingField { field: "id" }, whole));
            None
        }
        Some(p) => match number(p) {
            Err(e) => {
                errors.push(e);
                None
            }
            Ok(v) if v.fract() == 0.0 && (1.0..=f64::from(u32::MAX)).contains(&v) => Some(v as u32),
            Ok(_) => {
                errors.push(at_edit(
                    K::BadValue {
                        field: "id".into(),
                        problem: format!(
                            "is {}: an id is a whole number from 1 to {}",
                            p.value.text(text),
                            u32::MAX
                        ),
                    },
                    span(p.value.range()),
                ));
                None
            }
        },
    };
    let system = required_name(o, "system", whole, &mut errors);
    let parcel = match field(o, "parcel") {
        None => None,
        Some(p) => match string(p) {
            Err(e) => {
                errors.push(e);
                None
            }
            Ok(s) => match parse_parcel(s) {
                Some(v) => Some(v),
                None => {
                    errors.push(at_edit(
                        K::BadValue {
                            field: "parcel".into(),
                            problem: format!("is \"{s}\": a parcel's identity is 16 hex digits"),
                        },
                        span(p.value.range()),
                    ));
                    None
                }
            },
        },
    };
    let target = match field(o, "target") {
        None => {
            errors.push(at_edit(K::MissingField { field: "target" }, whole));
            None
        }
        Some(p) => match read_target(p) {
            Ok(t) => Some(t),
            Err(e) => {
                errors.push(e);
                None
            }
        },
    };
    let selected = match field(o, "selected") {
        None => None,
        Some(p) => match number(p) {
            Err(e) => {
                errors.push(e);
                None
            }
            Ok(v)
                if v.fract() == 0.0
                    && (1.0..=f64::from(u32::MAX)).contains(&v)
                    && matches!(target, Some(Target::Semantic(_)) | None) =>
            {
                Some(v as u32)
            }
            Ok(_) => {
                let problem = if matches!(target, Some(Target::Semantic(_)) | None) {
                    format!(
                        "is {}: how many parts the query selected is a whole number from 1",
                        p.value.text(text)
                    )
                } else {
                    "is given for a target that is not semantic (only a query selects several parts)"
                        .to_owned()
                };
                errors.push(at_edit(
                    K::BadValue {
                        field: "selected".into(),
                        problem,
                    },
                    span(p.value.range()),
                ));
                None
            }
        },
    };
    let symbol = match field(o, "symbol") {
        None => None,
        Some(p) => match string(p) {
            Err(e) => {
                errors.push(e);
                None
            }
            Ok(s) if !s.is_empty() && matches!(target, Some(Target::Key(_)) | None) => {
                Some(s.to_owned())
            }
            Ok(s) => {
                let problem = if s.is_empty() {
                    "is empty: the symbol of the part the key named".to_owned()
                } else {
                    "is given for a target that is not a key (an exact locator and a query name their symbol themselves)".to_owned()
                };
                errors.push(at_edit(
                    K::BadValue {
                        field: "symbol".into(),
                        problem,
                    },
                    span(p.value.range()),
                ));
                None
            }
        },
    };
    let kind = match field(o, "op") {
        None => {
            errors.push(at_edit(K::MissingField { field: "op" }, whole));
            None
        }
        Some(p) => match string(p) {
            Err(e) => {
                errors.push(e);
                None
            }
            Ok(s) => match OpKind::from_name(s) {
                Some(k) => Some(k),
                None => {
                    errors.push(at_edit(
                        K::UnknownOp { op: s.to_owned() },
                        span(p.value.range()),
                    ));
                    None
                }
            },
        },
    };
    let note = match field(o, "note") {
        None => None,
        Some(p) => match string(p) {
            Ok(s) => Some(s.to_owned()),
            Err(e) => {
                errors.push(e);
                None
            }
        },
    };
    // Unknown fields: known to no edit, or (the operation known) not this
    // operation's. With an unknown operation only the first kind is said.
    for p in &o.properties {
        let name = p.name.as_str();
        if COMMON.contains(&name) {
            continue;
        }
        let any_op = OpKind::ALL.iter().any(|k| k.fields().contains(&name));
        match kind {
            Some(k) if !k.fields().contains(&name) => errors.push(at_edit(
                K::UnknownField {
                    field: name.to_owned(),
                    op: any_op.then(|| k.as_str().to_owned()),
                },
                span(p.range),
            )),
            None if !any_op => errors.push(at_edit(
                K::UnknownField {
                    field: name.to_owned(),
                    op: None,
                },
                span(p.range),
            )),
            _ => {}
        }
    }
    let op = kind.and_then(|k| read_op(k, text, o, whole, &mut errors));
    if let (Some(id), Some(system), Some(target), Some(op), true) =
        (id, system, target, op, errors.is_empty())
    {
        return Ok(Edit {
            id,
            system,
            parcel,
            target,
            selected,
            symbol,
            op,
            note,
            span: whole,
        });
    }
    for e in &mut errors {
        e.edit = id;
    }
    Err(errors)
}

/// The operation's own fields.
fn read_op(
    kind: OpKind,
    text: &str,
    o: &Object<'_>,
    whole: Span,
    errors: &mut Vec<EditsError>,
) -> Option<Op> {
    let finite = |name: &'static str, errors: &mut Vec<EditsError>| -> Option<f64> {
        let Some(p) = field(o, name) else {
            errors.push(EditsError::new(K::MissingField { field: name }, whole));
            return None;
        };
        match number(p) {
            Err(e) => {
                errors.push(e);
                None
            }
            Ok(v) if v.is_finite() => Some(v),
            Ok(_) => {
                errors.push(EditsError::new(
                    K::BadValue {
                        field: name.into(),
                        problem: format!("is {}: not a finite number", p.value.text(text)),
                    },
                    span(p.value.range()),
                ));
                None
            }
        }
    };
    Some(match kind {
        OpKind::Set => {
            let name = required_name(o, "name", whole, errors);
            let value = finite("value", errors);
            Op::Set {
                name: name?,
                value: value?,
            }
        }
        OpKind::Offset => {
            let name = required_name(o, "name", whole, errors);
            let by = finite("by", errors);
            Op::Offset {
                name: name?,
                by: by?,
            }
        }
        OpKind::Force => {
            let Some(p) = field(o, "alternative") else {
                errors.push(EditsError::new(
                    K::MissingField {
                        field: "alternative",
                    },
                    whole,
                ));
                return None;
            };
            match number(p) {
                Err(e) => {
                    errors.push(e);
                    return None;
                }
                Ok(v) if v.fract() == 0.0 && (1.0..=f64::from(u32::MAX)).contains(&v) => {
                    Op::Force {
                        alternative: v as u32,
                    }
                }
                Ok(_) => {
                    errors.push(EditsError::new(
                        K::BadValue {
                            field: "alternative".into(),
                            problem: format!(
                                "is {}: alternatives are numbered from 1",
                                p.value.text(text)
                            ),
                        },
                        span(p.value.range()),
                    ));
                    return None;
                }
            }
        }
        OpKind::Pin => {
            let Some(p) = field(o, "key") else {
                errors.push(EditsError::new(K::MissingField { field: "key" }, whole));
                return None;
            };
            match string(p) {
                Err(e) => {
                    errors.push(e);
                    return None;
                }
                Ok(s) => match parse_key(s) {
                    Some(key) => Op::Pin { key },
                    None => {
                        errors.push(EditsError::new(
                            K::BadValue {
                                field: "key".into(),
                                problem: format!("is \"{s}\": a key is 8 hex digits"),
                            },
                            span(p.value.range()),
                        ));
                        return None;
                    }
                },
            }
        }
        OpKind::Material => Op::Material {
            name: required_name(o, "name", whole, errors)?,
        },
        OpKind::Mesh => Op::Mesh {
            name: required_name(o, "name", whole, errors)?,
        },
        OpKind::Remove => Op::Remove,
    })
}

/// A required, non-empty string field.
fn required_name(
    o: &Object<'_>,
    name: &'static str,
    whole: Span,
    errors: &mut Vec<EditsError>,
) -> Option<String> {
    let Some(p) = field(o, name) else {
        errors.push(EditsError::new(K::MissingField { field: name }, whole));
        return None;
    };
    match string(p) {
        Err(e) => {
            errors.push(e);
            None
        }
        Ok("") => {
            errors.push(EditsError::new(
                K::BadValue {
                    field: name.into(),
                    problem: "is empty".into(),
                },
                span(p.value.range()),
            ));
            None
        }
        Ok(s) => Some(s.to_owned()),
    }
}

fn string<'o>(p: &'o ObjectProp<'_>) -> Result<&'o str, EditsError> {
    match &p.value {
        Value::StringLit(s) => Ok(s.value.as_ref()),
        v => Err(EditsError::new(
            K::FieldType {
                field: p.name.as_str().to_owned(),
                expected: "a string",
            },
            span(v.range()),
        )),
    }
}

fn number(p: &ObjectProp<'_>) -> Result<f64, EditsError> {
    let bad = |v: &Value| {
        EditsError::new(
            K::FieldType {
                field: p.name.as_str().to_owned(),
                expected: "a number",
            },
            span(v.range()),
        )
    };
    match &p.value {
        // JSON's number syntax is a subset of Rust's; a number too large
        // for f64 reads as infinite, which the callers refuse.
        Value::NumberLit(n) => n.value.parse::<f64>().map_err(|_| bad(&p.value)),
        v => Err(bad(v)),
    }
}

/// `{"exact": "..."}`, `{"semantic": "..."}` or `{"key": "..."}`.
fn read_target(p: &ObjectProp<'_>) -> Result<Target, EditsError> {
    let bad = |problem: String, at: Span| EditsError::new(K::BadTarget { problem }, at);
    let Value::Object(t) = &p.value else {
        return Err(EditsError::new(
            K::FieldType {
                field: "target".into(),
                expected: "an object: { \"exact\" | \"semantic\" | \"key\": \"...\" }",
            },
            span(p.value.range()),
        ));
    };
    let [one] = t.properties.as_slice() else {
        let names: Vec<String> = t
            .properties
            .iter()
            .map(|p| format!("`{}`", p.name.as_str()))
            .collect();
        let problem = if names.is_empty() {
            "it names no locator (one of `exact`, `semantic`, `key`)".to_owned()
        } else {
            format!(
                "it has {} fields ({}); a target has one of `exact`, `semantic`, `key`",
                names.len(),
                names.join(", ")
            )
        };
        return Err(bad(problem, span(t.range)));
    };
    let kind = one.name.as_str();
    if !matches!(kind, "exact" | "semantic" | "key") {
        return Err(bad(
            format!("`{kind}` is not a locator (one of `exact`, `semantic`, `key`)"),
            span(one.range),
        ));
    }
    let Value::StringLit(s) = &one.value else {
        return Err(EditsError::new(
            K::FieldType {
                field: format!("target.{kind}"),
                expected: "a string",
            },
            span(one.value.range()),
        ));
    };
    let at = span(s.range);
    let text = s.value.as_ref();
    match kind {
        "exact" => text
            .parse()
            .map(Target::Exact)
            .map_err(|e| bad(format!("exact locator: {e}"), at)),
        "semantic" => text
            .parse()
            .map(Target::Semantic)
            .map_err(|e| bad(format!("semantic query: {e}"), at)),
        _ => parse_key(text)
            .map(Target::Key)
            .ok_or_else(|| bad(format!("key \"{text}\" is not 8 hex digits"), at)),
    }
}

/// The file's canonical text: edits sorted by (system, id), keys in a
/// fixed order (id, system, parcel, target, op, the operation's fields, note),
/// two-space indent, a trailing newline; one edit per block, so a diff
/// shows one edit per change. [`parse`] reads it back to the same file
/// (sorted), and writing that again gives the same text. A value that is
/// not finite (only an edit made in memory can hold one) is written as
/// `null`, which reads back as an error.
pub fn write(file: &EditsFile) -> String {
    let mut order: Vec<&Edit> = file.edits.iter().collect();
    order.sort_by(|a, b| (&a.system, a.id).cmp(&(&b.system, b.id)));
    let mut s = String::new();
    let _ = writeln!(s, "{{");
    let _ = writeln!(s, "  \"version\": {},", file.written_version());
    if order.is_empty() {
        let _ = writeln!(s, "  \"edits\": []");
    } else {
        let _ = writeln!(s, "  \"edits\": [");
        for (i, e) in order.iter().enumerate() {
            write_block(&mut s, e);
            let _ = writeln!(s, "{}", if i + 1 < order.len() { "," } else { "" });
        }
        let _ = writeln!(s, "  ]");
    }
    let _ = writeln!(s, "}}");
    s
}

/// One edit's canonical text as it stands in a written file, from its
/// `{` to its `}` (its lines after the first indented for the list): what
/// replaces [`Edit::span`] in a quick fix that changes one edit.
pub fn write_edit(edit: &Edit) -> String {
    let mut s = String::new();
    write_block(&mut s, edit);
    s.trim_start().to_owned()
}

/// One edit's block, at the list's indent, without the comma after it.
fn write_block(s: &mut String, e: &Edit) {
    let mut fields: Vec<(&str, String)> =
        vec![("id", e.id.to_string()), ("system", json_string(&e.system))];
    if let Some(parcel) = e.parcel {
        fields.push(("parcel", json_string(&parcel_text(parcel))));
    }
    fields.extend([(
        "target",
        format!(
            "{{ {}: {} }}",
            json_string(e.target.kind()),
            json_string(&e.target.text())
        ),
    )]);
    if let (Some(n), Target::Semantic(_)) = (e.selected, &e.target) {
        fields.push(("selected", n.to_string()));
    }
    if let (Some(sym), Target::Key(_)) = (&e.symbol, &e.target) {
        fields.push(("symbol", json_string(sym)));
    }
    fields.push(("op", json_string(e.op.kind().as_str())));
    match &e.op {
        Op::Set { name, value } => {
            fields.push(("name", json_string(name)));
            fields.push(("value", json_number(*value)));
        }
        Op::Offset { name, by } => {
            fields.push(("name", json_string(name)));
            fields.push(("by", json_number(*by)));
        }
        Op::Force { alternative } => fields.push(("alternative", alternative.to_string())),
        Op::Pin { key } => fields.push(("key", json_string(&key_text(*key)))),
        Op::Material { name } | Op::Mesh { name } => fields.push(("name", json_string(name))),
        Op::Remove => {}
    }
    if let Some(note) = &e.note {
        fields.push(("note", json_string(note)));
    }
    let _ = writeln!(s, "    {{");
    for (i, (k, v)) in fields.iter().enumerate() {
        let comma = if i + 1 < fields.len() { "," } else { "" };
        let _ = writeln!(s, "      \"{k}\": {v}{comma}");
    }
    let _ = write!(s, "    }}");
}

fn json_string(s: &str) -> String {
    serde_json::to_string(s).unwrap_or_else(|_| "\"\"".to_owned())
}

/// Shortest text that reads back to the same `f64` (`1.0`, `0.25`,
/// `1e300`); `null` for a value that is not finite.
fn json_number(v: f64) -> String {
    serde_json::to_string(&v).unwrap_or_else(|_| "null".to_owned())
}

impl EditsFile {
    /// The version [`write`] gives the file: its own, or the oldest
    /// that holds its edits where that is newer: 3 when a key edit has a
    /// `symbol`, 2 when an edit has an ordinal edge (`#k`) or a
    /// `selected` count.
    pub fn written_version(&self) -> u32 {
        let needs_3 = self
            .edits
            .iter()
            .any(|e| e.symbol.is_some() && matches!(e.target, Target::Key(_)));
        let needs_2 = self.edits.iter().any(|e| {
            e.selected.is_some()
                || matches!(&e.target, Target::Exact(l)
                    if l.edges.iter().any(|g| matches!(g, crate::locator::EdgeRef::Ordinal(_))))
        });
        let needs = if needs_3 {
            3
        } else if needs_2 {
            2
        } else {
            1
        };
        self.version.clamp(1, FORMAT_VERSION).max(needs)
    }

    /// The edit with this id.
    pub fn get(&self, id: u32) -> Option<&Edit> {
        self.edits.iter().find(|e| e.id == id)
    }

    /// The id a new edit gets: the largest plus 1 (1 in an empty file).
    /// `None` when the largest is `u32::MAX`.
    pub fn next_id(&self) -> Option<u32> {
        self.edits
            .iter()
            .map(|e| e.id)
            .max()
            .map_or(Some(1), |m| m.checked_add(1))
    }

    /// The edits of one system, in the file's order.
    pub fn of_system<'a>(&'a self, system: &'a str) -> impl Iterator<Item = &'a Edit> + 'a {
        self.edits.iter().filter(move |e| e.system == system)
    }

    /// Sort the edits into the written order, (system, id).
    pub fn sort(&mut self) {
        self.edits
            .sort_by(|a, b| (&a.system, a.id).cmp(&(&b.system, b.id)));
    }

    /// Add an edit (the latest: id [`EditsFile::next_id`], the largest
    /// plus 1) at its place in the written order; its id. When the largest
    /// id is `u32::MAX` there is no later id: nothing is added and `None`
    /// comes back.
    pub fn add(&mut self, system: &str, target: Target, op: Op) -> Option<u32> {
        let id = self.next_id()?;
        let edit = Edit {
            id,
            system: system.to_owned(),
            parcel: None,
            target,
            selected: None,
            symbol: None,
            op,
            note: None,
            span: Span::default(),
        };
        let at = self
            .edits
            .partition_point(|e| (e.system.as_str(), e.id) <= (system, id));
        self.edits.insert(at, edit);
        Some(id)
    }

    /// Remove the edit with this id; it, if there was one.
    pub fn remove(&mut self, id: u32) -> Option<Edit> {
        let at = self.edits.iter().position(|e| e.id == id)?;
        Some(self.edits.remove(at))
    }

    /// Point the edit with this id at another target (a quick fix); its
    /// old target, if there was such an edit. Its id, and so its place
    /// among later and earlier edits, stays; its `selected` count and
    /// `symbol` are dropped (they were the old target's).
    pub fn retarget(&mut self, id: u32, target: Target) -> Option<Target> {
        let e = self.edits.iter_mut().find(|e| e.id == id)?;
        e.selected = None;
        e.symbol = None;
        Some(std::mem::replace(&mut e.target, target))
    }
}

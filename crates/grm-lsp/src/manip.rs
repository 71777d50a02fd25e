//! Direct manipulation (issue 28, docs/lsp-extensions.md "Direct
//! manipulation"): `grm/provenance`, `grm/drag`, `grm/sketch` and
//! `grm/writeParams` over `grm-manip`.
//!
//! Each request reads the document as the client holds it (its open
//! buffer, else the file), grows it with the preview's system, seed,
//! slider values and persistent edits, and answers with byte spans turned
//! into the client's ranges. An edit is sent as one `workspace/applyEdit`
//! (`TextDocumentEdit` at the document's version: one undo step), or,
//! for a client that cannot apply edits (`grmc view`), returned whole as
//! `text` for the client to write.

use crate::{Backend, convert, failed};
use grm_diag::{SourceFile, Span};
use grm_manip::{DragOutcome, Keyframe, Manip, Part, Setup, Target};
use grm_sema::{FileLoader, LoadError};
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;
use tower_lsp_server::jsonrpc::{Error, ErrorCode, Result};
use tower_lsp_server::ls_types::*;

/// What every manipulation request shares with `grm/preview`.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct Common {
    pub text_document: TextDocumentIdentifier,
    /// Answered with ContentModified when the document is at another.
    #[serde(default)]
    pub version: Option<i32>,
    #[serde(default)]
    pub system: Option<String>,
    #[serde(default)]
    pub seed: Option<u32>,
    /// Slider values by name.
    #[serde(default)]
    pub params: BTreeMap<String, f64>,
}

/// A part as the protocol names it (keys as 8 hex digits).
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct PartIn {
    pub kind: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub key: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub command: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub edge: Option<u32>,
}

/// `grm/provenance` parameters.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct ProvenanceParams {
    #[serde(flatten)]
    pub common: Common,
    pub part: PartIn,
}

/// `grm/drag` parameters.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct DragParams {
    #[serde(flatten)]
    pub common: Common,
    pub part: PartIn,
    pub target: serde_json::Value,
    /// Default true; false only proposes.
    #[serde(default)]
    pub apply: Option<bool>,
}

/// A keyframe of `grm/sketch`.
#[derive(Clone, Debug, Deserialize, Serialize)]
pub struct KeyframeIn {
    pub t: f64,
    pub target: serde_json::Value,
}

/// `grm/sketch` parameters.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct SketchParams {
    #[serde(flatten)]
    pub common: Common,
    pub part: PartIn,
    pub name: String,
    pub keyframes: Vec<KeyframeIn>,
    #[serde(default)]
    pub apply: Option<bool>,
}

/// `grm/writeParams` parameters.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct WriteParamsParams {
    pub text_document: TextDocumentIdentifier,
    #[serde(default)]
    pub version: Option<i32>,
    pub params: BTreeMap<String, f64>,
    #[serde(default)]
    pub apply: Option<bool>,
}

/// One changed number.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct ChangeOut {
    pub range: Range,
    pub old: String,
    pub new: String,
}

/// What an edit request answers (`grm/drag`, `grm/sketch`,
/// `grm/writeParams`).
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct EditOut {
    /// `solved`, `unchanged` or `unreachable` (drag); `solved` otherwise.
    pub outcome: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub why: Option<String>,
    #[serde(default)]
    pub changes: Vec<ChangeOut>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub residual: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub moved: Option<usize>,
    /// Sketch: the parameter's name, each keyframe's distance, exactness.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub residuals: Vec<(f64, f64)>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exact_at_zero: Option<bool>,
    pub applied: bool,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub failure_reason: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub edit: Option<WorkspaceEdit>,
    /// The whole edited text, for a client that cannot apply edits.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub text: Option<String>,
    /// The document's version the answer was computed from.
    pub version: i32,
}

/// One source of `grm/provenance`.
#[derive(Clone, Debug, Serialize)]
#[serde(rename_all = "camelCase")]
struct SourceOut {
    range: Range,
    #[serde(flatten)]
    source: grm_manip::Source,
}

fn invalid(msg: impl Into<String>) -> Error {
    Error {
        code: ErrorCode::InvalidParams,
        message: msg.into().into(),
        data: None,
    }
}

fn hex(s: Option<&String>, what: &str) -> Result<u32> {
    let s = s.ok_or_else(|| invalid(format!("part: no `{what}`")))?;
    grm_edits::file::parse_key(s.trim())
        .ok_or_else(|| invalid(format!("part: `{what}` is not a key (8 hex digits): {s}")))
}

fn part_of(p: &PartIn) -> Result<Part> {
    Ok(match p.kind.as_str() {
        "plane" => Part::Plane {
            command: hex(p.command.as_ref(), "command")?,
            edge: p.edge.ok_or_else(|| invalid("part: no `edge`"))?,
        },
        "shape" => Part::Shape {
            key: hex(p.key.as_ref(), "key")?,
        },
        "bone" => Part::Bone {
            key: hex(p.key.as_ref(), "key")?,
        },
        k => {
            return Err(invalid(format!(
                "part: kind `{k}` is none of plane, shape, bone"
            )));
        }
    })
}

/// A target as the protocol gives it (the model's frame), as the solver
/// takes it (a shape's corner in the shape frame: z up).
fn target_of(v: &serde_json::Value) -> Result<Target> {
    let t: Target =
        serde_json::from_value(v.clone()).map_err(|e| invalid(format!("target: {e}")))?;
    Ok(match t {
        // Model (x, y, z) is the shape world's (x, z, -y).
        Target::Corner { at: [x, y, z] } => Target::Corner { at: [x, -z, y] },
        t => t,
    })
}

/// The open documents (their buffers) over the server's loader.
struct Docs {
    open: HashMap<PathBuf, Arc<str>>,
    base: Arc<dyn FileLoader + Send + Sync>,
}

impl FileLoader for Docs {
    fn read(&self, path: &Path) -> std::result::Result<String, LoadError> {
        match self.open.get(&grm_sema::normalize(path)) {
            Some(t) => Ok(t.to_string()),
            None => self.base.read(path),
        }
    }
    fn exists(&self, path: &Path) -> bool {
        self.open.contains_key(&grm_sema::normalize(path)) || self.base.exists(path)
    }
    fn resolve(&self, from: &Path, written: &str) -> PathBuf {
        self.base.resolve(from, written)
    }
}

/// A document as the request sees it.
struct Doc {
    path: PathBuf,
    uri: Uri,
    /// The open buffer's version (`None`: read from disk).
    version: Option<i32>,
    text: String,
    docs: Arc<Docs>,
    edits: Option<grm_edits::EditsFile>,
}

impl Doc {
    fn params(&self, c: &Common) -> Vec<String> {
        c.params.iter().map(|(k, v)| format!("{k}={v}")).collect()
    }

    fn range(&self, span: Span) -> Range {
        convert::range(&SourceFile::new("", &self.text), span)
    }

    fn changes(&self, changes: &[grm_manip::Change]) -> Vec<ChangeOut> {
        changes
            .iter()
            .map(|c| ChangeOut {
                range: self.range(c.span),
                old: c.old.clone(),
                new: c.new.clone(),
            })
            .collect()
    }
}

/// What a kept [`Manip`] was made from: a request with the same text,
/// options and edits reuses it (a drag's release reuses the probes its
/// grab's `grm/provenance` grew).
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct ManipKey {
    path: PathBuf,
    text: String,
    system: Option<String>,
    seed: Option<u32>,
    params: Vec<String>,
    edits: u64,
}

/// The last document's [`Manip`], kept between requests.
pub(crate) type ManipCache = Option<(ManipKey, Arc<Manip>)>;

/// Models up to this many measured parts are kept between requests (a
/// kept `Manip` holds one growth per probed number).
const KEEP_PARTS: usize = 50_000;

impl Backend {
    /// Run `f` on the document's [`Manip`] (the kept one when it was made
    /// from the same text, options and edits) on a blocking thread (each
    /// growth is a whole derivation); the document back with its answer.
    async fn with_manip<T: Send + 'static>(
        &self,
        doc: Doc,
        common: Common,
        f: impl FnOnce(&Manip) -> std::result::Result<T, grm_manip::ManipError> + Send + 'static,
    ) -> Result<(Doc, T)> {
        let key = ManipKey {
            path: doc.path.clone(),
            text: doc.text.clone(),
            system: common.system.clone(),
            seed: common.seed,
            params: doc.params(&common),
            edits: self.shared.edits_generation(),
        };
        let kept = self
            .shared
            .manips
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .as_ref()
            .filter(|(k, _)| *k == key)
            .map(|(_, m)| m.clone());
        let shared = self.shared.clone();
        let (doc, out) = tokio::task::spawn_blocking(move || {
            let m = match kept {
                Some(m) => m,
                None => {
                    let m = Arc::new(
                        Manip::new(setup(&doc, &common), &doc.text)
                            .map_err(|e| manip_failed(&e))?,
                    );
                    // Kept at once: a request for the same text that comes
                    // while this one runs (a drag's release while its
                    // grab's provenance still probes) shares its probes.
                    if m.part_count() <= KEEP_PARTS {
                        *shared
                            .manips
                            .lock()
                            .unwrap_or_else(std::sync::PoisonError::into_inner) =
                            Some((key, m.clone()));
                    }
                    m
                }
            };
            let out = f(&m).map_err(|e| manip_failed(&e))?;
            Ok::<_, Error>((doc, out))
        })
        .await
        .map_err(|e| failed(e.to_string()))??;
        Ok((doc, out))
    }
}

fn manip_failed(e: &grm_manip::ManipError) -> Error {
    match e {
        grm_manip::ManipError::Mismatch { .. } => invalid(e.to_string()),
        _ => failed(e.to_string()),
    }
}

impl Backend {
    /// The document `uri` (its buffer, else the file), checked against
    /// the version asked for.
    fn manip_doc(&self, uri: &Uri, version: Option<i32>) -> Result<Doc> {
        let path = convert::path_of(uri).ok_or_else(|| failed("not a file URI"))?;
        let (open, base, current) = {
            let a = self.shared.analysis();
            let open: HashMap<PathBuf, Arc<str>> = a
                .documents()
                .into_iter()
                .filter_map(|p| a.document(&p).map(|(_, t)| (p, t)))
                .collect();
            (open, a.loader(), a.document(&path))
        };
        let (doc_version, text) = match current {
            Some((v, t)) => (Some(v), t.to_string()),
            None => (
                None,
                base.read(&path)
                    .map_err(|e| failed(format!("cannot read {}: {e:?}", path.display())))?,
            ),
        };
        if let (Some(want), Some(have)) = (version, doc_version)
            && want != have
        {
            return Err(Error {
                code: ErrorCode::ContentModified,
                message: format!("the document is at version {have}, not {want}").into(),
                data: None,
            });
        }
        let loaded = self
            .shared
            .edits_source()
            .load(&grm_edits::edits_path(&grm_sema::normalize(&path)));
        let edits = loaded.text.is_some().then_some(loaded.parsed.file);
        Ok(Doc {
            path,
            uri: uri.clone(),
            version: doc_version,
            text,
            docs: Arc::new(Docs { open, base }),
            edits,
        })
    }

    /// `grm/provenance`.
    pub async fn provenance(&self, params: ProvenanceParams) -> Result<serde_json::Value> {
        let doc = self.manip_doc(&params.common.text_document.uri, params.common.version)?;
        let part = part_of(&params.part)?;
        let (doc, p) = self
            .with_manip(doc, params.common.clone(), move |m| m.provenance(&part))
            .await?;
        let sources: Vec<SourceOut> = p
            .sources
            .iter()
            .map(|s| SourceOut {
                range: doc.range(s.candidate.span),
                source: s.clone(),
            })
            .collect();
        let mut out = serde_json::to_value(&p).map_err(|e| failed(e.to_string()))?;
        out["sources"] = serde_json::to_value(sources).map_err(|e| failed(e.to_string()))?;
        // The part as the request named it (keys as 8 hex digits).
        out["part"] = serde_json::to_value(&params.part).map_err(|e| failed(e.to_string()))?;
        Ok(out)
    }

    /// `grm/drag`.
    pub async fn drag(&self, params: DragParams) -> Result<EditOut> {
        let doc = self.manip_doc(&params.common.text_document.uri, params.common.version)?;
        let part = part_of(&params.part)?;
        let target = target_of(&params.target)?;
        let (doc, out) = self
            .with_manip(doc, params.common.clone(), move |m| m.drag(&part, &target))
            .await?;
        let mut answer = EditOut {
            version: doc.version.unwrap_or(0),
            ..EditOut::default()
        };
        match out {
            DragOutcome::Unchanged => answer.outcome = "unchanged".into(),
            DragOutcome::Unreachable { why, .. } => {
                answer.outcome = "unreachable".into();
                answer.why = Some(why);
            }
            DragOutcome::Solved(s) => {
                answer.outcome = "solved".into();
                answer.changes = doc.changes(&s.changes);
                answer.residual = Some(s.residual);
                answer.moved = Some(s.moved);
                let edits: Vec<(Span, String)> =
                    s.edits.iter().map(|e| (e.span, e.text.clone())).collect();
                self.send(
                    &doc,
                    &edits,
                    s.text,
                    params.apply.unwrap_or(true),
                    "grm: drag",
                    &mut answer,
                )
                .await?;
            }
        }
        Ok(answer)
    }

    /// `grm/sketch`.
    pub async fn sketch(&self, params: SketchParams) -> Result<EditOut> {
        let doc = self.manip_doc(&params.common.text_document.uri, params.common.version)?;
        let part = part_of(&params.part)?;
        let keys = params
            .keyframes
            .iter()
            .map(|k| {
                Ok(Keyframe {
                    t: k.t,
                    target: target_of(&k.target)?,
                })
            })
            .collect::<Result<Vec<_>>>()?;
        let name = params.name.clone();
        let (doc, s) = self
            .with_manip(doc, params.common.clone(), move |m| {
                m.sketch(&part, &keys, &name)
            })
            .await?;
        let mut answer = EditOut {
            outcome: "solved".into(),
            version: doc.version.unwrap_or(0),
            changes: doc.changes(&s.changes),
            name: Some(s.name.clone()),
            residuals: s.residuals.clone(),
            exact_at_zero: Some(s.exact_at_zero),
            ..EditOut::default()
        };
        let edits: Vec<(Span, String)> = s.edits.iter().map(|e| (e.span, e.text.clone())).collect();
        self.send(
            &doc,
            &edits,
            s.text,
            params.apply.unwrap_or(true),
            "grm: sketch parameter",
            &mut answer,
        )
        .await?;
        Ok(answer)
    }

    /// `grm/writeParams`.
    pub async fn write_params(&self, params: WriteParamsParams) -> Result<EditOut> {
        let doc = self.manip_doc(&params.text_document.uri, params.version)?;
        let edits = grm_manip::defaults::rewrite(&doc.text, &params.params)
            .map_err(|e| invalid(e.to_string()))?;
        let mut answer = EditOut {
            outcome: "solved".into(),
            version: doc.version.unwrap_or(0),
            changes: edits
                .iter()
                .map(|e| ChangeOut {
                    range: doc.range(e.span),
                    old: doc.text[e.span.start as usize..e.span.end as usize].to_string(),
                    new: e.text.clone(),
                })
                .collect(),
            ..EditOut::default()
        };
        let pairs: Vec<(Span, String)> = edits.iter().map(|e| (e.span, e.text.clone())).collect();
        let text = grm_manip::candidates::apply(&doc.text, &pairs);
        self.send(
            &doc,
            &pairs,
            text,
            params.apply.unwrap_or(true),
            "grm: write slider values",
            &mut answer,
        )
        .await?;
        Ok(answer)
    }

    /// Send `edits` of `doc` as one `workspace/applyEdit`, or put the
    /// edited `text` in the answer for a client that cannot apply edits.
    async fn send(
        &self,
        doc: &Doc,
        edits: &[(Span, String)],
        text: String,
        apply: bool,
        label: &str,
        answer: &mut EditOut,
    ) -> Result<()> {
        let caps = *self
            .shared
            .edit_caps
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let text_edits: Vec<TextEdit> = edits
            .iter()
            .map(|(s, t)| TextEdit {
                range: doc.range(*s),
                new_text: t.clone(),
            })
            .collect();
        let edit = if caps.document_changes() {
            WorkspaceEdit {
                document_changes: Some(DocumentChanges::Edits(vec![TextDocumentEdit {
                    text_document: OptionalVersionedTextDocumentIdentifier {
                        uri: doc.uri.clone(),
                        version: doc.version,
                    },
                    edits: text_edits.into_iter().map(OneOf::Left).collect(),
                }])),
                ..WorkspaceEdit::default()
            }
        } else {
            WorkspaceEdit {
                changes: Some(HashMap::from([(doc.uri.clone(), text_edits)])),
                ..WorkspaceEdit::default()
            }
        };
        answer.edit = Some(edit.clone());
        if !apply {
            return Ok(());
        }
        if !caps.can_apply() {
            answer.text = Some(text);
            return Ok(());
        }
        let reply = tokio::time::timeout(
            Duration::from_secs(60),
            self.client
                .send_request::<request::ApplyWorkspaceEdit>(ApplyWorkspaceEditParams {
                    label: Some(label.to_owned()),
                    edit,
                }),
        )
        .await
        .map_err(|_| failed("the client did not answer workspace/applyEdit"))?
        .map_err(|e| failed(format!("workspace/applyEdit: {}", e.message)))?;
        answer.applied = reply.applied;
        answer.failure_reason = reply.failure_reason;
        Ok(())
    }
}

/// The setup of a request's growths.
fn setup(doc: &Doc, c: &Common) -> Setup {
    Setup {
        system: c.system.clone(),
        params: doc.params(c),
        seed: c.seed,
        edits: doc.edits.clone(),
        ..Setup::new(doc.path.to_string_lossy().into_owned(), doc.docs.clone())
    }
}

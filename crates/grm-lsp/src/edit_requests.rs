//! `grm/edit` and `grm/removeEdit` (docs/lsp-extensions.md, "Persistent
//! edits"): an edit added to, or removed from, the edits file, written
//! canonically by grm-edits and sent as a `workspace/applyEdit`, so the
//! client's undo reverts it; a client that cannot apply edits (`grmc
//! view`) gets the file written by the server.

use crate::edit_fixes::{minimal_edit, symbol_clash, without_edit};
use crate::edits::{changed, is_edits_path, read};
use crate::{Backend, Shared, convert, failed};
use grm_diag::SourceFile;
use grm_edits::locator::SemanticQuery;
use grm_edits::{Edit, Target};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;
use tower_lsp_server::jsonrpc::{Error, ErrorCode, Result};
use tower_lsp_server::ls_types::*;

/// `grm/edit` parameters.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct EditParams {
    /// The grammar (an open document or a file).
    pub uri: Uri,
    /// The system (default: the file's first).
    #[serde(default)]
    pub system: Option<String>,
    /// `{ "exact": "..." }`, `{ "semantic": "..." }`, `{ "key": "..." }`
    /// as in the file, or the text alone: a key (8 hex digits), an exact
    /// locator (`{...}`) or a semantic query (`(...) Label`).
    pub target: serde_json::Value,
    /// As in the file: `{ "op": "material", "name": "brick" }`; or
    /// `"remove"`.
    pub op: serde_json::Value,
    /// An optional note, kept in the file.
    #[serde(default)]
    pub note: Option<String>,
    /// For a key target: the symbol of the part the key names (`symbol`
    /// in the file). Without it, the server records the symbol the key's
    /// part has in the system's last preview, if that preview has it.
    /// Refused (R0911) for a target that is not a key.
    #[serde(default)]
    pub symbol: Option<String>,
}

/// `grm/removeEdit` parameters.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct RemoveEditParams {
    /// The grammar, or the edits file itself.
    pub uri: Uri,
    /// The system whose grammar file's edits file holds it (default: the
    /// edits file beside `uri`).
    #[serde(default)]
    pub system: Option<String>,
    pub id: u32,
}

/// `grm/retargetEdit` parameters: edit `id` gets `target` (one of the
/// candidates the preview proposed, or any target), keeping its id, so its
/// place among the edits (a later edit wins) stays.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct RetargetEditParams {
    /// The grammar, or the edits file itself.
    pub uri: Uri,
    /// As in `grm/removeEdit`.
    #[serde(default)]
    pub system: Option<String>,
    pub id: u32,
    /// As in `grm/edit`.
    pub target: serde_json::Value,
    /// As in `grm/edit`: for a key target, the symbol of the part the
    /// key names (a candidate's `symbol`); without it, the one the
    /// system's last preview gives the key.
    #[serde(default)]
    pub symbol: Option<String>,
}

/// `grm/edit`, `grm/removeEdit` and `grm/retargetEdit` result.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct EditResult {
    /// The edits file.
    pub uri: Uri,
    /// The edit added (or removed).
    pub id: u32,
    /// The change, as sent to the client in `workspace/applyEdit`.
    pub edit: WorkspaceEdit,
    /// Whether it was applied: the client's answer, or the server wrote
    /// the file itself (`written`).
    pub applied: bool,
    /// Why the client did not apply it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub failure_reason: Option<String>,
    /// The server wrote the file itself: the client cannot apply edits
    /// (it did not declare `workspace.applyEdit`, as `grmc view`).
    #[serde(default)]
    pub written: bool,
}

/// What the client can do with a workspace edit.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct EditCaps {
    apply: bool,
    document_changes: bool,
    create: bool,
}

impl EditCaps {
    /// The client applies `workspace/applyEdit`.
    pub(crate) fn can_apply(&self) -> bool {
        self.apply
    }

    /// The client takes `documentChanges` (versioned document edits).
    pub(crate) fn document_changes(&self) -> bool {
        self.document_changes
    }

    pub(crate) fn of(c: &ClientCapabilities) -> EditCaps {
        let w = c.workspace.as_ref();
        let we = w.and_then(|w| w.workspace_edit.as_ref());
        EditCaps {
            apply: w.and_then(|w| w.apply_edit).unwrap_or(false),
            document_changes: we.and_then(|e| e.document_changes).unwrap_or(false),
            create: we
                .and_then(|e| e.resource_operations.as_ref())
                .is_some_and(|r| r.contains(&ResourceOperationKind::Create)),
        }
    }
}

fn invalid(msg: impl Into<String>) -> Error {
    Error {
        code: ErrorCode::InvalidParams,
        message: msg.into().into(),
        data: None,
    }
}

/// The target of a `grm/edit` as the file writes it.
fn target_json(t: &serde_json::Value) -> Result<serde_json::Value> {
    match t {
        serde_json::Value::String(s) => {
            let s = s.trim();
            let kind = if grm_edits::file::parse_key(s).is_some() {
                "key"
            } else if s.starts_with('{') {
                "exact"
            } else if s.starts_with('(') {
                "semantic"
            } else {
                return Err(invalid(format!(
                    "target `{s}` is neither a key (8 hex digits), an exact locator (`{{...}}`) nor a semantic query (`(...) Label`)"
                )));
            };
            Ok(serde_json::json!({ kind: s }))
        }
        serde_json::Value::Object(_) => Ok(t.clone()),
        _ => Err(invalid(
            "target: a locator's text, or an object as in the edits file",
        )),
    }
}

/// The edit a `grm/edit` asks for, read as the file would read it (so its
/// problems are the file's: R0905-R0911, a `symbol` for a target that is
/// not a key among them).
fn requested_edit(p: &EditParams, system: &str) -> Result<Edit> {
    let mut obj = match &p.op {
        serde_json::Value::String(op) => serde_json::json!({ "op": op }),
        serde_json::Value::Object(o) => serde_json::Value::Object(o.clone()),
        _ => {
            return Err(invalid(
                "op: an object as in the edits file ({ \"op\": \"material\", \"name\": \"brick\" }), or \"remove\"",
            ));
        }
    };
    for k in ["id", "system", "target"] {
        if obj.get(k).is_some() {
            return Err(invalid(format!(
                "op: `{k}` is given apart from the operation"
            )));
        }
    }
    obj["id"] = 1.into();
    obj["system"] = system.into();
    obj["target"] = target_json(&p.target)?;
    if let Some(n) = &p.note {
        obj["note"] = n.clone().into();
    }
    if let Some(s) = &p.symbol {
        obj["symbol"] = s.clone().into();
    }
    let text = serde_json::json!({ "version": 1, "edits": [obj] }).to_string();
    let parsed = grm_edits::parse(&text);
    if let Some(e) = parsed.errors.first() {
        return Err(invalid(format!("{} ({})", e, e.code())));
    }
    parsed
        .file
        .edits
        .into_iter()
        .next()
        .ok_or_else(|| invalid("no edit"))
}

/// The edits file of `system` in the grammar at `uri` (the system's own
/// file's, which an import may hold), and the system's name.
async fn locate(
    shared: &Arc<Shared>,
    uri: &Uri,
    system: Option<String>,
) -> Result<(PathBuf, String)> {
    let path = convert::path_of(uri).ok_or_else(|| invalid("not a file URI"))?;
    if is_edits_path(&path) {
        return Ok((path, system.unwrap_or_default()));
    }
    let s = shared.clone();
    tokio::task::spawn_blocking(move || {
        let fa = s
            .analyze(&path)
            .ok_or_else(|| failed("the grammar cannot be read"))?;
        let prog = &fa.checked.program;
        let sys = match &system {
            Some(name) => prog
                .system(name)
                .ok_or_else(|| failed(format!("no system `{name}`")))?,
            None => prog
                .default_system()
                .ok_or_else(|| failed("the file defines no system"))?,
        };
        let file = grm_sema::normalize(Path::new(&fa.sources.get(sys.file).path));
        Ok((grm_edits::edits_path(&file), sys.name.clone()))
    })
    .await
    .map_err(|e| failed(e.to_string()))?
}

/// What the last preview of a system grew: the shape tree (shape mode)
/// or the derivation tree and the compiled system's symbol names (derive
/// and sample mode).
enum Grown {
    Shape(Arc<crate::shape_preview::ShapePicks>),
    Derived(Arc<(grm_grow::Tree, Vec<u32>)>, Vec<String>),
}

/// What the last preview of `system` whose edits file is `edits` grew
/// (the model as the preview shows it, its edits replayed): the preview of
/// the document at `uri` when it is one, else any document's (the first
/// by path). `None` when there is no such preview.
fn last_grown(shared: &Shared, uri: &Uri, edits: &Path, system: &str) -> Option<Grown> {
    let me = convert::path_of(uri);
    let picks = shared
        .picks
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let fits = |t: &&crate::preview::PickTable| {
        let shape = t.shape.as_ref().is_some_and(|s| {
            s.program().name() == system && s.edits.as_ref().is_none_or(|r| r.path == edits)
        });
        // Derive and sample mode name the system in their edits run.
        let derived = t.tree.is_some()
            && t.edits
                .as_ref()
                .is_some_and(|r| r.system == system && r.path == edits);
        shape || derived
    };
    let t = me
        .as_ref()
        .and_then(|p| picks.get(p))
        .filter(fits)
        .or_else(|| {
            // The others in a fixed order (the map's is not).
            let mut v: Vec<_> = picks.iter().filter(|(_, t)| fits(t)).collect();
            v.sort_by(|a, b| a.0.cmp(b.0));
            v.first().map(|(_, t)| *t)
        })?;
    match (&t.shape, &t.tree) {
        (Some(s), _) => Some(Grown::Shape(s.clone())),
        (None, Some(tree)) => Some(Grown::Derived(tree.clone(), t.symbols.clone())),
        (None, None) => None,
    }
}

/// How many parts `query` selects in the last shape preview of `system`
/// whose edits file is `edits` ([`last_grown`]). `None` when there is no
/// such preview or the query selects nothing there.
async fn selected_now(
    shared: &Arc<Shared>,
    uri: &Uri,
    edits: &Path,
    system: &str,
    query: SemanticQuery,
) -> Option<u32> {
    let Some(Grown::Shape(shape)) = last_grown(shared, uri, edits, system) else {
        return None;
    };
    tokio::task::spawn_blocking(move || {
        let n = shape.tree().select(shape.program(), &query).len();
        u32::try_from(n).ok().filter(|&n| n >= 1)
    })
    .await
    .ok()
    .flatten()
}

/// The symbol of the part with identity key `key` in the last preview of
/// `system` whose edits file is `edits` ([`last_grown`]): shape mode's
/// shapes with the key, derive and sample mode's modules. `None` when
/// there is no such preview, no part has the key there, or parts of two
/// symbols share it (the symbol is never guessed).
async fn symbol_now(
    shared: &Arc<Shared>,
    uri: &Uri,
    edits: &Path,
    system: &str,
    key: u32,
) -> Option<String> {
    let grown = last_grown(shared, uri, edits, system)?;
    tokio::task::spawn_blocking(move || match grown {
        Grown::Shape(s) => crate::edits::shape_key_symbol(s.tree(), s.program(), key),
        Grown::Derived(t, symbols) => crate::edits::tree_key_symbol(&t.0, &symbols, key),
    })
    .await
    .ok()
    .flatten()
}

/// The symbol an edit among `edits` of key `key` in `system` and `parcel`
/// records: the file's own record of what the key names (edits of one key
/// record one symbol, R0911), for a key the last preview does not know
/// (no such preview, or an edit removed the part before it was a node).
fn recorded_symbol(edits: &[Edit], system: &str, parcel: Option<u64>, key: u32) -> Option<String> {
    edits
        .iter()
        .filter(|e| {
            e.system == system
                && e.parcel == parcel
                && matches!(e.target, Target::Key(k) if k == key)
        })
        .find_map(|e| e.symbol.clone())
}

/// The InvalidParams error for an edit whose key's symbol is not the one
/// another edit of that key records ([`symbol_clash`]), if it is so.
fn check_symbol(file: &grm_edits::EditsFile, id: u32) -> Result<()> {
    let Some(e) = file.get(id) else {
        return Ok(());
    };
    match symbol_clash(&file.edits, e) {
        None => Ok(()),
        Some(other) => Err(invalid(format!(
            "the key's part is a `{}`, but edit {} of the same key records `{}` (a key names one part, of one symbol) (R0911)",
            e.symbol.as_deref().unwrap_or_default(),
            other.id,
            other.symbol.as_deref().unwrap_or_default(),
        ))),
    }
}

impl Backend {
    /// `grm/edit`: add an edit to the edits file.
    pub async fn edit(&self, params: EditParams) -> Result<EditResult> {
        let (path, system) = locate(&self.shared, &params.uri, params.system.clone()).await?;
        if system.is_empty() {
            return Err(invalid("give the grammar's URI (or a system) for grm/edit"));
        }
        let edit = requested_edit(&params, &system)?;
        let current = read(&self.shared.edits_source().open, &path)
            .map_err(|e| failed(format!("{e} ({})", e.code())))?;
        let (version, old) = match &current {
            Some((v, t)) => (*v, Some(t.clone())),
            None => (None, None),
        };
        let mut file = match &old {
            Some(t) => {
                let parsed = grm_edits::parse(t);
                if let Some(e) = parsed.errors.first() {
                    return Err(failed(format!(
                        "the edits file has {} problem{} (the first: {} ({})): fix {} first, it is rewritten whole",
                        parsed.errors.len(),
                        if parsed.errors.len() == 1 { "" } else { "s" },
                        e,
                        e.code(),
                        if parsed.errors.len() == 1 {
                            "it"
                        } else {
                            "them"
                        },
                    )));
                }
                parsed.file
            }
            None => grm_edits::EditsFile::default(),
        };
        // A query's count of parts: as the request gives it, else what it
        // selects in the system's last shape preview (docs/edits.md, "The
        // file": a later derivation where it selects more is ambiguous).
        let selected = match (&edit.target, edit.selected) {
            (_, Some(n)) => Some(n),
            (Target::Semantic(q), None) => {
                selected_now(&self.shared, &params.uri, &path, &system, q.clone()).await
            }
            _ => None,
        };
        // A key's symbol: as the request gives it, else the symbol of the
        // key's part in the system's last preview (docs/edits.md,
        // "Targets": the key then names a part of that symbol only), else
        // the one another edit of the key records.
        let symbol = match (&edit.target, edit.symbol) {
            (_, Some(s)) => Some(s),
            (Target::Key(k), None) => {
                match symbol_now(&self.shared, &params.uri, &path, &system, *k).await {
                    Some(s) => Some(s),
                    None => recorded_symbol(&file.edits, &edit.system, None, *k),
                }
            }
            _ => None,
        };
        let id = file
            .add(&edit.system, edit.target, edit.op)
            .ok_or_else(|| failed("no id is left after the largest"))?;
        if let Some(e) = file.edits.iter_mut().find(|e| e.id == id) {
            e.note = edit.note;
            e.selected = selected;
            e.symbol = symbol;
        }
        check_symbol(&file, id)?;
        let new = grm_edits::write(&file);
        self.apply(path, id, version, old.as_deref(), new, "grm: add edit")
            .await
    }

    /// `grm/removeEdit`: delete an edit from the edits file.
    pub async fn remove_edit(&self, params: RemoveEditParams) -> Result<EditResult> {
        let (path, _) = locate(&self.shared, &params.uri, params.system.clone()).await?;
        let current = read(&self.shared.edits_source().open, &path)
            .map_err(|e| failed(format!("{e} ({})", e.code())))?;
        let Some((version, old)) = current else {
            return Err(failed("there is no edits file"));
        };
        let (span, text) = without_edit(&old, params.id)
            .ok_or_else(|| failed(format!("the edits file has no edit {}", params.id)))?;
        let mut new = old.to_string();
        new.replace_range(span.range(), &text);
        self.apply(
            path,
            params.id,
            version,
            Some(&old),
            new,
            "grm: remove edit",
        )
        .await
    }

    /// `grm/retargetEdit`: give an edit another target, keeping its id.
    pub async fn retarget_edit(&self, params: RetargetEditParams) -> Result<EditResult> {
        let (path, _) = locate(&self.shared, &params.uri, params.system.clone()).await?;
        // The target read as the file reads it (R0909 for one that does not read).
        let probe = EditParams {
            uri: params.uri.clone(),
            system: None,
            target: params.target.clone(),
            op: serde_json::Value::String("remove".into()),
            note: None,
            symbol: params.symbol.clone(),
        };
        let probed = requested_edit(&probe, "S")?;
        let target = probed.target;
        let current = read(&self.shared.edits_source().open, &path)
            .map_err(|e| failed(format!("{e} ({})", e.code())))?;
        let Some((version, old)) = current else {
            return Err(failed("there is no edits file"));
        };
        let parsed = grm_edits::parse(&old);
        if let Some(e) = parsed.errors.first() {
            return Err(failed(format!(
                "the edits file has problems (the first: {e} ({})): fix them first, it is rewritten whole",
                e.code()
            )));
        }
        let mut file = parsed.file;
        let system = file
            .get(params.id)
            .map(|e| e.system.clone())
            .ok_or_else(|| failed(format!("the edits file has no edit {}", params.id)))?;
        // A query's count of parts and a key's symbol in the system's last
        // preview (the old target's count and symbol go with it; a key the
        // preview does not know keeps the symbol the file records for it).
        let selected = match &target {
            Target::Semantic(q) => {
                selected_now(&self.shared, &params.uri, &path, &system, q.clone()).await
            }
            _ => None,
        };
        let parcel = file.get(params.id).and_then(|e| e.parcel);
        let symbol = match (&target, probed.symbol) {
            (_, Some(s)) => Some(s),
            (Target::Key(k), None) => {
                match symbol_now(&self.shared, &params.uri, &path, &system, *k).await {
                    Some(s) => Some(s),
                    // The file's record (the edit's own, when it keeps its key).
                    None => recorded_symbol(&file.edits, &system, parcel, *k),
                }
            }
            _ => None,
        };
        file.retarget(params.id, target)
            .ok_or_else(|| failed(format!("the edits file has no edit {}", params.id)))?;
        if let Some(e) = file.edits.iter_mut().find(|e| e.id == params.id) {
            e.selected = selected;
            e.symbol = symbol;
        }
        check_symbol(&file, params.id)?;
        let new = grm_edits::write(&file);
        self.apply(
            path,
            params.id,
            version,
            Some(&old),
            new,
            "grm: retarget edit",
        )
        .await
    }

    /// Change the edits file `path` from `old` (`None`: it does not exist)
    /// to `new`: through the client's `workspace/applyEdit` when it can,
    /// else by writing the file.
    async fn apply(
        &self,
        path: PathBuf,
        id: u32,
        version: Option<i32>,
        old: Option<&str>,
        new: String,
        label: &str,
    ) -> Result<EditResult> {
        let caps = *self
            .shared
            .edit_caps
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let uri = self
            .shared
            .uris()
            .uri_of(&path)
            .ok_or_else(|| failed("the edits file has no URI"))?;
        let edit = workspace_edit(&uri, version, old, &new, caps);
        if !caps.apply {
            if version.is_some() {
                return Err(failed(
                    "the edits file is open in the editor, which cannot apply edits (workspace.applyEdit)",
                ));
            }
            let p = path.clone();
            tokio::task::spawn_blocking(move || write_file(&p, &new))
                .await
                .map_err(|e| failed(e.to_string()))?
                .map_err(|e| failed(format!("cannot write {}: {e}", path.display())))?;
            changed(&self.shared, &self.client, path, Duration::ZERO);
            return Ok(EditResult {
                uri,
                id,
                edit,
                applied: true,
                failure_reason: None,
                written: true,
            });
        }
        if old.is_none() && !(caps.document_changes && caps.create) {
            return Err(failed(
                "the edits file does not exist and the client cannot create files (workspaceEdit.resourceOperations)",
            ));
        }
        let answer = tokio::time::timeout(
            Duration::from_secs(60),
            self.client
                .send_request::<request::ApplyWorkspaceEdit>(ApplyWorkspaceEditParams {
                    label: Some(label.to_owned()),
                    edit: edit.clone(),
                }),
        )
        .await
        .map_err(|_| failed("the client did not answer workspace/applyEdit"))?
        .map_err(|e| failed(format!("workspace/applyEdit: {}", e.message)))?;
        Ok(EditResult {
            uri,
            id,
            edit,
            applied: answer.applied,
            failure_reason: answer.failure_reason,
            written: false,
        })
    }
}

/// Write `text` to `path` through a file beside it (renamed over it).
pub(crate) fn write_file(path: &Path, text: &str) -> std::io::Result<()> {
    let mut tmp = path.as_os_str().to_os_string();
    tmp.push(".tmp");
    let tmp = PathBuf::from(tmp);
    std::fs::write(&tmp, text)?;
    std::fs::rename(&tmp, path).inspect_err(|_| {
        let _ = std::fs::remove_file(&tmp);
    })
}

/// The workspace edit turning `old` into `new` in the file `uri` (created
/// when `old` is `None`).
pub(crate) fn workspace_edit(
    uri: &Uri,
    version: Option<i32>,
    old: Option<&str>,
    new: &str,
    caps: EditCaps,
) -> WorkspaceEdit {
    let (range, text) = match old {
        Some(old) => {
            let (span, text) = minimal_edit(old, new);
            (convert::range(&SourceFile::new("", old), span), text)
        }
        None => (Range::default(), new.to_owned()),
    };
    let text_edit = TextEdit {
        range,
        new_text: text,
    };
    if !caps.document_changes {
        return WorkspaceEdit {
            changes: Some(HashMap::from([(uri.clone(), vec![text_edit])])),
            ..WorkspaceEdit::default()
        };
    }
    let doc_edit = TextDocumentEdit {
        text_document: OptionalVersionedTextDocumentIdentifier {
            uri: uri.clone(),
            version,
        },
        edits: vec![OneOf::Left(text_edit)],
    };
    let changes = if old.is_none() {
        DocumentChanges::Operations(vec![
            DocumentChangeOperation::Op(ResourceOp::Create(CreateFile {
                uri: uri.clone(),
                options: Some(CreateFileOptions {
                    overwrite: Some(false),
                    ignore_if_exists: Some(true),
                }),
                annotation_id: None,
            })),
            DocumentChangeOperation::Edit(doc_edit),
        ])
    } else {
        DocumentChanges::Edits(vec![doc_edit])
    };
    WorkspaceEdit {
        document_changes: Some(changes),
        ..WorkspaceEdit::default()
    }
}

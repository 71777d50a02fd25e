//! `grm/layout` and `grm/layoutEdit` (docs/lsp-extensions.md, "City
//! layouts"): the editor's layout view of a `NAME.layout.json` sidecar
//! (issue 29, docs/layout.md).
//!
//! `grm/layout` evaluates the sidecar (the client's buffer when it is
//! open, else the file) with grm-layout's public road (each layer built,
//! then merged in order, with the layers as last built and a
//! [`MergeCache`] kept per file ([`Caches`]), so a drag's updates build
//! again only the layer that changed and reuse the merge's blocks and
//! parcels that did not) and answers the merged streets,
//! parcels and blocks, each with the layer it comes from, the layers, and
//! every problem with its code (the sidecar's R1021-R1026, a layer's
//! R1001-R1015).
//!
//! `grm/layoutEdit` applies one of the artist's operators to a layer (a
//! move of a selection, protect, cut to a new layer, an anchored
//! assignment, show or hide) by editing the document and writing it with
//! grm-layout's canonical writer. A move is first tried on the layer: a
//! move the transform rejects is answered with its code (R1013) and the
//! file is left alone. The change goes to the client as a
//! `workspace/applyEdit` (its undo reverts it), or, for a client that
//! cannot apply edits (`grmc view`), the server writes the file, as
//! `grm/edit` does (edit_requests.rs).

use crate::edit_requests::{EditCaps, workspace_edit, write_file};
use crate::{Backend, Shared, convert, failed};
use grm_layout::assign::Anchor;
use grm_layout::blocks::blocks;
use grm_layout::geom::Affine;
use grm_layout::id::Id;
use grm_layout::layers::{
    Document, LayerIssue, LayerSpec, Move, Select, Source, layer_layout, merge_layers_cached,
};
use grm_layout::model::{Layout, PROTECTED, TagValue, Tags};
use grm_layout::sidecar;
use grm_layout::subdivide::MergeCache;
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::collections::{BTreeSet, HashMap};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, PoisonError};
use tower_lsp_server::jsonrpc::{Error, ErrorCode, Result};
use tower_lsp_server::ls_types::*;

/// The file name ending of a layout sidecar.
pub(crate) const SUFFIX: &str = ".layout.json";

/// Whether `path` names a layout sidecar (`NAME.layout.json`).
pub fn is_layout_path(path: &Path) -> bool {
    path.file_name()
        .and_then(|n| n.to_str())
        .is_some_and(|n| n.len() > SUFFIX.len() && n.ends_with(SUFFIX))
}

/// The server's state of the layout sidecars.
#[derive(Debug, Default)]
pub(crate) struct LayoutState {
    /// The sidecars open in the client: version and text.
    docs: HashMap<PathBuf, (i32, Arc<str>)>,
    /// Per sidecar: what a drag's updates share.
    caches: HashMap<PathBuf, Arc<Mutex<Caches>>>,
    /// Per sidecar: the buildings last grown (layout_city.rs).
    pub(crate) cities: HashMap<PathBuf, Arc<Mutex<grm_layout::city::BuildingCache>>>,
}

/// What the evaluations of one sidecar keep between requests: the merge
/// cache, and each layer as last built with what built it (a drag's update
/// builds again only the layer whose spec changed).
#[derive(Debug, Default)]
pub(crate) struct Caches {
    merge: MergeCache,
    layers: Vec<Option<BuiltLayer>>,
}

/// A layer built from `spec` with `parcels`.
#[derive(Debug)]
struct BuiltLayer {
    spec: LayerSpec,
    parcels: grm_layout::subdivide::ParcelParams,
    layout: Layout,
    issues: Vec<LayerIssue>,
}

/// `grm/layout` parameters.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct LayoutParams {
    /// The sidecar, `NAME.layout.json`, or a grammar `NAME.grm` with a
    /// `layout` item (layout_grm.rs).
    pub uri: Uri,
    /// Also answer the merged layout's blocks.
    #[serde(default)]
    pub blocks: bool,
    /// Only say whether there is a layout (a grammar's item, by name):
    /// nothing is built, the lists are empty.
    #[serde(default)]
    pub probe: bool,
}

/// One layer as the view lists it.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct LayerOut {
    pub index: usize,
    pub name: String,
    pub visible: bool,
    /// How it merges onto the layers below: `hard` or `graph_cut`.
    pub merge: String,
    /// `grid`, `radial`, `geojson`, `features` or `empty`.
    pub source: String,
    pub moves: usize,
    pub protected: Vec<String>,
    pub assignments: usize,
    /// Its own streets and parcels (built, before the merge).
    pub streets: usize,
    pub parcels: usize,
}

/// A street of the merged layout.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct StreetOut {
    pub id: String,
    /// The topmost visible layer that has it (or the street it is a piece
    /// of); none for a street a merge made.
    pub layer: Option<usize>,
    /// Its identity in that layer (a piece's whole street).
    pub layer_id: Option<String>,
    pub points: Vec<[f64; 2]>,
    pub class: String,
    pub width: f64,
    pub protected: bool,
}

/// A parcel of the merged layout.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct ParcelOut {
    pub id: String,
    pub layer: Option<usize>,
    pub ring: Vec<[f64; 2]>,
    pub protected: bool,
    pub tags: serde_json::Map<String, Value>,
}

/// A block of the merged layout (when asked).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct BlockOut {
    pub id: String,
    pub ring: Vec<[f64; 2]>,
}

/// A problem with its stable code.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct LayoutProblem {
    pub code: String,
    pub message: String,
}

/// `grm/layout` result.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct LayoutResult {
    pub uri: Uri,
    /// The buffer's version, when the client has it open.
    pub version: Option<i32>,
    pub layers: Vec<LayerOut>,
    pub streets: Vec<StreetOut>,
    pub parcels: Vec<ParcelOut>,
    pub blocks: Vec<BlockOut>,
    /// The sidecar's problems (R1021-R1026), then the layers' (R1001-R1015).
    pub problems: Vec<LayoutProblem>,
    /// The merged layout's validity problems (none: the operators keep it valid).
    pub invalid: Vec<String>,
    /// `[min x, min y, max x, max y]` of the merged streets and parcels.
    pub bounds: [f64; 4],
    /// A grammar's layout item: its name (the edits go to `sidecar`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub item: Option<String>,
    /// Where the artist's edits are written: the sidecar itself, or the
    /// one beside the grammar (which may not exist yet).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sidecar: Option<Uri>,
}

/// `grm/layoutEdit` parameters.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct LayoutEditParams {
    pub uri: Uri,
    /// The layer the operator works on (its index, bottom first).
    pub layer: usize,
    /// One of (selections and points in the merged layout's coordinates,
    /// as the sidecar writes them):
    /// `{"move": {"select": SELECT, "translate": [dx, dy]}}`,
    /// `{"protect": {"ids": [...], "protected": true}}`,
    /// `{"cut": {"ids": [...], "name": "..."}}`,
    /// `{"assign": {"tags": {...}, "kinds": [...], "radius": r, "falloff": "linear", "at": [x, y], "anchor": ID}}`,
    /// `{"visible": false}`.
    pub op: Value,
}

/// `grm/layoutEdit` result.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct LayoutEditResult {
    pub uri: Uri,
    /// The sidecar changed (the client applied the edit, or the server
    /// wrote the file).
    pub applied: bool,
    /// The server wrote the file itself (a client without `workspace.applyEdit`).
    #[serde(default)]
    pub written: bool,
    /// The change sent in `workspace/applyEdit` (none when rejected).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub edit: Option<WorkspaceEdit>,
    /// Why the client did not apply it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub failure_reason: Option<String>,
    /// A move the transform rejected (R1013): nothing was written.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rejected: Option<LayoutProblem>,
    /// The layer a cut made.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub new_layer: Option<usize>,
}

/// The `grm/layoutUpdated` notification.
#[derive(Debug)]
pub enum LayoutUpdated {}

impl notification::Notification for LayoutUpdated {
    type Params = LayoutUpdatedParams;
    const METHOD: &'static str = "grm/layoutUpdated";
}

fn invalid(msg: impl Into<String>) -> Error {
    Error {
        code: ErrorCode::InvalidParams,
        message: msg.into().into(),
        data: None,
    }
}

fn pt(c: geo::Coord) -> [f64; 2] {
    [c.x, c.y]
}

fn tags_json(t: &Tags) -> serde_json::Map<String, Value> {
    t.iter()
        .map(|(k, v)| {
            let v = match v {
                TagValue::Num(x) => {
                    serde_json::Number::from_f64(*x).map_or(Value::Null, Value::Number)
                }
                TagValue::Text(s) => Value::String(s.clone()),
                TagValue::Bool(b) => Value::Bool(*b),
            };
            (k.clone(), v)
        })
        .collect()
}

fn is_protected(t: &Tags) -> bool {
    t.get(PROTECTED) == Some(&TagValue::Bool(true))
}

fn source_name(s: &Source) -> &'static str {
    match s {
        Source::Grid(_) => "grid",
        Source::Radial(_) => "radial",
        Source::GeoJson(_) => "geojson",
        Source::Features(_) => "features",
        Source::Empty => "empty",
    }
}

/// A sidecar read and evaluated.
pub(crate) struct Evaluated {
    pub(crate) doc: Document,
    pub(crate) errors: Vec<sidecar::SidecarError>,
    layers: Vec<Layout>,
    pub(crate) merged: Layout,
    pub(crate) issues: Vec<LayerIssue>,
    /// A `.grm`'s layout item (layout_grm.rs): where its edits go.
    pub(crate) grm: Option<crate::layout_grm::FromGrm>,
}

/// Reads the files a layer names, relative to the sidecar.
fn loader(path: &Path) -> impl Fn(&str) -> std::result::Result<String, String> + use<> {
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    move |p: &str| std::fs::read_to_string(dir.join(p)).map_err(|e| e.to_string())
}

/// Reads the sidecar `text` (at `path`) and merges its layers. A layer
/// whose spec and parcel knobs are those it was last built from is taken
/// from `cache` (one read from a GeoJSON file is built again: the file may
/// have changed).
pub(crate) fn evaluate_text(path: &Path, text: &str, cache: &mut Caches) -> Evaluated {
    let (doc, errors) = sidecar::read(text);
    evaluate_doc(path, doc, errors, cache)
}

/// Builds and merges the layers of `doc` (read from the file at `path`,
/// with `errors`), as [`evaluate_text`].
pub(crate) fn evaluate_doc(
    path: &Path,
    doc: Document,
    errors: Vec<sidecar::SidecarError>,
    cache: &mut Caches,
) -> Evaluated {
    let load = loader(path);
    let mut issues = Vec::new();
    let mut layers = Vec::with_capacity(doc.layers.len());
    let mut built = Vec::with_capacity(doc.layers.len());
    for (i, spec) in doc.layers.iter().enumerate() {
        let hit = cache.layers.get(i).and_then(Option::as_ref).filter(|b| {
            b.spec == *spec
                && b.parcels == doc.parcels
                && !matches!(spec.source, Source::GeoJson(_))
        });
        let (layout, own) = match hit {
            Some(b) => (b.layout.clone(), b.issues.clone()),
            None => {
                let mut own = Vec::new();
                let l = layer_layout(spec, &doc.parcels, &load, &mut own);
                (l, own)
            }
        };
        issues.extend(own.iter().cloned());
        built.push(Some(BuiltLayer {
            spec: spec.clone(),
            parcels: doc.parcels,
            layout: layout.clone(),
            issues: own,
        }));
        layers.push(layout);
    }
    cache.layers = built;
    let (merged, _) = merge_layers_cached(
        &doc.layers,
        &layers,
        &doc.parcels,
        &mut issues,
        &cache.merge,
    );
    Evaluated {
        doc,
        errors,
        layers,
        merged,
        issues,
        grm: None,
    }
}

/// The topmost visible layer holding `id`.
fn layer_of(ev: &Evaluated, id: Id, street: bool) -> Option<usize> {
    (0..ev.layers.len()).rev().find(|&i| {
        ev.doc.layers[i].visible
            && if street {
                ev.layers[i].streets.contains_key(&id)
            } else {
                ev.layers[i].parcels.contains_key(&id)
            }
    })
}

/// The sidecar's problems, then the layers'.
pub(crate) fn problems_of(ev: &Evaluated) -> Vec<LayoutProblem> {
    let mut problems: Vec<LayoutProblem> = ev
        .errors
        .iter()
        .map(|e| LayoutProblem {
            code: e.kind.code().to_string(),
            message: format!("{}: {}", e.path, e.message),
        })
        .collect();
    problems.extend(ev.issues.iter().map(|i| LayoutProblem {
        code: i.code().to_string(),
        message: i.describe(),
    }));
    problems
}

fn result(uri: Uri, version: Option<i32>, ev: &Evaluated, with_blocks: bool) -> LayoutResult {
    let mut lo = [f64::INFINITY, f64::INFINITY];
    let mut hi = [f64::NEG_INFINITY, f64::NEG_INFINITY];
    let mut grow = |p: [f64; 2]| {
        lo = [lo[0].min(p[0]), lo[1].min(p[1])];
        hi = [hi[0].max(p[0]), hi[1].max(p[1])];
    };
    let m = &ev.merged;
    let mut streets = Vec::new();
    for s in m.streets.values() {
        let Some(pl) = m.polyline(s) else { continue };
        let points: Vec<[f64; 2]> = pl.into_iter().map(pt).collect();
        points.iter().for_each(|p| grow(*p));
        // A piece of a cut street names the whole one (`part_of`).
        let whole = match s.tags.get("part_of") {
            Some(TagValue::Text(t)) => Id::parse(t),
            _ => None,
        };
        let (layer, layer_id) = match layer_of(ev, s.id, true) {
            Some(l) => (Some(l), Some(s.id)),
            None => match whole.and_then(|w| layer_of(ev, w, true).map(|l| (l, w))) {
                Some((l, w)) => (Some(l), Some(w)),
                None => (None, None),
            },
        };
        streets.push(StreetOut {
            id: s.id.to_string(),
            layer,
            layer_id: layer_id.map(|i| i.to_string()),
            points,
            class: s.class.name().to_string(),
            width: s.width,
            protected: is_protected(&s.tags),
        });
    }
    let parcels = m
        .parcels
        .values()
        .map(|p| {
            let ring: Vec<[f64; 2]> = p.ring.iter().map(|c| pt(*c)).collect();
            ring.iter().for_each(|p| grow(*p));
            ParcelOut {
                id: p.id.to_string(),
                layer: layer_of(ev, p.id, false),
                ring,
                protected: is_protected(&p.tags),
                tags: tags_json(&p.tags),
            }
        })
        .collect();
    let blocks_out = if with_blocks {
        blocks(m)
            .into_iter()
            .map(|b| BlockOut {
                id: b.id.to_string(),
                ring: b.ring.iter().map(|c| pt(*c)).collect(),
            })
            .collect()
    } else {
        Vec::new()
    };
    let layers = ev
        .doc
        .layers
        .iter()
        .enumerate()
        .map(|(i, l)| LayerOut {
            index: i,
            name: l.name.clone(),
            visible: l.visible,
            merge: l.merge.name().to_string(),
            source: source_name(&l.source).to_string(),
            moves: l.moves.len(),
            protected: l.protected.iter().map(Id::to_string).collect(),
            assignments: l.assignments.len(),
            streets: ev.layers.get(i).map_or(0, |x| x.streets.len()),
            parcels: ev.layers.get(i).map_or(0, |x| x.parcels.len()),
        })
        .collect();
    let problems = problems_of(ev);
    let bounds = if lo[0].is_finite() {
        [lo[0], lo[1], hi[0], hi[1]]
    } else {
        [0.0; 4]
    };
    LayoutResult {
        uri,
        version,
        layers,
        streets,
        parcels,
        blocks: blocks_out,
        problems,
        invalid: grm_layout::validity::check(m)
            .iter()
            .map(|v| v.describe())
            .collect(),
        bounds,
        item: ev.grm.as_ref().map(|g| g.item.clone()),
        sidecar: ev
            .grm
            .as_ref()
            .and_then(|g| crate::uris::uri_of(&g.sidecar)),
    }
}

// ------------------------------------------------------------------ edits

/// A selection given in the merged layout's coordinates, read as the
/// sidecar reads a move's (so its problems are the file's, R1021-R1026).
fn read_move(v: &Value) -> Result<Move> {
    let mv = v.as_object().ok_or_else(|| invalid("move: an object"))?;
    read_in_layer("move", "moves", mv.clone())?
        .moves
        .into_iter()
        .next()
        .ok_or_else(|| invalid("move: no move"))
}

/// The same, for an assignment (`anchor` is given as an element's id and
/// completed from the layer).
fn read_assignment(v: &Value) -> Result<grm_layout::assign::Assignment> {
    let mut a = v
        .as_object()
        .ok_or_else(|| invalid("assign: an object"))?
        .clone();
    a.remove("anchor");
    read_in_layer("assign", "assignments", a)?
        .assignments
        .into_iter()
        .next()
        .ok_or_else(|| invalid("assign: no assignment"))
}

/// `entry` read as the one element of a layer's `list` in a sidecar (its
/// problems the file's, named with `what`).
fn read_in_layer(
    what: &str,
    list: &str,
    entry: serde_json::Map<String, Value>,
) -> Result<grm_layout::layers::LayerSpec> {
    let mut layer = serde_json::Map::new();
    layer.insert("name".into(), "edit".into());
    layer.insert(list.into(), Value::Array(vec![Value::Object(entry)]));
    let text = serde_json::json!({ "version": 1, "layers": [layer] }).to_string();
    let (doc, errs) = sidecar::read(&text);
    if let Some(e) = errs.first() {
        return Err(invalid(format!(
            "{what}: {}: {} ({})",
            e.path,
            e.message,
            e.kind.code()
        )));
    }
    doc.layers
        .into_iter()
        .next()
        .ok_or_else(|| invalid(format!("{what}: no layer")))
}

fn ids_of(v: &Value, what: &str) -> Result<Vec<Id>> {
    v.get("ids")
        .and_then(Value::as_array)
        .ok_or_else(|| invalid(format!("{what}: `ids`, an array of identities")))?
        .iter()
        .map(|x| {
            x.as_str()
                .and_then(Id::parse)
                .ok_or_else(|| invalid(format!("{what}: `{x}` is not an identity (16 hex digits)")))
        })
        .collect()
}

/// The inverse of a layer's placement (its rotation, then translation).
fn unplace(spec: &LayerSpec) -> Affine {
    let p = spec.place;
    Affine::translate(-p.translate.x, -p.translate.y).then(&Affine::rotate(-p.rotate_deg, p.about))
}

/// A move given in merged coordinates, in the layer's own (moves come
/// before the layer's placement).
fn to_layer(spec: &LayerSpec, mut m: Move) -> Move {
    if spec.place.is_identity() {
        return m;
    }
    let inv = unplace(spec);
    let o = inv.apply(geo::Coord { x: 0.0, y: 0.0 });
    let d = inv.apply(m.translate);
    m.translate = geo::Coord {
        x: d.x - o.x,
        y: d.y - o.y,
    };
    m.about = inv.apply(m.about);
    m.select = match m.select {
        Select::Region(r) => Select::Region(r.into_iter().map(|c| inv.apply(c)).collect()),
        Select::Soft { centre, radius } => Select::Soft {
            centre: inv.apply(centre),
            radius,
        },
        other => other,
    };
    m
}

/// What an operator made of the document.
enum Outcome {
    Changed { new_layer: Option<usize> },
    Rejected(LayoutProblem),
}

/// Applies `op` to layer `li` of `ev.doc` (changed in place).
fn operate(path: &Path, ev: &mut Evaluated, li: usize, op: &Value) -> Result<Outcome> {
    let obj = op.as_object().filter(|o| o.len() == 1).ok_or_else(|| {
        invalid("op: an object with one operator (move, protect, cut, assign, visible)")
    })?;
    let (name, arg) = obj.iter().next().ok_or_else(|| invalid("op: empty"))?;
    if li >= ev.doc.layers.len() {
        return Err(invalid(format!(
            "there is no layer {li} (the file has {})",
            ev.doc.layers.len()
        )));
    }
    match name.as_str() {
        "move" => {
            let m = to_layer(&ev.doc.layers[li], read_move(arg)?);
            let mut spec = ev.doc.layers[li].clone();
            spec.moves.push(m);
            let index = spec.moves.len() - 1;
            let mut issues = Vec::new();
            let load = loader(path);
            layer_layout(&spec, &ev.doc.parcels, &load, &mut issues);
            if let Some(i) = issues
                .iter()
                .find(|i| matches!(i, LayerIssue::MoveRejected { index: k, .. } if *k == index))
            {
                return Ok(Outcome::Rejected(LayoutProblem {
                    code: i.code().to_string(),
                    message: i.describe(),
                }));
            }
            ev.doc.layers[li] = spec;
            Ok(Outcome::Changed { new_layer: None })
        }
        "protect" => {
            let ids = ids_of(arg, "protect")?;
            let on = arg
                .get("protected")
                .and_then(Value::as_bool)
                .unwrap_or(true);
            let built = &ev.layers[li];
            if let Some(id) = ids.iter().find(|i| built.kind_of(**i).is_none()) {
                return Err(invalid(format!("layer {li} has no element {id}")));
            }
            let p = &mut ev.doc.layers[li].protected;
            for id in ids {
                if on && !p.contains(&id) {
                    p.push(id);
                } else if !on {
                    p.retain(|x| *x != id);
                }
            }
            Ok(Outcome::Changed { new_layer: None })
        }
        "cut" => {
            let ids: BTreeSet<Id> = ids_of(arg, "cut")?.into_iter().collect();
            let name = arg.get("name").and_then(Value::as_str).map_or_else(
                || format!("{} (cut)", ev.doc.layers[li].name),
                str::to_owned,
            );
            let built = ev.layers[li].clone();
            if ids.iter().all(|i| built.kind_of(*i).is_none()) {
                return Err(invalid(format!("layer {li} has none of these elements")));
            }
            let new_layer = ev.doc.cut_to_layer(li, &ids, &built, &name);
            // Gone below; a protection goes up with it (its `protected` tag).
            ev.doc.layers[li].protected.retain(|x| !ids.contains(x));
            Ok(Outcome::Changed { new_layer })
        }
        "assign" => {
            let mut a = read_assignment(arg)?;
            if let Some(anchor) = arg.get("anchor").filter(|v| !v.is_null()) {
                let id = anchor
                    .as_str()
                    .and_then(Id::parse)
                    .ok_or_else(|| invalid("assign: `anchor`, an element's identity"))?;
                let built = &ev.layers[li];
                let kind = built
                    .kind_of(id)
                    .ok_or_else(|| invalid(format!("layer {li} has no element {id}")))?;
                let at = built
                    .position_of(id)
                    .ok_or_else(|| invalid(format!("element {id} has no position")))?;
                a.anchor = Some(Anchor {
                    element: id,
                    kind,
                    at,
                });
            }
            ev.doc.layers[li].assignments.push(a);
            Ok(Outcome::Changed { new_layer: None })
        }
        "visible" => {
            let on = arg
                .as_bool()
                .ok_or_else(|| invalid("visible: true or false"))?;
            ev.doc.layers[li].visible = on;
            Ok(Outcome::Changed { new_layer: None })
        }
        other => Err(invalid(format!(
            "op: unknown operator `{other}` (move, protect, cut, assign, visible)"
        ))),
    }
}

// ------------------------------------------------------------------ state

impl Shared {
    pub(crate) fn layouts_lock(&self) -> std::sync::MutexGuard<'_, LayoutState> {
        self.layouts.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// The sidecar's text: the client's buffer (with its version), else the file.
    pub(crate) fn layout_text(&self, path: &Path) -> Result<(Option<i32>, Arc<str>)> {
        if let Some((v, t)) = self.layouts_lock().docs.get(path) {
            return Ok((Some(*v), t.clone()));
        }
        let t = grm_diag::input::read_bounded_string(path, 64 << 20, "a layout file")
            .map_err(|e| failed(format!("cannot read {}: {e}", path.display())))?;
        Ok((None, Arc::from(t)))
    }

    pub(crate) fn layout_cache(&self, path: &Path) -> Arc<Mutex<Caches>> {
        self.layouts_lock()
            .caches
            .entry(path.to_path_buf())
            .or_default()
            .clone()
    }

    /// Whether the client has the sidecar `path` open.
    pub(crate) fn layout_is_open(&self, path: &Path) -> bool {
        self.layouts_lock().docs.contains_key(path)
    }

    /// Whether a layout view was shown for `path` (its caches are kept).
    pub(crate) fn layout_is_shown(&self, path: &Path) -> bool {
        self.layouts_lock().caches.contains_key(path)
    }

    pub(crate) fn layout_opened(&self, path: PathBuf, version: i32, text: String) {
        self.layouts_lock()
            .docs
            .insert(path, (version, Arc::from(text)));
    }

    /// A change of an open sidecar (full or incremental).
    pub(crate) fn layout_edited(&self, path: &Path, params: &DidChangeTextDocumentParams) {
        let mut st = self.layouts_lock();
        if let Some((_, old)) = st.docs.get(path) {
            let text = convert::apply_changes(old, &params.content_changes);
            st.docs.insert(
                path.to_path_buf(),
                (params.text_document.version, Arc::from(text)),
            );
        }
    }

    pub(crate) fn layout_closed(&self, path: &Path) {
        let mut st = self.layouts_lock();
        st.docs.remove(path);
        st.caches.remove(path);
        st.cities.remove(path);
    }
}

/// The sidecar a request names (InvalidParams for another file).
pub(crate) fn layout_path(uri: &Uri) -> Result<PathBuf> {
    let path = convert::path_of(uri).ok_or_else(|| invalid("not a file URI"))?;
    if !is_layout_path(&path) {
        return Err(invalid(format!(
            "{} is not a layout file (NAME{SUFFIX})",
            path.display()
        )));
    }
    Ok(path)
}

/// `grm/layoutUpdated` parameters: an open sidecar changed (its buffer);
/// a layout view asks `grm/layout` again.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct LayoutUpdatedParams {
    pub uri: Uri,
    pub version: i32,
}

impl Backend {
    /// `didOpen` of a sidecar.
    pub(crate) async fn layout_opened(&self, path: PathBuf, doc: TextDocumentItem, version: i32) {
        self.shared.layout_opened(path.clone(), version, doc.text);
        self.layout_notify(doc.uri, version).await;
        self.layout_notify_grammar(&path).await;
    }

    /// `didChange` of a sidecar.
    pub(crate) async fn layout_changed(&self, path: &Path, params: &DidChangeTextDocumentParams) {
        self.shared.layout_edited(path, params);
        let d = &params.text_document;
        self.layout_notify(d.uri.clone(), d.version).await;
        self.layout_notify_grammar(path).await;
    }

    /// A sidecar changed: the view of the grammar beside it (`NAME.grm`,
    /// when one was shown) asks for its layout again.
    async fn layout_notify_grammar(&self, sidecar: &Path) {
        let Some(stem) = sidecar
            .file_name()
            .and_then(|n| n.to_str())
            .and_then(|n| n.strip_suffix(SUFFIX))
        else {
            return;
        };
        let grm = sidecar.with_file_name(format!("{stem}.grm"));
        if self.shared.layout_is_shown(&grm)
            && let Some(uri) = self.shared.uris().uri_of(&grm)
        {
            let version = self.shared.version(&grm).unwrap_or(0);
            self.layout_notify(uri, version).await;
        }
    }

    /// A grammar changed (`didChange`): its layout view, if one was
    /// shown, asks for its layout again (a generator's argument regrows it).
    pub(crate) async fn layout_grammar_changed(&self, grm: &Path, uri: Uri, version: i32) {
        if self.shared.layout_is_shown(grm) {
            self.layout_notify(uri, version).await;
        }
    }

    async fn layout_notify(&self, uri: Uri, version: i32) {
        self.client
            .send_notification::<LayoutUpdated>(LayoutUpdatedParams { uri, version })
            .await;
    }

    /// `grm/layout`: the merged layout of a sidecar or a grammar's item.
    pub async fn layout(&self, params: LayoutParams) -> Result<LayoutResult> {
        let target = crate::layout_grm::target(&params.uri)?;
        if params.probe {
            return self.layout_probe(params.uri, &target).await;
        }
        let cache = self.shared.layout_cache(target.path());
        let uri = params.uri.clone();
        let shared = self.shared.clone();
        tokio::task::spawn_blocking(move || {
            let mut cache = cache.lock().unwrap_or_else(PoisonError::into_inner);
            let (version, ev) = crate::layout_grm::evaluate(&shared, &target, &mut cache)?;
            Ok(result(uri, version, &ev, params.blocks))
        })
        .await
        .map_err(|e| failed(e.to_string()))?
    }

    /// `grm/layout` with `probe`: whether there is a layout, built not.
    async fn layout_probe(
        &self,
        uri: Uri,
        target: &crate::layout_grm::Target,
    ) -> Result<LayoutResult> {
        let item = match target {
            crate::layout_grm::Target::Sidecar(_) => None,
            crate::layout_grm::Target::Grm(grm) => {
                let (shared, g) = (self.shared.clone(), grm.clone());
                let fa = tokio::task::spawn_blocking(move || shared.analyze(&g))
                    .await
                    .map_err(|e| failed(e.to_string()))?
                    .ok_or_else(|| failed(format!("cannot read {}", grm.display())))?;
                let def = fa.checked.program.layouts.first().ok_or_else(|| {
                    failed(format!(
                        "{} has no `layout NAME {{ ... }}` item",
                        grm.display()
                    ))
                })?;
                Some(def.name.clone())
            }
        };
        Ok(LayoutResult {
            version: self.shared.version(target.path()),
            uri,
            layers: Vec::new(),
            streets: Vec::new(),
            parcels: Vec::new(),
            blocks: Vec::new(),
            problems: Vec::new(),
            invalid: Vec::new(),
            bounds: [0.0; 4],
            sidecar: crate::uris::uri_of(&target.sidecar()),
            item,
        })
    }

    /// `grm/layoutEdit`: an operator on a layer, written to the sidecar.
    pub async fn layout_edit(&self, params: LayoutEditParams) -> Result<LayoutEditResult> {
        let target = crate::layout_grm::target(&params.uri)?;
        // The sidecar written: the one named, or the one beside the grammar.
        let path = target.sidecar();
        let (version, old) = match self.shared.layout_text_if_any(&path)? {
            Some((v, t)) => (v, Some(t)),
            None => (None, None),
        };
        let cache = self.shared.layout_cache(target.path());
        let shared = self.shared.clone();
        let (outcome, new) = tokio::task::spawn_blocking(move || -> Result<(Outcome, String)> {
            let mut cache = cache.lock().unwrap_or_else(PoisonError::into_inner);
            let (_, mut ev) = crate::layout_grm::evaluate(&shared, &target, &mut cache)?;
            let p = target.path().to_path_buf();
            if let Some(e) = ev.errors.first() {
                return Err(failed(format!(
                    "the layout file has {} problem{} (the first: {}: {} ({})): fix {} first, it is rewritten whole",
                    ev.errors.len(),
                    if ev.errors.len() == 1 { "" } else { "s" },
                    e.path,
                    e.message,
                    e.kind.code(),
                    if ev.errors.len() == 1 { "it" } else { "them" },
                )));
            }
            let before = ev.grm.is_some().then(|| ev.doc.clone());
            let o = operate(&p, &mut ev, params.layer, &params.op)?;
            let doc = match (&ev.grm, before) {
                (Some(g), Some(before)) => g.to_sidecar(&before, &ev.doc),
                _ => ev.doc.clone(),
            };
            Ok((o, sidecar::write(&doc)))
        })
        .await
        .map_err(|e| failed(e.to_string()))??;
        let uri = params.uri;
        // The sidecar's URI as the client spells it (the request's, or the
        // one beside a grammar).
        let side_uri = if convert::path_of(&uri).as_deref() == Some(path.as_path()) {
            uri.clone()
        } else {
            self.shared
                .uris()
                .uri_of(&path)
                .ok_or_else(|| failed(format!("no URI for {}", path.display())))?
        };
        let new_layer = match outcome {
            Outcome::Rejected(problem) => {
                return Ok(LayoutEditResult {
                    uri,
                    applied: false,
                    written: false,
                    edit: None,
                    failure_reason: None,
                    rejected: Some(problem),
                    new_layer: None,
                });
            }
            Outcome::Changed { new_layer } => new_layer,
        };
        let caps: EditCaps = *self
            .shared
            .edit_caps
            .lock()
            .unwrap_or_else(PoisonError::into_inner);
        let edit = workspace_edit(&side_uri, version, old.as_deref(), &new, caps);
        if !caps.can_apply() {
            let p = path.clone();
            let text = new.clone();
            tokio::task::spawn_blocking(move || write_file(&p, &text))
                .await
                .map_err(|e| failed(e.to_string()))?
                .map_err(|e| failed(format!("cannot write {}: {e}", path.display())))?;
            // The open buffer (grmc view's) is the file: keep it so.
            if let Some(d) = self.shared.layouts_lock().docs.get_mut(&path) {
                d.1 = Arc::from(new);
            }
            return Ok(LayoutEditResult {
                uri,
                applied: true,
                written: true,
                edit: Some(edit),
                failure_reason: None,
                rejected: None,
                new_layer,
            });
        }
        let answer = tokio::time::timeout(
            std::time::Duration::from_secs(60),
            self.client
                .send_request::<request::ApplyWorkspaceEdit>(ApplyWorkspaceEditParams {
                    label: Some("grm: layout edit".to_owned()),
                    edit: edit.clone(),
                }),
        )
        .await
        .map_err(|_| failed("the client did not answer workspace/applyEdit"))?
        .map_err(|e| failed(format!("workspace/applyEdit: {}", e.message)))?;
        Ok(LayoutEditResult {
            uri,
            applied: answer.applied,
            written: false,
            edit: Some(edit),
            failure_reason: answer.failure_reason,
            rejected: None,
            new_layer,
        })
    }
}

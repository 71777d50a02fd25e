//! The live-preview protocol (docs/lsp-extensions.md): `grm/preview`
//! derives and builds the model of a document, `grm/previewUpdated` sends
//! it again after debounced edits, `grm/pick` maps a picked triangle or
//! bone back to the production that made it.
//!
//! Buffers are base64 of little-endian `f32` / `u32` / `i32` arrays inside
//! the JSON: base64 is 4/3 of the raw size (decimal JSON numbers are about
//! 3x and must be parsed one by one), and a webview turns it into a
//! `Float32Array` with one `atob`. A request with `binary` (protocol 3)
//! gets them as ranges of a binary blob sent beside the message instead
//! ([`crate::blob`]), where the server has somewhere to send it.
//! Everything is computed on a blocking thread, never on the executor.
//!
//! Superseding: a `grm/preview` with `live: true` supersedes the document's
//! live request still in progress (the live preview is the document's one
//! current preview): the older one's [`CancelToken`] is set, its sampler
//! (or derivation) stops at its next check, and it is answered with
//! ServerCancelled (-32802). A request whose future is dropped (the
//! client's `$/cancelRequest`, answered RequestCancelled by
//! tower-lsp-server) sets its token too, so its work stops as well.
//!
//! Provenance and identity: the preview grows its model through
//! `grm_grow` (the road `grmc` takes too) in either mode: derive mode
//! (`grm_grow::Grower`) records the engine's own decisions: the production
//! that made every module (exact, never guessed, so `ambiguousOrigins` is
//! always 0), what descends from the focused production, and the
//! derivation tree; sample mode (`grm_grow::sample`) runs the guided
//! search with the request's curves, budget and cancel token and gives
//! the model shown (the result or a generation's frame) with its tree.
//! From the tree `grm/pick` answers the picked part's identity key and its
//! ancestry.

use crate::blob::{Buf, Enc};
use crate::{Backend, Shared, convert, failed};
use base64::Engine as _;
use grm_analysis::FileAnalysis;
use grm_compile::CompiledSystem;
use grm_derive::{DeriveLimits, ModuleString};
use grm_sample::CancelToken;
use grm_sema::{Mode, Value};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Instant;
use tower_lsp_server::Client;
use tower_lsp_server::jsonrpc::{Error, ErrorCode, Result};
use tower_lsp_server::ls_types::notification::Notification;
use tower_lsp_server::ls_types::{Position, Range, TextDocumentIdentifier, Uri};

mod build;
mod serve;
#[cfg(test)]
mod tests;

pub use build::*;
pub(crate) use serve::*;

/// Bumped on any incompatible change of the messages below.
/// 2: picks are base64 of six `u32`s each, no longer one object per pick.
/// 3: a request with `binary` gets its buffers as ranges of a binary blob
/// sent beside the answer ([`crate::blob`]); without it, as in 2.
pub const PROTOCOL_VERSION: u32 = 3;

/// No origin (a module whose maker is unknown).
pub const NO_ORIGIN: u32 = u32::MAX;

/// LSP 3.17's ServerCancelled: the answer of a `grm/preview` that a newer
/// live one for the same document superseded.
pub const SERVER_CANCELLED: i64 = -32802;

/// The most bytes a preview's model may need to build
/// ([`grm_geom::BuildOptions::max_bytes`]), as its derivation's limit.
pub const PREVIEW_MAX_BYTES: u64 = 1 << 30;

/// The largest `grm/preview` answer (and `grm/previewUpdated` payload):
/// the transport's limit on a message ([`crate::stdio::MAX_BODY`]). A
/// model whose answer would be larger is refused before it is encoded
/// (R0408), so that every request is answered.
pub const MAX_ANSWER_BYTES: u64 = crate::stdio::MAX_BODY as u64;

/// What the answer for `model` takes, at most, as JSON: its buffers in
/// base64 (4 characters per 3 bytes), the picks (24 bytes each, in
/// base64 too), a record per origin, and the rest.
pub fn answer_bytes(model: &grm_geom::Model, origins: usize) -> u64 {
    let b64 = |bytes: u64| bytes.div_ceil(3) * 4;
    let mut n: u64 = 64 << 10;
    for part in &model.parts {
        let v = part.mesh.positions.len() as u64;
        let t = part.mesh.indices.len() as u64 / 3;
        n += 2 * b64(12 * v) + b64(12 * t) + b64(24 * part.picks.len() as u64) + 256;
    }
    let bones = model.skeleton.bones.len() as u64;
    n += b64(32 * bones) + 2 * b64(4 * bones);
    n + 512 * origins as u64
}

/// Why a preview was not built.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Failure {
    /// A message for the user (RequestFailed).
    Msg(String),
    /// The request named a version; the document is at this one.
    Stale(i32),
    /// Its cancel token was set: superseded, or dropped by the client.
    Cancelled,
}

impl From<String> for Failure {
    fn from(m: String) -> Failure {
        Failure::Msg(m)
    }
}

impl From<&str> for Failure {
    fn from(m: &str) -> Failure {
        Failure::Msg(m.to_string())
    }
}

impl std::fmt::Display for Failure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Failure::Msg(m) => f.write_str(m),
            Failure::Stale(v) => write!(f, "the document changed: the current version is {v}"),
            Failure::Cancelled => f.write_str("the preview was cancelled"),
        }
    }
}

/// `Err(Cancelled)` once `cancel` is set.
pub(crate) fn check(cancel: Option<&CancelToken>) -> std::result::Result<(), Failure> {
    match cancel {
        Some(t) if t.is_cancelled() => Err(Failure::Cancelled),
        _ => Ok(()),
    }
}

/// How the model is grown.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PreviewMode {
    /// Parallel rewriting (the CPU derivation engine).
    #[default]
    Derive,
    /// The guided sampler (needs curves).
    Sample,
    /// A split grammar for buildings (`mode = shape`): the shape engine
    /// through `grm_grow::shape` (`crate::shape_preview`).
    Shape,
}

/// `grm/preview` parameters.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct PreviewParams {
    pub text_document: TextDocumentIdentifier,
    /// The document version the client shows; a different current version
    /// is answered with ContentModified.
    #[serde(default)]
    pub version: Option<i32>,
    /// Default: the system's own `mode`.
    #[serde(default)]
    pub mode: Option<PreviewMode>,
    /// The system to grow (default: the file's first).
    #[serde(default)]
    pub system: Option<String>,
    #[serde(default)]
    pub seed: Option<u32>,
    #[serde(default)]
    pub iterations: Option<u32>,
    /// Meta-parameter values by name (sliders).
    #[serde(default)]
    pub params: BTreeMap<String, f64>,
    /// Guiding curves (docs/curves.md format), for sample mode.
    #[serde(default)]
    pub curves: Option<serde_json::Value>,
    /// A position in a production: the parts it grows are marked, and the
    /// count is taken over `spreadSeeds` seeds.
    #[serde(default)]
    pub focus: Option<Position>,
    /// Seeds for the focus spread (default 8, at most 64).
    #[serde(default)]
    pub spread_seeds: Option<u32>,
    /// Send `grm/previewUpdated` after edits of this document.
    #[serde(default)]
    pub live: bool,
    /// Live requests: who sends them (any string, the same for all of one
    /// client's requests) and their order (growing with each one the client
    /// sends). A live request whose client has begun a later one for the
    /// document is answered ServerCancelled at once, whatever order they
    /// arrive in.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub client: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub order: Option<u64>,
    /// Stop growing past this many modules (default 2,000,000).
    #[serde(default)]
    pub max_modules: Option<u64>,
    /// Sample mode: stop the search after this much wall time (default
    /// 5,000 ms; the result then says `stoppedEarly`).
    #[serde(default)]
    pub budget_ms: Option<u64>,
    /// Sample mode: show the model the search returns when stopped after
    /// this generation (0-based; `grmc sample --generation`) instead of
    /// the result; past the last generation run, the result. Costs one
    /// frame of the search (`grm_sample::Sampler::sample_frame`). Ignored
    /// in derive mode.
    #[serde(default)]
    pub generation: Option<u32>,
    /// Focus and context (issue 28): the subtree of the node with this key
    /// shown `depth` levels down, the rest as proxies: shape mode, the rest
    /// of the building as boxes at its level; derive mode, the other bones
    /// without tubes (the skeleton's lines) and no other instances or
    /// polygons (docs/lsp-extensions.md).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub context: Option<ContextIn>,
    /// Protocol 3: the buffers as ranges of a binary blob sent beside the
    /// answer (where the server has somewhere to send it, [`crate::blob`]),
    /// not as base64 text.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub binary: bool,
}

/// `grm/preview`'s `context`: a shape's key and how many levels below it
/// are drawn.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "camelCase")]
pub struct ContextIn {
    pub key: String,
    pub depth: u32,
}

/// A run of triangles of a part and what made it: one record of a part's
/// `picks` buffer, decoded ([`decode_picks`]). On the wire a pick is
/// [`PICK_WORDS`] little-endian `u32`s (a building's preview has tens of
/// thousands of picks: one JSON object each was most of its answer).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct PickOut {
    pub first_triangle: u32,
    pub triangle_count: u32,
    /// `bone`, `instance`, `polygon` or `shape`.
    pub kind: std::borrow::Cow<'static, str>,
    /// Index into the skeleton's bones / instances / polygons.
    pub index: u32,
    /// The module of the derived string.
    pub module: u32,
    /// Index into [`PreviewResult::origins`], if known.
    pub origin: Option<u32>,
    /// Grown by the focused production.
    pub focus: bool,
}

/// `u32`s per pick in a part's `picks` buffer: first triangle, triangle
/// count, kind code (+ [`PICK_FOCUS`] when focused), index, module, origin
/// (`0xFFFFFFFF` unknown).
pub const PICK_WORDS: usize = 6;

/// The kinds of a pick, by their code in the `picks` buffer.
pub const PICK_KINDS: [&str; 4] = ["bone", "instance", "polygon", "shape"];

/// Added to a pick's kind code when the focused production grew it.
pub const PICK_FOCUS: u32 = 0x100;

/// A part's `picks` buffer (base64 of [`PICK_WORDS`] little-endian `u32`s
/// per pick) as records; `None` when it is not one.
pub fn decode_picks(b64: &str) -> Option<Vec<PickOut>> {
    let bytes = base64::engine::general_purpose::STANDARD.decode(b64).ok()?;
    if bytes.len() % (4 * PICK_WORDS) != 0 {
        return None;
    }
    bytes
        .chunks_exact(4 * PICK_WORDS)
        .map(|r| {
            let w =
                |i: usize| u32::from_le_bytes([r[4 * i], r[4 * i + 1], r[4 * i + 2], r[4 * i + 3]]);
            Some(PickOut {
                first_triangle: w(0),
                triangle_count: w(1),
                kind: std::borrow::Cow::Borrowed(PICK_KINDS.get((w(2) & 0xff) as usize)?),
                index: w(3),
                module: w(4),
                origin: (w(5) != u32::MAX).then_some(w(5)),
                focus: w(2) & PICK_FOCUS != 0,
            })
        })
        .collect()
}

/// One material's triangles.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct PartOut {
    pub material: usize,
    pub vertex_count: usize,
    pub triangle_count: usize,
    /// base64 of `f32` x, y, z per vertex.
    pub positions: Buf,
    /// base64 of `f32` unit normals, one per vertex; empty when they are
    /// the flat normals of the triangles (`grm_geom::MeshData::flat_normals`:
    /// the client computes them, summing each vertex's face normals).
    pub normals: Buf,
    /// base64 of `u32` vertex indices, three per triangle (empty in the
    /// `quads` layout).
    pub indices: Buf,
    /// The number of picks (runs of triangles and what made them).
    pub pick_count: usize,
    /// base64 of [`PICK_WORDS`] `u32`s per pick, by first triangle
    /// ([`PickOut`], [`decode_picks`]).
    pub picks: Buf,
    /// `quads` when the part is parallelogram quads
    /// (`grm_geom::MeshData::is_quads`): `positions` holds the corners
    /// `a b c` of each quad (nine floats), the fourth being `a + c - b`,
    /// and `indices` and `normals` are empty; the client rebuilds the mesh
    /// (vertices `a b c d`, triangles `a b c` and `a c d`, flat normals).
    /// `vertexCount` and `triangleCount` (and the picks' triangles) count
    /// the rebuilt mesh. Absent: triangles as above.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub layout: Option<String>,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct MaterialOut {
    pub name: String,
    pub color: [f32; 3],
    pub roughness: f32,
    pub metallic: f32,
    pub emissive: [f32; 3],
    pub opacity: f32,
}

/// The skeleton: one record per bone.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct SkeletonOut {
    pub bone_count: usize,
    /// base64 of `f32` per bone: base x y z, tip x y z, width at base, at tip.
    pub bones: Buf,
    /// base64 of `i32` per bone: the parent bone, -1 for none.
    pub parents: Buf,
    /// base64 of `u32` per bone: index into the origins, `0xFFFFFFFF` unknown.
    pub origins: Buf,
}

/// A production that made part of the model.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct OriginOut {
    pub uri: Uri,
    pub range: Range,
    /// The predecessor symbol (or `axiom`).
    pub symbol: String,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct StatsOut {
    pub modules: usize,
    pub vertices: usize,
    pub triangles: usize,
    pub bones: usize,
    pub instances: usize,
    pub polygons: usize,
    pub parts: usize,
    pub dropped: usize,
    pub bounds_min: [f32; 3],
    pub bounds_max: [f32; 3],
    /// Always 0: origins come from the engine's own decisions (kept for
    /// clients of protocol version 1, where origins were aligned after the
    /// fact and could tie).
    pub ambiguous_origins: usize,
    pub derive_ms: f64,
    pub build_ms: f64,
    pub encode_ms: f64,
}

/// What the focused production grows.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct FocusOut {
    /// Index into the origins.
    pub origin: u32,
    /// Bones and instances it grows with the requested seed.
    pub bones: usize,
    pub instances: usize,
    /// Bones it grows with each of the spread seeds (`seed`, `seed + 1`, ...).
    pub spread_bones: Vec<usize>,
}

/// `grm/preview` result (also the payload of `grm/previewUpdated`).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct PreviewResult {
    pub uri: Uri,
    pub version: i32,
    pub system: String,
    pub mode: PreviewMode,
    pub seed: u32,
    pub iterations: u32,
    /// `base64-le`: the buffers are base64 text; `blob-le`: ranges of
    /// `blob` (protocol 3, [`crate::blob`]).
    pub encoding: String,
    /// Protocol 3: the blob the buffers' ranges are in, sent before this
    /// message.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub blob: Option<crate::blob::BlobRef>,
    pub materials: Vec<MaterialOut>,
    pub parts: Vec<PartOut>,
    pub skeleton: SkeletonOut,
    pub origins: Vec<OriginOut>,
    pub focus: Option<FocusOut>,
    /// The meta-parameters with the values used (for sliders).
    pub params: Vec<ParamOut>,
    /// Sample mode: how the search went.
    pub sample: Option<SampleOut>,
    pub stats: StatsOut,
    /// What the model lacks that its string asked for (W0013 no
    /// triangles, W0014 geometry left out), as `grmc derive -o` prints
    /// them: these depend on the seed and the parameters, so they come
    /// with the model rather than with the file's diagnostics.
    pub warnings: Vec<WarningOut>,
    /// Shape mode: the derivation tree's figures.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shape: Option<crate::shape_preview::ShapeOut>,
    /// Shape mode: the edits file beside the system's grammar, replayed,
    /// and what became of each of its edits.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub edits: Option<crate::edits::EditsOut>,
}

impl PreviewResult {
    /// Protocol 3: moves the buffers' bytes into blob `id` (each buffer
    /// becomes its range; `encoding` becomes `blob-le`). `None` when
    /// they are base64 text already (a request without `binary`).
    pub fn take_blob(&mut self, id: u64) -> Option<crate::blob::Blob> {
        let s = &mut self.skeleton;
        let skeleton = [&mut s.bones, &mut s.parents, &mut s.origins];
        let bufs = self.parts.iter_mut().flat_map(PartOut::bufs);
        let (bytes, chunks) = crate::blob::gather(bufs.chain(skeleton))?;
        self.encoding = "blob-le".into();
        self.blob = Some(crate::blob::BlobRef { id, bytes });
        Some(crate::blob::Blob { id, chunks })
    }
}

impl PartOut {
    /// Its buffers, in the order a blob holds them.
    pub(crate) fn bufs(&mut self) -> [&mut Buf; 4] {
        [
            &mut self.positions,
            &mut self.normals,
            &mut self.indices,
            &mut self.picks,
        ]
    }
}

/// How a request's buffers are written.
pub(crate) fn encoding(p: &PreviewParams) -> Enc {
    if p.binary { Enc::Binary } else { Enc::Base64 }
}

/// A model warning (`grm_geom::Model::warnings`).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct WarningOut {
    /// The stable code, e.g. `W0013`.
    pub code: String,
    pub message: String,
    /// What the builder counted (e.g. bones without a tube).
    pub notes: Vec<String>,
    pub help: Option<String>,
}

impl WarningOut {
    /// The model builder's warnings (`grm_geom::Model::warnings`) as sent.
    pub(crate) fn all(diags: Vec<grm_diag::Diagnostic>) -> Vec<WarningOut> {
        diags
            .into_iter()
            .map(|d| WarningOut {
                code: d.code.as_str().to_string(),
                message: d.message,
                notes: d.notes,
                help: d.help,
            })
            .collect()
    }
}

/// A meta-parameter: its value in this preview, its default and range.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct ParamOut {
    pub name: String,
    pub value: f64,
    pub default: f64,
    pub min: Option<f64>,
    pub max: Option<f64>,
}

/// Figures of a guided-sampler run.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct SampleOut {
    /// The best model's objective (curve cost).
    pub objective: f64,
    pub generations: usize,
    /// Distinct final particles the best was chosen from.
    pub candidates: usize,
    /// The wall-clock budget stopped the search early.
    pub stopped_early: bool,
    /// Refinement rounds run to their end after the search, within the
    /// budget (`grm_sample::Refine`; docs/sampling.md 4.5): the model shown
    /// is the best of the pass and these rounds.
    #[serde(default)]
    pub refinements: u32,
    /// Where the curves came from (`request` or a file path).
    pub curves: String,
    /// The generation whose model is shown, when the request asked for one
    /// (the last generation run: the result); else absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub generation: Option<usize>,
    /// How much of each curve the shown model follows, in the curves'
    /// order (docs/curves.md 2.8; the page tints the gaps).
    #[serde(default)]
    pub coverage: Vec<crate::coverage::CoverageOut>,
}

/// `grm/previewUpdated` parameters: a new model, or why there is none.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct PreviewUpdatedParams {
    pub uri: Uri,
    pub version: i32,
    pub result: Option<PreviewResult>,
    pub error: Option<String>,
}

/// The `grm/previewUpdated` notification.
#[derive(Debug)]
pub enum PreviewUpdated {}

impl Notification for PreviewUpdated {
    type Params = PreviewUpdatedParams;
    const METHOD: &'static str = "grm/previewUpdated";
}

/// `grm/pick` parameters: a triangle of a part, or a bone.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct PickParams {
    pub text_document: TextDocumentIdentifier,
    #[serde(default)]
    pub part: Option<usize>,
    #[serde(default)]
    pub triangle: Option<u32>,
    #[serde(default)]
    pub bone: Option<u32>,
}

/// `grm/pick` result: where the picked thing came from.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct PickResult {
    pub uri: Uri,
    pub range: Range,
    pub symbol: String,
    /// The version of the preview the pick refers to.
    pub version: i32,
    pub module: u32,
    /// The picked part's identity key (8 hex digits; docs/engine.md,
    /// "Identity"): the same part has the same key after the model is
    /// regrown with other parameters, a new seed for the rest, or an edit
    /// to a production it does not descend from.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub key: Option<String>,
    /// Its ancestry, from the axiom (first) down to the part (last).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub ancestry: Vec<AncestryOut>,
    /// Shape mode: the picked shape's locators and its ancestors' scopes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shape: Option<crate::shape_preview::ShapePickOut>,
}

/// One step of a part's ancestry.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct AncestryOut {
    /// The node's identity key (8 hex digits).
    pub key: String,
    /// Its symbol (`null` for the axiom).
    pub symbol: Option<String>,
    /// Its place among its parent's children (its module's index in the
    /// parent's successor); `null` for the axiom.
    pub child: Option<u32>,
    /// The production that rewrote it (an index into the preview's
    /// origins); `null` where none did (the part itself, in derive mode).
    pub production: Option<u32>,
}

/// What `grm/pick` needs from the last preview of a document.
#[derive(Clone, Debug, Default)]
pub(crate) struct PickTable {
    pub(crate) version: i32,
    /// Per part: (first triangle, count, module, origin).
    pub(crate) parts: Vec<Vec<(u32, u32, u32, u32)>>,
    /// Per bone: (module, origin).
    pub(crate) bones: Vec<(u32, u32)>,
    pub(crate) origins: Vec<OriginOut>,
    /// The compiled system's symbol names.
    pub(crate) symbols: Vec<String>,
    /// The derivation tree and each node's place among its siblings.
    pub(crate) tree: Option<Arc<(grm_grow::Tree, Vec<u32>)>>,
    /// Shape mode: the shape tree and where its rules are written.
    pub(crate) shape: Option<Arc<crate::shape_preview::ShapePicks>>,
    /// Derive mode: the edits file replayed, and what became of its edits
    /// (shape mode keeps its own in `shape`).
    pub(crate) edits: Option<Arc<crate::edits::EditsRun>>,
}

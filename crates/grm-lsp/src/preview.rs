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

#[cfg(test)]
fn f32s(xs: &[f32]) -> String {
    crate::b64::words(xs, f32::to_le_bytes)
}

#[cfg(test)]
fn u32s(xs: &[u32]) -> String {
    crate::b64::words(xs, u32::to_le_bytes)
}

#[cfg(test)]
fn i32s(xs: &[i32]) -> String {
    crate::b64::words(xs, i32::to_le_bytes)
}

#[cfg(test)]
fn quad_corners(mesh: &grm_geom::MeshData) -> String {
    crate::b64::quad_corners(&mesh.positions)
}

/// A derived string with provenance.
struct Grown {
    string: ModuleString,
    origin: Option<Vec<u32>>,
    focus: Vec<bool>,
    tree: Option<grm_grow::Tree>,
    /// What the persistent edits met (with a plan).
    edits: Option<grm_derive::EditOutcome>,
}

/// Derive `sys` through `grm_grow`, recording origins, the focus flags
/// and (`tree`) the derivation tree; stops when `cancel` is set.
#[cfg(test)]
fn grow(
    sys: &CompiledSystem,
    iterations: u32,
    seed: u32,
    max_modules: u64,
    focus: Option<u32>,
    tree: bool,
    cancel: Option<&CancelToken>,
) -> std::result::Result<Grown, Failure> {
    grow_edited(
        sys,
        iterations,
        seed,
        max_modules,
        focus,
        tree,
        None,
        cancel,
    )
}

/// [`grow`], replaying `edits` (the system's persistent edits, docs/
/// edits.md) while deriving.
#[allow(clippy::too_many_arguments)]
fn grow_edited(
    sys: &CompiledSystem,
    iterations: u32,
    seed: u32,
    max_modules: u64,
    focus: Option<u32>,
    tree: bool,
    edits: Option<&grm_derive::EditPlan>,
    cancel: Option<&CancelToken>,
) -> std::result::Result<Grown, Failure> {
    let record = grm_grow::Record {
        tree,
        origins: true,
        keys: true,
        focus: Some(focus.unwrap_or(NO_ORIGIN)),
    };
    let mut grower = grm_grow::Grower::new(sys, 1, record).map_err(|e| e.to_string())?;
    if let Some(plan) = edits {
        grower = grower.with_edits(plan.clone()).map_err(|e| e.to_string())?;
    }
    let opts = grm_derive::DeriveOptions {
        iterations,
        seed,
        limits: DeriveLimits {
            max_modules,
            max_bytes: 1 << 30,
        },
    };
    let stop = || cancel.is_some_and(CancelToken::is_cancelled);
    let g = grower
        .derive_until(&opts, &mut |_| {}, &stop)
        .map_err(|e| e.to_string())?
        .ok_or(Failure::Cancelled)?;
    Ok(Grown {
        focus: g.focus.unwrap_or_default(),
        origin: g.origins,
        tree: g.tree,
        string: g.string,
        edits: g.edits,
    })
}

/// A built model and what the preview reports about its growth.
struct Made {
    model: grm_geom::Model,
    /// Modules of the final string.
    modules: usize,
    /// Per module: grown by the focused production.
    focus_flags: Vec<bool>,
    /// The derivation tree (identity and ancestry for `grm/pick`).
    tree: Option<grm_grow::Tree>,
    derive_ms: f64,
    build_ms: f64,
    focus_out: Option<FocusOut>,
    sample: Option<SampleOut>,
    /// Derive mode: what the persistent edits met.
    edits: Option<grm_derive::EditOutcome>,
    /// Sample mode: what became of the persistent edits replayed.
    sampled_edits: Option<Vec<grm_grow::edits::EditReport>>,
}

/// Derive mode: the CPU engine through `grm_grow`, exact provenance,
/// focus spread over seeds; `edits` replayed (the spread's seeds too).
#[allow(clippy::too_many_arguments)]
fn derive_model(
    prog: &grm_sema::Program,
    sys: &grm_sema::System,
    compiled: &CompiledSystem,
    settings: &grm_sema::Settings,
    p: &PreviewParams,
    focus: Option<u32>,
    edits: Option<&grm_derive::EditPlan>,
    cancel: Option<&CancelToken>,
) -> std::result::Result<Made, Failure> {
    let max_modules = p.max_modules.unwrap_or(2_000_000).min(50_000_000);
    let t0 = Instant::now();
    let grown = grow_edited(
        compiled,
        settings.iterations,
        settings.seed,
        max_modules,
        focus,
        true,
        edits,
        cancel,
    )?;
    let derive_ms = t0.elapsed().as_secs_f64() * 1e3;
    check(cancel)?;
    let t1 = Instant::now();
    // Focus and context: the modules a few levels below the focused one
    // are meshed, the rest left to the skeleton's lines (an unknown key:
    // the whole model).
    let window = p.context.as_ref().and_then(|c| {
        let key = grm_edits::file::parse_key(c.key.trim())?;
        grown.tree.as_ref()?.focus_window(key, c.depth)
    });
    let in_window = |m: u32| {
        window
            .as_ref()
            .is_some_and(|w| w.get(m as usize) == Some(&true))
    };
    let mut model = grm_geom::build_model_drawn(
        prog,
        sys,
        &grown.string,
        settings,
        &compiled.param_values,
        &grm_geom::BuildOptions::limited(PREVIEW_MAX_BYTES, grm_geom::Output::Model),
        window
            .is_some()
            .then_some(&in_window as &dyn Fn(u32) -> bool),
    )
    .map_err(|e| too_large(&e))?;
    if let Some(o) = &grown.origin {
        model.fill_origins(o);
    }
    let build_ms = t1.elapsed().as_secs_f64() * 1e3;
    // Focus spread over seeds: bones grown by the focused production.
    let mut focus_out = None;
    if let Some(fo) = focus {
        let count = |g: &Grown, m: &grm_geom::grm_turtle::Interpretation| {
            let bones = m
                .bones
                .iter()
                .filter(|b| g.focus.get(b.module as usize) == Some(&true))
                .count();
            let inst = m
                .instances
                .iter()
                .filter(|b| g.focus.get(b.module as usize) == Some(&true))
                .count();
            (bones, inst)
        };
        let (bones, instances) = count(&grown, &model.skeleton);
        let n = p.spread_seeds.unwrap_or(8).clamp(1, 64);
        let mut spread = Vec::with_capacity(n as usize);
        for k in 0..n {
            let seed = settings.seed.wrapping_add(k);
            let g = grow_edited(
                compiled,
                settings.iterations,
                seed,
                max_modules,
                focus,
                false,
                edits,
                cancel,
            )?;
            let mut st = settings.clone();
            st.seed = seed;
            let interp =
                grm_geom::grm_turtle::interpret(sys, &st, &g.string).map_err(|e| e.to_string())?;
            spread.push(count(&g, &interp).0);
        }
        focus_out = Some(FocusOut {
            origin: fo,
            bones,
            instances,
            spread_bones: spread,
        });
    }
    Ok(Made {
        modules: grown.string.len(),
        focus_flags: grown.focus,
        tree: grown.tree,
        model,
        derive_ms,
        build_ms,
        focus_out,
        sample: None,
        edits: grown.edits,
        sampled_edits: None,
    })
}

/// Sample mode: the guided sampler through `grm_grow::sample` with the
/// request's curves (or the file's `NAME.curves.json` next to it); the
/// sampler reports provenance itself. Focus marks what the focused
/// production made directly. `edits` (the edits file's, those of other
/// systems skipped) are replayed in the sampler and classified against
/// the model shown.
#[allow(clippy::too_many_arguments)]
fn sample_model(
    fa: &FileAnalysis,
    sys: &grm_sema::System,
    compiled: &CompiledSystem,
    settings: &grm_sema::Settings,
    p: &PreviewParams,
    focus: Option<u32>,
    edits: Option<&[grm_edits::Edit]>,
    cancel: Option<&CancelToken>,
) -> std::result::Result<Made, Failure> {
    let prog = &fa.checked.program;
    let (curves, from) = match &p.curves {
        Some(v) => (
            grm_guide::Curves::from_json_str("request", &v.to_string())
                .map_err(|e| e.to_string())?,
            "request".to_string(),
        ),
        None => {
            let path = std::path::Path::new(&fa.source().path).with_extension("curves.json");
            if !path.is_file() {
                return Err(Failure::Msg(format!(
                    "sample mode needs guiding curves: pass `curves`, or put them in {}",
                    path.display()
                )));
            }
            (
                grm_guide::Curves::load(&path).map_err(|e| e.to_string())?,
                path.display().to_string(),
            )
        }
    };
    let t0 = Instant::now();
    let opts = grm_sample::SampleOptions {
        seed: settings.seed,
        schedule: grm_sample::Schedule::from_settings(settings),
        threads: 1,
        budget: Some(std::time::Duration::from_millis(
            p.budget_ms.unwrap_or(5000).min(600_000),
        )),
        cancel: cancel.cloned(),
        ..grm_sample::SampleOptions::default()
    };
    let request = grm_grow::sample::SampleRequest {
        // The one frame shown, not one per generation.
        generation: p.generation,
        tree: true,
        edits,
        ..grm_grow::sample::SampleRequest::new(&curves, opts)
    };
    let mut sampled = grm_grow::sample::sample(sys, compiled, &request).map_err(|e| match e {
        grm_sample::SampleError::Cancelled => Failure::Cancelled,
        e => Failure::Msg(e.to_string()),
    })?;
    // The shown model's tree (identity and ancestry for `grm/pick`).
    let tree = sampled.tree.take();
    let sampled_edits = sampled.edits.take();
    let run = &sampled.result;
    // The frame asked for (the last one past the end: the result).
    let (shown, best) = match sampled.shown() {
        grm_grow::sample::Shown::Frame(g, m) => (Some(g as usize), m),
        grm_grow::sample::Shown::FrameFailed(g, e) => {
            return Err(Failure::Msg(format!(
                "the model of generation {g} cannot be finished: {e} (a search stopped after it ends so; the full search finished)"
            )));
        }
        grm_grow::sample::Shown::NoFrame(k) => {
            return Err(format!("the sampler kept no model of generation {k}").into());
        }
        grm_grow::sample::Shown::Models(m) => {
            (None, m.first().ok_or("the sampler returned no model")?)
        }
    };
    let derive_ms = t0.elapsed().as_secs_f64() * 1e3;
    let t1 = Instant::now();
    let model = best
        .build(
            prog,
            &grm_geom::BuildOptions::limited(PREVIEW_MAX_BYTES, grm_geom::Output::Model),
        )
        .map_err(|e| too_large(&e))?;
    let build_ms = t1.elapsed().as_secs_f64() * 1e3;
    let bones: Vec<(glam::Vec3, glam::Vec3)> = (best.interpretation.bones.iter())
        .map(|b| (b.base, b.tip))
        .collect();
    let coverage = crate::coverage::coverage(&curves, &bones);
    let focus_flags: Vec<bool> = best.origins.iter().map(|&o| Some(o) == focus).collect();
    let focus_out = focus.map(|fo| FocusOut {
        origin: fo,
        bones: model
            .skeleton
            .bones
            .iter()
            .filter(|b| b.origin == fo)
            .count(),
        instances: model
            .skeleton
            .instances
            .iter()
            .filter(|i| i.origin == fo)
            .count(),
        spread_bones: Vec::new(),
    });
    Ok(Made {
        modules: best.string.len(),
        focus_flags,
        tree,
        model,
        derive_ms,
        build_ms,
        focus_out,
        sample: Some(SampleOut {
            objective: best.objective,
            generations: run.generations.len(),
            candidates: run.candidates.len(),
            stopped_early: run.stopped_early,
            refinements: run.refinements,
            curves: from,
            generation: shown,
            coverage,
        }),
        edits: None,
        sampled_edits,
    })
}

/// A model error as the preview says it: over the memory limit, with its
/// code and what to lower.
pub(crate) fn too_large(e: &grm_geom::GeomError) -> Failure {
    match e {
        grm_geom::GeomError::MemoryLimit { .. } => Failure::Msg(format!(
            "{} (R0202): lower `maxModules` or the iterations to preview it",
            e
        )),
        e => Failure::Msg(e.to_string()),
    }
}

/// Build the preview of a checked file. Errors are messages for the user.
pub(crate) fn build(
    fa: &FileAnalysis,
    uri: &Uri,
    uris: &crate::uris::Uris,
    edits: &crate::edits::Source,
    p: &PreviewParams,
    cancel: Option<&CancelToken>,
) -> std::result::Result<(PreviewResult, PickTable), Failure> {
    build_with_model(fa, uri, uris, edits, p, cancel).map(|(r, t, model)| {
        drop_later(model);
        (r, t)
    })
}

/// Free a large value on a thread of its own, off the answer's path (a
/// building's model is tens of thousands of groups: freeing them took
/// as long as encoding its positions).
pub(crate) fn drop_later<T: Send + 'static>(x: T) {
    // A failed spawn (no threads left) drops it here.
    let _ = std::thread::Builder::new()
        .name("grm-drop".into())
        .spawn(move || drop(x));
}

/// The `grm/preview` answer for an analysed file, exactly as the request
/// and `grm/previewUpdated` build it (without the pick table the server
/// keeps): for benchmarks (`benches/shape_regrow.rs`) and tools. An error
/// is the message the client would get. Edits files are read from disk.
pub fn answer(
    fa: &FileAnalysis,
    uri: &Uri,
    params: &PreviewParams,
) -> std::result::Result<PreviewResult, String> {
    let edits = crate::edits::Source::default();
    build(fa, uri, &crate::uris::Uris::default(), &edits, params, None)
        .map(|(r, table)| {
            // The server keeps the table (and frees the one it replaces
            // off the answer's path, `store`).
            drop_later(table);
            r
        })
        .map_err(|f| f.to_string())
}

/// [`build`], and the model it was made from (`grm/picture` draws it).
pub(crate) fn build_with_model(
    fa: &FileAnalysis,
    uri: &Uri,
    uris: &crate::uris::Uris,
    edits: &crate::edits::Source,
    p: &PreviewParams,
    cancel: Option<&CancelToken>,
) -> std::result::Result<(PreviewResult, PickTable, grm_geom::Model), Failure> {
    check(cancel)?;
    if fa.checked.has_errors() {
        let n = fa
            .checked
            .diagnostics
            .iter()
            .filter(|d| d.is_error())
            .count();
        return Err(Failure::Msg(format!(
            "the program has {n} error{}: fix {} to preview",
            if n == 1 { "" } else { "s" },
            if n == 1 { "it" } else { "them" }
        )));
    }
    let prog = &fa.checked.program;
    let sys = match &p.system {
        Some(name) => prog
            .system(name)
            .ok_or_else(|| format!("no system `{name}`"))?,
        None => prog.default_system().ok_or("the file defines no system")?,
    };
    let mode = p.mode.unwrap_or(match sys.mode {
        Mode::Derive => PreviewMode::Derive,
        Mode::Sample => PreviewMode::Sample,
        Mode::Shape => PreviewMode::Shape,
    });
    match (mode, sys.mode) {
        (PreviewMode::Derive, Mode::Sample) => {
            return Err(Failure::Msg(format!(
                "system `{}` is a sample system: derive mode cannot grow it",
                sys.name
            )));
        }
        (PreviewMode::Sample, Mode::Derive) => {
            return Err(Failure::Msg(format!(
                "system `{}` is a derive system: only sample systems are sampled",
                sys.name
            )));
        }
        (PreviewMode::Derive | PreviewMode::Sample, Mode::Shape) => {
            return Err(Failure::Msg(format!(
                "system `{}` is a shape system: only shape mode grows it",
                sys.name
            )));
        }
        (PreviewMode::Shape, Mode::Derive | Mode::Sample) => {
            return Err(Failure::Msg(format!(
                "system `{}` is a {} system: shape mode grows only shape systems",
                sys.name,
                sys.mode.name()
            )));
        }
        _ => {}
    }
    let mut values = prog.default_params();
    for (name, v) in &p.params {
        let id = prog
            .param_by_name(name)
            .ok_or_else(|| format!("no meta-parameter `{name}`"))?;
        let decl = &prog.params[id.index()];
        if decl.ty != grm_sema::Ty::Float {
            return Err(Failure::Msg(format!(
                "meta-parameter `{name}` is not a float"
            )));
        }
        if !v.is_finite() {
            return Err(Failure::Msg(format!(
                "meta-parameter `{name}` must be finite"
            )));
        }
        // As `grmc --param` refuses it: a slider never leaves its range.
        if let Some((lo, hi)) = decl.range
            && !(lo..=hi).contains(v)
        {
            return Err(Failure::Msg(format!(
                "meta-parameter `{name}` = {v} is outside its range {lo} .. {hi}"
            )));
        }
        values[id.index()] = Value::Float(*v);
    }
    if mode == PreviewMode::Shape {
        return crate::shape_preview::build(fa, uri, uris, edits, p, sys, values, cancel);
    }
    let globals = prog.global_values(&values).map_err(|e| e.to_string())?;
    let mut settings = sys.settings_with(&values, &globals)?;
    if let Some(s) = p.seed {
        settings.seed = s;
    }
    if let Some(i) = p.iterations {
        // The checker's bound on the setting holds for the override too.
        if i > grm_sema::MAX_ITERATIONS {
            return Err(Failure::Msg(format!(
                "{i} iterations is more than the {} a preview derives",
                grm_sema::MAX_ITERATIONS
            )));
        }
        settings.iterations = i;
    }
    let compiled = grm_compile::compile(prog, sys, &values).map_err(|e| e.to_string())?;
    let sys_file = fa.sources.get(sys.file);
    // The file of the system, named as the client names it (it may be an
    // imported file: the previewed document's URI only when it is this one).
    let sys_path = grm_sema::normalize(std::path::Path::new(&sys_file.path));
    let sys_uri = if sys_path == fa.path {
        uri.clone()
    } else {
        uris.uri_of(&sys_path).unwrap_or_else(|| uri.clone())
    };
    let origin_table: Vec<OriginOut> = compiled
        .alt_spans
        .iter()
        .enumerate()
        .map(|(a, span)| OriginOut {
            uri: sys_uri.clone(),
            range: convert::range(sys_file, *span),
            symbol: if a as u32 == compiled.axiom_alt {
                "axiom".into()
            } else {
                compiled
                    .alts
                    .get(a)
                    .and_then(|alt| compiled.groups.get(alt.group as usize))
                    .and_then(|g| compiled.symbol_names.get(g.pred as usize))
                    .cloned()
                    .unwrap_or_default()
            },
        })
        .collect();
    // The production under the focus position, if any.
    let focus = p.focus.and_then(|pos| {
        if sys.file != fa.root {
            return None;
        }
        let off = convert::offset(sys_file, pos);
        compiled
            .alt_spans
            .iter()
            .position(|s| s.contains(off) || s.end == off)
            .map(|a| a as u32)
    });
    // Derive and sample mode: the edits file beside the system's grammar
    // (its buffer, else the disk), replayed by the CPU engine or the
    // sampler (docs/edits.md).
    let loaded = matches!(mode, PreviewMode::Derive | PreviewMode::Sample)
        .then(|| edits.load(&grm_edits::edits_path(&sys_path)));
    let plan = loaded
        .as_ref()
        .filter(|l| mode == PreviewMode::Derive && l.text.is_some())
        .map(|l| grm_grow::edits::edit_plan(sys, l.parsed.file.of_system(&sys.name)));
    let sample_edits = loaded
        .as_ref()
        .filter(|l| l.text.is_some())
        .map(|l| l.parsed.file.edits.as_slice());
    let made = match mode {
        PreviewMode::Sample => sample_model(
            fa,
            sys,
            &compiled,
            &settings,
            p,
            focus,
            sample_edits,
            cancel,
        )?,
        _ => derive_model(
            prog,
            sys,
            &compiled,
            &settings,
            p,
            focus,
            plan.as_ref(),
            cancel,
        )?,
    };
    check(cancel)?;
    let Made {
        model,
        modules,
        focus_flags,
        tree,
        derive_ms,
        build_ms,
        focus_out,
        sample,
        edits: outcome,
        sampled_edits,
    } = made;
    // What became of each edit (with the tree, the prints and retarget
    // candidates of key edits).
    let grown = tree.as_ref().map(|tree| crate::edits::KeyTree {
        tree,
        symbols: &compiled.symbol_names,
        drawn: &model.skeleton,
    });
    let (edits_out, edits_run) = match (&loaded, uris.uri_of(&grm_edits::edits_path(&sys_path))) {
        (Some(l), Some(edits_uri)) if mode == PreviewMode::Sample => {
            let reports = sampled_edits.unwrap_or_default();
            let (o, r) =
                crate::edits::classify_sampled(edits, l, edits_uri, prog, sys, reports, grown);
            (Some(o), Some(r))
        }
        (Some(l), Some(edits_uri)) => {
            let outcome = outcome.unwrap_or_default();
            let (o, r) = crate::edits::classify_derive(
                edits,
                l,
                edits_uri,
                prog,
                (sys, &compiled),
                &outcome,
                grown,
            );
            (Some(o), Some(r))
        }
        _ => (None, None),
    };
    let params_out = params_out(prog, &values);
    fits_answer(&model, origin_table.len())?;
    let t2 = Instant::now();
    let is_focus = |module: u32| focus_flags.get(module as usize) == Some(&true);
    let origin_of = |o: u32| (o != NO_ORIGIN && (o as usize) < origin_table.len()).then_some(o);
    let mut table = PickTable {
        version: fa.version,
        origins: origin_table.clone(),
        symbols: compiled.symbol_names.clone(),
        tree: tree.map(|t| {
            let mut place = vec![0u32; t.nodes.len()];
            for kids in t.children() {
                for (k, &c) in kids.iter().enumerate() {
                    place[c as usize] = k as u32;
                }
            }
            Arc::new((t, place))
        }),
        edits: edits_run.map(Arc::new),
        ..PickTable::default()
    };
    let enc = encoding(p);
    let parts = parts_out(&model, &origin_of, &is_focus, &mut table.parts, enc);
    let bones = &model.skeleton.bones;
    let mut bone_f = Vec::with_capacity(bones.len() * 8);
    let mut parents = Vec::with_capacity(bones.len());
    let mut bone_o = Vec::with_capacity(bones.len());
    for b in bones {
        bone_f.extend_from_slice(&b.base.to_array());
        bone_f.extend_from_slice(&b.tip.to_array());
        bone_f.push(b.width_base);
        bone_f.push(b.width_tip);
        parents.push(b.parent.map_or(-1, |p| i32::try_from(p).unwrap_or(-1)));
        bone_o.push(origin_of(b.origin).unwrap_or(NO_ORIGIN));
        table.bones.push((b.module, b.origin));
    }
    let skeleton = SkeletonOut {
        bone_count: bones.len(),
        bones: enc.f32s(&bone_f),
        parents: enc.i32s(&parents),
        origins: enc.u32s(&bone_o),
    };
    let materials = materials_out(&model);
    let warnings: Vec<WarningOut> = model
        .warnings(compiled.file, compiled.span, false)
        .into_iter()
        .map(|d| WarningOut {
            code: d.code.as_str().to_string(),
            message: d.message,
            notes: d.notes,
            help: d.help,
        })
        .collect();
    let result = PreviewResult {
        uri: uri.clone(),
        version: fa.version,
        system: sys.name.clone(),
        mode,
        seed: settings.seed,
        iterations: settings.iterations,
        encoding: "base64-le".into(),
        blob: None,
        materials,
        parts,
        skeleton,
        origins: origin_table,
        focus: focus_out,
        params: params_out,
        sample,
        stats: stats_out(&model, modules, derive_ms, build_ms, t2),
        warnings,
        shape: None,
        edits: edits_out,
    };
    Ok((result, table, model))
}

/// The meta-parameters with the values of a run (for the sliders).
pub(crate) fn params_out(prog: &grm_sema::Program, values: &[Value]) -> Vec<ParamOut> {
    prog.params
        .iter()
        .zip(values)
        .filter_map(|(m, v)| {
            Some(ParamOut {
                name: m.name.clone(),
                value: v.as_float()?,
                default: m.default.as_float()?,
                min: m.range.map(|r| r.0),
                max: m.range.map(|r| r.1),
            })
        })
        .collect()
}

/// Refuse a model before it is encoded when its answer would be too large:
/// the transport drops a larger message, and the client would wait for
/// its answer forever.
pub(crate) fn fits_answer(
    model: &grm_geom::Model,
    origins: usize,
) -> std::result::Result<(), Failure> {
    let answer = answer_bytes(model, origins);
    if answer > MAX_ANSWER_BYTES {
        let st = &model.stats;
        return Err(Failure::Msg(format!(
            "the model is too large to preview (R0408): its answer would be {} ({} triangles, {} vertices, {} bones), over the limit of {} on a grm/preview answer; lower `maxModules` or the iterations",
            grm_geom::budget::mib(answer),
            st.triangles,
            st.vertices,
            st.bones,
            grm_geom::budget::mib(MAX_ANSWER_BYTES)
        )));
    }
    Ok(())
}

/// A part with at least this many vertices has its vertices encoded on a
/// second thread (spawning one costs some tens of microseconds; encoding
/// 64Ki vertices, about a millisecond).
const PARALLEL_VERTICES: usize = 1 << 16;

/// The model's parts on the wire, and for `grm/pick` each part's runs
/// (first triangle, count, module, origin) pushed on `table`.
pub(crate) fn parts_out(
    model: &grm_geom::Model,
    origin_of: &dyn Fn(u32) -> Option<u32>,
    is_focus: &dyn Fn(u32) -> bool,
    table: &mut Vec<Vec<(u32, u32, u32, u32)>>,
    enc: Enc,
) -> Vec<PartOut> {
    model
        .parts
        .iter()
        .map(|part| {
            let mesh = &part.mesh;
            // Parallelogram quads (walls, windows, boxes) go as three
            // corners each, without indices or normals (`layout: "quads"`,
            // `MeshData::is_quads`); other meshes' flat normals are left
            // out (`MeshData::flat_normals`): the client computes both.
            // The index half of the test here, its geometry half with the
            // vertices on a second thread (a large part: a building's
            // walls), the picks and indices here.
            let quad_indices = mesh.quad_indices();
            let vertices = || {
                if quad_indices && mesh.quad_geometry() {
                    return (enc.quad_corners(&mesh.positions), Buf::default(), true);
                }
                let normals = if mesh.flat_normals() {
                    Buf::default()
                } else {
                    enc.f32s(mesh.normals.as_flattened())
                };
                (enc.f32s(mesh.positions.as_flattened()), normals, false)
            };
            let rest = || {
                let mut picks = Vec::with_capacity(part.picks.len() * 4 * PICK_WORDS);
                let mut runs = Vec::with_capacity(part.picks.len());
                for pk in &part.picks {
                    let (kind, index) = match pk.source {
                        grm_geom::PartSource::Bone(i) => (0, i),
                        grm_geom::PartSource::Instance(i) => (1, i),
                        grm_geom::PartSource::Polygon(i) => (2, i),
                        grm_geom::PartSource::Shape(i) => (3, i),
                    };
                    let flags = kind | if is_focus(pk.module) { PICK_FOCUS } else { 0 };
                    let origin = origin_of(pk.origin).unwrap_or(u32::MAX);
                    let words = [
                        pk.first_triangle,
                        pk.triangle_count,
                        flags,
                        index,
                        pk.module,
                        origin,
                    ];
                    // One append of the pick's 24 bytes.
                    let mut bytes = [0u8; 4 * PICK_WORDS];
                    for (d, w) in bytes.chunks_exact_mut(4).zip(words) {
                        d.copy_from_slice(&w.to_le_bytes());
                    }
                    picks.extend_from_slice(&bytes);
                    runs.push((pk.first_triangle, pk.triangle_count, pk.module, pk.origin));
                }
                let picks = enc.bytes(picks);
                // Indices in quad order are left out unless the geometry
                // half says otherwise (then written after the join).
                let indices = (!quad_indices).then(|| enc.u32s(&mesh.indices));
                (indices, picks, runs)
            };
            let ((positions, normals, quads), (indices, picks_b64, runs)) =
                if mesh.positions.len() >= PARALLEL_VERTICES {
                    std::thread::scope(|s| {
                        let h = s.spawn(vertices);
                        let r = rest();
                        (h.join().unwrap_or_else(|_| vertices()), r)
                    })
                } else {
                    (vertices(), rest())
                };
            let indices = match indices {
                Some(b) => b,
                None if quads => Buf::default(),
                None => enc.u32s(&mesh.indices),
            };
            table.push(runs);
            PartOut {
                material: part.material,
                vertex_count: mesh.positions.len(),
                triangle_count: mesh.indices.len() / 3,
                positions,
                normals,
                indices,
                pick_count: part.picks.len(),
                picks: picks_b64,
                layout: quads.then(|| "quads".to_owned()),
            }
        })
        .collect()
}

/// The model's materials on the wire.
pub(crate) fn materials_out(model: &grm_geom::Model) -> Vec<MaterialOut> {
    model
        .materials
        .iter()
        .map(|m| MaterialOut {
            name: m.name.clone(),
            color: m.color,
            roughness: m.roughness,
            metallic: m.metallic,
            emissive: m.emissive,
            opacity: m.opacity,
        })
        .collect()
}

/// The model's figures; `encode` is when encoding began.
pub(crate) fn stats_out(
    model: &grm_geom::Model,
    modules: usize,
    derive_ms: f64,
    build_ms: f64,
    encode: Instant,
) -> StatsOut {
    let st = &model.stats;
    let finite = |v: [f32; 3]| {
        if v.iter().all(|x| x.is_finite()) {
            v
        } else {
            [0.0; 3]
        }
    };
    StatsOut {
        modules,
        vertices: st.vertices,
        triangles: st.triangles,
        bones: st.bones,
        instances: st.instances,
        polygons: st.polygons,
        parts: st.parts,
        dropped: st.dropped,
        bounds_min: finite(st.bounds.min.to_array()),
        bounds_max: finite(st.bounds.max.to_array()),
        ambiguous_origins: 0,
        derive_ms,
        build_ms,
        encode_ms: encode.elapsed().as_secs_f64() * 1e3,
    }
}

/// What [`compute`] made of a request: the document version it analysed
/// (none: the document is not open) and the preview or why there is none.
type Computed = (
    Option<i32>,
    std::result::Result<(PreviewResult, PickTable), Failure>,
);

/// Compute a preview off the executor.
async fn compute(
    shared: &Arc<Shared>,
    path: PathBuf,
    uri: Uri,
    params: PreviewParams,
    cancel: CancelToken,
) -> Result<Computed> {
    let s = shared.clone();
    tokio::task::spawn_blocking(move || {
        let Some(fa) = s.analyze(&path) else {
            return (None, Err("the document is not open".into()));
        };
        let version = Some(fa.version);
        if let Some(v) = params.version
            && v != fa.version
        {
            return (version, Err(Failure::Stale(fa.version)));
        }
        if params.live {
            // This answer is the live preview of this analysis: a refresh
            // scheduled by the same edit (or the opening) need not build
            // and send it again.
            let key = (
                fa.version,
                (Arc::as_ptr(&fa) as usize, s.edits_generation()),
            );
            let mut sent = s.preview_sent.blocking_lock();
            if sent.get(&path).is_none_or(|&(v, _)| v <= fa.version) {
                sent.insert(path.clone(), key);
            }
        }
        let edits = s.edits_source();
        (
            version,
            build(&fa, &uri, &s.uris(), &edits, &params, Some(&cancel)),
        )
    })
    .await
    .map_err(|e| Error {
        code: ErrorCode::InternalError,
        message: e.to_string().into(),
        data: None,
    })
}

/// A `grm/preview` in progress: its cancel token, registered as the
/// document's live request when it is live (superseding the one before).
/// Dropped with the request's future, before its answer when the client
/// cancelled it (`$/cancelRequest`): then it stops the work.
pub(crate) struct Ticket {
    shared: Arc<Shared>,
    path: PathBuf,
    id: u64,
    pub(crate) token: CancelToken,
}

/// Clients whose order of live requests is remembered (per document); past
/// it the memory starts afresh.
const MAX_ORDERED_CLIENTS: usize = 256;

impl Ticket {
    /// A `grm/preview`'s ticket. A live one registers as the document's live
    /// preview (its options are `grm/previewUpdated`'s) unless its client
    /// has begun a later one (`client`, `order`): then its ticket is
    /// cancelled at once and it supersedes nothing. Two requests of a client
    /// sent a moment apart may arrive in either order (`grmc view` answers
    /// each connection in a thread of its own); the older never wins.
    pub(crate) fn begin_preview(
        shared: &Arc<Shared>,
        path: &std::path::Path,
        params: &PreviewParams,
    ) -> Ticket {
        if !params.live {
            let ticket = Ticket::begin(shared, path, false);
            shared.previews().remove(path);
            return ticket;
        }
        // Held while registering: one client's requests register in its order.
        let mut orders = shared.live_orders();
        if let (Some(client), Some(order)) = (&params.client, params.order) {
            let key = (path.to_path_buf(), client.clone());
            if orders.get(&key).is_some_and(|&o| o > order) {
                let ticket = Ticket::begin(shared, path, false);
                ticket.token.cancel();
                return ticket;
            }
            if orders.len() >= MAX_ORDERED_CLIENTS && !orders.contains_key(&key) {
                orders.clear();
            }
            orders.insert(key, order);
        }
        // The ticket first: a refresh that sees the live registration below
        // also sees this request running (and leaves the answer to it).
        let ticket = Ticket::begin(shared, path, true);
        shared.previews().insert(path.to_path_buf(), params.clone());
        ticket
    }

    pub(crate) fn begin(shared: &Arc<Shared>, path: &std::path::Path, live: bool) -> Ticket {
        let token = CancelToken::new();
        let id = shared.preview_seq.fetch_add(1, Ordering::Relaxed);
        if live {
            let version = shared.version(path);
            let generation = shared.edits_generation();
            let old = shared
                .running()
                .insert(path.to_path_buf(), (id, token.clone(), version, generation));
            if let Some((_, old, _, _)) = old {
                old.cancel();
            }
        }
        Ticket {
            shared: shared.clone(),
            path: path.to_path_buf(),
            id,
            token,
        }
    }
}

impl Drop for Ticket {
    fn drop(&mut self) {
        // After the answer the flag is read by no one; before it, the
        // request was dropped, and its blocking work stops at its next check.
        self.token.cancel();
        let mut running = self.shared.running();
        if running
            .get(&self.path)
            .is_some_and(|(id, _, _, _)| *id == self.id)
        {
            running.remove(&self.path);
        }
    }
}

/// Protocol 3: sends the answer's buffers as a blob, where the server has
/// somewhere to send it, just before the message that names it; else (or
/// for base64 text) the answer stays as it is.
pub(crate) fn ship(shared: &Shared, r: &mut PreviewResult) {
    let Some(sink) = &shared.blobs else {
        return;
    };
    let id = shared.blob_seq.fetch_add(1, Ordering::Relaxed);
    if let Some(blob) = r.take_blob(id) {
        sink.send(blob);
    }
}

/// A `grm/preview` that failed on the text of `version` (the program has
/// errors, a limit was hit): RequestFailed, with `data.version` the
/// document version whose text failed, so that a client can tell the
/// failure of an older text (a request sent while the user typed) from the
/// current text's and never shows it over a newer model.
fn failed_at(msg: String, version: Option<i32>) -> Error {
    let mut e = failed(msg);
    if let Some(v) = version {
        e.data = Some(serde_json::json!({ "version": v }));
    }
    e
}

/// The answer of a superseded `grm/preview`.
fn superseded() -> Error {
    Error {
        code: ErrorCode::ServerError(SERVER_CANCELLED),
        message: "superseded by a newer grm/preview request for this document".into(),
        data: None,
    }
}

impl Backend {
    /// `grm/preview`.
    pub async fn preview(&self, params: PreviewParams) -> Result<PreviewResult> {
        let uri = params.text_document.uri.clone();
        let path = convert::path_of(&uri).ok_or_else(|| failed("not a file URI"))?;
        let ticket = Ticket::begin_preview(&self.shared, &path, &params);
        if ticket.token.is_cancelled() {
            // Its client has begun a later live request for the document.
            return Err(superseded());
        }
        let (version, outcome) = compute(
            &self.shared,
            path.clone(),
            uri,
            params,
            ticket.token.clone(),
        )
        .await?;
        match outcome {
            // Superseded while being built: a newer request answers.
            _ if ticket.token.is_cancelled() => Err(superseded()),
            Ok((mut r, table)) => {
                crate::edits::after_preview(&self.shared, &self.client, &path, &table).await;
                store(&self.shared, path, table);
                // The blob goes out before the answer that names it.
                ship(&self.shared, &mut r);
                Ok(r)
            }
            Err(Failure::Cancelled) => Err(superseded()),
            Err(stale @ Failure::Stale(_)) => Err(Error {
                code: ErrorCode::ContentModified,
                message: stale.to_string().into(),
                data: None,
            }),
            Err(Failure::Msg(msg)) => Err(failed_at(msg, version)),
        }
    }

    /// `grm/pick`.
    pub async fn pick(&self, params: PickParams) -> Result<Option<PickResult>> {
        let path =
            convert::path_of(&params.text_document.uri).ok_or_else(|| failed("not a file URI"))?;
        let tables = self
            .shared
            .picks
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let Some(t) = tables.get(&path) else {
            return Err(failed("no preview of this document yet"));
        };
        if let Some(shape) = &t.shape {
            return Ok(shape.pick(t, &params));
        }
        let found = match (params.part, params.triangle, params.bone) {
            (Some(part), Some(tri), _) => t.parts.get(part).and_then(|ps| {
                let i = ps.partition_point(|p| p.0 <= tri);
                let p = ps.get(i.checked_sub(1)?)?;
                (tri < p.0 + p.1).then_some((p.2, p.3))
            }),
            (_, _, Some(b)) => t.bones.get(b as usize).copied(),
            _ => return Err(failed("give `part` and `triangle`, or `bone`")),
        };
        Ok(found.and_then(|(module, origin)| {
            let o = t.origins.get(origin as usize)?;
            let (key, ancestry) = match &t.tree {
                Some(tp) => identity(&tp.0, &tp.1, &t.symbols, module),
                None => (None, Vec::new()),
            };
            Some(PickResult {
                uri: o.uri.clone(),
                range: o.range,
                symbol: o.symbol.clone(),
                version: t.version,
                module,
                key,
                ancestry,
                shape: None,
            })
        }))
    }
}

/// The identity key and ancestry of module `module` of the final string.
fn identity(
    tree: &grm_grow::Tree,
    place: &[u32],
    symbols: &[String],
    module: u32,
) -> (Option<String>, Vec<AncestryOut>) {
    let Some(node) = tree.node_of_module(module) else {
        return (None, Vec::new());
    };
    let key = tree
        .nodes
        .get(node as usize)
        .map(|n| grm_grow::json::key_text(n.key));
    let ancestry = tree
        .ancestry(node)
        .into_iter()
        .filter_map(|i| {
            let n = tree.nodes.get(i as usize)?;
            Some(AncestryOut {
                key: grm_grow::json::key_text(n.key),
                symbol: n.symbol.and_then(|s| symbols.get(s as usize)).cloned(),
                child: n
                    .parent
                    .map(|_| place.get(i as usize).copied().unwrap_or(0)),
                production: n.production,
            })
        })
        .collect();
    (key, ancestry)
}

fn store(shared: &Shared, path: PathBuf, table: PickTable) {
    let old = shared
        .picks
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
        .insert(path, table);
    // The table replaced (a building's tree) is freed off the lock and
    // the answer's path.
    if let Some(old) = old {
        drop_later(old);
    }
}

/// After an edit: recompute a live preview of `path` at `version` and send
/// it, unless a newer version exists or was sent.
pub(crate) async fn refresh(shared: &Arc<Shared>, client: &Client, path: PathBuf, version: i32) {
    let Some(params) = shared.previews().get(&path).cloned() else {
        return;
    };
    if shared.version(&path) != Some(version) {
        return;
    }
    // A live request that began at this version or later, and after the
    // last change of an edits file, answers with this analysis (or a newer
    // one) and those edits: not built twice.
    let generation = shared.edits_generation();
    if shared
        .running()
        .get(&path)
        .is_some_and(|&(_, _, v, g)| v >= Some(version) && g >= generation)
    {
        return;
    }
    let uri = params.text_document.uri.clone();
    let options = serde_json::to_value(&params).ok();
    let s = shared.clone();
    let (p, u) = (path.clone(), uri.clone());
    let built = tokio::task::spawn_blocking(move || {
        let fa = s.analyze(&p)?;
        if fa.version != version {
            return None; // a newer text has its own refresh
        }
        // Built from this very analysis and edits already (a second task
        // for the same edit): nothing to send. A changed import makes a new
        // analysis, a changed edits file a new generation.
        let key = (Arc::as_ptr(&fa) as usize, s.edits_generation());
        if s.preview_sent.blocking_lock().get(&p) == Some(&(version, key)) {
            return None;
        }
        let edits = s.edits_source();
        Some((key, build(&fa, &u, &s.uris(), &edits, &params, None)))
    })
    .await;
    let Ok(Some((key, outcome))) = built else {
        return;
    };
    let (result, error) = match outcome {
        Ok((r, table)) => {
            crate::edits::after_preview(shared, client, &path, &table).await;
            store(shared, path.clone(), table);
            (Some(r), None)
        }
        Err(failure) => (None, Some(failure.to_string())),
    };
    // A live request begun since with other options answers for this
    // version (or a newer one) itself: a model of the older options, sent
    // after its answer, would replace the client's current one.
    let live_now = shared
        .previews()
        .get(&path)
        .and_then(|p| serde_json::to_value(p).ok());
    if live_now.is_none() || live_now != options {
        return;
    }
    let mut sent = shared.preview_sent.lock().await;
    // Nor after one of a newer version, or of this version with the
    // edits files of a later generation.
    if shared.version(&path) != Some(version)
        || sent.get(&path).is_some_and(|&(v, k)| {
            v > version || (v, k) == (version, key) || (v == version && k.1 > key.1)
        })
    {
        return;
    }
    sent.insert(path, (version, key));
    let mut result = result;
    if let Some(r) = &mut result {
        ship(shared, r);
    }
    client
        .send_notification::<PreviewUpdated>(PreviewUpdatedParams {
            uri,
            version,
            result,
            error,
        })
        .await;
}

#[cfg(test)]
mod tests {
    use super::*;

    fn compiled(text: &str) -> (grm_sema::Program, CompiledSystem) {
        let (_, checked) = grm_sema::check_with("t.grm", text, &grm_sema::MemLoader::new());
        assert!(!checked.has_errors(), "{:?}", checked.diagnostics);
        let prog = checked.program;
        let sys = prog.systems[0].clone();
        let c = grm_compile::compile(&prog, &sys, &prog.default_params()).expect("compiles");
        (prog, c)
    }

    /// The production (by its predecessor and first successor symbol) that
    /// made each module.
    fn makers(c: &CompiledSystem, g: &Grown) -> Vec<String> {
        let o = g.origin.as_ref().expect("origins");
        g.string
            .symbols()
            .zip(o)
            .map(|(s, &a)| {
                let alt = &c.alts[a as usize];
                let first = c.successor(alt).first().map_or("ε".to_string(), |m| {
                    c.symbol_names[m.symbol as usize].clone()
                });
                let pred = if a == c.axiom_alt {
                    "axiom".to_string()
                } else {
                    c.symbol_names[c.groups[alt.group as usize].pred as usize].clone()
                };
                format!("{}<{pred}:{first}", c.symbol_names[s as usize])
            })
            .collect()
    }

    #[test]
    fn origins_follow_each_step() {
        // A -> F B; B -> G | f (stochastic); F is never rewritten and keeps
        // its maker; X is copied from the axiom.
        let (_, c) =
            compiled("system S { iterations = 2; axiom X A; A -> F B; B -> (1) G; B -> (1) f; }");
        let g = grow(&c, 2, 3, 1000, None, true, None).unwrap();
        let m = makers(&c, &g);
        assert_eq!(m.len(), 3);
        assert_eq!(m[0], "X<axiom:X");
        assert_eq!(m[1], "F<A:F");
        assert!(m[2] == "G<B:G" || m[2] == "f<B:f", "{m:?}");
    }

    #[test]
    fn origins_are_the_decisions_even_when_alternatives_tie() {
        // `C -> (1) G; C -> (1) G;` write the same symbols: the origin is
        // the alternative the engine chose (the tree's record of it), not
        // a guess; both are chosen over the seeds.
        let (_, c) = compiled(
            "system S { iterations = 3; axiom A C; A -> (1) F; A -> (1) F A; C -> (1) G; C -> (1) G; }",
        );
        let mut seen = std::collections::BTreeSet::new();
        for seed in 0..20 {
            let g = grow(&c, 3, seed, 1000, None, true, None).unwrap();
            let tree = g.tree.as_ref().expect("tree");
            let o = g.origin.as_ref().expect("origins");
            for (m, &a) in o.iter().enumerate() {
                let n = tree.node_of_module(m as u32).expect("node");
                let parent = tree.nodes[n as usize].parent.expect("parent");
                assert_eq!(
                    tree.nodes[parent as usize].production,
                    Some(a),
                    "seed {seed}"
                );
                if c.symbol_names[g.string.sym(m) as usize] == "G" {
                    seen.insert(a);
                }
            }
        }
        assert_eq!(seen.len(), 2, "both tied alternatives are told apart");
    }

    #[test]
    fn focus_marks_descendants() {
        // Focus on `B -> C D`: C and D, and what they become, are marked.
        let text = "system S { iterations = 3; axiom A; A -> F B; B -> C D; C -> G; D -> G G; }";
        let (_, c) = compiled(text);
        let b_alt = (0..c.alts.len() as u32)
            .find(|&a| {
                let g = &c.groups[c.alts[a as usize].group as usize];
                a != c.axiom_alt && c.symbol_names[g.pred as usize] == "B"
            })
            .unwrap();
        let g = grow(&c, 3, 0, 1000, Some(b_alt), false, None).unwrap();
        let names: Vec<&str> = g
            .string
            .symbols()
            .map(|s| c.symbol_names[s as usize].as_str())
            .collect();
        assert_eq!(names, ["F", "G", "G", "G"]);
        assert_eq!(g.focus, [false, true, true, true]);
    }

    #[test]
    fn a_live_ticket_supersedes_the_one_before_and_dropping_one_cancels_it() {
        let shared = Arc::new(Shared::new(crate::Config::default()));
        let path = std::path::Path::new("/t/tree.grm");
        let other = std::path::Path::new("/t/other.grm");
        let a = Ticket::begin(&shared, path, true);
        let elsewhere = Ticket::begin(&shared, other, true);
        assert!(!a.token.is_cancelled());
        // A request that is not live neither supersedes nor is superseded.
        let once = Ticket::begin(&shared, path, false);
        assert!(!a.token.is_cancelled());
        let b = Ticket::begin(&shared, path, true);
        assert!(a.token.is_cancelled(), "superseded");
        assert!(!b.token.is_cancelled());
        assert!(!once.token.is_cancelled());
        assert!(!elsewhere.token.is_cancelled(), "another document");
        // The superseded ticket ending does not unregister the newer one.
        drop(a);
        assert_eq!(shared.running().get(path).map(|r| r.0), Some(b.id));
        // A ticket dropped before its answer (`$/cancelRequest`) stops its work.
        let (tb, tonce) = (b.token.clone(), once.token.clone());
        drop(b);
        drop(once);
        assert!(tb.is_cancelled() && tonce.is_cancelled());
        assert!(shared.running().get(path).is_none());
        assert!(shared.running().get(other).is_some());
    }

    #[test]
    fn a_clients_older_live_request_arriving_late_supersedes_nothing() {
        let shared = Arc::new(Shared::new(crate::Config::default()));
        let path = std::path::Path::new("/t/tree.grm");
        let params = |client: &str, order: u64, seed: u32| -> PreviewParams {
            serde_json::from_value(serde_json::json!({
                "textDocument": { "uri": "file:///t/tree.grm" }, "live": true,
                "client": client, "order": order, "seed": seed,
            }))
            .expect("params")
        };
        // The page sent 1 then 2; 2 arrives first.
        let newer = Ticket::begin_preview(&shared, path, &params("page", 2, 2));
        let older = Ticket::begin_preview(&shared, path, &params("page", 1, 1));
        assert!(
            older.token.is_cancelled(),
            "the older one is answered superseded"
        );
        assert!(!newer.token.is_cancelled(), "and supersedes nothing");
        // previewUpdated keeps the newer one's options.
        assert_eq!(shared.previews().get(path).and_then(|p| p.seed), Some(2));
        drop(older);
        assert_eq!(shared.running().get(path).map(|r| r.0), Some(newer.id));
        // Even after the newer one was answered.
        drop(newer);
        let late = Ticket::begin_preview(&shared, path, &params("page", 1, 1));
        assert!(late.token.is_cancelled());
        assert_eq!(shared.previews().get(path).and_then(|p| p.seed), Some(2));
        // Another client's requests, and requests without an order, are taken as they come.
        let other = Ticket::begin_preview(&shared, path, &params("other", 1, 3));
        assert!(!other.token.is_cancelled());
        let next = Ticket::begin_preview(&shared, path, &params("page", 3, 4));
        assert!(
            other.token.is_cancelled(),
            "a later request supersedes another client's"
        );
        assert!(!next.token.is_cancelled());
        let plain: PreviewParams = serde_json::from_value(serde_json::json!({
            "textDocument": { "uri": "file:///t/tree.grm" }, "live": true,
        }))
        .expect("params");
        let unordered = Ticket::begin_preview(&shared, path, &plain);
        assert!(next.token.is_cancelled() && !unordered.token.is_cancelled());
    }

    #[test]
    fn quads_go_as_three_corners_each() {
        use base64::Engine as _;
        let mut m = grm_geom::MeshData::default();
        let o = glam::Vec3::new(3.0, -1.0, 2.5);
        let (u, v) = (
            glam::Vec3::new(2.0, 0.0, 0.5),
            glam::Vec3::new(0.0, 1.5, 0.0),
        );
        m.quad([o, o + u, o + u + v, o + v], u.cross(v).normalize());
        m.quad(
            [o + v, o + u + v, o + u + 2.0 * v, o + 2.0 * v],
            u.cross(v).normalize(),
        );
        assert!(m.is_quads());
        let bytes = base64::engine::general_purpose::STANDARD
            .decode(quad_corners(&m))
            .unwrap();
        let floats: Vec<f32> = bytes
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect();
        assert_eq!(floats.len(), 18);
        for (q, c) in floats.chunks_exact(9).enumerate() {
            let corner = |k: usize| glam::Vec3::new(c[3 * k], c[3 * k + 1], c[3 * k + 2]);
            // The fourth corner, rebuilt as the client does.
            let d = corner(0) + corner(2) - corner(1);
            assert!((d - glam::Vec3::from_array(m.positions[4 * q + 3])).length() < 1e-5);
            for k in 0..3 {
                assert_eq!(corner(k).to_array(), m.positions[4 * q + k]);
            }
        }
    }

    #[test]
    fn base64_is_little_endian() {
        assert_eq!(f32s(&[1.0]), "AACAPw==");
        assert_eq!(u32s(&[1, 2]), "AQAAAAIAAAA=");
        assert_eq!(i32s(&[-1]), "/////w==");
        // Across blocks: the same text as the bytes encoded at once.
        let xs: Vec<u32> = (0..2_000u32)
            .map(|i| i.wrapping_mul(2_654_435_761))
            .collect();
        for n in [0, 1, 2, 3, 767, 768, 769, 1536, 2000] {
            let bytes: Vec<u8> = xs[..n].iter().flat_map(|x| x.to_le_bytes()).collect();
            assert_eq!(
                u32s(&xs[..n]),
                base64::engine::general_purpose::STANDARD.encode(bytes)
            );
        }
    }
}

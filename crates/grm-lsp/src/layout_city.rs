//! `grm/layoutCity` (docs/lsp-extensions.md, "City layouts"): the layout
//! view's 3D mode, the merged city with a building grown on every parcel
//! (grm-layout's `city`), answered as the model's mesh buffers, the same
//! parts and materials `grm/preview` answers (the page draws them with its
//! three.js renderer, orbiting): base64 text, or with `"binary": true` on a
//! server that sends blobs, ranges of one blob (protocol 3, blob.rs).
//!
//! The buildings are grown by the sidecar's `buildings` grammar, or for a
//! grammar's `layout` item (layout_grm.rs) by the item's `buildings`
//! system. The building edits of the edits file beside the layout
//! (`NAME.edits.json` for `NAME.layout.json` or `NAME.grm`; edits with a
//! `parcel`) are replayed in their parcels' buildings
//! (`city::city_edited`, as `grmc layout` does); one whose parcel is gone
//! (R1032) is applied nowhere, listed in the answer and published as an
//! error on the edits file.
//!
//! A [`BuildingCache`] is kept per layout, so after a drag only the
//! parcels the move changed grow again (the same model, byte for byte, as
//! a whole growth); the answer says how many buildings were taken from it.

use crate::blob::Enc;
use crate::layout::{Evaluated, LayoutProblem};
use crate::layout_grm::{Target, evaluate, target};
use crate::preview::{MaterialOut, PartOut, fits_answer, materials_out, parts_out};
use crate::{Backend, Shared, failed};
use grm_layout::city::{self, BuildingCache, Buildings};
use grm_layout::model::TagValue;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Instant;
use tower_lsp_server::jsonrpc::Result;
use tower_lsp_server::ls_types::Uri;

/// `grm/layoutCity` parameters.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct LayoutCityParams {
    /// A sidecar `NAME.layout.json` or a grammar with a `layout` item.
    pub uri: Uri,
    /// Protocol 3: the buffers as ranges of a blob (where the server has
    /// somewhere to send it), not base64 text.
    #[serde(default)]
    pub binary: bool,
}

/// `grm/layoutCity` result.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct LayoutCityResult {
    pub uri: Uri,
    /// `base64-le` or `blob-le` (as `grm/preview`'s).
    pub encoding: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub blob: Option<crate::blob::BlobRef>,
    /// The city's model: ground, streets, parcels and buildings, y up (a
    /// layout point `(x, y)` is `(x, 0, -y)`), as `grm/preview`'s parts.
    pub materials: Vec<MaterialOut>,
    pub parts: Vec<PartOut>,
    pub bounds_min: [f32; 3],
    pub bounds_max: [f32; 3],
    /// Buildings in the city, and how many of them the cache gave (the
    /// rest grew for this answer).
    pub buildings: usize,
    pub reused: usize,
    /// Buildings grown with building edits replayed.
    pub edited: usize,
    pub parcels: usize,
    pub triangles: u64,
    pub vertices: u64,
    /// Parcels without a building (R1031 a tag that does not fit, or the
    /// shape engine's code), building edits applied nowhere (R1032), and
    /// the layout's own problems.
    pub problems: Vec<LayoutProblem>,
    /// The edits file whose building edits were replayed (none without one).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub edits: Option<Uri>,
    /// Milliseconds to grow the city (not encoding it).
    pub grow_ms: f64,
}

impl LayoutCityResult {
    /// Protocol 3: moves the parts' bytes into blob `id` (as
    /// `PreviewResult::take_blob`).
    pub fn take_blob(&mut self, id: u64) -> Option<crate::blob::Blob> {
        let bufs = self.parts.iter_mut().flat_map(PartOut::bufs);
        let (bytes, chunks) = crate::blob::gather(bufs)?;
        self.encoding = "blob-le".into();
        self.blob = Some(crate::blob::BlobRef { id, bytes });
        Some(crate::blob::Blob { id, chunks })
    }
}

impl Shared {
    fn city_cache(&self, path: &Path) -> Arc<Mutex<BuildingCache>> {
        self.layouts_lock()
            .cities
            .entry(path.to_path_buf())
            .or_default()
            .clone()
    }
}

/// The edits file beside a layout: `NAME.edits.json` for
/// `NAME.layout.json` or `NAME.grm`.
pub(crate) fn edits_beside(t: &Target) -> PathBuf {
    let file = t.path();
    let name = file.file_name().and_then(|n| n.to_str()).unwrap_or("");
    match name.strip_suffix(crate::layout::SUFFIX) {
        Some(stem) => file.with_file_name(format!("{stem}.edits.json")),
        None => grm_edits::edits_path(file),
    }
}

/// The building edits of `path` (the client's buffer, else the file; none
/// without either). Its own problems are the edits file's diagnostics
/// (edits.rs); an edit with one is skipped.
fn read_edits(
    shared: &Shared,
    path: &Path,
) -> std::result::Result<Option<grm_edits::EditsFile>, String> {
    let open = shared.edits_source().open;
    match crate::edits::read(&open, path) {
        Ok(Some((_, text))) => Ok(Some(grm_edits::parse(&text).file)),
        Ok(None) => Ok(None),
        Err(e) => Err(format!("error[{}]: {e}", e.code().as_str())),
    }
}

/// Grows the city: the buildings of the sidecar's `buildings` section or
/// of the grammar's item, with the building edits replayed.
fn grow(
    shared: &Shared,
    target: &Target,
    ev: &Evaluated,
    edits: &grm_edits::EditsFile,
    cache: &mut BuildingCache,
) -> std::result::Result<city::City, String> {
    let build = grm_geom::BuildOptions {
        group_names: false,
        ..grm_geom::BuildOptions::default()
    };
    let Some(spec) = ev.doc.buildings.as_ref() else {
        return city::city_edited(&ev.merged, None, &build, edits, Some(cache), &mut |_, _| {})
            .map_err(|e| e.to_string());
    };
    let grammar: PathBuf = match &ev.grm {
        // The item's system is in the grammar itself.
        Some(g) => g.grm.clone(),
        None => {
            let dir = target
                .path()
                .parent()
                .map(Path::to_path_buf)
                .unwrap_or_default();
            grm_sema::normalize(&dir.join(&spec.grammar))
        }
    };
    let fa = shared
        .analyze(&grammar)
        .ok_or_else(|| format!("cannot read {}", grammar.display()))?;
    if let Some(d) = fa.checked.diagnostics.iter().find(|d| d.is_error()) {
        return Err(format!(
            "{}: error[{}]: {}",
            grammar.display(),
            d.code.as_str(),
            d.message
        ));
    }
    let prog = &fa.checked.program;
    let index = prog
        .pick_system(spec.system.as_deref())
        .map_err(|d| format!("{}: {}", grammar.display(), d.message))?;
    let system = &prog.systems[index];
    if system.mode != grm_sema::Mode::Shape {
        return Err(format!(
            "{}: system `{}` is not a shape system (it has no `mode = shape;`): parcels grow shape systems",
            grammar.display(),
            system.name
        ));
    }
    let params: Vec<String> = spec
        .params
        .iter()
        .map(|(k, v)| match v {
            TagValue::Num(x) => format!("{k}={x}"),
            TagValue::Bool(b) => format!("{k}={b}"),
            TagValue::Text(t) => format!("{k}={t}"),
        })
        .collect();
    let values = grm_compile::param_values(prog, &params)?;
    let b = Buildings {
        program: prog,
        system,
        params: &values,
        dir: grammar.parent(),
        seed: spec.seed,
        options: grm_grow::shape::ShapeOptions::default(),
    };
    city::city_edited(
        &ev.merged,
        Some(&b),
        &build,
        edits,
        Some(cache),
        &mut |_, _| {},
    )
    .map_err(|e| e.to_string())
}

/// What the answer's thread computed, with what goes to the edits file.
struct Grown {
    result: LayoutCityResult,
    edits_path: PathBuf,
    edit_issues: Vec<(u32, String, String)>,
}

/// The city of `target` as mesh buffers (`enc`).
fn city_answer(shared: &Shared, uri: Uri, target: &Target, enc: Enc) -> Result<Grown> {
    let merge = shared.layout_cache(target.path());
    let cache = shared.city_cache(target.path());
    let (_, ev) = {
        let mut m = merge.lock().unwrap_or_else(PoisonError::into_inner);
        evaluate(shared, target, &mut m)?
    };
    let edits_path = edits_beside(target);
    let edits = read_edits(shared, &edits_path).map_err(failed)?;
    let start = Instant::now();
    let grown = {
        let mut c = cache.lock().unwrap_or_else(PoisonError::into_inner);
        grow(
            shared,
            target,
            &ev,
            edits.as_ref().unwrap_or(&Default::default()),
            &mut c,
        )
        .map_err(failed)?
    };
    let grow_ms = start.elapsed().as_secs_f64() * 1e3;
    let model = &grown.model;
    fits_answer(model, 0).map_err(|e| failed(e.to_string()))?;
    let parts = parts_out(model, &|_| None, &|_| false, &mut Vec::new(), enc);
    let mut problems = crate::layout::problems_of(&ev);
    problems.extend(grown.issues.iter().map(|i| LayoutProblem {
        code: i.code(),
        message: i.describe(),
    }));
    problems.extend(grown.edit_issues.iter().map(|i| LayoutProblem {
        code: i.code(),
        message: i.describe(),
    }));
    let edit_issues = grown
        .edit_issues
        .iter()
        .map(|i| (i.edit, i.code(), i.describe()))
        .collect();
    let st = &model.stats;
    let finite = |v: [f32; 3]| v.map(|x| if x.is_finite() { x } else { 0.0 });
    Ok(Grown {
        result: LayoutCityResult {
            uri,
            encoding: "base64-le".into(),
            blob: None,
            materials: materials_out(model),
            parts,
            bounds_min: finite(st.bounds.min.to_array()),
            bounds_max: finite(st.bounds.max.to_array()),
            buildings: grown.buildings,
            reused: grown.reused,
            edited: grown.edited,
            parcels: ev.merged.parcels.len(),
            triangles: st.triangles as u64,
            vertices: st.vertices as u64,
            problems,
            edits: edits
                .is_some()
                .then(|| crate::uris::uri_of(&edits_path))
                .flatten(),
            grow_ms,
        },
        edits_path,
        edit_issues,
    })
}

impl Backend {
    /// `grm/layoutCity`: the city with its buildings, as mesh buffers.
    pub async fn layout_city(&self, params: LayoutCityParams) -> Result<LayoutCityResult> {
        let target = target(&params.uri)?;
        let shared = self.shared.clone();
        let uri = params.uri.clone();
        let enc = if params.binary && self.shared.blobs.is_some() {
            Enc::Binary
        } else {
            Enc::Base64
        };
        let Grown {
            mut result,
            edits_path,
            edit_issues,
        } = tokio::task::spawn_blocking(move || city_answer(&shared, uri, &target, enc))
            .await
            .map_err(|e| failed(e.to_string()))??;
        // R1032 on the edits file (its diagnostics, with its own problems).
        let had = {
            let mut st = self.shared.edits_state();
            let had = st.layout_issues.contains_key(&edits_path);
            if edit_issues.is_empty() {
                st.layout_issues.remove(&edits_path);
            } else {
                st.layout_issues
                    .insert(edits_path.clone(), edit_issues.clone());
            }
            had
        };
        if had || !edit_issues.is_empty() {
            crate::edits::publish(&self.shared, &self.client, &edits_path).await;
        }
        if enc == Enc::Binary
            && let Some(sink) = &self.shared.blobs
        {
            let id = self.shared.blob_seq.fetch_add(1, Ordering::Relaxed);
            if let Some(blob) = result.take_blob(id) {
                sink.send(blob);
            }
        }
        Ok(result)
    }
}

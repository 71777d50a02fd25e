//! `grm/layoutCity` (docs/lsp-extensions.md, "City layouts"): the layout
//! view's 3D mode, the merged city with a building grown on every parcel
//! by the sidecar's `buildings` grammar (grm-layout's `city`), drawn as a
//! PNG picture from above at an angle by `grm_geom::render` (the picture
//! `grmc layout -o city.png` writes).
//!
//! A [`BuildingCache`] is kept per sidecar, so after a drag only the
//! parcels the move changed grow again (`city::city_cached`: the same
//! model, byte for byte, as a whole growth); the answer says how many
//! buildings were taken from it.

use crate::layout::{LayoutProblem, evaluate_text, layout_path};
use crate::{Backend, Shared, failed};
use base64::Engine as _;
use grm_layout::city::{self, BuildingCache, Buildings};
use grm_layout::model::TagValue;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Instant;
use tower_lsp_server::jsonrpc::Result;
use tower_lsp_server::ls_types::Uri;

/// `grm/layoutCity` parameters.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct LayoutCityParams {
    pub uri: Uri,
    /// Pixels (default 800 x 600; each side 16 to 4096).
    #[serde(default)]
    pub width: Option<u32>,
    #[serde(default)]
    pub height: Option<u32>,
    /// The view's direction in degrees (as `grmc --view`): default 30, 45.
    #[serde(default)]
    pub azimuth: Option<f32>,
    #[serde(default)]
    pub elevation: Option<f32>,
}

/// `grm/layoutCity` result.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct LayoutCityResult {
    pub uri: Uri,
    /// The picture, PNG, base64.
    pub png: String,
    pub width: u32,
    pub height: u32,
    /// Buildings in the city, and how many of them the cache gave (the
    /// rest grew for this answer).
    pub buildings: usize,
    pub reused: usize,
    pub parcels: usize,
    pub triangles: u64,
    /// Parcels without a building (R1031 a tag that does not fit, or the
    /// shape engine's code), and the layout's own problems.
    pub problems: Vec<LayoutProblem>,
    /// Milliseconds to grow the city (not drawing it).
    pub grow_ms: f64,
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

/// The grammar's system and values for the sidecar's `buildings` section.
fn grow(
    shared: &Shared,
    sidecar: &Path,
    ev: &crate::layout::Evaluated,
    cache: &mut BuildingCache,
) -> std::result::Result<city::City, String> {
    let Some(spec) = ev.doc.buildings.as_ref() else {
        let build = grm_geom::BuildOptions {
            group_names: false,
            ..grm_geom::BuildOptions::default()
        };
        return city::city_cached(&ev.merged, None, &build, cache, &mut |_, _| {})
            .map_err(|e| e.to_string());
    };
    let dir = sidecar.parent().map(Path::to_path_buf).unwrap_or_default();
    let grammar: PathBuf = grm_sema::normalize(&dir.join(&spec.grammar));
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
    let build = grm_geom::BuildOptions {
        group_names: false,
        ..grm_geom::BuildOptions::default()
    };
    city::city_cached(&ev.merged, Some(&b), &build, cache, &mut |_, _| {})
        .map_err(|e| e.to_string())
}

impl Backend {
    /// `grm/layoutCity`: the city with its buildings, as a picture.
    pub async fn layout_city(&self, params: LayoutCityParams) -> Result<LayoutCityResult> {
        let path = layout_path(&params.uri)?;
        let (_, text) = self.shared.layout_text(&path)?;
        let merge = self.shared.layout_cache(&path);
        let cache = self.shared.city_cache(&path);
        let shared = self.shared.clone();
        let uri = params.uri.clone();
        tokio::task::spawn_blocking(move || -> Result<LayoutCityResult> {
            let ev = {
                let mut m = merge.lock().unwrap_or_else(PoisonError::into_inner);
                evaluate_text(&path, &text, &mut m)
            };
            let start = Instant::now();
            let grown = {
                let mut c = cache.lock().unwrap_or_else(PoisonError::into_inner);
                grow(&shared, &path, &ev, &mut c).map_err(failed)?
            };
            let grow_ms = start.elapsed().as_secs_f64() * 1e3;
            let width = params.width.unwrap_or(800).clamp(16, 4096);
            let height = params.height.unwrap_or(600).clamp(16, 4096);
            let options = grm_geom::render::RenderOptions {
                width,
                height,
                view: grm_geom::render::View::Angles {
                    azimuth: params.azimuth.unwrap_or(30.0),
                    elevation: params.elevation.unwrap_or(45.0),
                },
                samples: 2,
                ..grm_geom::render::RenderOptions::default()
            };
            let image = grm_geom::render::render(&grown.model, &options)
                .map_err(|e| failed(format!("the city could not be drawn: {e}")))?;
            let png = grm_geom::render::png_bytes(&image)
                .map_err(|e| failed(format!("the picture could not be encoded: {e}")))?;
            let mut problems = crate::layout::problems_of(&ev);
            problems.extend(grown.issues.iter().map(|i| LayoutProblem {
                code: i.code(),
                message: i.describe(),
            }));
            Ok(LayoutCityResult {
                uri,
                png: base64::engine::general_purpose::STANDARD.encode(png),
                width,
                height,
                buildings: grown.buildings,
                reused: grown.reused,
                parcels: ev.merged.parcels.len(),
                triangles: grown.model.stats.triangles as u64,
                problems,
                grow_ms,
            })
        })
        .await
        .map_err(|e| failed(e.to_string()))?
    }
}

//! `grm/picture` (docs/lsp-extensions.md): the model a `grm/preview` with
//! the same parameters would show, drawn as a PNG picture by
//! `grm_geom::render` (the picture `grmc derive -o x.png` writes), for
//! clients that save what the user sees: the preview page under `grmc
//! view`, or any editor.
//!
//! Input: a preview's parameters (document, version, system, seed,
//! meta-parameters, curves; `live` and `focus` are ignored) plus the
//! picture's size, view and background. Output: the PNG, base64, with its
//! size and what it shows. Computed on a blocking thread; a request the
//! client cancels stops at the preview's next check.

use base64::Engine as _;
use serde::{Deserialize, Serialize};
use tower_lsp_server::jsonrpc::{Error, ErrorCode, Result};
use tower_lsp_server::ls_types::Uri;

use crate::preview::{Failure, PreviewParams, Ticket, build_with_model};
use crate::{Backend, convert, failed};

/// Where the picture is taken from, in degrees (as `grmc --view`).
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
pub struct PictureView {
    /// About +y, from +z towards +x.
    pub azimuth: f32,
    /// Above the xz plane, -90 to 90.
    pub elevation: f32,
}

/// A perspective camera (the preview's orbit camera), as `grmc
/// --camera/--look-at/--fov`: +y up, not fitted to the model.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
pub struct PictureCamera {
    /// Where the camera is.
    pub position: [f64; 3],
    /// The point it looks at (a different point; default the centre of
    /// the model's bounds, as `--look-at`'s).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target: Option<[f64; 3]>,
    /// The vertical field of view in degrees, more than 0 and at most 179
    /// (default 45, the preview's).
    #[serde(default = "default_fov")]
    pub fov: f32,
}

fn default_fov() -> f32 {
    45.0
}

/// `grm/picture` parameters.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct PictureParams {
    /// What to grow, as for `grm/preview`.
    #[serde(flatten)]
    pub preview: PreviewParams,
    /// Default: the automatic view (face on for a flat model, else 35, 20).
    #[serde(default)]
    pub view: Option<PictureView>,
    /// A perspective camera instead of the fitted orthographic view (not
    /// with `view`).
    #[serde(default)]
    pub camera: Option<PictureCamera>,
    /// Pixels (default 1024 each; each side 1 to 16384, at most 4096 x
    /// 4096 in all).
    #[serde(default)]
    pub width: Option<u32>,
    #[serde(default)]
    pub height: Option<u32>,
    /// A transparent background (an RGBA PNG) instead of the grey gradient.
    #[serde(default)]
    pub transparent: bool,
}

/// `grm/picture` result.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct PictureResult {
    pub uri: Uri,
    /// The document version the picture was made from.
    pub version: i32,
    pub system: String,
    pub seed: u32,
    pub width: u32,
    pub height: u32,
    /// The view it was taken from (the automatic one resolved; a camera's
    /// direction from its target).
    pub view: PictureView,
    /// The camera it was taken with, when one was given (its target
    /// resolved).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub camera: Option<PictureCamera>,
    /// Sample mode, when the request asked for a `generation`: the one
    /// drawn (as `grm/preview`'s `sample.generation`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub generation: Option<usize>,
    /// `image/png`, base64.
    pub png: String,
    pub triangles: usize,
    pub bones: usize,
    /// Why the picture shows nothing of the model, when it does not (a
    /// camera behind it, looking away, or so far that it is under a
    /// pixel): `grm_geom::render::camera_warning`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub warning: Option<String>,
}

/// The renderer's options for `p`, or why they cannot be drawn.
fn options(p: &PictureParams) -> std::result::Result<grm_geom::render::RenderOptions, String> {
    let d = grm_geom::render::RenderOptions::default();
    let o = grm_geom::render::RenderOptions {
        width: p.width.unwrap_or(d.width),
        height: p.height.unwrap_or(d.height),
        view: p.view.map_or(grm_geom::render::View::Auto, |v| {
            grm_geom::render::View::Angles {
                azimuth: v.azimuth,
                elevation: v.elevation,
            }
        }),
        transparent: p.transparent,
        ..d
    };
    let o = match p.camera {
        Some(_) if p.view.is_some() => {
            return Err("give the picture a view or a camera, not both".into());
        }
        Some(c) => grm_geom::render::RenderOptions {
            // Without a target, checked here looking from the position at
            // a point beside it (the position and field of view are what
            // can be wrong before the model is built); the model's centre
            // replaces it.
            view: camera_view(&c, glam::DVec3::from_array(c.position) + glam::DVec3::ONE),
            ..o
        },
        None => o,
    };
    o.validate().map_err(|e| e.to_string())?;
    if let Some(v) = p.view
        && !(-90.0..=90.0).contains(&v.elevation)
    {
        return Err(format!(
            "the view's elevation {} is not -90 to 90 degrees",
            v.elevation
        ));
    }
    Ok(o)
}

/// The view of camera `c`, looking at `centre` when it names no target.
fn camera_view(c: &PictureCamera, centre: glam::DVec3) -> grm_geom::render::View {
    grm_geom::render::View::Camera {
        eye: glam::DVec3::from_array(c.position),
        target: c.target.map_or(centre, glam::DVec3::from_array),
        fov: c.fov,
    }
}

/// The centre of `model`'s bounds (the origin when it has none), in f64.
fn centre(model: &grm_geom::Model) -> glam::DVec3 {
    let b = &model.stats.bounds;
    if b.is_empty() {
        glam::DVec3::ZERO
    } else {
        (b.min.as_dvec3() + b.max.as_dvec3()) * 0.5
    }
}

impl Backend {
    /// `grm/picture`.
    pub async fn picture(&self, params: PictureParams) -> Result<PictureResult> {
        let uri = params.preview.text_document.uri.clone();
        let path = convert::path_of(&uri).ok_or_else(|| failed("not a file URI"))?;
        let opts = options(&params).map_err(|m| Error {
            code: ErrorCode::InvalidParams,
            message: m.into(),
            data: None,
        })?;
        let params_camera = params.camera;
        let mut preview = params.preview;
        // A picture is a one-off: it neither registers nor supersedes the
        // live preview, and marks no rule.
        preview.live = false;
        preview.focus = None;
        let ticket = Ticket::begin(&self.shared, &path, false);
        let token = ticket.token.clone();
        let s = self.shared.clone();
        let made = tokio::task::spawn_blocking(move || {
            let fa = s
                .analyze(&path)
                .ok_or_else(|| Failure::Msg("the document is not open".into()))?;
            if let Some(v) = preview.version
                && v != fa.version
            {
                return Err(Failure::Stale(fa.version));
            }
            let edits = s.edits_source();
            let (r, _, model) =
                build_with_model(&fa, &uri, &s.uris(), &edits, &preview, Some(&token))?;
            if token.is_cancelled() {
                return Err(Failure::Cancelled);
            }
            // A camera without a target looks at the model's centre.
            let mut camera = params_camera;
            let opts = match &mut camera {
                Some(c) => {
                    let view = camera_view(c, centre(&model));
                    if let grm_geom::render::View::Camera { target, .. } = view {
                        c.target = Some(target.to_array());
                    }
                    grm_geom::render::RenderOptions { view, ..opts }
                }
                None => opts,
            };
            opts.validate().map_err(|e| Failure::Msg(e.to_string()))?;
            let warning =
                grm_geom::render::camera_warning(&model, &opts.view, opts.width, opts.height);
            let framing = grm_geom::render::framing(&model, opts.view);
            let image = grm_geom::render::render_framed(&model, &opts, &framing)
                .map_err(|e| Failure::Msg(e.to_string()))?;
            let png = grm_geom::render::png_bytes(&image)
                .map_err(|e| Failure::Msg(format!("the picture could not be encoded: {e}")))?;
            Ok(PictureResult {
                uri: r.uri,
                version: r.version,
                system: r.system,
                seed: r.seed,
                width: image.width,
                height: image.height,
                view: PictureView {
                    azimuth: framing.azimuth,
                    elevation: framing.elevation,
                },
                camera,
                generation: r.sample.as_ref().and_then(|s| s.generation),
                png: base64::engine::general_purpose::STANDARD.encode(png),
                triangles: model.stats.triangles,
                bones: model.stats.bones,
                warning,
            })
        })
        .await
        .map_err(|e| Error {
            code: ErrorCode::InternalError,
            message: e.to_string().into(),
            data: None,
        })?;
        drop(ticket);
        match made {
            Ok(r) => Ok(r),
            Err(Failure::Cancelled) => Err(Error::request_cancelled()),
            Err(stale @ Failure::Stale(_)) => Err(Error {
                code: ErrorCode::ContentModified,
                message: stale.to_string().into(),
                data: None,
            }),
            Err(Failure::Msg(m)) => Err(failed(m)),
        }
    }
}

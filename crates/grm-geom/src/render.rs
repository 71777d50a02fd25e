//! A picture of a [`Model`]: a software rasterizer behind the `.png` export.
//!
//! Input: a built model and [`RenderOptions`] (size, view, samples,
//! background). Output: an [`Image`] (8-bit sRGB RGBA, rows top to bottom)
//! and its PNG encoding ([`write_png`]). No GPU and no window: it runs the
//! same on a headless CI machine, for thumbnails, batch renders and
//! comparing models by eye.
//!
//! How it draws:
//! - **Camera**: orthographic, looking at the model from a direction given
//!   by azimuth and elevation ([`View::Angles`]), with +y up on the
//!   picture (the turtle's initial heading); or perspective, from a point
//!   toward a point with a vertical field of view ([`View::Camera`], the
//!   preview's orbit camera: what the preview shows, zoom and pan
//!   included), clipped at a near plane a thousandth of the way to the
//!   target and at a guard band a picture size around the picture (so
//!   what the rasterizer gets keeps f32's precision, however narrow the
//!   view or near the plane), with depth relative to the model's far end
//!   (so it keeps its precision however far the camera stands).
//!   [`View::Auto`] looks straight
//!   down -z at a model that is flat in the xy plane (the classic 2D
//!   L-systems, as the SVG export shows them) and from
//!   [`AUTO_AZIMUTH`]/[`AUTO_ELEVATION`] at anything else. The projection
//!   is fitted to the model's projected extent (every mesh vertex and every
//!   drawn bone end) with a margin of [`MARGIN`] of the shorter side, so
//!   the model fills the picture whatever its scale; or to a [`Framing`]
//!   shared by several models ([`render_framed`]), which then keep their
//!   places (the frames of `grmc derive --frames`).
//! - **Surfaces**: every triangle of every part, depth-buffered, lit per
//!   vertex (a key light from the upper left, ambient and a little light
//!   from the camera), two-sided (a triangle seen from behind is lit as
//!   its front would be: `{ . }` polygons and discs have one face),
//!   coloured by the part's material (base colour plus emissive).
//! - **Opacity**: a material of opacity below 1 is translucent. Its
//!   triangles are drawn after everything opaque, farthest first (by the
//!   depth of each triangle's centroid), each blended over what is there
//!   without hiding what comes after; over the background the colour is
//!   kept premultiplied with the coverage, so a transparent picture's alpha
//!   is what the surfaces stop. A sheet counts once (a disc's back face
//!   lies on its front face); a closed surface counts twice, front and
//!   back. Opacity 0 is not drawn. Triangles that cross each other are not
//!   split, so where translucent surfaces intersect the order is the
//!   centroids'.
//! - **Bones as lines**: bare bones (no tube: zero width, as in the classic
//!   2D systems) are drawn as one-pixel lines in their paint colour,
//!   depth-tested against the surfaces, as the SVG export draws them as
//!   hairlines. A bone with a tube also gets its line, under the
//!   surfaces: a tube thinner than a pixel stays a continuous line, and a
//!   thicker one hides it.
//! - **Anti-aliasing**: `samples` x `samples` samples per pixel, averaged in
//!   linear light, then encoded as sRGB.
//!
//! Drawing is parallel (rayon) over bands of [`BAND_ROWS`] sample rows:
//! each band owns its rows and draws, in the model's order, the triangles
//! and lines that overlap it.
//!
//! Invariants: the picture depends only on the model, the options and the
//! framing (no clock; bands never share a sample, so any number of threads
//! gives the same bytes); non-finite coordinates never reach the buffers
//! (the fit and the clipping are computed in f64, depth is in samples or
//! relative to the far end); the sample buffers
//! never exceed [`MAX_SAMPLES_TOTAL`] samples (`samples` is lowered for a
//! large picture, down to one sample per pixel); sizes outside
//! 1..=[`MAX_IMAGE_SIDE`] or over [`MAX_PIXELS`] are a [`RenderError`],
//! never a panic.

use std::borrow::Cow;
use std::io::{self, Write};

pub use glam::DVec3;
use glam::{DVec2, Vec3};
use rayon::prelude::*;

use crate::{Model, PartSource};

mod projection;
mod raster;
use projection::*;
pub use projection::{auto_angles, camera_warning, orbit_camera};
pub use raster::BAND_ROWS;
pub(crate) use raster::srgb;
use raster::*;

/// The longest side of a picture, in pixels.
pub const MAX_IMAGE_SIDE: u32 = 16384;
/// The most pixels of a picture (width x height): 4096 x 4096.
pub const MAX_PIXELS: u64 = 1 << 24;
/// The most samples (pixels x samples²) the buffers hold: about 330 MB.
pub const MAX_SAMPLES_TOTAL: u64 = 1 << 25;
/// The most samples per pixel along each axis.
pub const MAX_SAMPLES: u32 = 4;
/// [`View::Auto`]'s azimuth for a model that is not flat, in degrees.
pub const AUTO_AZIMUTH: f32 = 35.0;
/// [`View::Auto`]'s elevation for a model that is not flat, in degrees.
pub const AUTO_ELEVATION: f32 = 20.0;
/// The margin around the model, as a fraction of the picture's shorter side.
pub const MARGIN: f32 = 0.04;

/// Where the camera looks from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum View {
    /// Down -z at a model flat in xy; otherwise
    /// [`AUTO_AZIMUTH`]/[`AUTO_ELEVATION`].
    Auto,
    /// The camera's direction from the model, in degrees: `azimuth` about
    /// +y, from +z (0: looking down -z) toward +x (90: looking down -x);
    /// `elevation` above the xz plane (90: looking straight down, at most
    /// ±89.9 is used so that +y can stay up).
    Angles { azimuth: f32, elevation: f32 },
    /// A perspective camera at `eye` looking at `target`, +y up on the
    /// picture (as the preview's orbit camera keeps it), with a vertical
    /// field of view of `fov` degrees (more than 0, less than 180). Not
    /// fitted: what the camera sees is drawn, at the scale it sees it.
    /// Geometry nearer than [`NEAR_FRACTION`] of the eye's distance to
    /// the target, or behind the eye, is clipped.
    Camera { eye: DVec3, target: DVec3, fov: f32 },
}

/// [`View::Camera`]'s near plane, as a fraction of the distance from the
/// eye to the target.
pub const NEAR_FRACTION: f64 = 1e-3;
/// The largest field of view [`View::Camera`] takes, in degrees.
pub const MAX_FOV: f32 = 179.0;

/// How to draw a picture.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderOptions {
    pub width: u32,
    pub height: u32,
    pub view: View,
    /// Samples per pixel along each axis, 1 to [`MAX_SAMPLES`] (3 = nine
    /// samples a pixel); lowered when the picture would need more than
    /// [`MAX_SAMPLES_TOTAL`].
    pub samples: u32,
    /// A transparent background (alpha = coverage) instead of the light
    /// grey gradient.
    pub transparent: bool,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            width: 1024,
            height: 1024,
            view: View::Auto,
            samples: 3,
            transparent: false,
        }
    }
}

impl RenderOptions {
    /// Check the size and samples; the error says what is wrong.
    pub fn validate(&self) -> Result<(), RenderError> {
        let (w, h) = (self.width, self.height);
        if w == 0 || h == 0 || w > MAX_IMAGE_SIDE || h > MAX_IMAGE_SIDE {
            return Err(RenderError::Size {
                width: w,
                height: h,
            });
        }
        if u64::from(w) * u64::from(h) > MAX_PIXELS {
            return Err(RenderError::Size {
                width: w,
                height: h,
            });
        }
        if !(1..=MAX_SAMPLES).contains(&self.samples) {
            return Err(RenderError::Samples(self.samples));
        }
        self.view.validate()
    }

    /// The samples per axis actually used: `samples`, lowered until the
    /// buffers fit [`MAX_SAMPLES_TOTAL`] (at least 1).
    pub fn effective_samples(&self) -> u32 {
        let pixels = u64::from(self.width) * u64::from(self.height);
        let mut s = self.samples.clamp(1, MAX_SAMPLES);
        while s > 1 && pixels * u64::from(s * s) > MAX_SAMPLES_TOTAL {
            s -= 1;
        }
        s
    }
}

impl View {
    /// Check the view's numbers: finite angles; a camera whose eye and
    /// target are finite and apart (their distance too) and whose field
    /// of view is in `(0, MAX_FOV]`.
    pub fn validate(&self) -> Result<(), RenderError> {
        match *self {
            View::Auto => Ok(()),
            View::Angles { azimuth, elevation } => {
                if azimuth.is_finite() && elevation.is_finite() {
                    Ok(())
                } else {
                    Err(RenderError::View)
                }
            }
            View::Camera { eye, target, fov } => {
                let distance = length(target - eye);
                if !(eye.is_finite() && target.is_finite() && distance.is_finite()) {
                    Err(RenderError::Camera(
                        "its position and target must be finite numbers",
                    ))
                } else if NEAR_FRACTION * distance == 0.0 {
                    // Zero, or so close that the near plane would be at
                    // the eye (about 5e-321 apart).
                    Err(RenderError::Camera(
                        "its position and target must be different points",
                    ))
                } else if !(fov > 0.0 && fov <= MAX_FOV) {
                    Err(RenderError::Camera(
                        "its field of view must be more than 0 and at most 179 degrees",
                    ))
                } else {
                    Ok(())
                }
            }
        }
    }
}

/// Why a picture cannot be drawn.
#[derive(Clone, Debug, PartialEq)]
pub enum RenderError {
    /// A side is 0 or over [`MAX_IMAGE_SIDE`], or the picture has more
    /// than [`MAX_PIXELS`] pixels.
    Size { width: u32, height: u32 },
    /// Samples per axis outside 1..=[`MAX_SAMPLES`].
    Samples(u32),
    /// An angle of the view is not finite.
    View,
    /// A [`View::Camera`] that cannot look: why.
    Camera(&'static str),
}

impl std::fmt::Display for RenderError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RenderError::Size { width, height } => write!(
                f,
                "a picture of {width}x{height} pixels cannot be drawn: each side must be 1 to \
                 {MAX_IMAGE_SIDE} and the picture at most {MAX_PIXELS} pixels"
            ),
            RenderError::Samples(s) => {
                write!(
                    f,
                    "{s} samples per pixel side: it must be 1 to {MAX_SAMPLES}"
                )
            }
            RenderError::View => write!(f, "the view's angles must be finite numbers"),
            RenderError::Camera(why) => write!(f, "the camera cannot be used: {why}"),
        }
    }
}

impl std::error::Error for RenderError {}

/// An 8-bit sRGB picture with alpha, rows top to bottom.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    /// `width * height * 4` bytes: R, G, B, A per pixel.
    pub rgba: Vec<u8>,
    /// Drawn on a transparent background: written as RGBA even when every
    /// pixel happens to be covered (else RGB when every pixel is opaque).
    pub transparent: bool,
}

impl Image {
    /// The pixel at column `x`, row `y` (0, 0 is the top left); `None`
    /// outside the picture (or past the end of `rgba`).
    pub fn pixel(&self, x: u32, y: u32) -> Option<[u8; 4]> {
        if x >= self.width || y >= self.height {
            return None;
        }
        // x < width and y < height, both u32: the index fits in u64.
        let i = (u64::from(y) * u64::from(self.width) + u64::from(x)) * 4;
        let i = usize::try_from(i).ok()?;
        let p = self.rgba.get(i..i.checked_add(4)?)?;
        Some([p[0], p[1], p[2], p[3]])
    }

    /// Whether every pixel is opaque.
    pub fn is_opaque(&self) -> bool {
        self.rgba.chunks_exact(4).all(|p| p[3] == 255)
    }
}

/// The background gradient, top and bottom, linear RGB.
const BACKGROUND_TOP: [f32; 3] = [0.913, 0.930, 0.955];
const BACKGROUND_BOTTOM: [f32; 3] = [0.716, 0.745, 0.783];
/// Light in camera space (x right, y up, z toward the camera).
const KEY_LIGHT: Vec3 = Vec3::new(-0.42, 0.62, 0.66);
const AMBIENT: f32 = 0.22;
const KEY: f32 = 0.66;
const HEAD: f32 = 0.18;
/// The light of a tube's line (a tube thinner than a sample): its
/// surface's light half way round.
const LINE_LIGHT: f32 = AMBIENT + 0.5 * KEY + 0.5 * HEAD;

/// Which bones got a tube (from the parts' picks).
fn tubed_bones(model: &Model) -> Vec<bool> {
    let mut tubed = vec![false; model.skeleton.bones.len()];
    for part in &model.parts {
        for pick in &part.picks {
            if let PartSource::Bone(b) = pick.source
                && let Some(t) = tubed.get_mut(b as usize)
            {
                *t = true;
            }
        }
    }
    tubed
}

/// A material's opacity as drawn: 0 to 1 (not a number: opaque).
fn opacity(o: f32) -> f32 {
    if o.is_nan() { 1.0 } else { o.clamp(0.0, 1.0) }
}

/// The opacity of each bone's tube (1 for a bone without one): a
/// translucent tube gets no line under it, an invisible one (0) is not
/// framed either.
fn tube_opacity(model: &Model) -> Vec<f32> {
    let mut of = vec![1.0f32; model.skeleton.bones.len()];
    for part in &model.parts {
        let alpha = model
            .materials
            .get(part.material)
            .map_or(1.0, |m| opacity(m.opacity));
        if alpha >= 1.0 {
            continue;
        }
        for pick in &part.picks {
            if let PartSource::Bone(b) = pick.source
                && let Some(o) = of.get_mut(b as usize)
            {
                *o = o.min(alpha);
            }
        }
    }
    of
}

/// Whether a part is drawn at all (its material's opacity is not 0).
fn visible(model: &Model, part: &crate::Part) -> bool {
    model
        .materials
        .get(part.material)
        .is_none_or(|m| opacity(m.opacity) > 0.0)
}

/// What a picture shows: the view it looks from (resolved: never
/// [`View::Auto`]) and the box it fits to the picture, in camera space (x
/// right, y up, z toward the camera). [`framing`] computes it for one
/// model; several models drawn with one framing ([`render_framed`], with
/// the [`Framing::union`] of theirs) keep their places and scale, as the
/// iterations of a derivation do in `grmc derive --frames`. A
/// [`View::Camera`] is not fitted: its framing is the camera, and
/// `azimuth` and `elevation` are the direction it looks from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Framing {
    pub azimuth: f32,
    pub elevation: f32,
    lo: DVec3,
    hi: DVec3,
    perspective: Option<Perspective>,
}

impl Framing {
    /// Whether nothing is framed (a model with nothing to draw).
    pub fn is_empty(&self) -> bool {
        self.lo.x.partial_cmp(&self.hi.x).is_none_or(|o| o.is_gt())
    }

    /// The framing of both: `self`'s view, the box holding both boxes.
    /// Boxes of different views are not comparable: `other` must have the
    /// same view (else `self` is returned unchanged).
    pub fn union(&self, other: &Framing) -> Framing {
        if (self.azimuth, self.elevation, self.perspective)
            != (other.azimuth, other.elevation, other.perspective)
        {
            return *self;
        }
        Framing {
            lo: self.lo.min(other.lo),
            hi: self.hi.max(other.hi),
            ..*self
        }
    }

    /// The view this framing draws from ([`View::Angles`] or
    /// [`View::Camera`]).
    pub fn view(&self) -> View {
        match self.perspective {
            Some(Perspective { eye, target, fov }) => View::Camera { eye, target, fov },
            None => View::Angles {
                azimuth: self.azimuth,
                elevation: self.elevation,
            },
        }
    }
}

/// Every bone that is a segment (finite ends, not a point): drawn as a
/// line.
fn line_bones(model: &Model) -> Vec<usize> {
    model
        .skeleton
        .bones
        .iter()
        .enumerate()
        .filter(|(_, b)| b.base.is_finite() && b.tip.is_finite() && b.base != b.tip)
        .map(|(i, _)| i)
        .collect()
}

/// The framing of `model` seen from `view` ([`View::Auto`] picks by the
/// model, [`auto_angles`]): the projected extent of everything drawn, every
/// mesh vertex and every line's ends, in f64 (no overflow for coordinates
/// near f32's limits, no loss for a model far from the origin).
pub fn framing(model: &Model, view: View) -> Framing {
    let (cam, azimuth, elevation, perspective) = match view {
        View::Auto => {
            let (a, e) = auto_angles(model);
            (Camera::new(a, e), a, e, None)
        }
        View::Angles { azimuth, elevation } => {
            (Camera::new(azimuth, elevation), azimuth, elevation, None)
        }
        View::Camera { eye, target, fov } if eye != target => {
            let cam = Camera::looking(eye, target);
            let (a, e) = cam.angles();
            (cam, a, e, Some(Perspective { eye, target, fov }))
        }
        // The same point: no direction (`validate` refuses it before any
        // drawing); framed from the front so the framing stays finite.
        View::Camera { eye, target, fov } => (
            Camera::new(0.0, 0.0),
            0.0,
            0.0,
            Some(Perspective { eye, target, fov }),
        ),
    };
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    let mut grow = |p: Vec3| {
        if p.is_finite() {
            let q = cam.project(p);
            lo = lo.min(q);
            hi = hi.max(q);
        }
    };
    // What is drawn: not the parts of opacity 0, nor their bones' lines.
    for part in model.parts.iter().filter(|p| visible(model, p)) {
        for p in &part.mesh.positions {
            grow(Vec3::from_array(*p));
        }
    }
    let tubes = tube_opacity(model);
    for i in line_bones(model) {
        if tubes[i] <= 0.0 {
            continue;
        }
        let b = &model.skeleton.bones[i];
        grow(b.base);
        grow(b.tip);
    }
    Framing {
        azimuth,
        elevation,
        lo,
        hi,
        perspective,
    }
}

/// Draw `model` as `options` say, fitted to the picture.
pub fn render(model: &Model, options: &RenderOptions) -> Result<Image, RenderError> {
    options.validate()?;
    render_framed(model, options, &framing(model, options.view))
}

/// A part's vertices in camera space and light, clipped (perspective) at
/// the near plane and the guard band: the triangles that cross a plane are
/// cut there (Sutherland-Hodgman; each becomes a convex polygon of new
/// vertices after the mesh's, drawn as a fan, so its triangles keep its
/// orientation), those wholly outside one dropped.
fn prepare<'m>(
    proj: &Projection,
    indices: &'m [u32],
    cam: Vec<DVec3>,
    mut front: Vec<Vec3>,
    mut back: Vec<Vec3>,
) -> Prepared<'m> {
    let n = cam.len();
    let mut screen: Vec<Vec3> = cam.iter().map(|c| proj.screen(*c)).collect();
    // Orthographic: no clip planes, nothing to classify per vertex.
    let out: Vec<u8> = if proj.planes() == 0 {
        Vec::new()
    } else {
        cam.iter().map(|c| proj.outside(*c)).collect()
    };
    if out.iter().all(|&o| o == 0) {
        return Prepared {
            indices: Cow::Borrowed(indices),
            screen,
            front,
            back,
            alpha: 1.0,
        };
    }
    let mut kept = Vec::with_capacity(indices.len());
    // A polygon's vertices: camera space, light from the front and back.
    let (mut poly, mut next) = (Vec::new(), Vec::new());
    for t in indices.chunks_exact(3) {
        let i = [t[0] as usize, t[1] as usize, t[2] as usize];
        if i.iter().any(|&k| k >= n) {
            continue;
        }
        let o = i.map(|k| out[k]);
        if o == [0; 3] {
            kept.extend_from_slice(t);
            continue;
        }
        if o[0] & o[1] & o[2] != 0 || !i.iter().all(|&k| cam[k].is_finite()) {
            continue;
        }
        poly.clear();
        poly.extend(i.map(|k| (cam[k], front[k], back[k])));
        // Only the planes a vertex is outside of: the polygon's points are
        // on its edges, inside the others.
        for plane in (0..PLANES).filter(|&k| (o[0] | o[1] | o[2]) & 1 << k != 0) {
            next.clear();
            for e in 0..poly.len() {
                let (a, b) = (poly[e], poly[(e + 1) % poly.len()]);
                let (a_in, b_in) = (proj.side(plane, a.0) >= 0.0, proj.side(plane, b.0) >= 0.0);
                if a_in {
                    next.push(a);
                }
                if a_in != b_in {
                    let (from, to) = if a_in { (a, b) } else { (b, a) };
                    let (p, s) = proj.clip(plane, from.0, to.0);
                    next.push((p, from.1.lerp(to.1, s), from.2.lerp(to.2, s)));
                }
            }
            std::mem::swap(&mut poly, &mut next);
        }
        if poly.len() < 3 {
            continue;
        }
        let first = screen.len() as u32;
        for &(c, f, b) in &poly {
            screen.push(proj.screen(c));
            front.push(f);
            back.push(b);
        }
        for k in 1..poly.len() as u32 - 1 {
            kept.extend_from_slice(&[first, first + k, first + k + 1]);
        }
    }
    Prepared {
        indices: Cow::Owned(kept),
        screen,
        front,
        back,
        alpha: 1.0,
    }
}

/// Draw `model` as `options` say (their view is not used) with `framing`'s
/// view and fit: the model keeps the place and scale of whatever the
/// framing was made from.
pub fn render_framed(
    model: &Model,
    options: &RenderOptions,
    framing: &Framing,
) -> Result<Image, RenderError> {
    options.validate()?;
    // The framing's view first: a camera that cannot look is a
    // `RenderError::Camera` (its direction's angles are then not finite
    // either), and finite angles are what an orthographic one needs.
    framing.view().validate()?;
    let s = options.effective_samples() as usize;
    let (width, height) = (options.width as usize, options.height as usize);
    let (sw, sh) = (width * s, height * s);
    let tubed = tubed_bones(model);
    // Every bone that is a segment is drawn as a line: those without a tube
    // over the surfaces, those with one under them (a tube thinner than a
    // sample would leave gaps; a thicker one hides its line).
    let lines = line_bones(model);
    let (lo, hi) = (framing.lo, framing.hi);

    let mut target = Target::new(sw, sh);
    if !framing.is_empty() {
        let centre = (lo + hi) * 0.5;
        let extent = hi - lo;
        // A side the model does not extend along (a line seen end on, a
        // single point) counts as a millionth of the model's size, so the
        // scale stays finite: sample coordinates, depth included, stay
        // within about 1e6 picture widths.
        let size = extent.max_element();
        let floor = if size > 0.0 { 1e-6 * size } else { 1.0 };
        let (half_w, half_h) = (sw as f64 * 0.5, sh as f64 * 0.5);
        let proj = match framing.perspective {
            None => {
                let margin = f64::from(MARGIN) * (sw.min(sh) as f64);
                let scale_x = (sw as f64 - 2.0 * margin).max(1.0) / extent.x.max(floor);
                let scale_y = (sh as f64 - 2.0 * margin).max(1.0) / extent.y.max(floor);
                let scale = scale_x.min(scale_y);
                Projection::Ortho {
                    cam: Camera::new(framing.azimuth, framing.elevation),
                    centre,
                    scale,
                    half_w,
                    half_h,
                    // Depth is in samples too, so a near tie means the same
                    // at any scale: a bare bone wins against a surface less
                    // than 1e-4 of the model's size in front of it (one it
                    // lies on, up to rounding).
                    bias: (1e-4 * size.max(floor) * scale) as f32,
                }
            }
            Some(Perspective { eye, target, fov }) => {
                let half_fov = (f64::from(fov) * 0.5).to_radians();
                let cam = Camera::looking(eye, target);
                let near = NEAR_FRACTION * length(target - eye);
                // The model's far end (`lo.z` is its least `p . toward`).
                let reference = (eye.dot(cam.toward) - lo.z).max(near);
                let guard = sw.max(sh) as f64;
                Projection::Persp {
                    cam,
                    eye,
                    focal: half_h / half_fov.tan(),
                    near,
                    half_w,
                    half_h,
                    guard_w: half_w + guard,
                    guard_h: half_h + guard,
                    reference,
                    bias: (1e-4 * size.max(floor) / reference).min(f64::from(f32::MAX)) as f32,
                }
            }
        };
        let line = |i: usize, light: f32, biased: bool| {
            let b = &model.skeleton.bones[i];
            let (mut a, mut c) = (proj.cam(b.base), proj.cam(b.tip));
            // Cut at each clip plane in turn (none, orthographic).
            for plane in 0..proj.planes() {
                match (proj.side(plane, a) >= 0.0, proj.side(plane, c) >= 0.0) {
                    (false, false) => return None,
                    (true, false) => c = proj.clip(plane, a, c).0,
                    (false, true) => a = proj.clip(plane, c, a).0,
                    (true, true) => {}
                }
            }
            Some(Line {
                a: proj.screen(a),
                b: proj.screen(c),
                color: quantize(Vec3::from_array(model.paint_color(b.paint)) * light),
                bias: if biased { proj.bias() } else { Bias::Flat(0.0) },
            })
        };
        let mut scene = Scene {
            parts: Vec::with_capacity(model.parts.len()),
            lines: Vec::with_capacity(lines.len()),
            items: Vec::new(),
        };
        // A translucent tube's line would show through it as a core: none.
        let tubes = tube_opacity(model);
        for &i in lines.iter().filter(|&&i| tubed[i] && tubes[i] >= 1.0) {
            if let Some(l) = line(i, LINE_LIGHT, false) {
                scene.items.push(Item::Line(scene.lines.len() as u32));
                scene.lines.push(l);
            }
        }
        let light = KEY_LIGHT.normalize();
        let cam = proj.camera();
        // Translucent triangles: drawn after everything opaque.
        let mut translucent = Vec::new();
        for part in &model.parts {
            let Some(material) = model.materials.get(part.material) else {
                continue;
            };
            let alpha = opacity(material.opacity);
            if alpha <= 0.0 {
                // Invisible (as a glTF viewer shows an alpha of 0).
                continue;
            }
            let base = Vec3::from_array(material.color);
            let emissive = Vec3::from_array(material.emissive);
            let mesh = &part.mesh;
            let shade = |n: Vec3| {
                let n = cam.project(n).as_vec3();
                let lit = AMBIENT + KEY * n.dot(light).max(0.0) + HEAD * n.z.max(0.0);
                base * lit + emissive
            };
            let k = scene.parts.len() as u32;
            let n = mesh.positions.len().min(mesh.normals.len());
            let prepared = prepare(
                &proj,
                &mesh.indices,
                mesh.positions[..n]
                    .iter()
                    .map(|p| proj.cam(Vec3::from_array(*p)))
                    .collect(),
                mesh.normals[..n]
                    .iter()
                    .map(|v| shade(Vec3::from_array(*v)))
                    .collect(),
                mesh.normals[..n]
                    .iter()
                    .map(|v| shade(-Vec3::from_array(*v)))
                    .collect(),
            );
            let triangles = (prepared.indices.len() / 3) as u32;
            scene.parts.push(Prepared { alpha, ..prepared });
            let items = (0..triangles).map(|t| Item::Tri(k, t));
            if alpha < 1.0 {
                translucent.extend(items);
            } else {
                scene.items.extend(items);
            }
        }
        for &i in lines.iter().filter(|&&i| !tubed[i]) {
            if let Some(l) = line(i, 1.0, true) {
                scene.items.push(Item::Line(scene.lines.len() as u32));
                scene.lines.push(l);
            }
        }
        // Farthest first (z larger = nearer), by the centroid's depth; the
        // sort is stable, so equal depths keep the model's order.
        let depth_of = |item: &Item| match *item {
            Item::Tri(part, tri) => scene
                .triangle(part, tri)
                .map_or(f32::NEG_INFINITY, |(v, _, _)| v[0].z + v[1].z + v[2].z),
            Item::Line(_) => f32::NEG_INFINITY,
        };
        let mut keyed: Vec<(f32, Item)> = translucent.iter().map(|t| (depth_of(t), *t)).collect();
        keyed.sort_by(|a, b| a.0.total_cmp(&b.0));
        scene.items.extend(keyed.into_iter().map(|(_, t)| t));
        target.draw(&scene, s);
    }
    Ok(resolve(&target, width, height, s, options.transparent))
}

/// Write `image` as PNG, tagged sRGB: RGBA for a picture drawn on a
/// transparent background or with any pixel not opaque, else RGB.
pub fn write_png(image: &Image, w: &mut dyn Write) -> io::Result<()> {
    let opaque = !image.transparent && image.is_opaque();
    let mut encoder = png::Encoder::new(w, image.width, image.height);
    encoder.set_color(if opaque {
        png::ColorType::Rgb
    } else {
        png::ColorType::Rgba
    });
    encoder.set_depth(png::BitDepth::Eight);
    // fdeflate's PNG-tuned mode: several times faster than the default
    // level, files about a fifth larger.
    encoder.set_compression(png::Compression::Fast);
    encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    let mut writer = encoder.write_header().map_err(png_error)?;
    if opaque {
        let rgb: Vec<u8> = image
            .rgba
            .chunks_exact(4)
            .flat_map(|p| [p[0], p[1], p[2]])
            .collect();
        writer.write_image_data(&rgb).map_err(png_error)?;
    } else {
        writer.write_image_data(&image.rgba).map_err(png_error)?;
    }
    writer.finish().map_err(png_error)
}

fn png_error(e: png::EncodingError) -> io::Error {
    match e {
        png::EncodingError::IoError(e) => e,
        other => io::Error::other(other.to_string()),
    }
}

/// `image` as PNG bytes (an error only for an [`Image`] whose `rgba` is
/// not `width * height * 4` bytes).
pub fn png_bytes(image: &Image) -> io::Result<Vec<u8>> {
    let mut out = Vec::new();
    write_png(image, &mut out)?;
    Ok(out)
}

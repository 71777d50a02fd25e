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

/// The camera's frame: `right` and `up` span the picture, `toward` points
/// from the model to the camera. In f64: the fit projects the model's
/// points with it, and a model far from the origin (or one with
/// coordinates near f32's limits) keeps its detail and its extent.
#[derive(Clone, Copy, Debug)]
struct Camera {
    right: DVec3,
    up: DVec3,
    toward: DVec3,
}

impl Camera {
    fn new(azimuth_deg: f32, elevation_deg: f32) -> Camera {
        // Whole turns taken off first (exactly: `rem_euclid` of a float is
        // exact), so 360 draws as 0 and a huge azimuth is still the angle
        // it names, not the rounding error of its radians.
        let az = f64::from(azimuth_deg).rem_euclid(360.0).to_radians();
        let el = f64::from(elevation_deg.clamp(-89.9, 89.9)).to_radians();
        let toward = DVec3::new(az.sin() * el.cos(), el.sin(), az.cos() * el.cos());
        // |toward.y| < 1, so the cross product with +y is never zero.
        let right = DVec3::Y.cross(toward).normalize();
        let up = toward.cross(right);
        Camera { right, up, toward }
    }

    /// The frame of a camera at `eye` looking at `target` (different
    /// points), +y up on the picture; straight up or down, +x is right.
    fn looking(eye: DVec3, target: DVec3) -> Camera {
        // Scaled first: the square of a distance of 1e-300 (or 1e160)
        // underflows (overflows), and `normalize` would give NaN.
        let d = eye - target;
        let toward = (d / d.abs().max_element()).normalize();
        let right = DVec3::Y.cross(toward);
        let right = if right.length() > 1e-9 {
            right.normalize()
        } else {
            DVec3::X
        };
        let up = toward.cross(right);
        Camera { right, up, toward }
    }

    /// The direction the camera looks from, as (azimuth, elevation) in
    /// degrees ([`View::Angles`]' convention).
    fn angles(&self) -> (f32, f32) {
        let t = self.toward;
        let azimuth = t.x.atan2(t.z).to_degrees();
        let elevation = t.y.clamp(-1.0, 1.0).asin().to_degrees();
        (azimuth as f32, elevation as f32)
    }

    #[inline]
    fn project(&self, p: Vec3) -> DVec3 {
        self.project_d(p.as_dvec3())
    }

    #[inline]
    fn project_d(&self, p: DVec3) -> DVec3 {
        DVec3::new(p.dot(self.right), p.dot(self.up), p.dot(self.toward))
    }
}

/// The length of `v`, without squaring its components first (which
/// underflows to 0 for 1e-300, overflows for 1e160): a camera's eye and
/// target may be any two different finite points.
fn length(v: DVec3) -> f64 {
    let m = v.abs().max_element();
    if m > 0.0 && m.is_finite() {
        m * (v / m).length()
    } else {
        m
    }
}

/// Why a picture through `view` (a [`View::Camera`]) of `model` will show
/// nothing of it, said so rather than drawn as an empty picture: the model
/// is behind the camera, outside what it sees, or, seen from so far (a
/// position near or past f32's range), smaller than a pixel of a picture
/// of `width` x `height` pixels. `None` when the model shows (or the view
/// is not a camera, or the model is empty). Judged from the corners of
/// the model's bounds, in f64.
pub fn camera_warning(model: &Model, view: &View, width: u32, height: u32) -> Option<String> {
    let View::Camera { eye, target, fov } = *view else {
        return None;
    };
    let b = &model.stats.bounds;
    if b.is_empty() || view.validate().is_err() {
        return None;
    }
    let cam = Camera::looking(eye, target);
    let (lo, hi) = (b.min.as_dvec3(), b.max.as_dvec3());
    let half = (f64::from(fov).to_radians() * 0.5).tan();
    let scale = f64::from(height.max(1)) * 0.5 / half;
    let (mut min, mut max) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
    let mut in_front = 0;
    for k in 0..8 {
        let c = DVec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        );
        // Relative to the eye, scaled down first so that a far eye does
        // not overflow; the ratios below are unchanged by the scale.
        let d = c - eye;
        let m = d.abs().max_element().max(f64::MIN_POSITIVE);
        let q = cam.project_d(d / m);
        let depth = -q.z;
        if depth > 0.0 {
            in_front += 1;
            let p = DVec2::new(q.x, q.y) / depth * scale;
            min = min.min(p);
            max = max.max(p);
        }
    }
    let distance = length((lo + hi) * 0.5 - eye);
    if in_front == 0 {
        return Some(format!(
            "the model is behind the camera ({} units from it): the picture shows nothing of it",
            short(distance)
        ));
    }
    let (half_w, half_h) = (
        f64::from(width.max(1)) * 0.5,
        f64::from(height.max(1)) * 0.5,
    );
    // Only when every corner is in front: a model around the eye is
    // partly seen whatever its corners project to.
    if in_front == 8 {
        let size = (max - min).max_element();
        if size < 1.0 {
            return Some(format!(
                "the model is smaller than a pixel from this camera ({} units from it, {} units across): \
                 the picture shows nothing of it; move the camera closer",
                short(distance),
                short(length(hi - lo))
            ));
        }
        if min.x > half_w || max.x < -half_w || min.y > half_h || max.y < -half_h {
            return Some(
                "the model is outside what the camera sees: the picture shows nothing of it"
                    .to_string(),
            );
        }
    }
    None
}

/// A distance for a message: 3 significant digits, exponent past 1e6.
fn short(x: f64) -> String {
    if x.abs() >= 1e6 || (x != 0.0 && x.abs() < 1e-3) {
        format!("{x:.2e}")
    } else {
        format!("{x:.3}")
    }
}

/// A [`View::Camera`] set up for a picture.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Perspective {
    eye: DVec3,
    target: DVec3,
    fov: f32,
}

/// The view [`View::Auto`] picks for `model`: (azimuth, elevation). A
/// model is flat when it has no primitives or meshes and its bone ends and
/// polygon vertices keep one z (to 1e-4 of their extent in x and y): the
/// classic 2D L-systems, whose tubes alone are not a third dimension.
pub fn auto_angles(model: &Model) -> (f32, f32) {
    let s = &model.skeleton;
    let mut b = crate::Aabb::EMPTY;
    for bone in &s.bones {
        b.add(bone.base);
        b.add(bone.tip);
    }
    for p in &s.polygon_vertices {
        b.add(*p);
    }
    // In f64: the extent of a model spanning f32's range overflows f32.
    let size = b.max.as_dvec3() - b.min.as_dvec3();
    let flat = s.instances.is_empty() && !b.is_empty() && size.z <= 1e-4 * size.x.max(size.y);
    if flat {
        (0.0, 0.0)
    } else {
        (AUTO_AZIMUTH, AUTO_ELEVATION)
    }
}

/// The perspective camera that frames `model` as the preview does when a
/// model first appears: looking at the centre of its bounds from
/// `azimuth`/`elevation` (degrees, [`View::Angles`]' convention), far
/// enough that the sphere around the bounds fits a vertical field of view
/// of `fov` degrees (with 5% to spare). `None` for a model with nothing in
/// its bounds, or bounds past f64's reach.
pub fn orbit_camera(model: &Model, azimuth: f32, elevation: f32, fov: f32) -> Option<View> {
    let b = &model.stats.bounds;
    if b.is_empty() {
        return None;
    }
    let (lo, hi) = (b.min.as_dvec3(), b.max.as_dvec3());
    let target = (lo + hi) * 0.5;
    let radius = (length(hi - lo) * 0.5)
        .max(1e-6 * target.abs().max_element())
        .max(1e-30);
    let half = (f64::from(fov) * 0.5).to_radians();
    let distance = radius / half.sin() * 1.05;
    let eye = target + Camera::new(azimuth, elevation).toward * distance;
    let view = View::Camera { eye, target, fov };
    view.validate().is_ok().then_some(view)
}

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

/// Sample rows per band: the unit of parallel work. Each band owns its rows
/// of the buffers and draws, in the model's order, what overlaps them.
pub const BAND_ROWS: usize = 32;

/// A line in sample space; `bias` (in depth units) lets it win a near tie
/// with a surface it runs along.
#[derive(Clone, Copy)]
struct Line {
    a: Vec3,
    b: Vec3,
    color: [u16; 3],
    bias: Bias,
}

/// A part's vertices in sample space (x right, y down, z larger = nearer,
/// all three in samples)
/// and their light, seen from the front and from behind.
struct Prepared<'m> {
    indices: Cow<'m, [u32]>,
    screen: Vec<Vec3>,
    front: Vec<Vec3>,
    back: Vec<Vec3>,
    /// The material's opacity: 1 drawn opaque, less blended over what is
    /// behind (set after [`prepare`]).
    alpha: f32,
}

/// What is drawn, in order: lines under the surfaces, the surfaces
/// (part, triangle), lines over them (index into the lines).
#[derive(Clone, Copy)]
enum Item {
    Tri(u32, u32),
    Line(u32),
}

/// Everything a band draws from.
struct Scene<'m> {
    parts: Vec<Prepared<'m>>,
    lines: Vec<Line>,
    items: Vec<Item>,
}

impl Scene<'_> {
    /// A triangle's vertices, and their colours as seen from the side the
    /// camera is on (two-sided lighting: seen from behind, clockwise on the
    /// picture whose y points down, the normals are turned around).
    fn triangle(&self, part: u32, tri: u32) -> Option<([Vec3; 3], [Vec3; 3], f32)> {
        let p = self.parts.get(part as usize)?;
        let t = p.indices.get(tri as usize * 3..tri as usize * 3 + 3)?;
        let i = [t[0] as usize, t[1] as usize, t[2] as usize];
        let v = [
            *p.screen.get(i[0])?,
            *p.screen.get(i[1])?,
            *p.screen.get(i[2])?,
        ];
        let lit = if edge(v[0], v[1], v[2].x, v[2].y) <= 0.0 {
            &p.front
        } else {
            &p.back
        };
        Some((v, [lit[i[0]], lit[i[1]], lit[i[2]]], p.alpha))
    }

    /// The sample rows an item may touch (inclusive; may lie outside the
    /// picture).
    fn rows(&self, item: Item, thickness: f32) -> Option<(f32, f32)> {
        match item {
            Item::Tri(part, tri) => {
                let ([a, b, c], _, _) = self.triangle(part, tri)?;
                Some((a.y.min(b.y).min(c.y) - 1.0, a.y.max(b.y).max(c.y) + 1.0))
            }
            Item::Line(i) => {
                let l = self.lines.get(i as usize)?;
                Some((l.a.y.min(l.b.y) - thickness, l.a.y.max(l.b.y) + thickness))
            }
        }
    }
}

#[inline]
fn edge(a: Vec3, b: Vec3, px: f32, py: f32) -> f32 {
    (b.x - a.x) * (py - a.y) - (b.y - a.y) * (px - a.x)
}

#[inline]
fn quantize(c: Vec3) -> [u16; 3] {
    let q = |x: f32| (x.clamp(0.0, 1.0) * 65535.0 + 0.5) as u16;
    [q(c.x), q(c.y), q(c.z)]
}

/// The rows `y0 .. y0 + rows` of the sample buffers.
struct Band<'a> {
    y0: usize,
    rows: usize,
    width: usize,
    depth: &'a mut [f32],
    /// Linear RGB in 1/65535 units (premultiplied by `cover` where no
    /// opaque surface is: what translucent ones leave over the background).
    color: &'a mut [[u16; 3]],
    /// How much of the sample translucent surfaces cover, in 1/65535, where
    /// no opaque one does (empty when the scene has no translucent part).
    cover: &'a mut [u16],
    /// The depth and part (+1; 0 none) of the last translucent surface
    /// blended into the sample: a surface of the same part at the same
    /// depth (a disc's back face, which lies on its front face) is the
    /// same sheet and is not blended twice. Empty as `cover` is.
    last: &'a mut [(f32, u16)],
}

impl Band<'_> {
    /// Fill a triangle's samples in this band, colours interpolated across
    /// it; `alpha` below 1 blends them over what is there (drawn after
    /// every opaque item, farthest first) and leaves the depth as it is.
    fn triangle(&mut self, v: [Vec3; 3], c: [Vec3; 3], alpha: f32, part: u32) {
        let [a, mut b, mut c0] = v;
        let [ca, mut cb, mut cc] = c;
        if !(a.is_finite() && b.is_finite() && c0.is_finite()) {
            return;
        }
        let mut area = edge(a, b, c0.x, c0.y);
        if !(area.is_finite() && area.abs() > 1e-12) {
            return;
        }
        if area < 0.0 {
            std::mem::swap(&mut b, &mut c0);
            std::mem::swap(&mut cb, &mut cc);
            area = -area;
        }
        let inv = 1.0 / area;
        let w = self.width as f32;
        let (top, bottom) = (self.y0 as f32, (self.y0 + self.rows) as f32);
        let min_x = a.x.min(b.x).min(c0.x);
        let max_x = a.x.max(b.x).max(c0.x);
        let min_y = a.y.min(b.y).min(c0.y);
        let max_y = a.y.max(b.y).max(c0.y);
        if max_x < 0.0 || max_y < top || min_x >= w || min_y >= bottom {
            return;
        }
        // Samples sit at pixel centres (i + 0.5); both bounds are >= 0
        // here, so `as` rounds down.
        let x0 = (min_x - 0.5).max(0.0) as usize;
        let x1 = ((max_x - 0.5).max(0.0) as usize).min(self.width - 1);
        let y0 = ((min_y - 0.5).max(top)) as usize;
        let y1 = ((max_y - 0.5).max(0.0) as usize).min(self.y0 + self.rows - 1);
        if x1 < x0 || y1 < y0 {
            return;
        }
        // Each edge function is linear in x along a row: the samples inside
        // all three form one span, found per row, so a long thin triangle
        // (a tube's side seen at an angle) costs its samples, not its
        // bounding box.
        let edges = [(b, c0), (c0, a), (a, b)];
        // Along a row each edge function and the depth change by a constant
        // per sample: stepped, not recomputed.
        let dw = [-(c0.y - b.y), -(a.y - c0.y), -(b.y - a.y)];
        let dz = (dw[0] * a.z + dw[1] * b.z + dw[2] * c0.z) * inv;
        for y in y0..=y1 {
            let py = y as f32 + 0.5;
            let (mut lo, mut hi) = (x0 as f32 + 0.5, x1 as f32 + 0.5);
            for (p, q) in edges {
                // w(px) = k * px + m
                let k = -(q.y - p.y);
                let m = (q.x - p.x) * (py - p.y) + (q.y - p.y) * p.x;
                if k > 0.0 {
                    lo = lo.max(-m / k);
                } else if k < 0.0 {
                    hi = hi.min(-m / k);
                } else if m < 0.0 {
                    hi = f32::NEG_INFINITY;
                }
            }
            if lo.partial_cmp(&hi).is_none_or(|o| o.is_gt()) {
                continue;
            }
            // One sample of slack either side for rounding; the edge test
            // below decides. (Both are >= 0, so `as` rounds down.)
            let xs = (lo - 1.5).max(x0 as f32) as usize;
            let xe = (hi + 0.5).min(x1 as f32) as usize;
            let px = xs as f32 + 0.5;
            let mut w0 = edge(b, c0, px, py);
            let mut w1 = edge(c0, a, px, py);
            let mut w2 = edge(a, b, px, py);
            let mut z = (w0 * a.z + w1 * b.z + w2 * c0.z) * inv;
            let row = (y - self.y0) * self.width;
            if alpha < 1.0 {
                // A sample on the edge two triangles share can fall just
                // outside both by rounding: harmless when opaque (what is
                // behind shows at one sample), a missing layer when not.
                // Translucent triangles take a sliver more (a 1e-4 of
                // their size); the same sheet is blended once (`blend`).
                let slack = -1e-4 * area;
                for k in row + xs..=row + xe {
                    if w0 >= slack && w1 >= slack && w2 >= slack && z > self.depth[k] {
                        let (l0, l1, l2) = (w0 * inv, w1 * inv, w2 * inv);
                        self.blend(k, ca * l0 + cb * l1 + cc * l2, alpha, (z, part));
                    }
                    w0 += dw[0];
                    w1 += dw[1];
                    w2 += dw[2];
                    z += dz;
                }
                continue;
            }
            for (depth, color) in self.depth[row + xs..=row + xe]
                .iter_mut()
                .zip(&mut self.color[row + xs..=row + xe])
            {
                if w0 >= 0.0 && w1 >= 0.0 && w2 >= 0.0 && z > *depth {
                    *depth = z;
                    let (l0, l1, l2) = (w0 * inv, w1 * inv, w2 * inv);
                    *color = quantize(ca * l0 + cb * l1 + cc * l2);
                }
                w0 += dw[0];
                w1 += dw[1];
                w2 += dw[2];
                z += dz;
            }
        }
    }

    /// Sample `k` seen through a translucent surface of colour `src` and
    /// opacity `alpha` (`src` over what is there; over the background,
    /// the colour stays premultiplied by the coverage it adds to).
    #[inline]
    fn blend(&mut self, k: usize, src: Vec3, alpha: f32, (z, part): (f32, u32)) {
        // Part + 1 (0: none); parts past u16 are not told apart.
        let tag = u16::try_from(part.saturating_add(1)).unwrap_or(u16::MAX);
        if let Some(last) = self.last.get_mut(k) {
            let same_sheet = last.1 == tag && (z - last.0).abs() <= 1e-5 * z.abs().max(1.0);
            if same_sheet {
                return;
            }
            *last = (z, tag);
        }
        let old = self.color[k].map(|c| f32::from(c) / 65535.0);
        let old = Vec3::from_array(old);
        self.color[k] = quantize(src * alpha + old * (1.0 - alpha));
        if let Some(c) = self.cover.get_mut(k) {
            let old = f32::from(*c) / 65535.0;
            *c = ((alpha + old * (1.0 - alpha)).clamp(0.0, 1.0) * 65535.0 + 0.5) as u16;
        }
    }

    /// A line's samples in this band, `thickness` samples wide across its
    /// major axis, depth-tested.
    fn line(&mut self, l: &Line, thickness: usize) {
        let (a, b) = (l.a, l.b);
        let d = b - a;
        let steps = d.x.abs().max(d.y.abs()).ceil().max(1.0);
        if !steps.is_finite() || steps > 1e7 {
            return;
        }
        let n = steps as usize;
        let half = thickness as f32 * 0.5;
        // The steps whose samples can fall in this band.
        let (top, bottom) = (
            self.y0 as f32 - half - 1.0,
            (self.y0 + self.rows) as f32 + half + 1.0,
        );
        // The part of the line (0..1 along it) within [lo, hi] on one axis.
        let within = |start: f32, delta: f32, lo: f32, hi: f32| -> Option<(f32, f32)> {
            if delta == 0.0 {
                (start >= lo && start <= hi).then_some((0.0, 1.0))
            } else {
                let t0 = (lo - start) / delta;
                let t1 = (hi - start) / delta;
                Some((t0.min(t1), t0.max(t1)))
            }
        };
        // Rows of this band, columns of the picture: a line running far
        // outside the picture (a perspective camera's reaches the guard
        // band, a picture size beyond it) costs only the steps that can
        // land in it.
        let (Some((ty0, ty1)), Some((tx0, tx1))) = (
            within(a.y, d.y, top, bottom),
            within(a.x, d.x, -half - 1.0, self.width as f32 + half + 1.0),
        ) else {
            return;
        };
        let (t0, t1) = (ty0.max(tx0).max(0.0), ty1.min(tx1).min(1.0));
        if t0.partial_cmp(&t1).is_none_or(|o| o.is_gt()) {
            return;
        }
        let (k0, k1) = (
            ((t0 * steps).floor().max(0.0) as usize).min(n),
            ((t1 * steps).ceil().max(0.0) as usize).min(n),
        );
        let along_x = d.x.abs() >= d.y.abs();
        // Depth per sample along the major axis (0 for a line seen end on).
        let d_major = if along_x { d.x } else { d.y };
        let slope = if d_major == 0.0 { 0.0 } else { d.z / d_major };
        for k in k0..=k1 {
            let t = k as f32 / steps;
            let p = a + d * t;
            let (major, minor) = if along_x { (p.x, p.y) } else { (p.y, p.x) };
            if major < 0.0 {
                continue;
            }
            let m = major as usize;
            // The depth at the sample's centre along the major axis.
            let z = p.z + slope * (m as f32 + 0.5 - major);
            let bias = match l.bias {
                Bias::Flat(b) => b,
                Bias::Perspective(scale) => scale * (z + 1.0) * (z + 1.0),
            };
            let lo = (minor - half + 0.5).floor();
            for j in 0..thickness {
                let o = lo + j as f32;
                if o < 0.0 {
                    continue;
                }
                let o = o as usize;
                let (x, y) = if along_x { (m, o) } else { (o, m) };
                if x >= self.width || y < self.y0 || y >= self.y0 + self.rows {
                    continue;
                }
                let i = (y - self.y0) * self.width + x;
                if z + bias > self.depth[i] {
                    self.depth[i] = z;
                    self.color[i] = l.color;
                }
            }
        }
    }
}

/// A band's rows of [`Band::cover`] and [`Band::last`].
type TranslucentRows<'a> = (&'a mut [u16], &'a mut [(f32, u16)]);

/// The sample buffers, drawn band by band in parallel.
struct Target {
    width: usize,
    height: usize,
    depth: Vec<f32>,
    /// Linear RGB in 1/65535 units.
    color: Vec<[u16; 3]>,
    /// [`Band::cover`]: empty until a translucent part is drawn.
    cover: Vec<u16>,
    /// [`Band::last`]: as `cover`.
    last: Vec<(f32, u16)>,
}

impl Target {
    fn new(width: usize, height: usize) -> Target {
        Target {
            width,
            height,
            depth: vec![f32::NEG_INFINITY; width * height],
            color: vec![[0; 3]; width * height],
            cover: Vec::new(),
            last: Vec::new(),
        }
    }

    /// Draw the scene's items in order. Each band draws the items that
    /// overlap it, in the same order, into rows no other band touches: the
    /// result is the same for any number of threads.
    fn draw(&mut self, scene: &Scene<'_>, thickness: usize) {
        let bands = self.height.div_ceil(BAND_ROWS);
        let mut bins: Vec<Vec<u32>> = vec![Vec::new(); bands];
        let last = bands as f32 - 1.0;
        for (i, &item) in scene.items.iter().enumerate() {
            let Some((lo, hi)) = scene.rows(item, thickness as f32) else {
                continue;
            };
            if !(lo.is_finite() && hi.is_finite()) || hi < 0.0 || lo > self.height as f32 {
                continue;
            }
            let b0 = (lo.max(0.0) / BAND_ROWS as f32).min(last) as usize;
            let b1 = (hi.max(0.0) / BAND_ROWS as f32).min(last) as usize;
            for bin in &mut bins[b0..=b1] {
                bin.push(i as u32);
            }
        }
        let width = self.width;
        let height = self.height;
        if scene.parts.iter().any(|p| p.alpha < 1.0) {
            self.cover = vec![0; width * height];
            self.last = vec![(0.0, 0); width * height];
        }
        // Without translucent parts each band gets empty slices.
        let translucent: Vec<TranslucentRows<'_>> = if self.cover.is_empty() {
            (0..bands).map(|_| Default::default()).collect()
        } else {
            self.cover
                .chunks_mut(BAND_ROWS * width)
                .zip(self.last.chunks_mut(BAND_ROWS * width))
                .collect()
        };
        self.depth
            .par_chunks_mut(BAND_ROWS * width)
            .zip(self.color.par_chunks_mut(BAND_ROWS * width))
            .zip(translucent)
            .zip(bins.par_iter())
            .enumerate()
            .for_each(|(k, (((depth, color), (cover, last)), bin))| {
                let y0 = k * BAND_ROWS;
                let mut band = Band {
                    y0,
                    rows: BAND_ROWS.min(height - y0),
                    width,
                    depth,
                    color,
                    cover,
                    last,
                };
                for &i in bin {
                    match scene.items[i as usize] {
                        Item::Tri(part, tri) => {
                            if let Some((v, c, alpha)) = scene.triangle(part, tri) {
                                band.triangle(v, c, alpha, part);
                            }
                        }
                        Item::Line(l) => {
                            if let Some(l) = scene.lines.get(l as usize) {
                                band.line(l, thickness);
                            }
                        }
                    }
                }
            });
    }
}

pub(crate) fn srgb(linear: f32) -> u8 {
    let x = linear.clamp(0.0, 1.0);
    let s = if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5) as u8
}

/// [`srgb`] of every linear value in 1/65535 units (the buffers' unit).
fn srgb_table() -> Vec<u8> {
    (0..=u16::MAX)
        .map(|i| srgb(f32::from(i) / 65535.0))
        .collect()
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

/// How model points reach sample space: `cam` takes a point to camera
/// space (x right, y up, in samples from the picture's centre for the
/// orthographic view; the perspective one keeps world units with z the
/// distance in front of the eye), `screen` to samples (x right, y down,
/// z larger = nearer).
#[derive(Clone, Copy)]
enum Projection {
    Ortho {
        cam: Camera,
        centre: DVec3,
        scale: f64,
        half_w: f64,
        half_h: f64,
        /// A bare bone's depth bias, in samples.
        bias: f32,
    },
    Persp {
        cam: Camera,
        eye: DVec3,
        /// Samples per unit of `x / z` (the focal length in samples).
        focal: f64,
        near: f64,
        half_w: f64,
        half_h: f64,
        /// The guard band's half width and half height, in samples from
        /// the picture's centre: what reaches the rasterizer lies within
        /// it (see [`Projection::side`]).
        guard_w: f64,
        guard_h: f64,
        /// The distance of the framed model's far end (at least `near`):
        /// depth is `reference / z - 1`, so it is 0 there and the model's
        /// depths keep f32's precision however far the camera stands
        /// (`1 / z` alone loses them: a model 1e7 away spans 1e-8 of it).
        /// It overflows f32 only for geometry within 1e-38 `reference`
        /// of the eye (a target 1e35 times nearer than the model's far
        /// end), which is then not drawn.
        reference: f64,
        /// A bare bone's bias: `bias (depth + 1)²` in depth units is 1e-4
        /// of the model's size in z, wherever along the line
        /// ([`Bias::Perspective`]).
        bias: f32,
    },
}

/// A line's depth bias (see [`Line`]).
#[derive(Clone, Copy)]
enum Bias {
    /// The same along the line (orthographic: depth is linear in z, in
    /// samples). The line's depth is taken at the sample's centre along
    /// it, as [`Bias::Perspective`]'s: at a grazing angle (a floor seen
    /// from a few degrees above) the half sample between a step and the
    /// centre changes depth by more than the bias, and a bone lying on
    /// the surface was hidden.
    Flat(f32),
    /// `scale (depth + 1)²` at each of its samples (perspective: a step in z
    /// moves depth `reference / z²`, `(depth + 1)² / reference`), so a
    /// line running from the near plane to the horizon ties with the
    /// surface it lies on all along, and shows through nothing in front
    /// of it. The line's depth is taken at the sample's centre along it,
    /// as a surface's is: a line receding at a grazing angle (a bone on
    /// the floor the camera stands on) changes depth by far more than the
    /// bias within the half sample between its step and the centre.
    Perspective(f32),
}

/// The planes a perspective camera clips at: the near plane, then the four
/// sides of the guard band (see [`Projection::side`]).
const PLANES: usize = 5;

impl Projection {
    fn camera(&self) -> &Camera {
        match self {
            Projection::Ortho { cam, .. } | Projection::Persp { cam, .. } => cam,
        }
    }

    #[inline]
    fn cam(&self, p: Vec3) -> DVec3 {
        match *self {
            Projection::Ortho {
                cam, centre, scale, ..
            } => {
                let q = cam.project(p);
                DVec3::new(
                    (q.x - centre.x) * scale,
                    (q.y - centre.y) * scale,
                    (q.z - centre.z) * scale,
                )
            }
            Projection::Persp { cam, eye, .. } => {
                let q = cam.project_d(p.as_dvec3() - eye);
                DVec3::new(q.x, q.y, -q.z)
            }
        }
    }

    /// How many planes geometry is clipped at (none, orthographic: the fit
    /// keeps the model in the picture).
    fn planes(&self) -> usize {
        match self {
            Projection::Ortho { .. } => 0,
            Projection::Persp { .. } => PLANES,
        }
    }

    /// Where a camera-space point is against clip plane `plane`: >= 0 on
    /// the kept side. Plane 0 is the near plane; 1 to 4 bound the picture
    /// plus a guard band a picture size wide on each side. They are planes
    /// through the eye (`|focal x / z| <= guard_w` times `z > 0`), so
    /// clipping at them needs no division: a point at the near plane,
    /// whose projection can reach beyond f32's range (a tiny field of
    /// view, a near plane close to the eye), is cut back to a few picture
    /// widths first, and the rasterizer's f32 edge functions keep their
    /// precision (floors with holes, lines dropped as too long).
    #[inline]
    fn side(&self, plane: usize, c: DVec3) -> f64 {
        match *self {
            Projection::Ortho { .. } => 1.0,
            Projection::Persp {
                focal,
                near,
                guard_w,
                guard_h,
                ..
            } => match plane {
                0 => c.z - near,
                1 => guard_w * c.z + focal * c.x,
                2 => guard_w * c.z - focal * c.x,
                3 => guard_h * c.z + focal * c.y,
                _ => guard_h * c.z - focal * c.y,
            },
        }
    }

    /// The clip planes `c` is outside of, one bit each (a non-finite point
    /// is outside all).
    fn outside(&self, c: DVec3) -> u8 {
        (0..self.planes())
            .filter(|&k| self.side(k, c).partial_cmp(&0.0).is_none_or(|o| o.is_lt()))
            .fold(0, |m, k| m | 1 << k)
    }

    /// The point where the segment from `a` (inside `plane`) to `b` (not)
    /// crosses it, and how far along it is on the picture (what the
    /// colours are interpolated by: the rasterizer interpolates them
    /// linearly on the picture, so a vertex cut at the guard band leaves
    /// the colours inside unchanged). At the near plane, whose other end
    /// has no place on the picture, that is how far along it is in space.
    fn clip(&self, plane: usize, a: DVec3, b: DVec3) -> (DVec3, f32) {
        let (fa, fb) = (self.side(plane, a), self.side(plane, b));
        // fa >= 0 > fb: the denominator is not 0. Measured from the end
        // inside, so a far end (1e30 behind the eye) costs no precision.
        let t = (fa / (fa - fb)).clamp(0.0, 1.0);
        let mut p = a + (b - a) * t;
        let Projection::Persp {
            focal,
            near,
            guard_w,
            guard_h,
            ..
        } = *self
        else {
            return (p, t as f32);
        };
        // Put on the plane: the rounding of a point between far-off ends
        // then moves it along the plane, outside the picture, not across.
        match plane {
            0 => {
                p.z = near;
                return (p, t as f32);
            }
            1 => p.x = -guard_w * p.z / focal,
            2 => p.x = guard_w * p.z / focal,
            3 => p.y = -guard_h * p.z / focal,
            _ => p.y = guard_h * p.z / focal,
        }
        // Both ends in front of the eye: a point t along in space is
        // t z_b / z_p along on the picture.
        (p, (t * b.z / p.z).clamp(0.0, 1.0) as f32)
    }

    #[inline]
    fn screen(&self, c: DVec3) -> Vec3 {
        match *self {
            Projection::Ortho { half_w, half_h, .. } => {
                Vec3::new((half_w + c.x) as f32, (half_h - c.y) as f32, c.z as f32)
            }
            Projection::Persp {
                focal,
                half_w,
                half_h,
                reference,
                ..
            } => {
                let k = focal / c.z;
                Vec3::new(
                    (half_w + c.x * k) as f32,
                    (half_h - c.y * k) as f32,
                    // reference / z - 1, linear on the picture as 1 / z is
                    // (the difference taken in f64, before rounding).
                    ((reference - c.z) / c.z) as f32,
                )
            }
        }
    }

    /// The depth bias of a bare bone: a surface 1e-4 of the model's size
    /// behind it does not hide it.
    fn bias(&self) -> Bias {
        match *self {
            Projection::Ortho { bias, .. } => Bias::Flat(bias),
            Projection::Persp { bias, .. } => Bias::Perspective(bias),
        }
    }
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

/// Average each pixel's samples (in linear light) and encode as sRGB.
fn resolve(target: &Target, width: usize, height: usize, s: usize, transparent: bool) -> Image {
    let table = srgb_table();
    let encode = |c: u32| table[c.min(65535) as usize];
    let mut rgba = Vec::with_capacity(width * height * 4);
    let n = (s * s) as u32;
    for y in 0..height {
        let t = if height > 1 {
            y as f32 / (height - 1) as f32
        } else {
            0.0
        };
        let bg =
            quantize(Vec3::from_array(BACKGROUND_TOP).lerp(Vec3::from_array(BACKGROUND_BOTTOM), t))
                .map(u32::from);
        for x in 0..width {
            let mut sum = [0u32; 3];
            let mut covered = 0u32;
            // Samples only translucent surfaces cover: their premultiplied
            // colour and their coverage (1/65535), summed.
            let mut part = [0u64; 3];
            let mut part_cover = 0u64;
            let mut part_samples = 0u32;
            for sy in 0..s {
                let row = (y * s + sy) * target.width + x * s;
                for i in row..row + s {
                    let c = target.color[i];
                    if target.depth[i] > f32::NEG_INFINITY {
                        sum[0] += u32::from(c[0]);
                        sum[1] += u32::from(c[1]);
                        sum[2] += u32::from(c[2]);
                        covered += 1;
                    } else if let Some(&k) = target.cover.get(i)
                        && k > 0
                    {
                        for (p, c) in part.iter_mut().zip(c) {
                            *p += u64::from(c);
                        }
                        part_cover += u64::from(k);
                        part_samples += 1;
                    }
                }
            }
            // Rounded averages, in the buffers' 1/65535 units.
            let px = if part_samples > 0 {
                resolve_translucent(
                    (sum, covered),
                    (part, part_cover, part_samples),
                    n,
                    bg,
                    transparent,
                )
                .map(|(rgb, a)| [encode(rgb[0]), encode(rgb[1]), encode(rgb[2]), a])
                .unwrap_or([0; 4])
            } else if transparent {
                if covered == 0 {
                    [0, 0, 0, 0]
                } else {
                    let avg = |v: u32| encode((v + covered / 2) / covered);
                    let a = ((covered * 255 + n / 2) / n) as u8;
                    [avg(sum[0]), avg(sum[1]), avg(sum[2]), a]
                }
            } else {
                let rest = n - covered;
                let avg = |v: u32, b: u32| encode((v + b * rest + n / 2) / n);
                [
                    avg(sum[0], bg[0]),
                    avg(sum[1], bg[1]),
                    avg(sum[2], bg[2]),
                    255,
                ]
            };
            rgba.extend_from_slice(&px);
        }
    }
    Image {
        width: width as u32,
        height: height as u32,
        rgba,
        transparent,
    }
}

/// A pixel some of whose samples only translucent surfaces cover: its
/// linear colour (1/65535 units) and alpha, from the opaque samples'
/// colour sum and count, the translucent ones' premultiplied colour sum,
/// coverage sum (1/65535 each) and count, out of `n` samples. Over the
/// background `bg`, or with `transparent` unpremultiplied with the alpha
/// the coverage gives (`None`: nothing covers the pixel).
fn resolve_translucent(
    (sum, covered): ([u32; 3], u32),
    (part, part_cover, part_samples): ([u64; 3], u64, u32),
    n: u32,
    bg: [u32; 3],
    transparent: bool,
) -> Option<([u32; 3], u8)> {
    const ONE: u64 = 65535;
    let n = u64::from(n);
    // Premultiplied colour and coverage over all samples, in 1/65535².
    let colour = |k: usize| u64::from(sum[k]) * ONE + part[k] * ONE;
    let cover = u64::from(covered) * ONE + part_cover;
    if transparent {
        if cover == 0 {
            return None;
        }
        let avg = |k: usize| ((colour(k) + cover / 2) / cover) as u32;
        let a = ((cover * 255 + n * ONE / 2) / (n * ONE)) as u8;
        Some(([avg(0), avg(1), avg(2)], a))
    } else {
        // The background shows through what the samples leave uncovered.
        let empty = n - u64::from(covered) - u64::from(part_samples);
        let through = empty * ONE + (u64::from(part_samples) * ONE - part_cover);
        let avg =
            |k: usize| ((colour(k) + u64::from(bg[k]) * through + n * ONE / 2) / (n * ONE)) as u32;
        Some(([avg(0), avg(1), avg(2)], 255))
    }
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

//! The camera of a picture: the orthographic and perspective frames,
//! the automatic angles and the orbit camera, the warning for a camera
//! that sees nothing, and the projection of model points into sample
//! space with its clipping planes (see the parent module).

use super::*;

/// The camera's frame: `right` and `up` span the picture, `toward` points
/// from the model to the camera. In f64: the fit projects the model's
/// points with it, and a model far from the origin (or one with
/// coordinates near f32's limits) keeps its detail and its extent.
#[derive(Clone, Copy, Debug)]
pub(super) struct Camera {
    pub(super) right: DVec3,
    pub(super) up: DVec3,
    pub(super) toward: DVec3,
}

impl Camera {
    pub(super) fn new(azimuth_deg: f32, elevation_deg: f32) -> Camera {
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
    pub(super) fn looking(eye: DVec3, target: DVec3) -> Camera {
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
    pub(super) fn angles(&self) -> (f32, f32) {
        let t = self.toward;
        let azimuth = t.x.atan2(t.z).to_degrees();
        let elevation = t.y.clamp(-1.0, 1.0).asin().to_degrees();
        (azimuth as f32, elevation as f32)
    }

    #[inline]
    pub(super) fn project(&self, p: Vec3) -> DVec3 {
        self.project_d(p.as_dvec3())
    }

    #[inline]
    pub(super) fn project_d(&self, p: DVec3) -> DVec3 {
        DVec3::new(p.dot(self.right), p.dot(self.up), p.dot(self.toward))
    }
}

/// The length of `v`, without squaring its components first (which
/// underflows to 0 for 1e-300, overflows for 1e160): a camera's eye and
/// target may be any two different finite points.
pub(super) fn length(v: DVec3) -> f64 {
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
pub(super) fn short(x: f64) -> String {
    if x.abs() >= 1e6 || (x != 0.0 && x.abs() < 1e-3) {
        format!("{x:.2e}")
    } else {
        format!("{x:.3}")
    }
}

/// A [`View::Camera`] set up for a picture.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Perspective {
    pub(super) eye: DVec3,
    pub(super) target: DVec3,
    pub(super) fov: f32,
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

/// How model points reach sample space: `cam` takes a point to camera
/// space (x right, y up, in samples from the picture's centre for the
/// orthographic view; the perspective one keeps world units with z the
/// distance in front of the eye), `screen` to samples (x right, y down,
/// z larger = nearer).
#[derive(Clone, Copy)]
pub(super) enum Projection {
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
pub(super) enum Bias {
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
pub(super) const PLANES: usize = 5;

impl Projection {
    pub(super) fn camera(&self) -> &Camera {
        match self {
            Projection::Ortho { cam, .. } | Projection::Persp { cam, .. } => cam,
        }
    }

    #[inline]
    pub(super) fn cam(&self, p: Vec3) -> DVec3 {
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
    pub(super) fn planes(&self) -> usize {
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
    pub(super) fn side(&self, plane: usize, c: DVec3) -> f64 {
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
    pub(super) fn outside(&self, c: DVec3) -> u8 {
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
    pub(super) fn clip(&self, plane: usize, a: DVec3, b: DVec3) -> (DVec3, f32) {
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
    pub(super) fn screen(&self, c: DVec3) -> Vec3 {
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
    pub(super) fn bias(&self) -> Bias {
        match *self {
            Projection::Ortho { bias, .. } => Bias::Flat(bias),
            Projection::Persp { bias, .. } => Bias::Perspective(bias),
        }
    }
}

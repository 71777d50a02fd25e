//! Scopes: the oriented boxes shapes live in.
//!
//! A scope is an origin, three orthonormal axes (a rotation, kept as a
//! unit quaternion) and a size along each axis; the shape's geometry is
//! given in scope-local coordinates, `[0, size.x] x [0, size.y] x [0,
//! size.z]`. The world is z-up: a lot's footprint lies in the world xy
//! plane and a mass is extruded along z (docs/shapes.md, "Frames").

use crate::ir::Axis;
use glam::{Mat3, Quat, Vec3};

/// An oriented box: `origin + rotation * local` is the world point of a
/// scope-local point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scope {
    /// The world position of the scope's local origin (a corner).
    pub origin: Vec3,
    /// The scope's orientation as a unit quaternion's `x, y, z, w` (kept
    /// as plain floats so a scope packs into 40 bytes; read it with
    /// [`Scope::rotation`]).
    rot: [f32; 4],
    /// The extent along each axis (never negative).
    pub size: Vec3,
}

fn unit(axis: Axis) -> Vec3 {
    match axis {
        Axis::X => Vec3::X,
        Axis::Y => Vec3::Y,
        Axis::Z => Vec3::Z,
    }
}

impl Scope {
    /// A world-aligned scope.
    pub fn new(origin: Vec3, size: Vec3) -> Self {
        Scope {
            origin,
            rot: Quat::IDENTITY.to_array(),
            size,
        }
    }

    /// A scope turned by `rotation` (normalized here).
    pub fn with_rotation(origin: Vec3, rotation: Quat, size: Vec3) -> Self {
        Scope {
            origin,
            rot: rotation.normalize().to_array(),
            size,
        }
    }

    /// The scope's orientation: its x, y and z axes are the world's turned
    /// by this unit quaternion.
    #[inline]
    pub fn rotation(&self) -> Quat {
        Quat::from_array(self.rot)
    }

    /// A scope whose x, y and z axes are the columns of `axes`
    /// (orthonormal, right-handed).
    pub fn with_axes(origin: Vec3, axes: Mat3, size: Vec3) -> Self {
        Scope::with_rotation(origin, Quat::from_mat3(&axes), size)
    }

    /// The scope's axes in world coordinates, as a matrix's columns.
    pub fn axes(&self) -> Mat3 {
        Mat3::from_quat(self.rotation())
    }

    /// The world direction of `axis`.
    #[inline]
    pub fn axis(&self, axis: Axis) -> Vec3 {
        self.rotation() * unit(axis)
    }

    /// The world point of a scope-local point.
    #[inline]
    pub fn world(&self, local: Vec3) -> Vec3 {
        self.origin + self.rotation() * local
    }

    /// The scope's centre in world coordinates.
    pub fn center(&self) -> Vec3 {
        self.world(self.size * 0.5)
    }

    /// The slab `[start, start + len)` along `axis`: the scope of one
    /// split part.
    #[inline]
    pub fn slab(&self, axis: Axis, start: f32, len: f32) -> Scope {
        self.slab_along(self.axis(axis), axis, start, len)
    }

    /// [`Scope::slab`] with the world direction of `axis` given
    /// (`self.axis(axis)`, computed once for all of a split's parts).
    #[inline]
    pub fn slab_along(&self, dir: Vec3, axis: Axis, start: f32, len: f32) -> Scope {
        let mut s = *self;
        s.origin += dir * start;
        s.size[axis.index()] = len;
        s
    }

    /// Moved by `local` along the scope's own axes.
    pub fn translated(&self, local: Vec3) -> Scope {
        Scope {
            origin: self.world(local),
            ..*self
        }
    }

    /// Turned about its own `axis` through its origin by `degrees`
    /// (right-handed).
    pub fn rotated(&self, axis: Axis, degrees: f32) -> Scope {
        let r = Quat::from_axis_angle(unit(axis), degrees.to_radians());
        Scope {
            rot: (self.rotation() * r).normalize().to_array(),
            ..*self
        }
    }

    /// The eight corners in world coordinates.
    pub fn corners(&self) -> [Vec3; 8] {
        let s = self.size;
        let mut out = [Vec3::ZERO; 8];
        for (i, c) in out.iter_mut().enumerate() {
            let l = Vec3::new(
                if i & 1 != 0 { s.x } else { 0.0 },
                if i & 2 != 0 { s.y } else { 0.0 },
                if i & 4 != 0 { s.z } else { 0.0 },
            );
            *c = self.world(l);
        }
        out
    }
}

//! A volume-matching baseline cost, from the SOSMC paper family (Ritchie et
//! al. steer procedural models towards a target volume), for comparison
//! with the curve cost.
//!
//! The target volume is the union of tubes of radius `radius` around the
//! guiding curves, voxelized on a grid of edge `voxel_size` (a voxel is in
//! the target when its centre is within `radius` of a curve). Each bone is
//! sampled at points no further apart than half a voxel, both ends
//! included. The cost of a model is
//!
//! ```text
//! cost = outside / samples  +  uncovered / target_voxels
//! ```
//!
//! the fraction of bone samples outside the target plus the fraction of
//! target voxels that hold no sample; it lies in `[0, 2]`, 0 being a model
//! that stays inside the tubes and fills them. Both counts are sums over
//! bones or sets of voxels, so the cost is independent of bone order. It
//! ignores direction entirely, which is what the curve cost adds.

use std::fmt;

use glam::{DVec3, Vec3};

use crate::curves::Curves;

/// Most voxels a target grid may have.
pub const MAX_VOXELS: usize = 1 << 22;

/// How to voxelize the target.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VolumeOptions {
    /// Tube radius around each curve, `> 0`.
    pub radius: f64,
    /// Voxel edge, `> 0`.
    pub voxel_size: f64,
}

impl Default for VolumeOptions {
    /// Radius 0.5, voxels of 0.1.
    fn default() -> Self {
        Self {
            radius: 0.5,
            voxel_size: 0.1,
        }
    }
}

/// An invalid [`VolumeOptions`].
#[derive(Clone, Debug, PartialEq)]
pub enum VolumeError {
    /// `radius` or `voxel_size` is not a finite number `> 0`.
    BadOption {
        /// `radius` or `voxel_size`.
        field: &'static str,
        /// The value given.
        value: f64,
    },
    /// The grid would have more than [`MAX_VOXELS`] voxels.
    TooManyVoxels {
        /// Voxels the grid would have.
        count: usize,
    },
}

impl fmt::Display for VolumeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            VolumeError::BadOption { field, value } => {
                write!(
                    f,
                    "volume target: {field} {value} must be a finite number > 0"
                )
            }
            VolumeError::TooManyVoxels { count } => write!(
                f,
                "volume target: the grid would have {count} voxels, at most {MAX_VOXELS} are allowed (raise voxel_size)"
            ),
        }
    }
}

impl std::error::Error for VolumeError {}

/// The voxelized target volume.
#[derive(Clone, Debug)]
pub struct VolumeTarget {
    origin: DVec3,
    voxel: f64,
    dims: [usize; 3],
    /// Per grid voxel: its index among target voxels, or `u32::MAX`.
    index: Vec<u32>,
    targets: usize,
}

/// Per-particle state of the baseline: which target voxels hold a sample,
/// and the sample counts.
#[derive(Clone, Debug)]
pub struct VolumeState {
    covered: Vec<u64>,
    covered_count: u64,
    samples: u64,
    outside: u64,
}

/// The baseline cost of a model.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct VolumeCost {
    /// Fraction of bone samples outside the target (0 with no bones).
    pub outside_fraction: f64,
    /// Fraction of target voxels with no bone sample.
    pub uncovered_fraction: f64,
}

impl VolumeCost {
    /// `outside_fraction + uncovered_fraction`, in `[0, 2]`.
    pub fn total(&self) -> f64 {
        self.outside_fraction + self.uncovered_fraction
    }
}

impl VolumeTarget {
    /// Voxelizes the tubes around `curves`.
    pub fn from_curves(curves: &Curves, options: VolumeOptions) -> Result<Self, VolumeError> {
        let VolumeOptions { radius, voxel_size } = options;
        for (field, value) in [("radius", radius), ("voxel_size", voxel_size)] {
            if !(value.is_finite() && value > 0.0) {
                return Err(VolumeError::BadOption { field, value });
            }
        }
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for c in curves.curves() {
            let (a, b) = c.bezier.bounds();
            lo = lo.min(a);
            hi = hi.max(b);
        }
        let pad = DVec3::splat(radius + voxel_size);
        let origin = lo - pad;
        let extent = (hi + pad - origin) / voxel_size;
        let mut count = 1usize;
        let mut dims = [0usize; 3];
        for (d, e) in dims.iter_mut().zip(extent.to_array()) {
            let n = e.ceil();
            if !(n.is_finite() && n <= MAX_VOXELS as f64) {
                return Err(VolumeError::TooManyVoxels { count: usize::MAX });
            }
            *d = (n as usize).max(1);
            count = count.saturating_mul(*d);
        }
        if count > MAX_VOXELS {
            return Err(VolumeError::TooManyVoxels { count });
        }
        let boxes: Vec<_> = curves
            .curves()
            .iter()
            .map(|c| {
                let (a, b) = c.bezier.bounds();
                (c.bezier, c.bezier.bracket_samples(), a, b)
            })
            .collect();
        let mut index = vec![u32::MAX; count];
        let mut targets = 0usize;
        for z in 0..dims[2] {
            for y in 0..dims[1] {
                for x in 0..dims[0] {
                    let centre =
                        origin + (DVec3::new(x as f64, y as f64, z as f64) + 0.5) * voxel_size;
                    let inside = boxes.iter().any(|(bez, samples, a, b)| {
                        (centre.clamp(*a, *b) - centre).length() <= radius
                            && bez.closest_point_sampled(samples, centre).dist <= radius
                    });
                    if inside {
                        // count <= MAX_VOXELS < u32::MAX
                        index[(z * dims[1] + y) * dims[0] + x] = targets as u32;
                        targets += 1;
                    }
                }
            }
        }
        Ok(Self {
            origin,
            voxel: voxel_size,
            dims,
            index,
            targets,
        })
    }

    /// Number of target voxels.
    pub fn target_voxels(&self) -> usize {
        self.targets
    }

    /// Whether `p` lies in a target voxel.
    pub fn contains(&self, p: Vec3) -> bool {
        self.target_of(p.as_dvec3()).is_some()
    }

    fn target_of(&self, p: DVec3) -> Option<usize> {
        let g = (p - self.origin) / self.voxel;
        if !g.is_finite() {
            return None;
        }
        let mut cell = [0usize; 3];
        for ((c, v), d) in cell.iter_mut().zip(g.to_array()).zip(self.dims) {
            let f = v.floor();
            if f < 0.0 || f >= d as f64 {
                return None;
            }
            *c = f as usize;
        }
        let i = self.index[(cell[2] * self.dims[1] + cell[1]) * self.dims[0] + cell[0]];
        (i != u32::MAX).then_some(i as usize)
    }

    /// A state with no bones.
    pub fn new_state(&self) -> VolumeState {
        VolumeState {
            covered: vec![0; self.targets.div_ceil(64)],
            covered_count: 0,
            samples: 0,
            outside: 0,
        }
    }

    /// Adds a bone's samples to `state`. A non-finite bone counts as one
    /// sample outside the target.
    pub fn add_bone(&self, state: &mut VolumeState, base: Vec3, tip: Vec3) {
        let (b, t) = (base.as_dvec3(), tip.as_dvec3());
        if !(b.is_finite() && t.is_finite()) {
            state.samples += 1;
            state.outside += 1;
            return;
        }
        let steps = (b.distance(t) / (0.5 * self.voxel)).ceil().clamp(1.0, 1e6) as u64;
        for k in 0..=steps {
            let p = b.lerp(t, k as f64 / steps as f64);
            state.samples += 1;
            match self.target_of(p) {
                Some(i) => {
                    let (w, bit) = (i / 64, 1u64 << (i % 64));
                    if state.covered[w] & bit == 0 {
                        state.covered[w] |= bit;
                        state.covered_count += 1;
                    }
                }
                None => state.outside += 1,
            }
        }
    }

    /// The cost of the model in `state`.
    pub fn cost(&self, state: &VolumeState) -> VolumeCost {
        VolumeCost {
            outside_fraction: if state.samples == 0 {
                0.0
            } else {
                state.outside as f64 / state.samples as f64
            },
            uncovered_fraction: if self.targets == 0 {
                0.0
            } else {
                (self.targets as u64 - state.covered_count) as f64 / self.targets as f64
            },
        }
    }

    /// The cost of a whole model given as bones `(base, tip)`.
    pub fn evaluate(&self, bones: &[(Vec3, Vec3)]) -> VolumeCost {
        let mut s = self.new_state();
        for &(b, t) in bones {
            self.add_bone(&mut s, b, t);
        }
        self.cost(&s)
    }
}

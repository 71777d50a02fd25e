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

impl VolumeState {
    /// Heap bytes this state owns (its coverage bits).
    pub fn heap_bytes(&self) -> usize {
        self.covered.capacity() * std::mem::size_of::<u64>()
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// One straight curve from (0,0,0) to (0,3,0).
    fn line() -> Curves {
        Curves::from_json_str(
            "line.json",
            r#"{"version":1,"curves":[{"points":[[0,0,0],[0,1,0],[0,2,0],[0,3,0]]}]}"#,
        )
        .expect("valid")
    }

    #[test]
    fn target_is_the_tube_volume() {
        let t = VolumeTarget::from_curves(&line(), VolumeOptions::default()).expect("valid");
        // Capsule of radius 0.5 around a segment of length 3:
        // pi r^2 L + 4/3 pi r^3 = 2.3562 + 0.5236 = 2.8798, over voxels of
        // 0.001: about 2880 voxels (voxelization error a few percent).
        let n = t.target_voxels() as f64;
        assert!((n - 2880.0).abs() < 0.05 * 2880.0, "{n}");
        assert!(t.contains(Vec3::new(0., 1.5, 0.)));
        assert!(t.contains(Vec3::new(0.3, 1.5, -0.3)));
        assert!(!t.contains(Vec3::new(0.6, 1.5, 0.)));
        assert!(!t.contains(Vec3::new(0., 3.7, 0.)));
        assert!(!t.contains(Vec3::new(50., 0., 0.)));
        assert!(!t.contains(Vec3::NAN));
    }

    #[test]
    fn cost_fractions() {
        let t = VolumeTarget::from_curves(&line(), VolumeOptions::default()).expect("valid");
        // No bones: nothing outside, nothing covered: 0 + 1.
        let empty = t.evaluate(&[]);
        assert_eq!(empty.outside_fraction, 0.0);
        assert_eq!(empty.uncovered_fraction, 1.0);
        assert_eq!(empty.total(), 1.0);
        // A bone far away: all samples outside, nothing covered: 1 + 1.
        let far = t.evaluate(&[(Vec3::new(5., 0., 0.), Vec3::new(5., 1., 0.))]);
        assert_eq!(far.outside_fraction, 1.0);
        assert_eq!(far.total(), 2.0);
        // A bone along the axis: all inside; it covers one column of voxels,
        // 3 / 0.1 = 30 of ~2880, plus one or two where its ends sit on voxel
        // boundaries (the grid starts at y = -0.6).
        let axis = t.evaluate(&[(Vec3::new(0.01, 0., 0.01), Vec3::new(0.01, 3., 0.01))]);
        assert_eq!(axis.outside_fraction, 0.0);
        let covered = (1.0 - axis.uncovered_fraction) * t.target_voxels() as f64;
        assert!((30.0..=32.5).contains(&covered), "{covered}");
        // Half in, half out: from (0,2,0) to (0,5,0): inside up to y = 3.5.
        // Samples every 0.05: 61 samples, those with y < 3.5 (or on the
        // boundary voxel) inside: about half.
        let half = t.evaluate(&[(Vec3::new(0.01, 2., 0.01), Vec3::new(0.01, 5., 0.01))]);
        assert!((half.outside_fraction - 0.5).abs() < 0.05, "{half:?}");
        // A non-finite bone is one sample outside.
        let nan = t.evaluate(&[(Vec3::NAN, Vec3::ZERO)]);
        assert_eq!(nan.outside_fraction, 1.0);
    }

    #[test]
    fn filling_the_tube_drives_the_cost_to_zero() {
        let t = VolumeTarget::from_curves(&line(), VolumeOptions::default()).expect("valid");
        let mut s = t.new_state();
        // Vertical bones on a 0.05 grid inside radius 0.4: every sample's
        // voxel centre is within 0.4 + 0.05 sqrt 2 < 0.5 of the axis.
        let mut k = 0;
        for i in -9..=9 {
            for j in -9..=9 {
                let (x, z) = (i as f32 * 0.05, j as f32 * 0.05);
                if x * x + z * z < 0.4 * 0.4 {
                    t.add_bone(&mut s, Vec3::new(x, 0.0, z), Vec3::new(x, 3.0, z));
                    k += 1;
                }
            }
        }
        assert!(k > 150);
        let c = t.cost(&s);
        assert_eq!(c.outside_fraction, 0.0);
        // The caps and the outer shell (0.4 < r < 0.5) stay uncovered:
        // under half.
        assert!(c.uncovered_fraction < 0.5, "{c:?}");
        let cloned = s.clone();
        t.add_bone(&mut s, Vec3::new(9., 9., 9.), Vec3::new(9., 9., 9.));
        assert_eq!(t.cost(&cloned), c);
        assert!(t.cost(&s).outside_fraction > 0.0);
    }

    #[test]
    fn bad_options_are_errors() {
        let c = line();
        let e = VolumeTarget::from_curves(
            &c,
            VolumeOptions {
                radius: 0.0,
                voxel_size: 0.1,
            },
        )
        .unwrap_err();
        assert_eq!(
            e.to_string(),
            "volume target: radius 0 must be a finite number > 0"
        );
        let e = VolumeTarget::from_curves(
            &c,
            VolumeOptions {
                radius: 0.5,
                voxel_size: 1e-4,
            },
        )
        .unwrap_err();
        assert!(matches!(e, VolumeError::TooManyVoxels { .. }), "{e}");
        assert!(e.to_string().contains("at most 4194304"));
    }
}

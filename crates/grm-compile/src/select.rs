//! Choosing one alternative of a matched production group by weight.
//!
//! Shared by the CPU derivation engine (`grm-derive`) and the sampler
//! (`grm-sample`), so both pick the same alternative from the same draw with
//! the same float operations in the same order. The GPU kernels implement
//! the same rule and are tested against the CPU engine.

use crate::CompiledSystem;
use crate::rng::DrawCtx;
use crate::table::{GROUP_CONST_WEIGHTS, GroupHeader, NONE};
use crate::vm::{Vm, VmError};

/// Why no alternative could be chosen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AltError {
    /// A weight expression faulted in the VM.
    Fault(VmError),
    /// A weight evaluated to a non-finite or non-positive value. `alt` is the
    /// global alternative index (into [`CompiledSystem::alts`] and
    /// [`CompiledSystem::weight_spans`]).
    BadWeight { value: f32, alt: u32 },
}

impl From<VmError> for AltError {
    fn from(e: VmError) -> Self {
        AltError::Fault(e)
    }
}

/// Choose an alternative of group `g` given the uniform draw `u` in `[0, 1)`;
/// returns its global alternative index.
///
/// Constant weights use the precomputed cumulative weights
/// ([`crate::table::AltHeader::cum_weight`]) against `u * total_weight`.
/// Otherwise each weight is evaluated in order (bytecode with `bind` and
/// `draws`, or the constant), rejected unless finite and positive, summed
/// into `scratch` as cumulative weights, and the first alternative whose
/// cumulative weight exceeds `u * total` is chosen (the last one if none
/// does, against rounding).
pub fn choose_alternative(
    sys: &CompiledSystem,
    g: &GroupHeader,
    vm: &mut Vm,
    bind: &[f32],
    draws: &DrawCtx,
    u: f32,
    scratch: &mut Vec<f32>,
) -> Result<u32, AltError> {
    if g.alt_count == 1 {
        return Ok(g.first_alt);
    }
    let alts = sys
        .alts
        .get(g.first_alt as usize..g.first_alt as usize + g.alt_count as usize)
        .unwrap_or(&[]);
    let last = alts.len().saturating_sub(1);
    if g.flags & GROUP_CONST_WEIGHTS != 0 {
        let target = u * g.total_weight;
        let k = alts
            .iter()
            .position(|a| target < a.cum_weight)
            .unwrap_or(last);
        return Ok(g.first_alt + k as u32);
    }
    // The weights, then their sum (in order, as the GPU sums them).
    scratch.clear();
    let mut total = 0.0f32;
    for (k, a) in alts.iter().enumerate() {
        let wgt = if a.weight_code == NONE {
            a.weight
        } else {
            vm.run1(&sys.code, &sys.consts, a.weight_code, bind, draws)?
        };
        if !(wgt.is_finite() && wgt > 0.0) {
            return Err(AltError::BadWeight {
                value: wgt,
                alt: g.first_alt + k as u32,
            });
        }
        total += wgt;
        scratch.push(wgt);
    }
    // Past the f32 range: every weight scaled by an exact power of two
    // (multiplying by 1 otherwise changes nothing).
    let scale = if total.is_finite() {
        1.0
    } else {
        total = scratch
            .iter()
            .fold(0.0f32, |t, &w| t + w * crate::table::WEIGHT_SCALE);
        crate::table::WEIGHT_SCALE
    };
    let target = u * total;
    let mut acc = 0.0f32;
    let k = scratch
        .iter()
        .position(|&w| {
            acc += w * scale;
            target < acc
        })
        .unwrap_or(last);
    Ok(g.first_alt + k as u32)
}

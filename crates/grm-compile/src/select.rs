//! Choosing one alternative of a matched production group by weight.
//!
//! Shared by the CPU derivation engine (`grm-derive`) and the sampler
//! (`grm-sample`), so both pick the same alternative from the same draw with
//! the same float operations in the same order. The GPU kernels implement
//! the same rule and are tested against the CPU engine.

use crate::CompiledSystem;
use crate::rng::{DrawCtx, choice_draw, hash_finish, race_earlier, race_time};
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

/// Choose an alternative of group `g`; returns its global alternative
/// index.
///
/// The exponential race of [`crate::rng`] ("Choosing among weighted
/// alternatives"): every weight is taken first (the constant, or its
/// bytecode run with `bind` and `draws`) and rejected unless finite and
/// positive; then alternative `k`'s time is
/// [`race_time`]`(draws.bits(choice_draw(k)))` over its weight, and the
/// earliest ([`race_earlier`]) wins, the first alternative on a tie.
/// `scratch` holds computed weights.
pub fn choose_alternative(
    sys: &CompiledSystem,
    g: &GroupHeader,
    vm: &mut Vm,
    bind: &[f32],
    draws: &DrawCtx,
    scratch: &mut Vec<f32>,
) -> Result<u32, AltError> {
    if g.alt_count == 1 {
        return Ok(g.first_alt);
    }
    let alts = sys
        .alts
        .get(g.first_alt as usize..g.first_alt as usize + g.alt_count as usize)
        .unwrap_or(&[]);
    if g.flags & GROUP_CONST_WEIGHTS != 0 {
        return Ok(g.first_alt + race(draws, alts.iter().map(|a| a.weight)));
    }
    scratch.clear();
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
        scratch.push(wgt);
    }
    Ok(g.first_alt + race(draws, scratch.iter().copied()))
}

/// The index of the race's winner among `weights` (finite, positive).
#[inline]
fn race(draws: &DrawCtx, weights: impl Iterator<Item = f32>) -> u32 {
    let prefix = draws.prefix();
    let mut best: Option<(u32, f32, u32)> = None;
    for (k, w) in weights.enumerate() {
        let k = k as u32;
        let t = race_time(hash_finish(prefix, choice_draw(k)));
        if best.is_none_or(|(bt, bw, _)| race_earlier(t, w, bt, bw)) {
            best = Some((t, w, k));
        }
    }
    best.map_or(0, |b| b.2)
}

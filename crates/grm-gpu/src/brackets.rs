//! Bracket matching on the GPU (`shaders/brackets.wgsl`): every `[` and
//! `]` gets the position of its partner, as a stack would match them.

use grm_compile::CompiledSystem;
use grm_derive::ModuleString;

use crate::derive::check_string;
use crate::device::{Gpu, groups_for};
use crate::error::GpuError;
use crate::kernels;
use crate::layout::{BRACKET_FAN, BRACKET_MAX_LEVELS, BracketParams};
use crate::scan::{ScanElem, record_scan};

/// No partner.
pub const UNMATCHED: u32 = u32::MAX;

/// Lengths of the minimum tree's levels over `n1` depth values.
fn level_lens(n1: u64) -> Vec<u64> {
    let mut v = vec![n1];
    while let Some(&last) = v.last() {
        if last <= u64::from(BRACKET_FAN) {
            break;
        }
        v.push(last.div_ceil(u64::from(BRACKET_FAN)));
    }
    v
}

/// Device bytes of the scratch buffers for `n` modules (pairs and levels).
pub(crate) fn scratch_bytes(n: u64) -> u64 {
    8 * (n + 1) + 8 * level_lens(n + 1).iter().sum::<u64>()
}

/// The buffers of a bracket matching.
#[derive(Debug)]
pub(crate) struct BracketTree {
    /// Per module: partner + 1, or 0 for none.
    pub(crate) mate: wgpu::Buffer,
    /// The depth tree: level 0 is `(D, D)` for the depth `D` before each
    /// module (and after the last); each level above holds (min, max) of
    /// `BRACKET_FAN` entries below.
    pub(crate) levels: wgpu::Buffer,
    /// Scratch: the scanned bracket counts.
    pub(crate) pairs: wgpu::Buffer,
    /// Length of each level.
    pub(crate) lens: Vec<u64>,
}

impl BracketTree {
    /// Where the top level starts in `levels` (in entries).
    pub(crate) fn top_offset(&self) -> u64 {
        self.lens[..self.lens.len() - 1].iter().sum()
    }
}

/// Record the matching of the `n` modules in `syms` (`tables` says which
/// symbols are brackets).
pub(crate) fn record_match(
    gpu: &Gpu,
    enc: &mut wgpu::CommandEncoder,
    tables: &wgpu::Buffer,
    syms: &wgpu::Buffer,
    n: u64,
) -> Result<BracketTree, GpuError> {
    let n32 = u32::try_from(n).map_err(|_| GpuError::CountOverflow {
        what: "modules to match brackets in",
        count: n,
    })?;
    let lens = level_lens(n + 1);
    if lens.len() > BRACKET_MAX_LEVELS {
        return Err(GpuError::CountOverflow {
            what: "modules to match brackets in",
            count: n,
        });
    }
    let mut p = BracketParams {
        n: n32,
        levels: lens.len() as u32,
        ..BracketParams::default()
    };
    let mut off = 0u64;
    for (l, &len) in lens.iter().enumerate() {
        p.offs[l / 4][l % 4] = off as u32;
        p.lens[l / 4][l % 4] = len as u32;
        off += len;
    }
    let mate = gpu.storage("bracket partners", 4 * n)?;
    let pairs = gpu.storage("bracket depth pairs", 8 * (n + 1))?;
    let levels = gpu.storage("bracket depth tree", 8 * off)?;
    let bind = |gpu: &Gpu, enc: &mut wgpu::CommandEncoder, k, p: &BracketParams, threads| {
        let u = gpu.uniform("bracket params", p);
        gpu.dispatch(
            enc,
            k,
            &[&u, tables, syms, &pairs, &levels, &mate],
            groups_for(threads),
        )
    };
    bind(gpu, enc, &kernels::BRACKET_FLAGS, &p, n + 1)?;
    record_scan(gpu, enc, ScanElem::U32x2, &pairs, n + 1)?;
    bind(gpu, enc, &kernels::BRACKET_DEPTH, &p, n + 1)?;
    for l in 0..lens.len().saturating_sub(1) {
        let q = BracketParams {
            level: l as u32,
            ..p
        };
        bind(gpu, enc, &kernels::BRACKET_REDUCE, &q, lens[l + 1])?;
    }
    bind(gpu, enc, &kernels::BRACKET_MATCH, &p, n)?;
    Ok(BracketTree {
        mate,
        levels,
        pairs,
        lens,
    })
}

/// The bracket partner of every module of `s` (`[` and `]` are the
/// symbols `sys` flags as push and pop), or [`UNMATCHED`].
pub fn match_brackets(
    gpu: &Gpu,
    sys: &CompiledSystem,
    s: &ModuleString,
) -> Result<Vec<u32>, GpuError> {
    check_string(sys, s)?;
    gpu.run(|| {
        let dir = crate::layout::SystemEntry {
            base: (std::mem::size_of::<crate::layout::SystemEntry>() / 4) as u32,
            end: u32::MAX,
            ..Default::default()
        };
        let mut words: Vec<u32> = bytemuck::cast_slice(&[dir]).to_vec();
        words.extend_from_slice(&sys.pack());
        let tables = gpu.upload("tables", &words)?;
        let syms = gpu.upload("symbols", &s.parts().syms)?;
        let n = s.len() as u64;
        let mut enc = gpu.encoder();
        let tree = record_match(gpu, &mut enc, &tables, &syms, n)?;
        let raw = gpu.read::<u32>(enc, &[(&tree.mate, 0, n)])?;
        Ok(raw
            .into_iter()
            .next()
            .unwrap_or_default()
            .into_iter()
            .map(|m| m.wrapping_sub(1))
            .collect())
    })
}

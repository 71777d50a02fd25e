//! GPU turtle interpretation (`shaders/turtle.wgsl`): the bones of a module
//! string, as `grm_turtle::Interpreter` draws them (base, tip, left, width,
//! parent, module).
//!
//! Scope: bones only. Geometry instances, polygons and paint are the CPU
//! interpreter's (`grm-turtle`); on the GPU those modules leave the turtle
//! unchanged, as they do on the CPU.
//!
//! Two ways, chosen per system:
//! - every command an affine transform (no tropism, no `$`, no `%`): a
//!   segmented matrix scan over the modules sorted by depth, then one
//!   composition round per depth (work O(n), rounds = depth + 1);
//! - otherwise: one thread per branch walks it, depth by depth (Lipp's
//!   work items, level-synchronous).

use std::time::{Duration, Instant};

use bytemuck::Zeroable;
use grm_compile::table::{PACKED_MAGIC, PackedHeader, SYM_POP, SYM_PUSH, SymbolEntry};
use grm_derive::ModuleString;
use grm_sema::{Settings, SymbolKind, System, Terminal};
use grm_turtle::TurtleConfig;

use crate::brackets;
use crate::derive::DeviceString;
use crate::device::{Gpu, groups_for};
use crate::error::GpuError;
use crate::kernels;
use crate::layout::{
    GpuBone, SCAN_BLOCK, SEG_INDEX, SystemEntry, TurtleConfig as GpuTurtleConfig, TurtleElem,
    TurtleParams, TurtleSym,
};
use crate::scan::{ScanElem, record_scan};

/// The turtle commands the GPU interpreter knows (`TOP_*` in WGSL).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TurtleOp {
    /// No effect on the turtle (user modules, geometry, paint, polygons).
    Inert = 0,
    /// `F`, `G`: a bone, then move.
    Forward,
    /// `f`, `g`: move.
    Move,
    RotX,
    RotY,
    RotZ,
    TurnAround,
    RollHorizontal,
    Push,
    Pop,
    Cut,
    SetWidth,
    ShrinkWidth,
    Translate,
    Rotate,
    ScaleUniform,
    Scale,
}

impl TurtleOp {
    pub const ALL: &'static [TurtleOp] = &[
        TurtleOp::Inert,
        TurtleOp::Forward,
        TurtleOp::Move,
        TurtleOp::RotX,
        TurtleOp::RotY,
        TurtleOp::RotZ,
        TurtleOp::TurnAround,
        TurtleOp::RollHorizontal,
        TurtleOp::Push,
        TurtleOp::Pop,
        TurtleOp::Cut,
        TurtleOp::SetWidth,
        TurtleOp::ShrinkWidth,
        TurtleOp::Translate,
        TurtleOp::Rotate,
        TurtleOp::ScaleUniform,
        TurtleOp::Scale,
    ];

    /// The command of a terminal and the sign of its angle (as
    /// `grm_turtle::Turtle::step`: `+(a)` is `rotz(-a)`, ...).
    pub fn of(t: Terminal) -> (TurtleOp, f32) {
        use Terminal as T;
        use TurtleOp as O;
        match t {
            T::Forward | T::ForwardNoVertex => (O::Forward, 1.0),
            T::Move | T::MoveNoVertex => (O::Move, 1.0),
            T::TurnLeft => (O::RotZ, -1.0),
            T::TurnRight => (O::RotZ, 1.0),
            T::PitchDown => (O::RotX, 1.0),
            T::PitchUp => (O::RotX, -1.0),
            T::RollLeft => (O::RotY, 1.0),
            T::RollRight => (O::RotY, -1.0),
            T::TurnAround => (O::TurnAround, 1.0),
            T::RollHorizontal => (O::RollHorizontal, 1.0),
            T::Push => (O::Push, 1.0),
            T::Pop => (O::Pop, 1.0),
            T::Cut => (O::Cut, 1.0),
            T::SetWidth => (O::SetWidth, 1.0),
            T::ShrinkWidth => (O::ShrinkWidth, 1.0),
            T::Translate => (O::Translate, 1.0),
            T::Rotate => (O::Rotate, 1.0),
            T::RotX => (O::RotX, 1.0),
            T::RotY => (O::RotY, 1.0),
            T::RotZ => (O::RotZ, 1.0),
            T::ScaleUniform => (O::ScaleUniform, 1.0),
            T::Scale => (O::Scale, 1.0),
            T::SetColor
            | T::NextColor
            | T::PolygonStart
            | T::PolygonVertex
            | T::PolygonEnd
            | T::Cylinder
            | T::Cone
            | T::Sphere
            | T::Box
            | T::Disc
            | T::Mesh
            | T::Material
            | T::Color => (O::Inert, 1.0),
        }
    }

    /// Whether the command depends on the turtle state in a way no affine
    /// transform expresses (then branches are walked, not scanned).
    pub fn is_state_dependent(self) -> bool {
        matches!(self, TurtleOp::RollHorizontal | TurtleOp::Cut)
    }
}

/// What the interpreter needs to know about a system: each symbol's
/// command, and the turtle settings.
#[derive(Clone, Debug)]
pub struct TurtleProgram {
    pub syms: Vec<TurtleSym>,
    pub config: TurtleConfig,
}

impl TurtleProgram {
    pub fn new(system: &System, settings: &Settings) -> TurtleProgram {
        let syms = system
            .symbols
            .iter()
            .map(|s| match s.kind {
                SymbolKind::Terminal(t) => {
                    let (op, sign) = TurtleOp::of(t);
                    TurtleSym {
                        op: op as u32,
                        sign,
                    }
                }
                SymbolKind::User => TurtleSym {
                    op: TurtleOp::Inert as u32,
                    sign: 1.0,
                },
            })
            .collect();
        TurtleProgram {
            syms,
            config: TurtleConfig::from_settings(settings),
        }
    }

    /// Whether branches must be walked (tropism, `$` or `%`).
    pub fn walks(&self) -> bool {
        self.config.tropism.is_some()
            || self.syms.iter().any(|s| {
                TurtleOp::ALL
                    .get(s.op as usize)
                    .is_some_and(|o| o.is_state_dependent())
            })
    }

    /// Whether any symbol is a bracket (`[` or `]`): else every string
    /// of the system is straight (depth 0 everywhere).
    pub fn has_brackets(&self) -> bool {
        self.syms
            .iter()
            .any(|s| s.op == TurtleOp::Push as u32 || s.op == TurtleOp::Pop as u32)
    }

    /// Per symbol: 1 for `[`, -1 for `]`, 0 for the rest.
    pub(crate) fn bracket_kinds(&self) -> Vec<i8> {
        self.syms
            .iter()
            .map(|s| match s.op {
                op if op == TurtleOp::Push as u32 => 1,
                op if op == TurtleOp::Pop as u32 => -1,
                _ => 0,
            })
            .collect()
    }

    /// At most how many bones a string with `counts[s]` modules of each
    /// symbol `s` has (its `F`/`G` modules: one bone each, except those a
    /// cut `%` removes).
    pub fn bones_at_most(&self, counts: &[u64]) -> u64 {
        self.syms
            .iter()
            .zip(counts)
            .filter(|(t, _)| t.op == TurtleOp::Forward as u32)
            .fold(0u64, |a, (_, &n)| a.saturating_add(n))
    }

    /// [`TurtleProgram::bones_at_most`] for expected counts.
    pub(crate) fn bones_expected(&self, counts: &[f64]) -> f64 {
        self.syms
            .iter()
            .zip(counts)
            .filter(|(t, _)| t.op == TurtleOp::Forward as u32)
            .map(|(_, &n)| n)
            .sum()
    }

    /// Push / pop flags of the symbols, as a packed symbol section.
    fn bracket_section(&self) -> Vec<u32> {
        let hw = (std::mem::size_of::<PackedHeader>() / 4) as u32;
        let header = PackedHeader {
            magic: PACKED_MAGIC,
            symbols_offset: hw,
            symbols_count: self.syms.len() as u32,
            ..PackedHeader::zeroed()
        };
        let entries: Vec<SymbolEntry> = self
            .syms
            .iter()
            .map(|s| SymbolEntry {
                flags: if s.op == TurtleOp::Push as u32 {
                    SYM_PUSH
                } else if s.op == TurtleOp::Pop as u32 {
                    SYM_POP
                } else {
                    0
                },
                ..SymbolEntry::zeroed()
            })
            .collect();
        let mut words: Vec<u32> = bytemuck::cast_slice(&[header]).to_vec();
        words.extend_from_slice(bytemuck::cast_slice(&entries));
        words
    }

    /// This system's settings, its symbols' records at word `syms`.
    fn gpu_config(&self, syms: u32) -> GpuTurtleConfig {
        let cfg = &self.config;
        let t = cfg.tropism.unwrap_or_default();
        GpuTurtleConfig {
            syms,
            angle: cfg.angle,
            step: cfg.step,
            width: cfg.width,
            elasticity: cfg.elasticity,
            tropism_x: t.x,
            tropism_y: t.y,
            tropism_z: t.z,
            has_tropism: u32::from(cfg.tropism.is_some()),
            ..GpuTurtleConfig::default()
        }
    }
}

/// The bracket kernels' tables for systems over `ranges` of the string: a
/// directory, then each system's symbol flags.
fn bracket_tables(programs: &[&TurtleProgram], ranges: &[(u64, u64)]) -> Vec<u32> {
    let dw = programs.len() * std::mem::size_of::<SystemEntry>() / 4;
    let mut words = vec![0u32; dw];
    let mut dir = Vec::with_capacity(programs.len());
    for (p, &(start, end)) in programs.iter().zip(ranges) {
        dir.push(SystemEntry {
            base: words.len() as u32,
            start: start as u32,
            end: end as u32,
            ..SystemEntry::default()
        });
        words.extend_from_slice(&p.bracket_section());
    }
    words[..dw].copy_from_slice(bytemuck::cast_slice(&dir));
    words
}

/// The `tsyms` buffer: every system's config, then their symbol records.
pub(crate) fn turtle_tables(programs: &[&TurtleProgram]) -> Vec<u32> {
    let cw = std::mem::size_of::<GpuTurtleConfig>() / 4;
    let mut words = vec![0u32; cw * programs.len()];
    let mut configs = Vec::with_capacity(programs.len());
    for p in programs {
        configs.push(p.gpu_config(words.len() as u32));
        for t in &p.syms {
            words.extend_from_slice(bytemuck::cast_slice(&[*t]));
        }
    }
    words[..cw * programs.len()].copy_from_slice(bytemuck::cast_slice(&configs));
    words
}

/// What the caller knows of the number of bones before they are counted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum BoneCount {
    /// At most this many (a host string's or an exact derivation's symbol
    /// counts): the bone buffer is sized from it, and counting and writing
    /// the bones is one submission.
    AtMost(u64),
    /// Probably at most this many (a stochastic derivation's expected
    /// counts with a margin): the same, and where the count turns out
    /// larger the bones are written again into a buffer of that size.
    Expected(u64),
    /// Nothing: the count is read back first.
    Unknown,
}

/// What the caller of [`interpret_device`] knows in advance, and what it
/// wants read back with the bone count.
#[derive(Clone, Copy, Debug)]
pub(crate) struct InterpHints<'b> {
    pub bones: BoneCount,
    /// Bounds on a branching string's brackets (else its depth range is
    /// read back before anything is sized).
    pub brackets: Option<BracketBounds>,
    /// A buffer whose first word is read back with the bone count, with
    /// no wait of its own (a pipelined derivation's status).
    pub also_read: Option<&'b wgpu::Buffer>,
}

/// The largest bone buffer allocated on a guess ([`BoneCount::Expected`]).
const GUESS_MAX_BYTES: u64 = 256 << 20;

/// The deepest nesting a [`BracketBounds`] may give for the interpretation
/// to use it: each depth up to the bound costs one (possibly empty) round,
/// and a few dozen empty dispatches cost about what the one read-back they
/// save does on a GPU.
const MAX_BOUNDED_DEPTH: u64 = 64;

/// Bounds on a string's brackets known before it is interpreted (from the
/// derivation's tables, or counted on the host): the deepest nesting and
/// the number of `[`. With them the buffers are sized and the rounds
/// recorded without first reading the depth range back, and the range is
/// read (and checked against them) with the bone count.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct BracketBounds {
    pub depth: u64,
    pub opens: u64,
}

/// The bracket pass's figures, read back: what [`check_depths`] reads.
/// In `u32` words: the top level's `[min, max]` depth pairs, the number
/// of `[` (the scanned counts' total), and the depth where each later
/// system starts (it must start at depth 0: every system before it closed
/// its brackets).
fn depth_reads<'b>(
    tree: &'b brackets::BracketTree,
    n: u64,
    ranges: &[(u64, u64)],
) -> Vec<(&'b wgpu::Buffer, u64, u64)> {
    let mut reads = vec![(
        &tree.levels,
        2 * tree.top_offset(),
        2 * *tree.lens.last().unwrap_or(&1),
    )];
    // `pairs` holds (`[` count, `]` count) pairs: the first word of pair n.
    reads.push((&tree.pairs, 2 * n, 1));
    for &(start, _) in ranges.iter().skip(1) {
        reads.push((&tree.levels, 2 * start.min(n), 2));
    }
    reads
}

/// The deepest nesting and the number of `[` from [`depth_reads`]' words;
/// unbalanced brackets (a depth below 0, or a system that does not start
/// at depth 0) are an error.
fn check_depths(got: &[Vec<u32>], ranges: &[(u64, u64)]) -> Result<(u64, u64), GpuError> {
    let pairs = |v: &Vec<u32>| -> Vec<[i32; 2]> {
        v.chunks_exact(2)
            .map(|c| [c[0] as i32, c[1] as i32])
            .collect()
    };
    let top = got.first().map(pairs).unwrap_or_default();
    let opens = got
        .get(1)
        .and_then(|v| v.first())
        .map_or(0, |&c| u64::from(c));
    let dmin = top.iter().map(|v| v[0]).min().unwrap_or(0);
    let dmax = top.iter().map(|v| v[1]).max().unwrap_or(0);
    if dmin < 0 {
        return Err(GpuError::UnbalancedBrackets { position: None });
    }
    if let Some(k) = got
        .iter()
        .skip(2)
        .position(|v| v.first().is_some_and(|&d| d != 0))
    {
        return Err(GpuError::UnbalancedBrackets {
            position: Some(ranges[k + 1].0 as usize),
        });
    }
    Ok((dmax as u64, opens))
}

/// The exact [`BracketBounds`] of a host string (one pass over it).
fn host_bracket_bounds(program: &TurtleProgram, string: &ModuleString) -> BracketBounds {
    let kinds = program.bracket_kinds();
    let (mut d, mut depth, mut opens) = (0i64, 0i64, 0u64);
    for sym in string.symbols() {
        let k = kinds.get(sym as usize).copied().unwrap_or(0);
        d += i64::from(k);
        opens += u64::from(k > 0);
        depth = depth.max(d);
    }
    BracketBounds {
        depth: depth.max(0) as u64,
        opens,
    }
}

/// Bones and figures of one interpretation.
#[derive(Clone, Debug, Default)]
pub struct GpuInterpretation {
    /// In string order (as the CPU numbers them); empty when not read back.
    pub bones: Vec<GpuBone>,
    /// Number of bones.
    pub bone_count: u64,
    /// Deepest branch nesting.
    pub max_depth: u32,
    /// Whether branches were walked (else scanned).
    pub walked: bool,
    /// Whether the matrix scan was fused (affine commands: no per-module
    /// states stored, only block totals and the states at `[`).
    pub fused: bool,
    /// Whether the bones came from a direct derivation's tables, without
    /// reading the string (derive/direct.rs, shaders/expand_turtle.wgsl).
    pub direct: bool,
    /// Wall time on the host, including the synchronisations, without
    /// reading the bones back.
    pub elapsed: Duration,
}

/// The longest string whose branches a software device (Mesa's lavapipe)
/// may walk (tropism, `$`, `%`: one thread per branch, about one loop
/// iteration per module): llvmpipe stops an invocation's loops after
/// 65,535 iterations in all and leaves the rest of the branch without
/// bones. Longer strings are refused there with the reason
/// (`GpuError::Unsupported`: `--cpu-fallback` interprets them on the CPU);
/// a GPU has no such limit.
pub const SOFTWARE_WALK_MAX: u64 = 60_000;

/// Histogram entries (chunks x depths) to aim for.
const HIST_BUDGET: u64 = 1 << 24;

/// How a branching string of affine commands is scanned (shaders/turtle.wgsl
/// 3a and 3a'). A straight string always takes the fused scan (one pass,
/// no rounds); state-dependent commands always walk, with a state per
/// module.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BranchScan {
    /// A state per module where that buffer fits the device, else fused.
    #[default]
    Auto,
    /// A state per module: each transform computed once, then scanned,
    /// composed and read (five passes over 64 bytes per module). Fails
    /// with [`GpuError::BufferTooLarge`] where the states do not fit.
    PerModule,
    /// Block totals and the states at `[` only: each transform computed
    /// twice (reduce, then the round that writes the bones), a fifth of
    /// the memory or less.
    Fused,
}

/// Interpret a host string.
pub fn interpret(
    gpu: &Gpu,
    program: &TurtleProgram,
    string: &ModuleString,
) -> Result<GpuInterpretation, GpuError> {
    interpret_with(gpu, program, string, BranchScan::Auto)
}

/// As [`interpret`], choosing how a branching string is scanned.
pub fn interpret_with(
    gpu: &Gpu,
    program: &TurtleProgram,
    string: &ModuleString,
    scan: BranchScan,
) -> Result<GpuInterpretation, GpuError> {
    if !string.is_well_formed() {
        return Err(GpuError::InvalidInput(
            "the module string breaks its invariant".into(),
        ));
    }
    if let Some(i) = string
        .symbols()
        .position(|s| s as usize >= program.syms.len())
    {
        return Err(GpuError::InvalidInput(format!(
            "module {i}: symbol {} is not in the system",
            string.sym(i)
        )));
    }
    gpu.run(|| {
        let p = string.parts();
        let s = DeviceString {
            syms: gpu.upload("symbols", &p.syms)?,
            starts: gpu.upload("parameter starts", &p.starts)?,
            params: gpu.upload("parameters", &p.params)?,
            keys: None,
            len: string.len() as u64,
            words: p.params.len() as u64,
        };
        let mut counts = vec![0u64; program.syms.len()];
        for sym in string.symbols() {
            // In range: checked above.
            counts[sym as usize] += 1;
        }
        let most = program.bones_at_most(&counts);
        let b = host_bracket_bounds(program, string);
        let hints = InterpHints {
            bones: BoneCount::AtMost(most),
            brackets: Some(b),
            also_read: None,
        };
        let (bones, count, mut out, _) =
            interpret_device(gpu, &[program], &s, &[(0, s.len)], hints, scan)?;
        out.bones = read_bones(gpu, &bones, count)?;
        Ok(out)
    })
}

pub(crate) fn read_bones(
    gpu: &Gpu,
    bones: &wgpu::Buffer,
    count: u64,
) -> Result<Vec<GpuBone>, GpuError> {
    if count == 0 {
        return Ok(Vec::new());
    }
    Ok(gpu
        .read::<GpuBone>(gpu.encoder(), &[(bones, 0, count)])?
        .pop()
        .unwrap_or_default())
}

/// Interpret a string on the device: system `k` (the symbols' bits above
/// `SYS_SHIFT`) is `programs[k]` and covers `ranges[k]` of the string.
/// Returns the bone buffer (bones in string order), the bone count and the
/// figures (with no bones read yet), and the first word of
/// `hints.also_read`. `hints.bones` ([`BoneCount`]), when the caller
/// knows or expects it, sizes the bone buffer before the bones are
/// counted, so counting and writing them is one submission (else the
/// count is read back first). `hints.brackets`, when the caller knows
/// them, does the same for the depth range of a branching string (else it
/// is read back before anything is sized).
/// Inside [`Gpu::run`].
pub(crate) fn interpret_device(
    gpu: &Gpu,
    programs: &[&TurtleProgram],
    s: &DeviceString,
    ranges: &[(u64, u64)],
    hints: InterpHints<'_>,
    scan: BranchScan,
) -> Result<(wgpu::Buffer, u64, GpuInterpretation, Option<u32>), GpuError> {
    let (bones_hint, brackets_at_most) = (hints.bones, hints.brackets);
    let t0 = Instant::now();
    let n = s.len;
    if programs.is_empty() || programs.len() != ranges.len() {
        return Err(GpuError::InvalidInput(
            "one turtle program and range per system".into(),
        ));
    }
    let walked = programs.iter().any(|p| p.walks());
    let mut out = GpuInterpretation {
        bones: Vec::new(),
        bone_count: 0,
        max_depth: 0,
        walked,
        fused: false,
        direct: false,
        elapsed: Duration::ZERO,
    };
    if n == 0 {
        let also = match hints.also_read {
            Some(b) => gpu
                .read::<u32>(gpu.encoder(), &[(b, 0, 1)])?
                .first()
                .and_then(|v| v.first().copied()),
            None => None,
        };
        return Ok((gpu.storage("bones", 16)?, 0, out, also));
    }
    if n >= u64::from(SEG_INDEX) {
        return Err(GpuError::CountOverflow {
            what: "modules to interpret",
            count: n,
        });
    }
    if walked && gpu.is_software() && n > SOFTWARE_WALK_MAX {
        return Err(GpuError::Unsupported(format!(
            "interpreting {n} modules with tropism, `$` or `%` on a software device ({}): it walks \
             each branch with one thread and stops a thread's loops after 65,535 steps, so a \
             branch longer than that would lose its bones (strings of at most {SOFTWARE_WALK_MAX} \
             modules are interpreted there)",
            gpu.describe()
        )));
    }
    // 1. Depths. A string of systems without brackets is straight: depth
    // 0 everywhere, already in depth order; nothing to match, read or sort.
    // A branching one is matched first; its depth range sizes the buffers
    // and the rounds: the caller's bounds (checked against the range when
    // the bone count is read), else the range read back now.
    let straight = !programs.iter().any(|p| p.has_brackets());
    let state_bytes = std::mem::size_of::<TurtleElem>() as u64;
    let fused = !walked
        && (straight
            || match scan {
                BranchScan::Fused => true,
                BranchScan::PerModule => false,
                BranchScan::Auto => gpu.check_storage("turtle states", state_bytes * n).is_err(),
            });
    out.fused = fused;
    let blocks = n.div_ceil(u64::from(SCAN_BLOCK));
    let mut enc = gpu.encoder();
    let mut bracket_tables_buf = None;
    let mut bounded = None;
    let tree = if straight {
        None
    } else {
        let tables = gpu.upload("turtle symbols", &bracket_tables(programs, ranges))?;
        let tree = brackets::record_match(gpu, &mut enc, &tables, &s.syms, n)?;
        bracket_tables_buf = Some(tables);
        // A depth bound costs a round per depth whether the string reaches
        // it or not: past `MAX_BOUNDED_DEPTH` the range is read instead. A
        // fused scan keeps a state per `[`: that bound must fit too.
        let usable = brackets_at_most
            .map(|b| BracketBounds {
                depth: b.depth.min(n),
                opens: b.opens.min(n),
            })
            .filter(|b| {
                b.depth <= MAX_BOUNDED_DEPTH
                    && (!fused
                        || gpu
                            .check_storage(
                                "turtle states",
                                state_bytes.saturating_mul(blocks.saturating_add(b.opens)),
                            )
                            .is_ok())
            });
        match usable {
            Some(b) => {
                bounded = Some(b);
                Some((tree, b.depth, b.opens))
            }
            None => {
                let first = std::mem::replace(&mut enc, gpu.encoder());
                let got = gpu.read::<u32>(first, &depth_reads(&tree, n, ranges))?;
                let (dmax, opens) = check_depths(&got, ranges)?;
                Some((tree, dmax, opens))
            }
        }
    };
    let dmax = tree.as_ref().map_or(0, |t| t.1);
    let opens = tree.as_ref().map_or(0, |t| t.2);
    out.max_depth = dmax as u32;
    let unused = || gpu.storage("unused", 16);
    let tree = match tree {
        Some((t, _, _)) => t,
        None => brackets::BracketTree {
            mate: unused()?,
            levels: unused()?,
            pairs: unused()?,
            lens: vec![1],
        },
    };
    let (levels, pairs) = (&tree.levels, &tree.pairs);

    // 2. Buffers. A straight string of affine commands keeps one turtle
    // state per block of SCAN_BLOCK modules, not one per module (the fused
    // matrix scan, shaders/turtle.wgsl 3a); a branching one also one per
    // `[` when it is fused (`scan`: where the per-module states would not
    // fit, by default).
    let chunk = (n * (dmax + 1)).div_ceil(HIST_BUDGET).max(32);
    let chunks = n.div_ceil(chunk);
    let hist_len = (chunks * (dmax + 1) + 1).max(n + 1);
    let base = TurtleParams {
        n: n as u32,
        dmax: dmax as u32,
        chunk: chunk as u32,
        chunks: chunks as u32,
        depth: 0,
        bstart: 0,
        args: (dmax + 2) as u32,
        max_groups: gpu.grid_width(),
        straight: u32::from(straight),
        fused: u32::from(fused),
        blocks: blocks as u32,
        ..TurtleParams::default()
    };
    let tsyms = gpu.upload("turtle commands", &turtle_tables(programs))?;
    let hist = gpu.storage("depth histogram", 4 * hist_len)?;
    let (order, pos_of) = if straight {
        (unused()?, unused()?)
    } else {
        (
            gpu.storage("modules by depth", 4 * n)?,
            gpu.storage("depth positions", 4 * n)?,
        )
    };
    let elems = gpu.storage(
        "turtle states",
        state_bytes * if fused { blocks + opens } else { n },
    )?;
    let aux = gpu.storage("depth buckets", 4 * ((dmax + 2) + 3 * (dmax + 1)))?;
    let indirect = gpu.indirect("round dispatches", 12 * (dmax + 1))?;
    let no_bones = gpu.storage("unused", 16)?;
    let run = |enc: &mut wgpu::CommandEncoder,
               k,
               p: &TurtleParams,
               bones: &wgpu::Buffer,
               threads: u64| {
        let u = gpu.uniform("turtle params", p);
        let b = [
            &u, &s.syms, &s.starts, &s.params, &tsyms, levels, &hist, &order, &pos_of, &elems,
            bones, &aux, pairs,
        ];
        gpu.dispatch(enc, k, &b, groups_for(threads))
    };
    let round = |enc: &mut wgpu::CommandEncoder, k, d: u64, bones: &wgpu::Buffer| {
        let p = TurtleParams {
            depth: d as u32,
            ..base
        };
        let u = gpu.uniform("turtle params", &p);
        let b = [
            &u, &s.syms, &s.starts, &s.params, &tsyms, levels, &hist, &order, &pos_of, &elems,
            bones, &aux, pairs,
        ];
        gpu.dispatch_indirect(enc, k, &b, &indirect, 12 * d)
    };

    // 3. Sort by depth (a string with brackets), then walk (state-dependent
    // commands) or scan the per-module states and compose them depth by
    // depth, then number the bones. The fused scan comes with the bones,
    // in step 4.
    let wg = u64::from(crate::device::WORKGROUP);
    if !straight {
        run(&mut enc, &kernels::DEPTH_HIST, &base, &no_bones, chunks + 1)?;
        record_scan(gpu, &mut enc, ScanElem::U32, &hist, chunks * (dmax + 1) + 1)?;
        run(&mut enc, &kernels::DEPTH_SCATTER, &base, &no_bones, chunks)?;
    }
    if !straight || !fused {
        run(&mut enc, &kernels::DEPTH_STARTS, &base, &no_bones, dmax + 2)?;
        enc.copy_buffer_to_buffer(
            &aux,
            4 * u64::from(base.args),
            &indirect,
            0,
            Some(12 * (dmax + 1)),
        );
    }
    if walked {
        for d in 0..=dmax {
            round(&mut enc, &kernels::TURTLE_WALK, d, &no_bones)?;
        }
    } else if !fused {
        run(&mut enc, &kernels::TURTLE_ELEMS, &base, &no_bones, n)?;
        record_scan(gpu, &mut enc, ScanElem::Turtle, &elems, n)?;
        for d in 0..=dmax {
            round(&mut enc, &kernels::TURTLE_ROUND, d, &no_bones)?;
        }
    }
    run(&mut enc, &kernels::BONE_FLAGS, &base, &no_bones, n + 1)?;
    record_scan(gpu, &mut enc, ScanElem::U32, &hist, n + 1)?;

    // 4. The bones: in the same submission when their number is bounded
    // in advance (and the bound fits a buffer), else after reading it.
    // Fused: reduce the blocks, scan the block totals, then scan each
    // block again as it writes its bones (one pass for a straight string,
    // one round per depth otherwise, each writing the states at its `[`s
    // for the next).
    let bone_bytes = std::mem::size_of::<GpuBone>() as u64;
    // The bone buffer sized before counting: (capacity, a bound that holds).
    let sized = match bones_hint {
        BoneCount::AtMost(b) => Some((b, true)),
        BoneCount::Expected(b) => Some((b.min(n), false))
            .filter(|&(b, _)| bone_bytes.saturating_mul(b) <= GUESS_MAX_BYTES),
        BoneCount::Unknown => None,
    }
    .filter(|&(b, _)| {
        gpu.check_storage("bones", bone_bytes.saturating_mul(b))
            .is_ok()
    });
    let write = |enc: &mut wgpu::CommandEncoder, bones: &wgpu::Buffer| {
        if !fused {
            return run(enc, &kernels::BONES_WRITE, &base, bones, n);
        }
        run(enc, &kernels::FUSED_REDUCE, &base, &no_bones, blocks * wg)?;
        record_scan(gpu, enc, ScanElem::Turtle, &elems, blocks)?;
        if straight {
            return run(enc, &kernels::STRAIGHT_BONES, &base, bones, blocks * wg);
        }
        for d in 0..=dmax {
            round(enc, &kernels::FUSED_ROUND, d, bones)?;
        }
        Ok(())
    };
    // The bone count; with bounds, the depth range with it (checked: a
    // depth range over the bounds means the kernels ran on buffers too
    // small, so nothing they wrote is used).
    let also = std::cell::Cell::new(None);
    let read_count = |enc: wgpu::CommandEncoder| -> Result<(u64, Option<(u64, u64)>), GpuError> {
        let mut reads = vec![(&hist, n, 1)];
        if let Some(b) = hints.also_read {
            reads.push((b, 0, 1));
        }
        let skip = reads.len();
        if bounded.is_some() {
            reads.extend(depth_reads(&tree, n, ranges));
        }
        let got = gpu.read::<u32>(enc, &reads)?;
        let count = got
            .first()
            .and_then(|v| v.first())
            .map_or(0, |&c| u64::from(c));
        if hints.also_read.is_some() {
            also.set(got.get(1).and_then(|v| v.first().copied()));
        }
        let range = match bounded {
            Some(_) => Some(check_depths(&got[skip..], ranges)?),
            None => None,
        };
        Ok((count, range))
    };
    let in_bounds = |range: Option<(u64, u64)>| range.is_none_or(|(d, o)| d <= dmax && o <= opens);
    let (bones, count, range) = match sized {
        Some((most, holds)) => {
            let mut bones = gpu.storage("bones", bone_bytes * most)?;
            write(&mut enc, &bones)?;
            let (count, range) = read_count(enc)?;
            if count > most {
                if holds {
                    return Err(GpuError::Readback(format!(
                        "{count} bones, more than the {most} the string's symbols allow"
                    )));
                }
                // More than expected: written again, into a buffer of the
                // count (what the unknown count does after reading it).
                gpu.recycle([bones]);
                bones = gpu.storage("bones", bone_bytes * count)?;
                if in_bounds(range) {
                    let mut enc = gpu.encoder();
                    write(&mut enc, &bones)?;
                    gpu.submit_wait(enc)?;
                }
            }
            (bones, count, range)
        }
        None => {
            let (count, range) = read_count(enc)?;
            let bones = gpu.storage("bones", bone_bytes * count)?;
            if in_bounds(range) {
                let mut enc = gpu.encoder();
                write(&mut enc, &bones)?;
                gpu.submit_wait(enc)?;
            }
            (bones, count, range)
        }
    };
    let _ = bracket_tables_buf;
    gpu.recycle([hist, order, pos_of, elems, aux, no_bones]);
    gpu.recycle([tree.levels, tree.pairs, tree.mate]);
    if let Some((d, o)) = range {
        if d > dmax || o > opens {
            // The caller's bounds were wrong: interpret again, reading the
            // depth range first.
            gpu.recycle([bones]);
            let exact = InterpHints {
                brackets: None,
                ..hints
            };
            return interpret_device(gpu, programs, s, ranges, exact, scan);
        }
        out.max_depth = d as u32;
    }
    out.elapsed = t0.elapsed();
    out.bone_count = count;
    Ok((bones, count, out, also.get()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bounds below the string's real depth range are caught when the
    /// range is read with the bone count, and the string is interpreted
    /// again from the range read first; an expected bone count below the
    /// real one has the bones written again: the same bones every way.
    #[test]
    fn wrong_bracket_bounds_are_caught_and_the_string_interpreted_again() {
        let gpu = match crate::shared() {
            Ok(g) => g,
            Err(e) => {
                panic!("GPU tests need a GPU adapter (scripts/test.sh installs lavapipe): {e}")
            }
        };
        let src = "system S { axiom F [ + F [ - F [ + F ] ] F ] F [ - F ] F; }";
        let (_, checked) = grm_sema::check_with("inline.grm", src, &grm_sema::MemLoader::new());
        assert!(!checked.has_errors(), "{:?}", checked.diagnostics);
        let p = &checked.program;
        let sys = p.default_system().expect("a system");
        let c = grm_compile::compile(p, sys, &p.default_params()).expect("compiles");
        let string = grm_derive::Engine::new(&c, 1)
            .and_then(|e| e.axiom(0))
            .expect("axiom");
        let prog = TurtleProgram::new(sys, &c.settings);
        let exact = host_bracket_bounds(&prog, &string);
        assert_eq!(exact, BracketBounds { depth: 3, opens: 4 });
        for scan in [BranchScan::PerModule, BranchScan::Fused] {
            let got = gpu.run(|| {
                let mut out = Vec::new();
                let at_most = BoneCount::AtMost(8);
                for (bounds, hint) in [
                    (None, at_most),
                    (Some(exact), at_most),
                    (Some(BracketBounds { depth: 0, opens: 4 }), at_most),
                    (Some(BracketBounds { depth: 3, opens: 1 }), at_most),
                    (Some(exact), BoneCount::Expected(3)),
                    (Some(exact), BoneCount::Expected(100)),
                    (Some(exact), BoneCount::Unknown),
                    (None, BoneCount::Unknown),
                ] {
                    let s = DeviceString::upload(gpu, &c, &string)?;
                    let w = gpu.waits();
                    let hints = InterpHints {
                        bones: hint,
                        brackets: bounds,
                        also_read: None,
                    };
                    let (bones, count, o, _) =
                        interpret_device(gpu, &[&prog], &s, &[(0, s.len)], hints, scan)?;
                    let waits = gpu.waits() - w;
                    out.push((read_bones(gpu, &bones, count)?, o.max_depth, waits));
                }
                Ok(out)
            });
            let got = got.expect("interprets");
            let (want, depth, _) = &got[0];
            assert_eq!(want.len(), 8, "{scan:?}");
            assert_eq!(*depth, 3, "{scan:?}");
            // No bracket bounds: the range, then the bones with their
            // count. Exact: one wait. Wrong: one, then again without. An
            // expected bone count too small: the bones written again; large
            // enough: as a bound. Unknown: the count, then the bones.
            let waits: Vec<u64> = got.iter().map(|g| g.2).collect();
            assert_eq!(waits, [2, 1, 3, 3, 2, 1, 2, 3], "{scan:?}");
            for (k, (bones, depth, _)) in got.iter().enumerate().skip(1) {
                assert_eq!(bones, want, "{scan:?} bounds {k}");
                assert_eq!(*depth, 3, "{scan:?} bounds {k}");
            }
        }
    }
}

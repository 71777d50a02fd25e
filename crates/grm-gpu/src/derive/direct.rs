//! Direct derivation: the final string of deterministic, context-free
//! systems in one pass (`shaders/expand.wgsl`), with no intermediate
//! string, no scan and one wait.
//!
//! In such a system (every symbol either has no production or a first
//! group with one alternative, no context and no condition) every module
//! of a symbol becomes a string of the same size after the same number of
//! steps, whatever its parameters, so each symbol's length and parameter
//! words after `r` steps are known from the tables, and so is the final
//! string's layout: a tree of expansions. The host writes, per job, every
//! successor module's first position (module and parameter word) inside
//! its predecessor's expansion for each number of steps left, and the
//! axioms' own offsets; the kernel's threads take one output position each
//! and walk down to the module there (a binary search per step). Its
//! parameters are its slot's constants, or (`expand_vm.wgsl`) the chain of
//! computed parameters from the last slot with constant ones, evaluated
//! in order with the bytecode interpreter. The work is one pass over the
//! output whatever the number of iterations, where stepwise derivation
//! writes and scans every intermediate string.
//!
//! Invariants: the result (string, per-string figures, directory) is the
//! stepwise derivation's exactly (the axioms are the CPU engine's, the
//! constants the tables', computed parameters the same operations in the
//! same order); code with random draws is never taken (the walk has no
//! positions in the intermediate strings); a fault or non-finite value
//! makes the caller derive stepwise, which reports it; a plan exists only
//! where every computed parameter of the stepwise derivation is evaluated
//! by some walk (so none can fail unseen) and every string of the
//! stepwise derivation is within the options' and
//! the device's limits (otherwise the stepwise path runs and reports the
//! limit as before); every table value a thread reads on its way is exact
//! (clamping applies only to symbols the final string cannot reach, whose
//! sizes overflow).

use std::time::Instant;

use grm_compile::CompiledSystem;
use grm_compile::op::{Op, decode};
use grm_compile::rng::child_key;
use grm_compile::table::{NONE, PARAM_CODE, PARAM_CONST, SuccModule};
use grm_derive::ModuleString;

use super::{
    DeviceString, GpuDeriveOptions, GpuIterationStats, GpuJob, GpuSystem, exact_symbol, succ_of,
};
use crate::device::groups_for;
use crate::error::GpuError;
use crate::interp::{GpuInterpretation, TurtleOp, TurtleProgram, turtle_tables};
use crate::kernels;
use crate::layout::{
    DIRECT_MAX_STEPS, DIRECT_TURTLE_STACK, EXPAND_SLOT_WORDS, ExpandJob, ExpandParams,
    ExpandTurtleParams, GpuBone, SYM_MASK, SYS_SHIFT, SystemEntry, TurtleElem,
};
use crate::stamps::Stamps;

/// The most computed-parameter evaluations a direct derivation may do per
/// evaluation of the stepwise derivation: on lavapipe, the ternary tree
/// (as many either way) derives 1.7x faster directly and the row of trees
/// (7.5 times as many) 4.6x slower (docs/benchmarks.md).
pub const DIRECT_MAX_EVAL_RATIO: u64 = 2;

/// The most words of expansion tables (16 MiB).
const DIRECT_MAX_TABLE_WORDS: usize = 1 << 22;

/// What the `expand` kernel reads, and the figures of every string.
#[derive(Debug)]
pub(crate) struct DirectPlan {
    jobs: Vec<ExpandJob>,
    words: Vec<u32>,
    /// String 0: each job's axiom (the CPU engine's), each module tagged
    /// with its job.
    axioms: ModuleString,
    /// Per axiom module, its expansion's first (module, parameter word)
    /// in the final string; then the final string's totals.
    in_offs: Vec<[u32; 2]>,
    /// (Modules, parameter words) of strings 0 ..= the last iteration.
    pub(crate) totals: Vec<(u64, u64)>,
    /// Each job's final length.
    job_lens: Vec<u64>,
    /// Some successor parameters are computed ([`kernels::EXPAND_VM`]).
    computed: bool,
    /// Computed successor slots the walks evaluate, and those the stepwise
    /// derivation would.
    walk_evals: u64,
    step_evals: u64,
    /// One job with constant parameters: what its direct interpretation
    /// needs.
    single: Option<SingleJob>,
}

/// A single job's expansion, kept for its direct interpretation.
#[derive(Debug)]
pub(crate) struct SingleJob {
    succ: Vec<Option<Vec<u32>>>,
    slot_string: ModuleString,
}

/// Sizes of one module's expansion after `r` steps, per symbol: `r = 0`
/// is the module itself.
type Sizes = Vec<Vec<(u64, u64)>>;

/// One system's expansion tables for a number of steps.
#[derive(Debug)]
struct Expansion {
    job: ExpandJob,
    size: Sizes,
    /// Some successor parameters are computed.
    computed: bool,
    /// Per steps and symbol, the computed slots the walks of one module's
    /// expansion evaluate (each final module evaluates the computed slots
    /// after the last constant one on its path) ...
    walk_evals: Vec<Vec<u64>>,
    /// ... and those the stepwise derivation evaluates (every computed
    /// slot of every step once).
    step_evals: Vec<Vec<u64>>,
    /// Per symbol with a production, its successor's symbols in slot
    /// order (the direct interpretation's bone counts).
    succ: Vec<Option<Vec<u32>>>,
    /// One module per slot with its constant parameters, when every slot's
    /// are constants (the direct interpretation's slot string).
    slot_string: Option<ModuleString>,
}

/// One system's expansion tables for `steps` steps (appended to `words`),
/// with its sizes and evaluation counts; `None` when the system does not
/// qualify or its tables would be too large.
fn expansion(sys: &CompiledSystem, steps: u32, words: &mut Vec<u32>) -> Option<Expansion> {
    let ns = sys.symbols.len();
    let mut succ: Vec<Option<&[SuccModule]>> = Vec::with_capacity(ns);
    for (s, e) in sys.symbols.iter().enumerate() {
        if !exact_symbol(sys, s) {
            return None;
        }
        if e.group_count == 0 {
            succ.push(None);
            continue;
        }
        let g = sys.groups.get(e.first_group as usize)?;
        succ.push(Some(succ_of(sys, sys.alts.get(g.first_alt as usize)?)?));
    }
    // Every successor module: a known symbol and parameters of its
    // symbol's width; constants kept (`Some`), computed ones without
    // random draws (`None`: the walk evaluates them).
    let mut consts: Vec<Option<Vec<u32>>> = Vec::new();
    for m in succ.iter().flatten().flat_map(|c| c.iter()) {
        let e = sys.symbols.get(m.symbol as usize)?;
        let start = m.first_param as usize;
        let pes = sys
            .params
            .get(start..start.checked_add(m.param_count as usize)?)?;
        let mut w = Vec::with_capacity(e.param_words as usize);
        let mut words = 0u32;
        let mut constant = true;
        for pe in pes {
            words = words.checked_add(pe.words)?;
            if pe.kind == PARAM_CONST {
                let a = pe.a as usize;
                let c = sys.consts.get(a..a.checked_add(pe.words as usize)?)?;
                w.extend(c.iter().map(|x| x.to_bits()));
            } else {
                constant = false;
                if pe.kind == PARAM_CODE && !draws_nothing(sys, pe.a)? {
                    return None;
                }
            }
        }
        if words != e.param_words {
            return None;
        }
        consts.push(constant.then_some(w));
    }
    let own: Vec<(u64, u64)> = sys
        .symbols
        .iter()
        .map(|e| (1, u64::from(e.param_words)))
        .collect();
    let mut size = vec![own.clone()];
    for r in 1..=steps as usize {
        let prev = &size[r - 1];
        let row = succ
            .iter()
            .zip(&own)
            .map(|(c, &me)| match c {
                None => me,
                Some(c) => c.iter().fold((0u64, 0u64), |(m, w), x| {
                    let (dm, dw) = prev[x.symbol as usize];
                    (m.saturating_add(dm), w.saturating_add(dw))
                }),
            })
            .collect();
        size.push(row);
    }
    let slots: usize = consts.len();
    let data: usize = consts.iter().flatten().map(Vec::len).sum();
    let need = 2 * ns + EXPAND_SLOT_WORDS as usize * slots + data + 2 * slots * steps as usize;
    if words.len() + need > DIRECT_MAX_TABLE_WORDS {
        return None;
    }
    let base = words.len();
    let slot_base = base + 2 * ns;
    let data_base = slot_base + EXPAND_SLOT_WORDS as usize * slots;
    let job = ExpandJob {
        symbols: base as u32,
        slots: slot_base as u32,
        offsets: (data_base + data) as u32,
        slot_count: slots as u32,
        steps,
        ..ExpandJob::default()
    };
    let mut first = 0u32;
    for c in &succ {
        let n = c.map_or(0, |c| c.len() as u32);
        words.extend_from_slice(&[first, n]);
        first += n;
    }
    let mut at = data_base as u32;
    let mut k = 0;
    for (s, c) in succ.iter().enumerate() {
        let Some(c) = c else { continue };
        // The production's binding of its predecessor's parameters.
        let g = sys.groups.get(sys.symbols[s].first_group as usize)?;
        for m in c.iter() {
            let pw = sys.symbols[m.symbol as usize].param_words;
            let data = match &consts[k] {
                Some(w) => {
                    at += w.len() as u32;
                    at - w.len() as u32
                }
                None => NONE,
            };
            words.extend_from_slice(&[
                m.symbol,
                pw,
                data,
                m.first_param,
                m.param_count,
                g.pred_bind_offset,
                g.pred_bind_words,
                m.salt,
            ]);
            k += 1;
        }
    }
    for w in consts.iter().flatten() {
        words.extend_from_slice(w);
    }
    let clamp = |x: u64| x.min(u64::from(u32::MAX)) as u32;
    for prev in &size[..steps as usize] {
        for c in succ.iter().flatten() {
            let (mut m, mut w) = (0u64, 0u64);
            for x in c.iter() {
                words.extend_from_slice(&[clamp(m), clamp(w)]);
                let (dm, dw) = prev[x.symbol as usize];
                m = m.saturating_add(dm);
                w = w.saturating_add(dw);
            }
        }
    }
    debug_assert_eq!(words.len(), base + need);
    let computed = consts.iter().any(Option::is_none);
    // The evaluations either way. Per symbol with a production, its
    // successor's slots as (symbol, computed); `reach[r][s]`: the final
    // modules of the expansion whose path below `s` is all computed slots
    // (their chains reach up to `s`).
    let mut kids: Vec<Option<Vec<(usize, u64)>>> = Vec::with_capacity(ns);
    let mut k = 0;
    for c in &succ {
        kids.push(c.map(|c| {
            c.iter()
                .map(|m| {
                    let one = u64::from(consts[k].is_none());
                    k += 1;
                    (m.symbol as usize, one)
                })
                .collect()
        }));
    }
    let (mut reach, mut walk, mut step) = (
        vec![vec![1u64; ns]],
        vec![vec![0u64; ns]],
        vec![vec![0u64; ns]],
    );
    for r in 1..=steps as usize {
        let (mut reach1, mut walk1, mut step1) = (vec![1u64; ns], vec![0u64; ns], vec![0u64; ns]);
        let below = &reach[r - 1];
        for (s, kid) in kids.iter().enumerate() {
            let Some(kid) = kid else { continue };
            let (mut a, mut d, mut e) = (0u64, 0u64, 0u64);
            for &(c, one) in kid {
                a = a.saturating_add(one.saturating_mul(below[c]));
                d = d.saturating_add(walk[r - 1][c].saturating_add(one.saturating_mul(below[c])));
                e = e.saturating_add(one.saturating_add(step[r - 1][c]));
            }
            (reach1[s], walk1[s], step1[s]) = (a, d, e);
        }
        reach.push(reach1);
        walk.push(walk1);
        step.push(step1);
    }
    if computed && !every_evaluation_walked(sys, &kids, &reach, steps)? {
        return None;
    }
    let slot_string = if computed {
        None
    } else {
        let mut st = ModuleString::with_capacity(slots, data);
        let mut p: Vec<f32> = Vec::new();
        for (m, w) in succ.iter().flatten().flat_map(|c| c.iter()).zip(&consts) {
            p.clear();
            p.extend(w.iter().flatten().map(|&x| f32::from_bits(x)));
            st.push(m.symbol, &p);
        }
        Some(st)
    };
    Some(Expansion {
        job,
        size,
        computed,
        walk_evals: walk,
        step_evals: step,
        succ: succ
            .iter()
            .map(|c| c.map(|c| c.iter().map(|m| m.symbol).collect()))
            .collect(),
        slot_string,
    })
}

/// Whether every computed successor slot that the stepwise derivation
/// evaluates is evaluated by some walk, so that a fault or non-finite value
/// anywhere in the derivation shows in the direct one's status. A walk
/// evaluates a computed slot only when the final module it leads to
/// descends from it through computed slots alone (`reach[r][c]`: how many
/// final modules a module of `c` with `r` steps left leads to that way).
/// A slot whose expansion is erased (`B(x) ->`), or reaches the final
/// string only through slots with constant parameters (`B(y) -> F`), is
/// evaluated by the stepwise derivation, which reports `B(sqrt(-2))`, but
/// by no walk: such a system is derived stepwise. Only the (symbol, steps
/// left) pairs the axiom's modules lead to are checked.
fn every_evaluation_walked(
    sys: &CompiledSystem,
    kids: &[Option<Vec<(usize, u64)>>],
    reach: &[Vec<u64>],
    steps: u32,
) -> Option<bool> {
    let ns = kids.len();
    let mut occurs = vec![false; ns];
    for m in succ_of(sys, sys.alts.get(sys.axiom_alt as usize)?)? {
        *occurs.get_mut(m.symbol as usize)? = true;
    }
    for r in (1..=steps as usize).rev() {
        let mut next = vec![false; ns];
        for (s, kid) in kids.iter().enumerate() {
            let Some(kid) = kid else { continue };
            if !occurs[s] {
                continue;
            }
            for &(c, one) in kid {
                if one == 1 && reach[r - 1][c] == 0 {
                    return Some(false);
                }
                next[c] = true;
            }
        }
        // A symbol without a production stays itself.
        for (s, kid) in kids.iter().enumerate() {
            if kid.is_none() && occurs[s] {
                next[s] = true;
            }
        }
        occurs = next;
    }
    Some(true)
}

/// The axiom when all its parameters are constants (the common case:
/// `axiom F(1) A`, meta-parameters folded): read from the tables, as the
/// CPU engine evaluates it, without building an engine (which verifies
/// every expression again: about 20 us for Hilbert 3D on the dev VM).
fn constant_axiom(sys: &CompiledSystem) -> Option<ModuleString> {
    let alt = sys.alts.get(sys.axiom_alt as usize)?;
    let mut out = ModuleString::new();
    let mut p: Vec<f32> = Vec::new();
    for m in succ_of(sys, alt)? {
        p.clear();
        let start = m.first_param as usize;
        let pes = sys
            .params
            .get(start..start.checked_add(m.param_count as usize)?)?;
        for pe in pes {
            if pe.kind != PARAM_CONST {
                return None;
            }
            let a = pe.a as usize;
            p.extend_from_slice(sys.consts.get(a..a.checked_add(pe.words as usize)?)?);
        }
        if p.len() != sys.symbols.get(m.symbol as usize)?.param_words as usize {
            return None;
        }
        out.push(m.symbol, &p);
    }
    Some(out)
}

/// Whether the code at `entry` runs without random draws (the walk has no
/// string positions to draw with); `None` when it does not decode.
fn draws_nothing(sys: &CompiledSystem, entry: u32) -> Option<bool> {
    let mut pc = entry as usize;
    loop {
        let (code, _) = decode(*sys.code.get(pc)?);
        let op = Op::from_code(code)?;
        if op.is_random() {
            return Some(false);
        }
        if op == Op::Ret {
            return Some(true);
        }
        pc += 1 + op.extra_words() as usize;
    }
}

impl DirectPlan {
    /// The plan for `jobs` taking `its` steps each with `seeds` (the
    /// derivation's last string is `k_max`), or `None` where a job's
    /// system does not qualify, its axiom fails on the CPU (the stepwise
    /// path reports it), or the string's positions do not fit 32 bits.
    pub(crate) fn new(
        jobs: &[GpuJob<'_>],
        its: &[u32],
        seeds: &[u32],
        k_max: usize,
        keyed: bool,
    ) -> Option<DirectPlan> {
        let mut words = Vec::new();
        let mut headers = Vec::with_capacity(jobs.len());
        // Jobs of the same system and steps (a forest of seeds) share tables.
        let mut made: Vec<(&CompiledSystem, u32, Expansion)> = Vec::new();
        let mut single = None;
        let mut computed = false;
        let (mut walk_evals, mut step_evals) = (0u64, 0u64);
        // One CPU engine per distinct system, for the axioms.
        let mut engines: Vec<grm_derive::Engine<'_>> = Vec::new();
        let mut axioms = ModuleString::new();
        let mut in_offs = Vec::new();
        let mut totals = vec![(0u64, 0u64); k_max + 1];
        let mut job_lens = Vec::with_capacity(jobs.len());
        let (mut pos, mut wpos) = (0u64, 0u64);
        for (j, ((job, &steps), &seed)) in jobs.iter().zip(its).zip(seeds).enumerate() {
            if steps > DIRECT_MAX_STEPS {
                return None;
            }
            let sys = job.system;
            let k = match made
                .iter()
                .position(|(s, r, ..)| std::ptr::eq(*s, sys) && *r == steps)
            {
                Some(k) => k,
                None => {
                    let x = expansion(sys, steps, &mut words)?;
                    computed |= x.computed;
                    made.push((sys, steps, x));
                    made.len() - 1
                }
            };
            let (_, _, x) = &made[k];
            let size = &x.size;
            headers.push(x.job);
            if jobs.len() == 1
                && let Some(st) = &x.slot_string
            {
                single = Some(SingleJob {
                    succ: x.succ.clone(),
                    slot_string: st.clone(),
                });
            }
            let axiom = match constant_axiom(sys) {
                Some(a) => a,
                None => {
                    let e = match engines.iter().position(|e| std::ptr::eq(e.system(), sys)) {
                        Some(e) => e,
                        None => {
                            engines.push(grm_derive::Engine::new(sys, 1).ok()?);
                            engines.len() - 1
                        }
                    };
                    engines[e].axiom(seed).ok()?
                }
            };
            let start = pos;
            // The axiom modules' identity keys (the CPU engine's: children
            // of the root key), where the derivation carries keys.
            let salts = succ_of(sys, sys.alts.get(sys.axiom_alt as usize)?)?;
            if keyed && salts.len() != axiom.len() {
                return None;
            }
            let root = sys.root_key(seed);
            for (i, (sym, p)) in axiom.iter().enumerate() {
                let s = sym as usize;
                let tagged = sym | ((j as u32) << SYS_SHIFT);
                if keyed {
                    axioms.push_keyed(tagged, p, child_key(root, salts[i].salt));
                } else {
                    axioms.push(tagged, p);
                }
                in_offs.push([u32::try_from(pos).ok()?, u32::try_from(wpos).ok()?]);
                let (m, w) = *size.get(steps as usize)?.get(s)?;
                walk_evals = walk_evals.saturating_add(x.walk_evals[steps as usize][s]);
                step_evals = step_evals.saturating_add(x.step_evals[steps as usize][s]);
                pos = pos.checked_add(m)?;
                wpos = wpos.checked_add(w)?;
                for (k, t) in totals.iter_mut().enumerate() {
                    let (m, w) = size[k.min(steps as usize)][s];
                    *t = (t.0.saturating_add(m), t.1.saturating_add(w));
                }
            }
            job_lens.push(pos - start);
        }
        // Positions and the thread after the last must fit 32 bits.
        if pos >= u64::from(u32::MAX) || wpos >= u64::from(u32::MAX) {
            return None;
        }
        in_offs.push([pos as u32, wpos as u32]);
        Some(DirectPlan {
            jobs: headers,
            words,
            axioms,
            in_offs,
            totals,
            job_lens,
            computed,
            walk_evals,
            step_evals,
            single,
        })
    }

    /// The final string's modules and parameter words.
    pub(crate) fn total(&self) -> (u64, u64) {
        self.totals.last().copied().unwrap_or((0, 0))
    }
}

impl GpuSystem<'_> {
    /// The direct plan for this derivation, or `None` where the stepwise
    /// paths must run: a system does not qualify, the CPU derives the
    /// whole string anyway (within [`GpuDeriveOptions::cpu_prefix`]), or a
    /// string of the stepwise derivation would be over a limit (the
    /// stepwise path then reports it exactly).
    pub(crate) fn direct_plan(&self, opts: &GpuDeriveOptions) -> Option<DirectPlan> {
        if opts.iterations == 0 {
            return None;
        }
        let its = self.job_iterations(opts);
        let seeds: Vec<u32> = if self.jobs.len() == 1 {
            vec![opts.seed]
        } else {
            self.jobs.iter().map(|j| j.seed).collect()
        };
        let plan = DirectPlan::new(
            &self.jobs,
            &its,
            &seeds,
            opts.iterations as usize,
            self.keyed,
        )?;
        let (total, total_words) = plan.total();
        if opts.cpu_prefix > 0 && total <= opts.cpu_prefix {
            return None;
        }
        // Walks that evaluate many more computed parameters than the
        // stepwise derivation (each final module its whole chain: the row
        // of trees at 10 steps, 10.5 million against 1.4 million) lose
        // what skipping the intermediate strings saves.
        if plan.walk_evals > DIRECT_MAX_EVAL_RATIO.saturating_mul(plan.step_evals) {
            return None;
        }
        // The stepwise derivation's limits, string by string (a string can
        // be longer than the final one: productions may erase).
        for (k, &(m, w)) in plan.totals.iter().enumerate().skip(1) {
            let (n, nw) = plan.totals[k - 1];
            let bytes = self.string_bytes(n, nw) + 8 * (n + 1) + 4 * n + self.string_bytes(m, w);
            if m > opts.max_modules || bytes > opts.max_bytes {
                return None;
            }
        }
        let gpu = self.gpu;
        let fits = |what, b| gpu.check_storage(what, b).is_ok();
        let ok = fits("output symbols", 4 * total)
            && fits("output parameter starts", 4 * (total + 1))
            && fits("output parameters", 4 * total_words)
            && (!self.keyed || fits("output identity keys", 4 * total))
            && fits("expansion tables", 4 * plan.words.len() as u64)
            && gpu.grid("expand", groups_for(total + 1)).is_ok();
        ok.then_some(plan)
    }

    /// Run a direct derivation: one dispatch, one wait (none when `wait`
    /// is false and no device timestamps are taken: with computed
    /// parameters the status is then the caller's to read; the flag
    /// returned says whether it waited). `None`: a computed parameter faulted or was not finite;
    /// nothing is returned and the caller derives stepwise, which reports
    /// the error exactly.
    #[allow(clippy::type_complexity)]
    pub(crate) fn derive_direct(
        &self,
        plan: &DirectPlan,
        opts: &GpuDeriveOptions,
        wait: bool,
    ) -> Result<Option<(DeviceString, Vec<GpuIterationStats>, bool)>, GpuError> {
        let t = Instant::now();
        let gpu = self.gpu;
        let (total, total_words) = plan.total();
        let out = self.alloc_string(total, total_words)?;
        let ax = plan.axioms.parts();
        // Everything the kernel reads, in one upload: each part at an
        // aligned offset of one pooled buffer (one write, one binding
        // range each).
        let parts: [&[u8]; 7] = [
            bytemuck::cast_slice(&plan.jobs),
            bytemuck::cast_slice(&plan.words),
            bytemuck::cast_slice(&ax.syms),
            bytemuck::cast_slice(&ax.starts),
            bytemuck::cast_slice(&ax.params),
            bytemuck::cast_slice(&plan.in_offs),
            // The axiom modules' identity keys (empty without keys).
            bytemuck::cast_slice(ax.keys),
        ];
        let align = gpu.storage_offset_alignment() as usize;
        let mut packed: Vec<u8> = Vec::new();
        let mut at = Vec::with_capacity(parts.len());
        for part in parts {
            let start = packed.len();
            // An empty part still binds 16 bytes.
            let len = part.len().max(16);
            packed.extend_from_slice(part);
            packed.resize(start + len, 0);
            at.push((start as u64, Some(len as u64)));
            packed.resize(packed.len().next_multiple_of(align), 0);
        }
        let input = gpu.storage("direct derivation input", packed.len() as u64)?;
        gpu.queue().write_buffer(&input, 0, &packed);
        let status = gpu.storage("direct status", 4)?;
        gpu.queue().write_buffer(&status, 0, &[0u8; 4]);
        let params = gpu.uniform(
            "expand params",
            &ExpandParams {
                n_in: plan.axioms.len() as u32,
                total: total as u32,
                total_words: total_words as u32,
                keyed: u32::from(self.keyed),
            },
        );
        let mut bufs: Vec<(&wgpu::Buffer, u64, Option<u64>)> = vec![(&params, 0, None)];
        bufs.extend(at[..6].iter().map(|&(o, n)| (&input, o, n)));
        bufs.extend([
            (&out.syms, 0, None),
            (&out.starts, 0, None),
            (&out.params, 0, None),
        ]);
        let kernel = if plan.computed {
            bufs.extend([(&self.tables, 0, None), (&status, 0, None)]);
            &kernels::EXPAND_VM
        } else {
            &kernels::EXPAND
        };
        bufs.extend([(&input, at[6].0, at[6].1), (self.keys_of(&out, 1), 0, None)]);
        let bound = gpu.bound_ranges(kernel, &bufs)?;
        let grid = gpu.grid("expand", groups_for(total + 1))?;
        // Profiling: one pass; the kernel is the "rewrite" stage (the
        // stages before it, count, scan and next, are empty).
        let stamps = Stamps::new(gpu, 1);
        let mut enc = gpu.encoder();
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("direct derivation"),
                timestamp_writes: stamps.as_ref().and_then(|s| s.pass_writes(0)),
            });
            if let Some(s) = &stamps {
                for stage in 0..3 {
                    s.after_stage(&mut pass, 0, stage);
                }
            }
            bound.dispatch(&mut pass, grid);
            if let Some(s) = &stamps {
                s.after_stage(&mut pass, 0, 3);
            }
        }
        // One wait: the status (computed parameters can fail) and the
        // stamps, read together. Not waited for (`wait` false, no stamps):
        // the status is left for the caller to read with its own results
        // (`GpuSystem::take_pending_status`).
        let defer = !wait && plan.computed && stamps.is_none();
        let mut ranges = Vec::new();
        if plan.computed && !defer {
            ranges.push((&status, 0, 1));
        }
        if let Some(s) = &stamps {
            s.resolve(&mut enc);
            let (buf, n) = s.readback();
            ranges.push((buf, 0, n));
        }
        let waited = wait || !ranges.is_empty();
        let (failed, device) = if ranges.is_empty() {
            if wait {
                gpu.submit_wait(enc)?;
            } else {
                gpu.submit(enc);
            }
            (false, Vec::new())
        } else {
            let words = gpu.read::<u32>(enc, &ranges)?;
            let mut words = words.iter();
            let failed = plan.computed && words.next().is_none_or(|w| w.iter().any(|&x| x != 0));
            let device = match (&stamps, words.next()) {
                (Some(s), Some(w)) => s.times(w),
                _ => Vec::new(),
            };
            (failed, device)
        };
        let elapsed = t.elapsed();
        gpu.recycle([input]);
        if defer {
            self.pending_status.replace(Some(status));
        } else {
            gpu.recycle([status]);
        }
        if failed {
            gpu.recycle(out.into_buffers());
            return Ok(None);
        }
        // The directory: each job's range in the final string.
        let mut dir: Vec<SystemEntry> = self.directory.clone();
        let mut start = 0u64;
        for (e, &n) in dir.iter_mut().zip(&plan.job_lens) {
            e.start = start as u32;
            start += n;
            e.end = start as u32;
        }
        if let [one] = &mut dir[..] {
            *one = self.single_entry(one, opts);
        }
        gpu.queue()
            .write_buffer(&self.tables, 0, bytemuck::cast_slice(&dir));
        self.final_directory.replace(Some(dir));
        let last = plan.totals.len() - 1;
        let stats = plan
            .totals
            .iter()
            .enumerate()
            .map(|(k, &(m, w))| GpuIterationStats {
                iteration: k as u32,
                modules: m,
                param_words: w,
                elapsed: if k == last {
                    elapsed
                } else {
                    std::time::Duration::ZERO
                },
                device: if k == last {
                    device.first().copied()
                } else {
                    None
                },
                on_cpu: false,
            })
            .collect();
        Ok(Some((out, stats, waited)))
    }
}

impl GpuSystem<'_> {
    /// The bones of the last derivation when it ran directly, for one job
    /// with constant parameters and affine commands (brackets balanced in
    /// every successor; `shaders/expand_turtle.wgsl`): from the expansion
    /// tables, without
    /// reading the string. `None` where that does not hold (the caller
    /// interprets the string). One submission, one wait.
    pub(crate) fn interpret_direct(
        &self,
        program: &TurtleProgram,
    ) -> Result<Option<(wgpu::Buffer, u64, GpuInterpretation)>, GpuError> {
        let t0 = Instant::now();
        let guard = self.direct.borrow();
        let Some(plan) = guard.as_ref() else {
            return Ok(None);
        };
        let (Some(one), [job]) = (&plan.single, &plan.jobs[..]) else {
            return Ok(None);
        };
        if program.walks() {
            return Ok(None);
        }
        let ns = one.succ.len();
        let steps = job.steps as usize;
        let slots = one.slot_string.len();
        let n_ax = plan.axioms.len();
        if ns != program.syms.len() || n_ax == 0 {
            return Ok(None);
        }
        // Brackets: none with a production, every successor and the axiom
        // balanced within the table kernel's stack.
        let op = |s: u32| program.syms.get(s as usize).map(|t| t.op);
        let (push, pop) = (TurtleOp::Push as u32, TurtleOp::Pop as u32);
        let balanced = |seq: &mut dyn Iterator<Item = u32>| {
            let mut depth = 0u32;
            for s in seq {
                match op(s) {
                    Some(o) if o == push => depth += 1,
                    Some(o) if o == pop => match depth.checked_sub(1) {
                        Some(d) => depth = d,
                        None => return false,
                    },
                    Some(_) => {}
                    None => return false,
                }
                if depth > DIRECT_TURTLE_STACK {
                    return false;
                }
            }
            depth == 0
        };
        let brackets_ok = one.succ.iter().enumerate().all(|(s, c)| match c {
            Some(c) => {
                let o = op(s as u32);
                o != Some(push) && o != Some(pop) && balanced(&mut c.iter().copied())
            }
            None => true,
        }) && balanced(&mut plan.axioms.symbols().map(|x| x & SYM_MASK));
        if !brackets_ok {
            return Ok(None);
        }
        // Bone counts: per step and symbol the `F`s of its expansion ...
        let is_f = |s: usize| u64::from(program.syms[s].op == TurtleOp::Forward as u32);
        let mut f = vec![(0..ns).map(is_f).collect::<Vec<u64>>()];
        for r in 1..=steps {
            let row = (0..ns)
                .map(|s| match &one.succ[s] {
                    Some(c) => c
                        .iter()
                        .fold(0u64, |a, &t| a.saturating_add(f[r - 1][t as usize])),
                    None => is_f(s),
                })
                .collect();
            f.push(row);
        }
        // ... the table: productions, per step the bones before each slot
        // in its predecessor's expansion, per axiom module the bones and
        // modules before its expansion.
        let mut ft: Vec<u32> = one.succ.iter().map(|c| u32::from(c.is_some())).collect();
        let f_pre = ft.len();
        for prev in &f[..steps] {
            for c in one.succ.iter().flatten() {
                let mut at = 0u64;
                for &t in c {
                    ft.push(u32::try_from(at).ok().unwrap_or(u32::MAX));
                    at = at.saturating_add(prev[t as usize]);
                }
            }
        }
        let f_top = ft.len();
        let mut at = 0u64;
        for sym in plan.axioms.symbols() {
            ft.push(u32::try_from(at).unwrap_or(u32::MAX));
            at = at.saturating_add(f[steps][(sym & SYM_MASK) as usize]);
        }
        let bones = at;
        if bones >= u64::from(u32::MAX) {
            return Ok(None);
        }
        ft.push(bones as u32);
        let m_top = ft.len();
        ft.extend(plan.in_offs[..n_ax].iter().map(|o| o[0]));
        // The slot string, then the axiom modules.
        let mut st = one.slot_string.clone();
        for (sym, p) in plan.axioms.iter() {
            st.push(sym, p);
        }
        let net_n = (slots + n_ax) as u64;
        let net_p = net_n + (steps * ns) as u64;
        let net_ax = net_p + (steps * slots) as u64;
        let nets_len = net_ax + n_ax as u64;
        let gpu = self.gpu;
        let elem = std::mem::size_of::<TurtleElem>() as u64;
        let bone_bytes = std::mem::size_of::<GpuBone>() as u64;
        if gpu
            .check_storage("direct turtle tables", elem * nets_len)
            .is_err()
            || gpu.check_storage("bones", bone_bytes * bones).is_err()
        {
            return Ok(None);
        }
        let x = ExpandTurtleParams {
            symbols: job.symbols,
            slots: job.slots,
            offsets: job.offsets,
            slot_count: job.slot_count,
            steps: job.steps,
            nsym: ns as u32,
            n_ax: n_ax as u32,
            bones: bones as u32,
            net_n: net_n as u32,
            net_p: net_p as u32,
            net_ax: net_ax as u32,
            f_pre: f_pre as u32,
            f_top: f_top as u32,
            m_top: m_top as u32,
            ..ExpandTurtleParams::default()
        };
        let u = gpu.uniform("direct turtle params", &x);
        // Pooled buffers, written (nothing is created in a repeated run but
        // the parameters).
        let put = |what, data: &[u8]| -> Result<wgpu::Buffer, GpuError> {
            let b = gpu.storage(what, data.len() as u64)?;
            if !data.is_empty() {
                gpu.queue().write_buffer(&b, 0, data);
            }
            Ok(b)
        };
        let st = st.parts();
        let syms = put("slot symbols", bytemuck::cast_slice(&st.syms))?;
        let starts = put("slot parameter starts", bytemuck::cast_slice(&st.starts))?;
        let params = put("slot parameters", bytemuck::cast_slice(&st.params))?;
        let tables = turtle_tables(&[program]);
        let tsyms = put("turtle commands", bytemuck::cast_slice(&tables))?;
        let xt = put("expansion tables", bytemuck::cast_slice(&plan.words))?;
        let ftb = put("direct bone counts", bytemuck::cast_slice(&ft))?;
        let nets = gpu.storage("direct turtle tables", elem * nets_len)?;
        let out = gpu.storage("bones", bone_bytes * bones)?;
        let b = [&u, &syms, &starts, &params, &tsyms, &xt, &ftb, &nets, &out];
        let mut enc = gpu.encoder();
        gpu.dispatch(&mut enc, &kernels::EXPAND_NETS, &b, 1)?;
        gpu.dispatch(&mut enc, &kernels::EXPAND_BONES, &b, groups_for(bones))?;
        gpu.submit_wait(enc)?;
        gpu.recycle([nets, syms, starts, params, tsyms, xt, ftb]);
        let interp = GpuInterpretation {
            bone_count: bones,
            direct: true,
            elapsed: t0.elapsed(),
            ..GpuInterpretation::default()
        };
        Ok(Some((out, bones, interp)))
    }
}

//! GPU derivation: count / scan / rewrite per iteration (Lipp 5.2.2) on a
//! compiled system's packed tables.
//!
//! Per iteration, on the device: (bracket matching for context-sensitive
//! systems) -> `count` -> scan of the (modules, words) pairs -> read back the
//! totals and the error status (the one synchronisation of an iteration:
//! the next buffers' sizes depend on it) -> check the limits -> allocate
//! -> `rewrite`. The string stays on the device between iterations.
//!
//! Batched (the default when nothing needs the iterations one by one): an
//! upper bound of every string's length is computed on the host from the
//! tables, the buffers are sized from it, and all iterations are recorded
//! into one submission (one per `BATCH_SUBMIT_ITERATIONS` for long
//! derivations) whose dispatch sizes are written on the device
//! (`shaders/batch.wgsl`, indirect dispatches); the totals, an overflow
//! flag and the error status are read back once at the end. Where the
//! bound is over a limit, or the batched run reports an error or an
//! overflow, the derivation runs (again) iteration by iteration, which
//! gives the exact error.
//!
//! Direct (deterministic, context-free systems; `direct.rs`): the final
//! string in one dispatch, each output module found by walking down the
//! derivation tree, whose shape the host computes from the tables; no
//! intermediate string.
//!
//! A loosely bounded (stochastic) system after a CPU prefix of at least
//! [`PROJECT_MIN_MODULES`] modules is batched with buffers sized from its
//! expected sizes; an overflow reruns it iteration by iteration.

use std::time::{Duration, Instant};

/// Iterations recorded into one submission of a batched derivation before
/// it is submitted and waited for (bounds the host memory of the recorded
/// commands; one wait per chunk costs nothing next to a chunk's work).
const BATCH_SUBMIT_ITERATIONS: u32 = 1024;

use grm_compile::CompiledSystem;
use grm_derive::ModuleString;

use crate::brackets;
use crate::device::{Bound, Gpu, groups_for};
use crate::error::{GpuError, RuntimeKind};
use crate::kernels;
use crate::layout::{
    BatchParams, DeriveParams, ERR_BAD_WEIGHT, ERR_FAULT, ERR_NON_FINITE, MAX_BIND_WORDS,
    MAX_SYSTEMS, SCAN_BLOCK, STATUS_WORDS, SYM_MASK, SYS_SHIFT, SystemEntry,
};
use crate::scan::{ScanElem, record_scan};
use crate::stamps::{DeviceTime, Stamps};

mod batched;
mod bounds;
mod direct;
mod step;
pub use crate::layout::DIRECT_MAX_STEPS;
use bounds::{BatchPlan, exact_symbol, growth_row, scan_levels, succ_of};
pub use direct::DIRECT_MAX_EVAL_RATIO;

/// How to run a GPU derivation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GpuDeriveOptions {
    /// Rewriting steps.
    pub iterations: u32,
    /// The seed of every random draw.
    pub seed: u32,
    /// The most modules a derived string may have.
    pub max_modules: u64,
    /// The most device memory one iteration may use (input, scratch and
    /// output buffers together), in bytes. The device's own limits apply
    /// in any case.
    pub max_bytes: u64,
    /// Wait for every iteration to finish before the next starts, so that
    /// each iteration's elapsed time is its own (benchmarks). Otherwise an
    /// iteration's rewrite overlaps the next iteration's host work.
    pub sync_iterations: bool,
    /// Derive the first iterations on the CPU (`grm-derive`, one thread)
    /// while the next string is bounded by this many modules, then upload
    /// the string and go on on the GPU; 0: every iteration on the GPU.
    /// Small strings cost the CPU microseconds and the GPU a chain of
    /// latency-bound dispatches; the result is the same string either way
    /// (the engines agree module for module). [`CPU_PREFIX_MODULES`] by
    /// default.
    pub cpu_prefix: u64,
    /// Carry every module's identity key even when no system draws random
    /// numbers (a system that draws carries them anyway): the strings
    /// read back then have the CPU engine's keys (`grm_derive::Engine::
    /// with_keys`), e.g. for a glb's part table. Costs a key buffer beside
    /// each string. The free functions ([`derive()`], [`derive_with`],
    /// [`derive_many`], `run`, `run_many`) load the systems so; a
    /// [`GpuSystem`] must be loaded with [`GpuSystem::load_with`] to derive
    /// with it.
    pub keys: bool,
}

/// The default [`GpuDeriveOptions::cpu_prefix`]: strings of up to 32,768
/// modules are derived on the CPU (at 350-1,300 modules/us on one thread,
/// at most about 0.1 ms for all of them together; docs/gpu.md).
pub const CPU_PREFIX_MODULES: u64 = 32_768;

impl GpuDeriveOptions {
    /// The system's settings (iterations, seed); limits as the CPU engine's
    /// defaults (50 million modules, 2 GiB).
    pub fn from_system(sys: &CompiledSystem) -> GpuDeriveOptions {
        let cpu = grm_derive::DeriveLimits::default();
        GpuDeriveOptions {
            iterations: sys.settings.iterations,
            seed: sys.settings.seed,
            max_modules: cpu.max_modules,
            max_bytes: cpu.max_bytes,
            sync_iterations: false,
            cpu_prefix: CPU_PREFIX_MODULES,
            keys: false,
        }
    }
}

/// Figures of one string of a GPU derivation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GpuIterationStats {
    /// 0 is the axiom, `k` the string after `k` steps.
    pub iteration: u32,
    pub modules: u64,
    pub param_words: u64,
    /// Wall time of this step on the host, including its synchronisation.
    pub elapsed: Duration,
    /// The step's kernels on the device, from timestamps (batched
    /// derivations on devices that write them; `None` otherwise).
    pub device: Option<DeviceTime>,
    /// This string was derived on the CPU ([`GpuDeriveOptions::cpu_prefix`]).
    pub on_cpu: bool,
}

/// A module string that lives on the device.
#[derive(Debug)]
pub struct DeviceString {
    pub(crate) syms: wgpu::Buffer,
    pub(crate) starts: wgpu::Buffer,
    pub(crate) params: wgpu::Buffer,
    /// The modules' identity keys, where the derivation carries them (some
    /// system draws random numbers; `grm_compile::rng`, "Identity keys").
    pub(crate) keys: Option<wgpu::Buffer>,
    pub(crate) len: u64,
    pub(crate) words: u64,
}

impl DeviceString {
    pub fn len(&self) -> u64 {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    pub fn param_words(&self) -> u64 {
        self.words
    }

    /// The buffers (to recycle them).
    pub(crate) fn into_buffers(self) -> impl IntoIterator<Item = wgpu::Buffer> {
        [self.syms, self.starts, self.params]
            .into_iter()
            .chain(self.keys)
    }

    /// Whether the string carries identity keys.
    pub fn has_keys(&self) -> bool {
        self.keys.is_some()
    }

    /// Device bytes of the arrays (the keys included).
    pub fn bytes(&self) -> u64 {
        string_bytes(self.len, self.words) + key_bytes(self.len, self.keys.is_some())
    }

    /// Upload a host string (checked against the system: symbols in range,
    /// parameter words as the symbols declare), with its identity keys
    /// where it carries them.
    pub fn upload(
        gpu: &Gpu,
        sys: &CompiledSystem,
        s: &ModuleString,
    ) -> Result<DeviceString, GpuError> {
        check_string(sys, s)?;
        let p = s.parts();
        let keys = if s.has_keys() && !s.is_empty() {
            Some(gpu.upload("identity keys", p.keys)?)
        } else {
            None
        };
        Ok(DeviceString {
            syms: gpu.upload("symbols", &p.syms)?,
            starts: gpu.upload("parameter starts", &p.starts)?,
            params: gpu.upload("parameters", &p.params)?,
            keys,
            len: s.len() as u64,
            words: p.params.len() as u64,
        })
    }

    /// Read the string back (records the copies into a fresh submission),
    /// its identity keys with it where it carries them.
    pub(crate) fn read(&self, gpu: &Gpu) -> Result<ModuleString, GpuError> {
        let enc = gpu.encoder();
        let mut ranges = vec![(&self.syms, 0, self.len), (&self.starts, 0, self.len + 1)];
        if let Some(k) = &self.keys {
            ranges.push((k, 0, self.len));
        }
        let mut u = gpu.read::<u32>(enc, &ranges)?;
        let keys = if self.keys.is_some() {
            u.pop().unwrap_or_default()
        } else {
            Vec::new()
        };
        let starts = u.pop().unwrap_or_default();
        let syms = u.pop().unwrap_or_default();
        let params = if self.words > 0 {
            gpu.read::<f32>(gpu.encoder(), &[(&self.params, 0, self.words)])?
                .pop()
                .unwrap_or_default()
        } else {
            Vec::new()
        };
        let s = ModuleString::from_parts(syms, starts, params, keys);
        if !s.is_well_formed() {
            if std::env::var_os("GRM_DEBUG_STRING").is_some() {
                let p = s.parts();
                let (syms, starts, params) = (&p.syms, &p.starts, &p.params);
                let bad = (0..syms.len())
                    .find(|&i| starts.get(i + 1) < starts.get(i))
                    .unwrap_or(0);
                let lo = bad.saturating_sub(3);
                let from = starts.get(lo).map_or(0, |&x| x as usize).min(params.len());
                eprintln!(
                    "DEBUG len {} words {} first bad {bad}: syms {:?} starts {:?} params {:?}",
                    syms.len(),
                    params.len(),
                    &syms[lo.min(syms.len())..(bad + 4).min(syms.len())],
                    &starts[lo.min(starts.len())..(bad + 5).min(starts.len())],
                    &params[from..(from + 6).min(params.len())]
                );
                eprintln!(
                    "DEBUG tail starts {:?}",
                    &starts[starts.len().saturating_sub(4)..]
                );
            }
            return Err(GpuError::Readback(
                "the derived string breaks its invariant".into(),
            ));
        }
        Ok(s)
    }
}

fn string_bytes(modules: u64, words: u64) -> u64 {
    4 * modules + 4 * (modules + 1) + 4 * words
}

/// Device bytes of a string's identity keys (`keyed`: it carries them).
fn key_bytes(modules: u64, keyed: bool) -> u64 {
    if keyed { 4 * modules } else { 0 }
}

/// Check a host string against the system.
pub(crate) fn check_string(sys: &CompiledSystem, s: &ModuleString) -> Result<(), GpuError> {
    if !s.is_well_formed() {
        return Err(GpuError::InvalidInput(
            "the module string breaks its invariant".into(),
        ));
    }
    for (i, (sym, p)) in s.iter().enumerate() {
        let Some(e) = sys.symbols.get(sym as usize) else {
            return Err(GpuError::InvalidInput(format!(
                "module {i}: symbol {sym} is not in the system"
            )));
        };
        if p.len() as u32 != e.param_words {
            return Err(GpuError::InvalidInput(format!(
                "module {i}: {} parameter words, its symbol has {}",
                p.len(),
                e.param_words
            )));
        }
    }
    Ok(())
}

/// The buffers of one derivation dispatch.
struct Pass<'b> {
    input: &'b DeviceString,
    mate: &'b wgpu::Buffer,
    counts: &'b wgpu::Buffer,
    choice: &'b wgpu::Buffer,
    out: &'b DeviceString,
    status: &'b wgpu::Buffer,
}

/// One system of a multi-system derivation (Lipp 5.4): its tables, how
/// many iterations it takes and its seed.
#[derive(Clone, Copy, Debug)]
pub struct GpuJob<'a> {
    pub system: &'a CompiledSystem,
    pub iterations: u32,
    pub seed: u32,
}

/// Compiled systems loaded on the device, ready to derive together.
#[derive(Debug)]
pub struct GpuSystem<'a> {
    gpu: &'a Gpu,
    jobs: Vec<GpuJob<'a>>,
    /// The directory (one `SystemEntry` per job) followed by each
    /// system's packed tables.
    pub(crate) tables: wgpu::Buffer,
    /// The directory as uploaded (string 0's ranges).
    directory: Vec<SystemEntry>,
    has_context: bool,
    /// The strings carry identity keys: some job's system draws random
    /// numbers (`CompiledSystem::draws_randomly`; every module of the
    /// combined string then has its key, the draws are keyed by them).
    keyed: bool,
    /// Per job: its string read back carries keys (its system draws, as
    /// the CPU engine's strings do).
    job_keyed: Vec<bool>,
    /// Bound in place of the key buffers of a derivation without keys
    /// (input, output: one buffer may not be bound both ways).
    no_keys: [wgpu::Buffer; 2],
    /// Some successor other than an axiom is longer than
    /// [`kernels::LONG_SUCCESSOR`] modules.
    long_successors: bool,
    /// The count and rewrite kernels: compiled without the bytecode
    /// interpreter when no system's tables hold code (computed weights,
    /// conditions or successor parameters), without context matching
    /// when no group has a context.
    kernels: &'static kernels::DeriveKernels,
    /// The plan of the last derivation when it ran directly (its tables
    /// serve the direct interpretation).
    direct: std::cell::RefCell<Option<direct::DirectPlan>>,
    /// The directory after the last derivation, where it knew it without
    /// a read of its own ([`GpuSystem::read_directory`]).
    final_directory: std::cell::RefCell<Option<Vec<SystemEntry>>>,
    /// The status word of a direct derivation with computed parameters
    /// that was not waited for: nonzero where a value faulted or was not
    /// finite (its string is then not to be used).
    pending_status: std::cell::RefCell<Option<wgpu::Buffer>>,
}

/// The result of [`derive()`].
#[derive(Clone, Debug)]
pub struct GpuDerivation {
    pub string: ModuleString,
    /// One entry per string: the axiom, then each step.
    pub stats: Vec<GpuIterationStats>,
}

/// Derive on the GPU and read the final string back.
pub fn derive(
    gpu: &Gpu,
    sys: &CompiledSystem,
    opts: &GpuDeriveOptions,
) -> Result<GpuDerivation, GpuError> {
    gpu.run(|| {
        let job = GpuJob {
            system: sys,
            iterations: opts.iterations,
            seed: opts.seed,
        };
        let g = GpuSystem::load_with(gpu, &[job], opts.keys)?;
        let (s, stats) = g.derive(opts, &mut |_| {})?;
        Ok(GpuDerivation {
            string: s.read(gpu)?,
            stats,
        })
    })
}

/// The result of [`derive_many`].
#[derive(Clone, Debug)]
pub struct GpuManyDerivation {
    /// Each job's final string, in job order.
    pub strings: Vec<ModuleString>,
    /// The combined string's figures: the axioms, then each step.
    pub stats: Vec<GpuIterationStats>,
}

/// Derive several systems (or one system with several seeds) in the same
/// dispatches: one combined string, each module reading its own system's
/// tables (Lipp 5.4). Each job's string is what deriving it alone gives.
/// `opts.iterations` and `opts.seed` are ignored (each job has its own);
/// the limits apply to the combined string.
pub fn derive_many(
    gpu: &Gpu,
    jobs: &[GpuJob<'_>],
    opts: &GpuDeriveOptions,
) -> Result<GpuManyDerivation, GpuError> {
    gpu.run(|| {
        let g = GpuSystem::load_with(gpu, jobs, opts.keys)?;
        let o = many_options(jobs, opts);
        let (s, stats) = g.derive(&o, &mut |_| {})?;
        let all = s.read(gpu)?;
        let dir = g.read_directory()?;
        gpu.recycle(s.into_buffers());
        Ok(GpuManyDerivation {
            strings: split_string(&all, &dir, &g.job_keyed)?,
            stats,
        })
    })
}

/// The options of a derivation of `jobs`: the most iterations of any
/// job; and, for one job, its own seed (a derivation of one system takes
/// the options' seed, and a forest of one tree was derived with seed 0
/// whatever its own).
pub(crate) fn many_options(jobs: &[GpuJob<'_>], opts: &GpuDeriveOptions) -> GpuDeriveOptions {
    GpuDeriveOptions {
        iterations: jobs.iter().map(|j| j.iterations).max().unwrap_or(0),
        seed: match jobs {
            [one] => one.seed,
            _ => opts.seed,
        },
        ..*opts
    }
}

/// Cut a combined string into its systems' strings (symbols without the
/// system bits); a system's string carries its modules' identity keys
/// where `keyed[k]` says so (and the combined string has them).
pub(crate) fn split_string(
    all: &ModuleString,
    dir: &[SystemEntry],
    keyed: &[bool],
) -> Result<Vec<ModuleString>, GpuError> {
    let mut strings = Vec::with_capacity(dir.len());
    let with_keys = all.has_keys() && !all.keys().is_empty();
    for (k, e) in dir.iter().enumerate() {
        let (a, b) = (e.start as usize, e.end as usize);
        if a > b || b > all.len() {
            return Err(GpuError::Readback(
                "a system's range is outside the string".into(),
            ));
        }
        let words = (a..b).map(|i| all.params_of(i).len()).sum();
        let mut one = ModuleString::with_capacity(b - a, words);
        if with_keys && keyed.get(k).copied().unwrap_or(false) {
            let keys = &all.keys()[a..b];
            for (i, &key) in (a..b).zip(keys) {
                let (sym, p) = all.get(i);
                one.push_keyed(sym & SYM_MASK, p, key);
            }
        } else {
            for i in a..b {
                let (sym, p) = all.get(i);
                one.push(sym & SYM_MASK, p);
            }
        }
        strings.push(one);
    }
    Ok(strings)
}

impl Drop for GpuSystem<'_> {
    /// The placeholder key buffers go back to the pool (taken from it
    /// at every load, they would otherwise take a pooled buffer another
    /// request of a repeated run needs).
    fn drop(&mut self) {
        self.gpu.recycle(self.no_keys.iter().cloned());
    }
}

impl<'a> GpuSystem<'a> {
    /// Validate and upload the tables of `jobs`. Must run inside `Gpu::run`.
    /// The strings carry identity keys where some system draws random
    /// numbers.
    pub fn load(gpu: &'a Gpu, jobs: &[GpuJob<'a>]) -> Result<GpuSystem<'a>, GpuError> {
        Self::load_with(gpu, jobs, false)
    }

    /// [`GpuSystem::load`]; with `keys` every job's string carries its
    /// modules' identity keys, whether its system draws or not
    /// ([`GpuDeriveOptions::keys`]).
    pub fn load_with(
        gpu: &'a Gpu,
        jobs: &[GpuJob<'a>],
        keys: bool,
    ) -> Result<GpuSystem<'a>, GpuError> {
        if jobs.is_empty() || jobs.len() > MAX_SYSTEMS {
            return Err(GpuError::InvalidInput(format!(
                "{} systems: one derivation takes 1 to {MAX_SYSTEMS}",
                jobs.len()
            )));
        }
        let dir_words = jobs.len() * std::mem::size_of::<SystemEntry>() / 4;
        let mut words: Vec<u32> = vec![0; dir_words];
        let mut directory = Vec::with_capacity(jobs.len());
        let mut start = 0u64;
        for job in jobs {
            let sys = job.system;
            sys.validate()
                .map_err(|e| GpuError::InvalidInput(e.to_string()))?;
            let widest = sys.symbols.iter().map(|s| s.param_words).max().unwrap_or(0);
            if sys.max_bind_words > MAX_BIND_WORDS || widest > MAX_BIND_WORDS {
                return Err(GpuError::Unsupported(format!(
                    "productions binding more than {MAX_BIND_WORDS} parameter words (this system binds {})",
                    sys.max_bind_words.max(widest)
                )));
            }
            if sys.symbols.len() > SYM_MASK as usize {
                return Err(GpuError::Unsupported(format!(
                    "more than {SYM_MASK} symbols in one system"
                )));
            }
            let axiom = sys
                .alts
                .get(sys.axiom_alt as usize)
                .ok_or_else(|| GpuError::InvalidInput("no axiom".into()))?;
            let end = start + u64::from(axiom.succ_len);
            directory.push(SystemEntry {
                base: words.len() as u32,
                iterations: job.iterations,
                seed: job.seed,
                root_key: sys.root_key(job.seed),
                start: start as u32,
                end: end as u32,
                ..SystemEntry::default()
            });
            start = end;
            words.extend_from_slice(&sys.pack());
        }
        words[..dir_words].copy_from_slice(bytemuck::cast_slice(&directory));
        let tables = gpu.upload("tables", &words)?;
        let has_code = jobs.iter().any(|j| !j.system.code.is_empty());
        let has_context = jobs.iter().any(|j| j.system.has_context());
        // (The axiom is written one module per thread anyway.)
        let long_successors = jobs.iter().any(|j| {
            let sys = j.system;
            (sys.alts.iter().enumerate())
                .any(|(k, a)| k != sys.axiom_alt as usize && a.succ_len > kernels::LONG_SUCCESSOR)
        });
        let job_keyed: Vec<bool> = jobs
            .iter()
            .map(|j| keys || j.system.draws_randomly())
            .collect();
        Ok(GpuSystem {
            gpu,
            has_context,
            keyed: job_keyed.iter().any(|&k| k),
            job_keyed,
            no_keys: [gpu.storage("unused", 16)?, gpu.storage("unused", 16)?],
            long_successors,
            kernels: kernels::DeriveKernels::pick(has_code, has_context),
            jobs: jobs.to_vec(),
            tables,
            directory,
            direct: std::cell::RefCell::new(None),
            final_directory: std::cell::RefCell::new(None),
            pending_status: std::cell::RefCell::new(None),
        })
    }

    /// Whether the count and rewrite kernels carry the bytecode
    /// interpreter: some system's tables hold code. Systems whose weights,
    /// conditions and successor parameters are all constants or copies
    /// derive with kernels compiled without it.
    pub fn interprets_code(&self) -> bool {
        self.kernels.interprets_code()
    }

    /// Whether the count kernel matches contexts: some system's groups
    /// have them (the others derive with kernels compiled without).
    pub fn matches_contexts(&self) -> bool {
        self.kernels.matches_contexts()
    }

    /// The status buffer the last derivation left unread (see
    /// `pending_status`), for the caller to read with its own results.
    pub(crate) fn take_pending_status(&self) -> Option<wgpu::Buffer> {
        self.pending_status.replace(None)
    }

    /// The directory as it is on the device now: as the last derivation
    /// left it where that derivation knew it (a direct one computes it on
    /// the host, a batched one reads it with its totals), else read back.
    pub(crate) fn read_directory(&self) -> Result<Vec<SystemEntry>, GpuError> {
        if let Some(d) = self.final_directory.borrow().as_ref() {
            return Ok(d.clone());
        }
        let n = self.jobs.len() as u64;
        Ok(self
            .gpu
            .read::<SystemEntry>(self.gpu.encoder(), &[(&self.tables, 0, n)])?
            .pop()
            .unwrap_or_default())
    }

    /// Run the derivation; the final string stays on the device.
    /// `progress` sees every string's figures as soon as they are known
    /// (in a batched derivation, all of them at the end, the whole time
    /// counted as the last string's).
    pub fn derive(
        &self,
        opts: &GpuDeriveOptions,
        progress: &mut dyn FnMut(&GpuIterationStats),
    ) -> Result<(DeviceString, Vec<GpuIterationStats>), GpuError> {
        self.derive_with(opts, DeriveStrategy::Auto, progress)
            .map(|(s, stats, _)| (s, stats))
    }

    /// As [`GpuSystem::derive`], choosing how the iterations are recorded;
    /// also says which path ran.
    pub fn derive_with(
        &self,
        opts: &GpuDeriveOptions,
        strategy: DeriveStrategy,
        progress: &mut dyn FnMut(&GpuIterationStats),
    ) -> Result<(DeviceString, Vec<GpuIterationStats>, DerivePath), GpuError> {
        self.derive_then(opts, strategy, true, progress)
            .map(|(s, stats, path, _)| (s, stats, path))
    }

    /// As [`GpuSystem::derive_with`]; with `wait` false a derivation that
    /// reads nothing back (a direct one of constant parameters) is
    /// submitted and not waited for: the caller's next wait covers it, and
    /// its elapsed time is that of recording and submitting it. The flag
    /// returned says whether it was waited for.
    #[allow(clippy::type_complexity)]
    pub(crate) fn derive_then(
        &self,
        opts: &GpuDeriveOptions,
        strategy: DeriveStrategy,
        wait: bool,
        progress: &mut dyn FnMut(&GpuIterationStats),
    ) -> Result<(DeviceString, Vec<GpuIterationStats>, DerivePath, bool), GpuError> {
        if opts.keys && !self.keyed {
            return Err(GpuError::InvalidInput(
                "identity keys asked of systems loaded without them (GpuSystem::load_with)".into(),
            ));
        }
        self.direct.replace(None);
        self.final_directory.replace(None);
        if let Some(b) = self.pending_status.replace(None) {
            self.gpu.recycle([b]);
        }
        if strategy == DeriveStrategy::Auto
            && !opts.sync_iterations
            && let Some(plan) = self.direct_plan(opts)
            && let Some((s, stats, waited)) = self.derive_direct(&plan, opts, wait)?
        {
            for st in &stats {
                progress(st);
            }
            self.direct.replace(Some(plan));
            return Ok((s, stats, DerivePath::Direct, waited));
        }
        let mut path = DerivePath::PerIteration;
        let prefix = self.cpu_prefix(opts);
        let prefix = prefix.as_ref();
        let plan = if strategy != DeriveStrategy::PerIteration && !opts.sync_iterations {
            self.batch_plan(opts, prefix)
        } else {
            None
        };
        if let Some(plan) = plan {
            let t = Instant::now();
            match self.derive_batched(&plan, opts, strategy, prefix)? {
                Some((string, totals, device)) => {
                    let elapsed = t.elapsed();
                    let last = totals.len() - 1;
                    let k0 = prefix.map_or(0, |p| p.stats.len() - 1);
                    let stats: Vec<GpuIterationStats> = totals
                        .iter()
                        .enumerate()
                        .map(|(k, &(m, w))| match prefix.and_then(|p| p.stats.get(k)) {
                            Some(st) => *st,
                            None => GpuIterationStats {
                                iteration: k as u32,
                                modules: m,
                                param_words: w,
                                elapsed: if k == last { elapsed } else { Duration::ZERO },
                                device: k.checked_sub(1 + k0).and_then(|j| device.get(j).copied()),
                                on_cpu: false,
                            },
                        })
                        .collect();
                    for st in &stats {
                        progress(st);
                    }
                    return Ok((string, stats, DerivePath::Batched, true));
                }
                None => path = DerivePath::BatchedThenPerIteration,
            }
        }
        let (s, stats) = self.derive_per_iteration(opts, prefix, progress)?;
        Ok((s, stats, path, true))
    }

    /// The first strings on the CPU ([`GpuDeriveOptions::cpu_prefix`]):
    /// every job steps while the bound of the next combined string is
    /// within the option (and the GPU's own limits would let that string
    /// be derived). `None` when not even the first step qualifies, or when
    /// the CPU reports an error: the GPU then derives from the axiom and
    /// reports the error exactly as without a prefix.
    fn cpu_prefix(&self, opts: &GpuDeriveOptions) -> Option<Prefix> {
        if opts.cpu_prefix == 0 || opts.iterations == 0 {
            return None;
        }
        let t = Instant::now();
        let its = self.job_iterations(opts);
        let seeds: Vec<u32> = if self.jobs.len() == 1 {
            vec![opts.seed]
        } else {
            self.jobs.iter().map(|j| j.seed).collect()
        };
        // One engine per distinct system (a forest of seeds shares one).
        let mut engines: Vec<grm_derive::Engine<'a>> = Vec::new();
        let mut engine_of = Vec::with_capacity(self.jobs.len());
        let mut rows: Vec<Vec<Vec<(usize, u64)>>> = Vec::new();
        for job in &self.jobs {
            let k = match engines
                .iter()
                .position(|e| std::ptr::eq(e.system(), job.system))
            {
                Some(k) => k,
                None => {
                    let sys = job.system;
                    // Every module of a keyed combined string has its
                    // key, a system that draws nothing too.
                    engines.push(grm_derive::Engine::new(sys, 1).ok()?.with_keys(self.keyed));
                    rows.push(
                        (0..sys.symbols.len())
                            .map(|s| growth_row(sys, s))
                            .collect::<Option<Vec<_>>>()?,
                    );
                    engines.len() - 1
                }
            };
            engine_of.push(k);
        }
        let limits = grm_derive::DeriveLimits {
            max_modules: opts.max_modules,
            max_bytes: opts.max_bytes,
        };
        let mut strings = Vec::with_capacity(self.jobs.len());
        for (j, &e) in engine_of.iter().enumerate() {
            strings.push(engines[e].axiom(seeds[j]).ok()?);
        }
        let totals = |strings: &[ModuleString]| {
            strings.iter().fold((0u64, 0u64), |(m, w), s| {
                (m + s.len() as u64, w + s.param_words() as u64)
            })
        };
        let stat = |k: u32, (m, w): (u64, u64), elapsed: Duration| GpuIterationStats {
            iteration: k,
            modules: m,
            param_words: w,
            elapsed,
            device: None,
            on_cpu: true,
        };
        let mut stats = vec![stat(0, totals(&strings), t.elapsed())];
        let mut k = 0u32;
        while k < opts.iterations {
            let t = Instant::now();
            // The bound of the next string (exact for deterministic
            // context-free systems).
            let mut next = (0u64, 0u64);
            for (j, s) in strings.iter().enumerate() {
                if k >= its[j] {
                    next.0 += s.len() as u64;
                    next.1 += s.param_words() as u64;
                    continue;
                }
                let sys = self.jobs[j].system;
                let row = &rows[engine_of[j]];
                for sym in s.symbols() {
                    for &(t, q) in row.get(sym as usize)? {
                        next.0 = next.0.saturating_add(q);
                        next.1 = next.1.saturating_add(
                            q.saturating_mul(u64::from(sys.symbols.get(t)?.param_words)),
                        );
                    }
                }
            }
            let (n, nw) = stats.last().map_or((0, 0), |s| (s.modules, s.param_words));
            let bytes =
                self.string_bytes(n, nw) + 8 * (n + 1) + 4 * n + self.string_bytes(next.0, next.1);
            if next.0 > opts.cpu_prefix || next.0 > opts.max_modules || bytes > opts.max_bytes {
                break;
            }
            k += 1;
            for (j, s) in strings.iter_mut().enumerate() {
                if k <= its[j] {
                    *s = engines[engine_of[j]].step(s, k, seeds[j], &limits).ok()?;
                }
            }
            stats.push(stat(k, totals(&strings), t.elapsed()));
        }
        if k == 0 {
            return None;
        }
        // The combined string, each module tagged with its job.
        let (m, w) = totals(&strings);
        let mut string = ModuleString::with_capacity(m as usize, w as usize);
        let mut directory = self.directory.clone();
        let mut hist = Vec::with_capacity(strings.len());
        for (j, one) in strings.iter().enumerate() {
            let start = string.len() as u32;
            let mut h = vec![0u64; self.jobs[j].system.symbols.len()];
            if self.keyed && !one.has_keys() {
                return None;
            }
            for (i, (sym, p)) in one.iter().enumerate() {
                *h.get_mut(sym as usize)? += 1;
                let tagged = sym | ((j as u32) << SYS_SHIFT);
                if self.keyed {
                    string.push_keyed(tagged, p, one.keys()[i]);
                } else {
                    string.push(tagged, p);
                }
            }
            hist.push(h);
            directory[j].start = start;
            directory[j].end = string.len() as u32;
        }
        Some(Prefix {
            string,
            directory,
            hist,
            stats,
        })
    }

    /// The directory as the derivation starts: the uploaded ranges; one
    /// system takes the options' iterations and seed.
    fn reset_directory(&self, opts: &GpuDeriveOptions, prefix: Option<&Prefix>) {
        let mut dir = prefix.map_or_else(|| self.directory.clone(), |p| p.directory.clone());
        if let [one] = &mut dir[..] {
            *one = self.single_entry(one, opts);
        }
        self.gpu
            .queue()
            .write_buffer(&self.tables, 0, bytemuck::cast_slice(&dir));
    }

    /// The directory entry of a derivation of one system: `e` with the
    /// options' iterations, seed and that seed's root key.
    pub(crate) fn single_entry(&self, e: &SystemEntry, opts: &GpuDeriveOptions) -> SystemEntry {
        SystemEntry {
            iterations: opts.iterations,
            seed: opts.seed,
            root_key: self.jobs[0].system.root_key(opts.seed),
            ..*e
        }
    }

    /// Device bytes of a string of this derivation (its identity keys
    /// included where it carries them).
    pub(crate) fn string_bytes(&self, modules: u64, words: u64) -> u64 {
        string_bytes(modules, words) + key_bytes(modules, self.keyed)
    }

    /// Whether the strings carry identity keys (some system draws, or
    /// keys were asked for).
    pub fn carries_keys(&self) -> bool {
        self.keyed
    }

    /// Per job, whether its string read back carries identity keys (its
    /// system draws random numbers, as `CompiledSystem::draws_randomly`,
    /// or keys were asked for: [`GpuSystem::load_with`]).
    pub(crate) fn job_keyed(&self) -> &[bool] {
        &self.job_keyed
    }

    /// Each job's iterations in this derivation.
    fn job_iterations(&self, opts: &GpuDeriveOptions) -> Vec<u32> {
        if self.jobs.len() == 1 {
            vec![opts.iterations]
        } else {
            self.jobs.iter().map(|j| j.iterations).collect()
        }
    }
}

fn kind_of(bits: u32) -> RuntimeKind {
    if bits & ERR_FAULT != 0 {
        RuntimeKind::Fault
    } else if bits & ERR_BAD_WEIGHT != 0 {
        RuntimeKind::BadWeight
    } else if bits & ERR_NON_FINITE != 0 {
        RuntimeKind::NonFinite
    } else {
        RuntimeKind::Fault
    }
}

/// The most device memory a batched derivation allocates; larger ones run
/// iteration by iteration (with exact sizes).
pub const BATCH_MAX_BYTES: u64 = 4 << 30;

/// As [`BATCH_MAX_BYTES`] where the bound may be above the real sizes
/// (some symbol has conditions, contexts or several alternatives): the
/// bound of a stochastic plant can be 20 times its string, and allocating
/// (and clearing) it costs more than the synchronisations it saves.
pub const BATCH_LOOSE_MAX_BYTES: u64 = 256 << 20;

/// The shortest CPU prefix string from which a batched derivation of a
/// loosely bounded system is sized from the expected sizes
/// ([`PROJECT_MARGIN`]) instead of the bound. From a string of n modules
/// the rest of a branching derivation varies by about 1/sqrt(n) of its
/// expected size (the stochastic plant: 0.3/sqrt(n)).
pub const PROJECT_MIN_MODULES: u64 = 1024;
/// Buffers of a projected batched derivation hold this many times the
/// expected sizes ...
pub const PROJECT_MARGIN: f64 = 1.25;
/// ... plus this many modules (or parameter words).
pub const PROJECT_SLACK: u64 = 4096;

/// How [`GpuSystem::derive_with`] records the iterations.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DeriveStrategy {
    /// Direct (the final string in one pass, for deterministic,
    /// context-free systems), else batched (one
    /// submission, sizes from the bound) where the bounds allow it, else
    /// iteration by iteration; neither direct nor batched with
    /// `sync_iterations`.
    Auto,
    /// As `Auto` without the direct path: every string is derived.
    Stepwise,
    /// One submission and one synchronisation per iteration.
    PerIteration,
    /// As `Auto`, with the device's capacity check of the last string set
    /// to zero: a non-empty result overflows, the batched run is discarded
    /// and the derivation runs iteration by iteration (tests the fallback).
    #[doc(hidden)]
    AutoShrunkCaps,
}

/// The path a derivation took.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DerivePath {
    /// The final string in one pass, no intermediate string
    /// (deterministic, context-free systems).
    Direct,
    /// All iterations in one submission.
    Batched,
    /// Iteration by iteration (the bound was over a limit, or batching was
    /// not asked for).
    PerIteration,
    /// Batched first; an error or an overflow was reported, so it ran
    /// again iteration by iteration.
    BatchedThenPerIteration,
}

/// [`derive()`], choosing the strategy and reporting the path taken.
pub fn derive_with(
    gpu: &Gpu,
    sys: &CompiledSystem,
    opts: &GpuDeriveOptions,
    strategy: DeriveStrategy,
) -> Result<(GpuDerivation, DerivePath), GpuError> {
    gpu.run(|| {
        let job = GpuJob {
            system: sys,
            iterations: opts.iterations,
            seed: opts.seed,
        };
        let g = GpuSystem::load_with(gpu, &[job], opts.keys)?;
        let (s, stats, path) = g.derive_with(opts, strategy, &mut |_| {})?;
        let string = s.read(gpu)?;
        gpu.recycle(s.into_buffers());
        Ok((GpuDerivation { string, stats }, path))
    })
}

/// The first strings of a derivation, derived on the CPU
/// ([`GpuDeriveOptions::cpu_prefix`]).
#[derive(Debug)]
pub(crate) struct Prefix {
    /// The combined string after the CPU's iterations (each module's
    /// symbol tagged with its job above `SYS_SHIFT`).
    string: ModuleString,
    /// The directory for it: each job's range in `string`.
    directory: Vec<SystemEntry>,
    /// Per job, how many modules of each symbol its string has.
    hist: Vec<Vec<u64>>,
    /// Strings 0 ..= k0 (k0 = `stats.len() - 1`, the CPU's iterations).
    stats: Vec<GpuIterationStats>,
}

/// Write a host string into device buffers that hold at least its length
/// (all three arrays, the last start included; the keys where both carry
/// them).
fn write_string(gpu: &Gpu, out: &DeviceString, s: &ModuleString) {
    let q = gpu.queue();
    let p = s.parts();
    if !p.syms.is_empty() {
        q.write_buffer(&out.syms, 0, bytemuck::cast_slice(&p.syms));
        if let Some(k) = &out.keys
            && s.has_keys()
        {
            q.write_buffer(k, 0, bytemuck::cast_slice(p.keys));
        }
    }
    q.write_buffer(&out.starts, 0, bytemuck::cast_slice(&p.starts));
    if !p.params.is_empty() {
        q.write_buffer(&out.params, 0, bytemuck::cast_slice(&p.params));
    }
}

fn begin<'e>(enc: &'e mut wgpu::CommandEncoder, label: &'static str) -> wgpu::ComputePass<'e> {
    enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
        label: Some(label),
        timestamp_writes: None,
    })
}

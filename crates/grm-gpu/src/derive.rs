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

mod direct;
pub use crate::layout::DIRECT_MAX_STEPS;
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

    /// Upper bounds of every string's modules and parameter words (string
    /// 0 is the axiom), from the tables: per symbol, the most modules of
    /// each symbol any of its outcomes produces (every alternative of the
    /// groups that may apply, and the unchanged copy unless a group
    /// without context or condition always applies). Exact for
    /// deterministic context-free systems. `None` when a table is out of
    /// range (the per-iteration path reports it).
    pub(crate) fn string_bounds(
        &self,
        opts: &GpuDeriveOptions,
        prefix: Option<&Prefix>,
    ) -> Option<Vec<(u64, u64)>> {
        self.symbol_bounds(opts, prefix).map(|(total, _)| total)
    }

    /// Per job, how many modules of each symbol its final string has, when
    /// that is known before deriving: every symbol of every job is exact
    /// (deterministic and context-free, so the bound is the count).
    pub(crate) fn exact_final_counts(&self, opts: &GpuDeriveOptions) -> Option<Vec<Vec<u64>>> {
        let exact = self
            .jobs
            .iter()
            .all(|j| (0..j.system.symbols.len()).all(|s| exact_symbol(j.system, s)));
        if !exact {
            return None;
        }
        self.symbol_bounds(opts, None).map(|(_, last)| last)
    }

    /// At most how deep the brackets of the final string nest and how many
    /// `[` it has, over every outcome that may happen (the outcomes
    /// [`growth_row`] counts), `kinds[j][s]` being 1 for a `[` and -1 for
    /// a `]` of job `j`'s symbol `s`. Each job's string starts at depth 0.
    /// `None` when a table is out of range.
    pub(crate) fn bracket_bounds(
        &self,
        opts: &GpuDeriveOptions,
        kinds: &[Vec<i8>],
    ) -> Option<(u64, u64)> {
        let (_, last) = self.symbol_bounds(opts, None)?;
        let mut opens = 0u64;
        let mut depth = 0i64;
        for (((job, its), counts), kind) in self
            .jobs
            .iter()
            .zip(self.job_iterations(opts))
            .zip(&last)
            .zip(kinds)
        {
            let sys = job.system;
            let k = |s: u32| i64::from(kind.get(s as usize).copied().unwrap_or(0));
            for (s, &c) in counts.iter().enumerate() {
                if k(s as u32) > 0 {
                    opens = opens.saturating_add(c);
                }
            }
            // `rel[s]`: the deepest a module of `s` and what it becomes
            // reach after the steps so far, relative to the depth before
            // it. A module's own depth: 1 for `[` (the depth after it),
            // else 0.
            let ns = sys.symbols.len();
            let outcomes = (0..ns)
                .map(|s| successors_of(sys, s))
                .collect::<Option<Vec<_>>>()?;
            let mut rel: Vec<i64> = (0..ns).map(|s| k(s as u32).max(0)).collect();
            let reach = |succ: &[u32], rel: &[i64]| -> i64 {
                let mut d = 0i64;
                let mut most = 0i64;
                for &m in succ {
                    most = most.max(d.saturating_add(rel[m as usize]));
                    d = d.saturating_add(k(m));
                }
                most.max(d)
            };
            for _ in 0..its {
                rel = outcomes
                    .iter()
                    .enumerate()
                    .map(|(s, outs)| {
                        outs.iter()
                            .map(|succ| reach(succ, &rel))
                            .fold(rel[s], i64::max)
                    })
                    .collect();
            }
            let axiom = sys.alts.get(sys.axiom_alt as usize)?;
            let axiom: Vec<u32> = succ_of(sys, axiom)?.iter().map(|m| m.symbol).collect();
            if axiom.iter().any(|&m| m as usize >= ns) {
                return None;
            }
            depth = depth.max(reach(&axiom, &rel));
        }
        Some((depth.max(0) as u64, opens))
    }

    /// [`GpuSystem::string_bounds`], and per job the bound of each
    /// symbol's count in its final string.
    #[allow(clippy::type_complexity)]
    fn symbol_bounds(
        &self,
        opts: &GpuDeriveOptions,
        prefix: Option<&Prefix>,
    ) -> Option<(Vec<(u64, u64)>, Vec<Vec<u64>>)> {
        let k_max = opts.iterations as usize;
        let k0 = prefix.map_or(0, |p| p.stats.len() - 1);
        let mut total = vec![(0u64, 0u64); k_max + 1];
        let mut last = Vec::with_capacity(self.jobs.len());
        for (j, (job, its)) in self.jobs.iter().zip(self.job_iterations(opts)).enumerate() {
            let sys = job.system;
            let ns = sys.symbols.len();
            let rows = (0..ns)
                .map(|s| growth_row(sys, s))
                .collect::<Option<Vec<_>>>()?;
            let mut c = vec![0u64; ns];
            match prefix {
                Some(p) => c.clone_from(p.hist.get(j)?),
                None => {
                    let axiom = sys.alts.get(sys.axiom_alt as usize)?;
                    for m in succ_of(sys, axiom)? {
                        *c.get_mut(m.symbol as usize)? += 1;
                    }
                }
            }
            for (k, tot) in total.iter_mut().enumerate().skip(k0) {
                if k > k0 && k <= its as usize {
                    let mut next = vec![0u64; ns];
                    for (s, &n) in c.iter().enumerate() {
                        if n == 0 {
                            continue;
                        }
                        for &(t, q) in &rows[s] {
                            next[t] = next[t].saturating_add(n.saturating_mul(q));
                        }
                    }
                    c = next;
                }
                let m = c.iter().fold(0u64, |a, &x| a.saturating_add(x));
                let w = c.iter().zip(&sys.symbols).fold(0u64, |a, (&x, e)| {
                    a.saturating_add(x.saturating_mul(u64::from(e.param_words)))
                });
                tot.0 = tot.0.saturating_add(m);
                tot.1 = tot.1.saturating_add(w);
            }
            last.push(c);
        }
        // The CPU's strings are known exactly.
        for (tot, st) in total
            .iter_mut()
            .zip(prefix.map_or(&[][..], |p| &p.stats[..]))
        {
            *tot = (st.modules, st.param_words);
        }
        Some((total, last))
    }

    /// Per job, the expected number of modules of each symbol in its final
    /// string, from the axiom: each symbol's outcomes weighted by their
    /// probabilities (the largest outcome where a condition, a context or
    /// computed weights decide; [`expected_row`]). `None` when a table is
    /// out of range.
    pub(crate) fn expected_final_counts(&self, opts: &GpuDeriveOptions) -> Option<Vec<Vec<f64>>> {
        let mut out = Vec::with_capacity(self.jobs.len());
        for (job, its) in self.jobs.iter().zip(self.job_iterations(opts)) {
            let sys = job.system;
            let ns = sys.symbols.len();
            let rows = (0..ns)
                .map(|s| expected_row(sys, s))
                .collect::<Option<Vec<_>>>()?;
            let mut c = vec![0f64; ns];
            let axiom = sys.alts.get(sys.axiom_alt as usize)?;
            for m in succ_of(sys, axiom)? {
                *c.get_mut(m.symbol as usize)? += 1.0;
            }
            for _ in 0..its {
                let mut next = vec![0f64; ns];
                for (s, &n) in c.iter().enumerate() {
                    for &(t, q) in &rows[s] {
                        next[t] += n * q;
                    }
                }
                c = next;
            }
            out.push(c);
        }
        Some(out)
    }

    /// The expected modules and parameter words of every string after
    /// the CPU's (each symbol's outcomes weighted by their probabilities;
    /// the largest outcome where a condition, a context or computed
    /// weights decide), from the prefix string's exact symbol counts.
    /// `None` without a prefix or when a table is out of range.
    fn projected_sizes(
        &self,
        opts: &GpuDeriveOptions,
        prefix: Option<&Prefix>,
    ) -> Option<Vec<(f64, f64)>> {
        let p = prefix?;
        let k_max = opts.iterations as usize;
        let k0 = p.stats.len() - 1;
        let mut total = vec![(0f64, 0f64); k_max + 1];
        for (j, (job, its)) in self.jobs.iter().zip(self.job_iterations(opts)).enumerate() {
            let sys = job.system;
            let ns = sys.symbols.len();
            let rows = (0..ns)
                .map(|s| expected_row(sys, s))
                .collect::<Option<Vec<_>>>()?;
            let mut c: Vec<f64> = p.hist.get(j)?.iter().map(|&n| n as f64).collect();
            for (k, tot) in total.iter_mut().enumerate().skip(k0) {
                if k > k0 && k <= its as usize {
                    let mut next = vec![0f64; ns];
                    for (s, &n) in c.iter().enumerate() {
                        for &(t, q) in &rows[s] {
                            next[t] += n * q;
                        }
                    }
                    c = next;
                }
                tot.0 += c.iter().sum::<f64>();
                tot.1 += c
                    .iter()
                    .zip(&sys.symbols)
                    .map(|(&x, e)| x * f64::from(e.param_words))
                    .sum::<f64>();
            }
        }
        Some(total)
    }

    /// The buffers of a batched derivation, or `None` when the bounds are
    /// over a limit (the options', the device's, 32-bit counts) or the
    /// system needs bracket matching.
    fn batch_plan(&self, opts: &GpuDeriveOptions, prefix: Option<&Prefix>) -> Option<BatchPlan> {
        let k0 = prefix.map_or(0, |p| p.stats.len() - 1);
        if self.has_context || opts.iterations as usize <= k0 {
            return None;
        }
        let mut bounds = self.string_bounds(opts, prefix)?;
        // A loose bound (stochastic or conditional productions) can be far
        // above the real sizes (every symbol taking its largest outcome at
        // every step: 21x for the stochastic plant at 11 steps). After a
        // CPU prefix of at least PROJECT_MIN_MODULES modules, whose exact
        // symbol counts make the rest predictable within a fraction of a
        // percent, the buffers are sized from the expected sizes with a
        // margin instead; a string over them sets the overflow flag, and
        // the derivation runs again iteration by iteration.
        let exact = self
            .jobs
            .iter()
            .all(|j| (0..j.system.symbols.len()).all(|s| exact_symbol(j.system, s)));
        let projected = match prefix {
            Some(p) if !exact && p.string.len() as u64 >= PROJECT_MIN_MODULES => {
                self.projected_sizes(opts, prefix)
            }
            _ => None,
        };
        if let Some(proj) = &projected {
            let cap = |x: f64| (x * PROJECT_MARGIN).ceil() as u64 + PROJECT_SLACK;
            for (b, &(m, w)) in bounds.iter_mut().zip(proj).skip(k0 + 1) {
                *b = (b.0.min(cap(m)), b.1.min(cap(w)));
            }
        }
        let limit32 = u64::from(u32::MAX) - 1;
        let mut caps = [(0u64, 0u64); 2];
        let mut max_in = 0u64;
        // String k lives in buffer (k - k0) % 2; the CPU's strings before
        // k0 are not on the device.
        for (k, &(m, w)) in bounds.iter().enumerate().skip(k0) {
            if m > limit32 || w > limit32 {
                return None;
            }
            let c = &mut caps[(k - k0) % 2];
            *c = (c.0.max(m), c.1.max(w));
            if k > k0 {
                let (n, nw) = bounds[k - 1];
                max_in = max_in.max(n);
                let bytes =
                    self.string_bytes(n, nw) + 8 * (n + 1) + 4 * n + self.string_bytes(m, w);
                if m > opts.max_modules || bytes > opts.max_bytes {
                    return None;
                }
            }
        }
        let levels = scan_levels(max_in);
        let total = self.string_bytes(caps[0].0, caps[0].1)
            + self.string_bytes(caps[1].0, caps[1].1)
            + 12 * (max_in + 1);
        let gpu = self.gpu;
        let fits = |what, b| gpu.check_storage(what, b).is_ok();
        // A loose bound (stochastic or conditional productions) costs its
        // allocation however short the string: keep it small.
        let cap = if exact {
            BATCH_MAX_BYTES
        } else {
            BATCH_LOOSE_MAX_BYTES
        };
        let ok = total <= cap
            && total <= opts.max_bytes
            && caps.iter().all(|&(m, w)| {
                fits("output symbols", 4 * m)
                    && fits("output parameter starts", 4 * (m + 1))
                    && fits("output parameters", 4 * w)
                    && (!self.keyed || fits("output identity keys", 4 * m))
            })
            && fits("output counts", 8 * (max_in + 1))
            && gpu.grid("count", groups_for(max_in + 1)).is_ok();
        ok.then_some(BatchPlan {
            k0,
            bounds,
            caps,
            max_in,
            levels,
        })
    }

    /// All iterations in one submission (see the module documentation).
    /// `None`: an error or an overflow was reported; nothing is returned
    /// and the caller derives iteration by iteration.
    #[allow(clippy::type_complexity)]
    fn derive_batched(
        &self,
        plan: &BatchPlan,
        opts: &GpuDeriveOptions,
        strategy: DeriveStrategy,
        prefix: Option<&Prefix>,
    ) -> Result<Option<(DeviceString, Vec<(u64, u64)>, Vec<DeviceTime>)>, GpuError> {
        let gpu = self.gpu;
        self.reset_directory(opts, prefix);
        let k_max = opts.iterations as usize;
        let nlev = plan.levels.len();
        let k0 = plan.k0;
        let (offsets, m0, w0) = match prefix {
            Some(p) => (
                Vec::new(),
                p.string.len() as u64,
                p.string.param_words() as u64,
            ),
            None => self.axiom_offsets()?,
        };
        let strings = [
            self.alloc_string(plan.caps[0].0, plan.caps[0].1)?,
            self.alloc_string(plan.caps[1].0, plan.caps[1].1)?,
        ];
        let counts = gpu.storage("output counts", 8 * (plan.max_in + 1))?;
        let choice = gpu.storage("production choices", 4 * plan.max_in)?;
        let mate = gpu.storage("unused", 16)?;
        let status = gpu.storage_zeroed("derive status", u64::from(STATUS_WORDS) * 4)?;
        let sums = plan
            .levels
            .iter()
            .map(|&b| gpu.storage("scan block sums", 8 * b))
            .collect::<Result<Vec<_>, _>>()?;
        // Parameters written on the device by `batch_next`, read where
        // they are written (shaders/batch.wgsl): the DeriveParams and the
        // indirect arguments by iteration parity, the scan levels' records
        // `align` bytes apart (binding offsets must be aligned).
        let align = gpu.storage_offset_alignment();
        let sp_stride = 16u64.next_multiple_of(align);
        let arg_bytes = 12 * (1 + 2 * nlev as u64);
        let arg_half = arg_bytes.next_multiple_of(align);
        let args = gpu.indirect_storage("batch dispatch args", 2 * arg_half)?;
        let dp0 = gpu.upload(
            "batch derive params",
            &[DeriveParams {
                systems: self.jobs.len() as u32,
                iteration: k0 as u32,
                keyed: u32::from(self.keyed),
                ..DeriveParams::default()
            }],
        )?;
        let dp = [
            gpu.storage("derive params", std::mem::size_of::<DeriveParams>() as u64)?,
            gpu.storage("derive params", std::mem::size_of::<DeriveParams>() as u64)?,
        ];
        let sp = gpu.storage_zeroed("batch scan params", sp_stride * nlev as u64)?;
        let flag = 2 * (k_max + 1);
        let hist = gpu.upload("batch history", &vec![0u32; flag + 1])?;
        let mut caps: Vec<[u32; 2]> = plan
            .bounds
            .iter()
            .map(|&(m, w)| [m as u32, w as u32])
            .collect();
        if strategy == DeriveStrategy::AutoShrunkCaps {
            caps[k_max] = [0, 0];
        }
        let caps = gpu.upload("batch capacities", &caps)?;
        let bp = gpu.uniform(
            "batch params",
            &BatchParams {
                grid_width: gpu.grid_width(),
                levels: nlev as u32,
                flag: flag as u32,
                sp_stride: (sp_stride / 16) as u32,
            },
        );

        // `batch_next` before iteration 1 reads `dp0` and writes parity 0;
        // after iteration k (parity p = (k - 1) % 2) it reads dp[p] and
        // writes the other parity's DeriveParams and arguments.
        let next_bound = |input: &wgpu::Buffer, out: usize| -> Result<Bound, GpuError> {
            gpu.bound_ranges(
                &kernels::BATCH_NEXT,
                &[
                    (&bp, 0, None),
                    (&counts, 0, None),
                    (&caps, 0, None),
                    (input, 0, None),
                    (&dp[out], 0, None),
                    (&sp, 0, None),
                    (&args, arg_half * out as u64, Some(arg_half)),
                    (&hist, 0, None),
                    (&sums[0], 0, None),
                ],
            )
        };
        let start = next_bound(&dp0, 0)?;
        let next = [next_bound(&dp[0], 1)?, next_bound(&dp[1], 0)?];
        let derive_bound =
            |kernel: &'static crate::shader::Kernel, p: usize| -> Result<Bound, GpuError> {
                let (i, o) = (&strings[p], &strings[1 - p]);
                gpu.bound(
                    kernel,
                    &[
                        &dp[p],
                        &self.tables,
                        &i.syms,
                        &i.starts,
                        &i.params,
                        &mate,
                        &counts,
                        &choice,
                        &o.syms,
                        &o.starts,
                        &o.params,
                        &status,
                        self.keys_of(i, 0),
                        self.keys_of(o, 1),
                        &sums[0],
                    ],
                )
            };
        // Count and scan level 0 in one kernel: `counts` gets the offsets
        // within each block, `sums[0]` the blocks' totals; the levels
        // above scan those, and the readers combine the two
        // (shaders/offsets_blocks.wgsl), so level 0 is never added.
        let count = [
            derive_bound(self.kernels.count_scan_dev, 0)?,
            derive_bound(self.kernels.count_scan_dev, 1)?,
        ];
        let rewrite = [
            derive_bound(self.kernels.rewrite_out_dev, 0)?,
            derive_bound(self.kernels.rewrite_out_dev, 1)?,
        ];
        // Levels 1 and up (level l scans level l - 1's block sums).
        let mut scans = Vec::with_capacity(nlev);
        let mut adds = Vec::with_capacity(nlev);
        for l in 1..nlev {
            let b = [
                (&sp, sp_stride * l as u64, Some(16)),
                (&sums[l - 1], 0, None),
                (&sums[l], 0, None),
            ];
            scans.push((l, gpu.bound_ranges(&kernels::SCAN_U32X2_DEV, &b)?));
            adds.push((l, gpu.bound_ranges(&kernels::ADD_U32X2_DEV, &b)?));
        }
        let directory = [
            gpu.bound(
                &kernels::UPDATE_DIRECTORY_DEV,
                &[&dp[0], &self.tables, &counts, &sums[0]],
            )?,
            gpu.bound(
                &kernels::UPDATE_DIRECTORY_DEV,
                &[&dp[1], &self.tables, &counts, &sums[0]],
            )?,
        ];
        let dir_grid = gpu.grid("update directory", groups_for(self.jobs.len() as u64))?;

        let mut enc = gpu.encoder();
        match prefix {
            Some(p) => write_string(gpu, &strings[0], &p.string),
            None => {
                self.record_axiom(&mut enc, &offsets, (m0, w0), &strings[0], &status)?;
                gpu.queue().write_buffer(
                    &strings[0].starts,
                    4 * m0,
                    bytemuck::bytes_of(&(w0 as u32)),
                );
            }
        }
        gpu.queue()
            .write_buffer(&counts, 0, bytemuck::cast_slice(&[m0 as u32, w0 as u32]));
        {
            let mut pass = begin(&mut enc, "batch start");
            start.dispatch(&mut pass, (1, 1));
        }
        let stamps = Stamps::new(gpu, (k_max - k0) as u32);
        for k in k0 + 1..=k_max {
            let p = (k - 1 - k0) % 2;
            let j = (k - 1 - k0) as u32;
            // A recorded iteration holds host memory until its submission
            // completes: a long derivation (thousands of iterations of a
            // slowly growing string) is submitted in chunks, each waited
            // for, so the host holds at most one chunk.
            if j > 0 && j.is_multiple_of(BATCH_SUBMIT_ITERATIONS) {
                let full = std::mem::replace(&mut enc, gpu.encoder());
                gpu.submit_wait(full)?;
            }
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("batch iteration"),
                timestamp_writes: stamps.as_ref().and_then(|s| s.pass_writes(j)),
            });
            let stage = |pass: &mut wgpu::ComputePass<'_>, st: u32| {
                if let Some(s) = &stamps {
                    s.after_stage(pass, j, st);
                }
            };
            // This iteration's arguments (written by the previous
            // `batch_next` into parity p's half).
            let a = arg_half * p as u64;
            // The input's bound says which scan levels can have work:
            // `batch_next` gives the others empty grids, so they are
            // not recorded (an empty dispatch still costs a barrier).
            let lev = scan_levels(plan.bounds[k - 1].0).len().min(nlev);
            // Level 0's grid (one workgroup per block of SCAN_BLOCK).
            count[p].dispatch_indirect(&mut pass, &args, a + 12);
            stage(&mut pass, 0);
            for (l, sc) in scans.iter().take(lev - 1) {
                sc.dispatch_indirect(&mut pass, &args, a + 12 * (1 + *l as u64));
            }
            for (l, ad) in adds.iter().take(lev.saturating_sub(2)).rev() {
                ad.dispatch_indirect(&mut pass, &args, a + 12 * (1 + (nlev + l) as u64));
            }
            stage(&mut pass, 1);
            next[p].dispatch(&mut pass, (1, 1));
            stage(&mut pass, 2);
            rewrite[p].dispatch_indirect(&mut pass, &args, a);
            stage(&mut pass, 3);
            // One system's range is the whole string: no kernel reads
            // it on this path (contexts are derived per iteration); it
            // is written once at the end instead.
            if self.jobs.len() > 1 {
                directory[p].dispatch(&mut pass, dir_grid);
            }
        }
        let mut ranges = vec![
            (&hist, 0, flag as u64 + 1),
            (&status, 0, u64::from(STATUS_WORDS)),
        ];
        if let Some(s) = &stamps {
            s.resolve(&mut enc);
            let (buf, words) = s.readback();
            ranges.push((buf, 0, words));
        }
        // Several systems: their ranges in the final string, read with the
        // totals (the interpretation needs them; no wait of their own).
        let entry_words = (std::mem::size_of::<SystemEntry>() / 4) as u64;
        let dir_at = ranges.len();
        if self.jobs.len() > 1 {
            ranges.push((&self.tables, 0, entry_words * self.jobs.len() as u64));
        }
        let words = gpu.read::<u32>(enc, &ranges)?;
        let device = match (&stamps, words.get(2)) {
            (Some(s), Some(w)) => s.times(w),
            _ => Vec::new(),
        };
        if self.jobs.len() > 1
            && let Some(w) = words.get(dir_at)
        {
            let entries: Vec<SystemEntry> = w
                .chunks_exact(entry_words as usize)
                .map(|c| bytemuck::pod_read_unaligned(bytemuck::cast_slice(c)))
                .collect();
            self.final_directory.replace(Some(entries));
        }
        let [strings0, strings1] = strings;
        let (last, other) = if (k_max - k0).is_multiple_of(2) {
            (strings0, strings1)
        } else {
            (strings1, strings0)
        };
        let [dp_a, dp_b] = dp;
        let mut scratch: Vec<wgpu::Buffer> = vec![counts, choice, mate, sp, dp_a, dp_b];
        scratch.extend(sums);
        scratch.extend(other.into_buffers());
        let h = words.first().map(Vec::as_slice).unwrap_or(&[]);
        let st = words.get(1).map(Vec::as_slice).unwrap_or(&[]);
        let failed = h.len() != flag + 1 || h[flag] != 0 || st.iter().any(|&x| x != 0);
        if failed {
            scratch.extend(last.into_buffers());
            gpu.recycle(scratch);
            return Ok(None);
        }
        gpu.recycle(scratch);
        let totals: Vec<(u64, u64)> = (0..=k_max)
            .map(|k| (u64::from(h[2 * k]), u64::from(h[2 * k + 1])))
            .collect();
        let (len, words) = totals[k_max];
        if let [one] = &self.directory[..] {
            let e = SystemEntry {
                start: 0,
                end: len as u32,
                ..self.single_entry(one, opts)
            };
            gpu.queue()
                .write_buffer(&self.tables, 0, bytemuck::bytes_of(&e));
            self.final_directory.replace(Some(vec![e]));
        }
        Ok(Some((DeviceString { len, words, ..last }, totals, device)))
    }

    /// One submission and one synchronisation per iteration.
    fn derive_per_iteration(
        &self,
        opts: &GpuDeriveOptions,
        prefix: Option<&Prefix>,
        progress: &mut dyn FnMut(&GpuIterationStats),
    ) -> Result<(DeviceString, Vec<GpuIterationStats>), GpuError> {
        let t = Instant::now();
        self.reset_directory(opts, prefix);
        // Not sized by `opts.iterations` (any u32; a limit can end it early).
        let mut stats = Vec::with_capacity(opts.iterations.min(64) as usize + 1);
        let mut string = match prefix {
            Some(p) => {
                let s = &p.string;
                let out = self.alloc_string(s.len() as u64, s.param_words() as u64)?;
                write_string(self.gpu, &out, s);
                for st in &p.stats {
                    progress(st);
                    stats.push(*st);
                }
                out
            }
            None => {
                let string = self.axiom()?;
                let first = GpuIterationStats {
                    iteration: 0,
                    modules: string.len,
                    param_words: string.words,
                    elapsed: t.elapsed(),
                    device: None,
                    on_cpu: false,
                };
                progress(&first);
                stats.push(first);
                string
            }
        };
        let k0 = stats.len() as u32 - 1;
        let status = self
            .gpu
            .storage_zeroed("derive status", u64::from(STATUS_WORDS) * 4)?;
        let previous = self.gpu.storage(
            "previous directory",
            (self.directory.len() * std::mem::size_of::<SystemEntry>()) as u64,
        )?;
        for iteration in k0 + 1..=opts.iterations {
            let t = Instant::now();
            let next = self.step(&string, iteration, opts, &status, &previous)?;
            let old = std::mem::replace(&mut string, next);
            self.gpu.recycle(old.into_buffers());
            let s = GpuIterationStats {
                iteration,
                modules: string.len,
                param_words: string.words,
                elapsed: t.elapsed(),
                device: None,
                on_cpu: false,
            };
            progress(&s);
            stats.push(s);
        }
        // Errors of the last rewrite (none when the CPU derived every
        // string: no wait for a device that did nothing).
        if k0 < opts.iterations {
            let st = self
                .gpu
                .read::<u32>(self.gpu.encoder(), &[(&status, 0, u64::from(STATUS_WORDS))])?;
            let st = st.into_iter().next().unwrap_or_default();
            self.check_status(&st, 1, opts.iterations, None, &previous)?;
        }
        self.gpu.recycle([status, previous]);
        Ok((string, stats))
    }

    /// The rewrite kernel: one thread per output module (`rewrite_out`),
    /// or per input module (`rewrite`) for context-sensitive systems,
    /// whose binding would otherwise match the contexts again for every
    /// output module, unless one of their successors is longer than
    /// [`kernels::LONG_SUCCESSOR`].
    fn rewrite_kernel(&self) -> &'static crate::shader::Kernel {
        if self.has_context && !self.long_successors {
            self.kernels.rewrite
        } else {
            self.kernels.rewrite_out
        }
    }

    /// A string's buffers (with identity keys where the derivation
    /// carries them).
    fn alloc_string(&self, modules: u64, words: u64) -> Result<DeviceString, GpuError> {
        Ok(DeviceString {
            syms: self.gpu.storage("output symbols", 4 * modules)?,
            starts: self
                .gpu
                .storage("output parameter starts", 4 * (modules + 1))?,
            params: self.gpu.storage("output parameters", 4 * words)?,
            keys: if self.keyed {
                Some(self.gpu.storage("output identity keys", 4 * modules)?)
            } else {
                None
            },
            len: modules,
            words,
        })
    }

    /// The key buffer of `s` to bind, or a placeholder (`side` 0 for an
    /// input, 1 for an output).
    fn keys_of<'s>(&'s self, s: &'s DeviceString, side: usize) -> &'s wgpu::Buffer {
        s.keys.as_ref().unwrap_or(&self.no_keys[side])
    }

    fn dispatch_derive(
        &self,
        enc: &mut wgpu::CommandEncoder,
        kernel: &'static crate::shader::Kernel,
        params: &DeriveParams,
        pass: &Pass<'_>,
        threads: u64,
    ) -> Result<(), GpuError> {
        let uniform = self.gpu.uniform("derive params", params);
        self.gpu.dispatch(
            enc,
            kernel,
            &[
                &uniform,
                &self.tables,
                &pass.input.syms,
                &pass.input.starts,
                &pass.input.params,
                pass.mate,
                pass.counts,
                pass.choice,
                &pass.out.syms,
                &pass.out.starts,
                &pass.out.params,
                pass.status,
                self.keys_of(pass.input, 0),
                self.keys_of(pass.out, 1),
            ],
            groups_for(threads),
        )
    }

    /// Where each system's axiom goes in string 0, and its totals.
    fn axiom_offsets(&self) -> Result<(Vec<[u32; 2]>, u64, u64), GpuError> {
        let mut offsets: Vec<[u32; 2]> = Vec::with_capacity(self.jobs.len());
        let (mut m, mut w) = (0u64, 0u64);
        for job in &self.jobs {
            offsets.push([m as u32, w as u32]);
            let a = &job.system.alts[job.system.axiom_alt as usize];
            m += u64::from(a.succ_len);
            w += u64::from(a.succ_words);
        }
        if m >= u64::from(u32::MAX) || w >= u64::from(u32::MAX) {
            return Err(GpuError::CountOverflow {
                what: "axiom modules",
                count: m.max(w),
            });
        }
        Ok((offsets, m, w))
    }

    /// Record the axiom kernel writing string 0 into `out` (one thread
    /// per output module; each system's axiom at its `offsets`; errors in
    /// `status` slot 1, at the system's index). The last start is not
    /// written.
    fn record_axiom(
        &self,
        enc: &mut wgpu::CommandEncoder,
        offsets: &[[u32; 2]],
        (modules, words): (u64, u64),
        out: &DeviceString,
        status: &wgpu::Buffer,
    ) -> Result<(), GpuError> {
        // The kernel finds each output module's system by its offset, and
        // reads the totals after the last system's (both fit u32: checked
        // by `axiom_offsets`). Empty axioms: nothing to write.
        if modules == 0 {
            return Ok(());
        }
        let mut with_totals = offsets.to_vec();
        with_totals.push([modules as u32, words as u32]);
        let counts = self.gpu.upload("axiom offsets", &with_totals)?;
        let (mate, choice) = (
            self.gpu.storage("unused", 16)?,
            self.gpu.storage("unused", 16)?,
        );
        let empty = DeviceString {
            syms: self.gpu.storage("unused", 16)?,
            starts: self.gpu.storage("unused", 16)?,
            params: self.gpu.storage("unused", 16)?,
            keys: None,
            len: 0,
            words: 0,
        };
        let params = DeriveParams {
            n: self.jobs.len() as u32,
            systems: self.jobs.len() as u32,
            iteration: 0,
            axiom: 1,
            keyed: u32::from(self.keyed),
            ..DeriveParams::default()
        };
        let pass = Pass {
            input: &empty,
            mate: &mate,
            counts: &counts,
            choice: &choice,
            out,
            status,
        };
        self.dispatch_derive(enc, self.kernels.rewrite, &params, &pass, modules)?;
        let mut done = vec![mate, choice];
        done.extend(empty.into_buffers());
        self.gpu.recycle(done);
        Ok(())
    }

    /// String 0: every system's axiom, evaluated on the device (one thread
    /// per module, writing at offsets computed here).
    fn axiom(&self) -> Result<DeviceString, GpuError> {
        let (offsets, m, w) = self.axiom_offsets()?;
        let out = self.alloc_string(m, w)?;
        let status = self
            .gpu
            .storage_zeroed("axiom status", u64::from(STATUS_WORDS) * 4)?;
        let mut enc = self.gpu.encoder();
        self.record_axiom(&mut enc, &offsets, (m, w), &out, &status)?;
        self.gpu
            .queue()
            .write_buffer(&out.starts, 4 * m, bytemuck::bytes_of(&(w as u32)));
        let st = self
            .gpu
            .read::<u32>(enc, &[(&status, 0, u64::from(STATUS_WORDS))])?;
        let st = st.into_iter().next().unwrap_or_default();
        // Only the rewrite ran (slot 1); its thread index is the system.
        let word = |k: usize| st.get(k).copied().unwrap_or(0);
        if word(2) != 0 {
            return Err(GpuError::Runtime {
                system: u32::MAX - word(2),
                iteration: 0,
                position: 0,
                symbol: String::new(),
                kind: kind_of(word(3)),
            });
        }
        Ok(out)
    }

    /// One rewriting step producing string `iteration`.
    fn step(
        &self,
        input: &DeviceString,
        iteration: u32,
        opts: &GpuDeriveOptions,
        status: &wgpu::Buffer,
        previous: &wgpu::Buffer,
    ) -> Result<DeviceString, GpuError> {
        let gpu = self.gpu;
        let n = input.len;
        let mut enc = gpu.encoder();
        let mut scratch_bufs = Vec::new();
        let mate = if self.has_context {
            let tree = brackets::record_match(gpu, &mut enc, &self.tables, &input.syms, n)?;
            scratch_bufs.push(tree.levels);
            scratch_bufs.push(tree.pairs);
            tree.mate
        } else {
            gpu.storage("unused", 16)?
        };
        let scratch = 8 * (n + 1)
            + 4 * n
            + if self.has_context {
                4 * n + brackets::scratch_bytes(n)
            } else {
                0
            };
        let counts = gpu.storage("output counts", 8 * (n + 1))?;
        let choice = gpu.storage("production choices", 4 * n)?;
        let dummy = self.alloc_string(0, 0)?;
        let params = DeriveParams {
            n: u32::try_from(n).map_err(|_| GpuError::CountOverflow {
                what: "input modules",
                count: n,
            })?,
            words: u32::try_from(input.words).map_err(|_| GpuError::CountOverflow {
                what: "input parameter words",
                count: input.words,
            })?,
            systems: self.jobs.len() as u32,
            iteration,
            keyed: u32::from(self.keyed),
            ..DeriveParams::default()
        };
        let pass = Pass {
            input,
            mate: &mate,
            counts: &counts,
            choice: &choice,
            out: &dummy,
            status,
        };
        self.dispatch_derive(&mut enc, self.kernels.count, &params, &pass, n + 1)?;
        record_scan(gpu, &mut enc, ScanElem::U32x2, &counts, n + 1)?;
        // Totals and status in one readback; then clear the status for the
        // rewrite (the copy is recorded before the clear).
        let tot = gpu.storage("totals", 8 + 4 * u64::from(STATUS_WORDS))?;
        enc.copy_buffer_to_buffer(&counts, 8 * n, &tot, 0, Some(8));
        enc.copy_buffer_to_buffer(status, 0, &tot, 8, Some(4 * u64::from(STATUS_WORDS)));
        enc.clear_buffer(status, 0, None);
        let words = gpu.read::<u32>(enc, &[(&tot, 0, 2 + u64::from(STATUS_WORDS))])?;
        let words = words.into_iter().next().unwrap_or_default();
        let word = |k: usize| words.get(k).copied().unwrap_or(0);
        let (m, w) = (u64::from(word(0)), u64::from(word(1)));
        let st = words.get(2..).unwrap_or(&[]);
        // The previous rewrite's errors come first (an earlier iteration);
        // its input's ranges are the saved directory.
        self.check_status(st, 1, iteration - 1, None, previous)?;
        self.check_status(st, 0, iteration, Some(input), &self.tables)?;
        // A saturated module count is over any module limit below it: the
        // limit is reported, as the CPU reports it (R0201), before the
        // indices that could not hold the string anyway.
        if (word(0) == u32::MAX && opts.max_modules >= u64::from(u32::MAX))
            || (word(0) != u32::MAX && word(1) == u32::MAX)
        {
            return Err(GpuError::CountOverflow {
                what: "derived modules or parameter words",
                count: m.max(w),
            });
        }
        if m > opts.max_modules {
            return Err(GpuError::ModuleLimit {
                iteration,
                modules: m,
                limit: opts.max_modules,
            });
        }
        let bytes = input.bytes() + scratch + self.string_bytes(m, w);
        if bytes > opts.max_bytes {
            return Err(GpuError::MemoryLimit {
                iteration,
                bytes,
                limit: opts.max_bytes,
            });
        }
        let out = self.alloc_string(m, w)?;
        let mut enc = gpu.encoder();
        let pass = Pass {
            input,
            mate: &mate,
            counts: &counts,
            choice: &choice,
            out: &out,
            status,
        };
        self.dispatch_derive(&mut enc, self.rewrite_kernel(), &params, &pass, n)?;
        // The last start is the total of parameter words (the scan's total).
        enc.copy_buffer_to_buffer(&counts, 8 * n + 4, &out.starts, 4 * m, Some(4));
        // Every system's range in the new string (the old one kept for
        // error reports).
        let dir_bytes = (self.directory.len() * std::mem::size_of::<SystemEntry>()) as u64;
        enc.copy_buffer_to_buffer(&self.tables, 0, previous, 0, Some(dir_bytes));
        let u = gpu.uniform("directory params", &params);
        gpu.dispatch(
            &mut enc,
            &kernels::UPDATE_DIRECTORY,
            &[&u, &self.tables, &counts],
            groups_for(self.jobs.len() as u64),
        )?;
        if opts.sync_iterations {
            gpu.submit_wait(enc)?;
        } else {
            gpu.queue().submit([enc.finish()]);
        }
        scratch_bufs.extend([mate, counts, choice, tot]);
        scratch_bufs.extend(dummy.into_buffers());
        gpu.recycle(scratch_bufs);
        Ok(out)
    }

    /// Turn an error slot of the status words into a typed error; `dir`
    /// holds the ranges of the string the failing pass read.
    fn check_status(
        &self,
        st: &[u32],
        slot: usize,
        iteration: u32,
        input: Option<&DeviceString>,
        dir: &wgpu::Buffer,
    ) -> Result<(), GpuError> {
        let (inv, bits) = (
            st.get(2 * slot).copied().unwrap_or(0),
            st.get(2 * slot + 1).copied().unwrap_or(0),
        );
        if inv == 0 {
            return Ok(());
        }
        let global = u64::from(u32::MAX - inv);
        // Which system, and the position within it.
        let entries = self
            .gpu
            .read::<SystemEntry>(self.gpu.encoder(), &[(dir, 0, self.jobs.len() as u64)])?
            .pop()
            .unwrap_or_default();
        let (system, start) = entries
            .iter()
            .enumerate()
            .find(|(_, e)| u64::from(e.start) <= global && global < u64::from(e.end))
            .map_or((0, 0), |(k, e)| (k as u32, u64::from(e.start)));
        // The symbol of the failing module (for the message), when the
        // input string is the one that failed.
        let symbol = match input {
            Some(s) if global < s.len => self
                .gpu
                .read::<u32>(self.gpu.encoder(), &[(&s.syms, global, 1)])
                .ok()
                .and_then(|v| v.into_iter().next())
                .and_then(|v| v.first().copied())
                .and_then(|sym| {
                    self.jobs.get(system as usize).and_then(|j| {
                        j.system
                            .symbol_names
                            .get((sym & SYM_MASK) as usize)
                            .cloned()
                    })
                }),
            _ => None,
        };
        Err(GpuError::Runtime {
            system,
            iteration,
            position: global - start,
            symbol: symbol.unwrap_or_default(),
            kind: kind_of(bits),
        })
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

/// The sizes of a batched derivation.
#[derive(Debug)]
struct BatchPlan {
    /// The strings derived on the CPU before the batch: 0..=k0.
    k0: usize,
    /// Every string's bound (modules, parameter words).
    bounds: Vec<(u64, u64)>,
    /// The two string buffers' capacities (even and odd strings).
    caps: [(u64, u64); 2],
    /// The largest input bound.
    max_in: u64,
    /// Blocks of each scan level for the largest input.
    levels: Vec<u64>,
}

/// Blocks of each level of a batched iteration's scan of the counts of
/// `n` input modules (`n + 1` elements), down to the level of one block:
/// level 0 is `count_scan`'s (one block per workgroup), the levels above
/// scan block sums [`SCAN_BLOCK`] at a time (shaders/batch.wgsl sizes them
/// the same way).
fn scan_levels(n: u64) -> Vec<u64> {
    let mut levels = Vec::new();
    let mut len = n + 1;
    loop {
        let per = if levels.is_empty() {
            u64::from(crate::device::WORKGROUP)
        } else {
            u64::from(SCAN_BLOCK)
        };
        let blocks = len.div_ceil(per);
        levels.push(blocks);
        if blocks <= 1 {
            break;
        }
        len = blocks;
    }
    levels
}

fn begin<'e>(enc: &'e mut wgpu::CommandEncoder, label: &'static str) -> wgpu::ComputePass<'e> {
    enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
        label: Some(label),
        timestamp_writes: None,
    })
}

/// An alternative's successor modules.
fn succ_of<'s>(
    sys: &'s CompiledSystem,
    a: &grm_compile::table::AltHeader,
) -> Option<&'s [grm_compile::table::SuccModule]> {
    let start = a.succ_offset as usize;
    sys.succ.get(start..start.checked_add(a.succ_len as usize)?)
}

/// For symbol `s`: (symbol, the most modules of it one module of `s`
/// becomes in one step), over every outcome that may happen.
fn growth_row(sys: &CompiledSystem, s: usize) -> Option<Vec<(usize, u64)>> {
    use grm_compile::table::{GROUP_CONTEXT, NONE};
    let e = sys.symbols.get(s)?;
    let mut row: std::collections::BTreeMap<usize, u64> = Default::default();
    let mut copy = true;
    for g in e.first_group..e.first_group.checked_add(e.group_count)? {
        let gh = sys.groups.get(g as usize)?;
        for a in gh.first_alt..gh.first_alt.checked_add(gh.alt_count)? {
            let mut here: std::collections::BTreeMap<usize, u64> = Default::default();
            for m in succ_of(sys, sys.alts.get(a as usize)?)? {
                if m.symbol as usize >= sys.symbols.len() {
                    return None;
                }
                *here.entry(m.symbol as usize).or_default() += 1;
            }
            for (t, q) in here {
                let r = row.entry(t).or_default();
                *r = (*r).max(q);
            }
        }
        if gh.flags & GROUP_CONTEXT == 0 && gh.cond_code == NONE {
            // Always applies: the groups after it never do, nor the copy.
            copy = false;
            break;
        }
    }
    if copy {
        let r = row.entry(s).or_default();
        *r = (*r).max(1);
    }
    Some(row.into_iter().collect())
}

/// For symbol `s`: the successors (as symbol lists) a module of it may
/// become in one step, staying as it is included where that may happen
/// (the outcomes of [`growth_row`]).
fn successors_of(sys: &CompiledSystem, s: usize) -> Option<Vec<Vec<u32>>> {
    use grm_compile::table::{GROUP_CONTEXT, NONE};
    let e = sys.symbols.get(s)?;
    let mut outs = Vec::new();
    let mut copy = true;
    for g in e.first_group..e.first_group.checked_add(e.group_count)? {
        let gh = sys.groups.get(g as usize)?;
        for a in gh.first_alt..gh.first_alt.checked_add(gh.alt_count)? {
            let succ = succ_of(sys, sys.alts.get(a as usize)?)?;
            if succ.iter().any(|m| m.symbol as usize >= sys.symbols.len()) {
                return None;
            }
            outs.push(succ.iter().map(|m| m.symbol).collect());
        }
        if gh.flags & GROUP_CONTEXT == 0 && gh.cond_code == NONE {
            copy = false;
            break;
        }
    }
    if copy {
        outs.push(vec![s as u32]);
    }
    Some(outs)
}

/// For symbol `s`: (symbol, the expected number of modules of it one
/// module of `s` becomes in one step): its first group's alternatives
/// weighted by their constant weights where that group always applies,
/// else (a condition, a context or computed weights decide)
/// [`growth_row`]'s largest outcome.
fn expected_row(sys: &CompiledSystem, s: usize) -> Option<Vec<(usize, f64)>> {
    use grm_compile::table::{GROUP_CONST_WEIGHTS, GROUP_CONTEXT, NONE};
    let e = sys.symbols.get(s)?;
    if e.group_count == 0 {
        return Some(vec![(s, 1.0)]);
    }
    let g = sys.groups.get(e.first_group as usize)?;
    let sure = g.flags & GROUP_CONTEXT == 0 && g.cond_code == NONE;
    let weighted = g.alt_count == 1 || (g.flags & GROUP_CONST_WEIGHTS != 0 && g.total_weight > 0.0);
    if !(sure && weighted) {
        let row = growth_row(sys, s)?;
        return Some(row.into_iter().map(|(t, q)| (t, q as f64)).collect());
    }
    let mut row: std::collections::BTreeMap<usize, f64> = Default::default();
    for a in g.first_alt..g.first_alt.checked_add(g.alt_count)? {
        let alt = sys.alts.get(a as usize)?;
        let p = if g.alt_count == 1 {
            1.0
        } else {
            f64::from(alt.weight) / f64::from(g.total_weight)
        };
        for m in succ_of(sys, alt)? {
            if m.symbol as usize >= sys.symbols.len() {
                return None;
            }
            *row.entry(m.symbol as usize).or_default() += p;
        }
    }
    Some(row.into_iter().collect())
}

/// Whether every module of symbol `s` becomes the same successor (or
/// stays): its first group always applies and has one alternative, or it
/// has no group. The bound is then the exact size.
fn exact_symbol(sys: &CompiledSystem, s: usize) -> bool {
    use grm_compile::table::{GROUP_CONTEXT, NONE};
    let Some(e) = sys.symbols.get(s) else {
        return false;
    };
    if e.group_count == 0 {
        return true;
    }
    sys.groups
        .get(e.first_group as usize)
        .is_some_and(|g| g.flags & GROUP_CONTEXT == 0 && g.cond_code == NONE && g.alt_count == 1)
}

//! Derive mode: [`Grower`], one system derived by the CPU engine (with
//! what [`Record`] asks recorded from the engine's own decisions) or, with
//! the `gpu` feature, by the GPU engine behind the same call.

use std::time::Instant;

use grm_compile::CompiledSystem;
use grm_derive::{DeriveError, DeriveOptions, Engine, IterationStats};

use crate::tree::{self, Tree};
use crate::{Backend, Event, GrowError, Grown, Record};

/// A system prepared to grow in derive mode: the engine, what to record.
#[derive(Debug)]
pub struct Grower<'a> {
    record: Record,
    /// The GPU backend was asked for, and edits moved the derivation to
    /// the CPU.
    moved_for_edits: bool,
    /// The CPU engine (the CPU backend).
    engine: Option<Engine<'a>>,
    /// The GPU backend.
    #[cfg(feature = "gpu")]
    gpu: Option<OnGpu<'a>>,
}

/// A system to derive on the GPU.
#[cfg(feature = "gpu")]
#[derive(Debug)]
struct OnGpu<'a> {
    sys: &'a CompiledSystem,
    /// Its turtle's system.
    system: &'a grm_sema::System,
    choice: crate::gpu::GpuChoice,
    /// The CPU engine's threads, should it derive instead.
    threads: usize,
}

impl<'a> Grower<'a> {
    /// The CPU engine; `threads` as [`Engine::new`] takes it.
    pub fn new(
        sys: &'a CompiledSystem,
        threads: usize,
        record: Record,
    ) -> Result<Self, DeriveError> {
        Ok(Grower {
            record,
            moved_for_edits: false,
            engine: Some(cpu_engine(sys, threads, record)?),
            #[cfg(feature = "gpu")]
            gpu: None,
        })
    }

    /// The engine `backend` names for `sys`, compiled from `system` (the
    /// GPU interprets with its turtle); `threads` are the CPU engine's
    /// (after a fall back, or for the CPU's report of a GPU run-time
    /// error). The GPU records keys ([`Record::keys`]) but no tree,
    /// origins or focus ([`GrowError::Unsupported`]).
    pub fn with_backend(
        sys: &'a CompiledSystem,
        system: &'a grm_sema::System,
        threads: usize,
        record: Record,
        backend: Backend,
    ) -> Result<Self, GrowError> {
        #[cfg(not(feature = "gpu"))]
        let _ = system;
        match backend {
            Backend::Cpu => Ok(Grower::new(sys, threads, record)?),
            #[cfg(feature = "gpu")]
            Backend::Gpu(choice) => {
                if record.needs_decisions() {
                    return Err(GrowError::Unsupported(
                        "the GPU records no derivation tree, origins or focus (derive on the CPU)",
                    ));
                }
                Ok(Grower {
                    record,
                    moved_for_edits: false,
                    engine: None,
                    gpu: Some(OnGpu {
                        sys,
                        system,
                        choice,
                        threads,
                    }),
                })
            }
        }
    }

    /// Replay `plan` (a system's persistent edits, [`crate::edits::
    /// edit_plan`]) in every derivation (docs/edits.md). Edits are
    /// replayed by the CPU engine: on the GPU backend a plan with edits
    /// makes the grower derive on the CPU ([`Grower::on_cpu_for_edits`]);
    /// an empty plan changes nothing. What the edits met comes back in
    /// [`Grown::edits`].
    pub fn with_edits(mut self, plan: grm_derive::EditPlan) -> Result<Self, DeriveError> {
        if plan.is_empty() {
            return Ok(self);
        }
        #[cfg(feature = "gpu")]
        if let Some(g) = self.gpu.take() {
            self.engine = Some(cpu_engine(g.sys, g.threads, self.record)?);
            self.moved_for_edits = true;
        }
        self.engine = self.engine.take().map(|e| e.with_edits(plan));
        Ok(self)
    }

    /// Whether the GPU backend was asked for but the grower derives on the
    /// CPU, because it replays edits ([`Grower::with_edits`]).
    pub fn on_cpu_for_edits(&self) -> bool {
        self.moved_for_edits
    }

    /// The CPU engine (for callers that derive again, such as frames);
    /// `None` on the GPU backend.
    pub fn engine(&self) -> Option<&Engine<'a>> {
        self.engine.as_ref()
    }

    /// Derive `opts.iterations` steps; `progress` sees the engine start
    /// and each string's figures (the axiom's first) as soon as it is
    /// complete.
    pub fn derive(
        &self,
        opts: &DeriveOptions,
        progress: &mut dyn FnMut(Event<'_>),
    ) -> Result<Grown, GrowError> {
        let never = || false;
        // Never stopped: always grown.
        self.derive_until(opts, progress, &never)
            .map(Option::unwrap_or_default)
    }

    /// [`Grower::derive`], asking `stop` before each step (and before the
    /// tree or origins are recorded): `Ok(None)` when it said stop (a
    /// preview superseded by a newer one). Without anything to record the
    /// whole derivation is the engine's, and `stop` is asked once.
    pub fn derive_until(
        &self,
        opts: &DeriveOptions,
        progress: &mut dyn FnMut(Event<'_>),
        stop: &dyn Fn() -> bool,
    ) -> Result<Option<Grown>, GrowError> {
        #[cfg(feature = "gpu")]
        if let Some(g) = &self.gpu {
            if stop() {
                return Ok(None);
            }
            let run = crate::gpu::derive(g.sys, g.system, &g.choice, self.record, opts, progress)
                .or_else(|e| match e {
                // The CPU engine stops at the same module and names
                // the source.
                crate::gpu::Failed::Runtime(e) => {
                    match grm_derive::derive(g.sys, opts, g.threads, &mut |_| {}) {
                        Err(ce) => Err(GrowError::Derive(ce)),
                        Ok(_) => Err(GrowError::Gpu(e)),
                    }
                }
                crate::gpu::Failed::Stop(e) => Err(GrowError::Gpu(e)),
                crate::gpu::Failed::FellBack => Ok(None),
            })?;
            if let Some(grown) = run {
                return Ok(Some(grown));
            }
            // The CPU derives instead (the fall back was reported).
            let engine = cpu_engine(g.sys, g.threads, self.record)?;
            return derive_cpu(&engine, self.record, opts, progress, stop).map_err(Into::into);
        }
        match &self.engine {
            Some(engine) => {
                derive_cpu(engine, self.record, opts, progress, stop).map_err(Into::into)
            }
            None => Err(GrowError::Unsupported("no engine to derive with")),
        }
    }
}

/// The CPU engine for `record` (keys when asked or when a tree is).
fn cpu_engine(
    sys: &CompiledSystem,
    threads: usize,
    record: Record,
) -> Result<Engine<'_>, DeriveError> {
    Ok(Engine::new(sys, threads)?.with_keys(record.keys || record.tree))
}

/// Derive on the CPU engine, recording what `r` asks.
#[cfg_attr(not(feature = "gpu"), allow(clippy::needless_update))]
fn derive_cpu(
    engine: &Engine<'_>,
    r: Record,
    opts: &DeriveOptions,
    progress: &mut dyn FnMut(Event<'_>),
    stop: &dyn Fn() -> bool,
) -> Result<Option<Grown>, DeriveError> {
    let step = |progress: &mut dyn FnMut(Event<'_>), stats: &IterationStats| {
        progress(Event::Step {
            stats,
            on_gpu: false,
        });
    };
    if !r.needs_decisions() {
        if stop() {
            return Ok(None);
        }
        progress(Event::Cpu);
        if engine.edit_plan().is_some() {
            let (d, outcome) = engine.derive_edited(opts, &mut |s| step(progress, s))?;
            return Ok(Some(Grown {
                string: d.string,
                stats: d.stats,
                edits: Some(outcome),
                ..Grown::default()
            }));
        }
        let d = engine.derive(opts, &mut |s| step(progress, s))?;
        return Ok(Some(Grown {
            string: d.string,
            stats: d.stats,
            ..Grown::default()
        }));
    }
    progress(Event::Cpu);
    let sys = engine.system();
    let t = Instant::now();
    // With edits: the edited road, its state carried step to step.
    let mut edited = None;
    let mut string = if engine.edit_plan().is_some() {
        let (s, state) = engine.edited_axiom(opts.seed)?;
        edited = Some(state);
        s
    } else {
        engine.axiom(opts.seed)?
    };
    let mut stats = vec![IterationStats::of(&string, 0, 0, 0, t.elapsed())];
    step(progress, &stats[0]);
    let mut tree = r.tree.then(|| Tree::axiom(sys, opts.seed, &string));
    let mut origins = r.origins.then(|| vec![sys.axiom_alt; string.len()]);
    let mut focus = r.focus.map(|f| vec![f == sys.axiom_alt; string.len()]);
    let (mut cumulative, mut processed) = (0u64, 0u64);
    for iteration in 1..=opts.iterations {
        if stop() {
            return Ok(None);
        }
        let t = Instant::now();
        let (decided, kept, removed, next) = match &mut edited {
            Some(state) => {
                let mut rec = grm_derive::StepRecord::default();
                let next = engine.edited_step(
                    state,
                    &string,
                    iteration,
                    opts.seed,
                    &opts.limits,
                    Some(&mut rec),
                )?;
                (rec.decided, Some(rec.kept), rec.removed, next)
            }
            None => {
                let decided = engine.decisions(&string, iteration, opts.seed)?;
                let next = engine.step(&string, iteration, opts.seed, &opts.limits)?;
                (decided, None, Vec::new(), next)
            }
        };
        // How many modules of the next string each module became.
        let made = |i: usize, d: Option<u32>| match &kept {
            Some(k) => k[i] as usize,
            None => d.map_or(1, |a| sys.alts[a as usize].succ_len as usize),
        };
        if let Some(tree) = &mut tree {
            // The tree grows by the new string's rewritten modules.
            let grown = tree.nodes.len() as u64 + next.len() as u64;
            let bytes =
                grown * tree::NODE_BYTES + string.heap_bytes() as u64 + next.heap_bytes() as u64;
            if bytes > opts.limits.max_bytes {
                return Err(DeriveError::MemoryLimit {
                    iteration,
                    bytes,
                    limit: opts.limits.max_bytes,
                    modules: next.len() as u64,
                    words: next.param_words() as u64,
                    file: sys.file,
                    span: sys.span,
                });
            }
            tree.advance(iteration, &decided, &made, &next, &removed);
        }
        if let Some(o) = &mut origins {
            let mut out = Vec::with_capacity(next.len());
            for (i, d) in decided.iter().enumerate() {
                let n = made(i, *d);
                match *d {
                    None => out.extend(std::iter::repeat_n(o[i], n)),
                    Some(a) => out.extend(std::iter::repeat_n(a, n)),
                }
            }
            *o = out;
        }
        if let (Some(f), Some(alt)) = (&mut focus, r.focus) {
            let mut out = Vec::with_capacity(next.len());
            for (i, d) in decided.iter().enumerate() {
                let n = made(i, *d);
                match *d {
                    None => out.extend(std::iter::repeat_n(f[i], n)),
                    Some(a) => out.extend(std::iter::repeat_n(f[i] || a == alt, n)),
                }
            }
            *f = out;
        }
        processed += string.len() as u64;
        engine.recycle(std::mem::replace(&mut string, next));
        cumulative += string.len() as u64;
        let s = IterationStats::of(&string, iteration, cumulative, processed, t.elapsed());
        step(progress, &s);
        stats.push(s);
    }
    if let Some(tree) = &mut tree {
        tree.finish(&string);
    }
    let edits = edited.map(|state| match engine.edit_plan() {
        Some(plan) => state.outcome(plan),
        None => grm_derive::EditOutcome::default(),
    });
    Ok(Some(Grown {
        string,
        stats,
        tree,
        origins,
        focus,
        edits,
        ..Grown::default()
    }))
}

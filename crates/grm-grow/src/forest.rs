//! A forest: many trees (systems, seeds, iteration counts, parameter
//! values) grown by one call, [`grow`], and each interpreted alone (the
//! CPU turtle) for a model of them all (`grmc forest`).
//!
//! On the CPU ([`Backend::Cpu`]) the trees derive in parallel, one tree
//! per worker thread (each tree's engine gets the threads left over when
//! there are fewer trees than workers). On the GPU (`Backend::Gpu`) the
//! whole forest is one derivation (`grm_gpu::run_many`, Lipp 5.4: one
//! count / scan / rewrite per iteration for every tree), with the fall
//! back to the CPU and the CPU's report of a production's run-time error
//! as for one tree (`grm_grow::gpu`). Either way every tree's string is
//! exactly what deriving it alone gives.
//!
//! Limits: [`ForestOptions::limits`]' module limit bounds each tree's
//! strings and the forest's final strings together (on the GPU they are
//! one string; on the CPU a worker whose tree takes the total over it
//! stops the rest: [`ForestError::ModuleLimit`]); its memory limit bounds
//! each derivation, and, where the trees are interpreted, what their
//! interpretations hold together, counted from the strings before any is
//! made ([`ForestError::MemoryLimit`], R0202).

use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};

use grm_compile::CompiledSystem;
use grm_derive::{DeriveError, DeriveLimits, DeriveOptions, Engine, ModuleString};
use grm_turtle::{Interpretation, TurtleError};

use crate::{Backend, Event};

/// One tree to grow.
#[derive(Clone, Copy, Debug)]
pub struct ForestTree<'a> {
    /// The checked system (its turtle interprets the tree).
    pub system: &'a grm_sema::System,
    /// It compiled, with the tree's parameter values.
    pub compiled: &'a CompiledSystem,
    pub iterations: u32,
    pub seed: u32,
}

/// How a forest grows.
#[derive(Clone, Copy, Debug, Default)]
pub struct ForestOptions {
    /// See the module documentation.
    pub limits: DeriveLimits,
    /// CPU worker threads (0: all cores).
    pub threads: usize,
    /// Interpret every tree on the host ([`GrownTree::interpretation`]),
    /// held to the memory limit together.
    pub interpret: bool,
    pub backend: Backend,
}

/// One tree grown.
#[derive(Clone, Debug)]
pub struct GrownTree<T> {
    /// Modules of its final string.
    pub modules: u64,
    /// Its interpretation ([`ForestOptions::interpret`]), without spare
    /// capacity.
    pub interpretation: Option<Interpretation>,
    /// What the caller kept of its string (the `keep` of [`grow`]).
    pub kept: T,
}

/// How a forest ran.
#[derive(Clone, Debug)]
pub enum Ran {
    /// On the CPU, trees in parallel on this many workers.
    Cpu { workers: usize },
    /// On the GPU, in one derivation.
    #[cfg(feature = "gpu")]
    Gpu {
        /// The combined string's figures (the axioms, then each step).
        stats: Vec<grm_gpu::GpuIterationStats>,
        /// Bones of the device's interpretation, where it interpreted.
        bones: Option<u64>,
        /// Wall time of the derivation and interpretation on the device.
        elapsed: std::time::Duration,
    },
}

/// A grown forest.
#[derive(Clone, Debug)]
pub struct Forest<T> {
    /// Every tree, in order; empty when nothing came back per tree (a GPU
    /// forest whose strings stay on the device).
    pub trees: Vec<GrownTree<T>>,
    /// The final strings' modules, all trees together.
    pub modules: u64,
    /// Modules produced over the derivations.
    pub produced: u64,
    pub ran: Ran,
}

/// Why a forest stopped.
#[derive(Clone, Debug, PartialEq)]
pub enum ForestError {
    /// A tree's derivation failed (the first in tree order).
    Derive { tree: usize, error: DeriveError },
    /// A tree's interpretation failed.
    Turtle { tree: usize, error: TurtleError },
    /// The forest's final strings together would pass the module limit;
    /// `tree` took it over (`modules`: the total then).
    ModuleLimit {
        tree: usize,
        modules: u64,
        limit: u64,
    },
    /// The trees' interpretations together would pass the memory limit
    /// (counted from the strings, before any is made); `tree` took it
    /// over (on the CPU; the GPU counts all strings at once).
    MemoryLimit {
        tree: Option<usize>,
        footprint: grm_geom::Footprint,
        limit: u64,
    },
    /// The GPU's error, where the CPU did not take over.
    #[cfg(feature = "gpu")]
    Gpu(grm_gpu::GpuError),
}

/// Run `f(i)` for `i` in `0..n` on up to `threads` threads (0: all
/// cores), results in order.
pub fn parallel_map<R: Send>(n: usize, threads: usize, f: impl Fn(usize) -> R + Sync) -> Vec<R> {
    let cores = std::thread::available_parallelism().map_or(1, |c| c.get());
    let workers = if threads == 0 { cores } else { threads }.clamp(1, n.max(1));
    if workers == 1 {
        return (0..n).map(f).collect();
    }
    let next = AtomicUsize::new(0);
    let out: Mutex<Vec<Option<R>>> = Mutex::new((0..n).map(|_| None).collect());
    std::thread::scope(|s| {
        for _ in 0..workers {
            s.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    if i >= n {
                        break;
                    }
                    let r = f(i);
                    // A poisoned lock means another worker panicked, which
                    // the scope re-raises anyway.
                    if let Ok(mut o) = out.lock() {
                        o[i] = Some(r);
                    }
                }
            });
        }
    });
    out.into_inner()
        .unwrap_or_default()
        .into_iter()
        .flatten()
        .collect()
}

/// Grow `trees` as `opts` says. `keep` makes what the caller keeps of
/// each tree's string (its text, say), on the worker that derived it;
/// `progress` hears of a fall back from the GPU.
pub fn grow<T: Send>(
    trees: &[ForestTree<'_>],
    opts: &ForestOptions,
    keep: &(dyn Fn(usize, &ModuleString) -> T + Sync),
    progress: &mut dyn FnMut(Event<'_>),
) -> Result<Forest<T>, ForestError> {
    let _ = &progress;
    #[cfg(feature = "gpu")]
    if let Backend::Gpu(choice) = opts.backend {
        use crate::gpu::Failed;
        match grow_gpu(trees, opts, &choice, keep, progress) {
            Ok(Some(f)) => return Ok(f),
            // The CPU derives instead (reported).
            Ok(None) | Err(GpuStop::Gpu(Failed::FellBack)) => {}
            Err(GpuStop::Forest(e)) => return Err(e),
            Err(GpuStop::Gpu(Failed::Stop(e))) => return Err(ForestError::Gpu(e)),
            // A value failed: the CPU engine derives the forest to report
            // it with its source; the GPU's error stands should the CPU
            // not fail (not a forest the engines disagree on).
            Err(GpuStop::Gpu(Failed::Runtime(e))) => {
                grow_cpu(trees, opts, keep)?;
                return Err(ForestError::Gpu(e));
            }
        }
    }
    grow_cpu(trees, opts, keep)
}

/// Add `f` to `sum`.
fn add(sum: &mut grm_geom::Footprint, f: &grm_geom::Footprint) {
    sum.bones += f.bones;
    sum.instances += f.instances;
    sum.polygons += f.polygons;
    sum.polygon_vertices += f.polygon_vertices;
    sum.bytes = sum.bytes.saturating_add(f.bytes);
}

/// The forest on the CPU. The first failing tree's error, in tree order.
fn grow_cpu<T: Send>(
    trees: &[ForestTree<'_>],
    opts: &ForestOptions,
    keep: &(dyn Fn(usize, &ModuleString) -> T + Sync),
) -> Result<Forest<T>, ForestError> {
    let lim = opts.limits;
    enum Failure {
        Derive(DeriveError),
        Turtle(TurtleError),
        /// The forest's total passed the limit (modules so far) with
        /// this tree.
        Forest(u64),
        /// The trees' interpretations together passed the memory limit
        /// with this tree.
        Memory(grm_geom::Footprint),
        /// Not derived: another tree stopped the forest.
        Skipped,
    }
    let cores = std::thread::available_parallelism().map_or(1, |c| c.get());
    let threads = if opts.threads == 0 {
        cores
    } else {
        opts.threads
    };
    let workers = threads.clamp(1, trees.len().max(1));
    let engine_threads = (threads / workers).max(1);
    let total = AtomicU64::new(0);
    // What the trees' interpretations hold together (the forest's model is
    // built from them all: the memory limit bounds them as it bounds one
    // model's; grm_geom::budget).
    let held = Mutex::new(grm_geom::Footprint::default());
    let stop = AtomicBool::new(false);
    let results = parallel_map(trees.len(), workers, |k| {
        if stop.load(Ordering::Relaxed) {
            return Err(Failure::Skipped);
        }
        let t = &trees[k];
        let d = DeriveOptions {
            iterations: t.iterations,
            seed: t.seed,
            limits: lim,
        };
        let d = Engine::new(t.compiled, engine_threads)
            .and_then(|e| e.derive(&d, &mut |_| {}))
            .map_err(|e| {
                stop.store(true, Ordering::Relaxed);
                Failure::Derive(e)
            })?;
        let modules = d.string.len() as u64;
        let sum = total.fetch_add(modules, Ordering::Relaxed) + modules;
        if sum > lim.max_modules {
            stop.store(true, Ordering::Relaxed);
            return Err(Failure::Forest(sum));
        }
        let produced = d.stats.last().map_or(0, |s| s.cumulative_modules);
        let interpretation = match opts.interpret {
            true => {
                let f = grm_geom::budget::count_string(t.system, &d.string);
                let over = {
                    let mut h = held.lock().unwrap_or_else(|p| p.into_inner());
                    add(&mut h, &f);
                    (h.bytes > lim.max_bytes).then_some(*h)
                };
                if let Some(h) = over {
                    stop.store(true, Ordering::Relaxed);
                    return Err(Failure::Memory(h));
                }
                let i = interpret(t, &d.string).map_err(Failure::Turtle)?;
                Some(i)
            }
            false => None,
        };
        Ok((
            GrownTree {
                modules,
                interpretation,
                kept: keep(k, &d.string),
            },
            produced,
        ))
    });
    let mut out = Vec::with_capacity(results.len());
    let mut produced = 0u64;
    let mut over = None;
    let mut memory: Option<(grm_geom::Footprint, usize)> = None;
    for (k, r) in results.into_iter().enumerate() {
        match r {
            Ok((g, p)) => {
                out.push(g);
                produced = produced.saturating_add(p);
            }
            Err(Failure::Derive(error)) => return Err(ForestError::Derive { tree: k, error }),
            Err(Failure::Turtle(error)) => return Err(ForestError::Turtle { tree: k, error }),
            Err(Failure::Forest(sum)) => {
                if over.is_none_or(|(s, _)| sum > s) {
                    over = Some((sum, k));
                }
            }
            Err(Failure::Memory(f)) => {
                if memory.is_none_or(|(m, _)| f.bytes > m.bytes) {
                    memory = Some((f, k));
                }
            }
            Err(Failure::Skipped) => {}
        }
    }
    if let Some((footprint, k)) = memory {
        return Err(ForestError::MemoryLimit {
            tree: Some(k),
            footprint,
            limit: lim.max_bytes,
        });
    }
    if let Some((modules, k)) = over {
        return Err(ForestError::ModuleLimit {
            tree: k,
            modules,
            limit: lim.max_modules,
        });
    }
    Ok(Forest {
        modules: out.iter().map(|g| g.modules).sum(),
        trees: out,
        produced,
        ran: Ran::Cpu { workers },
    })
}

/// Interpret one tree's string with its own system and settings, held to
/// the end (no spare capacity).
fn interpret(t: &ForestTree<'_>, s: &ModuleString) -> Result<Interpretation, TurtleError> {
    let mut i = grm_turtle::interpret(t.system, &t.compiled.settings, s)?;
    i.bones.shrink_to_fit();
    i.instances.shrink_to_fit();
    i.polygons.shrink_to_fit();
    i.polygon_vertices.shrink_to_fit();
    Ok(i)
}

/// How a GPU forest stopped.
#[cfg(feature = "gpu")]
enum GpuStop {
    Gpu(crate::gpu::Failed),
    Forest(ForestError),
}

/// The forest as one GPU derivation (`run_many`); `None`: the CPU derives
/// instead (reported through `progress`).
#[cfg(feature = "gpu")]
fn grow_gpu<T: Send>(
    trees: &[ForestTree<'_>],
    opts: &ForestOptions,
    choice: &crate::gpu::GpuChoice,
    keep: &(dyn Fn(usize, &ModuleString) -> T + Sync),
    progress: &mut dyn FnMut(Event<'_>),
) -> Result<Option<Forest<T>>, GpuStop> {
    use crate::gpu::{Failed, failed};
    use grm_gpu::{GpuJob, GpuRunOptions, TurtleProgram};
    let lim = opts.limits;
    let gpu = match grm_gpu::shared() {
        Ok(g) => g,
        Err(e) => {
            return match failed(e, choice, progress) {
                Failed::FellBack => Ok(None),
                f => Err(GpuStop::Gpu(f)),
            };
        }
    };
    let turtles: Vec<TurtleProgram> = trees
        .iter()
        .map(|t| TurtleProgram::new(t.system, &t.compiled.settings))
        .collect();
    let turtle_refs: Vec<&TurtleProgram> = turtles.iter().collect();
    let jobs: Vec<GpuJob<'_>> = trees
        .iter()
        .map(|t| GpuJob {
            system: t.compiled,
            iterations: t.iterations,
            seed: t.seed,
        })
        .collect();
    let whole = DeriveOptions {
        iterations: 0,
        seed: 0,
        limits: lim,
    };
    let run = GpuRunOptions {
        derive: crate::gpu::derive_options(&whole, choice, false),
        interpret: choice.interpret,
        read_string: choice.read_string,
        read_bones: false,
        strategy: grm_gpu::DeriveStrategy::Auto,
        branch_scan: grm_gpu::interp::BranchScan::Auto,
        pipelined: true,
    };
    let r = match grm_gpu::run_many(gpu, &jobs, &turtle_refs, &run, &mut |_| {}) {
        Ok(r) => r,
        Err(e) => {
            return match failed(e, choice, progress) {
                Failed::FellBack => Ok(None),
                f => Err(GpuStop::Gpu(f)),
            };
        }
    };
    let ran = Ran::Gpu {
        stats: r.stats.clone(),
        bones: r.interpretation.as_ref().map(|i| i.bone_count),
        elapsed: r.derive_elapsed
            + r.interpretation
                .as_ref()
                .map_or(std::time::Duration::ZERO, |i| i.elapsed),
    };
    let produced = r.produced;
    let modules = r.stats.last().map_or(0, |s| s.modules);
    let Some(strings) = r.strings else {
        return Ok(Some(Forest {
            trees: Vec::new(),
            modules,
            produced,
            ran,
        }));
    };
    if opts.interpret {
        // The trees' interpretations are held together, as on the CPU:
        // counted from the strings (which are held too) before any is made.
        let mut f = grm_geom::Footprint::default();
        for (k, s) in strings.iter().enumerate() {
            let mut t = grm_geom::budget::count_string(trees[k].system, s);
            t.bytes = t.bytes.saturating_add(s.heap_bytes() as u64);
            add(&mut f, &t);
        }
        if f.bytes > lim.max_bytes {
            return Err(GpuStop::Forest(ForestError::MemoryLimit {
                tree: None,
                footprint: f,
                limit: lim.max_bytes,
            }));
        }
    }
    let interpretations = parallel_map(strings.len(), opts.threads, |k| {
        opts.interpret
            .then(|| interpret(&trees[k], &strings[k]))
            .transpose()
    });
    let mut grown = Vec::with_capacity(strings.len());
    for (k, (s, i)) in strings.iter().zip(interpretations).enumerate() {
        match i {
            Ok(interpretation) => grown.push(GrownTree {
                modules: s.len() as u64,
                interpretation,
                kept: keep(k, s),
            }),
            Err(error) => return Err(GpuStop::Forest(ForestError::Turtle { tree: k, error })),
        }
    }
    Ok(Some(Forest {
        trees: grown,
        modules,
        produced,
        ran,
    }))
}

//! The sampler: the SOSMC loop, the expected directions, wrap-up and the
//! geometry phase.

use std::collections::HashMap;
use std::mem::size_of;
use std::sync::Arc;
use std::time::{Duration, Instant};

use glam::Vec3;
use grm_compile::CompiledSystem;
use grm_compile::rng::{self, DrawCtx};
use grm_derive::ModuleString;
use grm_guide::{
    BonePlan, CostBreakdown, CostModel, CostOptions, Curves, ExpectedDirection, VolumeOptions,
    VolumeTarget,
};
use grm_sema::{Mode, System};
use grm_turtle::{Interpreter, Turtle};
use rayon::prelude::*;

use crate::cancel::{self, CancelToken};
use crate::edits::{EditPlan, PINNED, Replay, pinned_draws};
use crate::error::{LimitKind, SampleError};
use crate::expand::{Grammar, Which, Worker};
use crate::model::*;
use crate::particle::*;
use crate::pvec::PVec;
use crate::refine::{self, Refine};
use crate::resample;
use crate::schedule::Schedule;
use crate::tubes_memo::TubesMemo;

/// What the search minimizes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Objective {
    /// The guiding-curve cost of Calder (eq. 1-8, plus density when the
    /// curves file turns it on), with the heuristic of eq. 9-10.
    Curves,
    /// The volume-matching baseline (`grm_guide::VolumeTarget`): likelihood
    /// `exp(-weight * cost)`; no heuristic (eq. 10 is a curve term).
    Volume {
        options: VolumeOptions,
        /// The volume cost lies in `[0, 2]`; the weight puts it on a scale
        /// comparable to the curve cost's.
        weight: f64,
    },
}

/// How the expected directions (eq. 9) are estimated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ExpectedOptions {
    /// Sub-derivations sampled per skeleton symbol.
    pub models: u32,
    /// Expansions per sub-derivation (its open skeleton symbols are
    /// expanded in random order until none is left or this many were made).
    pub expansions: u32,
    /// The fixed seed of those samples (independent of the run's seed).
    pub seed: u32,
}

impl Default for ExpectedOptions {
    /// 64 models of up to 24 expansions each, seed `0x5EED`.
    fn default() -> Self {
        ExpectedOptions {
            models: 64,
            expansions: 24,
            seed: 0x5EED,
        }
    }
}

/// The default [`SampleOptions::ess_target`]: every generation keeps an
/// effective sample size of at least a tenth of its particles (no
/// population collapse). With Calder's untempered weights the ESS is 1 to 3
/// of 15 to 100 particles; with tempering alone the final cost rises, and
/// the candidates ([`DEFAULT_CANDIDATES`]) win it back
/// (`docs/sampling.md` section 4, `docs/benchmarks.md`).
pub const DEFAULT_ESS_TARGET: f64 = 0.1;

/// The default [`SampleOptions::candidates`]: 12 candidate expansions per
/// bone-making expansion. With [`Guide::default`] a particle then does
/// about four times the work of one with Calder's proposal, and a quarter
/// of Calder's particles (the examples' schedules: 25 -> 4) covers the
/// curves far more often at a lower cost in less time than 3 candidates
/// with Calder's 100 -> 15 (`docs/sampling.md` section 4.3,
/// `docs/benchmarks.md` "Curve coverage"). Before the curve-coverage work
/// it was 3.
pub const DEFAULT_CANDIDATES: u32 = 12;

/// The default [`Guide::order`]: the most promising of 3 open symbols
/// drawn at random (with [`Reach::recent`]'s 3 newest: of 6). It was 4
/// before the reach look-ahead (`docs/sampling.md` section 4.4).
pub const DEFAULT_ORDER: u32 = 3;

/// The default [`Guide::cover`]: the coverage term at `W = 150`.
pub const DEFAULT_COVER: f64 = 150.0;

/// How the search steers towards covering every curve, beyond the paper
/// (`docs/sampling.md` section 4.3). [`Guide::paper`] turns it all off:
/// the stochastic order of Calder's method. The cost (eq. 1-8) is the
/// same either way: these change which open symbol a step expands, not
/// how a model is scored.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Guide {
    /// Expansion order: each expansion draws this many open symbols
    /// uniformly (with replacement) and expands the one whose position
    /// promises the cheapest next bone (the distance cost there, eq. 10's
    /// alignment for the symbol's expected direction, and the utilization
    /// the curve's next segment would still give). 1 is the paper's
    /// uniform order (the draw is then exactly the paper's).
    pub order: u32,
    /// Weight `W` of the coverage term of the search objective, in cost
    /// units: a particle is searched (weighted, its candidates chosen and
    /// the final models ranked) by `cost + T` with
    /// `T = -W sum_curves n_c (1 - (1 - k_c / n_c)^2)`, `n_c` the curve's
    /// utilization segments and `k_c` those covered (spanned by a bone
    /// with both ends within the curve's thickness + 0.15 of it,
    /// `CostModel::covered_segments`). A newly covered segment of a curve
    /// covered over a share `s` gains about `2 W (1 - s)`: the
    /// least-covered curve gains most. The reported cost is eq. 1-8 (plus
    /// density) without it. 0 turns it off (the paper's objective); only
    /// the curve objective uses it.
    pub cover: f64,
}

impl Guide {
    /// The paper's stochastic order (uniform over the open symbols).
    pub fn paper() -> Guide {
        Guide {
            order: 1,
            cover: 0.0,
        }
    }
}

impl Default for Guide {
    /// The measured best (`docs/sampling.md` sections 4.3-4.4): a
    /// tournament of 3 random draws for the order ([`DEFAULT_ORDER`]; with
    /// [`Reach::recent`] the newest open symbols enter too) and the
    /// coverage term at `W = 150` ([`DEFAULT_COVER`]).
    fn default() -> Self {
        Guide {
            order: DEFAULT_ORDER,
            cover: DEFAULT_COVER,
        }
    }
}

/// The reach look-ahead (`docs/sampling.md` section 4.4): how far a
/// subtree grown from an open symbol could still follow a curve, and how
/// much that counts. Works with [`Guide::cover`] (its weight `W` sets the
/// unit); all off with [`Reach::off`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reach {
    /// Weight of the look-ahead in the candidates' choice.
    pub candidates: f64,
    /// Weight of the look-ahead in the expansion order's promise (0: the
    /// next segment's cover gain, as before).
    pub order: f64,
    /// Multiplier of the symbols' reach factors.
    pub scale: f64,
    /// Whether the candidates' look-ahead follows the curves that start
    /// on a curve (an arm drawn from a trunk: a longer trunk bone reaches
    /// further along the arms).
    pub branches: bool,
    /// The newest open symbols (this many, last opened first) enter every
    /// expansion's tournament besides its [`Guide::order`] random draws,
    /// so a chain that follows a curve can be grown on at once.
    pub recent: u32,
    /// Weight of the look-ahead at a particle's newest tip in its score
    /// (so in the weights that resample the population): 0 leaves the
    /// weights as without the look-ahead.
    pub weights: f64,
    /// Whether a reach is capped by the bones the generations left can
    /// grow (a bone a generation, each the symbol's stride): where the
    /// schedule, not the grammar, is what limits the model (the vine). The
    /// one part of the search that depends on the run's length, so with it
    /// frame K is the model of the run stopped after generation K but not
    /// that of a run of K + 1 generations (`docs/sampling.md` section 9).
    pub budget: bool,
    /// Candidates per bone for a *paced* symbol (when more than 0 and
    /// fewer than [`SampleOptions::candidates`]): one whose bones all have
    /// one length (the sub-derivations of its reach factor draw their
    /// first bone at one length: the vine's internodes, not the Calder
    /// tree's randomly scaled branches). There a candidate can choose a
    /// bone's direction but not a longer bone (the chain's reach is the
    /// bone count's), and what decides the model is where the chains fork,
    /// which the population chooses: fewer candidates leave the time for
    /// more particles (`docs/sampling.md` section 4.4). Only with the
    /// coverage term on; 0 is off.
    pub paced: u32,
}

impl Reach {
    /// No look-ahead.
    pub fn off() -> Reach {
        Reach {
            candidates: 0.0,
            order: 0.0,
            scale: 1.0,
            branches: false,
            recent: 0,
            weights: 0.0,
            budget: false,
            paced: 0,
        }
    }
}

impl Default for Reach {
    /// The measured best (`docs/sampling.md` section 4.4): the look-ahead
    /// in the candidates' choice at weight 1 and in the order's promise at
    /// 0.5, reach factors times 1.5, following the curves that start on a
    /// curve, the 3 newest open symbols in every tournament, the newest
    /// tip's look-ahead in the particles' scores at 0.25, and reaches
    /// capped by the generations left.
    fn default() -> Self {
        Reach {
            candidates: 1.0,
            order: 0.5,
            scale: 1.5,
            branches: true,
            recent: 3,
            weights: 0.25,
            budget: true,
            paced: DEFAULT_PACED_CANDIDATES,
        }
    }
}

/// Candidates per bone for a paced symbol by default ([`Reach::paced`]).
pub const DEFAULT_PACED_CANDIDATES: u32 = 2;

/// Wrap-up and geometry expansions between two checks of the cancel token.
const CANCEL_EVERY: u32 = 4096;

/// The most worker threads [`Sampler::sample`] starts
/// ([`SampleOptions::threads`]); asking for more is
/// [`SampleError::Options`] (R0308), returned before any thread starts.
/// The same maximum as the derivation engine's ([`grm_derive::MAX_THREADS`])
/// and `grmc --threads`: tens of thousands of threads exhaust memory and the
/// operating system then fails inside the new threads, which panics.
/// `threads: 0` (all cores) uses at most this many too.
pub const MAX_THREADS: usize = grm_derive::MAX_THREADS;

/// Which frames a run keeps ([`SampleOptions::frames`],
/// [`Sampler::sample_frame`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Keep {
    None,
    All,
    /// This generation's alone (past the last generation run: the last).
    One(u32),
}

impl Keep {
    /// Whether generation `g`'s frame is kept, were it not the last.
    fn wants(self, g: u32) -> bool {
        match self {
            Keep::None => false,
            Keep::All => true,
            Keep::One(k) => k == g,
        }
    }

    /// Whether the last generation run, `g`, has its frame kept (the
    /// result).
    fn wants_last(self, g: u32) -> bool {
        match self {
            Keep::None => false,
            Keep::All => true,
            Keep::One(k) => k >= g,
        }
    }
}

/// How one run samples.
#[derive(Clone, Debug, PartialEq)]
pub struct SampleOptions {
    /// The seed of every random draw of the run.
    pub seed: u32,
    pub schedule: Schedule,
    /// Whether the heuristic (eq. 10) is used (with the schedule's scale).
    pub heuristic: bool,
    /// Likelihood `exp(-objective / temperature)`; 1 is Calder's.
    /// `f64::INFINITY` gives every particle the same weight (unguided
    /// sampling: resampling then only thins the population).
    pub temperature: f64,
    /// Adaptive tempering: each generation's incremental log-weights are
    /// multiplied by the largest `beta` in `(0, 1]` that keeps the effective
    /// sample size at least this fraction of the generation's particle
    /// count (bisection, deterministic; `docs/sampling.md` section 4.2).
    /// 0 disables it: the untempered weights, Calder's. Default
    /// [`DEFAULT_ESS_TARGET`].
    pub ess_target: f64,
    /// Worker threads: 1 runs on the calling thread, 0 uses all cores,
    /// at most [`MAX_THREADS`] (more is [`SampleError::Options`]).
    /// The result does not depend on it.
    pub threads: usize,
    /// Stop the search after the generation during which this much wall
    /// time has passed (then wrap up and finish as usual). The one
    /// non-deterministic option: where it stops depends on the machine.
    /// The time spent on frames ([`SampleOptions::frames`]) does not
    /// count: they finish models beside the search, and must not make a
    /// budget stop it sooner than it would without them.
    pub budget: Option<Duration>,
    /// How many of the best distinct final models to return (at least 1).
    pub best: usize,
    /// A particle's step expands random open skeleton symbols until one
    /// adds a bone, at most this many.
    pub max_expansions_per_step: u32,
    /// Candidate expansions per bone-making expansion (the proposal of
    /// `docs/sampling.md` section 4.1): each expansion of a symbol that can
    /// make a bone draws this many candidates (production and parameters)
    /// and keeps one, chosen in proportion to `exp(-cost / temperature)` of
    /// its bones; the particle's weight is corrected by the candidates'
    /// mean. 1 is the plain proposal (the grammar's own draws, Calder's).
    /// Only the curve objective at a finite temperature uses candidates.
    /// Default [`DEFAULT_CANDIDATES`].
    pub candidates: u32,
    /// How the expansion order steers towards every curve ([`Guide`];
    /// [`Guide::paper`] is Calder's uniform order).
    pub guide: Guide,
    /// The reach look-ahead ([`Reach`]).
    pub reach: Reach,
    /// Refinement rounds after the SMC pass, for a model that leaves a
    /// curve under-covered ([`Refine`]; [`Refine::off`] is the pass alone).
    pub refine: Refine,
    pub limits: FinishLimits,
    /// Stop with [`SampleError::MemoryLimit`] after a generation that
    /// leaves the search holding more than this many bytes
    /// ([`crate::GenerationStats::memory_bytes`]: the arena's buffers and
    /// its structure (a step per particle per generation, where it made
    /// nodes), recycled buffers, the kept particles, the generation
    /// records, the per-particle weights, and the frames kept so far). Checked
    /// between generations, so a run ends at most one generation's growth
    /// past it. Default [`DEFAULT_MAX_BYTES`].
    pub max_bytes: u64,
    /// Cooperative cancellation: when another thread sets the token, the
    /// run stops at its next check (between generations, before wrap-up
    /// and the geometry phase, every 4096 wrap-up or geometry expansions)
    /// and returns [`SampleError::Cancelled`]. A token that is never set
    /// changes nothing: the result is the same as without one.
    pub cancel: Option<CancelToken>,
    /// Keep a frame per generation ([`SampleResult::frames`]): the model
    /// this run returns when its budget stops it after that generation
    /// (the generation's distinct particles wrapped up, the best one
    /// built, with the draws the end of the run gives them). Costs the
    /// end of a run per generation; the search itself (its draws,
    /// weights, resampling and result) is the same with or without. The
    /// frames kept count towards [`SampleOptions::max_bytes`].
    /// [`Sampler::sample_frame`] keeps one frame alone.
    pub frames: bool,
}

impl Default for SampleOptions {
    fn default() -> Self {
        SampleOptions {
            seed: 0,
            schedule: Schedule::calder_playground(),
            heuristic: true,
            temperature: 1.0,
            ess_target: DEFAULT_ESS_TARGET,
            threads: 1,
            budget: None,
            best: 1,
            max_expansions_per_step: 1000,
            candidates: DEFAULT_CANDIDATES,
            guide: Guide::default(),
            reach: Reach::default(),
            refine: Refine::default(),
            limits: FinishLimits::default(),
            max_bytes: DEFAULT_MAX_BYTES,
            cancel: None,
            frames: false,
        }
    }
}

/// The default of [`SampleOptions::max_bytes`]: 2 GiB, the CPU
/// derivation's default too (`grm_derive::DeriveLimits`).
pub const DEFAULT_MAX_BYTES: u64 = 2048 << 20;

impl SampleOptions {
    /// Forward sampling without guidance: one particle, no weights, the
    /// schedule's number of generations (steps).
    pub fn unguided(seed: u32, generations: u32) -> SampleOptions {
        SampleOptions {
            seed,
            schedule: Schedule {
                generations,
                particles_start: 1,
                particles_end: 1,
                heuristic_scale: 0.0,
                heuristic_until: 0,
            },
            heuristic: false,
            temperature: f64::INFINITY,
            candidates: 1,
            ..SampleOptions::default()
        }
    }
}

/// A sample system prepared for guided sampling: the compiled grammar, the
/// cost of the curves and the expected direction of every skeleton symbol
/// (eq. 9, computed here, once).
#[derive(Debug)]
pub struct Sampler<'a> {
    g: Grammar<'a>,
    cost: CostModel,
    objective: Objective,
    volume: Option<VolumeTarget>,
    /// Per symbol: EXPECTED (zero for non-skeleton symbols and for those
    /// that never grow a bone).
    expected: Vec<Vec3>,
    /// Per symbol: its reach factor (the look-ahead of
    /// [`SampleOptions::reach`]): the upper quartile, over sub-derivations
    /// grown depth first from the symbol alone in the identity frame, of
    /// the longest chain of bones (0 for symbols that grow none).
    reach: Vec<f32>,
    /// Per symbol: the median length of the first bone its depth-first
    /// sub-derivations grow (a bone's length in the identity frame).
    stride: Vec<f32>,
    /// Per symbol: whether the first bones of those sub-derivations all
    /// have one length (the vine's internodes; not the Calder tree's
    /// branches, scaled by a random draw): a candidate can turn such a
    /// bone, not lengthen it ([`Reach::paced`]).
    fixed: Vec<bool>,
    expected_time: Duration,
    /// Per curve: its Bézier and parameters (as the cost model has them).
    guides: Vec<(grm_guide::Bezier3, grm_guide::CurveParams)>,
    /// The curves, for refinement's coverage check
    /// ([`Refine::followed_ends`]).
    curves: Curves,
    /// The persistent edits replayed ([`Self::with_edits`]); `None`: the
    /// plain sampler.
    replay: Option<Replay>,
}

// Random streams. Every draw is `rng::hash` of the run's seed and a tuple
// naming exactly one decision, so the run is a function of (program,
// curves, seed, schedule) and of nothing else (not of thread timing).
const STREAM_SKELETON: u32 = 1;
const STREAM_RESAMPLE: u32 = 2;
const STREAM_AXIOM: u32 = 3;
const STREAM_WRAPUP: u32 = 4;
const STREAM_GEOMETRY: u32 = 5;
const STREAM_EXPECTED: u32 = 6;
const STREAM_ORDER: u32 = 7;
const STREAM_CANDIDATE: u32 = 8;
const STREAM_REACH: u32 = 9;

/// Expansions of each depth-first sub-derivation of the reach factors.
const REACH_EXPANSIONS: u32 = 96;

/// Expansion `k` of particle `i`'s step in generation `g`.
fn skeleton_draws(seed: u32, g: u32, i: u32, k: u32) -> DrawCtx {
    DrawCtx {
        seed: rng::hash(seed, g, i, k),
        iteration: STREAM_SKELETON,
        position: 0,
    }
}

fn tagged(seed: u32, tag: u32, a: u32, b: u32) -> DrawCtx {
    DrawCtx {
        seed: rng::hash(seed, u32::MAX - tag, a, b),
        iteration: tag,
        position: 0,
    }
}

/// The uniform of generation `g`'s systematic resampling.
fn resample_uniform(seed: u32, g: u32) -> f64 {
    f64::from(rng::uniform(seed, g, u32::MAX, STREAM_RESAMPLE))
}

/// The scale of a turtle's frame, `|det|^(1/3)` (the length a unit bone
/// drawn there gets under a uniform scale).
fn frame_scale(t: &Turtle) -> f64 {
    f64::from(t.frame.matrix3.determinant().abs().cbrt())
}

/// Per symbol: the expected direction (eq. 9), the reach factor and the
/// stride ([`Sampler::new`]'s estimates).
type PerSymbol = (Vec<Vec3>, Vec<f32>, Vec<f32>, Vec<bool>);

/// A run's look-ahead: the options and how many generations are left
/// after the one being grown (a particle grows a bone a generation, so
/// nothing reaches further than that many bones).
struct Look<'r> {
    o: &'r Reach,
    left: f64,
}

impl Look<'_> {
    /// [`CostModel::uncovered_within_reach`]'s `branches` for a reach the
    /// grammar bounds (`shrinks`) or the generations left: the curves that
    /// start on a curve are followed only where the chain's own shrinking
    /// bounds it (a longer bone then reaches further along them); where
    /// the generations left bound it, following them would only keep tips
    /// short of a fork (measured on the vine: `docs/sampling.md` 4.4).
    fn branches(&self, shrinks: bool) -> Option<f64> {
        (self.o.branches && shrinks).then_some(0.0)
    }
}

impl std::ops::Deref for Look<'_> {
    type Target = Reach;
    fn deref(&self) -> &Reach {
        self.o
    }
}

/// Pick an index in `0 .. n` with draw `draw` of `ctx`.
fn pick(ctx: &DrawCtx, draw: u32, n: usize) -> usize {
    ((ctx.uniform(draw) as f64 * n as f64) as usize).min(n.saturating_sub(1))
}

/// How an open non-terminal is expanded.
enum How<'t> {
    /// Draw the production and its parameters.
    Draw {
        draws: DrawCtx,
        which: Which,
        phase: &'static str,
    },
    /// Apply a given production with given successor parameters (replay).
    Given {
        alt: u32,
        params: &'t [f32],
        which: Which,
    },
    /// Apply production `alt` (a normal one) whose successor the worker
    /// holds already evaluated and interpreted from the symbol's frame
    /// (`params`, `users`, `bones`, `non_finite`): a chosen candidate.
    Prepared { alt: u32 },
}

/// A simple (non-persistent) open symbol, for the expected directions.
struct Loose {
    symbol: u32,
    params: Vec<f32>,
    turtle: Turtle,
    /// Length of the bones from the sub-derivation's root to here.
    path: f32,
}

impl<'a> Sampler<'a> {
    /// Prepare `system` (checked without errors, of mode sample) compiled
    /// as `compiled`, guided by `curves`, for the given objective. This
    /// estimates the expected direction of every skeleton symbol.
    pub fn new(
        system: &System,
        compiled: &'a CompiledSystem,
        curves: &Curves,
        objective: Objective,
        expected: ExpectedOptions,
    ) -> Result<Sampler<'a>, SampleError> {
        if system.mode != Mode::Sample {
            return Err(SampleError::NotSampleSystem {
                system: system.name.clone(),
            });
        }
        let g = Grammar::new(system, compiled);
        let cost = CostModel::new(curves, CostOptions::from_curves(curves));
        let volume = match objective {
            Objective::Curves => None,
            Objective::Volume { options, weight } => {
                if !(weight.is_finite() && weight > 0.0) {
                    return Err(SampleError::Options(format!(
                        "the volume weight {weight} must be a finite number > 0"
                    )));
                }
                Some(
                    VolumeTarget::from_curves(curves, options)
                        .map_err(|e| SampleError::Options(e.to_string()))?,
                )
            }
        };
        let mut s = Sampler {
            g,
            cost,
            objective,
            volume,
            expected: Vec::new(),
            reach: Vec::new(),
            stride: Vec::new(),
            fixed: Vec::new(),
            expected_time: Duration::ZERO,
            curves: curves.clone(),
            guides: curves
                .curves()
                .iter()
                .map(|c| (c.bezier, c.params))
                .collect(),
            replay: None,
        };
        let t = Instant::now();
        (s.expected, s.reach, s.stride, s.fixed) = s.expected_directions(&expected)?;
        s.expected_time = t.elapsed();
        Ok(s)
    }

    /// Replay the persistent edits of `plan` while sampling (docs/edits.md,
    /// "Sample mode"): every module the search, wrap-up and the geometry
    /// phase write is looked up by its identity key, the key the model's
    /// tree gives it. A removed module and its subtree are not written; a
    /// forced module's production is the alternative forced (the weights
    /// and the draw ignored: the proposal is the constrained grammar's, so
    /// the particle weights stay those of SMC for the edited model); a
    /// pinned module takes the pinned key and it and its subtree draw from
    /// their keys, not from the particle's place in the search; `set` and
    /// `offset` change the parameter words of the target and of every
    /// module of its subtree that has the parameter, as they are written.
    /// The expected directions (computed by [`Self::new`]) are the
    /// grammar's, not the edited model's. An empty plan is the plain
    /// sampler. The model's [`SampledModel::edits`] says what the edits met.
    pub fn with_edits(mut self, plan: EditPlan) -> Self {
        self.replay = (!plan.is_empty()).then(|| Replay::new(plan));
        self
    }

    /// The edits' hook where a module is expanded: the successor of `alt`
    /// written by the module with key `key` and scope `scope` (symbol
    /// `sym`) looked up in the plan, with `values` its parameter words in
    /// `w.params` edited ([`Replay::successor`]). Nothing without a plan.
    #[allow(clippy::too_many_arguments)]
    fn edit_successor(
        &self,
        w: &mut Worker,
        key: u32,
        scope: u32,
        alt: u32,
        values: bool,
        sym: u32,
        phase: &'static str,
    ) -> Result<(), SampleError> {
        let Some(r) = &self.replay else {
            return Ok(());
        };
        let params = if values {
            Some(&mut w.params[..])
        } else {
            None
        };
        r.successor(&self.g, key, scope, alt, params, &mut w.succ, None)
            .map_err(|value| self.non_finite_edit(sym, alt, value, phase))
    }

    /// The error of a value a `set` or `offset` edit made not finite.
    fn non_finite_edit(&self, sym: u32, alt: u32, value: f32, phase: &'static str) -> SampleError {
        let sys = self.g.sys;
        let span = sys.alt_spans.get(alt as usize).copied().unwrap_or(sys.span);
        self.g.error(
            phase,
            sym,
            crate::error::ExpandErrorKind::NonFinite { value },
            span,
        )
    }

    /// [`CostModel::set_cover_others`] for this sampler's cost model: with
    /// `false`, a bone covers only eq. 1's curve (the coverage term as
    /// before the fork fix of `docs/sampling.md` section 4.4; for
    /// comparisons).
    pub fn with_cover_others(mut self, on: bool) -> Self {
        self.cost.set_cover_others(on);
        self
    }

    /// The curve cost model.
    pub fn cost_model(&self) -> &CostModel {
        &self.cost
    }

    /// The expected direction (eq. 9) of a symbol, by name: `None` for a
    /// name the system does not have; zero for symbols that are not
    /// skeleton symbols or never grow a bone.
    pub fn expected_direction(&self, symbol: &str) -> Option<Vec3> {
        let i = self.g.sys.symbol_names.iter().position(|n| n == symbol)?;
        self.expected.get(i).copied()
    }

    /// The heuristic term (eq. 10, unscaled) of skeleton symbol `symbol`
    /// opened at `frame`, as the sampler computes it; equal, bit for bit, to
    /// `CostModel::heuristic_in_frame` with the symbol's expected direction
    /// (0 for a symbol whose expected direction is zero).
    pub fn heuristic_term_at(&self, symbol: &str, frame: &glam::Affine3A) -> Option<f64> {
        let i = self.g.sys.symbol_names.iter().position(|n| n == symbol)?;
        let e = self.expected.get(i).copied()?;
        if e == Vec3::ZERO {
            return Some(0.0);
        }
        Some(self.heuristic_in_frame(frame, e))
    }

    /// The reach factor of a symbol, by name ([`SampleOptions::reach`]):
    /// the upper quartile of the longest chain of bones grown depth first
    /// from it in the identity frame; `None` for a name the system does not
    /// have.
    pub fn reach_factor(&self, symbol: &str) -> Option<f32> {
        let i = self.g.sys.symbol_names.iter().position(|n| n == symbol)?;
        self.reach.get(i).copied()
    }

    /// Time spent estimating the expected directions in [`Sampler::new`].
    pub fn expected_time(&self) -> Duration {
        self.expected_time
    }

    // ---- expected directions (eq. 9) ------------------------------------

    /// Expand random open skeleton symbols of `open` (a plain vector) until
    /// none is left or `max` were expanded; the bones made are appended to
    /// `bones`, and `on_open` sees each skeleton symbol opened (symbol,
    /// parameters).
    /// `lifo`: expand the newest open symbol first (depth first, for the
    /// reach factors) instead of a random one. Returns the longest path
    /// of bones from the root to a bone's tip.
    #[allow(clippy::too_many_arguments)]
    fn grow_loose(
        &self,
        w: &mut Worker,
        open: &mut Vec<Loose>,
        max: u32,
        lifo: bool,
        draws: impl Fn(u32) -> DrawCtx,
        bones: &mut Vec<(Vec3, Vec3)>,
        mut on_open: impl FnMut(u32, &[f32]),
    ) -> Result<f32, SampleError> {
        let sys = self.g.sys;
        let mut k = 0;
        let mut longest = 0.0f32;
        while !open.is_empty() && k < max {
            let ctx = draws(k);
            k += 1;
            let idx = if lifo {
                open.len() - 1
            } else {
                pick(&ctx, sys.draws, open.len())
            };
            let item = open.swap_remove(idx);
            let phase = "expected direction";
            let Some(alt) =
                self.g
                    .choose(w, item.symbol, &item.params, Which::Normal, &ctx, phase)?
            else {
                continue;
            };
            self.g.eval_successor(w, item.symbol, alt, &ctx, phase)?;
            self.g.interpret(w, alt, &item.turtle)?;
            bones.extend_from_slice(&w.bones);
            let path = item.path
                + w.bones
                    .iter()
                    .map(|&(b, t)| b.distance(t))
                    .filter(|l| l.is_finite())
                    .sum::<f32>();
            longest = longest.max(path);
            let a = &sys.alts[alt as usize];
            for &(m, t) in &w.users {
                let sym = sys.succ[(a.succ_offset + m) as usize].symbol;
                if self.g.is_skeleton(sym) {
                    let params = self.g.module_params(alt, m, &w.params).to_vec();
                    on_open(sym, &params);
                    open.push(Loose {
                        symbol: sym,
                        params,
                        turtle: t,
                        path,
                    });
                }
            }
        }
        Ok(longest)
    }

    /// Eq. 9 for every skeleton symbol: the mean, over `opts.models`
    /// sub-derivations grown from the symbol alone in the identity frame,
    /// of each one's mean bone vector. A symbol with parameters is grown
    /// with parameter values it actually takes: those of its occurrences in
    /// forward samples from the axiom (a symbol never met there gets no
    /// heuristic).
    fn expected_directions(&self, opts: &ExpectedOptions) -> Result<PerSymbol, SampleError> {
        let n = self.g.phase.len();
        let mut w = self.g.worker();
        let mut params: Vec<Vec<Vec<f32>>> = vec![Vec::new(); n];
        let per = opts.models.max(1) as usize;
        let mut parametric = false;
        for (s, list) in params.iter_mut().enumerate() {
            if self.g.is_skeleton(s as u32) {
                if self.g.words[s] == 0 {
                    list.push(Vec::new());
                } else {
                    parametric = true;
                }
            }
        }
        let mut bones = Vec::new();
        if parametric {
            // Parameter values from forward samples of the whole grammar.
            for run in 0..16u32 {
                let root = self.axiom_loose(&mut w, opts.seed, run)?;
                let mut open = root;
                for o in &open {
                    if params[o.symbol as usize].len() < per {
                        params[o.symbol as usize].push(o.params.clone());
                    }
                }
                self.grow_loose(
                    &mut w,
                    &mut open,
                    opts.expansions.max(1) * 4,
                    false,
                    |k| tagged(opts.seed, STREAM_EXPECTED, u32::MAX - run, k),
                    &mut bones,
                    |sym, p| {
                        let list = &mut params[sym as usize];
                        if list.len() < per {
                            list.push(p.to_vec());
                        }
                    },
                )?;
                bones.clear();
            }
        }
        let mut out = vec![Vec3::ZERO; n];
        let mut reach = vec![0.0f32; n];
        let mut stride = vec![0.0f32; n];
        let mut fixed = vec![false; n];
        let identity = self.g.initial_turtle();
        for s in 0..n {
            if !self.g.is_skeleton(s as u32) || params[s].is_empty() {
                continue;
            }
            let mut acc = ExpectedDirection::new();
            for m in 0..per {
                let mut open = vec![Loose {
                    symbol: s as u32,
                    params: params[s][m % params[s].len()].clone(),
                    turtle: identity,
                    path: 0.0,
                }];
                bones.clear();
                self.grow_loose(
                    &mut w,
                    &mut open,
                    opts.expansions.max(1),
                    false,
                    |k| {
                        let seed = rng::hash(opts.seed, s as u32, m as u32, k);
                        tagged(seed, STREAM_EXPECTED, 0, 0)
                    },
                    &mut bones,
                    |_, _| {},
                )?;
                acc.add_model(&bones);
            }
            let e = acc.finish();
            out[s] = if e.is_finite() { e } else { Vec3::ZERO };
            // The reach factor: the longest chain of bones of sub-derivations
            // grown depth first from the symbol alone (draws of their own).
            let mut longest = Vec::with_capacity(per);
            let mut first = Vec::with_capacity(per);
            for m in 0..per {
                let mut open = vec![Loose {
                    symbol: s as u32,
                    params: params[s][m % params[s].len()].clone(),
                    turtle: identity,
                    path: 0.0,
                }];
                bones.clear();
                let l = self.grow_loose(
                    &mut w,
                    &mut open,
                    REACH_EXPANSIONS,
                    true,
                    |k| {
                        let seed = rng::hash(opts.seed, s as u32, m as u32, k);
                        tagged(seed, STREAM_REACH, 0, 0)
                    },
                    &mut bones,
                    |_, _| {},
                )?;
                longest.push(l);
                if let Some(&(b, t)) = bones.first() {
                    let len = b.distance(t);
                    if len.is_finite() {
                        first.push(len);
                    }
                }
            }
            longest.sort_by(f32::total_cmp);
            reach[s] = longest[(longest.len() * 3) / 4].max(0.0);
            first.sort_by(f32::total_cmp);
            stride[s] = first.get(first.len() / 2).copied().unwrap_or(0.0);
            fixed[s] = match (first.first(), first.last()) {
                (Some(&lo), Some(&hi)) => hi > 0.0 && hi - lo <= 1e-6 * hi,
                _ => false,
            };
        }
        Ok((out, reach, stride, fixed))
    }

    /// The axiom's skeleton symbols as loose open items (for the parameter
    /// samples of the expected directions).
    fn axiom_loose(&self, w: &mut Worker, seed: u32, run: u32) -> Result<Vec<Loose>, SampleError> {
        let sys = self.g.sys;
        let ctx = tagged(seed, STREAM_AXIOM, run, 0);
        let alt = sys.axiom_alt;
        self.g.eval_successor(w, u32::MAX, alt, &ctx, "axiom")?;
        self.g.interpret(w, alt, &self.g.initial_turtle())?;
        let a = &sys.alts[alt as usize];
        let mut out = Vec::new();
        for &(m, t) in &w.users {
            let sym = sys.succ[(a.succ_offset + m) as usize].symbol;
            if self.g.is_skeleton(sym) {
                out.push(Loose {
                    symbol: sym,
                    params: self.g.module_params(alt, m, &w.params).to_vec(),
                    turtle: t,
                    path: 0.0,
                });
            }
        }
        Ok(out)
    }

    // ---- particles --------------------------------------------------------

    /// Eq. 1 at `position`: remembered in `memo` for the last position
    /// asked (the non-terminals an expansion emits side by side share
    /// their frame, `branch maybeBranch maybeBranch`, and the closest-point
    /// search is most of the cost). `None` for a non-finite position.
    fn near_at(&self, position: Vec3, memo: &mut Option<Near>) -> Option<Near> {
        self.near_at_known(position, memo, None)
    }

    /// [`Self::near_at`] with one curve's closest point known
    /// (`CostModel::nearest_curve_known`; the same answer).
    fn near_at_known(
        &self,
        position: Vec3,
        memo: &mut Option<Near>,
        known: Option<(usize, &grm_guide::ClosestPoint)>,
    ) -> Option<Near> {
        match memo {
            Some(m) if m.position == position => Some(*m),
            _ => {
                let p = position.as_dvec3();
                if !p.is_finite() {
                    return None;
                }
                let (curve, closest) = self.cost.nearest_curve_known(p, known);
                let n = Near {
                    position,
                    curve,
                    closest,
                };
                *memo = Some(n);
                Some(n)
            }
        }
    }

    /// Eq. 10's term for a skeleton symbol opened at frame `t` (fixed
    /// point) whose position's nearest curve is `near`; 0 for a symbol
    /// whose expected direction is zero (it grows no bone, so it adds no
    /// future alignment cost).
    fn heuristic_term(&self, sym: u32, t: &Turtle, near: Option<Near>) -> i64 {
        let e = self
            .expected
            .get(sym as usize)
            .copied()
            .unwrap_or(Vec3::ZERO);
        if e == Vec3::ZERO {
            return 0;
        }
        to_fixed(self.heuristic_near(&t.frame, e, near))
    }

    /// `CostModel::heuristic_in_frame`, computed the same way (the same
    /// operations on the same values, so bit for bit the same result),
    /// given eq. 1 at the frame's position (`None`: not finite).
    fn heuristic_near(&self, frame: &glam::Affine3A, expected: Vec3, near: Option<Near>) -> f64 {
        let Some(n) = near else {
            return f64::INFINITY;
        };
        let (bez, params) = &self.guides[n.curve];
        grm_guide::alignment_cost(
            frame.transform_vector3(expected).as_dvec3(),
            bez.tangent(n.closest.t),
            params.alignment_scale,
            params.alignment_offset,
        )
    }

    /// [`Self::heuristic_near`] for a frame, finding eq. 1 at its position.
    fn heuristic_in_frame(&self, frame: &glam::Affine3A, expected: Vec3) -> f64 {
        let near = self.near_at(Vec3::from(frame.translation), &mut None);
        self.heuristic_near(frame, expected, near)
    }

    /// The objective without heuristic.
    fn objective_of(&self, p: &Particle) -> f64 {
        match (self.objective, &self.volume, &p.volume) {
            (Objective::Volume { weight, .. }, Some(vt), Some(vs)) => weight * vt.cost(vs).total(),
            _ => self.cost.total(&p.cost).total(),
        }
    }

    /// [`Guide::cover`]'s term `T` of `state` (0 when `w` is 0 or the
    /// objective is not the curve cost).
    fn cover_term(&self, state: &grm_guide::CostState, w: f64) -> f64 {
        if w <= 0.0 || !matches!(self.objective, Objective::Curves) {
            return 0.0;
        }
        let mut t = 0.0;
        for c in 0..self.guides.len() {
            let (k, n) = self.cost.covered_segments(state, c);
            if n > 0 {
                let u = 1.0 - k as f64 / n as f64;
                t -= w * n as f64 * (1.0 - u * u);
            }
        }
        t
    }

    /// The change of [`Self::cover_term`] were `plan` added to `state`.
    fn cover_delta(&self, state: &grm_guide::CostState, plan: &BonePlan, w: f64) -> f64 {
        if w <= 0.0 {
            return 0.0;
        }
        let mut delta = 0.0;
        self.cost.cover_gains(state, plan, |c, new| {
            let (k, n) = self.cost.covered_segments(state, c);
            let n = n.max(1) as f64;
            let (u0, u1) = (1.0 - k as f64 / n, 1.0 - (k + new) as f64 / n);
            delta -= w * n * (u0 * u0 - u1 * u1);
        });
        delta
    }

    /// The objective the search follows: [`Self::objective_of`] plus the
    /// coverage term of [`Guide::cover`] `w`.
    fn searched(&self, p: &Particle, w: f64) -> f64 {
        self.objective_of(p) + self.cover_term(&p.cost, w)
    }

    fn score(&self, p: &Particle, h_scale: f64, w: f64) -> f64 {
        let base = self.searched(p, w);
        if h_scale == 0.0 {
            base
        } else {
            base + h_scale * from_fixed(p.heuristic)
        }
    }

    /// Score `w.bones` into `p`. `plans`: the bones' plans when the caller
    /// made them already (a chosen candidate), else empty.
    /// `near`: eq. 1 at the expanded symbol's position, for bones based
    /// there.
    fn add_bones(&self, w: &Worker, p: &mut Particle, plans: &[BonePlan], near: Option<Near>) {
        let planned = plans.len() == w.bones.len()
            && plans
                .iter()
                .zip(&w.bones)
                .all(|(pl, &(b, t))| pl.ends() == (b.as_dvec3(), t.as_dvec3()));
        for (k, &(b, t)) in w.bones.iter().enumerate() {
            if planned {
                self.cost.add_planned(&mut p.cost, &plans[k]);
            } else {
                let plan = match near {
                    Some(n) if n.position == b => {
                        self.cost.plan_bone_near(b, t, n.curve, &n.closest)
                    }
                    _ => self.cost.plan_bone(b, t),
                };
                self.cost.add_planned(&mut p.cost, &plan);
            }
            if let (Some(vt), Some(vs)) = (&self.volume, p.volume.as_mut()) {
                vt.add_bone(vs, b, t);
            }
        }
        if w.non_finite {
            // The interpreter dropped a bone with a non-finite end: the
            // model's cost is +inf (weight 0).
            self.cost.add_bone(&mut p.cost, Vec3::NAN, Vec3::NAN);
        }
        p.bones += w.bones.len() as u32;
    }

    /// Append the skeleton spawns of the successor just interpreted in `w`
    /// to `out`; returns the sum of their heuristic terms.
    /// Each spawn gets eq. 1 at its position (`memo`: the expanded
    /// symbol's, reused where a spawn sits at the same position).
    fn push_spawns(
        &self,
        w: &Worker,
        alt: u32,
        compute_h: bool,
        out: &mut Vec<Spawn>,
        mut memo: Option<Near>,
        plans: &[BonePlan],
    ) -> i128 {
        let sys = self.g.sys;
        let a = &sys.alts[alt as usize];
        let mut h_sum = 0;
        for (ord, &(m, t)) in w.users.iter().enumerate() {
            let sym = sys.succ[(a.succ_offset + m) as usize].symbol;
            if self.g.is_skeleton(sym) {
                let position = Vec3::from(t.frame.translation);
                // At a planned bone's tip the tip's closest point on the
                // bone's curve is known already.
                let known = plans
                    .iter()
                    .find(|pl| pl.ends().1 == position.as_dvec3())
                    .and_then(BonePlan::tip_closest);
                let near = self.near_at_known(position, &mut memo, known);
                let h = if compute_h {
                    self.heuristic_term(sym, &t, near)
                } else {
                    0
                };
                h_sum += i128::from(h);
                let e = if self.replay.is_some() {
                    w.succ.mods.get(m as usize).copied().unwrap_or_default()
                } else {
                    crate::edits::Succ::default()
                };
                out.push(Spawn {
                    ordinal: ord as u32,
                    symbol: sym,
                    module: m,
                    turtle: t,
                    h,
                    near,
                    key: e.key,
                    scope: e.scope,
                    force: e.force,
                });
            }
        }
        h_sum
    }

    /// Add the node for the successor just made in `w` (parameter words in
    /// `w.params`) to `local` (step `cur`), and open its skeleton spawns.
    #[allow(clippy::too_many_arguments)]
    fn add_node(
        &self,
        w: &Worker,
        p: &mut Particle,
        local: &mut Step,
        cur: (u32, u32),
        parent: (u32, u32),
        symbol: u32,
        kind: NodeKind,
        alt: u32,
        compute_h: bool,
        slot: Option<usize>,
        near: Option<Near>,
        plans: &[BonePlan],
    ) {
        let p0 = local.params.len() as u32;
        let s0 = local.spawns.len() as u32;
        if alt != INERT {
            local.params.extend_from_slice(&w.params);
            p.heuristic += self.push_spawns(w, alt, compute_h, &mut local.spawns, near, plans);
        }
        let id = NodeId {
            layer: cur.0,
            step: cur.1,
            k: local.nodes.len() as u32,
        };
        let first = p.seq == u32::MAX;
        local.nodes.push(Node {
            prev: (!first).then_some(p.head),
            seq: p.seq.wrapping_add(1),
            parent,
            symbol,
            kind,
            alt,
            params: (p0, local.params.len() as u32),
            spawns: (s0, local.spawns.len() as u32),
        });
        // The expanded symbol's slot (if any) takes the first new open
        // symbol (one path copy instead of a removal and an append); the
        // others are appended, or the slot is removed when there are none.
        let n = local.spawns.len() as u32 - s0;
        let live = |s: u32| !self.g.dead.get(s as usize).copied().unwrap_or(false);
        let opened = local.spawns[s0 as usize..]
            .iter()
            .filter(|sp| live(sp.symbol))
            .count() as u32;
        // The expanded symbol (open at `slot`) is closed.
        let closed = u32::from(slot.is_some() && live(symbol));
        p.live = (p.live + opened).saturating_sub(closed);
        let mut first_new = 0;
        if let Some(i) = slot {
            let open = if n > 0 && !w.append_spawns {
                first_new = 1;
                p.open.set(i, OpenRef { node: id, spawn: 0 })
            } else {
                p.open.swap_remove(i).map(|(v, _)| v)
            };
            if let Some(open) = open {
                p.open = open;
            }
        }
        for k in first_new..n {
            p.open = p.open.push(OpenRef { node: id, spawn: k });
        }
        p.head = id;
        p.seq = p.seq.wrapping_add(1);
    }

    /// The particle holding only the axiom (interpreted from the initial
    /// turtle, its bones scored, its skeleton symbols open), in its own
    /// step (layer 0). `given`: the axiom's parameter words (replay);
    /// otherwise they are drawn.
    fn root_particle(
        &self,
        w: &mut Worker,
        given: Option<&[f32]>,
        seed: u32,
        h_scale: f64,
        cover: f64,
    ) -> Result<(Particle, Step), SampleError> {
        let alt = self.g.sys.axiom_alt;
        match given {
            None => {
                let ctx = tagged(seed, STREAM_AXIOM, 0, 0);
                self.g.eval_successor(w, u32::MAX, alt, &ctx, "axiom")?;
            }
            Some(p) => {
                w.params.clear();
                w.params.extend_from_slice(p);
            }
        }
        let root = self.g.sys.root_key(seed);
        self.edit_successor(w, root, 0, alt, given.is_none(), u32::MAX, "axiom")?;
        self.g.interpret(w, alt, &self.g.initial_turtle())?;
        let mut p = Particle {
            head: NodeId {
                layer: 0,
                step: 0,
                k: 0,
            },
            seq: u32::MAX,
            open: PVec::new(),
            cost: self.cost.new_state(),
            volume: self.volume.as_ref().map(VolumeTarget::new_state),
            heuristic: 0,
            score: 0.0,
            bones: 0,
            live: 0,
        };
        self.add_bones(w, &mut p, &[], None);
        let mut step = Step::default();
        self.add_node(
            w,
            &mut p,
            &mut step,
            (0, 0),
            ROOT,
            u32::MAX,
            NodeKind::Axiom,
            alt,
            h_scale > 0.0,
            None,
            None,
            &[],
        );
        p.score = self.score(&p, h_scale, cover);
        Ok((p, step))
    }

    /// The spawn an open symbol refers to and its parent node's sequence
    /// number; puts the spawned module's parameters in `w.input`.
    fn open_spawn(
        &self,
        w: &mut Worker,
        arena: Arena<'_>,
        r: OpenRef,
    ) -> Result<(Spawn, u32), SampleError> {
        let (step, node) = arena.get(r.node).ok_or_else(missing_node)?;
        let sp = *step
            .spawns(node)
            .get(r.spawn as usize)
            .ok_or_else(missing_node)?;
        let input = self.g.module_params(node.alt, sp.module, step.params(node));
        w.input.clear();
        w.input.extend_from_slice(input);
        Ok((sp, node.seq))
    }

    /// Expand open symbol `idx` of `p`, adding the node to `local` (step
    /// `cur` of the arena); returns the bones it added.
    #[allow(clippy::too_many_arguments)]
    fn expand_open(
        &self,
        w: &mut Worker,
        layers: &[Vec<Step>],
        local: &mut Step,
        cur: (u32, u32),
        p: &mut Particle,
        idx: usize,
        how: How<'_>,
        compute_h: bool,
        plans: &[BonePlan],
    ) -> Result<usize, SampleError> {
        let Some(&r) = p.open.get(idx) else {
            return Ok(0);
        };
        // Read the parent (copy what is needed: `local` grows below).
        let (sp, parent_seq) = self.open_spawn(w, Arena { layers, local, cur }, r)?;
        p.heuristic -= i128::from(sp.h);
        let which = match how {
            How::Draw { which, .. } | How::Given { which, .. } => which,
            How::Prepared { .. } => Which::Normal,
        };
        let prepared = matches!(how, How::Prepared { .. });
        let alt = match how {
            How::Draw { draws, phase, .. } => {
                // A pinned module draws from its key.
                let draws = if sp.scope & PINNED != 0 {
                    pinned_draws(sp.key)
                } else {
                    draws
                };
                let input = std::mem::take(&mut w.input);
                let chosen = if sp.force != 0 {
                    self.g
                        .choose_forced(w, sp.symbol, &input, which, &draws, phase, sp.force)
                } else {
                    self.g.choose(w, sp.symbol, &input, which, &draws, phase)
                };
                w.input = input;
                match chosen? {
                    Some(a) => {
                        self.g.eval_successor(w, sp.symbol, a, &draws, phase)?;
                        a
                    }
                    None => INERT,
                }
            }
            How::Given { alt, params, .. } => {
                if alt != INERT && !self.fits(alt, sp.symbol, which, params) {
                    return Err(SampleError::Options(format!(
                        "cannot replay the tree: production {alt} with {} parameter words does not expand `{}`",
                        params.len(),
                        self.g.symbol_name(sp.symbol)
                    )));
                }
                w.params.clear();
                w.params.extend_from_slice(params);
                alt
            }
            How::Prepared { alt } => alt,
        };
        let kind = match which {
            Which::Normal => NodeKind::Skeleton,
            Which::Wrapup => NodeKind::Wrapup,
        };
        let mut bones = 0;
        if alt != INERT {
            // A drawn successor's values are edited here; a given or
            // prepared one's were (its keys and scopes are found again).
            let drawn = matches!(how, How::Draw { .. });
            self.edit_successor(w, sp.key, sp.scope, alt, drawn, sp.symbol, "skeleton")?;
            if prepared {
                w.succ.removing = false;
            } else {
                self.g.interpret(w, alt, &sp.turtle)?;
            }
            self.add_bones(w, p, plans, sp.near);
            bones = w.bones.len();
        }
        self.add_node(
            w,
            p,
            local,
            cur,
            (parent_seq, sp.ordinal),
            sp.symbol,
            kind,
            alt,
            compute_h,
            Some(idx),
            sp.near,
            plans,
        );
        Ok(bones)
    }

    /// Whether alternative `alt` is a `which` production of `symbol` whose
    /// successor has `params.len()` parameter words (a replayed tree's node
    /// must be, or the tables would be read out of range).
    fn fits(&self, alt: u32, symbol: u32, which: Which, params: &[f32]) -> bool {
        let sys = self.g.sys;
        let Some(a) = sys.alts.get(alt as usize) else {
            return false;
        };
        let Some(g) = sys.groups.get(a.group as usize) else {
            return false;
        };
        let wrapup = g.flags & grm_compile::table::GROUP_WRAPUP != 0;
        g.pred == symbol
            && wrapup == (which == Which::Wrapup)
            && a.succ_words as usize == params.len()
    }

    /// One particle step (Calder's `advance`): expand random open skeleton
    /// symbols until one adds a bone or none is left; score the result.
    /// `local` is a (recycled) step to fill. An expansion of a symbol that
    /// can make a bone draws `kc` candidates when `kc > 1`
    /// ([`Self::draw_candidates`]). Returns the new particle, the step
    /// holding its new nodes (layer `g + 1`, index `i`), the number of
    /// expansions and the log-weight correction of the candidates chosen.
    #[allow(clippy::too_many_arguments)]
    fn advance(
        &self,
        w: &mut Worker,
        layers: &[Vec<Step>],
        mut local: Step,
        p: &Particle,
        seed: u32,
        g: u32,
        i: u32,
        h_scale: f64,
        max_k: u32,
        kc: u32,
        temperature: f64,
        guide: &Guide,
        reach: &Reach,
        left: u32,
    ) -> Result<(Particle, Step, u32, f64), SampleError> {
        let mut q = p.clone();
        local.clear();
        // The layer this generation's steps go to (generation g's is g + 1
        // in the first pass; a refinement round's are appended after).
        let cur = (layers.len() as u32, i);
        let compute_h = h_scale > 0.0;
        let reach = &Look {
            o: reach,
            left: f64::from(left),
        };
        w.append_spawns = guide.order > 1 && reach.recent > 0;
        let mut k = 0;
        let mut correction = 0.0;
        // A particle whose open symbols can none lead to a bone (W0015)
        // has nothing left to search: wrap-up closes them.
        while q.live > 0 && k < max_k {
            let draws = skeleton_draws(seed, g, i, k);
            k += 1;
            let arena = Arena {
                layers,
                local: &local,
                cur,
            };
            let spawn_at = |idx: usize| {
                q.open
                    .get(idx)
                    .and_then(|r| arena.get(r.node).map(|(st, n)| (r, st, n)))
                    .and_then(|(r, st, n)| st.spawns(n).get(r.spawn as usize).copied())
            };
            let n_open = q.open.len();
            let mut idx = pick(&draws, self.g.sys.draws, n_open);
            if guide.order > 1 {
                // A tournament: the most promising of `order` uniform
                // draws (the first draw is the paper's).
                let mut best = spawn_at(idx).map_or(f64::INFINITY, |sp| {
                    self.promise(&q, &sp, guide, reach, &mut w.tubes)
                });
                // With `Reach::recent`, the newest open symbols (last in
                // the list) enter too.
                let recent = (reach.recent as usize).min(n_open);
                for j in 1..guide.order + recent as u32 {
                    let other = if j < guide.order {
                        pick(&draws, self.g.sys.draws + j, n_open)
                    } else {
                        n_open - 1 - (j - guide.order) as usize
                    };
                    if other == idx {
                        continue;
                    }
                    let v = spawn_at(other).map_or(f64::INFINITY, |sp| {
                        self.promise(&q, &sp, guide, reach, &mut w.tubes)
                    });
                    if v < best {
                        best = v;
                        idx = other;
                    }
                }
            }
            let symbol = spawn_at(idx).map(|sp| sp.symbol);
            let kc = match symbol {
                Some(s) if guide.cover > 0.0 && self.paced(s, reach) => kc.min(reach.paced),
                _ => kc,
            };
            let candidates = kc > 1 && symbol.is_some_and(|s| self.g.can_bone[s as usize]);
            let added = if candidates {
                let (c, corr) = self.draw_candidates(
                    w,
                    layers,
                    &local,
                    cur,
                    &q,
                    idx,
                    draws,
                    kc,
                    temperature,
                    guide.cover,
                    reach,
                )?;
                correction += corr;
                // The chosen candidate's successor into the worker.
                std::mem::swap(&mut w.params, &mut w.cand_params[c]);
                std::mem::swap(&mut w.users, &mut w.cand_users[c]);
                std::mem::swap(&mut w.bones, &mut w.cand_bones[c]);
                w.non_finite = w.cand_non_finite[c];
                let plans = std::mem::take(&mut w.cand_plans[c]);
                let how = How::Prepared { alt: w.cand_alt[c] };
                let r = self.expand_open(
                    w, layers, &mut local, cur, &mut q, idx, how, compute_h, &plans,
                );
                w.cand_plans[c] = plans;
                r?
            } else {
                let how = How::Draw {
                    draws,
                    which: Which::Normal,
                    phase: "skeleton",
                };
                self.expand_open(w, layers, &mut local, cur, &mut q, idx, how, compute_h, &[])?
            };
            if added > 0 {
                break;
            }
        }
        // Only the search's steps append (wrap-up and replays do not).
        w.append_spawns = false;
        q.score = self.score(&q, h_scale, guide.cover);
        if guide.cover > 0.0 && reach.weights > 0.0 {
            // The potential of the newest tip (what the look-ahead says
            // its symbols could still cover): a heuristic term of the
            // particle's score, taken back in the next generation's weight.
            if let Some(node) = local.nodes.last() {
                let ahead = self.spawns_lookahead(&q.cost, local.spawns(node), reach, &mut w.tubes);
                q.score -= 2.0 * guide.cover * reach.weights * ahead;
            }
        }
        Ok((q, local, k, correction))
    }

    /// How promising it is to expand open symbol `sp` of `q` next (lower
    /// is better; [`Guide::order`]): the cost a bone grown from there in
    /// the symbol's expected direction would get (eq. 3 at its position,
    /// eq. 6 for its expected direction as in eq. 10) plus the utilization
    /// the nearest curve's next segment would still give
    /// (`CostModel::utilization_ahead`), and, with [`Guide::cover`], the
    /// coverage term's gain for a first cover of that segment
    /// (`2 W (1 - s)`, `s` the curve's covered share). A
    /// symbol that never grows a bone, or at a non-finite position, is
    /// least promising (`+inf`).
    fn promise(
        &self,
        q: &Particle,
        sp: &Spawn,
        guide: &Guide,
        reach: &Look<'_>,
        memo: &mut TubesMemo,
    ) -> f64 {
        let e = self
            .expected
            .get(sp.symbol as usize)
            .copied()
            .unwrap_or(Vec3::ZERO);
        let Some(n) = sp.near else {
            return f64::INFINITY;
        };
        if e == Vec3::ZERO {
            return f64::INFINITY;
        }
        let (_, params) = &self.guides[n.curve];
        let mut v = grm_guide::distance_cost(n.closest.dist, params)
            + self.heuristic_near(&sp.turtle.frame, e, Some(n))
            + self.cost.utilization_ahead(&q.cost, n.curve, n.closest.t);
        if guide.cover > 0.0 && reach.order > 0.0 {
            let tubes = memo.tubes_near(&self.cost, &n);
            if !tubes.is_empty() {
                let (r, _) = self.reach_of(sp.symbol, &sp.turtle, reach);
                let ahead = self.cost.uncovered_within_reach(&q.cost, &tubes, r, None);
                v -= 2.0 * guide.cover * reach.order * ahead;
            }
        } else if guide.cover > 0.0 && !self.cost.covered_ahead(&q.cost, n.curve, n.closest.t) {
            let (k, m) = self.cost.covered_segments(&q.cost, n.curve);
            v -= 2.0 * guide.cover * (1.0 - k as f64 / m.max(1) as f64);
        }
        if v.is_nan() { f64::INFINITY } else { v }
    }

    /// Whether `symbol` is paced ([`Reach::paced`]): the first bones it
    /// grows all have one length, so its candidates can only turn them.
    fn paced(&self, symbol: u32, reach: &Look<'_>) -> bool {
        reach.paced > 0 && self.fixed.get(symbol as usize).copied().unwrap_or(false)
    }

    /// How far a subtree of `symbol` grown from turtle state `t` could
    /// reach along a curve: its reach factor times the frame's scale
    /// (`|det|^(1/3)`) times [`Reach::scale`].
    fn reach_of(&self, symbol: u32, t: &Turtle, reach: &Look<'_>) -> (f64, bool) {
        let f = self.reach.get(symbol as usize).copied().unwrap_or(0.0);
        let stride = self.stride.get(symbol as usize).copied().unwrap_or(0.0);
        let s = frame_scale(t);
        let grammar = f64::from(f) * s * reach.scale;
        // No further than the bones the generations left can grow.
        let budget = if reach.budget {
            f64::from(stride) * s * (reach.left + 1.0)
        } else {
            f64::INFINITY
        };
        let r = grammar.min(budget);
        if r.is_finite() {
            (r, grammar <= budget)
        } else {
            (0.0, false)
        }
    }

    /// The reach look-ahead of open symbols `spawns` (emitted by one
    /// expansion) against `state`: [`CostModel::uncovered_within_reach`] at
    /// each position where they sit (the largest reach of those there),
    /// summed.
    fn spawns_lookahead(
        &self,
        state: &grm_guide::CostState,
        spawns: &[Spawn],
        reach: &Look<'_>,
        memo: &mut TubesMemo,
    ) -> f64 {
        let mut sum = 0.0;
        let mut i = 0;
        while i < spawns.len() {
            let sp = &spawns[i];
            let (mut r, mut shrinks) = self.reach_of(sp.symbol, &sp.turtle, reach);
            let mut j = i + 1;
            while j < spawns.len()
                && spawns[j].turtle.frame.translation == sp.turtle.frame.translation
            {
                let (rj, sj) = self.reach_of(spawns[j].symbol, &spawns[j].turtle, reach);
                if rj > r {
                    (r, shrinks) = (rj, sj);
                }
                j += 1;
            }
            if let Some(n) = sp.near
                && r > 0.0
            {
                let tubes = memo.tubes_near(&self.cost, &n);
                sum += self
                    .cost
                    .uncovered_within_reach(state, &tubes, r, reach.branches(shrinks));
            }
            i = j;
        }
        sum
    }

    /// The reach look-ahead of the successor in `w` (just interpreted):
    /// [`CostModel::uncovered_within_reach`] at each position where it
    /// opens skeleton symbols (the largest reach of those there), summed.
    fn lookahead(
        &self,
        w: &Worker,
        alt: u32,
        state: &grm_guide::CostState,
        plans: &[BonePlan],
        reach: &Look<'_>,
    ) -> f64 {
        let sys = self.g.sys;
        let a = &sys.alts[alt as usize];
        let mut at: Option<(Vec3, (f64, bool))> = None;
        let mut sum = 0.0;
        let flush = |at: Option<(Vec3, (f64, bool))>, sum: &mut f64| {
            if let Some((pos, (r, shrinks))) = at {
                let p = pos.as_dvec3();
                let known = plans
                    .iter()
                    .find(|pl| pl.ends().1 == p)
                    .and_then(BonePlan::tip_closest);
                if r > 0.0 {
                    let tubes = self.cost.tubes_at(p, known);
                    *sum +=
                        self.cost
                            .uncovered_within_reach(state, &tubes, r, reach.branches(shrinks));
                }
            }
        };
        for &(m, t) in &w.users {
            let sym = sys.succ[(a.succ_offset + m) as usize].symbol;
            if !self.g.is_skeleton(sym) {
                continue;
            }
            let pos = Vec3::from(t.frame.translation);
            let r = self.reach_of(sym, &t, reach);
            match at {
                Some((p, r0)) if p == pos => at = Some((p, if r.0 > r0.0 { r } else { r0 })),
                _ => {
                    flush(at, &mut sum);
                    at = Some((pos, r));
                }
            }
        }
        flush(at, &mut sum);
        sum
    }

    /// The candidates of one expansion: open symbol `idx` of `q` expanded
    /// `kc` times from its own frame, candidate `c` with the draws of
    /// `draws` at position `c` (candidate 0 draws exactly what a plain
    /// expansion draws), each candidate's bones planned and priced against
    /// `q`'s cost state without changing it ([`CostModel::peek`]).
    /// Candidate `c` gets the selection weight `v_c = exp(-cost_c / T)`;
    /// one is chosen with probability `v_c / sum v` (a seeded uniform), and
    /// the returned correction `log(mean v) - log(v_chosen)` makes the
    /// particle's weight the sampling-importance-resampling weight of the
    /// step (section 4.1 of docs/sampling.md). Results are left in `w`'s
    /// `cand_*` buffers; returns (chosen candidate, correction).
    #[allow(clippy::too_many_arguments)]
    fn draw_candidates(
        &self,
        w: &mut Worker,
        layers: &[Vec<Step>],
        local: &Step,
        cur: (u32, u32),
        q: &Particle,
        idx: usize,
        draws: DrawCtx,
        kc: u32,
        temperature: f64,
        cover: f64,
        reach: &Look<'_>,
    ) -> Result<(usize, f64), SampleError> {
        let r = *q.open.get(idx).ok_or_else(missing_node)?;
        let (sp, _) = self.open_spawn(w, Arena { layers, local, cur }, r)?;
        let n = kc as usize;
        w.cand_alt.clear();
        w.cand_logv.clear();
        let m = n.max(w.cand_params.len());
        w.cand_params.resize_with(m, Vec::new);
        w.cand_plans.resize_with(m, Vec::new);
        w.cand_users.resize_with(m, Vec::new);
        w.cand_bones.resize_with(m, Vec::new);
        w.cand_non_finite.resize(m, false);
        // Eq. 1 at the symbol's own position (where a successor's first
        // bone starts) is the spawn's; other bases are remembered.
        let mut memo = None;
        let mut base_tubes = None;
        let input = std::mem::take(&mut w.input);
        for c in 0..n {
            // A pinned module draws from its key (every candidate the same).
            let ctx = if sp.scope & PINNED != 0 {
                pinned_draws(sp.key)
            } else {
                DrawCtx {
                    position: c as u32,
                    ..draws
                }
            };
            let chosen = if sp.force != 0 {
                self.g.choose_forced(
                    w,
                    sp.symbol,
                    &input,
                    Which::Normal,
                    &ctx,
                    "skeleton",
                    sp.force,
                )
            } else {
                self.g
                    .choose(w, sp.symbol, &input, Which::Normal, &ctx, "skeleton")
            };
            let alt = match chosen {
                Ok(Some(a)) => a,
                Ok(None) => INERT,
                Err(e) => {
                    w.input = input;
                    return Err(e);
                }
            };
            let mut plans = std::mem::take(&mut w.cand_plans[c]);
            plans.clear();
            let mut cost = 0.0;
            if alt != INERT {
                let done = self
                    .g
                    .eval_successor(w, sp.symbol, alt, &ctx, "skeleton")
                    .and_then(|()| {
                        self.edit_successor(w, sp.key, sp.scope, alt, true, sp.symbol, "skeleton")
                    })
                    .and_then(|()| self.g.interpret(w, alt, &sp.turtle));
                if let Err(e) = done {
                    w.input = input;
                    return Err(e);
                }
                for &(b, t) in &w.bones {
                    let plan = if !(b.is_finite() && t.is_finite()) {
                        self.cost.plan_bone(b, t)
                    } else {
                        match sp.near {
                            // Based at the symbol: its tubes are searched
                            // once for all the candidates.
                            Some(n) if n.position == b => {
                                let tubes = base_tubes
                                    .get_or_insert_with(|| w.tubes.tubes_near(&self.cost, &n));
                                self.cost
                                    .plan_bone_near_in(b, t, n.curve, &n.closest, Some(tubes))
                            }
                            _ => match self.near_at(b, &mut memo) {
                                Some(n) => self.cost.plan_bone_near(b, t, n.curve, &n.closest),
                                None => self.cost.plan_bone(b, t),
                            },
                        }
                    };
                    cost +=
                        self.cost.peek(&q.cost, &plan) + self.cover_delta(&q.cost, &plan, cover);
                    plans.push(plan);
                }
                if w.non_finite {
                    cost = f64::INFINITY;
                } else if cover > 0.0 && reach.candidates > 0.0 {
                    let ahead = self.lookahead(w, alt, &q.cost, &plans, reach);
                    cost -= 2.0 * cover * reach.candidates * ahead;
                }
            } else {
                w.params.clear();
                w.users.clear();
                w.bones.clear();
                w.non_finite = false;
            }
            // Keep the candidate's successor (swapped: no copies).
            std::mem::swap(&mut w.params, &mut w.cand_params[c]);
            std::mem::swap(&mut w.users, &mut w.cand_users[c]);
            std::mem::swap(&mut w.bones, &mut w.cand_bones[c]);
            w.cand_non_finite[c] = w.non_finite;
            w.cand_plans[c] = plans;
            w.cand_alt.push(alt);
            w.cand_logv.push(if cost.is_nan() {
                f64::NEG_INFINITY
            } else {
                -cost / temperature
            });
        }
        w.input = input;
        let u = f64::from(
            DrawCtx {
                iteration: STREAM_CANDIDATE,
                position: 0,
                ..draws
            }
            .uniform(0),
        );
        let (c, correction) = resample::choose_candidate(&w.cand_logv, u);
        Ok((c, correction))
    }

    /// Close every open skeleton symbol of `p` with its wrap-up production
    /// (nodes in step `cur`; draws keyed by `key`, the particle's index
    /// among the run's final particles over every refinement round).
    #[allow(clippy::too_many_arguments)]
    fn wrap_up(
        &self,
        w: &mut Worker,
        layers: &[Vec<Step>],
        cur: (u32, u32),
        key: u32,
        p: &Particle,
        seed: u32,
        opts: &SampleOptions,
    ) -> Result<(Particle, Step), SampleError> {
        let (limits, cancel) = (&opts.limits, opts.cancel.as_ref());
        w.append_spawns = false;
        let mut q = p.clone();
        let mut local = Step::default();
        let mut k = 0u32;
        while !q.open.is_empty() {
            if k.is_multiple_of(CANCEL_EVERY) {
                cancel::check(cancel)?;
            }
            if u64::from(k) >= limits.max_expansions {
                return Err(SampleError::GeometryLimit {
                    symbol: "(wrap-up)".into(),
                    what: LimitKind::Expansions,
                    limit: limits.max_expansions,
                    file: self.g.sys.file,
                    span: self.g.sys.span,
                });
            }
            let draws = tagged(seed, STREAM_WRAPUP, key, k);
            k += 1;
            let idx = q.open.len() - 1;
            let how = How::Draw {
                draws,
                which: Which::Wrapup,
                phase: "wrap-up",
            };
            self.expand_open(w, layers, &mut local, cur, &mut q, idx, how, false, &[])?;
        }
        q.score = self.score(&q, 0.0, opts.guide.cover);
        Ok((q, local))
    }

    // ---- the run ----------------------------------------------------------

    /// Sample one model: the skeleton phase (SOSMC over the schedule),
    /// wrap-up of every distinct final particle, then the geometry phase
    /// for the best ones. Deterministic for a given seed and schedule,
    /// whatever `threads`, unless a `budget` stops the search early.
    /// A set [`SampleOptions::cancel`] token stops it with
    /// [`SampleError::Cancelled`].
    pub fn sample(&self, opts: &SampleOptions) -> Result<SampleResult, SampleError> {
        let keep = if opts.frames { Keep::All } else { Keep::None };
        self.sample_keeping(opts, keep)
    }

    /// [`Self::sample`], keeping the frame of `generation` alone (0-based;
    /// past the last generation run, the last one: the result's) in
    /// [`SampleResult::frames`] ([`SampleResult::frame`] finds it): what
    /// `grmc sample --generation K` and the preview's generation scrubber
    /// show, for the price of one frame rather than one per generation.
    /// With [`SampleOptions::frames`] every frame is kept anyway.
    pub fn sample_frame(
        &self,
        opts: &SampleOptions,
        generation: u32,
    ) -> Result<SampleResult, SampleError> {
        let keep = if opts.frames {
            Keep::All
        } else {
            Keep::One(generation)
        };
        self.sample_keeping(opts, keep)
    }

    fn sample_keeping(
        &self,
        opts: &SampleOptions,
        keep: Keep,
    ) -> Result<SampleResult, SampleError> {
        let threads = match opts.threads {
            0 => std::thread::available_parallelism().map_or(1, |n| n.get().min(MAX_THREADS)),
            t if t > MAX_THREADS => {
                return Err(SampleError::Options(format!(
                    "{t} threads is more than the {MAX_THREADS} a sampler starts (0 uses all cores, 1 runs on the calling thread)"
                )));
            }
            t => t,
        };
        // The checker's bounds on the settings (a schedule built by hand
        // can pass anything): beyond them the particles alone would not fit
        // in memory.
        let sched = &opts.schedule;
        if sched.generations > grm_sema::MAX_GENERATIONS {
            return Err(SampleError::Options(format!(
                "{} generations is more than the {} a search runs",
                sched.generations,
                grm_sema::MAX_GENERATIONS
            )));
        }
        let most = sched.particles_start.max(sched.particles_end);
        if most > grm_sema::MAX_PARTICLES {
            return Err(SampleError::Options(format!(
                "{most} particles is more than the {} a search keeps",
                grm_sema::MAX_PARTICLES
            )));
        }
        if opts.candidates > grm_sema::MAX_PARTICLES {
            return Err(SampleError::Options(format!(
                "{} candidates is more than the {} a search tries",
                opts.candidates,
                grm_sema::MAX_PARTICLES
            )));
        }
        cancel::check(opts.cancel.as_ref())?;
        if threads <= 1 {
            return self.run(opts, keep, false);
        }
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .map_err(|e| SampleError::ThreadPool(e.to_string()))?;
        pool.install(|| self.run(opts, keep, true))
    }

    fn run(
        &self,
        opts: &SampleOptions,
        keep: Keep,
        parallel: bool,
    ) -> Result<SampleResult, SampleError> {
        let start = Instant::now();
        let sched = opts.schedule;
        let gens = sched.generations.max(1);
        let seed = opts.seed;
        let h_of = |g: u32| {
            if opts.heuristic {
                sched.heuristic_scale(g)
            } else {
                0.0
            }
        };
        let temperature = if opts.temperature > 0.0 && !opts.temperature.is_nan() {
            opts.temperature
        } else {
            1.0
        };
        let ess_target = if opts.ess_target.is_finite() {
            opts.ess_target.clamp(0.0, 1.0)
        } else {
            0.0
        };
        let max_k = opts.max_expansions_per_step.max(1);
        // Candidates need a per-bone cost and finite weights.
        let kc = if matches!(self.objective, Objective::Curves) && temperature.is_finite() {
            opts.candidates.max(1)
        } else {
            1
        };
        let cancel = opts.cancel.as_ref();
        let mut w = self.g.worker();
        let (root, root_step) =
            self.root_particle(&mut w, None, seed, h_of(0), opts.guide.cover)?;
        // The arena: layer 0 the axiom, layer g + 1 generation g, then the
        // wrap-ups.
        let mut layers: Vec<Vec<Step>> = vec![vec![root_step]];
        // Every particle of generation 0 starts as the same axiom (shared).
        let root = Arc::new(root);
        let mut pop: Vec<Arc<Particle>> =
            (0..sched.particles(0)).map(|_| Arc::clone(&root)).collect();
        // Grown as the generations run (a preallocated record per
        // generation of a long schedule is memory the search may not use).
        let mut stats: Vec<GenerationStats> = Vec::new();
        let mut log_w = Vec::new();
        let mut weights = Vec::new();
        let mut ancestors = Vec::new();
        let mut stopped_early = false;
        let mut last: Vec<Arc<Particle>> = Vec::new();
        let mut frames: Vec<(u32, Result<SampledModel, SampleError>)> = Vec::new();
        // The bytes of the frames kept (what `max_bytes` bounds with the
        // search: a frame per generation of a long run is many models).
        let mut frame_bytes: u64 = 0;
        // Wall time spent on frames, which the budget does not count.
        let mut frame_time = Duration::ZERO;
        // Steps of particles that were not resampled, emptied for reuse.
        let mut spare: Vec<Step> = Vec::new();
        let mut used = Vec::new();
        // The bytes of every step in `layers` and `spare` (a recycled
        // step moves from one to the other with its capacity).
        let mut arena_bytes: u64 = layers.iter().flatten().map(|s| s.bytes() as u64).sum();
        // The arena's own structure: a `Step` per particle per generation
        // (its buffers are in `arena_bytes`), counted as layers are made.
        let mut layer_bytes: u64 = layers
            .iter()
            .map(|l| (l.capacity() * size_of::<Step>() + size_of::<Vec<Step>>()) as u64)
            .sum();
        // Everything else the search holds that grows with it: the layers'
        // list, the generation records, the spare steps, and per particle
        // its weights, ancestors and flags.
        let bookkeeping = |layers: &Vec<Vec<Step>>,
                           stats: &Vec<GenerationStats>,
                           spare: &Vec<Step>,
                           particles: usize| {
            (layers.len() * size_of::<Vec<Step>>()
                + stats.capacity() * size_of::<GenerationStats>()
                + spare.capacity() * size_of::<Step>()
                + particles
                    * (3 * size_of::<f64>() + size_of::<usize>() + 1 + 2 * size_of::<usize>()))
                as u64
        };
        let check_memory = |g: u32, held: u64, particles: usize, stats: &[GenerationStats]| {
            if held > opts.max_bytes {
                Err(SampleError::MemoryLimit {
                    generation: g,
                    bytes: held,
                    limit: opts.max_bytes,
                    particles,
                    generations: stats.to_vec(),
                })
            } else {
                Ok(())
            }
        };
        // Refinement (`Refine`): the generation its rounds restart from,
        // the population kept there, and every round's wrapped-up final
        // particles (the first pass's first).
        let restart = if opts.guide.cover > 0.0
            && matches!(self.objective, Objective::Curves)
            && temperature.is_finite()
        {
            opts.refine.restart(gens)
        } else {
            None
        };
        let covering = restart.is_some() && opts.refine.prefer_covering;
        let mut checkpoint: Option<Vec<Arc<Particle>>> = None;
        let mut kept_bytes: u64 = 0;
        let mut finals: Vec<Particle> = Vec::new();
        let mut seen_finals = std::collections::HashSet::new();
        let mut first = 0;
        let mut round = 0;
        // Rounds run to their end (a round the budget cuts short is
        // dropped, below).
        let mut completed = 0;
        let mut searched_gens = 0;
        loop {
            // Round r > 0 draws with a seed of its own.
            let rseed = if round == 0 {
                seed
            } else {
                refine::round_seed(seed, round)
            };
            for g in first..gens {
                if round == 0 && restart == Some(g) {
                    // What refinement rounds restart from (its particles'
                    // own state is held: counted with the search's).
                    kept_bytes = pop.iter().map(|p| p.own_bytes() as u64).sum();
                    checkpoint = Some(pop.clone());
                }
                // Between generations: a cancelled run stops here (a
                // generation of the Calder tree is a fraction of a millisecond).
                cancel::check(cancel)?;
                let h = h_of(g);
                let lay: &[Vec<Step>] = &layers;
                let bufs: Vec<Step> = (0..pop.len())
                    .map(|_| spare.pop().unwrap_or_default())
                    .collect();
                let taken_bytes: u64 = bufs.iter().map(|s| s.bytes() as u64).sum();
                let step = |w: &mut Worker, (i, (p, buf)): (usize, (&Arc<Particle>, Step))| {
                    self.advance(
                        w,
                        lay,
                        buf,
                        p,
                        rseed,
                        g,
                        i as u32,
                        h,
                        max_k,
                        kc,
                        temperature,
                        &opts.guide,
                        &opts.reach,
                        gens - g - 1,
                    )
                };
                let results: Vec<Result<(Particle, Step, u32, f64), SampleError>> = if parallel {
                    pop.par_iter()
                        .zip(bufs)
                        .enumerate()
                        .map_init(|| self.g.worker(), step)
                        .collect()
                } else {
                    pop.iter()
                        .zip(bufs)
                        .enumerate()
                        .map(|x| step(&mut w, x))
                        .collect()
                };
                let mut next = Vec::with_capacity(results.len());
                let mut layer = Vec::with_capacity(results.len());
                let mut expansions = 0u64;
                let mut corrections = Vec::with_capacity(results.len());
                for r in results {
                    // The first error in particle order, whatever the threads.
                    let (q, st, k, corr) = r?;
                    expansions += u64::from(k);
                    next.push(Arc::new(q));
                    layer.push(st);
                    corrections.push(corr);
                }
                // Taken from `spare` (counted there) or new: the arena holds
                // whatever capacity they have now.
                arena_bytes += layer.iter().map(|s| s.bytes() as u64).sum::<u64>();
                arena_bytes -= taken_bytes;
                layer_bytes +=
                    (layer.capacity() * size_of::<Step>() + size_of::<Vec<Step>>()) as u64;
                layers.push(layer);
                log_w.clear();
                log_w.extend(
                    next.iter()
                        .zip(&pop)
                        .zip(&corrections)
                        .map(|((q, p), corr)| {
                            if temperature.is_infinite() {
                                0.0
                            } else {
                                -(q.score - p.score) / temperature + corr
                            }
                        }),
                );
                let beta = if ess_target > 0.0 {
                    resample::temper(&log_w, ess_target * next.len() as f64)
                } else {
                    1.0
                };
                resample::scale(&mut log_w, beta);
                resample::normalized(&log_w, &mut weights);
                let best = next
                    .iter()
                    .map(|q| self.objective_of(q))
                    .fold(f64::INFINITY, f64::min);
                stats.push(GenerationStats {
                    generation: g,
                    particles: next.len(),
                    expanding: pop.iter().filter(|p| p.live > 0).count(),
                    ess: resample::ess(&weights),
                    beta,
                    survivors: 0,
                    heuristic_scale: h,
                    best_objective: best,
                    mean_bones: next.iter().map(|q| f64::from(q.bones)).sum::<f64>()
                        / next.len().max(1) as f64,
                    expansions,
                    memory_bytes: 0,
                });
                let out_of_time = opts
                    .budget
                    .is_some_and(|b| start.elapsed().saturating_sub(frame_time) >= b);
                if round > 0 && out_of_time && g + 1 < gens {
                    // A refinement round the budget stops before its end is
                    // dropped: the model is the best of the pass and the
                    // rounds that ran to their end (`last` stays empty).
                    break;
                }
                if round == 0 && keep.wants(g) && !(g + 1 == gens || out_of_time) {
                    // The last generation's frame is the returned model.
                    let t = Instant::now();
                    let f = self.frame(&mut w, &mut layers, &next, seed, opts, parallel)?;
                    frame_bytes += f.as_ref().map_or(0, |m| m.heap_bytes() as u64);
                    frames.push((g, f));
                    frame_time += t.elapsed();
                }
                if g + 1 == gens || out_of_time {
                    stopped_early = g + 1 < gens;
                    let mut seen = std::collections::HashSet::new();
                    let distinct = next.iter().filter(|p| seen.insert(p.head)).count();
                    let held = arena_bytes
                        + layer_bytes
                        + bookkeeping(&layers, &stats, &spare, next.len())
                        + frame_bytes
                        + kept_bytes
                        + next.iter().map(|p| p.own_bytes() as u64).sum::<u64>();
                    if let Some(st) = stats.last_mut() {
                        st.survivors = distinct;
                        st.memory_bytes = held;
                    }
                    check_memory(g, held, next.len(), &stats)?;
                    last = next;
                    break;
                }
                resample::systematic(
                    &weights,
                    sched.particles(g + 1),
                    resample_uniform(rseed, g),
                    &mut ancestors,
                );
                pop = ancestors.iter().map(|&a| Arc::clone(&next[a])).collect();
                // A step that no resampled particle descends from is never
                // read again: recycle its buffers.
                used.clear();
                used.resize(next.len(), false);
                for &a in &ancestors {
                    used[a] = true;
                }
                if let Some(st) = stats.last_mut() {
                    st.survivors = used.iter().filter(|&&u| u).count();
                }
                if let Some(layer) = layers.last_mut() {
                    for (st, _) in layer.iter_mut().zip(&used).filter(|(_, u)| !**u) {
                        let mut st = std::mem::take(st);
                        st.clear();
                        spare.push(st);
                    }
                    // Steps without nodes at the layer's end are never looked
                    // up (a node id names a node that exists): a search whose
                    // particles add nothing (all finished, or expanding
                    // nothing that lasts) keeps no `Step` per particle per
                    // generation for them.
                    let before = (layer.capacity() * size_of::<Step>()) as u64;
                    while layer.last().is_some_and(|s| s.nodes.is_empty()) {
                        if let Some(st) = layer.pop()
                            && st.bytes() > 0
                        {
                            spare.push(st);
                        }
                    }
                    layer.shrink_to_fit();
                    layer_bytes -= before;
                    layer_bytes += (layer.capacity() * size_of::<Step>()) as u64;
                }
                let held = arena_bytes
                    + layer_bytes
                    + bookkeeping(&layers, &stats, &spare, next.len())
                    + frame_bytes
                    + kept_bytes
                    + next
                        .iter()
                        .zip(&used)
                        .filter(|(_, u)| **u)
                        .map(|(p, _)| p.own_bytes() as u64)
                        .sum::<u64>();
                if let Some(st) = stats.last_mut() {
                    st.memory_bytes = held;
                }
                check_memory(g, held, pop.len(), &stats)?;
            }
            if round == 0 {
                searched_gens = stats.len();
            } else if last.is_empty() {
                // This round was cut short by the budget (above).
                break;
            } else {
                completed = round;
            }
            cancel::check(cancel)?;
            let wrapped = self.wrap_finals(
                &mut w,
                &mut layers,
                &last,
                seed,
                opts,
                parallel,
                &mut seen_finals,
                finals.len(),
            )?;
            finals.extend(wrapped);
            let (Some(from), Some(kept)) = (restart, checkpoint.as_ref()) else {
                break;
            };
            if round >= opts.refine.rounds || stopped_early {
                break;
            }
            let best = self.ranked(&finals, opts.guide.cover, covering, 1);
            let Some(&b) = best.first() else {
                break;
            };
            // Once started, `min_rounds` rounds run whatever the best.
            let may_end = round == 0 || round >= opts.refine.min_rounds;
            if may_end
                && (refine::covers_every_curve(&self.cost, &finals[b].cost)
                    || (opts.refine.followed_ends
                        && self.follows_every_curve(&mut w, &layers, &finals[b], seed, b, opts)?))
            {
                break;
            }
            round += 1;
            pop = kept.clone();
            first = from;
            last = Vec::new();
        }
        drop(checkpoint);
        drop(pop);
        cancel::check(cancel)?;
        // The refinement rounds' generations are not the search's: the
        // records are the first pass's.
        stats.truncate(searched_gens);
        let (models, candidates) = self.build_best(
            &mut w,
            &layers,
            &finals,
            seed,
            opts,
            covering,
            opts.best.max(1),
        )?;
        // The last generation's frame: the returned model.
        let ran = stats.len().saturating_sub(1) as u32;
        if keep.wants_last(ran)
            && let Some(best) = models.first()
        {
            frames.push((ran, Ok(best.clone())));
        }
        Ok(SampleResult {
            frames,
            models,
            generations: stats,
            candidates,
            stopped_early,
            refinements: completed,
            elapsed: start.elapsed(),
        })
    }

    /// The end of a run from `last` (its final generation's particles):
    /// [`Self::wrap_finals`], then [`Self::build_best`] of the first `best`.
    /// The wrap-ups' nodes go into a new layer of `layers`, which the
    /// caller may drop once the models are built.
    #[allow(clippy::too_many_arguments)]
    fn finish(
        &self,
        w: &mut Worker,
        layers: &mut Vec<Vec<Step>>,
        last: &[Arc<Particle>],
        seed: u32,
        opts: &SampleOptions,
        parallel: bool,
        best: usize,
    ) -> Result<(Vec<SampledModel>, Vec<f64>), SampleError> {
        let mut seen = std::collections::HashSet::new();
        let done = self.wrap_finals(w, layers, last, seed, opts, parallel, &mut seen, 0)?;
        self.build_best(w, layers, &done, seed, opts, false, best)
    }

    /// Wrap up the distinct particles of `last` (copies share their head
    /// node; a head in `seen`, wrapped up before, is skipped), each with
    /// the draws of its index among them plus `offset` (the particles
    /// wrapped up before, in earlier refinement rounds). Their nodes go
    /// into a new layer of `layers`. In particle order.
    #[allow(clippy::too_many_arguments)]
    fn wrap_finals(
        &self,
        w: &mut Worker,
        layers: &mut Vec<Vec<Step>>,
        last: &[Arc<Particle>],
        seed: u32,
        opts: &SampleOptions,
        parallel: bool,
        seen: &mut std::collections::HashSet<NodeId>,
        offset: usize,
    ) -> Result<Vec<Particle>, SampleError> {
        let cancel = opts.cancel.as_ref();
        let finals: Vec<&Arc<Particle>> = last.iter().filter(|p| seen.insert(p.head)).collect();
        let wl = layers.len() as u32;
        let lay: &[Vec<Step>] = layers;
        let wrap = |w: &mut Worker, (c, p): (usize, &&Arc<Particle>)| {
            self.wrap_up(w, lay, (wl, c as u32), (offset + c) as u32, p, seed, opts)
        };
        let wrapped: Vec<Result<(Particle, Step), SampleError>> = if parallel {
            finals
                .par_iter()
                .enumerate()
                .map_init(|| self.g.worker(), wrap)
                .collect()
        } else {
            finals.iter().enumerate().map(|x| wrap(w, x)).collect()
        };
        let mut done = Vec::with_capacity(wrapped.len());
        let mut layer = Vec::with_capacity(wrapped.len());
        for r in wrapped {
            let (q, st) = r?;
            done.push(q);
            layer.push(st);
        }
        cancel::check(cancel)?;
        layers.push(layer);
        Ok(done)
    }

    /// Whether the model of wrapped-up final particle `p` (index `c` among
    /// the run's final particles: the model [`Self::build_best`] returns
    /// when it ranks first) follows every curve by
    /// [`grm_guide::coverage`]'s measure ([`Refine::followed_ends`]). A
    /// model that cannot be built (a geometry-phase limit) does not; a
    /// cancellation is passed on.
    fn follows_every_curve(
        &self,
        w: &mut Worker,
        layers: &[Vec<Step>],
        p: &Particle,
        seed: u32,
        c: usize,
        opts: &SampleOptions,
    ) -> Result<bool, SampleError> {
        match self.build_model(w, layers, p, seed, c as u32, opts) {
            Ok(m) => {
                let bones: Vec<(Vec3, Vec3)> = m
                    .interpretation
                    .bones
                    .iter()
                    .map(|b| (b.base, b.tip))
                    .collect();
                Ok(grm_guide::follows_every_curve(
                    &self.curves,
                    &bones,
                    &grm_guide::CoverageOptions::default(),
                ))
            }
            Err(SampleError::Cancelled) => Err(SampleError::Cancelled),
            Err(_) => Ok(false),
        }
    }

    /// The indices of the `best` lowest of `done` by the objective
    /// searched (with the coverage term `w`): lowest first, NaN last, ties
    /// by index; with `covering`, those that cover every curve
    /// ([`Refine::prefer_covering`]) before the others.
    fn ranked(&self, done: &[Particle], w: f64, covering: bool, best: usize) -> Vec<usize> {
        let objective: Vec<f64> = done.iter().map(|q| self.searched(q, w)).collect();
        // With `covering`, those that leave a curve under-covered last.
        let misses: Vec<bool> = done
            .iter()
            .map(|q| covering && !refine::covers_every_curve(&self.cost, &q.cost))
            .collect();
        let mut order: Vec<usize> = (0..done.len()).collect();
        order.sort_by(|&a, &b| {
            let (x, y) = (objective[a], objective[b]);
            misses[a].cmp(&misses[b]).then(
                x.partial_cmp(&y)
                    .unwrap_or_else(|| x.is_nan().cmp(&y.is_nan()))
                    .then(a.cmp(&b)),
            )
        });
        order.truncate(best);
        order
    }

    /// The models of the `best` first of the wrapped-up final particles
    /// `done` ([`Self::ranked`] with `covering`; the geometry phase of each drawn with its
    /// index), and the objective of every one, in order.
    #[allow(clippy::too_many_arguments)]
    fn build_best(
        &self,
        w: &mut Worker,
        layers: &[Vec<Step>],
        done: &[Particle],
        seed: u32,
        opts: &SampleOptions,
        covering: bool,
        best: usize,
    ) -> Result<(Vec<SampledModel>, Vec<f64>), SampleError> {
        let order = self.ranked(done, opts.guide.cover, covering, best);
        let mut models = Vec::with_capacity(order.len());
        for c in order {
            models.push(self.build_model(w, layers, &done[c], seed, c as u32, opts)?);
        }
        let candidates = done
            .iter()
            .map(|q| self.searched(q, opts.guide.cover))
            .collect();
        Ok((models, candidates))
    }

    /// A frame of [`SampleOptions::frames`]: [`Self::finish`] of a
    /// generation's particles, as if the run stopped there (the same
    /// draws, so exactly the model a budget stopping it there returns).
    /// The wrap-ups' layer is dropped once the model is built: the search
    /// never sees it. A frame that cannot be finished (a wrap-up or
    /// geometry-phase limit or a failing production that the run's own
    /// end need not meet) is that error, and the search goes on; only a
    /// cancellation stops the run.
    fn frame(
        &self,
        w: &mut Worker,
        layers: &mut Vec<Vec<Step>>,
        particles: &[Arc<Particle>],
        seed: u32,
        opts: &SampleOptions,
        parallel: bool,
    ) -> Result<Result<SampledModel, SampleError>, SampleError> {
        let n = layers.len();
        let made = self.finish(w, layers, particles, seed, opts, parallel, 1);
        layers.truncate(n);
        match made {
            Err(SampleError::Cancelled) => Err(SampleError::Cancelled),
            Err(e) => Ok(Err(e)),
            Ok((models, _)) => Ok(models.into_iter().next().ok_or_else(|| {
                // A generation has at least one particle (`Schedule`).
                SampleError::Options("a generation without particles has no frame".into())
            })),
        }
    }

    // ---- the complete model ------------------------------------------------

    /// The complete model of a wrapped-up particle: walk its derivation tree
    /// depth first, interpreting each expansion's successor from its
    /// non-terminal's frame, and expand the geometry symbols on the way
    /// (the geometry phase, to completion, within `limits`).
    fn build_model(
        &self,
        w: &mut Worker,
        layers: &[Vec<Step>],
        p: &Particle,
        seed: u32,
        c: u32,
        opts: &SampleOptions,
    ) -> Result<SampledModel, SampleError> {
        let (limits, cancel) = (&opts.limits, opts.cancel.as_ref());
        let sys = self.g.sys;
        let chain = p.chain(layers);
        let key = |a: u32, b: u32| (u64::from(a) << 32) | u64::from(b);
        let mut kids: Vec<(u64, u32)> = chain
            .iter()
            .skip(1)
            .map(|(_, n)| (key(n.parent.0, n.parent.1), n.seq))
            .collect();
        kids.sort_unstable();

        enum Src {
            Chain(u32),
            Fresh {
                symbol: u32,
                alt: u32,
                params: Vec<f32>,
            },
        }
        struct Item {
            src: Src,
            turtle: Turtle,
            parent: Option<(u32, u32)>,
            depth: u32,
            /// The expanded module's identity key (the root key for the
            /// axiom).
            key: u32,
            /// Its persistent edits' scope (`crate::edits`; 0 without).
            scope: u32,
        }
        let mut interp = Interpreter::from_parts(self.g.ops.clone(), self.g.cfg);
        let mut string = ModuleString::new();
        let mut origins: Vec<u32> = Vec::new();
        let mut tree = DerivationTree::default();
        let mut users: Vec<(usize, Turtle)> = Vec::new();
        let mut stack = vec![Item {
            src: Src::Chain(0),
            turtle: self.g.initial_turtle(),
            parent: None,
            depth: 0,
            key: sys.root_key(seed),
            scope: 0,
        }];
        let mut geometry = 0u64;
        let mut hits = self.replay.as_ref().map(Replay::new_hits);
        while let Some(mut item) = stack.pop() {
            // The persistent edits of the successor about to be written
            // (a chain node's values were edited when the search made it).
            let edited = if let Some(r) = &self.replay {
                let (sym, alt, values) = match &mut item.src {
                    Src::Chain(seq) => {
                        let n = chain[*seq as usize].1;
                        (n.symbol, n.alt, None)
                    }
                    Src::Fresh {
                        symbol,
                        alt,
                        params,
                    } => (*symbol, *alt, Some(&mut params[..])),
                };
                r.successor(
                    &self.g,
                    item.key,
                    item.scope,
                    alt,
                    values,
                    &mut w.succ,
                    hits.as_mut(),
                )
                .map_err(|v| self.non_finite_edit(sym, alt, v, "geometry"))?;
                true
            } else {
                false
            };
            let (symbol, kind, alt, params): (u32, NodeKind, u32, &[f32]) = match &item.src {
                Src::Chain(seq) => {
                    let (st, n) = chain[*seq as usize];
                    (n.symbol, n.kind, n.alt, st.params(n))
                }
                Src::Fresh {
                    symbol,
                    alt,
                    params,
                } => (*symbol, NodeKind::Geometry, *alt, params),
            };
            let idx = tree.nodes.len() as u32;
            let first = string.len();
            if let Some(a) = sys.alts.get(alt as usize) {
                for (j, m) in sys.successor(a).iter().enumerate() {
                    let key = if edited {
                        let e = w.succ.mods[j];
                        if e.removed {
                            continue;
                        }
                        e.key
                    } else {
                        grm_compile::rng::child_key(item.key, m.salt)
                    };
                    let n = self.g.words[m.symbol as usize] as usize;
                    let o = m.word_offset as usize;
                    string.push_keyed(m.symbol, params.get(o..o + n).unwrap_or(&[]), key);
                    origins.push(alt);
                }
            }
            let b0 = interp.output().bones.len() as u32;
            users.clear();
            interp
                .run_range(item.turtle, &string, first..string.len(), &mut |i, t| {
                    users.push((i, *t));
                })
                .map_err(|e| SampleError::Turtle(e.to_string()))?;
            let b1 = interp.output().bones.len() as u32;
            tree.nodes.push(TreeNode {
                parent: item.parent,
                key: item.key,
                kind,
                symbol,
                alt: (alt != INERT).then_some(alt),
                params: params.to_vec(),
                modules: first as u32..string.len() as u32,
                bones: b0..b1,
            });
            for (ord, &(i, t)) in users.iter().enumerate().rev() {
                let parent = Some((idx, ord as u32));
                // Its edits (by its successor position).
                let e = if edited {
                    let j = i - first;
                    let j = if w.succ.removing {
                        w.succ.kept.get(j).map_or(j, |&k| k as usize)
                    } else {
                        j
                    };
                    w.succ.mods.get(j).copied().unwrap_or_default()
                } else {
                    crate::edits::Succ::default()
                };
                if let Src::Chain(seq) = item.src
                    && let Ok(pos) = kids.binary_search_by_key(&key(seq, ord as u32), |k| k.0)
                {
                    stack.push(Item {
                        src: Src::Chain(kids[pos].1),
                        turtle: t,
                        parent,
                        depth: 0,
                        key: string.keys()[i],
                        scope: e.scope,
                    });
                    continue;
                }
                let sym = string.sym(i);
                if !self.g.is_geometry(sym) {
                    // Inert: a symbol without a phase, or (only if the
                    // checker let one through) a skeleton symbol.
                    continue;
                }
                let depth = item.depth + 1;
                let what = if depth > limits.max_depth {
                    Some((LimitKind::Depth, u64::from(limits.max_depth)))
                } else if geometry >= limits.max_expansions {
                    Some((LimitKind::Expansions, limits.max_expansions))
                } else {
                    None
                };
                if let Some((what, limit)) = what {
                    return Err(SampleError::GeometryLimit {
                        symbol: self.g.symbol_name(sym),
                        what,
                        limit,
                        file: sys.file,
                        span: sys.alt_spans.get(alt as usize).copied().unwrap_or(sys.span),
                    });
                }
                if geometry.is_multiple_of(u64::from(CANCEL_EVERY)) {
                    cancel::check(cancel)?;
                }
                let draws = if e.scope & PINNED != 0 {
                    pinned_draws(string.keys()[i])
                } else {
                    tagged(seed, STREAM_GEOMETRY, c, geometry as u32)
                };
                geometry += 1;
                let input: Vec<f32> = string.get(i).1.to_vec();
                let chosen = if e.force != 0 {
                    self.g.choose_forced(
                        w,
                        sym,
                        &input,
                        Which::Normal,
                        &draws,
                        "geometry",
                        e.force,
                    )?
                } else {
                    self.g
                        .choose(w, sym, &input, Which::Normal, &draws, "geometry")?
                };
                if let Some(a) = chosen {
                    self.g.eval_successor(w, sym, a, &draws, "geometry")?;
                    stack.push(Item {
                        src: Src::Fresh {
                            symbol: sym,
                            alt: a,
                            params: w.params.clone(),
                        },
                        turtle: t,
                        parent,
                        depth,
                        key: string.keys()[i],
                        scope: e.scope,
                    });
                }
            }
        }
        let mut interpretation = interp.finish();
        interpretation.fill_origins(&origins);
        Ok(SampledModel {
            cost: self.cost.total(&p.cost),
            volume: match (&self.volume, &p.volume) {
                (Some(vt), Some(vs)) => Some(vt.cost(vs)),
                _ => None,
            },
            objective: self.searched(p, opts.guide.cover),
            skeleton_bones: p.bones,
            interpretation,
            string,
            origins,
            tree,
            candidate: c as usize,
            param_values: sys.param_values.clone(),
            edits: self
                .replay
                .as_ref()
                .zip(hits.as_ref())
                .map(|(r, h)| r.hits(h)),
        })
    }

    // ---- checks -------------------------------------------------------------

    /// Replay the axiom, skeleton and wrap-up expansions of `tree` (a
    /// complete derivation made by this sampler) in a random order (every
    /// non-terminal after the expansion that emitted it; the order is drawn
    /// from `order_seed`) with the sampler's own machinery, and return the
    /// cost of the result. It equals the model's cost, bit for bit, for
    /// every order: the check that the cost does not depend on the order in
    /// which symbols were expanded.
    pub fn cost_in_order(
        &self,
        tree: &DerivationTree,
        order_seed: u32,
    ) -> Result<CostBreakdown, SampleError> {
        let bad = |m: &str| SampleError::Options(format!("cannot replay the tree: {m}"));
        let root = tree.nodes.first().ok_or_else(|| bad("it is empty"))?;
        if root.kind != NodeKind::Axiom {
            return Err(bad("node 0 is not the axiom"));
        }
        let mut kid: HashMap<(u32, u32), u32> = HashMap::new();
        for (i, n) in tree.nodes.iter().enumerate() {
            if let Some(p) = n.parent {
                kid.insert(p, i as u32);
            }
        }
        let axiom = self.g.sys.alts.get(self.g.sys.axiom_alt as usize);
        if root.alt != Some(self.g.sys.axiom_alt)
            || axiom.is_none_or(|a| a.succ_words as usize != root.params.len())
        {
            return Err(bad("node 0 does not fit the axiom"));
        }
        let mut w = self.g.worker();
        let (mut p, root_step) = self.root_particle(&mut w, Some(&root.params), 0, 0.0, 0.0)?;
        let mut layers = vec![vec![root_step]];
        // Chain seq -> tree node.
        let mut tree_of = vec![0u32];
        let mut used = vec![false; tree.nodes.len()];
        used[0] = true;
        let mut k = 0u32;
        while !p.open.is_empty() {
            let ctx = tagged(order_seed, STREAM_ORDER, k, 0);
            k += 1;
            let idx = pick(&ctx, 0, p.open.len());
            let r = *p.open.get(idx).ok_or_else(|| bad("open list"))?;
            let (seq, ordinal) = {
                let arena = Arena {
                    layers: &layers,
                    local: &layers[0][0],
                    cur: (0, 0),
                };
                let (st, n) = arena.get(r.node).ok_or_else(|| bad("a node is missing"))?;
                let sp = st
                    .spawns(n)
                    .get(r.spawn as usize)
                    .ok_or_else(|| bad("spawn"))?;
                (n.seq, sp.ordinal)
            };
            let parent = tree_of[seq as usize];
            let child = *kid
                .get(&(parent, ordinal))
                .ok_or_else(|| bad("an open symbol has no expansion"))?;
            // Each node expands one symbol once (defensive: with one parent
            // per node and the root used once, no node can come back).
            if std::mem::replace(&mut used[child as usize], true) {
                return Err(bad("a node is reached twice"));
            }
            let n = &tree.nodes[child as usize];
            let which = match n.kind {
                NodeKind::Wrapup => Which::Wrapup,
                NodeKind::Skeleton => Which::Normal,
                _ => return Err(bad("a skeleton symbol has a geometry expansion")),
            };
            let how = How::Given {
                alt: n.alt.unwrap_or(INERT),
                params: &n.params,
                which,
            };
            // Each replayed expansion in a step (layer) of its own.
            let cur = (layers.len() as u32, 0);
            let mut local = Step::default();
            self.expand_open(
                &mut w,
                &layers,
                &mut local,
                cur,
                &mut p,
                idx,
                how,
                false,
                &[],
            )?;
            layers.push(vec![local]);
            tree_of.push(child);
        }
        Ok(self.cost.total(&p.cost))
    }
}

/// An open symbol whose node or spawn is not in the arena (an invariant
/// broken inside the sampler, reported rather than panicking).
fn missing_node() -> SampleError {
    SampleError::Options("an open symbol refers to a missing node".into())
}

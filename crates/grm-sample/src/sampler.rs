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

mod complete;
mod expected;
mod grow;
mod lookahead;
mod run;

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
}

/// An open symbol whose node or spawn is not in the arena (an invariant
/// broken inside the sampler, reported rather than panicking).
fn missing_node() -> SampleError {
    SampleError::Options("an open symbol refers to a missing node".into())
}

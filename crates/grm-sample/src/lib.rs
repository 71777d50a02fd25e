//! `grm-sample`: the guided sampler (SOSMC steered by guiding curves,
//! Calder; DESIGN.md section 5, docs/sampling.md).
//!
//! **Role.** Grow a model of a sample-mode system (`mode = sample;`) that
//! follows the user's guiding curves: stochastically ordered sequential
//! Monte Carlo over partial derivations in the skeleton phase, then
//! wrap-up, then the geometry phase, returning the lowest-cost complete
//! model.
//!
//! **Inputs.** A checked sample [`grm_sema::System`] and its
//! [`grm_compile::CompiledSystem`], the guiding [`grm_guide::Curves`], an
//! [`Objective`] (the curve cost, or the volume-matching baseline) and
//! [`SampleOptions`] (seed, [`Schedule`], heuristic, temperature, candidate
//! expansions, adaptive tempering's ESS floor, threads, optional
//! wall-clock budget, how many best models, an optional [`CancelToken`]).
//!
//! **Outputs.** A [`SampleResult`]: the best [`SampledModel`]s (cost by
//! term, the full turtle [`grm_turtle::Interpretation`] ready for
//! `grm-geom`, the flat module string with per-module origins, the
//! [`DerivationTree`]), and [`GenerationStats`] per generation (effective
//! sample size, distinct survivors of resampling, tempering factor,
//! heuristic scale, best objective).
//!
//! **Method** (details and reasons in docs/sampling.md):
//! - A particle is a partial derivation: an `Arc`-linked list of
//!   expansion nodes plus a persistent vector of open skeleton
//!   non-terminals ([`pvec`]); expanding copies nothing of
//!   the ancestors.
//! - A particle's step expands uniformly chosen open skeleton symbols (a
//!   seeded draw: stochastic ordering) until one adds a bone; the
//!   alternative is drawn by its weight and the parameters evaluated with
//!   the grm-compile VM; the successor is interpreted from the
//!   non-terminal's own saved turtle frame (frame locality) and each bone
//!   is scored against the curves at once.
//! - Candidates: an expansion of a symbol that can make a bone draws
//!   [`SampleOptions::candidates`] (default 3) productions and parameters,
//!   prices each one's bones without changing the particle
//!   (`CostModel::peek`) and keeps one in proportion to `exp(-cost / T)`;
//!   the weight gets the sampling-importance-resampling correction
//!   `log(mean v) - log(v_kept)`.
//! - Weights are incremental and in log space: `log w = -(S_g(new) -
//!   S_{g-1}(old)) / T` (plus the candidates' correction) with `S = cost +
//!   HEURISTICSCALE_g * heuristic`; tempered by the largest `beta <= 1`
//!   that keeps the effective sample size at least
//!   [`SampleOptions::ess_target`] (default 0.1) of the particles: no
//!   population collapse; normalized with log-sum-exp; systematic
//!   resampling every generation ([`resample`]), where every particle, the
//!   last one included, can be chosen.
//! - The heuristic (eq. 9-10): each skeleton symbol's expected bone
//!   direction is estimated once, in [`Sampler::new`], from sub-derivations
//!   grown from the identity frame with a fixed seed; each open symbol
//!   contributes eq. 6 for that direction in its frame.
//!
//! **Invariants.**
//! - Deterministic: every draw is `grm_compile::rng::hash` of the seed and
//!   a tuple naming one decision (generation, particle, expansion, draw),
//!   so the result is a function of (program, curves, seed, schedule),
//!   the same for 1 or many threads. The one exception is
//!   [`SampleOptions::budget`], which stops when the wall clock says so.
//! - Cancellation is cooperative ([`SampleOptions::cancel`]): a set token
//!   stops the run at its next check with [`SampleError::Cancelled`],
//!   never with a partial model; an unset one changes nothing.
//! - A model's cost does not depend on the order its symbols were expanded
//!   (fixed-point sums; [`Sampler::cost_in_order`] checks it).
//! - The returned model is the lowest-cost complete one among the final
//!   generation's distinct particles (after wrap-up), not the first.
//! - No panics on user input: run-time failures are [`SampleError`]s with
//!   codes `R03xx` and source spans; the geometry phase has depth and size
//!   limits ([`FinishLimits`]).

mod cancel;
pub mod edits;
mod error;
mod expand;
mod model;
mod particle;
pub mod pvec;
mod refine;
pub mod resample;
mod sampler;
mod schedule;
mod tubes_memo;

pub use cancel::CancelToken;
pub use edits::{EditHits, EditPlan};
pub use error::{ExpandError, ExpandErrorKind, LimitKind, SampleError};
pub use model::{
    DerivationTree, FinishLimits, GenerationStats, NodeKind, RemovedModule, SampleResult,
    SampledModel, TreeNode,
};
pub use refine::{DEFAULT_REFINE_FROM, DEFAULT_REFINE_MIN_ROUNDS, DEFAULT_REFINE_ROUNDS, Refine};
pub use sampler::{
    DEFAULT_CANDIDATES, DEFAULT_COVER, DEFAULT_ESS_TARGET, DEFAULT_MAX_BYTES, DEFAULT_ORDER,
    DEFAULT_PACED_CANDIDATES, ExpectedOptions, Guide, MAX_THREADS, Objective, Reach, SampleOptions,
    Sampler,
};
pub use schedule::Schedule;

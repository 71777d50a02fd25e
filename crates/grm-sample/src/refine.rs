//! Refinement after the SMC pass (`docs/sampling.md` section 4.5): when
//! the best model the search found leaves a curve under-covered, the
//! search's tail is grown again from a population it kept part-way
//! (rejuvenation of every subtree grown after that generation, with
//! draws of their own), and the best model of all the passes is kept.

use grm_compile::rng;
use grm_guide::{CostModel, CostState, FOLLOWED};

/// Refinement rounds after the SMC pass ([`crate::SampleOptions::refine`]).
///
/// The run keeps the resampled population at the start of generation
/// `from * generations`. When the search ends and the best wrapped-up
/// model (by the searched objective) covers some curve at less than
/// [`FOLLOWED`] of its utilization segments (the coverage term's measure,
/// `docs/sampling.md` section 4.3) and, with [`Refine::followed_ends`],
/// also of its arc length by [`grm_guide::coverage`]'s measure, the generations from there to the end
/// are run again from that population with draws keyed by the round, and
/// their final particles join the candidates; this repeats until the best
/// model so far covers every curve or `rounds` rounds have run. A round
/// re-derives every subtree the search grew after the kept generation
/// (the branch points near the top of a tree, where a curve was left),
/// and the model returned is the lowest objective of all the rounds'
/// final particles, so a round can only lower it.
///
/// Only with the coverage term on (`Guide::cover > 0`, the curve
/// objective, a finite temperature); a run whose first pass covers every
/// curve is the same, bit for bit, as without refinement. With a
/// wall-clock budget ([`crate::SampleOptions::budget`]), no round runs
/// after a pass the budget stopped, and a round the budget stops before
/// its last generation is dropped: the model is the best of the pass and
/// the rounds that ran to their end (so a budget that stops nothing gives
/// the same model as no budget; the preview refines within its budget).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Refine {
    /// Rounds at most (0: off).
    pub rounds: u32,
    /// Where the rounds start, as a fraction of the generations (the
    /// generation `floor(from * generations)`, at least 1 and before the
    /// last).
    pub from: f64,
    /// Whether the model returned is the lowest objective among the
    /// final particles that cover every curve at [`FOLLOWED`] (when
    /// refinement is on and one does), rather than among all of them.
    pub prefer_covering: bool,
    /// Whether a best model that the segment check calls under-covered
    /// but that follows every curve by [`grm_guide::coverage`]'s measure
    /// (the `--stats` report's: the share of each curve's arc length with
    /// a bone within its covering radius, [`grm_guide::follows_every_curve`])
    /// ends the rounds too: the segment check (a segment counts when one
    /// bone has both ends in the tube) is stricter, and without this some
    /// models the report calls followed ran rounds (`docs/sampling.md`
    /// 4.5, session 26). On by default (since session 27, with
    /// [`Refine::min_rounds`]): the fork of four's and the vine's median
    /// model then runs no round (the pass's time); alone it raised the
    /// fork's median cost 0.3-0.5%, which five rounds at least once
    /// started win back (`docs/sampling.md` 4.5, session 27).
    pub followed_ends: bool,
    /// Rounds that run at least, once the pass's best model has started
    /// them (capped by `rounds`): before that many, a round whose best
    /// model covers every curve does not end the rounds. A pass that
    /// covers runs none either way, so this spends time only on the runs
    /// that already pay for a round (above the median time wherever most
    /// passes cover), and can only lower their model's objective. 0: the
    /// rounds end at the first best model that covers. By default
    /// [`DEFAULT_REFINE_MIN_ROUNDS`] (all the rounds, once started).
    pub min_rounds: u32,
}

impl Refine {
    /// No refinement: the SMC pass alone.
    pub fn off() -> Refine {
        Refine {
            rounds: 0,
            from: DEFAULT_REFINE_FROM,
            prefer_covering: false,
            followed_ends: false,
            min_rounds: 0,
        }
    }

    /// The generation the rounds restart from, for a run of `gens`
    /// generations; `None` when the run is too short to restart part-way.
    pub(crate) fn restart(&self, gens: u32) -> Option<u32> {
        if self.rounds == 0 || gens < 2 || !self.from.is_finite() {
            return None;
        }
        let g = (self.from.clamp(0.0, 1.0) * f64::from(gens)).floor() as u32;
        Some(g.clamp(1, gens - 1))
    }
}

impl Default for Refine {
    /// [`DEFAULT_REFINE_ROUNDS`] rounds from [`DEFAULT_REFINE_FROM`] of
    /// the run, all of them once started ([`DEFAULT_REFINE_MIN_ROUNDS`]),
    /// ended early by a best model that covers or follows every curve
    /// ([`Refine::followed_ends`]) only before they start.
    ///
    /// Chosen in session 27 (`docs/sampling.md` 4.5) over the session-26
    /// defaults (3 rounds, `followed_ends` off, no minimum): over 50 seeds
    /// on the bench's five scenes every median cost is as low or lower
    /// (the fork of four -23,563 against -23,524, the vine -16,018 against
    /// -16,001), every scene's share of models covering every curve as high
    /// or higher (the fork and the vine 100% against 96%), and the median
    /// model of every scene is a pass without rounds; the price is the
    /// runs that start the rounds, which run all five (the fork's mean
    /// instructions a model 1.25x, the vine's 1.65x).
    fn default() -> Self {
        Refine {
            rounds: DEFAULT_REFINE_ROUNDS,
            from: DEFAULT_REFINE_FROM,
            prefer_covering: true,
            followed_ends: true,
            min_rounds: DEFAULT_REFINE_MIN_ROUNDS,
        }
    }
}

/// Refinement rounds at most by default ([`Refine::rounds`]).
pub const DEFAULT_REFINE_ROUNDS: u32 = 5;

/// Refinement rounds at least, once started, by default
/// ([`Refine::min_rounds`]).
pub const DEFAULT_REFINE_MIN_ROUNDS: u32 = 5;

/// Where refinement rounds start by default ([`Refine::from`]).
pub const DEFAULT_REFINE_FROM: f64 = 0.0;

/// The seed of refinement round `round` (1-based) of a run seeded `seed`:
/// every draw of the round's generations is keyed by it as the first pass's
/// are by `seed`.
pub(crate) fn round_seed(seed: u32, round: u32) -> u32 {
    rng::hash(seed, u32::MAX - STREAM_REFINE, round, 0)
}

/// The draw stream of refinement rounds (after the sampler's 1-9).
const STREAM_REFINE: u32 = 10;

/// Whether `state` covers every curve of `cost` at [`FOLLOWED`] or more of
/// its utilization segments (curves without segments count as covered).
pub(crate) fn covers_every_curve(cost: &CostModel, state: &CostState) -> bool {
    (0..cost.curve_count()).all(|c| {
        let (k, n) = cost.covered_segments(state, c);
        n == 0 || k as f64 >= FOLLOWED * n as f64
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_restart_is_inside_the_run() {
        let r = Refine {
            rounds: 2,
            from: 0.5,
            ..Refine::default()
        };
        assert_eq!(r.restart(100), Some(50));
        assert_eq!(r.restart(2), Some(1));
        assert_eq!(r.restart(1), None);
        let early = Refine {
            from: 0.0,
            ..Refine::default()
        };
        assert_eq!(early.restart(30), Some(1));
        let late = Refine {
            from: 1.0,
            ..Refine::default()
        };
        assert_eq!(late.restart(30), Some(29));
        assert_eq!(Refine::off().restart(100), None);
        let nan = Refine {
            from: f64::NAN,
            ..Refine::default()
        };
        assert_eq!(nan.restart(100), None);
    }

    #[test]
    fn rounds_draw_apart() {
        assert_ne!(round_seed(7, 1), round_seed(7, 2));
        assert_ne!(round_seed(7, 1), round_seed(8, 1));
        assert_ne!(round_seed(7, 1), 7);
    }
}

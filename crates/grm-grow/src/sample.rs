//! Sample mode: a sample system grown by the guided sampler (`grm_sample`)
//! through one call, [`sample`]: the sampler prepared for the curves and
//! the objective, the search run with the caller's options (seed,
//! particle schedule, budget, cancellation, limits, threads, best K,
//! frames), the model shown picked (the result, or the model the search
//! returns when stopped after one generation: [`SampleRequest::
//! generation`]) and its derivation tree built, keyed as the sampler keyed
//! it (the run's root key for its seed).
//!
//! `grmc sample` and the language server's sample-mode preview both grow
//! through it; what they load the curves from (a file beside the grammar,
//! the request's JSON) and how they show the result is theirs.

use std::time::{Duration, Instant};

use grm_compile::CompiledSystem;
use grm_guide::Curves;
use grm_sample::{
    ExpectedOptions, Objective, SampleError, SampleOptions, SampleResult, SampledModel, Sampler,
};

use crate::Tree;

/// What to sample, and what to bring back.
#[derive(Clone, Debug)]
pub struct SampleRequest<'a> {
    /// The guiding curves.
    pub curves: &'a Curves,
    /// What the search minimizes.
    pub objective: Objective,
    /// How the expected directions (eq. 9) are estimated.
    pub expected: ExpectedOptions,
    /// The search's options (seed, schedule, budget, cancellation, limits,
    /// threads, best K, frames).
    pub options: SampleOptions,
    /// Show the model the search returns when stopped after this
    /// generation (0-based; past the last one run, the result) instead of
    /// the result: the search keeps that one frame alone
    /// (`Sampler::sample_frame`).
    pub generation: Option<u32>,
    /// Build the derivation tree of the first model shown.
    pub tree: bool,
    /// The persistent edits to replay while sampling (docs/edits.md,
    /// "Sample mode"): those of the system are replayed
    /// ([`crate::edits::sample_plan`]) and classified after the run
    /// against the first model shown ([`Sampled::edits`]); `None`: no
    /// edits (the plain sampler).
    pub edits: Option<&'a [grm_edits::Edit]>,
}

impl<'a> SampleRequest<'a> {
    /// The curve cost with `options`, the result shown, no tree.
    pub fn new(curves: &'a Curves, options: SampleOptions) -> SampleRequest<'a> {
        SampleRequest {
            curves,
            objective: Objective::Curves,
            expected: ExpectedOptions::default(),
            options,
            generation: None,
            tree: false,
            edits: None,
        }
    }
}

/// A finished search and what it shows.
#[derive(Clone, Debug)]
pub struct Sampled {
    /// The search's result (its models, generations, frames).
    pub result: SampleResult,
    /// The generation asked for ([`SampleRequest::generation`]).
    pub generation: Option<u32>,
    /// The derivation tree of the first model shown ([`SampleRequest::
    /// tree`]; `None` too when no model is shown).
    pub tree: Option<Tree>,
    /// Wall time of preparing the sampler (the expected directions
    /// included).
    pub prepare: Duration,
    /// Wall time of the expected directions (eq. 9).
    pub expected_time: Duration,
    /// The run's seed and root key (the tree's).
    pub seed: u32,
    pub root_key: u32,
    /// What became of each edit of the system ([`SampleRequest::edits`]),
    /// classified against the first model shown (none shown: every edit
    /// finds no module). `None` without edits.
    pub edits: Option<Vec<crate::edits::EditReport>>,
}

/// The models a search shows.
#[derive(Clone, Copy, Debug)]
pub enum Shown<'s> {
    /// The result's best models, lowest objective first.
    Models(&'s [SampledModel]),
    /// The model of a generation (the one asked for, or the last one run
    /// when asked past it).
    Frame(u32, &'s SampledModel),
    /// That generation's model cannot be finished (the search itself went
    /// on; its result is the one a run without a generation shows).
    FrameFailed(u32, &'s SampleError),
    /// The sampler kept no model of the generation asked for.
    NoFrame(u32),
}

impl<'s> Shown<'s> {
    /// The models shown (none when the frame failed or is missing).
    pub fn models(&self) -> &'s [SampledModel] {
        match *self {
            Shown::Models(m) => m,
            Shown::Frame(_, m) => std::slice::from_ref(m),
            Shown::FrameFailed(..) | Shown::NoFrame(_) => &[],
        }
    }
}

impl Sampled {
    /// What the search shows: the generation's frame asked for, else the
    /// result's models.
    pub fn shown(&self) -> Shown<'_> {
        match self.generation {
            Some(k) => match self.result.frame(k) {
                Some((g, Ok(m))) => Shown::Frame(g, m),
                Some((g, Err(e))) => Shown::FrameFailed(g, e),
                None => Shown::NoFrame(k),
            },
            None => Shown::Models(&self.result.models),
        }
    }

    /// The derivation tree of a model of this run (keyed by the run's
    /// root key).
    pub fn tree_of(&self, model: &SampledModel) -> Tree {
        Tree::from_sampled(model, self.seed, self.root_key)
    }
}

/// Sample `compiled` (compiled from `system`) as `request` asks. The
/// sampler's errors are its own (`SampleError`: not a sample system, the
/// curves, limits, a failing production, cancellation).
pub fn sample(
    system: &grm_sema::System,
    compiled: &CompiledSystem,
    request: &SampleRequest<'_>,
) -> Result<Sampled, SampleError> {
    let t0 = Instant::now();
    let sampler = Sampler::new(
        system,
        compiled,
        request.curves,
        request.objective,
        request.expected,
    )?;
    let mine: Vec<&grm_edits::Edit> = request
        .edits
        .unwrap_or(&[])
        .iter()
        .filter(|e| e.system == system.name)
        .collect();
    let sampler = if mine.is_empty() {
        sampler
    } else {
        sampler.with_edits(crate::edits::sample_plan(system, mine.iter().copied()))
    };
    let prepare = t0.elapsed();
    let opts = &request.options;
    // The one frame asked for, not one per generation.
    let result = match request.generation {
        Some(k) => sampler.sample_frame(opts, k)?,
        None => sampler.sample(opts)?,
    };
    let mut sampled = Sampled {
        result,
        generation: request.generation,
        tree: None,
        prepare,
        expected_time: sampler.expected_time(),
        seed: opts.seed,
        root_key: compiled.root_key(opts.seed),
        edits: None,
    };
    if request.edits.is_some() {
        let none = grm_sample::EditHits::default();
        let hits = sampled
            .shown()
            .models()
            .first()
            .and_then(|m| m.edits.as_ref())
            .unwrap_or(&none);
        sampled.edits = Some(crate::edits::classify_sampled(
            system,
            compiled,
            hits,
            mine.iter().copied(),
        ));
    }
    if request.tree {
        sampled.tree = sampled.shown().models().first().map(|m| sampled.tree_of(m));
    }
    Ok(sampled)
}

//! What the sampler returns: complete models with their derivation trees,
//! costs, and per-generation figures.

use std::ops::Range;
use std::time::Duration;

use grm_derive::ModuleString;
use grm_geom::{BuildOptions, GeomError, Model};
use grm_guide::{CostBreakdown, VolumeCost};
use grm_sema::{Program, Value};
use grm_turtle::Interpretation;

use crate::SampleError;

pub use crate::particle::NodeKind;

/// One expansion of a complete derivation tree.
#[derive(Clone, Debug, PartialEq)]
pub struct TreeNode {
    /// The node that emitted the expanded non-terminal and the
    /// non-terminal's ordinal among those the turtle met in that node's
    /// successor; `None` for the axiom.
    pub parent: Option<(u32, u32)>,
    /// The expanded module's identity key (`grm_compile::rng`, "Identity
    /// keys"): the run's root key for the axiom, else `child_key(the
    /// parent's key, the module's salt)`, as in a derivation. The model's
    /// string carries the keys of all its modules
    /// ([`SampledModel::string`]`.keys()`).
    pub key: u32,
    pub kind: NodeKind,
    /// The expanded symbol (`u32::MAX` for the axiom).
    pub symbol: u32,
    /// The compiled alternative applied; `None` when no production applied
    /// (the non-terminal stays as an inert module).
    pub alt: Option<u32>,
    /// The successor's parameter words.
    pub params: Vec<f32>,
    /// Its successor's modules in [`SampledModel::string`].
    pub modules: Range<u32>,
    /// The bones its successor made, in [`SampledModel::interpretation`].
    pub bones: Range<u32>,
}

/// A complete derivation: every expansion, in depth-first order (a node's
/// children follow it, in the order of their modules in its successor).
/// Node 0 is the axiom.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DerivationTree {
    pub nodes: Vec<TreeNode>,
    /// The modules persistent edits removed as their parent's successor
    /// was written (no nodes: nothing expands them and they are not in
    /// the string), in the order they were met: what a retarget of the
    /// edit that removed one knows of it (docs/edits.md, "Retargeting").
    pub removed: Vec<RemovedModule>,
}

/// A module a persistent edit removed ([`DerivationTree::removed`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RemovedModule {
    /// The node whose successor it was in.
    pub parent: u32,
    /// The key the edit named: `child_key(the parent's key, its salt)`.
    pub key: u32,
    pub symbol: u32,
    /// Its place among the parent's children in the tree had it stayed:
    /// how many of the parent's expanded modules come before it in the
    /// successor.
    pub sibling: u32,
}

impl DerivationTree {
    /// Expansions of each kind: (axiom, skeleton, wrap-up, geometry).
    pub fn counts(&self) -> (usize, usize, usize, usize) {
        let c = |k| self.nodes.iter().filter(|n| n.kind == k).count();
        (
            c(NodeKind::Axiom),
            c(NodeKind::Skeleton),
            c(NodeKind::Wrapup),
            c(NodeKind::Geometry),
        )
    }
}

/// A complete model: skeleton phase, wrap-up and geometry phase done.
#[derive(Clone, Debug)]
pub struct SampledModel {
    /// Its curve cost by term (eq. 8 plus density), over the skeleton
    /// bones (those made by the axiom and by skeleton and wrap-up
    /// productions).
    pub cost: CostBreakdown,
    /// The volume baseline's cost, when that was the objective.
    pub volume: Option<VolumeCost>,
    /// The objective it was ranked by: the curve cost's total plus the
    /// coverage term of [`crate::Guide::cover`] (0 with
    /// [`crate::Guide::paper`]; `cost` never includes it), or the volume
    /// cost times its weight.
    pub objective: f64,
    /// Skeleton bones scored.
    pub skeleton_bones: u32,
    /// Everything the turtle drew: all bones (skeleton and geometry),
    /// instances, polygons; `origin` fields hold the compiled alternative
    /// that made each part.
    pub interpretation: Interpretation,
    /// The expansions' successors laid end to end in tree order (each
    /// interpreted from its own non-terminal's frame); non-terminals stay
    /// in it as inert modules.
    pub string: ModuleString,
    /// Per module of `string`: the compiled alternative that produced it.
    pub origins: Vec<u32>,
    pub tree: DerivationTree,
    /// Its index among the final generation's distinct particles.
    pub candidate: usize,
    /// The meta-parameter values it was grown with (those the system was
    /// compiled with); [`SampledModel::build`] evaluates materials with them.
    pub param_values: Vec<Value>,
    /// What the persistent edits met in it ([`crate::Sampler::with_edits`]):
    /// per key with edits, the modules written with it; `None` without
    /// edits.
    pub edits: Option<crate::edits::EditHits>,
}

impl SampledModel {
    /// The bone list as `(base, tip)` pairs (all bones, in tree order).
    pub fn bone_list(&self) -> Vec<([f32; 3], [f32; 3])> {
        self.interpretation
            .bones
            .iter()
            .map(|b| (b.base.to_array(), b.tip.to_array()))
            .collect()
    }

    /// The bytes it holds on the heap (its interpretation, string,
    /// origins and tree): what a kept frame adds to
    /// [`GenerationStats::memory_bytes`].
    pub fn heap_bytes(&self) -> usize {
        fn vec<T>(v: &Vec<T>) -> usize {
            v.capacity() * std::mem::size_of::<T>()
        }
        let i = &self.interpretation;
        vec(&i.bones)
            + vec(&i.instances)
            + vec(&i.polygons)
            + vec(&i.polygon_vertices)
            + self.string.heap_bytes()
            + vec(&self.origins)
            + vec(&self.tree.nodes)
            + self
                .tree
                .nodes
                .iter()
                .map(|n| vec(&n.params))
                .sum::<usize>()
            + vec(&self.param_values)
    }

    /// Build the meshes (tubes, primitives, OBJ meshes) for export.
    pub fn build(&self, program: &Program, options: &BuildOptions) -> Result<Model, GeomError> {
        let mut model = grm_geom::build_from_interpretation(
            program,
            self.interpretation.clone(),
            options,
            &self.param_values,
        )?;
        // The string carries the expansions' identity keys: exports name
        // parts by them.
        model.module_keys = self.string.keys().to_vec();
        Ok(model)
    }
}

/// Figures of one generation of the skeleton phase.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GenerationStats {
    /// 0-based.
    pub generation: u32,
    /// Particles expanded in this generation.
    pub particles: usize,
    /// Of them, those still searching: with an open skeleton symbol that
    /// can lead to a bone or finish (not W0015's).
    pub expanding: usize,
    /// Effective sample size of the generation's weights (after
    /// tempering, the weights resampling uses), in `[1, particles]`.
    pub ess: f64,
    /// The tempering factor of the generation's incremental log-weights
    /// (1: untempered; `SampleOptions::ess_target`).
    pub beta: f64,
    /// Distinct particles of this generation that resampling kept (each
    /// the ancestor of one or more particles of the next generation); for
    /// the last generation, its distinct particles (those wrapped up). With
    /// Calder's untempered weights it is 1 to 3: a population collapse.
    pub survivors: usize,
    /// `HEURISTICSCALE` used.
    pub heuristic_scale: f64,
    /// The lowest objective (without heuristic) among the particles.
    pub best_objective: f64,
    /// Mean skeleton bones per particle.
    pub mean_bones: f64,
    /// Expansions made in this generation (all particles).
    pub expansions: u64,
    /// Bytes the search holds after the generation: the arena of every
    /// expansion the kept particles descend from, the recycled buffers,
    /// and the kept particles' own state, and the frames kept so far
    /// ([`crate::SampleOptions::frames`]; what
    /// [`crate::SampleOptions::max_bytes`] bounds).
    pub memory_bytes: u64,
}

/// The result of [`crate::Sampler::sample`].
#[derive(Clone, Debug)]
pub struct SampleResult {
    /// The best models, lowest objective first (at most
    /// [`crate::SampleOptions::best`]).
    pub models: Vec<SampledModel>,
    /// One entry per generation run (the search's, not those of
    /// refinement rounds).
    pub generations: Vec<GenerationStats>,
    /// The objective of every distinct final particle after wrap-up, in
    /// particle order (the models were the lowest of these), then those of
    /// each refinement round's final particles.
    pub candidates: Vec<f64>,
    /// Whether the wall-clock budget stopped the skeleton phase early.
    pub stopped_early: bool,
    /// Refinement rounds run after the search ([`crate::Refine`]): 0 when
    /// its best model covered every curve, or refinement was off. Only
    /// rounds that ran to their end count: one the wall-clock budget
    /// stopped part-way is dropped.
    pub refinements: u32,
    /// Wall time of the whole run (search, wrap-up, geometry phase).
    pub elapsed: Duration,
    /// With [`crate::SampleOptions::frames`] (or
    /// [`crate::Sampler::sample_frame`]): the frames
    /// kept, in generation order, each with its generation (0-based): the
    /// model this run returns when its budget stops it after that
    /// generation, or the error that such a run would end with (a wrap-up
    /// or geometry-phase limit, or a production that fails on that
    /// generation's particles alone: the search goes on, and the run's own
    /// result may well be fine). The last generation's frame is the best
    /// model. Empty otherwise.
    pub frames: Vec<(u32, Result<SampledModel, SampleError>)>,
}

impl SampleResult {
    /// The best model.
    pub fn best(&self) -> Option<&SampledModel> {
        self.models.first()
    }

    /// The frame kept for generation `generation` (0-based), or past the
    /// last generation run, the last one (the result's): its generation
    /// and its model (or why it could not be finished). `None` when that
    /// frame was not kept ([`crate::SampleOptions::frames`],
    /// [`crate::Sampler::sample_frame`]).
    pub fn frame(&self, generation: u32) -> Option<(u32, &Result<SampledModel, SampleError>)> {
        let last = self.generations.len().checked_sub(1)? as u32;
        let g = generation.min(last);
        self.frames
            .iter()
            .find(|(k, _)| *k == g)
            .map(|(k, m)| (*k, m))
    }

    /// Effective sample sizes, one per generation.
    pub fn ess(&self) -> Vec<f64> {
        self.generations.iter().map(|g| g.ess).collect()
    }
}

/// Limits of the wrap-up and geometry phases.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FinishLimits {
    /// Geometry symbols nested deeper than this (a geometry expansion
    /// inside a geometry expansion, ...) are an error.
    pub max_depth: u32,
    /// More geometry expansions than this in one model are an error.
    pub max_expansions: u64,
}

impl Default for FinishLimits {
    /// Depth 4096, one million expansions.
    fn default() -> Self {
        FinishLimits {
            max_depth: 4096,
            max_expansions: 1_000_000,
        }
    }
}

//! Particles: partial derivations as structurally shared expansion nodes.
//!
//! A particle is the head of a singly linked list of [`Node`]s, one per
//! expansion, newest first (Calder section 4.1: each new piece points to
//! the piece added before it). A node records which open non-terminal it
//! expanded (the node that emitted it and its position there), the
//! production applied, the successor's parameter words and the frames of
//! the skeleton non-terminals it emitted. Expanding a particle adds one
//! node that points to the old head: nothing of the ancestors is copied,
//! and all particles descended from one ancestor share its nodes.
//!
//! Nodes live in an arena of [`Step`]s: the nodes one particle made in one
//! generation (or the axiom, or one candidate's wrap-up), with their
//! parameter words and spawns in flat vectors. A [`NodeId`] names (layer,
//! step, index); layers are generations, append-only and immutable once
//! their generation is done, so a lookup is two indexings, the parallel
//! steps of a generation each fill their own step, and the run frees the
//! whole tree at once at its end. The arena keeps every node made during
//! the run (a few hundred bytes each), including those of particles that
//! were not resampled.
//!
//! The open skeleton non-terminals are a persistent vector
//! ([`crate::pvec::PVec`]) of `Copy` references `(node, spawn)`: removing
//! the expanded one and adding the new ones copies O(log n) small tree
//! nodes. The cost state ([`grm_guide::CostState`]: a few hundred bytes of
//! segment counters) is the only part cloned per step.

use grm_guide::{CostState, VolumeState};
use grm_turtle::Turtle;

use crate::pvec::PVec;

/// `Node::alt` of an expansion where no production applied: the
/// non-terminal stays in the model as an inert module.
pub(crate) const INERT: u32 = u32::MAX;

/// `Node::parent` of the root (the axiom).
pub(crate) const ROOT: (u32, u32) = (u32::MAX, u32::MAX);

/// What kind of expansion a node is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum NodeKind {
    /// The axiom (the root of every derivation).
    Axiom,
    /// A skeleton symbol expanded during the search.
    Skeleton,
    /// A skeleton symbol closed by its wrap-up production.
    Wrapup,
    /// A geometry symbol expanded in the geometry phase.
    Geometry,
}

/// A skeleton non-terminal emitted by an expansion: what is needed to
/// expand it later, in its own frame.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Spawn {
    /// Its index among the non-terminals the turtle met in the successor
    /// (the `on_user` calls of `Interpreter::run_range`, in order).
    pub ordinal: u32,
    pub symbol: u32,
    /// Its module offset in the successor (for its parameters).
    pub module: u32,
    /// The turtle state at the module: where its expansion starts.
    pub turtle: Turtle,
    /// Its unscaled heuristic term (eq. 10), in fixed point; 0 when not
    /// computed.
    pub h: i64,
    /// Eq. 1 at its position (the curve nearest to it and the closest
    /// point), computed once when it was emitted: the base of the bones
    /// its expansion draws from that position (every copy of the particle
    /// shares it). `None` at a non-finite position.
    pub near: Option<Near>,
    /// Persistent edits (`crate::edits`; all 0 without a plan): its
    /// identity key, its scope (what it inherits from edited ancestors)
    /// and the alternative (from 1) forced on it, or 0.
    pub key: u32,
    pub scope: u32,
    pub force: u32,
}

/// The guiding curve nearest to a position (eq. 1) and the closest point
/// on it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Near {
    pub position: glam::Vec3,
    pub curve: usize,
    pub closest: grm_guide::ClosestPoint,
}

/// Where a node is in the arena: `layers[layer][step].nodes[k]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) struct NodeId {
    pub layer: u32,
    pub step: u32,
    pub k: u32,
}

/// One expansion.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Node {
    /// The expansion before this one in the particle's history.
    pub prev: Option<NodeId>,
    /// How many expansions come before it (0 for the axiom).
    pub seq: u32,
    /// The `seq` of the node that emitted the expanded non-terminal (an
    /// ancestor in the same history) and the spawn's ordinal there;
    /// [`ROOT`] for the axiom.
    pub parent: (u32, u32),
    /// The expanded non-terminal (`u32::MAX` for the axiom).
    pub symbol: u32,
    pub kind: NodeKind,
    /// The compiled alternative applied, or [`INERT`].
    pub alt: u32,
    /// Its successor's parameter words: `Step::params[params.0 .. params.1]`.
    pub params: (u32, u32),
    /// The skeleton non-terminals it emitted: `Step::spawns[spawns.0 .. spawns.1]`.
    pub spawns: (u32, u32),
}

/// The nodes one particle made in one generation (or the axiom, or one
/// wrap-up), with their parameter words and spawns.
#[derive(Clone, Debug, Default)]
pub(crate) struct Step {
    pub nodes: Vec<Node>,
    pub params: Vec<f32>,
    pub spawns: Vec<Spawn>,
}

impl Step {
    /// Bytes its buffers hold (capacities: a recycled step keeps them).
    pub fn bytes(&self) -> usize {
        self.nodes.capacity() * std::mem::size_of::<Node>()
            + self.params.capacity() * std::mem::size_of::<f32>()
            + self.spawns.capacity() * std::mem::size_of::<Spawn>()
    }

    /// Empty it, keeping its buffers.
    pub fn clear(&mut self) {
        self.nodes.clear();
        self.params.clear();
        self.spawns.clear();
    }

    pub fn params(&self, n: &Node) -> &[f32] {
        self.params
            .get(n.params.0 as usize..n.params.1 as usize)
            .unwrap_or(&[])
    }

    pub fn spawns(&self, n: &Node) -> &[Spawn] {
        self.spawns
            .get(n.spawns.0 as usize..n.spawns.1 as usize)
            .unwrap_or(&[])
    }
}

/// Read access to the arena: finished layers plus the step being built
/// (`local`, which is `layers[cur.0][cur.1]` once done).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Arena<'a> {
    pub layers: &'a [Vec<Step>],
    pub local: &'a Step,
    pub cur: (u32, u32),
}

impl<'a> Arena<'a> {
    /// The step holding node `id`, and the node.
    pub fn get(&self, id: NodeId) -> Option<(&'a Step, &'a Node)> {
        let step = if (id.layer, id.step) == self.cur {
            self.local
        } else {
            self.layers.get(id.layer as usize)?.get(id.step as usize)?
        };
        Some((step, step.nodes.get(id.k as usize)?))
    }
}

/// An open skeleton non-terminal: spawn `spawn` of node `node`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct OpenRef {
    pub node: NodeId,
    pub spawn: u32,
}

/// A partial (or complete) derivation and its running cost.
#[derive(Clone, Debug)]
pub(crate) struct Particle {
    pub head: NodeId,
    /// The head's `seq`.
    pub seq: u32,
    pub open: PVec<OpenRef>,
    /// The curve cost (always kept: it is what the output reports).
    pub cost: CostState,
    /// The volume baseline's state, when that is the objective.
    pub volume: Option<VolumeState>,
    /// Sum of the open spawns' heuristic terms (fixed point).
    pub heuristic: i128,
    /// The score at the generation it was last weighed:
    /// `objective + HEURISTICSCALE * heuristic`.
    pub score: f64,
    /// Skeleton bones scored so far.
    pub bones: u32,
    /// Open symbols that can still lead to a bone or finish (not
    /// `Grammar::dead`); at 0 the particle's search is over and wrap-up
    /// closes what is open.
    pub live: u32,
}

impl Particle {
    /// Bytes this particle owns beyond what it shares with its ancestors:
    /// itself, its cost states and the path of its open list its last
    /// step copied (the memory accounting of `SampleOptions::max_bytes`).
    pub fn own_bytes(&self) -> usize {
        std::mem::size_of::<Particle>()
            + self.cost.heap_bytes()
            + self.volume.as_ref().map_or(0, |v| v.heap_bytes())
            + self.open.path_bytes()
    }
    /// The nodes of its history with their steps, oldest (the axiom)
    /// first: `out[i].1.seq == i`.
    pub fn chain<'a>(&self, layers: &'a [Vec<Step>]) -> Vec<(&'a Step, &'a Node)> {
        let arena = Arena {
            layers,
            local: &EMPTY_STEP,
            cur: (u32::MAX, u32::MAX),
        };
        let mut out = Vec::with_capacity(self.seq as usize + 1);
        let mut id = Some(self.head);
        while let Some(x) = id.and_then(|i| arena.get(i)) {
            out.push(x);
            id = x.1.prev;
        }
        out.reverse();
        out
    }
}

static EMPTY_STEP: Step = Step {
    nodes: Vec::new(),
    params: Vec::new(),
    spawns: Vec::new(),
};

/// Fixed-point scale of heuristic terms (2^-20: exact sums, so the sum
/// over open symbols does not depend on the order they were opened and
/// closed).
const FIXED_ONE: f64 = 1_048_576.0;

/// A heuristic term in fixed point (clamped to +-1e12, which fits an i64).
pub(crate) fn to_fixed(x: f64) -> i64 {
    let x = x.clamp(-1e12, 1e12);
    if x.is_nan() {
        0
    } else {
        (x * FIXED_ONE).round() as i64
    }
}

pub(crate) fn from_fixed(x: i128) -> f64 {
    x as f64 / FIXED_ONE
}

//! Particles: partial derivations as structurally shared expansion nodes.
//!
//! A particle is the head of a singly linked list of [`Node`]s, one per
//! expansion, newest first (Calder section 4.1: each new piece points to
//! the piece added before it). A node records which open non-terminal it
//! expanded (the node that emitted it and its position there), the
//! production applied, the successor's parameter words and the frames of
//! the skeleton non-terminals it emitted. Expanding a particle allocates
//! one node and links it to the old head: nothing of the ancestors is
//! copied, and all particles descended from one ancestor share its nodes.
//!
//! The open skeleton non-terminals are a persistent vector
//! ([`crate::pvec::PVec`]) of references `(node, spawn)`: removing the
//! expanded one and adding the new ones copies O(log n) small tree nodes.
//! The cost state ([`grm_guide::CostState`]: a few hundred bytes of
//! segment counters) is the only part cloned per expansion.

use std::sync::Arc;

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
    pub h: i128,
}

/// One expansion.
#[derive(Debug)]
pub(crate) struct Node {
    /// The expansion before this one in the particle's history.
    pub prev: Option<Arc<Node>>,
    /// How many expansions come before it (0 for the axiom).
    pub seq: u32,
    /// The node that emitted the expanded non-terminal and the spawn's
    /// ordinal there; [`ROOT`] for the axiom.
    pub parent: (u32, u32),
    /// The expanded non-terminal (`u32::MAX` for the axiom).
    pub symbol: u32,
    pub kind: NodeKind,
    /// The compiled alternative applied, or [`INERT`].
    pub alt: u32,
    /// The successor's parameter words.
    pub params: Box<[f32]>,
    /// The skeleton non-terminals it emitted.
    pub spawns: Box<[Spawn]>,
}

impl Drop for Node {
    /// Drop a long history iteratively (a recursive drop of a list of
    /// thousands of nodes could overflow the stack).
    fn drop(&mut self) {
        let mut next = self.prev.take();
        while let Some(arc) = next {
            match Arc::try_unwrap(arc) {
                Ok(mut node) => next = node.prev.take(),
                Err(_) => break,
            }
        }
    }
}

/// An open skeleton non-terminal: spawn `spawn` of `node`.
#[derive(Clone, Debug)]
pub(crate) struct OpenRef {
    pub node: Arc<Node>,
    pub spawn: u32,
}

impl OpenRef {
    pub fn spawn(&self) -> &Spawn {
        &self.node.spawns[self.spawn as usize]
    }
}

/// A partial (or complete) derivation and its running cost.
#[derive(Clone, Debug)]
pub(crate) struct Particle {
    pub head: Arc<Node>,
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
}

impl Particle {
    /// The nodes of its history, oldest (the axiom) first; `nodes[i].seq == i`.
    pub fn chain(&self) -> Vec<&Node> {
        let mut out = Vec::with_capacity(self.head.seq as usize + 1);
        let mut n = Some(&*self.head);
        while let Some(x) = n {
            out.push(x);
            n = x.prev.as_deref();
        }
        out.reverse();
        out
    }
}

/// Fixed-point scale of heuristic sums (exact, so the sum over open
/// symbols does not depend on the order they were opened and closed).
const FIXED_ONE: f64 = 4_294_967_296.0;

pub(crate) fn to_fixed(x: f64) -> i128 {
    let x = x.clamp(-1e12, 1e12);
    if x.is_nan() {
        0
    } else {
        (x * FIXED_ONE).round() as i128
    }
}

pub(crate) fn from_fixed(x: i128) -> f64 {
    x as f64 / FIXED_ONE
}

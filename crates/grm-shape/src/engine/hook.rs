//! The derivation loop's replay hook (`crate::replay`): `()` for the plain
//! loop, [`Replay`] for a plan's edits: the forced regions, the trie
//! states of the shapes on an exact target's path, and the work on a
//! shape some edit names.

use super::*;

/// The derivation loop's replay hook: `()` replays nothing (every call
/// inlines to nothing, so the plain derivation is the loop without
/// edits), [`Replay`] a plan's edits.
pub(super) trait Hook<'p> {
    /// The bit of a derivation stack entry that says the shape has an
    /// entry on the replay's stack (0: no replay).
    const FLAG: u32;
    /// The replay state, if any.
    fn get(&mut self) -> Option<&mut Replay<'p>>;
}

/// [`Hook::FLAG`] of a replay.
pub(super) const FLAGGED: u32 = 1 << 31;

/// The derivation stack entry below a forced region's shapes: popped, the
/// region is left (`Replay::leave`). Flagged, so the loop's one test of
/// the flag finds it; its index is none (the job's nodes are fewer than
/// `FLAGGED - 3`).
pub(super) const LEAVE: u32 = u32::MAX;

/// The derivation stack entries around a run of quiet shapes (ones no
/// query can name, nor any shape below them:
/// `EditPlan::quiet_children`): `QBEGIN` above them, popped first, enters
/// their quiet subtrees (only key targets are looked for there), `QEND`
/// below them, popped when the last subtree is done, leaves them.
/// Flagged, as [`LEAVE`]: one test of the flag finds all three.
pub(super) const QEND: u32 = u32::MAX - 1;
pub(super) const QBEGIN: u32 = u32::MAX - 2;

impl<'p> Hook<'p> for () {
    const FLAG: u32 = 0;
    #[inline(always)]
    fn get(&mut self) -> Option<&mut Replay<'p>> {
        None
    }
}

impl<'p> Hook<'p> for Replay<'p> {
    const FLAG: u32 = FLAGGED;
    #[inline(always)]
    fn get(&mut self) -> Option<&mut Replay<'p>> {
        Some(self)
    }
}

/// The derivation loop's replay state (a job's).
pub(super) struct Replay<'p> {
    /// The edits replayed.
    pub(super) plan: &'p EditPlan,
    /// The trie states of the shapes on the derivation stack that are on
    /// an exact target's path (flagged there), in step with it; the
    /// shapes off every path have none.
    pub(super) stack: Vec<u32>,
    /// The forced regions' forcing, innermost last: where a shape's own
    /// edits force a material or mesh, its subtree's shapes are those
    /// pushed on the derivation stack above the [`LEAVE`] entry its block
    /// put below them; popping that entry leaves the region. The first is
    /// the job root's forcing (never left).
    pub(super) regions: Vec<Forced>,
    /// The innermost region's forcing, and whether it forces a mesh
    /// (every block in it then has its inserts replaced).
    pub(super) forced: Forced,
    pub(super) meshed: bool,
    /// Per symbol, whether a shape off the exact targets' paths is looked
    /// at (`EditPlan::attention`: by query, by key, or every shape in a
    /// forced mesh's region); empty when none is.
    pub(super) attend: &'p [u8],
    /// Whether the shape at hand is in a quiet subtree (between a
    /// [`QBEGIN`] and its [`QEND`]).
    pub(super) quiet: bool,
    /// Whether the own edits of the shape at hand changed its forcing
    /// (`Engine::own_edits`: its block opens a forced region), and the
    /// forcing then (else it is the region's, `forced`).
    pub(super) opens: bool,
    pub(super) opened: Forced,
    /// Scratch: the trie states of the block at hand, from its start, and
    /// its ordinals counted (`EditPlan::block_states`).
    pub(super) block: Vec<u32>,
    pub(super) counts: Vec<(usize, replay::Label, u32)>,
    /// Scratch: the edits of the shape at hand, the tags on its path, the
    /// indices a query pattern reads there.
    pub(super) matched: Vec<(u32, replay::Action)>,
    pub(super) path: replay::PathScratch,
    /// Scratch of [`hand_down`]: the quiet scratch, each pushed shape's
    /// answer, the pushed entries.
    pub(super) quiet_scratch: replay::QuietScratch,
    pub(super) quiet_out: Vec<bool>,
    pub(super) pushed: Vec<u32>,
    /// Forced materials remembered: (attributes, material, result).
    pub(super) memo: Vec<(AttrId, crate::ir::MaterialId, AttrId)>,
}

impl<'p> Replay<'p> {
    /// Whether the shape of `symbol` with key `key`, off every exact
    /// target's path, is looked at (`EditPlan::attention`): most shapes
    /// cost one load and a test.
    #[inline(always)]
    pub(super) fn attends(&self, symbol: SymbolId, key: u32) -> bool {
        match self.attend.get(symbol.0 as usize) {
            Some(&a) if a != 0 => a & replay::ATTEND != 0 || self.plan.key_bit(key),
            _ => false,
        }
    }

    /// The state of a job whose root's replay state is `root`.
    pub(super) fn new(plan: &'p EditPlan, root: Carried) -> Replay<'p> {
        Replay {
            plan,
            stack: vec![root.state],
            regions: vec![root.forced],
            forced: root.forced,
            meshed: root.forced.mesh.is_some(),
            attend: plan.attention(root.forced.mesh.is_some(), false),
            quiet: false,
            opens: false,
            opened: root.forced,
            block: Vec::new(),
            counts: Vec::new(),
            matched: Vec::new(),
            path: replay::PathScratch::default(),
            quiet_scratch: replay::QuietScratch::default(),
            quiet_out: Vec::new(),
            pushed: Vec::new(),
            memo: Vec::new(),
        }
    }

    /// The innermost region's [`LEAVE`] entry was popped: its shapes are
    /// done, leave it.
    #[cold]
    #[inline(never)]
    pub(super) fn leave(&mut self) {
        if self.regions.len() > 1 {
            self.regions.pop();
        }
        self.forced = self.regions.last().copied().unwrap_or_default();
        self.meshed = self.forced.mesh.is_some();
        self.attend = self.plan.attention(self.meshed, self.quiet);
    }

    /// A quiet subtree's [`QBEGIN`] (`true`) or [`QEND`] (`false`) was
    /// popped.
    #[cold]
    #[inline(never)]
    pub(super) fn set_quiet(&mut self, quiet: bool) {
        self.quiet = quiet;
        self.attend = self.plan.attention(self.meshed, quiet);
    }

    /// Open a forced region (`forced`) for the shapes pushed on the
    /// derivation stack last (above its [`LEAVE`] entry).
    fn open(&mut self, forced: Forced) {
        self.regions.push(forced);
        self.forced = forced;
        self.meshed = forced.mesh.is_some();
        self.attend = self.plan.attention(self.meshed, self.quiet);
    }
}

/// A shape's replay state, carried down from its parent's.
#[derive(Clone, Copy)]
pub(super) struct Carried {
    /// Its state in the exact targets' trie (`replay::NONE`: off every
    /// target's path, and so is its subtree).
    pub(super) state: u32,
    /// What its ancestors' edits force on it.
    pub(super) forced: Forced,
}

/// After the shape at `at` (trie state `state`; its forcing, its own
/// edits' over its ancestors', is `r.opened` where those force anything,
/// `r.opens`, else the region's) made the block `nodes[start..]`, whose
/// shapes the derivation stack took last (`stack[before..]`, last first),
/// when the block needs anything of the replay: the forced mesh on the
/// block's inserts; a forced region for its shapes where the shape's own
/// edits force (a [`LEAVE`] entry put below them); on a target's path,
/// each shape's trie state, and those still on a path flagged. A forced
/// material needs nothing more: the shape's attributes carry it to the
/// block and its rules' materials were skipped. Off every path, a shape is
/// matched only when a key target or a query may name it
/// (`Replay::attends`, asked when it is popped).
#[inline(never)]
pub(super) fn replay_block(
    r: &mut Replay,
    nodes: &mut [Node],
    at: u32,
    start: usize,
    stack: &mut Vec<u32>,
    before: usize,
    state: u32,
) {
    let opens = r.opens;
    let forced = if opens { r.opened } else { r.forced };
    let block = &mut nodes[start..];
    if let Some(a) = forced.mesh {
        for n in block.iter_mut() {
            if let NodeKind::Insert { .. } = n.kind {
                n.kind = NodeKind::Insert { asset: a };
            }
        }
    }
    if stack.len() == before {
        return;
    }
    if state != replay::NONE {
        // Each node's state from its parent's (the shape or a command of
        // the block before it).
        let plan = r.plan;
        plan.block_states(
            block,
            start,
            at as usize,
            state,
            &mut r.block,
            &mut r.counts,
        );
        for e in stack[before..].iter_mut() {
            // A quiet shape's markers ([`hand_down`]).
            if *e >= QBEGIN {
                continue;
            }
            let state = r.block[*e as usize - start];
            if state != replay::NONE {
                *e |= FLAGGED;
                r.stack.push(state);
            }
        }
    }
    if opens {
        stack.insert(before, LEAVE);
        r.open(forced);
    }
}

/// After the shape at `at` made the block `nodes[start..]`, whose shapes
/// the derivation stack took last (`stack[before..]`), where its rule
/// makes a command of a tag some query names: each of those shapes no
/// query can name, nor any shape below it (`EditPlan::quiet_children`),
/// put between a [`QBEGIN`] and a [`QEND`] (one pair for a run of them),
/// so its subtree's shapes skip
/// the queries (a window in a column no query wants costs no walk up its
/// path). `prefix`: the tagged commands above the job's root.
#[inline(never)]
pub(super) fn hand_down(
    r: &mut Replay,
    nodes: &[Node],
    at: u32,
    start: usize,
    stack: &mut Vec<u32>,
    before: usize,
    prefix: &[(crate::ir::TagId, u32, u32)],
) {
    if stack.len() == before {
        return;
    }
    r.quiet_out.clear();
    r.plan.quiet_children(
        nodes,
        at as usize,
        start,
        prefix,
        stack[before..].iter().map(|&e| e as usize),
        &mut r.quiet_scratch,
        &mut r.quiet_out,
    );
    if !r.quiet_out.contains(&true) {
        return;
    }
    r.pushed.clear();
    r.pushed.extend(stack.drain(before..));
    // A run of quiet shapes shares one pair of markers: nothing between
    // them changes the quietness (no shape in a quiet subtree hands down,
    // so no marker is pushed there), and a floor's hundred tiles, most of
    // them quiet, cost a pair instead of a hundred.
    let mut run = false;
    for (&e, &quiet) in r.pushed.iter().zip(&r.quiet_out) {
        if quiet != run {
            stack.push(if quiet { QEND } else { QBEGIN });
            run = quiet;
        }
        stack.push(e);
    }
    if run {
        stack.push(QBEGIN);
    }
}

impl Engine<'_> {
    /// The shape `job.nodes[at]` (of `symbol`, trie state `state`) with
    /// the replay's work (`Engine::own_edits`): its own edits applied,
    /// then its rule run ([`Engine::rule_run`]), then its block's replay
    /// state ([`replay_block`]) where it needs one. Out of the loop: most
    /// shapes have no part in the replay.
    #[allow(clippy::too_many_arguments)]
    #[inline(never)]
    pub(super) fn replayed(
        &self,
        r: &mut Replay,
        job: &mut Job,
        at: u32,
        symbol: SymbolId,
        state: u32,
        budget: usize,
        scratch: &mut Scratch,
        stack: &mut Vec<u32>,
    ) -> Result<(), Overflow> {
        let Some(special) = self.own_edits(r, job, at, state, scratch) else {
            return Ok(());
        };
        let start = job.nodes.len();
        let before = self.rule_run(job, at, symbol, budget, scratch, stack)?;
        if !r.quiet && r.plan.hands_down(symbol) {
            hand_down(
                r,
                &job.nodes,
                at,
                start,
                stack,
                before,
                &scratch.prefix.tags,
            );
        }
        if special {
            replay_block(r, &mut job.nodes, at, start, stack, before, state);
            scratch.force = None;
            scratch.keep_material = r.forced.material.is_some();
        }
        Ok(())
    }

    /// The edits whose target is the shape `job.nodes[at]` (trie state
    /// `state`), resolved and applied to the shape: its hits recorded;
    /// `None` when one removes it (recorded in `job.removed`); else a
    /// forced material set on its attributes (its subtree inherits them,
    /// the rules' materials below are skipped: `Scratch::keep_material`),
    /// a pin on its key and a forced alternative in `s.force`, and where
    /// its own edits change its forcing (its block opens a forced region)
    /// that forcing in `r.opened` (`r.opens`). `None` when removed, else
    /// whether the shape's block needs [`replay_block`] (on a target's
    /// path, a region opened or a forced mesh) or the scratch's forcing
    /// reset after its rule run (a forced alternative): most shapes a key
    /// or query may name need neither.
    #[inline(always)]
    pub(super) fn own_edits(
        &self,
        r: &mut Replay,
        job: &mut Job,
        at: u32,
        state: u32,
        s: &mut Scratch,
    ) -> Option<bool> {
        let here = at as usize;
        r.matched.clear();
        r.plan.matches(
            &job.nodes,
            here,
            state,
            &s.prefix.tags,
            &mut r.path,
            &mut r.matched,
        );
        r.opens = false;
        if r.matched.is_empty() {
            return Some(state != replay::NONE || r.meshed);
        }
        job.hits.extend(r.matched.iter().map(|&(id, _)| (id, at)));
        let own = Own::of(&r.matched);
        r.matched.clear();
        if own.remove {
            job.removed.push(at);
            return None;
        }
        if let Some(m) = own.material {
            match self.forced_material(r, job.nodes[here].attrs, m) {
                Ok(a) => job.nodes[here].attrs = a,
                Err(e) => job.failures.push((at, e)),
            }
        }
        if let Some(k) = own.pin {
            job.nodes[here].key = k;
        }
        s.force = own.force;
        let opens = own.material.is_some() || own.mesh.is_some();
        if opens {
            let mut forced = r.forced;
            forced.material = own.material.or(forced.material);
            forced.mesh = own.mesh.or(forced.mesh);
            s.keep_material = forced.material.is_some();
            r.opened = forced;
            r.opens = true;
        }
        Some(opens || own.force.is_some() || state != replay::NONE || r.meshed)
    }

    /// The attributes `attrs` with material `m` forced by an edit,
    /// remembered (a forced floor's hundreds of parts share a few sets).
    fn forced_material(
        &self,
        r: &mut Replay,
        attrs: AttrId,
        m: crate::ir::MaterialId,
    ) -> Result<AttrId, ShapeError> {
        if let Some(&(_, _, a)) = r.memo.iter().find(|e| e.0 == attrs && e.1 == m) {
            return Ok(a);
        }
        let a = self.set_attribute(&Op::Material(m), None, attrs)?;
        if r.memo.len() >= 16 {
            r.memo.remove(0);
        }
        r.memo.push((attrs, m, a));
        Ok(a)
    }
}

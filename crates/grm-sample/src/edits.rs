//! Persistent edits replayed while the sampler grows (docs/edits.md,
//! "Sample mode"; Lipp, 3.1-3.3).
//!
//! An [`EditPlan`] holds, per identity key, what the artist changed on
//! the module with that key (as derive mode's `grm_derive::EditPlan`,
//! whose [`EditAction`], [`ValueOp`] and [`SlotTarget`] it takes): remove
//! it and its subtree, set or offset a parameter (of it and of every
//! module of its subtree that has it), force its production's
//! alternative, pin its key. `grm_grow` resolves the edits file to it.
//!
//! The sampler ([`crate::Sampler::with_edits`]) mints every module's key
//! as it writes a successor (the key the model's tree gives it:
//! `rng::child_key` of the expanded module's key and the successor
//! module's salt) and looks it up here; what a module inherits from its
//! edited ancestors (the values in force, whether its draws are pinned)
//! is its **scope**, a small number interned in [`Replay`], carried by
//! the open symbol ([`crate::particle::Spawn`]) with its key and its own
//! forced alternative. Without a plan none of this runs (the sampler's
//! `replay` is `None`).
//!
//! Determinism: a scope's number depends on which thread interned it
//! first, but nothing is decided by the number, only by what it holds
//! (the values and the pinned flag), which depend on the module's
//! ancestry alone: the model is the same for any thread count.

use std::collections::HashMap;
use std::sync::RwLock;

pub use grm_derive::{EditAction, KeyEdits, KeyHits, KeyPlan, SlotTarget, ValueOp};

/// The bit of a scope number that pins the draws of the module and of
/// its subtree to their keys.
pub(crate) const PINNED: u32 = 1 << 31;

/// The persistent edits of one sampled derivation, by identity key.
#[derive(Clone, Debug)]
pub struct EditPlan {
    nodes: Vec<KeyEdits>,
    index: HashMap<u32, u32>,
    /// A bit per value of a key's low 16 bits: a key whose bit is clear
    /// has no edits (one test before the map).
    filter: Vec<u64>,
    /// Per slot, per symbol: where the slot's parameter is.
    slots: Vec<Vec<SlotTarget>>,
}

impl Default for EditPlan {
    fn default() -> EditPlan {
        EditPlan::new()
    }
}

impl EditPlan {
    /// A plan without edits.
    pub fn new() -> EditPlan {
        EditPlan {
            nodes: Vec::new(),
            index: HashMap::new(),
            filter: vec![0; 1024],
            slots: Vec::new(),
        }
    }

    /// A value slot (one parameter name): per symbol id, where that
    /// parameter is (`words == 0` where the symbol has none). Returns the
    /// slot's number for [`EditAction::Value`].
    pub fn add_slot(&mut self, per_symbol: Vec<SlotTarget>) -> u32 {
        self.slots.push(per_symbol);
        (self.slots.len() - 1) as u32
    }

    /// Count the modules made with `key` ([`EditHits::hits`]) without
    /// editing them: for edits the sampler does not replay, whose targets
    /// are still classified.
    pub fn watch(&mut self, key: u32) {
        self.node(key);
    }

    fn node(&mut self, key: u32) -> usize {
        if let Some(&n) = self.index.get(&key) {
            return n as usize;
        }
        self.index.insert(key, self.nodes.len() as u32);
        self.nodes.push(KeyEdits::new(key));
        let b = (key & 0xffff) as usize;
        self.filter[b / 64] |= 1 << (b % 64);
        self.nodes.len() - 1
    }

    /// Add edit `id` of the module with `key`. Of two edits of one key in
    /// one slot the larger id wins, whatever the order they are added in.
    pub fn add(&mut self, key: u32, id: u32, action: EditAction) {
        let n = self.node(key);
        self.nodes[n].merge(id, action);
    }

    /// The module with `key` is one of symbol `symbol` only
    /// (`grm_derive::KeyEdits::symbol`).
    pub fn restrict(&mut self, key: u32, symbol: u32) {
        let n = self.node(key);
        self.nodes[n].symbol = Some(symbol);
    }

    /// Whether the plan has no edits (nor watched keys).
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// The number of keys with edits.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// The plan node of `key`, if it has edits.
    #[inline]
    fn lookup(&self, key: u32) -> Option<u32> {
        let b = (key & 0xffff) as usize;
        if self.filter[b / 64] & (1 << (b % 64)) == 0 {
            return None;
        }
        self.index.get(&key).copied()
    }
}

impl KeyPlan for EditPlan {
    fn add_slot(&mut self, per_symbol: Vec<SlotTarget>) -> u32 {
        EditPlan::add_slot(self, per_symbol)
    }
    fn watch(&mut self, key: u32) {
        EditPlan::watch(self, key);
    }
    fn add(&mut self, key: u32, id: u32, action: EditAction) {
        EditPlan::add(self, key, id, action);
    }
    fn restrict(&mut self, key: u32, symbol: u32) {
        EditPlan::restrict(self, key, symbol);
    }
}

/// What the edits met in a sampled model: per key with edits, how many
/// modules of the model were made with it and the symbol of the first
/// (counted as the model is built, removed modules included).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct EditHits {
    hits: HashMap<u32, KeyHits>,
}

impl EditHits {
    /// The modules made with `key`; `None` when none was (or the key has
    /// no edits).
    pub fn hits(&self, key: u32) -> Option<KeyHits> {
        self.hits.get(&key).copied()
    }
}

/// One value a scope holds: (slot, set or offset, the number's bits).
type ScopeValue = (u32, bool, u32);

/// The scopes interned by a run (see the module doc): scope 0 holds
/// nothing.
#[derive(Debug)]
struct Scopes {
    values: Vec<Vec<ScopeValue>>,
    by_values: HashMap<Vec<ScopeValue>, u32>,
    /// (parent scope without [`PINNED`], plan node) -> scope without
    /// [`PINNED`].
    composed: HashMap<(u32, u32), u32>,
}

/// A plan being replayed by a sampler: the plan and its scopes.
#[derive(Debug)]
pub(crate) struct Replay {
    pub plan: EditPlan,
    scopes: RwLock<Scopes>,
}

/// What the sampler knows of one successor module while it writes it.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Succ {
    /// Its key (the pinned one where a `pin` edit gives it one).
    pub key: u32,
    /// What it inherits and passes down (with [`PINNED`]).
    pub scope: u32,
    /// The alternative (from 1) forced on its own production, or 0.
    pub force: u32,
    /// Removed by an edit (or inside a removed `[ ... ]`).
    pub removed: bool,
}

/// The modules of the successor being written, per module ([`Replay::successor`]).
#[derive(Clone, Debug, Default)]
pub(crate) struct SuccEdits {
    pub mods: Vec<Succ>,
    /// Whether one is removed (the interpreter skips it).
    pub removing: bool,
    /// The successor positions of the modules interpreted, when some are
    /// removed (the interpreter's module index `i` is `kept[i]`).
    pub kept: Vec<u32>,
}

impl Replay {
    pub fn new(plan: EditPlan) -> Replay {
        Replay {
            plan,
            scopes: RwLock::new(Scopes {
                values: vec![Vec::new()],
                by_values: HashMap::from([(Vec::new(), 0)]),
                composed: HashMap::new(),
            }),
        }
    }

    /// The scope of a module of plan node `node` whose parent's scope is
    /// `parent`: the node's values over the parent's, per slot; pinned
    /// when the parent's is or the node has a pin.
    fn compose(&self, parent: u32, node: u32) -> u32 {
        let n = &self.plan.nodes[node as usize];
        let pinned = (parent & PINNED) | if n.pin.is_some() { PINNED } else { 0 };
        let base = parent & !PINNED;
        if n.values.is_empty() {
            return base | pinned;
        }
        if let Some(&s) = self
            .scopes
            .read()
            .unwrap_or_else(|e| e.into_inner())
            .composed
            .get(&(base, node))
        {
            return s | pinned;
        }
        let mut scopes = self.scopes.write().unwrap_or_else(|e| e.into_inner());
        let mut values = scopes.values[base as usize].clone();
        for &(slot, _, op) in &n.values {
            let v = match op {
                ValueOp::Set(x) => (slot, true, x.to_bits()),
                ValueOp::Offset(x) => (slot, false, x.to_bits()),
            };
            match values.iter_mut().find(|v| v.0 == slot) {
                Some(old) => *old = v,
                None => values.push(v),
            }
        }
        values.sort_by_key(|v| v.0);
        let s = match scopes.by_values.get(&values) {
            Some(&s) => s,
            None => {
                let s = scopes.values.len() as u32;
                scopes.values.push(values.clone());
                scopes.by_values.insert(values, s);
                s
            }
        };
        scopes.composed.insert((base, node), s);
        s | pinned
    }

    /// The successor of alternative `alt` written by the expansion of the
    /// module with key `key` and scope `scope`: every successor module's
    /// key looked up (its hits counted in `hits` when given), its scope,
    /// forced alternative and removal decided (a removed `[` or `]` takes
    /// its branch, to its partner, with it), and, with `values`, the
    /// values in force applied to the successor's parameter words
    /// `params` (the module's own edits over its ancestors'). `Err(v)`: a
    /// value an edit made not finite.
    #[allow(clippy::too_many_arguments)]
    pub fn successor(
        &self,
        g: &crate::expand::Grammar<'_>,
        key: u32,
        scope: u32,
        alt: u32,
        params: Option<&mut [f32]>,
        out: &mut SuccEdits,
        mut hits: Option<&mut Vec<(u32, u32)>>,
    ) -> Result<(), f32> {
        use grm_sema::Terminal;
        out.mods.clear();
        out.removing = false;
        out.kept.clear();
        let sys = g.sys;
        let Some(a) = sys.alts.get(alt as usize) else {
            return Ok(());
        };
        let inherited = scope & !PINNED;
        for m in sys.successor(a) {
            let orig = grm_compile::rng::child_key(key, m.salt);
            let mut s = Succ {
                key: orig,
                scope,
                force: 0,
                removed: false,
            };
            // A module of another symbol than its key's edits recorded is
            // not their part.
            if let Some(n) = self.plan.lookup(orig)
                && self.plan.nodes[n as usize]
                    .symbol
                    .is_none_or(|s| s == m.symbol)
            {
                if let Some(h) = hits.as_deref_mut() {
                    let h = &mut h[n as usize];
                    if h.0 == 0 {
                        h.1 = m.symbol;
                    }
                    h.0 += 1;
                }
                let e = &self.plan.nodes[n as usize];
                s.removed = e.remove.is_some();
                s.force = e.force.map_or(0, |f| f.1);
                if let Some((_, p)) = e.pin {
                    s.key = p;
                }
                s.scope = self.compose(scope, n);
                out.removing |= s.removed;
            }
            out.mods.push(s);
        }
        if out.removing {
            // A removed bracket takes its branch with it.
            let is = |j: usize, t: Terminal| {
                let sym = sys.succ[a.succ_offset as usize + j].symbol;
                g.ops.get(sym as usize).copied().flatten() == Some(t)
            };
            let n = out.mods.len();
            for j in 0..n {
                if !out.mods[j].removed {
                    continue;
                }
                if is(j, Terminal::Push) {
                    let mut depth = 0i32;
                    for k in j..n {
                        depth += i32::from(is(k, Terminal::Push)) - i32::from(is(k, Terminal::Pop));
                        out.mods[k].removed = true;
                        if depth == 0 {
                            break;
                        }
                    }
                } else if is(j, Terminal::Pop) {
                    let mut depth = 0i32;
                    for k in (0..=j).rev() {
                        depth += i32::from(is(k, Terminal::Pop)) - i32::from(is(k, Terminal::Push));
                        out.mods[k].removed = true;
                        if depth == 0 {
                            break;
                        }
                    }
                }
            }
            out.kept.extend(
                out.mods
                    .iter()
                    .enumerate()
                    .filter(|(_, s)| !s.removed)
                    .map(|(j, _)| j as u32),
            );
        }
        let Some(params) = params else {
            return Ok(());
        };
        if inherited == 0 && out.mods.iter().all(|s| s.scope & !PINNED == 0) {
            return Ok(());
        }
        let scopes = self.scopes.read().unwrap_or_else(|e| e.into_inner());
        for (s, m) in out.mods.iter().zip(sys.successor(a)) {
            let values = &scopes.values[(s.scope & !PINNED) as usize];
            if s.removed || values.is_empty() {
                continue;
            }
            let w = g.words.get(m.symbol as usize).copied().unwrap_or(0) as usize;
            let o = m.word_offset as usize;
            let Some(words) = params.get_mut(o..o + w) else {
                continue;
            };
            for &(slot, set, bits) in values {
                let Some(t) = self
                    .plan
                    .slots
                    .get(slot as usize)
                    .and_then(|s| s.get(m.symbol as usize))
                else {
                    continue;
                };
                let (lo, hi) = (t.word as usize, t.word as usize + t.words as usize);
                let Some(xs) = words.get_mut(lo..hi) else {
                    continue;
                };
                let v = f32::from_bits(bits);
                for x in xs {
                    let y = match (set, t.boolean) {
                        (true, true) => {
                            if v != 0.0 {
                                1.0
                            } else {
                                0.0
                            }
                        }
                        (true, false) => v,
                        (false, true) => continue,
                        (false, false) => *x + v,
                    };
                    if !y.is_finite() {
                        return Err(y);
                    }
                    *x = y;
                }
            }
        }
        Ok(())
    }

    /// A zeroed hit count per plan node, for [`Replay::successor`].
    pub fn new_hits(&self) -> Vec<(u32, u32)> {
        vec![(0, 0); self.plan.nodes.len()]
    }

    /// The hits counted, by key.
    pub fn hits(&self, counted: &[(u32, u32)]) -> EditHits {
        EditHits {
            hits: self
                .plan
                .nodes
                .iter()
                .zip(counted)
                .filter(|(_, h)| h.0 > 0)
                .map(|(n, &(modules, symbol))| (n.key, KeyHits { modules, symbol }))
                .collect(),
        }
    }
}

/// The draws of a module in a pinned scope: its key alone (not the
/// run's seed nor the particle's place in the search), so the module
/// draws the same production and parameters in every particle, run and
/// seed.
pub(crate) fn pinned_draws(key: u32) -> grm_compile::rng::DrawCtx {
    grm_compile::rng::DrawCtx {
        seed: 0x5eed_9127,
        iteration: 10,
        position: key,
    }
}

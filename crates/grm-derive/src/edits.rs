//! Persistent edits replayed while deriving (docs/edits.md, "Replay and
//! classification in the engines"; Lipp, 3.1-3.3).
//!
//! An [`EditPlan`] holds, per identity key, what the artist changed on
//! the module with that key: remove it (and so its whole future subtree),
//! set or offset one of its parameters (and the same parameter of every
//! module of its subtree that has it), force the alternative of the
//! production that rewrites it, or pin its key (the key its random draws
//! and its subtree's keys come from). The plan is resolved to the
//! compiled system by the caller (`grm_grow` reads the edits file and
//! names parameters); this crate knows no file.
//!
//! The replay runs only when a plan is given ([`Engine::with_edits`]), in
//! pieces of at most 4,096 input modules: a piece no edit reaches (no
//! module of it carries a tag) is the engine's plain rewrite, its written
//! keys then scanned; another is the engine's own rewrite loop through its
//! `Replay` hooks (the plain derivation passes `()`, which compiles to the
//! plain loop, so a derivation without edits costs what it did) over its
//! runs of tagged modules, and without them over its long runs of untagged
//! ones (`TAG_BLOCK`, `QUIET`); a step
//! that records its decisions (`edited_step` with a record) takes a second
//! loop of its own that writes the same string. Either keeps the engine's
//! structure (count, scan, rewrite over chunks in parallel, the same
//! decisions, `emit` and keys) and adds:
//!
//! - a **tag** per module of the string (0: no edit reaches it; no tag
//!   buffer at all until an edit makes the first tag; buffers are reused,
//!   never zeroed: every tag of a piece is written), carried
//!   by copies and inherited by successors: the alternative a `force`
//!   edit imposes on the module's own rewrite, and the **scope** of `set`
//!   and `offset` edits of its ancestors (and its own), applied to every
//!   successor module as it is written (compiled per scope and successor
//!   list to word operations; scopes with the same values are one);
//! - every key written looked up in the plan (two bits of one word of a
//!   65,536-bit filter, tested eight keys at a time after the piece: an
//!   AVX2 gather where the CPU has it, `filter.rs`; then a hash map on a
//!   hit; the successors of a tagged module are looked up by the hooks,
//!   with their parent's scope): a module whose key
//!   has edits is settled after the chunk's rewrite, in position order on
//!   one thread: removed (a `[` or `]` with the whole branch to its
//!   partner), its key replaced by a pinned one, its values set (its own
//!   edits over its ancestors', per slot: the deeper target wins), its tag
//!   given. A copy of a settled module is passed over.
//! - removed modules stay in the string [`Engine::derive_edited`] passes
//!   to the next step, which skips them (its pieces split around them),
//!   and are dropped once after the last step (where no rule reads a
//!   neighbour; a step of [`Engine::edited_step`] drops its own).
//!
//! Determinism: decisions and values depend only on the input string, its
//! tags, the seed and the iteration, never on the chunking; tags are
//! created in position order. The output is the same for any thread count.

mod derive;
mod filter;

use derive::TAG_MOVE;

use std::collections::{HashMap, HashSet};
use std::hash::{BuildHasherDefault, Hasher};
use std::sync::Mutex;
use std::time::Instant;

use grm_compile::rng;
use rayon::prelude::*;

use crate::engine::{
    Act, Binds, COPY, ChunkOut, Derivation, DeriveLimits, DeriveOptions, Engine, IterationStats,
    Made, Out, Replay, SLOW, Step, copy_small, keep_first,
};
use crate::error::{DeriveError, RuntimeError, RuntimeErrorKind};
use crate::string::ModuleString;

/// A hasher for identity keys (already well mixed: a multiply spreads
/// them over the table) and small tuples of them; the maps of the replay
/// are looked up per module, where SipHash costs more than the lookup.
#[derive(Clone, Copy, Debug, Default)]
struct KeyHasher(u64);

impl Hasher for KeyHasher {
    #[inline(always)]
    fn finish(&self) -> u64 {
        self.0
    }

    #[inline(always)]
    fn write_u32(&mut self, x: u32) {
        self.0 = (self.0.rotate_left(26) ^ u64::from(x)).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    }

    #[inline(always)]
    fn write_u64(&mut self, x: u64) {
        self.write_u32(x as u32);
        self.write_u32((x >> 32) as u32);
    }

    #[inline(always)]
    fn write_usize(&mut self, x: usize) {
        self.write_u64(x as u64);
    }

    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u32(u32::from(b));
        }
    }
}

type KeyMap<K, V> = HashMap<K, V, BuildHasherDefault<KeyHasher>>;
type KeySet<K> = HashSet<K, BuildHasherDefault<KeyHasher>>;

/// What a `set` or `offset` edit does to a parameter's words.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ValueOp {
    /// Replace the value (a `bool` parameter becomes 1 for any non-zero
    /// value, 0 for zero).
    Set(f32),
    /// Add to the value the production computed (not applied to `bool`
    /// parameters).
    Offset(f32),
}

/// One edit of the module with some key, resolved to the compiled system.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum EditAction {
    /// The module never appears (nor, so, its subtree).
    Remove,
    /// Its rewrite uses this alternative (from 1) of the group that
    /// applies (its context and condition as written; the weights and the
    /// draw ignored). A group with fewer alternatives races as written.
    Force(u32),
    /// Its key becomes this one: its draws, and its subtree's keys, are
    /// those of this key.
    Pin(u32),
    /// A parameter of the module and of every module of its subtree that
    /// has it: slot `slot` of [`EditPlan::add_slot`].
    Value { slot: u32, op: ValueOp },
}

/// Where a value slot (a parameter name) lives in one symbol's words.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SlotTarget {
    /// The first parameter word.
    pub word: u32,
    /// How many words (0: the symbol has no such parameter).
    pub words: u32,
    /// A `bool` parameter.
    pub boolean: bool,
}

/// The edits of one key: per slot (removal, the alternative, the pin,
/// one value slot) the edit with the larger id. Shared by every engine
/// that replays key targets (the guided sampler's plan holds these too).
#[derive(Clone, Debug, Default)]
pub struct KeyEdits {
    /// The identity key.
    pub key: u32,
    /// The id of the edit that removes it.
    pub remove: Option<u32>,
    /// (id, alternative from 1).
    pub force: Option<(u32, u32)>,
    /// (id, key).
    pub pin: Option<(u32, u32)>,
    /// (slot, id, op), one per slot, sorted by slot.
    pub values: Vec<(u32, u32, ValueOp)>,
    /// The symbol the key's edits recorded (`grm_edits::Edit::symbol`),
    /// if one did: a module of another symbol made with the key is not
    /// the part (neither edited nor counted as a hit).
    pub symbol: Option<u32>,
}

impl KeyEdits {
    /// No edits yet of `key`.
    pub fn new(key: u32) -> KeyEdits {
        KeyEdits {
            key,
            ..KeyEdits::default()
        }
    }

    /// Take edit `id`'s `action`: of two edits in one slot the larger id
    /// wins, whatever the order they come in.
    pub fn merge(&mut self, id: u32, action: EditAction) {
        fn later<T>(slot: &mut Option<(u32, T)>, id: u32, v: T) {
            if slot.as_ref().is_none_or(|(old, _)| id >= *old) {
                *slot = Some((id, v));
            }
        }
        match action {
            EditAction::Remove => {
                if self.remove.is_none_or(|old| id >= old) {
                    self.remove = Some(id);
                }
            }
            EditAction::Force(k) => later(&mut self.force, id, k),
            EditAction::Pin(p) => later(&mut self.pin, id, p),
            EditAction::Value { slot, op } => {
                match self.values.iter_mut().find(|v| v.0 == slot) {
                    Some(v) => {
                        if id >= v.1 {
                            *v = (slot, id, op);
                        }
                    }
                    None => self.values.push((slot, id, op)),
                }
                self.values.sort_by_key(|v| v.0);
            }
        }
    }
}

/// A replay plan by identity key, as an edits file is resolved into it
/// (`grm_grow::edits`): this crate's [`EditPlan`] and the guided
/// sampler's.
pub trait KeyPlan {
    /// A value slot (one parameter name): per symbol id, where that
    /// parameter is. Returns the slot's number for [`EditAction::Value`].
    fn add_slot(&mut self, per_symbol: Vec<SlotTarget>) -> u32;
    /// Count the modules made with `key` without editing them.
    fn watch(&mut self, key: u32);
    /// Add edit `id` of the module with `key` ([`KeyEdits::merge`]).
    fn add(&mut self, key: u32, id: u32, action: EditAction);
    /// The module with `key` is one of symbol `symbol` only
    /// ([`KeyEdits::symbol`]).
    fn restrict(&mut self, key: u32, symbol: u32);
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

/// The most input modules of one piece of the edited rewrite: a piece
/// whose modules carry no tag is rewritten by the engine's own loop.
const EDIT_PIECE: usize = 4096;

/// The bit of a tag whose entry forces an alternative (the rest: its
/// index in [`Table::entries`]), so that a piece without forced modules
/// is found by OR-ing its tags.
const FORCED: u32 = 1 << 31;

/// The persistent edits of one derivation, by identity key.
#[derive(Clone, Debug)]
pub struct EditPlan {
    nodes: Vec<KeyEdits>,
    index: KeyMap<u32, u32>,
    /// A bit set for every key with edits (its low bits).
    filter: filter::KeyFilter,
    /// Per slot, per symbol: where the slot's parameter is.
    slots: Vec<Vec<SlotTarget>>,
    /// Tag buffers of earlier derivations, reused (see [`TagPool`]).
    pool: TagPool,
}

/// What an edited derivation leaves for the next one (as the engine keeps
/// its strings' buffers): its tag buffers (one as long as the string it is
/// taken for needs no zeroing, since the edited rewrite writes every tag
/// of a piece with tags and zeroes the others) and its tags' table (the
/// scopes and tags it composed, found again rather than composed anew; a
/// tag's number means nothing outside its derivation). A clone of a plan
/// starts without them.
#[derive(Debug, Default)]
struct TagPool(Mutex<Vec<Vec<u32>>>, Mutex<Option<Table>>);

impl Clone for TagPool {
    fn clone(&self) -> TagPool {
        TagPool::default()
    }
}

impl TagPool {
    /// At most this many buffers are kept (the longest).
    const KEEP: usize = 4;
    /// A table with more scopes than this is not kept.
    const KEEP_SCOPES: usize = 1 << 16;

    /// The table a derivation of `engine` left, or a new one.
    fn table(&self, engine: &Engine<'_>) -> Table {
        let kept = self.1.lock().unwrap_or_else(|p| p.into_inner()).take();
        match kept {
            Some(t) if t.sym_words == engine.sym_words && t.plans == engine.plans.len() => t,
            _ => Table::new(engine),
        }
    }

    /// Keep `table` for a later derivation.
    fn give_table(&self, table: Table) {
        if table.scopes.len() <= TagPool::KEEP_SCOPES {
            *self.1.lock().unwrap_or_else(|p| p.into_inner()) = Some(table);
        }
    }

    /// A buffer of at least `m` tags, their values unspecified (zeros
    /// where the buffer had to grow): `spare` when long enough, else the
    /// shortest kept buffer that is, else `spare` grown. Never shortened:
    /// what a buffer's length covers needs no zeroing the next time.
    fn take(&self, spare: Vec<u32>, m: usize) -> Vec<u32> {
        let mut b = spare;
        if b.len() < m {
            let mut pool = self.0.lock().unwrap_or_else(|p| p.into_inner());
            let pick = (0..pool.len())
                .filter(|&i| pool[i].len() >= m)
                .min_by_key(|&i| pool[i].len());
            if let Some(i) = pick {
                let p = pool.swap_remove(i);
                if b.capacity() > 0 {
                    pool.push(b);
                }
                b = p;
            }
        }
        if b.len() < m {
            b.resize(m, 0);
        }
        b
    }

    /// Keep `b` for a later derivation.
    fn give(&self, b: Vec<u32>) {
        if b.is_empty() {
            return;
        }
        let mut pool = self.0.lock().unwrap_or_else(|p| p.into_inner());
        pool.push(b);
        if pool.len() > TagPool::KEEP {
            pool.sort_by_key(|v| std::cmp::Reverse(v.len()));
            pool.truncate(TagPool::KEEP);
        }
    }
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
            index: KeyMap::default(),
            filter: filter::KeyFilter::new(),
            slots: Vec::new(),
            pool: TagPool::default(),
        }
    }

    /// A value slot (one parameter name): per symbol id, where that
    /// parameter is (`words == 0` where the symbol has none; symbols past
    /// the vector's end have none). Returns the slot's number for
    /// [`EditAction::Value`].
    pub fn add_slot(&mut self, per_symbol: Vec<SlotTarget>) -> u32 {
        self.slots.push(per_symbol);
        (self.slots.len() - 1) as u32
    }

    /// Count the modules made with `key` ([`EditOutcome::hits`]) without
    /// editing them: for edits the engine does not replay, whose targets
    /// are still classified.
    pub fn watch(&mut self, key: u32) {
        self.node(key);
    }

    /// The node of `key`, made when missing.
    fn node(&mut self, key: u32) -> usize {
        match self.index.get(&key) {
            Some(&n) => n as usize,
            None => {
                self.index.insert(key, self.nodes.len() as u32);
                self.nodes.push(KeyEdits::new(key));
                self.filter.insert(key);
                self.nodes.len() - 1
            }
        }
    }

    /// Add edit `id` of the module with `key`. Of two edits of one key in
    /// one slot (removal, the alternative, the pin, one value slot) the
    /// larger id wins, whatever the order they are added in.
    pub fn add(&mut self, key: u32, id: u32, action: EditAction) {
        let n = self.node(key);
        self.nodes[n].merge(id, action);
    }

    /// The module with `key` is one of symbol `symbol` only: a module of
    /// another symbol made with it is passed over ([`KeyEdits::symbol`]).
    pub fn restrict(&mut self, key: u32, symbol: u32) {
        let n = self.node(key);
        self.nodes[n].symbol = Some(symbol);
    }

    /// Whether the plan has no edits.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// The number of keys with edits.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// The keys with edits, in the order they were first added.
    pub fn keys(&self) -> impl Iterator<Item = u32> + '_ {
        self.nodes.iter().map(|n| n.key)
    }

    /// The node of `key`, if it has edits: one filter bit, then the map.
    #[inline(always)]
    fn lookup(&self, key: u32) -> Option<u32> {
        if !self.filter.maybe(key) {
            return None;
        }
        self.index.get(&key).copied()
    }

    /// Push a [`Match`] (scope 0) for every key of `keys` with edits, the
    /// first at output position `base`: the filter tested eight keys at a
    /// time, the map only where a bit is set.
    fn scan(&self, keys: &[u32], base: usize, matches: &mut Vec<Match>) {
        self.filter.scan(keys, |j| {
            if let Some(&node) = self.index.get(&keys[j]) {
                matches.push(Match {
                    pos: base + j,
                    node,
                    scope: 0,
                });
            }
        });
    }
}

/// What the edits met in one derivation: per key with edits, how many
/// modules were made with it (a module is made once; a copy is the same
/// module) and the symbol of the first.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct EditOutcome {
    hits: KeyMap<u32, KeyHits>,
}

/// The modules made with one key.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct KeyHits {
    /// How many (more than one: keys collide, the edit is ambiguous).
    pub modules: u32,
    /// The first one's symbol.
    pub symbol: u32,
}

impl EditOutcome {
    /// The modules made with `key`; `None` when none was (or the key has
    /// no edits).
    pub fn hits(&self, key: u32) -> Option<KeyHits> {
        self.hits.get(&key).copied()
    }
}

/// One word a scope's values change on a module of one symbol (`word`:
/// among the module's words), or on the modules of one successor list
/// (`word`: among the list's words, `sym` the module's symbol): set to
/// `v`, or `v` added (`offset`).
#[derive(Clone, Copy, Debug)]
struct WordOp {
    word: u32,
    offset: bool,
    v: f32,
    sym: u32,
}

/// At most this many successor lists get their scopes' values compiled
/// per list (each scope holds a range per list); more fall back to the
/// per-symbol operations.
const MAX_LISTS: usize = 256;

/// The tags and scopes of one edited derivation (see the module doc).
#[derive(Clone, Debug)]
struct Table {
    /// Per tag: (forced alternative or 0, scope). Tag 0 is (0, 0).
    entries: Vec<(u32, u32)>,
    /// Per scope: the values in force, one per slot. Scope 0 is empty.
    scopes: Vec<Vec<(u32, ValueOp)>>,
    /// Per scope: its tag without a forced alternative (what successors
    /// inherit).
    scope_tag: Vec<u32>,
    /// (parent scope, node) -> scope.
    composed: KeyMap<(u32, u32), u32>,
    /// The values of each scope (per slot: the slot, set or offset, the
    /// value's bits) -> the scope: compositions with the same values share
    /// one scope (a value edit below another of the same values).
    by_values: KeyMap<Vec<(u32, u32, u32)>, u32>,
    /// (force, scope) -> tag.
    tags: KeyMap<(u32, u32), u32>,
    /// The symbols' word counts (the engine's).
    sym_words: Vec<u32>,
    /// The engine's alternatives (how many).
    plans: usize,
    /// Per scope, per symbol (`scope * symbols + symbol`): its values
    /// compiled to word operations, the range of them in `ops` (empty for
    /// a symbol none of the values names).
    sym_ops: Vec<(u32, u32)>,
    ops: Vec<WordOp>,
    /// The successor lists of the alternatives (their first module in
    /// the engine's `succ_syms`, their symbols), at most [`MAX_LISTS`].
    lists: Vec<(u32, Vec<u32>)>,
    /// Per first successor module: its list in `lists`, plus one (0: none).
    list_of: Vec<u32>,
    /// Per scope, per list (`scope * lists + list`): the range in `ops` of
    /// its values on the list's modules (words from the list's first).
    list_ops: Vec<(u32, u32)>,
}

impl Table {
    fn new(engine: &Engine<'_>) -> Table {
        let sym_words = &engine.sym_words[..];
        let mut lists: Vec<(u32, Vec<u32>)> = Vec::new();
        let mut list_of = Vec::new();
        if engine.plans.len() <= MAX_LISTS {
            list_of = vec![0u32; engine.succ_syms.len()];
            for p in &engine.plans {
                let (a, n) = (p.succ as usize, p.len as usize);
                let Some(syms) = engine.succ_syms.get(a..a + n) else {
                    continue;
                };
                if n == 0 || list_of[a] != 0 {
                    continue;
                }
                lists.push((p.succ, syms.to_vec()));
                list_of[a] = lists.len() as u32;
            }
        }
        Table {
            list_ops: vec![(0, 0); lists.len()],
            lists,
            list_of,
            entries: vec![(0, 0)],
            scopes: vec![Vec::new()],
            scope_tag: vec![0],
            composed: KeyMap::default(),
            by_values: KeyMap::default(),
            tags: KeyMap::from_iter([((0, 0), 0)]),
            sym_words: sym_words.to_vec(),
            plans: engine.plans.len(),
            sym_ops: vec![(0, 0); sym_words.len()],
            ops: Vec::new(),
        }
    }

    /// The entry of tag `t` (its [`FORCED`] bit cleared).
    #[inline(always)]
    fn entry(&self, t: u32) -> (u32, u32) {
        self.entries[(t & !FORCED) as usize]
    }

    fn tag(&mut self, force: u32, scope: u32) -> u32 {
        if let Some(&t) = self.tags.get(&(force, scope)) {
            return t;
        }
        let t = self.entries.len() as u32 | if force != 0 { FORCED } else { 0 };
        self.entries.push((force, scope));
        self.tags.insert((force, scope), t);
        t
    }

    /// The scope of a module of `node` whose parent's scope is `parent`:
    /// the node's values over the parent's, per slot.
    fn compose(&mut self, plan: &EditPlan, parent: u32, node: u32) -> u32 {
        if let Some(&s) = self.composed.get(&(parent, node)) {
            return s;
        }
        let mut values = self.scopes[parent as usize].clone();
        for &(slot, _, op) in &plan.nodes[node as usize].values {
            match values.iter_mut().find(|v| v.0 == slot) {
                Some(v) => v.1 = op,
                None => values.push((slot, op)),
            }
        }
        values.sort_by_key(|v| v.0);
        let key: Vec<(u32, u32, u32)> = values
            .iter()
            .map(|&(slot, op)| match op {
                ValueOp::Set(v) => (slot, 0, v.to_bits()),
                ValueOp::Offset(v) => (slot, 1, v.to_bits()),
            })
            .collect();
        if let Some(&s) = self.by_values.get(&key) {
            self.composed.insert((parent, node), s);
            return s;
        }
        // Per symbol, the values' word operations in slot order (a slot
        // the symbol has not, or whose words lie past the symbol's, does
        // nothing; a `bool` is set to 0 or 1 and never offset).
        for (sym, &words) in self.sym_words.iter().enumerate() {
            let lo = self.ops.len() as u32;
            for &(slot, op) in &values {
                let Some(t) = plan.slots.get(slot as usize).and_then(|s| s.get(sym)) else {
                    continue;
                };
                if u64::from(t.word) + u64::from(t.words) > u64::from(words) {
                    continue;
                }
                for word in t.word..t.word + t.words {
                    let (offset, v) = match op {
                        ValueOp::Set(v) if t.boolean => (false, if v != 0.0 { 1.0 } else { 0.0 }),
                        ValueOp::Set(v) => (false, v),
                        ValueOp::Offset(_) if t.boolean => continue,
                        ValueOp::Offset(by) => (true, by),
                    };
                    self.ops.push(WordOp {
                        word,
                        offset,
                        v,
                        sym: sym as u32,
                    });
                }
            }
            self.sym_ops.push((lo, self.ops.len() as u32));
        }
        // Per successor list, its modules' operations in order, their
        // words counted from the list's first.
        let scope = self.scopes.len();
        let n = self.sym_words.len();
        for l in 0..self.lists.len() {
            let lo = self.ops.len() as u32;
            let mut at = 0u32;
            for k in 0..self.lists[l].1.len() {
                let sym = self.lists[l].1[k] as usize;
                let (a, b) = self.sym_ops[scope * n + sym];
                for j in a..b {
                    let op = self.ops[j as usize];
                    self.ops.push(WordOp {
                        word: at + op.word,
                        ..op
                    });
                }
                at += self.sym_words.get(sym).copied().unwrap_or(0);
            }
            self.list_ops.push((lo, self.ops.len() as u32));
        }
        let s = self.scopes.len() as u32;
        self.scopes.push(values);
        let t = self.tag(0, s);
        self.scope_tag.push(t);
        self.composed.insert((parent, node), s);
        self.by_values.insert(key, s);
        s
    }

    /// Apply scope `scope`'s values to the words `params` of a module of
    /// symbol `sym`; `Err(v)` for the first value that is not finite.
    #[inline(always)]
    fn apply(&self, scope: u32, sym: u32, params: &mut [f32]) -> Result<(), f32> {
        let at = scope as usize * self.sym_words.len() + sym as usize;
        let Some(&(lo, hi)) = self.sym_ops.get(at) else {
            return Ok(());
        };
        if lo == hi {
            return Ok(());
        }
        self.apply_ops(&self.ops[lo as usize..hi as usize], params)
            .map_err(|(v, _)| v)
    }

    /// Scope `scope`'s values compiled for the modules of successor list
    /// `succ` (`n` modules): `None` where the list has none compiled.
    #[inline(always)]
    fn list_ops(&self, scope: u32, succ: u32, n: usize) -> Option<&[WordOp]> {
        let l = *self.list_of.get(succ as usize)? as usize;
        if l == 0 || self.lists[l - 1].1.len() != n {
            return None;
        }
        let (lo, hi) = self.list_ops[scope as usize * self.lists.len() + l - 1];
        Some(&self.ops[lo as usize..hi as usize])
    }

    /// Apply `ops` to `params` (their words counted from its first);
    /// `Err((v, sym))` for the first value that is not finite.
    #[inline(always)]
    fn apply_ops(&self, ops: &[WordOp], params: &mut [f32]) -> Result<(), (f32, u32)> {
        for op in ops {
            let Some(x) = params.get_mut(op.word as usize) else {
                continue;
            };
            let v = if op.offset { *x + op.v } else { op.v };
            if !v.is_finite() {
                return Err((v, op.sym));
            }
            *x = v;
        }
        Ok(())
    }
}

/// The state an edited derivation carries from one string to the next:
/// per module its tag, the tags' table, and what the edits met so far.
#[derive(Clone, Debug)]
pub struct EditState {
    /// Per module of the string its tag (the first `len`; the buffer may
    /// be longer); empty while no module has one (no buffer until a tag is
    /// made).
    tags: Vec<u32>,
    /// The string's length.
    len: usize,
    /// The modules of the string removed by the last step and not yet
    /// dropped (sorted, disjoint ranges): [`Engine::derive_edited`] leaves
    /// them for the next step to skip and drops them once, after the last
    /// step (a system without context only; empty otherwise).
    dead: Vec<std::ops::Range<usize>>,
    /// The keys of the modules settled so far (a pinned one's new key): a
    /// module with one of them is a copy of one (or a later collision)
    /// and is not edited again.
    made: KeySet<u32>,
    /// A spare buffer for the next string's tags.
    spare: Vec<u32>,
    table: Table,
    /// Per plan node: modules made with its key, the first one's symbol.
    hits: Vec<(u32, u32)>,
}

impl EditState {
    /// What the edits met so far.
    pub fn outcome(&self, plan: &EditPlan) -> EditOutcome {
        let mut hits = KeyMap::with_capacity_and_hasher(plan.len(), Default::default());
        hits.extend(
            plan.nodes
                .iter()
                .zip(&self.hits)
                .filter(|(_, h)| h.0 > 0)
                .map(|(n, &(modules, symbol))| (n.key, KeyHits { modules, symbol })),
        );
        EditOutcome { hits }
    }
}

/// What one edited step decided, for callers that build the derivation
/// tree: per input module the alternative that rewrote it (`None`: copied)
/// and how many of the modules it became are in the output (fewer than
/// its successor's length where edits removed some).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct StepRecord {
    pub decided: Vec<Option<u32>>,
    pub kept: Vec<u32>,
    /// The modules edits removed from the step's output (whole branches
    /// with a removed `[` or `]`), in output order.
    pub removed: Vec<RemovedModule>,
}

/// A module of a step's output that edits removed ([`StepRecord`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RemovedModule {
    /// The input module whose rewrite (or copy) made it.
    pub input: u32,
    /// Whether it is a copy of that input module (no rule rewrote it).
    pub copy: bool,
    /// Its place among the modules the input module became (0 for a copy).
    pub successor: u32,
    pub symbol: u32,
    pub key: u32,
}

/// A successor module whose key has edits, settled after the rewrite.
#[derive(Clone, Copy, Debug)]
struct Match {
    /// Its output position.
    pos: usize,
    /// Its plan node.
    node: u32,
    /// Its parent's scope.
    scope: u32,
}

/// The edits' hooks in the engine's rewrite loop ([`Replay`]): the same
/// tags, lookups and values as [`Engine::rewrite_edited`]'s own loop.
struct Hooks<'h, 'o> {
    engine: &'h Engine<'h>,
    iteration: u32,
    plan: &'h EditPlan,
    table: &'h Table,
    /// The input's tags.
    tags: &'h [u32],
    /// The chunk's output tags (their values unspecified when the
    /// rewrite starts: every one is written).
    otags: &'o mut [u32],
    /// The chunk's first output module.
    base: usize,
    matches: Vec<Match>,
    /// The tag of the module `force` was last asked about.
    tag: u32,
    /// Where the output written so far ends.
    end: usize,
}

impl Replay for Hooks<'_, '_> {
    #[inline(always)]
    fn force(&mut self, i: usize) -> u32 {
        let t = self.tags[i];
        // `made` for this module comes next (`Replay::force`).
        self.tag = t;
        if t & FORCED == 0 {
            0
        } else {
            self.table.entry(t).0
        }
    }

    #[inline(always)]
    fn copied(&mut self, i: std::ops::Range<usize>, o: usize) {
        let n = i.len();
        self.end = o + n;
        if n == 1 {
            self.otags[o] = self.tags[i.start];
        } else if n <= TAG_MOVE
            && o + TAG_MOVE <= self.otags.len()
            && i.start + TAG_MOVE <= self.tags.len()
        {
            // One fixed-size move: the tags past the run's are written
            // again by the modules after it (every tag of the piece is).
            self.otags[o..o + TAG_MOVE].copy_from_slice(&self.tags[i.start..i.start + TAG_MOVE]);
        } else {
            copy_small(&mut self.otags[o..o + n], &self.tags[i]);
        }
    }

    #[inline(always)]
    fn made(
        &mut self,
        i: usize,
        o: usize,
        made: Made<'_>,
        params: &mut [f32],
    ) -> Result<(), crate::error::RuntimeError> {
        self.end = o + made.keys.len();
        // Module `i`'s tag, read by `force` just before.
        let tag = self.tag;
        debug_assert_eq!(tag, self.tags[i]);
        if tag == 0 {
            // Every output tag is written (the buffer is not zeroed); the
            // keys are looked up after the piece (`rewrite_edited`).
            let n = made.keys.len();
            if n == 1 {
                self.otags[o] = 0;
            } else if n <= TAG_MOVE && o + TAG_MOVE <= self.otags.len() {
                // As in `copied`: the tags past these are written again.
                self.otags[o..o + TAG_MOVE].fill(0);
            } else {
                self.otags[o..o + n].fill(0);
            }
            return Ok(());
        }
        // Most modules made have no edits: one test of all their keys.
        let maybe = self.plan.filter.any(made.keys);
        let scope = self.table.entry(tag).1;
        let inherit = self.table.scope_tag[scope as usize];
        let n = made.keys.len();
        if !maybe || !made.keys.iter().any(|&ck| self.plan.lookup(ck).is_some()) {
            // No successor has edits of its own: all inherit the tag, and
            // the scope's values compiled for the list apply at once.
            if n == 1 {
                self.otags[o] = inherit;
            } else {
                self.otags[o..o + n].fill(inherit);
            }
            if scope == 0 || made.starts.is_empty() {
                return Ok(());
            }
            if let Some(ops) = self.table.list_ops(scope, made.succ, n) {
                if ops.is_empty() {
                    return Ok(());
                }
                let a = (made.starts[0] - made.word_base) as usize;
                return match self.table.apply_ops(ops, &mut params[a..]) {
                    Ok(()) => Ok(()),
                    Err((v, s)) => Err(self.engine.edit_error(self.iteration, i, s, v)),
                };
            }
        }
        for (k, &ck) in made.keys.iter().enumerate() {
            if maybe && let Some(node) = self.plan.lookup(ck) {
                // Settled after the rewrite, its values and tag with it.
                self.otags[o + k] = 0;
                self.found(o + k, node, scope);
                continue;
            }
            self.otags[o + k] = inherit;
            if scope != 0 && !made.starts.is_empty() {
                let s = made.syms[k];
                let a = (made.starts[k] - made.word_base) as usize;
                let words = self.engine.sym_words[s as usize] as usize;
                if let Err(v) = self.table.apply(scope, s, &mut params[a..a + words]) {
                    return Err(self.engine.edit_error(self.iteration, i, s, v));
                }
            }
        }
        Ok(())
    }
}

/// The hooks of a run without tags: where its output ends, nothing else.
struct Tail(usize);

impl Replay for Tail {
    #[inline(always)]
    fn force(&mut self, _: usize) -> u32 {
        0
    }
    #[inline(always)]
    fn copied(&mut self, i: std::ops::Range<usize>, o: usize) {
        self.0 = o + i.len();
    }
    #[inline(always)]
    fn made(
        &mut self,
        _: usize,
        o: usize,
        made: Made<'_>,
        _: &mut [f32],
    ) -> Result<(), crate::error::RuntimeError> {
        self.0 = o + made.keys.len();
        Ok(())
    }
}

impl Hooks<'_, '_> {
    #[cold]
    #[inline(never)]
    fn found(&mut self, o: usize, node: u32, scope: u32) {
        self.matches.push(Match {
            pos: self.base + o,
            node,
            scope,
        });
    }
}

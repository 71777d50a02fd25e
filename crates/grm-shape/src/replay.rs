//! Persistent edits replayed while the engine derives (Lipp, 3.2;
//! docs/edits.md, "Replay"): an [`EditPlan`] is a system's edits
//! (`grm_edits::Edit`) lowered to this program's ids, which the derivation
//! loop consults at every shape it is about to expand.
//!
//! Finding an edit's parts costs nothing where no edit is:
//!
//! - **exact** targets form a trie over (label, edge) from the axiom; each
//!   node of the tree carries its state in it, computed from its parent's
//!   with one look at its parent state's edges (which lie together: a
//!   floor's hundred tiles read its few targeted ones), and only while its
//!   path is a prefix of some target's (a node off every target's path is
//!   `NONE` and its subtree is never looked up again);
//! - **key** targets are a hash map from identity keys, behind a blocked
//!   Bloom filter sized to stay in the first-level cache: a shape whose key
//!   is no target's costs one load and a compare (one in 1,500 passes it
//!   with 200 key targets), and only the shapes of the symbols the key
//!   edits recorded (`grm_edits::Edit::symbol`, what a pick writes; every
//!   symbol where one recorded none) test their keys at all; a key's edit
//!   applies to a shape of its recorded symbol only;
//! - **semantic** queries are indexed by their label, then grouped by
//!   their pattern (the tags and anchors they name, in order) with a map
//!   from a mix of the indices they want to the edits, behind a
//!   256-bit filter of those keys: a shape of a queried symbol walks up its
//!   path once to collect the tagged commands of the tags queries name
//!   (each tag a slot: a pattern tells its own tags by one mask), and only
//!   up to its innermost tagged command when that is the last path's: the
//!   entries above it, and each pattern's reading of them, are kept (a
//!   floor's hundred windows read the floor and facade once). Below the
//!   kept entries a shape has one, its innermost command's child: a gate
//!   per command and symbol (`pattern::Gate`, from the patterns' readings
//!   and their wanted lists) says which children a query can name, so most
//!   shapes cost the walk and a bit test. One the gate lets through costs
//!   one reading of its own entries per pattern, however many queries
//!   share it (the tower's 80 window queries are three patterns), and a
//!   map lookup only where the filter lets the key through;
//! - **quiet subtrees**: where a rule makes a command of a tag some query
//!   names, its children that no query can name, nor any shape below them
//!   (`EditPlan::quiet_children`: one gate over all patterns per command),
//!   are bracketed on the derivation stack by markers, and the shapes of
//!   their subtrees are looked at for key targets only: a query's label
//!   costs its shapes no walk where the query cannot name them.
//!
//! Which shapes off every exact target's path the loop looks at is one
//! byte per symbol (`EditPlan::attention`).
//!
//! What applies (Lipp 3.2.2, `grm_edits::scoping`): `remove`, `material`
//! and `mesh` reach the whole subtree (a deeper target's edit overrides an
//! ancestor's; on one part the later edit, the larger id, wins); `force`
//! and `pin` only the part itself. A removed shape stays in the tree (its
//! locators still resolve) but is not expanded and draws nothing
//! ([`ShapeTree::is_removed`]). `material` and `mesh` win over the rules
//! below the target (the part is what the artist said, whatever the
//! grammar's rules inside it set). `set` and `offset` are not replayed in
//! shape mode: meta-parameters are numbers once lowered; such edits are
//! listed in [`EditPlan::unsupported`].
//!
//! [`ShapeTree::is_removed`]: crate::ShapeTree::is_removed

use crate::ir::{AssetId, MaterialId, Program, SymbolId, TagId};
use crate::locator::{Anchor, EdgeRef};
use crate::tree::{Command, Node, NodeKind};
use foldhash::HashMap;
use grm_edits::{Edit, Op, Target};

mod pattern;
mod trie;

use pattern::{MIX_SEED, NO_SLOT, Pattern, Reading, keep, mix};
pub(crate) use pattern::{PathScratch, QuietScratch};
use trie::{ExactBuild, TrieEdge, TrieState};

/// A node's label as the plan compares it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) enum Label {
    Symbol(SymbolId),
    Command(Command),
    Insert(AssetId),
}

/// What one edit does, in the program's ids.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Action {
    Remove,
    /// The alternative, from 0.
    Force(u32),
    Pin(u32),
    Material(MaterialId),
    Mesh(AssetId),
}

/// The most words a [`KeyFilter`] has (8 KiB).
const FILTER_WORDS: usize = 1 << 10;

/// A blocked Bloom filter of 32-bit hashes ([`EditPlan::key_filter`]): a
/// value picks a word by its low bits and sets three bits of it chosen by
/// its high ones, so a test is one load and a compare. Sized by how many
/// values it holds, about 16 bits each (200 key targets: 512 bytes, eight
/// cache lines, about one false pass in 230; at most 8 KiB): the loop
/// tests it for every shape, so it is kept small enough to stay in the
/// first-level cache while the derivation's nodes and scratch stream
/// through it (at 64 bits a key, 2 KiB for 200, the test cost the tower's
/// derivation 2-3 points more, session 31; the fixed 8 KiB bitmap before
/// that missed on about one test in two), while a false pass costs only
/// a call and a map lookup (about 950 a derivation of the tower with 200
/// key targets).
#[derive(Clone, Debug)]
struct KeyFilter {
    words: Box<[u64]>,
    mask: u32,
}

impl Default for KeyFilter {
    fn default() -> KeyFilter {
        KeyFilter {
            words: Box::new([0]),
            mask: 0,
        }
    }
}

impl KeyFilter {
    /// The filter of `values`.
    fn of(values: &[u32]) -> KeyFilter {
        let n = (values.len().next_power_of_two() / 4).clamp(1, FILTER_WORDS);
        let mut f = KeyFilter {
            words: vec![0; n].into_boxed_slice(),
            mask: n as u32 - 1,
        };
        for &v in values {
            if let Some(w) = f.words.get_mut((v & f.mask) as usize) {
                *w |= Self::bits(v);
            }
        }
        f
    }

    /// The three bits `v` sets in its word (from bits 14-31: the word is
    /// picked by the low ones, at most 10 of them).
    #[inline(always)]
    fn bits(v: u32) -> u64 {
        1 << (v >> 26) | 1 << (v >> 20 & 63) | 1 << (v >> 14 & 63)
    }

    /// Whether `v` may be one of the filter's values (false: it is not).
    #[inline(always)]
    fn has(&self, v: u32) -> bool {
        let m = Self::bits(v);
        self.words
            .get((v & self.mask) as usize)
            .is_some_and(|&w| w & m == m)
    }
}

/// [`EditPlan::attention`]: a query may name the symbol's shapes (or a
/// forced mesh's region holds them).
pub(crate) const ATTEND: u8 = 1;
/// [`EditPlan::attention`]: a key target may name the symbol's shapes.
pub(crate) const KEYED: u8 = 2;

/// The state of a node outside every exact target's path.
pub(crate) const NONE: u32 = u32::MAX;

/// The bit of [`EditPlan::leaves`] set on a trie state where some exact
/// target ends.
const FINAL: u8 = 4;

/// A system's edits for one derivation.
#[derive(Clone, Debug, Default)]
pub struct EditPlan {
    /// Per lowered edit: its id and action.
    actions: Vec<(u32, Action)>,
    /// The trie's first state, if the axiom's label is some target's first.
    root: Option<(Label, u32)>,
    /// The trie's states ([`TrieState`]): where each one's edges and
    /// final actions lie, which kinds of edge leave it, and signatures of
    /// its numbered and its ordinal edges. One record a state, so a shape
    /// on a target's path reads one cache line for all of them. Numbered
    /// in depth-first order (`trie::depth_first`), as the derivation
    /// meets them: the states and edges a floor's subtree reads lie
    /// together.
    states: Vec<TrieState>,
    /// The trie's edges, state by state (a state's from
    /// [`TrieState::edges`]), each state's sorted. One table, so the edges
    /// a lookup reads lie together: a floor's targeted tiles are one
    /// state's few edges, and a target's path, whose states were made one
    /// after another, is a run of the table (a hash map put each lookup on
    /// a cache line of its own, a miss on most: 5% of a derivation with
    /// 700 exact targets).
    trie_edges: Vec<TrieEdge>,
    /// The actions of the edits whose exact target ends at a trie state,
    /// state by state (a state's from [`TrieState::finals`]): one flat
    /// table, so a shape on a target's path costs a test of its state's
    /// [`FINAL`] bit, and a final one a slice of this table (no per-state
    /// list, no index into `actions`).
    final_actions: Vec<(u32, Action)>,
    /// The key targets: per key, its edits' action indices, each with
    /// the symbol its edit recorded (`Edit::symbol`; `None`: any).
    by_key: HashMap<u32, Vec<(u32, Option<SymbolId>)>>,
    /// A filter of the target keys ([`KeyFilter`]: one word, all clear,
    /// without key targets).
    key_filter: KeyFilter,
    /// Whether some edit targets a key.
    has_keys: bool,
    /// Per symbol (by id), whether a key target may name its shapes: its
    /// edit recorded that symbol, or none (then every symbol's). Only
    /// those symbols' shapes test their keys against the filter (a key
    /// picked on a window costs the tower's walls and panes nothing).
    keyed: Vec<bool>,
    /// Semantic queries grouped by pattern.
    semantic: Vec<Pattern>,
    /// Per symbol (by id), whether a query may name its shapes (one of
    /// its label or one without a label): empty without queries.
    queried: Vec<bool>,
    /// Per symbol (by id), what the derivation loop asks of a shape off
    /// every exact target's path ([`EditPlan::attention`]): [`ATTEND`]
    /// where a query may name it, [`KEYED`] where only a key target may
    /// (its key's filter bit decides); empty when no edit names shapes by
    /// key or query. `attend_all`: [`ATTEND`] for every symbol (a forced
    /// mesh's region, whose every shape has its inserts replaced).
    attend: Vec<u8>,
    attend_all: Vec<u8>,
    /// The same inside a quiet subtree (no query can name a shape there,
    /// [`EditPlan::quiet_children`]): key targets alone.
    attend_quiet: Vec<u8>,
    /// Per symbol (by id), whether its rule makes a command of a tag some
    /// query names (the derivation hands down which of that command's
    /// children no query can name below: [`EditPlan::quiet_children`]).
    hands_down: Vec<bool>,
    /// Per symbol (by id), the labels of patterns ([`Pattern::label`]) a
    /// shape of it or one below it can have, a bit per pattern (where
    /// there are at most 64 patterns; else empty and every pattern counts
    /// everywhere): a query on floors cannot name anything inside a
    /// floor's tiles, so it keeps none of them looked at.
    reach: Vec<u64>,
    /// Per tag (by id), its slot when a query names it (0: none; else the
    /// slot plus one, `NO_SLOT` past 64 tags): the tagged commands a path
    /// walk keeps, and the bit of a pattern's mask.
    slot: Vec<u8>,
    /// Per symbol (by id), the patterns of its queries.
    semantic_by_symbol: Vec<Vec<u32>>,
    /// The patterns of queries without a label.
    semantic_any: Vec<u32>,
    /// Edits the plan cannot replay: (id, why).
    unsupported: Vec<(u32, String)>,
    /// The edits lowered, as given, when some has an exact target:
    /// `crate::rewrap` finds those a wrapping put out of the trie's reach.
    pub(crate) lowered: Vec<Edit>,
}

/// The label of a node.
fn label(n: &Node) -> Label {
    match n.kind {
        NodeKind::Shape { symbol, .. } => Label::Symbol(symbol),
        NodeKind::Command { command, .. } => Label::Command(command),
        NodeKind::Insert { asset } => Label::Insert(asset),
    }
}

/// The edge a node was reached by (as `ShapeTree::exact_locator` writes it).
pub(crate) fn edge(n: &Node) -> EdgeRef {
    match n.selector {
        Some(selector) => EdgeRef::Component {
            selector,
            index: n.index,
        },
        None => EdgeRef::Number(n.edge),
    }
}

/// A label's text read back against the program.
fn parse_label(program: &Program, s: &str) -> Option<Label> {
    if let Some(sym) = program.symbol(s) {
        return Some(Label::Symbol(sym));
    }
    if let Some(asset) = s.strip_prefix("insert:") {
        return program
            .asset_names()
            .position(|a| a == asset)
            .map(|i| Label::Insert(AssetId(i as u32)));
    }
    let commands = crate::ir::Axis::ALL
        .iter()
        .flat_map(|&a| [Command::Split(a), Command::Repeat(a)])
        .chain(crate::ir::CompTarget::ALL.iter().map(|&t| Command::Comp(t)));
    commands
        .into_iter()
        .find(|c| c.label() == s)
        .map(Label::Command)
}

impl EditPlan {
    /// Lower `edits` (those of this program's system) to the program's
    /// ids. An edit whose target or operation names what the program
    /// lacks can match nothing and is left out (the classification after
    /// the derivation says why); `set` and `offset` are listed in
    /// [`EditPlan::unsupported`].
    pub fn new<'e>(program: &Program, edits: impl IntoIterator<Item = &'e Edit>) -> EditPlan {
        let mut plan = EditPlan::default();
        // Labels read back once each (a command's label is formatted).
        let mut labels: HashMap<String, Option<Label>> = HashMap::default();
        // The exact targets' trie as it is built.
        let mut build = ExactBuild::default();
        // The key targets' keys, for their filter.
        let mut key_values = Vec::new();
        for e in edits {
            let action = match &e.op {
                Op::Remove => Action::Remove,
                Op::Force { alternative } => Action::Force(alternative.saturating_sub(1)),
                Op::Pin { key } => Action::Pin(*key),
                Op::Material { name } => match program.materials().iter().position(|m| m == name) {
                    Some(i) => Action::Material(MaterialId(i as u32)),
                    None => continue,
                },
                Op::Mesh { name } => match program.asset_names().position(|a| a == name) {
                    Some(i) => Action::Mesh(AssetId(i as u32)),
                    None => continue,
                },
                Op::Set { .. } | Op::Offset { .. } => {
                    plan.unsupported.push((
                        e.id,
                        format!(
                            "`{}` is not replayed in shape mode (meta-parameters are numbers once the system is lowered)",
                            e.op.kind().as_str()
                        ),
                    ));
                    continue;
                }
            };
            let index = plan.actions.len() as u32;
            let lowered = match &e.target {
                Target::Key(k) => {
                    // A recorded symbol the program lacks: the key names
                    // nothing (the classification says so).
                    let symbol = match &e.symbol {
                        Some(name) => match program.symbol(name) {
                            Some(s) => Some(s),
                            None => continue,
                        },
                        None => None,
                    };
                    let keyed = &mut plan.keyed;
                    keyed.resize(program.symbols.len(), false);
                    match symbol {
                        Some(s) => keyed[s.0 as usize] = true,
                        None => keyed.fill(true),
                    }
                    plan.by_key.entry(*k).or_default().push((index, symbol));
                    key_values.push(*k);
                    plan.has_keys = true;
                    true
                }
                Target::Exact(loc) => {
                    plan.insert_exact(program, &mut labels, &mut build, loc, index)
                }
                Target::Semantic(q) => {
                    let label = match &q.label {
                        Some(l) => match program.symbol(l) {
                            Some(s) => Some(s),
                            None => continue,
                        },
                        None => None,
                    };
                    let entries: Option<Vec<(TagId, Anchor)>> = q
                        .entries
                        .iter()
                        .map(|(t, a, _)| Some((program.tag(t)?, *a)))
                        .collect();
                    let Some(entries) = entries else { continue };
                    let wants: Box<[i64]> = q.entries.iter().map(|e| e.2).collect();
                    plan.insert_query(label, entries, wants, index);
                    true
                }
            };
            if lowered {
                plan.actions.push((e.id, action));
                plan.lowered.push(e.clone());
            }
        }
        plan.key_filter = KeyFilter::of(&key_values);
        // The trie's edges laid out by state, each state's sorted.
        let mut edges: Vec<(u32, TrieEdge)> = build
            .trie
            .into_iter()
            .map(|((from, label, edge), to)| {
                let (label, edge) = TrieEdge::pack(label, &edge);
                (from, TrieEdge { label, edge, to })
            })
            .collect();
        edges.sort_unstable_by_key(|(from, e)| (*from, e.label, e.edge));
        let (mut finals, mut leaves) = (build.finals, build.leaves);
        if let Some((l, root)) = plan.root {
            trie::depth_first(root, &mut edges, &mut finals, &mut leaves);
            plan.root = Some((l, 0));
        }
        plan.states = Vec::with_capacity(finals.len());
        let mut at = 0;
        for (s, f) in finals.iter().enumerate() {
            let from = at;
            let (mut sig, mut osig) = (0u64, 0u64);
            while let Some((_, e)) = edges.get(at).filter(|(from, _)| *from as usize == s) {
                match TrieEdge::sig_bit(e.edge) {
                    (true, b) => osig |= 1 << b,
                    (false, b) => sig |= 1 << b,
                }
                at += 1;
            }
            let before = plan.final_actions.len();
            let actions = &plan.actions;
            plan.final_actions
                .extend(f.iter().filter_map(|&i| actions.get(i as usize).copied()));
            let done = plan.final_actions.len();
            let mut flags = leaves.get(s).copied().unwrap_or(0);
            if done > before {
                flags |= FINAL;
            }
            plan.states.push(TrieState {
                sig,
                osig,
                edges: (from as u32, at as u32),
                finals: (before as u32, done as u32),
                flags,
            });
        }
        plan.trie_edges = edges.into_iter().map(|(_, e)| e).collect();
        // The symbols and tags the queries name, by id.
        if !plan.semantic.is_empty() {
            let any = !plan.semantic_any.is_empty();
            plan.queried = (0..program.symbols.len())
                .map(|s| {
                    any || plan
                        .semantic_by_symbol
                        .get(s)
                        .is_some_and(|q| !q.is_empty())
                })
                .collect();
            let mut slots = 0u8;
            for p in &mut plan.semantic {
                let mut mask = Some(0u64);
                for &(t, _) in &p.entries {
                    let i = t.0 as usize;
                    if plan.slot.len() <= i {
                        plan.slot.resize(i + 1, 0);
                    }
                    if plan.slot[i] == 0 {
                        plan.slot[i] = if slots < 64 { slots + 1 } else { NO_SLOT };
                        slots = slots.saturating_add(1);
                    }
                    mask = match (mask, plan.slot[i]) {
                        (Some(m), s) if s != NO_SLOT && m >> (s - 1) & 1 == 0 => {
                            Some(m | 1 << (s - 1))
                        }
                        _ => None,
                    };
                }
                p.mask = mask;
            }
        }
        // The symbols whose rules make a command of a tag a query names.
        let symbols = program.symbols.len();
        if !plan.semantic.is_empty() {
            let named = |t: Option<TagId>| {
                t.is_some_and(|t| plan.slot.get(t.0 as usize).is_some_and(|&s| s != 0))
            };
            plan.hands_down = program
                .symbols
                .iter()
                .map(|info| {
                    info.rule.iter().flat_map(|r| &r.alternatives).any(|alt| {
                        alt.ops.iter().any(|op| match op {
                            crate::ir::Op::Split(s) | crate::ir::Op::Repeat(s) => named(s.tag),
                            crate::ir::Op::Comp(c) => named(c.tag),
                            _ => false,
                        })
                    })
                })
                .collect();
        }
        if !plan.semantic.is_empty() {
            plan.reach = reach(program, &plan.semantic);
        }
        // What the loop asks of a shape off every exact target's path.
        if plan.names_any() {
            let keyed = |s: usize| {
                if plan.keyed.get(s).copied().unwrap_or(false) {
                    KEYED
                } else {
                    0
                }
            };
            plan.attend = (0..symbols)
                .map(|s| {
                    let queried = plan.queried.get(s).copied().unwrap_or(false);
                    let hands = plan.hands_down.get(s).copied().unwrap_or(false);
                    if queried || hands { ATTEND } else { keyed(s) }
                })
                .collect();
            if plan.has_keys {
                plan.attend_quiet = (0..symbols).map(keyed).collect();
            }
        }
        if plan.actions.iter().any(|a| matches!(a.1, Action::Mesh(_))) {
            plan.attend_all = vec![ATTEND; symbols];
        }
        plan
    }

    /// Add a semantic query (its label, pattern and wanted indices) for
    /// edit `edit`: to the pattern's group under the label, made if new.
    fn insert_query(
        &mut self,
        label: Option<SymbolId>,
        entries: Vec<(TagId, Anchor)>,
        wants: Box<[i64]>,
        edit: u32,
    ) {
        let list = match label {
            Some(s) => {
                let i = s.0 as usize;
                if self.semantic_by_symbol.len() <= i {
                    self.semantic_by_symbol.resize(i + 1, Vec::new());
                }
                &mut self.semantic_by_symbol[i]
            }
            None => &mut self.semantic_any,
        };
        let k = match list
            .iter()
            .find(|&&k| self.semantic[k as usize].entries == entries)
        {
            Some(&k) => k,
            None => {
                list.push(self.semantic.len() as u32);
                self.semantic.push(Pattern {
                    label,
                    entries,
                    ..Pattern::default()
                });
                self.semantic.len() as u32 - 1
            }
        };
        let h = wants.iter().fold(MIX_SEED, |h, &v| mix(h, v));
        let bit = (h >> 56) as usize;
        self.semantic[k as usize].filter[bit / 64] |= 1 << (bit % 64);
        if let Some((&last, before)) = wants.split_last() {
            let prefix = before.iter().fold(MIX_SEED, |h, &v| mix(h, v));
            self.semantic[k as usize]
                .lasts
                .entry(prefix)
                .or_default()
                .push(last);
        }
        let lists = self.semantic[k as usize].wants.entry(h).or_default();
        match lists.iter_mut().find(|(w, _)| *w == wants) {
            Some((_, edits)) => edits.push(edit),
            None => lists.push((wants, vec![edit])),
        }
    }

    /// Whether the plan has no edit to replay.
    pub fn is_empty(&self) -> bool {
        self.actions.is_empty()
    }

    /// The edits the plan cannot replay, with why.
    pub fn unsupported(&self) -> &[(u32, String)] {
        &self.unsupported
    }

    /// Whether some edit names shapes by key or by query (without, only
    /// the shapes on an exact target's path can be named).
    #[inline]
    pub(crate) fn names_any(&self) -> bool {
        self.has_keys || !self.semantic.is_empty()
    }

    /// The per-symbol table the derivation loop reads for a shape off
    /// every exact target's path (before [`EditPlan::matches`]): its byte
    /// for the shape's symbol is 0 where neither a key target nor a query
    /// can name it (most shapes of a building: one load and a test, with
    /// the table's slice held by the loop), [`ATTEND`] where a query may,
    /// [`KEYED`] where a key target may and its key's filter bit decides
    /// ([`EditPlan::key_bit`]). `meshed`: inside a forced mesh's region,
    /// where every shape is attended.
    /// `quiet`: inside a subtree no query can name a shape of
    /// ([`EditPlan::quiet_children`]), where only key targets are looked
    /// for.
    #[inline]
    pub(crate) fn attention(&self, meshed: bool, quiet: bool) -> &[u8] {
        if meshed {
            &self.attend_all
        } else if quiet {
            &self.attend_quiet
        } else {
            &self.attend
        }
    }

    /// Whether the shapes of `symbol` make a command of a tag some query
    /// names ([`EditPlan::quiet_children`] is asked after their rule run).
    #[inline]
    pub(crate) fn hands_down(&self, symbol: SymbolId) -> bool {
        self.hands_down
            .get(symbol.0 as usize)
            .copied()
            .unwrap_or(false)
    }

    /// The patterns (a bit each) whose label a shape of `symbol` or one
    /// below it can have ([`EditPlan::reach`]); every pattern where the
    /// plan keeps no table.
    #[inline]
    pub(crate) fn reaches(&self, symbol: SymbolId) -> u64 {
        if self.reach.is_empty() {
            return u64::MAX;
        }
        self.reach
            .get(symbol.0 as usize)
            .copied()
            .unwrap_or(u64::MAX)
    }

    /// Whether `key`'s filter bit is set (some key target may be `key`).
    #[inline]
    pub(crate) fn key_bit(&self, key: u32) -> bool {
        self.key_filter.has(key)
    }

    /// Whether the plan has semantic queries (which read the tagged
    /// commands above a parallel job's root).
    pub(crate) fn has_semantic(&self) -> bool {
        !self.semantic.is_empty()
    }

    /// The actions of the edits whose target is the shape `nodes[at]`
    /// (its trie state `state`), pushed on `out` as (edit id, action).
    /// `prefix`: the tagged commands above `nodes[0]` (a parallel job's
    /// root), innermost first. Inlined into its one caller,
    /// `Engine::own_edits` (itself inlined into `Engine::replayed`, out of
    /// the derivation loop).
    #[inline(always)]
    pub(crate) fn matches(
        &self,
        nodes: &[Node],
        at: usize,
        state: u32,
        prefix: &[(TagId, u32, u32)],
        scratch: &mut PathScratch,
        out: &mut Vec<(u32, Action)>,
    ) {
        let n = &nodes[at];
        if let Some(st) = self.states.get(state as usize)
            && st.flags & FINAL != 0
            && let Some(f) = self
                .final_actions
                .get(st.finals.0 as usize..st.finals.1 as usize)
        {
            out.extend_from_slice(f);
        }
        let mut push = |i: u32| {
            if let Some(a) = self.actions.get(i as usize) {
                out.push(*a);
            }
        };
        let NodeKind::Shape { symbol, .. } = n.kind else {
            return;
        };
        // A key target's edits whose recorded symbol is this shape's, or
        // which recorded none.
        if self.key_bit(n.key)
            && let Some(f) = self.by_key.get(&n.key)
        {
            f.iter()
                .filter(|(_, s)| s.is_none_or(|s| s == symbol))
                .for_each(|&(i, _)| push(i));
        }
        let by_label = self
            .semantic_by_symbol
            .get(symbol.0 as usize)
            .filter(|q| !q.is_empty());
        if by_label.is_none() && self.semantic_any.is_empty() {
            return;
        }
        // The tagged commands on the path of the tags some query names,
        // innermost first, read once for all the patterns.
        // Up to the innermost tagged command, and no further when it is
        // the last path's: the entries above it, and each pattern's
        // reading of them, are kept.
        let w = scratch;
        w.tags.clear();
        let mut innermost = None;
        let mut known = false;
        let mut cur = at;
        while cur > 0 {
            let up = nodes[cur].parent_offset as usize;
            if up == 0 || up > cur {
                break;
            }
            let p = cur - up;
            // The last path's innermost tagged command, its tag known.
            if innermost.is_none()
                && let Some((q, t)) = w.above_at
                && q == p
            {
                keep(
                    &self.slot,
                    &mut w.tags,
                    (t, nodes[cur].index, nodes[cur].count),
                );
                known = true;
                break;
            }
            if let NodeKind::Command { tag: Some(t), .. } = nodes[p].kind {
                keep(
                    &self.slot,
                    &mut w.tags,
                    (t, nodes[cur].index, nodes[cur].count),
                );
                if innermost.is_none() {
                    innermost = Some((p, w.tags.len(), t));
                }
            }
            cur = p;
        }
        if !known {
            w.gate.symbol = None;
            for &entry in prefix {
                keep(&self.slot, &mut w.tags, entry);
            }
            match innermost {
                Some((p, from, t)) => {
                    w.above_at = Some((p, t));
                    w.above.clear();
                    w.above.extend_from_slice(&w.tags[from..]);
                    w.tags.truncate(from);
                    w.readings.clear();
                    for pattern in &self.semantic {
                        let mut r = Reading::START;
                        w.above.iter().rev().for_each(|e| pattern.read(&mut r, e));
                        w.readings.push(r);
                    }
                }
                // No tagged command on the path: nothing above.
                None => {
                    w.above_at = None;
                    w.above.clear();
                    w.readings.clear();
                    w.readings.resize(self.semantic.len(), Reading::START);
                }
            }
        }
        // `grm_edits::SemanticQuery::matches` on ids, a pattern at a time:
        // the path's entries of the tags a query names are exactly the
        // query's, in order, each at its anchored index.
        // A pattern whose reading of the kept entries failed is done.
        // Below the kept entries, only the innermost tagged command's
        // child: the gate says whether a query may name it.
        if let [e] = w.tags[..]
            && w.above_at.is_some()
        {
            if w.gate.symbol != Some(symbol) {
                let patterns = by_label.into_iter().flatten().chain(&self.semantic_any);
                self.gate(&mut w.gate, symbol, &e, &w.readings, patterns);
            }
            if !w.gate.lets(e.index) {
                return;
            }
        }
        let (above, below, readings) = (&w.above[..], &w.tags[..], &w.readings[..]);
        let mut each = |k: u32| {
            let k = k as usize;
            let (Some(pattern), Some(&r)) = (self.semantic.get(k), readings.get(k)) else {
                return;
            };
            if r.failed {
                return;
            }
            let r = pattern.read_below(r, below);
            if let Some(edits) = pattern.edits(r, above, below) {
                edits.iter().for_each(|&i| push(i));
            }
        };
        // One call site: the reading inlined.
        for &k in by_label.into_iter().flatten().chain(&self.semantic_any) {
            each(k);
        }
    }
}

/// What the edits reaching one node decide (scoping: the node's own
/// winners over those it inherited).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Forced {
    pub(crate) material: Option<MaterialId>,
    pub(crate) mesh: Option<AssetId>,
}

/// The node's own edits resolved: per slot, the larger id wins.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Own {
    pub(crate) remove: bool,
    pub(crate) force: Option<u32>,
    pub(crate) pin: Option<u32>,
    pub(crate) material: Option<MaterialId>,
    pub(crate) mesh: Option<AssetId>,
}

impl Own {
    /// From the node's matched edits.
    pub(crate) fn of(matched: &[(u32, Action)]) -> Own {
        let mut own = Own::default();
        let mut best = [0u32; 5];
        for &(id, a) in matched {
            let slot = match a {
                Action::Remove => 0,
                Action::Force(_) => 1,
                Action::Pin(_) => 2,
                Action::Material(_) => 3,
                Action::Mesh(_) => 4,
            };
            if id < best[slot] {
                continue;
            }
            best[slot] = id;
            match a {
                Action::Remove => own.remove = true,
                Action::Force(k) => own.force = Some(k),
                Action::Pin(k) => own.pin = Some(k),
                Action::Material(m) => own.material = Some(m),
                Action::Mesh(m) => own.mesh = Some(m),
            }
        }
        own
    }
}

/// [`EditPlan::reach`]: per symbol, a bit for each pattern whose label a
/// shape of the symbol or one below it can have (every alternative of
/// every rule followed: emitted successors, split and repeat parts,
/// component cases); empty past 64 patterns.
fn reach(program: &Program, patterns: &[Pattern]) -> Vec<u64> {
    let n = program.symbols.len();
    if patterns.len() > 64 {
        return Vec::new();
    }
    // The symbols each symbol's rules make.
    let made: Vec<Vec<usize>> = program
        .symbols
        .iter()
        .map(|info| {
            let mut v = Vec::new();
            for alt in info.rule.iter().flat_map(|r| &r.alternatives) {
                for op in &alt.ops {
                    match op {
                        crate::ir::Op::Emit(t) => v.push(t.0 as usize),
                        crate::ir::Op::Split(sp) | crate::ir::Op::Repeat(sp) => v.extend(
                            sp.parts
                                .iter()
                                .filter_map(|p| p.target)
                                .map(|t| t.0 as usize),
                        ),
                        crate::ir::Op::Comp(c) => v.extend(
                            c.cases
                                .iter()
                                .filter_map(|c| c.target)
                                .map(|t| t.0 as usize),
                        ),
                        _ => {}
                    }
                }
            }
            v
        })
        .collect();
    // Own bits: the patterns labelled with the symbol, and every unlabelled one.
    let any: u64 = patterns
        .iter()
        .enumerate()
        .filter(|(_, p)| p.label.is_none())
        .fold(0, |m, (k, _)| m | 1 << k);
    let mut bits = vec![any; n];
    for (k, p) in patterns.iter().enumerate() {
        if let Some(b) = p.label.and_then(|l| bits.get_mut(l.0 as usize)) {
            *b |= 1 << k;
        }
    }
    // What a symbol reaches is its own and what the symbols it makes
    // reach: to a fixed point (recursion included).
    loop {
        let mut changed = false;
        for s in 0..n {
            let below = made[s]
                .iter()
                .fold(0, |m, &t| m | bits.get(t).copied().unwrap_or(0));
            if bits[s] | below != bits[s] {
                bits[s] |= below;
                changed = true;
            }
        }
        if !changed {
            return bits;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::KeyFilter;

    /// `n` random 32-bit hashes (keys are hashes).
    fn hashes(seed: u64, n: usize) -> Vec<u32> {
        let mut rng = grm_testkit::Rng::new(seed);
        (0..n).map(|_| rng.next_u64() as u32).collect()
    }

    /// `reach`: a pattern counts at a symbol whose shapes, or shapes
    /// below them, can carry its label (recursion and `Emit` followed), and
    /// an unlabelled one everywhere.
    #[test]
    fn a_pattern_reaches_the_symbols_above_its_label() {
        use super::{Pattern, reach};
        use crate::ir::{Axis, Op, Part, ProgramBuilder, Split};
        let mut b = ProgramBuilder::new("reach");
        let [facade, floor, tile, window, ledge] =
            ["Facade", "Floor", "Tile", "Window", "Ledge"].map(|n| b.symbol(n));
        let split = |parts: Vec<Part>| {
            Op::Repeat(Split {
                axis: Axis::Y,
                parts,
                tag: None,
            })
        };
        b.rule(facade, vec![split(vec![Part::abs(3.0, Some(floor))])]);
        b.rule(
            floor,
            vec![split(vec![
                Part::abs(2.0, Some(tile)),
                Part::abs(0.2, Some(ledge)),
            ])],
        );
        b.rule(tile, vec![Op::Emit(window)]);
        // A ledge makes a ledge again (recursion) and nothing else.
        b.rule(ledge, vec![split(vec![Part::rel(0.5, Some(ledge))])]);
        let program = b.build(facade).expect("a program");
        let patterns = [Some(floor), Some(window), None].map(|label| Pattern {
            label,
            ..Pattern::default()
        });
        let r = reach(&program, &patterns);
        let at = |s: crate::ir::SymbolId| r[s.0 as usize];
        // Bit 0: floors, bit 1: windows, bit 2: unlabelled.
        assert_eq!(at(facade), 0b111);
        assert_eq!(at(floor), 0b111);
        assert_eq!(at(tile), 0b110, "no floor inside a tile");
        assert_eq!(at(window), 0b110);
        assert_eq!(at(ledge), 0b100, "a ledge holds only ledges");
        // Past 64 patterns: no table (every pattern counts everywhere).
        assert!(reach(&program, &vec![Pattern::default(); 65]).is_empty());
    }

    #[test]
    fn the_key_filter_passes_its_keys_and_few_others() {
        // Up to 4,096 keys (past that the filter stays at its 8 KiB and
        // passes more).
        for n in [1, 7, 200, 1000, 4000] {
            let keys = hashes(n as u64, n);
            let f = KeyFilter::of(&keys);
            assert!(keys.iter().all(|&k| f.has(k)), "{n} keys: one missed");
            // The size the loop relies on: about 16 bits a key, in the
            // first-level cache for the usual few hundred.
            assert!(f.words.len() * 64 <= 32 * n.next_power_of_two().max(2));
            let others = hashes(n as u64 + 99, 100_000);
            let passed = others.iter().filter(|&&k| f.has(k)).count();
            // Three bits of a 64-bit word at 16 bits a key: about 0.4%
            // (the tower's 200 keys: one in 230), never near 1%.
            assert!(
                passed < 1_000,
                "{n} keys: {passed} of 100,000 others passed"
            );
        }
    }
}

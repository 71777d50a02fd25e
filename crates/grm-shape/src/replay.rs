//! Persistent edits replayed while the engine derives (Lipp, 3.2;
//! docs/edits.md, "Replay"): an [`EditPlan`] is a system's edits
//! (`grm_edits::Edit`) lowered to this program's ids, which the derivation
//! loop consults at every shape it is about to expand.
//!
//! Finding an edit's parts costs nothing where no edit is:
//!
//! - **exact** targets form a trie over (label, edge) from the axiom; each
//!   node of the tree carries its state in it, computed from its parent's
//!   with one hash lookup, and only while its path is a prefix of some
//!   target's (a node off every target's path is `NONE` and its subtree is
//!   never looked up again);
//! - **key** targets are a hash map from identity keys, consulted for
//!   every shape (one lookup);
//! - **semantic** queries are indexed by their label; a shape of a
//!   queried symbol walks up its path once to collect its tagged commands.
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

/// A node's label as the plan compares it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Label {
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

/// A semantic query's entries in the program's ids: (tag, anchor, index).
type QueryIds = Vec<(TagId, Anchor, i64)>;

/// The state of a node outside every exact target's path.
pub(crate) const NONE: u32 = u32::MAX;

/// A system's edits for one derivation.
#[derive(Clone, Debug, Default)]
pub struct EditPlan {
    /// Per lowered edit: its id and action.
    actions: Vec<(u32, Action)>,
    /// The trie's first state, if the axiom's label is some target's first.
    root: Option<(Label, u32)>,
    trie: HashMap<(u32, Label, EdgeRef), u32>,
    /// Per trie state, the edits whose target ends there.
    finals: Vec<Vec<u32>>,
    by_key: HashMap<u32, Vec<u32>>,
    /// Semantic queries: (label, entries, edit), indexed by label.
    semantic: Vec<(QueryIds, u32)>,
    /// Per symbol (by id), its queries.
    semantic_by_symbol: Vec<Vec<u32>>,
    semantic_any: Vec<u32>,
    /// Edits the plan cannot replay: (id, why).
    unsupported: Vec<(u32, String)>,
    /// Whether an edit passes a material or mesh down its subtree.
    forces: bool,
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
                    plan.by_key.entry(*k).or_default().push(index);
                    true
                }
                Target::Exact(loc) => plan.insert_exact(program, loc, index),
                Target::Semantic(q) => {
                    let label = match &q.label {
                        Some(l) => match program.symbol(l) {
                            Some(s) => Some(s),
                            None => continue,
                        },
                        None => None,
                    };
                    let entries: Option<QueryIds> = q
                        .entries
                        .iter()
                        .map(|(t, a, i)| Some((program.tag(t)?, *a, *i)))
                        .collect();
                    let Some(entries) = entries else { continue };
                    let k = plan.semantic.len() as u32;
                    plan.semantic.push((entries, index));
                    match label {
                        Some(s) => {
                            let i = s.0 as usize;
                            if plan.semantic_by_symbol.len() <= i {
                                plan.semantic_by_symbol.resize(i + 1, Vec::new());
                            }
                            plan.semantic_by_symbol[i].push(k);
                        }
                        None => plan.semantic_any.push(k),
                    }
                    true
                }
            };
            if lowered {
                plan.forces |= matches!(action, Action::Material(_) | Action::Mesh(_));
                plan.actions.push((e.id, action));
            }
        }
        plan
    }

    /// Add an exact target's path to the trie; false when a label is not
    /// the program's (it can match nothing).
    fn insert_exact(&mut self, program: &Program, loc: &crate::ExactLocator, edit: u32) -> bool {
        if loc.labels.len() != loc.edges.len() + 1 {
            return false;
        }
        let labels: Option<Vec<Label>> =
            loc.labels.iter().map(|l| parse_label(program, l)).collect();
        let Some(labels) = labels else { return false };
        let state = match self.root {
            Some((l, s)) if l == labels[0] => s,
            Some(_) => return false,
            None => {
                self.finals.push(Vec::new());
                let s = self.finals.len() as u32 - 1;
                self.root = Some((labels[0], s));
                s
            }
        };
        let mut state = state;
        for (l, e) in labels[1..].iter().zip(&loc.edges) {
            let next = self.finals.len() as u32;
            state = *self.trie.entry((state, *l, e.clone())).or_insert(next);
            if state == next {
                self.finals.push(Vec::new());
            }
        }
        self.finals[state as usize].push(edit);
        true
    }

    /// Whether the plan has no edit to replay.
    pub fn is_empty(&self) -> bool {
        self.actions.is_empty()
    }

    /// The edits the plan cannot replay, with why.
    pub fn unsupported(&self) -> &[(u32, String)] {
        &self.unsupported
    }

    /// Whether an edit passes something down a subtree (material, mesh).
    pub(crate) fn forces(&self) -> bool {
        self.forces
    }

    /// Whether an edit may name the shape of `symbol` with key `key` whose
    /// trie state is `state` (what [`EditPlan::matches`] would look at):
    /// most shapes of a building are named by none, and cost this alone.
    #[inline]
    pub(crate) fn may_match(&self, state: u32, symbol: SymbolId, key: u32) -> bool {
        state != NONE
            || (!self.by_key.is_empty() && self.by_key.contains_key(&key))
            || !self.semantic_any.is_empty()
            || self
                .semantic_by_symbol
                .get(symbol.0 as usize)
                .is_some_and(|q| !q.is_empty())
    }

    /// Whether nodes need trie states (the plan has exact targets).
    pub(crate) fn has_exact(&self) -> bool {
        self.root.is_some()
    }

    /// The axiom's trie state.
    pub(crate) fn root_state(&self, axiom: &Node) -> u32 {
        match self.root {
            Some((l, s)) if l == label(axiom) => s,
            _ => NONE,
        }
    }

    /// A child's trie state from its parent's.
    #[inline]
    pub(crate) fn step(&self, parent: u32, child: &Node) -> u32 {
        if parent == NONE {
            return NONE;
        }
        self.trie
            .get(&(parent, label(child), edge(child)))
            .copied()
            .unwrap_or(NONE)
    }

    /// The actions of the edits whose target is the shape `nodes[at]`
    /// (its trie state `state`), pushed on `out` as (edit id, action).
    /// `tags` is scratch space.
    pub(crate) fn matches(
        &self,
        nodes: &[Node],
        at: usize,
        state: u32,
        tags: &mut Vec<(TagId, u32, u32)>,
        out: &mut Vec<(u32, Action)>,
    ) {
        let n = &nodes[at];
        let mut push = |i: u32| {
            if let Some(a) = self.actions.get(i as usize) {
                out.push(*a);
            }
        };
        if state != NONE
            && let Some(f) = self.finals.get(state as usize)
        {
            f.iter().for_each(|&i| push(i));
        }
        if !self.by_key.is_empty()
            && let Some(f) = self.by_key.get(&n.key)
        {
            f.iter().for_each(|&i| push(i));
        }
        let NodeKind::Shape { symbol, .. } = n.kind else {
            return;
        };
        let by_label = self
            .semantic_by_symbol
            .get(symbol.0 as usize)
            .filter(|q| !q.is_empty());
        if by_label.is_none() && self.semantic_any.is_empty() {
            return;
        }
        // The tagged commands on the path, root first.
        tags.clear();
        crate::engine::walk_up(nodes, at, |p, child| {
            if let NodeKind::Command { tag: Some(t), .. } = nodes[p].kind {
                tags.push((t, nodes[child].index, nodes[child].count));
            }
        });
        tags.reverse();
        for &k in by_label.into_iter().flatten().chain(&self.semantic_any) {
            let (entries, edit) = &self.semantic[k as usize];
            if semantic_match(entries, tags) {
                push(*edit);
            }
        }
    }
}

/// `grm_edits::SemanticQuery::matches` on ids: the path's entries of the
/// tags the query names are exactly the query's, in order, each at its
/// anchored index.
fn semantic_match(query: &[(TagId, Anchor, i64)], path: &[(TagId, u32, u32)]) -> bool {
    let named = |t: TagId| query.iter().any(|q| q.0 == t);
    let mut kept = path.iter().filter(|e| named(e.0));
    for &(tag, anchor, want) in query {
        match kept.next() {
            Some(&(t, index, count)) if t == tag && anchor.index(index, count) == want => {}
            _ => return false,
        }
    }
    kept.next().is_none()
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

//! The exact targets' trie (`crate::replay`): its edges laid out by state
//! and sorted, built from the targets' locators, and the states of a
//! block's nodes from their parents' as the derivation makes them.

use super::{EdgeRef, EditPlan, Label, NONE, edge, label, parse_label};
use crate::ir::Program;
use crate::tree::Command;
use crate::tree::Node;
use foldhash::HashMap;

/// An edge of the exact targets' trie: its label and edge packed in two
/// words ([`TrieEdge::pack`]; a state's edges are sorted by them), and the
/// state it leads to.
#[derive(Clone, Copy, Debug)]
pub(super) struct TrieEdge {
    pub(super) label: u64,
    pub(super) edge: u64,
    pub(super) to: u32,
}

/// A state of the exact targets' trie, as the derivation reads it.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct TrieState {
    /// A bit for each numbered or component edge leaving the state (its
    /// number or index modulo 64, [`TrieEdge::sig_bit`]): a child whose
    /// bit is clear is on no target's path by such an edge, known without
    /// a look at the edges (most of a targeted floor's hundred tiles).
    pub(super) sig: u64,
    /// The same for its ordinal edges (their ordinal modulo 64).
    pub(super) osig: u64,
    /// Its edges: `trie_edges[edges.0..edges.1]`.
    pub(super) edges: (u32, u32),
    /// The actions of the edits whose target ends here:
    /// `final_actions[finals.0..finals.1]`.
    pub(super) finals: (u32, u32),
    /// Bit 0: a numbered or component edge leaves it; bit 1: an ordinal
    /// one (`step` looks up only those); [`super::FINAL`]: some target
    /// ends here.
    pub(super) flags: u8,
}

impl TrieEdge {
    /// A packed edge's signature bit: whether it is an ordinal edge (its
    /// bit is then one of [`TrieState::osig`], else of
    /// [`TrieState::sig`]), and its number, index or ordinal modulo 64.
    #[inline]
    pub(super) fn sig_bit(edge: u64) -> (bool, u32) {
        (edge >> 40 == 1, edge as u32 & 63)
    }

    /// `label` and `edge` as two words, each kind above its number.
    #[inline]
    pub(super) fn pack(label: Label, edge: &EdgeRef) -> (u64, u64) {
        let l = match label {
            Label::Symbol(s) => u64::from(s.0),
            Label::Command(c) => {
                let code = match c {
                    Command::Split(a) => a.index() as u64,
                    Command::Repeat(a) => 4 + a.index() as u64,
                    Command::Comp(t) => 8 + t as u64,
                };
                1 << 32 | code
            }
            Label::Insert(a) => 2 << 32 | u64::from(a.0),
        };
        let e = match *edge {
            EdgeRef::Number(k) => u64::from(k),
            EdgeRef::Ordinal(k) => 1 << 40 | u64::from(k),
            EdgeRef::Component { selector, index } => {
                2 << 40 | (selector as u64) << 32 | u64::from(index)
            }
        };
        (l, e)
    }
}

/// The exact targets' trie while [`EditPlan::new`] builds it: per state
/// the edits whose target ends there, and the edges.
#[derive(Default)]
pub(super) struct ExactBuild {
    pub(super) finals: Vec<Vec<u32>>,
    /// Per state, the kinds of edge that leave it ([`TrieState::flags`]).
    pub(super) leaves: Vec<u8>,
    pub(super) trie: HashMap<(u32, Label, EdgeRef), u32>,
}

/// Renumber the trie's states in depth-first order from `root` (which
/// becomes 0), each state's children in its edges' order: `edges` (per
/// state, sorted by (from, label, edge)), `finals` and `leaves` are
/// rewritten in the new numbering. The derivation walks the tree depth
/// first, so it then reads the states and edges of one subtree (a
/// floor's targeted tiles and their windows) from one run of each table,
/// where the order the targets were added in (the file's, at random
/// over the building) put each path's states far apart: a miss in the
/// second-level cache at most shapes on a path, since the derivation's
/// nodes stream through it (about 2 points of the tower's derivation
/// with 1,000 edits, session 33). A trie is a tree (a state is made for
/// one (parent, label, edge)), so each state is met once.
pub(super) fn depth_first(
    root: u32,
    edges: &mut [(u32, TrieEdge)],
    finals: &mut Vec<Vec<u32>>,
    leaves: &mut Vec<u8>,
) {
    let n = finals.len();
    // Each state's edges: `edges[start[s]..start[s + 1]]`.
    let mut start = vec![0usize; n + 1];
    for &(from, _) in edges.iter() {
        if let Some(c) = start.get_mut(from as usize + 1) {
            *c += 1;
        }
    }
    for i in 0..n {
        start[i + 1] += start[i];
    }
    let mut new_id = vec![u32::MAX; n];
    let mut order: Vec<usize> = Vec::with_capacity(n);
    let mut stack = vec![root as usize];
    while let Some(s) = stack.pop() {
        if s >= n || new_id[s] != u32::MAX {
            continue;
        }
        new_id[s] = order.len() as u32;
        order.push(s);
        // The first child on top: visited first.
        stack.extend(
            edges[start[s]..start[s + 1]]
                .iter()
                .rev()
                .map(|(_, e)| e.to as usize),
        );
    }
    // States the root does not reach (none in a trie built from the
    // root) keep their place after the others.
    for (s, id) in new_id.iter_mut().enumerate() {
        if *id == u32::MAX {
            *id = order.len() as u32;
            order.push(s);
        }
    }
    for (from, e) in edges.iter_mut() {
        *from = new_id[*from as usize];
        e.to = new_id[e.to as usize];
    }
    edges.sort_unstable_by_key(|(from, e)| (*from, e.label, e.edge));
    let mut old = std::mem::take(finals);
    *finals = order.iter().map(|&o| std::mem::take(&mut old[o])).collect();
    *leaves = order
        .iter()
        .map(|&o| leaves.get(o).copied().unwrap_or(0))
        .collect();
}

impl EditPlan {
    /// Add an exact target's path to the trie; false when a label is not
    /// the program's (it can match nothing). `known`: labels read so far.
    pub(super) fn insert_exact(
        &mut self,
        program: &Program,
        known: &mut HashMap<String, Option<Label>>,
        build: &mut ExactBuild,
        loc: &crate::ExactLocator,
        edit: u32,
    ) -> bool {
        if loc.labels.len() != loc.edges.len() + 1 {
            return false;
        }
        let labels: Option<Vec<Label>> = loc
            .labels
            .iter()
            .map(|l| match known.get(l.as_str()) {
                Some(&label) => label,
                None => *known
                    .entry(l.clone())
                    .or_insert_with(|| parse_label(program, l)),
            })
            .collect();
        let Some(labels) = labels else { return false };
        let ExactBuild {
            finals,
            leaves,
            trie,
        } = build;
        let state = match self.root {
            Some((l, s)) if l == labels[0] => s,
            Some(_) => return false,
            None => {
                finals.push(Vec::new());
                leaves.push(0);
                let s = finals.len() as u32 - 1;
                self.root = Some((labels[0], s));
                s
            }
        };
        let mut state = state;
        for (l, e) in labels[1..].iter().zip(&loc.edges) {
            match *e {
                EdgeRef::Ordinal(_) => leaves[state as usize] |= 2,
                EdgeRef::Number(_) | EdgeRef::Component { .. } => leaves[state as usize] |= 1,
            }
            let next = finals.len() as u32;
            state = *trie.entry((state, *l, e.clone())).or_insert(next);
            if state == next {
                finals.push(Vec::new());
                leaves.push(0);
            }
        }
        finals[state as usize].push(edit);
        true
    }

    /// The axiom's trie state.
    pub(crate) fn root_state(&self, axiom: &Node) -> u32 {
        match self.root {
            Some((l, s)) if l == label(axiom) => s,
            _ => NONE,
        }
    }

    /// The trie states of the block `block` (the nodes the shape at
    /// `at`, trie state `state`, made from `start` on: parent offsets are
    /// relative, so a node's parent is `at` or a command before it in the
    /// block), in `out`, one per node. An ordinal edge (`#k`) is counted
    /// in one pass over the block (`counts`: scratch, per parent and label
    /// the siblings seen so far), and only under a parent some target
    /// leaves by an ordinal edge: what `ShapeTree::ordinal` gives.
    pub(crate) fn block_states(
        &self,
        block: &[Node],
        start: usize,
        at: usize,
        state: u32,
        out: &mut Vec<u32>,
        counts: &mut Vec<(usize, Label, u32)>,
    ) {
        out.clear();
        counts.clear();
        if self.repeat_states(block, start, at, state, out, counts) {
            return;
        }
        for (k, n) in block.iter().enumerate() {
            let p = (start + k).wrapping_sub(n.parent_offset as usize);
            let parent = if p == at {
                state
            } else if p >= start && p < start + k {
                out[p - start]
            } else {
                NONE
            };
            out.push(self.step(parent, p, n, counts));
        }
    }

    /// [`EditPlan::block_states`] of a block that is one command and its
    /// children, all of one label (a `repeat`'s: a floor's hundred tiles),
    /// where the command's state has ordinal edges alone (picks make
    /// them): a child's ordinal is then its place, so each costs a test of
    /// its signature bit, without the per-label count. False (nothing
    /// written) for any other block.
    fn repeat_states(
        &self,
        block: &[Node],
        start: usize,
        at: usize,
        state: u32,
        out: &mut Vec<u32>,
        counts: &mut Vec<(usize, Label, u32)>,
    ) -> bool {
        let [cmd, kids @ ..] = block else {
            return false;
        };
        let Some(first) = kids.first() else {
            return false;
        };
        let l = label(first);
        if start.wrapping_sub(cmd.parent_offset as usize) != at
            || !kids
                .iter()
                .enumerate()
                .all(|(k, n)| n.parent_offset as usize == k + 1 && label(n) == l)
        {
            return false;
        }
        let cs = self.step(state, at, cmd, counts);
        let st = match self.states.get(cs as usize) {
            Some(st) if st.flags & 1 == 0 => st,
            // Numbered edges leave the command: the general pass.
            Some(_) => return false,
            None => {
                out.push(cs);
                out.resize(block.len(), NONE);
                return true;
            }
        };
        out.push(cs);
        if st.flags & 2 == 0 {
            out.resize(block.len(), NONE);
            return true;
        }
        out.extend(kids.iter().enumerate().map(|(k, n)| {
            let ordinal = k as u32 + 1;
            if n.selector.is_some() || st.osig >> (ordinal & 63) & 1 == 0 {
                NONE
            } else {
                self.child(st, l, &EdgeRef::Ordinal(ordinal))
                    .unwrap_or(NONE)
            }
        }));
        true
    }

    /// A child's trie state from its parent's (`parent`, the parent at
    /// position `p`), counting its ordinal in `counts` where some target
    /// leaves the parent's state by an ordinal edge.
    #[inline(always)]
    fn step(
        &self,
        parent: u32,
        p: usize,
        child: &Node,
        counts: &mut Vec<(usize, Label, u32)>,
    ) -> u32 {
        let Some(st) = self.states.get(parent as usize) else {
            return NONE;
        };
        let leaves = st.flags;
        if leaves & 3 == 0 {
            return NONE;
        }
        let l = label(child);
        // The child's ordinal among its parent's children of its label
        // (every such sibling counts, whatever its edge).
        let ordinal = if leaves & 2 != 0 {
            match counts.iter_mut().rev().find(|c| c.0 == p && c.1 == l) {
                Some(c) => {
                    c.2 += 1;
                    c.2
                }
                None => {
                    counts.push((p, l, 1));
                    1
                }
            }
        } else {
            0
        };
        // A numbered or component edge, only where one leaves the state
        // (picks make ordinal edges): its signature bit first.
        if leaves & 1 != 0 {
            let e = edge(child);
            let bit = match e {
                EdgeRef::Number(k) | EdgeRef::Ordinal(k) => k,
                EdgeRef::Component { index, .. } => index,
            } & 63;
            if st.sig >> bit & 1 != 0
                && let Some(s) = self.child(st, l, &e)
            {
                return s;
            }
        }
        if ordinal == 0 || child.selector.is_some() || st.osig >> (ordinal & 63) & 1 == 0 {
            return NONE;
        }
        self.child(st, l, &EdgeRef::Ordinal(ordinal))
            .unwrap_or(NONE)
    }

    /// The state the trie's edge (`label`, `edge`) from `state` leads to:
    /// a look at the state's own edges, which lie together (a floor's
    /// hundred tiles read its few targeted ones, in cache after the
    /// first), by a scan where they are few and a binary search where
    /// they are many.
    #[inline]
    fn child(&self, st: &TrieState, label: Label, edge: &EdgeRef) -> Option<u32> {
        let edges = self
            .trie_edges
            .get(st.edges.0 as usize..st.edges.1 as usize)?;
        let key = TrieEdge::pack(label, edge);
        if edges.len() <= 16 {
            return edges
                .iter()
                .find(|t| (t.label, t.edge) == key)
                .map(|t| t.to);
        }
        edges
            .binary_search_by_key(&key, |t| (t.label, t.edge))
            .ok()
            .map(|k| edges[k].to)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn edge(from: u32, k: u64, to: u32) -> (u32, TrieEdge) {
        (
            from,
            TrieEdge {
                label: 0,
                edge: k,
                to,
            },
        )
    }

    #[test]
    fn depth_first_numbers_each_subtree_as_one_run() {
        // Made in the order targets came (root 3): 3 -> {1 (edge 2), 0
        // (edge 1)}, 1 -> {4}, 0 -> {2}; the final of each state is its
        // old number, its leaves byte the old number too.
        let mut edges = vec![edge(0, 1, 2), edge(1, 1, 4), edge(3, 1, 0), edge(3, 2, 1)];
        let mut finals: Vec<Vec<u32>> = (0..5).map(|s| vec![s]).collect();
        let mut leaves: Vec<u8> = (0..5).collect();
        depth_first(3, &mut edges, &mut finals, &mut leaves);
        // Depth first, edge 1 before edge 2: 3, 0, 2, 1, 4.
        assert_eq!(finals, vec![vec![3], vec![0], vec![2], vec![1], vec![4]]);
        assert_eq!(leaves, vec![3, 0, 2, 1, 4]);
        let pairs: Vec<(u32, u64, u32)> = edges.iter().map(|(f, e)| (*f, e.edge, e.to)).collect();
        assert_eq!(pairs, vec![(0, 1, 1), (0, 2, 3), (1, 1, 2), (3, 1, 4)]);
    }
}

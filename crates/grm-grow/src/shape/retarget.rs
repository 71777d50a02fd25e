//! Retargeting a persistent edit whose target no longer finds its part
//! (Lipp, 3.2.2, "Transformations between Hierarchies"): the parts of the
//! tree grown now that the edit could name instead, best first. They are
//! proposed, never applied: the editor offers each as a quick fix the
//! artist picks (docs/edits.md, "In the editor").
//!
//! What the edit named is a [`PartPrint`]: the part's label, its
//! **ordering value** per tag on its path, and its position. A print is
//! taken from the part while the edit is valid ([`print_of`]; the editor
//! keeps the last one per edit), else read from the target itself
//! ([`print_of_target`]: a semantic query's label and indices, an exact
//! locator's last label and the place its longest matching prefix leads
//! to). The candidates ([`candidates`]) come in three tiers, in the order
//! 3.2.2 gives:
//!
//! 1. **ordering values**: parts of the same label whose ordering value
//!    of every tag of the print is the print's (the third floor stays the
//!    third floor when a split is wrapped around the floors or a floor
//!    type is inserted beside them), nearest first;
//! 2. **symbol and tags**: parts of the same label under the same tags,
//!    closest ordering values first, then nearest;
//! 3. **nearest**: parts of the same label, nearest to where the part was.
//!
//! Ordering values are Lipp's sequential orderings (his figure 3.10): for
//! a tag, a post-order walk of the tree counts each child of a command so
//! tagged whose subtree holds no command of the tag; a tagged command of
//! another axis (or a component split) is a *semantic splitter*: each of
//! its children is counted from the same start and the count goes on from
//! the largest, so columns are counted per floor and per facade, not
//! across them. The walk follows the tree's structure, not world
//! positions (as Lipp's does).
//!
//! The print, the reasons and the classes that get candidates are shared
//! with derive and sample mode ([`crate::retarget`], re-exported here).

use crate::retarget::distance;
pub use crate::retarget::{PartPrint, Reason, wants_candidates};
use crate::shape::Lowered;
use grm_edits::locator::{Anchor, EdgeRef, ExactLocator, SemanticQuery};
use grm_edits::{Edit, Target};
use grm_shape::{Command, NodeId, NodeKind, ShapeTree, TagId};
use std::collections::{HashMap, HashSet};

/// A target an edit could be given.
#[derive(Clone, Debug, PartialEq)]
pub struct Candidate {
    pub target: Target,
    pub reason: Reason,
    /// The parts the new target names in the tree.
    pub parts: Vec<NodeId>,
}

/// Ordering values of a tree, computed per tag when first asked.
#[derive(Debug)]
pub struct Orderings<'t> {
    tree: &'t ShapeTree,
    lowered: &'t Lowered,
    /// Per tag: per node, the ordering value in force there (0: none).
    per_tag: HashMap<TagId, Vec<u32>>,
}

impl<'t> Orderings<'t> {
    pub fn new(lowered: &'t Lowered, tree: &'t ShapeTree) -> Self {
        Orderings {
            tree,
            lowered,
            per_tag: HashMap::new(),
        }
    }

    /// The ordering value of `tag` at `node` (0 when no command of the
    /// tag is on its path).
    pub fn value(&mut self, tag: TagId, node: NodeId) -> u32 {
        let tree = self.tree;
        let v = self
            .per_tag
            .entry(tag)
            .or_insert_with(|| ordering(tree, tag));
        v.get(node.0 as usize).copied().unwrap_or(0)
    }

    /// The tags of the tagged commands on `node`'s path, outermost first,
    /// each once.
    fn tags_on_path(&self, node: NodeId) -> Vec<TagId> {
        let mut out = Vec::new();
        for n in self.tree.path(node) {
            if let Some(NodeKind::Command { tag: Some(t), .. }) = self.tree.node(n).map(|x| x.kind)
                && !out.contains(&t)
            {
                out.push(t);
            }
        }
        out
    }

    /// The print of `node`.
    pub fn print(&mut self, node: NodeId) -> PartPrint {
        let program = &self.lowered.program;
        let order = self
            .tags_on_path(node)
            .into_iter()
            .map(|t| (program.tag_name(t).to_owned(), self.value(t, node)))
            .collect();
        PartPrint {
            label: Some(self.tree.label(program, node)),
            order,
            ancestry: None,
            centre: self.tree.node(node).map(|n| n.scope.center().to_array()),
            ..PartPrint::default()
        }
    }
}

/// The print of `node` in `tree` (one part; see [`Orderings`] for many).
pub fn print_of(lowered: &Lowered, tree: &ShapeTree, node: NodeId) -> PartPrint {
    Orderings::new(lowered, tree).print(node)
}

/// What an edit's target says by itself of the part it named: a semantic
/// query's label and its indices from the start (taken as ordering
/// values; those counted from the end or the centre are resolved in no
/// tree, so left out); an exact locator's last label and the centre of
/// the deepest node its path reaches; for a key, the symbol the edit
/// recorded (`Edit::symbol`), if it did.
pub fn print_of_target(lowered: &Lowered, tree: &ShapeTree, edit: &Edit) -> PartPrint {
    match &edit.target {
        Target::Semantic(q) => PartPrint {
            label: q.label.clone(),
            order: q
                .entries
                .iter()
                .filter(|(_, a, _)| *a == Anchor::Start)
                .filter_map(|(t, _, n)| Some((t.clone(), u32::try_from(*n).ok()?)))
                .collect(),
            ancestry: None,
            centre: None,
            ..PartPrint::default()
        },
        Target::Exact(loc) => PartPrint {
            label: loc.labels.last().cloned(),
            order: Vec::new(),
            ancestry: None,
            centre: deepest(lowered, tree, loc)
                .and_then(|n| tree.node(n))
                .map(|n| n.scope.center().to_array()),
            ..PartPrint::default()
        },
        Target::Key(_) => PartPrint {
            label: edit.symbol.clone(),
            ..PartPrint::default()
        },
    }
}

/// The deepest node the path of `loc` reaches in `tree` (labels and edges
/// matching from the axiom).
fn deepest(lowered: &Lowered, tree: &ShapeTree, loc: &ExactLocator) -> Option<NodeId> {
    let program = &lowered.program;
    let mut cur = NodeId(0);
    if tree.is_empty() || tree.label(program, cur) != *loc.labels.first()? {
        return None;
    }
    for (edge, label) in loc.edges.iter().zip(loc.labels.iter().skip(1)) {
        let next = tree.children(cur).find(|&c| {
            let n = &tree.nodes()[c.0 as usize];
            let fits = match (n.selector, edge) {
                (Some(selector), _) => {
                    EdgeRef::Component {
                        selector,
                        index: n.index,
                    } == *edge
                }
                (None, EdgeRef::Ordinal(k)) => tree.ordinal(c) == *k,
                (None, _) => EdgeRef::Number(n.edge) == *edge,
            };
            fits && tree.label(program, c) == *label
        });
        match next {
            Some(c) => cur = c,
            None => break,
        }
    }
    Some(cur)
}

/// Lipp's sequential ordering of `tag` over `tree`: per node, the value
/// in force there (the value of its innermost ancestor-or-self that is a
/// child of a command of the tag; 0 when none is).
fn ordering(tree: &ShapeTree, tag: TagId) -> Vec<u32> {
    let n = tree.len();
    let mut own = vec![0u32; n];
    if n == 0 {
        return own;
    }
    // The tag's command kind: another tagged command splits the count
    // when it divides along another axis (or is a component split).
    let tag_command = tree.nodes().iter().find_map(|x| match x.kind {
        NodeKind::Command {
            command,
            tag: Some(t),
        } if t == tag => Some(command),
        _ => None,
    });
    let Some(tag_command) = tag_command else {
        return own;
    };
    let splits = |c: Command| match (c, tag_command) {
        (Command::Comp(_), _) | (_, Command::Comp(_)) => true,
        (Command::Split(a) | Command::Repeat(a), Command::Split(b) | Command::Repeat(b)) => a != b,
    };
    let mut value = 0u32;
    walk(tree, NodeId(0), tag, &splits, &mut value, &mut own);
    // Down the tree (parents come first): the innermost value in force.
    let mut inherited = own;
    for i in 1..n {
        if inherited[i] == 0
            && let Some(p) = tree.parent(NodeId(i as u32))
        {
            inherited[i] = inherited[p.0 as usize];
        }
    }
    inherited
}

/// Figure 3.10's traversal below `node`; whether the subtree holds a
/// command of `tag`.
fn walk(
    tree: &ShapeTree,
    node: NodeId,
    tag: TagId,
    splits: &dyn Fn(Command) -> bool,
    value: &mut u32,
    own: &mut [u32],
) -> bool {
    let (has_tag, splitter) = match tree.node(node).map(|x| x.kind) {
        Some(NodeKind::Command {
            command,
            tag: Some(t),
        }) => (t == tag, t != tag && splits(command)),
        _ => (false, false),
    };
    let before = *value;
    let mut most = before;
    let mut found = has_tag;
    let children: Vec<NodeId> = tree.children(node).collect();
    for c in children {
        let inside = walk(tree, c, tag, splits, value, own);
        found |= inside;
        if has_tag && !inside {
            *value += 1;
            own[c.0 as usize] = *value;
        }
        if splitter {
            most = most.max(*value);
            *value = before;
        }
    }
    if splitter {
        *value = most;
    }
    found
}

/// Up to `max` targets `edit` could be given in `tree`, best first (the
/// tiers of the module doc; an ambiguous target's own parts first), each
/// of the edit's target kind where that names the part alone (an exact
/// locator otherwise), none twice. `print` is what the edit named (the
/// last print taken while it was valid, else [`print_of_target`]);
/// `matched` the parts its target names now (an ambiguous one's).
pub fn candidates(
    lowered: &Lowered,
    tree: &ShapeTree,
    edit: &Edit,
    print: &PartPrint,
    matched: &[NodeId],
    max: usize,
) -> Vec<Candidate> {
    candidates_with(
        &mut Orderings::new(lowered, tree),
        edit,
        print,
        matched,
        max,
    )
}

/// [`candidates`] with the tree's ordering values computed once for many
/// edits.
pub fn candidates_with(
    ord: &mut Orderings<'_>,
    edit: &Edit,
    print: &PartPrint,
    matched: &[NodeId],
    max: usize,
) -> Vec<Candidate> {
    let (lowered, tree) = (ord.lowered, ord.tree);
    let program = &lowered.program;
    let mut ranked: Vec<(Reason, NodeId)> = Vec::new();
    if matched.len() > 1 {
        let mut m: Vec<(f32, NodeId)> = matched
            .iter()
            .map(|&n| (distance(print.centre, ord.print(n).centre), n))
            .collect();
        m.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        ranked.extend(m.into_iter().map(|(_, n)| (Reason::OneOfMatched, n)));
    }
    if let Some(label) = &print.label
        && let Some(symbol) = program.symbol(label)
    {
        let same: Vec<NodeId> = tree
            .nodes()
            .iter()
            .enumerate()
            .filter(|(_, n)| matches!(n.kind, NodeKind::Shape { symbol: s, .. } if s == symbol))
            .map(|(i, _)| NodeId(i as u32))
            .collect();
        let tags: Vec<Option<TagId>> = print.order.iter().map(|(t, _)| program.tag(t)).collect();
        let mut tiers: [Vec<(u64, f32, NodeId)>; 3] = Default::default();
        for &n in &same {
            let centre = tree.node(n).map(|x| x.scope.center().to_array());
            let dist = distance(print.centre, centre);
            let on_path = ord.tags_on_path(n);
            let values: Vec<Option<u32>> = tags
                .iter()
                .map(|t| t.filter(|t| on_path.contains(t)).map(|t| ord.value(t, n)))
                .collect();
            let all_tags = !print.order.is_empty() && values.iter().all(Option::is_some);
            let gap: u64 = values
                .iter()
                .zip(&print.order)
                .map(|(v, (_, want))| {
                    v.map_or(u64::from(u32::MAX), |v| u64::from(v.abs_diff(*want)))
                })
                .sum();
            let tier = if all_tags && gap == 0 {
                0
            } else if all_tags {
                1
            } else {
                2
            };
            tiers[tier].push((if tier == 1 { gap } else { 0 }, dist, n));
        }
        for (i, mut t) in tiers.into_iter().enumerate() {
            t.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)).then(a.2.cmp(&b.2)));
            let reason = [Reason::Ordering, Reason::SymbolAndTags, Reason::Nearest][i];
            ranked.extend(t.into_iter().map(|(_, _, n)| (reason, n)));
        }
    }
    let mut out: Vec<Candidate> = Vec::new();
    let mut seen: HashSet<String> = HashSet::new();
    seen.insert(edit.target.text());
    let mut keys: Option<HashMap<u32, u32>> = None;
    for (reason, n) in ranked {
        if out.len() >= max {
            break;
        }
        let Some(target) = target_for(lowered, tree, &edit.target, n, &mut keys) else {
            continue;
        };
        if !seen.insert(target.text()) {
            continue;
        }
        let parts = match &target {
            Target::Semantic(q) => tree.select(program, q),
            _ => vec![n],
        };
        out.push(Candidate {
            target,
            reason,
            parts,
        });
    }
    out
}

/// The target naming part `n` of the kind of `old`: a semantic query with
/// `old`'s tags (their anchors kept) and the part's indices, when the part
/// has those tags; the part's key, when no other node has it; its exact
/// locator otherwise.
fn target_for(
    lowered: &Lowered,
    tree: &ShapeTree,
    old: &Target,
    n: NodeId,
    keys: &mut Option<HashMap<u32, u32>>,
) -> Option<Target> {
    let program = &lowered.program;
    let node = tree.node(n)?;
    match old {
        Target::Semantic(q) => {
            let loc = tree.semantic_locator(program, n);
            let mut at = 0usize;
            let mut entries = Vec::new();
            for (tag, anchor, _) in &q.entries {
                let i = loc.entries[at..].iter().position(|e| e.tag == *tag)? + at;
                let e = &loc.entries[i];
                entries.push((tag.clone(), *anchor, anchor.index(e.index, e.count)));
                at = i + 1;
            }
            // Counted from the start or the end, an index is at least 1.
            if entries
                .iter()
                .any(|(_, a, v)| *a != Anchor::Centre && *v < 1)
            {
                return None;
            }
            Some(Target::Semantic(SemanticQuery {
                entries,
                label: Some(loc.label),
            }))
        }
        Target::Key(_) => {
            let counts = keys.get_or_insert_with(|| {
                let mut m = HashMap::new();
                for x in tree.nodes() {
                    *m.entry(x.key).or_insert(0u32) += 1;
                }
                m
            });
            if counts.get(&node.key) == Some(&1) {
                Some(Target::Key(node.key))
            } else {
                Some(Target::Exact(tree.exact_locator(program, n)))
            }
        }
        Target::Exact(_) => Some(Target::Exact(tree.exact_locator(program, n))),
    }
}

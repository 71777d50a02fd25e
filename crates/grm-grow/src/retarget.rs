//! Retargeting a persistent edit whose target no longer finds its part,
//! the parts shared by every mode (docs/edits.md, "Retargeting"): what an
//! edit named ([`PartPrint`]), why a candidate is proposed ([`Reason`]),
//! which classes get candidates; and the candidates of derive and sample
//! mode, whose targets are identity keys ([`TreeParts`], [`candidates`]).
//! Shape mode's candidates, ranked by Lipp's ordering values, are in
//! [`crate::shape::retarget`] and use the same print and reasons.
//!
//! Derive and sample mode name a part by its key; a key changes with
//! every change of the module's ancestry or of the alternatives chosen on
//! it (docs/engine.md, "Identity"): a reordered alternative, an inserted
//! rule. The part itself is usually still there under another key. A
//! print of the part (its symbol, its **ancestry**, the symbols of the
//! modules that produced it from the axiom down, and where the turtle drew
//! its subtree) is taken while the edit is valid, and when the key is
//! gone the derivation tree grown now is searched, in the order issue 27
//! gives:
//!
//! 1. **ancestry**: modules of the same symbol produced by the same chain
//!    of symbols, nearest first;
//! 2. **nearest**: modules of the same symbol, nearest to where the part
//!    was.
//!
//! A module's place is the centre of what its subtree drew (its bones'
//! midpoints and its instances' origins); a subtree that drew nothing has
//! none and ranks after those that did, in tree order. Each candidate is
//! the module's key, proposed only when no other module of the tree has
//! it (a key two modules share would name both).

use crate::Tree;
use grm_edits::{Edit, EditClass, Target};
use std::collections::{HashMap, HashSet};

/// What is known of the part an edit named.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PartPrint {
    /// Its label (the symbol), if known.
    pub label: Option<String>,
    /// Shape mode: its ordering value per tag on its path, outermost
    /// first (a tag once).
    pub order: Vec<(String, u32)>,
    /// Derive and sample mode: the symbols of the modules that produced
    /// it, from the axiom's module down (its parent's last); `None` when
    /// unknown.
    pub ancestry: Option<Vec<String>>,
    /// Where it was in world coordinates (shape mode: its scope's centre;
    /// derive and sample mode: the centre of what its subtree drew), if
    /// known.
    pub centre: Option<[f32; 3]>,
    /// `centre` is its parent's (a module an edit removed drew nothing of
    /// its own).
    pub centre_of_parent: bool,
    /// Derive mode, and a removed module in sample mode: its place among
    /// the modules its parent's production made (from 0), if known.
    pub sibling: Option<u32>,
}

/// Which tier proposed a candidate.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Reason {
    /// The same label and ordering values (shape mode).
    Ordering,
    /// The same label and tags (shape mode).
    SymbolAndTags,
    /// The same symbol produced by the same chain of symbols (derive and
    /// sample mode).
    Ancestry,
    /// The same label, nearest by position.
    Nearest,
    /// One of the parts an ambiguous target matches.
    OneOfMatched,
}

impl Reason {
    const ALL: [Reason; 5] = [
        Reason::Ordering,
        Reason::SymbolAndTags,
        Reason::Ancestry,
        Reason::Nearest,
        Reason::OneOfMatched,
    ];

    /// `ordering`, `symbol_and_tags`, `ancestry`, `nearest`,
    /// `one_of_matched`.
    pub fn as_str(self) -> &'static str {
        match self {
            Reason::Ordering => "ordering",
            Reason::SymbolAndTags => "symbol_and_tags",
            Reason::Ancestry => "ancestry",
            Reason::Nearest => "nearest",
            Reason::OneOfMatched => "one_of_matched",
        }
    }

    /// The reason [`Reason::as_str`] names.
    pub fn from_name(name: &str) -> Option<Reason> {
        Reason::ALL.into_iter().find(|r| r.as_str() == name)
    }

    /// In words, for a quick fix's title.
    pub fn words(self) -> &'static str {
        match self {
            Reason::Ordering => "same ordering values",
            Reason::SymbolAndTags => "same symbol and tags",
            Reason::Ancestry => "same symbol and ancestry",
            Reason::Nearest => "nearest of the same symbol",
            Reason::OneOfMatched => "one of the parts it matches",
        }
    }
}

/// Whether an edit of this class gets candidates in shape mode: every
/// class that says its target does not name what it did (a stale edit's
/// operation is at fault, which a part of the same symbol does not mend).
/// Derive and sample mode: see [`wants_key_candidates`].
pub fn wants_candidates(class: EditClass) -> bool {
    matches!(
        class,
        EditClass::StructurallyInvalid | EditClass::SemanticallyInvalid | EditClass::Ambiguous
    )
}

/// Whether a derive- or sample-mode edit gets candidates: a key target
/// no module has now (structurally invalid). An ambiguous key names
/// modules that share it, which no other key tells apart; exact and
/// semantic targets are not replayed there.
pub fn wants_key_candidates(edit: &Edit, class: EditClass) -> bool {
    class == EditClass::StructurallyInvalid && matches!(edit.target, Target::Key(_))
}

/// The distance between two places; 0 when either is unknown.
pub(crate) fn distance(a: Option<[f32; 3]>, b: Option<[f32; 3]>) -> f32 {
    match (a, b) {
        (Some(a), Some(b)) => {
            let d = [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
            (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
        }
        _ => 0.0,
    }
}

/// A derivation tree (derive or sample mode) with what its candidates
/// are ranked by: each node's place and how many nodes share each key.
#[derive(Debug)]
pub struct TreeParts<'t> {
    tree: &'t Tree,
    /// The compiled system's symbol names.
    symbols: &'t [String],
    /// Per node: the centre of what its subtree drew.
    centres: Vec<Option<[f32; 3]>>,
    /// Per key: how many nodes have it.
    keys: HashMap<u32, u32>,
    /// Per node: its place among its parent's children.
    siblings: Vec<u32>,
}

impl<'t> TreeParts<'t> {
    /// `tree` with `symbols` (the compiled system's names) and what the
    /// turtle drew from its final string (`interpretation`: each bone and
    /// instance names its module).
    pub fn new(
        tree: &'t Tree,
        symbols: &'t [String],
        interpretation: &grm_turtle::Interpretation,
    ) -> Self {
        let points = interpretation
            .bones
            .iter()
            .map(|b| (b.module, ((b.base + b.tip) * 0.5).to_array()))
            .chain(
                interpretation
                    .instances
                    .iter()
                    .map(|i| (i.module, i.transform.translation.to_array())),
            );
        Self::from_points(tree, symbols, points)
    }

    /// [`TreeParts::new`] from drawn points, each with the final string's
    /// module that drew it.
    pub fn from_points(
        tree: &'t Tree,
        symbols: &'t [String],
        points: impl IntoIterator<Item = (u32, [f32; 3])>,
    ) -> Self {
        let n = tree.nodes.len();
        // Per node: the sum of its subtree's points and their count.
        let mut sum = vec![([0f64; 3], 0u32); n];
        for (m, p) in points {
            let Some(node) = tree.node_of_module(m) else {
                continue;
            };
            if let Some(s) = sum.get_mut(node as usize) {
                for (acc, v) in s.0.iter_mut().zip(p) {
                    *acc += f64::from(v);
                }
                s.1 += 1;
            }
        }
        // A parent precedes its children: children first, up the tree.
        for i in (1..n).rev() {
            if let Some(p) = tree.nodes[i].parent.filter(|&p| (p as usize) < i) {
                let (c, k) = sum[i];
                let s = &mut sum[p as usize];
                for (acc, v) in s.0.iter_mut().zip(c) {
                    *acc += v;
                }
                s.1 += k;
            }
        }
        let centres = sum
            .iter()
            .map(|(s, k)| {
                (*k > 0).then(|| {
                    let k = f64::from(*k);
                    [(s[0] / k) as f32, (s[1] / k) as f32, (s[2] / k) as f32]
                })
            })
            .collect();
        let mut keys: HashMap<u32, u32> = HashMap::new();
        for k in tree
            .nodes
            .iter()
            .map(|x| x.key)
            .chain(tree.removed.iter().map(|r| r.key))
        {
            *keys.entry(k).or_insert(0) += 1;
        }
        let mut children = vec![0u32; n];
        let siblings = tree
            .nodes
            .iter()
            .map(
                |x| match x.parent.and_then(|p| children.get_mut(p as usize)) {
                    Some(c) => {
                        *c += 1;
                        *c - 1
                    }
                    None => 0,
                },
            )
            .collect();
        TreeParts {
            tree,
            symbols,
            centres,
            keys,
            siblings,
        }
    }

    fn symbol(&self, node: usize) -> Option<&str> {
        let s = self.tree.nodes.get(node)?.symbol?;
        self.symbols.get(s as usize).map(String::as_str)
    }

    /// The node keyed `key`, when exactly one node has it (the root, keyed
    /// by the run's root key, is no module).
    pub fn node_of_key(&self, key: u32) -> Option<u32> {
        if self.keys.get(&key) != Some(&1) {
            return None;
        }
        let i = self.tree.nodes.iter().position(|x| x.key == key)?;
        (i > 0).then_some(i as u32)
    }

    /// The print of `node`: its symbol, the symbols of its ancestors below
    /// the root, the centre of what its subtree drew.
    pub fn print(&self, node: u32) -> PartPrint {
        let path = self.tree.ancestry(node);
        let ancestry = path[..path.len().saturating_sub(1)]
            .iter()
            .filter_map(|&a| self.symbol(a as usize).map(str::to_owned))
            .collect();
        PartPrint {
            label: self.symbol(node as usize).map(str::to_owned),
            order: Vec::new(),
            ancestry: Some(ancestry),
            centre: self.centres.get(node as usize).copied().flatten(),
            centre_of_parent: false,
            sibling: (self.tree.mode == crate::TreeMode::Derive)
                .then(|| self.siblings.get(node as usize).copied())
                .flatten(),
        }
    }

    /// The print of the module keyed `key`, when one module has it: a
    /// node, or a module an edit removed as it was made ([`Tree::removed`]:
    /// its symbol, its parent's ancestry and symbol, and for its place,
    /// having drawn nothing, its parent's).
    pub fn print_of_key(&self, key: u32) -> Option<PartPrint> {
        if let Some(n) = self.node_of_key(key) {
            return Some(self.print(n));
        }
        if self.keys.get(&key) != Some(&1) {
            return None;
        }
        let r = self.tree.removed.iter().find(|r| r.key == key)?;
        let ancestry = self
            .tree
            .ancestry(r.parent)
            .iter()
            .skip(1)
            .filter_map(|&a| self.symbol(a as usize).map(str::to_owned))
            .collect();
        Some(PartPrint {
            label: self.symbols.get(r.symbol as usize).cloned(),
            order: Vec::new(),
            ancestry: Some(ancestry),
            centre: self.centres.get(r.parent as usize).copied().flatten(),
            centre_of_parent: true,
            sibling: Some(r.sibling),
        })
    }
}

/// A key target an edit could be given (derive and sample mode).
#[derive(Clone, Debug, PartialEq)]
pub struct KeyCandidate {
    pub target: Target,
    pub reason: Reason,
    /// The tree node it names.
    pub node: u32,
}

/// Up to `max` key targets `edit` could be given in `parts`' tree, best
/// first (the tiers of the module doc), none twice and none the edit's
/// own. `print` is what the edit named (the last print taken while it
/// was valid); without its symbol there is nothing to propose.
pub fn candidates(
    parts: &TreeParts<'_>,
    edit: &Edit,
    print: &PartPrint,
    max: usize,
) -> Vec<KeyCandidate> {
    let Some(label) = &print.label else {
        return Vec::new();
    };
    let id = |name: &str| parts.symbols.iter().position(|s| s == name);
    let Some(symbol) = id(label) else {
        return Vec::new();
    };
    // The print's ancestry as symbol ids, innermost first (a symbol the
    // system no longer has matches no module).
    let ancestry: Option<Vec<Option<usize>>> = print
        .ancestry
        .as_ref()
        .map(|a| a.iter().rev().map(|s| id(s)).collect());
    let nodes = &parts.tree.nodes;
    // Whether node `i`'s ancestors below the root are `want`'s symbols.
    let same_ancestry = |i: usize, want: &[Option<usize>]| {
        let mut at = nodes[i].parent;
        for w in want {
            match at.and_then(|p| nodes.get(p as usize)) {
                Some(x) if x.parent.is_some() && x.symbol.map(|s| s as usize) == *w => {
                    at = x.parent
                }
                _ => return false,
            }
        }
        // Then the root.
        at.and_then(|p| nodes.get(p as usize))
            .is_some_and(|x| x.parent.is_none())
    };
    // (unknown place, distance, another place among its siblings, node)
    let mut tiers: [Vec<(bool, f32, bool, u32)>; 2] = Default::default();
    for (i, x) in nodes.iter().enumerate().skip(1) {
        if x.symbol.map(|s| s as usize) != Some(symbol) || parts.keys.get(&x.key) != Some(&1) {
            continue;
        }
        let tier = usize::from(!ancestry.as_ref().is_some_and(|a| same_ancestry(i, a)));
        // A removed part's place is its parent's: compared with the
        // candidate's parent's, its siblings told apart by their place.
        let centre = if print.centre_of_parent {
            x.parent
                .and_then(|p| parts.centres.get(p as usize).copied().flatten())
        } else {
            parts.centres[i]
        };
        let other_place = print.sibling.is_some_and(|s| s != parts.siblings[i]);
        // Unknown places last, in tree order.
        let known = print.centre.is_some() && centre.is_some();
        tiers[tier].push((
            !known,
            distance(print.centre, centre),
            other_place,
            i as u32,
        ));
    }
    let mut out: Vec<KeyCandidate> = Vec::new();
    let mut seen: HashSet<u32> = HashSet::new();
    if let Target::Key(k) = edit.target {
        seen.insert(k);
    }
    for (t, mut tier) in tiers.into_iter().enumerate() {
        tier.sort_by(|a, b| {
            a.0.cmp(&b.0)
                .then(a.1.total_cmp(&b.1))
                .then(a.2.cmp(&b.2))
                .then(a.3.cmp(&b.3))
        });
        for (_, _, _, n) in tier {
            if out.len() >= max {
                return out;
            }
            let key = parts.tree.nodes[n as usize].key;
            if !seen.insert(key) {
                continue;
            }
            out.push(KeyCandidate {
                target: Target::Key(key),
                reason: [Reason::Ancestry, Reason::Nearest][t],
                node: n,
            });
        }
    }
    out
}

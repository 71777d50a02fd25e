//! The derivation tree: every part's identity and ancestry.
//!
//! Node 0 is the axiom (the root, keyed by the run's root key). In derive
//! mode every module that ever existed is a node: an axiom module's parent
//! is the root, a successor module's parent is the module its production
//! rewrote, and a module that no production rewrites stays the same node
//! (its key does not change either). The final string's modules are the
//! leaves. In sample mode a node is an expansion (`grm_sample`'s tree):
//! the modules of its successor are its own, and the expansion of one of
//! them is a child keyed by that module's key.

use std::ops::Range;

use grm_compile::CompiledSystem;
use grm_derive::ModuleString;

/// How the tree was grown.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TreeMode {
    /// Parallel rewriting (`grmc derive`): a node per module.
    Derive,
    /// The guided search (`grmc sample`): a node per expansion.
    Sample,
}

/// One node.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TreeNode {
    /// Its identity key (its module's key; the root key for the root).
    pub key: u32,
    /// Its parent's index; `None` for the root.
    pub parent: Option<u32>,
    /// Its module's symbol; `None` for the root.
    pub symbol: Option<u32>,
    /// Derive mode: the string it first appears in (0: the axiom's).
    /// Sample mode: 0.
    pub iteration: u32,
    /// The compiled alternative that rewrote (expanded) it; the axiom's
    /// for the root; `None` if nothing did.
    pub production: Option<u32>,
    /// The final string's modules that are directly its own.
    pub modules: Range<u32>,
}

/// A module an edit removed as it was made ([`Tree::removed`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RemovedPart {
    /// Its identity key.
    pub key: u32,
    /// The node whose production made it.
    pub parent: u32,
    pub symbol: u32,
    /// Derive mode: the string it would have first appeared in (sample
    /// mode: 0).
    pub iteration: u32,
    /// Its place among the modules its parent's production made (sample
    /// mode: among the parent's expanded modules, as a node's place is
    /// counted there).
    pub sibling: u32,
}

/// Bytes one node costs while the tree is built (the node and the
/// module-to-node entries), for the memory limit.
pub(crate) const NODE_BYTES: u64 = std::mem::size_of::<TreeNode>() as u64 + 8;

/// A derivation tree.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Tree {
    pub mode: TreeMode,
    pub seed: u32,
    /// The run's root key (the root's key).
    pub root_key: u32,
    pub nodes: Vec<TreeNode>,
    /// The modules persistent edits removed as they were made (they are
    /// no nodes: nothing descends from them and they own no module), in
    /// the order they were made (derive mode) or met (sample mode).
    pub removed: Vec<RemovedPart>,
    /// Per module of the final string: the node that owns it. While a
    /// derive-mode tree is built: per module of the current string.
    module_node: Vec<u32>,
}

impl Tree {
    /// The tree of the axiom string `axiom` of `sys` with `seed` (which
    /// must carry keys).
    pub(crate) fn axiom(sys: &CompiledSystem, seed: u32, axiom: &ModuleString) -> Tree {
        let root_key = sys.root_key(seed);
        let mut nodes = Vec::with_capacity(axiom.len() + 1);
        nodes.push(TreeNode {
            key: root_key,
            parent: None,
            symbol: None,
            iteration: 0,
            production: Some(sys.axiom_alt),
            modules: 0..0,
        });
        for (i, sym) in axiom.symbols().enumerate() {
            nodes.push(TreeNode {
                key: axiom.keys().get(i).copied().unwrap_or_default(),
                parent: Some(0),
                symbol: Some(sym),
                iteration: 0,
                production: None,
                modules: 0..0,
            });
        }
        Tree {
            mode: TreeMode::Derive,
            seed,
            root_key,
            nodes,
            removed: Vec::new(),
            module_node: (1..=axiom.len() as u32).collect(),
        }
    }

    /// Record step `iteration`: `decided` is the engine's decision per
    /// module of the current string, `next` the string it made.
    /// `made(i, decided[i])` how many modules of `next` module `i` became
    /// (a successor's length, fewer where edits removed some; a copy 1);
    /// `removed` the modules edits removed from `next` (a removed copy
    /// stays its node).
    pub(crate) fn advance(
        &mut self,
        iteration: u32,
        decided: &[Option<u32>],
        made: &dyn Fn(usize, Option<u32>) -> usize,
        next: &ModuleString,
        removed: &[grm_derive::RemovedModule],
    ) {
        for r in removed.iter().filter(|r| !r.copy) {
            if let Some(&parent) = self.module_node.get(r.input as usize) {
                self.removed.push(RemovedPart {
                    key: r.key,
                    parent,
                    symbol: r.symbol,
                    iteration,
                    sibling: r.successor,
                });
            }
        }
        let mut cur = Vec::with_capacity(next.len());
        let mut o = 0usize;
        for (i, d) in decided.iter().enumerate() {
            let node = self.module_node[i];
            match *d {
                None => {
                    let n = made(i, None);
                    cur.extend(std::iter::repeat_n(node, n));
                    o += n;
                }
                Some(a) => {
                    self.nodes[node as usize].production = Some(a);
                    let n = made(i, Some(a));
                    for j in o..o + n {
                        cur.push(self.nodes.len() as u32);
                        self.nodes.push(TreeNode {
                            key: next.keys().get(j).copied().unwrap_or_default(),
                            parent: Some(node),
                            symbol: next.sym_at(j),
                            iteration,
                            production: None,
                            modules: 0..0,
                        });
                    }
                    o += n;
                }
            }
        }
        self.module_node = cur;
    }

    /// Record the final string: each leaf's module.
    pub(crate) fn finish(&mut self, last: &ModuleString) {
        debug_assert_eq!(self.module_node.len(), last.len());
        for (m, &node) in self.module_node.iter().enumerate() {
            let m = m as u32;
            self.nodes[node as usize].modules = m..m + 1;
        }
    }

    /// The tree of a sampled model (`grm_sample`'s expansions), keyed as
    /// the sampler keyed them.
    pub fn from_sampled(model: &grm_sample::SampledModel, seed: u32, root_key: u32) -> Tree {
        let src = &model.tree.nodes;
        let mut nodes: Vec<TreeNode> = src
            .iter()
            .map(|n| TreeNode {
                key: n.key,
                parent: n.parent.map(|p| p.0),
                symbol: (n.symbol != u32::MAX).then_some(n.symbol),
                iteration: 0,
                production: n.alt,
                modules: n.modules.clone(),
            })
            .collect();
        let mut module_node = vec![0u32; model.string.len()];
        for (i, n) in nodes.iter_mut().enumerate() {
            // The expansion that wrote a module owns it (a non-terminal
            // that a later expansion expanded stays its writer's module;
            // that expansion is the node keyed by it).
            for m in n.modules.clone() {
                if let Some(slot) = module_node.get_mut(m as usize) {
                    *slot = i as u32;
                }
            }
        }
        Tree {
            mode: TreeMode::Sample,
            seed,
            root_key,
            nodes,
            removed: model
                .tree
                .removed
                .iter()
                .map(|r| RemovedPart {
                    key: r.key,
                    parent: r.parent,
                    symbol: r.symbol,
                    iteration: 0,
                    sibling: r.sibling,
                })
                .collect(),
            module_node,
        }
    }

    /// The node that owns module `m` of the final string.
    pub fn node_of_module(&self, m: u32) -> Option<u32> {
        self.module_node.get(m as usize).copied()
    }

    /// The path from the root to `node`, both included.
    pub fn ancestry(&self, node: u32) -> Vec<u32> {
        let mut path = Vec::new();
        let mut at = Some(node);
        while let Some(n) = at {
            path.push(n);
            // A parent always precedes its child; stop at anything else.
            at = self
                .nodes
                .get(n as usize)
                .and_then(|x| x.parent)
                .filter(|&p| p < n);
        }
        path.reverse();
        path
    }

    /// Focus and context in derive mode (issue 28): per module of the
    /// final string, whether it lies within `depth` levels below the node
    /// keyed `key` (that node's own modules at level 0). The rest of the
    /// model is context (an editor draws its bones as lines). `None` when
    /// no node has that key.
    pub fn focus_window(&self, key: u32, depth: u32) -> Option<Vec<bool>> {
        let at = self.nodes.iter().position(|n| n.key == key)?;
        // A parent always precedes its child: one pass. Levels below the
        // focus, for the nodes inside its subtree.
        let mut below: Vec<Option<u32>> = vec![None; self.nodes.len()];
        below[at] = Some(0);
        for i in at + 1..self.nodes.len() {
            below[i] = self.nodes[i]
                .parent
                .filter(|&p| (p as usize) < i)
                .and_then(|p| below[p as usize])
                .map(|d| d.saturating_add(1));
        }
        Some(
            self.module_node
                .iter()
                .map(|&n| {
                    below
                        .get(n as usize)
                        .copied()
                        .flatten()
                        .is_some_and(|d| d <= depth)
                })
                .collect(),
        )
    }

    /// Every node's children, in order.
    pub fn children(&self) -> Vec<Vec<u32>> {
        let mut out = vec![Vec::new(); self.nodes.len()];
        for (i, n) in self.nodes.iter().enumerate() {
            if let Some(p) = n.parent {
                out[p as usize].push(i as u32);
            }
        }
        out
    }
}

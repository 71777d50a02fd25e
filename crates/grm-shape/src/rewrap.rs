//! Exact targets through a wrapping (docs/edits.md, "Replay"): the replay's
//! trie follows a target's path step by step, so a level inserted above a
//! part (a split wrapped in another) puts the part out of its reach, while
//! [`ShapeTree::resolve`] still finds it through the inserted level when
//! exactly one node fits there. After a derivation, the exact edits that
//! named no shape but resolve to one are given that shape's own path, and
//! the tree is derived again with them: the replay then reaches the part
//! that classification names. An ambiguous step (two nodes fit) resolves
//! to nothing and is never applied. The second derivation happens only
//! when some edit was rewrapped: never without a grammar change since the
//! edit was made.

use crate::ir::Program;
use crate::locator::Resolution;
use crate::replay::EditPlan;
use crate::tree::ShapeTree;
use grm_edits::Target;

impl EditPlan {
    /// The plan again with every exact target that named no shape in
    /// `tree` (grown with this plan) but resolves to one there given that
    /// shape's exact locator; `None` when there is no such target.
    pub(crate) fn rewrapped(&self, program: &Program, tree: &ShapeTree) -> Option<EditPlan> {
        // The exact edits that named no shape but resolve to one: their
        // new paths (nothing is cloned when there are none, the usual case).
        let moved: Vec<(usize, Target)> = self
            .lowered
            .iter()
            .enumerate()
            .filter_map(|(i, e)| {
                let Target::Exact(loc) = &e.target else {
                    return None;
                };
                if !tree.edit_hits(e.id).is_some_and(|h| h.is_empty()) {
                    return None;
                }
                match tree.resolve(program, loc) {
                    Resolution::Found(n) if tree.node(n).is_some_and(|n| n.is_shape()) => {
                        Some((i, Target::Exact(tree.exact_locator(program, n))))
                    }
                    _ => None,
                }
            })
            .collect();
        if moved.is_empty() {
            return None;
        }
        let mut edits = self.lowered.clone();
        for (i, t) in moved {
            edits[i].target = t;
        }
        Some(EditPlan::new(program, &edits))
    }
}

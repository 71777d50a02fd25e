//! Scoping (Lipp, 3.2.2): which of the edits that reach a node applies.
//!
//! An edit applies to its target's subtree. For one node, the edits whose
//! target is the node or one of its ancestors compete **per slot** (what
//! the operation decides: the value of one parameter or variable, the
//! rule's alternative, the random draws, the material, the mesh, removal):
//!
//! 1. the **deepest** target wins (a window's edit over its floor's);
//! 2. at equal depth (two edits on one part, or two semantic targets that
//!    select the same part) the **later** edit, the larger id, wins.
//!
//! `set` and `offset` of one name share a slot (the deeper or later one
//! decides the value); edits of different names, or of different slots,
//! do not compete and all apply. Forcing an alternative and pinning the
//! random draws are about the target's own rule and key, not inherited by
//! its subtree: for them only edits whose target is the node itself
//! count (its subtree's draws follow from its key by themselves).

use crate::file::{Edit, Op};

/// What an operation decides for a node; the edits of one slot compete.
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Slot {
    /// `set` and `offset` of this parameter or variable.
    Value(String),
    /// `force`: the alternative of the node's rule.
    Alternative,
    /// `pin`: the key the node's random numbers are drawn from.
    Pin,
    /// `material`.
    Material,
    /// `mesh`.
    Mesh,
    /// `remove`.
    Remove,
}

impl Slot {
    /// Whether an edit of this slot on an ancestor reaches the node (all
    /// but [`Slot::Alternative`] and [`Slot::Pin`]).
    pub fn inherits(&self) -> bool {
        !matches!(self, Slot::Alternative | Slot::Pin)
    }
}

impl Op {
    /// The slot the operation competes in.
    pub fn slot(&self) -> Slot {
        match self {
            Op::Set { name, .. } | Op::Offset { name, .. } => Slot::Value(name.clone()),
            Op::Force { .. } => Slot::Alternative,
            Op::Pin { .. } => Slot::Pin,
            Op::Material { .. } => Slot::Material,
            Op::Mesh { .. } => Slot::Mesh,
            Op::Remove => Slot::Remove,
        }
    }
}

/// Whether an edit `a` (its target's depth, its id) overrides `b` in one
/// slot: the deeper target, then the larger id.
pub fn overrides(a: (u32, u32), b: (u32, u32)) -> bool {
    a > b
}

/// The winners of one node's slots, offered the edits that reach it one
/// by one (in any order: the result does not depend on it).
#[derive(Clone, Debug)]
pub struct Scoping<'a> {
    node_depth: u32,
    /// (slot, target depth, edit), at most one per slot.
    winners: Vec<(Slot, u32, &'a Edit)>,
}

impl<'a> Scoping<'a> {
    /// For a node at `node_depth` (the axiom's is 0).
    pub fn new(node_depth: u32) -> Scoping<'a> {
        Scoping {
            node_depth,
            winners: Vec::new(),
        }
    }

    /// Offer an edit whose target is at `depth` on the node's path. An
    /// edit whose target is below the node (`depth > node_depth`), or of a
    /// slot that does not inherit on an ancestor, does not apply and is
    /// ignored.
    pub fn offer(&mut self, edit: &'a Edit, depth: u32) {
        if depth > self.node_depth {
            return;
        }
        let slot = edit.op.slot();
        if depth < self.node_depth && !slot.inherits() {
            return;
        }
        match self.winners.iter_mut().find(|(s, _, _)| *s == slot) {
            Some(w) => {
                if overrides((depth, edit.id), (w.1, w.2.id)) {
                    w.1 = depth;
                    w.2 = edit;
                }
            }
            None => self.winners.push((slot, depth, edit)),
        }
    }

    /// The edit that applies in `slot`, if any.
    pub fn winner(&self, slot: &Slot) -> Option<&'a Edit> {
        self.winners
            .iter()
            .find(|(s, _, _)| s == slot)
            .map(|(_, _, e)| *e)
    }

    /// Every slot's winner, in slot order.
    pub fn winners(&self) -> Vec<&'a Edit> {
        let mut w: Vec<&(Slot, u32, &Edit)> = self.winners.iter().collect();
        w.sort_by(|a, b| a.0.cmp(&b.0));
        w.into_iter().map(|(_, _, e)| *e).collect()
    }
}

/// The edits that apply to a node at `node_depth`, one per slot (in slot
/// order), given the edits that match it or an ancestor with the depth of
/// each one's target node.
pub fn scope<'a>(
    node_depth: u32,
    matches: impl IntoIterator<Item = (&'a Edit, u32)>,
) -> Vec<&'a Edit> {
    let mut s = Scoping::new(node_depth);
    for (edit, depth) in matches {
        s.offer(edit, depth);
    }
    s.winners()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::file::Target;

    fn edit(id: u32, op: Op) -> Edit {
        Edit {
            id,
            system: "S".into(),
            parcel: None,
            target: Target::Key(id),
            selected: None,
            symbol: None,
            op,
            note: None,
            span: Default::default(),
        }
    }

    fn material(id: u32, name: &str) -> Edit {
        edit(id, Op::Material { name: name.into() })
    }

    fn ids(w: &[&Edit]) -> Vec<u32> {
        w.iter().map(|e| e.id).collect()
    }

    #[test]
    fn the_deepest_target_wins() {
        let (floor, window) = (material(2, "brick"), material(1, "glass"));
        // The window's own edit (depth 5) beats its floor's (depth 3),
        // although the floor's is later.
        assert_eq!(ids(&scope(5, [(&floor, 3), (&window, 5)])), [1]);
        assert_eq!(ids(&scope(5, [(&window, 5), (&floor, 3)])), [1]);
    }

    #[test]
    fn ties_go_to_the_later_edit() {
        let (a, b) = (material(3, "brick"), material(7, "stone"));
        assert_eq!(ids(&scope(4, [(&a, 2), (&b, 2)])), [7]);
        assert_eq!(ids(&scope(4, [(&b, 2), (&a, 2)])), [7]);
    }

    #[test]
    fn slots_do_not_compete() {
        let m = material(1, "brick");
        let w = edit(
            2,
            Op::Set {
                name: "width".into(),
                value: 2.0,
            },
        );
        let h = edit(
            3,
            Op::Offset {
                name: "height".into(),
                by: 1.0,
            },
        );
        let w2 = edit(
            4,
            Op::Offset {
                name: "width".into(),
                by: 0.5,
            },
        );
        let r = edit(5, Op::Remove);
        // width: set (depth 1) and offset (depth 2) share a slot, the deeper
        // offset wins; height and material and remove each apply.
        let got = scope(2, [(&m, 0), (&w, 1), (&h, 1), (&w2, 2), (&r, 0)]);
        assert_eq!(ids(&got), [3, 4, 1, 5]);
        let s = {
            let mut s = Scoping::new(2);
            for (e, d) in [(&m, 0), (&w, 1), (&h, 1), (&w2, 2)] {
                s.offer(e, d);
            }
            s
        };
        assert_eq!(
            s.winner(&Slot::Value("width".into())).map(|e| e.id),
            Some(4)
        );
        assert_eq!(s.winner(&Slot::Mesh), None);
    }

    #[test]
    fn force_and_pin_are_not_inherited() {
        let force = edit(1, Op::Force { alternative: 2 });
        let pin = edit(2, Op::Pin { key: 0xdead_beef });
        assert!(scope(3, [(&force, 2), (&pin, 1)]).is_empty());
        assert_eq!(ids(&scope(3, [(&force, 3), (&pin, 3)])), [1, 2]);
    }

    #[test]
    fn targets_below_the_node_do_not_apply() {
        let m = material(1, "brick");
        assert!(scope(2, [(&m, 3)]).is_empty());
    }

    /// Whatever the order the matches come in, the winner is the maximum
    /// of (depth, id) among the edits that apply (seeded property test).
    #[test]
    fn order_does_not_matter() {
        let mut rng = grm_testkit::Rng::seeded(0x0005_c0b1);
        for _ in 0..500 {
            let n = rng.below(8usize) + 1;
            let edits: Vec<Edit> = (0..n as u32).map(|i| material(i + 1, "m")).collect();
            let mut matches: Vec<(&Edit, u32)> =
                edits.iter().map(|e| (e, rng.below(5u32))).collect();
            let node = rng.below(5u32);
            let best = matches
                .iter()
                .filter(|(_, d)| *d <= node)
                .max_by_key(|(e, d)| (*d, e.id))
                .map(|(e, _)| e.id);
            rng.shuffle(&mut matches);
            let got = scope(node, matches.iter().copied());
            assert_eq!(got.first().map(|e| e.id), best, "{matches:?} at {node}");
        }
    }
}

//! Semantic queries in the replay (`crate::replay`): the patterns the
//! queries are grouped by, the tags a shape's path holds, each pattern's
//! reading of the entries kept from the last path, and the gate over the
//! children of that path's innermost tagged command.

use super::EditPlan;
use crate::ir::{SymbolId, TagId};
use crate::locator::Anchor;
use crate::tree::{Node, NodeKind};
use std::hash::{BuildHasherDefault, Hasher};

/// The hasher of keys that are hashes already ([`mix`]): the key is its
/// own hash.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Premixed(u64);

impl Hasher for Premixed {
    fn finish(&self) -> u64 {
        self.0
    }

    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = mix(self.0, i64::from(b));
        }
    }

    fn write_u64(&mut self, v: u64) {
        self.0 = v;
    }
}

/// A map from [`mix`]ed keys.
pub(super) type MixedMap<V> = std::collections::HashMap<u64, V, BuildHasherDefault<Premixed>>;

/// `h` with the index `v` mixed in (the wanted indices' key, one index
/// at a time: a multiply and a fold, so the map's low bits and high bits
/// both depend on every index).
#[inline]
pub(super) fn mix(h: u64, v: i64) -> u64 {
    let h = (h ^ v as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    h ^ (h >> 29)
}

/// The key of no index yet.
pub(super) const MIX_SEED: u64 = 0x243f_6a88_85a3_08d3;

/// Semantic queries that name the same tags with the same anchors, in the
/// same order (and the same label): the indices they want, each to its
/// edits.
#[derive(Clone, Debug, Default)]
pub(super) struct Pattern {
    /// The queries' label (`None`: unlabelled, any shape).
    pub(super) label: Option<SymbolId>,
    /// The tags named and their anchors, in order.
    pub(super) entries: Vec<(TagId, Anchor)>,
    /// The plan's slots ([`EditPlan::slot`]) of the entries' tags, one bit
    /// each; `None` when two entries name one tag or a tag has no slot
    /// (only the plain reading can match it).
    pub(super) mask: Option<u64>,
    /// The wanted indices (one per entry, anchored) to the edits, by the
    /// indices' [`mix`]: each key's list holds every wanted list with that
    /// key (almost always one).
    pub(super) wants: MixedMap<Vec<Wanted>>,
    /// A 256-bit filter of the wanted keys (bit `key >> 56`): most paths'
    /// keys are none, and cost a bit test instead of a map lookup.
    pub(super) filter: [u64; 4],
    /// The last wanted index of each wanted list, by the [`mix`] of the
    /// ones before it ([`Gate`]).
    pub(super) lasts: MixedMap<Vec<i64>>,
}

/// A list of wanted indices (one per pattern entry) and its edits.
pub(super) type Wanted = (Box<[i64]>, Vec<u32>);

/// A tagged command on a shape's path, of a tag some query names: the
/// tag, its slot's bit (0: no slot; a pattern's mask tests it in one
/// `and`) and the child's index and count.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PathTag {
    pub(super) tag: TagId,
    pub(super) bit: u64,
    pub(super) index: u32,
    pub(super) count: u32,
}

/// The slot of a tag named by queries beyond the first 64.
pub(super) const NO_SLOT: u8 = u8::MAX;

/// Scratch space of [`EditPlan::matches`], one per derivation job: the
/// path's tagged entries, and those above the innermost tagged command of
/// the last path read (a window's floor and facade, the same for the
/// hundred windows of a floor: the next window's walk stops at that
/// command, and each pattern's reading of them is kept). Node indices are
/// the job's, which never change.
#[derive(Debug, Default)]
pub(crate) struct PathScratch {
    /// The entries below the kept ones (innermost first).
    pub(super) tags: Vec<PathTag>,
    /// The last path's innermost tagged command, the entries above it
    /// (the job root's prefix included, innermost first) and every
    /// pattern's reading of them.
    /// (The command's position and tag: a walk that reaches it stops
    /// there without loading its node again.)
    pub(super) above_at: Option<(usize, TagId)>,
    pub(super) above: Vec<PathTag>,
    pub(super) readings: Vec<Reading>,
    /// Which children of that command a query may name, for the shapes
    /// of one symbol below it ([`Gate`]).
    pub(super) gate: Gate,
}

/// The children of the last path's innermost tagged command below which a
/// shape of symbol `symbol` may be named by a query: a shape's entry of
/// that command is the only one its walk reads below the kept ones, so the
/// patterns' readings of the kept entries and their wanted lists say which
/// of the command's children can complete one (the last wanted index
/// anchored back to a child's index). A floor's hundred windows cost a
/// bit test each instead of three pattern readings; a child let through
/// is read as before. Built for a symbol at its first shape below the
/// command; `all`: every child (a pattern complete above, or an index out
/// of the bits' range).
#[derive(Debug, Default)]
pub(super) struct Gate {
    pub(super) symbol: Option<SymbolId>,
    pub(super) all: bool,
    pub(super) bits: Vec<u64>,
}

/// The children's indices a gate keeps as bits.
const GATE_MAX: i64 = 1 << 16;

impl Gate {
    /// Whether child `index` may be named.
    #[inline]
    pub(super) fn lets(&self, index: u32) -> bool {
        self.all
            || self
                .bits
                .get(index as usize / 64)
                .is_some_and(|w| w >> (index % 64) & 1 != 0)
    }

    pub(super) fn add(&mut self, index: i64) {
        if !(0..GATE_MAX).contains(&index) {
            self.all = true;
            return;
        }
        let w = index as usize / 64;
        if self.bits.len() <= w {
            self.bits.resize(w + 1, 0);
        }
        self.bits[w] |= 1 << (index % 64);
    }
}

/// The index of the child (of `count`) whose index counted from `anchor`
/// is `v`: the inverse of `Anchor::index`.
pub(super) fn unanchor(anchor: Anchor, v: i64, count: u32) -> i64 {
    match anchor {
        Anchor::Start => v,
        Anchor::End => i64::from(count) + 1 - v,
        Anchor::Centre => v + i64::from(count.div_ceil(2).max(1)),
    }
}

/// A pattern's reading of a path so far, root first: the indices' key,
/// how many of its entries were met, and whether the path's entries of
/// its tags already differ from its own.
#[derive(Clone, Copy, Debug)]
pub(super) struct Reading {
    pub(super) key: u64,
    pub(super) met: u32,
    pub(super) failed: bool,
}

impl Reading {
    pub(super) const START: Reading = Reading {
        key: MIX_SEED,
        met: 0,
        failed: false,
    };
}

/// Add the entry of tag `tag` (child `index` of `count`) to `tags` if a
/// query names it.
#[inline]
pub(super) fn keep(slots: &[u8], tags: &mut Vec<PathTag>, (tag, index, count): (TagId, u32, u32)) {
    let slot = slots.get(tag.0 as usize).copied().unwrap_or(0);
    if slot != 0 {
        tags.push(PathTag {
            tag,
            bit: 1u64.checked_shl(u32::from(slot) - 1).unwrap_or(0),
            index,
            count,
        });
    }
}

impl Pattern {
    /// Whether the pattern names the tag of `e` (by its slot, when the
    /// pattern's tags all have one).
    #[inline]
    pub(super) fn names(&self, e: &PathTag) -> bool {
        match self.mask {
            Some(mask) => mask & e.bit != 0,
            None => self.entries.iter().any(|q| q.0 == e.tag),
        }
    }

    /// `r` with the path's entries `below` (innermost first) read
    /// ([`Pattern::read`]), the mask's test out of the loop.
    #[inline]
    pub(super) fn read_below(&self, mut r: Reading, below: &[PathTag]) -> Reading {
        let Some(mask) = self.mask else {
            below.iter().rev().for_each(|e| self.read(&mut r, e));
            return r;
        };
        for e in below.iter().rev() {
            if mask & e.bit == 0 {
                continue;
            }
            match self.entries.get(r.met as usize) {
                Some(&(tag, anchor)) if tag == e.tag => {
                    r.key = mix(r.key, anchor.index(e.index, e.count));
                    r.met += 1;
                }
                _ => {
                    r.failed = true;
                    break;
                }
            }
        }
        r
    }

    /// Read the path's next entry (root first) into `r`: an entry of a
    /// tag the pattern names must be its next entry, and its anchored
    /// index is mixed into the key.
    #[inline]
    pub(super) fn read(&self, r: &mut Reading, e: &PathTag) {
        if r.failed || !self.names(e) {
            return;
        }
        match self.entries.get(r.met as usize) {
            Some(&(tag, anchor)) if tag == e.tag => {
                r.key = mix(r.key, anchor.index(e.index, e.count));
                r.met += 1;
            }
            _ => r.failed = true,
        }
    }

    /// The edits of the queries of this pattern that match the path read
    /// into `r`, `above` then `below` (each innermost first): the path's
    /// entries of the tags the pattern names are its entries in order,
    /// and their anchored indices a wanted list.
    #[inline]
    pub(super) fn edits(&self, r: Reading, above: &[PathTag], below: &[PathTag]) -> Option<&[u32]> {
        if r.failed || r.met as usize != self.entries.len() {
            return None;
        }
        let bit = (r.key >> 56) as usize;
        if self.filter[bit / 64] >> (bit % 64) & 1 == 0 {
            return None;
        }
        // The key's lists, compared index by index.
        let read = || {
            above
                .iter()
                .rev()
                .chain(below.iter().rev())
                .filter(|e| self.names(e))
                .zip(&self.entries)
                .map(|(e, &(_, anchor))| anchor.index(e.index, e.count))
        };
        self.wants
            .get(&r.key)?
            .iter()
            .find(|(w, _)| w.iter().copied().eq(read()))
            .map(|(_, edits)| &edits[..])
    }
}

impl EditPlan {
    /// Build `gate` for the shapes of `symbol` whose one entry below the
    /// kept ones is `e`'s command's (each its own child): the children
    /// that complete a wanted list of one of `patterns` (the symbol's, with
    /// their `readings` of the kept entries).
    #[cold]
    #[inline(never)]
    pub(super) fn gate<'a>(
        &self,
        gate: &mut Gate,
        symbol: SymbolId,
        e: &PathTag,
        readings: &[Reading],
        patterns: impl Iterator<Item = &'a u32>,
    ) {
        gate.symbol = Some(symbol);
        gate.all = false;
        gate.bits.clear();
        for &k in patterns {
            let (Some(p), Some(&r)) = (self.semantic.get(k as usize), readings.get(k as usize))
            else {
                continue;
            };
            if r.failed {
                continue;
            }
            let met = r.met as usize;
            if !p.names(e) {
                // The child's entry is not read: the pattern matches all
                // of them or none.
                if met == p.entries.len() {
                    gate.all = true;
                }
                continue;
            }
            // Read, the child's entry must be the pattern's last.
            match p.entries.get(met) {
                Some(&(tag, anchor)) if tag == e.tag && met + 1 == p.entries.len() => {
                    for &v in p.lasts.get(&r.key).into_iter().flatten() {
                        gate.add(unanchor(anchor, v, e.count));
                    }
                }
                _ => {}
            }
        }
    }
}

/// Scratch space of [`EditPlan::quiet_children`], one per derivation job.
#[derive(Debug, Default)]
pub(crate) struct QuietScratch {
    tags: Vec<PathTag>,
    below: Vec<PathTag>,
    readings: Vec<Reading>,
    /// The children of one tagged command a query may still name below
    /// (`all`: every one), and that command's position and the patterns
    /// that counted ([`EditPlan::reaches`] of the children's symbol).
    gate: Gate,
    command: Option<(usize, u64)>,
    /// The last child's parent and symbol, where its one kept entry was
    /// its parent's (the gate decided it): a sibling of the same symbol
    /// under the same command is decided by the same gate at once.
    last: Option<(usize, Option<SymbolId>)>,
}

impl EditPlan {
    /// After the shape `nodes[at]` made the block `nodes[start..]` (its
    /// rule makes a command of a tag some query names,
    /// [`EditPlan::hands_down`]): for each of the block's shapes
    /// `children`, whether no query can name it or any shape below it,
    /// pushed on `out`. A child is quiet when every pattern's reading of
    /// its path (the tagged commands above `at`, `prefix` those above the
    /// job's root, then those in the block above the child) has failed, or
    /// is complete with indices no query wants: entries further down can
    /// only fail it. A reading still short of its pattern's entries, or
    /// complete with wanted indices, keeps the child looked at. A child
    /// whose one entry in the block is its own command's costs a bit test
    /// (the command's gate over all patterns, built once: a floor's
    /// hundred tiles); the shapes below a quiet one (a window, its frames
    /// and panes) then skip the walk up their path that a query's label
    /// would cost them.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn quiet_children(
        &self,
        nodes: &[Node],
        at: usize,
        start: usize,
        prefix: &[(TagId, u32, u32)],
        children: impl Iterator<Item = usize>,
        w: &mut QuietScratch,
        out: &mut Vec<bool>,
    ) {
        // The shape's own path, innermost first, and every pattern's
        // reading of it.
        w.tags.clear();
        crate::engine::walk_up(nodes, at, |p, cur| {
            if let NodeKind::Command { tag: Some(t), .. } = nodes[p].kind {
                keep(
                    &self.slot,
                    &mut w.tags,
                    (t, nodes[cur].index, nodes[cur].count),
                );
            }
        });
        for &entry in prefix {
            keep(&self.slot, &mut w.tags, entry);
        }
        w.readings.clear();
        for pattern in &self.semantic {
            let mut r = Reading::START;
            w.tags.iter().rev().for_each(|e| pattern.read(&mut r, e));
            w.readings.push(r);
        }
        w.command = None;
        w.last = None;
        for c in children {
            let up = nodes[c].parent_offset as usize;
            let symbol = match nodes[c].kind {
                NodeKind::Shape { symbol, .. } => Some(symbol),
                _ => None,
            };
            // A floor's hundred tiles: the same command, the same gate.
            if up != 0 && up <= c && w.last == Some((c - up, symbol)) {
                out.push(!w.gate.lets(nodes[c].index));
                continue;
            }
            w.last = None;
            // The tagged commands between the child and the shape, and
            // the innermost one's position.
            w.below.clear();
            let mut innermost = None;
            let mut cur = c;
            while cur > at {
                let up = nodes[cur].parent_offset as usize;
                if up == 0 || up > cur {
                    break;
                }
                let p = cur - up;
                if p < start {
                    break;
                }
                if let NodeKind::Command { tag: Some(t), .. } = nodes[p].kind {
                    let before = w.below.len();
                    keep(
                        &self.slot,
                        &mut w.below,
                        (t, nodes[cur].index, nodes[cur].count),
                    );
                    if innermost.is_none() && w.below.len() > before {
                        innermost = Some(p);
                    }
                }
                cur = p;
            }
            // The patterns whose label the child or a shape below it can
            // have (a bit each; all where the plan keeps no such table).
            let relevant = match nodes[c].kind {
                NodeKind::Shape { symbol, .. } => self.reaches(symbol),
                _ => u64::MAX,
            };
            let quiet =
                match (&w.below[..], innermost) {
                    ([], _) | (_, None) => false,
                    ([e], Some(p)) => {
                        if w.command != Some((p, relevant)) {
                            self.hand_down_gate(&mut w.gate, e, &w.readings, relevant);
                            w.command = Some((p, relevant));
                        }
                        if up != 0 && up <= c && c - up == p {
                            w.last = Some((p, symbol));
                        }
                        !w.gate.lets(e.index)
                    }
                    _ => self.semantic.iter().zip(&w.readings).enumerate().all(
                        |(k, (pattern, &r))| {
                            if r.failed || !counts(relevant, k) {
                                return true;
                            }
                            let r = pattern.read_below(r, &w.below);
                            r.failed
                                || (r.met as usize == pattern.entries.len() && !pattern.may_want(r))
                        },
                    ),
                };
            out.push(quiet);
        }
    }

    /// `gate` for the children of `e`'s command, their one entry in the
    /// block being theirs: those a query of any pattern may name below
    /// (with its `readings` of the path above). A pattern complete above
    /// with wanted indices, or short of its entries after the child's,
    /// lets every child through; one whose last entry is the child's
    /// lets the children its wanted lists end at. Only the patterns of
    /// `relevant` (a bit each, [`EditPlan::reaches`]) count: one whose
    /// label cannot be below the child lets none through.
    fn hand_down_gate(&self, gate: &mut Gate, e: &PathTag, readings: &[Reading], relevant: u64) {
        gate.symbol = None;
        gate.all = false;
        gate.bits.clear();
        for (k, (p, &r)) in self.semantic.iter().zip(readings).enumerate() {
            if r.failed || !counts(relevant, k) {
                continue;
            }
            let met = r.met as usize;
            if !p.names(e) {
                if met < p.entries.len() || p.may_want(r) {
                    gate.all = true;
                    return;
                }
                continue;
            }
            match p.entries.get(met) {
                Some(&(tag, anchor)) if tag == e.tag => {
                    if met + 1 < p.entries.len() {
                        gate.all = true;
                        return;
                    }
                    for &v in p.lasts.get(&r.key).into_iter().flatten() {
                        gate.add(unanchor(anchor, v, e.count));
                    }
                }
                // The child's entry is not the pattern's next: it fails.
                _ => {}
            }
        }
    }
}

/// Whether pattern `k` counts in `relevant` ([`EditPlan::reaches`]: a bit
/// per pattern; past 64 patterns the plan keeps no table and every
/// pattern counts).
#[inline]
fn counts(relevant: u64, k: usize) -> bool {
    k >= 64 || relevant >> k & 1 != 0
}

impl Pattern {
    /// Whether a complete reading's indices may be a wanted list (its key
    /// passes the filter and has lists; false: no query of the pattern
    /// wants them).
    fn may_want(&self, r: Reading) -> bool {
        let bit = (r.key >> 56) as usize;
        self.filter[bit / 64] >> (bit % 64) & 1 != 0 && self.wants.contains_key(&r.key)
    }
}

#[cfg(test)]
mod tests {
    /// Past 64 patterns every pattern counts, and no shift overflows.
    #[test]
    fn patterns_past_64_count_everywhere() {
        assert!(super::counts(0b10, 1));
        assert!(!super::counts(0b10, 0));
        assert!(super::counts(0, 64));
        assert!(super::counts(0, 200));
    }
}

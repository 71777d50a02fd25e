//! The two merges of a lower layout `U_a` and an upper `U_b` (4.1.3,
//! 4.1.4). Both build the shared graph ([`crate::shared`]).
//!
//! Hard merge `M_h`: every upper street stays; a lower piece stays unless
//! it lies inside a block of the upper layout (the upper components'
//! concave hulls) or runs along an upper street.
//!
//! Flexible merge `M_f` by graph cut: each piece's capacity is its
//! priority (times a numeric `priority` tag, e.g. from an anchored
//! assignment); dead ends are left out of the cut graph; border nodes
//! (a node of one side on a piece that reaches a crossing, and not inside
//! a block of the other side) are tied to the source (lower) or the sink
//! (upper) by arcs no cut can afford; when a side has no border node, the
//! ends of its five highest-priority streets are tied instead. The minimum
//! cut comes from `pathfinding`'s Edmonds-Karp; the source side is what
//! the residual graph reaches from the source. A lower piece stays when
//! both its ends are on the source side, an upper piece when both are on
//! the sink side; then mending adds back lower pieces with one end on the
//! source side, and lower pieces reached from the kept ones that do not
//! enter an upper block.
//!
//! Then (both): a street whose pieces all stayed, with nothing else at the
//! cuts, is whole again (its identity back); the parcels of every block
//! bounded by one side's streets alone come from that side, the other
//! blocks regrow; parcels that still clash are dropped, the lower side's
//! first.

use crate::blocks::Block;
use crate::geom::{self, point_in_ring};
use crate::id::Id;
use crate::index::{self, Boxed, bounds};
use crate::model::{Layout, Parcel, ParcelOrigin, TagValue};
use crate::shared::{Shared, Side};
use crate::subdivide::{MergeCache, ParcelParams, block_seed};
use crate::validity::{Violation, check};
use geo::Coord;
use pathfinding::directed::edmonds_karp::{SparseCapacity, edmonds_karp};
use rstar::RTree;
use std::collections::{BTreeMap, BTreeSet};

/// Which merge joins a layer to the layers above it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MergeMode {
    /// `M_h`: everything above stays.
    Hard,
    /// `M_f`: a minimum cut by street priorities.
    GraphCut,
}

impl MergeMode {
    pub fn name(self) -> &'static str {
        match self {
            MergeMode::Hard => "hard",
            MergeMode::GraphCut => "graph_cut",
        }
    }

    pub fn parse(s: &str) -> Option<MergeMode> {
        match s {
            "hard" => Some(MergeMode::Hard),
            "graph_cut" | "graphcut" | "flexible" => Some(MergeMode::GraphCut),
            _ => None,
        }
    }
}

/// The merge's knobs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MergeParams {
    pub parcels: ParcelParams,
    /// The seed regrown blocks' parcels are drawn from.
    pub seed: u64,
    /// How many of a side's highest-priority streets are tied when it has
    /// no border node (Lipp: 5).
    pub constrain_top: usize,
}

impl Default for MergeParams {
    fn default() -> Self {
        MergeParams {
            parcels: ParcelParams::default(),
            seed: 1,
            constrain_top: 5,
        }
    }
}

/// What a merge did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MergeReport {
    pub crossings: usize,
    /// The minimum cut's capacity (graph cut only).
    pub cut: i64,
    pub lower_pieces_dropped: usize,
    pub upper_pieces_dropped: usize,
    pub mended: usize,
    pub blocks_kept: usize,
    pub blocks_regrown: usize,
    pub parcels_dropped: usize,
}

/// Why a merge failed (the result would not be valid).
#[derive(Debug, Clone, PartialEq)]
pub enum MergeError {
    Invalid(Vec<Violation>),
}

impl std::fmt::Display for MergeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let MergeError::Invalid(v) = self;
        write!(
            f,
            "the merge left an invalid layout: {}",
            v.first().map(Violation::describe).unwrap_or_default()
        )
    }
}

/// A piece's capacity in the cut (integers: priorities in thousandths).
pub fn capacity(s: &crate::model::Street) -> i64 {
    let k = match s.tags.get("priority") {
        Some(TagValue::Num(x)) if x.is_finite() && *x >= 0.0 => *x,
        _ => 1.0,
    };
    let c = (s.priority * k * 1000.0).round();
    if c.is_finite() {
        (c as i64).clamp(1, 1 << 40)
    } else {
        1
    }
}

/// Blocks' boxes for point-in-block queries.
struct BlockIndex<'a> {
    /// Sorted by identity (as [`crate::blocks::blocks`] gives them).
    blocks: &'a [Block],
    tree: std::borrow::Cow<'a, RTree<Boxed>>,
}

/// The blocks' boxes (each block's identity and the bounds of its ring).
fn block_boxes(blocks: &[Block]) -> Vec<Boxed> {
    blocks
        .iter()
        .map(|b| {
            let (min, max) = bounds(&b.ring);
            Boxed { id: b.id, min, max }
        })
        .collect()
}

impl<'a> BlockIndex<'a> {
    fn new(blocks: &'a [Block]) -> Self {
        BlockIndex {
            blocks,
            tree: std::borrow::Cow::Owned(RTree::bulk_load(block_boxes(blocks))),
        }
    }

    /// Over a tree of the blocks' boxes kept elsewhere.
    fn with_tree(blocks: &'a [Block], tree: &'a RTree<Boxed>) -> Self {
        BlockIndex {
            blocks,
            tree: std::borrow::Cow::Borrowed(tree),
        }
    }

    /// Whether a point is inside some block's outer ring (a box stands for
    /// the last block with its identity).
    fn inside(&self, p: Coord) -> bool {
        self.tree
            .locate_in_envelope_intersecting(&rstar::AABB::from_point([p.x, p.y]))
            .any(|bx| {
                let k = self.blocks.partition_point(|b| b.id <= bx.id);
                k > 0
                    && self.blocks[k - 1].id == bx.id
                    && point_in_ring(p, &self.blocks[k - 1].ring)
            })
    }
}

fn midpoint(l: &Layout, id: Id) -> Option<Coord> {
    let s = l.streets.get(&id)?;
    if s.interior.is_empty() {
        // A straight street's polyline is its two ends (no list built).
        let (a, b) = (l.nodes.get(&s.a)?.pos, l.nodes.get(&s.b)?.pos);
        return Some(geom::polyline_midpoint(&[a, b]));
    }
    Some(geom::polyline_midpoint(&l.polyline(s)?))
}

/// Merges `upper` onto `lower` with the given mode.
pub fn merge(
    lower: &Layout,
    upper: &Layout,
    mode: MergeMode,
    params: &MergeParams,
) -> Result<(Layout, MergeReport), MergeError> {
    merge_cached(lower, upper, mode, params, &MergeCache::default())
}

/// [`merge`] with blocks and regrown parcels kept in a cache between calls
/// (the same results; a drag's updates repeat most of that work).
pub fn merge_cached(
    lower: &Layout,
    upper: &Layout,
    mode: MergeMode,
    params: &MergeParams,
    cache: &MergeCache,
) -> Result<(Layout, MergeReport), MergeError> {
    merge_step(lower, upper, None, mode, params, cache).map(|(l, r, _)| (l, r))
}

/// [`merge_cached`] given the upper side's blocks when the caller has them
/// (equal to [`crate::blocks::blocks`]`(upper)`: a stack's next merge has
/// the blocks of the result of the last), returning the result's blocks.
pub(crate) fn merge_step(
    lower: &Layout,
    upper: &Layout,
    upper_blocks: Option<Vec<Block>>,
    mode: MergeMode,
    params: &MergeParams,
    cache: &MergeCache,
) -> Result<(Layout, MergeReport, Vec<Block>), MergeError> {
    // The upper side and the result change where a dragged layer moved:
    // the faces, the indexes and the clash checks are kept per merge (a
    // slot named by the lower layout) and redone where they changed.
    let slot = |role: &str| {
        let mut m = Id::mint("merge-slot")
            .str(role)
            .u64(lower.streets.len() as u64);
        for id in lower
            .streets
            .keys()
            .take(1)
            .chain(lower.streets.keys().last())
        {
            m = m.id(*id);
        }
        m.finish()
    };
    // (Its isolated nodes are dropped with the result's, below.)
    let mut sh = crate::shared::shared_graph(lower, upper, false);
    let blocks_a = cache.blocks_shared(lower);
    let blocks_b = match upper_blocks {
        Some(b) => b,
        None => cache.blocks_in(slot("upper"), upper),
    };
    let mut boxes_b = cache
        .boxes
        .borrow_mut()
        .remove(&slot("upper"))
        .unwrap_or_default();
    boxes_b.update(block_boxes(&blocks_b));
    let idx_b = BlockIndex::with_tree(&blocks_b, boxes_b.tree());
    let mut report = MergeReport {
        crossings: sh.crossings.len(),
        ..MergeReport::default()
    };
    let mut keep: BTreeSet<Id> = match mode {
        MergeMode::Hard => hard_keep(&sh, &idx_b),
        MergeMode::GraphCut => cut_keep(
            &sh,
            &BlockIndex::new(blocks_a.as_slice()),
            &idx_b,
            params,
            &mut report,
        ),
    };
    drop(idx_b);
    {
        let mut c = cache.boxes.borrow_mut();
        if c.len() >= 64 {
            c.clear();
        }
        c.insert(slot("upper"), boxes_b);
    }
    clear_free_parcels(&sh, upper, &blocks_b, &mut keep);
    for (id, (side, _)) in &sh.origin {
        if !keep.contains(id) {
            match side {
                Side::A => report.lower_pieces_dropped += 1,
                Side::B => report.upper_pieces_dropped += 1,
            }
        }
    }
    // The shared graph's layout is not read past this point: its nodes
    // and kept pieces move into the result.
    let mut out = Layout {
        nodes: std::mem::take(&mut sh.layout.nodes),
        streets: std::mem::take(&mut sh.layout.streets)
            .into_iter()
            .filter(|(k, _)| keep.contains(k))
            .collect(),
        parcels: BTreeMap::new(),
        rests: BTreeMap::new(),
    };
    rejoin(&mut out, &sh);
    out.drop_isolated_nodes();
    // Which side each piece and whole street came from.
    // (Looked up only: a hash map.)
    let mut orig_side: crate::id::IdMap<Id, (Side, Id)> =
        crate::id::IdMap::with_capacity_and_hasher(
            sh.origin.len() + sh.originals.len(),
            Default::default(),
        );
    orig_side.extend(sh.origin.iter().map(|(k, v)| (*k, *v)));
    for (side, id) in sh.originals.keys() {
        orig_side.insert(*id, (*side, *id));
    }
    // The result's segments: an index kept for this merge and brought up
    // to date (only the changed streets' segments go out and in); a
    // street's side and width count as part of it (the clash checks read
    // them).
    let mut seg_index = cache
        .segs
        .borrow_mut()
        .remove(&slot("result"))
        .unwrap_or_default();
    let changes = seg_index.update(&out, out.streets.values(), |s| {
        let side = match orig_side.get(&s.id).map(|o| o.0) {
            Some(Side::A) => 1,
            Some(Side::B) => 2,
            None => 0,
        };
        (side, s.width)
    });
    let segs = seg_index.tree();
    // A street of one side that was not cut met no street of the other
    // side, and each side was valid: only the pieces and the streets at a
    // crossing can have come to meet wrongly (a debug build checks all).
    let seam: BTreeSet<Id> = out
        .streets
        .values()
        .filter(|s| {
            cfg!(debug_assertions)
                || sh.origin.get(&s.id).is_some_and(|o| o.1 != s.id)
                || sh.crossings.contains(&s.a)
                || sh.crossings.contains(&s.b)
        })
        .map(|s| s.id)
        .collect();
    if !crate::validity::check_streets(&out, segs, Some(&seam)).is_empty() {
        // The violations in the order a fresh index gives them.
        let fresh = index::segments(&out);
        return Err(MergeError::Invalid(crate::validity::check_streets(
            &out,
            &fresh,
            Some(&seam),
        )));
    }
    let result_blocks = parcels(
        &mut out,
        lower,
        upper,
        blocks_a.as_slice(),
        &blocks_b,
        params,
        &mut report,
        cache,
        segs,
        &changes,
        &orig_side,
        slot("result"),
    );
    {
        let mut c = cache.segs.borrow_mut();
        if c.len() >= 64 {
            c.clear();
        }
        c.insert(slot("result"), seg_index);
    }
    // The clash pass above settles the parcels; a debug build checks the
    // whole result as well (the test suites run it after every merge).
    let v = if cfg!(debug_assertions) {
        check(&out)
    } else {
        Vec::new()
    };
    if !v.is_empty() {
        return Err(MergeError::Invalid(v));
    }
    Ok((out, report, result_blocks))
}

/// The upper layout's free parcels (owned by none of its blocks) stand
/// like blocks of their own (Lipp encloses them with streets): a lower
/// piece that would touch one is dropped.
fn clear_free_parcels(sh: &Shared, upper: &Layout, blocks_b: &[Block], keep: &mut BTreeSet<Id>) {
    let own = crate::blocks::explicit_ownership(upper, blocks_b);
    let free: Vec<&Parcel> = upper
        .parcels
        .values()
        .filter(|p| p.origin == ParcelOrigin::Explicit && !own.contains_key(&p.id))
        .collect();
    if free.is_empty() {
        return;
    }
    let mut lower = Layout {
        nodes: sh.layout.nodes.clone(),
        ..Layout::default()
    };
    for id in keep.iter() {
        if sh.origin.get(id).is_some_and(|o| o.0 == Side::A)
            && let Some(s) = sh.layout.streets.get(id)
        {
            lower.streets.insert(*id, s.clone());
        }
    }
    let segs = index::segments(&lower);
    let max_half = lower
        .streets
        .values()
        .map(|s| s.width * 0.5)
        .fold(0.0, f64::max);
    for p in free {
        while let Some(hit) = crate::validity::parcel_street_hit(&lower, &segs, &p.ring, max_half) {
            keep.remove(&hit);
            lower.streets.remove(&hit);
        }
    }
}

fn hard_keep(sh: &Shared, idx_b: &BlockIndex) -> BTreeSet<Id> {
    sh.origin
        .iter()
        .filter(|(id, (side, _))| {
            *side == Side::B || midpoint(&sh.layout, **id).is_some_and(|m| !idx_b.inside(m))
        })
        .map(|(id, _)| *id)
        .collect()
}

fn cut_keep(
    sh: &Shared,
    idx_a: &BlockIndex,
    idx_b: &BlockIndex,
    params: &MergeParams,
    report: &mut MergeReport,
) -> BTreeSet<Id> {
    let l = &sh.layout;
    if sh.splits.is_empty() {
        // Nothing crosses: the union is planar as it is.
        return sh.origin.keys().copied().collect();
    }
    // Border nodes (on the whole shared graph): a node of one side on a
    // piece that reaches a crossing, not inside a block of the other side.
    let mut src: BTreeSet<Id> = BTreeSet::new();
    let mut snk: BTreeSet<Id> = BTreeSet::new();
    for s in l.streets.values() {
        let Some(&(side, _)) = sh.origin.get(&s.id) else {
            continue;
        };
        for (n, m) in [(s.a, s.b), (s.b, s.a)] {
            if !sh.crossings.contains(&m) || sh.crossings.contains(&n) {
                continue;
            }
            let Some(p) = l.nodes.get(&n).map(|x| x.pos) else {
                continue;
            };
            match side {
                Side::A if !idx_b.inside(p) => {
                    src.insert(n);
                }
                Side::B if !idx_a.inside(p) => {
                    snk.insert(n);
                }
                _ => {}
            }
        }
    }
    // A connected part of one side with fewer than n border nodes (it lies
    // inside the other side's blocks, or nearly) has the ends of its n
    // highest-priority pieces tied too (crossings as well, when that is all
    // they have): Lipp's special case (n = 5), per part, and also where a
    // stray node or two would otherwise be the part's only anchor.
    let tie_parts = |side: Side, set: &mut BTreeSet<Id>, other: &BTreeSet<Id>| {
        for part in side_parts(sh, side) {
            let mut border: BTreeSet<Id> = BTreeSet::new();
            for id in &part {
                let s = &l.streets[id];
                border.extend([s.a, s.b].into_iter().filter(|n| set.contains(n)));
            }
            if border.len() >= params.constrain_top {
                continue;
            }
            let mut v: Vec<(i64, Id)> = part
                .iter()
                .map(|id| (capacity(&l.streets[id]), *id))
                .collect();
            v.sort_by(|x, y| y.0.cmp(&x.0).then(x.1.cmp(&y.1)));
            for (_, id) in v.into_iter().take(params.constrain_top) {
                let s = &l.streets[&id];
                for n in [s.a, s.b] {
                    if !other.contains(&n) {
                        set.insert(n);
                    }
                }
            }
        }
    };
    tie_parts(Side::A, &mut src, &snk);
    tie_parts(Side::B, &mut snk, &src);
    // The cut graph without dead ends (peeled leaf by leaf; a node tied to
    // the source or the sink is no dead end).
    let mut adj: BTreeMap<Id, BTreeSet<Id>> = BTreeMap::new();
    for s in l.streets.values() {
        adj.entry(s.a).or_default().insert(s.id);
        adj.entry(s.b).or_default().insert(s.id);
    }
    let tied = |n: &Id| src.contains(n) || snk.contains(n);
    let mut removed_streets: BTreeSet<Id> = BTreeSet::new();
    let mut peel: Vec<(Id, Id)> = Vec::new(); // (leaf node, node it hangs from)
    let mut stack: Vec<Id> = adj
        .iter()
        .filter(|(n, e)| e.len() == 1 && !tied(n))
        .map(|(n, _)| *n)
        .collect();
    while let Some(n) = stack.pop() {
        let Some(es) = adj.get(&n) else { continue };
        if es.len() != 1 {
            continue;
        }
        let Some(&e) = es.iter().next() else { continue };
        let Some(s) = l.streets.get(&e) else { continue };
        let other = s.other(n);
        removed_streets.insert(e);
        adj.remove(&n);
        peel.push((n, other));
        if let Some(o) = adj.get_mut(&other)
            && o.remove(&e)
            && o.len() == 1
            && !tied(&other)
        {
            stack.push(other);
        }
    }
    snk.retain(|n| !src.contains(n));
    let mut edges: Vec<(Id, Id, i64)> = Vec::new();
    for s in l.streets.values() {
        if !removed_streets.contains(&s.id) {
            edges.push((s.a, s.b, capacity(s)));
        }
    }
    let (cut, mut in_s) = min_cut(&edges, &src, &snk);
    report.cut = cut;
    // Dead ends take the side of the node they hang from.
    for (leaf, from) in peel.iter().rev() {
        if in_s.contains(from) {
            in_s.insert(*leaf);
        }
    }
    let mut keep: BTreeSet<Id> = BTreeSet::new();
    for s in l.streets.values() {
        let Some(&(side, _)) = sh.origin.get(&s.id) else {
            continue;
        };
        let (ia, ib) = (in_s.contains(&s.a), in_s.contains(&s.b));
        let ok = match side {
            Side::A => ia && ib,
            Side::B => !ia && !ib,
        };
        if ok {
            keep.insert(s.id);
        }
    }
    // Mending: lower pieces with one end on the source side, then lower
    // pieces reached from kept ones that stay out of the upper blocks.
    for s in l.streets.values() {
        if sh.origin.get(&s.id).is_some_and(|o| o.0 == Side::A)
            && !keep.contains(&s.id)
            && (in_s.contains(&s.a) || in_s.contains(&s.b))
        {
            keep.insert(s.id);
            report.mended += 1;
        }
    }
    let mut inc: BTreeMap<Id, Vec<Id>> = BTreeMap::new();
    for s in l.streets.values() {
        if sh.origin.get(&s.id).is_some_and(|o| o.0 == Side::A) {
            inc.entry(s.a).or_default().push(s.id);
            inc.entry(s.b).or_default().push(s.id);
        }
    }
    let mut stack: Vec<Id> = keep
        .iter()
        .copied()
        .filter(|id| sh.origin.get(id).is_some_and(|o| o.0 == Side::A))
        .collect();
    while let Some(e) = stack.pop() {
        let s = &l.streets[&e];
        for n in [s.a, s.b] {
            for &f in inc.get(&n).map(Vec::as_slice).unwrap_or(&[]) {
                if keep.contains(&f) {
                    continue;
                }
                if midpoint(l, f).is_some_and(|m| !idx_b.inside(m)) {
                    keep.insert(f);
                    report.mended += 1;
                    stack.push(f);
                }
            }
        }
    }
    keep
}

/// The connected parts of one side's pieces (pieces joined at nodes), each
/// sorted; in order of their smallest piece.
fn side_parts(sh: &Shared, side: Side) -> Vec<Vec<Id>> {
    let mut at: BTreeMap<Id, Vec<Id>> = BTreeMap::new();
    let pieces: Vec<Id> = sh
        .origin
        .iter()
        .filter(|(_, o)| o.0 == side)
        .map(|(id, _)| *id)
        .collect();
    for id in &pieces {
        let s = &sh.layout.streets[id];
        at.entry(s.a).or_default().push(*id);
        at.entry(s.b).or_default().push(*id);
    }
    let mut seen: BTreeSet<Id> = BTreeSet::new();
    let mut parts = Vec::new();
    for id in &pieces {
        if !seen.insert(*id) {
            continue;
        }
        let mut part = vec![*id];
        let mut stack = vec![*id];
        while let Some(e) = stack.pop() {
            let s = &sh.layout.streets[&e];
            for n in [s.a, s.b] {
                for &f in at.get(&n).map(Vec::as_slice).unwrap_or(&[]) {
                    if seen.insert(f) {
                        part.push(f);
                        stack.push(f);
                    }
                }
            }
        }
        part.sort();
        parts.push(part);
    }
    parts
}

/// The minimum cut of an undirected graph with capacities, between the
/// nodes in `sources` (tied to a source) and those in `sinks` (tied to a
/// sink): its capacity and the nodes on the source side. The maximum flow
/// is `pathfinding`'s Edmonds-Karp; the source side is what the residual
/// graph reaches from the source.
pub fn min_cut(
    edges: &[(Id, Id, i64)],
    sources: &BTreeSet<Id>,
    sinks: &BTreeSet<Id>,
) -> (i64, BTreeSet<Id>) {
    let source = Id::mint("cut").str("source").finish();
    let sink = Id::mint("cut").str("sink").finish();
    let mut cap_map: BTreeMap<(Id, Id), i64> = BTreeMap::new();
    let mut total: i64 = 1;
    let mut vs: BTreeSet<Id> = BTreeSet::new();
    for &(a, b, c) in edges {
        if a == b || c <= 0 {
            continue;
        }
        total = total.saturating_add(c);
        *cap_map.entry((a, b)).or_default() += c;
        *cap_map.entry((b, a)).or_default() += c;
        vs.insert(a);
        vs.insert(b);
    }
    let inf = total.saturating_add(1);
    for n in sources {
        *cap_map.entry((source, *n)).or_default() += inf;
        vs.insert(*n);
    }
    for n in sinks.iter().filter(|n| !sources.contains(n)) {
        *cap_map.entry((*n, sink)).or_default() += inf;
        vs.insert(*n);
    }
    let mut vertices: Vec<Id> = vs.into_iter().collect();
    vertices.push(source);
    vertices.push(sink);
    let caps: Vec<((Id, Id), i64)> = cap_map.iter().map(|(k, c)| (*k, *c)).collect();
    let (flows, cut, _) =
        edmonds_karp::<Id, i64, _, SparseCapacity<i64>>(&vertices, &source, &sink, caps);
    let mut flow: BTreeMap<(Id, Id), i64> = BTreeMap::new();
    for ((u, v), f) in flows {
        *flow.entry((u, v)).or_default() += f;
    }
    let mut out_edges: BTreeMap<Id, Vec<Id>> = BTreeMap::new();
    for (u, v) in cap_map.keys() {
        out_edges.entry(*u).or_default().push(*v);
        out_edges.entry(*v).or_default().push(*u);
    }
    let residual = |u: Id, v: Id| {
        cap_map.get(&(u, v)).copied().unwrap_or(0) - flow.get(&(u, v)).copied().unwrap_or(0)
            + flow.get(&(v, u)).copied().unwrap_or(0)
    };
    let mut in_s: BTreeSet<Id> = BTreeSet::from([source]);
    let mut queue = vec![source];
    while let Some(u) = queue.pop() {
        for &v in out_edges.get(&u).map(Vec::as_slice).unwrap_or(&[]) {
            if !in_s.contains(&v) && residual(u, v) > 0 {
                in_s.insert(v);
                queue.push(v);
            }
        }
    }
    in_s.remove(&source);
    (cut, in_s)
}

/// A street whose pieces all stayed, with nothing else at its cuts, is
/// put back whole under its own identity.
fn rejoin(out: &mut Layout, sh: &Shared) {
    // How many streets meet at each node (as [`Layout::incidence`] counts
    // them: a loop once), before any street is put back.
    let mut degree: crate::id::IdMap<Id, usize> =
        crate::id::IdMap::with_capacity_and_hasher(out.nodes.len(), Default::default());
    for s in out.streets.values() {
        *degree.entry(s.a).or_default() += 1;
        if s.b != s.a {
            *degree.entry(s.b).or_default() += 1;
        }
    }
    for ((_, orig), pieces) in &sh.pieces {
        if pieces.len() < 2 || !pieces.iter().all(|p| out.streets.contains_key(p)) {
            continue;
        }
        let inner: Vec<Id> = pieces
            .windows(2)
            .filter_map(|w| {
                let (x, y) = (&out.streets[&w[0]], &out.streets[&w[1]]);
                [x.a, x.b].into_iter().find(|n| *n == y.a || *n == y.b)
            })
            .collect();
        if inner.len() + 1 != pieces.len()
            || inner.iter().any(|n| degree.get(n).is_none_or(|&d| d != 2))
        {
            continue;
        }
        let Some(whole) = sh.originals.get(&(sh.origin[&pieces[0]].0, *orig)) else {
            continue;
        };
        if out.streets.contains_key(&whole.id) {
            continue;
        }
        for p in pieces {
            out.streets.remove(p);
        }
        out.streets.insert(whole.id, whole.clone());
    }
}

/// The clash checks of one merge's result kept for the next merge in the
/// same slot: each parcel's verdict by its ring and its class (checked
/// against every street, the upper side's, or the lower side's), kept
/// while no changed street (gone, new, moved, widened, or of the other
/// side now) comes within its half width of the parcel's box.
#[derive(Debug, Default)]
pub(crate) struct ClashMemo {
    verdicts: crate::id::IdMap<Id, (Id, u8, bool)>,
}

#[allow(clippy::too_many_arguments)]
fn parcels<'a>(
    out: &mut Layout,
    lower: &'a Layout,
    upper: &'a Layout,
    blocks_a: &[Block],
    blocks_b: &[Block],
    params: &MergeParams,
    report: &mut MergeReport,
    cache: &MergeCache,
    segs: &rstar::RTree<index::Seg>,
    changes: &[index::SegChange],
    orig_side: &crate::id::IdMap<Id, (Side, Id)>,
    slot: Id,
) -> Vec<Block> {
    let result_blocks = cache.blocks_in(slot, out);
    let rings_a: BTreeMap<Id, &Block> = blocks_a.iter().map(|b| (b.id, b)).collect();
    let rings_b: BTreeMap<Id, &Block> = blocks_b.iter().map(|b| (b.id, b)).collect();
    // The block of one side this result block is (the same original
    // streets, the same area).
    let source_block = |b: &Block| -> Option<(Side, Id)> {
        // One side's streets only (every street known), and their
        // original streets, sorted, each once.
        let mut side = None;
        let mut origs: Vec<Id> = Vec::with_capacity(b.streets.len());
        for s in &b.streets {
            let (sd, o) = orig_side.get(s)?;
            if side.is_some_and(|x| x != *sd) {
                return None;
            }
            side = Some(*sd);
            origs.push(*o);
        }
        let side = side?;
        origs.sort_unstable();
        origs.dedup();
        let id = crate::blocks::block_id(&origs);
        let src = match side {
            Side::A => rings_a.get(&id),
            Side::B => rings_b.get(&id),
        }?;
        ((src.area - b.area).abs() <= 1e-6 * src.area.max(1.0)).then_some((side, id))
    };
    let own_a = crate::blocks::explicit_ownership(lower, blocks_a);
    let own_b = crate::blocks::explicit_ownership(upper, blocks_b);
    // Each side's parcels by the block that owns them: (block, parcel)
    // sorted by block, a block's parcels in identity order.
    let by_block = |l: &'a Layout, own: &BTreeMap<Id, Id>| -> Vec<(Id, &'a Parcel)> {
        let mut m: Vec<(Id, &Parcel)> = l
            .parcels
            .values()
            .filter_map(|p| {
                let b = match p.origin {
                    ParcelOrigin::Generated { block } => Some(block),
                    ParcelOrigin::Explicit => own.get(&p.id).copied(),
                };
                b.map(|b| (b, p))
            })
            .collect();
        // Stable: a block's parcels stay in identity order.
        m.sort_by_key(|x| x.0);
        m
    };
    let (parcels_a, parcels_b) = (by_block(lower, &own_a), by_block(upper, &own_b));
    let owned = |m: &[(Id, &Parcel)], block: Id| -> Vec<Parcel> {
        let k = m.partition_point(|x| x.0 < block);
        m[k..]
            .iter()
            .take_while(|x| x.0 == block)
            .map(|x| x.1.clone())
            .collect()
    };
    // Where each parcel came from (bits: the lower side, regrown, free),
    // looked up by identity; the free ones also in order (their boxes'
    // tree is loaded in that order).
    const FROM_A: u8 = 1;
    const FRESH: u8 = 2;
    const FREE: u8 = 4;
    let mut from: crate::id::IdMap<Id, u8> = crate::id::IdMap::with_capacity_and_hasher(
        lower.parcels.len() + upper.parcels.len(),
        Default::default(),
    );
    let mut free: BTreeSet<Id> = BTreeSet::new();
    for b in &result_blocks {
        // A block with another component inside (a hole of the other
        // side's streets and blocks) regrows.
        let src = if b.inner { None } else { source_block(b) };
        let kept = match src {
            Some((Side::B, id)) => Some(owned(&parcels_b, id)),
            Some((Side::A, id)) => Some(owned(&parcels_a, id)),
            None => None,
        };
        match kept {
            Some(ps) => {
                report.blocks_kept += 1;
                for mut p in ps {
                    // The parcel now belongs to the result's block.
                    if matches!(p.origin, ParcelOrigin::Generated { .. }) {
                        p.origin = ParcelOrigin::Generated { block: b.id };
                    }
                    if matches!(src, Some((Side::A, _))) {
                        *from.entry(p.id).or_default() |= FROM_A;
                    }
                    out.parcels.insert(p.id, p);
                }
            }
            None => {
                report.blocks_regrown += 1;
                for p in
                    cache.subdivide(out, segs, b, block_seed(params.seed, b.id), &params.parcels)
                {
                    *from.entry(p.id).or_default() |= FRESH;
                    out.parcels.insert(p.id, p);
                }
            }
        }
    }
    // Free parcels: the upper's, then the lower's.
    for (l, own, is_a) in [(upper, &own_b, false), (lower, &own_a, true)] {
        for p in l.parcels.values() {
            if p.origin == ParcelOrigin::Explicit
                && !own.contains_key(&p.id)
                && !out.parcels.contains_key(&p.id)
            {
                *from.entry(p.id).or_default() |= if is_a { FROM_A | FREE } else { FREE };
                free.insert(p.id);
                out.parcels.insert(p.id, p.clone());
            }
        }
    }
    // Clashes. Kept parcels lie in disjoint faces and regrown ones clear
    // their block's streets, so only these can clash: any parcel with a
    // street (a component inside a kept block), and a free or regrown
    // parcel with another parcel. The lower side's parcel goes first, then
    // a regrown one.
    let flags = |id: &Id| from.get(id).copied().unwrap_or(0);
    let rank = |id: &Id| {
        if flags(id) & FROM_A != 0 {
            0
        } else if flags(id) & FRESH != 0 {
            1
        } else {
            2
        }
    };
    let max_half = out
        .streets
        .values()
        .map(|s| s.width * 0.5)
        .fold(0.0, f64::max);
    // A kept parcel keeps clear of its own side's streets (its block is
    // that side's block, whole); the other side's streets, a wide one
    // passing close or one inside the block, are checked. Regrown and free
    // parcels are checked against every street.
    let side_of = |id: Id| orig_side.get(&id).map(|o| o.0);
    // Each parcel's verdict is kept from the last merge in this slot when
    // its ring and the streets it is checked against are the same there:
    // no changed street (gone, new, moved, widened or of the other side
    // now) comes within its half width of the parcel's box.
    let mut memo = cache.clash.borrow_mut().remove(&slot).unwrap_or_default();
    let dirty: RTree<Boxed> = RTree::bulk_load(
        changes
            .iter()
            .flat_map(|c| [(c.id, &c.old), (c.id, &c.new)])
            .filter_map(|(id, x)| x.as_ref().map(|x| (id, x)))
            .map(|(id, (pl, _, width))| {
                let (min, max) = bounds(pl);
                let r = width.abs() * 0.5;
                Boxed {
                    id,
                    min: [min[0] - r, min[1] - r],
                    max: [max[0] + r, max[1] + r],
                }
            })
            .collect(),
    );
    // The box around all of them: a parcel's box outside it meets none
    // (rstar's test, bounds included; a box with a NaN meets nothing).
    let reach = dirty.size().gt(&0).then(|| dirty.root().envelope());
    let may_meet =
        |env: &rstar::AABB<[f64; 2]>| reach.is_some_and(|r| rstar::Envelope::intersects(&r, env));
    // The changed streets as they are now: a parcel that was clear of
    // every street and is the same ring of the same class is clear now
    // unless one of these hits it (an unchanged street is the same
    // polyline, width and side: the same answer as last time).
    let changed_now: crate::id::IdMap<Id, &[Coord]> = changes
        .iter()
        .filter_map(|c| c.new.as_ref().map(|n| (c.id, n.0.as_slice())))
        .collect();
    let mut verdicts: crate::id::IdMap<Id, (Id, u8, bool)> =
        crate::id::IdMap::with_capacity_and_hasher(out.parcels.len(), Default::default());
    let mut on_street: Vec<Id> = Vec::new();
    for p in out.parcels.values() {
        let f = flags(&p.id);
        let class: u8 = if f & (FRESH | FREE) != 0 {
            0
        } else if f & FROM_A != 0 {
            1
        } else {
            2
        };
        let ring = crate::stack_cache::ring_key(&p.ring);
        let (min, max) = bounds(&p.ring);
        let same = memo
            .verdicts
            .get(&p.id)
            .filter(|v| v.0 == ring && v.1 == class);
        let side = match class {
            0 => None,
            1 => Some(Side::B),
            _ => Some(Side::A),
        };
        let keep = |id: Id| side.is_none() || side_of(id) == side;
        let near = |env: &rstar::AABB<[f64; 2]>| dirty.locate_in_envelope_intersecting(env);
        let env = index::grown(min, max, 0.0);
        let hit = match same {
            Some(v) if !may_meet(&env) || near(&env).next().is_none() => v.2,
            // Clear last time: only a changed street near it can hit it
            // now (the check [`crate::validity::parcel_street_hit_where`]
            // makes, street by street).
            Some(v) if !v.2 => {
                let mut ids: Vec<Id> = near(&env).map(|b| b.id).collect();
                ids.sort_unstable();
                ids.dedup();
                ids.into_iter().any(|id| {
                    keep(id)
                        && changed_now.get(&id).is_some_and(|pl| {
                            crate::validity::street_hits_ring(out, id, pl, &p.ring, min, max)
                        })
                })
            }
            _ => {
                !cache.ring_ok_key(ring, &p.ring)
                    || crate::validity::parcel_street_hit_where(out, segs, &p.ring, max_half, keep)
                        .is_some()
            }
        };
        verdicts.insert(p.id, (ring, class, hit));
        if hit {
            on_street.push(p.id);
        }
    }
    memo.verdicts = verdicts;
    {
        let mut c = cache.clash.borrow_mut();
        if c.len() >= 64 {
            c.clear();
        }
        c.insert(slot, memo);
    }
    let mut drop: BTreeSet<Id> = on_street.into_iter().collect();
    // Regrown parcels keep clear of each other and of kept ones (disjoint
    // faces); only a free parcel can overlap another.
    let free_boxes = rstar::RTree::bulk_load(
        free.iter()
            .filter_map(|id| out.parcels.get(id))
            .map(|p| {
                let (min, max) = bounds(&p.ring);
                Boxed { id: p.id, min, max }
            })
            .collect(),
    );
    if free_boxes.size() > 0 {
        for p in out.parcels.values() {
            if drop.contains(&p.id) {
                continue;
            }
            let (min, max) = bounds(&p.ring);
            for o in free_boxes.locate_in_envelope_intersecting(&index::grown(min, max, 0.0)) {
                if o.id == p.id || drop.contains(&o.id) || (free.contains(&p.id) && o.id < p.id) {
                    continue;
                }
                if crate::validity::rings_overlap(&p.ring, &out.parcels[&o.id].ring) {
                    drop.insert(if rank(&p.id) <= rank(&o.id) {
                        p.id
                    } else {
                        o.id
                    });
                    if drop.contains(&p.id) {
                        break;
                    }
                }
            }
        }
    }
    report.parcels_dropped += drop.len();
    for id in drop {
        out.parcels.remove(&id);
    }
    result_blocks
}

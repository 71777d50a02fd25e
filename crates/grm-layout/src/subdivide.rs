//! Blocks subdivided into parcels (4.1.2, "local regeneration"): the
//! block shrunk by its widest street's half width plus a setback, minus
//! any other street's corridor that comes near, then split recursively across the long axis of each piece's
//! minimum rotated rectangle (the split point jittered by the block's own
//! seed) until pieces are small enough. A parcel's identity is minted from
//! the block's identity and the split path, its random draws from the
//! block's seed alone, so regrowing one block changes nothing elsewhere.

use crate::blocks::Block;
use crate::geom::{self, check_ring, open_ccw};
use crate::id::{Id, Stream};
use crate::index::{Seg, bounds};
use crate::model::{Layout, Parcel, ParcelOrigin, Tags};
use geo::{Area, BooleanOps, Buffer, Coord, LineString, MinimumRotatedRect, MultiPolygon, Polygon};
use rstar::RTree;
use std::collections::BTreeSet;

/// How blocks are cut into parcels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParcelParams {
    /// A piece at most this large (m^2) becomes a parcel.
    pub max_area: f64,
    /// Pieces smaller than this are dropped (left open).
    pub min_area: f64,
    /// Extra distance (m) kept from a street's edge.
    pub setback: f64,
    /// The split point moves up to this fraction of the long side off centre.
    pub jitter: f64,
    /// Splits at most this deep.
    pub max_depth: u32,
}

impl Default for ParcelParams {
    fn default() -> Self {
        ParcelParams {
            max_area: 900.0,
            min_area: 40.0,
            setback: 1.0,
            jitter: 0.15,
            max_depth: 14,
        }
    }
}

impl ParcelParams {
    /// Whether every value is usable.
    /// (A block splits at most `max_depth` deep, at most 2^20 pieces: a
    /// bound on the work a file can ask for.)
    pub fn is_valid(&self) -> bool {
        self.max_depth <= 20
            && self.max_area.is_finite()
            && self.max_area >= 1.0
            && self.min_area.is_finite()
            && self.min_area >= 0.0
            && self.setback.is_finite()
            && self.setback > 0.0
            && self.jitter.is_finite()
            && (0.0..0.5).contains(&self.jitter)
    }
}

/// The seed of a block's parcels: the layer's seed and the block's identity.
pub fn block_seed(layer_seed: u64, block: Id) -> Id {
    Id::mint("block-seed").u64(layer_seed).id(block).finish()
}

/// The area of a block parcels may use: the block (minus its holes) shrunk
/// by the widest of its streets' half widths plus the setback (Lipp
/// shrinks the block by the distance to the road, 4.1.2), then minus the
/// corridor of any other street that comes near (a rectangle per segment
/// and an octagon around each point, half the street's width plus the
/// setback either side, taken away in one non-zero-fill difference).
pub fn parcel_area(
    layout: &Layout,
    segs: &RTree<Seg>,
    block: &Block,
    params: &ParcelParams,
) -> MultiPolygon {
    let holes: Vec<LineString> = block
        .holes
        .iter()
        .map(|h| geom::remove_spikes(h))
        .filter(|h| h.len() >= 3)
        .map(|h| LineString::new(geom::close(&h)))
        .collect();
    // Exterior counter-clockwise, holes clockwise: the offset reads rings
    // by their winding.
    let poly = geo::Orient::orient(
        &Polygon::new(
            LineString::new(geom::close(&geom::remove_spikes(&block.ring))),
            holes,
        ),
        geo::orient::Direction::Default,
    );
    // Streets around the block are kept clear by shrinking it; a street
    // with the block on both sides (a dead end) vanishes from the shrunk
    // outline, so it is cut away like any other street nearby.
    let own: BTreeSet<Id> = block
        .streets
        .iter()
        .copied()
        .filter(|s| !block.both_sides.contains(s))
        .collect();
    let inset = block
        .streets
        .iter()
        .filter_map(|id| layout.streets.get(id))
        .map(|s| s.width * 0.5)
        .fold(0.0, f64::max)
        + params.setback;
    let mut region = poly.buffer(-inset);
    if region.0.is_empty() {
        return region;
    }
    let (min, max) = bounds(&block.ring);
    let env = crate::index::grown(min, max, 0.0);
    let near: BTreeSet<Id> = segs
        .locate_in_envelope_intersecting(&env)
        .map(|s| s.street)
        .filter(|s| !own.contains(s))
        .collect();
    // Only corridor pieces whose boxes meet the shrunk block's box are
    // clipped: the others cannot take anything away, and `i_overlay`'s
    // work (and the grid it snaps to, scaled by its whole input's box)
    // follows what it is given. Every path (merge from scratch, cached,
    // incremental, the generators) computes a block's parcels here, so
    // they all clip the same pieces.
    let (rmin, rmax) = region_bounds(&region);
    let meets = |ring: &[Coord]| {
        let (min, max) = bounds(ring);
        min[0] <= rmax[0] && max[0] >= rmin[0] && min[1] <= rmax[1] && max[1] >= rmin[1]
    };
    let mut corridors: Vec<Polygon> = Vec::new();
    for id in near {
        let Some(s) = layout.streets.get(&id) else {
            continue;
        };
        let Some(pl) = layout.polyline(s) else {
            continue;
        };
        let d = s.width * 0.5 + params.setback;
        for w in pl.windows(2) {
            let (dx, dy) = (w[1].x - w[0].x, w[1].y - w[0].y);
            let l = dx.hypot(dy);
            if l <= 0.0 {
                continue;
            }
            let (nx, ny) = (-dy / l * d, dx / l * d);
            let c = |p: Coord, sx: f64| Coord {
                x: p.x + nx * sx,
                y: p.y + ny * sx,
            };
            let ring = vec![
                c(w[0], -1.0),
                c(w[1], -1.0),
                c(w[1], 1.0),
                c(w[0], 1.0),
                c(w[0], -1.0),
            ];
            if meets(&ring) {
                corridors.push(Polygon::new(LineString::new(ring), vec![]));
            }
        }
        let r = d / (std::f64::consts::PI / 8.0).cos();
        for p in &pl {
            let ring: Vec<Coord> = (0..=8)
                .map(|k| {
                    let (cos, sin) = OCTAGON[k % 8];
                    Coord {
                        x: p.x + r * cos,
                        y: p.y + r * sin,
                    }
                })
                .collect();
            if meets(&ring) {
                corridors.push(Polygon::new(LineString::new(ring), vec![]));
            }
        }
    }
    if !corridors.is_empty() {
        region = region.boolean_op_with_fill_rule(
            &MultiPolygon::new(corridors),
            geo::algorithm::bool_ops::OpType::Difference,
            geo::algorithm::bool_ops::FillRule::NonZero,
        );
    }
    region
}

/// The box of every exterior ring of a multipolygon (holes lie inside).
fn region_bounds(region: &MultiPolygon) -> ([f64; 2], [f64; 2]) {
    let mut min = [f64::INFINITY; 2];
    let mut max = [f64::NEG_INFINITY; 2];
    for p in &region.0 {
        let (a, b) = bounds(&p.exterior().0);
        min = [min[0].min(a[0]), min[1].min(a[1])];
        max = [max[0].max(b[0]), max[1].max(b[1])];
    }
    (min, max)
}

/// The corners of a corridor's octagon around a point: the cosine and
/// sine of `TAU * k / 8 + PI / 8` (computed once; the same bits).
static OCTAGON: std::sync::LazyLock<[(f64, f64); 8]> = std::sync::LazyLock::new(|| {
    std::array::from_fn(|k| {
        let a = std::f64::consts::TAU * f64::from(k as u8) / 8.0 + std::f64::consts::PI / 8.0;
        (a.cos(), a.sin())
    })
});

/// Parcels and blocks computed before, for a run of merges that repeat
/// work (dragging a layer: most regrown blocks and most layers' blocks are
/// the same from one update to the next). Keys hash everything the result
/// depends on, so a hit is what would be computed. Emptied when it holds
/// more than [`MergeCache::LIMIT`] entries. Per merge of a stack (a slot
/// named by the lower layout) it also keeps the last update's faces,
/// R-trees and clash verdicts, brought up to date where streets changed
/// (the incremental merge: the same bytes as a merge from scratch).
#[derive(Debug, Default)]
pub struct MergeCache {
    parcels: std::cell::RefCell<crate::id::IdMap<Id, Vec<Parcel>>>,
    blocks: std::cell::RefCell<crate::id::IdMap<Id, std::sync::Arc<Vec<Block>>>>,
    /// Merged prefixes of a layer stack ([`crate::layers::merge_layers_cached`]).
    pub stack: crate::stack_cache::StackCache,
    /// Whether a ring passes [`check_ring`], by the ring's content.
    rings: std::cell::RefCell<crate::id::IdMap<Id, bool>>,
    /// The faces of the last layout seen in each slot (a merge's upper
    /// side, its result), updated where the streets changed.
    faces: std::cell::RefCell<crate::id::IdMap<Id, crate::blocks::Faces>>,
    /// A merge's clash checks of its result's parcels, per slot, with the
    /// streets they were checked against.
    pub(crate) clash: std::cell::RefCell<crate::id::IdMap<Id, crate::merge::ClashMemo>>,
    /// A merge's result's street segments, per slot.
    pub(crate) segs: std::cell::RefCell<crate::id::IdMap<Id, crate::index::SegIndex>>,
    /// The boxes of a merge's upper blocks, per slot.
    pub(crate) boxes: std::cell::RefCell<crate::id::IdMap<Id, crate::index::BoxIndex>>,
}

impl MergeCache {
    pub const LIMIT: usize = 50_000;

    /// The blocks of a layout, from the cache when its streets are the same.
    pub fn blocks(&self, layout: &Layout) -> Vec<Block> {
        self.blocks_shared(layout).as_ref().clone()
    }

    /// [`MergeCache::blocks`] shared with the cache (not copied).
    pub(crate) fn blocks_shared(&self, layout: &Layout) -> std::sync::Arc<Vec<Block>> {
        let key = crate::stack_cache::streets_key(layout);
        if let Some(b) = self.blocks.borrow().get(&key) {
            return b.clone();
        }
        let b = std::sync::Arc::new(crate::blocks::blocks(layout));
        let mut c = self.blocks.borrow_mut();
        if c.len() >= Self::LIMIT {
            c.clear();
        }
        c.insert(key, b.clone());
        b
    }

    /// The blocks of a layout (equal to [`crate::blocks::blocks`]), from
    /// the faces kept in `slot` for the last layout seen there: only the
    /// faces through a changed street are traced again. A slot names a
    /// role (the upper side of the merge under some layer, its result);
    /// any slot gives the same blocks, a good one less work.
    pub fn blocks_in(&self, slot: Id, layout: &Layout) -> Vec<Block> {
        let mut f = self.faces.borrow_mut().remove(&slot).unwrap_or_default();
        let b = f.update(layout);
        let mut c = self.faces.borrow_mut();
        if c.len() >= 64 {
            c.clear();
        }
        c.insert(slot, f);
        b
    }

    /// Whether a ring is a simple polygon ([`check_ring`]), from the cache
    /// when the same ring was checked before (a merge's kept parcels are
    /// the same rings from one update to the next).
    pub fn ring_ok(&self, ring: &[Coord]) -> bool {
        self.ring_ok_key(crate::stack_cache::ring_key(ring), ring)
    }

    /// [`MergeCache::ring_ok`] with the ring's key computed already.
    pub(crate) fn ring_ok_key(&self, key: Id, ring: &[Coord]) -> bool {
        if let Some(&ok) = self.rings.borrow().get(&key) {
            return ok;
        }
        let ok = check_ring(ring).is_ok();
        let mut c = self.rings.borrow_mut();
        if c.len() >= Self::LIMIT {
            c.clear();
        }
        c.insert(key, ok);
        ok
    }

    /// The parcels of a block, from the cache when the block, its
    /// surroundings, the seed and the knobs are the same.
    pub fn subdivide(
        &self,
        layout: &Layout,
        segs: &RTree<Seg>,
        block: &Block,
        seed: Id,
        params: &ParcelParams,
    ) -> Vec<Parcel> {
        let mut m = Id::mint("parcels-of").id(block.id).id(seed);
        for v in [
            params.max_area,
            params.min_area,
            params.setback,
            params.jitter,
        ] {
            m = m.f64(v);
        }
        m = m.u64(u64::from(params.max_depth));
        for c in block.ring.iter().chain(block.holes.iter().flatten()) {
            m = m.f64(c.x).f64(c.y);
        }
        let (min, max) = bounds(&block.ring);
        let mut near: Vec<Id> = segs
            .locate_in_envelope_intersecting(&crate::index::grown(min, max, 0.0))
            .map(|s| s.street)
            .chain(block.streets.iter().copied())
            .collect();
        near.sort();
        near.dedup();
        for id in near {
            if let Some(s) = layout.streets.get(&id) {
                m = m.id(id).f64(s.width);
                for p in layout.polyline(s).unwrap_or_default() {
                    m = m.f64(p.x).f64(p.y);
                }
            }
        }
        let key = m.finish();
        if let Some(v) = self.parcels.borrow().get(&key) {
            return v.clone();
        }
        let v = subdivide_block(layout, segs, block, seed, params);
        let mut c = self.parcels.borrow_mut();
        if c.len() >= Self::LIMIT {
            c.clear();
        }
        c.insert(key, v.clone());
        v
    }
}

/// The parcels of one block.
pub fn subdivide_block(
    layout: &Layout,
    segs: &RTree<Seg>,
    block: &Block,
    seed: Id,
    params: &ParcelParams,
) -> Vec<Parcel> {
    let region = parcel_area(layout, segs, block, params);
    let mut out = Vec::new();
    let mut pieces: Vec<Polygon> = region.0;
    sort_pieces(&mut pieces);
    for (k, piece) in pieces.into_iter().enumerate() {
        split(piece, &mut vec![k as u8], block, seed, params, 0, &mut out);
    }
    out
}

fn sort_pieces(p: &mut [Polygon]) {
    // Deterministic order whatever the clipper returns: by lowest vertex.
    p.sort_by(|a, b| {
        let ka = key(a);
        let kb = key(b);
        ka.0.total_cmp(&kb.0).then(ka.1.total_cmp(&kb.1))
    });
}

fn key(p: &Polygon) -> (f64, f64) {
    p.exterior()
        .0
        .iter()
        .fold((f64::INFINITY, f64::INFINITY), |m, c| {
            if (c.y, c.x) < (m.0, m.1) {
                (c.y, c.x)
            } else {
                m
            }
        })
}

fn split(
    piece: Polygon,
    path: &mut Vec<u8>,
    block: &Block,
    seed: Id,
    params: &ParcelParams,
    depth: u32,
    out: &mut Vec<Parcel>,
) {
    let area = piece.unsigned_area();
    if area < params.min_area {
        return;
    }
    let simple = piece.interiors().is_empty();
    if (area <= params.max_area && simple) || depth >= params.max_depth.min(20) {
        if !simple {
            return;
        }
        let ring = open_ccw(piece.exterior());
        if check_ring(&ring).is_err() {
            return;
        }
        let mut m = Id::mint("parcel").id(block.id);
        for b in path.iter() {
            m = m.u64(u64::from(*b));
        }
        out.push(Parcel {
            id: m.finish(),
            ring,
            origin: ParcelOrigin::Generated { block: block.id },
            tags: Tags::new(),
        });
        return;
    }
    let Some(rect) = piece.minimum_rotated_rect() else {
        return;
    };
    let c = &rect.exterior().0;
    if c.len() < 4 {
        return;
    }
    let e0 = Coord {
        x: c[1].x - c[0].x,
        y: c[1].y - c[0].y,
    };
    let e1 = Coord {
        x: c[2].x - c[1].x,
        y: c[2].y - c[1].y,
    };
    let (l0, l1) = (e0.x.hypot(e0.y), e1.x.hypot(e1.y));
    let (long, llen) = if l0 >= l1 { (e0, l0) } else { (e1, l1) };
    if llen <= 0.0 {
        return;
    }
    let u = Coord {
        x: long.x / llen,
        y: long.y / llen,
    };
    let v = Coord { x: -u.y, y: u.x };
    let centre = geom::lerp(c[0], c[2], 0.5);
    let mut rng = Stream::new(Id::mint("split").id(seed).u64(path.len() as u64).finish());
    for b in path.iter() {
        rng = Stream::new(
            Id::mint("split")
                .u64(rng.next_u64())
                .u64(u64::from(*b))
                .finish(),
        );
    }
    let t = rng.range(-params.jitter, params.jitter) * llen;
    let at = Coord {
        x: centre.x + u.x * t,
        y: centre.y + u.y * t,
    };
    let big = llen + l0.min(l1) + 10.0;
    let half = |sign: f64| {
        let p = |a: f64, b: f64| Coord {
            x: at.x + u.x * a * sign + v.x * b,
            y: at.y + u.y * a * sign + v.y * b,
        };
        Polygon::new(
            LineString::new(vec![
                p(0.0, -big),
                p(big, -big),
                p(big, big),
                p(0.0, big),
                p(0.0, -big),
            ]),
            vec![],
        )
    };
    for (side, sign) in [(0u8, -1.0), (1u8, 1.0)] {
        let mut parts = piece.intersection(&half(sign)).0;
        sort_pieces(&mut parts);
        for (k, part) in parts.into_iter().enumerate() {
            path.push(side * 64 + (k.min(63) as u8));
            split(part, path, block, seed, params, depth + 1, out);
            path.pop();
        }
    }
}

/// Replaces the generated parcels of the given blocks (all blocks when
/// `only` is None) with freshly subdivided ones; explicit parcels stay.
pub fn regrow(
    layout: &mut Layout,
    blocks: &[Block],
    layer_seed: u64,
    params: &ParcelParams,
    only: Option<&BTreeSet<Id>>,
) {
    let segs = crate::index::segments(layout);
    let chosen: Vec<&Block> = blocks
        .iter()
        .filter(|b| only.is_none_or(|o| o.contains(&b.id)))
        .collect();
    let ids: BTreeSet<Id> = chosen.iter().map(|b| b.id).collect();
    // A regrown block's rest pose is gone (its parcels are new).
    layout
        .rests
        .retain(|k, _| only.is_some() && !ids.contains(k));
    layout.parcels.retain(|_, p| match p.origin {
        ParcelOrigin::Generated { block } => only.is_some() && !ids.contains(&block),
        ParcelOrigin::Explicit => true,
    });
    let boxes = crate::validity::parcel_boxes(layout);
    let mut fresh = Vec::new();
    for b in chosen {
        for p in subdivide_block(layout, &segs, b, block_seed(layer_seed, b.id), params) {
            // A parcel already there (given, or kept by a merge) keeps its place.
            let (min, max) = bounds(&p.ring);
            let clash = boxes
                .locate_in_envelope_intersecting(&crate::index::grown(min, max, 0.0))
                .any(|o| crate::validity::rings_overlap(&p.ring, &layout.parcels[&o.id].ring));
            if !clash {
                fresh.push(p);
            }
        }
    }
    for p in fresh {
        layout.parcels.insert(p.id, p);
    }
}

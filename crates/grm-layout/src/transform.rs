//! The non-topological transform T(U, A, W) (4.1.2): every node moves by
//! its weight towards its image under the affine map A
//! (`v' = v + w (A v - v)`, snapped to the grid), a street's interior
//! points by the weight interpolated between its ends. A move that makes a
//! street cross a street is rejected and the layout is left as it was.
//! Otherwise the parcels of every block around a moved node follow: a
//! block whose area or corner angles changed less than the thresholds
//! (against the pose its parcels were made in) moves its parcels smoothly
//! by mean value coordinates; a block that changed more, or whose smooth
//! parcels would touch a street, regrows its generated parcels. A block
//! back in its rest pose gets its parcels' rest rings back exactly, so
//! moving away and back restores identities and geometry.

use crate::blocks::{Block, blocks};
use crate::geom::{self, Affine, apply_coords, mean_value_coords, quantize};
use crate::id::Id;
use crate::index;
use crate::model::{BlockRest, Layout, Parcel, ParcelOrigin};
use crate::subdivide::{ParcelParams, block_seed, subdivide_block};
use crate::validity::{Violation, check_parcels, check_streets, parcel_street_hit};
use std::collections::{BTreeMap, BTreeSet};

/// How parcels follow a move.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UpdateParams {
    /// Relative area change above which a block regrows.
    pub area_threshold: f64,
    /// Corner-angle change (degrees) above which a block regrows.
    pub angle_threshold_deg: f64,
    pub parcels: ParcelParams,
    /// The layer's seed (each block's seed is minted from it).
    pub seed: u64,
}

impl Default for UpdateParams {
    fn default() -> Self {
        UpdateParams {
            area_threshold: 0.2,
            angle_threshold_deg: 15.0,
            parcels: ParcelParams::default(),
            seed: 1,
        }
    }
}

/// Why a transform was not applied.
#[derive(Debug, Clone, PartialEq)]
pub enum TransformError {
    /// The map or a weight is not a finite number.
    NotFinite,
    /// A weighted node is not in the layout.
    UnknownNode(Id),
    /// The move would change the topology (these violations).
    WouldIntersect(Vec<Violation>),
    /// A block would turn inside out or vanish.
    BlockCollapsed(Id),
    /// An explicit parcel would overlap a street or a parcel after moving.
    ParcelConflict(Vec<Violation>),
}

impl std::fmt::Display for TransformError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            TransformError::NotFinite => write!(f, "the transform or a weight is not finite"),
            TransformError::UnknownNode(id) => write!(f, "node {id} is not in the layer"),
            TransformError::WouldIntersect(v) => {
                write!(
                    f,
                    "the move would make streets cross: {}",
                    v.first().map(Violation::describe).unwrap_or_default()
                )
            }
            TransformError::BlockCollapsed(id) => write!(f, "block {id} would turn inside out"),
            TransformError::ParcelConflict(v) => {
                write!(
                    f,
                    "a given parcel would overlap: {}",
                    v.first().map(Violation::describe).unwrap_or_default()
                )
            }
        }
    }
}

/// What a transform did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Moved {
    pub nodes: usize,
    pub blocks_smoothed: usize,
    pub blocks_regrown: usize,
    pub blocks_restored: usize,
}

fn moved(p: geo::Coord, a: &Affine, w: f64) -> geo::Coord {
    let t = a.apply(p);
    quantize(geo::Coord {
        x: p.x + w * (t.x - p.x),
        y: p.y + w * (t.y - p.y),
    })
}

/// Applies T(U, A, W) to a layout in place; on an error the layout is unchanged.
pub fn transform(
    layout: &mut Layout,
    a: &Affine,
    weights: &BTreeMap<Id, f64>,
    params: &UpdateParams,
) -> Result<Moved, TransformError> {
    if !a.is_finite() || weights.values().any(|w| !w.is_finite()) {
        return Err(TransformError::NotFinite);
    }
    let w: BTreeMap<Id, f64> = weights
        .iter()
        .filter(|(_, w)| **w > 0.0)
        .map(|(k, v)| (*k, v.clamp(0.0, 1.0)))
        .collect();
    for id in w.keys() {
        if !layout.nodes.contains_key(id) {
            return Err(TransformError::UnknownNode(*id));
        }
    }
    let before = blocks(layout);
    let mut u = layout.clone();
    for (id, wt) in &w {
        if let Some(n) = u.nodes.get_mut(id) {
            n.pos = moved(n.pos, a, *wt);
        }
    }
    let mut touched_streets = BTreeSet::new();
    for s in u.streets.values_mut() {
        let (wa, wb) = (
            w.get(&s.a).copied().unwrap_or(0.0),
            w.get(&s.b).copied().unwrap_or(0.0),
        );
        if wa == 0.0 && wb == 0.0 {
            continue;
        }
        touched_streets.insert(s.id);
        let k = s.interior.len() as f64 + 1.0;
        for (i, p) in s.interior.iter_mut().enumerate() {
            let t = (i as f64 + 1.0) / k;
            let wi = wa + (wb - wa) * t;
            if wi > 0.0 {
                *p = moved(*p, a, wi);
            }
        }
    }
    let segs = index::segments(&u);
    let v = check_streets(&u, &segs, Some(&touched_streets));
    if !v.is_empty() {
        return Err(TransformError::WouldIntersect(v));
    }
    let after = blocks(&u);
    let after_by: BTreeMap<Id, &Block> = after.iter().map(|b| (b.id, b)).collect();
    let own = crate::blocks::explicit_ownership(layout, &before);
    let mut out = Moved {
        nodes: w.len(),
        ..Moved::default()
    };
    let mut changed_parcels: BTreeSet<Id> = BTreeSet::new();
    let max_half = u
        .streets
        .values()
        .map(|s| s.width * 0.5)
        .fold(0.0, f64::max);
    for b in before
        .iter()
        .filter(|b| b.nodes.iter().any(|n| w.contains_key(n)))
    {
        let Some(b1) = after_by.get(&b.id) else {
            return Err(TransformError::BlockCollapsed(b.id));
        };
        let members: Vec<Id> = u
            .parcels
            .values()
            .filter(|p| match p.origin {
                ParcelOrigin::Generated { block } => block == b.id,
                ParcelOrigin::Explicit => own.get(&p.id) == Some(&b.id),
            })
            .map(|p| p.id)
            .collect();
        let rest = u
            .rests
            .entry(b.id)
            .or_insert_with(|| BlockRest {
                ring: b.ring.clone(),
                parcels: members
                    .iter()
                    .filter_map(|id| layout.parcels.get(id).cloned())
                    .collect(),
            })
            .clone();
        for id in &members {
            u.parcels.remove(id);
        }
        let (new, how) = parcels_for(&u, &segs, &rest, b1, params, max_half);
        match how {
            How::Restored => out.blocks_restored += 1,
            How::Smoothed => out.blocks_smoothed += 1,
            How::Regrown => out.blocks_regrown += 1,
        }
        for p in new {
            changed_parcels.insert(p.id);
            u.parcels.insert(p.id, p);
        }
    }
    let live: BTreeSet<Id> = after.iter().map(|b| b.id).collect();
    u.rests.retain(|k, _| live.contains(k));
    // Every parcel near a moved street, and every parcel that changed, must be clear.
    let mut near: BTreeSet<Id> = changed_parcels;
    let boxes = crate::validity::parcel_boxes(&u);
    let max_half = u
        .streets
        .values()
        .map(|s| s.width * 0.5)
        .fold(0.0, f64::max);
    for sid in &touched_streets {
        if let Some(pl) = u.streets.get(sid).and_then(|s| u.polyline(s)) {
            let (min, max) = index::bounds(&pl);
            for bx in boxes.locate_in_envelope_intersecting(&index::grown(min, max, max_half)) {
                near.insert(bx.id);
            }
        }
    }
    let v = check_parcels(&u, &segs, Some(&near));
    if !v.is_empty() {
        return Err(TransformError::ParcelConflict(v));
    }
    *layout = u;
    Ok(out)
}

enum How {
    Restored,
    Smoothed,
    Regrown,
}

/// A block's parcels in a new pose, from its rest pose alone: the rest
/// parcels when the ring is the rest ring; else the given (explicit)
/// parcels moved smoothly, and the generated ones moved smoothly too
/// unless the block changed past the thresholds or a moved parcel would
/// touch a street, when they regrow (clear of the explicit ones).
fn parcels_for(
    u: &Layout,
    segs: &rstar::RTree<index::Seg>,
    rest: &BlockRest,
    b1: &Block,
    params: &UpdateParams,
    max_half: f64,
) -> (Vec<Parcel>, How) {
    if rest.ring == b1.ring {
        return (rest.parcels.clone(), How::Restored);
    }
    let mut explicit = Vec::new();
    let mut generated = Vec::new();
    let mut regrow = too_different(&rest.ring, &b1.ring, params);
    for p in &rest.parcels {
        let is_gen = matches!(p.origin, ParcelOrigin::Generated { .. });
        if is_gen && regrow {
            continue;
        }
        let mut q = p.clone();
        match smooth(&p.ring, &rest.ring, &b1.ring) {
            Some(r) => q.ring = r,
            None if is_gen => regrow = true,
            None => {}
        }
        if is_gen {
            if geom::check_ring(&q.ring).is_err()
                || parcel_street_hit(u, segs, &q.ring, max_half).is_some()
            {
                regrow = true;
            }
            generated.push(q);
        } else {
            explicit.push(q);
        }
    }
    if !regrow {
        // Smoothing bends shared edges with a vertex of one parcel in the
        // middle of the other's edge; parcels that then overlap regrow.
        let all: Vec<&Parcel> = explicit.iter().chain(generated.iter()).collect();
        let clash = generated.iter().any(|g| {
            all.iter()
                .any(|o| o.id != g.id && crate::validity::rings_overlap(&g.ring, &o.ring))
        });
        if !clash {
            explicit.extend(generated);
            return (explicit, How::Smoothed);
        }
    }
    for p in subdivide_block(u, segs, b1, block_seed(params.seed, b1.id), &params.parcels) {
        if !explicit
            .iter()
            .any(|e| crate::validity::rings_overlap(&e.ring, &p.ring))
        {
            explicit.push(p);
        }
    }
    (explicit, How::Regrown)
}

fn too_different(a: &[geo::Coord], b: &[geo::Coord], p: &UpdateParams) -> bool {
    if a.len() != b.len() {
        return true;
    }
    let (aa, ab) = (geom::signed_area(a), geom::signed_area(b));
    if aa <= 0.0 || (ab / aa - 1.0).abs() > p.area_threshold {
        return true;
    }
    let lim = p.angle_threshold_deg.to_radians();
    geom::angles(a).iter().zip(geom::angles(b)).any(|(x, y)| {
        let d = (x - y).abs();
        d.min(std::f64::consts::TAU - d) > lim
    })
}

/// A parcel ring carried from one pose of its block to another by mean
/// value coordinates.
fn smooth(ring: &[geo::Coord], from: &[geo::Coord], to: &[geo::Coord]) -> Option<Vec<geo::Coord>> {
    if from.len() != to.len() {
        return None;
    }
    ring.iter()
        .map(|p| {
            let w = mean_value_coords(*p, from)?;
            let c = apply_coords(&w, to);
            (c.x.is_finite() && c.y.is_finite()).then_some(c)
        })
        .collect()
}

//! The spatial index (rstar R-tree) over street segments and parcel
//! boxes that the validity check and the merges query.

use crate::id::Id;
use crate::model::Layout;
use geo::Coord;
use rstar::{AABB, RTree, RTreeObject};

/// One segment of a street.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Seg {
    pub street: Id,
    /// The segment's index along the street's polyline.
    pub k: usize,
    pub a: Coord,
    pub b: Coord,
}

impl RTreeObject for Seg {
    type Envelope = AABB<[f64; 2]>;
    fn envelope(&self) -> Self::Envelope {
        AABB::from_corners([self.a.x, self.a.y], [self.b.x, self.b.y])
    }
}

/// A box with an identity (a parcel's or a block's bounds).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Boxed {
    pub id: Id,
    pub min: [f64; 2],
    pub max: [f64; 2],
}

impl RTreeObject for Boxed {
    type Envelope = AABB<[f64; 2]>;
    fn envelope(&self) -> Self::Envelope {
        AABB::from_corners(self.min, self.max)
    }
}

/// The bounds of some points.
pub fn bounds(pts: &[Coord]) -> ([f64; 2], [f64; 2]) {
    let mut min = [f64::INFINITY; 2];
    let mut max = [f64::NEG_INFINITY; 2];
    for p in pts {
        min[0] = min[0].min(p.x);
        min[1] = min[1].min(p.y);
        max[0] = max[0].max(p.x);
        max[1] = max[1].max(p.y);
    }
    (min, max)
}

/// Every street segment of a layout, bulk-loaded.
pub fn segments(layout: &Layout) -> RTree<Seg> {
    segments_where(layout, |_| true)
}

/// The segments of the streets `keep` accepts.
pub fn segments_where(layout: &Layout, keep: impl Fn(Id) -> bool) -> RTree<Seg> {
    let mut v = Vec::new();
    for s in layout.streets.values().filter(|s| keep(s.id)) {
        if let Some(pl) = layout.polyline(s) {
            for (k, w) in pl.windows(2).enumerate() {
                v.push(Seg {
                    street: s.id,
                    k,
                    a: w[0],
                    b: w[1],
                });
            }
        }
    }
    RTree::bulk_load(v)
}

/// The box around `min..max` grown by `r`.
pub fn grown(min: [f64; 2], max: [f64; 2], r: f64) -> AABB<[f64; 2]> {
    AABB::from_corners([min[0] - r, min[1] - r], [max[0] + r, max[1] + r])
}

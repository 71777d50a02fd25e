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

/// Whether two point lists are the same bit for bit (0 and -0 differ, so
/// what is kept because it is the same gives the same bytes).
pub fn same_bits(a: &[Coord], b: &[Coord]) -> bool {
    a.len() == b.len()
        && a.iter()
            .zip(b)
            .all(|(p, q)| p.x.to_bits() == q.x.to_bits() && p.y.to_bits() == q.y.to_bits())
}

/// What a street is indexed as: its polyline and a caller's mark (a side,
/// a width) that counts as part of it.
pub type Indexed = (Vec<Coord>, u8, f64);

/// A street that changed between two updates of a [`SegIndex`]: as it was
/// indexed (None: new) and as it is (None: gone).
#[derive(Debug, Clone)]
pub struct SegChange {
    pub id: Id,
    /// The street's end nodes now (when it is there).
    pub ends: (Id, Id),
    pub old: Option<Indexed>,
    pub new: Option<Indexed>,
}

/// An R-tree of street segments kept up to date with a layout's streets
/// from one update to the next: only changed streets' segments are taken
/// out and put in. The tree's shape then depends on its history, so its
/// users read queries as sets (a minimum, a sorted list), never in the
/// order the tree gives them.
#[derive(Debug, Default)]
pub struct SegIndex {
    /// Street -> its end nodes and how it is indexed.
    streets: std::collections::BTreeMap<Id, (Id, Id, Indexed)>,
    tree: RTree<Seg>,
}

fn same_indexed(
    layout: &Layout,
    s: &crate::model::Street,
    kept: &(Id, Id, Indexed),
    mark: (u8, f64),
) -> bool {
    let old = &kept.2;
    let pl = &old.0;
    if kept.0 != s.a || kept.1 != s.b {
        return false;
    }
    let n = pl.len();
    if old.1 != mark.0 || old.2.to_bits() != mark.1.to_bits() || n != s.interior.len() + 2 {
        return false;
    }
    let (Some(a), Some(b)) = (layout.nodes.get(&s.a), layout.nodes.get(&s.b)) else {
        return false;
    };
    same_bits(&pl[..1], &[a.pos])
        && same_bits(&pl[n - 1..], &[b.pos])
        && same_bits(&pl[1..n - 1], &s.interior)
}

fn segs_of(id: Id, pl: &[Coord]) -> impl Iterator<Item = Seg> + '_ {
    pl.windows(2).enumerate().map(move |(k, w)| Seg {
        street: id,
        k,
        a: w[0],
        b: w[1],
    })
}

impl SegIndex {
    pub fn tree(&self) -> &RTree<Seg> {
        &self.tree
    }

    /// Brings the index to `streets` (in identity order, their end nodes in
    /// `layout`; a street without both end nodes is left out), each with
    /// its mark; returns the streets that changed.
    pub fn update<'a>(
        &mut self,
        layout: &Layout,
        streets: impl Iterator<Item = &'a crate::model::Street>,
        mark: impl Fn(&crate::model::Street) -> (u8, f64),
    ) -> Vec<SegChange> {
        let mut changes: Vec<SegChange> = Vec::new();
        let mut olds = self.streets.iter().peekable();
        for s in streets {
            while let Some((&id, old)) = olds.peek().copied()
                && id < s.id
            {
                changes.push(SegChange {
                    id,
                    ends: (old.0, old.1),
                    old: Some(old.2.clone()),
                    new: None,
                });
                olds.next();
            }
            let m = mark(s);
            let old = match olds.peek().copied() {
                Some((&id, old)) if id == s.id => {
                    olds.next();
                    if same_indexed(layout, s, old, m) {
                        continue;
                    }
                    Some(old.2.clone())
                }
                _ => None,
            };
            let new = layout.polyline(s).map(|pl| (pl, m.0, m.1));
            if old.is_some() || new.is_some() {
                changes.push(SegChange {
                    id: s.id,
                    ends: (s.a, s.b),
                    old,
                    new,
                });
            }
        }
        for (&id, old) in olds {
            changes.push(SegChange {
                id,
                ends: (old.0, old.1),
                old: Some(old.2.clone()),
                new: None,
            });
        }
        if self.streets.is_empty() {
            // A first update: load the tree in one go.
            let mut v = Vec::new();
            for c in &changes {
                if let Some(new) = &c.new {
                    v.extend(segs_of(c.id, &new.0));
                    self.streets.insert(c.id, (c.ends.0, c.ends.1, new.clone()));
                }
            }
            self.tree = RTree::bulk_load(v);
            return changes;
        }
        for c in &changes {
            if let Some(old) = &c.old {
                for sg in segs_of(c.id, &old.0) {
                    self.tree.remove(&sg);
                }
                self.streets.remove(&c.id);
            }
            if let Some(new) = &c.new {
                for sg in segs_of(c.id, &new.0) {
                    self.tree.insert(sg);
                }
                self.streets.insert(c.id, (c.ends.0, c.ends.1, new.clone()));
            }
        }
        changes
    }
}

/// An R-tree of boxes kept up to date with a list of boxes from one update
/// to the next (only the boxes that changed go out and in). Read its
/// queries as sets.
#[derive(Debug, Default)]
pub struct BoxIndex {
    boxes: Vec<Boxed>,
    tree: RTree<Boxed>,
}

fn box_key(b: &Boxed) -> (Id, [u64; 4]) {
    (
        b.id,
        [
            b.min[0].to_bits(),
            b.min[1].to_bits(),
            b.max[0].to_bits(),
            b.max[1].to_bits(),
        ],
    )
}

impl BoxIndex {
    pub fn tree(&self) -> &RTree<Boxed> {
        &self.tree
    }

    /// Brings the tree to these boxes.
    pub fn update(&mut self, mut boxes: Vec<Boxed>) {
        boxes.sort_by_key(box_key);
        if self.boxes.is_empty() {
            self.tree = RTree::bulk_load(boxes.clone());
            self.boxes = boxes;
            return;
        }
        let (mut i, mut j) = (0, 0);
        let (old, new) = (&self.boxes, &boxes);
        while i < old.len() || j < new.len() {
            let o = old.get(i).map(box_key);
            let n = new.get(j).map(box_key);
            match (o, n) {
                (Some(x), Some(y)) if x == y => {
                    i += 1;
                    j += 1;
                }
                (Some(x), Some(y)) if x < y => {
                    self.tree.remove(&old[i]);
                    i += 1;
                }
                (Some(_), None) => {
                    self.tree.remove(&old[i]);
                    i += 1;
                }
                _ => {
                    self.tree.insert(new[j]);
                    j += 1;
                }
            }
        }
        self.boxes = boxes;
    }
}

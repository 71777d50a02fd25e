//! The density term's per-particle state: a persistent spatial hash of bone
//! midpoints.
//!
//! The sampler clones a particle's state whenever it resamples, then adds a
//! bone to each copy, so cloning must be O(1) and adding must not copy the
//! whole set. [`PersistentGrid`] is a hash trie of fixed depth
//! ([`LEVELS`] levels of [`WIDTH`] children, 4096 buckets) whose buckets are
//! shared immutable linked lists: clone = one `Arc` increment, insert = a
//! path copy of `LEVELS` small nodes (bitmap-compressed: only occupied
//! children are stored and cloned) plus one list cell, query = a walk down
//! the trie per grid cell touched. Points are bucketed by grid cell (edge
//! `2 * radius`), so a query ball of the given radius touches at most 8 cells.

use std::sync::Arc;

use glam::DVec3;

const BITS: u32 = 4;
const WIDTH: usize = 1 << BITS;
const LEVELS: u32 = 3;

type Cell = [i32; 3];

#[derive(Debug)]
struct Cons {
    cell: Cell,
    point: DVec3,
    next: Option<Arc<Cons>>,
}

impl Drop for Cons {
    /// Iterative drop: a long bucket list must not overflow the stack.
    fn drop(&mut self) {
        let mut next = self.next.take();
        while let Some(node) = next {
            match Arc::try_unwrap(node) {
                Ok(mut owned) => next = owned.next.take(),
                Err(_) => break,
            }
        }
    }
}

#[derive(Clone, Debug, Default)]
enum Slot {
    #[default]
    Empty,
    /// A trie node: the children whose bits are set in the bitmap, in bit
    /// order (only occupied children are stored, so a path copy clones
    /// only those).
    Inner(u16, Arc<[Slot]>),
    List(Arc<Cons>),
}

/// A persistent set of points bucketed by grid cell (see the module docs).
#[derive(Clone, Debug)]
pub(crate) struct PersistentGrid {
    cell_size: f64,
    root: Slot,
    len: usize,
}

fn hash(cell: Cell) -> u32 {
    let mut h = (cell[0] as u32).wrapping_mul(0x9E37_79B1);
    h ^= (cell[1] as u32).wrapping_mul(0x85EB_CA77);
    h = h.rotate_left(13);
    h ^= (cell[2] as u32).wrapping_mul(0xC2B2_AE3D);
    h ^= h >> 15;
    h = h.wrapping_mul(0x2C1B_3C6D);
    h ^ (h >> 12)
}

fn cell_coord(x: f64, cell_size: f64) -> i32 {
    // Saturating cast: far-away points share the outermost cells, which
    // only costs speed, not correctness (distances are checked exactly).
    (x / cell_size).floor() as i32
}

impl PersistentGrid {
    /// An empty grid for queries of radius `radius` (> 0).
    pub(crate) fn new(radius: f64) -> Self {
        Self {
            cell_size: 2.0 * radius,
            root: Slot::Empty,
            len: 0,
        }
    }

    /// Number of points.
    #[cfg(test)]
    pub(crate) fn len(&self) -> usize {
        self.len
    }

    fn cell_of(&self, p: DVec3) -> Cell {
        [
            cell_coord(p.x, self.cell_size),
            cell_coord(p.y, self.cell_size),
            cell_coord(p.z, self.cell_size),
        ]
    }

    /// Adds a point (path copy; other clones are unaffected).
    pub(crate) fn insert(&mut self, p: DVec3) {
        let cell = self.cell_of(p);
        self.root = insert(&self.root, hash(cell), 0, cell, p);
        self.len += 1;
    }

    /// Calls `f(q)` for every stored point `q` within `radius` of `p`
    /// (strictly closer), `radius <= cell_size / 2`.
    pub(crate) fn for_each_within(&self, p: DVec3, radius: f64, mut f: impl FnMut(DVec3)) {
        let lo = self.cell_of(p - DVec3::splat(radius));
        let hi = self.cell_of(p + DVec3::splat(radius));
        let r2 = radius * radius;
        for x in lo[0]..=hi[0] {
            for y in lo[1]..=hi[1] {
                for z in lo[2]..=hi[2] {
                    let cell = [x, y, z];
                    let mut node = bucket(&self.root, hash(cell));
                    while let Some(c) = node {
                        if c.cell == cell && c.point.distance_squared(p) < r2 {
                            f(c.point);
                        }
                        node = c.next.as_deref();
                    }
                }
            }
        }
    }
}

fn child_bit(h: u32, level: u32) -> u16 {
    1 << ((h >> (level * BITS)) as usize & (WIDTH - 1))
}

fn insert(slot: &Slot, h: u32, level: u32, cell: Cell, p: DVec3) -> Slot {
    if level == LEVELS {
        let next = match slot {
            Slot::List(l) => Some(Arc::clone(l)),
            _ => None,
        };
        return Slot::List(Arc::new(Cons {
            cell,
            point: p,
            next,
        }));
    }
    let bit = child_bit(h, level);
    match slot {
        Slot::Inner(bitmap, kids) => {
            let pos = (bitmap & (bit - 1)).count_ones() as usize;
            if bitmap & bit != 0 {
                let mut new = Some(insert(&kids[pos], h, level + 1, cell, p));
                let kids: Arc<[Slot]> = kids
                    .iter()
                    .enumerate()
                    .map(|(j, k)| {
                        if j == pos {
                            new.take().unwrap_or_default()
                        } else {
                            k.clone()
                        }
                    })
                    .collect();
                Slot::Inner(*bitmap, kids)
            } else {
                let new = insert(&Slot::Empty, h, level + 1, cell, p);
                let kids: Arc<[Slot]> = kids[..pos]
                    .iter()
                    .cloned()
                    .chain(std::iter::once(new))
                    .chain(kids[pos..].iter().cloned())
                    .collect();
                Slot::Inner(bitmap | bit, kids)
            }
        }
        _ => {
            let new = insert(&Slot::Empty, h, level + 1, cell, p);
            Slot::Inner(bit, Arc::new([new]))
        }
    }
}

fn bucket(root: &Slot, h: u32) -> Option<&Cons> {
    let mut slot = root;
    for level in 0..LEVELS {
        match slot {
            Slot::Inner(bitmap, kids) => {
                let bit = child_bit(h, level);
                if bitmap & bit == 0 {
                    return None;
                }
                slot = &kids[(bitmap & (bit - 1)).count_ones() as usize];
            }
            _ => return None,
        }
    }
    match slot {
        Slot::List(l) => Some(l),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn query_matches_brute_force_and_clones_are_independent() {
        let mut rng = grm_testkit::Rng::seeded(7);
        let r = 0.3;
        let mut g = PersistentGrid::new(r);
        let mut pts = Vec::new();
        for _ in 0..2000 {
            let p = DVec3::new(rng.unit(), rng.unit(), rng.unit()) * 4.0 - 2.0;
            g.insert(p);
            pts.push(p);
        }
        let snapshot = g.clone();
        g.insert(DVec3::ZERO);
        assert_eq!(snapshot.len(), 2000);
        assert_eq!(g.len(), 2001);
        for _ in 0..200 {
            let q = DVec3::new(rng.unit(), rng.unit(), rng.unit()) * 4.4 - 2.2;
            let mut got = Vec::new();
            snapshot.for_each_within(q, r, |p| got.push(p));
            let want: Vec<_> = pts.iter().filter(|p| p.distance(q) < r).collect();
            assert_eq!(got.len(), want.len(), "query {q}");
            for w in want {
                assert!(got.contains(w));
            }
        }
        let mut near_origin = 0;
        g.for_each_within(DVec3::ZERO, 1e-9, |_| near_origin += 1);
        let mut before = 0;
        snapshot.for_each_within(DVec3::ZERO, 1e-9, |_| before += 1);
        assert_eq!(near_origin, before + 1);
    }

    #[test]
    fn long_bucket_drops_without_overflow() {
        let mut g = PersistentGrid::new(1.0);
        for _ in 0..200_000 {
            g.insert(DVec3::ZERO);
        }
        assert_eq!(g.len(), 200_000);
        drop(g);
    }
}

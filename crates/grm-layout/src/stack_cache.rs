//! Merged layer stacks kept between evaluations ("merge layers cached"):
//! the merge runs top down (`L_m = L_n`, then `L_m = M(L_i, L_m)`), so
//! the result after merging layer `i` depends only on the layers from the
//! top down to `i`, their merge modes and seeds, and the parcel knobs. A
//! key chains the content of each of those layers ([`layout_key`]: every
//! node, street, parcel, tag and rest pose, every float by its bits, so
//! 0 and -0 differ), so an unchanged
//! run of layers at the top of the stack is taken from the cache instead
//! of merged again: dragging or editing a layer re-merges only that layer
//! and the ones below it. A hit is exactly what the merge would compute
//! (the merges are deterministic functions of what the key hashes).

use crate::id::{Id, mix};
use crate::merge::{MergeMode, MergeParams, MergeReport};
use crate::model::{Layout, ParcelOrigin, TagValue, Tags};
use std::cell::RefCell;
use std::sync::Arc;

/// One step of the stack: the merged layout and its report, or the
/// merge's failure (the layer was left out).
pub type StackStep = Result<Arc<(Layout, MergeReport)>, String>;

/// Merged prefixes of layer stacks by their chained key.
#[derive(Debug, Default)]
pub struct StackCache {
    steps: RefCell<crate::id::IdMap<Id, StackStep>>,
}

impl StackCache {
    /// Entries kept before the cache is emptied (each holds a merged
    /// layout, so few: a drag adds one per layer below the dragged one).
    pub const LIMIT: usize = 32;

    pub fn get(&self, key: Id) -> Option<StackStep> {
        self.steps.borrow().get(&key).cloned()
    }

    pub fn insert(&self, key: Id, step: StackStep) {
        let mut c = self.steps.borrow_mut();
        if c.len() >= Self::LIMIT {
            c.clear();
        }
        c.insert(key, step);
    }

    /// How many steps are kept (for tests).
    pub fn len(&self) -> usize {
        self.steps.borrow().len()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// A 64-bit hash fed whole words (each word through splitmix64's
/// finaliser: a few instructions a word, so hashing a city's layers costs
/// little next to merging them).
#[derive(Clone, Copy)]
struct Minter(u64);

impl Minter {
    fn new(kind: &str) -> Minter {
        Minter(Id::mint(kind).finish().0)
    }

    fn u64(self, v: u64) -> Minter {
        Minter(mix(self.0 ^ v).wrapping_add(0x9e37_79b9_7f4a_7c15))
    }

    fn id(self, id: Id) -> Minter {
        self.u64(id.0)
    }

    /// A float by its bits (0 and -0 differ).
    fn f64(self, v: f64) -> Minter {
        self.u64(v.to_bits())
    }

    fn str(self, s: &str) -> Minter {
        self.id(Id::mint("str").str(s).finish())
    }

    fn finish(self) -> Id {
        Id(mix(self.0))
    }
}

/// The key of a stack's top layer alone.
pub fn top_key(top: &Layout) -> Id {
    Minter::new("stack-top").id(layout_key(top)).finish()
}

/// The key of the stack after merging `lower` under the stack `above`.
pub fn step_key(above: Id, lower: &Layout, mode: MergeMode, params: &MergeParams) -> Id {
    let p = &params.parcels;
    let mut m = Minter::new("stack-step")
        .id(above)
        .id(layout_key(lower))
        .str(mode.name())
        .u64(params.seed)
        .u64(params.constrain_top as u64);
    for v in [p.max_area, p.min_area, p.setback, p.jitter] {
        m = m.f64(v);
    }
    m.u64(u64::from(p.max_depth)).finish()
}

fn tags(mut m: Minter, t: &Tags) -> Minter {
    m = m.u64(t.len() as u64);
    for (k, v) in t {
        m = m.str(k);
        m = match v {
            TagValue::Num(x) => m.u64(0).f64(*x),
            TagValue::Text(s) => m.u64(1).str(s),
            TagValue::Bool(b) => m.u64(2).u64(u64::from(*b)),
        };
    }
    m
}

fn ring(mut m: Minter, r: &[geo::Coord]) -> Minter {
    m = m.u64(r.len() as u64);
    for c in r {
        m = m.f64(c.x).f64(c.y);
    }
    m
}

fn parcel(mut m: Minter, p: &crate::model::Parcel) -> Minter {
    m = ring(m.id(p.id), &p.ring);
    m = match p.origin {
        ParcelOrigin::Generated { block } => m.u64(0).id(block),
        ParcelOrigin::Explicit => m.u64(1),
    };
    tags(m, &p.tags)
}

/// A layout's streets (each one's identity, end nodes and polyline, bit
/// for bit): what its blocks depend on.
pub fn streets_key(l: &Layout) -> Id {
    let mut m = Minter::new("blocks-of").u64(l.streets.len() as u64);
    for s in l.streets.values() {
        m = m.id(s.id).id(s.a).id(s.b);
        match (l.nodes.get(&s.a), l.nodes.get(&s.b)) {
            (Some(a), Some(b)) => {
                m = m.u64(s.interior.len() as u64 + 2).f64(a.pos.x).f64(a.pos.y);
                for p in &s.interior {
                    m = m.f64(p.x).f64(p.y);
                }
                m = m.f64(b.pos.x).f64(b.pos.y);
            }
            // No polyline (an end node missing).
            _ => m = m.u64(0),
        }
    }
    m.finish()
}

/// A ring's content (its points' bits), for memos of checks on rings.
pub fn ring_key(r: &[geo::Coord]) -> Id {
    ring(Minter::new("ring"), r).finish()
}

/// A layout's content, bit for bit (every field a merge can read).
pub fn layout_key(l: &Layout) -> Id {
    let mut m = Minter::new("layout").u64(l.nodes.len() as u64);
    for n in l.nodes.values() {
        m = tags(m.id(n.id).f64(n.pos.x).f64(n.pos.y), &n.tags);
    }
    m = m.u64(l.streets.len() as u64);
    for s in l.streets.values() {
        m = ring(m.id(s.id).id(s.a).id(s.b), &s.interior)
            .str(s.class.name())
            .f64(s.width)
            .f64(s.priority);
        m = tags(m, &s.tags);
    }
    m = m.u64(l.parcels.len() as u64);
    for p in l.parcels.values() {
        m = parcel(m, p);
    }
    m = m.u64(l.rests.len() as u64);
    for (id, r) in &l.rests {
        m = ring(m.id(*id), &r.ring).u64(r.parcels.len() as u64);
        for p in &r.parcels {
            m = parcel(m, p);
        }
    }
    m.finish()
}

//! Anchored assignments (4.3): tags given to the elements a target picks
//! (the nearest element of the listed kinds to a position, or every such
//! element within a radius, numbers scaled by a falloff), with the
//! position anchored to an element so it moves with it, kept apart from
//! the layout so deleting elements does not delete them; an anchor whose
//! element is gone moves to the nearest element of the same kind.
//! Applied in order, an element keeps a value it already has (its own
//! tags, then earlier assignments, win).

use crate::geom;
use crate::id::Id;
use crate::model::{ElementKind, Layout, Tags};
use geo::Coord;

/// How the tags fall off over a region.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Falloff {
    /// The same values everywhere in the region.
    None,
    /// Numbers scaled by `1 - d / radius`.
    Linear,
}

/// Which elements an assignment reaches.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Target {
    /// The nearest element of the kinds.
    Nearest,
    /// Every element of the kinds within `radius`.
    Region { radius: f64, falloff: Falloff },
}

/// The element an assignment's position follows, and where that element
/// was when the position was set.
#[derive(Debug, Clone, PartialEq)]
pub struct Anchor {
    pub element: Id,
    pub kind: ElementKind,
    pub at: Coord,
}

/// One anchored assignment.
#[derive(Debug, Clone, PartialEq)]
pub struct Assignment {
    pub tags: Tags,
    pub kinds: Vec<ElementKind>,
    pub target: Target,
    pub pos: Coord,
    pub anchor: Option<Anchor>,
}

impl Assignment {
    /// The position now: moved by as much as its anchor moved.
    pub fn position(&self, layout: &Layout) -> Coord {
        match &self.anchor {
            Some(a) => match layout.position_of(a.element) {
                Some(now) => Coord {
                    x: self.pos.x + now.x - a.at.x,
                    y: self.pos.y + now.y - a.at.y,
                },
                None => self.pos,
            },
            None => self.pos,
        }
    }

    /// When the anchor's element is gone, anchors to the nearest element of
    /// the same kind instead (keeping the position where it was last
    /// seen); true when it changed.
    pub fn reanchor(&mut self, layout: &Layout) -> bool {
        let Some(a) = &self.anchor else { return false };
        if layout.kind_of(a.element).is_some() {
            return false;
        }
        let kind = a.kind;
        match nearest(layout, self.pos, &[kind]) {
            Some((id, at)) => {
                self.anchor = Some(Anchor {
                    element: id,
                    kind,
                    at,
                });
                true
            }
            None => {
                self.anchor = None;
                true
            }
        }
    }
}

fn candidates(layout: &Layout, kinds: &[ElementKind]) -> Vec<Id> {
    let mut v = Vec::new();
    for k in kinds {
        match k {
            ElementKind::Node => v.extend(layout.nodes.keys()),
            ElementKind::Street => v.extend(layout.streets.keys()),
            ElementKind::Parcel => v.extend(layout.parcels.keys()),
        }
    }
    v
}

/// The element of the kinds nearest a point (ties: the smaller identity).
pub fn nearest(layout: &Layout, p: Coord, kinds: &[ElementKind]) -> Option<(Id, Coord)> {
    let mut best: Option<(f64, Id, Coord)> = None;
    for id in candidates(layout, kinds) {
        let Some(q) = layout.position_of(id) else {
            continue;
        };
        let d = distance_to(layout, id, p).unwrap_or_else(|| geom::dist(p, q));
        if best.is_none_or(|b| d < b.0 || (d == b.0 && id < b.1)) {
            best = Some((d, id, q));
        }
    }
    best.map(|(_, id, q)| (id, q))
}

/// The distance from a point to an element's shape (a parcel: 0 inside).
fn distance_to(layout: &Layout, id: Id, p: Coord) -> Option<f64> {
    if let Some(s) = layout.streets.get(&id) {
        let pl = layout.polyline(s)?;
        return pl
            .windows(2)
            .map(|w| geom::point_segment_dist(p, w[0], w[1]))
            .reduce(f64::min);
    }
    if let Some(q) = layout.parcels.get(&id) {
        if geom::point_in_ring(p, &q.ring) {
            return Some(0.0);
        }
        let n = q.ring.len();
        return (0..n)
            .map(|i| geom::point_segment_dist(p, q.ring[i], q.ring[(i + 1) % n]))
            .reduce(f64::min);
    }
    layout.nodes.get(&id).map(|n| geom::dist(n.pos, p))
}

/// Applies assignments in order; returns how many tags were set.
pub fn apply(assignments: &[Assignment], layout: &mut Layout) -> usize {
    let mut set = 0;
    for a in assignments {
        let p = a.position(layout);
        let hits: Vec<(Id, f64)> = match a.target {
            Target::Nearest => nearest(layout, p, &a.kinds)
                .map(|(id, _)| vec![(id, 1.0)])
                .unwrap_or_default(),
            Target::Region { radius, falloff } => candidates(layout, &a.kinds)
                .into_iter()
                .filter_map(|id| {
                    let d = distance_to(layout, id, p)?;
                    (d <= radius).then_some((
                        id,
                        match falloff {
                            Falloff::None => 1.0,
                            Falloff::Linear if radius > 0.0 => 1.0 - d / radius,
                            Falloff::Linear => 1.0,
                        },
                    ))
                })
                .collect(),
        };
        for (id, w) in hits {
            if let Some(tags) = layout.tags_mut(id) {
                for (k, v) in &a.tags {
                    if !tags.contains_key(k) {
                        tags.insert(k.clone(), v.scaled(w));
                        set += 1;
                    }
                }
            }
        }
    }
    set
}

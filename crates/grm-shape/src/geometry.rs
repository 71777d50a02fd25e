//! A shape's geometry in its scope: the whole box, a rectangle, a prism
//! over a footprint outline, a planar outline, or an edge.
//!
//! Outlines are `geo` multipolygons (`f64`) in scope-local xy, exterior
//! rings counter-clockwise and holes clockwise. Cutting one by a split
//! slab is `geo`'s boolean intersection with the slab's rectangle, so a
//! non-convex footprint (an L, a U, a courtyard) falls apart into the right
//! pieces; an outline that is exactly its scope's rectangle is kept as
//! [`Geom::Box`] / [`Geom::Rect`], which cut by arithmetic alone
//! (facades, floors and tiles never call into `geo`).

use crate::ir::Axis;
use crate::roof::Roof;
use crate::scope::Scope;
use geo::algorithm::buffer::{BufferStyle, LineJoin};
use geo::orient::{Direction, Orient};
use geo::{Area, BooleanOps, BoundingRect, Buffer, Coord, LineString, MultiPolygon, Polygon};
use std::sync::Arc;

/// Relative tolerance for "this outline is its scope's rectangle" and
/// "this piece has no area".
const RECT_TOL: f64 = 1e-6;

/// A shape's geometry as it is stored in the tree: small and `Copy`,
/// outlines by index into the tree's outline table
/// ([`crate::ShapeTree::outline`]); [`Geom`] is the same with the outline
/// in hand.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Geometry {
    /// A mass filling its scope box.
    Box,
    /// A face filling its scope's xy rectangle.
    Rect,
    /// A mass over the outline.
    Prism(OutlineId),
    /// A planar face with the outline.
    Polygon(OutlineId),
    /// An edge along the scope's x axis.
    Edge,
    /// A roof or tapered solid: the table entry is its footprint with the
    /// faces ([`Outline::roof`]).
    Roof(OutlineId),
}

impl Geometry {
    /// What kind of geometry, in words.
    pub fn describe(&self) -> &'static str {
        match self {
            Geometry::Box | Geometry::Prism(_) => "a mass",
            Geometry::Rect | Geometry::Polygon(_) => "a face",
            Geometry::Edge => "an edge",
            Geometry::Roof(_) => "a roof",
        }
    }

    /// The outline's index, where there is one.
    pub fn outline_id(&self) -> Option<OutlineId> {
        match *self {
            Geometry::Prism(o) | Geometry::Polygon(o) | Geometry::Roof(o) => Some(o),
            _ => None,
        }
    }
}

/// An index into a tree's outline table.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct OutlineId(pub u32);

/// A shape's geometry with its outline in hand, in scope-local coordinates.
#[derive(Clone, Debug, PartialEq)]
pub enum Geom {
    /// A mass filling its scope box.
    Box,
    /// A face filling its scope's xy rectangle (`size.z` is 0).
    Rect,
    /// A mass: the outline extruded over `[0, size.z]`.
    Prism(Arc<Outline>),
    /// A planar face: the outline in the scope's xy plane.
    Polygon(Arc<Outline>),
    /// An edge along the scope's x axis (`size.x` is its length).
    Edge,
    /// A roof or tapered solid ([`crate::roof`]): its footprint outline in
    /// the scope's xy, carrying the faces ([`Outline::roof`]) in
    /// scope-local coordinates (eaves at z = 0).
    Roof(Arc<Outline>),
}

impl Geom {
    /// What kind of geometry, in words (for errors).
    pub fn describe(&self) -> &'static str {
        match self {
            Geom::Box | Geom::Prism(_) => "a mass",
            Geom::Rect | Geom::Polygon(_) => "a face",
            Geom::Edge => "an edge",
            Geom::Roof(_) => "a roof",
        }
    }

    /// The roof's faces, for a roof.
    pub fn roof(&self) -> Option<&Roof> {
        match self {
            Geom::Roof(o) => o.roof(),
            _ => None,
        }
    }

    /// The entry of the tree's outline table this geometry keeps, if any
    /// (a prism's or polygon's outline, a roof's footprint and faces).
    pub fn table_entry(&self) -> Option<&Arc<Outline>> {
        match self {
            Geom::Prism(o) | Geom::Polygon(o) | Geom::Roof(o) => Some(o),
            _ => None,
        }
    }

    /// A 3D mass (box or prism).
    pub fn is_mass(&self) -> bool {
        matches!(self, Geom::Box | Geom::Prism(_))
    }

    /// A 2D face (rectangle or outline).
    pub fn is_face(&self) -> bool {
        matches!(self, Geom::Rect | Geom::Polygon(_))
    }

    /// The outline, where there is one (prisms and polygons).
    pub fn outline(&self) -> Option<&Outline> {
        match self {
            Geom::Prism(o) | Geom::Polygon(o) => Some(o),
            _ => None,
        }
    }

    /// The area of the face, or of a mass's footprint (0 for an edge).
    pub fn area(&self, scope: &Scope) -> f64 {
        match self {
            Geom::Box | Geom::Rect => f64::from(scope.size.x) * f64::from(scope.size.y),
            Geom::Prism(o) | Geom::Polygon(o) | Geom::Roof(o) => o.area(),
            Geom::Edge => 0.0,
        }
    }

    /// The volume of a mass (0 for faces and edges).
    pub fn volume(&self, scope: &Scope) -> f64 {
        match self {
            Geom::Box | Geom::Prism(_) => self.area(scope) * f64::from(scope.size.z),
            Geom::Roof(o) => o.roof().map_or(0.0, Roof::volume),
            _ => 0.0,
        }
    }

    /// The geometry of the slab `[start, start + len)` along `axis` of a
    /// shape with this geometry and `scope`, in the slab's own scope
    /// (`None`: the slab holds none of it).
    #[inline]
    pub fn slab(&self, scope: &Scope, axis: Axis, start: f32, len: f32) -> Option<Geom> {
        match (self, axis) {
            (Geom::Prism(_) | Geom::Polygon(_), Axis::Z) => Some(self.clone()),
            (Geom::Prism(o) | Geom::Polygon(o), _) => {
                let piece = o.clip_slab(axis.index(), f64::from(start), f64::from(len))?;
                let mut size = scope.size;
                size[axis.index()] = len;
                Some(Self::from_outline(piece, size.x, size.y, self.is_mass()))
            }
            (Geom::Roof(o), _) => {
                let (start, len) = (f64::from(start), f64::from(len));
                let roof = o.roof()?.clipped(axis.index(), start, start + len)?;
                let footprint = match axis {
                    Axis::Z => o.polygons().clone(),
                    _ => o.clip_slab(axis.index(), start, len)?.polygons().clone(),
                };
                Some(Geom::Roof(Arc::new(Outline::with_roof(footprint, roof))))
            }
            _ => Some(self.clone()),
        }
    }

    /// The face or mass with `outline`, simplified to [`Geom::Rect`] or
    /// [`Geom::Box`] when it is exactly the `sx` by `sy` rectangle.
    pub fn from_outline(outline: Outline, sx: f32, sy: f32, mass: bool) -> Geom {
        match (outline.is_rect(f64::from(sx), f64::from(sy)), mass) {
            (true, true) => Geom::Box,
            (true, false) => Geom::Rect,
            (false, true) => Geom::Prism(Arc::new(outline)),
            (false, false) => Geom::Polygon(Arc::new(outline)),
        }
    }
}

/// A planar outline: one or more polygons (with holes) in scope-local xy.
/// An entry of a tree's outline table; a roof's entry is its footprint and
/// carries the roof's faces ([`Outline::roof`]), so roofs are stored,
/// shared and spliced exactly as outlines are.
#[derive(Clone, Debug, PartialEq)]
pub struct Outline {
    polygons: MultiPolygon<f64>,
    roof: Option<Arc<Roof>>,
}

impl Outline {
    /// An outline from one ring of points (closed implicitly). Fails on
    /// fewer than three points, a non-finite coordinate or no area;
    /// a self-intersecting ring is resolved by `geo` (even-odd).
    pub fn from_ring(points: &[[f64; 2]]) -> Result<Outline, String> {
        if points.len() < 3 {
            return Err(format!(
                "a polygon needs at least 3 points, got {}",
                points.len()
            ));
        }
        if let Some(p) = points
            .iter()
            .find(|p| !(p[0].is_finite() && p[1].is_finite()))
        {
            return Err(format!("point ({}, {}) is not finite", p[0], p[1]));
        }
        let ring: Vec<Coord<f64>> = points.iter().map(|p| Coord { x: p[0], y: p[1] }).collect();
        let poly = Polygon::new(LineString::new(ring), vec![]);
        // A union with nothing cleans the ring: self-intersections, repeated
        // points, orientation.
        let cleaned = MultiPolygon::new(vec![poly]).union(&MultiPolygon::<f64>::new(vec![]));
        let outline = Outline::new(cleaned);
        if outline.area() <= 0.0 {
            return Err("the polygon has no area".to_owned());
        }
        Ok(outline)
    }

    /// Wrap `geo` polygons (re-oriented: exteriors counter-clockwise).
    pub fn new(polygons: MultiPolygon<f64>) -> Outline {
        Outline {
            polygons: polygons.orient(Direction::Default),
            roof: None,
        }
    }

    /// A roof's table entry: its footprint `polygons` and its faces.
    pub fn with_roof(polygons: MultiPolygon<f64>, roof: Roof) -> Outline {
        Outline {
            polygons: polygons.orient(Direction::Default),
            roof: Some(Arc::new(roof)),
        }
    }

    /// The roof standing on this outline, for a roof's entry.
    pub fn roof(&self) -> Option<&Roof> {
        self.roof.as_deref()
    }

    /// The polygons.
    pub fn polygons(&self) -> &MultiPolygon<f64> {
        &self.polygons
    }

    /// The rings, each without its closing point: per polygon the exterior
    /// (counter-clockwise) then its holes (clockwise).
    pub fn rings(&self) -> impl Iterator<Item = Vec<[f64; 2]>> + '_ {
        self.polygons
            .0
            .iter()
            .flat_map(|p| std::iter::once(p.exterior()).chain(p.interiors()))
            .map(|ring| {
                let mut pts: Vec<[f64; 2]> = ring.coords().map(|c| [c.x, c.y]).collect();
                if pts.len() > 1 && pts.first() == pts.last() {
                    pts.pop();
                }
                pts
            })
    }

    /// The area.
    pub fn area(&self) -> f64 {
        self.polygons.unsigned_area()
    }

    /// The bounding box `(min, max)`, or `None` when empty.
    pub fn bounds(&self) -> Option<([f64; 2], [f64; 2])> {
        self.polygons
            .bounding_rect()
            .map(|r| ([r.min().x, r.min().y], [r.max().x, r.max().y]))
    }

    /// Exactly the rectangle `[0, sx] x [0, sy]` (within a relative
    /// tolerance): one polygon, no holes, four corners.
    pub fn is_rect(&self, sx: f64, sy: f64) -> bool {
        let [p] = self.polygons.0.as_slice() else {
            return false;
        };
        if !p.interiors().is_empty() {
            return false;
        }
        let tol = RECT_TOL * sx.max(sy).max(1.0);
        let corners = [[0.0, 0.0], [sx, 0.0], [sx, sy], [0.0, sy]];
        let mut pts: Vec<Coord<f64>> = p.exterior().coords().copied().collect();
        if pts.len() > 1 && pts.first() == pts.last() {
            pts.pop();
        }
        // Drop points on a straight run (collinear with their neighbours).
        let n = pts.len();
        let kept: Vec<Coord<f64>> = (0..n)
            .filter(|&i| {
                let a = pts[(i + n - 1) % n];
                let b = pts[i];
                let c = pts[(i + 1) % n];
                ((b.x - a.x) * (c.y - b.y) - (b.y - a.y) * (c.x - b.x)).abs() > tol * tol
            })
            .map(|i| pts[i])
            .collect();
        kept.len() == 4
            && kept.iter().all(|q| {
                corners
                    .iter()
                    .any(|c| (q.x - c[0]).abs() <= tol && (q.y - c[1]).abs() <= tol)
            })
            && (self.area() - sx * sy).abs() <= tol * sx.max(sy).max(1.0)
    }

    /// The part of the outline in the slab `[start, start + len]` along
    /// local axis 0 (x) or 1 (y), moved so that the slab starts at 0
    /// (`None` when the slab holds no area).
    pub fn clip_slab(&self, axis: usize, start: f64, len: f64) -> Option<Outline> {
        let (lo, hi) = self.bounds()?;
        let (a, b) = (start, start + len);
        let (rlo, rhi) = if axis == 0 {
            ([a, lo[1] - 1.0], [b, hi[1] + 1.0])
        } else {
            ([lo[0] - 1.0, a], [hi[0] + 1.0, b])
        };
        let rect = geo::Rect::new(
            Coord {
                x: rlo[0],
                y: rlo[1],
            },
            Coord {
                x: rhi[0],
                y: rhi[1],
            },
        )
        .to_polygon();
        let piece = self.polygons.intersection(&rect);
        let (dx, dy) = if axis == 0 {
            (start, 0.0)
        } else {
            (0.0, start)
        };
        let moved = Outline::new(piece).translated(-dx, -dy);
        let scale = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(len);
        if moved.area() <= RECT_TOL * RECT_TOL * scale * scale {
            return None;
        }
        Some(moved)
    }

    /// Moved by `(dx, dy)`.
    pub fn translated(&self, dx: f64, dy: f64) -> Outline {
        self.map(|x, y| (x + dx, y + dy))
    }

    /// Scaled by `(fx, fy)` about the origin (orientation kept for
    /// positive factors).
    pub fn scaled(&self, fx: f64, fy: f64) -> Outline {
        Outline::new(self.map(|x, y| (x * fx, y * fy)).polygons)
    }

    /// Mirrored to `(x, h - y)`: the footprint seen from below.
    pub fn flipped_y(&self, h: f64) -> Outline {
        Outline::new(self.map(|x, y| (x, h - y)).polygons)
    }

    fn map(&self, f: impl Fn(f64, f64) -> (f64, f64)) -> Outline {
        let ring = |r: &LineString<f64>| {
            LineString::new(
                r.coords()
                    .map(|c| {
                        let (x, y) = f(c.x, c.y);
                        Coord { x, y }
                    })
                    .collect(),
            )
        };
        let polys = self
            .polygons
            .0
            .iter()
            .map(|p| Polygon::new(ring(p.exterior()), p.interiors().iter().map(ring).collect()))
            .collect();
        Outline {
            polygons: MultiPolygon::new(polys),
            roof: None,
        }
    }

    /// The outline offset by `distance` (negative: inset), with mitred
    /// corners; `None` when nothing is left.
    pub fn offset(&self, distance: f64) -> Option<Outline> {
        if distance == 0.0 {
            return Some(self.clone());
        }
        let style = BufferStyle::new(distance).line_join(LineJoin::Miter(0.1));
        let out = Outline::new(self.polygons.buffer_with_style(style));
        (out.area() > 0.0).then_some(out)
    }

    /// The `sx` by `sy` rectangle as an outline.
    pub fn rect(sx: f64, sy: f64) -> Outline {
        Outline::new(MultiPolygon::new(vec![
            geo::Rect::new(Coord { x: 0.0, y: 0.0 }, Coord { x: sx, y: sy }).to_polygon(),
        ]))
    }
}

//! The lot of a shape system: `rect(w, d)`, `polygon(x0, y0, ...)` or a
//! GeoJSON footprint file, and the test that a footprint is usable (a
//! simple polygon with area), shared by the checker (with the
//! meta-parameters' defaults) and the lowering (with the run's values).

use std::path::PathBuf;

use grm_diag::Span;

use crate::program::TExpr;

/// The corners of a footprint: its exterior ring, then its holes.
pub type Rings = Vec<Vec<[f64; 2]>>;

/// The most corners a footprint may have (a bound on the checker's
/// quadratic crossing test: a city block has dozens).
pub const MAX_LOT_CORNERS: usize = 4096;

/// The lot as written.
#[derive(Clone, Debug)]
pub struct ShapeLot {
    pub kind: LotKind,
    /// The `lot = ...;` setting's value; `None` for the default.
    pub span: Option<Span>,
}

impl Default for ShapeLot {
    /// `rect(10, 10)`.
    fn default() -> Self {
        ShapeLot {
            kind: LotKind::Default,
            span: None,
        }
    }
}

#[derive(Clone, Debug)]
pub enum LotKind {
    /// Not set: a 10 by 10 rectangle.
    Default,
    /// `rect(w, d)`: floats.
    Rect { width: TExpr, depth: TExpr },
    /// `polygon(x0, y0, x1, y1, ...)`: floats, an even number, at least 6.
    Polygon(Vec<TExpr>),
    /// A GeoJSON file's first polygon, read by the checker.
    File {
        /// The path as written.
        written: String,
        /// Resolved against the system's file.
        path: PathBuf,
        /// Its exterior ring and holes (each without the closing repeat
        /// of the first corner).
        rings: Rings,
    },
}

/// Why a footprint is not usable (the message of E0509).
pub fn footprint_problem(rings: &Rings) -> Option<String> {
    if rings.is_empty() {
        return Some("the footprint has no corners".into());
    }
    if rings.iter().map(Vec::len).sum::<usize>() > MAX_LOT_CORNERS {
        return Some(format!(
            "the footprint has more than {MAX_LOT_CORNERS} corners"
        ));
    }
    for (i, ring) in rings.iter().enumerate() {
        let what = if i == 0 {
            "the footprint".to_string()
        } else {
            format!("hole {i} of the footprint")
        };
        if ring.iter().flatten().any(|v| !v.is_finite()) {
            return Some(format!("{what} has a corner that is not a finite number"));
        }
        let distinct = distinct_corners(ring);
        if distinct.len() < 3 {
            return Some(format!(
                "{what} has {} distinct corner{}: a polygon needs at least three",
                distinct.len(),
                if distinct.len() == 1 { "" } else { "s" }
            ));
        }
        if signed_area(&distinct).abs() <= 1e-9 * scale(&distinct).powi(2) {
            return Some(format!("{what} has no area: its corners are on one line"));
        }
        if let Some((a, b)) = crossing(&distinct) {
            return Some(format!(
                "{what} crosses itself: its edges {} and {} meet",
                a + 1,
                b + 1
            ));
        }
    }
    None
}

/// The ring without repeated consecutive corners (and without a closing
/// repeat of the first).
fn distinct_corners(ring: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let mut out: Vec<[f64; 2]> = Vec::with_capacity(ring.len());
    for &p in ring {
        if out.last() != Some(&p) {
            out.push(p);
        }
    }
    while out.len() > 1 && out.first() == out.last() {
        out.pop();
    }
    out
}

fn signed_area(ring: &[[f64; 2]]) -> f64 {
    let n = ring.len();
    (0..n)
        .map(|i| {
            let (a, b) = (ring[i], ring[(i + 1) % n]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum::<f64>()
        / 2.0
}

fn scale(ring: &[[f64; 2]]) -> f64 {
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for p in ring {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (hi[0] - lo[0]).max(hi[1] - lo[1]).max(f64::MIN_POSITIVE)
}

fn orient(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

fn on_segment(a: [f64; 2], b: [f64; 2], p: [f64; 2]) -> bool {
    p[0] >= a[0].min(b[0])
        && p[0] <= a[0].max(b[0])
        && p[1] >= a[1].min(b[1])
        && p[1] <= a[1].max(b[1])
}

/// Whether segments `ab` and `cd` share a point.
fn segments_meet(a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2]) -> bool {
    let (d1, d2) = (orient(c, d, a), orient(c, d, b));
    let (d3, d4) = (orient(a, b, c), orient(a, b, d));
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0))
        && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
    {
        return true;
    }
    (d1 == 0.0 && on_segment(c, d, a))
        || (d2 == 0.0 && on_segment(c, d, b))
        || (d3 == 0.0 && on_segment(a, b, c))
        || (d4 == 0.0 && on_segment(a, b, d))
}

/// Two edges of the ring that meet other than at a shared corner of
/// neighbours: `(i, j)`, edge `i` from corner `i` to `i + 1`.
fn crossing(ring: &[[f64; 2]]) -> Option<(usize, usize)> {
    let n = ring.len();
    let edge = |i: usize| (ring[i], ring[(i + 1) % n]);
    for i in 0..n {
        for j in i + 1..n {
            let neighbours = j == i + 1 || (i == 0 && j == n - 1);
            let ((a, b), (c, d)) = (edge(i), edge(j));
            if neighbours {
                // Neighbours share one corner; they may not fold back on
                // each other (collinear and overlapping).
                let (p, q, r) = if j == i + 1 { (a, b, d) } else { (c, d, b) };
                if orient(p, q, r) == 0.0 && {
                    let u = [q[0] - p[0], q[1] - p[1]];
                    let v = [r[0] - q[0], r[1] - q[1]];
                    u[0] * v[0] + u[1] * v[1] < 0.0
                } {
                    return Some((i, j));
                }
                continue;
            }
            if segments_meet(a, b, c, d) {
                return Some((i, j));
            }
        }
    }
    None
}

/// The rings of the first polygon of a GeoJSON text: a `Polygon`, a
/// `MultiPolygon`'s first, or the first polygon of a `Feature`'s or
/// `FeatureCollection`'s geometry. `Err` says why there is none.
pub fn geojson_rings(text: &str) -> Result<Rings, String> {
    let gj: geojson::GeoJson = text
        .parse()
        .map_err(|e: geojson::Error| format!("not GeoJSON: {e}"))?;
    let found = match &gj {
        geojson::GeoJson::Geometry(g) => polygon_of(g),
        geojson::GeoJson::Feature(f) => f.geometry.as_ref().and_then(polygon_of),
        geojson::GeoJson::FeatureCollection(c) => c
            .features
            .iter()
            .filter_map(|f| f.geometry.as_ref())
            .find_map(polygon_of),
    };
    found.ok_or_else(|| "it holds no Polygon or MultiPolygon".into())
}

fn polygon_of(g: &geojson::Geometry) -> Option<Rings> {
    let rings: &geojson::PolygonType = match &g.value {
        geojson::GeometryValue::Polygon { coordinates } => coordinates,
        geojson::GeometryValue::MultiPolygon { coordinates } => coordinates.first()?,
        geojson::GeometryValue::GeometryCollection { geometries } => {
            return geometries.iter().find_map(polygon_of);
        }
        _ => return None,
    };
    Some(
        rings
            .iter()
            .map(|r| {
                let mut ring: Vec<[f64; 2]> = r
                    .iter()
                    .map(|p| {
                        let p = p.as_slice();
                        [
                            p.first().copied().unwrap_or(f64::NAN),
                            p.get(1).copied().unwrap_or(f64::NAN),
                        ]
                    })
                    .collect();
                if ring.len() > 1 && ring.first() == ring.last() {
                    ring.pop();
                }
                ring
            })
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn squares_triangles_and_bad_polygons() {
        let sq = vec![vec![[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]]];
        assert_eq!(footprint_problem(&sq), None);
        let tri = vec![vec![[0.0, 0.0], [4.0, 0.0], [0.0, 3.0]]];
        assert_eq!(footprint_problem(&tri), None);
        let line = vec![vec![[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]]];
        assert!(footprint_problem(&line).unwrap().contains("no area"));
        let bow = vec![vec![[0.0, 0.0], [4.0, 4.0], [4.0, 0.0], [0.0, 4.0]]];
        assert!(footprint_problem(&bow).unwrap().contains("crosses itself"));
        let two = vec![vec![[0.0, 0.0], [4.0, 4.0], [4.0, 4.0]]];
        assert!(footprint_problem(&two).unwrap().contains("2 distinct"));
        let l = vec![vec![
            [0.0, 0.0],
            [6.0, 0.0],
            [6.0, 2.0],
            [2.0, 2.0],
            [2.0, 6.0],
            [0.0, 6.0],
        ]];
        assert_eq!(footprint_problem(&l), None);
    }

    #[test]
    fn geojson_polygons() {
        let text = r#"{"type":"Feature","properties":{},"geometry":{"type":"Polygon",
            "coordinates":[[[0,0],[10,0],[10,8],[0,8],[0,0]]]}}"#;
        let rings = geojson_rings(text).unwrap();
        assert_eq!(rings[0].len(), 4);
        assert!(geojson_rings("{}").is_err());
        assert!(geojson_rings(r#"{"type":"Point","coordinates":[1,2]}"#).is_err());
    }
}

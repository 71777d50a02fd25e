//! The lot of a shape system: `rect(w, d)`, `polygon(x0, y0, ...)` or a
//! GeoJSON footprint file, and the test that a footprint is usable (a
//! simple polygon with area), shared by the checker (with the
//! meta-parameters' defaults) and the lowering (with the run's values).

use std::path::PathBuf;

use grm_diag::{Code, Diagnostic, Span};
use grm_syntax::ast::{self, ExprKind};

use super::check::ShapeCheck;
use crate::expr::Scope;
use crate::program::{TExpr, Ty, Value};
use crate::suggest;

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
        // Edges that cross (a bow tie has no area either, but crossing
        // says why), then no area (corners on a line), then neighbours
        // that fold back on each other.
        let crosses = |(a, b): (usize, usize)| {
            format!(
                "{what} crosses itself: its edges {} and {} meet",
                a + 1,
                b + 1
            )
        };
        if let Some(c) = crossing(&distinct, false) {
            return Some(crosses(c));
        }
        if signed_area(&distinct).abs() <= 1e-9 * scale(&distinct).powi(2) {
            return Some(format!("{what} has no area: its corners are on one line"));
        }
        if let Some(c) = crossing(&distinct, true) {
            return Some(crosses(c));
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
/// neighbours: `(i, j)`, edge `i` from corner `i` to `i + 1`. With
/// `neighbours`, only neighbouring edges that fold back on each other;
/// without, only edges that are not neighbours.
fn crossing(ring: &[[f64; 2]], neighbours: bool) -> Option<(usize, usize)> {
    let n = ring.len();
    let edge = |i: usize| (ring[i], ring[(i + 1) % n]);
    for i in 0..n {
        for j in i + 1..n {
            let adjacent = j == i + 1 || (i == 0 && j == n - 1);
            if adjacent != neighbours {
                continue;
            }
            let ((a, b), (c, d)) = (edge(i), edge(j));
            if adjacent {
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

impl ShapeCheck<'_, '_> {
    pub(super) fn lot(&mut self, lots: &[&ast::Setting]) -> ShapeLot {
        for extra in lots.iter().skip(1) {
            self.err(
                Diagnostic::new(
                    Code::DuplicateSetting,
                    "`lot` is set twice",
                    self.file,
                    extra.name.span,
                    "set again here",
                )
                .with_label(self.file, lots[0].name.span, "first set here")
                .with_help("remove one of them"),
            );
        }
        let Some(set) = lots.first() else {
            return ShapeLot::default();
        };
        let v = &set.value;
        let span = v.span;
        if let ExprKind::Str(written) = &v.kind {
            return self.lot_file(written, span);
        }
        let bad = |this: &mut Self, msg: String, label: &str| {
            this.err(
                Diagnostic::new(Code::BadLot, msg, this.file, span, label.to_string()).with_help(
                    "write `lot = rect(width, depth);`, `lot = polygon(x0, y0, x1, y1, x2, y2, ...);` or `lot = \"footprint.geojson\";`",
                ),
            );
        };
        let ExprKind::Call { func, args } = &v.kind else {
            bad(
                self,
                "the lot must be `rect(w, d)` or `polygon(x0, y0, ...)`".into(),
                "not a lot",
            );
            return ShapeLot::default();
        };
        let mut values = Vec::with_capacity(args.len());
        for a in args {
            let mut sc = Scope::global(self.fi, true, "the lot");
            let e = self.cx.expr(a, &mut sc);
            let e = self
                .cx
                .expect(self.file, e, Ty::Float, "a lot's size or corner");
            values.push(e);
        }
        let broken = values.iter().any(|e| e.ty == Ty::Error);
        let kind = match func.name.as_str() {
            "rect" if values.len() == 2 => {
                let mut it = values.into_iter();
                let (Some(width), Some(depth)) = (it.next(), it.next()) else {
                    return ShapeLot::default();
                };
                LotKind::Rect { width, depth }
            }
            "rect" => {
                bad(
                    self,
                    format!(
                        "`rect` takes 2 arguments (width and depth), but {} {} given",
                        args.len(),
                        if args.len() == 1 { "was" } else { "were" }
                    ),
                    "not a rectangle",
                );
                return ShapeLot::default();
            }
            "polygon" if values.len() >= 6 && values.len() % 2 == 0 => LotKind::Polygon(values),
            "polygon" => {
                bad(
                    self,
                    format!(
                        "`polygon` takes the x and y of three or more corners, but {} number{} {} given",
                        args.len(),
                        if args.len() == 1 { "" } else { "s" },
                        if args.len() == 1 { "was" } else { "were" }
                    ),
                    "not a polygon",
                );
                return ShapeLot::default();
            }
            other => {
                let mut d = Diagnostic::new(
                    Code::BadLot,
                    format!("`{other}` is not a kind of lot"),
                    self.file,
                    func.span,
                    "not `rect` or `polygon`",
                );
                d = match suggest::did_you_mean(other, ["rect", "polygon"]) {
                    Some(h) => d.with_help(h),
                    None => d.with_help("write `rect(width, depth)` or `polygon(x0, y0, ...)`"),
                };
                self.err(d);
                return ShapeLot::default();
            }
        };
        let lot = ShapeLot {
            kind,
            span: Some(span),
        };
        if !broken {
            let params = self.cx.program.default_params();
            let globals = self.cx.default_globals.clone();
            match lot_rings(&lot, &params, &globals) {
                Ok(rings) => {
                    if let Some(why) = footprint_problem(&rings) {
                        let mut d = Diagnostic::new(
                            Code::BadLot,
                            format!("the lot is not a usable footprint: {why}"),
                            self.file,
                            span,
                            "this lot",
                        )
                        .with_help("a lot is a simple polygon with area: three or more corners, edges that do not cross");
                        if !lot_is_constant(&lot) {
                            d = d.with_note("evaluated with the meta-parameters' default values");
                        }
                        self.err(d);
                    }
                }
                Err(why) => {
                    let mut d = Diagnostic::new(
                        Code::BadLot,
                        format!("the lot is not a usable footprint: {why}"),
                        self.file,
                        span,
                        "this lot",
                    );
                    if !lot_is_constant(&lot) {
                        d = d.with_note("evaluated with the meta-parameters' default values");
                    }
                    self.err(d);
                }
            }
        }
        lot
    }

    /// `lot = "file.geojson";` (a string value is read as a path).
    pub(crate) fn lot_file(&mut self, written: &str, span: Span) -> ShapeLot {
        let from = self.cx.files[self.fi].real.clone();
        let path = self.cx.loader.resolve(&from, written);
        let fail = |this: &mut Self, why: String| {
            this.err(
                Diagnostic::new(
                    Code::LotFileUnreadable,
                    format!("the lot file `{written}` cannot be used: {why}"),
                    this.file,
                    span,
                    "this file",
                )
                .with_help("name a GeoJSON file with a Polygon, relative to this .grm file"),
            );
            ShapeLot::default()
        };
        let text = match self.cx.loader.read(&path) {
            Ok(t) => t,
            Err(crate::LoadError::NotFound) => return fail(self, "no such file".into()),
            Err(crate::LoadError::NotUtf8) => return fail(self, "it is not UTF-8 text".into()),
            Err(crate::LoadError::Other(m)) => return fail(self, m),
        };
        let rings = match geojson_rings(&text) {
            Ok(r) => r,
            Err(why) => return fail(self, why),
        };
        if let Some(why) = footprint_problem(&rings) {
            self.err(
                Diagnostic::new(
                    Code::BadLot,
                    format!("the lot is not a usable footprint: {why}"),
                    self.file,
                    span,
                    "this lot",
                )
                .with_help("a lot is a simple polygon with area: three or more corners, edges that do not cross"),
            );
        }
        ShapeLot {
            kind: LotKind::File {
                written: written.to_string(),
                path,
                rings,
            },
            span: Some(span),
        }
    }
}

/// The footprint of a lot for the given meta-parameter values and
/// constants: its rings, or why it cannot be evaluated.
pub fn lot_rings(
    lot: &ShapeLot,
    params: &[Value],
    globals: &[Value],
) -> Result<super::lot::Rings, String> {
    let rings = lot_corners(lot, params, globals)?;
    if let (LotKind::Rect { .. }, Some([_, [w, _], [_, d], _])) =
        (&lot.kind, rings.first().map(Vec::as_slice))
        && !(*w > 0.0 && *d > 0.0)
    {
        return Err(format!(
            "a rectangle's width and depth must be more than 0, not {} by {}",
            *w as f32, *d as f32
        ));
    }
    Ok(rings)
}

fn lot_corners(
    lot: &ShapeLot,
    params: &[Value],
    globals: &[Value],
) -> Result<super::lot::Rings, String> {
    let env = crate::eval::Env {
        params,
        globals,
        bindings: &[],
    };
    let num = |e: &TExpr| -> Result<f64, String> {
        match crate::eval::eval(e, &env) {
            Ok(Value::Float(x)) => Ok(x),
            Ok(v) => Err(format!("`{v}` is not a number")),
            Err(e) => Err(e.to_string()),
        }
    };
    Ok(match &lot.kind {
        LotKind::Default => vec![vec![[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]]],
        LotKind::Rect { width, depth } => {
            let (w, d) = (num(width)?, num(depth)?);
            vec![vec![[0.0, 0.0], [w, 0.0], [w, d], [0.0, d]]]
        }
        LotKind::Polygon(vs) => {
            let mut ring = Vec::with_capacity(vs.len() / 2);
            for pair in vs.chunks(2) {
                if let [x, y] = pair {
                    ring.push([num(x)?, num(y)?]);
                }
            }
            vec![ring]
        }
        LotKind::File { rings, .. } => rings.clone(),
    })
}

fn lot_is_constant(lot: &ShapeLot) -> bool {
    match &lot.kind {
        LotKind::Default | LotKind::File { .. } => true,
        LotKind::Rect { width, depth } => width.constant().is_some() && depth.constant().is_some(),
        LotKind::Polygon(vs) => vs.iter().all(|v| v.constant().is_some()),
    }
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

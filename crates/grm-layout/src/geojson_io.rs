//! GeoJSON in and out. Reading: LineStrings (and MultiLineStrings) become
//! streets whose end points become nodes (equal coordinates join), Polygons
//! become explicit parcels; properties `class`, `width`, `priority` set a
//! street's type, width and priority, every other property becomes a tag.
//! A bad element is reported with a coded [`LoadError`] naming it, and the
//! rest still load. Writing: one FeatureCollection, streets then parcels
//! then tagged nodes, each in identity order, numbers in shortest
//! round-trip form: the same layout gives the same bytes.

use crate::blocks::Block;
use crate::geom::{self, MAX_COORD, RingProblem, check_ring};
use crate::id::Id;
use crate::model::{
    ElementKind, Layout, Parcel, ParcelOrigin, Street, StreetClass, TagValue, Tags,
};
use geo::Coord;
use serde_json::{Map, Value, json};
use std::collections::{BTreeMap, BTreeSet};

/// What is wrong with one element of a GeoJSON input.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LoadErrorKind {
    /// The text is not GeoJSON at all (nothing loads).
    NotGeoJson,
    /// A geometry other than (Multi)LineString or Polygon.
    UnsupportedGeometry,
    /// A street with fewer than two distinct points, or both ends at one place.
    DegenerateStreet,
    /// A street polyline that crosses itself.
    SelfCrossingStreet,
    /// A polygon ring whose last point is not its first.
    OpenPolygon,
    /// A polygon ring that crosses itself, has under three points or no area.
    BadPolygon,
    /// A polygon with holes (parcels are simple polygons).
    PolygonWithHoles,
    /// A coordinate that is not a finite number within 1e9 (metres).
    NotFinite,
    /// A property with a value that cannot be used (`class`, `width`, `priority`).
    BadProperty,
    /// The element crosses or overlaps one loaded before it.
    Conflict,
}

impl LoadErrorKind {
    /// The stable code (R1001-R1010 in grm-diag's registry).
    pub fn diag_code(&self) -> grm_diag::Code {
        use grm_diag::Code;
        match self {
            LoadErrorKind::NotGeoJson => Code::LayoutNotGeoJson,
            LoadErrorKind::UnsupportedGeometry => Code::LayoutUnsupportedGeometry,
            LoadErrorKind::DegenerateStreet => Code::LayoutDegenerateStreet,
            LoadErrorKind::SelfCrossingStreet => Code::LayoutSelfCrossingStreet,
            LoadErrorKind::OpenPolygon => Code::LayoutOpenPolygon,
            LoadErrorKind::BadPolygon => Code::LayoutBadPolygon,
            LoadErrorKind::PolygonWithHoles => Code::LayoutPolygonWithHoles,
            LoadErrorKind::NotFinite => Code::LayoutNotFinite,
            LoadErrorKind::BadProperty => Code::LayoutBadProperty,
            LoadErrorKind::Conflict => Code::LayoutConflict,
        }
    }

    /// The stable code as written (`R1005`).
    pub fn code(&self) -> &'static str {
        self.diag_code().as_str()
    }
}

/// One bad element: its code, its name (the feature's `id`, else
/// `feature N`), and what is wrong.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LoadError {
    pub kind: LoadErrorKind,
    pub element: String,
    pub message: String,
}

impl std::fmt::Display for LoadError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}: {}: {}",
            self.kind.code(),
            self.element,
            self.message
        )
    }
}

/// What a GeoJSON text gave: the elements that loaded and the errors.
#[derive(Debug, Clone, Default)]
pub struct Loaded {
    pub layout: Layout,
    pub errors: Vec<LoadError>,
}

const RESERVED: [&str; 6] = ["id", "kind", "class", "width", "priority", "layer"];

fn tag_of(v: &Value) -> Option<TagValue> {
    match v {
        Value::Bool(b) => Some(TagValue::Bool(*b)),
        Value::Number(n) => n.as_f64().map(TagValue::Num),
        Value::String(s) => Some(TagValue::Text(s.clone())),
        _ => None,
    }
}

fn err(kind: LoadErrorKind, element: &str, message: impl Into<String>) -> LoadError {
    LoadError {
        kind,
        element: element.to_string(),
        message: message.into(),
    }
}

/// Reads a GeoJSON text (a FeatureCollection, a Feature or a bare
/// Geometry). `source` names the input in minted identities, so two files
/// with the same coordinates do not share nodes.
pub fn read(text: &str, source: &str) -> Loaded {
    let mut out = Loaded::default();
    let gj: geojson::GeoJson = match text.parse() {
        Ok(g) => g,
        Err(e) => {
            out.errors
                .push(err(LoadErrorKind::NotGeoJson, source, e.to_string()));
            return out;
        }
    };
    let features: Vec<geojson::Feature> = match gj {
        geojson::GeoJson::FeatureCollection(fc) => fc.features,
        geojson::GeoJson::Feature(f) => vec![f],
        geojson::GeoJson::Geometry(g) => vec![geojson::Feature {
            geometry: Some(g),
            ..Default::default()
        }],
    };
    let mut names: BTreeMap<Id, (usize, String)> = BTreeMap::new();
    let junctions = junctions(&features);
    for (i, f) in features.iter().enumerate() {
        let before: BTreeSet<Id> = out
            .layout
            .streets
            .keys()
            .chain(out.layout.parcels.keys())
            .copied()
            .collect();
        let name = match &f.id {
            Some(geojson::feature::Id::String(s)) => s.clone(),
            Some(geojson::feature::Id::Number(n)) => n.to_string(),
            None => match f
                .properties
                .as_ref()
                .and_then(|p| p.get("id"))
                .and_then(|v| v.as_str())
            {
                Some(s) => s.to_string(),
                None => format!("feature {i}"),
            },
        };
        let explicit_id = f
            .properties
            .as_ref()
            .and_then(|p| p.get("id"))
            .and_then(|v| v.as_str())
            .and_then(Id::parse)
            .or_else(|| match &f.id {
                Some(geojson::feature::Id::String(s)) => Id::parse(s),
                _ => None,
            });
        let props = f.properties.clone().unwrap_or_default();
        let Some(g) = &f.geometry else {
            out.errors.push(err(
                LoadErrorKind::UnsupportedGeometry,
                &name,
                "a feature without a geometry",
            ));
            continue;
        };
        let fid = if f.id.is_some() || props.contains_key("id") {
            Some(name.as_str())
        } else {
            None
        };
        match &g.value {
            geojson::GeometryValue::LineString { coordinates } => {
                if let Err(e) = add_street(
                    &mut out.layout,
                    coordinates,
                    &props,
                    &name,
                    fid,
                    explicit_id,
                    source,
                    &junctions,
                ) {
                    out.errors.push(e);
                }
            }
            geojson::GeometryValue::MultiLineString { coordinates } => {
                for (k, part) in coordinates.iter().enumerate() {
                    let pname = format!("{name} part {k}");
                    let pid = fid.map(|_| pname.as_str());
                    if let Err(e) = add_street(
                        &mut out.layout,
                        part,
                        &props,
                        &pname,
                        pid,
                        None,
                        source,
                        &junctions,
                    ) {
                        out.errors.push(e);
                    }
                }
            }
            geojson::GeometryValue::Polygon { coordinates } => {
                if let Err(e) = add_parcel(
                    &mut out.layout,
                    coordinates,
                    &props,
                    &name,
                    fid,
                    explicit_id,
                    source,
                ) {
                    out.errors.push(e);
                }
            }
            _ => out.errors.push(err(
                LoadErrorKind::UnsupportedGeometry,
                &name,
                "only LineString, MultiLineString (streets) and Polygon (parcels) are read",
            )),
        }
        for id in out.layout.streets.keys().chain(out.layout.parcels.keys()) {
            if !before.contains(id) {
                names.insert(*id, (i, name.clone()));
            }
        }
    }
    drop_conflicts(&mut out, &names);
    out
}

fn coord(p: &[f64], name: &str) -> Result<Coord, LoadError> {
    match p {
        [x, y, ..] if x.abs() <= MAX_COORD && y.abs() <= MAX_COORD => Ok(Coord { x: *x, y: *y }),
        [_, _, ..] => Err(err(
            LoadErrorKind::NotFinite,
            name,
            "a coordinate is not a finite number within 1e9 (metres)",
        )),
        _ => Err(err(
            LoadErrorKind::NotFinite,
            name,
            "a position needs two numbers",
        )),
    }
}

fn tags_from(props: &Map<String, Value>) -> Tags {
    props
        .iter()
        .filter(|(k, _)| !RESERVED.contains(&k.as_str()))
        .filter_map(|(k, v)| tag_of(v).map(|t| (k.clone(), t)))
        .collect()
}

#[allow(clippy::too_many_arguments)]
fn add_street(
    l: &mut Layout,
    coords: &[geojson::Position],
    props: &Map<String, Value>,
    name: &str,
    fid: Option<&str>,
    explicit: Option<Id>,
    source: &str,
    junctions: &BTreeSet<(u64, u64)>,
) -> Result<(), LoadError> {
    let mut pts: Vec<Coord> = Vec::with_capacity(coords.len());
    for p in coords {
        let c = coord(p.as_slice(), name)?;
        if pts.last() != Some(&c) {
            pts.push(c);
        }
    }
    if pts.len() < 2 {
        return Err(err(
            LoadErrorKind::DegenerateStreet,
            name,
            "a street needs two distinct points",
        ));
    }
    if pts.first() == pts.last() {
        return Err(err(
            LoadErrorKind::DegenerateStreet,
            name,
            "a street's two ends are one place (split a loop into streets)",
        ));
    }
    for i in 0..pts.len() - 1 {
        for j in i + 2..pts.len() - 1 {
            if geom::meet(pts[i], pts[i + 1], pts[j], pts[j + 1]).is_some() {
                return Err(err(
                    LoadErrorKind::SelfCrossingStreet,
                    name,
                    "the street crosses itself",
                ));
            }
        }
        if i + 2 < pts.len()
            && let Some(geom::Meet::Overlap) =
                geom::meet(pts[i], pts[i + 1], pts[i + 1], pts[i + 2])
        {
            return Err(err(
                LoadErrorKind::SelfCrossingStreet,
                name,
                "the street turns back on itself",
            ));
        }
    }
    let class = match props.get("class").or_else(|| props.get("streetType")) {
        None => StreetClass::Minor,
        Some(v) => match v.as_str().and_then(StreetClass::parse) {
            Some(c) => c,
            None => {
                return Err(err(
                    LoadErrorKind::BadProperty,
                    name,
                    "`class` must be \"minor\", \"major\" or \"highway\"",
                ));
            }
        },
    };
    let num = |key: &str, default: f64| -> Result<f64, LoadError> {
        match props.get(key) {
            None => Ok(default),
            Some(v) => match v.as_f64() {
                Some(x) if x.is_finite() && x >= 0.0 => Ok(x),
                _ => Err(err(
                    LoadErrorKind::BadProperty,
                    name,
                    format!("`{key}` must be a number, 0 or more"),
                )),
            },
        }
    };
    let width = num("width", class.default_width())?;
    let priority = num("priority", class.default_priority())?;
    let node = |c: Coord| {
        Id::mint("node")
            .str("geojson")
            .str(source)
            .f64(c.x)
            .f64(c.y)
            .finish()
    };
    // A street is cut where another street starts, ends or passes through
    // one of its points (a junction drawn as a shared vertex).
    let mut pieces: Vec<Vec<Coord>> = vec![vec![pts[0]]];
    for (i, p) in pts.iter().enumerate().skip(1) {
        if let Some(cur) = pieces.last_mut() {
            cur.push(*p);
        }
        if i + 1 < pts.len() && junctions.contains(&key(*p)) {
            pieces.push(vec![*p]);
        }
    }
    let whole = pieces.len() == 1;
    for (k, pts) in pieces.into_iter().enumerate() {
        let n = pts.len();
        let a = l.add_node(node(pts[0]), pts[0]);
        let b = l.add_node(node(pts[n - 1]), pts[n - 1]);
        let interior = pts[1..n - 1].to_vec();
        let base = match (explicit, fid) {
            (Some(id), _) => id,
            (None, Some(f)) => Id::mint("street")
                .str("geojson")
                .str(source)
                .str(f)
                .finish(),
            (None, None) => Street::mint_id(a, b, &interior),
        };
        let id = if whole || (explicit.is_none() && fid.is_none()) {
            base
        } else {
            Id::mint("street-piece").id(base).u64(k as u64).finish()
        };
        if l.kind_of(id).is_some() {
            return Err(err(
                LoadErrorKind::Conflict,
                name,
                format!("identity {id} is already used"),
            ));
        }
        let mut s = Street::new(id, a, b, class);
        s.interior = interior;
        s.width = width;
        s.priority = priority;
        s.tags = tags_from(props);
        l.streets.insert(id, s);
    }
    Ok(())
}

fn key(c: Coord) -> (u64, u64) {
    let z = |v: f64| {
        if v == 0.0 {
            0.0f64.to_bits()
        } else {
            v.to_bits()
        }
    };
    (z(c.x), z(c.y))
}

/// Points where streets meet: every end of a line, and every point that
/// two lines share.
fn junctions(features: &[geojson::Feature]) -> BTreeSet<(u64, u64)> {
    let mut ends = BTreeSet::new();
    let mut seen: BTreeMap<(u64, u64), usize> = BTreeMap::new();
    let mut line = 0usize;
    let mut visit = |coords: &[geojson::Position], ends: &mut BTreeSet<(u64, u64)>| {
        line += 1;
        let pts: Vec<Coord> = coords
            .iter()
            .filter_map(|p| match p.as_slice() {
                [x, y, ..] if x.is_finite() && y.is_finite() => Some(Coord { x: *x, y: *y }),
                _ => None,
            })
            .collect();
        if let (Some(f), Some(l)) = (pts.first(), pts.last()) {
            ends.insert(key(*f));
            ends.insert(key(*l));
        }
        for p in pts {
            let e = seen.entry(key(p)).or_insert(line);
            if *e != line {
                *e = usize::MAX;
            }
        }
    };
    for f in features {
        match f.geometry.as_ref().map(|g| &g.value) {
            Some(geojson::GeometryValue::LineString { coordinates }) => {
                visit(coordinates, &mut ends)
            }
            Some(geojson::GeometryValue::MultiLineString { coordinates }) => {
                for c in coordinates {
                    visit(c, &mut ends);
                }
            }
            _ => {}
        }
    }
    ends.extend(
        seen.into_iter()
            .filter(|(_, v)| *v == usize::MAX)
            .map(|(k, _)| k),
    );
    ends
}

fn add_parcel(
    l: &mut Layout,
    rings: &[Vec<geojson::Position>],
    props: &Map<String, Value>,
    name: &str,
    fid: Option<&str>,
    explicit: Option<Id>,
    source: &str,
) -> Result<(), LoadError> {
    let Some(outer) = rings.first() else {
        return Err(err(
            LoadErrorKind::BadPolygon,
            name,
            "a polygon without a ring",
        ));
    };
    if rings.len() > 1 {
        return Err(err(
            LoadErrorKind::PolygonWithHoles,
            name,
            "a parcel is a simple polygon without holes",
        ));
    }
    let mut pts = Vec::with_capacity(outer.len());
    for p in outer {
        pts.push(coord(p.as_slice(), name)?);
    }
    if pts.len() < 2 || pts.first() != pts.last() {
        return Err(err(
            LoadErrorKind::OpenPolygon,
            name,
            "the ring's last point is not its first",
        ));
    }
    pts.pop();
    pts.dedup();
    if let Err(p) = check_ring(&pts) {
        let what = match p {
            RingProblem::TooFewPoints => "fewer than three distinct points",
            RingProblem::NotFinite => "a coordinate is not finite",
            RingProblem::ZeroArea => "no area",
            RingProblem::SelfIntersecting => "the ring crosses itself",
        };
        return Err(err(LoadErrorKind::BadPolygon, name, what));
    }
    if geom::signed_area(&pts) < 0.0 {
        pts.reverse();
    }
    let id = match (explicit, fid) {
        (Some(id), _) => id,
        (None, Some(f)) => Id::mint("parcel")
            .str("geojson")
            .str(source)
            .str(f)
            .finish(),
        (None, None) => {
            let mut m = Id::mint("parcel").str("geojson").str(source);
            for c in &pts {
                m = m.f64(c.x).f64(c.y);
            }
            m.finish()
        }
    };
    if l.kind_of(id).is_some() {
        return Err(err(
            LoadErrorKind::Conflict,
            name,
            format!("identity {id} is already used"),
        ));
    }
    l.parcels.insert(
        id,
        Parcel {
            id,
            ring: pts,
            origin: ParcelOrigin::Explicit,
            tags: tags_from(props),
        },
    );
    Ok(())
}

/// Streets that cross earlier ones, then parcels that overlap a street or
/// an earlier parcel, are dropped and reported by their feature's name
/// (the layout stays valid).
fn drop_conflicts(out: &mut Loaded, names: &BTreeMap<Id, (usize, String)>) {
    use crate::validity::{Violation, check};
    let order = |id: &Id| names.get(id).map_or(usize::MAX, |n| n.0);
    let name = |id: &Id, l: &Layout| {
        names.get(id).map_or_else(
            || {
                format!(
                    "{} {id}",
                    l.kind_of(*id).map_or("element", ElementKind::name)
                )
            },
            |n| n.1.clone(),
        )
    };
    for _ in 0..64 {
        let v = check(&out.layout);
        if v.is_empty() {
            break;
        }
        let streets_wrong = v.iter().any(|x| {
            matches!(
                x,
                Violation::StreetsCross { .. }
                    | Violation::StreetsOverlap { .. }
                    | Violation::StreetSelfCrossing { .. }
                    | Violation::DegenerateStreet { .. }
                    | Violation::MissingNode { .. }
            )
        });
        let later = |a: &Id, b: &Id| {
            if order(a) > order(b) {
                (*a, *b)
            } else {
                (*b, *a)
            }
        };
        let mut drop: BTreeMap<Id, String> = BTreeMap::new();
        for x in &v {
            let (victim, msg) = match x {
                Violation::StreetsCross { a, b, .. } => {
                    let (v, o) = later(a, b);
                    (
                        v,
                        format!(
                            "crosses street `{}` away from a shared node",
                            name(&o, &out.layout)
                        ),
                    )
                }
                Violation::StreetsOverlap { a, b } => {
                    let (v, o) = later(a, b);
                    (v, format!("runs along street `{}`", name(&o, &out.layout)))
                }
                Violation::StreetSelfCrossing { street } => (*street, "crosses itself".to_string()),
                Violation::DegenerateStreet { street } => (*street, "is degenerate".to_string()),
                Violation::MissingNode { street, .. } => {
                    (*street, "names a missing node".to_string())
                }
                _ if streets_wrong => continue,
                Violation::ParcelOnStreet { parcel, street } => (
                    *parcel,
                    format!("overlaps street `{}`", name(street, &out.layout)),
                ),
                Violation::ParcelsOverlap { a, b } => {
                    let (v, o) = later(a, b);
                    (v, format!("overlaps parcel `{}`", name(&o, &out.layout)))
                }
                Violation::BadParcel { parcel, .. } => (*parcel, "is not simple".to_string()),
            };
            drop.entry(victim).or_insert(msg);
        }
        for (id, msg) in drop {
            out.errors
                .push(err(LoadErrorKind::Conflict, &name(&id, &out.layout), msg));
            out.layout.delete(id);
        }
        out.layout.drop_isolated_nodes();
    }
}

fn tags_json(tags: &Tags, m: &mut Map<String, Value>) {
    for (k, v) in tags {
        if RESERVED.contains(&k.as_str()) {
            continue;
        }
        let val = match v {
            TagValue::Num(x) => num(*x),
            TagValue::Text(s) => Value::String(s.clone()),
            TagValue::Bool(b) => Value::Bool(*b),
        };
        m.insert(k.clone(), val);
    }
}

fn num(x: f64) -> Value {
    // -0 is written as 0 (equal numbers, one text).
    serde_json::Number::from_f64(x + 0.0).map_or(Value::Null, Value::Number)
}

fn pos(c: Coord) -> Value {
    Value::Array(vec![num(c.x), num(c.y)])
}

fn feature(id: Id, geometry: Value, props: Map<String, Value>) -> Value {
    json!({"type": "Feature", "id": id.to_string(), "geometry": geometry, "properties": Value::Object(props)})
}

/// The layout as a GeoJSON FeatureCollection (with `blocks`, the blocks
/// too, as Polygons with `kind: "block"`), byte-identical for the same
/// layout.
pub fn write(layout: &Layout, blocks: Option<&[Block]>) -> String {
    let mut features = Vec::new();
    for s in layout.streets.values() {
        let Some(pl) = layout.polyline(s) else {
            continue;
        };
        let mut p = Map::new();
        p.insert("kind".into(), json!("street"));
        p.insert("class".into(), json!(s.class.name()));
        p.insert("width".into(), num(s.width));
        p.insert("priority".into(), num(s.priority));
        tags_json(&s.tags, &mut p);
        let g = json!({"type": "LineString", "coordinates": pl.iter().map(|c| pos(*c)).collect::<Vec<_>>()});
        features.push(feature(s.id, g, p));
    }
    for q in layout.parcels.values() {
        let mut p = Map::new();
        p.insert("kind".into(), json!("parcel"));
        if let ParcelOrigin::Generated { block } = q.origin {
            p.insert("block".into(), json!(block.to_string()));
        }
        tags_json(&q.tags, &mut p);
        let ring: Vec<Value> = geom::close(&q.ring).iter().map(|c| pos(*c)).collect();
        features.push(feature(
            q.id,
            json!({"type": "Polygon", "coordinates": [ring]}),
            p,
        ));
    }
    for n in layout.nodes.values().filter(|n| !n.tags.is_empty()) {
        let mut p = Map::new();
        p.insert("kind".into(), json!("node"));
        tags_json(&n.tags, &mut p);
        features.push(feature(
            n.id,
            json!({"type": "Point", "coordinates": pos(n.pos)}),
            p,
        ));
    }
    for b in blocks.unwrap_or(&[]) {
        let mut p = Map::new();
        p.insert("kind".into(), json!("block"));
        let mut rings = vec![Value::Array(
            geom::close(&b.ring).iter().map(|c| pos(*c)).collect(),
        )];
        for h in &b.holes {
            let mut h = h.clone();
            h.reverse();
            rings.push(Value::Array(
                geom::close(&h).iter().map(|c| pos(*c)).collect(),
            ));
        }
        features.push(feature(
            b.id,
            json!({"type": "Polygon", "coordinates": rings}),
            p,
        ));
    }
    let fc = json!({"type": "FeatureCollection", "features": features});
    let mut s = serde_json::to_string_pretty(&fc).unwrap_or_default();
    s.push('\n');
    s
}

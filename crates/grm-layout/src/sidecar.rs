//! The artist's sidecar `NAME.layout.json`: the layers (source, merge
//! mode, seed, visibility, placement), each layer's moves, deletions,
//! protections and anchored assignments, and the parcel knobs. Read
//! tolerantly: a bad layer, move or assignment is reported with a typed
//! error naming its place (`layers[1].moves[0].translate`) and skipped,
//! the rest kept; only text that is not JSON fails whole. Written
//! canonically (keys sorted, two-space indent, a final newline), so
//! reading and writing a canonical file gives the same bytes.

use crate::assign::{Anchor, Assignment, Falloff, Target};
use crate::city::BuildingSpec;
use crate::generate::{GridParams, RadialParams};
use crate::id::Id;
use crate::layers::{Document, LayerSpec, Move, Place, Select, Source};
use crate::merge::MergeMode;
use crate::model::{ElementKind, TagValue, Tags};
use crate::subdivide::ParcelParams;
use geo::Coord;
use serde_json::{Map, Value, json};

/// What is wrong at one place in the sidecar.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SidecarErrorKind {
    /// Not JSON (nothing is read).
    Syntax,
    /// A value of the wrong type or out of range.
    BadValue,
    /// A required key is missing.
    Missing,
    /// A key the format does not know (ignored).
    UnknownKey,
    /// An element identity that is not 16 hex digits.
    BadId,
    /// A newer format version.
    Version,
}

impl SidecarErrorKind {
    /// The stable code (R1021-R1026 in grm-diag's registry).
    pub fn diag_code(&self) -> grm_diag::Code {
        use grm_diag::Code;
        match self {
            SidecarErrorKind::Syntax => Code::SidecarSyntax,
            SidecarErrorKind::BadValue => Code::SidecarBadValue,
            SidecarErrorKind::Missing => Code::SidecarMissing,
            SidecarErrorKind::UnknownKey => Code::SidecarUnknownKey,
            SidecarErrorKind::BadId => Code::SidecarBadId,
            SidecarErrorKind::Version => Code::SidecarVersion,
        }
    }

    /// The stable code as written (`R1022`).
    pub fn code(&self) -> &'static str {
        self.diag_code().as_str()
    }
}

/// One problem in the sidecar, at a JSON path.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SidecarError {
    pub kind: SidecarErrorKind,
    pub path: String,
    pub message: String,
}

impl std::fmt::Display for SidecarError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}: {}", self.kind.code(), self.path, self.message)
    }
}

/// The sidecar's format version.
pub const VERSION: u64 = 1;

type R<T> = Result<T, SidecarError>;

fn bad(path: &str, kind: SidecarErrorKind, msg: impl Into<String>) -> SidecarError {
    SidecarError {
        kind,
        path: path.to_string(),
        message: msg.into(),
    }
}

fn num(v: &Value, path: &str) -> R<f64> {
    v.as_f64()
        .filter(|x| x.is_finite())
        .ok_or_else(|| bad(path, SidecarErrorKind::BadValue, "expected a finite number"))
}

fn uint(v: &Value, path: &str) -> R<u64> {
    v.as_u64().ok_or_else(|| {
        bad(
            path,
            SidecarErrorKind::BadValue,
            "expected a whole number, 0 or more",
        )
    })
}

fn point(v: &Value, path: &str) -> R<Coord> {
    let coord = |v: &Value, p: String| -> R<f64> {
        let x = num(v, &p)?;
        if x.abs() > crate::geom::MAX_COORD {
            return Err(bad(
                &p,
                SidecarErrorKind::BadValue,
                "a coordinate within 1e9",
            ));
        }
        Ok(x)
    };
    match v.as_array().map(Vec::as_slice) {
        Some([x, y]) => Ok(Coord {
            x: coord(x, format!("{path}[0]"))?,
            y: coord(y, format!("{path}[1]"))?,
        }),
        _ => Err(bad(path, SidecarErrorKind::BadValue, "expected [x, y]")),
    }
}

fn id(v: &Value, path: &str) -> R<Id> {
    v.as_str().and_then(Id::parse).ok_or_else(|| {
        bad(
            path,
            SidecarErrorKind::BadId,
            "expected an element identity (16 hex digits)",
        )
    })
}

fn obj<'a>(v: &'a Value, path: &str) -> R<&'a Map<String, Value>> {
    v.as_object()
        .ok_or_else(|| bad(path, SidecarErrorKind::BadValue, "expected an object"))
}

/// Checks an object's keys against the known ones (unknown keys are reported, not fatal).
fn keys(m: &Map<String, Value>, known: &[&str], path: &str, errs: &mut Vec<SidecarError>) {
    for k in m.keys() {
        if !known.contains(&k.as_str()) {
            errs.push(bad(
                &format!("{path}.{k}"),
                SidecarErrorKind::UnknownKey,
                "unknown key, ignored",
            ));
        }
    }
}

/// Reads a sidecar text: the document and every problem found.
pub fn read(text: &str) -> (Document, Vec<SidecarError>) {
    let mut errs = Vec::new();
    let mut doc = Document::default();
    let v: Value = match serde_json::from_str(text) {
        Ok(v) => v,
        Err(e) => {
            errs.push(bad("$", SidecarErrorKind::Syntax, e.to_string()));
            return (doc, errs);
        }
    };
    let Some(top) = v.as_object() else {
        errs.push(bad("$", SidecarErrorKind::BadValue, "expected an object"));
        return (doc, errs);
    };
    keys(
        top,
        &["version", "parcels", "buildings", "layers"],
        "$",
        &mut errs,
    );
    if let Some(ver) = top.get("version") {
        match ver.as_u64() {
            Some(n) if n <= VERSION => {}
            _ => errs.push(bad(
                "$.version",
                SidecarErrorKind::Version,
                format!("this reader knows version {VERSION}"),
            )),
        }
    }
    if let Some(p) = top.get("parcels") {
        match parcels(p, "$.parcels", &mut errs) {
            Ok(pp) => doc.parcels = pp,
            Err(e) => errs.push(e),
        }
    }
    if let Some(b) = top.get("buildings") {
        match buildings(b, "$.buildings", &mut errs) {
            Ok(spec) => doc.buildings = Some(spec),
            Err(e) => errs.push(e),
        }
    }
    if let Some(ls) = top.get("layers") {
        match ls.as_array() {
            Some(ls) => {
                for (i, l) in ls.iter().enumerate() {
                    match layer(l, &format!("$.layers[{i}]"), &mut errs) {
                        Ok(spec) => doc.layers.push(spec),
                        Err(e) => errs.push(e),
                    }
                }
            }
            None => errs.push(bad(
                "$.layers",
                SidecarErrorKind::BadValue,
                "expected an array",
            )),
        }
    }
    (doc, errs)
}

fn parcels(v: &Value, path: &str, errs: &mut Vec<SidecarError>) -> R<ParcelParams> {
    let m = obj(v, path)?;
    keys(
        m,
        &["max_area", "min_area", "setback", "jitter", "max_depth"],
        path,
        errs,
    );
    let mut p = ParcelParams::default();
    if let Some(x) = m.get("max_area") {
        p.max_area = num(x, &format!("{path}.max_area"))?;
    }
    if let Some(x) = m.get("min_area") {
        p.min_area = num(x, &format!("{path}.min_area"))?;
    }
    if let Some(x) = m.get("setback") {
        p.setback = num(x, &format!("{path}.setback"))?;
    }
    if let Some(x) = m.get("jitter") {
        p.jitter = num(x, &format!("{path}.jitter"))?;
    }
    if let Some(x) = m.get("max_depth") {
        p.max_depth = u32::try_from(uint(x, &format!("{path}.max_depth"))?.min(64)).unwrap_or(64);
    }
    if !p.is_valid() {
        return Err(bad(
            path,
            SidecarErrorKind::BadValue,
            "max_area >= 1, min_area >= 0, setback > 0, jitter in [0, 0.5), max_depth <= 20",
        ));
    }
    Ok(p)
}

/// `"buildings": {"grammar", "system", "seed", "params"}` (docs/layout.md,
/// "Buildings").
fn buildings(v: &Value, path: &str, errs: &mut Vec<SidecarError>) -> R<BuildingSpec> {
    let m = obj(v, path)?;
    keys(m, &["grammar", "system", "seed", "params"], path, errs);
    let text = |k: &str| -> R<Option<String>> {
        match m.get(k) {
            None => Ok(None),
            Some(Value::String(s)) if !s.is_empty() => Ok(Some(s.clone())),
            Some(_) => Err(bad(
                &format!("{path}.{k}"),
                SidecarErrorKind::BadValue,
                "expected a non-empty string",
            )),
        }
    };
    let grammar = text("grammar")?.ok_or_else(|| {
        bad(
            &format!("{path}.grammar"),
            SidecarErrorKind::Missing,
            "the grammar file (a shape system) the parcels grow",
        )
    })?;
    let system = text("system")?;
    let seed = match m.get("seed") {
        None => 0,
        Some(x) => u32::try_from(uint(x, &format!("{path}.seed"))?).map_err(|_| {
            bad(
                &format!("{path}.seed"),
                SidecarErrorKind::BadValue,
                "a seed below 2^32",
            )
        })?,
    };
    let mut params = Tags::new();
    if let Some(ps) = m.get("params") {
        for (k, x) in obj(ps, &format!("{path}.params"))? {
            let at = format!("{path}.params.{k}");
            let v = match x {
                Value::Bool(b) => TagValue::Bool(*b),
                Value::Number(_) => TagValue::Num(num(x, &at)?),
                _ => {
                    return Err(bad(
                        &at,
                        SidecarErrorKind::BadValue,
                        "expected a number or true or false",
                    ));
                }
            };
            params.insert(k.clone(), v);
        }
    }
    Ok(BuildingSpec {
        grammar,
        system,
        seed,
        params,
    })
}

fn layer(v: &Value, path: &str, errs: &mut Vec<SidecarError>) -> R<LayerSpec> {
    let m = obj(v, path)?;
    keys(
        m,
        &[
            "name",
            "source",
            "merge",
            "seed",
            "visible",
            "fill",
            "place",
            "moves",
            "deleted",
            "protected",
            "assignments",
        ],
        path,
        errs,
    );
    let name = m.get("name").and_then(Value::as_str).ok_or_else(|| {
        bad(
            &format!("{path}.name"),
            SidecarErrorKind::Missing,
            "a layer needs a name",
        )
    })?;
    let source = match m.get("source") {
        None => Source::Empty,
        Some(s) => source(s, &format!("{path}.source"), errs)?,
    };
    let mut spec = LayerSpec::new(name, source);
    if let Some(x) = m.get("merge") {
        spec.merge = x.as_str().and_then(MergeMode::parse).ok_or_else(|| {
            bad(
                &format!("{path}.merge"),
                SidecarErrorKind::BadValue,
                "expected \"hard\" or \"graph_cut\"",
            )
        })?;
    }
    if let Some(x) = m.get("seed") {
        spec.seed = uint(x, &format!("{path}.seed"))?;
    }
    for (key, slot) in [("visible", &mut spec.visible), ("fill", &mut spec.fill)] {
        if let Some(x) = m.get(key) {
            *slot = x.as_bool().ok_or_else(|| {
                bad(
                    &format!("{path}.{key}"),
                    SidecarErrorKind::BadValue,
                    "expected true or false",
                )
            })?;
        }
    }
    if let Some(x) = m.get("place") {
        let p = format!("{path}.place");
        let pm = obj(x, &p)?;
        keys(pm, &["translate", "rotate", "about"], &p, errs);
        let mut place = Place::default();
        if let Some(t) = pm.get("translate") {
            place.translate = point(t, &format!("{p}.translate"))?;
        }
        if let Some(t) = pm.get("rotate") {
            place.rotate_deg = num(t, &format!("{p}.rotate"))?;
        }
        if let Some(t) = pm.get("about") {
            place.about = point(t, &format!("{p}.about"))?;
        }
        spec.place = place;
    }
    let list = |key: &str, errs: &mut Vec<SidecarError>| -> Vec<(String, Value)> {
        match m.get(key) {
            None => Vec::new(),
            Some(Value::Array(a)) => a
                .iter()
                .enumerate()
                .map(|(i, x)| (format!("{path}.{key}[{i}]"), x.clone()))
                .collect(),
            Some(_) => {
                errs.push(bad(
                    &format!("{path}.{key}"),
                    SidecarErrorKind::BadValue,
                    "expected an array",
                ));
                Vec::new()
            }
        }
    };
    for (p, x) in list("deleted", errs) {
        match id(&x, &p) {
            Ok(i) => spec.deleted.push(i),
            Err(e) => errs.push(e),
        }
    }
    for (p, x) in list("protected", errs) {
        match id(&x, &p) {
            Ok(i) => spec.protected.push(i),
            Err(e) => errs.push(e),
        }
    }
    for (p, x) in list("moves", errs) {
        match mov(&x, &p, errs) {
            Ok(mv) => spec.moves.push(mv),
            Err(e) => errs.push(e),
        }
    }
    for (p, x) in list("assignments", errs) {
        match assignment(&x, &p, errs) {
            Ok(a) => spec.assignments.push(a),
            Err(e) => errs.push(e),
        }
    }
    Ok(spec)
}

fn source(v: &Value, path: &str, errs: &mut Vec<SidecarError>) -> R<Source> {
    if v.as_str() == Some("empty") {
        return Ok(Source::Empty);
    }
    let m = obj(v, path)?;
    if m.len() != 1 {
        return Err(bad(
            path,
            SidecarErrorKind::BadValue,
            "one of grid, radial, geojson, features or \"empty\"",
        ));
    }
    let (k, body) = m
        .iter()
        .next()
        .ok_or_else(|| bad(path, SidecarErrorKind::Missing, "empty source"))?;
    let p = format!("{path}.{k}");
    match k.as_str() {
        "geojson" => Ok(Source::GeoJson(
            body.as_str()
                .ok_or_else(|| bad(&p, SidecarErrorKind::BadValue, "expected a file name"))?
                .to_string(),
        )),
        "features" => {
            if !body.is_object() {
                return Err(bad(
                    &p,
                    SidecarErrorKind::BadValue,
                    "expected a GeoJSON FeatureCollection",
                ));
            }
            Ok(Source::Features(
                serde_json::to_string(body).unwrap_or_default(),
            ))
        }
        "grid" => {
            let g = obj(body, &p)?;
            keys(
                g,
                &[
                    "origin",
                    "size",
                    "spacing",
                    "rotation",
                    "jitter",
                    "major_every",
                    "seed",
                ],
                &p,
                errs,
            );
            let mut gp = GridParams::default();
            if let Some(x) = g.get("origin") {
                gp.origin = point(x, &format!("{p}.origin"))?;
            }
            if let Some(x) = g.get("size") {
                let c = point(x, &format!("{p}.size"))?;
                if !(c.x >= 1.0
                    && c.y >= 1.0
                    && c.x <= 1000.0
                    && c.y <= 1000.0
                    && c.x.fract() == 0.0
                    && c.y.fract() == 0.0)
                {
                    return Err(bad(
                        &format!("{p}.size"),
                        SidecarErrorKind::BadValue,
                        "expected [nx, ny], whole numbers 1 to 1000",
                    ));
                }
                gp.nx = c.x as u32;
                gp.ny = c.y as u32;
            }
            if let Some(x) = g.get("spacing") {
                gp.spacing = point(x, &format!("{p}.spacing"))?;
            }
            if let Some(x) = g.get("rotation") {
                gp.rotation_deg = num(x, &format!("{p}.rotation"))?;
            }
            if let Some(x) = g.get("jitter") {
                gp.jitter = num(x, &format!("{p}.jitter"))?;
            }
            if let Some(x) = g.get("major_every") {
                gp.major_every = u32::try_from(uint(x, &format!("{p}.major_every"))?).unwrap_or(0);
            }
            if let Some(x) = g.get("seed") {
                gp.seed = uint(x, &format!("{p}.seed"))?;
            }
            Ok(Source::Grid(gp))
        }
        "radial" => {
            let g = obj(body, &p)?;
            keys(
                g,
                &[
                    "centre",
                    "rings",
                    "ring_spacing",
                    "spokes",
                    "arc_points",
                    "jitter",
                    "seed",
                ],
                &p,
                errs,
            );
            let mut rp = RadialParams::default();
            if let Some(x) = g.get("centre") {
                rp.centre = point(x, &format!("{p}.centre"))?;
            }
            let small = |x: &Value, q: &str| -> R<u32> {
                u32::try_from(uint(x, q)?)
                    .map_err(|_| bad(q, SidecarErrorKind::BadValue, "too large"))
            };
            if let Some(x) = g.get("rings") {
                rp.rings = small(x, &format!("{p}.rings"))?;
            }
            if let Some(x) = g.get("spokes") {
                rp.spokes = small(x, &format!("{p}.spokes"))?;
            }
            if let Some(x) = g.get("arc_points") {
                rp.arc_points = small(x, &format!("{p}.arc_points"))?;
            }
            if let Some(x) = g.get("ring_spacing") {
                rp.ring_spacing = num(x, &format!("{p}.ring_spacing"))?;
            }
            if let Some(x) = g.get("jitter") {
                rp.jitter = num(x, &format!("{p}.jitter"))?;
            }
            if let Some(x) = g.get("seed") {
                rp.seed = uint(x, &format!("{p}.seed"))?;
            }
            Ok(Source::Radial(rp))
        }
        _ => Err(bad(&p, SidecarErrorKind::BadValue, "unknown source kind")),
    }
}

fn mov(v: &Value, path: &str, errs: &mut Vec<SidecarError>) -> R<Move> {
    let m = obj(v, path)?;
    keys(
        m,
        &["select", "translate", "rotate", "scale", "about"],
        path,
        errs,
    );
    let sel = m.get("select").ok_or_else(|| {
        bad(
            &format!("{path}.select"),
            SidecarErrorKind::Missing,
            "a move needs a selection",
        )
    })?;
    let select = select(sel, &format!("{path}.select"))?;
    let about = match m.get("about") {
        Some(x) => point(x, &format!("{path}.about"))?,
        None => Coord { x: 0.0, y: 0.0 },
    };
    let mut mv = Move::translation(select, Coord { x: 0.0, y: 0.0 });
    mv.about = about;
    if let Some(x) = m.get("scale") {
        let k = num(x, &format!("{path}.scale"))?;
        if !(k > 0.0 && k <= 1e3) {
            return Err(bad(
                &format!("{path}.scale"),
                SidecarErrorKind::BadValue,
                "a scale above 0, up to 1000",
            ));
        }
        mv.scale = k;
    }
    if let Some(x) = m.get("rotate") {
        mv.rotate_deg = num(x, &format!("{path}.rotate"))?;
    }
    if let Some(x) = m.get("translate") {
        mv.translate = point(x, &format!("{path}.translate"))?;
    }
    Ok(mv)
}

fn select(v: &Value, path: &str) -> R<Select> {
    let m = obj(v, path)?;
    let (k, body) = match (m.len(), m.iter().next()) {
        (1, Some(kv)) => kv,
        _ => {
            return Err(bad(
                path,
                SidecarErrorKind::BadValue,
                "one of ids, region, soft, continuation",
            ));
        }
    };
    let p = format!("{path}.{k}");
    match k.as_str() {
        "ids" => {
            let a = body
                .as_array()
                .ok_or_else(|| bad(&p, SidecarErrorKind::BadValue, "expected an array"))?;
            Ok(Select::Ids(
                a.iter()
                    .enumerate()
                    .map(|(i, x)| id(x, &format!("{p}[{i}]")))
                    .collect::<R<Vec<_>>>()?,
            ))
        }
        "region" => {
            let a = body.as_array().ok_or_else(|| {
                bad(
                    &p,
                    SidecarErrorKind::BadValue,
                    "expected an array of points",
                )
            })?;
            let ring = a
                .iter()
                .enumerate()
                .map(|(i, x)| point(x, &format!("{p}[{i}]")))
                .collect::<R<Vec<_>>>()?;
            if ring.len() < 3 {
                return Err(bad(
                    &p,
                    SidecarErrorKind::BadValue,
                    "a region needs three points",
                ));
            }
            Ok(Select::Region(ring))
        }
        "soft" => {
            let s = obj(body, &p)?;
            let centre = point(
                s.get("centre")
                    .ok_or_else(|| bad(&p, SidecarErrorKind::Missing, "centre"))?,
                &format!("{p}.centre"),
            )?;
            let radius = num(
                s.get("radius")
                    .ok_or_else(|| bad(&p, SidecarErrorKind::Missing, "radius"))?,
                &format!("{p}.radius"),
            )?;
            Ok(Select::Soft { centre, radius })
        }
        "continuation" => {
            let s = obj(body, &p)?;
            let street = id(
                s.get("street")
                    .ok_or_else(|| bad(&p, SidecarErrorKind::Missing, "street"))?,
                &format!("{p}.street"),
            )?;
            let max_turn_deg = match s.get("max_turn") {
                Some(x) => num(x, &format!("{p}.max_turn"))?,
                None => 30.0,
            };
            Ok(Select::Continuation {
                street,
                max_turn_deg,
            })
        }
        _ => Err(bad(&p, SidecarErrorKind::BadValue, "unknown selection")),
    }
}

fn assignment(v: &Value, path: &str, errs: &mut Vec<SidecarError>) -> R<Assignment> {
    let m = obj(v, path)?;
    keys(
        m,
        &["tags", "kinds", "radius", "falloff", "at", "anchor"],
        path,
        errs,
    );
    let tm = obj(
        m.get("tags")
            .ok_or_else(|| bad(&format!("{path}.tags"), SidecarErrorKind::Missing, "tags"))?,
        &format!("{path}.tags"),
    )?;
    let mut tags = Tags::new();
    for (k, x) in tm {
        let t = match x {
            Value::Bool(b) => TagValue::Bool(*b),
            Value::Number(_) => TagValue::Num(num(x, &format!("{path}.tags.{k}"))?),
            Value::String(s) => TagValue::Text(s.clone()),
            _ => {
                return Err(bad(
                    &format!("{path}.tags.{k}"),
                    SidecarErrorKind::BadValue,
                    "a tag is a number, a string or a boolean",
                ));
            }
        };
        tags.insert(k.clone(), t);
    }
    let kinds = match m.get("kinds") {
        None => vec![ElementKind::Parcel],
        Some(Value::Array(a)) => a
            .iter()
            .enumerate()
            .map(|(i, x)| {
                x.as_str().and_then(ElementKind::parse).ok_or_else(|| {
                    bad(
                        &format!("{path}.kinds[{i}]"),
                        SidecarErrorKind::BadValue,
                        "node, street or parcel",
                    )
                })
            })
            .collect::<R<Vec<_>>>()?,
        Some(_) => {
            return Err(bad(
                &format!("{path}.kinds"),
                SidecarErrorKind::BadValue,
                "expected an array",
            ));
        }
    };
    let target = match m.get("radius") {
        None => Target::Nearest,
        Some(r) => {
            let radius = num(r, &format!("{path}.radius"))?;
            if radius < 0.0 {
                return Err(bad(
                    &format!("{path}.radius"),
                    SidecarErrorKind::BadValue,
                    "a radius, 0 or more",
                ));
            }
            let falloff = match m.get("falloff").and_then(Value::as_str) {
                None | Some("none") => Falloff::None,
                Some("linear") => Falloff::Linear,
                Some(_) => {
                    return Err(bad(
                        &format!("{path}.falloff"),
                        SidecarErrorKind::BadValue,
                        "\"none\" or \"linear\"",
                    ));
                }
            };
            Target::Region { radius, falloff }
        }
    };
    let pos = point(
        m.get("at")
            .ok_or_else(|| bad(&format!("{path}.at"), SidecarErrorKind::Missing, "at"))?,
        &format!("{path}.at"),
    )?;
    let anchor = match m.get("anchor") {
        None => None,
        Some(a) => {
            let p = format!("{path}.anchor");
            let am = obj(a, &p)?;
            Some(Anchor {
                element: id(
                    am.get("id")
                        .ok_or_else(|| bad(&p, SidecarErrorKind::Missing, "id"))?,
                    &format!("{p}.id"),
                )?,
                kind: am
                    .get("kind")
                    .and_then(Value::as_str)
                    .and_then(ElementKind::parse)
                    .ok_or_else(|| {
                        bad(
                            &format!("{p}.kind"),
                            SidecarErrorKind::BadValue,
                            "node, street or parcel",
                        )
                    })?,
                at: point(
                    am.get("at")
                        .ok_or_else(|| bad(&p, SidecarErrorKind::Missing, "at"))?,
                    &format!("{p}.at"),
                )?,
            })
        }
    };
    Ok(Assignment {
        tags,
        kinds,
        target,
        pos,
        anchor,
    })
}

fn n(x: f64) -> Value {
    serde_json::Number::from_f64(x).map_or(Value::Null, Value::Number)
}

fn pt(c: Coord) -> Value {
    json!([n(c.x), n(c.y)])
}

/// Writes a document canonically.
pub fn write(doc: &Document) -> String {
    let d = ParcelParams::default();
    let mut top = Map::new();
    top.insert("version".into(), json!(VERSION));
    if doc.parcels != d {
        let p = &doc.parcels;
        top.insert(
            "parcels".into(),
            json!({"max_area": n(p.max_area), "min_area": n(p.min_area), "setback": n(p.setback), "jitter": n(p.jitter), "max_depth": p.max_depth}),
        );
    }
    if let Some(b) = &doc.buildings {
        let mut m = Map::new();
        m.insert("grammar".into(), json!(b.grammar));
        if let Some(sys) = &b.system {
            m.insert("system".into(), json!(sys));
        }
        if b.seed != 0 {
            m.insert("seed".into(), json!(b.seed));
        }
        if !b.params.is_empty() {
            m.insert("params".into(), tags_json(&b.params));
        }
        top.insert("buildings".into(), Value::Object(m));
    }
    let layers: Vec<Value> = doc.layers.iter().map(layer_json).collect();
    top.insert("layers".into(), Value::Array(layers));
    let mut s = serde_json::to_string_pretty(&Value::Object(top)).unwrap_or_default();
    s.push('\n');
    s
}

fn layer_json(l: &LayerSpec) -> Value {
    let mut m = Map::new();
    m.insert("name".into(), json!(l.name));
    m.insert("merge".into(), json!(l.merge.name()));
    m.insert("seed".into(), json!(l.seed));
    m.insert("visible".into(), json!(l.visible));
    m.insert("fill".into(), json!(l.fill));
    let src = match &l.source {
        Source::Empty => json!("empty"),
        Source::GeoJson(p) => json!({"geojson": p}),
        Source::Features(t) => {
            json!({"features": serde_json::from_str::<Value>(t).unwrap_or(Value::Null)})
        }
        Source::Grid(g) => {
            json!({"grid": {"origin": pt(g.origin), "size": [g.nx, g.ny], "spacing": pt(g.spacing), "rotation": n(g.rotation_deg), "jitter": n(g.jitter), "major_every": g.major_every, "seed": g.seed}})
        }
        Source::Radial(r) => {
            json!({"radial": {"centre": pt(r.centre), "rings": r.rings, "ring_spacing": n(r.ring_spacing), "spokes": r.spokes, "arc_points": r.arc_points, "jitter": n(r.jitter), "seed": r.seed}})
        }
    };
    m.insert("source".into(), src);
    if !l.place.is_identity() {
        m.insert(
            "place".into(),
            json!({"translate": pt(l.place.translate), "rotate": n(l.place.rotate_deg), "about": pt(l.place.about)}),
        );
    }
    if !l.moves.is_empty() {
        m.insert(
            "moves".into(),
            Value::Array(l.moves.iter().map(move_json).collect()),
        );
    }
    if !l.deleted.is_empty() {
        m.insert(
            "deleted".into(),
            json!(l.deleted.iter().map(Id::to_string).collect::<Vec<_>>()),
        );
    }
    if !l.protected.is_empty() {
        m.insert(
            "protected".into(),
            json!(l.protected.iter().map(Id::to_string).collect::<Vec<_>>()),
        );
    }
    if !l.assignments.is_empty() {
        m.insert(
            "assignments".into(),
            Value::Array(l.assignments.iter().map(assignment_json).collect()),
        );
    }
    Value::Object(m)
}

/// A move is written with the artist's numbers as read.
fn move_json(mv: &Move) -> Value {
    let mut m = Map::new();
    m.insert("select".into(), select_json(&mv.select));
    if mv.scale != 1.0 {
        m.insert("scale".into(), n(mv.scale));
    }
    if mv.rotate_deg != 0.0 {
        m.insert("rotate".into(), n(mv.rotate_deg));
    }
    if mv.about != (Coord { x: 0.0, y: 0.0 }) {
        m.insert("about".into(), pt(mv.about));
    }
    m.insert("translate".into(), pt(mv.translate));
    Value::Object(m)
}

fn select_json(s: &Select) -> Value {
    match s {
        Select::Ids(ids) => json!({"ids": ids.iter().map(Id::to_string).collect::<Vec<_>>()}),
        Select::Region(r) => json!({"region": r.iter().map(|c| pt(*c)).collect::<Vec<_>>()}),
        Select::Soft { centre, radius } => {
            json!({"soft": {"centre": pt(*centre), "radius": n(*radius)}})
        }
        Select::Continuation {
            street,
            max_turn_deg,
        } => {
            json!({"continuation": {"street": street.to_string(), "max_turn": n(*max_turn_deg)}})
        }
    }
}

fn tags_json(tags: &Tags) -> Value {
    let mut m = Map::new();
    for (k, v) in tags {
        m.insert(
            k.clone(),
            match v {
                TagValue::Num(x) => n(*x),
                TagValue::Text(s) => json!(s),
                TagValue::Bool(b) => json!(b),
            },
        );
    }
    Value::Object(m)
}

fn assignment_json(a: &Assignment) -> Value {
    let mut m = Map::new();
    m.insert("tags".into(), tags_json(&a.tags));
    m.insert(
        "kinds".into(),
        json!(a.kinds.iter().map(|k| k.name()).collect::<Vec<_>>()),
    );
    if let Target::Region { radius, falloff } = a.target {
        m.insert("radius".into(), n(radius));
        m.insert(
            "falloff".into(),
            json!(if falloff == Falloff::Linear {
                "linear"
            } else {
                "none"
            }),
        );
    }
    m.insert("at".into(), pt(a.pos));
    if let Some(an) = &a.anchor {
        m.insert(
            "anchor".into(),
            json!({"id": an.element.to_string(), "kind": an.kind.name(), "at": pt(an.at)}),
        );
    }
    Value::Object(m)
}

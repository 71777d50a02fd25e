//! The guiding-curves file: a small, versioned JSON format (`docs/curves.md`).
//!
//! ```json
//! {
//!   "version": 1,
//!   "defaults": { "alignment_scale": 400, "alignment_offset": 0.6 },
//!   "curves": [
//!     { "name": "trunk", "points": [[0, 0, 0], [0, 1.3, 0], [0, 2.7, 0], [0, 4, 0]] }
//!   ]
//! }
//! ```
//!
//! Loading parses the text (syntax errors carry line and column), then walks
//! the document by hand so that every other error names the file, the curve
//! (index from 0 and name) and the field. Unknown keys are errors: a typo in
//! a parameter name must not silently fall back to a default.

use std::fmt;
use std::path::Path;

use glam::DVec3;
use serde_json::{Map, Value};

use crate::bezier::Bezier3;

/// The format version this crate reads and writes.
pub const FORMAT_VERSION: u64 = 1;

/// Most utilization segments one curve may be split into.
pub const MAX_SEGMENTS_PER_CURVE: usize = 2048;
/// The largest absolute control-point coordinate accepted.
pub const MAX_COORDINATE: f64 = 1e6;

/// Most utilization segments over all curves of a file (each sampler
/// particle carries one counter per segment).
pub const MAX_SEGMENTS_TOTAL: usize = 8192;

/// The largest curves file [`Curves::load`] reads: far more than guiding
/// curves need (the examples' files are under 1 KiB); a larger file is
/// refused unread.
pub const MAX_CURVES_BYTES: u64 = 16 << 20;

/// Per-curve cost parameters (Calder section 3.3).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CurveParams {
    /// `scale_d`: distance-cost coefficients `m0 + m1 d + m2 d^2` (eq. 3).
    pub distance: [f64; 3],
    /// `scale_a`: alignment scale (eq. 6), `>= 0`.
    pub alignment_scale: f64,
    /// `delta_a`: alignment offset (eq. 6), in `[-1, 1]`.
    pub alignment_offset: f64,
    /// `scale_u`: utilization scale (eq. 7), `>= 0`; 0 turns it off.
    pub utilization_scale: f64,
    /// Length of a utilization segment along the curve, `> 0`.
    pub segment_length: f64,
    /// Tube radius: distance inside it costs nothing; 0 = a plain curve.
    pub thickness: f64,
}

impl Default for CurveParams {
    /// Calder's defaults: alignment scale 400, offset 0.6, distance
    /// coefficients `[0, 0, 100]`, segment length 0.2; utilization and
    /// thickness off.
    fn default() -> Self {
        Self {
            distance: [0.0, 0.0, 100.0],
            alignment_scale: 400.0,
            alignment_offset: 0.6,
            utilization_scale: 0.0,
            segment_length: 0.2,
            thickness: 0.0,
        }
    }
}

/// The density term (beyond the paper; off unless given).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DensityParams {
    /// Bones whose midpoints are closer than this crowd each other, `> 0`.
    pub radius: f64,
    /// Cost of a coincident pair; a pair at distance `r < radius` costs
    /// `scale (1 - r / radius)^2`. `>= 0`.
    pub scale: f64,
}

/// One guiding curve: a cubic Bézier with its cost parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct GuideCurve {
    /// Optional name, unique within the file.
    pub name: Option<String>,
    /// The curve.
    pub bezier: Bezier3,
    /// Its cost parameters (file defaults already applied).
    pub params: CurveParams,
}

/// A validated set of guiding curves.
#[derive(Clone, Debug, PartialEq)]
pub struct Curves {
    source: String,
    curves: Vec<GuideCurve>,
    density: Option<DensityParams>,
}

/// Where in a curves file an error is.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Location {
    /// The top-level object.
    File,
    /// The `defaults` object.
    Defaults,
    /// The `density` object.
    Density,
    /// A curve: its index in `curves` (from 0) and its name if it has one.
    Curve {
        /// Index in the `curves` array, from 0.
        index: usize,
        /// The curve's name, if it has a (valid) one.
        name: Option<String>,
    },
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::File => Ok(()),
            Location::Defaults => write!(f, "defaults: "),
            Location::Density => write!(f, "density: "),
            Location::Curve { index, name: None } => write!(f, "curve {index}: "),
            Location::Curve {
                index,
                name: Some(n),
            } => write!(f, "curve {index} ({n:?}): "),
        }
    }
}

/// What went wrong loading a curves file.
#[derive(Debug)]
pub enum CurvesErrorKind {
    /// The file could not be read.
    Io(std::io::Error),
    /// The text is not JSON (1-based line and column).
    Syntax {
        /// Line, from 1.
        line: usize,
        /// Column, from 1.
        column: usize,
        /// serde_json's description, without the position.
        message: String,
    },
    /// `version` is not one this crate reads.
    UnsupportedVersion(String),
    /// A field is missing, of the wrong type, unknown or out of range.
    Field {
        /// Where.
        at: Location,
        /// The field (`alignment_offset`, `points[2]`, ...).
        field: String,
        /// What is wrong, starting with the offending value where there is one.
        problem: String,
    },
}

/// An error loading a curves file; its `Display` names the file, the curve
/// and the field, e.g.
/// `calder_tree.curves.json: curve 1 ("left"): alignment_offset 1.5 is outside [-1, 1]`.
#[derive(Debug)]
pub struct CurvesError {
    /// The file name as given to [`Curves::load`] or [`Curves::from_json_str`].
    pub file: String,
    /// What went wrong.
    pub kind: CurvesErrorKind,
}

impl CurvesError {
    /// The stable code: `R0501` to `R0504`.
    pub fn code(&self) -> grm_diag::Code {
        use grm_diag::Code;
        match self.kind {
            CurvesErrorKind::Io(_) => Code::CurvesIo,
            CurvesErrorKind::Syntax { .. } => Code::CurvesSyntax,
            CurvesErrorKind::UnsupportedVersion(_) => Code::CurvesVersion,
            CurvesErrorKind::Field { .. } => Code::CurvesField,
        }
    }

    /// The error as a diagnostic. Its message names the curves file (and
    /// the line, curve and field); the primary label is on `file`/`span`,
    /// the system the curves guide, since the curves file is not grm source.
    pub fn to_diagnostic(
        &self,
        file: grm_diag::FileId,
        span: grm_diag::Span,
    ) -> grm_diag::Diagnostic {
        let help = match self.kind {
            CurvesErrorKind::Io(_) => {
                "name the guiding curves with `--curves CURVES.json` (by default FILE.curves.json next to the .grm file)"
            }
            CurvesErrorKind::Syntax { .. } => {
                "the curves file is JSON: fix it at the line and column given"
            }
            CurvesErrorKind::UnsupportedVersion(_) => {
                "write `\"version\": 1`, the format docs/curves.md describes"
            }
            CurvesErrorKind::Field { .. } => {
                "docs/curves.md lists every field, its type and its range"
            }
        };
        grm_diag::Diagnostic::new(
            self.code(),
            self.to_string(),
            file,
            span,
            "guided by these curves",
        )
        .with_help(help)
    }
}

impl fmt::Display for CurvesError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let file = &self.file;
        match &self.kind {
            CurvesErrorKind::Io(e) => write!(f, "{file}: cannot read: {e}"),
            CurvesErrorKind::Syntax {
                line,
                column,
                message,
            } => write!(f, "{file}:{line}:{column}: invalid JSON: {message}"),
            CurvesErrorKind::UnsupportedVersion(v) => write!(
                f,
                "{file}: version {v} is not supported (this grm reads version {FORMAT_VERSION})"
            ),
            CurvesErrorKind::Field { at, field, problem } => {
                write!(f, "{file}: {at}{field} {problem}")
            }
        }
    }
}

impl std::error::Error for CurvesError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match &self.kind {
            CurvesErrorKind::Io(e) => Some(e),
            _ => None,
        }
    }
}

impl Curves {
    /// Reads and validates a curves file. Errors name the file by the path
    /// as given.
    ///
    /// Only a regular file of at most [`MAX_CURVES_BYTES`] is read
    /// (`grm_diag::input::read_bounded`): `--curves /dev/zero` read without
    /// end, and a named pipe waited forever.
    pub fn load(path: impl AsRef<Path>) -> Result<Curves, CurvesError> {
        let path = path.as_ref();
        let file = path.display().to_string();
        match grm_diag::input::read_bounded_string(path, MAX_CURVES_BYTES, "a curves file") {
            Ok(text) => Self::from_json_str(&file, &text),
            Err(e) => Err(CurvesError {
                file,
                kind: CurvesErrorKind::Io(e),
            }),
        }
    }

    /// Parses and validates curves JSON; `file` names the source in errors.
    pub fn from_json_str(file: &str, text: &str) -> Result<Curves, CurvesError> {
        Parser { file }.document(text)
    }

    /// Builds a validated set from curves made in code (the editor). The
    /// same rules as for a file apply; `source` names it in errors.
    pub fn new(
        source: &str,
        curves: Vec<GuideCurve>,
        density: Option<DensityParams>,
    ) -> Result<Curves, CurvesError> {
        let p = Parser { file: source };
        if curves.is_empty() {
            return Err(p.err(
                Location::File,
                "curves",
                "is empty (at least one curve is needed)",
            ));
        }
        if let Some(d) = &density {
            p.check_density(d)?;
        }
        let mut total_segments = 0;
        for (index, c) in curves.iter().enumerate() {
            let at = Location::Curve {
                index,
                name: c.name.clone(),
            };
            if let Some(name) = &c.name {
                if name.is_empty() {
                    return Err(p.err(at, "name", "is empty"));
                }
                if let Some(first) = curves[..index]
                    .iter()
                    .position(|o| o.name.as_deref() == Some(name))
                {
                    return Err(p.err(
                        at,
                        "name",
                        format!("{name:?} is already used by curve {first}"),
                    ));
                }
            }
            total_segments += p.check_curve(&at, c)?;
        }
        if total_segments > MAX_SEGMENTS_TOTAL {
            return Err(p.err(
                Location::File,
                "curves",
                format!(
                    "have {total_segments} utilization segments in all; at most {MAX_SEGMENTS_TOTAL} are allowed (raise segment_length)"
                ),
            ));
        }
        Ok(Curves {
            source: source.to_string(),
            curves,
            density,
        })
    }

    /// The file name (or source label) the curves came from.
    pub fn source(&self) -> &str {
        &self.source
    }

    /// The curves, in file order (never empty).
    pub fn curves(&self) -> &[GuideCurve] {
        &self.curves
    }

    /// The density term's parameters, if the file turns it on.
    pub fn density(&self) -> Option<DensityParams> {
        self.density
    }

    /// The canonical JSON text of these curves (version 1, every parameter
    /// written out per curve, no `defaults`). Loading it gives back an equal
    /// [`Curves`] (up to the `source` label).
    pub fn to_json_string(&self) -> String {
        use std::fmt::Write as _;
        // `{:?}` on f64 is the shortest text that reads back to the same
        // value, and always has a digit after a point or an exponent.
        let v = |p: DVec3| format!("[{:?}, {:?}, {:?}]", p.x, p.y, p.z);
        let mut s = String::new();
        // Writing to a String cannot fail; the results are ignored below.
        let _ = writeln!(s, "{{\n  \"version\": {FORMAT_VERSION},");
        if let Some(d) = &self.density {
            let _ = writeln!(
                s,
                "  \"density\": {{ \"radius\": {:?}, \"scale\": {:?} }},",
                d.radius, d.scale
            );
        }
        s.push_str("  \"curves\": [\n");
        for (i, c) in self.curves.iter().enumerate() {
            s.push_str("    {\n");
            if let Some(n) = &c.name {
                let _ = writeln!(s, "      \"name\": {},", Value::String(n.clone()));
            }
            let [p0, p1, p2, p3] = c.bezier.points();
            let _ = writeln!(
                s,
                "      \"points\": [{}, {}, {}, {}],",
                v(p0),
                v(p1),
                v(p2),
                v(p3)
            );
            let p = &c.params;
            let _ = writeln!(
                s,
                "      \"distance\": [{:?}, {:?}, {:?}],",
                p.distance[0], p.distance[1], p.distance[2]
            );
            let _ = writeln!(s, "      \"alignment_scale\": {:?},", p.alignment_scale);
            let _ = writeln!(s, "      \"alignment_offset\": {:?},", p.alignment_offset);
            let _ = writeln!(s, "      \"utilization_scale\": {:?},", p.utilization_scale);
            let _ = writeln!(s, "      \"segment_length\": {:?},", p.segment_length);
            let _ = writeln!(s, "      \"thickness\": {:?}", p.thickness);
            s.push_str(if i + 1 == self.curves.len() {
                "    }\n"
            } else {
                "    },\n"
            });
        }
        s.push_str("  ]\n}\n");
        s
    }
}

/// Number of utilization segments of a curve of arc length `length`:
/// `ceil(length / segment_length)`, at least 1 (all `segment_length` long
/// except the last, which is shorter). A ratio within 1e-9 above an integer
/// counts as that integer, so that rounding in the arc length does not add
/// a sliver of a last segment (2.1 / 0.3 = 7.000000000000001 gives 7).
pub fn segment_count(length: f64, segment_length: f64) -> usize {
    let n = (length / segment_length - 1e-9).ceil();
    if n.is_finite() && n >= 1.0 {
        // Saturating float-to-int cast; callers bound it.
        n as usize
    } else {
        1
    }
}

const PARAM_KEYS: [&str; 6] = [
    "distance",
    "alignment_scale",
    "alignment_offset",
    "utilization_scale",
    "segment_length",
    "thickness",
];

struct Parser<'a> {
    file: &'a str,
}

impl Parser<'_> {
    fn err(&self, at: Location, field: &str, problem: impl Into<String>) -> CurvesError {
        CurvesError {
            file: self.file.to_string(),
            kind: CurvesErrorKind::Field {
                at,
                field: field.to_string(),
                problem: problem.into(),
            },
        }
    }

    fn document(&self, text: &str) -> Result<Curves, CurvesError> {
        // Editors on Windows save a byte-order mark; JSON does not allow one.
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        // serde_json keeps the last of two equal keys; a key given twice is
        // a mistake to report (with its position), not a value to drop.
        let value: Value = serde_json::from_str::<NoDuplicateKeys>(text)
            .and_then(|_| serde_json::from_str(text))
            .map_err(|e| {
                let full = e.to_string();
                let suffix = format!(" at line {} column {}", e.line(), e.column());
                let message = full.strip_suffix(&suffix).unwrap_or(&full).to_string();
                CurvesError {
                    file: self.file.to_string(),
                    kind: CurvesErrorKind::Syntax {
                        line: e.line(),
                        // serde_json counts 0 at the start of a line (an error
                        // right after a line break, e.g. the end of the file).
                        column: e.column().max(1),
                        message,
                    },
                }
            })?;
        let Value::Object(top) = value else {
            return Err(self.err(
                Location::File,
                "(document)",
                format!(
                    "is {}; expected an object with \"version\" and \"curves\"",
                    kind(&value)
                ),
            ));
        };
        match top.get("version") {
            None => return Err(self.err(Location::File, "version", "is missing (expected 1)")),
            Some(v) if v.as_u64() == Some(FORMAT_VERSION) => {}
            // `1.0` or `"1"`: the right version in the wrong form.
            Some(v) if v.as_f64() == Some(FORMAT_VERSION as f64) => {
                return Err(self.err(
                    Location::File,
                    "version",
                    format!("{v} must be written as the integer {FORMAT_VERSION}"),
                ));
            }
            Some(v) if !v.is_number() => {
                return Err(self.err(
                    Location::File,
                    "version",
                    format!("is {}; expected the integer {FORMAT_VERSION}", kind(v)),
                ));
            }
            Some(v) => {
                return Err(CurvesError {
                    file: self.file.to_string(),
                    kind: CurvesErrorKind::UnsupportedVersion(v.to_string()),
                });
            }
        }
        for key in top.keys() {
            if !["version", "defaults", "density", "curves"].contains(&key.as_str()) {
                return Err(self.err(
                    Location::File,
                    key,
                    "is not a known key (expected version, defaults, density, curves)",
                ));
            }
        }
        let mut defaults = CurveParams::default();
        if let Some(d) = top.get("defaults") {
            let Value::Object(d) = d else {
                return Err(self.err(
                    Location::File,
                    "defaults",
                    format!("is {}; expected an object", kind(d)),
                ));
            };
            for key in d.keys() {
                if !PARAM_KEYS.contains(&key.as_str()) {
                    return Err(self.err(Location::Defaults, key, unknown_param()));
                }
            }
            defaults = self.params(&Location::Defaults, d, defaults)?;
            self.check_params(&Location::Defaults, &defaults)?;
        }
        let density = match top.get("density") {
            None => None,
            Some(Value::Object(d)) => {
                for key in d.keys() {
                    if !["radius", "scale"].contains(&key.as_str()) {
                        return Err(self.err(
                            Location::Density,
                            key,
                            "is not a known key (expected radius, scale)",
                        ));
                    }
                }
                let get = |field: &str| -> Result<f64, CurvesError> {
                    match d.get(field) {
                        None => Err(self.err(Location::Density, field, "is missing")),
                        Some(v) => self.number(&Location::Density, field, v),
                    }
                };
                Some(DensityParams {
                    radius: get("radius")?,
                    scale: get("scale")?,
                })
            }
            Some(other) => {
                return Err(self.err(
                    Location::File,
                    "density",
                    format!("is {}; expected an object", kind(other)),
                ));
            }
        };
        let list = match top.get("curves") {
            None => return Err(self.err(Location::File, "curves", "is missing")),
            Some(Value::Array(a)) => a,
            Some(other) => {
                return Err(self.err(
                    Location::File,
                    "curves",
                    format!("is {}; expected an array of curves", kind(other)),
                ));
            }
        };
        let mut curves = Vec::with_capacity(list.len());
        for (index, c) in list.iter().enumerate() {
            curves.push(self.curve(index, c, defaults)?);
        }
        Curves::new(self.file, curves, density)
    }

    fn curve(
        &self,
        index: usize,
        v: &Value,
        defaults: CurveParams,
    ) -> Result<GuideCurve, CurvesError> {
        let Value::Object(m) = v else {
            return Err(self.err(
                Location::Curve { index, name: None },
                "(curve)",
                format!("is {}; expected an object", kind(v)),
            ));
        };
        let name = match m.get("name") {
            None => None,
            Some(Value::String(s)) => Some(s.clone()),
            Some(other) => {
                return Err(self.err(
                    Location::Curve { index, name: None },
                    "name",
                    format!("is {}; expected a string", kind(other)),
                ));
            }
        };
        let at = Location::Curve {
            index,
            name: name.clone(),
        };
        for key in m.keys() {
            if key != "name" && key != "points" && !PARAM_KEYS.contains(&key.as_str()) {
                return Err(self.err(
                    at,
                    key,
                    "is not a known curve key (expected name, points, or a parameter)",
                ));
            }
        }
        let points = match m.get("points") {
            None => {
                return Err(self.err(at, "points", "is missing (four control points [x, y, z])"));
            }
            Some(Value::Array(a)) => a,
            Some(other) => {
                return Err(self.err(
                    at,
                    "points",
                    format!(
                        "is {}; expected an array of four [x, y, z] points",
                        kind(other)
                    ),
                ));
            }
        };
        if points.len() != 4 {
            return Err(self.err(
                at,
                "points",
                format!(
                    "has {} points; a cubic Bezier needs exactly 4 control points",
                    points.len()
                ),
            ));
        }
        let mut ctrl = [DVec3::ZERO; 4];
        for (i, (p, out)) in points.iter().zip(ctrl.iter_mut()).enumerate() {
            let field = format!("points[{i}]");
            let xyz = match p {
                Value::Array(a) if a.len() == 3 => a,
                Value::Array(a) => {
                    return Err(self.err(
                        at,
                        &field,
                        format!("has {} coordinates; expected 3 [x, y, z]", a.len()),
                    ));
                }
                other => {
                    return Err(self.err(
                        at,
                        &field,
                        format!("is {}; expected [x, y, z]", kind(other)),
                    ));
                }
            };
            let mut c = [0.0; 3];
            for (j, (v, o)) in xyz.iter().zip(c.iter_mut()).enumerate() {
                *o = self.number(&at, &format!("{field}[{j}]"), v)?;
            }
            *out = DVec3::from_array(c);
        }
        let params = self.params(&at, m, defaults)?;
        Ok(GuideCurve {
            name,
            bezier: Bezier3::new(ctrl),
            params,
        })
    }

    /// Reads the parameter keys present in `m` over `base`.
    fn params(
        &self,
        at: &Location,
        m: &Map<String, Value>,
        base: CurveParams,
    ) -> Result<CurveParams, CurvesError> {
        let mut p = base;
        if let Some(v) = m.get("distance") {
            let Value::Array(a) = v else {
                return Err(self.err(
                    at.clone(),
                    "distance",
                    format!("is {}; expected three coefficients [m0, m1, m2]", kind(v)),
                ));
            };
            if a.len() != 3 {
                return Err(self.err(
                    at.clone(),
                    "distance",
                    format!("has {} coefficients; expected 3 [m0, m1, m2]", a.len()),
                ));
            }
            for (i, (v, o)) in a.iter().zip(p.distance.iter_mut()).enumerate() {
                *o = self.number(at, &format!("distance[{i}]"), v)?;
            }
        }
        let scalar = |key: &str, out: &mut f64| -> Result<(), CurvesError> {
            if let Some(v) = m.get(key) {
                *out = self.number(at, key, v)?;
            }
            Ok(())
        };
        scalar("alignment_scale", &mut p.alignment_scale)?;
        scalar("alignment_offset", &mut p.alignment_offset)?;
        scalar("utilization_scale", &mut p.utilization_scale)?;
        scalar("segment_length", &mut p.segment_length)?;
        scalar("thickness", &mut p.thickness)?;
        Ok(p)
    }

    fn number(&self, at: &Location, field: &str, v: &Value) -> Result<f64, CurvesError> {
        match v.as_f64() {
            Some(x) if x.is_finite() => Ok(x),
            Some(x) => Err(self.err(at.clone(), field, format!("{x} is not a finite number"))),
            None => Err(self.err(
                at.clone(),
                field,
                format!("is {}; expected a number", kind(v)),
            )),
        }
    }

    fn check_params(&self, at: &Location, p: &CurveParams) -> Result<(), CurvesError> {
        let bad = |field: &str, problem: String| Err(self.err(at.clone(), field, problem));
        for (i, m) in p.distance.iter().enumerate() {
            if !m.is_finite() {
                return bad(
                    &format!("distance[{i}]"),
                    format!("{m} is not a finite number"),
                );
            }
        }
        for (i, m) in p.distance.iter().enumerate().skip(1) {
            if *m < 0.0 {
                return bad(
                    &format!("distance[{i}]"),
                    format!("{m} is negative (it would reward bones for leaving the curve)"),
                );
            }
        }
        let nonneg = |field: &str, x: f64| {
            if !(x.is_finite() && x >= 0.0) {
                Err(self.err(
                    at.clone(),
                    field,
                    format!("{x} must be a finite number >= 0"),
                ))
            } else {
                Ok(())
            }
        };
        nonneg("alignment_scale", p.alignment_scale)?;
        nonneg("utilization_scale", p.utilization_scale)?;
        nonneg("thickness", p.thickness)?;
        if !(-1.0..=1.0).contains(&p.alignment_offset) {
            return bad(
                "alignment_offset",
                format!("{} is outside [-1, 1]", p.alignment_offset),
            );
        }
        if !(p.segment_length.is_finite() && p.segment_length > 0.0) {
            return bad(
                "segment_length",
                format!("{} must be a finite number > 0", p.segment_length),
            );
        }
        Ok(())
    }

    fn check_density(&self, d: &DensityParams) -> Result<(), CurvesError> {
        if !(d.radius.is_finite() && d.radius > 0.0) {
            return Err(self.err(
                Location::Density,
                "radius",
                format!("{} must be a finite number > 0", d.radius),
            ));
        }
        if !(d.scale.is_finite() && d.scale >= 0.0) {
            return Err(self.err(
                Location::Density,
                "scale",
                format!("{} must be a finite number >= 0", d.scale),
            ));
        }
        Ok(())
    }

    /// Validates one curve; returns its number of utilization segments.
    fn check_curve(&self, at: &Location, c: &GuideCurve) -> Result<usize, CurvesError> {
        for (i, p) in c.bezier.points().iter().enumerate() {
            if !p.is_finite() {
                return Err(self.err(
                    at.clone(),
                    &format!("points[{i}]"),
                    "has a coordinate that is not finite",
                ));
            }
            // Models are built in f32: far beyond this, a bone's position
            // keeps no precision (and lengths overflow).
            if p.abs().max_element() > MAX_COORDINATE {
                return Err(self.err(
                    at.clone(),
                    &format!("points[{i}]"),
                    format!(
                        "[{}, {}, {}] has a coordinate beyond ±{MAX_COORDINATE:e} (models are built in single precision)",
                        short(p.x),
                        short(p.y),
                        short(p.z)
                    ),
                ));
            }
        }
        self.check_params(at, &c.params)?;
        let length = c.bezier.length();
        let scale = c.bezier.polygon_length();
        if length.is_nan() || length <= 1e-9 * scale.max(1.0) {
            return Err(self.err(
                at.clone(),
                "points",
                "make a curve of zero length (all control points coincide)",
            ));
        }
        let n = segment_count(length, c.params.segment_length);
        if n > MAX_SEGMENTS_PER_CURVE {
            return Err(self.err(
                at.clone(),
                "segment_length",
                format!(
                    "{} splits the curve (length {length:.3}) into {} segments; at most {MAX_SEGMENTS_PER_CURVE} are allowed",
                    short(c.params.segment_length),
                    if n > 1_000_000_000 {
                        "more than a billion".to_string()
                    } else {
                        n.to_string()
                    }
                ),
            ));
        }
        Ok(n)
    }
}

/// A number as written in an error: huge and tiny ones in exponent form.
fn short(x: f64) -> String {
    if x.abs() >= 1e7 || (x != 0.0 && x.abs() < 1e-4) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

fn unknown_param() -> String {
    format!(
        "is not a known parameter (expected one of {})",
        PARAM_KEYS.join(", ")
    )
}

fn kind(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "an array",
        Value::Object(_) => "an object",
    }
}

/// Walks a JSON document and fails on an object that gives a key twice
/// (serde_json's `Value` would silently keep the last one).
struct NoDuplicateKeys;

impl<'de> serde::Deserialize<'de> for NoDuplicateKeys {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(NoDuplicateKeysVisitor)
    }
}

struct NoDuplicateKeysVisitor;

impl<'de> serde::de::Visitor<'de> for NoDuplicateKeysVisitor {
    type Value = NoDuplicateKeys;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("a JSON value")
    }
    fn visit_bool<E>(self, _: bool) -> Result<NoDuplicateKeys, E> {
        Ok(NoDuplicateKeys)
    }
    fn visit_i64<E>(self, _: i64) -> Result<NoDuplicateKeys, E> {
        Ok(NoDuplicateKeys)
    }
    fn visit_u64<E>(self, _: u64) -> Result<NoDuplicateKeys, E> {
        Ok(NoDuplicateKeys)
    }
    fn visit_f64<E>(self, _: f64) -> Result<NoDuplicateKeys, E> {
        Ok(NoDuplicateKeys)
    }
    fn visit_str<E>(self, _: &str) -> Result<NoDuplicateKeys, E> {
        Ok(NoDuplicateKeys)
    }
    fn visit_unit<E>(self) -> Result<NoDuplicateKeys, E> {
        Ok(NoDuplicateKeys)
    }
    fn visit_seq<A: serde::de::SeqAccess<'de>>(
        self,
        mut seq: A,
    ) -> Result<NoDuplicateKeys, A::Error> {
        while seq.next_element::<NoDuplicateKeys>()?.is_some() {}
        Ok(NoDuplicateKeys)
    }
    fn visit_map<A: serde::de::MapAccess<'de>>(
        self,
        mut map: A,
    ) -> Result<NoDuplicateKeys, A::Error> {
        let mut seen = std::collections::HashSet::new();
        while let Some(key) = map.next_key::<String>()? {
            if !seen.insert(key.clone()) {
                return Err(serde::de::Error::custom(format!(
                    "the key \"{key}\" is given twice in one object"
                )));
            }
            map.next_value::<NoDuplicateKeys>()?;
        }
        Ok(NoDuplicateKeys)
    }
}

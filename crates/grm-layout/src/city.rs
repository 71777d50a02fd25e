//! Buildings on parcels and the city as one model (issue 29, "buildings
//! grown on the parcels"): every parcel's polygon is the lot of a shape
//! system (a split grammar, `mode = shape`), grown on the one road
//! (`grm_grow::shape::grow_on_lot`: lot polygon in, model out), its x
//! axis along the parcel's street front ([`Fronts`]), with the parcel's
//! tags as the building's meta-parameters; the streets, parcels
//! and open ground drawn flat under them; all of it one
//! [`grm_geom::Model`] that exports as glTF (one node per street, parcel
//! and open area, a parcel's building in its node) or a picture.
//!
//! Identity: a building's seed is minted from its parcel's identity and
//! the spec's seed ([`parcel_seed`]), never from the parcel's place in a
//! list, so a layout change that keeps a parcel (same identity, same
//! polygon, same tags, and so the same street front) regrows the same
//! building, byte for byte; parcels
//! are visited in identity order, so the city's model is the same for the
//! same layout.
//!
//! Errors: a parcel whose tag does not fit the parameter it names (R1031)
//! or whose building does not grow (the shape engine's coded error:
//! E0509 a lot without area, R0801 too many shapes, ...) is reported as a
//! [`BuildingIssue`] naming the parcel and keeps its ground; the others
//! grow. The city as a whole stops only at its memory bound
//! ([`CityError`]).

use std::collections::HashMap;
use std::path::Path;

use glam::Vec3;
use grm_edits::{Edit, EditsFile};
use grm_geom::grm_turtle::Aabb;
use grm_geom::shape::{GroupSpan, ShapeGroup};
use grm_geom::{BuildOptions, MeshData, Model, ModelMaterial, ModelTexture, Part};
use grm_grow::shape::{GivenLot, ShapeGrowError, ShapeOptions, grow_on_lot_with_edits};
use grm_sema::{Program, System, Ty, Value};

use crate::building_edits::{self, EditIssue};
use crate::id::Id;
use crate::model::{Layout, Parcel, TagValue, Tags};
use crate::{geom, index};

/// The tag that keeps a parcel free of a building when it is `false` (a
/// park, a square): its ground is drawn as open ground.
pub const NO_BUILDING: &str = "building";

/// The sidecar's `buildings` section: which shape system grows on the
/// parcels, with what base values.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BuildingSpec {
    /// The grammar file, relative to the sidecar.
    pub grammar: String,
    /// The system to grow (default: the file's default system).
    pub system: Option<String>,
    /// Mixed into every parcel's seed (a new value reseeds every
    /// building; 0 by default).
    pub seed: u32,
    /// Meta-parameter values for every building (numbers and booleans);
    /// a parcel's tag of the same name wins.
    pub params: Tags,
}

/// A shape system ready to grow on parcels.
#[derive(Debug, Clone, Copy)]
pub struct Buildings<'a> {
    pub program: &'a Program,
    /// A shape system of `program` (`mode = shape`) checked without errors.
    pub system: &'a System,
    /// The base meta-parameter values, by `ParamId` (`program`'s defaults
    /// with the spec's `params`).
    pub params: &'a [Value],
    /// The grammar's directory (textures and meshes).
    pub dir: Option<&'a Path>,
    /// [`BuildingSpec::seed`].
    pub seed: u32,
    /// Threads and limits of each building's derivation (its seed is the
    /// parcel's).
    pub options: ShapeOptions,
}

/// Why one parcel has no building.
#[derive(Debug)]
pub enum BuildingError {
    /// A tag names a meta-parameter but its value does not fit it (R1031).
    Tag {
        name: String,
        value: String,
        why: String,
    },
    /// The shape system did not grow on the parcel (its coded error).
    Grow(ShapeGrowError),
}

/// A parcel without a building, and why.
#[derive(Debug)]
pub struct BuildingIssue {
    pub parcel: Id,
    pub error: BuildingError,
}

impl BuildingIssue {
    /// The stable code: R1031, or the shape engine's (E0509, R08xx).
    pub fn diag_code(&self) -> grm_diag::Code {
        match &self.error {
            BuildingError::Tag { .. } => grm_diag::Code::BuildingTag,
            BuildingError::Grow(e) => e.code(),
        }
    }

    /// The stable code as written.
    pub fn code(&self) -> String {
        self.diag_code().as_str().to_string()
    }

    pub fn describe(&self) -> String {
        match &self.error {
            BuildingError::Tag { name, value, why } => format!(
                "parcel {}: tag `{name}` = {value} does not fit the building's meta-parameter: {why}",
                self.parcel
            ),
            BuildingError::Grow(e) => format!("parcel {}: no building: {e}", self.parcel),
        }
    }
}

/// Why the city was not built.
#[derive(Debug, Clone, PartialEq)]
pub enum CityError {
    /// The model grew past `BuildOptions::max_bytes`.
    MemoryLimit { bytes: u64, limit: u64 },
}

impl std::fmt::Display for CityError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CityError::MemoryLimit { bytes, limit } => write!(
                f,
                "the city's model needs more than {limit} bytes (at least {bytes}); grow fewer or smaller buildings"
            ),
        }
    }
}

impl std::error::Error for CityError {}

/// A built city.
#[derive(Debug)]
pub struct City {
    /// Ground and buildings, y-up like every grm model (a layout point
    /// `(x, y)` is the model point `(x, 0, -y)`).
    pub model: Model,
    /// Parcels with a building.
    pub buildings: usize,
    /// Of those, the buildings taken from a [`BuildingCache`] rather than
    /// grown.
    pub reused: usize,
    /// Parcels without one, and why.
    pub issues: Vec<BuildingIssue>,
    /// Buildings grown with building edits replayed ([`city_edited`]).
    pub edited: usize,
    /// Building edits applied to no building, and why (R1032).
    pub edit_issues: Vec<EditIssue>,
}

/// The seed of the building on `parcel`: its identity mixed with the
/// spec's seed (the same parcel gets the same building on every run).
pub fn parcel_seed(parcel: Id, seed: u32) -> u32 {
    let h = Id::mint("building")
        .id(parcel)
        .f64(f64::from(seed))
        .finish();
    (h.0 ^ (h.0 >> 32)) as u32
}

/// The meta-parameter values of the building on a parcel with `tags`:
/// the base values, each parameter named by a tag set to the tag's value
/// (numbers for number parameters within their range, booleans for
/// boolean ones). Tags that name no parameter are ignored.
pub fn parcel_params(b: &Buildings, tags: &Tags) -> Result<Vec<Value>, BuildingError> {
    let mut values = b.params.to_vec();
    for (name, tag) in tags {
        let Some(id) = b.program.param_by_name(name) else {
            continue;
        };
        let p = &b.program.params[id.index()];
        let bad = |why: String| BuildingError::Tag {
            name: name.clone(),
            value: match tag {
                TagValue::Num(x) => format!("{x}"),
                TagValue::Text(t) => format!("{t:?}"),
                TagValue::Bool(v) => format!("{v}"),
            },
            why,
        };
        let v = match (p.ty, tag) {
            (Ty::Float, TagValue::Num(x)) if x.is_finite() => {
                if let Some((lo, hi)) = p.range
                    && !(lo..=hi).contains(x)
                {
                    return Err(bad(format!("outside its range {lo} .. {hi}")));
                }
                Value::Float(*x)
            }
            (Ty::Bool, TagValue::Bool(v)) => Value::Bool(*v),
            (Ty::Float, _) => return Err(bad("expected a finite number".into())),
            (Ty::Bool, _) => return Err(bad("expected true or false".into())),
            (other, _) => return Err(bad(format!("a `{other}` cannot be set by a tag"))),
        };
        if let Some(slot) = values.get_mut(id.index()) {
            *slot = v;
        }
    }
    Ok(values)
}

/// Grow the building on one parcel: its polygon the lot, with the lot's
/// x axis along `x_axis` (its street front, [`Fronts::of`]), its tags the
/// meta-parameters, its identity the seed.
pub fn building(
    b: &Buildings,
    parcel: &Parcel,
    x_axis: [f64; 2],
    build: &BuildOptions,
) -> Result<Model, BuildingError> {
    building_edited(b, parcel, x_axis, build, &[])
}

/// [`building`] with the parcel's building edits replayed inside its
/// derivation (`grm_grow::shape::grow_on_lot_with_edits`; those naming
/// another system are left out). The caller picks the parcel's edits
/// ([`building_edits::by_parcel`]).
pub fn building_edited(
    b: &Buildings,
    parcel: &Parcel,
    x_axis: [f64; 2],
    build: &BuildOptions,
    edits: &[&Edit],
) -> Result<Model, BuildingError> {
    let params = parcel_params(b, &parcel.tags)?;
    let ring: Vec<[f64; 2]> = open(&parcel.ring).iter().map(|c| [c.x, c.y]).collect();
    let options = ShapeOptions {
        seed: Some(parcel_seed(parcel.id, b.seed)),
        ..b.options
    };
    let rings = [ring];
    let lot = GivenLot {
        rings: &rings,
        x_axis,
    };
    let grown = grow_on_lot_with_edits(
        b.program,
        b.system,
        &params,
        lot,
        &options,
        Some((build, b.dir)),
        edits,
    )
    .map_err(BuildingError::Grow)?;
    Ok(grown.model.unwrap_or_default())
}

/// How far from a parcel a street still makes its front.
const FRONT_REACH: f64 = 60.0;

/// The street fronts of a layout's parcels: the lot's x axis runs along
/// the parcel's edge nearest a street's centre line (among the edges at
/// least a quarter as long as the longest, so a sliver at a corner does
/// not turn the building), with the parcel on its left (its +y), so a
/// grammar's `front` face looks at the street. A parcel with no street
/// within 60 m runs along its longest edge.
#[derive(Debug)]
pub struct Fronts {
    segments: rstar::RTree<index::Seg>,
}

impl Fronts {
    pub fn new(layout: &Layout) -> Fronts {
        Fronts {
            segments: index::segments(layout),
        }
    }

    /// The direction of `parcel`'s street front (a unit vector).
    pub fn of(&self, parcel: &Parcel) -> [f64; 2] {
        let mut ring = open(&parcel.ring);
        if ring.len() < 2 {
            return [1.0, 0.0];
        }
        // Counter-clockwise: the inside is left of each edge.
        let twice_area: f64 = (0..ring.len())
            .map(|i| {
                let (a, b) = (ring[i], ring[(i + 1) % ring.len()]);
                a.x * b.y - b.x * a.y
            })
            .sum();
        if twice_area < 0.0 {
            ring.reverse();
        }
        let edges: Vec<(geo::Coord, geo::Coord, f64)> = (0..ring.len())
            .map(|i| {
                let (a, b) = (ring[i], ring[(i + 1) % ring.len()]);
                (a, b, geom::dist(a, b))
            })
            .collect();
        let longest = edges.iter().map(|e| e.2).fold(0.0, f64::max);
        if !(longest > 0.0 && longest.is_finite()) {
            return [1.0, 0.0];
        }
        let (lo, hi) = index::bounds(&ring);
        let near: Vec<&index::Seg> = self
            .segments
            .locate_in_envelope_intersecting(&index::grown(lo, hi, FRONT_REACH))
            .collect();
        let mut best: Option<(f64, f64, usize)> = None;
        for (i, &(a, b, len)) in edges.iter().enumerate() {
            if len < longest / 4.0 {
                continue;
            }
            let mid = geo::Coord {
                x: (a.x + b.x) / 2.0,
                y: (a.y + b.y) / 2.0,
            };
            let d = near
                .iter()
                .map(|s| geom::point_segment_dist(mid, s.a, s.b))
                .fold(f64::INFINITY, f64::min);
            // Nearest first, then longest, then first.
            let better = match best {
                None => true,
                Some((bd, bl, _)) => d < bd || (d == bd && len > bl),
            };
            if better {
                best = Some((d, len, i));
            }
        }
        let i = best.map_or(0, |(_, _, i)| i);
        let (a, b, len) = edges[i];
        [(b.x - a.x) / len, (b.y - a.y) / len]
    }
}

/// The ground's materials (names no grammar's material is likely to
/// take; a grammar's material of the same name and look is shared).
fn ground_material(name: &str, color: [f32; 3]) -> ModelMaterial {
    ModelMaterial {
        name: name.into(),
        color,
        roughness: 0.95,
        metallic: 0.0,
        emissive: [0.0; 3],
        opacity: 1.0,
        texture: None,
    }
}

/// Build the city: the ground (streets, parcels, open areas) and, with
/// `buildings`, a building on every parcel but those tagged
/// `building: false` ([`NO_BUILDING`]). `progress(done, total)` is
/// called after each parcel.
pub fn city(
    layout: &Layout,
    buildings: Option<&Buildings>,
    build: &BuildOptions,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<City, CityError> {
    city_with(layout, buildings, build, None, None, progress)
}

/// [`city`] (or [`city_cached`] with `cache`) with the building edits of
/// `edits` (those with a `parcel`; docs/layout.md, "Building edits"):
/// each parcel's replayed in its building, the rest reported in
/// [`City::edit_issues`] (R1032) and applied nowhere. A building is the
/// same, byte for byte, as long as its parcel and its edits are.
pub fn city_edited(
    layout: &Layout,
    buildings: Option<&Buildings>,
    build: &BuildOptions,
    edits: &EditsFile,
    cache: Option<&mut BuildingCache>,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<City, CityError> {
    city_with(layout, buildings, build, Some(edits), cache, progress)
}

/// The buildings of the last growth of a city, kept for the next (an
/// editor's drag): each with the parcel, front and system's seed and
/// values it was grown from, so a parcel that is the same gets its
/// building back without growing it ([`city_cached`]). It holds a second
/// copy of the buildings' meshes. Clear it when the grammar changes.
#[derive(Debug, Default)]
pub struct BuildingCache {
    kept: HashMap<Id, Kept>,
}

#[derive(Debug)]
struct Kept {
    parcel: Parcel,
    x_axis: [f64; 2],
    seed: u32,
    params: Vec<Value>,
    edits: Vec<Edit>,
    model: Model,
}

impl BuildingCache {
    pub fn clear(&mut self) {
        self.kept.clear();
    }

    /// Buildings kept.
    pub fn len(&self) -> usize {
        self.kept.len()
    }

    pub fn is_empty(&self) -> bool {
        self.kept.is_empty()
    }
}

/// [`city`], taking the buildings of parcels that are the same (identity,
/// polygon, tags, front, and the system's seed and values) from `cache`
/// instead of growing them, and keeping this growth's buildings there
/// (those of parcels that are gone are dropped). The model is the same,
/// byte for byte, as [`city`]'s (tested); [`City::reused`] counts the
/// buildings taken.
pub fn city_cached(
    layout: &Layout,
    buildings: Option<&Buildings>,
    build: &BuildOptions,
    cache: &mut BuildingCache,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<City, CityError> {
    city_with(layout, buildings, build, None, Some(cache), progress)
}

fn city_with(
    layout: &Layout,
    buildings: Option<&Buildings>,
    build: &BuildOptions,
    edits: Option<&EditsFile>,
    mut cache: Option<&mut BuildingCache>,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<City, CityError> {
    let mut a = Assembler::default();
    let street = a.material(ground_material("layout.street", [0.18, 0.18, 0.2]));
    let parcel = a.material(ground_material("layout.parcel", [0.62, 0.6, 0.55]));
    let open_ground = a.material(ground_material("layout.open", [0.42, 0.55, 0.32]));
    for s in layout.streets.values() {
        let Some(line) = layout.polyline(s) else {
            continue;
        };
        let start = a.start();
        let m = &mut a.model.parts[street].mesh;
        street_mesh(&line, s.width, m);
        a.group(format!("street.{}", s.id), s.id, start);
    }
    for (id, rest) in &layout.rests {
        let start = a.start();
        flat_polygon(&rest.ring, &mut a.model.parts[open_ground].mesh);
        a.group(format!("open.{id}"), *id, start);
    }
    let fronts = buildings.map(|_| Fronts::new(layout));
    let total = layout.parcels.len();
    let mut grown = 0;
    let mut reused = 0;
    let mut issues = Vec::new();
    let mut next: HashMap<Id, Kept> = HashMap::new();
    let by_parcel = edits.map(building_edits::by_parcel).unwrap_or_default();
    let mut edited = 0;
    for (done, p) in layout.parcels.values().enumerate() {
        let start = a.start();
        let unbuilt = p.tags.get(NO_BUILDING) == Some(&TagValue::Bool(false));
        let ground = if unbuilt { open_ground } else { parcel };
        flat_polygon(&p.ring, &mut a.model.parts[ground].mesh);
        if let (Some(b), Some(fronts)) = (buildings.filter(|_| !unbuilt), &fronts) {
            let x_axis = fronts.of(p);
            let mine: &[&Edit] = by_parcel.get(&p.id).map_or(&[], Vec::as_slice);
            let hit = cache
                .as_deref_mut()
                .and_then(|c| c.kept.remove(&p.id))
                .filter(|k| {
                    k.parcel == *p
                        && k.x_axis == x_axis
                        && k.seed == b.seed
                        && k.params == b.params
                        && k.edits.len() == mine.len()
                        && k.edits.iter().zip(mine).all(|(a, e)| a == *e)
                });
            let made = match hit {
                Some(k) => {
                    reused += 1;
                    Ok(k.model)
                }
                None => building_edited(b, p, x_axis, build, mine),
            };
            match made {
                Ok(m) => {
                    a.append(&m);
                    grown += 1;
                    if mine.iter().any(|e| e.system == b.system.name) {
                        edited += 1;
                    }
                    if cache.is_some() {
                        next.insert(
                            p.id,
                            Kept {
                                parcel: p.clone(),
                                x_axis,
                                seed: b.seed,
                                params: b.params.to_vec(),
                                edits: mine.iter().map(|e| (*e).clone()).collect(),
                                model: m,
                            },
                        );
                    }
                }
                Err(error) => issues.push(BuildingIssue {
                    parcel: p.id,
                    error,
                }),
            }
        }
        a.group(format!("parcel.{}", p.id), p.id, start);
        let bytes = a.model.heap_bytes();
        if bytes > build.max_bytes {
            return Err(CityError::MemoryLimit {
                bytes,
                limit: build.max_bytes,
            });
        }
        progress(done + 1, total);
    }
    if let Some(c) = cache {
        c.kept = next;
    }
    // Without buildings nothing is edited, and nothing is reported.
    let edit_issues = match buildings {
        Some(b) => building_edits::unplaced(layout, &by_parcel, &b.system.name),
        None => Vec::new(),
    };
    Ok(City {
        model: a.finish(),
        buildings: grown,
        reused,
        issues,
        edited,
        edit_issues,
    })
}

fn open(ring: &[geo::Coord]) -> Vec<geo::Coord> {
    let mut v: Vec<geo::Coord> = Vec::with_capacity(ring.len());
    for &c in ring {
        if v.last() != Some(&c) {
            v.push(c);
        }
    }
    if v.len() > 1 && v.first() == v.last() {
        v.pop();
    }
    v
}

/// A layout point on the ground, in the model's frame.
fn ground(c: geo::Coord) -> Vec3 {
    Vec3::new(c.x as f32, 0.0, -(c.y as f32))
}

/// A polygon lying on the ground, facing up (ear-clipped).
fn flat_polygon(ring: &[geo::Coord], m: &mut MeshData) {
    let mut vs: Vec<Vec3> = open(ring).into_iter().map(ground).collect();
    if vs.len() < 3 {
        return;
    }
    // Counter-clockwise seen from above, whichever way the ring runs.
    if grm_geom::polygon::newell_normal(&vs).y < 0.0 {
        vs.reverse();
    }
    let up = Vec3::Y;
    let mut tris = Vec::new();
    grm_geom::polygon::triangulate(&vs, up, &mut tris);
    if tris.is_empty() {
        return;
    }
    let first = m.positions.len() as u32;
    for v in &vs {
        m.vertex(*v, up);
    }
    for [a, b, c] in tris {
        m.triangle(first + a, first + b, first + c);
    }
}

/// A street: a quad per segment, its width across, and a square at every
/// corner so bends and ends have no gaps (coplanar, the same material).
fn street_mesh(line: &[geo::Coord], width: f64, m: &mut MeshData) {
    let h = (width / 2.0) as f32;
    let pts: Vec<Vec3> = line.iter().copied().map(ground).collect();
    for w in pts.windows(2) {
        let d = w[1] - w[0];
        let len = d.length();
        if len <= 1e-6 || !len.is_finite() {
            continue;
        }
        let across = Vec3::new(-d.z, 0.0, d.x) / len * h;
        // Counter-clockwise seen from above (+y).
        m.quad(
            [w[0] + across, w[1] + across, w[1] - across, w[0] - across],
            Vec3::Y,
        );
    }
    if pts.len() > 2 {
        for p in &pts[1..pts.len() - 1] {
            let (x, z) = (Vec3::X * h, Vec3::Z * h);
            m.quad([*p - x + z, *p + x + z, *p + x - z, *p - x - z], Vec3::Y);
        }
    }
}

/// Joins models into one: parts by material, each group's triangles
/// contiguous in each part.
#[derive(Default)]
struct Assembler {
    model: Model,
    by_name: HashMap<String, usize>,
    textures: HashMap<(String, std::path::PathBuf), usize>,
}

impl Assembler {
    /// The part drawing `m` (a new one for a new material; a material
    /// named like another but looking different gets a number).
    fn material(&mut self, mut m: ModelMaterial) -> usize {
        if let Some(&p) = self.by_name.get(&m.name) {
            let same = &self.model.materials[self.model.parts[p].material];
            if *same == m {
                return p;
            }
            let mut k = 2;
            while self.by_name.contains_key(&format!("{}.{k}", m.name)) {
                k += 1;
            }
            let name = format!("{}.{k}", m.name);
            m.name = name;
            return self.material(m);
        }
        let name = m.name.clone();
        self.model.materials.push(m);
        self.model.parts.push(Part {
            material: self.model.materials.len() - 1,
            ..Part::default()
        });
        let p = self.model.parts.len() - 1;
        self.by_name.insert(name, p);
        p
    }

    fn texture(&mut self, t: &ModelTexture) -> usize {
        let key = (t.name.clone(), t.path.clone());
        if let Some(&i) = self.textures.get(&key) {
            return i;
        }
        self.model.textures.push(t.clone());
        let i = self.model.textures.len() - 1;
        self.textures.insert(key, i);
        i
    }

    /// Where every part stands now (vertices, triangles).
    fn start(&self) -> Vec<(u32, u32)> {
        self.model
            .parts
            .iter()
            .map(|p| {
                (
                    p.mesh.positions.len() as u32,
                    p.mesh.triangle_count() as u32,
                )
            })
            .collect()
    }

    /// Append a building's parts.
    fn append(&mut self, m: &Model) {
        for part in &m.parts {
            let Some(mat) = m.materials.get(part.material) else {
                continue;
            };
            let mut mat = mat.clone();
            mat.texture = mat
                .texture
                .and_then(|t| m.textures.get(t))
                .map(|t| self.texture(t));
            let p = self.material(mat);
            let to = &mut self.model.parts[p].mesh;
            let first = to.positions.len() as u32;
            // UVs: all or none per part (the ground has none, buildings
            // all): a part that gets some has one for every vertex.
            let uvs = !to.uvs.is_empty() || part.mesh.has_uvs();
            if uvs {
                to.uvs.resize(to.positions.len(), [0.0, 0.0]);
            }
            to.positions.extend_from_slice(&part.mesh.positions);
            to.normals.extend_from_slice(&part.mesh.normals);
            if part.mesh.has_uvs() {
                to.uvs.extend_from_slice(&part.mesh.uvs);
            }
            if uvs {
                to.uvs.resize(to.positions.len(), [0.0, 0.0]);
            }
            to.indices
                .extend(part.mesh.indices.iter().map(|&i| i + first));
        }
    }

    /// The group of what was added since `start`.
    fn group(&mut self, name: String, id: Id, start: Vec<(u32, u32)>) {
        let mut spans = smallvec::SmallVec::new();
        for (k, part) in self.model.parts.iter().enumerate() {
            let (v0, t0) = start.get(k).copied().unwrap_or((0, 0));
            let (v1, t1) = (
                part.mesh.positions.len() as u32,
                part.mesh.triangle_count() as u32,
            );
            if t1 > t0 {
                spans.push(GroupSpan {
                    part: k,
                    first_vertex: v0,
                    vertex_count: v1 - v0,
                    first_triangle: t0,
                    triangle_count: t1 - t0,
                });
            }
        }
        if spans.is_empty() {
            return;
        }
        let node = self.model.groups.len() as u32;
        self.model.groups.push(ShapeGroup {
            name,
            node,
            key: (id.0 ^ (id.0 >> 32)) as u32,
            exact: String::new(),
            semantic: String::new(),
            spans,
        });
    }

    fn finish(mut self) -> Model {
        // A part for a UV-less ground part joined by a building after
        // some of its own vertices: fill to one UV per vertex.
        for p in &mut self.model.parts {
            if !p.mesh.uvs.is_empty() {
                p.mesh.uvs.resize(p.mesh.positions.len(), [0.0, 0.0]);
            }
        }
        let mut bounds = Aabb::EMPTY;
        let (mut vertices, mut triangles) = (0, 0);
        for p in &self.model.parts {
            for q in &p.mesh.positions {
                bounds.add(Vec3::from_array(*q));
            }
            vertices += p.mesh.positions.len();
            triangles += p.mesh.triangle_count();
        }
        let s = &mut self.model.stats;
        s.vertices = vertices;
        s.triangles = triangles;
        s.parts = self
            .model
            .parts
            .iter()
            .filter(|p| !p.mesh.is_empty())
            .count();
        s.bounds = bounds;
        self.model.declared_materials = self.model.materials.clone();
        self.model
    }
}

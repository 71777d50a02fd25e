//! `grm-geom`: meshes from the turtle's output, and export.
//!
//! Role: the last stage of the pipeline. [`build_model`] interprets a
//! derived [`ModuleString`] with `grm-turtle` and turns the result into
//! triangle meshes: generalized cylinders along the bones ([`tube`]), the
//! primitives (`cylinder cone sphere box disc`, [`mesh`]), OBJ meshes
//! declared in the program ([`import`], read once each and instanced) and
//! the `{ . }` polygons ([`polygon`]). [`export()`] writes the model as
//! glTF 2.0 binary (`.glb`), OBJ + MTL, PLY or SVG ([`mod@export`]), or
//! draws it as a PNG picture with a software rasterizer ([`render`]).
//!
//! Inputs: the checked [`grm_sema::Program`] and one of its systems, the
//! system's [`Settings`], the module string, and the meta-parameter values
//! of the run (material properties may depend on them).
//!
//! Outputs: a [`Model`]: one [`Part`] (an indexed triangle mesh) per
//! material or colour, the [`ModelMaterial`]s, the skeleton (the whole
//! [`Interpretation`]: bones, instances, polygons), per-part [`Pick`]
//! ranges saying which bone, instance or polygon (and so which module and
//! production) made each triangle, and [`Stats`].
//!
//! Invariants: parts and their picks come in a deterministic order (tubes
//! in bone order, then instances, then polygons); every index is in range,
//! every normal unit length and every coordinate finite (anything that
//! would not be is dropped and counted in [`Stats::dropped`]); errors
//! (a missing or malformed OBJ file, an id the program does not have) are
//! typed and leave no partial model.

pub mod budget;
pub mod export;
pub mod import;
pub mod mesh;
pub mod parts;
pub mod polygon;
pub mod render;
pub mod shape;
pub mod tube;

use std::collections::HashMap;
use std::path::PathBuf;

use glam::Vec3;
use grm_derive::ModuleString;
use grm_diag::{Code, Diagnostic, FileId, Span};
use grm_sema::{MaterialProp, Program, Settings, System, Value};
use grm_turtle::{Aabb, InstanceKind, Interpretation, Paint, TurtleError};

pub use budget::{DEFAULT_MAX_BYTES, Footprint, Output};
pub use export::{
    ExportError, ExportFormat, export, export_as, export_image, write_atomic, write_image,
};
pub use grm_turtle;
pub use mesh::MeshData;

/// Mesh building settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BuildOptions {
    /// Sides of a bone's tube ring (at least 3).
    pub tube_sides: u32,
    /// Segments around cylinders, cones, discs and spheres (at least 3).
    pub segments: u32,
    /// The most bytes building the model may need, with `held` and what
    /// `output` needs to write it ([`budget`]); past it the build stops
    /// with [`GeomError::MemoryLimit`] before the meshes are made.
    /// Default [`DEFAULT_MAX_BYTES`] (2 GiB).
    pub max_bytes: u64,
    /// Bytes the caller holds while the model is built and written (e.g.
    /// the module string), counted against `max_bytes`.
    pub held: u64,
    /// What the model is built for ([`Output::Model`]: held).
    pub output: Output,
    /// Shape mode: give each terminal shape group its name and locators
    /// (`shape::ShapeGroup::{name, exact, semantic}`, what an export
    /// writes). Default true; the preview, which draws the triangles and
    /// finds a picked shape's locators in the tree, turns it off (the text
    /// of 10,000 windows' locators is most of a building's model).
    pub group_names: bool,
    /// Shape mode: threads building the meshes (1: the calling thread's
    /// alone, the default; 0: the machine's parallelism). A model whose
    /// size the tree predicts (boxes and rectangles only, well within
    /// `max_bytes`) is built in halves on two threads and joined; the
    /// model is the same as one thread's, byte for byte.
    pub threads: usize,
}

impl Default for BuildOptions {
    fn default() -> Self {
        BuildOptions {
            tube_sides: 8,
            segments: 16,
            max_bytes: DEFAULT_MAX_BYTES,
            held: 0,
            output: Output::Model,
            group_names: true,
            threads: 1,
        }
    }
}

impl BuildOptions {
    /// Default mesh settings with a memory limit of `max_bytes` for a
    /// model built for `output`.
    pub fn limited(max_bytes: u64, output: Output) -> BuildOptions {
        BuildOptions {
            max_bytes,
            output,
            ..BuildOptions::default()
        }
    }
}

/// A material of the model: a declared material, a palette colour or an
/// explicit colour.
#[derive(Clone, Debug, PartialEq)]
pub struct ModelMaterial {
    /// Unique in the model; no spaces (safe for OBJ/MTL).
    pub name: String,
    /// Linear RGB base colour in [0, 1].
    pub color: [f32; 3],
    pub roughness: f32,
    pub metallic: f32,
    pub emissive: [f32; 3],
    /// 1 = opaque.
    pub opacity: f32,
    /// A base-colour texture: an index into [`Model::textures`] (shape
    /// mode's `texture(name)`), multiplied by `color`.
    pub texture: Option<usize>,
}

/// An image a material maps by the mesh's UV coordinates: the file's bytes
/// (PNG or JPEG), embedded in a glb and named by path in an MTL.
#[derive(Clone, Debug, PartialEq)]
pub struct ModelTexture {
    /// The texture's name in the program.
    pub name: String,
    /// The file it was read from.
    pub path: PathBuf,
    /// `image/png` or `image/jpeg`.
    pub mime: &'static str,
    pub bytes: std::sync::Arc<[u8]>,
}

/// What made a run of triangles.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PartSource {
    /// A bone's tube (index into the skeleton's bones).
    Bone(u32),
    /// A primitive or mesh (index into the skeleton's instances).
    Instance(u32),
    /// A polygon (index into the skeleton's polygons).
    Polygon(u32),
    /// A node of a shape-grammar derivation tree (index into
    /// `grm_shape::ShapeTree::nodes`: a terminal shape or an insert;
    /// [`shape`]).
    Shape(u32),
}

/// Triangles `first_triangle .. first_triangle + triangle_count` of a part
/// were made by `source`, from module `module` of the string (made by
/// production `origin`, see [`Model::fill_origins`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Pick {
    pub first_triangle: u32,
    pub triangle_count: u32,
    pub source: PartSource,
    pub module: u32,
    pub origin: u32,
}

/// The geometry of one material.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Part {
    /// Index into [`Model::materials`].
    pub material: usize,
    pub mesh: MeshData,
    /// Sorted by `first_triangle`, not overlapping.
    pub picks: Vec<Pick>,
}

/// Counts and bounds.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Stats {
    pub vertices: usize,
    pub triangles: usize,
    pub bones: usize,
    pub instances: usize,
    pub polygons: usize,
    pub parts: usize,
    /// Bounds of the meshes and the skeleton.
    pub bounds: Aabb,
    /// Instances with a singular or non-finite transform and degenerate
    /// polygons, skipped.
    pub dropped: usize,
    /// Bones without a tube: zero width, zero length or not finite (an SVG
    /// export still draws the finite ones as lines).
    pub bare_bones: usize,
}

/// A built model.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Model {
    /// The turtle's output: bones (the skeleton), instances, polygons.
    pub skeleton: Interpretation,
    /// The materials of the parts.
    pub materials: Vec<ModelMaterial>,
    /// Every material the program declares, evaluated (index =
    /// [`grm_sema::MaterialId`]), whether used or not.
    pub declared_materials: Vec<ModelMaterial>,
    pub parts: Vec<Part>,
    pub stats: Stats,
    /// Per module of the string it was built from: the module's identity
    /// key (`grm_derive::ModuleString::keys`); empty when the string
    /// carried none. Exports name parts by it ([`parts`]).
    pub module_keys: Vec<u32>,
    /// Shape mode ([`shape`]): the terminal shape groups, each exported
    /// as a named glTF node (an OBJ object) with its locators; empty for
    /// models built from a string.
    pub groups: Vec<shape::ShapeGroup>,
    /// The images the materials map ([`ModelMaterial::texture`]).
    pub textures: Vec<ModelTexture>,
    /// What the builder counted before building it ([`budget`]): the
    /// most vertices and triangles, and the bytes building it (and writing
    /// it as its `BuildOptions::output` says) needs.
    pub footprint: Footprint,
}

impl Model {
    /// The base colour a paint stands for.
    pub fn paint_color(&self, paint: Paint) -> [f32; 3] {
        match paint {
            Paint::Palette(i) => Paint::palette_color(i),
            Paint::Rgb(c) => c,
            Paint::Material(m) => self
                .declared_materials
                .get(m.index())
                .map_or([0.8; 3], |m| m.color),
        }
    }

    /// The bytes the model holds on the heap: its interpretation, meshes,
    /// picks and keys (capacities).
    pub fn heap_bytes(&self) -> u64 {
        let parts: u64 = self
            .parts
            .iter()
            .map(|p| {
                budget::VERTEX_BYTES / 2
                    * (p.mesh.positions.capacity() + p.mesh.normals.capacity()) as u64
                    + 8 * p.mesh.uvs.capacity() as u64
                    + 4 * p.mesh.indices.capacity() as u64
                    + (p.picks.capacity() * std::mem::size_of::<Pick>()) as u64
            })
            .sum();
        budget::interpretation_heap(&self.skeleton) + parts + 4 * self.module_keys.capacity() as u64
    }

    pub fn bones(&self) -> &[grm_turtle::Bone] {
        &self.skeleton.bones
    }

    /// What the model lacks that its string asked for, as warnings on
    /// `span` of `file` (the system's name): no triangles at all (W0013),
    /// or instances and polygons the builder had to leave out (W0014).
    /// `grmc` prints them before it writes a mesh format; a format that
    /// draws lines (SVG) is told by `lines`, where bones need no width.
    pub fn warnings(&self, file: FileId, span: Span, lines: bool) -> Vec<Diagnostic> {
        let s = &self.stats;
        let count =
            |n: usize, one: &str, many: &str| format!("{n} {}", if n == 1 { one } else { many });
        let dropped_note = |n: usize| {
            format!(
                "{} left out: an instance whose transform is singular or not finite (e.g. after `scale(0)`), or a polygon with fewer than three distinct vertices or all of them on one line, has no triangles",
                count(n, "shape was", "shapes were")
            )
        };
        // An SVG draws every bone as a line, with or without a width.
        if s.triangles == 0 && !(lines && s.bones > 0) {
            let mut d = Diagnostic::new(
                Code::EmptyModel,
                "the model has no triangles",
                file,
                span,
                "this system's string draws nothing",
            );
            if s.bare_bones > 0 {
                d = d
                    .with_note(format!(
                        "{} no tube: zero width, zero length or a position that is not finite",
                        count(s.bare_bones, "bone has", "bones have"),
                    ))
                    .with_help(
                        "give the bones a width (the `width` setting or `!(w)`) and a length (`F(len)`), or export to .svg to draw them as lines",
                    );
            }
            if s.dropped > 0 {
                d = d.with_note(dropped_note(s.dropped));
            }
            if s.bones + s.instances + s.polygons == 0 {
                d = d.with_help(
                    "no module of the string draws: `F` draws a bone, `sphere(r)`, `mesh(m)` and `{ . . . }` draw shapes",
                );
            }
            return vec![d];
        }
        if s.dropped == 0 {
            return Vec::new();
        }
        vec![
            Diagnostic::new(
                Code::GeometryDropped,
                format!(
                    "{} left out of the model",
                    count(s.dropped, "shape", "shapes")
                ),
                file,
                span,
                "in this system's model",
            )
            .with_note(dropped_note(s.dropped)),
        ]
    }

    /// What made triangle `triangle` of part `part`.
    pub fn pick(&self, part: usize, triangle: u32) -> Option<&Pick> {
        let picks = &self.parts.get(part)?.picks;
        let i = picks.partition_point(|p| p.first_triangle <= triangle);
        let p = picks.get(i.checked_sub(1)?)?;
        (triangle < p.first_triangle + p.triangle_count).then_some(p)
    }

    /// Set the `origin` of every bone, instance, polygon and pick from a
    /// per-module side table (`origins[module]`, e.g. the production that
    /// made each module); modules past its end get [`grm_turtle::NO_ORIGIN`].
    pub fn fill_origins(&mut self, origins: &[u32]) {
        self.skeleton.fill_origins(origins);
        for part in &mut self.parts {
            for p in &mut part.picks {
                p.origin = origins
                    .get(p.module as usize)
                    .copied()
                    .unwrap_or(grm_turtle::NO_ORIGIN);
            }
        }
    }
}

/// Why a model could not be built.
#[derive(Debug)]
pub enum GeomError {
    /// The string could not be interpreted.
    Turtle(TurtleError),
    /// `mesh(id)` with an id the program does not declare.
    UnknownMesh { id: u32, module: u32 },
    /// `material(id)` with an id the program does not declare.
    UnknownMaterial { id: u32, module: u32 },
    /// A declared mesh's file could not be read.
    MeshMissing {
        mesh: String,
        path: PathBuf,
        message: String,
    },
    /// A declared mesh's file is not a usable OBJ file.
    MeshMalformed {
        mesh: String,
        path: PathBuf,
        message: String,
    },
    /// Meta-parameter values that do not fit the program (wrong count or
    /// type): a caller's mistake, never the user's.
    Params(String),
    /// Building the model (and writing it as `output` says) would need
    /// `footprint.bytes`, more than `limit` ([`BuildOptions::max_bytes`]);
    /// nothing was built. R0202, as a derivation over its memory limit.
    MemoryLimit {
        footprint: Footprint,
        limit: u64,
        output: Output,
    },
    /// Shape mode: a material, insert asset or texture name of the shape
    /// program that the [`shape::ShapeAssets`] do not resolve (`what`:
    /// `material`, `asset` or `texture`).
    UnknownShapeName { what: &'static str, name: String },
    /// Shape mode: a texture's image could not be read, or is not a PNG
    /// or JPEG file.
    TextureUnreadable {
        texture: String,
        path: PathBuf,
        message: String,
    },
}

impl std::fmt::Display for GeomError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            GeomError::Turtle(e) => write!(f, "{e}"),
            GeomError::UnknownMesh { id, module } => {
                write!(
                    f,
                    "module {module} draws mesh #{id}, which the program does not declare"
                )
            }
            GeomError::UnknownMaterial { id, module } => write!(
                f,
                "module {module} uses material #{id}, which the program does not declare"
            ),
            GeomError::MeshMissing {
                mesh,
                path,
                message,
            } => write!(
                f,
                "cannot read mesh `{mesh}` from {}: {message}",
                path.display()
            ),
            GeomError::MeshMalformed {
                mesh,
                path,
                message,
            } => write!(
                f,
                "mesh `{mesh}` in {} is not a valid OBJ file: {message}",
                path.display()
            ),
            GeomError::Params(m) => write!(f, "meta-parameter values do not fit: {m}"),
            GeomError::MemoryLimit {
                footprint,
                limit,
                output,
            } => write!(f, "{}", footprint.message(*limit, *output)),
            GeomError::UnknownShapeName { what, name } => {
                write!(
                    f,
                    "the shape grammar uses {what} `{name}`, which is not declared"
                )
            }
            GeomError::TextureUnreadable {
                texture,
                path,
                message,
            } => write!(
                f,
                "cannot read texture `{texture}` from {}: {message}",
                path.display()
            ),
        }
    }
}

impl GeomError {
    /// The stable code: `R04xx`.
    pub fn code(&self) -> Code {
        match self {
            GeomError::Turtle(_) => Code::InterpretString,
            GeomError::UnknownMesh { .. } => Code::UnknownMeshId,
            GeomError::UnknownMaterial { .. } => Code::UnknownMaterialId,
            GeomError::MeshMissing { .. } => Code::MeshUnreadable,
            GeomError::MeshMalformed { .. } => Code::MeshMalformed,
            GeomError::Params(_) => Code::ParamValues,
            GeomError::MemoryLimit { .. } => Code::MemoryLimit,
            GeomError::UnknownShapeName {
                what: "material", ..
            } => Code::UnknownMaterialId,
            GeomError::UnknownShapeName { .. } => Code::UnknownMeshId,
            GeomError::TextureUnreadable { .. } => Code::MeshUnreadable,
        }
    }

    /// The error as a diagnostic. A mesh file's problem points at the
    /// mesh's declaration in `program` and names the file as written there;
    /// the others point at `file`/`span`, the system whose model was being
    /// built.
    pub fn to_diagnostic(&self, program: &Program, file: FileId, span: Span) -> Diagnostic {
        let (mesh, message, help) = match self {
            GeomError::MemoryLimit { .. } => {
                return Diagnostic::new(
                    self.code(),
                    self.to_string(),
                    file,
                    span,
                    "while building the model of this system",
                )
                .with_help(MEMORY_HELP);
            }
            GeomError::UnknownShapeName { .. } | GeomError::TextureUnreadable { .. } => {
                let help = match self {
                    GeomError::TextureUnreadable { .. } => {
                        "a texture names a PNG or JPEG image; make the file readable and run again"
                    }
                    _ => {
                        "declare it (`material NAME { ... }`, `mesh NAME = \"file.obj\";`) or use one of the primitives box, cylinder, cone, sphere, disc"
                    }
                };
                return Diagnostic::new(
                    self.code(),
                    self.to_string(),
                    file,
                    span,
                    "while building the model of this system",
                )
                .with_help(help);
            }
            GeomError::MeshMissing { mesh, message, .. } => (mesh, message, MESH_MISSING_HELP),
            GeomError::MeshMalformed { mesh, message, .. } => (mesh, message, MESH_MALFORMED_HELP),
            GeomError::Turtle(_)
            | GeomError::UnknownMesh { .. }
            | GeomError::UnknownMaterial { .. }
            | GeomError::Params(_) => {
                let label = "while building the model of this system";
                return Diagnostic::new(self.code(), self.to_string(), file, span, label)
                    .with_help(INTERNAL_HELP);
            }
        };
        let Some(m) = program.meshes.iter().find(|m| &m.name == mesh) else {
            return Diagnostic::new(self.code(), self.to_string(), file, span, "in this model")
                .with_help(help);
        };
        let text = match self {
            GeomError::MeshMissing { .. } => {
                format!(
                    "cannot read mesh `{mesh}` from \"{}\": {message}",
                    m.written
                )
            }
            _ => format!(
                "mesh `{mesh}` in \"{}\" is not a valid OBJ file: {message}",
                m.written
            ),
        };
        Diagnostic::new(
            self.code(),
            text,
            m.loc.file,
            m.loc.span,
            "this mesh's file",
        )
        .with_help(help)
    }
}

const MESH_MISSING_HELP: &str = "mesh paths are relative to the directory of the file that \
     declares them; make the file readable and run again";
const MESH_MALFORMED_HELP: &str =
    "save the mesh as an OBJ file of triangles or polygons with at least one face";
const MEMORY_HELP: &str = "derive fewer iterations (`-n`) or plant fewer trees, draw \
     fewer bones (a coarser grammar), or raise the limit (`--max-memory MIB`)";
const INTERNAL_HELP: &str =
    "this is an internal error of grm; please report it with the file that caused it";

impl std::error::Error for GeomError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            GeomError::Turtle(e) => Some(e),
            _ => None,
        }
    }
}

impl From<TurtleError> for GeomError {
    fn from(e: TurtleError) -> Self {
        GeomError::Turtle(e)
    }
}

/// The materials `program` declares, evaluated with the meta-parameter
/// values `params` (as [`build_model`] evaluates them), in declaration
/// order: what a shape-mode model's `material(name)` resolves to
/// ([`shape::ShapeAssets::from_program`]).
pub fn declared_materials(
    program: &Program,
    params: &[Value],
) -> Result<Vec<ModelMaterial>, GeomError> {
    Ok(Builder::new(program, &BuildOptions::default(), params)?.declared)
}

/// Interpret `string` (a string of `system`) and build its meshes, within
/// the default memory limit ([`DEFAULT_MAX_BYTES`], the string counted).
/// `params` are the meta-parameter values of the run, by
/// [`grm_sema::ParamId`] (`CompiledSystem::param_values`, or
/// [`Program::default_params`]): declared materials are evaluated with them.
pub fn build_model(
    program: &Program,
    system: &System,
    string: &ModuleString,
    settings: &Settings,
    params: &[Value],
) -> Result<Model, GeomError> {
    build_model_with(
        program,
        system,
        string,
        settings,
        params,
        &BuildOptions::default(),
    )
}

/// [`build_model`] with `options`: the string's bytes are counted with
/// `options.held`, and what its interpretation can hold is checked
/// against `options.max_bytes` before it is interpreted ([`budget`]).
pub fn build_model_with(
    program: &Program,
    system: &System,
    string: &ModuleString,
    settings: &Settings,
    params: &[Value],
    options: &BuildOptions,
) -> Result<Model, GeomError> {
    build_model_drawn(program, system, string, settings, params, options, None)
}

/// [`build_model_with`], meshing only the bones, instances and polygons
/// whose module (of `string`) `drawn` keeps (`None`: all): focus and
/// context in derive mode, where the rest of the skeleton stays in the
/// model's [`Model::skeleton`] (an editor draws it as lines). A kept
/// bone whose parent is not kept starts its own tube.
pub fn build_model_drawn(
    program: &Program,
    system: &System,
    string: &ModuleString,
    settings: &Settings,
    params: &[Value],
    options: &BuildOptions,
    drawn: Option<&dyn Fn(u32) -> bool>,
) -> Result<Model, GeomError> {
    // The string, held throughout, and the model's copy of its keys.
    let held = options
        .held
        .saturating_add(budget::BASELINE_BYTES)
        .saturating_add(string.heap_bytes() as u64)
        .saturating_add(4 * string.keys().len() as u64);
    let mut pre = budget::count_string(system, string);
    pre.bytes = pre.bytes.saturating_add(held);
    if pre.bytes > options.max_bytes {
        return Err(GeomError::MemoryLimit {
            footprint: pre,
            limit: options.max_bytes,
            output: options.output,
        });
    }
    let mut it = grm_turtle::Interpreter::new(system, settings);
    {
        // At most this much: reserved, the arrays never grow by doubling.
        let out = &mut it.collector.out;
        out.bones.reserve_exact(pre.bones as usize);
        out.instances.reserve_exact(pre.instances as usize);
        out.polygons.reserve_exact(pre.polygons as usize);
        out.polygon_vertices
            .reserve_exact(pre.polygon_vertices as usize);
    }
    it.run(string)?;
    let skeleton = it.finish();
    // The baseline is counted again by the interpretation's build.
    let held = held - budget::BASELINE_BYTES;
    let options = BuildOptions { held, ..*options };
    let mut model = build_interpretation(program, skeleton, &options, params, drawn)?;
    model.module_keys = string.keys().to_vec();
    Ok(model)
}

/// Build the meshes of an interpretation made elsewhere (e.g. by the
/// guided sampler, expansion by expansion); `params` as for
/// [`build_model`]. The model's size is counted from the interpretation
/// first and checked against `options.max_bytes` ([`budget`]); the
/// meshes are then made in buffers of exactly that size.
pub fn build_from_interpretation(
    program: &Program,
    skeleton: Interpretation,
    options: &BuildOptions,
    params: &[Value],
) -> Result<Model, GeomError> {
    build_interpretation(program, skeleton, options, params, None)
}

/// [`build_from_interpretation`], meshing what `drawn` keeps
/// ([`build_model_drawn`]).
fn build_interpretation(
    program: &Program,
    skeleton: Interpretation,
    options: &BuildOptions,
    params: &[Value],
    drawn: Option<&dyn Fn(u32) -> bool>,
) -> Result<Model, GeomError> {
    let keep = |module: u32| drawn.is_none_or(|d| d(module));
    let mut builder = Builder::new(program, options, params)?;
    let too_large = |footprint: Footprint| GeomError::MemoryLimit {
        footprint,
        limit: options.max_bytes,
        output: options.output,
    };
    let mut f = Footprint {
        bones: skeleton.bones.len() as u64,
        instances: skeleton.instances.len() as u64,
        polygons: skeleton.polygons.len() as u64,
        polygon_vertices: skeleton.polygon_vertices.len() as u64,
        ..Footprint::default()
    };
    // The interpretation and the builder's tables, before they are made.
    f.bytes = options
        .held
        .saturating_add(budget::BASELINE_BYTES)
        .saturating_add(budget::interpretation_heap(&skeleton))
        .saturating_add(f.bones.saturating_mul(budget::PLAN_BYTES_PER_BONE));
    if f.bytes > options.max_bytes {
        return Err(too_large(f));
    }
    // Check ids and load every mesh used, once, before building anything.
    let mut meshes: Vec<Option<MeshData>> = vec![None; program.meshes.len()];
    for inst in &skeleton.instances {
        if let InstanceKind::Mesh(id) = inst.kind {
            let Some(decl) = program.meshes.get(id.index()) else {
                return Err(GeomError::UnknownMesh {
                    id: id.0,
                    module: inst.module,
                });
            };
            if meshes[id.index()].is_none() {
                let m = import::load_obj(&decl.name, &decl.path)?;
                f.bytes = f.bytes.saturating_add(
                    m.vertex_count() as u64 * budget::VERTEX_BYTES
                        + m.triangle_count() as u64 * budget::TRIANGLE_BYTES,
                );
                meshes[id.index()] = Some(m);
            }
        }
    }
    builder.check_paints(&skeleton)?;
    let mut plan = tube::TubePlan::new(&skeleton.bones);
    if drawn.is_some() {
        // A tube is cut where its bone or the bone it continues is not
        // drawn: each side gets its cap.
        for (i, bone) in skeleton.bones.iter().enumerate() {
            let Some(p) = bone.parent.map(|p| p as usize) else {
                continue;
            };
            if plan.continues[i]
                && !(keep(bone.module) && skeleton.bones.get(p).is_some_and(|pb| keep(pb.module)))
            {
                plan.continues[i] = false;
                if plan.next.get(p) == Some(&Some(i as u32)) {
                    plan.next[p] = None;
                }
            }
        }
    }
    let unit = UnitShapes::new(options.segments);
    let circle = tube::circle(options.tube_sides);

    // Count every part's vertices, triangles and picks (the parts are made
    // here, in the order the loops below use them), check, and reserve.
    let mut sizes: Vec<(u64, u64, u64)> = Vec::new();
    let add = |sizes: &mut Vec<(u64, u64, u64)>, part: usize, v: u64, t: u64| {
        if sizes.len() <= part {
            sizes.resize(part + 1, (0, 0, 0));
        }
        let s = &mut sizes[part];
        *s = (s.0 + v, s.1 + t, s.2 + u64::from(t > 0));
    };
    for (i, bone) in skeleton.bones.iter().enumerate() {
        if plan.dir[i].is_none() || !keep(bone.module) {
            continue;
        }
        let part = builder.part(bone.paint);
        // A parent with a tube of its own (drawn, not bare) shares its tip ring.
        let shared = plan.continues[i]
            && bone.parent.is_some_and(|p| {
                skeleton.bones.get(p as usize).is_some_and(|pb| {
                    PaintKey::of(pb.paint) == PaintKey::of(bone.paint)
                        && plan.dir[p as usize].is_some()
                        && keep(pb.module)
                })
            });
        let (v, t) = tube::bone_size(&plan, i, circle.len() as u64, shared);
        add(&mut sizes, part, v, t);
    }
    for inst in &skeleton.instances {
        if !keep(inst.module) {
            continue;
        }
        let Some(shape) = unit.of(inst.kind, &meshes) else {
            continue;
        };
        let part = builder.part(inst.paint);
        let (v, t) = (shape.vertex_count() as u64, shape.triangle_count() as u64);
        add(&mut sizes, part, v, t);
    }
    for poly in &skeleton.polygons {
        if !keep(poly.module) {
            continue;
        }
        let part = builder.part(poly.paint);
        let n = u64::from(poly.len);
        if n >= 3 {
            add(&mut sizes, part, 2 * n, 2 * (n - 2));
        }
    }
    for &(v, t, p) in &sizes {
        f.vertices += v;
        f.triangles += t;
        f.picks += p;
    }
    f.bytes = f
        .bytes
        .saturating_add(f.vertices.saturating_mul(budget::VERTEX_BYTES))
        .saturating_add(f.triangles.saturating_mul(budget::TRIANGLE_BYTES))
        .saturating_add(f.picks.saturating_mul(std::mem::size_of::<Pick>() as u64))
        .saturating_add(budget::output_bytes(
            &f,
            options.output,
            builder.materials.iter().any(|m| m.opacity < 1.0),
        ));
    if f.bytes > options.max_bytes {
        return Err(too_large(f));
    }
    for (part, &(v, t, p)) in builder.parts.iter_mut().zip(&sizes) {
        part.mesh.positions.reserve_exact(v as usize);
        part.mesh.normals.reserve_exact(v as usize);
        part.mesh.indices.reserve_exact(3 * t as usize);
        part.picks.reserve_exact(p as usize);
    }
    builder.footprint = f;

    // Tubes.
    let mut tip_rings: Vec<Option<(usize, u32)>> = vec![None; skeleton.bones.len()];
    let mut scratch = Vec::with_capacity(circle.len());
    for (i, bone) in skeleton.bones.iter().enumerate() {
        if plan.dir[i].is_none() {
            builder.bare_bones += 1;
            continue;
        }
        if !keep(bone.module) {
            continue;
        }
        let part = builder.part(bone.paint);
        let shared = if plan.continues[i] {
            bone.parent
                .and_then(|p| tip_rings[p as usize])
                .and_then(|(pp, first)| (pp == part).then_some(first))
        } else {
            None
        };
        let before = builder.parts[part].mesh.triangle_count();
        let m = &mut builder.parts[part].mesh;
        if let Some(first) =
            tube::emit_bone(&plan, &skeleton.bones, i, &circle, shared, m, &mut scratch)
        {
            tip_rings[i] = Some((part, first));
        }
        builder.pick(
            part,
            before,
            PartSource::Bone(i as u32),
            bone.module,
            bone.origin,
        );
    }
    drop(tip_rings);
    drop(plan);
    // Every part holds only tubes so far.
    for part in &mut builder.parts {
        tube::finish_normals(&mut part.mesh);
    }

    // Instances.
    for (i, inst) in skeleton.instances.iter().enumerate() {
        if !keep(inst.module) {
            continue;
        }
        // Loaded above for every mesh instance.
        let Some(shape) = unit.of(inst.kind, &meshes) else {
            continue;
        };
        let part = builder.part(inst.paint);
        let before = builder.parts[part].mesh.triangle_count();
        if builder.parts[part]
            .mesh
            .append_transformed(shape, &inst.transform)
        {
            builder.pick(
                part,
                before,
                PartSource::Instance(i as u32),
                inst.module,
                inst.origin,
            );
        } else {
            builder.dropped += 1;
        }
    }

    // Polygons.
    let mut tris = Vec::new();
    for (i, poly) in skeleton.polygons.iter().enumerate() {
        if !keep(poly.module) {
            continue;
        }
        let vs = skeleton.vertices(poly);
        let part = builder.part(poly.paint);
        let before = builder.parts[part].mesh.triangle_count();
        if polygon::emit_polygon(vs, &mut builder.parts[part].mesh, &mut tris) {
            builder.pick(
                part,
                before,
                PartSource::Polygon(i as u32),
                poly.module,
                poly.origin,
            );
        } else {
            builder.dropped += 1;
        }
    }

    Ok(builder.finish(skeleton))
}

/// The unit primitives, built once per model.
struct UnitShapes {
    cylinder: MeshData,
    cone: MeshData,
    sphere: MeshData,
    cube: MeshData,
    disc: MeshData,
}

impl UnitShapes {
    fn new(segments: u32) -> UnitShapes {
        UnitShapes {
            cylinder: mesh::unit_cylinder(segments),
            cone: mesh::unit_cone(segments),
            sphere: mesh::unit_sphere(segments),
            cube: mesh::unit_box(),
            disc: mesh::unit_disc(segments),
        }
    }

    /// The mesh an instance of `kind` draws (a mesh instance's from
    /// `meshes`, `None` where it was not loaded).
    fn of<'a>(
        &'a self,
        kind: InstanceKind,
        meshes: &'a [Option<MeshData>],
    ) -> Option<&'a MeshData> {
        Some(match kind {
            InstanceKind::Cylinder => &self.cylinder,
            InstanceKind::Cone => &self.cone,
            InstanceKind::Sphere => &self.sphere,
            InstanceKind::Box => &self.cube,
            InstanceKind::Disc => &self.disc,
            InstanceKind::Mesh(id) => meshes.get(id.index())?.as_ref()?,
        })
    }
}

/// Paints that share a material.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum PaintKey {
    Palette(u32),
    /// Quantised to 8 bits per channel.
    Rgb([u8; 3]),
    Material(u32),
}

pub(crate) fn to_u8(x: f32) -> u8 {
    (x.clamp(0.0, 1.0) * 255.0).round() as u8
}

impl PaintKey {
    fn of(p: Paint) -> PaintKey {
        match p {
            Paint::Palette(i) => PaintKey::Palette(i % grm_turtle::PALETTE.len() as u32),
            Paint::Rgb(c) => PaintKey::Rgb(c.map(to_u8)),
            Paint::Material(m) => PaintKey::Material(m.0),
        }
    }
}

struct Builder<'a> {
    program: &'a Program,
    /// Meta-parameter values of the run and the constants' values with
    /// them, for material fields that depend on meta-parameters.
    params: Vec<Value>,
    globals: Vec<Value>,
    declared: Vec<ModelMaterial>,
    materials: Vec<ModelMaterial>,
    parts: Vec<Part>,
    by_key: HashMap<PaintKey, usize>,
    dropped: usize,
    bare_bones: usize,
    footprint: Footprint,
}

impl<'a> Builder<'a> {
    fn new(
        program: &'a Program,
        _options: &BuildOptions,
        params: &[Value],
    ) -> Result<Builder<'a>, GeomError> {
        if params.len() != program.params.len() {
            return Err(GeomError::Params(format!(
                "{} values given for {} meta-parameters",
                params.len(),
                program.params.len()
            )));
        }
        if let Some((p, v)) = program
            .params
            .iter()
            .zip(params)
            .find(|(p, v)| p.ty != v.ty())
        {
            return Err(GeomError::Params(format!(
                "`{}` is `{}`, the value given is `{}`",
                p.name,
                p.ty,
                v.ty()
            )));
        }
        let globals = program
            .global_values(params)
            .map_err(|e| GeomError::Params(e.to_string()))?;
        let mut b = Builder {
            program,
            params: params.to_vec(),
            globals,
            declared: Vec::new(),
            materials: Vec::new(),
            parts: Vec::new(),
            by_key: HashMap::new(),
            dropped: 0,
            bare_bones: 0,
            footprint: Footprint::default(),
        };
        b.declared = program.materials.iter().map(|m| b.evaluate(m)).collect();
        Ok(b)
    }

    /// A declared material with the run's values: each property clamped to
    /// 0..1 (the checker warns, W0010); an unset or NaN one (the checker
    /// rejects a NaN with the defaults, E0212, but other meta-parameter
    /// values may still make one) takes the default material's value.
    fn evaluate(&self, decl: &grm_sema::Material) -> ModelMaterial {
        let vec3 = |p| {
            decl.get(p)
                .and_then(|e| self.eval(e))
                .and_then(|v| v.as_vec3())
                .filter(|v| v.iter().all(|x| !x.is_nan()))
                .map(|v| v.map(|x| (x as f32).clamp(0.0, 1.0)))
        };
        let float = |p| {
            decl.get(p)
                .and_then(|e| self.eval(e))
                .and_then(|v| v.as_float())
                .filter(|x| !x.is_nan())
                .map(|x| (x as f32).clamp(0.0, 1.0))
        };
        let d = ModelMaterial::default();
        ModelMaterial {
            name: sanitize(&decl.name),
            color: vec3(MaterialProp::Color).unwrap_or(d.color),
            roughness: float(MaterialProp::Roughness).unwrap_or(d.roughness),
            metallic: float(MaterialProp::Metallic).unwrap_or(d.metallic),
            emissive: vec3(MaterialProp::Emissive).unwrap_or(d.emissive),
            opacity: float(MaterialProp::Opacity).unwrap_or(d.opacity),
            texture: None,
        }
    }

    /// Every `material(m)` must name a declared material.
    fn check_paints(&self, s: &Interpretation) -> Result<(), GeomError> {
        let n = self.program.materials.len() as u32;
        let bad = |p: Paint, module: u32| match p {
            Paint::Material(m) if m.0 >= n => Err(GeomError::UnknownMaterial { id: m.0, module }),
            _ => Ok(()),
        };
        for b in &s.bones {
            bad(b.paint, b.module)?;
        }
        for i in &s.instances {
            bad(i.paint, i.module)?;
        }
        for p in &s.polygons {
            bad(p.paint, p.module)?;
        }
        Ok(())
    }

    fn eval(&self, e: &grm_sema::TExpr) -> Option<Value> {
        e.constant().or_else(|| {
            let env = grm_sema::eval::Env {
                params: &self.params,
                globals: &self.globals,
                bindings: &[],
            };
            grm_sema::eval::eval(e, &env).ok()
        })
    }

    fn material_of(&self, key: PaintKey) -> ModelMaterial {
        let mut m = ModelMaterial::default();
        match key {
            PaintKey::Palette(i) => {
                m.name = format!("color{i}");
                m.color = Paint::palette_color(i);
            }
            PaintKey::Rgb(c) => {
                m.name = format!("rgb_{:02x}{:02x}{:02x}", c[0], c[1], c[2]);
                m.color = c.map(|x| f32::from(x) / 255.0);
            }
            // `check_paints` guarantees the id is in range.
            PaintKey::Material(id) => m = self.declared[id as usize].clone(),
        }
        // Names are unique: a declared material may be called `color1`.
        if self.materials.iter().any(|x| x.name == m.name) {
            m.name = format!("{}_{}", m.name, self.materials.len());
        }
        m
    }

    fn part(&mut self, paint: Paint) -> usize {
        let key = PaintKey::of(paint);
        if let Some(&i) = self.by_key.get(&key) {
            return i;
        }
        let material = self.material_of(key);
        self.materials.push(material);
        let i = self.parts.len();
        self.parts.push(Part {
            material: self.materials.len() - 1,
            ..Part::default()
        });
        self.by_key.insert(key, i);
        i
    }

    fn pick(&mut self, part: usize, before: usize, source: PartSource, module: u32, origin: u32) {
        let p = &mut self.parts[part];
        let after = p.mesh.triangle_count();
        if after > before {
            p.picks.push(Pick {
                first_triangle: before as u32,
                triangle_count: (after - before) as u32,
                source,
                module,
                origin,
            });
        }
    }

    fn finish(mut self, skeleton: Interpretation) -> Model {
        // Drop parts that ended up empty (everything in them was dropped)
        // and their materials.
        self.parts.retain(|p| !p.mesh.is_empty());
        let mut materials = Vec::with_capacity(self.parts.len());
        for p in &mut self.parts {
            materials.push(self.materials[p.material].clone());
            p.material = materials.len() - 1;
        }
        self.materials = materials;
        let mut bounds = skeleton.bounds;
        let mut vertices = 0;
        let mut triangles = 0;
        for p in &self.parts {
            vertices += p.mesh.vertex_count();
            triangles += p.mesh.triangle_count();
            for v in &p.mesh.positions {
                bounds.add(Vec3::from_array(*v));
            }
        }
        let stats = Stats {
            vertices,
            triangles,
            bones: skeleton.bones.len(),
            instances: skeleton.instances.len(),
            polygons: skeleton.polygons.len(),
            parts: self.parts.len(),
            bounds,
            dropped: self.dropped,
            bare_bones: self.bare_bones,
        };
        Model {
            skeleton,
            materials: self.materials,
            declared_materials: self.declared,
            parts: self.parts,
            stats,
            module_keys: Vec::new(),
            groups: Vec::new(),
            textures: Vec::new(),
            footprint: self.footprint,
        }
    }
}

/// The default material: grey, rough, opaque (what an unset property of a
/// declared material takes).
impl Default for ModelMaterial {
    fn default() -> Self {
        ModelMaterial {
            name: "default".to_string(),
            color: [0.8; 3],
            roughness: 0.8,
            metallic: 0.0,
            emissive: [0.0; 3],
            opacity: 1.0,
            texture: None,
        }
    }
}

/// A name safe for OBJ/MTL and glTF: ASCII letters, digits, `_` `-` `.`.
pub(crate) fn sanitize(name: &str) -> String {
    let s: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.') {
                c
            } else {
                '_'
            }
        })
        .collect();
    if s.is_empty() {
        "material".to_string()
    } else {
        s
    }
}

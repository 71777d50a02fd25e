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
mod build;
mod error;
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
use build::*;
pub use error::GeomError;
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

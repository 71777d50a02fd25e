//! What a model costs in memory, counted before it is built.
//!
//! A model's meshes are many times larger than the string that draws them
//! (a Koch island's bone is a tube of 16 to 32 triangles), so a derivation
//! that fits its memory limit can still build a model that does not. The
//! builder counts first and builds only what fits [`BuildOptions::max_bytes`]
//! (the `--max-memory` of `grmc`, 2 GiB by default):
//!
//! 1. **From the string** ([`count_string`]), before interpreting it: the
//!    modules that draw (bones, shapes, polygon vertices and ends) and the
//!    brackets bound the interpretation; with the caller's `held` bytes
//!    (the string) it must fit.
//! 2. **From the interpretation**, before any mesh is made: each bone's
//!    tube exactly (its rings and caps, shared rings where a chain goes on
//!    in the same material: [`crate::tube`]), each shape's unit mesh, each
//!    polygon at most `2n` vertices and `2(n - 2)` triangles; the mesh
//!    buffers are then reserved at these sizes, so they never grow by
//!    doubling past them.
//! 3. **What the output needs** on top of the model ([`Output`]): a glb's
//!    part ids and parts table, an SVG's text, a picture's sample buffers
//!    and its per-vertex screen data.
//!
//! Each count includes [`BASELINE_BYTES`] for the process itself, so that
//! a run's peak stays under the limit, not only its model.
//!
//! Past the limit, building stops with [`crate::GeomError::MemoryLimit`]
//! (R0202, as a derivation over `--max-memory`), which says what the model
//! would need, of what, and by how much it is over.

use std::mem::size_of;

use grm_derive::ModuleString;
use grm_sema::{System, Terminal};
use grm_turtle::{Bone, Instance, Interpretation, Polygon, Turtle};

use crate::export::ExportFormat;
use crate::render::RenderOptions;

/// The default of [`crate::BuildOptions::max_bytes`]: 2 GiB, as a
/// derivation's (`grm_derive::DeriveLimits`).
pub const DEFAULT_MAX_BYTES: u64 = 2 << 30;

/// What the process holds besides the model: its code, the checked and
/// compiled program, threads' stacks, the allocator's own (measured: 10
/// to 12 MiB for `grmc derive`), counted with every model.
pub const BASELINE_BYTES: u64 = 16 << 20;

/// What a model is built for: what comes after it counts too.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Output {
    /// Held (the preview, a library caller).
    #[default]
    Model,
    /// Written in a file format (`Png` with the default picture).
    Format(ExportFormat),
    /// Drawn as a picture of `width` x `height` pixels, `samples` per axis
    /// ([`RenderOptions::samples`]).
    Picture {
        width: u32,
        height: u32,
        samples: u32,
    },
}

impl Output {
    /// The output for writing with `format`, a picture drawn with `image`.
    pub fn of(format: Option<ExportFormat>, image: &RenderOptions) -> Output {
        match format {
            Some(ExportFormat::Png) => Output::Picture {
                width: image.width,
                height: image.height,
                samples: image.samples,
            },
            Some(f) => Output::Format(f),
            None => Output::Model,
        }
    }

    fn describe(&self) -> &'static str {
        match self {
            Output::Model => "",
            Output::Format(ExportFormat::Glb) => " and writing it as .glb",
            Output::Format(ExportFormat::Obj) => " and writing it as .obj",
            Output::Format(ExportFormat::Ply | ExportFormat::PlyAscii) => " and writing it as .ply",
            Output::Format(ExportFormat::Svg) => " and writing it as .svg",
            Output::Format(ExportFormat::Png) | Output::Picture { .. } => {
                " and drawing its picture"
            }
        }
    }
}

/// What a model is made of, and the bytes it needs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Footprint {
    pub bones: u64,
    pub instances: u64,
    pub polygons: u64,
    pub polygon_vertices: u64,
    /// Mesh vertices and triangles (at most: a shape or polygon that turns
    /// out degenerate makes none).
    pub vertices: u64,
    pub triangles: u64,
    /// Runs of triangles with their maker ([`crate::Pick`]).
    pub picks: u64,
    /// Bytes: what the caller holds, the interpretation, the builder's
    /// own tables, the meshes and what the output needs.
    pub bytes: u64,
}

impl Footprint {
    /// The text of a [`crate::GeomError::MemoryLimit`].
    pub(crate) fn message(&self, limit: u64, output: Output) -> String {
        let over = self.bytes.saturating_sub(limit);
        let what = if self.vertices > 0 || self.triangles > 0 {
            format!(
                "{} triangles and {} vertices from {} bones, {} shapes and {} polygons",
                self.triangles, self.vertices, self.bones, self.instances, self.polygons
            )
        } else {
            format!(
                "{} bones, {} shapes and {} polygon vertices",
                self.bones, self.instances, self.polygon_vertices
            )
        };
        format!(
            "building the model{} would need {} ({what}): {} over the memory limit of {}",
            output.describe(),
            mib(self.bytes),
            mib(over),
            mib(limit)
        )
    }
}

/// Bytes as MiB for messages (`1.13 MiB`, `9012 MiB`).
pub fn mib(bytes: u64) -> String {
    let m = bytes as f64 / f64::from(1 << 20);
    if m < 10.0 {
        format!("{m:.2} MiB")
    } else {
        format!("{m:.0} MiB")
    }
}

fn bytes_of<T>(n: u64) -> u64 {
    n.saturating_mul(size_of::<T>() as u64)
}

/// The most the interpretation of `string` (a string of `system`) can
/// hold: every module that draws counted as drawing, every `[` as open at
/// once. `held` is not included.
pub fn count_string(system: &System, string: &ModuleString) -> Footprint {
    use Terminal as T;
    let ops: Vec<Option<Terminal>> = system.terminals();
    let mut f = Footprint::default();
    let mut pushes = 0u64;
    let mut starts = 0u64;
    for s in string.symbols() {
        match ops.get(s as usize).copied().flatten() {
            Some(T::Forward) => {
                f.bones += 1;
                f.polygon_vertices += 1;
            }
            Some(T::ForwardNoVertex) => f.bones += 1,
            Some(T::Move | T::PolygonVertex) => f.polygon_vertices += 1,
            Some(T::PolygonStart) => starts += 1,
            Some(T::PolygonEnd) => f.polygons += 1,
            Some(T::Push) => pushes += 1,
            Some(T::Cylinder | T::Cone | T::Sphere | T::Box | T::Disc | T::Mesh) => {
                f.instances += 1
            }
            _ => {}
        }
    }
    if starts == 0 {
        // Vertices are kept only inside `{ }`.
        f.polygon_vertices = 0;
        f.polygons = 0;
    }
    f.bytes = interpretation_bytes(f.bones, f.instances, f.polygons, f.polygon_vertices)
        // The turtle's stack, and the open polygons' vertices.
        .saturating_add(bytes_of::<Turtle>(pushes))
        .saturating_add(bytes_of::<glam::Vec3>(f.polygon_vertices));
    f
}

/// An interpretation's arrays at exactly these lengths.
fn interpretation_bytes(bones: u64, instances: u64, polygons: u64, vertices: u64) -> u64 {
    bytes_of::<Bone>(bones)
        .saturating_add(bytes_of::<Instance>(instances))
        .saturating_add(bytes_of::<Polygon>(polygons))
        .saturating_add(bytes_of::<glam::Vec3>(vertices))
}

/// The bytes an interpretation holds (its capacities).
pub fn interpretation_heap(s: &Interpretation) -> u64 {
    interpretation_bytes(
        s.bones.capacity() as u64,
        s.instances.capacity() as u64,
        s.polygons.capacity() as u64,
        s.polygon_vertices.capacity() as u64,
    )
}

/// The builder's tables per bone: the tube plan (direction, continuing
/// child, flag, ring frame, and the best child while it is made) and the
/// tip ring of each bone.
pub(crate) const PLAN_BYTES_PER_BONE: u64 = (size_of::<Option<glam::Vec3>>()
    + size_of::<Option<u32>>()
    + size_of::<bool>()
    + size_of::<glam::Vec3>()
    + size_of::<Option<(u32, f32)>>()
    + size_of::<Option<(usize, u32)>>()) as u64;

/// A mesh vertex (position and normal) and a triangle (three indices).
pub(crate) const VERTEX_BYTES: u64 = 24;
pub(crate) const TRIANGLE_BYTES: u64 = 12;

/// Bytes `output` needs beyond the model `f` describes (vertices,
/// triangles, picks, bones and polygon vertices set); `translucent` when
/// a material of the model is (a picture then blends in more buffers).
pub fn output_bytes(f: &Footprint, output: Output, translucent: bool) -> u64 {
    let v = f.vertices;
    let t = f.triangles;
    match output {
        Output::Model | Output::Format(ExportFormat::Obj | ExportFormat::Ply) => 0,
        Output::Format(ExportFormat::PlyAscii) => 0,
        // The part id of every vertex (`parts::part_ids`) and one part's
        // copy as it is written; per part the id map, the table's JSON
        // value (an object of two entries) and its text.
        Output::Format(ExportFormat::Glb) => v
            .saturating_mul(8)
            .saturating_add(f.picks.saturating_mul(GLB_BYTES_PER_PART)),
        // The document, grown by doubling: a line per bone, a path per
        // polygon.
        Output::Format(ExportFormat::Svg) => f
            .bones
            .saturating_mul(2 * 160)
            .saturating_add(f.polygon_vertices.saturating_mul(2 * 40))
            .saturating_add(f.polygons.saturating_mul(2 * 48)),
        Output::Format(ExportFormat::Png) => {
            picture_bytes(f, &RenderOptions::default(), translucent)
        }
        Output::Picture {
            width,
            height,
            samples,
        } => picture_bytes(
            f,
            &RenderOptions {
                width,
                height,
                samples,
                ..RenderOptions::default()
            },
            translucent,
        ),
    }
    .saturating_add(if t > 0 || v > 0 { 1 << 16 } else { 0 })
}

/// Per part of a glb: the id map's entry and the module list (grown by
/// doubling), the parts table's JSON object (a map of two entries, its
/// keys and the key's text) and its serialised text.
const GLB_BYTES_PER_PART: u64 = 2048;

/// What the rasterizer holds for a picture of `f` (`crate::render`): per
/// vertex its camera-space position (f64), screen position and the light
/// from both sides; per triangle its draw item, its place in the bands'
/// bins (two bands), a clipped copy of its indices and its depth key
/// when translucent; per bone a line; and the sample buffers (depth,
/// colour, the translucency buffers), the picture and its PNG. Measured:
/// the Koch island at n = 6 (16.8 million triangles) was drawn in 1.25 GB,
/// its model included, against 1.75 GiB counted.
fn picture_bytes(f: &Footprint, o: &RenderOptions, translucent: bool) -> u64 {
    let pixels = u64::from(o.width) * u64::from(o.height);
    let s = u64::from(o.effective_samples());
    let samples = pixels * s * s;
    f.vertices
        .saturating_mul(24 + 12 + 12 + 12)
        .saturating_add(
            f.triangles
                .saturating_mul(12 + 8 + 12 + if translucent { 16 } else { 0 }),
        )
        .saturating_add(f.bones.saturating_mul(64))
        .saturating_add(samples * if translucent { 4 + 6 + 2 + 8 } else { 4 + 6 })
        .saturating_add(pixels * (4 + 4 + 4))
}

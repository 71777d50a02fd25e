//! Shape mode: a [`ShapeTree`] (a derived `mode = shape` building) as a
//! [`Model`] of triangle meshes, grouped for export (docs/export.md,
//! "Shape mode").
//!
//! **What draws.** Every *terminal shape* (a shape node with no children:
//! no rule rewrote it, or its rule made nothing) draws its geometry, and
//! every *insert* node draws its asset fitted to its scope:
//!
//! - a box mass: 6 quads (12 triangles; a face of zero area is left out);
//! - a prism (a mass over a footprint outline): one quad per edge of each
//!   ring (walls, facing out of the solid, courtyard walls included) and
//!   the outline triangulated as its top (facing +z) and bottom (facing
//!   -z); non-convex outlines are ear-clipped, outlines with holes are
//!   first cut into hole-free pieces by vertical lines through the holes;
//! - a rectangle face: one quad facing the scope's +z (a component
//!   split's faces face out of their mass); an outline face: its outline
//!   triangulated, facing +z;
//! - a roof (or tapered solid): each of its planar faces (slopes, gable
//!   ends, a flat top, the underside) ear-clipped in its plane, facing
//!   out, UVs by the face's own bounds (`u` along the eave, `v` up the
//!   slope);
//! - an edge: nothing (it has no area);
//! - an insert: a primitive (`box cylinder cone sphere disc`, the unit
//!   shapes of [`crate::mesh`]) or an OBJ mesh (the [`ShapeAssets`]'
//!   `meshes`, by asset name), its bounding box mapped onto the scope box:
//!   the asset's x, y and z on the scope's x, y and z (an asset modelled
//!   y-up stands upright on a wall, whose scope has y up and z out). On a
//!   scope axis of size 0 (a face's z) the asset keeps its proportions:
//!   that axis is scaled by the mean of the other axes' scales, from the
//!   face outwards. An asset that is flat on an axis stays flat there.
//!
//! **Frames.** The shape world is z-up; the model is grm's y-up, as every
//! grm model: a world point `(x, y, z)` is the model point `(x, z, -y)`
//! (a quarter turn about x; the PLY export turns it back).
//!
//! **UV coordinates** (every vertex has them, `MeshData::uvs`): normalised
//! per face, in `[0, 1]`: a face's `u = x / size.x`, `v = y / size.y` in
//! its scope; a box's face the same in the face's two axes (mirrored on
//! the faces looking down an axis, so no face shows its texture mirrored);
//! a prism's wall `u` along the edge, `v` up the height, its top and
//! bottom `x / size.x`, `y / size.y`; an insert by box projection of its
//! asset's bounding box (each vertex on the plane its normal leans to
//! most). A texture so covers each face once (no tiling by world units).
//!
//! **Materials.** A node's attributes (`grm_shape::attributes`): a
//! `material(name)` is the declared material of that name
//! ([`ShapeAssets::materials`]); `color(r, g, b)` overrides its base
//! colour (or makes a colour material); `texture(name)` adds the image
//! (read once, PNG or JPEG, kept in [`Model::textures`] and embedded in a
//! glb) as the base-colour texture, on a white base unless a material or
//! colour is set. One model part per distinct (material, colour quantised
//! to 8 bits, texture), in order of first use.
//!
//! **Groups.** A *terminal shape group* is a shape that draws something:
//! its own geometry if it is terminal, and the inserts its rule made
//! directly (`Window --> insert(frame) Glass` gives a group `Window` with
//! the frame, and a group `Glass`). Groups are in tree order; each
//! becomes one named glTF node (an OBJ object) with its locators
//! ([`ShapeGroup`]). A group's triangles in each part are contiguous
//! ([`GroupSpan`]), and every drawn node's triangles have a [`Pick`] with
//! [`PartSource::Shape`] (the node's index) and `module` the same index.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::{Quat, Vec3};
use grm_shape::{
    Attributes, Geom, NodeId, NodeKind, Outline, Program as ShapeProgram, Scope, ShapeTree,
};

use crate::mesh::{self, MeshData};

mod builder;
mod emit;
use crate::{
    BuildOptions, Footprint, GeomError, Model, ModelMaterial, ModelTexture, Part, PartSource, Pick,
    Stats, budget, import, sanitize,
};
use builder::*;
use emit::*;

/// The largest image a texture may name.
pub const MAX_TEXTURE_BYTES: u64 = 64 << 20;

/// What a shape program's names resolve to.
#[derive(Clone, Debug, Default)]
pub struct ShapeAssets {
    /// Materials by name (`ModelMaterial::name`; e.g. the program's
    /// declared materials, [`crate::declared_materials`]).
    pub materials: Vec<ModelMaterial>,
    /// OBJ meshes by insert asset name (the primitives `box cylinder cone
    /// sphere disc` need no entry; an entry of that name takes precedence).
    pub meshes: Vec<(String, PathBuf)>,
    /// Images by texture name; a name not listed is read as a path,
    /// relative to `dir` when it is relative.
    pub textures: Vec<(String, PathBuf)>,
    /// The directory relative texture names are read from (the grammar
    /// file's); `None`: the working directory.
    pub dir: Option<PathBuf>,
}

impl ShapeAssets {
    /// The assets of a checked grm program: its declared materials
    /// evaluated with the meta-parameter values `params`, and its declared
    /// meshes; texture names are paths relative to `dir`.
    pub fn from_program(
        program: &grm_sema::Program,
        params: &[grm_sema::Value],
        dir: Option<&Path>,
    ) -> Result<ShapeAssets, GeomError> {
        Ok(ShapeAssets {
            materials: crate::declared_materials(program, params)?,
            meshes: program
                .meshes
                .iter()
                .map(|m| (m.name.clone(), m.path.clone()))
                .collect(),
            textures: Vec::new(),
            dir: dir.map(Path::to_path_buf),
        })
    }

    fn texture_path(&self, name: &str) -> PathBuf {
        if let Some((_, p)) = self.textures.iter().find(|(n, _)| n == name) {
            return p.clone();
        }
        let p = PathBuf::from(name);
        match &self.dir {
            Some(d) if p.is_relative() => d.join(p),
            _ => p,
        }
    }
}

/// One terminal shape group of a shape-mode model (module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct ShapeGroup {
    /// Unique in the model and readable: the symbol, then each tagged
    /// command's tag and index (`Window.facade1.floor3.column5`); the key
    /// (`.1a2b3c4d`) is added where that is not unique, then a number.
    /// ASCII letters, digits, `_`, `-` and `.` only. Empty, as are
    /// `exact` and `semantic`, when the model was built without
    /// `BuildOptions::group_names` (the preview).
    pub name: String,
    /// The shape's index in the tree.
    pub node: u32,
    /// Its identity key.
    pub key: u32,
    /// Its exact locator, `ExactLocator`'s text form (it parses back).
    pub exact: String,
    /// Its semantic locator, `SemanticLocator`'s text form.
    pub semantic: String,
    /// Its triangles, per part (inline for one: most groups draw in one
    /// part, and a building has tens of thousands of groups).
    pub spans: smallvec::SmallVec<[GroupSpan; 1]>,
}

/// A group's vertices and triangles in one part (contiguous; the
/// triangles use only these vertices).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GroupSpan {
    pub part: usize,
    pub first_vertex: u32,
    pub vertex_count: u32,
    pub first_triangle: u32,
    pub triangle_count: u32,
}

impl ShapeGroup {
    /// The glTF node's `extras`: `{"grm": {"exact", "semantic", "key"
    /// (8 hex digits), "node"}}`.
    pub fn extras(&self) -> serde_json::Value {
        serde_json::json!({ "grm": {
            "exact": self.exact,
            "semantic": self.semantic,
            "key": format!("{:08x}", self.key),
            "node": self.node,
        }})
    }
}

/// The primitives an insert may name without a mesh declaration.
pub const PRIMITIVES: [&str; 5] = ["box", "cylinder", "cone", "sphere", "disc"];

/// Build the model of a derived shape tree: every terminal shape's
/// geometry and every insert's asset, with UVs, materials from the
/// nodes' attributes, picks and groups (module documentation).
/// `options.segments` sets the primitives' resolution; the model is
/// checked against `options.max_bytes` (with `options.held`) as it grows,
/// and a build past it stops with [`GeomError::MemoryLimit`].
///
/// Errors: a material, asset or texture name that `assets` do not
/// resolve ([`GeomError::UnknownShapeName`]), an OBJ or image that cannot
/// be read, the memory limit. Degenerate geometry (no area, a scope that
/// is not finite) is left out and counted in [`Stats::dropped`].
pub fn build_shape_model(
    tree: &ShapeTree,
    program: &ShapeProgram,
    assets: &ShapeAssets,
    options: &BuildOptions,
) -> Result<Model, GeomError> {
    build_shape_model_cut(tree, program, assets, options, None)
}

/// How a node is drawn in a model built with a cut (focus and context:
/// a few levels below a selection, the rest as proxies).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Cut {
    /// As in the whole model.
    #[default]
    Drawn,
    /// A proxy: a shape drawn with its own geometry (its mass, its
    /// facade's rectangle) as if it were terminal; nothing below it is.
    Proxy,
    /// Below a proxy: not drawn.
    Hidden,
}

/// [`build_shape_model`] with a cut: per node of the tree (by index),
/// how it is drawn (`None`: every node as in the whole model). A cut
/// shorter than the tree draws the nodes past it as usual.
pub fn build_shape_model_cut(
    tree: &ShapeTree,
    program: &ShapeProgram,
    assets: &ShapeAssets,
    options: &BuildOptions,
    cut: Option<&[Cut]>,
) -> Result<Model, GeomError> {
    let nodes = tree.nodes();
    let threads = match options.threads {
        0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
        n => n,
    };
    let mut b = ShapeBuilder::new(program, assets, options)?;
    b.cut = cut;
    let whole = 0..nodes.len();
    let mid = nodes.len() / 2;
    let (predicted, groups, tail) = b.plan(tree, whole.clone(), mid);
    // In halves: when the tree says what will be drawn (boxes and
    // rectangles only) and that fits the budget (so neither half can pass
    // it), and there is enough of it to be worth a thread.
    b.within_budget = predicted.is_some_and(|f| b.predicted_bytes(&f) <= options.max_bytes);
    let halves = threads > 1 && groups >= PARALLEL_GROUPS && b.within_budget;
    if !halves {
        b.build_range(tree, whole)?;
    } else {
        let mut second = ShapeBuilder::new(program, assets, options)?;
        second.cut = cut;
        // This builder's parts are reserved for the whole (the other's
        // join them without moving), the other's for its half (counted
        // by the same walk).
        second.plan_tail(tail);
        second.within_budget = true;
        // Each half's parts' bounds on its own thread (`finish` folds
        // them in the order it would have read their vertices).
        let (first, other) = std::thread::scope(|s| {
            let h = s.spawn(|| {
                second.build_range(tree, mid..nodes.len()).map(|()| {
                    second.bounds = part_bounds(&second.parts);
                    second
                })
            });
            let first = b.build_range(tree, 0..mid).map(|()| {
                b.bounds = part_bounds(&b.parts);
            });
            (first, h.join())
        });
        first?;
        let other = match other {
            Ok(r) => r?,
            // A panic in the second half: build it here instead.
            Err(_) => {
                let mut again = ShapeBuilder::new(program, assets, options)?;
                again.cut = cut;
                again.plan(tree, mid..nodes.len(), nodes.len());
                again.build_range(tree, mid..nodes.len())?;
                again
            }
        };
        b.join(other)?;
        b.check_budget()?;
    }
    if options.group_names {
        unique_names(&mut b.groups);
    }
    Ok(b.finish())
}

/// Each part's bounds (its vertices as `Aabb::add` takes them).
fn part_bounds(parts: &[Part]) -> Vec<grm_turtle::Aabb> {
    parts
        .iter()
        .map(|p| {
            let mut b = grm_turtle::Aabb::EMPTY;
            for v in &p.mesh.positions {
                b.add(Vec3::from_array(*v));
            }
            b
        })
        .collect()
}

/// What [`ShapeBuilder::plan`] counted from its split on: per attribute
/// set, the vertices, triangles and picks; and the groups.
struct Tail {
    sizes: Vec<(usize, usize, usize)>,
    groups: usize,
}

/// Groups from which a shape model is built on two threads
/// ([`BuildOptions::threads`]): below, a thread costs more than it saves.
const PARALLEL_GROUPS: usize = 4096;

/// Make the groups' names unique: the key where a name is taken, then a
/// number.
fn unique_names(groups: &mut [ShapeGroup]) {
    let mut count: HashMap<String, usize> = HashMap::new();
    for g in groups.iter() {
        *count.entry(g.name.clone()).or_default() += 1;
    }
    let mut taken: std::collections::HashSet<String> = count
        .iter()
        .filter(|(_, n)| **n == 1)
        .map(|(k, _)| k.clone())
        .collect();
    for g in groups.iter_mut() {
        if count.get(&g.name) == Some(&1) {
            continue;
        }
        let mut name = format!("{}.{:08x}", g.name, g.key);
        let mut k = 2;
        while taken.contains(&name) {
            name = format!("{}.{:08x}.{k}", g.name, g.key);
            k += 1;
        }
        taken.insert(name.clone());
        g.name = name;
    }
}

/// Whether a terminal shape with this geometry draws (edges do not).
fn draws(g: &Option<Geom>) -> bool {
    !matches!(g, None | Some(Geom::Edge))
}

/// A world (z-up) point or direction in the model's y-up frame.
#[inline]
fn to_model(p: Vec3) -> Vec3 {
    Vec3::new(p.x, p.z, -p.y)
}

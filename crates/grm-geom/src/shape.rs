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
use crate::{
    BuildOptions, Footprint, GeomError, Model, ModelMaterial, ModelTexture, Part, PartSource, Pick,
    Stats, budget, import, sanitize,
};

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

/// Materials are keyed by (material, colour in 8 bits, texture).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
struct MatKey {
    material: Option<u32>,
    color: Option<[u8; 3]>,
    texture: Option<u32>,
}

/// A loaded insert asset.
enum Asset {
    Mesh(MeshData, Vec3, Vec3),
    Unloaded,
}

struct ShapeBuilder<'a> {
    program: &'a ShapeProgram,
    assets: &'a ShapeAssets,
    options: &'a BuildOptions,
    materials: Vec<ModelMaterial>,
    parts: Vec<Part>,
    by_key: HashMap<MatKey, usize>,
    /// Per asset id, its mesh and bounds, loaded on first use.
    meshes: Vec<Asset>,
    /// Per texture id, its index in `textures`, loaded on first use.
    texture_index: Vec<Option<usize>>,
    textures: Vec<ModelTexture>,
    groups: Vec<ShapeGroup>,
    dropped: usize,
    shapes: usize,
    inserts: usize,
    /// Bytes of the loaded meshes and textures.
    loaded_bytes: u64,
    tris: Vec<[u32; 3]>,
    /// Per attribute set of the tree (`AttrId`): its part, once made.
    attr_parts: Vec<Option<usize>>,
    /// Per attribute set: the vertices, triangles and picks its box and
    /// rectangle shapes will draw at most (reserved when its part is
    /// made).
    attr_sizes: Vec<(usize, usize, usize)>,
    /// The attributes each part was made for (a joined builder makes the
    /// other's new parts from them, [`ShapeBuilder::join`]).
    attrs_of: HashMap<MatKey, Attributes>,
    /// Set when the tree predicted the whole model's size within the
    /// limit: no group's check is needed.
    within_budget: bool,
    /// Focus and context: how each node is drawn ([`Cut`]).
    cut: Option<&'a [Cut]>,
    /// Built in halves: per part, the bounds of this half's vertices
    /// (empty otherwise), and after [`ShapeBuilder::join`] the other
    /// half's in `tail_bounds`.
    bounds: Vec<grm_turtle::Aabb>,
    tail_bounds: Vec<grm_turtle::Aabb>,
}

impl<'a> ShapeBuilder<'a> {
    fn new(
        program: &'a ShapeProgram,
        assets: &'a ShapeAssets,
        options: &'a BuildOptions,
    ) -> Result<ShapeBuilder<'a>, GeomError> {
        Ok(ShapeBuilder {
            program,
            assets,
            options,
            materials: Vec::new(),
            parts: Vec::new(),
            by_key: HashMap::new(),
            meshes: program.asset_names().map(|_| Asset::Unloaded).collect(),
            texture_index: vec![None; program.textures().len()],
            textures: Vec::new(),
            groups: Vec::new(),
            dropped: 0,
            shapes: 0,
            inserts: 0,
            loaded_bytes: 0,
            tris: Vec::new(),
            attr_parts: Vec::new(),
            attr_sizes: Vec::new(),
            attrs_of: HashMap::new(),
            within_budget: false,
            cut: None,
            bounds: Vec::new(),
            tail_bounds: Vec::new(),
        })
    }

    /// How node `i` is drawn.
    fn cut_of(&self, i: usize) -> Cut {
        self.cut.and_then(|c| c.get(i).copied()).unwrap_or_default()
    }

    /// Count what the terminal shapes of `range` will draw per attribute
    /// set (boxes and rectangles, the common case; other geometry grows
    /// the meshes as it goes), and reserve the groups. Returns the
    /// footprint of the whole (an upper bound: faces without area are
    /// left out) when the range draws boxes and rectangles alone (no
    /// other geometry, no insert, no texture), and the number of groups.
    /// The same counts for the nodes from `split` on go into `tail` (a
    /// second half's plan, [`ShapeBuilder::plan_tail`], without a second
    /// walk of the tree); `split` at or past the range's end counts none.
    fn plan(
        &mut self,
        tree: &ShapeTree,
        range: std::ops::Range<usize>,
        split: usize,
    ) -> (Option<Footprint>, usize, Tail) {
        let table = tree.attribute_table();
        self.attr_parts = vec![None; table.len()];
        self.attr_sizes = vec![(0, 0, 0); table.len()];
        let mut tail = Tail {
            sizes: if split < range.end {
                vec![(0, 0, 0); table.len()]
            } else {
                Vec::new()
            },
            groups: 0,
        };
        let mut groups = 0;
        let mut known = true;
        let mut f = Footprint::default();
        for (i, n) in tree
            .nodes()
            .iter()
            .enumerate()
            .take(range.end)
            .skip(range.start)
        {
            let cut = self.cut_of(i);
            if cut == Cut::Hidden {
                continue;
            }
            if matches!(n.kind, NodeKind::Insert { .. }) {
                known = false;
            }
            let leaf = !n.has_children() || cut == Cut::Proxy;
            if !matches!(n.kind, NodeKind::Shape { .. }) || !leaf {
                continue;
            }
            let (v, t) = match n.geometry {
                grm_shape::Geometry::Box => (24, 12),
                grm_shape::Geometry::Rect => (4, 2),
                grm_shape::Geometry::Edge => continue,
                _ => {
                    known = false;
                    (0, 0)
                }
            };
            groups += 1;
            let attr = usize::from(n.attrs.0);
            if let Some(a) = self.attr_sizes.get_mut(attr) {
                *a = (a.0 + v, a.1 + t, a.2 + 1);
            }
            if i >= split {
                tail.groups += 1;
                if let Some(a) = tail.sizes.get_mut(attr) {
                    *a = (a.0 + v, a.1 + t, a.2 + 1);
                }
            }
            f.vertices += v as u64;
            f.triangles += t as u64;
            f.picks += 1;
            f.polygons += 1;
        }
        known &= table.iter().all(|a| a.texture.is_none());
        self.groups.reserve(groups);
        (known.then_some(f), groups, tail)
    }

    /// A second half's plan from the first's [`Tail`] (what
    /// [`ShapeBuilder::plan`] of its range would have reserved).
    fn plan_tail(&mut self, tail: Tail) {
        self.attr_parts = vec![None; tail.sizes.len()];
        self.attr_sizes = tail.sizes;
        self.groups.reserve(tail.groups);
    }

    /// Draw the groups of the nodes in `range` (in node order).
    fn build_range(
        &mut self,
        tree: &ShapeTree,
        range: std::ops::Range<usize>,
    ) -> Result<(), GeomError> {
        let program = self.program;
        let nodes = tree.nodes();
        // Reused per group: the parts' sizes before it, its inserts.
        let mut before: Vec<(u32, u32)> = Vec::new();
        let mut inserts: Vec<NodeId> = Vec::new();
        // The groups: shapes that draw (terminal) or whose rule made inserts.
        for (i, n) in nodes.iter().enumerate().take(range.end).skip(range.start) {
            let id = NodeId(i as u32);
            let NodeKind::Shape { symbol, .. } = n.kind else {
                continue;
            };
            let cut = self.cut_of(i);
            if cut == Cut::Hidden {
                continue;
            }
            // A proxy draws its own geometry, as a terminal shape would.
            let leaf = !n.has_children() || cut == Cut::Proxy;
            let geom = if leaf { tree.geom(id) } else { None };
            // A shape a persistent edit removed draws nothing.
            let own = draws(&geom) && !tree.is_removed(id);
            inserts.clear();
            if n.has_children() && cut == Cut::Drawn {
                inserts.extend(
                    tree.children(id)
                        .filter(|&c| matches!(nodes[c.0 as usize].kind, NodeKind::Insert { .. })),
                );
            }
            if !own && inserts.is_empty() {
                continue;
            }
            let spans = if inserts.is_empty() {
                // The shape alone: its one part's span is what it drew.
                let span = match geom.filter(|_| own) {
                    Some(geom) => self.draw_shape(tree, id, &n.scope, &geom)?,
                    None => None,
                };
                let Some(span) = span else { continue };
                smallvec::smallvec![span]
            } else {
                before.clear();
                before.extend(
                    self.parts
                        .iter()
                        .map(|p| (p.mesh.vertex_count() as u32, p.mesh.triangle_count() as u32)),
                );
                if let Some(geom) = geom.filter(|_| own) {
                    self.draw_shape(tree, id, &n.scope, &geom)?;
                }
                for &c in &inserts {
                    self.draw_insert(tree, c)?;
                }
                self.spans_since(&before)
            };
            // A build whose size the tree predicted within the limit
            // cannot pass it (`plan`).
            if !self.within_budget {
                self.check_budget()?;
            }
            if spans.is_empty() {
                continue;
            }
            let (name, exact, semantic) = if self.options.group_names {
                let semantic = tree.semantic_locator(program, id);
                let mut name = program.symbol_name(symbol).to_owned();
                for e in &semantic.entries {
                    name.push_str(&format!(".{}{}", e.tag, e.index));
                }
                (
                    sanitize(&name),
                    tree.exact_locator(program, id).to_string(),
                    semantic.to_string(),
                )
            } else {
                (String::new(), String::new(), String::new())
            };
            self.groups.push(ShapeGroup {
                name,
                node: id.0,
                key: n.key,
                exact,
                semantic,
                spans,
            });
        }
        Ok(())
    }

    /// Append `other`, built from the nodes after this builder's, as one
    /// builder would have built them all: its parts joined to the parts of
    /// the same attributes (new ones after these, in its order of first
    /// use), its vertices, triangles, picks and groups moved past these,
    /// its materials and textures numbered after these.
    fn join(&mut self, other: ShapeBuilder<'a>) -> Result<(), GeomError> {
        // The other's parts in its order of first use.
        let mut keys: Vec<(MatKey, usize)> = other.by_key.iter().map(|(k, &i)| (*k, i)).collect();
        keys.sort_by_key(|&(_, i)| i);
        // Per part of the other: (this builder's part, vertex and triangle
        // offsets).
        let mut moved = vec![(0usize, 0u32, 0u32); other.parts.len()];
        let parts_before = self.parts.len();
        for (key, i) in keys {
            let Some(part) = other.parts.get(i) else {
                continue;
            };
            let mine = match self.by_key.get(&key) {
                Some(&j) => j,
                // A part first used in the other half: made as this
                // builder would have made it, from the same attributes.
                None => {
                    let attrs = other.attrs_of.get(&key).copied().unwrap_or_default();
                    self.part(attrs)?
                }
            };
            let p = &mut self.parts[mine];
            let (v0, t0) = (p.mesh.vertex_count() as u32, p.mesh.triangle_count() as u32);
            p.mesh.positions.extend_from_slice(&part.mesh.positions);
            p.mesh.normals.extend_from_slice(&part.mesh.normals);
            p.mesh.uvs.extend_from_slice(&part.mesh.uvs);
            p.mesh
                .indices
                .extend(part.mesh.indices.iter().map(|&k| k + v0));
            p.picks.extend(part.picks.iter().map(|pk| Pick {
                first_triangle: pk.first_triangle + t0,
                ..*pk
            }));
            moved[i] = (mine, v0, t0);
        }
        let made = self.parts.len() - parts_before;
        self.groups.extend(other.groups.into_iter().map(|mut g| {
            for span in &mut g.spans {
                let (mine, v0, t0) = moved[span.part];
                span.part = mine;
                span.first_vertex += v0;
                span.first_triangle += t0;
            }
            g
        }));
        // Per part, the first half's bounds, then the other's (parts new
        // to the other have none of this half's).
        if self.bounds.len() == self.parts.len() - made && other.bounds.len() == other.parts.len() {
            self.bounds
                .resize(self.parts.len(), grm_turtle::Aabb::EMPTY);
            self.tail_bounds = vec![grm_turtle::Aabb::EMPTY; self.parts.len()];
            for (i, &(mine, ..)) in moved.iter().enumerate() {
                self.tail_bounds[mine] = other.bounds[i];
            }
        } else {
            self.bounds.clear();
        }
        self.dropped += other.dropped;
        self.shapes += other.shapes;
        self.inserts += other.inserts;
        self.loaded_bytes += other.loaded_bytes;
        Ok(())
    }

    /// The part a node is drawn in (by its attributes).
    fn part_of(&mut self, tree: &ShapeTree, id: NodeId) -> Result<usize, GeomError> {
        let attr = tree.node(id).map(|n| usize::from(n.attrs.0));
        if let Some(Some(i)) = attr.and_then(|a| self.attr_parts.get(a)) {
            return Ok(*i);
        }
        let i = self.part(tree.attributes(id))?;
        if let Some(a) = attr.filter(|&a| a < self.attr_parts.len()) {
            self.attr_parts[a] = Some(i);
            let (v, t, k) = self.attr_sizes[a];
            let p = &mut self.parts[i];
            p.mesh.positions.reserve(v);
            p.mesh.normals.reserve(v);
            p.mesh.uvs.reserve(v);
            p.mesh.indices.reserve(3 * t);
            p.picks.reserve(k);
        }
        Ok(i)
    }

    /// The part for a node's attributes (made on first use).
    fn part(&mut self, a: Attributes) -> Result<usize, GeomError> {
        let key = MatKey {
            material: a.material.map(|m| m.0),
            color: a.color.map(|c| c.map(crate::to_u8)),
            texture: a.texture.map(|t| t.0),
        };
        if let Some(&i) = self.by_key.get(&key) {
            return Ok(i);
        }
        let mut m = match a.material {
            Some(id) => {
                let name = self.program.material_name(id);
                self.assets
                    .materials
                    .iter()
                    .find(|m| m.name == sanitize(name) || m.name == name)
                    .cloned()
                    .ok_or_else(|| GeomError::UnknownShapeName {
                        what: "material",
                        name: name.to_owned(),
                    })?
            }
            None => ModelMaterial::default(),
        };
        if let Some(c) = key.color {
            m.color = c.map(|x| f32::from(x) / 255.0);
            let base = if a.material.is_some() {
                m.name.clone()
            } else {
                "rgb".to_owned()
            };
            m.name = format!("{base}_{:02x}{:02x}{:02x}", c[0], c[1], c[2]);
        }
        if let Some(t) = a.texture {
            let index = self.texture(t)?;
            if a.material.is_none() && a.color.is_none() {
                m.color = [1.0; 3];
                m.name = "textured".to_owned();
            }
            m.texture = Some(index);
            m.name = format!("{}_{}", m.name, sanitize(&self.textures[index].name));
        }
        if self.materials.iter().any(|x| x.name == m.name) {
            m.name = format!("{}_{}", m.name, self.materials.len());
        }
        self.materials.push(m);
        let i = self.parts.len();
        self.parts.push(Part {
            material: self.materials.len() - 1,
            ..Part::default()
        });
        self.by_key.insert(key, i);
        self.attrs_of.insert(key, a);
        Ok(i)
    }

    /// The texture `t`, read on first use.
    fn texture(&mut self, t: grm_shape::TextureId) -> Result<usize, GeomError> {
        let name = self.program.texture_name(t).to_owned();
        let slot = self
            .texture_index
            .get(t.0 as usize)
            .copied()
            .ok_or_else(|| GeomError::UnknownShapeName {
                what: "texture",
                name: name.clone(),
            })?;
        if let Some(i) = slot {
            return Ok(i);
        }
        let path = self.assets.texture_path(&name);
        let unreadable = |message: String| GeomError::TextureUnreadable {
            texture: name.clone(),
            path: path.clone(),
            message,
        };
        let what = "it is larger than 64 MiB, the most a texture may be";
        let bytes = grm_diag::input::read_bounded(&path, MAX_TEXTURE_BYTES, what)
            .map_err(|e| unreadable(e.to_string()))?;
        let mime = if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
            "image/png"
        } else if bytes.starts_with(&[0xff, 0xd8, 0xff]) {
            "image/jpeg"
        } else {
            return Err(unreadable("it is not a PNG or JPEG image".to_owned()));
        };
        self.loaded_bytes += bytes.len() as u64;
        self.textures.push(ModelTexture {
            name,
            path: path.clone(),
            mime,
            bytes: Arc::from(bytes),
        });
        let i = self.textures.len() - 1;
        self.texture_index[t.0 as usize] = Some(i);
        Ok(i)
    }

    /// The parts' triangles and vertices added since `before` (per part;
    /// parts made since count from 0).
    fn spans_since(&self, before: &[(u32, u32)]) -> smallvec::SmallVec<[GroupSpan; 1]> {
        self.parts
            .iter()
            .enumerate()
            .filter_map(|(k, p)| {
                let (v0, t0) = before.get(k).copied().unwrap_or((0, 0));
                let (v1, t1) = (p.mesh.vertex_count() as u32, p.mesh.triangle_count() as u32);
                (t1 > t0).then_some(GroupSpan {
                    part: k,
                    first_vertex: v0,
                    vertex_count: v1 - v0,
                    first_triangle: t0,
                    triangle_count: t1 - t0,
                })
            })
            .collect()
    }

    fn pick(&mut self, part: usize, before: usize, node: NodeId) {
        let p = &mut self.parts[part];
        let after = p.mesh.triangle_count();
        if after > before {
            p.picks.push(Pick {
                first_triangle: before as u32,
                triangle_count: (after - before) as u32,
                source: PartSource::Shape(node.0),
                module: node.0,
                origin: grm_turtle::NO_ORIGIN,
            });
        }
    }

    /// What the model holds so far, counted against the limit.
    fn footprint(&self) -> Footprint {
        let mut f = Footprint {
            instances: self.inserts as u64,
            polygons: self.shapes as u64,
            ..Footprint::default()
        };
        for p in &self.parts {
            f.vertices += p.mesh.vertex_count() as u64;
            f.triangles += p.mesh.triangle_count() as u64;
            f.picks += p.picks.len() as u64;
        }
        f.bytes = self.bytes_of(
            &f,
            self.groups.len() as u64,
            self.materials.iter().any(|m| m.opacity < 1.0),
        );
        f
    }

    /// The bytes a model of these counts holds, counted against the limit
    /// (one group per picked run).
    fn bytes_of(&self, f: &Footprint, groups: u64, transparent: bool) -> u64 {
        self.options
            .held
            .saturating_add(budget::BASELINE_BYTES)
            .saturating_add(self.loaded_bytes)
            .saturating_add(f.vertices.saturating_mul(budget::VERTEX_BYTES + 8))
            .saturating_add(f.triangles.saturating_mul(budget::TRIANGLE_BYTES))
            .saturating_add(f.picks.saturating_mul(std::mem::size_of::<Pick>() as u64))
            .saturating_add(groups.saturating_mul(512))
            .saturating_add(budget::output_bytes(f, self.options.output, transparent))
    }

    /// [`ShapeBuilder::bytes_of`] a predicted model (one group per pick,
    /// its materials' opacity unknown: the larger of the two).
    fn predicted_bytes(&self, f: &Footprint) -> u64 {
        let g = f.picks;
        self.bytes_of(f, g, true).max(self.bytes_of(f, g, false))
    }

    fn check_budget(&self) -> Result<(), GeomError> {
        let f = self.footprint();
        if f.bytes > self.options.max_bytes {
            return Err(GeomError::MemoryLimit {
                footprint: f,
                limit: self.options.max_bytes,
                output: self.options.output,
            });
        }
        Ok(())
    }

    /// Draw a terminal shape's geometry.
    fn draw_shape(
        &mut self,
        tree: &ShapeTree,
        id: NodeId,
        scope: &Scope,
        geom: &Geom,
    ) -> Result<Option<GroupSpan>, GeomError> {
        if !scope_ok(scope) {
            self.dropped += 1;
            return Ok(None);
        }
        let part = self.part_of(tree, id)?;
        let before = self.parts[part].mesh.triangle_count();
        let first_vertex = self.parts[part].mesh.vertex_count() as u32;
        let mut tris = std::mem::take(&mut self.tris);
        let mut out = Emitter {
            mesh: &mut self.parts[part].mesh,
            scope,
            rot: scope.rotation(),
        };
        let s = scope.size;
        match geom {
            Geom::Box => out.cuboid(s),
            Geom::Rect => out.rect(s),
            Geom::Polygon(o) => out.outline(o, 0.0, false, s, &mut tris),
            Geom::Prism(o) => {
                out.walls(o, s.z);
                out.outline(o, s.z, false, s, &mut tris);
                out.outline(o, 0.0, true, s, &mut tris);
            }
            Geom::Roof(o) => {
                if let Some(roof) = o.roof() {
                    for face in roof.faces() {
                        out.planar(&roof.face_points(face), &mut tris);
                    }
                }
            }
            Geom::Edge => {}
        }
        self.tris = tris;
        let mesh = &self.parts[part].mesh;
        let (vertices, after) = (mesh.vertex_count() as u32, mesh.triangle_count());
        let span = (after > before).then(|| GroupSpan {
            part,
            first_vertex,
            vertex_count: vertices - first_vertex,
            first_triangle: before as u32,
            triangle_count: (after - before) as u32,
        });
        if span.is_none() {
            self.dropped += 1;
        } else {
            self.shapes += 1;
        }
        self.pick(part, before, id);
        Ok(span)
    }

    /// Draw an insert's asset fitted to its scope.
    fn draw_insert(&mut self, tree: &ShapeTree, id: NodeId) -> Result<(), GeomError> {
        let Some(n) = tree.node(id) else {
            return Ok(());
        };
        let NodeKind::Insert { asset } = n.kind else {
            return Ok(());
        };
        let scope = n.scope;
        let part = self.part_of(tree, id)?;
        self.load(asset)?;
        let Some(Asset::Mesh(m, lo, hi)) = self.meshes.get(asset.0 as usize) else {
            return Ok(());
        };
        let before = self.parts[part].mesh.triangle_count();
        let drawn =
            scope_ok(&scope) && append_fitted(&mut self.parts[part].mesh, m, *lo, *hi, &scope);
        if drawn {
            self.inserts += 1;
        } else {
            self.dropped += 1;
        }
        self.pick(part, before, id);
        Ok(())
    }

    /// Load asset `a` (a primitive, or an OBJ file) on first use.
    fn load(&mut self, a: grm_shape::AssetId) -> Result<(), GeomError> {
        let i = a.0 as usize;
        if !matches!(self.meshes.get(i), Some(Asset::Unloaded)) {
            return Ok(());
        }
        let name = self.program.asset_name(a);
        let segments = self.options.segments;
        let m = if let Some((_, path)) = self.assets.meshes.iter().find(|(n, _)| n == name) {
            let m = import::load_obj(name, path)?;
            self.loaded_bytes += m.vertex_count() as u64 * budget::VERTEX_BYTES
                + m.triangle_count() as u64 * budget::TRIANGLE_BYTES;
            m
        } else {
            match name {
                "box" => mesh::unit_box(),
                "cylinder" => mesh::unit_cylinder(segments),
                "cone" => mesh::unit_cone(segments),
                "sphere" => mesh::unit_sphere(segments),
                "disc" => mesh::unit_disc(segments),
                _ => {
                    return Err(GeomError::UnknownShapeName {
                        what: "asset",
                        name: name.to_owned(),
                    });
                }
            }
        };
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for p in &m.positions {
            lo = lo.min(Vec3::from_array(*p));
            hi = hi.max(Vec3::from_array(*p));
        }
        self.meshes[i] = Asset::Mesh(m, lo, hi);
        Ok(())
    }

    fn finish(self) -> Model {
        let mut bounds = grm_turtle::Aabb::EMPTY;
        let mut vertices = 0;
        let mut triangles = 0;
        // Built in halves: each part's bounds are its halves' (found on
        // their threads), folded in the vertices' order: the same box, to
        // the sign of a zero (a fold of `Aabb::add` over a run of points
        // is the union with the run's own bounds).
        let halves =
            self.bounds.len() == self.parts.len() && self.tail_bounds.len() == self.parts.len();
        for (k, p) in self.parts.iter().enumerate() {
            vertices += p.mesh.vertex_count();
            triangles += p.mesh.triangle_count();
            if halves {
                bounds = bounds.union(&self.bounds[k]).union(&self.tail_bounds[k]);
            } else {
                for v in &p.mesh.positions {
                    bounds.add(Vec3::from_array(*v));
                }
            }
        }
        let footprint = self.footprint();
        // Parts are made on first use, so none is empty but where every
        // node of its material was dropped: keep the indices (groups and
        // picks refer to them); exporters skip empty parts.
        let stats = Stats {
            vertices,
            triangles,
            bones: 0,
            instances: self.inserts,
            polygons: self.shapes,
            parts: self.parts.len(),
            bounds,
            dropped: self.dropped,
            bare_bones: 0,
        };
        Model {
            skeleton: Default::default(),
            materials: self.materials,
            declared_materials: self.assets.materials.clone(),
            parts: self.parts,
            stats,
            module_keys: Vec::new(),
            footprint,
            groups: self.groups,
            textures: self.textures,
        }
    }
}

/// A scope whose placement is finite.
fn scope_ok(s: &Scope) -> bool {
    s.origin.is_finite() && s.size.is_finite() && s.rotation().is_finite()
}

/// Writes a scope's local geometry into a mesh, in the model's frame.
struct Emitter<'m> {
    mesh: &'m mut MeshData,
    scope: &'m Scope,
    rot: Quat,
}

impl Emitter<'_> {
    /// A local normal in the model's frame (what each vertex with that
    /// normal is given).
    #[inline]
    fn normal(&self, normal: Vec3) -> Vec3 {
        to_model(self.rot * normal).normalize_or(Vec3::Y)
    }

    /// A vertex with its normal already in the model's frame.
    #[inline]
    fn vertex(&mut self, local: Vec3, n: Vec3, uv: [f32; 2]) -> u32 {
        let p = to_model(self.scope.origin + self.rot * local);
        self.mesh.vertex_uv(p, n, uv)
    }

    /// A quad `a b c d` (counter-clockwise seen from `normal`).
    /// The four vertices go in with one append per buffer (the same
    /// arithmetic per corner as [`Emitter::vertex`]: the same bytes).
    #[inline]
    fn quad(&mut self, corners: [Vec3; 4], normal: Vec3, uvs: [[f32; 2]; 4]) {
        let n = self.normal(normal).to_array();
        let (o, rot) = (self.scope.origin, self.rot);
        let at = |p: Vec3| to_model(o + rot * p).to_array();
        let [a, b, c, d] = [
            at(corners[0]),
            at(corners[1]),
            at(corners[2]),
            at(corners[3]),
        ];
        let m = &mut *self.mesh;
        let i = m.positions.len() as u32;
        m.positions.extend_from_slice(&[a, b, c, d]);
        m.normals.extend_from_slice(&[n; 4]);
        m.uvs.extend_from_slice(&uvs);
        m.indices
            .extend_from_slice(&[i, i + 1, i + 2, i, i + 2, i + 3]);
    }

    /// The box `[0, s]`: six quads, those of zero area left out.
    fn cuboid(&mut self, s: Vec3) {
        for a in 0..3 {
            let (b, c) = ((a + 1) % 3, (a + 2) % 3);
            if !(s[b] > 0.0 && s[c] > 0.0) {
                continue;
            }
            for positive in [true, false] {
                let mut n = Vec3::ZERO;
                n[a] = if positive { 1.0 } else { -1.0 };
                let at = |u: f32, v: f32| {
                    let mut p = Vec3::ZERO;
                    p[a] = if positive { s[a] } else { 0.0 };
                    p[b] = u * s[b];
                    p[c] = v * s[c];
                    p
                };
                // Counter-clockwise about +a in (b, c); reversed for -a,
                // with u mirrored so the texture reads the right way.
                if positive {
                    self.quad(
                        [at(0., 0.), at(1., 0.), at(1., 1.), at(0., 1.)],
                        n,
                        [[0., 0.], [1., 0.], [1., 1.], [0., 1.]],
                    );
                } else {
                    self.quad(
                        [at(1., 0.), at(0., 0.), at(0., 1.), at(1., 1.)],
                        n,
                        [[0., 0.], [1., 0.], [1., 1.], [0., 1.]],
                    );
                }
            }
        }
    }

    /// The rectangle `[0, s.x] x [0, s.y]`, facing +z.
    fn rect(&mut self, s: Vec3) {
        if !(s.x > 0.0 && s.y > 0.0) {
            return;
        }
        self.quad(
            [
                Vec3::ZERO,
                Vec3::new(s.x, 0.0, 0.0),
                Vec3::new(s.x, s.y, 0.0),
                Vec3::new(0.0, s.y, 0.0),
            ],
            Vec3::Z,
            [[0., 0.], [1., 0.], [1., 1.], [0., 1.]],
        );
    }

    /// The outline triangulated at height `z`, facing +z (or -z when
    /// `down`); UVs `x / s.x`, `y / s.y`.
    fn outline(&mut self, o: &Outline, z: f32, down: bool, s: Vec3, tris: &mut Vec<[u32; 3]>) {
        let normal = if down { -Vec3::Z } else { Vec3::Z };
        let uv = |p: [f64; 2]| {
            let f = |x: f64, len: f32| {
                if len > 0.0 {
                    (x / f64::from(len)).clamp(0.0, 1.0) as f32
                } else {
                    0.0
                }
            };
            [f(p[0], s.x), f(p[1], s.y)]
        };
        for ring in hole_free(o) {
            let vs: Vec<Vec3> = ring
                .iter()
                .map(|p| Vec3::new(p[0] as f32, p[1] as f32, 0.0))
                .collect();
            crate::polygon::triangulate(&vs, Vec3::Z, tris);
            if tris.is_empty() {
                continue;
            }
            let first = self.mesh.vertex_count() as u32;
            let n = self.normal(normal);
            for p in &ring {
                self.vertex(Vec3::new(p[0] as f32, p[1] as f32, z), n, uv(*p));
            }
            for t in tris.iter() {
                if down {
                    self.mesh.triangle(first + t[0], first + t[2], first + t[1]);
                } else {
                    self.mesh.triangle(first + t[0], first + t[1], first + t[2]);
                }
            }
        }
    }

    /// A planar face (a roof's; corners counter-clockwise seen from
    /// outside), ear-clipped in its plane; UVs by its own bounds in the
    /// plane: `u` horizontal, `v` up the slope (a horizontal face: `x`,
    /// `y`). A face of no area draws nothing.
    fn planar(&mut self, points: &[[f64; 3]], tris: &mut Vec<[u32; 3]>) {
        let vs: Vec<Vec3> = points
            .iter()
            .map(|p| Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32))
            .collect();
        let Some(normal) = crate::polygon::newell_normal(&vs).try_normalize() else {
            return;
        };
        crate::polygon::triangulate(&vs, normal, tris);
        if tris.is_empty() {
            return;
        }
        let u = Vec3::Z.cross(normal).try_normalize().unwrap_or(Vec3::X);
        let v = normal.cross(u);
        let (lo, hi) = vs.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), p| {
                let q = Vec3::new(p.dot(u), p.dot(v), 0.0);
                (lo.min(q), hi.max(q))
            },
        );
        let ext = hi - lo;
        let norm = |x: f32, lo: f32, e: f32| {
            if e > 0.0 {
                ((x - lo) / e).clamp(0.0, 1.0)
            } else {
                0.0
            }
        };
        let first = self.mesh.vertex_count() as u32;
        let n = self.normal(normal);
        for p in &vs {
            let uv = [norm(p.dot(u), lo.x, ext.x), norm(p.dot(v), lo.y, ext.y)];
            self.vertex(*p, n, uv);
        }
        for t in tris.iter() {
            self.mesh.triangle(first + t[0], first + t[1], first + t[2]);
        }
    }

    /// One quad per edge of each ring, `h` high, facing out of the solid.
    fn walls(&mut self, o: &Outline, h: f32) {
        if h <= 0.0 {
            return;
        }
        for ring in o.rings() {
            let n = ring.len();
            for k in 0..n {
                let a = ring[k];
                let b = ring[(k + 1) % n];
                let (dx, dy) = ((b[0] - a[0]) as f32, (b[1] - a[1]) as f32);
                let Some(normal) = Vec3::new(dy, -dx, 0.0).try_normalize() else {
                    continue;
                };
                let pa = Vec3::new(a[0] as f32, a[1] as f32, 0.0);
                let pb = Vec3::new(b[0] as f32, b[1] as f32, 0.0);
                let up = Vec3::new(0.0, 0.0, h);
                self.quad(
                    [pa, pb, pb + up, pa + up],
                    normal,
                    [[0., 0.], [1., 0.], [1., 1.], [0., 1.]],
                );
            }
        }
    }
}

/// The outline's polygons as rings without holes (counter-clockwise, no
/// closing point): a polygon with holes is cut by vertical lines through
/// the middle of each hole, so that every piece is simple.
fn hole_free(o: &Outline) -> Vec<Vec<[f64; 2]>> {
    let mut out = Vec::new();
    let mut work: Vec<(Outline, u32)> = vec![(o.clone(), 0)];
    while let Some((piece, depth)) = work.pop() {
        let mut cuts: Vec<f64> = Vec::new();
        for p in &piece.polygons().0 {
            if p.interiors().is_empty() || depth >= 4 {
                let mut pts: Vec<[f64; 2]> = p.exterior().coords().map(|c| [c.x, c.y]).collect();
                if pts.len() > 1 && pts.first() == pts.last() {
                    pts.pop();
                }
                out.push(pts);
                // Past the depth limit (a hole the cuts never opened, only
                // numerically possible), holes are left filled.
                continue;
            }
            for hole in p.interiors() {
                let (lo, hi) = hole
                    .coords()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), c| {
                        (lo.min(c.x), hi.max(c.x))
                    });
                if lo.is_finite() && hi.is_finite() {
                    cuts.push(0.5 * (lo + hi));
                }
            }
        }
        if cuts.is_empty() {
            continue;
        }
        // Only the polygons with holes are cut; the others are out already.
        let holed: Vec<_> = piece
            .polygons()
            .0
            .iter()
            .filter(|p| !p.interiors().is_empty())
            .cloned()
            .collect();
        let holed = Outline::new(holed.into());
        let Some((lo, hi)) = holed.bounds() else {
            continue;
        };
        cuts.sort_by(f64::total_cmp);
        cuts.dedup();
        let mut edges = vec![lo[0]];
        edges.extend(cuts.into_iter().filter(|&x| x > lo[0] && x < hi[0]));
        edges.push(hi[0]);
        for w in edges.windows(2) {
            if let Some(slab) = holed.clip_slab(0, w[0], w[1] - w[0]) {
                work.push((slab.translated(w[0], 0.0), depth + 1));
            }
        }
    }
    out
}

/// Append `m` (with bounds `lo`, `hi`) fitted to `scope` (module
/// documentation), with box-projected UVs. `false` (nothing appended)
/// when the fit is degenerate.
fn append_fitted(out: &mut MeshData, m: &MeshData, lo: Vec3, hi: Vec3, scope: &Scope) -> bool {
    let ext = hi - lo;
    let size = scope.size;
    if !(ext.is_finite() && size.is_finite()) {
        return false;
    }
    // Scale per axis: the scope's size over the asset's; a zero-size scope
    // axis takes the mean of the others; a flat asset axis stays flat.
    let mut scale = [None::<f32>; 3];
    for i in 0..3 {
        if ext[i] > 0.0 && size[i] > 0.0 {
            scale[i] = Some(size[i] / ext[i]);
        }
    }
    let known: Vec<f32> = scale.iter().flatten().copied().collect();
    if known.is_empty() {
        return false;
    }
    let mean = known.iter().sum::<f32>() / known.len() as f32;
    let s = Vec3::from_array(std::array::from_fn(|i| match scale[i] {
        Some(x) => x,
        None if ext[i] > 0.0 => mean,
        None => 1.0,
    }));
    let rot = scope.rotation();
    let base = out.positions.len() as u32;
    for (p, n) in m.positions.iter().zip(&m.normals) {
        let p = Vec3::from_array(*p);
        let n = Vec3::from_array(*n);
        let local = (p - lo) * s;
        let normal = (n / s).normalize_or(n);
        // Box projection: the plane the normal leans to most.
        let t = Vec3::from_array(std::array::from_fn(|i| {
            if ext[i] > 0.0 {
                ((p[i] - lo[i]) / ext[i]).clamp(0.0, 1.0)
            } else {
                0.0
            }
        }));
        let a = normal.abs();
        let uv = if a.x >= a.y && a.x >= a.z {
            [t.z, t.y]
        } else if a.y >= a.z {
            [t.x, t.z]
        } else {
            [t.x, t.y]
        };
        let world = scope.origin + rot * local;
        out.vertex_uv(
            to_model(world),
            to_model(rot * normal).normalize_or(Vec3::Y),
            uv,
        );
    }
    for t in m.indices.chunks_exact(3) {
        out.triangle(base + t[0], base + t[1], base + t[2]);
    }
    true
}

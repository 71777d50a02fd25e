//! The builder of a shape model (see the parent module): the tree walked
//! in order, terminal shapes and inserts turned into groups of meshes,
//! materials and textures keyed and shared, assets loaded once.

use super::*;

/// Materials are keyed by (material, colour in 8 bits, texture).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(super) struct MatKey {
    pub(super) material: Option<u32>,
    pub(super) color: Option<[u8; 3]>,
    pub(super) texture: Option<u32>,
}

/// A loaded insert asset.
pub(super) enum Asset {
    Mesh(MeshData, Vec3, Vec3),
    Unloaded,
}

pub(super) struct ShapeBuilder<'a> {
    pub(super) program: &'a ShapeProgram,
    pub(super) assets: &'a ShapeAssets,
    pub(super) options: &'a BuildOptions,
    pub(super) materials: Vec<ModelMaterial>,
    pub(super) parts: Vec<Part>,
    pub(super) by_key: HashMap<MatKey, usize>,
    /// Per asset id, its mesh and bounds, loaded on first use.
    pub(super) meshes: Vec<Asset>,
    /// Per texture id, its index in `textures`, loaded on first use.
    pub(super) texture_index: Vec<Option<usize>>,
    pub(super) textures: Vec<ModelTexture>,
    pub(super) groups: Vec<ShapeGroup>,
    pub(super) dropped: usize,
    pub(super) shapes: usize,
    pub(super) inserts: usize,
    /// Bytes of the loaded meshes and textures.
    pub(super) loaded_bytes: u64,
    pub(super) tris: Vec<[u32; 3]>,
    /// Per attribute set of the tree (`AttrId`): its part, once made.
    pub(super) attr_parts: Vec<Option<usize>>,
    /// Per attribute set: the vertices, triangles and picks its box and
    /// rectangle shapes will draw at most (reserved when its part is
    /// made).
    pub(super) attr_sizes: Vec<(usize, usize, usize)>,
    /// The attributes each part was made for (a joined builder makes the
    /// other's new parts from them, [`ShapeBuilder::join`]).
    pub(super) attrs_of: HashMap<MatKey, Attributes>,
    /// Set when the tree predicted the whole model's size within the
    /// limit: no group's check is needed.
    pub(super) within_budget: bool,
    /// Focus and context: how each node is drawn ([`Cut`]).
    pub(super) cut: Option<&'a [Cut]>,
    /// Built in halves: per part, the bounds of this half's vertices
    /// (empty otherwise), and after [`ShapeBuilder::join`] the other
    /// half's in `tail_bounds`.
    pub(super) bounds: Vec<grm_turtle::Aabb>,
    pub(super) tail_bounds: Vec<grm_turtle::Aabb>,
}

impl<'a> ShapeBuilder<'a> {
    pub(super) fn new(
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
    pub(super) fn cut_of(&self, i: usize) -> Cut {
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
    pub(super) fn plan(
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
    pub(super) fn plan_tail(&mut self, tail: Tail) {
        self.attr_parts = vec![None; tail.sizes.len()];
        self.attr_sizes = tail.sizes;
        self.groups.reserve(tail.groups);
    }

    /// Draw the groups of the nodes in `range` (in node order).
    pub(super) fn build_range(
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
    pub(super) fn join(&mut self, other: ShapeBuilder<'a>) -> Result<(), GeomError> {
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
    pub(super) fn part_of(&mut self, tree: &ShapeTree, id: NodeId) -> Result<usize, GeomError> {
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
    pub(super) fn part(&mut self, a: Attributes) -> Result<usize, GeomError> {
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
    pub(super) fn texture(&mut self, t: grm_shape::TextureId) -> Result<usize, GeomError> {
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
    pub(super) fn spans_since(&self, before: &[(u32, u32)]) -> smallvec::SmallVec<[GroupSpan; 1]> {
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

    pub(super) fn pick(&mut self, part: usize, before: usize, node: NodeId) {
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
    pub(super) fn footprint(&self) -> Footprint {
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
    pub(super) fn bytes_of(&self, f: &Footprint, groups: u64, transparent: bool) -> u64 {
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
    pub(super) fn predicted_bytes(&self, f: &Footprint) -> u64 {
        let g = f.picks;
        self.bytes_of(f, g, true).max(self.bytes_of(f, g, false))
    }

    pub(super) fn check_budget(&self) -> Result<(), GeomError> {
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
    pub(super) fn draw_shape(
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
    pub(super) fn draw_insert(&mut self, tree: &ShapeTree, id: NodeId) -> Result<(), GeomError> {
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
    pub(super) fn load(&mut self, a: grm_shape::AssetId) -> Result<(), GeomError> {
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

    pub(super) fn finish(self) -> Model {
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

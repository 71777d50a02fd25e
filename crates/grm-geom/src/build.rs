//! Derive mode's model builder: an interpretation's turtle output (bones,
//! instances, paints) turned into the parts, meshes and materials of a
//! [`Model`], with the unit shapes built once and materials keyed by paint.

use super::*;

/// [`build_from_interpretation`], meshing what `drawn` keeps
/// ([`build_model_drawn`]).
pub(crate) fn build_interpretation(
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
pub(crate) struct UnitShapes {
    pub(crate) cylinder: MeshData,
    pub(crate) cone: MeshData,
    pub(crate) sphere: MeshData,
    pub(crate) cube: MeshData,
    pub(crate) disc: MeshData,
}

impl UnitShapes {
    pub(crate) fn new(segments: u32) -> UnitShapes {
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
    pub(crate) fn of<'a>(
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
pub(crate) enum PaintKey {
    Palette(u32),
    /// Quantised to 8 bits per channel.
    Rgb([u8; 3]),
    Material(u32),
}

pub(crate) fn to_u8(x: f32) -> u8 {
    (x.clamp(0.0, 1.0) * 255.0).round() as u8
}

impl PaintKey {
    pub(crate) fn of(p: Paint) -> PaintKey {
        match p {
            Paint::Palette(i) => PaintKey::Palette(i % grm_turtle::PALETTE.len() as u32),
            Paint::Rgb(c) => PaintKey::Rgb(c.map(to_u8)),
            Paint::Material(m) => PaintKey::Material(m.0),
        }
    }
}

pub(crate) struct Builder<'a> {
    pub(crate) program: &'a Program,
    /// Meta-parameter values of the run and the constants' values with
    /// them, for material fields that depend on meta-parameters.
    pub(crate) params: Vec<Value>,
    pub(crate) globals: Vec<Value>,
    pub(crate) declared: Vec<ModelMaterial>,
    pub(crate) materials: Vec<ModelMaterial>,
    pub(crate) parts: Vec<Part>,
    pub(crate) by_key: HashMap<PaintKey, usize>,
    pub(crate) dropped: usize,
    pub(crate) bare_bones: usize,
    pub(crate) footprint: Footprint,
}

impl<'a> Builder<'a> {
    pub(crate) fn new(
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
    pub(crate) fn evaluate(&self, decl: &grm_sema::Material) -> ModelMaterial {
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
    pub(crate) fn check_paints(&self, s: &Interpretation) -> Result<(), GeomError> {
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

    pub(crate) fn eval(&self, e: &grm_sema::TExpr) -> Option<Value> {
        e.constant().or_else(|| {
            let env = grm_sema::eval::Env {
                params: &self.params,
                globals: &self.globals,
                bindings: &[],
            };
            grm_sema::eval::eval(e, &env).ok()
        })
    }

    pub(crate) fn material_of(&self, key: PaintKey) -> ModelMaterial {
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

    pub(crate) fn part(&mut self, paint: Paint) -> usize {
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

    pub(crate) fn pick(
        &mut self,
        part: usize,
        before: usize,
        source: PartSource,
        module: u32,
        origin: u32,
    ) {
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

    pub(crate) fn finish(mut self, skeleton: Interpretation) -> Model {
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

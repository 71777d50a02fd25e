//! Property tests over random skeletons and polygons (grm-testkit's seeded
//! generator; `GRM_TEST_SEED=n` draws other inputs, `scripts/soak.sh`).
//!
//! * Tubes: for random bone trees (chains that turn by up to 180 degrees,
//!   lateral branches, jumps, zero-length bones, widths from 0 up), every
//!   part is an indexed mesh with indices in range, finite positions and
//!   unit normals; at moderate scales the model is a union of closed,
//!   consistently oriented surfaces and every tube triangle faces away
//!   from its bone's axis (no tube folds inside out at a bend); the picks
//!   cover the triangles in order.
//! * Export: random models (tubes in palette colours, explicit colours and
//!   declared materials, primitives, polygons) read back from glb, OBJ +
//!   MTL, binary and ASCII PLY and SVG as they were built.
//! * Polygons: a random simple (star-shaped) polygon in a random plane,
//!   with collinear and repeated vertices, triangulates into at most
//!   `n - 2` triangles that all face the Newell normal and whose areas add
//!   up to the polygon's (so they do not overlap).

mod common;

use common::edges_balanced;
use glam::{Quat, Vec3};
use grm_geom::{BuildOptions, MeshData, Model, PartSource, build_from_interpretation, polygon};
use grm_testkit::Rng;
use grm_turtle::{Bone, Interpretation, NO_ORIGIN, Paint};

fn unit_vector(rng: &mut Rng) -> Vec3 {
    loop {
        let v = Vec3::new(
            rng.range_f32(-1.0, 1.0),
            rng.range_f32(-1.0, 1.0),
            rng.range_f32(-1.0, 1.0),
        );
        let l = v.length();
        if l > 0.1 && l <= 1.0 {
            return v / l;
        }
    }
}

/// `d` turned by `angle` radians about a random axis perpendicular to it.
fn turned(rng: &mut Rng, d: Vec3, angle: f32) -> Vec3 {
    let axis = d
        .cross(unit_vector(rng))
        .normalize_or(d.any_orthonormal_vector());
    (Quat::from_axis_angle(axis, angle) * d).normalize()
}

/// A random skeleton as a turtle would make one: each bone continues the
/// current bone, starts a branch at an earlier bone's tip, or starts after
/// a jump; `scale` sets the lengths and `widths` the range of widths.
fn skeleton(rng: &mut Rng, n: usize, scale: f32, widths: (f32, f32)) -> Vec<Bone> {
    let mut bones: Vec<Bone> = Vec::with_capacity(n);
    let mut dirs: Vec<Vec3> = Vec::with_capacity(n);
    let width = |rng: &mut Rng| {
        if rng.below(8u32) == 0 {
            0.0
        } else {
            rng.range_f32(widths.0, widths.1)
        }
    };
    for i in 0..n {
        let kind = if i == 0 { 9 } else { rng.below(10u32) };
        let (base, parent, from_dir, width_base) = match kind {
            // Continue the last bone, or branch off an earlier one.
            0..=6 => {
                let p = if kind <= 4 { i - 1 } else { rng.below(i) };
                let b = &bones[p];
                (b.tip, Some(p as u32), dirs[p], b.width_tip)
            }
            // A jump (after `f`): a new base, the last bone still current.
            7 | 8 => {
                let p = i - 1;
                let off = unit_vector(rng) * rng.range_f32(0.1, 2.0) * scale;
                (bones[p].tip + off, Some(p as u32), dirs[p], width(rng))
            }
            _ => (
                Vec3::new(
                    rng.range_f32(-5.0, 5.0),
                    rng.range_f32(-5.0, 5.0),
                    rng.range_f32(-5.0, 5.0),
                ) * scale,
                None,
                unit_vector(rng),
                width(rng),
            ),
        };
        // Mostly small turns, sometimes sharp ones, reversals and exact
        // repeats (zero angle).
        let angle = match rng.below(10u32) {
            0 => 0.0,
            1 => std::f32::consts::PI,
            2 => rng.range_f32(1.5, 3.1),
            3 => std::f32::consts::FRAC_PI_2,
            _ => rng.range_f32(0.0, 0.8),
        };
        let d = turned(rng, from_dir, angle);
        let len = match rng.below(12u32) {
            0 => 0.0,
            1 => 1e-7 * scale,
            _ => rng.range_f32(0.05, 1.5) * scale,
        };
        let left = d.any_orthonormal_vector();
        bones.push(Bone {
            base,
            tip: base + d * len,
            left,
            parent,
            width_base,
            width_tip: width(rng),
            paint: Paint::Palette(rng.below(3u32)),
            module: i as u32,
            origin: NO_ORIGIN,
        });
        dirs.push(d);
    }
    bones
}

fn build(bones: Vec<Bone>) -> Model {
    let program = common::program("mem.grm", "system S { axiom F; }");
    let skeleton = Interpretation {
        bones,
        ..Interpretation::default()
    };
    build_from_interpretation(&program, skeleton, &BuildOptions::default(), &[]).expect("builds")
}

/// Indices in range, finite positions, one unit normal per position, and
/// the picks cover every triangle in order.
fn well_formed(model: &Model) -> Result<(), String> {
    for (k, part) in model.parts.iter().enumerate() {
        let m = &part.mesh;
        if m.normals.len() != m.positions.len() {
            return Err(format!("part {k}: normals and positions differ in number"));
        }
        if m.indices.len() % 3 != 0 {
            return Err(format!("part {k}: {} indices", m.indices.len()));
        }
        if let Some(i) = m.indices.iter().find(|&&i| i as usize >= m.positions.len()) {
            return Err(format!("part {k}: index {i} out of range"));
        }
        if let Some(p) = m
            .positions
            .iter()
            .find(|p| !p.iter().all(|x| x.is_finite()))
        {
            return Err(format!("part {k}: position {p:?}"));
        }
        if let Some(n) = m
            .normals
            .iter()
            .find(|n| (Vec3::from_array(**n).length() - 1.0).abs() > 1e-3)
        {
            return Err(format!("part {k}: normal {n:?}"));
        }
        let mut next = 0;
        for p in &part.picks {
            if p.first_triangle != next {
                return Err(format!("part {k}: picks not contiguous at {next}"));
            }
            next = p.first_triangle + p.triangle_count;
        }
        if next as usize != m.indices.len() / 3 {
            return Err(format!("part {k}: picks cover {next} triangles"));
        }
    }
    Ok(())
}

/// All parts as one mesh.
fn union(model: &Model) -> MeshData {
    let mut all = MeshData::default();
    for part in &model.parts {
        let first = all.positions.len() as u32;
        all.positions.extend_from_slice(&part.mesh.positions);
        all.normals.extend_from_slice(&part.mesh.normals);
        all.indices
            .extend(part.mesh.indices.iter().map(|i| i + first));
    }
    all
}

/// The first tube triangle that faces its bone's axis (a tube folded
/// inside out, as a mitre deeper than its tube is long makes one).
fn folded(model: &Model, bones: &[Bone]) -> Option<String> {
    for (k, part) in model.parts.iter().enumerate() {
        let m = &part.mesh;
        for pick in &part.picks {
            let PartSource::Bone(i) = pick.source else {
                continue;
            };
            let b = &bones[i as usize];
            let d = (b.tip - b.base).normalize();
            let first = pick.first_triangle as usize;
            for t in first..first + pick.triangle_count as usize {
                let p = |j: usize| Vec3::from_array(m.positions[m.indices[3 * t + j] as usize]);
                let g = (p(1) - p(0)).cross(p(2) - p(0));
                let c = (p(0) + p(1) + p(2)) / 3.0 - b.base;
                let radial = c - d * c.dot(d);
                // Triangles near a pinched elbow may stand almost edge-on
                // to the axis; a folded one faces it.
                let facing = g.normalize().dot(radial.normalize());
                if g.length() > 1e-9 && radial.length() > 1e-5 && facing < -0.25 {
                    return Some(format!(
                        "part {k}: triangle {t} of bone {i}'s tube faces its axis ({facing})"
                    ));
                }
            }
        }
    }
    None
}

fn describe(bones: &[Bone]) -> String {
    bones
        .iter()
        .enumerate()
        .map(|(i, b)| {
            format!(
                "  {i}: {:?} -> {:?} parent {:?} widths {} {}\n",
                b.base, b.tip, b.parent, b.width_base, b.width_tip
            )
        })
        .collect()
}

#[test]
fn random_skeletons_give_closed_well_formed_tubes() {
    let mut rng = Rng::seeded(0x6e0_7be5);
    for case in 0..300 {
        let n = 1 + rng.below(24usize);
        let bones = skeleton(&mut rng, n, 1.0, (0.02, 0.3));
        let model = build(bones.clone());
        if let Err(e) = well_formed(&model) {
            panic!("case {case}: {e}\n{}", describe(&bones));
        }
        // A chain whose paint changes is split between two parts at a
        // shared ring, and tubes may touch: the union is closed.
        let all = union(&model);
        assert!(
            edges_balanced(&all),
            "case {case}: the tubes are not closed\n{}",
            describe(&bones)
        );
        if let Some(e) = folded(&model, &bones) {
            panic!("case {case}: {e}\n{}", describe(&bones));
        }
    }
}

#[test]
fn extreme_skeletons_stay_finite() {
    let mut rng = Rng::seeded(0xe87_7e3e);
    for case in 0..200 {
        let n = 1 + rng.below(16usize);
        let scale = *rng.pick(&[1e-4f32, 1e-2, 1.0, 1e3, 1e5]);
        let widths = *rng.pick(&[(1e-7f32, 1e-5), (1e-3, 1.0), (10.0, 1e4)]);
        let bones = skeleton(&mut rng, n, scale, (widths.0 * scale, widths.1 * scale));
        let model = build(bones.clone());
        if let Err(e) = well_formed(&model) {
            panic!("case {case} (scale {scale}): {e}\n{}", describe(&bones));
        }
        // Finite, or empty when no bone got a tube (min > max).
        let b = model.stats.bounds;
        assert!(
            (b.min.is_finite() && b.max.is_finite())
                || (model.stats.triangles == 0 && b.min.x > b.max.x),
            "case {case}: bounds {b:?}"
        );
    }
}

/// Twice the signed area of triangle `t` of `vs`, along `normal`.
fn signed_area2(vs: &[Vec3], t: [u32; 3], normal: Vec3) -> f32 {
    let p = |i: u32| vs[i as usize];
    (p(t[1]) - p(t[0])).cross(p(t[2]) - p(t[0])).dot(normal)
}

/// A simple star-shaped polygon around the origin of the plane through
/// `centre` with normal `n`, counter-clockwise about `n`; some vertices lie
/// on the segment between their neighbours (collinear) and some repeat.
fn star_polygon(rng: &mut Rng, centre: Vec3, n: Vec3) -> Vec<Vec3> {
    let u = n.any_orthonormal_vector();
    let v = n.cross(u);
    let count = 3 + rng.below(14usize);
    // Gaps under half a turn (at most 1.4 / 3 of one), so the centre sees
    // every edge from inside and the polygon is simple.
    let step = std::f32::consts::TAU / count as f32;
    let angles: Vec<f32> = (0..count)
        .map(|k| (k as f32 + rng.range_f32(0.0, 0.4)) * step)
        .collect();
    let mut pts: Vec<Vec3> = angles
        .iter()
        .map(|&a| {
            let r = if rng.below(3u32) == 0 {
                1.0
            } else {
                rng.range_f32(0.2, 1.0)
            };
            centre + (u * a.cos() + v * a.sin()) * r
        })
        .collect();
    // Collinear points: the midpoint of a random edge; repeats.
    for _ in 0..rng.below(3usize) {
        let i = rng.below(pts.len());
        let j = (i + 1) % pts.len();
        let t = *rng.pick(&[0.5f32, 0.25]);
        let m = pts[i].lerp(pts[j], t);
        // Between `i` and `j`: at `j`, or at the end when `j` wraps to 0.
        if j == 0 {
            pts.push(m);
        } else {
            pts.insert(j, m);
        }
    }
    if rng.below(4u32) == 0 && pts.len() > 3 {
        let i = rng.below(pts.len());
        let p = pts[i];
        pts.insert(i, p);
    }
    pts
}

/// Area of a polygon in its plane from its 2D shoelace formula, which is
/// what `newell_normal` computes; checked independently by fanning from
/// the star's centre, which lies inside.
fn star_area(pts: &[Vec3], centre: Vec3, n: Vec3) -> f32 {
    (0..pts.len())
        .map(|i| {
            let (a, b) = (pts[i] - centre, pts[(i + 1) % pts.len()] - centre);
            0.5 * a.cross(b).dot(n)
        })
        .sum()
}

#[test]
fn random_simple_polygons_triangulate_exactly() {
    let mut rng = Rng::seeded(0x9017_90e5);
    let mut tris = Vec::new();
    for case in 0..2000 {
        let n = unit_vector(&mut rng);
        let centre = Vec3::new(
            rng.range_f32(-3.0, 3.0),
            rng.range_f32(-3.0, 3.0),
            rng.range_f32(-3.0, 3.0),
        );
        let pts = star_polygon(&mut rng, centre, n);
        if pts.len() < 3 {
            continue;
        }
        let want = star_area(&pts, centre, n);
        let newell = polygon::newell_normal(&pts);
        let normal = newell.normalize();
        assert!(
            (0.5 * newell.length() - want).abs() < 1e-4 * want.max(1.0),
            "case {case}: Newell area {} against {want}",
            0.5 * newell.length()
        );
        polygon::triangulate(&pts, normal, &mut tris);
        let got: f32 = tris
            .iter()
            .map(|t| 0.5 * signed_area2(&pts, *t, normal))
            .sum();
        let flipped = tris
            .iter()
            .filter(|t| signed_area2(&pts, **t, normal) < -1e-5)
            .count();
        assert!(
            tris.len() <= pts.len() - 2
                && flipped == 0
                && (got - want).abs() < 1e-4 * want.max(1.0),
            "case {case}: {} triangles for {} vertices, {flipped} facing away, area {got} against {want}\n{pts:?}\n{tris:?}",
            tris.len(),
            pts.len()
        );
    }
}

/// A random model: a random skeleton painted with palette colours,
/// explicit colours and declared materials (random properties, some
/// outside 0..1), plus primitives (some with a singular transform) and
/// star polygons; `(program, model)`.
fn random_model(rng: &mut Rng) -> (grm_sema::Program, Model) {
    use glam::Affine3A;
    use grm_sema::MaterialId;
    use grm_turtle::{Instance, InstanceKind, Polygon};
    let materials = rng.below(4usize);
    let mut text = String::new();
    for k in 0..materials {
        let mut v = || format!("{}", rng.range_f32(-0.2, 1.2));
        let (r, g, b, e) = (v(), v(), v(), v());
        let (rough, metal, opacity) = (v(), v(), v());
        text.push_str(&format!(
            "material m{k} {{ color = rgb({r}, {g}, {b}); emissive = rgb({e}, 0, 0); \
             roughness = {rough}; metallic = {metal}; opacity = {opacity}; }}\n"
        ));
    }
    text.push_str("system S { axiom F; }\n");
    let program = common::program("mem.grm", &text);
    let paint = |rng: &mut Rng| match rng.below(3u32) {
        0 => Paint::Palette(rng.below(5u32)),
        1 if materials > 0 => Paint::Material(MaterialId(rng.below(materials as u32))),
        _ => Paint::Rgb([rng.range_f32(0.0, 1.0), 0.5, rng.range_f32(0.0, 1.0)]),
    };
    let n = rng.below(12usize);
    let mut bones = skeleton(rng, n, 1.0, (0.02, 0.3));
    for b in &mut bones {
        b.paint = paint(rng);
    }
    let mut s = Interpretation {
        bones,
        ..Interpretation::default()
    };
    let kinds = [
        InstanceKind::Cylinder,
        InstanceKind::Cone,
        InstanceKind::Sphere,
        InstanceKind::Box,
        InstanceKind::Disc,
    ];
    for m in 0..rng.below(5u32) {
        let scale = if rng.below(6u32) == 0 {
            Vec3::new(1.0, 0.0, 1.0)
        } else {
            Vec3::new(
                rng.range_f32(0.1, 2.0),
                rng.range_f32(0.1, 2.0),
                rng.range_f32(0.1, 2.0),
            )
        };
        let rotation = Quat::from_axis_angle(unit_vector(rng), rng.range_f32(0.0, 6.0));
        let at = Vec3::new(rng.range_f32(-3.0, 3.0), 0.0, rng.range_f32(-3.0, 3.0));
        s.instances.push(Instance {
            kind: *rng.pick(&kinds),
            transform: Affine3A::from_scale_rotation_translation(scale, rotation, at),
            paint: paint(rng),
            bone: None,
            module: m,
            origin: NO_ORIGIN,
        });
    }
    for m in 0..rng.below(3u32) {
        let centre = Vec3::new(rng.range_f32(-3.0, 3.0), 1.0, 0.0);
        let normal = unit_vector(rng);
        let pts = star_polygon(rng, centre, normal);
        s.polygons.push(Polygon {
            first: s.polygon_vertices.len() as u32,
            len: pts.len() as u32,
            paint: paint(rng),
            module: 100 + m,
            origin: NO_ORIGIN,
        });
        s.polygon_vertices.extend(pts);
    }
    let model =
        build_from_interpretation(&program, s, &BuildOptions::default(), &[]).expect("builds");
    (program, model)
}

/// Every format reads back as what was built: the glb (validated by
/// `gltf`) holds each non-empty part's positions, normals and indices bit
/// for bit with exact bounds and its material's factors (all in 0..1,
/// none null); OBJ + MTL (read by `tobj`) the same triangles, normals and
/// materials; binary and ASCII PLY every vertex, colour and face; the SVG
/// one line per bone and one path per polygon, all numbers finite.
#[test]
fn random_models_read_back_from_every_format() {
    use grm_geom::{ExportFormat, export_as};
    let mut rng = Rng::seeded(0xe8_9081);
    let dir = tempfile::tempdir().expect("tempdir");
    for case in 0..60 {
        let (_program, model) = random_model(&mut rng);
        let ctx = |what: &str| format!("case {case}: {what}");
        let parts: Vec<&grm_geom::Part> =
            model.parts.iter().filter(|p| !p.mesh.is_empty()).collect();
        for m in &model.materials {
            let floats = [m.roughness, m.metallic, m.opacity];
            let all = m.color.iter().chain(&m.emissive).chain(&floats);
            for x in all {
                assert!(
                    (0.0..=1.0).contains(x),
                    "{}",
                    ctx(&format!("material {m:?}"))
                );
            }
        }

        // glb.
        let path = dir.path().join(format!("m{case}.glb"));
        export_as(&model, &path, ExportFormat::Glb).expect("exports");
        let bytes = std::fs::read(&path).expect("written");
        let gltf =
            gltf::Gltf::from_slice(&bytes).unwrap_or_else(|e| panic!("{}", ctx(&e.to_string())));
        let prims: Vec<gltf::Primitive> = gltf.meshes().flat_map(|m| m.primitives()).collect();
        assert_eq!(prims.len(), parts.len(), "{}", ctx("primitives"));
        let blob = gltf.blob.clone().unwrap_or_default();
        for (prim, part) in prims.iter().zip(&parts) {
            let reader = prim.reader(|_| Some(&blob[..]));
            let positions: Vec<[f32; 3]> = reader.read_positions().expect("positions").collect();
            let normals: Vec<[f32; 3]> = reader.read_normals().expect("normals").collect();
            let indices: Vec<u32> = reader.read_indices().expect("indices").into_u32().collect();
            assert_eq!(positions, part.mesh.positions, "{}", ctx("glb positions"));
            assert_eq!(normals, part.mesh.normals, "{}", ctx("glb normals"));
            assert_eq!(indices, part.mesh.indices, "{}", ctx("glb indices"));
            let mut lo = Vec3::splat(f32::INFINITY);
            let mut hi = Vec3::splat(f32::NEG_INFINITY);
            for p in &positions {
                lo = lo.min(Vec3::from_array(*p));
                hi = hi.max(Vec3::from_array(*p));
            }
            let bb = prim.bounding_box();
            assert_eq!(
                (bb.min, bb.max),
                (lo.to_array(), hi.to_array()),
                "{}",
                ctx("bounds")
            );
            let mat = prim.material();
            assert_eq!(
                mat.index(),
                Some(part.material),
                "{}",
                ctx("material index")
            );
            let m = &model.materials[part.material];
            let pbr = mat.pbr_metallic_roughness();
            assert_eq!(mat.name(), Some(m.name.as_str()));
            assert_eq!(
                (
                    pbr.base_color_factor(),
                    pbr.metallic_factor(),
                    pbr.roughness_factor()
                ),
                (
                    [m.color[0], m.color[1], m.color[2], m.opacity],
                    m.metallic,
                    m.roughness
                ),
                "{}",
                ctx("material factors")
            );
            assert_eq!(mat.emissive_factor(), m.emissive, "{}", ctx("emissive"));
        }

        // OBJ + MTL: triangle by triangle (tobj renumbers vertices).
        let path = dir.path().join(format!("m{case}.obj"));
        export_as(&model, &path, ExportFormat::Obj).expect("exports");
        let (objs, mtls) = tobj::load_obj(&path, &tobj::LoadOptions::default()).expect("obj loads");
        let mtls = mtls.expect("mtl loads");
        let objs: Vec<&tobj::Model> = objs.iter().filter(|o| !o.mesh.indices.is_empty()).collect();
        assert_eq!(objs.len(), parts.len(), "{}", ctx("objects"));
        for (o, part) in objs.iter().zip(&parts) {
            let (om, pm) = (&o.mesh, &part.mesh);
            assert_eq!(
                om.indices.len(),
                pm.indices.len(),
                "{}",
                ctx("obj triangles")
            );
            let at = |v: &[f32], i: u32| {
                [
                    v[3 * i as usize],
                    v[3 * i as usize + 1],
                    v[3 * i as usize + 2],
                ]
            };
            for (k, &i) in pm.indices.iter().enumerate() {
                let i = i as usize;
                assert_eq!(
                    at(&om.positions, om.indices[k]),
                    pm.positions[i],
                    "{}",
                    ctx("obj position")
                );
                assert_eq!(
                    at(&om.normals, om.normal_indices[k]),
                    pm.normals[i],
                    "{}",
                    ctx("obj normal")
                );
            }
            let mtl = &mtls[om.material_id.expect("usemtl")];
            let m = &model.materials[part.material];
            assert_eq!(mtl.name, m.name);
            assert_eq!(
                (mtl.diffuse, mtl.dissolve),
                (Some(m.color), Some(m.opacity)),
                "{}",
                ctx("mtl")
            );
        }

        // PLY, binary and ASCII.
        for (format, name) in [
            (ExportFormat::Ply, "b.ply"),
            (ExportFormat::PlyAscii, "a.ply"),
        ] {
            let path = dir.path().join(format!("m{case}{name}"));
            export_as(&model, &path, format).expect("exports");
            let bytes = std::fs::read(&path).expect("written");
            let (vertices, faces) = read_ply(&bytes).unwrap_or_else(|e| panic!("{}", ctx(&e)));
            let mut want_v = Vec::new();
            let mut want_f = Vec::new();
            // sRGB-encoded colours; +y up turned to PLY's +z up.
            let srgb = |x: f32| {
                let x = x.clamp(0.0, 1.0);
                let s = if x <= 0.003_130_8 {
                    12.92 * x
                } else {
                    1.055 * x.powf(1.0 / 2.4) - 0.055
                };
                (s * 255.0 + 0.5) as u8
            };
            let z_up = |[x, y, z]: [f32; 3]| [x, -z, y];
            if model.parts.iter().all(|p| p.mesh.positions.is_empty()) {
                // An empty model: one vertex, no faces (Blender needs one).
                want_v.push(([0.0; 3], [0.0, 0.0, 1.0], [204; 3]));
            }
            for part in &model.parts {
                let base = want_v.len() as u32;
                let c = model.materials[part.material].color.map(srgb);
                for (p, n) in part.mesh.positions.iter().zip(&part.mesh.normals) {
                    want_v.push((z_up(*p), z_up(*n), c));
                }
                for t in part.mesh.indices.chunks_exact(3) {
                    want_f.push([t[0] + base, t[1] + base, t[2] + base]);
                }
            }
            assert!(vertices == want_v, "{}", ctx(&format!("{name} vertices")));
            assert_eq!(faces, want_f, "{}", ctx(&format!("{name} faces")));
        }

        // SVG.
        let path = dir.path().join(format!("m{case}.svg"));
        export_as(&model, &path, ExportFormat::Svg).expect("exports");
        let svg = std::fs::read_to_string(&path).expect("written");
        assert_eq!(svg.matches("<line ").count(), model.skeleton.bones.len());
        assert_eq!(svg.matches("<path ").count(), model.skeleton.polygons.len());
        assert!(
            !svg.contains("NaN") && !svg.contains("inf"),
            "{}",
            ctx("non-finite SVG number")
        );
        assert!(svg.trim_end().ends_with("</svg>"));
    }
}

type PlyVertex = ([f32; 3], [f32; 3], [u8; 3]);

/// A reader for the PLY files grm writes (x y z nx ny nz as floats, red
/// green blue as uchar; faces as a uchar-counted list of uints), binary
/// little-endian or ASCII, checking the header on the way.
fn read_ply(bytes: &[u8]) -> Result<(Vec<PlyVertex>, Vec<[u32; 3]>), String> {
    let end = b"end_header\n";
    let at = bytes
        .windows(end.len())
        .position(|w| w == end)
        .ok_or("no end_header")?;
    let header = std::str::from_utf8(&bytes[..at]).map_err(|e| e.to_string())?;
    let body = &bytes[at + end.len()..];
    let mut lines = header.lines();
    if lines.next() != Some("ply") {
        return Err("no magic".into());
    }
    let ascii = match lines.next() {
        Some("format ascii 1.0") => true,
        Some("format binary_little_endian 1.0") => false,
        f => return Err(format!("format {f:?}")),
    };
    let count = |name: &str| {
        header
            .lines()
            .find_map(|l| l.strip_prefix(&format!("element {name} ")))
            .and_then(|n| n.parse::<usize>().ok())
            .ok_or(format!("no {name} count"))
    };
    let (nv, nf) = (count("vertex")?, count("face")?);
    let props: Vec<&str> = header
        .lines()
        .filter(|l| l.starts_with("property"))
        .collect();
    let want = [
        "property float x",
        "property float y",
        "property float z",
        "property float nx",
        "property float ny",
        "property float nz",
        "property uchar red",
        "property uchar green",
        "property uchar blue",
        "property list uchar uint vertex_indices",
    ];
    if props != want {
        return Err(format!("properties {props:?}"));
    }
    let mut vertices = Vec::with_capacity(nv);
    let mut faces = Vec::with_capacity(nf);
    if ascii {
        let text = std::str::from_utf8(body).map_err(|e| e.to_string())?;
        let mut lines = text.lines();
        for _ in 0..nv {
            let l = lines.next().ok_or("vertex line missing")?;
            let w: Vec<&str> = l.split(' ').collect();
            if w.len() != 9 {
                return Err(format!("vertex line {l:?}"));
            }
            let f = |i: usize| w[i].parse::<f32>().map_err(|e| format!("{l:?}: {e}"));
            let u = |i: usize| w[i].parse::<u8>().map_err(|e| format!("{l:?}: {e}"));
            vertices.push((
                [f(0)?, f(1)?, f(2)?],
                [f(3)?, f(4)?, f(5)?],
                [u(6)?, u(7)?, u(8)?],
            ));
        }
        for _ in 0..nf {
            let l = lines.next().ok_or("face line missing")?;
            let w: Vec<u32> = l
                .split(' ')
                .map(|x| x.parse::<u32>().map_err(|e| format!("{l:?}: {e}")))
                .collect::<Result<_, _>>()?;
            if w.len() != 4 || w[0] != 3 {
                return Err(format!("face line {l:?}"));
            }
            faces.push([w[1], w[2], w[3]]);
        }
        if lines.next().is_some() {
            return Err("trailing lines".into());
        }
    } else {
        if body.len() != nv * 27 + nf * 13 {
            return Err(format!(
                "{} body bytes for {nv} vertices and {nf} faces",
                body.len()
            ));
        }
        let f = |b: &[u8], i: usize| {
            f32::from_le_bytes([b[4 * i], b[4 * i + 1], b[4 * i + 2], b[4 * i + 3]])
        };
        for v in body[..nv * 27].chunks_exact(27) {
            vertices.push((
                [f(v, 0), f(v, 1), f(v, 2)],
                [f(v, 3), f(v, 4), f(v, 5)],
                [v[24], v[25], v[26]],
            ));
        }
        let u = |b: &[u8], at: usize| u32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]]);
        for t in body[nv * 27..].chunks_exact(13) {
            if t[0] != 3 {
                return Err(format!("a face of {} vertices", t[0]));
            }
            faces.push([u(t, 1), u(t, 5), u(t, 9)]);
        }
    }
    if let Some(i) = faces.iter().flatten().find(|&&i| i as usize >= nv) {
        return Err(format!("face index {i} of {nv} vertices"));
    }
    Ok((vertices, faces))
}

//! Shape mode: a derived shape tree as a model (grm_geom::shape) and its
//! export: exact triangle counts, every vertex inside its node's scope,
//! unit normals, UVs in [0, 1], one named glTF node per terminal shape
//! group with locators in `extras` that resolve back to the node, OBJ
//! objects per group, textures embedded, typed errors for bad names.

use std::path::PathBuf;

use glam::{Quat, Vec3};
use grm_geom::shape::{ShapeAssets, build_shape_model};
use grm_geom::{BuildOptions, GeomError, Model, ModelMaterial, PartSource};
use grm_shape::{
    Axis, Comp, CompCase, CompTarget, ExactLocator, Lot, NodeId, Op, Options, Param, Part, Program,
    ProgramBuilder, Resolution, Selector, ShapeTree, Split, derive,
};

fn leaf_obj() -> PathBuf {
    PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../examples/leaf.obj"
    ))
}

fn rgb(r: f32, g: f32, b: f32) -> Op {
    Op::Color([Param::Const(r), Param::Const(g), Param::Const(b)])
}

/// A 12 x 8 lot extruded 9 high; the front wall a facade of 3 floors by 4
/// tiles (wall | window | wall), each window a glass box 0.2 deep and a
/// leaf (the OBJ) on it; the other walls plain and textured; the roof
/// painted by its own rule (which makes nothing); no bottom.
fn building(texture: Option<&str>) -> (Program, ShapeTree) {
    let mut b = ProgramBuilder::new("house");
    let facade_tag = b.tag("facade");
    let floor_tag = b.tag("floor");
    let column_tag = b.tag("column");
    let lot = b.symbol("Lot");
    let facade = b.symbol("Facade");
    let floor = b.symbol("Floor");
    let tile = b.symbol("Tile");
    let window = b.symbol("Window");
    let wall = b.symbol("Wall");
    let side = b.symbol("Side");
    let roof = b.symbol("Roof");
    let cube = b.asset("box");
    let leaf = b.asset("leaf");
    let glass = b.material("glass");
    let mut side_ops = vec![];
    if let Some(t) = texture {
        let t = b.texture(t);
        side_ops.push(Op::Texture(t));
    }
    side_ops.push(Op::Emit(wall));
    b.rule(side, side_ops);
    b.rule(
        lot,
        vec![
            Op::Extrude(Param::Const(9.0)),
            Op::Comp(Comp {
                target: CompTarget::Faces,
                cases: vec![
                    CompCase {
                        selector: Selector::Front,
                        target: Some(facade),
                    },
                    CompCase {
                        selector: Selector::Side,
                        target: Some(side),
                    },
                    CompCase {
                        selector: Selector::Top,
                        target: Some(roof),
                    },
                ],
                tag: Some(facade_tag),
            }),
        ],
    );
    b.rule(
        facade,
        vec![Op::Repeat(Split {
            axis: Axis::Y,
            parts: vec![Part::abs(3.0, Some(floor))],
            tag: Some(floor_tag),
        })],
    );
    b.rule(
        floor,
        vec![Op::Repeat(Split {
            axis: Axis::X,
            parts: vec![Part::abs(3.0, Some(tile))],
            tag: Some(column_tag),
        })],
    );
    b.rule(
        tile,
        vec![Op::Split(Split {
            axis: Axis::X,
            parts: vec![
                Part::float(1.0, Some(wall)),
                Part::abs(1.0, Some(window)),
                Part::float(1.0, Some(wall)),
            ],
            tag: None,
        })],
    );
    b.rule(
        window,
        vec![
            Op::Size([None, None, Some(Param::Const(0.2))]),
            Op::Material(glass),
            Op::Insert(cube),
            Op::Insert(leaf),
        ],
    );
    b.rule(roof, vec![rgb(0.6, 0.2, 0.1)]);
    let program = b.build(lot).expect("program");
    let tree = derive(&program, &Lot::rectangle(12.0, 8.0), &Options::default()).expect("tree");
    (program, tree)
}

fn assets() -> ShapeAssets {
    ShapeAssets {
        materials: vec![ModelMaterial {
            name: "glass".into(),
            color: [0.2, 0.4, 0.9],
            opacity: 0.5,
            ..ModelMaterial::default()
        }],
        meshes: vec![("leaf".into(), leaf_obj())],
        ..ShapeAssets::default()
    }
}

/// Model points are y-up: `(x, y, z)` is the world's `(x, -z, y)`.
fn world(p: [f32; 3]) -> Vec3 {
    Vec3::new(p[0], -p[2], p[1])
}

fn check_mesh(model: &Model, tree: &ShapeTree) {
    for part in &model.parts {
        let m = &part.mesh;
        assert!(m.has_uvs());
        for n in &m.normals {
            let l = Vec3::from_array(*n).length();
            assert!((l - 1.0).abs() < 1e-4, "normal of length {l}");
        }
        for uv in &m.uvs {
            assert!(uv.iter().all(|x| (0.0..=1.0).contains(x)), "uv {uv:?}");
        }
        assert!(m.indices.iter().all(|&i| (i as usize) < m.positions.len()));
        // Every triangle is picked, by the node that drew it, and lies in
        // that node's scope.
        let picked: u32 = part.picks.iter().map(|p| p.triangle_count).sum();
        assert_eq!(picked as usize, m.triangle_count());
        for pick in &part.picks {
            let PartSource::Shape(node) = pick.source else {
                panic!("a shape model's pick is {:?}", pick.source);
            };
            assert_eq!(pick.module, node);
            let scope = tree.node(NodeId(node)).expect("node").scope;
            let inv: Quat = scope.rotation().inverse();
            let tris =
                pick.first_triangle as usize..(pick.first_triangle + pick.triangle_count) as usize;
            for t in tris {
                for &i in &m.indices[3 * t..3 * t + 3] {
                    let local = inv * (world(m.positions[i as usize]) - scope.origin);
                    let eps = 1e-3;
                    assert!(
                        local.cmpge(Vec3::splat(-eps)).all()
                            && local.cmple(scope.size + Vec3::splat(eps)).all(),
                        "node {node}: local {local} outside {}",
                        scope.size
                    );
                }
            }
        }
    }
}

#[test]
fn a_building_has_exact_triangles_inside_scopes_with_uvs_and_unit_normals() {
    let (program, tree) = building(None);
    let model =
        build_shape_model(&tree, &program, &assets(), &BuildOptions::default()).expect("model");
    let leaf_tris = 4;
    // 3 side walls and the roof (2 each), 24 tile walls (2 each), 12
    // windows (a box, 12, and the leaf).
    let expected = 3 * 2 + 2 + 24 * 2 + 12 * (12 + leaf_tris);
    assert_eq!(model.stats.triangles, expected);
    assert_eq!(model.stats.dropped, 0);
    // Groups: 3 side walls (`Wall` under `Side`), the roof, 24 tile
    // walls and 12 windows (each with its two inserts).
    assert_eq!(model.groups.len(), 3 + 1 + 24 + 12);
    check_mesh(&model, &tree);
    // Materials: default (walls), the painted roof, glass.
    let names: Vec<&str> = model.materials.iter().map(|m| m.name.as_str()).collect();
    // In order of first use: the roof comes before the side walls (the
    // component split's top is a child of the lot's; the walls are Side's).
    assert_eq!(names, ["rgb_99331a", "default", "glass"], "{names:?}");
    let roof = &model.materials[0];
    assert!((roof.color[0] - 0.6).abs() < 0.01);
    assert_eq!(model.materials[2].opacity, 0.5);
    // Names: readable, unique; a window's is its semantic path.
    let mut seen = std::collections::HashSet::new();
    for g in &model.groups {
        assert!(seen.insert(g.name.clone()), "{} twice", g.name);
    }
    assert!(seen.contains("Window.facade1.floor2.column3"), "{seen:?}");
    assert!(seen.contains("Roof.facade1"));
    // A tile's two walls share a semantic path: the key tells them apart.
    let walls: Vec<_> = model
        .groups
        .iter()
        .filter(|g| g.name.starts_with("Wall.facade1.floor1.column1."))
        .collect();
    assert_eq!(walls.len(), 2);
    // A window's group holds its two inserts, in the glass part.
    let w = model
        .groups
        .iter()
        .find(|g| g.name == "Window.facade1.floor1.column1")
        .expect("window");
    assert_eq!(w.spans.len(), 1);
    assert_eq!(w.spans[0].triangle_count, 12 + leaf_tris as u32);
    assert_eq!(model.parts[w.spans[0].part].material, 2);
}

#[test]
fn the_glb_has_a_named_node_per_group_with_locators_that_resolve() {
    let (program, tree) = building(None);
    let model =
        build_shape_model(&tree, &program, &assets(), &BuildOptions::default()).expect("model");
    let bytes = grm_geom::export::glb_bytes(&model).expect("glb");
    let gltf = gltf::Gltf::from_slice(&bytes).expect("valid glb");
    let scene = gltf.default_scene().expect("scene");
    let roots: Vec<_> = scene.nodes().collect();
    assert_eq!(roots.len(), 1);
    assert_eq!(roots[0].name(), Some("grm"));
    let children: Vec<_> = roots[0].children().collect();
    assert_eq!(children.len(), model.groups.len());
    assert_eq!(gltf.nodes().count(), 1 + model.groups.len());
    for (node, g) in children.iter().zip(&model.groups) {
        assert_eq!(node.name(), Some(g.name.as_str()));
        let extras: serde_json::Value =
            serde_json::from_str(node.extras().as_ref().expect("extras").get()).expect("json");
        let grm = &extras["grm"];
        let exact: ExactLocator = grm["exact"]
            .as_str()
            .expect("exact")
            .parse()
            .expect("parses");
        assert_eq!(
            tree.resolve(&program, &exact),
            Resolution::Found(NodeId(g.node))
        );
        assert_eq!(grm["node"], g.node);
        let key = grm["key"].as_str().expect("key");
        assert_eq!(key.len(), 8);
        assert_eq!(u32::from_str_radix(key, 16).ok(), Some(g.key));
        assert_eq!(
            grm["semantic"].as_str(),
            Some(
                tree.semantic_locator(&program, NodeId(g.node))
                    .to_string()
                    .as_str()
            )
        );
        let mesh = node.mesh().expect("mesh");
        for prim in mesh.primitives() {
            assert!(prim.get(&gltf::Semantic::TexCoords(0)).is_some());
            assert!(prim.get(&gltf::Semantic::Normals).is_some());
        }
    }
    let window = children
        .iter()
        .find(|n| n.name() == Some("Window.facade1.floor3.column4"))
        .expect("window node");
    let extras = window.extras().as_ref().expect("extras").get();
    assert!(
        extras.contains("(facade = 1/1, floor = 3/3, column = 4/4) Window"),
        "{extras}"
    );
    // The triangles add up: every index count over the primitives.
    let indices: usize = gltf
        .meshes()
        .flat_map(|m| m.primitives().collect::<Vec<_>>())
        .map(|p| p.indices().expect("indexed").count())
        .sum();
    assert_eq!(indices, 3 * model.stats.triangles);
}

#[test]
fn obj_has_an_object_per_group_with_uvs_and_ply_and_png_export() {
    let (program, tree) = building(None);
    let model =
        build_shape_model(&tree, &program, &assets(), &BuildOptions::default()).expect("model");
    let dir = tempfile::tempdir().expect("tempdir");
    let obj = dir.path().join("house.obj");
    grm_geom::export(&model, &obj).expect("obj");
    let text = std::fs::read_to_string(&obj).expect("read");
    let objects: Vec<&str> = text.lines().filter(|l| l.starts_with("o ")).collect();
    assert_eq!(objects.len(), model.groups.len());
    assert_eq!(objects[0], format!("o {}", model.groups[0].name));
    let faces = text.lines().filter(|l| l.starts_with("f ")).count();
    assert_eq!(faces, model.stats.triangles);
    let v = text.lines().filter(|l| l.starts_with("v ")).count();
    let vt = text.lines().filter(|l| l.starts_with("vt ")).count();
    assert_eq!(v, vt);
    assert_eq!(v, model.stats.vertices);
    // tobj reads it back with the same triangles.
    let (models, _) = tobj::load_obj(&obj, &tobj::GPU_LOAD_OPTIONS).expect("tobj");
    let tris: usize = models.iter().map(|m| m.mesh.indices.len() / 3).sum();
    assert_eq!(tris, model.stats.triangles);
    assert!(models.iter().all(|m| !m.mesh.texcoords.is_empty()));
    for ext in ["ply", "png"] {
        let p = dir.path().join(format!("house.{ext}"));
        grm_geom::export(&model, &p).expect(ext);
        assert!(std::fs::metadata(&p).expect("written").len() > 100);
    }
}

/// A 2 x 2 PNG.
fn png_bytes() -> Vec<u8> {
    let mut out = Vec::new();
    {
        let mut e = png::Encoder::new(&mut out, 2, 2);
        e.set_color(png::ColorType::Rgb);
        e.set_depth(png::BitDepth::Eight);
        let mut w = e.write_header().expect("header");
        w.write_image_data(&[255, 0, 0, 0, 255, 0, 0, 0, 255, 255, 255, 255])
            .expect("data");
    }
    out
}

#[test]
fn a_texture_is_embedded_in_the_glb_and_named_in_the_mtl() {
    let dir = tempfile::tempdir().expect("tempdir");
    std::fs::write(dir.path().join("bricks.png"), png_bytes()).expect("png");
    let (program, tree) = building(Some("bricks.png"));
    let mut a = assets();
    a.dir = Some(dir.path().to_path_buf());
    let model = build_shape_model(&tree, &program, &a, &BuildOptions::default()).expect("model");
    assert_eq!(model.textures.len(), 1);
    assert_eq!(model.textures[0].mime, "image/png");
    let textured: Vec<_> = model
        .materials
        .iter()
        .filter(|m| m.texture.is_some())
        .collect();
    assert_eq!(textured.len(), 1);
    assert_eq!(textured[0].color, [1.0; 3]);
    let bytes = grm_geom::export::glb_bytes(&model).expect("glb");
    let doc = gltf::Gltf::from_slice(&bytes).expect("valid glb");
    let images: Vec<_> = doc.images().collect();
    assert_eq!(images.len(), 1);
    let gltf::image::Source::View { view, mime_type } = images[0].source() else {
        panic!("the image is not embedded");
    };
    assert_eq!(mime_type, "image/png");
    let blob = doc.blob.as_ref().expect("BIN chunk");
    assert_eq!(
        &blob[view.offset()..view.offset() + view.length()],
        png_bytes().as_slice()
    );
    assert_eq!(doc.textures().count(), 1);
    let m = doc
        .materials()
        .find(|m| m.pbr_metallic_roughness().base_color_texture().is_some())
        .expect("textured material");
    assert_eq!(m.name(), Some(textured[0].name.as_str()));
    let obj = dir.path().join("house.obj");
    grm_geom::export(&model, &obj).expect("obj");
    let mtl = std::fs::read_to_string(dir.path().join("house.mtl")).expect("mtl");
    assert!(
        mtl.contains("map_Kd ") && mtl.contains("bricks.png"),
        "{mtl}"
    );
    // A missing image is a typed error.
    let (program, tree) = building(Some("missing.png"));
    let e = build_shape_model(&tree, &program, &a, &BuildOptions::default()).unwrap_err();
    assert!(matches!(e, GeomError::TextureUnreadable { .. }), "{e:?}");
    std::fs::write(dir.path().join("text.png"), "not an image").expect("write");
    let (program, tree) = building(Some("text.png"));
    let e = build_shape_model(&tree, &program, &a, &BuildOptions::default()).unwrap_err();
    assert!(e.to_string().contains("not a PNG or JPEG"), "{e}");
}

/// An L-shaped mass (6 corners), and a square with a square courtyard.
#[test]
fn prisms_draw_walls_top_and_bottom_non_convex_and_with_holes() {
    let mut b = ProgramBuilder::new("l");
    let lot = b.symbol("Lot");
    let mass = b.symbol("Mass");
    b.rule(lot, vec![Op::Extrude(Param::Const(3.0)), Op::Emit(mass)]);
    let program = b.build(lot).expect("program");
    let l = [
        [0.0, 0.0],
        [6.0, 0.0],
        [6.0, 2.0],
        [2.0, 2.0],
        [2.0, 5.0],
        [0.0, 5.0],
    ];
    let tree = derive(
        &program,
        &Lot::footprint(&l).expect("lot"),
        &Options::default(),
    )
    .expect("tree");
    let model = build_shape_model(
        &tree,
        &program,
        &ShapeAssets::default(),
        &BuildOptions::default(),
    )
    .expect("model");
    // 6 walls, an L top and bottom of 4 triangles each.
    assert_eq!(model.stats.triangles, 6 * 2 + 2 * 4);
    check_mesh(&model, &tree);
    let area = |up: bool| -> f32 {
        let m = &model.parts[0].mesh;
        m.indices
            .chunks_exact(3)
            .map(|t| {
                let p = |k: usize| Vec3::from_array(m.positions[t[k] as usize]);
                let n = (p(1) - p(0)).cross(p(2) - p(0));
                if (n.y > 0.0) == up && n.y.abs() > 1e-6 {
                    0.5 * n.length()
                } else {
                    0.0
                }
            })
            .sum()
    };
    // 6 x 2 and 2 x 3.
    assert!((area(true) - 18.0).abs() < 1e-3, "top {}", area(true));
    assert!((area(false) - 18.0).abs() < 1e-3, "bottom {}", area(false));

    // The courtyard: walls 4 + 4, top and bottom of area 100 - 16.
    let ring = |pts: &[(f64, f64)]| geo::LineString::from(pts.to_vec());
    let outer = grm_shape::Outline::new(geo::MultiPolygon::new(vec![geo::Polygon::new(
        ring(&[(0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0)]),
        vec![ring(&[(3.0, 3.0), (3.0, 7.0), (7.0, 7.0), (7.0, 3.0)])],
    )]));
    let lot = Lot {
        scope: grm_shape::Scope::new(Vec3::ZERO, Vec3::new(10.0, 10.0, 0.0)),
        geometry: grm_shape::Geom::Polygon(std::sync::Arc::new(outer)),
    };
    let tree = derive(&program, &lot, &Options::default()).expect("tree");
    let model = build_shape_model(
        &tree,
        &program,
        &ShapeAssets::default(),
        &BuildOptions::default(),
    )
    .expect("model");
    check_mesh(&model, &tree);
    let walls = model.parts[0]
        .mesh
        .indices
        .chunks_exact(3)
        .filter(|t| {
            let n = model.parts[0].mesh.normals[t[0] as usize];
            n[1].abs() < 0.5
        })
        .count();
    assert_eq!(walls, 8 * 2);
    let m = &model.parts[0].mesh;
    let top: f32 = m
        .indices
        .chunks_exact(3)
        .map(|t| {
            let p = |k: usize| Vec3::from_array(m.positions[t[k] as usize]);
            let n = (p(1) - p(0)).cross(p(2) - p(0));
            if n.y > 1e-6 { 0.5 * n.length() } else { 0.0 }
        })
        .sum();
    assert!((top - 84.0).abs() < 1e-3, "courtyard top {top}");
    // Courtyard walls face into the court (x in [3, 7]): the wall at
    // x = 3 faces +x.
    let inner = m
        .positions
        .iter()
        .zip(&m.normals)
        .any(|(p, n)| (p[0] - 3.0).abs() < 1e-5 && n[0] > 0.99);
    assert!(inner);
}

#[test]
fn unknown_names_are_typed_errors_and_edges_draw_nothing() {
    let mut b = ProgramBuilder::new("bad");
    let lot = b.symbol("Lot");
    let thing = b.asset("teapot");
    b.rule(lot, vec![Op::Insert(thing)]);
    let program = b.build(lot).expect("program");
    let tree = derive(&program, &Lot::rectangle(1.0, 1.0), &Options::default()).expect("tree");
    let e = build_shape_model(
        &tree,
        &program,
        &ShapeAssets::default(),
        &BuildOptions::default(),
    )
    .unwrap_err();
    assert!(
        matches!(&e, GeomError::UnknownShapeName { what: "asset", name } if name == "teapot"),
        "{e:?}"
    );
    let mut b = ProgramBuilder::new("bad");
    let lot = b.symbol("Lot");
    let m = b.material("marble");
    b.rule(lot, vec![Op::Material(m), Op::Extrude(Param::Const(1.0))]);
    let program = b.build(lot).expect("program");
    let tree = derive(&program, &Lot::rectangle(1.0, 1.0), &Options::default()).expect("tree");
    let e = build_shape_model(
        &tree,
        &program,
        &ShapeAssets::default(),
        &BuildOptions::default(),
    )
    .unwrap_err();
    assert!(
        matches!(
            e,
            GeomError::UnknownShapeName {
                what: "material",
                ..
            }
        ),
        "{e:?}"
    );
    // Edges draw nothing: a box's 12 edges make an empty model.
    let mut b = ProgramBuilder::new("edges");
    let lot = b.symbol("Lot");
    let edge = b.symbol("Edge");
    b.rule(
        lot,
        vec![
            Op::Extrude(Param::Const(1.0)),
            Op::Comp(Comp {
                target: CompTarget::Edges,
                cases: vec![CompCase {
                    selector: Selector::All,
                    target: Some(edge),
                }],
                tag: None,
            }),
        ],
    );
    let program = b.build(lot).expect("program");
    let tree = derive(&program, &Lot::rectangle(1.0, 1.0), &Options::default()).expect("tree");
    let model = build_shape_model(
        &tree,
        &program,
        &ShapeAssets::default(),
        &BuildOptions::default(),
    )
    .expect("model");
    assert_eq!(model.stats.triangles, 0);
    assert!(model.groups.is_empty());
    let bytes = grm_geom::export::glb_bytes(&model).expect("glb");
    gltf::Gltf::from_slice(&bytes).expect("an empty model is a valid glb");
}

#[test]
fn a_model_over_the_memory_limit_is_refused() {
    let (program, tree) = building(None);
    let options = BuildOptions {
        max_bytes: 16 << 20,
        ..BuildOptions::default()
    };
    let e = build_shape_model(&tree, &program, &assets(), &options).unwrap_err();
    assert!(matches!(e, GeomError::MemoryLimit { .. }), "{e:?}");
}

/// A hip roof on a 10 x 6 lot: two trapezoid slopes, two triangular hip
/// ends and the underside, each face planar and facing out.
#[test]
fn a_roof_draws_its_planar_faces() {
    let mut b = ProgramBuilder::new("roof");
    let lot = b.symbol("Lot");
    let roof = b.symbol("Roof");
    b.rule(
        lot,
        vec![
            Op::Roof {
                kind: grm_shape::RoofKind::Hip,
                angle: Param::Const(30.0),
                overhang: Param::Const(0.0),
            },
            Op::Emit(roof),
        ],
    );
    let program = b.build(lot).expect("program");
    let tree = derive(&program, &Lot::rectangle(10.0, 6.0), &Options::default()).expect("tree");
    let model = build_shape_model(
        &tree,
        &program,
        &ShapeAssets::default(),
        &BuildOptions::default(),
    )
    .expect("model");
    assert_eq!(model.stats.triangles, 2 * 2 + 2 + 2);
    check_mesh(&model, &tree);
    let m = &model.parts[0].mesh;
    let (mut up, mut down) = (0.0f32, 0.0f32);
    for t in m.indices.chunks_exact(3) {
        let p = |k: usize| Vec3::from_array(m.positions[t[k] as usize]);
        let n = (p(1) - p(0)).cross(p(2) - p(0));
        // The face normal agrees with the vertex normals (flat faces).
        let vn = Vec3::from_array(m.normals[t[0] as usize]);
        assert!(n.normalize().dot(vn) > 0.999);
        if n.y > 0.0 {
            up += 0.5 * n.length();
        } else {
            down += 0.5 * n.length();
        }
    }
    assert!((down - 60.0).abs() < 1e-3, "underside {down}");
    let slopes = 60.0 / 30f32.to_radians().cos();
    assert!((up - slopes).abs() < 1e-2, "slopes {up}, expected {slopes}");
}

/// Writes the shape-mode glbs of this file's buildings (plain, textured)
/// where `scripts/export-check.sh` asks (`GRM_SHAPE_GLB_OUT`), for
/// the Khronos validator and Blender; always checks they re-read.
#[test]
fn sample_glbs_for_the_validator() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = std::env::var_os("GRM_SHAPE_GLB_OUT")
        .map(PathBuf::from)
        .unwrap_or_else(|| dir.path().to_path_buf());
    std::fs::create_dir_all(&out).expect("out dir");
    std::fs::write(dir.path().join("bricks.png"), png_bytes()).expect("png");
    let mut a = assets();
    a.dir = Some(dir.path().to_path_buf());
    for (name, texture) in [
        ("shape_house", None),
        ("shape_house_textured", Some("bricks.png")),
    ] {
        let (program, tree) = building(texture);
        let model =
            build_shape_model(&tree, &program, &a, &BuildOptions::default()).expect("model");
        let path = out.join(format!("{name}.glb"));
        grm_geom::export(&model, &path).expect("glb");
        let bytes = std::fs::read(&path).expect("read");
        gltf::Gltf::from_slice(&bytes).expect("valid glb");
    }
}

/// A facade of 6,000 rectangles: the lower floors' windows glass, the
/// upper floors' red (a part first used in the second half of the tree),
/// the walls plain; the side walls painted.
fn big_facade() -> (Program, ShapeTree) {
    let mut b = ProgramBuilder::new("tower");
    let (lot, facade, lower, upper, floor, floor2, tile, tile2) = (
        b.symbol("Lot"),
        b.symbol("Facade"),
        b.symbol("Lower"),
        b.symbol("Upper"),
        b.symbol("Floor"),
        b.symbol("Floor2"),
        b.symbol("Tile"),
        b.symbol("Tile2"),
    );
    let (window, window2, wall, side) = (
        b.symbol("Window"),
        b.symbol("Window2"),
        b.symbol("Wall"),
        b.symbol("Side"),
    );
    let glass = b.material("glass");
    let case = |selector, target| CompCase {
        selector,
        target: Some(target),
    };
    b.rule(
        lot,
        vec![
            Op::Extrude(Param::Const(60.0)),
            Op::Comp(Comp {
                target: CompTarget::Faces,
                cases: vec![case(Selector::Front, facade), case(Selector::Side, side)],
                tag: None,
            }),
        ],
    );
    b.rule(
        facade,
        vec![Op::Split(Split {
            axis: Axis::Y,
            parts: vec![Part::float(1.0, Some(lower)), Part::abs(15.0, Some(upper))],
            tag: None,
        })],
    );
    let floors = |f| {
        Op::Repeat(Split {
            axis: Axis::Y,
            parts: vec![Part::abs(3.0, Some(f))],
            tag: None,
        })
    };
    let tiles = |t| {
        Op::Repeat(Split {
            axis: Axis::X,
            parts: vec![Part::abs(3.0, Some(t))],
            tag: None,
        })
    };
    let split = |w| {
        Op::Split(Split {
            axis: Axis::X,
            parts: vec![
                Part::float(1.0, Some(wall)),
                Part::abs(1.2, Some(w)),
                Part::float(1.0, Some(wall)),
            ],
            tag: None,
        })
    };
    b.rule(lower, vec![floors(floor)]);
    b.rule(upper, vec![floors(floor2)]);
    b.rule(floor, vec![tiles(tile)]);
    b.rule(floor2, vec![tiles(tile2)]);
    b.rule(tile, vec![split(window)]);
    b.rule(tile2, vec![split(window2)]);
    b.rule(window, vec![Op::Material(glass)]);
    b.rule(window2, vec![rgb(0.8, 0.1, 0.1)]);
    b.rule(side, vec![rgb(0.5, 0.5, 0.45)]);
    let program = b.build(lot).expect("program");
    let tree = derive(&program, &Lot::rectangle(300.0, 40.0), &Options::default()).expect("tree");
    (program, tree)
}

/// A model built in halves on two threads is the one thread's, byte for
/// byte: parts and materials in order of first use (one first used in
/// the second half), vertices, picks and groups; and so is a model whose
/// size the tree cannot predict (an insert), which one thread builds.
#[test]
fn two_threads_build_the_same_model() {
    let (program, tree) = big_facade();
    let one = build_shape_model(&tree, &program, &assets(), &BuildOptions::default()).unwrap();
    assert!(one.groups.len() > 6000, "{} groups", one.groups.len());
    assert_eq!(one.parts.len(), 4, "{:?}", one.materials);
    for threads in [2, 3, 0] {
        let options = BuildOptions {
            threads,
            ..BuildOptions::default()
        };
        let many = build_shape_model(&tree, &program, &assets(), &options).unwrap();
        assert!(many == one, "{threads} threads: another model");
        // The bounds (folded from each half's, found on its thread) to
        // the bit: `==` takes -0.0 for 0.0.
        let bits = |m: &grm_geom::Model| {
            let b = m.stats.bounds;
            [b.min.to_array(), b.max.to_array()].map(|v| v.map(f32::to_bits))
        };
        assert_eq!(bits(&many), bits(&one), "{threads} threads: other bounds");
    }
    let (program, tree) = building(None);
    let one = build_shape_model(&tree, &program, &assets(), &BuildOptions::default()).unwrap();
    let options = BuildOptions {
        threads: 2,
        ..BuildOptions::default()
    };
    assert!(build_shape_model(&tree, &program, &assets(), &options).unwrap() == one);
}

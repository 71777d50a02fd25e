//! Export: glb re-read with `gltf`, OBJ re-read with `tobj`, PLY header,
//! SVG, atomic writes and typed errors; OBJ mesh import errors; end to end
//! from the examples.

mod common;

use std::path::{Path, PathBuf};

use common::{axiom, build_with_defaults, derive, program};
use glam::Vec3;
use grm_geom::{ExportError, ExportFormat, GeomError, Model, export, export::glb_bytes, export_as};

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples")
}

fn load_example(name: &str) -> grm_sema::Program {
    let path = examples().join(name);
    let text = std::fs::read_to_string(&path).expect("example exists");
    program(&path.to_string_lossy(), &text)
}

/// Koch island after 2 iterations, plus a sphere in a declared material.
fn sample_model() -> Model {
    let program = program(
        "mem.grm",
        "material red { color = rgb(1, 0, 0); opacity = 0.5; }\n\
         system K { angle = 90; axiom F - F - F - F material(red) sphere(0.3);\n\
         F -> F - F + F + F F - F - F + F; }",
    );
    let system = &program.systems[0];
    let string = derive(&program, system, 2);
    build_with_defaults(&program, system, &string).expect("builds")
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .expect("dir")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn glb_reads_back_with_gltf() {
    let model = sample_model();
    assert_eq!(model.stats.bones, 4 * 8 * 8);
    assert_eq!(model.parts.len(), 2);
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("koch.glb");
    export(&model, &path).expect("exports");
    let bytes = std::fs::read(&path).expect("written");
    assert_eq!(&bytes[0..4], b"glTF");
    assert_eq!(
        u32::from_le_bytes(bytes[8..12].try_into().unwrap()) as usize,
        bytes.len()
    );
    let json_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    assert_eq!(json_len % 4, 0);
    assert_eq!(bytes.len() % 4, 0);

    // `from_slice` validates the document.
    let gltf = gltf::Gltf::from_slice(&bytes).expect("valid glb");
    let blob = gltf.blob.clone().expect("BIN chunk");
    assert_eq!(gltf.meshes().count(), 1);
    let mesh = gltf.meshes().next().unwrap();
    assert_eq!(mesh.primitives().count(), model.parts.len());
    let mut vertices = 0;
    let mut triangles = 0;
    for (prim, part) in mesh.primitives().zip(&model.parts) {
        let reader = prim.reader(|_| Some(&blob[..]));
        let positions: Vec<[f32; 3]> = reader.read_positions().expect("positions").collect();
        let normals: Vec<[f32; 3]> = reader.read_normals().expect("normals").collect();
        let indices: Vec<u32> = reader.read_indices().expect("indices").into_u32().collect();
        assert_eq!(positions, part.mesh.positions);
        assert_eq!(normals.len(), positions.len());
        assert_eq!(indices, part.mesh.indices);
        vertices += positions.len();
        triangles += indices.len() / 3;
        // min/max are the exact bounds.
        let bb = prim.bounding_box();
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for p in &positions {
            lo = lo.min(Vec3::from_array(*p));
            hi = hi.max(Vec3::from_array(*p));
        }
        assert_eq!(bb.min, lo.to_array());
        assert_eq!(bb.max, hi.to_array());
        let mat = prim.material();
        let m = &model.materials[part.material];
        let f = mat.pbr_metallic_roughness().base_color_factor();
        assert_eq!(f, [m.color[0], m.color[1], m.color[2], m.opacity]);
    }
    assert_eq!(vertices, model.stats.vertices);
    assert_eq!(triangles, model.stats.triangles);
    let red = gltf
        .materials()
        .find(|m| m.name() == Some("red"))
        .expect("red");
    assert_eq!(red.alpha_mode(), gltf::material::AlphaMode::Blend);
    // No temporary files left behind.
    assert_eq!(files_in(dir.path()), vec!["koch.glb".to_string()]);

    // An empty model is a valid glb too.
    let empty = glb_bytes(&Model::default()).expect("small");
    let g = gltf::Gltf::from_slice(&empty).expect("valid empty glb");
    assert_eq!(g.meshes().count(), 0);
}

#[test]
fn obj_and_mtl_read_back_with_tobj() {
    let model = sample_model();
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("koch.obj");
    export(&model, &path).expect("exports");
    assert_eq!(
        files_in(dir.path()),
        vec!["koch.mtl".to_string(), "koch.obj".to_string()]
    );
    let opts = tobj::LoadOptions {
        single_index: true,
        triangulate: true,
        ..Default::default()
    };
    let (models, materials) = tobj::load_obj(&path, &opts).expect("obj loads");
    let materials = materials.expect("mtl loads");
    assert_eq!(models.len(), model.parts.len());
    assert_eq!(materials.len(), model.materials.len());
    let tris: usize = models.iter().map(|m| m.mesh.indices.len() / 3).sum();
    assert_eq!(tris, model.stats.triangles);
    for (m, part) in models.iter().zip(&model.parts) {
        let mat = &materials[m.mesh.material_id.expect("usemtl")];
        assert_eq!(mat.name, model.materials[part.material].name);
        assert_eq!(mat.diffuse, Some(model.materials[part.material].color));
        assert!(!m.mesh.normals.is_empty());
    }
    let red = materials.iter().find(|m| m.name == "red").expect("red");
    assert_eq!(red.dissolve, Some(0.5));
}

/// `mtllib` takes names separated by spaces: an OBJ whose name has spaces
/// gets a material library without them, and names it on one word.
#[test]
fn obj_with_spaces_in_its_name_names_a_loadable_mtl() {
    let model = sample_model();
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("my koch\tisland.obj");
    export(&model, &path).expect("exports");
    assert_eq!(
        files_in(dir.path()),
        vec![
            "my koch\tisland.obj".to_string(),
            "my_koch_island.mtl".to_string()
        ]
    );
    let text = std::fs::read_to_string(&path).expect("written");
    assert!(
        text.lines().any(|l| l == "mtllib my_koch_island.mtl"),
        "{text}"
    );
    let (_, materials) = tobj::load_obj(&path, &tobj::LoadOptions::default()).expect("obj loads");
    assert_eq!(materials.expect("mtl loads").len(), model.materials.len());
}

#[test]
fn ply_header_and_size() {
    let model = sample_model();
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("koch.ply");
    export(&model, &path).expect("exports");
    let bytes = std::fs::read(&path).expect("written");
    let end = b"end_header\n";
    let at = bytes
        .windows(end.len())
        .position(|w| w == end)
        .expect("header end")
        + end.len();
    let header = std::str::from_utf8(&bytes[..at]).expect("ascii header");
    assert!(header.starts_with("ply\nformat binary_little_endian 1.0\n"));
    let (v, t) = (model.stats.vertices, model.stats.triangles);
    assert!(header.contains(&format!("element vertex {v}\n")));
    assert!(header.contains(&format!("element face {t}\n")));
    assert!(header.contains("property uchar red\n"));
    assert!(header.contains("property list uchar uint vertex_indices\n"));
    assert_eq!(bytes.len() - at, v * 27 + t * 13);
    // First vertex round-trips.
    let x = f32::from_le_bytes(bytes[at..at + 4].try_into().unwrap());
    assert_eq!(x, model.parts[0].mesh.positions[0][0]);

    let ascii = dir.path().join("ascii.ply");
    export_as(&model, &ascii, ExportFormat::PlyAscii).expect("exports");
    let text = std::fs::read_to_string(&ascii).expect("text");
    assert!(text.starts_with("ply\nformat ascii 1.0\n"));
    let body = text.split("end_header\n").nth(1).expect("body");
    assert_eq!(body.lines().count(), v + t);
}

#[test]
fn svg_of_a_2d_system() {
    let program = load_example("koch_island.grm");
    let system = &program.systems[0];
    let string = derive(&program, system, 1);
    let model = build_with_defaults(&program, system, &string).expect("builds");
    let svg = grm_geom::export::svg_string(&model);
    assert!(svg.starts_with("<?xml"));
    assert!(svg.trim_end().ends_with("</svg>"));
    assert_eq!(svg.matches("<line ").count(), 32);
    assert!(svg.contains("viewBox=\""));
    // Tags balance: every element is self-closed or closed.
    assert_eq!(svg.matches("<g").count(), svg.matches("</g>").count());
    assert_eq!(svg.matches("<svg").count(), 1);
    // The viewBox covers the island (y flipped).
    let vb: Vec<f32> = svg
        .split("viewBox=\"")
        .nth(1)
        .and_then(|r| r.split('"').next())
        .expect("viewBox")
        .split(' ')
        .map(|x| x.parse().expect("number"))
        .collect();
    let b = model.skeleton.bounds;
    assert!(vb[0] <= b.min.x && vb[0] + vb[2] >= b.max.x);
    assert!(vb[1] <= -b.max.y && vb[1] + vb[3] >= -b.min.y);

    // Polygons become paths.
    let program = program_with_polygon();
    let system = &program.systems[0];
    let model = build_with_defaults(&program, system, &axiom(system)).expect("builds");
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("leaf.svg");
    export(&model, &path).expect("exports");
    let svg = std::fs::read_to_string(&path).expect("written");
    assert_eq!(svg.matches("<path ").count(), 1);
    assert!(svg.contains(" Z\"/>"));
}

fn program_with_polygon() -> grm_sema::Program {
    program(
        "mem.grm",
        "system S { angle = 60; axiom '(1) { . f . + f . + f . }; }",
    )
}

#[test]
fn unwritable_paths_give_typed_errors_and_no_file() {
    let model = sample_model();
    let dir = tempfile::tempdir().expect("tempdir");
    let file = dir.path().join("not_a_dir");
    std::fs::write(&file, "x").expect("write");
    for name in ["m.glb", "m.obj", "m.ply", "m.svg"] {
        // Parent is a regular file.
        let path = file.join(name);
        match export(&model, &path) {
            Err(ExportError::Io { path: p, .. }) => assert!(p.starts_with(&file), "{p:?}"),
            other => panic!("expected an I/O error, got {other:?}"),
        }
        // Parent does not exist.
        let path = dir.path().join("missing").join(name);
        let err = export(&model, &path).expect_err("fails");
        assert!(err.to_string().contains("missing"), "{err}");
    }
    // The target is a directory: the rename fails, nothing is left.
    let target = dir.path().join("taken.glb");
    std::fs::create_dir(&target).expect("mkdir");
    assert!(matches!(
        export(&model, &target),
        Err(ExportError::Io { .. })
    ));
    assert_eq!(
        files_in(dir.path()),
        vec!["not_a_dir".to_string(), "taken.glb".to_string()]
    );
    assert!(std::fs::read_dir(&target).expect("dir").next().is_none());
    // Unknown format.
    let err = export(&model, &dir.path().join("m.fbx")).expect_err("unknown");
    assert!(matches!(err, ExportError::UnknownFormat { .. }));
    assert!(err.to_string().contains("m.fbx"));
}

#[test]
fn existing_file_is_replaced_whole() {
    let model = sample_model();
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("m.glb");
    std::fs::write(&path, vec![0u8; 10_000_000]).expect("write");
    export(&model, &path).expect("exports");
    let bytes = std::fs::read(&path).expect("read");
    assert_eq!(bytes, glb_bytes(&model).expect("small"));
}

/// A directory with a copy of the example leaf and a grammar using it.
fn mesh_program(dir: &Path, obj: Option<&[u8]>) -> grm_sema::Program {
    let obj_path = dir.join("leaf.obj");
    match obj {
        Some(bytes) => std::fs::write(&obj_path, bytes).expect("write obj"),
        None => {
            std::fs::copy(examples().join("leaf.obj"), &obj_path).expect("copy leaf");
        }
    }
    let grm = dir.join("plant.grm");
    program(
        &grm.to_string_lossy(),
        "mesh leaf = \"leaf.obj\";\nsystem S { axiom F mesh(leaf) + F mesh(leaf) scale(2) mesh(leaf); }",
    )
}

#[test]
fn obj_meshes_are_loaded_once_and_instanced() {
    let dir = tempfile::tempdir().expect("tempdir");
    let program = mesh_program(dir.path(), None);
    let system = &program.systems[0];
    let model = build_with_defaults(&program, system, &axiom(system)).expect("builds");
    assert_eq!(model.stats.instances, 3);
    let leaf = grm_geom::import::load_obj("leaf", &dir.path().join("leaf.obj")).expect("loads");
    assert_eq!(leaf.triangle_count(), 4);
    let part = &model.parts[0];
    let mesh_tris: u32 = part
        .picks
        .iter()
        .filter(|p| matches!(p.source, grm_geom::PartSource::Instance(_)))
        .map(|p| p.triangle_count)
        .sum();
    assert_eq!(mesh_tris, 3 * 4);
    // The scaled instance reaches twice as high: tip of leaf at (0, 1, 0)
    // in the frame at (1, 1, 0) heading +X, scaled by 2: x = 1 + 2.
    assert!(
        (model.stats.bounds.max.x - 3.0).abs() < 1e-5,
        "{:?}",
        model.stats.bounds
    );
}

#[test]
fn missing_or_malformed_obj_is_a_typed_error() {
    let dir = tempfile::tempdir().expect("tempdir");
    let program = mesh_program(dir.path(), None);
    let system = &program.systems[0];
    let string = axiom(system);
    // The file disappears after checking.
    std::fs::remove_file(dir.path().join("leaf.obj")).expect("rm");
    match build_with_defaults(&program, system, &string) {
        Err(e @ GeomError::MeshMissing { .. }) => {
            let msg = e.to_string();
            assert!(msg.contains("leaf.obj") && msg.contains("`leaf`"), "{msg}");
        }
        other => panic!("expected MeshMissing, got {other:?}"),
    }
    for bad in [
        &b"v 1 2\nf 1 2 3\n"[..],
        b"v 0 0 0\nv 1 0 0\nf 1 2 9\n",
        b"# nothing\n",
        // Indices before the first element: tobj would overflow on them.
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//-3 2//-3 3//-3\n",
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/-3 2/-3 3/-3\n",
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//6148914691236517206 2//1 3//1\n",
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n",
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 -2 -1\n",
    ] {
        let dir = tempfile::tempdir().expect("tempdir");
        let program = mesh_program(dir.path(), Some(bad));
        let system = &program.systems[0];
        match build_with_defaults(&program, system, &axiom(system)) {
            Err(e @ GeomError::MeshMalformed { .. }) => {
                assert!(e.to_string().contains("leaf.obj"), "{e}");
            }
            other => panic!("expected MeshMalformed for {bad:?}, got {other:?}"),
        }
    }
    // Relative indices that name elements above them are fine.
    let path = Path::new("rel.obj");
    let ok = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\nf -3/-1/-1 -2/1/1 -1/-1/-1\n";
    let mesh = grm_geom::import::parse_obj("rel", path, ok).expect("relative indices");
    assert_eq!(mesh.triangle_count(), 1);
    assert_eq!(mesh.normals, vec![[0.0, 0.0, 1.0]; 3]);
    let e = grm_geom::import::parse_obj("rel", path, b"v 0 0 0\nf 1//-1 1 1\n")
        .expect_err("no normal above");
    assert_eq!(
        e.to_string(),
        "mesh `rel` in rel.obj is not a valid OBJ file: line 2: normal index -1, but no normal is defined above it"
    );
}

/// Faces of more than three vertices are ear-clipped, not fanned: a
/// concave face covers exactly its own area with every triangle wound as
/// the face (tobj's fan put a reversed triangle over the notch).
#[test]
fn concave_obj_faces_cover_their_own_area() {
    let path = Path::new("concave.obj");
    // The 2 x 2 square with a notch cut into its top edge down to
    // (1, 0.5): area 4 - 1.5 = 2.5.
    let concave = b"v 0 0 0\nv 2 0 0\nv 2 2 0\nv 1 0.5 0\nv 0 2 0\nf 1 2 3 4 5\n";
    // The same with a triangle after it (faces of mixed sizes): + 2.
    let mixed = b"v 0 0 0\nv 2 0 0\nv 2 2 0\nv 1 0.5 0\nv 0 2 0\nf 1 2 3 4 5\nf 1 2 3\n";
    for (bytes, area, tris) in [(&concave[..], 2.5f32, 3), (&mixed[..], 4.5, 4)] {
        let mesh = grm_geom::import::parse_obj("concave", path, bytes).expect("loads");
        assert_eq!(mesh.triangle_count(), tris);
        let mut total = 0.0;
        for t in mesh.indices.chunks_exact(3) {
            let [a, b, c] =
                [t[0], t[1], t[2]].map(|i| glam::Vec3::from(mesh.positions[i as usize]));
            let n = (b - a).cross(c - a);
            // Wound like the face (counter-clockwise about +z), none reversed.
            assert!(n.z > 0.0, "{t:?} is reversed or flat: {n}");
            total += n.z / 2.0;
        }
        assert!((total - area).abs() < 1e-5, "area {total}, expected {area}");
    }
    // A quad with no area gives no triangle, a plain quad two.
    let flat = b"v 0 0 0\nv 1 0 0\nv 2 0 0\nv 3 0 0\nf 1 2 3 4\nv 0 1 0\nf 1 2 5\n";
    assert_eq!(
        grm_geom::import::parse_obj("f", path, flat)
            .expect("loads")
            .triangle_count(),
        1
    );
    let quad = b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n";
    assert_eq!(
        grm_geom::import::parse_obj("q", path, quad)
            .expect("loads")
            .triangle_count(),
        2
    );
}

#[test]
fn examples_end_to_end() {
    let out = tempfile::tempdir().expect("tempdir");
    // Koch island, n = 3: 4 * 8^3 bones; closed curve.
    let program = load_example("koch_island.grm");
    let system = &program.systems[0];
    let string = derive(&program, system, system.settings.iterations);
    let model = build_with_defaults(&program, system, &string).expect("builds");
    assert_eq!(model.stats.bones, 2048);
    let last = model.bones().last().expect("bones").tip;
    assert!(last.length() < 1e-3, "island closes: {last}");
    for ext in ["glb", "obj", "ply", "svg"] {
        export(&model, &out.path().join(format!("koch.{ext}"))).expect("exports");
    }

    // 3D Hilbert curve, n = 2: 63 unit bones visiting a 4x4x4 grid once
    // each, which only holds with ABoP's turn conventions.
    let program = load_example("hilbert3d.grm");
    let system = &program.systems[0];
    let string = derive(&program, system, 2);
    let model = build_with_defaults(&program, system, &string).expect("builds");
    assert_eq!(model.stats.bones, 63);
    let mut cells: Vec<[i32; 3]> = vec![[0; 3]];
    for b in model.bones() {
        assert!((b.length() - 1.0).abs() < 1e-4);
        cells.push(b.tip.round().to_array().map(|x| x as i32));
    }
    cells.sort();
    cells.dedup();
    assert_eq!(cells.len(), 64, "self-intersecting curve");
    let size = model.skeleton.bounds.size();
    assert!((size - Vec3::splat(3.0)).length() < 1e-3, "{size}");
    export(&model, &out.path().join("hilbert.glb")).expect("exports");

    // Bracketed plant (meta-parameter angle), n = 3.
    let program = load_example("bracketed_plant.grm");
    let system = &program.systems[0];
    let string = derive(&program, system, 3);
    let model = build_with_defaults(&program, system, &string).expect("builds");
    assert_eq!(
        model.stats.bones,
        string
            .symbols()
            .filter(|&s| { system.symbols[s as usize].name == "F" })
            .count()
    );
    let bytes = glb_bytes(&model).expect("small");
    gltf::Gltf::from_slice(&bytes).expect("valid glb");
    export(&model, &out.path().join("plant.obj")).expect("exports");
}

#[test]
fn calder_example_meshes_and_materials() {
    // A sample system cannot be derived here; place its declared meshes by
    // hand, the way its geometry symbols do.
    let program = load_example("calder_tree.grm");
    let system = &program.systems[0];
    let sym = |name: &str| system.symbol_by_name(name).expect("symbol").0;
    let mesh = |name: &str| {
        program
            .meshes
            .iter()
            .position(|m| m.name == name)
            .expect("mesh") as f32
    };
    let material = |name: &str| {
        program
            .materials
            .iter()
            .position(|m| m.name == name)
            .expect("material") as f32
    };
    let mut s = grm_derive::ModuleString::new();
    s.push(sym("material"), &[material("bark")]);
    s.push(sym("mesh"), &[mesh("trunkMesh")]);
    s.push(sym("F"), &[1.0]);
    s.push(sym("material"), &[material("foliage")]);
    s.push(sym("mesh"), &[mesh("leafMesh")]);
    let model = build_with_defaults(&program, system, &s).expect("builds");
    let names: Vec<&str> = model.materials.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, vec!["bark", "foliage"]);
    assert_eq!(model.materials[0].color, [0.45, 0.32, 0.2]);
    assert_eq!(model.stats.instances, 2);
    // The bone is painted bark too (material set before it).
    assert_eq!(model.parts[0].picks.len(), 2);
    let out = tempfile::tempdir().expect("tempdir");
    export(&model, &out.path().join("calder.glb")).expect("exports");
}

#[cfg(unix)]
#[test]
fn exported_files_are_readable() {
    use std::os::unix::fs::PermissionsExt;
    let model = sample_model();
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("m.glb");
    export(&model, &path).expect("exports");
    let mode = std::fs::metadata(&path).expect("meta").permissions().mode();
    assert_eq!(mode & 0o777, 0o644);
    // Replacing a file keeps its permissions.
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o600)).expect("chmod");
    export(&model, &path).expect("exports");
    let mode = std::fs::metadata(&path).expect("meta").permissions().mode();
    assert_eq!(mode & 0o777, 0o600);
}

/// Mesh-file errors point at the mesh's declaration and name the file as
/// written there; the codes are R0404 (unreadable) and R0405 (malformed).
#[test]
fn mesh_errors_become_diagnostics() {
    use grm_diag::{Code, FileId, Span};
    let at = (FileId(9), Span::new(0, 1));
    let dir = tempfile::tempdir().expect("tempdir");
    let program = mesh_program(dir.path(), Some(b"# nothing\n"));
    let system = &program.systems[0];
    let e = build_with_defaults(&program, system, &axiom(system)).expect_err("no faces");
    let d = e.to_diagnostic(&program, at.0, at.1);
    assert_eq!(d.code, Code::MeshMalformed);
    assert_eq!(d.primary().span, program.meshes[0].loc.span);
    assert!(d.message.contains("\"leaf.obj\""), "{}", d.message);
    assert!(
        !d.message.contains(&*dir.path().to_string_lossy()),
        "{}",
        d.message
    );
    std::fs::remove_file(dir.path().join("leaf.obj")).expect("rm");
    let e = build_with_defaults(&program, system, &axiom(system)).expect_err("gone");
    let d = e.to_diagnostic(&program, at.0, at.1);
    assert_eq!(d.code, Code::MeshUnreadable);
    assert_eq!(d.primary().file, program.meshes[0].loc.file);
}

/// Internal R0401 to R0403: strings and ids that a checked program never
/// produces are typed errors with their codes.
#[test]
fn internal_geometry_errors_have_codes() {
    use grm_diag::{Code, FileId, Span};
    let at = (FileId(9), Span::new(0, 1));
    // A module string whose offsets break the invariant.
    let program = program(
        "m.grm",
        "material red { color = rgb(1, 0, 0); }\nsystem S { axiom F material(red) F; }",
    );
    let system = &program.systems[0];
    let (syms, mut starts, params, keys) = axiom(system).into_parts();
    starts.push(7);
    let broken = grm_derive::ModuleString::from_parts(syms, starts, params, keys);
    let e = build_with_defaults(&program, system, &broken).expect_err("malformed");
    assert!(matches!(e, GeomError::Turtle(_)), "{e:?}");
    assert_eq!(e.code(), Code::InterpretString);
    let d = e.to_diagnostic(&program, at.0, at.1);
    assert_eq!((d.primary().file, d.primary().span), at);
    assert!(d.help.as_deref().is_some_and(|h| h.contains("internal")));
    // A material id past the program's materials.
    let mut fewer = program.clone();
    fewer.materials.clear();
    let e = build_with_defaults(&fewer, system, &axiom(system)).expect_err("material");
    assert!(matches!(e, GeomError::UnknownMaterial { .. }), "{e:?}");
    assert_eq!(e.code(), Code::UnknownMaterialId);
    // A mesh id past the program's meshes.
    let dir = tempfile::tempdir().expect("tempdir");
    let mut meshless = mesh_program(dir.path(), None);
    meshless.meshes.clear();
    let system = &meshless.systems[0];
    let e = build_with_defaults(&meshless, system, &axiom(system)).expect_err("mesh");
    assert!(matches!(e, GeomError::UnknownMesh { .. }), "{e:?}");
    assert_eq!(e.code(), Code::UnknownMeshId);
}

/// Export errors carry their codes: an unknown extension (R0406) and a
/// directory that does not exist (R0407).
#[test]
fn export_errors_have_codes() {
    use grm_diag::{Code, FileId, Span};
    let model = sample_model();
    let dir = tempfile::tempdir().expect("tempdir");
    let e = export(&model, &dir.path().join("m.stl")).expect_err("format");
    assert_eq!(e.code(), Code::UnknownExportFormat);
    let e = export(&model, &dir.path().join("missing/m.glb")).expect_err("no directory");
    assert_eq!(e.code(), Code::ExportIo);
    let d = e.to_diagnostic(FileId(2), Span::new(4, 5));
    assert_eq!(d.code, Code::ExportIo);
    assert_eq!(d.primary().span, Span::new(4, 5));
    assert!(d.help.is_some());
}

/// The binary PLY's header and body after `end_header`.
fn ply_parts(bytes: &[u8]) -> (String, &[u8]) {
    let end = b"end_header\n";
    let at = bytes
        .windows(end.len())
        .position(|w| w == end)
        .expect("header end")
        + end.len();
    let header = std::str::from_utf8(&bytes[..at]).expect("ascii header");
    (header.to_string(), &bytes[at..])
}

/// PLY vertex colours are 8-bit sRGB, as the PNG and glb show them:
/// `rgb(0.45, 0.32, 0.2)` (179, 153, 124) was written as (115, 82, 51), linear values
/// scaled, a darker colour than the material's. And the model stands up
/// in Blender: grm's +y (the turtle's heading) is PLY's +z.
#[test]
fn ply_colours_are_srgb_and_up_is_z() {
    let program = program(
        "mem.grm",
        "material bark { color = rgb(0.45, 0.32, 0.2); }\n\
         system S { width = 0.1; axiom material(bark) F(2); }",
    );
    let system = &program.systems[0];
    let model = build_with_defaults(&program, system, &axiom(system)).expect("builds");
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("stem.ply");
    export(&model, &path).expect("exports");
    let bytes = std::fs::read(&path).expect("written");
    let (header, body) = ply_parts(&bytes);
    assert!(header.contains("z up"), "{header}");
    let f = |v: &[u8], i: usize| f32::from_le_bytes(v[4 * i..4 * i + 4].try_into().unwrap());
    let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
    for v in body[..model.stats.vertices * 27].chunks_exact(27) {
        assert_eq!(&v[24..27], &[179, 153, 124]);
        for i in 0..3 {
            lo[i] = lo[i].min(f(v, i));
            hi[i] = hi[i].max(f(v, i));
        }
        // Normals turn with the points: level on the tube's side, along
        // z on its caps.
        let n = [f(v, 3), f(v, 4), f(v, 5)];
        assert!(
            n[2].abs() < 1e-5 || (n[2].abs() - 1.0).abs() < 1e-5,
            "normal {n:?}"
        );
    }
    // The 2-long stem runs along +z, 0.1 thick in x and y.
    assert!(
        (hi[2] - 2.0).abs() < 1e-4 && lo[2].abs() < 1e-4,
        "{lo:?} {hi:?}"
    );
    assert!(
        hi[1] - lo[1] < 0.11 && hi[0] - lo[0] < 0.11,
        "{lo:?} {hi:?}"
    );
}

/// An empty model's PLY is one Blender reads: Blender 4.5 refuses a PLY
/// without vertices, so it holds one vertex at the origin and no faces.
#[test]
fn an_empty_model_is_a_ply_with_one_vertex_and_no_faces() {
    let program = program("mem.grm", "system S { axiom +; }");
    let system = &program.systems[0];
    let model = build_with_defaults(&program, system, &axiom(system)).expect("builds");
    assert_eq!(model.stats.vertices, 0);
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("empty.ply");
    export(&model, &path).expect("exports");
    let bytes = std::fs::read(&path).expect("written");
    let (header, body) = ply_parts(&bytes);
    assert!(header.contains("element vertex 1\n"), "{header}");
    assert!(header.contains("element face 0\n"), "{header}");
    assert_eq!(body.len(), 27);
    assert!(body[..12].iter().all(|&b| b == 0), "at the origin");
    let ascii = dir.path().join("empty_ascii.ply");
    export_as(&model, &ascii, ExportFormat::PlyAscii).expect("exports");
    let text = std::fs::read_to_string(&ascii).expect("written");
    let body = text.split("end_header\n").nth(1).expect("body");
    assert_eq!(body, "0 0 0 0 0 1 204 204 204\n");
}

/// SVG colours are sRGB too (`#735233` was the linear bark colour scaled).
#[test]
fn svg_colours_are_srgb() {
    let program = program(
        "mem.grm",
        "material bark { color = rgb(0.45, 0.32, 0.2); }\n\
         system S { axiom material(bark) F; }",
    );
    let system = &program.systems[0];
    let model = build_with_defaults(&program, system, &axiom(system)).expect("builds");
    let svg = grm_geom::export::svg_string(&model);
    assert!(svg.contains("stroke=\"#b3997c\""), "{svg}");
    assert!(!svg.contains("#735233"), "{svg}");
}

/// `mtllib` names the library the export wrote, whatever the OBJ's name:
/// `#` starts a comment in OBJ (`mtllib a#b.mtl` named `a`), and names
/// that are not UTF-8 all got the same library (their bytes replaced with
/// U+FFFD), each export overwriting the last one's.
#[test]
fn mtllib_names_the_library_written_for_any_name() {
    let model = sample_model();
    let dir = tempfile::tempdir().expect("tempdir");
    let mut names: Vec<(std::ffi::OsString, &str)> = vec![
        ("a#b.obj".into(), "a%23b.mtl"),
        ("50%.obj".into(), "50%25.mtl"),
        ("é.obj".into(), "é.mtl"),
    ];
    #[cfg(unix)]
    {
        use std::os::unix::ffi::OsStringExt;
        names.push((
            std::ffi::OsString::from_vec(b"x\xff.obj".to_vec()),
            "x%FF.mtl",
        ));
        names.push((
            std::ffi::OsString::from_vec(b"x\xfe.obj".to_vec()),
            "x%FE.mtl",
        ));
    }
    for (name, mtl) in &names {
        let path = dir.path().join(name);
        export(&model, &path).expect("exports");
        assert_eq!(grm_geom::export::mtl_file_name(&path), *mtl);
        assert!(dir.path().join(mtl).is_file(), "{mtl} written");
        let text = std::fs::read_to_string(&path).expect("written");
        assert!(
            text.lines().any(|l| l == format!("mtllib {mtl}")),
            "{name:?}: {text:.200}"
        );
        let (_, materials) =
            tobj::load_obj(&path, &tobj::LoadOptions::default()).expect("obj loads");
        assert_eq!(
            materials.expect("its own mtl loads").len(),
            model.materials.len(),
            "{name:?}"
        );
    }
}

//! Primitive meshes, tubes along bones, polygons, materials, picking.

mod common;

use common::{area, axiom, build_with_defaults, is_closed, normals_ok, program};
use glam::Vec3;
use grm_geom::{
    BuildOptions, Model, ModelMaterial, PartSource, build_from_interpretation, build_model, mesh,
};
use grm_sema::Value;
use grm_turtle::{Bone, Interpretation, NO_ORIGIN, Paint};

#[test]
fn unit_primitives() {
    let n = 16;
    let cases = [
        ("cylinder", mesh::unit_cylinder(n), 4 * n + 2, 4 * n),
        ("cone", mesh::unit_cone(n), 3 * n + 1, 2 * n),
        (
            "sphere",
            mesh::unit_sphere(n),
            n * (n / 2 - 1) + 2,
            2 * n * (n / 2 - 1),
        ),
        ("box", mesh::unit_box(), 24, 12),
        ("disc", mesh::unit_disc(n), 2 * (n + 1), 2 * n),
    ];
    for (name, m, verts, tris) in &cases {
        assert_eq!(m.vertex_count() as u32, *verts, "{name} vertices");
        assert_eq!(m.triangle_count() as u32, *tris, "{name} triangles");
        assert!(normals_ok(m), "{name} normals");
        assert!(m.indices.iter().all(|&i| (i as usize) < m.positions.len()));
        if *name != "disc" {
            assert!(is_closed(m), "{name} closed");
        }
    }
    // Exact areas: box 1x1x1 = 6; sphere and cylinder approach 4 pi and 4 pi.
    assert!((area(&mesh::unit_box()) - 6.0).abs() < 1e-5);
    let sphere = area(&mesh::unit_sphere(64));
    assert!(
        (sphere - 4.0 * std::f32::consts::PI).abs() < 0.05,
        "{sphere}"
    );
    // The disc's two sides cover the unit disc twice.
    let disc = area(&mesh::unit_disc(64));
    assert!((disc - 2.0 * std::f32::consts::PI).abs() < 0.02, "{disc}");
    // Spheres: every vertex on the unit sphere, normal = position.
    let s = mesh::unit_sphere(12);
    for (p, n) in s.positions.iter().zip(&s.normals) {
        assert!((Vec3::from_array(*p).length() - 1.0).abs() < 1e-5);
        assert!(Vec3::from_array(*p).distance(Vec3::from_array(*n)) < 1e-5);
    }
}

fn bone(base: Vec3, tip: Vec3, parent: Option<u32>, width: f32) -> Bone {
    Bone {
        base,
        tip,
        left: Vec3::X,
        parent,
        width_base: width,
        width_tip: width,
        paint: Paint::Palette(0),
        module: 0,
        origin: NO_ORIGIN,
    }
}

fn empty_program() -> grm_sema::Program {
    program("mem.grm", "system S { axiom F; }")
}

fn build(bones: Vec<Bone>) -> Model {
    let skeleton = Interpretation {
        bones,
        ..Interpretation::default()
    };
    build_from_interpretation(&empty_program(), skeleton, &BuildOptions::default(), &[])
        .expect("builds")
}

#[test]
fn tube_chain_is_one_closed_tube() {
    let y = |v: f32| Vec3::new(0.0, v, 0.0);
    let model = build(vec![
        bone(y(0.0), y(1.0), None, 0.2),
        bone(y(1.0), y(2.0), Some(0), 0.2),
        bone(y(2.0), y(3.0), Some(1), 0.1),
    ]);
    assert_eq!(model.parts.len(), 1);
    let m = &model.parts[0].mesh;
    let s = 8;
    // Base ring + base cap, then one ring per bone, and a tip cap.
    assert_eq!(m.vertex_count(), s + (s + 1) + 3 * s + (s + 1));
    assert_eq!(m.triangle_count(), s + 3 * 2 * s + s);
    assert!(is_closed(m));
    assert!(normals_ok(m));
    // Radii: 0.1 along the first two bones, tapering to 0.05.
    let b = model.stats.bounds;
    assert!((b.max.x - 0.1).abs() < 1e-5 && (b.min.y).abs() < 1e-6 && (b.max.y - 3.0).abs() < 1e-6);
    let top: Vec<_> = m
        .positions
        .iter()
        .filter(|p| (p[1] - 3.0).abs() < 1e-6)
        .collect();
    assert!(
        top.iter()
            .all(|p| Vec3::new(p[0], 0.0, p[2]).length() < 0.05 + 1e-5)
    );
    // Picking: the middle bone's triangles.
    let pick = model.pick(0, (s + 2 * s + 1) as u32).expect("pick");
    assert_eq!(pick.source, PartSource::Bone(1));
    assert!(model.pick(0, 10_000).is_none());
}

#[test]
fn tube_corners_are_mitred_and_closed() {
    // A square (Koch island, n = 0): every corner turns 90 degrees.
    let p = [
        Vec3::ZERO,
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
    ];
    let model = build(vec![
        bone(p[0], p[1], None, 0.2),
        bone(p[1], p[2], Some(0), 0.2),
        bone(p[2], p[3], Some(1), 0.2),
    ]);
    let m = &model.parts[0].mesh;
    assert!(is_closed(m));
    assert!(normals_ok(m));
    // The ring at the first corner lies in the bisecting plane x + ... :
    // points at the corner satisfy (q - corner) . normalize(d0 + d1) = 0.
    let n = (Vec3::Y + Vec3::X).normalize();
    let ring: Vec<Vec3> = m.positions[17..25]
        .iter()
        .map(|v| Vec3::from_array(*v))
        .collect();
    for q in &ring {
        assert!((*q - p[1]).dot(n).abs() < 1e-5, "{q}");
    }
}

#[test]
fn branches_and_widths() {
    let y = |v: f32| Vec3::new(0.0, v, 0.0);
    // F [ + F ] F: the straight child continues the trunk, the lateral one
    // starts its own closed tube; width 0 bones get no tube.
    let model = build(vec![
        bone(y(0.0), y(1.0), None, 0.2),
        bone(y(1.0), Vec3::new(1.0, 1.0, 0.0), Some(0), 0.1),
        bone(y(1.0), y(2.0), Some(0), 0.2),
        bone(y(2.0), y(3.0), Some(2), 0.0),
        bone(y(3.0), y(3.0), Some(3), 0.1),
    ]);
    let m = &model.parts[0].mesh;
    assert!(is_closed(m));
    assert!(normals_ok(m));
    let bones: Vec<PartSource> = model.parts[0].picks.iter().map(|p| p.source).collect();
    assert_eq!(
        bones,
        vec![
            PartSource::Bone(0),
            PartSource::Bone(1),
            PartSource::Bone(2)
        ]
    );
    // The lateral branch has its own base cap: 8 + 9 + 8 + 9 vertices.
    let lateral = model.parts[0].picks[1];
    assert_eq!(lateral.triangle_count, 8 + 16 + 8);
}

/// Materials take the run's meta-parameter values: a value outside 0..1
/// is clamped, a NaN one falls back to the default property, and values
/// that do not fit the program are a typed error (R0102), not a guess.
#[test]
fn materials_follow_the_meta_parameters() {
    let program = program(
        "mem.grm",
        "param red = 0.25 in 0 .. 4;\n\
         material m { color = rgb(red, 0, 0); roughness = acos(red - 0.25); metallic = red; }\n\
         system S { axiom material(m) F; }",
    );
    let system = &program.systems[0];
    let build = |red: f64| {
        build_model(
            &program,
            system,
            &axiom(system),
            &system.settings,
            &[Value::Float(red)],
        )
        .expect("builds")
    };
    let default = build(0.25);
    let m = &default.materials[0];
    assert_eq!((m.color, m.metallic), ([0.25, 0.0, 0.0], 0.25));
    // acos(0) = 90 degrees, clamped to 1.
    assert_eq!(m.roughness, 1.0);

    let other = build(0.75);
    let m = &other.materials[0];
    assert_eq!((m.color, m.metallic), ([0.75, 0.0, 0.0], 0.75));

    // acos(2.75) is NaN: the default roughness; 3 is clamped to 1.
    let wild = build(3.0);
    let m = &wild.materials[0];
    let fallback = ModelMaterial::default().roughness;
    assert_eq!(
        (m.color, m.metallic, m.roughness),
        ([1.0, 0.0, 0.0], 1.0, fallback)
    );
    let glb = grm_geom::export::glb_bytes(&wild).expect("small");
    gltf::Gltf::from_slice(&glb).expect("a valid glb, no null factors");

    for bad in [&[][..], &[Value::Bool(true)][..]] {
        let e = build_model(&program, system, &axiom(system), &system.settings, bad)
            .expect_err("values that do not fit");
        assert_eq!(e.code().as_str(), "R0102", "{e}");
    }
}

#[test]
fn parts_by_paint_and_materials() {
    let program = program(
        "mem.grm",
        "material bark { color = rgb(0.5, 0.25, 0.0); roughness = 0.9; metallic = 0.1; }\n\
         system S { axiom F material(bark) F color(0, 0, 1) F '(1) F; }",
    );
    let system = &program.systems[0];
    let string = axiom(system);
    let model = build_with_defaults(&program, system, &string).expect("builds");
    assert_eq!(model.parts.len(), 4);
    let names: Vec<&str> = model.materials.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, vec!["color0", "bark", "rgb_0000ff", "color1"]);
    let bark = &model.materials[1];
    assert_eq!(bark.color, [0.5, 0.25, 0.0]);
    assert!((bark.roughness - 0.9).abs() < 1e-6 && (bark.metallic - 0.1).abs() < 1e-6);
    assert_eq!(model.stats.bones, 4);
    assert_eq!(model.stats.parts, 4);
    assert_eq!(
        model.stats.triangles,
        model
            .parts
            .iter()
            .map(|p| p.mesh.triangle_count())
            .sum::<usize>()
    );
    // Picks carry modules; origins come from a side table.
    let mut model = model;
    model.fill_origins(&[7, 7, 8, 8, 9, 9, 10]);
    assert_eq!(model.parts[1].picks[0].module, 2);
    assert_eq!(model.parts[1].picks[0].origin, 8);
    assert_eq!(model.skeleton.bones[3].origin, 10);
}

#[test]
fn polygons_triangulated_two_sided() {
    let program = program(
        "mem.grm",
        // An L-shaped (concave) hexagon, drawn with g moves (no bones).
        "system S { angle = 90; axiom { . g(2) . - g(1) . - g(1) . + g(1) . - g(1) . - g(2) . }; }",
    );
    let system = &program.systems[0];
    let model = build_with_defaults(&program, system, &axiom(system)).expect("builds");
    assert_eq!(model.stats.polygons, 1);
    assert_eq!(model.skeleton.polygon_vertices.len(), 6);
    let m = &model.parts[0].mesh;
    assert_eq!(m.triangle_count(), 2 * 4);
    assert!(normals_ok(m));
    // Area 3 on each side.
    assert!((area(m) - 6.0).abs() < 1e-4, "{}", area(m));
    // Each front triangle is followed by its mirror on the back.
    for t in m.indices.chunks(6) {
        assert_eq!([t[0] + 6, t[2] + 6, t[1] + 6], [t[3], t[4], t[5]]);
    }
}

#[test]
fn primitives_in_a_model() {
    let program = program(
        "mem.grm",
        "system S { axiom F cylinder(0.5, 2) sphere(1) box(1, 2, 3) cone(1, 1) disc(2) scale(0) sphere(1); }",
    );
    let system = &program.systems[0];
    let model = build_with_defaults(&program, system, &axiom(system)).expect("builds");
    assert_eq!(model.stats.instances, 6);
    // The zero-scaled sphere is dropped, not a NaN mesh.
    assert_eq!(model.stats.dropped, 1);
    let picks: Vec<PartSource> = model.parts[0].picks.iter().map(|p| p.source).collect();
    assert_eq!(picks.len(), 6);
    assert_eq!(picks[1], PartSource::Instance(0));
    assert!(normals_ok(&model.parts[0].mesh));
    let b = model.stats.bounds;
    assert!((b.max.y - 3.0).abs() < 1e-5, "{b:?}");
    assert!((b.max.z - 2.0).abs() < 1e-5, "{b:?}");
}

/// Timing at scale: run with `cargo test --release -p grm-geom --test
/// geometry -- --ignored --nocapture`.
#[test]
#[ignore]
fn large_model_timing() {
    let program = program(
        "mem.grm",
        "system S { angle = 25; axiom [ + F(1) ] F(0.5); }",
    );
    let system = &program.systems[0];
    let unit = axiom(system);
    let mut string = grm_derive::ModuleString::with_capacity(1_000_000, 1_000_000);
    while string.len() < 1_000_000 {
        string.extend_from(&unit);
    }
    let t0 = std::time::Instant::now();
    let model = build_with_defaults(&program, system, &string).expect("builds");
    let t1 = std::time::Instant::now();
    let bytes = grm_geom::export::glb_bytes(&model).expect("fits");
    let t2 = std::time::Instant::now();
    println!(
        "{} modules: {} bones, {} vertices, {} triangles; build {:?}, glb {:?} ({} MB)",
        string.len(),
        model.stats.bones,
        model.stats.vertices,
        model.stats.triangles,
        t1 - t0,
        t2 - t1,
        bytes.len() / 1_000_000
    );
}

#[test]
fn tapering_tube_normals_lean_with_the_taper() {
    // Radius 0.2 -> 0.1 over length 1: the side leans in by atan(0.1), so
    // its normals point up the tube by about sin(atan(0.1)) = 0.0995 (the
    // octagon's faces lean by atan(0.1 cos(pi/8)) = 0.0920).
    let mut b = bone(Vec3::ZERO, Vec3::Y, None, 0.4);
    b.width_tip = 0.2;
    let model = build(vec![b]);
    let m = &model.parts[0].mesh;
    assert!(is_closed(m) && normals_ok(m));
    let mut sides = 0;
    for (p, n) in m.positions.iter().zip(&m.normals) {
        let (p, n) = (Vec3::from_array(*p), Vec3::from_array(*n));
        let radial = Vec3::new(p.x, 0.0, p.z);
        if n.y.abs() > 0.99 || radial.length() < 1e-6 {
            continue; // a cap's
        }
        sides += 1;
        let want = 0.1f32.atan();
        assert!((n.y.asin() - want).abs() < 0.01, "{n} at {p}");
        assert!(n.dot(radial.normalize()) > 0.99, "{n} at {p}");
    }
    assert_eq!(sides, 16, "two rings of 8");
}

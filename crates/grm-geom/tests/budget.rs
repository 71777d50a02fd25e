//! The model's size is counted before it is built (grm_geom::budget): the
//! count bounds what is built, the meshes are made in buffers of exactly
//! that size, and a model over `BuildOptions::max_bytes` is refused
//! (R0202) before its meshes are made.

mod common;

use common::*;
use grm_geom::{BuildOptions, ExportFormat, GeomError, Output, build_model_with};

const KOCH: &str = "system Koch {\n    angle = 90;\n    axiom F - F - F - F;\n    F -> F - F + F + F F - F - F + F;\n}\n";

const MIXED: &str = "system Mixed {\n    angle = 30;\n    axiom A;\n    A -> F [ + F A ] [ - color(1, 0, 0) F A ] F { . f . + f . } sphere(0.2) box(0.1, 0.1, 0.1);\n}\n";

fn build(text: &str, n: u32, options: &BuildOptions) -> Result<grm_geom::Model, GeomError> {
    let p = program("budget.grm", text);
    let s = &p.systems[0];
    let string = derive(&p, s, n);
    build_model_with(&p, s, &string, &s.settings, &p.default_params(), options)
}

#[test]
fn tubes_are_counted_exactly_and_built_without_spare_capacity() {
    for n in 0..4 {
        let m = build(KOCH, n, &BuildOptions::default()).expect("builds");
        assert_eq!(m.footprint.vertices, m.stats.vertices as u64, "n = {n}");
        assert_eq!(m.footprint.triangles, m.stats.triangles as u64, "n = {n}");
        for part in &m.parts {
            assert_eq!(part.mesh.positions.capacity(), part.mesh.positions.len());
            assert_eq!(part.mesh.indices.capacity(), part.mesh.indices.len());
            assert_eq!(part.picks.capacity(), part.picks.len());
        }
    }
}

#[test]
fn the_count_bounds_every_kind_of_geometry() {
    for n in 0..5 {
        let m = build(MIXED, n, &BuildOptions::default()).expect("builds");
        assert!(m.footprint.vertices >= m.stats.vertices as u64, "n = {n}");
        assert!(m.footprint.triangles >= m.stats.triangles as u64, "n = {n}");
        let mesh_bytes: u64 = m
            .parts
            .iter()
            .map(|p| 24 * p.mesh.positions.capacity() as u64 + 4 * p.mesh.indices.capacity() as u64)
            .sum();
        assert!(m.footprint.bytes >= mesh_bytes, "n = {n}");
    }
}

#[test]
fn a_model_over_the_limit_is_refused_before_it_is_built() {
    // Koch at n = 5: 131,072 bones (about 32 MiB with the string and the process itself), 2
    // million triangles (about 50 MiB more).
    let options = BuildOptions::limited(48 << 20, Output::Format(ExportFormat::Obj));
    let e = build(KOCH, 5, &options).expect_err("over 48 MiB");
    let GeomError::MemoryLimit {
        footprint, limit, ..
    } = &e
    else {
        panic!("{e}");
    };
    assert_eq!(*limit, 48 << 20);
    assert!(footprint.bytes > 60 << 20, "{footprint:?}");
    assert_eq!(footprint.triangles, 2_097_168);
    assert_eq!(footprint.bones, 131_072);
    assert_eq!(e.code().as_str(), "R0202");
    let text = e.to_string();
    assert!(text.contains("over the memory limit of 48 MiB"), "{text}");
    assert!(text.contains("writing it as .obj"), "{text}");
    // The interpretation alone is checked before the string is interpreted.
    let e = build(KOCH, 5, &BuildOptions::limited(1 << 20, Output::Model)).expect_err("over 1 MiB");
    let GeomError::MemoryLimit { footprint, .. } = &e else {
        panic!("{e}");
    };
    assert_eq!(footprint.triangles, 0, "refused from the string's counts");
    // The same model fits a limit that holds it.
    let m = build(KOCH, 5, &BuildOptions::limited(256 << 20, Output::Model)).expect("fits");
    assert!(m.footprint.bytes <= 256 << 20);
    assert_eq!(m.stats.bones, 131_072);
}

#[test]
fn a_picture_counts_its_buffers() {
    let model_only = build(KOCH, 2, &BuildOptions::default()).expect("builds");
    let picture = Output::Picture {
        width: 4096,
        height: 4096,
        samples: 3,
    };
    let drawn = build(KOCH, 2, &BuildOptions::limited(1 << 30, picture)).expect("builds");
    // 16 million pixels: at least their depth and colour samples.
    assert!(drawn.footprint.bytes > model_only.footprint.bytes + (150 << 20));
    let e = build(KOCH, 2, &BuildOptions::limited(64 << 20, picture)).expect_err("too large");
    assert!(e.to_string().contains("drawing its picture"), "{e}");
}

/// Focus and context (`build_model_drawn`): only the kept modules' bones,
/// instances and polygons are meshed, every cut tube is closed with caps
/// (each part a union of closed surfaces, which may touch),
/// the count is still exact for tubes, the skeleton is whole, and keeping
/// everything is the plain build byte for byte.
#[test]
fn a_drawn_mask_meshes_only_what_it_keeps_and_closes_cut_tubes() {
    let p = program("budget.grm", KOCH);
    let s = &p.systems[0];
    let string = derive(&p, s, 2);
    let opts = BuildOptions::default();
    let params = p.default_params();
    let whole = build_model_with(&p, s, &string, &s.settings, &params, &opts).expect("builds");
    let all: &dyn Fn(u32) -> bool = &|_| true;
    let same = grm_geom::build_model_drawn(&p, s, &string, &s.settings, &params, &opts, Some(all))
        .expect("builds");
    assert_eq!(same.parts, whole.parts);
    // Every third module: chains cut everywhere.
    let some: &dyn Fn(u32) -> bool = &|m| m % 3 == 0;
    let cut = grm_geom::build_model_drawn(&p, s, &string, &s.settings, &params, &opts, Some(some))
        .expect("builds");
    assert_eq!(cut.skeleton.bones.len(), whole.skeleton.bones.len());
    assert_eq!(cut.footprint.triangles, cut.stats.triangles as u64);
    assert_eq!(cut.footprint.vertices, cut.stats.vertices as u64);
    assert!(cut.stats.triangles > 0 && cut.stats.triangles < whole.stats.triangles);
    for part in &cut.parts {
        assert!(edges_balanced(&part.mesh), "a cut tube is open");
        for pk in &part.picks {
            assert!(some(pk.module), "module {} meshed", pk.module);
        }
    }
    let kept = whole
        .skeleton
        .bones
        .iter()
        .filter(|b| some(b.module))
        .count();
    let picked: usize = cut.parts.iter().map(|part| part.picks.len()).sum();
    assert_eq!(picked, kept);
    // Nothing kept: no triangles, the skeleton whole.
    let none: &dyn Fn(u32) -> bool = &|_| false;
    let empty =
        grm_geom::build_model_drawn(&p, s, &string, &s.settings, &params, &opts, Some(none))
            .expect("builds");
    assert_eq!(empty.stats.triangles, 0);
    assert_eq!(empty.skeleton.bones.len(), whole.skeleton.bones.len());
}

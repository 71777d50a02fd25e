//! `-o FILE.png`: `grmc derive`, `forest` and `sample` draw the model as a
//! picture (grm_geom::render), with `--image-size`, `--view` and
//! `--transparent`; the flags are checked before any work.

mod common;

use std::path::Path;

use common::{example, grmc, text};

fn path(p: &Path) -> &str {
    p.to_str().expect("utf-8 temp path")
}

/// A written PNG: (width, height, colour type, pixel bytes).
fn read_png(p: &Path) -> (u32, u32, png::ColorType, Vec<u8>) {
    let bytes = std::fs::read(p).expect("the picture is written");
    let mut reader = png::Decoder::new(std::io::Cursor::new(bytes))
        .read_info()
        .expect("a PNG");
    let mut buf = vec![0; reader.output_buffer_size().expect("size")];
    let info = reader.next_frame(&mut buf).expect("a frame");
    buf.truncate(info.buffer_size());
    (info.width, info.height, info.color_type, buf)
}

/// How many distinct pixel values a picture has.
fn distinct(pixels: &[u8], channels: usize) -> usize {
    pixels
        .chunks_exact(channels)
        .collect::<std::collections::HashSet<_>>()
        .len()
}

/// `grmc derive ternary_tree.grm -n 4 --image-size 320x240 EXTRA -o OUT`.
fn draw_tree(out: &Path, extra: &[&str]) -> std::process::Output {
    let tree = example("ternary_tree.grm");
    let mut args = vec![
        "derive",
        tree.as_str(),
        "-n",
        "4",
        "--image-size",
        "320x240",
    ];
    args.extend_from_slice(extra);
    args.extend_from_slice(&["-o", path(out)]);
    grmc(&args)
}

#[test]
fn derive_draws_a_tree_at_the_asked_size_and_view() {
    let dir = tempfile::tempdir().expect("tempdir");
    let a = dir.path().join("a.png");
    let o = draw_tree(&a, &[]);
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(err.contains("a.png (320x240 picture of"), "{err}");
    let (w, h, colour, pixels) = read_png(&a);
    assert_eq!((w, h, colour), (320, 240, png::ColorType::Rgb));
    // A shaded tree on a gradient, not a flat fill.
    assert!(distinct(&pixels, 3) > 100, "{}", distinct(&pixels, 3));

    // The same command draws the same bytes; another view, others.
    let b = dir.path().join("b.png");
    assert_eq!(draw_tree(&b, &[]).status.code(), Some(0));
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    let c = dir.path().join("c.png");
    let o = draw_tree(&c, &["--view", "-90,-10"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    assert_ne!(read_png(&a).3, read_png(&c).3);
}

#[test]
fn a_transparent_picture_has_alpha() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("koch.PNG");
    let o = grmc(&[
        "derive",
        &example("koch_island.grm"),
        "-n",
        "2",
        "--image-size",
        "64",
        "--transparent",
        "-o",
        path(&out),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let (w, h, colour, pixels) = read_png(&out);
    assert_eq!((w, h, colour), (64, 64, png::ColorType::Rgba));
    let alpha: Vec<u8> = pixels.chunks_exact(4).map(|p| p[3]).collect();
    assert_eq!(alpha[0], 0, "a corner is background");
    assert!(alpha.iter().any(|&a| a > 128), "the island is drawn");
}

#[test]
fn forest_and_sample_draw_pictures_too() {
    let dir = tempfile::tempdir().expect("tempdir");
    let forest = dir.path().join("forest.png");
    let o = grmc(&[
        "forest",
        &example("stochastic_plant.grm"),
        "--trees",
        "4",
        "-n",
        "3",
        "--image-size",
        "200x100",
        "-o",
        path(&forest),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    assert_eq!(read_png(&forest).0, 200);

    let tree = dir.path().join("tree.png");
    let o = grmc(&[
        "sample",
        &example("calder_tree.grm"),
        "--generations",
        "3",
        "--particles",
        "4",
        "--image-size",
        "120x160",
        "--view",
        "0,0",
        "-o",
        path(&tree),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let (w, h, _, pixels) = read_png(&tree);
    assert_eq!((w, h), (120, 160));
    assert!(distinct(&pixels, 3) > 20);
}

#[test]
fn bad_picture_flags_are_usage_errors_before_any_work() {
    let dir = tempfile::tempdir().expect("tempdir");
    let tree = example("ternary_tree.grm");
    let png = dir.path().join("t.png");
    let glb = dir.path().join("t.glb");
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["--image-size", "0x10"], "is not a picture size"),
        (vec!["--image-size", "20000x10"], "is not a picture size"),
        (vec!["--image-size", "5000x5000"], "at most 16777216 pixels"),
        (vec!["--image-size", "wide"], "is not a picture size"),
        (vec!["--view", "10"], "is not a view"),
        (vec!["--view", "0,91"], "is not a view"),
        (vec!["--view", "nan,0"], "is not a view"),
        // Numbers, but not angles: the message says which is wrong.
        (
            vec!["--view", "1e400,0"],
            "`1e400,0` is not a view: the azimuth must be a finite number",
        ),
        (
            vec!["--view=-0,-90.5"],
            "`-0,-90.5` is not a view: the elevation must be -90 to 90",
        ),
    ];
    for (flags, says) in cases {
        let mut args = vec!["derive", tree.as_str()];
        args.extend_from_slice(&flags);
        args.extend_from_slice(&["-o", path(&png)]);
        let o = grmc(&args);
        let err = text(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{flags:?}: {err}");
        assert!(err.contains(says), "{flags:?}: {err}");
    }
    // Picture flags without a picture to draw.
    for (flags, output) in [
        (vec!["--view", "10,10"], Some(path(&glb))),
        (vec!["--transparent"], None),
        (vec!["--image-size", "64x64"], None),
    ] {
        let mut args = vec!["derive", tree.as_str()];
        args.extend_from_slice(&flags);
        if let Some(o) = output {
            args.extend_from_slice(&["-o", o]);
        }
        let o = grmc(&args);
        let err = text(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{flags:?}: {err}");
        assert!(
            err.contains("it needs an output named -o FILE.png"),
            "{err}"
        );
        assert!(!err.contains("iterations:"), "nothing derived: {err}");
    }
    assert!(!png.exists() && !glb.exists());
}

#[test]
fn bench_render_prints_a_row_per_scene() {
    let o = common::grmc_at_root(&[
        "bench",
        "render",
        "--scene",
        "hilbert3d_4",
        "--runs",
        "1",
        "--image-size",
        "64x48",
    ]);
    let out = text(&o.stdout);
    assert_eq!(o.status.code(), Some(0), "{out}{}", text(&o.stderr));
    assert!(out.contains("64x48 pixels, 3x3 samples"), "{out}");
    let row = out
        .lines()
        .find(|l| l.starts_with("hilbert3d_4"))
        .expect("the scene's row");
    // triangles, bones, then the times: the Hilbert curve at 4 has 4095 bones.
    let cols: Vec<&str> = row.split_whitespace().collect();
    assert_eq!(cols[2], "4095", "{row}");
    let o = common::grmc_at_root(&["bench", "render", "--scene", "nope"]);
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn an_output_that_is_a_directory_is_refused_before_any_work() {
    // `-o out.png` where out.png is a folder: R0407 before the derivation
    // (it used to fail only when writing, after all the work).
    let dir = tempfile::tempdir().expect("tempdir");
    let folder = dir.path().join("out.png");
    std::fs::create_dir(&folder).expect("a folder");
    let tree = example("ternary_tree.grm");
    for flags in [vec![], vec!["--view", "0,0"]] {
        let mut args = vec!["derive", tree.as_str(), "-n", "2"];
        args.extend_from_slice(&flags);
        args.extend_from_slice(&["-o", path(&folder)]);
        let o = grmc(&args);
        let err = text(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(
            err.contains("R0407") && err.contains("is a directory"),
            "{err}"
        );
        assert!(!err.contains("iterations:"), "nothing derived: {err}");
    }
    assert!(folder.is_dir());
}

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
        (vec!["--camera", "1,2"], "`1,2` is not a point: write X,Y,Z"),
        (vec!["--camera", "1,2,3,4"], "is not a point"),
        (
            vec!["--camera", "1,inf,3"],
            "its coordinates must be finite numbers",
        ),
        (
            vec!["--camera", "1,2,3", "--fov", "0"],
            "is not a field of view",
        ),
        (vec!["--camera", "1,2,3", "--fov", "180"], "at most 179"),
        (vec!["--fov", "30"], "--camera <X,Y,Z>"),
        (vec!["--look-at", "0,0,0"], "--camera <X,Y,Z>"),
        (
            vec!["--camera", "1,2,3", "--view", "0,0"],
            "cannot be used with",
        ),
        (
            vec!["--camera", "1,2,3", "--look-at", "1,2,3"],
            "name the same point",
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
        (vec!["--camera", "0,1,2"], Some(path(&glb))),
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

#[test]
fn frames_write_every_iteration_in_one_framing() {
    let dir = tempfile::tempdir().expect("tempdir");
    // A stalk growing one bone per iteration: every frame lies inside the
    // last, so the last frame is the picture of the final model alone.
    let grammar = dir.path().join("stalk.grm");
    std::fs::write(
        &grammar,
        "system Stalk { iterations = 10; width = 0.05; axiom A; A -> F A; }\n",
    )
    .unwrap();
    let out = dir.path().join("stalk.png");
    let o = grmc(&[
        "derive",
        path(&grammar),
        "--frames",
        "--image-size",
        "48x64",
        "-o",
        path(&out),
    ]);
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{err}");
    // 0 to 10: zero-padded to two digits, in order.
    let names: Vec<String> = (0..=10).map(|k| format!("stalk-{k:02}.png")).collect();
    for name in &names {
        assert!(dir.path().join(name).exists(), "{name}: {err}");
    }
    assert!(!out.exists(), "no unnumbered picture");
    let single = dir.path().join("single.png");
    let o = grmc(&[
        "derive",
        path(&grammar),
        "--image-size",
        "48x64",
        "-o",
        path(&single),
    ]);
    assert_eq!(o.status.code(), Some(0));
    let frame = |k: usize| std::fs::read(dir.path().join(&names[k])).unwrap();
    assert_eq!(frame(10), std::fs::read(&single).unwrap());
    // Each earlier frame draws less of the same picture.
    let drawn = |k: usize| {
        let (_, _, _, px) = read_png(&dir.path().join(&names[k]));
        let (_, _, _, bg) = read_png(&dir.path().join(&names[0]));
        px.chunks_exact(3)
            .zip(bg.chunks_exact(3))
            .filter(|(a, b)| a != b)
            .count()
    };
    assert!(drawn(3) > 0 && drawn(3) < drawn(6) && drawn(6) < drawn(10));

    // Other formats: a file per iteration.
    let svg = dir.path().join("s.svg");
    let o = grmc(&[
        "derive",
        path(&grammar),
        "-n",
        "2",
        "--frames",
        "-o",
        path(&svg),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    for k in 0..=2 {
        let written = std::fs::read_to_string(dir.path().join(format!("s-{k}.svg")))
            .expect("an svg per iteration");
        assert_eq!(written.matches("<line").count(), k, "frame {k}");
    }

    // At most 1,000 files, refused before any work.
    let o = grmc(&[
        "derive",
        path(&grammar),
        "-n",
        "1000",
        "--frames",
        "-o",
        path(&svg),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        text(&o.stderr).contains("at most 1000 files"),
        "{}",
        text(&o.stderr)
    );
    assert!(!dir.path().join("s-0000.svg").exists());
    // --frames needs -o, and is a CPU derivation.
    let o = grmc(&["derive", path(&grammar), "--frames"]);
    assert_eq!(o.status.code(), Some(2));
    let o = grmc(&[
        "derive",
        path(&grammar),
        "--frames",
        "--gpu",
        "-o",
        path(&out),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        text(&o.stderr).contains("cannot be used with"),
        "{}",
        text(&o.stderr)
    );
}

#[test]
fn a_perspective_camera_draws_what_it_looks_at() {
    // The 4-iteration ternary tree stands on the origin, about 200 units
    // tall: a camera far off looking at its centre shows it whole; the
    // same camera turned away shows only the background.
    let dir = tempfile::tempdir().expect("tempdir");
    let whole = dir.path().join("whole.png");
    let o = draw_tree(&whole, &["--camera", "600,400,800", "--fov", "40"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let (w, h, _, pixels) = read_png(&whole);
    assert_eq!((w, h), (320, 240));
    assert!(distinct(&pixels, 3) > 100, "{}", distinct(&pixels, 3));

    let away = dir.path().join("away.png");
    let o = draw_tree(
        &away,
        &["--camera", "600,400,800", "--look-at", "1200,400,1600"],
    );
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let (_, _, _, bg) = read_png(&away);
    // Looking away, every row is the background gradient: one colour.
    for row in bg.chunks_exact(320 * 3) {
        assert_eq!(distinct(row, 3), 1);
    }
    // The same camera with the default 45 degrees differs from 40.
    let wide = dir.path().join("wide.png");
    let o = draw_tree(&wide, &["--camera", "600,400,800"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    assert_ne!(read_png(&wide).3, pixels);
}

#[test]
fn the_camera_looks_at_the_models_centre_by_default() {
    // A sphere centred on (10, 0, 0): the default look-at is that point.
    let dir = tempfile::tempdir().expect("tempdir");
    let grm = dir.path().join("ball.grm");
    std::fs::write(&grm, "system B { axiom translate(10, 0, 0) sphere(1); }\n").unwrap();
    let draw = |name: &str, extra: &[&str]| {
        let out = dir.path().join(name);
        let mut args = vec![
            "derive",
            path(&grm),
            "--image-size",
            "64x48",
            "--camera",
            "12,1,5",
        ];
        args.extend_from_slice(extra);
        args.extend_from_slice(&["-o", path(&out)]);
        let o = grmc(&args);
        assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
        read_png(&out).3
    };
    let default = draw("a.png", &[]);
    assert_eq!(default, draw("b.png", &["--look-at", "10,0,0"]));
    assert_ne!(default, draw("c.png", &["--look-at", "0,0,0"]));
}

/// `examples/row_of_trees.grm` draws the book's line figure (ABoP fig.
/// 1.37a), not a solid wedge: at its 7 iterations no segment is longer
/// than 0.08, and it was drawn with the default width 0.1, so the tubes
/// filled the outline in. Now most of the wedge is background between
/// the lines (counting pixels more than half covered).
#[test]
fn the_row_of_trees_is_a_line_figure() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("row.png");
    let o = grmc(&[
        "derive",
        &example("row_of_trees.grm"),
        "--image-size",
        "512",
        "--transparent",
        "-o",
        path(&out),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let (w, _, colour, pixels) = read_png(&out);
    assert_eq!(colour, png::ColorType::Rgba);
    // The covered pixels against their bounding box.
    let (mut n, mut lo, mut hi) = (0u32, [u32::MAX; 2], [0u32; 2]);
    for (i, p) in pixels.chunks_exact(4).enumerate() {
        if p[3] > 128 {
            let (x, y) = (i as u32 % w, i as u32 / w);
            n += 1;
            lo = [lo[0].min(x), lo[1].min(y)];
            hi = [hi[0].max(x), hi[1].max(y)];
        }
    }
    let covered = f64::from(n) / f64::from((hi[0] + 1 - lo[0]) * (hi[1] + 1 - lo[1]));
    // The solid wedge covered 57% of its box, the lines cover 22%.
    assert!(covered < 0.35, "{covered:.3} of the box is covered");
}

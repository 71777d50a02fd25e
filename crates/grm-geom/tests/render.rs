//! The `.png` export's rasterizer (`grm_geom::render`): what a picture
//! shows (coverage, colour, occlusion, framing, hairlines), that it is
//! repeatable and reads back as PNG, and that bad options are errors.

mod common;

use common::{axiom, build_with_defaults, derive, program};
use glam::DVec3;
use grm_geom::render::{
    Image, MARGIN, RenderError, RenderOptions, View, framing, png_bytes, render, render_framed,
    write_png,
};
use grm_geom::{ExportFormat, Model, export};

/// The model of a one-system program's axiom (`iterations` > 0: derived).
fn model(text: &str, iterations: u32) -> Model {
    let p = program("mem.grm", text);
    let s = &p.systems[0];
    let string = if iterations == 0 {
        axiom(s)
    } else {
        derive(&p, s, iterations)
    };
    build_with_defaults(&p, s, &string).expect("builds")
}

fn options(width: u32, height: u32, view: View) -> RenderOptions {
    RenderOptions {
        width,
        height,
        view,
        samples: 2,
        transparent: false,
    }
}

const FRONT: View = View::Angles {
    azimuth: 0.0,
    elevation: 0.0,
};

fn draw(m: &Model, o: &RenderOptions) -> Image {
    render(m, o).expect("renders")
}

/// The pixels where `image` differs from `background` (same options, an
/// empty model), as a bounding box `(x0, y0, x1, y1)` inclusive, and their
/// count.
fn covered(image: &Image, background: &Image) -> (Option<(u32, u32, u32, u32)>, usize) {
    let mut bbox: Option<(u32, u32, u32, u32)> = None;
    let mut n = 0;
    for y in 0..image.height {
        for x in 0..image.width {
            if px(image, x, y) != px(background, x, y) {
                n += 1;
                bbox = Some(match bbox {
                    None => (x, y, x, y),
                    Some((a, b, c, d)) => (a.min(x), b.min(y), c.max(x), d.max(y)),
                });
            }
        }
    }
    (bbox, n)
}

fn empty() -> Model {
    model("system E { axiom f; }", 0)
}

#[test]
fn an_empty_model_is_the_background_gradient() {
    let m = empty();
    assert_eq!(m.stats.triangles, 0);
    let img = draw(&m, &options(64, 48, View::Auto));
    assert_eq!((img.width, img.height), (64, 48));
    assert_eq!(img.rgba.len(), 64 * 48 * 4);
    assert!(img.is_opaque());
    // Lighter at the top, the same across a row.
    let (top, bottom) = (px(&img, 10, 0), px(&img, 10, 47));
    assert!(
        top[0] > bottom[0] && top[2] > bottom[2],
        "{top:?} {bottom:?}"
    );
    assert_eq!(px(&img, 0, 20), px(&img, 63, 20));

    let clear = draw(
        &m,
        &RenderOptions {
            transparent: true,
            ..options(64, 48, View::Auto)
        },
    );
    assert!(clear.rgba.chunks_exact(4).all(|p| p[3] == 0));
}

#[test]
fn a_red_box_fills_the_frame_within_the_margin() {
    let m = model("system B { axiom color(1, 0, 0) box(1, 1, 1); }", 0);
    assert!(m.stats.triangles > 0);
    let o = options(200, 200, FRONT);
    let img = draw(&m, &o);
    let bg = draw(&empty(), &o);
    let centre = px(&img, 100, 100);
    assert!(
        centre[0] > 120 && centre[1] < 40 && centre[2] < 40,
        "a lit red face: {centre:?}"
    );
    // Seen from the front, the 1 x 1 face is fitted to the picture less
    // the margin on every side.
    let (bbox, _) = covered(&img, &bg);
    let (x0, y0, x1, y1) = bbox.expect("the box is drawn");
    let m_px = (MARGIN * 200.0) as i64;
    for (got, want) in [
        (x0 as i64, m_px),
        (y0 as i64, m_px),
        (x1 as i64, 199 - m_px),
        (y1 as i64, 199 - m_px),
    ] {
        assert!((got - want).abs() <= 1, "bbox {bbox:?}, margin {m_px}");
    }
    assert_eq!(px(&img, 2, 2), px(&bg, 2, 2));
}

#[test]
fn the_nearer_surface_hides_the_farther() {
    // A red box at the origin, a blue one 2 units along +z: the camera of
    // azimuth 0 is on +z, that of azimuth 180 on -z.
    let m = model(
        "system O { axiom color(1, 0, 0) box(1, 1, 1) translate(0, 0, 2) color(0, 0, 1) box(1, 1, 1); }",
        0,
    );
    let front = draw(&m, &options(100, 100, FRONT));
    let back = draw(
        &m,
        &options(
            100,
            100,
            View::Angles {
                azimuth: 180.0,
                elevation: 0.0,
            },
        ),
    );
    let f = px(&front, 50, 50);
    let b = px(&back, 50, 50);
    assert!(f[2] > f[0] + 60, "blue in front: {f:?}");
    assert!(b[0] > b[2] + 60, "red in front from behind: {b:?}");
}

#[test]
fn a_polygon_seen_from_behind_is_lit_like_its_front() {
    // One quad in the xy plane; the front and the back view draw it with
    // the same shading (two-sided lighting), mirrored.
    let m = model(
        "system P { angle = 90; axiom color(0.2, 0.8, 0.2) { . F + F + F + F }; }",
        0,
    );
    assert_eq!(m.stats.polygons, 1);
    let f = draw(&m, &options(60, 60, FRONT));
    let b = draw(
        &m,
        &options(
            60,
            60,
            View::Angles {
                azimuth: 180.0,
                elevation: 0.0,
            },
        ),
    );
    let (pf, pb) = (px(&f, 30, 30), px(&b, 30, 30));
    assert!(pf[1] > pf[0] + 60, "green: {pf:?}");
    for k in 0..3 {
        assert!(
            (pf[k] as i32 - pb[k] as i32).abs() <= 2,
            "{pf:?} against {pb:?}"
        );
    }
}

#[test]
fn the_picture_does_not_depend_on_the_models_scale() {
    let small = model("system S { axiom box(1, 2, 0.5) sphere(0.4); }", 0);
    let large = model(
        "system S { axiom scale(1000) box(1, 2, 0.5) sphere(0.4); }",
        0,
    );
    let tiny = model(
        "system S { axiom scale(0.001) box(1, 2, 0.5) sphere(0.4); }",
        0,
    );
    let o = options(120, 120, View::Auto);
    let a = draw(&small, &o);
    for other in [&large, &tiny] {
        let b = draw(other, &o);
        let differing = a
            .rgba
            .chunks_exact(4)
            .zip(b.rgba.chunks_exact(4))
            .filter(|(p, q)| p.iter().zip(q.iter()).any(|(x, y)| x.abs_diff(*y) > 8))
            .count();
        assert!(differing * 100 < 120 * 120, "{differing} pixels differ");
    }
}

#[test]
fn bones_without_width_are_hairlines() {
    // Bones of width 0 (the Koch island): no triangles, but lines.
    let m = model(
        "system K { angle = 90; width = 0; axiom F - F - F - F; F -> F - F + F + F F - F - F + F; }",
        1,
    );
    assert_eq!(m.stats.triangles, 0);
    assert_eq!(m.stats.bare_bones, 32);
    let o = options(128, 128, View::Auto);
    let img = draw(&m, &o);
    let bg = draw(&empty(), &o);
    let (bbox, n) = covered(&img, &bg);
    // Lines, not areas: a thin fraction of the picture, spanning the frame.
    assert!(n > 128 && n < 128 * 128 / 4, "{n} pixels drawn");
    let (x0, _, x1, _) = bbox.expect("lines drawn");
    assert!(x0 <= 8 && x1 >= 119, "{bbox:?}");
    // Transparent: the lines have alpha, the rest none.
    let clear = draw(
        &m,
        &RenderOptions {
            transparent: true,
            ..o
        },
    );
    let opaque_enough = clear.rgba.chunks_exact(4).filter(|p| p[3] > 64).count();
    let zero = clear.rgba.chunks_exact(4).filter(|p| p[3] == 0).count();
    assert!(opaque_enough > 100 && zero > 128 * 128 / 2);
}

#[test]
fn a_tree_seen_from_the_auto_view_and_from_above() {
    let m = model(
        "system T { angle = 30; width = 0.1; axiom F A; A -> F [ + F A ] [ & F A ] [ - F A ]; }",
        3,
    );
    assert!(m.stats.triangles > 100);
    for view in [
        View::Auto,
        View::Angles {
            azimuth: 10.0,
            elevation: 90.0,
        },
        View::Angles {
            azimuth: -30.0,
            elevation: -90.0,
        },
    ] {
        let o = options(96, 64, view);
        let (_, n) = covered(&draw(&m, &o), &draw(&empty(), &o));
        assert!(n > 50, "{view:?}: {n} pixels");
    }
}

#[test]
fn the_same_model_gives_the_same_png_bytes_and_they_read_back() {
    let m = model(
        "system T { angle = 25; width = 0.05; axiom F A; A -> F [ + F A ] [ - F A ] color(0.9, 0.2, 0.1) sphere(0.1); }",
        3,
    );
    let o = options(80, 60, View::Auto);
    let a = png_bytes(&draw(&m, &o)).expect("encodes");
    let b = png_bytes(&draw(&m, &o)).expect("encodes");
    assert_eq!(a, b);
    assert_eq!(&a[..8], b"\x89PNG\r\n\x1a\n");

    let img = draw(&m, &o);
    let decoder = png::Decoder::new(std::io::Cursor::new(&a));
    let mut reader = decoder.read_info().expect("a PNG");
    let mut buf = vec![0; reader.output_buffer_size().expect("size")];
    let info = reader.next_frame(&mut buf).expect("a frame");
    assert_eq!((info.width, info.height), (80, 60));
    assert_eq!(info.color_type, png::ColorType::Rgb);
    let rgb: Vec<u8> = img
        .rgba
        .chunks_exact(4)
        .flat_map(|p| [p[0], p[1], p[2]])
        .collect();
    assert_eq!(&buf[..info.buffer_size()], &rgb[..]);

    // Transparent pictures are written with their alpha.
    let clear = draw(
        &m,
        &RenderOptions {
            transparent: true,
            ..o
        },
    );
    let bytes = png_bytes(&clear).expect("encodes");
    let mut reader = png::Decoder::new(std::io::Cursor::new(&bytes))
        .read_info()
        .expect("a PNG");
    let mut buf = vec![0; reader.output_buffer_size().expect("size")];
    let info = reader.next_frame(&mut buf).expect("a frame");
    assert_eq!(info.color_type, png::ColorType::Rgba);
    assert_eq!(&buf[..info.buffer_size()], &clear.rgba[..]);
}

#[test]
fn bad_options_are_errors_not_panics() {
    let m = empty();
    for (w, h) in [(0, 10), (10, 0), (16385, 10), (5000, 5000)] {
        assert_eq!(
            render(&m, &options(w, h, View::Auto)),
            Err(RenderError::Size {
                width: w,
                height: h
            })
        );
    }
    for s in [0, 5] {
        let o = RenderOptions {
            samples: s,
            ..options(8, 8, View::Auto)
        };
        assert_eq!(render(&m, &o), Err(RenderError::Samples(s)));
    }
    let o = options(
        8,
        8,
        View::Angles {
            azimuth: f32::NAN,
            elevation: 0.0,
        },
    );
    assert_eq!(render(&m, &o), Err(RenderError::View));
    // A big picture keeps its buffers bounded by lowering the samples.
    let big = RenderOptions {
        samples: 4,
        ..options(4096, 4096, View::Auto)
    };
    assert_eq!(big.validate(), Ok(()));
    assert_eq!(big.effective_samples(), 1);
    assert_eq!(options(1024, 1024, View::Auto).effective_samples(), 2);
    // An Image whose bytes do not match its size is an encoding error.
    let broken = Image {
        width: 4,
        height: 4,
        rgba: vec![0; 10],
        transparent: false,
    };
    assert!(write_png(&broken, &mut Vec::new()).is_err());
}

#[test]
fn export_writes_png_by_extension() {
    assert_eq!(
        ExportFormat::from_path(std::path::Path::new("a/tree.PNG")),
        Some(ExportFormat::Png)
    );
    let m = model("system B { axiom box(1, 1, 1); }", 0);
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("box.png");
    export(&m, &path).expect("exports");
    let bytes = std::fs::read(&path).expect("written");
    let reader = png::Decoder::new(std::io::Cursor::new(&bytes))
        .read_info()
        .expect("a PNG");
    let d = RenderOptions::default();
    assert_eq!(
        (reader.info().width, reader.info().height),
        (d.width, d.height)
    );
}

#[test]
fn any_number_of_threads_draws_the_same_picture() {
    // Taller than a few bands, with tubes, lines and a polygon.
    let m = model(
        "system T { angle = 25; width = 0.05; axiom F A; A -> F [ + F A ] [ - ! (0) F A ] { . f + f + f };  }",
        4,
    );
    assert!(m.stats.triangles > 0 && m.stats.bare_bones > 0);
    let o = RenderOptions {
        samples: 3,
        ..options(150, 170, View::Auto)
    };
    let on = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("a pool")
            .install(|| draw(&m, &o))
    };
    let one = on(1);
    assert!((o.height * 3) as usize > 4 * grm_geom::render::BAND_ROWS);
    assert_eq!(one, on(3));
    assert_eq!(one, on(8));
}

/// The pixel at column `x`, row `y` of a picture the test drew.
fn px(image: &Image, x: u32, y: u32) -> [u8; 4] {
    image.pixel(x, y).expect("a pixel of the picture")
}

#[test]
fn a_bare_bone_behind_a_surface_is_hidden_at_any_scale() {
    // A green unit square in the xy plane, seen from the front (+z), and a
    // red bone of width 0 across it: on its plane (a tie: the line shows)
    // or 0.02 behind it (hidden). The depth bias that settles the tie is
    // relative to the model's size, so the picture is the same at any
    // scale (it was 1e-4 world units: at scale 0.001 the bone showed
    // through the square).
    for s in ["0.001", "1", "1000"] {
        for (dz, shows) in [("0", true), ("-0.02", false)] {
            let m = model(
                &format!(
                    "system S {{ angle = 90; width = 0; axiom scale({s}) color(0, 0.6, 0) \
                     [ {{ . f + f + f + f }} ] \
                     [ translate(0.5, 0.1, {dz}) color(1, 0, 0) F(0.8) ]; }}"
                ),
                0,
            );
            assert_eq!((m.stats.polygons, m.stats.bare_bones), (1, 1));
            let img = draw(&m, &options(60, 60, FRONT));
            // The bone runs down the middle, between columns 29 and 30.
            let mid = [px(&img, 29, 30), px(&img, 30, 30)];
            let red = mid.iter().any(|p| p[0] > p[1]);
            assert_eq!(red, shows, "scale {s}, bone at z {dz}: {mid:?}");
            // Left of it, the square.
            let side = px(&img, 15, 30);
            assert!(side[1] > side[0] + 60, "{side:?}");
        }
    }
}

/// The bounding box of what `m` draws from the front in a 64 x 64 picture.
fn front_bbox(m: &Model) -> Option<(u32, u32, u32, u32)> {
    let o = options(64, 64, FRONT);
    covered(&draw(m, &o), &draw(&empty(), &o)).0
}

/// `m` with its bones replaced by these (base, tip) pairs, and no parts.
fn with_bones(m: &Model, bones: &[(glam::Vec3, glam::Vec3)]) -> Model {
    let mut m = m.clone();
    m.parts.clear();
    let first = m.skeleton.bones[0];
    m.skeleton.bones = bones
        .iter()
        .map(|&(base, tip)| grm_turtle::Bone { base, tip, ..first })
        .collect();
    m
}

#[test]
fn models_far_from_the_origin_tiny_or_huge_fill_the_frame() {
    use glam::Vec3;
    // An L of width-0 bones: seen from the front it fills the 64 x 64
    // frame less the margin of 2 pixels (64 * 0.04) on every side.
    let l = "width = 0; angle = 90; axiom F F - F F;";
    let near = model(&format!("system L {{ {l} }}"), 0);
    let fitted = front_bbox(&near);
    assert_eq!(fitted, Some((2, 2, 61, 61)));
    // Ten million units from the origin (the fit was in f32 with a floor
    // of 1e-6 of the distance: a fifth of the frame).
    let far = model(
        &format!(
            "system L {{ {} }}",
            l.replace("axiom", "axiom translate(1e7, 1e7, 0)")
        ),
        0,
    );
    assert_eq!(front_bbox(&far), fitted);
    // From a program: 1e-37 units across (the scale overflowed f32:
    // nothing was drawn), and a bone from -f32::MAX to f32::MAX (its
    // extent overflowed: one dot).
    let tiny = with_bones(
        &near,
        &[
            (Vec3::ZERO, Vec3::Y * 2e-37),
            (Vec3::Y * 2e-37, Vec3::new(2e-37, 2e-37, 0.0)),
        ],
    );
    assert_eq!(front_bbox(&tiny), fitted);
    let huge = with_bones(&near, &[(Vec3::splat(-f32::MAX), Vec3::splat(f32::MAX))]);
    let (x0, y0, x1, y1) = front_bbox(&huge).expect("a diagonal line");
    assert!(
        x0 <= 3 && y0 <= 3 && x1 >= 60 && y1 >= 60,
        "{x0} {y0} {x1} {y1}"
    );
}

#[test]
fn azimuths_a_whole_turn_apart_draw_the_same_picture() {
    let m = model(
        "system T { angle = 30; width = 0.1; axiom F A; A -> F [ + F A ] [ & F A ] [ - F A ]; }",
        3,
    );
    let at = |azimuth: f32| {
        draw(
            &m,
            &options(
                96,
                96,
                View::Angles {
                    azimuth,
                    elevation: 20.0,
                },
            ),
        )
    };
    let a = at(35.0);
    for turns in [35.0 + 360.0, 35.0 - 720.0, 35.0 + 3.6e6] {
        assert_eq!(a, at(turns), "azimuth {turns}");
    }
    // A huge azimuth is the angle it names (whole turns off), not the
    // rounding error of its radians.
    let big = 1e30_f32;
    assert_eq!(at(big), at(big.rem_euclid(360.0)));
}

#[test]
fn a_pixel_outside_the_picture_is_none() {
    let img = draw(&empty(), &options(3, 2, FRONT));
    assert!(img.pixel(2, 1).is_some());
    assert_eq!(img.pixel(3, 0), None);
    assert_eq!(img.pixel(0, 2), None);
    assert_eq!(img.pixel(u32::MAX, u32::MAX), None);
    // An Image built by hand with too few bytes.
    let short = Image {
        width: 4,
        height: 4,
        rgba: vec![0; 10],
        transparent: false,
    };
    assert_eq!(short.pixel(3, 3), None);
    assert_eq!(short.pixel(1, 0), Some([0; 4]));
}

#[test]
fn a_transparent_picture_keeps_its_alpha_channel_when_fully_covered() {
    // A box seen face on, in a picture so small that the margin is less
    // than a pixel: every pixel is covered, yet the file is RGBA as asked.
    let m = model("system B { axiom box(1, 1, 1); }", 0);
    let o = RenderOptions {
        transparent: true,
        ..options(4, 4, FRONT)
    };
    let img = draw(&m, &o);
    assert!(img.is_opaque(), "every pixel covered: {:?}", img.rgba);
    let bytes = png_bytes(&img).expect("encodes");
    let reader = png::Decoder::new(std::io::Cursor::new(&bytes))
        .read_info()
        .expect("a PNG");
    assert_eq!(reader.info().color_type, png::ColorType::Rgba);
    // Opaque ones stay RGB.
    let bytes = png_bytes(&draw(&m, &options(4, 4, FRONT))).expect("encodes");
    let reader = png::Decoder::new(std::io::Cursor::new(&bytes))
        .read_info()
        .expect("a PNG");
    assert_eq!(reader.info().color_type, png::ColorType::Rgb);
}

#[test]
fn the_auto_view_of_a_model_spanning_f32s_range_in_depth_is_not_flat() {
    use glam::Vec3;
    // Bones along x and along z, both from -f32::MAX to f32::MAX: the z
    // extent (inf in f32) is not negligible against the x extent.
    let near = model("system S { width = 0; axiom F; }", 0);
    let m = with_bones(
        &near,
        &[
            (
                Vec3::new(-f32::MAX, 0.0, 0.0),
                Vec3::new(f32::MAX, 0.0, 0.0),
            ),
            (
                Vec3::new(0.0, 0.0, -f32::MAX),
                Vec3::new(0.0, 0.0, f32::MAX),
            ),
        ],
    );
    assert_eq!(
        grm_geom::render::auto_angles(&m),
        (
            grm_geom::render::AUTO_AZIMUTH,
            grm_geom::render::AUTO_ELEVATION
        )
    );
}

#[test]
fn a_shared_framing_keeps_models_in_place() {
    // A stalk of 1 and of 4 bones: drawn with the taller one's framing,
    // the short one keeps its place and scale (the bottom quarter), where
    // alone it fills the frame.
    let stalk = |n: u32| model("system S { width = 0; axiom A; A -> F A; }", n);
    let (short, tall) = (stalk(1), stalk(4));
    assert_eq!((short.stats.bones, tall.stats.bones), (1, 4));
    let o = options(64, 64, FRONT);
    let f = framing(&tall, FRONT).union(&framing(&short, FRONT));
    assert_eq!(f, framing(&tall, FRONT), "the tall one holds the short one");
    let bg = draw(&empty(), &o);
    let alone = covered(&draw(&short, &o), &bg).0.expect("drawn");
    let framed = covered(&render_framed(&short, &o, &f).expect("draws"), &bg)
        .0
        .expect("drawn");
    let tall_box = covered(&draw(&tall, &o), &bg).0.expect("drawn");
    // Alone: from the top margin to the bottom one.
    assert!(alone.1 <= 3 && alone.3 >= 60, "{alone:?}");
    // Framed: the bottom quarter of the tall stalk's height.
    assert_eq!(framed.3, tall_box.3, "{framed:?} {tall_box:?}");
    let quarter = (tall_box.3 - tall_box.1) / 4;
    assert!(
        (framed.3 - framed.1).abs_diff(quarter) <= 2,
        "{framed:?} against a quarter of {tall_box:?}"
    );
    // The same framing draws the tall one as render() does.
    assert_eq!(
        render_framed(&tall, &o, &f).expect("draws"),
        draw(&tall, &o)
    );
    // Nothing to draw: an empty framing, and the background.
    let none = framing(&empty(), FRONT);
    assert!(none.is_empty() && !f.is_empty());
    assert_eq!(none.union(&f), f);
    // Framings from other views do not mix.
    let side = View::Angles {
        azimuth: 90.0,
        elevation: 0.0,
    };
    assert_eq!(f.union(&framing(&tall, side)), f);
}

/// A perspective camera at `eye` looking at `target`.
fn camera(eye: [f64; 3], target: [f64; 3], fov: f32) -> View {
    View::Camera {
        eye: DVec3::from_array(eye),
        target: DVec3::from_array(target),
        fov,
    }
}

#[test]
fn a_perspective_camera_draws_at_the_scale_it_sees() {
    // A sphere of radius 0.5 at the origin seen from 2 and from 4 units
    // along +z with a 90 degree field of view: its outline is a circle of
    // angular radius asin(r / d), r / sqrt(d² - r²) of the half height on
    // the picture, centred (not fitted to the frame, as the orthographic
    // views are).
    let m = model("system S { axiom color(1, 0, 0) sphere(0.5); }", 0);
    for d in [2.0f64, 4.0] {
        let o = options(200, 200, camera([0.0, 0.0, d], [0.0, 0.0, 0.0], 90.0));
        let img = draw(&m, &o);
        let (bbox, _) = covered(&img, &draw(&empty(), &o));
        let (x0, y0, x1, y1) = bbox.expect("the sphere is drawn");
        let want = 100.0 * 0.5 / (d * d - 0.25).sqrt();
        for (lo, hi) in [(x0, x1), (y0, y1)] {
            let radius = f64::from(hi - lo + 1) / 2.0;
            let centre = f64::from(lo + hi + 1) / 2.0;
            assert!(
                (radius - want).abs() <= 2.0,
                "d = {d}: radius {radius} px, expected {want}"
            );
            assert!((centre - 100.0).abs() <= 1.0, "d = {d}: centre {centre}");
        }
    }
}

#[test]
fn a_perspective_camera_shows_the_nearer_of_two_equal_spheres_larger() {
    // Two spheres of radius 0.3, at x = -1 (z = 0) and x = +1 (z = -3),
    // seen from +z: the left one is nearer, so wider on the picture.
    let m = model(
        "system S { axiom [ translate(-1, 0, 0) sphere(0.3) ] translate(1, 0, -3) sphere(0.3); }",
        0,
    );
    let o = options(240, 120, camera([0.0, 0.0, 3.0], [0.0, 0.0, -1.0], 60.0));
    let img = draw(&m, &o);
    let bg = draw(&empty(), &o);
    let row: Vec<bool> = (0..240)
        .map(|x| px(&img, x, 60) != px(&bg, x, 60))
        .collect();
    let left = row[..120].iter().filter(|&&c| c).count();
    let right = row[120..].iter().filter(|&&c| c).count();
    assert!(left > 0 && right > 0, "both drawn: {left} {right}");
    // 3 and 6 units away: twice as wide, up to a pixel or two.
    let ratio = left as f64 / right as f64;
    assert!((1.7..=2.3).contains(&ratio), "{left} px against {right} px");
}

#[test]
fn geometry_behind_the_camera_is_clipped_at_the_near_plane() {
    // A floor 100 wide (x and z, 0.01 high) and the camera 1 above it
    // looking along -z: the floor's far corners are in front, its near
    // ones behind the eye. The lower half of the picture is floor up to
    // the horizon (the floor's far edge, 50 away, 1 below: about a pixel
    // under the middle), the upper half background; a triangle
    // projected through the eye without clipping would cover both.
    let m = model(
        "system F { axiom color(0.2, 0.6, 0.2) box(100, 0.01, 100); }",
        0,
    );
    let o = options(200, 200, camera([0.0, 1.0, 0.0], [0.0, 1.0, -10.0], 90.0));
    let img = draw(&m, &o);
    let bg = draw(&empty(), &o);
    for y in [0, 40, 90] {
        for x in [0, 100, 199] {
            assert_eq!(px(&img, x, y), px(&bg, x, y), "sky at {x},{y}");
        }
    }
    for y in [110, 150, 199] {
        for x in [0, 100, 199] {
            let p = px(&img, x, y);
            assert!(
                i32::from(p[1]) > i32::from(p[0]) + 30,
                "green floor at {x},{y}: {p:?}"
            );
        }
    }
    // The same from straight above (no up direction from +y: +x is right).
    let above = camera([0.0, 10.0, 0.0], [0.0, 0.0, 0.0], 60.0);
    let o = options(64, 64, above);
    let img = draw(&m, &o);
    assert!(
        (0..64).all(|x| px(&img, x, 32)[1] > px(&img, x, 32)[0]),
        "the floor fills the view from above"
    );
}

#[test]
fn lines_crossing_the_near_plane_are_clipped() {
    // Hairlines (width 0) from behind the camera to in front of it: drawn
    // from the near plane on, the part behind never folded onto the
    // picture.
    let m = model(
        "system L { angle = 90; width = 0; axiom F F F F F F F F F F; }",
        0,
    );
    // The line runs along +y from 0 to 10; the camera at y = 5 beside it
    // looks along +y, so half the line is behind the eye.
    let o = options(100, 100, camera([0.2, 5.0, 0.0], [0.2, 15.0, 0.0], 90.0));
    let img = draw(&m, &o);
    let bg = draw(&empty(), &o);
    let (bbox, n) = covered(&img, &bg);
    assert!(n > 0, "the part in front is drawn");
    // The drawn part runs from the picture's edge (the near plane) to the
    // vanishing point at the centre; unclipped, the part behind the eye
    // would fold back onto the picture around the centre instead.
    let (x0, y0, x1, y1) = bbox.expect("drawn");
    assert!(
        x0.min(y0) <= 1 || x1.max(y1) >= 98,
        "reaches an edge: {bbox:?}"
    );
    assert!(
        (45..=55).contains(&x0)
            || (45..=55).contains(&x1)
            || (45..=55).contains(&y0)
            || (45..=55).contains(&y1),
        "ends at the vanishing point: {bbox:?}"
    );
}

#[test]
fn a_camera_framing_is_the_camera_and_its_direction() {
    let m = model("system S { axiom sphere(0.5); }", 0);
    let v = camera([3.0, 0.0, 0.0], [0.0, 0.0, 0.0], 40.0);
    let f = framing(&m, v);
    assert_eq!(f.view(), v);
    assert!(
        (f.azimuth - 90.0).abs() < 1e-4 && f.elevation.abs() < 1e-4,
        "{f:?}"
    );
    let up = framing(&m, camera([0.0, 2.0, 2.0], [0.0, 0.0, 0.0], 40.0));
    assert!(
        up.azimuth.abs() < 1e-4 && (up.elevation - 45.0).abs() < 1e-4,
        "{up:?}"
    );
    // Cameras that differ do not mix; the same one keeps itself.
    assert_eq!(f.union(&up), f);
    assert_eq!(f.union(&f), f);
    // An angles framing reports its angles as its view.
    let front = framing(&m, FRONT);
    assert_eq!(front.view(), FRONT);
}

#[test]
fn a_camera_that_cannot_look_is_an_error() {
    let m = model("system S { axiom sphere(0.5); }", 0);
    for (v, why) in [
        (camera([1.0, 1.0, 1.0], [1.0, 1.0, 1.0], 45.0), "different"),
        (camera([0.0, 0.0, f64::NAN], [0.0; 3], 45.0), "finite"),
        (
            camera([1e308, 0.0, 0.0], [-1e308, 0.0, 0.0], 45.0),
            "finite",
        ),
        (camera([0.0, 0.0, 2.0], [0.0; 3], 0.0), "field of view"),
        (camera([0.0, 0.0, 2.0], [0.0; 3], 180.0), "field of view"),
        (camera([0.0, 0.0, 2.0], [0.0; 3], f32::NAN), "field of view"),
    ] {
        let e = render(&m, &options(8, 8, v)).expect_err("refused");
        assert!(matches!(e, RenderError::Camera(_)), "{v:?}: {e:?}");
        assert!(e.to_string().contains(why), "{v:?}: {e}");
        // render_framed with such a framing refuses it too, for the same
        // reason (it said "the view's angles must be finite numbers" for a
        // camera at NaN or 2e308 from its target: its direction's angles).
        let f = framing(&m, v);
        assert_eq!(render_framed(&m, &options(8, 8, FRONT), &f).err(), Some(e));
    }
}

#[test]
fn a_camera_may_stand_any_finite_distance_from_its_target() {
    // The distance was the root of the sum of squares: 1e-300 squared is
    // 0 ("must be different points"), 1e160 squared infinite ("must be
    // finite numbers"). The target only gives the direction (and the near
    // plane, a thousandth of the way): from the origin along -z, a sphere
    // 2 away is drawn the same whatever the target's distance.
    let m = model(
        "system S { axiom translate(0, 0, -2) color(1, 0, 0) sphere(0.5); }",
        0,
    );
    let o = |d: f64| options(40, 40, camera([0.0; 3], [0.0, 0.0, -d], 50.0));
    let seen = draw(&m, &o(1.0));
    assert!(covered(&seen, &draw(&empty(), &o(1.0))).1 > 100);
    assert_eq!(render(&m, &o(1e-300)), Ok(seen));
    assert_eq!(o(1e160).validate(), Ok(()));
}

/// `img`'s rows (0 at the top) with a pixel where `pick` holds.
fn rows_where(img: &Image, pick: impl Fn([u8; 4]) -> bool) -> Vec<u32> {
    (0..img.height)
        .filter(|&y| (0..img.width).any(|x| pick(px(img, x, y))))
        .collect()
}

fn reddish(p: [u8; 4]) -> bool {
    i32::from(p[0]) > i32::from(p[1]) + 30 && i32::from(p[0]) > i32::from(p[2]) + 30
}

#[test]
fn a_line_through_a_narrow_field_of_view_is_drawn() {
    // A bare bone from y = -1 to 1 through the target, 10 away. With a
    // field of view of 1e-4 degrees its ends are 1e5 picture heights
    // apart: the line was dropped as too long (over 1e7 samples), though
    // its middle crosses the picture top to bottom.
    let m = model("system L { width = 0; axiom translate(0, -1, 0) F(2); }", 0);
    for fov in [1.0, 1e-4, 1e-6] {
        let o = options(100, 100, camera([0.0, 0.0, 10.0], [0.0; 3], fov));
        let (bbox, n) = covered(&draw(&m, &o), &draw(&empty(), &o));
        assert_eq!((bbox, n), (Some((49, 0, 50, 99)), 200), "fov {fov}");
    }
}

#[test]
fn a_floor_seen_from_close_to_the_target_has_no_holes() {
    // A floor 2000 wide, the camera 1 above it looking along -z at a
    // target 1e-3, 1e-6 or 1e-300 away: the near plane is a thousandth of
    // that from the eye, and the floor's triangles cut there reached 1e9
    // samples and more, where f32 has no precision left (a sample's edge
    // function rounded to nothing: holes, or no floor at all). Below the
    // horizon (the middle row) floor, above it sky.
    let m = model(
        "system F { axiom color(0.2, 0.6, 0.2) box(2000, 0.01, 2000); }",
        0,
    );
    for d in [1e-3, 1e-6, 1e-300] {
        let o = options(100, 100, camera([0.0, 1.0, 0.0], [0.0, 1.0, -d], 90.0));
        let (img, bg) = (draw(&m, &o), draw(&empty(), &o));
        for y in 0..100 {
            for x in 0..100 {
                let p = px(&img, x, y);
                if y < 48 {
                    assert_eq!(p, px(&bg, x, y), "sky at {x},{y}, d {d}");
                } else if y > 52 {
                    assert!(
                        i32::from(p[1]) > i32::from(p[0]) + 30,
                        "floor at {x},{y}, d {d}: {p:?}"
                    );
                }
            }
        }
    }
}

#[test]
fn depth_keeps_its_precision_at_any_distance_and_field_of_view() {
    // A red plate 0.05 in front of a blue box, seen from 10 to 1e9 away
    // with the field of view that frames the box: depth was focal / z in
    // f32, whose 24 bits cannot tell 1e7 from 1e7 - 0.05 (the box showed
    // through the plate); it is now relative to the model's far end.
    let m = model(
        "system O { axiom color(0, 0, 1) box(1, 1, 1) translate(0, 0, 0.55) color(1, 0, 0) box(0.5, 0.5, 0.05); }",
        0,
    );
    for d in [10.0f64, 1e5, 1e7, 1e9] {
        let fov = (2.0 * (1.0 / d).atan()).to_degrees() as f32;
        let o = options(50, 50, camera([0.0, 0.5, d], [0.0, 0.5, 0.0], fov));
        let c = px(&draw(&m, &o), 25, 25);
        assert!(reddish(c), "{d} away: {c:?}");
    }
    // A tiny field of view: the focal length (1e23 samples at 1e-20
    // degrees) overflowed f32 in the triangles' edge functions and depth,
    // and nothing was drawn. The view's axis is off the face's diagonal
    // (what it sees of the face is all one triangle).
    let m = model(
        "system B { axiom color(1, 0, 0) translate(0, -0.5, 0) box(1, 1, 1); }",
        0,
    );
    for fov in [1e-3, 1e-20, 1e-38] {
        let o = options(20, 20, camera([0.1, 0.2, 10.0], [0.1, 0.2, 0.0], fov));
        let img = draw(&m, &o);
        assert!(
            img.rgba
                .chunks_exact(4)
                .all(|p| reddish([p[0], p[1], p[2], p[3]])),
            "fov {fov}: the face fills the picture"
        );
    }
}

/// A green floor 400 wide (its top at y = 0.01), maybe a blue box 1.5
/// high standing on it 2.5 to 3.5 along -z, and a red bare bone along -z
/// at height `y` from 5 behind the origin to `far` in front.
fn floor_and_bone(y: f32, far: f32, with_box: bool) -> Model {
    let blue = if with_box {
        "[ translate(0, 0, -3) color(0, 0, 1) box(1, 1.5, 1) ]"
    } else {
        ""
    };
    let mut m = model(
        &format!(
            "system S {{ width = 0; axiom color(0, 0.6, 0) box(400, 0.01, 400) {blue} \
             color(1, 0, 0) F; }}"
        ),
        0,
    );
    let bone = &mut m.skeleton.bones[0];
    bone.base = glam::Vec3::new(0.0, y, 5.0);
    bone.tip = glam::Vec3::new(0.0, y, -far);
    m
}

#[test]
fn a_bare_bone_on_a_floor_shows_all_along_and_not_through_what_is_in_front() {
    // The camera stands `h` above the floor looking along -z (fov 90:
    // the horizon is the middle row, a point d away on the floor h (100
    // / d) pixels below it). The bone lies on the floor (a tie: it
    // shows) from behind the camera to the horizon, so every row from
    // the horizon down has its red pixels. Its depth was the step's, up
    // to half a sample off the sample's (at a grazing angle, far more
    // than the bias): a bone to 1000 away showed in 1 row of 100, from
    // 0.1 above the floor in none. And its bias was one number for the
    // whole line, taken half way along (its near end needs a million
    // times that): from 0.05 above, 74 rows lacked the line.
    for (h, far) in [(1.0, 1000.0f32), (0.05, 1000.0), (0.1, 100.0), (1.0, 10.0)] {
        let m = floor_and_bone(0.01, far, false);
        let o = options(200, 200, camera([0.0, h, 0.0], [0.0, h, -10.0], 90.0));
        let img = draw(&m, &o);
        // From the horizon, or the row of its far end, down: the line's
        // two pixels (two samples wide, on the middle columns) red.
        let top = 100 + ((h - 0.01) * 100.0 / f64::from(far)).floor() as u32;
        for y in top + 2..200 {
            let red = (0..200).filter(|&x| reddish(px(&img, x, y))).count();
            assert!(red >= 2, "h {h}, to {far}: row {y} has {red} red");
        }
    }
    // 0.5 under the floor (well past the bias, 1e-4 of the model's
    // size): hidden all along.
    let m = floor_and_bone(-0.5, 1000.0, false);
    let o = options(200, 200, camera([0.0, 1.0, 0.0], [0.0, 1.0, -10.0], 90.0));
    assert_eq!(rows_where(&draw(&m, &o), reddish), Vec::<u32>::new());
    // A box taller than the eye in front of it hides it from the box's
    // foot (2.5 away: row 100 + 99 / 2.5) to the horizon.
    let m = floor_and_bone(0.01, 1000.0, true);
    let red = rows_where(&draw(&m, &o), reddish);
    assert!(
        red.first().is_some_and(|&y| (138..=141).contains(&y)) && red.len() >= 58,
        "red rows {red:?}"
    );
}

#[test]
fn a_bare_bone_on_a_surface_shows_from_far_away() {
    // The bone on the square of `a_bare_bone_behind_a_surface_is_hidden_
    // at_any_scale`, seen from 1e4 and 1e7 away through a narrow field of
    // view that frames the square: a tie up to f32's precision of 1 / z,
    // which the bias (1e-4 of the square's size) was far below.
    for (dz, shows) in [("0", true), ("-0.02", false)] {
        let m = model(
            &format!(
                "system S {{ angle = 90; width = 0; axiom translate(-0.5, -0.5, 0) \
                 color(0, 0.6, 0) [ {{ . f + f + f + f }} ] \
                 [ translate(0.5, 0.1, {dz}) color(1, 0, 0) F(0.8) ]; }}"
            ),
            0,
        );
        for d in [2.0f64, 1e4, 1e7] {
            let fov = (2.0 * (0.6 / d).atan()).to_degrees() as f32;
            let img = draw(&m, &options(60, 60, camera([0.0, 0.0, d], [0.0; 3], fov)));
            let mid = [px(&img, 29, 30), px(&img, 30, 30)];
            assert_eq!(
                mid.iter().any(|p| p[0] > p[1]),
                shows,
                "{d} away, bone at z {dz}: {mid:?}"
            );
        }
    }
}

#[test]
fn camera_pictures_are_the_same_on_any_threads_and_in_a_shared_framing() {
    // A tree seen from inside it (its tubes cut at the near plane and the
    // guard band), on 1 and 4 threads; and each stage of its growth drawn
    // with the framing of all of them (`grmc derive --frames`) as alone:
    // a camera is not fitted, so nothing moves. Behind the camera, nothing.
    let text = "system T { angle = 25; width = 0.05; axiom F A; A -> F [ + F A ] [ - ! (0) F A ] { . f + f + f }; }";
    let stages: Vec<Model> = (1..5).map(|i| model(text, i)).collect();
    let v = camera([0.1, 0.5, 0.3], [0.0, 2.0, -1.0], 100.0);
    let o = RenderOptions {
        samples: 3,
        ..options(90, 110, v)
    };
    let on = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("a pool")
            .install(|| draw(&stages[3], &o))
    };
    let one = on(1);
    assert!(covered(&one, &draw(&empty(), &o)).1 > 500);
    assert_eq!(one, on(4));
    let all = stages
        .iter()
        .fold(framing(&stages[0], v), |f, m| f.union(&framing(m, v)));
    for m in &stages {
        assert_eq!(render_framed(m, &o, &all), render(m, &o));
    }
    let away = options(90, 110, camera([0.0, -1.0, 0.0], [0.0, -2.0, 0.0], 100.0));
    assert_eq!(draw(&stages[3], &away), draw(&empty(), &away));
}

#[test]
fn a_polygon_cut_at_the_near_plane_keeps_its_side() {
    // A flat quad 100 wide (one face, lit two-sided) in the xy plane, seen
    // from either side 1e-3 or 3 away, looking into it obliquely (it
    // fills the picture): it is cut at the near plane and the guard band
    // into polygons drawn as fans, and every triangle of them is lit as
    // the side the camera sees, so the picture is one colour, the same
    // from both distances.
    let m = model(
        "system P { angle = 90; axiom translate(-50, -50, 0) color(0.2, 0.8, 0.2) { . f(100) + f(100) + f(100) + f(100) }; }",
        0,
    );
    for side in [1.0, -1.0] {
        let colours = [1e-3, 3.0].map(|z| {
            let eye = [0.0, 0.0, side * z];
            let o = options(60, 60, camera(eye, [0.03, 0.02, side * (z - 0.1)], 120.0));
            let img = draw(&m, &o);
            let first = px(&img, 0, 0);
            assert!(first[1] > first[0].saturating_add(60), "green: {first:?}");
            for p in img.rgba.chunks_exact(4) {
                assert!(
                    (0..3).all(|k| p[k].abs_diff(first[k]) <= 1),
                    "side {side}, {z} away: {p:?} and {first:?}"
                );
            }
            first
        });
        assert!(
            (0..3).all(|k| colours[0][k].abs_diff(colours[1][k]) <= 1),
            "side {side}: {colours:?}"
        );
    }
}

#[test]
fn cutting_at_the_guard_band_leaves_the_picture_as_it_was() {
    // A picture 20 wide is the middle of one 300 wide (the same height
    // and vertical field of view: the same scale). The long sides of a
    // cylinder seen along it reach past the narrow picture's guard band
    // (a picture size beyond each side), not the wide one's, and are cut
    // there; the colours of the cut were taken at the distance along the
    // edge in space rather than on the picture, which the rasterizer
    // interpolates over (up to 9 levels off). Now they match, up to the
    // rounding of the cut and of the near plane's (2 levels).
    let m = model(
        "system S { axiom color(0.9, 0.5, 0.2) cylinder(3, 100); }",
        0,
    );
    for (eye, target, fov) in [
        ([1.0, 2.0, 0.0], [0.0, 50.0, 2.0], 120.0),
        ([0.0, 5.0, 8.0], [0.0, 50.0, 0.0], 60.0),
        ([4.0, 0.0, 4.0], [0.0, 30.0, 0.0], 90.0),
    ] {
        let v = camera(eye, target, fov);
        let narrow = draw(&m, &options(20, 40, v));
        let wide = draw(&m, &options(300, 40, v));
        for y in 0..40 {
            for x in 0..20 {
                let (p, q) = (px(&narrow, x, y), px(&wide, x + 140, y));
                assert!(
                    (0..3).all(|k| p[k].abs_diff(q[k]) <= 2),
                    "from {eye:?}, at {x},{y}: {p:?} against {q:?}"
                );
            }
        }
    }
}

/// Materials of opacity 0.5 (`glass`), 0 (`ghost`), opaque red and blue.
const MATERIALS: &str = "material glass { color = rgb(1, 0, 0); opacity = 0.5; }\n\
    material ghost { color = rgb(0, 1, 0); opacity = 0; }\n\
    material red { color = rgb(1, 0, 0); }\n\
    material blue { color = rgb(0, 0, 1); }\n";

#[test]
fn a_translucent_surface_shows_what_is_behind_it() {
    // A red disc facing +z in front of a blue box.
    let scene = |front: &str| {
        model(
            &format!(
                "{MATERIALS}system S {{ axiom material(blue) box(1, 1, 1) translate(0, 0.5, 2) &(90) material({front}) disc(0.4); }}"
            ),
            0,
        )
    };
    let o = options(80, 80, FRONT);
    let at_centre = |m: &Model| px(&draw(m, &o), 40, 40);
    let opaque = at_centre(&scene("red"));
    let glass = at_centre(&scene("glass"));
    let ghost = at_centre(&scene("ghost"));
    assert!(opaque[0] > 100 && opaque[2] < 20, "opaque red: {opaque:?}");
    assert!(
        ghost[2] > 100 && ghost[0] < 20,
        "opacity 0 is not drawn: {ghost:?}"
    );
    // Half red, half the blue behind.
    assert!(
        glass[0] > 60 && glass[2] > 60,
        "red over blue, both showing: {glass:?}"
    );
    // Drawn after everything opaque, whatever the model's order: the
    // same picture with the disc first.
    let first = model(
        &format!(
            "{MATERIALS}system S {{ axiom [ translate(0, 0.5, 2) &(90) material(glass) disc(0.4) ] material(blue) box(1, 1, 1); }}"
        ),
        0,
    );
    assert_eq!(draw(&first, &o), draw(&scene("glass"), &o));
}

#[test]
fn a_translucent_surface_alone_has_partial_alpha() {
    let disc = |material: &str| {
        model(
            &format!("{MATERIALS}system S {{ axiom &(90) material({material}) disc(1); }}"),
            0,
        )
    };
    let o = RenderOptions {
        transparent: true,
        ..options(40, 40, FRONT)
    };
    let glass = px(&draw(&disc("glass"), &o), 20, 20);
    assert!(
        (i32::from(glass[3]) - 128).abs() <= 1,
        "alpha of opacity 0.5: {glass:?}"
    );
    // A disc is one sheet (its back face lies on its front face and
    // counts once); a box has two surfaces in line, a front and a back:
    // 1 - 0.5² of the light is stopped.
    let glass_box = model(
        &format!("{MATERIALS}system S {{ axiom material(glass) box(2, 2, 2); }}"),
        0,
    );
    let img = draw(&glass_box, &o);
    // Every pixel inside: the triangles' shared edges (the faces'
    // diagonals cross at the centre) lose no layer.
    for y in 3..37 {
        for x in 3..37 {
            let a = px(&img, x, y)[3];
            assert!(
                (i32::from(a) - 191).abs() <= 1,
                "two layers at {x},{y}: {a}"
            );
        }
    }
    // Its colour is the surface's, not darkened by the coverage (the
    // picture is not premultiplied): as bright as the opaque disc's.
    let red = px(&draw(&disc("red"), &o), 20, 20);
    assert_eq!(red[3], 255);
    assert!(
        (i32::from(glass[0]) - i32::from(red[0])).abs() <= 2,
        "{glass:?} against {red:?}"
    );
    // On the background: between the background and the opaque red.
    let o = options(40, 40, FRONT);
    let bg = px(&draw(&empty(), &o), 20, 20);
    let on_bg = px(&draw(&disc("glass"), &o), 20, 20);
    let red = px(&draw(&disc("red"), &o), 20, 20);
    assert!(
        on_bg[1] < bg[1] && on_bg[1] > red[1],
        "{on_bg:?} between {bg:?} and {red:?}"
    );
    // Opacity 0 draws nothing at all.
    assert_eq!(draw(&disc("ghost"), &o), draw(&empty(), &o));
}

#[test]
fn translucent_surfaces_are_drawn_farthest_first() {
    // Two translucent discs, one red (nearer the camera on +z) and one
    // green; whichever the model lists first, the nearer one's colour
    // dominates, and the two orders draw the same picture.
    let text = |first: (&str, f32), second: (&str, f32)| {
        format!(
            "material r {{ color = rgb(1, 0, 0); opacity = 0.6; }}\n\
             material g {{ color = rgb(0, 1, 0); opacity = 0.6; }}\n\
             system S {{ axiom [ translate(0, 0, {}) &(90) material({}) disc(1) ] translate(0, 0, {}) &(90) material({}) disc(1); }}",
            first.1, first.0, second.1, second.0
        )
    };
    let o = options(40, 40, FRONT);
    let a = draw(&model(&text(("r", 1.0), ("g", 0.0)), 0), &o);
    let b = draw(&model(&text(("g", 0.0), ("r", 1.0)), 0), &o);
    assert_eq!(a, b);
    let p = px(&a, 20, 20);
    assert!(p[0] > p[1] && p[1] > 30, "red over green: {p:?}");
}

#[test]
fn the_orbit_camera_frames_the_model_as_the_preview_does() {
    use grm_geom::render::orbit_camera;
    // A box far from the origin: the camera looks at its centre from the
    // direction asked, and the box is whole and centred in the picture.
    let m = model(
        "system S { axiom translate(1000, 50, -20) color(1, 0, 0) box(4, 2, 3); }",
        0,
    );
    let v = orbit_camera(&m, 35.0, 20.0, 45.0).expect("a camera");
    let View::Camera { eye, target, fov } = v else {
        panic!("{v:?}")
    };
    assert_eq!(fov, 45.0);
    assert!(
        (target - DVec3::new(1000.0, 51.0, -20.0)).length() < 1e-3,
        "{target}"
    );
    let f = framing(&m, v);
    assert!(
        (f.azimuth - 35.0).abs() < 1e-3 && (f.elevation - 20.0).abs() < 1e-3,
        "{f:?}"
    );
    assert!((eye - target).length() > 2.0);
    let o = options(100, 100, v);
    let (bbox, _) = covered(&draw(&m, &o), &draw(&empty(), &o));
    let (x0, y0, x1, y1) = bbox.expect("drawn");
    assert!(x0 > 5 && y0 > 5 && x1 < 95 && y1 < 95, "whole: {bbox:?}");
    assert!(x1 - x0 > 30, "not a speck: {bbox:?}");
    assert!((i64::from(x0 + x1) - 100).abs() <= 6, "centred: {bbox:?}");
    // Nothing to frame: no camera.
    assert_eq!(orbit_camera(&empty(), 0.0, 0.0, 45.0), None);
}

#[test]
fn what_is_not_drawn_is_not_framed() {
    // A red box, and a tube of opacity 0 far to its right: the picture
    // frames the box as if the tube were not there (it is not drawn).
    let with = model(
        &format!(
            "{MATERIALS}system S {{ width = 0.5; axiom [ material(red) box(1, 1, 1) ] translate(20, 0, 0) material(ghost) F(1); }}"
        ),
        0,
    );
    let without = model(
        &format!("{MATERIALS}system S {{ axiom material(red) box(1, 1, 1); }}"),
        0,
    );
    let o = options(60, 60, FRONT);
    assert_eq!(draw(&with, &o), draw(&without, &o));
}

#[test]
fn a_bare_bone_on_a_floor_shows_all_along_from_a_grazing_orthographic_view() {
    // A floor and a bone along it, seen from 5 degrees above the floor,
    // fitted: the bone lying on the floor shows
    // in as many rows as one lifted well above it (which nothing hides).
    // Its depth was the step's, up to half a sample off the sample's: at
    // a grazing angle more than the bias, so it showed in about half its
    // rows.
    let o = options(
        200,
        200,
        View::Angles {
            azimuth: 0.0,
            elevation: 5.0,
        },
    );
    let scene = |y: f32| {
        let mut m = model(
            "system S { width = 0; axiom color(0, 0.6, 0) box(20, 0.01, 20) color(1, 0, 0) F; }",
            0,
        );
        let bone = &mut m.skeleton.bones[0];
        bone.base = glam::Vec3::new(0.0, y, 9.0);
        bone.tip = glam::Vec3::new(0.0, y, -9.0);
        m
    };
    let on = rows_where(&draw(&scene(0.01), &o), reddish);
    let above = rows_where(&draw(&scene(0.3), &o), reddish);
    assert!(above.len() > 8, "the lifted bone spans rows: {above:?}");
    assert!(
        on.len() + 1 >= above.len(),
        "on the floor {} rows, lifted {} rows: {on:?}",
        on.len(),
        above.len()
    );
}

/// A camera that shows nothing of the model says why instead of drawing an
/// empty picture silently: so far that the model is under a pixel (a
/// position near or past f32's range), behind it, or looking away; and
/// one that shows the model says nothing.
#[test]
fn a_camera_that_shows_nothing_says_why() {
    use grm_geom::render::camera_warning;
    let m = model("system S { axiom color(1, 0, 0) sphere(0.5); }", 0);
    let origin = [0.0, 0.0, 0.0];
    let seen = camera([0.0, 0.0, 4.0], origin, 45.0);
    assert_eq!(camera_warning(&m, &seen, 200, 200), None);
    // Near the model, and around it: seen (partly).
    assert_eq!(
        camera_warning(&m, &camera([0.0, 0.0, 0.1], origin, 45.0), 200, 200),
        None
    );
    for far in [1e39, 3.4e38, 1e30, 1e300] {
        let w = camera_warning(&m, &camera([far, 0.0, 0.0], origin, 45.0), 200, 200)
            .expect("under a pixel");
        assert!(w.contains("smaller than a pixel"), "{far}: {w}");
        // And the picture is indeed the background: nothing was lost.
        let o = options(200, 200, camera([far, 0.0, 0.0], origin, 45.0));
        let (_, n) = covered(&draw(&m, &o), &draw(&empty(), &o));
        assert_eq!(n, 0, "{far}: {n} pixels drawn");
    }
    let behind = camera([0.0, 0.0, 4.0], [0.0, 0.0, 8.0], 45.0);
    let w = camera_warning(&m, &behind, 200, 200).expect("behind");
    assert!(w.contains("behind the camera"), "{w}");
    let away = camera([0.0, 0.0, 4.0], [4.0, 0.0, 0.0], 45.0);
    let w = camera_warning(&m, &away, 200, 200).expect("outside");
    assert!(w.contains("outside what the camera sees"), "{w}");
    // Views that are not a camera, and an empty model: nothing to say.
    assert_eq!(camera_warning(&m, &FRONT, 200, 200), None);
    assert_eq!(camera_warning(&empty(), &behind, 200, 200), None);
}

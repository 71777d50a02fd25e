//! `grm/picture`: the model a `grm/preview` with the same parameters shows,
//! drawn as a PNG; the same picture `grmc derive -o x.png` writes for the
//! same seed and parameters.

mod common;

use base64::Engine as _;
use common::*;
use serde_json::{Value, json};

fn decode(r: &Value) -> (u32, u32, png::ColorType, Vec<u8>) {
    let bytes = base64::engine::general_purpose::STANDARD
        .decode(r["png"].as_str().unwrap_or_else(|| panic!("no png: {r}")))
        .expect("base64");
    let mut reader = png::Decoder::new(std::io::Cursor::new(bytes))
        .read_info()
        .expect("a PNG");
    let mut buf = vec![0; reader.output_buffer_size().expect("size")];
    let info = reader.next_frame(&mut buf).expect("a frame");
    buf.truncate(info.buffer_size());
    (info.width, info.height, info.color_type, buf)
}

const TREE: &str = "param a = 30 in 10 .. 60;\n\
    system T {\n    iterations = 3;\n    angle = a;\n    width = 0.05;\n    axiom F A;\n    \
    A -> F [ + F A ] [ - F A ];\n}\n";

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_picture_of_what_the_preview_shows() {
    let mut c = Client::start().await;
    let path = std::env::temp_dir().join(format!("grm-picture-{}.grm", std::process::id()));
    let u = c.open(&path, TREE).await;
    let doc = json!({ "uri": u.as_str() });

    let preview = c.ok("grm/preview", json!({ "textDocument": doc })).await;
    let r = c
        .ok(
            "grm/picture",
            json!({ "textDocument": doc, "width": 120, "height": 90 }),
        )
        .await;
    assert_eq!(r["version"], preview["version"]);
    assert_eq!(r["system"], "T");
    assert_eq!(r["triangles"], preview["stats"]["triangles"]);
    assert_eq!(r["bones"], preview["stats"]["bones"]);
    // The automatic view of a flat tree: face on.
    assert_eq!(r["view"], json!({ "azimuth": 0.0, "elevation": 0.0 }));
    let (w, h, colour, pixels) = decode(&r);
    assert_eq!((w, h, colour), (120, 90, png::ColorType::Rgb));
    let distinct: std::collections::HashSet<&[u8]> = pixels.chunks_exact(3).collect();
    assert!(
        distinct.len() > 20,
        "a drawn tree: {} colours",
        distinct.len()
    );

    // The same request draws the same bytes; other parameters, a view and
    // a transparent background draw another picture.
    let again = c
        .ok(
            "grm/picture",
            json!({ "textDocument": doc, "width": 120, "height": 90 }),
        )
        .await;
    assert_eq!(again["png"], r["png"]);
    let other = c
        .ok(
            "grm/picture",
            json!({
                "textDocument": doc, "width": 120, "height": 90,
                "params": { "a": 50.0 }, "view": { "azimuth": 30.0, "elevation": -20.0 },
                "transparent": true,
            }),
        )
        .await;
    assert_eq!(
        other["view"],
        json!({ "azimuth": 30.0, "elevation": -20.0 })
    );
    let (_, _, colour, rgba) = decode(&other);
    assert_eq!(colour, png::ColorType::Rgba);
    assert_eq!(rgba[3], 0, "the corner is transparent");
    assert_ne!(other["png"], r["png"]);

    // Errors: a picture that cannot be drawn is invalid params; a stale
    // version is ContentModified; a preview error is the preview's.
    let e = c
        .request("grm/picture", json!({ "textDocument": doc, "width": 0 }))
        .await
        .expect_err("a 0-pixel picture");
    assert_eq!(e["code"], -32602, "{e}");
    let e = c
        .request(
            "grm/picture",
            json!({ "textDocument": doc, "view": { "azimuth": 0.0, "elevation": 95.0 } }),
        )
        .await
        .expect_err("elevation past 90");
    assert_eq!(e["code"], -32602, "{e}");
    let e = c
        .request("grm/picture", json!({ "textDocument": doc, "version": 99 }))
        .await
        .expect_err("a stale version");
    assert_eq!(e["code"], -32801, "{e}");
    let e = c
        .request(
            "grm/picture",
            json!({ "textDocument": doc, "params": { "a": 500.0 } }),
        )
        .await
        .expect_err("a parameter out of range");
    assert!(
        e["message"]
            .as_str()
            .is_some_and(|m| m.contains("outside its range")),
        "{e}"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_server_announces_pictures() {
    let c = Client::start().await;
    assert_eq!(
        c.initialized["capabilities"]["experimental"]["grmPreview"],
        json!({ "version": 3, "picture": true })
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_picture_through_the_previews_camera() {
    let mut c = Client::start().await;
    let path = std::env::temp_dir().join(format!("grm-picture-cam-{}.grm", std::process::id()));
    let u = c.open(&path, TREE).await;
    let doc = json!({ "uri": u.as_str() });
    let camera = json!({ "position": [0.0, 2.0, 6.0], "target": [0.0, 2.0, 0.0], "fov": 45.0 });
    let r = c
        .ok(
            "grm/picture",
            json!({ "textDocument": doc, "width": 80, "height": 60, "camera": camera }),
        )
        .await;
    // The camera is echoed; the view is its direction from the target (+z).
    assert_eq!(r["camera"], camera);
    assert_eq!(r["view"], json!({ "azimuth": 0.0, "elevation": 0.0 }));
    let (w, h, _, pixels) = decode(&r);
    assert_eq!((w, h), (80, 60));
    // Not the fitted front view: the camera sees the tree at its own scale.
    let front = c
        .ok(
            "grm/picture",
            json!({ "textDocument": doc, "width": 80, "height": 60,
                    "view": { "azimuth": 0.0, "elevation": 0.0 } }),
        )
        .await;
    assert_ne!(decode(&front).3, pixels);
    // A picture from farther away covers fewer pixels; the field of view
    // defaults to 45 degrees.
    let background = pixels[..3].to_vec();
    let covered = |p: &[u8]| {
        p.chunks_exact(3)
            .filter(|q| *q != background.as_slice())
            .count()
    };
    let far = c
        .ok(
            "grm/picture",
            json!({ "textDocument": doc, "width": 80, "height": 60,
                    "camera": { "position": [0.0, 2.0, 30.0], "target": [0.0, 2.0, 0.0] } }),
        )
        .await;
    assert_eq!(far["camera"]["fov"], 45.0);
    // Without a target the camera looks at the model's centre, and says so.
    let centred = c
        .ok(
            "grm/picture",
            json!({ "textDocument": doc, "width": 80, "height": 60,
                    "camera": { "position": [0.0, 2.0, 30.0] } }),
        )
        .await;
    let preview = c.ok("grm/preview", json!({ "textDocument": doc })).await;
    let (lo, hi) = (
        &preview["stats"]["boundsMin"],
        &preview["stats"]["boundsMax"],
    );
    for k in 0..3 {
        let want = (lo[k].as_f64().unwrap() + hi[k].as_f64().unwrap()) / 2.0;
        let got = centred["camera"]["target"][k].as_f64().unwrap();
        assert!(
            (got - want).abs() < 1e-4,
            "target {k}: {got} against {want}"
        );
    }
    assert!(centred.get("generation").is_none());
    let (near_n, far_n) = (covered(&pixels), covered(&decode(&far).3));
    assert!(far_n > 0 && far_n < near_n, "{far_n} against {near_n}");
    assert!(far.get("warning").is_none(), "{far}");
    // Past f32's range the tree is under a pixel: the answer says why (the
    // picture is the empty model's: crates/grm-geom/tests/render.rs).
    let beyond = c
        .ok(
            "grm/picture",
            json!({ "textDocument": doc, "width": 80, "height": 60,
                    "camera": { "position": [0.0, 2.0, 1e39], "target": [0.0, 2.0, 0.0] } }),
        )
        .await;
    assert!(
        beyond["warning"]
            .as_str()
            .is_some_and(|w| w.contains("smaller than a pixel")),
        "{beyond}"
    );

    // A view and a camera, or a camera that cannot look: invalid params.
    for (params, says) in [
        (
            json!({ "textDocument": doc, "camera": camera, "view": { "azimuth": 0.0, "elevation": 0.0 } }),
            "not both",
        ),
        (
            json!({ "textDocument": doc, "camera": { "position": [1.0, 1.0, 1.0], "target": [1.0, 1.0, 1.0] } }),
            "different points",
        ),
        (
            json!({ "textDocument": doc, "camera": { "position": [0.0, 0.0, 1.0], "target": [0.0, 0.0, 0.0], "fov": 0.0 } }),
            "field of view",
        ),
    ] {
        let e = c.request("grm/picture", params).await.expect_err("refused");
        assert_eq!(e["code"], -32602, "{e}");
        assert!(
            e["message"].as_str().is_some_and(|m| m.contains(says)),
            "{e}"
        );
    }
}

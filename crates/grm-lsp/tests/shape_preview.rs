//! The preview of a shape system (`mode = shape`): `grm/preview` grows it
//! through `grm_grow::shape`, `grm/pick` on its triangles answers the
//! picked shape's key, locators, the operation that made it (where the
//! editor jumps) and its ancestors' scopes (tests/lsp/shape.grm).

mod common;

use base64::Engine as _;
use common::*;
use serde_json::{Value, json};
use std::fmt::Write;

/// The text an LSP range covers.
fn text_of<'a>(text: &'a str, r: &Value) -> &'a str {
    let src = grm_diag::SourceFile::new("", text);
    let o = |p: &Value| {
        src.offset_of_utf16(
            p["line"].as_u64().unwrap() as u32,
            p["character"].as_u64().unwrap() as u32,
        ) as usize
    };
    &text[o(&r["start"])..o(&r["end"])]
}

/// The first pick (part, its first triangle) whose rule is `symbol`'s.
fn pick_made_by(r: &Value, symbol: &str) -> Option<(usize, u64)> {
    let origins = r["origins"].as_array().unwrap();
    for (i, part) in r["parts"].as_array().unwrap().iter().enumerate() {
        for pk in &picks(part) {
            let o = pk["origin"].as_u64()? as usize;
            if origins[o]["symbol"] == symbol {
                return Some((i, pk["firstTriangle"].as_u64().unwrap()));
            }
        }
    }
    None
}

#[tokio::test]
async fn shape_preview_and_pick() {
    let mut c = Client::start().await;
    let (p, text) = fixture("shape.grm");
    let u = c.open(&p, &text).await;
    let r = c
        .ok("grm/preview", json!({ "textDocument": { "uri": u } }))
        .await;
    let mut out = String::new();
    assert_eq!(r["mode"], "shape");
    assert_eq!(r["system"], "Townhouse");
    let shape = &r["shape"];
    let _ = writeln!(
        out,
        "seed {} nodes {} shapes {} groups {} (stats: modules {}, bones {})",
        r["seed"],
        shape["nodes"],
        shape["shapes"],
        shape["groups"],
        r["stats"]["modules"],
        r["stats"]["bones"]
    );
    assert_eq!(r["stats"]["modules"], shape["shapes"]);
    assert!(shape["groups"].as_u64().unwrap() > 20, "{shape}");
    // One origin per rule, in source order.
    let origins = r["origins"].as_array().unwrap();
    let rules: Vec<&str> = origins
        .iter()
        .map(|o| o["symbol"].as_str().unwrap())
        .collect();
    let _ = writeln!(out, "rules {}", rules.join(" "));
    assert_eq!(rules.len(), 10);
    for o in origins {
        assert!(text_of(&text, &o["range"]).starts_with(o["symbol"].as_str().unwrap()));
    }
    // Every triangle is picked: a shape node, made by a rule.
    let mut triangles = 0;
    for part in r["parts"].as_array().unwrap() {
        let nt = part["triangleCount"].as_u64().unwrap();
        let mut covered = 0;
        for pk in &picks(part) {
            assert_eq!(pk["kind"], "shape");
            assert_eq!(pk["index"], pk["module"]);
            assert!(pk["origin"].is_u64(), "{pk}");
            covered += pk["triangleCount"].as_u64().unwrap();
        }
        assert_eq!(covered, nt);
        triangles += nt;
    }
    assert_eq!(triangles, r["stats"]["triangles"].as_u64().unwrap());
    // A wall of a tile: made by the tile's split, below a floor and a facade.
    let (part, tri) = pick_made_by(&r, "Tile").expect("a tile's part");
    let pk = c
        .ok(
            "grm/pick",
            json!({ "textDocument": { "uri": u }, "part": part, "triangle": tri }),
        )
        .await;
    let s = &pk["shape"];
    let made = text_of(&text, &pk["range"]);
    let _ = writeln!(
        out,
        "\npick {}: made by {} at `{made}`\n  key {} exact {}\n  semantic {}\n  rule {}",
        pk["symbol"], s["madeBy"], pk["key"], s["exact"], s["semantic"], s["rule"]
    );
    assert!(made.starts_with("split(x) { ~1: Wall"), "{made}");
    assert_eq!(s["madeBy"], "split.x");
    assert!(s["semantic"].as_str().unwrap().contains("floor"));
    assert!(s["semantic"].as_str().unwrap().contains("facade"));
    assert_eq!(pk["key"].as_str().map(str::len), Some(8));
    // The ancestry and the scopes follow the same path, down to the shape.
    let ancestry = pk["ancestry"].as_array().unwrap();
    let scopes = s["scopes"].as_array().unwrap();
    assert_eq!(ancestry.len(), scopes.len());
    assert_eq!(ancestry.last().unwrap()["key"], pk["key"]);
    assert_eq!(scopes.first().unwrap()["label"], "Lot");
    assert_eq!(scopes.last().unwrap()["label"], pk["symbol"]);
    assert_eq!(scopes.last().unwrap()["node"], s["node"]);
    for sc in scopes {
        let cuts: Vec<String> = sc["cuts"]
            .as_array()
            .map(|c| {
                c.iter()
                    .map(|x| format!("{:.2}", x.as_f64().unwrap()))
                    .collect()
            })
            .unwrap_or_default();
        let size: Vec<String> = sc["size"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| format!("{:.2}", x.as_f64().unwrap()))
            .collect();
        let _ = writeln!(
            out,
            "  {} {} size [{}] axis {} cuts [{}]",
            if sc["command"] == true {
                "command"
            } else {
                "shape  "
            },
            sc["label"].as_str().unwrap(),
            size.join(", "),
            sc["axis"],
            cuts.join(", ")
        );
        // A unit frame: the axes are orthonormal.
        let ax: Vec<[f64; 3]> = (0..3)
            .map(|i| {
                let a = &sc["axes"][i];
                [0, 1, 2].map(|k| a[k].as_f64().unwrap())
            })
            .collect();
        for (i, a) in ax.iter().enumerate() {
            let dot = |b: &[f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
            assert!((dot(a) - 1.0).abs() < 1e-4, "{sc}");
            for b in &ax[i + 1..] {
                assert!(dot(b).abs() < 1e-4, "{sc}");
            }
        }
        // A split's cuts lie inside its scope, in order.
        if let (Some(axis), Some(cuts)) = (sc["axis"].as_u64(), sc["cuts"].as_array()) {
            let len = sc["size"][axis as usize].as_f64().unwrap();
            let xs: Vec<f64> = cuts.iter().map(|x| x.as_f64().unwrap()).collect();
            assert!(xs.windows(2).all(|w| w[0] < w[1]) && xs.iter().all(|&x| x > 0.0 && x < len));
        }
    }
    let repeat = scopes
        .iter()
        .find(|sc| sc["label"] == "repeat.y")
        .expect("the floors' repeat");
    assert!(repeat["cuts"].as_array().unwrap().len() >= 2, "{repeat}");

    // A window's pane: inserted by the window's rule; the shape picked is
    // the window, and the rule that rewrote it is its first one.
    let (part, tri) = pick_made_by(&r, "Window").expect("a window's pane");
    let pk = c
        .ok(
            "grm/pick",
            json!({ "textDocument": { "uri": u }, "part": part, "triangle": tri }),
        )
        .await;
    let s = &pk["shape"];
    let _ = writeln!(
        out,
        "\npick {}: made by {} at `{}`, its rule `{}`",
        pk["symbol"],
        s["madeBy"],
        text_of(&text, &pk["range"]),
        text_of(&text, &s["rule"]).lines().next().unwrap()
    );
    assert_eq!(pk["symbol"], "Window");
    assert_eq!(s["madeBy"], "split.x");
    assert!(text_of(&text, &s["rule"]).starts_with("Window : scope.x > 1"));
    // Past the last triangle: nothing.
    let none = c
        .ok(
            "grm/pick",
            json!({ "textDocument": { "uri": u }, "part": 0, "triangle": 9_999_999 }),
        )
        .await;
    assert!(none.is_null());
    insta::with_settings!({
        snapshot_path => concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/lsp/snapshots"),
        prepend_module_to_snapshot => false,
        omit_expression => true,
    }, {
        insta::assert_snapshot!("shape_preview", scrub(&out));
    });
}

#[tokio::test]
async fn shape_preview_follows_sliders_seeds_and_edits() {
    let mut c = Client::start().await;
    let (p, text) = fixture("shape.grm");
    let u = c.open(&p, &text).await;
    let grow = |extra: Value| {
        let mut params = json!({ "textDocument": { "uri": u } });
        for (k, v) in extra.as_object().unwrap() {
            params[k] = v.clone();
        }
        params
    };
    let base = c.ok("grm/preview", grow(json!({}))).await;
    // More floors: a taller building, more shapes.
    let tall = c
        .ok("grm/preview", grow(json!({ "params": { "floors": 8 } })))
        .await;
    assert!(tall["shape"]["shapes"].as_u64() > base["shape"]["shapes"].as_u64());
    assert!(
        tall["stats"]["boundsMax"][1].as_f64().unwrap()
            > base["stats"]["boundsMax"][1].as_f64().unwrap() + 10.0,
        "y is up in the model"
    );
    let floors = tall["params"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["name"] == "floors")
        .unwrap();
    assert_eq!(floors["value"], 8.0);
    // Another seed: the windows' alternatives race again.
    let other = c.ok("grm/preview", grow(json!({ "seed": 7 }))).await;
    assert_eq!(other["seed"], 7);
    // The other modes do not grow a shape system, nor shape mode others.
    let e = c
        .request("grm/preview", grow(json!({ "mode": "derive" })))
        .await
        .unwrap_err();
    assert!(
        e["message"].as_str().unwrap().contains("shape system"),
        "{e}"
    );
    let (pp, ptext) = fixture("plant.grm");
    let pu = c.open(&pp, &ptext).await;
    let e = c
        .request(
            "grm/preview",
            json!({ "textDocument": { "uri": pu }, "mode": "shape" }),
        )
        .await
        .unwrap_err();
    assert!(
        e["message"].as_str().unwrap().contains("derive system"),
        "{e}"
    );
    // A run-time error is a message with its code: a rule that splits forever.
    let bad = text.replace(
        "Window -> (1) Wall;",
        "Window -> (1) split(x) { ~1: Window | ~1: Window };",
    );
    let bp = p.with_file_name("shape_forever.grm");
    let bu = c.open(&bp, &bad).await;
    let e = c
        .request(
            "grm/preview",
            json!({ "textDocument": { "uri": bu }, "maxModules": 5000 }),
        )
        .await
        .unwrap_err();
    let m = e["message"].as_str().unwrap();
    assert!(m.contains("R08"), "{m}");
}

/// A building of walls and windows only (no roof, no inserted asset):
/// every part is parallelogram quads, sent as three corners each with no
/// indices or normals (`layout: "quads"`, docs/lsp-extensions.md); its
/// triangle counts and picks count the rebuilt mesh.
#[tokio::test]
async fn quads_go_as_three_corners() {
    let mut c = Client::start().await;
    let (dir, _) = fixture("shape.grm");
    let p = dir.with_file_name("quads_only.grm");
    let text = "material glass { color = rgb(0.3, 0.4, 0.5); }\n\
        system Block {\n mode = shape;\n lot = rect(12, 8);\n axiom Lot;\n\
        Lot -> extrude(9) Mass;\n\
        Mass -> comp(faces) { front: Facade | side: Wall | top: Wall };\n\
        Facade -> repeat(y) { 3: Floor };\n\
        Floor -> repeat(x) { ~3: Tile };\n\
        Tile -> split(x) { ~1: Wall | 1.2: Window | ~1: Wall };\n\
        Window -> material(glass);\n}\n";
    let u = c.open(&p, text).await;
    let r = c
        .ok("grm/preview", json!({ "textDocument": { "uri": u } }))
        .await;
    let parts = r["parts"].as_array().unwrap();
    assert_eq!(parts.len(), 2, "{r}");
    let mut triangles = 0;
    for p in parts {
        assert_eq!(p["layout"], "quads", "{p}");
        let nv = p["vertexCount"].as_u64().unwrap() as usize;
        let nt = p["triangleCount"].as_u64().unwrap() as usize;
        assert_eq!((nv % 4, nt), (0, nv / 2));
        let corners = base64::engine::general_purpose::STANDARD
            .decode(p["positions"].as_str().unwrap())
            .unwrap();
        assert_eq!(corners.len(), nv / 4 * 9 * 4);
        assert_eq!(
            (p["indices"].as_str(), p["normals"].as_str()),
            (Some(""), Some(""))
        );
        let covered: u64 = picks(p)
            .iter()
            .map(|pk| pk["triangleCount"].as_u64().unwrap())
            .sum();
        assert_eq!(covered as usize, nt);
        triangles += nt;
    }
    assert_eq!(triangles as u64, r["stats"]["triangles"].as_u64().unwrap());
}

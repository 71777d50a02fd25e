//! `cargo run -p grm-sample --release --example picture -- OUT.svg [SEED]`:
//! sample the Calder tree (examples/calder_tree.grm, Calder's playground
//! schedule, the default weights) and draw its skeleton with the guiding curves as an SVG, in an
//! orthographic front view (x to the right, y up; z is dropped). The
//! documentation's picture is this file converted to PNG:
//!
//! ```text
//! cargo run -p grm-sample --release --example picture -- /tmp/tree.svg 1
//! rsvg-convert -w 1000 /tmp/tree.svg -o docs/img/calder_tree_guided.png
//! ```
//!
//! Drawn: each guiding curve as a wide translucent band with an arrow at its
//! end (the direction bones are rewarded for following), the skeleton's
//! bones as dark lines (wider near the root), leaves as green dots at the
//! leaf meshes' anchors, and a caption with the seed and the cost by term.

use std::fmt::Write as _;
use std::path::PathBuf;

use glam::Vec3;
use grm_guide::Curves;
use grm_sample::{ExpectedOptions, NodeKind, Objective, SampleOptions, Sampler, Schedule};

fn main() {
    let mut args = std::env::args().skip(1);
    let out = PathBuf::from(
        args.next()
            .unwrap_or_else(|| "calder_tree_guided.svg".into()),
    );
    let seed: u32 = args.next().and_then(|s| s.parse().ok()).unwrap_or(1);
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    let path = root.join("calder_tree.grm");
    let text = std::fs::read_to_string(&path).expect("example");
    let (_s, checked) = grm_sema::check_text(path.to_str().expect("path"), &text);
    assert!(!checked.has_errors(), "calder_tree.grm has errors");
    let program = checked.program;
    let system = &program.systems[0];
    let compiled =
        grm_compile::compile(&program, system, &program.default_params()).expect("compiles");
    let curves = Curves::load(root.join("calder_tree.curves.json")).expect("curves");
    let sampler = Sampler::new(
        system,
        &compiled,
        &curves,
        Objective::Curves,
        ExpectedOptions::default(),
    )
    .expect("sampler");
    let result = sampler
        .sample(&SampleOptions {
            seed,
            schedule: Schedule::calder_playground(),
            ..SampleOptions::default()
        })
        .expect("samples");
    let m = result.best().expect("a model");

    // Skeleton bones (axiom, skeleton and wrap-up expansions).
    let mut bones: Vec<(Vec3, Vec3, u32)> = Vec::new();
    for n in &m.tree.nodes {
        if n.kind == NodeKind::Geometry {
            continue;
        }
        for i in n.bones.start..n.bones.end {
            let b = &m.interpretation.bones[i as usize];
            // Depth along the parent chain, for the line width.
            let mut depth = 0;
            let mut p = b.parent;
            while let Some(j) = p {
                depth += 1;
                p = m.interpretation.bones[j as usize].parent;
            }
            bones.push((b.base, b.tip, depth));
        }
    }
    let leaves: Vec<Vec3> = m
        .interpretation
        .instances
        .iter()
        .filter(|i| matches!(i.kind, grm_turtle::InstanceKind::Mesh(id) if program.meshes[id.index()].name == "leafMesh"))
        .map(|i| Vec3::from(i.transform.translation))
        .collect();
    let curve_points: Vec<Vec<Vec3>> = curves
        .curves()
        .iter()
        .map(|c| {
            (0..=64)
                .map(|k| c.bezier.eval(f64::from(k) / 64.0).as_vec3())
                .collect()
        })
        .collect();

    // View box over everything, in world units; SVG y points down.
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    for p in bones
        .iter()
        .flat_map(|b| [b.0, b.1])
        .chain(leaves.iter().copied())
        .chain(curve_points.iter().flatten().copied())
    {
        lo = lo.min(p);
        hi = hi.max(p);
    }
    let margin = 0.4;
    let (x0, x1) = (lo.x - margin, hi.x + margin);
    let (y0, y1) = (lo.y - margin, hi.y + margin + 0.6);
    let scale = 160.0; // pixels per unit
    let (w, h) = ((x1 - x0) * scale, (y1 - y0) * scale);
    let px = |p: Vec3| ((p.x - x0) * scale, (y1 - p.y) * scale);

    let mut svg = String::new();
    let _ = writeln!(
        svg,
        r##"<svg xmlns="http://www.w3.org/2000/svg" width="{w:.0}" height="{h:.0}" viewBox="0 0 {w:.1} {h:.1}">"##
    );
    svg.push_str(r##"<rect width="100%" height="100%" fill="#fbfaf6"/>"##);
    svg.push('\n');
    // Ground line at y = 0.
    let (gx0, gy) = px(Vec3::new(x0, 0.0, 0.0));
    let (gx1, _) = px(Vec3::new(x1, 0.0, 0.0));
    let _ = writeln!(
        svg,
        r##"<line x1="{gx0:.1}" y1="{gy:.1}" x2="{gx1:.1}" y2="{gy:.1}" stroke="#c9c2b0" stroke-width="2"/>"##
    );
    let colours = ["#3a7bd5", "#d5663a", "#8e44ad", "#27ae60"];
    for (k, pts) in curve_points.iter().enumerate() {
        let col = colours[k % colours.len()];
        let mut d = String::new();
        for (i, p) in pts.iter().enumerate() {
            let (x, y) = px(*p);
            let _ = write!(d, "{}{x:.1} {y:.1} ", if i == 0 { "M" } else { "L" });
        }
        let _ = writeln!(
            svg,
            r##"<path d="{d}" fill="none" stroke="{col}" stroke-opacity="0.22" stroke-width="26" stroke-linecap="round" stroke-linejoin="round"/>"##
        );
        let _ = writeln!(
            svg,
            r##"<path d="{d}" fill="none" stroke="{col}" stroke-width="2" stroke-dasharray="8 6"/>"##
        );
        // Arrow head at the end: the curve's direction.
        let (a, b) = (pts[pts.len() - 2], pts[pts.len() - 1]);
        let dir = (b - a).normalize_or_zero();
        let side = Vec3::new(-dir.y, dir.x, 0.0);
        let s = 0.12;
        let (tx, ty) = px(b + dir * s);
        let (lx, ly) = px(b - dir * s + side * s);
        let (rx, ry) = px(b - dir * s - side * s);
        let _ = writeln!(
            svg,
            r##"<path d="M{tx:.1} {ty:.1} L{lx:.1} {ly:.1} L{rx:.1} {ry:.1} Z" fill="{col}"/>"##
        );
        let name = curves.curves()[k].name.clone().unwrap_or_default();
        let (nx, ny) = px(pts[pts.len() / 2]);
        let _ = writeln!(
            svg,
            r##"<text x="{:.1}" y="{:.1}" font-family="sans-serif" font-size="15" fill="{col}">{name}</text>"##,
            nx + 16.0,
            ny + 22.0
        );
    }
    for &(a, b, depth) in &bones {
        let (ax, ay) = px(a);
        let (bx, by) = px(b);
        let width = (9.0 * 0.8f32.powi(depth as i32)).max(1.6);
        let _ = writeln!(
            svg,
            r##"<line x1="{ax:.1}" y1="{ay:.1}" x2="{bx:.1}" y2="{by:.1}" stroke="#4a3222" stroke-width="{width:.1}" stroke-linecap="round"/>"##
        );
    }
    for &p in &leaves {
        let (x, y) = px(p);
        let _ = writeln!(
            svg,
            r##"<circle cx="{x:.1}" cy="{y:.1}" r="5" fill="#4f9a35" fill-opacity="0.85"/>"##
        );
    }
    let c = &m.cost;
    let caption = format!(
        "calder_tree.grm, seed {seed}, playground schedule (100 generations, 100 -> 15 particles), {} candidates, ESS >= {} N",
        grm_sample::DEFAULT_CANDIDATES,
        grm_sample::DEFAULT_ESS_TARGET
    );
    let caption2 = format!(
        "{} bones, cost {:.0} = distance {:.0} + alignment {:.0} + utilization {:.0}; front view, z dropped",
        m.skeleton_bones,
        c.total(),
        c.distance,
        c.alignment,
        c.utilization
    );
    let _ = writeln!(
        svg,
        r##"<text x="12" y="22" font-family="sans-serif" font-size="14" fill="#333">{caption}</text>"##
    );
    let _ = writeln!(
        svg,
        r##"<text x="12" y="42" font-family="sans-serif" font-size="14" fill="#333">{caption2}</text>"##
    );
    svg.push_str("</svg>\n");
    std::fs::write(&out, svg).expect("write the SVG");
    eprintln!("wrote {} ({caption2})", out.display());
}

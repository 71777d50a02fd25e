//! A top-down picture of a layout as SVG: blocks (when given) in light
//! grey, parcels in a pale fill, streets as their centre lines drawn as
//! wide as they are, major streets darker. North is up (y flipped), one
//! unit a metre; numbers with two decimals, elements in identity order,
//! so the same layout gives the same bytes.

use crate::blocks::Block;
use crate::index::bounds;
use crate::model::{Layout, StreetClass};
use geo::Coord;
use std::fmt::Write;

/// The SVG text of a layout.
pub fn svg(layout: &Layout, blocks: Option<&[Block]>) -> String {
    let mut pts: Vec<Coord> = layout.nodes.values().map(|n| n.pos).collect();
    pts.extend(layout.parcels.values().flat_map(|p| p.ring.iter().copied()));
    let (min, max) = if pts.is_empty() {
        ([0.0, 0.0], [1.0, 1.0])
    } else {
        bounds(&pts)
    };
    let pad = 20.0;
    let (w, h) = (max[0] - min[0] + 2.0 * pad, max[1] - min[1] + 2.0 * pad);
    let x = |c: Coord| c.x - min[0] + pad;
    let y = |c: Coord| max[1] - c.y + pad;
    let path = |ring: &[Coord], close: bool| {
        let mut d = String::new();
        for (i, c) in ring.iter().enumerate() {
            let _ = write!(
                d,
                "{}{:.2},{:.2}",
                if i == 0 { "M" } else { " L" },
                x(*c),
                y(*c)
            );
        }
        if close {
            d.push_str(" Z");
        }
        d
    };
    let mut s = String::new();
    let _ = writeln!(
        s,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 {w:.2} {h:.2}\" width=\"{:.0}\" height=\"{:.0}\">",
        w.min(4000.0),
        h * w.min(4000.0) / w.max(1e-9)
    );
    let _ = writeln!(s, "<rect width=\"100%\" height=\"100%\" fill=\"#ffffff\"/>");
    if let Some(bs) = blocks {
        let _ = writeln!(s, "<g fill=\"#e4e4e0\" stroke=\"none\">");
        for b in bs {
            let mut d = path(&b.ring, true);
            for hole in &b.holes {
                d.push(' ');
                d.push_str(&path(hole, true));
            }
            let _ = writeln!(
                s,
                "<path id=\"b{}\" fill-rule=\"evenodd\" d=\"{d}\"/>",
                b.id
            );
        }
        let _ = writeln!(s, "</g>");
    }
    let _ = writeln!(
        s,
        "<g fill=\"#f3dcb2\" stroke=\"#b08850\" stroke-width=\"0.3\">"
    );
    for p in layout.parcels.values() {
        let _ = writeln!(s, "<path id=\"p{}\" d=\"{}\"/>", p.id, path(&p.ring, true));
    }
    let _ = writeln!(s, "</g>");
    let _ = writeln!(
        s,
        "<g fill=\"none\" stroke-linecap=\"round\" stroke-linejoin=\"round\">"
    );
    for st in layout.streets.values() {
        let Some(pl) = layout.polyline(st) else {
            continue;
        };
        let colour = match st.class {
            StreetClass::Minor => "#9a9a9a",
            StreetClass::Major => "#6a6a6a",
            StreetClass::Highway => "#404040",
        };
        let _ = writeln!(
            s,
            "<path id=\"s{}\" stroke=\"{colour}\" stroke-width=\"{:.2}\" d=\"{}\"/>",
            st.id,
            st.width,
            path(&pl, false)
        );
    }
    let _ = writeln!(s, "</g>");
    s.push_str("</svg>\n");
    s
}

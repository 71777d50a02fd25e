//! `grmc layout FILE.layout.json [-o city.geojson|city.svg] [--blocks]`: a
//! city layout (docs/layout.md) merged from the sidecar's layers and
//! written as GeoJSON or an SVG plan.
//!
//! The sidecar's problems (S001-S006, at their JSON paths) and each
//! layer's (a bad GeoJSON element, L001-L010, naming it; a missing file; a
//! rejected move) are printed; the plan is still written from what loaded,
//! and the exit code is 1. A sidecar or output that cannot be read or
//! written is exit 2. GeoJSON files named by layers are read relative to
//! the sidecar.

use std::path::{Path, PathBuf};

use clap::Args;
use grm_layout::blocks::blocks;
use grm_layout::{geojson_io, sidecar, svg};

use crate::Outcome;

#[derive(Debug, Args)]
pub struct LayoutArgs {
    /// The layout sidecar (NAME.layout.json).
    pub file: PathBuf,
    /// Write the merged plan: .geojson or .svg.
    #[arg(short, long, value_name = "PATH")]
    pub output: Option<PathBuf>,
    /// Also write the blocks (GeoJSON features with `kind: "block"`; grey
    /// areas in the SVG).
    #[arg(long)]
    pub blocks: bool,
}

/// The most a sidecar or a layer's GeoJSON file may be.
const MAX_INPUT: u64 = 256 << 20;

fn read(path: &Path, what: &str) -> Result<String, String> {
    grm_diag::input::read_bounded_string(path, MAX_INPUT, what).map_err(|e| e.to_string())
}

pub fn run(a: LayoutArgs) -> Outcome {
    let text = match read(
        &a.file,
        "it is larger than 256 MiB, the most a layout file may be",
    ) {
        Ok(t) => t,
        Err(e) => {
            eprintln!("error: cannot read {}: {e}", a.file.display());
            return Outcome::Usage;
        }
    };
    let (doc, errs) = sidecar::read(&text);
    for e in &errs {
        eprintln!(
            "{}: error[{}]: {}: {}",
            a.file.display(),
            e.kind.code(),
            e.path,
            e.message
        );
    }
    let dir = a.file.parent().map(Path::to_path_buf).unwrap_or_default();
    let load = |p: &str| -> Result<String, String> {
        read(
            &dir.join(p),
            "it is larger than 256 MiB, the most a GeoJSON layer may be",
        )
    };
    let ev = doc.evaluate(&load);
    for i in &ev.issues {
        eprintln!("{}: error: {}", a.file.display(), i.describe());
    }
    let bs = blocks(&ev.merged);
    outln!(
        "{} layers: {} streets, {} nodes, {} blocks, {} parcels",
        doc.layers.len(),
        ev.merged.streets.len(),
        ev.merged.nodes.len(),
        bs.len(),
        ev.merged.parcels.len()
    );
    if let Some(out) = &a.output {
        let shown = a.blocks.then_some(bs.as_slice());
        let body = match out.extension().and_then(|e| e.to_str()) {
            Some("geojson") | Some("json") => geojson_io::write(&ev.merged, shown),
            Some("svg") => svg::svg(&ev.merged, shown),
            _ => {
                eprintln!(
                    "error: cannot write {}: unknown format (use .geojson or .svg)",
                    out.display()
                );
                return Outcome::Usage;
            }
        };
        if let Err(e) = grm_geom::export::write_atomic(out, |w| w.write_all(body.as_bytes())) {
            eprintln!("error: {e}");
            return Outcome::Usage;
        }
        outln!("wrote {}", out.display());
    }
    if errs.is_empty() && ev.issues.is_empty() {
        Outcome::Ok
    } else {
        Outcome::InputErrors
    }
}

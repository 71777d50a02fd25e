//! `grmc layout FILE.grm|FILE.layout.json [-o city.glb|city.png|city.geojson|city.svg]
//! [--blocks] [--no-buildings]`: a city layout (docs/layout.md) merged
//! from the sidecar's layers and written as GeoJSON or an SVG plan, or as
//! a model (glb, OBJ, PLY, a PNG picture): the streets, parcels and open
//! ground, and on every parcel the building the sidecar's `buildings`
//! grammar grows (`grm_layout::city`; none with `--no-buildings` or
//! without a `buildings` section). Progress goes to stderr. A `.grm` is
//! checked and its first `layout` item made into the document on the one
//! road (`grm_layout::program::document`), with `FILE.layout.json` beside
//! it as the artist's edits; its `buildings` system grows on the parcels.
//! The building edits of `NAME.edits.json` beside the layout (edits with
//! a `parcel`) are replayed in their parcels' buildings; one whose parcel
//! is gone is printed (R1032) and applied nowhere.
//!
//! The sidecar's problems (R1021-R1026, at their JSON paths), each layer's
//! (a bad GeoJSON element, R1001-R1010, naming it; a generator's
//! parameters, a missing file, a rejected move, an unknown element:
//! R1011-R1015), each parcel's without a building (R1031, E0509, R08xx,
//! naming it) and the edits file's (R0902-R0911, R1032) are printed; the
//! rest is still written, and the exit code is 1. A sidecar, grammar or output that cannot be read or written
//! is exit 2. Files named by the sidecar are read relative to it.
use std::path::{Path, PathBuf};

use clap::Args;
use grm_grow::shape::ShapeOptions;
use grm_layout::blocks::blocks;
use grm_layout::city::{self, Buildings};
use grm_layout::model::TagValue;
use grm_layout::{geojson_io, sidecar, svg};
use std::time::Instant;

use crate::Outcome;

#[derive(Debug, Args)]
pub struct LayoutArgs {
    /// A grammar with a `layout` item (NAME.grm), or a layout sidecar
    /// (NAME.layout.json).
    pub file: PathBuf,
    /// Write the city: .geojson or .svg (the plan), .glb, .obj, .ply or
    /// .png (streets, parcels and buildings).
    #[arg(short, long, value_name = "PATH")]
    pub output: Option<PathBuf>,
    /// Also write the blocks (GeoJSON features with `kind: "block"`; grey
    /// areas in the SVG).
    #[arg(long)]
    pub blocks: bool,
    /// A model or picture of the plan alone, without the buildings.
    #[arg(long)]
    pub no_buildings: bool,
}

/// The most a sidecar or a layer's GeoJSON file may be.
const MAX_INPUT: u64 = 256 << 20;

fn read(path: &Path, what: &str) -> Result<String, String> {
    grm_diag::input::read_bounded_string(path, MAX_INPUT, what).map_err(|e| e.to_string())
}

/// `grmc layout FILE.grm`: the grammar's first `layout` item
/// (`grm_layout::program::document`), the artist's edits from
/// `NAME.layout.json` beside it when there is one, the buildings grown by
/// the item's `buildings` system with the grammar's defaults.
fn from_grammar(
    a: &LayoutArgs,
) -> Result<(grm_layout::layers::Document, crate::derive::Checked, bool), Outcome> {
    let mut checked = crate::derive::load_checked(&a.file, None, &[])?;
    let Some(def) = checked.program.layouts.first().cloned() else {
        eprintln!(
            "error: {} has no `layout NAME {{ ... }}` item (docs/layout.md)",
            a.file.display()
        );
        return Err(Outcome::Usage);
    };
    let side = a.file.with_extension("layout.json");
    let mut problems = false;
    let sidecar = match std::fs::metadata(&side) {
        Ok(_) => {
            let text = read(
                &side,
                "it is larger than 256 MiB, the most a layout file may be",
            )
            .map_err(|e| {
                eprintln!("error: cannot read {}: {e}", side.display());
                Outcome::Usage
            })?;
            let (doc, errs) = sidecar::read(&text);
            for e in &errs {
                eprintln!(
                    "{}: error[{}]: {}: {}",
                    side.display(),
                    e.kind.code(),
                    e.path,
                    e.message
                );
            }
            problems |= !errs.is_empty();
            Some(doc)
        }
        Err(_) => None,
    };
    let (doc, issues) =
        grm_layout::program::document(&checked.program, &def, &checked.values, sidecar.as_ref());
    for i in &issues {
        eprintln!(
            "{}: error[{}]: {}",
            a.file.display(),
            i.code(),
            i.describe()
        );
    }
    problems |= !issues.is_empty();
    if let Some(i) = def.buildings {
        checked.system = i;
    }
    Ok((doc, checked, problems))
}

pub fn run(a: LayoutArgs) -> Outcome {
    if a.file.extension().is_some_and(|e| e == "grm") {
        let (doc, checked, problems) = match from_grammar(&a) {
            Ok(r) => r,
            Err(o) => return o,
        };
        return write_city(&a, doc, Some(&checked), problems);
    }
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
    write_city(&a, doc, None, !errs.is_empty())
}

/// Merges the document's layers and writes the city (`grammar`: the
/// buildings' checked grammar, when a `.grm` named them).
fn write_city(
    a: &LayoutArgs,
    doc: grm_layout::layers::Document,
    grammar: Option<&crate::derive::Checked>,
    mut problems: bool,
) -> Outcome {
    let dir = a.file.parent().map(Path::to_path_buf).unwrap_or_default();
    let load = |p: &str| -> Result<String, String> {
        read(
            &dir.join(p),
            "it is larger than 256 MiB, the most a GeoJSON layer may be",
        )
    };
    let ev = doc.evaluate(&load);
    for i in &ev.issues {
        eprintln!(
            "{}: error[{}]: {}",
            a.file.display(),
            i.code(),
            i.describe()
        );
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
    problems |= !ev.issues.is_empty();
    if let Some(out) = &a.output {
        let shown = a.blocks.then_some(bs.as_slice());
        let ext = out.extension().and_then(|e| e.to_str()).unwrap_or("");
        let body = match ext {
            "geojson" | "json" => geojson_io::write(&ev.merged, shown),
            "svg" => svg::svg(&ev.merged, shown),
            _ => match grm_geom::ExportFormat::from_path(out) {
                Some(format) => {
                    return match model(a, &doc, grammar, &dir, &ev.merged, out, format) {
                        Ok(issues) if problems || issues => Outcome::InputErrors,
                        Ok(_) => Outcome::Ok,
                        Err(o) => o,
                    };
                }
                None => {
                    eprintln!(
                        "error: cannot write {}: unknown format (use .geojson, .svg, .glb, .obj, .ply or .png)",
                        out.display()
                    );
                    return Outcome::Usage;
                }
            },
        };
        if let Err(e) = grm_geom::export::write_atomic(out, |w| w.write_all(body.as_bytes())) {
            eprintln!("error: {e}");
            return Outcome::Usage;
        }
        outln!("wrote {}", out.display());
    }
    if !problems {
        Outcome::Ok
    } else {
        Outcome::InputErrors
    }
}

/// The city as a model written to `out`: the buildings grown from the
/// sidecar's grammar unless `--no-buildings`. `Ok(true)`: some parcel has
/// no building (printed).
fn model(
    a: &LayoutArgs,
    doc: &grm_layout::layers::Document,
    grammar: Option<&crate::derive::Checked>,
    dir: &Path,
    layout: &grm_layout::model::Layout,
    out: &Path,
    format: grm_geom::ExportFormat,
) -> Result<bool, Outcome> {
    let spec = doc.buildings.as_ref().filter(|_| !a.no_buildings);
    let loaded = match spec {
        Some(_) if grammar.is_some() => None,
        Some(spec) => {
            let params: Vec<String> = spec
                .params
                .iter()
                .map(|(k, v)| match v {
                    TagValue::Num(x) => format!("{k}={x}"),
                    TagValue::Bool(b) => format!("{k}={b}"),
                    TagValue::Text(t) => format!("{k}={t}"),
                })
                .collect();
            let grammar = dir.join(&spec.grammar);
            let checked = crate::derive::load_checked(&grammar, spec.system.as_deref(), &params)?;
            if checked.system().mode != grm_sema::Mode::Shape {
                eprintln!(
                    "error: {}: system `{}` is not a shape system (it has no `mode = shape;`): parcels grow shape systems",
                    grammar.display(),
                    checked.system().name
                );
                return Err(Outcome::Usage);
            }
            Some((checked, grammar))
        }
        None => None,
    };
    let from_grm = grammar
        .filter(|_| spec.is_some())
        .map(|c| (c, a.file.as_path()));
    let buildings = loaded
        .as_ref()
        .map(|(c, grammar)| (c, grammar.as_path()))
        .or(from_grm)
        .map(|(c, grammar)| Buildings {
            program: &c.program,
            system: c.system(),
            params: &c.values,
            dir: grammar.parent(),
            seed: spec.map_or(0, |s| s.seed),
            options: ShapeOptions::default(),
        });
    let build = grm_geom::BuildOptions {
        group_names: false,
        ..grm_geom::BuildOptions::default()
    };
    let start = Instant::now();
    let mut shown = Instant::now();
    let mut progress = |done: usize, total: usize| {
        if buildings.is_some() && (shown.elapsed().as_secs_f64() >= 1.0 || done == total) {
            eprint!("\rbuildings: {done}/{total}");
            if done == total {
                eprintln!();
            }
            shown = Instant::now();
        }
    };
    let edits = if buildings.is_some() {
        building_edits(&a.file)?
    } else {
        (PathBuf::new(), grm_edits::EditsFile::default(), false)
    };
    let grown = match city::city_edited(
        layout,
        buildings.as_ref(),
        &build,
        &edits.1,
        None,
        &mut progress,
    ) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("error[{}]: {e}", grm_diag::Code::MemoryLimit.as_str());
            return Err(Outcome::InputErrors);
        }
    };
    for i in &grown.issues {
        eprintln!(
            "{}: error[{}]: {}",
            a.file.display(),
            i.code(),
            i.describe()
        );
    }
    for e in &grown.edit_issues {
        eprintln!(
            "{}: error[{}]: {}",
            edits.0.display(),
            e.code(),
            e.describe()
        );
    }
    if buildings.is_some() {
        outln!(
            "{} buildings on {} parcels in {:.0} ms",
            grown.buildings,
            layout.parcels.len(),
            start.elapsed().as_secs_f64() * 1e3
        );
        if grown.edited > 0 {
            outln!("{} buildings with building edits", grown.edited);
        }
    }
    let m = &grown.model;
    if let Err(e) = grm_geom::export::export_as(m, out, format) {
        eprintln!("error: {e}");
        return Err(Outcome::Usage);
    }
    outln!("wrote {} ({} triangles)", out.display(), m.stats.triangles);
    Ok(!grown.issues.is_empty() || !grown.edit_issues.is_empty() || edits.2)
}

/// The building edits beside the layout (docs/layout.md, "Building
/// edits"): `NAME.edits.json` for `NAME.grm` or `NAME.layout.json`; none
/// without one. A file that cannot be read is exit 2; an edit with a
/// problem (R0902-R0911) is printed and skipped, the others apply.
fn building_edits(file: &Path) -> Result<(PathBuf, grm_edits::EditsFile, bool), Outcome> {
    let name = file.file_name().and_then(|n| n.to_str()).unwrap_or("");
    let path = match name.strip_suffix(".layout.json") {
        Some(stem) => file.with_file_name(format!("{stem}.edits.json")),
        None => grm_edits::edits_path(file),
    };
    let text = match grm_edits::read(&path) {
        Ok(t) => t,
        Err(e) if e.is_not_found() => return Ok((path, grm_edits::EditsFile::default(), false)),
        Err(e) => {
            eprintln!("error[{}]: {e}", e.code().as_str());
            return Err(Outcome::Usage);
        }
    };
    let parsed = grm_edits::parse(&text);
    for e in &parsed.errors {
        eprintln!("{}: error[{}]: {e}", path.display(), e.code().as_str());
    }
    Ok((path, parsed.file, !parsed.errors.is_empty()))
}

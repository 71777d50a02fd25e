//! A `layout` item of a `.grm` file (grm-sema's [`LayoutDef`]; docs/layout.md)
//! made into a [`Document`]: its layers' sources (generators with their
//! parameters, GeoJSON files, streets grown by an L-system, the artist's
//! edited layers), with the artist's moves, deletions, protections and
//! assignments from the sidecar `NAME.layout.json`, and the shape system
//! every parcel grows. The one road from a grammar to a city: `grmc layout
//! FILE.grm` and the editor call [`document`], never the engines one by one.
//!
//! Streets grown by an L-system: the system is derived with its own
//! settings and meta-parameter values, its turtle interpreted, and every
//! drawn segment (a bone, base to tip, projected onto the ground plane x-y)
//! becomes a street; segments that share an end share a node (ends snap to
//! the layout's grid), and a segment that would cross one drawn before it
//! is left out with R1010 naming it, as a GeoJSON file's would be.

use std::collections::BTreeMap;

use grm_sema::Program;
use grm_sema::layout::{LayerSource, LayoutDef};

use crate::generate::{GridParams, RadialParams};
use crate::layers::{Document, LayerSpec, Source};

/// The streets an L-system's turtle draws, as a GeoJSON FeatureCollection
/// (one LineString per drawn segment, `id` `NAME segment N`). `Err`: the
/// system did not compile, derive or interpret (the message).
pub fn lsystem_streets(
    program: &Program,
    system: usize,
    values: &[grm_sema::Value],
) -> Result<String, String> {
    let sys = program
        .systems
        .get(system)
        .ok_or_else(|| "no such system".to_string())?;
    let compiled = grm_compile::compile(program, sys, values).map_err(|e| e.to_string())?;
    let opts = grm_derive::DeriveOptions::from_system(&compiled);
    let grown = grm_grow::Grower::new(&compiled, 1, grm_grow::Record::default())
        .map_err(|e| grm_grow::GrowError::from(e).to_string())?
        .derive(&opts, &mut |_| {})
        .map_err(|e| e.to_string())?;
    let interp = grm_geom::grm_turtle::interpret(sys, &compiled.settings, &grown.string)
        .map_err(|e| e.to_string())?;
    let mut features = Vec::new();
    for (i, b) in interp.bones.iter().enumerate() {
        let (a, t) = (b.base, b.tip);
        if !(a.is_finite() && t.is_finite()) || (t.truncate() - a.truncate()).length() < 1e-3 {
            continue;
        }
        features.push(serde_json::json!({
            "type": "Feature",
            "id": format!("{} segment {}", sys.name, i + 1),
            "properties": {},
            "geometry": {"type": "LineString", "coordinates": [
                [a.x as f64, a.y as f64], [t.x as f64, t.y as f64]
            ]}
        }));
    }
    Ok(serde_json::json!({"type": "FeatureCollection", "features": features}).to_string())
}

/// The document a `layout` item describes, with the artist's sidecar
/// (`NAME.layout.json`, already read; `None` without one): each of the
/// item's layers, bottom to top, takes the sidecar's layer of the same
/// name for the artist's edits (merge mode, seed, moves, deletions,
/// protections, assignments, placement) and keeps its own source (an
/// `edited()` layer takes the sidecar's source); the sidecar's layers the
/// item does not name go on top, in the sidecar's order (hand-edited
/// layers). An L-system that does not grow leaves its layer empty and is
/// reported (R1011 naming the layer). The buildings are the item's; the
/// caller grows them ([`crate::city`]) with `program`'s system.
pub fn document(
    program: &Program,
    def: &LayoutDef,
    values: &[grm_sema::Value],
    sidecar: Option<&Document>,
) -> (Document, Vec<crate::layers::LayerIssue>) {
    let mut issues = Vec::new();
    let mut doc = Document::default();
    let mut edited: BTreeMap<&str, &LayerSpec> = BTreeMap::new();
    if let Some(s) = sidecar {
        doc.parcels = s.parcels;
        for l in &s.layers {
            edited.entry(l.name.as_str()).or_insert(l);
        }
    }
    for layer in &def.layers {
        let source = match &layer.source {
            LayerSource::Grid {
                nx,
                ny,
                dx,
                dy,
                seed,
            } => Source::Grid(GridParams {
                nx: *nx,
                ny: *ny,
                spacing: geo::Coord { x: *dx, y: *dy },
                seed: *seed,
                ..GridParams::default()
            }),
            LayerSource::Radial {
                x,
                y,
                rings,
                ring_spacing,
                spokes,
                seed,
            } => Source::Radial(RadialParams {
                centre: geo::Coord { x: *x, y: *y },
                rings: *rings,
                ring_spacing: *ring_spacing,
                spokes: *spokes,
                seed: *seed,
                ..RadialParams::default()
            }),
            LayerSource::GeoJson(path) => Source::GeoJson(path.clone()),
            LayerSource::LSystem(i) => match lsystem_streets(program, *i, values) {
                Ok(text) => Source::Features(text),
                Err(message) => {
                    issues.push(crate::layers::LayerIssue::Params {
                        layer: layer.name.clone(),
                        message: format!("the L-system did not grow: {message}"),
                    });
                    Source::Empty
                }
            },
            LayerSource::Edited => edited
                .get(layer.name.as_str())
                .map_or(Source::Empty, |s| s.source.clone()),
        };
        let mut spec = match edited.remove(layer.name.as_str()) {
            Some(s) => s.clone(),
            None => {
                let mut s = LayerSpec::new(&layer.name, Source::Empty);
                // Streets alone (an L-system's, a file's) get parcels in
                // their blocks; so do generators.
                s.fill = true;
                s
            }
        };
        spec.source = source;
        doc.layers.push(spec);
    }
    if let Some(s) = sidecar {
        for l in &s.layers {
            if edited.contains_key(l.name.as_str()) {
                doc.layers.push(l.clone());
            }
        }
    }
    doc.buildings = def.buildings.map(|i| crate::city::BuildingSpec {
        grammar: String::new(),
        system: program.systems.get(i).map(|s| s.name.clone()),
        seed: def.seed,
        params: Default::default(),
    });
    (doc, issues)
}

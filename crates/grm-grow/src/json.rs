//! The derivation tree as a JSON file (`grmc derive|sample --tree
//! FILE.json`).
//!
//! ```text
//! { "format": "grm-tree", "version": 1,
//!   "system": "StochasticPlant", "mode": "derive", "seed": 1,
//!   "root_key": "9c1e0a52",
//!   "productions": [ { "index": 0, "symbol": "F", "file": "plant.grm",
//!                      "start": 812, "end": 846, "line": 27, "column": 5 }, ... ],
//!   "nodes": [ { "id": 0, "key": "9c1e0a52", "parent": null, "symbol": null,
//!                "iteration": 0, "production": 3, "children": [1],
//!                "modules": [0, 0], "bones": [0, 0], "instances": [0, 0] }, ... ] }
//! ```
//!
//! `productions` lists every compiled alternative (the axiom last): the
//! symbol it rewrites (`null` for the axiom) and its source range (byte
//! offsets, then the 1-based line and column of its start). A node's
//! `production` indexes that list; `modules` is the half-open range of the
//! final string's modules that are its own, `bones` and `instances` the
//! ranges of what those modules drew in the model's interpretation
//! (`grm_turtle`, in string order). Keys are 8 hex digits. The file is
//! written to a temporary name beside the target and renamed into place:
//! it is there whole or not at all.

use std::io::{self, Write};
use std::ops::Range;
use std::path::Path;

use grm_compile::CompiledSystem;
use grm_diag::SourceMap;
use grm_turtle::Interpretation;
use serde::Serialize;

use crate::tree::{Tree, TreeMode};

#[derive(Serialize)]
struct File<'a> {
    format: &'static str,
    version: u32,
    system: &'a str,
    mode: &'static str,
    seed: u32,
    root_key: String,
    productions: Vec<Production<'a>>,
    nodes: Vec<Node<'a>>,
}

#[derive(Serialize)]
struct Production<'a> {
    index: u32,
    symbol: Option<&'a str>,
    file: &'a str,
    start: u32,
    end: u32,
    line: u32,
    column: u32,
}

#[derive(Serialize)]
struct Node<'a> {
    id: u32,
    key: String,
    parent: Option<u32>,
    symbol: Option<&'a str>,
    iteration: u32,
    production: Option<u32>,
    children: Vec<u32>,
    modules: [u32; 2],
    bones: [u32; 2],
    instances: [u32; 2],
}

/// A key as the file writes it: 8 hex digits.
pub fn key_text(key: u32) -> String {
    format!("{key:08x}")
}

/// The range of items (in module order) whose module lies in `modules`.
fn items_of(module_of: &[u32], modules: &Range<u32>) -> [u32; 2] {
    let a = module_of.partition_point(|&m| m < modules.start) as u32;
    let b = module_of.partition_point(|&m| m < modules.end) as u32;
    [a, b]
}

/// The tree's JSON text (see the module documentation). `interp` is the
/// interpretation of the final string (for the bone and instance ranges),
/// `sources` the files the system's spans are in.
pub fn to_json(
    tree: &Tree,
    sys: &CompiledSystem,
    sources: &SourceMap,
    interp: Option<&Interpretation>,
) -> String {
    let mut out = Vec::new();
    // Writing to memory cannot fail.
    let _ = write_json(&mut out, tree, sys, sources, interp);
    String::from_utf8(out).unwrap_or_default()
}

fn write_json(
    w: &mut dyn Write,
    tree: &Tree,
    sys: &CompiledSystem,
    sources: &SourceMap,
    interp: Option<&Interpretation>,
) -> io::Result<()> {
    let name = |s: u32| sys.symbol_names.get(s as usize).map(String::as_str);
    let file = sources.get(sys.file);
    let productions = (0..sys.alts.len() as u32)
        .map(|i| {
            let a = &sys.alts[i as usize];
            let span = sys.alt_spans.get(i as usize).copied().unwrap_or(sys.span);
            let (line, column) = file.line_col(span.start);
            Production {
                index: i,
                symbol: sys.groups.get(a.group as usize).and_then(|g| name(g.pred)),
                file: file.path.as_str(),
                start: span.start,
                end: span.end,
                line: line + 1,
                column: column + 1,
            }
        })
        .collect();
    let (bone_modules, instance_modules): (Vec<u32>, Vec<u32>) = match interp {
        Some(i) => (
            i.bones.iter().map(|b| b.module).collect(),
            i.instances.iter().map(|x| x.module).collect(),
        ),
        None => (Vec::new(), Vec::new()),
    };
    let mut children = tree.children();
    let nodes = tree
        .nodes
        .iter()
        .enumerate()
        .map(|(i, n)| Node {
            id: i as u32,
            key: key_text(n.key),
            parent: n.parent,
            symbol: n.symbol.and_then(name),
            iteration: n.iteration,
            production: n.production,
            children: std::mem::take(&mut children[i]),
            modules: [n.modules.start, n.modules.end],
            bones: items_of(&bone_modules, &n.modules),
            instances: items_of(&instance_modules, &n.modules),
        })
        .collect();
    let doc = File {
        format: "grm-tree",
        version: 1,
        system: &sys.name,
        mode: match tree.mode {
            TreeMode::Derive => "derive",
            TreeMode::Sample => "sample",
        },
        seed: tree.seed,
        root_key: key_text(tree.root_key),
        productions,
        nodes,
    };
    serde_json::to_writer(&mut *w, &doc).map_err(io::Error::other)?;
    w.write_all(b"\n")
}

/// Write the tree's JSON to `path` as every export is written
/// ([`grm_geom::write_atomic`]: a temporary file beside it renamed into
/// place), so a failure leaves no half-written file (and an existing file
/// as it was); the error is the export's (R0407).
pub fn write(
    path: &Path,
    tree: &Tree,
    sys: &CompiledSystem,
    sources: &SourceMap,
    interp: Option<&Interpretation>,
) -> Result<(), grm_geom::ExportError> {
    grm_geom::write_atomic(path, |w| write_json(w, tree, sys, sources, interp))
}

//! A shape tree as the derivation tree's JSON file (`grmc derive --tree
//! FILE.json` of a shape system): the same document as derive mode's
//! ([`crate::json`]), `"mode": "shape"`, with what a shape node has
//! besides.
//!
//! ```text
//! { "format": "grm-tree", "version": 1,
//!   "system": "Townhouse", "mode": "shape", "seed": 1, "root_key": "5d0c31a2",
//!   "productions": [ { "index": 0, "symbol": "Lot", "file": "townhouse.grm",
//!                      "start": 1210, "end": 1249, "line": 37, "column": 5 }, ... ],
//!   "nodes": [ { "id": 0, "key": "0be4e1f3", "parent": null, "kind": "shape",
//!                "symbol": "Lot", "command": null, "tag": null, "asset": null,
//!                "depth": 0, "edge": 0, "index": 0, "count": 0,
//!                "production": 0, "children": [1],
//!                "exact": "{Lot}", "semantic": "() Lot",
//!                "origin": [0, 0, 0], "size": [24, 10, 0] }, ... ] }
//! ```
//!
//! `productions` lists the system's rules in source order; a shape's
//! `production` is the rule that rewrote it (`null`: a terminal shape).
//! A node is a `shape` (its `symbol`), a `command` (`command` is its
//! label, `split.y`, `repeat.x`, `comp.faces`, and `tag` its tag) or an
//! `insert` (`asset`). `exact` and `semantic` are the node's locators in
//! their text forms (docs/shapes.md, "Locators"); `origin` and `size` its
//! scope's corner (world, z-up) and size. Keys are 8 hex digits.

use std::io::{self, Write};
use std::path::Path;

use grm_diag::SourceMap;
use grm_shape::{NodeId, NodeKind, ShapeTree};
use serde::Serialize;

use super::Lowered;
use crate::json::key_text;

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
    kind: &'static str,
    symbol: Option<&'a str>,
    command: Option<String>,
    tag: Option<&'a str>,
    asset: Option<&'a str>,
    depth: u32,
    edge: u32,
    index: u32,
    count: u32,
    production: Option<u32>,
    children: Vec<u32>,
    exact: String,
    semantic: String,
    origin: [f32; 3],
    size: [f32; 3],
}

/// The tree's JSON text (module documentation). `sources` holds the file
/// the system is written in (`file`).
pub fn to_json(
    lowered: &Lowered,
    tree: &ShapeTree,
    seed: u32,
    file: grm_diag::FileId,
    sources: &SourceMap,
) -> String {
    let mut out = Vec::new();
    // Writing to memory cannot fail.
    let _ = write_json(&mut out, lowered, tree, seed, file, sources);
    String::from_utf8(out).unwrap_or_default()
}

fn write_json(
    w: &mut dyn Write,
    lowered: &Lowered,
    tree: &ShapeTree,
    seed: u32,
    file: grm_diag::FileId,
    sources: &SourceMap,
) -> io::Result<()> {
    let program = &lowered.program;
    let src = sources.get(file);
    let productions = lowered
        .rules
        .iter()
        .enumerate()
        .map(|(i, r)| {
            let (line, column) = src.line_col(r.span.start);
            Production {
                index: i as u32,
                symbol: Some(program.symbol_name(r.symbol)),
                file: src.path.as_str(),
                start: r.span.start,
                end: r.span.end,
                line: line + 1,
                column: column + 1,
            }
        })
        .collect();
    let nodes = tree
        .nodes()
        .iter()
        .enumerate()
        .map(|(i, n)| {
            let id = NodeId(i as u32);
            let (kind, symbol, command, tag, asset, production) = match n.kind {
                NodeKind::Shape {
                    symbol,
                    alternative,
                } => (
                    "shape",
                    Some(program.symbol_name(symbol)),
                    None,
                    None,
                    None,
                    alternative.and_then(|a| lowered.rule_of(symbol, a)),
                ),
                NodeKind::Command { command, tag } => (
                    "command",
                    None,
                    Some(command.label()),
                    tag.map(|t| program.tag_name(t)),
                    None,
                    None,
                ),
                NodeKind::Insert { asset } => (
                    "insert",
                    None,
                    None,
                    None,
                    Some(program.asset_name(asset)),
                    None,
                ),
            };
            Node {
                id: i as u32,
                key: key_text(n.key),
                parent: tree.parent(id).map(|p| p.0),
                kind,
                symbol,
                command,
                tag,
                asset,
                depth: n.depth,
                edge: n.edge,
                index: n.index,
                count: n.count,
                production,
                children: tree.children(id).map(|c| c.0).collect(),
                exact: tree.exact_locator(program, id).to_string(),
                semantic: tree.semantic_locator(program, id).to_string(),
                origin: n.scope.origin.to_array(),
                size: n.scope.size.to_array(),
            }
        })
        .collect();
    let doc = File {
        format: "grm-tree",
        version: 1,
        system: program.name(),
        mode: "shape",
        seed,
        root_key: key_text(grm_compile::rng::root_key(
            seed,
            grm_compile::rng::name_hash(program.name()),
        )),
        productions,
        nodes,
    };
    serde_json::to_writer(&mut *w, &doc).map_err(io::Error::other)?;
    w.write_all(b"\n")
}

/// Write the tree's JSON to `path` whole or not at all (as every export:
/// [`grm_geom::write_atomic`]); the error is the export's (R0407).
pub fn write(
    path: &Path,
    lowered: &Lowered,
    tree: &ShapeTree,
    seed: u32,
    file: grm_diag::FileId,
    sources: &SourceMap,
) -> Result<(), grm_geom::ExportError> {
    grm_geom::write_atomic(path, |w| write_json(w, lowered, tree, seed, file, sources))
}

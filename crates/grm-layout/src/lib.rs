//! City layouts with layers (issue 29; Lipp's dissertation, chapter 4).
//!
//! Role: the urban-layout engine above the building engines: a planar
//! street graph (nodes, streets with a class, width and priority), the
//! blocks it encloses (computed faces, never stored), parcels (simple
//! polygons, each owned by at most one block) and tags on all of them,
//! kept in layers that are merged in order into one valid layout.
//!
//! Inputs: generator parameters (grid, radial), GeoJSON files (LineStrings
//! as streets, Polygons as parcels), the artist's sidecar
//! `NAME.layout.json` (layers, moves, deletions, protections, anchored
//! assignments) and the shape system its parcels grow. Outputs: a merged
//! [`model::Layout`], its GeoJSON (byte-identical for the same inputs),
//! the city as one model with a building on every parcel ([`city`]),
//! typed errors and reports.
//!
//! Invariants: identities are minted from structure ([`id`]: a generator's
//! seed and construction path, a street's end nodes, a block's streets, a
//! parcel's block and split path), never from array indices or creation
//! order; every operator leaves a layout that passes
//! [`validity::check`] (no street crosses a street except at a shared
//! node, no parcel overlaps a street with its width or another parcel) or
//! returns a typed error and leaves its input as it was; maps are ordered
//! by identity, so everything is deterministic; library code never panics
//! on user input.
//!
//! Modules, in the order of the data: [`id`], [`model`], [`geom`],
//! [`index`] (R-trees), [`blocks`], [`validity`]; [`generate`],
//! [`subdivide`] (parcels), [`geojson_io`]; [`transform`] (4.1.2),
//! [`select`], [`shared`] (the shared graph), [`merge`] (4.1.3, 4.1.4),
//! [`assign`] (4.3), [`layers`] (4.2), [`stack_cache`] (merged layer
//! stacks kept for an editor), [`sidecar`] (the file); [`svg`];
//! [`city`] (buildings grown on the parcels by a shape system, and the
//! city as one model for glTF and pictures), [`building_edits`] (an
//! artist's edits of one parcel's building, replayed there, reported
//! when the parcel is gone); [`diag`] (the problems as
//! coded diagnostics, R10xx); [`program`] (a `.grm` file's `layout`
//! item made into a document: the one road from a grammar to a city).
//! docs/layout.md explains them.
pub mod assign;
pub mod blocks;
pub mod building_edits;
pub mod city;
pub mod diag;
pub mod generate;
pub mod geojson_io;
pub mod geom;
pub mod id;
pub mod index;
pub mod layers;
pub mod merge;
pub mod model;
pub mod program;
pub mod select;
pub mod shared;
pub mod sidecar;
pub mod stack_cache;
pub mod subdivide;
pub mod svg;
pub mod transform;
pub mod validity;

//! Layers (4.2): each layer is a layout made from a source (a generator,
//! a GeoJSON file, features kept inline), then the artist's deletions,
//! moves (non-topological transforms of a selection), a rigid placement
//! of the whole layer (dragging it), and its anchored assignments. The
//! merged layout is `L_m = L_n`, then `L_m = M(L_i, L_m)` for i = n-1 .. 1,
//! each merge the mode of the layer above `L_i`, so higher layers win.
//! Insertion is a new layer; cutting a selection to a new layer deletes it
//! below and keeps it above (its elements keep their identities);
//! regenerating a layer first copies its protected elements to a layer
//! above it (4.2.3).

use crate::assign::{self, Assignment};
use crate::blocks::{blocks, ownership};
use crate::generate::{self, GridParams, RadialParams};
use crate::geojson_io::{self, LoadError};
use crate::geom::{Affine, quantize};
use crate::id::Id;
use crate::merge::{MergeMode, MergeParams, MergeReport, merge_step};
use crate::model::{Layout, PROTECTED, TagValue};
use crate::select::Selection;
use crate::stack_cache;
use crate::subdivide::{MergeCache, ParcelParams, regrow};
use crate::transform::{TransformError, UpdateParams, transform};
use geo::Coord;
use std::collections::BTreeSet;

/// Where a layer's elements come from.
#[derive(Debug, Clone, PartialEq)]
pub enum Source {
    Grid(GridParams),
    Radial(RadialParams),
    /// A GeoJSON file (a path relative to the sidecar).
    GeoJson(String),
    /// GeoJSON kept in the sidecar (inserted or cut elements).
    Features(String),
    Empty,
}

/// The elements a move picks.
#[derive(Debug, Clone, PartialEq)]
pub enum Select {
    Ids(Vec<Id>),
    Region(Vec<Coord>),
    Soft { centre: Coord, radius: f64 },
    Continuation { street: Id, max_turn_deg: f64 },
}

impl Select {
    pub fn resolve(&self, layout: &Layout) -> Selection {
        match self {
            Select::Ids(ids) => Selection::simple(ids.iter().copied()),
            Select::Region(r) => Selection::region(layout, r),
            Select::Soft { centre, radius } => Selection::soft(layout, *centre, *radius),
            Select::Continuation {
                street,
                max_turn_deg,
            } => Selection::continuation(layout, *street, *max_turn_deg),
        }
    }
}

/// One non-topological move of a selection: scale, then rotate (both
/// about `about`), then translate. The artist's numbers are kept (the
/// sidecar writes them back as they were); [`Move::map`] is the affine map.
#[derive(Debug, Clone, PartialEq)]
pub struct Move {
    pub select: Select,
    pub translate: Coord,
    pub rotate_deg: f64,
    pub scale: f64,
    pub about: Coord,
}

impl Move {
    /// A translation of a selection.
    pub fn translation(select: Select, d: Coord) -> Move {
        Move {
            select,
            translate: d,
            rotate_deg: 0.0,
            scale: 1.0,
            about: Coord { x: 0.0, y: 0.0 },
        }
    }

    pub fn map(&self) -> Affine {
        Affine::scale(self.scale, self.about)
            .then(&Affine::rotate(self.rotate_deg, self.about))
            .then(&Affine::translate(self.translate.x, self.translate.y))
    }
}

/// A rigid placement of a whole layer: rotate about `about`, then translate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Place {
    pub translate: Coord,
    pub rotate_deg: f64,
    pub about: Coord,
}

impl Default for Place {
    fn default() -> Self {
        Place {
            translate: Coord { x: 0.0, y: 0.0 },
            rotate_deg: 0.0,
            about: Coord { x: 0.0, y: 0.0 },
        }
    }
}

impl Place {
    pub fn is_identity(&self) -> bool {
        self.translate == Coord { x: 0.0, y: 0.0 } && self.rotate_deg == 0.0
    }

    pub fn affine(&self) -> Affine {
        Affine::rotate(self.rotate_deg, self.about)
            .then(&Affine::translate(self.translate.x, self.translate.y))
    }
}

/// One layer as the artist keeps it.
#[derive(Debug, Clone, PartialEq)]
pub struct LayerSpec {
    pub name: String,
    pub source: Source,
    /// How this layer merges onto the layers below it.
    pub merge: MergeMode,
    pub seed: u64,
    pub visible: bool,
    /// Fill blocks without parcels with generated ones.
    pub fill: bool,
    pub place: Place,
    pub moves: Vec<Move>,
    pub deleted: Vec<Id>,
    pub protected: Vec<Id>,
    pub assignments: Vec<Assignment>,
}

impl LayerSpec {
    pub fn new(name: &str, source: Source) -> LayerSpec {
        LayerSpec {
            name: name.to_string(),
            source,
            merge: MergeMode::Hard,
            seed: 1,
            visible: true,
            fill: true,
            place: Place::default(),
            moves: Vec::new(),
            deleted: Vec::new(),
            protected: Vec::new(),
            assignments: Vec::new(),
        }
    }
}

/// The artist's whole layout: layers bottom to top, the parcel knobs,
/// and the shape system the parcels grow ([`crate::city`]).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Document {
    pub layers: Vec<LayerSpec>,
    pub parcels: ParcelParams,
    pub buildings: Option<crate::city::BuildingSpec>,
}

/// Something that went wrong in one layer; the other layers still merge.
#[derive(Debug, Clone, PartialEq)]
pub enum LayerIssue {
    /// A generator's parameters.
    Params { layer: String, message: String },
    /// A GeoJSON file that cannot be read.
    MissingFile {
        layer: String,
        path: String,
        message: String,
    },
    /// A bad element in a GeoJSON source.
    Element { layer: String, error: LoadError },
    /// A move that was rejected (it would change the topology).
    MoveRejected {
        layer: String,
        index: usize,
        error: TransformError,
    },
    /// A deletion or protection naming an element the layer lacks.
    UnknownElement { layer: String, id: Id },
    /// A merge that failed (the layer is left out).
    Merge { layer: String, message: String },
}

impl LayerIssue {
    /// The stable code: the element's (R1001-R1010) or the layer's
    /// (R1011-R1015).
    pub fn diag_code(&self) -> grm_diag::Code {
        use grm_diag::Code;
        match self {
            LayerIssue::Params { .. } => Code::LayoutBadGenerator,
            LayerIssue::MissingFile { .. } => Code::LayoutMissingFile,
            LayerIssue::Element { error, .. } => error.kind.diag_code(),
            LayerIssue::MoveRejected { .. } => Code::LayoutMoveRejected,
            LayerIssue::UnknownElement { .. } => Code::LayoutUnknownElement,
            LayerIssue::Merge { .. } => Code::LayoutMergeFailed,
        }
    }

    /// The stable code as written (`R1012`).
    pub fn code(&self) -> &'static str {
        self.diag_code().as_str()
    }

    pub fn describe(&self) -> String {
        match self {
            LayerIssue::Params { layer, message } => format!("layer `{layer}`: {message}"),
            LayerIssue::MissingFile {
                layer,
                path,
                message,
            } => format!("layer `{layer}`: cannot read `{path}`: {message}"),
            LayerIssue::Element { layer, error } => {
                format!("layer `{layer}`: {}: {}", error.element, error.message)
            }
            LayerIssue::MoveRejected {
                layer,
                index,
                error,
            } => format!("layer `{layer}`: move {index} rejected: {error}"),
            LayerIssue::UnknownElement { layer, id } => format!("layer `{layer}`: no element {id}"),
            LayerIssue::Merge { layer, message } => format!("layer `{layer}`: {message}"),
        }
    }
}

/// The evaluated document: each layer's layout and the merged one.
#[derive(Debug, Clone, Default)]
pub struct Evaluated {
    pub layers: Vec<Layout>,
    pub merged: Layout,
    pub reports: Vec<MergeReport>,
    pub issues: Vec<LayerIssue>,
}

/// Reads a file a layer names (relative paths are the caller's to resolve).
pub type Loader<'a> = &'a dyn Fn(&str) -> Result<String, String>;

/// Applies a rigid map to every coordinate of a layout (nodes snapped to
/// the grid; parcels and the blocks' rest poses carried along).
pub fn place(layout: &mut Layout, a: &Affine) {
    for n in layout.nodes.values_mut() {
        n.pos = quantize(a.apply(n.pos));
    }
    for s in layout.streets.values_mut() {
        for p in &mut s.interior {
            *p = quantize(a.apply(*p));
        }
    }
    for p in layout.parcels.values_mut() {
        for c in &mut p.ring {
            *c = a.apply(*c);
        }
    }
    for r in layout.rests.values_mut() {
        for c in &mut r.ring {
            *c = a.apply(*c);
        }
        for p in &mut r.parcels {
            for c in &mut p.ring {
                *c = a.apply(*c);
            }
        }
    }
}

/// Builds one layer's layout from its source, before the artist's edits.
pub fn source_layout(
    spec: &LayerSpec,
    parcels: &ParcelParams,
    load: Loader,
    issues: &mut Vec<LayerIssue>,
) -> Layout {
    let name = &spec.name;
    let mut l = match &spec.source {
        Source::Grid(p) => generate::grid(p).unwrap_or_else(|e| {
            issues.push(LayerIssue::Params {
                layer: name.clone(),
                message: e.to_string(),
            });
            Layout::default()
        }),
        Source::Radial(p) => generate::radial(p).unwrap_or_else(|e| {
            issues.push(LayerIssue::Params {
                layer: name.clone(),
                message: e.to_string(),
            });
            Layout::default()
        }),
        Source::GeoJson(path) => match load(path) {
            Ok(text) => {
                let r = geojson_io::read(&text, path);
                issues.extend(r.errors.into_iter().map(|error| LayerIssue::Element {
                    layer: name.clone(),
                    error,
                }));
                r.layout
            }
            Err(message) => {
                issues.push(LayerIssue::MissingFile {
                    layer: name.clone(),
                    path: path.clone(),
                    message,
                });
                Layout::default()
            }
        },
        Source::Features(text) => {
            let r = geojson_io::read(text, name);
            issues.extend(r.errors.into_iter().map(|error| LayerIssue::Element {
                layer: name.clone(),
                error,
            }));
            r.layout
        }
        Source::Empty => Layout::default(),
    };
    if spec.fill {
        let b = blocks(&l);
        let own = ownership(&l, &b);
        let owners: BTreeSet<Id> = own.values().copied().collect();
        let empty: BTreeSet<Id> = b
            .iter()
            .map(|x| x.id)
            .filter(|id| !owners.contains(id))
            .collect();
        regrow(&mut l, &b, spec.seed, parcels, Some(&empty));
    }
    l
}

/// One layer with the artist's edits applied.
pub fn layer_layout(
    spec: &LayerSpec,
    parcels: &ParcelParams,
    load: Loader,
    issues: &mut Vec<LayerIssue>,
) -> Layout {
    let mut l = source_layout(spec, parcels, load, issues);
    for id in &spec.deleted {
        if !l.delete(*id) {
            issues.push(LayerIssue::UnknownElement {
                layer: spec.name.clone(),
                id: *id,
            });
        }
    }
    l.drop_isolated_nodes();
    let up = UpdateParams {
        parcels: *parcels,
        seed: spec.seed,
        ..UpdateParams::default()
    };
    for (i, m) in spec.moves.iter().enumerate() {
        let w = m.select.resolve(&l).node_weights(&l);
        if let Err(error) = transform(&mut l, &m.map(), &w, &up) {
            issues.push(LayerIssue::MoveRejected {
                layer: spec.name.clone(),
                index: i,
                error,
            });
        }
    }
    for id in &spec.protected {
        match l.tags_mut(*id) {
            Some(t) => {
                t.insert(PROTECTED.to_string(), TagValue::Bool(true));
            }
            None => issues.push(LayerIssue::UnknownElement {
                layer: spec.name.clone(),
                id: *id,
            }),
        }
    }
    if !spec.place.is_identity() {
        place(&mut l, &spec.place.affine());
    }
    assign::apply(&spec.assignments, &mut l);
    l
}

/// Merges built layers (bottom to top) in Lipp's order.
pub fn merge_layers(
    specs: &[LayerSpec],
    layouts: &[Layout],
    parcels: &ParcelParams,
    issues: &mut Vec<LayerIssue>,
) -> (Layout, Vec<MergeReport>) {
    merge_layers_cached(specs, layouts, parcels, issues, &MergeCache::default())
}

/// [`merge_layers`] with a cache kept between calls (an editor dragging a
/// layer keeps one: the same results, less work per update).
pub fn merge_layers_cached(
    specs: &[LayerSpec],
    layouts: &[Layout],
    parcels: &ParcelParams,
    issues: &mut Vec<LayerIssue>,
    cache: &MergeCache,
) -> (Layout, Vec<MergeReport>) {
    let visible: Vec<usize> = (0..specs.len().min(layouts.len()))
        .filter(|&i| specs[i].visible)
        .collect();
    let mut reports = Vec::new();
    let Some((&top, rest)) = visible.split_last() else {
        return (Layout::default(), reports);
    };
    let mut acc = std::sync::Arc::new((layouts[top].clone(), MergeReport::default()));
    let mut above = top;
    // The stack merged so far, by its key: an unchanged run of layers at
    // the top comes from the cache (a step that misses merges, and is kept
    // for the next call).
    let mut key = stack_cache::top_key(&acc.0);
    // The blocks of `acc` when the last step merged it here (the result's
    // blocks are the next merge's upper blocks: not computed twice).
    let mut acc_blocks: Option<Vec<crate::blocks::Block>> = None;
    for &i in rest.iter().rev() {
        let params = MergeParams {
            parcels: *parcels,
            seed: specs[i].seed,
            ..MergeParams::default()
        };
        let mode = specs[above].merge;
        key = stack_cache::step_key(key, &layouts[i], mode, &params);
        let mut blocks = None;
        let step = match cache.stack.get(key) {
            Some(step) => step,
            None => {
                let step = merge_step(&layouts[i], &acc.0, acc_blocks.take(), mode, &params, cache)
                    .map(|(l, r, b)| {
                        blocks = Some(b);
                        std::sync::Arc::new((l, r))
                    })
                    .map_err(|e| e.to_string());
                cache.stack.insert(key, step.clone());
                step
            }
        };
        match step {
            Ok(m) => {
                reports.push(m.1.clone());
                acc = m;
                acc_blocks = blocks;
            }
            Err(message) => issues.push(LayerIssue::Merge {
                layer: specs[i].name.clone(),
                message,
            }),
        }
        above = i;
    }
    let mut acc = std::sync::Arc::try_unwrap(acc).map_or_else(|rc| rc.0.clone(), |m| m.0);
    assign_regrown(specs, layouts, &visible, &mut acc);
    (acc, reports)
}

/// Parcels the merges regrew belong to no layer; they get every visible
/// layer's assignments, the top layer's first (a value already set stays),
/// each assignment at the place its anchor has in its own layer.
fn assign_regrown(specs: &[LayerSpec], layouts: &[Layout], visible: &[usize], acc: &mut Layout) {
    // No assignment: nothing to set (and no pass over the city's parcels).
    if visible.iter().all(|&i| specs[i].assignments.is_empty()) {
        return;
    }
    let known: BTreeSet<Id> = visible
        .iter()
        .flat_map(|&i| layouts[i].parcels.keys().copied())
        .collect();
    let mut fresh = Layout::default();
    for (id, p) in &acc.parcels {
        if !known.contains(id) {
            fresh.parcels.insert(*id, p.clone());
        }
    }
    if fresh.parcels.is_empty() {
        return;
    }
    for &i in visible.iter().rev() {
        let placed: Vec<Assignment> = specs[i]
            .assignments
            .iter()
            .map(|a| Assignment {
                pos: a.position(&layouts[i]),
                anchor: None,
                ..a.clone()
            })
            .collect();
        assign::apply(&placed, &mut fresh);
    }
    for (id, p) in fresh.parcels {
        if let Some(q) = acc.parcels.get_mut(&id) {
            q.tags = p.tags;
        }
    }
}

impl Document {
    /// Builds every layer and merges them.
    pub fn evaluate(&self, load: Loader) -> Evaluated {
        let mut ev = Evaluated::default();
        for spec in &self.layers {
            let l = layer_layout(spec, &self.parcels, load, &mut ev.issues);
            ev.layers.push(l);
        }
        let (m, r) = merge_layers(&self.layers, &ev.layers, &self.parcels, &mut ev.issues);
        ev.merged = m;
        ev.reports = r;
        ev
    }

    /// Moves the selected elements of a layer to a new layer right above it
    /// (4.2.2 "cut to a new layer"): deleted below, kept above as inline
    /// features with their identities. Returns the new layer's index.
    pub fn cut_to_layer(
        &mut self,
        layer: usize,
        ids: &BTreeSet<Id>,
        built: &Layout,
        name: &str,
    ) -> Option<usize> {
        let spec = self.layers.get_mut(layer)?;
        let sub = extract(built, ids);
        spec.deleted
            .extend(sub.streets.keys().chain(sub.parcels.keys()).copied());
        let mut new = LayerSpec::new(name, Source::Features(geojson_io::write(&sub, None)));
        new.fill = false;
        new.seed = spec.seed;
        self.layers.insert(layer + 1, new);
        Some(layer + 1)
    }

    /// Replaces a layer's source (a regeneration), first copying its
    /// protected elements (named in `protected` or tagged `protected`) to a
    /// hard-merged layer right above it. Returns that layer's index, if any.
    pub fn regenerate(&mut self, layer: usize, source: Source, built: &Layout) -> Option<usize> {
        let spec = self.layers.get_mut(layer)?;
        let mut ids: BTreeSet<Id> = spec.protected.iter().copied().collect();
        for (id, tags) in built
            .streets
            .iter()
            .map(|(k, s)| (k, &s.tags))
            .chain(built.parcels.iter().map(|(k, p)| (k, &p.tags)))
        {
            if tags.get(PROTECTED) == Some(&TagValue::Bool(true)) {
                ids.insert(*id);
            }
        }
        spec.source = source;
        spec.protected.clear();
        spec.deleted.clear();
        spec.moves.clear();
        if ids.is_empty() {
            return None;
        }
        let sub = extract(built, &ids);
        let mut new = LayerSpec::new(
            &format!("{} (protected)", spec.name),
            Source::Features(geojson_io::write(&sub, None)),
        );
        new.fill = false;
        new.merge = MergeMode::Hard;
        self.layers.insert(layer + 1, new);
        Some(layer + 1)
    }
}

/// The named streets (with their end nodes) and parcels of a layout.
pub fn extract(l: &Layout, ids: &BTreeSet<Id>) -> Layout {
    let mut out = Layout::default();
    for s in l.streets.values().filter(|s| ids.contains(&s.id)) {
        for n in [s.a, s.b] {
            if let Some(node) = l.nodes.get(&n) {
                out.nodes.insert(n, node.clone());
            }
        }
        out.streets.insert(s.id, s.clone());
    }
    for p in l.parcels.values().filter(|p| ids.contains(&p.id)) {
        let mut q = p.clone();
        q.origin = crate::model::ParcelOrigin::Explicit;
        out.parcels.insert(p.id, q);
    }
    out
}

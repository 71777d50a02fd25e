//! Shape mode in the preview (`mode = shape`, docs/lsp-extensions.md):
//! `grm/preview` grows a shape system through `grm_grow::shape` (lower,
//! derive, build: the road `grmc derive` takes) and sends its model as the
//! other modes do; `grm/pick` on one of its triangles answers the picked
//! shape (a terminal shape, or the shape whose rule inserted the picked
//! asset) with its key, exact and semantic locators, the operation that
//! made it (the range the editor jumps to: the `split`, `repeat` or `comp`
//! command, the successor or the `insert` in its parent's rule), the rule
//! that rewrote it, and the scopes of its ancestors, commands included,
//! with each split's and repeat's cuts (the page draws them as wireframe
//! boxes and planes).
//!
//! Frames: the shape world is z-up and the model grm's y-up (a world point
//! `(x, y, z)` is the model point `(x, z, -y)`, `grm_geom::shape`); scopes
//! are sent in the model's frame, as the triangles are.

use crate::convert;
use crate::preview::{
    AncestryOut, Failure, OriginOut, PickParams, PickResult, PickTable, PreviewMode, PreviewParams,
    PreviewResult, SkeletonOut, WarningOut, check, fits_answer, materials_out, params_out,
    parts_out, stats_out, too_large,
};
use glam::Vec3;
use grm_analysis::FileAnalysis;
use grm_grow::shape::{Lowered, ShapeGrowError, ShapeOptions};
use grm_sample::CancelToken;
use grm_sema::Value;
use grm_sema::shape::OpKind;
use grm_shape::{Command, NodeId, NodeKind, Scope, ShapeTree};
use serde::{Deserialize, Serialize};
use std::sync::Arc;
use std::time::Instant;
use tower_lsp_server::ls_types::{Range, Uri};

/// The preview's bound on the shape tree (the engine's own default).
const PREVIEW_MAX_SHAPES: u64 = 1_000_000;

/// Shape mode's figures in a preview result.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct ShapeOut {
    /// Nodes of the derivation tree (shapes, commands, inserts).
    pub nodes: usize,
    /// Of which shapes.
    pub shapes: usize,
    /// Terminal shape groups drawn (one glTF node each in an export).
    pub groups: usize,
}

/// A scope of the picked shape's path (model frame).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct ScopeOut {
    /// The node's index in the tree.
    pub node: u32,
    /// A shape's symbol, or a command's label (`split.y`, `repeat.x`,
    /// `comp.faces`).
    pub label: String,
    /// A command node (its scope is the one it divided).
    pub command: bool,
    /// The scope's corner.
    pub origin: [f32; 3],
    /// Its unit x, y and z axes.
    pub axes: [[f32; 3]; 3],
    /// Its extent along each axis.
    pub size: [f32; 3],
    /// A split's or repeat's axis (0 x, 1 y, 2 z).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis: Option<u32>,
    /// Where its parts begin and end along that axis (from the scope's
    /// origin, sorted, without 0 and the scope's size): the split planes.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub cuts: Vec<f32>,
    /// The node's identity key (8 hex digits): a command's names its
    /// planes in `grm/drag`.
    #[serde(default)]
    pub key: String,
    /// A split's or repeat's planes a drag can move: the end of each
    /// child (by its edge number) inside the scope.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub planes: Vec<PlaneOut>,
    /// A shape's exact locator (absent for commands and inserts): what the
    /// page's edit panel targets when it goes up a level.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exact: Option<String>,
    /// A shape's semantic locator (absent for commands and inserts).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub semantic: Option<String>,
}

/// A split's or repeat's plane: the end of child `edge`, at `at` from the
/// command scope's origin along its axis.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct PlaneOut {
    pub edge: u32,
    pub at: f32,
}

/// What `grm/pick` says of a shape.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct ShapePickOut {
    /// The shape's index in the tree.
    pub node: u32,
    /// Its exact locator (docs/shapes.md, "Locators").
    pub exact: String,
    /// Its semantic locator.
    pub semantic: String,
    /// What made it: the command's label (`split.x`), `successor`,
    /// `insert` or `axiom`; the result's range is where it is written.
    pub made_by: String,
    /// The rule that rewrote the shape itself, if one did.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rule: Option<Range>,
    /// The scopes of its path, from the axiom down to the shape (last).
    pub scopes: Vec<ScopeOut>,
}

/// What `grm/pick` keeps of a shape-mode preview.
#[derive(Debug)]
pub(crate) struct ShapePicks {
    tree: ShapeTree,
    lowered: Lowered,
    /// The system's file, as the client names it.
    uri: Uri,
    /// Where the system's name is written (the axiom's maker).
    system: Range,
    /// Per rule (by `Lowered::rules`): where it is written, and where each
    /// operation that makes a node (successor, command, insert) is, in
    /// order: a node's edge number `e` from its shape is the `e`-th.
    rules: Vec<(Range, Vec<Range>)>,
    /// The edits file replayed, and what became of its edits.
    pub(crate) edits: Option<crate::edits::EditsRun>,
}

/// A world point or direction in the model's frame.
fn model(v: Vec3) -> [f32; 3] {
    [v.x, v.z, -v.y]
}

impl ShapePicks {
    /// The shape tree of the preview.
    pub(crate) fn tree(&self) -> &ShapeTree {
        &self.tree
    }

    /// The lowered program (symbol, tag and asset names).
    pub(crate) fn program(&self) -> &grm_shape::Program {
        &self.lowered.program
    }

    /// Where the operation that made `node` is written (the system's name
    /// for the axiom).
    pub(crate) fn made_range(&self, node: NodeId) -> Option<(Uri, Range)> {
        if node.0 == 0 {
            return Some((self.uri.clone(), self.system));
        }
        let (_, _, range) = self.made_by(node)?;
        Some((self.uri.clone(), range))
    }

    /// The node a pick names: the shape whose group was picked (an
    /// insert's shape is the one whose rule inserted it).
    fn shape_of(&self, node: NodeId) -> Option<NodeId> {
        let n = self.tree.node(node)?;
        match n.kind {
            NodeKind::Insert { .. } => self.tree.parent(node),
            _ => Some(node),
        }
    }

    /// The rule that made `node` (an index into `rules`) and its operation
    /// there (what made the node, its range).
    fn maker(&self, node: NodeId) -> Option<(u32, String, Range)> {
        let (rule, made, range) = self.made_by(node)?;
        let what = match self.tree.node(made)?.kind {
            NodeKind::Command { command, .. } => command.label(),
            NodeKind::Insert { .. } => "insert".to_string(),
            NodeKind::Shape { .. } => "successor".to_string(),
        };
        Some((rule, what, range))
    }

    /// The rule that made `node`, the node its operation made (`node`
    /// itself, or the command whose child it is) and that operation's
    /// range; nothing allocated (called for every pick of a preview).
    fn made_by(&self, node: NodeId) -> Option<(u32, NodeId, Range)> {
        let n = self.tree.node(node)?;
        let parent = self.tree.parent(node)?;
        let p = self.tree.node(parent)?;
        // A command's child was made by the command, which its shape's rule ran.
        let (made, made_id, shape) = match p.kind {
            NodeKind::Command { .. } => (p, parent, self.tree.parent(parent)?),
            NodeKind::Shape { .. } => (n, node, parent),
            NodeKind::Insert { .. } => return None,
        };
        let NodeKind::Shape {
            symbol,
            alternative: Some(alt),
        } = self.tree.node(shape)?.kind
        else {
            return None;
        };
        let rule = self.lowered.rule_of(symbol, alt)?;
        let (_, ops) = self.rules.get(rule as usize)?;
        let range = *ops.get((made.edge as usize).checked_sub(1)?)?;
        Some((rule, made_id, range))
    }

    /// The scope of a node of the path, with a split's or repeat's cuts.
    fn scope_out(&self, id: NodeId) -> Option<ScopeOut> {
        let n = self.tree.node(id)?;
        let s: &Scope = &n.scope;
        let axes = s.axes();
        let (label, command, axis) = match n.kind {
            NodeKind::Shape { symbol, .. } => (
                self.lowered.program.symbol_name(symbol).to_string(),
                false,
                None,
            ),
            NodeKind::Command { command, .. } => {
                let axis = match command {
                    Command::Split(a) | Command::Repeat(a) => Some(a),
                    Command::Comp(_) => None,
                };
                (command.label(), true, axis)
            }
            NodeKind::Insert { .. } => ("insert".to_string(), false, None),
        };
        let mut cuts = Vec::new();
        let mut planes = Vec::new();
        if let Some(a) = axis {
            let dir = s.axis(a);
            let len = s.size[a.index()];
            for c in self.tree.children(id) {
                let Some(k) = self.tree.node(c) else { continue };
                let start = (k.scope.origin - s.origin).dot(dir);
                let end = start + k.scope.size[a.index()];
                if end > len * 1e-5 && end < len * (1.0 - 1e-5) {
                    planes.push(PlaneOut {
                        edge: k.edge,
                        at: end,
                    });
                }
                for x in [start, end] {
                    if x > len * 1e-5 && x < len * (1.0 - 1e-5) {
                        cuts.push(x);
                    }
                }
            }
            cuts.sort_by(f32::total_cmp);
            cuts.dedup_by(|a, b| (*a - *b).abs() <= len * 1e-5);
        }
        let program = &self.lowered.program;
        let (exact, semantic) = match n.kind {
            NodeKind::Shape { .. } => (
                Some(self.tree.exact_locator(program, id).to_string()),
                Some(self.tree.semantic_locator(program, id).to_string()),
            ),
            _ => (None, None),
        };
        Some(ScopeOut {
            node: id.0,
            label,
            command,
            origin: model(s.origin),
            axes: [model(axes.x_axis), model(axes.y_axis), model(axes.z_axis)],
            size: s.size.to_array(),
            axis: axis.map(|a| a.index() as u32),
            cuts,
            key: grm_grow::json::key_text(n.key),
            planes,
            exact,
            semantic,
        })
    }

    /// `grm/pick` on a shape-mode preview: a triangle of a part.
    pub(crate) fn pick(&self, t: &PickTable, params: &PickParams) -> Option<PickResult> {
        let (part, tri) = (params.part?, params.triangle?);
        let ps = t.parts.get(part)?;
        let i = ps.partition_point(|p| p.0 <= tri);
        let &(first, count, module, _) = ps.get(i.checked_sub(1)?)?;
        if tri >= first + count {
            return None;
        }
        let node = self.shape_of(NodeId(module))?;
        let n = self.tree.node(node)?;
        let program = &self.lowered.program;
        let NodeKind::Shape {
            symbol,
            alternative,
        } = n.kind
        else {
            return None;
        };
        let (made_by, range) = match self.maker(node) {
            Some((_, what, range)) => (what, range),
            None => ("axiom".to_string(), self.system),
        };
        let rule = alternative
            .and_then(|a| self.lowered.rule_of(symbol, a))
            .and_then(|r| self.rules.get(r as usize))
            .map(|r| r.0);
        let path = self.tree.path(node);
        let key = |k: u32| grm_grow::json::key_text(k);
        let ancestry = path
            .iter()
            .filter_map(|&id| {
                let m = self.tree.node(id)?;
                let (symbol, production) = match m.kind {
                    NodeKind::Shape {
                        symbol,
                        alternative,
                    } => (
                        Some(program.symbol_name(symbol).to_string()),
                        alternative.and_then(|a| self.lowered.rule_of(symbol, a)),
                    ),
                    NodeKind::Command { command, .. } => (Some(command.label()), None),
                    NodeKind::Insert { .. } => (None, None),
                };
                Some(AncestryOut {
                    key: key(m.key),
                    symbol,
                    child: self.tree.parent(id).map(|_| m.edge),
                    production,
                })
            })
            .collect();
        Some(PickResult {
            uri: self.uri.clone(),
            range,
            symbol: program.symbol_name(symbol).to_string(),
            version: t.version,
            module,
            key: Some(key(n.key)),
            ancestry,
            shape: Some(ShapePickOut {
                node: node.0,
                exact: self.tree.exact_locator(program, node).to_string(),
                semantic: self.tree.semantic_locator(program, node).to_string(),
                made_by,
                rule,
                scopes: path.iter().filter_map(|&id| self.scope_out(id)).collect(),
            }),
        })
    }
}

/// Whether a checked operation makes a node of the tree.
fn makes_node(op: &OpKind) -> bool {
    matches!(
        op,
        OpKind::Emit(_)
            | OpKind::Insert(_)
            | OpKind::Split(_)
            | OpKind::Repeat(_)
            | OpKind::Comp(_)
    )
}

/// Grow a shape system for the preview (`values`: the run's
/// meta-parameter values, the sliders' included), replaying the edits file
/// beside the system's grammar (`edits`: the client's buffers, else disk).
#[allow(clippy::too_many_arguments)]
pub(crate) fn build(
    fa: &FileAnalysis,
    uri: &Uri,
    uris: &crate::uris::Uris,
    edits: &crate::edits::Source,
    p: &PreviewParams,
    sys: &grm_sema::System,
    values: Vec<Value>,
    cancel: Option<&CancelToken>,
) -> Result<(PreviewResult, PickTable, grm_geom::Model), Failure> {
    let prog = &fa.checked.program;
    let shape = sys
        .shape
        .as_deref()
        .ok_or_else(|| format!("system `{}` has no shape rules", sys.name))?;
    let sys_file = fa.sources.get(sys.file);
    let (sys_path, sys_uri) = crate::preview::system_file(fa, sys.file, uri, uris);
    let dir = sys_path.parent().map(std::path::Path::to_path_buf);
    let options = ShapeOptions {
        seed: p.seed,
        threads: 1,
        limits: grm_shape::Limits {
            max_nodes: p.max_modules.unwrap_or(PREVIEW_MAX_SHAPES).min(50_000_000) as usize,
            ..grm_shape::Limits::default()
        },
    };
    let t0 = Instant::now();
    let edits_path = grm_edits::edits_path(&sys_path);
    let loaded = edits.load(&edits_path);
    let replayed = loaded.text.is_some().then_some(&loaded.parsed.file);
    let grown = grm_grow::shape::grow(prog, sys, &values, &options, None, replayed)
        .map_err(|e| Failure::Msg(message(&e, fa, sys)))?;
    // What became of each edit.
    let (edits_out, edits_run) = match uris.uri_of(&edits_path) {
        Some(edits_uri) => {
            let (o, r) = crate::edits::classify(
                edits,
                &loaded,
                edits_uri,
                prog,
                &grown.lowered,
                &grown.tree,
                &sys.name,
            );
            (Some(o), Some(r))
        }
        None => (None, None),
    };
    let derive_ms = t0.elapsed().as_secs_f64() * 1e3;
    check(cancel)?;
    let t1 = Instant::now();
    // No group names or locators: a pick finds its shape's in the tree.
    // On every core (a large building of boxes and rectangles is built in
    // halves; the model is the same).
    let build = grm_geom::BuildOptions {
        group_names: false,
        threads: 0,
        ..grm_geom::BuildOptions::limited(
            crate::preview::PREVIEW_MAX_BYTES,
            grm_geom::Output::Model,
        )
    };
    // Focus and context: the focused shape's subtree a few levels down,
    // the rest as proxies (an unknown key: the whole building).
    let cut = p.context.as_ref().and_then(|c| {
        let key = grm_edits::file::parse_key(c.key.trim())?;
        let at = grown.tree.nodes().iter().position(|n| n.key == key)?;
        Some(grm_grow::shape::focus_cut(
            &grown.tree,
            NodeId(at as u32),
            c.depth,
        ))
    });
    let model = grm_grow::shape::model_cut(
        prog,
        &values,
        &grown.lowered,
        &grown.tree,
        dir.as_deref(),
        &build,
        cut.as_deref(),
    )
    .map_err(|e| match e {
        ShapeGrowError::Geom(g) => too_large(&g),
        e => Failure::Msg(message(&e, fa, sys)),
    })?;
    let build_ms = t1.elapsed().as_secs_f64() * 1e3;
    check(cancel)?;
    // One origin per rule, in source order.
    let origins: Vec<OriginOut> = grown
        .lowered
        .rules
        .iter()
        .map(|r| OriginOut {
            uri: sys_uri.clone(),
            range: convert::range(sys_file, r.span),
            symbol: grown.lowered.program.symbol_name(r.symbol).to_string(),
        })
        .collect();
    let rules: Vec<(Range, Vec<Range>)> = shape
        .rules
        .iter()
        .map(|r| {
            let ops = r
                .ops
                .iter()
                .filter(|o| makes_node(&o.kind))
                .map(|o| convert::range(sys_file, o.span))
                .collect();
            (convert::range(sys_file, r.span), ops)
        })
        .collect();
    fits_answer(&model, origins.len())?;
    let picks = ShapePicks {
        lowered: grown.lowered,
        tree: grown.tree,
        uri: sys_uri,
        system: convert::range(sys_file, sys.loc.span),
        rules,
        edits: edits_run,
    };
    // The production under the focus position: the shapes its rule made.
    let focus = p.focus.and_then(|pos| {
        if sys.file != fa.root {
            return None;
        }
        let off = convert::offset(sys_file, pos);
        picks
            .lowered
            .rules
            .iter()
            .position(|r| r.span.contains(off) || r.span.end == off)
            .map(|r| r as u32)
    });
    let t2 = Instant::now();
    // A pick's origin is the rule that made its node (the `origin` field
    // is set to the node below); found for the picked nodes only.
    // The rule depends on the node's parent alone (the shape whose rule
    // made it, or the command that shape's rule ran): the last parent's
    // is remembered, since a split's or repeat's parts come in a row (a
    // walk up the tree per window was most of the encoding).
    let last = std::cell::Cell::new((u32::MAX, None));
    let origin_of = |node: u32| {
        let parent = picks.tree.parent(NodeId(node))?.0;
        match last.get() {
            (p, rule) if p == parent => rule,
            _ => {
                let rule = picks.made_by(NodeId(node)).map(|m| m.0);
                last.set((parent, rule));
                rule
            }
        }
    };
    let is_focus = |node: u32| focus.is_some() && origin_of(node) == focus;
    let mut table = PickTable {
        version: fa.version,
        origins: origins.clone(),
        ..PickTable::default()
    };
    let mut model = model;
    for part in &mut model.parts {
        for pk in &mut part.picks {
            pk.origin = pk.module;
        }
    }
    let parts = parts_out(
        &model,
        &origin_of,
        &is_focus,
        &mut table.parts,
        crate::preview::encoding(p),
    );
    let nodes = picks.tree.nodes();
    let shapes = nodes.iter().filter(|n| n.is_shape()).count();
    let shape_out = ShapeOut {
        nodes: nodes.len(),
        shapes,
        groups: model.groups.len(),
    };
    let seed = grown.seed;
    table.shape = Some(Arc::new(picks));
    let warnings = WarningOut::all(model.warnings(sys.file, sys.loc.span, false));
    let result = PreviewResult {
        uri: uri.clone(),
        version: fa.version,
        system: sys.name.clone(),
        mode: PreviewMode::Shape,
        seed,
        iterations: 0,
        encoding: "base64-le".into(),
        blob: None,
        materials: materials_out(&model),
        parts,
        skeleton: SkeletonOut {
            bone_count: 0,
            bones: Default::default(),
            parents: Default::default(),
            origins: Default::default(),
        },
        origins,
        focus: None,
        params: params_out(prog, &values),
        sample: None,
        stats: stats_out(&model, shapes, derive_ms, build_ms, t2),
        warnings,
        shape: Some(shape_out),
        edits: edits_out,
    };
    Ok((result, table, model))
}

/// A growing error as the preview says it: the message and its code.
fn message(e: &ShapeGrowError, fa: &FileAnalysis, sys: &grm_sema::System) -> String {
    let d = e.to_diagnostic(&fa.checked.program, sys.file, sys.span);
    format!("{} ({})", d.message, d.code.as_str())
}

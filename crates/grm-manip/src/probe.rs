//! A probe: one text grown through the real engines, measured.
//!
//! The text is checked (`grm_sema`, the loader for imports and meshes),
//! the system grown as the preview grows it (shape mode through
//! `grm_grow::shape` with the persistent edits replayed; derive mode
//! through `grm_grow::Grower` with identity keys, then the turtle), and
//! every part measured by its identity key: a shape's scope, the planes
//! of each split and repeat, a bone's base and tip. Finite differences of
//! these measures are the derivatives the solver uses: exact engines,
//! no model of them.

use std::collections::HashMap;

use grm_diag::Span;
use grm_sema::{FileLoader, Mode};

use crate::ManipError;

/// A measured part, by identity key.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) enum Measure {
    /// A shape: origin (3), size (3), x axis (3), z axis (3), world
    /// (shape frame, z up).
    Shape(u32),
    /// A split's or repeat's plane at the end of its child `edge`: the
    /// distance from the command's scope origin along its axis.
    Plane(u32, u32),
    /// A bone (derive mode), by its module's key: base (3), tip (3),
    /// width (the tube's diameter).
    Bone(u32),
}

/// What every probe shares: where the text lives and how to grow it.
/// Owned, so a [`crate::Manip`] can be kept between requests (a drag's
/// release reuses the probes its grab's provenance grew).
#[derive(Clone)]
pub struct Setup {
    /// The root file's path, as the loader reads its imports relative to it.
    pub path: String,
    /// Imports and meshes.
    pub loader: std::sync::Arc<dyn FileLoader + Send + Sync>,
    /// The system (default: the file's first).
    pub system: Option<String>,
    /// Meta-parameter values, `name=value` (the preview's sliders).
    pub params: Vec<String>,
    /// The seed (default: the system's).
    pub seed: Option<u32>,
    /// The persistent edits replayed (shape mode).
    pub edits: Option<grm_edits::EditsFile>,
}

impl Setup {
    /// A setup of `path` read through `loader`, the file's first system,
    /// default values and seed, no edits.
    pub fn new(
        path: impl Into<String>,
        loader: std::sync::Arc<dyn FileLoader + Send + Sync>,
    ) -> Setup {
        Setup {
            path: path.into(),
            loader,
            system: None,
            params: Vec::new(),
            seed: None,
            edits: None,
        }
    }
}

impl std::fmt::Debug for Setup {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Setup")
            .field("path", &self.path)
            .field("system", &self.system)
            .field("params", &self.params)
            .field("seed", &self.seed)
            .finish_non_exhaustive()
    }
}

/// Which engine grew a probe.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "camelCase")]
pub enum Grown {
    Shape,
    Derive,
}

/// One grown text's measures.
#[derive(Debug, Default)]
pub(crate) struct Snapshot {
    pub(crate) measures: HashMap<Measure, Vec<f64>>,
    /// Terminal parts (leaf shapes, bones): what "moved" counts.
    pub(crate) terminal: Vec<Measure>,
    /// What each part is, in words (the base growth only: [`grow_labelled`]).
    pub(crate) labels: HashMap<Measure, String>,
}

impl Snapshot {
    pub(crate) fn get(&self, m: &Measure) -> Option<&[f64]> {
        self.measures.get(m).map(Vec::as_slice)
    }

    /// How many terminal parts of `self` differ from `base` by more than
    /// `tol` in any measure, or are missing from either.
    pub(crate) fn moved_from(&self, base: &Snapshot, tol: f64) -> usize {
        let mut n = base
            .terminal
            .iter()
            .filter(|m| match (base.get(m), self.get(m)) {
                (Some(a), Some(b)) => a.iter().zip(b).any(|(x, y)| (x - y).abs() > tol),
                _ => true,
            })
            .count();
        n += self
            .terminal
            .iter()
            .filter(|m| !base.measures.contains_key(m))
            .count();
        n
    }
}

/// The facts of the checked root text that candidates need.
#[derive(Debug)]
pub(crate) struct Facts {
    pub(crate) system: Span,
    pub(crate) consts: Vec<Span>,
    pub(crate) names: Vec<String>,
    pub(crate) mode: Grown,
    pub(crate) system_name: String,
    /// Where the root file's last `param` declaration ends (after its `;`).
    pub(crate) params_end: Option<u32>,
}

/// Check `text`; the program, the system's index and the values.
fn checked(
    setup: &Setup,
    text: &str,
) -> Result<
    (
        grm_sema::Program,
        usize,
        Vec<grm_sema::Value>,
        grm_diag::FileId,
    ),
    ManipError,
> {
    let mut sources = grm_diag::SourceMap::new();
    let root = sources.add(setup.path.as_str(), text);
    let checked = grm_sema::check(&mut sources, root, setup.loader.as_ref());
    if let Some(d) = checked
        .diagnostics
        .iter()
        .find(|d| d.severity == grm_diag::Severity::Error)
    {
        return Err(ManipError::Invalid {
            message: format!("{}: {}", d.code.as_str(), d.message),
        });
    }
    let program = checked.program;
    let index = program
        .pick_system(setup.system.as_deref())
        .map_err(|d| ManipError::Invalid { message: d.message })?;
    let values = grm_compile::param_values(&program, &setup.params)
        .map_err(|m| ManipError::Invalid { message: m })?;
    Ok((program, index, values, root))
}

/// What the root text declares that candidates need.
pub(crate) fn facts(setup: &Setup, text: &str) -> Result<Facts, ManipError> {
    let (program, index, _, root) = checked(setup, text)?;
    let sys = &program.systems[index];
    if sys.file != root {
        return Err(ManipError::Unsupported {
            why: format!(
                "system `{}` is written in an imported file: open that file to drag its parts",
                sys.name
            ),
        });
    }
    let mode = match sys.mode {
        Mode::Shape => Grown::Shape,
        Mode::Derive => Grown::Derive,
        _ => {
            return Err(ManipError::Unsupported {
                why: format!(
                    "system `{}` is sampled (mode = sample): a sampled model is searched for, not placed by its numbers; drag a derive-mode or shape-mode system",
                    sys.name
                ),
            });
        }
    };
    // Each constant's declaration: from its name to the `;` after it.
    let consts = program
        .consts
        .iter()
        .filter(|c| c.loc.file == root)
        .map(|c| {
            let from = c.loc.span.start as usize;
            let end = text[from..].find(';').map_or(text.len(), |i| from + i + 1);
            Span::new(c.loc.span.start, end as u32)
        })
        .collect();
    let names = program
        .consts
        .iter()
        .filter(|c| c.ty == grm_sema::Ty::Float)
        .map(|c| c.name.clone())
        .chain(
            program
                .params
                .iter()
                .filter(|p| p.ty == grm_sema::Ty::Float)
                .map(|p| p.name.clone()),
        )
        .collect();
    let params_end = program
        .params
        .iter()
        .filter(|p| p.loc.file == root)
        .filter_map(|p| {
            let from = p.loc.span.start as usize;
            text[from..].find(';').map(|i| (from + i + 1) as u32)
        })
        .max();
    Ok(Facts {
        params_end,
        system: sys.span,
        consts,
        names,
        mode,
        system_name: sys.name.clone(),
    })
}

/// The derive-mode bound on a probe's string (a preview-sized model).
const MAX_MODULES: u64 = 4_000_000;

/// Grow `text` and measure every part.
pub(crate) fn grow(setup: &Setup, text: &str) -> Result<Snapshot, ManipError> {
    grow_seeded(setup, text, setup.seed)
}

/// [`grow`], naming every part in words too.
pub(crate) fn grow_labelled(setup: &Setup, text: &str) -> Result<Snapshot, ManipError> {
    grow_with(setup, text, setup.seed, true)
}

/// [`grow`] with another seed.
pub(crate) fn grow_seeded(
    setup: &Setup,
    text: &str,
    seed: Option<u32>,
) -> Result<Snapshot, ManipError> {
    grow_with(setup, text, seed, false)
}

fn grow_with(
    setup: &Setup,
    text: &str,
    seed: Option<u32>,
    labels: bool,
) -> Result<Snapshot, ManipError> {
    let (program, index, values, _) = checked(setup, text)?;
    let sys = &program.systems[index];
    let fail = |e: &dyn std::fmt::Display| ManipError::Grow {
        message: e.to_string(),
    };
    let mut snap = Snapshot::default();
    match sys.mode {
        Mode::Shape => {
            let options = grm_grow::shape::ShapeOptions {
                seed,
                threads: 1,
                ..Default::default()
            };
            let grown =
                grm_grow::shape::grow(&program, sys, &values, &options, None, setup.edits.as_ref())
                    .map_err(|e| fail(&e))?;
            measure_shapes(&grown.tree, &mut snap);
            if labels {
                label_shapes(&grown.tree, &grown.lowered.program, &mut snap);
            }
        }
        Mode::Derive => {
            let compiled = grm_compile::compile(&program, sys, &values)
                .map_err(|e| fail(&e.to_diagnostic().message))?;
            let record = grm_grow::Record {
                keys: true,
                ..Default::default()
            };
            let grower = grm_grow::Grower::new(&compiled, 1, record).map_err(|e| fail(&e))?;
            let opts = grm_derive::DeriveOptions {
                iterations: compiled.settings.iterations,
                seed: seed.unwrap_or(compiled.settings.seed),
                limits: grm_derive::DeriveLimits {
                    max_modules: MAX_MODULES,
                    ..Default::default()
                },
            };
            let g = grower.derive(&opts, &mut |_| {}).map_err(|e| fail(&e))?;
            let interp =
                grm_turtle::interpret(sys, &compiled.settings, &g.string).map_err(|e| fail(&e))?;
            for (i, b) in interp.bones.iter().enumerate() {
                let Some(key) = g.string.key(b.module as usize) else {
                    continue;
                };
                let m = Measure::Bone(key);
                if labels {
                    let sym = g
                        .string
                        .sym_at(b.module as usize)
                        .and_then(|s| compiled.symbol_names.get(s as usize));
                    snap.labels.insert(
                        m,
                        format!(
                            "bone {i} ({}, module {})",
                            sym.map_or("?", String::as_str),
                            b.module
                        ),
                    );
                }
                let v = [b.base, b.tip]
                    .iter()
                    .flat_map(|p| p.to_array())
                    .chain([b.width_base])
                    .map(f64::from)
                    .collect();
                if snap.measures.insert(m, v).is_none() {
                    snap.terminal.push(m);
                }
            }
        }
        _ => {
            return Err(ManipError::Unsupported {
                why: "a sampled system's parts are not placed by its numbers".into(),
            });
        }
    }
    Ok(snap)
}

fn measure_shapes(tree: &grm_shape::ShapeTree, snap: &mut Snapshot) {
    use grm_shape::{Command, NodeId, NodeKind};
    for (i, n) in tree.nodes().iter().enumerate() {
        let id = NodeId(i as u32);
        if tree.is_removed(id) {
            continue;
        }
        match n.kind {
            NodeKind::Shape { .. } => {
                let axes = n.scope.axes();
                let v: Vec<f64> = [n.scope.origin, n.scope.size, axes.x_axis, axes.z_axis]
                    .iter()
                    .flat_map(|p| p.to_array())
                    .map(f64::from)
                    .collect();
                let m = Measure::Shape(n.key);
                if snap.measures.insert(m, v).is_none() && !n.has_children() {
                    snap.terminal.push(m);
                }
            }
            NodeKind::Command {
                command: Command::Split(a) | Command::Repeat(a),
                ..
            } => {
                let dir = n.scope.axis(a);
                let len = n.scope.size[a.index()];
                for c in tree.children(id) {
                    let Some(k) = tree.node(c) else { continue };
                    let end = (k.scope.origin - n.scope.origin).dot(dir) + k.scope.size[a.index()];
                    // The scope's own end is no plane a drag moves.
                    if end < len * (1.0 - 1e-5) {
                        snap.measures
                            .insert(Measure::Plane(n.key, k.edge), vec![f64::from(end)]);
                    }
                }
            }
            _ => {}
        }
    }
}

/// Name every shape and plane of `tree` in words.
fn label_shapes(tree: &grm_shape::ShapeTree, program: &grm_shape::Program, snap: &mut Snapshot) {
    use grm_shape::{Command, NodeId, NodeKind};
    for (i, n) in tree.nodes().iter().enumerate() {
        let id = NodeId(i as u32);
        match n.kind {
            NodeKind::Shape { .. } => {
                snap.labels
                    .entry(Measure::Shape(n.key))
                    .or_insert_with(|| tree.semantic_locator(program, id).to_string());
            }
            NodeKind::Command {
                command: Command::Split(_) | Command::Repeat(_),
                ..
            } => {
                let owner = tree
                    .parent(id)
                    .map(|p| tree.semantic_locator(program, p).to_string())
                    .unwrap_or_default();
                for c in tree.children(id) {
                    let Some(k) = tree.node(c) else { continue };
                    snap.labels
                        .entry(Measure::Plane(n.key, k.edge))
                        .or_insert_with(|| {
                            format!(
                                "{owner} {}: after part {} ({})",
                                tree.label(program, id),
                                k.edge,
                                tree.label(program, c)
                            )
                        });
                }
            }
            _ => {}
        }
    }
}

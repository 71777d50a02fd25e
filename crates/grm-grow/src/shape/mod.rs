//! Shape mode on the one road: a checked `mode = shape` system lowered to
//! the shape engine's IR ([`lower`]), derived (`grm_shape::derive`: seed,
//! threads, limits) and built into a model (`grm_geom::shape`: one glTF
//! node per terminal shape group, with its locators), the tree returned
//! beside it for `--tree` ([`json`]) and the preview's picking.
//!
//! Errors are typed ([`ShapeGrowError`]) and become coded diagnostics
//! ([`ShapeGrowError::to_diagnostic`]): an unusable lot for the run's
//! meta-parameter values (E0509), the engine's run-time errors (R0801
//! too many shapes, R0802 too deep, R0803 a bad value, R0804 the wrong
//! kind of shape, R0805 internal), each pointing at the first rule of the
//! symbol the engine names, and the model's (`grm_geom::GeomError`).

pub mod bake;
pub mod edits;
pub mod json;
mod lower;
pub mod retarget;

use std::path::Path;

use grm_diag::{Code, Diagnostic, FileId, Span};
use grm_geom::{BuildOptions, GeomError, Model};
use grm_sema::Value;
use grm_shape::{Limits, ShapeError, ShapeTree};

pub use lower::{GivenLot, Lowered, RuleSource, lower, lower_on};

/// How to grow a shape system.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShapeOptions {
    /// The seed (default: the system's `seed` setting).
    pub seed: Option<u32>,
    /// Worker threads: 1 derives on the calling thread, 0 on every core;
    /// the tree is the same for any number.
    pub threads: usize,
    /// Bounds on the tree (nodes, depth).
    pub limits: Limits,
}

impl Default for ShapeOptions {
    fn default() -> Self {
        ShapeOptions {
            seed: None,
            threads: 1,
            limits: Limits::default(),
        }
    }
}

/// A grown shape system.
#[derive(Debug)]
pub struct ShapeGrown {
    /// The lowered program (names of symbols, tags and assets; the
    /// source span of each rule).
    pub lowered: Lowered,
    /// The whole derivation tree (shapes, commands, inserts).
    pub tree: ShapeTree,
    /// The seed it was grown with.
    pub seed: u32,
    /// The model, when one was asked for.
    pub model: Option<Model>,
}

/// Why lowering stopped.
#[derive(Clone, Debug, PartialEq)]
pub enum LowerError {
    /// The system is not a shape system (R0806).
    NotShape { system: String },
    /// The lot is not a usable footprint for these meta-parameter values
    /// (E0509); `span` is the `lot` setting's value.
    Lot { why: String, span: Option<Span> },
    /// The engine refused the lowered program (internal, R0805).
    Program { error: String },
    /// A checked system that is not what the checker promises (internal,
    /// R0805).
    Internal(String),
}

/// Why growing a shape system stopped.
#[derive(Debug)]
pub enum ShapeGrowError {
    Lower(LowerError),
    /// The engine's error; `span` is the first rule of the symbol it
    /// names, where there is one.
    Shape {
        error: ShapeError,
        span: Option<Span>,
    },
    /// Building the model.
    Geom(GeomError),
}

impl std::fmt::Display for ShapeGrowError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ShapeGrowError::Lower(LowerError::NotShape { system }) => write!(
                f,
                "system `{system}` is not a shape system (it has no `mode = shape;`)"
            ),
            ShapeGrowError::Lower(LowerError::Lot { why, .. }) => {
                write!(f, "the lot is not a usable footprint: {why}")
            }
            ShapeGrowError::Lower(LowerError::Program { error }) => {
                write!(f, "the shape engine refused the program: {error}")
            }
            ShapeGrowError::Lower(LowerError::Internal(m)) => write!(f, "{m}"),
            ShapeGrowError::Shape { error, .. } => error.fmt(f),
            ShapeGrowError::Geom(e) => e.fmt(f),
        }
    }
}

impl std::error::Error for ShapeGrowError {}

impl From<LowerError> for ShapeGrowError {
    fn from(e: LowerError) -> Self {
        ShapeGrowError::Lower(e)
    }
}

/// The internal errors' help line.
const INTERNAL: &str =
    "this is an internal error of grm; please report it with the file that caused it";

impl ShapeGrowError {
    /// The error's code.
    pub fn code(&self) -> Code {
        match self {
            ShapeGrowError::Lower(LowerError::NotShape { .. }) => Code::NotShapeRunnable,
            ShapeGrowError::Lower(LowerError::Lot { .. }) => Code::BadLot,
            ShapeGrowError::Lower(_) => Code::ShapeInternal,
            ShapeGrowError::Shape { error, .. } => match error {
                ShapeError::TooManyShapes { .. } => Code::TooManyShapes,
                ShapeError::TooDeep { .. } => Code::ShapeTooDeep,
                ShapeError::Size { .. } | ShapeError::BadValue { .. } | ShapeError::Roof { .. } => {
                    Code::ShapeBadValue
                }
                ShapeError::WrongGeometry { .. } | ShapeError::PopWithoutPush { .. } => {
                    Code::ShapeWrongGeometry
                }
                ShapeError::BadLot { .. } => Code::BadLot,
                _ => Code::ShapeInternal,
            },
            ShapeGrowError::Geom(_) => Code::ExportIo,
        }
    }

    /// The error as a diagnostic in `file`; errors that name no rule point
    /// at `span` (the system's name). A model's error is the geometry
    /// crate's own diagnostic (`program` resolves its names).
    pub fn to_diagnostic(
        &self,
        program: &grm_sema::Program,
        file: FileId,
        span: Span,
    ) -> Diagnostic {
        let (at, label, help): (Span, &str, &str) = match self {
            ShapeGrowError::Geom(e) => return e.to_diagnostic(program, file, span),
            ShapeGrowError::Lower(LowerError::NotShape { .. }) => (
                span,
                "not a shape system",
                "run derive and sample systems with `grmc derive` and `grmc sample`",
            ),
            ShapeGrowError::Lower(LowerError::Lot { span: at, .. }) => (
                at.unwrap_or(span),
                "this lot",
                "choose meta-parameter values (`--param`) that make the lot a polygon with area",
            ),
            ShapeGrowError::Lower(_) => (span, "in this system", INTERNAL),
            ShapeGrowError::Shape { error, span: at } => {
                let at = at.unwrap_or(span);
                match error {
                    ShapeError::TooManyShapes { .. } => (
                        at,
                        "in this system",
                        "bound the grammar (a rule that splits or repeats forever?), or raise the limit with `--max-shapes`",
                    ),
                    ShapeError::TooDeep { .. } => (
                        at,
                        "this rule goes too deep",
                        "make the rule end: a symbol that rewrites to itself needs a condition that stops it",
                    ),
                    ShapeError::Size { .. }
                    | ShapeError::BadValue { .. }
                    | ShapeError::Roof { .. } => (
                        at,
                        "in this rule",
                        "make the value a finite number for every shape (a condition can keep the rule from small scopes)",
                    ),
                    ShapeError::WrongGeometry { .. } => (
                        at,
                        "in this rule",
                        "give the operation a shape it applies to: extrude a face before `comp(faces)`, split an edge rather than extrude it",
                    ),
                    ShapeError::PopWithoutPush { .. } => (
                        at,
                        "in this rule",
                        "every `]` needs a `[` before it in the same rule",
                    ),
                    ShapeError::BadLot { .. } => {
                        (at, "the lot", "make the lot a polygon with area")
                    }
                    ShapeError::TooManyAttributes { .. } => (
                        at,
                        "in this system",
                        "use fewer distinct colours and materials",
                    ),
                    _ => (at, "in this system", INTERNAL),
                }
            }
        };
        Diagnostic::new(self.code(), self.to_string(), file, at, label).with_help(help)
    }
}

/// The symbol an engine error names.
fn error_symbol(e: &ShapeError) -> Option<&str> {
    match e {
        ShapeError::TooDeep { symbol, .. }
        | ShapeError::Size { symbol, .. }
        | ShapeError::BadValue { symbol, .. }
        | ShapeError::WrongGeometry { symbol, .. }
        | ShapeError::PopWithoutPush { symbol }
        | ShapeError::Roof { symbol, .. } => Some(symbol),
        _ => None,
    }
}

/// Derive a lowered system.
pub fn derive(
    lowered: &Lowered,
    seed: u32,
    options: &ShapeOptions,
) -> Result<ShapeTree, ShapeGrowError> {
    derive_with_edits(lowered, seed, options, None)
}

/// [`derive`], replaying `edits` (a plan of the system's persistent
/// edits, [`edit_plan`]) while deriving (docs/edits.md, "Replay").
pub fn derive_with_edits(
    lowered: &Lowered,
    seed: u32,
    options: &ShapeOptions,
    edits: Option<&grm_shape::EditPlan>,
) -> Result<ShapeTree, ShapeGrowError> {
    let opts = grm_shape::Options {
        seed,
        threads: options.threads,
        limits: options.limits,
    };
    grm_shape::derive_with_edits(&lowered.program, &lowered.lot, &opts, edits).map_err(|error| {
        let span = error_symbol(&error).and_then(|s| lowered.rule_span(s));
        ShapeGrowError::Shape { error, span }
    })
}

/// The replay plan of the edits of `file` that name the lowered system
/// (not those of one city parcel's building, `Edit::parcel`: only
/// [`grow_on_lot_with_edits`] replays those, for their parcel).
pub fn edit_plan(lowered: &Lowered, file: &grm_edits::EditsFile) -> grm_shape::EditPlan {
    let name = lowered.program.name();
    grm_shape::EditPlan::new(
        &lowered.program,
        file.edits
            .iter()
            .filter(|e| e.system == name && e.parcel.is_none()),
    )
}

/// Build the model of a grown tree: terminal shapes and inserts, with the
/// program's declared materials and meshes (evaluated with `params`) and
/// textures relative to `dir` (the grammar's directory).
pub fn model(
    program: &grm_sema::Program,
    params: &[Value],
    lowered: &Lowered,
    tree: &ShapeTree,
    dir: Option<&Path>,
    build: &BuildOptions,
) -> Result<Model, ShapeGrowError> {
    model_cut(program, params, lowered, tree, dir, build, None)
}

/// [`model`] with a cut (focus and context: per node, drawn, a proxy or
/// hidden; [`grm_geom::shape::Cut`], [`focus_cut`]).
pub fn model_cut(
    program: &grm_sema::Program,
    params: &[Value],
    lowered: &Lowered,
    tree: &ShapeTree,
    dir: Option<&Path>,
    build: &BuildOptions,
    cut: Option<&[grm_geom::shape::Cut]>,
) -> Result<Model, ShapeGrowError> {
    let assets = grm_geom::shape::ShapeAssets::from_program(program, params, dir)
        .map_err(ShapeGrowError::Geom)?;
    grm_geom::shape::build_shape_model_cut(tree, &lowered.program, &assets, build, cut)
        .map_err(ShapeGrowError::Geom)
}

/// Focus and context (Lipp, section 3.3.2): the cut that shows `focus`'s
/// subtree down to `depth` levels below it, and the rest of the building
/// as proxies at the focus's own level: a shape at its limit that has
/// children is drawn with its own geometry (its mass, its facade), the
/// nodes below it are not drawn. The limit is the focus's depth plus
/// `depth` inside its subtree, the focus's depth outside it. Nodes are in
/// expansion order, every parent before its children.
pub fn focus_cut(
    tree: &ShapeTree,
    focus: grm_shape::NodeId,
    depth: u32,
) -> Vec<grm_geom::shape::Cut> {
    use grm_geom::shape::Cut;
    let nodes = tree.nodes();
    let Some(f) = tree.node(focus) else {
        return vec![Cut::Drawn; nodes.len()];
    };
    let base = f.depth;
    let mut inside = vec![false; nodes.len()];
    let mut cut = vec![Cut::Drawn; nodes.len()];
    for (i, n) in nodes.iter().enumerate() {
        let id = grm_shape::NodeId(i as u32);
        let parent = tree.parent(id);
        inside[i] = id == focus || parent.is_some_and(|p| inside[p.0 as usize]);
        if parent.is_some_and(|p| cut[p.0 as usize] != Cut::Drawn) {
            cut[i] = Cut::Hidden;
            continue;
        }
        let limit = if inside[i] {
            base.saturating_add(depth)
        } else {
            base
        };
        if n.is_shape() && n.depth >= limit && n.has_children() {
            cut[i] = Cut::Proxy;
        }
    }
    cut
}

/// Grow `system` of `program` (a shape system checked without errors)
/// with the meta-parameter values `params`: lower, derive, and build the
/// model when `build` is given. `dir` is the grammar's directory
/// (textures).
pub fn grow(
    program: &grm_sema::Program,
    system: &grm_sema::System,
    params: &[Value],
    options: &ShapeOptions,
    build: Option<(&BuildOptions, Option<&Path>)>,
    edits: Option<&grm_edits::EditsFile>,
) -> Result<ShapeGrown, ShapeGrowError> {
    let lowered = lower(program, system, params)?;
    grow_lowered(program, params, lowered, options, build, edits)
}

/// Derive a lowered system (replaying `edits`) and build its model when
/// `build` is given: the end of [`grow`] and [`grow_on_lot`].
fn grow_lowered(
    program: &grm_sema::Program,
    params: &[Value],
    lowered: Lowered,
    options: &ShapeOptions,
    build: Option<(&BuildOptions, Option<&Path>)>,
    edits: Option<&grm_edits::EditsFile>,
) -> Result<ShapeGrown, ShapeGrowError> {
    let plan = edits.map(|f| edit_plan(&lowered, f));
    grow_planned(program, params, lowered, options, build, plan.as_ref())
}

/// [`grow_lowered`] with the replay plan made.
fn grow_planned(
    program: &grm_sema::Program,
    params: &[Value],
    lowered: Lowered,
    options: &ShapeOptions,
    build: Option<(&BuildOptions, Option<&Path>)>,
    plan: Option<&grm_shape::EditPlan>,
) -> Result<ShapeGrown, ShapeGrowError> {
    let seed = options.seed.unwrap_or(lowered.seed);
    let tree = derive_with_edits(&lowered, seed, options, plan)?;
    let model = match build {
        Some((b, dir)) => Some(model(program, params, &lowered, &tree, dir, b)?),
        None => None,
    };
    Ok(ShapeGrown {
        lowered,
        tree,
        seed,
        model,
    })
}

/// [`grow`] on a lot the caller gives instead of the system's `lot`
/// setting ([`GivenLot`]: rings of `[x, y]` metres in the shape world, z
/// up, and the direction of the lot's x axis; a city parcel:
/// `grm_layout::city`). The lot's scope is its bounding box in that frame,
/// so the building stands where the rings are; a lot without area is
/// E0509 naming no place. The model is built when `build` is given (lot
/// polygon in, model out).
pub fn grow_on_lot(
    program: &grm_sema::Program,
    system: &grm_sema::System,
    params: &[Value],
    lot: GivenLot,
    options: &ShapeOptions,
    build: Option<(&BuildOptions, Option<&Path>)>,
) -> Result<ShapeGrown, ShapeGrowError> {
    let lowered = lower_on(program, system, params, Some(lot))?;
    grow_lowered(program, params, lowered, options, build, None)
}

/// [`grow_on_lot`] replaying `edits` inside the derivation (the engine's
/// replay, docs/edits.md): those of them that name `system`, whatever
/// their `parcel` (the caller picks the edits of one lot's building: a
/// city parcel's, `grm_layout::city`). No edits grows what
/// [`grow_on_lot`] grows.
pub fn grow_on_lot_with_edits(
    program: &grm_sema::Program,
    system: &grm_sema::System,
    params: &[Value],
    lot: GivenLot,
    options: &ShapeOptions,
    build: Option<(&BuildOptions, Option<&Path>)>,
    edits: &[&grm_edits::Edit],
) -> Result<ShapeGrown, ShapeGrowError> {
    let lowered = lower_on(program, system, params, Some(lot))?;
    if edits.is_empty() {
        return grow_lowered(program, params, lowered, options, build, None);
    }
    let name = lowered.program.name();
    let plan = grm_shape::EditPlan::new(
        &lowered.program,
        edits.iter().copied().filter(|e| e.system == name),
    );
    grow_planned(program, params, lowered, options, build, Some(&plan))
}

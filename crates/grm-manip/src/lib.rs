//! `grm-manip`: direct manipulation that writes the grammar (issue 28;
//! Lipp's visual rule editor, section 3.3.2, and Merz et al.'s sketched
//! meta-parameters, seed 004).
//!
//! Role: from a part the artist picked in the preview back to the source
//! numbers that place it, and from a drag or a sketch to the fewest edits
//! of those numbers that reproduce it. The language server and `grmc`
//! both call it; it calls the one road (`grm_grow`) for every growth.
//!
//! - **Provenance** ([`Manip::provenance`]): each candidate source number
//!   ([`candidates`]: the literals of the system and of its constants'
//!   declarations, and each use of a constant or meta-parameter) is
//!   perturbed in the text, the text grown through the real engines
//!   ([`probe`]), and the part measured again by its identity key; a
//!   number whose perturbation moves the part is one of its sources, with
//!   the finite-difference derivative of the part's measures.
//! - **Drag** ([`Manip::drag`]): a [`Target`] for one measure of the part
//!   (a split plane's position, a shape's size or corner, a bone's tip or
//!   length) is solved by Gauss-Newton over one source number, then two,
//!   every step verified by growing the edited text; among the edits that
//!   reach the target within the tolerance the one that moves the fewest
//!   other parts wins. A literal is rewritten; a constant or
//!   meta-parameter is rewritten as `NAME + offset` at this use only.
//!   Where nothing reaches it the answer says why (a random draw, a bound).
//! - **Sketch** ([`Manip::sketch`]): keyframes (t, target) with t = 1
//!   required; the drag's sources are solved at each t and written as an
//!   interpolating piecewise-linear B-spline of a new meta-parameter
//!   (`mix`, exact at its knots: t = 0 gives the original values bit for
//!   bit), and `param NAME = 0 in 0 .. 1;` is added.
//!
//! Inputs: the root file's text, a [`Setup`] (path, loader, system,
//! slider values, seed, persistent edits), a [`Part`] (by identity key).
//! Outputs: [`Provenance`], [`DragOutcome`], [`SketchOutcome`]: text
//! edits by byte span in the root file, and the edited text.
//!
//! Invariants: every answer was grown and measured, never extrapolated;
//! a proposed edit checks without errors; the solver never panics on user
//! input (typed [`ManipError`]s).

pub mod candidates;
pub mod defaults;
mod probe;
mod sketch;
mod solve;

use grm_diag::Span;
use serde::Serialize;

pub use candidates::{Candidate, CandidateKind, format_number};
pub use probe::{Grown, Setup};
pub use sketch::{Keyframe, SketchOutcome};
pub use solve::{Change, DragOutcome, Manip, PartInfo, Provenance, Solution, Source};

/// A picked part, by identity key (docs/engine.md and docs/shapes.md,
/// "Identity"), as `grm/pick` names it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "camelCase", tag = "kind")]
pub enum Part {
    /// A shape (shape mode): its scope's corner, size and axes.
    Shape { key: u32 },
    /// The plane at the end of child `edge` (from 1) of a split or repeat
    /// command (shape mode): its distance from the command's scope
    /// corner along the command's axis.
    Plane { command: u32, edge: u32 },
    /// A bone (derive mode), by its module's key: its base, tip and width.
    Bone { key: u32 },
}

/// Where a drag puts a measure of the part.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, serde::Deserialize)]
#[serde(rename_all = "camelCase", tag = "kind")]
pub enum Target {
    /// A plane's new distance from its command's scope corner.
    Plane { at: f64 },
    /// A shape's new extent along its scope axis `axis` (0 x, 1 y, 2 z).
    Size { axis: usize, size: f64 },
    /// A shape's scope corner to this world point (shape frame, z up).
    Corner { at: [f64; 3] },
    /// A bone's tip to this point (the model's frame).
    Tip { at: [f64; 3] },
    /// A bone's new length.
    Length { length: f64 },
    /// A bone's new width (its tube's diameter).
    Width { width: f64 },
}

impl Target {
    /// The residual of `measures` (of `part`) against the target: zero
    /// when the part is where it was dropped.
    pub(crate) fn residual(&self, part: &Part, m: &[f64]) -> Result<Vec<f64>, ManipError> {
        let bad = || ManipError::Mismatch {
            why: format!("{self:?} does not apply to {part:?}"),
        };
        Ok(match (part, self) {
            (Part::Plane { .. }, Target::Plane { at }) => vec![m[0] - at],
            (Part::Shape { .. }, Target::Size { axis, size }) if *axis < 3 => {
                vec![m[3 + axis] - size]
            }
            (Part::Shape { .. }, Target::Corner { at }) => (0..3).map(|i| m[i] - at[i]).collect(),
            (Part::Bone { .. }, Target::Tip { at }) => (0..3).map(|i| m[3 + i] - at[i]).collect(),
            (Part::Bone { .. }, Target::Length { length }) => {
                let l = (0..3)
                    .map(|i| (m[3 + i] - m[i]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                vec![l - length]
            }
            (Part::Bone { .. }, Target::Width { width }) => vec![m[6] - width],
            _ => return Err(bad()),
        })
    }
}

/// Why a manipulation could not be answered.
#[derive(Clone, Debug, PartialEq)]
pub enum ManipError {
    /// The text does not check, or the system or a value is unknown.
    Invalid { message: String },
    /// Growing failed (an engine's error).
    Grow { message: String },
    /// This system or part cannot be manipulated so.
    Unsupported { why: String },
    /// The part is not in the grown model.
    NoPart { part: Part },
    /// The target does not fit the part.
    Mismatch { why: String },
}

impl std::fmt::Display for ManipError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ManipError::Invalid { message } => {
                write!(f, "the grammar does not check: {message}")
            }
            ManipError::Grow { message } => write!(f, "growing failed: {message}"),
            ManipError::Unsupported { why } => write!(f, "{why}"),
            ManipError::NoPart { part } => write!(
                f,
                "the part ({}) is not in the grown model (regrow the preview and pick again)",
                part_name(part)
            ),
            ManipError::Mismatch { why } => write!(f, "{why}"),
        }
    }
}

impl std::error::Error for ManipError {}

/// A part as the messages name it.
pub(crate) fn part_name(p: &Part) -> String {
    match p {
        Part::Shape { key } => format!("shape {key:08x}"),
        Part::Plane { command, edge } => format!("plane {edge} of command {command:08x}"),
        Part::Bone { key } => format!("bone {key:08x}"),
    }
}

/// A text edit of the root file.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct TextEdit {
    /// Bytes replaced (empty: an insertion).
    pub span: Span,
    /// The new text.
    pub text: String,
}

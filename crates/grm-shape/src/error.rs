//! The typed errors of the shape engine: a bad program, a bad value met
//! while deriving, or a derivation past its limits. None of them is a
//! panic; every one names what went wrong in words a grammar's author can
//! act on.

use std::fmt;

/// Why a split or repeat could not be laid out ([`crate::split`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SizeError {
    /// The extent to divide (a scope size) is NaN or infinite.
    BadExtent(f32),
    /// Part `part` (0-based) has a NaN or infinite size.
    BadSize { part: usize, value: f32 },
    /// A repeat's tile has no length at all (every part sizes to 0), so
    /// it would repeat without end.
    EmptyTile,
    /// A repeat would lay more tiles than allowed (`count` is the number
    /// that fit, saturated at `u64::MAX`).
    TooManyTiles { count: u64, max: u64 },
    /// A split or repeat with no parts.
    NoParts,
}

impl fmt::Display for SizeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SizeError::BadExtent(v) => {
                write!(f, "the scope size to divide is {v}, not a finite number")
            }
            SizeError::BadSize { part, value } => {
                write!(f, "part {} has size {value}, not a finite number", part + 1)
            }
            SizeError::EmptyTile => write!(
                f,
                "the repeated tile has length 0, so it would repeat forever"
            ),
            SizeError::TooManyTiles { count, max } => {
                write!(
                    f,
                    "the repeat fits {count} tiles, more than the limit of {max}"
                )
            }
            SizeError::NoParts => write!(f, "a split or repeat needs at least one part"),
        }
    }
}

impl std::error::Error for SizeError {}

/// A program that cannot be derived as written (found by
/// [`crate::ProgramBuilder::build`], before any derivation).
#[derive(Clone, Debug, PartialEq)]
pub enum ProgramError {
    /// An id (symbol, tag or asset) that the program does not define.
    UnknownId { what: &'static str, id: u32 },
    /// Two rules for one symbol.
    DuplicateRule { symbol: String },
    /// A rule with no alternatives.
    NoAlternatives { symbol: String },
    /// An alternative weight that is not finite and positive.
    BadWeight {
        symbol: String,
        alternative: usize,
        weight: f32,
    },
    /// A split, repeat or component split with nothing in it.
    EmptyCommand {
        symbol: String,
        command: &'static str,
    },
    /// An expression that cannot be compiled (`why` says how: ill-typed,
    /// nested too deep).
    BadExpr { why: String },
    /// An expression of the wrong type where it is used (`what`: a
    /// condition, a weight, a number of an operation).
    ExprType {
        symbol: String,
        alternative: usize,
        what: &'static str,
        expected: &'static str,
    },
    /// An alternative whose random draws do not fit the draw index
    /// (docs/shapes.md, "Identity": at most 2,047 draws per operation,
    /// 4,094 operations and 256 alternatives with draws).
    TooManyDraws { symbol: String, alternative: usize },
}

impl fmt::Display for ProgramError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ProgramError::UnknownId { what, id } => write!(f, "unknown {what} id {id}"),
            ProgramError::DuplicateRule { symbol } => write!(f, "symbol `{symbol}` has two rules"),
            ProgramError::NoAlternatives { symbol } => {
                write!(f, "the rule of `{symbol}` has no alternatives")
            }
            ProgramError::BadWeight {
                symbol,
                alternative,
                weight,
            } => write!(
                f,
                "alternative {} of `{symbol}` has weight {weight}; weights must be finite and positive",
                alternative + 1
            ),
            ProgramError::EmptyCommand { symbol, command } => {
                write!(f, "a {command} in the rule of `{symbol}` has no parts")
            }
            ProgramError::BadExpr { why } => write!(f, "invalid expression: {why}"),
            ProgramError::ExprType {
                symbol,
                alternative,
                what,
                expected,
            } => write!(
                f,
                "in alternative {} of `{symbol}`: {what} must be a {expected}",
                alternative + 1
            ),
            ProgramError::TooManyDraws {
                symbol,
                alternative,
            } => write!(
                f,
                "alternative {} of `{symbol}` has more random draws than the draw index holds",
                alternative + 1
            ),
        }
    }
}

impl std::error::Error for ProgramError {}

/// Why a derivation stopped. Deterministic: the same program, lot and
/// options give the same error with any number of threads (docs/shapes.md,
/// "Limits and errors").
#[derive(Clone, Debug, PartialEq)]
pub enum ShapeError {
    /// The program itself is malformed.
    Program(ProgramError),
    /// The initial shape (the lot) is unusable: `why` says how.
    BadLot { why: String },
    /// The derivation tree would hold more than `max` nodes.
    TooManyShapes { max: usize },
    /// A rule would make a node deeper than `max` (a grammar that splits
    /// or rewrites forever). `symbol` is the shape whose rule went too deep.
    TooDeep { max: u32, symbol: String },
    /// A split or repeat in the rule of `symbol` could not be laid out.
    Size { symbol: String, error: SizeError },
    /// An operation got a value it cannot use (`what` says which, e.g. a
    /// NaN extrusion height).
    BadValue {
        symbol: String,
        what: &'static str,
        value: f32,
    },
    /// An operation applied to a shape it does not apply to (e.g. a
    /// component split into faces of a 2D face, or an extrusion of an
    /// edge).
    WrongGeometry {
        symbol: String,
        op: &'static str,
        geometry: &'static str,
    },
    /// `pop` with nothing pushed.
    PopWithoutPush { symbol: String },
    /// A roof or taper in the rule of `symbol` could not be built on the
    /// shape's footprint ([`crate::roof`]).
    Roof {
        symbol: String,
        error: crate::roof::RoofError,
    },
    /// The rules set more than `max` distinct attribute sets (material,
    /// colour, texture; [`crate::attributes`]).
    TooManyAttributes { max: usize },
}

impl fmt::Display for ShapeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ShapeError::Program(e) => write!(f, "invalid shape program: {e}"),
            ShapeError::BadLot { why } => write!(f, "invalid lot: {why}"),
            ShapeError::TooManyShapes { max } => write!(
                f,
                "the derivation makes more than {max} shapes and commands (raise the limit or bound the grammar)"
            ),
            ShapeError::TooDeep { max, symbol } => write!(
                f,
                "the rule of `{symbol}` goes deeper than {max} levels (a grammar that splits or rewrites forever?)"
            ),
            ShapeError::Size { symbol, error } => write!(f, "in the rule of `{symbol}`: {error}"),
            ShapeError::BadValue {
                symbol,
                what,
                value,
            } => {
                write!(f, "in the rule of `{symbol}`: {what} is {value}")
            }
            ShapeError::WrongGeometry {
                symbol,
                op,
                geometry,
            } => {
                write!(
                    f,
                    "in the rule of `{symbol}`: {op} does not apply to {geometry}"
                )
            }
            ShapeError::PopWithoutPush { symbol } => {
                write!(f, "in the rule of `{symbol}`: pop without a matching push")
            }
            ShapeError::Roof { symbol, error } => write!(f, "in the rule of `{symbol}`: {error}"),
            ShapeError::TooManyAttributes { max } => write!(
                f,
                "the rules set more than {max} distinct materials, colours and textures (use fewer distinct colours)"
            ),
        }
    }
}

impl std::error::Error for ShapeError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            ShapeError::Program(e) => Some(e),
            ShapeError::Size { error, .. } => Some(error),
            ShapeError::Roof { error, .. } => Some(error),
            _ => None,
        }
    }
}

impl From<ProgramError> for ShapeError {
    fn from(e: ProgramError) -> Self {
        ShapeError::Program(e)
    }
}

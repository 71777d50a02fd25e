//! Typed sampling errors, each with a stable code (`R03xx`) and, where
//! there is one, the place in the source.

use grm_compile::vm::VmError;
use grm_diag::{Code, Diagnostic, FileId, Span, mib};

/// Why sampling stopped.
#[derive(Clone, Debug, PartialEq)]
pub enum SampleError {
    /// The system is not a sample system (`mode = sample;`).
    NotSampleSystem { system: String },
    /// A production failed while expanding one non-terminal.
    Runtime(ExpandError),
    /// The geometry phase (or a wrap-up) went past a limit: a geometry
    /// symbol that in practice never stops expanding.
    GeometryLimit {
        /// The symbol being expanded when the limit was hit.
        symbol: String,
        /// What ran out.
        what: LimitKind,
        limit: u64,
        file: FileId,
        /// The production that was applied last.
        span: Span,
    },
    /// The interpreter rejected an expansion (a broken compiled system).
    Turtle(String),
    /// The thread pool could not be created.
    ThreadPool(String),
    /// The options are unusable (e.g. a volume target that cannot be built).
    Options(String),
    /// After generation `generation` (0-based) the search held `bytes`
    /// ([`crate::GenerationStats::memory_bytes`]), over
    /// [`crate::SampleOptions::max_bytes`].
    MemoryLimit {
        generation: u32,
        bytes: u64,
        limit: u64,
        /// The particles it kept.
        particles: usize,
        /// The figures of the generations run, this one included (what
        /// `grmc sample --stats` prints before the error).
        generations: Vec<crate::GenerationStats>,
    },
    /// The run's [`crate::CancelToken`] was set: the caller asked it to
    /// stop (there is no model, not even a partial one).
    Cancelled,
}

/// Which geometry-phase limit was hit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LimitKind {
    /// Nested geometry expansions ([`crate::FinishLimits::max_depth`]).
    Depth,
    /// Geometry expansions of one model ([`crate::FinishLimits::max_expansions`]).
    Expansions,
}

/// A failure while applying a production to one non-terminal.
#[derive(Clone, Debug, PartialEq)]
pub struct ExpandError {
    /// The phase: `"axiom"`, `"skeleton"`, `"wrap-up"`, `"geometry"` or
    /// `"expected direction"`.
    pub phase: &'static str,
    /// The non-terminal's symbol name.
    pub symbol: String,
    pub kind: ExpandErrorKind,
    /// The expression that failed.
    pub file: FileId,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub enum ExpandErrorKind {
    /// A module parameter evaluated to NaN or an infinity.
    NonFinite { value: f32 },
    /// A weight evaluated to something that is not a positive finite number.
    BadWeight { value: f32 },
    /// The bytecode faulted (a compiler bug or broken tables).
    Fault(VmError),
}

impl SampleError {
    /// The stable code: `R03xx`.
    pub fn code(&self) -> Code {
        match self {
            SampleError::NotSampleSystem { .. } => Code::NotSampleSystem,
            SampleError::Runtime(e) => match e.kind {
                ExpandErrorKind::NonFinite { .. } => Code::SampleNonFinite,
                ExpandErrorKind::BadWeight { .. } => Code::SampleInvalidWeight,
                ExpandErrorKind::Fault(_) => Code::SampleBytecodeFault,
            },
            SampleError::GeometryLimit { .. } => Code::GeometryLimit,
            SampleError::Turtle(_) => Code::SampleInterpret,
            SampleError::ThreadPool(_) => Code::SampleThreadPool,
            SampleError::Options(_) => Code::SampleOptions,
            SampleError::Cancelled => Code::SampleCancelled,
            SampleError::MemoryLimit { .. } => Code::SampleMemoryLimit,
        }
    }

    /// The error as a diagnostic: code, message, the primary label on the
    /// span it names (errors that name none point at `file`/`span`, the
    /// system being sampled) and the help line.
    pub fn to_diagnostic(&self, file: FileId, span: Span) -> Diagnostic {
        let (file, span, label) = match self.location() {
            Some((f, s)) => (f, s, self.label()),
            None => {
                let label = match self {
                    SampleError::NotSampleSystem { .. } => "this system has no `mode = sample;`",
                    _ => "while sampling this system",
                };
                (file, span, label.to_string())
            }
        };
        let d = Diagnostic::new(self.code(), self.to_string(), file, span, label);
        match self.help() {
            Some(h) => d.with_help(h),
            None => d,
        }
    }

    /// The place in the source the error points at, if any.
    pub fn location(&self) -> Option<(FileId, Span)> {
        match self {
            SampleError::Runtime(e) => Some((e.file, e.span)),
            SampleError::GeometryLimit { file, span, .. } => Some((*file, *span)),
            _ => None,
        }
    }

    /// A short label for the source span.
    pub fn label(&self) -> String {
        match self {
            SampleError::Runtime(e) => match e.kind {
                ExpandErrorKind::NonFinite { value } => format!("this evaluates to {value}"),
                ExpandErrorKind::BadWeight { value } => format!("this weight is {value}"),
                ExpandErrorKind::Fault(_) => "while evaluating this".into(),
            },
            SampleError::GeometryLimit { .. } => "applied here last".into(),
            _ => String::new(),
        }
    }

    /// A hint on how to fix it.
    pub fn help(&self) -> Option<String> {
        match self {
            SampleError::NotSampleSystem { .. } => {
                Some("add `mode = sample;` to the system, or run it with `grmc derive`".into())
            }
            SampleError::Runtime(e) => match e.kind {
                ExpandErrorKind::NonFinite { .. } => Some(
                    "guard the expression with a condition, e.g. `: x > 0`, or clamp its inputs (a `choose` whose weights are all 0 is NaN too)"
                        .into(),
                ),
                ExpandErrorKind::BadWeight { .. } => {
                    Some("weights must be positive: e.g. `max(w, 0.001)`".into())
                }
                ExpandErrorKind::Fault(_) => Some(INTERNAL.into()),
            },
            SampleError::GeometryLimit { what, limit, .. } => Some(match what {
                LimitKind::Depth => format!(
                    "make the recursion of the geometry symbols end sooner (a condition on a counter): they nest at most {limit} deep, and a chain like `deco(n) -> sphere(r) deco(n + 1)` nests one level per step, so emit several shapes per expansion"
                ),
                LimitKind::Expansions => format!(
                    "geometry symbols expand into too many modules: end their recursion sooner (a model has at most {limit} geometry expansions)"
                ),
            }),
            SampleError::Turtle(_) => Some(INTERNAL.into()),
            SampleError::ThreadPool(_) => Some(
                "the operating system refused the worker threads: run with `--threads 1`, or free resources"
                    .into(),
            ),
            SampleError::MemoryLimit { .. } => Some(
                "sample fewer particles (`--particles`, or the `particles_start` and `particles_end` settings) or fewer generations, or raise the limit (`--max-memory`)"
                    .into(),
            ),
            SampleError::Options(_) | SampleError::Cancelled => None,
        }
    }
}

/// The help line of errors that only a bug in grm can cause.
const INTERNAL: &str =
    "this is an internal error of grm; please report it with the file that caused it";

impl std::fmt::Display for SampleError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SampleError::NotSampleSystem { system } => {
                write!(f, "`{system}` is not a sample system")
            }
            SampleError::Runtime(e) => write!(f, "{e}"),
            SampleError::GeometryLimit {
                symbol,
                what,
                limit,
                ..
            } => match what {
                LimitKind::Depth => write!(
                    f,
                    "the geometry phase nested more than {limit} expansions deep while expanding `{symbol}`"
                ),
                LimitKind::Expansions => write!(
                    f,
                    "the geometry phase made more than {limit} expansions (last: `{symbol}`)"
                ),
            },
            SampleError::Turtle(m) => write!(f, "cannot interpret an expansion: {m}"),
            SampleError::ThreadPool(m) => write!(f, "cannot start the thread pool: {m}"),
            SampleError::Options(m) => write!(f, "{m}"),
            SampleError::Cancelled => write!(f, "sampling was cancelled"),
            SampleError::MemoryLimit {
                generation,
                bytes,
                limit,
                particles,
                ..
            } => write!(
                f,
                "after generation {}, the search holds {} for its {particles} particles, over the limit of {}",
                generation + 1,
                mib(*bytes),
                mib(*limit)
            ),
        }
    }
}

impl std::error::Error for SampleError {}

impl std::fmt::Display for ExpandError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let what = match &self.kind {
            ExpandErrorKind::NonFinite { value } => format!("a parameter evaluated to {value}"),
            ExpandErrorKind::BadWeight { value } => {
                format!("a weight evaluated to {value}, not a positive number")
            }
            ExpandErrorKind::Fault(v) => v.to_string(),
        };
        write!(
            f,
            "{what} while expanding `{}` ({} phase)",
            self.symbol, self.phase
        )
    }
}

impl std::error::Error for ExpandError {}

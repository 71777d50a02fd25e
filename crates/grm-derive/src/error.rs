//! Typed derivation errors, each with a stable code (`R02xx`) and a place.

use grm_compile::vm::VmError;
use grm_diag::{Code, Diagnostic, FileId, Span, mib};

/// Why a derivation stopped.
#[derive(Clone, Debug, PartialEq)]
pub enum DeriveError {
    /// The next string would have more modules than allowed.
    ModuleLimit {
        /// The iteration that would produce it (1 = the first rewriting step).
        iteration: u32,
        /// Its length in modules.
        modules: u64,
        /// The limit ([`crate::DeriveLimits::max_modules`]).
        limit: u64,
        /// The system (its name in its file).
        file: FileId,
        span: Span,
    },
    /// The next iteration would need more memory than allowed.
    MemoryLimit {
        iteration: u32,
        /// Bytes live during the iteration: the input string, its bracket
        /// table (context-sensitive systems) and the output string.
        bytes: u64,
        limit: u64,
        /// The output's length in modules and parameter words.
        modules: u64,
        words: u64,
        file: FileId,
        span: Span,
    },
    /// The next string's module or parameter count does not fit the 32-bit
    /// indices of [`crate::ModuleString`].
    TooLarge {
        iteration: u32,
        modules: u64,
        words: u64,
        file: FileId,
        span: Span,
    },
    /// A production failed while rewriting one module.
    Runtime(RuntimeError),
    /// The compiled tables are inconsistent.
    InvalidTables(String),
    /// A module string given to [`crate::Engine::step`] does not fit the system.
    InvalidInput(String),
    /// The thread pool could not be created.
    ThreadPool(String),
    /// More worker threads were asked for than an engine starts
    /// ([`crate::MAX_THREADS`]); nothing was started. Same code as
    /// [`DeriveError::ThreadPool`] (R0209): the pool cannot start.
    TooManyThreads {
        /// The thread count asked for.
        threads: usize,
        /// [`crate::MAX_THREADS`].
        max: usize,
    },
    /// A `mode = sample` system was given to classic derivation (`grmc
    /// derive`, the runner): its skeleton symbols are meant to be searched
    /// for by the guided sampler, and parallel rewriting grows nothing
    /// useful from them. The engine itself rewrites any compiled system;
    /// front-ends refuse these with this error.
    SampleSystem {
        /// The system's name.
        system: String,
    },
}

/// A failure while applying a production to one module.
#[derive(Clone, Debug, PartialEq)]
pub struct RuntimeError {
    /// The iteration being computed (1 = the first rewriting step; 0 = the axiom).
    pub iteration: u32,
    /// The input position of the module being rewritten.
    pub position: u64,
    /// The module's symbol name.
    pub symbol: String,
    pub kind: RuntimeErrorKind,
    /// Where in the source: the expression that failed.
    pub file: FileId,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub enum RuntimeErrorKind {
    /// A module parameter evaluated to NaN or an infinity.
    NonFinite { value: f32 },
    /// A weight evaluated to something that is not a positive finite number.
    BadWeight { value: f32 },
    /// The bytecode faulted (a compiler bug or broken tables).
    Fault(VmError),
}

impl DeriveError {
    /// The stable code: `R02xx`.
    pub fn code(&self) -> Code {
        match self {
            DeriveError::ModuleLimit { .. } => Code::ModuleLimit,
            DeriveError::MemoryLimit { .. } => Code::MemoryLimit,
            DeriveError::TooLarge { .. } => Code::StringTooLarge,
            DeriveError::Runtime(e) => match e.kind {
                RuntimeErrorKind::NonFinite { .. } => Code::NonFiniteParameter,
                RuntimeErrorKind::BadWeight { .. } => Code::InvalidWeight,
                RuntimeErrorKind::Fault(_) => Code::BytecodeFault,
            },
            DeriveError::InvalidTables(_) => Code::InvalidTables,
            DeriveError::InvalidInput(_) => Code::InvalidModuleString,
            DeriveError::ThreadPool(_) | DeriveError::TooManyThreads { .. } => Code::ThreadPool,
            DeriveError::SampleSystem { .. } => Code::NotDeriveSystem,
        }
    }

    /// The error as a diagnostic: code, message, the primary label on the
    /// span it names (errors that name none point at `file`/`span`, the
    /// system being derived) and the help line.
    pub fn to_diagnostic(&self, file: FileId, span: Span) -> Diagnostic {
        let (file, span, label) = match self.location() {
            Some((f, s)) => (f, s, self.label()),
            None if matches!(self, DeriveError::SampleSystem { .. }) => (file, span, self.label()),
            None => (file, span, "while deriving this system".to_string()),
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
            DeriveError::ModuleLimit { file, span, .. }
            | DeriveError::MemoryLimit { file, span, .. }
            | DeriveError::TooLarge { file, span, .. } => Some((*file, *span)),
            DeriveError::Runtime(e) => Some((e.file, e.span)),
            _ => None,
        }
    }

    /// A short label for the source span.
    pub fn label(&self) -> String {
        match self {
            DeriveError::ModuleLimit { .. }
            | DeriveError::MemoryLimit { .. }
            | DeriveError::TooLarge { .. } => "this system grows too large".into(),
            DeriveError::Runtime(e) => match e.kind {
                RuntimeErrorKind::NonFinite { value } => format!("this evaluates to {value}"),
                RuntimeErrorKind::BadWeight { value } => format!("this weight is {value}"),
                RuntimeErrorKind::Fault(_) => "while evaluating this".into(),
            },
            DeriveError::SampleSystem { .. } => "this system has `mode = sample;`".into(),
            _ => String::new(),
        }
    }

    /// A hint on how to fix it.
    pub fn help(&self) -> Option<String> {
        match self {
            DeriveError::ModuleLimit { .. } => {
                Some("derive fewer iterations (`-n`), or raise the limit (`--max-modules`)".into())
            }
            DeriveError::MemoryLimit { .. } => {
                Some("derive fewer iterations (`-n`), or raise the limit (`--max-memory`)".into())
            }
            DeriveError::TooLarge { .. } => Some("derive fewer iterations (`-n`)".into()),
            DeriveError::Runtime(e) => match e.kind {
                RuntimeErrorKind::NonFinite { .. } => Some(
                    "guard the expression with a condition, e.g. `: x > 0`, or clamp its inputs (a `choose` whose weights are all 0 is NaN too)"
                        .into(),
                ),
                RuntimeErrorKind::BadWeight { .. } => {
                    Some("weights must be positive: e.g. `max(w, 0.001)`".into())
                }
                RuntimeErrorKind::Fault(_) => Some(INTERNAL.into()),
            },
            DeriveError::InvalidTables(_) | DeriveError::InvalidInput(_) => Some(INTERNAL.into()),
            DeriveError::ThreadPool(_) => Some(
                "the operating system refused the worker threads: run with `--threads 1`, or free resources"
                    .into(),
            ),
            DeriveError::TooManyThreads { max, .. } => Some(format!(
                "ask for at most {max} threads (0 uses all cores, 1 runs on the calling thread)"
            )),
            DeriveError::SampleSystem { .. } => Some(
                "grow it with `grmc sample` (guided by curves), or remove `mode = sample;` to derive it"
                    .into(),
            ),
        }
    }
}

/// The help line of errors that only a bug in grm can cause.
const INTERNAL: &str =
    "this is an internal error of grm; please report it with the file that caused it";

impl std::fmt::Display for DeriveError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            DeriveError::ModuleLimit {
                iteration,
                modules,
                limit,
                ..
            } => write!(
                f,
                "iteration {iteration} would produce {modules} modules, more than the limit of {limit}"
            ),
            DeriveError::MemoryLimit {
                iteration,
                bytes,
                limit,
                modules,
                words,
                ..
            } => write!(
                f,
                "iteration {iteration} would need {} ({modules} modules, {words} parameter words), more than the limit of {}",
                mib(*bytes),
                mib(*limit)
            ),
            DeriveError::TooLarge {
                iteration,
                modules,
                words,
                ..
            } => write!(
                f,
                "iteration {iteration} would produce {modules} modules with {words} parameter words, beyond 32-bit indices"
            ),
            DeriveError::Runtime(e) => write!(f, "{e}"),
            DeriveError::InvalidTables(m) => write!(f, "invalid compiled tables: {m}"),
            DeriveError::InvalidInput(m) => write!(f, "invalid module string: {m}"),
            DeriveError::ThreadPool(m) => write!(f, "cannot start the thread pool: {m}"),
            DeriveError::TooManyThreads { threads, max } => write!(
                f,
                "cannot start the thread pool: {threads} threads is more than the {max} an engine starts"
            ),
            DeriveError::SampleSystem { system } => write!(
                f,
                "`{system}` is a sample system: classic derivation does not grow it"
            ),
        }
    }
}

impl std::error::Error for DeriveError {}

impl std::fmt::Display for RuntimeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let what = match &self.kind {
            RuntimeErrorKind::NonFinite { value } => {
                format!("a parameter evaluated to {value}")
            }
            RuntimeErrorKind::BadWeight { value } => {
                format!("a weight evaluated to {value}, not a positive number")
            }
            RuntimeErrorKind::Fault(v) => v.to_string(),
        };
        write!(
            f,
            "{what} in iteration {} while rewriting `{}` at position {}",
            self.iteration, self.symbol, self.position
        )
    }
}

impl std::error::Error for RuntimeError {}

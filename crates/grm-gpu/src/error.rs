//! Typed errors of the GPU engine.

use std::fmt;

use grm_diag::{Code, Diagnostic, FileId, Span};

/// A count the kernels' scan saturated at (`u32::MAX`): the real count is
/// larger.
const SATURATED: u64 = u32::MAX as u64;

/// Everything that can go wrong on the GPU path. Library calls return this;
/// they never panic on user input and never let a derivation outgrow the
/// device (sizes are checked before each dispatch).
#[derive(Clone, Debug, PartialEq)]
pub enum GpuError {
    /// No GPU adapter could be found (no Vulkan driver, or no device). On a
    /// machine without a GPU install Mesa's lavapipe
    /// (`mesa-vulkan-drivers`, `libvulkan1`).
    NoAdapter(String),
    /// The adapter refused to create a device.
    RequestDevice(String),
    /// A buffer the next dispatch needs is larger than the device allows.
    BufferTooLarge {
        /// Which buffer (for example `"output symbols"`).
        what: &'static str,
        /// Bytes it would need.
        bytes: u64,
        /// The device's limit in bytes.
        limit: u64,
        /// Which limit (`max_storage_buffer_binding_size` or `max_buffer_size`).
        limit_name: &'static str,
    },
    /// A count does not fit the 32-bit indices the kernels use.
    CountOverflow {
        what: &'static str,
        /// The count (saturated at `u64::MAX`).
        count: u64,
    },
    /// A dispatch needs more workgroups than even a 2D grid of
    /// `max_compute_workgroups_per_dimension`² allows.
    TooManyWorkgroups {
        what: &'static str,
        workgroups: u64,
        limit: u64,
    },
    /// The brackets of a module string do not balance where the
    /// interpreter needs them to (a `]` without `[`; or, in a string of
    /// several systems, a system that leaves a `[` open before the next).
    UnbalancedBrackets {
        /// Where it shows (the first module of the system that starts at
        /// the wrong depth), when known.
        position: Option<usize>,
    },
    /// The next string would have more modules than allowed.
    ModuleLimit {
        iteration: u32,
        modules: u64,
        limit: u64,
    },
    /// The next iteration would need more device memory than allowed.
    MemoryLimit {
        iteration: u32,
        bytes: u64,
        limit: u64,
    },
    /// A production failed on one module (as the CPU engine's runtime errors).
    Runtime {
        /// The system (the job's index in a multi-system derivation; 0 otherwise).
        system: u32,
        /// The string being produced (0: the axiom).
        iteration: u32,
        /// The input position of the failing module (the lowest one).
        position: u64,
        /// Its symbol's name, when known.
        symbol: String,
        kind: RuntimeKind,
    },
    /// The program uses something the GPU engine does not implement.
    Unsupported(String),
    /// The input is malformed (a module string that breaks its invariant,
    /// a symbol out of range, ...).
    InvalidInput(String),
    /// wgpu reported an error (validation, out of memory, internal).
    Device(String),
    /// The device was lost.
    DeviceLost(String),
    /// Reading results back from the GPU failed.
    Readback(String),
}

/// What failed in a [`GpuError::Runtime`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RuntimeKind {
    /// A module parameter evaluated to NaN or an infinity.
    NonFinite,
    /// A weight that is not a positive finite number.
    BadWeight,
    /// The bytecode faulted.
    Fault,
}

impl GpuError {
    /// The stable code: `R06xx`, except the limits and production errors,
    /// which share the CPU engine's codes (R0201, R0202, R0204 to R0206).
    pub fn code(&self) -> Code {
        match self {
            GpuError::NoAdapter(_) => Code::GpuNoAdapter,
            GpuError::RequestDevice(_) => Code::GpuRequestDevice,
            GpuError::BufferTooLarge { .. } => Code::GpuBufferTooLarge,
            GpuError::CountOverflow { .. } => Code::GpuCountOverflow,
            GpuError::TooManyWorkgroups { .. } => Code::GpuTooManyWorkgroups,
            GpuError::UnbalancedBrackets { .. } => Code::GpuUnbalancedBrackets,
            GpuError::ModuleLimit { .. } => Code::ModuleLimit,
            GpuError::MemoryLimit { .. } => Code::MemoryLimit,
            GpuError::Runtime { kind, .. } => match kind {
                RuntimeKind::NonFinite => Code::NonFiniteParameter,
                RuntimeKind::BadWeight => Code::InvalidWeight,
                RuntimeKind::Fault => Code::BytecodeFault,
            },
            GpuError::Unsupported(_) => Code::GpuUnsupported,
            GpuError::InvalidInput(_) => Code::GpuInvalidInput,
            GpuError::Device(_) => Code::GpuDevice,
            GpuError::DeviceLost(_) => Code::GpuDeviceLost,
            GpuError::Readback(_) => Code::GpuReadback,
        }
    }

    /// The error as a diagnostic pointing at `file`/`span`, the system
    /// being derived (GPU errors name no source place; a production error
    /// is best reported by the CPU engine, which names the expression).
    pub fn to_diagnostic(&self, file: FileId, span: Span) -> Diagnostic {
        let help = match self {
            GpuError::NoAdapter(_) | GpuError::RequestDevice(_) => {
                Some("derive on the CPU (without `--gpu`, or with `--cpu-fallback`)")
            }
            GpuError::BufferTooLarge { .. }
            | GpuError::CountOverflow { .. }
            | GpuError::TooManyWorkgroups { .. } => Some(
                "derive fewer iterations, or on the CPU (without `--gpu`, or with `--cpu-fallback`)",
            ),
            GpuError::ModuleLimit { .. } => {
                Some("derive fewer iterations (`-n`), or raise the limit (`--max-modules`)")
            }
            GpuError::MemoryLimit { .. } => {
                Some("derive fewer iterations (`-n`), or raise the limit (`--max-memory`)")
            }
            GpuError::Unsupported(_) => Some("derive this system on the CPU (without `--gpu`)"),
            GpuError::Device(_) | GpuError::DeviceLost(_) | GpuError::Readback(_) => Some(
                "a problem of the GPU or its driver: try again, or derive on the CPU (`--cpu-fallback`)",
            ),
            GpuError::UnbalancedBrackets { .. }
            | GpuError::InvalidInput(_)
            | GpuError::Runtime {
                kind: RuntimeKind::Fault,
                ..
            } => Some(
                "this is an internal error of grm; please report it with the file that caused it",
            ),
            GpuError::Runtime { .. } => None,
        };
        let d = Diagnostic::new(
            self.code(),
            format!("GPU: {self}"),
            file,
            span,
            "while deriving this system on the GPU",
        );
        match help {
            Some(h) => d.with_help(h),
            None => d,
        }
    }
}

impl fmt::Display for GpuError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            GpuError::NoAdapter(m) => write!(
                f,
                "no GPU adapter found ({m}); without a GPU install Mesa's software Vulkan driver: \
                 apt-get install mesa-vulkan-drivers libvulkan1"
            ),
            GpuError::RequestDevice(m) => write!(f, "could not create the GPU device: {m}"),
            GpuError::BufferTooLarge {
                what,
                bytes,
                limit,
                limit_name,
            } => write!(
                f,
                "the {what} buffer would need {bytes} bytes, over the device's {limit_name} of \
                 {limit} bytes; derive fewer iterations or use the CPU engine"
            ),
            // The kernels' counts saturate at u32::MAX: such a count is a
            // lower bound.
            GpuError::CountOverflow { what, count } if *count >= SATURATED => write!(
                f,
                "{what} (more than {}) do not fit 32-bit GPU indices; derive fewer iterations or use the CPU engine",
                SATURATED - 1
            ),
            GpuError::CountOverflow { what, count } => write!(
                f,
                "{what} ({count}) do not fit 32-bit GPU indices; derive fewer iterations or use the CPU engine"
            ),
            GpuError::TooManyWorkgroups {
                what,
                workgroups,
                limit,
            } => write!(
                f,
                "the {what} dispatch needs {workgroups} workgroups, over the device's limit of {limit}"
            ),
            GpuError::UnbalancedBrackets { position: Some(p) } => write!(
                f,
                "unbalanced brackets: the system starting at module {p} does not start at depth 0"
            ),
            GpuError::UnbalancedBrackets { position: None } => {
                write!(f, "unbalanced brackets: a `]` closes no `[`")
            }
            GpuError::ModuleLimit {
                iteration,
                modules,
                limit,
            } if *modules >= SATURATED => write!(
                f,
                "iteration {iteration} would produce more than {} modules, over the limit of {limit}",
                SATURATED - 1
            ),
            GpuError::ModuleLimit {
                iteration,
                modules,
                limit,
            } => write!(
                f,
                "iteration {iteration} would produce {modules} modules, over the limit of {limit}"
            ),
            GpuError::MemoryLimit {
                iteration,
                bytes,
                limit,
            } => write!(
                f,
                "iteration {iteration} would need {} of GPU memory, over the limit of {}",
                grm_diag::mib(*bytes),
                grm_diag::mib(*limit)
            ),
            GpuError::Runtime {
                iteration,
                position,
                symbol,
                kind,
                ..
            } => {
                let what = match kind {
                    RuntimeKind::NonFinite => "a parameter is not finite",
                    RuntimeKind::BadWeight => "a weight is not a positive finite number",
                    RuntimeKind::Fault => "the bytecode faulted",
                };
                write!(f, "iteration {iteration}, module {position}")?;
                if !symbol.is_empty() {
                    write!(f, " (`{symbol}`)")?;
                }
                write!(f, ": {what}")
            }
            GpuError::Unsupported(m) => write!(f, "not supported on the GPU engine: {m}"),
            GpuError::InvalidInput(m) => write!(f, "invalid input: {m}"),
            GpuError::Device(m) => write!(f, "GPU error: {m}"),
            GpuError::DeviceLost(m) => write!(f, "GPU device lost: {m}"),
            GpuError::Readback(m) => write!(f, "reading GPU results back failed: {m}"),
        }
    }
}

impl std::error::Error for GpuError {}

//! Every compute kernel: file, entry point, bindings. [`ALL`] lists them
//! for the naga validation test.

use crate::shader::{Bind, Kernel};

/// `PARAM_SPACE` of `derive.wgsl`, `scan.wgsl` and `directory.wgsl`:
/// parameters in a uniform buffer the host wrote ...
const HOST_PARAMS: (&str, &str) = ("PARAM_SPACE", "uniform");
/// ... or in a storage buffer a kernel wrote (`batch_next`: batched
/// derivations read their parameters where the device computed them, with
/// no copy between iterations). The `_DEV` kernels are these variants.
const DEVICE_PARAMS: (&str, &str) = ("PARAM_SPACE", "storage, read");

/// `OFFSETS` of `derive.wgsl` and `directory.wgsl`: output offsets read
/// from fully scanned counts (the per-iteration path) ...
const GLOBAL_OFFSETS: (&str, &str) = ("OFFSETS", "offsets_global.wgsl");
/// ... or from block-local offsets and block sums (`count_scan`, the
/// batched kernels), with `block_sums` at the kernel's binding 14.
const BLOCK_OFFSETS: (&str, &str) = ("OFFSETS", "offsets_blocks.wgsl");
/// The scan operator's element in the kernels that include
/// `offsets_blocks.wgsl` (saturating sums of pairs).
const PAIRS: (&str, &str) = ("ELEM", "vec2<u32>");

/// `VM_RUN` of `vm.wgsl`: the bytecode interpreter, in every kernel that
/// evaluates code ...
const VM: (&str, &str) = ("VM_RUN", "vm_run.wgsl");
/// ... or none, in the `_PLAIN` derive kernels the host picks for programs
/// whose tables hold no code (every weight, condition and successor
/// parameter a constant or a copy; [`DeriveKernels::pick`]). Leaving
/// the interpreter's loop out of the count and rewrite kernels took the
/// stochastic plant's GPU steps at 8 iterations from 84 to 26-31 ms on
/// lavapipe (docs/benchmarks.md, session 5): fewer registers, no
/// dynamically indexed stack.
const NO_VM: (&str, &str) = ("VM_RUN", "vm_run_none.wgsl");

const SCAN_BINDS: &[Bind] = &[Bind::Uniform, Bind::ReadWrite, Bind::ReadWrite];

pub static SCAN_U32: Kernel = Kernel {
    name: "scan_blocks_u32",
    file: "scan.wgsl",
    entry: "scan_blocks",
    bindings: SCAN_BINDS,
    subst: &[("ELEM", "u32"), ("SCAN_OP", "scan_add.wgsl"), HOST_PARAMS],
};
pub static ADD_U32: Kernel = Kernel {
    name: "add_sums_u32",
    file: "scan.wgsl",
    entry: "add_sums",
    bindings: SCAN_BINDS,
    subst: &[("ELEM", "u32"), ("SCAN_OP", "scan_add.wgsl"), HOST_PARAMS],
};
pub static SCAN_U32X2: Kernel = Kernel {
    name: "scan_blocks_u32x2",
    file: "scan.wgsl",
    entry: "scan_blocks",
    bindings: SCAN_BINDS,
    subst: &[
        ("ELEM", "vec2<u32>"),
        ("SCAN_OP", "scan_add.wgsl"),
        HOST_PARAMS,
    ],
};
pub static ADD_U32X2: Kernel = Kernel {
    name: "add_sums_u32x2",
    file: "scan.wgsl",
    entry: "add_sums",
    bindings: SCAN_BINDS,
    subst: &[
        ("ELEM", "vec2<u32>"),
        ("SCAN_OP", "scan_add.wgsl"),
        HOST_PARAMS,
    ],
};

const SCAN_DEV_BINDS: &[Bind] = &[Bind::Read, Bind::ReadWrite, Bind::ReadWrite];

/// [`SCAN_U32X2`] with its parameters written on the device.
pub static SCAN_U32X2_DEV: Kernel = Kernel {
    name: "scan_blocks_u32x2_dev",
    file: "scan.wgsl",
    entry: "scan_blocks",
    bindings: SCAN_DEV_BINDS,
    subst: &[
        ("ELEM", "vec2<u32>"),
        ("SCAN_OP", "scan_add.wgsl"),
        DEVICE_PARAMS,
    ],
};
/// [`ADD_U32X2`] with its parameters written on the device.
pub static ADD_U32X2_DEV: Kernel = Kernel {
    name: "add_sums_u32x2_dev",
    file: "scan.wgsl",
    entry: "add_sums",
    bindings: SCAN_DEV_BINDS,
    subst: &[
        ("ELEM", "vec2<u32>"),
        ("SCAN_OP", "scan_add.wgsl"),
        DEVICE_PARAMS,
    ],
};

pub static VM_EVAL: Kernel = Kernel {
    name: "vm_eval",
    file: "vm_eval.wgsl",
    entry: "vm_eval",
    bindings: &[Bind::Read, Bind::Read, Bind::Read, Bind::ReadWrite],
    subst: &[VM],
};

/// A kernel's bindings in the usual order: its parameters (`params`), then
/// `reads` read-only buffers, then read-write ones up to `N`.
const fn binds<const N: usize>(params: Bind, reads: usize) -> [Bind; N] {
    let mut b = [Bind::ReadWrite; N];
    b[0] = params;
    let mut i = 1;
    while i <= reads {
        b[i] = Bind::Read;
        i += 1;
    }
    b
}

/// The bindings of derive.wgsl: the parameters (`params`: a uniform the
/// host wrote, or storage `batch_next` wrote), five read-only buffers
/// (tables, the input string, bracket partners), six read-write ones
/// (counts, choices, the output string, status), then the input's identity
/// keys (read) and the output's (read-write); `N` = 15 adds the batched
/// kernels' block sums (offsets_blocks.wgsl).
const fn derive_binds<const N: usize>(params: Bind) -> [Bind; N] {
    let mut b = binds::<N>(params, 5);
    b[12] = Bind::Read;
    b
}

const DERIVE_BINDS: &[Bind] = &derive_binds::<14>(Bind::Uniform);

/// `CONTEXT_MATCH` of `derive.wgsl`: the bracket-aware context matching,
/// in the kernels that context-sensitive systems use ...
const CTX: (&str, &str) = ("CONTEXT_MATCH", "contexts.wgsl");
/// ... or none, in the kernels only context-free systems use: the
/// output-parallel and batched rewrites (never picked with contexts) and
/// the `_free` count builds. Without the matching loops the stochastic
/// plant's GPU steps took a further 1.4x less time on lavapipe.
const NO_CTX: (&str, &str) = ("CONTEXT_MATCH", "contexts_none.wgsl");

/// A derive kernel: `derive_kernel!(NAME, "name", file, entry, bindings,
/// [substitutions])`.
macro_rules! derive_kernel {
    ($(#[$doc:meta])* $name:ident, $label:literal, $file:literal, $entry:literal, $binds:expr, [$($s:expr),*]) => {
        $(#[$doc])*
        pub static $name: Kernel = Kernel {
            name: $label,
            file: $file,
            entry: $entry,
            bindings: $binds,
            subst: &[$($s),*],
        };
    };
}

derive_kernel!(
    /// Each module's production and output size (one thread per input
    /// module), with the interpreter and context matching.
    COUNT,
    "count",
    "derive.wgsl",
    "count",
    DERIVE_BINDS,
    [HOST_PARAMS, GLOBAL_OFFSETS, VM, CTX]
);
derive_kernel!(
    /// [`COUNT`] without the interpreter.
    COUNT_PLAIN,
    "count_plain",
    "derive.wgsl",
    "count",
    DERIVE_BINDS,
    [HOST_PARAMS, GLOBAL_OFFSETS, NO_VM, CTX]
);
derive_kernel!(
    /// [`COUNT`] without context matching.
    COUNT_FREE,
    "count_free",
    "derive.wgsl",
    "count",
    DERIVE_BINDS,
    [HOST_PARAMS, GLOBAL_OFFSETS, VM, NO_CTX]
);
derive_kernel!(
    /// [`COUNT`] without the interpreter or context matching.
    COUNT_PLAIN_FREE,
    "count_plain_free",
    "derive.wgsl",
    "count",
    DERIVE_BINDS,
    [HOST_PARAMS, GLOBAL_OFFSETS, NO_VM, NO_CTX]
);
derive_kernel!(
    /// The rewrite by input module: context-sensitive systems, and every
    /// system's axiom.
    REWRITE,
    "rewrite",
    "derive.wgsl",
    "rewrite",
    DERIVE_BINDS,
    [HOST_PARAMS, GLOBAL_OFFSETS, VM, CTX]
);
derive_kernel!(
    /// [`REWRITE`] without the interpreter.
    REWRITE_PLAIN,
    "rewrite_plain",
    "derive.wgsl",
    "rewrite",
    DERIVE_BINDS,
    [HOST_PARAMS, GLOBAL_OFFSETS, NO_VM, CTX]
);
derive_kernel!(
    /// The rewrite by output module (context-free systems).
    REWRITE_OUT,
    "rewrite_out",
    "derive.wgsl",
    "rewrite_out",
    DERIVE_BINDS,
    [HOST_PARAMS, GLOBAL_OFFSETS, VM, NO_CTX]
);
derive_kernel!(
    /// [`REWRITE_OUT`] without the interpreter.
    REWRITE_OUT_PLAIN,
    "rewrite_out_plain",
    "derive.wgsl",
    "rewrite_out",
    DERIVE_BINDS,
    [HOST_PARAMS, GLOBAL_OFFSETS, NO_VM, NO_CTX]
);

derive_kernel!(
    /// [`REWRITE_OUT`] with context matching: context-sensitive systems
    /// whose successors are too long for one thread to write
    /// ([`LONG_SUCCESSOR`]).
    REWRITE_OUT_CTX,
    "rewrite_out_ctx",
    "derive.wgsl",
    "rewrite_out",
    DERIVE_BINDS,
    [HOST_PARAMS, GLOBAL_OFFSETS, VM, CTX]
);
derive_kernel!(
    /// [`REWRITE_OUT_CTX`] without the interpreter.
    REWRITE_OUT_CTX_PLAIN,
    "rewrite_out_ctx_plain",
    "derive.wgsl",
    "rewrite_out",
    DERIVE_BINDS,
    [HOST_PARAMS, GLOBAL_OFFSETS, NO_VM, CTX]
);

/// Successors longer than this (in modules) are not written by one thread
/// (`rewrite`): a context-sensitive system with one is rewritten by output
/// module (`rewrite_out` with context matching). Besides spreading the
/// work, this keeps each invocation's loops short: Mesa's lavapipe stops
/// an invocation's loops after 65,535 iterations in all, and a thread
/// writing a successor of about 1,500 one-parameter modules ran past that.
pub const LONG_SUCCESSOR: u32 = 64;

const DERIVE_DEV_BINDS: &[Bind] = &derive_binds::<15>(Bind::Read);
/// The batched derive kernels (parameters from the device, offsets from
/// block sums at binding 14; no contexts: batched derivations are
/// context-free).
const BLOCK_SUMS_14: (&str, &str) = ("BLOCK_SUMS_BINDING", "14");

derive_kernel!(
    /// The batched derivation's count and first scan level in one dispatch
    /// (`count_scan.wgsl`), parameters written on the device.
    COUNT_SCAN_DEV,
    "count_scan_dev",
    "count_scan.wgsl",
    "count_scan",
    DERIVE_DEV_BINDS,
    [DEVICE_PARAMS, BLOCK_OFFSETS, BLOCK_SUMS_14, PAIRS, VM, NO_CTX]
);
derive_kernel!(
    /// [`COUNT_SCAN_DEV`] without the interpreter.
    COUNT_SCAN_DEV_PLAIN,
    "count_scan_dev_plain",
    "count_scan.wgsl",
    "count_scan",
    DERIVE_DEV_BINDS,
    [DEVICE_PARAMS, BLOCK_OFFSETS, BLOCK_SUMS_14, PAIRS, NO_VM, NO_CTX]
);
derive_kernel!(
    /// [`REWRITE_OUT`] with its parameters written on the device and its
    /// offsets from [`COUNT_SCAN_DEV`]'s blocks (batched).
    REWRITE_OUT_DEV,
    "rewrite_out_dev",
    "derive.wgsl",
    "rewrite_out",
    DERIVE_DEV_BINDS,
    [DEVICE_PARAMS, BLOCK_OFFSETS, BLOCK_SUMS_14, PAIRS, VM, NO_CTX]
);
derive_kernel!(
    /// [`REWRITE_OUT_DEV`] without the interpreter.
    REWRITE_OUT_DEV_PLAIN,
    "rewrite_out_dev_plain",
    "derive.wgsl",
    "rewrite_out",
    DERIVE_DEV_BINDS,
    [DEVICE_PARAMS, BLOCK_OFFSETS, BLOCK_SUMS_14, PAIRS, NO_VM, NO_CTX]
);

/// The kernels of one derivation that evaluate the tables' code and match
/// contexts: with the interpreter or without it (programs with no code),
/// with context matching or without it (context-free systems, whose
/// rewrites are the output-parallel ones).
#[derive(Debug)]
pub struct DeriveKernels {
    pub count: &'static Kernel,
    /// By input module: context-sensitive systems and the axiom.
    pub rewrite: &'static Kernel,
    /// By output module: context-free systems, and context-sensitive ones
    /// with long successors.
    pub rewrite_out: &'static Kernel,
    pub count_scan_dev: &'static Kernel,
    pub rewrite_out_dev: &'static Kernel,
}

/// Code and contexts.
pub static DERIVE_WITH_VM: DeriveKernels = DeriveKernels {
    count: &COUNT,
    rewrite: &REWRITE,
    rewrite_out: &REWRITE_OUT_CTX,
    count_scan_dev: &COUNT_SCAN_DEV,
    rewrite_out_dev: &REWRITE_OUT_DEV,
};
/// Contexts, no code (`vm_run` faults in these).
pub static DERIVE_PLAIN: DeriveKernels = DeriveKernels {
    count: &COUNT_PLAIN,
    rewrite: &REWRITE_PLAIN,
    rewrite_out: &REWRITE_OUT_CTX_PLAIN,
    count_scan_dev: &COUNT_SCAN_DEV_PLAIN,
    rewrite_out_dev: &REWRITE_OUT_DEV_PLAIN,
};
/// Code, no contexts (`match_contexts` faults in the count).
pub static DERIVE_FREE: DeriveKernels = DeriveKernels {
    count: &COUNT_FREE,
    rewrite_out: &REWRITE_OUT,
    ..DERIVE_WITH_VM
};
/// Neither.
pub static DERIVE_PLAIN_FREE: DeriveKernels = DeriveKernels {
    count: &COUNT_PLAIN_FREE,
    rewrite_out: &REWRITE_OUT_PLAIN,
    ..DERIVE_PLAIN
};

impl DeriveKernels {
    /// The set for systems whose packed tables have code (`has_code`) or
    /// not, and groups with contexts (`has_context`) or not.
    pub fn pick(has_code: bool, has_context: bool) -> &'static DeriveKernels {
        match (has_code, has_context) {
            (true, true) => &DERIVE_WITH_VM,
            (false, true) => &DERIVE_PLAIN,
            (true, false) => &DERIVE_FREE,
            (false, false) => &DERIVE_PLAIN_FREE,
        }
    }

    /// Whether these kernels carry the bytecode interpreter.
    pub fn interprets_code(&self) -> bool {
        self.count.subst.contains(&VM)
    }

    /// Whether the count matches contexts.
    pub fn matches_contexts(&self) -> bool {
        self.count.subst.contains(&CTX)
    }
}

const BRACKET_BINDS: &[Bind] = &binds::<6>(Bind::Uniform, 2);

pub static BRACKET_FLAGS: Kernel = Kernel {
    name: "bracket_flags",
    file: "brackets.wgsl",
    entry: "bracket_flags",
    bindings: BRACKET_BINDS,
    subst: &[],
};
pub static BRACKET_DEPTH: Kernel = Kernel {
    name: "bracket_depth",
    file: "brackets.wgsl",
    entry: "bracket_depth",
    bindings: BRACKET_BINDS,
    subst: &[],
};
pub static BRACKET_REDUCE: Kernel = Kernel {
    name: "bracket_reduce",
    file: "brackets.wgsl",
    entry: "bracket_reduce",
    bindings: BRACKET_BINDS,
    subst: &[],
};
pub static BRACKET_MATCH: Kernel = Kernel {
    name: "bracket_match",
    file: "brackets.wgsl",
    entry: "bracket_match",
    bindings: BRACKET_BINDS,
    subst: &[],
};

pub static SCAN_TURTLE: Kernel = Kernel {
    name: "scan_blocks_turtle",
    file: "scan.wgsl",
    entry: "scan_blocks",
    bindings: SCAN_BINDS,
    subst: &[
        ("ELEM", "TurtleElem"),
        ("SCAN_OP", "turtle_scan.wgsl"),
        HOST_PARAMS,
    ],
};
pub static ADD_TURTLE: Kernel = Kernel {
    name: "add_sums_turtle",
    file: "scan.wgsl",
    entry: "add_sums",
    bindings: SCAN_BINDS,
    subst: &[
        ("ELEM", "TurtleElem"),
        ("SCAN_OP", "turtle_scan.wgsl"),
        HOST_PARAMS,
    ],
};

/// turtle.wgsl: parameters, the string and its turtle tables and depths
/// (read), then the sort, states, bones and bracket counts (read-write).
const TURTLE_BINDS: &[Bind] = &binds::<13>(Bind::Uniform, 5);

macro_rules! turtle_kernels {
    ($($name:ident = $entry:literal),* $(,)?) => {
        $(
            pub static $name: Kernel = Kernel {
                name: $entry,
                file: "turtle.wgsl",
                entry: $entry,
                bindings: TURTLE_BINDS,
                // wg_scan.wgsl's element: turtle transforms.
                subst: &[("ELEM", "TurtleElem")],
            };
        )*
    };
}

turtle_kernels! {
    DEPTH_HIST = "depth_hist",
    DEPTH_SCATTER = "depth_scatter",
    DEPTH_STARTS = "depth_starts",
    TURTLE_WALK = "turtle_walk",
    BONE_FLAGS = "bone_flags",
    BONES_WRITE = "bones_write",
    TURTLE_ELEMS = "turtle_elems",
    TURTLE_ROUND = "turtle_round",
    FUSED_REDUCE = "fused_reduce",
    FUSED_ROUND = "fused_round",
    STRAIGHT_BONES = "straight_bones",
}

pub static UPDATE_DIRECTORY: Kernel = Kernel {
    name: "update_directory",
    file: "directory.wgsl",
    entry: "update_directory",
    bindings: &[Bind::Uniform, Bind::ReadWrite, Bind::Read],
    subst: &[HOST_PARAMS, GLOBAL_OFFSETS],
};
/// [`UPDATE_DIRECTORY`] with its parameters written on the device.
pub static UPDATE_DIRECTORY_DEV: Kernel = Kernel {
    name: "update_directory_dev",
    file: "directory.wgsl",
    entry: "update_directory",
    bindings: &[Bind::Read, Bind::ReadWrite, Bind::Read, Bind::ReadWrite],
    subst: &[
        DEVICE_PARAMS,
        BLOCK_OFFSETS,
        ("BLOCK_SUMS_BINDING", "3"),
        PAIRS,
    ],
};

pub static BATCH_NEXT: Kernel = Kernel {
    name: "batch_next",
    file: "batch.wgsl",
    entry: "batch_next",
    bindings: &[
        Bind::Uniform,
        Bind::Read,
        Bind::Read,
        Bind::Read,
        Bind::ReadWrite,
        Bind::ReadWrite,
        Bind::ReadWrite,
        Bind::ReadWrite,
        Bind::ReadWrite,
    ],
    subst: &[("BLOCK_SUMS_BINDING", "8"), PAIRS],
};

const EXPAND_BINDS: [Bind; 10] = binds::<10>(Bind::Uniform, 6);

/// [`EXPAND_BINDS`], then (read, read-write) pairs from binding 10: `N` =
/// 12 the identity keys (axiom modules', output's); 14 the packed tables
/// and the status, then the keys.
const fn expand_binds<const N: usize>() -> [Bind; N] {
    let mut b = [Bind::ReadWrite; N];
    let mut i = 0;
    while i < 10 {
        b[i] = EXPAND_BINDS[i];
        i += 1;
    }
    while i < N {
        b[i] = Bind::Read;
        i += 2;
    }
    b
}

/// The direct derivation (`expand.wgsl`): the final string of
/// deterministic, context-free systems in one pass, where every successor
/// parameter is a constant; the identity keys at bindings 10 and 11.
pub static EXPAND: Kernel = Kernel {
    name: "expand",
    file: "expand.wgsl",
    entry: "expand",
    bindings: &expand_binds::<12>(),
    subst: &[("EXPAND_PARAMS", "expand_const.wgsl")],
};

/// [`EXPAND`] where some successor parameters are computed: the chain of
/// computed parameters is evaluated with the bytecode interpreter, which
/// reads the systems' packed tables (binding 10); errors in binding 11;
/// the identity keys at 12 and 13.
pub static EXPAND_VM: Kernel = Kernel {
    name: "expand_vm",
    file: "expand.wgsl",
    entry: "expand",
    bindings: &expand_binds::<14>(),
    subst: &[("EXPAND_PARAMS", "expand_vm.wgsl"), VM],
};

const EXPAND_TURTLE_BINDS: &[Bind] = &binds::<9>(Bind::Uniform, 6);

/// The direct interpretation's tables (`expand_turtle.wgsl`, one
/// workgroup): every expansion's and slot prefix's turtle transform.
pub static EXPAND_NETS: Kernel = Kernel {
    name: "expand_nets",
    file: "expand_turtle.wgsl",
    entry: "expand_nets",
    bindings: EXPAND_TURTLE_BINDS,
    subst: &[("ELEM", "TurtleElem")],
};

/// The direct interpretation's bones, one thread each.
pub static EXPAND_BONES: Kernel = Kernel {
    name: "expand_bones",
    file: "expand_turtle.wgsl",
    entry: "expand_bones",
    bindings: EXPAND_TURTLE_BINDS,
    subst: &[("ELEM", "TurtleElem")],
};

/// All kernels.
pub static ALL: &[&Kernel] = &[
    &SCAN_U32,
    &ADD_U32,
    &SCAN_U32X2,
    &ADD_U32X2,
    &SCAN_U32X2_DEV,
    &ADD_U32X2_DEV,
    &VM_EVAL,
    &COUNT,
    &REWRITE,
    &REWRITE_OUT,
    &COUNT_SCAN_DEV,
    &REWRITE_OUT_DEV,
    &COUNT_PLAIN,
    &COUNT_FREE,
    &COUNT_PLAIN_FREE,
    &REWRITE_PLAIN,
    &REWRITE_OUT_PLAIN,
    &REWRITE_OUT_CTX,
    &REWRITE_OUT_CTX_PLAIN,
    &COUNT_SCAN_DEV_PLAIN,
    &REWRITE_OUT_DEV_PLAIN,
    &BRACKET_FLAGS,
    &BRACKET_DEPTH,
    &BRACKET_REDUCE,
    &BRACKET_MATCH,
    &SCAN_TURTLE,
    &ADD_TURTLE,
    &DEPTH_HIST,
    &DEPTH_SCATTER,
    &DEPTH_STARTS,
    &TURTLE_ELEMS,
    &TURTLE_ROUND,
    &FUSED_ROUND,
    &TURTLE_WALK,
    &BONE_FLAGS,
    &BONES_WRITE,
    &FUSED_REDUCE,
    &STRAIGHT_BONES,
    &UPDATE_DIRECTORY,
    &UPDATE_DIRECTORY_DEV,
    &BATCH_NEXT,
    &EXPAND,
    &EXPAND_VM,
    &EXPAND_NETS,
    &EXPAND_BONES,
];

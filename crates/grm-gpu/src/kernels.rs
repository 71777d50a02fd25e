//! Every compute kernel: file, entry point, bindings. [`ALL`] lists them
//! for the naga validation test.

use crate::shader::{Bind, Kernel};

const SCAN_BINDS: &[Bind] = &[Bind::Uniform, Bind::ReadWrite, Bind::ReadWrite];

pub static SCAN_U32: Kernel = Kernel {
    name: "scan_blocks_u32",
    file: "scan.wgsl",
    entry: "scan_blocks",
    bindings: SCAN_BINDS,
    subst: &[("ELEM", "u32")],
};
pub static ADD_U32: Kernel = Kernel {
    name: "add_sums_u32",
    file: "scan.wgsl",
    entry: "add_sums",
    bindings: SCAN_BINDS,
    subst: &[("ELEM", "u32")],
};
pub static SCAN_U32X2: Kernel = Kernel {
    name: "scan_blocks_u32x2",
    file: "scan.wgsl",
    entry: "scan_blocks",
    bindings: SCAN_BINDS,
    subst: &[("ELEM", "vec2<u32>")],
};
pub static ADD_U32X2: Kernel = Kernel {
    name: "add_sums_u32x2",
    file: "scan.wgsl",
    entry: "add_sums",
    bindings: SCAN_BINDS,
    subst: &[("ELEM", "vec2<u32>")],
};

pub static VM_EVAL: Kernel = Kernel {
    name: "vm_eval",
    file: "vm_eval.wgsl",
    entry: "vm_eval",
    bindings: &[Bind::Read, Bind::Read, Bind::Read, Bind::ReadWrite],
    subst: &[],
};

/// All kernels.
pub static ALL: &[&Kernel] = &[&SCAN_U32, &ADD_U32, &SCAN_U32X2, &ADD_U32X2, &VM_EVAL];

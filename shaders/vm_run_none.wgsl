// vm.wgsl's `vm_run` for the kernels compiled for programs without code
// (grm-gpu's kernels.rs, the `_PLAIN` derive kernels): the host picks them
// only when every system's packed tables have an empty code section, so
// no weight, condition or successor parameter refers to code and nothing
// calls this. Were it reached, the run faults: the engine's error path,
// never a silent value. Without the interpreter's loop the kernels need
// far fewer registers and no dynamically indexed stack.
fn vm_run(entry: u32, d: Draws) -> u32 {
    return VM_FAULT;
}

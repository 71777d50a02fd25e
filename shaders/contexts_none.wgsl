// derive.wgsl's `match_contexts` for the context-free kernels (grm-gpu's
// kernels.rs): the host picks them only for systems none of whose groups
// has a context, so nothing calls this. Were it reached, the module is
// reported as a fault (the engine's error path), never matched silently.
// Without the matching loops the count and rewrite kernels are smaller.
fn match_contexts(i: u32, g: GroupHeader) -> bool {
    report(0u, i, ERR_FAULT);
    return false;
}

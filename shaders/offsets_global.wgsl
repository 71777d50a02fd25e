// Output offsets where `counts` holds them in full: the per-iteration
// path scans the counts completely (and the axiom's offsets are the
// host's). The batched kernels read offsets_blocks.wgsl's instead.

fn out_offset(i: u32) -> vec2<u32> {
    return counts[i];
}

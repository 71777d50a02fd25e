// Output offsets where `counts` holds each module's offset within its
// block of WORKGROUP modules (the batched derivation's fused
// `count_scan`, count_scan.wgsl) and `block_sums` the blocks' totals,
// scanned (exclusive) by the scan levels above once there are several
// blocks. The offset of module i is its block's offset combined with its
// own; block 0's offset is zero (with a single block, `block_sums[0]` is
// its total and is never read). Saturating, as the scan is: an
// overflowing count shows as 0xffffffff. Needs ELEM = vec2<u32> for
// scan_add.wgsl; BLOCK_SUMS_BINDING is the including kernel's binding.
//!include scan_add.wgsl

@group(0) @binding(BLOCK_SUMS_BINDING) var<storage, read_write> block_sums: array<vec2<u32>>;

fn out_offset(i: u32) -> vec2<u32> {
    let b = i / WORKGROUP;
    if (b == 0u) {
        return counts[i];
    }
    return scan_combine(block_sums[b], counts[i]);
}

// The batched derivation's count and first scan level in one dispatch:
// each workgroup decides the productions of WORKGROUP consecutive input
// modules (one per thread, as `count` does), scans their output sizes
// within the block and writes each module's offset within its block to
// `counts`, and the block's total to `block_sums` (scanned by the levels
// above, SCAN_BLOCK per block; offsets_blocks.wgsl combines the two). One pass
// over the counts and one dispatch fewer per iteration than `count` then
// `scan_blocks`, and no `add_sums` at level 0.
//!include derive.wgsl
//!include wg_scan.wgsl

@compute @workgroup_size(WORKGROUP)
fn count_scan(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    // Elements 0 ..= P.n: the modules, then the slot after the last
    // (size zero) where the totals end up. One per thread: the decisions
    // run as parallel as in `count`.
    let block = wg_linear(wid, nwg);
    if (block * WORKGROUP > P.n) {
        return;
    }
    let i = block * WORKGROUP + lid;
    var c = scan_identity();
    if (i < P.n) {
        c = count_one(i);
    }
    let excl = wg_scan_exclusive(lid, c);
    if (i <= P.n) {
        counts[i] = excl;
    }
    if (lid == WORKGROUP - 1u) {
        block_sums[block] = wg_scan_total();
    }
}

// Prefix scan of ELEM values under an associative operator: the host
// instantiates it with an operator file SCAN_OP that defines ELEM's
// `scan_identity()`, `scan_combine(earlier, later)` and SCAN_INCLUSIVE
// (scan_add.wgsl: exclusive saturating sums of u32 and vec2<u32>;
// turtle.wgsl's segmented scan of turtle transforms).
//
// Block scan + recursion over block sums: `scan_blocks` scans each block
// of SCAN_BLOCK elements in place (each thread scans SCAN_PER_THREAD
// consecutive elements serially, then the workgroup scans the per-thread
// sums in shared memory) and writes the block's total to `sums`; the host
// scans `sums` the same way (recursively, until one block is left), then
// `add_sums` combines each block's scanned offset with its elements. No
// atomics.
//!include grid.wgsl
//!include SCAN_OP
//!include wg_scan.wgsl

// PARAM_SPACE: `uniform` (parameters from the host) or `storage, read`
// (written on the device by `batch_next`).
@group(0) @binding(0) var<PARAM_SPACE> P: ScanParams;
@group(0) @binding(1) var<storage, read_write> data: array<ELEM>;
@group(0) @binding(2) var<storage, read_write> sums: array<ELEM>;

@compute @workgroup_size(WORKGROUP)
fn scan_blocks(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let block = wg_linear(wid, nwg);
    if (block >= P.blocks) {
        return;
    }
    let base = block * SCAN_BLOCK + lid * SCAN_PER_THREAD;
    var v: array<ELEM, SCAN_PER_THREAD>;
    var s = scan_identity();
    for (var i = 0u; i < SCAN_PER_THREAD; i = i + 1u) {
        var x = scan_identity();
        if (base + i < P.n) {
            x = data[base + i];
        }
        if (SCAN_INCLUSIVE) {
            s = scan_combine(s, x);
            v[i] = s;
        } else {
            v[i] = s;
            s = scan_combine(s, x);
        }
    }
    let excl = wg_scan_exclusive(lid, s);
    for (var i = 0u; i < SCAN_PER_THREAD; i = i + 1u) {
        if (base + i < P.n) {
            data[base + i] = scan_combine(excl, v[i]);
        }
    }
    if (lid == WORKGROUP - 1u) {
        sums[block] = wg_scan_total();
    }
}

@compute @workgroup_size(WORKGROUP)
fn add_sums(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let block = wg_linear(wid, nwg);
    if (block >= P.blocks || block == 0u) {
        return;
    }
    // The block sums were scanned the same way: exclusively (the offset of
    // this block is its own entry) or inclusively (the previous entry).
    var add = sums[block];
    if (SCAN_INCLUSIVE) {
        add = sums[block - 1u];
    }
    let base = block * SCAN_BLOCK + lid * SCAN_PER_THREAD;
    for (var i = 0u; i < SCAN_PER_THREAD; i = i + 1u) {
        if (base + i < P.n) {
            data[base + i] = scan_combine(add, data[base + i]);
        }
    }
}

// Exclusive prefix sum (scan), saturating at 0xffffffff, of ELEM values
// (the host instantiates ELEM as u32 and as vec2<u32>).
//
// Block scan + recursion over block sums: `scan_blocks` scans each block
// of SCAN_BLOCK elements in place (each thread scans SCAN_PER_THREAD
// consecutive elements serially, then the workgroup scans the per-thread
// sums in shared memory) and writes the block's total to `sums`; the host
// scans `sums` the same way (recursively, until one block is left), then
// `add_sums` adds each block's scanned offset to its elements. No atomics.
// Saturation makes an overflowing total visible to the host as 0xffffffff
// in every component that overflowed, instead of wrapping.
//!include grid.wgsl

@group(0) @binding(0) var<uniform> P: ScanParams;
@group(0) @binding(1) var<storage, read_write> data: array<ELEM>;
@group(0) @binding(2) var<storage, read_write> sums: array<ELEM>;

var<workgroup> tmp: array<ELEM, WORKGROUP>;

fn sat_add(a: ELEM, b: ELEM) -> ELEM {
    let s = a + b;
    return select(s, ELEM(0xffffffffu), s < a);
}

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
    var s = ELEM(0u);
    for (var i = 0u; i < SCAN_PER_THREAD; i = i + 1u) {
        var x = ELEM(0u);
        if (base + i < P.n) {
            x = data[base + i];
        }
        v[i] = s;
        s = sat_add(s, x);
    }
    tmp[lid] = s;
    workgroupBarrier();
    for (var off = 1u; off < WORKGROUP; off = off << 1u) {
        var t = ELEM(0u);
        if (lid >= off) {
            t = tmp[lid - off];
        }
        workgroupBarrier();
        tmp[lid] = sat_add(tmp[lid], t);
        workgroupBarrier();
    }
    var excl = ELEM(0u);
    if (lid > 0u) {
        excl = tmp[lid - 1u];
    }
    for (var i = 0u; i < SCAN_PER_THREAD; i = i + 1u) {
        if (base + i < P.n) {
            data[base + i] = sat_add(excl, v[i]);
        }
    }
    if (lid == WORKGROUP - 1u) {
        sums[block] = tmp[lid];
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
    let add = sums[block];
    let base = block * SCAN_BLOCK + lid * SCAN_PER_THREAD;
    for (var i = 0u; i < SCAN_PER_THREAD; i = i + 1u) {
        if (base + i < P.n) {
            data[base + i] = sat_add(add, data[base + i]);
        }
    }
}

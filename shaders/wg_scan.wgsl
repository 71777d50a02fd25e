// A workgroup's scan of one ELEM per thread under the SCAN_OP operator
// (`scan_identity`, `scan_combine`): the block step of scan.wgsl's
// `scan_blocks` and of derive.wgsl's fused `count_scan`. Every thread of
// the workgroup must call it, once per invocation (it synchronises the
// workgroup, and a second call could overwrite what another thread still
// reads of the first).

var<workgroup> wg_scan_tmp: array<ELEM, WORKGROUP>;

// The combination of the values of the threads before `lid` (the identity
// for thread 0); `wg_scan_total` is then the workgroup's total.
fn wg_scan_exclusive(lid: u32, x: ELEM) -> ELEM {
    wg_scan_tmp[lid] = x;
    workgroupBarrier();
    for (var off = 1u; off < WORKGROUP; off = off << 1u) {
        var t = scan_identity();
        if (lid >= off) {
            t = wg_scan_tmp[lid - off];
        }
        workgroupBarrier();
        wg_scan_tmp[lid] = scan_combine(t, wg_scan_tmp[lid]);
        workgroupBarrier();
    }
    var excl = scan_identity();
    if (lid > 0u) {
        excl = wg_scan_tmp[lid - 1u];
    }
    return excl;
}

fn wg_scan_total() -> ELEM {
    return wg_scan_tmp[WORKGROUP - 1u];
}

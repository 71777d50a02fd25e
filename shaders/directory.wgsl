// After each rewrite: every system's range in the new string, from the
// scanned output offsets (`out_offset`: each input module's output offset,
// the total at n): a range [start, end) of the input maps to
// [out_offset(start).x, out_offset(end).x).
//!include grid.wgsl

@group(0) @binding(0) var<PARAM_SPACE> P: DeriveParams;
@group(0) @binding(1) var<storage, read_write> tables: array<u32>;
@group(0) @binding(2) var<storage, read> counts: array<vec2<u32>>;
//!include OFFSETS
//!include generated_tables
//!include generated_directory_store

@compute @workgroup_size(WORKGROUP)
fn update_directory(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let s = wg_linear(wid, nwg) * WORKGROUP + lid;
    if (s >= P.systems) {
        return;
    }
    var e = load_SystemEntry(s * SYSTEM_ENTRY_WORDS);
    e.start = out_offset(e.start).x;
    e.end = out_offset(e.end).x;
    store_SystemEntry(s * SYSTEM_ENTRY_WORDS, e);
}

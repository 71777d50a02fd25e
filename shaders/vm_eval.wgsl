// Runs single expressions with the bytecode interpreter: used by the tests
// that compare the GPU VM with the CPU VM (grm_compile::vm), op by op.
//!include grid.wgsl

@group(0) @binding(0) var<storage, read> tables: array<u32>;
@group(0) @binding(1) var<storage, read> jobs: array<VmJob>;
@group(0) @binding(2) var<storage, read> binds: array<f32>;
@group(0) @binding(3) var<storage, read_write> results: array<VmResult>;
//!include generated_tables
//!include vm.wgsl

@compute @workgroup_size(WORKGROUP)
fn vm_eval(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = wg_linear(wid, nwg) * WORKGROUP + lid;
    if (i >= arrayLength(&jobs)) {
        return;
    }
    tab_select(0u);
    let j = jobs[i];
    for (var k = 0u; k < min(j.bind_len, MAX_BIND_WORDS); k = k + 1u) {
        vm_bind[k] = binds[j.bind_first + k];
    }
    let n = vm_run(j.entry, Draws(j.seed, j.iteration, j.position));
    results[i] = VmResult(n, vm_st[0], vm_st[1], vm_st[2]);
}

// Dispatch grids. The host splits a dispatch of more than
// max_compute_workgroups_per_dimension workgroups over a 2D grid; kernels
// linearise the workgroup id with this function and skip ids past the end.

fn wg_linear(wid: vec3<u32>, nwg: vec3<u32>) -> u32 {
    return wid.x + wid.y * nwg.x;
}

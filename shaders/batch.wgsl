// Batched derivation (src/derive.rs, `derive_batched`): every iteration is
// recorded into one submission, with buffers sized from an upper bound
// computed on the host. After an iteration's scan, `batch_next` (one
// thread) reads the string's totals and writes the next iteration's
// dispatch parameters on the device: the DeriveParams, each scan level's
// ScanParams and the indirect workgroup counts. The kernels read them
// where they are written (storage bindings, indirect arguments): no copy
// between iterations, so an iteration is its dispatches and nothing else.
// What the rest of the current iteration still reads is not overwritten:
// the DeriveParams and the indirect arguments are double-buffered by
// iteration parity (`dp_in` is this iteration's, `dp_out` and `args` the
// next one's); the scan parameters are read before `batch_next` runs. It
// also keeps every string's totals (the history) and raises an overflow
// flag when a total is over its buffer's capacity; from then on every
// dispatch is empty (the host re-runs the derivation iteration by
// iteration).
//
// `args` layout, three words (x, y, 1) per dispatch: 0: rewrite (n + 1
// threads), 1 + l: scan level l (level 0: `count_scan`, which counts and
// scans each block of WORKGROUP modules), 1 + levels + l: add level l
// (level 0 is never added: the kernels combine block sums themselves).
// `sp`: level l's ScanParams at element l * B.sp_stride (a binding offset
// must be aligned, so each level's record starts on its own boundary).

@group(0) @binding(0) var<uniform> B: BatchParams;
@group(0) @binding(1) var<storage, read> counts: array<vec2<u32>>;
@group(0) @binding(2) var<storage, read> caps: array<vec2<u32>>;
@group(0) @binding(3) var<storage, read> dp_in: DeriveParams;
@group(0) @binding(4) var<storage, read_write> dp_out: DeriveParams;
@group(0) @binding(5) var<storage, read_write> sp: array<ScanParams>;
@group(0) @binding(6) var<storage, read_write> args: array<u32>;
@group(0) @binding(7) var<storage, read_write> hist: array<u32>;
// The string's totals come from the block-local offsets and block sums of
// `count_scan` (binding 8).
//!include offsets_blocks.wgsl

fn set_grid(slot: u32, groups: u32) {
    var x = groups;
    var y = 1u;
    if (groups > B.grid_width) {
        x = B.grid_width;
        y = (groups + B.grid_width - 1u) / B.grid_width;
    }
    args[slot * 3u] = x;
    args[slot * 3u + 1u] = y;
    args[slot * 3u + 2u] = 1u;
}

@compute @workgroup_size(1)
fn batch_next() {
    // String k was just sized: its totals are the scan's last element
    // (for the axiom the host put them in counts[0], with dp.n = 0).
    let k = dp_in.iteration;
    var t = out_offset(dp_in.n);
    hist[2u * k] = t.x;
    hist[2u * k + 1u] = t.y;
    if (hist[B.flag] != 0u || t.x > caps[k].x || t.y > caps[k].y) {
        hist[B.flag] = 1u;
        t = vec2<u32>(0u, 0u);
    }
    dp_out = dp_in;
    dp_out.n = t.x;
    dp_out.words = t.y;
    dp_out.iteration = k + 1u;
    // count and rewrite: one thread per module plus the one after the last.
    let threads = t.x + 1u;
    set_grid(0u, (threads + WORKGROUP - 1u) / WORKGROUP);
    var len = threads;
    var need = true;
    for (var l = 0u; l < B.levels; l = l + 1u) {
        // Level 0 (`count_scan`): blocks of WORKGROUP modules; above it,
        // `scan_blocks` over SCAN_BLOCK block sums.
        let per = select(SCAN_BLOCK, WORKGROUP, l == 0u);
        let blocks = (len + per - 1u) / per;
        sp[l * B.sp_stride] = ScanParams(len, blocks, 0u, 0u);
        set_grid(1u + l, select(0u, blocks, need));
        need = need && blocks > 1u;
        set_grid(1u + B.levels + l, select(0u, blocks, need));
        len = blocks;
    }
}

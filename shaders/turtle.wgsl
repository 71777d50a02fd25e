// Turtle interpretation on the GPU: bones (base, tip, left, width, parent)
// of a module string, as grm_turtle::Interpreter computes them. The string
// may hold several systems (derive.wgsl's symbol bits above SYS_SHIFT):
// each has its own commands and settings (TurtleConfig), its first module
// starts from the initial turtle, and nothing crosses a system boundary.
//
// The turtle state before a module is its enclosing branch's state at the
// `[` composed with the transforms of the modules before it in its own
// branch (nested branches excluded: `[ ... ]` restores the state). So:
//
// 1. Depth of every module (brackets.wgsl: the depth tree, level 0).
// 2. Stable counting sort of the modules by depth (`depth_hist`: a
//    histogram per chunk and depth, owner-exclusive; a scan; `depth_scatter`).
//    In depth order each branch's own modules are contiguous: a branch is a
//    segment that starts right after its `[`.
// 3a. Linear turtles (every command is an affine transform: Lipp's matrix
//    scan, 5.3.1, extended to branching strings), fused: no per-module
//    state is stored. `fused_reduce` composes each block of SCAN_BLOCK
//    positions of the depth order (segmented: a branch starts afresh) into
//    one transform; the host scans the block totals; then one
//    `fused_round` per depth scans again the blocks that hold that depth,
//    from their block's prefix, and composes each module's transform
//    within its branch with the state at the branch's `[` (written in the
//    round before): it writes the bones at that depth and the states at
//    its `[`s (one per `[`, by the `[`'s rank). d_max + 1 rounds, O(n)
//    work, and only block totals and `[` states in memory.
// 3a'. The same with a state per module (T.fused = 0): `turtle_elems` puts
//    each module's predecessor's transform in place; one segmented
//    inclusive scan (scan.wgsl with turtle_scan.wgsl) gives every module
//    its local transform within its branch; `turtle_round` then composes,
//    depth by depth, the state at each branch's `[` with them, and
//    `bones_write` reads them. Each transform is computed once instead of
//    twice, for five passes over 64 bytes per module.
// 3b. Turtles with state-dependent commands (tropism, `$`, `%`): Lipp's
//    branch work items (5.3.2), level-synchronous: in round d one thread
//    per branch at depth d walks it sequentially from the state at its `[`.
// 4. `bone_flags` + a scan number the bones in string order (before the
//    fused rounds, which write them; after a walk, `bones_write` does).
//
// Rounds are dispatched indirectly (`depth_starts` writes the bucket
// bounds and workgroup counts), so the host synchronises only once, to
// learn the depth range. No atomics.
//!include grid.wgsl
//!include turtle_scan.wgsl
//!include wg_scan.wgsl

@group(0) @binding(0) var<uniform> T: TurtleParams;
@group(0) @binding(1) var<storage, read> syms: array<u32>;
@group(0) @binding(2) var<storage, read> starts: array<u32>;
@group(0) @binding(3) var<storage, read> params: array<f32>;
// Per system: its TurtleConfig (TURTLE_CONFIG_WORDS words, config k at
// word k * TURTLE_CONFIG_WORDS), then its symbols' TurtleSym records from
// the config's `syms` word on.
@group(0) @binding(4) var<storage, read> tsyms: array<u32>;
@group(0) @binding(5) var<storage, read> levels: array<vec2<i32>>;
@group(0) @binding(6) var<storage, read_write> hist: array<u32>;
@group(0) @binding(7) var<storage, read_write> order: array<u32>;
@group(0) @binding(8) var<storage, read_write> pos_of: array<u32>;
@group(0) @binding(9) var<storage, read_write> elems: array<TurtleElem>;
@group(0) @binding(10) var<storage, read_write> bones: array<GpuBone>;
@group(0) @binding(11) var<storage, read_write> aux: array<u32>;
// Per module (brackets.wgsl, scanned): the number of `[` and of `]` before
// it; a `[`'s first number is its rank, where the fused rounds keep the
// state at it (elems[T.blocks + rank]).
@group(0) @binding(12) var<storage, read_write> pairs: array<vec2<u32>>;

fn tid(wid: vec3<u32>, nwg: vec3<u32>, lid: u32) -> u32 {
    return wg_linear(wid, nwg) * WORKGROUP + lid;
}

fn depth_of(i: u32) -> u32 {
    if (T.straight != 0u) {
        return 0u;
    }
    return u32(levels[i].x);
}

// A string without brackets (T.straight): every module is at depth 0, the
// depth order is the string order, and neither the depths nor the sort
// are computed (`levels`, `order` and `pos_of` are not read).
fn order_at(s: u32) -> u32 {
    if (T.straight != 0u) {
        return s;
    }
    return order[s];
}

fn pos_at(i: u32) -> u32 {
    if (T.straight != 0u) {
        return i;
    }
    return pos_of[i];
}

// ---- 2. counting sort by depth

@compute @workgroup_size(WORKGROUP)
fn depth_hist(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let c = tid(wid, nwg, lid);
    if (c >= T.chunks) {
        if (c == T.chunks) {
            // The slot after the last count: the scan leaves n here.
            hist[(T.dmax + 1u) * T.chunks] = 0u;
        }
        return;
    }
    for (var d = 0u; d <= T.dmax; d = d + 1u) {
        hist[d * T.chunks + c] = 0u;
    }
    let end = min((c + 1u) * T.chunk, T.n);
    for (var i = c * T.chunk; i < end; i = i + 1u) {
        let k = depth_of(i) * T.chunks + c;
        hist[k] = hist[k] + 1u;
    }
}

@compute @workgroup_size(WORKGROUP)
fn depth_scatter(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let c = tid(wid, nwg, lid);
    if (c >= T.chunks) {
        return;
    }
    let end = min((c + 1u) * T.chunk, T.n);
    for (var i = c * T.chunk; i < end; i = i + 1u) {
        let k = depth_of(i) * T.chunks + c;
        let s = hist[k];
        hist[k] = s + 1u;
        order[s] = i;
        pos_of[i] = s;
    }
}

// The end of depth d's bucket in depth order: after depth_scatter,
// hist[d * chunks + c] is the end of (d, c). A straight string has one
// bucket, the whole string.
fn depth_end(d: u32) -> u32 {
    if (T.straight != 0u) {
        return T.n;
    }
    return hist[(d + 1u) * T.chunks - 1u];
}

// Bucket bounds aux[T.bstart + d] (d = 0 ..= dmax + 1) and the indirect
// dispatch arguments of each round, aux[T.args + 3 d ..].
@compute @workgroup_size(WORKGROUP)
fn depth_starts(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let d = tid(wid, nwg, lid);
    if (d > T.dmax + 1u) {
        return;
    }
    // After depth_scatter, hist[d * chunks + c] is the end of (d, c); the
    // start of depth d is the end of (d - 1, last chunk).
    var lo = 0u;
    if (d > 0u) {
        lo = depth_end(d - 1u);
    }
    aux[T.bstart + d] = lo;
    if (d <= T.dmax) {
        let hi = depth_end(d);
        var groups = (hi - lo + WORKGROUP - 1u) / WORKGROUP;
        if (T.fused != 0u) {
            // One workgroup per block of SCAN_BLOCK positions holding some
            // of depth d (fused_round).
            groups = select(0u, (hi - 1u) / SCAN_BLOCK - lo / SCAN_BLOCK + 1u, hi > lo);
        }
        let x = min(groups, T.max_groups);
        let y = select(1u, (groups + T.max_groups - 1u) / T.max_groups, groups > T.max_groups);
        aux[T.args + 3u * d] = select(x, 0u, groups == 0u);
        aux[T.args + 3u * d + 1u] = y;
        aux[T.args + 3u * d + 2u] = 1u;
    }
}

// Module commands (module_elem and its helpers): turtle_cmds.wgsl.
//!include turtle_cmds.wgsl

// Whether module i starts a branch segment: the first module of its
// system, or right after a `[`.
fn seg_start(i: u32) -> bool {
    return i == 0u || sys_of(i - 1u) != sys_of(i) || op_of(i - 1u).op == TOP_PUSH;
}

// The state at the start of module i's segment: the initial state at depth
// 0, else the state at the `[` before it (computed in the round before).
fn base_state(start: u32) -> TurtleElem {
    if (start == 0u || sys_of(start - 1u) != sys_of(start)) {
        CFG = config_of(sys_of(start));
        var e = scan_identity();
        e.wa = 0.0;
        e.wb = CFG.width;
        return e;
    }
    // The state at the `[` before it: per module after a walk, per `[`
    // (by rank, after the block totals) in the fused rounds.
    var b: TurtleElem;
    if (T.fused != 0u) {
        b = elems[T.blocks + pairs[start - 1u].x];
    } else {
        b = elems[pos_at(start - 1u)];
    }
    b.seg = b.seg & SEG_DEAD;
    return b;
}

// ---- 3a'. linear turtles with branches, per-module states

// elems[s] = the scan's input at position s (scan_input_at, 3a below).
@compute @workgroup_size(WORKGROUP)
fn turtle_elems(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let s = tid(wid, nwg, lid);
    if (s >= T.n) {
        return;
    }
    elems[s] = scan_input_at(s);
}

fn round_index(wid: vec3<u32>, nwg: vec3<u32>, lid: u32) -> u32 {
    let lo = aux[T.bstart + T.depth];
    let hi = aux[T.bstart + T.depth + 1u];
    let s = lo + tid(wid, nwg, lid);
    return select(NONE, s, s < hi);
}

// Round T.depth: the full state before every module at this depth.
@compute @workgroup_size(WORKGROUP)
fn turtle_round(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let s = round_index(wid, nwg, lid);
    if (s == NONE) {
        return;
    }
    let local = elems[s];
    var full = compose(base_state(local.seg & SEG_INDEX), local);
    full.seg = 0u;
    elems[s] = full;
}

// ---- 3b. state-dependent turtles: one thread walks each branch

fn tropism(e: ptr<function, TurtleElem>) {
    if (CFG.has_tropism == 0u) {
        return;
    }
    let m = elem_mat(*e);
    let h = normalize_or_zero(m[1]);
    let axis = cross(h, vec3<f32>(CFG.tropism_x, CFG.tropism_y, CFG.tropism_z));
    let s = length(axis);
    if (s > 1e-9 && finite(s)) {
        set_frame(e, rot_axis(axis / s, CFG.elasticity * s) * m, elem_t(*e));
    }
}

fn roll_horizontal(e: ptr<function, TurtleElem>) {
    var m = elem_mat(*e);
    let h = normalize_or_zero(m[1]);
    let l0 = cross(vec3<f32>(0.0, 1.0, 0.0), h);
    let len = length(l0);
    if (len < 1e-6 || !finite(len)) {
        return;
    }
    let l = l0 / len;
    let u = cross(h, l);
    let sx = length(m[0]);
    let sz = length(m[2]);
    m[0] = l * sx;
    m[2] = -u * sz;
    set_frame(e, m, elem_t(*e));
}

@compute @workgroup_size(WORKGROUP)
fn turtle_walk(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let s0 = round_index(wid, nwg, lid);
    if (s0 == NONE) {
        return;
    }
    let i0 = order_at(s0);
    if (!seg_start(i0)) {
        return;
    }
    let hi = aux[T.bstart + T.depth + 1u];
    CFG = config_of(sys_of(i0));
    var st = base_state(i0);
    for (var s = s0; s < hi; s = s + 1u) {
        let i = order_at(s);
        if (s > s0 && seg_start(i)) {
            break;
        }
        elems[s] = st;
        if ((st.seg & SEG_DEAD) != 0u) {
            continue;
        }
        let op = op_of(i).op;
        if (op == TOP_CUT) {
            st.seg = st.seg | SEG_DEAD;
        } else if (op == TOP_ROLL_HORIZONTAL) {
            roll_horizontal(&st);
        } else {
            st = compose(st, module_elem(i));
            if (op == TOP_FORWARD) {
                tropism(&st);
            }
        }
    }
}

// ---- 4. bones

fn is_bone(i: u32) -> bool {
    if (op_of(i).op != TOP_FORWARD) {
        return false;
    }
    // Only a walk cuts (`%`); the fused scan keeps no per-module states.
    return T.fused != 0u || (elems[pos_at(i)].seg & SEG_DEAD) == 0u;
}

// hist[i] = 1 for every live `F`/`G` (and 0 at i = n), to be scanned into
// bone indices (the histogram is not needed any more).
@compute @workgroup_size(WORKGROUP)
fn bone_flags(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let i = tid(wid, nwg, lid);
    if (i > T.n) {
        return;
    }
    hist[i] = select(0u, 1u, i < T.n && is_bone(i));
}

// Write module i's bone from the turtle state `st` before it.
fn write_bone(i: u32, st: TurtleElem) {
    CFG = config_of(sys_of(i));
    let m = elem_mat(st);
    let base = elem_t(st);
    let tip = base + m[1] * arg(i, 0u, CFG.step);
    let left = normalize_or_zero(m[0]);
    let w = st.wb * 0.5 * (length(m[0]) + length(m[2]));
    var parent = NONE;
    if (st.bone != NONE) {
        parent = hist[st.bone];
    }
    bones[hist[i]] = GpuBone(base.x, base.y, base.z, tip.x, tip.y, tip.z, left.x, left.y, left.z, w, parent, i);
}

@compute @workgroup_size(WORKGROUP)
fn bones_write(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let i = tid(wid, nwg, lid);
    if (i >= T.n || !is_bone(i)) {
        return;
    }
    write_bone(i, elems[pos_at(i)]);
}

// ---- 3a (and straight strings). Linear turtles: the matrix scan fused
//
// With affine commands only, the state before a module is the state at its
// branch's `[` (the initial state for a system's first branch) composed
// with the transforms of the modules before it in its branch, which are
// the positions before it in the depth order, back to its segment's start.
// Lipp's matrix scan (5.3.1) as reduce, scan, re-scan over the depth order
// (the string order for a straight string, T.straight): no per-module
// state is stored. `fused_reduce` writes each block's composition
// (SCAN_BLOCK positions) to elems[block], the host scans those (scan.wgsl,
// inclusive, segmented); then `straight_bones` (a straight string: one
// depth, the initial state at every segment start) or one `fused_round`
// per depth scans each block again from its block's prefix and writes the
// bones at once (their indices from the scanned bone flags in `hist`).

// The scan's input at position s of the depth order (as a segmented scan
// of the modules' transforms wants it): a segment start (its module index
// recorded), else the transform of the module before it in its branch,
// which is the module at position s - 1.
fn scan_input_at(s: u32) -> TurtleElem {
    let i = order_at(s);
    if (seg_start(i)) {
        var e = scan_identity();
        e.seg = SEG_START | i;
        return e;
    }
    var e = module_elem(order_at(s - 1u));
    e.seg = 0u;
    return e;
}

// The composition of this thread's SCAN_PER_THREAD positions of `block`.
fn thread_total(block: u32, lid: u32) -> TurtleElem {
    let first = block * SCAN_BLOCK + lid * SCAN_PER_THREAD;
    var s = scan_identity();
    for (var j = 0u; j < SCAN_PER_THREAD; j = j + 1u) {
        if (first + j < T.n) {
            s = scan_combine(s, scan_input_at(first + j));
        }
    }
    return s;
}

@compute @workgroup_size(WORKGROUP)
fn fused_reduce(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let block = wg_linear(wid, nwg);
    if (block >= T.blocks) {
        return;
    }
    let s = thread_total(block, lid);
    let before = wg_scan_exclusive(lid, s);
    if (lid == WORKGROUP - 1u) {
        elems[block] = scan_combine(before, s);
    }
}

// The scan of `block` again: this thread's inputs into v, and the
// composition from the block prefix's segment start to just before them.
var<private> v: array<TurtleElem, SCAN_PER_THREAD>;

fn rescan(block: u32, lid: u32) -> TurtleElem {
    // The inputs are kept (as scan_blocks keeps its elements) rather than
    // computed again after the workgroup scan.
    let first = block * SCAN_BLOCK + lid * SCAN_PER_THREAD;
    var s = scan_identity();
    for (var j = 0u; j < SCAN_PER_THREAD; j = j + 1u) {
        if (first + j < T.n) {
            v[j] = scan_input_at(first + j);
            s = scan_combine(s, v[j]);
        }
    }
    let before = wg_scan_exclusive(lid, s);
    // elems[] is the inclusive scan of the block totals.
    var acc = scan_identity();
    if (block > 0u) {
        acc = elems[block - 1u];
    }
    return scan_combine(acc, before);
}

@compute @workgroup_size(WORKGROUP)
fn straight_bones(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let block = wg_linear(wid, nwg);
    if (block >= T.blocks) {
        return;
    }
    var acc = rescan(block, lid);
    let first = block * SCAN_BLOCK + lid * SCAN_PER_THREAD;
    for (var j = 0u; j < SCAN_PER_THREAD; j = j + 1u) {
        let i = first + j;
        if (i >= T.n) {
            break;
        }
        // The state before module i, relative to its system's start.
        acc = scan_combine(acc, v[j]);
        if (op_of(i).op == TOP_FORWARD) {
            write_bone(i, compose(base_state(acc.seg & SEG_INDEX), acc));
        }
    }
}

// Round T.depth of a branching string: the blocks holding positions of
// that depth (aux's bucket bounds), one workgroup each. Every position of
// the block joins the scan; those of this depth write their bone (an `F`)
// or the state at them (a `[`, for the branch it opens, read in the next
// round by base_state).
var<workgroup> wg_bounds: vec2<u32>;

@compute @workgroup_size(WORKGROUP)
fn fused_round(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    // The bucket bounds, read once and uniform across the workgroup (its
    // scan has barriers).
    if (lid == 0u) {
        wg_bounds = vec2<u32>(aux[T.bstart + T.depth], aux[T.bstart + T.depth + 1u]);
    }
    let bounds = workgroupUniformLoad(&wg_bounds);
    let lo = bounds.x;
    let hi = bounds.y;
    let block = lo / SCAN_BLOCK + wg_linear(wid, nwg);
    if (hi <= lo || block > (hi - 1u) / SCAN_BLOCK) {
        return;
    }
    var acc = rescan(block, lid);
    let first = block * SCAN_BLOCK + lid * SCAN_PER_THREAD;
    for (var j = 0u; j < SCAN_PER_THREAD; j = j + 1u) {
        let s = first + j;
        if (s >= hi) {
            break;
        }
        acc = scan_combine(acc, v[j]);
        if (s < lo) {
            continue;
        }
        let i = order_at(s);
        let op = op_of(i).op;
        if (op == TOP_FORWARD || op == TOP_PUSH) {
            let st = compose(base_state(acc.seg & SEG_INDEX), acc);
            if (op == TOP_FORWARD) {
                write_bone(i, st);
            } else {
                elems[T.blocks + pairs[i].x] = st;
            }
        }
    }
}

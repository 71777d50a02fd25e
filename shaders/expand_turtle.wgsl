// Direct interpretation (grm-gpu's interpret_direct): the bones of a string
// of affine turtle commands that was derived directly (expand.wgsl) with
// constant parameters, without reading the string.
//
// The turtle state before a module is the initial state composed with the
// transforms of the modules before it on its path (turtle_scan.wgsl's
// `compose`; a closed branch `[ ... ]` leaves the state as it found it).
// In the derivation tree of a direct derivation that is, level by level,
// the composition of the whole expansions of the siblings before the
// path's slot, branches skipped: `expand_nets` computes, once, each
// symbol's whole expansion after r steps (`N[r][s]`: its successor's
// slots' expansions with one step fewer, composed with a stack at the
// brackets) and each slot's prefix within its predecessor's expansion
// (`P[r][slot]`); the slots' own transforms come from a string of one
// module per slot with its constant parameters (`syms`, `starts`,
// `params`: the slot string, then the axiom modules). A transform's
// `bone` field is the number of the last bone in it (relative to its
// expansion's first bone; absolute once composed on a path), so the
// state carries its parent bone as the CPU's does. Then `expand_bones`
// takes one thread per bone b: it walks down to the b-th `F` by the bone
// counts of the host (`ft`), composing the prefixes on its way, and
// writes the bone as turtle.wgsl's `write_bone` does. One pass over the
// bones; the string is not read, only the small tables.
//!include grid.wgsl
//!include turtle_scan.wgsl

@group(0) @binding(0) var<uniform> X: ExpandTurtleParams;
@group(0) @binding(1) var<storage, read> syms: array<u32>;
@group(0) @binding(2) var<storage, read> starts: array<u32>;
@group(0) @binding(3) var<storage, read> params: array<f32>;
@group(0) @binding(4) var<storage, read> tsyms: array<u32>;
@group(0) @binding(5) var<storage, read> xt: array<u32>;
@group(0) @binding(6) var<storage, read> ft: array<u32>;
@group(0) @binding(7) var<storage, read_write> nets: array<TurtleElem>;
@group(0) @binding(8) var<storage, read_write> bones: array<GpuBone>;
//!include turtle_cmds.wgsl

fn has_production(s: u32) -> bool {
    return ft[s] != 0u;
}

// The whole expansion of the module of slot k (slot string index) with r
// steps left: the symbol's when it has a production and a step is left,
// else the module itself (with the slot's parameters).
fn child_net(r: u32, k: u32, s: u32) -> TurtleElem {
    if (r >= 1u && has_production(s)) {
        return nets[X.net_n + (r - 1u) * X.nsym + s];
    }
    return nets[k];
}

fn op_of_symbol(s: u32) -> u32 {
    return tsyms[config_of(0u).syms + s * TURTLE_SYM_WORDS];
}

// A transform with its bone numbers moved by `by` (relative to absolute,
// or to an enclosing expansion).
fn moved(e: TurtleElem, by: u32) -> TurtleElem {
    var m = e;
    if (m.bone != NONE) {
        m.bone = m.bone + by;
    }
    return m;
}

var<private> stack: array<TurtleElem, DIRECT_TURTLE_STACK>;
var<private> sp: u32;

// The state after one more module of a successor (or of the axiom): slot
// string entry k, symbol c, with r steps left and `bones` bones before it
// in the sequence. `[` saves the state, `]` restores the saved one,
// anything else composes the module's whole expansion.
fn then_module(acc: TurtleElem, r: u32, k: u32, c: u32, bones: u32) -> TurtleElem {
    let op = op_of_symbol(c);
    if (op == TOP_PUSH) {
        stack[sp] = acc;
        sp = sp + 1u;
        return acc;
    }
    if (op == TOP_POP) {
        sp = sp - 1u;
        return stack[sp];
    }
    return compose(acc, moved(child_net(r, k, c), bones));
}

// One workgroup: the slots' transforms, then N and P step by step, then
// the prefixes of the axiom modules. Brackets: `[` saves the state, `]`
// restores it (the host checks that every successor and the axiom are
// balanced within DIRECT_TURTLE_STACK and that brackets have no
// production).
@compute @workgroup_size(WORKGROUP)
fn expand_nets(@builtin(local_invocation_index) lid: u32) {
    let own = X.slot_count + X.n_ax;
    for (var k = lid; k < own; k = k + WORKGROUP) {
        var e = module_elem(k);
        // Its own bone, if it is one, is its expansion's bone 0.
        e.bone = select(NONE, 0u, op_of(k).op == TOP_FORWARD);
        e.seg = 0u;
        nets[k] = e;
    }
    storageBarrier();
    workgroupBarrier();
    for (var r = 1u; r <= X.steps; r = r + 1u) {
        for (var s = lid; s < X.nsym; s = s + WORKGROUP) {
            if (!has_production(s)) {
                continue;
            }
            let first = xt[X.symbols + 2u * s];
            let len = xt[X.symbols + 2u * s + 1u];
            var acc = scan_identity();
            sp = 0u;
            for (var i = 0u; i < len; i = i + 1u) {
                let k = first + i;
                nets[X.net_p + (r - 1u) * X.slot_count + k] = acc;
                let c = xt[X.slots + EXPAND_SLOT_WORDS * k];
                let bones = ft[X.f_pre + (r - 1u) * X.slot_count + k];
                acc = then_module(acc, r - 1u, k, c, bones);
            }
            nets[X.net_n + (r - 1u) * X.nsym + s] = acc;
        }
        storageBarrier();
        workgroupBarrier();
    }
    if (lid == 0u) {
        var acc = scan_identity();
        sp = 0u;
        for (var i = 0u; i < X.n_ax; i = i + 1u) {
            nets[X.net_ax + i] = acc;
            let k = X.slot_count + i;
            acc = then_module(acc, X.steps, k, syms[k] & SYM_MASK, ft[X.f_top + i]);
        }
    }
}

@compute @workgroup_size(WORKGROUP)
fn expand_bones(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let b = wg_linear(wid, nwg) * WORKGROUP + lid;
    if (b >= X.bones) {
        return;
    }
    // The axiom module whose expansion holds bone b (an expansion without
    // bones starts where the next one does, so it is never the last).
    var lo = 0u;
    var hi = X.n_ax;
    while (hi - lo > 1u) {
        let mid = (lo + hi) / 2u;
        if (ft[X.f_top + mid] <= b) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    var rest = b - ft[X.f_top + lo];
    var o = ft[X.m_top + lo];
    var st = nets[X.net_ax + lo];
    var k = X.slot_count + lo;
    var s = syms[k] & SYM_MASK;
    var r = X.steps;
    while (r > 0u && has_production(s)) {
        let first = xt[X.symbols + 2u * s];
        let len = xt[X.symbols + 2u * s + 1u];
        let fr = X.f_pre + (r - 1u) * X.slot_count + first;
        var a = 0u;
        var z = len;
        while (z - a > 1u) {
            let m = (a + z) / 2u;
            if (ft[fr + m] <= rest) {
                a = m;
            } else {
                z = m;
            }
        }
        // The first bone of this expansion, absolute: its prefixes' bone
        // numbers are relative to it.
        let start = b - rest;
        rest = rest - ft[fr + a];
        o = o + xt[X.offsets + 2u * ((r - 1u) * X.slot_count + first + a)];
        st = compose(st, moved(nets[X.net_p + (r - 1u) * X.slot_count + first + a], start));
        k = first + a;
        s = xt[X.slots + EXPAND_SLOT_WORDS * k];
        r = r - 1u;
    }
    // Module o is the b-th `F`: its state is the initial one composed with
    // everything before it.
    CFG = config_of(0u);
    var base = scan_identity();
    base.wa = 0.0;
    base.wb = CFG.width;
    let full = compose(base, st);
    let m = elem_mat(full);
    let at = elem_t(full);
    let tip = at + m[1] * arg(k, 0u, CFG.step);
    let left = normalize_or_zero(m[0]);
    let w = full.wb * 0.5 * (length(m[0]) + length(m[2]));
    // The bone that was current: the last `F` on the path.
    let parent = full.bone;
    bones[b] = GpuBone(at.x, at.y, at.z, tip.x, tip.y, tip.z, left.x, left.y, left.z, w, parent, o);
}

// Direct derivation (grm-gpu's derive/direct.rs): the final string of
// deterministic, context-free systems, written in one pass with no
// intermediate string.
//
// In such a system every module of symbol s becomes, after r more steps,
// the same string, whose length and parameter words the host computes
// from the tables; so the final string is a tree whose shape is known
// before anything is derived. One thread per output position o: it finds
// the axiom module whose expansion holds o (binary search over the host's
// offsets), then walks down that module's derivation tree one step at a
// time: among the current symbol's successor modules, the one whose
// expansion (with one step fewer left) holds o (binary search over the
// host's offsets of the successor modules), adding up the parameter words
// before it, until no step is left or the symbol has no production (it
// stays itself). The module there is the successor slot it came from:
// its symbol, and its parameters (EXPAND_PARAMS: expand_const.wgsl copies
// the slot's constants, or the axiom module's own parameters when no step
// was taken; expand_vm.wgsl evaluates the chain of computed parameters
// from the last slot with constant ones down to the module, with the
// bytecode interpreter). Its identity key (E.keyed: some system draws) is
// the axiom module's key with child_key(key, slot salt) applied at each
// step taken, as the stepwise rewrites derive it (a module that stays
// itself keeps its key). Module writes are coalesced; there is no scan,
// no atomic (but on the error path), and nothing is read but the small
// tables: the derivation costs one pass over the output.
//!include grid.wgsl

@group(0) @binding(0) var<uniform> E: ExpandParams;
@group(0) @binding(1) var<storage, read> jobs: array<ExpandJob>;
@group(0) @binding(2) var<storage, read> xt: array<u32>;
// String 0 (the axioms, each module tagged with its job above SYS_SHIFT),
// and per module the first (module, parameter word) of its expansion in
// the final string (n_in + 1 entries, the totals last).
@group(0) @binding(3) var<storage, read> in_syms: array<u32>;
@group(0) @binding(4) var<storage, read> in_starts: array<u32>;
@group(0) @binding(5) var<storage, read> in_params: array<f32>;
@group(0) @binding(6) var<storage, read> in_offs: array<vec2<u32>>;
@group(0) @binding(7) var<storage, read_write> out_syms: array<u32>;
@group(0) @binding(8) var<storage, read_write> out_starts: array<u32>;
@group(0) @binding(9) var<storage, read_write> out_params: array<f32>;
// walk_begin(), walk_step(slot), write_params(job, input module, first word);
// the key bindings `in_keys` (per axiom module) and `out_keys`.
//!include EXPAND_PARAMS
//!include rng.wgsl

@compute @workgroup_size(WORKGROUP)
fn expand(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let o = wg_linear(wid, nwg) * WORKGROUP + lid;
    if (o >= E.total) {
        if (o == E.total) {
            out_starts[o] = E.total_words;
        }
        return;
    }
    // The last axiom module starting at or before o (an empty expansion
    // starts where the next one does, so it is never the last).
    var lo = 0u;
    var hi = E.n_in;
    while (hi - lo > 1u) {
        let mid = (lo + hi) / 2u;
        if (in_offs[mid].x <= o) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let tagged = in_syms[lo];
    let job = tagged >> SYS_SHIFT;
    let j = jobs[job];
    var s = tagged & SYM_MASK;
    var rest = o - in_offs[lo].x;
    var wo = in_offs[lo].y;
    walk_begin();
    var key = 0u;
    if (E.keyed != 0u) {
        key = in_keys[lo];
    }
    var r = j.steps;
    while (r > 0u) {
        let first = xt[j.symbols + 2u * s];
        let len = xt[j.symbols + 2u * s + 1u];
        if (len == 0u) {
            break;
        }
        let row = j.offsets + 2u * ((r - 1u) * j.slot_count + first);
        var a = 0u;
        var b = len;
        while (b - a > 1u) {
            let m = (a + b) / 2u;
            if (xt[row + 2u * m] <= rest) {
                a = m;
            } else {
                b = m;
            }
        }
        rest = rest - xt[row + 2u * a];
        wo = wo + xt[row + 2u * a + 1u];
        let slot = j.slots + EXPAND_SLOT_WORDS * (first + a);
        walk_step(slot);
        if (E.keyed != 0u) {
            key = child_key(key, xt[slot + 7u]);
        }
        s = xt[slot];
        r = r - 1u;
    }
    out_syms[o] = s | (job << SYS_SHIFT);
    out_starts[o] = wo;
    if (E.keyed != 0u) {
        out_keys[o] = key;
    }
    write_params(job, lo, wo);
}

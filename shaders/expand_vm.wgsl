// The direct derivation's parameters (expand.wgsl) where some successor
// slots compute theirs (`F(l) -> F(l * 1.109)`): a module's parameters
// depend on its ancestors' only back to the last slot with constant
// parameters (or the axiom module). The walk remembers that slot and the
// computed slots after it; then each of those is evaluated in order, as
// the stepwise rewrite evaluates it: its predecessor's parameters bound
// at the production's binding words, each parameter constant, copied or
// computed by the bytecode interpreter (the code draws nothing: the host
// checks). A fault or a non-finite value sets `status` and the host
// derives stepwise, which reports the error exactly.
@group(0) @binding(10) var<storage, read> tables: array<u32>;
@group(0) @binding(11) var<storage, read_write> status: array<atomic<u32>>;
// The axiom modules' identity keys and the output's.
@group(0) @binding(12) var<storage, read> in_keys: array<u32>;
@group(0) @binding(13) var<storage, read_write> out_keys: array<u32>;
//!include generated_tables
//!include vm.wgsl

var<private> anchor: u32;
var<private> path: array<u32, DIRECT_MAX_STEPS>;
var<private> plen: u32;
var<private> cur: array<f32, MAX_BIND_WORDS>;
var<private> nxt: array<f32, MAX_BIND_WORDS>;

fn walk_begin() {
    anchor = NONE;
    plen = 0u;
}

fn walk_step(slot: u32) {
    if (xt[slot + 2u] != NONE) {
        anchor = slot;
        plen = 0u;
    } else {
        path[plen] = slot;
        plen = plen + 1u;
    }
}

fn write_params(job: u32, lo: u32, wo: u32) {
    var n = 0u;
    if (anchor == NONE) {
        let a = in_starts[lo];
        n = in_starts[lo + 1u] - a;
        for (var c = 0u; c < n; c = c + 1u) {
            cur[c] = in_params[a + c];
        }
    } else {
        n = xt[anchor + 1u];
        let d = xt[anchor + 2u];
        for (var c = 0u; c < n; c = c + 1u) {
            cur[c] = bitcast<f32>(xt[d + c]);
        }
    }
    if (plen > 0u) {
        tab_select(load_SystemEntry(job * SYSTEM_ENTRY_WORDS).base);
    }
    for (var k = 0u; k < plen; k = k + 1u) {
        let slot = path[k];
        let bind_at = xt[slot + 5u];
        for (var c = 0u; c < xt[slot + 6u]; c = c + 1u) {
            vm_bind[bind_at + c] = cur[c];
        }
        var w = 0u;
        let first = xt[slot + 3u];
        for (var q = first; q < first + xt[slot + 4u]; q = q + 1u) {
            let pe = load_ParamExpr(TAB_BASE + TAB.params_offset + q * PARAM_EXPR_WORDS);
            if (vm_param(pe, Draws(0u, 0u, 0u)) != 0u) {
                atomicOr(&status[0], 1u);
            }
            for (var c = 0u; c < pe.words; c = c + 1u) {
                nxt[w + c] = vm_st[c];
            }
            w = w + pe.words;
        }
        n = w;
        for (var c = 0u; c < n; c = c + 1u) {
            cur[c] = nxt[c];
        }
    }
    for (var c = 0u; c < n; c = c + 1u) {
        out_params[wo + c] = cur[c];
    }
}

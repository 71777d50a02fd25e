// The direct derivation's parameters (expand.wgsl) where every successor
// slot's parameters are constants: a module's parameters are those of the
// slot it came from, or the axiom module's own when no step was taken.
// Bindings 10 and 11: the axiom modules' identity keys and the output's.
@group(0) @binding(10) var<storage, read> in_keys: array<u32>;
@group(0) @binding(11) var<storage, read_write> out_keys: array<u32>;

var<private> last_slot: u32;

fn walk_begin() {
    last_slot = NONE;
}

fn walk_step(slot: u32) {
    last_slot = slot;
}

fn write_params(job: u32, lo: u32, wo: u32) {
    if (last_slot == NONE) {
        let a = in_starts[lo];
        let n = in_starts[lo + 1u] - a;
        for (var c = 0u; c < n; c = c + 1u) {
            out_params[wo + c] = in_params[a + c];
        }
        return;
    }
    let n = xt[last_slot + 1u];
    let d = xt[last_slot + 2u];
    for (var c = 0u; c < n; c = c + 1u) {
        out_params[wo + c] = bitcast<f32>(xt[d + c]);
    }
}

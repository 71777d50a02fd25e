// One derivation iteration (Lipp 5.2.2): `count` decides the production of
// every module and writes its output size (modules, parameter words);
// the host scans the sizes (scan.wgsl, vec2<u32>); `rewrite` writes every
// module's successor at its scanned offset. One thread per input module,
// no atomics except on the error path (the lowest failing position).
//
// The decision is the CPU engine's (grm_derive::engine), step for step:
// groups in order; contexts matched bracket-aware with the ignore list
// (left: towards the root over complete branches; right: forward in the
// branch over lateral branches, `[`/`]` items enter a branch / skip to its
// end); the condition; among alternatives the one drawn with draw index 0
// (constant weights from the tables, computed weights from their code,
// each checked positive and finite). Tables, bytecode and draws are
// grm_compile's, read through the generated loaders.
//
// Several systems at once (Lipp 5.4): `tables` starts with a directory of
// SystemEntry records (each system's packed tables, iterations, seed, root
// key and its range in the current string); a module's symbol carries its
// system's index above SYS_SHIFT. A module reads its own system's tables,
// draws with its system's seed and its own identity key, matches contexts
// only inside that range, and is copied unchanged once its system has done
// its iterations. One system is the same with one directory entry.
//
// Identity keys (grm_compile::rng, "Identity keys"; P.keyed: some system
// draws): every module has a key (`in_keys`), and its draws are keyed by
// it, never by its position. The rewrite writes the output's keys
// (`out_keys`): a copied module keeps its key, a successor module gets
// child_key(the rewritten module's key, its salt); an axiom module gets
// child_key(its system's root key, its salt), and the axiom's draws use
// the root key. Without P.keyed nothing draws, and the key buffers are
// neither read nor written.
//!include grid.wgsl

// PARAM_SPACE: `uniform` (parameters written by the host) or `storage, read`
// (written on the device by `batch_next`, batched derivations).
@group(0) @binding(0) var<PARAM_SPACE> P: DeriveParams;
@group(0) @binding(1) var<storage, read> tables: array<u32>;
@group(0) @binding(2) var<storage, read> in_syms: array<u32>;
@group(0) @binding(3) var<storage, read> in_starts: array<u32>;
@group(0) @binding(4) var<storage, read> in_params: array<f32>;
@group(0) @binding(5) var<storage, read> mate: array<u32>;
@group(0) @binding(6) var<storage, read_write> counts: array<vec2<u32>>;
@group(0) @binding(7) var<storage, read_write> choice: array<u32>;
@group(0) @binding(8) var<storage, read_write> out_syms: array<u32>;
@group(0) @binding(9) var<storage, read_write> out_starts: array<u32>;
@group(0) @binding(10) var<storage, read_write> out_params: array<f32>;
@group(0) @binding(11) var<storage, read_write> status: array<atomic<u32>, STATUS_WORDS>;
@group(0) @binding(12) var<storage, read> in_keys: array<u32>;
@group(0) @binding(13) var<storage, read_write> out_keys: array<u32>;
// `out_offset(i)`: module i's output offsets (modules, parameter words),
// from `counts` alone (offsets_global.wgsl) or from block-local offsets and
// block sums (offsets_blocks.wgsl, the batched kernels' binding 14).
//!include OFFSETS
//!include generated_tables
//!include vm.wgsl
// match_contexts(i, g): group g's left and right contexts at module i,
// binding their parameters. The kernel's substitution names the file:
// contexts.wgsl (the bracket-aware matching) or contexts_none.wgsl (the
// context-free kernels; grm-gpu's kernels.rs).
//!include CONTEXT_MATCH

// `choice`: copy the module unchanged.
const COPY: u32 = 0xffffffffu;

// The system of the module being worked on.
var<private> SYS: SystemEntry;
var<private> SYS_ID: u32;

fn select_system(id: u32) {
    SYS_ID = id;
    SYS = load_SystemEntry(id * SYSTEM_ENTRY_WORDS);
    tab_select(SYS.base);
}

// The symbol of input module p within its system.
fn sym_at(p: u32) -> u32 {
    return in_syms[p] & SYM_MASK;
}

struct Decision {
    alt: u32,
    err: u32,
}

fn sym_entry(s: u32) -> SymbolEntry {
    return load_SymbolEntry(TAB_BASE + TAB.symbols_offset + s * SYMBOL_ENTRY_WORDS);
}

fn group_at(g: u32) -> GroupHeader {
    return load_GroupHeader(TAB_BASE + TAB.groups_offset + g * GROUP_HEADER_WORDS);
}

fn alt_at(a: u32) -> AltHeader {
    return load_AltHeader(TAB_BASE + TAB.alts_offset + a * ALT_HEADER_WORDS);
}

fn ctx_at(c: u32) -> ContextItem {
    return load_ContextItem(TAB_BASE + TAB.context_offset + c * CONTEXT_ITEM_WORDS);
}

fn succ_at(k: u32) -> SuccModule {
    return load_SuccModule(TAB_BASE + TAB.succ_offset + k * SUCC_MODULE_WORDS);
}

fn param_at(k: u32) -> ParamExpr {
    return load_ParamExpr(TAB_BASE + TAB.params_offset + k * PARAM_EXPR_WORDS);
}

fn sym_flags(s: u32) -> u32 {
    return sym_entry(s).flags;
}

// Copy the parameter words of the module at `pos` to vm_bind[off..].
fn bind_module(pos: u32, off: u32) {
    let s = in_starts[pos];
    let e = in_starts[pos + 1u];
    for (var k = 0u; k < e - s; k = k + 1u) {
        vm_bind[off + k] = in_params[s + k];
    }
}


// Match group g's contexts at module i (binding their parameters) and bind
// the predecessor's parameters.
fn bind_group(i: u32, g: GroupHeader) -> bool {
    if ((g.flags & GROUP_CONTEXT) != 0u && !match_contexts(i, g)) {
        return false;
    }
    if (g.pred_bind_words > 0u) {
        bind_module(i, g.pred_bind_offset);
    }
    return true;
}

// Input module i's identity key (its position within its system where no
// system draws: nothing reads it then).
fn key_at(i: u32) -> u32 {
    if (P.keyed != 0u) {
        return in_keys[i];
    }
    return i - SYS.start;
}

// Draws are keyed by the module's identity key.
fn draws_at(i: u32) -> Draws {
    return Draws(SYS.seed, P.iteration, key_at(i));
}

// The weight of alternative `a` (constant or computed); NaN on a fault.
fn weight_of(a: u32, d: Draws) -> f32 {
    let alt = alt_at(a);
    if (alt.weight_code == NONE) {
        return alt.weight;
    }
    if (vm_run(alt.weight_code, d) == VM_FAULT) {
        return bitcast<f32>(0x7fc00000u);
    }
    return vm_st[0];
}

// The race (grm_compile::rng, "Choosing among weighted alternatives"),
// bit for bit: an alternative's time `-log2(u)` in 16.16 fixed point from
// the logarithm table packed after the system's tables, and the exact
// comparison `ta * wb < tb * wa` on 64-bit integers made of two u32s.
fn log2_frac(x: u32) -> u32 {
    let i = (x >> 23u) & 0xffu;
    let t = (x >> 7u) & 0xffffu;
    let a = tables[TAB_BASE + TAB.log2_offset + i];
    let b = tables[TAB_BASE + TAB.log2_offset + i + 1u];
    return a + (((b - a) * t + 0x8000u) >> 16u);
}

fn log2_fixed(v: u32) -> u32 {
    if (v == 0u) {
        return 0u;
    }
    let n = 31u - countLeadingZeros(v);
    return (n << 16u) + log2_frac(v << (31u - n));
}

fn race_time(h: u32) -> u32 {
    return (24u << 16u) - log2_fixed((h >> 8u) + 1u);
}

// A finite positive f32 as an integer mantissa and a power of two:
// w = m * 2^e, m below 2^24 (e biased by 150 to stay unsigned: e + 150).
fn weight_parts(w: f32) -> vec2<u32> {
    let bits = bitcast<u32>(w) & 0x7fffffffu;
    let e = bits >> 23u;
    let m = bits & 0x007fffffu;
    if (e == 0u) {
        return vec2<u32>(m, 1u);
    }
    return vec2<u32>(m | 0x00800000u, e);
}

// t * m as (lo, hi) for t below 2^21 and m below 2^24.
fn mul_wide(t: u32, m: u32) -> vec2<u32> {
    let tl = t & 0xffffu;
    let th = t >> 16u;
    let ml = m & 0xffffu;
    let mh = m >> 16u;
    let ll = tl * ml;
    let mid = tl * mh + th * ml;
    let lo = ll + (mid << 16u);
    let carry = select(0u, 1u, lo < ll);
    let hi = th * mh + (mid >> 16u) + carry;
    return vec2<u32>(lo, hi);
}

fn bit_length(x: vec2<u32>) -> u32 {
    if (x.y != 0u) {
        return 64u - countLeadingZeros(x.y);
    }
    return 32u - countLeadingZeros(x.x);
}

fn shift_left(x: vec2<u32>, s: u32) -> vec2<u32> {
    if (s == 0u) {
        return x;
    }
    if (s >= 32u) {
        return vec2<u32>(0u, x.x << (s - 32u));
    }
    return vec2<u32>(x.x << s, (x.y << s) | (x.x >> (32u - s)));
}

fn less_wide(a: vec2<u32>, b: vec2<u32>) -> bool {
    return a.y < b.y || (a.y == b.y && a.x < b.x);
}

// ta / wa < tb / wb, exactly: ta * mb * 2^eb < tb * ma * 2^ea.
fn race_earlier(ta: u32, wa: f32, tb: u32, wb: f32) -> bool {
    let pa = weight_parts(wa);
    let pb = weight_parts(wb);
    let x = mul_wide(ta, pb.x);
    let y = mul_wide(tb, pa.x);
    let x_zero = x.x == 0u && x.y == 0u;
    let y_zero = y.x == 0u && y.y == 0u;
    if (x_zero || y_zero) {
        return x_zero && !y_zero;
    }
    // Compare x * 2^(eb - ea) with y: first by the leading bit's place.
    let lx = i32(bit_length(x)) + i32(pb.y);
    let ly = i32(bit_length(y)) + i32(pa.y);
    if (lx != ly) {
        return lx < ly;
    }
    let d = i32(pb.y) - i32(pa.y);
    if (d >= 0i) {
        return less_wide(shift_left(x, u32(d)), y);
    }
    return less_wide(x, shift_left(y, u32(-d)));
}

fn decide(i: u32) -> Decision {
    if (P.iteration > SYS.iterations) {
        return Decision(COPY, 0u);
    }
    let se = sym_entry(sym_at(i));
    let d = draws_at(i);
    for (var gi = se.first_group; gi < se.first_group + se.group_count; gi = gi + 1u) {
        let g = group_at(gi);
        if (!bind_group(i, g)) {
            continue;
        }
        if (g.cond_code != NONE) {
            if (vm_run(g.cond_code, d) == VM_FAULT) {
                return Decision(COPY, ERR_FAULT);
            }
            if (vm_st[0] == 0.0) {
                continue;
            }
        }
        if (g.alt_count == 1u) {
            return Decision(g.first_alt, 0u);
        }
        // The race among the alternatives (grm_compile::rng, "Choosing
        // among weighted alternatives"; grm_compile::select): computed
        // weights must all be positive and finite (checked before any
        // draw, as the CPU does); each alternative's time is its own
        // draw over its weight, the earliest wins, the first on a tie.
        let last = g.first_alt + g.alt_count - 1u;
        let const_weights = (g.flags & GROUP_CONST_WEIGHTS) != 0u;
        if (!const_weights) {
            for (var a = g.first_alt; a <= last; a = a + 1u) {
                let w = weight_of(a, d);
                if (!(is_finite(w) && w > 0.0)) {
                    return Decision(COPY, ERR_BAD_WEIGHT);
                }
            }
        }
        let prefix = rng_prefix(d.seed, d.iteration, d.position);
        var best = g.first_alt;
        var best_time = 0u;
        var best_w = 1.0;
        for (var a = g.first_alt; a <= last; a = a + 1u) {
            var w = alt_at(a).weight;
            if (!const_weights) {
                w = weight_of(a, d);
            }
            let t = race_time(rng_finish(prefix, 0x80000000u | (a - g.first_alt)));
            if (a == g.first_alt || race_earlier(t, w, best_time, best_w)) {
                best = a;
                best_time = t;
                best_w = w;
            }
        }
        return Decision(best, 0u);
    }
    return Decision(COPY, 0u);
}

// Record an error at position i in slot 0 (count) or 1 (rewrite): the
// lowest position wins (stored inverted, so zero means none).
fn report(slot: u32, i: u32, kind: u32) {
    atomicMax(&status[slot * 2u], 0xffffffffu - i);
    atomicOr(&status[slot * 2u + 1u], kind);
}

// Decide module i's production (recorded in `choice`, errors reported)
// and return its output size: (modules, parameter words).
fn count_one(i: u32) -> vec2<u32> {
    select_system(in_syms[i] >> SYS_SHIFT);
    let dec = decide(i);
    if (dec.err != 0u) {
        report(0u, i, dec.err);
    }
    choice[i] = dec.alt;
    if (dec.alt == COPY) {
        return vec2<u32>(1u, in_starts[i + 1u] - in_starts[i]);
    }
    let a = alt_at(dec.alt);
    return vec2<u32>(a.succ_len, a.succ_words);
}

@compute @workgroup_size(WORKGROUP)
fn count(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = wg_linear(wid, nwg) * WORKGROUP + lid;
    if (i > P.n) {
        return;
    }
    if (i == P.n) {
        // The slot after the last count: the scan leaves the totals here.
        counts[i] = vec2<u32>(0u, 0u);
        return;
    }
    counts[i] = count_one(i);
}

// Successor parameter `pe` of input module i, evaluated with draws d,
// written at out_params[dst ..]; a fault or a non-finite value is
// reported at i.
fn write_param(i: u32, pe: ParamExpr, d: Draws, dst: u32) {
    let bad = vm_param(pe, d);
    if ((bad & VM_PARAM_FAULT) != 0u) {
        report(1u, i, ERR_FAULT);
    }
    if ((bad & VM_PARAM_NON_FINITE) != 0u) {
        report(1u, i, ERR_NON_FINITE);
    }
    for (var c = 0u; c < pe.words; c = c + 1u) {
        out_params[dst + c] = vm_st[c];
    }
}

// The axiom (string 0), one thread per output module `o` (whatever the
// axioms' lengths, no thread writes more than one module: Mesa's lavapipe
// stops an invocation's loops after 65,535 iterations in all, and a thread
// writing a whole long axiom ran past that). `counts` holds the host's
// offsets of each system's axiom (P.n systems), and their totals at P.n.
// Every axiom is evaluated at iteration 0 with its system's root key (the
// CPU's `Engine::axiom`), and its modules' keys are children of the root
// key; an error is reported at the system's index.
fn write_axiom_module(o: u32) {
    if (o >= out_offset(P.n).x) {
        return;
    }
    // The last system whose axiom starts at or before o (the systems
    // before it with the same offset have empty axioms).
    var lo = 0u;
    var hi = P.n;
    while (hi - lo > 1u) {
        let mid = (lo + hi) / 2u;
        if (out_offset(mid).x <= o) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    select_system(lo);
    let off = out_offset(lo);
    let a = alt_at(TAB.axiom_alt);
    let m = succ_at(a.succ_offset + (o - off.x));
    out_syms[o] = m.symbol | (SYS_ID << SYS_SHIFT);
    var dst = off.y + m.word_offset;
    out_starts[o] = dst;
    if (P.keyed != 0u) {
        out_keys[o] = child_key(SYS.root_key, m.salt);
    }
    let d = Draws(SYS.seed, 0u, SYS.root_key);
    for (var q = m.first_param; q < m.first_param + m.param_count; q = q + 1u) {
        let pe = param_at(q);
        write_param(lo, pe, d, dst);
        dst = dst + pe.words;
    }
}

@compute @workgroup_size(WORKGROUP)
fn rewrite(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = wg_linear(wid, nwg) * WORKGROUP + lid;
    if (P.axiom != 0u) {
        write_axiom_module(i);
        return;
    }
    if (i > P.n) {
        return;
    }
    if (i == P.n) {
        // The thread after the last module: the last start is the total
        // of parameter words (the scan's totals are at n).
        let t = out_offset(i);
        out_starts[t.x] = t.y;
        return;
    }
    let off = out_offset(i);
    let o = off.x;
    let wo = off.y;
    select_system(in_syms[i] >> SYS_SHIFT);
    let alt = choice[i];
    if (alt == COPY) {
        out_syms[o] = in_syms[i];
        out_starts[o] = wo;
        if (P.keyed != 0u) {
            out_keys[o] = in_keys[i];
        }
        let s = in_starts[i];
        let e = in_starts[i + 1u];
        for (var k = 0u; k < e - s; k = k + 1u) {
            out_params[wo + k] = in_params[s + k];
        }
        return;
    }
    // Bind again (the decision is a pure function of the input, so the
    // chosen group matches again and binds the same words).
    bind_group(i, group_at(alt_at(alt).group));
    let a = alt_at(alt);
    let d = draws_at(i);
    for (var k = 0u; k < a.succ_len; k = k + 1u) {
        let m = succ_at(a.succ_offset + k);
        out_syms[o + k] = m.symbol | (SYS_ID << SYS_SHIFT);
        var dst = wo + m.word_offset;
        out_starts[o + k] = dst;
        if (P.keyed != 0u) {
            out_keys[o + k] = child_key(d.position, m.salt);
        }
        for (var q = m.first_param; q < m.first_param + m.param_count; q = q + 1u) {
            let pe = param_at(q);
            write_param(i, pe, d, dst);
            dst = dst + pe.words;
        }
    }
}

// Output offsets of this workgroup's input modules (and the one after).
var<workgroup> wg_off: array<u32, WG_OFF_LEN>;
// Per input module of the workgroup, loaded once by its own thread: the
// chosen alternative (`choice`), its first parameter word in the output,
// its system, its successor's first module in the tables, and whether its
// production binds parameters (contexts or the predecessor's).
var<workgroup> wg_alt: array<u32, WORKGROUP>;
var<workgroup> wg_wo: array<u32, WORKGROUP>;
var<workgroup> wg_sys: array<u32, WORKGROUP>;
var<workgroup> wg_succ: array<u32, WORKGROUP>;
var<workgroup> wg_bind: array<u32, WORKGROUP>;

// `rewrite` by output module (the host's choice for systems without
// contexts; same grid, same results): the workgroup's input modules
// [base, end) write the output range [counts[base].x, counts[end].x); its
// threads stride over that range, each output position finding its input
// module by binary search over the offsets in workgroup memory, then
// writing that one successor module (symbol, start, parameters evaluated
// with the same code and draws as `rewrite`, and its identity key). Writes are coalesced and the
// work is spread evenly however long the successors are. What an input
// module's outputs share (its production, system, offsets) is read from
// the tables once per input module, into workgroup memory, not once per
// output module.
@compute @workgroup_size(WORKGROUP)
fn rewrite_out(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let base = wg_linear(wid, nwg) * WORKGROUP;
    let end = min(base + WORKGROUP, P.n);
    let first = min(base, P.n);
    wg_off[lid] = out_offset(min(first + lid, end)).x;
    if (lid == 0u) {
        wg_off[WORKGROUP] = out_offset(end).x;
    }
    var selected = false;
    if (base + lid < end) {
        let i = base + lid;
        let sid = in_syms[i] >> SYS_SHIFT;
        select_system(sid);
        selected = true;
        let alt = choice[i];
        wg_alt[lid] = alt;
        wg_wo[lid] = out_offset(i).y;
        wg_sys[lid] = sid;
        if (alt != COPY) {
            let a = alt_at(alt);
            let g = group_at(a.group);
            wg_succ[lid] = a.succ_offset;
            wg_bind[lid] = select(
                0u,
                1u,
                (g.flags & GROUP_CONTEXT) != 0u || g.pred_bind_words > 0u,
            );
        }
    }
    workgroupBarrier();
    if (base + lid == P.n) {
        // The last start is the total of parameter words.
        let t = out_offset(P.n);
        out_starts[t.x] = t.y;
    }
    if (base >= P.n) {
        return;
    }
    let m = end - base;
    let o1 = wg_off[m];
    var cur = NONE;
    var alt = COPY;
    var succ = 0u;
    var wo = 0u;
    var d = Draws(0u, 0u, 0u);
    for (var o = wg_off[0] + lid; o < o1; o = o + WORKGROUP) {
        // wg_off[lo] <= o < wg_off[hi]
        var lo = 0u;
        var hi = m;
        while (hi - lo > 1u) {
            let mid = (lo + hi) / 2u;
            if (wg_off[mid] <= o) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let i = base + lo;
        let k = o - wg_off[lo];
        if (i != cur) {
            cur = i;
            let sid = wg_sys[lo];
            if (!selected || sid != SYS_ID) {
                select_system(sid);
                selected = true;
            }
            alt = wg_alt[lo];
            wo = wg_wo[lo];
            if (alt != COPY) {
                succ = wg_succ[lo];
                if (wg_bind[lo] != 0u) {
                    bind_group(i, group_at(alt_at(alt).group));
                }
                d = draws_at(i);
            }
        }
        if (alt == COPY) {
            out_syms[o] = in_syms[i];
            out_starts[o] = wo;
            if (P.keyed != 0u) {
                out_keys[o] = in_keys[i];
            }
            let s = in_starts[i];
            let e = in_starts[i + 1u];
            for (var c = 0u; c < e - s; c = c + 1u) {
                out_params[wo + c] = in_params[s + c];
            }
            continue;
        }
        let sm = succ_at(succ + k);
        out_syms[o] = sm.symbol | (SYS_ID << SYS_SHIFT);
        var dst = wo + sm.word_offset;
        out_starts[o] = dst;
        if (P.keyed != 0u) {
            // d.position: the input module's key (draws_at).
            out_keys[o] = child_key(d.position, sm.salt);
        }
        for (var q = sm.first_param; q < sm.first_param + sm.param_count; q = q + 1u) {
            let pe = param_at(q);
            write_param(i, pe, d, dst);
            dst = dst + pe.words;
        }
    }
}

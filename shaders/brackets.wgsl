// Bracket matching: for every `[` the position of its `]` and back, as the
// CPU engine's stack matching gives them (an unmatched bracket has none).
// Used for bracket-aware context matching (derive.wgsl) and for branching
// interpretation.
//
// Instead of Lipp's per-depth bucket sort (5.3.2), which needs the maximum
// depth in advance and a chunks x depth histogram, a `[` at i finds its
// `]` as the first position where the depth returns to the depth before i:
// with D[k] the depth before module k (a scan of (#[, #]) pairs), the
// partner is j = k - 1 for the first k >= i + 2 with D[k] <= D[i]. That
// query runs on a BRACKET_FAN-ary tree of block minima of D (levels built
// by `bracket_reduce`, which keeps the maxima too: the interpreter reads
// the depth range from the top level): scan forward in the own block,
// climb while the rest of the block is all deeper, then descend into the
// first block whose minimum qualifies. O(BRACKET_FAN * levels) reads per `[`, no depth
// limit, no atomics; unbalanced strings get the same partial matching as
// a stack (a stray `]` or `[` stays unmatched).
//!include grid.wgsl

@group(0) @binding(0) var<uniform> B: BracketParams;
@group(0) @binding(1) var<storage, read> tables: array<u32>;
@group(0) @binding(2) var<storage, read> syms: array<u32>;
@group(0) @binding(3) var<storage, read_write> pairs: array<vec2<u32>>;
@group(0) @binding(4) var<storage, read_write> levels: array<vec2<i32>>;
@group(0) @binding(5) var<storage, read_write> mate: array<u32>;
//!include generated_tables

fn lvl_off(l: u32) -> u32 {
    return B.offs[l / 4u][l % 4u];
}

fn lvl_len(l: u32) -> u32 {
    return B.lens[l / 4u][l % 4u];
}

// The flags of a module's symbol, from its own system's tables (the
// system index is above SYS_SHIFT; see derive.wgsl).
fn bracket_flags_of(raw: u32) -> u32 {
    let sys = load_SystemEntry((raw >> SYS_SHIFT) * SYSTEM_ENTRY_WORDS);
    tab_select(sys.base);
    return load_SymbolEntry(TAB_BASE + TAB.symbols_offset + (raw & SYM_MASK) * SYMBOL_ENTRY_WORDS).flags;
}

// pairs[k] = (is `[`, is `]`) for k < n, and (0, 0) at k = n.
@compute @workgroup_size(WORKGROUP)
fn bracket_flags(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let k = wg_linear(wid, nwg) * WORKGROUP + lid;
    if (k > B.n) {
        return;
    }
    var v = vec2<u32>(0u, 0u);
    if (k < B.n) {
        let f = bracket_flags_of(syms[k]);
        v = vec2<u32>(select(0u, 1u, (f & SYM_PUSH) != 0u), select(0u, 1u, (f & SYM_POP) != 0u));
        // No partner until bracket_match writes one.
        mate[k] = 0u;
    }
    pairs[k] = v;
}

// Level 0 of the minimum tree: the depth before each module (and after the last).
@compute @workgroup_size(WORKGROUP)
fn bracket_depth(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let k = wg_linear(wid, nwg) * WORKGROUP + lid;
    if (k > B.n) {
        return;
    }
    let p = pairs[k];
    let d = i32(p.x) - i32(p.y);
    levels[k] = vec2<i32>(d, d);
}

// Level B.level + 1 from level B.level: the minimum and maximum of each block.
@compute @workgroup_size(WORKGROUP)
fn bracket_reduce(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let b = wg_linear(wid, nwg) * WORKGROUP + lid;
    let l = B.level;
    if (b >= lvl_len(l + 1u)) {
        return;
    }
    let src = lvl_off(l);
    let len = lvl_len(l);
    let first = b * BRACKET_FAN;
    var m = levels[src + first];
    for (var k = first + 1u; k < min(first + BRACKET_FAN, len); k = k + 1u) {
        let v = levels[src + k];
        m = vec2<i32>(min(m.x, v.x), max(m.y, v.y));
    }
    levels[lvl_off(l + 1u) + b] = m;
}

// The first index >= `start` at level 0 with depth <= `limit`, or NONE.
fn first_at_most(start: u32, limit: i32) -> u32 {
    var l = 0u;
    var pos = start;
    // Climb.
    loop {
        let len = lvl_len(l);
        if (pos >= len) {
            return NONE;
        }
        let end = min((pos / BRACKET_FAN + 1u) * BRACKET_FAN, len);
        let off = lvl_off(l);
        var found = NONE;
        for (var k = pos; k < end; k = k + 1u) {
            if (levels[off + k].x <= limit) {
                found = k;
                break;
            }
        }
        if (found != NONE) {
            pos = found;
            break;
        }
        if (end >= len || l + 1u >= B.levels) {
            return NONE;
        }
        l = l + 1u;
        pos = end / BRACKET_FAN;
    }
    // Descend: the block at `pos` holds a qualifying entry; find the first.
    loop {
        if (l == 0u) {
            return pos;
        }
        l = l - 1u;
        let off = lvl_off(l);
        let first = pos * BRACKET_FAN;
        let end = min(first + BRACKET_FAN, lvl_len(l));
        var found = end;
        for (var k = first; k < end; k = k + 1u) {
            if (levels[off + k].x <= limit) {
                found = k;
                break;
            }
        }
        pos = found;
    }
    return NONE;
}

@compute @workgroup_size(WORKGROUP)
fn bracket_match(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = wg_linear(wid, nwg) * WORKGROUP + lid;
    if (i >= B.n) {
        return;
    }
    if (pairs[i + 1u].x == pairs[i].x) {
        return;
    }
    // A `[` at i: the depth returns to levels[i] right after its `]`,
    // which must be in the same system.
    let k = first_at_most(i + 2u, levels[i].x);
    let sys = load_SystemEntry((syms[i] >> SYS_SHIFT) * SYSTEM_ENTRY_WORDS);
    if (k != NONE && k <= sys.end) {
        let j = k - 1u;
        mate[i] = j + 1u;
        mate[j] = i + 1u;
    }
}

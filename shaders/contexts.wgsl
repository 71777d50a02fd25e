// Context matching for derive.wgsl (its `match_contexts`), bracket-aware
// with the ignore list as the CPU engine matches: left towards the root
// over complete branches, right forward in the branch over lateral
// branches, `[`/`]` items entering a branch / skipping to its end. Bracket
// partners come from the `mate` binding (brackets.wgsl).

// 1 for `[`, 2 for `]`, 0 otherwise.
fn bracket_kind(s: u32) -> u32 {
    let f = sym_flags(s);
    if ((f & SYM_PUSH) != 0u) {
        return 1u;
    }
    if ((f & SYM_POP) != 0u) {
        return 2u;
    }
    return 0u;
}

// The bracket partner of the module at p, or NONE (stored as partner + 1).
fn mate_of(p: u32) -> u32 {
    let m = mate[p];
    return select(m - 1u, NONE, m == 0u);
}

fn match_left(i: u32, g: GroupHeader) -> bool {
    var pos = i;
    for (var t = g.left_len; t > 0u; t = t - 1u) {
        let item = ctx_at(g.left_offset + t - 1u);
        loop {
            if (pos == SYS.start) {
                return false;
            }
            pos = pos - 1u;
            let s = sym_at(pos);
            let bk = bracket_kind(s);
            if (bk == 2u) {
                let m = mate_of(pos);
                if (m == NONE) {
                    return false;
                }
                pos = m;
            } else if (bk == 1u) {
                // Leave the enclosing branch: its parent is before it.
            } else if ((sym_flags(s) & SYM_IGNORED) != 0u) {
            } else {
                break;
            }
        }
        if (item.kind != CTX_SYMBOL || sym_at(pos) != item.symbol) {
            return false;
        }
        if (item.bind_words > 0u) {
            bind_module(pos, item.bind_offset);
        }
    }
    return true;
}

fn match_right(i: u32, g: GroupHeader) -> bool {
    let n = SYS.end;
    var pos = i + 1u;
    for (var t = 0u; t < g.right_len; t = t + 1u) {
        let item = ctx_at(g.right_offset + t);
        if (item.kind == CTX_SYMBOL) {
            loop {
                if (pos >= n) {
                    return false;
                }
                let s = sym_at(pos);
                let bk = bracket_kind(s);
                if (bk == 1u) {
                    let m = mate_of(pos);
                    if (m == NONE) {
                        return false;
                    }
                    pos = m + 1u;
                } else if (bk == 2u) {
                    return false;
                } else if ((sym_flags(s) & SYM_IGNORED) != 0u) {
                    pos = pos + 1u;
                } else {
                    break;
                }
            }
            if (sym_at(pos) != item.symbol) {
                return false;
            }
            if (item.bind_words > 0u) {
                bind_module(pos, item.bind_offset);
            }
            pos = pos + 1u;
        } else if (item.kind == CTX_PUSH) {
            // Enter the next lateral branch (ignored symbols may come first).
            loop {
                if (pos >= n) {
                    return false;
                }
                let s = sym_at(pos);
                let bk = bracket_kind(s);
                if (bk == 1u) {
                    pos = pos + 1u;
                    break;
                }
                if (bk == 0u && (sym_flags(s) & SYM_IGNORED) != 0u) {
                    pos = pos + 1u;
                    continue;
                }
                return false;
            }
        } else {
            // `]`: skip the rest of the current branch, up to and including its `]`.
            loop {
                if (pos >= n) {
                    return false;
                }
                let bk = bracket_kind(sym_at(pos));
                if (bk == 2u) {
                    pos = pos + 1u;
                    break;
                }
                if (bk == 1u) {
                    let m = mate_of(pos);
                    if (m == NONE) {
                        return false;
                    }
                    pos = m + 1u;
                } else {
                    pos = pos + 1u;
                }
            }
        }
    }
    return true;
}

fn match_contexts(i: u32, g: GroupHeader) -> bool {
    return match_left(i, g) && match_right(i, g);
}

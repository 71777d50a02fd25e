//! Whole-system analyses over the grouped productions: shadowing,
//! ambiguity, reachability, and the phase rules of sample systems
//! (docs/language.md section 7), including termination of geometry symbols.

use grm_diag::{Code, Diagnostic, Span};

use crate::builtins::Terminal;
use crate::program::*;
use crate::suggest;

/// Symbols that can derive a string of finished symbols.
///
/// `initially[s]` marks symbols that are finished as they are; `prods` lists
/// (predecessor, successor symbols) of every alternative. The classic
/// productive-symbol fixpoint, in linear time: each alternative counts its
/// unfinished successor occurrences, and a symbol that becomes productive
/// decrements the counts of the alternatives it occurs in.
pub fn productive(initially: &[bool], prods: &[(usize, Vec<usize>)]) -> Vec<bool> {
    let n = initially.len();
    let mut done = initially.to_vec();
    let mut missing: Vec<usize> = Vec::with_capacity(prods.len());
    let mut occurs: Vec<Vec<usize>> = vec![Vec::new(); n];
    let mut work: Vec<usize> = Vec::new();
    for (pi, (pred, succ)) in prods.iter().enumerate() {
        let mut m = 0;
        for &s in succ {
            if s < n && !done[s] {
                m += 1;
                occurs[s].push(pi);
            }
        }
        missing.push(m);
        if m == 0 && *pred < n && !done[*pred] {
            done[*pred] = true;
            work.push(*pred);
        }
    }
    while let Some(s) = work.pop() {
        for &pi in &occurs[s] {
            missing[pi] -= 1;
            let pred = prods[pi].0;
            if missing[pi] == 0 && pred < n && !done[pred] {
                done[pred] = true;
                work.push(pred);
            }
        }
    }
    done
}

/// Symbols reachable from `roots` along `edges[s]` (breadth first).
pub fn reachable(n: usize, roots: &[usize], edges: &[Vec<usize>]) -> Vec<bool> {
    let mut seen = vec![false; n];
    let mut queue: std::collections::VecDeque<usize> = std::collections::VecDeque::new();
    for &r in roots {
        if r < n && !seen[r] {
            seen[r] = true;
            queue.push_back(r);
        }
    }
    while let Some(s) = queue.pop_front() {
        for &t in edges.get(s).map(Vec::as_slice).unwrap_or(&[]) {
            if t < n && !seen[t] {
                seen[t] = true;
                queue.push_back(t);
            }
        }
    }
    seen
}

/// The modules a name written without spaces would be if each letter were
/// one symbol, when that reading is what the author most likely meant:
/// every letter is a drawing command (`F f G g`) or a one-letter symbol the
/// system rewrites, and the name itself is never rewritten or declared.
/// `None` for any other name.
/// `letters`: [`rewritten_letters`] of `sys`.
pub fn run_together_split(
    info: &SymbolInfo,
    letters: &std::collections::HashSet<char>,
) -> Option<String> {
    if info.is_terminal()
        || info.name.chars().count() < 2
        || info.arity != 0
        || info.decl.is_some()
        || !info.groups.is_empty()
        || !info.wrapup_groups.is_empty()
    {
        return None;
    }
    let mut drawing = false;
    for c in info.name.chars() {
        if matches!(c, 'F' | 'f' | 'G' | 'g') {
            drawing = true;
            continue;
        }
        if !letters.contains(&c) {
            return None;
        }
    }
    // `AB` made only of rewritten symbols may be a deliberate marker; a
    // drawing letter in it is the book's notation (`FF`, `YF`).
    drawing.then(|| {
        let letters: Vec<String> = info.name.chars().map(String::from).collect();
        letters.join(" ")
    })
}

/// The one-letter names of the symbols `sys` rewrites (not terminals):
/// what [`run_together_split`] may split a name into, found once per
/// system (per name it was quadratic in the symbols).
pub fn rewritten_letters(sys: &System) -> std::collections::HashSet<char> {
    sys.symbols
        .iter()
        .filter(|o| !o.is_terminal() && !o.groups.is_empty())
        .filter_map(|o| {
            let mut cs = o.name.chars();
            match (cs.next(), cs.next()) {
                (Some(c), None) => Some(c),
                _ => None,
            }
        })
        .collect()
}

/// W0011: `FF` written as in the books is one symbol here, never rewritten
/// and drawing nothing.
fn check_run_together(sys: &System, diags: &mut Vec<Diagnostic>) {
    let letters = rewritten_letters(sys);
    for info in &sys.symbols {
        let Some(split) = run_together_split(info, &letters) else {
            continue;
        };
        let name = &info.name;
        let n = name.chars().count();
        let count = [
            "two", "three", "four", "five", "six", "seven", "eight", "nine",
        ]
        .get(n - 2)
        .map_or_else(|| n.to_string(), |w| w.to_string());
        diags.push(
            Diagnostic::new(
                Code::RunTogether,
                format!("`{name}` is one symbol, not {count} modules"),
                sys.file,
                info.first,
                "one symbol, never rewritten, draws nothing",
            )
            .with_note("module names are whole identifiers: separate modules with spaces")
            .with_help(format!("write `{split}`")),
        );
    }
}

/// W0016 (a weight on a group's only production), W0005 (ambiguous
/// groups), W0009 (contexts naming ignored symbols), W0003
/// (shadowed groups) and, unless `skip_reach`,
/// W0002 (unreachable productions).
pub(crate) fn check_groups(sys: &System, diags: &mut Vec<Diagnostic>, skip_reach: bool) {
    let file = sys.file;
    for g in &sys.groups {
        if let [only] = &g.alternatives[..]
            && only.weight_written
            && only.weight.ty != Ty::Error
        {
            let name = &sys.symbol(g.pred.symbol).name;
            diags.push(
                Diagnostic::new(
                    Code::LoneWeight,
                    format!("the weight of the only production for `{name}` in this case has no effect"),
                    file,
                    only.weight.span,
                    "always applies",
                )
                .with_note("a weight is a share among the productions of a group (same predecessor, contexts and condition); alone, it always applies")
                .with_help(format!(
                    "remove the weight; to apply it only some of the time, add an alternative that keeps the module, e.g. `{name} -> (1) {name};` (with its parameters)"
                )),
            );
        }
        let unweighted: Vec<&Alternative> = g
            .alternatives
            .iter()
            .filter(|a| !a.weight_written)
            .collect();
        if unweighted.len() >= 2 {
            let name = &sys.symbol(g.pred.symbol).name;
            diags.push(
                Diagnostic::new(
                    Code::AmbiguousProductions,
                    format!("several productions for `{name}` apply in the same case, without weights"),
                    file,
                    unweighted[1].pred,
                    "another alternative",
                )
                .with_label(file, unweighted[0].pred, "first alternative")
                .with_note("one of them is drawn at random, each with weight 1")
                .with_help("write the weights, e.g. `-> (1) ...`, or give the productions different conditions"),
            );
        }
    }

    // Contexts that name an ignored symbol never match (docs/language.md,
    // "Context matching"). Sample systems reject contexts altogether.
    if sys.mode == Mode::Derive && !sys.ignore.is_empty() {
        for g in &sys.groups {
            for c in g.left.iter().chain(&g.right) {
                if let TContextItem::Pattern(p) = c
                    && sys.ignore.contains(&p.symbol)
                {
                    let name = &sys.symbol(p.symbol).name;
                    diags.push(
                        Diagnostic::new(
                            Code::IgnoredInContext,
                            format!("`{name}` is in the ignore list, so this context never matches"),
                            file,
                            p.span,
                            "ignored while matching",
                        )
                        .with_note("ignored symbols are skipped while matching contexts, even where a context names them")
                        .with_help(format!("remove `{name}` from the ignore list, or from this context")),
                    );
                }
            }
        }
    }

    if sys.mode == Mode::Derive {
        check_run_together(sys, diags);
    }

    for info in &sys.symbols {
        let mut catch_all: Option<&Group> = None;
        for gid in &info.groups {
            let g = &sys.groups[gid.index()];
            if let Some(first) = catch_all {
                let name = &info.name;
                diags.push(
                    Diagnostic::new(
                        Code::ShadowedProduction,
                        format!("this production for `{name}` can never apply"),
                        file,
                        g.alternatives[0].pred,
                        "never tried",
                    )
                    .with_label(
                        file,
                        first.alternatives[0].span,
                        "this earlier production always applies first",
                    )
                    .with_note(
                        "productions are tried in source order; the first that matches is applied",
                    )
                    .with_help(
                        "move it before the unconditional production, or give that one a condition",
                    ),
                );
                continue;
            }
            let always = !g.has_context()
                && match &g.condition {
                    None => true,
                    Some(c) => c.constant() == Some(Value::Bool(true)),
                };
            if always {
                catch_all = Some(g);
            }
        }
    }

    if skip_reach {
        return;
    }
    let n = sys.symbols.len();
    let mut edges: Vec<Vec<usize>> = vec![Vec::new(); n];
    for g in &sys.groups {
        let out = &mut edges[g.pred.symbol.index()];
        for a in &g.alternatives {
            out.extend(a.successor.iter().map(|m| m.symbol.index()));
        }
    }
    for e in &mut edges {
        e.sort_unstable();
        e.dedup();
    }
    let roots: Vec<usize> = sys.axiom.iter().map(|m| m.symbol.index()).collect();
    let seen = reachable(n, &roots, &edges);
    // The names a typo could have meant: reachable symbols that nothing
    // rewrites (found once, not once per unreachable symbol: that was
    // quadratic in the symbols).
    let letters = rewritten_letters(sys);
    let nothing_rewrites: Vec<&str> = sys
        .symbols
        .iter()
        .enumerate()
        .filter(|(t, o)| {
            seen[*t]
                && !o.is_terminal()
                && o.groups.is_empty()
                && o.wrapup_groups.is_empty()
                // W0011 explains those (`FX` for `F X`).
                && (sys.mode != Mode::Derive || run_together_split(o, &letters).is_none())
        })
        .map(|(_, o)| o.name.as_str())
        .collect();
    for (s, info) in sys.symbols.iter().enumerate() {
        // Productions for `[` and `]` are E0311 already.
        if seen[s]
            || matches!(
                info.kind,
                SymbolKind::Terminal(Terminal::Push | Terminal::Pop)
            )
        {
            continue;
        }
        // Productions whose every condition is already an error (ABoP's
        // label `p1: F -> F F` reads as a predecessor `p1` whose condition
        // is the unknown name `F`) say nothing more by being unreachable.
        if info
            .groups
            .iter()
            .chain(&info.wrapup_groups)
            .all(|id| matches!(&sys.groups[id.index()].condition, Some(c) if c.ty == Ty::Error))
        {
            continue;
        }
        let mut gids = info.groups.iter().chain(&info.wrapup_groups);
        let Some(first) = gids.next() else {
            continue;
        };
        let g = &sys.groups[first.index()];
        let mut d = Diagnostic::new(
            Code::UnreachableProduction,
            format!(
                "`{}` never occurs in a derivation, so its productions never apply",
                info.name
            ),
            file,
            g.alternatives[0].pred,
            "unreachable",
        );
        for other in g
            .alternatives
            .iter()
            .skip(1)
            .chain(gids.flat_map(|id| &sys.groups[id.index()].alternatives))
            .take(3)
        {
            d = d.with_label(file, other.pred, "also unreachable");
        }
        // A reachable symbol that nothing rewrites, spelt nearly the same
        // (`Plant` in the axiom, productions for `plant`): likely a typo.
        // One- and two-letter names are all one edit apart (`X` for `G`):
        // only a difference of case counts for them.
        let short = info.name.chars().count() < 3;
        let near = suggest::best(
            &info.name,
            nothing_rewrites
                .iter()
                .copied()
                .filter(|o| !short || o.to_lowercase() == info.name.to_lowercase()),
        );
        let written = near.and_then(|near| {
            let modules = sys.axiom.iter().chain(
                sys.groups
                    .iter()
                    .filter(|g| seen[g.pred.symbol.index()])
                    .flat_map(|g| g.alternatives.iter().flat_map(|a| &a.successor)),
            );
            let mut at = modules.filter(|m| sys.symbol(m.symbol).name == near);
            at.next().map(|m| (near, m.span))
        });
        match written {
            Some((near, at)) => {
                d = d.with_label(file, at, format!("`{near}` is written here, and nothing rewrites it"));
                diags.push(d.with_help(format!(
                    "did you mean `{}` where `{near}` is written?",
                    info.name
                )));
            }
            None => diags.push(d.with_help(format!(
                "emit `{}` from the axiom or from a reachable production, or remove these productions",
                info.name
            ))),
        }
    }
}

fn context_span(items: &[TContextItem]) -> Option<Span> {
    let span = |c: &TContextItem| match c {
        TContextItem::Pattern(p) => p.span,
        TContextItem::Push(s) | TContextItem::Pop(s) => *s,
    };
    Some(span(items.first()?).to(span(items.last()?)))
}

/// The phase rules of sample systems (E0301-E0308, E0313, and E0101 for
/// symbols that are neither declared nor rewritten). With `holes` (parse
/// errors in the system) the whole-system rules are skipped. Rewriting one
/// of `declared` (terminals whose declaration was already refused) is not
/// reported again.
pub(crate) fn check_sample(
    sys: &System,
    diags: &mut Vec<Diagnostic>,
    holes: bool,
    declared: &[Terminal],
) {
    let file = sys.file;
    let mut phase_reported = vec![false; sys.symbols.len()];
    // The contexts reported below: a symbol first seen in one is part of
    // that mistake, not an unknown symbol of its own.
    let mut contexts: Vec<Span> = Vec::new();
    for g in &sys.groups {
        let pred = sys.symbol(g.pred.symbol);
        for items in [&g.left, &g.right] {
            if let Some(span) = context_span(items) {
                contexts.push(span);
                diags.push(
                    Diagnostic::new(
                        Code::ContextInSampleMode,
                        "sample systems cannot use context-sensitive productions",
                        file,
                        span,
                        "context",
                    )
                    .with_note("the guided search expands one symbol at a time, so its neighbours are not known yet")
                    .with_help("remove the context, or run the system with `mode = derive;`"),
                );
            }
        }
        if let Some(t) = pred.terminal() {
            if declared.contains(&t) {
                continue;
            }
            diags.push(
                Diagnostic::new(
                    Code::TerminalPredecessor,
                    format!(
                        "`{}` is a terminal and cannot be rewritten in a sample system",
                        t.name()
                    ),
                    file,
                    g.pred.span,
                    "terminal",
                )
                .with_help("rewrite a skeleton or geometry symbol that emits it instead"),
            );
            continue;
        }
        if pred.phase == Phase::None {
            if !phase_reported[g.pred.symbol.index()] {
                phase_reported[g.pred.symbol.index()] = true;
                diags.push(
                    Diagnostic::new(
                        Code::MissingPhase,
                        format!("`{}` has productions but no phase", pred.name),
                        file,
                        g.pred.span,
                        "non-terminal without a phase",
                    )
                    .with_help(format!(
                        "declare it `skeleton {0};` (grown during the search) or `geometry {0};` (expanded after it)",
                        pred.name
                    )),
                );
            }
            continue;
        }
        if g.wrapup && pred.phase == Phase::Geometry {
            let decl = pred.decl.unwrap_or(pred.first);
            diags.push(
                Diagnostic::new(
                    Code::WrapupNotSkeleton,
                    format!(
                        "`{}` is a geometry symbol; only skeleton symbols are wrapped up",
                        pred.name
                    ),
                    file,
                    g.pred.span,
                    "not a skeleton symbol",
                )
                .with_label(file, decl, "declared `geometry` here")
                .with_help("geometry symbols are expanded to completion anyway; remove `wrapup`"),
            );
            continue;
        }
        for a in &g.alternatives {
            for m in &a.successor {
                let s = sys.symbol(m.symbol);
                if pred.phase == Phase::Skeleton && s.is_geometry_terminal() {
                    diags.push(
                        Diagnostic::new(
                            Code::SkeletonEmitsGeometry,
                            format!("skeleton symbol `{}` emits the geometry terminal `{}`", pred.name, s.name),
                            file,
                            m.span,
                            "geometry terminal",
                        )
                        .with_label(file, a.pred, "a skeleton symbol")
                        .with_help(format!(
                            "decorate instead: emit a geometry symbol (`geometry deco;`) whose production emits `{}`",
                            s.name
                        )),
                    );
                }
                if s.phase == Phase::Skeleton && g.wrapup {
                    diags.push(
                        Diagnostic::new(
                            Code::WrapupLeavesSkeleton,
                            format!("the wrap-up of `{}` emits the skeleton symbol `{}`", pred.name, s.name),
                            file,
                            m.span,
                            "skeleton symbol",
                        )
                        .with_note("wrap-up runs once, when the search ends; what it emits is never expanded by the search")
                        .with_help("emit only terminals and geometry symbols in a wrap-up"),
                    );
                } else if s.phase == Phase::Skeleton && pred.phase == Phase::Geometry {
                    diags.push(
                        Diagnostic::new(
                            Code::GeometryEmitsSkeleton,
                            format!("geometry symbol `{}` emits the skeleton symbol `{}`", pred.name, s.name),
                            file,
                            m.span,
                            "skeleton symbol",
                        )
                        .with_label(file, a.pred, "a geometry symbol")
                        .with_note("geometry symbols are expanded after the search; the skeleton is finished by then")
                        .with_help("emit the skeleton symbol from a skeleton production instead"),
                    );
                }
            }
        }
    }

    for info in &sys.symbols {
        if info.phase == Phase::Skeleton && info.wrapup_groups.is_empty() {
            let at = info.decl.unwrap_or(info.first);
            diags.push(
                Diagnostic::new(
                    Code::MissingWrapup,
                    format!("skeleton symbol `{}` has no wrap-up production", info.name),
                    file,
                    at,
                    "no `wrapup` for this symbol",
                )
                .with_note(
                    "when the search ends, every open skeleton symbol is closed by its wrap-up",
                )
                .with_help(format!("add one, e.g. `wrapup {} -> ;`", info.name)),
            );
        }
    }

    if holes {
        return;
    }

    // Symbols used but neither declared nor rewritten.
    // Prepared once for all the unknown symbols of the system.
    let known = crate::suggest::Candidates::new(
        sys.symbols
            .iter()
            .filter(|s| !s.is_terminal() && (s.decl.is_some() || !s.groups.is_empty()))
            .map(|s| s.name.as_str())
            .collect(),
    );
    let letters = rewritten_letters(sys);
    for info in &sys.symbols {
        if info.is_terminal()
            || info.decl.is_some()
            || !info.groups.is_empty()
            || !info.wrapup_groups.is_empty()
            || contexts
                .iter()
                .any(|c| c.start <= info.first.start && info.first.end <= c.end)
        {
            continue;
        }
        let mut d = Diagnostic::new(
            Code::UnknownName,
            format!("unknown symbol `{}`", info.name),
            file,
            info.first,
            "not declared, and no production rewrites it",
        );
        // Modules run together (`bF` for `b F`) before a near spelling.
        d = match run_together_split(info, &letters) {
            Some(split) => d
                .with_note("module names are whole identifiers: separate modules with spaces")
                .with_help(format!("write `{split}`")),
            None => match known.did_you_mean(&info.name) {
                Some(h) => d.with_help(h),
            None => d.with_help(format!(
                "declare it (`geometry {0};` or `module {0};`) if it is meant to stay in the model",
                    info.name
                )),
            },
        };
        diags.push(d);
    }

    // Termination of geometry symbols.
    let initially: Vec<bool> = sys
        .symbols
        .iter()
        .map(|s| s.phase != Phase::Geometry || s.groups.is_empty())
        .collect();
    let mut prods = Vec::new();
    for g in sys.groups.iter().filter(|g| !g.wrapup) {
        let pred = g.pred.symbol.index();
        if initially[pred] {
            continue;
        }
        for a in &g.alternatives {
            prods.push((pred, a.successor.iter().map(|m| m.symbol.index()).collect()));
        }
    }
    let done = productive(&initially, &prods);
    for (s, info) in sys.symbols.iter().enumerate() {
        if done[s] {
            continue;
        }
        let at = info.decl.unwrap_or(info.first);
        diags.push(
            Diagnostic::new(
                Code::NonTerminating,
                format!("geometry symbol `{}` can never finish expanding", info.name),
                file,
                at,
                "never terminates",
            )
            .with_note(
                "every production for it emits it again, or another symbol that never finishes",
            )
            .with_help(format!(
                "add a production that ends the recursion, e.g. `{} -> ;` under a condition",
                info.name
            )),
        );
    }

    // Skeleton symbols that can neither draw a bone nor finish.
    let grows = sys.skeleton_grows();
    let is_skeleton = |i: usize| sys.symbols[i].phase == Phase::Skeleton;
    for (i, info) in sys.symbols.iter().enumerate() {
        if !is_skeleton(i) || info.groups.is_empty() || grows[i] {
            continue;
        }
        diags.push(
            Diagnostic::new(
                Code::SkeletonNeverGrows,
                format!("skeleton symbol `{}` never draws a bone", info.name),
                file,
                info.decl.unwrap_or(info.first),
                "never grows",
            )
            .with_note(
                "every production for it emits it again, or another skeleton symbol that never draws, without a bone: the search can never score a bone from it, and stops expanding a particle left with only such symbols",
            )
            .with_help(format!(
                "draw a bone in one of its productions (`{0} -> F(1) {0};`), or end it with one that emits no skeleton symbol",
                info.name
            )),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn productive_fixpoint_finds_finishing_symbols() {
        // 0: terminal. 1 -> 0 (finishes). 2 -> 2 (loops). 3 -> 2 | 1 (finishes via 1).
        // 4 -> 4 2 (loops).
        let initially = [true, false, false, false, false];
        let prods = vec![
            (1, vec![0]),
            (2, vec![2]),
            (3, vec![2]),
            (3, vec![1, 0]),
            (4, vec![4, 2]),
        ];
        assert_eq!(
            productive(&initially, &prods),
            vec![true, true, false, true, false]
        );
    }

    #[test]
    fn productive_counts_repeated_occurrences() {
        // 1 -> 2 2, 2 -> (empty): both finish.
        let initially = [true, false, false];
        let prods = vec![(1, vec![2, 2]), (2, vec![])];
        assert_eq!(productive(&initially, &prods), vec![true, true, true]);
    }

    #[test]
    fn productive_chain_resolves_in_reverse_order() {
        // 1 -> 2, 2 -> 3, ..., 999 -> 0: a long chain resolved without recursion.
        let n = 1000;
        let mut initially = vec![false; n];
        initially[0] = true;
        let prods: Vec<(usize, Vec<usize>)> = (1..n).map(|i| (i, vec![(i + 1) % n])).collect();
        assert!(productive(&initially, &prods).iter().all(|&b| b));
    }

    #[test]
    fn reachability_follows_edges_only() {
        let edges = vec![vec![1], vec![2], vec![], vec![0]];
        assert_eq!(reachable(4, &[0], &edges), vec![true, true, true, false]);
    }
}

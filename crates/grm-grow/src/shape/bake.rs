//! Baking a persistent edit into the grammar (issue 27, item 7;
//! docs/edits.md, "Baking"): a semantic edit becomes a condition on the
//! rules of its target's symbol, so the grammar alone grows what the
//! grammar and the edit grew, and the edit can be deleted.
//!
//! The query `(floor = 3, column = end 1) Window` becomes the condition
//! `tagged(floor) && index(floor) == 3 && tagged(column) &&
//! count(column) - index(column) == 0` on `Window`'s rules
//! ([`condition`]). What is baked, exactly (the same tree, keys and draws
//! included):
//!
//! - **`force k`**: the k-th rule's condition becomes `C || (its
//!   condition)` (none: it holds already) and every other rule's
//!   `!(C) && (its condition)` (none: `!(C)`), so for the selected shapes
//!   the k-th alternative is the only one that holds and wins its race,
//!   and every other shape sees the rules as they were. The alternative
//!   keeps its number, so the keys its children are minted with and its
//!   draws are the replay's. Refused when the k-th rule's weight is not a
//!   number (a forced alternative ignores its weight; a baked one races
//!   with it).
//! - **`material m`** on a symbol without rules (a terminal shape): a
//!   rule `Window : C -> material(m);`, which draws the shape as it was,
//!   in `m`. A symbol with rules is refused: a forced material overrides
//!   what the rules below set, which no rule of the grammar can say.
//!
//! Refused too: targets other than a semantic query with a label, a tag
//! named twice, a tree where a selected symbol's path holds a named tag
//! twice (`index(t)` reads the nearest), and the other operations.

use crate::shape::Lowered;
use grm_diag::Span;
use grm_edits::locator::{Anchor, SemanticQuery};
use grm_edits::{Edit, Op, Target};
use grm_sema::TExprKind;
use grm_shape::{NodeKind, ShapeTree};

/// The text edits that bake an edit, in the system's file.
#[derive(Clone, Debug, PartialEq)]
pub struct Baked {
    /// Insertions (empty spans) and replacements, ascending, apart.
    pub edits: Vec<(Span, String)>,
    /// The condition written (`tagged(floor) && index(floor) == 3`).
    pub condition: String,
    /// The symbol whose rules change.
    pub symbol: String,
}

impl Baked {
    /// `text` with the edits applied.
    pub fn apply(&self, text: &str) -> String {
        let mut out = text.to_owned();
        for (span, t) in self.edits.iter().rev() {
            out.replace_range(span.range(), t);
        }
        out
    }
}

/// The condition that holds exactly for the shapes `query` selects among
/// those of its label (each tag it names appearing at most once on their
/// paths).
pub fn condition(query: &SemanticQuery) -> String {
    let mut parts = Vec::new();
    for (tag, anchor, n) in &query.entries {
        parts.push(format!("tagged({tag})"));
        parts.push(match anchor {
            Anchor::Start => format!("index({tag}) == {n}"),
            Anchor::End => format!("count({tag}) - index({tag}) == {}", n - 1),
            Anchor::Centre => format!("index({tag}) - ceil(count({tag}) / 2) == {n}"),
        });
    }
    if parts.is_empty() {
        "true".to_owned()
    } else {
        parts.join(" && ")
    }
}

/// Bake `edit` (of `system`, whose source text is `source`) into the
/// grammar; `tree` is the system's tree (to check the query's tags), or
/// why it cannot be baked.
pub fn bake(
    system: &grm_sema::System,
    lowered: &Lowered,
    tree: &ShapeTree,
    source: &str,
    edit: &Edit,
) -> Result<Baked, String> {
    let Target::Semantic(query) = &edit.target else {
        return Err("only an edit with a semantic target is baked (a condition names what a query selects; an exact locator or key names one part)".to_owned());
    };
    let Some(label) = &query.label else {
        return Err("the query names no symbol: the condition has no rule to go on".to_owned());
    };
    let shape = system
        .shape
        .as_deref()
        .ok_or_else(|| format!("system `{}` has no shape rules", system.name))?;
    let symbol = system
        .symbols
        .iter()
        .position(|s| s.name == *label)
        .ok_or_else(|| format!("the grammar has no symbol `{label}`"))?;
    for (i, (t, ..)) in query.entries.iter().enumerate() {
        if query.entries[..i].iter().any(|(u, ..)| u == t) {
            return Err(format!(
                "the query names `{t}` twice: a condition reads only the nearest `{t}`"
            ));
        }
    }
    // `index(t)` reads the nearest command tagged `t`: every shape of the
    // symbol must have each named tag at most once on its path.
    let program = &lowered.program;
    if let Some(sym) = program.symbol(label) {
        for (i, n) in tree.nodes().iter().enumerate() {
            if !matches!(n.kind, NodeKind::Shape { symbol: s, .. } if s == sym) {
                continue;
            }
            let loc = tree.semantic_locator(program, grm_shape::NodeId(i as u32));
            for (t, ..) in &query.entries {
                if loc.entries.iter().filter(|e| e.tag == *t).count() > 1 {
                    return Err(format!(
                        "a `{label}` has `{t}` twice on its path: a condition reads only the nearest"
                    ));
                }
            }
        }
    }
    let cond = condition(query);
    let rules: Vec<&grm_sema::shape::ShapeRule> = shape.rules_of(symbol as u32).collect();
    let src_len = source.len();
    let in_text = |s: Span| (s.end as usize) <= src_len && s.start <= s.end;
    let mut edits: Vec<(Span, String)> = Vec::new();
    match &edit.op {
        Op::Force { alternative } => {
            let k = *alternative as usize;
            let Some(forced) = rules.get(k.wrapping_sub(1)) else {
                return Err(format!(
                    "`{label}` has {} rule{}, not {k}",
                    rules.len(),
                    if rules.len() == 1 { "" } else { "s" }
                ));
            };
            if forced.weight_written && !matches!(forced.weight.kind, TExprKind::Lit(_)) {
                return Err(format!(
                    "rule {k} of `{label}` has a weight that is not a number: forced, it is ignored; baked, it would race"
                ));
            }
            for (i, r) in rules.iter().enumerate() {
                let mine = i + 1 == k;
                match &r.condition {
                    Some(c) if in_text(c.span) => {
                        let (open, close) = if mine {
                            (format!("({cond}) || ("), ")".to_owned())
                        } else {
                            (format!("!({cond}) && ("), ")".to_owned())
                        };
                        edits.push((Span::new(c.span.start, c.span.start), open));
                        edits.push((Span::new(c.span.end, c.span.end), close));
                    }
                    Some(_) => return Err("a rule's condition is not in the file".to_owned()),
                    None if mine => {}
                    None if in_text(r.pred) => {
                        edits.push((Span::new(r.pred.end, r.pred.end), format!(" : !({cond})")));
                    }
                    None => return Err("a rule is not in the file".to_owned()),
                }
            }
        }
        Op::Material { name } => {
            if !rules.is_empty() {
                return Err(format!(
                    "`{label}` has rules: a baked material would be overridden by what they set below (only a shape without rules takes one)"
                ));
            }
            let last = shape
                .rules
                .iter()
                .map(|r| r.span)
                .filter(|s| in_text(*s))
                .max_by_key(|s| s.end)
                .ok_or_else(|| "the system has no rule in the file".to_owned())?;
            let line_start = source[..last.start as usize]
                .rfind('\n')
                .map_or(0, |p| p + 1);
            let indent: String = source[line_start..last.start as usize]
                .chars()
                .take_while(|c| c.is_whitespace())
                .collect();
            edits.push((
                Span::new(last.end, last.end),
                format!("\n{indent}{label} : {cond} -> material({name});"),
            ));
        }
        op => {
            return Err(format!(
                "`{}` is not baked: only `force` and `material` (on a shape without rules) become rules exactly",
                op.kind().as_str()
            ));
        }
    }
    edits.sort_by_key(|(s, _)| (s.start, s.end));
    Ok(Baked {
        edits,
        condition: cond,
        symbol: label.clone(),
    })
}

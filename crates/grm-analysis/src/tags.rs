//! Suggested semantic tags for a shape system's untagged commands: Lipp's
//! automated tagging (seed 002, section 3.2.1), read from the rules alone.
//!
//! Lipp tags a Y split or repeat `floor` when its scope holds several
//! floors and the shapes it makes are at least a floor high (threshold
//! `f_s`), an X split or repeat `column` by the same test on widths, and a
//! component split of a tall shape `facade`. The editor has no grown model,
//! so the scope is read from the rules:
//!
//! - **kinds**: which geometry each symbol's shapes may have (the axiom is
//!   the lot, a footprint; `extrude` and `taper` make a mass; `comp(faces)`
//!   of a mass makes walls from `front`/`back`/`left`/`right`/`side` and
//!   horizontal faces from `top`/`bottom`; `roof` a roof; `comp(edges)`
//!   edges), a small fixpoint like the checker's. A symbol no rule reaches
//!   counts as a wall (a facade's rules written on their own).
//! - **the vertical axis** is a wall's `y` and a mass's `z`; a wall's `x`
//!   runs along the facade. A command on a symbol whose kinds disagree is
//!   not tagged.
//! - **floor**: a split or repeat along the vertical axis with a part at
//!   least [`FLOOR_HEIGHT`] long (a constant length, or a repeat's `~w`,
//!   which means about `w`). **column**: a split or repeat along a wall's
//!   `x` with a part at least [`COLUMN_WIDTH`] wide. **facade**: a
//!   `comp(faces)` of a mass.
//! - Of the commands on one path that qualify for a tag, the **deepest**
//!   gets it (its parts are single floors: `Upper -> repeat(y) { 3.2:
//!   Floor }` rather than the `split(y) { 4: Ground | ~1: Upper }` above
//!   it), and a tag is never suggested where it would be written twice on
//!   one path (W0501): not above or below a command already carrying it,
//!   nor on a command that reaches itself.

use crate::shape::{is_op, rules};
use crate::{CodeAction, FileAnalysis, Span, TextEdit};
use grm_syntax::ast::{ExprKind, Module, PartKind, System, UnaryOp};
use std::collections::HashMap;

/// The least height of a floor (Lipp's `f_s`), in scope units (metres).
pub const FLOOR_HEIGHT: f64 = 2.5;
/// The least width of a column of a facade.
pub const COLUMN_WIDTH: f64 = 2.0;

const FACE: u8 = 1; // a footprint or horizontal face
const MASS: u8 = 2;
const WALL: u8 = 4;
const EDGE: u8 = 8;
const ROOF: u8 = 16;

/// A suggested tag: the command, the tag, where it is written.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TagSuggestion {
    /// The command, from its name to its parts' `}`.
    pub command: Span,
    /// How the command starts, e.g. `repeat(y)`.
    pub written: String,
    pub tag: &'static str,
    /// The edit that writes it as the last argument.
    pub edit: TextEdit,
}

/// One command of the graph.
struct Cmd<'a> {
    module: &'a Module,
    /// Its kinds where it runs.
    kinds: u8,
    /// The symbols its parts make.
    targets: Vec<usize>,
}

/// The rules of one shape system as a graph of symbols and commands.
struct Graph<'a> {
    names: HashMap<&'a str, usize>,
    kinds: Vec<u8>,
    /// Per symbol: the symbols its rules make directly (successors).
    succ: Vec<Vec<usize>>,
    /// Per symbol: its rules' commands.
    cmds_of: Vec<Vec<usize>>,
    cmds: Vec<Cmd<'a>>,
}

/// The kinds a component split of `kinds` makes for a case `selector`.
fn comp_kinds(kinds: u8, faces: bool, selector: &str) -> u8 {
    if !faces {
        return EDGE;
    }
    let mut out = 0;
    if kinds & MASS != 0 {
        out |= match selector {
            "top" | "bottom" => FACE,
            "all" => WALL | FACE,
            _ => WALL,
        };
    }
    if kinds & ROOF != 0 {
        out |= ROOF;
    }
    // Faces of a face: the face itself.
    out | (kinds & (FACE | WALL))
}

impl<'a> Graph<'a> {
    fn new(sys: &'a System) -> Graph<'a> {
        let mut g = Graph {
            names: HashMap::new(),
            kinds: Vec::new(),
            succ: Vec::new(),
            cmds_of: Vec::new(),
            cmds: Vec::new(),
        };
        for (name, _) in crate::shape::symbols(sys) {
            g.id(name);
        }
        // Kinds: from the axiom's footprint to a fixpoint (sets only grow).
        loop {
            let mut changed = false;
            for (pred, modules) in rules(sys) {
                let start = match pred {
                    None => FACE,
                    // (`nil` names no symbol: a rule for it makes nothing.)
                    Some(p) => match g.names.get(p.name.as_str()) {
                        Some(&s) => g.kinds[s],
                        None => continue,
                    },
                };
                if start == 0 {
                    continue;
                }
                g.run(modules, start, &mut |g, sym, k| {
                    let old = g.kinds[sym];
                    g.kinds[sym] |= k;
                    changed |= g.kinds[sym] != old;
                });
            }
            if !changed {
                break;
            }
        }
        // Unreached symbols: a facade's rules on their own.
        for k in &mut g.kinds {
            if *k == 0 {
                *k = WALL;
            }
        }
        // Edges and commands.
        for (pred, modules) in rules(sys) {
            let Some(p) = pred else { continue };
            let Some(&owner) = g.names.get(p.name.as_str()) else {
                continue;
            };
            let start = g.kinds[owner];
            for m in modules {
                let name = m.symbol.name.as_str();
                if !is_op(name)
                    && !m.symbol.is_punct()
                    && let Some(&s) = g.names.get(name)
                {
                    g.succ[owner].push(s);
                }
                if matches!(name, "split" | "repeat" | "comp") {
                    let targets = m
                        .parts
                        .iter()
                        .flat_map(|p| &p.parts)
                        .filter(|p| p.target.name != "nil")
                        .filter_map(|p| g.names.get(p.target.name.as_str()).copied())
                        .collect();
                    let kinds = g.kind_before(modules, m, start);
                    g.cmds_of[owner].push(g.cmds.len());
                    g.cmds.push(Cmd {
                        module: m,
                        kinds,
                        targets,
                    });
                }
            }
        }
        g
    }

    fn id(&mut self, name: &'a str) -> usize {
        let n = self.names.len();
        *self.names.entry(name).or_insert_with(|| {
            self.kinds.push(0);
            self.succ.push(Vec::new());
            self.cmds_of.push(Vec::new());
            n
        })
    }

    /// The kinds after one operation.
    fn step(&self, m: &Module, k: u8, stack: &mut Vec<u8>) -> u8 {
        match m.symbol.name.as_str() {
            "extrude" | "taper" => MASS,
            "roof" => ROOF,
            "[" => {
                stack.push(k);
                k
            }
            "]" => stack.pop().unwrap_or(k),
            _ => k,
        }
    }

    /// The kinds where `target` runs in a rule starting with `start`.
    fn kind_before(&self, modules: &[Module], target: &Module, start: u8) -> u8 {
        let mut k = start;
        let mut stack = Vec::new();
        for m in modules {
            if std::ptr::eq(m, target) {
                return k;
            }
            k = self.step(m, k, &mut stack);
        }
        k
    }

    /// Run a rule's operations from `start`, reporting what each symbol it
    /// makes may be.
    fn run(
        &mut self,
        modules: &[Module],
        start: u8,
        report: &mut impl FnMut(&mut Self, usize, u8),
    ) {
        let mut k = start;
        let mut stack = Vec::new();
        for m in modules {
            let name = m.symbol.name.as_str();
            k = self.step(m, k, &mut stack);
            if !is_op(name) && !m.symbol.is_punct() && name != "nil" {
                if let Some(&s) = self.names.get(name) {
                    report(self, s, k);
                }
                continue;
            }
            let faces = m
                .args
                .first()
                .is_none_or(|a| !matches!(&a.kind, ExprKind::Name(n) if n.name == "edges"));
            for p in m.parts.iter().flat_map(|p| &p.parts) {
                let Some(&s) = self.names.get(p.target.name.as_str()) else {
                    continue;
                };
                let kk = if name == "comp" {
                    let sel = match &p.value.kind {
                        ExprKind::Name(n) => n.name.as_str(),
                        _ => "",
                    };
                    comp_kinds(k, faces, sel)
                } else {
                    k
                };
                report(self, s, kk);
            }
        }
    }

    /// The commands below command `c`: those of every symbol its parts
    /// reach.
    fn below(&self, c: usize) -> Vec<bool> {
        let mut seen_sym = vec![false; self.kinds.len()];
        let mut out = vec![false; self.cmds.len()];
        let mut stack: Vec<usize> = self.cmds[c].targets.clone();
        while let Some(s) = stack.pop() {
            if std::mem::replace(&mut seen_sym[s], true) {
                continue;
            }
            for &d in &self.cmds_of[s] {
                out[d] = true;
                stack.extend(&self.cmds[d].targets);
            }
            stack.extend(&self.succ[s]);
        }
        out
    }
}

/// The value of a constant size written as a number (possibly negated or
/// in parentheses).
fn number(e: &grm_syntax::ast::Expr) -> Option<f64> {
    match &e.kind {
        ExprKind::Number { value, .. } => Some(*value),
        ExprKind::Paren(inner) => number(inner),
        ExprKind::Unary {
            op: UnaryOp::Neg,
            operand,
        } => number(operand).map(|x| -x),
        _ => None,
    }
}

/// Whether a command has a part of at least `least` along its axis.
fn has_part_of(m: &Module, least: f64) -> bool {
    let repeat = m.symbol.name == "repeat";
    m.parts.iter().flat_map(|p| &p.parts).any(|p| {
        let known = match p.kind {
            PartKind::Absolute => true,
            PartKind::Floating => repeat,
            PartKind::Relative => false,
        };
        known && number(&p.value).is_some_and(|x| x >= least)
    })
}

/// The tag command `c` qualifies for, if any.
fn qualifies(c: &Cmd) -> Option<&'static str> {
    let m = c.module;
    let first = match m.args.first().map(|a| &a.kind) {
        Some(ExprKind::Name(n)) => n.name.as_str(),
        _ => return None,
    };
    match (m.symbol.name.as_str(), first) {
        ("comp", "faces") if c.kinds == MASS => Some("facade"),
        ("split" | "repeat", axis) => {
            let vertical = (c.kinds == WALL && axis == "y") || (c.kinds == MASS && axis == "z");
            let along = c.kinds == WALL && axis == "x";
            if vertical && has_part_of(m, FLOOR_HEIGHT) {
                Some("floor")
            } else if along && has_part_of(m, COLUMN_WIDTH) {
                Some("column")
            } else {
                None
            }
        }
        _ => None,
    }
}

/// The tag a command carries (its second argument, a name).
fn written_tag(m: &Module) -> Option<&str> {
    match m.args.get(1).map(|a| &a.kind) {
        Some(ExprKind::Name(n)) => Some(n.name.as_str()),
        _ => None,
    }
}

impl FileAnalysis {
    /// The semantic tags suggested for this file's untagged commands.
    pub fn tag_suggestions(&self) -> Vec<TagSuggestion> {
        let mut out = Vec::new();
        for sys in self.shape_systems() {
            let g = Graph::new(sys);
            let below: Vec<Vec<bool>> = (0..g.cmds.len()).map(|c| g.below(c)).collect();
            let quals: Vec<Option<&str>> = g.cmds.iter().map(qualifies).collect();
            for (c, cmd) in g.cmds.iter().enumerate() {
                let m = cmd.module;
                let (Some(tag), 1) = (quals[c], m.args.len()) else {
                    continue;
                };
                let clash =
                    |d: usize| written_tag(g.cmds[d].module) == Some(tag) || quals[d] == Some(tag);
                if below[c][c] || (0..g.cmds.len()).any(|d| below[c][d] && clash(d)) {
                    continue;
                }
                let above_written = (0..g.cmds.len())
                    .any(|d| below[d][c] && written_tag(g.cmds[d].module) == Some(tag));
                if above_written {
                    continue;
                }
                let end = m.parts.as_ref().map_or(m.span.end, |p| p.span.end);
                let after = m.args[0].span.end;
                // `repeat(y)`: up to the arguments' `)`.
                let close = self.text()[after as usize..]
                    .find(')')
                    .map_or(after, |i| after + i as u32 + 1);
                out.push(TagSuggestion {
                    command: Span::new(m.span.start, end.max(m.span.end)),
                    written: self.slice(Span::new(m.span.start, close)).to_string(),
                    tag,
                    edit: TextEdit {
                        span: Span::new(after, after),
                        new_text: format!(", {tag}"),
                    },
                });
            }
        }
        out.sort_by_key(|s| s.command.start);
        out
    }
}

impl FileAnalysis {
    /// The quick fixes that write suggested tags: one for each command
    /// `range` touches, and one that writes every suggestion of the file.
    pub(crate) fn tag_actions(&self, range: Span) -> Vec<CodeAction> {
        let all = self.tag_suggestions();
        let mut out: Vec<CodeAction> = all
            .iter()
            .filter(|s| s.command.start <= range.end && range.start <= s.command.end)
            .map(|s| CodeAction {
                title: format!("Tag `{}` as `{}`", s.written, s.tag),
                code: "",
                diagnostic: s.command,
                edits: vec![s.edit.clone()],
                preferred: false,
            })
            .collect();
        if all.len() > 1 && !out.is_empty() {
            out.push(CodeAction {
                title: format!("Add the {} suggested semantic tags", all.len()),
                code: "",
                diagnostic: out[0].diagnostic,
                edits: all.iter().map(|s| s.edit.clone()).collect(),
                preferred: false,
            });
        }
        out
    }
}

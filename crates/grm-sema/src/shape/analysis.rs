//! Whole-grammar checks of a shape system, on the checked rules:
//!
//! - sizes that can never fit (E0507): relative parts summing over 100%,
//!   a repeated tile of length zero, a negative constant size;
//! - component splits of shapes without faces (E0508), by a small
//!   abstract interpretation: the kinds of geometry each symbol's shapes
//!   may have, from the axiom's footprint (`extrude` makes a mass,
//!   `comp(faces)` faces, `comp(edges)` edges, `roof` a roof, ...);
//! - a tag used twice on one path (W0501), from the tags each symbol's
//!   shapes may have above them.
//!
//! Both interpretations are fixpoints over small bit sets per symbol
//! (each rule is visited a bounded number of times: the sets only grow),
//! and report only what holds for every possibility (a comp of a shape
//! that is a mass on some path is not reported).

use grm_diag::{Code, Diagnostic, FileId, Span};

use super::*;
use crate::program::{TExpr, Value};

/// Geometry kinds, as bits.
const FACE: u8 = 1;
const MASS: u8 = 2;
const EDGE: u8 = 4;
const ROOF: u8 = 8;

/// Run the analyses and push what they find.
pub(crate) fn analyse(
    sys: &ShapeSystem,
    n_symbols: usize,
    file: FileId,
    names: &[&str],
    diags: &mut Vec<Diagnostic>,
) {
    sizes(sys, file, diags);
    if let Some(axiom) = sys.axiom {
        kinds(sys, axiom, n_symbols, file, diags);
        tags(sys, axiom, n_symbols, file, names, diags);
    }
}

fn constant(e: &TExpr) -> Option<f64> {
    match e.constant() {
        Some(Value::Float(x)) => Some(x),
        _ => None,
    }
}

fn never_fits(file: FileId, span: Span, msg: String, label: &str, help: &str) -> Diagnostic {
    Diagnostic::new(Code::SizesNeverFit, msg, file, span, label.to_string())
        .with_help(help.to_string())
}

fn sizes(sys: &ShapeSystem, file: FileId, diags: &mut Vec<Diagnostic>) {
    for rule in &sys.rules {
        for op in &rule.ops {
            match &op.kind {
                OpKind::Split(s) | OpKind::Repeat(s) => {
                    let repeat = matches!(op.kind, OpKind::Repeat(_));
                    split_sizes(s, repeat, op.span, file, diags);
                }
                OpKind::Size(v) => {
                    for e in v.iter().flatten() {
                        if let Some(x) = constant(e)
                            && x < 0.0
                        {
                            diags.push(never_fits(
                                file,
                                e.span,
                                format!("a scope's size cannot be negative ({})", x as f32),
                                "negative size",
                                "sizes are lengths, 0 or more; turn the scope with `rotate` to face the other way",
                            ));
                        }
                    }
                }
                _ => {}
            }
        }
    }
}

fn split_sizes(s: &SplitT, repeat: bool, span: Span, file: FileId, diags: &mut Vec<Diagnostic>) {
    let mut relative = 0.0f64;
    let mut all_constant = true;
    let mut tile = 0.0f64;
    for part in &s.parts {
        let Some(x) = constant(&part.size) else {
            all_constant = false;
            continue;
        };
        if x < 0.0 {
            let what = match part.kind {
                PartKind::Absolute => "length",
                PartKind::Relative => "percentage",
                PartKind::Floating => "weight",
            };
            diags.push(never_fits(
                file,
                part.size.span,
                format!("a part's {what} cannot be negative ({})", x as f32),
                "negative size",
                "sizes are 0 or more; a part of size 0 makes nothing",
            ));
            continue;
        }
        match part.kind {
            PartKind::Relative => relative += x,
            PartKind::Absolute | PartKind::Floating => tile += x,
        }
    }
    if relative > 100.0 * (1.0 + 1e-9) {
        let parts: Vec<Span> = s
            .parts
            .iter()
            .filter(|p| p.kind == PartKind::Relative)
            .map(|p| p.span)
            .collect();
        let mut d = never_fits(
            file,
            parts.first().copied().unwrap_or(span),
            format!(
                "the relative parts add up to {}%, more than the whole scope",
                relative as f32
            ),
            "relative part",
            "relative parts share one scope: make them add up to 100% or less, or make some floating (`~1: A`)",
        );
        for &p in parts.iter().skip(1) {
            d = d.with_label(file, p, "relative part");
        }
        diags.push(d);
    }
    if repeat && all_constant && tile == 0.0 && relative == 0.0 && !s.parts.is_empty() {
        diags.push(never_fits(
            file,
            span,
            "the repeated tile has length zero: it would repeat forever".into(),
            "this repeat",
            "give the tile a length: a part such as `3: Tile` or `~3: Tile`",
        ));
    }
}

/// The kinds each symbol's shapes may have; reports comps of shapes
/// without faces or edges.
fn kinds(sys: &ShapeSystem, axiom: u32, n: usize, file: FileId, diags: &mut Vec<Diagnostic>) {
    let mut kinds = vec![0u8; n];
    if let Some(k) = kinds.get_mut(axiom as usize) {
        *k = FACE;
    }
    // Each pass visits every rule with its symbol's kinds so far; the
    // kinds only grow (4 bits per symbol), so this ends within 4n passes.
    let mut changed = true;
    let mut guard = 0;
    while changed && guard <= 4 * n + 4 {
        changed = false;
        guard += 1;
        for rule in &sys.rules {
            let k = kinds.get(rule.symbol as usize).copied().unwrap_or(0);
            if k == 0 {
                continue;
            }
            run_kinds(rule, k, &mut |target, kk| {
                if let Some(slot) = kinds.get_mut(target as usize)
                    && *slot | kk != *slot
                {
                    *slot |= kk;
                    changed = true;
                }
            });
        }
    }
    // Report comps whose shape can never have what they take.
    for rule in &sys.rules {
        let k = kinds.get(rule.symbol as usize).copied().unwrap_or(0);
        if k == 0 {
            continue;
        }
        let mut cur = k;
        let mut stack = Vec::new();
        for op in &rule.ops {
            if let OpKind::Comp(c) = &op.kind {
                let ok = match c.target {
                    CompTarget::Faces => cur & (MASS | ROOF) != 0,
                    CompTarget::Edges => cur & (MASS | ROOF | FACE) != 0,
                };
                if !ok {
                    let (what, has) = (c.target.name(), describe(cur));
                    diags.push(
                        Diagnostic::new(
                            Code::CompWithoutFaces,
                            format!("this shape has no {what} to split: it is always {has}"),
                            file,
                            op.span,
                            format!("comp({what}) of {has}"),
                        )
                        .with_note("a mass (after `extrude`) or a roof has faces; a mass, a roof or a face has edges")
                        .with_help(match c.target {
                            CompTarget::Faces => "extrude the shape first, or split it with `split`",
                            CompTarget::Edges => "an edge has no edges: split it with `split(x)`",
                        }),
                    );
                }
            }
            step(&op.kind, &mut cur, &mut stack);
        }
    }
}

fn describe(k: u8) -> &'static str {
    match k {
        FACE => "a face",
        EDGE => "an edge",
        x if x == FACE | EDGE => "a face or an edge",
        _ => "flat",
    }
}

/// The kinds after one operation (`cur` the kinds before).
fn step(op: &OpKind, cur: &mut u8, stack: &mut Vec<u8>) {
    match op {
        OpKind::Extrude(_) | OpKind::Taper(_) => *cur = MASS,
        OpKind::Roof { .. } => *cur = ROOF,
        OpKind::Push => stack.push(*cur),
        OpKind::Pop => {
            if let Some(k) = stack.pop() {
                *cur = k;
            }
        }
        _ => {}
    }
}

/// Visit what a rule makes: `emit(symbol, kinds)` for each successor and
/// part or case target.
fn run_kinds(rule: &ShapeRule, k: u8, emit: &mut dyn FnMut(u32, u8)) {
    let mut cur = k;
    let mut stack = Vec::new();
    for op in &rule.ops {
        match &op.kind {
            OpKind::Emit(s) => emit(*s, cur),
            OpKind::Split(s) | OpKind::Repeat(s) => {
                for p in &s.parts {
                    if let Some(t) = p.target {
                        emit(t, cur);
                    }
                }
            }
            OpKind::Comp(c) => {
                let out = match c.target {
                    CompTarget::Faces if cur & (MASS | ROOF) != 0 => FACE,
                    CompTarget::Edges if cur & (MASS | ROOF | FACE) != 0 => EDGE,
                    _ => 0,
                };
                if out != 0 {
                    for case in &c.cases {
                        if let Some(t) = case.target {
                            emit(t, out);
                        }
                    }
                }
            }
            other => step(other, &mut cur, &mut stack),
        }
    }
}

/// The tags each symbol's shapes may have above them; warns where a
/// command's tag may already be there.
fn tags(
    sys: &ShapeSystem,
    axiom: u32,
    n: usize,
    file: FileId,
    names: &[&str],
    diags: &mut Vec<Diagnostic>,
) {
    // Tags by number, in order of first use.
    let mut tag_names: Vec<&str> = Vec::new();
    fn tag_id<'s>(names: &mut Vec<&'s str>, t: &'s str) -> usize {
        match names.iter().position(|x| *x == t) {
            Some(i) => i,
            None => {
                names.push(t);
                names.len() - 1
            }
        }
    }
    // Each command's tag id, per rule and op.
    let mut cmd_tags: Vec<Vec<Option<usize>>> = Vec::with_capacity(sys.rules.len());
    for rule in &sys.rules {
        let mut row = Vec::with_capacity(rule.ops.len());
        for op in &rule.ops {
            let tag = match &op.kind {
                OpKind::Split(s) | OpKind::Repeat(s) => s.tag.as_ref(),
                OpKind::Comp(c) => c.tag.as_ref(),
                _ => None,
            };
            row.push(tag.map(|t| tag_id(&mut tag_names, &t.name)));
        }
        cmd_tags.push(row);
    }
    let nt = tag_names.len();
    if nt == 0 {
        return;
    }
    // above[s]: the tags that may be above a shape of s (a bit set).
    let words = nt.div_ceil(64);
    let mut above = vec![0u64; n * words];
    let mut reached = vec![false; n];
    if let Some(r) = reached.get_mut(axiom as usize) {
        *r = true;
    }
    // Via one tag from a symbol: where the set `from` flows with `tag`.
    let mut changed = true;
    let mut guard = 0;
    while changed && guard <= n * (nt + 1) + 4 {
        changed = false;
        guard += 1;
        for (ri, rule) in sys.rules.iter().enumerate() {
            let s = rule.symbol as usize;
            if !reached.get(s).copied().unwrap_or(false) {
                continue;
            }
            let from: Vec<u64> = above[s * words..(s + 1) * words].to_vec();
            for (oi, op) in rule.ops.iter().enumerate() {
                let targets: Vec<u32> = match &op.kind {
                    OpKind::Emit(t) => vec![*t],
                    OpKind::Split(sp) | OpKind::Repeat(sp) => {
                        sp.parts.iter().filter_map(|p| p.target).collect()
                    }
                    OpKind::Comp(c) => c.cases.iter().filter_map(|c| c.target).collect(),
                    _ => continue,
                };
                let mut set = from.clone();
                if let Some(t) = cmd_tags[ri][oi] {
                    set[t / 64] |= 1 << (t % 64);
                }
                for t in targets {
                    let t = t as usize;
                    if t >= n {
                        continue;
                    }
                    if !reached[t] {
                        reached[t] = true;
                        changed = true;
                    }
                    for w in 0..words {
                        let slot = &mut above[t * words + w];
                        if *slot | set[w] != *slot {
                            *slot |= set[w];
                            changed = true;
                        }
                    }
                }
            }
        }
    }
    for (ri, rule) in sys.rules.iter().enumerate() {
        let s = rule.symbol as usize;
        if !reached.get(s).copied().unwrap_or(false) {
            continue;
        }
        for (oi, op) in rule.ops.iter().enumerate() {
            let Some(t) = cmd_tags[ri][oi] else { continue };
            if above[s * words + t / 64] & (1 << (t % 64)) == 0 {
                continue;
            }
            let tag = match &op.kind {
                OpKind::Split(sp) | OpKind::Repeat(sp) => sp.tag.as_ref(),
                OpKind::Comp(c) => c.tag.as_ref(),
                _ => None,
            };
            let Some(tag) = tag else { continue };
            let sym = names.get(s).copied().unwrap_or("?");
            diags.push(
                Diagnostic::new(
                    Code::TagTwiceOnPath,
                    format!(
                        "tag `{}` may be used twice on one path: a `{sym}` shape can lie below a command tagged `{}` already",
                        tag.name, tag.name
                    ),
                    file,
                    tag.span,
                    "tagged again here",
                )
                .with_note("a semantic locator names each tag on the path once: the inner one would hide the outer")
                .with_help("give this command its own tag, e.g. `floor` and `storey`, or `column` and `bay`"),
            );
        }
    }
}

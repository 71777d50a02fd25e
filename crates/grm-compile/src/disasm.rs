//! A readable listing of a compiled system (`grmc disasm`).
//!
//! Notation in successors: a constant parameter is printed as its value, a
//! copied binding word as `$k`, a computed one as `@pc` (the code offset of
//! its expression, listed under `code:`).

use std::fmt::Write;

use grm_diag::Span;

use crate::compiled::CompiledSystem;
use crate::op::{Op, Operand, decode};
use crate::table::*;

/// Disassemble `c`. With the text of the system's file, each group and
/// each run of code is annotated with the source it came from.
pub fn disassemble(c: &CompiledSystem, source: Option<&str>) -> String {
    let mut o = String::new();
    let s = &c.settings;
    let _ = writeln!(o, "system {}", c.name);
    let _ = writeln!(
        o,
        "settings: iterations {}, angle {}, seed {}, step {}, width {}",
        s.iterations, s.angle, s.seed, s.step, s.width
    );
    let _ = writeln!(
        o,
        "sizes: {} symbols, {} groups, {} alternatives (+ the axiom), {} context items, {} successor modules, {} parameters, {} code words, {} constants, draw indices 0..{} (0: the choice), binding words <= {}",
        c.symbols.len(),
        c.groups.len(),
        c.alts.len().saturating_sub(1),
        c.context.len(),
        c.succ.len(),
        c.params.len(),
        c.code.len(),
        c.consts.len(),
        c.draws,
        c.max_bind_words
    );
    let _ = writeln!(o, "\nsymbols:");
    for (i, sym) in c.symbols.iter().enumerate() {
        let mut flags = Vec::new();
        if sym.flags & SYM_TERMINAL != 0 {
            flags.push("terminal");
        }
        if sym.flags & SYM_PUSH != 0 {
            flags.push("push");
        }
        if sym.flags & SYM_POP != 0 {
            flags.push("pop");
        }
        if sym.flags & SYM_IGNORED != 0 {
            flags.push("ignored");
        }
        let mut line = format!(
            "  {i:>3}  {:<10} words {}",
            c.symbol_names[i], sym.param_words
        );
        if sym.group_count > 0 {
            let _ = write!(
                line,
                "  groups {}..{}",
                sym.first_group,
                sym.first_group + sym.group_count
            );
        }
        if sym.wrapup_count > 0 {
            let _ = write!(
                line,
                "  wrapup {}..{}",
                sym.first_wrapup,
                sym.first_wrapup + sym.wrapup_count
            );
        }
        if !flags.is_empty() {
            let _ = write!(line, "  [{}]", flags.join(", "));
        }
        let _ = writeln!(o, "{}", line.trim_end());
    }
    if !c.consts.is_empty() {
        let _ = writeln!(o, "\nconstants:");
        for (i, k) in c.consts.iter().enumerate() {
            let _ = writeln!(o, "  #{i:<3} {}", fmt_f32(*k));
        }
    }
    let _ = writeln!(
        o,
        "\naxiom: {}",
        successor(c, &c.alts[c.axiom_alt as usize])
    );
    let _ = writeln!(o, "\ngroups:");
    for (gi, g) in c.groups.iter().enumerate() {
        let name = c.symbol_names.get(g.pred as usize).map_or("?", |s| s);
        let mut head = format!("  group {gi}: {name}");
        if g.flags & GROUP_WRAPUP != 0 {
            head.push_str(" (wrapup)");
        }
        if let Some(text) = source {
            let span = c.alt_spans[g.first_alt as usize];
            let (line, snippet) = first_line(text, span);
            let _ = write!(head, "    // line {line}: {snippet}");
        }
        let _ = writeln!(o, "{head}");
        let _ = writeln!(
            o,
            "    binds {} words (predecessor {} at ${})",
            g.bind_words, g.pred_bind_words, g.pred_bind_offset
        );
        if g.left_len > 0 {
            let items = &c.context[g.left_offset as usize..][..g.left_len as usize];
            let _ = writeln!(o, "    left:  {}", context(c, items));
        }
        if g.right_len > 0 {
            let items = &c.context[g.right_offset as usize..][..g.right_len as usize];
            let _ = writeln!(o, "    right: {}", context(c, items));
        }
        if g.cond_code != NONE {
            let _ = writeln!(o, "    condition: @{}", g.cond_code);
        }
        for ai in g.first_alt..g.first_alt + g.alt_count {
            let a = &c.alts[ai as usize];
            let weight = if a.weight_code != NONE {
                format!("@{}", a.weight_code)
            } else if g.alt_count > 1 {
                format!("{} (cum {})", fmt_f32(a.weight), fmt_f32(a.cum_weight))
            } else {
                fmt_f32(a.weight)
            };
            let _ = writeln!(
                o,
                "    alt {ai} weight {weight}: {} modules, {} words{}",
                a.succ_len,
                a.succ_words,
                if a.flags & ALT_NO_CODE != 0 {
                    ", no code"
                } else {
                    ""
                }
            );
            let _ = writeln!(o, "      -> {}", successor(c, a));
        }
    }
    if !c.code.is_empty() {
        let _ = writeln!(o, "\ncode:");
        o.push_str(&code(c, source));
    }
    o
}

/// Shortest text that reads back as the same f32.
fn fmt_f32(x: f32) -> String {
    format!("{x}")
}

fn context(c: &CompiledSystem, items: &[ContextItem]) -> String {
    let parts: Vec<String> = items
        .iter()
        .map(|it| match it.kind {
            CTX_PUSH => "[".to_string(),
            CTX_POP => "]".to_string(),
            _ => {
                let name = c.symbol_names.get(it.symbol as usize).map_or("?", |s| s);
                if it.bind_words > 0 {
                    format!(
                        "{name}(${}..${})",
                        it.bind_offset,
                        it.bind_offset + it.bind_words
                    )
                } else {
                    name.to_string()
                }
            }
        })
        .collect();
    parts.join(" ")
}

fn successor(c: &CompiledSystem, a: &AltHeader) -> String {
    let mut parts = Vec::new();
    for m in c.successor(a) {
        let name = c.symbol_names.get(m.symbol as usize).map_or("?", |s| s);
        let ps = c.module_params(m);
        if ps.is_empty() {
            parts.push(name.to_string());
            continue;
        }
        let args: Vec<String> = ps
            .iter()
            .map(|p| match p.kind {
                PARAM_CONST => {
                    let vs = &c.consts[p.a as usize..][..p.words as usize];
                    if p.words == 3 {
                        format!(
                            "vec3({}, {}, {})",
                            fmt_f32(vs[0]),
                            fmt_f32(vs[1]),
                            fmt_f32(vs[2])
                        )
                    } else {
                        fmt_f32(vs[0])
                    }
                }
                PARAM_COPY if p.words == 3 => format!("${}..${}", p.a, p.a + 3),
                PARAM_COPY => format!("${}", p.a),
                _ => format!("@{}", p.a),
            })
            .collect();
        parts.push(format!("{name}({})", args.join(", ")));
    }
    if parts.is_empty() {
        "(empty)".to_string()
    } else {
        parts.join(" ")
    }
}

/// 1-based line of the span's start and the first line of its text.
fn first_line(text: &str, span: Span) -> (usize, String) {
    let start = (span.start as usize).min(text.len());
    let end = (span.end as usize).min(text.len()).max(start);
    let (Some(before), Some(body)) = (text.get(..start), text.get(start..end)) else {
        return (0, String::new());
    };
    let line = before.matches('\n').count() + 1;
    let first = body.lines().next().unwrap_or("").trim_end();
    let more = if body.contains('\n') { " ..." } else { "" };
    (line, format!("{first}{more}"))
}

fn snippet(text: &str, span: Span) -> String {
    let start = (span.start as usize).min(text.len());
    let end = (span.end as usize).min(text.len()).max(start);
    let s: String = text
        .get(start..end)
        .unwrap_or("")
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ");
    if s.chars().count() > 48 {
        let cut: String = s.chars().take(45).collect();
        format!("{cut}...")
    } else {
        s
    }
}

fn code(c: &CompiledSystem, source: Option<&str>) -> String {
    let mut o = String::new();
    let mut pc = 0usize;
    let mut next_span = 0usize;
    while let Some(&word) = c.code.get(pc) {
        let (opcode, a) = decode(word);
        let mut line = format!("  {pc:>5}  ");
        let mut extra = 0;
        match Op::from_code(opcode) {
            Some(op) => {
                let operand = match op.operand() {
                    Operand::None => String::new(),
                    Operand::Index if matches!(op, Op::Const) => format!(
                        "#{a} ({})",
                        c.consts.get(a as usize).map_or("?".into(), |x| fmt_f32(*x))
                    ),
                    Operand::Index if matches!(op, Op::Const3) => {
                        let v = c.consts.get(a as usize..a as usize + 3);
                        match v {
                            Some(v) => format!(
                                "#{a} ({}, {}, {})",
                                fmt_f32(v[0]),
                                fmt_f32(v[1]),
                                fmt_f32(v[2])
                            ),
                            None => format!("#{a} (?)"),
                        }
                    }
                    Operand::Index => format!("${a}"),
                    Operand::Width => format!("w{a}"),
                    Operand::Component => {
                        ["x", "y", "z"].get(a as usize).unwrap_or(&"?").to_string()
                    }
                    Operand::Draw => format!("draw {a}"),
                    Operand::CountWidth => {
                        let s = format!("n{} w{}", a & 0xFFFF, a >> 16);
                        if op == Op::RandChoose {
                            let d = c.code.get(pc + 1).copied().unwrap_or(0);
                            format!("{s} draw {d}")
                        } else {
                            s
                        }
                    }
                };
                extra = op.extra_words() as usize;
                let _ = write!(line, "{:<13}{operand}", op.name());
            }
            None => {
                let _ = write!(line, "<bad word {word:#010x}>");
            }
        }
        // Annotate where a new span starts.
        while next_span + 1 < c.spans.len() && c.spans[next_span + 1].code_offset as usize <= pc {
            next_span += 1;
        }
        if let (Some(text), Some(e)) = (source, c.spans.get(next_span))
            && e.code_offset as usize == pc
        {
            let width = 40usize.saturating_sub(line.len()).max(1);
            let _ = write!(
                line,
                "{:width$}// {}",
                "",
                snippet(text, Span::new(e.start, e.end))
            );
        }
        let _ = writeln!(o, "{}", line.trim_end());
        pc += 1 + extra;
    }
    o
}

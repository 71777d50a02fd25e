//! Derived module strings as grm source text that reads back: each
//! module's parameter words printed by the types the checker gave its
//! symbol (`vec3(1, 2, 3)`, `true`, mesh and material names), so the text
//! of a derived string can be pasted back as an axiom.

use grm_sema::{Program, System, Ty};

/// Append the module `symbol(words...)` of `system` to `out` as source
/// text. Words that do not fit the symbol's parameter types (a string
/// from another system) are printed as plain numbers.
pub fn write_module(
    program: &Program,
    system: &System,
    symbol: u32,
    words: &[f32],
    out: &mut String,
) {
    use std::fmt::Write;
    let Some(info) = system.symbols.get(symbol as usize) else {
        let _ = write!(out, "#{symbol}");
        return write_numbers(words, out);
    };
    out.push_str(&info.name);
    if words.is_empty() {
        return;
    }
    let width = |t: &Ty| if *t == Ty::Vec3 { 3 } else { 1 };
    if info.params.iter().map(width).sum::<usize>() != words.len() {
        return write_numbers(words, out);
    }
    // `scale` has no vec3 form (`scale(s)` is the uniform one): its vector
    // is written as the three numbers the checker reads it from.
    let spread = info.terminal() == Some(grm_sema::Terminal::Scale);
    out.push('(');
    let mut w = words.iter().copied();
    for (k, t) in info.params.iter().enumerate() {
        if k > 0 {
            out.push_str(", ");
        }
        // The widths were checked above: every `next` has a word.
        let mut next = || w.next().unwrap_or(0.0);
        match t {
            Ty::Vec3 if spread => {
                let (x, y, z) = (next(), next(), next());
                let _ = write!(out, "{x}, {y}, {z}");
            }
            Ty::Vec3 => {
                let (x, y, z) = (next(), next(), next());
                let _ = write!(out, "vec3({x}, {y}, {z})");
            }
            Ty::Bool => out.push_str(if next() != 0.0 { "true" } else { "false" }),
            Ty::Mesh => {
                let id = next();
                match program.meshes.get(id as usize).filter(|_| id >= 0.0) {
                    Some(m) => out.push_str(&m.name),
                    None => {
                        let _ = write!(out, "{id}");
                    }
                }
            }
            Ty::Material => {
                let id = next();
                match program.materials.get(id as usize).filter(|_| id >= 0.0) {
                    Some(m) => out.push_str(&m.name),
                    None => {
                        let _ = write!(out, "{id}");
                    }
                }
            }
            Ty::Float | Ty::Error => {
                let _ = write!(out, "{}", next());
            }
        }
    }
    out.push(')');
}

/// Append `(a, b, ...)` for a module's parameter words; nothing for none.
pub fn write_numbers(words: &[f32], out: &mut String) {
    use std::fmt::Write;
    if words.is_empty() {
        return;
    }
    out.push('(');
    for (k, p) in words.iter().enumerate() {
        if k > 0 {
            out.push_str(", ");
        }
        let _ = write!(out, "{p}");
    }
    out.push(')');
}

/// A whole string (`(symbol, words)` per module) as source text, modules
/// separated by one space.
pub fn string_text<'a>(
    program: &Program,
    system: &System,
    modules: impl IntoIterator<Item = (u32, &'a [f32])>,
) -> String {
    let mut out = String::new();
    for (i, (s, w)) in modules.into_iter().enumerate() {
        if i > 0 {
            out.push(' ');
        }
        write_module(program, system, s, w, &mut out);
    }
    out
}

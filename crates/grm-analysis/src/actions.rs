//! Code actions: the quick fixes for diagnostics whose fix is known, read
//! from the diagnostic's code, span and help line ("did you mean `x`?",
//! "prefix it with `_`", "add one, e.g. `wrapup A -> ;`", ...).

use crate::{FileAnalysis, Span, TextEdit, clamp};
use grm_diag::Code;
use grm_syntax::ast::{Item, Phase, SystemItem};
use grm_syntax::lexer::TokKind;

/// A quick fix: edits of the analysed file that resolve one diagnostic,
/// or (with an empty `code`) a suggestion such as a shape command's
/// semantic tag (`crate::tags`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CodeAction {
    pub title: String,
    /// The code and primary span of the diagnostic it fixes (empty, and
    /// the span it is about, for a suggestion that fixes none).
    pub code: &'static str,
    pub diagnostic: Span,
    pub edits: Vec<TextEdit>,
    /// The fix an editor may apply without asking ("fix all").
    pub preferred: bool,
}

/// Text between the backticks following `after` in `help`.
fn quoted_after<'a>(help: &'a str, after: &str) -> Option<&'a str> {
    let i = help.find(after)? + after.len();
    let rest = &help[i..];
    let a = rest.find('`')? + 1;
    let b = rest[a..].find('`')? + a;
    Some(&rest[a..b])
}

/// Every backticked part of `help`.
fn quoted(help: &str) -> Vec<&str> {
    help.split('`').skip(1).step_by(2).collect()
}

fn edit(span: Span, new_text: impl Into<String>) -> TextEdit {
    TextEdit {
        span,
        new_text: new_text.into(),
    }
}

impl FileAnalysis {
    /// `not x > 2`, with the parser stopped at `x` (`operand`): the edits
    /// that write `!(x > 2)`. The operand runs, as Python reads `not`, to
    /// the first `&&`, `||`, `and`, `or`, `->`, `;` or unmatched `)` at its
    /// own depth. `None` when no `not` precedes it.
    fn not_operand(&self, operand: Span) -> Option<Vec<TextEdit>> {
        let text = self.text();
        let before = text.get(..operand.start as usize)?.trim_end();
        let not_start = before.strip_suffix("not")?.len();
        let boundary = before[..not_start]
            .chars()
            .next_back()
            .is_none_or(|c| !(c.is_alphanumeric() || c == '_'));
        if !boundary {
            return None;
        }
        let rest = text.get(operand.start as usize..)?;
        let lexed = grm_syntax::lexer::lex(grm_diag::FileId(0), rest);
        let mut depth = 0i32;
        let mut end = None;
        for t in &lexed.tokens {
            match t.kind {
                TokKind::LParen => depth += 1,
                TokKind::RParen if depth == 0 => break,
                TokKind::RParen => depth -= 1,
                TokKind::AndAnd | TokKind::OrOr | TokKind::Arrow | TokKind::Semi if depth == 0 => {
                    break;
                }
                TokKind::Ident if depth == 0 && matches!(t.text, "and" | "or") => break,
                TokKind::LBrace | TokKind::RBrace => break,
                _ => {}
            }
            end = Some(t.span.end);
        }
        let end = operand.start + end?;
        let inner = text.get(operand.start as usize..end as usize)?;
        Some(vec![edit(
            Span::new(not_start as u32, end),
            format!("!({inner})"),
        )])
    }

    /// Quick fixes for the diagnostics of this file whose primary span
    /// touches `range`.
    pub fn code_actions(&self, range: Span) -> Vec<CodeAction> {
        let mut out = Vec::new();
        for d in &self.checked.diagnostics {
            let p = d.primary();
            if p.file != self.root {
                continue;
            }
            let span = clamp(p.span, self.text());
            if span.end < range.start || span.start > range.end {
                continue;
            }
            let help = d.help.as_deref().unwrap_or("");
            let code = d.code.as_str();
            let mut push = |title: String, edits: Vec<TextEdit>, preferred: bool| {
                if !edits.is_empty() {
                    out.push(CodeAction {
                        title,
                        code,
                        diagnostic: span,
                        edits,
                        preferred,
                    });
                }
            };
            // W0002 "did you mean `x` where `X` is written?": the misspelt
            // name is where the second label points, not the production.
            if d.code == Code::UnreachableProduction {
                if let Some(s) = quoted_after(help, "did you mean") {
                    let written: Vec<TextEdit> = d
                        .labels
                        .iter()
                        .filter(|l| {
                            !l.primary
                                && l.file == self.root
                                && l.message.ends_with("nothing rewrites it")
                        })
                        .map(|l| edit(clamp(l.span, self.text()), s))
                        .collect();
                    push(format!("Replace with `{s}`"), written, false);
                }
            } else if let Some(s) = quoted_after(help, "did you mean")
                && crate::nav::valid_identifier(self.slice(span)).is_ok()
            {
                // "did you mean `x`?": replace the misspelt name.
                push(format!("Replace with `{s}`"), vec![edit(span, s)], true);
            }
            match d.code {
                Code::UnexpectedToken | Code::InvalidCharacter
                    if d.message.ends_with("is not an arrow in grm") =>
                {
                    push("Replace with `->`".into(), vec![edit(span, "->")], true);
                }
                // `not x > 2` (other tools' notation): `!(x > 2)`.
                Code::UnexpectedToken if help.starts_with("write `!` for not:") => {
                    if let Some(edits) = self.not_operand(span) {
                        push("Replace with `!(...)`".into(), edits, true);
                    }
                }
                // `not (x > 2)`, read as a call of a function `not`.
                Code::UnknownFunction if help.starts_with("write `!` for not") => {
                    push("Replace with `!`".into(), vec![edit(span, "!")], true);
                }
                // `=` or `and` in a condition: the grm operator.
                Code::UnexpectedToken
                    if help.starts_with("to compare, write") || help.starts_with("write `") =>
                {
                    if let Some(op) = quoted_after(help, "write") {
                        push(format!("Replace with `{op}`"), vec![edit(span, op)], true);
                    }
                }
                // `ω: F;` / `axiom: F;`, read as the axiom: `axiom F;`.
                Code::UnexpectedToken if help.starts_with("the axiom is written without `:`") => {
                    push(
                        "Replace with `axiom`".into(),
                        vec![edit(span, "axiom")],
                        true,
                    );
                }
                Code::UnexpectedToken if d.message == "expected `;`" => {
                    push(
                        "Insert `;`".into(),
                        vec![edit(Span::new(span.end, span.end), ";")],
                        true,
                    );
                }
                Code::UnusedParameter | Code::UnusedDefinition => {
                    let name = self.slice(span);
                    if crate::nav::valid_identifier(name).is_ok() {
                        push(
                            format!("Prefix `{name}` with `_`"),
                            vec![edit(Span::new(span.start, span.start), "_")],
                            true,
                        );
                    }
                }
                Code::AmbiguousProductions => {
                    // Write the implicit weight 1 on every unweighted
                    // alternative of the group: same meaning, now explicit.
                    let group = self
                        .root_systems()
                        .flat_map(|s| &s.groups)
                        .find(|g| g.alternatives.iter().any(|a| a.pred == span));
                    if let Some(g) = group {
                        let edits: Vec<TextEdit> = g
                            .alternatives
                            .iter()
                            .filter(|a| !a.weight_written)
                            .map(|a| edit(Span::new(a.arrow.end, a.arrow.end), " (1)"))
                            .collect();
                        push("Write the weights `(1)`".into(), edits, false);
                    }
                }
                Code::UnknownField => {
                    // "colours are vectors: write `.x` for red"
                    if let Some(f) = quoted_after(help, "write")
                        .and_then(|q| q.strip_prefix('.'))
                        .filter(|f| matches!(*f, "x" | "y" | "z"))
                    {
                        push(format!("Replace with `.{f}`"), vec![edit(span, f)], true);
                    }
                }
                Code::UnitValueClamped => {
                    // "material values lie in 0..1: write `rgb(1, 1, 1)`",
                    // "colours lie in 0..1; for 0..255 values divide by
                    // 255: write `color(1, 0.502, 0)`"
                    // (only for a constant value: the fix would drop a
                    // meta-parameter).
                    if let Some(v) = quoted_after(help, "write") {
                        push(format!("Replace with `{v}`"), vec![edit(span, v)], true);
                    }
                }
                Code::RunTogether | Code::UnknownName
                    if help.starts_with("write `") && !help.contains("did you mean") =>
                {
                    // "write `F F`": every occurrence of the run-together
                    // symbol in this file, spaced out.
                    if let Some(v) = quoted_after(help, "write")
                        && let Some(r) = self.checked.program.index.at(self.root, span.start)
                        && matches!(r.def, grm_sema::Def::Symbol(..))
                    {
                        let mut edits: Vec<TextEdit> = self
                            .checked
                            .program
                            .index
                            .occurrences(r.def)
                            .filter(|o| {
                                o.loc.file == self.root
                                    && self.slice(o.loc.span) == self.slice(span)
                            })
                            .map(|o| edit(o.loc.span, v))
                            .collect();
                        edits.dedup_by_key(|e| e.span);
                        push(format!("Replace with `{v}`"), edits, true);
                    }
                }
                Code::InvalidCharacter => {
                    push(
                        "Remove the invalid characters".into(),
                        vec![edit(span, "")],
                        true,
                    );
                }
                Code::UnterminatedString => {
                    push(
                        "Close the string".into(),
                        vec![edit(Span::new(span.end, span.end), "\"")],
                        true,
                    );
                }
                Code::UnterminatedComment => {
                    let end = self.text().len() as u32;
                    push(
                        "Close the comment".into(),
                        vec![edit(Span::new(end, end), " */")],
                        true,
                    );
                }
                Code::MissingWrapup => {
                    if let Some(stmt) = quoted_after(help, "e.g.") {
                        push(
                            format!("Add `{stmt}`"),
                            self.insert_at_system_end(span, stmt),
                            true,
                        );
                    }
                }
                Code::PhaseInDerive => {
                    // The declaration's keyword: `module` keeps the
                    // parameters it declares and drops the phase.
                    if matches!(self.slice(span), "skeleton" | "geometry") {
                        push(
                            format!("Change `{}` to `module`", self.slice(span)),
                            vec![edit(span, "module")],
                            true,
                        );
                    }
                }
                Code::MissingPhase | Code::UnknownName => {
                    // The phase the checker's other rules allow first: a
                    // symbol that emits geometry or is emitted by a wrap-up
                    // cannot be a skeleton symbol; one that emits a skeleton
                    // symbol cannot be a geometry symbol.
                    let fits = self.phase_fits(span);
                    let mut fixes: Vec<(bool, String, Vec<TextEdit>)> = Vec::new();
                    for stmt in quoted(help) {
                        let mut words = stmt.trim_end_matches(';').split_whitespace();
                        let (Some(kw), Some(name), None) =
                            (words.next(), words.next(), words.next())
                        else {
                            continue;
                        };
                        let phase = match kw {
                            "skeleton" => Phase::Skeleton,
                            "geometry" => Phase::Geometry,
                            "module" => Phase::None,
                            _ => continue,
                        };
                        let ok = match phase {
                            Phase::Skeleton => fits.0,
                            Phase::Geometry => fits.1,
                            Phase::None => true,
                        };
                        fixes.push((
                            ok,
                            format!("Declare `{name}` as {kw}"),
                            self.declare(span, phase, name),
                        ));
                    }
                    // Those that fit first; preferred if it is the only one.
                    fixes.sort_by_key(|f| !f.0);
                    let fitting = fixes.iter().filter(|f| f.0).count();
                    for (ok, title, edits) in fixes {
                        push(title, edits, ok && fitting == 1);
                    }
                }
                Code::MissingAxiom => {
                    let sys = self.ast_system(span);
                    let first = sys.and_then(|s| {
                        s.items.iter().find_map(|i| match i {
                            SystemItem::Production(p) => Some(p.pred.symbol.name.clone()),
                            _ => None,
                        })
                    });
                    if let Some(name) = first {
                        let stmt = format!("axiom {name};");
                        push(
                            format!("Add `{stmt}`"),
                            self.insert_statement(span, &stmt),
                            true,
                        );
                    }
                }
                Code::DuplicateSetting => {
                    if let Some(s) = self.statement_span(span) {
                        push(
                            "Remove this statement".into(),
                            vec![self.delete_lines(s)],
                            true,
                        );
                    }
                }
                Code::WrapupNotSkeleton => {
                    if self
                        .text()
                        .get(span.range())
                        .is_some_and(|t| t.starts_with("wrapup"))
                    {
                        let mut end = span.start + 6;
                        while self.text().as_bytes().get(end as usize) == Some(&b' ') {
                            end += 1;
                        }
                        push(
                            "Remove `wrapup`".into(),
                            vec![edit(Span::new(span.start, end), "")],
                            true,
                        );
                    } else if let Some(p) = self.production_at(span) {
                        let mut end = p.start + 6;
                        while self.text().as_bytes().get(end as usize) == Some(&b' ') {
                            end += 1;
                        }
                        push(
                            "Remove `wrapup`".into(),
                            vec![edit(Span::new(p.start, end), "")],
                            true,
                        );
                    }
                }
                Code::LoneWeight => {
                    // `(w) ` around the weight's expression.
                    let b = self.text().as_bytes();
                    let mut start = span.start as usize;
                    while start > 0 && b[start - 1].is_ascii_whitespace() {
                        start -= 1;
                    }
                    let mut end = span.end as usize;
                    while end < b.len() && b[end].is_ascii_whitespace() {
                        end += 1;
                    }
                    if start > 0 && b[start - 1] == b'(' && b.get(end) == Some(&b')') {
                        let mut after = end + 1;
                        while after < b.len() && b[after] == b' ' {
                            after += 1;
                        }
                        push(
                            "Remove the weight".into(),
                            vec![edit(Span::from_range(start - 1..after), "")],
                            true,
                        );
                    }
                }
                Code::DeclInsideSystem => {
                    if let Some(edits) = self.move_above_system(span) {
                        push("Move above the system".into(), edits, true);
                    }
                }
                Code::WrapupInDerive => {
                    if let Some(p) = self.production_at(span) {
                        push(
                            "Remove this production".into(),
                            vec![self.delete_lines(p)],
                            false,
                        );
                    }
                }
                _ => {}
            }
            if help.contains("`mode = sample;`") {
                push(
                    "Set `mode = sample;`".into(),
                    self.set_mode_sample(span),
                    false,
                );
            }
        }
        // Semantic tags for shape commands (no diagnostic).
        out.extend(self.tag_actions(range));
        out
    }

    /// For the symbol written at `span` in a sample system: whether the
    /// phase rules allow it to be a skeleton symbol and a geometry symbol
    /// (E0301, E0303, E0308 are what the wrong choice would bring). Both
    /// when the symbol is not known.
    fn phase_fits(&self, span: Span) -> (bool, bool) {
        use grm_sema::{Def, Phase as P};
        let p = &self.checked.program;
        let Some(Def::Symbol(sid, sym)) = p.index.at(self.root, span.start).map(|r| r.def) else {
            return (true, true);
        };
        let Some(sys) = p.systems.get(sid.0 as usize) else {
            return (true, true);
        };
        let (mut skeleton, mut geometry) = (true, true);
        for g in &sys.groups {
            let pred = sys.symbol(g.pred.symbol);
            for a in &g.alternatives {
                let emits = a.successor.iter().any(|m| m.symbol == sym);
                if g.pred.symbol == sym && !g.wrapup {
                    for m in &a.successor {
                        let info = sys.symbol(m.symbol);
                        skeleton &= !info.is_geometry_terminal();
                        geometry &= info.phase != P::Skeleton;
                    }
                }
                if emits && (g.wrapup || pred.phase == P::Geometry) {
                    skeleton = false;
                }
            }
        }
        (skeleton, geometry)
    }

    /// The system of the syntax tree containing `span`.
    fn ast_system(&self, span: Span) -> Option<&grm_syntax::ast::System> {
        self.parsed().file.items.iter().find_map(|i| match i {
            Item::System(s) if s.span.start <= span.start && span.start <= s.span.end => Some(s),
            _ => None,
        })
    }

    /// E0007: cut the declaration starting at `span` (its keyword) out of
    /// the system it was written in and paste it, dedented, on its own
    /// lines above that system.
    fn move_above_system(&self, span: Span) -> Option<Vec<TextEdit>> {
        let items = &self.parsed().file.items;
        let decl = items
            .iter()
            .find(|i| !matches!(i, Item::System(_)) && i.span().start == span.start)?
            .span();
        let sys = items.iter().find_map(|i| match i {
            Item::System(s) if s.span.start < decl.start && decl.end <= s.span.end => Some(s),
            _ => None,
        })?;
        let t = self.text();
        let ls = self.line_start_of(decl.start as usize);
        let indent = &t[ls..decl.start as usize];
        let indent = if indent.trim().is_empty() { indent } else { "" };
        let body = &t[decl.start as usize..decl.end as usize];
        let eol = self.eol();
        let mut text = String::new();
        for (i, line) in body.lines().enumerate() {
            if i > 0 {
                text.push_str(eol);
            }
            text.push_str(if i > 0 {
                line.strip_prefix(indent).unwrap_or(line)
            } else {
                line
            });
        }
        text.push_str(eol);
        text.push_str(eol);
        let at = self.line_start_of(sys.span.start as usize) as u32;
        Some(vec![edit(Span::new(at, at), text), self.delete_lines(decl)])
    }

    /// The production containing `span`.
    fn production_at(&self, span: Span) -> Option<Span> {
        self.ast_system(span)?.items.iter().find_map(|i| match i {
            SystemItem::Production(p) if p.span.start <= span.start && span.end <= p.span.end => {
                Some(p.span)
            }
            _ => None,
        })
    }

    /// The statement (system item or material field) containing `span`.
    fn statement_span(&self, span: Span) -> Option<Span> {
        for item in &self.parsed().file.items {
            match item {
                Item::System(s) => {
                    for i in &s.items {
                        let is = i.span();
                        if is.start <= span.start && span.end <= is.end {
                            return Some(is);
                        }
                    }
                }
                Item::Material(m) => {
                    for f in &m.fields {
                        if f.span.start <= span.start && span.end <= f.span.end {
                            return Some(f.span);
                        }
                    }
                }
                _ => {}
            }
        }
        None
    }

    /// Where the line holding byte `at` starts (lines end at `\n`, `\r\n`
    /// or a lone `\r`, as the file's line table counts them).
    fn line_start_of(&self, at: usize) -> usize {
        let src = self.source();
        let line = src.line_of(u32::try_from(at).unwrap_or(u32::MAX));
        src.line_start(line).map_or(0, |s| s as usize)
    }

    /// Where the line after the one holding byte `at` starts, if there is
    /// one (after its `\n`, `\r\n` or lone `\r`).
    fn next_line_start(&self, at: usize) -> Option<usize> {
        let src = self.source();
        let line = src.line_of(u32::try_from(at).unwrap_or(u32::MAX));
        src.line_start(line.saturating_add(1)).map(|s| s as usize)
    }

    /// The line break inserted lines end with: the file's first one (`\n`,
    /// `\r\n` or a lone `\r`), `\n` in a file of one line.
    fn eol(&self) -> &'static str {
        let t = self.text();
        let i = grm_diag::first_line_len(t);
        match (t.as_bytes().get(i), t.as_bytes().get(i + 1)) {
            (Some(b'\r'), Some(b'\n')) => "\r\n",
            (Some(b'\r'), _) => "\r",
            _ => "\n",
        }
    }

    /// Delete a statement; with its whole line when nothing else is on it.
    fn delete_lines(&self, s: Span) -> TextEdit {
        let t = self.text();
        let ls = self.line_start_of(s.start as usize);
        let le = self.next_line_start(s.end as usize).unwrap_or(t.len());
        let alone =
            t[ls..s.start as usize].trim().is_empty() && t[s.end as usize..le].trim().is_empty();
        if alone {
            edit(Span::from_range(ls..le), "")
        } else {
            edit(s, "")
        }
    }

    /// The indentation of the statements of a system.
    fn indent_of(&self, sys: &grm_syntax::ast::System) -> String {
        let t = self.text();
        sys.items
            .first()
            .map(|i| {
                let st = i.span().start as usize;
                let ls = self.line_start_of(st);
                let pre = &t[ls..st];
                if pre.trim().is_empty() {
                    pre.to_string()
                } else {
                    "    ".to_string()
                }
            })
            .unwrap_or_else(|| "    ".into())
    }

    /// Insert a statement before the closing `}` of the system containing `at`.
    fn insert_at_system_end(&self, at: Span, stmt: &str) -> Vec<TextEdit> {
        let Some(sys) = self.ast_system(at) else {
            return Vec::new();
        };
        let t = self.text();
        let body = self.slice(sys.span);
        if !body.ends_with('}') {
            let end = sys.span.end;
            return vec![edit(
                Span::new(end, end),
                format!("{nl}{}{stmt}{nl}", self.indent_of(sys), nl = self.eol()),
            )];
        }
        let close = sys.span.end as usize - 1;
        let ls = self.line_start_of(close);
        if t[ls..close].trim().is_empty() && ls > sys.span.start as usize {
            let at = ls as u32;
            vec![edit(
                Span::new(at, at),
                format!("{}{stmt}{}", self.indent_of(sys), self.eol()),
            )]
        } else {
            let at = close as u32;
            vec![edit(Span::new(at, at), format!("{stmt} "))]
        }
    }

    /// Insert a statement before the first production of the system
    /// containing `at` (or at its end when it has none).
    fn insert_statement(&self, at: Span, stmt: &str) -> Vec<TextEdit> {
        let Some(sys) = self.ast_system(at) else {
            return Vec::new();
        };
        let t = self.text();
        let first = sys.items.iter().find_map(|i| match i {
            SystemItem::Production(p) => Some(p.span.start as usize),
            _ => None,
        });
        match first {
            Some(st) => {
                let ls = self.line_start_of(st);
                if t[ls..st].trim().is_empty() {
                    let at = ls as u32;
                    vec![edit(
                        Span::new(at, at),
                        format!("{}{stmt}{}", self.indent_of(sys), self.eol()),
                    )]
                } else {
                    let at = st as u32;
                    vec![edit(Span::new(at, at), format!("{stmt} "))]
                }
            }
            None => self.insert_at_system_end(at, stmt),
        }
    }

    /// Declare `name` with a phase: appended to an existing declaration of
    /// that phase in the system, or as a new statement.
    fn declare(&self, at: Span, phase: Phase, name: &str) -> Vec<TextEdit> {
        let Some(sys) = self.ast_system(at) else {
            return Vec::new();
        };
        let existing = sys.items.iter().find_map(|i| match i {
            SystemItem::ModuleDecl(d) if d.phase == phase => d.modules.last().map(|m| m.span.end),
            _ => None,
        });
        match existing {
            Some(end) => vec![edit(Span::new(end, end), format!(", {name}"))],
            None => {
                let kw = match phase {
                    Phase::None => "module",
                    Phase::Skeleton => "skeleton",
                    Phase::Geometry => "geometry",
                };
                self.insert_statement(at, &format!("{kw} {name};"))
            }
        }
    }

    /// Set `mode = sample;` in the system containing `at`.
    fn set_mode_sample(&self, at: Span) -> Vec<TextEdit> {
        let Some(sys) = self.ast_system(at) else {
            return Vec::new();
        };
        for i in &sys.items {
            if let SystemItem::Setting(s) = i
                && s.name.name == "mode"
            {
                return vec![edit(s.value.span, "sample")];
            }
        }
        // After the opening brace's line.
        let t = self.text();
        let Some(brace) = t[sys.span.range()].find('{') else {
            return Vec::new();
        };
        let brace = sys.span.start as usize + brace;
        let nl = self.next_line_start(brace);
        match nl {
            Some(ls) if ls < sys.span.end as usize => {
                let at = ls as u32;
                vec![edit(
                    Span::new(at, at),
                    format!("{}mode = sample;{}", self.indent_of(sys), self.eol()),
                )]
            }
            _ => {
                let at = brace as u32 + 1;
                vec![edit(Span::new(at, at), " mode = sample;")]
            }
        }
    }
}

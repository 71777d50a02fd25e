//! Hover: what the thing under the cursor is, its type or value, and for a
//! production's predecessor, weight or arrow the probability of each
//! alternative of its group.

use crate::docs::{self, DocKind};
use crate::{FileAnalysis, Span};
use grm_sema::{
    Def, Group, Program, SettingKey, SymbolInfo, SymbolKind, System, TExpr, TExprKind, Ty, Value,
};
use grm_syntax::ast::{Item, Phase, SystemItem};
use grm_syntax::lexer::TokKind;

/// Hover text (markdown) and the span it describes.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Hover {
    pub span: Span,
    pub markdown: String,
}

fn code(s: &str) -> String {
    format!("```grm\n{s}\n```")
}

/// A probability as a percentage with up to one decimal.
pub(crate) fn percent(p: f64) -> String {
    let x = (p * 1000.0).round() / 10.0;
    if x.fract() == 0.0 {
        format!("{x:.0}%")
    } else {
        format!("{x:.1}%")
    }
}

/// A symbol's signature: `A(len: float, w: vec3)`.
pub(crate) fn symbol_signature(info: &SymbolInfo) -> String {
    if info.arity == 0 {
        return info.name.clone();
    }
    let ps: Vec<String> = info
        .params
        .iter()
        .enumerate()
        .map(
            |(i, t)| match info.param_names.get(i).and_then(|n| n.as_deref()) {
                Some(n) => format!("{n}: {t}"),
                None => t.to_string(),
            },
        )
        .collect();
    format!("{}({})", info.name, ps.join(", "))
}

impl FileAnalysis {
    /// Hover at a byte offset.
    pub fn hover(&self, offset: u32) -> Option<Hover> {
        if self
            .parsed()
            .comments
            .iter()
            .any(|c| c.span.contains(offset))
        {
            return None;
        }
        if let Some(h) = self.shape_hover(offset) {
            return Some(h);
        }
        if let Some(r) = self.ref_at(offset) {
            let md = self.hover_def(r.def, r.loc.span, offset)?;
            return Some(Hover {
                span: r.loc.span,
                markdown: md,
            });
        }
        let (kind, span) = self.token_at(offset)?;
        let text = self.slice(span);
        // The weight or arrow of a production: its group's probabilities.
        if matches!(kind, TokKind::Arrow | TokKind::LParen | TokKind::RParen)
            && let Some((sys, g, i)) = self.group_at(offset, kind == TokKind::Arrow)
        {
            return Some(Hover {
                span,
                markdown: group_table(self, sys, g, Some(i)),
            });
        }
        if let Some(md) = self.hover_word(kind, span, text) {
            return Some(Hover { span, markdown: md });
        }
        // Any other expression: its type and constant value.
        if let Some(e) = self.expr_at(offset) {
            let mut md = format!("`{}`", e.ty);
            if let Some(v) = e.constant()
                && !matches!(v, Value::Mesh(_) | Value::Material(_))
            {
                md = format!("{md} = `{v}`");
            }
            if let Some(g) = self.weight_group(e.span) {
                md.push_str("\n\n");
                md.push_str(&group_table(self, g.0, g.1, Some(g.2)));
            }
            return Some(Hover {
                span: e.span,
                markdown: md,
            });
        }
        None
    }

    fn hover_def(&self, def: Def, span: Span, offset: u32) -> Option<String> {
        let p: &Program = &self.checked.program;
        Some(match def {
            Def::Const(id) => {
                let c = p.consts.get(id.index())?;
                let mut s = code(&format!("const {}: {}", c.name, c.ty));
                match c.value.constant() {
                    Some(v) => s.push_str(&format!("\n\nvalue: `{v}`")),
                    None => s.push_str("\n\nvalue depends on meta-parameters"),
                }
                s.push_str(&self.leading_comment(c.loc));
                s
            }
            Def::Param(id) => {
                let m = p.params.get(id.index())?;
                let range = m
                    .range
                    .map(|(lo, hi)| format!(" in {lo} .. {hi}"))
                    .unwrap_or_default();
                let mut s = code(&format!(
                    "param {}: {} = {}{range}",
                    m.name, m.ty, m.default
                ));
                s.push_str("\n\nmeta-parameter: a slider in the preview");
                s.push_str(&self.leading_comment(m.loc));
                s
            }
            Def::Mesh(id) => {
                let m = p.meshes.get(id.index())?;
                format!(
                    "{}\n\nfile: `{}`",
                    code(&format!("mesh {} = \"{}\"", m.name, m.written)),
                    m.path.display()
                )
            }
            Def::Material(id) => {
                let m = p.materials.get(id.index())?;
                let fields: Vec<String> = m
                    .fields
                    .iter()
                    .map(|f| match f.value.constant() {
                        Some(v) => format!("    {} = {v};", f.prop.name()),
                        None => format!("    {}: {};", f.prop.name(), f.value.ty),
                    })
                    .collect();
                code(&format!(
                    "material {} {{\n{}\n}}",
                    m.name,
                    fields.join("\n")
                ))
            }
            Def::System(id) => {
                let s = p.systems.get(id.index())?;
                let mut md = code(&format!("system {}", s.name));
                let mode = s.mode.name();
                let user = s.symbols.iter().filter(|x| !x.is_terminal()).count();
                let prods: usize = s.groups.iter().map(|g| g.alternatives.len()).sum();
                md.push_str(&format!(
                    "\n\nmode `{mode}`, {} iteration{}, {user} symbol{}, {prods} production{}",
                    s.settings.iterations,
                    plural(s.settings.iterations as usize),
                    plural(user),
                    plural(prods)
                ));
                md.push_str(&self.leading_comment(s.loc));
                md
            }
            Def::Symbol(sid, id) => {
                let sys = p.systems.get(sid.index())?;
                let info = sys.symbols.get(id.index())?;
                match info.kind {
                    SymbolKind::Terminal(_) => {
                        let written = self.slice(span);
                        let e = docs::lookup(written, DocKind::Terminal)
                            .or_else(|| docs::lookup(&info.name, DocKind::Terminal))?;
                        let carries: Vec<&str> = info.params.iter().map(|t| t.name()).collect();
                        if carries.is_empty() {
                            format!("{}\n\ncarries no parameters", e.markdown())
                        } else {
                            format!("{}\n\ncarries ({})", e.markdown(), carries.join(", "))
                        }
                    }
                    SymbolKind::User => {
                        let kw = match info.phase {
                            Phase::None => "module",
                            Phase::Skeleton => "skeleton",
                            Phase::Geometry => "geometry",
                        };
                        let mut md = code(&format!("{kw} {}", symbol_signature(info)));
                        let n: usize = sys.groups_of(id).map(|g| g.alternatives.len()).sum();
                        let w: usize = sys.wrapups_of(id).map(|g| g.alternatives.len()).sum();
                        md.push_str(&format!(
                            "\n\nin system `{}`: {n} production{}",
                            sys.name,
                            plural(n)
                        ));
                        if w > 0 {
                            md.push_str(&format!(", {w} wrap-up{}", plural(w)));
                        }
                        if n == 0 && w == 0 {
                            md.push_str(" (inert: copied unchanged)");
                        }
                        if let Some((_, g, i)) = self.group_at(offset, false) {
                            md.push_str("\n\n");
                            md.push_str(&group_table(self, sys, g, Some(i)));
                        }
                        md
                    }
                }
            }
            Def::Binding { binding } => {
                let (owner, ty) = self.binding_info(binding.file, binding.span)?;
                format!(
                    "{}\n\nparameter of `{owner}`",
                    code(&format!(
                        "{}: {ty}",
                        self.slice_in(binding.file, binding.span)
                    ))
                )
            }
        })
    }

    fn slice_in(&self, file: grm_diag::FileId, span: Span) -> &str {
        self.sources.get(file).text.get(span.range()).unwrap_or("")
    }

    /// The predecessor symbol name and type of the binding written at `span`.
    pub(crate) fn binding_info(&self, file: grm_diag::FileId, span: Span) -> Option<(String, Ty)> {
        for sys in self
            .checked
            .program
            .systems
            .iter()
            .filter(|s| s.file == file)
        {
            for g in &sys.groups {
                for a in &g.alternatives {
                    if let Some(b) = a.bindings.iter().find(|b| b.span == span) {
                        // The pattern the binding belongs to.
                        let owner = self
                            .checked
                            .program
                            .index
                            .refs
                            .iter()
                            .rfind(|r| {
                                r.loc.file == file
                                    && r.loc.span.end <= span.start
                                    && a.span.contains(r.loc.span.start)
                                    && matches!(r.def, Def::Symbol(..))
                            })
                            .map(|r| self.slice_in(file, r.loc.span).to_string())
                            .unwrap_or_else(|| sys.symbol(g.pred.symbol).name.clone());
                        return Some((owner, b.ty));
                    }
                }
            }
        }
        None
    }

    /// Comments on the lines right above a definition in this file.
    fn leading_comment(&self, loc: grm_sema::Loc) -> String {
        if loc.file != self.root {
            return String::new();
        }
        let src = self.source();
        let (line, _) = src.line_col(loc.span.start);
        let mut lines = Vec::new();
        let mut want = line;
        for c in self.parsed().comments.iter().rev() {
            if c.span.start >= loc.span.start {
                continue;
            }
            let (l0, _) = src.line_col(c.span.start);
            let (l1, _) = src.line_col(c.span.end);
            if want == 0 || l1 + 1 != want {
                break;
            }
            lines.push(
                c.text
                    .trim_start_matches("//")
                    .trim_start_matches("/*")
                    .trim_end_matches("*/")
                    .trim()
                    .to_string(),
            );
            want = l0;
        }
        if lines.is_empty() {
            return String::new();
        }
        lines.reverse();
        format!("\n\n---\n{}", lines.join("\n"))
    }

    /// Hover for keywords, function names, settings, types and mode values.
    fn hover_word(&self, kind: TokKind, span: Span, text: &str) -> Option<String> {
        if kind != TokKind::Ident && kind != TokKind::Str && docs::is_keyword(text) {
            return docs::lookup(text, DocKind::Keyword).map(|e| e.markdown());
        }
        if kind != TokKind::Ident {
            return None;
        }
        let next = self.next_token(span.end);
        let prev = self.prev_token(span.start);
        if next == Some(TokKind::LParen)
            && let Some(e) = docs::function(text)
        {
            return Some(e.markdown());
        }
        if prev == Some(TokKind::Colon)
            && let Some(e) = docs::lookup(text, DocKind::Type)
        {
            return Some(e.markdown());
        }
        if matches!(text, "derive" | "sample" | "shape")
            && let Some(e) = docs::lookup(text, DocKind::ModeValue)
        {
            return Some(e.markdown());
        }
        if next == Some(TokKind::Assign) {
            if let Some((sys, key)) = self.setting_at(span.start) {
                let e = docs::lookup(key.name(), DocKind::Setting)?;
                let mut md = e.markdown();
                if let Some(se) = sys.setting_exprs.iter().find(|s| s.key == key)
                    && let Some(v) = se.value.constant()
                {
                    md.push_str(&format!("\n\nvalue: `{v}`"));
                }
                return Some(md);
            }
            if self.in_material(span.start) {
                return docs::lookup(text, DocKind::MaterialProp).map(|e| e.markdown());
            }
            // A shape system's own setting (`lot`).
            if self.shape_system_at(span.start).is_some() {
                return docs::lookup(text, DocKind::Setting).map(|e| e.markdown());
            }
        }
        None
    }

    /// The system (of this file) whose setting statement starts at `start`.
    fn setting_at(&self, start: u32) -> Option<(&System, SettingKey)> {
        for item in &self.parsed().file.items {
            if let Item::System(s) = item {
                for it in &s.items {
                    if let SystemItem::Setting(set) = it
                        && set.name.span.start == start
                    {
                        let key = SettingKey::from_name(&set.name.name)?;
                        let sys = self
                            .checked
                            .program
                            .systems
                            .iter()
                            .find(|x| x.file == self.root && x.span == s.span)?;
                        return Some((sys, key));
                    }
                }
            }
        }
        None
    }

    fn in_material(&self, offset: u32) -> bool {
        self.parsed()
            .file
            .items
            .iter()
            .any(|i| matches!(i, Item::Material(m) if m.span.contains(offset)))
    }

    pub(crate) fn next_token(&self, end: u32) -> Option<TokKind> {
        let i = self.tokens().partition_point(|(_, s)| s.start < end);
        self.tokens().get(i).map(|t| t.0)
    }

    pub(crate) fn prev_token(&self, start: u32) -> Option<TokKind> {
        let i = self.tokens().partition_point(|(_, s)| s.end <= start);
        self.tokens().get(i.checked_sub(1)?).map(|t| t.0)
    }

    /// The group (and alternative index) whose production in this file has
    /// its predecessor (or, with `arrow`, its `->`) or weight at `offset`.
    pub(crate) fn group_at(&self, offset: u32, arrow: bool) -> Option<(&System, &Group, usize)> {
        for sys in self.root_systems() {
            for g in &sys.groups {
                for (i, a) in g.alternatives.iter().enumerate() {
                    let on_pred = a.pred.contains(offset);
                    let on_arrow = arrow && (a.arrow.contains(offset) || a.arrow.end == offset);
                    // The weight's parentheses sit between the arrow and
                    // the first successor module.
                    let on_weight = a.weight_written && {
                        let end = a
                            .successor
                            .first()
                            .map(|m| m.span.start)
                            .unwrap_or(a.span.end);
                        offset >= a.arrow.end && offset < end
                    };
                    if on_pred || on_arrow || on_weight {
                        return Some((sys, g, i));
                    }
                }
            }
        }
        None
    }

    /// The group whose alternative's weight expression is `span`.
    fn weight_group(&self, span: Span) -> Option<(&System, &Group, usize)> {
        for sys in self.root_systems() {
            for g in &sys.groups {
                for (i, a) in g.alternatives.iter().enumerate() {
                    if a.weight_written && a.weight.span == span {
                        return Some((sys, g, i));
                    }
                }
            }
        }
        None
    }

    pub(crate) fn root_systems(&self) -> impl Iterator<Item = &System> {
        self.checked
            .program
            .systems
            .iter()
            .filter(|s| s.file == self.root)
    }

    /// The smallest typed expression of this file containing `offset`.
    pub(crate) fn expr_at<'a>(&'a self, offset: u32) -> Option<&'a TExpr> {
        let mut roots: Vec<&TExpr> = Vec::new();
        let mut consider = |e: &'a TExpr| roots.push(e);
        let p = &self.checked.program;
        for c in p.consts.iter().filter(|c| c.loc.file == self.root) {
            consider(&c.value);
        }
        for m in p.materials.iter().filter(|m| m.loc.file == self.root) {
            for f in &m.fields {
                consider(&f.value);
            }
        }
        for sys in self.root_systems() {
            if !sys.span.contains(offset) {
                continue;
            }
            for s in &sys.setting_exprs {
                consider(&s.value);
            }
            for m in &sys.axiom {
                for a in &m.args {
                    consider(a);
                }
            }
            for g in &sys.groups {
                if let Some(c) = &g.condition {
                    consider(c);
                }
                for a in &g.alternatives {
                    if !a.span.contains(offset) {
                        continue;
                    }
                    if a.weight_written {
                        consider(&a.weight);
                    }
                    for m in &a.successor {
                        // Filled-in defaults carry the module's span.
                        if m.args.iter().any(|x| x.span == m.span) {
                            continue;
                        }
                        for x in &m.args {
                            consider(x);
                        }
                    }
                }
            }
        }
        let mut best: Option<&TExpr> = None;
        let mut stack = roots;
        while let Some(e) = stack.pop() {
            if !(e.span.contains(offset) || (e.span.end == offset && !e.span.is_empty())) {
                continue;
            }
            if matches!(e.kind, TExprKind::Error) {
                continue;
            }
            if best.is_none_or(|b| e.span.len() <= b.span.len()) {
                best = Some(e);
            }
            match &e.kind {
                TExprKind::Unary(_, a) | TExprKind::Field(a, _) => stack.push(a),
                TExprKind::Binary(_, a, b) => {
                    stack.push(a);
                    stack.push(b);
                }
                TExprKind::If(a, b, c) => {
                    stack.push(a);
                    stack.push(b);
                    stack.push(c);
                }
                TExprKind::Call(_, args) | TExprKind::Random(_, args) => {
                    stack.extend(args.iter());
                }
                _ => {}
            }
        }
        best
    }
}

fn plural(n: usize) -> &'static str {
    if n == 1 { "" } else { "s" }
}

/// A markdown table of a group's alternatives and their probabilities.
pub(crate) fn group_table(
    fa: &FileAnalysis,
    sys: &System,
    g: &Group,
    current: Option<usize>,
) -> String {
    let name = &sys.symbol(g.pred.symbol).name;
    let probs = g.probabilities();
    let mut s = format!(
        "{}group of `{name}`: {} alternative{}\n\n| | line | weight | probability |\n|---|---|---|---|\n",
        if g.wrapup { "wrap-up " } else { "" },
        g.alternatives.len(),
        plural(g.alternatives.len())
    );
    let src = fa.sources.get(sys.file);
    for (i, a) in g.alternatives.iter().enumerate() {
        let (line, _) = src.line_col(a.span.start);
        let w = match a.weight.constant() {
            Some(v) => v.to_string(),
            None => src
                .text
                .get(a.weight.span.range())
                .unwrap_or("?")
                .to_string(),
        };
        let p = match &probs {
            Some(ps) => percent(ps[i]),
            None => "depends on parameters".into(),
        };
        let mark = if current == Some(i) { "▶" } else { "" };
        s.push_str(&format!("| {mark} | {} | {w} | {p} |\n", line + 1));
    }
    s
}

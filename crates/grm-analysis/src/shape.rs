//! Shape systems (`mode = shape`, docs/language.md section 8) as the editor
//! reads them: every word of a shape rule that means something only there
//! (operations, axes, component kinds and selectors, roof kinds,
//! primitives, tags, `nil`, part sizes and separators, shape values) is a
//! [`Site`], found in the syntax tree, so hover, semantic tokens and
//! completion work whatever the checker makes of the system (and while the
//! text is being typed). Shape symbols are read from the tree too: a shape
//! system's checked form keeps them in its own table.

use crate::complete::{Ctx, keyword};
use crate::docs::{self, DocEntry, DocKind};
use crate::{CompletionItem, CompletionKind, FileAnalysis, Span};
use grm_sema::shape::{Axis, CENTER_AXES, CompTarget, Primitive, RoofKind, Selector, ShapeQuery};
use grm_syntax::ast::{Expr, ExprKind, Item, Module, PartKind, Symbol, System, SystemItem};
use grm_syntax::lexer::TokKind;

/// What a word of a shape system is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Role {
    /// An operation's name (`split`, `extrude`, `[`).
    Op,
    /// `x`, `y`, `z`, `xy`, ... or `_` as an operation's argument.
    Axis,
    /// `faces` or `edges`.
    CompKind,
    /// A component split's case selector (`front`, `side`).
    Selector,
    RoofKind,
    /// `box`, `cylinder`, ... in `insert(...)`.
    Primitive,
    /// A semantic tag (a command's last argument, `tagged(tag)`).
    Tag,
    /// `nil`: a part that makes nothing.
    Nil,
    /// `~` of a floating part.
    Tilde,
    /// `%` of a relative part.
    Percent,
    /// `{`, `}`, `|` and `:` of a command's parts.
    PartPunct,
    /// `scope`, `index`, `count`, `depth`.
    Value,
    /// `tagged`, `overlaps`, `touches`, `inside`.
    ValueFn,
    /// `rect`, `polygon` in `lot = ...`.
    Lot,
    /// A shape symbol (a rule's predecessor, a successor, a part's target,
    /// a context query's argument).
    Symbol,
}

impl Role {
    /// A weak role gives way to what the checker resolved the name to (a
    /// constant named `count` is the constant).
    pub(crate) fn weak(self) -> bool {
        matches!(self, Role::Value | Role::Symbol)
    }

    /// The documentation table's kind for this role, if it has entries.
    fn doc_kind(self) -> Option<DocKind> {
        Some(match self {
            Role::Op | Role::Nil => DocKind::ShapeOp,
            Role::Axis => DocKind::Axis,
            Role::CompKind => DocKind::CompKind,
            Role::Selector => DocKind::Selector,
            Role::RoofKind => DocKind::RoofKind,
            Role::Primitive => DocKind::Primitive,
            Role::Value | Role::ValueFn => DocKind::ShapeValue,
            Role::Lot => DocKind::Lot,
            Role::Tilde | Role::Percent => DocKind::PartSize,
            Role::Tag | Role::PartPunct | Role::Symbol => return None,
        })
    }
}

/// A classified word of a shape system.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Site {
    pub span: Span,
    pub role: Role,
}

/// Whether a system is a shape system (`mode = shape;`).
pub(crate) fn is_shape_system(s: &System) -> bool {
    s.items.iter().any(|i| {
        matches!(i, SystemItem::Setting(set)
            if set.name.name == "mode"
                && matches!(&set.value.kind, ExprKind::Name(n) if n.name == "shape"))
    })
}

/// The operations of a shape rule, by name.
pub(crate) fn is_op(name: &str) -> bool {
    docs::lookup(name, DocKind::ShapeOp).is_some() && name != "nil"
}

/// Shape values read as names in expressions.
const VALUES: &[&str] = &["scope", "index", "count", "depth"];
/// Shape values called as functions: `tagged` takes a tag, the context
/// queries a symbol.
fn is_value_fn(name: &str) -> bool {
    name == "tagged" || ShapeQuery::from_name(name).is_some()
}

/// The name of an expression that is a bare name.
fn name_of(e: &Expr) -> Option<(&str, Span)> {
    match &e.kind {
        ExprKind::Name(id) => Some((id.name.as_str(), id.span)),
        _ => None,
    }
}

/// A shape command (`split`, `repeat`, `comp`) of a rule.
#[derive(Clone, Debug)]
pub(crate) struct Command<'a> {
    pub module: &'a Module,
    /// The tag written, if any.
    pub tag: Option<&'a str>,
}

impl<'a> Command<'a> {
    pub(crate) fn of(m: &'a Module) -> Option<Command<'a>> {
        if !matches!(m.symbol.name.as_str(), "split" | "repeat" | "comp") {
            return None;
        }
        Some(Command {
            module: m,
            tag: m.args.get(1).and_then(name_of).map(|n| n.0),
        })
    }
}

/// The rules (predecessor and operations) and the axiom of a shape system.
pub(crate) fn rules(s: &System) -> impl Iterator<Item = (Option<&Symbol>, &[Module])> {
    s.items.iter().filter_map(|i| match i {
        SystemItem::Production(p) => Some((Some(&p.pred.symbol), &p.successor[..])),
        SystemItem::Axiom(a) => Some((None, &a.modules[..])),
        _ => None,
    })
}

/// The shape symbols of a system, in order of first appearance:
/// predecessors, successors that are not operations, parts' targets.
pub(crate) fn symbols(s: &System) -> Vec<(&str, Span)> {
    fn add<'a>(out: &mut Vec<(&'a str, Span)>, n: &'a str, sp: Span) {
        if n != "nil" && !out.iter().any(|(m, _)| *m == n) {
            out.push((n, sp));
        }
    }
    let mut out: Vec<(&str, Span)> = Vec::new();
    for (pred, modules) in rules(s) {
        if let Some(p) = pred {
            add(&mut out, &p.name, p.span);
        }
        for m in modules {
            let name = m.symbol.name.as_str();
            if !m.symbol.is_punct() && !is_op(name) {
                add(&mut out, name, m.symbol.span);
            }
            for p in m.parts.iter().flat_map(|p| &p.parts) {
                add(&mut out, &p.target.name, p.target.span);
            }
        }
    }
    out
}

impl FileAnalysis {
    /// The shape systems of this file (syntax trees).
    pub(crate) fn shape_systems(&self) -> impl Iterator<Item = &System> {
        self.parsed().file.items.iter().filter_map(|i| match i {
            Item::System(s) if is_shape_system(s) => Some(s),
            _ => None,
        })
    }

    /// The shape system whose text holds `offset` (an unclosed system runs
    /// to the end of the file).
    pub(crate) fn shape_system_at(&self, offset: u32) -> Option<&System> {
        self.shape_systems().find(|s| {
            s.span.start < offset
                && (offset < s.span.end
                    || (offset == s.span.end && !self.slice(s.span).ends_with('}')))
        })
    }

    /// Every classified word of this file's shape systems, sorted by start.
    pub(crate) fn shape_sites(&self) -> Vec<Site> {
        let mut out = Vec::new();
        for s in self.shape_systems() {
            self.system_sites(s, &mut out);
        }
        out.sort_by_key(|x| (x.span.start, x.span.end));
        out.dedup_by_key(|x| x.span);
        out
    }

    /// The site at `offset`, if any.
    pub(crate) fn shape_site_at(&self, offset: u32) -> Option<Site> {
        self.shape_sites()
            .into_iter()
            .find(|x| x.span.contains(offset) || (x.span.end == offset && !x.span.is_empty()))
    }

    fn system_sites(&self, s: &System, out: &mut Vec<Site>) {
        let mut push = |span: Span, role: Role| out.push(Site { span, role });
        let mut exprs: Vec<&Expr> = Vec::new();
        for item in &s.items {
            match item {
                SystemItem::Setting(set) if set.name.name == "lot" => {
                    if let ExprKind::Call { func, args } = &set.value.kind
                        && docs::lookup(&func.name, DocKind::Lot).is_some()
                    {
                        push(func.span, Role::Lot);
                        exprs.extend(args);
                    }
                }
                SystemItem::Production(p) => {
                    push(p.pred.symbol.span, Role::Symbol);
                    exprs.extend(p.condition.as_ref());
                    exprs.extend(p.weight.as_ref());
                }
                _ => {}
            }
        }
        for (_, modules) in rules(s) {
            for m in modules {
                let name = m.symbol.name.as_str();
                let op = is_op(name);
                push(
                    m.symbol.span,
                    if op {
                        Role::Op
                    } else if name == "nil" {
                        Role::Nil
                    } else {
                        Role::Symbol
                    },
                );
                for (i, a) in m.args.iter().enumerate() {
                    let role = name_of(a).and_then(|(n, _)| arg_role(name, i, n));
                    match role {
                        Some(r) => push(a.span, r),
                        None => exprs.push(a),
                    }
                }
                if let Some(parts) = &m.parts {
                    let comp = name == "comp";
                    for p in &parts.parts {
                        match name_of(&p.value) {
                            Some((n, sp))
                                if comp
                                    && p.kind == PartKind::Absolute
                                    && Selector::from_name(n).is_some() =>
                            {
                                push(sp, Role::Selector)
                            }
                            _ => exprs.push(&p.value),
                        }
                        let target = if p.target.name == "nil" {
                            Role::Nil
                        } else {
                            Role::Symbol
                        };
                        push(p.target.span, target);
                    }
                    let toks = self.tokens();
                    let from = toks.partition_point(|(_, t)| t.start < parts.span.start);
                    for &(k, t) in toks[from..]
                        .iter()
                        .take_while(|(_, t)| t.end <= parts.span.end)
                    {
                        match k {
                            TokKind::Tilde => push(t, Role::Tilde),
                            TokKind::PercentSize => push(t, Role::Percent),
                            TokKind::PartsOpen
                            | TokKind::PartsClose
                            | TokKind::Pipe
                            | TokKind::Colon => push(t, Role::PartPunct),
                            _ => {}
                        }
                    }
                }
            }
        }
        // Shape values in conditions, weights and sizes.
        while let Some(e) = exprs.pop() {
            match &e.kind {
                ExprKind::Name(id) if VALUES.contains(&id.name.as_str()) => {
                    push(id.span, Role::Value)
                }
                ExprKind::Call { func, args } if is_value_fn(&func.name) => {
                    push(func.span, Role::ValueFn);
                    let role = if func.name == "tagged" {
                        Role::Tag
                    } else {
                        Role::Symbol
                    };
                    for a in args {
                        match name_of(a) {
                            Some((_, sp)) => push(sp, role),
                            None => exprs.push(a),
                        }
                    }
                }
                // `index(tag)`, `count(tag)`: a tag's index and count (as
                // the checker reads them: one bare name).
                ExprKind::Call { func, args }
                    if matches!(func.name.as_str(), "index" | "count")
                        && args.len() == 1
                        && name_of(&args[0]).is_some() =>
                {
                    push(args[0].span, Role::Tag)
                }
                ExprKind::Call { args, .. } => exprs.extend(args),
                ExprKind::Unary { operand, .. } => exprs.push(operand),
                ExprKind::Binary { lhs, rhs, .. } => exprs.extend([&**lhs, &**rhs]),
                ExprKind::Field { base, .. } => exprs.push(base),
                ExprKind::If { cond, then, els } => exprs.extend([&**cond, &**then, &**els]),
                ExprKind::Paren(inner) => exprs.push(inner),
                _ => {}
            }
        }
    }

    /// Every tag written in this file's shape systems (commands' tags and
    /// `tagged(...)`, `index(...)`, `count(...)` arguments) with its span,
    /// in order.
    pub(crate) fn shape_tags(&self) -> Vec<(String, Span)> {
        self.shape_sites()
            .into_iter()
            .filter(|s| s.role == Role::Tag)
            .map(|s| (self.slice(s.span).to_string(), s.span))
            .collect()
    }

    /// The tag under `offset` and the shape system it is written in: a
    /// tag has no declaration, it is the same name in one system's
    /// commands and shape values (Lipp's semantic tags, docs/shapes.md).
    pub(crate) fn tag_at(&self, offset: u32) -> Option<(Span, &System)> {
        let sys = self.shape_system_at(offset)?;
        let mut sites = Vec::new();
        self.system_sites(sys, &mut sites);
        let site = sites.into_iter().find(|x| {
            x.role == Role::Tag
                && (x.span.contains(offset) || (x.span.end == offset && !x.span.is_empty()))
        })?;
        Some((site.span, sys))
    }

    /// Every place `sys` writes the tag `name`, in order.
    pub(crate) fn tag_occurrences(&self, sys: &System, name: &str) -> Vec<Span> {
        let mut sites = Vec::new();
        self.system_sites(sys, &mut sites);
        let mut out: Vec<Span> = sites
            .into_iter()
            .filter(|x| x.role == Role::Tag && self.slice(x.span) == name)
            .map(|x| x.span)
            .collect();
        out.sort_by_key(|s| (s.start, s.end));
        out.dedup();
        out
    }
}

/// The role of a bare-name argument `n` at position `i` of operation `op`.
pub(crate) fn arg_role(op: &str, i: usize, n: &str) -> Option<Role> {
    match (op, i) {
        ("split" | "repeat" | "rotate", 0) if Axis::from_name(n).is_some() => Some(Role::Axis),
        ("center", 0) if CENTER_AXES.contains(&n) => Some(Role::Axis),
        ("size", _) if n == "_" => Some(Role::Axis),
        ("comp", 0) if CompTarget::from_name(n).is_some() => Some(Role::CompKind),
        ("roof", 0) if RoofKind::from_name(n).is_some() => Some(Role::RoofKind),
        ("insert", 0) if Primitive::from_name(n).is_some() => Some(Role::Primitive),
        ("split" | "repeat" | "comp", 1) => Some(Role::Tag),
        _ => None,
    }
}

/// The documentation of a site's word, if the table has it.
pub(crate) fn site_doc(role: Role, word: &str) -> Option<&'static DocEntry> {
    docs::lookup(word, role.doc_kind()?)
}

impl FileAnalysis {
    /// Hover on a word of a shape system: an operation, argument word,
    /// part size, shape value, tag or shape symbol.
    pub(crate) fn shape_hover(&self, offset: u32) -> Option<crate::Hover> {
        let site = self.shape_site_at(offset)?;
        let word = self.slice(site.span);
        let resolved = self
            .ref_at(offset)
            .is_some_and(|r| !matches!(r.def, grm_sema::Def::Symbol(..)));
        if site.role.weak() && resolved {
            return None;
        }
        let markdown = match site.role {
            Role::Tag => self.tag_markdown(word),
            Role::Symbol => self.shape_symbol_markdown(word, offset)?,
            Role::PartPunct => return None,
            r => site_doc(r, word)?.markdown(),
        };
        Some(crate::Hover {
            span: site.span,
            markdown,
        })
    }

    /// A tag: what it names, and where this file writes it.
    fn tag_markdown(&self, tag: &str) -> String {
        let mut md = format!("```grm\ntag {tag}\n```\n\n");
        match docs::lookup(tag, DocKind::Tag) {
            Some(e) => md.push_str(&format!("*semantic tag*: {}", e.doc)),
            None => md.push_str("*semantic tag*"),
        }
        let src = self.source();
        let lines: Vec<String> = self
            .shape_commands()
            .iter()
            .filter(|c| c.tag == Some(tag))
            .map(|c| (src.line_col(c.module.span.start).0 + 1).to_string())
            .collect();
        if lines.is_empty() {
            md.push_str("\n\nno command of this file carries it");
        } else {
            md.push_str(&format!(
                "\n\non {} command{} (line{} {}): each shape below one is numbered in its semantic locator, `{tag} 1`, `{tag} 2`, ...",
                lines.len(),
                if lines.len() == 1 { "" } else { "s" },
                if lines.len() == 1 { "" } else { "s" },
                lines.join(", ")
            ));
        }
        md
    }

    /// A shape symbol: its rules, or that it is a terminal shape.
    fn shape_symbol_markdown(&self, name: &str, offset: u32) -> Option<String> {
        let sys = self.shape_system_at(offset)?;
        let src = self.source();
        let lines: Vec<String> = sys
            .items
            .iter()
            .filter_map(|i| match i {
                SystemItem::Production(p) if p.pred.symbol.name == name => {
                    Some((src.line_col(p.span.start).0 + 1).to_string())
                }
                _ => None,
            })
            .collect();
        let mut md = format!(
            "```grm\nshape {name}\n```\n\nin shape system `{}`: ",
            sys.name.name
        );
        if lines.is_empty() {
            md.push_str("no rules: a terminal shape, drawn as its geometry");
        } else {
            md.push_str(&format!(
                "{} rule{} (line{} {})",
                lines.len(),
                if lines.len() == 1 { "" } else { "s" },
                if lines.len() == 1 { "" } else { "s" },
                lines.join(", ")
            ));
        }
        let axiom = sys.items.iter().any(|i| {
            matches!(i, SystemItem::Axiom(a) if a.modules.iter().any(|m| m.symbol.name == name))
        });
        if axiom {
            md.push_str("; the axiom: grown from the lot");
        }
        Some(md)
    }

    /// The shape commands (`split`, `repeat`, `comp`) of this file's shape
    /// systems, in order.
    pub(crate) fn shape_commands(&self) -> Vec<Command<'_>> {
        let mut out = Vec::new();
        for s in self.shape_systems() {
            for (_, modules) in rules(s) {
                out.extend(modules.iter().filter_map(Command::of));
            }
        }
        out
    }
}

/// Where the cursor is inside a shape rule's text, read from the
/// statement's tokens.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Spot<'a> {
    /// Between operations of a rule (or the axiom).
    Operations,
    /// Argument `arg` of a call: an operation's (`module`) or a function's.
    Arg {
        callee: Option<&'a str>,
        arg: usize,
        module: bool,
    },
    /// A part's size (or a case's selector, for `comp`).
    PartSize { command: Option<&'a str> },
    /// A part's target symbol (after its `:`).
    PartTarget,
    /// An expression outside calls (a condition, a setting's value).
    Expr,
}

enum Frame<'a> {
    Paren {
        callee: Option<&'a str>,
        commas: usize,
        module: bool,
    },
    Parts {
        command: Option<&'a str>,
        colon: bool,
    },
}

/// Snippets of the operations that take arguments or parts.
fn op_snippet(name: &str) -> Option<&'static str> {
    Some(match name {
        "split" => "split(${1|x,y,z|}) { ${2:~1}: ${3:A} }",
        "repeat" => "repeat(${1|x,y,z|}) { ${2:~1}: ${3:A} }",
        "comp" => "comp(${1|faces,edges|}) { ${2:side}: ${3:A} }",
        "roof" => "roof(${1|hip,gable,flat,shed,pyramid|}, ${2:30})",
        "rotate" => "rotate(${1|x,y,z|}, ${2:90})",
        "center" => "center(${1|xy,x,y,z,xz,yz,xyz|})",
        "translate" => "translate(${1:0}, ${2:0}, ${3:0})",
        "size" => "size(${1:_}, ${2:_}, ${3:_})",
        "insert" => "insert(${1|box,cylinder,cone,sphere,disc|})",
        "extrude" => "extrude($1)",
        "taper" => "taper($1)",
        "offset" => "offset($1)",
        "material" => "material($1)",
        "color" => "color(rgb($1))",
        "texture" => "texture(\"$1\")",
        _ => return None,
    })
}

impl FileAnalysis {
    /// Completion in a shape system; `None` where the general completion
    /// applies (outside shape systems, the mode's value, top-level items).
    pub(crate) fn shape_completion(&self, ctx: Ctx, offset: u32) -> Option<Vec<CompletionItem>> {
        let sys = self.shape_system_at(offset)?;
        let mut out = Vec::new();
        match ctx {
            Ctx::SystemStatement => {
                for e in docs::of_kind(DocKind::Setting)
                    .filter(|e| matches!(e.name, "mode" | "seed" | "lot"))
                {
                    out.push(
                        CompletionItem::new(e.name, CompletionKind::Setting)
                            .detail(e.signatures.first().copied().unwrap_or(""))
                            .doc(e.markdown())
                            .snippet(format!("{} = $1;", e.name)),
                    );
                }
                out.push(keyword("axiom"));
                self.push_shape_symbols(sys, offset, &mut out);
                out.push(
                    CompletionItem::new("rule", CompletionKind::Snippet)
                        .detail("Symbol -> operations;")
                        .doc("a rule: `Symbol [: condition] -> [(weight)] operations;`")
                        .snippet("${1:A} -> ${2:split(${3|x,y,z|}) { ${4:~1}: ${5:B} }};"),
                );
                return Some(out);
            }
            Ctx::Pattern => {
                self.push_shape_symbols(sys, offset, &mut out);
                return Some(out);
            }
            Ctx::Expr | Ctx::Modules | Ctx::MeshName | Ctx::MaterialName => {}
            _ => return None,
        }
        let a = self.around(offset);
        let spot = self.spot(a.toks);
        let first = a.toks.first().map(|t| self.slice(t.1));
        match spot {
            Spot::Operations => {
                for e in docs::of_kind(DocKind::ShapeOp).filter(|e| e.name != "nil") {
                    let mut item = CompletionItem::new(e.name, CompletionKind::Turtle)
                        .detail(e.signatures.last().copied().unwrap_or(e.name))
                        .doc(e.markdown());
                    if let Some(s) = op_snippet(e.name) {
                        item = item.snippet(s);
                    }
                    out.push(item);
                }
                self.push_shape_symbols(sys, offset, &mut out);
            }
            Spot::PartTarget => {
                self.push_shape_symbols(sys, offset, &mut out);
                out.push(word(DocKind::ShapeOp, "nil", CompletionKind::Keyword));
            }
            Spot::PartSize {
                command: Some("comp"),
            } => {
                for n in Selector::names() {
                    out.push(word(DocKind::Selector, n, CompletionKind::Value));
                }
            }
            Spot::PartSize { .. } => self.push_shape_expr(offset, &mut out),
            Spot::Arg {
                callee: Some(f),
                arg,
                module,
            } => {
                let words: Option<(DocKind, Vec<&str>)> = match (f, arg, module) {
                    ("split" | "repeat" | "rotate", 0, true) => {
                        Some((DocKind::Axis, Axis::names().collect()))
                    }
                    ("center", 0, true) => Some((DocKind::Axis, CENTER_AXES.to_vec())),
                    ("comp", 0, true) => Some((DocKind::CompKind, CompTarget::names().collect())),
                    ("roof", 0, true) => Some((DocKind::RoofKind, RoofKind::names().collect())),
                    ("insert", 0, true) => Some((DocKind::Primitive, Primitive::names().collect())),
                    _ => None,
                };
                if let Some((kind, names)) = words {
                    for n in names {
                        out.push(word(kind, n, CompletionKind::Value));
                    }
                    if f == "insert" {
                        for m in &self.checked.program.meshes {
                            out.push(
                                CompletionItem::new(&m.name, CompletionKind::Resource)
                                    .detail(format!("mesh \"{}\"", m.written)),
                            );
                        }
                    }
                } else if (module && arg == 1 && matches!(f, "split" | "repeat" | "comp"))
                    || (!module && f == "tagged" && arg == 0)
                {
                    self.push_tags(offset, &mut out);
                } else if !module && ShapeQuery::from_name(f).is_some() && arg == 0 {
                    self.push_shape_symbols(sys, offset, &mut out);
                } else if module && f == "material" {
                    for m in &self.checked.program.materials {
                        out.push(
                            CompletionItem::new(&m.name, CompletionKind::Resource)
                                .detail("material"),
                        );
                    }
                } else {
                    if module && f == "size" {
                        out.push(word(DocKind::Axis, "_", CompletionKind::Value));
                    }
                    self.push_shape_expr(offset, &mut out);
                }
            }
            Spot::Arg { callee: None, .. } => self.push_shape_expr(offset, &mut out),
            Spot::Expr if first == Some("lot") => {
                for e in docs::of_kind(DocKind::Lot) {
                    out.push(
                        CompletionItem::new(e.name, CompletionKind::Function)
                            .detail(e.signatures[0])
                            .doc(e.markdown())
                            .snippet(format!("{}($1)", e.name)),
                    );
                }
                self.push_expr(Ctx::Expr, offset, &mut out);
            }
            Spot::Expr => self.push_shape_expr(offset, &mut out),
        }
        Some(out)
    }

    /// Where the cursor is among a statement's tokens (those before it).
    fn spot<'a>(&'a self, toks: &[(TokKind, Span)]) -> Spot<'a> {
        let mut modules = false;
        let mut stack: Vec<Frame<'a>> = Vec::new();
        for (i, &(k, _)) in toks.iter().enumerate() {
            let prev = |j: usize| j.checked_sub(1).map(|j| toks[j]);
            match k {
                TokKind::Arrow | TokKind::Axiom => {
                    modules = true;
                    stack.clear();
                }
                TokKind::LParen => {
                    let callee = prev(i)
                        .filter(|t| t.0 == TokKind::Ident)
                        .map(|t| self.slice(t.1));
                    // A weight's parentheses follow the arrow directly.
                    let weight = prev(i).is_some_and(|t| t.0 == TokKind::Arrow);
                    stack.push(Frame::Paren {
                        callee,
                        commas: 0,
                        module: modules && stack.is_empty() && !weight,
                    });
                }
                TokKind::RParen => {
                    if matches!(stack.last(), Some(Frame::Paren { .. })) {
                        stack.pop();
                    }
                }
                TokKind::Comma => {
                    if let Some(Frame::Paren { commas, .. }) = stack.last_mut() {
                        *commas += 1;
                    }
                }
                TokKind::PartsOpen | TokKind::PolyOpen if modules => {
                    // The command: `name(...) {`.
                    let mut command = None;
                    if prev(i).is_some_and(|t| t.0 == TokKind::RParen) {
                        let mut depth = 0i32;
                        for j in (0..i).rev() {
                            match toks[j].0 {
                                TokKind::RParen => depth += 1,
                                TokKind::LParen => {
                                    depth -= 1;
                                    if depth == 0 {
                                        command = prev(j)
                                            .filter(|t| t.0 == TokKind::Ident)
                                            .map(|t| self.slice(t.1));
                                        break;
                                    }
                                }
                                _ => {}
                            }
                        }
                    }
                    stack.push(Frame::Parts {
                        command,
                        colon: false,
                    });
                }
                TokKind::PartsClose | TokKind::PolyClose => {
                    if matches!(stack.last(), Some(Frame::Parts { .. })) {
                        stack.pop();
                    }
                }
                TokKind::Colon => {
                    if let Some(Frame::Parts { colon, .. }) = stack.last_mut() {
                        *colon = true;
                    }
                }
                TokKind::Pipe => {
                    if let Some(Frame::Parts { colon, .. }) = stack.last_mut() {
                        *colon = false;
                    }
                }
                _ => {}
            }
        }
        match stack.last() {
            Some(&Frame::Paren {
                callee,
                commas,
                module,
            }) => Spot::Arg {
                callee,
                arg: commas,
                module,
            },
            Some(&Frame::Parts { colon: true, .. }) => Spot::PartTarget,
            Some(&Frame::Parts { command, .. }) => Spot::PartSize { command },
            None if modules => Spot::Operations,
            None => Spot::Expr,
        }
    }

    /// An expression of a shape system: globals, functions, random draws,
    /// keywords, and the shape values.
    fn push_shape_expr(&self, offset: u32, out: &mut Vec<CompletionItem>) {
        for e in docs::of_kind(DocKind::ShapeValue) {
            let mut item = CompletionItem::new(e.name, CompletionKind::Value)
                .detail(e.signatures[0])
                .doc(e.markdown());
            if is_value_fn(e.name) {
                item.kind = CompletionKind::Function;
                item = item.snippet(format!("{}($1)", e.name));
            }
            out.push(item);
        }
        self.push_expr(Ctx::Expr, offset, out);
    }

    /// The symbols of a shape system, less one being typed at the cursor.
    fn push_shape_symbols(&self, sys: &System, offset: u32, out: &mut Vec<CompletionItem>) {
        let typing = |s: Span| s.start <= offset && offset <= s.end;
        for (name, first) in symbols(sys) {
            let elsewhere = typing(first)
                && rules(sys).any(|(p, ms)| {
                    p.is_some_and(|p| p.name == name && !typing(p.span))
                        || ms.iter().any(|m| {
                            (m.symbol.name == name && !typing(m.symbol.span))
                                || m.parts
                                    .iter()
                                    .flat_map(|p| &p.parts)
                                    .any(|p| p.target.name == name && !typing(p.target.span))
                        })
                });
            if typing(first) && !elsewhere {
                continue;
            }
            out.push(CompletionItem::new(name, CompletionKind::Module).detail("shape"));
        }
    }

    /// The tags this file uses (most used first), then the usual ones it
    /// does not.
    fn push_tags(&self, offset: u32, out: &mut Vec<CompletionItem>) {
        let mut used: Vec<(String, usize)> = Vec::new();
        for (t, span) in self.shape_tags() {
            if span.start <= offset && offset <= span.end {
                continue;
            }
            match used.iter_mut().find(|u| u.0 == t) {
                Some(u) => u.1 += 1,
                None => used.push((t, 1)),
            }
        }
        used.sort_by_key(|u| std::cmp::Reverse(u.1));
        for (t, n) in &used {
            let mut item = CompletionItem::new(t, CompletionKind::Value).detail(format!(
                "tag, used {n} time{} in this file",
                if *n == 1 { "" } else { "s" }
            ));
            if let Some(e) = docs::lookup(t, DocKind::Tag) {
                item = item.doc(e.markdown());
            }
            out.push(item);
        }
        for e in docs::of_kind(DocKind::Tag) {
            if !used.iter().any(|u| u.0 == e.name) {
                out.push(word(DocKind::Tag, e.name, CompletionKind::Value));
            }
        }
    }
}

/// A completion of a documented word.
fn word(kind: DocKind, name: &str, ck: CompletionKind) -> CompletionItem {
    let mut item = CompletionItem::new(name, ck).detail(kind.describe());
    if let Some(e) = docs::lookup(name, kind) {
        item = item.doc(e.markdown());
    }
    item
}

//! Completion and signature help.
//!
//! The context is read from the tokens of the statement around the cursor
//! (not from the syntax tree, which may not exist yet for the statement
//! being typed): inside parentheses or after `:` / `=` an expression is
//! expected; after `->`, `axiom` or `ignore` a module string; at the start
//! of a system statement a setting, keyword or predecessor.
//!
//! Where a name is being defined nothing is proposed: a system's name, the
//! parameters a pattern binds (`A(x) ->`) and the parameter list of a
//! declared signature. A declaration list (`module`, `skeleton`,
//! `geometry`) proposes only user symbols that it may still declare, and a
//! constant's or meta-parameter's value leaves out the globals that would
//! make it cyclic (E0210).

use crate::docs::{self, DocKind};
use crate::hover::symbol_signature;
use crate::{FileAnalysis, Span};
use grm_sema::{Phase, SymbolKind, System};
use grm_syntax::ast::{Expr, ExprKind, Item, SystemItem};
use grm_syntax::lexer::TokKind;
use std::collections::HashSet;

/// What a completion item is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum CompletionKind {
    Keyword,
    Snippet,
    Module,
    Turtle,
    Parameter,
    Constant,
    MetaParameter,
    Function,
    Setting,
    Resource,
    System,
    Value,
}

/// A completion proposal.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CompletionItem {
    pub label: String,
    pub kind: CompletionKind,
    pub detail: Option<String>,
    /// Markdown.
    pub documentation: Option<String>,
    /// Text to insert instead of the label; a snippet (`$1`, `${1:x}`)
    /// when `snippet` is set.
    pub insert_text: Option<String>,
    pub snippet: bool,
}

impl CompletionItem {
    pub(crate) fn new(label: impl Into<String>, kind: CompletionKind) -> CompletionItem {
        CompletionItem {
            label: label.into(),
            kind,
            detail: None,
            documentation: None,
            insert_text: None,
            snippet: false,
        }
    }

    pub(crate) fn detail(mut self, d: impl Into<String>) -> Self {
        self.detail = Some(d.into());
        self
    }

    pub(crate) fn doc(mut self, d: impl Into<String>) -> Self {
        self.documentation = Some(d.into());
        self
    }

    pub(crate) fn snippet(mut self, s: impl Into<String>) -> Self {
        self.insert_text = Some(s.into());
        self.snippet = true;
        self
    }
}

/// One signature: its label, its parameters as byte ranges into the label,
/// and its documentation (markdown).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Signature {
    pub label: String,
    pub params: Vec<(usize, usize)>,
    pub doc: String,
}

/// Signature help for a call or terminal under the cursor.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SignatureHelp {
    pub signatures: Vec<Signature>,
    pub active_signature: usize,
    pub active_parameter: usize,
}

/// Where the cursor is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Ctx {
    /// Nothing to propose (in a comment or string).
    None,
    /// Start of a top-level item.
    TopLevel,
    /// An expression outside any system (const, param, material field),
    /// with the name of the const or param being defined, if any.
    GlobalExpr(Option<Span>),
    /// A material field name.
    MaterialField,
    /// Start of a statement in a system.
    SystemStatement,
    /// Before `->`: predecessor or contexts.
    Pattern,
    /// A module string (successor, axiom, ignore list).
    Modules,
    /// The symbol list of a `module` / `skeleton` / `geometry`
    /// declaration (outside its parentheses).
    Declaration(Phase),
    /// An expression in a system (condition, weight, argument, setting).
    Expr,
    /// After `mode =`.
    ModeValue,
    /// Inside `mesh(` ... `)`.
    MeshName,
    /// Inside `material(` ... `)`.
    MaterialName,
}

/// The statement tokens before the cursor and what encloses them.
pub(crate) struct Around<'a> {
    /// Tokens of the current statement up to the cursor (the partial word
    /// being typed excluded).
    pub(crate) toks: &'a [(TokKind, Span)],
    system: Option<&'a grm_syntax::ast::System>,
    material: bool,
}

impl FileAnalysis {
    pub(crate) fn around(&self, offset: u32) -> Around<'_> {
        // Tokens entirely before the cursor, minus a word being typed.
        let mut end = self.tokens().partition_point(|(_, s)| s.end < offset);
        if let Some(&(k, s)) = self.tokens().get(end)
            && s.end == offset
            && s.start < offset
            && !matches!(k, TokKind::Ident | TokKind::Number)
            && !is_keyword_tok(k)
        {
            // A punctuation token ending at the cursor belongs to the context.
            end += 1;
        }
        let mut begin = end;
        while begin > 0 {
            match self.tokens()[begin - 1].0 {
                TokKind::Semi | TokKind::LBrace | TokKind::RBrace => break,
                _ => begin -= 1,
            }
        }
        let system = self.parsed().file.items.iter().find_map(|i| match i {
            // An unclosed system runs to the end of the file.
            Item::System(s)
                if s.span.start < offset
                    && (offset < s.span.end
                        || (offset == s.span.end && !self.slice(s.span).ends_with('}'))) =>
            {
                Some(s)
            }
            _ => None,
        });
        let material = self.parsed().file.items.iter().any(
            |i| matches!(i, Item::Material(m) if m.span.start < offset && offset < m.span.end),
        );
        Around {
            toks: &self.tokens()[begin..end],
            system,
            material,
        }
    }

    fn context(&self, offset: u32) -> Ctx {
        let in_comment = self.parsed().comments.iter().any(|c| {
            c.span.start < offset
                && (offset < c.span.end || (offset == c.span.end && c.text.starts_with("//")))
        });
        let in_string = self
            .tokens()
            .iter()
            .any(|(k, s)| *k == TokKind::Str && s.start < offset && offset < s.end);
        if in_comment || in_string {
            return Ctx::None;
        }
        let a = self.around(offset);
        let toks = a.toks;
        let mut depth = 0i32;
        let mut arrow = false;
        let mut modules = false;
        let mut colon = false;
        let mut assign = false;
        let mut call: Option<&str> = None;
        let mut calls: Vec<Option<&str>> = Vec::new();
        for (i, &(k, s)) in toks.iter().enumerate() {
            match k {
                TokKind::LParen => {
                    depth += 1;
                    let callee = i
                        .checked_sub(1)
                        .map(|j| toks[j])
                        .filter(|(k, _)| {
                            matches!(k, TokKind::Ident | TokKind::Mesh | TokKind::Material)
                        })
                        .map(|(_, s)| self.slice(s));
                    calls.push(callee);
                    call = callee;
                }
                TokKind::RParen => {
                    depth -= 1;
                    calls.pop();
                    call = calls.last().copied().flatten();
                }
                TokKind::Arrow => arrow = true,
                TokKind::Axiom
                | TokKind::Ignore
                | TokKind::Module
                | TokKind::Skeleton
                | TokKind::Geometry
                    if i == 0 || toks[0].0 == TokKind::Wrapup =>
                {
                    modules = true
                }
                TokKind::Colon if depth == 0 => colon = true,
                TokKind::Assign if depth == 0 => assign = true,
                _ => {}
            }
            let _ = s;
        }
        let first = toks.first().map(|t| t.0);
        if first == Some(TokKind::System) {
            // `system NAME {`: the system's name is being defined (the
            // enclosing system already starts at the keyword).
            return Ctx::None;
        }
        if a.system.is_none() && !a.material {
            return match first {
                None => Ctx::TopLevel,
                Some(TokKind::Const | TokKind::Param) if assign || depth > 0 => {
                    // `const NAME [: ty] = ...`: the name, to keep out of
                    // its own value.
                    let name = toks.get(1).filter(|t| t.0 == TokKind::Ident);
                    Ctx::GlobalExpr(name.map(|t| t.1))
                }
                _ => Ctx::None,
            };
        }
        if a.material && a.system.is_none() {
            return if toks.is_empty() {
                Ctx::MaterialField
            } else if assign {
                Ctx::GlobalExpr(None)
            } else {
                Ctx::None
            };
        }
        let decl = match first {
            Some(TokKind::Module) => Some(Phase::None),
            Some(TokKind::Skeleton) => Some(Phase::Skeleton),
            Some(TokKind::Geometry) => Some(Phase::Geometry),
            _ => None,
        };
        if let Some(phase) = decl {
            // Inside parentheses: the parameter names and types of a
            // declared signature, not expressions.
            return if depth > 0 {
                Ctx::None
            } else {
                Ctx::Declaration(phase)
            };
        }
        if depth > 0 && !arrow && !modules && !colon && !assign {
            // The parameters of a predecessor or context pattern
            // (`A(x, y) ->`): new names bound here, nothing to propose.
            return Ctx::None;
        }
        if depth > 0 {
            return match call {
                Some("mesh") if arrow || modules => Ctx::MeshName,
                Some("material") if arrow || modules => Ctx::MaterialName,
                _ => Ctx::Expr,
            };
        }
        if toks.is_empty() {
            return Ctx::SystemStatement;
        }
        if arrow || modules {
            return Ctx::Modules;
        }
        if assign {
            let first = self.slice(toks[0].1);
            return if first == "mode" {
                Ctx::ModeValue
            } else {
                Ctx::Expr
            };
        }
        if colon {
            return Ctx::Expr;
        }
        Ctx::Pattern
    }

    /// The system (checked) whose text contains `offset`.
    fn system_at(&self, offset: u32) -> Option<&System> {
        self.root_systems()
            .find(|s| s.span.start < offset && offset <= s.span.end)
    }

    /// Completion proposals at `offset`.
    pub fn completion(&self, offset: u32) -> Vec<CompletionItem> {
        let offset = offset.min(self.text().len() as u32);
        let ctx = self.context(offset);
        if let Some(items) = self.shape_completion(ctx, offset) {
            return items;
        }
        let mut out = Vec::new();
        match ctx {
            Ctx::None => {}
            Ctx::TopLevel => {
                for kw in ["import", "const", "param", "mesh", "material", "system"] {
                    out.push(keyword(kw));
                }
                out.push(
                    CompletionItem::new("system …", CompletionKind::Snippet)
                        .detail("a new system")
                        .snippet("system ${1:Name} {\n    iterations = ${2:4};\n    angle = ${3:25};\n    axiom ${4:A};\n\n    ${4:A} -> ${5:F [ + ${4:A} ] F ${4:A}};\n}"),
                );
            }
            Ctx::MaterialField => {
                for e in docs::of_kind(DocKind::MaterialProp) {
                    out.push(
                        CompletionItem::new(e.name, CompletionKind::Setting)
                            .detail(e.signatures.first().copied().unwrap_or(""))
                            .doc(e.markdown())
                            .snippet(format!("{} = $1;", e.name)),
                    );
                }
            }
            Ctx::SystemStatement => {
                // `lot` is a shape system's (offered there).
                for e in docs::of_kind(DocKind::Setting).filter(|e| e.name != "lot") {
                    out.push(
                        CompletionItem::new(e.name, CompletionKind::Setting)
                            .detail(e.signatures.first().copied().unwrap_or(""))
                            .doc(e.markdown())
                            .snippet(format!("{} = $1;", e.name)),
                    );
                }
                for kw in [
                    "axiom", "ignore", "module", "skeleton", "geometry", "wrapup",
                ] {
                    out.push(keyword(kw));
                }
                self.push_symbols(offset, &mut out);
                out.push(
                    CompletionItem::new("production", CompletionKind::Snippet)
                        .detail("PRED -> SUCCESSOR;")
                        .doc("a production: `[LEFT <] PRED [> RIGHT] [: CONDITION] -> [(WEIGHT)] SUCCESSOR;`")
                        .snippet("${1:A} -> ${2:F ${1:A}};"),
                );
                out.push(
                    CompletionItem::new("stochastic productions", CompletionKind::Snippet)
                        .detail("PRED -> (w) ...; PRED -> (w) ...;")
                        .doc("two alternatives drawn with probability weight / sum of weights")
                        .snippet("${1:A} -> (${2:1}) ${3:F [ + ${1:A} ]};\n${1:A} -> (${4:1}) ${5:F [ - ${1:A} ]};"),
                );
            }
            Ctx::Pattern => self.push_symbols(offset, &mut out),
            Ctx::Modules => {
                self.push_symbols(offset, &mut out);
                for e in docs::of_kind(DocKind::Terminal) {
                    let mut item = CompletionItem::new(e.name, CompletionKind::Turtle)
                        .detail(e.signatures.last().copied().unwrap_or(e.name))
                        .doc(e.markdown());
                    let first = e.signatures.first().copied().unwrap_or("");
                    if first.contains('(') && e.name.chars().all(char::is_alphanumeric) {
                        item = item.snippet(format!("{}($1)", e.name));
                    }
                    out.push(item);
                }
            }
            Ctx::Declaration(phase) => self.push_undeclared(offset, phase, &mut out),
            Ctx::Expr | Ctx::GlobalExpr(_) => self.push_expr(ctx, offset, &mut out),
            Ctx::ModeValue => {
                for e in docs::of_kind(DocKind::ModeValue) {
                    out.push(CompletionItem::new(e.name, CompletionKind::Value).doc(e.markdown()));
                }
            }
            Ctx::MeshName => {
                for m in &self.checked.program.meshes {
                    out.push(
                        CompletionItem::new(&m.name, CompletionKind::Resource)
                            .detail(format!("mesh \"{}\"", m.written)),
                    );
                }
            }
            Ctx::MaterialName => {
                for m in &self.checked.program.materials {
                    out.push(
                        CompletionItem::new(&m.name, CompletionKind::Resource).detail("material"),
                    );
                }
            }
        }
        out
    }

    /// What an expression may hold: the production's parameters (in a
    /// system), globals, functions (and random draws, in a system) and the
    /// expression keywords.
    pub(crate) fn push_expr(&self, ctx: Ctx, offset: u32, out: &mut Vec<CompletionItem>) {
        if ctx == Ctx::Expr {
            for b in self.bindings_before(offset) {
                out.push(CompletionItem::new(b, CompletionKind::Parameter).detail("parameter"));
            }
        }
        // A constant's value may not use the constant itself, nor
        // a global defined in terms of it (E0210).
        let cyclic = match ctx {
            Ctx::GlobalExpr(Some(name)) => self.dependents_of(self.slice(name)),
            _ => HashSet::new(),
        };
        self.push_globals(out, |n| !cyclic.contains(n));
        for e in docs::of_kind(DocKind::Function)
            .chain(docs::of_kind(DocKind::Random).filter(|_| ctx == Ctx::Expr))
        {
            out.push(
                CompletionItem::new(e.name, CompletionKind::Function)
                    .detail(e.signatures.first().copied().unwrap_or(""))
                    .doc(e.markdown())
                    .snippet(format!("{}($1)", e.name)),
            );
        }
        for kw in ["if", "then", "else", "true", "false"] {
            out.push(keyword(kw));
        }
    }

    fn push_symbols(&self, offset: u32, out: &mut Vec<CompletionItem>) {
        let Some(sys) = self.system_at(offset) else {
            return;
        };
        for info in &sys.symbols {
            if info.kind != SymbolKind::User {
                continue;
            }
            out.push(
                CompletionItem::new(&info.name, CompletionKind::Module)
                    .detail(symbol_signature(info)),
            );
        }
    }

    /// The user symbols of the system at `offset` that a declaration list
    /// introduced by `phase` may still declare. Terminals cannot be
    /// declared (E0102). A `skeleton` / `geometry` list leaves out the
    /// symbols that already have a phase (the same one would be redundant,
    /// the other one conflicts); a symbol declared only by a `module` list
    /// (parameters, no phase) is still proposed there. A `module` list
    /// leaves out the symbols declared in any list.
    fn push_undeclared(&self, offset: u32, phase: Phase, out: &mut Vec<CompletionItem>) {
        let Some(sys) = self.system_at(offset) else {
            return;
        };
        let a = self.around(offset);
        let counts = |p: Phase| phase == Phase::None || p != Phase::None;
        // The word at the cursor is being typed: not a declaration yet.
        let at_cursor = |s: Span| s.start <= offset && offset <= s.end;
        let mut declared: HashSet<&str> = HashSet::new();
        for item in a.system.iter().flat_map(|s| &s.items) {
            if let SystemItem::ModuleDecl(d) = item
                && counts(d.phase)
            {
                declared.extend(
                    d.modules
                        .iter()
                        .filter(|m| !at_cursor(m.symbol.span))
                        .map(|m| m.symbol.name.as_str()),
                );
            }
        }
        // The names already listed by the declaration being written, which
        // may not have parsed yet: identifiers outside its parentheses.
        let mut depth = 0i32;
        for &(k, s) in a.toks.iter().skip(1) {
            match k {
                TokKind::LParen => depth += 1,
                TokKind::RParen => depth -= 1,
                TokKind::Ident if depth == 0 => {
                    declared.insert(self.slice(s));
                }
                _ => {}
            }
        }
        for info in &sys.symbols {
            // A symbol first seen at the cursor is the word being typed.
            if info.kind != SymbolKind::User
                || declared.contains(info.name.as_str())
                || at_cursor(info.first)
            {
                continue;
            }
            out.push(
                CompletionItem::new(&info.name, CompletionKind::Module)
                    .detail(symbol_signature(info)),
            );
        }
    }

    /// The constants and meta-parameters written in this file whose value
    /// depends on `name`, directly or through others, and `name` itself:
    /// using one of them in `name`'s value would make a cycle (E0210).
    /// Imported globals cannot depend on this file's.
    fn dependents_of(&self, name: &str) -> HashSet<String> {
        // Each global of this file with the names its value mentions.
        let mut deps: Vec<(&str, Vec<&str>)> = Vec::new();
        for item in &self.parsed().file.items {
            let (def, exprs): (&str, Vec<&Expr>) = match item {
                Item::Const(c) => (&c.name.name, vec![&c.value]),
                Item::Param(p) => {
                    let mut v = vec![&p.default];
                    if let Some((lo, hi)) = &p.range {
                        v.extend([lo, hi]);
                    }
                    (&p.name.name, v)
                }
                _ => continue,
            };
            deps.push((def, names_in(exprs)));
        }
        let mut out: HashSet<String> = HashSet::from([name.to_string()]);
        // Grow the set to a fixed point (each round adds a global or ends).
        loop {
            let before = out.len();
            for (def, names) in &deps {
                if !out.contains(*def) && names.iter().any(|n| out.contains(*n)) {
                    out.insert(def.to_string());
                }
            }
            if out.len() == before {
                return out;
            }
        }
    }

    fn push_globals(&self, out: &mut Vec<CompletionItem>, keep: impl Fn(&str) -> bool) {
        let p = &self.checked.program;
        for c in p.consts.iter().filter(|c| keep(&c.name)) {
            let d = match c.value.constant() {
                Some(v) => format!("const {}: {} = {v}", c.name, c.ty),
                None => format!("const {}: {}", c.name, c.ty),
            };
            out.push(CompletionItem::new(&c.name, CompletionKind::Constant).detail(d));
        }
        for m in p.params.iter().filter(|m| keep(&m.name)) {
            out.push(
                CompletionItem::new(&m.name, CompletionKind::MetaParameter)
                    .detail(format!("param {}: {} = {}", m.name, m.ty, m.default)),
            );
        }
    }

    /// Names bound by the patterns of the production being written: the
    /// identifiers in parentheses before `->` (or before the cursor).
    fn bindings_before(&self, offset: u32) -> Vec<String> {
        let a = self.around(offset);
        let mut out: Vec<String> = Vec::new();
        let mut depth = 0;
        for (i, &(k, s)) in a.toks.iter().enumerate() {
            match k {
                TokKind::Arrow | TokKind::Colon => break,
                TokKind::LParen => depth += 1,
                TokKind::RParen => depth -= 1,
                TokKind::Ident if depth == 1 => {
                    let after = a.toks.get(i + 1).map(|t| t.0);
                    if matches!(after, Some(TokKind::Comma | TokKind::RParen) | None) {
                        let n = self.slice(s).to_string();
                        if !out.contains(&n) {
                            out.push(n);
                        }
                    }
                }
                _ => {}
            }
        }
        // Patterns after the cursor (completing a condition typed before
        // the rest): also the finished production's bindings.
        for sys in self.root_systems() {
            for g in &sys.groups {
                for alt in &g.alternatives {
                    if alt.span.contains(offset) {
                        for b in &alt.bindings {
                            if !out.iter().any(|n| n == b.name.as_str()) {
                                out.push(b.name.to_string());
                            }
                        }
                    }
                }
            }
        }
        out
    }

    /// Signature help for the call or terminal whose parentheses contain
    /// `offset`.
    pub fn signature_help(&self, offset: u32) -> Option<SignatureHelp> {
        let offset = offset.min(self.text().len() as u32);
        let a = self.around(offset);
        let toks = a.toks;
        // The innermost unclosed `(` before the cursor.
        let mut depth = 0i32;
        let mut commas = 0usize;
        let mut open = None;
        for i in (0..toks.len()).rev() {
            match toks[i].0 {
                TokKind::RParen => depth += 1,
                TokKind::LParen if depth > 0 => depth -= 1,
                TokKind::LParen => {
                    open = Some(i);
                    break;
                }
                TokKind::Comma if depth == 0 => commas += 1,
                _ => {}
            }
        }
        let open = open?;
        let (ck, cs) = toks.get(open.checked_sub(1)?)?;
        let name = self.slice(*cs);
        // Is the callee a module (depth 0 of a module string) or a function?
        let mut d = 0i32;
        let mut module_string = false;
        for &(k, _) in &toks[..open - 1] {
            match k {
                TokKind::LParen => d += 1,
                TokKind::RParen => d -= 1,
                TokKind::Arrow | TokKind::Axiom => module_string = true,
                _ => {}
            }
        }
        let module_pos = module_string && d == 0;
        let entry = if self.shape_system_at(offset).is_some() {
            // A shape operation, a shape value or lot function, a function.
            docs::lookup(name, DocKind::ShapeOp)
                .filter(|_| module_pos)
                .or_else(|| docs::lookup(name, DocKind::ShapeValue))
                .or_else(|| docs::lookup(name, DocKind::Lot))
                .or_else(|| docs::function(name).filter(|_| *ck == TokKind::Ident))
        } else if module_pos {
            docs::lookup(name, DocKind::Terminal)
        } else if *ck == TokKind::Ident {
            docs::function(name)
        } else {
            None
        }?;
        let signatures: Vec<Signature> = entry
            .signatures
            .iter()
            .filter(|s| s.contains('('))
            .map(|s| Signature {
                label: s.to_string(),
                params: docs::signature_params(s),
                doc: entry.doc.to_string(),
            })
            .collect();
        if signatures.is_empty() {
            return None;
        }
        let variadic = entry.signatures.iter().any(|s| s.contains("..."));
        let active_signature = signatures
            .iter()
            .position(|s| s.params.len() > commas)
            .unwrap_or(0);
        let n = signatures[active_signature].params.len();
        let active_parameter = if variadic && commas >= n {
            n.saturating_sub(1)
        } else {
            commas.min(n.saturating_sub(1))
        };
        Some(SignatureHelp {
            signatures,
            active_signature,
            active_parameter,
        })
    }
}

/// The names an expression mentions (not function or field names), walked
/// without recursion: a parsed expression may nest arbitrarily deep.
fn names_in(roots: Vec<&Expr>) -> Vec<&str> {
    let mut out = Vec::new();
    let mut stack = roots;
    while let Some(e) = stack.pop() {
        match &e.kind {
            ExprKind::Name(id) => out.push(id.name.as_str()),
            ExprKind::Call { args, .. } => stack.extend(args),
            ExprKind::Unary { operand, .. } => stack.push(operand),
            ExprKind::Binary { lhs, rhs, .. } => stack.extend([&**lhs, &**rhs]),
            ExprKind::Field { base, .. } => stack.push(base),
            ExprKind::If { cond, then, els } => stack.extend([&**cond, &**then, &**els]),
            ExprKind::Paren(inner) => stack.push(inner),
            ExprKind::Number { .. } | ExprKind::Bool(_) | ExprKind::Str(_) | ExprKind::Error => {}
        }
    }
    out
}

pub(crate) fn keyword(kw: &str) -> CompletionItem {
    let mut item = CompletionItem::new(kw, CompletionKind::Keyword);
    if let Some(e) = docs::lookup(kw, DocKind::Keyword) {
        item = item.doc(e.markdown());
    }
    item
}

fn is_keyword_tok(k: TokKind) -> bool {
    use TokKind as T;
    matches!(
        k,
        T::Import
            | T::Const
            | T::Param
            | T::Mesh
            | T::Material
            | T::System
            | T::Module
            | T::Skeleton
            | T::Geometry
            | T::Wrapup
            | T::Axiom
            | T::Ignore
            | T::In
            | T::If
            | T::Then
            | T::Else
            | T::True
            | T::False
    )
}

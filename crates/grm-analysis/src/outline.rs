//! The outline of a file: document symbols (systems containing their
//! settings, declarations and productions), workspace symbols over the open
//! documents, and folding ranges (systems, materials, comment blocks).
//! Built from the syntax tree, so a file with errors still has an outline.

use crate::{Analysis, FileAnalysis, Location, Span};
use grm_sema::SymbolKind as SemaSymbolKind;
use grm_syntax::ast::{ContextItem, Field, Item, Phase, SystemItem};

/// What an outline entry is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SymbolKind {
    Import,
    Const,
    Param,
    Mesh,
    Material,
    System,
    Setting,
    Axiom,
    Ignore,
    /// A `module` / `skeleton` / `geometry` declaration.
    Declaration,
    Production,
    /// A module symbol (workspace symbols).
    Module,
}

/// An entry of the document outline.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SymbolNode {
    pub name: String,
    pub detail: Option<String>,
    pub kind: SymbolKind,
    /// The whole construct.
    pub span: Span,
    /// The name (what the editor highlights).
    pub selection: Span,
    pub children: Vec<SymbolNode>,
}

/// A symbol found by a workspace search.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct WorkspaceSymbol {
    pub name: String,
    pub kind: SymbolKind,
    /// The system a module symbol belongs to.
    pub container: Option<String>,
    pub location: Location,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FoldKind {
    Region,
    Comment,
    Imports,
}

/// A foldable byte range (the editor folds whole lines).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FoldingRange {
    pub span: Span,
    pub kind: FoldKind,
}

/// Whitespace runs collapsed to one space, shortened to `max` characters.
fn squash(s: &str, max: usize) -> String {
    let joined = s.split_whitespace().collect::<Vec<_>>().join(" ");
    if joined.chars().count() <= max {
        joined
    } else {
        let mut t: String = joined.chars().take(max.saturating_sub(1)).collect();
        t.push('…');
        t
    }
}

impl FileAnalysis {
    /// The outline: top-level items, systems with their contents.
    pub fn document_symbols(&self) -> Vec<SymbolNode> {
        let mut out = Vec::new();
        let leaf = |name: String, detail: Option<String>, kind, span, selection| SymbolNode {
            name,
            detail,
            kind,
            span,
            selection,
            children: Vec::new(),
        };
        for item in &self.parsed().file.items {
            match item {
                Item::Import(i) => out.push(leaf(
                    i.path.value.clone(),
                    Some("import".into()),
                    SymbolKind::Import,
                    i.span,
                    i.path.span,
                )),
                Item::Const(c) => out.push(leaf(
                    c.name.name.to_string(),
                    Some(squash(self.slice(c.value.span), 40)),
                    SymbolKind::Const,
                    c.span,
                    c.name.span,
                )),
                Item::Param(p) => out.push(leaf(
                    p.name.name.to_string(),
                    Some(squash(
                        self.slice(Span::new(p.default.span.start, p.span.end))
                            .trim_end_matches(';'),
                        40,
                    )),
                    SymbolKind::Param,
                    p.span,
                    p.name.span,
                )),
                Item::Mesh(m) => out.push(leaf(
                    m.name.name.to_string(),
                    Some(m.path.value.clone()),
                    SymbolKind::Mesh,
                    m.span,
                    m.name.span,
                )),
                Item::Material(m) => {
                    let mut node = leaf(
                        m.name.name.to_string(),
                        None,
                        SymbolKind::Material,
                        m.span,
                        m.name.span,
                    );
                    node.children = self.settings(&m.fields);
                    out.push(node);
                }
                Item::Layout(l) => {
                    let mut node = leaf(
                        l.name.name.to_string(),
                        Some("layout".into()),
                        SymbolKind::System,
                        l.span,
                        l.name.span,
                    );
                    node.children = self.settings(&l.fields);
                    out.push(node);
                }
                Item::System(s) => {
                    let mode = self
                        .checked
                        .program
                        .systems
                        .iter()
                        .find(|x| x.file == self.root && x.span == s.span)
                        .map(|x| x.mode.name());
                    let mut node = leaf(
                        s.name.name.to_string(),
                        mode.map(|m| format!("system ({m})")),
                        SymbolKind::System,
                        s.span,
                        s.name.span,
                    );
                    for it in &s.items {
                        if let Some(child) = self.system_item(it) {
                            node.children.push(child);
                        }
                    }
                    out.push(node);
                }
                Item::Error(_) => {}
            }
        }
        out
    }

    /// A material's or a layout's fields, each a setting with its value.
    fn settings(&self, fields: &[Field]) -> Vec<SymbolNode> {
        fields
            .iter()
            .map(|f| SymbolNode {
                name: f.name.name.to_string(),
                detail: Some(squash(self.slice(f.value.span), 40)),
                kind: SymbolKind::Setting,
                span: f.span,
                selection: f.name.span,
                children: Vec::new(),
            })
            .collect()
    }

    fn system_item(&self, it: &SystemItem) -> Option<SymbolNode> {
        let node = |name: String, detail: Option<String>, kind, span, selection| SymbolNode {
            name,
            detail,
            kind,
            span,
            selection,
            children: Vec::new(),
        };
        Some(match it {
            SystemItem::Axiom(a) => {
                let body = a
                    .modules
                    .first()
                    .map(|m| Span::new(m.span.start, a.modules[a.modules.len() - 1].span.end));
                node(
                    "axiom".into(),
                    body.map(|b| squash(self.slice(b), 40)),
                    SymbolKind::Axiom,
                    a.span,
                    Span::new(a.span.start, a.span.start + 5),
                )
            }
            SystemItem::Setting(s) => node(
                s.name.name.to_string(),
                Some(squash(self.slice(s.value.span), 40)),
                SymbolKind::Setting,
                s.span,
                s.name.span,
            ),
            SystemItem::Ignore(i) => node(
                "ignore".into(),
                Some(
                    i.symbols
                        .iter()
                        .map(|s| s.name.as_str())
                        .collect::<Vec<_>>()
                        .join(" "),
                ),
                SymbolKind::Ignore,
                i.span,
                Span::new(i.span.start, i.span.start + 6),
            ),
            SystemItem::ModuleDecl(d) => {
                let kw = match d.phase {
                    Phase::None => "module",
                    Phase::Skeleton => "skeleton",
                    Phase::Geometry => "geometry",
                };
                let names: Vec<&str> = d.modules.iter().map(|m| m.symbol.name.as_str()).collect();
                node(
                    names.join(", "),
                    Some(kw.into()),
                    SymbolKind::Declaration,
                    d.span,
                    d.modules.first().map(|m| m.span).unwrap_or(d.keyword),
                )
            }
            SystemItem::Production(p) => {
                let head_start = p
                    .left
                    .first()
                    .map(ContextItem::span)
                    .unwrap_or(p.pred.span)
                    .start;
                let head_start = if p.wrapup { p.span.start } else { head_start };
                let head = squash(self.slice(Span::new(head_start, p.arrow.start)), 60);
                let body = squash(self.slice(Span::new(p.arrow.end, p.span.end)), 50);
                node(
                    head,
                    Some(format!("-> {}", body.trim_end_matches(';').trim())),
                    SymbolKind::Production,
                    p.span,
                    p.pred.symbol.span,
                )
            }
            SystemItem::Error(_) => return None,
        })
    }

    /// Folding ranges: systems, materials, multi-line block comments, runs
    /// of line comments and of imports.
    pub fn folding_ranges(&self) -> Vec<FoldingRange> {
        let src = self.source();
        let line = |o: u32| src.line_col(o).0;
        let mut out = Vec::new();
        let mut imports: Option<Span> = None;
        for item in &self.parsed().file.items {
            match item {
                Item::System(s) => out.push(FoldingRange {
                    span: s.span,
                    kind: FoldKind::Region,
                }),
                Item::Material(m) => out.push(FoldingRange {
                    span: m.span,
                    kind: FoldKind::Region,
                }),
                Item::Layout(l) => out.push(FoldingRange {
                    span: l.span,
                    kind: FoldKind::Region,
                }),
                _ => {}
            }
            if let Item::Import(i) = item {
                imports = Some(imports.map_or(i.span, |s| s.to(i.span)));
            } else if let Some(s) = imports.take() {
                out.push(FoldingRange {
                    span: s,
                    kind: FoldKind::Imports,
                });
            }
        }
        if let Some(s) = imports {
            out.push(FoldingRange {
                span: s,
                kind: FoldKind::Imports,
            });
        }
        // Comments: a block comment, or consecutive line comments.
        let mut run: Option<Span> = None;
        for c in &self.parsed().comments {
            if c.text.starts_with("/*") {
                if let Some(r) = run.take() {
                    out.push(FoldingRange {
                        span: r,
                        kind: FoldKind::Comment,
                    });
                }
                out.push(FoldingRange {
                    span: c.span,
                    kind: FoldKind::Comment,
                });
                continue;
            }
            run = match run {
                Some(r) if line(c.span.start) == line(r.end) + 1 => Some(r.to(c.span)),
                Some(r) => {
                    out.push(FoldingRange {
                        span: r,
                        kind: FoldKind::Comment,
                    });
                    Some(c.span)
                }
                None => Some(c.span),
            };
        }
        if let Some(r) = run {
            out.push(FoldingRange {
                span: r,
                kind: FoldKind::Comment,
            });
        }
        out.retain(|f| line(f.span.start) < line(f.span.end));
        out.sort_by_key(|f| (f.span.start, f.span.end));
        out
    }

    /// Named definitions of this file (and its imports) for a workspace
    /// search.
    fn symbols_for_search(&self) -> Vec<WorkspaceSymbol> {
        let p = &self.checked.program;
        let mut out = Vec::new();
        let mut push = |name: &str, kind, container: Option<String>, loc: grm_sema::Loc| {
            out.push(WorkspaceSymbol {
                name: name.to_string(),
                kind,
                container,
                location: self.loc(loc.file, loc.span),
            });
        };
        for c in &p.consts {
            push(&c.name, SymbolKind::Const, None, c.loc);
        }
        for c in &p.params {
            push(&c.name, SymbolKind::Param, None, c.loc);
        }
        for c in &p.meshes {
            push(&c.name, SymbolKind::Mesh, None, c.loc);
        }
        for c in &p.materials {
            push(&c.name, SymbolKind::Material, None, c.loc);
        }
        for s in &p.systems {
            push(&s.name, SymbolKind::System, None, s.loc);
            for info in &s.symbols {
                if info.kind != SemaSymbolKind::User {
                    continue;
                }
                let at = info.decl.unwrap_or(info.first);
                // `decl` may span a whole signature: name only.
                let at = Span::new(at.start, at.start + info.name.len() as u32);
                push(
                    &info.name,
                    SymbolKind::Module,
                    Some(s.name.clone()),
                    grm_sema::Loc::new(s.file, at),
                );
            }
        }
        out
    }
}

/// Whether `query`'s characters appear in order in `name` (ignoring case).
fn fuzzy(query: &str, name: &str) -> bool {
    let mut it = name.chars().flat_map(char::to_lowercase);
    query
        .chars()
        .flat_map(char::to_lowercase)
        .all(|q| it.any(|c| c == q))
}

impl Analysis {
    /// Definitions matching `query` (case-insensitive subsequence) in the
    /// open documents, the known workspace files and the files they import,
    /// without duplicates.
    pub fn workspace_symbols(&mut self, query: &str) -> Vec<WorkspaceSymbol> {
        let mut out: Vec<WorkspaceSymbol> = Vec::new();
        // A file's analysis holds its imports' definitions too: each
        // definition once (a set, not a search of `out`: a chain of 1,000
        // files importing each other offers about half a million).
        let mut seen = std::collections::HashSet::new();
        for doc in self.known_files() {
            let Some(fa) = self.analyze(&doc) else {
                continue;
            };
            for s in fa.symbols_for_search() {
                if fuzzy(query, &s.name)
                    && seen.insert((s.location.path.clone(), s.location.span, s.name.clone()))
                {
                    out.push(s);
                }
            }
        }
        out.sort_by(|a, b| {
            (&a.name, &a.location.path, a.location.span).cmp(&(
                &b.name,
                &b.location.path,
                b.location.span,
            ))
        });
        out
    }
}

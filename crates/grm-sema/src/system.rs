//! Checking one system: settings, the symbol table, module parameter
//! inference, typed axiom and productions, grouping, and the analyses.

use std::collections::HashMap;
use std::hash::Hasher;

use grm_diag::{Code, Diagnostic, FileId, Span};
use grm_syntax::ast::{self, ContextItem, ExprKind, Phase, SystemItem};

use crate::builtins::{Builtin, Fill, Form, SettingKey, Terminal, form_counts, terminal_forms};
use crate::check::{Checker, GlobalKind, ValueInfo, has_error};
use crate::expr::{Scope, ScopeBinding};
use crate::index::Def;
use crate::infer::{Infer, It};
use crate::program::*;
use crate::suggest;

mod inference;
mod settings;
mod symbols;
mod typed;

/// How a module occurrence resolved.
#[derive(Clone, Copy, Debug)]
struct UseRes {
    sym: SymbolId,
    /// For terminals: the written form (`None` when no form has this many
    /// arguments; already reported).
    form: Option<Form>,
}

/// How a pattern resolved.
#[derive(Clone, Copy, Debug)]
struct PatRes {
    sym: SymbolId,
    /// Names it binds (as written, even on an arity error).
    binds: usize,
    /// The pattern fits the symbol (else its names are bound as errors).
    ok: bool,
}

struct ProdRes {
    left: Vec<Option<PatRes>>,
    pred: PatRes,
    right: Vec<Option<PatRes>>,
    succ: Vec<UseRes>,
}

/// Symbol table under construction.
#[derive(Default)]
struct SymTab {
    infos: Vec<SymbolInfo>,
    user: HashMap<String, SymbolId>,
    term: HashMap<Terminal, SymbolId>,
    /// User symbols: where the arity was fixed (declaration or first use).
    arity_at: Vec<Option<Span>>,
    /// User symbols: where a parameter list was declared.
    sig_at: Vec<Option<Span>>,
    /// User symbols: declared parameter types.
    declared: Vec<Vec<Option<Ty>>>,
    /// User symbols: first inference variable.
    var_base: Vec<u32>,
}

impl SymTab {
    fn user(&mut self, name: &str, span: Span) -> SymbolId {
        if let Some(&id) = self.user.get(name) {
            return id;
        }
        let id = SymbolId(self.infos.len() as u32);
        self.infos.push(SymbolInfo {
            name: name.to_string(),
            kind: SymbolKind::User,
            arity: 0,
            params: Vec::new(),
            param_names: Vec::new(),
            phase: Phase::None,
            decl: None,
            first: span,
            groups: Vec::new(),
            wrapup_groups: Vec::new(),
        });
        self.arity_at.push(None);
        self.sig_at.push(None);
        self.declared.push(Vec::new());
        self.var_base.push(0);
        self.user.insert(name.to_string(), id);
        id
    }

    fn terminal(&mut self, t: Terminal, span: Span) -> SymbolId {
        if let Some(&id) = self.term.get(&t) {
            return id;
        }
        let id = SymbolId(self.infos.len() as u32);
        self.infos.push(SymbolInfo {
            name: t.name().to_string(),
            kind: SymbolKind::Terminal(t),
            arity: t.params().len(),
            params: t.params().to_vec(),
            param_names: vec![None; t.params().len()],
            phase: Phase::None,
            decl: None,
            first: span,
            groups: Vec::new(),
            wrapup_groups: Vec::new(),
        });
        self.arity_at.push(Some(span));
        self.sig_at.push(None);
        self.declared.push(Vec::new());
        self.var_base.push(0);
        self.term.insert(t, id);
        id
    }
}

struct Sys<'c, 'a> {
    cx: &'c mut Checker<'a>,
    fi: usize,
    file: FileId,
    sid: SystemId,
    mode: Mode,
    /// The `mode` setting is broken (a bad value, or a misspelt name such as
    /// `mod = sample`; reported once): the mode is guessed from the
    /// system's contents, and nothing is reported for not fitting it.
    mode_unsure: bool,
    tab: SymTab,
    occurrences: Vec<(Span, SymbolId)>,
    /// Terminals named in a phase declaration (E0102 reported): rewriting
    /// them is the same mistake, not reported again.
    declared_terminals: Vec<Terminal>,
    /// Typed setting expressions by key.
    setting_exprs: Vec<SettingExpr>,
    /// User symbols: where each parameter's type was inferred from.
    origins: HashMap<usize, Vec<Option<Span>>>,
    /// User symbols: the arity diagnostic already reported (index in diags).
    arity_diag: HashMap<usize, usize>,
}

/// Group identity: predecessor, contexts, wrap-up flag and condition hash.
#[derive(Clone, PartialEq, Eq, Hash)]
struct GroupKey {
    wrapup: bool,
    pred: (SymbolId, u32),
    left: Vec<CtxKey>,
    right: Vec<CtxKey>,
    cond: u64,
}

#[derive(Clone, PartialEq, Eq, Hash)]
enum CtxKey {
    Pat(SymbolId, u32),
    Push,
    Pop,
}

/// Every list of a checked system at its length: lists grown by pushes
/// hold up to twice their length (four elements for one), most of a large
/// program's memory (issue 32).
fn shrink_system(system: &mut System) {
    system.setting_exprs.shrink_to_fit();
    system.axiom.shrink_to_fit();
    system.ignore.shrink_to_fit();
    system.symbols.shrink_to_fit();
    for s in &mut system.symbols {
        s.params.shrink_to_fit();
        s.param_names.shrink_to_fit();
        s.groups.shrink_to_fit();
        s.wrapup_groups.shrink_to_fit();
    }
    system.groups.shrink_to_fit();
    for g in &mut system.groups {
        g.left.shrink_to_fit();
        g.right.shrink_to_fit();
        g.alternatives.shrink_to_fit();
        for a in &mut g.alternatives {
            a.successor.shrink_to_fit();
            a.bindings.shrink_to_fit();
        }
    }
}

/// Check one system. Its productions are taken out of `s` and each is
/// dropped once typed: the system's tree and its checked groups are not
/// both whole in memory (issue 32).
pub(crate) fn check_system(
    cx: &mut Checker<'_>,
    fi: usize,
    s: &mut ast::System,
    sid: SystemId,
) -> System {
    let file = cx.file_id(fi);
    let mut sys = Sys {
        cx,
        fi,
        file,
        sid,
        mode: Mode::Derive,
        mode_unsure: false,
        tab: SymTab::default(),
        occurrences: Vec::new(),
        declared_terminals: Vec::new(),
        setting_exprs: Vec::new(),
        origins: HashMap::new(),
        arity_diag: HashMap::new(),
    };
    sys.run(s)
}

impl Sys<'_, '_> {
    fn err(&mut self, d: Diagnostic) {
        self.cx.error(d);
    }

    fn run(&mut self, s: &mut ast::System) -> System {
        let file = self.file;
        let mut holes = false;
        let mut settings_ast = Vec::new();
        let mut lots = Vec::new();
        let mut axioms = Vec::new();
        let mut ignores = Vec::new();
        let mut decls = Vec::new();
        let mut prods = Vec::new();
        for item in &s.items {
            match item {
                SystemItem::Setting(x) if x.name.name == "lot" => lots.push(x),
                SystemItem::Setting(x) => settings_ast.push(x),
                SystemItem::Axiom(x) => axioms.push(x),
                SystemItem::Ignore(x) => ignores.push(x),
                SystemItem::ModuleDecl(x) => decls.push(x),
                SystemItem::Production(x) => prods.push(x),
                SystemItem::Error(_) => holes = true,
            }
        }
        holes |= prods.iter().any(|p| prod_has_error(p));

        // A broken `mode` setting: sample if the system uses what only
        // sample systems have.
        if settings_ast.iter().any(|set| mode_setting_broken(set)) {
            self.mode_unsure = true;
            if decls.iter().any(|d| d.phase != Phase::None) || prods.iter().any(|p| p.wrapup) {
                self.mode = Mode::Sample;
            } else if !lots.is_empty()
                || prods
                    .iter()
                    .any(|p| p.successor.iter().any(|m| m.parts.is_some()))
            {
                self.mode = Mode::Shape;
            }
        }

        // Settings.
        let settings = self.settings(&settings_ast);
        if self.mode == Mode::Shape {
            let extra: Vec<Span> = decls
                .iter()
                .map(|d| d.span)
                .chain(ignores.iter().map(|i| i.span))
                .collect();
            for extra in axioms.iter().skip(1) {
                self.err(
                    Diagnostic::new(
                        Code::DuplicateSetting,
                        format!("system `{}` has more than one axiom", s.name.name),
                        file,
                        extra.span,
                        "second axiom",
                    )
                    .with_label(file, axioms[0].span, "first axiom")
                    .with_help("a system has one start shape; remove one of them"),
                );
            }
            let checker = crate::shape::check::ShapeCheck::new(self.cx, self.fi, self.sid);
            let (shape, symbols) = checker.run(
                &s.name,
                &lots,
                axioms.first().copied(),
                &prods,
                &extra,
                holes,
            );
            let names: Vec<&str> = symbols.iter().map(|x| x.name.as_str()).collect();
            crate::shape::analysis::analyse(
                &shape,
                symbols.len(),
                file,
                &names,
                &mut self.cx.diags,
            );
            return System {
                name: s.name.name.to_string(),
                loc: Loc::new(file, s.name.span),
                file,
                span: s.span,
                mode: Mode::Shape,
                settings,
                setting_exprs: std::mem::take(&mut self.setting_exprs),
                axiom: Vec::new(),
                ignore: Vec::new(),
                symbols,
                groups: Vec::new(),
                shape: Some(Box::new(shape)),
            };
        }
        for lot in &lots {
            self.err(
                Diagnostic::new(
                    Code::UnknownSetting,
                    "`lot` is a setting of shape systems",
                    file,
                    lot.name.span,
                    format!("not used by a {} system", self.mode.name()),
                )
                .with_help("add `mode = shape;` or remove this setting"),
            );
        }

        // Axiom.
        let axiom_ast: Option<&ast::Axiom> = axioms.first().copied();
        for extra in axioms.iter().skip(1) {
            let first = axioms[0].span;
            self.err(
                Diagnostic::new(
                    Code::DuplicateSetting,
                    format!("system `{}` has more than one axiom", s.name.name),
                    file,
                    extra.span,
                    "second axiom",
                )
                .with_label(file, first, "first axiom")
                .with_help("a system has one start string; remove one of them"),
            );
        }

        // Declarations, then uses in item order.
        self.declarations(&decls);
        let mut axiom_res: Vec<UseRes> = Vec::new();
        let mut prod_res: Vec<ProdRes> = Vec::with_capacity(prods.len());
        {
            let mut pi = 0;
            for item in &s.items {
                match item {
                    SystemItem::Axiom(a) if axiom_ast.is_some_and(|x| std::ptr::eq(x, a)) => {
                        axiom_res = a.modules.iter().map(|m| self.resolve_use(m)).collect();
                    }
                    SystemItem::Production(p) => {
                        let r = self.resolve_production(p);
                        prod_res.push(r);
                        pi += 1;
                    }
                    _ => {}
                }
            }
            debug_assert_eq!(pi, prods.len());
        }
        let ignore = self.ignore_list(&ignores);

        // Inference of user symbols' parameter types.
        self.infer(axiom_ast, &prods, &prod_res, &axiom_res);

        // Typed axiom.
        let mut axiom = Vec::new();
        if let Some(a) = axiom_ast {
            let mut sc = Scope {
                file_idx: self.fi,
                bindings: Vec::new(),
                allow_random: true,
                allow_params: true,
                what: "the axiom",
                shape: false,
            };
            for (m, r) in a.modules.iter().zip(&axiom_res) {
                let tm = self.module(m, r, &mut sc);
                axiom.push(tm);
            }
            let br: Vec<(Option<bool>, Span)> = axiom
                .iter()
                .map(|m| (self.bracket_of(m.symbol), m.span))
                .collect();
            self.brackets(br.into_iter(), "axiom");
        } else if !holes && s.span.end > s.name.span.end {
            // (A broken statement may be the axiom, and a system without
            // its `{` has no statements: the syntax error says it all.)
            self.err(
                Diagnostic::new(
                    Code::MissingAxiom,
                    if s.name.name.is_empty() {
                        "this system has no axiom".to_string()
                    } else {
                        format!("system `{}` has no axiom", s.name.name)
                    },
                    file,
                    s.name.span,
                    "no `axiom` in this system",
                )
                .with_help("add the start string, e.g. `axiom A;`"),
            );
        }

        let no_axiom = axiom_ast.is_none();
        drop((prods, settings_ast, axioms, ignores, decls));

        // Productions and groups: each production's tree is dropped once
        // it is typed.
        let mut groups: Vec<Group> = Vec::new();
        let mut by_key: HashMap<GroupKey, Vec<usize>> = HashMap::new();
        let productions = std::mem::take(&mut s.items)
            .into_iter()
            .filter_map(|item| match item {
                SystemItem::Production(p) => Some(p),
                _ => None,
            });
        for (p, r) in productions.zip(&prod_res) {
            let (key, group, alt) = self.production(&p, r);
            drop(p);
            let candidates = by_key.entry(key).or_default();
            let found = candidates.iter().copied().find(|&g| {
                match (&groups[g].condition, &group.condition) {
                    (None, None) => true,
                    (Some(a), Some(b)) => a.same_as(b),
                    _ => false,
                }
            });
            match found {
                Some(g) => groups[g].alternatives.push(alt),
                None => {
                    candidates.push(groups.len());
                    let mut group = group;
                    group.alternatives.push(alt);
                    groups.push(group);
                }
            }
        }

        // Finish the symbol table.
        let mut symbols = std::mem::take(&mut self.tab.infos);
        for (i, g) in groups.iter().enumerate() {
            let info = &mut symbols[g.pred.symbol.index()];
            if g.wrapup {
                info.wrapup_groups.push(GroupId(i as u32));
            } else {
                info.groups.push(GroupId(i as u32));
            }
        }
        for (span, id) in std::mem::take(&mut self.occurrences) {
            let info = &symbols[id.index()];
            let is_def = span == info.decl.unwrap_or(info.first);
            self.cx
                .program
                .index
                .push(file, span, Def::Symbol(self.sid, id), is_def);
        }

        let system = System {
            name: s.name.name.to_string(),
            loc: Loc::new(file, s.name.span),
            file,
            span: s.span,
            mode: self.mode,
            settings,
            setting_exprs: std::mem::take(&mut self.setting_exprs),
            axiom,
            ignore,
            symbols,
            groups,
            shape: None,
        };
        let mut system = system;
        shrink_system(&mut system);
        let diags = &mut self.cx.diags;
        crate::phases::check_groups(&system, diags, holes || no_axiom);
        if system.mode == Mode::Sample {
            crate::phases::check_sample(&system, diags, holes, &self.declared_terminals);
        }
        system
    }
}

fn phase_name(p: Phase) -> &'static str {
    match p {
        Phase::Skeleton => "skeleton",
        Phase::Geometry => "geometry",
        Phase::None => "module",
    }
}

fn plural(n: usize) -> &'static str {
    if n == 1 { "" } else { "s" }
}

fn forms_help(name: &str, forms: &[Form]) -> String {
    forms
        .iter()
        .map(|f| {
            if f.written.is_empty() {
                format!("`{name}`")
            } else {
                let a: Vec<&str> = f.written.iter().map(|t| t.name()).collect();
                format!("`{name}({})`", a.join(", "))
            }
        })
        .collect::<Vec<_>>()
        .join(" or ")
}

fn prod_has_error(p: &ast::Production) -> bool {
    p.condition.as_ref().is_some_and(has_error)
        || p.weight.as_ref().is_some_and(has_error)
        || p.successor.iter().any(|m| m.args.iter().any(has_error))
}

fn hash_cond(c: Option<&TExpr>) -> u64 {
    let mut h = std::collections::hash_map::DefaultHasher::new();
    if let Some(c) = c {
        c.structural_hash(&mut h);
    }
    h.finish()
}

/// Whether a setting is a broken `mode`: `mode` with a value other than
/// `derive` or `sample`, or an unknown name that `mode` is the nearest
/// setting to (`mod`, `Mode`) or whose value is `derive` or `sample`.
fn mode_setting_broken(set: &ast::Setting) -> bool {
    let name = set.name.name.as_str();
    let value_is_mode =
        matches!(&set.value.kind, ExprKind::Name(n) if n.name == "derive" || n.name == "sample");
    match SettingKey::from_name(name) {
        Some(SettingKey::Mode) => !value_is_mode,
        Some(_) => false,
        None => {
            value_is_mode
                || suggest::best(name, SettingKey::ALL.iter().map(|k| k.name())) == Some("mode")
        }
    }
}

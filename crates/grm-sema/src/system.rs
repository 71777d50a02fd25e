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

    // ---- settings ---------------------------------------------------------

    fn settings(&mut self, items: &[&ast::Setting]) -> Settings {
        let file = self.file;
        let mut seen: HashMap<SettingKey, Span> = HashMap::new();
        let mut typed: Vec<(SettingKey, TExpr, Span, Span)> = Vec::new();
        for set in items {
            let Some(key) = SettingKey::from_name(&set.name.name) else {
                let mut d = Diagnostic::new(
                    Code::UnknownSetting,
                    format!("unknown setting `{}`", set.name.name),
                    file,
                    set.name.span,
                    "not a setting",
                );
                let names = SettingKey::ALL.iter().map(|k| k.name());
                // ABoP's symbols and other tools' names for the settings.
                let alias = match set.name.name.as_str() {
                    "n" | "depth" | "generation" | "steps" | "iter" => Some("iterations"),
                    "δ" | "delta" | "turn" | "theta" => Some("angle"),
                    "length" | "len" | "distance" => Some("step"),
                    "thickness" | "diameter" | "radius" => Some("width"),
                    _ => None,
                };
                d = match alias
                    .map(|a| format!("did you mean `{a}`?"))
                    .or_else(|| suggest::did_you_mean(&set.name.name, names))
                {
                    Some(h) => d.with_help(h),
                    None => d.with_help(format!(
                        "the settings are {}",
                        SettingKey::ALL
                            .iter()
                            .map(|k| format!("`{}`", k.name()))
                            .collect::<Vec<_>>()
                            .join(", ")
                    )),
                };
                self.err(d);
                continue;
            };
            if let Some(&prev) = seen.get(&key) {
                self.err(
                    Diagnostic::new(
                        Code::DuplicateSetting,
                        format!("`{}` is set twice", key.name()),
                        file,
                        set.name.span,
                        "set again here",
                    )
                    .with_label(file, prev, "first set here")
                    .with_help("remove one of them"),
                );
                continue;
            }
            seen.insert(key, set.name.span);
            if key == SettingKey::Mode {
                match &set.value.kind {
                    ExprKind::Name(n) if n.name == "derive" => self.mode = Mode::Derive,
                    ExprKind::Name(n) if n.name == "sample" => self.mode = Mode::Sample,
                    ExprKind::Name(n) if n.name == "shape" => self.mode = Mode::Shape,
                    _ => {
                        let mut d = Diagnostic::new(
                            Code::InvalidSettingValue,
                            "`mode` must be `derive`, `sample` or `shape`",
                            file,
                            set.value.span,
                            "not a mode",
                        );
                        if let ExprKind::Name(n) = &set.value.kind
                            && let Some(h) =
                                suggest::did_you_mean(&n.name, ["derive", "sample", "shape"])
                        {
                            d = d.with_help(h);
                        }
                        self.err(d);
                    }
                }
                continue;
            }
            let mut sc = Scope::global(self.fi, true, "a setting");
            let v = self.cx.expr(&set.value, &mut sc);
            let v = self
                .cx
                .expect(file, v, key.ty(), &format!("setting `{}`", key.name()));
            typed.push((key, v, set.span, set.name.span));
        }
        let mut out = Settings::default();
        let params = self.cx.program.default_params();
        let globals = self.cx.default_globals.clone();
        let env = crate::eval::Env {
            params: &params,
            globals: &globals,
            bindings: &[],
        };
        for (key, v, span, name_span) in typed {
            if self.mode == Mode::Shape && key != SettingKey::Seed {
                self.cx.error(
                    Diagnostic::new(
                        Code::UnknownSetting,
                        format!("`{}` is not a setting of shape systems", key.name()),
                        file,
                        name_span,
                        "not used by a shape system",
                    )
                    .with_note("a shape system has a `lot` and a `seed`")
                    .with_help("remove this setting"),
                );
                continue;
            }
            if key.sample_only() && self.mode == Mode::Derive && !self.mode_unsure {
                self.cx.error(
                    Diagnostic::new(
                        Code::UnknownSetting,
                        format!("`{}` is a setting of sample systems", key.name()),
                        file,
                        name_span,
                        "not used by a derive system",
                    )
                    .with_help("add `mode = sample;` or remove this setting"),
                );
                continue;
            }
            if key == crate::builtins::SettingKey::Iterations
                && self.mode == Mode::Sample
                && !self.mode_unsure
            {
                self.cx.error(
                    Diagnostic::new(
                        Code::UnknownSetting,
                        "`iterations` is a setting of derive systems",
                        file,
                        name_span,
                        "not used by a sample system",
                    )
                    .with_note(
                        "a sample system is grown by the search, whose length is `generations`",
                    )
                    .with_help("remove this setting, or set `generations`"),
                );
                continue;
            }
            if v.ty != Ty::Error
                && let Ok(val) = crate::eval::eval_setting(&v, &env)
                && let Err(msg) = key.apply(&mut out, val)
            {
                let mut d = Diagnostic::new(
                    Code::InvalidSettingValue,
                    msg,
                    file,
                    v.span,
                    "invalid value",
                );
                if v.constant().is_none() {
                    d = d.with_note("evaluated with the meta-parameters' default values");
                }
                self.cx.error(d);
                continue;
            }
            self.setting_exprs.push(SettingExpr {
                key,
                value: v,
                span,
            });
        }
        out
    }

    /// The expression an omitted `F`/`+` argument takes.
    fn default_arg(&self, key: SettingKey, span: Span) -> TExpr {
        if let Some(se) = self.setting_exprs.iter().find(|s| s.key == key) {
            let mut e = se.value.clone();
            if e.constant().is_some() {
                e.span = span;
            }
            return e;
        }
        let d = Settings::default();
        let v = match key {
            SettingKey::Step => d.step,
            _ => d.angle,
        };
        TExpr::lit(Value::Float(f64::from(v)), span)
    }

    // ---- symbols ----------------------------------------------------------

    fn declarations(&mut self, decls: &[&ast::ModuleDecl]) {
        let file = self.file;
        for d in decls {
            if d.phase != Phase::None && self.mode == Mode::Derive && !self.mode_unsure {
                let kw = if d.phase == Phase::Skeleton {
                    "skeleton"
                } else {
                    "geometry"
                };
                self.err(
                    Diagnostic::new(
                        Code::PhaseInDerive,
                        format!("`{kw}` declarations have no effect in a derive system"),
                        file,
                        d.keyword,
                        "ignored in derive mode",
                    )
                    .with_help("use `module` to declare parameters, or set `mode = sample;`"),
                );
            }
            for sig in &d.modules {
                let name = &sig.symbol.name;
                if let Some(forms) = terminal_forms(name) {
                    self.declared_terminals
                        .extend(forms.iter().map(|f| f.terminal));
                    self.err(
                        Diagnostic::new(
                            Code::DuplicateDefinition,
                            format!("`{name}` is a built-in terminal and cannot be declared"),
                            file,
                            sig.symbol.span,
                            "built-in",
                        )
                        .with_help("give your symbol another name"),
                    );
                    continue;
                }
                let id = self.tab.user(name, sig.symbol.span);
                self.occurrences.push((sig.symbol.span, id));
                let info = &mut self.tab.infos[id.index()];
                if info.decl.is_none() {
                    info.decl = Some(sig.symbol.span);
                }
                if d.phase != Phase::None {
                    let prev = info.phase;
                    if prev == Phase::None {
                        info.phase = d.phase;
                        info.decl = Some(sig.symbol.span);
                    } else if prev != d.phase {
                        let first = info.decl.unwrap_or(info.first);
                        self.err(
                            Diagnostic::new(
                                Code::ConflictingPhase,
                                format!("`{name}` is declared both `skeleton` and `geometry`"),
                                file,
                                sig.symbol.span,
                                format!("declared `{}` here", phase_name(d.phase)),
                            )
                            .with_label(file, first, format!("declared `{}` here", phase_name(prev)))
                            .with_help("a symbol is either grown during the search (skeleton) or after it (geometry); keep one"),
                        );
                    }
                }
                if let Some(params) = &sig.params {
                    if let Some(prev) = self.tab.sig_at[id.index()] {
                        self.err(
                            Diagnostic::new(
                                Code::DuplicateDefinition,
                                format!("the parameters of `{name}` are declared twice"),
                                file,
                                sig.span,
                                "declared again here",
                            )
                            .with_label(file, prev, "first declared here")
                            .with_help("declare a symbol's parameters once"),
                        );
                        continue;
                    }
                    self.tab.sig_at[id.index()] = Some(sig.span);
                    self.tab.arity_at[id.index()] = Some(sig.span);
                    let mut names: Vec<Option<String>> = Vec::new();
                    let mut tys = Vec::new();
                    let mut seen: HashMap<&str, Span> = HashMap::new();
                    for p in params {
                        if p.name.name != "_" {
                            if let Some(&prev) = seen.get(p.name.name.as_str()) {
                                self.err(
                                    Diagnostic::new(
                                        Code::DuplicateParameter,
                                        format!("parameter `{}` is declared twice", p.name.name),
                                        file,
                                        p.name.span,
                                        "declared again",
                                    )
                                    .with_label(file, prev, "first declared here")
                                    .with_help("give each parameter its own name"),
                                );
                            }
                            seen.insert(&p.name.name, p.name.span);
                        }
                        let ty = p.ty.as_ref().map(|t| self.cx.resolve_type(self.fi, t));
                        names.push(Some(p.name.name.to_string()));
                        tys.push(ty);
                    }
                    let info = &mut self.tab.infos[id.index()];
                    info.arity = params.len();
                    info.param_names = names;
                    self.tab.declared[id.index()] = tys;
                }
            }
        }
    }

    /// Fix or check a user symbol's arity.
    fn fix_arity(&mut self, id: SymbolId, n: usize, span: Span, what: &str) -> bool {
        let i = id.index();
        match self.tab.arity_at[i] {
            None => {
                self.tab.arity_at[i] = Some(span);
                self.tab.infos[i].arity = n;
                true
            }
            Some(at) => {
                let arity = self.tab.infos[i].arity;
                if arity == n {
                    return true;
                }
                // One diagnostic per symbol: later mismatches become labels.
                if let Some(&di) = self.arity_diag.get(&i) {
                    if let Some(d) = self.cx.diags.get_mut(di)
                        && d.labels.len() < 8
                    {
                        d.labels.push(grm_diag::Label {
                            file: self.file,
                            span,
                            message: format!("also {n} here"),
                            primary: false,
                        });
                    }
                    return false;
                }
                self.arity_diag.insert(i, self.cx.diags.len());
                let name = self.tab.infos[i].name.clone();
                let how = if self.tab.sig_at[i].is_some() {
                    "declared"
                } else {
                    "first used"
                };
                self.err(
                    Diagnostic::new(
                        Code::ModuleArity,
                        format!(
                            "`{name}` has {arity} parameter{}, but this {what} has {n}",
                            plural(arity)
                        ),
                        self.file,
                        span,
                        format!("{n} here"),
                    )
                    .with_label(self.file, at, format!("{how} with {arity} here"))
                    .with_note("every module of a symbol carries the same number of parameters"),
                );
                false
            }
        }
    }

    fn resolve_use(&mut self, m: &ast::Module) -> UseRes {
        if let Some(parts) = &m.parts {
            self.err(
                Diagnostic::new(
                    Code::MisplacedParts,
                    format!("a parts block in a {} system", self.mode.name()),
                    self.file,
                    parts.span,
                    "parts block",
                )
                .with_note("parts divide a shape: only shape systems have them")
                .with_help("add `mode = shape;` to grow this system as a building"),
            );
        }
        let k = m.args.len();
        let name = &m.symbol.name;
        if let Some(forms) = terminal_forms(name) {
            if let Some(f) = forms.iter().find(|f| f.written.len() == k) {
                let sym = self.tab.terminal(f.terminal, m.symbol.span);
                self.occurrences.push((m.symbol.span, sym));
                return UseRes {
                    sym,
                    form: Some(*f),
                };
            }
            let sym = self
                .tab
                .terminal(forms[forms.len() - 1].terminal, m.symbol.span);
            self.occurrences.push((m.symbol.span, sym));
            self.err(
                Diagnostic::new(
                    Code::ModuleArity,
                    format!(
                        "`{name}` takes {} argument{}, but {k} {} given",
                        form_counts(forms),
                        if form_counts(forms) == "1" { "" } else { "s" },
                        if k == 1 { "was" } else { "were" }
                    ),
                    self.file,
                    m.span,
                    format!("{k} argument{}", plural(k)),
                )
                .with_help(format!(
                    "see the turtle and geometry terminals: {}",
                    forms_help(name, forms)
                )),
            );
            return UseRes { sym, form: None };
        }
        let sym = self.tab.user(name, m.symbol.span);
        self.occurrences.push((m.symbol.span, sym));
        self.fix_arity(sym, k, m.span, "module");
        UseRes { sym, form: None }
    }

    fn resolve_pattern(&mut self, p: &ast::Pattern) -> PatRes {
        let k = p.params.len();
        let name = &p.symbol.name;
        if let Some(forms) = terminal_forms(name) {
            let form = forms.iter().find(|f| f.written.len() == k);
            let t = form.map(|f| f.terminal).unwrap_or(forms[0].terminal);
            let sym = self.tab.terminal(t, p.symbol.span);
            self.occurrences.push((p.symbol.span, sym));
            let ok =
                form.is_some_and(|f| k == 0 || (f.fill == Fill::AsIs && k == t.params().len()));
            if !ok {
                let carried: Vec<&str> = t.params().iter().map(|t| t.name()).collect();
                self.err(
                    Diagnostic::new(
                        Code::ModuleArity,
                        format!("a `{name}` pattern binds {k} parameter{}", plural(k)),
                        self.file,
                        p.span,
                        "cannot match this",
                    )
                    .with_note(format!(
                        "`{}` modules carry ({})",
                        t.name(),
                        carried.join(", ")
                    ))
                    .with_help(format!(
                        "bind {} name{} (or none)",
                        carried.len(),
                        plural(carried.len())
                    )),
                );
            }
            return PatRes { sym, binds: k, ok };
        }
        let sym = self.tab.user(name, p.symbol.span);
        self.occurrences.push((p.symbol.span, sym));
        let ok = self.fix_arity(sym, k, p.span, "pattern");
        PatRes { sym, binds: k, ok }
    }

    fn resolve_production(&mut self, p: &ast::Production) -> ProdRes {
        let ctx = |this: &mut Self, items: &[ContextItem]| -> Vec<Option<PatRes>> {
            items
                .iter()
                .map(|c| match c {
                    ContextItem::Pattern(pat) => Some(this.resolve_pattern(pat)),
                    ContextItem::Push(_) | ContextItem::Pop(_) => None,
                })
                .collect()
        };
        let left = ctx(self, &p.left);
        let pred = self.resolve_pattern(&p.pred);
        let right = ctx(self, &p.right);
        let succ = p.successor.iter().map(|m| self.resolve_use(m)).collect();
        ProdRes {
            left,
            pred,
            right,
            succ,
        }
    }

    fn ignore_list(&mut self, ignores: &[&ast::Ignore]) -> Vec<SymbolId> {
        let mut out: Vec<SymbolId> = Vec::new();
        // What `out` holds (a list of thousands was quadratic to search).
        let mut listed = std::collections::HashSet::new();
        // The system's symbols in the order they were first seen, prepared
        // once (on the first unknown entry) for every suggestion.
        let mut known: Option<suggest::Candidates<'_>> = None;
        for ig in ignores {
            for s in &ig.symbols {
                if s.name == "[" || s.name == "]" {
                    self.cx.error(
                        Diagnostic::new(
                            Code::BracketIgnored,
                            format!("`{}` cannot be ignored", s.name),
                            self.file,
                            s.span,
                            "has no effect",
                        )
                        .with_note(
                            "brackets are never ignored: context matching steps over lateral branches by the bracket rules",
                        )
                        .with_help("remove it from the ignore list"),
                    );
                } else if let Some(forms) = terminal_forms(&s.name) {
                    for f in forms {
                        if let Some(&id) = self.tab.term.get(&f.terminal)
                            && listed.insert(id)
                        {
                            out.push(id);
                            self.occurrences.push((s.span, id));
                        }
                    }
                } else if let Some(&id) = self.tab.user.get(s.name.as_str()) {
                    if listed.insert(id) {
                        out.push(id);
                    }
                    self.occurrences.push((s.span, id));
                } else {
                    let mut d = Diagnostic::new(
                        Code::UnknownName,
                        format!(
                            "`{}` in the ignore list never occurs in this system",
                            s.name
                        ),
                        self.file,
                        s.span,
                        "unknown symbol",
                    );
                    let known = known.get_or_insert_with(|| {
                        let mut v: Vec<(SymbolId, &str)> = self
                            .tab
                            .user
                            .iter()
                            .map(|(n, &id)| (id, n.as_str()))
                            .collect();
                        v.sort_unstable();
                        suggest::Candidates::new(v.into_iter().map(|(_, n)| n).collect())
                    });
                    if let Some(h) = known.did_you_mean(&s.name) {
                        d = d.with_help(h);
                    } else {
                        d = d.with_help("remove it from the ignore list");
                    }
                    self.cx.error(d);
                }
            }
        }
        out
    }

    // ---- inference --------------------------------------------------------

    fn infer(
        &mut self,
        axiom: Option<&ast::Axiom>,
        prods: &[&ast::Production],
        res: &[ProdRes],
        axiom_res: &[UseRes],
    ) {
        let mut inf = Infer::default();
        for i in 0..self.tab.infos.len() {
            if self.tab.infos[i].kind != SymbolKind::User {
                continue;
            }
            let arity = self.tab.infos[i].arity;
            let base = inf.fresh();
            for _ in 1..arity {
                inf.fresh();
            }
            self.tab.var_base[i] = base;
            let declared = self.tab.declared[i].clone();
            let at = self.tab.sig_at[i].unwrap_or_default();
            for (j, ty) in declared.iter().enumerate() {
                if let Some(ty) = ty {
                    inf.set(base + j as u32, *ty, at);
                }
            }
        }
        let cx = &*self.cx;
        let fi = self.fi;
        let global = |name: &str| -> It {
            match cx.lookup(fi, name).map(|g| g.kind) {
                Some(GlobalKind::Value(j)) => match cx.values[j].info {
                    ValueInfo::Const { ty, .. } | ValueInfo::Param { ty, .. } => It::K(ty),
                    ValueInfo::Pending => It::Any,
                },
                Some(GlobalKind::Mesh(_)) => It::K(Ty::Mesh),
                Some(GlobalKind::Material(_)) => It::K(Ty::Material),
                None => It::Any,
            }
        };
        let tab = &self.tab;
        let param_it = |sym: SymbolId, i: usize| -> It {
            let info = &tab.infos[sym.index()];
            match info.kind {
                SymbolKind::User if i < info.arity => It::V(tab.var_base[sym.index()] + i as u32),
                SymbolKind::Terminal(t) => t.params().get(i).map(|t| It::K(*t)).unwrap_or(It::Any),
                SymbolKind::User => It::Any,
            }
        };
        let module = |inf: &mut Infer, m: &ast::Module, r: &UseRes, lookup: &dyn Fn(&str) -> It| {
            for (i, a) in m.args.iter().enumerate() {
                let t = inf.expr(a, lookup);
                let target = match (r.form, tab.infos[r.sym.index()].kind) {
                    (Some(f), _) => f.written.get(i).map(|t| It::K(*t)).unwrap_or(It::Any),
                    (None, SymbolKind::User) => param_it(r.sym, i),
                    (None, SymbolKind::Terminal(_)) => It::Any,
                };
                inf.unify(t, target, a.span);
            }
        };
        let mut ai = 0;
        let run_axiom = |inf: &mut Infer| {
            if let Some(a) = axiom {
                for (m, r) in a.modules.iter().zip(axiom_res) {
                    module(inf, m, r, &global);
                }
            }
        };
        // Axiom first when it comes first in the file; the order only
        // matters for which of two conflicting uses is reported.
        let axiom_start = axiom.map(|a| a.span.start).unwrap_or(u32::MAX);
        let mut axiom_done = false;
        for (p, r) in prods.iter().zip(res) {
            if !axiom_done && axiom_start < p.span.start {
                run_axiom(&mut inf);
                axiom_done = true;
            }
            let mut binds: Vec<(&str, It)> = Vec::new();
            let pats = r
                .left
                .iter()
                .zip(p.left.iter())
                .filter_map(|(r, c)| match (r, c) {
                    (Some(r), ContextItem::Pattern(pat)) => Some((r, pat)),
                    _ => None,
                })
                .chain(std::iter::once((&r.pred, &p.pred)))
                .chain(
                    r.right
                        .iter()
                        .zip(p.right.iter())
                        .filter_map(|(r, c)| match (r, c) {
                            (Some(r), ContextItem::Pattern(pat)) => Some((r, pat)),
                            _ => None,
                        }),
                );
            for (pr, pat) in pats {
                for (i, name) in pat.params.iter().enumerate().take(pr.binds) {
                    binds.push((&name.name, param_it(pr.sym, i)));
                }
            }
            let lookup = |n: &str| -> It {
                match binds.iter().find(|(b, _)| *b == n) {
                    Some((_, t)) => *t,
                    None => global(n),
                }
            };
            if let Some(c) = &p.condition {
                let t = inf.expr(c, &lookup);
                inf.unify(t, It::K(Ty::Bool), c.span);
            }
            if let Some(w) = &p.weight {
                let t = inf.expr(w, &lookup);
                inf.unify(t, It::K(Ty::Float), w.span);
            }
            for (m, ur) in p.successor.iter().zip(&r.succ) {
                module(&mut inf, m, ur, &lookup);
            }
            ai += 1;
        }
        if !axiom_done {
            run_axiom(&mut inf);
        }
        let _ = ai;
        inf.solve();
        inf.default_all();
        for i in 0..self.tab.infos.len() {
            if self.tab.infos[i].kind != SymbolKind::User {
                continue;
            }
            let arity = self.tab.infos[i].arity;
            let base = self.tab.var_base[i];
            let mut params = Vec::with_capacity(arity);
            let mut origins = Vec::with_capacity(arity);
            for j in 0..arity {
                let v = base + j as u32;
                params.push(inf.get(v).unwrap_or(Ty::Float));
                origins.push(inf.origin(v));
            }
            let info = &mut self.tab.infos[i];
            info.params = params;
            if info.param_names.len() != arity {
                info.param_names = vec![None; arity];
            }
            self.origins.insert(i, origins);
        }
    }
}

impl Sys<'_, '_> {
    // ---- typed modules and productions ------------------------------------

    fn bracket_of(&self, sym: SymbolId) -> Option<bool> {
        match self.tab.infos[sym.index()].kind {
            SymbolKind::Terminal(Terminal::Push) => Some(true),
            SymbolKind::Terminal(Terminal::Pop) => Some(false),
            _ => None,
        }
    }

    /// Report unbalanced brackets (E0311): one diagnostic for the `]`s
    /// that close no branch and one for the `[`s never closed, each on the
    /// first of them, the next few as secondary labels and a count of the
    /// rest (a successor of ten thousand `[` is one mistake, not ten
    /// thousand).
    fn brackets(&mut self, items: impl Iterator<Item = (Option<bool>, Span)>, what: &str) {
        /// Secondary labels shown after the primary one.
        const SHOWN: usize = 3;
        let mut open: Vec<Span> = Vec::new();
        let mut stray: Vec<Span> = Vec::new();
        for (b, span) in items {
            match b {
                Some(true) => open.push(span),
                Some(false) if open.pop().is_none() => stray.push(span),
                Some(false) | None => {}
            }
        }
        let file = self.file;
        let report =
            |spans: &[Span], one: &str, many: &str, label: &str, again: &str, help: &str| {
                let first = *spans.first()?;
                let n = spans.len();
                let message = if n == 1 {
                    format!("{one} in this {what}")
                } else {
                    format!("{n} {many} in this {what}")
                };
                let mut d = Diagnostic::new(Code::UnbalancedBrackets, message, file, first, label)
                    .with_help(help);
                for &s in spans.iter().skip(1).take(SHOWN) {
                    d = d.with_label(file, s, again);
                }
                if n > SHOWN + 1 {
                    d = d.with_note(format!("and {} more", n - SHOWN - 1));
                }
                Some(d)
            };
        let stray_d = report(
            &stray,
            "`]` closes no branch",
            "`]` close no branch",
            "no `[` before it",
            "nor this one",
            "remove it, or open the branch with `[` first",
        );
        let open_d = report(
            &open,
            "`[` is never closed",
            "`[` are never closed",
            "no matching `]`",
            "nor this one",
            "close the branch with `]`",
        );
        for d in [stray_d, open_d].into_iter().flatten() {
            self.err(d);
        }
    }

    /// Check an argument of a user module against the inferred parameter type.
    fn arg(&mut self, a: TExpr, sym: SymbolId, i: usize) -> TExpr {
        let info = &self.tab.infos[sym.index()];
        let want = info.params.get(i).copied().unwrap_or(Ty::Error);
        if a.ty == want || a.ty == Ty::Error || want == Ty::Error {
            return a;
        }
        let name = info.name.clone();
        let origin = self
            .origins
            .get(&sym.index())
            .and_then(|o| o.get(i).copied().flatten())
            .filter(|o| *o != a.span && *o != Span::default());
        let declared = self.tab.declared[sym.index()]
            .get(i)
            .copied()
            .flatten()
            .is_some();
        let mut d = Diagnostic::new(
            Code::TypeMismatch,
            format!("expected `{want}`, found `{}`", a.ty),
            self.file,
            a.span,
            format!("this is `{}`", a.ty),
        )
        .with_note(format!("parameter {} of `{name}` is `{want}`", i + 1));
        if let Some(o) = origin {
            let why = if declared {
                "declared here".to_string()
            } else {
                format!("`{want}` because of this")
            };
            d = d.with_label(self.file, o, why);
        }
        self.err(d);
        TExpr::error(a.span)
    }

    fn module(&mut self, m: &ast::Module, r: &UseRes, sc: &mut Scope) -> TModule {
        let file = self.file;
        let wanted = match (self.tab.infos[r.sym.index()].kind, r.form) {
            (SymbolKind::Terminal(_), Some(f)) => f
                .written
                .first()
                .copied()
                .filter(|t| matches!(t, Ty::Mesh | Ty::Material)),
            _ => None,
        };
        let targs: Vec<TExpr> = m
            .args
            .iter()
            .map(|a| {
                let since = self.cx.diags.len();
                let t = self.cx.expr(a, sc);
                // Only a bare name: in `if(x > 0, m1, m2)`, `x` is no mesh.
                if let (Some(want), ast::ExprKind::Name(n)) = (wanted, &a.kind) {
                    let help = if want == Ty::Mesh {
                        format!(
                            "declare the mesh above the system: `mesh {} = \"{}.obj\";`",
                            n.name, n.name
                        )
                    } else {
                        format!(
                            "declare the material above the system: `material {} {{ color = rgb(0.5, 0.5, 0.5); }}`",
                            n.name
                        )
                    };
                    self.cx.amend_unknown_name(since, a.span, help, true);
                }
                t
            })
            .collect();
        let info = &self.tab.infos[r.sym.index()];
        let arity = info.arity;
        let kind = info.kind;
        let args = match (kind, r.form) {
            (SymbolKind::Terminal(_), Some(f)) => {
                let mut checked = Vec::with_capacity(targs.len());
                for (i, (a, want)) in targs.into_iter().zip(f.written).enumerate() {
                    let what = format!("argument {} of `{}`", i + 1, m.symbol.name);
                    checked.push(self.cx.expect(file, a, *want, &what));
                }
                match f.fill {
                    Fill::AsIs => checked,
                    Fill::Step => vec![self.default_arg(SettingKey::Step, m.span)],
                    Fill::Angle => vec![self.default_arg(SettingKey::Angle, m.span)],
                    Fill::Pack3 => {
                        if checked.iter().any(|a| a.ty == Ty::Error) {
                            vec![TExpr::error(m.span)]
                        } else {
                            let span = checked[0].span.to(checked[checked.len() - 1].span);
                            vec![crate::expr::node(
                                TExprKind::Call(Builtin::Vec3, checked),
                                Ty::Vec3,
                                span,
                            )]
                        }
                    }
                }
            }
            (SymbolKind::Terminal(_), None) => (0..arity).map(|_| TExpr::error(m.span)).collect(),
            (SymbolKind::User, _) => {
                let mut out = Vec::with_capacity(arity);
                for (i, a) in targs.into_iter().enumerate().take(arity) {
                    out.push(self.arg(a, r.sym, i));
                }
                while out.len() < arity {
                    out.push(TExpr::error(m.span));
                }
                out
            }
        };
        if let (SymbolKind::Terminal(Terminal::Color), Some(f)) = (kind, r.form)
            && let Some(Value::Vec3(c)) = args.first().and_then(|a| a.constant())
        {
            let write = |xs: &[f64]| match f.fill {
                Fill::Pack3 => format!("color({})", crate::unit::join(xs)),
                _ => format!("color(rgb({}))", crate::unit::join(xs)),
            };
            let d = crate::unit::check(&crate::unit::UnitValue {
                file,
                span: m.span,
                subject: "this colour",
                xs: &c,
                write: &write,
                constant: true,
                kind: "colours",
            });
            if let Some(d) = d {
                self.err(d);
            }
        }
        TModule {
            symbol: r.sym,
            args,
            span: m.span,
        }
    }

    fn bind(
        &mut self,
        pr: &PatRes,
        pat: &ast::Pattern,
        bindings: &mut Vec<ScopeBinding>,
        slot: &mut u32,
    ) -> TPattern {
        let file = self.file;
        let first = *slot;
        for (i, name) in pat.params.iter().enumerate() {
            let ty = match pr.ok {
                true => self.tab.infos[pr.sym.index()]
                    .params
                    .get(i)
                    .copied()
                    .unwrap_or(Ty::Error),
                false => Ty::Error,
            };
            let mut duplicate = false;
            if name.name != "_"
                && let Some(prev) = bindings.iter_mut().find(|b| b.name == name.name)
            {
                {
                    // Uses of the name read the later binding: the first
                    // is not reported again as unused either (W0001).
                    prev.used = true;
                    let prev = prev.span;
                    self.err(
                        Diagnostic::new(
                            Code::DuplicateParameter,
                            format!("`{}` is bound twice in this production", name.name),
                            file,
                            name.span,
                            "bound again here",
                        )
                        .with_label(file, prev, "first bound here")
                        .with_help(
                            "give each parameter its own name (use `_` for values you ignore)",
                        ),
                    );
                    duplicate = true;
                }
            }
            self.cx.program.index.push(
                file,
                name.span,
                Def::Binding {
                    binding: Loc::new(file, name.span),
                },
                true,
            );
            bindings.push(ScopeBinding {
                name: name.name.clone(),
                span: name.span,
                slot: *slot,
                ty,
                // A duplicate is reported once, not again as unused.
                used: duplicate,
            });
            *slot += 1;
        }
        TPattern {
            symbol: pr.sym,
            first_slot: first,
            binds: pat.params.len() as u32,
            span: pat.span,
        }
    }

    fn context(
        &mut self,
        items: &[ContextItem],
        res: &[Option<PatRes>],
        bindings: &mut Vec<ScopeBinding>,
        slot: &mut u32,
    ) -> Vec<TContextItem> {
        let mut out = Vec::with_capacity(items.len());
        for (c, r) in items.iter().zip(res) {
            out.push(match (c, r) {
                (ContextItem::Pattern(p), Some(r)) => {
                    TContextItem::Pattern(self.bind(r, p, bindings, slot))
                }
                (ContextItem::Push(s), _) => TContextItem::Push(*s),
                (ContextItem::Pop(s), _)
                | (ContextItem::Pattern(ast::Pattern { span: s, .. }), None) => {
                    TContextItem::Pop(*s)
                }
            });
        }
        out
    }

    fn production(&mut self, p: &ast::Production, r: &ProdRes) -> (GroupKey, Group, Alternative) {
        let file = self.file;
        let mut bindings = Vec::new();
        let mut slot = 0u32;
        let left = self.context(&p.left, &r.left, &mut bindings, &mut slot);
        let pred = self.bind(&r.pred, &p.pred, &mut bindings, &mut slot);
        if r.pred.ok
            && let Some(open) = self.bracket_of(r.pred.sym)
        {
            // `[ -> ..` does not parse; its word spelling must not slip past.
            let (word, sign) = if open { ("push", "[") } else { ("pop", "]") };
            self.err(
                Diagnostic::new(
                    Code::UnbalancedBrackets,
                    format!("a production for `{word}` would unbalance every string it rewrites"),
                    file,
                    p.pred.span,
                    format!("`{word}` is the bracket `{sign}`"),
                )
                .with_help(
                    "brackets are not rewritten; rewrite a symbol inside the branch instead",
                ),
            );
        }
        let right = self.context(&p.right, &r.right, &mut bindings, &mut slot);
        let mut sc = Scope {
            file_idx: self.fi,
            bindings,
            allow_random: true,
            allow_params: true,
            what: "a production",
            shape: false,
        };
        let diags_before = self.cx.diags.len();

        let condition = p.condition.as_ref().map(|c| {
            let t = self.cx.expr(c, &mut sc);
            // ABoP's production labels, `p1: F -> F F`: read here as a
            // predecessor `p1` whose condition is the name `F`.
            let label = p
                .pred
                .symbol
                .name
                .strip_prefix('p')
                .is_some_and(|n| n.chars().all(|c| c.is_ascii_digit()));
            if label
                && p.pred.params.is_empty()
                && p.left.is_empty()
                && let ast::ExprKind::Name(n) = &c.kind
            {
                let help = format!(
                    "production labels like `{}:` are not written in grm: write `{} -> ...;`",
                    p.pred.symbol.name, n.name
                );
                self.cx
                    .amend_unknown_name(diags_before, c.span, help, false);
            }
            if t.ty != Ty::Bool && t.ty != Ty::Error {
                let mut d = Diagnostic::new(
                    Code::ConditionNotBool,
                    format!("a condition must be `bool`, but this is `{}`", t.ty),
                    file,
                    t.span,
                    format!("`{}`", t.ty),
                );
                if t.ty == Ty::Float {
                    d = d.with_help("compare it, e.g. `x > 0`");
                }
                self.err(d);
                return TExpr::error(t.span);
            }
            if let Some(Value::Bool(b)) = t.constant() {
                let help = if b {
                    "remove the condition: the production applies whenever its predecessor matches"
                } else {
                    "the production can never apply; remove it or fix the condition"
                };
                self.err(
                    Diagnostic::new(
                        Code::ConstantCondition,
                        format!("this condition is always {b}"),
                        file,
                        t.span,
                        format!("always {b}"),
                    )
                    .with_help(help),
                );
            }
            t
        });

        let weight = match &p.weight {
            Some(w) => {
                let t = self.cx.expr(w, &mut sc);
                let t = self.cx.expect(file, t, Ty::Float, "a weight");
                if let Some(Value::Float(x)) = t.constant()
                    && (x.is_nan() || x <= 0.0 || x.is_infinite())
                {
                    {
                        let (what, label) = if x.is_infinite() {
                            ("finite ", "past the largest float")
                        } else {
                            ("", "not positive")
                        };
                        self.err(
                            Diagnostic::new(
                                Code::NonPositiveWeight,
                                format!(
                                    "a weight must be a {what}positive number, but this is {}",
                                    x as f32
                                ),
                                file,
                                t.span,
                                label,
                            )
                            .with_help("use a weight > 0; to disable an alternative, remove it"),
                        );
                    }
                }
                t
            }
            None => TExpr::lit(Value::Float(1.0), p.arrow),
        };

        let successor: Vec<TModule> = p
            .successor
            .iter()
            .zip(&r.succ)
            .map(|(m, ur)| self.module(m, ur, &mut sc))
            .collect();
        let br: Vec<(Option<bool>, Span)> = successor
            .iter()
            .map(|m| (self.bracket_of(m.symbol), m.span))
            .collect();
        self.brackets(br.into_iter(), "successor");
        let ctx_br = p.right.iter().map(|c| match c {
            ContextItem::Push(s) => (Some(true), *s),
            ContextItem::Pop(s) => (Some(false), *s),
            ContextItem::Pattern(pat) => (None, pat.span),
        });
        self.brackets(ctx_br, "context");

        // A misspelt name is reported once, not also as an unused parameter.
        let misspelt = self.cx.diags[diags_before..]
            .iter()
            .any(|d| d.code == Code::UnknownName);
        if !prod_has_error(p) && !misspelt {
            for b in &sc.bindings {
                if !b.used && !b.name.starts_with('_') {
                    self.cx.error(
                        Diagnostic::new(
                            Code::UnusedParameter,
                            format!("parameter `{}` is never used", b.name),
                            file,
                            b.span,
                            "bound here, used nowhere",
                        )
                        .with_help(format!(
                            "prefix it with `_` (`_{}`) if it is meant to be ignored",
                            b.name
                        )),
                    );
                }
            }
        }

        if p.wrapup && self.mode == Mode::Derive && !self.mode_unsure {
            let kw = Span::new(
                p.span.start,
                p.span
                    .start
                    .saturating_add(6)
                    .min(p.pred.span.start.max(p.span.start)),
            );
            self.err(
                Diagnostic::new(
                    Code::WrapupInDerive,
                    "wrap-up productions only apply in sample systems",
                    file,
                    kw,
                    "this production never applies",
                )
                .with_help("remove it, or set `mode = sample;`"),
            );
        }

        let ctx_key = |items: &[TContextItem]| -> Vec<CtxKey> {
            items
                .iter()
                .map(|c| match c {
                    TContextItem::Pattern(tp) => CtxKey::Pat(tp.symbol, tp.binds),
                    TContextItem::Push(_) => CtxKey::Push,
                    TContextItem::Pop(_) => CtxKey::Pop,
                })
                .collect()
        };
        let key = GroupKey {
            wrapup: p.wrapup,
            pred: (pred.symbol, pred.binds),
            left: ctx_key(&left),
            right: ctx_key(&right),
            cond: hash_cond(condition.as_ref()),
        };
        let bindings = sc
            .bindings
            .iter()
            .map(|b| Binding {
                name: b.name.clone(),
                span: b.span,
                ty: b.ty,
            })
            .collect();
        let group = Group {
            wrapup: p.wrapup,
            left,
            pred,
            right,
            condition,
            slots: slot,
            alternatives: Vec::new(),
        };
        let alt = Alternative {
            weight,
            weight_written: p.weight.is_some(),
            successor,
            bindings,
            pred: p.pred.span,
            span: p.span,
            arrow: p.arrow,
        };
        (key, group, alt)
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

//! A system's symbol table: declarations, arities, module uses,
//! patterns, productions and `ignore` lists resolved (see the parent
//! module).

use super::*;

impl Sys<'_, '_> {
    // ---- symbols ----------------------------------------------------------

    pub(super) fn declarations(&mut self, decls: &[&ast::ModuleDecl]) {
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
    pub(super) fn fix_arity(&mut self, id: SymbolId, n: usize, span: Span, what: &str) -> bool {
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

    pub(super) fn resolve_use(&mut self, m: &ast::Module) -> UseRes {
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

    pub(super) fn resolve_pattern(&mut self, p: &ast::Pattern) -> PatRes {
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

    pub(super) fn resolve_production(&mut self, p: &ast::Production) -> ProdRes {
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

    pub(super) fn ignore_list(&mut self, ignores: &[&ast::Ignore]) -> Vec<SymbolId> {
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
}

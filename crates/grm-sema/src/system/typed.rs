//! A system's typed modules and productions: brackets, arguments,
//! bindings, contexts and groups (see the parent module).

use super::*;

impl Sys<'_, '_> {
    // ---- typed modules and productions ------------------------------------

    pub(super) fn bracket_of(&self, sym: SymbolId) -> Option<bool> {
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
    pub(super) fn brackets(
        &mut self,
        items: impl Iterator<Item = (Option<bool>, Span)>,
        what: &str,
    ) {
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
    pub(super) fn arg(&mut self, a: TExpr, sym: SymbolId, i: usize) -> TExpr {
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

    pub(super) fn module(&mut self, m: &ast::Module, r: &UseRes, sc: &mut Scope) -> TModule {
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

    pub(super) fn bind(
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

    pub(super) fn context(
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

    pub(super) fn production(
        &mut self,
        p: &ast::Production,
        r: &ProdRes,
    ) -> (GroupKey, Group, Alternative) {
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

//! A system's settings checked and typed, with their defaults (see the
//! parent module).

use super::*;

impl Sys<'_, '_> {
    // ---- settings ---------------------------------------------------------

    pub(super) fn settings(&mut self, items: &[&ast::Setting]) -> Settings {
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
    pub(super) fn default_arg(&self, key: SettingKey, span: Span) -> TExpr {
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
}

//! The global values of a program checked: constants and meta-parameters
//! in dependency order (cycles reported), their type annotations, and the
//! materials' fields (see the parent module).

use super::*;

impl<'a> Checker<'a> {
    pub(super) fn check_values(&mut self) {
        let n = self.values.len();
        // Dependency edges with the span of the reference.
        let mut edges: Vec<Vec<(usize, Span)>> = vec![Vec::new(); n];
        for (i, edge_list) in edges.iter_mut().enumerate() {
            let v = &self.values[i];
            let fi = v.file_idx;
            let mut names = Vec::new();
            match v.ast {
                ValueAst::Const(c) => collect_names(&c.value, &mut names),
                ValueAst::Param(p) => {
                    collect_names(&p.default, &mut names);
                    if let Some((lo, hi)) = &p.range {
                        collect_names(lo, &mut names);
                        collect_names(hi, &mut names);
                    }
                }
            }
            for id in names {
                if let Some(GlobalName {
                    kind: GlobalKind::Value(j),
                    ..
                }) = self.lookup(fi, &id.name)
                {
                    edge_list.push((j, id.span));
                }
            }
        }
        for e in edges.iter().flatten() {
            self.values[e.0].uses += 1;
        }
        // Iterative DFS: post-order is dependency order; a back edge is a cycle.
        #[derive(Clone, Copy, PartialEq)]
        enum Mark {
            White,
            Gray,
            Black,
        }
        let mut mark = vec![Mark::White; n];
        let mut order = Vec::with_capacity(n);
        let mut cyclic = vec![false; n];
        for start in 0..n {
            if mark[start] != Mark::White {
                continue;
            }
            let mut stack: Vec<(usize, usize)> = vec![(start, 0)];
            mark[start] = Mark::Gray;
            while let Some(&mut (v, ref mut next)) = stack.last_mut() {
                if let Some(&(w, span)) = edges[v].get(*next) {
                    *next += 1;
                    match mark[w] {
                        Mark::White => {
                            mark[w] = Mark::Gray;
                            stack.push((w, 0));
                        }
                        Mark::Gray => {
                            let from = stack.iter().position(|&(s, _)| s == w).unwrap_or(0);
                            let members: Vec<usize> =
                                stack[from..].iter().map(|&(s, _)| s).collect();
                            for &m in &members {
                                cyclic[m] = true;
                            }
                            let chain: Vec<String> = members
                                .iter()
                                .chain(std::iter::once(&w))
                                .map(|&m| format!("`{}`", self.values[m].name))
                                .collect();
                            let file = self.file_id(self.values[v].file_idx);
                            let wl = self.values[w].loc;
                            let d = Diagnostic::new(
                                Code::CyclicConstant,
                                format!("`{}` is defined in terms of itself", self.values[w].name),
                                file,
                                span,
                                "this reference closes the cycle",
                            )
                            .with_label(wl.file, wl.span, "defined here")
                            .with_note(format!("cycle: {}", chain.join(" -> ")))
                            .with_help(
                                "give one of these a value that does not depend on the others",
                            );
                            self.error(d);
                        }
                        Mark::Black => {}
                    }
                } else {
                    mark[v] = Mark::Black;
                    order.push(v);
                    stack.pop();
                }
            }
        }
        for v in order {
            self.check_value(v, cyclic[v]);
        }
        // Values with the parameters' defaults, for settings.
        let params = self.program.default_params();
        let mut globals = Vec::with_capacity(self.program.consts.len());
        for c in &self.program.consts {
            let env = crate::eval::Env {
                params: &params,
                globals: &globals,
                bindings: &[],
            };
            globals.push(crate::eval::eval(&c.value, &env).unwrap_or(Value::zero(c.ty)));
        }
        self.default_globals = globals;
    }

    pub(crate) fn resolve_type(&mut self, file_idx: usize, ann: &ast::TypeAnn) -> Ty {
        match ann.name.name.as_str() {
            "float" => Ty::Float,
            "vec3" => Ty::Vec3,
            "bool" => Ty::Bool,
            other => {
                let mut d = Diagnostic::new(
                    Code::UnknownType,
                    format!("unknown type `{other}`"),
                    self.file_id(file_idx),
                    ann.name.span,
                    "not a type",
                );
                d = match suggest::did_you_mean(other, ["float", "vec3", "bool"]) {
                    Some(h) => d.with_help(h),
                    None if matches!(
                        other,
                        "int" | "integer" | "number" | "double" | "f32" | "f64"
                    ) =>
                    {
                        d.with_help(
                            "numbers are `float` (whole-number settings are checked as floats)",
                        )
                    }
                    None => d.with_help("the types are `float`, `vec3` and `bool`"),
                };
                self.error(d);
                Ty::Error
            }
        }
    }

    pub(super) fn check_value(&mut self, v: usize, cyclic: bool) {
        let fi = self.values[v].file_idx;
        let file = self.file_id(fi);
        match self.values[v].ast {
            ValueAst::Const(c) => {
                let ann = c.ty.as_ref().map(|t| self.resolve_type(fi, t));
                let mut sc = Scope::global(fi, true, "a constant");
                let mut value = if cyclic {
                    TExpr::error(c.value.span)
                } else {
                    self.expr(&c.value, &mut sc)
                };
                if let Some(t) = ann {
                    value = self.expect(file, value, t, "the declared type");
                }
                let ty = match ann {
                    Some(t) => t,
                    None => value.ty,
                };
                let broken = cyclic || ty == Ty::Error || value.ty == Ty::Error;
                let id = ConstId(self.program.consts.len() as u32);
                self.program
                    .index
                    .push(file, c.name.span, Def::Const(id), true);
                self.values[v].info = ValueInfo::Const {
                    id,
                    ty,
                    folded: value.constant(),
                    broken,
                };
                self.program.consts.push(Const {
                    name: c.name.name.to_string(),
                    loc: Loc::new(file, c.name.span),
                    ty,
                    value,
                });
            }
            ValueAst::Param(p) => {
                let ValueInfo::Param { id, .. } = self.values[v].info else {
                    return;
                };
                let ann = p.ty.as_ref().map(|t| self.resolve_type(fi, t));
                let mut sc = Scope::global(fi, false, "a meta-parameter's default");
                let mut default = if cyclic {
                    TExpr::error(p.default.span)
                } else {
                    self.expr(&p.default, &mut sc)
                };
                if let Some(t) = ann {
                    default = self.expect(file, default, t, "the declared type");
                }
                let ty = ann.unwrap_or(default.ty);
                let dv = default.constant();
                let mut range = None;
                if let Some((lo, hi)) = &p.range {
                    let mut sc = Scope::global(fi, false, "a meta-parameter's range");
                    let tlo = self.expr(lo, &mut sc);
                    let thi = self.expr(hi, &mut sc);
                    if ty == Ty::Error || tlo.ty == Ty::Error || thi.ty == Ty::Error {
                        // already reported
                    } else if ty != Ty::Float {
                        self.error(
                            Diagnostic::new(
                                Code::InvalidParamRange,
                                format!(
                                    "a range needs a `float` parameter, but `{}` is `{ty}`",
                                    p.name.name
                                ),
                                file,
                                lo.span.to(hi.span),
                                "range on a non-float parameter",
                            )
                            .with_help("remove the `in lo .. hi` part"),
                        );
                    } else {
                        let tlo = self.expect(file, tlo, Ty::Float, "a range bound");
                        let thi = self.expect(file, thi, Ty::Float, "a range bound");
                        if let (Some(Value::Float(a)), Some(Value::Float(b))) =
                            (tlo.constant(), thi.constant())
                        {
                            if a.partial_cmp(&b) != Some(std::cmp::Ordering::Less) {
                                self.error(
                                    Diagnostic::new(
                                        Code::InvalidParamRange,
                                        format!("the range of `{}` is empty", p.name.name),
                                        file,
                                        lo.span.to(hi.span),
                                        format!("{a} .. {b} has no room"),
                                    )
                                    .with_help(
                                        "write the smaller bound first: `in lo .. hi` with lo < hi",
                                    ),
                                );
                            } else if let Some(Value::Float(d)) = dv {
                                if !(a <= d && d <= b) {
                                    self.error(
                                        Diagnostic::new(
                                            Code::InvalidParamRange,
                                            format!(
                                                "the default of `{}` is outside its range",
                                                p.name.name
                                            ),
                                            file,
                                            p.default.span,
                                            format!("{d} is not in {a} .. {b}"),
                                        )
                                        .with_label(file, lo.span.to(hi.span), "the range")
                                        .with_help(
                                            "move the default into the range or widen the range",
                                        ),
                                    );
                                } else {
                                    range = Some((a, b));
                                }
                            } else {
                                range = Some((a, b));
                            }
                        }
                    }
                }
                let pm = &mut self.program.params[id.index()];
                pm.ty = ty;
                pm.default = dv.unwrap_or(Value::zero(ty));
                pm.range = range;
                self.values[v].info = ValueInfo::Param { id, ty };
            }
        }
    }

    pub(super) fn check_material(
        &mut self,
        fi: usize,
        m: &'a ast::MaterialDecl,
    ) -> Vec<MaterialField> {
        let file = self.file_id(fi);
        let mut out: Vec<MaterialField> = Vec::new();
        let mut seen: HashMap<MaterialProp, Span> = HashMap::new();
        for f in &m.fields {
            let mut sc = Scope::global(fi, true, "a material property");
            let value = self.expr(&f.value, &mut sc);
            let Some(prop) = MaterialProp::from_name(&f.name.name) else {
                let mut d = Diagnostic::new(
                    Code::UnknownMaterialProperty,
                    format!("materials have no property `{}`", f.name.name),
                    file,
                    f.name.span,
                    "unknown property",
                );
                let names = MaterialProp::ALL.iter().map(|p| p.name());
                d = match suggest::did_you_mean(&f.name.name, names) {
                    Some(h) => d.with_help(h),
                    None => d.with_help(format!(
                        "the properties are {}",
                        MaterialProp::ALL
                            .iter()
                            .map(|p| format!("`{}`", p.name()))
                            .collect::<Vec<_>>()
                            .join(", ")
                    )),
                };
                self.error(d);
                continue;
            };
            if let Some(prev) = seen.get(&prop) {
                let prev = *prev;
                self.error(
                    Diagnostic::new(
                        Code::DuplicateSetting,
                        format!(
                            "`{}` is set twice in material `{}`",
                            prop.name(),
                            m.name.name
                        ),
                        file,
                        f.name.span,
                        "set again here",
                    )
                    .with_label(file, prev, "first set here")
                    .with_help("remove one of them"),
                );
                continue;
            }
            seen.insert(prop, f.name.span);
            let value = self.expect(
                file,
                value,
                prop.ty(),
                &format!("material property `{}`", prop.name()),
            );
            self.check_material_value(file, &m.name.name, prop, &value);
            out.push(MaterialField {
                prop,
                value,
                span: f.span,
            });
        }
        out
    }

    /// A material value must be finite (E0212) and should lie in 0..1
    /// (W0010: the model clamps it, as glTF and MTL allow nothing else).
    /// A value that depends on meta-parameters is checked with their
    /// defaults; one that draws random numbers is not checked here (the
    /// geometry builder falls back to the default property for a
    /// non-finite value at run time).
    pub(super) fn check_material_value(
        &mut self,
        file: FileId,
        material: &str,
        prop: MaterialProp,
        value: &TExpr,
    ) {
        if value.ty == Ty::Error {
            return;
        }
        let params = self.program.default_params();
        let env = crate::eval::Env {
            params: &params,
            globals: &self.default_globals,
            bindings: &[],
        };
        let Ok(v) = crate::eval::eval(value, &env) else {
            return;
        };
        let xs: Vec<f64> = match v {
            Value::Float(x) => vec![x],
            Value::Vec3(c) => c.to_vec(),
            _ => return,
        };
        let subject = format!("`{}` of material `{material}`", prop.name());
        let d = crate::unit::check(&crate::unit::UnitValue {
            file,
            span: value.span,
            subject: &subject,
            xs: &xs,
            write: &crate::unit::write_value,
            constant: value.constant().is_some(),
            kind: "material values",
        });
        if let Some(d) = d {
            self.error(d);
        }
    }
}

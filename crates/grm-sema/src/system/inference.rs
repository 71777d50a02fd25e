//! Module parameter inference over a system's axiom and productions
//! (see the parent module).

use super::*;

impl Sys<'_, '_> {
    // ---- inference --------------------------------------------------------

    pub(super) fn infer(
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

//! The expected growth directions of a guided sampler (Calder's eq. 9):
//! per symbol, the mean direction its subtree grows in, from loose
//! derivations (see the parent module).

use super::*;

impl<'a> Sampler<'a> {
    // ---- expected directions (eq. 9) ------------------------------------

    /// Expand random open skeleton symbols of `open` (a plain vector) until
    /// none is left or `max` were expanded; the bones made are appended to
    /// `bones`, and `on_open` sees each skeleton symbol opened (symbol,
    /// parameters).
    /// `lifo`: expand the newest open symbol first (depth first, for the
    /// reach factors) instead of a random one. Returns the longest path
    /// of bones from the root to a bone's tip.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn grow_loose(
        &self,
        w: &mut Worker,
        open: &mut Vec<Loose>,
        max: u32,
        lifo: bool,
        draws: impl Fn(u32) -> DrawCtx,
        bones: &mut Vec<(Vec3, Vec3)>,
        mut on_open: impl FnMut(u32, &[f32]),
    ) -> Result<f32, SampleError> {
        let sys = self.g.sys;
        let mut k = 0;
        let mut longest = 0.0f32;
        while !open.is_empty() && k < max {
            let ctx = draws(k);
            k += 1;
            let idx = if lifo {
                open.len() - 1
            } else {
                pick(&ctx, sys.draws, open.len())
            };
            let item = open.swap_remove(idx);
            let phase = "expected direction";
            let Some(alt) =
                self.g
                    .choose(w, item.symbol, &item.params, Which::Normal, &ctx, phase)?
            else {
                continue;
            };
            self.g.eval_successor(w, item.symbol, alt, &ctx, phase)?;
            self.g.interpret(w, alt, &item.turtle)?;
            bones.extend_from_slice(&w.bones);
            let path = item.path
                + w.bones
                    .iter()
                    .map(|&(b, t)| b.distance(t))
                    .filter(|l| l.is_finite())
                    .sum::<f32>();
            longest = longest.max(path);
            let a = &sys.alts[alt as usize];
            for &(m, t) in &w.users {
                let sym = sys.succ[(a.succ_offset + m) as usize].symbol;
                if self.g.is_skeleton(sym) {
                    let params = self.g.module_params(alt, m, &w.params).to_vec();
                    on_open(sym, &params);
                    open.push(Loose {
                        symbol: sym,
                        params,
                        turtle: t,
                        path,
                    });
                }
            }
        }
        Ok(longest)
    }

    /// Eq. 9 for every skeleton symbol: the mean, over `opts.models`
    /// sub-derivations grown from the symbol alone in the identity frame,
    /// of each one's mean bone vector. A symbol with parameters is grown
    /// with parameter values it actually takes: those of its occurrences in
    /// forward samples from the axiom (a symbol never met there gets no
    /// heuristic).
    pub(super) fn expected_directions(
        &self,
        opts: &ExpectedOptions,
    ) -> Result<PerSymbol, SampleError> {
        let n = self.g.phase.len();
        let mut w = self.g.worker();
        let mut params: Vec<Vec<Vec<f32>>> = vec![Vec::new(); n];
        let per = opts.models.max(1) as usize;
        let mut parametric = false;
        for (s, list) in params.iter_mut().enumerate() {
            if self.g.is_skeleton(s as u32) {
                if self.g.words[s] == 0 {
                    list.push(Vec::new());
                } else {
                    parametric = true;
                }
            }
        }
        let mut bones = Vec::new();
        if parametric {
            // Parameter values from forward samples of the whole grammar.
            for run in 0..16u32 {
                let root = self.axiom_loose(&mut w, opts.seed, run)?;
                let mut open = root;
                for o in &open {
                    if params[o.symbol as usize].len() < per {
                        params[o.symbol as usize].push(o.params.clone());
                    }
                }
                self.grow_loose(
                    &mut w,
                    &mut open,
                    opts.expansions.max(1) * 4,
                    false,
                    |k| tagged(opts.seed, STREAM_EXPECTED, u32::MAX - run, k),
                    &mut bones,
                    |sym, p| {
                        let list = &mut params[sym as usize];
                        if list.len() < per {
                            list.push(p.to_vec());
                        }
                    },
                )?;
                bones.clear();
            }
        }
        let mut out = vec![Vec3::ZERO; n];
        let mut reach = vec![0.0f32; n];
        let mut stride = vec![0.0f32; n];
        let mut fixed = vec![false; n];
        let identity = self.g.initial_turtle();
        for s in 0..n {
            if !self.g.is_skeleton(s as u32) || params[s].is_empty() {
                continue;
            }
            let mut acc = ExpectedDirection::new();
            for m in 0..per {
                let mut open = vec![Loose {
                    symbol: s as u32,
                    params: params[s][m % params[s].len()].clone(),
                    turtle: identity,
                    path: 0.0,
                }];
                bones.clear();
                self.grow_loose(
                    &mut w,
                    &mut open,
                    opts.expansions.max(1),
                    false,
                    |k| {
                        let seed = rng::hash(opts.seed, s as u32, m as u32, k);
                        tagged(seed, STREAM_EXPECTED, 0, 0)
                    },
                    &mut bones,
                    |_, _| {},
                )?;
                acc.add_model(&bones);
            }
            let e = acc.finish();
            out[s] = if e.is_finite() { e } else { Vec3::ZERO };
            // The reach factor: the longest chain of bones of sub-derivations
            // grown depth first from the symbol alone (draws of their own).
            let mut longest = Vec::with_capacity(per);
            let mut first = Vec::with_capacity(per);
            for m in 0..per {
                let mut open = vec![Loose {
                    symbol: s as u32,
                    params: params[s][m % params[s].len()].clone(),
                    turtle: identity,
                    path: 0.0,
                }];
                bones.clear();
                let l = self.grow_loose(
                    &mut w,
                    &mut open,
                    REACH_EXPANSIONS,
                    true,
                    |k| {
                        let seed = rng::hash(opts.seed, s as u32, m as u32, k);
                        tagged(seed, STREAM_REACH, 0, 0)
                    },
                    &mut bones,
                    |_, _| {},
                )?;
                longest.push(l);
                if let Some(&(b, t)) = bones.first() {
                    let len = b.distance(t);
                    if len.is_finite() {
                        first.push(len);
                    }
                }
            }
            longest.sort_by(f32::total_cmp);
            reach[s] = longest[(longest.len() * 3) / 4].max(0.0);
            first.sort_by(f32::total_cmp);
            stride[s] = first.get(first.len() / 2).copied().unwrap_or(0.0);
            fixed[s] = match (first.first(), first.last()) {
                (Some(&lo), Some(&hi)) => hi > 0.0 && hi - lo <= 1e-6 * hi,
                _ => false,
            };
        }
        Ok((out, reach, stride, fixed))
    }

    /// The axiom's skeleton symbols as loose open items (for the parameter
    /// samples of the expected directions).
    pub(super) fn axiom_loose(
        &self,
        w: &mut Worker,
        seed: u32,
        run: u32,
    ) -> Result<Vec<Loose>, SampleError> {
        let sys = self.g.sys;
        let ctx = tagged(seed, STREAM_AXIOM, run, 0);
        let alt = sys.axiom_alt;
        self.g.eval_successor(w, u32::MAX, alt, &ctx, "axiom")?;
        self.g.interpret(w, alt, &self.g.initial_turtle())?;
        let a = &sys.alts[alt as usize];
        let mut out = Vec::new();
        for &(m, t) in &w.users {
            let sym = sys.succ[(a.succ_offset + m) as usize].symbol;
            if self.g.is_skeleton(sym) {
                out.push(Loose {
                    symbol: sym,
                    params: self.g.module_params(alt, m, &w.params).to_vec(),
                    turtle: t,
                    path: 0.0,
                });
            }
        }
        Ok(out)
    }
}

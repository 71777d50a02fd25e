//! How promising an open symbol is, the lookahead over its spawns, and
//! the candidates drawn for an expansion (see the parent module).

use super::*;

impl<'a> Sampler<'a> {
    /// How promising it is to expand open symbol `sp` of `q` next (lower
    /// is better; [`Guide::order`]): the cost a bone grown from there in
    /// the symbol's expected direction would get (eq. 3 at its position,
    /// eq. 6 for its expected direction as in eq. 10) plus the utilization
    /// the nearest curve's next segment would still give
    /// (`CostModel::utilization_ahead`), and, with [`Guide::cover`], the
    /// coverage term's gain for a first cover of that segment
    /// (`2 W (1 - s)`, `s` the curve's covered share). A
    /// symbol that never grows a bone, or at a non-finite position, is
    /// least promising (`+inf`).
    pub(super) fn promise(
        &self,
        q: &Particle,
        sp: &Spawn,
        guide: &Guide,
        reach: &Look<'_>,
        memo: &mut TubesMemo,
    ) -> f64 {
        let e = self
            .expected
            .get(sp.symbol as usize)
            .copied()
            .unwrap_or(Vec3::ZERO);
        let Some(n) = sp.near else {
            return f64::INFINITY;
        };
        if e == Vec3::ZERO {
            return f64::INFINITY;
        }
        let (_, params) = &self.guides[n.curve];
        let mut v = grm_guide::distance_cost(n.closest.dist, params)
            + self.heuristic_near(&sp.turtle.frame, e, Some(n))
            + self.cost.utilization_ahead(&q.cost, n.curve, n.closest.t);
        if guide.cover > 0.0 && reach.order > 0.0 {
            let tubes = memo.tubes_near(&self.cost, &n);
            if !tubes.is_empty() {
                let (r, _) = self.reach_of(sp.symbol, &sp.turtle, reach);
                let ahead = self.cost.uncovered_within_reach(&q.cost, &tubes, r, None);
                v -= 2.0 * guide.cover * reach.order * ahead;
            }
        } else if guide.cover > 0.0 && !self.cost.covered_ahead(&q.cost, n.curve, n.closest.t) {
            let (k, m) = self.cost.covered_segments(&q.cost, n.curve);
            v -= 2.0 * guide.cover * (1.0 - k as f64 / m.max(1) as f64);
        }
        if v.is_nan() { f64::INFINITY } else { v }
    }

    /// Whether `symbol` is paced ([`Reach::paced`]): the first bones it
    /// grows all have one length, so its candidates can only turn them.
    pub(super) fn paced(&self, symbol: u32, reach: &Look<'_>) -> bool {
        reach.paced > 0 && self.fixed.get(symbol as usize).copied().unwrap_or(false)
    }

    /// How far a subtree of `symbol` grown from turtle state `t` could
    /// reach along a curve: its reach factor times the frame's scale
    /// (`|det|^(1/3)`) times [`Reach::scale`].
    pub(super) fn reach_of(&self, symbol: u32, t: &Turtle, reach: &Look<'_>) -> (f64, bool) {
        let f = self.reach.get(symbol as usize).copied().unwrap_or(0.0);
        let stride = self.stride.get(symbol as usize).copied().unwrap_or(0.0);
        let s = frame_scale(t);
        let grammar = f64::from(f) * s * reach.scale;
        // No further than the bones the generations left can grow.
        let budget = if reach.budget {
            f64::from(stride) * s * (reach.left + 1.0)
        } else {
            f64::INFINITY
        };
        let r = grammar.min(budget);
        if r.is_finite() {
            (r, grammar <= budget)
        } else {
            (0.0, false)
        }
    }

    /// The reach look-ahead of open symbols `spawns` (emitted by one
    /// expansion) against `state`: [`CostModel::uncovered_within_reach`] at
    /// each position where they sit (the largest reach of those there),
    /// summed.
    pub(super) fn spawns_lookahead(
        &self,
        state: &grm_guide::CostState,
        spawns: &[Spawn],
        reach: &Look<'_>,
        memo: &mut TubesMemo,
    ) -> f64 {
        let mut sum = 0.0;
        let mut i = 0;
        while i < spawns.len() {
            let sp = &spawns[i];
            let (mut r, mut shrinks) = self.reach_of(sp.symbol, &sp.turtle, reach);
            let mut j = i + 1;
            while j < spawns.len()
                && spawns[j].turtle.frame.translation == sp.turtle.frame.translation
            {
                let (rj, sj) = self.reach_of(spawns[j].symbol, &spawns[j].turtle, reach);
                if rj > r {
                    (r, shrinks) = (rj, sj);
                }
                j += 1;
            }
            if let Some(n) = sp.near
                && r > 0.0
            {
                let tubes = memo.tubes_near(&self.cost, &n);
                sum += self
                    .cost
                    .uncovered_within_reach(state, &tubes, r, reach.branches(shrinks));
            }
            i = j;
        }
        sum
    }

    /// The reach look-ahead of the successor in `w` (just interpreted):
    /// [`CostModel::uncovered_within_reach`] at each position where it
    /// opens skeleton symbols (the largest reach of those there), summed.
    pub(super) fn lookahead(
        &self,
        w: &Worker,
        alt: u32,
        state: &grm_guide::CostState,
        plans: &[BonePlan],
        reach: &Look<'_>,
    ) -> f64 {
        let sys = self.g.sys;
        let a = &sys.alts[alt as usize];
        let mut at: Option<(Vec3, (f64, bool))> = None;
        let mut sum = 0.0;
        let flush = |at: Option<(Vec3, (f64, bool))>, sum: &mut f64| {
            if let Some((pos, (r, shrinks))) = at {
                let p = pos.as_dvec3();
                let known = plans
                    .iter()
                    .find(|pl| pl.ends().1 == p)
                    .and_then(BonePlan::tip_closest);
                if r > 0.0 {
                    let tubes = self.cost.tubes_at(p, known);
                    *sum +=
                        self.cost
                            .uncovered_within_reach(state, &tubes, r, reach.branches(shrinks));
                }
            }
        };
        for &(m, t) in &w.users {
            let sym = sys.succ[(a.succ_offset + m) as usize].symbol;
            if !self.g.is_skeleton(sym) {
                continue;
            }
            let pos = Vec3::from(t.frame.translation);
            let r = self.reach_of(sym, &t, reach);
            match at {
                Some((p, r0)) if p == pos => at = Some((p, if r.0 > r0.0 { r } else { r0 })),
                _ => {
                    flush(at, &mut sum);
                    at = Some((pos, r));
                }
            }
        }
        flush(at, &mut sum);
        sum
    }

    /// The candidates of one expansion: open symbol `idx` of `q` expanded
    /// `kc` times from its own frame, candidate `c` with the draws of
    /// `draws` at position `c` (candidate 0 draws exactly what a plain
    /// expansion draws), each candidate's bones planned and priced against
    /// `q`'s cost state without changing it ([`CostModel::peek`]).
    /// Candidate `c` gets the selection weight `v_c = exp(-cost_c / T)`;
    /// one is chosen with probability `v_c / sum v` (a seeded uniform), and
    /// the returned correction `log(mean v) - log(v_chosen)` makes the
    /// particle's weight the sampling-importance-resampling weight of the
    /// step (section 4.1 of docs/sampling.md). Results are left in `w`'s
    /// `cand_*` buffers; returns (chosen candidate, correction).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn draw_candidates(
        &self,
        w: &mut Worker,
        layers: &[Vec<Step>],
        local: &Step,
        cur: (u32, u32),
        q: &Particle,
        idx: usize,
        draws: DrawCtx,
        kc: u32,
        temperature: f64,
        cover: f64,
        reach: &Look<'_>,
    ) -> Result<(usize, f64), SampleError> {
        let r = *q.open.get(idx).ok_or_else(missing_node)?;
        let (sp, _) = self.open_spawn(w, Arena { layers, local, cur }, r)?;
        let n = kc as usize;
        w.cand_alt.clear();
        w.cand_logv.clear();
        let m = n.max(w.cand_params.len());
        w.cand_params.resize_with(m, Vec::new);
        w.cand_plans.resize_with(m, Vec::new);
        w.cand_users.resize_with(m, Vec::new);
        w.cand_bones.resize_with(m, Vec::new);
        w.cand_non_finite.resize(m, false);
        // Eq. 1 at the symbol's own position (where a successor's first
        // bone starts) is the spawn's; other bases are remembered.
        let mut memo = None;
        let mut base_tubes = None;
        let input = std::mem::take(&mut w.input);
        for c in 0..n {
            // A pinned module draws from its key (every candidate the same).
            let ctx = if sp.scope & PINNED != 0 {
                pinned_draws(sp.key)
            } else {
                DrawCtx {
                    position: c as u32,
                    ..draws
                }
            };
            let chosen = if sp.force != 0 {
                self.g.choose_forced(
                    w,
                    sp.symbol,
                    &input,
                    Which::Normal,
                    &ctx,
                    "skeleton",
                    sp.force,
                )
            } else {
                self.g
                    .choose(w, sp.symbol, &input, Which::Normal, &ctx, "skeleton")
            };
            let alt = match chosen {
                Ok(Some(a)) => a,
                Ok(None) => INERT,
                Err(e) => {
                    w.input = input;
                    return Err(e);
                }
            };
            let mut plans = std::mem::take(&mut w.cand_plans[c]);
            plans.clear();
            let mut cost = 0.0;
            if alt != INERT {
                let done = self
                    .g
                    .eval_successor(w, sp.symbol, alt, &ctx, "skeleton")
                    .and_then(|()| {
                        self.edit_successor(w, sp.key, sp.scope, alt, true, sp.symbol, "skeleton")
                    })
                    .and_then(|()| self.g.interpret(w, alt, &sp.turtle));
                if let Err(e) = done {
                    w.input = input;
                    return Err(e);
                }
                for &(b, t) in &w.bones {
                    let plan = if !(b.is_finite() && t.is_finite()) {
                        self.cost.plan_bone(b, t)
                    } else {
                        match sp.near {
                            // Based at the symbol: its tubes are searched
                            // once for all the candidates.
                            Some(n) if n.position == b => {
                                let tubes = base_tubes
                                    .get_or_insert_with(|| w.tubes.tubes_near(&self.cost, &n));
                                self.cost
                                    .plan_bone_near_in(b, t, n.curve, &n.closest, Some(tubes))
                            }
                            _ => match self.near_at(b, &mut memo) {
                                Some(n) => self.cost.plan_bone_near(b, t, n.curve, &n.closest),
                                None => self.cost.plan_bone(b, t),
                            },
                        }
                    };
                    cost +=
                        self.cost.peek(&q.cost, &plan) + self.cover_delta(&q.cost, &plan, cover);
                    plans.push(plan);
                }
                if w.non_finite {
                    cost = f64::INFINITY;
                } else if cover > 0.0 && reach.candidates > 0.0 {
                    let ahead = self.lookahead(w, alt, &q.cost, &plans, reach);
                    cost -= 2.0 * cover * reach.candidates * ahead;
                }
            } else {
                w.params.clear();
                w.users.clear();
                w.bones.clear();
                w.non_finite = false;
            }
            // Keep the candidate's successor (swapped: no copies).
            std::mem::swap(&mut w.params, &mut w.cand_params[c]);
            std::mem::swap(&mut w.users, &mut w.cand_users[c]);
            std::mem::swap(&mut w.bones, &mut w.cand_bones[c]);
            w.cand_non_finite[c] = w.non_finite;
            w.cand_plans[c] = plans;
            w.cand_alt.push(alt);
            w.cand_logv.push(if cost.is_nan() {
                f64::NEG_INFINITY
            } else {
                -cost / temperature
            });
        }
        w.input = input;
        let u = f64::from(
            DrawCtx {
                iteration: STREAM_CANDIDATE,
                position: 0,
                ..draws
            }
            .uniform(0),
        );
        let (c, correction) = resample::choose_candidate(&w.cand_logv, u);
        Ok((c, correction))
    }

    /// Close every open skeleton symbol of `p` with its wrap-up production
    /// (nodes in step `cur`; draws keyed by `key`, the particle's index
    /// among the run's final particles over every refinement round).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn wrap_up(
        &self,
        w: &mut Worker,
        layers: &[Vec<Step>],
        cur: (u32, u32),
        key: u32,
        p: &Particle,
        seed: u32,
        opts: &SampleOptions,
    ) -> Result<(Particle, Step), SampleError> {
        let (limits, cancel) = (&opts.limits, opts.cancel.as_ref());
        w.append_spawns = false;
        let mut q = p.clone();
        let mut local = Step::default();
        let mut k = 0u32;
        while !q.open.is_empty() {
            if k.is_multiple_of(CANCEL_EVERY) {
                cancel::check(cancel)?;
            }
            if u64::from(k) >= limits.max_expansions {
                return Err(SampleError::GeometryLimit {
                    symbol: "(wrap-up)".into(),
                    what: LimitKind::Expansions,
                    limit: limits.max_expansions,
                    file: self.g.sys.file,
                    span: self.g.sys.span,
                });
            }
            let draws = tagged(seed, STREAM_WRAPUP, key, k);
            k += 1;
            let idx = q.open.len() - 1;
            let how = How::Draw {
                draws,
                which: Which::Wrapup,
                phase: "wrap-up",
            };
            self.expand_open(w, layers, &mut local, cur, &mut q, idx, how, false, &[])?;
        }
        q.score = self.score(&q, 0.0, opts.guide.cover);
        Ok((q, local))
    }
}

//! Particles of a guided sampler: the heuristic and cost terms of a
//! partial model, bones added, open symbols spawned and expanded one
//! step (see the parent module).

use super::*;

impl<'a> Sampler<'a> {
    // ---- particles --------------------------------------------------------

    /// Eq. 1 at `position`: remembered in `memo` for the last position
    /// asked (the non-terminals an expansion emits side by side share
    /// their frame, `branch maybeBranch maybeBranch`, and the closest-point
    /// search is most of the cost). `None` for a non-finite position.
    pub(super) fn near_at(&self, position: Vec3, memo: &mut Option<Near>) -> Option<Near> {
        self.near_at_known(position, memo, None)
    }

    /// [`Self::near_at`] with one curve's closest point known
    /// (`CostModel::nearest_curve_known`; the same answer).
    pub(super) fn near_at_known(
        &self,
        position: Vec3,
        memo: &mut Option<Near>,
        known: Option<(usize, &grm_guide::ClosestPoint)>,
    ) -> Option<Near> {
        match memo {
            Some(m) if m.position == position => Some(*m),
            _ => {
                let p = position.as_dvec3();
                if !p.is_finite() {
                    return None;
                }
                let (curve, closest) = self.cost.nearest_curve_known(p, known);
                let n = Near {
                    position,
                    curve,
                    closest,
                };
                *memo = Some(n);
                Some(n)
            }
        }
    }

    /// Eq. 10's term for a skeleton symbol opened at frame `t` (fixed
    /// point) whose position's nearest curve is `near`; 0 for a symbol
    /// whose expected direction is zero (it grows no bone, so it adds no
    /// future alignment cost).
    pub(super) fn heuristic_term(&self, sym: u32, t: &Turtle, near: Option<Near>) -> i64 {
        let e = self
            .expected
            .get(sym as usize)
            .copied()
            .unwrap_or(Vec3::ZERO);
        if e == Vec3::ZERO {
            return 0;
        }
        to_fixed(self.heuristic_near(&t.frame, e, near))
    }

    /// `CostModel::heuristic_in_frame`, computed the same way (the same
    /// operations on the same values, so bit for bit the same result),
    /// given eq. 1 at the frame's position (`None`: not finite).
    pub(super) fn heuristic_near(
        &self,
        frame: &glam::Affine3A,
        expected: Vec3,
        near: Option<Near>,
    ) -> f64 {
        let Some(n) = near else {
            return f64::INFINITY;
        };
        let (bez, params) = &self.guides[n.curve];
        grm_guide::alignment_cost(
            frame.transform_vector3(expected).as_dvec3(),
            bez.tangent(n.closest.t),
            params.alignment_scale,
            params.alignment_offset,
        )
    }

    /// [`Self::heuristic_near`] for a frame, finding eq. 1 at its position.
    pub(super) fn heuristic_in_frame(&self, frame: &glam::Affine3A, expected: Vec3) -> f64 {
        let near = self.near_at(Vec3::from(frame.translation), &mut None);
        self.heuristic_near(frame, expected, near)
    }

    /// The objective without heuristic.
    pub(super) fn objective_of(&self, p: &Particle) -> f64 {
        match (self.objective, &self.volume, &p.volume) {
            (Objective::Volume { weight, .. }, Some(vt), Some(vs)) => weight * vt.cost(vs).total(),
            _ => self.cost.total(&p.cost).total(),
        }
    }

    /// [`Guide::cover`]'s term `T` of `state` (0 when `w` is 0 or the
    /// objective is not the curve cost).
    pub(super) fn cover_term(&self, state: &grm_guide::CostState, w: f64) -> f64 {
        if w <= 0.0 || !matches!(self.objective, Objective::Curves) {
            return 0.0;
        }
        let mut t = 0.0;
        for c in 0..self.guides.len() {
            let (k, n) = self.cost.covered_segments(state, c);
            if n > 0 {
                let u = 1.0 - k as f64 / n as f64;
                t -= w * n as f64 * (1.0 - u * u);
            }
        }
        t
    }

    /// The change of [`Self::cover_term`] were `plan` added to `state`.
    pub(super) fn cover_delta(&self, state: &grm_guide::CostState, plan: &BonePlan, w: f64) -> f64 {
        if w <= 0.0 {
            return 0.0;
        }
        let mut delta = 0.0;
        self.cost.cover_gains(state, plan, |c, new| {
            let (k, n) = self.cost.covered_segments(state, c);
            let n = n.max(1) as f64;
            let (u0, u1) = (1.0 - k as f64 / n, 1.0 - (k + new) as f64 / n);
            delta -= w * n * (u0 * u0 - u1 * u1);
        });
        delta
    }

    /// The objective the search follows: [`Self::objective_of`] plus the
    /// coverage term of [`Guide::cover`] `w`.
    pub(super) fn searched(&self, p: &Particle, w: f64) -> f64 {
        self.objective_of(p) + self.cover_term(&p.cost, w)
    }

    pub(super) fn score(&self, p: &Particle, h_scale: f64, w: f64) -> f64 {
        let base = self.searched(p, w);
        if h_scale == 0.0 {
            base
        } else {
            base + h_scale * from_fixed(p.heuristic)
        }
    }

    /// Score `w.bones` into `p`. `plans`: the bones' plans when the caller
    /// made them already (a chosen candidate), else empty.
    /// `near`: eq. 1 at the expanded symbol's position, for bones based
    /// there.
    pub(super) fn add_bones(
        &self,
        w: &Worker,
        p: &mut Particle,
        plans: &[BonePlan],
        near: Option<Near>,
    ) {
        let planned = plans.len() == w.bones.len()
            && plans
                .iter()
                .zip(&w.bones)
                .all(|(pl, &(b, t))| pl.ends() == (b.as_dvec3(), t.as_dvec3()));
        for (k, &(b, t)) in w.bones.iter().enumerate() {
            if planned {
                self.cost.add_planned(&mut p.cost, &plans[k]);
            } else {
                let plan = match near {
                    Some(n) if n.position == b => {
                        self.cost.plan_bone_near(b, t, n.curve, &n.closest)
                    }
                    _ => self.cost.plan_bone(b, t),
                };
                self.cost.add_planned(&mut p.cost, &plan);
            }
            if let (Some(vt), Some(vs)) = (&self.volume, p.volume.as_mut()) {
                vt.add_bone(vs, b, t);
            }
        }
        if w.non_finite {
            // The interpreter dropped a bone with a non-finite end: the
            // model's cost is +inf (weight 0).
            self.cost.add_bone(&mut p.cost, Vec3::NAN, Vec3::NAN);
        }
        p.bones += w.bones.len() as u32;
    }

    /// Append the skeleton spawns of the successor just interpreted in `w`
    /// to `out`; returns the sum of their heuristic terms.
    /// Each spawn gets eq. 1 at its position (`memo`: the expanded
    /// symbol's, reused where a spawn sits at the same position).
    pub(super) fn push_spawns(
        &self,
        w: &Worker,
        alt: u32,
        compute_h: bool,
        out: &mut Vec<Spawn>,
        mut memo: Option<Near>,
        plans: &[BonePlan],
    ) -> i128 {
        let sys = self.g.sys;
        let a = &sys.alts[alt as usize];
        let mut h_sum = 0;
        for (ord, &(m, t)) in w.users.iter().enumerate() {
            let sym = sys.succ[(a.succ_offset + m) as usize].symbol;
            if self.g.is_skeleton(sym) {
                let position = Vec3::from(t.frame.translation);
                // At a planned bone's tip the tip's closest point on the
                // bone's curve is known already.
                let known = plans
                    .iter()
                    .find(|pl| pl.ends().1 == position.as_dvec3())
                    .and_then(BonePlan::tip_closest);
                let near = self.near_at_known(position, &mut memo, known);
                let h = if compute_h {
                    self.heuristic_term(sym, &t, near)
                } else {
                    0
                };
                h_sum += i128::from(h);
                let e = if self.replay.is_some() {
                    w.succ.mods.get(m as usize).copied().unwrap_or_default()
                } else {
                    crate::edits::Succ::default()
                };
                out.push(Spawn {
                    ordinal: ord as u32,
                    symbol: sym,
                    module: m,
                    turtle: t,
                    h,
                    near,
                    key: e.key,
                    scope: e.scope,
                    force: e.force,
                });
            }
        }
        h_sum
    }

    /// Add the node for the successor just made in `w` (parameter words in
    /// `w.params`) to `local` (step `cur`), and open its skeleton spawns.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn add_node(
        &self,
        w: &Worker,
        p: &mut Particle,
        local: &mut Step,
        cur: (u32, u32),
        parent: (u32, u32),
        symbol: u32,
        kind: NodeKind,
        alt: u32,
        compute_h: bool,
        slot: Option<usize>,
        near: Option<Near>,
        plans: &[BonePlan],
    ) {
        let p0 = local.params.len() as u32;
        let s0 = local.spawns.len() as u32;
        if alt != INERT {
            local.params.extend_from_slice(&w.params);
            p.heuristic += self.push_spawns(w, alt, compute_h, &mut local.spawns, near, plans);
        }
        let id = NodeId {
            layer: cur.0,
            step: cur.1,
            k: local.nodes.len() as u32,
        };
        let first = p.seq == u32::MAX;
        local.nodes.push(Node {
            prev: (!first).then_some(p.head),
            seq: p.seq.wrapping_add(1),
            parent,
            symbol,
            kind,
            alt,
            params: (p0, local.params.len() as u32),
            spawns: (s0, local.spawns.len() as u32),
        });
        // The expanded symbol's slot (if any) takes the first new open
        // symbol (one path copy instead of a removal and an append); the
        // others are appended, or the slot is removed when there are none.
        let n = local.spawns.len() as u32 - s0;
        let live = |s: u32| !self.g.dead.get(s as usize).copied().unwrap_or(false);
        let opened = local.spawns[s0 as usize..]
            .iter()
            .filter(|sp| live(sp.symbol))
            .count() as u32;
        // The expanded symbol (open at `slot`) is closed.
        let closed = u32::from(slot.is_some() && live(symbol));
        p.live = (p.live + opened).saturating_sub(closed);
        let mut first_new = 0;
        if let Some(i) = slot {
            let open = if n > 0 && !w.append_spawns {
                first_new = 1;
                p.open.set(i, OpenRef { node: id, spawn: 0 })
            } else {
                p.open.swap_remove(i).map(|(v, _)| v)
            };
            if let Some(open) = open {
                p.open = open;
            }
        }
        for k in first_new..n {
            p.open = p.open.push(OpenRef { node: id, spawn: k });
        }
        p.head = id;
        p.seq = p.seq.wrapping_add(1);
    }

    /// The particle holding only the axiom (interpreted from the initial
    /// turtle, its bones scored, its skeleton symbols open), in its own
    /// step (layer 0). `given`: the axiom's parameter words (replay);
    /// otherwise they are drawn.
    pub(super) fn root_particle(
        &self,
        w: &mut Worker,
        given: Option<&[f32]>,
        seed: u32,
        h_scale: f64,
        cover: f64,
    ) -> Result<(Particle, Step), SampleError> {
        let alt = self.g.sys.axiom_alt;
        match given {
            None => {
                let ctx = tagged(seed, STREAM_AXIOM, 0, 0);
                self.g.eval_successor(w, u32::MAX, alt, &ctx, "axiom")?;
            }
            Some(p) => {
                w.params.clear();
                w.params.extend_from_slice(p);
            }
        }
        let root = self.g.sys.root_key(seed);
        self.edit_successor(w, root, 0, alt, given.is_none(), u32::MAX, "axiom")?;
        self.g.interpret(w, alt, &self.g.initial_turtle())?;
        let mut p = Particle {
            head: NodeId {
                layer: 0,
                step: 0,
                k: 0,
            },
            seq: u32::MAX,
            open: PVec::new(),
            cost: self.cost.new_state(),
            volume: self.volume.as_ref().map(VolumeTarget::new_state),
            heuristic: 0,
            score: 0.0,
            bones: 0,
            live: 0,
        };
        self.add_bones(w, &mut p, &[], None);
        let mut step = Step::default();
        self.add_node(
            w,
            &mut p,
            &mut step,
            (0, 0),
            ROOT,
            u32::MAX,
            NodeKind::Axiom,
            alt,
            h_scale > 0.0,
            None,
            None,
            &[],
        );
        p.score = self.score(&p, h_scale, cover);
        Ok((p, step))
    }

    /// The spawn an open symbol refers to and its parent node's sequence
    /// number; puts the spawned module's parameters in `w.input`.
    pub(super) fn open_spawn(
        &self,
        w: &mut Worker,
        arena: Arena<'_>,
        r: OpenRef,
    ) -> Result<(Spawn, u32), SampleError> {
        let (step, node) = arena.get(r.node).ok_or_else(missing_node)?;
        let sp = *step
            .spawns(node)
            .get(r.spawn as usize)
            .ok_or_else(missing_node)?;
        let input = self.g.module_params(node.alt, sp.module, step.params(node));
        w.input.clear();
        w.input.extend_from_slice(input);
        Ok((sp, node.seq))
    }

    /// Expand open symbol `idx` of `p`, adding the node to `local` (step
    /// `cur` of the arena); returns the bones it added.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn expand_open(
        &self,
        w: &mut Worker,
        layers: &[Vec<Step>],
        local: &mut Step,
        cur: (u32, u32),
        p: &mut Particle,
        idx: usize,
        how: How<'_>,
        compute_h: bool,
        plans: &[BonePlan],
    ) -> Result<usize, SampleError> {
        let Some(&r) = p.open.get(idx) else {
            return Ok(0);
        };
        // Read the parent (copy what is needed: `local` grows below).
        let (sp, parent_seq) = self.open_spawn(w, Arena { layers, local, cur }, r)?;
        p.heuristic -= i128::from(sp.h);
        let which = match how {
            How::Draw { which, .. } | How::Given { which, .. } => which,
            How::Prepared { .. } => Which::Normal,
        };
        let prepared = matches!(how, How::Prepared { .. });
        let alt = match how {
            How::Draw { draws, phase, .. } => {
                // A pinned module draws from its key.
                let draws = if sp.scope & PINNED != 0 {
                    pinned_draws(sp.key)
                } else {
                    draws
                };
                let input = std::mem::take(&mut w.input);
                let chosen = if sp.force != 0 {
                    self.g
                        .choose_forced(w, sp.symbol, &input, which, &draws, phase, sp.force)
                } else {
                    self.g.choose(w, sp.symbol, &input, which, &draws, phase)
                };
                w.input = input;
                match chosen? {
                    Some(a) => {
                        self.g.eval_successor(w, sp.symbol, a, &draws, phase)?;
                        a
                    }
                    None => INERT,
                }
            }
            How::Given { alt, params, .. } => {
                if alt != INERT && !self.fits(alt, sp.symbol, which, params) {
                    return Err(SampleError::Options(format!(
                        "cannot replay the tree: production {alt} with {} parameter words does not expand `{}`",
                        params.len(),
                        self.g.symbol_name(sp.symbol)
                    )));
                }
                w.params.clear();
                w.params.extend_from_slice(params);
                alt
            }
            How::Prepared { alt } => alt,
        };
        let kind = match which {
            Which::Normal => NodeKind::Skeleton,
            Which::Wrapup => NodeKind::Wrapup,
        };
        let mut bones = 0;
        if alt != INERT {
            // A drawn successor's values are edited here; a given or
            // prepared one's were (its keys and scopes are found again).
            let drawn = matches!(how, How::Draw { .. });
            self.edit_successor(w, sp.key, sp.scope, alt, drawn, sp.symbol, "skeleton")?;
            if prepared {
                w.succ.removing = false;
            } else {
                self.g.interpret(w, alt, &sp.turtle)?;
            }
            self.add_bones(w, p, plans, sp.near);
            bones = w.bones.len();
        }
        self.add_node(
            w,
            p,
            local,
            cur,
            (parent_seq, sp.ordinal),
            sp.symbol,
            kind,
            alt,
            compute_h,
            Some(idx),
            sp.near,
            plans,
        );
        Ok(bones)
    }

    /// Whether alternative `alt` is a `which` production of `symbol` whose
    /// successor has `params.len()` parameter words (a replayed tree's node
    /// must be, or the tables would be read out of range).
    pub(super) fn fits(&self, alt: u32, symbol: u32, which: Which, params: &[f32]) -> bool {
        let sys = self.g.sys;
        let Some(a) = sys.alts.get(alt as usize) else {
            return false;
        };
        let Some(g) = sys.groups.get(a.group as usize) else {
            return false;
        };
        let wrapup = g.flags & grm_compile::table::GROUP_WRAPUP != 0;
        g.pred == symbol
            && wrapup == (which == Which::Wrapup)
            && a.succ_words as usize == params.len()
    }

    /// One particle step (Calder's `advance`): expand random open skeleton
    /// symbols until one adds a bone or none is left; score the result.
    /// `local` is a (recycled) step to fill. An expansion of a symbol that
    /// can make a bone draws `kc` candidates when `kc > 1`
    /// ([`Self::draw_candidates`]). Returns the new particle, the step
    /// holding its new nodes (layer `g + 1`, index `i`), the number of
    /// expansions and the log-weight correction of the candidates chosen.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn advance(
        &self,
        w: &mut Worker,
        layers: &[Vec<Step>],
        mut local: Step,
        p: &Particle,
        seed: u32,
        g: u32,
        i: u32,
        h_scale: f64,
        max_k: u32,
        kc: u32,
        temperature: f64,
        guide: &Guide,
        reach: &Reach,
        left: u32,
    ) -> Result<(Particle, Step, u32, f64), SampleError> {
        let mut q = p.clone();
        local.clear();
        // The layer this generation's steps go to (generation g's is g + 1
        // in the first pass; a refinement round's are appended after).
        let cur = (layers.len() as u32, i);
        let compute_h = h_scale > 0.0;
        let reach = &Look {
            o: reach,
            left: f64::from(left),
        };
        w.append_spawns = guide.order > 1 && reach.recent > 0;
        let mut k = 0;
        let mut correction = 0.0;
        // A particle whose open symbols can none lead to a bone (W0015)
        // has nothing left to search: wrap-up closes them.
        while q.live > 0 && k < max_k {
            let draws = skeleton_draws(seed, g, i, k);
            k += 1;
            let arena = Arena {
                layers,
                local: &local,
                cur,
            };
            let spawn_at = |idx: usize| {
                q.open
                    .get(idx)
                    .and_then(|r| arena.get(r.node).map(|(st, n)| (r, st, n)))
                    .and_then(|(r, st, n)| st.spawns(n).get(r.spawn as usize).copied())
            };
            let n_open = q.open.len();
            let mut idx = pick(&draws, self.g.sys.draws, n_open);
            if guide.order > 1 {
                // A tournament: the most promising of `order` uniform
                // draws (the first draw is the paper's).
                let mut best = spawn_at(idx).map_or(f64::INFINITY, |sp| {
                    self.promise(&q, &sp, guide, reach, &mut w.tubes)
                });
                // With `Reach::recent`, the newest open symbols (last in
                // the list) enter too.
                let recent = (reach.recent as usize).min(n_open);
                for j in 1..guide.order + recent as u32 {
                    let other = if j < guide.order {
                        pick(&draws, self.g.sys.draws + j, n_open)
                    } else {
                        n_open - 1 - (j - guide.order) as usize
                    };
                    if other == idx {
                        continue;
                    }
                    let v = spawn_at(other).map_or(f64::INFINITY, |sp| {
                        self.promise(&q, &sp, guide, reach, &mut w.tubes)
                    });
                    if v < best {
                        best = v;
                        idx = other;
                    }
                }
            }
            let symbol = spawn_at(idx).map(|sp| sp.symbol);
            let kc = match symbol {
                Some(s) if guide.cover > 0.0 && self.paced(s, reach) => kc.min(reach.paced),
                _ => kc,
            };
            let candidates = kc > 1 && symbol.is_some_and(|s| self.g.can_bone[s as usize]);
            let added = if candidates {
                let (c, corr) = self.draw_candidates(
                    w,
                    layers,
                    &local,
                    cur,
                    &q,
                    idx,
                    draws,
                    kc,
                    temperature,
                    guide.cover,
                    reach,
                )?;
                correction += corr;
                // The chosen candidate's successor into the worker.
                std::mem::swap(&mut w.params, &mut w.cand_params[c]);
                std::mem::swap(&mut w.users, &mut w.cand_users[c]);
                std::mem::swap(&mut w.bones, &mut w.cand_bones[c]);
                w.non_finite = w.cand_non_finite[c];
                let plans = std::mem::take(&mut w.cand_plans[c]);
                let how = How::Prepared { alt: w.cand_alt[c] };
                let r = self.expand_open(
                    w, layers, &mut local, cur, &mut q, idx, how, compute_h, &plans,
                );
                w.cand_plans[c] = plans;
                r?
            } else {
                let how = How::Draw {
                    draws,
                    which: Which::Normal,
                    phase: "skeleton",
                };
                self.expand_open(w, layers, &mut local, cur, &mut q, idx, how, compute_h, &[])?
            };
            if added > 0 {
                break;
            }
        }
        // Only the search's steps append (wrap-up and replays do not).
        w.append_spawns = false;
        q.score = self.score(&q, h_scale, guide.cover);
        if guide.cover > 0.0 && reach.weights > 0.0 {
            // The potential of the newest tip (what the look-ahead says
            // its symbols could still cover): a heuristic term of the
            // particle's score, taken back in the next generation's weight.
            if let Some(node) = local.nodes.last() {
                let ahead = self.spawns_lookahead(&q.cost, local.spawns(node), reach, &mut w.tubes);
                q.score -= 2.0 * guide.cover * reach.weights * ahead;
            }
        }
        Ok((q, local, k, correction))
    }
}

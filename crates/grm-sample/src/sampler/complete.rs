//! The complete model of a finished particle (its tree, bones and
//! geometry) and the checks of a model's cost in derivation order (see
//! the parent module).

use super::*;

impl<'a> Sampler<'a> {
    // ---- the complete model ------------------------------------------------

    /// The complete model of a wrapped-up particle: walk its derivation tree
    /// depth first, interpreting each expansion's successor from its
    /// non-terminal's frame, and expand the geometry symbols on the way
    /// (the geometry phase, to completion, within `limits`).
    pub(super) fn build_model(
        &self,
        w: &mut Worker,
        layers: &[Vec<Step>],
        p: &Particle,
        seed: u32,
        c: u32,
        opts: &SampleOptions,
    ) -> Result<SampledModel, SampleError> {
        let (limits, cancel) = (&opts.limits, opts.cancel.as_ref());
        let sys = self.g.sys;
        let chain = p.chain(layers);
        let key = |a: u32, b: u32| (u64::from(a) << 32) | u64::from(b);
        let mut kids: Vec<(u64, u32)> = chain
            .iter()
            .skip(1)
            .map(|(_, n)| (key(n.parent.0, n.parent.1), n.seq))
            .collect();
        kids.sort_unstable();

        enum Src {
            Chain(u32),
            Fresh {
                symbol: u32,
                alt: u32,
                params: Vec<f32>,
            },
        }
        struct Item {
            src: Src,
            turtle: Turtle,
            parent: Option<(u32, u32)>,
            depth: u32,
            /// The expanded module's identity key (the root key for the
            /// axiom).
            key: u32,
            /// Its persistent edits' scope (`crate::edits`; 0 without).
            scope: u32,
        }
        let mut interp = Interpreter::from_parts(self.g.ops.clone(), self.g.cfg);
        let mut string = ModuleString::new();
        let mut origins: Vec<u32> = Vec::new();
        let mut tree = DerivationTree::default();
        let mut users: Vec<(usize, Turtle)> = Vec::new();
        // Per expansion: its removed modules, and the successor positions
        // of the children it pushed (their places in the tree).
        let mut removed_here: Vec<(u32, u32, u32)> = Vec::new();
        let mut pushed: Vec<u32> = Vec::new();
        let mut stack = vec![Item {
            src: Src::Chain(0),
            turtle: self.g.initial_turtle(),
            parent: None,
            depth: 0,
            key: sys.root_key(seed),
            scope: 0,
        }];
        let mut geometry = 0u64;
        let mut hits = self.replay.as_ref().map(Replay::new_hits);
        while let Some(mut item) = stack.pop() {
            // The persistent edits of the successor about to be written
            // (a chain node's values were edited when the search made it).
            let edited = if let Some(r) = &self.replay {
                let (sym, alt, values) = match &mut item.src {
                    Src::Chain(seq) => {
                        let n = chain[*seq as usize].1;
                        (n.symbol, n.alt, None)
                    }
                    Src::Fresh {
                        symbol,
                        alt,
                        params,
                    } => (*symbol, *alt, Some(&mut params[..])),
                };
                r.successor(
                    &self.g,
                    item.key,
                    item.scope,
                    alt,
                    values,
                    &mut w.succ,
                    hits.as_mut(),
                )
                .map_err(|v| self.non_finite_edit(sym, alt, v, "geometry"))?;
                true
            } else {
                false
            };
            let (symbol, kind, alt, params): (u32, NodeKind, u32, &[f32]) = match &item.src {
                Src::Chain(seq) => {
                    let (st, n) = chain[*seq as usize];
                    (n.symbol, n.kind, n.alt, st.params(n))
                }
                Src::Fresh {
                    symbol,
                    alt,
                    params,
                } => (*symbol, NodeKind::Geometry, *alt, params),
            };
            let idx = tree.nodes.len() as u32;
            let first = string.len();
            // The successor's modules an edit removed: (position, the key
            // the edit named, symbol).
            removed_here.clear();
            if let Some(a) = sys.alts.get(alt as usize) {
                for (j, m) in sys.successor(a).iter().enumerate() {
                    let key = if edited {
                        let e = w.succ.mods[j];
                        if e.removed {
                            removed_here.push((
                                j as u32,
                                grm_compile::rng::child_key(item.key, m.salt),
                                m.symbol,
                            ));
                            continue;
                        }
                        e.key
                    } else {
                        grm_compile::rng::child_key(item.key, m.salt)
                    };
                    let n = self.g.words[m.symbol as usize] as usize;
                    let o = m.word_offset as usize;
                    string.push_keyed(m.symbol, params.get(o..o + n).unwrap_or(&[]), key);
                    origins.push(alt);
                }
            }
            let b0 = interp.output().bones.len() as u32;
            users.clear();
            interp
                .run_range(item.turtle, &string, first..string.len(), &mut |i, t| {
                    users.push((i, *t));
                })
                .map_err(|e| SampleError::Turtle(e.to_string()))?;
            let b1 = interp.output().bones.len() as u32;
            tree.nodes.push(TreeNode {
                parent: item.parent,
                key: item.key,
                kind,
                symbol,
                alt: (alt != INERT).then_some(alt),
                params: params.to_vec(),
                modules: first as u32..string.len() as u32,
                bones: b0..b1,
            });
            pushed.clear();
            for (ord, &(i, t)) in users.iter().enumerate().rev() {
                let parent = Some((idx, ord as u32));
                // Its successor position, and its edits by it.
                let j = i - first;
                let j = if edited && w.succ.removing {
                    w.succ.kept.get(j).map_or(j, |&k| k as usize)
                } else {
                    j
                };
                let e = if edited {
                    w.succ.mods.get(j).copied().unwrap_or_default()
                } else {
                    crate::edits::Succ::default()
                };
                if let Src::Chain(seq) = item.src
                    && let Ok(pos) = kids.binary_search_by_key(&key(seq, ord as u32), |k| k.0)
                {
                    pushed.push(j as u32);
                    stack.push(Item {
                        src: Src::Chain(kids[pos].1),
                        turtle: t,
                        parent,
                        depth: 0,
                        key: string.keys()[i],
                        scope: e.scope,
                    });
                    continue;
                }
                let sym = string.sym(i);
                if !self.g.is_geometry(sym) {
                    // Inert: a symbol without a phase, or (only if the
                    // checker let one through) a skeleton symbol.
                    continue;
                }
                let depth = item.depth + 1;
                let what = if depth > limits.max_depth {
                    Some((LimitKind::Depth, u64::from(limits.max_depth)))
                } else if geometry >= limits.max_expansions {
                    Some((LimitKind::Expansions, limits.max_expansions))
                } else {
                    None
                };
                if let Some((what, limit)) = what {
                    return Err(SampleError::GeometryLimit {
                        symbol: self.g.symbol_name(sym),
                        what,
                        limit,
                        file: sys.file,
                        span: sys.alt_spans.get(alt as usize).copied().unwrap_or(sys.span),
                    });
                }
                if geometry.is_multiple_of(u64::from(CANCEL_EVERY)) {
                    cancel::check(cancel)?;
                }
                let draws = if e.scope & PINNED != 0 {
                    pinned_draws(string.keys()[i])
                } else {
                    tagged(seed, STREAM_GEOMETRY, c, geometry as u32)
                };
                geometry += 1;
                let input: Vec<f32> = string.get(i).1.to_vec();
                let chosen = if e.force != 0 {
                    self.g.choose_forced(
                        w,
                        sym,
                        &input,
                        Which::Normal,
                        &draws,
                        "geometry",
                        e.force,
                    )?
                } else {
                    self.g
                        .choose(w, sym, &input, Which::Normal, &draws, "geometry")?
                };
                if let Some(a) = chosen {
                    self.g.eval_successor(w, sym, a, &draws, "geometry")?;
                    pushed.push(j as u32);
                    stack.push(Item {
                        src: Src::Fresh {
                            symbol: sym,
                            alt: a,
                            params: w.params.clone(),
                        },
                        turtle: t,
                        parent,
                        depth,
                        key: string.keys()[i],
                        scope: e.scope,
                    });
                }
            }
            // The removed modules' places: the parent's children are its
            // pushed modules, in successor order.
            for &(j, key, symbol) in &removed_here {
                tree.removed.push(RemovedModule {
                    parent: idx,
                    key,
                    symbol,
                    sibling: pushed.iter().filter(|&&p| p < j).count() as u32,
                });
            }
        }
        let mut interpretation = interp.finish();
        interpretation.fill_origins(&origins);
        Ok(SampledModel {
            cost: self.cost.total(&p.cost),
            volume: match (&self.volume, &p.volume) {
                (Some(vt), Some(vs)) => Some(vt.cost(vs)),
                _ => None,
            },
            objective: self.searched(p, opts.guide.cover),
            skeleton_bones: p.bones,
            interpretation,
            string,
            origins,
            tree,
            candidate: c as usize,
            param_values: sys.param_values.clone(),
            edits: self
                .replay
                .as_ref()
                .zip(hits.as_ref())
                .map(|(r, h)| r.hits(h)),
        })
    }

    // ---- checks -------------------------------------------------------------

    /// Replay the axiom, skeleton and wrap-up expansions of `tree` (a
    /// complete derivation made by this sampler) in a random order (every
    /// non-terminal after the expansion that emitted it; the order is drawn
    /// from `order_seed`) with the sampler's own machinery, and return the
    /// cost of the result. It equals the model's cost, bit for bit, for
    /// every order: the check that the cost does not depend on the order in
    /// which symbols were expanded.
    pub fn cost_in_order(
        &self,
        tree: &DerivationTree,
        order_seed: u32,
    ) -> Result<CostBreakdown, SampleError> {
        let bad = |m: &str| SampleError::Options(format!("cannot replay the tree: {m}"));
        let root = tree.nodes.first().ok_or_else(|| bad("it is empty"))?;
        if root.kind != NodeKind::Axiom {
            return Err(bad("node 0 is not the axiom"));
        }
        let mut kid: HashMap<(u32, u32), u32> = HashMap::new();
        for (i, n) in tree.nodes.iter().enumerate() {
            if let Some(p) = n.parent {
                kid.insert(p, i as u32);
            }
        }
        let axiom = self.g.sys.alts.get(self.g.sys.axiom_alt as usize);
        if root.alt != Some(self.g.sys.axiom_alt)
            || axiom.is_none_or(|a| a.succ_words as usize != root.params.len())
        {
            return Err(bad("node 0 does not fit the axiom"));
        }
        let mut w = self.g.worker();
        let (mut p, root_step) = self.root_particle(&mut w, Some(&root.params), 0, 0.0, 0.0)?;
        let mut layers = vec![vec![root_step]];
        // Chain seq -> tree node.
        let mut tree_of = vec![0u32];
        let mut used = vec![false; tree.nodes.len()];
        used[0] = true;
        let mut k = 0u32;
        while !p.open.is_empty() {
            let ctx = tagged(order_seed, STREAM_ORDER, k, 0);
            k += 1;
            let idx = pick(&ctx, 0, p.open.len());
            let r = *p.open.get(idx).ok_or_else(|| bad("open list"))?;
            let (seq, ordinal) = {
                let arena = Arena {
                    layers: &layers,
                    local: &layers[0][0],
                    cur: (0, 0),
                };
                let (st, n) = arena.get(r.node).ok_or_else(|| bad("a node is missing"))?;
                let sp = st
                    .spawns(n)
                    .get(r.spawn as usize)
                    .ok_or_else(|| bad("spawn"))?;
                (n.seq, sp.ordinal)
            };
            let parent = tree_of[seq as usize];
            let child = *kid
                .get(&(parent, ordinal))
                .ok_or_else(|| bad("an open symbol has no expansion"))?;
            // Each node expands one symbol once (defensive: with one parent
            // per node and the root used once, no node can come back).
            if std::mem::replace(&mut used[child as usize], true) {
                return Err(bad("a node is reached twice"));
            }
            let n = &tree.nodes[child as usize];
            let which = match n.kind {
                NodeKind::Wrapup => Which::Wrapup,
                NodeKind::Skeleton => Which::Normal,
                _ => return Err(bad("a skeleton symbol has a geometry expansion")),
            };
            let how = How::Given {
                alt: n.alt.unwrap_or(INERT),
                params: &n.params,
                which,
            };
            // Each replayed expansion in a step (layer) of its own.
            let cur = (layers.len() as u32, 0);
            let mut local = Step::default();
            self.expand_open(
                &mut w,
                &layers,
                &mut local,
                cur,
                &mut p,
                idx,
                how,
                false,
                &[],
            )?;
            layers.push(vec![local]);
            tree_of.push(child);
        }
        Ok(self.cost.total(&p.cost))
    }
}

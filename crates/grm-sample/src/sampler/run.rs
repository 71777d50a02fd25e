//! The run of a guided sampler: the schedule of generations, resampling,
//! wrap-up, and the ranked finished particles (see the parent module).

use super::*;

impl<'a> Sampler<'a> {
    // ---- the run ----------------------------------------------------------

    /// Sample one model: the skeleton phase (SOSMC over the schedule),
    /// wrap-up of every distinct final particle, then the geometry phase
    /// for the best ones. Deterministic for a given seed and schedule,
    /// whatever `threads`, unless a `budget` stops the search early.
    /// A set [`SampleOptions::cancel`] token stops it with
    /// [`SampleError::Cancelled`].
    pub fn sample(&self, opts: &SampleOptions) -> Result<SampleResult, SampleError> {
        let keep = if opts.frames { Keep::All } else { Keep::None };
        self.sample_keeping(opts, keep)
    }

    /// [`Self::sample`], keeping the frame of `generation` alone (0-based;
    /// past the last generation run, the last one: the result's) in
    /// [`SampleResult::frames`] ([`SampleResult::frame`] finds it): what
    /// `grmc sample --generation K` and the preview's generation scrubber
    /// show, for the price of one frame rather than one per generation.
    /// With [`SampleOptions::frames`] every frame is kept anyway.
    pub fn sample_frame(
        &self,
        opts: &SampleOptions,
        generation: u32,
    ) -> Result<SampleResult, SampleError> {
        let keep = if opts.frames {
            Keep::All
        } else {
            Keep::One(generation)
        };
        self.sample_keeping(opts, keep)
    }

    pub(super) fn sample_keeping(
        &self,
        opts: &SampleOptions,
        keep: Keep,
    ) -> Result<SampleResult, SampleError> {
        let threads = match opts.threads {
            0 => std::thread::available_parallelism().map_or(1, |n| n.get().min(MAX_THREADS)),
            t if t > MAX_THREADS => {
                return Err(SampleError::Options(format!(
                    "{t} threads is more than the {MAX_THREADS} a sampler starts (0 uses all cores, 1 runs on the calling thread)"
                )));
            }
            t => t,
        };
        // The checker's bounds on the settings (a schedule built by hand
        // can pass anything): beyond them the particles alone would not fit
        // in memory.
        let sched = &opts.schedule;
        if sched.generations > grm_sema::MAX_GENERATIONS {
            return Err(SampleError::Options(format!(
                "{} generations is more than the {} a search runs",
                sched.generations,
                grm_sema::MAX_GENERATIONS
            )));
        }
        let most = sched.particles_start.max(sched.particles_end);
        if most > grm_sema::MAX_PARTICLES {
            return Err(SampleError::Options(format!(
                "{most} particles is more than the {} a search keeps",
                grm_sema::MAX_PARTICLES
            )));
        }
        if opts.candidates > grm_sema::MAX_PARTICLES {
            return Err(SampleError::Options(format!(
                "{} candidates is more than the {} a search tries",
                opts.candidates,
                grm_sema::MAX_PARTICLES
            )));
        }
        cancel::check(opts.cancel.as_ref())?;
        if threads <= 1 {
            return self.run(opts, keep, false);
        }
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .map_err(|e| SampleError::ThreadPool(e.to_string()))?;
        pool.install(|| self.run(opts, keep, true))
    }

    pub(super) fn run(
        &self,
        opts: &SampleOptions,
        keep: Keep,
        parallel: bool,
    ) -> Result<SampleResult, SampleError> {
        let start = Instant::now();
        let sched = opts.schedule;
        let gens = sched.generations.max(1);
        let seed = opts.seed;
        let h_of = |g: u32| {
            if opts.heuristic {
                sched.heuristic_scale(g)
            } else {
                0.0
            }
        };
        let temperature = if opts.temperature > 0.0 && !opts.temperature.is_nan() {
            opts.temperature
        } else {
            1.0
        };
        let ess_target = if opts.ess_target.is_finite() {
            opts.ess_target.clamp(0.0, 1.0)
        } else {
            0.0
        };
        let max_k = opts.max_expansions_per_step.max(1);
        // Candidates need a per-bone cost and finite weights.
        let kc = if matches!(self.objective, Objective::Curves) && temperature.is_finite() {
            opts.candidates.max(1)
        } else {
            1
        };
        let cancel = opts.cancel.as_ref();
        let mut w = self.g.worker();
        let (root, root_step) =
            self.root_particle(&mut w, None, seed, h_of(0), opts.guide.cover)?;
        // The arena: layer 0 the axiom, layer g + 1 generation g, then the
        // wrap-ups.
        let mut layers: Vec<Vec<Step>> = vec![vec![root_step]];
        // Every particle of generation 0 starts as the same axiom (shared).
        let root = Arc::new(root);
        let mut pop: Vec<Arc<Particle>> =
            (0..sched.particles(0)).map(|_| Arc::clone(&root)).collect();
        // Grown as the generations run (a preallocated record per
        // generation of a long schedule is memory the search may not use).
        let mut stats: Vec<GenerationStats> = Vec::new();
        let mut log_w = Vec::new();
        let mut weights = Vec::new();
        let mut ancestors = Vec::new();
        let mut stopped_early = false;
        let mut last: Vec<Arc<Particle>> = Vec::new();
        let mut frames: Vec<(u32, Result<SampledModel, SampleError>)> = Vec::new();
        // The bytes of the frames kept (what `max_bytes` bounds with the
        // search: a frame per generation of a long run is many models).
        let mut frame_bytes: u64 = 0;
        // Wall time spent on frames, which the budget does not count.
        let mut frame_time = Duration::ZERO;
        // Steps of particles that were not resampled, emptied for reuse.
        let mut spare: Vec<Step> = Vec::new();
        let mut used = Vec::new();
        // The bytes of every step in `layers` and `spare` (a recycled
        // step moves from one to the other with its capacity).
        let mut arena_bytes: u64 = layers.iter().flatten().map(|s| s.bytes() as u64).sum();
        // The arena's own structure: a `Step` per particle per generation
        // (its buffers are in `arena_bytes`), counted as layers are made.
        let mut layer_bytes: u64 = layers
            .iter()
            .map(|l| (l.capacity() * size_of::<Step>() + size_of::<Vec<Step>>()) as u64)
            .sum();
        // Everything else the search holds that grows with it: the layers'
        // list, the generation records, the spare steps, and per particle
        // its weights, ancestors and flags.
        let bookkeeping = |layers: &Vec<Vec<Step>>,
                           stats: &Vec<GenerationStats>,
                           spare: &Vec<Step>,
                           particles: usize| {
            (layers.len() * size_of::<Vec<Step>>()
                + stats.capacity() * size_of::<GenerationStats>()
                + spare.capacity() * size_of::<Step>()
                + particles
                    * (3 * size_of::<f64>() + size_of::<usize>() + 1 + 2 * size_of::<usize>()))
                as u64
        };
        let check_memory = |g: u32, held: u64, particles: usize, stats: &[GenerationStats]| {
            if held > opts.max_bytes {
                Err(SampleError::MemoryLimit {
                    generation: g,
                    bytes: held,
                    limit: opts.max_bytes,
                    particles,
                    generations: stats.to_vec(),
                })
            } else {
                Ok(())
            }
        };
        // Refinement (`Refine`): the generation its rounds restart from,
        // the population kept there, and every round's wrapped-up final
        // particles (the first pass's first).
        let restart = if opts.guide.cover > 0.0
            && matches!(self.objective, Objective::Curves)
            && temperature.is_finite()
        {
            opts.refine.restart(gens)
        } else {
            None
        };
        let covering = restart.is_some() && opts.refine.prefer_covering;
        let mut checkpoint: Option<Vec<Arc<Particle>>> = None;
        let mut kept_bytes: u64 = 0;
        let mut finals: Vec<Particle> = Vec::new();
        let mut seen_finals = std::collections::HashSet::new();
        let mut first = 0;
        let mut round = 0;
        // Rounds run to their end (a round the budget cuts short is
        // dropped, below).
        let mut completed = 0;
        let mut searched_gens = 0;
        loop {
            // Round r > 0 draws with a seed of its own.
            let rseed = if round == 0 {
                seed
            } else {
                refine::round_seed(seed, round)
            };
            for g in first..gens {
                if round == 0 && restart == Some(g) {
                    // What refinement rounds restart from (its particles'
                    // own state is held: counted with the search's).
                    kept_bytes = pop.iter().map(|p| p.own_bytes() as u64).sum();
                    checkpoint = Some(pop.clone());
                }
                // Between generations: a cancelled run stops here (a
                // generation of the Calder tree is a fraction of a millisecond).
                cancel::check(cancel)?;
                let h = h_of(g);
                let lay: &[Vec<Step>] = &layers;
                let bufs: Vec<Step> = (0..pop.len())
                    .map(|_| spare.pop().unwrap_or_default())
                    .collect();
                let taken_bytes: u64 = bufs.iter().map(|s| s.bytes() as u64).sum();
                let step = |w: &mut Worker, (i, (p, buf)): (usize, (&Arc<Particle>, Step))| {
                    self.advance(
                        w,
                        lay,
                        buf,
                        p,
                        rseed,
                        g,
                        i as u32,
                        h,
                        max_k,
                        kc,
                        temperature,
                        &opts.guide,
                        &opts.reach,
                        gens - g - 1,
                    )
                };
                let results: Vec<Result<(Particle, Step, u32, f64), SampleError>> = if parallel {
                    pop.par_iter()
                        .zip(bufs)
                        .enumerate()
                        .map_init(|| self.g.worker(), step)
                        .collect()
                } else {
                    pop.iter()
                        .zip(bufs)
                        .enumerate()
                        .map(|x| step(&mut w, x))
                        .collect()
                };
                let mut next = Vec::with_capacity(results.len());
                let mut layer = Vec::with_capacity(results.len());
                let mut expansions = 0u64;
                let mut corrections = Vec::with_capacity(results.len());
                for r in results {
                    // The first error in particle order, whatever the threads.
                    let (q, st, k, corr) = r?;
                    expansions += u64::from(k);
                    next.push(Arc::new(q));
                    layer.push(st);
                    corrections.push(corr);
                }
                // Taken from `spare` (counted there) or new: the arena holds
                // whatever capacity they have now.
                arena_bytes += layer.iter().map(|s| s.bytes() as u64).sum::<u64>();
                arena_bytes -= taken_bytes;
                layer_bytes +=
                    (layer.capacity() * size_of::<Step>() + size_of::<Vec<Step>>()) as u64;
                layers.push(layer);
                log_w.clear();
                log_w.extend(
                    next.iter()
                        .zip(&pop)
                        .zip(&corrections)
                        .map(|((q, p), corr)| {
                            if temperature.is_infinite() {
                                0.0
                            } else {
                                -(q.score - p.score) / temperature + corr
                            }
                        }),
                );
                let beta = if ess_target > 0.0 {
                    resample::temper(&log_w, ess_target * next.len() as f64)
                } else {
                    1.0
                };
                resample::scale(&mut log_w, beta);
                resample::normalized(&log_w, &mut weights);
                let best = next
                    .iter()
                    .map(|q| self.objective_of(q))
                    .fold(f64::INFINITY, f64::min);
                stats.push(GenerationStats {
                    generation: g,
                    particles: next.len(),
                    expanding: pop.iter().filter(|p| p.live > 0).count(),
                    ess: resample::ess(&weights),
                    beta,
                    survivors: 0,
                    heuristic_scale: h,
                    best_objective: best,
                    mean_bones: next.iter().map(|q| f64::from(q.bones)).sum::<f64>()
                        / next.len().max(1) as f64,
                    expansions,
                    memory_bytes: 0,
                });
                let out_of_time = opts
                    .budget
                    .is_some_and(|b| start.elapsed().saturating_sub(frame_time) >= b);
                if round > 0 && out_of_time && g + 1 < gens {
                    // A refinement round the budget stops before its end is
                    // dropped: the model is the best of the pass and the
                    // rounds that ran to their end (`last` stays empty).
                    break;
                }
                if round == 0 && keep.wants(g) && !(g + 1 == gens || out_of_time) {
                    // The last generation's frame is the returned model.
                    let t = Instant::now();
                    let f = self.frame(&mut w, &mut layers, &next, seed, opts, parallel)?;
                    frame_bytes += f.as_ref().map_or(0, |m| m.heap_bytes() as u64);
                    frames.push((g, f));
                    frame_time += t.elapsed();
                }
                if g + 1 == gens || out_of_time {
                    stopped_early = g + 1 < gens;
                    let mut seen = std::collections::HashSet::new();
                    let distinct = next.iter().filter(|p| seen.insert(p.head)).count();
                    let held = arena_bytes
                        + layer_bytes
                        + bookkeeping(&layers, &stats, &spare, next.len())
                        + frame_bytes
                        + kept_bytes
                        + next.iter().map(|p| p.own_bytes() as u64).sum::<u64>();
                    if let Some(st) = stats.last_mut() {
                        st.survivors = distinct;
                        st.memory_bytes = held;
                    }
                    check_memory(g, held, next.len(), &stats)?;
                    last = next;
                    break;
                }
                resample::systematic(
                    &weights,
                    sched.particles(g + 1),
                    resample_uniform(rseed, g),
                    &mut ancestors,
                );
                pop = ancestors.iter().map(|&a| Arc::clone(&next[a])).collect();
                // A step that no resampled particle descends from is never
                // read again: recycle its buffers.
                used.clear();
                used.resize(next.len(), false);
                for &a in &ancestors {
                    used[a] = true;
                }
                if let Some(st) = stats.last_mut() {
                    st.survivors = used.iter().filter(|&&u| u).count();
                }
                if let Some(layer) = layers.last_mut() {
                    for (st, _) in layer.iter_mut().zip(&used).filter(|(_, u)| !**u) {
                        let mut st = std::mem::take(st);
                        st.clear();
                        spare.push(st);
                    }
                    // Steps without nodes at the layer's end are never looked
                    // up (a node id names a node that exists): a search whose
                    // particles add nothing (all finished, or expanding
                    // nothing that lasts) keeps no `Step` per particle per
                    // generation for them.
                    let before = (layer.capacity() * size_of::<Step>()) as u64;
                    while layer.last().is_some_and(|s| s.nodes.is_empty()) {
                        if let Some(st) = layer.pop()
                            && st.bytes() > 0
                        {
                            spare.push(st);
                        }
                    }
                    layer.shrink_to_fit();
                    layer_bytes -= before;
                    layer_bytes += (layer.capacity() * size_of::<Step>()) as u64;
                }
                let held = arena_bytes
                    + layer_bytes
                    + bookkeeping(&layers, &stats, &spare, next.len())
                    + frame_bytes
                    + kept_bytes
                    + next
                        .iter()
                        .zip(&used)
                        .filter(|(_, u)| **u)
                        .map(|(p, _)| p.own_bytes() as u64)
                        .sum::<u64>();
                if let Some(st) = stats.last_mut() {
                    st.memory_bytes = held;
                }
                check_memory(g, held, pop.len(), &stats)?;
            }
            if round == 0 {
                searched_gens = stats.len();
            } else if last.is_empty() {
                // This round was cut short by the budget (above).
                break;
            } else {
                completed = round;
            }
            cancel::check(cancel)?;
            let wrapped = self.wrap_finals(
                &mut w,
                &mut layers,
                &last,
                seed,
                opts,
                parallel,
                &mut seen_finals,
                finals.len(),
            )?;
            finals.extend(wrapped);
            let (Some(from), Some(kept)) = (restart, checkpoint.as_ref()) else {
                break;
            };
            if round >= opts.refine.rounds || stopped_early {
                break;
            }
            let best = self.ranked(&finals, opts.guide.cover, covering, 1);
            let Some(&b) = best.first() else {
                break;
            };
            // Once started, `min_rounds` rounds run whatever the best.
            let may_end = round == 0 || round >= opts.refine.min_rounds;
            if may_end
                && (refine::covers_every_curve(&self.cost, &finals[b].cost)
                    || (opts.refine.followed_ends
                        && self.follows_every_curve(&mut w, &layers, &finals[b], seed, b, opts)?))
            {
                break;
            }
            round += 1;
            pop = kept.clone();
            first = from;
            last = Vec::new();
        }
        drop(checkpoint);
        drop(pop);
        cancel::check(cancel)?;
        // The refinement rounds' generations are not the search's: the
        // records are the first pass's.
        stats.truncate(searched_gens);
        let (models, candidates) = self.build_best(
            &mut w,
            &layers,
            &finals,
            seed,
            opts,
            covering,
            opts.best.max(1),
        )?;
        // The last generation's frame: the returned model.
        let ran = stats.len().saturating_sub(1) as u32;
        if keep.wants_last(ran)
            && let Some(best) = models.first()
        {
            frames.push((ran, Ok(best.clone())));
        }
        Ok(SampleResult {
            frames,
            models,
            generations: stats,
            candidates,
            stopped_early,
            refinements: completed,
            elapsed: start.elapsed(),
        })
    }

    /// The end of a run from `last` (its final generation's particles):
    /// [`Self::wrap_finals`], then [`Self::build_best`] of the first `best`.
    /// The wrap-ups' nodes go into a new layer of `layers`, which the
    /// caller may drop once the models are built.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn finish(
        &self,
        w: &mut Worker,
        layers: &mut Vec<Vec<Step>>,
        last: &[Arc<Particle>],
        seed: u32,
        opts: &SampleOptions,
        parallel: bool,
        best: usize,
    ) -> Result<(Vec<SampledModel>, Vec<f64>), SampleError> {
        let mut seen = std::collections::HashSet::new();
        let done = self.wrap_finals(w, layers, last, seed, opts, parallel, &mut seen, 0)?;
        self.build_best(w, layers, &done, seed, opts, false, best)
    }

    /// Wrap up the distinct particles of `last` (copies share their head
    /// node; a head in `seen`, wrapped up before, is skipped), each with
    /// the draws of its index among them plus `offset` (the particles
    /// wrapped up before, in earlier refinement rounds). Their nodes go
    /// into a new layer of `layers`. In particle order.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn wrap_finals(
        &self,
        w: &mut Worker,
        layers: &mut Vec<Vec<Step>>,
        last: &[Arc<Particle>],
        seed: u32,
        opts: &SampleOptions,
        parallel: bool,
        seen: &mut std::collections::HashSet<NodeId>,
        offset: usize,
    ) -> Result<Vec<Particle>, SampleError> {
        let cancel = opts.cancel.as_ref();
        let finals: Vec<&Arc<Particle>> = last.iter().filter(|p| seen.insert(p.head)).collect();
        let wl = layers.len() as u32;
        let lay: &[Vec<Step>] = layers;
        let wrap = |w: &mut Worker, (c, p): (usize, &&Arc<Particle>)| {
            self.wrap_up(w, lay, (wl, c as u32), (offset + c) as u32, p, seed, opts)
        };
        let wrapped: Vec<Result<(Particle, Step), SampleError>> = if parallel {
            finals
                .par_iter()
                .enumerate()
                .map_init(|| self.g.worker(), wrap)
                .collect()
        } else {
            finals.iter().enumerate().map(|x| wrap(w, x)).collect()
        };
        let mut done = Vec::with_capacity(wrapped.len());
        let mut layer = Vec::with_capacity(wrapped.len());
        for r in wrapped {
            let (q, st) = r?;
            done.push(q);
            layer.push(st);
        }
        cancel::check(cancel)?;
        layers.push(layer);
        Ok(done)
    }

    /// Whether the model of wrapped-up final particle `p` (index `c` among
    /// the run's final particles: the model [`Self::build_best`] returns
    /// when it ranks first) follows every curve by
    /// [`grm_guide::coverage`]'s measure ([`Refine::followed_ends`]). A
    /// model that cannot be built (a geometry-phase limit) does not; a
    /// cancellation is passed on.
    pub(super) fn follows_every_curve(
        &self,
        w: &mut Worker,
        layers: &[Vec<Step>],
        p: &Particle,
        seed: u32,
        c: usize,
        opts: &SampleOptions,
    ) -> Result<bool, SampleError> {
        match self.build_model(w, layers, p, seed, c as u32, opts) {
            Ok(m) => {
                let bones: Vec<(Vec3, Vec3)> = m
                    .interpretation
                    .bones
                    .iter()
                    .map(|b| (b.base, b.tip))
                    .collect();
                Ok(grm_guide::follows_every_curve(
                    &self.curves,
                    &bones,
                    &grm_guide::CoverageOptions::default(),
                ))
            }
            Err(SampleError::Cancelled) => Err(SampleError::Cancelled),
            Err(_) => Ok(false),
        }
    }

    /// The indices of the `best` lowest of `done` by the objective
    /// searched (with the coverage term `w`): lowest first, NaN last, ties
    /// by index; with `covering`, those that cover every curve
    /// ([`Refine::prefer_covering`]) before the others.
    pub(super) fn ranked(
        &self,
        done: &[Particle],
        w: f64,
        covering: bool,
        best: usize,
    ) -> Vec<usize> {
        let objective: Vec<f64> = done.iter().map(|q| self.searched(q, w)).collect();
        // With `covering`, those that leave a curve under-covered last.
        let misses: Vec<bool> = done
            .iter()
            .map(|q| covering && !refine::covers_every_curve(&self.cost, &q.cost))
            .collect();
        let mut order: Vec<usize> = (0..done.len()).collect();
        order.sort_by(|&a, &b| {
            let (x, y) = (objective[a], objective[b]);
            misses[a].cmp(&misses[b]).then(
                x.partial_cmp(&y)
                    .unwrap_or_else(|| x.is_nan().cmp(&y.is_nan()))
                    .then(a.cmp(&b)),
            )
        });
        order.truncate(best);
        order
    }

    /// The models of the `best` first of the wrapped-up final particles
    /// `done` ([`Self::ranked`] with `covering`; the geometry phase of each drawn with its
    /// index), and the objective of every one, in order.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn build_best(
        &self,
        w: &mut Worker,
        layers: &[Vec<Step>],
        done: &[Particle],
        seed: u32,
        opts: &SampleOptions,
        covering: bool,
        best: usize,
    ) -> Result<(Vec<SampledModel>, Vec<f64>), SampleError> {
        let order = self.ranked(done, opts.guide.cover, covering, best);
        let mut models = Vec::with_capacity(order.len());
        for c in order {
            models.push(self.build_model(w, layers, &done[c], seed, c as u32, opts)?);
        }
        let candidates = done
            .iter()
            .map(|q| self.searched(q, opts.guide.cover))
            .collect();
        Ok((models, candidates))
    }

    /// A frame of [`SampleOptions::frames`]: [`Self::finish`] of a
    /// generation's particles, as if the run stopped there (the same
    /// draws, so exactly the model a budget stopping it there returns).
    /// The wrap-ups' layer is dropped once the model is built: the search
    /// never sees it. A frame that cannot be finished (a wrap-up or
    /// geometry-phase limit or a failing production that the run's own
    /// end need not meet) is that error, and the search goes on; only a
    /// cancellation stops the run.
    pub(super) fn frame(
        &self,
        w: &mut Worker,
        layers: &mut Vec<Vec<Step>>,
        particles: &[Arc<Particle>],
        seed: u32,
        opts: &SampleOptions,
        parallel: bool,
    ) -> Result<Result<SampledModel, SampleError>, SampleError> {
        let n = layers.len();
        let made = self.finish(w, layers, particles, seed, opts, parallel, 1);
        layers.truncate(n);
        match made {
            Err(SampleError::Cancelled) => Err(SampleError::Cancelled),
            Err(e) => Ok(Err(e)),
            Ok((models, _)) => Ok(models.into_iter().next().ok_or_else(|| {
                // A generation has at least one particle (`Schedule`).
                SampleError::Options("a generation without particles has no frame".into())
            })),
        }
    }
}

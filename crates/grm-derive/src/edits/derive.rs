//! The edited derivation on [`Engine`]: the steps, chunks and settling
//! of a replayed [`EditPlan`] (the types and the hooks are in the parent).

use super::*;

/// The tags a run of copied modules (or the successors of an untagged
/// module) moves at once, when the buffers have room.
pub(super) const TAG_MOVE: usize = 16;

/// The blocks of input tags a tagged piece is split by: a run of at least
/// `QUIET` blocks of `TAG_BLOCK` modules without a tag is rewritten without
/// the hooks.
pub(super) const TAG_BLOCK: usize = 16;
pub(super) const QUIET: usize = 2;

/// One chunk's output slices, with the tags.
pub(super) struct EditChunk<'o> {
    range: std::ops::Range<usize>,
    /// The chunk's first output module.
    base: usize,
    syms: &'o mut [u32],
    keys: &'o mut [u32],
    tags: &'o mut [u32],
    starts: &'o mut [u32],
    params: &'o mut [f32],
    word_base: u32,
}

/// What one chunk's rewrite found.
pub(super) struct ChunkDone {
    matches: Vec<Match>,
    decided: Vec<Option<u32>>,
}

impl<'a> Engine<'a> {
    /// Replay `plan` in every derivation of this engine ([`Engine::derive`]
    /// and [`Engine::derive_edited`]; strings then carry keys). An empty
    /// plan changes nothing: the plain derivation. One step at a time,
    /// [`Engine::edited_axiom`] and [`Engine::edited_step`] replay it (they
    /// carry the state a step leaves the next); [`Engine::axiom`],
    /// [`Engine::step`] and [`Engine::decisions`] stay the plain ones.
    pub fn with_edits(mut self, plan: EditPlan) -> Engine<'a> {
        if plan.is_empty() {
            self.edits = None;
            return self;
        }
        // An edit may set any module's words: every module stores them.
        self = self.with_implicit_words(false);
        self.keyed = true;
        self.edits = Some(Box::new(plan));
        self
    }

    /// The edits this engine replays, if any.
    pub fn edit_plan(&self) -> Option<&EditPlan> {
        self.edits.as_deref()
    }

    /// [`Engine::derive`] with the engine's edits replayed, and what they
    /// met (empty without edits).
    pub fn derive_edited(
        &self,
        opts: &DeriveOptions,
        progress: &mut dyn FnMut(&IterationStats),
    ) -> Result<(Derivation, EditOutcome), DeriveError> {
        let Some(plan) = self.edits.as_deref() else {
            // `derive` takes the edited road only with a plan.
            return self
                .derive(opts, progress)
                .map(|d| (d, EditOutcome::default()));
        };
        let t = Instant::now();
        let (mut string, mut state) = self.edited_axiom(opts.seed)?;
        let mut stats = Vec::with_capacity(opts.iterations.min(64) as usize + 1);
        let first = IterationStats::of(&string, 0, 0, 0, t.elapsed());
        progress(&first);
        stats.push(first);
        let (mut cumulative, mut processed) = (0u64, 0u64);
        // Removed modules are dropped by the next step, which skips them
        // (one move of the string's tail saved per step with a removal),
        // where no rule reads a neighbour.
        let defer = !self.has_context;
        for iteration in 1..=opts.iterations {
            let t = Instant::now();
            processed += (string.len() - dead_modules(&state.dead)) as u64;
            let (next, _) = self.edited_inner(
                plan,
                &mut state,
                &string,
                iteration,
                opts.seed,
                &opts.limits,
                false,
                defer,
            )?;
            self.recycle(std::mem::replace(&mut string, next));
            let live = (string.len() - dead_modules(&state.dead)) as u64;
            cumulative += live;
            let mut s = IterationStats::of(&string, iteration, cumulative, processed, t.elapsed());
            s.modules = live;
            s.param_words -= state
                .dead
                .iter()
                .map(|r| (string.start(r.end) - string.start(r.start)) as u64)
                .sum::<u64>();
            progress(&s);
            stats.push(s);
        }
        if !state.dead.is_empty() {
            compact(&mut string, &mut Vec::new(), &state.dead);
            state.dead.clear();
            state.len = string.len();
        }
        let outcome = state.outcome(plan);
        plan.pool.give(std::mem::take(&mut state.tags));
        plan.pool.give(std::mem::take(&mut state.spare));
        plan.pool.give_table(state.table);
        Ok((Derivation { string, stats }, outcome))
    }

    /// The axiom with the engine's edits replayed on its modules, and the
    /// state [`Engine::edited_step`] carries on (without edits: the plain
    /// axiom and an empty state).
    pub fn edited_axiom(&self, seed: u32) -> Result<(ModuleString, EditState), DeriveError> {
        let mut s = self.axiom(seed)?;
        let mut state = EditState {
            tags: Vec::new(),
            len: s.len(),
            dead: Vec::new(),
            made: KeySet::with_capacity_and_hasher(
                self.edits.as_deref().map_or(0, EditPlan::len),
                Default::default(),
            ),
            spare: Vec::new(),
            table: match self.edits.as_deref() {
                Some(plan) => plan.pool.table(self),
                None => Table::new(self),
            },
            hits: vec![(0, 0); self.edits.as_deref().map_or(0, EditPlan::len)],
        };
        if let Some(plan) = self.edits.as_deref() {
            let matches: Vec<Match> = (0..s.len())
                .filter_map(|j| {
                    plan.lookup(s.keys[j]).map(|node| Match {
                        pos: j,
                        node,
                        scope: 0,
                    })
                })
                .collect();
            let mut tags = std::mem::take(&mut state.tags);
            if let Some(cut) = self.settle(plan, &mut state, &mut s, &mut tags, &matches, 0)? {
                compact(&mut s, &mut tags, &cut);
            }
            state.tags = tags;
            state.len = s.len();
        }
        Ok((s, state))
    }

    /// One rewriting step with the engine's edits replayed: the string
    /// that follows `input` (the previous string of the same edited
    /// derivation, `state` its state). `record`: what the step decided,
    /// for the derivation tree. Without edits, the plain step.
    #[allow(clippy::too_many_arguments)]
    pub fn edited_step(
        &self,
        state: &mut EditState,
        input: &ModuleString,
        iteration: u32,
        seed: u32,
        limits: &DeriveLimits,
        record: Option<&mut StepRecord>,
    ) -> Result<ModuleString, DeriveError> {
        let input = &*self.check_input(input)?;
        if state.len != input.len() || !(state.tags.is_empty() || state.tags.len() >= state.len) {
            return Err(DeriveError::InvalidInput(
                "the edit state is not the input string's".into(),
            ));
        }
        let Some(plan) = self.edits.as_deref() else {
            if let Some(r) = record {
                let decided = self.decisions(input, iteration, seed)?;
                r.kept = decided
                    .iter()
                    .map(|d| d.map_or(1, |a| self.plans[a as usize].len))
                    .collect();
                r.decided = decided;
                r.removed.clear();
            }
            let next = self.step(input, iteration, seed, limits)?;
            state.tags.clear();
            state.len = next.len();
            return Ok(next);
        };
        if state
            .tags
            .iter()
            .take(state.len)
            .any(|&t| (t & !FORCED) as usize >= state.table.entries.len())
        {
            return Err(DeriveError::InvalidInput(
                "the edit state is not the input string's".into(),
            ));
        }
        let (next, rec) = self.edited_inner(
            plan,
            state,
            input,
            iteration,
            seed,
            limits,
            record.is_some(),
            false,
        )?;
        if let (Some(r), Some(rec)) = (record, rec) {
            *r = rec;
        }
        Ok(next)
    }

    /// The edited step (see the module doc).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn edited_inner(
        &self,
        plan: &EditPlan,
        state: &mut EditState,
        input: &ModuleString,
        iteration: u32,
        seed: u32,
        limits: &DeriveLimits,
        record: bool,
        defer: bool,
    ) -> Result<(ModuleString, Option<StepRecord>), DeriveError> {
        let n = input.len();
        // The input's removed modules, skipped (`EditState::dead`).
        let dead = std::mem::take(&mut state.dead);
        let chunks = self.chunks(n);
        let parallel = chunks.len() > 1;
        let chunk = chunks.first().map_or(n, |c| c.len());
        let mate = self.in_pool(|| self.mates(input, chunk, parallel));
        // Pieces of at most `EDIT_PIECE` modules (the smallest chunk, when
        // smaller: tests): one without tags is the plain rewrite's (see
        // `rewrite_edited`).
        let piece = EDIT_PIECE.min(self.min_chunk);
        let chunks: Vec<std::ops::Range<usize>> = chunks
            .into_iter()
            .flat_map(|r| {
                (r.start..r.end)
                    .step_by(piece)
                    .map(move |a| a..(a + piece).min(r.end))
            })
            .collect();
        let chunks = if dead.is_empty() {
            chunks
        } else {
            live_pieces(chunks, &dead)
        };
        // A runtime error's position in the string without its removed
        // modules (the string the caller sees).
        let fix = |mut e: RuntimeError| {
            e.position -= dead
                .iter()
                .take_while(|r| r.end as u64 <= e.position)
                .map(|r| r.len() as u64)
                .sum::<u64>();
            e
        };
        let step = self.step_of(input, &mate, iteration, seed);
        let tags = if state.tags.is_empty() {
            &[][..]
        } else {
            &state.tags[..n]
        };
        let table = &state.table;

        // 1. Count.
        let counts: Vec<Result<(u64, u64), RuntimeError>> = if parallel {
            self.in_pool(|| {
                chunks
                    .par_iter()
                    .map(|r| self.count_edited(&step, tags, table, r.clone()))
                    .collect()
            })
        } else {
            chunks
                .iter()
                .map(|r| self.count_edited(&step, tags, table, r.clone()))
                .collect()
        };
        let mut totals = Vec::with_capacity(counts.len());
        let mut first_err: Option<RuntimeError> = None;
        for c in counts {
            match c {
                Ok(t) => totals.push(t),
                Err(e) => keep_first(&mut first_err, e),
            }
        }
        if let Some(e) = first_err {
            return Err(DeriveError::Runtime(fix(e)));
        }

        // 2. Scan and the limits.
        let (mut m, mut w) = (0u64, 0u64);
        let mut offsets = Vec::with_capacity(totals.len());
        for &(cm, cw) in &totals {
            offsets.push((m, w));
            m += cm;
            w += cw;
        }
        self.check_limits(input, &mate, iteration, m, w, limits)?;
        let (m, w) = (m as usize, w as usize);

        // 3. Rewrite.
        let mut out = self.take(m, w);
        // The tags' buffer: the one of the string before the input, or
        // one an earlier derivation left; its values are overwritten (a
        // piece with tags writes each of its own, the others are zeroed:
        // `rewrite_edited`). None while the input has no tag (`settle`
        // makes one when it makes a tag).
        let mut otags = std::mem::take(&mut state.spare);
        if tags.is_empty() {
            otags.clear();
        } else {
            otags = plan.pool.take(otags, m);
        }
        let done = {
            let mut parts = Vec::with_capacity(chunks.len());
            let (mut syms, mut starts, mut params) =
                (&mut out.syms[..], &mut out.starts[..m], &mut out.params[..]);
            let mut keys = &mut out.keys[..];
            let mut ts = &mut otags[..];
            for ((r, &(cm, cw)), &(base, word_base)) in chunks.iter().zip(&totals).zip(&offsets) {
                let cm = cm as usize;
                let (s, rest) = syms.split_at_mut(cm);
                syms = rest;
                let (k, rest) = keys.split_at_mut(cm);
                keys = rest;
                let (t, rest) = ts.split_at_mut(if tags.is_empty() { 0 } else { cm });
                ts = rest;
                let (st, rest) = starts.split_at_mut(cm);
                starts = rest;
                let (p, rest) = params.split_at_mut(cw as usize);
                params = rest;
                parts.push(EditChunk {
                    range: r.clone(),
                    base: base as usize,
                    syms: s,
                    keys: k,
                    tags: t,
                    starts: st,
                    params: p,
                    word_base: word_base as u32,
                });
            }
            let work = |c: EditChunk<'_>| self.rewrite_edited(&step, plan, tags, table, c, record);
            let results: Vec<Result<ChunkDone, RuntimeError>> = if parallel {
                self.in_pool(|| parts.into_par_iter().map(work).collect())
            } else {
                parts.into_iter().map(work).collect()
            };
            let mut first_err = None;
            let mut done = Vec::with_capacity(results.len());
            for r in results {
                match r {
                    Ok(d) => done.push(d),
                    Err(e) => keep_first(&mut first_err, e),
                }
            }
            if let Some(e) = first_err {
                return Err(DeriveError::Runtime(fix(e)));
            }
            done
        };
        out.starts[m] = w as u32;
        let mut matches: Vec<Match> =
            Vec::with_capacity(done.iter().map(|d| d.matches.len()).sum());
        for d in &done {
            matches.extend_from_slice(&d.matches);
        }
        let removed = self.settle(plan, state, &mut out, &mut otags, &matches, iteration)?;
        // For the record, what was removed (its output position, symbol
        // and key), read before the string is compacted.
        let gone: Vec<(usize, u32, u32)> = match (&removed, record) {
            (Some(cut), true) => cut
                .iter()
                .flat_map(|r| r.clone())
                .map(|p| {
                    let sym = out.sym_at(p).unwrap_or_default();
                    (p, sym, out.keys().get(p).copied().unwrap_or_default())
                })
                .collect(),
            _ => Vec::new(),
        };
        if let Some(cut) = &removed {
            if defer && !record {
                state.dead = cut.clone();
            } else {
                compact(&mut out, &mut otags, cut);
            }
        }
        state.spare = std::mem::replace(&mut state.tags, otags);
        state.len = out.len();
        let rec = record.then(|| {
            let mask = removed.map(|cut| {
                let mut mask = vec![false; m];
                for r in cut {
                    mask[r].fill(true);
                }
                mask
            });
            let decided: Vec<Option<u32>> = done.into_iter().flat_map(|d| d.decided).collect();
            let mut o = 0usize;
            let mut gone = gone.into_iter().peekable();
            let mut removed = Vec::new();
            let kept = decided
                .iter()
                .enumerate()
                .map(|(i, d)| {
                    let len = d.map_or(1, |a| self.plans[a as usize].len as usize);
                    let k = match &mask {
                        Some(mask) => mask[o..o + len].iter().filter(|&&r| !r).count(),
                        None => len,
                    };
                    while let Some(&(p, symbol, key)) = gone.peek()
                        && p < o + len
                    {
                        removed.push(RemovedModule {
                            input: i as u32,
                            copy: d.is_none(),
                            successor: (p - o) as u32,
                            symbol,
                            key,
                        });
                        gone.next();
                    }
                    o += len;
                    k as u32
                })
                .collect();
            StepRecord {
                decided,
                kept,
                removed,
            }
        });
        Ok((out, rec))
    }

    /// The decision for input module `i` tagged `tag`: the engine's, but
    /// for a forced alternative.
    #[inline(always)]
    pub(super) fn decide_edited(
        &self,
        step: &Step<'_>,
        worker: &mut crate::engine::Worker,
        table: &Table,
        tag: u32,
        i: usize,
    ) -> Result<Option<(u32, Binds)>, RuntimeError> {
        let s = step.input.syms[i] as usize;
        if self.copies[s] {
            return Ok(None);
        }
        let force = table.entry(tag).0;
        let f = self.counts[s].0;
        if force == 0 {
            if f != SLOW {
                return Ok(Some((f, Binds::Direct)));
            }
            return self.decide(step, worker, i);
        }
        self.decide_in::<true>(step, worker, i, force)
    }

    pub(super) fn count_edited(
        &self,
        step: &Step<'_>,
        tags: &[u32],
        table: &Table,
        range: std::ops::Range<usize>,
    ) -> Result<(u64, u64), RuntimeError> {
        // No forced module: the engine's own decisions, its count.
        if tags.is_empty() || tags[range.clone()].iter().fold(0, |a, &t| a | t) & FORCED == 0 {
            return self.count_chunk(step, range).map(|(m, w, _, _)| (m, w));
        }
        // The engine's count, each forced module's own decision in place
        // of the engine's (an error of the engine's: the count below, so
        // that only the decisions the replay takes can fail).
        if let Ok((mut m, mut w, _, _)) = self.count_chunk(step, range.clone()) {
            let mut worker = self.worker();
            // Blocks of 64 tags without a forced one passed at once.
            let mut a = range.start;
            while a < range.end {
                let b = (a + 64).min(range.end);
                let block = &tags[a..b];
                if block.iter().fold(0, |x, &t| x | t) & FORCED == 0 {
                    a = b;
                    continue;
                }
                for (k, &tag) in block.iter().enumerate() {
                    if tag & FORCED == 0 {
                        continue;
                    }
                    let i = a + k;
                    let (Ok((pm, pw)), (fm, fw)) = (
                        self.count_one(step, &mut worker, table, 0, i),
                        self.count_one(step, &mut worker, table, tag, i)?,
                    ) else {
                        return self.count_modules(step, tags, table, range);
                    };
                    m = m - pm + fm;
                    w = w - pw + fw;
                }
                a = b;
            }
            return Ok((m, w));
        }
        self.count_modules(step, tags, table, range)
    }

    /// The modules and words input module `i` tagged `tag` becomes.
    pub(super) fn count_one(
        &self,
        step: &Step<'_>,
        worker: &mut crate::engine::Worker,
        table: &Table,
        tag: u32,
        i: usize,
    ) -> Result<(u64, u64), RuntimeError> {
        let s = step.input.syms[i] as usize;
        Ok(match self.decide_edited(step, worker, table, tag, i)? {
            Some((alt, _)) => {
                let a = &self.system().alts[alt as usize];
                (u64::from(a.succ_len), u64::from(a.succ_words))
            }
            None => (1, u64::from(self.sym_words[s])),
        })
    }

    /// [`Engine::count_edited`] module by module.
    pub(super) fn count_modules(
        &self,
        step: &Step<'_>,
        tags: &[u32],
        table: &Table,
        range: std::ops::Range<usize>,
    ) -> Result<(u64, u64), RuntimeError> {
        let syms = &step.input.syms;
        let (mut m, mut w) = (0u64, 0u64);
        let mut worker: Option<crate::engine::Worker> = None;
        for i in range {
            let s = syms[i] as usize;
            let (f, len, words) = self.counts[s];
            let tag = tags[i];
            if f != SLOW && tag & FORCED == 0 {
                m += u64::from(len);
                w += u64::from(words);
                continue;
            }
            let wk = worker.get_or_insert_with(|| self.worker());
            match self.decide_edited(step, wk, table, tag, i)? {
                Some((alt, _)) => {
                    let a = &self.system().alts[alt as usize];
                    m += u64::from(a.succ_len);
                    w += u64::from(a.succ_words);
                }
                None => {
                    m += 1;
                    w += u64::from(self.sym_words[s]);
                }
            }
        }
        Ok((m, w))
    }

    pub(super) fn rewrite_edited(
        &self,
        step: &Step<'_>,
        plan: &EditPlan,
        tags: &[u32],
        table: &Table,
        c: EditChunk<'_>,
        record: bool,
    ) -> Result<ChunkDone, RuntimeError> {
        let EditChunk {
            range,
            base,
            syms: osyms,
            keys: okeys,
            tags: otags,
            starts: ostarts,
            params: oparams,
            word_base,
        } = c;
        let input = step.input;
        let tagged = !tags.is_empty() && tags[range.clone()].iter().fold(0, |a, &t| a | t) != 0;
        if !tagged {
            // No edit reaches a module of this piece: the plain rewrite
            // (the same modules and keys as the edited one), then the keys
            // written looked up; its tags zeros (`otags` may be empty:
            // `edited_inner`).
            self.rewrite_chunk_best::<true, ()>(
                step,
                ChunkOut {
                    range: range.clone(),
                    syms: &mut *osyms,
                    keys: &mut *okeys,
                    starts: &mut *ostarts,
                    params: &mut *oparams,
                    word_base,
                    // An engine with edits stores every word (`starts`).
                    word_in: input.start(range.start),
                },
                &mut (),
            )?;
            otags.fill(0);
            let mut matches = Vec::new();
            plan.scan(okeys, base, &mut matches);
            let decided = if record {
                self.decide_range(step, range)?
            } else {
                Vec::new()
            };
            return Ok(ChunkDone { matches, decided });
        }
        if !record {
            // The engine's own loop: with the edits' hooks over the runs
            // of blocks that hold a tag, without (`()`, then zero tags)
            // over the long runs that hold none (the tags are sparse: a
            // value edit's subtree, a forced module).
            let mut found = Vec::new();
            let (mut o, mut wo) = (0usize, 0usize);
            let mut a = range.start;
            while a < range.end {
                // The run from `a`: tagged or not as its first block, to
                // the first block of the other kind (an untagged run
                // shorter than `QUIET` blocks joins the tagged one).
                let hot = |b: usize| {
                    let e = (b + TAG_BLOCK).min(range.end);
                    tags[b..e].iter().fold(0, |x, &t| x | t) != 0
                };
                let mut b = a;
                let first_hot = hot(a);
                if first_hot {
                    loop {
                        b = (b + TAG_BLOCK).min(range.end);
                        // The quiet blocks after it, up to `QUIET`.
                        let (mut c, mut q) = (b, 0);
                        while c < range.end && q < QUIET && !hot(c) {
                            c = (c + TAG_BLOCK).min(range.end);
                            q += 1;
                        }
                        if q == QUIET {
                            break;
                        }
                        b = c;
                        if c >= range.end {
                            break;
                        }
                    }
                } else {
                    while b < range.end && !hot(b) {
                        b = (b + TAG_BLOCK).min(range.end);
                    }
                }
                let out = ChunkOut {
                    word_in: input.start(a),
                    range: a..b,
                    syms: &mut osyms[o..],
                    keys: &mut okeys[o..],
                    starts: &mut ostarts[o..],
                    params: &mut oparams[wo..],
                    word_base: word_base + wo as u32,
                };
                let m = if first_hot {
                    let mut hooks = Hooks {
                        engine: self,
                        iteration: step.iteration,
                        plan,
                        table,
                        tags,
                        otags: &mut otags[o..],
                        base: base + o,
                        matches: std::mem::take(&mut found),
                        tag: 0,
                        end: 0,
                    };
                    let r = self.rewrite_chunk_best::<true, Hooks<'_, '_>>(step, out, &mut hooks);
                    found = hooks.matches;
                    r?;
                    hooks.end
                } else {
                    let mut tail = Tail(0);
                    self.rewrite_chunk_best::<true, Tail>(step, out, &mut tail)?;
                    otags[o..o + tail.0].fill(0);
                    tail.0
                };
                // Every module's words are stored (`with_edits`).
                let w = if m == 0 {
                    0
                } else {
                    let last = (ostarts[o + m - 1] - word_base) as usize;
                    last + self.sym_words[osyms[o + m - 1] as usize] as usize - wo
                };
                o += m;
                wo += w;
                a = b;
            }
            // The keys written looked up (those the hooks did not: the
            // successors of untagged modules, scope 0, and copies, which
            // `settle` passes over), merged in position order with the
            // hooks' matches.
            let mut scanned = Vec::new();
            plan.scan(okeys, base, &mut scanned);
            let matches = if found.is_empty() {
                scanned
            } else {
                let mut all = Vec::with_capacity(scanned.len() + found.len());
                let mut f = found.into_iter().peekable();
                for m in scanned {
                    while let Some(h) = f.next_if(|h| h.pos <= m.pos) {
                        all.push(h);
                    }
                    if all.last().is_none_or(|l| l.pos != m.pos) {
                        all.push(m);
                    }
                }
                all.extend(f);
                all
            };
            return Ok(ChunkDone {
                matches,
                decided: Vec::new(),
            });
        }
        let (isyms, istarts, iparams, ikeys) = (
            &input.syms[..],
            &input.starts[..],
            &input.params[..],
            step.keys,
        );
        let mut worker = self.worker();
        let mut done = ChunkDone {
            matches: Vec::new(),
            decided: Vec::with_capacity(if record { range.len() } else { 0 }),
        };
        let (mut o, mut wo) = (0usize, 0usize);
        let (end, mut i) = (range.end, range.start);
        while i < end {
            let sym = isyms[i];
            let s = sym as usize;
            if self.copies[s] {
                // A run of copied modules, moved whole with their keys and
                // tags (as the plain rewrite moves them).
                let mut j = i + 1;
                while j < end && self.copies[isyms[j] as usize] {
                    j += 1;
                }
                let (len, ps, pe) = (j - i, istarts[i] as usize, istarts[j] as usize);
                if len == 1 {
                    // One module (a turn between two rewritten ones).
                    osyms[o] = sym;
                    ostarts[o] = word_base + wo as u32;
                    if pe - ps == 1 {
                        oparams[wo] = iparams[ps];
                    } else {
                        copy_small(&mut oparams[wo..wo + (pe - ps)], &iparams[ps..pe]);
                    }
                    okeys[o] = ikeys[i];
                    otags[o] = tags[i];
                } else {
                    osyms[o..o + len].copy_from_slice(&isyms[i..j]);
                    let delta = (word_base + wo as u32).wrapping_sub(istarts[i]);
                    for (d, &st) in ostarts[o..o + len].iter_mut().zip(&istarts[i..j]) {
                        *d = st.wrapping_add(delta);
                    }
                    oparams[wo..wo + (pe - ps)].copy_from_slice(&iparams[ps..pe]);
                    okeys[o..o + len].copy_from_slice(&ikeys[i..j]);
                    otags[o..o + len].copy_from_slice(&tags[i..j]);
                }
                if record {
                    done.decided.extend(std::iter::repeat_n(None, len));
                }
                o += len;
                wo += pe - ps;
                i = j;
                continue;
            }
            let tag = tags[i];
            if tag == 0
                && let Act::Unit(u) = self.acts[s]
            {
                // `F(l) -> F(l * k)`, inline (as the plain rewrite writes
                // it): one word, one key.
                let v = iparams[istarts[i] as usize] * u.m + u.a;
                if !v.is_finite() {
                    let span = self.system().param_spans[u.span as usize];
                    let kind = RuntimeErrorKind::NonFinite { value: v };
                    return Err(self.runtime(step, i, kind, span));
                }
                osyms[o] = u.sym;
                ostarts[o] = word_base + wo as u32;
                oparams[wo] = v;
                let ck = rng::child_key_premixed(ikeys[i], self.succ_salts[u.succ as usize]);
                okeys[o] = ck;
                otags[o] = 0;
                if let Some(node) = plan.lookup(ck) {
                    done.matches.push(Match {
                        pos: base + o,
                        node,
                        scope: 0,
                    });
                }
                if record {
                    done.decided.push(Some(self.counts[s].0));
                }
                o += 1;
                wo += 1;
                i += 1;
                continue;
            }
            let (ps, pe) = (istarts[i] as usize, istarts[i + 1] as usize);
            match self.decide_edited(step, &mut worker, table, tag, i)? {
                None => {
                    osyms[o] = sym;
                    ostarts[o] = word_base + wo as u32;
                    oparams[wo..wo + (pe - ps)].copy_from_slice(&iparams[ps..pe]);
                    okeys[o] = ikeys[i];
                    otags[o] = tag;
                    o += 1;
                    wo += pe - ps;
                    if record {
                        done.decided.push(None);
                    }
                }
                Some((alt, binds)) => {
                    let mut out = Out {
                        syms: &mut *osyms,
                        starts: &mut *ostarts,
                        params: &mut *oparams,
                        word_base,
                        o,
                        wo,
                    };
                    if binds == Binds::Buffer {
                        let buf = std::mem::take(&mut worker.buf);
                        let r = self.emit(step, &mut worker, alt, &buf, i, &mut out);
                        worker.buf = buf;
                        r?;
                    } else {
                        self.emit(step, &mut worker, alt, &iparams[ps..pe], i, &mut out)?;
                    }
                    let p = self.plans[alt as usize];
                    let len = p.len as usize;
                    let key = ikeys[i];
                    let scope = table.entry(tag).1;
                    let inherit = table.scope_tag[scope as usize];
                    let salts = &self.succ_salts[p.succ as usize..][..len];
                    for (k, &salt) in salts.iter().enumerate() {
                        let j = o + k;
                        let ck = rng::child_key_premixed(key, salt);
                        okeys[j] = ck;
                        if let Some(node) = plan.lookup(ck) {
                            // Settled after the rewrite, its values with it.
                            otags[j] = 0;
                            done.matches.push(Match {
                                pos: base + j,
                                node,
                                scope,
                            });
                            continue;
                        }
                        otags[j] = inherit;
                        if scope != 0 {
                            let s = osyms[j];
                            let a = (ostarts[j] - word_base) as usize;
                            let words = self.sym_words[s as usize] as usize;
                            if let Err(v) = table.apply(scope, s, &mut oparams[a..a + words]) {
                                return Err(self.edit_error(step.iteration, i, s, v));
                            }
                        }
                    }
                    o += len;
                    wo += p.words as usize;
                    if record {
                        done.decided.push(Some(alt));
                    }
                }
            }
            i += 1;
        }
        Ok(done)
    }

    /// The plain decisions of the modules in `range` (as
    /// [`Engine::decisions`]).
    pub(super) fn decide_range(
        &self,
        step: &Step<'_>,
        range: std::ops::Range<usize>,
    ) -> Result<Vec<Option<u32>>, RuntimeError> {
        let mut worker: Option<crate::engine::Worker> = None;
        range
            .map(|i| match self.counts[step.input.syms[i] as usize].0 {
                COPY => Ok(None),
                SLOW => {
                    let wk = worker.get_or_insert_with(|| self.worker());
                    Ok(self.decide(step, wk, i)?.map(|(alt, _)| alt))
                }
                alt => Ok(Some(alt)),
            })
            .collect()
    }

    /// A value an edit made that is not finite (R0204, at the system).
    #[cold]
    pub(super) fn edit_error(
        &self,
        iteration: u32,
        position: usize,
        sym: u32,
        value: f32,
    ) -> RuntimeError {
        let sys = self.system();
        RuntimeError {
            iteration,
            position: position as u64,
            symbol: sys
                .symbol_names
                .get(sym as usize)
                .cloned()
                .unwrap_or_default(),
            kind: RuntimeErrorKind::NonFinite { value },
            file: sys.file,
            span: sys.span,
        }
    }

    /// Settle the modules of `out` whose keys have edits (`matches`, in
    /// position order). Returns the ranges to remove (sorted, disjoint),
    /// when something is removed: the caller drops them ([`compact`]).
    pub(super) fn settle(
        &self,
        plan: &EditPlan,
        state: &mut EditState,
        out: &mut ModuleString,
        otags: &mut Vec<u32>,
        matches: &[Match],
        iteration: u32,
    ) -> Result<Option<Vec<std::ops::Range<usize>>>, DeriveError> {
        // The removed ranges, and the end of the furthest: each starts at
        // or before its match, so a later match is removed when it lies
        // before that end.
        let mut cut: Vec<std::ops::Range<usize>> = Vec::new();
        let mut reach = 0usize;
        let mut made = Vec::with_capacity(matches.len());
        // What a module of another symbol than its key's edits recorded
        // gets: no edits of its own (its parent's scope and tag, as any
        // module without edits).
        let no_edits = KeyEdits::default();
        for m in matches {
            let j = m.pos;
            if state.made.contains(&out.keys[j]) {
                // A copy of a module settled before (or a later module
                // with its key): edited once, when it was made.
                continue;
            }
            let sym = out.syms[j];
            let node = &plan.nodes[m.node as usize];
            let mine = node.symbol.is_none_or(|s| s == sym);
            let node = if mine {
                let hit = &mut state.hits[m.node as usize];
                if hit.0 == 0 {
                    hit.1 = sym;
                }
                hit.0 = hit.0.saturating_add(1);
                node
            } else {
                &no_edits
            };
            if j < reach {
                continue;
            }
            if mine {
                made.push(node.pin.map_or(out.keys[j], |(_, p)| p));
            }
            if node.remove.is_some() {
                let range = self.branch(&out.syms, j);
                reach = reach.max(range.end);
                cut.push(range);
                continue;
            }
            if let Some((_, p)) = node.pin {
                out.keys[j] = p;
            }
            let scope = if node.values.is_empty() {
                m.scope
            } else {
                state.table.compose(plan, m.scope, m.node)
            };
            if scope != 0 {
                let (a, b) = (out.starts[j] as usize, out.starts[j + 1] as usize);
                if let Err(v) = state.table.apply(scope, sym, &mut out.params[a..b]) {
                    return Err(DeriveError::Runtime(self.edit_error(iteration, j, sym, v)));
                }
            }
            let force = node.force.map_or(0, |f| f.1);
            let tag = state.table.tag(force, scope);
            if tag != 0 {
                if otags.is_empty() {
                    // The string's first tag: its buffer.
                    otags.resize(out.len(), 0);
                }
                otags[j] = tag;
            } else if !otags.is_empty() {
                otags[j] = 0;
            }
        }
        state.made.extend(made);
        if cut.is_empty() {
            return Ok(None);
        }
        cut.sort_unstable_by_key(|r| r.start);
        let mut merged: Vec<std::ops::Range<usize>> = Vec::with_capacity(cut.len());
        for r in cut {
            match merged.last_mut() {
                Some(last) if r.start <= last.end => last.end = last.end.max(r.end),
                _ => merged.push(r),
            }
        }
        Ok(Some(merged))
    }

    /// What removing module `j` of `syms` removes: the module, or for a
    /// `[` (`]`) the whole branch to its partner (itself alone when it has
    /// none).
    pub(super) fn branch(&self, syms: &[u32], j: usize) -> std::ops::Range<usize> {
        let kind = |p: usize| self.bracket.get(syms[p] as usize).copied().unwrap_or(0);
        match kind(j) {
            1 => {
                let mut depth = 0usize;
                for p in j..syms.len() {
                    match kind(p) {
                        1 => depth += 1,
                        2 => {
                            depth -= 1;
                            if depth == 0 {
                                return j..p + 1;
                            }
                        }
                        _ => {}
                    }
                }
                j..j + 1
            }
            2 => {
                let mut depth = 0usize;
                for p in (0..=j).rev() {
                    match kind(p) {
                        2 => depth += 1,
                        1 => {
                            depth -= 1;
                            if depth == 0 {
                                return p..j + 1;
                            }
                        }
                        _ => {}
                    }
                }
                j..j + 1
            }
            _ => j..j + 1,
        }
    }
}

/// How many modules `dead` (disjoint ranges) covers.
pub(super) fn dead_modules(dead: &[std::ops::Range<usize>]) -> usize {
    dead.iter().map(|r| r.len()).sum()
}

/// `pieces` (sorted, disjoint ranges) less the modules in `dead` (sorted,
/// disjoint): the live parts of each piece, in order.
pub(super) fn live_pieces(
    pieces: Vec<std::ops::Range<usize>>,
    dead: &[std::ops::Range<usize>],
) -> Vec<std::ops::Range<usize>> {
    let mut out = Vec::with_capacity(pieces.len() + dead.len());
    let mut d = 0usize;
    for r in pieces {
        while d < dead.len() && dead[d].end <= r.start {
            d += 1;
        }
        let mut a = r.start;
        let mut k = d;
        while k < dead.len() && dead[k].start < r.end {
            if dead[k].start > a {
                out.push(a..dead[k].start);
            }
            a = a.max(dead[k].end);
            k += 1;
        }
        if a < r.end {
            out.push(a..r.end);
        }
    }
    out
}

/// Drop the modules in `cut` (sorted, disjoint ranges) from `out` and its
/// tags, in place: each run of kept modules moved as one block.
pub(super) fn compact(out: &mut ModuleString, tags: &mut Vec<u32>, cut: &[std::ops::Range<usize>]) {
    let n = out.syms.len();
    let first = cut.first().map_or(n, |r| r.start);
    let (mut w, mut pw) = (first, out.starts[first] as usize);
    let kept = cut
        .iter()
        .zip(cut.iter().skip(1).map(|r| r.start).chain([n]))
        .map(|(r, next)| r.end..next);
    for std::ops::Range { start: j, end: k } in kept {
        if j >= k {
            continue;
        }
        let (s, e) = (out.starts[j] as usize, out.starts[k] as usize);
        let delta = (pw as u32).wrapping_sub(out.starts[j]);
        out.syms.copy_within(j..k, w);
        out.keys.copy_within(j..k, w);
        if !tags.is_empty() {
            tags.copy_within(j..k, w);
        }
        // Moved, then shifted in place (one pass the compiler vectorizes).
        out.starts.copy_within(j..k, w);
        for s in &mut out.starts[w..w + (k - j)] {
            *s = s.wrapping_add(delta);
        }
        out.params.copy_within(s..e, pw);
        pw += e - s;
        w += k - j;
    }
    out.syms.truncate(w);
    out.keys.truncate(w);
    tags.truncate(w);
    out.starts.truncate(w + 1);
    out.starts[w] = pw as u32;
    out.params.truncate(pw);
}

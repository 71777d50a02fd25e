//! One step over chunks: splitting the input, the count pass with its
//! limits, the exclusive scan and the parallel rewrite of the chunks.

use super::*;

impl<'a> Engine<'a> {
    /// One rewriting step: the string that follows `input` (which must be a
    /// string of this system) in iteration `iteration`.
    pub fn step(
        &self,
        input: &ModuleString,
        iteration: u32,
        seed: u32,
        limits: &DeriveLimits,
    ) -> Result<ModuleString, DeriveError> {
        let input = self.check_input(input)?;
        self.step_counted(&input, iteration, seed, limits, None, None)
    }

    /// The productions applied by step `iteration` to `input`: per input
    /// module, the global index of the alternative that rewrites it
    /// (into `CompiledSystem::alts`), or `None` where the module is copied
    /// unchanged. The same decisions [`Engine::step`] makes (a pure
    /// function of the input, seed and iteration), taken on one thread,
    /// for callers that build the derivation tree: module `i`'s successor
    /// is the next `succ_len` modules of the output (one for a copy).
    pub fn decisions(
        &self,
        input: &ModuleString,
        iteration: u32,
        seed: u32,
    ) -> Result<Vec<Option<u32>>, DeriveError> {
        let input = &*self.check_input(input)?;
        let n = input.len();
        let mate = self.mates(input, n, false);
        let step = self.step_of(input, &mate, iteration, seed);
        let mut worker = self.worker();
        let mut out = Vec::with_capacity(n);
        for i in 0..n {
            let (f, _, _) = self.counts[input.syms[i] as usize];
            out.push(match f {
                COPY => None,
                SLOW => self
                    .decide(&step, &mut worker, i)
                    .map_err(DeriveError::Runtime)?
                    .map(|(alt, _)| alt),
                alt => Some(alt),
            });
        }
        Ok(out)
    }

    /// The bracket partners of `input` (context-sensitive systems only;
    /// empty otherwise), in chunks of `chunk` modules.
    pub(crate) fn mates(&self, input: &ModuleString, chunk: usize, parallel: bool) -> Vec<u32> {
        if !self.has_context {
            return Vec::new();
        }
        let bracket = &self.bracket;
        let kind = |s: u32| bracket.get(s as usize).copied().unwrap_or(0);
        brackets::mates(kind, &input.syms, chunk, parallel)
    }

    /// What step `iteration` over `input` reads.
    pub(crate) fn step_of<'s>(
        &self,
        input: &'s ModuleString,
        mate: &'s [u32],
        iteration: u32,
        seed: u32,
    ) -> Step<'s> {
        Step {
            input,
            keys: if self.keyed { &input.keys } else { &[] },
            mate,
            seed,
            iteration,
        }
    }

    /// Check that `s` is a string of this system, in this engine's layout
    /// (implicit words or not): a string in the other layout is brought
    /// into it, which fails where a module's words differ from the
    /// constants that this engine leaves implicit.
    pub(crate) fn check_input<'s>(
        &self,
        s: &'s ModuleString,
    ) -> Result<Cow<'s, ModuleString>, DeriveError> {
        if !s.is_well_formed() {
            return Err(DeriveError::InvalidInput("offsets are inconsistent".into()));
        }
        if s.len() >= u32::MAX as usize {
            return Err(DeriveError::InvalidInput("too many modules".into()));
        }
        if self.keyed && !s.has_keys() {
            return Err(DeriveError::InvalidInput(
                "the string carries no identity keys, and this engine's draws are keyed by them"
                    .into(),
            ));
        }
        if s.implicit != self.implicit {
            return self.relayout(s).map(Cow::Owned);
        }
        if s.walks() {
            // Its widths are this engine's (the same table), and
            // `is_well_formed` checked them.
            return Ok(Cow::Borrowed(s));
        }
        for i in 0..s.len() {
            let sym = s.syms[i] as usize;
            let Some(&w) = self.sym_words.get(sym) else {
                return Err(DeriveError::InvalidInput(format!(
                    "module {i} has unknown symbol {sym}"
                )));
            };
            let stored = s.stored(i).len();
            if stored != w as usize {
                return Err(DeriveError::InvalidInput(format!(
                    "module {i} (`{}`) has {stored} parameter words, not {w}",
                    self.sys.symbol_names[sym],
                )));
            }
        }
        Ok(Cow::Borrowed(s))
    }

    /// Chunk ranges for an input of `n` modules.
    pub(crate) fn chunks(&self, n: usize) -> Vec<Range<usize>> {
        if self.threads == 1 || n <= self.min_chunk {
            return std::iter::once(0..n).collect();
        }
        // A few chunks per thread balance uneven successors; none shorter
        // than `min_chunk`, all of about the same length (a short last
        // chunk left one thread idle for a third of a step split 8192,
        // 8192 and 947).
        let k = (n / self.min_chunk).clamp(1, self.most_chunks());
        let len = n.div_ceil(k);
        (0..n.div_ceil(len))
            .map(|c| c * len..((c + 1) * len).min(n))
            .collect()
    }

    /// The most chunks a step is split into: a few per thread.
    pub(crate) fn most_chunks(&self) -> usize {
        let threads = match self.threads {
            0 => rayon::current_num_threads(),
            t => t,
        };
        threads * 4
    }

    pub(crate) fn in_pool<R: Send>(&self, f: impl FnOnce() -> R + Send) -> R {
        match &self.pool {
            Some(p) => p.install(f),
            None => f(),
        }
    }

    pub(crate) fn worker(&self) -> Worker {
        Worker {
            vm: Vm::new(),
            buf: vec![0.0; self.sys.max_bind_words as usize],
            weights: Vec::new(),
        }
    }

    /// One step; `hist`, when given, is the input's symbol histogram (see
    /// `succ_hist`) and is advanced to the output's.
    pub(super) fn step_counted(
        &self,
        input: &ModuleString,
        iteration: u32,
        seed: u32,
        limits: &DeriveLimits,
        hist: Option<&mut Vec<u64>>,
        carried: Option<&mut Carried>,
    ) -> Result<ModuleString, DeriveError> {
        let n = input.len();
        let mut chunks = self.chunks(n);
        let parallel = chunks.len() > 1;
        // Several chunks: their counts from carried histograms (no count
        // pass; `expand.rs`) where no symbol needs a decision.
        let mut from_chunks = None;
        if let Some(c) = carried {
            if !parallel {
                *c = Carried::default();
            } else if let Some((ch, counts)) = self.counts_carried(&input.syms, c) {
                chunks = ch;
                from_chunks = Some(counts);
            }
        }
        // Counts from the histogram (exact: no symbol needs a decision).
        let mut from_hist = None;
        if let (Some(h), Some(sh)) = (hist, &self.succ_hist) {
            let ((m, w, iw, _), next) = self.image(h, sh, true);
            *h = next;
            if !parallel {
                from_hist = Some((m, w, iw));
            }
        }
        let chunk = chunks.first().map_or(n, |c| c.len());
        let mate = if self.has_context {
            self.in_pool(|| self.mates(input, chunk, parallel))
        } else {
            Vec::new()
        };
        let step = self.step_of(input, &mate, iteration, seed);

        // 1. Count.
        let counts: Vec<Result<(u64, u64, u64, u64), RuntimeError>> =
            if let Some((m, w, iw)) = from_hist {
                vec![Ok((m, w, iw, 0))]
            } else if let Some(counts) = from_chunks {
                counts.into_iter().map(Ok).collect()
            } else if parallel {
                self.in_pool(|| {
                    chunks
                        .par_iter()
                        .map(|r| self.count_chunk(&step, r.clone()))
                        .collect()
                })
            } else {
                chunks
                    .iter()
                    .map(|r| self.count_chunk(&step, r.clone()))
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
            return Err(DeriveError::Runtime(e));
        }

        // 2. Scan, and the limits before allocating.
        let mut offsets = Vec::with_capacity(totals.len());
        let (mut m, mut w, mut iw, mut wi) = (0u64, 0u64, 0u64, 0u64);
        for (&(cm, cw, ciw, cwi), r) in totals.iter().zip(&chunks) {
            // Where the chunk's input words begin: a walked input's from
            // the counts (one chunk: at 0), another's from its starts.
            let word_in = if input.walks() {
                wi
            } else {
                input.start(r.start) as u64
            };
            offsets.push((m, w, word_in as usize));
            m += cm;
            w += cw;
            iw += ciw;
            wi += cwi;
        }
        self.check_limits(input, &mate, iteration, m, w, limits)?;
        let (m, w) = (m as usize, w as usize);

        // 3. Rewrite into disjoint slices.
        let mut out = self.take(m, w);
        out.implicit_words = iw as usize;
        {
            let mut parts = Vec::with_capacity(chunks.len());
            let with_starts = !out.starts.is_empty();
            let (mut syms, mut starts, mut params, mut keys) = out.parts_mut(m);
            for ((r, &(cm, cw, _, _)), &(_, word_base, word_in)) in
                chunks.iter().zip(&totals).zip(&offsets)
            {
                let (s, rest) = syms.split_at_mut(cm as usize);
                syms = rest;
                let (k, rest) = keys.split_at_mut(if self.keyed { cm as usize } else { 0 });
                keys = rest;
                let (st, rest) = starts.split_at_mut(if with_starts { cm as usize } else { 0 });
                starts = rest;
                let (p, rest) = params.split_at_mut(cw as usize);
                params = rest;
                parts.push(ChunkOut {
                    range: r.clone(),
                    syms: s,
                    keys: k,
                    starts: st,
                    params: p,
                    word_base: word_base as u32,
                    word_in,
                });
            }
            let work = |out: ChunkOut<'_>| {
                if self.keyed {
                    self.rewrite_chunk_best::<true, ()>(&step, out, &mut ())
                } else {
                    self.rewrite_chunk_best::<false, ()>(&step, out, &mut ())
                }
            };
            let results: Vec<Result<(), RuntimeError>> = if parallel {
                self.in_pool(|| parts.into_par_iter().map(work).collect())
            } else {
                parts.into_iter().map(work).collect()
            };
            let mut first_err = None;
            for r in results {
                if let Err(e) = r {
                    keep_first(&mut first_err, e);
                }
            }
            if let Some(e) = first_err {
                return Err(DeriveError::Runtime(e));
            }
        }
        if let Some(last) = out.starts.get_mut(m) {
            *last = w as u32;
        }
        Ok(out)
    }

    /// The implicit words a module of symbol `s` leaves behind when the
    /// fast path rewrites or copies it (`counts`).
    #[inline]
    pub(crate) fn implicit_words_of(&self, s: usize) -> u32 {
        match self.counts[s].0 {
            COPY => self.implicit_sym[s],
            SLOW => 0,
            alt => self.implicit_alt[alt as usize],
        }
    }

    pub(crate) fn check_limits(
        &self,
        input: &ModuleString,
        mate: &[u32],
        iteration: u32,
        m: u64,
        w: u64,
        limits: &DeriveLimits,
    ) -> Result<(), DeriveError> {
        let in_bytes = input.heap_bytes() as u64 + 4 * mate.len() as u64;
        self.check_limits_bytes(in_bytes, iteration, m, w, limits)
    }

    /// [`Engine::check_limits`] of an iteration whose input (string and
    /// bracket table) holds `in_bytes`.
    pub(crate) fn check_limits_bytes(
        &self,
        in_bytes: u64,
        iteration: u32,
        m: u64,
        w: u64,
        limits: &DeriveLimits,
    ) -> Result<(), DeriveError> {
        let (file, span) = (self.sys.file, self.sys.span);
        if m > limits.max_modules {
            return Err(DeriveError::ModuleLimit {
                iteration,
                modules: m,
                limit: limits.max_modules,
                file,
                span,
            });
        }
        if m >= u64::from(u32::MAX) || w >= u64::from(u32::MAX) {
            return Err(DeriveError::TooLarge {
                iteration,
                modules: m,
                words: w,
                file,
                span,
            });
        }
        let key_bytes = if self.keyed { 4 * m } else { 0 };
        let out_bytes = 4 * m + 4 * (m + 1) + 4 * w + key_bytes;
        let bytes = in_bytes + out_bytes;
        if bytes > limits.max_bytes {
            return Err(DeriveError::MemoryLimit {
                iteration,
                bytes,
                limit: limits.max_bytes,
                modules: m,
                words: w,
                file,
                span,
            });
        }
        Ok(())
    }

    pub(crate) fn count_chunk(
        &self,
        step: &Step<'_>,
        range: Range<usize>,
    ) -> Result<(u64, u64, u64, u64), RuntimeError> {
        let syms = &step.input.syms[range.clone()];
        let (mut m, mut w, mut iw, mut wi) = (0u64, 0u64, 0u64, 0u64);
        let mut worker: Option<Worker> = None;
        let compact = self.compact();
        // A walked input's words of the chunk (where the next chunk's
        // begin).
        let walks = step.input.walks();
        for (k, &sym) in syms.iter().enumerate() {
            let s = sym as usize;
            if walks {
                wi += u64::from(self.sym_words[s]);
            }
            let (f, len, words) = self.counts[s];
            if f != SLOW {
                m += u64::from(len);
                w += u64::from(words);
                if compact {
                    iw += u64::from(self.implicit_words_of(s));
                }
                continue;
            }
            let wk = worker.get_or_insert_with(|| self.worker());
            match self.decide(step, wk, range.start + k)? {
                Some((alt, _)) => {
                    let plan = &self.plans[alt as usize];
                    m += u64::from(plan.len);
                    w += u64::from(plan.words);
                    iw += u64::from(self.implicit_alt[alt as usize]);
                }
                None => {
                    m += 1;
                    w += u64::from(self.sym_words[s]);
                    iw += u64::from(self.implicit_sym[s]);
                }
            }
        }
        Ok((m, w, iw, wi))
    }
}

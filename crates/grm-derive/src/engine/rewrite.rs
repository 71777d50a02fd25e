//! The rewrite of one chunk, module by module: the decision (groups,
//! contexts, conditions, the draw), the successors' emission (templates,
//! symbol runs, short arithmetic, the VM) and its runtime errors.

use super::*;

impl<'a> Engine<'a> {
    /// [`Engine::rewrite_chunk`] compiled for AVX2 where the CPU has it
    /// (its fixed-size moves in 32-byte registers), else for the baseline.
    /// The same f32 operations either way (Rust never fuses a multiply
    /// and an add), so the same bits.
    pub(crate) fn rewrite_chunk_best<const K: bool, R: Replay>(
        &self,
        step: &Step<'_>,
        out: ChunkOut<'_>,
        replay: &mut R,
    ) -> Result<(), RuntimeError> {
        #[cfg(target_arch = "x86_64")]
        if crate::cpu::avx2() {
            // SAFETY: the CPU has AVX2 (checked just above), the only
            // feature `rewrite_chunk_avx2` is compiled for beyond the
            // baseline.
            #[allow(unsafe_code)]
            return unsafe { self.rewrite_chunk_avx2::<K, R>(step, out, replay) };
        }
        self.rewrite_chunk::<K, R>(step, out, replay)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    pub(super) fn rewrite_chunk_avx2<const K: bool, R: Replay>(
        &self,
        step: &Step<'_>,
        out: ChunkOut<'_>,
        replay: &mut R,
    ) -> Result<(), RuntimeError> {
        self.rewrite_chunk::<K, R>(step, out, replay)
    }

    /// Rewrite one chunk; `K`: the engine is keyed (write every output
    /// module's identity key: a copied module keeps its key, a successor
    /// module gets `child_key(parent key, salt)`). `replay`: the edits'
    /// hooks (`()`: none, the plain loop; see [`Replay`]).
    #[inline(always)]
    pub(super) fn rewrite_chunk<const K: bool, R: Replay>(
        &self,
        step: &Step<'_>,
        out: ChunkOut<'_>,
        replay: &mut R,
    ) -> Result<(), RuntimeError> {
        let ChunkOut {
            range,
            syms: osyms,
            keys: okeys,
            starts: ostarts,
            params: oparams,
            word_base,
            word_in,
        } = out;
        let input = step.input;
        let mut worker = self.worker();
        let (mut o, mut wo) = (0usize, 0usize);
        // The input's words are walked with the modules: every module has
        // its symbol's word count (`check_input`, and the engine's own
        // strings), so `starts` is not read.
        let mut wi = word_in;
        // The tables, hoisted out of the loop (the compiler reloads fields
        // behind `self` after every store otherwise).
        let (acts, plans, sym_words) = (&self.acts[..], &self.plans[..], &self.sym_words[..]);
        let (ariths, tpls, fans) = (&self.ariths[..], &self.tpl[..], &self.fans[..]);
        let (ikeys, salts) = (step.keys, &self.succ_salts[..]);
        /// `ksucc`: the module was copied (keeps its key).
        const KCOPY: u32 = u32::MAX;
        // Where the next successor goes: the chunk's slices, reborrowed.
        macro_rules! out_at {
            ($o:expr, $wo:expr) => {
                Out {
                    syms: &mut *osyms,
                    starts: &mut *ostarts,
                    params: &mut *oparams,
                    word_base,
                    o: $o,
                    wo: $wo,
                }
            };
        }
        let (isyms, istarts, iparams) = (&input.syms[..], &input.starts[..], &input.params[..]);
        // The input stores no word (no starts) or walks them, the output
        // stores none or walks them.
        let (ino, ono) = (istarts.is_empty(), ostarts.is_empty());
        let iwalk = ino && !iparams.is_empty();
        let copies = &self.copies[..];
        let end = range.end;
        let mut i = range.start;
        while i < end {
            let sym = isyms[i];
            let s = sym as usize;
            if copies[s] {
                // A run of copied modules, moved whole: one branch per run
                // instead of a dispatch per module (Hilbert 3D's `F` and
                // turns between its rewritten symbols).
                let mut j = i + 1;
                let wj = if iwalk {
                    // Walked words: the widths added up while the run is
                    // found (one pass over it).
                    let mut wj = wi + sym_words[s] as usize;
                    while j < end {
                        let t = isyms[j] as usize;
                        if !copies[t] {
                            break;
                        }
                        wj += sym_words[t] as usize;
                        j += 1;
                    }
                    wj
                } else {
                    while j < end && copies[isyms[j] as usize] {
                        j += 1;
                    }
                    if ino { wi } else { istarts[j] as usize }
                };
                let len = j - i;
                let words = wj - wi;
                if len == 1 {
                    // One module (a turn between two rewritten `F`s):
                    // three stores, not three block moves.
                    osyms[o] = sym;
                    if !ono {
                        ostarts[o] = word_base + wo as u32;
                    }
                    if words == 1 {
                        oparams[wo] = iparams[wi];
                    } else {
                        copy_small(&mut oparams[wo..wo + words], &iparams[wi..wj]);
                    }
                    if K {
                        okeys[o] = ikeys[i];
                        replay.copied(i..j, o);
                    }
                    o += 1;
                    wo += words;
                    wi = wj;
                    i = j;
                    continue;
                }
                if ono {
                    // Symbols only.
                    if len <= PAD && i + PAD <= isyms.len() && o + PAD <= osyms.len() {
                        osyms[o..o + PAD].copy_from_slice(&isyms[i..i + PAD]);
                    } else {
                        copy_small(&mut osyms[o..o + len], &isyms[i..j]);
                    }
                } else if ino {
                    // No input word: every start is the output's position;
                    // walked input words: the widths added up.
                    copy_small(&mut osyms[o..o + len], &isyms[i..j]);
                    if iwalk {
                        let mut at = word_base + wo as u32;
                        for (d, &t) in ostarts[o..o + len].iter_mut().zip(&isyms[i..j]) {
                            *d = at;
                            at += sym_words[t as usize];
                        }
                    } else {
                        ostarts[o..o + len].fill(word_base + wo as u32);
                    }
                } else {
                    // The input's starts shifted to the output's words.
                    let delta = (word_base + wo as u32).wrapping_sub(istarts[i]);
                    if len <= PAD && i + PAD <= isyms.len() && o + PAD <= osyms.len() {
                        // Fixed-size moves (see `PAD`; the chunk's `starts`
                        // is as long as its `syms`, the input's one longer).
                        osyms[o..o + PAD].copy_from_slice(&isyms[i..i + PAD]);
                        for (d, &st) in ostarts[o..o + PAD].iter_mut().zip(&istarts[i..i + PAD]) {
                            *d = st.wrapping_add(delta);
                        }
                    } else {
                        copy_small(&mut osyms[o..o + len], &isyms[i..j]);
                        for (d, &st) in ostarts[o..o + len].iter_mut().zip(&istarts[i..j]) {
                            *d = st.wrapping_add(delta);
                        }
                    }
                }
                if words > 0 {
                    if words <= PAD && wi + PAD <= iparams.len() && wo + PAD <= oparams.len() {
                        oparams[wo..wo + PAD].copy_from_slice(&iparams[wi..wi + PAD]);
                    } else {
                        copy_small(&mut oparams[wo..wo + words], &iparams[wi..wj]);
                    }
                }
                if K {
                    copy_small(&mut okeys[o..o + len], &ikeys[i..j]);
                    replay.copied(i..j, o);
                }
                o += len;
                wo += words;
                wi = wj;
                i = j;
                continue;
            }
            // Keyed: the output position of this module's successor and its
            // first successor module (or `KCOPY`).
            let o0 = o;
            let mut ksucc = KCOPY;
            // An edit's forced alternative: the general road (`()`: never).
            let forced = replay.force(i);
            match if forced != 0 { Act::Slow } else { acts[s] } {
                // Copies are moved as runs above; these two arms keep the
                // per-module form of the same writes.
                Act::Copy0 => {
                    osyms[o] = sym;
                    if !ono {
                        ostarts[o] = word_base + wo as u32;
                    }
                    o += 1;
                }
                Act::Copy(n) => {
                    let n = n as usize;
                    osyms[o] = sym;
                    if !ono {
                        ostarts[o] = word_base + wo as u32;
                    }
                    if n == 1 {
                        oparams[wo] = input.params[wi];
                    } else {
                        copy_small(&mut oparams[wo..wo + n], &input.params[wi..wi + n]);
                    }
                    o += 1;
                    wo += n;
                    wi += n;
                }
                Act::Unit(u) => {
                    let v = input.params[wi] * u.m + u.a;
                    if !v.is_finite() {
                        return Err(self.runtime(
                            step,
                            i,
                            RuntimeErrorKind::NonFinite { value: v },
                            self.sys.param_spans[u.span as usize],
                        ));
                    }
                    osyms[o] = u.sym;
                    if !ono {
                        ostarts[o] = word_base + wo as u32;
                    }
                    oparams[wo] = v;
                    o += 1;
                    wo += 1;
                    wi += 1;
                    ksucc = u.succ;
                }
                Act::Plan(alt) => {
                    let plan = plans[alt as usize];
                    let n = sym_words[s] as usize;
                    let mut out = out_at!(o, wo);
                    ksucc = plan.succ;
                    if plan.words == 0 {
                        // Symbols only (Koch curves, Hilbert curves).
                        self.emit_syms(plan, &mut out);
                    } else {
                        let bind = &input.params[wi..wi + n];
                        if plan.arith {
                            self.emit_arith(step, plan, bind, i, &mut out)?;
                        } else {
                            self.emit(step, &mut worker, alt, bind, i, &mut out)?;
                        }
                    }
                    o += plan.len as usize;
                    wo += plan.words as usize;
                    wi += n;
                }
                Act::Small(alt) => {
                    let plan = plans[alt as usize];
                    ksucc = plan.succ;
                    let n = sym_words[s] as usize;
                    let mut spare = [0.0f32; PAD];
                    let b: &[f32; PAD] = match input.params.get(wi..wi + PAD) {
                        // A slice of `PAD` words.
                        Some(w) => w.try_into().unwrap_or(&spare),
                        None => {
                            spare[..n].copy_from_slice(&input.params[wi..wi + n]);
                            &spare
                        }
                    };
                    let mut out = out_at!(o, wo);
                    self.emit_syms(plan, &mut out);
                    let words = plan.words as usize;
                    let ariths = &ariths[plan.patch_lo as usize..plan.patch_hi as usize];
                    let t = plan.tpl as usize;
                    // `tpl` is padded with `PAD` words.
                    let tpl: &[f32; PAD] = tpls[t..t + PAD].try_into().unwrap_or(&[0.0; PAD]);
                    // Bit 31 set where a value is not finite: its exponent
                    // is all ones, and one more carries into bit 31.
                    let mut bad = 0u32;
                    let room = oparams
                        .get_mut(wo..wo + PAD)
                        .and_then(|d| <&mut [f32; PAD]>::try_from(d).ok());
                    match room {
                        Some(d) => {
                            *d = *tpl;
                            for p in ariths {
                                // In range (`Act::Small`); the masks only
                                // spare the bounds checks.
                                let v = b[p.src as usize % PAD] * p.m + p.a;
                                bad |= (v.to_bits() & 0x7f80_0000) + 0x0080_0000;
                                d[p.dst as usize % PAD] = v;
                            }
                        }
                        None => {
                            let d = &mut oparams[wo..wo + words];
                            d.copy_from_slice(&tpl[..words]);
                            for p in ariths {
                                let v = b[p.src as usize % PAD] * p.m + p.a;
                                bad |= (v.to_bits() & 0x7f80_0000) + 0x0080_0000;
                                d[p.dst as usize] = v;
                            }
                        }
                    }
                    if bad & 0x8000_0000 != 0 {
                        let patches = &self.patches[plan.patch_lo as usize..plan.patch_hi as usize];
                        return Err(self.non_finite(step, i, &oparams[wo..wo + words], patches));
                    }
                    o += plan.len as usize;
                    wo += words;
                    wi += n;
                }
                Act::Fan(f) => {
                    let fan = &fans[f as usize];
                    let plan = fan.plan;
                    ksucc = plan.succ;
                    let (v, bad) = fan.apply(iparams[wi + fan.src as usize]);
                    let mut out = out_at!(o, wo);
                    self.emit_syms(plan, &mut out);
                    let words = plan.words as usize;
                    match oparams.get_mut(wo..wo + PAD) {
                        Some(d) => d.copy_from_slice(&v),
                        None => oparams[wo..wo + words].copy_from_slice(&v[..words]),
                    }
                    if bad {
                        let patches = &self.patches[plan.patch_lo as usize..plan.patch_hi as usize];
                        return Err(self.non_finite(step, i, &oparams[wo..wo + words], patches));
                    }
                    o += plan.len as usize;
                    wo += words;
                    wi += sym_words[s] as usize;
                }
                Act::Slow => {
                    let n = sym_words[s] as usize;
                    let decided = if forced != 0 {
                        self.decide_in::<true>(step, &mut worker, i, forced)?
                    } else {
                        self.decide(step, &mut worker, i)?
                    };
                    match decided {
                        None => {
                            osyms[o] = sym;
                            if !ono {
                                ostarts[o] = word_base + wo as u32;
                            }
                            copy_small(&mut oparams[wo..wo + n], &input.params[wi..wi + n]);
                            o += 1;
                            wo += n;
                        }
                        Some((alt, binds)) => {
                            let mut out = out_at!(o, wo);
                            if binds == Binds::Buffer {
                                // The bindings live in the worker; move the
                                // buffer out for the call (no allocation: a
                                // swap).
                                let buf = std::mem::take(&mut worker.buf);
                                let r = self.emit(step, &mut worker, alt, &buf, i, &mut out);
                                worker.buf = buf;
                                r?;
                            } else {
                                let bind = &input.params[wi..wi + n];
                                self.emit(step, &mut worker, alt, bind, i, &mut out)?;
                            }
                            let plan = plans[alt as usize];
                            o += plan.len as usize;
                            wo += plan.words as usize;
                            ksucc = plan.succ;
                        }
                    }
                    wi += n;
                }
            }
            if K {
                let key = ikeys[i];
                if ksucc == KCOPY {
                    okeys[o0] = key;
                    replay.copied(i..i + 1, o0);
                } else {
                    let salts = &salts[ksucc as usize..][..o - o0];
                    for (k, &salt) in okeys[o0..o].iter_mut().zip(salts) {
                        *k = rng::child_key_premixed(key, salt);
                    }
                    let made = Made {
                        succ: ksucc,
                        keys: &okeys[o0..o],
                        syms: &osyms[o0..o],
                        starts: if ono { &[] } else { &ostarts[o0..o] },
                        word_base,
                    };
                    replay.made(i, o0, made, oparams)?;
                }
            }
            i += 1;
        }
        Ok(())
    }

    /// Write alternative `plan`'s symbols, starts and constant words at
    /// `out.o` / `out.wo` (the patches are the caller's).
    #[inline(always)]
    pub(super) fn emit_template(&self, plan: Plan, out: &mut Out<'_>) {
        self.emit_syms(plan, out);
        let (t, words, wo) = (plan.tpl as usize, plan.words as usize, out.wo);
        if words == 0 {
            return;
        }
        if words <= PAD && wo + PAD <= out.params.len() {
            out.params[wo..wo + PAD].copy_from_slice(&self.tpl[t..t + PAD]);
        } else if words <= 2 * PAD && wo + 2 * PAD <= out.params.len() {
            // The same in `2 * PAD` (the Koch island's 15 words, the
            // bracketed plant's 12).
            out.params[wo..wo + 2 * PAD].copy_from_slice(&self.tpl[t..t + 2 * PAD]);
        } else {
            copy_small(&mut out.params[wo..wo + words], &self.tpl[t..t + words]);
        }
    }

    /// Write alternative `plan`'s symbols and starts at `out.o`.
    #[inline(always)]
    pub(super) fn emit_syms(&self, plan: Plan, out: &mut Out<'_>) {
        let (so, len) = (plan.succ as usize, plan.len as usize);
        let (o, wo) = (out.o, out.wo);
        let base = out.word_base + wo as u32;
        if out.starts.is_empty() {
            // The output stores no word: symbols only.
            if len <= PAD && o + PAD <= out.syms.len() {
                out.syms[o..o + PAD].copy_from_slice(&self.succ_syms[so..so + PAD]);
            } else if len <= 2 * PAD && o + 2 * PAD <= out.syms.len() {
                out.syms[o..o + 2 * PAD].copy_from_slice(&self.succ_syms[so..so + 2 * PAD]);
            } else {
                copy_small(&mut out.syms[o..o + len], &self.succ_syms[so..so + len]);
            }
            return;
        }
        if len <= PAD && o + PAD <= out.syms.len() {
            // Fixed-size moves (see `PAD`); `starts` has the same length.
            out.syms[o..o + PAD].copy_from_slice(&self.succ_syms[so..so + PAD]);
            let offs = &self.succ_words[so..so + PAD];
            for (st, off) in out.starts[o..o + PAD].iter_mut().zip(offs) {
                *st = base + off;
            }
        } else if len <= 2 * PAD && o + 2 * PAD <= out.syms.len() {
            // The same in `2 * PAD` (Koch curves, bracketed plants).
            out.syms[o..o + 2 * PAD].copy_from_slice(&self.succ_syms[so..so + 2 * PAD]);
            let starts = &mut out.starts[o..o + 2 * PAD];
            if plan.words == 0 {
                starts.fill(base);
            } else {
                for (st, off) in starts.iter_mut().zip(&self.succ_words[so..so + 2 * PAD]) {
                    *st = base + off;
                }
            }
        } else {
            copy_small(&mut out.syms[o..o + len], &self.succ_syms[so..so + len]);
            let starts = &mut out.starts[o..o + len];
            if plan.words == 0 {
                starts.fill(base);
            } else {
                for (st, off) in starts.iter_mut().zip(&self.succ_words[so..so + len]) {
                    *st = base + off;
                }
            }
        }
    }

    /// [`Engine::emit`] for a plan whose patches are all [`Patch::Arith`]:
    /// no dispatch per patch, one test for non-finite values.
    #[inline(always)]
    pub(super) fn emit_arith(
        &self,
        step: &Step<'_>,
        plan: Plan,
        bind: &[f32],
        position: usize,
        out: &mut Out<'_>,
    ) -> Result<(), RuntimeError> {
        self.emit_template(plan, out);
        let patches = &self.patches[plan.patch_lo as usize..plan.patch_hi as usize];
        let params = &mut out.params[out.wo..out.wo + plan.words as usize];
        let mut finite = true;
        for p in patches {
            if let Patch::Arith { dst, src, m, a, .. } = *p {
                let v = bind[src as usize] * m + a;
                finite &= v.is_finite();
                params[dst as usize] = v;
            }
        }
        if finite {
            return Ok(());
        }
        Err(self.non_finite(step, position, params, patches))
    }

    /// The error for the first of `patches` (arithmetic, in the
    /// successor's order, as `emit` reports it) whose word in `params` is
    /// not finite.
    #[cold]
    pub(super) fn non_finite(
        &self,
        step: &Step<'_>,
        position: usize,
        params: &[f32],
        patches: &[Patch],
    ) -> RuntimeError {
        let bad = patches.iter().find_map(|p| match *p {
            Patch::Arith { dst, span, .. } => params
                .get(dst as usize)
                .filter(|v| !v.is_finite())
                .map(|&v| (v, span)),
            _ => None,
        });
        // Unreachable: the callers found a non-finite patched word. The
        // fallback still names the module.
        let (value, span) = bad.unwrap_or((f32::NAN, 0));
        self.runtime(
            step,
            position,
            RuntimeErrorKind::NonFinite { value },
            self.sys
                .param_spans
                .get(span as usize)
                .copied()
                .unwrap_or_default(),
        )
    }

    /// Write alternative `alt`'s successor for the module at `position`.
    #[inline(always)]
    pub(crate) fn emit(
        &self,
        step: &Step<'_>,
        worker: &mut Worker,
        alt: u32,
        bind: &[f32],
        position: usize,
        out: &mut Out<'_>,
    ) -> Result<(), RuntimeError> {
        let sys = self.sys;
        let plan = self.plans[alt as usize];
        self.emit_template(plan, out);
        if plan.patch_lo == plan.patch_hi {
            return Ok(());
        }
        let params = &mut out.params[out.wo..out.wo + plan.words as usize];
        for p in &self.patches[plan.patch_lo as usize..plan.patch_hi as usize] {
            let (dst, value, span) = match *p {
                Patch::Copy { dst, src, words } => {
                    let (d, s, w) = (dst as usize, src as usize, words as usize);
                    params[d..d + w].copy_from_slice(&bind[s..s + w]);
                    continue;
                }
                Patch::Arith {
                    dst,
                    src,
                    m,
                    a,
                    span,
                } => (dst, bind[src as usize] * m + a, span),
                Patch::Code {
                    dst,
                    entry,
                    words,
                    span,
                } => {
                    let draws = step.draws(position);
                    let v = worker
                        .vm
                        .run(&sys.code, &sys.consts, entry, bind, &draws)
                        .map_err(|e| self.fault(step, position, e))?;
                    let d = dst as usize;
                    for (o, &x) in params[d..d + words as usize].iter_mut().zip(v) {
                        if !x.is_finite() {
                            return Err(self.runtime(
                                step,
                                position,
                                RuntimeErrorKind::NonFinite { value: x },
                                sys.param_spans[span as usize],
                            ));
                        }
                        *o = x;
                    }
                    continue;
                }
            };
            if !value.is_finite() {
                return Err(self.runtime(
                    step,
                    position,
                    RuntimeErrorKind::NonFinite { value },
                    sys.param_spans[span as usize],
                ));
            }
            params[dst as usize] = value;
        }
        Ok(())
    }

    pub(crate) fn runtime(
        &self,
        step: &Step<'_>,
        position: usize,
        kind: RuntimeErrorKind,
        span: grm_diag::Span,
    ) -> RuntimeError {
        let symbol = step
            .input
            .syms
            .get(position)
            .and_then(|&s| self.sys.symbol_names.get(s as usize))
            .cloned()
            .unwrap_or_else(|| "axiom".to_string());
        RuntimeError {
            iteration: step.iteration,
            position: position as u64,
            symbol,
            kind,
            file: self.sys.file,
            span,
        }
    }

    pub(super) fn fault(
        &self,
        step: &Step<'_>,
        position: usize,
        e: grm_compile::vm::VmError,
    ) -> RuntimeError {
        let span = self.sys.span_at(e.pc).unwrap_or(self.sys.span);
        self.runtime(step, position, RuntimeErrorKind::Fault(e), span)
    }

    /// Decide the production for the module at `i`: the alternative and
    /// where its bindings are, or `None` to copy the module.
    pub(crate) fn decide(
        &self,
        step: &Step<'_>,
        worker: &mut Worker,
        i: usize,
    ) -> Result<Option<(u32, Binds)>, RuntimeError> {
        self.decide_in::<false>(step, worker, i, 0)
    }

    /// [`Engine::decide`]; `F`: a persistent edit forces alternative
    /// `force` (from 1) of the group that applies, when it has that many
    /// (else the group races as written).
    #[inline(always)]
    pub(crate) fn decide_in<const F: bool>(
        &self,
        step: &Step<'_>,
        worker: &mut Worker,
        i: usize,
        force: u32,
    ) -> Result<Option<(u32, Binds)>, RuntimeError> {
        let sys = self.sys;
        let input = step.input;
        let sym = input.syms[i];
        let std::ops::Range { start: ps, end: pe } = input.stored(i);
        let draws = step.draws(i);
        for g in sys.groups_of(sym) {
            let direct = g.pred_bind_offset == 0 && g.bind_words == g.pred_bind_words;
            if g.flags & GROUP_CONTEXT != 0 {
                let left = &sys.context[g.left_offset as usize..][..g.left_len as usize];
                let right = &sys.context[g.right_offset as usize..][..g.right_len as usize];
                if !self.match_left(step, &mut worker.buf, i, left)
                    || !self.match_right(step, &mut worker.buf, i, right)
                {
                    continue;
                }
            }
            if !direct && g.pred_bind_words > 0 {
                let o = g.pred_bind_offset as usize;
                worker.buf[o..o + (pe - ps)].copy_from_slice(&input.params[ps..pe]);
            }
            let bind: &[f32] = if direct {
                &input.params[ps..pe]
            } else {
                &worker.buf[..g.bind_words as usize]
            };
            if g.cond_code != NONE {
                let c = worker
                    .vm
                    .run1(&sys.code, &sys.consts, g.cond_code, bind, &draws)
                    .map_err(|e| self.fault(step, i, e))?;
                if c == 0.0 {
                    continue;
                }
            }
            let binds = if direct { Binds::Direct } else { Binds::Buffer };
            if F && force >= 1 && force <= g.alt_count {
                return Ok(Some((g.first_alt + force - 1, binds)));
            }
            if g.alt_count == 1 {
                return Ok(Some((g.first_alt, binds)));
            }
            let alt = select::choose_alternative(
                sys,
                g,
                &mut worker.vm,
                bind,
                &draws,
                &mut worker.weights,
            )
            .map_err(|e| match e {
                AltError::Fault(e) => self.fault(step, i, e),
                AltError::BadWeight { value, alt } => self.runtime(
                    step,
                    i,
                    RuntimeErrorKind::BadWeight { value },
                    sys.weight_spans[alt as usize],
                ),
            })?;
            return Ok(Some((alt, binds)));
        }
        Ok(None)
    }

    /// Bind a matched context module's parameters.
    pub(super) fn bind(&self, step: &Step<'_>, buf: &mut [f32], pos: usize, item: &ContextItem) {
        if item.bind_words > 0 {
            let input = step.input;
            let std::ops::Range { start: s, end: e } = input.stored(pos);
            let o = item.bind_offset as usize;
            buf[o..o + (e - s)].copy_from_slice(&input.params[s..e]);
        }
    }

    /// Left context: the nearest modules on the path towards the root,
    /// stepping over complete branches `[ ... ]` (and out of the enclosing
    /// `[`), skipping ignored symbols. Items are matched nearest first.
    pub(super) fn match_left(
        &self,
        step: &Step<'_>,
        buf: &mut [f32],
        i: usize,
        items: &[ContextItem],
    ) -> bool {
        let syms = &step.input.syms;
        let mut pos = i;
        for item in items.iter().rev() {
            // Find the next candidate before `pos`.
            loop {
                if pos == 0 {
                    return false;
                }
                pos -= 1;
                let s = syms[pos] as usize;
                match self.bracket[s] {
                    2 => {
                        let m = step.mate[pos];
                        if m == UNMATCHED {
                            return false;
                        }
                        // Continue before the branch's `[`.
                        pos = m as usize;
                    }
                    1 => {} // leave the enclosing branch: its parent is before it
                    _ if self.ignored[s] => {}
                    _ => break,
                }
            }
            if item.kind != CTX_SYMBOL || syms[pos] != item.symbol {
                return false;
            }
            self.bind(step, buf, pos, item);
        }
        true
    }

    /// Right context: the next modules forward in the current branch,
    /// stepping over lateral branches `[ ... ]` unless the context itself
    /// has `[` there, skipping ignored symbols; the branch ending (`]` or the
    /// end of the string) fails the match.
    pub(super) fn match_right(
        &self,
        step: &Step<'_>,
        buf: &mut [f32],
        i: usize,
        items: &[ContextItem],
    ) -> bool {
        let syms = &step.input.syms;
        let n = syms.len();
        let mut pos = i + 1;
        for item in items {
            match item.kind {
                CTX_SYMBOL => {
                    loop {
                        if pos >= n {
                            return false;
                        }
                        let s = syms[pos] as usize;
                        match self.bracket[s] {
                            1 => {
                                let m = step.mate[pos];
                                if m == UNMATCHED {
                                    return false;
                                }
                                pos = m as usize + 1;
                            }
                            2 => return false,
                            _ if self.ignored[s] => pos += 1,
                            _ => break,
                        }
                    }
                    if syms[pos] != item.symbol {
                        return false;
                    }
                    self.bind(step, buf, pos, item);
                    pos += 1;
                }
                CTX_PUSH => {
                    // Enter the next lateral branch (ignored symbols may
                    // come before it).
                    loop {
                        if pos >= n {
                            return false;
                        }
                        let s = syms[pos] as usize;
                        if self.bracket[s] == 1 {
                            pos += 1;
                            break;
                        }
                        if self.bracket[s] == 0 && self.ignored[s] {
                            pos += 1;
                            continue;
                        }
                        return false;
                    }
                }
                _ => {
                    // `]`: the rest of the current branch is skipped, up to
                    // and including its `]`.
                    loop {
                        if pos >= n {
                            return false;
                        }
                        match self.bracket[syms[pos] as usize] {
                            2 => {
                                pos += 1;
                                break;
                            }
                            1 => {
                                let m = step.mate[pos];
                                if m == UNMATCHED {
                                    return false;
                                }
                                pos = m as usize + 1;
                            }
                            _ => pos += 1,
                        }
                    }
                }
            }
        }
        true
    }
}

//! Building an [`Engine`]: each symbol's action, each production's plan
//! (its template, its parameter patches, its short arithmetic), the pool.

use super::*;

impl<'a> Engine<'a> {
    /// [`Engine::new`]; `compact`: strings leave implicit words unstored
    /// ([`Implicit`]).
    pub(crate) fn build(
        sys: &'a CompiledSystem,
        threads: usize,
        compact: bool,
    ) -> Result<Engine<'a>, DeriveError> {
        if threads > MAX_THREADS {
            return Err(DeriveError::TooManyThreads {
                threads,
                max: MAX_THREADS,
            });
        }
        sys.validate()
            .map_err(|e| DeriveError::InvalidTables(e.0))?;
        let n = sys.symbols.len();
        let implicit = if compact {
            crate::compact::implicit_words(sys)
        } else {
            None
        };
        // Per symbol, the words its modules store.
        let stored = |s: u32| -> u32 {
            let w = sys.symbols.get(s as usize).map_or(0, |e| e.param_words);
            match &implicit {
                Some(t) if t.width(s) > 0 => 0,
                _ => w,
            }
        };
        let implicit_sym: Vec<u32> = (0..n as u32)
            .map(|s| implicit.as_ref().map_or(0, |t| t.width(s) as u32))
            .collect();
        // Per alternative, the words its successor stores and the implicit
        // ones.
        let alt_words: Vec<(u32, u32)> = sys
            .alts
            .iter()
            .map(|a| {
                sys.successor(a).iter().fold((0, 0), |(w, i), m| {
                    (w + stored(m.symbol), i + implicit_sym[m.symbol as usize])
                })
            })
            .collect();
        let mut fast = vec![COPY; n];
        let mut fast_len = vec![1; n];
        let mut fast_words = vec![0; n];
        let mut bracket = vec![0u8; n];
        let mut ignored = vec![false; n];
        let mut sym_words = vec![0; n];
        for (i, s) in sys.symbols.iter().enumerate() {
            sym_words[i] = stored(i as u32);
            fast_words[i] = stored(i as u32);
            ignored[i] = s.flags & SYM_IGNORED != 0;
            if s.flags & SYM_PUSH != 0 {
                bracket[i] = 1;
            } else if s.flags & SYM_POP != 0 {
                bracket[i] = 2;
            }
            let groups = sys.groups_of(i as u32);
            if groups.is_empty() {
                continue;
            }
            let g = &groups[0];
            let simple = groups.len() == 1
                && g.flags & GROUP_CONTEXT == 0
                && g.cond_code == NONE
                && g.alt_count == 1
                && g.pred_bind_offset == 0
                && g.bind_words == g.pred_bind_words;
            if simple {
                let alt = &sys.alts[g.first_alt as usize];
                fast[i] = g.first_alt;
                fast_len[i] = alt.succ_len;
                fast_words[i] = alt_words[g.first_alt as usize].0;
            } else {
                fast[i] = SLOW;
            }
        }
        let counts = (0..n)
            .map(|i| (fast[i], fast_len[i], fast_words[i]))
            .collect();
        let succ_hist = fast.iter().all(|&f| f != SLOW).then(|| {
            (0..n)
                .map(|i| {
                    let mut h: Vec<(u32, u64)> = Vec::new();
                    let syms: Vec<u32> = if fast[i] == COPY {
                        vec![i as u32]
                    } else {
                        let a = &sys.alts[fast[i] as usize];
                        sys.successor(a).iter().map(|m| m.symbol).collect()
                    };
                    for t in syms {
                        match h.iter_mut().find(|(x, _)| *x == t) {
                            Some((_, c)) => *c += 1,
                            None => h.push((t, 1)),
                        }
                    }
                    h
                })
                .collect()
        });
        let succ_syms: Vec<u32> = sys.succ.iter().map(|m| m.symbol).collect();
        let succ_salts: Vec<u32> = sys.succ.iter().map(|m| rng::premix(m.salt)).collect();
        // Each successor module's offset among the words its successor
        // stores.
        let mut succ_words: Vec<u32> = sys.succ.iter().map(|m| m.word_offset).collect();
        for a in &sys.alts {
            let mut off = 0;
            let o = a.succ_offset as usize;
            for (k, m) in sys.successor(a).iter().enumerate() {
                if let Some(x) = succ_words.get_mut(o + k) {
                    *x = off;
                }
                off += stored(m.symbol);
            }
        }
        let mut tpl = Vec::new();
        let mut patches = Vec::new();
        let mut plans = Vec::with_capacity(sys.alts.len());
        for (ai, a) in sys.alts.iter().enumerate() {
            let tpl_start = tpl.len() as u32;
            let first_patch = patches.len() as u32;
            let mut dst = 0u32;
            for m in sys.successor(a) {
                if implicit_sym[m.symbol as usize] > 0 {
                    // Constants, not stored.
                    continue;
                }
                for p in sys.module_params(m) {
                    let w = p.words as usize;
                    match p.kind {
                        PARAM_CONST => {
                            tpl.extend_from_slice(&sys.consts[p.a as usize..p.a as usize + w]);
                        }
                        _ => {
                            tpl.extend(std::iter::repeat_n(0.0, w));
                            patches.push(Patch::of(sys, p, dst));
                        }
                    }
                    dst += p.words;
                }
            }
            plans.push(Plan {
                succ: a.succ_offset,
                len: a.succ_len,
                words: alt_words[ai].0,
                tpl: tpl_start,
                patch_lo: first_patch,
                patch_hi: patches.len() as u32,
                arith: patches[first_patch as usize..]
                    .iter()
                    .all(|p| matches!(p, Patch::Arith { .. })),
            });
        }
        let mut fans = Vec::new();
        let acts: Vec<Act> = (0..n)
            .map(|i| {
                let alt = fast[i];
                match alt {
                    COPY if sym_words[i] == 0 => return Act::Copy0,
                    COPY => return Act::Copy(sym_words[i]),
                    SLOW => return Act::Slow,
                    _ => {}
                }
                let plan = plans[alt as usize];
                if sym_words[i] == 1
                    && plan.len == 1
                    && plan.words == 1
                    && plan.patch_hi == plan.patch_lo + 1
                    && let Patch::Arith {
                        dst: 0,
                        src: 0,
                        m,
                        a,
                        span,
                    } = patches[plan.patch_lo as usize]
                {
                    return Act::Unit(Unit {
                        sym: succ_syms[plan.succ as usize],
                        succ: plan.succ,
                        m,
                        a,
                        span,
                    });
                }
                let (t, words) = (plan.tpl as usize, plan.words as usize);
                let small = plan.arith
                    && plan.len as usize <= PAD
                    && words <= PAD
                    && sym_words[i] as usize <= PAD
                    && tpl[t..t + words].iter().all(|x| x.is_finite())
                    && patches[plan.patch_lo as usize..plan.patch_hi as usize]
                        .iter()
                        .all(|p| match *p {
                            Patch::Arith { dst, src, .. } => {
                                (dst as usize) < words && src < sym_words[i]
                            }
                            _ => false,
                        });
                let arith = |p: &Patch| match *p {
                    Patch::Arith { dst, src, m, a, .. } => Some((dst, src, m, a)),
                    _ => None,
                };
                let fan = Fan::of(
                    plan,
                    patches[plan.patch_lo as usize..plan.patch_hi as usize]
                        .iter()
                        .map(arith),
                    sym_words[i],
                );
                if let (true, Some(fan)) = (small, fan) {
                    fans.push(fan);
                    Act::Fan(fans.len() as u32 - 1)
                } else if small {
                    Act::Small(alt)
                } else {
                    Act::Plan(alt)
                }
            })
            .collect();
        let ariths = patches
            .iter()
            .map(|p| match *p {
                Patch::Arith { dst, src, m, a, .. } => Arith { dst, src, m, a },
                _ => Arith::default(),
            })
            .collect();
        // The padded tables (see `PAD`).
        let mut succ_syms = succ_syms;
        succ_syms.extend([0; 2 * PAD]);
        succ_words.extend([0; 2 * PAD]);
        tpl.extend([0.0; 2 * PAD]);
        // Strings walk their stored words (no `starts`) where every symbol
        // is rewritten without a decision: nothing then reads a module's
        // words out of order while deriving ([`ModuleString`], "Walked
        // words").
        let mut implicit = implicit;
        if let Some(t) = &mut implicit
            && succ_hist.is_some()
        {
            t.widths = sym_words.clone();
        }
        let pool = if threads > 1 {
            Some(
                rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .map_err(|e| DeriveError::ThreadPool(e.to_string()))?,
            )
        } else {
            None
        };
        Ok(Engine {
            sys,
            counts,
            sym_words,
            bracket,
            ignored,
            succ_hist,
            succ_syms,
            succ_words,
            succ_salts,
            keyed: sys.draws_randomly(),
            tpl,
            patches,
            ariths,
            plans,
            fans,
            copies: acts
                .iter()
                .map(|a| matches!(a, Act::Copy0 | Act::Copy(_)))
                .collect(),
            acts,
            has_context: sys.has_context(),
            threads,
            min_chunk: MIN_CHUNK,
            pool,
            spare: std::sync::Mutex::new(Vec::new()),
            scratch: std::sync::Mutex::new(Vec::new()),
            response: std::sync::Mutex::new(Default::default()),
            edits: None,
            implicit: implicit.map(Arc::new),
            implicit_sym,
            implicit_alt: alt_words.iter().map(|&(_, i)| i).collect(),
        })
    }
}

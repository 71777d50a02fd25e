//! Bounds of a derivation's strings, computed on the host from the
//! compiled tables before anything runs on the device: per-string upper
//! bounds, exact or expected final counts, projected sizes, and the plan
//! of a batched derivation's buffers (see the parent module).

use super::*;

impl GpuSystem<'_> {
    /// Upper bounds of every string's modules and parameter words (string
    /// 0 is the axiom), from the tables: per symbol, the most modules of
    /// each symbol any of its outcomes produces (every alternative of the
    /// groups that may apply, and the unchanged copy unless a group
    /// without context or condition always applies). Exact for
    /// deterministic context-free systems. `None` when a table is out of
    /// range (the per-iteration path reports it).
    pub(crate) fn string_bounds(
        &self,
        opts: &GpuDeriveOptions,
        prefix: Option<&Prefix>,
    ) -> Option<Vec<(u64, u64)>> {
        self.symbol_bounds(opts, prefix).map(|(total, _)| total)
    }

    /// Per job, how many modules of each symbol its final string has, when
    /// that is known before deriving: every symbol of every job is exact
    /// (deterministic and context-free, so the bound is the count).
    pub(crate) fn exact_final_counts(&self, opts: &GpuDeriveOptions) -> Option<Vec<Vec<u64>>> {
        let exact = self
            .jobs
            .iter()
            .all(|j| (0..j.system.symbols.len()).all(|s| exact_symbol(j.system, s)));
        if !exact {
            return None;
        }
        self.symbol_bounds(opts, None).map(|(_, last)| last)
    }

    /// At most how deep the brackets of the final string nest and how many
    /// `[` it has, over every outcome that may happen (the outcomes
    /// [`growth_row`] counts), `kinds[j][s]` being 1 for a `[` and -1 for
    /// a `]` of job `j`'s symbol `s`. Each job's string starts at depth 0.
    /// `None` when a table is out of range.
    pub(crate) fn bracket_bounds(
        &self,
        opts: &GpuDeriveOptions,
        kinds: &[Vec<i8>],
    ) -> Option<(u64, u64)> {
        let (_, last) = self.symbol_bounds(opts, None)?;
        let mut opens = 0u64;
        let mut depth = 0i64;
        for (((job, its), counts), kind) in self
            .jobs
            .iter()
            .zip(self.job_iterations(opts))
            .zip(&last)
            .zip(kinds)
        {
            let sys = job.system;
            let k = |s: u32| i64::from(kind.get(s as usize).copied().unwrap_or(0));
            for (s, &c) in counts.iter().enumerate() {
                if k(s as u32) > 0 {
                    opens = opens.saturating_add(c);
                }
            }
            // `rel[s]`: the deepest a module of `s` and what it becomes
            // reach after the steps so far, relative to the depth before
            // it. A module's own depth: 1 for `[` (the depth after it),
            // else 0.
            let ns = sys.symbols.len();
            let outcomes = (0..ns)
                .map(|s| successors_of(sys, s))
                .collect::<Option<Vec<_>>>()?;
            let mut rel: Vec<i64> = (0..ns).map(|s| k(s as u32).max(0)).collect();
            let reach = |succ: &[u32], rel: &[i64]| -> i64 {
                let mut d = 0i64;
                let mut most = 0i64;
                for &m in succ {
                    most = most.max(d.saturating_add(rel[m as usize]));
                    d = d.saturating_add(k(m));
                }
                most.max(d)
            };
            for _ in 0..its {
                rel = outcomes
                    .iter()
                    .enumerate()
                    .map(|(s, outs)| {
                        outs.iter()
                            .map(|succ| reach(succ, &rel))
                            .fold(rel[s], i64::max)
                    })
                    .collect();
            }
            let axiom = sys.alts.get(sys.axiom_alt as usize)?;
            let axiom: Vec<u32> = succ_of(sys, axiom)?.iter().map(|m| m.symbol).collect();
            if axiom.iter().any(|&m| m as usize >= ns) {
                return None;
            }
            depth = depth.max(reach(&axiom, &rel));
        }
        Some((depth.max(0) as u64, opens))
    }

    /// [`GpuSystem::string_bounds`], and per job the bound of each
    /// symbol's count in its final string.
    #[allow(clippy::type_complexity)]
    pub(super) fn symbol_bounds(
        &self,
        opts: &GpuDeriveOptions,
        prefix: Option<&Prefix>,
    ) -> Option<(Vec<(u64, u64)>, Vec<Vec<u64>>)> {
        let k_max = opts.iterations as usize;
        let k0 = prefix.map_or(0, |p| p.stats.len() - 1);
        let mut total = vec![(0u64, 0u64); k_max + 1];
        let mut last = Vec::with_capacity(self.jobs.len());
        for (j, (job, its)) in self.jobs.iter().zip(self.job_iterations(opts)).enumerate() {
            let sys = job.system;
            let ns = sys.symbols.len();
            let rows = (0..ns)
                .map(|s| growth_row(sys, s))
                .collect::<Option<Vec<_>>>()?;
            let mut c = vec![0u64; ns];
            match prefix {
                Some(p) => c.clone_from(p.hist.get(j)?),
                None => {
                    let axiom = sys.alts.get(sys.axiom_alt as usize)?;
                    for m in succ_of(sys, axiom)? {
                        *c.get_mut(m.symbol as usize)? += 1;
                    }
                }
            }
            for (k, tot) in total.iter_mut().enumerate().skip(k0) {
                if k > k0 && k <= its as usize {
                    let mut next = vec![0u64; ns];
                    for (s, &n) in c.iter().enumerate() {
                        if n == 0 {
                            continue;
                        }
                        for &(t, q) in &rows[s] {
                            next[t] = next[t].saturating_add(n.saturating_mul(q));
                        }
                    }
                    c = next;
                }
                let m = c.iter().fold(0u64, |a, &x| a.saturating_add(x));
                let w = c.iter().zip(&sys.symbols).fold(0u64, |a, (&x, e)| {
                    a.saturating_add(x.saturating_mul(u64::from(e.param_words)))
                });
                tot.0 = tot.0.saturating_add(m);
                tot.1 = tot.1.saturating_add(w);
            }
            last.push(c);
        }
        // The CPU's strings are known exactly.
        for (tot, st) in total
            .iter_mut()
            .zip(prefix.map_or(&[][..], |p| &p.stats[..]))
        {
            *tot = (st.modules, st.param_words);
        }
        Some((total, last))
    }

    /// Per job, the expected number of modules of each symbol in its final
    /// string, from the axiom: each symbol's outcomes weighted by their
    /// probabilities (the largest outcome where a condition, a context or
    /// computed weights decide; [`expected_row`]). `None` when a table is
    /// out of range.
    pub(crate) fn expected_final_counts(&self, opts: &GpuDeriveOptions) -> Option<Vec<Vec<f64>>> {
        let mut out = Vec::with_capacity(self.jobs.len());
        for (job, its) in self.jobs.iter().zip(self.job_iterations(opts)) {
            let sys = job.system;
            let ns = sys.symbols.len();
            let rows = (0..ns)
                .map(|s| expected_row(sys, s))
                .collect::<Option<Vec<_>>>()?;
            let mut c = vec![0f64; ns];
            let axiom = sys.alts.get(sys.axiom_alt as usize)?;
            for m in succ_of(sys, axiom)? {
                *c.get_mut(m.symbol as usize)? += 1.0;
            }
            for _ in 0..its {
                let mut next = vec![0f64; ns];
                for (s, &n) in c.iter().enumerate() {
                    for &(t, q) in &rows[s] {
                        next[t] += n * q;
                    }
                }
                c = next;
            }
            out.push(c);
        }
        Some(out)
    }

    /// The expected modules and parameter words of every string after
    /// the CPU's (each symbol's outcomes weighted by their probabilities;
    /// the largest outcome where a condition, a context or computed
    /// weights decide), from the prefix string's exact symbol counts.
    /// `None` without a prefix or when a table is out of range.
    pub(super) fn projected_sizes(
        &self,
        opts: &GpuDeriveOptions,
        prefix: Option<&Prefix>,
    ) -> Option<Vec<(f64, f64)>> {
        let p = prefix?;
        let k_max = opts.iterations as usize;
        let k0 = p.stats.len() - 1;
        let mut total = vec![(0f64, 0f64); k_max + 1];
        for (j, (job, its)) in self.jobs.iter().zip(self.job_iterations(opts)).enumerate() {
            let sys = job.system;
            let ns = sys.symbols.len();
            let rows = (0..ns)
                .map(|s| expected_row(sys, s))
                .collect::<Option<Vec<_>>>()?;
            let mut c: Vec<f64> = p.hist.get(j)?.iter().map(|&n| n as f64).collect();
            for (k, tot) in total.iter_mut().enumerate().skip(k0) {
                if k > k0 && k <= its as usize {
                    let mut next = vec![0f64; ns];
                    for (s, &n) in c.iter().enumerate() {
                        for &(t, q) in &rows[s] {
                            next[t] += n * q;
                        }
                    }
                    c = next;
                }
                tot.0 += c.iter().sum::<f64>();
                tot.1 += c
                    .iter()
                    .zip(&sys.symbols)
                    .map(|(&x, e)| x * f64::from(e.param_words))
                    .sum::<f64>();
            }
        }
        Some(total)
    }

    /// The buffers of a batched derivation, or `None` when the bounds are
    /// over a limit (the options', the device's, 32-bit counts) or the
    /// system needs bracket matching.
    pub(super) fn batch_plan(
        &self,
        opts: &GpuDeriveOptions,
        prefix: Option<&Prefix>,
    ) -> Option<BatchPlan> {
        let k0 = prefix.map_or(0, |p| p.stats.len() - 1);
        if self.has_context || opts.iterations as usize <= k0 {
            return None;
        }
        let mut bounds = self.string_bounds(opts, prefix)?;
        // A loose bound (stochastic or conditional productions) can be far
        // above the real sizes (every symbol taking its largest outcome at
        // every step: 21x for the stochastic plant at 11 steps). After a
        // CPU prefix of at least PROJECT_MIN_MODULES modules, whose exact
        // symbol counts make the rest predictable within a fraction of a
        // percent, the buffers are sized from the expected sizes with a
        // margin instead; a string over them sets the overflow flag, and
        // the derivation runs again iteration by iteration.
        let exact = self
            .jobs
            .iter()
            .all(|j| (0..j.system.symbols.len()).all(|s| exact_symbol(j.system, s)));
        let projected = match prefix {
            Some(p) if !exact && p.string.len() as u64 >= PROJECT_MIN_MODULES => {
                self.projected_sizes(opts, prefix)
            }
            _ => None,
        };
        if let Some(proj) = &projected {
            let cap = |x: f64| (x * PROJECT_MARGIN).ceil() as u64 + PROJECT_SLACK;
            for (b, &(m, w)) in bounds.iter_mut().zip(proj).skip(k0 + 1) {
                *b = (b.0.min(cap(m)), b.1.min(cap(w)));
            }
        }
        let limit32 = u64::from(u32::MAX) - 1;
        let mut caps = [(0u64, 0u64); 2];
        let mut max_in = 0u64;
        // String k lives in buffer (k - k0) % 2; the CPU's strings before
        // k0 are not on the device.
        for (k, &(m, w)) in bounds.iter().enumerate().skip(k0) {
            if m > limit32 || w > limit32 {
                return None;
            }
            let c = &mut caps[(k - k0) % 2];
            *c = (c.0.max(m), c.1.max(w));
            if k > k0 {
                let (n, nw) = bounds[k - 1];
                max_in = max_in.max(n);
                let bytes =
                    self.string_bytes(n, nw) + 8 * (n + 1) + 4 * n + self.string_bytes(m, w);
                if m > opts.max_modules || bytes > opts.max_bytes {
                    return None;
                }
            }
        }
        let levels = scan_levels(max_in);
        let total = self.string_bytes(caps[0].0, caps[0].1)
            + self.string_bytes(caps[1].0, caps[1].1)
            + 12 * (max_in + 1);
        let gpu = self.gpu;
        let fits = |what, b| gpu.check_storage(what, b).is_ok();
        // A loose bound (stochastic or conditional productions) costs its
        // allocation however short the string: keep it small.
        let cap = if exact {
            BATCH_MAX_BYTES
        } else {
            BATCH_LOOSE_MAX_BYTES
        };
        let ok = total <= cap
            && total <= opts.max_bytes
            && caps.iter().all(|&(m, w)| {
                fits("output symbols", 4 * m)
                    && fits("output parameter starts", 4 * (m + 1))
                    && fits("output parameters", 4 * w)
                    && (!self.keyed || fits("output identity keys", 4 * m))
            })
            && fits("output counts", 8 * (max_in + 1))
            && gpu.grid("count", groups_for(max_in + 1)).is_ok();
        ok.then_some(BatchPlan {
            k0,
            bounds,
            caps,
            max_in,
            levels,
        })
    }
}

/// The sizes of a batched derivation.
#[derive(Debug)]
pub(super) struct BatchPlan {
    /// The strings derived on the CPU before the batch: 0..=k0.
    pub(super) k0: usize,
    /// Every string's bound (modules, parameter words).
    pub(super) bounds: Vec<(u64, u64)>,
    /// The two string buffers' capacities (even and odd strings).
    pub(super) caps: [(u64, u64); 2],
    /// The largest input bound.
    pub(super) max_in: u64,
    /// Blocks of each scan level for the largest input.
    pub(super) levels: Vec<u64>,
}

/// Blocks of each level of a batched iteration's scan of the counts of
/// `n` input modules (`n + 1` elements), down to the level of one block:
/// level 0 is `count_scan`'s (one block per workgroup), the levels above
/// scan block sums [`SCAN_BLOCK`] at a time (shaders/batch.wgsl sizes them
/// the same way).
pub(super) fn scan_levels(n: u64) -> Vec<u64> {
    let mut levels = Vec::new();
    let mut len = n + 1;
    loop {
        let per = if levels.is_empty() {
            u64::from(crate::device::WORKGROUP)
        } else {
            u64::from(SCAN_BLOCK)
        };
        let blocks = len.div_ceil(per);
        levels.push(blocks);
        if blocks <= 1 {
            break;
        }
        len = blocks;
    }
    levels
}

/// An alternative's successor modules.
pub(super) fn succ_of<'s>(
    sys: &'s CompiledSystem,
    a: &grm_compile::table::AltHeader,
) -> Option<&'s [grm_compile::table::SuccModule]> {
    let start = a.succ_offset as usize;
    sys.succ.get(start..start.checked_add(a.succ_len as usize)?)
}

/// For symbol `s`: (symbol, the most modules of it one module of `s`
/// becomes in one step), over every outcome that may happen.
pub(super) fn growth_row(sys: &CompiledSystem, s: usize) -> Option<Vec<(usize, u64)>> {
    use grm_compile::table::{GROUP_CONTEXT, NONE};
    let e = sys.symbols.get(s)?;
    let mut row: std::collections::BTreeMap<usize, u64> = Default::default();
    let mut copy = true;
    for g in e.first_group..e.first_group.checked_add(e.group_count)? {
        let gh = sys.groups.get(g as usize)?;
        for a in gh.first_alt..gh.first_alt.checked_add(gh.alt_count)? {
            let mut here: std::collections::BTreeMap<usize, u64> = Default::default();
            for m in succ_of(sys, sys.alts.get(a as usize)?)? {
                if m.symbol as usize >= sys.symbols.len() {
                    return None;
                }
                *here.entry(m.symbol as usize).or_default() += 1;
            }
            for (t, q) in here {
                let r = row.entry(t).or_default();
                *r = (*r).max(q);
            }
        }
        if gh.flags & GROUP_CONTEXT == 0 && gh.cond_code == NONE {
            // Always applies: the groups after it never do, nor the copy.
            copy = false;
            break;
        }
    }
    if copy {
        let r = row.entry(s).or_default();
        *r = (*r).max(1);
    }
    Some(row.into_iter().collect())
}

/// For symbol `s`: the successors (as symbol lists) a module of it may
/// become in one step, staying as it is included where that may happen
/// (the outcomes of [`growth_row`]).
pub(super) fn successors_of(sys: &CompiledSystem, s: usize) -> Option<Vec<Vec<u32>>> {
    use grm_compile::table::{GROUP_CONTEXT, NONE};
    let e = sys.symbols.get(s)?;
    let mut outs = Vec::new();
    let mut copy = true;
    for g in e.first_group..e.first_group.checked_add(e.group_count)? {
        let gh = sys.groups.get(g as usize)?;
        for a in gh.first_alt..gh.first_alt.checked_add(gh.alt_count)? {
            let succ = succ_of(sys, sys.alts.get(a as usize)?)?;
            if succ.iter().any(|m| m.symbol as usize >= sys.symbols.len()) {
                return None;
            }
            outs.push(succ.iter().map(|m| m.symbol).collect());
        }
        if gh.flags & GROUP_CONTEXT == 0 && gh.cond_code == NONE {
            copy = false;
            break;
        }
    }
    if copy {
        outs.push(vec![s as u32]);
    }
    Some(outs)
}

/// For symbol `s`: (symbol, the expected number of modules of it one
/// module of `s` becomes in one step): its first group's alternatives
/// weighted by their constant weights where that group always applies,
/// else (a condition, a context or computed weights decide)
/// [`growth_row`]'s largest outcome.
pub(super) fn expected_row(sys: &CompiledSystem, s: usize) -> Option<Vec<(usize, f64)>> {
    use grm_compile::table::{GROUP_CONST_WEIGHTS, GROUP_CONTEXT, NONE};
    let e = sys.symbols.get(s)?;
    if e.group_count == 0 {
        return Some(vec![(s, 1.0)]);
    }
    let g = sys.groups.get(e.first_group as usize)?;
    let sure = g.flags & GROUP_CONTEXT == 0 && g.cond_code == NONE;
    let weighted = g.alt_count == 1 || (g.flags & GROUP_CONST_WEIGHTS != 0 && g.total_weight > 0.0);
    if !(sure && weighted) {
        let row = growth_row(sys, s)?;
        return Some(row.into_iter().map(|(t, q)| (t, q as f64)).collect());
    }
    let mut row: std::collections::BTreeMap<usize, f64> = Default::default();
    for a in g.first_alt..g.first_alt.checked_add(g.alt_count)? {
        let alt = sys.alts.get(a as usize)?;
        let p = if g.alt_count == 1 {
            1.0
        } else {
            f64::from(alt.weight) / f64::from(g.total_weight)
        };
        for m in succ_of(sys, alt)? {
            if m.symbol as usize >= sys.symbols.len() {
                return None;
            }
            *row.entry(m.symbol as usize).or_default() += p;
        }
    }
    Some(row.into_iter().collect())
}

/// Whether every module of symbol `s` becomes the same successor (or
/// stays): its first group always applies and has one alternative, or it
/// has no group. The bound is then the exact size.
pub(super) fn exact_symbol(sys: &CompiledSystem, s: usize) -> bool {
    use grm_compile::table::{GROUP_CONTEXT, NONE};
    let Some(e) = sys.symbols.get(s) else {
        return false;
    };
    if e.group_count == 0 {
        return true;
    }
    sys.groups
        .get(e.first_group as usize)
        .is_some_and(|g| g.flags & GROUP_CONTEXT == 0 && g.cond_code == NONE && g.alt_count == 1)
}

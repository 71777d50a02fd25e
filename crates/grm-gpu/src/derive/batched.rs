//! The two iteration loops of a GPU derivation: all iterations recorded
//! into one submission (batched), and one iteration at a time (the exact
//! fallback that reports errors where they happen; see the parent module).

use super::*;

impl GpuSystem<'_> {
    /// All iterations in one submission (see the module documentation).
    /// `None`: an error or an overflow was reported; nothing is returned
    /// and the caller derives iteration by iteration.
    #[allow(clippy::type_complexity)]
    pub(super) fn derive_batched(
        &self,
        plan: &BatchPlan,
        opts: &GpuDeriveOptions,
        strategy: DeriveStrategy,
        prefix: Option<&Prefix>,
    ) -> Result<Option<(DeviceString, Vec<(u64, u64)>, Vec<DeviceTime>)>, GpuError> {
        let gpu = self.gpu;
        self.reset_directory(opts, prefix);
        let k_max = opts.iterations as usize;
        let nlev = plan.levels.len();
        let k0 = plan.k0;
        let (offsets, m0, w0) = match prefix {
            Some(p) => (
                Vec::new(),
                p.string.len() as u64,
                p.string.param_words() as u64,
            ),
            None => self.axiom_offsets()?,
        };
        let strings = [
            self.alloc_string(plan.caps[0].0, plan.caps[0].1)?,
            self.alloc_string(plan.caps[1].0, plan.caps[1].1)?,
        ];
        let counts = gpu.storage("output counts", 8 * (plan.max_in + 1))?;
        let choice = gpu.storage("production choices", 4 * plan.max_in)?;
        let mate = gpu.storage("unused", 16)?;
        let status = gpu.storage_zeroed("derive status", u64::from(STATUS_WORDS) * 4)?;
        let sums = plan
            .levels
            .iter()
            .map(|&b| gpu.storage("scan block sums", 8 * b))
            .collect::<Result<Vec<_>, _>>()?;
        // Parameters written on the device by `batch_next`, read where
        // they are written (shaders/batch.wgsl): the DeriveParams and the
        // indirect arguments by iteration parity, the scan levels' records
        // `align` bytes apart (binding offsets must be aligned).
        let align = gpu.storage_offset_alignment();
        let sp_stride = 16u64.next_multiple_of(align);
        let arg_bytes = 12 * (1 + 2 * nlev as u64);
        let arg_half = arg_bytes.next_multiple_of(align);
        let args = gpu.indirect_storage("batch dispatch args", 2 * arg_half)?;
        let dp0 = gpu.upload(
            "batch derive params",
            &[DeriveParams {
                systems: self.jobs.len() as u32,
                iteration: k0 as u32,
                keyed: u32::from(self.keyed),
                ..DeriveParams::default()
            }],
        )?;
        let dp = [
            gpu.storage("derive params", std::mem::size_of::<DeriveParams>() as u64)?,
            gpu.storage("derive params", std::mem::size_of::<DeriveParams>() as u64)?,
        ];
        let sp = gpu.storage_zeroed("batch scan params", sp_stride * nlev as u64)?;
        let flag = 2 * (k_max + 1);
        let hist = gpu.upload("batch history", &vec![0u32; flag + 1])?;
        let mut caps: Vec<[u32; 2]> = plan
            .bounds
            .iter()
            .map(|&(m, w)| [m as u32, w as u32])
            .collect();
        if strategy == DeriveStrategy::AutoShrunkCaps {
            caps[k_max] = [0, 0];
        }
        let caps = gpu.upload("batch capacities", &caps)?;
        let bp = gpu.uniform(
            "batch params",
            &BatchParams {
                grid_width: gpu.grid_width(),
                levels: nlev as u32,
                flag: flag as u32,
                sp_stride: (sp_stride / 16) as u32,
            },
        );

        // `batch_next` before iteration 1 reads `dp0` and writes parity 0;
        // after iteration k (parity p = (k - 1) % 2) it reads dp[p] and
        // writes the other parity's DeriveParams and arguments.
        let next_bound = |input: &wgpu::Buffer, out: usize| -> Result<Bound, GpuError> {
            gpu.bound_ranges(
                &kernels::BATCH_NEXT,
                &[
                    (&bp, 0, None),
                    (&counts, 0, None),
                    (&caps, 0, None),
                    (input, 0, None),
                    (&dp[out], 0, None),
                    (&sp, 0, None),
                    (&args, arg_half * out as u64, Some(arg_half)),
                    (&hist, 0, None),
                    (&sums[0], 0, None),
                ],
            )
        };
        let start = next_bound(&dp0, 0)?;
        let next = [next_bound(&dp[0], 1)?, next_bound(&dp[1], 0)?];
        let derive_bound =
            |kernel: &'static crate::shader::Kernel, p: usize| -> Result<Bound, GpuError> {
                let (i, o) = (&strings[p], &strings[1 - p]);
                gpu.bound(
                    kernel,
                    &[
                        &dp[p],
                        &self.tables,
                        &i.syms,
                        &i.starts,
                        &i.params,
                        &mate,
                        &counts,
                        &choice,
                        &o.syms,
                        &o.starts,
                        &o.params,
                        &status,
                        self.keys_of(i, 0),
                        self.keys_of(o, 1),
                        &sums[0],
                    ],
                )
            };
        // Count and scan level 0 in one kernel: `counts` gets the offsets
        // within each block, `sums[0]` the blocks' totals; the levels
        // above scan those, and the readers combine the two
        // (shaders/offsets_blocks.wgsl), so level 0 is never added.
        let count = [
            derive_bound(self.kernels.count_scan_dev, 0)?,
            derive_bound(self.kernels.count_scan_dev, 1)?,
        ];
        let rewrite = [
            derive_bound(self.kernels.rewrite_out_dev, 0)?,
            derive_bound(self.kernels.rewrite_out_dev, 1)?,
        ];
        // Levels 1 and up (level l scans level l - 1's block sums).
        let mut scans = Vec::with_capacity(nlev);
        let mut adds = Vec::with_capacity(nlev);
        for l in 1..nlev {
            let b = [
                (&sp, sp_stride * l as u64, Some(16)),
                (&sums[l - 1], 0, None),
                (&sums[l], 0, None),
            ];
            scans.push((l, gpu.bound_ranges(&kernels::SCAN_U32X2_DEV, &b)?));
            adds.push((l, gpu.bound_ranges(&kernels::ADD_U32X2_DEV, &b)?));
        }
        let directory = [
            gpu.bound(
                &kernels::UPDATE_DIRECTORY_DEV,
                &[&dp[0], &self.tables, &counts, &sums[0]],
            )?,
            gpu.bound(
                &kernels::UPDATE_DIRECTORY_DEV,
                &[&dp[1], &self.tables, &counts, &sums[0]],
            )?,
        ];
        let dir_grid = gpu.grid("update directory", groups_for(self.jobs.len() as u64))?;

        let mut enc = gpu.encoder();
        match prefix {
            Some(p) => write_string(gpu, &strings[0], &p.string),
            None => {
                self.record_axiom(&mut enc, &offsets, (m0, w0), &strings[0], &status)?;
                gpu.queue().write_buffer(
                    &strings[0].starts,
                    4 * m0,
                    bytemuck::bytes_of(&(w0 as u32)),
                );
            }
        }
        gpu.queue()
            .write_buffer(&counts, 0, bytemuck::cast_slice(&[m0 as u32, w0 as u32]));
        {
            let mut pass = begin(&mut enc, "batch start");
            start.dispatch(&mut pass, (1, 1));
        }
        let stamps = Stamps::new(gpu, (k_max - k0) as u32);
        for k in k0 + 1..=k_max {
            let p = (k - 1 - k0) % 2;
            let j = (k - 1 - k0) as u32;
            // A recorded iteration holds host memory until its submission
            // completes: a long derivation (thousands of iterations of a
            // slowly growing string) is submitted in chunks, each waited
            // for, so the host holds at most one chunk.
            if j > 0 && j.is_multiple_of(BATCH_SUBMIT_ITERATIONS) {
                let full = std::mem::replace(&mut enc, gpu.encoder());
                gpu.submit_wait(full)?;
            }
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("batch iteration"),
                timestamp_writes: stamps.as_ref().and_then(|s| s.pass_writes(j)),
            });
            let stage = |pass: &mut wgpu::ComputePass<'_>, st: u32| {
                if let Some(s) = &stamps {
                    s.after_stage(pass, j, st);
                }
            };
            // This iteration's arguments (written by the previous
            // `batch_next` into parity p's half).
            let a = arg_half * p as u64;
            // The input's bound says which scan levels can have work:
            // `batch_next` gives the others empty grids, so they are
            // not recorded (an empty dispatch still costs a barrier).
            let lev = scan_levels(plan.bounds[k - 1].0).len().min(nlev);
            // Level 0's grid (one workgroup per block of SCAN_BLOCK).
            count[p].dispatch_indirect(&mut pass, &args, a + 12);
            stage(&mut pass, 0);
            for (l, sc) in scans.iter().take(lev - 1) {
                sc.dispatch_indirect(&mut pass, &args, a + 12 * (1 + *l as u64));
            }
            for (l, ad) in adds.iter().take(lev.saturating_sub(2)).rev() {
                ad.dispatch_indirect(&mut pass, &args, a + 12 * (1 + (nlev + l) as u64));
            }
            stage(&mut pass, 1);
            next[p].dispatch(&mut pass, (1, 1));
            stage(&mut pass, 2);
            rewrite[p].dispatch_indirect(&mut pass, &args, a);
            stage(&mut pass, 3);
            // One system's range is the whole string: no kernel reads
            // it on this path (contexts are derived per iteration); it
            // is written once at the end instead.
            if self.jobs.len() > 1 {
                directory[p].dispatch(&mut pass, dir_grid);
            }
        }
        let mut ranges = vec![
            (&hist, 0, flag as u64 + 1),
            (&status, 0, u64::from(STATUS_WORDS)),
        ];
        if let Some(s) = &stamps {
            s.resolve(&mut enc);
            let (buf, words) = s.readback();
            ranges.push((buf, 0, words));
        }
        // Several systems: their ranges in the final string, read with the
        // totals (the interpretation needs them; no wait of their own).
        let entry_words = (std::mem::size_of::<SystemEntry>() / 4) as u64;
        let dir_at = ranges.len();
        if self.jobs.len() > 1 {
            ranges.push((&self.tables, 0, entry_words * self.jobs.len() as u64));
        }
        let words = gpu.read::<u32>(enc, &ranges)?;
        let device = match (&stamps, words.get(2)) {
            (Some(s), Some(w)) => s.times(w),
            _ => Vec::new(),
        };
        if self.jobs.len() > 1
            && let Some(w) = words.get(dir_at)
        {
            let entries: Vec<SystemEntry> = w
                .chunks_exact(entry_words as usize)
                .map(|c| bytemuck::pod_read_unaligned(bytemuck::cast_slice(c)))
                .collect();
            self.final_directory.replace(Some(entries));
        }
        let [strings0, strings1] = strings;
        let (last, other) = if (k_max - k0).is_multiple_of(2) {
            (strings0, strings1)
        } else {
            (strings1, strings0)
        };
        let [dp_a, dp_b] = dp;
        let mut scratch: Vec<wgpu::Buffer> = vec![counts, choice, mate, sp, dp_a, dp_b];
        scratch.extend(sums);
        scratch.extend(other.into_buffers());
        let h = words.first().map(Vec::as_slice).unwrap_or(&[]);
        let st = words.get(1).map(Vec::as_slice).unwrap_or(&[]);
        let failed = h.len() != flag + 1 || h[flag] != 0 || st.iter().any(|&x| x != 0);
        if failed {
            scratch.extend(last.into_buffers());
            gpu.recycle(scratch);
            return Ok(None);
        }
        gpu.recycle(scratch);
        let totals: Vec<(u64, u64)> = (0..=k_max)
            .map(|k| (u64::from(h[2 * k]), u64::from(h[2 * k + 1])))
            .collect();
        let (len, words) = totals[k_max];
        if let [one] = &self.directory[..] {
            let e = SystemEntry {
                start: 0,
                end: len as u32,
                ..self.single_entry(one, opts)
            };
            gpu.queue()
                .write_buffer(&self.tables, 0, bytemuck::bytes_of(&e));
            self.final_directory.replace(Some(vec![e]));
        }
        Ok(Some((DeviceString { len, words, ..last }, totals, device)))
    }

    /// One submission and one synchronisation per iteration.
    pub(super) fn derive_per_iteration(
        &self,
        opts: &GpuDeriveOptions,
        prefix: Option<&Prefix>,
        progress: &mut dyn FnMut(&GpuIterationStats),
    ) -> Result<(DeviceString, Vec<GpuIterationStats>), GpuError> {
        let t = Instant::now();
        self.reset_directory(opts, prefix);
        // Not sized by `opts.iterations` (any u32; a limit can end it early).
        let mut stats = Vec::with_capacity(opts.iterations.min(64) as usize + 1);
        let mut string = match prefix {
            Some(p) => {
                let s = &p.string;
                let out = self.alloc_string(s.len() as u64, s.param_words() as u64)?;
                write_string(self.gpu, &out, s);
                for st in &p.stats {
                    progress(st);
                    stats.push(*st);
                }
                out
            }
            None => {
                let string = self.axiom()?;
                let first = GpuIterationStats {
                    iteration: 0,
                    modules: string.len,
                    param_words: string.words,
                    elapsed: t.elapsed(),
                    device: None,
                    on_cpu: false,
                };
                progress(&first);
                stats.push(first);
                string
            }
        };
        let k0 = stats.len() as u32 - 1;
        let status = self
            .gpu
            .storage_zeroed("derive status", u64::from(STATUS_WORDS) * 4)?;
        let previous = self.gpu.storage(
            "previous directory",
            (self.directory.len() * std::mem::size_of::<SystemEntry>()) as u64,
        )?;
        for iteration in k0 + 1..=opts.iterations {
            let t = Instant::now();
            let next = self.step(&string, iteration, opts, &status, &previous)?;
            let old = std::mem::replace(&mut string, next);
            self.gpu.recycle(old.into_buffers());
            let s = GpuIterationStats {
                iteration,
                modules: string.len,
                param_words: string.words,
                elapsed: t.elapsed(),
                device: None,
                on_cpu: false,
            };
            progress(&s);
            stats.push(s);
        }
        // Errors of the last rewrite (none when the CPU derived every
        // string: no wait for a device that did nothing).
        if k0 < opts.iterations {
            let st = self
                .gpu
                .read::<u32>(self.gpu.encoder(), &[(&status, 0, u64::from(STATUS_WORDS))])?;
            let st = st.into_iter().next().unwrap_or_default();
            self.check_status(&st, 1, opts.iterations, None, &previous)?;
        }
        self.gpu.recycle([status, previous]);
        Ok((string, stats))
    }
}

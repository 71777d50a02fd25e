//! One GPU iteration and its parts: the rewrite kernel's choice, string
//! buffers, the axiom's upload, the count / scan / rewrite dispatches of a
//! step, and reading back the error status.

use super::*;

impl GpuSystem<'_> {
    /// The rewrite kernel: one thread per output module (`rewrite_out`),
    /// or per input module (`rewrite`) for context-sensitive systems,
    /// whose binding would otherwise match the contexts again for every
    /// output module, unless one of their successors is longer than
    /// [`kernels::LONG_SUCCESSOR`].
    pub(super) fn rewrite_kernel(&self) -> &'static crate::shader::Kernel {
        if self.has_context && !self.long_successors {
            self.kernels.rewrite
        } else {
            self.kernels.rewrite_out
        }
    }

    /// A string's buffers (with identity keys where the derivation
    /// carries them).
    pub(super) fn alloc_string(&self, modules: u64, words: u64) -> Result<DeviceString, GpuError> {
        Ok(DeviceString {
            syms: self.gpu.storage("output symbols", 4 * modules)?,
            starts: self
                .gpu
                .storage("output parameter starts", 4 * (modules + 1))?,
            params: self.gpu.storage("output parameters", 4 * words)?,
            keys: if self.keyed {
                Some(self.gpu.storage("output identity keys", 4 * modules)?)
            } else {
                None
            },
            len: modules,
            words,
        })
    }

    /// The key buffer of `s` to bind, or a placeholder (`side` 0 for an
    /// input, 1 for an output).
    pub(super) fn keys_of<'s>(&'s self, s: &'s DeviceString, side: usize) -> &'s wgpu::Buffer {
        s.keys.as_ref().unwrap_or(&self.no_keys[side])
    }

    pub(super) fn dispatch_derive(
        &self,
        enc: &mut wgpu::CommandEncoder,
        kernel: &'static crate::shader::Kernel,
        params: &DeriveParams,
        pass: &Pass<'_>,
        threads: u64,
    ) -> Result<(), GpuError> {
        let uniform = self.gpu.uniform("derive params", params);
        self.gpu.dispatch(
            enc,
            kernel,
            &[
                &uniform,
                &self.tables,
                &pass.input.syms,
                &pass.input.starts,
                &pass.input.params,
                pass.mate,
                pass.counts,
                pass.choice,
                &pass.out.syms,
                &pass.out.starts,
                &pass.out.params,
                pass.status,
                self.keys_of(pass.input, 0),
                self.keys_of(pass.out, 1),
            ],
            groups_for(threads),
        )
    }

    /// Where each system's axiom goes in string 0, and its totals.
    pub(super) fn axiom_offsets(&self) -> Result<(Vec<[u32; 2]>, u64, u64), GpuError> {
        let mut offsets: Vec<[u32; 2]> = Vec::with_capacity(self.jobs.len());
        let (mut m, mut w) = (0u64, 0u64);
        for job in &self.jobs {
            offsets.push([m as u32, w as u32]);
            let a = &job.system.alts[job.system.axiom_alt as usize];
            m += u64::from(a.succ_len);
            w += u64::from(a.succ_words);
        }
        if m >= u64::from(u32::MAX) || w >= u64::from(u32::MAX) {
            return Err(GpuError::CountOverflow {
                what: "axiom modules",
                count: m.max(w),
            });
        }
        Ok((offsets, m, w))
    }

    /// Record the axiom kernel writing string 0 into `out` (one thread
    /// per output module; each system's axiom at its `offsets`; errors in
    /// `status` slot 1, at the system's index). The last start is not
    /// written.
    pub(super) fn record_axiom(
        &self,
        enc: &mut wgpu::CommandEncoder,
        offsets: &[[u32; 2]],
        (modules, words): (u64, u64),
        out: &DeviceString,
        status: &wgpu::Buffer,
    ) -> Result<(), GpuError> {
        // The kernel finds each output module's system by its offset, and
        // reads the totals after the last system's (both fit u32: checked
        // by `axiom_offsets`). Empty axioms: nothing to write.
        if modules == 0 {
            return Ok(());
        }
        let mut with_totals = offsets.to_vec();
        with_totals.push([modules as u32, words as u32]);
        let counts = self.gpu.upload("axiom offsets", &with_totals)?;
        let (mate, choice) = (
            self.gpu.storage("unused", 16)?,
            self.gpu.storage("unused", 16)?,
        );
        let empty = DeviceString {
            syms: self.gpu.storage("unused", 16)?,
            starts: self.gpu.storage("unused", 16)?,
            params: self.gpu.storage("unused", 16)?,
            keys: None,
            len: 0,
            words: 0,
        };
        let params = DeriveParams {
            n: self.jobs.len() as u32,
            systems: self.jobs.len() as u32,
            iteration: 0,
            axiom: 1,
            keyed: u32::from(self.keyed),
            ..DeriveParams::default()
        };
        let pass = Pass {
            input: &empty,
            mate: &mate,
            counts: &counts,
            choice: &choice,
            out,
            status,
        };
        self.dispatch_derive(enc, self.kernels.rewrite, &params, &pass, modules)?;
        let mut done = vec![mate, choice];
        done.extend(empty.into_buffers());
        self.gpu.recycle(done);
        Ok(())
    }

    /// String 0: every system's axiom, evaluated on the device (one thread
    /// per module, writing at offsets computed here).
    pub(super) fn axiom(&self) -> Result<DeviceString, GpuError> {
        let (offsets, m, w) = self.axiom_offsets()?;
        let out = self.alloc_string(m, w)?;
        let status = self
            .gpu
            .storage_zeroed("axiom status", u64::from(STATUS_WORDS) * 4)?;
        let mut enc = self.gpu.encoder();
        self.record_axiom(&mut enc, &offsets, (m, w), &out, &status)?;
        self.gpu
            .queue()
            .write_buffer(&out.starts, 4 * m, bytemuck::bytes_of(&(w as u32)));
        let st = self
            .gpu
            .read::<u32>(enc, &[(&status, 0, u64::from(STATUS_WORDS))])?;
        let st = st.into_iter().next().unwrap_or_default();
        // Only the rewrite ran (slot 1); its thread index is the system.
        let word = |k: usize| st.get(k).copied().unwrap_or(0);
        if word(2) != 0 {
            return Err(GpuError::Runtime {
                system: u32::MAX - word(2),
                iteration: 0,
                position: 0,
                symbol: String::new(),
                kind: kind_of(word(3)),
            });
        }
        Ok(out)
    }

    /// One rewriting step producing string `iteration`.
    pub(super) fn step(
        &self,
        input: &DeviceString,
        iteration: u32,
        opts: &GpuDeriveOptions,
        status: &wgpu::Buffer,
        previous: &wgpu::Buffer,
    ) -> Result<DeviceString, GpuError> {
        let gpu = self.gpu;
        let n = input.len;
        let mut enc = gpu.encoder();
        let mut scratch_bufs = Vec::new();
        let mate = if self.has_context {
            let tree = brackets::record_match(gpu, &mut enc, &self.tables, &input.syms, n)?;
            scratch_bufs.push(tree.levels);
            scratch_bufs.push(tree.pairs);
            tree.mate
        } else {
            gpu.storage("unused", 16)?
        };
        let scratch = 8 * (n + 1)
            + 4 * n
            + if self.has_context {
                4 * n + brackets::scratch_bytes(n)
            } else {
                0
            };
        let counts = gpu.storage("output counts", 8 * (n + 1))?;
        let choice = gpu.storage("production choices", 4 * n)?;
        let dummy = self.alloc_string(0, 0)?;
        let params = DeriveParams {
            n: u32::try_from(n).map_err(|_| GpuError::CountOverflow {
                what: "input modules",
                count: n,
            })?,
            words: u32::try_from(input.words).map_err(|_| GpuError::CountOverflow {
                what: "input parameter words",
                count: input.words,
            })?,
            systems: self.jobs.len() as u32,
            iteration,
            keyed: u32::from(self.keyed),
            ..DeriveParams::default()
        };
        let pass = Pass {
            input,
            mate: &mate,
            counts: &counts,
            choice: &choice,
            out: &dummy,
            status,
        };
        self.dispatch_derive(&mut enc, self.kernels.count, &params, &pass, n + 1)?;
        record_scan(gpu, &mut enc, ScanElem::U32x2, &counts, n + 1)?;
        // Totals and status in one readback; then clear the status for the
        // rewrite (the copy is recorded before the clear).
        let tot = gpu.storage("totals", 8 + 4 * u64::from(STATUS_WORDS))?;
        enc.copy_buffer_to_buffer(&counts, 8 * n, &tot, 0, Some(8));
        enc.copy_buffer_to_buffer(status, 0, &tot, 8, Some(4 * u64::from(STATUS_WORDS)));
        enc.clear_buffer(status, 0, None);
        let words = gpu.read::<u32>(enc, &[(&tot, 0, 2 + u64::from(STATUS_WORDS))])?;
        let words = words.into_iter().next().unwrap_or_default();
        let word = |k: usize| words.get(k).copied().unwrap_or(0);
        let (m, w) = (u64::from(word(0)), u64::from(word(1)));
        let st = words.get(2..).unwrap_or(&[]);
        // The previous rewrite's errors come first (an earlier iteration);
        // its input's ranges are the saved directory.
        self.check_status(st, 1, iteration - 1, None, previous)?;
        self.check_status(st, 0, iteration, Some(input), &self.tables)?;
        // A saturated module count is over any module limit below it: the
        // limit is reported, as the CPU reports it (R0201), before the
        // indices that could not hold the string anyway.
        if (word(0) == u32::MAX && opts.max_modules >= u64::from(u32::MAX))
            || (word(0) != u32::MAX && word(1) == u32::MAX)
        {
            return Err(GpuError::CountOverflow {
                what: "derived modules or parameter words",
                count: m.max(w),
            });
        }
        if m > opts.max_modules {
            return Err(GpuError::ModuleLimit {
                iteration,
                modules: m,
                limit: opts.max_modules,
            });
        }
        let bytes = input.bytes() + scratch + self.string_bytes(m, w);
        if bytes > opts.max_bytes {
            return Err(GpuError::MemoryLimit {
                iteration,
                bytes,
                limit: opts.max_bytes,
            });
        }
        let out = self.alloc_string(m, w)?;
        let mut enc = gpu.encoder();
        let pass = Pass {
            input,
            mate: &mate,
            counts: &counts,
            choice: &choice,
            out: &out,
            status,
        };
        self.dispatch_derive(&mut enc, self.rewrite_kernel(), &params, &pass, n)?;
        // The last start is the total of parameter words (the scan's total).
        enc.copy_buffer_to_buffer(&counts, 8 * n + 4, &out.starts, 4 * m, Some(4));
        // Every system's range in the new string (the old one kept for
        // error reports).
        let dir_bytes = (self.directory.len() * std::mem::size_of::<SystemEntry>()) as u64;
        enc.copy_buffer_to_buffer(&self.tables, 0, previous, 0, Some(dir_bytes));
        let u = gpu.uniform("directory params", &params);
        gpu.dispatch(
            &mut enc,
            &kernels::UPDATE_DIRECTORY,
            &[&u, &self.tables, &counts],
            groups_for(self.jobs.len() as u64),
        )?;
        if opts.sync_iterations {
            gpu.submit_wait(enc)?;
        } else {
            gpu.queue().submit([enc.finish()]);
        }
        scratch_bufs.extend([mate, counts, choice, tot]);
        scratch_bufs.extend(dummy.into_buffers());
        gpu.recycle(scratch_bufs);
        Ok(out)
    }

    /// Turn an error slot of the status words into a typed error; `dir`
    /// holds the ranges of the string the failing pass read.
    pub(super) fn check_status(
        &self,
        st: &[u32],
        slot: usize,
        iteration: u32,
        input: Option<&DeviceString>,
        dir: &wgpu::Buffer,
    ) -> Result<(), GpuError> {
        let (inv, bits) = (
            st.get(2 * slot).copied().unwrap_or(0),
            st.get(2 * slot + 1).copied().unwrap_or(0),
        );
        if inv == 0 {
            return Ok(());
        }
        let global = u64::from(u32::MAX - inv);
        // Which system, and the position within it.
        let entries = self
            .gpu
            .read::<SystemEntry>(self.gpu.encoder(), &[(dir, 0, self.jobs.len() as u64)])?
            .pop()
            .unwrap_or_default();
        let (system, start) = entries
            .iter()
            .enumerate()
            .find(|(_, e)| u64::from(e.start) <= global && global < u64::from(e.end))
            .map_or((0, 0), |(k, e)| (k as u32, u64::from(e.start)));
        // The symbol of the failing module (for the message), when the
        // input string is the one that failed.
        let symbol = match input {
            Some(s) if global < s.len => self
                .gpu
                .read::<u32>(self.gpu.encoder(), &[(&s.syms, global, 1)])
                .ok()
                .and_then(|v| v.into_iter().next())
                .and_then(|v| v.first().copied())
                .and_then(|sym| {
                    self.jobs.get(system as usize).and_then(|j| {
                        j.system
                            .symbol_names
                            .get((sym & SYM_MASK) as usize)
                            .cloned()
                    })
                }),
            _ => None,
        };
        Err(GpuError::Runtime {
            system,
            iteration,
            position: global - start,
            symbol: symbol.unwrap_or_default(),
            kind: kind_of(bits),
        })
    }
}

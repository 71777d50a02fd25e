//! Device timestamps: how long the kernels themselves ran, apart from the
//! host's set-up, submission, synchronisation and read-back.
//!
//! Written by the batched derivation when profiling is on
//! ([`Gpu::set_profiling`]; the benchmarks turn it on for separate runs):
//! every iteration is one compute pass, stamped at its beginning and end,
//! and with `TIMESTAMP_QUERY_INSIDE_PASSES` after each kernel stage too.
//! Timestamps only measure: with profiling off, or on a device without
//! them, the derivation is the same and reports `None`.
//!
//! Invariant: the query set is resolved into a buffer that is read back in
//! the same submission as the derivation's own results, so measuring adds
//! no synchronisation.

use std::time::Duration;

use crate::device::{Gpu, Timestamps};

/// The kernels of one batched iteration, in dispatch order, as stamped:
/// "count" is `count_scan` (the count and the scan's first level), "scan"
/// the levels above it.
pub const KERNEL_STAGES: [&str; 5] = ["count", "scan", "next", "rewrite", "directory"];

/// Device time of one iteration: the whole pass, and each stage when the
/// device stamps inside passes (in [`KERNEL_STAGES`] order).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct DeviceTime {
    /// The iteration's pass, beginning to end.
    pub pass: Duration,
    /// From the beginning of the first iteration's pass to the end of this
    /// one (the gaps between passes included).
    pub end: Duration,
    pub stages: Option<[Duration; 5]>,
}

/// A query set for `passes` passes and the buffer it resolves into.
pub(crate) struct Stamps {
    set: wgpu::QuerySet,
    resolved: wgpu::Buffer,
    per_pass: u32,
    passes: u32,
    inside: bool,
    period_ns: f64,
}

impl Stamps {
    /// Stamps for `passes` passes, or `None` when profiling is off
    /// ([`Gpu::set_profiling`]) or the device writes none.
    pub(crate) fn new(gpu: &Gpu, passes: u32) -> Option<Stamps> {
        let inside = match gpu.profiling() {
            Timestamps::None => return None,
            Timestamps::Passes => false,
            Timestamps::InsidePasses => true,
        };
        // Beginning, one after each stage but the last, end.
        let per_pass = if inside {
            KERNEL_STAGES.len() as u32 + 1
        } else {
            2
        };
        let count = per_pass.checked_mul(passes)?;
        if count == 0 || count > wgpu::QUERY_SET_MAX_QUERIES {
            return None;
        }
        let set = gpu.device().create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("derive timestamps"),
            ty: wgpu::QueryType::Timestamp,
            count,
        });
        let resolved = gpu.device().create_buffer(&wgpu::BufferDescriptor {
            label: Some("derive timestamps resolved"),
            size: 8 * u64::from(count),
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        Some(Stamps {
            set,
            resolved,
            per_pass,
            passes,
            inside,
            period_ns: f64::from(gpu.timestamp_period()),
        })
    }

    /// The pass-level writes of pass `k` (its beginning and end).
    pub(crate) fn pass_writes(&self, k: u32) -> Option<wgpu::ComputePassTimestampWrites<'_>> {
        (k < self.passes).then(|| wgpu::ComputePassTimestampWrites {
            query_set: &self.set,
            beginning_of_pass_write_index: Some(k * self.per_pass),
            end_of_pass_write_index: Some(k * self.per_pass + self.per_pass - 1),
        })
    }

    /// Stamp the end of stage `stage` (not the last) inside pass `k`.
    pub(crate) fn after_stage(&self, pass: &mut wgpu::ComputePass<'_>, k: u32, stage: u32) {
        if self.inside && k < self.passes && stage + 1 < self.per_pass - 1 {
            pass.write_timestamp(&self.set, k * self.per_pass + 1 + stage);
        }
    }

    /// Record the resolution of every query into the read-back buffer.
    pub(crate) fn resolve(&self, enc: &mut wgpu::CommandEncoder) {
        enc.resolve_query_set(&self.set, 0..self.per_pass * self.passes, &self.resolved, 0);
    }

    /// The buffer to read back, and its length in `u32` words.
    pub(crate) fn readback(&self) -> (&wgpu::Buffer, u64) {
        (&self.resolved, 2 * u64::from(self.per_pass * self.passes))
    }

    /// Per pass, from the words read back. Ticks that go backwards (a
    /// device that resets its counter) count as zero.
    pub(crate) fn times(&self, words: &[u32]) -> Vec<DeviceTime> {
        let ticks: Vec<u64> = words
            .chunks_exact(2)
            .map(|w| u64::from(w[0]) | (u64::from(w[1]) << 32))
            .collect();
        let span = |a: u64, b: u64| {
            Duration::from_nanos((b.saturating_sub(a) as f64 * self.period_ns).round() as u64)
        };
        let origin = ticks.first().copied().unwrap_or(0);
        ticks
            .chunks_exact(self.per_pass as usize)
            .map(|t| {
                let (first, last) = (t[0], t[t.len() - 1]);
                DeviceTime {
                    pass: span(first, last),
                    end: span(origin, last),
                    stages: self.inside.then(|| {
                        let mut s = [Duration::ZERO; 5];
                        for (j, d) in s.iter_mut().enumerate() {
                            *d = span(t[j], t[j + 1]);
                        }
                        s
                    }),
                }
            })
            .collect()
    }
}

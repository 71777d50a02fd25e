//! The GPU context: one adapter, device and queue per process, shared by
//! every engine call (and by all tests), plus the pipeline cache, buffer
//! helpers, limit checks and dispatch splitting.

use std::collections::HashMap;
use std::sync::{Arc, Mutex, MutexGuard, OnceLock};

use wgpu::util::DeviceExt;

use crate::error::GpuError;
use crate::shader::Kernel;

/// Threads per workgroup of every 1D kernel (the shaders use the same
/// constant, from the generated header).
pub const WORKGROUP: u32 = 256;

/// The smallest buffer created: at least one element of every array type
/// a kernel declares (wgpu checks bindings against the element size).
const MIN_BUFFER: u64 = 256;

/// The most device memory the buffer pool keeps between uses.
pub const POOL_BYTES: u64 = 2 << 30;

/// Storage buffers the largest kernel binds (`shaders/count_scan.wgsl`
/// and the batched `rewrite_out`: 15 with their parameters and the
/// identity keys).
pub const MIN_STORAGE_BUFFERS: u32 = 15;

/// The shared GPU: adapter facts, device, queue, compiled pipelines.
#[derive(Debug)]
pub struct Gpu {
    device: wgpu::Device,
    queue: wgpu::Queue,
    info: wgpu::AdapterInfo,
    limits: wgpu::Limits,
    /// Set by the device-lost callback.
    lost: Arc<Mutex<Option<String>>>,
    /// Errors no error scope caught (kept instead of wgpu's default panic).
    uncaptured: Arc<Mutex<Vec<String>>>,
    pipelines: Mutex<HashMap<&'static str, Arc<Pipeline>>>,
    /// Recycled storage buffers ([`Gpu::storage`], [`Gpu::recycle`]).
    pool: Mutex<Pool<wgpu::Buffer>>,
    /// Buffers created so far and their bytes ([`Gpu::allocated`]).
    created: [std::sync::atomic::AtomicU64; 2],
    /// Times the host has waited for the device ([`Gpu::waits`]).
    waits: std::sync::atomic::AtomicU64,
    /// Serialises engine runs: error scopes are per thread, and two large
    /// derivations at once could together exceed memory that each alone fits.
    run: Mutex<()>,
    /// Workgroups per grid dimension the dispatches use (at most the
    /// device's limit; lowered by [`Gpu::limit_dispatch_width`]).
    grid_width: std::sync::atomic::AtomicU32,
    /// Which device timestamps the adapter can write (requested when
    /// offered; they only measure, they never change a result).
    timestamps: Timestamps,
    /// The timestamps derivations write now ([`Gpu::set_profiling`]):
    /// `Timestamps as u8`, at most `timestamps`.
    profiling: std::sync::atomic::AtomicU8,
}

/// The device timestamps the engine can write: none, at the beginning and
/// end of compute passes (`TIMESTAMP_QUERY`), or also between the
/// dispatches of a pass (`TIMESTAMP_QUERY_INSIDE_PASSES`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Timestamps {
    None = 0,
    Passes = 1,
    InsidePasses = 2,
}

/// Buffers the engine has created on the device (cumulative, per
/// process): what a run allocates is the difference of two readings. A
/// repeated run of the same work should take its large buffers from the
/// pool and create only small ones (parameters, read-back staging).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Allocations {
    pub buffers: u64,
    pub bytes: u64,
}

impl std::ops::Sub for Allocations {
    type Output = Allocations;
    fn sub(self, o: Allocations) -> Allocations {
        Allocations {
            buffers: self.buffers.saturating_sub(o.buffers),
            bytes: self.bytes.saturating_sub(o.bytes),
        }
    }
}

/// A compiled kernel with its explicit bind group layout.
#[derive(Debug)]
pub(crate) struct Pipeline {
    pub(crate) pipeline: wgpu::ComputePipeline,
    pub(crate) layout: wgpu::BindGroupLayout,
    pub(crate) kernel: &'static Kernel,
}

static SHARED: OnceLock<Result<Gpu, GpuError>> = OnceLock::new();

/// The process-wide GPU, created on first use. Every later call returns the
/// same device (or the same error).
pub fn shared() -> Result<&'static Gpu, GpuError> {
    SHARED.get_or_init(Gpu::new).as_ref().map_err(Clone::clone)
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    // A poisoned lock only means another thread panicked while holding it;
    // the data (a cache or a flag) is still consistent.
    m.lock().unwrap_or_else(|e| e.into_inner())
}

impl Gpu {
    /// Open the best adapter (high-performance preference; `WGPU_ADAPTER_NAME`
    /// picks one by name) and create a device with the adapter's own limits.
    pub fn new() -> Result<Gpu, GpuError> {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
        // wgpu validates every indirect dispatch with a compute pass and a
        // copy of its own. The engine's indirect arguments are computed on
        // the device within the limits by construction (`batch_next` and
        // `depth_starts` split their grids at the width the host checked),
        // so that validation only adds passes: it stays on where the
        // user's WGPU_VALIDATION_INDIRECT_CALL asks for it, and on Windows,
        // where D3D12 needs it for `num_workgroups`, which the kernels read.
        if std::env::var_os("WGPU_VALIDATION_INDIRECT_CALL").is_none() && !cfg!(windows) {
            desc.flags
                .remove(wgpu::InstanceFlags::VALIDATION_INDIRECT_CALL);
        }
        let instance = wgpu::Instance::new(desc);
        let adapter = match std::env::var("WGPU_ADAPTER_NAME") {
            Ok(name) => {
                let name = name.to_lowercase();
                pollster::block_on(instance.enumerate_adapters(wgpu::Backends::all()))
                    .into_iter()
                    .find(|a| a.get_info().name.to_lowercase().contains(&name))
                    .ok_or_else(|| GpuError::NoAdapter(format!("no adapter named like {name:?}")))?
            }
            Err(_) => pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
                power_preference: wgpu::PowerPreference::HighPerformance,
                force_fallback_adapter: false,
                compatible_surface: None,
                apply_limit_buckets: false,
            }))
            .map_err(|e| GpuError::NoAdapter(e.to_string()))?,
        };
        let info = adapter.get_info();
        let limits = adapter.limits();
        if limits.max_storage_buffers_per_shader_stage < MIN_STORAGE_BUFFERS {
            return Err(GpuError::RequestDevice(format!(
                "{} allows {} storage buffers per shader stage; the kernels need {MIN_STORAGE_BUFFERS}",
                info.name, limits.max_storage_buffers_per_shader_stage
            )));
        }
        let offered = adapter.features();
        let timestamps = if offered.contains(
            wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::TIMESTAMP_QUERY_INSIDE_PASSES,
        ) {
            Timestamps::InsidePasses
        } else if offered.contains(wgpu::Features::TIMESTAMP_QUERY) {
            Timestamps::Passes
        } else {
            Timestamps::None
        };
        let required_features = match timestamps {
            Timestamps::None => wgpu::Features::empty(),
            Timestamps::Passes => wgpu::Features::TIMESTAMP_QUERY,
            Timestamps::InsidePasses => {
                wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::TIMESTAMP_QUERY_INSIDE_PASSES
            }
        };
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("grm-gpu"),
            required_features,
            required_limits: limits.clone(),
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        }))
        .map_err(|e| GpuError::RequestDevice(e.to_string()))?;
        let lost = Arc::new(Mutex::new(None));
        let l2 = lost.clone();
        device.set_device_lost_callback(move |reason, msg| {
            *lock(&l2) = Some(format!("{reason:?}: {msg}"));
        });
        let uncaptured = Arc::new(Mutex::new(Vec::new()));
        let u2 = uncaptured.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            lock(&u2).push(e.to_string());
        }));
        Ok(Gpu {
            grid_width: std::sync::atomic::AtomicU32::new(
                limits.max_compute_workgroups_per_dimension,
            ),
            limits: device.limits(),
            device,
            queue,
            info,
            lost,
            uncaptured,
            pipelines: Mutex::new(HashMap::new()),
            pool: Mutex::new(Pool::new(POOL_BYTES)),
            created: Default::default(),
            waits: Default::default(),
            run: Mutex::new(()),
            timestamps,
            profiling: std::sync::atomic::AtomicU8::new(Timestamps::None as u8),
        })
    }

    /// Which device timestamps this device writes.
    pub fn timestamps(&self) -> Timestamps {
        self.timestamps
    }

    /// Which timestamps derivations write from now on (benchmarks): off by
    /// default, since stamps between kernels can serialise the device's
    /// work and so slow what they measure. Capped at what the device
    /// supports; returns the level set.
    pub fn set_profiling(&self, level: Timestamps) -> Timestamps {
        let level = level.min(self.timestamps);
        self.profiling
            .store(level as u8, std::sync::atomic::Ordering::Relaxed);
        level
    }

    /// The level set by [`Gpu::set_profiling`].
    pub fn profiling(&self) -> Timestamps {
        match self.profiling.load(std::sync::atomic::Ordering::Relaxed) {
            0 => Timestamps::None,
            1 => Timestamps::Passes,
            _ => Timestamps::InsidePasses,
        }
    }

    /// Nanoseconds per timestamp tick.
    pub fn timestamp_period(&self) -> f32 {
        self.queue.get_timestamp_period()
    }

    /// The adapter: name, backend, device type (lavapipe reports `Cpu`).
    pub fn adapter_info(&self) -> &wgpu::AdapterInfo {
        &self.info
    }

    /// One line for logs and benchmark output.
    pub fn describe(&self) -> String {
        format!(
            "{} ({:?}, {:?}, driver {} {})",
            self.info.name,
            self.info.backend,
            self.info.device_type,
            self.info.driver,
            self.info.driver_info
        )
    }

    /// Whether the adapter is a software rasteriser on the CPU (lavapipe,
    /// llvmpipe, WARP): right for tests, meaningless for GPU timings.
    pub fn is_software(&self) -> bool {
        self.info.device_type == wgpu::DeviceType::Cpu
    }

    pub fn limits(&self) -> &wgpu::Limits {
        &self.limits
    }

    pub(crate) fn device(&self) -> &wgpu::Device {
        &self.device
    }

    pub(crate) fn queue(&self) -> &wgpu::Queue {
        &self.queue
    }

    /// Run `f` as one engine operation: serialised with other operations,
    /// with every wgpu error turned into a [`GpuError`].
    pub(crate) fn run<T>(&self, f: impl FnOnce() -> Result<T, GpuError>) -> Result<T, GpuError> {
        let _guard = lock(&self.run);
        self.check_lost()?;
        let oom = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let val = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let int = self.device.push_error_scope(wgpu::ErrorFilter::Internal);
        let result = f();
        let mut errors = Vec::new();
        for scope in [int, val, oom] {
            if let Some(e) = pollster::block_on(scope.pop()) {
                errors.push(e.to_string());
            }
        }
        errors.append(&mut lock(&self.uncaptured));
        self.check_lost()?;
        if !errors.is_empty() {
            return Err(GpuError::Device(errors.join("; ")));
        }
        result
    }

    fn check_lost(&self) -> Result<(), GpuError> {
        match lock(&self.lost).as_ref() {
            Some(m) => Err(GpuError::DeviceLost(m.clone())),
            None => Ok(()),
        }
    }

    /// The compiled pipeline of a kernel (compiled once, then cached).
    pub(crate) fn pipeline(&self, kernel: &'static Kernel) -> Result<Arc<Pipeline>, GpuError> {
        if let Some(p) = lock(&self.pipelines).get(kernel.name) {
            return Ok(p.clone());
        }
        let source = kernel.source()?;
        let module = self
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(kernel.name),
                source: wgpu::ShaderSource::Wgsl(source.into()),
            });
        let entries: Vec<wgpu::BindGroupLayoutEntry> = kernel
            .bindings
            .iter()
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupLayoutEntry {
                binding: i as u32,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: match b {
                    crate::shader::Bind::Uniform => wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    crate::shader::Bind::Read => wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Storage { read_only: true },
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    crate::shader::Bind::ReadWrite => wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Storage { read_only: false },
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                },
                count: None,
            })
            .collect();
        let layout = self
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some(kernel.name),
                entries: &entries,
            });
        let pl = self
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(kernel.name),
                bind_group_layouts: &[Some(&layout)],
                immediate_size: 0,
            });
        let pipeline = self
            .device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(kernel.name),
                layout: Some(&pl),
                module: &module,
                entry_point: Some(kernel.entry),
                compilation_options: wgpu::PipelineCompilationOptions::default(),
                cache: None,
            });
        let p = Arc::new(Pipeline {
            pipeline,
            layout,
            kernel,
        });
        lock(&self.pipelines).insert(kernel.name, p.clone());
        Ok(p)
    }

    // ---- limits -------------------------------------------------------

    /// Check that a storage buffer of `bytes` may be created and bound.
    pub fn check_storage(&self, what: &'static str, bytes: u64) -> Result<(), GpuError> {
        check_storage_limits(&self.limits, what, bytes)
    }

    /// The 2D grid for `groups` workgroups (x at most
    /// `max_compute_workgroups_per_dimension`; kernels linearise
    /// `id.x + id.y * num_workgroups.x` and skip ids past the end).
    pub fn grid(&self, what: &'static str, groups: u64) -> Result<(u32, u32), GpuError> {
        grid_for(
            self.grid_width(),
            self.limits.max_compute_workgroups_per_dimension,
            what,
            groups,
        )
    }

    /// Workgroups per dimension of a dispatch grid.
    pub fn grid_width(&self) -> u32 {
        self.grid_width.load(std::sync::atomic::Ordering::Relaxed)
    }

    /// Use at most `width` workgroups per grid dimension (at least 1, at
    /// most the device's limit), so that small dispatches are split over
    /// 2D grids too: for testing the grid code on small inputs. Affects
    /// every later dispatch of this device.
    pub fn limit_dispatch_width(&self, width: u32) {
        let w = width.clamp(1, self.limits.max_compute_workgroups_per_dimension);
        self.grid_width
            .store(w, std::sync::atomic::Ordering::Relaxed);
    }

    // ---- buffers ------------------------------------------------------

    /// Buffers created on this device so far ([`Allocations`]).
    pub fn allocated(&self) -> Allocations {
        use std::sync::atomic::Ordering::Relaxed;
        Allocations {
            buffers: self.created[0].load(Relaxed),
            bytes: self.created[1].load(Relaxed),
        }
    }

    /// How many times the host has waited for the device to finish a
    /// submission (cumulative, per process; a run's is the difference of
    /// two readings): the synchronisations that a GPU's latency is paid
    /// for, whatever the work.
    pub fn waits(&self) -> u64 {
        self.waits.load(std::sync::atomic::Ordering::Relaxed)
    }

    /// Count a buffer about to be created.
    fn creating(&self, bytes: u64) {
        use std::sync::atomic::Ordering::Relaxed;
        self.created[0].fetch_add(1, Relaxed);
        self.created[1].fetch_add(bytes, Relaxed);
    }

    /// A storage buffer holding `data` (at least 4 bytes: wgpu rejects
    /// empty bindings).
    pub(crate) fn upload<T: bytemuck::Pod>(
        &self,
        what: &'static str,
        data: &[T],
    ) -> Result<wgpu::Buffer, GpuError> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        self.check_storage(what, bytes.len() as u64)?;
        let padded;
        let contents = if bytes.len() < MIN_BUFFER as usize || !bytes.len().is_multiple_of(4) {
            let mut v = bytes.to_vec();
            v.resize(bytes.len().next_multiple_of(4).max(MIN_BUFFER as usize), 0);
            padded = v;
            &padded[..]
        } else {
            bytes
        };
        self.creating(contents.len() as u64);
        Ok(self
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(what),
                contents,
                usage: wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::COPY_SRC
                    | wgpu::BufferUsages::COPY_DST,
            }))
    }

    /// A new, zeroed storage buffer of `bytes` (at least [`MIN_BUFFER`]).
    pub(crate) fn storage_zeroed(
        &self,
        what: &'static str,
        bytes: u64,
    ) -> Result<wgpu::Buffer, GpuError> {
        self.check_storage(what, bytes)?;
        Ok(self.create_storage(what, bytes.max(MIN_BUFFER).next_multiple_of(4)))
    }

    fn create_storage(&self, what: &'static str, size: u64) -> wgpu::Buffer {
        self.creating(size);
        self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(what),
            size,
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_SRC
                | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    /// A storage buffer of at least `bytes`, from the pool of recycled
    /// buffers when one fits (its contents are then undefined: every
    /// kernel writes what it later reads), else a new one with room to
    /// grow ([`size_class`], within the device's limits). Reusing buffers
    /// saves allocating and zeroing them in every iteration and run.
    pub(crate) fn storage(&self, what: &'static str, bytes: u64) -> Result<wgpu::Buffer, GpuError> {
        self.check_storage(what, bytes)?;
        let want = bytes.max(MIN_BUFFER).next_multiple_of(4);
        if let Some(b) = lock(&self.pool).take(want) {
            return Ok(b);
        }
        let limit = self
            .limits
            .max_storage_buffer_binding_size
            .min(self.limits.max_buffer_size)
            & !3;
        let size = size_class(want).min(limit).max(want);
        Ok(self.create_storage(what, size))
    }

    /// Give a buffer from [`Gpu::storage`] back for reuse (later submissions
    /// are ordered after the ones already recorded with it). The pool keeps
    /// at most [`POOL_BYTES`], evicting the least recently given back
    /// buffers for newer ones; [`Gpu::trim`] empties it.
    pub(crate) fn recycle(&self, buffers: impl IntoIterator<Item = wgpu::Buffer>) {
        let mut pool = lock(&self.pool);
        for b in buffers {
            if b.usage().contains(wgpu::BufferUsages::STORAGE)
                && !b.usage().contains(wgpu::BufferUsages::UNIFORM)
            {
                pool.give(b);
            }
        }
    }

    /// Free every pooled buffer.
    pub fn trim(&self) {
        lock(&self.pool).clear();
    }

    /// A uniform buffer with the parameters of one dispatch.
    pub(crate) fn uniform<T: bytemuck::Pod>(&self, what: &'static str, value: &T) -> wgpu::Buffer {
        self.creating(std::mem::size_of::<T>() as u64);
        self.device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(what),
                contents: bytemuck::bytes_of(value),
                usage: wgpu::BufferUsages::UNIFORM,
            })
    }

    /// Record one dispatch of `groups` workgroups of `kernel` with `buffers`
    /// bound in order (binding 0, 1, ...).
    pub(crate) fn dispatch(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        kernel: &'static Kernel,
        buffers: &[&wgpu::Buffer],
        groups: u64,
    ) -> Result<(), GpuError> {
        if groups == 0 {
            return Ok(());
        }
        let (x, y) = self.grid(kernel.name, groups)?;
        let p = self.pipeline(kernel)?;
        let bg = self.bind_group(&p, buffers)?;
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(p.kernel.name),
            timestamp_writes: None,
        });
        pass.set_pipeline(&p.pipeline);
        pass.set_bind_group(0, &bg, &[]);
        pass.dispatch_workgroups(x, y, 1);
        Ok(())
    }

    /// Record one indirect dispatch: the workgroup counts are three `u32`
    /// at byte `offset` of `args` (written by an earlier kernel).
    pub(crate) fn dispatch_indirect(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        kernel: &'static Kernel,
        buffers: &[&wgpu::Buffer],
        args: &wgpu::Buffer,
        offset: u64,
    ) -> Result<(), GpuError> {
        let p = self.pipeline(kernel)?;
        let bg = self.bind_group(&p, buffers)?;
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(p.kernel.name),
            timestamp_writes: None,
        });
        pass.set_pipeline(&p.pipeline);
        pass.set_bind_group(0, &bg, &[]);
        pass.dispatch_workgroups_indirect(args, offset);
        Ok(())
    }

    /// A kernel's pipeline with `buffers` bound (binding 0, 1, ...), to
    /// record several dispatches in one compute pass.
    pub(crate) fn bound(
        &self,
        kernel: &'static Kernel,
        buffers: &[&wgpu::Buffer],
    ) -> Result<Bound, GpuError> {
        let ranges: Vec<(&wgpu::Buffer, u64, Option<u64>)> =
            buffers.iter().map(|&b| (b, 0, None)).collect();
        self.bound_ranges(kernel, &ranges)
    }

    /// As [`Gpu::bound`], each binding a range of its buffer: (buffer,
    /// byte offset, bytes; `None`: to the end). Offsets must be multiples
    /// of the device's `min_storage_buffer_offset_alignment`
    /// ([`Gpu::storage_offset_alignment`]).
    pub(crate) fn bound_ranges(
        &self,
        kernel: &'static Kernel,
        ranges: &[(&wgpu::Buffer, u64, Option<u64>)],
    ) -> Result<Bound, GpuError> {
        let p = self.pipeline(kernel)?;
        let bg = self.bind_group_ranges(&p, ranges)?;
        Ok(Bound {
            pipeline: p,
            bind_group: bg,
        })
    }

    /// The alignment of storage binding offsets, in bytes.
    pub(crate) fn storage_offset_alignment(&self) -> u64 {
        u64::from(self.limits.min_storage_buffer_offset_alignment.max(4))
    }

    fn bind_group(
        &self,
        p: &Pipeline,
        buffers: &[&wgpu::Buffer],
    ) -> Result<wgpu::BindGroup, GpuError> {
        let ranges: Vec<(&wgpu::Buffer, u64, Option<u64>)> =
            buffers.iter().map(|&b| (b, 0, None)).collect();
        self.bind_group_ranges(p, &ranges)
    }

    fn bind_group_ranges(
        &self,
        p: &Pipeline,
        buffers: &[(&wgpu::Buffer, u64, Option<u64>)],
    ) -> Result<wgpu::BindGroup, GpuError> {
        if buffers.len() != p.kernel.bindings.len() {
            return Err(GpuError::Device(format!(
                "internal: kernel {} takes {} bindings, got {}",
                p.kernel.name,
                p.kernel.bindings.len(),
                buffers.len()
            )));
        }
        let entries: Vec<wgpu::BindGroupEntry> = buffers
            .iter()
            .enumerate()
            .map(|(i, &(buffer, offset, size))| wgpu::BindGroupEntry {
                binding: i as u32,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer,
                    offset,
                    size: size.and_then(wgpu::BufferSize::new),
                }),
            })
            .collect();
        Ok(self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(p.kernel.name),
            layout: &p.layout,
            entries: &entries,
        }))
    }

    /// A buffer of indirect dispatch arguments (filled by copying from a
    /// storage buffer: a dispatch may not write the buffer it reads its
    /// arguments from).
    pub(crate) fn indirect(
        &self,
        what: &'static str,
        bytes: u64,
    ) -> Result<wgpu::Buffer, GpuError> {
        self.indirect_with(what, bytes, wgpu::BufferUsages::COPY_DST)
    }

    /// A zeroed storage buffer that is also read as indirect dispatch
    /// arguments (a kernel writes the arguments of later dispatches in
    /// place; wgpu orders the write before the indirect read).
    pub(crate) fn indirect_storage(
        &self,
        what: &'static str,
        bytes: u64,
    ) -> Result<wgpu::Buffer, GpuError> {
        use wgpu::BufferUsages as U;
        self.indirect_with(what, bytes, U::STORAGE | U::COPY_SRC | U::COPY_DST)
    }

    fn indirect_with(
        &self,
        what: &'static str,
        bytes: u64,
        usage: wgpu::BufferUsages,
    ) -> Result<wgpu::Buffer, GpuError> {
        self.check_storage(what, bytes)?;
        let size = bytes.max(MIN_BUFFER).next_multiple_of(4);
        self.creating(size);
        Ok(self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(what),
            size,
            usage: wgpu::BufferUsages::INDIRECT | usage,
            mapped_at_creation: false,
        }))
    }

    pub(crate) fn encoder(&self) -> wgpu::CommandEncoder {
        self.device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("grm-gpu"),
            })
    }

    /// Submit `encoder` without waiting for it: what is recorded after it
    /// runs after it (one queue), and the next wait covers it.
    pub(crate) fn submit(&self, encoder: wgpu::CommandEncoder) {
        self.queue.submit([encoder.finish()]);
    }

    /// Submit `encoder` and wait for the GPU to finish.
    pub(crate) fn submit_wait(&self, encoder: wgpu::CommandEncoder) -> Result<(), GpuError> {
        self.waits
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let idx = self.queue.submit([encoder.finish()]);
        self.device
            .poll(wgpu::PollType::Wait {
                submission_index: Some(idx),
                timeout: None,
            })
            .map_err(|e| GpuError::Device(e.to_string()))?;
        Ok(())
    }

    /// Submit `encoder`, then copy `ranges` (buffer, first element, count
    /// of `T`) back to the host and return them.
    pub(crate) fn read<T: bytemuck::Pod>(
        &self,
        mut encoder: wgpu::CommandEncoder,
        ranges: &[(&wgpu::Buffer, u64, u64)],
    ) -> Result<Vec<Vec<T>>, GpuError> {
        let size = std::mem::size_of::<T>() as u64;
        let mut stagings = Vec::new();
        for &(buf, first, count) in ranges {
            let bytes = (count * size).next_multiple_of(4).max(4);
            self.creating(bytes);
            let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("readback"),
                size: bytes,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            if count > 0 {
                encoder.copy_buffer_to_buffer(
                    buf,
                    first * size,
                    &staging,
                    0,
                    Some((count * size).next_multiple_of(4)),
                );
            }
            stagings.push((staging, count));
        }
        self.submit_wait(encoder)?;
        let mut out = Vec::new();
        for (staging, count) in stagings {
            let slice = staging.slice(..);
            let status = Arc::new(Mutex::new(None));
            let s2 = status.clone();
            slice.map_async(wgpu::MapMode::Read, move |r| *lock(&s2) = Some(r));
            self.device
                .poll(wgpu::PollType::Wait {
                    submission_index: None,
                    timeout: None,
                })
                .map_err(|e| GpuError::Readback(e.to_string()))?;
            match lock(&status).take() {
                Some(Ok(())) => {}
                Some(Err(e)) => return Err(GpuError::Readback(e.to_string())),
                None => return Err(GpuError::Readback("buffer was not mapped".into())),
            }
            let data = slice
                .get_mapped_range()
                .map_err(|e| GpuError::Readback(e.to_string()))?;
            let n = (count * size) as usize;
            out.push(bytemuck::pod_collect_to_vec::<u8, T>(&data[..n]));
            drop(data);
            staging.unmap();
        }
        Ok(out)
    }
}

/// A kernel with its buffers bound, ready to dispatch in a compute pass.
#[derive(Debug)]
pub(crate) struct Bound {
    pipeline: Arc<Pipeline>,
    bind_group: wgpu::BindGroup,
}

impl Bound {
    /// Record an indirect dispatch into `pass` (workgroup counts: three
    /// `u32` at byte `offset` of `args`).
    pub(crate) fn dispatch_indirect(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        args: &wgpu::Buffer,
        offset: u64,
    ) {
        pass.set_pipeline(&self.pipeline.pipeline);
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.dispatch_workgroups_indirect(args, offset);
    }

    /// Record a direct dispatch of an `(x, y)` grid into `pass`.
    pub(crate) fn dispatch(&self, pass: &mut wgpu::ComputePass<'_>, (x, y): (u32, u32)) {
        if x == 0 || y == 0 {
            return;
        }
        pass.set_pipeline(&self.pipeline.pipeline);
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.dispatch_workgroups(x, y, 1);
    }
}

/// The storage-buffer checks, separate from a device so they can be tested
/// with any limits.
pub fn check_storage_limits(
    limits: &wgpu::Limits,
    what: &'static str,
    bytes: u64,
) -> Result<(), GpuError> {
    if bytes > limits.max_storage_buffer_binding_size {
        return Err(GpuError::BufferTooLarge {
            what,
            bytes,
            limit: limits.max_storage_buffer_binding_size,
            limit_name: "max_storage_buffer_binding_size",
        });
    }
    if bytes > limits.max_buffer_size {
        return Err(GpuError::BufferTooLarge {
            what,
            bytes,
            limit: limits.max_buffer_size,
            limit_name: "max_buffer_size",
        });
    }
    Ok(())
}

/// The 2D grid for `groups` workgroups: at most `max_x` wide, at most
/// `max_y` high.
pub fn grid_for(
    max_x: u32,
    max_y: u32,
    what: &'static str,
    groups: u64,
) -> Result<(u32, u32), GpuError> {
    let mx = u64::from(max_x.max(1));
    let my = u64::from(max_y.max(1));
    if groups <= mx {
        return Ok((groups as u32, 1));
    }
    let y = groups.div_ceil(mx);
    if y > my {
        return Err(GpuError::TooManyWorkgroups {
            what,
            workgroups: groups,
            limit: mx * my,
        });
    }
    Ok((mx as u32, y as u32))
}

/// Something the pool can hold: its size in bytes.
pub(crate) trait Pooled {
    fn bytes(&self) -> u64;
}

impl Pooled for wgpu::Buffer {
    fn bytes(&self) -> u64 {
        self.size()
    }
}

/// Recycled buffers, least recently given back first, holding at most
/// `limit` bytes: a buffer given back when the pool is full evicts the
/// oldest ones (the buffers of the work at hand are the likely next
/// requests, not those of some earlier, different run).
#[derive(Debug)]
pub(crate) struct Pool<B> {
    items: std::collections::VecDeque<B>,
    held: u64,
    limit: u64,
}

impl<B: Pooled> Pool<B> {
    pub(crate) fn new(limit: u64) -> Pool<B> {
        Pool {
            items: Default::default(),
            held: 0,
            limit,
        }
    }

    /// The smallest item of at least `want` bytes and not more than 4x
    /// too big (or 64 KiB), removed from the pool.
    pub(crate) fn take(&mut self, want: u64) -> Option<B> {
        let cap = want.saturating_mul(4).max(64 * 1024);
        let i = self
            .items
            .iter()
            .enumerate()
            .filter(|(_, b)| b.bytes() >= want && b.bytes() <= cap)
            .min_by_key(|(_, b)| b.bytes())
            .map(|(i, _)| i)?;
        let b = self.items.remove(i)?;
        self.held -= b.bytes();
        Some(b)
    }

    /// Keep `b` (dropped if it alone is over the limit), evicting the
    /// least recently given back items while the pool would be over it.
    pub(crate) fn give(&mut self, b: B) {
        let size = b.bytes();
        if size > self.limit {
            return;
        }
        while self.held + size > self.limit {
            match self.items.pop_front() {
                Some(old) => self.held -= old.bytes(),
                None => break,
            }
        }
        self.held += size;
        self.items.push_back(b);
    }

    pub(crate) fn clear(&mut self) {
        self.items.clear();
        self.held = 0;
    }

    #[cfg(test)]
    fn sizes(&self) -> Vec<u64> {
        self.items.iter().map(Pooled::bytes).collect()
    }
}

/// The size a new pooled buffer of at least `bytes` gets: the next of
/// the sizes 4, 5, 6, 7 x 2^k (at most 25% above the request, so that
/// the buffers of a large run, counted against [`POOL_BYTES`], stay in the
/// pool; powers of two wasted up to half of it). Below 1 KiB: the next
/// power of two, at least `MIN_BUFFER`.
pub fn size_class(bytes: u64) -> u64 {
    let b = bytes.max(MIN_BUFFER);
    if b < 1024 {
        return b.next_power_of_two();
    }
    let k = 63 - b.leading_zeros(); // 2^k <= b < 2^(k+1), k >= 10
    let step = 1u64 << (k - 2);
    b.div_ceil(step).saturating_mul(step)
}

/// Workgroups of [`WORKGROUP`] threads for `n` items.
pub fn groups_for(n: u64) -> u64 {
    n.div_ceil(u64::from(WORKGROUP))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_splits_past_the_limit() {
        assert_eq!(grid_for(65535, 65535, "t", 10).unwrap(), (10, 1));
        assert_eq!(grid_for(65535, 65535, "t", 65535).unwrap(), (65535, 1));
        assert_eq!(grid_for(65535, 65535, "t", 65536).unwrap(), (65535, 2));
        let (x, y) = grid_for(100, 100, "t", 1234).unwrap();
        assert!(u64::from(x) * u64::from(y) >= 1234 && x == 100 && y == 13);
        assert!(matches!(
            grid_for(100, 100, "t", 100 * 100 + 1),
            Err(GpuError::TooManyWorkgroups { .. })
        ));
        assert_eq!(grid_for(3, 65535, "t", 10).unwrap(), (3, 4));
    }

    impl Pooled for u64 {
        fn bytes(&self) -> u64 {
            *self
        }
    }

    #[test]
    fn the_pool_takes_the_best_fit_and_evicts_the_oldest() {
        let mut p: Pool<u64> = Pool::new(1000 * 1024);
        for b in [300, 100, 200, 150].map(|k| k * 1024) {
            p.give(b);
        }
        // Best fit, within 4x.
        assert_eq!(p.take(120 * 1024), Some(150 * 1024));
        assert_eq!(p.take(40 * 1024), Some(100 * 1024));
        assert_eq!(p.take(40 * 1024), None, "200 KiB is over 4x of 40");
        assert_eq!(p.sizes(), vec![300 * 1024, 200 * 1024]);
        // Full: the oldest (300) makes room for the newest.
        p.give(600 * 1024);
        assert_eq!(p.sizes(), vec![200 * 1024, 600 * 1024]);
        p.give(500 * 1024);
        assert_eq!(p.sizes(), vec![500 * 1024]);
        // Over the limit alone: not kept, nothing evicted.
        p.give(2000 * 1024);
        assert_eq!(p.sizes(), vec![500 * 1024]);
        assert_eq!(p.held, 500 * 1024);
        p.clear();
        assert_eq!((p.sizes(), p.held), (vec![], 0));
    }

    #[test]
    fn size_classes_are_within_a_quarter_of_the_request() {
        assert_eq!(size_class(1), MIN_BUFFER);
        assert_eq!(size_class(300), 512);
        assert_eq!(size_class(64 * 1024), 64 * 1024);
        assert_eq!(size_class(64 * 1024 + 1), 80 * 1024);
        assert_eq!(size_class(570_000_000), 671_088_640); // 5 x 2^27
        let mut prev = 0;
        for b in (1..40u64).map(|k| (k * 7_919) << k.min(30)) {
            let c = size_class(b);
            assert!(c >= b && c as f64 <= b as f64 * 1.25, "{b} -> {c}");
            if b > prev {
                assert!(c >= size_class(prev));
            }
            prev = b;
        }
    }

    #[test]
    fn storage_limits_are_typed_errors() {
        let limits = wgpu::Limits {
            max_storage_buffer_binding_size: 1000,
            max_buffer_size: 2000,
            ..wgpu::Limits::default()
        };
        assert!(check_storage_limits(&limits, "x", 1000).is_ok());
        assert!(matches!(
            check_storage_limits(&limits, "x", 1001),
            Err(GpuError::BufferTooLarge {
                limit_name: "max_storage_buffer_binding_size",
                ..
            })
        ));
        let limits = wgpu::Limits {
            max_storage_buffer_binding_size: 5000,
            max_buffer_size: 2000,
            ..wgpu::Limits::default()
        };
        assert!(matches!(
            check_storage_limits(&limits, "x", 3000),
            Err(GpuError::BufferTooLarge {
                limit_name: "max_buffer_size",
                ..
            })
        ));
    }
}

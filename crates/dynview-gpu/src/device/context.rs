//! The GPU context: adapter and device acquisition, the buffer pool, and recording work on the
//! device through its [`Recorder`] (frames, dispatches, commands, queue writes, waiting).
//! Profiling is in `profile.rs`, reading back in `readback.rs`, both on top of this.

use std::sync::{Mutex, MutexGuard, PoisonError};

use crate::device::error::GpuError;
use crate::device::kernel::{Kernel, LINEAR_WORKGROUP};
use crate::device::pool::BufferPool;
use crate::device::recorder::{DispatchTarget, GpuCounters, Recorder};
use crate::device::shaders;
use crate::device::signal::Signal;

/// A device and its queue, with what the adapter is.
#[derive(Debug)]
pub struct GpuContext {
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// The adapter's name, backend and driver.
    pub adapter_info: wgpu::AdapterInfo,
    /// The instance (for surfaces: a canvas to draw into).
    pub instance: wgpu::Instance,
    /// The adapter.
    pub adapter: wgpu::Adapter,
    pub(crate) pool: BufferPool,
    /// Idle read-back staging buffers (`device::readback`).
    pub(crate) staging: crate::device::pool::StagingPool,
    /// The open encoder and pass, shared uniforms, cached bind groups, counters and profiler.
    recorder: Mutex<Recorder>,
    /// Zeros over a reused image's buffer (`shaders/zero.wgsl`), compiled on first use.
    zero: std::sync::OnceLock<Kernel>,
    /// A small storage buffer bound where a kernel's binding is unused (`placeholder`).
    placeholder: std::sync::OnceLock<wgpu::Buffer>,
}

/// Keeps a frame open: work recorded meanwhile goes into one command buffer, submitted when the
/// outermost guard drops ([`GpuContext::frame`]).
#[must_use = "the frame closes when the guard drops"]
pub struct FrameGuard<'a> {
    ctx: &'a GpuContext,
}

impl Drop for FrameGuard<'_> {
    fn drop(&mut self) {
        let mut recorder = self.ctx.recorder();
        if recorder.close_frame() {
            recorder.flush();
        }
    }
}

impl GpuContext {
    /// Requests an adapter (any backend this build has; the software one when nothing else)
    /// and a device with the adapter's own limits on buffer sizes and dispatches (inputs and
    /// outputs of any size a camera gives where the adapter allows them), WebGPU's defaults
    /// otherwise.
    pub async fn new() -> Result<Self, GpuError> {
        Self::with_limits(None).await
    }

    /// [`Self::new`] with the device's limits given (`None`: as [`Self::new`] asks); tests ask
    /// for small ones to exercise what large inputs need.
    pub async fn with_limits(limits: Option<wgpu::Limits>) -> Result<Self, GpuError> {
        // Backends and validation from WGPU_BACKEND / WGPU_VALIDATION etc. when set; debug
        // builds validate.
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let adapter = instance
            .request_adapter(&wgpu::RequestAdapterOptions {
                power_preference: wgpu::PowerPreference::HighPerformance,
                ..Default::default()
            })
            .await
            .map_err(|e| GpuError::NoAdapter(e.to_string()))?;
        let adapter_info = adapter.get_info();
        let own = adapter.limits();
        let required_limits = limits.unwrap_or_else(|| wgpu::Limits {
            max_buffer_size: own.max_buffer_size,
            max_storage_buffer_binding_size: own.max_storage_buffer_binding_size,
            max_compute_workgroups_per_dimension: own.max_compute_workgroups_per_dimension,
            ..wgpu::Limits::default().using_resolution(own)
        });
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("dynview"),
                required_limits,
                // For `cargo xtask bench`'s time per stage, where the adapter has them.
                required_features: adapter.features() & wgpu::Features::TIMESTAMP_QUERY,
                ..Default::default()
            })
            .await
            .map_err(|e| GpuError::NoDevice(e.to_string()))?;
        let recorder = Mutex::new(Recorder::new(&device, &queue));
        Ok(Self {
            device,
            queue,
            adapter_info,
            instance,
            adapter,
            pool: BufferPool::default(),
            staging: Default::default(),
            recorder,
            zero: Default::default(),
            placeholder: Default::default(),
        })
    }

    /// The zero-fill kernel.
    pub(crate) fn zero_kernel(&self) -> &Kernel {
        self.zero
            .get_or_init(|| Kernel::new(&self.device, &shaders::module(&self.device, shaders::ZERO), "zero", &[false], LINEAR_WORKGROUP))
    }

    /// A 16-byte storage buffer for a binding the dispatch does not use (a kernel's partial
    /// sums when the views are in one chunk).
    pub(crate) fn placeholder(&self) -> &wgpu::Buffer {
        self.placeholder.get_or_init(|| {
            self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("placeholder"),
                size: 16,
                usage: wgpu::BufferUsages::STORAGE,
                mapped_at_creation: false,
            })
        })
    }

    /// The recorder, locked (a poisoned lock is taken over: the recorder stays consistent).
    pub(super) fn recorder(&self) -> MutexGuard<'_, Recorder> {
        self.recorder.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Opens a frame: everything recorded until the guard drops is submitted at once, in one
    /// command buffer (frames nest; the outermost submits). Outside a frame every operation is
    /// submitted when it is recorded.
    pub fn frame(&self) -> FrameGuard<'_> {
        self.recorder().open_frame();
        FrameGuard { ctx: self }
    }

    /// Submits what was recorded so far, even inside a frame (before a read-back or a present).
    pub fn flush(&self) {
        self.recorder().flush();
    }

    /// Submits, passes, dispatches, bind groups created, uniform bytes and bytes bound so far.
    pub fn counters(&self) -> GpuCounters {
        self.recorder().counters
    }

    /// Records dispatches of `kernel` (see [`Recorder::dispatch`]); submitted at once outside a
    /// frame.
    pub(crate) fn dispatch(
        &self,
        kernel: &DispatchTarget<'_>,
        uniforms: &[&[u8]],
        sequence: &[usize],
        buffers: &[&wgpu::Buffer],
        groups: (u32, u32, u32),
    ) {
        let mut recorder = self.recorder();
        recorder.dispatch(kernel, uniforms, sequence, buffers, groups);
        if !recorder.in_frame() {
            recorder.flush();
        }
    }

    /// Records commands (copies, clears, render passes) with `record`, in order with the
    /// dispatches; submitted at once outside a frame. `record` must not use the context.
    pub(crate) fn encode<R>(&self, record: impl FnOnce(&mut wgpu::CommandEncoder) -> R) -> R {
        let mut recorder = self.recorder();
        let out = record(recorder.encoder());
        if !recorder.in_frame() {
            recorder.flush();
        }
        out
    }

    /// The most bytes one storage buffer may hold and bind on this device.
    pub fn storage_limit_bytes(&self) -> u64 {
        let limits = self.device.limits();
        limits.max_storage_buffer_binding_size.min(limits.max_buffer_size)
    }

    /// Counts a bind group made outside the recorder (the display's, once per draw).
    pub(crate) fn note_bind_group(&self) {
        self.recorder().counters.bind_groups_created += 1;
    }

    /// Writes `data` into `buffer` at `offset`, after the work recorded so far (which is
    /// submitted first when there is any: a queue write lands before the next submit's commands).
    pub(crate) fn write_buffer(&self, buffer: &wgpu::Buffer, offset: u64, data: &[u8]) {
        let mut recorder = self.recorder();
        if recorder.pending() {
            recorder.flush();
        }
        self.queue.write_buffer(buffer, offset, data);
    }

    /// Idle pooled buffers and their bytes (images dropped since, kept for reuse).
    pub fn pooled(&self) -> (usize, u64) {
        let pool = self.pool.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        pool.iter().fold((0, 0), |(n, bytes), (size, buffers)| (n + buffers.len(), bytes + size * buffers.len() as u64))
    }

    /// Blocks until the GPU has finished all submitted work (native; a no-op on WebGPU).
    pub fn wait(&self) -> Result<(), GpuError> {
        self.flush();
        self.device.poll(wgpu::PollType::wait_indefinitely()).map(|_| ()).map_err(|e| GpuError::ReadBack(e.to_string()))
    }

    /// Resolves when the GPU has finished the work submitted so far (natively after waiting
    /// for it; in the browser from the event loop, without blocking).
    pub async fn finished(&self) -> Result<(), GpuError> {
        self.flush();
        let signal = Signal::default();
        let callback = signal.clone();
        self.queue.on_submitted_work_done(move || callback.fire(Ok(())));
        #[cfg(not(target_family = "wasm"))]
        self.wait()?;
        signal.await.map_err(|e| GpuError::ReadBack(e.to_string()))
    }

    /// [`GpuContext::new`], blocking (native only).
    #[cfg(not(target_family = "wasm"))]
    pub fn new_blocking() -> Result<Self, GpuError> {
        pollster::block_on(Self::new())
    }

    /// [`GpuContext::with_limits`], blocking (native only).
    #[cfg(not(target_family = "wasm"))]
    pub fn with_limits_blocking(limits: wgpu::Limits) -> Result<Self, GpuError> {
        pollster::block_on(Self::with_limits(Some(limits)))
    }
}

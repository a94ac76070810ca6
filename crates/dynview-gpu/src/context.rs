//! Adapter and device acquisition.

/// Errors of the GPU path.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    /// No adapter (no GPU driver, no lavapipe, no WebGPU).
    #[error("no GPU adapter: {0} (natively, install a Vulkan driver; on Debian `mesa-vulkan-drivers` provides lavapipe)")]
    NoAdapter(String),
    /// The adapter refused a device.
    #[error("the GPU adapter refused a device: {0}")]
    NoDevice(String),
    /// A read-back failed (device lost, timeout).
    #[error("reading GPU results back failed: {0}")]
    ReadBack(String),
    /// The inputs do not fit (sizes disagree, or beyond the device's limits).
    #[error("{0}")]
    Size(String),
    /// A parameter or input is invalid for the GPU path (out of range, unsupported, or
    /// missing), whatever the sizes.
    #[error("invalid {field}: {reason}")]
    InvalidParams {
        /// The parameter or input, by name (a `RenderParams` field where it is one).
        field: &'static str,
        /// What is wrong with it.
        reason: String,
    },
}

/// Storage buffers no longer in use, by size in bytes: images of the sizes a frame needs are
/// allocated once and reused by every later frame of the same resolution.
pub(crate) type BufferPool = std::sync::Arc<std::sync::Mutex<std::collections::HashMap<u64, Vec<wgpu::Buffer>>>>;

/// Most idle buffers kept per size.
pub(crate) const POOL_BUFFERS_PER_SIZE: usize = 64;

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
    /// Timestamps per compute pass while a profile is being taken.
    profiler: std::sync::Mutex<Option<crate::profile::Profiler>>,
}

impl GpuContext {
    /// Requests an adapter (any backend this build has; the software one when nothing else)
    /// and a device with WebGPU's default limits.
    pub async fn new() -> Result<Self, GpuError> {
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
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("dynview"),
                required_limits: wgpu::Limits::default().using_resolution(adapter.limits()),
                // For `cargo xtask bench`'s time per stage, where the adapter has them.
                required_features: adapter.features() & wgpu::Features::TIMESTAMP_QUERY,
                ..Default::default()
            })
            .await
            .map_err(|e| GpuError::NoDevice(e.to_string()))?;
        Ok(Self { device, queue, adapter_info, instance, adapter, pool: BufferPool::default(), profiler: Default::default() })
    }

    /// Starts timing every compute pass (timestamp queries) until [`Self::finish_profile`];
    /// false when the device has no timestamp queries.
    pub fn start_profile(&self) -> bool {
        if !self.device.features().contains(wgpu::Features::TIMESTAMP_QUERY) {
            return false;
        }
        *self.profiler.lock().unwrap_or_else(std::sync::PoisonError::into_inner) = Some(crate::profile::Profiler::new());
        true
    }

    /// Stops timing and returns GPU milliseconds per level and stage since
    /// [`Self::start_profile`] (empty when it was not started). Blocks until the GPU is done.
    #[cfg(not(target_family = "wasm"))]
    pub fn finish_profile(&self) -> Result<Vec<crate::profile::StageTime>, GpuError> {
        let profiler = self.profiler.lock().unwrap_or_else(std::sync::PoisonError::into_inner).take();
        profiler.map_or(Ok(Vec::new()), |p| p.finish(self))
    }

    /// Labels the compute passes that follow (while profiling).
    pub(crate) fn set_stage(&self, level: usize, stage: &'static str) {
        if let Some(p) = self.profiler.lock().unwrap_or_else(std::sync::PoisonError::into_inner).as_mut() {
            p.set_stage(level, stage);
        }
    }

    /// Begins a compute pass on `encoder`; while profiling, it writes its start and end
    /// timestamps under the current stage.
    pub(crate) fn begin_compute_pass<'e>(&self, encoder: &'e mut wgpu::CommandEncoder, label: Option<&str>) -> wgpu::ComputePass<'e> {
        let timestamps =
            self.profiler.lock().unwrap_or_else(std::sync::PoisonError::into_inner).as_mut().map(|p| p.next_pass(&self.device));
        let timestamp_writes = timestamps.as_ref().map(|(query_set, first)| wgpu::ComputePassTimestampWrites {
            query_set,
            beginning_of_pass_write_index: Some(*first),
            end_of_pass_write_index: Some(first + 1),
        });
        encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label, timestamp_writes })
    }

    /// Idle pooled buffers and their bytes (images dropped since, kept for reuse).
    pub fn pooled(&self) -> (usize, u64) {
        let pool = self.pool.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        pool.iter().fold((0, 0), |(n, bytes), (size, buffers)| (n + buffers.len(), bytes + size * buffers.len() as u64))
    }

    /// Blocks until the GPU has finished all submitted work (native; a no-op on WebGPU).
    pub fn wait(&self) -> Result<(), GpuError> {
        self.device.poll(wgpu::PollType::wait_indefinitely()).map(|_| ()).map_err(|e| GpuError::ReadBack(e.to_string()))
    }

    /// Resolves when the GPU has finished the work submitted so far (natively after waiting
    /// for it; in the browser from the event loop, without blocking).
    pub async fn finished(&self) -> Result<(), GpuError> {
        let signal = crate::readback::Signal::default();
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
}

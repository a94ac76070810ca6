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
}

/// A device and its queue, with what the adapter is.
#[derive(Debug)]
pub struct GpuContext {
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// The adapter's name, backend and driver.
    pub adapter_info: wgpu::AdapterInfo,
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
                ..Default::default()
            })
            .await
            .map_err(|e| GpuError::NoDevice(e.to_string()))?;
        Ok(Self { device, queue, adapter_info })
    }

    /// Blocks until the GPU has finished all submitted work (native; a no-op on WebGPU).
    pub fn wait(&self) -> Result<(), GpuError> {
        self.device.poll(wgpu::PollType::wait_indefinitely()).map(|_| ()).map_err(|e| GpuError::ReadBack(e.to_string()))
    }

    /// [`GpuContext::new`], blocking (native only).
    #[cfg(not(target_family = "wasm"))]
    pub fn new_blocking() -> Result<Self, GpuError> {
        pollster::block_on(Self::new())
    }
}

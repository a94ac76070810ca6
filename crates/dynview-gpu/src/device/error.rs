//! The errors of the GPU path: no adapter or device, a failed read-back, inputs that do not fit
//! the device, and invalid parameters.

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

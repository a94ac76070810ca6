//! The pool of idle storage buffers that images are taken from ([`crate::GpuImage`]), by size
//! in bytes, shared by the context and every image it made.

/// Storage buffers no longer in use, by size in bytes: images of the sizes a frame needs are
/// allocated once and reused by every later frame of the same resolution. Each size's idle
/// buffers are ordered (by wgpu's identity) and the first is taken: which buffer a frame gets
/// depends on which are idle, not on the order they came back, so frames that begin with the
/// same idle buffers use the same buffers in the same roles, and their bind groups are reused.
pub(crate) type BufferPool = std::sync::Arc<std::sync::Mutex<std::collections::HashMap<u64, std::collections::BTreeSet<wgpu::Buffer>>>>;

/// Most idle buffers kept per size.
pub(crate) const POOL_BUFFERS_PER_SIZE: usize = 64;

/// Idle read-back staging buffers (`MAP_READ | COPY_DST`), reused by `device::readback` for
/// reads of the same size.
pub(crate) type StagingPool = std::sync::Mutex<Vec<wgpu::Buffer>>;

//! Reading GPU buffers back through a staging buffer: without blocking the thread, a future that
//! resolves when wgpu has mapped the staging buffer (natively the device is polled to
//! completion first; in the browser the map callback arrives from the event loop), or natively
//! blocking until it has.

use crate::device::{context::GpuContext, error::GpuError, signal::Signal};

/// The first `len` floats of `buffer` (which must have `COPY_SRC`), through a staging buffer.
pub async fn read_floats(ctx: &GpuContext, buffer: &wgpu::Buffer, len: usize) -> Result<Vec<f32>, GpuError> {
    let bytes = read_bytes(ctx, buffer, (len * 4) as u64).await?;
    Ok(bytemuck::pod_collect_to_vec(&bytes))
}

/// The first `size` bytes of `buffer` (which must have `COPY_SRC`), through a staging buffer.
pub async fn read_bytes(ctx: &GpuContext, buffer: &wgpu::Buffer, size: u64) -> Result<Vec<u8>, GpuError> {
    let staging = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("read-back"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    ctx.encode(|encoder| encoder.copy_buffer_to_buffer(buffer, 0, &staging, 0, size));
    ctx.flush();
    let slice = staging.slice(..);
    let signal = Signal::default();
    let callback = signal.clone();
    slice.map_async(wgpu::MapMode::Read, move |result| callback.fire(result));
    #[cfg(not(target_family = "wasm"))]
    ctx.wait()?;
    signal.await.map_err(|e| GpuError::ReadBack(e.to_string()))?;
    let out = slice.get_mapped_range().map_err(|e| GpuError::ReadBack(e.to_string()))?.to_vec();
    staging.unmap();
    Ok(out)
}

/// Reads `buffer` (which must have `COPY_SRC`) into `out`; blocks until the GPU is done
/// (native only).
#[cfg(not(target_family = "wasm"))]
pub(crate) fn read_floats_blocking(ctx: &GpuContext, buffer: &wgpu::Buffer, out: &mut [f32]) -> Result<(), GpuError> {
    let floats = pollster::block_on(read_floats(ctx, buffer, out.len()))?;
    out.copy_from_slice(&floats);
    Ok(())
}

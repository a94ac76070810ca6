//! Reading GPU buffers back through a staging buffer: without blocking the thread, a future that
//! resolves when wgpu has mapped the staging buffer (natively the device is polled to
//! completion first; in the browser the map callback arrives from the event loop), or natively
//! blocking until it has. Staging buffers are reused (a playback frame reads back buffers of the
//! same sizes every time) and the mapped bytes are copied once, straight into the caller's
//! elements.

use crate::device::{context::GpuContext, error::GpuError, signal::Signal};

/// Idle staging buffers kept for reuse; more sizes than this in turn are allocated afresh.
const STAGING_BUFFERS_KEPT: usize = 4;

/// An idle staging buffer of exactly `size` bytes, or a new one.
fn take_staging(ctx: &GpuContext, size: u64) -> wgpu::Buffer {
    let mut idle = ctx.staging.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    match idle.iter().position(|b| b.size() == size) {
        Some(i) => idle.swap_remove(i),
        None => ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("read-back"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        }),
    }
}

/// Gives an unmapped staging buffer back (the oldest idle one goes when too many are kept).
fn give_back_staging(ctx: &GpuContext, staging: wgpu::Buffer) {
    let mut idle = ctx.staging.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    if idle.len() >= STAGING_BUFFERS_KEPT {
        idle.remove(0);
    }
    idle.push(staging);
}

/// Copies the first `size_of_val(out)` bytes of `buffer` (which must have `COPY_SRC`; the size
/// a multiple of 4) into `out`, through a staging buffer.
pub(crate) async fn read_into<T: bytemuck::Pod>(ctx: &GpuContext, buffer: &wgpu::Buffer, out: &mut [T]) -> Result<(), GpuError> {
    let size = std::mem::size_of_val(out) as u64;
    if size == 0 {
        return Ok(());
    }
    if size > buffer.size() || !size.is_multiple_of(wgpu::COPY_BUFFER_ALIGNMENT) {
        return Err(GpuError::Size(format!("a read-back of {size} bytes from a buffer of {}", buffer.size())));
    }
    let staging = take_staging(ctx, size);
    ctx.encode(|encoder| encoder.copy_buffer_to_buffer(buffer, 0, &staging, 0, size));
    ctx.flush();
    let slice = staging.slice(..);
    let signal = Signal::default();
    let callback = signal.clone();
    slice.map_async(wgpu::MapMode::Read, move |result| callback.fire(result));
    #[cfg(not(target_family = "wasm"))]
    ctx.wait()?;
    signal.await.map_err(|e| GpuError::ReadBack(e.to_string()))?;
    {
        let mapped = slice.get_mapped_range().map_err(|e| GpuError::ReadBack(e.to_string()))?;
        bytemuck::cast_slice_mut::<T, u8>(out).copy_from_slice(&mapped);
    }
    staging.unmap();
    give_back_staging(ctx, staging);
    Ok(())
}

/// The first `len` floats of `buffer` (which must have `COPY_SRC`), through a staging buffer.
pub async fn read_floats(ctx: &GpuContext, buffer: &wgpu::Buffer, len: usize) -> Result<Vec<f32>, GpuError> {
    let mut out = vec![0.0f32; len];
    read_into(ctx, buffer, &mut out).await?;
    Ok(out)
}

/// The first `size` bytes of `buffer` (which must have `COPY_SRC`; `size` a multiple of 4),
/// through a staging buffer.
pub async fn read_bytes(ctx: &GpuContext, buffer: &wgpu::Buffer, size: u64) -> Result<Vec<u8>, GpuError> {
    let len = usize::try_from(size).map_err(|_| GpuError::Size(format!("a read-back of {size} bytes")))?;
    let mut out = vec![0u8; len];
    read_into(ctx, buffer, &mut out).await?;
    Ok(out)
}

/// Reads `buffer` (which must have `COPY_SRC`) into `out`; blocks until the GPU is done
/// (native only).
#[cfg(not(target_family = "wasm"))]
pub(crate) fn read_blocking<T: bytemuck::Pod>(ctx: &GpuContext, buffer: &wgpu::Buffer, out: &mut [T]) -> Result<(), GpuError> {
    pollster::block_on(read_into(ctx, buffer, out))
}

//! Reading GPU buffers back without blocking the thread: a future that resolves when wgpu has
//! mapped the staging buffer. Natively the device is polled to completion first; in the
//! browser the map callback arrives from the event loop.

use std::future::Future;
use std::pin::Pin;
use std::sync::{Arc, Mutex, PoisonError};
use std::task::{Context, Poll, Waker};

use crate::context::{GpuContext, GpuError};

#[derive(Default)]
struct SignalState {
    result: Option<Result<(), wgpu::BufferAsyncError>>,
    waker: Option<Waker>,
}

/// A future that resolves when a wgpu callback (`map_async`, `on_submitted_work_done`) fires
/// it; a clone goes into the callback.
#[derive(Clone, Default)]
pub(crate) struct Signal(Arc<Mutex<SignalState>>);

impl Signal {
    /// Resolves the future with `result`.
    pub(crate) fn fire(&self, result: Result<(), wgpu::BufferAsyncError>) {
        let mut state = self.0.lock().unwrap_or_else(PoisonError::into_inner);
        state.result = Some(result);
        if let Some(waker) = state.waker.take() {
            waker.wake();
        }
    }
}

impl Future for Signal {
    type Output = Result<(), wgpu::BufferAsyncError>;

    fn poll(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Self::Output> {
        let mut state = self.0.lock().unwrap_or_else(PoisonError::into_inner);
        match state.result.take() {
            Some(result) => Poll::Ready(result),
            None => {
                state.waker = Some(cx.waker().clone());
                Poll::Pending
            }
        }
    }
}

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

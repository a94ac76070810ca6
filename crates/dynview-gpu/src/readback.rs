//! Reading GPU buffers back without blocking the thread: a future that resolves when wgpu has
//! mapped the staging buffer. Natively the device is polled to completion first; in the
//! browser the map callback arrives from the event loop.

use std::future::Future;
use std::pin::Pin;
use std::sync::{Arc, Mutex, PoisonError};
use std::task::{Context, Poll, Waker};

use crate::context::{GpuContext, GpuError};

#[derive(Default)]
struct MapState {
    result: Option<Result<(), wgpu::BufferAsyncError>>,
    waker: Option<Waker>,
}

/// Resolves when the `map_async` callback has run.
struct Mapped(Arc<Mutex<MapState>>);

impl Future for Mapped {
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
    let size = (len * 4) as u64;
    let staging = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("read-back"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("read-back") });
    encoder.copy_buffer_to_buffer(buffer, 0, &staging, 0, size);
    ctx.queue.submit([encoder.finish()]);
    let slice = staging.slice(..);
    let state = Arc::new(Mutex::new(MapState::default()));
    let callback_state = state.clone();
    slice.map_async(wgpu::MapMode::Read, move |result| {
        let mut s = callback_state.lock().unwrap_or_else(PoisonError::into_inner);
        s.result = Some(result);
        if let Some(waker) = s.waker.take() {
            waker.wake();
        }
    });
    #[cfg(not(target_family = "wasm"))]
    ctx.wait()?;
    Mapped(state).await.map_err(|e| GpuError::ReadBack(e.to_string()))?;
    let out = {
        let view = slice.get_mapped_range().map_err(|e| GpuError::ReadBack(e.to_string()))?;
        bytemuck::cast_slice::<u8, f32>(&view).to_vec()
    };
    staging.unmap();
    Ok(out)
}

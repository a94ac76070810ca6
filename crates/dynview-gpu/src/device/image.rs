//! Images on the GPU: flat `f32` storage buffers, `channels` per pixel, taken from the context's
//! buffer pool and given back to it when dropped; a reused buffer is cleared by the zero kernel
//! (`shaders/zero.wgsl`) where the image must start at zero.

use wgpu::util::DeviceExt;

use crate::device::context::GpuContext;
use crate::device::error::GpuError;
use crate::device::pool::{BufferPool, POOL_BUFFERS_PER_SIZE};
#[cfg(not(target_family = "wasm"))]
use crate::device::readback::read_blocking;
use crate::device::readback::read_floats;
#[cfg(test)]
use crate::device::shaders;

/// An image in a storage buffer. Its buffer comes from, and goes back to when dropped, the
/// context's pool.
pub struct GpuImage {
    /// The pixels, `channels` floats each, row-major.
    pub buffer: wgpu::Buffer,
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Floats per pixel (1 to 4).
    pub channels: usize,
    pool: BufferPool,
}

impl std::fmt::Debug for GpuImage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuImage")
            .field("width", &self.width)
            .field("height", &self.height)
            .field("channels", &self.channels)
            .finish_non_exhaustive()
    }
}

impl Drop for GpuImage {
    // The pool's keys are wgpu's identities, which never change.
    #[allow(clippy::mutable_key_type)]
    fn drop(&mut self) {
        let mut pool = self.pool.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        let idle = pool.entry(self.buffer.size()).or_default();
        if idle.len() < POOL_BUFFERS_PER_SIZE {
            idle.insert(self.buffer.clone());
        }
    }
}

/// `zero.wgsl`'s uniform block.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct ZeroParams {
    words: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

/// Records zeros over `buffer` (a dispatch, which stays in the frame's compute pass).
fn zero(ctx: &GpuContext, buffer: &wgpu::Buffer) {
    let words = (buffer.size() / 4) as usize;
    let params = ZeroParams { words: words as u32, _pad0: 0, _pad1: 0, _pad2: 0 };
    ctx.zero_kernel().dispatch(ctx, bytemuck::bytes_of(&params), &[buffer], words, 1);
}

const IMAGE_USAGE: wgpu::BufferUsages = wgpu::BufferUsages::STORAGE.union(wgpu::BufferUsages::COPY_SRC).union(wgpu::BufferUsages::COPY_DST);

impl GpuImage {
    fn check(ctx: &GpuContext, width: usize, height: usize, channels: usize) -> Result<u64, GpuError> {
        if width == 0 || height == 0 || !(1..=4).contains(&channels) {
            return Err(GpuError::Size(format!("image of {width}x{height}x{channels}: empty or unsupported channel count")));
        }
        let bytes = (width as u64) * (height as u64) * (channels as u64) * 4;
        let limit = ctx.storage_limit_bytes();
        if bytes > limit {
            return Err(GpuError::Size(format!(
                "image of {width}x{height}x{channels} needs {bytes} bytes, the device binds at most {limit}"
            )));
        }
        Ok(bytes)
    }

    /// Uploads `data` (`width * height * channels` floats).
    pub fn upload(ctx: &GpuContext, data: &[f32], width: usize, height: usize, channels: usize) -> Result<Self, GpuError> {
        Self::check(ctx, width, height, channels)?;
        if data.len() != width * height * channels {
            return Err(GpuError::Size(format!("{} floats for an image of {width}x{height}x{channels}", data.len())));
        }
        let size = Self::check(ctx, width, height, channels)?;
        let buffer = match Self::take(ctx, size) {
            Some(buffer) => {
                ctx.write_buffer(&buffer, 0, bytemuck::cast_slice(data));
                buffer
            }
            None => ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("image"),
                contents: bytemuck::cast_slice(data),
                usage: IMAGE_USAGE,
            }),
        };
        Ok(Self { buffer, width, height, channels, pool: ctx.pool.clone() })
    }

    /// An idle pooled buffer of `size` bytes.
    fn take(ctx: &GpuContext, size: u64) -> Option<wgpu::Buffer> {
        ctx.pool.lock().unwrap_or_else(std::sync::PoisonError::into_inner).get_mut(&size).and_then(std::collections::BTreeSet::pop_first)
    }

    /// An image of zeros (a reused buffer is cleared on the GPU first).
    pub fn zeroed(ctx: &GpuContext, width: usize, height: usize, channels: usize) -> Result<Self, GpuError> {
        let size = Self::check(ctx, width, height, channels)?;
        let buffer = match Self::take(ctx, size) {
            Some(buffer) => {
                zero(ctx, &buffer);
                buffer
            }
            None => ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("image"),
                size,
                usage: IMAGE_USAGE,
                mapped_at_creation: false,
            }),
        };
        Ok(Self { buffer, width, height, channels, pool: ctx.pool.clone() })
    }

    /// An image whose pixels the caller writes before reading any (a pooled buffer keeps its
    /// old contents: no zeroing pass).
    pub(crate) fn scratch(ctx: &GpuContext, width: usize, height: usize, channels: usize) -> Result<Self, GpuError> {
        let size = Self::check(ctx, width, height, channels)?;
        let buffer = Self::take(ctx, size).unwrap_or_else(|| {
            ctx.device.create_buffer(&wgpu::BufferDescriptor { label: Some("image"), size, usage: IMAGE_USAGE, mapped_at_creation: false })
        });
        Ok(Self { buffer, width, height, channels, pool: ctx.pool.clone() })
    }

    /// Reads the pixels back without blocking the thread (the browser's way).
    pub async fn download_async(&self, ctx: &GpuContext) -> Result<Vec<f32>, GpuError> {
        read_floats(ctx, &self.buffer, self.width * self.height * self.channels).await
    }

    /// Reads an RGB image back as a raster, blocking until the GPU is done (native only).
    #[cfg(not(target_family = "wasm"))]
    pub fn download_rgb(&self, ctx: &GpuContext) -> Result<dynview_core::raster::RgbRaster, GpuError> {
        if self.channels != 3 {
            return Err(GpuError::Size(format!("an RGB read-back of an image with {} channels", self.channels)));
        }
        let mut data = vec![[0.0f32; 3]; self.width * self.height];
        read_blocking(ctx, &self.buffer, &mut data)?;
        Ok(dynview_core::raster::Raster { width: self.width, height: self.height, data })
    }

    /// Reads the pixels back, blocking until the GPU is done (native only).
    #[cfg(not(target_family = "wasm"))]
    pub fn download(&self, ctx: &GpuContext) -> Result<Vec<f32>, GpuError> {
        let mut out = vec![0.0f32; self.width * self.height * self.channels];
        read_blocking(ctx, &self.buffer, &mut out)?;
        Ok(out)
    }
}

/// The zero kernel's uniform block mirror, checked against the WGSL (`src/layout_tests.rs`).
#[cfg(test)]
pub(crate) fn wgsl_mirrors() -> Vec<crate::device::shader_layout::Mirror> {
    use crate::device::shader_layout::mirror;
    vec![mirror!(shaders::ZERO, "Params", ZeroParams { words, _pad0, _pad1, _pad2 })]
}

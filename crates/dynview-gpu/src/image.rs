//! Images on the GPU (flat `f32` storage buffers, `channels` per pixel) and the image kernels
//! of the renderer: pyramid resampling (`shaders/pyramid.wgsl`) and push-pull hole filling
//! (`shaders/pushpull_pull.wgsl`, `shaders/pushpull_push.wgsl`).

use wgpu::util::DeviceExt;

use crate::context::{BufferPool, GpuContext, GpuError, POOL_BUFFERS_PER_SIZE};
use crate::kernel::Kernel;
use crate::shaders;

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
        crate::readback::read_floats(ctx, &self.buffer, self.width * self.height * self.channels).await
    }

    /// Reads an RGB image back as a raster, blocking until the GPU is done (native only).
    #[cfg(not(target_family = "wasm"))]
    pub fn download_rgb(&self, ctx: &GpuContext) -> Result<dynview_core::raster::RgbRaster, GpuError> {
        if self.channels != 3 {
            return Err(GpuError::Size(format!("an RGB read-back of an image with {} channels", self.channels)));
        }
        let data = self.download(ctx)?;
        Ok(dynview_core::raster::Raster {
            width: self.width,
            height: self.height,
            data: data.chunks(3).map(|c| [c[0], c[1], c[2]]).collect(),
        })
    }

    /// Reads the pixels back, blocking until the GPU is done (native only).
    #[cfg(not(target_family = "wasm"))]
    pub fn download(&self, ctx: &GpuContext) -> Result<Vec<f32>, GpuError> {
        let mut out = vec![0.0f32; self.width * self.height * self.channels];
        crate::solver::read_buffer(ctx, &self.buffer, &mut out)?;
        Ok(out)
    }
}

/// The image kernels, compiled once per device.
#[derive(Debug)]
pub struct ImageKernels {
    downsample: Kernel,
    upsample: Kernel,
    premultiply: Kernel,
    pull: Kernel,
    top: Kernel,
    push: Kernel,
}

/// `pyramid.wgsl`'s uniform block.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct PyramidDims {
    src_width: u32,
    src_height: u32,
    dst_width: u32,
    dst_height: u32,
    channels: u32,
    scale_x: f32,
    scale_y: f32,
    _pad: u32,
}

/// `pushpull_pull.wgsl`'s uniform block.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct PullDims {
    fine_width: u32,
    fine_height: u32,
    coarse_width: u32,
    coarse_height: u32,
    channels: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

/// `pushpull_push.wgsl`'s uniform block.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct PushDims {
    fine_width: u32,
    fine_height: u32,
    coarse_width: u32,
    coarse_height: u32,
    channels: u32,
    scale_x: f32,
    scale_y: f32,
    _pad: u32,
    fallback: [f32; 4],
}

/// Half a size, rounded up (as dynview-core's pyramid).
fn half(n: usize) -> usize {
    n.div_ceil(2).max(1)
}

impl ImageKernels {
    /// Compiles the kernels on `ctx`'s device.
    pub fn new(ctx: &GpuContext) -> Self {
        let pyramid = shaders::module(ctx, shaders::PYRAMID);
        let pull = shaders::module(ctx, shaders::PUSHPULL_PULL);
        let push = shaders::module(ctx, shaders::PUSHPULL_PUSH);
        let pull_bindings = [true, true, false, false];
        let push_bindings = [true, true, true, false];
        Self {
            downsample: Kernel::new(ctx, &pyramid, "downsample", &[true, false], 8),
            upsample: Kernel::new(ctx, &pyramid, "upsample", &[true, false], 8),
            premultiply: Kernel::new(ctx, &pull, "premultiply", &pull_bindings, 8),
            pull: Kernel::new(ctx, &pull, "pull", &pull_bindings, 8),
            top: Kernel::new(ctx, &push, "top", &push_bindings, 1),
            push: Kernel::new(ctx, &push, "push", &push_bindings, 8),
        }
    }

    fn resample(&self, ctx: &GpuContext, kernel: &Kernel, image: &GpuImage, width: usize, height: usize) -> Result<GpuImage, GpuError> {
        let out = GpuImage::zeroed(ctx, width, height, image.channels)?;
        let dims = PyramidDims {
            src_width: image.width as u32,
            src_height: image.height as u32,
            dst_width: width as u32,
            dst_height: height as u32,
            channels: image.channels as u32,
            scale_x: image.width as f32 / width as f32,
            scale_y: image.height as f32 / height as f32,
            _pad: 0,
        };
        kernel.dispatch(ctx, bytemuck::bytes_of(&dims), &[&image.buffer, &out.buffer], width, height);
        Ok(out)
    }

    /// 2x2 box downsampling (dynview-core's `pyramid::downsample`).
    pub fn downsample(&self, ctx: &GpuContext, image: &GpuImage) -> Result<GpuImage, GpuError> {
        self.resample(ctx, &self.downsample, image, half(image.width), half(image.height))
    }

    /// Bilinear upsampling to `width x height` (dynview-core's `pyramid::upsample`).
    pub fn upsample(&self, ctx: &GpuContext, image: &GpuImage, width: usize, height: usize) -> Result<GpuImage, GpuError> {
        self.resample(ctx, &self.upsample, image, width, height)
    }

    /// Push-pull fill of `values` where `weights` (1 channel, same size) are 0, as dynview-core's
    /// `pushpull::fill`; `fallback` (first `channels` entries) where nothing is known.
    pub fn push_pull(&self, ctx: &GpuContext, values: &GpuImage, weights: &GpuImage, fallback: [f32; 3]) -> Result<GpuImage, GpuError> {
        if (weights.width, weights.height, weights.channels) != (values.width, values.height, 1) {
            return Err(GpuError::Size(format!(
                "push-pull weights are {}x{}x{}, values {}x{}",
                weights.width, weights.height, weights.channels, values.width, values.height
            )));
        }
        let channels = values.channels;
        let pull_dims = |fine: (usize, usize), coarse: (usize, usize)| PullDims {
            fine_width: fine.0 as u32,
            fine_height: fine.1 as u32,
            coarse_width: coarse.0 as u32,
            coarse_height: coarse.1 as u32,
            channels: channels as u32,
            _pad0: 0,
            _pad1: 0,
            _pad2: 0,
        };
        let push_dims = |fine: (usize, usize), coarse: (usize, usize)| PushDims {
            fine_width: fine.0 as u32,
            fine_height: fine.1 as u32,
            coarse_width: coarse.0 as u32,
            coarse_height: coarse.1 as u32,
            channels: channels as u32,
            scale_x: coarse.0 as f32 / fine.0 as f32,
            scale_y: coarse.1 as f32 / fine.1 as f32,
            _pad: 0,
            fallback: [fallback[0], fallback[1], fallback[2], 0.0],
        };
        let _frame = ctx.frame();
        // Pull: premultiplied levels down to 1x1.
        let (w, h) = (values.width, values.height);
        let mut levels = vec![(GpuImage::zeroed(ctx, w, h, channels)?, GpuImage::zeroed(ctx, w, h, 1)?)];
        let (v0, w0) = &levels[0];
        self.premultiply.dispatch(
            ctx,
            bytemuck::bytes_of(&pull_dims((w, h), (w, h))),
            &[&values.buffer, &weights.buffer, &v0.buffer, &w0.buffer],
            w,
            h,
        );
        while levels.last().is_some_and(|(v, _)| v.width > 1 || v.height > 1) {
            let (fine_v, fine_w) = &levels[levels.len() - 1];
            let (nw, nh) = (half(fine_v.width), half(fine_v.height));
            let (cv, cw) = (GpuImage::zeroed(ctx, nw, nh, channels)?, GpuImage::zeroed(ctx, nw, nh, 1)?);
            let d = pull_dims((fine_v.width, fine_v.height), (nw, nh));
            self.pull.dispatch(ctx, bytemuck::bytes_of(&d), &[&fine_v.buffer, &fine_w.buffer, &cv.buffer, &cw.buffer], nw, nh);
            levels.push((cv, cw));
        }
        // Push: the 1x1 top (no coarser fill: its binding takes the top's weights, unread), then
        // each finer level from the coarser fill.
        let (top_v, top_w) = &levels[levels.len() - 1];
        let mut filled = GpuImage::zeroed(ctx, 1, 1, channels)?;
        self.top.dispatch(
            ctx,
            bytemuck::bytes_of(&push_dims((1, 1), (1, 1))),
            &[&top_v.buffer, &top_w.buffer, &top_w.buffer, &filled.buffer],
            1,
            1,
        );
        for (v, wt) in levels.iter().rev().skip(1) {
            let next = GpuImage::zeroed(ctx, v.width, v.height, channels)?;
            let d = push_dims((v.width, v.height), (filled.width, filled.height));
            self.push.dispatch(ctx, bytemuck::bytes_of(&d), &[&v.buffer, &wt.buffer, &filled.buffer, &next.buffer], v.width, v.height);
            filled = next;
        }
        Ok(filled)
    }
}

/// The uniform blocks' mirrors, checked against the WGSL (`shaders/layout_tests.rs`).
#[cfg(test)]
pub(crate) fn wgsl_mirrors() -> Vec<crate::shaders::layout_tests::Mirror> {
    use crate::shaders::layout_tests::mirror;
    vec![
        mirror!(shaders::ZERO, "Params", ZeroParams { words, _pad0, _pad1, _pad2 }),
        mirror!(shaders::PYRAMID, "Dims", PyramidDims { src_width, src_height, dst_width, dst_height, channels, scale_x, scale_y, _pad }),
        mirror!(
            shaders::PUSHPULL_PULL,
            "Dims",
            PullDims { fine_width, fine_height, coarse_width, coarse_height, channels, _pad0, _pad1, _pad2 }
        ),
        mirror!(
            shaders::PUSHPULL_PUSH,
            "Dims",
            PushDims { fine_width, fine_height, coarse_width, coarse_height, channels, scale_x, scale_y, _pad, fallback }
        ),
    ]
}

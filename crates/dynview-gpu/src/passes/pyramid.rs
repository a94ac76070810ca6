//! The image pyramid's kernels: 2x2 box downsampling and bilinear upsampling
//! (`shaders/pyramid.wgsl`), and push-pull hole filling, which pulls premultiplied levels down
//! to 1x1 and pushes the fill back up (`shaders/pushpull_pull.wgsl`, `shaders/pushpull_push.wgsl`).

use crate::device::{context::GpuContext, error::GpuError, image::GpuImage, kernel::Kernel, shaders};

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
        let pyramid = shaders::module(&ctx.device, shaders::PYRAMID);
        let pull = shaders::module(&ctx.device, shaders::PUSHPULL_PULL);
        let push = shaders::module(&ctx.device, shaders::PUSHPULL_PUSH);
        let pull_bindings = [true, true, false, false];
        let push_bindings = [true, true, true, false];
        Self {
            downsample: Kernel::new(&ctx.device, &pyramid, "downsample", &[true, false], 8),
            upsample: Kernel::new(&ctx.device, &pyramid, "upsample", &[true, false], 8),
            premultiply: Kernel::new(&ctx.device, &pull, "premultiply", &pull_bindings, 8),
            pull: Kernel::new(&ctx.device, &pull, "pull", &pull_bindings, 8),
            top: Kernel::new(&ctx.device, &push, "top", &push_bindings, 1),
            push: Kernel::new(&ctx.device, &push, "push", &push_bindings, 8),
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

/// The uniform blocks' mirrors, checked against the WGSL (`src/layout_tests.rs`).
#[cfg(test)]
pub(crate) fn wgsl_mirrors() -> Vec<crate::device::shader_layout::Mirror> {
    use crate::device::shader_layout::mirror;
    vec![
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

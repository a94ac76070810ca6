//! The color initial guess on the GPU (`shaders/blend.wgsl`), as dynview-core's
//! `LevelViews::blend`: the visible warps blended with per-view weights.

use crate::device::context::GpuContext;
use crate::device::error::GpuError;
use crate::device::image::GpuImage;
use crate::device::kernel::Kernel;
use crate::device::shaders;
use crate::passes::views::{partial_binding, partial_sums};
use crate::passes::warp::GpuWarps;

/// Most views the blend takes (its uniform block holds 8 weights).
pub const MAX_VIEWS: usize = 8;

/// `blend.wgsl`'s uniform block.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct BlendParams {
    width: u32,
    height: u32,
    views: u32,
    chunk: u32,
    view_weights: [f32; MAX_VIEWS],
}

/// The blend kernel, compiled once per device.
#[derive(Debug)]
pub struct BlendKernel {
    blend: Kernel,
}

impl BlendKernel {
    /// Compiles the kernel on `ctx`'s device.
    pub fn new(ctx: &GpuContext) -> Self {
        let module = shaders::module(&ctx.device, shaders::BLEND);
        Self { blend: Kernel::new(&ctx.device, &module, "blend", &[true, true, true, false, false], 8) }
    }

    /// The visibility-tested blend of the warps weighted by `view_weights` (one per view, as
    /// dynview-core's `view_ranking::ChosenViews::blend_weights`); `fallback` (RGB) where no
    /// view sees.
    pub fn blend(&self, ctx: &GpuContext, warps: &GpuWarps, fallback: &GpuImage, view_weights: &[f32]) -> Result<GpuImage, GpuError> {
        let split = warps.split();
        if split.count > MAX_VIEWS || view_weights.len() != split.count {
            return Err(GpuError::InvalidParams {
                field: "view_weights",
                reason: format!("{} views with {} weights (at most {MAX_VIEWS} views)", split.count, view_weights.len()),
            });
        }
        let (w, h) = (fallback.width, fallback.height);
        let out = GpuImage::zeroed(ctx, w, h, 3)?;
        let partial = partial_sums(ctx, split, w, h, 4)?;
        for (c, (views, chunk)) in split.iter().enumerate() {
            let mut weights = [0.0; MAX_VIEWS];
            weights[..views.len()].copy_from_slice(&view_weights[views.clone()]);
            let params = BlendParams { width: w as u32, height: h as u32, views: views.len() as u32, chunk, view_weights: weights };
            let buffers = [
                &warps.colors.chunks[c].buffer,
                &warps.visibility.chunks[c].buffer,
                &fallback.buffer,
                &out.buffer,
                partial_binding(ctx, &partial),
            ];
            self.blend.dispatch(ctx, bytemuck::bytes_of(&params), &buffers, w, h);
        }
        Ok(out)
    }
}

/// The uniform block's mirror, checked against the WGSL (`src/layout_tests.rs`).
#[cfg(test)]
pub(crate) fn wgsl_mirrors() -> Vec<crate::device::shader_layout::Mirror> {
    use crate::device::shader_layout::mirror;
    vec![mirror!(shaders::BLEND, "Params", BlendParams { width, height, views, chunk, view_weights })]
}

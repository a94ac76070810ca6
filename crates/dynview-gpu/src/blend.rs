//! The color initial guess on the GPU (`shaders/blend.wgsl`), as dynview-core's
//! `LevelViews::blend`: the visible warps blended with per-view weights.

use crate::context::{GpuContext, GpuError};
use crate::image::GpuImage;
use crate::kernel::Kernel;
use crate::shaders;
use crate::warp::GpuWarps;

/// Most views the blend takes (its uniform block holds 8 weights).
pub const MAX_VIEWS: usize = 8;

/// `blend.wgsl`'s uniform block.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct BlendParams {
    width: u32,
    height: u32,
    views: u32,
    _pad0: u32,
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
        let module = shaders::module(ctx, shaders::BLEND);
        Self { blend: Kernel::new(ctx, &module, "blend", &[true, true, true, false], 8) }
    }

    /// The visibility-tested blend of the warps weighted by `view_weights` (one per view, as
    /// dynview-core's `view_ranking::ChosenViews::blend_weights`); `fallback` (RGB) where no
    /// view sees.
    pub fn blend(&self, ctx: &GpuContext, warps: &GpuWarps, fallback: &GpuImage, view_weights: &[f32]) -> Result<GpuImage, GpuError> {
        if warps.count > MAX_VIEWS || view_weights.len() != warps.count {
            return Err(GpuError::InvalidParams {
                field: "view_weights",
                reason: format!("{} views with {} weights (at most {MAX_VIEWS} views)", warps.count, view_weights.len()),
            });
        }
        let (w, h) = (fallback.width, fallback.height);
        let out = GpuImage::zeroed(ctx, w, h, 3)?;
        let mut weights = [0.0; MAX_VIEWS];
        weights[..view_weights.len()].copy_from_slice(view_weights);
        let params = BlendParams { width: w as u32, height: h as u32, views: warps.count as u32, _pad0: 0, view_weights: weights };
        let buffers = [&warps.colors.buffer, &warps.visibility.buffer, &fallback.buffer, &out.buffer];
        self.blend.dispatch(ctx, bytemuck::bytes_of(&params), &buffers, w, h);
        Ok(out)
    }
}

/// The uniform block's mirror, checked against the WGSL (`shaders/layout_tests.rs`).
#[cfg(test)]
pub(crate) fn wgsl_mirrors() -> Vec<crate::shaders::layout_tests::Mirror> {
    use crate::shaders::layout_tests::mirror;
    vec![mirror!(shaders::BLEND, "Params", BlendParams { width, height, views, _pad0, view_weights })]
}

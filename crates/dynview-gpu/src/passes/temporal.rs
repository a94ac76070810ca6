//! The temporal terms on the GPU (`shaders/temporal_weights.wgsl`,
//! `shaders/temporal_terms.wgsl`): `w_T` as dynview-core's `render::weights::temporal_weights`,
//! and the terms `(lambda_T w_T, previous)` the depth and color systems take.

use crate::device::context::GpuContext;
use crate::device::error::GpuError;
use crate::device::image::GpuImage;
use crate::device::kernel::Kernel;
use crate::device::shaders;
use crate::passes::splat::GpuSplat;
use crate::passes::views::{partial_binding, partial_sums};
use crate::passes::warp::GpuWarps;

/// `temporal_weights.wgsl`'s uniform block.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct WeightsParams {
    width: u32,
    height: u32,
    views: u32,
    sigma: f32,
    chunk: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

/// `temporal_terms.wgsl`'s uniform block.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct TermsParams {
    width: u32,
    height: u32,
    coverage_scaling: u32,
    lambda_t: f32,
}

/// The temporal kernels, compiled once per device.
#[derive(Debug)]
pub struct TemporalKernels {
    weights: Kernel,
    terms: Kernel,
}

impl TemporalKernels {
    /// Compiles the kernels on `ctx`'s device.
    pub fn new(ctx: &GpuContext) -> Self {
        let weights = shaders::module(&ctx.device, shaders::TEMPORAL_WEIGHTS);
        let terms = shaders::module(&ctx.device, shaders::TEMPORAL_TERMS);
        Self {
            weights: Kernel::new(&ctx.device, &weights, "temporal_weights", &[true, true, true, true, false, false], 8),
            terms: Kernel::new(&ctx.device, &terms, "temporal_terms", &[true, true, true, true, false, false], 8),
        }
    }

    /// `w_T` from the previous frame splatted here and the current warps.
    pub fn temporal_weights(&self, ctx: &GpuContext, previous: &GpuSplat, warps: &GpuWarps, sigma: f32) -> Result<GpuImage, GpuError> {
        let (w, h) = (previous.mask.width, previous.mask.height);
        let w_t = GpuImage::zeroed(ctx, w, h, 1)?;
        let split = warps.split();
        let partial = partial_sums(ctx, split, w, h, 2)?;
        for (c, (views, chunk)) in split.iter().enumerate() {
            let params =
                WeightsParams { width: w as u32, height: h as u32, views: views.len() as u32, sigma, chunk, _pad0: 0, _pad1: 0, _pad2: 0 };
            let buffers = [
                &warps.colors.chunks[c].buffer,
                &warps.valid.chunks[c].buffer,
                &previous.color.buffer,
                &previous.mask.buffer,
                &w_t.buffer,
                partial_binding(ctx, &partial),
            ];
            self.weights.dispatch(ctx, bytemuck::bytes_of(&params), &buffers, w, h);
        }
        Ok(w_t)
    }

    /// The temporal terms `(lambda_T w_T, Dprev)` and `(lambda_T w_T, Iprev)`; `counters` are
    /// the consistency filter's (coverage after it in `[1]`).
    pub fn temporal_terms(
        &self,
        ctx: &GpuContext,
        w_t: &GpuImage,
        previous: &GpuSplat,
        counters: &GpuImage,
        lambda_t: f32,
        coverage_scaling: bool,
    ) -> Result<(GpuImage, GpuImage), GpuError> {
        let (w, h) = (w_t.width, w_t.height);
        let (depth_terms, color_terms) = (GpuImage::zeroed(ctx, w, h, 2)?, GpuImage::zeroed(ctx, w, h, 4)?);
        let params = TermsParams { width: w as u32, height: h as u32, coverage_scaling: u32::from(coverage_scaling), lambda_t };
        let buffers =
            [&w_t.buffer, &previous.depth.buffer, &previous.color.buffer, &counters.buffer, &depth_terms.buffer, &color_terms.buffer];
        self.terms.dispatch(ctx, bytemuck::bytes_of(&params), &buffers, w, h);
        Ok((depth_terms, color_terms))
    }
}

/// The uniform blocks' mirrors, checked against the WGSL (`src/layout_tests.rs`).
#[cfg(test)]
pub(crate) fn wgsl_mirrors() -> Vec<crate::device::shader_layout::Mirror> {
    use crate::device::shader_layout::mirror;
    vec![
        mirror!(shaders::TEMPORAL_WEIGHTS, "Params", WeightsParams { width, height, views, sigma, chunk, _pad0, _pad1, _pad2 }),
        mirror!(shaders::TEMPORAL_TERMS, "Params", TermsParams { width, height, coverage_scaling, lambda_t }),
    ]
}

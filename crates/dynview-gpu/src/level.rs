//! Small per-level kernels of the frame loop (`shaders/frame.wgsl`, `shaders/consistency.wgsl`):
//! the color initial guess, `w_T`, the temporal terms, and the sparse consistency filter.

use crate::context::{GpuContext, GpuError};
use crate::image::GpuImage;
use crate::kernel::Kernel;
use crate::splat::GpuSplat;
use crate::warp::GpuWarps;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct FrameParams {
    width: u32,
    height: u32,
    views: u32,
    coverage_scaling: u32,
    sigma: f32,
    lambda_t: f32,
    _pad: [u32; 2],
    view_weights: [f32; 8],
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct ConsistencyParams {
    width: u32,
    height: u32,
    ratio: f32,
    _pad: u32,
}

/// Most views the blend takes (the uniform block holds 8 weights).
pub const MAX_VIEWS: usize = 8;

/// The per-level kernels, compiled once per device.
#[derive(Debug)]
pub struct LevelKernels {
    blend: Kernel,
    temporal_weights: Kernel,
    temporal_terms: Kernel,
    pack_sparse: Kernel,
    count: Kernel,
    isolated: Kernel,
    occluded: Kernel,
    apply: Kernel,
}

/// Scratch for unused writable bindings.
fn scratch(ctx: &GpuContext) -> Result<GpuImage, GpuError> {
    GpuImage::zeroed(ctx, 1, 1, 1)
}

impl LevelKernels {
    /// Compiles the kernels on `ctx`'s device.
    pub fn new(ctx: &GpuContext) -> Self {
        let module = |name: &str, source: &str| {
            ctx.device
                .create_shader_module(wgpu::ShaderModuleDescriptor { label: Some(name), source: wgpu::ShaderSource::Wgsl(source.into()) })
        };
        let frame = module("frame.wgsl", include_str!("shaders/frame.wgsl"));
        let consistency = module("consistency.wgsl", include_str!("shaders/consistency.wgsl"));
        let f = [true, true, true, true, false, false];
        let c = [false, false, false, false];
        Self {
            blend: Kernel::new(ctx, &frame, "blend", &f, 8),
            temporal_weights: Kernel::new(ctx, &frame, "temporal_weights", &f, 8),
            temporal_terms: Kernel::new(ctx, &frame, "temporal_terms", &f, 8),
            pack_sparse: Kernel::new(ctx, &frame, "pack_sparse", &f, 8),
            count: Kernel::new(ctx, &consistency, "count", &c, 8),
            isolated: Kernel::new(ctx, &consistency, "isolated", &c, 8),
            occluded: Kernel::new(ctx, &consistency, "occluded", &c, 8),
            apply: Kernel::new(ctx, &consistency, "apply", &c, 8),
        }
    }

    fn frame_params(
        width: usize,
        height: usize,
        views: usize,
        sigma: f32,
        lambda_t: f32,
        coverage_scaling: bool,
        weights: &[f32],
    ) -> FrameParams {
        let mut view_weights = [0.0; 8];
        for (slot, w) in view_weights.iter_mut().zip(weights) {
            *slot = *w;
        }
        FrameParams {
            width: width as u32,
            height: height as u32,
            views: views as u32,
            coverage_scaling: u32::from(coverage_scaling),
            sigma,
            lambda_t,
            _pad: [0; 2],
            view_weights,
        }
    }

    fn run(&self, ctx: &GpuContext, kernel: &Kernel, params: &FrameParams, buffers: [&GpuImage; 6]) {
        let mut encoder = ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("level") });
        kernel.dispatch(
            ctx,
            &mut encoder,
            bytemuck::bytes_of(params),
            &buffers.map(|b| &b.buffer),
            params.width as usize,
            params.height as usize,
        );
        ctx.queue.submit([encoder.finish()]);
    }

    /// The visibility-tested blend of the warps weighted by `view_weights`; `fallback` where no
    /// view sees.
    pub fn blend(&self, ctx: &GpuContext, warps: &GpuWarps, fallback: &GpuImage, view_weights: &[f32]) -> Result<GpuImage, GpuError> {
        if warps.count > MAX_VIEWS || view_weights.len() != warps.count {
            return Err(GpuError::Size(format!("{} views with {} weights (at most {MAX_VIEWS})", warps.count, view_weights.len())));
        }
        let (w, h) = (fallback.width, fallback.height);
        let out = GpuImage::zeroed(ctx, w, h, 3)?;
        let params = Self::frame_params(w, h, warps.count, 0.0, 0.0, false, view_weights);
        let (s1, s2) = (scratch(ctx)?, scratch(ctx)?);
        self.run(ctx, &self.blend, &params, [&warps.colors, &warps.visibility, fallback, &s1, &out, &s2]);
        Ok(out)
    }

    /// `w_T` from the previous frame warped here and the current warps.
    pub fn temporal_weights(&self, ctx: &GpuContext, previous: &GpuSplat, warps: &GpuWarps, sigma: f32) -> Result<GpuImage, GpuError> {
        let (w, h) = (previous.mask.width, previous.mask.height);
        let out = GpuImage::zeroed(ctx, w, h, 1)?;
        let params = Self::frame_params(w, h, warps.count, sigma, 0.0, false, &[]);
        let s = scratch(ctx)?;
        self.run(ctx, &self.temporal_weights, &params, [&warps.colors, &warps.valid, &previous.color, &previous.mask, &out, &s]);
        Ok(out)
    }

    /// The temporal terms `(lambda_T w_T, Dprev)` and `(lambda_T w_T, Iprev)`; `counters` are
    /// the consistency filter's (coverage after it in `[1]`).
    #[allow(clippy::too_many_arguments)]
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
        let params = Self::frame_params(w, h, 0, 0.0, lambda_t, coverage_scaling, &[]);
        self.run(ctx, &self.temporal_terms, &params, [w_t, &previous.depth, &previous.color, counters, &depth_terms, &color_terms]);
        Ok((depth_terms, color_terms))
    }

    /// The sparse maps' color and mask as one RGBA image.
    pub fn pack_sparse(&self, ctx: &GpuContext, sparse: &GpuSplat) -> Result<GpuImage, GpuError> {
        let (w, h) = (sparse.mask.width, sparse.mask.height);
        let out = GpuImage::zeroed(ctx, w, h, 4)?;
        let params = Self::frame_params(w, h, 0, 0.0, 0.0, false, &[]);
        let (s1, s2, s3) = (scratch(ctx)?, scratch(ctx)?, scratch(ctx)?);
        self.run(ctx, &self.pack_sparse, &params, [&sparse.color, &sparse.mask, &s1, &s2, &out, &s3]);
        Ok(out)
    }

    /// Applies the consistency filter with `ratio` to `sparse` in place (skipped when `ratio`
    /// is 0) and returns the counters: covered pixels before (`[0]`) and after (`[1]`).
    pub fn consistency(&self, ctx: &GpuContext, sparse: &GpuSplat, ratio: f32) -> Result<GpuImage, GpuError> {
        let (w, h) = (sparse.mask.width, sparse.mask.height);
        let flags = GpuImage::zeroed(ctx, w, 2 * h, 1)?;
        let counters = GpuImage::zeroed(ctx, 2, 1, 1)?;
        let params = ConsistencyParams { width: w as u32, height: h as u32, ratio, _pad: 0 };
        let buffers = [&sparse.depth.buffer, &sparse.mask.buffer, &flags.buffer, &counters.buffer];
        let mut encoder = ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("consistency") });
        let uniform = bytemuck::bytes_of(&params);
        self.count.dispatch(ctx, &mut encoder, uniform, &buffers, w, h);
        if ratio > 0.0 {
            self.isolated.dispatch(ctx, &mut encoder, uniform, &buffers, w, h);
            self.occluded.dispatch(ctx, &mut encoder, uniform, &buffers, w, h);
        }
        self.apply.dispatch(ctx, &mut encoder, uniform, &buffers, w, h);
        ctx.queue.submit([encoder.finish()]);
        Ok(counters)
    }
}

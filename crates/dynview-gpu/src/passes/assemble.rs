//! The weights and the assembly of the depth and color systems on the GPU
//! (`shaders/assemble/*.wgsl`), as dynview-core's `render::weights` and `render::solve`.

use dynview_core::render::RenderParams;
use dynview_core::render::plane::{PixelPlane, support_radius_px};

use crate::device::context::GpuContext;
use crate::device::error::GpuError;
use crate::device::image::GpuImage;
use crate::device::kernel::Kernel;
use crate::device::shaders;
use crate::passes::views::{FIRST_CHUNK, LAST_CHUNK, ViewStack};
use crate::passes::warp::GpuWarps;

/// A grid system on the GPU, as dynview-core's `GridSystem`: couplings to the right and down
/// neighbours, `1 / diag`, and the right-hand side (`channels` per pixel).
#[derive(Debug)]
pub struct GpuSystem {
    /// Coupling of pixel `i` with `i + 1`.
    pub right: GpuImage,
    /// Coupling of pixel `i` with `i + width`.
    pub down: GpuImage,
    /// `1 / diag`.
    pub inv_diag: GpuImage,
    /// Right-hand side.
    pub rhs: GpuImage,
}

/// The uniform block of `shaders/assemble/*.wgsl` (`assemble/params.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct AssembleParams {
    width: u32,
    height: u32,
    views: u32,
    chunk: u32,
    sigma: f32,
    lambda_pc: f32,
    lambda_p: f32,
    lambda_g: f32,
    gradient_unit: f32,
    eps_gradient: f32,
    eps_visibility: f32,
    w_d_min: f32,
    w_d_max: f32,
    _pad1: u32,
    _pad2: u32,
    _pad3: u32,
}

/// The uniform block of `shaders/assemble/plane_support.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct SupportParams {
    width: u32,
    height: u32,
    radius: u32,
    _pad0: u32,
    lambda_plane: f32,
    support_coverage: f32,
    plane_a: f32,
    plane_b: f32,
    plane_c: f32,
    plane_inverse_min: f32,
    plane_inverse_max: f32,
    _pad1: u32,
}

impl SupportParams {
    /// The block for the support alone (`support_rows`, `unsupported`): no plane.
    pub(crate) fn support_only(width: usize, height: usize, radius_px: usize, support_coverage: f32) -> Self {
        Self { width: width as u32, height: height as u32, radius: radius_px as u32, support_coverage, ..bytemuck::Zeroable::zeroed() }
    }
}

/// The assembly kernels, compiled once per device.
#[derive(Debug)]
pub struct AssembleKernels {
    projection_weights: Kernel,
    depth_weights: Kernel,
    depth_system: Kernel,
    support_rows: Kernel,
    plane_prior: Kernel,
    color_system: Kernel,
    view_weight: Kernel,
}

fn check(image: &GpuImage, what: &str, width: usize, height: usize, channels: usize) -> Result<(), GpuError> {
    if (image.width, image.height, image.channels) == (width, height, channels) {
        Ok(())
    } else {
        Err(GpuError::Size(format!("{what} is {}x{}x{}, expected {width}x{height}x{channels}", image.width, image.height, image.channels)))
    }
}

impl AssembleKernels {
    /// Compiles the kernels on `ctx`'s device.
    pub fn new(ctx: &GpuContext) -> Self {
        let device = &ctx.device;
        // Read-only inputs, then the outputs.
        let kernel = |shader: shaders::Shader, entry, inputs: usize, outputs: usize| {
            let bindings: Vec<bool> = (0..inputs + outputs).map(|i| i < inputs).collect();
            Kernel::new(device, &shaders::module(device, shader), entry, &bindings, 8)
        };
        Self {
            projection_weights: kernel(shaders::PROJECTION_WEIGHTS, "projection_weights", 4, 1),
            depth_weights: kernel(shaders::DEPTH_WEIGHTS, "depth_weights", 4, 2),
            depth_system: kernel(shaders::DEPTH_SYSTEM, "depth_system", 4, 4),
            support_rows: kernel(shaders::PLANE_SUPPORT, "support_rows", 1, 1),
            // Row sums in, prior out, temporal terms in.
            plane_prior: Kernel::new(device, &shaders::module(device, shaders::PLANE_SUPPORT), "plane_prior", &[true, false, true], 8),
            color_system: kernel(shaders::COLOR_SYSTEM, "color_system", 3, 4),
            view_weight: kernel(shaders::VIEW_WEIGHT, "view_weight", 1, 1),
        }
    }

    /// The uniform block for a chunk of `views` views with chunk flags `chunk`.
    fn uniform(params: &RenderParams, width: usize, height: usize, views: usize, chunk: u32) -> AssembleParams {
        AssembleParams {
            width: width as u32,
            height: height as u32,
            views: views as u32,
            chunk,
            sigma: params.sigma,
            lambda_pc: params.lambda_pc,
            lambda_p: params.lambda_p,
            lambda_g: params.lambda_g,
            gradient_unit: params.gradient_unit,
            eps_gradient: params.eps_gradient,
            eps_visibility: params.eps_visibility,
            w_d_min: params.w_d_min,
            w_d_max: params.w_d_max,
            _pad1: 0,
            _pad2: 0,
            _pad3: 0,
        }
    }

    fn run(&self, ctx: &GpuContext, kernel: &Kernel, uniform: &AssembleParams, buffers: &[&GpuImage]) {
        let buffers: Vec<&wgpu::Buffer> = buffers.iter().map(|b| &b.buffer).collect();
        kernel.dispatch(ctx, bytemuck::bytes_of(uniform), &buffers, uniform.width as usize, uniform.height as usize);
    }

    /// Row sums of the sparse `mask` (1 channel) over the points' support window at pyramid
    /// `level`: what [`Self::plane_prior`] and [`crate::RankKernels::unsupported`] take, computed
    /// once per level for both.
    pub fn support_rows(&self, ctx: &GpuContext, mask: &GpuImage, level: usize) -> Result<GpuImage, GpuError> {
        let (w, h) = (mask.width, mask.height);
        check(mask, "sparse mask", w, h, 1)?;
        // plane_support.wgsl's uniform block: `support_rows` reads the size and the radius.
        let uniform = SupportParams::support_only(w, h, support_radius_px(level), 0.0);
        let rows = GpuImage::zeroed(ctx, w, h, 1)?;
        self.support_rows.dispatch(ctx, bytemuck::bytes_of(&uniform), &[&mask.buffer, &rows.buffer], w, h);
        Ok(rows)
    }

    /// The temporal terms (`temporal`: `lambda_T w_T` and the previous depth per pixel) with
    /// the pull toward `plane` (in this level's pixels) folded in, at pyramid `level`, from the
    /// sparse mask's [`Self::support_rows`]: what [`Self::depth_system`] takes as its temporal
    /// terms. The weight is dynview-core's `render::plane::plane_weights`.
    pub fn plane_prior(
        &self,
        ctx: &GpuContext,
        params: &RenderParams,
        rows: &GpuImage,
        temporal: &GpuImage,
        plane: &PixelPlane,
        level: usize,
    ) -> Result<GpuImage, GpuError> {
        let (w, h) = (rows.width, rows.height);
        check(rows, "support rows", w, h, 1)?;
        check(temporal, "temporal terms", w, h, 2)?;
        let uniform = SupportParams {
            width: w as u32,
            height: h as u32,
            radius: support_radius_px(level) as u32,
            _pad0: 0,
            lambda_plane: params.lambda_plane,
            support_coverage: params.plane_support,
            plane_a: plane.coefficients[0],
            plane_b: plane.coefficients[1],
            plane_c: plane.coefficients[2],
            plane_inverse_min: plane.inverse_depth_range[0],
            plane_inverse_max: plane.inverse_depth_range[1],
            _pad1: 0,
        };
        let prior = GpuImage::zeroed(ctx, w, h, 2)?;
        self.plane_prior.dispatch(ctx, bytemuck::bytes_of(&uniform), &[&rows.buffer, &prior.buffer, &temporal.buffer], w, h);
        Ok(prior)
    }

    /// `w_P^s` of every view (stacked like the warps), `-1` where the warp of view `s` is
    /// invalid; `color` is the current estimate.
    pub fn projection_weights(
        &self,
        ctx: &GpuContext,
        params: &RenderParams,
        color: &GpuImage,
        warps: &GpuWarps,
    ) -> Result<ViewStack, GpuError> {
        let (w, h) = (color.width, color.height);
        let split = warps.split();
        check(color, "color", w, h, 3)?;
        warps.colors.check("warp colors", split, w, h, 3)?;
        warps.visibility.check("visibility", split, w, h, 1)?;
        warps.valid.check("validity", split, w, h, 1)?;
        let w_p = ViewStack::zeroed(ctx, split, w, h, 1)?;
        for (c, (views, flags)) in split.iter().enumerate() {
            let images = [color, &warps.colors.chunks[c], &warps.visibility.chunks[c], &warps.valid.chunks[c], &w_p.chunks[c]];
            self.run(ctx, &self.projection_weights, &Self::uniform(params, w, h, views.len(), flags), &images);
        }
        Ok(w_p)
    }

    /// The depth system from the current color, `w_p` (from [`Self::projection_weights`]),
    /// the warps' visibility, the sparse maps (`sparse_color_mask`: RGB and mask;
    /// `sparse_depth`, infinite where no point) and the temporal terms (`temporal`:
    /// `lambda_T w_T` and the previous depth per pixel).
    #[allow(clippy::too_many_arguments)]
    pub fn depth_system(
        &self,
        ctx: &GpuContext,
        params: &RenderParams,
        color: &GpuImage,
        w_p: &ViewStack,
        visibility: &ViewStack,
        sparse_color_mask: &GpuImage,
        sparse_depth: &GpuImage,
        temporal: &GpuImage,
    ) -> Result<GpuSystem, GpuError> {
        let (w, h) = (color.width, color.height);
        let split = w_p.split;
        w_p.check("w_p", split, w, h, 1)?;
        visibility.check("visibility", split, w, h, 1)?;
        check(sparse_color_mask, "sparse color and mask", w, h, 4)?;
        check(sparse_depth, "sparse depth", w, h, 1)?;
        check(temporal, "temporal terms", w, h, 2)?;
        let w_d = GpuImage::zeroed(ctx, w, h, 1)?;
        let attach = GpuImage::zeroed(ctx, w, h, 1)?;
        for (c, (views, flags)) in split.iter().enumerate() {
            let images = [color, &w_p.chunks[c], &visibility.chunks[c], sparse_color_mask, &w_d, &attach];
            self.run(ctx, &self.depth_weights, &Self::uniform(params, w, h, views.len(), flags), &images);
        }
        let sys = GpuSystem {
            right: GpuImage::zeroed(ctx, w, h, 1)?,
            down: GpuImage::zeroed(ctx, w, h, 1)?,
            inv_diag: GpuImage::zeroed(ctx, w, h, 1)?,
            rhs: GpuImage::zeroed(ctx, w, h, 1)?,
        };
        self.run(
            ctx,
            &self.depth_system,
            &Self::uniform(params, w, h, 0, FIRST_CHUNK | LAST_CHUNK),
            &[&w_d, &attach, sparse_depth, temporal, &sys.right, &sys.down, &sys.inv_diag, &sys.rhs],
        );
        Ok(sys)
    }

    /// The color system from the warp colors, `w_p` and the temporal terms (`temporal`:
    /// `lambda_T w_T` and the previous RGB per pixel).
    pub fn color_system(
        &self,
        ctx: &GpuContext,
        params: &RenderParams,
        warp_colors: &ViewStack,
        w_p: &ViewStack,
        temporal: &GpuImage,
    ) -> Result<GpuSystem, GpuError> {
        let (w, h) = (temporal.width, temporal.height);
        let split = w_p.split;
        warp_colors.check("warp colors", split, w, h, 3)?;
        w_p.check("w_p", split, w, h, 1)?;
        check(temporal, "temporal terms", w, h, 4)?;
        let sys = GpuSystem {
            right: GpuImage::zeroed(ctx, w, h, 1)?,
            down: GpuImage::zeroed(ctx, w, h, 1)?,
            inv_diag: GpuImage::zeroed(ctx, w, h, 1)?,
            rhs: GpuImage::zeroed(ctx, w, h, 3)?,
        };
        for (c, (views, flags)) in split.iter().enumerate() {
            let images = [&warp_colors.chunks[c], &w_p.chunks[c], temporal, &sys.right, &sys.down, &sys.inv_diag, &sys.rhs];
            self.run(ctx, &self.color_system, &Self::uniform(params, w, h, views.len(), flags), &images);
        }
        Ok(sys)
    }

    /// `sum_s w_P^s` over the views, invalid warps counting 0: the view weight the viewer
    /// shows, as dynview-core's render job keeps it.
    pub fn view_weight(&self, ctx: &GpuContext, params: &RenderParams, w_p: &ViewStack) -> Result<GpuImage, GpuError> {
        let (w, h) = (w_p.width, w_p.height);
        w_p.check("w_p", w_p.split, w, h, 1)?;
        let sum = GpuImage::zeroed(ctx, w, h, 1)?;
        for (views, flags, chunk) in w_p.iter() {
            self.run(ctx, &self.view_weight, &Self::uniform(params, w, h, views.len(), flags), &[chunk, &sum]);
        }
        Ok(sum)
    }
}

/// The uniform block's mirror in each shader, checked against the WGSL
/// (`src/layout_tests.rs`).
#[cfg(test)]
pub(crate) fn wgsl_mirrors() -> Vec<crate::device::shader_layout::Mirror> {
    use crate::device::shader_layout::mirror;
    [shaders::PROJECTION_WEIGHTS, shaders::DEPTH_WEIGHTS, shaders::DEPTH_SYSTEM, shaders::COLOR_SYSTEM, shaders::VIEW_WEIGHT]
        .into_iter()
        .map(|shader| {
            mirror!(
                shader,
                "Params",
                AssembleParams {
                    width,
                    height,
                    views,
                    chunk,
                    sigma,
                    lambda_pc,
                    lambda_p,
                    lambda_g,
                    gradient_unit,
                    eps_gradient,
                    eps_visibility,
                    w_d_min,
                    w_d_max,
                    _pad1,
                    _pad2,
                    _pad3,
                }
            )
        })
        .chain([mirror!(
            shaders::PLANE_SUPPORT,
            "SupportParams",
            SupportParams {
                width,
                height,
                radius,
                _pad0,
                lambda_plane,
                support_coverage,
                plane_a,
                plane_b,
                plane_c,
                plane_inverse_min,
                plane_inverse_max,
                _pad1,
            }
        )])
        .collect()
}

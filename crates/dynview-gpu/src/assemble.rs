//! The weights and the assembly of the depth and color systems on the GPU
//! (`shaders/assemble/*.wgsl`), as dynview-core's `render::weights` and `render::solve`.

use dynview_core::render::RenderParams;
use dynview_core::render::plane::{PixelPlane, support_radius_px};

use crate::context::{GpuContext, GpuError};
use crate::image::GpuImage;
use crate::kernel::Kernel;
use crate::shaders;

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

/// The warps of the chosen views, packed: view `s` occupies rows `s * height ..` of each image.
#[derive(Clone, Copy, Debug)]
pub struct PackedViews<'a> {
    /// Warped colors `P^s` (RGB).
    pub colors: &'a GpuImage,
    /// `sigma_vis^s` (0 or 1).
    pub visibility: &'a GpuImage,
    /// 1 where the warp lands inside input `s`, else 0.
    pub valid: &'a GpuImage,
    /// Number of views.
    pub count: usize,
}

/// The uniform block of `shaders/assemble/*.wgsl` (`assemble/params.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct AssembleParams {
    width: u32,
    height: u32,
    views: u32,
    _pad0: u32,
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
        // Read-only inputs, then the outputs.
        let kernel = |shader: shaders::Shader, entry, inputs: usize, outputs: usize| {
            let bindings: Vec<bool> = (0..inputs + outputs).map(|i| i < inputs).collect();
            Kernel::new(ctx, &shaders::module(ctx, shader), entry, &bindings, 8)
        };
        Self {
            projection_weights: kernel(shaders::PROJECTION_WEIGHTS, "projection_weights", 4, 1),
            depth_weights: kernel(shaders::DEPTH_WEIGHTS, "depth_weights", 4, 2),
            depth_system: kernel(shaders::DEPTH_SYSTEM, "depth_system", 4, 4),
            support_rows: kernel(shaders::PLANE_SUPPORT, "support_rows", 1, 1),
            // Row sums in, prior out, temporal terms in.
            plane_prior: Kernel::new(ctx, &shaders::module(ctx, shaders::PLANE_SUPPORT), "plane_prior", &[true, false, true], 8),
            color_system: kernel(shaders::COLOR_SYSTEM, "color_system", 3, 4),
        }
    }

    fn uniform(params: &RenderParams, width: usize, height: usize, views: usize) -> AssembleParams {
        AssembleParams {
            width: width as u32,
            height: height as u32,
            views: views as u32,
            _pad0: 0,
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

    /// `w_P^s` of every view (packed like `views`), `-1` where the warp of view `s` is
    /// invalid; `color` is the current estimate.
    pub fn projection_weights(
        &self,
        ctx: &GpuContext,
        params: &RenderParams,
        color: &GpuImage,
        views: PackedViews,
    ) -> Result<GpuImage, GpuError> {
        let PackedViews { colors: warp_colors, visibility, valid, count: views } = views;
        let (w, h) = (color.width, color.height);
        check(color, "color", w, h, 3)?;
        check(warp_colors, "warp colors", w, h * views, 3)?;
        check(visibility, "visibility", w, h * views, 1)?;
        check(valid, "validity", w, h * views, 1)?;
        let w_p = GpuImage::zeroed(ctx, w, h * views, 1)?;
        self.run(ctx, &self.projection_weights, &Self::uniform(params, w, h, views), &[color, warp_colors, visibility, valid, &w_p]);
        Ok(w_p)
    }

    /// The depth system from the current color, `w_p` (from [`Self::projection_weights`]),
    /// the packed visibility, the sparse maps (`sparse_color_mask`: RGB and mask; `sparse_depth`,
    /// infinite where no point) and the temporal terms (`temporal`: `lambda_T w_T` and the
    /// previous depth per pixel).
    #[allow(clippy::too_many_arguments)]
    pub fn depth_system(
        &self,
        ctx: &GpuContext,
        params: &RenderParams,
        color: &GpuImage,
        w_p: &GpuImage,
        visibility: &GpuImage,
        sparse_color_mask: &GpuImage,
        sparse_depth: &GpuImage,
        temporal: &GpuImage,
        views: usize,
    ) -> Result<GpuSystem, GpuError> {
        let (w, h) = (color.width, color.height);
        check(w_p, "w_p", w, h * views, 1)?;
        check(visibility, "visibility", w, h * views, 1)?;
        check(sparse_color_mask, "sparse color and mask", w, h, 4)?;
        check(sparse_depth, "sparse depth", w, h, 1)?;
        check(temporal, "temporal terms", w, h, 2)?;
        let uniform = Self::uniform(params, w, h, views);
        let w_d = GpuImage::zeroed(ctx, w, h, 1)?;
        let attach = GpuImage::zeroed(ctx, w, h, 1)?;
        self.run(ctx, &self.depth_weights, &uniform, &[color, w_p, visibility, sparse_color_mask, &w_d, &attach]);
        let sys = GpuSystem {
            right: GpuImage::zeroed(ctx, w, h, 1)?,
            down: GpuImage::zeroed(ctx, w, h, 1)?,
            inv_diag: GpuImage::zeroed(ctx, w, h, 1)?,
            rhs: GpuImage::zeroed(ctx, w, h, 1)?,
        };
        self.run(
            ctx,
            &self.depth_system,
            &uniform,
            &[&w_d, &attach, sparse_depth, temporal, &sys.right, &sys.down, &sys.inv_diag, &sys.rhs],
        );
        Ok(sys)
    }

    /// The color system from the packed warp colors, `w_p` and the temporal terms
    /// (`temporal`: `lambda_T w_T` and the previous RGB per pixel).
    pub fn color_system(
        &self,
        ctx: &GpuContext,
        params: &RenderParams,
        warp_colors: &GpuImage,
        w_p: &GpuImage,
        temporal: &GpuImage,
        views: usize,
    ) -> Result<GpuSystem, GpuError> {
        let (w, h) = (temporal.width, temporal.height);
        check(warp_colors, "warp colors", w, h * views, 3)?;
        check(w_p, "w_p", w, h * views, 1)?;
        check(temporal, "temporal terms", w, h, 4)?;
        let sys = GpuSystem {
            right: GpuImage::zeroed(ctx, w, h, 1)?,
            down: GpuImage::zeroed(ctx, w, h, 1)?,
            inv_diag: GpuImage::zeroed(ctx, w, h, 1)?,
            rhs: GpuImage::zeroed(ctx, w, h, 3)?,
        };
        let uniform = Self::uniform(params, w, h, views);
        self.run(ctx, &self.color_system, &uniform, &[warp_colors, w_p, temporal, &sys.right, &sys.down, &sys.inv_diag, &sys.rhs]);
        Ok(sys)
    }
}

/// The uniform block's mirror in each shader, checked against the WGSL
/// (`shaders/layout_tests.rs`).
#[cfg(test)]
pub(crate) fn wgsl_mirrors() -> Vec<crate::shaders::layout_tests::Mirror> {
    use crate::shaders::layout_tests::mirror;
    [shaders::PROJECTION_WEIGHTS, shaders::DEPTH_WEIGHTS, shaders::DEPTH_SYSTEM, shaders::COLOR_SYSTEM]
        .into_iter()
        .map(|shader| {
            mirror!(
                shader,
                "Params",
                AssembleParams {
                    width,
                    height,
                    views,
                    _pad0,
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

//! The rank preference of the color energy on the GPU (dynview-core's
//! `render::weights::apply_rank_preference`, `RenderParams::view_rank_exponent`): where no point
//! supports the depth, each view's `w_P^s` is scaled toward the best-ranked view.

use dynview_core::render::plane::support_radius_px;

use crate::device::context::GpuContext;
use crate::device::error::GpuError;
use crate::device::image::GpuImage;
use crate::device::kernel::Kernel;
use crate::device::shaders;
use crate::passes::blend::MAX_VIEWS;
use crate::passes::views::ViewStack;

/// `rank_preference.wgsl`'s uniform block.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct RankParams {
    width: u32,
    height: u32,
    views: u32,
    _pad0: u32,
    preferences: [f32; MAX_VIEWS],
}

/// The kernels of the rank preference, compiled once per device.
#[derive(Debug)]
pub struct RankKernels {
    unsupported: Kernel,
    rank_preference: Kernel,
}

impl RankKernels {
    /// Compiles the kernels on `ctx`'s device.
    pub fn new(ctx: &GpuContext) -> Self {
        let device = &ctx.device;
        let support = shaders::module(device, shaders::PLANE_SUPPORT);
        Self {
            unsupported: Kernel::new(device, &support, "unsupported", &[true, false], 8),
            rank_preference: Kernel::new(device, &shaders::module(device, shaders::RANK_PREFERENCE), "rank_preference", &[true, false], 8),
        }
    }

    /// How far each pixel is from the points' support, in [0, 1], at pyramid `level`, from the
    /// sparse mask's [`crate::AssembleKernels::support_rows`]: dynview-core's
    /// `plane_weights(mask, level, 1, support)` (`support` is `RenderParams::view_rank_support`).
    /// The window sums are integers, so they match exactly.
    pub fn unsupported(&self, ctx: &GpuContext, rows: &GpuImage, level: usize, support: f32) -> Result<GpuImage, GpuError> {
        let (w, h) = (rows.width, rows.height);
        if rows.channels != 1 {
            return Err(GpuError::Size(format!("support rows have {} channels, expected 1", rows.channels)));
        }
        // plane_support.wgsl's uniform block, with only the support fields used.
        let uniform = crate::passes::assemble::SupportParams::support_only(w, h, support_radius_px(level), support);
        let out = GpuImage::zeroed(ctx, w, h, 1)?;
        self.unsupported.dispatch(ctx, bytemuck::bytes_of(&uniform), &[&rows.buffer, &out.buffer], w, h);
        Ok(out)
    }

    /// Scales `w_p` (from [`crate::AssembleKernels::projection_weights`]) in place by
    /// `1 + u preference_s` (`preferences` from dynview-core's
    /// `render::weights::rank_preferences`, `unsupported` from [`Self::unsupported`]).
    pub fn apply(&self, ctx: &GpuContext, w_p: &ViewStack, unsupported: &GpuImage, preferences: &[f32]) -> Result<(), GpuError> {
        let (w, h) = (unsupported.width, unsupported.height);
        let views = preferences.len();
        if views > MAX_VIEWS || views != w_p.split.count || unsupported.channels != 1 {
            return Err(GpuError::Size(format!(
                "{views} view preferences for w_p of {} views (at most {MAX_VIEWS}), support of {} channels",
                w_p.split.count, unsupported.channels
            )));
        }
        w_p.check("w_p", w_p.split, w, h, 1)?;
        for (chunk_views, _, chunk) in w_p.iter() {
            let mut packed = [0.0; MAX_VIEWS];
            packed[..chunk_views.len()].copy_from_slice(&preferences[chunk_views.clone()]);
            let uniform = RankParams { width: w as u32, height: h as u32, views: chunk_views.len() as u32, _pad0: 0, preferences: packed };
            self.rank_preference.dispatch(ctx, bytemuck::bytes_of(&uniform), &[&unsupported.buffer, &chunk.buffer], w, h);
        }
        Ok(())
    }
}

/// The uniform block's mirror, checked against the WGSL (`src/layout_tests.rs`).
#[cfg(test)]
pub(crate) fn wgsl_mirrors() -> Vec<crate::device::shader_layout::Mirror> {
    use crate::device::shader_layout::mirror;
    vec![mirror!(shaders::RANK_PREFERENCE, "RankParams", RankParams { width, height, views, _pad0, preferences })]
}

//! The sparse consistency filter on the GPU (`shaders/consistency.wgsl`), as dynview-core's
//! `SplatMaps::drop_inconsistent`.

use crate::device::context::GpuContext;
use crate::device::error::GpuError;
use crate::device::image::GpuImage;
use crate::device::kernel::Kernel;
use crate::device::shaders;
use crate::passes::splat::GpuSplat;

/// `consistency.wgsl`'s uniform block.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct ConsistencyParams {
    width: u32,
    height: u32,
    ratio: f32,
    surround: u32,
}

/// The consistency filter's kernels, compiled once per device.
#[derive(Debug)]
pub struct ConsistencyKernels {
    count: Kernel,
    isolated: Kernel,
    occluded: Kernel,
    apply: Kernel,
}

impl ConsistencyKernels {
    /// Compiles the kernels on `ctx`'s device.
    pub fn new(ctx: &GpuContext) -> Self {
        let module = shaders::module(&ctx.device, shaders::CONSISTENCY);
        let bindings = [false, false, false, false];
        Self {
            count: Kernel::new(&ctx.device, &module, "count", &bindings, 8),
            isolated: Kernel::new(&ctx.device, &module, "isolated", &bindings, 8),
            occluded: Kernel::new(&ctx.device, &module, "occluded", &bindings, 8),
            apply: Kernel::new(&ctx.device, &module, "apply", &bindings, 8),
        }
    }

    /// Drops the inconsistent samples of `sparse` with `ratio` and the surround test's radius
    /// `surround_px`, in place (skipped when `ratio` is 0), and returns the counters: covered
    /// pixels before (`[0]`) and after (`[1]`).
    pub fn drop_inconsistent(&self, ctx: &GpuContext, sparse: &GpuSplat, ratio: f32, surround_px: usize) -> Result<GpuImage, GpuError> {
        let (w, h) = (sparse.mask.width, sparse.mask.height);
        let flags = GpuImage::zeroed(ctx, w, 2 * h, 1)?;
        let counters = GpuImage::zeroed(ctx, 2, 1, 1)?;
        let params = ConsistencyParams { width: w as u32, height: h as u32, ratio, surround: surround_px.min(u32::MAX as usize) as u32 };
        let buffers = [&sparse.depth.buffer, &sparse.mask.buffer, &flags.buffer, &counters.buffer];
        let _frame = ctx.frame();
        let uniform = bytemuck::bytes_of(&params);
        self.count.dispatch(ctx, uniform, &buffers, w, h);
        if ratio > 0.0 {
            self.isolated.dispatch(ctx, uniform, &buffers, w, h);
            self.occluded.dispatch(ctx, uniform, &buffers, w, h);
        }
        self.apply.dispatch(ctx, uniform, &buffers, w, h);
        Ok(counters)
    }
}

/// The uniform block's mirror, checked against the WGSL (`src/layout_tests.rs`).
#[cfg(test)]
pub(crate) fn wgsl_mirrors() -> Vec<crate::device::shader_layout::Mirror> {
    use crate::device::shader_layout::mirror;
    vec![mirror!(shaders::CONSISTENCY, "Params", ConsistencyParams { width, height, ratio, surround })]
}

//! The plates' static mask on the GPU (`shaders/static_mask.wgsl`), as dynview-core's
//! `render::plates::static_mask` on the same geometry (`plates::MaskGeometry`): the step's own
//! points and its static points splatted apart with their footprints ([`SplatKernels`]), the
//! static depth's holes filled with the farthest static depth within the reach, the pixels
//! where an own point lies in front of the static surface, grown, inverted and feathered.
//! On the GPU the cloud is already uploaded; on the host this cost a real-footage frame most of
//! its time.

use dynview_core::render::RenderParams;
use dynview_core::render::plates::{self, MaskGeometry, NEARER_MARGIN};

use crate::device::context::GpuContext;
use crate::device::error::GpuError;
use crate::device::image::GpuImage;
use crate::device::kernel::Kernel;
use crate::device::shaders;
use crate::passes::splat::{GpuCloud, SplatKernels};

/// `static_mask.wgsl`'s uniform block.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct MaskParams {
    width: u32,
    height: u32,
    radius: u32,
    nearer_margin: f32,
}

/// The static mask's kernels, compiled once per device.
#[derive(Debug)]
pub struct StaticMaskKernels {
    farthest: Kernel,
    nearer: Kernel,
    grown: Kernel,
    feathered: Kernel,
}

impl StaticMaskKernels {
    /// Compiles the kernels on `ctx`'s device.
    pub fn new(ctx: &GpuContext) -> Self {
        let module = shaders::module(&ctx.device, shaders::STATIC_MASK);
        let bindings = [true, true, false];
        Self {
            farthest: Kernel::new(&ctx.device, &module, "farthest", &bindings, 8),
            nearer: Kernel::new(&ctx.device, &module, "nearer", &bindings, 8),
            grown: Kernel::new(&ctx.device, &module, "grown", &bindings, 8),
            feathered: Kernel::new(&ctx.device, &module, "feathered", &bindings, 8),
        }
    }

    /// The static mask of the novel view whose geometry is `geometry`
    /// (`MaskGeometry::of(params, camera)`), from `cloud` whose last `static_points` points are
    /// static; `None` where dynview-core's `static_mask` gives none (no static point, or the
    /// plates off).
    pub fn static_mask(
        &self,
        ctx: &GpuContext,
        splat: &SplatKernels,
        params: &RenderParams,
        cloud: &GpuCloud,
        static_points: usize,
        geometry: &MaskGeometry,
    ) -> Result<Option<GpuImage>, GpuError> {
        let count = cloud.len();
        if !plates::has_mask(params, static_points, count) {
            return Ok(None);
        }
        let camera = &geometry.camera;
        let (w, h) = (camera.width_px as usize, camera.height_px as usize);
        let split = count - static_points;
        let attached = |range: std::ops::Range<usize>| -> Result<GpuImage, GpuError> {
            let splat_maps = splat.project_range(ctx, cloud, range, camera)?;
            Ok(splat.with_footprint(ctx, &splat_maps, geometry.footprint_px)?.0.depth)
        };
        let (own, mut statics) = (attached(0..split)?, attached(split..count)?);
        let uniform = |radius: usize| MaskParams { width: w as u32, height: h as u32, radius: radius as u32, nearer_margin: NEARER_MARGIN };
        if geometry.static_reach_px > geometry.footprint_px {
            let reached = GpuImage::zeroed(ctx, w, h, 1)?;
            let params_reach = uniform(geometry.static_reach_px);
            self.farthest.dispatch(ctx, bytemuck::bytes_of(&params_reach), &[&statics.buffer, &statics.buffer, &reached.buffer], w, h);
            statics = reached;
        }
        let nearer = GpuImage::zeroed(ctx, w, h, 1)?;
        self.nearer.dispatch(ctx, bytemuck::bytes_of(&uniform(0)), &[&own.buffer, &statics.buffer, &nearer.buffer], w, h);
        let grown = GpuImage::zeroed(ctx, w, h, 1)?;
        let params_grown = uniform(geometry.dilation_px);
        self.grown.dispatch(ctx, bytemuck::bytes_of(&params_grown), &[&nearer.buffer, &nearer.buffer, &grown.buffer], w, h);
        if geometry.feather_px == 0 {
            return Ok(Some(grown));
        }
        let feathered = GpuImage::zeroed(ctx, w, h, 1)?;
        let params_feathered = uniform(geometry.feather_px);
        self.feathered.dispatch(ctx, bytemuck::bytes_of(&params_feathered), &[&grown.buffer, &grown.buffer, &feathered.buffer], w, h);
        Ok(Some(feathered))
    }
}

/// The uniform block's mirror, checked against the WGSL (`src/layout_tests.rs`).
#[cfg(test)]
pub(crate) fn wgsl_mirrors() -> Vec<crate::device::shader_layout::Mirror> {
    use crate::device::shader_layout::mirror;
    vec![mirror!(shaders::STATIC_MASK, "MaskParams", MaskParams { width, height, radius, nearer_margin })]
}

#[cfg(test)]
mod tests {
    use dynview_core::camera::{Camera, Intrinsics, Rigid3};
    use dynview_core::render::RenderParams;
    use dynview_core::render::plates::{self, MaskGeometry};
    use dynview_core::scene::PointCloud;

    use super::*;

    /// A wall of static points 10 m away, a few people's worth of own points in front of it
    /// (some on the wall itself), pseudo-random, seen by a 96x64 camera.
    fn scene() -> (PointCloud, usize, Camera) {
        let camera = Camera {
            intrinsics: Intrinsics { fx: 80.0, fy: 80.0, cx: 47.5, cy: 31.5 },
            camera_from_world: Rigid3::IDENTITY,
            width_px: 96,
            height_px: 64,
        };
        let mut state = 99u32;
        let mut next = || {
            state = state.wrapping_mul(1_103_515_245).wrapping_add(12345);
            f64::from(state >> 16) / 65536.0
        };
        let at = |x: f64, y: f64, z: f64| {
            let p = camera.unproject_world(glam::DVec2::new(x, y), z);
            [p.x as f32, p.y as f32, p.z as f32]
        };
        let mut cloud = PointCloud::default();
        for _ in 0..300 {
            let (x, y) = (next() * 30.0 + 20.0, next() * 40.0 + 10.0);
            let z = if next() < 0.2 { 10.0 } else { 4.0 + next() * 3.0 };
            cloud.positions_world.push(at(x, y, z));
        }
        let own = cloud.positions_world.len();
        for _ in 0..2500 {
            cloud.positions_world.push(at(next() * 100.0 - 2.0, next() * 68.0 - 2.0, 10.0 + next() * 0.2));
        }
        cloud.colors = vec![[100; 3]; cloud.positions_world.len()];
        let statics = cloud.positions_world.len() - own;
        (cloud, statics, camera)
    }

    #[test]
    fn the_gpu_mask_is_the_cpu_mask() {
        let ctx = GpuContext::new_blocking().unwrap_or_else(|e| panic!("{e}"));
        let (splat, kernels) = (SplatKernels::new(&ctx), StaticMaskKernels::new(&ctx));
        let (cloud, statics, camera) = scene();
        let uploaded = GpuCloud::upload(&ctx, &cloud).unwrap();
        for (dilation, footprint, feather, reach) in [(6, 2, 3, 0), (3, 1, 0, 0), (2, 0, 1, 0), (6, 2, 3, 8), (2, 0, 1, 5)] {
            let params = RenderParams {
                plate_moving_dilation_px: dilation,
                sparse_footprint_px: footprint,
                plate_feather_px: feather,
                plate_static_reach_px: reach,
                ..RenderParams::default()
            };
            let cpu = plates::static_mask(&params, &cloud, statics, &camera).unwrap();
            let geometry = MaskGeometry::of(&params, &camera);
            let gpu = kernels.static_mask(&ctx, &splat, &params, &uploaded, statics, &geometry).unwrap().unwrap();
            let gpu_values = gpu.download(&ctx).unwrap();
            assert_eq!((gpu.width, gpu.height), (cpu.width, cpu.height));
            let worst = gpu_values.iter().zip(&cpu.data).map(|(g, c)| (g - c).abs()).fold(0.0f32, f32::max);
            assert!(worst < 1e-5, "dilation {dilation}, footprint {footprint}, feather {feather}, reach {reach}: worst difference {worst}");
            let masked = cpu.data.iter().filter(|&&v| v < 0.5).count();
            assert!(masked > 500 && masked < 96 * 64 - 500, "{masked} pixels in front: the test shows nothing");
        }
        // No static point, or the plates off: no mask, as on the CPU.
        let params = RenderParams::default();
        let geometry = MaskGeometry::of(&params, &camera);
        assert!(kernels.static_mask(&ctx, &splat, &params, &uploaded, 0, &geometry).unwrap().is_none());
        let off = RenderParams { plate_moving_dilation_px: 0, ..params.clone() };
        assert!(kernels.static_mask(&ctx, &splat, &off, &uploaded, statics, &geometry).unwrap().is_none());
    }
}

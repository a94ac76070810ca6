//! Backward warps of the input views into the novel view and their visibility
//! (`shaders/warp.wgsl`), as dynview-core's `render::warp`, packed for the assembly kernels.

use dynview_core::camera::Camera;
use dynview_core::render::transfer::PixelTransfer;

use crate::device::context::GpuContext;
use crate::device::error::GpuError;
use crate::device::image::GpuImage;
use crate::device::kernel::Kernel;
use crate::device::shaders;
use crate::passes::views::{ViewChunks, ViewStack};

/// The chosen input views warped into the novel view, each stacked view after view in the
/// buffers of one split.
#[derive(Debug)]
pub struct GpuWarps {
    /// `I^proj_s`, RGB (black where invalid).
    pub colors: ViewStack,
    /// `sigma_vis^s` (0 or 1).
    pub visibility: ViewStack,
    /// 1 where the novel pixel lands inside input `s`.
    pub valid: ViewStack,
}

impl GpuWarps {
    /// How the views are split into buffers.
    pub fn split(&self) -> ViewChunks {
        self.colors.split
    }
}

/// `warp.wgsl`'s uniform block.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct WarpParams {
    width: u32,
    height: u32,
    input_width: u32,
    input_height: u32,
    tolerance: f32,
    offset: u32,
    mask_width: u32,
    mask_height: u32,
    m_row0: [f32; 4],
    m_row1: [f32; 4],
    m_row2: [f32; 4],
    e: [f32; 4],
}

/// The warp kernels, compiled once per device.
#[derive(Debug)]
pub struct WarpKernels {
    clear_zbuf: Kernel,
    warp: Kernel,
    visible: Kernel,
    /// The plates' colors where the novel view shows the static scene (`warp_plate.wgsl`).
    warp_plate: Kernel,
}

impl WarpKernels {
    /// Compiles the kernels on `ctx`'s device.
    pub fn new(ctx: &GpuContext) -> Self {
        let module = shaders::module(&ctx.device, shaders::WARP);
        let bindings = [true, true, false, false, false, false, false, false];
        let plate_module = shaders::module(&ctx.device, shaders::WARP_PLATE);
        Self {
            clear_zbuf: Kernel::new(&ctx.device, &module, "clear_zbuf", &bindings, 64),
            warp: Kernel::new(&ctx.device, &module, "warp", &bindings, 8),
            visible: Kernel::new(&ctx.device, &module, "visible", &bindings, 8),
            warp_plate: Kernel::new(&ctx.device, &plate_module, "warp_plate", &[true, true, true, false], 8),
        }
    }

    /// Warps each input (an RGB image seen by its camera, with its background plate if it has
    /// one) into `novel` with z-depth `depth`, and tests visibility with relative depth
    /// `tolerance`. With `static_mask` (the novel view's, at its size or smaller,
    /// `dynview_core::render::plates::static_mask`), a view with a plate gives the plate's color
    /// where the mask marks the static scene.
    pub fn warp_views(
        &self,
        ctx: &GpuContext,
        novel: &Camera,
        depth: &GpuImage,
        inputs: &[(Camera, &GpuImage, Option<&GpuImage>)],
        tolerance: f32,
        static_mask: Option<&GpuImage>,
    ) -> Result<GpuWarps, GpuError> {
        let (w, h) = (depth.width, depth.height);
        if (w, h) != (novel.width_px as usize, novel.height_px as usize) || depth.channels != 1 {
            return Err(GpuError::Size(format!(
                "depth {}x{}x{} for a {}x{} camera",
                w, h, depth.channels, novel.width_px, novel.height_px
            )));
        }
        if inputs.is_empty() {
            return Err(GpuError::InvalidParams { field: "inputs", reason: "no input views to warp".into() });
        }
        let split = ViewChunks::for_device(ctx, w, h, inputs.len())?;
        let out = GpuWarps {
            colors: ViewStack::zeroed(ctx, split, w, h, 3)?,
            visibility: ViewStack::zeroed(ctx, split, w, h, 1)?,
            valid: ViewStack::zeroed(ctx, split, w, h, 1)?,
        };
        let target = GpuImage::zeroed(ctx, w, h, 1)?;
        let depth_in_input = GpuImage::zeroed(ctx, w, h, 1)?;
        let _frame = ctx.frame();
        let mut zbufs = Vec::with_capacity(inputs.len());
        let (mask_width, mask_height) = static_mask.map_or((0, 0), |m| (m.width as u32, m.height as u32));
        for (s, (input_camera, input, plate)) in inputs.iter().enumerate() {
            if (input.width, input.height, input.channels) != (input_camera.width_px as usize, input_camera.height_px as usize, 3) {
                return Err(GpuError::Size(format!(
                    "input frame {s} is {}x{}x{} for a {}x{} camera",
                    input.width, input.height, input.channels, input_camera.width_px, input_camera.height_px
                )));
            }
            if let Some(plate) = plate
                && (plate.width, plate.height, plate.channels) != (input.width, input.height, 3)
            {
                return Err(GpuError::Size(format!(
                    "plate {s} is {}x{}x{} for a {}x{} frame",
                    plate.width, plate.height, plate.channels, input.width, input.height
                )));
            }

            let (m, e) = PixelTransfer::new(novel, input_camera).coefficients();
            let ((colors, offset), (visibility, _), (valid, _)) = (out.colors.locate(s), out.visibility.locate(s), out.valid.locate(s));
            let params = WarpParams {
                width: w as u32,
                height: h as u32,
                input_width: input.width as u32,
                input_height: input.height as u32,
                tolerance,
                offset: offset as u32,
                mask_width,
                mask_height,
                m_row0: [m[0], m[1], m[2], 0.0],
                m_row1: [m[3], m[4], m[5], 0.0],
                m_row2: [m[6], m[7], m[8], 0.0],
                e: [e[0], e[1], e[2], 0.0],
            };
            zbufs.push(GpuImage::zeroed(ctx, input.width, input.height, 1)?);
            let zbuf = &zbufs[s];
            let buffers = [
                &depth.buffer,
                &input.buffer,
                &colors.buffer,
                &target.buffer,
                &depth_in_input.buffer,
                &visibility.buffer,
                &zbuf.buffer,
                &valid.buffer,
            ];
            let uniform = bytemuck::bytes_of(&params);
            self.clear_zbuf.dispatch(ctx, uniform, &buffers, input.width * input.height, 1);
            self.warp.dispatch(ctx, uniform, &buffers, w, h);
            self.visible.dispatch(ctx, uniform, &buffers, w, h);
            if let (Some(plate), Some(mask)) = (plate, static_mask) {
                self.warp_plate.dispatch(ctx, uniform, &[&depth.buffer, &plate.buffer, &mask.buffer, &colors.buffer], w, h);
            }
        }
        Ok(out)
    }
}

/// The uniform block's mirror, checked against the WGSL (`src/layout_tests.rs`).
#[cfg(test)]
pub(crate) fn wgsl_mirrors() -> Vec<crate::device::shader_layout::Mirror> {
    use crate::device::shader_layout::mirror;
    let fields = |shader| {
        mirror!(
            shader,
            "Params",
            WarpParams { width, height, input_width, input_height, tolerance, offset, mask_width, mask_height, m_row0, m_row1, m_row2, e }
        )
    };
    vec![fields(shaders::WARP), fields(shaders::WARP_PLATE)]
}

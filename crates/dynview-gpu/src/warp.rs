//! Backward warps of the input views into the novel view and their visibility
//! (`shaders/warp.wgsl`), as dynview-core's `render::warp`.

use dynview_core::camera::Camera;
use dynview_core::render::transfer::PixelTransfer;

use crate::context::{GpuContext, GpuError};
use crate::image::GpuImage;
use crate::kernel::Kernel;

/// One input view warped into the novel view, on the GPU.
#[derive(Debug)]
pub struct GpuWarp {
    /// `I^proj_s`, RGB (black where invalid).
    pub color: GpuImage,
    /// Nearest input pixel per novel pixel (`u32::MAX` outside), as u32 bits.
    pub target: wgpu::Buffer,
    /// Depth in the input camera.
    pub depth_in_input: GpuImage,
    /// `sigma_vis^s` (0 or 1).
    pub visibility: GpuImage,
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
    _pad: [u32; 3],
    m_rows: [[f32; 4]; 3],
    e: [f32; 4],
}

/// The warp kernels, compiled once per device.
#[derive(Debug)]
pub struct WarpKernels {
    clear_zbuf: Kernel,
    warp: Kernel,
    visible: Kernel,
}

impl WarpKernels {
    /// Compiles the kernels on `ctx`'s device.
    pub fn new(ctx: &GpuContext) -> Self {
        let module = ctx.device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("warp.wgsl"),
            source: wgpu::ShaderSource::Wgsl(include_str!("shaders/warp.wgsl").into()),
        });
        let bindings = [true, true, false, false, false, false, false];
        Self {
            clear_zbuf: Kernel::new(ctx, &module, "clear_zbuf", &bindings, 64),
            warp: Kernel::new(ctx, &module, "warp", &bindings, 8),
            visible: Kernel::new(ctx, &module, "visible", &bindings, 8),
        }
    }

    /// Warps `input` (an RGB image seen by `input_camera`) into `novel` with z-depth `depth`,
    /// and tests visibility with relative depth `tolerance`.
    pub fn warp_view(
        &self,
        ctx: &GpuContext,
        novel: &Camera,
        depth: &GpuImage,
        input_camera: &Camera,
        input: &GpuImage,
        tolerance: f32,
    ) -> Result<GpuWarp, GpuError> {
        let (w, h) = (depth.width, depth.height);
        if (w, h) != (novel.width_px as usize, novel.height_px as usize) || depth.channels != 1 {
            return Err(GpuError::Size(format!(
                "depth {}x{}x{} for a {}x{} camera",
                w, h, depth.channels, novel.width_px, novel.height_px
            )));
        }
        if (input.width, input.height, input.channels) != (input_camera.width_px as usize, input_camera.height_px as usize, 3) {
            return Err(GpuError::Size(format!(
                "input frame {}x{}x{} for a {}x{} camera",
                input.width, input.height, input.channels, input_camera.width_px, input_camera.height_px
            )));
        }
        let (m, e) = PixelTransfer::new(novel, input_camera).coefficients();
        let params = WarpParams {
            width: w as u32,
            height: h as u32,
            input_width: input.width as u32,
            input_height: input.height as u32,
            tolerance,
            _pad: [0; 3],
            m_rows: [[m[0], m[1], m[2], 0.0], [m[3], m[4], m[5], 0.0], [m[6], m[7], m[8], 0.0]],
            e: [e[0], e[1], e[2], 0.0],
        };
        let out = GpuWarp {
            color: GpuImage::zeroed(ctx, w, h, 3)?,
            target: GpuImage::zeroed(ctx, w, h, 1)?.buffer,
            depth_in_input: GpuImage::zeroed(ctx, w, h, 1)?,
            visibility: GpuImage::zeroed(ctx, w, h, 1)?,
        };
        let zbuf = GpuImage::zeroed(ctx, input.width, input.height, 1)?;
        let buffers = [
            &depth.buffer,
            &input.buffer,
            &out.color.buffer,
            &out.target,
            &out.depth_in_input.buffer,
            &out.visibility.buffer,
            &zbuf.buffer,
        ];
        let uniform = bytemuck::bytes_of(&params);
        let mut encoder = ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("warp") });
        self.clear_zbuf.dispatch(ctx, &mut encoder, uniform, &buffers, input.width * input.height, 1);
        self.warp.dispatch(ctx, &mut encoder, uniform, &buffers, w, h);
        self.visible.dispatch(ctx, &mut encoder, uniform, &buffers, w, h);
        ctx.queue.submit([encoder.finish()]);
        Ok(out)
    }
}

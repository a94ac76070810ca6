//! Showing a frame without reading it back: a render pass that samples the renderer's storage
//! buffers into a target texture (a canvas's, in the browser) as dynview-core's
//! `display::picture` shows it (`shaders/display.wgsl`), with the false-color depth range found
//! on the GPU (`shaders/depth_range.wgsl`).

use dynview_core::display::DisplayMode;
use wgpu::util::DeviceExt;

use crate::device::context::GpuContext;
use crate::device::error::GpuError;
use crate::device::image::GpuImage;
use crate::device::kernel::Kernel;
use crate::device::shaders;
use crate::render::renderer::GpuFrame;

/// `depth_range.wgsl`'s uniform block.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct RangeParams {
    width: u32,
    height: u32,
    _pad: [u32; 2],
}

/// `display.wgsl`'s uniform block.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct DisplayParams {
    src_width: u32,
    src_height: u32,
    dst_width: u32,
    dst_height: u32,
    mode: u32,
    views: u32,
    srgb_target: u32,
    _pad: u32,
}

/// Histogram bins of the depth range (as `BINS` in `depth_range.wgsl`).
const BINS: u64 = 1024;

/// The display pipeline for one target format, with its scratch buffers.
#[derive(Debug)]
pub struct FrameDisplay {
    bounds_of: Kernel,
    histogram_of: Kernel,
    percentiles: Kernel,
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    format: wgpu::TextureFormat,
    bounds: wgpu::Buffer,
    /// `[u32::MAX, 0]`, copied into `bounds` before each search.
    bounds_start: wgpu::Buffer,
    histogram: wgpu::Buffer,
    range: wgpu::Buffer,
}

impl FrameDisplay {
    /// Compiles the pipeline for targets of `format` (any 8-bit RGBA or BGRA format, sRGB or
    /// not).
    pub fn new(ctx: &GpuContext, format: wgpu::TextureFormat) -> Self {
        let device = &ctx.device;
        let range_module = shaders::module(&ctx.device, shaders::DEPTH_RANGE);
        let display_module = shaders::module(&ctx.device, shaders::DISPLAY);
        let r = [true, false, false, false];
        let entry = |binding: u32, ty: wgpu::BufferBindingType| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::FRAGMENT,
            ty: wgpu::BindingType::Buffer { ty, has_dynamic_offset: false, min_binding_size: None },
            count: None,
        };
        let read = wgpu::BufferBindingType::Storage { read_only: true };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("display"),
            entries: &[entry(0, wgpu::BufferBindingType::Uniform), entry(1, read), entry(2, read), entry(3, read), entry(4, read)],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("display"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("display"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &display_module,
                entry_point: Some("vs"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            fragment: Some(wgpu::FragmentState {
                module: &display_module,
                entry_point: Some("fs"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState { format, blend: None, write_mask: wgpu::ColorWrites::ALL })],
            }),
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: None,
            multisample: wgpu::MultisampleState::default(),
            multiview_mask: None,
            cache: None,
        });
        let buffer = |label: &str, size: u64| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            })
        };
        Self {
            bounds_of: Kernel::new(&ctx.device, &range_module, "bounds_of", &r, 8),
            histogram_of: Kernel::new(&ctx.device, &range_module, "histogram_of", &r, 8),
            percentiles: Kernel::new(&ctx.device, &range_module, "percentiles", &r, 1),
            pipeline,
            layout,
            format,
            bounds: buffer("depth bounds", 8),
            bounds_start: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("depth bounds start"),
                contents: bytemuck::cast_slice(&[u32::MAX, 0u32]),
                usage: wgpu::BufferUsages::COPY_SRC,
            }),
            histogram: buffer("depth histogram", BINS * 4),
            range: buffer("depth range", 8),
        }
    }

    /// The target format this display draws to.
    pub fn format(&self) -> wgpu::TextureFormat {
        self.format
    }

    /// The range of the false-color depth map of `depth` (1 channel), left in a GPU buffer for
    /// the draw.
    fn depth_range(&self, ctx: &GpuContext, depth: &GpuImage) {
        ctx.encode(|encoder| {
            encoder.copy_buffer_to_buffer(&self.bounds_start, 0, &self.bounds, 0, 8);
            encoder.clear_buffer(&self.histogram, 0, None);
        });
        let params = RangeParams { width: depth.width as u32, height: depth.height as u32, _pad: [0; 2] };
        let buffers = [&depth.buffer, &self.bounds, &self.histogram, &self.range];
        let (w, h) = (depth.width, depth.height);
        self.bounds_of.dispatch(ctx, bytemuck::bytes_of(&params), &buffers, w, h);
        self.histogram_of.dispatch(ctx, bytemuck::bytes_of(&params), &buffers, w, h);
        self.percentiles.dispatch(ctx, bytemuck::bytes_of(&params), &buffers, 1, 1);
    }

    /// Draws `frame`'s finest level as `mode` into `target` (`width x height` pixels of this
    /// display's format), scaled with bilinear filtering of the color. Recorded in the open frame (submitted at once outside one); nothing
    /// is read back.
    pub fn draw(
        &self,
        ctx: &GpuContext,
        frame: &GpuFrame,
        mode: DisplayMode,
        target: &wgpu::TextureView,
        width: u32,
        height: u32,
    ) -> Result<(), GpuError> {
        if width == 0 || height == 0 {
            return Err(GpuError::Size(format!("display target of {width}x{height}")));
        }
        let (color, depth) = (frame.color(), frame.depth());
        let scratch;
        let (weights, views) = match &frame.view_weight {
            Some(w) if w.width == color.width && w.height == color.height => (w, frame.views_used),
            _ => {
                scratch = GpuImage::zeroed(ctx, 1, 1, 1)?;
                (&scratch, 0)
            }
        };
        let _frame = ctx.frame();
        if mode == DisplayMode::Depth {
            self.depth_range(ctx, depth);
        }
        let params = DisplayParams {
            src_width: color.width as u32,
            src_height: color.height as u32,
            dst_width: width,
            dst_height: height,
            mode: match mode {
                DisplayMode::Color => 0,
                DisplayMode::Depth => 1,
                DisplayMode::Weights => 2,
            },
            views: views as u32,
            srgb_target: u32::from(self.format.is_srgb()),
            _pad: 0,
        };
        let uniform = ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("display params"),
            contents: bytemuck::bytes_of(&params),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let bind_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("display"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: uniform.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: color.buffer.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 2, resource: depth.buffer.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 3, resource: weights.buffer.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 4, resource: self.range.as_entire_binding() },
            ],
        });
        ctx.note_bind_group();
        ctx.encode(|encoder| {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("display"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: target,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::BLACK), store: wgpu::StoreOp::Store },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &bind_group, &[]);
            pass.draw(0..3, 0..1);
        });
        Ok(())
    }

    /// What [`Self::draw`] shows, at the frame's own resolution, read back as opaque RGBA bytes
    /// (row-major, 4 per pixel): the canvas's pixels without the scaling. Does not block the
    /// thread (in the browser the read-back resolves from the event loop).
    pub async fn picture(&self, ctx: &GpuContext, frame: &GpuFrame, mode: DisplayMode) -> Result<(u32, u32, Vec<u8>), GpuError> {
        let (width, height) = (frame.color().width as u32, frame.color().height as u32);
        let texture = ctx.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("picture"),
            size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: self.format,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        self.draw(ctx, frame, mode, &texture.create_view(&wgpu::TextureViewDescriptor::default()), width, height)?;
        let row_bytes = width * 4;
        let padded_row_bytes = row_bytes.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
        let size = u64::from(padded_row_bytes) * u64::from(height);
        let buffer = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("picture"),
            size,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        ctx.encode(|encoder| {
            encoder.copy_texture_to_buffer(
                texture.as_image_copy(),
                wgpu::TexelCopyBufferInfo {
                    buffer: &buffer,
                    layout: wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(padded_row_bytes), rows_per_image: Some(height) },
                },
                wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
            )
        });
        let padded = crate::device::readback::read_bytes(ctx, &buffer, size).await?;
        let bgra = matches!(self.format, wgpu::TextureFormat::Bgra8Unorm | wgpu::TextureFormat::Bgra8UnormSrgb);
        let mut rgba = Vec::with_capacity((row_bytes * height) as usize);
        for row in padded.chunks(padded_row_bytes as usize) {
            for px in row[..row_bytes as usize].chunks(4) {
                if bgra {
                    rgba.extend_from_slice(&[px[2], px[1], px[0], px[3]]);
                } else {
                    rgba.extend_from_slice(px);
                }
            }
        }
        Ok((width, height, rgba))
    }
}

/// The uniform blocks' mirrors, checked against the WGSL (`src/layout_tests.rs`).
#[cfg(test)]
pub(crate) fn wgsl_mirrors() -> Vec<crate::device::shader_layout::Mirror> {
    use crate::device::shader_layout::mirror;
    vec![
        mirror!(shaders::DEPTH_RANGE, "Params", RangeParams { width, height, _pad }),
        mirror!(shaders::DISPLAY, "Params", DisplayParams { src_width, src_height, dst_width, dst_height, mode, views, srgb_target, _pad }),
    ]
}

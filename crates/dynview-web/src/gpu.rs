//! The viewer's GPU path: dynview-gpu on the browser's WebGPU, drawing each frame from the
//! renderer's buffers straight into an `OffscreenCanvas` (no read-back in the frame loop).
//! It lives in the worker next to the CPU path, so neither blocks the page's input handling.
//!
//! Where the browser cannot present WebGPU canvases (headless Chromium on SwiftShader loses
//! the device on the first present: it has no shared-image backing for WebGPU swap chains),
//! the worker passes no canvas and each frame's picture is read back asynchronously instead.

use std::cell::RefCell;
use std::rc::Rc;
use std::sync::{Arc, Mutex, PoisonError};

use dynview_core::camera::Camera;
use dynview_core::display::DisplayMode;
use dynview_core::render::pyramid::preview_camera;
use dynview_core::render::{RenderParams, TimeStepInputs};
use dynview_gpu::{FrameDisplay, GpuContext, GpuFrame, GpuStreamingRenderer, StreamRequest, wgpu};

/// Why the device is gone, once it is (set by wgpu's callbacks).
type LostReason = Arc<Mutex<Option<String>>>;

/// Time steps whose inputs stay uploaded (the current one and the next during playback).
const UPLOADED_STEPS: usize = 2;

/// A frame the GPU renders: what the worker asked for, resolved against the scene.
pub(crate) struct GpuRequest<'a> {
    pub camera: Camera,
    pub time_step: u32,
    pub inputs: &'a TimeStepInputs,
    /// Use the last full frame for the temporal terms.
    pub streaming: bool,
    /// A preview while the view moves: render at `1 / 2^level` of the size, keep nothing.
    pub preview_level: Option<usize>,
    pub mode: DisplayMode,
}

/// What one GPU render did (its timing comes when the GPU has finished).
pub(crate) struct GpuRendered {
    pub width: usize,
    pub height: usize,
    pub temporal_used: bool,
}

/// The GPU, its kernels, the canvas surface, and the frames kept between renders.
pub(crate) struct GpuView {
    pub ctx: GpuContext,
    renderer: RefCell<GpuStreamingRenderer>,
    display: FrameDisplay,
    /// The canvas and its surface; `None`: pictures are read back instead.
    canvas: Option<(web_sys::OffscreenCanvas, wgpu::Surface<'static>)>,
    configured: RefCell<(u32, u32)>,
    /// The frame on the canvas (for pictures).
    shown: RefCell<Option<Rc<GpuFrame>>>,
    lost: LostReason,
}

/// A surface drawing into `canvas`.
#[cfg(target_family = "wasm")]
fn surface_of(ctx: &GpuContext, canvas: &web_sys::OffscreenCanvas) -> Result<wgpu::Surface<'static>, String> {
    ctx.instance.create_surface(wgpu::SurfaceTarget::OffscreenCanvas(canvas.clone())).map_err(|e| format!("the canvas refused WebGPU: {e}"))
}

/// Natively there are no canvases (the crate builds natively only for its tests' tooling).
#[cfg(not(target_family = "wasm"))]
fn surface_of(_: &GpuContext, _: &web_sys::OffscreenCanvas) -> Result<wgpu::Surface<'static>, String> {
    Err("an OffscreenCanvas exists only in the browser".into())
}

fn error(e: impl std::fmt::Display) -> String {
    e.to_string()
}

impl GpuView {
    /// Asks the browser for a WebGPU device and sets up drawing into `canvas` (or, without one,
    /// reading pictures back).
    pub async fn new(canvas: Option<web_sys::OffscreenCanvas>) -> Result<Self, String> {
        let ctx = GpuContext::new().await.map_err(error)?;
        let lost = LostReason::default();
        let on_lost = lost.clone();
        ctx.device.set_device_lost_callback(move |reason, message| {
            let mut lost = on_lost.lock().unwrap_or_else(PoisonError::into_inner);
            let why = format!("the GPU device was lost ({reason:?}): {message}");
            // A GPU error that came first is the better explanation.
            *lost = Some(match lost.take() {
                Some(first) => format!("{first}; then {why}"),
                None => why,
            });
        });
        let on_error = lost.clone();
        ctx.device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            on_error.lock().unwrap_or_else(PoisonError::into_inner).get_or_insert_with(|| format!("GPU error: {e}"));
        }));
        let (canvas, format) = match canvas {
            Some(canvas) => {
                let surface = surface_of(&ctx, &canvas)?;
                let formats = surface.get_capabilities(&ctx.adapter).formats;
                let format = formats
                    .iter()
                    .copied()
                    .find(|f| matches!(f, wgpu::TextureFormat::Rgba8Unorm | wgpu::TextureFormat::Bgra8Unorm))
                    .or_else(|| formats.first().copied())
                    .ok_or("the canvas offers no texture format")?;
                (Some((canvas, surface)), format)
            }
            None => (None, wgpu::TextureFormat::Rgba8Unorm),
        };
        let renderer = RefCell::new(GpuStreamingRenderer::new(&ctx, UPLOADED_STEPS));
        let display = FrameDisplay::new(&ctx, format);
        Ok(Self { ctx, renderer, display, canvas, configured: RefCell::new((0, 0)), shown: RefCell::default(), lost })
    }

    /// The adapter, in words (browsers may keep its name to themselves: then empty).
    pub fn describe(&self) -> String {
        let info = &self.ctx.adapter_info;
        let software = if info.device_type == wgpu::DeviceType::Cpu { " (software)" } else { "" };
        if info.name.is_empty() { software.trim().to_owned() } else { format!("{}{software}", info.name) }
    }

    /// True when frames are drawn into the canvas (false: pictures are read back).
    pub fn presents(&self) -> bool {
        self.canvas.is_some()
    }

    /// Why the device is unusable, once it is.
    pub fn lost(&self) -> Option<String> {
        self.lost.lock().unwrap_or_else(PoisonError::into_inner).clone()
    }

    /// Destroys the device (tests of the fallback; the lost callback then fires).
    pub fn destroy(&self) {
        self.ctx.device.destroy();
    }

    /// Forgets the last full frame: the next streaming render has no temporal terms.
    pub fn jump(&self) {
        self.renderer.borrow_mut().jump();
    }

    /// Forgets everything uploaded (the render parameters' pyramid depth changed).
    pub fn clear(&self) {
        self.renderer.borrow_mut().clear();
    }

    /// Encodes and submits the render and its drawing into the canvas; returns at once (the
    /// GPU works on; [`GpuContext::finished`] tells when it is done).
    pub fn render(&self, params: &RenderParams, request: &GpuRequest<'_>) -> Result<GpuRendered, String> {
        if let Some(reason) = self.lost() {
            return Err(reason);
        }
        let camera = preview_camera(&request.camera, request.preview_level.unwrap_or(0));
        // The render and its drawing in one submit.
        let _frame = self.ctx.frame();
        let stream = StreamRequest {
            camera,
            time_step: request.time_step,
            inputs: request.inputs,
            streaming: request.streaming,
            keep: request.preview_level.is_none_or(|l| l == 0),
        };
        let (frame, temporal_used) = self.renderer.borrow_mut().render(&self.ctx, params, &stream).map_err(error)?;
        if self.canvas.is_some() {
            self.draw(&frame, request.mode)?;
        }
        let rendered = GpuRendered { width: frame.color().width, height: frame.color().height, temporal_used };
        *self.shown.borrow_mut() = Some(frame);
        Ok(rendered)
    }

    /// Draws `frame` into the canvas, scaled to the canvas's size.
    fn draw(&self, frame: &GpuFrame, mode: DisplayMode) -> Result<(), String> {
        let Some((canvas, surface)) = &self.canvas else { return Err("no canvas to draw into".into()) };
        let size = (canvas.width().max(1), canvas.height().max(1));
        if *self.configured.borrow() != size {
            let config = wgpu::SurfaceConfiguration {
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
                format: self.display.format(),
                color_space: wgpu::SurfaceColorSpace::Auto,
                width: size.0,
                height: size.1,
                present_mode: wgpu::PresentMode::Fifo,
                desired_maximum_frame_latency: 2,
                alpha_mode: wgpu::CompositeAlphaMode::Auto,
                view_formats: vec![],
            };
            surface.configure(&self.ctx.device, &config);
            *self.configured.borrow_mut() = size;
        }
        let texture = match surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t) | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
            other => {
                *self.configured.borrow_mut() = (0, 0);
                return Err(format!("the canvas gave no texture to draw into: {other:?}"));
            }
        };
        let view = texture.texture.create_view(&wgpu::TextureViewDescriptor::default());
        self.display.draw(&self.ctx, frame, mode, &view, size.0, size.1).map_err(error)?;
        // The frame's work must be submitted before the texture is presented.
        self.ctx.flush();
        self.ctx.queue.present(texture);
        Ok(())
    }

    /// The last frame rendered as `mode` (what the canvas shows), at its own resolution:
    /// `(width, height, rgba)`.
    pub async fn picture(&self, mode: DisplayMode) -> Result<(u32, u32, Vec<u8>), String> {
        let frame = self.shown.borrow().clone().ok_or("nothing rendered on the GPU yet")?;
        self.display.picture(&self.ctx, &frame, mode).await.map_err(error)
    }
}

//! Streaming on the GPU in one place: the GPU counterpart of dynview-core's
//! `StreamingRenderer`. It keeps the previous full frame (for the temporal terms of the next)
//! and the uploaded inputs of the last few time steps, so `dynview render --gpu` and the
//! viewer hold no renderer state of their own.

use std::rc::Rc;

use dynview_core::camera::Camera;
use dynview_core::render::{Method, RenderParams, TimeStepInputs};

use crate::device::context::GpuContext;
use crate::device::error::GpuError;
use crate::render::renderer::{GpuFrame, GpuInputs, GpuRenderer};

/// What to render: a camera at a time step, whether it follows the previous frame, and
/// whether it is kept as the next frame's previous one.
#[derive(Clone, Copy, Debug)]
pub struct StreamRequest<'a> {
    /// The camera (its own resolution).
    pub camera: Camera,
    /// The time step (the key of the uploaded inputs).
    pub time_step: u32,
    /// Its inputs, uploaded unless this time step's already are.
    pub inputs: &'a TimeStepInputs,
    /// Use the previous full frame for the temporal terms (playback); false for a jump.
    pub streaming: bool,
    /// Keep the frame as the previous one (false for previews while the view moves).
    pub keep: bool,
}

/// The renderer, the previous full frame, and the uploaded inputs by time step.
#[derive(Debug)]
pub struct GpuStreamingRenderer {
    renderer: GpuRenderer,
    /// Time steps whose inputs stay uploaded.
    keep_steps: usize,
    /// Uploaded inputs by time step (the views frames have needed), most recently used last.
    uploaded: Vec<(u32, GpuInputs)>,
    previous: Option<Rc<GpuFrame>>,
}

impl GpuStreamingRenderer {
    /// Compiles the kernels; the inputs of the last `keep_steps` time steps (at least 1) stay
    /// uploaded (2 covers playback: the current step and the next).
    pub fn new(ctx: &GpuContext, keep_steps: usize) -> Self {
        Self { renderer: GpuRenderer::new(ctx), keep_steps: keep_steps.max(1), uploaded: Vec::new(), previous: None }
    }

    /// Forgets the previous frame: the next render has no temporal terms.
    pub fn jump(&mut self) {
        self.previous = None;
    }

    /// True when a streaming render would use the temporal terms (with the full method).
    pub fn has_previous(&self) -> bool {
        self.previous.is_some()
    }

    /// Forgets the uploaded inputs and the previous frame (the pyramid depth changed).
    pub fn clear(&mut self) {
        self.uploaded.clear();
        self.jump();
    }

    /// The time steps whose inputs are uploaded, least recently used first.
    pub fn uploaded_steps(&self) -> Vec<u32> {
        self.uploaded.iter().map(|(t, _)| *t).collect()
    }

    /// The index in `uploaded` of `time_step`'s inputs (most recently used now), its cloud
    /// uploaded unless it already is.
    fn inputs(&mut self, ctx: &GpuContext, time_step: u32, inputs: &TimeStepInputs) -> Result<usize, GpuError> {
        if let Some(i) = self.uploaded.iter().position(|(t, _)| *t == time_step) {
            let entry = self.uploaded.remove(i);
            self.uploaded.push(entry);
        } else {
            let fresh = GpuInputs::upload_cloud(ctx, inputs)?;
            if self.uploaded.len() >= self.keep_steps {
                self.uploaded.remove(0);
            }
            self.uploaded.push((time_step, fresh));
        }
        Ok(self.uploaded.len() - 1)
    }

    /// Renders `request` (recorded and submitted; the GPU works on) and returns the frame;
    /// returns whether the temporal terms were used beside it.
    pub fn render(
        &mut self,
        ctx: &GpuContext,
        params: &RenderParams,
        request: &StreamRequest<'_>,
    ) -> Result<(Rc<GpuFrame>, bool), GpuError> {
        let slot = self.inputs(ctx, request.time_step, request.inputs)?;
        let uploaded = &mut self.uploaded[slot].1;
        self.renderer.upload_views_for(ctx, params, &request.camera, uploaded, request.inputs)?;
        let previous = if request.streaming { self.previous.clone() } else { None };
        let frame = Rc::new(self.renderer.render(ctx, params, &request.camera, uploaded, previous.as_deref())?);
        let temporal_used = previous.is_some() && params.method == Method::Full && params.temporal_levels > 0;
        if request.keep {
            self.previous = Some(frame.clone());
        }
        Ok((frame, temporal_used))
    }
}

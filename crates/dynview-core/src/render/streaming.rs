//! Rendering a sequence: each finished frame is kept as the previous frame of the next one, for
//! its temporal terms, until a jump in time drops it.
//!
//! - [`StreamingRenderer`] renders whole frames (`dynview render`, the evaluation);
//! - [`CpuStreamingRenderer`] renders one pyramid level per call, so that a single-threaded
//!   caller (the browser's worker) can show coarse levels first, yield between levels and drop
//!   stale work: the viewer's CPU path, the counterpart of `dynview_gpu::GpuStreamingRenderer`.

use std::rc::Rc;

use super::error::RenderError;
use super::frame::render_frame;
use super::hooks::RenderHooks;
use super::inputs::TimeStepInputs;
use super::job::{FrameJob, JobStep};
use super::outputs::{LevelPreview, PreviousFrame, RenderOutput};
use super::params::RenderParams;
use super::timing::Timings;
use crate::camera::Camera;
use crate::display::{self, DisplayMode};
use crate::raster::{RgbRaster, ScalarRaster};

/// Renders a sequence, carrying each output into the next frame's temporal terms.
#[derive(Debug, Default)]
pub struct StreamingRenderer {
    previous: Option<PreviousFrame>,
}

impl StreamingRenderer {
    /// A renderer without a previous frame.
    pub fn new() -> Self {
        Self::default()
    }

    /// Forgets the previous frame: the next render has no temporal terms (`w_T = 0`).
    pub fn jump(&mut self) {
        self.previous = None;
    }

    /// True when the next render will use the temporal terms (with the full method).
    pub fn has_previous(&self) -> bool {
        self.previous.is_some()
    }

    /// Renders the next frame and keeps it as the previous one.
    pub fn render(
        &mut self,
        params: &RenderParams,
        camera: &Camera,
        inputs: &TimeStepInputs,
        hooks: &mut RenderHooks,
    ) -> Result<RenderOutput, RenderError> {
        let output = render_frame(params, camera, inputs, self.previous.as_ref(), hooks)?;
        self.previous = Some(output.clone().into_previous(*camera));
        Ok(output)
    }
}

/// What [`CpuStreamingRenderer::begin`] renders: a camera at a time step, and whether it
/// follows the last finished frame.
#[derive(Clone, Debug)]
pub struct CpuStreamRequest {
    /// The camera (its own resolution).
    pub camera: Camera,
    /// The time step (kept with the finished frame).
    pub time_step: u32,
    /// Its inputs.
    pub inputs: Rc<TimeStepInputs>,
    /// Use the last finished frame for the temporal terms (playback); false for a jump.
    pub streaming: bool,
}

/// What one [`CpuStreamingRenderer::step`] achieved.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StreamProgress {
    /// The level just finished (0 = finest).
    pub level: usize,
    /// True when the frame is complete (then it is [`CpuStreamingRenderer::finished`]).
    pub done: bool,
    /// Width of the level's picture in pixels.
    pub width_px: usize,
    /// Height of the level's picture in pixels.
    pub height_px: usize,
    /// Whether the temporal terms were used (known when done; false before).
    pub temporal_used: bool,
}

/// The last finished frame: the previous frame of the next streaming render, and what is shown
/// while no render is in progress.
#[derive(Clone, Debug)]
pub struct FinishedFrame {
    /// Its camera and its solution at every pyramid level, finest first.
    pub frame: Rc<PreviousFrame>,
    /// `sum_s w_P^s` at the finest level ([`RenderOutput::view_weight`]).
    pub view_weight: ScalarRaster,
    /// How many input views it used.
    pub views_used: usize,
    /// Its time step.
    pub time_step: u32,
    /// Time per level and stage (zero without a clock).
    pub timings: Timings,
    /// Whether the temporal terms were used.
    pub temporal_used: bool,
}

/// A frame being rendered, a level per step.
#[derive(Debug)]
struct ActiveFrame {
    job: FrameJob<Rc<TimeStepInputs>, Rc<PreviousFrame>>,
    camera: Camera,
    time_step: u32,
    /// The level last finished (what [`CpuStreamingRenderer::preview`] shows).
    level: Option<usize>,
}

/// Streaming on the CPU a pyramid level at a time: the frame in progress and the last finished
/// frame (the previous frame of the next streaming render).
#[derive(Debug, Default)]
pub struct CpuStreamingRenderer {
    active: Option<ActiveFrame>,
    finished: Option<FinishedFrame>,
}

impl CpuStreamingRenderer {
    /// A renderer with nothing rendered.
    pub fn new() -> Self {
        Self::default()
    }

    /// Forgets the last finished frame: the next streaming render has no temporal terms (the
    /// frame in progress, if any, goes on).
    pub fn jump(&mut self) {
        self.finished = None;
    }

    /// True when a streaming render would use the temporal terms (with the full method).
    pub fn has_previous(&self) -> bool {
        self.finished.is_some()
    }

    /// Starts rendering `request`, dropping any render in progress (also when the request is
    /// refused). No pixel work yet: [`CpuStreamingRenderer::step`] does it.
    pub fn begin(&mut self, params: &RenderParams, request: CpuStreamRequest) -> Result<(), RenderError> {
        self.active = None;
        let previous = self.finished.as_ref().filter(|_| request.streaming).map(|f| f.frame.clone());
        let job = FrameJob::new(params.clone(), request.camera, request.inputs, previous)?;
        self.active = Some(ActiveFrame { job, camera: request.camera, time_step: request.time_step, level: None });
        Ok(())
    }

    /// True while a render is in progress.
    pub fn is_rendering(&self) -> bool {
        self.active.is_some()
    }

    /// Drops the render in progress.
    pub fn cancel(&mut self) {
        self.active = None;
    }

    /// Solves the next pyramid level of the render in progress; after the finest, the frame
    /// becomes the finished one. Without a render in progress, returns
    /// [`RenderError::Cancelled`]; a failed level leaves the render in progress.
    pub fn step(&mut self, hooks: &mut RenderHooks) -> Result<StreamProgress, RenderError> {
        let Some(active) = self.active.as_mut() else {
            return Err(RenderError::Cancelled);
        };
        match active.job.step(hooks)? {
            JobStep::Level(level) => {
                active.level = Some(level);
                let preview = active.job.preview(level);
                let (width_px, height_px) = (preview.color.width, preview.color.height);
                Ok(StreamProgress { level, done: false, width_px, height_px, temporal_used: false })
            }
            JobStep::Done(output) => {
                let (camera, time_step) = (active.camera, active.time_step);
                self.active = None;
                let output = *output;
                let (width_px, height_px, temporal_used) = (output.color.width, output.color.height, output.temporal_used);
                self.finished = Some(FinishedFrame {
                    view_weight: output.view_weight.clone(),
                    views_used: output.views_used.len(),
                    time_step,
                    timings: output.timings.clone(),
                    temporal_used,
                    frame: Rc::new(output.into_previous(camera)),
                });
                Ok(StreamProgress { level: 0, done: true, width_px, height_px, temporal_used })
            }
        }
    }

    /// The level last finished of the render in progress, if one is.
    pub fn preview(&self) -> Option<LevelPreview<'_>> {
        let active = self.active.as_ref()?;
        active.level.map(|level| active.job.preview(level))
    }

    /// The last finished frame, if any.
    pub fn finished(&self) -> Option<&FinishedFrame> {
        self.finished.as_ref()
    }

    /// The picture of the render in progress (its last finished level) or else of the last
    /// finished frame, as `mode`, at that level's resolution; `None` before anything is
    /// rendered. A level in progress has no view weights yet: its `weights` picture is black.
    pub fn picture(&self, mode: DisplayMode) -> Option<RgbRaster> {
        if let Some(preview) = self.preview() {
            return Some(display::picture(mode, preview.color, preview.depth, None, 0));
        }
        let finished = self.finished.as_ref()?;
        let finest = &finished.frame.levels[0];
        Some(display::picture(mode, &finest.color, &finest.depth, Some(&finished.view_weight), finished.views_used))
    }
}

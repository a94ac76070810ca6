//! The renderer of METHOD.md Part 2: for a virtual camera at time t, depth and color by the
//! coarse-to-fine alternation of two variational diffusions, with temporal consistency when
//! streaming. Also the baselines it is compared with (see [`Method`]).
//!
//! - [`render_frame`] renders one frame, optionally with a previous frame for the temporal terms;
//! - [`FrameJob`] renders one frame a pyramid level at a time (progressive display, cancel);
//! - [`StreamingRenderer`] carries the previous frame from call to call (playback), and drops it
//!   on [`StreamingRenderer::jump`] (the viewer jumped in time: no temporal terms).

mod frame;
mod job;
mod params;
pub mod plane;
pub mod pushpull;
pub mod pyramid;
pub mod solve;
pub mod sparse;
mod timing;
pub mod transfer;
pub mod warp;
pub mod weights;

pub use frame::{
    FALLBACK_COLOR, FALLBACK_DEPTH, InputView, LevelPreview, LevelSolution, PreviousFrame, RenderError, RenderHooks, RenderOutput,
    SolveKind, SolveTrace, TimeStepInputs, render_frame,
};
pub use job::{FrameJob, JobStep};
pub use params::{Method, ParamsError, RenderParams};
pub use timing::{LevelTimings, Stage, Timings};

use crate::camera::Camera;

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

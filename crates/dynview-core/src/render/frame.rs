//! Rendering one novel frame to completion: a [`FrameJob`] run level after level, with the
//! caller's per-level callback in between.

use super::error::RenderError;
use super::hooks::RenderHooks;
use super::inputs::TimeStepInputs;
use super::job::{FrameJob, JobStep};
use super::outputs::{LevelPreview, PreviousFrame, RenderOutput};
use super::params::RenderParams;
use crate::camera::Camera;

/// Renders the virtual `camera` at the time step of `inputs` with `params.method`. With
/// `previous` (and the full method), the temporal terms are active; without it, `w_T = 0`.
/// This runs a [`FrameJob`] to completion; `hooks.on_level` sees every level and may cancel.
pub fn render_frame(
    params: &RenderParams,
    camera: &Camera,
    inputs: &TimeStepInputs,
    previous: Option<&PreviousFrame>,
    hooks: &mut RenderHooks,
) -> Result<RenderOutput, RenderError> {
    let mut job = FrameJob::new(params.clone(), *camera, inputs, previous)?;
    loop {
        match job.step(hooks)? {
            JobStep::Level(level) => {
                if let Some(on_level) = hooks.on_level.as_mut()
                    && !on_level(job.preview(level))
                {
                    return Err(RenderError::Cancelled);
                }
            }
            JobStep::Done(output) => {
                if let Some(on_level) = hooks.on_level.as_mut()
                    && !on_level(LevelPreview { level: 0, color: &output.color, depth: &output.depth })
                {
                    return Err(RenderError::Cancelled);
                }
                return Ok(*output);
            }
        }
    }
}

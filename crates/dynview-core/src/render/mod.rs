//! The renderer of METHOD.md Part 2: for a virtual camera at time t, depth and color by the
//! coarse-to-fine alternation of two variational diffusions, with temporal consistency when
//! streaming. Also the baselines it is compared with (see [`Method`]).
//!
//! The stages, from what goes in to what comes out:
//!
//! - `inputs`: a time step's input views (frame pyramids) and sparse cloud, [`TimeStepInputs`];
//! - `params`: the method and its weights, [`RenderParams`];
//! - the building blocks of one pyramid level: [`pyramid`], [`transfer`], [`warp`], [`sparse`],
//!   [`pushpull`], [`plane`], [`weights`], [`solve`], assembled per level by `levels`;
//! - `job`: [`FrameJob`] renders one frame a pyramid level at a time (progressive display,
//!   cancel); `frame`: [`render_frame`] runs one to completion;
//! - `outputs`: the frame and its levels ([`RenderOutput`], [`PreviousFrame`]); `hooks`:
//!   clock, per-level callback and solve traces; `error`: [`RenderError`];
//! - `streaming`: sequences, each frame feeding the next one's temporal terms:
//!   [`StreamingRenderer`] whole frames at a time, [`CpuStreamingRenderer`] a level at a time
//!   (the viewer's CPU path), both dropping the previous frame on `jump` (no temporal terms).

mod error;
mod frame;
mod hooks;
mod inputs;
mod job;
mod levels;
mod outputs;
mod params;
pub mod plane;
pub mod plates;
pub mod pushpull;
pub mod pyramid;
pub mod solve;
pub mod sparse;
mod streaming;
pub mod surround;
mod timing;
pub mod transfer;
pub mod warp;
pub mod weights;

pub use error::RenderError;
pub use frame::render_frame;
pub use hooks::{RenderHooks, SolveKind, SolveTrace};
pub use inputs::{InputView, PlatePyramids, TimeStepInputs};
pub use job::{FrameJob, JobStep};
pub use levels::{FALLBACK_COLOR, FALLBACK_DEPTH};
pub use outputs::{LevelPreview, LevelSolution, PreviousFrame, RenderOutput};
pub use params::{Method, ParamsError, RenderParams};
pub use streaming::{CpuStreamRequest, CpuStreamingRenderer, FinishedFrame, StreamProgress, StreamingRenderer};
pub use timing::{LevelTimings, Stage, Timings};

#[cfg(test)]
mod streaming_tests;

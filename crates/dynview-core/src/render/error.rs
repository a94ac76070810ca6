//! Why a render fails: a bad request, or a cancel.

use super::params::ParamsError;

/// Errors of rendering.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// A parameter is out of range.
    #[error(transparent)]
    Params(#[from] ParamsError),
    /// No input view was given.
    #[error("no input views for this time step")]
    NoViews,
    /// An input frame's size does not match its camera.
    #[error("input view {index}: frame is {width}x{height}, camera says {camera_width}x{camera_height}")]
    ViewSize {
        /// The view.
        index: usize,
        /// Frame width.
        width: usize,
        /// Frame height.
        height: usize,
        /// Camera width.
        camera_width: u32,
        /// Camera height.
        camera_height: u32,
    },
    /// An input view's background plate differs in size from its frame.
    #[error("input view {index}: plate is {width}x{height}, its frame {frame_width}x{frame_height}")]
    PlateSize {
        /// The view.
        index: usize,
        /// Plate width.
        width: usize,
        /// Plate height.
        height: usize,
        /// Frame width.
        frame_width: usize,
        /// Frame height.
        frame_height: usize,
    },
    /// More static points than points in the cloud.
    #[error("the time step says {static_points} of its points are static, but it has {points}")]
    StaticPoints {
        /// Static points claimed.
        static_points: usize,
        /// Points in the cloud.
        points: usize,
    },
    /// The output camera is empty or too large.
    #[error("output size {width}x{height} is not in 1..=16384")]
    OutputSize {
        /// Width.
        width: u32,
        /// Height.
        height: u32,
    },
    /// The caller's level callback asked to stop.
    #[error("rendering cancelled")]
    Cancelled,
}

//! What the renderer gives back: a rendered frame, the solution of each pyramid level (kept for
//! the next frame's temporal terms), and the coarse previews offered while a frame is rendered.

use super::plane::WorldPlane;
use super::timing::Timings;
use crate::camera::{Camera, Intrinsics, Rigid3};
use crate::raster::{RgbRaster, ScalarRaster};

/// Depth and color of a render at one pyramid level.
#[derive(Clone, Debug)]
pub struct LevelSolution {
    /// Color.
    pub color: RgbRaster,
    /// z-depth.
    pub depth: ScalarRaster,
}

/// A previously rendered frame, for the temporal terms: its camera and its solution at every
/// pyramid level (finest first). Each level's temporal terms use the same level of the
/// previous frame: warping the finest previous frame into a coarse level instead picks the
/// nearest of many samples per pixel, biases depth toward the foreground at every edge, and
/// the bias accumulates over frames (1.6 dB lost on the synthetic event).
#[derive(Clone, Debug)]
pub struct PreviousFrame {
    /// Its camera (full resolution).
    pub camera: Camera,
    /// Its solution per level, finest first.
    pub levels: Vec<LevelSolution>,
    /// The plane its depth was pulled toward (kept for the next frame while it still fits).
    pub plane: Option<WorldPlane>,
}

pub(super) fn previous_camera(previous: Option<&PreviousFrame>) -> Camera {
    previous.map(|p| p.camera).unwrap_or(Camera {
        intrinsics: Intrinsics { fx: 1.0, fy: 1.0, cx: 0.0, cy: 0.0 },
        camera_from_world: Rigid3::IDENTITY,
        width_px: 1,
        height_px: 1,
    })
}

/// A rendered frame.
#[derive(Clone, Debug)]
pub struct RenderOutput {
    /// Color at the requested resolution.
    pub color: RgbRaster,
    /// z-depth.
    pub depth: ScalarRaster,
    /// `sum_s w_P^s` at the finest level, as the color energy weighs the views (rank
    /// preference included): how well the views agree, the viewer's "weights" display. Zero
    /// for the non-variational baselines.
    pub view_weight: ScalarRaster,
    /// Indices of the input views used, best first.
    pub views_used: Vec<usize>,
    /// Whether the temporal terms were active.
    pub temporal_used: bool,
    /// Time per level and stage (zero without a clock).
    pub timings: Timings,
    /// The solutions of the coarser levels (level 1 first; empty for the baselines), kept for
    /// the next frame's temporal terms.
    pub coarse_levels: Vec<LevelSolution>,
    /// The plane the depth was pulled toward (`lambda_plane`), if one fitted.
    pub plane: Option<WorldPlane>,
}

impl RenderOutput {
    /// This frame as the previous frame of the next one.
    pub fn into_previous(self, camera: Camera) -> PreviousFrame {
        let mut levels = vec![LevelSolution { color: self.color, depth: self.depth }];
        levels.extend(self.coarse_levels);
        PreviousFrame { camera, levels, plane: self.plane }
    }
}

/// A coarse result offered to the caller after each pyramid level (progressive display).
pub struct LevelPreview<'a> {
    /// The level just finished (0 = finest).
    pub level: usize,
    /// Its color.
    pub color: &'a RgbRaster,
    /// Its depth.
    pub depth: &'a ScalarRaster,
}

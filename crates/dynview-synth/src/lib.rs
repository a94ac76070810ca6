//! Synthetic dynamic events with ground truth, for tests, benchmarks and the demo.
//!
//! [`generate`] ray-traces a textured scene (a ground, a back wall, static objects, a bouncing
//! ball and a spinning box) from input cameras on a 60-degree arc and from a held-out camera
//! that moves between them, and writes:
//!
//! - `input/<camera>/<frame:05>.png`: the input frames, one folder per camera;
//! - `videos/<camera>.mp4`: one video per camera, when `ffmpeg` is installed;
//! - `heldout/color/<frame:05>.png`, `heldout/depth/<frame:05>.png` (+ `scale.json`): the
//!   moving held-out camera's ground truth; `heldout_static/` the same for a held-out camera
//!   that stands still mid-arc (for flicker, whose ground truth changes only where things move);
//! - `colmap/`, `heldout/colmap/` and `heldout_static/colmap/`: ground-truth poses as COLMAP
//!   text models (image names `<camera>/<frame file>`), with noise-free surface points of frame 0;
//! - `camera_path.json` and `camera_path_static.json`: the held-out paths as nerfstudio camera
//!   paths;
//! - `scene/`: a ground-truth scene package whose clouds are noisy samples of the visible
//!   surfaces with a share of outliers;
//! - `synth.json`: the configuration and what was written.
//!
//! With [`SynthConfig::unsync`] ([`unsync::UnsyncConfig::phones`], `dynview synth --unsync`),
//! the input cameras are not synchronized: each films on its own clock ([`unsync`] states the
//! convention), starting a different, non-whole-frame time before the event and stopping a
//! different time after it, at its own frame rate (one at twice the rate, one at a variable
//! rate), one in portrait, one with a drifting clock, each with its own microphone
//! ([`sound`]). Then:
//!
//! - `input/<camera>/<frame:05>.png` holds each camera's own frames in order, upright (the
//!   portrait camera's `height x width`); PNGs carry no times: `unsync/<camera>.json` does;
//! - `videos/<camera>.mp4` has each frame at its own time (the variable-rate camera's jittered
//!   timestamps included), the portrait camera's frames stored in landscape with rotation
//!   metadata (players show them upright), and, with audio, an AAC track at 48 kHz mono: the
//!   event's sounds delayed by their distance at 343 m/s and the camera's own noise;
//! - `unsync/<camera>.json`: per frame its video time and the event time it shows, and when each
//!   discrete sound reaches the camera;
//! - `synth.json`'s `time_alignment`: per camera `start_s`, `rate`, nominal fps, frame rate
//!   variability, rotation, frame count and sound delay;
//! - `colmap/` lists each camera's own frames with their poses at the event times they show
//!   (the portrait camera with its portrait intrinsics); the held-out cameras, the clouds and
//!   the scene package stay on the synchronized timeline, rendered at the time steps.

mod error;
mod files;
mod record;
pub mod render;
pub mod rig;
pub mod scene;
pub mod sound;
pub mod texture;
pub mod unsync;
mod video;
mod write;
#[cfg(test)]
mod write_tests;

use serde::{Deserialize, Serialize};

pub use error::SynthError;
pub use video::ffmpeg_available;
pub use write::{OBJECT_DIR, OBJECTS_FILE, ObjectEntry, generate};

/// Marker file of a synth output folder.
pub const SYNTH_MARKER: &str = "synth.json";

/// What to generate.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SynthConfig {
    /// Number of input cameras.
    pub cameras: usize,
    /// Number of frames (time steps).
    pub frames: u32,
    /// Frame width in pixels.
    pub width: u32,
    /// Frame height in pixels.
    pub height: u32,
    /// Frames per second.
    pub fps: f64,
    /// Seed of textures, wobble and point sampling.
    pub seed: u64,
    /// Hand-held input cameras (smooth wobble) instead of tripods.
    pub handheld: bool,
    /// Color samples per pixel along each axis (anti-aliasing).
    pub supersample: u32,
    /// Share of each input frame's pixels sampled into the ground-truth clouds.
    pub point_fraction: f64,
    /// Standard deviation of the Gaussian noise added to cloud points (m, per axis).
    pub point_noise_m: f64,
    /// Share of cloud points that are outliers (depth scaled by 0.6 to 1.4).
    pub outlier_fraction: f64,
    /// Write `videos/*.mp4` when ffmpeg is available.
    pub videos: bool,
    /// Where the input cameras stand and their lenses (default: a 60-degree arc, one lens).
    pub layout: rig::Layout,
    /// Unsynchronized input cameras (own clocks, frame rates, orientation, audio); `None`:
    /// every camera films every time step.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unsync: Option<unsync::UnsyncConfig>,
    /// Adds a small, fast, untextured ball and a plain-coloured box to the moving things
    /// ([`scene::plain_movers`]): what stereo cannot match.
    #[serde(default)]
    pub plain_movers: bool,
}

impl Default for SynthConfig {
    fn default() -> Self {
        Self {
            cameras: 6,
            frames: 30,
            width: 960,
            height: 540,
            fps: 30.0,
            seed: 1,
            handheld: false,
            supersample: 1,
            point_fraction: 0.004,
            point_noise_m: 0.005,
            outlier_fraction: 0.02,
            videos: true,
            layout: rig::Layout::default(),
            unsync: None,
            plain_movers: false,
        }
    }
}

impl SynthConfig {
    /// Checks every option's range.
    pub fn validate(&self) -> Result<(), SynthError> {
        let bad = |field, problem: String| Err(SynthError::Config { field, problem });
        if !(2..=64).contains(&self.cameras) {
            return bad("cameras", format!("must be in 2..=64, found {}", self.cameras));
        }
        if !(1..=100_000).contains(&self.frames) {
            return bad("frames", format!("must be in 1..=100000, found {}", self.frames));
        }
        for (field, v) in [("width", self.width), ("height", self.height)] {
            if !(16..=8192).contains(&v) {
                return bad(field, format!("must be in 16..=8192, found {v}"));
            }
        }
        if !(self.fps.is_finite() && self.fps > 0.0 && self.fps <= 1000.0) {
            return bad("fps", format!("must be in (0, 1000], found {}", self.fps));
        }
        if !(1..=8).contains(&self.supersample) {
            return bad("supersample", format!("must be in 1..=8, found {}", self.supersample));
        }
        for (field, v) in [("point_fraction", self.point_fraction), ("outlier_fraction", self.outlier_fraction)] {
            if !(0.0..=1.0).contains(&v) {
                return bad(field, format!("must be in [0, 1], found {v}"));
            }
        }
        if !(self.point_noise_m.is_finite() && (0.0..=1.0).contains(&self.point_noise_m)) {
            return bad("point_noise_m", format!("must be in [0, 1] m, found {}", self.point_noise_m));
        }
        let layout = &self.layout;
        if !(layout.arc_deg.is_finite() && layout.arc_deg > 0.0 && layout.arc_deg <= 180.0) {
            return bad("layout.arc_deg", format!("must be in (0, 180], found {}", layout.arc_deg));
        }
        if let Some(range) = layout.focal_range
            && !range.iter().all(|f| f.is_finite() && (0.2..=5.0).contains(f))
        {
            return bad("layout.focal_range", format!("each must be in [0.2, 5] x the longer side, found {range:?}"));
        }
        let [dx, dy] = layout.principal_offset_px;
        if !(dx.is_finite() && dy.is_finite() && dx.abs() <= f64::from(self.width) / 4.0 && dy.abs() <= f64::from(self.height) / 4.0) {
            return bad("layout.principal_offset_px", format!("must be within a quarter of the image, found [{dx}, {dy}]"));
        }
        if !(layout.height_spread_m.is_finite() && (0.0..=rig::CAMERA_HEIGHT_M).contains(&layout.height_spread_m)) {
            let most = rig::CAMERA_HEIGHT_M;
            return bad(
                "layout.height_spread_m",
                format!("must be in [0, {most}] m (no camera below the floor), found {}", layout.height_spread_m),
            );
        }
        if let Some(unsync) = &self.unsync {
            unsync.validate(self.cameras)?;
        }
        Ok(())
    }

    /// Name of input camera `i`.
    pub fn camera_name(i: usize) -> String {
        format!("cam{i:02}")
    }

    /// Duration of the event in seconds.
    pub fn duration_s(&self) -> f64 {
        f64::from(self.frames) / self.fps
    }

    /// Time of frame `t` in seconds.
    pub fn time_s(&self, t: u32) -> f64 {
        f64::from(t) / self.fps
    }
}

/// A summary of a finished run.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SynthReport {
    /// The configuration used.
    pub config: SynthConfig,
    /// Whether `videos/` was written.
    pub videos_written: bool,
    /// Points in the ground-truth clouds, per time step.
    pub points_per_step: Vec<u32>,
    /// Size of the ground-truth scene package in bytes.
    pub package_bytes: u64,
    /// With unsynchronized cameras: each camera's clock and recording (the ground truth of a
    /// time alignment).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time_alignment: Option<unsync::TimeAlignment>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_height_spread_that_would_put_a_camera_below_the_floor_is_refused_by_name() {
        let with_spread =
            |height_spread_m| SynthConfig { layout: rig::Layout { height_spread_m, ..rig::Layout::default() }, ..SynthConfig::default() };
        assert!(with_spread(1.0).validate().is_ok());
        for spread in [rig::CAMERA_HEIGHT_M + 0.1, -0.5, f64::NAN] {
            let error = with_spread(spread).validate().expect_err("refused").to_string();
            assert!(error.contains("layout.height_spread_m"), "{error}");
        }
    }
}

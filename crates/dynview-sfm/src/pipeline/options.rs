//! What `dynview prep` can be told ([`PrepOptions`], checked by [`PrepOptions::validate`]),
//! its stages ([`Stage`]) and what it reports ([`PrepReport`], `report.json`).

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use crate::error::{SfmError, SfmResult};
use crate::features::matching::MatchOptions;
use crate::features::sift::FeatureOptions;
use crate::input::calibration::{KnownCameras, KnownIntrinsics};
use crate::input::frames::EventFrames;
use crate::input::timing::retime::Retime;
use crate::input::timing::visual::VisualOptions;
use crate::input::timing::{SyncMethod, TimeAlignment};
use crate::mapping::incremental::MapperOptions;
use crate::mapping::refine::{RefineOptions, RefineReport};
use crate::mapping::step_adjust::{StepAdjustOptions, StepAdjustReport};
use crate::mapping::step_placement::{StepPlacement, StepPlacementOptions};
use crate::pipeline::export::{ExportReport, PackageOptions};
use crate::pipeline::timesteps::{StepOptions, StepsReport};

/// The stages, in order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub enum Stage {
    /// Cameras found, videos decoded, frame counts checked.
    Frames,
    /// Keyframe structure from motion.
    Keyframes,
    /// Every frame posed.
    Poses,
    /// Every time step's points (and densification) and package frames.
    Points,
    /// The scene package.
    Package,
}

impl std::str::FromStr for Stage {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "frames" => Ok(Self::Frames),
            "keyframes" => Ok(Self::Keyframes),
            "poses" => Ok(Self::Poses),
            "points" => Ok(Self::Points),
            "package" => Ok(Self::Package),
            other => Err(format!("unknown stage {other:?} (expected frames, keyframes, poses, points or package)")),
        }
    }
}

/// Everything `prep`'s pose stages can be told.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PrepOptions {
    /// Every `keyframe_interval`-th frame of every camera is a keyframe (the paper's kappa).
    /// 20: every 10 renders every Panoptic camera left out better from our own poses (mean
    /// own - calibrated -1.16 -> -0.85 dB) but takes `cargo xtask bench prep` from 495 to 788 s,
    /// past its 10 minutes (keyframe matching 36 -> 186 s, reconstruction 6 -> 44 s;
    /// `docs/results/sfm.md`).
    pub keyframe_interval: usize,
    /// Keep the first N frames of every camera when counts differ, N the shortest (with a
    /// warning); `false` makes differing counts an error.
    pub trim: bool,
    /// Focal lengths (px) known per camera name; others are estimated.
    pub focal_px: BTreeMap<String, f64>,
    /// A focal length (px) for every camera not in `focal_px`.
    pub focal_px_all: Option<f64>,
    /// Feature extraction.
    pub features: FeatureOptions,
    /// Matching and verification.
    pub matching: MatchOptions,
    /// The keyframe reconstruction.
    pub mapper: MapperOptions,
    /// Frame-to-frame refinement.
    pub refine: RefineOptions,
    /// The last stage to run.
    pub stop_after: Stage,
    /// Known poses (a COLMAP model folder or a `poses.json`): pose estimation is skipped.
    pub poses: Option<PathBuf>,
    /// Known intrinsics and distortion per camera (a COLMAP model folder or a `poses.json`;
    /// poses in it are ignored): frames with a distortion are undistorted first, and the
    /// intrinsics are kept fixed.
    pub intrinsics: Option<PathBuf>,
    /// The per-timestep stage.
    pub steps: StepOptions,
    /// The adjustment of intrinsics and poses over sampled time steps after the frame-to-frame
    /// refinement.
    #[serde(default)]
    pub step_adjust: StepAdjustOptions,
    /// Still cameras the keyframes left out, placed from the time steps before their
    /// adjustment.
    #[serde(default)]
    pub step_placement: StepPlacementOptions,
    /// What the package holds and how: the static cloud, video or JPEG frames.
    #[serde(default)]
    pub package: PackageOptions,
    /// Only these time steps (half-open, cut at the event's end) after the pose stage, and no
    /// package: a range job whose output `dynview merge` joins with the others.
    pub frames: Option<Range<usize>>,
    /// Time steps per second of the package; by default the slowest camera's frame rate
    /// (image folders: 30).
    pub fps: Option<f64>,
    /// How the cameras' clocks are found (ignored when `offsets_s` is given).
    #[serde(default)]
    pub sync: SyncMethod,
    /// Per camera, the time in its video (s) of one moment every camera filmed (`--offsets`).
    #[serde(default)]
    pub offsets_s: BTreeMap<String, f64>,
    /// The package's first time step at this time (s) of this camera's video (`--start-at`).
    #[serde(default)]
    pub start_at: Option<(String, f64)>,
    /// How offsets are found from the pictures (`sync` visual).
    #[serde(default)]
    pub visual_sync: VisualOptions,
    /// How a step gets the frame of a camera that did not film at its moment (`--retime`).
    #[serde(default)]
    pub retime: Retime,
}

impl Default for PrepOptions {
    fn default() -> Self {
        Self {
            keyframe_interval: 20,
            trim: true,
            focal_px: BTreeMap::new(),
            focal_px_all: None,
            features: FeatureOptions::default(),
            matching: MatchOptions::default(),
            mapper: MapperOptions::default(),
            refine: RefineOptions::default(),
            stop_after: Stage::Package,
            poses: None,
            intrinsics: None,
            steps: StepOptions::default(),
            step_adjust: StepAdjustOptions::default(),
            step_placement: StepPlacementOptions::default(),
            package: PackageOptions::default(),
            frames: None,
            fps: None,
            sync: SyncMethod::default(),
            offsets_s: BTreeMap::new(),
            visual_sync: VisualOptions::default(),
            start_at: None,
            retime: Retime::default(),
        }
    }
}

impl PrepOptions {
    /// Adds the focal lengths given with `--focal` to `known` for the cameras of `frames` it
    /// does not know yet (a calibration's intrinsics stay).
    pub fn add_given_focals(&self, frames: &EventFrames, known: &mut KnownCameras) {
        for c in &frames.cameras {
            if !known.contains_key(&c.name)
                && let Some(f) = self.focal_px.get(&c.name).copied().or(self.focal_px_all)
            {
                known.insert(c.name.clone(), KnownIntrinsics::focal(f, c.width, c.height));
            }
        }
    }

    /// Checks ranges.
    pub fn validate(&self) -> SfmResult<()> {
        self.visual_sync.validate()?;
        // Checked here too, not only where the package is written: a bad value must not cost
        // the stages before it.
        if let Some(hull) = &self.package.hull {
            hull.validate()?;
        }
        if let Some(free_space) = &self.package.free_space {
            free_space.validate()?;
        }
        let bad = |option, problem: String| Err(SfmError::Option { option, problem });
        if !(1..=10_000).contains(&self.keyframe_interval) {
            return bad("keyframe-interval", format!("must be in 1..=10000, found {}", self.keyframe_interval));
        }
        for (name, f) in self.focal_px.iter().map(|(k, v)| (k.as_str(), *v)).chain(self.focal_px_all.map(|f| ("all", f))) {
            if !(f.is_finite() && f > 0.0 && f < 1e6) {
                return bad("focal", format!("focal of {name} must be a positive number of pixels, found {f}"));
            }
        }
        if !(self.refine.smoothness.is_finite() && self.refine.smoothness >= 0.0) {
            return bad("smoothness", format!("must be >= 0, found {}", self.refine.smoothness));
        }
        if !(16..=8192).contains(&self.steps.working_width) {
            return bad("working-width", format!("must be in 16..=8192 px, found {}", self.steps.working_width));
        }
        if let Some(d) = &self.steps.densify
            && !(1..=dynview_core::scene::limits::MAX_POINTS_PER_STEP as usize).contains(&d.target_points)
        {
            return bad(
                "target-points",
                format!("must be in 1..={}, found {}", dynview_core::scene::limits::MAX_POINTS_PER_STEP, d.target_points),
            );
        }
        if let Some(r) = &self.frames
            && r.start >= r.end
        {
            return bad("frames", format!("{}..{} is empty (give A..B with A < B, B excluded)", r.start, r.end));
        }
        if let Some(fps) = self.fps
            && !(fps.is_finite() && fps > 0.0 && fps <= 1000.0)
        {
            return bad("fps", format!("must be in (0, 1000], found {fps}"));
        }
        Ok(())
    }
}

/// What a run did.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct PrepReport {
    /// Cameras.
    pub cameras: usize,
    /// Frames per camera.
    pub frames: usize,
    /// How the cameras were put on one timeline: the method, and per camera where the first
    /// time step sits in its video, its clock rate and the confidence.
    #[serde(default)]
    pub time_alignment: Option<TimeAlignment>,
    /// Keyframes in the reconstruction.
    pub keyframes: usize,
    /// Keyframes registered.
    pub keyframes_registered: usize,
    /// Keyframes placed from a verified pair with a placed keyframe, the translation's length
    /// from their few points, because PnP had too few correspondences ("camera frame t").
    #[serde(default)]
    pub keyframes_placed_from_pair: Vec<String>,
    /// Points of the keyframe model.
    pub keyframe_points: usize,
    /// RMS reprojection error of the keyframe model (px).
    pub keyframe_rms_px: f64,
    /// How each camera's focal was initialised.
    pub focal_source: Vec<String>,
    /// Per camera, which intrinsics the keyframe reconstruction refined and why.
    #[serde(default)]
    pub intrinsics_refined: Vec<String>,
    /// Per camera, the standard deviation of its refined focal length in % of it (`None`:
    /// given, or not measured).
    #[serde(default)]
    pub focal_std_percent: Vec<Option<f64>>,
    /// Per camera refinement figures.
    pub refine: Vec<RefineReport>,
    /// The adjustment over sampled time steps, when it ran.
    #[serde(default)]
    pub step_adjustment: Option<StepAdjustReport>,
    /// Still cameras the keyframes left out, and how the time steps placed them (or did not).
    #[serde(default)]
    pub step_placement: Vec<StepPlacement>,
    /// Stages skipped because an earlier run had finished them.
    pub skipped: Vec<String>,
    /// Seconds per stage run.
    pub stage_seconds: Vec<(String, f64)>,
    /// Where `poses.json` was written, when the pose stage ran.
    pub poses_file: Option<PathBuf>,
    /// Problems worked around: cameras left out, frames trimmed, poses filled in.
    pub warnings: Vec<String>,
    /// The time steps, when they ran.
    pub steps: Option<StepsReport>,
    /// The package, when it was written.
    pub package: Option<ExportReport>,
    /// Where the package was written.
    pub package_dir: Option<PathBuf>,
}

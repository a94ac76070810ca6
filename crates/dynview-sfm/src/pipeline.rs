//! `dynview prep`'s pose stages end to end: frames, keyframe reconstruction, frame-to-frame
//! refinement; each saved in the work folder and skipped on a re-run with the same inputs.

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use dynview_core::StageProgress;
use dynview_core::scene::manifest::PoseEntry;
use dynview_interchange::poses::{CameraPoses, EventPoses, FramePose, POSES_FILE};

use crate::calibration::{KnownCameras, KnownIntrinsics, calibration_for, known_intrinsics, read_poses, undistort_frames};
use crate::error::{SfmError, SfmResult};
use crate::export::{ExportReport, export_package, usable_poses};
use crate::features::{FeatureOptions, Features};
use crate::focal::PRIOR_FOCAL_FACTOR;
use crate::geometry::{Intrinsics, Pose};
use crate::incremental::MapperOptions;
use crate::input::{EventFrames, decode_frames, discover, video_fps};
use crate::keyframes::{
    Keyframe, KeyframeModel, PRIOR_FOCAL_SOURCE, focal_std_fractions, intrinsics_groups, intrinsics_notes, keyframe_features, keyframes,
    match_all_pairs, per_group, reconstruct_keyframes, to_colmap, weak_focal_warnings, write_colmap_text,
};
use crate::matching::MatchOptions;
use crate::refine::{CameraTrack, KeyframeView, RefineOptions, RefineReport, refine_camera};
use crate::step_adjust::{StepAdjustOptions, StepAdjustReport, StepCameras, adjust_with_steps};
use crate::timesteps::{StepOptions, StepSettings, StepsReport, run_steps};
use crate::work::WorkDir;

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
    /// What the package holds and how: the static cloud, video or JPEG frames.
    #[serde(default)]
    pub package: crate::export::PackageOptions,
    /// Only these time steps (half-open, cut at the event's end) after the pose stage, and no
    /// package: a range job whose output `dynview merge` joins with the others.
    pub frames: Option<Range<usize>>,
    /// Frames per second of the capture; by default the first video's, else 30.
    pub fps: Option<f64>,
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
            package: crate::export::PackageOptions::default(),
            frames: None,
            fps: None,
        }
    }
}

impl PrepOptions {
    /// Checks ranges.
    pub fn validate(&self) -> SfmResult<()> {
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

/// The report's file in the output folder.
pub const REPORT_FILE: &str = "report.json";
/// The package's folder in the output folder.
pub const SCENE_DIR: &str = "scene";

/// Runs `prep` from `input` into `out`: the pose stages, the time steps, the package
/// (`out/scene`) and the report (`out/report.json`); work files under `out/work`.
pub fn run(input: &Path, out: &Path, options: &PrepOptions, progress: StageProgress, interrupt: &AtomicBool) -> SfmResult<PrepReport> {
    options.validate()?;
    let work = WorkDir::new(out);
    std::fs::create_dir_all(work.path()).map_err(SfmError::io(work.path()))?;
    let mut report = PrepReport::default();
    let mut timer = std::time::Instant::now();
    let mut lap = |report: &mut PrepReport, name: &str| {
        report.stage_seconds.push((name.to_string(), timer.elapsed().as_secs_f64()));
        timer = std::time::Instant::now();
    };
    let cameras = discover(input)?;
    let fps = options.fps.or_else(|| video_fps(&cameras)).unwrap_or(DEFAULT_FPS);
    let Some((frames, event)) = pose_stages(&work, out, &cameras, options, &mut report, &mut lap, progress, interrupt)? else {
        return finish(out, report);
    };
    if options.stop_after == Stage::Poses {
        return finish(out, report);
    }

    let (event, warnings) = usable_poses(&event);
    report.warnings.extend(warnings);
    if event.cameras.len() < 2 {
        return Err(SfmError::Reconstruction(format!("only {} camera has poses; at least 2 are needed for points", event.cameras.len())));
    }
    let frames = undistorted_for(&work, &frames, &event, progress, interrupt)?;
    let event = EventPoses { cameras: event.cameras.into_iter().map(|c| CameraPoses { distortion: [0.0; 4], ..c }).collect() };
    let steps = event.time_step_count();
    // A range past the end is cut there, so array jobs of equal ranges need not know the length.
    let range = options.frames.clone().map_or(0..steps, |r| r.start..r.end.min(steps));
    if range.is_empty() {
        return Err(SfmError::Option {
            option: "frames",
            problem: format!("{:?} starts past the {steps} time steps of the event", options.frames.clone().unwrap_or_default()),
        });
    }
    let settings = StepSettings { options: options.steps.clone(), fps };
    report.steps = Some(run_steps(&work, &frames, &event, range, &settings, progress, interrupt)?);
    lap(&mut report, "time steps");
    if options.stop_after == Stage::Points || options.frames.is_some() {
        return finish(out, report);
    }

    let scene = out.join(SCENE_DIR);
    let name = out.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "event".into());
    let package = export_package(&[out.to_path_buf()], &scene, &name, &options.package, progress)?;
    report.warnings.extend(package.warnings.iter().filter(|w| !report.warnings.contains(w)).cloned().collect::<Vec<_>>());
    report.package = Some(package);
    report.package_dir = Some(scene);
    lap(&mut report, "package");
    finish(out, report)
}

/// Frames per second when neither `--fps` nor a video says.
pub const DEFAULT_FPS: f64 = 30.0;

fn finish(out: &Path, report: PrepReport) -> SfmResult<PrepReport> {
    let path = out.join(REPORT_FILE);
    let text = serde_json::to_vec_pretty(&report).map_err(|e| SfmError::WorkFile { path: path.clone(), problem: e.to_string() })?;
    dynview_core::fsutil::write_atomic(&path, &text).map_err(SfmError::io(&path))?;
    Ok(report)
}

/// The frames the time steps read: undistorted when the poses carry a distortion.
fn undistorted_for(
    work: &WorkDir,
    frames: &EventFrames,
    event: &EventPoses,
    progress: StageProgress,
    interrupt: &AtomicBool,
) -> SfmResult<EventFrames> {
    let mut kept =
        EventFrames { cameras: event.cameras.iter().filter_map(|c| frames.cameras.iter().find(|f| f.name == c.name).cloned()).collect() };
    if event.cameras.iter().any(|c| c.distortion.iter().any(|d| *d != 0.0)) {
        let calibration: Vec<&CameraPoses> = event.cameras.iter().collect();
        kept = undistort_frames(&kept, &calibration, &work.join("undistorted"), progress, interrupt)?;
    }
    Ok(kept)
}

type Lap<'a> = dyn FnMut(&mut PrepReport, &str) + 'a;

/// The frames and pose stages; `None` when `stop_after` ended the run before poses.
#[allow(clippy::too_many_arguments)]
fn pose_stages(
    work: &WorkDir,
    out: &Path,
    cameras: &[crate::input::DiscoveredCamera],
    options: &PrepOptions,
    report: &mut PrepReport,
    lap: &mut Lap,
    progress: StageProgress,
    interrupt: &AtomicBool,
) -> SfmResult<Option<(EventFrames, EventPoses)>> {
    let (mut frames, trimmed) = decode_frames(cameras, &work.join("frames"), options.trim, progress, interrupt)?;
    if let Some(counts) = trimmed {
        report.warnings.push(format!(
            "cameras have different frame counts ({counts}); frames are assumed synchronized from the first, so every camera was cut to its first {}",
            frames.frame_count()
        ));
    }
    // Known calibration: from --intrinsics, else from --poses.
    let calibration_file = options.intrinsics.as_ref().or(options.poses.as_ref());
    let given = calibration_file.map(|p| read_poses(p)).transpose()?;
    let mut known = KnownCameras::new();
    if let (Some(given), Some(path)) = (&given, calibration_file) {
        let calibration = calibration_for(given, path, &frames)?;
        frames = undistort_frames(&frames, &calibration, &work.join("undistorted"), progress, interrupt)?;
        known = known_intrinsics(&calibration);
    }
    for c in &frames.cameras {
        if !known.contains_key(&c.name)
            && let Some(f) = options.focal_px.get(&c.name).copied().or(options.focal_px_all)
        {
            known.insert(c.name.clone(), KnownIntrinsics::focal(f, c.width, c.height));
        }
    }
    work.write_json("frames.json", &frames)?;
    report.cameras = frames.cameras.len();
    report.frames = frames.frame_count();
    lap(report, "frames");
    if options.stop_after == Stage::Frames {
        return Ok(None);
    }

    if let (Some(path), Some(given)) = (&options.poses, &given) {
        let event = known_poses(given, path, &frames)?;
        let poses_path = out.join(POSES_FILE);
        event.write(&poses_path)?;
        report.poses_file = Some(poses_path);
        report.skipped.push(format!("pose estimation (poses from {})", path.display()));
        lap(report, "poses");
        return Ok(Some((frames, event)));
    }

    let mut keys = keyframes(&frames, options.keyframe_interval);
    let mut features = keyframe_features(work, &frames, &keys, &options.features, progress, interrupt)?;
    let unusable = textureless_cameras(&frames, &keys, &features, options.matching.min_inliers);
    if !unusable.is_empty() {
        if frames.cameras.len() - unusable.len() < 2 {
            return Err(unusable.into_iter().next().map(|(_, e)| e).unwrap_or(SfmError::Reconstruction("no cameras".into())));
        }
        for (_, error) in &unusable {
            report.warnings.push(format!("{error}: camera left out"));
        }
        let names: Vec<String> = unusable.iter().map(|(c, _)| frames.cameras[*c].name.clone()).collect();
        frames.cameras.retain(|c| !names.contains(&c.name));
        keys = keyframes(&frames, options.keyframe_interval);
        features = keyframe_features(work, &frames, &keys, &options.features, progress, interrupt)?;
    }
    lap(report, "keyframe features");
    let key_stage = (&frames, options.keyframe_interval, &options.features, &options.matching, &options.mapper, &known);
    let mapper = options.mapper.clone();
    let model: KeyframeModel = if work.is_done("keyframes", &key_stage) {
        report.skipped.push("keyframes".into());
        work.read_json("keyframes/model.json")?
    } else {
        let pairs = match_all_pairs(&features, &options.matching, progress, interrupt)?;
        lap(report, "keyframe matching");
        // What matched with what, for users wondering why a camera did not register.
        let summary: Vec<(String, String, usize, usize, usize)> = pairs
            .iter()
            .map(|(a, b, v)| {
                let name = |i: usize| {
                    format!("{}/{}", frames.cameras[keys[i].camera].name, frames.cameras[keys[i].camera].file_name(keys[i].frame))
                };
                (name(*a), name(*b), v.inliers.len(), v.fundamental_inliers, v.homography_inliers)
            })
            .collect();
        work.write_json("keyframes/pairs.json", &summary)?;
        let model = reconstruct_keyframes(&frames, &keys, &features, &pairs, &known, &options.matching, &mapper, progress, interrupt)?;
        work.write_json("keyframes/model.json", &model)?;
        write_colmap_text(&to_colmap(&model, &frames, &features), &work.join("keyframes/model"))?;
        work.mark_done("keyframes", &key_stage)?;
        model
    };
    check_two_view_model(&frames, &model, &known)?;
    let r = &model.reconstruction;
    report.keyframes = keys.len();
    report.keyframes_registered = r.poses.iter().flatten().count();
    report.keyframes_placed_from_pair = r
        .placed_from_pair
        .iter()
        .filter_map(|&k| keys.get(k))
        .map(|k| format!("{} frame {}", frames.cameras[k.camera].name, k.frame))
        .collect();
    report.keyframe_points = r.points.len();
    let errors = r.reprojection_errors_px(&model.map_images(&features));
    report.keyframe_rms_px = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len().max(1) as f64).sqrt();
    report.focal_source = model.focal_source.clone();
    report.intrinsics_refined = intrinsics_notes(&frames, &model, &known, &mapper);
    report.focal_std_percent = focal_std_fractions(&frames, &model, &known, &mapper).iter().map(|f| f.map(|f| 100.0 * f)).collect();
    lap(report, "keyframe reconstruction");
    if options.stop_after == Stage::Keyframes {
        report.warnings.extend(weak_focal_warnings(&frames, &model.reconstruction.intrinsics, &report.focal_std_percent));
        return Ok(None);
    }

    let mut poses = refine_all(work, &frames, &model, &features, options, &key_stage, report, progress, interrupt)?;
    lap(report, "poses");
    let mut model = model;
    adjust_steps(work, &frames, &mut model, &known, &mut poses, options, &key_stage, report, progress, interrupt)?;
    report.warnings.extend(weak_focal_warnings(&frames, &model.reconstruction.intrinsics, &report.focal_std_percent));
    let event = event_poses(&frames, &model, &poses);
    event.validate()?;
    let path = out.join(POSES_FILE);
    event.write(&path)?;
    report.poses_file = Some(path);
    lap(report, "time-step adjustment");
    Ok(Some((frames, event)))
}

/// Adjusts the intrinsics and `poses` over sampled time steps (`step_adjust`), or reads what an
/// earlier run found; updates `model`'s intrinsics and the report's intrinsics figures.
#[allow(clippy::too_many_arguments)]
fn adjust_steps<K: Serialize>(
    work: &WorkDir,
    frames: &EventFrames,
    model: &mut KeyframeModel,
    known: &KnownCameras,
    poses: &mut Vec<Vec<Pose>>,
    options: &PrepOptions,
    key_stage: &K,
    report: &mut PrepReport,
    progress: StageProgress,
    interrupt: &AtomicBool,
) -> SfmResult<()> {
    const STAGE: &str = "step_adjust";
    let key = (key_stage, &options.refine, &options.step_adjust);
    let adjusted: Option<(Vec<Vec<Pose>>, Vec<Intrinsics>, StepAdjustReport)> = if work.is_done(STAGE, &key) {
        report.skipped.push(STAGE.into());
        work.read_json(&format!("{STAGE}.json"))?
    } else {
        let group = intrinsics_groups(frames, known, options.mapper.share_intrinsics);
        let (intrinsics, held) = per_group(frames, known, &group, &model.reconstruction.intrinsics);
        let cameras = StepCameras {
            frames,
            group: &group,
            intrinsics,
            held,
            still: &model.still_cameras,
            principal_points_fixed: model.reconstruction.principal_point_refined,
        };
        let mut adjusted_poses = poses.clone();
        let result = adjust_with_steps(
            &cameras,
            &mut adjusted_poses,
            &options.step_adjust,
            &options.features,
            &options.mapper,
            progress,
            interrupt,
        )?
        .map(|(sets, step_report)| (adjusted_poses, group.iter().map(|&g| sets[g]).collect(), step_report));
        work.write_json(&format!("{STAGE}.json"), &result)?;
        work.mark_done(STAGE, &key)?;
        result
    };
    let Some((adjusted_poses, intrinsics, step_report)) = adjusted else { return Ok(()) };
    *poses = adjusted_poses;
    model.reconstruction.intrinsics = intrinsics;
    report.focal_std_percent = step_report.focal_std_percent.clone();
    for (c, note) in report.intrinsics_refined.iter_mut().enumerate() {
        let focal = match step_report.focal_std_percent.get(c).copied().flatten() {
            Some(std) => format!("focal {:+.2}% (known to {std:.2}%)", step_report.focal_change_percent[c]),
            None => "focal kept".to_string(),
        };
        let principal = match step_report.principal_point_std_px.get(c).copied().flatten() {
            Some(std) if step_report.principal_point_refined => format!("principal point refined (known to {std:.2} px)"),
            Some(std) if std.is_infinite() => "principal point kept (not fixed by the data)".to_string(),
            Some(std) => format!("principal point kept (fixed only to {std:.2} px)"),
            None => "principal point kept".to_string(),
        };
        note.push_str(&format!("; then over {} time steps: {focal}, {principal}", step_report.steps.len()));
    }
    report.step_adjustment = Some(step_report);
    Ok(())
}

/// Refuses a model of two viewpoints whose focal lengths nothing measured. Two views fix their
/// relative pose only given the focal length, and where no pair self-calibrated it is a guess
/// (the prior, 1.2 x the longer side): on 6 views of the Middlebury temple (every third of the
/// ring) the model placed 2 with a focal 45% short and their relative rotation 10.6 degrees
/// off. The error names the views placed and the cameras that could not be.
fn check_two_view_model(frames: &EventFrames, model: &KeyframeModel, known: &KnownCameras) -> SfmResult<()> {
    let r = &model.reconstruction;
    // Distinct viewpoints: a still camera's pooled keyframes share one pose.
    let mut viewpoints: Vec<(Pose, &Keyframe)> = Vec::new();
    for (key, pose) in model.keyframes.iter().zip(&r.poses) {
        if let Some(pose) = pose
            && !viewpoints.iter().any(|(p, _)| p == pose)
        {
            viewpoints.push((*pose, key));
        }
    }
    let guessed = |camera: usize| {
        !known.contains_key(&frames.cameras[camera].name)
            && model.focal_source.get(camera).is_some_and(|s| s.starts_with(PRIOR_FOCAL_SOURCE))
    };
    if viewpoints.len() != 2 || !viewpoints.iter().any(|(_, k)| guessed(k.camera)) {
        return Ok(());
    }
    let placed: Vec<String> = viewpoints
        .iter()
        .map(|(_, k)| format!("{} {}", frames.cameras[k.camera].name, frames.cameras[k.camera].file_name(k.frame)))
        .collect();
    let unplaced: Vec<&str> = frames
        .cameras
        .iter()
        .enumerate()
        .filter(|(c, _)| !viewpoints.iter().any(|(_, k)| k.camera == *c))
        .map(|(_, camera)| camera.name.as_str())
        .collect();
    let unplaced = match unplaced.is_empty() {
        true => String::new(),
        false => format!("; {} could not be placed", unplaced.join(", ")),
    };
    Err(SfmError::Reconstruction(format!(
        "only two views could be placed ({}), from one pair and a focal length nothing measured (the prior, {PRIOR_FOCAL_FACTOR} x the \
         longer side): their relative pose rests on that guess and is not trusted{unplaced}. Give the focal lengths (--focal), or film \
         with more overlap between the cameras",
        placed.join(" and ")
    )))
}

/// Cameras with a keyframe too poor in features to be matched (a black, textureless or
/// out-of-focus video), each with the error that names its worst frame.
fn textureless_cameras(frames: &EventFrames, keys: &[Keyframe], features: &[Features], needed: usize) -> Vec<(usize, SfmError)> {
    let mut out: Vec<(usize, SfmError)> = Vec::new();
    for (k, f) in keys.iter().zip(features) {
        if f.len() < needed && !out.iter().any(|(c, _)| *c == k.camera) {
            let c = &frames.cameras[k.camera];
            out.push((k.camera, SfmError::TooFewFeatures { camera: c.name.clone(), file: c.file_name(k.frame), found: f.len(), needed }));
        }
    }
    out
}

#[allow(clippy::too_many_arguments)]
fn refine_all<K: Serialize>(
    work: &WorkDir,
    frames: &EventFrames,
    model: &KeyframeModel,
    features: &[Features],
    options: &PrepOptions,
    key_stage: &K,
    report: &mut PrepReport,
    progress: StageProgress,
    interrupt: &AtomicBool,
) -> SfmResult<Vec<Vec<Pose>>> {
    let r = &model.reconstruction;
    let counts: Vec<usize> = features.iter().map(Features::len).collect();
    let point_of = r.point_of_feature(&counts);
    let points_world: Vec<Vector3<f64>> = r.points.iter().map(|p| p.xyz).collect();
    let mut out = Vec::new();
    for (c, camera) in frames.cameras.iter().enumerate() {
        if model.still_cameras.get(c) == Some(&true)
            && let Some(pose) = model.keyframes.iter().zip(&r.poses).find_map(|(k, p)| p.filter(|_| k.camera == c))
        {
            // A camera that stands still has one pose, which its keyframes fixed together.
            out.push(vec![pose; camera.files.len()]);
            report.refine.push(RefineReport { still: true, ..RefineReport::default() });
            continue;
        }
        let stage = format!("refine/{}", camera.name);
        let key = (key_stage, &options.refine);
        if work.is_done(&stage, &key) {
            let (poses, camera_report): (Vec<Pose>, RefineReport) = work.read_json(&format!("{stage}.json"))?;
            report.skipped.push(stage);
            warn_repaired(report, &camera.name, &camera_report, options.refine.max_reprojection_px);
            report.refine.push(camera_report);
            out.push(poses);
            continue;
        }
        let mut keyframes = vec![None; camera.files.len()];
        for (i, k) in model.keyframes.iter().enumerate() {
            if k.camera == c
                && let Some(pose) = r.poses[i]
            {
                keyframes[k.frame] = Some(KeyframeView { pose, features: &features[i], point_of_feature: point_of[i].clone() });
            }
        }
        if keyframes.iter().all(Option::is_none) {
            report.warnings.push(format!(
                "camera {}: none of its keyframes could be registered (it shares too few features with the other cameras)",
                camera.name
            ));
            out.push(Vec::new());
            continue;
        }
        let track =
            CameraTrack { name: &camera.name, files: &camera.files, intrinsics: r.intrinsics[c], keyframes, points_world: &points_world };
        let (poses, camera_report) = refine_camera(&track, &options.features, &options.matching, &options.refine, progress, interrupt)?;
        warn_repaired(report, &camera.name, &camera_report, options.refine.max_reprojection_px);
        work.write_json(&format!("{stage}.json"), &(&poses, &camera_report))?;
        work.mark_done(&stage, &key)?;
        report.refine.push(camera_report);
        out.push(poses);
    }
    Ok(out)
}

/// A warning naming the camera when its refinement misplaced frames (repaired, not kept).
fn warn_repaired(report: &mut PrepReport, camera: &str, refined: &RefineReport, limit_px: f64) {
    if refined.frames_repaired > 0 {
        report.warnings.push(format!(
            "camera {camera}: the refinement misplaced {} of its frames (reprojection errors above {} x the {} px limit): they were placed between their neighbours instead",
            refined.frames_repaired,
            crate::refine::MISPLACED_FRAME_FACTOR,
            limit_px,
        ));
    }
}

/// The poses of every frame as `poses.json`'s shape.
pub fn event_poses(frames: &EventFrames, model: &KeyframeModel, poses: &[Vec<Pose>]) -> EventPoses {
    let r = &model.reconstruction;
    EventPoses {
        cameras: frames
            .cameras
            .iter()
            .enumerate()
            .map(|(c, camera)| {
                let (intrinsics, distortion) = r.intrinsics[c].to_pinhole_and_distortion();
                CameraPoses {
                    name: camera.name.clone(),
                    width: camera.width,
                    height: camera.height,
                    intrinsics,
                    distortion,
                    frames: (0..camera.files.len())
                        .map(|t| FramePose {
                            file: camera.file_name(t),
                            camera_from_world: poses[c].get(t).map(|p| PoseEntry::from(p.to_rigid())),
                        })
                        .collect(),
                }
            })
            .collect(),
    }
}

/// Fits known poses (from a COLMAP model folder or a `poses.json` at `path`) to the input's
/// cameras and frames: every camera must be there with the input's image size, and either one
/// pose per frame or a single pose (a camera on a tripod or a calibrated rig) for all frames.
/// Frames were undistorted with the given distortion, so the result has none.
pub fn known_poses(given: &EventPoses, path: &Path, frames: &EventFrames) -> SfmResult<EventPoses> {
    let bad = |problem: String| SfmError::Input { path: path.to_path_buf(), problem };
    let mut cameras = Vec::new();
    for (camera, known) in frames.cameras.iter().zip(calibration_for(given, path, frames)?) {
        let n = camera.files.len();
        let poses: Vec<Option<PoseEntry>> = match known.frames.len() {
            1 => vec![known.frames[0].camera_from_world; n],
            m if m == n => known.frames.iter().map(|f| f.camera_from_world).collect(),
            m => return Err(bad(format!("camera {}: {m} poses for {n} frames (give one per frame, or one for all)", camera.name))),
        };
        if let Some(t) = poses.iter().position(Option::is_none) {
            return Err(bad(format!("camera {}: frame {t} has no pose", camera.name)));
        }
        cameras.push(CameraPoses {
            name: camera.name.clone(),
            width: camera.width,
            height: camera.height,
            intrinsics: known.intrinsics,
            distortion: [0.0; 4],
            frames: poses.into_iter().enumerate().map(|(t, p)| FramePose { file: camera.file_name(t), camera_from_world: p }).collect(),
        });
    }
    let event = EventPoses { cameras };
    event.validate()?;
    Ok(event)
}

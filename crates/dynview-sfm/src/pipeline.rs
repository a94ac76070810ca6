//! `dynview prep`'s pose stages end to end: frames, keyframe reconstruction, frame-to-frame
//! refinement; each saved in the work folder and skipped on a re-run with the same inputs.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use dynview_core::poses::{CameraPoses, EventPoses, FramePose, POSES_FILE};
use dynview_core::scene::manifest::PoseEntry;

use crate::Progress;
use crate::calibration::{calibration_for, known_intrinsics, read_poses, undistort_frames};
use crate::error::{SfmError, SfmResult};
use crate::features::{FeatureOptions, Features};
use crate::geometry::{Intrinsics, Pose};
use crate::incremental::MapperOptions;
use crate::input::{EventFrames, decode_frames, discover};
use crate::keyframes::{KeyframeModel, keyframe_features, keyframes, match_all_pairs, reconstruct_keyframes, to_colmap, write_colmap_text};
use crate::matching::MatchOptions;
use crate::refine::{CameraTrack, RefineOptions, RefineReport, refine_camera};
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
}

impl std::str::FromStr for Stage {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "frames" => Ok(Self::Frames),
            "keyframes" => Ok(Self::Keyframes),
            "poses" => Ok(Self::Poses),
            other => Err(format!("unknown stage {other:?} (expected frames, keyframes or poses)")),
        }
    }
}

/// Everything `prep`'s pose stages can be told.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PrepOptions {
    /// Every `keyframe_interval`-th frame of every camera is a keyframe (the paper's kappa).
    pub keyframe_interval: usize,
    /// Keep the first N frames of every camera when counts differ, N the shortest.
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
}

impl Default for PrepOptions {
    fn default() -> Self {
        Self {
            keyframe_interval: 20,
            trim: false,
            focal_px: BTreeMap::new(),
            focal_px_all: None,
            features: FeatureOptions::default(),
            matching: MatchOptions::default(),
            mapper: MapperOptions::default(),
            refine: RefineOptions::default(),
            stop_after: Stage::Poses,
            poses: None,
            intrinsics: None,
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
    /// Points of the keyframe model.
    pub keyframe_points: usize,
    /// RMS reprojection error of the keyframe model (px).
    pub keyframe_rms_px: f64,
    /// How each camera's focal was initialised.
    pub focal_source: Vec<String>,
    /// Per camera refinement figures.
    pub refine: Vec<RefineReport>,
    /// Stages skipped because an earlier run had finished them.
    pub skipped: Vec<String>,
    /// Seconds per stage run.
    pub stage_seconds: Vec<(String, f64)>,
    /// Where `poses.json` was written, when the pose stage ran.
    pub poses_file: Option<PathBuf>,
}

/// Runs the pose stages from `input` into `out` (work files under `out/work`).
pub fn run(input: &Path, out: &Path, options: &PrepOptions, progress: Progress, interrupt: &AtomicBool) -> SfmResult<PrepReport> {
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
    let mut frames = decode_frames(&cameras, &work.join("frames"), options.trim, progress, interrupt)?;
    // Known calibration: from --intrinsics, else from --poses.
    let calibration_file = options.intrinsics.as_ref().or(options.poses.as_ref());
    let given = calibration_file.map(|p| read_poses(p)).transpose()?;
    let mut known: BTreeMap<String, Intrinsics> = BTreeMap::new();
    if let (Some(given), Some(path)) = (&given, calibration_file) {
        let calibration = calibration_for(given, path, &frames)?;
        frames = undistort_frames(&frames, &calibration, &work.join("undistorted"), progress, interrupt)?;
        known = known_intrinsics(&calibration);
    }
    for c in &frames.cameras {
        if !known.contains_key(&c.name)
            && let Some(f) = options.focal_px.get(&c.name).copied().or(options.focal_px_all)
        {
            known.insert(c.name.clone(), Intrinsics::centred(f, c.width, c.height));
        }
    }
    work.write_json("frames.json", &frames)?;
    report.cameras = frames.cameras.len();
    report.frames = frames.frame_count();
    lap(&mut report, "frames");
    if options.stop_after == Stage::Frames {
        return Ok(report);
    }

    if let (Some(path), Some(given)) = (&options.poses, &given) {
        let event = known_poses(given, path, &frames)?;
        let poses_path = out.join(POSES_FILE);
        event.write(&poses_path)?;
        report.poses_file = Some(poses_path);
        report.skipped.push(format!("pose estimation (poses from {})", path.display()));
        lap(&mut report, "poses");
        return Ok(report);
    }

    let keys = keyframes(&frames, options.keyframe_interval);
    let features = keyframe_features(&work, &frames, &keys, &options.features, progress, interrupt)?;
    lap(&mut report, "keyframe features");
    for (k, f) in keys.iter().zip(&features) {
        if f.len() < options.matching.min_inliers {
            let c = &frames.cameras[k.camera];
            return Err(SfmError::TooFewFeatures {
                camera: c.name.clone(),
                file: c.file_name(k.frame),
                found: f.len(),
                needed: options.matching.min_inliers,
            });
        }
    }
    let key_stage = (&frames, options.keyframe_interval, &options.features, &options.matching, &options.mapper, &known);
    let model: KeyframeModel = if work.is_done("keyframes", &key_stage) {
        report.skipped.push("keyframes".into());
        work.read_json("keyframes/model.json")?
    } else {
        let pairs = match_all_pairs(&features, &options.matching, progress, interrupt)?;
        lap(&mut report, "keyframe matching");
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
        let mut mapper = options.mapper.clone();
        if known.len() == frames.cameras.len() {
            mapper.refine_focal = false;
        }
        let model = reconstruct_keyframes(&frames, &keys, &features, &pairs, &known, &options.matching, &mapper, progress, interrupt)?;
        work.write_json("keyframes/model.json", &model)?;
        write_colmap_text(&to_colmap(&model, &frames, &features), &work.join("keyframes/model"))?;
        work.mark_done("keyframes", &key_stage)?;
        model
    };
    let r = &model.reconstruction;
    report.keyframes = keys.len();
    report.keyframes_registered = r.poses.iter().flatten().count();
    report.keyframe_points = r.points.len();
    let errors = r.reprojection_errors_px(&model.map_images(&features));
    report.keyframe_rms_px = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len().max(1) as f64).sqrt();
    report.focal_source = model.focal_source.clone();
    lap(&mut report, "keyframe reconstruction");
    if options.stop_after == Stage::Keyframes {
        return Ok(report);
    }

    let poses = refine_all(&work, &frames, &model, &features, options, &key_stage, &mut report, progress, interrupt)?;
    let event = event_poses(&frames, &model, &poses);
    event.validate()?;
    let path = out.join(POSES_FILE);
    event.write(&path)?;
    report.poses_file = Some(path);
    lap(&mut report, "poses");
    Ok(report)
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
    progress: Progress,
    interrupt: &AtomicBool,
) -> SfmResult<Vec<Vec<Pose>>> {
    let r = &model.reconstruction;
    let counts: Vec<usize> = features.iter().map(Features::len).collect();
    let point_of = r.point_of_feature(&counts);
    let points_world: Vec<Vector3<f64>> = r.points.iter().map(|p| p.xyz).collect();
    let mut out = Vec::new();
    for (c, camera) in frames.cameras.iter().enumerate() {
        let stage = format!("refine/{}", camera.name);
        let key = (key_stage, &options.refine);
        if work.is_done(&stage, &key) {
            let (poses, camera_report): (Vec<Pose>, RefineReport) = work.read_json(&format!("{stage}.json"))?;
            report.skipped.push(stage);
            report.refine.push(camera_report);
            out.push(poses);
            continue;
        }
        let mut keyframes = vec![None; camera.files.len()];
        for (i, k) in model.keyframes.iter().enumerate() {
            if k.camera == c
                && let Some(pose) = r.poses[i]
            {
                keyframes[k.frame] = Some((pose, &features[i], point_of[i].clone()));
            }
        }
        let track =
            CameraTrack { name: &camera.name, files: &camera.files, intrinsics: r.intrinsics[c], keyframes, points_world: &points_world };
        let (poses, camera_report) = refine_camera(&track, &options.features, &options.matching, &options.refine, progress, interrupt)?;
        work.write_json(&format!("{stage}.json"), &(&poses, &camera_report))?;
        work.mark_done(&stage, &key)?;
        report.refine.push(camera_report);
        out.push(poses);
    }
    Ok(out)
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
                let k = &r.intrinsics[c];
                CameraPoses {
                    name: camera.name.clone(),
                    width: camera.width,
                    height: camera.height,
                    intrinsics: dynview_core::Intrinsics { fx: k.focal_px, fy: k.focal_px, cx: k.cx_px, cy: k.cy_px },
                    distortion: [k.k1, k.k2, 0.0, 0.0],
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

//! The frames and pose stages of `dynview prep`: the frames decoded (and undistorted with a
//! given calibration), the keyframe reconstruction, the frame-to-frame refinement of every
//! camera and the adjustment over sampled time steps, each saved in the work folder and
//! skipped on a re-run with the same inputs; then `poses.json`. Known poses skip them all.

use std::path::Path;
use std::sync::atomic::AtomicBool;

use serde::Serialize;

use dynview_camera::{Radial, Rigid3};
use dynview_core::StageProgress;
use dynview_core::scene::manifest::PoseEntry;
use dynview_interchange::poses::{CameraPoses, EventPoses, FramePose, POSES_FILE};

use crate::error::{SfmError, SfmResult};
use crate::estimators::focal::PRIOR_FOCAL_FACTOR;
use crate::features::sift::Features;
use crate::input::calibration::{KnownCameras, calibration_for, known_intrinsics, read_poses, recorded_frame_poses, undistort_frames};
use crate::input::frames::{CameraFrames, DiscoveredCamera, EventFrames, decode_frames};
use crate::input::timing::{StepSource, SyncMethod, TimeOptions, align_in_time};
use crate::mapping::keyframe_model::{
    KeyframeModel, PRIOR_FOCAL_SOURCE, focal_std_fractions, intrinsics_groups, intrinsics_notes, per_group, reconstruct_keyframes,
    to_colmap, weak_focal_warnings, write_colmap_text,
};
use crate::mapping::keyframes::{Keyframe, keyframe_features, keyframes, match_all_pairs};
use crate::mapping::refine::{RefineReport, refine_camera};
use crate::mapping::step_adjust::{StepAdjustReport, StepCameras, adjust_with_steps};
use crate::mapping::step_placement::{StepPlacement, place_left_out};
use crate::pipeline::options::{PrepOptions, PrepReport, Stage};
use crate::pipeline::still_placement::{check_confidence, hand_held_warnings, place_still_cameras};
use crate::work::WorkDir;

/// The revision of the pose stages' work files (`keyframes/model.json`, `refine/<camera>.json`,
/// `step_adjust.json`), part of their keys: a work folder written by an earlier revision
/// computes them again instead of failing to read them. 2: poses are stored as
/// `dynview_camera::Rigid3` (`{"rotation", "translation"}`, `camera_from_world`) instead of a
/// rotation and a camera centre (revision 1, which had no number).
pub const POSE_STAGES_REVISION: u32 = 2;

/// What a stage reports when it ends: the report and the stage's name (for its time).
pub(crate) type Lap<'a> = dyn FnMut(&mut PrepReport, &str) + 'a;

/// The frames and pose stages; `None` when `stop_after` ended the run before poses.
#[allow(clippy::too_many_arguments)]
pub(crate) fn pose_stages(
    work: &WorkDir,
    out: &Path,
    cameras: &[DiscoveredCamera],
    options: &PrepOptions,
    report: &mut PrepReport,
    lap: &mut Lap,
    progress: StageProgress,
    interrupt: &AtomicBool,
) -> SfmResult<Option<(EventFrames, EventPoses)>> {
    let recorded = decode_frames(cameras, &work.join("frames"), progress, interrupt)?;
    // Known calibration: from --intrinsics, else from --poses.
    let calibration_file = options.intrinsics.as_ref().or(options.poses.as_ref());
    let given = calibration_file.map(|p| read_poses(p)).transpose()?;
    let recorded_frames = EventFrames { cameras: recorded.iter().map(|r| r.frames.clone()).collect() };
    let calibration = match (&given, calibration_file) {
        (Some(given), Some(path)) => Some(calibration_for(given, path, &recorded_frames)?),
        _ => None,
    };
    let time = TimeOptions {
        sync: options.sync,
        offsets_s: options.offsets_s.clone(),
        fps: options.fps,
        strict_frame_counts: !options.trim,
        visual: options.visual_sync.clone(),
        start_at: options.start_at.clone(),
        retime: options.retime,
    };
    // Aligning from the pictures without a calibration: the cameras placed from the static
    // scene first (they are not a calibration for the later stages, which place them again).
    let placed = if calibration.is_none() && options.offsets_s.is_empty() && options.sync == SyncMethod::Visual {
        Some(place_still_cameras(work, &recorded_frames, options, progress, interrupt)?)
    } else {
        None
    };
    let placed_refs: Option<Vec<&CameraPoses>> = placed.as_ref().map(|p| p.iter().collect());
    let sync_calibration = calibration.as_deref().or(placed_refs.as_deref());
    let (mut frames, alignment, warnings) = align_in_time(&recorded, &time, sync_calibration, work, progress, interrupt)?;
    if let Some(placed) = &placed {
        check_confidence(&alignment)?;
        report.warnings.extend(hand_held_warnings(placed));
    }
    report.warnings.extend(warnings);
    report.time_alignment = Some(alignment);
    let mut known = KnownCameras::new();
    if let Some(calibration) = &calibration {
        frames = undistort_frames(&frames, calibration, &work.join("undistorted"), progress, interrupt)?;
        known = known_intrinsics(calibration);
    }
    options.add_given_focals(&frames, &mut known);
    work.write_json("frames.json", &frames)?;
    report.cameras = frames.cameras.len();
    report.frames = frames.frame_count();
    lap(report, "frames");
    if options.stop_after == Stage::Frames {
        return Ok(None);
    }

    if let (Some(path), Some(given)) = (&options.poses, &given) {
        let sources = report.time_alignment.as_ref().map(|a| a.step_sources.as_slice()).unwrap_or_default();
        let event = known_poses(given, path, &frames, Some((&recorded_frames, sources)))?;
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
    let key_stage =
        (&frames, options.keyframe_interval, &options.features, &options.matching, &options.mapper, &known, POSE_STAGES_REVISION);
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
    if place_left_out_cameras(work, &frames, &mut model, &mut poses, options, &key_stage, report, progress, interrupt)? {
        lap(report, "placing left-out cameras");
    }
    for (camera, _) in frames.cameras.iter().zip(&poses).filter(|(_, p)| p.is_empty()) {
        report.warnings.push(format!(
            "camera {}: none of its keyframes could be registered (it shares too few features with the other cameras)",
            camera.name
        ));
    }
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

/// Places the still cameras the keyframes left out from the time steps' points
/// (`step_placement`), or reads what an earlier run found: a placed camera gets its pose for
/// every frame in `poses` and its focal length in `model`. Whether a camera was left out.
#[allow(clippy::too_many_arguments)]
fn place_left_out_cameras<K: Serialize>(
    work: &WorkDir,
    frames: &EventFrames,
    model: &mut KeyframeModel,
    poses: &mut [Vec<Rigid3>],
    options: &PrepOptions,
    key_stage: &K,
    report: &mut PrepReport,
    progress: StageProgress,
    interrupt: &AtomicBool,
) -> SfmResult<bool> {
    const STAGE: &str = "step_placement";
    if poses.iter().all(|p| !p.is_empty()) {
        return Ok(false);
    }
    let key = (key_stage, &options.refine, &options.step_placement);
    let placed: Vec<(usize, StepPlacement)> = if work.is_done(STAGE, &key) {
        report.skipped.push(STAGE.into());
        work.read_json(&format!("{STAGE}.json"))?
    } else {
        let r = &model.reconstruction;
        let placed = place_left_out(
            frames,
            &r.intrinsics,
            poses,
            &model.still_cameras,
            &options.step_placement,
            &options.features,
            &options.matching,
            progress,
            interrupt,
        )?;
        work.write_json(&format!("{STAGE}.json"), &placed)?;
        work.mark_done(STAGE, &key)?;
        placed
    };
    for (c, placement) in placed {
        if let Some(pose) = placement.camera_from_world {
            model.reconstruction.intrinsics[c].f = placement.focal_px;
            poses[c] = vec![pose; frames.cameras[c].files.len()];
        }
        report.step_placement.push(placement);
    }
    Ok(true)
}

/// Adjusts the intrinsics and `poses` over sampled time steps (`step_adjust`), or reads what an
/// earlier run found; updates `model`'s intrinsics and the report's intrinsics figures.
#[allow(clippy::too_many_arguments)]
fn adjust_steps<K: Serialize>(
    work: &WorkDir,
    frames: &EventFrames,
    model: &mut KeyframeModel,
    known: &KnownCameras,
    poses: &mut Vec<Vec<Rigid3>>,
    options: &PrepOptions,
    key_stage: &K,
    report: &mut PrepReport,
    progress: StageProgress,
    interrupt: &AtomicBool,
) -> SfmResult<()> {
    const STAGE: &str = "step_adjust";
    let key = (key_stage, &options.refine, &options.step_placement, &options.step_adjust);
    let adjusted: Option<(Vec<Vec<Rigid3>>, Vec<Radial>, StepAdjustReport)> = if work.is_done(STAGE, &key) {
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
    let mut viewpoints: Vec<(Rigid3, &Keyframe)> = Vec::new();
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
) -> SfmResult<Vec<Vec<Rigid3>>> {
    let r = &model.reconstruction;
    let point_of = model.feature_points(features);
    let points_world = model.points_world();
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
            let (poses, camera_report): (Vec<Rigid3>, RefineReport) = work.read_json(&format!("{stage}.json"))?;
            report.skipped.push(stage);
            warn_repaired(report, &camera.name, &camera_report, options.refine.max_reprojection_px);
            report.refine.push(camera_report);
            out.push(poses);
            continue;
        }
        let Some(track) = model.camera_track(camera, c, features, &point_of, &points_world) else {
            // Not registered: placed from the time steps if it stands still, else left out.
            out.push(Vec::new());
            continue;
        };
        let (poses, camera_report) = refine_camera(&track, &options.features, &options.matching, &options.refine, progress, interrupt)?;
        warn_repaired(report, &camera.name, &camera_report, options.refine.max_reprojection_px);
        work.write_json(&format!("{stage}.json"), &(&poses, &camera_report))?;
        work.mark_done(&stage, &key)?;
        report.refine.push(camera_report);
        out.push(poses);
    }
    Ok(out)
}

/// A warning naming the camera when its refinement misplaced frames (repaired, or kept as
/// placed before the solve).
fn warn_repaired(report: &mut PrepReport, camera: &str, refined: &RefineReport, limit_px: f64) {
    if refined.frames_repaired > 0 {
        report.warnings.push(format!(
            "camera {camera}: the refinement misplaced {} of its frames (reprojection errors above {} x the {} px limit): they were placed between their neighbours instead",
            refined.frames_repaired,
            crate::mapping::refine::MISPLACED_FRAME_FACTOR,
            limit_px,
        ));
    }
    if refined.frames_kept_from_pnp > 0 {
        report.warnings.push(format!(
            "camera {camera}: the smoothing solve misplaced {} of its frames; each keeps its own pose (PnP on the keyframe model), unsmoothed",
            refined.frames_kept_from_pnp,
        ));
    }
}

/// The poses of every frame as `poses.json`'s shape.
pub fn event_poses(frames: &EventFrames, model: &KeyframeModel, poses: &[Vec<Rigid3>]) -> EventPoses {
    let r = &model.reconstruction;
    EventPoses {
        cameras: frames
            .cameras
            .iter()
            .enumerate()
            .map(|(c, camera)| {
                // dynview's pinhole and OpenCV's distortion `[k1, k2, p1, p2]`, as `poses.json` stores them.
                let opencv = r.intrinsics[c].to_opencv();
                let (intrinsics, distortion) = (opencv.pinhole.into(), opencv.distortion.to_array());
                CameraPoses {
                    name: camera.name.clone(),
                    width: camera.width,
                    height: camera.height,
                    intrinsics,
                    distortion,
                    frames: (0..camera.files.len())
                        .map(|t| FramePose { file: camera.file_name(t), camera_from_world: poses[c].get(t).map(|p| PoseEntry::from(*p)) })
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
///
/// `timeline` (the cameras' recorded frames and the alignment's
/// [`step_sources`](crate::input::timing::TimeAlignment::step_sources)) lets a moving camera's
/// poses, given per recorded frame by file name, follow a time alignment: each step takes the
/// pose of the frame it was filmed at, or the camera between the two frames its frame was made
/// between.
pub fn known_poses(
    given: &EventPoses,
    path: &Path,
    frames: &EventFrames,
    timeline: Option<(&EventFrames, &[Vec<StepSource>])>,
) -> SfmResult<EventPoses> {
    let bad = |problem: String| SfmError::Input { path: path.to_path_buf(), problem };
    let mut cameras = Vec::new();
    for (c, (camera, known)) in frames.cameras.iter().zip(calibration_for(given, path, frames)?).enumerate() {
        let n = camera.files.len();
        // A camera on a tripod may list its one pose per frame: one for all, whatever the
        // timeline made of its frames.
        let constant = known.frames.windows(2).all(|w| w[0].camera_from_world == w[1].camera_from_world);
        let followed = timeline.filter(|_| !constant).and_then(|(recorded, sources)| {
            Some(poses_along_timeline(known, recorded.cameras.get(c)?, sources.get(c)?)).filter(|p| p.len() == n)
        });
        let poses: Vec<Option<PoseEntry>> = match known.frames.len() {
            m if m >= 1 && (m == 1 || constant) => vec![known.frames[0].camera_from_world; n],
            _ if followed.as_ref().is_some_and(|p| p.iter().all(Option::is_some)) => followed.unwrap_or_default(),
            m if m == n => known.frames.iter().map(|f| f.camera_from_world).collect(),
            m => {
                return Err(bad(format!(
                    "camera {}: {m} poses for {n} time steps (give one per time step, or one for all; a moving camera's poses cannot follow a time alignment)",
                    camera.name
                )));
            }
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

/// Per time step, the pose of `known` (given per recorded frame, by file name) where `sources`
/// says the step's frame comes from in `recorded`: a frame's own, or the camera between two
/// frames a fraction of the way; `None` where a frame needed has no pose.
fn poses_along_timeline(known: &CameraPoses, recorded: &CameraFrames, sources: &[StepSource]) -> Vec<Option<PoseEntry>> {
    let by_frame = recorded_frame_poses(known, recorded);
    let pose = |j: usize| by_frame.get(j).copied().flatten();
    sources
        .iter()
        .map(|source| match *source {
            StepSource::Frame(j) => pose(j),
            StepSource::Between(j, fraction) => {
                let (before, after) = (pose(j)?, pose(j + 1)?);
                Some(PoseEntry::from(before.camera_from_world().camera_between(&after.camera_from_world(), fraction)))
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynview_core::camera::Intrinsics;
    use glam::DVec3;

    #[test]
    fn a_moving_cameras_poses_follow_the_frames_its_time_steps_were_made_from() {
        let at = |x: f64| Rigid3::camera_from_world_looking_at(DVec3::new(x, 0.0, -5.0), DVec3::new(x, 0.0, 0.0), DVec3::Y);
        let known = CameraPoses {
            name: "phone".into(),
            width: 64,
            height: 48,
            intrinsics: Intrinsics { fx: 60.0, fy: 60.0, cx: 31.5, cy: 23.5 },
            distortion: [0.0; 4],
            // Frame 2 has no pose.
            frames: [0, 1, 3]
                .iter()
                .map(|&k| FramePose { file: format!("{k:05}.png"), camera_from_world: Some(PoseEntry::from(at(k as f64))) })
                .collect(),
        };
        let recorded = CameraFrames {
            name: "phone".into(),
            width: 64,
            height: 48,
            files: (0..4).map(|k| std::path::PathBuf::from(format!("frames/phone/{k:05}.png"))).collect(),
        };
        let sources = [StepSource::Frame(0), StepSource::Frame(3), StepSource::Between(0, 0.25), StepSource::Between(1, 0.5)];
        let poses = poses_along_timeline(&known, &recorded, &sources);
        let centre = |p: &Option<PoseEntry>| p.map(|p| p.camera_from_world().camera_center_world().x);
        let centres: Vec<Option<f64>> = poses.iter().map(centre).collect();
        assert!((centres[0].unwrap() - 0.0).abs() < 1e-9 && (centres[1].unwrap() - 3.0).abs() < 1e-9, "{centres:?}");
        assert!((centres[2].unwrap() - 0.25).abs() < 1e-9, "a quarter of the way from frame 0 to 1: {centres:?}");
        assert_eq!(centres[3], None, "made between frames 1 and 2, and frame 2 has no pose");
    }
}

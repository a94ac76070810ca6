//! Cameras placed from the static scene before they are put on one timeline, for `--sync
//! visual` without a calibration: cameras on tripods see the same walls and floor whenever
//! they film, so keyframes of each camera's own recording, not yet aligned in time, place them
//! as the keyframe stage would. The visual alignment needs each camera's intrinsics and the
//! pose of each frame it compares: one for a camera on a tripod; for a hand-held camera every
//! frame of its own recording, posed by the frame-to-frame refinement on the keyframe model (a
//! wobble between keyframes is what the alignment measures time by, so the pose between
//! keyframes was not enough: on the synthetic hand-held phones at 320x180, keyframes every 10
//! frames, the worst clock 12.2 ms off with it, 6.6 ms with every frame posed). The pose stages
//! run again on the aligned frames afterwards.

use std::sync::atomic::AtomicBool;

use dynview_core::StageProgress;
use dynview_core::scene::manifest::PoseEntry;
use dynview_interchange::poses::{CameraPoses, FramePose};

use crate::error::{SfmError, SfmResult};
use crate::input::calibration::KnownCameras;
use crate::input::frames::{CameraFrames, EventFrames};
use crate::input::timing::TimeAlignment;
use crate::mapping::keyframe_model::reconstruct_keyframes;
use crate::mapping::keyframes::{keyframe_features, keyframes, match_all_pairs};
use crate::mapping::refine::refine_camera;
use crate::pipeline::options::PrepOptions;
use crate::work::WorkDir;

/// With cameras placed by our own SfM, every clock must be at least this sure, else the
/// alignment is an error: a wrong placement (a focal length misjudged on small frames) gives
/// wrong clocks with low confidence. On the synthetic phones the placements that gave clocks
/// within 8 ms had every confidence at 0.62 or more, those 50-290 ms off had one at 0.33 or less.
pub const MIN_CONFIDENCE: f64 = 0.5;

/// Where the placement is kept in the work folder (a `poses.json`).
pub const PLACED_FILE: &str = "time/placed_poses.json";

/// Keyframes taken from each camera at least (when it has that many frames).
const MIN_KEYFRAMES: usize = 4;

/// Every camera of `recorded` (each camera's own frames, in any time order) placed from its
/// keyframes: per camera its intrinsics, distortion and its keyframes' poses. An error when a
/// camera cannot be placed names it and says what to give instead.
pub fn place_still_cameras(
    work: &WorkDir,
    recorded: &EventFrames,
    options: &PrepOptions,
    progress: StageProgress,
    interrupt: &AtomicBool,
) -> SfmResult<Vec<CameraPoses>> {
    let failed = |problem: String| {
        SfmError::TimeAlignment(format!(
            "--sync visual without --poses places the cameras from the static scene first, and {problem}; give --poses (a calibration) or --offsets"
        ))
    };
    // The same number of frames from every camera (keyframes are taken at the same indices).
    let shortest = recorded.cameras.iter().map(|c| c.files.len()).min().unwrap_or(0);
    if shortest == 0 {
        return Err(failed("a camera has no frames".into()));
    }
    let frames = EventFrames {
        cameras: recorded.cameras.iter().map(|c| CameraFrames { files: c.files[..shortest].to_vec(), ..c.clone() }).collect(),
    };
    let mut known = KnownCameras::new();
    options.add_given_focals(&frames, &mut known);
    // At least four keyframes a camera (pooled where it stands still): short recordings too.
    let interval = options.keyframe_interval.min(shortest.div_ceil(MIN_KEYFRAMES)).max(1);
    let keys = keyframes(&frames, interval);
    let features = keyframe_features(work, &frames, &keys, &options.features, progress, interrupt)?;
    let pairs = match_all_pairs(&features, &options.matching, progress, interrupt)?;
    let model = reconstruct_keyframes(&frames, &keys, &features, &pairs, &known, &options.matching, &options.mapper, progress, interrupt)
        .map_err(|e| failed(format!("the reconstruction failed: {e}")))?;
    let r = &model.reconstruction;
    let point_of = model.feature_points(&features);
    let points_world = model.points_world();
    let mut placed = Vec::with_capacity(frames.cameras.len());
    let mut missing = Vec::new();
    for (c, camera) in frames.cameras.iter().enumerate() {
        // Every keyframe's pose for a hand-held camera; one for a camera on a tripod.
        let mut poses: Vec<FramePose> = model
            .keyframes
            .iter()
            .zip(&r.poses)
            .filter(|(k, _)| k.camera == c)
            .filter_map(|(k, p)| Some(FramePose { file: camera.file_name(k.frame), camera_from_world: Some(PoseEntry::from((*p)?)) }))
            .collect();
        if poses.is_empty() {
            missing.push(camera.name.clone());
            continue;
        }
        poses.sort_by(|a, b| a.file.cmp(&b.file));
        if model.still_cameras.get(c) == Some(&true) {
            // A camera found standing still keeps one pose, whether or not its keyframes were pooled.
            poses.truncate(1);
        } else if let Some(track) = model.camera_track(camera, c, &features, &point_of, &points_world) {
            // A hand-held camera: every frame posed by the frame-to-frame refinement (its own
            // recording, in its own time order), not only its keyframes.
            let (refined, _) = refine_camera(&track, &options.features, &options.matching, &options.refine, progress, interrupt)?;
            poses = refined
                .iter()
                .enumerate()
                .map(|(k, pose)| FramePose { file: camera.file_name(k), camera_from_world: Some(PoseEntry::from(*pose)) })
                .collect();
        }
        let opencv = r.intrinsics[c].to_opencv();
        placed.push(CameraPoses {
            name: camera.name.clone(),
            width: camera.width,
            height: camera.height,
            intrinsics: opencv.pinhole.into(),
            distortion: opencv.distortion.to_array(),
            frames: poses,
        });
    }
    if !missing.is_empty() {
        return Err(failed(format!("{} could not be placed (too few features shared with the others)", missing.join(", "))));
    }
    // Kept for a user checking an unsure clock: where the alignment took the cameras to be.
    std::fs::create_dir_all(work.join("time")).map_err(SfmError::io(&work.join("time")))?;
    work.write_json(PLACED_FILE, &dynview_interchange::poses::EventPoses { cameras: placed.clone() })?;
    Ok(placed)
}

/// A warning per camera [`place_still_cameras`] found moving (hand-held): the visual alignment
/// measured its clock with poses of our own SfM for every frame (its keyframes, the frames
/// between refined against them), so its clock rests on that placement (on the synthetic
/// hand-held phones: 5.3-6.6 ms off at worst, against 2.2-6.9 ms with the true pose of every
/// frame).
pub fn hand_held_warnings(placed: &[CameraPoses]) -> Vec<String> {
    placed
        .iter()
        .filter(|c| c.frames.len() > 1)
        .map(|c| {
            format!(
                "camera {}: hand-held, its clock found with every frame placed by our own SfM (its keyframes, the frames \
                 between refined against them), less sure than with a calibration; give --poses or --offsets where that matters",
                c.name
            )
        })
        .collect()
}

/// An error unless every camera's clock found with cameras placed by [`place_still_cameras`] is
/// at least [`MIN_CONFIDENCE`] sure; it names the unsure cameras.
pub fn check_confidence(alignment: &TimeAlignment) -> SfmResult<()> {
    let unsure: Vec<String> = alignment
        .cameras
        .iter()
        .filter(|(_, c)| c.confidence.is_nan() || c.confidence < MIN_CONFIDENCE)
        .map(|(name, c)| format!("{name} ({:.2})", c.confidence))
        .collect();
    if unsure.is_empty() {
        return Ok(());
    }
    Err(SfmError::TimeAlignment(format!(
        "the clocks found from the pictures with the cameras placed from the static scene (see {PLACED_FILE} in the work folder) are unsure for {}: below {MIN_CONFIDENCE}, the placement is likely wrong; give --poses (a calibration) or --offsets",
        unsure.join(", ")
    )))
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynview_camera::Rigid3;
    use dynview_core::camera::Intrinsics;

    fn placed(name: &str, poses: usize) -> CameraPoses {
        CameraPoses {
            name: name.into(),
            width: 64,
            height: 48,
            intrinsics: Intrinsics { fx: 60.0, fy: 60.0, cx: 31.5, cy: 23.5 },
            distortion: [0.0; 4],
            frames: (0..poses)
                .map(|k| FramePose { file: format!("{:05}.png", 20 * k), camera_from_world: Some(PoseEntry::from(Rigid3::IDENTITY)) })
                .collect(),
        }
    }

    #[test]
    fn only_cameras_placed_with_more_than_one_pose_are_warned_about() {
        let warnings = hand_held_warnings(&[placed("tripod", 1), placed("phone", 4)]);
        assert_eq!(warnings.len(), 1);
        assert!(warnings[0].starts_with("camera phone: hand-held") && warnings[0].contains("--offsets"), "{}", warnings[0]);
    }
}

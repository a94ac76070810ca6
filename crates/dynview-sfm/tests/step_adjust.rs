//! The adjustment over sampled time steps (`dynview_sfm::mapping::step_adjust`) on a hand-held
//! arc the keyframes fix poorly: 8 cameras over 90 degrees, each its own focal length (1.6 to 0.8 x
//! the longer side) and a principal point 5 px off the centre in x and y, 3 keyframes each.
//! The keyframes alone leave the focal lengths up to 0.66% off and the principal points up to
//! 5 px; every time step's own points fix them. On 6 cameras of that layout on tripods, the still rig's
//! adjustment takes points three cameras or more see, then every point, and keeps the principal
//! points at the centre where the time steps fix them loosely.

use std::collections::BTreeMap;
use std::sync::atomic::AtomicBool;

use dynview_core::{Intrinsics, Rigid3};
use dynview_eval::align::{PoseEvalOptions, evaluate_poses};
use dynview_interchange::colmap::ColmapModel;
use dynview_interchange::poses::EventPoses;
use dynview_sfm::mapping::step_adjust::StepAdjustOptions;
use dynview_sfm::{PrepOptions, Stage, run};
use dynview_synth::SynthConfig;
use dynview_synth::rig::Layout;

/// Rotation median (degrees), largest focal error (%) and largest principal-point error (px)
/// of `poses` against the event's truth.
fn errors(poses: &EventPoses, truth: &ColmapModel) -> (f64, f64, f64) {
    let stem = |name: &str| name.rsplit_once('.').map_or(name.to_string(), |(s, _)| s.to_string());
    let true_poses: BTreeMap<String, Rigid3> = truth.images.values().map(|im| (stem(&im.name), im.camera_from_world)).collect();
    let mut estimated = BTreeMap::new();
    let (mut focal_pct, mut principal_px) = (0.0_f64, 0.0_f64);
    for (c, camera) in poses.cameras.iter().enumerate() {
        for (t, frame) in camera.frames.iter().enumerate() {
            if let Some(pose) = poses.camera_from_world(c, t) {
                estimated.insert(stem(&format!("{}/{}", camera.name, frame.file)), pose);
            }
        }
        let image = truth.images.values().find(|im| im.name.starts_with(&format!("{}/", camera.name))).expect("camera in the truth");
        let true_k: Intrinsics = truth.cameras[&image.camera_id].intrinsics().0;
        let k = camera.intrinsics;
        focal_pct = focal_pct.max(100.0 * (k.fx / true_k.fx - 1.0).abs());
        principal_px = principal_px.max((k.cx - true_k.cx).hypot(k.cy - true_k.cy));
    }
    let accuracy = evaluate_poses(&estimated, &true_poses, PoseEvalOptions::default()).expect("evaluation");
    assert_eq!(accuracy.registered, accuracy.ground_truth_images, "every frame posed");
    (accuracy.rotation_error_median_deg, focal_pct, principal_px)
}

/// `cameras` over 90 degrees (focal 1.6 to 0.8 x the longer side, principal points 5 px off),
/// 25 frames at 640x360, hand-held or on tripods: its folder, its input and its truth.
fn arc_event(cameras: usize, handheld: bool) -> (tempfile::TempDir, std::path::PathBuf, ColmapModel) {
    let dir = tempfile::tempdir().expect("temp dir");
    let event = dir.path().join("event");
    let layout = Layout { arc_deg: 90.0, focal_range: Some([1.6, 0.8]), principal_offset_px: [5.0, 5.0], ..Layout::default() };
    let config = SynthConfig { cameras, frames: 25, width: 640, height: 360, handheld, layout, ..SynthConfig::default() };
    dynview_synth::generate(&config, &event, &|_, _, _| {}).expect("synth");
    let input = if event.join("videos").is_dir() { event.join("videos") } else { event.join("input") };
    let truth = ColmapModel::read_dir(&event.join("colmap")).expect("ground truth");
    (dir, input, truth)
}

#[test]
fn the_time_steps_fix_the_intrinsics_the_keyframes_leave_loose() {
    let (dir, input, truth) = arc_event(8, true);
    let out = dir.path().join("prep");
    let stop = AtomicBool::new(false);
    let keyframes_only = PrepOptions {
        keyframe_interval: 12,
        stop_after: Stage::Poses,
        step_adjust: StepAdjustOptions { samples: 0, ..StepAdjustOptions::default() },
        ..PrepOptions::default()
    };
    run(&input, &out, &keyframes_only, &|_, _, _| {}, &stop).expect("prep, keyframes' intrinsics");
    let before = errors(&EventPoses::read(&out.join("poses.json")).expect("poses.json"), &truth);
    // The same run with the adjustment (the keyframes and the frame-to-frame poses are reused).
    let adjusted = PrepOptions { step_adjust: StepAdjustOptions::default(), ..keyframes_only };
    let report = run(&input, &out, &adjusted, &|_, _, _| {}, &stop).expect("prep, adjusted over the time steps");
    let step = report.step_adjustment.as_ref().expect("the adjustment ran");
    let after = errors(&EventPoses::read(&out.join("poses.json")).expect("poses.json"), &truth);
    println!(
        "keyframes only: rotation median {:.3} deg, focal {:.2}%, principal point {:.1} px; over {} time steps: {:.3} deg, {:.2}%, {:.1} px",
        before.0,
        before.1,
        before.2,
        step.steps.len(),
        after.0,
        after.1,
        after.2
    );
    assert_eq!(step.steps.len(), 24);
    assert!(step.principal_point_refined, "{step:?}");
    // Measured with lossless work frames (issue 33): 0.192 deg, 0.24%, 6.7 px before; 0.063 deg,
    // 0.32%, 3.0 px after. With JPEG work frames it was 0.154 deg, 0.66%, 5.0 px before and
    // 0.070 deg, 0.31%, 2.1 px after: the keyframes now leave the focal lengths within the bound,
    // and the adjustment keeps them there while it fixes the rotations and principal points.
    assert!(after.0 <= 0.1 && after.0 < 0.6 * before.0, "rotation median {:.3} deg (before {:.3})", after.0, before.0);
    assert!(after.1 <= 0.4, "largest focal error {:.2}% (before {:.2}%)", after.1, before.1);
    assert!(after.2 <= 3.5 && after.2 < 0.6 * before.2, "largest principal-point error {:.1} px (before {:.1})", after.2, before.2);
}

#[test]
fn a_still_rig_is_adjusted_over_points_three_cameras_see_then_over_every_point() {
    let (dir, input, truth) = arc_event(6, false);
    let out = dir.path().join("prep");
    let stop = AtomicBool::new(false);
    let off = StepAdjustOptions { still_rig_min_cameras: 0, ..StepAdjustOptions::default() };
    let keyframes_only = PrepOptions { keyframe_interval: 12, stop_after: Stage::Poses, step_adjust: off, ..PrepOptions::default() };
    let report = run(&input, &out, &keyframes_only, &|_, _, _| {}, &stop).expect("prep, still rig not adjusted");
    assert!(report.step_adjustment.is_none(), "0 cameras a point: still rigs are not adjusted: {:?}", report.step_adjustment);
    let before = errors(&EventPoses::read(&out.join("poses.json")).expect("poses.json"), &truth);
    // The default: three cameras a point, then settled over every point.
    let adjusted = PrepOptions { step_adjust: StepAdjustOptions::default(), ..keyframes_only };
    let report = run(&input, &out, &adjusted, &|_, _, _| {}, &stop).expect("prep, still rig adjusted");
    let step = report.step_adjustment.as_ref().expect("the still rig's adjustment ran");
    let after = errors(&EventPoses::read(&out.join("poses.json")).expect("poses.json"), &truth);
    println!(
        "still rig, keyframes only: rotation median {:.3} deg, focal {:.2}%, principal point {:.1} px; over {} time steps ({} points, {} observations): {:.3} deg, {:.2}%, {:.1} px",
        before.0,
        before.1,
        before.2,
        step.steps.len(),
        step.points,
        step.observations,
        after.0,
        after.1,
        after.2
    );
    assert_eq!(step.min_track_cameras, 3);
    assert!(step.points > 0 && step.observations >= 3 * step.points, "every point seen by three cameras or more: {step:?}");
    let settled = step.settled.as_ref().expect("the settling pass ran");
    assert!(settled.points > step.points && settled.min_track_cameras == 2, "the settling pass takes every point: {settled:?}");
    // Measured (2026-11-28): 0.526 deg, 1.45%, 7.1 px before; 0.524 deg, 1.26%, 7.1 px after
    // both passes (0.527 deg, 0.90% after the first alone).
    assert!(after.1 <= 0.95 * before.1, "largest focal error {:.2}% (before {:.2}%)", after.1, before.1);
    assert!(after.0 <= 1.1 * before.0, "rotation median {:.3} deg (before {:.3})", after.0, before.0);
    // The keyframes left the principal points at the centre; the time steps fix them only to
    // 6-16 px here (measured), far looser than a still rig's bound, so they stay there.
    let bound_px = StepAdjustOptions::default().still_principal_point_fraction * 640.0;
    assert!(!step.principal_point_refined, "{step:?}");
    assert!(step.principal_point_std_px.iter().any(|s| s.is_some_and(|s| s > bound_px)), "{:?}", step.principal_point_std_px);
    assert!((after.2 - before.2).abs() < 1e-9, "principal points moved: {:.2} px off (before {:.2})", after.2, before.2);
    // Trusted that loosely (5% of the longer side), they are refined and land further off the
    // truth than the centre is (measured: 7.1 -> 55 px): why only a tight fix is trusted.
    let loose = StepAdjustOptions { still_principal_point_fraction: 0.05, ..StepAdjustOptions::default() };
    let report = run(&input, &out, &PrepOptions { step_adjust: loose, ..adjusted }, &|_, _, _| {}, &stop).expect("prep, loose bound");
    let step = report.step_adjustment.as_ref().expect("the still rig's adjustment ran");
    let loosely = errors(&EventPoses::read(&out.join("poses.json")).expect("poses.json"), &truth);
    println!("principal points trusted within 5% of the longer side: {:.1} px off (at the centre {:.1})", loosely.2, before.2);
    assert!(step.principal_point_refined, "{step:?}");
    assert!(loosely.2 > 2.0 * before.2, "principal points {:.1} px off (at the centre {:.1})", loosely.2, before.2);
}

//! The pose stages on a small synthetic hand-held event with ground truth: every frame of every
//! camera posed within the accuracy, the smoothness priors reduce frame-to-frame jitter,
//! and a re-run reuses the keyframe stage.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use std::sync::atomic::AtomicBool;

use dynview_core::Rigid3;
use dynview_eval::align::{PoseEvalOptions, evaluate_poses};
use dynview_interchange::colmap::ColmapModel;
use dynview_interchange::poses::EventPoses;
use dynview_sfm::{PrepOptions, Stage, run};
use dynview_synth::SynthConfig;

const FRAMES: u32 = 25;
const KEYFRAME_INTERVAL: usize = 12;

/// One synthetic event for all tests of this file: 4 hand-held cameras, 25 frames, 480x270.
fn event() -> &'static Path {
    static EVENT: OnceLock<(tempfile::TempDir, PathBuf)> = OnceLock::new();
    &EVENT
        .get_or_init(|| {
            let dir = tempfile::tempdir().expect("temp dir");
            let out = dir.path().join("event");
            let config = SynthConfig { cameras: 4, frames: FRAMES, width: 480, height: 270, handheld: true, ..SynthConfig::default() };
            dynview_synth::generate(&config, &out, &|_, _, _| {}).expect("synth");
            (dir, out)
        })
        .1
}

/// The event's videos when ffmpeg wrote them, else its image folders.
fn input() -> PathBuf {
    let videos = event().join("videos");
    if videos.is_dir() { videos } else { event().join("input") }
}

/// `<camera>/<frame stem>` -> pose, from a name like `cam00/00012.png`.
fn by_stem(poses: impl IntoIterator<Item = (String, Rigid3)>) -> BTreeMap<String, Rigid3> {
    poses.into_iter().map(|(name, pose)| (name.rsplit_once('.').map_or(name.clone(), |(s, _)| s.to_string()), pose)).collect()
}

fn ground_truth() -> BTreeMap<String, Rigid3> {
    let model = ColmapModel::read_dir(&event().join("colmap")).expect("ground-truth model");
    by_stem(model.images.values().map(|im| (im.name.clone(), im.camera_from_world)))
}

fn estimated(poses: &EventPoses) -> BTreeMap<String, Rigid3> {
    let mut out = Vec::new();
    for (c, camera) in poses.cameras.iter().enumerate() {
        for (t, frame) in camera.frames.iter().enumerate() {
            if let Some(pose) = poses.camera_from_world(c, t) {
                out.push((format!("{}/{}", camera.name, frame.file), pose));
            }
        }
    }
    by_stem(out)
}

/// RMS over consecutive frames of one camera of the change of the centre error, as a share of
/// the scene size: how much the recovered path shakes around the true one.
fn jitter(estimated: &BTreeMap<String, Rigid3>, truth: &BTreeMap<String, Rigid3>) -> f64 {
    let accuracy = evaluate_poses(estimated, truth, PoseEvalOptions::default()).expect("evaluation");
    let sim = accuracy.true_from_estimated;
    let error = |name: &str| sim.transform_point(estimated[name].camera_center_world()) - truth[name].camera_center_world();
    let names: Vec<&String> = estimated.keys().collect();
    let mut sum = 0.0;
    let mut count = 0;
    for pair in names.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        if a.split('/').next() == b.split('/').next() {
            sum += (error(b) - error(a)).length_squared();
            count += 1;
        }
    }
    (sum / count as f64).sqrt() / accuracy.scene_size
}

#[test]
fn every_frame_is_posed_accurately_and_the_priors_reduce_jitter() {
    let out = tempfile::tempdir().expect("temp dir");
    let options = PrepOptions { keyframe_interval: KEYFRAME_INTERVAL, stop_after: Stage::Poses, ..PrepOptions::default() };
    let stop = AtomicBool::new(false);
    let report = run(&input(), out.path(), &options, &|_, _, _| {}, &stop).expect("prep with priors");
    assert_eq!((report.cameras, report.frames), (4, FRAMES as usize));
    assert_eq!(report.keyframes_registered, report.keyframes, "every keyframe registered: {:?}", report.focal_source);
    // Each camera its own intrinsics; the report says per camera how well the data fix its
    // focal length, and whether they fixed its principal point well enough to refine it, with
    // the figure; the cameras decide alike.
    assert_eq!(report.intrinsics_refined.len(), 4);
    for note in &report.intrinsics_refined {
        let percent: f64 = note
            .strip_prefix("focal refined (known to ")
            .and_then(|rest| rest.split_once("%)"))
            .and_then(|(figure, _)| figure.parse().ok())
            .unwrap_or_else(|| panic!("no focal standard deviation in {note:?}"));
        assert!(percent > 0.0 && percent < 2.0, "{note}");
    }
    let refined = report.intrinsics_refined.iter().filter(|n| n.contains("), principal point refined (known to ")).count();
    let kept =
        report.intrinsics_refined.iter().filter(|n| n.contains("), principal point kept at the image centre: the data fix it to ")).count();
    assert!(refined == 4 || kept == 4, "{:?}", report.intrinsics_refined);
    assert!(report.intrinsics_refined.iter().all(|n| !n.contains("shared with")), "{:?}", report.intrinsics_refined);
    assert!(report.refine.iter().all(|r| r.frames_repaired == 0), "{:?}", report.refine);
    let with_priors = estimated(&EventPoses::read(&out.path().join("poses.json")).expect("poses.json"));
    let truth = ground_truth();
    let accuracy = evaluate_poses(&with_priors, &truth, PoseEvalOptions::default()).expect("evaluation");
    println!(
        "with priors: {} of {} frames, rotation median {:.3} max {:.3} deg, centre median {:.3}% max {:.3}%",
        accuracy.registered,
        accuracy.ground_truth_images,
        accuracy.rotation_error_median_deg,
        accuracy.rotation_error_max_deg,
        100.0 * accuracy.center_error_median_fraction,
        100.0 * accuracy.center_error_max_fraction
    );
    assert_eq!(accuracy.registered, 4 * FRAMES as usize, "every frame of every camera has a pose");
    assert!(accuracy.rotation_error_median_deg < 0.2, "median rotation error {} deg", accuracy.rotation_error_median_deg);
    // Below 0.5% from JPEG work frames; 0.51% from lossless ones (issue 33), with the rotation
    // median at 0.037 degrees: the features differ, not the accuracy. The same code gives 0.667%
    // (rotation median 0.045 degrees) on an AMD EPYC machine: OpenCV picks its SIMD code by
    // processor and the features shift with it, so the bound leaves room for the machine.
    assert!(accuracy.center_error_median_fraction < 0.008, "median centre error {}", accuracy.center_error_median_fraction);

    // The same run without priors: the keyframe stage is reused, only refinement reruns.
    let mut off = options.clone();
    off.refine.smoothness = 0.0;
    let report = run(&input(), out.path(), &off, &|_, _, _| {}, &stop).expect("prep without priors");
    assert!(report.skipped.iter().any(|s| s == "keyframes"), "keyframes reused: {:?}", report.skipped);
    let without = estimated(&EventPoses::read(&out.path().join("poses.json")).expect("poses.json"));
    let (j_on, j_off) = (jitter(&with_priors, &truth), jitter(&without, &truth));
    println!("jitter (RMS frame-to-frame change of the centre error): {:.4}% with priors, {:.4}% without", 100.0 * j_on, 100.0 * j_off);
    assert!(j_on < 0.8 * j_off, "priors must reduce jitter: {j_on} vs {j_off}");
}

/// The default demo's regime: tripod cameras on a richly textured event. Their keyframes match
/// well at one time step, so they are not pooled (a pooled pair of theirs matches mostly on the
/// static background and would not be trusted), and every camera is posed.
#[test]
fn tripod_cameras_on_a_textured_event_are_all_posed() {
    let dir = tempfile::tempdir().expect("temp dir");
    let event = dir.path().join("event");
    let config = SynthConfig { cameras: 4, frames: 8, width: 480, height: 270, handheld: false, ..SynthConfig::default() };
    dynview_synth::generate(&config, &event, &|_, _, _| {}).expect("synth");
    let out = dir.path().join("prep");
    let options = PrepOptions { keyframe_interval: 4, stop_after: Stage::Poses, ..PrepOptions::default() };
    let report = run(&event.join("input"), &out, &options, &|_, _, _| {}, &AtomicBool::new(false)).expect("prep");
    assert_eq!(report.keyframes_registered, report.keyframes, "{:?}", report.focal_source);
    assert!(report.focal_source.iter().all(|s| s.contains("stands still") && s.contains("not pooled")), "{:?}", report.focal_source);
    let poses = EventPoses::read(&out.join("poses.json")).expect("poses.json");
    assert_eq!(poses.registered_frame_count(), 4 * 8, "every frame of every camera has a pose");
}

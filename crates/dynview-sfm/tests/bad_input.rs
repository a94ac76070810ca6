//! Bad inputs give errors that name the file, camera or option, never a panic.

use std::path::Path;
use std::sync::atomic::AtomicBool;

use dynview_sfm::{PrepOptions, SfmError, Stage, run};

fn textured(path: &Path, seed: u32) {
    // A deterministic high-contrast pattern SIFT finds many features in.
    let image = image::RgbImage::from_fn(160, 120, |x, y| {
        let v = (x.wrapping_mul(7919) ^ y.wrapping_mul(104_729) ^ seed).wrapping_mul(2_654_435_761) >> 24;
        let block = ((x / 6 + y / 6 + seed) % 3) as u8 * 60;
        image::Rgb([v as u8, block, (255 - v) as u8])
    });
    image.save(path).expect("write png");
}

fn camera(root: &Path, name: &str, frames: usize, black: bool) {
    let dir = root.join(name);
    std::fs::create_dir_all(&dir).expect("mkdir");
    for t in 0..frames {
        let path = dir.join(format!("{t:05}.png"));
        if black {
            image::RgbImage::new(160, 120).save(&path).expect("write png");
        } else {
            textured(&path, t as u32);
        }
    }
}

fn prep(input: &Path, options: &PrepOptions) -> Result<dynview_sfm::PrepReport, SfmError> {
    let out = tempfile::tempdir().expect("temp dir");
    run(input, out.path(), options, &|_, _, _| {}, &AtomicBool::new(false))
}

#[test]
fn different_frame_counts_are_cut_to_the_shortest_with_a_warning_or_refused_when_strict() {
    let dir = tempfile::tempdir().expect("temp dir");
    camera(dir.path(), "a", 3, false);
    camera(dir.path(), "b", 2, false);
    let frames_only = PrepOptions { stop_after: Stage::Frames, ..PrepOptions::default() };
    let report = prep(dir.path(), &frames_only).expect("trimmed");
    assert_eq!(report.frames, 2);
    assert!(report.warnings.iter().any(|w| w.contains("a: 3") && w.contains("b: 2")), "{:?}", report.warnings);
    let err = prep(dir.path(), &PrepOptions { trim: false, ..frames_only }).expect_err("counts differ").to_string();
    assert!(err.contains("a: 3") && err.contains("b: 2") && err.contains("--strict-frame-counts"), "{err}");
}

#[test]
fn an_undecodable_video_is_named() {
    let dir = tempfile::tempdir().expect("temp dir");
    std::fs::write(dir.path().join("cam1.mp4"), b"this is not a video").expect("write");
    let err = prep(dir.path(), &PrepOptions { stop_after: Stage::Frames, ..PrepOptions::default() }).expect_err("garbage video");
    assert!(matches!(err, SfmError::Decode { .. }), "{err}");
    assert!(err.to_string().contains("cam1.mp4"), "{err}");
}

#[test]
fn a_textureless_camera_is_named() {
    let dir = tempfile::tempdir().expect("temp dir");
    camera(dir.path(), "good", 1, false);
    camera(dir.path(), "dark", 1, true);
    let err = prep(dir.path(), &PrepOptions { stop_after: Stage::Keyframes, ..PrepOptions::default() }).expect_err("black camera");
    let text = err.to_string();
    assert!(matches!(err, SfmError::TooFewFeatures { .. }) && text.contains("camera dark") && text.contains("00000.png"), "{text}");
}

#[test]
fn empty_folders_bad_names_and_bad_options_are_clear() {
    let dir = tempfile::tempdir().expect("temp dir");
    let err = prep(dir.path(), &PrepOptions::default()).expect_err("empty").to_string();
    assert!(err.contains("no cameras found"), "{err}");
    let err = prep(&dir.path().join("missing"), &PrepOptions::default()).expect_err("missing").to_string();
    assert!(err.contains("not a folder"), "{err}");
    camera(dir.path(), "bad name", 1, false);
    let err = prep(dir.path(), &PrepOptions::default()).expect_err("bad name").to_string();
    assert!(err.contains("bad name") && err.contains("camera name"), "{err}");
    let err = prep(dir.path(), &PrepOptions { keyframe_interval: 0, ..PrepOptions::default() }).expect_err("kappa 0").to_string();
    assert!(err.contains("keyframe-interval"), "{err}");
}

#[test]
fn cameras_that_share_nothing_give_a_clear_error() {
    let dir = tempfile::tempdir().expect("temp dir");
    camera(dir.path(), "a", 1, false);
    // Different random patterns: features, but no matches between the cameras.
    let b = dir.path().join("b");
    std::fs::create_dir_all(&b).expect("mkdir");
    textured(&b.join("00000.png"), 99_991);
    let err = prep(dir.path(), &PrepOptions::default()).expect_err("nothing shared").to_string();
    assert!(err.contains("structure from motion"), "{err}");
}

#[test]
fn an_interrupted_run_stops_with_interrupted_and_keeps_finished_stages() {
    let dir = tempfile::tempdir().expect("temp dir");
    camera(dir.path(), "a", 2, false);
    camera(dir.path(), "b", 2, false);
    let out = tempfile::tempdir().expect("temp dir");
    let options = PrepOptions { stop_after: Stage::Keyframes, ..PrepOptions::default() };
    let err = run(dir.path(), out.path(), &options, &|_, _, _| {}, &AtomicBool::new(true)).expect_err("interrupted");
    assert!(matches!(err, SfmError::Interrupted), "{err}");
    assert!(out.path().join("work/frames.json").is_file(), "the finished frames stage is kept");
}

/// A synthetic event's cameras plus a black camera, a camera of an unrelated scene and a short
/// video: the three are reported and the package is made from what is usable.
#[test]
fn a_black_camera_an_unrelated_camera_and_a_short_video_give_warnings_and_a_package_of_the_rest() {
    let dir = tempfile::tempdir().expect("temp dir");
    let event = dir.path().join("event");
    let config = dynview_synth::SynthConfig { cameras: 4, frames: 3, width: 480, height: 270, videos: false, ..Default::default() };
    dynview_synth::generate(&config, &event, &|_, _, _| {}).expect("synth");
    let input = event.join("input");
    // The last synthetic camera lost its final frame; two more cameras film nothing useful.
    std::fs::remove_file(input.join("cam03/00002.png")).expect("shorten cam03");
    camera(&input, "black", 3, true);
    let unrelated = input.join("unrelated");
    std::fs::create_dir_all(&unrelated).expect("mkdir");
    for t in 0..3 {
        textured(&unrelated.join(format!("{t:05}.png")), 7_000 + t);
    }
    let out = dir.path().join("prep");
    let options = PrepOptions {
        keyframe_interval: 2,
        steps: dynview_sfm::pipeline::timesteps::StepOptions { working_width: 240, densify: None, ..Default::default() },
        ..PrepOptions::default()
    };
    let report = run(&input, &out, &options, &|_, _, _| {}, &AtomicBool::new(false)).expect("a package from the usable cameras");
    let warnings = report.warnings.join("\n");
    assert!(warnings.contains("cam03: 2"), "the short video is reported: {warnings}");
    assert!(warnings.contains("camera black") && warnings.contains("textureless"), "the black camera is reported: {warnings}");
    assert!(warnings.contains("camera unrelated"), "the unrelated camera is reported: {warnings}");
    let package = dynview_core::scene::ScenePackage::open(out.join("scene")).expect("package");
    let names: Vec<&str> = package.manifest().cameras.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["cam00", "cam01", "cam02", "cam03"]);
    assert_eq!(package.time_step_count(), 2);
    assert_eq!((package.manifest().cameras[0].width, package.manifest().cameras[0].height), (240, 135));
    package.verify(|_, _| {}).expect("every cloud and frame is readable");
    assert!(package.read_cloud(1).expect("cloud").len() > 100, "points at the last time step");
}

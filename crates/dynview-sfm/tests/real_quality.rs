//! A quick real-footage quality test (issue 33, item 6): leave-one-camera-out on a short slice
//! of the Panoptic basketball arc (`../shared/data/panoptic-basketball-arc`) at a small working
//! size. The other seven cameras are prepared with their calibration (`dynview prep --poses
//! ... --working-width ...`, run here through the library), the held-out camera's view is
//! rendered at every time step with the full method and with the blend, and each render is
//! compared with the camera's real frame in colour-corrected PSNR (per channel affine fit
//! render -> truth, as `cargo xtask eval --real` scores it).
//!
//! The full method must beat the blend by [`MARGIN_DB`] and stay above [`FULL_FLOOR_DB`], so
//! that a change that costs quality on real footage fails `cargo xtask test` rather than only
//! showing in the long evaluation. The held-out camera's intrinsics, pose and real frames come
//! from a package prepared the same way with all eight cameras (as `eval-real` does), so the
//! two packages share their working size, undistortion and world.

use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use dynview_core::metrics::psnr;
use dynview_core::render::{Method, RenderHooks, RenderParams, StreamingRenderer};
use dynview_core::scene::ScenePackage;
use dynview_eval::datasets::real_captures::RealCapture;
use dynview_eval::eval::real::scores::color_corrected;
use dynview_sfm::{PrepOptions, run};

/// The capture: the first Panoptic arc (8 calibrated cameras, neighbours 5-25 degrees apart).
const CAPTURE: RealCapture = RealCapture::Panoptic;
/// The camera left out: an interior one, with neighbours on both sides.
const HELD_OUT: &str = "cam08";
/// Frames of each camera used, from the first.
const FRAMES: u32 = 8;
/// Width prep works at, pixels (the capture is 640x360).
const WORKING_WIDTH_PX: u32 = 320;
/// How far the full method's mean colour-corrected PSNR must stay above the blend's, dB: about
/// half the gap measured on 2026-11-26 (cam08 held out, 8 frames at 320 px, default prep and
/// renderer): full 19.35 dB, blend 18.20 dB, gap 1.14 dB (6 frames: 19.26 / 18.15, gap 1.11;
/// cam11 held out instead: gap 0.94 dB, cam27: 1.78 dB).
const MARGIN_DB: f64 = 0.55;
/// The least mean colour-corrected PSNR of the full method, dB: about 3 dB under the 19.35 dB
/// measured (see [`MARGIN_DB`]), so a broken renderer fails even when the blend collapses with it.
const FULL_FLOOR_DB: f64 = 16.0;

/// Prepares the frames in `input` with the calibrated poses of `cameras` (all when `None`) into
/// `out`, and opens the package.
fn prep(input: &Path, out: &Path, cameras: Option<&[&str]>) -> ScenePackage {
    let poses = out.with_extension("poses.json");
    CAPTURE.write_poses(&poses, cameras).expect("the Panoptic arc's calibration in ../shared/data/panoptic-basketball-arc");
    let mut options = PrepOptions { poses: Some(poses), ..PrepOptions::default() };
    options.steps.working_width = WORKING_WIDTH_PX;
    let report = run(input, out, &options, &|_, _, _| {}, &AtomicBool::new(false))
        .unwrap_or_else(|e| panic!("prep of {} with calibrated poses: {e}", input.display()));
    let scene = report.package_dir.expect("prep wrote no package");
    ScenePackage::open(&scene).unwrap_or_else(|e| panic!("opening {}: {e}", scene.display()))
}

#[test]
fn the_full_method_beats_the_blend_on_a_held_out_real_camera() {
    let started = Instant::now();
    let dir = tempfile::tempdir().expect("temp dir");
    let all = dir.path().join("all");
    CAPTURE
        .write_frames(&all, FRAMES)
        .expect("the Panoptic arc's frames in ../shared/data/panoptic-basketball-arc (see ../shared/data/README.md)");
    let cameras = CAPTURE.cameras().expect("the Panoptic arc's calibration");
    assert!(cameras.iter().any(|c| c == HELD_OUT), "{HELD_OUT} is not a camera of the arc: {cameras:?}");
    let others: Vec<&str> = cameras.iter().map(String::as_str).filter(|c| *c != HELD_OUT).collect();
    let input = dir.path().join("without");
    CAPTURE.write_frames(&input, FRAMES).expect("the Panoptic arc's frames");
    std::fs::remove_dir_all(input.join(HELD_OUT)).expect("removing the held-out camera's frames");

    let reference = prep(&all, &dir.path().join("all_out"), None);
    let package = prep(&input, &dir.path().join("without_out"), Some(&others));
    let prepared = started.elapsed().as_secs_f64();

    let k = reference.manifest().cameras.iter().position(|c| c.name == HELD_OUT).expect("the held-out camera in the reference package");
    let steps = reference.time_step_count().min(package.time_step_count());
    assert_eq!(steps, FRAMES, "time steps of the packages");
    let methods = [Method::Full, Method::Blend];
    let defaults = RenderParams::default();
    let mut renderers = methods.map(|_| StreamingRenderer::new());
    let mut sums = [0.0f64; 2];
    for t in 0..steps {
        let camera = reference.camera(k, t).expect("the held-out camera's pose");
        let truth = reference.read_frame(k, t).expect("the held-out camera's real frame");
        let inputs = package.time_step_inputs(t, defaults.levels).expect("the package's inputs");
        for ((method, renderer), sum) in methods.iter().zip(&mut renderers).zip(&mut sums) {
            let params = RenderParams { method: *method, ..defaults.clone() };
            let out = renderer.render(&params, &camera, &inputs, &mut RenderHooks::default()).expect("render");
            *sum += psnr(&color_corrected(&out.color, &truth), &truth);
        }
    }
    let [full, blend] = sums.map(|s| s / f64::from(steps));
    println!(
        "{HELD_OUT} held out, {steps} frames at {WORKING_WIDTH_PX} px: colour-corrected PSNR full {full:.2} dB, blend {blend:.2} dB \
         (gap {:.2} dB); prep {prepared:.1} s, all {:.1} s",
        full - blend,
        started.elapsed().as_secs_f64()
    );
    assert!(full >= FULL_FLOOR_DB, "full method {full:.2} dB, under the floor of {FULL_FLOOR_DB} dB");
    assert!(full >= blend + MARGIN_DB, "full method {full:.2} dB, not {MARGIN_DB} dB above the blend's {blend:.2} dB");
}

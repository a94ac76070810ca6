//! Keyframes of cameras that stand still, on a wide arc with long lenses: 8 tripods over 160
//! degrees, focal lengths 1.2 to 1.0 x the longer side, 3 keyframes each. The keyframe pairs
//! across time between two still cameras once left the middle cameras' focal lengths up to 5
//! times too long (24 of 24 registered at 0.37 px, no warning); without them every focal is
//! within 1.1% (`docs/results/sfm.md`, "Found on the way: long lenses on a 160-degree still arc").

use std::sync::atomic::AtomicBool;

use dynview_interchange::colmap::ColmapModel;
use dynview_sfm::{PrepOptions, Stage, run};
use dynview_synth::SynthConfig;
use dynview_synth::rig::Layout;

#[test]
fn long_lenses_on_a_wide_still_arc_keep_their_focal_lengths() {
    let dir = tempfile::tempdir().expect("temp dir");
    let event = dir.path().join("event");
    let layout = Layout { arc_deg: 160.0, focal_range: Some([1.2, 1.0]), principal_offset_px: [5.0, 5.0], ..Layout::default() };
    let config = SynthConfig { cameras: 8, frames: 25, width: 640, height: 360, handheld: false, layout, ..SynthConfig::default() };
    dynview_synth::generate(&config, &event, &|_, _, _| {}).expect("synth");
    let input = if event.join("videos").is_dir() { event.join("videos") } else { event.join("input") };
    let truth = ColmapModel::read_dir(&event.join("colmap")).expect("ground truth");
    let out = dir.path().join("prep");
    let options = PrepOptions { keyframe_interval: 12, stop_after: Stage::Keyframes, ..PrepOptions::default() };
    let report = run(&input, &out, &options, &|_, _, _| {}, &AtomicBool::new(false)).expect("prep");
    assert_eq!(report.keyframes_registered, 24, "every keyframe registered");
    let model = ColmapModel::read_dir(&out.join("work/keyframes/model")).expect("keyframe model");
    let mut worst_percent = 0.0_f64;
    for (id, camera) in &model.cameras {
        let focal = camera.intrinsics().0.fx;
        let true_focal = truth.cameras[id].intrinsics().0.fx;
        worst_percent = worst_percent.max(100.0 * (focal / true_focal - 1.0).abs());
    }
    println!("largest focal error {worst_percent:.2}%");
    // Measured: 1.03% (with the pairs across time: 463%).
    assert!(worst_percent < 2.0, "largest focal error {worst_percent:.2}%");
}

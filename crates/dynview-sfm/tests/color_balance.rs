//! Cameras that film one event with different color responses get color balances that map
//! them to one response (`docs/PREP.md`, stage 6).

use std::sync::atomic::AtomicBool;

use dynview_core::color_balance::ColorTransform;
use dynview_core::scene::ScenePackage;
use dynview_sfm::{PrepOptions, run};

/// cam01's sensor: paler and warmer than the others, which film as the synthetic event is.
const CAM01_RESPONSE: ColorTransform = ColorTransform { gain: [0.85, 0.8, 0.7], offset: [0.12, 0.1, 0.08] };

#[test]
fn a_camera_with_another_response_is_balanced_to_the_others() {
    let dir = tempfile::tempdir().expect("temp dir");
    let event = dir.path().join("event");
    let config = dynview_synth::SynthConfig { cameras: 4, frames: 3, width: 480, height: 270, videos: false, ..Default::default() };
    dynview_synth::generate(&config, &event, &|_, _, _| {}).expect("synth");
    let input = event.join("input");
    for t in 0..3 {
        let path = input.join(format!("cam01/{t:05}.png"));
        let mut frame = image::open(&path).expect("frame").to_rgb8();
        for px in frame.pixels_mut() {
            let c = CAM01_RESPONSE.apply(px.0.map(|v| f32::from(v) / 255.0));
            px.0 = c.map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8);
        }
        frame.save(&path).expect("write frame");
    }
    let out = dir.path().join("prep");
    let options = PrepOptions {
        keyframe_interval: 2,
        steps: dynview_sfm::pipeline::timesteps::StepOptions { working_width: 240, ..Default::default() },
        ..PrepOptions::default()
    };
    let report = run(&input, &out, &options, &|_, _, _| {}, &AtomicBool::new(false)).expect("prep");
    let package = report.package.expect("a package");
    assert!(package.color_samples > 1000, "points seen by several cameras: {}", package.color_samples);
    let scene = ScenePackage::open(out.join("scene")).expect("package");
    let maps: Vec<ColorTransform> = scene.manifest().cameras.iter().map(|c| c.color_balance.expect("every camera is balanced")).collect();
    // A surface color as each camera filmed it, after its balance: the same in every camera.
    for x in [0.2f32, 0.5, 0.8] {
        let filmed = |c: usize| if c == 1 { CAM01_RESPONSE.apply([x; 3]) } else { [x; 3] };
        let balanced: Vec<[f32; 3]> = (0..4).map(|c| maps[c].apply(filmed(c))).collect();
        for b in &balanced {
            for k in 0..3 {
                assert!((b[k] - balanced[0][k]).abs() < 0.03, "color {x} after the balances: {balanced:?}");
            }
        }
    }
    // The three cameras that agree are left almost as they are; cam01 is changed the most.
    let changes: Vec<f32> = maps.iter().map(|m| 255.0 * m.largest_change()).collect();
    assert!(changes[1] > 20.0 && [0, 2, 3].iter().all(|&c| changes[c] < changes[1] / 2.0), "largest changes: {changes:?}");
}

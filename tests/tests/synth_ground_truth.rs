//! The synthetic event's outputs agree with each other: COLMAP poses, surface points, frames,
//! held-out depth, the camera path and the scene package.

use std::fs;

use dynview_core::depth_io::{DepthScale, SCALE_FILE, depth_from_image};
use dynview_core::scene::ScenePackage;
use dynview_core::{Camera, RgbRaster};
use dynview_interchange::camera_path::parse_path;
use dynview_interchange::colmap::ColmapModel;
use dynview_tests::{load_rgb, small_config, small_event};
use glam::{DVec2, DVec3};

fn load_model(dir: &std::path::Path) -> ColmapModel {
    let read = |f: &str| fs::read_to_string(dir.join(f)).unwrap();
    ColmapModel::from_text(&read("cameras.txt"), &read("images.txt"), &read("points3D.txt")).unwrap()
}

fn camera_of(model: &ColmapModel, name: &str) -> Camera {
    let image = model.images.values().find(|i| i.name == name).unwrap_or_else(|| panic!("no image {name}"));
    let cam = &model.cameras[&image.camera_id];
    Camera { intrinsics: cam.intrinsics().0, camera_from_world: image.camera_from_world, width_px: cam.width, height_px: cam.height }
}

fn color_diff(a: [f32; 3], b: [f32; 3]) -> f32 {
    (0..3).map(|i| (a[i] - b[i]).abs()).sum::<f32>() / 3.0
}

fn sample(image: &RgbRaster, camera: &Camera, p: DVec3) -> Option<[f32; 3]> {
    let (px, _) = camera.project_world(p)?;
    camera.contains(px).then(|| image.sample_bilinear(px.x as f32, px.y as f32)).flatten()
}

fn median(mut v: Vec<f32>) -> f32 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

#[test]
fn colmap_points_are_photo_consistent_across_two_cameras() {
    let event = small_event();
    let model = load_model(&event.join("colmap"));
    let config = small_config();
    assert_eq!(model.cameras.len(), config.cameras);
    assert_eq!(model.images.len(), config.cameras * config.frames as usize);
    assert!(model.points3d.len() > 200, "{} points", model.points3d.len());
    let (a, b) = (camera_of(&model, "cam00/00000.png"), camera_of(&model, "cam01/00000.png"));
    let (img_a, img_b) = (load_rgb(&event.join("input/cam00/00000.png")), load_rgb(&event.join("input/cam01/00000.png")));
    let mut diffs = Vec::new();
    for point in model.points3d.values() {
        let p = DVec3::from_array(point.xyz);
        if let (Some(ca), Some(cb)) = (sample(&img_a, &a, p), sample(&img_b, &b, p)) {
            diffs.push(color_diff(ca, cb));
        }
    }
    assert!(diffs.len() > 100, "only {} points seen by both cameras", diffs.len());
    let agree = diffs.iter().filter(|&&d| d < 0.08).count() as f64 / diffs.len() as f64;
    // Occlusions and texture edges make a few disagree; most land on the same texture.
    assert!(median(diffs.clone()) < 0.04 && agree > 0.75, "median {} agree {agree}", median(diffs));
    // A wrong pose (shifted 10 cm) is not photo-consistent: the test can fail.
    let mut shifted = b;
    shifted.camera_from_world.translation.x += 0.1;
    let wrong: Vec<f32> = model
        .points3d
        .values()
        .filter_map(|pt| {
            let p = DVec3::from_array(pt.xyz);
            Some(color_diff(sample(&img_a, &a, p)?, sample(&img_b, &shifted, p)?))
        })
        .collect();
    assert!(median(wrong) > 2.0 * median(diffs));
}

#[test]
fn heldout_depth_agrees_with_colmap_poses() {
    let event = small_event();
    let inputs = load_model(&event.join("colmap"));
    let heldout = load_model(&event.join("heldout/colmap"));
    let scale: DepthScale = serde_json::from_str(&fs::read_to_string(event.join("heldout/depth").join(SCALE_FILE)).unwrap()).unwrap();
    for t in [0u32, 3] {
        let cam = camera_of(&heldout, &format!("heldout/{t:05}.png"));
        let depth = depth_from_image(&image::open(event.join(format!("heldout/depth/{t:05}.png"))).unwrap().into_luma16(), scale);
        let color = load_rgb(&event.join(format!("heldout/color/{t:05}.png")));
        let mut diffs = Vec::new();
        for input in ["cam01", "cam02"] {
            let other = camera_of(&inputs, &format!("{input}/{t:05}.png"));
            let img = load_rgb(&event.join(format!("input/{input}/{t:05}.png")));
            for y in (2..depth.height - 2).step_by(4) {
                for x in (2..depth.width - 2).step_by(4) {
                    let d = depth.get(x, y);
                    if d.is_nan() {
                        continue;
                    }
                    let p = cam.unproject_world(DVec2::new(x as f64, y as f64), f64::from(d));
                    if let Some(c) = sample(&img, &other, p) {
                        diffs.push(color_diff(c, color.get(x, y)));
                    }
                }
            }
        }
        assert!(diffs.len() > 500);
        let med = median(diffs);
        assert!(med < 0.04, "frame {t}: median color difference {med}");
    }
}

#[test]
fn camera_path_matches_heldout_model_and_package_is_valid() {
    let event = small_event();
    let heldout = load_model(&event.join("heldout/colmap"));
    let frames = parse_path(&fs::read(event.join("camera_path.json")).unwrap(), "camera_path.json", None).unwrap();
    let config = small_config();
    assert_eq!(frames.len(), config.frames as usize);
    for (t, frame) in frames.iter().enumerate() {
        assert_eq!(frame.time.time_step(config.frames), t as u32);
        let truth = camera_of(&heldout, &format!("heldout/{t:05}.png"));
        assert!((frame.camera.center_world() - truth.center_world()).length() < 1e-9);
        assert!((frame.camera.intrinsics.fy - truth.intrinsics.fy).abs() < 1e-6);
    }
    let package = ScenePackage::open(event.join("scene")).unwrap();
    package.verify(|_, _| {}).unwrap();
    assert_eq!(package.camera_count(), config.cameras);
    assert_eq!(package.time_step_count(), config.frames);
    // Clouds hold the sampled share of every camera's pixels (fewer where rays hit no surface).
    let cloud = package.read_cloud(1).unwrap();
    let expected = (config.point_fraction * f64::from(config.width * config.height)).round() as usize * config.cameras;
    assert!(cloud.len() > expected / 2 && cloud.len() <= expected, "{} points", cloud.len());
}

#[test]
fn rerunning_synth_replaces_output_but_never_foreign_folders() {
    let tmp = tempfile::tempdir().unwrap();
    let foreign = tmp.path().join("notes");
    fs::create_dir(&foreign).unwrap();
    fs::write(foreign.join("todo.txt"), "mine").unwrap();
    let config = dynview_synth::SynthConfig { frames: 1, cameras: 2, width: 32, height: 18, videos: false, ..Default::default() };
    let err = dynview_synth::generate(&config, &foreign, &|_, _, _| {}).unwrap_err();
    assert!(err.to_string().contains("refusing"), "{err}");
    assert_eq!(fs::read_to_string(foreign.join("todo.txt")).unwrap(), "mine");
    let out = tmp.path().join("event");
    dynview_synth::generate(&config, &out, &|_, _, _| {}).unwrap();
    dynview_synth::generate(&config, &out, &|_, _, _| {}).unwrap();
    assert!(out.join("synth.json").is_file());
    let bad = dynview_synth::SynthConfig { cameras: 1, ..config };
    assert!(dynview_synth::generate(&bad, &out, &|_, _, _| {}).unwrap_err().to_string().contains("cameras"));
}

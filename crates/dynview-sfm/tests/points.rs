//! Per-timestep points on a synthetic event with known poses: they lie on the true surfaces,
//! moving objects included (nothing is matched through time).

use dynview_camera::Radial;
use dynview_interchange::colmap::ColmapModel;
use dynview_interchange::poses::EventPoses;
use dynview_sfm::features::sift::FeatureOptions;
use dynview_sfm::input::frames::read_bgr;
use dynview_sfm::mapping::points::{PointOptions, TimestepView, timestep_points};
use dynview_synth::SynthConfig;
use dynview_synth::scene::{Frame, default_objects};
use glam::DVec3;

#[test]
fn timestep_points_lie_on_the_true_surfaces_including_moving_objects() {
    let dir = tempfile::tempdir().expect("temp dir");
    let event = dir.path().join("event");
    let config = SynthConfig { cameras: 4, frames: 12, width: 480, height: 270, videos: false, ..SynthConfig::default() };
    dynview_synth::generate(&config, &event, &|_, _, _| {}).expect("synth");
    let poses = EventPoses::from_colmap(&ColmapModel::read_dir(&event.join("colmap")).expect("model")).expect("poses");
    let t = 11;
    let images: Vec<_> =
        poses.cameras.iter().map(|c| read_bgr(&event.join("input").join(&c.name).join(&c.frames[t].file)).expect("frame")).collect();
    let views: Vec<TimestepView> = poses
        .cameras
        .iter()
        .zip(&images)
        .enumerate()
        .map(|(c, (camera, image))| {
            let k = &camera.intrinsics;
            TimestepView {
                intrinsics: Radial { f: k.fx, cx: k.cx, cy: k.cy, k1: 0.0, k2: 0.0 },
                pose: poses.camera_from_world(c, t).expect("pose"),
                image_bgr: image,
            }
        })
        .collect();
    let cloud = timestep_points(&views, &FeatureOptions::default(), &PointOptions::default()).expect("points");
    assert!(cloud.positions_world.len() >= 300, "{} points", cloud.positions_world.len());

    // Trace the true scene at this time from camera 0's centre towards each point.
    let objects = default_objects(config.seed);
    let frame = Frame::at(&objects, config.time_s(t as u32));
    let origin = views[0].pose.camera_center_world();
    let mut errors = Vec::new();
    let mut on_moving = 0;
    for p in &cloud.positions_world {
        let point = DVec3::new(p.x, p.y, p.z);
        let distance = (point - origin).length();
        if let Some(hit) = frame.trace(origin, (point - origin) / distance) {
            errors.push((hit.t - distance).abs() / distance);
            if objects[hit.object].motion.is_dynamic() && (hit.t - distance).abs() < 0.01 * distance {
                on_moving += 1;
            }
        }
    }
    errors.sort_by(f64::total_cmp);
    let median = errors[errors.len() / 2];
    println!(
        "{} points, median depth error {:.3}% from camera 0, {on_moving} on moving objects",
        cloud.positions_world.len(),
        100.0 * median
    );
    assert!(median < 0.005, "median relative depth error {median}");
    assert!(on_moving >= 10, "moving objects get points: {on_moving}");
    assert!(cloud.views.iter().all(|&v| v >= 2) && cloud.colors.len() == cloud.positions_world.len());
}

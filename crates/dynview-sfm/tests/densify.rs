//! Densification on a synthetic event with known poses: many more points than the sparse cloud,
//! on the true surfaces (moving objects included), deterministic, within the target count, and no
//! panic on degenerate input.

use dynview_camera::{Radial, Rigid3};
use dynview_interchange::colmap::ColmapModel;
use dynview_interchange::poses::EventPoses;
use dynview_sfm::dense::densify::{DensifyOptions, densify};
use dynview_sfm::features::sift::FeatureOptions;
use dynview_sfm::input::frames::read_bgr;
use dynview_sfm::mapping::points::{PointOptions, TimestepCloud, TimestepView, timestep_points};
use dynview_synth::SynthConfig;
use dynview_synth::scene::{Frame, default_objects};
use glam::DVec3;
use opencv::core::Mat;

/// The frames and poses of time step `t` of a small synthetic event.
struct Event {
    config: SynthConfig,
    t: usize,
    images: Vec<Mat>,
    intrinsics: Vec<Radial>,
    poses: Vec<Rigid3>,
}

impl Event {
    fn generate() -> Self {
        let dir = tempfile::tempdir().expect("temp dir");
        let event = dir.path().join("event");
        let config = SynthConfig { cameras: 4, frames: 6, width: 480, height: 270, videos: false, ..SynthConfig::default() };
        dynview_synth::generate(&config, &event, &|_, _, _| {}).expect("synth");
        let poses = EventPoses::from_colmap(&ColmapModel::read_dir(&event.join("colmap")).expect("model")).expect("poses");
        let t = 5;
        let images =
            poses.cameras.iter().map(|c| read_bgr(&event.join("input").join(&c.name).join(&c.frames[t].file)).expect("frame")).collect();
        let intrinsics = poses
            .cameras
            .iter()
            .map(|c| Radial { f: c.intrinsics.fx, cx: c.intrinsics.cx, cy: c.intrinsics.cy, k1: 0.0, k2: 0.0 })
            .collect();
        let poses = (0..poses.cameras.len()).map(|c| poses.camera_from_world(c, t).expect("pose")).collect();
        Self { config, t, images, intrinsics, poses }
    }

    fn views(&self) -> Vec<TimestepView<'_>> {
        self.images
            .iter()
            .zip(self.intrinsics.iter().zip(&self.poses))
            .map(|(image, (k, pose))| TimestepView { intrinsics: *k, pose: *pose, image_bgr: image })
            .collect()
    }

    /// Relative depth errors against the true surfaces (along the ray from the camera centre for
    /// which the point is closest to them; from camera 0 alone a point hidden from it would count
    /// as wrong) and the number of points within 1% on moving objects.
    fn errors(&self, cloud: &TimestepCloud) -> (Vec<f64>, usize) {
        let objects = default_objects(self.config.seed);
        let frame = Frame::at(&objects, self.config.time_s(self.t as u32));
        let origins: Vec<DVec3> = self.poses.iter().map(Rigid3::camera_center_world).collect();
        frame.relative_depth_errors(&origins, cloud.positions_world.iter().map(|p| DVec3::new(p.x, p.y, p.z)))
    }
}

#[test]
fn densify_grows_the_sparse_points_on_the_true_surfaces() {
    let event = Event::generate();
    let views = event.views();
    let sparse = timestep_points(&views, &FeatureOptions::default(), &PointOptions::default()).expect("points");
    let options = DensifyOptions::default();
    let start = std::time::Instant::now();
    let dense = densify(&views, &sparse, &options).expect("densify");
    let elapsed = start.elapsed();
    let (errors, on_moving) = event.errors(&dense);
    let quantile = |q: f64| errors[((errors.len() - 1) as f64 * q) as usize];
    let off = errors.iter().filter(|&&e| e > 0.05).count() as f64 / errors.len() as f64;
    println!(
        "{} sparse -> {} dense points in {elapsed:?}; depth error median {:.3}%, p90 {:.3}%, {:.2}% off by > 5%, {on_moving} on moving objects",
        sparse.positions_world.len(),
        dense.positions_world.len(),
        100.0 * quantile(0.5),
        100.0 * quantile(0.9),
        100.0 * off
    );
    assert!(dense.positions_world.len() >= 3 * sparse.positions_world.len(), "{} points", dense.positions_world.len());
    assert!(dense.positions_world.len() <= options.target_points);
    assert!(dense.colors.len() == dense.positions_world.len() && dense.views.len() == dense.positions_world.len());
    assert!(quantile(0.5) < 0.005, "median relative depth error {}", quantile(0.5));
    assert!(quantile(0.9) < 0.01, "90th percentile of the relative depth error {}", quantile(0.9));
    assert!(off < 0.01, "share of points off by more than 5%: {off}");
    assert!(on_moving >= 80, "moving objects get points: {on_moving}");

    let again = densify(&views, &sparse, &options).expect("densify");
    assert_eq!(again, dense, "two runs give the same cloud");
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("pool");
    let one_thread = pool.install(|| densify(&views, &sparse, &options)).expect("densify");
    assert_eq!(one_thread, dense, "the cloud does not depend on the threads");

    let fewer = densify(&views, &sparse, &DensifyOptions { target_points: 2000, ..options.clone() }).expect("densify");
    assert!(fewer.positions_world.len() <= 2000 && fewer.positions_world.len() >= 1500, "{}", fewer.positions_world.len());
    let below_sparse = densify(&views, &sparse, &DensifyOptions { target_points: 100, ..options }).expect("densify");
    assert_eq!(below_sparse.positions_world.len(), 100);
}

#[test]
fn densify_handles_degenerate_input() {
    let event = Event::generate();
    let views = event.views();
    let options = DensifyOptions { max_side_px: 160, iterations: 1, ..DensifyOptions::default() };
    let sparse = timestep_points(&views, &FeatureOptions::default(), &PointOptions::default()).expect("points");

    let one = densify(&views[..1], &sparse, &options).expect("one view");
    assert_eq!(one, sparse, "one view keeps the sparse cloud");
    let empty = densify(&views, &TimestepCloud::default(), &options).expect("no sparse points");
    assert!(empty.positions_world.is_empty());
    let none = densify(&[], &sparse, &options).expect("no views");
    assert_eq!(none.positions_world.len(), sparse.positions_world.len());

    let mut broken = event.views();
    broken[1].pose.rotation.x_axis.x = f64::NAN;
    broken[2].pose.translation.x = f64::NAN;
    let mut with_nan = sparse.clone();
    with_nan.positions_world[0].x = f64::NAN;
    let cloud = densify(&broken, &with_nan, &options).expect("NaN pose");
    assert!(cloud.positions_world.iter().all(|p| p.iter().all(|v| v.is_finite())));
    let blank = Mat::default();
    let mut blank_views = event.views();
    blank_views[0].image_bgr = &blank;
    densify(&blank_views, &sparse, &options).expect("empty frame");
}

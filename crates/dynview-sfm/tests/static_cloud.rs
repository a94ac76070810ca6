//! The static cloud on a synthetic event with known poses: the points it keeps lie on the true
//! surfaces, are lent to the steps where nothing moved in front of them, and not on the moving
//! objects; the steps gain many points from it.

use dynview_camera::Radial;
use dynview_core::scene::PointCloud;
use dynview_core::{Camera, Rigid3};
use dynview_interchange::colmap::ColmapModel;
use dynview_interchange::poses::EventPoses;
use dynview_sfm::dense::static_cloud::{StaticOptions, build_static_cloud, candidate_steps};
use dynview_sfm::features::sift::FeatureOptions;
use dynview_sfm::input::frames::read_bgr;
use dynview_sfm::mapping::points::{PointOptions, TimestepView, timestep_points};
use dynview_synth::SynthConfig;
use dynview_synth::scene::{Frame, default_objects};
use glam::DVec3;

const STEPS: usize = 8;

fn to_dvec3(p: [f32; 3]) -> DVec3 {
    DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]))
}

#[test]
fn static_points_lie_on_static_surfaces_and_are_lent_where_they_agree() {
    let dir = tempfile::tempdir().expect("temp dir");
    let root = dir.path().join("event");
    let config = SynthConfig { cameras: 4, frames: STEPS as u32, width: 320, height: 180, videos: false, ..SynthConfig::default() };
    dynview_synth::generate(&config, &root, &|_, _, _| {}).expect("synth");
    let event = EventPoses::from_colmap(&ColmapModel::read_dir(&root.join("colmap")).expect("model")).expect("poses");
    let file = |c: usize, t: usize| root.join("input").join(&event.cameras[c].name).join(&event.cameras[c].frames[t].file);
    let pose = |c: usize, t: usize| -> Rigid3 { event.camera_from_world(c, t).expect("pose") };

    // Each step's own points (triangulated across cameras only, as prep does).
    let mut own = Vec::new();
    for t in 0..STEPS {
        let images: Vec<_> = (0..event.cameras.len()).map(|c| read_bgr(&file(c, t)).expect("frame")).collect();
        let views: Vec<TimestepView> = event
            .cameras
            .iter()
            .zip(&images)
            .enumerate()
            .map(|(c, (camera, image))| TimestepView {
                intrinsics: Radial::from_pinhole(&camera.intrinsics.into()),
                pose: pose(c, t),
                image_bgr: image,
            })
            .collect();
        let cloud = timestep_points(&views, &FeatureOptions::default(), &PointOptions::default()).expect("points");
        own.push(PointCloud {
            positions_world: cloud.positions_world.iter().map(|p| [p.x as f32, p.y as f32, p.z as f32]).collect(),
            colors: cloud.colors.clone(),
        });
    }
    let cameras: Vec<Vec<Camera>> = event
        .cameras
        .iter()
        .enumerate()
        .map(|(c, camera)| {
            (0..STEPS)
                .map(|t| Camera {
                    intrinsics: camera.intrinsics,
                    camera_from_world: pose(c, t),
                    width_px: camera.width,
                    height_px: camera.height,
                })
                .collect()
        })
        .collect();
    let frames_at =
        |t: usize| (0..event.cameras.len()).map(|c| image::open(file(c, t)).map(|f| f.to_rgb8())).collect::<Result<Vec<_>, _>>();
    let options = StaticOptions::default();
    let candidates: Vec<(usize, PointCloud)> =
        candidate_steps(STEPS, options.candidate_steps).into_iter().map(|t| (t, own[t].clone())).collect();
    let statics = build_static_cloud(&cameras, frames_at, &candidates, &options).expect("frames");
    let own_mean = own.iter().map(PointCloud::len).sum::<usize>() as f64 / STEPS as f64;
    let lent_mean = (0..STEPS).map(|t| statics.borrowed(t).len()).sum::<usize>() as f64 / STEPS as f64;
    println!(
        "{} candidates -> {} static points; per step {own_mean:.0} own points, {lent_mean:.0} lent",
        statics.candidates,
        statics.points.len()
    );
    assert!(statics.points.len() >= 100, "{} static points", statics.points.len());
    assert!(lent_mean >= 0.5 * own_mean, "the steps gain many points: {lent_mean:.0} lent, {own_mean:.0} own");

    let objects = default_objects(config.seed);
    for (t, own_cloud) in own.iter().enumerate() {
        let lent = statics.borrowed(t);
        let frame = Frame::at(&objects, config.time_s(t as u32));
        let origins: Vec<DVec3> = (0..event.cameras.len()).map(|c| pose(c, t).camera_center_world()).collect();
        let figures = |cloud: &PointCloud| {
            let (errors, on_moving) = frame.relative_depth_errors(&origins, cloud.positions_world.iter().map(|&p| to_dvec3(p)));
            let median = errors[errors.len() / 2];
            let off = errors.iter().filter(|&&e| e > 0.05).count() as f64 / errors.len() as f64;
            (median, off, on_moving)
        };
        let (median, off, on_moving) = figures(&lent);
        let (own_median, own_off, _) = figures(own_cloud);
        println!(
            "step {t}: {} lent, depth error median {:.3}% (own points {:.3}%), {:.2}% off by > 5% (own points {:.2}%), {on_moving} on moving objects",
            lent.len(),
            100.0 * median,
            100.0 * own_median,
            100.0 * off,
            100.0 * own_off
        );
        assert!(median < 0.005, "step {t}: median relative depth error {median}");
        assert!(off <= own_off + 0.02, "step {t}: lent points off by more than 5%: {off}, the step's own: {own_off}");
        assert!((on_moving as f64) < 0.01 * lent.len() as f64, "step {t}: {on_moving} of {} lent points on moving objects", lent.len());
    }
}

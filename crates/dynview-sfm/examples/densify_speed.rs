//! Times per-timestep points and densification on a synthetic event (6 cameras, 960x540 by
//! default) and measures the points' depth errors against the true surfaces.
//!
//! `cargo run --release -p dynview-sfm --example densify_speed [cameras=6] [option=value ...]`, where
//! `option` is a field of `DensifyOptions` (e.g. `max_side_px=320 iterations=3`).

use std::time::Instant;

use dynview_camera::Radial;
use dynview_interchange::colmap::ColmapModel;
use dynview_interchange::poses::EventPoses;
use dynview_sfm::dense::densify::{DensifyOptions, densify};
use dynview_sfm::features::sift::FeatureOptions;
use dynview_sfm::input::frames::read_bgr;
use dynview_sfm::mapping::points::{PointOptions, TimestepCloud, TimestepView, timestep_points};
use dynview_synth::SynthConfig;
use dynview_synth::scene::{Frame, default_objects};
use glam::DVec3;

/// Median and 90th percentile of the relative depth errors (along the ray from the camera centre
/// for which the point is closest to the true surface), share over 5%, and points within 1% on
/// moving objects.
fn accuracy(config: &SynthConfig, t: usize, origins: &[DVec3], cloud: &TimestepCloud) -> (f64, f64, f64, usize) {
    let objects = default_objects(config.seed);
    let frame = Frame::at(&objects, config.time_s(t as u32));
    let (errors, on_moving) = frame.relative_depth_errors(origins, cloud.positions_world.iter().map(|p| DVec3::new(p.x, p.y, p.z)));
    if errors.is_empty() {
        return (f64::NAN, f64::NAN, f64::NAN, 0);
    }
    let q = |q: f64| errors[((errors.len() - 1) as f64 * q) as usize];
    let off = errors.iter().filter(|&&e| e > 0.05).count() as f64 / errors.len() as f64;
    (q(0.5), q(0.9), off, on_moving)
}

/// CPU time (ms) of this process so far, user and system (Linux; 0 elsewhere).
fn cpu_ms() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let fields: Vec<&str> = stat.rsplit(')').next().unwrap_or("").split_whitespace().collect();
    let ticks = |i: usize| fields.get(i).and_then(|f| f.parse::<f64>().ok()).unwrap_or(0.0);
    (ticks(11) + ticks(12)) * 10.0
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut options = serde_json::to_value(DensifyOptions::default())?;
    let mut cameras = 6;
    for arg in std::env::args().skip(1) {
        let (key, value) = arg.split_once('=').ok_or("arguments are option=value")?;
        if key == "cameras" {
            cameras = value.parse()?;
        } else {
            options[key] = serde_json::from_str(value)?;
        }
    }
    let options: DensifyOptions = serde_json::from_value(options)?;
    let dir = tempfile::tempdir()?;
    let event = dir.path().join("event");
    let config = SynthConfig { cameras, frames: 4, width: 960, height: 540, videos: false, ..SynthConfig::default() };
    dynview_synth::generate(&config, &event, &|_, _, _| {})?;
    let poses = EventPoses::from_colmap(&ColmapModel::read_dir(&event.join("colmap"))?)?;
    println!("{cameras} cameras 960x540, {options:?}, {} rayon threads", rayon::current_num_threads());
    for t in [1, 3] {
        let images = poses
            .cameras
            .iter()
            .map(|c| read_bgr(&event.join("input").join(&c.name).join(&c.frames[t].file)))
            .collect::<Result<Vec<_>, _>>()?;
        let mut views = Vec::new();
        for (c, (camera, image)) in poses.cameras.iter().zip(&images).enumerate() {
            let k = &camera.intrinsics;
            views.push(TimestepView {
                intrinsics: Radial { f: k.fx, cx: k.cx, cy: k.cy, k1: 0.0, k2: 0.0 },
                pose: poses.camera_from_world(c, t).ok_or("no pose")?,
                image_bgr: image,
            });
        }
        let origins: Vec<DVec3> = views.iter().map(|v| v.pose.camera_center_world()).collect();
        let start = Instant::now();
        let sparse = timestep_points(&views, &FeatureOptions::default(), &PointOptions::default())?;
        let points_ms = start.elapsed().as_secs_f64() * 1e3;
        let (start, cpu_start) = (Instant::now(), cpu_ms());
        let dense = densify(&views, &sparse, &options)?;
        let densify_ms = start.elapsed().as_secs_f64() * 1e3;
        println!("t={t} densify: {densify_ms:.1} ms wall, {:.1} ms CPU (all threads)", cpu_ms() - cpu_start);
        for (name, cloud, ms) in [("sparse", &sparse, points_ms), ("dense", &dense, densify_ms)] {
            let (median, p90, off, moving) = accuracy(&config, t, &origins, cloud);
            println!(
                "t={t} {name:>6}: {:6} points in {ms:7.1} ms; depth error median {:.3}% p90 {:.3}%, {:.2}% over 5%, {moving} on moving objects",
                cloud.positions_world.len(),
                100.0 * median,
                100.0 * p90,
                100.0 * off
            );
        }
    }
    Ok(())
}

//! The paper's smoothness priors (Eqs. 1-2) reduce pose jitter along a smooth camera path.

mod common;

use common::{CAMERA, add_pixel_noise, look_at, rng};
use dynview_ba::{Loss, Observation, Options, Problem, SmoothnessPrior, pixel_from_world, solve};
use nalgebra::Vector3;
use rand::Rng;

const FRAMES: usize = 30;
/// Points each frame sees (few, so that single-frame poses are noisy).
const POINTS_PER_FRAME: usize = 12;

/// A camera gliding sideways past a fixed point cloud, turning slowly; points fixed.
fn smooth_sequence(seed: u64) -> Problem {
    let mut rng = rng(seed);
    let images: Vec<_> = (0..FRAMES)
        .map(|t| {
            let s = t as f64;
            let center = Vector3::new(0.08 * s - 1.2, 0.2 * (0.15 * s).sin(), 0.1 * (0.1 * s).cos());
            look_at(center, Vector3::new(0.04 * s - 0.6, 12.0, 0.3 * (0.12 * s).sin()))
        })
        .collect();
    let points_world: Vec<[f64; 3]> =
        (0..200).map(|_| [rng.random_range(-6.0..6.0), rng.random_range(8.0..16.0), rng.random_range(-3.0..3.0)]).collect();
    let mut observations = Vec::new();
    for (image, pose) in images.iter().enumerate() {
        let mut seen = 0;
        while seen < POINTS_PER_FRAME {
            let point = rng.random_range(0..points_world.len());
            if let Some(pixel) = pixel_from_world(&CAMERA, pose, &points_world[point])
                && (0.0..1280.0).contains(&pixel[0])
                && (0.0..960.0).contains(&pixel[1])
            {
                observations.push(Observation { image, point, pixel });
                seen += 1;
            }
        }
    }
    Problem {
        cameras: vec![CAMERA],
        image_camera: vec![0; FRAMES],
        image_fixed: vec![false; FRAMES],
        images,
        point_fixed: vec![true; points_world.len()],
        points_world,
        observations,
        priors: Vec::new(),
        held_intrinsics: Vec::new(),
    }
}

/// RMS over the interior frames of the second difference of the centre errors.
fn centre_jitter(estimate: &Problem, truth: &Problem) -> f64 {
    let error = |t: usize| estimate.images[t].center() - truth.images[t].center();
    let sum: f64 = (1..FRAMES - 1).map(|t| (error(t + 1) - 2.0 * error(t) + error(t - 1)).norm_squared()).sum();
    (sum / (FRAMES - 2) as f64).sqrt()
}

/// Same for the angle-axis vectors.
fn rotation_jitter(estimate: &Problem, truth: &Problem) -> f64 {
    let error = |t: usize| estimate.images[t].angle_axis() - truth.images[t].angle_axis();
    let sum: f64 = (1..FRAMES - 1).map(|t| (error(t + 1) - 2.0 * error(t) + error(t - 1)).norm_squared()).sum();
    (sum / (FRAMES - 2) as f64).sqrt()
}

#[test]
fn smoothness_priors_reduce_pose_jitter() {
    let truth = smooth_sequence(31);
    let mut noisy = truth.clone();
    add_pixel_noise(&mut noisy, 2.0, 32);
    let options = Options { loss: Loss::Squared, refine_focal: false, refine_distortion: false, ..Options::default() };

    let mut without = noisy.clone();
    solve(&mut without, &options).expect("solves");
    let mut with = noisy.clone();
    with.priors = (1..FRAMES).map(|t| SmoothnessPrior { image_a: t - 1, image_b: t, weight_center: 2e5, weight_rotation: 2e7 }).collect();
    let report = solve(&mut with, &options).expect("solves");
    assert!(report.final_cost < report.initial_cost);

    let (jitter_without, jitter_with) = (centre_jitter(&without, &truth), centre_jitter(&with, &truth));
    let (turn_without, turn_with) = (rotation_jitter(&without, &truth), rotation_jitter(&with, &truth));
    println!("centre jitter {jitter_without:.2e} -> {jitter_with:.2e}, rotation jitter {turn_without:.2e} -> {turn_with:.2e}");
    assert!(jitter_with < 0.5 * jitter_without, "centre jitter {jitter_with} with priors vs {jitter_without} without");
    assert!(turn_with < 0.5 * turn_without, "rotation jitter {turn_with} with priors vs {turn_without} without");
}

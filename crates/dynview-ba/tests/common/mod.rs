//! Synthetic scenes for the tests and the `ba_scale` example.
#![allow(dead_code)]

use dynview_ba::{Observation, Problem, pixel_from_world};
use dynview_camera::{Radial, Rigid3};
use nalgebra::{Rotation3, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng, rngs::SmallRng};
use rand_distr::{Distribution, Normal};

/// The camera used by the synthetic scenes.
pub const CAMERA: Radial = Radial { f: 800.0, cx: 640.0, cy: 480.0, k1: -0.08, k2: 0.02 };

/// Seeded generator for reproducible tests.
pub fn rng(seed: u64) -> SmallRng {
    SmallRng::seed_from_u64(seed)
}

/// The pose of a camera at `center_world` looking at `target_world`, image y pointing down
/// towards world -z.
pub fn look_at(center_world: Vector3<f64>, target_world: Vector3<f64>) -> Rigid3 {
    let forward = (target_world - center_world).normalize();
    let down = Vector3::new(0.0, 0.0, -1.0);
    let right = down.cross(&forward).normalize();
    let down = forward.cross(&right);
    let camera_from_world = nalgebra::Matrix3::from_rows(&[right.transpose(), down.transpose(), forward.transpose()]);
    Rigid3::from_rotation_center(camera_from_world, center_world)
}

/// Adds `delta_angle_axis` (radians) to a pose's rotation as an angle-axis vector and
/// `delta_center` to its centre.
pub fn moved(pose: &Rigid3, delta_angle_axis: Vector3<f64>, delta_center: Vector3<f64>) -> Rigid3 {
    Rigid3::from_angle_axis_center(pose.angle_axis() + delta_angle_axis, pose.center() + delta_center)
}

/// `images` cameras on a circle of radius 8 around the origin, looking at it, and `points`
/// points in a ball of radius 2.5 at the origin, each observed by every image (noise-free).
/// Images 0 and 1 are fixed, which fixes the gauge.
pub fn inward_ring(images: usize, points: usize, seed: u64) -> Problem {
    let mut rng = rng(seed);
    let poses: Vec<Rigid3> = (0..images)
        .map(|i| {
            let angle = std::f64::consts::TAU * i as f64 / images as f64;
            let height = 0.5 * (3.0 * angle).sin();
            look_at(Vector3::new(8.0 * angle.cos(), 8.0 * angle.sin(), height), Vector3::zeros())
        })
        .collect();
    let points_world: Vec<[f64; 3]> = (0..points)
        .map(|_| {
            loop {
                let p = Vector3::new(rng.random_range(-2.5..2.5), rng.random_range(-2.5..2.5), rng.random_range(-2.5..2.5));
                if p.norm() <= 2.5 {
                    break p.into();
                }
            }
        })
        .collect();
    let mut observations = Vec::new();
    for (point, p) in points_world.iter().enumerate() {
        for (image, pose) in poses.iter().enumerate() {
            if let Some(pixel) = pixel_from_world(&CAMERA, pose, p) {
                observations.push(Observation { image, point, pixel });
            }
        }
    }
    problem_with_two_fixed_images(poses, points_world, observations)
}

/// `images` cameras on a circle of radius 10 looking outwards at a wall of `points` points at
/// radius 25-40; each point is observed by a run of 4 to 9 neighbouring images (mean track
/// length 6.5, like keyframe SfM). Images 0 and 1 are fixed.
pub fn outward_ring(images: usize, points: usize, seed: u64) -> Problem {
    let mut rng = rng(seed);
    let step = std::f64::consts::TAU / images as f64;
    let poses: Vec<Rigid3> = (0..images)
        .map(|i| {
            let angle = step * i as f64;
            let center = Vector3::new(10.0 * angle.cos(), 10.0 * angle.sin(), 0.3 * (5.0 * angle).sin());
            look_at(center, center * 3.0 + Vector3::new(0.0, 0.0, 0.5 * (7.0 * angle).cos()))
        })
        .collect();
    let mut points_world = Vec::with_capacity(points);
    let mut observations = Vec::new();
    for point in 0..points {
        let track = rng.random_range(4..=9usize);
        let first = rng.random_range(0..images);
        // The point lies in front of the middle of its track.
        let angle = step * (first as f64 + (track as f64 - 1.0) / 2.0) + rng.random_range(-0.5..0.5) * step;
        let radius = rng.random_range(25.0..40.0);
        let p = [radius * angle.cos(), radius * angle.sin(), rng.random_range(-8.0..8.0)];
        for offset in 0..track {
            let image = (first + offset) % images;
            if let Some(pixel) = pixel_from_world(&CAMERA, &poses[image], &p) {
                observations.push(Observation { image, point, pixel });
            }
        }
        points_world.push(p);
    }
    problem_with_two_fixed_images(poses, points_world, observations)
}

/// Standard deviations of a perturbation of the unknowns.
pub struct Perturbation {
    /// Angle-axis noise, radians.
    pub rotation_rad: f64,
    /// Centre noise, world units.
    pub center: f64,
    /// Point noise, world units.
    pub point: f64,
    /// Relative focal error (a fixed factor `1 + focal_relative`).
    pub focal_relative: f64,
}

/// Adds Gaussian noise to free poses and points and scales the focal lengths.
pub fn perturb(problem: &mut Problem, perturbation: &Perturbation, seed: u64) {
    let mut rng = rng(seed);
    let mut gaussian = |sigma: f64| if sigma > 0.0 { Normal::new(0.0, sigma).expect("valid sigma").sample(&mut rng) } else { 0.0 };
    for (pose, &fixed) in problem.images.iter_mut().zip(&problem.image_fixed) {
        if !fixed {
            let (mut rotation, mut center) = (Vector3::zeros(), Vector3::zeros());
            for axis in 0..3 {
                rotation[axis] = gaussian(perturbation.rotation_rad);
                center[axis] = gaussian(perturbation.center);
            }
            *pose = moved(pose, rotation, center);
        }
    }
    for (point, &fixed) in problem.points_world.iter_mut().zip(&problem.point_fixed) {
        if !fixed {
            for value in point.iter_mut() {
                *value += gaussian(perturbation.point);
            }
        }
    }
    for camera in &mut problem.cameras {
        camera.f *= 1.0 + perturbation.focal_relative;
    }
}

/// Adds Gaussian pixel noise to every observation.
pub fn add_pixel_noise(problem: &mut Problem, sigma_px: f64, seed: u64) {
    let mut rng = rng(seed);
    let normal = Normal::new(0.0, sigma_px).expect("valid sigma");
    for observation in &mut problem.observations {
        observation.pixel[0] += normal.sample(&mut rng);
        observation.pixel[1] += normal.sample(&mut rng);
    }
}

/// Moves a fraction of the observations by 20 to 100 pixels in a random direction (gross outliers).
pub fn add_outliers(problem: &mut Problem, fraction: f64, seed: u64) -> usize {
    let mut rng = rng(seed);
    let mut count = 0;
    for observation in &mut problem.observations {
        if rng.random_bool(fraction) {
            let angle = rng.random_range(0.0..std::f64::consts::TAU);
            let distance = rng.random_range(20.0..100.0);
            observation.pixel[0] += distance * angle.cos();
            observation.pixel[1] += distance * angle.sin();
            count += 1;
        }
    }
    count
}

/// Mean rotation error (radians) and mean centre error over the images, against the truth.
pub fn pose_errors(estimate: &[Rigid3], truth: &[Rigid3]) -> (f64, f64) {
    let mut rotation = 0.0;
    let mut center = 0.0;
    for (e, t) in estimate.iter().zip(truth) {
        let re = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(e.rotation_matrix()));
        let rt = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(t.rotation_matrix()));
        rotation += re.angle_to(&rt);
        center += (e.center() - t.center()).norm();
    }
    (rotation / estimate.len() as f64, center / estimate.len() as f64)
}

/// A problem with one camera ([`CAMERA`]) for every image and images 0 and 1 fixed (the gauge).
fn problem_with_two_fixed_images(poses: Vec<Rigid3>, points_world: Vec<[f64; 3]>, observations: Vec<Observation>) -> Problem {
    let (images, points) = (poses.len(), points_world.len());
    let mut image_fixed = vec![false; images];
    image_fixed[0] = true;
    image_fixed[1] = true;
    Problem {
        cameras: vec![CAMERA],
        image_camera: vec![0; images],
        image_fixed,
        images: poses,
        point_fixed: vec![false; points],
        points_world,
        observations,
        priors: Vec::new(),
        held_intrinsics: Vec::new(),
    }
}

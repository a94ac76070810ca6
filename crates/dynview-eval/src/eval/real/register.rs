//! Test-view registration: the held-out camera's pose refined against a frozen package before
//! it is scored, the protocol of methods that find their own poses (the test view's pose is
//! optimized photometrically with the reconstruction held fixed, as NoPe-NeRF, CF-3DGS and
//! InstantSplat evaluate). A package from our own structure from motion lives in a world that
//! matches the calibration's only up to small distortions (focal lengths and principal points a
//! little off move every point a little); a similarity fitted on the input cameras maps the
//! held-out camera close to, but not onto, the pose from which that world looks like its frames.
//!
//! Six degrees of freedom against every pixel of a few time steps: the correction
//! `camera_new_from_camera` (a small rotation and a shift in the camera's own frame) that
//! minimizes the colour-corrected squared error of the full method's render, found by a pattern
//! search (the render is not smooth in the pose, so no derivatives). The intrinsics stay the
//! calibration's. The whole frame, not its static pixels alone: where a world is a little
//! distorted no pose shows the background and the people both in place, and the static pixels
//! alone pay the people for the background (arc 1 cam11 from our own poses: +0.24 dB against
//! +0.39 for the whole frame).

use anyhow::Context;
use dynview_core::Camera;
use dynview_core::metrics::mse_masked;
use dynview_core::render::{Method, RenderHooks, RenderParams, StreamingRenderer, TimeStepInputs};
use dynview_core::rotation::matrix_from_angle_axis;
use dynview_core::scene::ScenePackage;
use dynview_core::{RgbRaster, Rigid3};
use glam::DVec3;

use super::scores::color_corrected;
use crate::align::Similarity3;

/// Time steps rendered for each trial pose.
const SAMPLE_STEPS: u32 = 3;
/// First rotation step of the search, radians (0.1 degrees).
const FIRST_ROTATION_STEP_RAD: f64 = 0.1 * std::f64::consts::PI / 180.0;
/// First shift step, as a share of the distance to the scene's middle.
const FIRST_SHIFT_SHARE: f64 = 0.002;
/// The search halves its steps this many times after the first.
const HALVINGS: u32 = 4;
/// Most moves along one direction in a row before the next direction is tried.
const MOST_MOVES_IN_A_ROW: u32 = 6;
/// The search sweeps no more once it has rendered this many poses (each at every sample; a
/// sweep renders at most 72 more); a search of the Panoptic arcs renders 73-130.
const MOST_TRIALS: usize = 400;

/// One time step the search renders: the camera as mapped and the real frame.
struct Sample {
    /// The held-out camera at this step, in the package's world, before the correction.
    camera: Camera,
    /// The package's inputs at this step.
    inputs: TimeStepInputs,
    /// The held-out camera's real frame.
    truth: RgbRaster,
}

/// The correction found and what it changed.
#[derive(Clone, Copy, Debug)]
pub struct Registration {
    /// The corrected camera from the camera as mapped.
    pub camera_new_from_camera: Rigid3,
    /// Colour-corrected PSNR of the samples, before and after, dB.
    pub psnr_db: [f64; 2],
    /// Poses rendered.
    pub trials: usize,
}

impl Registration {
    /// No correction.
    pub const NONE: Self =
        Self { camera_new_from_camera: Rigid3 { rotation: glam::DMat3::IDENTITY, translation: DVec3::ZERO }, psnr_db: [0.0; 2], trials: 0 };

    /// The rotation of the correction, degrees.
    pub fn rotation_deg(&self) -> f64 {
        dynview_core::rotation::angle_axis_from_matrix(self.camera_new_from_camera.rotation).length().to_degrees()
    }

    /// `camera_from_world` corrected.
    pub fn apply(&self, camera_from_world: &Rigid3) -> Rigid3 {
        self.camera_new_from_camera.compose(camera_from_world)
    }
}

/// Where the held-out camera's calibrated pose goes in a package's world: through the similarity
/// from the calibration's world, then the registration's correction.
#[derive(Clone, Copy, Debug)]
pub struct HeldOutPose {
    /// The package's world from the calibration's.
    pub package_from_reference: Similarity3,
    /// The correction found against the package ([`Registration::NONE`] for none).
    pub registration: Registration,
}

impl HeldOutPose {
    /// The calibrated pose as it is (a package in the calibration's world, no correction).
    pub const CALIBRATED: Self = Self { package_from_reference: Similarity3::IDENTITY, registration: Registration::NONE };

    /// The held-out camera's `camera_from_world` in the package's world.
    pub fn camera_from_world(&self, camera_from_reference: &Rigid3) -> Rigid3 {
        self.registration.apply(&self.package_from_reference.transform_camera_from_world(camera_from_reference))
    }
}

/// Registers camera `k` of `reference` against `package`, starting from its calibrated pose
/// mapped through `package_from_reference`, over the package's time steps `scored` (the
/// reference's step of the same moment is `reference_shift` later).
pub(super) fn register_held_out(
    reference: &ScenePackage,
    k: usize,
    package: &ScenePackage,
    params: &RenderParams,
    scored: std::ops::Range<u32>,
    reference_shift: u32,
    package_from_reference: Similarity3,
) -> anyhow::Result<HeldOutPose> {
    let mut samples = Vec::new();
    for t in sample_steps(scored) {
        let truth = RgbRaster::from_rgb8(&reference.read_frame(k, t + reference_shift)?.to_rgb8());
        let mut camera = reference.camera(k, t + reference_shift)?;
        camera.camera_from_world = package_from_reference.transform_camera_from_world(&camera.camera_from_world);
        samples.push(Sample { camera, inputs: inputs_at(package, t, params)?, truth });
    }
    let registration = register(&samples, params)?;
    Ok(HeldOutPose { package_from_reference, registration })
}

/// The steps of `scored` the search renders: [`SAMPLE_STEPS`] spread over them.
fn sample_steps(scored: std::ops::Range<u32>) -> Vec<u32> {
    let n = scored.len() as u32;
    (0..SAMPLE_STEPS.min(n)).map(|i| scored.start + (2 * i + 1) * n / (2 * SAMPLE_STEPS.min(n))).collect()
}

/// The package's inputs at step `t` (for [`Sample::inputs`]).
fn inputs_at(package: &ScenePackage, t: u32, params: &RenderParams) -> anyhow::Result<TimeStepInputs> {
    package.time_step_inputs(t, params.levels).with_context(|| format!("{}: time step {t}", package.root().display()))
}

/// Searches the correction of the held-out camera that best shows its frames.
fn register(samples: &[Sample], defaults: &RenderParams) -> anyhow::Result<Registration> {
    let Some(first) = samples.first() else { anyhow::bail!("registration without a time step") };
    let params = RenderParams { method: Method::Full, ..defaults.clone() };
    let distance = scene_distance(first);
    let trials = std::cell::Cell::new(0usize);
    let cost = |x: &[f64; 6]| -> anyhow::Result<f64> {
        trials.set(trials.get() + 1);
        let correction = correction_from(x);
        let mut sum = 0.0;
        for s in samples {
            let mut camera = s.camera;
            camera.camera_from_world = correction.compose(&s.camera.camera_from_world);
            let out = StreamingRenderer::new().render(&params, &camera, &s.inputs, &mut RenderHooks::default())?;
            sum += mse_masked(&color_corrected(&out.color, &s.truth), &s.truth, None);
        }
        Ok(sum / samples.len() as f64)
    };
    let shift_step = FIRST_SHIFT_SHARE * distance;
    let steps0 = [FIRST_ROTATION_STEP_RAD, FIRST_ROTATION_STEP_RAD, FIRST_ROTATION_STEP_RAD, shift_step, shift_step, shift_step];
    let mut x = [0.0f64; 6];
    let before = cost(&x)?;
    let mut best = before;
    for halving in 0..=HALVINGS {
        let scale = 0.5f64.powi(halving as i32);
        loop {
            let mut moved = false;
            for d in 0..6 {
                for sign in [1.0, -1.0] {
                    let mut in_a_row = 0;
                    loop {
                        let mut trial = x;
                        trial[d] += sign * steps0[d] * scale;
                        let c = cost(&trial)?;
                        if c < best {
                            (x, best, moved) = (trial, c, true);
                            in_a_row += 1;
                            if in_a_row < MOST_MOVES_IN_A_ROW {
                                continue;
                            }
                        }
                        break;
                    }
                    if in_a_row > 0 {
                        break;
                    }
                }
            }
            if !moved || trials.get() >= MOST_TRIALS {
                break;
            }
        }
    }
    let psnr = |mse: f64| -10.0 * mse.max(1e-12).log10();
    Ok(Registration { camera_new_from_camera: correction_from(&x), psnr_db: [psnr(before), psnr(best)], trials: trials.get() })
}

/// The correction of search coordinates `x`: a rotation vector (radians) and a shift.
fn correction_from(x: &[f64; 6]) -> Rigid3 {
    Rigid3::new(matrix_from_angle_axis(DVec3::new(x[0], x[1], x[2])), DVec3::new(x[3], x[4], x[5]))
}

/// How far the camera is from what it shows: the median depth of the sample's cloud in front of
/// it (1 when it sees none).
fn scene_distance(sample: &Sample) -> f64 {
    let pose = &sample.camera.camera_from_world;
    let mut depths: Vec<f64> = sample
        .inputs
        .cloud
        .positions_world
        .iter()
        .map(|p| pose.transform_point(DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]))).z)
        .filter(|z| z.is_finite() && *z > 0.0)
        .collect();
    if depths.is_empty() {
        return 1.0;
    }
    let middle = depths.len() / 2;
    *depths.select_nth_unstable_by(middle, f64::total_cmp).1
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sampled_steps_are_spread_over_the_scored_ones() {
        assert_eq!(sample_steps(0..75), vec![12, 37, 62]);
        assert_eq!(sample_steps(10..12), vec![10, 11]);
        assert!(sample_steps(5..5).is_empty());
    }

    #[test]
    fn a_correction_composes_in_the_cameras_frame() {
        let registration = Registration { camera_new_from_camera: correction_from(&[0.0, 0.0, 0.0, 0.5, 0.0, 0.0]), ..Registration::NONE };
        let pose = Rigid3::new(matrix_from_angle_axis(DVec3::new(0.0, 0.3, 0.0)), DVec3::new(1.0, 2.0, 3.0));
        let p = DVec3::new(0.2, -0.4, 5.0);
        let moved = registration.apply(&pose).transform_point(p);
        assert!((moved - (pose.transform_point(p) + DVec3::new(0.5, 0.0, 0.0))).length() < 1e-12);
        assert!(registration.rotation_deg().abs() < 1e-12);
    }

    /// A floor at y = -1 and a wall at z = -3, textured finely enough that a pixel's shift shows.
    fn hit(center: DVec3, direction: DVec3) -> Option<DVec3> {
        let floor = (direction.y < 0.0).then(|| (-1.0 - center.y) / direction.y);
        let wall = (direction.z < 0.0).then(|| (-3.0 - center.z) / direction.z);
        let t = match (floor, wall) {
            (Some(a), Some(b)) => a.min(b),
            (a, b) => a.or(b)?,
        };
        Some(center + direction * t)
    }

    fn texture(p: DVec3) -> [f32; 3] {
        let (u, v) = (p.x, if p.y <= -0.999 { p.z } else { p.y });
        let wave = |x: f64| (0.5 + 0.4 * x.sin()) as f32;
        [wave(6.0 * u), wave(5.0 * v + 1.0), wave(4.0 * u + 4.0 * v)]
    }

    fn camera_at(eye: DVec3) -> Camera {
        let (w, h) = (160, 120);
        Camera {
            intrinsics: dynview_core::Intrinsics::from_vertical_fov(0.9, w, h),
            camera_from_world: Rigid3::camera_from_world_looking_at(eye, DVec3::new(0.0, -0.5, 0.0), DVec3::Y),
            width_px: w,
            height_px: h,
        }
    }

    /// What `camera` sees, and the points it sees at every other pixel.
    fn ray_cast(camera: &Camera) -> (RgbRaster, Vec<DVec3>) {
        let (w, h) = (camera.width_px as usize, camera.height_px as usize);
        let center = camera.center_world();
        let mut color = RgbRaster::filled(w, h, [0.0; 3]);
        let mut points = Vec::new();
        for (i, c) in color.data.iter_mut().enumerate() {
            let pixel = glam::DVec2::new((i % w) as f64 + 0.5, (i / w) as f64 + 0.5);
            if let Some(p) = hit(center, camera.unproject_world(pixel, 1.0) - center) {
                *c = texture(p);
                if (i % w) % 2 == 0 && (i / w) % 2 == 0 {
                    points.push(p);
                }
            }
        }
        (color, points)
    }

    #[test]
    fn registration_brings_a_turned_and_shifted_camera_back_to_where_its_frame_was_seen_from() {
        let mut cloud = dynview_core::points::PointCloud::default();
        let views: Vec<_> = [DVec3::new(-1.0, 0.3, 4.0), DVec3::new(1.2, 0.4, 4.2), DVec3::new(0.1, 1.0, 4.5)]
            .into_iter()
            .map(|eye| {
                let camera = camera_at(eye);
                let (color, points) = ray_cast(&camera);
                for p in points {
                    cloud.positions_world.push([p.x as f32, p.y as f32, p.z as f32]);
                    cloud.colors.push(texture(p).map(|v| (v * 255.0).round() as u8));
                }
                dynview_core::render::InputView::new(camera, color, 3)
            })
            .collect();
        let inputs = TimeStepInputs { cloud, views, static_points: 0 };
        let truth_camera = camera_at(DVec3::new(0.3, 0.5, 4.3));
        let truth = ray_cast(&truth_camera).0;
        // Off by 0.6 degrees and 2 cm, about a pixel and a half at this size.
        let off = correction_from(&[0.004, -0.008, 0.002, 0.02, -0.01, 0.0]);
        let mut camera = truth_camera;
        camera.camera_from_world = off.compose(&truth_camera.camera_from_world);
        let angle_to_truth =
            |pose: &Rigid3| dynview_core::rotation::relative_angle_rad(pose.rotation, truth_camera.camera_from_world.rotation).to_degrees();
        let params = RenderParams { levels: 3, ..RenderParams::default() };
        // From the true pose the search stays near it, and shows the frame at least as well.
        let at_truth = register(&[Sample { camera: truth_camera, inputs: inputs.clone(), truth: truth.clone() }], &params).unwrap();
        assert!(at_truth.rotation_deg() < 0.1, "moved {:.3} degrees off the true pose", at_truth.rotation_deg());
        assert!(at_truth.psnr_db[1] >= at_truth.psnr_db[0], "{:?}", at_truth.psnr_db);
        let registration = register(&[Sample { camera, inputs, truth }], &params).unwrap();
        let corrected = registration.apply(&camera.camera_from_world);
        let (before, after) = (angle_to_truth(&camera.camera_from_world), angle_to_truth(&corrected));
        let [psnr_before, psnr_after] = registration.psnr_db;
        // A turn about the vertical and a sideways shift look nearly alike from here: the frame
        // is matched closely, the pose as closely as that allows.
        assert!(after < before / 2.0, "{before:.3} -> {after:.3} degrees");
        assert!(
            psnr_after > at_truth.psnr_db[0] && psnr_after > psnr_before + 6.0,
            "{psnr_before:.2} -> {psnr_after:.2} dB, at the truth {:.2}",
            at_truth.psnr_db[0]
        );
    }
}

//! Checks of the assembled normal equations and the Schur step against dense references built
//! from central-difference Jacobians.

use nalgebra::{DMatrix, DVector, Vector3};

use super::cost::evaluate_cost;
use super::layout::Layout;
use super::linearize::linearize;
use super::parameters::Parameters;
use super::step::compute_step;
use crate::loss::Loss;
use crate::options::Options;
use dynview_camera::{Radial, Rigid3};

use crate::pose::PoseParameters;
use crate::problem::{Observation, Problem, SmoothnessPrior};
use crate::projection::{ImageFrame, pixel_from_camera, pixel_from_world};

const STEP: f64 = 1e-6;

/// A small problem with every kind of block: two cameras, fixed and free images and points,
/// an unobserved point, an image known only through priors, and an observation behind its camera.
fn small_problem() -> Problem {
    let cameras = vec![
        Radial { f: 520.0, cx: 320.0, cy: 240.0, k1: -0.05, k2: 0.01 },
        Radial { f: 610.0, cx: 300.0, cy: 250.0, k1: 0.02, k2: -0.003 },
    ];
    let images: Vec<Rigid3> = (0..5)
        .map(|i| {
            let t = i as f64;
            PoseParameters { angle_axis: [0.02 * t, -0.1 + 0.05 * t, 0.01], center_world: [0.4 * t - 0.8, 0.1 * t, -5.0 + 0.05 * t] }
                .to_rigid()
        })
        .collect();
    let points_world: Vec<[f64; 3]> = (0..12)
        .map(|j| {
            let s = j as f64;
            [(s * 0.7).sin() * 1.5, (s * 1.3).cos(), 1.0 + 0.3 * (s * 0.4).sin()]
        })
        .collect();
    let image_camera = vec![0, 0, 0, 1, 0];
    let mut observations = Vec::new();
    for image in 0..4 {
        for (point, p) in points_world.iter().enumerate().take(11) {
            if (image + point) % 5 == 4 {
                continue;
            }
            let pixel = pixel_from_world(&cameras[image_camera[image]], &images[image], p).expect("in front");
            // Perturb so the residuals are non-zero (and some large, where the loss matters).
            let offset = [((image * 7 + point * 3) % 11) as f64 - 5.0, ((image * 5 + point * 2) % 9) as f64 - 4.0];
            observations.push(Observation { image, point, pixel: [pixel[0] + offset[0], pixel[1] + offset[1]] });
        }
    }
    // A point behind image 1: left out of the solve.
    let mut points_world = points_world;
    points_world.push([0.0, 0.0, -20.0]);
    observations.push(Observation { image: 1, point: 12, pixel: [100.0, 100.0] });
    let mut image_fixed = vec![false; 5];
    image_fixed[0] = true;
    let mut point_fixed = vec![false; points_world.len()];
    point_fixed[2] = true;
    point_fixed[5] = true;
    let priors = vec![
        SmoothnessPrior { image_a: 0, image_b: 1, weight_center: 40.0, weight_rotation: 900.0 },
        SmoothnessPrior { image_a: 1, image_b: 2, weight_center: 25.0, weight_rotation: 400.0 },
        SmoothnessPrior { image_a: 3, image_b: 4, weight_center: 10.0, weight_rotation: 100.0 },
        SmoothnessPrior { image_a: 2, image_b: 2, weight_center: 10.0, weight_rotation: 100.0 },
    ];
    Problem { cameras, images, image_camera, image_fixed, points_world, point_fixed, observations, priors, held_intrinsics: Vec::new() }
}

fn all_free_options(loss: Loss) -> Options {
    Options { loss, refine_focal: true, refine_principal_point: true, refine_distortion: true, ..Options::default() }
}

/// Splits a stacked unknown vector (camera side, then 3 per free point group) into a step.
fn split(layout: &Layout, x: &DVector<f64>) -> (Vec<f64>, Vec<Vector3<f64>>) {
    let camera = x.as_slice()[..layout.camera_unknowns()].to_vec();
    let mut next = layout.camera_unknowns();
    let points = layout
        .groups
        .iter()
        .map(|group| {
            if !group.free {
                return Vector3::zeros();
            }
            next += 3;
            Vector3::new(x[next - 3], x[next - 2], x[next - 1])
        })
        .collect();
    (camera, points)
}

fn stack(layout: &Layout, camera: &[f64], points: &[Vector3<f64>]) -> DVector<f64> {
    let mut values = camera.to_vec();
    for (group, point) in layout.groups.iter().zip(points).filter(|(g, _)| g.free) {
        debug_assert!(group.free);
        values.extend(point.iter());
    }
    DVector::from_vec(values)
}

/// The IRLS residual vector with the robust weights frozen at `weights_at`.
fn weighted_residuals(layout: &Layout, problem: &Problem, parameters: &Parameters, weights_at: &Parameters, loss: &Loss) -> DVector<f64> {
    let frames: Vec<ImageFrame> = parameters.images.iter().map(ImageFrame::new).collect();
    let base_frames: Vec<ImageFrame> = weights_at.images.iter().map(ImageFrame::new).collect();
    let mut residuals = Vec::new();
    for o in &layout.observations {
        let project = |frames: &[ImageFrame], p: &Parameters| {
            pixel_from_camera(&p.cameras[o.camera], &frames[o.image].point_camera(&Vector3::from(p.points_world[o.point])))
                .expect("in front")
                - o.pixel
        };
        let weight = loss.evaluate(project(&base_frames, weights_at).norm_squared()).1.sqrt();
        let r = project(&frames, parameters) * weight;
        residuals.extend([r.x, r.y]);
    }
    for prior in &problem.priors {
        let (a, b) = (&parameters.images[prior.image_a], &parameters.images[prior.image_b]);
        for axis in 0..3 {
            residuals.push(prior.weight_rotation.sqrt() * (a.angle_axis[axis] - b.angle_axis[axis]));
        }
        for axis in 0..3 {
            residuals.push(prior.weight_center.sqrt() * (a.center_world[axis] - b.center_world[axis]));
        }
    }
    DVector::from_vec(residuals)
}

fn numeric_jacobian(layout: &Layout, problem: &Problem, parameters: &Parameters, loss: &Loss) -> DMatrix<f64> {
    let unknowns = layout.camera_unknowns() + 3 * layout.free_points;
    let base = weighted_residuals(layout, problem, parameters, parameters, loss);
    let mut jacobian = DMatrix::zeros(base.len(), unknowns);
    for column in 0..unknowns {
        let mut delta = DVector::zeros(unknowns);
        delta[column] = STEP;
        let (camera, points) = split(layout, &delta);
        let plus = parameters.stepped(layout, &camera, &points);
        let (camera, points) = split(layout, &-delta);
        let minus = parameters.stepped(layout, &camera, &points);
        let difference =
            weighted_residuals(layout, problem, &plus, parameters, loss) - weighted_residuals(layout, problem, &minus, parameters, loss);
        jacobian.set_column(column, &(difference / (2.0 * STEP)));
    }
    jacobian
}

#[test]
fn layout_counts_unknowns() {
    let problem = small_problem();
    let layout = Layout::new(&problem, &all_free_options(Loss::Squared));
    // Images 1-4 free (image 4 only through a prior), cameras 0 and 1 observed: 4*6 + 2*5.
    assert_eq!(layout.camera_unknowns(), 34);
    // Points 0-10 observed, 2 and 5 fixed, 11 unobserved, 12 only behind the camera.
    assert_eq!(layout.free_points, 9);
    assert_eq!(layout.excluded_observations, 1);
}

#[test]
fn gradient_matches_central_differences_of_the_robust_cost() {
    let problem = small_problem();
    for loss in [Loss::Squared, Loss::Huber { scale_px: 2.0 }, Loss::Cauchy { scale_px: 1.5 }] {
        let layout = Layout::new(&problem, &all_free_options(loss));
        let parameters = Parameters::from_problem(&problem);
        let linearization = linearize(&layout, &parameters, &problem.priors, &loss);
        let analytic = stack(&layout, &linearization.gradient_camera, &linearization.point_gradient);
        for column in 0..analytic.len() {
            let mut delta = DVector::zeros(analytic.len());
            delta[column] = STEP;
            let cost = |delta: &DVector<f64>| {
                let (camera, points) = split(&layout, delta);
                evaluate_cost(&layout, &parameters.stepped(&layout, &camera, &points), &problem.priors, &loss).expect("finite").cost
            };
            // The gradient of the cost is 2 J^T rho' r; the linearisation holds J^T rho' r.
            let numeric = (cost(&delta) - cost(&-delta)) / (4.0 * STEP);
            let tolerance = 1e-5 * analytic[column].abs().max(1.0);
            assert!(
                (numeric - analytic[column]).abs() < tolerance,
                "{loss:?} unknown {column}: numeric {numeric} analytic {}",
                analytic[column]
            );
        }
    }
}

#[test]
fn schur_step_matches_dense_damped_solve() {
    let problem = small_problem();
    for loss in [Loss::Squared, Loss::Cauchy { scale_px: 2.0 }] {
        let layout = Layout::new(&problem, &all_free_options(loss));
        let parameters = Parameters::from_problem(&problem);
        let linearization = linearize(&layout, &parameters, &problem.priors, &loss);
        let jacobian = numeric_jacobian(&layout, &problem, &parameters, &loss);
        let residuals = weighted_residuals(&layout, &problem, &parameters, &parameters, &loss);
        let hessian = jacobian.transpose() * &jacobian;
        let gradient = jacobian.transpose() * &residuals;
        for lambda in [1e-3, 1.0] {
            let mut damped = hessian.clone();
            for i in 0..damped.nrows() {
                damped[(i, i)] += lambda * hessian[(i, i)].clamp(1e-6, 1e32);
            }
            let reference = damped.cholesky().expect("definite").solve(&-&gradient);
            let step = compute_step(&layout, &linearization, lambda).expect("definite");
            let computed = stack(&layout, &step.delta_camera, &step.delta_points);
            let error = (&computed - &reference).norm();
            assert!(error < 1e-5 * reference.norm(), "{loss:?}, lambda {lambda}: error {error}, step norm {}", reference.norm());
            let model_decrease = -2.0 * gradient.dot(&reference) - reference.dot(&(&hessian * &reference));
            assert!(
                (step.model_decrease - model_decrease).abs() < 1e-5 * model_decrease.abs(),
                "{} vs {model_decrease}",
                step.model_decrease
            );
        }
    }
}

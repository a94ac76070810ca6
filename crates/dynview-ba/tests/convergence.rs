//! Convergence on synthetic scenes: noise-free recovery, monotone cost, poses-only problems.

mod common;

use common::{CAMERA, Perturbation, add_outliers, add_pixel_noise, inward_ring, perturb, pose_errors};
use dynview_ba::{Loss, Options, Termination, reprojection_errors_px, solve};

/// Tolerances tight enough to run to the floor of double precision.
fn tight(loss: Loss) -> Options {
    Options {
        loss,
        refine_focal: true,
        refine_principal_point: true,
        refine_distortion: true,
        max_iterations: 100,
        function_tolerance: 1e-15,
        gradient_tolerance: 1e-15,
        parameter_tolerance: 1e-15,
    }
}

fn assert_monotone(history: &[f64]) {
    for pair in history.windows(2) {
        assert!(pair[1] <= pair[0], "cost rose from {} to {}", pair[0], pair[1]);
    }
}

#[test]
fn noise_free_ring_recovers_poses_points_and_intrinsics() {
    let truth = inward_ring(20, 1000, 1);
    let mut problem = truth.clone();
    perturb(&mut problem, &Perturbation { rotation_rad: 0.01, center: 0.05, point: 0.05, focal_relative: 0.03 }, 2);
    problem.cameras[0].k1 = 0.0;
    problem.cameras[0].k2 = 0.0;
    problem.cameras[0].cx += 4.0;
    problem.cameras[0].cy -= 3.0;
    let report = solve(&mut problem, &tight(Loss::Squared)).expect("solves");
    println!("{report:?}");
    assert!(report.initial_rms_px > 10.0, "the perturbation should matter: {}", report.initial_rms_px);
    assert!(report.final_rms_px < 1e-6, "final RMS {} px", report.final_rms_px);
    assert_monotone(&report.cost_history);
    assert_eq!(report.camera_unknowns, 18 * 6 + 5);
    assert_eq!(report.point_unknowns, 3000);
    let camera = problem.cameras[0];
    assert!(((camera.f - CAMERA.f) / CAMERA.f).abs() < 1e-6, "focal {}", camera.f);
    assert!((camera.cx - CAMERA.cx).abs() < 1e-4 && (camera.cy - CAMERA.cy).abs() < 1e-4, "{camera:?}");
    assert!((camera.k1 - CAMERA.k1).abs() < 1e-6 && (camera.k2 - CAMERA.k2).abs() < 1e-6, "{camera:?}");
    let (rotation_error, center_error) = pose_errors(&problem.images, &truth.images);
    assert!(rotation_error < 1e-8 && center_error < 1e-7, "pose errors {rotation_error} rad, {center_error}");
    let max_point_error = problem
        .points_world
        .iter()
        .zip(&truth.points_world)
        .map(|(a, b)| a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>().sqrt())
        .fold(0.0, f64::max);
    assert!(max_point_error < 1e-6, "point error {max_point_error}");
    let errors = reprojection_errors_px(&problem);
    assert!(errors.iter().all(|&e| e < 1e-5));
}

#[test]
fn accepted_steps_never_raise_the_cost() {
    for loss in [Loss::Squared, Loss::Huber { scale_px: 2.0 }, Loss::Cauchy { scale_px: 1.0 }] {
        let mut problem = inward_ring(12, 300, 3);
        add_pixel_noise(&mut problem, 1.0, 4);
        add_outliers(&mut problem, 0.1, 5);
        perturb(&mut problem, &Perturbation { rotation_rad: 0.02, center: 0.1, point: 0.1, focal_relative: -0.05 }, 6);
        let report = solve(&mut problem, &Options { loss, ..Options::default() }).expect("solves");
        assert!(report.accepted_steps >= 2, "{loss:?}: {report:?}");
        assert_eq!(report.cost_history.len(), report.accepted_steps + 1);
        assert_eq!(report.cost_history[0], report.initial_cost);
        assert_eq!(*report.cost_history.last().expect("non-empty"), report.final_cost);
        assert!(report.final_cost < report.initial_cost);
        assert_monotone(&report.cost_history);
    }
}

#[test]
fn poses_only_problem_converges() {
    let truth = inward_ring(20, 200, 7);
    let mut problem = truth.clone();
    problem.point_fixed = vec![true; problem.points_world.len()];
    problem.image_fixed = vec![false; problem.images.len()];
    perturb(&mut problem, &Perturbation { rotation_rad: 0.02, center: 0.2, point: 0.0, focal_relative: 0.0 }, 8);
    let options = Options { refine_focal: false, refine_principal_point: false, refine_distortion: false, ..tight(Loss::Squared) };
    let report = solve(&mut problem, &options).expect("solves");
    assert_eq!(report.point_unknowns, 0);
    assert_eq!(report.camera_unknowns, 20 * 6);
    assert!(report.final_rms_px < 1e-6, "final RMS {}", report.final_rms_px);
    let (rotation_error, center_error) = pose_errors(&problem.images, &truth.images);
    assert!(rotation_error < 1e-9 && center_error < 1e-8, "pose errors {rotation_error}, {center_error}");
    assert_eq!(problem.points_world, truth.points_world);
}

#[test]
fn unobserved_points_fixed_everything_and_points_behind_cameras() {
    let truth = inward_ring(6, 50, 9);
    // An unobserved free point and an observation of a point behind its camera.
    let mut problem = truth.clone();
    problem.points_world.push([100.0, 0.0, 0.0]);
    problem.point_fixed.push(false);
    problem.points_world.push([20.0, 0.0, 0.0]);
    problem.point_fixed.push(false);
    problem.observations.push(dynview_ba::Observation { image: 0, point: 51, pixel: [0.0, 0.0] });
    let unobserved = problem.points_world[50];
    perturb(&mut problem, &Perturbation { rotation_rad: 0.01, center: 0.05, point: 0.02, focal_relative: 0.0 }, 10);
    let report = solve(&mut problem, &tight(Loss::Squared)).expect("solves");
    assert_eq!(report.excluded_observations, 1);
    assert!(report.final_rms_px < 1e-6, "{report:?}");
    assert_ne!(problem.points_world[50], unobserved, "perturbed");
    let errors = reprojection_errors_px(&problem);
    assert_eq!(*errors.last().expect("observations"), f64::INFINITY);

    // Everything fixed: nothing to do, nothing changes.
    let mut frozen = truth.clone();
    frozen.image_fixed = vec![true; frozen.images.len()];
    frozen.point_fixed = vec![true; frozen.points_world.len()];
    let options = Options { refine_focal: false, refine_distortion: false, ..Options::default() };
    let report = solve(&mut frozen, &options).expect("solves");
    assert_eq!(report.termination, Termination::NothingToOptimize);
    assert_eq!(report.iterations, 0);
    assert_eq!(frozen, truth_with_all_fixed(&truth));
}

fn truth_with_all_fixed(truth: &dynview_ba::Problem) -> dynview_ba::Problem {
    let mut fixed = truth.clone();
    fixed.image_fixed = vec![true; fixed.images.len()];
    fixed.point_fixed = vec![true; fixed.points_world.len()];
    fixed
}

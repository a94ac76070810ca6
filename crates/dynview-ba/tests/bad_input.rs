//! Bad input is refused with an error naming the field; the problem is left unchanged.

mod common;

use common::inward_ring;
use dynview_ba::{BaError, Loss, Observation, Options, Problem, SmoothnessPrior, solve};

fn refused(mut problem: Problem, options: &Options) -> BaError {
    let before = problem.clone();
    let error = solve(&mut problem, options).expect_err("bad input must be refused");
    // Compared through Debug so that NaN fields compare equal to themselves.
    assert!(format!("{problem:?}") == format!("{before:?}"), "a refused problem must be left unchanged");
    error
}

fn base() -> Problem {
    inward_ring(4, 800, 41)
}

#[test]
fn out_of_range_indices_name_the_field() {
    let mut problem = base();
    problem.observations[12].point = 900;
    let error = refused(problem, &Options::default());
    assert_eq!(error.to_string(), "observations[12].point = 900 but there are 800 points");

    let mut problem = base();
    problem.observations[3].image = 4;
    assert_eq!(refused(problem, &Options::default()).to_string(), "observations[3].image = 4 but there are 4 images");

    let mut problem = base();
    problem.image_camera[2] = 1;
    assert_eq!(refused(problem, &Options::default()).to_string(), "image_camera[2] = 1 but there are 1 cameras");

    let mut problem = base();
    problem.priors.push(SmoothnessPrior { image_a: 0, image_b: 7, weight_center: 1.0, weight_rotation: 1.0 });
    assert_eq!(refused(problem, &Options::default()).to_string(), "priors[0].image_b = 7 but there are 4 images");
}

#[test]
fn wrong_lengths_are_refused() {
    let mut problem = base();
    problem.image_fixed.pop();
    assert!(matches!(refused(problem, &Options::default()), BaError::LengthMismatch { field: "image_fixed", actual: 3, expected: 4, .. }));

    let mut problem = base();
    problem.point_fixed.push(true);
    assert!(matches!(refused(problem, &Options::default()), BaError::LengthMismatch { field: "point_fixed", .. }));

    let mut problem = base();
    problem.image_camera.clear();
    assert!(matches!(refused(problem, &Options::default()), BaError::LengthMismatch { field: "image_camera", .. }));
}

#[test]
fn non_finite_and_invalid_values_are_refused() {
    let mut problem = base();
    problem.points_world[5][1] = f64::NAN;
    assert_eq!(refused(problem, &Options::default()).to_string(), "points_world[5][1] is not finite (NaN)");

    let mut problem = base();
    problem.observations.push(Observation { image: 0, point: 0, pixel: [f64::INFINITY, 0.0] });
    let last = problem.observations.len() - 1;
    assert_eq!(refused(problem, &Options::default()).to_string(), format!("observations[{last}].pixel[0] is not finite (inf)"));

    let mut problem = base();
    problem.images[2].translation.x = f64::NEG_INFINITY;
    assert!(matches!(refused(problem, &Options::default()), BaError::NonFinite { field, .. } if field == "images[2].translation[0]"));

    let mut problem = base();
    problem.images[1].rotation.z_axis.x = f64::NAN;
    assert!(matches!(refused(problem, &Options::default()), BaError::NonFinite { field, .. } if field == "images[1].rotation[0][2]"));

    let mut problem = base();
    problem.cameras[0].k2 = f64::NAN;
    assert!(matches!(refused(problem, &Options::default()), BaError::NonFinite { field, .. } if field == "cameras[0].k2"));

    let mut problem = base();
    problem.cameras[0].f = -100.0;
    assert!(matches!(refused(problem, &Options::default()), BaError::InvalidValue { field, .. } if field == "cameras[0].f"));

    let mut problem = base();
    problem.priors.push(SmoothnessPrior { image_a: 0, image_b: 1, weight_center: -1.0, weight_rotation: 1.0 });
    assert!(matches!(refused(problem, &Options::default()), BaError::InvalidValue { field, .. } if field == "priors[0].weight_center"));
}

#[test]
fn invalid_options_are_refused() {
    for options in [
        Options { loss: Loss::Huber { scale_px: 0.0 }, ..Options::default() },
        Options { loss: Loss::Cauchy { scale_px: -1.0 }, ..Options::default() },
        Options { function_tolerance: f64::NAN, ..Options::default() },
        Options { parameter_tolerance: -1.0, ..Options::default() },
    ] {
        assert!(matches!(refused(base(), &options), BaError::InvalidValue { .. }), "{options:?}");
    }
}

#[test]
fn empty_and_degenerate_problems_do_not_fail() {
    let mut empty = Problem::default();
    let report = solve(&mut empty, &Options::default()).expect("an empty problem is fine");
    assert_eq!(report.iterations, 0);
    assert_eq!(report.final_rms_px, 0.0);

    // Images with priors but no observations; no points at all.
    let mut problem = base();
    problem.observations.clear();
    problem.image_fixed = vec![true, false, false, false];
    problem.priors = (1..4).map(|i| SmoothnessPrior { image_a: i - 1, image_b: i, weight_center: 1.0, weight_rotation: 1.0 }).collect();
    let report = solve(&mut problem, &Options::default()).expect("priors alone are fine");
    assert!(report.final_cost < 1e-6 * report.initial_cost, "{report:?}");
    assert_eq!(report.point_unknowns, 0);
}

//! Per-camera held intrinsics and the intrinsics' standard deviations.

mod common;

use common::{CAMERA, inward_ring, rng};
use dynview_ba::{BaError, HeldIntrinsics, Loss, Options, Problem, intrinsics_std, solve};
use rand_distr::{Distribution, Normal};

fn squared() -> Options {
    Options { loss: Loss::Squared, refine_distortion: false, ..Options::default() }
}

/// The ring with images 4.. filmed by a second camera of the same intrinsics.
fn two_cameras() -> Problem {
    let mut problem = inward_ring(8, 300, 7);
    problem.cameras.push(CAMERA);
    for camera in problem.image_camera.iter_mut().skip(4) {
        *camera = 1;
    }
    problem
}

#[test]
fn a_held_focal_stays_as_given_while_the_other_cameras_focal_is_refined() {
    let mut problem = two_cameras();
    problem.cameras[0].f *= 1.01;
    problem.cameras[1].f *= 1.03;
    problem.held_intrinsics = vec![HeldIntrinsics { focal: true, ..HeldIntrinsics::default() }, HeldIntrinsics::default()];
    let given = problem.cameras[0].f;
    let std = intrinsics_std(&problem, &squared(), 1.0).unwrap();
    assert_eq!(std[0].focal_px, None, "a held focal has no standard deviation");
    assert!(std[1].focal_px.is_some());
    solve(&mut problem, &squared()).unwrap();
    assert_eq!(problem.cameras[0].f, given, "the held focal changed");
    // The other camera's focal moves: on exact observations it settles where the held one's
    // (1% long) error puts the rest of the model, not where it started.
    let moved = problem.cameras[1].f / (1.03 * CAMERA.f) - 1.0;
    assert!(moved.abs() > 1e-3, "the free focal stayed at its start ({moved})");
}

#[test]
fn a_held_calibration_keeps_every_intrinsic() {
    let mut problem = two_cameras();
    problem.cameras[1].cx += 6.0;
    problem.held_intrinsics = vec![HeldIntrinsics::default(), HeldIntrinsics::ALL];
    let given = problem.cameras[1];
    let options = Options { loss: Loss::Squared, refine_principal_point: true, ..Options::default() };
    let std = intrinsics_std(&problem, &options, 1.0).unwrap();
    assert_eq!((std[1].focal_px, std[1].principal_point_px), (None, None));
    assert!(std[0].focal_px.is_some() && std[0].principal_point_px.is_some());
    solve(&mut problem, &options).unwrap();
    assert_eq!(problem.cameras[1], given);
}

#[test]
fn held_intrinsics_of_the_wrong_length_are_refused_by_name() {
    let mut problem = two_cameras();
    problem.held_intrinsics = vec![HeldIntrinsics::ALL];
    let error = solve(&mut problem, &squared()).unwrap_err();
    assert!(matches!(error, BaError::LengthMismatch { field: "held_intrinsics", .. }), "{error}");
}

/// The focal's standard deviation is what the focal actually scatters by when the same
/// problem is solved with fresh pixel noise.
#[test]
fn the_focal_standard_deviation_predicts_the_scatter_of_noisy_solves() {
    let truth = inward_ring(6, 80, 11);
    let noise_px = 0.5;
    let predicted = intrinsics_std(&truth, &squared(), noise_px).unwrap()[0].focal_px.unwrap();
    let normal = Normal::new(0.0, noise_px).unwrap();
    let mut rng = rng(5);
    let trials = 60;
    let focals: Vec<f64> = (0..trials)
        .map(|_| {
            let mut problem = truth.clone();
            for observation in &mut problem.observations {
                observation.pixel[0] += normal.sample(&mut rng);
                observation.pixel[1] += normal.sample(&mut rng);
            }
            solve(&mut problem, &squared()).unwrap();
            problem.cameras[0].f
        })
        .collect();
    let mean = focals.iter().sum::<f64>() / trials as f64;
    let scatter = (focals.iter().map(|f| (f - mean).powi(2)).sum::<f64>() / (trials - 1) as f64).sqrt();
    println!("focal: predicted std {predicted:.4} px, scatter over {trials} noisy solves {scatter:.4} px (mean {mean:.3})");
    // 60 samples give the scatter to about 9% (one standard deviation).
    assert!((0.7..1.4).contains(&(scatter / predicted)), "scatter {scatter} px against predicted {predicted} px");
}

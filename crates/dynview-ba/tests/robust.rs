//! Robust losses against gross outliers.

mod common;

use common::{Perturbation, add_outliers, add_pixel_noise, inward_ring, perturb, pose_errors};
use dynview_ba::{Loss, Options, solve};

#[test]
fn robust_losses_resist_outliers_that_ruin_least_squares() {
    let truth = inward_ring(20, 500, 21);
    let mut noisy = truth.clone();
    add_pixel_noise(&mut noisy, 1.0, 22);
    let outliers = add_outliers(&mut noisy, 0.1, 23);
    assert!(outliers > noisy.observations.len() / 20);
    perturb(&mut noisy, &Perturbation { rotation_rad: 0.01, center: 0.05, point: 0.05, focal_relative: 0.02 }, 24);

    let errors_with = |loss: Loss| {
        let mut problem = noisy.clone();
        let report = solve(&mut problem, &Options { loss, refine_distortion: false, ..Options::default() }).expect("solves");
        let (rotation, center) = pose_errors(&problem.images, &truth.images);
        let focal = (problem.cameras[0].f - truth.cameras[0].f).abs();
        println!(
            "{loss:?}: rotation {rotation:.2e} rad, centre {center:.2e}, focal {focal:.3} px, {} iterations, {:?}",
            report.iterations, report.termination
        );
        (rotation, center, focal)
    };
    let squared = errors_with(Loss::Squared);
    for loss in [Loss::Huber { scale_px: 2.0 }, Loss::Cauchy { scale_px: 1.0 }] {
        let robust = errors_with(loss);
        assert!(robust.0 < 0.25 * squared.0, "{loss:?}: rotation error {} vs least squares {}", robust.0, squared.0);
        assert!(robust.1 < 0.25 * squared.1, "{loss:?}: centre error {} vs least squares {}", robust.1, squared.1);
        assert!(robust.2 < 0.25 * squared.2, "{loss:?}: focal error {} vs least squares {}", robust.2, squared.2);
    }
}

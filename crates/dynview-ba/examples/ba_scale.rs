//! Times bundle adjustment on a keyframe-SfM-sized synthetic problem: 300 images on a ring
//! looking out at 30k points, each seen by 4-9 neighbouring images (~200k observations),
//! 0.5 px pixel noise, perturbed poses, points and focal length.
//!
//! `cargo run --release -p dynview-ba --example ba_scale [images] [points]`

#[path = "../tests/common/mod.rs"]
mod common;

use std::time::Instant;

use common::{Perturbation, add_pixel_noise, outward_ring, perturb, pose_errors};
use dynview_ba::{Options, solve};

fn main() {
    let mut arguments = std::env::args().skip(1).map(|a| a.parse::<usize>());
    let images = arguments.next().and_then(Result::ok).unwrap_or(300);
    let points = arguments.next().and_then(Result::ok).unwrap_or(30_000);
    let truth = outward_ring(images, points, 1);
    let mut problem = truth.clone();
    add_pixel_noise(&mut problem, 0.5, 2);
    perturb(&mut problem, &Perturbation { rotation_rad: 0.002, center: 0.05, point: 0.1, focal_relative: 0.01 }, 3);
    println!("{images} images, {points} points, {} observations", problem.observations.len());

    let options = Options::default();
    // The fixed cost of a solve (validation, ordering, the first evaluation and linearisation),
    // measured by a solve that stops before its first iteration.
    let start = Instant::now();
    if let Err(error) = solve(&mut problem.clone(), &Options { max_iterations: 0, ..options }) {
        eprintln!("solve failed: {error}");
        std::process::exit(1);
    }
    let setup_seconds = start.elapsed().as_secs_f64();
    let start = Instant::now();
    let report = match solve(&mut problem, &options) {
        Ok(report) => report,
        Err(error) => {
            eprintln!("solve failed: {error}");
            std::process::exit(1);
        }
    };
    let seconds = start.elapsed().as_secs_f64();
    let (rotation_error, center_error) = pose_errors(&problem.images, &truth.images);
    println!("{} unknowns in the reduced camera system, {} point unknowns", report.camera_unknowns, report.point_unknowns);
    println!(
        "{} iterations ({} accepted), {:.3} s total, of which {:.3} s setup; {:.3} s per iteration; termination {:?}",
        report.iterations,
        report.accepted_steps,
        seconds,
        setup_seconds,
        (seconds - setup_seconds).max(0.0) / report.iterations.max(1) as f64,
        report.termination
    );
    println!("RMS {:.3} px -> {:.4} px", report.initial_rms_px, report.final_rms_px);
    println!(
        "focal {:.3} px (true {:.3}), mean pose error {:.2e} rad / {:.2e} units",
        problem.cameras[0].f, truth.cameras[0].f, rotation_error, center_error
    );
}

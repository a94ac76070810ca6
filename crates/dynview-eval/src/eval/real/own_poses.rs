//! `cargo xtask eval --real --own-poses`: the leave-one-out of the Panoptic arcs with the
//! package of the other cameras prepared from our own structure from motion (`dynview prep`
//! without `--poses`), beside the same cameras prepared with their calibration. Per held-out
//! camera: how many of the other cameras our SfM placed, their rotation and centre errors
//! against the calibration, and the held-out camera's colour-corrected PSNR rendered from each
//! package. Results in `docs/results/own_poses.md`.
//!
//! Our world differs from the calibration's by a similarity. It is fitted on the input cameras
//! at every time step (the held-out camera plays no part): rotation from the orientations of
//! what they see (each pose turned by its camera's `view_rotation` against the calibration's
//! intrinsics: our principal points stay at the image centre, the calibration's lie 3-10 px
//! off, which SfM turns into rotations), scale and translation from their centres (`cargo
//! xtask bench sfm` aligns the bare orientations: it scores poses, not views); the held-out
//! camera's calibrated pose is mapped into our world through it
//! ([`Similarity3::transform_camera_from_world`]); its intrinsics stay the calibration's.
//!
//! No similarity maps a world that is a little distorted onto the calibration's exactly, so
//! each package is also scored with the held-out pose registered against it ([`register`]: the
//! package held fixed, as methods that find their own poses are evaluated); the calibrated
//! package gets the same treatment, a control for what the registration alone is worth.
//!
//! [`register`]: super::register

use std::fmt::Write as _;
use std::path::Path;

use dynview_core::scene::ScenePackage;

use super::register::{HeldOutPose, Registration, register_held_out};
use super::run::{CameraResult, Options};
use super::{PosesFrom, Prepared, Steps, camera_index, captures_and_work, evaluate_camera, held_out_cameras};
use crate::align::Similarity3;
use crate::datasets::real_captures::RealCapture;
use crate::runs::prep::{PrepRun, align_packages};

/// How our SfM placed the input cameras, against the calibration.
pub(super) struct Placement {
    /// Input cameras with a pose in our package.
    pub(super) placed: usize,
    /// Input cameras.
    pub(super) cameras: usize,
    /// Median rotation error over cameras and time steps, degrees.
    pub(super) rotation_median_deg: f64,
    /// Median centre error, % of the scene (the diagonal of the calibrated centres' box).
    pub(super) centre_median_pct: f64,
    /// Our world from the calibration's.
    pub(super) package_from_reference: Similarity3,
}

/// Aligns `package`'s cameras to the same cameras of `reference` (by name and time step) and
/// says how many were placed and how well.
pub(super) fn placement(package: &ScenePackage, reference: &ScenePackage, cameras: usize) -> anyhow::Result<Placement> {
    let accuracy = align_packages(package, reference)?;
    Ok(Placement {
        placed: package.manifest().cameras.len(),
        cameras,
        rotation_median_deg: accuracy.rotation_error_median_deg,
        centre_median_pct: accuracy.center_error_median_fraction * 100.0,
        package_from_reference: accuracy.true_from_estimated.inverse(),
    })
}

/// One held-out camera rendered from one package: with its pose as mapped, and registered.
struct Renders {
    mapped: CameraResult,
    registration: Registration,
    registered: CameraResult,
}

/// One held-out camera: the calibrated package's results, and ours or why there are none.
struct Row {
    held_out: String,
    calibrated: Renders,
    own: Result<(Placement, Renders), String>,
}

/// Runs the comparison on the Panoptic arcs `options` names and writes `own_poses.md`.
pub fn run(options: Options) -> anyhow::Result<()> {
    let (captures, work) = captures_and_work(&options)?;
    let mut report = String::from("# Our own poses against the calibration, leave-one-camera-out\n\n");
    report.push_str(HEADER);
    for capture in captures.into_iter().filter(|c| c.panoptic_arc().is_some()) {
        let held_out = held_out_cameras(capture, &options.held_out)?;
        if held_out.is_empty() {
            continue;
        }
        let root = work.join(capture.label());
        let prepared = Prepared::new(capture, &options, &root)?;
        let params = options.params.clone().unwrap_or_default();
        let mut rows = Vec::new();
        for camera in &held_out {
            let (run, package) = prepared.without(capture, &options, &root, camera, PosesFrom::Calibration)?;
            let calibrated = renders(camera, &prepared, &package, &run, &params, Similarity3::IDENTITY)?;
            let own = own_result(&prepared, capture, &options, &root, camera, &params).map_err(|e| format!("{e:#}"));
            if let Err(e) = &own {
                println!("{camera} held out, own poses: {e}");
            }
            rows.push(Row { held_out: camera.clone(), calibrated, own });
        }
        report.push_str(&markdown(capture, &rows, prepared.frames));
    }
    std::fs::create_dir_all(&options.out)?;
    let path = options.out.join("own_poses.md");
    dynview_core::fsutil::write_atomic(&path, report.as_bytes())?;
    println!("wrote {}", path.display());
    Ok(())
}

/// Prepares the cameras but `held_out` without their calibration and scores `held_out` from it.
fn own_result(
    prepared: &Prepared,
    capture: RealCapture,
    options: &Options,
    root: &Path,
    held_out: &str,
    params: &dynview_core::render::RenderParams,
) -> anyhow::Result<(Placement, Renders)> {
    let (run, package) = prepared.without(capture, options, root, held_out, PosesFrom::OwnSfm)?;
    let cameras = capture.cameras()?.len() - 1;
    let placement = placement(&package, &prepared.reference, cameras)?;
    let renders = renders(held_out, prepared, &package, &run, params, placement.package_from_reference)?;
    Ok((placement, renders))
}

/// Scores `held_out` from `package` with its calibrated pose mapped through
/// `package_from_reference`, then registered against the package.
fn renders(
    held_out: &str,
    prepared: &Prepared,
    package: &ScenePackage,
    run: &PrepRun,
    params: &dynview_core::render::RenderParams,
    package_from_reference: Similarity3,
) -> anyhow::Result<Renders> {
    let reference = &prepared.reference;
    let steps = || Steps::all(reference, package);
    let mapped_pose = HeldOutPose { package_from_reference, registration: Registration::NONE };
    let (mapped, _) = evaluate_camera(held_out, reference, package, run, params, steps(), &mapped_pose)?;
    let k = camera_index(reference, held_out)?;
    let Steps { package: scored, reference_shift } = steps();
    let registered_pose = register_held_out(reference, k, package, params, scored, reference_shift, package_from_reference)?;
    let registration = registered_pose.registration;
    println!(
        "{held_out} registered against {}: turned {:.3} degrees, shifted {:.4} (package units); colour-corrected PSNR of the samples {:.2} -> {:.2} dB, {} poses rendered",
        package.root().display(),
        registration.rotation_deg(),
        registration.camera_new_from_camera.translation.length(),
        registration.psnr_db[0],
        registration.psnr_db[1],
        registration.trials
    );
    let (registered, _) = evaluate_camera(held_out, reference, package, run, params, steps(), &registered_pose)?;
    Ok(Renders { mapped, registration, registered })
}

const HEADER: &str = "For each interior camera left out, `dynview prep` runs on the other cameras twice: with their \
calibration (`--poses`, as in `real.md`) and without it, from our own structure from motion. Our world is aligned to the \
calibration's by a similarity fitted on the input cameras at every time step (rotation from the orientations of what they \
see: each pose turned by the rotation that its principal point and focal length trade against the calibration's; scale and \
translation from their centres); the held-out camera's calibrated pose \
is mapped through it and rendered from each package with the full method. Rotation and centre errors are medians over the \
input cameras and time steps after that alignment (centre errors in % of the diagonal of the calibrated centres' box). PSNR \
is colour-corrected (see `real.md`), whole frame, static and moving pixels.\n\n\
Registered: the held-out camera's pose (as mapped) corrected against each package before it is scored, the package held \
fixed, as methods that find their own poses are evaluated (six degrees of freedom, the full method's colour-corrected error \
over the whole frame at three time steps, a pattern search; `register.rs`); the correction's rotation is given in degrees, \
calibrated / own.\n\n";

fn cell(result: &CameraResult) -> String {
    let s = &result.scores[0];
    format!("{:.2} ({:.2} / {:.2})", s.psnr_db.corrected, s.static_psnr_db.corrected, s.moving_psnr_db.corrected)
}

fn psnr(result: &CameraResult) -> f64 {
    result.scores[0].psnr_db.corrected
}

fn markdown(capture: RealCapture, rows: &[Row], frames: u32) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "## {}\n\nFirst {frames} frames.\n", capture.label());
    let _ = writeln!(
        s,
        "| held-out camera | cameras placed | rotation error ° | centre error % | full, calibrated (static / moving) | full, own poses (static / moving) | own - calibrated | registered: calibrated | registered: own poses | registered: own - calibrated | correction ° |\n\
         | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"
    );
    for row in rows {
        let cal = &row.calibrated;
        match &row.own {
            Ok((p, own)) => {
                let _ = writeln!(
                    s,
                    "| {} | {} of {} | {:.2} | {:.2} | {} | {} | {:+.2} | {} | {} | {:+.2} | {:.3} / {:.3} |",
                    row.held_out,
                    p.placed,
                    p.cameras,
                    p.rotation_median_deg,
                    p.centre_median_pct,
                    cell(&cal.mapped),
                    cell(&own.mapped),
                    psnr(&own.mapped) - psnr(&cal.mapped),
                    cell(&cal.registered),
                    cell(&own.registered),
                    psnr(&own.registered) - psnr(&cal.registered),
                    cal.registration.rotation_deg(),
                    own.registration.rotation_deg()
                );
            }
            Err(why) => {
                let _ = writeln!(
                    s,
                    "| {} | failed: {} | | | {} | | | {} | | | {:.3} / |",
                    row.held_out,
                    why.replace('|', "/").replace('\n', " "),
                    cell(&cal.mapped),
                    cell(&cal.registered),
                    cal.registration.rotation_deg()
                );
            }
        }
    }
    s.push('\n');
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::real::scores::{RawAndCorrected, Score};

    fn result(psnr_db: f64) -> CameraResult {
        let both = |v: f64| RawAndCorrected { raw: v, corrected: v };
        let score = Score {
            label: "full",
            psnr_db: both(psnr_db),
            ssim: both(0.8),
            static_psnr_db: both(psnr_db + 1.0),
            moving_psnr_db: both(psnr_db - 4.0),
            static_ssim: both(0.85),
            moving_ssim: both(0.6),
            flicker: 0.0,
        };
        CameraResult {
            name: "cam08".into(),
            scores: vec![score],
            nearest: "cam11".into(),
            prep_secs: 1.0,
            ms_per_frame: 1.0,
            points_per_step: 1.0,
            depth_error_pct: [1.0, 1.0],
            moving_pct: 10.0,
        }
    }

    #[test]
    fn the_table_gives_placement_both_renders_and_why_a_run_failed() {
        let placement = Placement {
            placed: 6,
            cameras: 7,
            rotation_median_deg: 0.5,
            centre_median_pct: 1.25,
            package_from_reference: Similarity3::IDENTITY,
        };
        let renders = |mapped: f64, registered: f64| Renders {
            mapped: result(mapped),
            registration: Registration::NONE,
            registered: result(registered),
        };
        let rows = [
            Row { held_out: "cam08".into(), calibrated: renders(20.0, 20.5), own: Ok((placement, renders(19.25, 20.25))) },
            Row { held_out: "cam27".into(), calibrated: renders(21.0, 21.0), own: Err("prep failed | no pair\nat all".into()) },
        ];
        let table = markdown(RealCapture::Panoptic, &rows, 75);
        let lines: Vec<&str> = table.lines().filter(|l| l.starts_with("| cam")).collect();
        assert_eq!(lines.len(), 2, "{table}");
        assert!(lines[0].contains("| 6 of 7 |") && lines[0].contains("| -0.75 |"), "{}", lines[0]);
        assert!(lines[0].contains("| 20.50 (21.50 / 16.50) | 20.25 (21.25 / 16.25) | -0.25 |"), "{}", lines[0]);
        assert!(lines[0].contains("20.00 (21.00 / 16.00)") && lines[0].contains("19.25 (20.25 / 15.25)"), "{}", lines[0]);
        assert!(lines[1].contains("failed: prep failed / no pair at all"), "{}", lines[1]);
        assert_eq!(lines[1].matches('|').count(), lines[0].matches('|').count(), "the failed row keeps the columns");
    }
}

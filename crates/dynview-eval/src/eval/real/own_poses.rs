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

use std::fmt::Write as _;
use std::path::Path;

use dynview_core::scene::ScenePackage;

use super::run::{CameraResult, Options};
use super::{PosesFrom, Prepared, Steps, captures_and_work, evaluate_camera, held_out_cameras};
use crate::align::Similarity3;
use crate::datasets::real_captures::RealCapture;
use crate::runs::prep::align_packages;

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

/// One held-out camera: the calibrated package's result, and ours or why there is none.
struct Row {
    held_out: String,
    calibrated: CameraResult,
    own: Result<(Placement, CameraResult), String>,
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
            let steps = Steps::all(&prepared.reference, &package);
            let (calibrated, _) = evaluate_camera(camera, &prepared.reference, &package, &run, &params, steps, &Similarity3::IDENTITY)?;
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
) -> anyhow::Result<(Placement, CameraResult)> {
    let (run, package) = prepared.without(capture, options, root, held_out, PosesFrom::OwnSfm)?;
    let cameras = capture.cameras()?.len() - 1;
    let placement = placement(&package, &prepared.reference, cameras)?;
    let steps = Steps::all(&prepared.reference, &package);
    let (result, _) = evaluate_camera(held_out, &prepared.reference, &package, &run, params, steps, &placement.package_from_reference)?;
    Ok((placement, result))
}

const HEADER: &str = "For each interior camera left out, `dynview prep` runs on the other cameras twice: with their \
calibration (`--poses`, as in `real.md`) and without it, from our own structure from motion. Our world is aligned to the \
calibration's by a similarity fitted on the input cameras at every time step (rotation from the orientations of what they \
see: each pose turned by the rotation that its principal point and focal length trade against the calibration's; scale and \
translation from their centres); the held-out camera's calibrated pose \
is mapped through it and rendered from each package with the full method. Rotation and centre errors are medians over the \
input cameras and time steps after that alignment (centre errors in % of the diagonal of the calibrated centres' box). PSNR \
is colour-corrected (see `real.md`), whole frame, static and moving pixels.\n\n";

fn markdown(capture: RealCapture, rows: &[Row], frames: u32) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "## {}\n\nFirst {frames} frames.\n", capture.label());
    let _ = writeln!(
        s,
        "| held-out camera | cameras placed | rotation error ° | centre error % | full, calibrated (static / moving) | full, own poses (static / moving) | own - calibrated |\n\
         | --- | ---: | ---: | ---: | ---: | ---: | ---: |"
    );
    for row in rows {
        let cal = &row.calibrated.scores[0];
        let cal_cell = format!("{:.2} ({:.2} / {:.2})", cal.psnr_db.corrected, cal.static_psnr_db.corrected, cal.moving_psnr_db.corrected);
        match &row.own {
            Ok((p, result)) => {
                let own = &result.scores[0];
                let _ = writeln!(
                    s,
                    "| {} | {} of {} | {:.2} | {:.2} | {cal_cell} | {:.2} ({:.2} / {:.2}) | {:+.2} |",
                    row.held_out,
                    p.placed,
                    p.cameras,
                    p.rotation_median_deg,
                    p.centre_median_pct,
                    own.psnr_db.corrected,
                    own.static_psnr_db.corrected,
                    own.moving_psnr_db.corrected,
                    own.psnr_db.corrected - cal.psnr_db.corrected
                );
            }
            Err(why) => {
                let _ = writeln!(s, "| {} | failed: {} | | | {cal_cell} | | |", row.held_out, why.replace('|', "/").replace('\n', " "));
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
        let rows = [
            Row { held_out: "cam08".into(), calibrated: result(20.0), own: Ok((placement, result(19.25))) },
            Row { held_out: "cam27".into(), calibrated: result(21.0), own: Err("prep failed | no pair\nat all".into()) },
        ];
        let table = markdown(RealCapture::Panoptic, &rows, 75);
        let lines: Vec<&str> = table.lines().filter(|l| l.starts_with("| cam")).collect();
        assert_eq!(lines.len(), 2, "{table}");
        assert!(lines[0].contains("| 6 of 7 |") && lines[0].contains("| -0.75 |"), "{}", lines[0]);
        assert!(lines[0].contains("20.00 (21.00 / 16.00)") && lines[0].contains("19.25 (20.25 / 15.25)"), "{}", lines[0]);
        assert!(lines[1].contains("failed: prep failed / no pair at all"), "{}", lines[1]);
        assert_eq!(lines[1].matches('|').count(), lines[0].matches('|').count(), "the failed row keeps the columns");
    }
}

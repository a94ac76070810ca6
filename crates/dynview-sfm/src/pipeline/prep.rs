//! `dynview prep` end to end: the frames and pose stages ([`crate::pipeline::poses`]), the time
//! steps ([`crate::pipeline::timesteps`]), the package ([`crate::pipeline::export`]) and the
//! report; each stage saved in the work folder and skipped on a re-run with the same inputs.

use std::path::Path;
use std::sync::atomic::AtomicBool;

use dynview_core::StageProgress;
use dynview_interchange::poses::{CameraPoses, EventPoses};

use crate::error::{SfmError, SfmResult};
use crate::input::calibration::undistort_frames;
use crate::input::frames::{EventFrames, discover};
use crate::input::timing::DEFAULT_FPS;
use crate::pipeline::export::{export_package, usable_poses};
use crate::pipeline::options::{PrepOptions, PrepReport, Stage};
use crate::pipeline::poses::pose_stages;
use crate::pipeline::timesteps::{StepSettings, run_steps};
use crate::work::WorkDir;

/// The report's file in the output folder.
pub const REPORT_FILE: &str = "report.json";
/// The package's folder in the output folder.
pub const SCENE_DIR: &str = "scene";

/// Runs `prep` from `input` into `out`: the pose stages, the time steps, the package
/// (`out/scene`) and the report (`out/report.json`); work files under `out/work`.
pub fn run(input: &Path, out: &Path, options: &PrepOptions, progress: StageProgress, interrupt: &AtomicBool) -> SfmResult<PrepReport> {
    options.validate()?;
    let work = WorkDir::new(out);
    std::fs::create_dir_all(work.path()).map_err(SfmError::io(work.path()))?;
    let mut report = PrepReport::default();
    let mut timer = std::time::Instant::now();
    let mut lap = |report: &mut PrepReport, name: &str| {
        report.stage_seconds.push((name.to_string(), timer.elapsed().as_secs_f64()));
        timer = std::time::Instant::now();
    };
    let cameras = discover(input)?;
    let Some((frames, event)) = pose_stages(&work, out, &cameras, options, &mut report, &mut lap, progress, interrupt)? else {
        return finish(out, report);
    };
    if options.stop_after == Stage::Poses {
        return finish(out, report);
    }

    let fps = report.time_alignment.as_ref().map_or(options.fps.unwrap_or(DEFAULT_FPS), |t| t.fps);
    let (event, warnings) = usable_poses(&event);
    report.warnings.extend(warnings);
    if event.cameras.len() < 2 {
        return Err(SfmError::Reconstruction(format!("only {} camera has poses; at least 2 are needed for points", event.cameras.len())));
    }
    let frames = undistorted_for(&work, &frames, &event, progress, interrupt)?;
    let event = EventPoses { cameras: event.cameras.into_iter().map(|c| CameraPoses { distortion: [0.0; 4], ..c }).collect() };
    let steps = event.time_step_count();
    // A range past the end is cut there, so array jobs of equal ranges need not know the length.
    let range = options.frames.clone().map_or(0..steps, |r| r.start..r.end.min(steps));
    if range.is_empty() {
        return Err(SfmError::Option {
            option: "frames",
            problem: format!("{:?} starts past the {steps} time steps of the event", options.frames.clone().unwrap_or_default()),
        });
    }
    let settings = StepSettings { options: options.steps.clone(), fps };
    report.steps = Some(run_steps(&work, &frames, &event, range, &settings, progress, interrupt)?);
    lap(&mut report, "time steps");
    if options.stop_after == Stage::Points || options.frames.is_some() {
        return finish(out, report);
    }

    let scene = out.join(SCENE_DIR);
    let name = out.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "event".into());
    let package = export_package(&[out.to_path_buf()], &scene, &name, &options.package, progress)?;
    report.warnings.extend(package.warnings.iter().filter(|w| !report.warnings.contains(w)).cloned().collect::<Vec<_>>());
    report.package = Some(package);
    report.package_dir = Some(scene);
    lap(&mut report, "package");
    finish(out, report)
}

fn finish(out: &Path, report: PrepReport) -> SfmResult<PrepReport> {
    let path = out.join(REPORT_FILE);
    let text = serde_json::to_vec_pretty(&report).map_err(|e| SfmError::WorkFile { path: path.clone(), problem: e.to_string() })?;
    dynview_core::fsutil::write_atomic(&path, &text).map_err(SfmError::io(&path))?;
    Ok(report)
}

/// The frames the time steps read: undistorted when the poses carry a distortion.
fn undistorted_for(
    work: &WorkDir,
    frames: &EventFrames,
    event: &EventPoses,
    progress: StageProgress,
    interrupt: &AtomicBool,
) -> SfmResult<EventFrames> {
    let mut kept =
        EventFrames { cameras: event.cameras.iter().filter_map(|c| frames.cameras.iter().find(|f| f.name == c.name).cloned()).collect() };
    if event.cameras.iter().any(|c| c.distortion.iter().any(|d| *d != 0.0)) {
        let calibration: Vec<&CameraPoses> = event.cameras.iter().collect();
        kept = undistort_frames(&kept, &calibration, &work.join("undistorted"), progress, interrupt)?;
    }
    Ok(kept)
}

//! `cargo xtask eval --real --unsync`: the Panoptic arcs made unsynchronized, as phones started
//! by hand would film them. For each held-out camera, every other camera's recording is cut at
//! its own start (whole frames, [`cut_frames`], up to [`MAX_CUT_FRAMES`]), and one camera becomes
//! a 15 fps video (every other frame, encoded losslessly) among the 30 fps image folders.
//! `dynview prep` aligns them in time (with the calibration, from the pictures) at 30 time steps
//! a second; the offsets it finds are compared with the cuts, and the held-out camera is scored
//! on the moments every camera covers, against the control: the same cameras filmed in sync over
//! the same moments, prepared alike. Results in `docs/results/unsync.md`.

use std::fmt::Write as _;
use std::path::Path;
use std::process::Command;

use anyhow::{Context, bail};
use serde::Deserialize;

use super::register::HeldOutPose;
use super::run::Options;
use super::{Prepared, Steps, captures_and_work, evaluate_camera, held_out_cameras, open};
use crate::datasets::real_captures::RealCapture;
use crate::runs::prep::prep_once;

/// The largest cut at a camera's start, frames.
pub const MAX_CUT_FRAMES: usize = 45;
/// The frame rate of the capture's image folders.
const CAPTURE_FPS: f64 = 30.0;

/// Frames cut at the start of the `i`-th camera of a run (the same for every run, spread over
/// 0..=MAX_CUT_FRAMES).
pub fn cut_frames(i: usize) -> usize {
    (i * 29 + 7) % (MAX_CUT_FRAMES + 1)
}

/// One held-out camera's figures.
struct UnsyncResult {
    held_out: String,
    /// Per input camera: name, cut (frames), offset error (frames), confidence.
    offsets: Vec<(String, usize, f64, f64)>,
    slow_camera: String,
    steps: u32,
    first_frame: u32,
    /// Colour-corrected PSNR of the full method: whole, static, moving; synchronized then not.
    psnr_db: [[f64; 3]; 2],
}

#[derive(Deserialize)]
struct Report {
    time_alignment: Alignment,
}

#[derive(Deserialize)]
struct Alignment {
    method: String,
    cameras: std::collections::BTreeMap<String, CameraTiming>,
}

#[derive(Deserialize)]
struct CameraTiming {
    start_s: f64,
    confidence: f64,
}

/// The `--unsync` evaluation of the Panoptic arcs among the captures `options` names: writes
/// `unsync.md`.
pub fn run(options: Options) -> anyhow::Result<()> {
    let (captures, work) = captures_and_work(&options)?;
    let options = &options;
    let arcs: Vec<RealCapture> = captures.iter().copied().filter(|c| *c != RealCapture::Pose2sim).collect();
    let section_of = |capture: RealCapture| work.join(capture.label()).join("unsync_section.md");
    for &capture in &arcs {
        let held_out = held_out_cameras(capture, &options.held_out)?;
        if held_out.is_empty() {
            continue;
        }
        let section = evaluate(capture, options, &work.join(capture.label()), &held_out)?;
        println!("\n{section}");
        let path = section_of(capture);
        dynview_core::fsutil::write_atomic(&path, section.as_bytes()).with_context(|| format!("writing {}", path.display()))?;
    }
    let mut report = String::from(
        "# Unsynchronized cameras on real captures\n\nThe Panoptic arcs cut apart as hand-started phones would film them, put back together by `dynview prep` \
         from the pictures (issue 34). Reproduce: `cargo xtask eval --real --unsync` (add `--capture panoptic --held-out cam08` for one).\n\n",
    );
    for capture in [RealCapture::Panoptic, RealCapture::PanopticArc2] {
        match std::fs::read_to_string(section_of(capture)) {
            Ok(section) => report.push_str(&section),
            Err(_) => {
                let _ = writeln!(report, "## {}\n\nNot evaluated in this run.\n", capture.label());
            }
        }
    }
    std::fs::create_dir_all(&options.out)?;
    let path = options.out.join("unsync.md");
    dynview_core::fsutil::write_atomic(&path, report.as_bytes())?;
    println!("wrote {}", path.display());
    Ok(())
}

/// Scores the unsynchronized runs of `capture` for `held_out`; returns the report's section.
fn evaluate(capture: RealCapture, options: &Options, root: &Path, held_out: &[String]) -> anyhow::Result<String> {
    if capture == RealCapture::Pose2sim {
        bail!("--unsync: Pose2Sim's four cameras leave three when one is held out; the Panoptic arcs are evaluated");
    }
    let prepared = Prepared::new(capture, options, root)?;
    let mut results = Vec::new();
    for camera in held_out {
        results.push(evaluate_one(capture, options, root, &prepared, camera)?);
    }
    Ok(markdown(capture, &results, prepared.frames))
}

fn evaluate_one(capture: RealCapture, options: &Options, root: &Path, prepared: &Prepared, held_out: &str) -> anyhow::Result<UnsyncResult> {
    let cameras = capture.cameras()?;
    let others: Vec<&str> = cameras.iter().filter(|c| *c != held_out).map(String::as_str).collect();
    let dir = root.join(format!("unsync_without_{held_out}_{}", prepared.frames));
    let input = dir.join("input");
    let slow = others.get(1).copied().context("too few cameras")?;
    let cuts: Vec<usize> = (0..others.len()).map(cut_frames).collect();
    write_unsync_input(&prepared.frames_dir, &input, &others, &cuts, slow, prepared.frames as usize)?;
    let poses = dir.join("poses.json");
    capture.write_poses(&poses, Some(&others))?;
    let mut args = vec!["--poses".to_string(), poses.display().to_string(), "--fps".into(), CAPTURE_FPS.to_string()];
    args.extend(prepared.prep_args.iter().cloned());
    let run = prep_once(&prepared.dynview, &input, &dir.join("out"), &args, options.fresh)?;
    let report_path = run.out.join("report.json");
    let text = std::fs::read_to_string(&report_path).with_context(|| format!("reading {}", report_path.display()))?;
    let report: Report = serde_json::from_str(&text).with_context(|| format!("{}: time_alignment", report_path.display()))?;
    if report.time_alignment.method != "visual" {
        bail!("{}: aligned by {:?}, not from the pictures", report_path.display(), report.time_alignment.method);
    }
    // The truth: the latest start is the first moment every camera filmed.
    let first_frame = *cuts.iter().max().unwrap_or(&0);
    let mut offsets = Vec::new();
    for (camera, cut) in others.iter().zip(&cuts) {
        let timing =
            report.time_alignment.cameras.get(*camera).with_context(|| format!("{}: no camera {camera}", report_path.display()))?;
        let truth_s = (first_frame - cut) as f64 / CAPTURE_FPS;
        offsets.push((camera.to_string(), *cut, (timing.start_s - truth_s) * CAPTURE_FPS, timing.confidence));
    }
    let package = open(&run)?;
    // The control: the same cameras filmed in sync over the same moments, prepared alike.
    let sync_input = dir.join("sync_input");
    for camera in &others {
        copy_frames_once(&prepared.frames_dir.join(camera), &sync_input.join(camera), first_frame..prepared.frames as usize)?;
    }
    let mut args = vec!["--poses".to_string(), poses.display().to_string()];
    args.extend(prepared.prep_args.iter().cloned());
    let sync_run = prep_once(&prepared.dynview, &sync_input, &dir.join("sync_out"), &args, options.fresh)?;
    let sync_package = open(&sync_run)?;
    let steps = package.time_step_count().min(sync_package.time_step_count());
    let params = options.params.clone().unwrap_or_default();
    let scored = Steps { package: 0..steps, reference_shift: first_frame as u32 };
    let (unsync, _) = evaluate_camera(held_out, &prepared.reference, &package, &run, &params, scored.clone(), &HeldOutPose::CALIBRATED)?;
    let (sync, _) = evaluate_camera(held_out, &prepared.reference, &sync_package, &sync_run, &params, scored, &HeldOutPose::CALIBRATED)?;
    let figures = |r: &super::run::CameraResult| {
        let s = &r.scores[0];
        [s.psnr_db.corrected, s.static_psnr_db.corrected, s.moving_psnr_db.corrected]
    };
    Ok(UnsyncResult {
        held_out: held_out.to_string(),
        offsets,
        slow_camera: slow.to_string(),
        steps,
        first_frame: first_frame as u32,
        psnr_db: [figures(&sync), figures(&unsync)],
    })
}

/// Frames `range` of `from` into `to`, renamed from `00000.jpg` (kept when `to` exists).
fn copy_frames_once(from: &Path, to: &Path, range: std::ops::Range<usize>) -> anyhow::Result<()> {
    if to.is_dir() {
        return Ok(());
    }
    let partial = to.with_extension("partial");
    std::fs::create_dir_all(&partial).with_context(|| format!("cannot create {}", partial.display()))?;
    for (k, t) in range.enumerate() {
        let source = from.join(format!("{t:05}.jpg"));
        std::fs::copy(&source, partial.join(format!("{k:05}.jpg"))).with_context(|| format!("cannot copy {}", source.display()))?;
    }
    std::fs::rename(&partial, to).with_context(|| format!("cannot rename {} to {}", partial.display(), to.display()))
}

/// Each camera's frames from its cut on into `input/<camera>/` (kept when there), `slow` as a
/// 15 fps lossless video of every other frame instead.
fn write_unsync_input(frames_dir: &Path, input: &Path, cameras: &[&str], cuts: &[usize], slow: &str, frames: usize) -> anyhow::Result<()> {
    if input.is_dir() {
        return Ok(());
    }
    let partial = input.with_extension("partial");
    if partial.exists() {
        std::fs::remove_dir_all(&partial).with_context(|| format!("cannot remove {}", partial.display()))?;
    }
    for (camera, cut) in cameras.iter().zip(cuts) {
        let keep: Vec<usize> = if *camera == slow { (*cut..frames).step_by(2).collect() } else { (*cut..frames).collect() };
        let folder = if *camera == slow { partial.join(format!(".{camera}_frames")) } else { partial.join(camera) };
        std::fs::create_dir_all(&folder).with_context(|| format!("cannot create {}", folder.display()))?;
        for (k, t) in keep.iter().enumerate() {
            let from = frames_dir.join(camera).join(format!("{t:05}.jpg"));
            std::fs::copy(&from, folder.join(format!("{k:05}.jpg"))).with_context(|| format!("cannot copy {}", from.display()))?;
        }
        if *camera == slow {
            let video = partial.join(format!("{camera}.mkv"));
            let output = Command::new("ffmpeg")
                .args(["-y", "-v", "error", "-nostdin", "-framerate", "15", "-i"])
                .arg(folder.join("%05d.jpg"))
                .args(["-c:v", "ffv1"])
                .arg(&video)
                .output()
                .context("running ffmpeg")?;
            if !output.status.success() {
                bail!("ffmpeg could not write {}: {}", video.display(), String::from_utf8_lossy(&output.stderr).trim());
            }
            std::fs::remove_dir_all(&folder).with_context(|| format!("cannot remove {}", folder.display()))?;
        }
    }
    std::fs::rename(&partial, input).with_context(|| format!("cannot rename {} to {}", partial.display(), input.display()))
}

fn markdown(capture: RealCapture, results: &[UnsyncResult], frames: u32) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "## {}\n", capture.label());
    let _ = writeln!(
        s,
        "Of its first {frames} frames, each input camera's recording starts {} frames late by camera, in camera order (`cut_frames`); \
         the second input camera is a 15 fps lossless video of every other frame. Prepared with the calibration, `--fps 30`, \
         aligned from the pictures; the 15 fps camera's frames for the steps between its frames made along the optical flow \
         (`--retime flow`, the default; `docs/results/retime.md` has the figures with its nearest frames). Full method, colour-corrected PSNR (dB) on the moments every camera covers; beside it the \
         control: the same cameras' synchronized frames of the same moments, prepared alike.\n",
        (0..8).map(|i| cut_frames(i).to_string()).collect::<Vec<_>>().join(", ")
    );
    let _ = writeln!(
        s,
        "| held-out camera | steps (from frame) | offsets within a frame | worst offset error (frames) | lowest confidence | synchronized: whole / static / moving | unsynchronized: whole / static / moving | difference (whole) |"
    );
    let _ = writeln!(s, "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: |");
    for r in results {
        let exact = r.offsets.iter().filter(|o| o.2.abs() < 0.5).count();
        let worst = r.offsets.iter().map(|o| o.2.abs()).fold(0.0, f64::max);
        let lowest = r.offsets.iter().map(|o| o.3).fold(1.0, f64::min);
        let [sync, unsync] = r.psnr_db;
        let _ = writeln!(
            s,
            "| {} | {} ({}) | {exact} of {} | {worst:.3} | {lowest:.2} | {:.2} / {:.2} / {:.2} | {:.2} / {:.2} / {:.2} | {:+.2} |",
            r.held_out,
            r.steps,
            r.first_frame,
            r.offsets.len(),
            sync[0],
            sync[1],
            sync[2],
            unsync[0],
            unsync[1],
            unsync[2],
            unsync[0] - sync[0]
        );
    }
    let _ = writeln!(
        s,
        "\nPer input camera, offset error in frames (cut in frames; {} the 15 fps camera):\n",
        results.first().map_or("", |r| r.slow_camera.as_str())
    );
    for r in results {
        let cells: Vec<String> =
            r.offsets.iter().map(|(name, cut, error, confidence)| format!("{name} ({cut}) {error:+.3}, conf. {confidence:.2}")).collect();
        let _ = writeln!(s, "- {} held out: {}", r.held_out, cells.join("; "));
    }
    s.push('\n');
    s
}

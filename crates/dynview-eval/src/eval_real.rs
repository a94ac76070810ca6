//! `cargo xtask eval --real`: leave-one-camera-out on the Pose2Sim capture. For each camera k,
//! `dynview prep` runs on the other three (calibrated poses, the first frames of every video),
//! and camera k's view is rendered at every time step and compared with camera k's real frame.
//!
//! Camera k's intrinsics, pose and reference frames come from a package prepared the same way
//! with all four cameras: same working size, same undistortion, same (calibrated) world, so no
//! alignment is needed. Results in `docs/results/real.md` and `real_strip_<camera>.png`.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context;
use dynview_core::display::colorize_depth;
use dynview_core::metrics::{psnr, ssim};
use dynview_core::render::{Method, RenderHooks, RenderParams, StreamingRenderer};
use dynview_core::scene::ScenePackage;
use dynview_core::{RgbRaster, ScalarRaster};

use crate::paths::{results_dir, workspace_root};
use crate::pose2sim::{WORKING_WIDTH_PX, calibration, extract_first_frames, write_calibrated_poses};
use crate::prep_runs::{PrepRun, prep_once, stage_seconds};
use crate::sfm_runners::dynview_binary;

/// Frames of each video used by default (the capture has 100).
const DEFAULT_FRAMES: u32 = 20;
/// Methods rendered: the full method and the plain blend as a baseline.
const METHODS: [Method; 2] = [Method::Full, Method::Blend];
/// Largest strip PNG wanted, bytes.
const STRIP_MAX_BYTES: usize = 400_000;
/// Width of one strip panel to start from, pixels (shrunk until the PNG fits).
const STRIP_PANEL_WIDTH_PX: u32 = 270;

/// Options of `dynview-eval eval-real` (`cargo xtask eval --real`).
#[derive(Debug, clap::Args)]
pub struct Options {
    /// Frames of each video used, from the first.
    #[arg(long, default_value_t = DEFAULT_FRAMES, value_parser = clap::value_parser!(u32).range(1..))]
    pub frames: u32,
    /// Redo the prep runs even when their packages exist.
    #[arg(long)]
    pub fresh: bool,
    /// Folder of the written results.
    #[arg(long, default_value_os_t = results_dir())]
    pub out: PathBuf,
}

/// Scores of one held-out camera.
struct CameraResult {
    name: String,
    /// (method, mean PSNR, mean SSIM).
    scores: Vec<(Method, f64, f64)>,
    prep_secs: f64,
    ms_per_frame: f64,
    /// Mean points per time step of the package of the other cameras.
    points_per_step: f64,
}

/// The leave-one-out evaluation: writes `real.md` and one strip per camera into `options.out`.
pub fn run(options: Options) -> anyhow::Result<()> {
    let root = workspace_root().join("target/eval/real");
    let frames_dir = root.join(format!("frames{}", options.frames));
    println!("==> first {} frames of the Pose2Sim videos into {}", options.frames, frames_dir.display());
    extract_first_frames(&frames_dir, options.frames)?;
    let cameras: Vec<String> = calibration()?.into_iter().map(|c| c.serial).collect();
    let dynview = dynview_binary()?;
    let width = ["--working-width".to_string(), WORKING_WIDTH_PX.to_string()];

    let all_poses = root.join("poses_all.json");
    write_calibrated_poses(&all_poses, None)?;
    let mut args = vec!["--poses".to_string(), all_poses.display().to_string()];
    args.extend(width.iter().cloned());
    let reference_run = prep_once(&dynview, &frames_dir, &root.join(format!("all{}", options.frames)), &args, options.fresh)?;
    let reference = open(&reference_run)?;

    let mut results = Vec::new();
    for held_out in &cameras {
        let others: Vec<&str> = cameras.iter().filter(|c| *c != held_out).map(String::as_str).collect();
        let dir = root.join(format!("without_{held_out}_{}", options.frames));
        let input = dir.join("input");
        for camera in &others {
            copy_folder_once(&frames_dir.join(camera), &input.join(camera))?;
        }
        let poses = dir.join("poses.json");
        write_calibrated_poses(&poses, Some(&others))?;
        let mut args = vec!["--poses".to_string(), poses.display().to_string()];
        args.extend(width.iter().cloned());
        let run = prep_once(&dynview, &input, &dir.join("out"), &args, options.fresh)?;
        let package = open(&run)?;
        let (result, strip) = evaluate_camera(held_out, &reference, &package, &run)?;
        write_strip(&options.out.join(format!("real_strip_{held_out}.png")), &strip)?;
        results.push(result);
    }
    let reference_secs: f64 = stage_seconds(&reference_run.out)?.iter().map(|(_, s)| s).sum();
    let report = markdown(&results, &options, &reference, reference_secs);
    println!("\n{report}");
    std::fs::create_dir_all(&options.out)?;
    let path = options.out.join("real.md");
    dynview_core::fsutil::write_atomic(&path, report.as_bytes())?;
    println!("wrote {}", path.display());
    Ok(())
}

fn open(run: &PrepRun) -> anyhow::Result<ScenePackage> {
    ScenePackage::open(run.scene_dir()).with_context(|| format!("opening {}", run.scene_dir().display()))
}

/// Copies the files of `from` into `to` unless `to` exists.
fn copy_folder_once(from: &Path, to: &Path) -> anyhow::Result<()> {
    if to.is_dir() {
        return Ok(());
    }
    let partial = to.with_extension("partial");
    std::fs::create_dir_all(&partial).with_context(|| format!("cannot create {}", partial.display()))?;
    for entry in std::fs::read_dir(from).with_context(|| format!("cannot list {}", from.display()))? {
        let entry = entry?;
        std::fs::copy(entry.path(), partial.join(entry.file_name()))
            .with_context(|| format!("cannot copy {} into {}", entry.path().display(), partial.display()))?;
    }
    std::fs::rename(&partial, to).with_context(|| format!("cannot rename {} to {}", partial.display(), to.display()))
}

/// The three panels of a strip: real frame, rendered (full method), its depth.
type Strip = [RgbRaster; 3];

/// Renders camera `held_out` of `reference` from `package` at every time step with each of
/// [`METHODS`]; returns the scores and the middle frame's strip.
fn evaluate_camera(
    held_out: &str,
    reference: &ScenePackage,
    package: &ScenePackage,
    run: &PrepRun,
) -> anyhow::Result<(CameraResult, Strip)> {
    let k = reference
        .manifest()
        .cameras
        .iter()
        .position(|c| c.name == held_out)
        .with_context(|| format!("{}: no camera {held_out}", reference.root().display()))?;
    let steps = reference.time_step_count().min(package.time_step_count());
    let levels = RenderParams::default().levels;
    let mut renderers: Vec<StreamingRenderer> = METHODS.iter().map(|_| StreamingRenderer::new()).collect();
    let mut sums = vec![(0.0, 0.0); METHODS.len()];
    let mut strip = None;
    let mut render_secs = 0.0;
    for t in 0..steps {
        let camera = reference.camera(k, t)?;
        let truth = reference.read_frame(k, t)?;
        let inputs = package.time_step_inputs(t, levels)?;
        for (m, &method) in METHODS.iter().enumerate() {
            let params = RenderParams { method, ..RenderParams::default() };
            let start = Instant::now();
            let out = renderers[m].render(&params, &camera, &inputs, &mut RenderHooks::default())?;
            if method == Method::Full {
                render_secs += start.elapsed().as_secs_f64();
            }
            sums[m].0 += psnr(&out.color, &truth);
            sums[m].1 += ssim(&out.color, &truth);
            if method == Method::Full && t == steps / 2 {
                strip = Some([truth.clone(), out.color.clone(), depth_panel(&out.depth)]);
            }
        }
    }
    let n = f64::from(steps.max(1));
    let scores: Vec<(Method, f64, f64)> = METHODS.iter().zip(&sums).map(|(&m, (p, s))| (m, p / n, s / n)).collect();
    for (m, p, s) in &scores {
        println!("{held_out} held out, {}: PSNR {p:.2} dB, SSIM {s:.4}", m.label());
    }
    let prep_secs = stage_seconds(&run.out)?.iter().map(|(_, s)| s).sum();
    let points_per_step = crate::prep_runs::cloud_point_counts(package).0 as f64 / n;
    let result = CameraResult { name: held_out.to_string(), scores, prep_secs, ms_per_frame: render_secs * 1000.0 / n, points_per_step };
    Ok((result, strip.context("no time step rendered")?))
}

fn depth_panel(depth: &ScalarRaster) -> RgbRaster {
    colorize_depth(depth)
}

/// Writes the panels side by side, each downscaled until the PNG stays under
/// [`STRIP_MAX_BYTES`].
fn write_strip(path: &Path, panels: &Strip) -> anyhow::Result<()> {
    let mut panel_width = STRIP_PANEL_WIDTH_PX;
    loop {
        let (w, h) = (panel_width, (panels[0].height as f64 * f64::from(panel_width) / panels[0].width as f64).round() as u32);
        let mut strip = image::RgbImage::new(w * panels.len() as u32, h);
        for (k, panel) in panels.iter().enumerate() {
            let small = image::imageops::resize(&panel.to_rgb8(), w, h, image::imageops::FilterType::Triangle);
            image::imageops::replace(&mut strip, &small, i64::from(k as u32 * w), 0);
        }
        let mut bytes = Vec::new();
        strip.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png)?;
        if bytes.len() <= STRIP_MAX_BYTES || panel_width < 64 {
            if let Some(parent) = path.parent() {
                std::fs::create_dir_all(parent)?;
            }
            dynview_core::fsutil::write_atomic(path, &bytes)?;
            return Ok(());
        }
        panel_width = panel_width * 4 / 5;
    }
}

fn markdown(results: &[CameraResult], options: &Options, reference: &ScenePackage, reference_secs: f64) -> String {
    let mut s = String::new();
    let size = reference.manifest().cameras.first().map_or((0, 0), |c| (c.width, c.height));
    let _ = writeln!(s, "# Leave-one-camera-out on a real capture (Pose2Sim)\n");
    let _ = writeln!(
        s,
        "Pose2Sim's multi-person lab capture (`../shared/data/pose2sim-multiperson`: 4 synchronized portrait cameras about 90 degrees \
         apart, 1088x1920). For each camera k, `dynview prep` runs on the other three with the Qualisys calibration's poses \
         (`--poses`, one per camera, distortion included) on the first {} frames (`--working-width {WORKING_WIDTH_PX}`: {}x{} frames), \
         and camera k is rendered at each time step from that package. Camera k's intrinsics, pose and reference frames come from a \
         package prepared the same way from all four cameras (same undistortion and size; {reference_secs:.0} s of prep). PSNR and SSIM \
         are averaged over the time steps, on the whole frame.\n",
        options.frames, size.0, size.1
    );
    let _ = writeln!(
        s,
        "| held-out camera | (e) full PSNR (dB) | (e) full SSIM | (c) blend PSNR (dB) | (c) blend SSIM | points per step | prep of the other three (s) | (e) ms/frame |"
    );
    let _ = writeln!(s, "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |");
    let score = |r: &CameraResult, m: Method| r.scores.iter().find(|(x, _, _)| *x == m).map_or((f64::NAN, f64::NAN), |(_, p, q)| (*p, *q));
    for r in results {
        let (fp, fs) = score(r, Method::Full);
        let (bp, bs) = score(r, Method::Blend);
        let _ = writeln!(
            s,
            "| {} | {fp:.2} | {fs:.4} | {bp:.2} | {bs:.4} | {:.0} | {:.0} | {:.0} |",
            r.name, r.points_per_step, r.prep_secs, r.ms_per_frame
        );
    }
    let n = results.len().max(1) as f64;
    let mean = |m: Method, i: usize| results.iter().map(|r| if i == 0 { score(r, m).0 } else { score(r, m).1 }).sum::<f64>() / n;
    let _ = writeln!(
        s,
        "| **mean** | **{:.2}** | **{:.4}** | **{:.2}** | **{:.4}** | {:.0} | {:.0} | |",
        mean(Method::Full, 0),
        mean(Method::Full, 1),
        mean(Method::Blend, 0),
        mean(Method::Blend, 1),
        results.iter().map(|r| r.points_per_step).sum::<f64>() / n,
        results.iter().map(|r| r.prep_secs).sum::<f64>() / n
    );
    let _ = writeln!(s, "\nStrips (`real_strip_<camera>.png`, middle time step): real frame | rendered (e) | depth of (e).\n");
    for r in results {
        let _ = writeln!(s, "![{0}](real_strip_{0}.png)", r.name);
    }
    let _ = writeln!(
        s,
        "\nReproduce: `cargo xtask eval --real [--frames {}]` (work in `target/eval/real/`; `--fresh` redoes the prep runs).",
        options.frames
    );
    s
}

//! The two reconstructions the SfM benchmark compares, each run on an image folder
//! `<root>/<camera>/<file>` and returning its sparse model (image names `<camera>/<file>`):
//!
//! - COLMAP (CPU, headless): `feature_extractor` (one SIMPLE_RADIAL camera per folder),
//!   `exhaustive_matcher`, `mapper`, then `model_converter` of the largest model to text;
//!   the wall time covers the first three steps;
//! - ours: `dynview prep --input <images> --out <dir> --keyframe-interval 1 --stop-after
//!   keyframes`, whose keyframe model is a COLMAP text model in `<dir>/work/keyframes/model/`;
//!   the wall time covers the whole command.

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context, bail};
use dynview_interchange::colmap::ColmapModel;

use crate::datasets::colmap_models::read_colmap_text;
use crate::runs::programs::{log_tail, run_logged, run_logged_status};

/// A finished reconstruction.
pub struct Reconstruction {
    /// Wall-clock seconds of the timed steps.
    pub wall_secs: f64,
    /// The sparse model (empty when the method ran but reconstructed nothing).
    pub model: ColmapModel,
    /// What the table should say about the run, if anything.
    pub note: Option<String>,
    /// Per camera, the standard deviation of its refined focal length in %, as the method
    /// reports it (ours: `report.json`'s `focal_std_percent`; empty when not reported).
    pub focal_std_percent: Vec<f64>,
}

/// Where `dynview prep` writes its keyframe model, relative to `--out`.
pub const OURS_MODEL_DIR: &str = "work/keyframes/model";

/// What COLMAP's mapper logs when it cannot start any model.
const COLMAP_NO_MODEL: &str = "failed to create sparse model";

/// Empties `dir` (removing what an earlier run left) and creates it.
fn fresh_dir(dir: &Path) -> anyhow::Result<()> {
    if dir.exists() {
        std::fs::remove_dir_all(dir).with_context(|| format!("cannot remove {}", dir.display()))?;
    }
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))
}

/// A `colmap` command; Qt is told to need no display (harmless where none is needed).
fn colmap(subcommand: &str) -> Command {
    let mut cmd = Command::new("colmap");
    cmd.arg(subcommand).env("QT_QPA_PLATFORM", "offscreen");
    cmd
}

/// Runs COLMAP on `images_dir` in `work_dir` (emptied first).
pub fn run_colmap(images_dir: &Path, work_dir: &Path) -> anyhow::Result<Reconstruction> {
    fresh_dir(work_dir)?;
    let database = work_dir.join("database.db");
    let sparse = work_dir.join("sparse");
    std::fs::create_dir_all(&sparse)?;
    let log = work_dir.join("colmap.log");
    println!("  COLMAP (log: {})", log.display());

    let mut extract = colmap("feature_extractor");
    extract.arg("--database_path").arg(&database).arg("--image_path").arg(images_dir).args([
        "--ImageReader.single_camera_per_folder",
        "1",
        "--ImageReader.camera_model",
        "SIMPLE_RADIAL",
        "--SiftExtraction.use_gpu",
        "0",
    ]);
    let mut matcher = colmap("exhaustive_matcher");
    matcher.arg("--database_path").arg(&database).args(["--SiftMatching.use_gpu", "0"]);
    let mut mapper = colmap("mapper");
    mapper.arg("--database_path").arg(&database).arg("--image_path").arg(images_dir).arg("--output_path").arg(&sparse);
    let mut wall_secs = run_logged("feature_extractor", extract, &log)?;
    wall_secs += run_logged("exhaustive_matcher", matcher, &log)?;
    let (mapper_secs, status) = run_logged_status("mapper", mapper, &log)?;
    wall_secs += mapper_secs;
    if !status.success() {
        // COLMAP 3.8's mapper exits with 1 when no image pair can start a model: a result
        // (nothing registered), not a crash.
        let tail = log_tail(&log);
        if tail.contains(COLMAP_NO_MODEL) {
            let note = format!("COLMAP's mapper made no model (\"{COLMAP_NO_MODEL}\"; see {})", log.display());
            return Ok(Reconstruction { wall_secs, model: ColmapModel::default(), note: Some(note), focal_std_percent: Vec::new() });
        }
        bail!("mapper failed ({status}) after {mapper_secs:.1} s; the end of {}:\n{tail}", log.display());
    }

    // The mapper writes one binary model per connected part: sparse/0, sparse/1, ...
    let mut best: Option<ColmapModel> = None;
    let mut parts: Vec<PathBuf> = std::fs::read_dir(&sparse)?.filter_map(Result::ok).map(|e| e.path()).filter(|p| p.is_dir()).collect();
    parts.sort();
    for part in &parts {
        let text_dir = work_dir.join("text").join(part.file_name().unwrap_or_default());
        std::fs::create_dir_all(&text_dir)?;
        let mut convert = colmap("model_converter");
        convert.arg("--input_path").arg(part).arg("--output_path").arg(&text_dir).args(["--output_type", "TXT"]);
        run_logged("model_converter", convert, &log)?;
        let model = read_colmap_text(&text_dir)?;
        println!("      model {}: {} images, {} points", part.display(), model.images.len(), model.points3d.len());
        if best.as_ref().is_none_or(|b| model.images.len() > b.images.len()) {
            best = Some(model);
        }
    }
    let model = best.with_context(|| format!("the mapper made no model (see {})", log.display()))?;
    Ok(Reconstruction { wall_secs, model, note: None, focal_std_percent: Vec::new() })
}

/// Runs `dynview prep` up to its keyframe model on `images_dir` in `work_dir` (emptied first),
/// with `extra_args` after the benchmark's own.
pub fn run_ours(dynview: &Path, images_dir: &Path, work_dir: &Path, extra_args: &[String]) -> anyhow::Result<Reconstruction> {
    fresh_dir(work_dir)?;
    let out = work_dir.join("out");
    let log = work_dir.join("dynview.log");
    println!("  ours (log: {})", log.display());
    let mut prep = Command::new(dynview);
    prep.arg("prep").arg("--input").arg(images_dir).arg("--out").arg(&out).args(["--keyframe-interval", "1", "--stop-after", "keyframes"]);
    prep.args(extra_args);
    let wall_secs = run_logged("dynview prep", prep, &log)
        .context("ours: the benchmark expects `dynview prep --input DIR --out DIR --keyframe-interval 1 --stop-after keyframes`")?;
    let model_dir = out.join(OURS_MODEL_DIR);
    let model = read_colmap_text(&model_dir)
        .with_context(|| format!("dynview prep finished but its keyframe model in {} is unreadable", model_dir.display()))?;
    let report_path = out.join("report.json");
    let report: serde_json::Value = std::fs::read_to_string(&report_path)
        .ok()
        .and_then(|text| serde_json::from_str(&text).ok())
        .with_context(|| format!("dynview prep finished but {} is unreadable", report_path.display()))?;
    let focal_std_percent = report["focal_std_percent"].as_array().map_or(Vec::new(), |v| v.iter().filter_map(|s| s.as_f64()).collect());
    Ok(Reconstruction { wall_secs, model, note: None, focal_std_percent })
}

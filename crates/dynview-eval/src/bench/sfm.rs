//! `cargo xtask bench sfm`: our keyframe structure-from-motion (`dynview prep ... --stop-after
//! keyframes`) and COLMAP side by side on the synthetic event and three other synthetic
//! layouts, Middlebury's temple ring, Pose2Sim's lab capture and the Panoptic arc (see
//! [`crate::datasets::sfm`]), against ground-truth poses and intrinsics.
//!
//! Metrics per method and dataset:
//! - wall time of the reconstruction (see [`crate::runs::sfm`] for what is timed);
//! - registered images out of the dataset's images;
//! - mean reprojection error in pixels, *recomputed* from the model (every observation of
//!   every 3D point projected with its image's pose and camera model, distortion included),
//!   so both methods are measured the same way whatever their `ERROR` fields hold;
//! - after a similarity alignment to the ground truth (rotation from the camera orientations,
//!   scale and translation from the centres)
//!   (`crate::align`): median and largest rotation error in degrees, and median and
//!   largest centre error in percent of the scene size (the diagonal of the bounding box of the
//!   ground-truth camera centres);
//! - per camera folder with a registered image: the focal length's error in percent of the true
//!   one, and the principal point's distance from the true one in pixels (median and largest);
//! - ours: the focal lengths' standard deviations its report gives (smallest and largest), to
//!   read the errors against.
//!
//! `--prep-arg` passes options to ours (variants), and `--true-intrinsics` gives it each
//! dataset's true intrinsics, which it keeps: what is left is the error of its poses alone.
//!
//! The table is printed and written to `target/bench/sfm/results.md`.

use std::fmt::Write as _;
use std::path::PathBuf;

use crate::align::{PoseAccuracy, PoseEvalOptions, evaluate_poses};
use anyhow::{Context, bail};
use dynview_core::Intrinsics;
use dynview_interchange::colmap::ColmapModel;
use dynview_interchange::poses::{CameraPoses, EventPoses, FramePose};

use crate::datasets::colmap_models::{mean_reprojection_error_px, poses_from_colmap, track_weighted_error_px};
use crate::datasets::sfm::{DATASETS, Dataset, prepare};
use crate::paths::workspace_root;
use crate::runs::programs::dynview_binary;
use crate::runs::sfm::{Reconstruction, run_colmap, run_ours};

/// Relative gap between the recomputed and the model's own mean error that earns a note.
const ERROR_FIELD_MISMATCH: f64 = 0.1;

/// The methods compared.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Method {
    /// `dynview prep --stop-after keyframes`.
    Ours,
    /// COLMAP's incremental mapper.
    Colmap,
}

impl Method {
    fn label(self) -> &'static str {
        match self {
            Self::Ours => "ours",
            Self::Colmap => "COLMAP",
        }
    }
}

/// Options of `dynview-eval bench-sfm` (`cargo xtask bench sfm`).
#[derive(Debug, clap::Args)]
pub struct Options {
    /// Run only this dataset (repeatable; default: all).
    #[arg(long = "dataset", value_name = "NAME", value_parser = clap::builder::PossibleValuesParser::new(DATASETS))]
    pub datasets: Vec<String>,
    /// Run only ours or only COLMAP.
    #[arg(long, value_enum)]
    pub only: Option<Method>,
    /// Fit the similarity on the 80% best-aligned cameras (after a first fit on all).
    #[arg(long)]
    pub robust: bool,
    /// An extra `dynview prep` argument for ours (repeatable), e.g.
    /// `--prep-arg=--centred-principal-point`.
    #[arg(long = "prep-arg", value_name = "ARG", allow_hyphen_values = true)]
    pub prep_args: Vec<String>,
    /// Give ours each dataset's true intrinsics (`dynview prep --intrinsics`, kept as given):
    /// its pose errors without the intrinsics'.
    #[arg(long)]
    pub true_intrinsics: bool,
}

/// What one method achieved on one dataset.
struct Row {
    dataset: &'static str,
    method: Method,
    /// The figures, or why there are none.
    result: Result<Figures, String>,
}

struct Figures {
    wall_secs: f64,
    images: usize,
    registered: usize,
    reprojection_px: Option<f64>,
    accuracy: Result<PoseAccuracy, String>,
    intrinsics: Option<IntrinsicsAccuracy>,
    /// The reported focal standard deviations, %, smallest and largest.
    focal_std_percent: Option<(f64, f64)>,
    notes: Vec<String>,
}

/// Intrinsics against the truth, over the camera folders with a registered image.
#[derive(Debug, PartialEq)]
struct IntrinsicsAccuracy {
    focal_error_median_pct: f64,
    focal_error_max_pct: f64,
    principal_point_error_median_px: f64,
    principal_point_error_max_px: f64,
}

/// The model's intrinsics of every camera folder (the first registered image's camera, as
/// each folder is one camera) against the dataset's.
fn intrinsics_accuracy(dataset: &Dataset, model: &ColmapModel) -> Option<IntrinsicsAccuracy> {
    let mut focal_pct = Vec::new();
    let mut principal_px = Vec::new();
    let mut seen = std::collections::BTreeSet::new();
    for image in model.images.values() {
        let Some(folder) = image.name.split('/').next() else { continue };
        let (Some(truth), Some(camera)) = (dataset.intrinsics.get(folder), model.cameras.get(&image.camera_id)) else { continue };
        if !seen.insert(folder.to_string()) {
            continue;
        }
        let estimated = camera.intrinsics().0;
        let focal = |k: &Intrinsics| 0.5 * (k.fx + k.fy);
        focal_pct.push(100.0 * (focal(&estimated) - focal(truth)).abs() / focal(truth));
        principal_px.push((estimated.cx - truth.cx).hypot(estimated.cy - truth.cy));
    }
    let median_max = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        (v[v.len() / 2], v[v.len() - 1])
    };
    (!focal_pct.is_empty()).then(|| {
        let (focal_error_median_pct, focal_error_max_pct) = median_max(focal_pct);
        let (principal_point_error_median_px, principal_point_error_max_px) = median_max(principal_px);
        IntrinsicsAccuracy { focal_error_median_pct, focal_error_max_pct, principal_point_error_median_px, principal_point_error_max_px }
    })
}

/// The benchmark (COLMAP must be installed; `cargo xtask bench sfm` installs it): writes
/// `target/bench/sfm/results.md`.
pub fn run(options: Options) -> anyhow::Result<()> {
    let datasets: Vec<String> =
        if options.datasets.is_empty() { DATASETS.iter().map(|s| s.to_string()).collect() } else { options.datasets.clone() };
    let methods = options.only.map_or(vec![Method::Ours, Method::Colmap], |only| vec![only]);
    let eval = PoseEvalOptions { robust: options.robust, ..PoseEvalOptions::default() };
    let bench_dir = workspace_root().join("target/bench/sfm");
    let mut dynview: Option<Result<PathBuf, String>> = None;
    let mut rows = Vec::new();
    for name in &datasets {
        println!("\n==> dataset {name}");
        let dataset = prepare(name, &bench_dir)?;
        println!("  {} images in {}", dataset.ground_truth.len(), dataset.images_dir.display());
        for &method in &methods {
            let work_dir = bench_dir.join(dataset.name).join(method.label().to_lowercase());
            let reconstruction = match method {
                Method::Colmap => run_colmap(&dataset.images_dir, &work_dir),
                Method::Ours => {
                    let binary = dynview.get_or_insert_with(|| dynview_binary().map_err(|e| format!("{e:#}")));
                    match binary {
                        Ok(binary) => ours_arguments(&options, &dataset, &bench_dir)
                            .and_then(|args| run_ours(binary, &dataset.images_dir, &work_dir, &args)),
                        Err(e) => Err(anyhow::anyhow!("no dynview binary: {e}")),
                    }
                }
            };
            let result = reconstruction.map(|r| figures(&dataset, &r, eval)).map_err(|e| format!("{e:#}"));
            if let Err(e) = &result {
                eprintln!("  {} failed on {}: {e}", method.label(), dataset.name);
            }
            rows.push(Row { dataset: dataset.name, method, result });
        }
    }
    let mut report = table(&rows, eval);
    let variant = ours_variant(&options);
    if !variant.is_empty() {
        report = format!("Ours with `{variant}`.\n\n{report}");
    }
    println!("\n{report}");
    let out = bench_dir.join("results.md");
    dynview_core::fsutil::write_atomic(&out, report.as_bytes())?;
    println!("(also written to {})", out.display());
    let failed = rows.iter().filter(|r| r.result.is_err()).count();
    if failed > 0 {
        bail!("{failed} of {} runs failed (see the notes above)", rows.len());
    }
    Ok(())
}

/// The extra arguments of ours as the table names them.
fn ours_variant(options: &Options) -> String {
    let mut shown = options.prep_args.clone();
    if options.true_intrinsics {
        shown.push("--intrinsics <true intrinsics>".into());
    }
    shown.join(" ")
}

/// The extra `dynview prep` arguments of ours on `dataset`: `--prep-arg`s, and with
/// `--true-intrinsics` the dataset's intrinsics written as a `poses.json` without poses.
fn ours_arguments(options: &Options, dataset: &Dataset, bench_dir: &std::path::Path) -> anyhow::Result<Vec<String>> {
    let mut args = options.prep_args.clone();
    if options.true_intrinsics {
        let path = bench_dir.join(dataset.name).join("true_intrinsics.json");
        true_intrinsics(dataset)?.write(&path)?;
        args.extend(["--intrinsics".to_string(), path.display().to_string()]);
    }
    Ok(args)
}

/// The dataset's true intrinsics of every camera folder, its frames without poses.
fn true_intrinsics(dataset: &Dataset) -> anyhow::Result<EventPoses> {
    let mut cameras = Vec::new();
    for (name, intrinsics) in &dataset.intrinsics {
        let folder = dataset.images_dir.join(name);
        let mut files: Vec<String> = std::fs::read_dir(&folder)
            .with_context(|| format!("cannot list {}", folder.display()))?
            .flatten()
            .filter(|e| e.path().is_file())
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect();
        files.sort();
        let first = files.first().with_context(|| format!("{}: no images", folder.display()))?;
        let (width, height) =
            image::image_dimensions(folder.join(first)).with_context(|| format!("cannot read {}/{first}", folder.display()))?;
        cameras.push(CameraPoses {
            name: name.clone(),
            width,
            height,
            intrinsics: *intrinsics,
            distortion: [0.0; 4],
            frames: files.into_iter().map(|file| FramePose { file, camera_from_world: None }).collect(),
        });
    }
    Ok(EventPoses { cameras })
}

fn figures(dataset: &Dataset, reconstruction: &Reconstruction, eval: PoseEvalOptions) -> Figures {
    let model = &reconstruction.model;
    let estimated = poses_from_colmap(model);
    let registered = dataset.ground_truth.keys().filter(|name| estimated.contains_key(*name)).count();
    let mut notes: Vec<String> = reconstruction.note.iter().cloned().collect();
    let reprojection_px = match mean_reprojection_error_px(model) {
        Ok(Some((mean, _))) => {
            if let Some(own) = track_weighted_error_px(model)
                && (own - mean).abs() > ERROR_FIELD_MISMATCH * mean.max(own)
            {
                notes.push(format!("the model's own points3D ERROR averages {own:.3} px (track-weighted), recomputed {mean:.3} px"));
            }
            Some(mean)
        }
        Ok(None) => None,
        Err(e) => {
            notes.push(format!("reprojection error not computed: {e:#}"));
            None
        }
    };
    let accuracy = evaluate_poses(&estimated, &dataset.ground_truth, eval).map_err(|e| e.to_string());
    if let Ok(a) = &accuracy {
        if !a.missing.is_empty() {
            notes.push(format!("not registered: {}", a.missing.join(", ")));
        }
        if a.unknown > 0 {
            notes.push(format!("{} images of the model are not in the dataset (ignored)", a.unknown));
        }
    }
    let intrinsics = intrinsics_accuracy(dataset, model);
    let stds = &reconstruction.focal_std_percent;
    let focal_std_percent =
        (!stds.is_empty()).then(|| (stds.iter().copied().fold(f64::INFINITY, f64::min), stds.iter().copied().fold(0.0, f64::max)));
    Figures {
        wall_secs: reconstruction.wall_secs,
        images: dataset.ground_truth.len(),
        registered,
        reprojection_px,
        accuracy,
        intrinsics,
        focal_std_percent,
        notes,
    }
}

fn table(rows: &[Row], eval: PoseEvalOptions) -> String {
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut s = String::new();
    let _ = writeln!(
        s,
        "SfM: ours (`dynview prep --stop-after keyframes`) vs COLMAP {} (CPU), {threads} threads. Errors after a {} \
         similarity alignment to the ground truth (rotation from the camera orientations, scale and translation \
         from the centres: `crate::align`); centre errors in % of the scene size \
         (diagonal of the ground-truth camera centres' bounding box); reprojection error recomputed from each model; \
         focal and principal-point errors per camera against its true intrinsics; focal std: the standard deviations of \
         the focal lengths our report gives (smallest-largest).\n",
        colmap_version().unwrap_or_else(|| "(version unknown)".into()),
        if eval.robust { "robust (best 80%)" } else { "least-squares" },
    );
    let _ = writeln!(
        s,
        "| dataset | method | wall s | registered | reproj. px | rot. median ° | rot. max ° | centre median % | centre max % \
         | focal median % | focal max % | focal std % | pp median px | pp max px |"
    );
    let _ = writeln!(s, "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |");
    let mut notes = String::new();
    for row in rows {
        let label = row.method.label();
        match &row.result {
            Err(e) => {
                let _ = writeln!(s, "| {} | {label} | failed | - | - | - | - | - | - | - | - | - | - | - |", row.dataset);
                let _ = writeln!(notes, "- {} / {label}: failed: {}", row.dataset, e.replace('\n', "\n  "));
            }
            Ok(f) => {
                let reprojection = f.reprojection_px.map_or("-".into(), |v| format!("{v:.3}"));
                let errors = match &f.accuracy {
                    Ok(a) => format!(
                        "{:.3} | {:.3} | {:.3} | {:.3}",
                        a.rotation_error_median_deg,
                        a.rotation_error_max_deg,
                        100.0 * a.center_error_median_fraction,
                        100.0 * a.center_error_max_fraction
                    ),
                    Err(_) => "- | - | - | -".into(),
                };
                let focal_std = f.focal_std_percent.map_or("-".into(), |(low, high)| format!("{low:.2}-{high:.2}"));
                let intrinsics = f.intrinsics.as_ref().map_or(format!("- | - | {focal_std} | - | -"), |k| {
                    format!(
                        "{:.2} | {:.2} | {focal_std} | {:.1} | {:.1}",
                        k.focal_error_median_pct, k.focal_error_max_pct, k.principal_point_error_median_px, k.principal_point_error_max_px
                    )
                });
                let _ = writeln!(
                    s,
                    "| {} | {label} | {:.1} | {} / {} | {reprojection} | {errors} | {intrinsics} |",
                    row.dataset, f.wall_secs, f.registered, f.images
                );
                for note in &f.notes {
                    let _ = writeln!(notes, "- {} / {label}: {note}", row.dataset);
                }
                if let Err(e) = &f.accuracy {
                    let _ = writeln!(notes, "- {} / {label}: no pose errors: {e}", row.dataset);
                }
            }
        }
    }
    if !notes.is_empty() {
        let _ = write!(s, "\nNotes:\n\n{notes}");
    }
    s
}

/// COLMAP's version line, e.g. `3.8`.
fn colmap_version() -> Option<String> {
    let out = std::process::Command::new("colmap").arg("-h").env("QT_QPA_PLATFORM", "offscreen").output().ok()?;
    let text = String::from_utf8_lossy(&out.stdout);
    let line = text.lines().find(|l| l.starts_with("COLMAP"))?;
    line.split_whitespace().nth(1).map(str::to_owned)
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynview_core::Rigid3;
    use dynview_interchange::colmap::{ColmapCamera, ColmapImage, ColmapModel};
    use glam::DVec3;

    fn dataset() -> Dataset {
        let ground_truth = (0..4)
            .map(|i| {
                let eye = DVec3::new(f64::from(i), f64::from(i * i) * 0.3, 0.0);
                (format!("cam/{i}.png"), Rigid3::camera_from_world_looking_at(eye, DVec3::new(1.0, 1.0, 5.0), DVec3::Y))
            })
            .collect();
        let intrinsics = [("cam".to_string(), dynview_core::Intrinsics { fx: 100.0, fy: 100.0, cx: 52.0, cy: 50.0 })].into();
        Dataset { name: "toy", images_dir: PathBuf::from("unused"), ground_truth, intrinsics }
    }

    #[test]
    fn figures_and_table_of_a_perfect_and_a_failed_run() {
        let dataset = dataset();
        let mut model = ColmapModel::default();
        model.cameras.insert(1, ColmapCamera::pinhole(&dynview_core::Intrinsics { fx: 100.0, fy: 100.0, cx: 50.0, cy: 50.0 }, 100, 100));
        // Three of the four images, exact (the same world): zero errors, one missing.
        for (id, (name, pose)) in dataset.ground_truth.iter().take(3).enumerate() {
            let image = ColmapImage { camera_id: 1, camera_from_world: *pose, name: name.clone(), points2d: Vec::new() };
            model.images.insert(id as u32 + 1, image);
        }
        let reconstruction = Reconstruction { wall_secs: 1.5, model, note: None, focal_std_percent: vec![0.5, 0.25, 0.75] };
        let figures = figures(&dataset, &reconstruction, PoseEvalOptions::default());
        assert_eq!((figures.registered, figures.images), (3, 4));
        let accuracy = figures.accuracy.as_ref().unwrap();
        assert!(accuracy.rotation_error_max_deg < 1e-9 && accuracy.center_error_max_fraction < 1e-12);
        assert_eq!(figures.notes, ["not registered: cam/3.png"]);
        // The model's camera: the true focal, the principal point 2 px off the truth.
        let expected = IntrinsicsAccuracy {
            focal_error_median_pct: 0.0,
            focal_error_max_pct: 0.0,
            principal_point_error_median_px: 2.0,
            principal_point_error_max_px: 2.0,
        };
        assert_eq!(figures.intrinsics.as_ref(), Some(&expected));
        let rows = [
            Row { dataset: "toy", method: Method::Ours, result: Err("no binary".into()) },
            Row { dataset: "toy", method: Method::Colmap, result: Ok(figures) },
        ];
        let text = table(&rows, PoseEvalOptions::default());
        assert!(text.contains("| toy | ours | failed | - |"), "{text}");
        assert!(
            text.contains("| toy | COLMAP | 1.5 | 3 / 4 | - | 0.000 | 0.000 | 0.000 | 0.000 | 0.00 | 0.00 | 0.25-0.75 | 2.0 | 2.0 |"),
            "{text}"
        );
        assert!(text.contains("- toy / ours: failed: no binary"), "{text}");
    }

    #[test]
    fn the_true_intrinsics_are_written_for_every_camera_folder_with_its_frames_and_size() {
        let dir = tempfile::tempdir().unwrap();
        let folder = dir.path().join("cam");
        std::fs::create_dir(&folder).unwrap();
        for file in ["b.png", "a.png"] {
            image::RgbImage::new(12, 8).save(folder.join(file)).unwrap();
        }
        let dataset = Dataset { images_dir: dir.path().to_path_buf(), ..dataset() };
        let poses = true_intrinsics(&dataset).unwrap();
        assert_eq!(poses.cameras.len(), 1);
        let camera = &poses.cameras[0];
        assert_eq!((camera.name.as_str(), camera.width, camera.height), ("cam", 12, 8));
        assert_eq!(camera.intrinsics, dataset.intrinsics["cam"]);
        let files: Vec<&str> = camera.frames.iter().map(|f| f.file.as_str()).collect();
        assert_eq!(files, ["a.png", "b.png"]);
        assert!(camera.frames.iter().all(|f| f.camera_from_world.is_none()));
        poses.validate().unwrap();
    }
}

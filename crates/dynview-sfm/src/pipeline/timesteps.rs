//! The per-timestep stage (METHOD.md Part 1 steps 3-4): for each time step, the frames of every
//! camera are matched across cameras only ([`crate::mapping::points`]), the points densified
//! ([`crate::dense::densify`]) and saved with the frames at the package's working size under
//! `OUT/work/steps/`. Time steps are independent, so ranges of them can run as separate jobs
//! (`prep --frames A..B`) and be joined by [`crate::pipeline::export`].

use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use opencv::core::{Mat, Size};
use opencv::prelude::*;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use dynview_camera::Radial;
use dynview_core::StageProgress;
use dynview_core::scene::PointCloud;
use dynview_core::scene::manifest::PoseEntry;
use dynview_interchange::poses::EventPoses;

use crate::dense::densify::{DensifyOptions, densify};
use crate::error::{SfmError, SfmResult};
use crate::features::sift::FeatureOptions;
use crate::input::frames::{EventFrames, WORK_FRAME_EXTENSION, encode_work_frame, read_bgr};
use crate::mapping::points::{PointOptions, TimestepView, timestep_points};
use crate::work::WorkDir;

/// The steps folder inside the work folder.
pub const STEPS_DIR: &str = "steps";
/// The settings file of the steps folder (what every step was made with).
pub const SETTINGS_FILE: &str = "steps/settings.json";
const CLOUD_MAGIC: &[u8; 8] = b"DVSTEP01";
const POINT_BYTES: usize = 15;
/// Revision of what a step writes: a step done by an older revision is done again (2: the
/// working-size frames are PNG, no longer JPEG).
pub const STEP_REVISION: u32 = 2;

/// How each time step is processed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StepOptions {
    /// Package frames are downscaled so that their width is at most this (px); never upscaled.
    pub working_width: u32,
    /// Features of the cross-camera matching (fewer and from smaller images than the
    /// keyframes': densification fills in, and every time step pays for them).
    pub features: FeatureOptions,
    /// The cross-camera points.
    pub points: PointOptions,
    /// Densification; `None` keeps the triangulated points only.
    pub densify: Option<DensifyOptions>,
}

impl Default for StepOptions {
    fn default() -> Self {
        Self {
            working_width: 960,
            features: FeatureOptions {
                max_features: STEP_MAX_FEATURES,
                max_image_size_px: STEP_MAX_IMAGE_SIZE_PX,
                ..FeatureOptions::default()
            },
            points: PointOptions::default(),
            densify: Some(DensifyOptions::default()),
        }
    }
}

/// Most features per frame of a time step.
pub const STEP_MAX_FEATURES: usize = 2048;
/// Frames of a time step larger than this (longer side, px) are reduced for feature extraction.
pub const STEP_MAX_IMAGE_SIZE_PX: u32 = 640;

/// What the steps of an output were made with; equal in every output that `merge` joins.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StepSettings {
    /// The step options.
    pub options: StepOptions,
    /// Frames per second of the capture.
    pub fps: f64,
}

/// What the steps of a run did.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct StepsReport {
    /// Time steps computed (not skipped).
    pub computed: usize,
    /// Time steps finished by an earlier run.
    pub skipped: usize,
    /// Triangulated points per computed step, in step order.
    pub sparse_points: Vec<usize>,
    /// Points after densification per computed step.
    pub points: Vec<usize>,
    /// Seconds spent triangulating, summed over steps.
    pub points_seconds: f64,
    /// Seconds spent densifying, summed over steps.
    pub densify_seconds: f64,
    /// Seconds spent writing frames, summed over steps.
    pub frames_seconds: f64,
}

/// The working size of a `width x height` frame: width at most `working_width`, aspect kept.
pub fn working_size(width: u32, height: u32, working_width: u32) -> (u32, u32) {
    if width <= working_width {
        return (width, height);
    }
    let scale = f64::from(working_width) / f64::from(width);
    (working_width, ((f64::from(height) * scale).round() as u32).max(1))
}

/// Intrinsics of a frame resized from `from` to `to` pixels (pixel centres at integers).
pub fn resized_intrinsics(k: &dynview_core::Intrinsics, from: (u32, u32), to: (u32, u32)) -> dynview_core::Intrinsics {
    let sx = f64::from(to.0) / f64::from(from.0);
    let sy = f64::from(to.1) / f64::from(from.1);
    dynview_core::Intrinsics { fx: k.fx * sx, fy: k.fy * sy, cx: (k.cx + 0.5) * sx - 0.5, cy: (k.cy + 0.5) * sy - 0.5 }
}

/// Path of a step's cloud file.
pub fn cloud_path(work: &WorkDir, t: usize) -> PathBuf {
    work.join(format!("{STEPS_DIR}/{t:05}.cloud"))
}

/// Path of a step's package frame for camera `name`.
pub fn frame_path(work: &WorkDir, name: &str, t: usize) -> PathBuf {
    work.join(format!("{STEPS_DIR}/frames/{name}/{t:05}.{WORK_FRAME_EXTENSION}"))
}

fn marker_name(t: usize) -> String {
    format!("{STEPS_DIR}/{t:05}")
}

/// What a step depends on: the settings and, per camera, its name, frame, intrinsics and pose.
#[derive(Serialize)]
struct StepKey<'a> {
    revision: u32,
    settings: &'a StepSettings,
    cameras: Vec<(&'a str, &'a str, dynview_core::Intrinsics, Option<PoseEntry>)>,
}

fn step_key<'a>(event: &'a EventPoses, settings: &'a StepSettings, t: usize) -> StepKey<'a> {
    StepKey {
        revision: STEP_REVISION,
        settings,
        cameras: event
            .cameras
            .iter()
            .map(|c| (c.name.as_str(), c.frames[t].file.as_str(), c.intrinsics, c.frames[t].camera_from_world))
            .collect(),
    }
}

/// Whether step `t` of this work folder is finished for `event` and `settings`.
pub fn is_step_done(work: &WorkDir, event: &EventPoses, settings: &StepSettings, t: usize) -> bool {
    work.is_done(&marker_name(t), &step_key(event, settings, t))
}

/// Encodes a step's cloud: magic, point count (u32), then per point `x y z` (f32) and `r g b`.
pub fn encode_cloud(cloud: &PointCloud) -> Vec<u8> {
    let mut out = Vec::with_capacity(12 + cloud.len() * POINT_BYTES);
    out.extend_from_slice(CLOUD_MAGIC);
    out.extend_from_slice(&(cloud.len() as u32).to_le_bytes());
    for (p, c) in cloud.positions_world.iter().zip(&cloud.colors) {
        p.iter().for_each(|v| out.extend_from_slice(&v.to_le_bytes()));
        out.extend_from_slice(c);
    }
    out
}

/// The number of points of a step's cloud file of `byte_length` bytes (an estimate when the
/// file is damaged; [`read_cloud`] checks).
pub fn cloud_point_count(byte_length: u64) -> usize {
    (byte_length.saturating_sub(12) / POINT_BYTES as u64) as usize
}

/// Reads a step's cloud file, checking its magic and length.
pub fn read_cloud(path: &Path) -> SfmResult<PointCloud> {
    let bytes = std::fs::read(path).map_err(SfmError::io(path))?;
    let bad = |problem: &str| SfmError::WorkFile { path: path.to_path_buf(), problem: problem.into() };
    if bytes.len() < 12 || &bytes[..8] != CLOUD_MAGIC {
        return Err(bad("not a dynview step cloud"));
    }
    let count = u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize;
    if (bytes.len() - 12) != count * POINT_BYTES {
        return Err(bad("length does not match the point count"));
    }
    let mut cloud = PointCloud::default();
    for chunk in bytes[12..].chunks_exact(POINT_BYTES) {
        let f = |i: usize| f32::from_le_bytes([chunk[i], chunk[i + 1], chunk[i + 2], chunk[i + 3]]);
        let p = [f(0), f(4), f(8)];
        if p.iter().any(|v| !v.is_finite()) {
            return Err(bad("a point is not finite"));
        }
        cloud.positions_world.push(p);
        cloud.colors.push([chunk[12], chunk[13], chunk[14]]);
    }
    Ok(cloud)
}

/// One computed step's figures.
struct StepFigures {
    sparse: usize,
    points: usize,
    seconds: [f64; 3],
}

/// Runs the steps `range` of `event` (whose cameras must all be in `frames`, every frame posed,
/// and whose frames are undistorted) into `work/steps/`; finished steps are skipped.
pub fn run_steps(
    work: &WorkDir,
    frames: &EventFrames,
    event: &EventPoses,
    range: Range<usize>,
    settings: &StepSettings,
    progress: StageProgress,
    interrupt: &AtomicBool,
) -> SfmResult<StepsReport> {
    work.write_json(SETTINGS_FILE, settings)?;
    let files: Vec<&[PathBuf]> = event
        .cameras
        .iter()
        .map(|c| {
            frames.cameras.iter().find(|f| f.name == c.name).map(|f| f.files.as_slice()).ok_or_else(|| SfmError::Input {
                path: work.path().to_path_buf(),
                problem: format!("camera {} has poses but no frames", c.name),
            })
        })
        .collect::<SfmResult<_>>()?;
    let todo: Vec<usize> = range.clone().filter(|&t| !is_step_done(work, event, settings, t)).collect();
    let done = AtomicU64::new(0);
    let total = todo.len() as u64;
    let figures = todo
        .par_iter()
        .map(|&t| {
            SfmError::check_interrupt(interrupt)?;
            let figures = run_step(work, &files, event, settings, t)?;
            work.mark_done(&marker_name(t), &step_key(event, settings, t))?;
            progress("time steps", done.fetch_add(1, Ordering::Relaxed) + 1, total);
            Ok(figures)
        })
        .collect::<SfmResult<Vec<StepFigures>>>()?;
    let mut report = StepsReport { computed: todo.len(), skipped: range.len() - todo.len(), ..StepsReport::default() };
    for f in figures {
        report.sparse_points.push(f.sparse);
        report.points.push(f.points);
        report.points_seconds += f.seconds[0];
        report.densify_seconds += f.seconds[1];
        report.frames_seconds += f.seconds[2];
    }
    Ok(report)
}

fn run_step(work: &WorkDir, files: &[&[PathBuf]], event: &EventPoses, settings: &StepSettings, t: usize) -> SfmResult<StepFigures> {
    let mut clock = std::time::Instant::now();
    let mut lap = || {
        let s = clock.elapsed().as_secs_f64();
        clock = std::time::Instant::now();
        s
    };
    let images: Vec<Mat> = files.iter().map(|f| read_bgr(&f[t])).collect::<SfmResult<_>>()?;
    let mut views = Vec::new();
    for ((camera, image), c) in event.cameras.iter().zip(&images).zip(0..) {
        let rigid = event.camera_from_world(c, t).ok_or_else(|| SfmError::Input {
            path: work.path().to_path_buf(),
            problem: format!("camera {} has no pose at frame {t}", camera.name),
        })?;
        let intrinsics = Radial::from_pinhole(&camera.intrinsics.into());
        views.push(TimestepView { intrinsics, pose: rigid, image_bgr: image });
    }
    let sparse = timestep_points(&views, &settings.options.features, &settings.options.points)?;
    let points_seconds = lap();
    let dense = match &settings.options.densify {
        Some(options) => densify(&views, &sparse, options)?,
        None => sparse.clone(),
    };
    let densify_seconds = lap();
    let cloud = PointCloud {
        positions_world: dense.positions_world.iter().map(|p| [p.x as f32, p.y as f32, p.z as f32]).collect(),
        colors: dense.colors.clone(),
    };
    for (camera, image) in event.cameras.iter().zip(&images) {
        let size = working_size(camera.width, camera.height, settings.options.working_width);
        let path = frame_path(work, &camera.name, t);
        write_frame(image, size, &path)?;
    }
    let path = cloud_path(work, t);
    dynview_core::fsutil::write_atomic(&path, &encode_cloud(&cloud)).map_err(SfmError::io(&path))?;
    let frames_seconds = lap();
    Ok(StepFigures {
        sparse: sparse.positions_world.len(),
        points: cloud.len(),
        seconds: [points_seconds, densify_seconds, frames_seconds],
    })
}

/// Resizes (area filter) and writes a package frame, losslessly (the package encodes it once).
fn write_frame(image: &Mat, size: (u32, u32), path: &Path) -> SfmResult<()> {
    let mut resized = Mat::default();
    let source = if (image.cols() as u32, image.rows() as u32) == size {
        image
    } else {
        let target = Size::new(size.0 as i32, size.1 as i32);
        opencv::imgproc::resize(image, &mut resized, target, 0.0, 0.0, opencv::imgproc::INTER_AREA)
            .map_err(SfmError::cv("resizing a frame"))?;
        &resized
    };
    dynview_core::fsutil::write_atomic(path, encode_work_frame(source)?.as_slice()).map_err(SfmError::io(path))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn working_size_keeps_the_aspect_and_never_upscales() {
        assert_eq!(working_size(1920, 1080, 960), (960, 540));
        assert_eq!(working_size(1088, 1920, 540), (540, 953));
        assert_eq!(working_size(640, 480, 960), (640, 480));
    }

    #[test]
    fn resized_intrinsics_map_pixel_centres() {
        let k = dynview_core::Intrinsics { fx: 1000.0, fy: 1000.0, cx: 959.5, cy: 539.5 };
        let half = resized_intrinsics(&k, (1920, 1080), (960, 540));
        assert_eq!((half.fx, half.fy), (500.0, 500.0));
        // The exact image centre stays the exact image centre.
        assert!((half.cx - 479.5).abs() < 1e-12 && (half.cy - 269.5).abs() < 1e-12);
    }

    #[test]
    fn clouds_round_trip_and_corrupt_files_are_refused() {
        let dir = tempfile::tempdir().expect("temp dir");
        let cloud = PointCloud { positions_world: vec![[1.0, 2.0, 3.0], [-0.5, 0.0, 9.25]], colors: vec![[1, 2, 3], [200, 100, 0]] };
        let path = dir.path().join("a.cloud");
        std::fs::write(&path, encode_cloud(&cloud)).expect("write");
        assert_eq!(read_cloud(&path).expect("read"), cloud);
        let mut bytes = encode_cloud(&cloud);
        bytes.pop();
        std::fs::write(&path, &bytes).expect("write");
        let message = read_cloud(&path).expect_err("truncated").to_string();
        assert!(message.contains("a.cloud") && message.contains("length"), "{message}");
    }
}

//! The SfM benchmark's datasets, each an image folder `<root>/<camera>/<file>` under
//! `target/bench/sfm/<dataset>/images/` with ground-truth poses keyed by `<camera>/<file>`:
//!
//! - `synthetic`: a hand-held synthetic event (6 cameras, 41 frames, 960x540), frames 0, 20
//!   and 40 of every camera; ground truth from its `colmap/` model;
//! - `temple`: Middlebury's templeSparseRing, 16 PNGs as one camera folder `temple/`; ground
//!   truth from `templeSR_par.txt`;
//! - `pose2sim`: frames 0, 20, 40, 60 and 80 of the 4 Pose2Sim videos (1088x1920), folders
//!   `cam01`..`cam04`; ground truth from the Qualisys calibration, one pose per camera;
//! - `panoptic`: frames 0, 20, 40 and 60 of the 8 cameras of the Panoptic basketball arc
//!   (640x360, undistorted), folders `cam00`..`cam29`; ground truth from its calibration;
//! - `arc5x40`, `arc8x90`, `arc12x60`: hand-held synthetic events in other layouts (5 cameras
//!   over 40 degrees, 8 over 90, 12 over 60; 640x360), each camera its own focal (0.8 to 1.6 x
//!   the longer side) and a principal point off the centre; frames 0, 20 and 40.
//!
//! Every dataset also has each camera folder's true intrinsics.
//! Image folders are made once: a folder that exists is reused.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context, bail};
use dynview_core::Intrinsics;
use dynview_synth::SynthConfig;

use dynview_interchange::middlebury::parse_middlebury_par;
use dynview_interchange::qualisys::parse_qualisys_calibration;

use crate::datasets::colmap_models::{Poses, poses_from_colmap, read_colmap_text};
use crate::paths::{command_line as describe, shared_data};

/// Names of the datasets, in the order the benchmark runs them.
pub const DATASETS: [&str; 7] = ["synthetic", "temple", "pose2sim", "panoptic", "arc5x40", "arc8x90", "arc12x60"];

/// One of the other synthetic layouts.
struct SynthLayout {
    name: &'static str,
    cameras: usize,
    arc_deg: f64,
    /// Focal lengths, x the longer side, first camera to last.
    focal_range: [f64; 2],
    /// True principal point offset (px), alternating in sign from camera to camera.
    principal_offset_px: [f64; 2],
}

/// The other synthetic layouts.
const LAYOUTS: [SynthLayout; 3] = [
    SynthLayout { name: "arc5x40", cameras: 5, arc_deg: 40.0, focal_range: [0.8, 1.6], principal_offset_px: [6.0, -4.0] },
    SynthLayout { name: "arc8x90", cameras: 8, arc_deg: 90.0, focal_range: [1.6, 0.8], principal_offset_px: [-5.0, 5.0] },
    SynthLayout { name: "arc12x60", cameras: 12, arc_deg: 60.0, focal_range: [1.0, 1.4], principal_offset_px: [4.0, 3.0] },
];

/// The synthetic hand-held event of layout `name` (`arc5x40`, `arc8x90`, `arc12x60`): 41 frames
/// at 640x360, without videos; `None` for another name.
pub fn layout_config(name: &str) -> Option<(&'static str, SynthConfig)> {
    let l = LAYOUTS.iter().find(|l| l.name == name)?;
    let layout = dynview_synth::rig::Layout {
        arc_deg: l.arc_deg,
        focal_range: Some(l.focal_range),
        principal_offset_px: l.principal_offset_px,
        ..Default::default()
    };
    let config = SynthConfig {
        cameras: l.cameras,
        frames: 41,
        width: 640,
        height: 360,
        handheld: true,
        videos: false,
        layout,
        ..SynthConfig::default()
    };
    Some((l.name, config))
}

/// Synthetic frames taken from every camera.
const SYNTHETIC_FRAMES: [u32; 3] = [0, 20, 40];
/// Frames taken from every Pose2Sim video.
const POSE2SIM_FRAMES: [u32; 5] = [0, 20, 40, 60, 80];
/// Pose2Sim video size (portrait).
const POSE2SIM_SIZE_PX: (u32, u32) = (1088, 1920);
/// Frames taken from every Panoptic camera.
const PANOPTIC_FRAMES: [u32; 4] = [0, 20, 40, 60];

/// True intrinsics by camera folder.
pub type CameraIntrinsics = BTreeMap<String, Intrinsics>;

/// A prepared dataset.
pub struct Dataset {
    /// Its name (one of [`DATASETS`]).
    pub name: &'static str,
    /// The image folder (`<camera>/<file>` inside).
    pub images_dir: PathBuf,
    /// Ground-truth `camera_from_world` of every image in the folder, by `<camera>/<file>`.
    pub ground_truth: Poses,
    /// True intrinsics of every camera folder.
    pub intrinsics: CameraIntrinsics,
}

/// Prepares the dataset `name` under `bench_dir/<name>/` (images once, ground truth each time).
pub fn prepare(name: &str, bench_dir: &Path) -> anyhow::Result<Dataset> {
    let dir = bench_dir.join(name);
    let images_dir = dir.join("images");
    let (name, (all_truth, intrinsics)) = match name {
        "synthetic" => {
            let config =
                SynthConfig { cameras: 6, frames: 41, width: 960, height: 540, handheld: true, videos: false, ..SynthConfig::default() };
            ("synthetic", synthetic(&dir, &images_dir, &config)?)
        }
        "temple" => ("temple", temple(&images_dir)?),
        "pose2sim" => ("pose2sim", pose2sim(&images_dir)?),
        "panoptic" => ("panoptic", panoptic(&images_dir)?),
        other if let Some((name, config)) = layout_config(other) => (name, synthetic(&dir, &images_dir, &config)?),
        other => bail!("unknown dataset {other:?} (known: {})", DATASETS.join(", ")),
    };
    let images = list_images(&images_dir)?;
    if images.is_empty() {
        bail!("{}: no images", images_dir.display());
    }
    let mut ground_truth = Poses::new();
    for image in images {
        let pose = all_truth.get(&image).with_context(|| format!("{name}: no ground truth for image {image}"))?;
        let camera = image.split('/').next().unwrap_or_default();
        if !intrinsics.contains_key(camera) {
            bail!("{name}: no true intrinsics for camera {camera}");
        }
        ground_truth.insert(image, *pose);
    }
    Ok(Dataset { name, images_dir, ground_truth, intrinsics })
}

/// `<camera>/<file>` of every file in the camera folders of `images_dir`, sorted.
pub fn list_images(images_dir: &Path) -> anyhow::Result<Vec<String>> {
    let mut names = Vec::new();
    let read = |dir: &Path| std::fs::read_dir(dir).with_context(|| format!("cannot list {}", dir.display()));
    for camera in read(images_dir)? {
        let camera = camera?;
        if !camera.file_type()?.is_dir() {
            continue;
        }
        for file in read(&camera.path())? {
            let file = file?;
            if file.file_type()?.is_file() {
                names.push(format!("{}/{}", camera.file_name().to_string_lossy(), file.file_name().to_string_lossy()));
            }
        }
    }
    names.sort();
    Ok(names)
}

/// Runs `fill` on a fresh `<images_dir>.partial` and renames it to `images_dir`, unless
/// `images_dir` already exists.
fn make_once(images_dir: &Path, fill: impl FnOnce(&Path) -> anyhow::Result<()>) -> anyhow::Result<()> {
    if images_dir.is_dir() {
        println!("reusing {}", images_dir.display());
        return Ok(());
    }
    let partial = images_dir.with_extension("partial");
    if partial.exists() {
        std::fs::remove_dir_all(&partial).with_context(|| format!("cannot remove {}", partial.display()))?;
    }
    std::fs::create_dir_all(&partial).with_context(|| format!("cannot create {}", partial.display()))?;
    fill(&partial)?;
    std::fs::rename(&partial, images_dir).with_context(|| format!("cannot rename {} to {}", partial.display(), images_dir.display()))
}

fn copy(from: &Path, to: &Path) -> anyhow::Result<()> {
    if let Some(parent) = to.parent() {
        std::fs::create_dir_all(parent).with_context(|| format!("cannot create {}", parent.display()))?;
    }
    std::fs::copy(from, to).with_context(|| format!("cannot copy {} to {}", from.display(), to.display()))?;
    Ok(())
}

fn synthetic(dir: &Path, images_dir: &Path, config: &SynthConfig) -> anyhow::Result<(Poses, CameraIntrinsics)> {
    let synth_dir = dir.join("synth");
    if !synth_dir.join(dynview_synth::SYNTH_MARKER).is_file() {
        // The library `dynview synth` wraps, called directly: the benchmark's COLMAP side then
        // needs no CLI build.
        println!(
            "making the synthetic event in {} ({} hand-held cameras, {} frames of {}x{}) ...",
            synth_dir.display(),
            config.cameras,
            config.frames,
            config.width,
            config.height
        );
        let progress = |stage: &str, done: u64, total: u64| {
            if done == total || done.is_multiple_of((total / 4).max(1)) {
                println!("  {stage}: {done} / {total}");
            }
        };
        dynview_synth::generate(config, &synth_dir, &progress)
            .with_context(|| format!("generating the synthetic event in {}", synth_dir.display()))?;
    }
    make_once(images_dir, |out| {
        let input = synth_dir.join("input");
        for camera in std::fs::read_dir(&input).with_context(|| format!("cannot list {}", input.display()))? {
            let camera = camera?.file_name();
            for t in SYNTHETIC_FRAMES {
                let file = format!("{t:05}.png");
                copy(&input.join(&camera).join(&file), &out.join(&camera).join(&file))?;
            }
        }
        Ok(())
    })?;
    let model = read_colmap_text(&synth_dir.join("colmap"))?;
    let mut intrinsics = CameraIntrinsics::new();
    for image in model.images.values() {
        let (Some(camera), Some(folder)) = (model.cameras.get(&image.camera_id), image.name.split('/').next()) else { continue };
        intrinsics.insert(folder.to_string(), camera.intrinsics().0);
    }
    Ok((poses_from_colmap(&model), intrinsics))
}

fn temple(images_dir: &Path) -> anyhow::Result<(Poses, CameraIntrinsics)> {
    let source = shared_data().join("middlebury-temple-sparse-ring");
    let par_path = source.join("templeSR_par.txt");
    let text = std::fs::read_to_string(&par_path).with_context(|| format!("cannot read {}", par_path.display()))?;
    let cameras = parse_middlebury_par(&text, &par_path.display().to_string())?;
    make_once(images_dir, |out| {
        for camera in &cameras {
            copy(&source.join(&camera.name), &out.join("temple").join(&camera.name))?;
        }
        Ok(())
    })?;
    // One camera took every image.
    let intrinsics = cameras.first().map(|c| ("temple".to_string(), c.intrinsics)).into_iter().collect();
    Ok((cameras.into_iter().map(|c| (format!("temple/{}", c.name), c.camera_from_world)).collect(), intrinsics))
}

fn pose2sim(images_dir: &Path) -> anyhow::Result<(Poses, CameraIntrinsics)> {
    let source = shared_data().join("pose2sim-multiperson");
    let calibration_path = source.join("calibration/Calib.qca.txt");
    let text = std::fs::read_to_string(&calibration_path).with_context(|| format!("cannot read {}", calibration_path.display()))?;
    let cameras = parse_qualisys_calibration(&text, &calibration_path.display().to_string())?;
    make_once(images_dir, |out| {
        for camera in &cameras {
            let video = source.join("videos").join(format!("{}.mp4", camera.serial));
            let folder = out.join(&camera.serial);
            std::fs::create_dir_all(&folder).with_context(|| format!("cannot create {}", folder.display()))?;
            println!("  extracting frames {POSE2SIM_FRAMES:?} of {}", video.display());
            for frame in POSE2SIM_FRAMES {
                let png = folder.join(format!("{frame:05}.png"));
                let mut cmd = Command::new("ffmpeg");
                cmd.args(["-v", "error", "-nostdin", "-y", "-i"])
                    .arg(&video)
                    .args(["-vf", &format!("select=eq(n\\,{frame})"), "-frames:v", "1"])
                    .arg(&png);
                let status = cmd.status().with_context(|| format!("cannot start {} (is ffmpeg installed?)", describe(&cmd)))?;
                if !status.success() {
                    bail!("{} failed ({status})", describe(&cmd));
                }
                let size = image::image_dimensions(&png).with_context(|| format!("cannot read {}", png.display()))?;
                if size != POSE2SIM_SIZE_PX {
                    bail!("{}: {}x{} pixels, expected {}x{}", png.display(), size.0, size.1, POSE2SIM_SIZE_PX.0, POSE2SIM_SIZE_PX.1);
                }
            }
        }
        Ok(())
    })?;
    let mut poses = Poses::new();
    for camera in &cameras {
        for frame in POSE2SIM_FRAMES {
            poses.insert(format!("{}/{frame:05}.png", camera.serial), camera.camera_from_world);
        }
    }
    Ok((poses, cameras.iter().map(|c| (c.serial.clone(), c.intrinsics)).collect()))
}

fn panoptic(images_dir: &Path) -> anyhow::Result<(Poses, CameraIntrinsics)> {
    let arc = crate::datasets::panoptic::PanopticArc::First;
    let calibration = crate::datasets::panoptic::calibration(arc, None)?;
    let source = arc.source_dir().join("cams");
    make_once(images_dir, |out| {
        for camera in &calibration.cameras {
            for frame in PANOPTIC_FRAMES {
                let file = format!("{frame:05}.jpg");
                copy(&source.join(&camera.name).join(&file), &out.join(&camera.name).join(&file))?;
            }
        }
        Ok(())
    })?;
    let mut poses = Poses::new();
    for camera in &calibration.cameras {
        let pose = camera.frames.first().and_then(|f| f.camera_from_world.as_ref()).map(|p| p.camera_from_world());
        let Some(pose) = pose else { bail!("panoptic calibration: camera {} has no pose", camera.name) };
        for frame in PANOPTIC_FRAMES {
            poses.insert(format!("{}/{frame:05}.jpg", camera.name), pose);
        }
    }
    Ok((poses, calibration.cameras.iter().map(|c| (c.name.clone(), c.intrinsics)).collect()))
}

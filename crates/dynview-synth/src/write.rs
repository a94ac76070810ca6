//! Rendering every view of an event and writing all outputs.

use std::fs;
use std::path::Path;
use std::process::Command;

use glam::DVec2;
use rand::{Rng, SeedableRng, rngs::SmallRng};
use rand_distr::{Distribution, Normal};
use rayon::prelude::*;

use dynview_core::depth_io::{DepthScale, SCALE_FILE, depth_png_bytes};
use dynview_core::fsutil::{StagedDir, write_atomic};
use dynview_core::raster::u8_from_unit;
use dynview_core::scene::manifest::{
    Bounds, CameraEntry, CloudsEntry, FORMAT_NAME, FORMAT_VERSION, FrameFormat, Manifest, PoseEntry, StartView,
};
use dynview_core::scene::{PointCloud, ScenePackage, SceneWriter};
use dynview_core::{Camera, RgbRaster, StageProgress};
use dynview_interchange::camera_path::NerfstudioPath;
use dynview_interchange::colmap::{ColmapCamera, ColmapImage, ColmapModel, ColmapPoint3D, Point2D};

use crate::render::{View, render_view};
use crate::rig::{Heldout, Rig};
use crate::scene::{Frame, default_objects};
use crate::{SYNTH_MARKER, SynthConfig, SynthError, SynthReport};

/// Noise-free surface points per input camera kept for the COLMAP model (frame 0).
const COLMAP_POINTS_PER_CAMERA: usize = 400;
/// Extra margin around the cloud bounds (m).
const BOUNDS_MARGIN_M: f64 = 0.05;

/// A sampled surface point: noisy world position, color, and (for inliers) the exact
/// position and the pixel it came from.
struct Sample {
    position: [f32; 3],
    color: [u8; 3],
    exact: Option<([f64; 3], DVec2)>,
}

fn sample_points(view: &View, camera: &Camera, config: &SynthConfig, camera_index: usize, t: u32) -> Vec<Sample> {
    let (w, h) = (view.depth_m.width, view.depth_m.height);
    let count = (config.point_fraction * (w * h) as f64).round() as usize;
    let mut rng = SmallRng::seed_from_u64(config.seed ^ ((camera_index as u64) << 32 | u64::from(t)).wrapping_mul(0x9E37_79B9_7F4A_7C15));
    let noise = Normal::new(0.0, config.point_noise_m.max(1e-12)).ok();
    let mut out = Vec::with_capacity(count);
    for _ in 0..count {
        let (x, y) = (rng.random_range(0..w), rng.random_range(0..h));
        let depth = f64::from(view.depth_m.get(x, y));
        if !depth.is_finite() {
            continue;
        }
        let pixel = DVec2::new(x as f64, y as f64);
        let exact = camera.unproject_world(pixel, depth);
        let outlier = rng.random_bool(config.outlier_fraction);
        let mut p = if outlier { camera.unproject_world(pixel, depth * rng.random_range(0.6..1.4)) } else { exact };
        if let (Some(n), false) = (noise, outlier) {
            p += glam::DVec3::new(n.sample(&mut rng), n.sample(&mut rng), n.sample(&mut rng));
        }
        let c = view.color.get(x, y);
        out.push(Sample {
            position: [p.x as f32, p.y as f32, p.z as f32],
            color: c.map(u8_from_unit),
            exact: (!outlier).then_some((exact.to_array(), pixel)),
        });
    }
    out
}

fn save_png(color: &RgbRaster, path: &Path) -> Result<(), SynthError> {
    use image::ImageEncoder;
    use image::codecs::png::{CompressionType, FilterType, PngEncoder};
    let image = color.to_rgb8();
    let mut bytes = Vec::new();
    PngEncoder::new_with_quality(&mut bytes, CompressionType::Fast, FilterType::Adaptive)
        .write_image(image.as_raw(), image.width(), image.height(), image::ExtendedColorType::Rgb8)
        .map_err(|source| SynthError::Image { path: path.to_path_buf(), source })?;
    fs::write(path, bytes).map_err(SynthError::io(path))
}

/// One rendered task's by-products.
enum TaskOutput {
    Input { camera: usize, t: u32, samples: Vec<Sample> },
    Heldout,
}

/// Generates the event described by `config` into `out_dir` (created, or replaced if it holds
/// an earlier synth output; any other existing folder is refused). Nothing appears at
/// `out_dir` until everything is written.
pub fn generate(config: &SynthConfig, out_dir: &Path, progress: StageProgress) -> Result<SynthReport, SynthError> {
    config.validate()?;
    let staged = StagedDir::new(out_dir, SYNTH_MARKER, "a dynview synth output")?;
    let root = staged.path().to_path_buf();
    let objects = default_objects(config.seed);
    let rig =
        Rig::with_layout(config.cameras, config.width, config.height, config.handheld, config.seed, config.duration_s(), &config.layout);
    let names: Vec<String> = (0..config.cameras).map(SynthConfig::camera_name).collect();
    for name in &names {
        let dir = root.join("input").join(name);
        fs::create_dir_all(&dir).map_err(SynthError::io(&dir))?;
    }
    let depth_scale = DepthScale::MILLIMETERS;
    for heldout in Heldout::ALL {
        for sub in ["color", "depth"] {
            let dir = root.join(heldout.name()).join(sub);
            fs::create_dir_all(&dir).map_err(SynthError::io(&dir))?;
        }
        write_json(&root.join(heldout.name()).join("depth").join(SCALE_FILE), &depth_scale)?;
    }

    // Every (camera, frame) of the inputs, then the held-out cameras (indices from `cameras`).
    let views_per_step = config.cameras + Heldout::ALL.len();
    let tasks: Vec<(usize, u32)> = (0..config.frames).flat_map(|t| (0..views_per_step).map(move |c| (c, t))).collect();
    let total = tasks.len() as u64;
    let done = std::sync::atomic::AtomicU64::new(0);
    progress("render", 0, total);
    let outputs = tasks
        .par_iter()
        .map(|&(camera_index, t)| -> Result<TaskOutput, SynthError> {
            let time_s = config.time_s(t);
            let frame = Frame::at(&objects, time_s);
            let heldout = camera_index.checked_sub(config.cameras).map(|k| Heldout::ALL[k]);
            let camera = match heldout {
                Some(h) => h.camera(&rig, time_s),
                None => rig.input(camera_index, time_s),
            };
            let view = render_view(&frame, &camera, config.supersample);
            let file = format!("{t:05}.png");
            let output = if let Some(h) = heldout {
                save_png(&view.color, &root.join(h.name()).join("color").join(&file))?;
                let path = root.join(h.name()).join("depth").join(&file);
                let bytes =
                    depth_png_bytes(&view.depth_m, depth_scale).map_err(|source| SynthError::Image { path: path.clone(), source })?;
                fs::write(&path, bytes).map_err(SynthError::io(&path))?;
                TaskOutput::Heldout
            } else {
                save_png(&view.color, &root.join("input").join(&names[camera_index]).join(&file))?;
                let samples = sample_points(&view, &camera, config, camera_index, t);
                TaskOutput::Input { camera: camera_index, t, samples }
            };
            let n = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
            progress("render", n, total);
            Ok(output)
        })
        .collect::<Result<Vec<_>, _>>()?;

    // Clouds per time step, cameras in order (deterministic whatever the thread schedule).
    let mut per_step: Vec<Vec<Vec<Sample>>> = (0..config.frames).map(|_| (0..config.cameras).map(|_| Vec::new()).collect()).collect();
    for output in outputs {
        if let TaskOutput::Input { camera, t, samples } = output {
            per_step[t as usize][camera] = samples;
        }
    }

    write_colmap_models(config, &rig, &names, &per_step[0], &root)?;
    for heldout in Heldout::ALL {
        let path: Vec<(Camera, f64)> = (0..config.frames)
            .map(|t| (heldout.camera(&rig, config.time_s(t)), f64::from(t) / f64::from(config.frames.saturating_sub(1).max(1))))
            .collect();
        write_json(&root.join(heldout.path_file()), &NerfstudioPath::from_frames(&path, config.fps))?;
    }

    let clouds: Vec<PointCloud> = per_step
        .iter()
        .map(|cams| PointCloud {
            positions_world: cams.iter().flatten().map(|s| s.position).collect(),
            colors: cams.iter().flatten().map(|s| s.color).collect(),
        })
        .collect();
    progress("package", 0, u64::from(config.frames));
    let package_bytes = write_package(config, &rig, &names, &clouds, &root, progress)?;

    let mut videos_written = false;
    if config.videos && ffmpeg_available() {
        for (i, name) in names.iter().enumerate() {
            progress("video", i as u64, names.len() as u64);
            encode_video(&root, name, config.fps)?;
        }
        progress("video", names.len() as u64, names.len() as u64);
        videos_written = true;
    }

    let report = SynthReport {
        config: config.clone(),
        videos_written,
        points_per_step: clouds.iter().map(|c| c.len() as u32).collect(),
        package_bytes,
    };
    write_json(&root.join(SYNTH_MARKER), &report)?;
    staged.commit()?;
    Ok(report)
}

fn write_json<T: serde::Serialize>(path: &Path, value: &T) -> Result<(), SynthError> {
    let text =
        serde_json::to_string_pretty(value).map_err(|e| SynthError::Io { path: path.to_path_buf(), source: std::io::Error::other(e) })?;
    write_atomic(path, text.as_bytes()).map_err(SynthError::io(path))
}

fn write_colmap_models(config: &SynthConfig, rig: &Rig, names: &[String], step0: &[Vec<Sample>], root: &Path) -> Result<(), SynthError> {
    let mut model = ColmapModel::default();
    let image_id = |camera: usize, t: u32| (camera as u32) * config.frames + t + 1;
    for (c, name) in names.iter().enumerate() {
        let cam = rig.input(c, 0.0);
        model.cameras.insert(c as u32 + 1, ColmapCamera::pinhole(&cam.intrinsics, cam.width_px, cam.height_px));
        for t in 0..config.frames {
            model.images.insert(
                image_id(c, t),
                ColmapImage {
                    camera_id: c as u32 + 1,
                    camera_from_world: rig.input(c, config.time_s(t)).camera_from_world,
                    name: format!("{name}/{t:05}.png"),
                    points2d: Vec::new(),
                },
            );
        }
        // Noise-free points of frame 0, each observed by the camera that sampled it.
        let mut next_id = model.points3d.len() as u64 + 1;
        for sample in step0[c].iter().filter_map(|s| s.exact.map(|e| (e, s.color))).take(COLMAP_POINTS_PER_CAMERA) {
            let ((xyz, pixel), rgb) = sample;
            let Some(image) = model.images.get_mut(&image_id(c, 0)) else { continue };
            let idx = image.points2d.len() as u32;
            image.points2d.push(Point2D { xy: [pixel.x + 0.5, pixel.y + 0.5], point3d_id: Some(next_id) });
            model.points3d.insert(next_id, ColmapPoint3D { xyz, rgb, error: 0.0, track: vec![(image_id(c, 0), idx)] });
            next_id += 1;
        }
    }
    write_colmap(&model, &root.join("colmap"))?;

    for heldout in Heldout::ALL {
        let mut model = ColmapModel::default();
        let cam = heldout.camera(rig, 0.0);
        model.cameras.insert(1, ColmapCamera::pinhole(&cam.intrinsics, cam.width_px, cam.height_px));
        for t in 0..config.frames {
            model.images.insert(
                t + 1,
                ColmapImage {
                    camera_id: 1,
                    camera_from_world: heldout.camera(rig, config.time_s(t)).camera_from_world,
                    name: format!("{}/{t:05}.png", heldout.name()),
                    points2d: Vec::new(),
                },
            );
        }
        write_colmap(&model, &root.join(heldout.name()).join("colmap"))?;
    }
    Ok(())
}

/// Writes a COLMAP text model into `dir`.
pub(crate) fn write_colmap(model: &ColmapModel, dir: &Path) -> Result<(), SynthError> {
    for (file, text) in [("cameras.txt", model.cameras_txt()), ("images.txt", model.images_txt()), ("points3D.txt", model.points3d_txt())] {
        let path = dir.join(file);
        write_atomic(&path, text.as_bytes()).map_err(SynthError::io(&path))?;
    }
    Ok(())
}

fn cloud_bounds(clouds: &[PointCloud]) -> Bounds {
    let mut min = [f64::INFINITY; 3];
    let mut max = [f64::NEG_INFINITY; 3];
    for p in clouds.iter().flat_map(|c| &c.positions_world) {
        for i in 0..3 {
            min[i] = min[i].min(f64::from(p[i]));
            max[i] = max[i].max(f64::from(p[i]));
        }
    }
    if min[0] > max[0] {
        return Bounds { min: [-1.0; 3], max: [1.0; 3] };
    }
    Bounds { min: min.map(|v| v - BOUNDS_MARGIN_M), max: max.map(|v| v + BOUNDS_MARGIN_M) }
}

fn write_package(
    config: &SynthConfig,
    rig: &Rig,
    names: &[String],
    clouds: &[PointCloud],
    root: &Path,
    progress: StageProgress,
) -> Result<u64, SynthError> {
    let cameras = names
        .iter()
        .enumerate()
        .map(|(c, name)| CameraEntry {
            name: name.clone(),
            width: config.width,
            height: config.height,
            intrinsics: rig.input(c, 0.0).intrinsics,
            poses: (0..config.frames).map(|t| PoseEntry::from(rig.input(c, config.time_s(t)).camera_from_world)).collect(),
            color_balance: None,
            plate: false,
        })
        .map(|mut camera: CameraEntry| {
            camera.compact_poses(); // a tripod: one pose
            camera
        })
        .collect();
    let start = rig.heldout(0.0);
    let manifest = Manifest {
        format: FORMAT_NAME.into(),
        version: FORMAT_VERSION,
        name: format!("synthetic event (seed {}{})", config.seed, if config.handheld { ", hand-held" } else { "" }),
        fps: config.fps,
        time_step_count: config.frames,
        bounds: cloud_bounds(clouds),
        cameras,
        clouds: CloudsEntry { file: "clouds.bin".into(), byte_length: 0 },
        frame_format: FrameFormat::Jpeg,
        frames_index: None,
        start_view: StartView {
            time_step: 0,
            pose: start.camera_from_world.into(),
            vertical_fov_deg: start.intrinsics.vertical_fov_rad(start.height_px).to_degrees(),
        },
    };
    let mut writer = SceneWriter::create(root.join("scene"), manifest)?;
    let done = std::sync::atomic::AtomicU64::new(0);
    (0..config.frames).into_par_iter().try_for_each(|t| -> Result<(), SynthError> {
        for (c, name) in names.iter().enumerate() {
            let path = root.join("input").join(name).join(format!("{t:05}.png"));
            let image = image::open(&path).map_err(|source| SynthError::Image { path: path.clone(), source })?.to_rgb8();
            writer.write_frame(c, t, &image)?;
        }
        let n = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
        progress("package", n, u64::from(config.frames));
        Ok(())
    })?;
    for cloud in clouds {
        writer.push_cloud(cloud)?;
    }
    writer.finish()?;
    Ok(ScenePackage::open(root.join("scene"))?.size_on_disk()?)
}

/// True when an `ffmpeg` binary runs.
pub fn ffmpeg_available() -> bool {
    Command::new("ffmpeg")
        .arg("-version")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

fn encode_video(root: &Path, name: &str, fps: f64) -> Result<(), SynthError> {
    let dir = root.join("videos");
    fs::create_dir_all(&dir).map_err(SynthError::io(&dir))?;
    let output = Command::new("ffmpeg")
        .args(["-y", "-loglevel", "error", "-framerate", &fps.to_string(), "-i"])
        .arg(root.join("input").join(name).join("%05d.png"))
        .args(["-c:v", "libx264", "-preset", "veryfast", "-crf", "14", "-pix_fmt", "yuv420p"])
        .arg(dir.join(format!("{name}.mp4")))
        .output()
        .map_err(SynthError::io(&dir))?;
    if !output.status.success() {
        return Err(SynthError::Video { camera: name.to_owned(), message: String::from_utf8_lossy(&output.stderr).trim().to_owned() });
    }
    Ok(())
}

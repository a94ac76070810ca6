//! Rendering every view of an event and writing all outputs.

use std::fs;
use std::path::Path;

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
use dynview_core::{Camera, RgbRaster, Rigid3, StageProgress};
use dynview_interchange::camera_path::NerfstudioPath;
use dynview_interchange::colmap::{ColmapCamera, ColmapImage, ColmapModel, ColmapPoint3D, Point2D};

use crate::files::write_json;
use crate::record::write_recordings;
use crate::render::{View, render_view};
use crate::rig::{Heldout, Rig};
use crate::scene::{Frame, default_objects, plain_movers};
use crate::unsync::{Recording, recordings};
use crate::video::{encode_video, ffmpeg_available};
use crate::{SYNTH_MARKER, SynthConfig, SynthError, SynthReport};

/// Noise-free surface points per input camera kept for the COLMAP model (frame 0).
const COLMAP_POINTS_PER_CAMERA: usize = 400;
/// Extra margin around the cloud bounds (m).
const BOUNDS_MARGIN_M: f64 = 0.05;
/// With unsynchronized cameras, where the time steps' input views wait for the scene package
/// (removed before the output is committed).
const STEP_FRAMES_DIR: &str = ".steps";

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

/// Folder of a held-out camera's object ids: `00000.png` ... (8-bit grey, 1 + the object's
/// index in [`OBJECTS_FILE`], 0 where the pixel centre sees nothing) beside `color/` and `depth/`.
pub const OBJECT_DIR: &str = "object";
/// The list of the event's objects in [`OBJECT_DIR`]: [`ObjectEntry`] per id.
pub const OBJECTS_FILE: &str = "objects.json";

/// One object of [`OBJECTS_FILE`].
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ObjectEntry {
    /// Its id in the object images (1 + its index).
    pub id: u8,
    /// What it is ([`crate::scene::Object::label`]).
    pub label: String,
    /// Whether it moves.
    pub moving: bool,
}

fn object_list(objects: &[crate::scene::Object]) -> Vec<ObjectEntry> {
    objects
        .iter()
        .enumerate()
        .map(|(i, o)| ObjectEntry { id: u8::try_from(i + 1).unwrap_or(u8::MAX), label: o.label(), moving: o.moves() })
        .collect()
}

/// What one render task draws.
#[derive(Clone, Copy, Debug)]
enum Task {
    /// An input camera at a time step of the synchronized timeline.
    Step { camera: usize, t: u32 },
    /// A held-out camera at a time step.
    Heldout { heldout: Heldout, t: u32 },
    /// Frame `frame` of an unsynchronized input camera's own recording.
    Recorded { camera: usize, frame: usize },
}

/// One rendered task's by-products.
enum TaskOutput {
    Input { camera: usize, t: u32, samples: Vec<Sample> },
    Recorded { camera: usize, samples: Vec<Sample> },
    Nothing,
}

/// Generates the event described by `config` into `out_dir` (created, or replaced if it holds
/// an earlier synth output; any other existing folder is refused). Nothing appears at
/// `out_dir` until everything is written.
pub fn generate(config: &SynthConfig, out_dir: &Path, progress: StageProgress) -> Result<SynthReport, SynthError> {
    config.validate()?;
    let staged = StagedDir::new(out_dir, SYNTH_MARKER, "a dynview synth output")?;
    let root = staged.path().to_path_buf();
    let mut objects = default_objects(config.seed);
    if config.plain_movers {
        objects.extend(plain_movers());
    }
    let rig =
        Rig::with_layout(config.cameras, config.width, config.height, config.handheld, config.seed, config.duration_s(), &config.layout);
    let names: Vec<String> = (0..config.cameras).map(SynthConfig::camera_name).collect();
    let recordings: Option<Vec<Recording>> =
        config.unsync.as_ref().map(|u| recordings(config.seed, config.cameras, config.duration_s(), u));
    // The time steps' input views: the input frames, or with unsynchronized cameras (whose own
    // frames are the input) only the scene package's.
    let step_root = if recordings.is_some() { root.join(STEP_FRAMES_DIR) } else { root.join("input") };
    for name in &names {
        for dir in [root.join("input").join(name), step_root.join(name)] {
            fs::create_dir_all(&dir).map_err(SynthError::io(&dir))?;
        }
    }
    let depth_scale = DepthScale::MILLIMETERS;
    for heldout in Heldout::ALL {
        for sub in ["color", "depth", OBJECT_DIR] {
            let dir = root.join(heldout.name()).join(sub);
            fs::create_dir_all(&dir).map_err(SynthError::io(&dir))?;
        }
        write_json(&root.join(heldout.name()).join("depth").join(SCALE_FILE), &depth_scale)?;
        write_json(&root.join(heldout.name()).join(OBJECT_DIR).join(OBJECTS_FILE), &object_list(&objects))?;
    }

    // Every (camera, time step) of the inputs and the held-out cameras, then the unsynchronized
    // cameras' own frames.
    let mut tasks: Vec<Task> = (0..config.frames)
        .flat_map(|t| {
            let steps = (0..config.cameras).map(move |camera| Task::Step { camera, t });
            steps.chain(Heldout::ALL.into_iter().map(move |heldout| Task::Heldout { heldout, t }))
        })
        .collect();
    for (camera, recording) in recordings.iter().flatten().enumerate() {
        tasks.extend((0..recording.video_times_s.len()).map(|frame| Task::Recorded { camera, frame }));
    }
    let total = tasks.len() as u64;
    let done = std::sync::atomic::AtomicU64::new(0);
    progress("render", 0, total);
    let outputs = tasks
        .par_iter()
        .map(|&task| -> Result<TaskOutput, SynthError> {
            let output = match task {
                Task::Heldout { heldout: h, t } => {
                    let time_s = config.time_s(t);
                    let view = render_view(&Frame::at(&objects, time_s), &h.camera(&rig, time_s), config.supersample);
                    let file = format!("{t:05}.png");
                    save_png(&view.color, &root.join(h.name()).join("color").join(&file))?;
                    let path = root.join(h.name()).join("depth").join(&file);
                    let bytes =
                        depth_png_bytes(&view.depth_m, depth_scale).map_err(|source| SynthError::Image { path: path.clone(), source })?;
                    fs::write(&path, bytes).map_err(SynthError::io(&path))?;
                    let path = root.join(h.name()).join(OBJECT_DIR).join(&file);
                    let ids =
                        image::GrayImage::from_raw(view.object.width as u32, view.object.height as u32, view.object.data).ok_or_else(
                            || SynthError::Io { path: path.clone(), source: std::io::Error::other("object ids of the wrong size") },
                        )?;
                    ids.save(&path).map_err(|source| SynthError::Image { path: path.clone(), source })?;
                    TaskOutput::Nothing
                }
                Task::Step { camera: camera_index, t } => {
                    let time_s = config.time_s(t);
                    let camera = rig.input(camera_index, time_s);
                    let view = render_view(&Frame::at(&objects, time_s), &camera, config.supersample);
                    save_png(&view.color, &step_root.join(&names[camera_index]).join(format!("{t:05}.png")))?;
                    let samples = sample_points(&view, &camera, config, camera_index, t);
                    TaskOutput::Input { camera: camera_index, t, samples }
                }
                Task::Recorded { camera: camera_index, frame: j } => {
                    let Some(recording) = recordings.as_ref().map(|r| &r[camera_index]) else { return Ok(TaskOutput::Nothing) };
                    let time_s = recording.event_time_s(recording.video_times_s[j]);
                    let camera = recording.camera(rig.input(camera_index, time_s));
                    let view = render_view(&Frame::at(&objects, time_s), &camera, config.supersample);
                    save_png(&view.color, &root.join("input").join(&names[camera_index]).join(format!("{j:05}.png")))?;
                    // The first frame's points go into the COLMAP model.
                    match j {
                        0 => TaskOutput::Recorded { camera: camera_index, samples: sample_points(&view, &camera, config, camera_index, 0) },
                        _ => TaskOutput::Nothing,
                    }
                }
            };
            let n = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
            progress("render", n, total);
            Ok(output)
        })
        .collect::<Result<Vec<_>, _>>()?;

    // Clouds per time step, cameras in order (deterministic whatever the thread schedule).
    let mut per_step: Vec<Vec<Vec<Sample>>> = (0..config.frames).map(|_| (0..config.cameras).map(|_| Vec::new()).collect()).collect();
    let mut recorded_first: Vec<Vec<Sample>> = (0..config.cameras).map(|_| Vec::new()).collect();
    for output in outputs {
        match output {
            TaskOutput::Input { camera, t, samples } => per_step[t as usize][camera] = samples,
            TaskOutput::Recorded { camera, samples } => recorded_first[camera] = samples,
            TaskOutput::Nothing => {}
        }
    }

    let colmap_inputs: Vec<ColmapInput> = match &recordings {
        None => (0..config.cameras)
            .map(|c| ColmapInput {
                camera: rig.input(c, 0.0),
                images: (0..config.frames)
                    .map(|t| (format!("{}/{t:05}.png", names[c]), rig.input(c, config.time_s(t)).camera_from_world))
                    .collect(),
                first_samples: &per_step[0][c],
            })
            .collect(),
        Some(recordings) => recordings
            .iter()
            .enumerate()
            .map(|(c, recording)| {
                let times = recording.event_times_s();
                ColmapInput {
                    camera: recording.camera(rig.input(c, times[0])),
                    images: times
                        .iter()
                        .enumerate()
                        .map(|(j, &e)| (format!("{}/{j:05}.png", names[c]), rig.input(c, e).camera_from_world))
                        .collect(),
                    first_samples: &recorded_first[c],
                }
            })
            .collect(),
    };
    write_colmap_models(config, &rig, &colmap_inputs, &root)?;
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
    let package_bytes = write_package(config, &rig, &names, &clouds, &step_root, &root, progress)?;

    let videos_written = config.videos && ffmpeg_available();
    let mut time_alignment = None;
    if let Some(recordings) = &recordings {
        fs::remove_dir_all(&step_root).map_err(SynthError::io(&step_root))?;
        time_alignment = Some(write_recordings(config, &rig, &objects, recordings, &root, videos_written, progress)?);
    } else if videos_written {
        for (i, name) in names.iter().enumerate() {
            progress("video", i as u64, names.len() as u64);
            encode_video(&root, name, config.fps)?;
        }
        progress("video", names.len() as u64, names.len() as u64);
    }

    let report = SynthReport {
        config: config.clone(),
        videos_written,
        points_per_step: clouds.iter().map(|c| c.len() as u32).collect(),
        package_bytes,
        time_alignment,
    };
    write_json(&root.join(SYNTH_MARKER), &report)?;
    staged.commit()?;
    Ok(report)
}

/// What the ground-truth COLMAP model lists for one input camera.
struct ColmapInput<'a> {
    /// Its lens and image size.
    camera: Camera,
    /// Its images: name and pose.
    images: Vec<(String, Rigid3)>,
    /// Points sampled from its first image.
    first_samples: &'a [Sample],
}

fn write_colmap_models(config: &SynthConfig, rig: &Rig, inputs: &[ColmapInput], root: &Path) -> Result<(), SynthError> {
    let mut model = ColmapModel::default();
    let mut first_id = 1;
    for (c, input) in inputs.iter().enumerate() {
        let cam = &input.camera;
        model.cameras.insert(c as u32 + 1, ColmapCamera::pinhole(&cam.intrinsics, cam.width_px, cam.height_px));
        for (k, (name, camera_from_world)) in input.images.iter().enumerate() {
            model.images.insert(
                first_id + k as u32,
                ColmapImage { camera_id: c as u32 + 1, camera_from_world: *camera_from_world, name: name.clone(), points2d: Vec::new() },
            );
        }
        // Noise-free points of the first image, each observed by the camera that sampled it.
        let mut next_id = model.points3d.len() as u64 + 1;
        for sample in input.first_samples.iter().filter_map(|s| s.exact.map(|e| (e, s.color))).take(COLMAP_POINTS_PER_CAMERA) {
            let ((xyz, pixel), rgb) = sample;
            let Some(image) = model.images.get_mut(&first_id) else { continue };
            let idx = image.points2d.len() as u32;
            image.points2d.push(Point2D { xy: [pixel.x + 0.5, pixel.y + 0.5], point3d_id: Some(next_id) });
            model.points3d.insert(next_id, ColmapPoint3D { xyz, rgb, error: 0.0, track: vec![(first_id, idx)] });
            next_id += 1;
        }
        first_id += input.images.len() as u32;
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
    step_root: &Path,
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
            let path = step_root.join(name).join(format!("{t:05}.png"));
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

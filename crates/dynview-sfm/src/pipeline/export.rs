//! The scene package from prepared time steps (METHOD.md Part 1 step 5): `prep` writes it at
//! the end of a whole run, and `dynview merge` from the outputs of several range runs
//! (`prep --frames A..B`), which must share the pose stage. The package is the same either way:
//! bounds come from the points of every step, frames are encoded once, from the steps' lossless frames.

use std::path::{Path, PathBuf};

use dynview_core::StageProgress;
use dynview_core::scene::ffmpeg::VideoSettings;
use dynview_core::scene::manifest::{FORMAT_NAME, FORMAT_VERSION};
use dynview_core::scene::{Bounds, CameraEntry, CloudsEntry, FrameFormat, Manifest, SceneWriter, StartView};
use dynview_interchange::poses::{EventPoses, POSES_FILE};

use crate::dense::free_space::{FreeSpaceOptions, FreeSpaceView, drop_floaters, static_depth_map};
use crate::dense::hull::{Foreground, HullOptions, HullView, foreground, hull_points, static_depths};
use crate::dense::plate_cloud::{PlateCloudOptions, estimate_plates, plate_cloud, stands_still};
use crate::dense::static_cloud::{StaticCloud, StaticOptions, build_static_cloud, candidate_steps};
use crate::error::{SfmError, SfmResult};
use crate::pipeline::timesteps::{
    SETTINGS_FILE, StepSettings, cloud_path, frame_path, is_step_done, read_cloud, resized_intrinsics, working_size,
};
use crate::work::WorkDir;
use dynview_core::raster::ScalarRaster;

mod step_plates;
use step_plates::StepPlates;

/// Share of points cut at each end of each axis when the quantisation box is chosen, so that a
/// few stray points do not coarsen the 16-bit grid of all the others.
pub const BOUNDS_TAIL_FRACTION: f64 = 0.001;
/// Margin added on each side of the box, as a share of its extent.
pub const BOUNDS_MARGIN_FRACTION: f64 = 0.02;
/// Most coordinates sampled per axis to choose the box.
const BOUNDS_SAMPLES: usize = 4_000_000;

/// A format v2 package's clouds are quantised to this share of the static cloud's voxel edge.
pub const POSITION_STEP_OF_VOXEL: f64 = 0.25;
/// Bits per color channel of a format v2 package's points (at most 4 code values off, below
/// the noise of the frames they were sampled from).
pub const COLOR_BITS: u32 = 6;

/// What a package holds beside the prepared steps, and how.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PackageOptions {
    /// The static cloud lent to every step (`None`: each step keeps only its own points).
    pub static_cloud: Option<StaticOptions>,
    /// Grow the static cloud by stereo on the background plates of the cameras that stand still
    /// ([`crate::dense::plate_cloud`]; `None`: the static points found across time only). Needs
    /// `static_cloud`, whose points seed it.
    #[serde(default = "default_plates")]
    pub plates: Option<PlateCloudOptions>,
    /// Give moving things depth from their visual hull ([`crate::dense::hull`]): points where
    /// the rays through each plate camera's foreground enter the space every other camera's
    /// foreground allows, added to each step's own points. Needs plates of more cameras than
    /// [`HullOptions::min_witnesses`] (`None`: the steps' own points only).
    #[serde(default = "default_hull")]
    pub hull: Option<HullOptions>,
    /// Drop the steps' own points that float in front of the static scene where the still
    /// cameras see their plates ([`crate::dense::free_space`]; foregrounds as `hull` defines
    /// them, or its defaults). Needs plates of two cameras or more (`None`: own points kept).
    #[serde(default = "default_free_space")]
    pub free_space: Option<FreeSpaceOptions>,
    /// Give each camera without a plate of its own (a hand-held one) a plate per step, made of
    /// its frames around the step carried through the step's depth
    /// ([`crate::dense::moving_plates`]), so that its foregrounds join the visual hull. Needs
    /// `hull` and `static_cloud`.
    #[serde(default = "yes")]
    pub moving_plates: bool,
    /// The frames as one VP9 video per camera (format v2), or as JPEG files when `None`.
    pub video: Option<VideoSettings>,
    /// Write format v1 (JPEG frames, every step's points in full, static points lent to each),
    /// which viewers of that format read; `video` must then be `None`.
    #[serde(default)]
    pub format_v1: bool,
    /// Estimate each camera's color balance ([`dynview_core::color_balance`]) and store it in
    /// the manifest for the renderer to apply.
    #[serde(default = "yes")]
    pub color_balance: bool,
}

fn yes() -> bool {
    true
}

fn default_plates() -> Option<PlateCloudOptions> {
    Some(PlateCloudOptions::default())
}

fn default_hull() -> Option<HullOptions> {
    Some(HullOptions::default())
}

fn default_free_space() -> Option<FreeSpaceOptions> {
    Some(FreeSpaceOptions::default())
}

impl Default for PackageOptions {
    fn default() -> Self {
        Self {
            static_cloud: Some(StaticOptions::default()),
            plates: default_plates(),
            hull: default_hull(),
            free_space: default_free_space(),
            moving_plates: true,
            video: Some(VideoSettings::default()),
            format_v1: false,
            color_balance: true,
        }
    }
}

/// What an export wrote.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct ExportReport {
    /// Time steps.
    pub time_steps: usize,
    /// Cameras in the package.
    pub cameras: usize,
    /// Points over all steps (after the bounds cut).
    pub points: usize,
    /// Points dropped outside the bounds.
    pub points_outside_bounds: usize,
    /// Size of the package in bytes.
    pub bytes: u64,
    /// Static points accumulated across time (`None` without the static cloud).
    #[serde(default)]
    pub static_points: Option<usize>,
    /// Points of the static cloud grown from the background plates (`None` without plates).
    #[serde(default)]
    pub plate_points: Option<usize>,
    /// Plate pixels repaired from the points other cameras see, over all cameras (`None`
    /// without plates; `dense::plate_repair`).
    #[serde(default)]
    pub repaired_plate_pixels: Option<usize>,
    /// Points of the moving things' visual hulls, summed over steps (`None` without hulls).
    #[serde(default)]
    pub hull_points: Option<usize>,
    /// Own points dropped as floating in front of the static scene, summed over steps (`None`
    /// without the test).
    #[serde(default)]
    pub floating_points: Option<usize>,
    /// Static points lent to the steps, summed over steps (each step's own points excluded).
    #[serde(default)]
    pub borrowed_points: usize,
    /// Points seen by two or more cameras that the color balance was estimated from (0
    /// without it).
    #[serde(default)]
    pub color_samples: usize,
    /// Per camera, the largest change its color balance makes to a color, in 8-bit code
    /// values (empty without it).
    #[serde(default)]
    pub color_changes: Vec<(String, f32)>,
    /// Problems worked around (cameras dropped, poses filled in).
    pub warnings: Vec<String>,
}

/// The cameras of `event` that the package can use: frames without a pose take the pose of the
/// nearest posed frame of the same camera, and a camera with no pose at all is left out. Returns
/// the usable event and a warning per change.
pub fn usable_poses(event: &EventPoses) -> (EventPoses, Vec<String>) {
    let mut warnings = Vec::new();
    let mut cameras = Vec::new();
    for camera in &event.cameras {
        let posed: Vec<usize> = (0..camera.frames.len()).filter(|&t| camera.frames[t].camera_from_world.is_some()).collect();
        if posed.is_empty() {
            warnings.push(format!("camera {} has no pose at any frame (it shares too little with the others): left out", camera.name));
            continue;
        }
        let mut camera = camera.clone();
        let missing = camera.frames.len() - posed.len();
        if missing > 0 {
            for t in 0..camera.frames.len() {
                if camera.frames[t].camera_from_world.is_none() {
                    let nearest = *posed.iter().min_by_key(|&&p| p.abs_diff(t)).unwrap_or(&posed[0]);
                    camera.frames[t].camera_from_world = camera.frames[nearest].camera_from_world;
                }
            }
            warnings.push(format!("camera {}: {missing} frames without a pose take the pose of the nearest posed frame", camera.name));
        }
        cameras.push(camera);
    }
    (EventPoses { cameras }, warnings)
}

/// One prepared output folder: its poses and step settings.
struct Source {
    root: PathBuf,
    work: WorkDir,
    event: EventPoses,
    settings: StepSettings,
}

fn open_source(root: &Path) -> SfmResult<Source> {
    let event = EventPoses::read(&root.join(POSES_FILE))?;
    let work = WorkDir::new(root);
    if !work.join(SETTINGS_FILE).is_file() {
        return Err(SfmError::Input {
            path: root.to_path_buf(),
            problem: format!("no {} here: run `dynview prep` (with --frames for a range) into this folder first", SETTINGS_FILE),
        });
    }
    let settings: StepSettings = work.read_json(SETTINGS_FILE)?;
    Ok(Source { root: root.to_path_buf(), work, event, settings })
}

/// Writes the scene package `scene_dir` (named `name`) from the prepared steps of `sources`
/// (prep output folders of one event: equal `poses.json` and step settings, every time step
/// prepared in at least one of them). With `statics`, static points accumulated across time
/// ([`crate::dense::static_cloud`]) are lent to every step where they agree with its frames.
pub fn export_package(
    sources: &[PathBuf],
    scene_dir: &Path,
    name: &str,
    options: &PackageOptions,
    progress: StageProgress,
) -> SfmResult<ExportReport> {
    let statics = options.static_cloud.as_ref();
    let Some(first) = sources.first() else {
        return Err(SfmError::Input { path: scene_dir.to_path_buf(), problem: "no prep output folders to join".into() });
    };
    let opened = sources.iter().map(|s| open_source(s)).collect::<SfmResult<Vec<_>>>()?;
    for s in &opened[1..] {
        let differs = |what: &str| SfmError::Input {
            path: s.root.clone(),
            problem: format!(
                "its {what} differs from {}'s: range outputs of one event must come from the same pose stage and options",
                first.display()
            ),
        };
        if s.event != opened[0].event {
            return Err(differs(POSES_FILE));
        }
        if s.settings != opened[0].settings {
            return Err(differs(SETTINGS_FILE));
        }
    }
    let (event, warnings) = usable_poses(&opened[0].event);
    let settings = &opened[0].settings;
    if event.cameras.is_empty() {
        return Err(SfmError::Input { path: first.join(POSES_FILE), problem: "no camera has a pose".into() });
    }
    let steps = event.time_step_count();
    let mut source_of = Vec::with_capacity(steps);
    for t in 0..steps {
        let Some(s) = opened.iter().find(|s| is_step_done(&s.work, &event, settings, t) && cloud_path(&s.work, t).is_file()) else {
            let list = sources.iter().map(|s| s.display().to_string()).collect::<Vec<_>>().join(", ");
            return Err(SfmError::Input {
                path: first.clone(),
                problem: format!(
                    "time step {t} of {steps} is not prepared (or is out of date) in {list}: run `dynview prep --frames {t}..{}` into one of them",
                    t + 1
                ),
            });
        };
        source_of.push(s);
    }

    let bounds = choose_bounds(&source_of, &event)?;
    let mut manifest = manifest(&event, settings, bounds, name);
    if options.format_v1 {
        if options.video.is_some() {
            return Err(SfmError::Input {
                path: scene_dir.to_path_buf(),
                problem: "format v1 stores frames as JPEG files, not video".into(),
            });
        }
        manifest.version = dynview_core::scene::manifest::FORMAT_VERSION_V1;
    }
    if manifest.version != dynview_core::scene::manifest::FORMAT_VERSION_V1 {
        manifest.cameras.iter_mut().for_each(CameraEntry::compact_poses);
    }
    if let Some(video) = &options.video {
        manifest.set_video_frames(video.keyframe_interval);
    }
    let mut static_cloud = match statics {
        Some(options) => Some(static_cloud(&source_of, &manifest, options, progress)?),
        None => None,
    };
    let mut plate_points = None;
    let mut repaired_plate_pixels = None;
    let mut plates = Vec::new();
    if let (Some(across_time), Some(options)) = (&static_cloud, &options.plates) {
        let (grown, estimated) = static_cloud_from_plates(&source_of, &manifest, &across_time.points, options, progress)?;
        if let Some(grown) = grown {
            plate_points = Some(grown.points.len());
            repaired_plate_pixels = Some(grown.repaired_plate_pixels);
            static_cloud = Some(grown);
            plates = estimated;
        }
    }
    let mut warnings = warnings;
    let color_samples = if options.color_balance { balance_colors(&source_of, &mut manifest, &mut warnings, progress)? } else { 0 };
    let color_changes =
        manifest.cameras.iter().filter_map(|c| c.color_balance.map(|b| (c.name.clone(), 255.0 * b.largest_change()))).collect();
    let mut writer = SceneWriter::create_with(scene_dir, manifest, options.video.unwrap_or_default())?;
    for (c, plate) in plates.iter().enumerate() {
        if let Some(plate) = plate {
            writer.write_plate(c, &plate.image)?;
        }
    }
    let mut report = ExportReport {
        time_steps: steps,
        cameras: event.cameras.len(),
        color_samples,
        color_changes,
        warnings,
        static_points: static_cloud.as_ref().map(|s| s.points.len()),
        plate_points,
        repaired_plate_pixels,
        ..ExportReport::default()
    };
    // The cameras that move (hand-held ones) get a plate per step.
    let cameras = event.cameras.len();
    let moves = |c: usize| !stands_still(&(0..steps).map(|t| writer.manifest().camera_at(c, t as u32)).collect::<Vec<_>>());
    let without_plate: Vec<usize> = match &static_cloud {
        Some(_) if options.moving_plates => (0..cameras).filter(|&c| plates.get(c).is_none_or(Option::is_none) && moves(c)).collect(),
        _ => Vec::new(),
    };
    // A hull point needs the camera it is seen from and `min_witnesses` others with a plate.
    let hull = options.hull.as_ref().filter(|h| plates.iter().flatten().count() + without_plate.len() > h.min_witnesses);
    if let Some(hull) = hull {
        hull.validate()?;
        report.hull_points = Some(0);
    }
    let plate_options = options.plates.as_ref().map(|p| p.plates.clone()).unwrap_or_default();
    let mut step_plates = match (hull, &static_cloud) {
        (Some(_), Some(statics)) if !without_plate.is_empty() => Some(StepPlates::new(without_plate, &statics.points, plate_options)),
        _ => None,
    };
    let static_depth_of: Vec<Option<(f64, f64)>> = match (hull, &static_cloud) {
        (Some(_), Some(statics)) => (0..cameras)
            .map(|c| plates.get(c)?.as_ref().and_then(|_| static_depths(&writer.manifest().camera_at(c, 0), &statics.points)))
            .collect(),
        _ => Vec::new(),
    };
    // The free-space test: each plate camera's static depth (the cameras stand still).
    let free_space = options.free_space.as_ref().filter(|_| plates.iter().flatten().count() >= 2);
    let static_depth_maps: Vec<Option<ScalarRaster>> = match (free_space, &static_cloud) {
        (Some(free_space), Some(statics)) => {
            free_space.validate()?;
            report.floating_points = Some(0);
            (0..plates.len())
                .map(|c| {
                    plates[c]
                        .as_ref()
                        .map(|_| static_depth_map(&writer.manifest().camera_at(c, 0), &statics.points, free_space.footprint_px))
                })
                .collect()
        }
        _ => Vec::new(),
    };
    let foreground_options = options.hull.clone().unwrap_or_default();
    let (lo, hi) = (bounds.min.map(|v| v as f32), bounds.max.map(|v| v as f32));
    let inside = |p: &[f32; 3]| (0..3).all(|i| p[i] >= lo[i] && p[i] <= hi[i]);
    // A format v2 package stores the static points inside the box once (`store` maps a static
    // index to its stored one); a format v1 package lends them to every step in full.
    let stored_statics = static_cloud.as_ref().filter(|_| writer.has_static_cloud()).map(|statics| {
        let kept: Vec<usize> = (0..statics.points.len()).filter(|&i| inside(&statics.points.positions_world[i])).collect();
        let mut store = vec![None; statics.points.len()];
        for (k, &i) in kept.iter().enumerate() {
            store[i] = Some(k as u32);
        }
        (statics.points.select(kept), store)
    });
    if let Some((cloud, _)) = &stored_statics {
        // A quarter of a static voxel (half a pixel of the first camera at the median depth)
        // is finer than the points are accurate.
        if let Some(statics) = &static_cloud
            && statics.voxel_edge > 0.0
        {
            writer.set_position_step(POSITION_STEP_OF_VOXEL * statics.voxel_edge)?;
        }
        writer.set_color_bits(COLOR_BITS)?;
        writer.set_static_cloud(cloud)?;
    }
    for (t, s) in source_of.iter().enumerate() {
        // The frames' one lossy encode: the package's video or image format.
        let frames = work_frames(s, writer.manifest(), t)?;
        for (c, frame) in frames.iter().enumerate() {
            writer.write_frame(c, t as u32, frame)?;
        }
        let mut cloud = read_cloud(&cloud_path(&s.work, t))?;
        let mut foregrounds = if hull.is_some() || !static_depth_maps.is_empty() {
            step_foregrounds(&frames, &plates, &foreground_options)?
        } else {
            Vec::new()
        };
        let mut depth_of = static_depth_of.clone();
        if let Some(step_plates) = step_plates.as_mut() {
            let manifest = writer.manifest();
            let made = step_plates.at(
                t,
                steps,
                &cloud,
                |c, s| work_frame(source_of[s], &manifest.cameras[c].name, s),
                |c, s| manifest.camera_at(c, s as u32),
            )?;
            depth_of.resize(cameras, None);
            for (&c, (plate, range)) in step_plates.cameras().iter().zip(made) {
                foregrounds[c] = Some(foreground(&frames[c], &plate, &foreground_options)?);
                depth_of[c] = range;
            }
        }
        if let Some(free_space) = free_space.filter(|_| !static_depth_maps.is_empty()) {
            let (kept, dropped) = step_floaters_dropped(writer.manifest(), t, &foregrounds, &static_depth_maps, &cloud, free_space);
            cloud = kept;
            report.floating_points = report.floating_points.map(|n| n + dropped);
        }
        // Hull points are judged against the step's own points, before static points stand in.
        let moving = match hull {
            Some(hull) => Some(step_hull(writer.manifest(), t, &frames, &foregrounds, &depth_of, &cloud, hull)?),
            None => None,
        };
        let mut borrowed_indices = Vec::new();
        match (&static_cloud, &stored_statics) {
            (Some(statics), Some((_, store))) => {
                borrowed_indices = statics.active.get(t).into_iter().flatten().filter_map(|&i| store[i as usize]).collect();
                cloud = statics.own_not_covered(t, &cloud);
                borrowed_indices.sort_unstable();
                report.borrowed_points += borrowed_indices.len();
            }
            (Some(statics), None) => {
                let borrowed = statics.borrowed(t);
                report.borrowed_points += borrowed.len();
                cloud.positions_world.extend(borrowed.positions_world);
                cloud.colors.extend(borrowed.colors);
            }
            _ => {}
        }
        if let Some(moving) = moving {
            report.hull_points = report.hull_points.map(|n| n + moving.len());
            cloud.positions_world.extend(moving.positions_world);
            cloud.colors.extend(moving.colors);
        }
        let kept: Vec<usize> = (0..cloud.len()).filter(|&i| inside(&cloud.positions_world[i])).collect();
        report.points += kept.len() + borrowed_indices.len();
        report.points_outside_bounds += cloud.len() - kept.len();
        writer.push_cloud_borrowing(&cloud.select(kept), &borrowed_indices)?;
        progress("package", t as u64 + 1, steps as u64);
    }
    writer.finish()?;
    report.bytes = dynview_core::scene::ScenePackage::open(scene_dir)?.size_on_disk()?;
    Ok(report)
}

/// Time steps whose points and frames the color balance is estimated from, spread over the
/// event.
const COLOR_BALANCE_STEPS: usize = 8;

/// Estimates every camera's color balance from the points of up to [`COLOR_BALANCE_STEPS`]
/// steps and stores it in `manifest` (none for a camera the estimate leaves as it is). Returns
/// the number of points used; a camera that shares too few points is named in `warnings`.
fn balance_colors(source_of: &[&Source], manifest: &mut Manifest, warnings: &mut Vec<String>, progress: StageProgress) -> SfmResult<usize> {
    use dynview_core::color_balance::{self, CameraFrame, ColorTransform};
    let steps = source_of.len();
    let chosen: Vec<usize> = (0..COLOR_BALANCE_STEPS.min(steps)).map(|k| k * steps / COLOR_BALANCE_STEPS.min(steps)).collect();
    let mut samples = Vec::new();
    for (done, &t) in chosen.iter().enumerate() {
        progress("color balance", done as u64, chosen.len() as u64);
        let cloud = read_cloud(&cloud_path(&source_of[t].work, t))?;
        let frames: Vec<_> = work_frames(source_of[t], manifest, t)?.iter().map(dynview_core::RgbRaster::from_rgb8).collect();
        let cameras: Vec<CameraFrame> =
            frames.iter().enumerate().map(|(c, frame)| CameraFrame { camera: manifest.camera_at(c, t as u32), frame }).collect();
        samples.extend(color_balance::gather_samples(&cloud, &cameras));
    }
    progress("color balance", chosen.len() as u64, chosen.len() as u64);
    let (maps, counts) = color_balance::estimate(&samples, manifest.cameras.len());
    for ((entry, map), count) in manifest.cameras.iter_mut().zip(maps).zip(counts) {
        if count < color_balance::MIN_SAMPLES {
            warnings.push(format!(
                "camera {}: {count} points shared with other cameras, too few to balance its colors ({} needed): left as it is",
                entry.name,
                color_balance::MIN_SAMPLES
            ));
        }
        entry.color_balance = (map != ColorTransform::IDENTITY).then_some(map);
    }
    Ok(samples.len())
}

/// The working frames of step `t` from its prep output, one per camera of `manifest`.
fn work_frames(source: &Source, manifest: &Manifest, t: usize) -> SfmResult<Vec<image::RgbImage>> {
    manifest.cameras.iter().map(|entry| work_frame(source, &entry.name, t)).collect()
}

/// The working frame of camera `name` at step `t` from its prep output.
fn work_frame(source: &Source, name: &str, t: usize) -> SfmResult<image::RgbImage> {
    let path = frame_path(&source.work, name, t);
    let bytes = std::fs::read(&path).map_err(SfmError::io(&path))?;
    Ok(image::load_from_memory_with_format(&bytes, image::ImageFormat::Png)
        .map_err(|e| SfmError::WorkFile { path: path.clone(), problem: format!("cannot decode the frame: {e}") })?
        .to_rgb8())
}

/// The foreground of each camera's frame of a step against its plate (`None` without a plate,
/// one per frame).
fn step_foregrounds(
    frames: &[image::RgbImage],
    plates: &[Option<crate::dense::Plate>],
    options: &HullOptions,
) -> SfmResult<Vec<Option<Foreground>>> {
    frames
        .iter()
        .enumerate()
        .map(|(c, frame)| plates.get(c).and_then(Option::as_ref).map(|plate| foreground(frame, plate, options)).transpose())
        .collect()
}

/// The own points of step `t` (`own`) less those that float in front of the static scene of the
/// cameras with a foreground and a static depth map ([`crate::dense::free_space`]), and how many
/// were dropped.
fn step_floaters_dropped(
    manifest: &Manifest,
    t: usize,
    foregrounds: &[Option<Foreground>],
    static_depth_maps: &[Option<ScalarRaster>],
    own: &dynview_core::scene::PointCloud,
    options: &FreeSpaceOptions,
) -> (dynview_core::scene::PointCloud, usize) {
    let cameras: Vec<dynview_core::Camera> = (0..foregrounds.len()).map(|c| manifest.camera_at(c, t as u32)).collect();
    let views: Vec<FreeSpaceView> = (0..foregrounds.len())
        .filter_map(|c| {
            let (Some(foreground), Some(Some(depth))) = (&foregrounds[c], static_depth_maps.get(c)) else { return None };
            Some(FreeSpaceView { camera: &cameras[c], foreground, static_depth_m: depth })
        })
        .collect();
    drop_floaters(own, &views, options)
}

/// The visual hull's points of step `t` ([`crate::dense::hull`]) from the cameras with a plate
/// and a static depth range (`frames` and `foregrounds`: the step's, one per camera), `own` the
/// step's own points.
fn step_hull(
    manifest: &Manifest,
    t: usize,
    frames: &[image::RgbImage],
    foregrounds: &[Option<Foreground>],
    static_depth_of: &[Option<(f64, f64)>],
    own: &dynview_core::scene::PointCloud,
    options: &HullOptions,
) -> SfmResult<dynview_core::scene::PointCloud> {
    let mut views = Vec::new();
    for (c, frame) in frames.iter().enumerate() {
        let (Some(foreground), Some(Some((median, far)))) = (&foregrounds[c], static_depth_of.get(c)) else { continue };
        views.push(HullView {
            camera: manifest.camera_at(c, t as u32),
            frame,
            foreground: foreground.clone(),
            median_static_depth_m: *median,
            far_depth_m: *far,
        });
    }
    if views.len() <= options.min_witnesses {
        return Ok(dynview_core::scene::PointCloud::default());
    }
    hull_points(&views, own, options)
}

/// The static cloud of the prepared steps, judged on the package's frames and cameras (read
/// one step at a time).
fn static_cloud(source_of: &[&Source], manifest: &Manifest, options: &StaticOptions, progress: StageProgress) -> SfmResult<StaticCloud> {
    let cameras: Vec<Vec<dynview_core::Camera>> =
        (0..manifest.cameras.len()).map(|c| (0..manifest.time_step_count).map(|t| manifest.camera_at(c, t)).collect()).collect();
    let frames_at = |t: usize| work_frames(source_of[t], manifest, t);
    let candidates = candidate_steps(source_of.len(), options.candidate_steps)
        .into_iter()
        .map(|t| Ok((t, read_cloud(&cloud_path(&source_of[t].work, t))?)))
        .collect::<SfmResult<Vec<_>>>()?;
    progress("static cloud", 0, 1);
    let statics = build_static_cloud(&cameras, frames_at, &candidates, options)?;
    progress("static cloud", 1, 1);
    Ok(statics)
}

/// The background plates of the cameras that stand still (`None` for the others) and the static
/// cloud grown from them, seeded with `seeds` (the static points found across time); no cloud
/// when fewer than two cameras stand still or there are no seeds.
fn static_cloud_from_plates(
    source_of: &[&Source],
    manifest: &Manifest,
    seeds: &dynview_core::scene::PointCloud,
    options: &PlateCloudOptions,
    progress: StageProgress,
) -> SfmResult<(Option<StaticCloud>, Vec<Option<crate::dense::Plate>>)> {
    let cameras: Vec<Vec<dynview_core::Camera>> =
        (0..manifest.cameras.len()).map(|c| (0..manifest.time_step_count).map(|t| manifest.camera_at(c, t)).collect()).collect();
    let frames_at = |t: usize| {
        progress("plates", t as u64, source_of.len() as u64);
        work_frames(source_of[t], manifest, t)
    };
    let mut plates = estimate_plates(&cameras, frames_at, &options.plates)?;
    progress("plates", source_of.len() as u64, source_of.len() as u64);
    progress("static cloud from plates", 0, 1);
    let grown = plate_cloud(&cameras, &mut plates, seeds, |t| work_frames(source_of[t], manifest, t), options)?;
    progress("static cloud from plates", 1, 1);
    Ok((grown, plates))
}

/// The quantisation box: per axis the [`BOUNDS_TAIL_FRACTION`] quantiles of every step's
/// points, widened by [`BOUNDS_MARGIN_FRACTION`]; the camera centres' box when there are no
/// points.
fn choose_bounds(source_of: &[&Source], event: &EventPoses) -> SfmResult<Bounds> {
    // Point counts from the file sizes: no need to decode every cloud an extra time.
    let mut total = 0;
    for (t, s) in source_of.iter().enumerate() {
        let path = cloud_path(&s.work, t);
        total += crate::pipeline::timesteps::cloud_point_count(std::fs::metadata(&path).map_err(SfmError::io(&path))?.len());
    }
    let stride = total.div_ceil(BOUNDS_SAMPLES).max(1);
    let mut axes: [Vec<f32>; 3] = Default::default();
    for (t, s) in source_of.iter().enumerate() {
        for p in read_cloud(&cloud_path(&s.work, t))?.positions_world.iter().step_by(stride) {
            (0..3).for_each(|i| axes[i].push(p[i]));
        }
    }
    if axes[0].is_empty() {
        for c in 0..event.cameras.len() {
            for t in 0..event.time_step_count() {
                if let Some(pose) = event.camera_from_world(c, t) {
                    let center = pose.camera_center_world();
                    (0..3).for_each(|i| axes[i].push(center[i] as f32));
                }
            }
        }
    }
    let mut bounds = Bounds { min: [0.0; 3], max: [0.0; 3] };
    for (i, values) in axes.iter_mut().enumerate() {
        values.sort_by(f32::total_cmp);
        let n = values.len();
        let cut = ((n as f64 * BOUNDS_TAIL_FRACTION) as usize).min(n.saturating_sub(1) / 2);
        let (lo, hi) = (f64::from(values[cut]), f64::from(values[n - 1 - cut]));
        let margin = ((hi - lo) * BOUNDS_MARGIN_FRACTION).max(1e-3);
        bounds.min[i] = lo - margin;
        bounds.max[i] = hi + margin;
    }
    Ok(bounds)
}

/// The manifest: cameras at their working size, poses per step, a start view from the camera
/// nearest the middle of the rig.
fn manifest(event: &EventPoses, settings: &StepSettings, bounds: Bounds, name: &str) -> Manifest {
    let steps = event.time_step_count();
    let cameras: Vec<CameraEntry> = event
        .cameras
        .iter()
        .map(|c| {
            let (width, height) = working_size(c.width, c.height, settings.options.working_width);
            CameraEntry {
                name: c.name.clone(),
                width,
                height,
                intrinsics: resized_intrinsics(&c.intrinsics, (c.width, c.height), (width, height)),
                poses: c.frames.iter().map(|f| f.camera_from_world.unwrap_or(dynview_core::Rigid3::IDENTITY.into())).collect(),
                color_balance: None,
                plate: false,
            }
        })
        .collect();
    let centers: Vec<glam::DVec3> = cameras.iter().map(|c| c.poses[0].camera_from_world().camera_center_world()).collect();
    let mean = centers.iter().copied().sum::<glam::DVec3>() / centers.len().max(1) as f64;
    let start = (0..cameras.len()).min_by(|&a, &b| centers[a].distance(mean).total_cmp(&centers[b].distance(mean))).unwrap_or(0);
    let start_camera = &cameras[start];
    Manifest {
        format: FORMAT_NAME.into(),
        version: FORMAT_VERSION,
        name: name.chars().take(256).collect(),
        fps: settings.fps,
        time_step_count: steps as u32,
        bounds,
        clouds: CloudsEntry { file: "clouds.bin".into(), byte_length: 0 },
        frame_format: FrameFormat::Jpeg,
        frames_index: None,
        start_view: StartView {
            time_step: 0,
            pose: start_camera.poses[0],
            vertical_fov_deg: start_camera.intrinsics.vertical_fov_rad(start_camera.height).to_degrees(),
        },
        cameras,
    }
}

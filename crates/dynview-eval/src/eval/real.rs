//! `cargo xtask eval --real`: leave-one-camera-out on the real captures ([`RealCapture`]: two
//! Panoptic arcs and Pose2Sim). For each camera k left out, `dynview prep` runs on the others
//! (calibrated poses, all frames unless told), and camera k's view is rendered at every time
//! step with the full method and the baselines, and compared with camera k's real frame; the
//! floor is the nearest input camera's own frame shown as is (what a viewer would show without
//! any synthesis). The measures, raw and colour-corrected, over the whole frame and over its
//! static and moving pixels, are in [`scores`]; the report's text in [`report`].
//!
//! Camera k's intrinsics, pose and reference frames come from a package prepared the same way
//! with all cameras: same working size, same undistortion, same (calibrated) world, so no
//! alignment is needed. Results in `docs/results/real.md` and `real_strip_<capture>_<camera>.png`.

mod orbit;
pub mod own_poses;
pub mod register;
mod report;
pub mod rig;
mod run;
pub mod scores;
pub mod unsync;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, bail};
use dynview_core::display::colorize_depth;
use dynview_core::render::sparse::{SplatMaps, project_cloud};
use dynview_core::render::{Method, RenderHooks, RenderParams, StreamingRenderer};
use dynview_core::scene::ScenePackage;
use dynview_core::view_ranking::rank_views;
use dynview_core::{RgbRaster, ScalarRaster};

use crate::align::median;
use crate::datasets::real_captures::RealCapture;
use crate::eval::plane_view::plane_view;
use crate::paths::workspace_root;
use crate::runs::prep::{PrepRun, cloud_point_counts, prep_once, stage_seconds};
use crate::runs::programs::dynview_binary;
use register::HeldOutPose;
use report::{header, markdown};
use rig::Rig;
pub use run::Options;
use run::{CameraResult, METHODS, orbit_strip_name, strip_name, work_folder};
use scores::{MOVING_DILATION_PX, MOVING_THRESHOLD, Score, Sums, moving_mask, temporal_median};

/// The floor's label: the nearest input camera's frame shown as is.
const FLOOR: &str = "nearest input as is";
/// The experimental fallback's label ([`crate::eval::plane_view`]).
const PLANE_VIEW: &str = "plane view";
/// Largest strip PNG wanted, bytes.
const STRIP_MAX_BYTES: usize = 600_000;
/// Width of one strip panel to start from, pixels (shrunk until the PNG fits).
const STRIP_PANEL_WIDTH_PX: u32 = 320;

/// The leave-one-out evaluation: writes `real.md` and one strip per held-out camera into
/// `options.out`.
pub fn run(options: Options) -> anyhow::Result<()> {
    let (captures, work) = captures_and_work(&options)?;
    for capture in captures {
        let held_out = leave_one_out_cameras(capture, &options.held_out)?;
        if held_out.is_empty() {
            println!("==> {}: none of the cameras given with --held-out, skipped", capture.label());
            continue;
        }
        let section = evaluate_capture(capture, &options, &work.join(capture.label()), &held_out)?;
        println!("\n{section}");
        let path = section_path(&work, capture);
        dynview_core::fsutil::write_atomic(&path, section.as_bytes()).with_context(|| format!("writing {}", path.display()))?;
    }
    let mut report = String::from("# Leave-one-camera-out on real captures\n\n");
    report.push_str(&header());
    for capture in RealCapture::ALL {
        let path = section_path(&work, capture);
        match std::fs::read_to_string(&path) {
            Ok(section) => report.push_str(&section),
            Err(_) => {
                let _ = writeln!(report, "## {}\n\nNot evaluated in this run (`--capture {}`).\n", capture.label(), capture.label());
            }
        }
    }
    std::fs::create_dir_all(&options.out)?;
    let path = options.out.join("real.md");
    dynview_core::fsutil::write_atomic(&path, report.as_bytes())?;
    println!("wrote {}", path.display());
    Ok(())
}

/// The captures `options` names (all when none) and the work folder, once every `--held-out`
/// camera is known to one of them.
pub(crate) fn captures_and_work(options: &Options) -> anyhow::Result<(Vec<RealCapture>, PathBuf)> {
    let captures = if options.capture.is_empty() { RealCapture::ALL.to_vec() } else { options.capture.clone() };
    let work = workspace_root().join(work_folder(&options.prep_args));
    let mut known = Vec::new();
    for &capture in &captures {
        known.extend(capture.cameras()?);
    }
    if let Some(unknown) = options.held_out.iter().find(|c| !known.contains(c)) {
        bail!("--held-out {unknown}: no such camera in {}", captures.iter().map(|c| c.label()).collect::<Vec<_>>().join(", "));
    }
    Ok((captures, work))
}

/// The cameras of `capture` to leave out: its interior ones, or those of `requested` it has
/// (none when it has none of them).
pub(crate) fn held_out_cameras(capture: RealCapture, requested: &[String]) -> anyhow::Result<Vec<String>> {
    if requested.is_empty() {
        return capture.held_out();
    }
    let cameras = capture.cameras()?;
    Ok(requested.iter().filter(|c| cameras.contains(c)).cloned().collect())
}

/// The cameras the leave-one-out tables leave out: [`held_out_cameras`], and when none was
/// requested, the arc's highest and lowest camera too ([`off_arc_cameras`]).
fn leave_one_out_cameras(capture: RealCapture, requested: &[String]) -> anyhow::Result<Vec<String>> {
    let mut cameras = held_out_cameras(capture, requested)?;
    if requested.is_empty() {
        for camera in off_arc_cameras(capture)? {
            if !cameras.contains(&camera) {
                cameras.push(camera);
            }
        }
    }
    Ok(cameras)
}

/// The highest and the lowest camera of an arc, seen from the point its cameras look at: left
/// out, each is a view off the others' arc (none for a capture that is no arc).
pub(crate) fn off_arc_cameras(capture: RealCapture) -> anyhow::Result<Vec<String>> {
    let Some(rig) = capture_rig(capture)? else { return Ok(Vec::new()) };
    let (highest, lowest) = rig.highest_and_lowest();
    Ok(vec![highest.name.clone(), lowest.name.clone()])
}

/// The rig of an arc's calibrated cameras; `None` for a capture that is no arc.
fn capture_rig(capture: RealCapture) -> anyhow::Result<Option<Rig>> {
    let Some(arc) = capture.panoptic_arc() else { return Ok(None) };
    let poses = crate::datasets::panoptic::calibration(arc, None)?;
    let cameras: Vec<(String, dynview_core::Rigid3)> =
        poses.cameras.iter().enumerate().filter_map(|(i, c)| poses.camera_from_world(i, 0).map(|pose| (c.name.clone(), pose))).collect();
    Ok(Some(Rig::new(&cameras)?))
}

fn section_path(work: &Path, capture: RealCapture) -> PathBuf {
    work.join(capture.label()).join("section.md")
}

/// What every evaluation of a capture starts from: its frames, the prep arguments, and the
/// reference package of all its cameras.
pub(crate) struct Prepared {
    pub(crate) frames: u32,
    pub(crate) frames_dir: PathBuf,
    pub(crate) dynview: PathBuf,
    pub(crate) prep_args: Vec<String>,
    pub(crate) reference_run: PrepRun,
    pub(crate) reference: ScenePackage,
}

impl Prepared {
    /// Writes `capture`'s frames into `root` and prepares (or reuses) its reference package.
    pub(crate) fn new(capture: RealCapture, options: &Options, root: &Path) -> anyhow::Result<Self> {
        let frames = options.frames.map_or(capture.frame_count(), |f| f.min(capture.frame_count()));
        let frames_dir = root.join(format!("frames{frames}"));
        println!("==> {}: first {frames} frames into {}", capture.label(), frames_dir.display());
        capture.write_frames(&frames_dir, frames)?;
        let dynview = dynview_binary()?;
        let mut prep_args = vec!["--working-width".to_string(), capture.working_width_px().to_string()];
        prep_args.extend(options.prep_args.iter().cloned());
        let all_poses = root.join("poses_all.json");
        capture.write_poses(&all_poses, None)?;
        let mut args = vec!["--poses".to_string(), all_poses.display().to_string()];
        args.extend(prep_args.iter().cloned());
        let reference_run = prep_once(&dynview, &frames_dir, &root.join(format!("all{frames}")), &args, options.fresh)?;
        let reference = open(&reference_run)?;
        Ok(Self { frames, frames_dir, dynview, prep_args, reference_run, reference })
    }

    /// The package of every camera but `held_out`, with the poses `poses` says, in
    /// `root/<poses' prefix>without_<held_out>_<frames>` (or reused).
    pub(crate) fn without(
        &self,
        capture: RealCapture,
        options: &Options,
        root: &Path,
        held_out: &str,
        poses: PosesFrom,
    ) -> anyhow::Result<(PrepRun, ScenePackage)> {
        let dir = root.join(format!("{}without_{held_out}_{}", poses.folder_prefix(), self.frames));
        let cameras = capture.cameras()?;
        let others: Vec<&str> = cameras.iter().filter(|c| *c != held_out).map(String::as_str).collect();
        let input = dir.join("input");
        for camera in &others {
            copy_folder_once(&self.frames_dir.join(camera), &input.join(camera))?;
        }
        let mut args = Vec::new();
        if poses == PosesFrom::Calibration {
            let path = dir.join("poses.json");
            capture.write_poses(&path, Some(&others))?;
            args.extend(["--poses".to_string(), path.display().to_string()]);
        }
        args.extend(self.prep_args.iter().cloned());
        let run = prep_once(&self.dynview, &input, &dir.join("out"), &args, options.fresh)?;
        let package = open(&run)?;
        Ok((run, package))
    }
}

/// Where the poses of a package without a held-out camera come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum PosesFrom {
    /// The capture's calibration (`--poses`).
    Calibration,
    /// Our own structure from motion (no `--poses`).
    OwnSfm,
}

impl PosesFrom {
    fn folder_prefix(self) -> &'static str {
        match self {
            Self::Calibration => "",
            Self::OwnSfm => "own_",
        }
    }
}

/// Prepares the packages of `capture` in `root` and scores every held-out camera; returns the
/// report's section and writes the strips.
fn evaluate_capture(capture: RealCapture, options: &Options, root: &Path, held_out_cameras: &[String]) -> anyhow::Result<String> {
    let prepared = Prepared::new(capture, options, root)?;
    let mut results = Vec::new();
    for held_out in held_out_cameras {
        let (run, package) = prepared.without(capture, options, root, held_out, PosesFrom::Calibration)?;
        let steps = Steps::all(&prepared.reference, &package);
        let params = options.params.clone().unwrap_or_default();
        let (result, strip) = evaluate_camera(held_out, &prepared.reference, &package, &run, &params, steps, &HeldOutPose::CALIBRATED)?;
        write_strip(&options.out.join(strip_name(capture, held_out)), &[&strip[..]])?;
        results.push(result);
    }
    if let Some(rig) = capture_rig(capture)? {
        let step = prepared.reference.time_step_count() / 2;
        let rows = orbit::orbit_rows(&prepared.reference, &rig, step, &options.params.clone().unwrap_or_default())?;
        let rows: Vec<&[RgbRaster]> = rows.iter().map(Vec::as_slice).collect();
        write_strip(&options.out.join(orbit_strip_name(capture)), &rows)?;
    }
    let interior = capture.held_out()?;
    let reference_secs: f64 = stage_seconds(&prepared.reference_run.out)?.iter().map(|(_, s)| s).sum();
    let size = prepared.reference.manifest().cameras.first().map_or((0, 0), |c| (c.width, c.height));
    Ok(markdown(capture, &results, &interior, options, prepared.frames, size, reference_secs))
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

/// The panels of a strip: real frame, nearest input as is, blend, full method, its depth, and
/// the nearest input's background plate (black without one).
type Strip = [RgbRaster; 6];

/// Which time steps of a package are scored, and which of the reference package shows the same
/// moment: reference step = package step + `reference_shift`.
#[derive(Clone, Debug)]
pub(crate) struct Steps {
    /// The package's time steps scored.
    pub(crate) package: std::ops::Range<u32>,
    /// Steps from a package step to the reference's step of the same moment.
    pub(crate) reference_shift: u32,
}

impl Steps {
    /// Every time step both packages have, the same moments.
    fn all(reference: &ScenePackage, package: &ScenePackage) -> Self {
        Self { package: 0..reference.time_step_count().min(package.time_step_count()), reference_shift: 0 }
    }
}

/// The index of camera `name` in `package`.
fn camera_index(package: &ScenePackage, name: &str) -> anyhow::Result<usize> {
    package
        .manifest()
        .cameras
        .iter()
        .position(|c| c.name == name)
        .with_context(|| format!("{}: no camera {name}", package.root().display()))
}

/// Renders camera `held_out` of `reference` from `package` at the time steps of `steps` with
/// each of [`METHODS`] and shows the nearest input as is; returns the scores and the middle
/// frame's strip. The moving pixels of each frame are those that differ from the camera's
/// temporal median over the steps scored ([`scores::moving_mask`]). `pose` puts the
/// reference's camera into the package's world ([`HeldOutPose::CALIBRATED`] where both are
/// calibrated).
fn evaluate_camera(
    held_out: &str,
    reference: &ScenePackage,
    package: &ScenePackage,
    run: &PrepRun,
    defaults: &RenderParams,
    steps: Steps,
    pose: &HeldOutPose,
) -> anyhow::Result<(CameraResult, Strip)> {
    let k = camera_index(reference, held_out)?;
    let shift = steps.reference_shift;
    let scored = steps.package.clone();
    if scored.is_empty() || scored.end > package.time_step_count() || scored.end + shift > reference.time_step_count() {
        bail!("time steps {scored:?} (reference shifted by {shift}) are not in both packages");
    }
    // Every real frame first, for the temporal median (8 bits a channel, as stored).
    let truths: Vec<image::RgbImage> =
        scored.clone().map(|t| reference.read_frame(k, t + shift).map(|f| f.to_rgb8())).collect::<Result<_, _>>()?;
    let median_frame =
        temporal_median(&truths).with_context(|| format!("{}: no frame of camera {held_out}", reference.root().display()))?;
    let mut moving_share = 0.0;
    let mut renderers: Vec<StreamingRenderer> = METHODS.iter().map(|_| StreamingRenderer::new()).collect();
    // The methods', the plane view's, then the floor's.
    let mut sums: Vec<Sums> = (0..METHODS.len() + 2).map(|_| Sums::default()).collect();
    let mut strip = None;
    let mut nearest = String::new();
    let mut render_secs = 0.0;
    let mut truth_before: Option<RgbRaster> = None;
    let mut depth_errors: [Vec<f64>; 2] = [Vec::new(), Vec::new()];
    let blend_index = METHODS.iter().position(|&m| m == Method::Blend).unwrap_or(0);
    let middle = scored.start + scored.len() as u32 / 2;
    for t in scored.clone() {
        let reference_camera = reference.camera(k, t + shift)?;
        let mut camera = reference_camera;
        camera.camera_from_world = pose.camera_from_world(&reference_camera.camera_from_world);
        let truth = RgbRaster::from_rgb8(&truths[(t - scored.start) as usize]);
        let moving = moving_mask(&truth, &median_frame, MOVING_THRESHOLD, MOVING_DILATION_PX);
        moving_share += moving.data.iter().filter(|&&m| m > 0.0).count() as f64 / moving.data.len().max(1) as f64;
        // What the held-out camera's own frame implies: the points of the package prepared with
        // it, as it sees them (z-buffered, the renderer's consistency filter applied).
        let mut own = project_cloud(&reference.read_cloud(t + shift)?, &reference_camera);
        own.drop_inconsistent(defaults.sparse_consistency, None, defaults.sparse_surround_px);
        let inputs = package.time_step_inputs(t, defaults.levels)?;
        let mut shown = Vec::new();
        for (m, &method) in METHODS.iter().enumerate() {
            let params = RenderParams { method, ..defaults.clone() };
            let start = Instant::now();
            let out = renderers[m].render(&params, &camera, &inputs, &mut RenderHooks::default())?;
            if method == Method::Full {
                render_secs += start.elapsed().as_secs_f64();
            }
            shown.push((out.color, out.depth));
        }
        for (errors, m) in depth_errors.iter_mut().zip([0, blend_index]) {
            errors.extend(relative_depth_errors(&shown[m].1, &own, pose.package_from_reference.scale));
        }
        // The inputs already hold every input camera, frame and the cloud of this step.
        let input_poses: Vec<_> = inputs.views.iter().map(|v| v.camera.camera_from_world).collect();
        let j = rank_views(&camera.camera_from_world, &input_poses, f64::from(defaults.rank_sigma), 1)
            .first()
            .copied()
            .context("the package has no camera")?;
        let nearest_view = &inputs.views[j];
        // As stored: the renderer's inputs carry the package's color balance.
        let nearest_frame = package.read_frame(j, t)?;
        let plane = plane_view(&camera, &inputs.cloud, &nearest_view.camera, &nearest_frame);
        let floor = resized(nearest_frame, truth.width, truth.height);
        if t == middle {
            nearest.clone_from(&package.manifest().cameras[j].name);
            let full = &shown[0];
            let blend = &shown[METHODS.iter().position(|&m| m == Method::Blend).unwrap_or(0)].0;
            let plate = match package.plate(j)? {
                Some(plate) => resized(plate.as_ref().clone(), truth.width, truth.height),
                None => RgbRaster::filled(truth.width, truth.height, [0.0; 3]),
            };
            strip = Some([truth.clone(), floor.clone(), blend.clone(), full.0.clone(), colorize_depth(&full.1), plate]);
        }
        // In the order of `sums`; scored in parallel (SSIM twice per image is the slow part).
        let mut outputs: Vec<RgbRaster> = shown.into_iter().map(|(color, _)| color).collect();
        outputs.push(plane.unwrap_or_else(|| floor.clone()));
        outputs.push(floor);
        std::thread::scope(|scope| {
            for (sum, output) in sums.iter_mut().zip(outputs) {
                let (truth, truth_before, moving) = (&truth, truth_before.as_ref(), &moving);
                scope.spawn(move || sum.add(output, truth, truth_before, moving));
            }
        });
        truth_before = Some(truth);
    }
    let mut scores: Vec<Score> = METHODS.iter().zip(&sums).map(|(m, s)| s.score(m.label())).collect();
    scores.push(sums[METHODS.len()].score(PLANE_VIEW));
    scores.push(sums[METHODS.len() + 1].score(FLOOR));
    for s in &scores {
        println!(
            "{held_out} held out, {}: PSNR {:.2} dB (colour-corrected {:.2}), SSIM {:.4} ({:.4}), static / moving PSNR {:.2} / {:.2} dB ({:.2} / {:.2}), static / moving SSIM {:.4} / {:.4} ({:.4} / {:.4}), flicker {:.2}",
            s.label,
            s.psnr_db.raw,
            s.psnr_db.corrected,
            s.ssim.raw,
            s.ssim.corrected,
            s.static_psnr_db.raw,
            s.moving_psnr_db.raw,
            s.static_psnr_db.corrected,
            s.moving_psnr_db.corrected,
            s.static_ssim.raw,
            s.moving_ssim.raw,
            s.static_ssim.corrected,
            s.moving_ssim.corrected,
            s.flicker * 1000.0
        );
    }
    let n = f64::from(scored.len().max(1) as u32);
    let prep_secs = stage_seconds(&run.out)?.iter().map(|(_, s)| s).sum();
    let points_per_step = cloud_point_counts(package).0 as f64 / n;
    let depth_error_pct = depth_errors.map(|e| median(&e) * 100.0);
    let result = CameraResult {
        name: held_out.to_string(),
        scores,
        nearest,
        prep_secs,
        ms_per_frame: render_secs * 1000.0 / n,
        points_per_step,
        depth_error_pct,
        moving_pct: moving_share * 100.0 / n,
    };
    Ok((result, strip.context("no time step rendered")?))
}

/// `|rendered / scale - own| / own` at every pixel where `own` has a point (sizes must match;
/// `scale`: the rendered world's units per the reference's).
fn relative_depth_errors<'a>(rendered: &'a ScalarRaster, own: &'a SplatMaps, scale: f64) -> impl Iterator<Item = f64> + 'a {
    own.mask
        .data
        .iter()
        .zip(&own.depth.data)
        .zip(&rendered.data)
        .filter(|((m, d), _)| **m > 0.0 && d.is_finite() && **d > 0.0)
        .map(move |((_, d), r)| (f64::from(*r) / scale - f64::from(*d)).abs() / f64::from(*d))
}

/// `image` at `width x height` (bilinear), or as it is when it has that size.
fn resized(image: RgbRaster, width: usize, height: usize) -> RgbRaster {
    if (image.width, image.height) == (width, height) {
        return image;
    }
    let small = image::imageops::resize(&image.to_rgb8(), width as u32, height as u32, image::imageops::FilterType::Triangle);
    RgbRaster::from_rgb8(&small)
}

/// Writes the rows of panels one above the other, each panel downscaled until the PNG stays
/// under [`STRIP_MAX_BYTES`] (every panel the size of the first).
fn write_strip(path: &Path, rows: &[&[RgbRaster]]) -> anyhow::Result<()> {
    let Some(first) = rows.first().and_then(|r| r.first()) else { bail!("{}: a strip without panels", path.display()) };
    let columns = rows.iter().map(|r| r.len()).max().unwrap_or(0) as u32;
    let mut panel_width = STRIP_PANEL_WIDTH_PX;
    loop {
        let (w, h) = (panel_width, (first.height as f64 * f64::from(panel_width) / first.width as f64).round() as u32);
        let mut strip = image::RgbImage::new(w * columns, h * rows.len() as u32);
        for (r, row) in rows.iter().enumerate() {
            for (k, panel) in row.iter().enumerate() {
                let small = image::imageops::resize(&panel.to_rgb8(), w, h, image::imageops::FilterType::Triangle);
                image::imageops::replace(&mut strip, &small, i64::from(k as u32 * w), i64::from(r as u32 * h));
            }
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

#[cfg(test)]
mod tests {
    use super::run::parse_params;
    use super::*;

    #[test]
    fn extra_prep_arguments_get_a_work_folder_of_their_own() {
        assert_eq!(work_folder(&[]), "target/eval/real");
        let args = ["--no-static".to_string(), "--target-points".to_string(), "4000".to_string()];
        assert_eq!(work_folder(&args), "target/eval/real+no_static+target_points+4000");
        assert_eq!(work_folder(&["../x y".to_string()]), "target/eval/real+.._x_y");
    }

    #[test]
    fn renderer_parameters_come_as_json_or_a_file_and_are_checked() {
        assert_eq!(parse_params(r#"{"lambda_plane": 0}"#).unwrap().lambda_plane, 0.0);
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("p.json");
        std::fs::write(&file, r#"{"sparse_footprint_px": 1}"#).unwrap();
        assert_eq!(parse_params(file.to_str().unwrap()).unwrap().sparse_footprint_px, 1);
        assert!(parse_params(r#"{"relaxation": 3}"#).unwrap_err().contains("relaxation"));
        assert!(parse_params("{not json").unwrap_err().contains("renderer parameters"));
    }

    #[test]
    fn depth_errors_are_taken_in_the_reference_world() {
        let mut own = SplatMaps {
            depth: ScalarRaster::filled(2, 1, f32::INFINITY),
            color: RgbRaster::filled(2, 1, [0.0; 3]),
            mask: ScalarRaster::filled(2, 1, 0.0),
        };
        own.depth.data[0] = 2.0;
        own.mask.data[0] = 1.0;
        // A world three times larger renders three times the depth: no error in the reference's.
        let rendered = ScalarRaster { width: 2, height: 1, data: vec![6.0, 9.0] };
        let errors: Vec<f64> = relative_depth_errors(&rendered, &own, 3.0).collect();
        assert_eq!(errors.len(), 1, "only where the reference has a point");
        assert!(errors[0].abs() < 1e-12);
        let errors: Vec<f64> = relative_depth_errors(&rendered, &own, 1.0).collect();
        assert!((errors[0] - 2.0).abs() < 1e-12);
    }
}

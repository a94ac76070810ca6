//! `dynview prep`: a scene package from one video or image folder per camera.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use anyhow::{Context, bail};
use std::ops::Range;

use dynview_sfm::dense::densify::DensifyOptions;
use dynview_sfm::dense::hull::{ForegroundModel, HullOptions};
use dynview_sfm::dense::plate_cloud::PlateCloudOptions;
use dynview_sfm::input::timing::SyncMethod;
use dynview_sfm::input::timing::retime::Retime;
use dynview_sfm::mapping::step_adjust::StepAdjustOptions;
use dynview_sfm::mapping::step_placement::StepPlacementOptions;
use dynview_sfm::pipeline::timesteps::StepOptions;
use dynview_sfm::{PrepOptions, Stage};

use crate::progress::StageBars;

/// Arguments of `dynview prep`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Folder with one video (mp4, mov, ...) or one folder of images per camera; camera names
    /// come from the file or folder names. Video frames are placed in time by their
    /// timestamps (mixed and variable frame rates, portrait phones shown upright); see `--sync`
    /// and `--offsets` for cameras that did not start together.
    #[arg(long)]
    input: PathBuf,
    /// Output folder: `scene/` (the scene package), `poses.json`, `report.json`, and `work/`
    /// with every stage's result (a re-run skips finished stages).
    #[arg(long)]
    out: PathBuf,
    /// Every N-th frame of every camera is a keyframe of the structure from motion (kappa).
    #[arg(long, default_value_t = PrepOptions::default().keyframe_interval)]
    keyframe_interval: usize,
    /// Make different frame counts an error (by default every camera is cut to the shortest,
    /// with a warning).
    #[arg(long)]
    strict_frame_counts: bool,
    /// Known focal length in pixels: `PX` for every camera or `CAMERA=PX` for one (repeatable),
    /// kept as given. Focal lengths not given are estimated; on an arc of cameras one given focal
    /// also fixes the others' common scale.
    #[arg(long, value_name = "PX|CAMERA=PX")]
    focal: Vec<String>,
    /// Weight of the smoothness priors on camera paths (0: off).
    #[arg(long, default_value_t = PrepOptions::default().refine.smoothness)]
    smoothness: f64,
    /// Most SIFT features per image.
    #[arg(long, default_value_t = PrepOptions::default().features.max_features)]
    max_features: usize,
    /// Known poses: a COLMAP model folder (text or binary), a poses.json, or a calibration
    /// `dynview import` reads (Qualisys .qca.txt, Middlebury *_par.txt); pose estimation is
    /// skipped (calibrated rigs, ground truth, earlier COLMAP results). Image names
    /// `<camera>/<frame file>`; one pose per frame or one per camera.
    #[arg(long, value_name = "MODEL_DIR|POSES_JSON|CALIBRATION")]
    poses: Option<PathBuf>,
    /// Known intrinsics and distortion of every camera, a COLMAP model folder or a poses.json
    /// (its poses are ignored): frames are undistorted first and the intrinsics kept fixed.
    #[arg(long, value_name = "MODEL_DIR|POSES_JSON")]
    intrinsics: Option<PathBuf>,
    /// Refine the radial distortion (k1, k2) in the final bundle adjustment.
    #[arg(long)]
    refine_distortion: bool,
    /// Keep principal points at the image centre (by default the final bundle adjustment
    /// refines them where the data fix them better than 1.5% of the image's longer side; the
    /// report's `intrinsics_refined` says which and why).
    #[arg(long)]
    centred_principal_point: bool,
    /// Match every keyframe pair exactly (brute force). By default only pairs of up to 4
    /// million descriptor comparisons (about 2000 features an image) are, the others through
    /// FLANN's kd-trees: exact matching is more accurate and several times slower on large
    /// images.
    #[arg(long)]
    exact_matching: bool,
    /// Cauchy loss scale of bundle adjustment, in pixels: observations much farther than this
    /// from where their point projects weigh little. On sharp, lossless frames (keyframe RMS
    /// error near 0.1 px) 0.25 gave better poses and intrinsics; from videos it helped two of
    /// three synthetic arcs and cost the third 2.5 dB (docs/results/sfm.md).
    #[arg(long, value_name = "PX", default_value_t = PrepOptions::default().mapper.loss_scale_px, value_parser = parse_loss_scale)]
    loss_scale: f64,
    /// Cameras of one image size share one set of intrinsics (one camera model filmed
    /// everything). By default every camera has its own: equal image sizes say nothing about
    /// equal lenses or zoom.
    #[arg(long)]
    shared_intrinsics: bool,
    /// Time steps, spread over the capture, whose own cross-camera points refine every camera's
    /// intrinsics and the poses after the frame-to-frame refinement (0: the keyframes'
    /// intrinsics are kept).
    #[arg(long, default_value_t = StepAdjustOptions::default().samples)]
    adjust_steps: usize,
    /// Where every camera stands still, only points at least this many cameras see join the
    /// time-step adjustment (0: still rigs keep the keyframes' intrinsics and poses).
    #[arg(long, value_name = "N", default_value_t = StepAdjustOptions::default().still_rig_min_cameras)]
    adjust_still_min_cameras: usize,
    /// On a still rig, keep the first pass of the time-step adjustment (over points three
    /// cameras or more see) without the settling pass over every point.
    #[arg(long)]
    no_adjust_settle: bool,
    /// On a still rig whose keyframes left the principal points at the image centre, the
    /// time-step adjustment refines them only where it fixes every camera's to this share of
    /// its longer side (standard deviation; 0: never).
    #[arg(long, value_name = "FRACTION", default_value_t = StepAdjustOptions::default().still_principal_point_fraction)]
    adjust_still_principal_points: f64,
    /// Time steps, spread over the capture, whose points place the still cameras the keyframes
    /// left out (their matches with the placed cameras, pooled; a pose kept only where what
    /// moves supports it). 0: such cameras are left out.
    #[arg(long, value_name = "N", default_value_t = StepPlacementOptions::default().samples)]
    place_steps: usize,
    /// The last stage to run: frames, keyframes, poses, points or package.
    #[arg(long, default_value = "package")]
    stop_after: Stage,
    /// Package frames are downscaled to at most this width (px).
    #[arg(long, default_value_t = StepOptions::default().working_width)]
    working_width: u32,
    /// Points per time step after densification (fewer: a smaller package).
    #[arg(long, default_value_t = DensifyOptions::default().target_points)]
    target_points: usize,
    /// Keep only the triangulated points (no densification).
    #[arg(long)]
    no_densify: bool,
    /// Longest side (px) of the frames while densifying (PatchMatch stereo).
    #[arg(long, default_value_t = DensifyOptions::default().max_side_px as u32, value_parser = clap::value_parser!(u32).range(16..=4096))]
    densify_max_side: u32,
    /// Source views each view is matched against while densifying (closest optical axes first).
    #[arg(long, default_value_t = DensifyOptions::default().source_views as u32, value_parser = clap::value_parser!(u32).range(1..=8))]
    densify_source_views: u32,
    /// Each time step keeps only its own points (no static points accumulated across time).
    #[arg(long)]
    no_static: bool,
    /// No static cloud grown by stereo on the background plates of the cameras that stand
    /// still (by default it replaces the static points found across time, which seed it).
    #[arg(long)]
    no_plates: bool,
    /// Keep each plate as estimated (the colour each pixel showed longest): by default, where
    /// someone stood in front of the background longer than it was seen and the static points
    /// other cameras see show one of the pixel's other colours (seen in at least 15% of the
    /// frames), that colour is the plate's (docs/PREP.md).
    #[arg(long, conflicts_with = "no_plates")]
    no_plate_repair: bool,
    /// The least share of the frames a pixel's other colour must have been seen in for the
    /// plate repair to take it (0 to 1; 0 repairs nothing, as `--no-plate-repair`).
    #[arg(long, default_value_t = PlateCloudOptions::default().repair_min_share, conflicts_with = "no_plate_repair")]
    plate_repair_min_share: f32,
    /// Drop a point of the static cloud grown from the plates that as many cameras contradict
    /// as see it: it stands in front of everything else they see there, and their plates show
    /// another colour (stereo matched a pattern at the wrong depth).
    #[arg(long, conflicts_with = "no_plates")]
    plate_contradiction: bool,
    /// Other plates' depth maps that must agree with a pixel of a plate's for it to become a
    /// point of the static cloud grown from the plates (the stereo's consistency test).
    #[arg(long, default_value_t = PlateCloudOptions::default().densify.min_consistent_views, conflicts_with = "no_plates")]
    plate_consistent_views: usize,
    /// Other plates' depth maps that must agree with a plate pixel where more than this many
    /// were matched where its point lands, for it to become a point (0: off; never fewer than
    /// `--plate-consistent-views`, which alone applies where fewer were matched).
    #[arg(long, default_value_t = PlateCloudOptions::default().densify.consistent_views_where_matched, conflicts_with = "no_plates")]
    plate_matched_views: usize,
    /// No points from the visual hull of what moves (by default, with plates of four cameras
    /// or more, rays through each camera's foreground give moving things without stereo points
    /// a depth where they enter the space every other camera's foreground allows).
    #[arg(long)]
    no_hull: bool,
    /// No plates made per step for the cameras without one of their own (hand-held ones): by
    /// default their frames a few steps around each step, carried through the scene's depth,
    /// give them a plate, and their foregrounds join the visual hull (docs/results/moving.md).
    #[arg(long, conflicts_with = "no_hull")]
    no_moving_plates: bool,
    /// Fewest rays of the visual hull a connected region of a camera's foreground gets: small
    /// ones (a ball far from the cameras) are sampled more finely, down to every pixel. Off (0)
    /// by default: on the synthetic events 400 brings a plain 30 cm ball's depth error from 5.2%
    /// to 1.9% and the full method up by about 0.5 dB, but on the real Panoptic arcs its SSIM
    /// falls and arc 2's moving regions lose, however small the regions it is kept to
    /// (docs/results/moving.md).
    #[arg(long, value_name = "RAYS", default_value_t = 0, conflicts_with = "no_hull")]
    hull_region_rays: usize,
    /// Cells of the visual hull's ray grid around a hull point whose own stereo points move it
    /// from where its ray enters the hull onto their surface (a plain shirt between a textured
    /// face and arms, a flat face between matched edges); 0 leaves hull points where their rays
    /// enter the hull (docs/results/moving.md).
    #[arg(long, value_name = "CELLS", default_value_t = HullOptions::default().own_point_reach, conflicts_with = "no_hull")]
    hull_own_reach: usize,
    /// How each still camera's foreground (what differs from its background plate) is found,
    /// for the visual hull and for dropping points that float in free space: `soft` (a
    /// probability from colour and texture; a pixel it is unsure of does not carve the hull) or
    /// `difference` (a colour difference above a tolerance). See docs/results/moving.md.
    #[arg(long, value_name = "MODEL", default_value_t = ForegroundModel::default())]
    foreground: ForegroundModel,
    /// Mean absolute RGB difference from the plate (colours 0 to 1) above which a pixel is
    /// foreground; with `--foreground soft`, where its colour cue is certain (the cue starts at
    /// 0.05, and a pixel is foreground from half way).
    #[arg(long, value_name = "DIFFERENCE", default_value_t = HullOptions::default().foreground_tolerance, conflicts_with = "no_hull")]
    foreground_tolerance: f32,
    /// No shadow cue: by default, with `--foreground soft`, a pixel darker than its plate by one
    /// gain in every channel (to 35-95%), where the plate has texture and the frame keeps it,
    /// counts as a shadow on the background, not as something in front of it
    /// (docs/results/moving.md).
    #[arg(long, conflicts_with = "no_hull")]
    no_foreground_shadows: bool,
    /// Keep the steps' own points that float in front of the static scene where two or more
    /// still cameras see their background plate (by default they are dropped: nothing stands
    /// where a camera looking through it sees the wall behind).
    #[arg(long)]
    no_free_space: bool,
    /// Store every camera's frames as they are: no color balance between the cameras (by
    /// default each camera's colors are mapped to the response the cameras share, estimated
    /// from the points they see in common).
    #[arg(long)]
    no_color_balance: bool,
    #[command(flatten)]
    frames_as: crate::commands::frames::FrameArgs,
    /// Only time steps A..B (B excluded, from 0) after the pose stage, and no package: a range
    /// job of a scheduler array; `dynview merge` joins the ranges into the package.
    #[arg(long, value_name = "A..B", value_parser = parse_range)]
    frames: Option<Range<usize>>,
    /// Time steps per second of the package (default: the slowest camera's frame rate, or 30
    /// where that is 29.97 and most cameras film at 30; image
    /// folders count as this rate, else 30).
    #[arg(long)]
    fps: Option<f64>,
    /// How the cameras' clocks are found: `audio` (from their sound: onset envelopes for a
    /// coarse offset, GCC-PHAT refined below a sample, drift from windows along the recording,
    /// all pairs solved together), `visual` (from the pictures: the offsets at which what moves
    /// agrees with the calibration of `--poses`, or without it with the cameras placed from the
    /// static scene first; cameras on tripods), `none` (every camera taken
    /// to have started with the others), or `auto` (`audio` when every camera is a video with a
    /// sound track, else `visual` when `--poses` is given and the recordings differ in length,
    /// else `none`). `report.json`'s `time_alignment` says what was found.
    #[arg(long, default_value = "auto", value_name = "auto|audio|visual|none")]
    sync: SyncMethod,
    /// With `--sync visual`: the largest offset (s) looked for between two cameras (the time
    /// taken grows with it).
    #[arg(long, value_name = "SECONDS", default_value_t = dynview_sfm::input::timing::visual::VisualOptions::default().max_offset_s, value_parser = parse_max_offset)]
    sync_max_offset: f64,
    /// The package's first time step at SECONDS of CAMERA's video (by default where the last
    /// camera to start starts); it must lie in the stretch every camera filmed.
    #[arg(long, value_name = "CAMERA=SECONDS", value_parser = parse_start_at)]
    start_at: Option<(String, f64)>,
    /// The time (s) in CAMERA's video of one moment every camera filmed (a clap), given for
    /// every camera (repeatable): the clocks by hand, instead of `--sync`.
    #[arg(long, value_name = "CAMERA=SECONDS")]
    offsets: Vec<String>,
    /// How a time step gets the frame of a camera that did not film at its moment: `flow` (made
    /// from the frames filmed before and after it, moved along the optical flow between them)
    /// or `nearest` (the frame filmed nearest to it, as it is). Synchronized cameras film every
    /// step's moment and are not affected.
    #[arg(long, default_value = "flow", value_name = "flow|nearest")]
    retime: Retime,
}

/// `--offsets` as a map; a camera given twice with different times is an error.
fn parse_offsets(values: &[String]) -> anyhow::Result<BTreeMap<String, f64>> {
    let mut offsets = BTreeMap::new();
    for v in values {
        let (camera, seconds) = v.split_once('=').with_context(|| format!("--offsets {v:?}: expected CAMERA=SECONDS"))?;
        let seconds: f64 = seconds
            .trim()
            .parse()
            .ok()
            .filter(|s: &f64| s.is_finite())
            .with_context(|| format!("--offsets {v:?}: {seconds:?} is not a time in seconds"))?;
        if let Some(earlier) = offsets.insert(camera.trim().to_string(), seconds)
            && earlier != seconds
        {
            bail!("--offsets: camera {camera} is given twice, at {earlier} s and at {seconds} s");
        }
    }
    Ok(offsets)
}

fn parse_loss_scale(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(px) if px.is_finite() && (0.01..=100.0).contains(&px) => Ok(px),
        _ => Err(format!("{text:?}: expected pixels between 0.01 and 100, e.g. 0.5")),
    }
}

fn parse_start_at(text: &str) -> Result<(String, f64), String> {
    let (camera, seconds) = text.split_once('=').ok_or_else(|| format!("{text:?}: expected CAMERA=SECONDS"))?;
    match seconds.trim().parse::<f64>() {
        Ok(s) if s.is_finite() => Ok((camera.trim().to_string(), s)),
        _ => Err(format!("{text:?}: {seconds:?} is not a time in seconds")),
    }
}

fn parse_max_offset(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(s) if s.is_finite() && (0.05..=600.0).contains(&s) => Ok(s),
        _ => Err(format!("{text:?}: expected seconds between 0.05 and 600")),
    }
}

fn parse_range(text: &str) -> Result<Range<usize>, String> {
    let (a, b) = text.split_once("..").ok_or_else(|| format!("{text:?}: expected A..B, e.g. 0..100"))?;
    let parse = |s: &str| s.trim().parse::<usize>().map_err(|_| format!("{text:?}: {s:?} is not a frame number"));
    Ok(parse(a)?..parse(b)?)
}

fn parse_focal(values: &[String]) -> anyhow::Result<(BTreeMap<String, f64>, Option<f64>)> {
    let (mut per_camera, mut all) = (BTreeMap::new(), None);
    for v in values {
        let parse = |s: &str| s.parse::<f64>().with_context(|| format!("--focal {v:?}: expected PX or CAMERA=PX"));
        match v.split_once('=') {
            Some((camera, px)) => {
                per_camera.insert(camera.to_string(), parse(px)?);
            }
            None => all = Some(parse(v)?),
        }
    }
    Ok((per_camera, all))
}

/// Runs `dynview prep`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let (focal_px, focal_px_all) = parse_focal(&args.focal)?;
    let mut options = PrepOptions {
        keyframe_interval: args.keyframe_interval,
        trim: !args.strict_frame_counts,
        focal_px,
        focal_px_all,
        stop_after: args.stop_after,
        poses: args.poses,
        intrinsics: args.intrinsics,
        frames: args.frames,
        fps: args.fps,
        sync: args.sync,
        offsets_s: parse_offsets(&args.offsets)?,
        start_at: args.start_at,
        retime: args.retime,
        ..PrepOptions::default()
    };
    options.steps.working_width = args.working_width;
    if args.no_static {
        options.package.static_cloud = None;
    }
    if args.no_plates {
        options.package.plates = None;
    }
    if !(0.0..=1.0).contains(&args.plate_repair_min_share) {
        bail!("--plate-repair-min-share must be between 0 and 1, found {}", args.plate_repair_min_share);
    }
    if args.plate_consistent_views == 0 {
        bail!("--plate-consistent-views must be at least 1");
    }
    if let Some(plates) = options.package.plates.as_mut() {
        plates.repair_min_share = if args.no_plate_repair { 0.0 } else { args.plate_repair_min_share };
        plates.drop_contradicted = args.plate_contradiction;
        plates.densify.min_consistent_views = args.plate_consistent_views;
        plates.densify.consistent_views_where_matched = args.plate_matched_views;
    }
    if !(0.0..=1.0).contains(&args.adjust_still_principal_points) {
        bail!("--adjust-still-principal-points must be between 0 and 1, found {}", args.adjust_still_principal_points);
    }
    if !(args.foreground_tolerance > 0.0 && args.foreground_tolerance < 1.0) {
        bail!("--foreground-tolerance must lie between 0 and 1 (exclusive), found {}", args.foreground_tolerance);
    }
    if args.no_hull {
        options.package.hull = None;
    }
    if let Some(hull) = options.package.hull.as_mut() {
        hull.min_region_rays = args.hull_region_rays;
        hull.own_point_reach = args.hull_own_reach;
        hull.foreground_model = args.foreground;
        hull.foreground_tolerance = args.foreground_tolerance;
        hull.shadows = !args.no_foreground_shadows;
    }
    if args.no_free_space {
        options.package.free_space = None;
    }
    options.package.moving_plates = !args.no_moving_plates;
    options.package.video = args.frames_as.video();
    options.package.format_v1 = args.frames_as.format_v1();
    options.package.color_balance = !args.no_color_balance;
    options.steps.densify = (!args.no_densify).then(|| DensifyOptions {
        target_points: args.target_points,
        max_side_px: args.densify_max_side as usize,
        source_views: args.densify_source_views as usize,
        ..DensifyOptions::default()
    });
    options.mapper.refine_distortion = args.refine_distortion;
    options.mapper.refine_principal_point = !args.centred_principal_point;
    options.mapper.share_intrinsics = args.shared_intrinsics;
    options.mapper.loss_scale_px = args.loss_scale;
    if args.exact_matching {
        options.matching.exact_max_comparisons = usize::MAX;
    }
    options.visual_sync.max_offset_s = args.sync_max_offset;
    options.refine.smoothness = args.smoothness;
    options.step_adjust.samples = args.adjust_steps;
    options.step_adjust.still_rig_min_cameras = args.adjust_still_min_cameras;
    options.step_adjust.settle = !args.no_adjust_settle;
    options.step_adjust.still_principal_point_fraction = args.adjust_still_principal_points;
    options.step_placement.samples = args.place_steps;
    options.features.max_features = args.max_features;
    let interrupt = Arc::new(AtomicBool::new(false));
    let flag = interrupt.clone();
    // A second Ctrl-C while a stage winds down exits at once.
    let _ = ctrlc::set_handler(move || {
        if flag.swap(true, Ordering::SeqCst) {
            std::process::exit(130);
        }
        eprintln!("\ninterrupted: finishing the current item; finished stages are kept");
    });
    let bars = StageBars::new();
    let started = std::time::Instant::now();
    let result = dynview_sfm::run(&args.input, &args.out, &options, &|stage, done, total| bars.update(stage, done, total), &interrupt);
    bars.finish();
    let report = match result {
        Ok(report) => report,
        Err(dynview_sfm::SfmError::Interrupted) => bail!("interrupted; re-run the same command to continue from the last finished stage"),
        Err(e) => return Err(e).with_context(|| format!("dynview prep --input {}", args.input.display())),
    };
    println!("{} cameras x {} frames", report.cameras, report.frames);
    if let Some(time) = &report.time_alignment {
        let made: usize = time.cameras.values().map(|c| c.retimed).sum();
        println!(
            "timeline ({}): {} time steps at {:.3} fps, filmed frames at most {:.1} ms from their step{}",
            time.method,
            time.steps,
            time.fps,
            time.max_error_s * 1e3,
            if made > 0 { format!("; {made} frames made for the steps' moments (--retime)") } else { String::new() }
        );
        if time.method != "none" || time.cameras.values().any(|c| c.rate != 1.0 || c.start_s.abs() > 1e-6) {
            for (name, c) in &time.cameras {
                println!(
                    "  {name}: first step at {:.4} s of its video, clock rate {:.6}, {:.2} fps, confidence {:.2}{}",
                    c.start_s,
                    c.rate,
                    c.fps,
                    c.confidence,
                    if c.retimed > 0 { format!(", {} frames made", c.retimed) } else { String::new() }
                );
            }
        }
    }
    if !report.skipped.is_empty() {
        println!("reused from an earlier run: {}", report.skipped.join(", "));
    }
    if report.keyframes > 0 {
        println!(
            "keyframes: {}/{} registered, {} points, RMS reprojection error {:.3} px",
            report.keyframes_registered, report.keyframes, report.keyframe_points, report.keyframe_rms_px
        );
        if !report.keyframes_placed_from_pair.is_empty() {
            println!("  placed from a verified pair (too few shared points for PnP): {}", report.keyframes_placed_from_pair.join(", "));
        }
        for (camera, source) in report.focal_source.iter().enumerate() {
            let result = report.intrinsics_refined.get(camera).map_or(String::new(), |note| format!("; {note}"));
            println!("  camera {camera}: focal from {source}{result}");
        }
    }
    for (camera, r) in report.refine.iter().enumerate() {
        if r.still {
            println!("  camera {camera} stands still: its keyframes' pose for every frame");
            continue;
        }
        println!(
            "  refined: {} frames by PnP, {} from neighbours, {} observations, RMS {:.3} px",
            r.frames_with_pnp, r.frames_interpolated, r.observations, r.rms_px
        );
    }
    if let Some(a) = &report.step_adjustment {
        println!(
            "adjusted over {} time steps: {} points ({} cameras or more), {} observations, RMS {:.3} -> {:.3} px; focal changes {}",
            a.steps.len(),
            a.points,
            a.min_track_cameras,
            a.observations,
            a.rms_px[0],
            a.rms_px[1],
            a.focal_change_percent.iter().map(|p| format!("{p:+.2}%")).collect::<Vec<_>>().join(" ")
        );
        if let Some(s) = &a.settled {
            println!(
                "  then settled over every point: {} points, {} observations, RMS {:.3} -> {:.3} px",
                s.points, s.observations, s.rms_px[0], s.rms_px[1]
            );
        }
    }
    if let Some(steps) = &report.steps {
        let mean = |v: &[usize]| v.iter().sum::<usize>() as f64 / v.len().max(1) as f64;
        println!(
            "time steps: {} computed, {} reused; {:.0} points per step triangulated, {:.0} after densification",
            steps.computed,
            steps.skipped,
            mean(&steps.sparse_points),
            mean(&steps.points)
        );
    }
    for (stage, secs) in &report.stage_seconds {
        println!("  {stage:<24} {secs:>8.1} s");
    }
    if let Some(path) = &report.poses_file {
        println!("wrote {}", path.display());
    }
    if let (Some(dir), Some(package)) = (&report.package_dir, &report.package) {
        println!(
            "wrote {} ({} cameras x {} time steps, {} points, {:.1} MB)",
            dir.display(),
            package.cameras,
            package.time_steps,
            package.points,
            package.bytes as f64 / 1e6
        );
        if let Some(statics) = package.static_points {
            println!(
                "static cloud: {statics} points, {:.0} lent to each time step on average",
                package.borrowed_points as f64 / package.time_steps.max(1) as f64
            );
        }
        if let Some(repaired) = package.repaired_plate_pixels.filter(|&n| n > 0) {
            println!("plates: {repaired} pixels repaired where someone stood longer than the background was seen");
        }
        if !package.color_changes.is_empty() {
            let changes: Vec<String> = package.color_changes.iter().map(|(name, change)| format!("{name} {change:.0}")).collect();
            println!(
                "color balance from {} points seen by several cameras; largest change per camera (8-bit code values): {}",
                package.color_samples,
                changes.join(", ")
            );
        }
    } else if report.steps.is_some() {
        println!("time steps written to {}; join ranges with `dynview merge`", args.out.join("work/steps").display());
    }
    for warning in &report.warnings {
        eprintln!("warning: {warning}");
    }
    println!("total {:.1} s", started.elapsed().as_secs_f64());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::{parse_loss_scale, parse_offsets};

    #[test]
    fn offsets_are_per_camera_seconds_and_contradictions_are_named() {
        let given = parse_offsets(&["a=1.5".into(), "b=-0.25".into(), "a=1.5".into()]).expect("offsets");
        assert_eq!(given.len(), 2);
        assert_eq!(given["b"], -0.25);
        let err = parse_offsets(&["a=1.5".into(), "a=2".into()]).expect_err("twice").to_string();
        assert!(err.contains("camera a") && err.contains("twice"), "{err}");
        for bad in ["a", "a=soon", "a=NaN"] {
            let err = parse_offsets(&[bad.into()]).expect_err(bad).to_string();
            assert!(err.contains(bad), "{err}");
        }
    }

    #[test]
    fn loss_scale_takes_positive_pixels_and_names_bad_values() {
        assert_eq!(parse_loss_scale("0.25"), Ok(0.25));
        assert_eq!(parse_loss_scale(" 1 "), Ok(1.0));
        for bad in ["0", "-0.5", "NaN", "inf", "1e9", "quarter"] {
            let error = parse_loss_scale(bad).expect_err(bad);
            assert!(error.contains(bad), "{error}");
        }
    }
}

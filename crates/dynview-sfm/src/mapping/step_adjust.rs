//! Intrinsics from the time steps: after the frame-to-frame refinement, one bundle adjustment
//! over time steps sampled across the capture, each with its own points matched across cameras
//! only (as the per-timestep stage does: never through time, so what moves stays consistent),
//! every sampled frame's pose and every camera's intrinsics free.
//!
//! The keyframes alone fix the intrinsics weakly on an arc of cameras: on the arc8x90 layout
//! (8 hand-held cameras over 90 degrees, 3 keyframes each) the focal lengths drift by 0.7%
//! along the arc and the principal points are 2.5-6.3 px off, which bends the whole model: the
//! held-out camera lost 1.53 dB against the package from the true poses, 0.32 dB after this
//! adjustment (`docs/results/sfm.md`). Each time step adds its own points on the moving scene
//! and on the cameras' own hand-held motion. Each camera's path then moves as a whole: the
//! corrections of its sampled frames are fitted by a line in time and applied to every frame,
//! so the frame-to-frame motion (and its smoothness priors) stays as the refinement made it.

use std::sync::atomic::AtomicBool;

use dynview_ba::HeldIntrinsics;
use dynview_camera::{Radial, Rigid3};
use dynview_core::StageProgress;
use nalgebra::{Rotation3, Vector3};

use crate::error::{SfmError, SfmResult};
use crate::features::sift::FeatureOptions;
use crate::input::frames::{EventFrames, read_bgr};
use crate::mapping::incremental::{MapperOptions, PRINCIPAL_POINT_PRIOR_FRACTION, longer_side_px, solve_final};
use crate::mapping::points::{PointOptions, TimestepView, timestep_tracks};

/// Default number of sampled time steps.
pub const DEFAULT_SAMPLES: usize = 24;

/// Default for [`StepAdjustOptions::still_rig_min_cameras`]: a still rig is adjusted over the
/// time steps' points three cameras or more see, then settled over every point. On both
/// Panoptic arcs, every interior camera left out, it brings our poses nearer the calibration
/// (rotation medians 0.22-0.88 -> 0.07-0.24 degrees) and renders the held-out camera better on
/// five of six (arc means +0.53 and +0.38 dB colour-corrected, `docs/results/sfm.md`, "Still
/// rigs adjusted over points three cameras see, with the views aligned"). (Measured with the
/// bare orientations aligned, it had seemed to render four of six worse: that alignment charged
/// our principal points to the poses.)
pub const DEFAULT_STILL_RIG_MIN_CAMERAS: usize = 3;

/// Default for [`StepAdjustOptions::still_principal_point_fraction`]: 0.25% of the longer side
/// (1.6 px at 640). On the Panoptic arcs the time steps fix a still rig's principal points to
/// 0.8-1.4 px on arc 2, where refining them brought cam04 and cam07 out 1.0 dB nearer the
/// calibration, and to 2.8-3.7 px at worst on arc 1, where refining them cost cam08 0.9 dB
/// (`docs/results/sfm.md`, "Principal points refined by the time steps alone").
pub const DEFAULT_STILL_PRINCIPAL_POINT_FRACTION: f64 = 0.0025;

/// How the time steps adjust the intrinsics and poses.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StepAdjustOptions {
    /// Time steps sampled, evenly over the capture (every frame when it has fewer); 0 turns
    /// the adjustment off.
    pub samples: usize,
    /// Where every camera stands still, only points at least this many cameras see join the
    /// adjustment (0: still rigs are not adjusted; 3 by default). Points two cameras see hold a
    /// wrong focal-distance minimum on the Panoptic arc: with them, even over 75 steps, nothing
    /// moves; with only those three or more cameras see, cam08's focal goes from +11.1% to
    /// +2.7% and the rotation median from 1.00 to 0.65 degrees (`docs/results/sfm.md`).
    pub still_rig_min_cameras: usize,
    /// After a still rig's first pass, adjust once more over every point (those two cameras
    /// see too), from where the first pass left the cameras.
    pub settle: bool,
    /// Where every camera stands still and the keyframes left the principal points where they
    /// started, the time steps refine them only when they fix every camera's to this share of
    /// its longer side (standard deviation, px along the worse axis); 0: never. Where the
    /// keyframes refined them, the bound is [`PRINCIPAL_POINT_PRIOR_FRACTION`], as there.
    pub still_principal_point_fraction: f64,
}

impl Default for StepAdjustOptions {
    fn default() -> Self {
        Self {
            samples: DEFAULT_SAMPLES,
            still_rig_min_cameras: DEFAULT_STILL_RIG_MIN_CAMERAS,
            settle: true,
            still_principal_point_fraction: DEFAULT_STILL_PRINCIPAL_POINT_FRACTION,
        }
    }
}

/// The share of each camera's longer side within which the time steps must fix its principal
/// point for the refined ones to be kept; `None`: not tried. Where the keyframes refined them,
/// the keyframes' own bound; on a still rig whose keyframes did not, `still_fraction` (the time
/// steps add views from the same places, so only a tight fix is trusted); otherwise `None`
/// (hand-held cameras' time steps can fix them in appearance only: `StepCameras::principal_points_fixed`).
pub fn principal_point_bound_fraction(keyframes_refined: bool, still_rig: bool, still_fraction: f64) -> Option<f64> {
    if keyframes_refined {
        Some(PRINCIPAL_POINT_PRIOR_FRACTION)
    } else if still_rig && still_fraction > 0.0 {
        Some(still_fraction)
    } else {
        None
    }
}

/// What the adjustment did (in `report.json`).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StepAdjustReport {
    /// The sampled time steps.
    pub steps: Vec<usize>,
    /// Points triangulated over them (those enough cameras see).
    pub points: usize,
    /// The fewest cameras a point was seen by to join (2 on a rig with a moving camera).
    #[serde(default)]
    pub min_track_cameras: usize,
    /// Their observations.
    pub observations: usize,
    /// RMS reprojection error before and after (px).
    pub rms_px: [f64; 2],
    /// Iterations of the solve that was kept.
    pub iterations: usize,
    /// Why the kept solve stopped (`dynview_ba::Termination`).
    pub termination: String,
    /// Per camera, its focal length after the adjustment (px).
    pub focal_px: Vec<f64>,
    /// Per camera, the change of its focal length, % of the keyframes' one.
    pub focal_change_percent: Vec<f64>,
    /// Per camera, the standard deviation of its refined focal length (% of it); `None`
    /// where it was given.
    pub focal_std_percent: Vec<Option<f64>>,
    /// Per camera, its principal point's standard deviation (px) with it refined.
    pub principal_point_std_px: Vec<Option<f64>>,
    /// Whether the refined principal points were kept (all fixed to within their bound).
    pub principal_point_refined: bool,
    /// The settling pass over every point after a first pass over points three cameras or
    /// more see (a still rig's); the intrinsics figures above are after it (the focal changes
    /// from before both).
    #[serde(default)]
    pub settled: Option<Box<StepAdjustReport>>,
}

/// The cameras as the adjustment sees them.
pub struct StepCameras<'a> {
    /// The input frames.
    pub frames: &'a EventFrames,
    /// Per camera, its intrinsics set (cameras sharing intrinsics share a set).
    pub group: &'a [usize],
    /// Per intrinsics set, its intrinsics after the keyframe reconstruction.
    pub intrinsics: Vec<Radial>,
    /// Per intrinsics set, what the user gave.
    pub held: Vec<HeldIntrinsics>,
    /// Per camera, whether it stands still (one pose for all its frames).
    pub still: &'a [bool],
    /// Whether the keyframes fixed the principal points well enough to refine them: then the
    /// time steps refine them too, within the same bound. Otherwise only a still rig's time
    /// steps may, within the tighter [`StepAdjustOptions::still_principal_point_fraction`]. The
    /// time steps add views from the same cameras, not new viewing directions, and their
    /// principal points can be fixed in appearance only: on `tests/synthetic.rs`'s 4-camera
    /// hand-held event (principal points at the centre, which the keyframes kept) they came out
    /// 18-22 px off with a reported standard deviation of 3 px, and the rotation median went
    /// from 0.043 to 1.097 degrees.
    pub principal_points_fixed: bool,
}

/// Adjusts `poses` (per camera, per frame) and returns the intrinsics per set with the report;
/// `None` where nothing can be adjusted (off, fewer than two cameras with poses, or no point
/// seen by enough of them). Where every camera stands still the time steps add no new
/// viewpoints, only more points, and those two cameras see hold the keyframes' solution where it
/// is wrong; there only points `still_rig_min_cameras` cameras or more see join (three by
/// default; 0: still rigs keep the keyframes' solution), then, with `settle`, every point once
/// more.
pub fn adjust_with_steps(
    cameras: &StepCameras,
    poses: &mut [Vec<Rigid3>],
    options: &StepAdjustOptions,
    features: &FeatureOptions,
    mapper: &MapperOptions,
    progress: StageProgress,
    interrupt: &AtomicBool,
) -> SfmResult<Option<(Vec<Radial>, StepAdjustReport)>> {
    let posed: Vec<usize> = (0..poses.len()).filter(|&c| !poses[c].is_empty()).collect();
    let frames_count = posed.iter().map(|&c| poses[c].len()).min().unwrap_or(0);
    let moving = posed.iter().any(|&c| cameras.still.get(c) != Some(&true));
    let min_track_cameras = match (moving, options.still_rig_min_cameras) {
        (false, 0) => return Ok(None),
        (false, n) => n.max(2),
        (true, _) => 2,
    };
    if options.samples == 0 || posed.len() < min_track_cameras || frames_count == 0 {
        return Ok(None);
    }
    let steps = sample_steps(frames_count, options.samples);
    let bound = mapper
        .refine_principal_point
        .then(|| principal_point_bound_fraction(cameras.principal_points_fixed, !moving, options.still_principal_point_fraction))
        .flatten();
    let pass = PassOptions { min_track_cameras, principal_point_bound_fraction: bound };
    let Some((first, mut report)) = adjust_pass(cameras, poses, &posed, &steps, pass, features, mapper, progress, interrupt)? else {
        return Ok(None);
    };
    if min_track_cameras <= 2 || !options.settle {
        return Ok(Some((first, report)));
    }
    // The settling pass: every point again, from where the first pass left the cameras.
    let settled_cameras = StepCameras {
        frames: cameras.frames,
        group: cameras.group,
        intrinsics: first.clone(),
        held: cameras.held.clone(),
        still: cameras.still,
        principal_points_fixed: cameras.principal_points_fixed,
    };
    let pass = PassOptions { min_track_cameras: 2, ..pass };
    let Some((settled, second)) = adjust_pass(&settled_cameras, poses, &posed, &steps, pass, features, mapper, progress, interrupt)? else {
        return Ok(Some((first, report)));
    };
    report.focal_px = second.focal_px.clone();
    report.focal_change_percent = focal_change_percent(cameras, &settled);
    report.focal_std_percent = second.focal_std_percent.clone();
    report.principal_point_std_px = second.principal_point_std_px.clone();
    report.principal_point_refined = second.principal_point_refined;
    report.settled = Some(Box::new(second));
    Ok(Some((settled, report)))
}

/// Per camera, the change of its focal length in `adjusted` (per intrinsics set), % of its
/// focal in `cameras`.
fn focal_change_percent(cameras: &StepCameras, adjusted: &[Radial]) -> Vec<f64> {
    cameras.group.iter().map(|&g| 100.0 * (adjusted[g].f / cameras.intrinsics[g].f - 1.0)).collect()
}

/// What differs between the adjustment's passes.
#[derive(Clone, Copy, Debug)]
struct PassOptions {
    /// Only points this many cameras or more see join.
    min_track_cameras: usize,
    /// [`principal_point_bound_fraction`]: `None`, the principal points stay where they are.
    principal_point_bound_fraction: Option<f64>,
}

/// One adjustment over `steps`.
#[allow(clippy::too_many_arguments)]
fn adjust_pass(
    cameras: &StepCameras,
    poses: &mut [Vec<Rigid3>],
    posed: &[usize],
    steps: &[usize],
    pass: PassOptions,
    features: &FeatureOptions,
    mapper: &MapperOptions,
    progress: StageProgress,
    interrupt: &AtomicBool,
) -> SfmResult<Option<(Vec<Radial>, StepAdjustReport)>> {
    let steps = steps.to_vec();
    // One image per sampled frame; a still camera has one image for all.
    let mut image_of = vec![vec![usize::MAX; steps.len()]; poses.len()];
    let mut problem =
        dynview_ba::Problem { cameras: cameras.intrinsics.clone(), held_intrinsics: cameras.held.clone(), ..Default::default() };
    for &c in posed {
        for (s, &t) in steps.iter().enumerate() {
            if cameras.still.get(c) == Some(&true) && s > 0 {
                image_of[c][s] = image_of[c][0];
                continue;
            }
            image_of[c][s] = problem.images.len();
            problem.images.push(poses[c][t]);
            problem.image_camera.push(cameras.group[c]);
            problem.image_fixed.push(false);
        }
    }
    // The gauge: the first image (the scale is left to the solver's damping, as in the
    // keyframe reconstruction).
    problem.image_fixed[0] = true;
    let point_options = PointOptions::default();
    for (s, &t) in steps.iter().enumerate() {
        SfmError::check_interrupt(interrupt)?;
        progress("time-step adjustment", s as u64, steps.len() as u64);
        let images = posed.iter().map(|&c| read_bgr(&cameras.frames.cameras[c].files[t])).collect::<SfmResult<Vec<_>>>()?;
        let views: Vec<TimestepView> = posed
            .iter()
            .zip(&images)
            .map(|(&c, image)| TimestepView { intrinsics: cameras.intrinsics[cameras.group[c]], pose: poses[c][t], image_bgr: image })
            .collect();
        for (xyz, observations) in timestep_tracks(&views, features, &point_options)? {
            if observations.len() < pass.min_track_cameras {
                continue;
            }
            let point = problem.points_world.len();
            problem.points_world.push(xyz.into());
            problem.point_fixed.push(false);
            for (view, pixel) in observations {
                problem.observations.push(dynview_ba::Observation { image: image_of[posed[view]][s], point, pixel: pixel.into() });
            }
        }
    }
    progress("time-step adjustment", steps.len() as u64, steps.len() as u64);
    if problem.observations.is_empty() {
        return Ok(None);
    }
    let ba = dynview_ba::Options {
        loss: dynview_ba::Loss::Cauchy { scale_px: mapper.loss_scale_px },
        refine_focal: mapper.refine_focal,
        refine_principal_point: false,
        refine_distortion: false,
        max_iterations: 50,
        ..Default::default()
    };
    let bound_fraction = pass.principal_point_bound_fraction.unwrap_or(0.0);
    let bound_px: Vec<f64> = cameras.intrinsics.iter().map(|k| bound_fraction * longer_side_px(k)).collect();
    let solved = solve_final(&mut problem, ba, pass.principal_point_bound_fraction.is_some(), &bound_px)?;
    let adjusted: Vec<Radial> = problem.cameras.clone();
    for &c in posed {
        let corrections: Vec<(usize, Correction)> = steps
            .iter()
            .enumerate()
            .map(|(s, &t)| {
                let image = &problem.images[image_of[c][s]];
                (t, Correction::between(&poses[c][t], image))
            })
            .collect();
        let line = CorrectionLine::fit(&corrections);
        for (t, pose) in poses[c].iter_mut().enumerate() {
            *pose = line.at(t).apply(pose);
        }
    }
    let report = StepAdjustReport {
        points: problem.points_world.len(),
        min_track_cameras: pass.min_track_cameras,
        observations: problem.observations.len(),
        rms_px: [solved.report.initial_rms_px, solved.report.final_rms_px],
        iterations: solved.report.iterations,
        termination: format!("{:?}", solved.report.termination),
        focal_px: (0..poses.len()).map(|c| adjusted[cameras.group[c]].f).collect(),
        focal_change_percent: focal_change_percent(cameras, &adjusted),
        focal_std_percent: (0..poses.len())
            .map(|c| solved.std.get(cameras.group[c]).and_then(|s| s.focal_px).map(|s| 100.0 * s / adjusted[cameras.group[c]].f))
            .collect(),
        principal_point_std_px: (0..poses.len()).map(|c| solved.principal_point_std_px.get(cameras.group[c]).copied().flatten()).collect(),
        principal_point_refined: solved.principal_point_refined,
        settled: None,
        steps,
    };
    Ok(Some((adjusted, report)))
}

/// `samples` time steps spread evenly over `frames` (all of them when there are fewer).
pub fn sample_steps(frames: usize, samples: usize) -> Vec<usize> {
    if samples >= frames {
        return (0..frames).collect();
    }
    if samples == 1 {
        return vec![0];
    }
    let mut steps: Vec<usize> = (0..samples).map(|i| (i as f64 * (frames - 1) as f64 / (samples - 1) as f64).round() as usize).collect();
    steps.dedup();
    steps
}

/// How the adjustment moved one frame's pose: `new = turn * old` for the rotation
/// (camera_from_world), `new = old + shift` for the centre.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Correction {
    turn: Vector3<f64>,
    shift: Vector3<f64>,
}

impl Correction {
    fn between(old: &Rigid3, new: &Rigid3) -> Self {
        let turn = Rotation3::from_matrix_unchecked(new.rotation_matrix() * old.rotation_matrix().transpose()).scaled_axis();
        Self { turn, shift: new.center() - old.center() }
    }

    fn apply(&self, pose: &Rigid3) -> Rigid3 {
        Rigid3::from_rotation_center(
            Rotation3::from_scaled_axis(self.turn).into_inner() * pose.rotation_matrix(),
            pose.center() + self.shift,
        )
    }
}

/// The least-squares line in time through a camera's corrections, per component.
#[derive(Clone, Copy, Debug, PartialEq)]
struct CorrectionLine {
    /// The corrections' mean time.
    mean_t: f64,
    /// The correction at `mean_t`.
    at_mean: Correction,
    /// Its change per frame.
    slope: Correction,
}

impl CorrectionLine {
    /// The line through `corrections` (time, correction); constant with one time or none.
    fn fit(corrections: &[(usize, Correction)]) -> Self {
        let n = corrections.len().max(1) as f64;
        let mean_t = corrections.iter().map(|c| c.0 as f64).sum::<f64>() / n;
        let mean = |f: &dyn Fn(&Correction) -> Vector3<f64>| corrections.iter().map(|c| f(&c.1)).sum::<Vector3<f64>>() / n;
        let at_mean = Correction { turn: mean(&|c| c.turn), shift: mean(&|c| c.shift) };
        let spread: f64 = corrections.iter().map(|c| (c.0 as f64 - mean_t).powi(2)).sum();
        let slope_of = |f: &dyn Fn(&Correction) -> Vector3<f64>, m: Vector3<f64>| {
            if spread > 0.0 {
                corrections.iter().map(|c| (f(&c.1) - m) * (c.0 as f64 - mean_t)).sum::<Vector3<f64>>() / spread
            } else {
                Vector3::zeros()
            }
        };
        let slope = Correction { turn: slope_of(&|c| c.turn, at_mean.turn), shift: slope_of(&|c| c.shift, at_mean.shift) };
        Self { mean_t, at_mean, slope }
    }

    /// The correction at frame `t`.
    fn at(&self, t: usize) -> Correction {
        let dt = t as f64 - self.mean_t;
        Correction { turn: self.at_mean.turn + self.slope.turn * dt, shift: self.at_mean.shift + self.slope.shift * dt }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samples_spread_over_the_capture_from_first_to_last() {
        assert_eq!(sample_steps(41, 12), vec![0, 4, 7, 11, 15, 18, 22, 25, 29, 33, 36, 40]);
        assert_eq!(sample_steps(5, 12), vec![0, 1, 2, 3, 4]);
        assert_eq!(sample_steps(100, 1), vec![0]);
        assert_eq!(sample_steps(3, 2), vec![0, 2]);
    }

    #[test]
    fn principal_points_are_tried_within_the_keyframes_bound_or_a_still_rigs_tighter_one() {
        let tight = DEFAULT_STILL_PRINCIPAL_POINT_FRACTION;
        assert!(tight < PRINCIPAL_POINT_PRIOR_FRACTION);
        // Where the keyframes refined them, the keyframes' bound, still or hand-held.
        assert_eq!(principal_point_bound_fraction(true, true, tight), Some(PRINCIPAL_POINT_PRIOR_FRACTION));
        assert_eq!(principal_point_bound_fraction(true, false, tight), Some(PRINCIPAL_POINT_PRIOR_FRACTION));
        // A still rig whose keyframes did not: the tight bound, or never with 0.
        assert_eq!(principal_point_bound_fraction(false, true, tight), Some(tight));
        assert_eq!(principal_point_bound_fraction(false, true, 0.0), None);
        // Hand-held cameras whose keyframes did not: never.
        assert_eq!(principal_point_bound_fraction(false, false, tight), None);
    }

    #[test]
    fn a_cameras_path_moves_by_a_line_in_time_through_its_corrections() {
        let old = Rigid3::from_angle_axis_center(Vector3::new(0.1, -0.2, 0.05), Vector3::new(1.0, 2.0, 3.0));
        let correction = |angle: f64, shift: f64| Correction { turn: Vector3::new(0.0, angle, 0.0), shift: Vector3::new(shift, 0.0, 0.0) };
        // On a line: reproduced at every frame, samples or not.
        let line = CorrectionLine::fit(&[(2, correction(0.01, 0.1)), (6, correction(0.03, 0.5)), (10, correction(0.05, 0.9))]);
        for (t, angle, shift) in [(0, 0.0, -0.1), (4, 0.02, 0.3), (12, 0.06, 1.1)] {
            let (got, want) = (line.at(t), correction(angle, shift));
            assert!((got.turn - want.turn).norm() < 1e-12 && (got.shift - want.shift).norm() < 1e-12, "frame {t}: {got:?}");
        }
        // Jitter between the samples does not reach the frames: alternating errors cancel.
        let jittery = CorrectionLine::fit(&[
            (0, correction(0.011, 0.2)),
            (1, correction(0.009, 0.2)),
            (2, correction(0.011, 0.2)),
            (3, correction(0.009, 0.2)),
        ]);
        assert!((jittery.at(1).turn.y - 0.01).abs() < 5e-4 && (jittery.at(2).turn.y - 0.01).abs() < 5e-4, "{jittery:?}");
        // One sample (a still camera): constant.
        let still = CorrectionLine::fit(&[(0, correction(0.02, 0.3))]);
        assert_eq!(still.at(40), correction(0.02, 0.3));
        // Applied: the turn before the pose, the shift to the centre.
        let moved = correction(0.02, 0.3).apply(&old);
        let want = Rotation3::from_scaled_axis(Vector3::new(0.0, 0.02, 0.0)).into_inner() * old.rotation_matrix();
        assert!(
            (moved.rotation_matrix() - want).norm() < 1e-12 && (moved.center() - old.center() - Vector3::new(0.3, 0.0, 0.0)).norm() < 1e-12
        );
    }
}

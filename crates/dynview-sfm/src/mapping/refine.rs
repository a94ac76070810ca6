//! Frame-to-frame refinement (METHOD.md Part 1 step 2): every frame of a camera is matched only
//! with the next frame of the same camera; the keyframes' 3D points are carried along these
//! matches to every frame; all non-keyframe poses are then solved by bundle adjustment with the
//! keyframe poses and the points fixed, plus the paper's smoothness priors (Eqs. 1-2):
//! `w(t - t') ||C_t - C_t'||^2` and `w(t - t') ||A_t - A_t'||^2` over a +-3 frame window with a
//! Gaussian `w`.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use dynview_core::StageProgress;
use nalgebra::{UnitQuaternion, Vector2, Vector3};
use opencv::core::{Point2d, Point3d, Vector};
use rayon::prelude::*;

use dynview_camera::{PoseMatrices, Radial, Rigid3};

use crate::error::{SfmError, SfmResult};
use crate::estimators::geometry::reprojection_error_px;
use crate::estimators::pnp::pnp_ransac;
use crate::features::matching::{MatchOptions, build_indices, mutual_matches_shared, verify};
use crate::features::sift::{FeatureOptions, Features};

/// How frames are refined.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RefineOptions {
    /// Weight of the smoothness priors; 0 turns them off. 1 makes the prior between two
    /// neighbouring frames worth as much as all of a frame's observations at one pixel of error
    /// per scene-depth/focal of centre motion (or per 1/focal radian of rotation).
    pub smoothness: f64,
    /// Half-width of the prior window in frames (the paper: 3).
    pub window: usize,
    /// Standard deviation of the Gaussian weight over frame distance.
    pub sigma_frames: f64,
    /// Largest reprojection error (px) of an observation kept in the final solve.
    pub max_reprojection_px: f64,
    /// Cauchy loss scale (px).
    pub loss_scale_px: f64,
}

impl Default for RefineOptions {
    fn default() -> Self {
        Self { smoothness: 0.001, window: 3, sigma_frames: 1.5, max_reprojection_px: 4.0, loss_scale_px: dynview_ba::DEFAULT_LOSS_SCALE_PX }
    }
}

/// A registered keyframe as refinement sees it.
#[derive(Clone, Debug)]
pub struct KeyframeView<'a> {
    /// Its pose in the keyframe model, `camera_from_world`.
    pub pose: Rigid3,
    /// Its features.
    pub features: &'a Features,
    /// Per feature, the keyframe model's point it sees (an index into
    /// [`CameraTrack::points_world`]), if any.
    pub point_of_feature: Vec<Option<u32>>,
}

/// One camera's input to refinement.
pub struct CameraTrack<'a> {
    /// Camera name (for messages).
    pub name: &'a str,
    /// Its frame files in time order.
    pub files: &'a [std::path::PathBuf],
    /// Its intrinsics (fixed).
    pub intrinsics: Radial,
    /// Per frame: the keyframe's view for registered keyframes.
    pub keyframes: Vec<Option<KeyframeView<'a>>>,
    /// The keyframe model's points.
    pub points_world: &'a [Vector3<f64>],
}

/// What refinement measured for one camera.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RefineReport {
    /// Frames posed by PnP before the solve.
    pub frames_with_pnp: usize,
    /// Frames whose initial pose came from their neighbours.
    pub frames_interpolated: usize,
    /// Observations in the final solve.
    pub observations: usize,
    /// RMS reprojection error (px) after the solve, over its observations.
    pub rms_px: f64,
    /// Frames the solve misplaced (the median reprojection error of their observations above
    /// [`MISPLACED_FRAME_FACTOR`] x `max_reprojection_px`), whose poses were replaced by
    /// interpolation between their placed neighbours instead of being kept.
    #[serde(default)]
    pub frames_repaired: usize,
    /// Frames the last solve misplaced (as [`Self::frames_repaired`]) whose own pose before the
    /// solves (PnP on the model's points) was within the limit: that pose was kept instead,
    /// unsmoothed.
    #[serde(default)]
    pub frames_kept_from_pnp: usize,
    /// RMS reprojection error (px) over the observations within `max_reprojection_px` after the
    /// repair: what the kept poses explain.
    #[serde(default)]
    pub inlier_rms_px: f64,
    /// The camera stands still (`crate::mapping::still`): every frame has its keyframes' pose, and
    /// nothing was refined.
    #[serde(default)]
    pub still: bool,
}

/// A frame whose observations' median reprojection error is above this many times
/// `max_reprojection_px` after the solve is misplaced (a refinement that exploded there).
pub const MISPLACED_FRAME_FACTOR: f64 = 4.0;

/// The reprojection errors (px) of frame `t`'s observations (its features with a point) under
/// the pose whose matrices are `pose`.
fn frame_errors_px<'a>(
    intrinsics: &'a Radial,
    pose: PoseMatrices,
    features: &'a Features,
    point_at: &'a [Option<u32>],
    points_world: &'a [Vector3<f64>],
) -> impl Iterator<Item = f64> + 'a {
    point_at.iter().zip(&features.xy).filter_map(move |(p, xy)| {
        p.map(|p| reprojection_error_px(intrinsics, &pose, &points_world[p as usize], &Vector2::new(f64::from(xy[0]), f64::from(xy[1]))))
    })
}

/// Per frame, the median reprojection error (px) of its observations under `poses`; `None` for
/// a frame without observations.
pub fn median_frame_errors_px(
    intrinsics: &Radial,
    poses: &[Rigid3],
    features: &[&Features],
    point_at: &[Vec<Option<u32>>],
    points_world: &[Vector3<f64>],
) -> Vec<Option<f64>> {
    (0..poses.len())
        .map(|t| {
            let mut errors: Vec<f64> = frame_errors_px(intrinsics, poses[t].matrices(), features[t], &point_at[t], points_world).collect();
            errors.sort_by(f64::total_cmp);
            errors.get(errors.len() / 2).copied()
        })
        .collect()
}

/// Replaces the poses of frames (never keyframes) whose median error is above `limit_px` by
/// interpolation between their placed neighbours; returns how many were replaced.
pub fn repair_misplaced(poses: &mut [Rigid3], median_errors_px: &[Option<f64>], is_keyframe: &[bool], limit_px: f64) -> usize {
    let misplaced: Vec<bool> =
        (0..poses.len()).map(|t| !is_keyframe[t] && median_errors_px[t].is_some_and(|e| e > limit_px || e.is_nan())).collect();
    let count = misplaced.iter().filter(|&&m| m).count();
    if count > 0 {
        let mut kept: Vec<Option<Rigid3>> = poses.iter().zip(&misplaced).map(|(p, &m)| (!m).then_some(*p)).collect();
        fill_missing(&mut kept);
        for (pose, fixed) in poses.iter_mut().zip(kept) {
            if let Some(fixed) = fixed {
                *pose = fixed;
            }
        }
    }
    count
}

/// Puts back the pose a frame had before the solve (`before`, with its median errors
/// `errors_before_px`) where the solve misplaced it (median error above `limit_px` or NaN) and
/// the pose before was within the limit; never a keyframe. Updates `errors_px` alike and
/// returns how many frames were put back.
pub fn keep_poses_before(
    poses: &mut [Rigid3],
    errors_px: &mut [Option<f64>],
    before: &[Rigid3],
    errors_before_px: &[Option<f64>],
    is_keyframe: &[bool],
    limit_px: f64,
) -> usize {
    let mut kept = 0;
    for t in 0..poses.len() {
        let misplaced = errors_px[t].is_some_and(|e| e > limit_px || e.is_nan());
        if !is_keyframe[t] && misplaced && errors_before_px[t].is_some_and(|e| e <= limit_px) {
            poses[t] = before[t];
            errors_px[t] = errors_before_px[t];
            kept += 1;
        }
    }
    kept
}

/// Carries point ids along the consecutive-frame `matches`, forward then backward, never
/// overwriting a keyframe's own assignment or an earlier one.
pub fn propagate(point_at: &mut [Vec<Option<u32>>], matches: &[Vec<[u32; 2]>], is_keyframe: &[bool]) {
    for t in 0..matches.len() {
        if is_keyframe[t + 1] {
            continue;
        }
        for m in &matches[t] {
            if let Some(p) = point_at[t][m[0] as usize]
                && point_at[t + 1][m[1] as usize].is_none()
            {
                point_at[t + 1][m[1] as usize] = Some(p);
            }
        }
    }
    for t in (0..matches.len()).rev() {
        if is_keyframe[t] {
            continue;
        }
        for m in &matches[t] {
            if let Some(p) = point_at[t + 1][m[1] as usize]
                && point_at[t][m[0] as usize].is_none()
            {
                point_at[t][m[0] as usize] = Some(p);
            }
        }
    }
}

fn pnp(
    intrinsics: &Radial,
    features: &Features,
    point_at: &[Option<u32>],
    points: &[Vector3<f64>],
    max_px: f64,
) -> SfmResult<Option<Rigid3>> {
    let mut object = Vector::<Point3d>::new();
    let mut image = Vector::<Point2d>::new();
    for (f, p) in point_at.iter().enumerate() {
        if let Some(p) = p {
            let x = points[*p as usize];
            object.push(Point3d::new(x.x, x.y, x.z));
            image.push(Point2d::new(f64::from(features.xy[f][0]), f64::from(features.xy[f][1])));
        }
    }
    if object.len() < 12 {
        return Ok(None);
    }
    Ok(pnp_ransac(intrinsics, &object, &image, max_px, 1000, 0.999)?.filter(|(_, inliers)| *inliers >= 12).map(|(pose, _)| pose))
}

/// RMS reprojection error (px) of the observations within `max_px` under `poses`.
fn inlier_rms_px(
    intrinsics: &Radial,
    poses: &[Rigid3],
    features: &[&Features],
    point_at: &[Vec<Option<u32>>],
    points_world: &[Vector3<f64>],
    max_px: f64,
) -> f64 {
    let (mut sum, mut count) = (0.0, 0usize);
    for t in 0..poses.len() {
        for e in frame_errors_px(intrinsics, poses[t].matrices(), features[t], &point_at[t], points_world).filter(|&e| e <= max_px) {
            sum += e * e;
            count += 1;
        }
    }
    if count == 0 { 0.0 } else { (sum / count as f64).sqrt() }
}

/// Fills missing poses by interpolating (slerp and lerp) between the nearest posed frames.
fn fill_missing(poses: &mut [Option<Rigid3>]) -> usize {
    let known: Vec<usize> = (0..poses.len()).filter(|&t| poses[t].is_some()).collect();
    let mut filled = 0;
    for t in 0..poses.len() {
        if poses[t].is_some() {
            continue;
        }
        let before = known.iter().rev().find(|&&k| k < t).copied();
        let after = known.iter().find(|&&k| k > t).copied();
        let pose = match (before, after) {
            (Some(a), Some(b)) => {
                let (pa, pb) = (poses[a].unwrap_or_else(|| unreachable!()), poses[b].unwrap_or_else(|| unreachable!()));
                let s = (t - a) as f64 / (b - a) as f64;
                let qa = UnitQuaternion::from_matrix(&pa.rotation_matrix());
                let qb = UnitQuaternion::from_matrix(&pb.rotation_matrix());
                let q = qa.try_slerp(&qb, s, 1e-9).unwrap_or(qa);
                Rigid3::from_rotation_center(q.to_rotation_matrix().into_inner(), pa.center().lerp(&pb.center(), s))
            }
            (Some(k), None) | (None, Some(k)) => poses[k].unwrap_or_else(|| unreachable!()),
            (None, None) => continue,
        };
        poses[t] = Some(pose);
        filled += 1;
    }
    filled
}

/// The Gaussian prior weight of two frames `dt` apart.
pub fn prior_weight(options: &RefineOptions, dt: usize) -> f64 {
    (-((dt * dt) as f64) / (2.0 * options.sigma_frames * options.sigma_frames)).exp()
}

/// Frames whose matching indices are in memory at once.
const REFINE_CHUNK_FRAMES: usize = 32;

/// Poses every frame of one camera.
pub fn refine_camera(
    camera: &CameraTrack,
    feature_options: &FeatureOptions,
    match_options: &MatchOptions,
    options: &RefineOptions,
    progress: StageProgress,
    interrupt: &AtomicBool,
) -> SfmResult<(Vec<Rigid3>, RefineReport)> {
    let n = camera.files.len();
    let is_keyframe: Vec<bool> = camera.keyframes.iter().map(Option::is_some).collect();
    if !is_keyframe.iter().any(|k| *k) {
        return Err(SfmError::Reconstruction(format!(
            "camera {}: none of its keyframes could be registered (it shares too few features with the other cameras)",
            camera.name
        )));
    }
    let done = AtomicU64::new(0);
    let label = format!("refine {}", camera.name);
    let total = (2 * n) as u64;
    let owned: Vec<Option<Features>> = (0..n)
        .into_par_iter()
        .map(|t| {
            SfmError::check_interrupt(interrupt)?;
            let f = if camera.keyframes[t].is_some() {
                None
            } else {
                Some(crate::features::sift::extract_file(&camera.files[t], feature_options)?)
            };
            progress(&label, done.fetch_add(1, Ordering::Relaxed) + 1, total);
            Ok(f)
        })
        .collect::<SfmResult<Vec<_>>>()?;
    let features: Vec<&Features> = (0..n)
        .map(|t| camera.keyframes[t].as_ref().map_or_else(|| owned[t].as_ref().unwrap_or_else(|| unreachable!()), |k| k.features))
        .collect();
    // Frames in chunks sharing their last frame: each frame's index serves both of its pairs,
    // and only a chunk's indices are in memory at once.
    let mut matches: Vec<Vec<[u32; 2]>> = Vec::with_capacity(n);
    for first in (0..n.saturating_sub(1)).step_by(REFINE_CHUNK_FRAMES) {
        let last = (first + REFINE_CHUNK_FRAMES).min(n - 1);
        let mats = (first..=last).map(|t| features[t].descriptor_mat()).collect::<SfmResult<Vec<_>>>()?;
        let indices = build_indices(&mats)?;
        let chunk = (first..last)
            .into_par_iter()
            .map(|t| {
                SfmError::check_interrupt(interrupt)?;
                let m = mutual_matches_shared(&mats, &indices, t - first, t + 1 - first, match_options)?;
                let v = verify(&features[t].xy, &features[t + 1].xy, &m, match_options)?;
                progress(&label, done.fetch_add(1, Ordering::Relaxed) + 1, total);
                Ok(v.inliers)
            })
            .collect::<SfmResult<Vec<_>>>()?;
        matches.extend(chunk);
    }
    let mut point_at: Vec<Vec<Option<u32>>> = (0..n)
        .map(|t| camera.keyframes[t].as_ref().map_or_else(|| vec![None; features[t].len()], |k| k.point_of_feature.clone()))
        .collect();
    propagate(&mut point_at, &matches, &is_keyframe);

    let mut report = RefineReport::default();
    let mut poses: Vec<Option<Rigid3>> = (0..n)
        .map(|t| match &camera.keyframes[t] {
            Some(k) => Ok(Some(k.pose)),
            None => pnp(&camera.intrinsics, features[t], &point_at[t], camera.points_world, options.max_reprojection_px),
        })
        .collect::<SfmResult<Vec<_>>>()?;
    report.frames_with_pnp = (0..n).filter(|&t| !is_keyframe[t] && poses[t].is_some()).count();
    report.frames_interpolated = fill_missing(&mut poses);
    let mut poses: Vec<Rigid3> = poses.into_iter().map(|p| p.unwrap_or_else(|| unreachable!())).collect();
    if is_keyframe.iter().all(|k| *k) {
        return Ok((poses, report));
    }

    // Scale of the priors: one pixel at the median scene depth.
    let mut depths: Vec<f64> = Vec::new();
    for t in 0..n {
        let pose = poses[t].matrices();
        for p in point_at[t].iter().flatten() {
            let z = pose.point_camera(&camera.points_world[*p as usize]).z;
            if z > 0.0 {
                depths.push(z);
            }
        }
    }
    depths.sort_by(f64::total_cmp);
    let depth = depths.get(depths.len() / 2).copied().unwrap_or(1.0);
    let observations_per_frame = point_at.iter().map(|v| v.iter().flatten().count()).sum::<usize>() as f64 / n as f64;
    let focal = camera.intrinsics.f;
    let scale = options.smoothness * observations_per_frame.max(1.0);
    // A solve that explodes at a frame (the smoothness priors drag its neighbours along) gives
    // that frame back its own pose, which the next round starts from.
    let limit_px = MISPLACED_FRAME_FACTOR * options.max_reprojection_px;
    let errors_of = |poses: &[Rigid3]| median_frame_errors_px(&camera.intrinsics, poses, &features, &point_at, camera.points_world);
    let before = poses.clone();
    let errors_before = errors_of(&before);
    let mut errors = errors_before.clone();

    for round in 0..2 {
        let mut used_points: Vec<u32> = point_at.iter().flatten().flatten().copied().collect();
        used_points.sort_unstable();
        used_points.dedup();
        let slot = |p: u32| used_points.binary_search(&p).unwrap_or_else(|_| unreachable!());
        let mut problem = dynview_ba::Problem {
            cameras: vec![camera.intrinsics],
            images: poses.clone(),
            image_camera: vec![0; n],
            image_fixed: is_keyframe.clone(),
            points_world: used_points.iter().map(|&p| camera.points_world[p as usize].into()).collect(),
            point_fixed: vec![true; used_points.len()],
            observations: Vec::new(),
            priors: Vec::new(),
            held_intrinsics: Vec::new(),
        };
        for t in 0..n {
            if is_keyframe[t] {
                continue;
            }
            let pose = poses[t].matrices();
            for (f, p) in point_at[t].iter().enumerate() {
                let Some(p) = p else { continue };
                let xy = features[t].xy[f];
                let pixel = Vector2::new(f64::from(xy[0]), f64::from(xy[1]));
                if round > 0
                    && reprojection_error_px(&camera.intrinsics, &pose, &camera.points_world[*p as usize], &pixel)
                        > options.max_reprojection_px
                {
                    continue;
                }
                problem.observations.push(dynview_ba::Observation { image: t, point: slot(*p), pixel: pixel.into() });
            }
        }
        if options.smoothness > 0.0 {
            for t in 0..n {
                for dt in 1..=options.window {
                    if t + dt < n && !(is_keyframe[t] && is_keyframe[t + dt]) {
                        let w = scale * prior_weight(options, dt);
                        problem.priors.push(dynview_ba::SmoothnessPrior {
                            image_a: t,
                            image_b: t + dt,
                            weight_center: w * (focal / depth).powi(2),
                            weight_rotation: w * focal * focal,
                        });
                    }
                }
            }
        }
        let ba = dynview_ba::Options {
            loss: dynview_ba::Loss::Cauchy { scale_px: options.loss_scale_px },
            refine_focal: false,
            refine_principal_point: false,
            refine_distortion: false,
            max_iterations: 50,
            ..Default::default()
        };
        let solved = dynview_ba::solve(&mut problem, &ba)?;
        report.observations = problem.observations.len();
        report.rms_px = solved.final_rms_px;
        for (t, p) in problem.images.iter().enumerate() {
            poses[t] = *p;
        }
        errors = errors_of(&poses);
        report.frames_kept_from_pnp = keep_poses_before(&mut poses, &mut errors, &before, &errors_before, &is_keyframe, limit_px);
    }
    // Where neither the solve nor the frame's own pose explains it, the frame is placed between
    // its neighbours instead.
    report.frames_repaired = repair_misplaced(&mut poses, &errors, &is_keyframe, limit_px);
    report.inlier_rms_px =
        inlier_rms_px(&camera.intrinsics, &poses, &features, &point_at, camera.points_world, options.max_reprojection_px);
    Ok((poses, report))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(x: f64) -> Rigid3 {
        Rigid3::from_angle_axis_center(Vector3::new(0.0, 0.01 * x, 0.0), Vector3::new(x, 0.0, 0.0))
    }

    #[test]
    fn a_frame_the_solve_misplaced_gets_its_own_pose_back_where_that_one_was_within_the_limit() {
        let before: Vec<Rigid3> = (0..5).map(|t| at(t as f64)).collect();
        let exploded = Rigid3::from_angle_axis_center(Vector3::new(2.0, 0.0, 0.0), Vector3::new(1e4, -3e3, 7.0));
        let mut poses = vec![before[0], exploded, exploded, before[3], exploded];
        let errors_before = [Some(0.2), Some(0.8), Some(40.0), Some(0.3), Some(0.5)];
        let mut errors = [Some(900.0), Some(500.0), Some(700.0), Some(0.4), Some(f64::NAN)];
        // Frame 0 is a keyframe; frame 2 was misplaced before the solve too.
        let is_keyframe = [true, false, false, false, false];
        assert_eq!(keep_poses_before(&mut poses, &mut errors, &before, &errors_before, &is_keyframe, 16.0), 2);
        assert_eq!(poses, vec![before[0], before[1], exploded, before[3], before[4]]);
        assert_eq!(errors, [Some(900.0), Some(0.8), Some(700.0), Some(0.4), Some(0.5)]);
    }

    #[test]
    fn misplaced_frames_are_placed_between_their_neighbours_and_keyframes_kept() {
        // Keyframes 0 and 5; frame 2 exploded (100 px), frame 3 has no observations, frame 4
        // has a NaN error: the repair replaces 2 and 4, never a keyframe or frame 3.
        let mut poses: Vec<Rigid3> = (0..6).map(|t| at(t as f64)).collect();
        poses[2] = Rigid3::from_angle_axis_center(Vector3::new(2.0, 0.0, 0.0), Vector3::new(1e4, -3e3, 7.0));
        poses[4] = Rigid3::from_rotation_center(poses[4].rotation_matrix(), Vector3::new(4.0, 50.0, 0.0));
        let errors = [Some(300.0), Some(0.5), Some(100.0), None, Some(f64::NAN), Some(0.7)];
        let is_keyframe = [true, false, false, false, false, true];
        let expected_three = poses[3];
        assert_eq!(repair_misplaced(&mut poses, &errors, &is_keyframe, 16.0), 2);
        let close =
            |a: &Rigid3, b: &Rigid3| (a.center() - b.center()).norm() < 1e-9 && (a.rotation_matrix() - b.rotation_matrix()).norm() < 1e-9;
        assert!(close(&poses[0], &at(0.0)), "a keyframe is never replaced");
        assert!(close(&poses[3], &expected_three), "a frame without evidence is kept");
        // Frame 2 lies between frames 1 and 3, frame 4 between 3 and 5.
        assert!(close(&poses[2], &at(2.0)), "{:?}", poses[2].center());
        assert!(close(&poses[4], &at(4.0)), "{:?}", poses[4].center());
        // Nothing misplaced: nothing changes.
        let before = poses.clone();
        assert_eq!(repair_misplaced(&mut poses, &[Some(1.0); 6], &is_keyframe, 16.0), 0);
        assert!(poses.iter().zip(&before).all(|(a, b)| close(a, b)));
    }
}

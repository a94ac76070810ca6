//! Still cameras the keyframes left out, placed from the time steps.
//!
//! On a rig of wide-apart still cameras the keyframes can leave a group of cameras out: the
//! pooled pairs that would join it to the others fall under the trust rule of
//! [`crate::mapping::still`] (Panoptic arc 1 without cam08: cam14, cam16 and cam27, joined only
//! by pairs of 25 and 36 inliers, 0 and 5 of them on what moves). Once the other cameras are
//! placed, every time step triangulates its own points from them, the moving people included.
//! A left-out camera that stands still sees those points from one pose at every step, so its
//! matches with the placed cameras' features, pooled over sampled steps, are 2D-3D
//! correspondences for one PnP, its focal length scanned. The dome's repeated static structure
//! can agree on a wrong pose; what moves cannot repeat, so the pose is chosen by its inliers on
//! features the camera has at few other steps, and kept only with
//! [`StepPlacementOptions::min_moving_inliers`] of them.

use std::collections::{HashMap, HashSet};
use std::sync::atomic::AtomicBool;

use nalgebra::{Vector2, Vector3};
use opencv::core::{Point2d, Point3d, Vector};

use dynview_camera::{Radial, Rigid3};
use dynview_core::StageProgress;

use crate::error::{SfmError, SfmResult};
use crate::estimators::geometry::reprojection_error_px;
use crate::estimators::pnp::{pnp_ransac_minimal, pnp_refine};
use crate::features::matching::{MatchOptions, mutual_matches};
use crate::features::sift::{FeatureOptions, Features, extract_gray, read_gray};
use crate::input::frames::{EventFrames, read_bgr};
use crate::mapping::incremental::longer_side_px;
use crate::mapping::points::{PointOptions, TimestepView, feature_tracks, view_features};
use crate::mapping::step_adjust::sample_steps;

/// How left-out still cameras are placed from the time steps.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StepPlacementOptions {
    /// Time steps sampled, evenly over the capture; 0 turns the placement off.
    pub samples: usize,
    /// Largest reprojection error (px) of an inlier.
    pub max_reprojection_px: f64,
    /// Fewest inliers on what moves (features the camera has at few other steps) for a
    /// placement to be kept.
    pub min_moving_inliers: usize,
}

impl Default for StepPlacementOptions {
    fn default() -> Self {
        Self { samples: 24, max_reprojection_px: 4.0, min_moving_inliers: 20 }
    }
}

/// A left-out camera's placement from the time steps (in `report.json`).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StepPlacement {
    /// The camera's name.
    pub camera: String,
    /// 2D-3D correspondences pooled over the steps.
    pub correspondences: usize,
    /// Those on features the camera has at few other steps (what moves).
    pub moving_correspondences: usize,
    /// Inliers of the chosen pose.
    pub inliers: usize,
    /// Its inliers on what moves.
    pub moving_inliers: usize,
    /// The focal length chosen (px).
    pub focal_px: f64,
    /// The pose, `None` where it was not kept (too few inliers on what moves).
    pub camera_from_world: Option<Rigid3>,
}

/// A match of the left-out camera's: the sampled step, its feature's pixel and the placed
/// cameras' point.
type Found = (usize, Vector2<f64>, Vector3<f64>);

/// A feature of the left-out camera at a step and the placed cameras' point it matched.
struct Correspondence {
    pixel: Vector2<f64>,
    point_world: Vector3<f64>,
    moving: bool,
}

/// A feature is on what moves when the camera has a feature within a pixel of it at fewer than
/// this share of the other sampled steps (a static corner is found again at most of them).
const MOVING_SHARE: f64 = 0.25;

/// Focal lengths tried, as factors of the placed cameras' median (in longer sides): every 4%
/// from 0.62 to 1.6 times.
const FOCAL_STEPS: i32 = 12;
const FOCAL_STEP_FACTOR: f64 = 1.04;

/// The chosen focal length is refined over this many steps each way within one step of the
/// scan (every 0.5%).
const FINE_STEPS: i32 = 8;

/// Places every camera that stands still (`still`) and has no pose (`poses[c]` empty) from the
/// points the posed cameras triangulate at sampled time steps; one entry per such camera.
#[allow(clippy::too_many_arguments)]
pub fn place_left_out(
    frames: &EventFrames,
    intrinsics: &[Radial],
    poses: &[Vec<Rigid3>],
    still: &[bool],
    options: &StepPlacementOptions,
    features: &FeatureOptions,
    matching: &MatchOptions,
    progress: StageProgress,
    interrupt: &AtomicBool,
) -> SfmResult<Vec<(usize, StepPlacement)>> {
    let posed: Vec<usize> = (0..poses.len()).filter(|&c| !poses[c].is_empty()).collect();
    let missing: Vec<usize> = (0..poses.len()).filter(|&c| poses[c].is_empty() && still.get(c) == Some(&true)).collect();
    let frame_count = posed.iter().map(|&c| poses[c].len()).min().unwrap_or(0);
    if missing.is_empty() || posed.len() < 2 || options.samples == 0 || frame_count == 0 {
        return Ok(Vec::new());
    }
    let steps = sample_steps(frame_count, options.samples);
    // Per missing camera: per step, its features' pixels, and the correspondences found.
    let mut own: Vec<Vec<Vec<[f32; 2]>>> = vec![Vec::new(); missing.len()];
    let mut found: Vec<Vec<Found>> = vec![Vec::new(); missing.len()];
    let point_options = PointOptions::default();
    for (s, &t) in steps.iter().enumerate() {
        SfmError::check_interrupt(interrupt)?;
        progress("placing left-out cameras", s as u64, steps.len() as u64);
        let images = posed.iter().map(|&c| read_bgr(&frames.cameras[c].files[t])).collect::<SfmResult<Vec<_>>>()?;
        let views: Vec<TimestepView> = posed
            .iter()
            .zip(&images)
            .map(|(&c, image)| TimestepView { intrinsics: intrinsics[c], pose: poses[c][t], image_bgr: image })
            .collect();
        let extracted = view_features(&views, features)?;
        let tracks = feature_tracks(&views, &extracted, &point_options);
        let point_of: HashMap<(usize, u32), usize> =
            tracks.iter().enumerate().flat_map(|(p, (_, seen))| seen.iter().map(move |&key| (key, p))).collect();
        let mats = extracted.iter().map(Features::descriptor_mat).collect::<SfmResult<Vec<_>>>()?;
        for (m, &c) in missing.iter().enumerate() {
            let Some(file) = frames.cameras[c].files.get(t) else {
                own[m].push(Vec::new());
                continue;
            };
            let gray = read_gray(file)?;
            let mine = extract_gray(&gray, features)?;
            let mine_mat = mine.descriptor_mat()?;
            // One correspondence per feature and point, however many placed views matched it.
            let mut seen: HashSet<(u32, usize)> = HashSet::new();
            for (v, mat) in mats.iter().enumerate() {
                for [f, g] in mutual_matches(&mine_mat, mat, matching)? {
                    let Some(&p) = point_of.get(&(v, g)) else { continue };
                    if seen.insert((f, p)) {
                        let xy = mine.xy[f as usize];
                        found[m].push((s, Vector2::new(f64::from(xy[0]), f64::from(xy[1])), tracks[p].0));
                    }
                }
            }
            own[m].push(mine.xy.clone());
        }
    }
    progress("placing left-out cameras", steps.len() as u64, steps.len() as u64);
    let base_factor = median(posed.iter().map(|&c| intrinsics[c].f / longer_side_px(&intrinsics[c])).collect());
    let mut out = Vec::new();
    for (m, &c) in missing.iter().enumerate() {
        let correspondences = label_moving(&own[m], &found[m]);
        let start = intrinsics[c];
        let placement = solve(&frames.cameras[c].name, &correspondences, &start, base_factor * longer_side_px(&start), options)?;
        out.push((c, placement));
    }
    Ok(out)
}

/// Marks each correspondence moving or not from the camera's own features per step: moving
/// where a feature lies within a pixel of it at fewer than [`MOVING_SHARE`] of the other steps.
fn label_moving(own: &[Vec<[f32; 2]>], found: &[Found]) -> Vec<Correspondence> {
    let cells: Vec<HashSet<(i32, i32)>> =
        own.iter().map(|xy| xy.iter().map(|p| (p[0].round() as i32, p[1].round() as i32)).collect()).collect();
    let others = own.len().saturating_sub(1).max(1) as f64;
    found
        .iter()
        .map(|&(s, pixel, point_world)| {
            let (x, y) = (pixel.x.round() as i32, pixel.y.round() as i32);
            let near = |set: &HashSet<(i32, i32)>| (-1..=1).any(|dx| (-1..=1).any(|dy| set.contains(&(x + dx, y + dy))));
            let again = cells.iter().enumerate().filter(|(o, set)| *o != s && near(set)).count();
            Correspondence { pixel, point_world, moving: (again as f64) < MOVING_SHARE * others }
        })
        .collect()
}

/// The pose and focal length, over the focal lengths tried around `focal_px`: hypotheses from
/// the correspondences on what moves; among those with enough inliers on what moves, the most
/// inliers overall; then refined over its inliers.
fn solve(
    name: &str,
    correspondences: &[Correspondence],
    start: &Radial,
    focal_px: f64,
    options: &StepPlacementOptions,
) -> SfmResult<StepPlacement> {
    let moving_correspondences = correspondences.iter().filter(|c| c.moving).count();
    let mut best = StepPlacement {
        camera: name.to_string(),
        correspondences: correspondences.len(),
        moving_correspondences,
        inliers: 0,
        moving_inliers: 0,
        focal_px,
        camera_from_world: None,
    };
    if correspondences.len() < 6 {
        return Ok(best);
    }
    let to_cv = |cs: &[&Correspondence]| -> (Vector<Point3d>, Vector<Point2d>) {
        (
            cs.iter().map(|c| Point3d::new(c.point_world.x, c.point_world.y, c.point_world.z)).collect(),
            cs.iter().map(|c| Point2d::new(c.pixel.x, c.pixel.y)).collect(),
        )
    };
    // Hypotheses from what moves alone: the static matches agree on wrong poses too.
    let moving: Vec<&Correspondence> = correspondences.iter().filter(|c| c.moving).collect();
    let (object, image) = to_cv(&moving);
    let (mut best_pose, mut most_moving) = (None, (0, 0));
    for i in -FOCAL_STEPS..=FOCAL_STEPS {
        let k = Radial { f: focal_px * FOCAL_STEP_FACTOR.powi(i), ..*start };
        let Some((pose, _)) = pnp_ransac_minimal(&k, &object, &image, options.max_reprojection_px, 10_000, 0.9999)? else { continue };
        let (inliers, moving_inliers) = count_inliers(correspondences, &k, &pose, options.max_reprojection_px);
        most_moving = most_moving.max((moving_inliers, inliers));
        // Among the hypotheses what moves supports, the most inliers (static ones too) fix the
        // focal length against the distance, which what moves alone leaves loose.
        if moving_inliers >= options.min_moving_inliers && (inliers, moving_inliers) > (best.inliers, best.moving_inliers) {
            (best.inliers, best.moving_inliers, best.focal_px) = (inliers, moving_inliers, k.f);
            best_pose = Some(pose);
        }
    }
    let Some(pose) = best_pose else {
        // Not kept: the report says how near it came.
        (best.moving_inliers, best.inliers) = most_moving;
        return Ok(best);
    };
    // Refined over every inlier, static ones included, the focal length too: the pose refined
    // at focal lengths within a step of the scan, the one that explains the inliers best kept.
    let k = Radial { f: best.focal_px, ..*start };
    let inliers = inliers_of(correspondences, &k, &pose, options.max_reprojection_px);
    let (object, image) = to_cv(&inliers);
    let mut refined = (f64::INFINITY, k, pose);
    for j in -FINE_STEPS..=FINE_STEPS {
        let k = Radial { f: best.focal_px * FOCAL_STEP_FACTOR.powf(f64::from(j) / f64::from(FINE_STEPS)), ..*start };
        let Some(candidate) = pnp_refine(&k, &object, &image, &pose)? else { continue };
        let matrices = candidate.matrices();
        let squared: f64 = inliers.iter().map(|c| reprojection_error_px(&k, &matrices, &c.point_world, &c.pixel).powi(2)).sum();
        if squared < refined.0 {
            refined = (squared, k, candidate);
        }
    }
    let (_, k, pose) = refined;
    best.focal_px = k.f;
    (best.inliers, best.moving_inliers) = count_inliers(correspondences, &k, &pose, options.max_reprojection_px);
    best.camera_from_world = Some(pose);
    Ok(best)
}

/// The correspondences within `max_px` of their projection under `pose`: all, and those on
/// what moves.
fn count_inliers(correspondences: &[Correspondence], k: &Radial, pose: &Rigid3, max_px: f64) -> (usize, usize) {
    let inliers = inliers_of(correspondences, k, pose, max_px);
    (inliers.len(), inliers.iter().filter(|c| c.moving).count())
}

/// The correspondences within `max_px` of their projection under `pose`.
fn inliers_of<'a>(correspondences: &'a [Correspondence], k: &Radial, pose: &Rigid3, max_px: f64) -> Vec<&'a Correspondence> {
    let matrices = pose.matrices();
    correspondences.iter().filter(|c| reprojection_error_px(k, &matrices, &c.point_world, &c.pixel) <= max_px).collect()
}

fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    values.get(values.len() / 2).copied().unwrap_or(1.2)
}

#[cfg(test)]
mod tests {
    use super::*;

    const FOCAL_PX: f64 = 550.0;

    fn camera() -> Radial {
        Radial { f: FOCAL_PX, cx: 319.5, cy: 179.5, k1: 0.0, k2: 0.0 }
    }

    /// A camera 6 m from the origin looking at it, turned `azimuth` about the vertical.
    fn looking_at_origin(azimuth: f64) -> Rigid3 {
        let center = Vector3::new(6.0 * azimuth.sin(), -1.0, -6.0 * azimuth.cos());
        let forward = -center.normalize();
        let right = Vector3::new(0.0, 1.0, 0.0).cross(&forward).normalize();
        let down = forward.cross(&right);
        let rotation = nalgebra::Matrix3::from_rows(&[right.transpose(), down.transpose(), forward.transpose()]);
        Rigid3::from_rotation_center(rotation, center)
    }

    /// Deterministic points in a 4 m box around the origin.
    fn points(count: usize, seed: u64) -> Vec<Vector3<f64>> {
        let mut state = seed;
        let mut next = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) * 4.0 - 2.0
        };
        (0..count).map(|_| Vector3::new(next(), next(), next())).collect()
    }

    fn seen(pose: &Rigid3, point: Vector3<f64>, moving: bool) -> Option<Correspondence> {
        let normalized = pose.project_normalized(&point)?;
        let pixel = camera().pixel(normalized);
        (pixel.x >= 0.0 && pixel.y >= 0.0 && pixel.x < 640.0 && pixel.y < 360.0).then_some(Correspondence {
            pixel,
            point_world: point,
            moving,
        })
    }

    /// Static matches agreeing on a wrong pose (repeated structure), a few static ones and the
    /// moving ones on the right pose, and moving outliers.
    fn correspondences(right_moving: usize) -> (Rigid3, Vec<Correspondence>) {
        let (right, wrong) = (looking_at_origin(0.0), looking_at_origin(0.6));
        let mut out: Vec<Correspondence> = points(400, 1).into_iter().filter_map(|p| seen(&wrong, p, false)).take(300).collect();
        out.extend(points(200, 2).into_iter().filter_map(|p| seen(&right, p, false)).take(40));
        out.extend(points(200, 3).into_iter().filter_map(|p| seen(&right, p, true)).take(right_moving));
        // Moving matches gone wrong: the right pixels of other points.
        let decoys = points(200, 4);
        out.extend(
            points(200, 5)
                .into_iter()
                .zip(decoys)
                .filter_map(|(p, q)| seen(&right, p, true).map(|c| Correspondence { point_world: q, ..c }))
                .take(60),
        );
        (right, out)
    }

    #[test]
    fn a_left_out_camera_is_placed_by_what_moves_where_the_static_matches_agree_on_a_wrong_pose() {
        let (right, correspondences) = correspondences(60);
        let placed = solve("cam", &correspondences, &camera(), FOCAL_PX * 0.9, &StepPlacementOptions::default()).unwrap();
        let pose = placed.camera_from_world.expect("placed");
        let centre_error_m = (pose.center() - right.center()).norm();
        assert!(centre_error_m < 0.06, "centre {centre_error_m} m off (6 m away): {placed:?} {:?} {:?}", pose.center(), right.center());
        assert!((placed.focal_px / FOCAL_PX - 1.0).abs() < 0.03, "focal {} px", placed.focal_px);
        assert!(placed.moving_inliers >= 55, "{placed:?}");
    }

    #[test]
    fn a_camera_that_what_moves_does_not_support_stays_out() {
        let (_, correspondences) = correspondences(10);
        let placed = solve("cam", &correspondences, &camera(), FOCAL_PX, &StepPlacementOptions::default()).unwrap();
        assert!(placed.camera_from_world.is_none(), "{placed:?}");
        assert!(placed.moving_inliers < StepPlacementOptions::default().min_moving_inliers);
    }

    #[test]
    fn a_feature_found_again_at_most_steps_is_static_and_one_found_once_moves() {
        let corner = [100.2_f32, 50.7];
        let own: Vec<Vec<[f32; 2]>> =
            (0..8).map(|s| if s == 3 { vec![[100.6, 50.4], [300.0, 200.0]] } else { vec![[100.6, 50.4]] }).collect();
        let found = vec![
            (3, Vector2::new(f64::from(corner[0]), f64::from(corner[1])), Vector3::zeros()),
            (3, Vector2::new(300.0, 200.0), Vector3::zeros()),
        ];
        let labelled = label_moving(&own, &found);
        assert!(!labelled[0].moving);
        assert!(labelled[1].moving);
    }
}

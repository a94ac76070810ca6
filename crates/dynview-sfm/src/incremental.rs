//! Incremental structure from motion on keyframes: initial pair, registration by PnP,
//! triangulation of tracks, bundle adjustment with a robust loss, outlier filtering.

use dynview_ba::HeldIntrinsics;
use dynview_core::StageProgress;
use nalgebra::{Matrix3, Vector2, Vector3};
use opencv::core::{Point2d, Point3d, Vector};

use crate::error::{SfmError, SfmResult};
use crate::geometry::{Intrinsics, Pose, Ray, ray_angle_rad, reprojection_error_px, triangulate_robust};
use crate::matching::{MatchOptions, TwoView};
use crate::pnp::pnp_ransac;
use crate::relative::{RelativePose, place_along, relative_pose};
use crate::tracks::Tracks;

mod focal_restart;

pub use focal_restart::FocalRestart;

/// How the keyframe reconstruction runs.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MapperOptions {
    /// Largest reprojection error (px) of an observation kept in the model.
    pub max_reprojection_px: f64,
    /// Smallest angle (degrees) between two rays of a new point.
    pub min_triangulation_angle_deg: f64,
    /// Fewest 2D-3D inliers to register an image.
    pub min_registration_inliers: usize,
    /// Fewest points of an initial pair.
    pub min_initial_points: usize,
    /// An initial pair is taken at once when the median angle between its rays is at least
    /// this (degrees); otherwise the pair with the widest median angle among the candidates.
    pub init_min_median_angle_deg: f64,
    /// Cauchy loss scale (px) of bundle adjustment and pose refinement: observations much
    /// farther than this from their projection weigh little. Default
    /// [`dynview_ba::DEFAULT_LOSS_SCALE_PX`] (1 px, COLMAP's): 0.25 px gives better keyframe
    /// models on sharp, lossless frames, but not from videos across events
    /// (`docs/results/sfm.md`, "The robust loss at a quarter pixel").
    pub loss_scale_px: f64,
    /// Cameras with the same image size share one set of intrinsics (one camera model filmed
    /// everything). Off by default: cameras at an event are different phones and zooms, and
    /// equal image sizes say nothing about equal intrinsics.
    pub share_intrinsics: bool,
    /// Refine the focal lengths in bundle adjustment (those the user did not give).
    pub refine_focal: bool,
    /// Refine the principal points in the final bundle adjustment where the data fix them
    /// better than their usual distance from the centre ([`PRINCIPAL_POINT_PRIOR_FRACTION`];
    /// on by default; COLMAP keeps them at the image centre). On the Middlebury temple this cut the
    /// median rotation error from 0.62 to 0.25 degrees (`docs/results/sfm.md`).
    pub refine_principal_point: bool,
    /// Refine the radial distortion (k1, k2) in the final bundle adjustment (off by default:
    /// with few viewpoints it trades off against the focal length).
    pub refine_distortion: bool,
}

impl Default for MapperOptions {
    fn default() -> Self {
        Self {
            max_reprojection_px: 4.0,
            min_triangulation_angle_deg: 1.5,
            min_registration_inliers: 20,
            min_initial_points: 50,
            init_min_median_angle_deg: 10.0,
            loss_scale_px: dynview_ba::DEFAULT_LOSS_SCALE_PX,
            share_intrinsics: false,
            refine_focal: true,
            refine_principal_point: true,
            refine_distortion: false,
        }
    }
}

/// What [`solve_final`] found.
pub(crate) struct FinalSolve {
    /// The solve's report.
    pub report: dynview_ba::Report,
    /// The kept solution's intrinsics' standard deviations, per camera.
    pub std: Vec<dynview_ba::IntrinsicsStd>,
    /// Per camera, the principal point's standard deviation (px) in the trial with it refined;
    /// empty when there was no trial.
    pub principal_point_std_px: Vec<Option<f64>>,
    /// Whether the refined principal points were kept.
    pub principal_point_refined: bool,
}

/// The final adjustment of `problem` under `options`: with `try_principal_points` it first
/// solves with the principal points refined too, and keeps that solution only when every
/// camera's principal point is fixed by the data to within its prior (`prior_px`, from
/// [`PRINCIPAL_POINT_PRIOR_FRACTION`]): the estimate is then expected nearer the truth than
/// where it started (the image centre). Otherwise it solves with them where they are. Where
/// the normal equations are singular beyond the gauge (some unknown the data do not fix at
/// all), the trial's principal points count as not fixed (standard deviation infinite) and
/// the kept solution's standard deviations as unknown (empty): the measure never fails a
/// reconstruction that solved.
pub(crate) fn solve_final(
    problem: &mut dynview_ba::Problem,
    options: dynview_ba::Options,
    try_principal_points: bool,
    prior_px: &[f64],
) -> SfmResult<FinalSolve> {
    let mut principal_point_std_px = Vec::new();
    if try_principal_points {
        let trial_options = dynview_ba::Options { refine_principal_point: true, ..options };
        let mut trial = problem.clone();
        let report = dynview_ba::solve(&mut trial, &trial_options)?;
        match intrinsics_std_if_fixed(&trial, &trial_options, report.final_rms_px)? {
            Some(std) => {
                principal_point_std_px = std.iter().map(|s| s.principal_point_px).collect();
                if principal_point_std_px.iter().zip(prior_px).all(|(s, prior)| s.is_none_or(|s| s <= *prior)) {
                    *problem = trial;
                    return Ok(FinalSolve { report, std, principal_point_std_px, principal_point_refined: true });
                }
            }
            None => principal_point_std_px = vec![Some(f64::INFINITY); problem.cameras.len()],
        }
    }
    let report = dynview_ba::solve(problem, &options)?;
    let std = intrinsics_std_if_fixed(problem, &options, report.final_rms_px)?.unwrap_or_default();
    Ok(FinalSolve { report, std, principal_point_std_px, principal_point_refined: false })
}

/// [`dynview_ba::intrinsics_std`], or `None` where the normal equations cannot be factorised
/// (singular beyond the gauge: some unknown is not fixed by the data at all).
fn intrinsics_std_if_fixed(
    problem: &dynview_ba::Problem,
    options: &dynview_ba::Options,
    noise_px: f64,
) -> SfmResult<Option<Vec<dynview_ba::IntrinsicsStd>>> {
    match dynview_ba::intrinsics_std(problem, options, noise_px) {
        Ok(std) => Ok(Some(std)),
        Err(dynview_ba::BaError::Numerical { .. }) => Ok(None),
        Err(other) => Err(other.into()),
    }
}

/// Fewest of an image's 2D-3D correspondences that must agree on the translation's length
/// when it is placed from a verified pair (`relative::place_along`); at least half of them
/// must, too.
const MIN_PAIR_SCALE_INLIERS: usize = 5;

/// How far real principal points lie from the image centre, as a share of the longer image
/// side (radially): 0.6-1.9% on the Panoptic cameras, 0.5-1.6% on Pose2Sim's, 2.9% on the
/// Middlebury temple.
/// The final adjustment keeps refined principal points only when the data fix every camera's
/// better than this (its standard deviation, px along the worse axis at the adjustment's RMS
/// error as noise, below this share of its longer side): then the estimate is expected nearer
/// the truth than the centre is. An arc of cameras hardly tells a principal point from a
/// common turn of its images; a ring, or images at different rolls, does.
pub const PRINCIPAL_POINT_PRIOR_FRACTION: f64 = 0.015;

/// A keyframe to reconstruct.
#[derive(Clone, Debug)]
pub struct MapImage {
    /// Index of its physical camera (shared intrinsics).
    pub camera: usize,
    /// Feature positions (px).
    pub xy: Vec<[f32; 2]>,
}

/// A 3D point and the image features that see it.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MapPoint {
    /// Position in the world.
    pub xyz: Vector3<f64>,
    /// `(image, feature)` observations.
    pub observations: Vec<(usize, u32)>,
}

/// The keyframe reconstruction.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Reconstruction {
    /// Per physical camera.
    pub intrinsics: Vec<Intrinsics>,
    /// Per image; `None` when it could not be registered.
    pub poses: Vec<Option<Pose>>,
    /// Triangulated points.
    pub points: Vec<MapPoint>,
    /// Per physical camera, the standard deviation (px) its principal point would have if
    /// refined, measured by the final adjustment's trial; `None` where not measured.
    #[serde(default)]
    pub principal_point_std_px: Vec<Option<f64>>,
    /// Per physical camera, the standard deviation (px) of its refined focal length in the
    /// final adjustment; `None` where it was held or not measured.
    #[serde(default)]
    pub focal_std_px: Vec<Option<f64>>,
    /// Whether the final adjustment kept the refined principal points.
    #[serde(default)]
    pub principal_point_refined: bool,
    /// Images placed from a verified pair with a placed image (too few 2D-3D correspondences
    /// for PnP), in order.
    #[serde(default)]
    pub placed_from_pair: Vec<usize>,
    /// Focal lengths that had settled far from the other cameras' and fit the keyframes better
    /// solved again from their median, ending more than 2% from where they had settled
    /// (`focal_restart`).
    #[serde(default)]
    pub focal_restarts: Vec<FocalRestart>,
}

impl Reconstruction {
    /// Per image, per feature: the point it observes.
    pub fn point_of_feature(&self, feature_counts: &[usize]) -> Vec<Vec<Option<u32>>> {
        let mut out: Vec<Vec<Option<u32>>> = feature_counts.iter().map(|&n| vec![None; n]).collect();
        for (p, point) in self.points.iter().enumerate() {
            for &(image, f) in &point.observations {
                if let Some(slot) = out.get_mut(image).and_then(|v| v.get_mut(f as usize)) {
                    *slot = Some(p as u32);
                }
            }
        }
        out
    }

    /// Reprojection errors (px) of a point's observations in registered images.
    pub fn point_errors_px(&self, images: &[MapImage], point: &MapPoint) -> Vec<f64> {
        point
            .observations
            .iter()
            .filter_map(|&(image, f)| {
                let pose = self.poses[image].as_ref()?;
                let xy = images[image].xy[f as usize];
                Some(reprojection_error_px(&self.intrinsics[images[image].camera], pose, &point.xyz, &pixel(xy)))
            })
            .collect()
    }

    /// Reprojection error (px) of every observation.
    pub fn reprojection_errors_px(&self, images: &[MapImage]) -> Vec<f64> {
        self.points.iter().flat_map(|point| self.point_errors_px(images, point)).collect()
    }
}

struct Mapper<'a> {
    images: &'a [MapImage],
    tracks: Tracks,
    options: &'a MapperOptions,
    intrinsics: Vec<Intrinsics>,
    /// Per physical camera, the intrinsics the user gave (held as given).
    held: Vec<HeldIntrinsics>,
    poses: Vec<Option<Pose>>,
    /// Per track: its point (index into `points`), if triangulated.
    point_of_track: Vec<Option<usize>>,
    points: Vec<Option<MapPoint>>,
    fixed_image: usize,
    principal_point_std_px: Vec<Option<f64>>,
    focal_std_px: Vec<Option<f64>>,
    principal_point_refined: bool,
    /// Per physical camera, how far its principal point usually lies from the centre (px).
    principal_prior_px: Vec<f64>,
    /// Images placed from a verified pair rather than by PnP, in order.
    placed_from_pair: Vec<usize>,
    /// Focal lengths solved again from the other cameras' median that moved (`focal_restart`).
    focal_restarts: Vec<FocalRestart>,
}

/// Which map images and points a bundle adjustment problem's images and points are.
struct ProblemIds {
    images: Vec<usize>,
    points: Vec<usize>,
}

/// The longer side of the image of a camera with intrinsics `k`, from its principal point (pixel
/// centres at integers: a centred principal point is at (width - 1) / 2).
pub(crate) fn longer_side_px(k: &Intrinsics) -> f64 {
    2.0 * k.cx_px.max(k.cy_px) + 1.0
}

/// The median of the intrinsics' focal lengths in longer sides of their images; `None` for none.
fn median_focal_factor(intrinsics: impl Iterator<Item = Intrinsics>) -> Option<f64> {
    let mut factors: Vec<f64> = intrinsics.map(|k| k.focal_px / longer_side_px(&k)).collect();
    factors.sort_by(f64::total_cmp);
    factors.get(factors.len() / 2).copied()
}

fn pixel(xy: [f32; 2]) -> Vector2<f64> {
    Vector2::new(f64::from(xy[0]), f64::from(xy[1]))
}

impl Mapper<'_> {
    fn observation(&self, image: usize, feature: u32) -> Vector2<f64> {
        pixel(self.images[image].xy[feature as usize])
    }

    fn error(&self, image: usize, feature: u32, xyz: &Vector3<f64>) -> f64 {
        let Some(pose) = &self.poses[image] else { return f64::INFINITY };
        reprojection_error_px(&self.intrinsics[self.images[image].camera], pose, xyz, &self.observation(image, feature))
    }

    /// Triangulates track `t` from its registered observations, dropping the worst until all
    /// agree; keeps the point when two or more rays at a wide enough angle remain.
    fn triangulate_track(&mut self, t: usize) -> bool {
        if self.point_of_track[t].is_some() {
            return false;
        }
        let obs: Vec<(usize, u32)> = self.tracks.tracks[t].iter().copied().filter(|(i, _)| self.poses[*i].is_some()).collect();
        let views: Vec<Ray> = obs
            .iter()
            .filter_map(|&(i, f)| Some((self.intrinsics[self.images[i].camera], self.poses[i]?, self.observation(i, f))))
            .collect();
        let Some((xyz, kept)) = triangulate_robust(&views, self.options.max_reprojection_px, self.options.min_triangulation_angle_deg)
        else {
            return false;
        };
        self.point_of_track[t] = Some(self.points.len());
        self.points.push(Some(MapPoint { xyz, observations: kept.iter().map(|&k| obs[k]).collect() }));
        true
    }

    /// Adds image `i`'s features to existing points where they agree, and triangulates the
    /// tracks through it that have none.
    fn extend_from_image(&mut self, i: usize) {
        for (f, track) in self.tracks.track_of[i].clone().into_iter().enumerate() {
            let Some(t) = track else { continue };
            match self.point_of_track[t as usize] {
                Some(p) => {
                    let Some(point) = &self.points[p] else { continue };
                    if point.observations.iter().all(|(j, _)| *j != i)
                        && self.error(i, f as u32, &point.xyz) <= self.options.max_reprojection_px
                        && let Some(point) = &mut self.points[p]
                    {
                        point.observations.push((i, f as u32));
                    }
                }
                None => {
                    self.triangulate_track(t as usize);
                }
            }
        }
    }

    fn registered(&self) -> usize {
        self.poses.iter().filter(|p| p.is_some()).count()
    }

    /// Tries to start the model from the pair `(a, b)`; returns the median ray angle (degrees)
    /// of its points when it has enough.
    fn try_initial_pair(&mut self, a: usize, b: usize, pair: &TwoView) -> SfmResult<Option<f64>> {
        let (ka, kb) = (self.intrinsics[self.images[a].camera], self.intrinsics[self.images[b].camera]);
        let pa: Vec<Vector2<f64>> = pair.inliers.iter().map(|m| self.observation(a, m[0])).collect();
        let pb: Vec<Vector2<f64>> = pair.inliers.iter().map(|m| self.observation(b, m[1])).collect();
        let Some(RelativePose { rotation, translation, in_front }) = relative_pose(&ka, &kb, &pa, &pb)? else { return Ok(None) };
        if in_front < self.options.min_initial_points {
            return Ok(None);
        }
        self.poses[a] = Some(Pose { rotation: Matrix3::identity(), center_world: Vector3::zeros() });
        self.poses[b] = Some(Pose::from_rt(rotation, translation));
        for m in &pair.inliers {
            if let Some(t) = self.tracks.track_of[a][m[0] as usize] {
                self.triangulate_track(t as usize);
            }
        }
        if self.points.iter().flatten().count() < self.options.min_initial_points {
            self.reset();
            return Ok(None);
        }
        self.fixed_image = a;
        self.bundle_adjust(false, false)?;
        let (ca, cb) = (self.poses[a].map(|p| p.center_world), self.poses[b].map(|p| p.center_world));
        let (Some(ca), Some(cb)) = (ca, cb) else { return Ok(None) };
        let mut angles: Vec<f64> = self.points.iter().flatten().map(|p| ray_angle_rad(&ca, &cb, &p.xyz).to_degrees()).collect();
        if angles.len() < self.options.min_initial_points {
            return Ok(None);
        }
        angles.sort_by(f64::total_cmp);
        Ok(Some(angles[angles.len() / 2]))
    }

    fn reset(&mut self) {
        self.poses.iter_mut().for_each(|p| *p = None);
        self.points.clear();
        self.point_of_track.iter_mut().for_each(|p| *p = None);
    }

    /// Registers image `i` by PnP against the existing points.
    /// Image `i`'s 2D-3D correspondences: (world point, pixel) of each feature whose track has
    /// a point.
    fn correspondences(&self, i: usize) -> Vec<(Vector3<f64>, Vector2<f64>)> {
        self.tracks.track_of[i]
            .iter()
            .enumerate()
            .filter_map(|(f, track)| {
                let point = self.points[self.point_of_track[(*track)? as usize]?].as_ref()?;
                Some((point.xyz, self.observation(i, f as u32)))
            })
            .collect()
    }

    fn register(&mut self, i: usize) -> SfmResult<bool> {
        let (object, image) = self.pnp_correspondences(i);
        if object.len() < self.options.min_registration_inliers {
            return Ok(false);
        }
        let camera = self.images[i].camera;
        if let Some(pose) = self.pose_by_pnp(&self.intrinsics[camera], &object, &image)? {
            self.poses[i] = Some(pose);
            return Ok(true);
        }
        let placed = (0..self.images.len()).any(|j| self.images[j].camera == camera && self.poses[j].is_some());
        if self.options.refine_focal && !self.held[camera].focal && !placed {
            // The camera's first image: its focal may be far off (`first_focal`).
            if let Some(k) = self.first_focal(camera, &object, &image)?
                && let Some(pose) = self.pose_by_pnp(&k, &object, &image)?
            {
                self.poses[i] = Some(pose);
                self.intrinsics[camera] = k;
                return Ok(true);
            }
        }
        Ok(false)
    }

    /// Image `i`'s 2D-3D correspondences as OpenCV's PnP takes them: world points, pixels.
    fn pnp_correspondences(&self, i: usize) -> (Vector<Point3d>, Vector<Point2d>) {
        let correspondences = self.correspondences(i);
        (
            correspondences.iter().map(|(x, _)| Point3d::new(x.x, x.y, x.z)).collect(),
            correspondences.iter().map(|(_, p)| Point2d::new(p.x, p.y)).collect(),
        )
    }

    /// The pose of an image under intrinsics `k` from its 2D-3D correspondences, by PnP and a
    /// refinement on its inliers; `None` with too few inliers.
    fn pose_by_pnp(&self, k: &Intrinsics, object: &Vector<Point3d>, image: &Vector<Point2d>) -> SfmResult<Option<Pose>> {
        let Some((pose, inliers)) = pnp_ransac(k, object, image, self.options.max_reprojection_px, 2000, 0.9999)? else {
            return Ok(None);
        };
        if inliers < self.options.min_registration_inliers {
            return Ok(None);
        }
        // PnP can return a mirrored pose with the points behind the camera: count the inliers
        // by our own model (cheirality included), then refine the pose alone on them.
        let mut correspondences: Vec<([f64; 3], [f64; 2])> = Vec::new();
        for (object, pixel) in object.iter().zip(image.iter()) {
            let (x, p) = (Vector3::new(object.x, object.y, object.z), Vector2::new(pixel.x, pixel.y));
            if reprojection_error_px(k, &pose, &x, &p) <= self.options.max_reprojection_px {
                correspondences.push((x.into(), p.into()));
            }
        }
        if correspondences.len() < self.options.min_registration_inliers {
            return Ok(None);
        }
        Ok(Some(refine_pose(k, pose, &correspondences, self.options.loss_scale_px)?))
    }

    /// The intrinsics for a camera's first image when PnP failed under its current focal (the
    /// self-calibration or the prior): the focal under which PnP explains the most of the
    /// image's correspondences, among the median of the cameras placed so far and 0.5-2 x the
    /// longer side (`None` when none explains any). Cameras at an event differ in zoom; bundle adjustment refines the focal
    /// afterwards, but only once PnP has found a pose, which a focal 30% off can prevent (on
    /// the Panoptic arc, 2 of its 8 cameras).
    fn first_focal(&self, camera: usize, object: &Vector<Point3d>, image: &Vector<Point2d>) -> SfmResult<Option<Intrinsics>> {
        let current = self.intrinsics[camera];
        let mut factors: Vec<f64> = (0..=14).map(|n| 0.5 * 1.104_f64.powi(n)).collect();
        factors.extend(self.placed_focal_factor());
        let mut best: Option<(Intrinsics, usize)> = None;
        for focal_px in factors.iter().map(|f| f * longer_side_px(&current)) {
            let k = Intrinsics { focal_px, ..current };
            if let Some((_, inliers)) = pnp_ransac(&k, object, image, self.options.max_reprojection_px, 500, 0.999)?
                && best.is_none_or(|(_, most)| inliers > most)
            {
                best = Some((k, inliers));
            }
        }
        Ok(best.map(|(k, _)| k))
    }

    /// Global bundle adjustment of every registered image and point, then outlier filtering.
    /// `last`: the final adjustment, which also refines what the options allow beyond focals.
    fn bundle_adjust(&mut self, refine_focal: bool, last: bool) -> SfmResult<()> {
        let (mut problem, ids) = self.ba_problem();
        let options = self.ba_options(refine_focal, last);
        if last {
            let solved = solve_final(&mut problem, options, self.options.refine_principal_point, &self.principal_prior_px)?;
            self.principal_point_std_px = solved.principal_point_std_px;
            self.principal_point_refined = solved.principal_point_refined;
            self.focal_std_px = solved.std.iter().map(|s| s.focal_px).collect();
        } else {
            dynview_ba::solve(&mut problem, &options)?;
        }
        self.apply_solution(&problem, &ids);
        Ok(())
    }

    /// The bundle adjustment options of [`Self::bundle_adjust`].
    fn ba_options(&self, refine_focal: bool, last: bool) -> dynview_ba::Options {
        dynview_ba::Options {
            loss: dynview_ba::Loss::Cauchy { scale_px: self.options.loss_scale_px },
            refine_focal: refine_focal && self.options.refine_focal,
            refine_principal_point: false,
            refine_distortion: last && self.options.refine_distortion,
            max_iterations: 50,
            ..Default::default()
        }
    }

    /// Every registered image and point as a bundle adjustment problem, with the images' and
    /// points' indices in the map of its images and points.
    fn ba_problem(&self) -> (dynview_ba::Problem, ProblemIds) {
        let image_ids: Vec<usize> = (0..self.poses.len()).filter(|&i| self.poses[i].is_some()).collect();
        let mut slot = vec![usize::MAX; self.poses.len()];
        for (s, &i) in image_ids.iter().enumerate() {
            slot[i] = s;
        }
        let point_ids: Vec<usize> = (0..self.points.len()).filter(|&p| self.points[p].is_some()).collect();
        let mut problem = dynview_ba::Problem {
            cameras: self.intrinsics.iter().copied().map(dynview_ba::CameraIntrinsics::from).collect(),
            images: image_ids.iter().map(|&i| self.poses[i].unwrap_or_else(|| unreachable!()).into()).collect(),
            image_camera: image_ids.iter().map(|&i| self.images[i].camera).collect(),
            image_fixed: image_ids.iter().map(|&i| i == self.fixed_image).collect(),
            points_world: point_ids.iter().map(|&p| self.points[p].as_ref().map_or([0.0; 3], |q| q.xyz.into())).collect(),
            point_fixed: vec![false; point_ids.len()],
            observations: Vec::new(),
            priors: Vec::new(),
            held_intrinsics: self.held.clone(),
        };
        for (s, &p) in point_ids.iter().enumerate() {
            for &(i, f) in &self.points[p].as_ref().map_or(&Vec::new(), |q| &q.observations).clone() {
                problem.observations.push(dynview_ba::Observation { image: slot[i], point: s, pixel: self.observation(i, f).into() });
            }
        }
        (problem, ProblemIds { images: image_ids, points: point_ids })
    }

    /// Takes the poses, points and intrinsics of a solved [`Self::ba_problem`], then drops the
    /// outliers.
    fn apply_solution(&mut self, problem: &dynview_ba::Problem, ids: &ProblemIds) {
        for (s, &i) in ids.images.iter().enumerate() {
            self.poses[i] = Some(problem.images[s].into());
        }
        for (s, &p) in ids.points.iter().enumerate() {
            if let Some(point) = &mut self.points[p] {
                point.xyz = problem.points_world[s].into();
            }
        }
        for (c, k) in problem.cameras.iter().enumerate() {
            self.intrinsics[c] = Intrinsics::from(*k);
        }
        self.filter_outliers();
    }

    /// Drops observations above the reprojection limit and points left with fewer than two.
    fn filter_outliers(&mut self) {
        for t in 0..self.point_of_track.len() {
            let Some(p) = self.point_of_track[t] else { continue };
            let Some(point) = self.points[p].take() else { continue };
            let observations: Vec<(usize, u32)> = point
                .observations
                .iter()
                .copied()
                .filter(|&(i, f)| self.error(i, f, &point.xyz) <= self.options.max_reprojection_px)
                .collect();
            if observations.len() >= 2 {
                self.points[p] = Some(MapPoint { xyz: point.xyz, observations });
            } else {
                self.point_of_track[t] = None;
            }
        }
    }

    /// Places an unregistered image from a verified pair with a registered one when PnP has
    /// too few correspondences (`relative`): the pair gives its rotation and translation
    /// direction, its points the translation's length. The strongest pairs are tried first,
    /// each once per number of registered images; returns the image placed.
    fn register_from_pair(
        &mut self,
        pairs: &[(usize, usize, TwoView)],
        match_options: &MatchOptions,
        tried: &mut std::collections::HashSet<(usize, usize, usize)>,
    ) -> SfmResult<Option<usize>> {
        let registered = self.registered();
        let mut candidates: Vec<(usize, usize, &TwoView, bool)> = pairs
            .iter()
            .filter(|(_, _, v)| v.inliers.len() >= self.options.min_initial_points && !v.is_degenerate(match_options))
            .filter_map(|(a, b, v)| match (self.poses[*a].is_some(), self.poses[*b].is_some()) {
                (true, false) => Some((*b, *a, v, false)),
                (false, true) => Some((*a, *b, v, true)),
                _ => None,
            })
            .collect();
        candidates.sort_by_key(|(new, placed, v, _)| (std::cmp::Reverse(v.inliers.len()), *new, *placed));
        for (new, placed, pair, new_is_a) in candidates {
            if !tried.insert((new, placed, registered)) {
                continue;
            }
            // Each match is [feature in the pair's first image, feature in its second].
            let (new_side, placed_side) = if new_is_a { (0, 1) } else { (1, 0) };
            let pixels = |image: usize, side: usize| -> Vec<Vector2<f64>> {
                pair.inliers.iter().map(|m| self.observation(image, m[side])).collect()
            };
            let camera = self.images[new].camera;
            let k_placed = self.intrinsics[self.images[placed].camera];
            let Some(placed_pose) = self.poses[placed] else { continue };
            let correspondences = self.correspondences(new);
            let min_inliers = MIN_PAIR_SCALE_INLIERS.max(correspondences.len().div_ceil(2));
            for k_new in self.pair_focals(camera) {
                let Some(relative) = relative_pose(&k_placed, &k_new, &pixels(placed, placed_side), &pixels(new, new_side))? else {
                    continue;
                };
                if relative.in_front < self.options.min_initial_points {
                    continue;
                }
                if let Some((pose, _)) =
                    place_along(&k_new, &placed_pose, &relative, &correspondences, self.options.max_reprojection_px, min_inliers)
                {
                    self.poses[new] = Some(pose);
                    self.intrinsics[camera] = k_new;
                    self.placed_from_pair.push(new);
                    return Ok(Some(new));
                }
            }
        }
        Ok(None)
    }

    /// The intrinsics to place an image of `camera` from a pair under: its own, then, for a
    /// camera with no image placed yet whose focal may be refined, its own with the median
    /// focal of the placed cameras (every camera starts from one focal, the self-calibration or
    /// the prior, which bundle adjustment has since refined for the placed ones: on the temple
    /// ring as 16 one-frame cameras the prior is half the true focal and the placed cameras'
    /// median within 1% of it).
    fn pair_focals(&self, camera: usize) -> Vec<Intrinsics> {
        let own = self.intrinsics[camera];
        let unplaced = !(0..self.images.len()).any(|j| self.images[j].camera == camera && self.poses[j].is_some());
        match self.placed_focal_factor().map(|factor| factor * longer_side_px(&own)) {
            Some(focal_px)
                if self.options.refine_focal && !self.held[camera].focal && unplaced && (focal_px / own.focal_px - 1.0).abs() > 0.01 =>
            {
                vec![own, Intrinsics { focal_px, ..own }]
            }
            _ => vec![own],
        }
    }

    /// The median focal of the images placed so far, in longer sides of their camera's image.
    fn placed_focal_factor(&self) -> Option<f64> {
        median_focal_factor((0..self.images.len()).filter(|&j| self.poses[j].is_some()).map(|j| self.intrinsics[self.images[j].camera]))
    }

    fn next_image(&self, failed: &[bool]) -> Option<usize> {
        (0..self.images.len())
            .filter(|&i| self.poses[i].is_none() && !failed[i])
            .map(|i| {
                let seen = self.tracks.track_of[i].iter().filter(|t| t.and_then(|t| self.point_of_track[t as usize]).is_some()).count();
                (i, seen)
            })
            .filter(|&(_, seen)| seen >= self.options.min_registration_inliers)
            .max_by_key(|&(i, seen)| (seen, std::cmp::Reverse(i)))
            .map(|(i, _)| i)
    }
}

/// Refines one image's pose on fixed 3D points (robust loss).
pub fn refine_pose(k: &Intrinsics, pose: Pose, correspondences: &[([f64; 3], [f64; 2])], loss_scale_px: f64) -> SfmResult<Pose> {
    let mut problem = dynview_ba::Problem {
        cameras: vec![dynview_ba::CameraIntrinsics::from(*k)],
        images: vec![pose.into()],
        image_camera: vec![0],
        image_fixed: vec![false],
        points_world: correspondences.iter().map(|c| c.0).collect(),
        point_fixed: vec![true; correspondences.len()],
        observations: correspondences.iter().enumerate().map(|(p, c)| dynview_ba::Observation { image: 0, point: p, pixel: c.1 }).collect(),
        priors: Vec::new(),
        held_intrinsics: Vec::new(),
    };
    let options = dynview_ba::Options {
        loss: dynview_ba::Loss::Cauchy { scale_px: loss_scale_px },
        refine_focal: false,
        refine_principal_point: false,
        refine_distortion: false,
        max_iterations: 30,
        ..Default::default()
    };
    dynview_ba::solve(&mut problem, &options)?;
    let p = &problem.images[0];
    Ok((*p).into())
}

/// Reconstructs the keyframes `images` from verified `pairs` `(a, b, geometry)` with initial
/// `intrinsics` per physical camera, of which each holds what `held` says (empty: nothing).
#[allow(clippy::too_many_arguments)]
pub fn reconstruct(
    images: &[MapImage],
    pairs: &[(usize, usize, TwoView)],
    intrinsics: Vec<Intrinsics>,
    held: Vec<HeldIntrinsics>,
    match_options: &MatchOptions,
    options: &MapperOptions,
    progress: StageProgress,
    interrupt: &std::sync::atomic::AtomicBool,
) -> SfmResult<Reconstruction> {
    let counts: Vec<usize> = images.iter().map(|i| i.xy.len()).collect();
    let matches: Vec<(usize, usize, Vec<[u32; 2]>)> = pairs.iter().map(|(a, b, v)| (*a, *b, v.inliers.clone())).collect();
    let tracks = Tracks::build(&counts, &matches);
    // The initial principal points are the image centres: the longer side is twice the larger.
    let principal_prior_px = intrinsics.iter().map(|k| PRINCIPAL_POINT_PRIOR_FRACTION * longer_side_px(k)).collect();
    let mut mapper = Mapper {
        images,
        point_of_track: vec![None; tracks.tracks.len()],
        tracks,
        options,
        held: if held.is_empty() { vec![HeldIntrinsics::default(); intrinsics.len()] } else { held },
        intrinsics,
        poses: vec![None; images.len()],
        points: Vec::new(),
        fixed_image: 0,
        principal_point_std_px: Vec::new(),
        focal_std_px: Vec::new(),
        principal_point_refined: false,
        principal_prior_px,
        placed_from_pair: Vec::new(),
        focal_restarts: Vec::new(),
    };
    // Pairs of two physical cameras first (frames of one camera may have no baseline), then
    // the most matches; a pair is accepted only if enough points triangulate at a wide angle.
    let mut candidates: Vec<&(usize, usize, TwoView)> =
        pairs.iter().filter(|(_, _, v)| v.inliers.len() >= options.min_initial_points).collect();
    candidates.sort_by_key(|(a, b, v)| {
        (images[*a].camera == images[*b].camera, v.is_degenerate(match_options), std::cmp::Reverse(v.inliers.len()), *a, *b)
    });
    let mut started = false;
    let mut widest: Option<(f64, usize, usize)> = None;
    for (a, b, pair) in candidates.iter().take(30) {
        let angle = mapper.try_initial_pair(*a, *b, pair)?;
        if let Some(angle) = angle {
            if angle >= options.init_min_median_angle_deg {
                started = true;
                break;
            }
            if widest.is_none_or(|w| angle > w.0) {
                widest = Some((angle, *a, *b));
            }
        }
        mapper.reset();
    }
    if !started && let Some((_, a, b)) = widest {
        let pair = candidates.iter().find(|(x, y, _)| (*x, *y) == (a, b)).map(|c| &c.2);
        if let Some(pair) = pair {
            started = mapper.try_initial_pair(a, b, pair)?.is_some();
        }
    }
    if !started {
        return Err(SfmError::Reconstruction(format!(
            "no image pair has enough matches with parallax to start ({} verified pairs, {} with parallax); the cameras may share too little of the scene, or the frames are textureless",
            pairs.iter().filter(|p| !p.2.inliers.is_empty()).count(),
            candidates.len()
        )));
    }
    let total = images.len() as u64;
    progress("keyframe SfM", mapper.registered() as u64, total);
    let mut failed = vec![false; images.len()];
    let mut last_ba = mapper.registered();
    let mut tried_pairs = std::collections::HashSet::new();
    loop {
        SfmError::check_interrupt(interrupt)?;
        let i = match mapper.next_image(&failed) {
            Some(i) => {
                if !mapper.register(i)? {
                    failed[i] = true;
                    continue;
                }
                i
            }
            None => match mapper.register_from_pair(pairs, match_options, &mut tried_pairs)? {
                Some(i) => i,
                None => break,
            },
        };
        mapper.extend_from_image(i);
        let n = mapper.registered();
        if n <= 8 || n as f64 >= 1.25 * last_ba as f64 {
            mapper.bundle_adjust(n >= 3, false)?;
            last_ba = n;
            // Tracks that failed before may triangulate now.
            for t in 0..mapper.point_of_track.len() {
                mapper.triangulate_track(t);
            }
            failed.iter_mut().for_each(|f| *f = false);
        }
        progress("keyframe SfM", n as u64, total);
    }
    mapper.bundle_adjust(true, false)?;
    for t in 0..mapper.point_of_track.len() {
        mapper.triangulate_track(t);
    }
    mapper.restart_outlying_focals()?;
    mapper.bundle_adjust(true, true)?;
    Ok(Reconstruction {
        intrinsics: mapper.intrinsics,
        poses: mapper.poses,
        points: mapper.points.into_iter().flatten().collect(),
        principal_point_std_px: mapper.principal_point_std_px,
        focal_std_px: mapper.focal_std_px,
        principal_point_refined: mapper.principal_point_refined,
        placed_from_pair: mapper.placed_from_pair,
        focal_restarts: mapper.focal_restarts,
    })
}

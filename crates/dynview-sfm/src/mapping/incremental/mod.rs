//! Incremental structure from motion on keyframes: initial pair, registration by PnP
//! (`registration`), triangulation of tracks, bundle adjustment with a robust loss and outlier
//! filtering (`adjustment`), a second start for focal lengths that settled far from the others'
//! (`focal_restart`).

use dynview_ba::HeldIntrinsics;
use dynview_camera::{PoseMatrices, Radial, Rigid3};
use dynview_core::StageProgress;
use nalgebra::{Vector2, Vector3};

use crate::error::{SfmError, SfmResult};
use crate::estimators::geometry::{Ray, ray_angle_rad, reprojection_error_px, triangulate_robust};
use crate::estimators::relative::{RelativePose, relative_pose};
use crate::features::matching::{MatchOptions, TwoView};
use crate::features::tracks::Tracks;

mod adjustment;
mod focal_restart;
mod options;
mod registration;

pub use adjustment::refine_pose;
pub(crate) use adjustment::solve_final;
pub use options::{MapperOptions, PRINCIPAL_POINT_PRIOR_FRACTION};

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
    pub intrinsics: Vec<Radial>,
    /// Per image, `camera_from_world`; `None` when it could not be registered.
    pub poses: Vec<Option<Rigid3>>,
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

/// A camera whose focal length, solved again from the others' median, fit better and ended
/// more than 2% (`focal_restart`'s `MOVED_FOCAL_FRACTION`) from where it had settled.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FocalRestart {
    /// The intrinsics set.
    pub camera: usize,
    /// Where its focal length had settled (px).
    pub settled_px: f64,
    /// The start it was solved from: the other cameras' median (px).
    pub restarted_px: f64,
    /// The adjustment's cost from where it had settled and from the restart.
    pub cost: [f64; 2],
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

    /// Per image, its pose's [`PoseMatrices`] (for [`Reconstruction::point_errors_px`]).
    pub fn pose_matrices(&self) -> Vec<Option<PoseMatrices>> {
        self.poses.iter().map(|pose| pose.as_ref().map(Rigid3::matrices)).collect()
    }

    /// Reprojection errors (px) of a point's observations in registered images, whose poses'
    /// matrices are `poses` ([`Reconstruction::pose_matrices`]).
    pub fn point_errors_px(&self, images: &[MapImage], poses: &[Option<PoseMatrices>], point: &MapPoint) -> Vec<f64> {
        point
            .observations
            .iter()
            .filter_map(|&(image, f)| {
                let pose = poses[image].as_ref()?;
                let xy = images[image].xy[f as usize];
                Some(reprojection_error_px(&self.intrinsics[images[image].camera], pose, &point.xyz, &pixel(xy)))
            })
            .collect()
    }

    /// Reprojection error (px) of every observation.
    pub fn reprojection_errors_px(&self, images: &[MapImage]) -> Vec<f64> {
        let poses = self.pose_matrices();
        self.points.iter().flat_map(|point| self.point_errors_px(images, &poses, point)).collect()
    }
}

struct Mapper<'a> {
    images: &'a [MapImage],
    tracks: Tracks,
    options: &'a MapperOptions,
    intrinsics: Vec<Radial>,
    /// Per physical camera, the intrinsics the user gave (held as given).
    held: Vec<HeldIntrinsics>,
    poses: Vec<Option<Rigid3>>,
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

/// The longer side of the image of a camera with intrinsics `k`, from its principal point (pixel
/// centres at integers: a centred principal point is at (width - 1) / 2).
pub(crate) fn longer_side_px(k: &Radial) -> f64 {
    2.0 * k.cx.max(k.cy) + 1.0
}

/// The median of the intrinsics' focal lengths in longer sides of their images; `None` for none.
fn median_focal_factor(intrinsics: impl Iterator<Item = Radial>) -> Option<f64> {
    let mut factors: Vec<f64> = intrinsics.map(|k| k.f / longer_side_px(&k)).collect();
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

    /// The reprojection error (px) of `xyz` at feature `feature` of image `image`, whose pose's
    /// matrices are `pose` (infinite when it has none).
    fn error(&self, pose: Option<&PoseMatrices>, image: usize, feature: u32, xyz: &Vector3<f64>) -> f64 {
        let Some(pose) = pose else { return f64::INFINITY };
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
        let pose = self.poses[i].map(|pose| pose.matrices());
        for (f, track) in self.tracks.track_of[i].clone().into_iter().enumerate() {
            let Some(t) = track else { continue };
            match self.point_of_track[t as usize] {
                Some(p) => {
                    let Some(point) = &self.points[p] else { continue };
                    if point.observations.iter().all(|(j, _)| *j != i)
                        && self.error(pose.as_ref(), i, f as u32, &point.xyz) <= self.options.max_reprojection_px
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
        self.poses[a] = Some(Rigid3::IDENTITY);
        self.poses[b] = Some(Rigid3::from_rotation_translation(rotation, translation));
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
        let (ca, cb) = (self.poses[a].map(|p| p.center()), self.poses[b].map(|p| p.center()));
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
}

/// Reconstructs the keyframes `images` from verified `pairs` `(a, b, geometry)` with initial
/// `intrinsics` per physical camera, of which each holds what `held` says (empty: nothing).
#[allow(clippy::too_many_arguments)]
pub fn reconstruct(
    images: &[MapImage],
    pairs: &[(usize, usize, TwoView)],
    intrinsics: Vec<Radial>,
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

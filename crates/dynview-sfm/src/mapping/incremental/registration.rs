//! Registering images: by PnP against the points (with a second try at the focal length for
//! a camera's first image), or, with too few 2D-3D correspondences, from a verified pair with a
//! placed image; and which image to register next.

use dynview_camera::{Radial, Rigid3};
use nalgebra::{Vector2, Vector3};
use opencv::core::{Point2d, Point3d, Vector};

use super::adjustment::refine_pose;
use super::{Mapper, longer_side_px, median_focal_factor};
use crate::error::SfmResult;
use crate::estimators::geometry::reprojection_error_px;
use crate::estimators::pnp::pnp_ransac;
use crate::estimators::relative::{place_along, relative_pose};
use crate::features::matching::{MatchOptions, TwoView};

/// Fewest of an image's 2D-3D correspondences that must agree on the translation's length
/// when it is placed from a verified pair (`relative::place_along`); at least half of them
/// must, too.
const MIN_PAIR_SCALE_INLIERS: usize = 5;

impl Mapper<'_> {
    /// Image `i`'s 2D-3D correspondences: (world point, pixel) of each feature whose track has
    /// a point.
    pub(super) fn correspondences(&self, i: usize) -> Vec<(Vector3<f64>, Vector2<f64>)> {
        self.tracks.track_of[i]
            .iter()
            .enumerate()
            .filter_map(|(f, track)| {
                let point = self.points[self.point_of_track[(*track)? as usize]?].as_ref()?;
                Some((point.xyz, self.observation(i, f as u32)))
            })
            .collect()
    }

    /// Registers image `i` by PnP against the existing points (under its camera's focal, then,
    /// for a camera's first image, under the focal that explains the most of them).
    pub(super) fn register(&mut self, i: usize) -> SfmResult<bool> {
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
    pub(super) fn pnp_correspondences(&self, i: usize) -> (Vector<Point3d>, Vector<Point2d>) {
        let correspondences = self.correspondences(i);
        (
            correspondences.iter().map(|(x, _)| Point3d::new(x.x, x.y, x.z)).collect(),
            correspondences.iter().map(|(_, p)| Point2d::new(p.x, p.y)).collect(),
        )
    }

    /// The pose of an image under intrinsics `k` from its 2D-3D correspondences, by PnP and a
    /// refinement on its inliers; `None` with too few inliers.
    pub(super) fn pose_by_pnp(&self, k: &Radial, object: &Vector<Point3d>, image: &Vector<Point2d>) -> SfmResult<Option<Rigid3>> {
        let Some((pose, inliers)) = pnp_ransac(k, object, image, self.options.max_reprojection_px, 2000, 0.9999)? else {
            return Ok(None);
        };
        if inliers < self.options.min_registration_inliers {
            return Ok(None);
        }
        // PnP can return a mirrored pose with the points behind the camera: count the inliers
        // by our own model (cheirality included), then refine the pose alone on them.
        let mut correspondences: Vec<([f64; 3], [f64; 2])> = Vec::new();
        let matrices = pose.matrices();
        for (object, pixel) in object.iter().zip(image.iter()) {
            let (x, p) = (Vector3::new(object.x, object.y, object.z), Vector2::new(pixel.x, pixel.y));
            if reprojection_error_px(k, &matrices, &x, &p) <= self.options.max_reprojection_px {
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
    pub(super) fn first_focal(&self, camera: usize, object: &Vector<Point3d>, image: &Vector<Point2d>) -> SfmResult<Option<Radial>> {
        let current = self.intrinsics[camera];
        let mut factors: Vec<f64> = (0..=14).map(|n| 0.5 * 1.104_f64.powi(n)).collect();
        factors.extend(self.placed_focal_factor());
        let mut best: Option<(Radial, usize)> = None;
        for focal_px in factors.iter().map(|f| f * longer_side_px(&current)) {
            let k = Radial { f: focal_px, ..current };
            if let Some((_, inliers)) = pnp_ransac(&k, object, image, self.options.max_reprojection_px, 500, 0.999)?
                && best.is_none_or(|(_, most)| inliers > most)
            {
                best = Some((k, inliers));
            }
        }
        Ok(best.map(|(k, _)| k))
    }

    /// Places an unregistered image from a verified pair with a registered one when PnP has
    /// too few correspondences (`relative`): the pair gives its rotation and translation
    /// direction, its points the translation's length. The strongest pairs are tried first,
    /// each once per number of registered images; returns the image placed.
    pub(super) fn register_from_pair(
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
    pub(super) fn pair_focals(&self, camera: usize) -> Vec<Radial> {
        let own = self.intrinsics[camera];
        let unplaced = !(0..self.images.len()).any(|j| self.images[j].camera == camera && self.poses[j].is_some());
        match self.placed_focal_factor().map(|factor| factor * longer_side_px(&own)) {
            Some(focal_px)
                if self.options.refine_focal && !self.held[camera].focal && unplaced && (focal_px / own.f - 1.0).abs() > 0.01 =>
            {
                vec![own, Radial { f: focal_px, ..own }]
            }
            _ => vec![own],
        }
    }

    /// The median focal of the images placed so far, in longer sides of their camera's image.
    pub(super) fn placed_focal_factor(&self) -> Option<f64> {
        median_focal_factor((0..self.images.len()).filter(|&j| self.poses[j].is_some()).map(|j| self.intrinsics[self.images[j].camera]))
    }

    pub(super) fn next_image(&self, failed: &[bool]) -> Option<usize> {
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

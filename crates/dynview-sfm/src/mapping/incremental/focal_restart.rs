//! A second start for focal lengths that settled far from the others'.
//!
//! Every camera whose focal length nothing measured starts at the prior (1.2 x the longer
//! side), and bundle adjustment walks it to the data's optimum. A camera tied to the others by
//! few points can stop on the way: on the Panoptic arc's end camera (cam00, 80 2D-3D
//! correspondences at registration, true focal 545 px) it settled at 683 px, 25% off, turned
//! 3.2 degrees, with a reported standard deviation of 1.2% that described the wrong basin.
//! Before the final adjustment, each such camera is solved again from the median focal of the
//! other cameras, its images placed anew by PnP under it, and the solution whose cost is lower
//! on the same observations is kept.

use dynview_camera::Radial;

use super::{FocalRestart, Mapper, longer_side_px, median_focal_factor};
use crate::error::SfmResult;

/// How far (as a fraction) a camera's focal may lie from the median of the other cameras'
/// before it is also solved from there. Lenses at one event differ (the Panoptic cameras by
/// -15% to +15% around their median, the synthetic arcs' by up to 33%), so this only chooses
/// whom to try, and the cost decides; each try is a bundle adjustment of the whole model (at
/// 10%, arc12x60's 36 keyframes took 14.2 s instead of 7.5 to come back to the same optimum).
const OUTLYING_FOCAL_FRACTION: f64 = 0.2;

/// How far (as a fraction) a restarted focal length must end from where it had settled for
/// the restart to count as a different solution (and be reported): restarts that return to the
/// same optimum differ by a small fraction of a percent.
const MOVED_FOCAL_FRACTION: f64 = 0.02;

impl Mapper<'_> {
    /// Solves each outlying focal length again from the other cameras' median and keeps the
    /// better fit (see the module documentation); records the restarts that moved a focal.
    pub(super) fn restart_outlying_focals(&mut self) -> SfmResult<()> {
        if !self.options.refine_focal {
            return Ok(());
        }
        let (registered, held) = (self.registered_cameras(), self.held.clone());
        let outlying = |cameras: &[Radial], camera: usize| -> Option<f64> {
            let start_px = others_focal_factor(cameras, &registered, camera)? * longer_side_px(&cameras[camera]);
            let outlying = !held[camera].focal && (cameras[camera].f / start_px - 1.0).abs() > OUTLYING_FOCAL_FRACTION;
            outlying.then_some(start_px)
        };
        let (mut best, ids) = self.ba_problem();
        if !(0..best.cameras.len()).any(|c| outlying(&best.cameras, c).is_some()) {
            return Ok(());
        }
        let options = self.ba_options(true, false);
        let mut best_cost = dynview_ba::solve(&mut best, &options)?.final_cost;
        for camera in 0..best.cameras.len() {
            let Some(start_px) = outlying(&best.cameras, camera) else { continue };
            let mut trial = best.clone();
            let k = Radial { f: start_px, ..best.cameras[camera] };
            trial.cameras[camera] = k;
            for (slot, &image) in ids.images.iter().enumerate() {
                if self.images[image].camera != camera {
                    continue;
                }
                let (object, pixels) = self.pnp_correspondences(image);
                if let Some(pose) = self.pose_by_pnp(&k, &object, &pixels)? {
                    trial.images[slot] = pose;
                }
            }
            let trial_cost = dynview_ba::solve(&mut trial, &options)?.final_cost;
            if trial_cost < best_cost {
                let (settled_px, ended_px) = (best.cameras[camera].f, trial.cameras[camera].f);
                if (ended_px / settled_px - 1.0).abs() > MOVED_FOCAL_FRACTION {
                    self.focal_restarts.push(FocalRestart { camera, settled_px, restarted_px: start_px, cost: [best_cost, trial_cost] });
                }
                (best, best_cost) = (trial, trial_cost);
            }
        }
        self.apply_solution(&best, &ids);
        Ok(())
    }

    /// Per intrinsics set, whether an image of it is registered.
    fn registered_cameras(&self) -> Vec<bool> {
        let mut registered = vec![false; self.intrinsics.len()];
        for (image, pose) in self.images.iter().zip(&self.poses) {
            registered[image.camera] |= pose.is_some();
        }
        registered
    }
}

/// The median focal factor (focal / longer side) of the registered cameras other than
/// `camera`; `None` when there are none.
fn others_focal_factor(cameras: &[Radial], registered: &[bool], camera: usize) -> Option<f64> {
    median_focal_factor((0..cameras.len()).filter(|&c| c != camera && registered[c]).map(|c| cameras[c]))
}

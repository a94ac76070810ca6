//! An experiment measured by `eval-real` (issue 15, part 2): the best-ranked input view warped
//! with the renderer's plane alone (`dynview_core::render::plane`, fitted to the step's points
//! as the virtual camera sees them), with nothing of the full method. A plane is wrong almost
//! everywhere, but it warps a view as a homography: the picture stays a real, undistorted
//! photograph (sharp, no doubled or swirled texture), only displaced.

use dynview_core::render::plane::InverseDepthPlane;
use dynview_core::render::pushpull;
use dynview_core::render::warp::warp_view;
use dynview_core::scene::PointCloud;
use dynview_core::{Camera, RgbRaster, ScalarRaster};

/// The best-ranked input (`input`, seen by `input_camera`) warped into `camera` with the plane
/// fitted to `cloud`; holes (off the input image) filled by push-pull. `None` when the cloud
/// gives no plane.
pub fn plane_view(camera: &Camera, cloud: &PointCloud, input_camera: &Camera, input: &RgbRaster) -> Option<RgbRaster> {
    let plane = InverseDepthPlane::fit(camera, cloud)?;
    let (w, h) = (camera.width_px as usize, camera.height_px as usize);
    let depth = ScalarRaster::from_vec(w, h, plane.depth_map(camera))?;
    let warp = warp_view(camera, &depth, input_camera, input);
    let weights = ScalarRaster::from_vec(w, h, (0..w * h).map(|i| if warp.valid(i) { 1.0 } else { 0.0 }).collect())?;
    let color = RgbRaster::from_vec(w, h, warp.color)?;
    Some(pushpull::fill(&color, &weights, [0.5; 3]))
}

//! Camera pose from 2D-3D correspondences: OpenCV's EPnP inside RANSAC.

use nalgebra::{Rotation3, Vector3};
use opencv::calib3d;
use opencv::core::{Mat, Point2d, Point3d, Vector};
use opencv::prelude::*;

use dynview_camera::{Radial, Rigid3};

use crate::error::{SfmError, SfmResult};

/// The pose of a camera with intrinsics `k` seeing `object` points at `image` pixels, and its
/// inlier count (reprojection within `max_px`); `None` when RANSAC finds nothing or a value is
/// not finite.
pub fn pnp_ransac(
    k: &Radial,
    object: &Vector<Point3d>,
    image: &Vector<Point2d>,
    max_px: f64,
    iterations: i32,
    confidence: f64,
) -> SfmResult<Option<(Rigid3, usize)>> {
    let camera_matrix =
        Mat::from_slice_2d(&[[k.f, 0.0, k.cx], [0.0, k.f, k.cy], [0.0, 0.0, 1.0]]).map_err(SfmError::cv("camera matrix"))?;
    let distortion = Mat::from_slice(&[k.k1, k.k2, 0.0, 0.0]).and_then(|m| m.try_clone()).map_err(SfmError::cv("distortion"))?;
    let (mut rvec, mut tvec, mut inliers) = (Mat::default(), Mat::default(), Mat::default());
    let ok = calib3d::solve_pnp_ransac(
        object,
        image,
        &camera_matrix,
        &distortion,
        &mut rvec,
        &mut tvec,
        false,
        iterations,
        max_px as f32,
        confidence,
        &mut inliers,
        calib3d::SOLVEPNP_EPNP,
    )
    .map_err(SfmError::cv("PnP"))?;
    if !ok {
        return Ok(None);
    }
    let read = |m: &Mat| Vector3::from_fn(|r, _| m.at::<f64>(r as i32).copied().unwrap_or(f64::NAN));
    let (aa, t) = (read(&rvec), read(&tvec));
    if !aa.iter().chain(t.iter()).all(|v| v.is_finite()) {
        return Ok(None);
    }
    Ok(Some((Rigid3::from_rotation_translation(Rotation3::from_scaled_axis(aa).into_inner(), t), inliers.rows().max(0) as usize)))
}

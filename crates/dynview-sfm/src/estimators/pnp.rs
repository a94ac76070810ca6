//! Camera pose from 2D-3D correspondences: OpenCV's EPnP (or AP3P, on minimal samples) inside
//! RANSAC, and its Levenberg-Marquardt refinement.

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
    ransac(k, object, image, max_px, iterations, confidence, calib3d::SOLVEPNP_EPNP)
}

/// [`pnp_ransac`] with AP3P on samples of four correspondences: the fewest, so the most likely
/// to be all inliers where few are.
pub fn pnp_ransac_minimal(
    k: &Radial,
    object: &Vector<Point3d>,
    image: &Vector<Point2d>,
    max_px: f64,
    iterations: i32,
    confidence: f64,
) -> SfmResult<Option<(Rigid3, usize)>> {
    ransac(k, object, image, max_px, iterations, confidence, calib3d::SOLVEPNP_AP3P)
}

/// `pose` refined by Levenberg-Marquardt over the correspondences (all of them inliers);
/// `None` when a value comes out not finite.
pub fn pnp_refine(k: &Radial, object: &Vector<Point3d>, image: &Vector<Point2d>, pose: &Rigid3) -> SfmResult<Option<Rigid3>> {
    let (camera_matrix, distortion) = opencv_camera(k)?;
    let aa = pose.angle_axis();
    let t = pose.translation;
    let mut rvec = Mat::from_slice_2d(&[[aa.x], [aa.y], [aa.z]]).map_err(SfmError::cv("rotation"))?;
    let mut tvec = Mat::from_slice_2d(&[[t.x], [t.y], [t.z]]).map_err(SfmError::cv("translation"))?;
    let criteria = opencv::core::TermCriteria::new(opencv::core::TermCriteria_COUNT + opencv::core::TermCriteria_EPS, 50, 1e-10)
        .map_err(SfmError::cv("termination"))?;
    calib3d::solve_pnp_refine_lm(object, image, &camera_matrix, &distortion, &mut rvec, &mut tvec, criteria)
        .map_err(SfmError::cv("PnP refinement"))?;
    Ok(pose_from(&rvec, &tvec))
}

fn opencv_camera(k: &Radial) -> SfmResult<(Mat, Mat)> {
    let camera_matrix =
        Mat::from_slice_2d(&[[k.f, 0.0, k.cx], [0.0, k.f, k.cy], [0.0, 0.0, 1.0]]).map_err(SfmError::cv("camera matrix"))?;
    let distortion = Mat::from_slice(&[k.k1, k.k2, 0.0, 0.0]).and_then(|m| m.try_clone()).map_err(SfmError::cv("distortion"))?;
    Ok((camera_matrix, distortion))
}

fn pose_from(rvec: &Mat, tvec: &Mat) -> Option<Rigid3> {
    let read = |m: &Mat| Vector3::from_fn(|r, _| m.at::<f64>(r as i32).copied().unwrap_or(f64::NAN));
    let (aa, t) = (read(rvec), read(tvec));
    aa.iter()
        .chain(t.iter())
        .all(|v| v.is_finite())
        .then(|| Rigid3::from_rotation_translation(Rotation3::from_scaled_axis(aa).into_inner(), t))
}

#[allow(clippy::too_many_arguments)]
fn ransac(
    k: &Radial,
    object: &Vector<Point3d>,
    image: &Vector<Point2d>,
    max_px: f64,
    iterations: i32,
    confidence: f64,
    method: i32,
) -> SfmResult<Option<(Rigid3, usize)>> {
    let (camera_matrix, distortion) = opencv_camera(k)?;
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
        method,
    )
    .map_err(SfmError::cv("PnP"))?;
    if !ok {
        return Ok(None);
    }
    Ok(pose_from(&rvec, &tvec).map(|pose| (pose, inliers.rows().max(0) as usize)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_refinement_brings_a_disturbed_pose_back_to_the_one_that_saw_the_points() {
        let k = Radial { f: 500.0, cx: 320.0, cy: 240.0, k1: 0.0, k2: 0.0 };
        let truth = Rigid3::from_angle_axis_center(Vector3::new(0.02, -0.1, 0.01), Vector3::new(0.3, -0.2, -5.0));
        let world: Vec<Vector3<f64>> =
            (0..30).map(|i| Vector3::new(f64::from(i % 5) - 2.0, f64::from(i / 5) - 2.5, f64::from(i % 3) * 0.7)).collect();
        let object: Vector<Point3d> = world.iter().map(|p| Point3d::new(p.x, p.y, p.z)).collect();
        let image: Vector<Point2d> = world
            .iter()
            .map(|p| {
                let pixel = k.pixel(truth.project_normalized(p).unwrap());
                Point2d::new(pixel.x, pixel.y)
            })
            .collect();
        let disturbed = Rigid3::from_angle_axis_center(Vector3::new(0.03, -0.08, 0.0), Vector3::new(0.4, -0.1, -5.3));
        let refined = pnp_refine(&k, &object, &image, &disturbed).unwrap().unwrap();
        assert!((refined.center() - truth.center()).norm() < 1e-6, "{:?}", refined.center());
    }
}

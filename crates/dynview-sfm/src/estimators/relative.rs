//! Two-view relative poses and placing an image from one: the rotation and translation
//! direction of a verified pair (essential matrix), and the translation's length from the few
//! 3D points the new image sees.
//!
//! An image whose matches with the placed images run mostly through features no placed image
//! has triangulated yet (on a weakly textured ring, the images after a gap) has too few 2D-3D
//! correspondences for PnP, yet a strong verified pair with a placed image: the pair fixes 5 of
//! the pose's 6 degrees of freedom, and a handful of points fix the scale.

use nalgebra::{Matrix3, Vector2, Vector3};
use opencv::calib3d;
use opencv::core::{Mat, Point2d, Vector};
use opencv::prelude::*;

use dynview_camera::{Radial, Rigid3};

use crate::error::{SfmError, SfmResult};
use crate::estimators::geometry::reprojection_error_px;

/// View `b` relative to view `a`: `X_b = rotation X_a + translation`.
pub(crate) struct RelativePose {
    pub(crate) rotation: Matrix3<f64>,
    /// Of length 1 (two views do not fix the scale).
    pub(crate) translation: Vector3<f64>,
    /// Matches in front of both cameras.
    pub(crate) in_front: usize,
}

/// The pose of view `b` relative to view `a` from matched pixels; `None` when no essential
/// matrix is found.
pub(crate) fn relative_pose(
    ka: &Radial,
    kb: &Radial,
    pixels_a: &[Vector2<f64>],
    pixels_b: &[Vector2<f64>],
) -> SfmResult<Option<RelativePose>> {
    let to_cv = |v: Vector2<f64>| Point2d::new(v.x, v.y);
    let pa: Vector<Point2d> = pixels_a.iter().map(|p| to_cv(ka.normalized(*p))).collect();
    let pb: Vector<Point2d> = pixels_b.iter().map(|p| to_cv(kb.normalized(*p))).collect();
    if pa.len() < 5 || pa.len() != pb.len() {
        return Ok(None);
    }
    let identity = Mat::eye(3, 3, opencv::core::CV_64F).and_then(|m| m.to_mat()).map_err(SfmError::cv("identity"))?;
    let threshold = 1.0 / ka.f.min(kb.f);
    let mut mask = Mat::default();
    let e = calib3d::find_essential_mat(&pa, &pb, &identity, calib3d::USAC_MAGSAC, 0.9999, threshold, 10_000, &mut mask)
        .map_err(SfmError::cv("essential matrix of a pair"))?;
    if e.rows() != 3 || e.cols() != 3 {
        return Ok(None);
    }
    let (mut r, mut t) = (Mat::default(), Mat::default());
    let good = calib3d::recover_pose_estimated(&e, &pa, &pb, &identity, &mut r, &mut t, &mut mask)
        .map_err(SfmError::cv("relative pose of a pair"))?;
    let rotation = Matrix3::from_fn(|i, j| r.at_2d::<f64>(i as i32, j as i32).copied().unwrap_or(f64::NAN));
    let translation = Vector3::from_fn(|i, _| t.at_2d::<f64>(i as i32, 0).copied().unwrap_or(f64::NAN));
    if !rotation.iter().chain(translation.iter()).all(|v| v.is_finite()) {
        return Ok(None);
    }
    Ok(Some(RelativePose { rotation, translation, in_front: good.max(0) as usize }))
}

/// The pose of an image `relative` to a placed image whose pose is `placed`, with the
/// translation's length chosen so that most of `correspondences` (world point, pixel in the
/// image) reproject within `max_px`: `(pose, inliers)`, or `None` when no positive length
/// makes at least `min_inliers` agree.
pub(crate) fn place_along(
    k: &Radial,
    placed: &Rigid3,
    relative: &RelativePose,
    correspondences: &[(Vector3<f64>, Vector2<f64>)],
    max_px: f64,
    min_inliers: usize,
) -> Option<(Rigid3, usize)> {
    let (r, t) = (&relative.rotation, &relative.translation);
    let rotation = r * placed.rotation_matrix();
    let base = r * placed.translation_vector();
    let pose_at = |s: f64| Rigid3::from_rotation_translation(rotation, base + t * s);
    // Each correspondence's own length: least squares over its two projection equations.
    let candidates = correspondences.iter().filter_map(|(x, p)| {
        let u = k.normalized(*p);
        let a = rotation * x + base;
        let (a0, a1) = (a.x - u.x * a.z, a.y - u.y * a.z);
        let (b0, b1) = (t.x - u.x * t.z, t.y - u.y * t.z);
        let denominator = b0 * b0 + b1 * b1;
        let s = -(a0 * b0 + a1 * b1) / denominator;
        (denominator > 1e-12 && s.is_finite() && s > 0.0).then_some(s)
    });
    let inliers = |pose: &Rigid3| {
        let pose = pose.matrices();
        correspondences.iter().filter(|(x, p)| reprojection_error_px(k, &pose, x, p) <= max_px).count()
    };
    let (s, count) = candidates.map(|s| (s, inliers(&pose_at(s)))).max_by(|a, b| a.1.cmp(&b.1).then(b.0.total_cmp(&a.0)))?;
    (count >= min_inliers).then(|| (pose_at(s), count))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pose_is_placed_at_the_length_its_points_agree_on() {
        let k = Radial::centred(500.0, 640, 480);
        let placed = Rigid3::from_rotation_translation(Matrix3::identity(), Vector3::new(0.1, 0.0, 0.0));
        let angle = 0.2f64;
        let r = Matrix3::new(angle.cos(), 0.0, angle.sin(), 0.0, 1.0, 0.0, -angle.sin(), 0.0, angle.cos());
        let t = Vector3::new(-0.8, 0.1, 0.2).normalize();
        let truth = Rigid3::from_rotation_translation(r * placed.rotation_matrix(), r * placed.translation_vector() + t * 1.7);
        let points: Vec<Vector3<f64>> =
            (0..8).map(|i| Vector3::new(-0.5 + 0.15 * f64::from(i), 0.2 * f64::from(i % 3) - 0.2, 4.0 + 0.1 * f64::from(i))).collect();
        let mut correspondences: Vec<(Vector3<f64>, Vector2<f64>)> =
            points.iter().map(|x| (*x, k.pixel(truth.project_normalized(x).unwrap()))).collect();
        // Two wrong correspondences are outvoted.
        correspondences[0].1 += Vector2::new(40.0, -25.0);
        correspondences[1].1 += Vector2::new(-30.0, 60.0);
        let relative = RelativePose { rotation: r, translation: t, in_front: 0 };
        let (pose, inliers) = place_along(&k, &placed, &relative, &correspondences, 2.0, 5).unwrap();
        assert_eq!(inliers, 6);
        assert!((pose.center() - truth.center()).norm() < 1e-9, "{:?} vs {:?}", pose.center(), truth.center());
        // Too few agree: no placement.
        assert!(place_along(&k, &placed, &relative, &correspondences, 2.0, 7).is_none());
    }
}

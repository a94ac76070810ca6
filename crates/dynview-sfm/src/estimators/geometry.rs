//! Multi-view geometry in f64 (nalgebra): reprojection errors, the essential matrix of two
//! poses, ray angles and multi-view triangulation. Cameras are COLMAP's `RADIAL`
//! ([`dynview_camera::Radial`], the model of bundle adjustment, pixel centres at integers);
//! poses are `camera_from_world` [`Rigid3`], projected through their [`PoseMatrices`] (`R`
//! and the centre `C`, as `R (X - C)`).

use dynview_camera::{PoseMatrices, Radial, Rigid3};
use nalgebra::{Matrix3, Matrix4, Vector2, Vector3};

/// Reprojection error (px) of a world point in an image whose pose is `pose` (a
/// `camera_from_world` [`Rigid3`]'s [`PoseMatrices`]), infinite when it is behind.
pub fn reprojection_error_px(intrinsics: &Radial, pose: &PoseMatrices, point_world: &Vector3<f64>, pixel: &Vector2<f64>) -> f64 {
    pose.project_normalized(point_world).map_or(f64::INFINITY, |n| (intrinsics.pixel(n) - pixel).norm())
}

/// The essential matrix `E` with `n_b^T E n_a = 0` for normalized points of poses `a` and `b`.
pub fn essential_between(a: &Rigid3, b: &Rigid3) -> Matrix3<f64> {
    let rotation = b.rotation_matrix() * a.rotation_matrix().transpose();
    let translation = b.translation_vector() - rotation * a.translation_vector();
    translation.cross_matrix() * rotation
}

/// Linear (DLT) triangulation from normalized observations in posed images; `None` when the
/// system is degenerate.
pub fn triangulate(views: &[(Rigid3, Vector2<f64>)]) -> Option<Vector3<f64>> {
    if views.len() < 2 {
        return None;
    }
    // Normal equations of the homogeneous DLT rows: sum of r r^T over rows r.
    let mut ata = Matrix4::<f64>::zeros();
    for (pose, n) in views {
        let t = pose.translation_vector();
        let mut p = nalgebra::Matrix3x4::<f64>::zeros();
        p.fixed_view_mut::<3, 3>(0, 0).copy_from(&pose.rotation_matrix());
        p.set_column(3, &t);
        for row in [p.row(0) - p.row(2) * n.x, p.row(1) - p.row(2) * n.y] {
            let r = row.transpose();
            ata += r * r.transpose();
        }
    }
    let eigen = ata.symmetric_eigen();
    let (mut best, mut best_value) = (0, f64::INFINITY);
    for (i, v) in eigen.eigenvalues.iter().enumerate() {
        if *v < best_value {
            best_value = *v;
            best = i;
        }
    }
    let x = eigen.eigenvectors.column(best);
    if x[3].abs() < 1e-12 {
        return None;
    }
    let point = Vector3::new(x[0] / x[3], x[1] / x[3], x[2] / x[3]);
    point.iter().all(|v| v.is_finite()).then_some(point)
}

/// One observation for [`triangulate_robust`]: the camera's intrinsics, its pose
/// (`camera_from_world`) and the pixel.
pub type Ray = (Radial, Rigid3, Vector2<f64>);

/// Triangulates `views`, dropping the worst-fitting observation until every remaining one is
/// within `max_reprojection_px`; keeps the point when two or more remain and some two of their
/// rays are at least `min_angle_deg` apart. Returns the point and the indices of the views kept.
pub fn triangulate_robust(views: &[Ray], max_reprojection_px: f64, min_angle_deg: f64) -> Option<(Vector3<f64>, Vec<usize>)> {
    let matrices: Vec<PoseMatrices> = views.iter().map(|view| view.1.matrices()).collect();
    let mut kept: Vec<usize> = (0..views.len()).collect();
    while kept.len() >= 2 {
        let rays: Vec<(Rigid3, Vector2<f64>)> = kept.iter().map(|&i| (views[i].1, views[i].0.normalized(views[i].2))).collect();
        let xyz = triangulate(&rays)?;
        let errors: Vec<f64> = kept.iter().map(|&i| reprojection_error_px(&views[i].0, &matrices[i], &xyz, &views[i].2)).collect();
        let (worst, &worst_error) = errors.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1))?;
        if worst_error > max_reprojection_px {
            kept.remove(worst);
            continue;
        }
        let mut max_angle: f64 = 0.0;
        for a in 0..kept.len() {
            for b in a + 1..kept.len() {
                max_angle = max_angle.max(ray_angle_rad(&matrices[kept[a]].center_world, &matrices[kept[b]].center_world, &xyz));
            }
        }
        return (max_angle.to_degrees() >= min_angle_deg).then_some((xyz, kept));
    }
    None
}

/// Angle (rad) between the rays from two camera centres to a point.
pub fn ray_angle_rad(center_a: &Vector3<f64>, center_b: &Vector3<f64>, point_world: &Vector3<f64>) -> f64 {
    let (a, b) = (point_world - center_a, point_world - center_b);
    let cos = a.dot(&b) / (a.norm() * b.norm()).max(1e-300);
    cos.clamp(-1.0, 1.0).acos()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn triangulates_exactly_and_undistorts() {
        let k = Radial { f: 800.0, cx: 320.0, cy: 240.0, k1: -0.1, k2: 0.01 };
        let point = Vector3::new(0.3, -0.2, 5.0);
        let poses = [
            Rigid3::from_angle_axis_center(Vector3::new(0.0, 0.1, 0.0), Vector3::new(-1.0, 0.0, 0.0)),
            Rigid3::from_angle_axis_center(Vector3::new(0.02, -0.1, 0.0), Vector3::new(1.0, 0.1, 0.0)),
            Rigid3::from_angle_axis_center(Vector3::zeros(), Vector3::new(0.0, 0.5, -1.0)),
        ];
        let views: Vec<_> = poses
            .iter()
            .map(|p| {
                let pixel = k.pixel(p.project_normalized(&point).unwrap());
                (*p, k.normalized(pixel))
            })
            .collect();
        let x = triangulate(&views).unwrap();
        assert!((x - point).norm() < 1e-9, "{x}");
        for p in &poses {
            let pixel = k.pixel(p.project_normalized(&point).unwrap());
            assert!(reprojection_error_px(&k, &p.matrices(), &x, &pixel) < 1e-6);
        }
    }
}

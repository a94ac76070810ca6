//! Multi-view geometry in f64 (nalgebra): the camera model shared with bundle adjustment,
//! projection, undistortion and multi-view triangulation.

use dynview_camera::{Model, Radial};
use nalgebra::{Matrix3, Matrix4, Rotation3, Vector2, Vector3};
use serde::{Deserialize, Serialize};

/// A physical camera's intrinsics: COLMAP's `RADIAL` model ([`dynview_camera::Radial`], pinhole
/// with two radial distortion terms), pixel centres at integers (the model of
/// `dynview_ba::CameraIntrinsics`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Intrinsics {
    /// Focal length (px), equal in x and y.
    pub focal_px: f64,
    /// Principal point x (px).
    pub cx_px: f64,
    /// Principal point y (px).
    pub cy_px: f64,
    /// Radial distortion, r^2 term.
    pub k1: f64,
    /// Radial distortion, r^4 term.
    pub k2: f64,
}

impl Intrinsics {
    /// A centred principal point and no distortion.
    pub fn centred(focal_px: f64, width: u32, height: u32) -> Self {
        Radial::centred(focal_px, width, height).into()
    }

    /// A calibration's pinhole intrinsics without distortion (the frames are undistorted).
    /// Our model has `fx = fy`; a calibration's tiny difference is averaged.
    pub fn from_pinhole(k: &dynview_core::Intrinsics) -> Self {
        Self { focal_px: 0.5 * (k.fx + k.fy), cx_px: k.cx, cy_px: k.cy, k1: 0.0, k2: 0.0 }
    }

    /// dynview's pinhole intrinsics and OpenCV distortion `[k1, k2, p1, p2]` of this camera
    /// (as `poses.json` stores them).
    pub fn to_pinhole_and_distortion(&self) -> (dynview_core::Intrinsics, [f64; 4]) {
        let opencv = Radial::from(*self).to_opencv();
        (opencv.pinhole.into(), opencv.distortion.to_array())
    }

    /// Pixel of a normalized image point (applies the distortion).
    pub fn pixel(&self, normalized: Vector2<f64>) -> Vector2<f64> {
        Vector2::from(Radial::from(*self).pixel_from_normalized(normalized.into()))
    }

    /// Normalized, undistorted image point of a pixel (fixed-point inversion of the distortion).
    pub fn normalized(&self, pixel: Vector2<f64>) -> Vector2<f64> {
        Vector2::from(Radial::from(*self).normalized_from_pixel(pixel.into()))
    }
}

impl From<Intrinsics> for Radial {
    fn from(k: Intrinsics) -> Self {
        Self { f: k.focal_px, cx: k.cx_px, cy: k.cy_px, k1: k.k1, k2: k.k2 }
    }
}

impl From<Radial> for Intrinsics {
    fn from(k: Radial) -> Self {
        Self { focal_px: k.f, cx_px: k.cx, cy_px: k.cy, k1: k.k1, k2: k.k2 }
    }
}

impl From<Intrinsics> for dynview_ba::CameraIntrinsics {
    fn from(k: Intrinsics) -> Self {
        Radial::from(k).into()
    }
}

impl From<dynview_ba::CameraIntrinsics> for Intrinsics {
    fn from(k: dynview_ba::CameraIntrinsics) -> Self {
        Radial::from(k).into()
    }
}

/// An image's pose: `X_cam = R (X_world - C)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    /// Rotation `camera_from_world`.
    pub rotation: Matrix3<f64>,
    /// Camera centre in the world.
    pub center_world: Vector3<f64>,
}

impl From<Pose> for dynview_ba::ImagePose {
    fn from(pose: Pose) -> Self {
        Self { angle_axis: pose.angle_axis().into(), center_world: pose.center_world.into() }
    }
}

impl From<dynview_ba::ImagePose> for Pose {
    fn from(image: dynview_ba::ImagePose) -> Self {
        Self::from_angle_axis(image.angle_axis.into(), image.center_world.into())
    }
}

impl Pose {
    /// From OpenCV's `X_cam = R X_world + t`.
    pub fn from_rt(rotation: Matrix3<f64>, translation: Vector3<f64>) -> Self {
        Self { rotation, center_world: -rotation.transpose() * translation }
    }

    /// `t` of `X_cam = R X_world + t`.
    pub fn translation(&self) -> Vector3<f64> {
        -self.rotation * self.center_world
    }

    /// The rotation as an angle-axis vector.
    pub fn angle_axis(&self) -> Vector3<f64> {
        Rotation3::from_matrix_unchecked(self.rotation).scaled_axis()
    }

    /// From an angle-axis vector and a centre.
    pub fn from_angle_axis(angle_axis: Vector3<f64>, center_world: Vector3<f64>) -> Self {
        Self { rotation: Rotation3::from_scaled_axis(angle_axis).into_inner(), center_world }
    }

    /// A world point in camera coordinates.
    pub fn to_camera(&self, point_world: &Vector3<f64>) -> Vector3<f64> {
        self.rotation * (point_world - self.center_world)
    }

    /// Normalized image point of a world point in front of the camera.
    pub fn project_normalized(&self, point_world: &Vector3<f64>) -> Option<Vector2<f64>> {
        let p = self.to_camera(point_world);
        (p.z > 1e-9).then(|| Vector2::new(p.x / p.z, p.y / p.z))
    }

    /// The pose as dynview's `camera_from_world`.
    pub fn to_rigid(&self) -> dynview_core::Rigid3 {
        let r = self.rotation;
        let t = self.translation();
        dynview_core::Rigid3::from_rotation_rows(
            [[r[(0, 0)], r[(0, 1)], r[(0, 2)]], [r[(1, 0)], r[(1, 1)], r[(1, 2)]], [r[(2, 0)], r[(2, 1)], r[(2, 2)]]],
            [t.x, t.y, t.z],
        )
    }

    /// From dynview's `camera_from_world`.
    pub fn from_rigid(rigid: &dynview_core::Rigid3) -> Self {
        let rows = rigid.rotation_rows();
        let r = Matrix3::from_fn(|i, j| rows[i][j]);
        let t = rigid.translation;
        Self::from_rt(r, Vector3::new(t.x, t.y, t.z))
    }
}

/// Reprojection error (px) of a world point in an image, infinite when it is behind.
pub fn reprojection_error_px(intrinsics: &Intrinsics, pose: &Pose, point_world: &Vector3<f64>, pixel: &Vector2<f64>) -> f64 {
    pose.project_normalized(point_world).map_or(f64::INFINITY, |n| (intrinsics.pixel(n) - pixel).norm())
}

/// Linear (DLT) triangulation from normalized observations in posed images; `None` when the
/// system is degenerate.
pub fn triangulate(views: &[(Pose, Vector2<f64>)]) -> Option<Vector3<f64>> {
    if views.len() < 2 {
        return None;
    }
    // Normal equations of the homogeneous DLT rows: sum of r r^T over rows r.
    let mut ata = Matrix4::<f64>::zeros();
    for (pose, n) in views {
        let t = pose.translation();
        let mut p = nalgebra::Matrix3x4::<f64>::zeros();
        p.fixed_view_mut::<3, 3>(0, 0).copy_from(&pose.rotation);
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

/// One observation for [`triangulate_robust`]: the camera's intrinsics, its pose and the pixel.
pub type Ray = (Intrinsics, Pose, Vector2<f64>);

/// Triangulates `views`, dropping the worst-fitting observation until every remaining one is
/// within `max_reprojection_px`; keeps the point when two or more remain and some two of their
/// rays are at least `min_angle_deg` apart. Returns the point and the indices of the views kept.
pub fn triangulate_robust(views: &[Ray], max_reprojection_px: f64, min_angle_deg: f64) -> Option<(Vector3<f64>, Vec<usize>)> {
    let mut kept: Vec<usize> = (0..views.len()).collect();
    while kept.len() >= 2 {
        let rays: Vec<(Pose, Vector2<f64>)> = kept.iter().map(|&i| (views[i].1, views[i].0.normalized(views[i].2))).collect();
        let xyz = triangulate(&rays)?;
        let errors: Vec<f64> = kept.iter().map(|&i| reprojection_error_px(&views[i].0, &views[i].1, &xyz, &views[i].2)).collect();
        let (worst, &worst_error) = errors.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1))?;
        if worst_error > max_reprojection_px {
            kept.remove(worst);
            continue;
        }
        let mut max_angle: f64 = 0.0;
        for a in 0..rays.len() {
            for b in a + 1..rays.len() {
                max_angle = max_angle.max(ray_angle_rad(&rays[a].0.center_world, &rays[b].0.center_world, &xyz));
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
        let k = Intrinsics { focal_px: 800.0, cx_px: 320.0, cy_px: 240.0, k1: -0.1, k2: 0.01 };
        let point = Vector3::new(0.3, -0.2, 5.0);
        let poses = [
            Pose::from_angle_axis(Vector3::new(0.0, 0.1, 0.0), Vector3::new(-1.0, 0.0, 0.0)),
            Pose::from_angle_axis(Vector3::new(0.02, -0.1, 0.0), Vector3::new(1.0, 0.1, 0.0)),
            Pose::from_angle_axis(Vector3::zeros(), Vector3::new(0.0, 0.5, -1.0)),
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
            assert!(reprojection_error_px(&k, p, &x, &pixel) < 1e-6);
        }
        let rigid = poses[1].to_rigid();
        let back = Pose::from_rigid(&rigid);
        assert!((back.rotation - poses[1].rotation).norm() < 1e-12 && (back.center_world - poses[1].center_world).norm() < 1e-12);
    }
}

//! The nalgebra forms of [`Rigid3`] and [`Radial`] (feature `nalgebra`), for `dynview-sfm` and
//! `dynview-ba`, which compute in nalgebra. Every conversion between glam's and nalgebra's
//! values of a pose is here, written once.
//!
//! The rotation and translation are copied exactly. The camera centre `C = -R^T t` and the
//! translation `t = -R C` are one product each, in the order `dynview-sfm` has always computed
//! them (so a pose made from a rotation and translation gives the centre it always gave).
//! Angle-axis vectors are nalgebra's (`Rotation3::scaled_axis` and `from_scaled_axis`), as
//! `dynview-sfm` has always handed them to bundle adjustment, except near a half-turn, where
//! `Rotation3::scaled_axis` is imprecise and the quaternion's is taken ([`Rigid3::angle_axis`]).
//!
//! A [`Rigid3`] stores the translation; code that projects many points through one pose takes
//! its [`PoseMatrices`] once rather than converting per point.

use glam::{DMat3, DVec3};
use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector2, Vector3};

use crate::{Model, Radial, Rigid3};

/// Smallest camera-frame depth of a point that [`PoseMatrices::project_normalized`] projects.
const MIN_DEPTH: f64 = 1e-9;

/// Rotations by more than this angle (radians, 3/4 of a half-turn) take their angle-axis vector
/// from the quaternion ([`Rigid3::angle_axis`]).
pub const QUATERNION_ANGLE_RAD: f64 = 0.75 * std::f64::consts::PI;

/// A `camera_from_world` [`Rigid3`] as nalgebra values, computed once for projecting many
/// points: its rotation matrix and the camera centre. Not a second pose type: made from a
/// [`Rigid3`] ([`Rigid3::matrices`]) where points are projected, never stored.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseMatrices {
    /// Rotation `camera_from_world`.
    pub rotation: Matrix3<f64>,
    /// Camera centre in the world, `C = -R^T t`.
    pub center_world: Vector3<f64>,
}

impl PoseMatrices {
    /// A world point in camera coordinates, `R (X - C)`.
    #[inline]
    pub fn point_camera(&self, point_world: &Vector3<f64>) -> Vector3<f64> {
        self.rotation * (point_world - self.center_world)
    }

    /// The normalized image point of a world point more than `1e-9` in front of the camera
    /// (camera-frame z).
    #[inline]
    pub fn project_normalized(&self, point_world: &Vector3<f64>) -> Option<Vector2<f64>> {
        let p = self.point_camera(point_world);
        (p.z > MIN_DEPTH).then(|| Vector2::new(p.x / p.z, p.y / p.z))
    }
}

impl Rigid3 {
    /// The rotation as a nalgebra matrix (an exact copy).
    pub fn rotation_matrix(&self) -> Matrix3<f64> {
        Matrix3::from_column_slice(&self.rotation.to_cols_array())
    }

    /// The translation as a nalgebra vector (an exact copy).
    pub fn translation_vector(&self) -> Vector3<f64> {
        Vector3::new(self.translation.x, self.translation.y, self.translation.z)
    }

    /// For a `camera_from_world` transform: the camera centre in the world, `C = -R^T t`, as a
    /// nalgebra vector (the value of [`Rigid3::camera_center_world`]).
    pub fn center(&self) -> Vector3<f64> {
        self.matrices().center_world
    }

    /// The rotation matrix and camera centre, for projecting many points.
    pub fn matrices(&self) -> PoseMatrices {
        let rotation = self.rotation_matrix();
        PoseMatrices { rotation, center_world: -rotation.transpose() * self.translation_vector() }
    }

    /// From nalgebra's rotation and translation (OpenCV's `X_cam = R X_world + t`), copied
    /// exactly.
    pub fn from_rotation_translation(rotation: Matrix3<f64>, translation: Vector3<f64>) -> Self {
        Self { rotation: DMat3::from_cols_slice(rotation.as_slice()), translation: DVec3::new(translation.x, translation.y, translation.z) }
    }

    /// From the rotation `camera_from_world` and the camera centre in the world: `t = -R C`.
    pub fn from_rotation_center(rotation: Matrix3<f64>, center_world: Vector3<f64>) -> Self {
        Self::from_rotation_translation(rotation, -rotation * center_world)
    }

    /// The rotation as an angle-axis vector (radians, angle in `[0, pi]`): nalgebra's
    /// `Rotation3::scaled_axis` up to [`QUATERNION_ANGLE_RAD`], as `dynview-sfm` has always
    /// computed it, and through the quaternion beyond. `scaled_axis` finds the axis from
    /// `R - R^T`, which vanishes at a half-turn: it loses precision as the angle nears `pi`
    /// (about `1e-16 / sin(angle)`) and returns zero at an exact half-turn.
    pub fn angle_axis(&self) -> Vector3<f64> {
        let rotation = Rotation3::from_matrix_unchecked(self.rotation_matrix());
        if rotation.angle() <= QUATERNION_ANGLE_RAD {
            rotation.scaled_axis()
        } else {
            UnitQuaternion::from_rotation_matrix(&rotation).scaled_axis()
        }
    }

    /// From an angle-axis vector (`Rotation3::from_scaled_axis`) and the camera centre.
    pub fn from_angle_axis_center(angle_axis: Vector3<f64>, center_world: Vector3<f64>) -> Self {
        Self::from_rotation_center(Rotation3::from_scaled_axis(angle_axis).into_inner(), center_world)
    }

    /// A world point in camera coordinates, `R (X - C)` (converts the pose: for many points,
    /// use [`Rigid3::matrices`]).
    pub fn point_camera(&self, point_world: &Vector3<f64>) -> Vector3<f64> {
        self.matrices().point_camera(point_world)
    }

    /// The normalized image point of a world point in front of the camera (converts the pose:
    /// for many points, use [`Rigid3::matrices`]).
    pub fn project_normalized(&self, point_world: &Vector3<f64>) -> Option<Vector2<f64>> {
        self.matrices().project_normalized(point_world)
    }
}

impl Radial {
    /// The pixel of a normalized image point ([`Model::pixel_from_normalized`] on nalgebra
    /// vectors).
    #[inline]
    pub fn pixel(&self, normalized: Vector2<f64>) -> Vector2<f64> {
        Vector2::from(self.pixel_from_normalized(normalized.into()))
    }

    /// The undistorted normalized image point of a pixel ([`Model::normalized_from_pixel`] on
    /// nalgebra vectors).
    #[inline]
    pub fn normalized(&self, pixel: Vector2<f64>) -> Vector2<f64> {
        Vector2::from(self.normalized_from_pixel(pixel.into()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conversions_are_exact_where_they_copy_and_agree_with_glam() {
        let rotation = Rotation3::from_scaled_axis(Vector3::new(0.3, -0.2, 0.1)).into_inner();
        let translation = Vector3::new(0.5, -1.0, 2.0);
        let pose = Rigid3::from_rotation_translation(rotation, translation);
        assert_eq!(pose.rotation_matrix(), rotation);
        assert_eq!(pose.translation_vector(), translation);
        // The centre is the one glam computes, bit for bit.
        let c = pose.camera_center_world();
        assert_eq!(pose.center(), Vector3::new(c.x, c.y, c.z));
        assert_eq!(pose.matrices().center_world, pose.center());
        // A pose from its centre maps the centre to the camera origin.
        let from_center = Rigid3::from_rotation_center(rotation, Vector3::new(1.0, 2.0, -3.0));
        assert!(from_center.point_camera(&Vector3::new(1.0, 2.0, -3.0)).norm() < 1e-15);
        // Angle-axis round trip.
        let back = Rigid3::from_angle_axis_center(pose.angle_axis(), pose.center());
        assert!((back.rotation_matrix() - rotation).norm() < 1e-15 && (back.center() - pose.center()).norm() < 1e-14);
        // The same point in the camera as glam's transform.
        let point = Vector3::new(0.3, 0.4, 6.0);
        let glam_point = pose.transform_point(DVec3::new(point.x, point.y, point.z));
        assert!((pose.point_camera(&point) - Vector3::new(glam_point.x, glam_point.y, glam_point.z)).norm() < 1e-14);
        let n = pose.project_normalized(&point).expect("in front");
        assert!((n - Vector2::new(glam_point.x / glam_point.z, glam_point.y / glam_point.z)).norm() < 1e-15);
    }

    #[test]
    fn angle_axis_is_nalgebras_and_finds_half_turns() {
        for angle_axis in [Vector3::zeros(), Vector3::new(0.3, -0.2, 0.1), Vector3::new(1e-5, 2e-5, 0.0), Vector3::new(-1.5, 1.0, 0.5)] {
            let pose = Rigid3::from_angle_axis_center(angle_axis, Vector3::zeros());
            assert_eq!(pose.angle_axis(), Rotation3::from_matrix_unchecked(pose.rotation_matrix()).scaled_axis());
        }
        // Half a turn about y: x and z flip.
        let half_turn = Rigid3::new(DMat3::from_diagonal(DVec3::new(-1.0, 1.0, -1.0)), DVec3::ZERO);
        let angle_axis = half_turn.angle_axis();
        assert!((angle_axis.norm() - std::f64::consts::PI).abs() < 1e-15 && angle_axis.x == 0.0 && angle_axis.z == 0.0, "{angle_axis:?}");
        assert!(
            (Rigid3::from_angle_axis_center(angle_axis, Vector3::zeros()).rotation_matrix() - half_turn.rotation_matrix()).norm() < 1e-15
        );
        // Near a half-turn the round trip stays exact to rounding.
        let near = Vector3::new(0.0, std::f64::consts::PI - 1e-9, 0.0);
        let back = Rigid3::from_angle_axis_center(near, Vector3::zeros()).angle_axis();
        assert!((back - near).norm() < 1e-14, "{back:?}");
    }

    #[test]
    fn radial_on_vectors_is_the_model() {
        let k = Radial { f: 800.0, cx: 320.0, cy: 240.0, k1: -0.1, k2: 0.01 };
        let n = Vector2::new(0.2, -0.1);
        assert_eq!(k.pixel(n), Vector2::from(k.pixel_from_normalized([0.2, -0.1])));
        assert!((k.normalized(k.pixel(n)) - n).norm() < 1e-12);
    }
}

//! Rigid transforms in 3D (glam, `f64`), dynview's one pose type: [`Rigid3`], named after the
//! frames it connects, e.g. `camera_from_world: Rigid3`.
//!
//! Axes of a camera frame (OpenCV): x right, y down, z forward (into the scene). A world point
//! maps into the camera as `X_c = R X_w + t` (`camera_from_world`); the camera centre is
//! `C = -R^T t`. With the feature `nalgebra`, `PoseMatrices` and the `nalgebra` methods
//! of [`Rigid3`] give the same pose as nalgebra values; with `serde` it serializes as
//! `{"rotation": [9 entries, column-major], "translation": [x, y, z]}`.

use glam::{DMat3, DQuat, DVec3};

/// A rigid transform `p_to = rotation * p_from + translation`. Name values after the frames
/// they connect, e.g. `camera_from_world: Rigid3`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Rigid3 {
    /// Rotation part (orthonormal, determinant +1).
    pub rotation: DMat3,
    /// Translation part.
    pub translation: DVec3,
}

impl Default for Rigid3 {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Rigid3 {
    /// The identity transform.
    pub const IDENTITY: Self = Self { rotation: DMat3::IDENTITY, translation: DVec3::ZERO };

    /// A transform from its rotation and translation.
    pub fn new(rotation: DMat3, translation: DVec3) -> Self {
        Self { rotation, translation }
    }

    /// Applies the transform to a point.
    pub fn transform_point(&self, point: DVec3) -> DVec3 {
        self.rotation * point + self.translation
    }

    /// Applies only the rotation (for directions).
    pub fn transform_vector(&self, vector: DVec3) -> DVec3 {
        self.rotation * vector
    }

    /// The inverse transform: if `self` is `b_from_a`, returns `a_from_b`.
    pub fn inverse(&self) -> Self {
        let rotation_t = self.rotation.transpose();
        Self { rotation: rotation_t, translation: -(rotation_t * self.translation) }
    }

    /// Composition: `c_from_b.compose(&b_from_a)` is `c_from_a`.
    pub fn compose(&self, b_from_a: &Self) -> Self {
        Self { rotation: self.rotation * b_from_a.rotation, translation: self.rotation * b_from_a.translation + self.translation }
    }

    /// A camera's `camera_from_world` that sits at `eye_world` and looks at `target_world`,
    /// with image "up" (`-y` in OpenCV axes) as close as possible to `up_world`.
    pub fn camera_from_world_looking_at(eye_world: DVec3, target_world: DVec3, up_world: DVec3) -> Self {
        let z_axis = (target_world - eye_world).normalize();
        let x_axis = z_axis.cross(up_world).normalize();
        let y_axis = z_axis.cross(x_axis);
        // Rows of R are the camera axes expressed in world coordinates.
        let rotation = DMat3::from_cols(x_axis, y_axis, z_axis).transpose();
        Self { rotation, translation: -(rotation * eye_world) }
    }

    /// For a `camera_from_world` transform: the camera centre in world coordinates,
    /// `C = -R^T t`.
    pub fn camera_center_world(&self) -> DVec3 {
        -(self.rotation.transpose() * self.translation)
    }

    /// For `camera_from_world` transforms: the camera a fraction `s` (0 at `self`, 1 at `other`)
    /// of the way to `other`, its rotation slerped and its centre on the straight line between.
    pub fn camera_between(&self, other: &Self, s: f64) -> Self {
        let (a, b) = (DQuat::from_mat3(&self.rotation), DQuat::from_mat3(&other.rotation));
        let rotation = DMat3::from_quat(a.slerp(b, s).normalize());
        let centre = self.camera_center_world().lerp(other.camera_center_world(), s);
        Self { rotation, translation: -(rotation * centre) }
    }

    /// True when all entries are finite, `R R^T` is within `tolerance` of the identity
    /// (max abs entry) and `det R` within `tolerance` of +1.
    pub fn is_proper_rigid(&self, tolerance: f64) -> bool {
        let r = self.rotation;
        let finite = r.to_cols_array().iter().all(|v| v.is_finite()) && self.translation.is_finite();
        if !finite {
            return false;
        }
        let gram = r * r.transpose();
        let off = (gram - DMat3::IDENTITY).to_cols_array().iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        off <= tolerance && (r.determinant() - 1.0).abs() <= tolerance
    }

    /// Row-major 3x3 rotation entries, the order used in `scene.json`.
    pub fn rotation_rows(&self) -> [[f64; 3]; 3] {
        let r = self.rotation.transpose(); // columns of R^T are rows of R
        [r.x_axis.to_array(), r.y_axis.to_array(), r.z_axis.to_array()]
    }

    /// Builds a transform from row-major rotation entries and a translation.
    pub fn from_rotation_rows(rows: [[f64; 3]; 3], translation: [f64; 3]) -> Self {
        let rotation = DMat3::from_cols(DVec3::from_array(rows[0]), DVec3::from_array(rows[1]), DVec3::from_array(rows[2])).transpose();
        Self { rotation, translation: DVec3::from_array(translation) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_camera_between_two_turns_and_moves_part_of_the_way() {
        let a = Rigid3::camera_from_world_looking_at(DVec3::new(0.0, 0.0, -5.0), DVec3::ZERO, DVec3::Y);
        let b = Rigid3::camera_from_world_looking_at(DVec3::new(5.0, 0.0, 0.0), DVec3::ZERO, DVec3::Y);
        let half = a.camera_between(&b, 0.5);
        // Half of a quarter turn about y, its centre midway (not on the circle).
        let angle = DQuat::from_mat3(&(half.rotation * a.rotation.transpose())).angle_between(DQuat::IDENTITY);
        assert!((angle - std::f64::consts::FRAC_PI_4).abs() < 1e-9, "{angle}");
        assert!((half.camera_center_world() - DVec3::new(2.5, 0.0, -2.5)).length() < 1e-9);
        assert!(half.is_proper_rigid(1e-9));
        assert!((a.camera_between(&b, 0.0).translation - a.translation).length() < 1e-9);
        assert!(a.camera_between(&b, 1.0).rotation.abs_diff_eq(b.rotation, 1e-9));
    }

    fn approx(a: DVec3, b: DVec3, tol: f64) -> bool {
        (a - b).abs().max_element() <= tol
    }

    #[test]
    fn inverse_and_centre() {
        let rotation = DMat3::from_rotation_y(0.3) * DMat3::from_rotation_x(-0.2);
        let t = Rigid3::new(rotation, DVec3::new(1.0, 2.0, 3.0));
        let p = DVec3::new(0.4, -1.1, 7.0);
        assert!(approx(t.inverse().transform_point(t.transform_point(p)), p, 1e-12));
        // The centre maps to the camera origin.
        assert!(approx(t.transform_point(t.camera_center_world()), DVec3::ZERO, 1e-12));
        let id = t.compose(&t.inverse());
        assert!(approx(id.translation, DVec3::ZERO, 1e-12));
    }

    #[test]
    fn look_at_puts_target_on_axis_and_up_up() {
        let eye = DVec3::new(2.0, 1.5, 6.0);
        let target = DVec3::new(0.0, 1.0, 0.0);
        let pose = Rigid3::camera_from_world_looking_at(eye, target, DVec3::Y);
        assert!(pose.is_proper_rigid(1e-12));
        let p = pose.transform_point(target);
        assert!(p.x.abs() < 1e-12 && p.y.abs() < 1e-12 && p.z > 0.0);
        // A point above the target is above in the image (negative y in OpenCV axes).
        assert!(pose.transform_point(target + DVec3::Y).y < 0.0);
        assert!(approx(pose.camera_center_world(), eye, 1e-12));
    }

    #[test]
    fn rotation_rows_round_trip() {
        let t = Rigid3::new(DMat3::from_rotation_z(0.7), DVec3::new(1.0, 0.0, -2.0));
        let rows = t.rotation_rows();
        // Row 0 of Rz(a) is (cos a, -sin a, 0).
        assert!((rows[0][0] - 0.7f64.cos()).abs() < 1e-15);
        assert!((rows[0][1] + 0.7f64.sin()).abs() < 1e-15);
        let back = Rigid3::from_rotation_rows(rows, t.translation.to_array());
        assert_eq!(back, t);
    }

    #[test]
    fn proper_rigid_rejects_bad_matrices() {
        let mut t = Rigid3::IDENTITY;
        assert!(t.is_proper_rigid(1e-9));
        t.rotation.x_axis.x = 1.1;
        assert!(!t.is_proper_rigid(1e-3));
        let mirror = Rigid3::new(DMat3::from_diagonal(DVec3::new(1.0, 1.0, -1.0)), DVec3::ZERO);
        assert!(!mirror.is_proper_rigid(1e-3));
        let nan = Rigid3::new(DMat3::IDENTITY, DVec3::new(f64::NAN, 0.0, 0.0));
        assert!(!nan.is_proper_rigid(1e-3));
    }
}

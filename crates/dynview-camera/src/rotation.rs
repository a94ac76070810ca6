//! Rotation parameterisations: unit quaternions (COLMAP's `w, x, y, z` order), angle-axis
//! vectors (axis times angle in radians, the paper's `A_{s,t}`), and rotation matrices.

use glam::{DMat3, DQuat, DVec3};

/// Rotation matrix from a quaternion given in COLMAP's order `[w, x, y, z]`. The quaternion is
/// normalised first; returns `None` for a zero or non-finite quaternion.
pub fn matrix_from_quaternion_wxyz(q_wxyz: [f64; 4]) -> Option<DMat3> {
    let [w, x, y, z] = q_wxyz;
    let q = DQuat::from_xyzw(x, y, z, w);
    let norm = q.length();
    if !norm.is_finite() || norm < 1e-12 {
        return None;
    }
    Some(DMat3::from_quat(q / norm))
}

/// Unit quaternion `[w, x, y, z]` with `w >= 0` for a rotation matrix.
pub fn quaternion_wxyz_from_matrix(rotation: DMat3) -> [f64; 4] {
    let q = DQuat::from_mat3(&rotation).normalize();
    let q = if q.w < 0.0 { -q } else { q };
    [q.w, q.x, q.y, q.z]
}

/// Angle-axis vector (unit axis times angle in `[0, pi]`) of a rotation matrix. Accurate for
/// small angles (uses `atan2`, not `acos`).
pub fn angle_axis_from_matrix(rotation: DMat3) -> DVec3 {
    let q = DQuat::from_mat3(&rotation).normalize();
    let q = if q.w < 0.0 { -q } else { q };
    let v = DVec3::new(q.x, q.y, q.z);
    let sin_half = v.length();
    if sin_half < 1e-12 {
        // angle ~ 2 * sin_half / w: first-order expansion.
        return 2.0 * v / q.w;
    }
    let angle = 2.0 * sin_half.atan2(q.w);
    v * (angle / sin_half)
}

/// Rotation matrix of an angle-axis vector (Rodrigues).
pub fn matrix_from_angle_axis(angle_axis: DVec3) -> DMat3 {
    let angle = angle_axis.length();
    if angle < 1e-12 {
        // First order: I + [a]x; re-orthonormalise through the quaternion.
        let q = DQuat::from_xyzw(0.5 * angle_axis.x, 0.5 * angle_axis.y, 0.5 * angle_axis.z, 1.0).normalize();
        return DMat3::from_quat(q);
    }
    DMat3::from_axis_angle(angle_axis / angle, angle)
}

/// Angle in radians of the relative rotation `a b^T`: `acos((tr(a b^T) - 1) / 2)`, clamped to
/// a valid argument (paper Eq. rF uses it to compare viewing directions).
pub fn relative_angle_rad(a: DMat3, b: DMat3) -> f64 {
    let rel = a * b.transpose();
    let trace = rel.x_axis.x + rel.y_axis.y + rel.z_axis.z;
    ((trace - 1.0) * 0.5).clamp(-1.0, 1.0).acos()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_1_SQRT_2, FRAC_PI_2, PI};

    fn max_abs_diff(a: DMat3, b: DMat3) -> f64 {
        (a - b).to_cols_array().iter().fold(0.0, |m, v| m.max(v.abs()))
    }

    #[test]
    fn quaternion_hand_checked_90_degrees_about_z() {
        // q = (cos 45, 0, 0, sin 45) rotates x onto y.
        let r = matrix_from_quaternion_wxyz([FRAC_1_SQRT_2, 0.0, 0.0, FRAC_1_SQRT_2]).unwrap();
        let v = r * DVec3::X;
        assert!((v - DVec3::Y).length() < 1e-15);
        let q = quaternion_wxyz_from_matrix(r);
        for (got, want) in q.iter().zip([FRAC_1_SQRT_2, 0.0, 0.0, FRAC_1_SQRT_2]) {
            assert!((got - want).abs() < 1e-15);
        }
    }

    #[test]
    fn quaternion_rejects_zero_and_nan() {
        assert!(matrix_from_quaternion_wxyz([0.0; 4]).is_none());
        assert!(matrix_from_quaternion_wxyz([f64::NAN, 0.0, 0.0, 0.0]).is_none());
        // Non-unit quaternions are normalised.
        let r = matrix_from_quaternion_wxyz([2.0, 0.0, 0.0, 0.0]).unwrap();
        assert!(max_abs_diff(r, DMat3::IDENTITY) < 1e-15);
    }

    #[test]
    fn quaternion_sign_is_canonical() {
        let r = DMat3::from_rotation_x(3.0);
        let q = quaternion_wxyz_from_matrix(r);
        assert!(q[0] >= 0.0);
        assert!(max_abs_diff(matrix_from_quaternion_wxyz(q).unwrap(), r) < 1e-14);
    }

    #[test]
    fn angle_axis_hand_checked() {
        let a = angle_axis_from_matrix(DMat3::from_rotation_y(FRAC_PI_2));
        assert!((a - DVec3::new(0.0, FRAC_PI_2, 0.0)).length() < 1e-14);
        let r = matrix_from_angle_axis(DVec3::new(0.0, 0.0, PI / 3.0));
        assert!(max_abs_diff(r, DMat3::from_rotation_z(PI / 3.0)) < 1e-15);
    }

    #[test]
    fn angle_axis_round_trips_small_and_large() {
        for &angle in &[1e-14, 1e-9, 1e-4, 0.3, 2.0, PI - 1e-6] {
            let axis = DVec3::new(0.3, -0.5, 0.8).normalize();
            let aa = axis * angle;
            let back = angle_axis_from_matrix(matrix_from_angle_axis(aa));
            assert!((back - aa).length() < 1e-9 * angle.max(1.0), "angle {angle}: {back:?} vs {aa:?}");
        }
    }

    #[test]
    fn relative_angle_matches_construction() {
        let a = DMat3::from_rotation_y(0.4) * DMat3::from_rotation_x(0.1);
        let b = DMat3::from_rotation_z(0.25) * a;
        assert!((relative_angle_rad(b, a) - 0.25).abs() < 1e-12);
        assert_eq!(relative_angle_rad(a, a), 0.0);
        // Half a turn.
        assert!((relative_angle_rad(DMat3::from_rotation_x(PI), DMat3::IDENTITY) - PI).abs() < 1e-7);
    }
}

//! The optimiser's rotation parameter: angle-axis rotations (Rodrigues) and the exact
//! derivative of a rotated point with respect to the angle-axis vector (the right Jacobian of
//! SO(3)).
//!
//! With `a` the angle-axis vector, `theta = |a|` and `[a]x` its cross-product matrix:
//! `R(a) = I + sin(theta)/theta [a]x + (1 - cos(theta))/theta^2 [a]x^2` (Rodrigues) and the
//! right Jacobian `Jr(a) = I - (1 - cos(theta))/theta^2 [a]x + (theta - sin(theta))/theta^3 [a]x^2`,
//! so that `R(a + da) = R(a) Exp(Jr(a) da) + O(|da|^2)` and therefore
//! `d(R(a) p)/da = -R(a) [p]x Jr(a) = -[R(a) p]x R(a) Jr(a)`.

use nalgebra::{Matrix3, Vector3};

/// Below this squared angle (radians^2) the trigonometric coefficients use their Taylor series.
const SMALL_ANGLE_SQ_RAD2: f64 = 1e-8;

/// The coefficients `(sin t / t, (1 - cos t) / t^2, (t - sin t) / t^3)` for `t^2 = theta_sq`.
fn coefficients(theta_sq: f64) -> (f64, f64, f64) {
    if theta_sq < SMALL_ANGLE_SQ_RAD2 {
        (
            1.0 - theta_sq / 6.0 + theta_sq * theta_sq / 120.0,
            0.5 - theta_sq / 24.0 + theta_sq * theta_sq / 720.0,
            1.0 / 6.0 - theta_sq / 120.0 + theta_sq * theta_sq / 5040.0,
        )
    } else {
        let theta = theta_sq.sqrt();
        let (sin, cos) = theta.sin_cos();
        (sin / theta, (1.0 - cos) / theta_sq, (theta - sin) / (theta_sq * theta))
    }
}

/// The rotation matrix of an angle-axis vector (Rodrigues' formula).
pub(crate) fn rotation_from_angle_axis(angle_axis: &Vector3<f64>) -> Matrix3<f64> {
    let (a, b, _) = coefficients(angle_axis.norm_squared());
    let k = angle_axis.cross_matrix();
    Matrix3::identity() + k * a + k * k * b
}

/// The right Jacobian `Jr(a)` of SO(3) at the angle-axis vector `a`.
pub(crate) fn right_jacobian(angle_axis: &Vector3<f64>) -> Matrix3<f64> {
    let (_, b, c) = coefficients(angle_axis.norm_squared());
    let k = angle_axis.cross_matrix();
    Matrix3::identity() - k * b + k * k * c
}

#[cfg(test)]
mod tests {
    use super::*;

    const STEP: f64 = 1e-6;

    fn check_derivative(angle_axis: Vector3<f64>, point: Vector3<f64>) {
        let rotation = rotation_from_angle_axis(&angle_axis);
        let analytic = -(rotation * point).cross_matrix() * rotation * right_jacobian(&angle_axis);
        for axis in 0..3 {
            let mut delta = Vector3::zeros();
            delta[axis] = STEP;
            let plus = rotation_from_angle_axis(&(angle_axis + delta)) * point;
            let minus = rotation_from_angle_axis(&(angle_axis - delta)) * point;
            let numeric = (plus - minus) / (2.0 * STEP);
            let error = (numeric - analytic.column(axis)).norm();
            assert!(error < 1e-8, "angle-axis {angle_axis:?}, axis {axis}: numeric {numeric:?} analytic {:?}", analytic.column(axis));
        }
    }

    #[test]
    fn rotated_point_derivative_matches_central_differences() {
        let point = Vector3::new(0.3, -1.2, 2.5);
        for angle_axis in [
            Vector3::zeros(),
            Vector3::new(1e-7, -2e-7, 3e-8),
            Vector3::new(3e-5, 1e-5, -2e-5),
            Vector3::new(0.1, -0.2, 0.3),
            Vector3::new(1.5, 0.7, -1.1),
            Vector3::new(0.0, 3.0, 0.2),
        ] {
            check_derivative(angle_axis, point);
        }
    }

    #[test]
    fn rotation_is_orthonormal_and_matches_axis_angle() {
        let angle_axis = Vector3::new(0.4, -0.9, 0.2);
        let rotation = rotation_from_angle_axis(&angle_axis);
        assert!((rotation.transpose() * rotation - Matrix3::identity()).norm() < 1e-14);
        assert!((rotation.determinant() - 1.0).abs() < 1e-14);
        // The axis is the fixed direction; the angle is the norm.
        assert!((rotation * angle_axis - angle_axis).norm() < 1e-14);
        let reference = nalgebra::Rotation3::from_scaled_axis(angle_axis);
        assert!((reference.matrix() - rotation).norm() < 1e-14);
    }
}

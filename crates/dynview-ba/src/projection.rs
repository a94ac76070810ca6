//! The projection of a world point and its exact Jacobians with respect to every parameter
//! block; the camera model's own part (pixel from normalized point, and its derivatives) is
//! [`dynview_camera::Radial`]'s.

use dynview_camera::{Model, Radial, Rigid3};
use nalgebra::{Matrix2, Matrix2x3, Matrix3, SMatrix, Vector2, Vector3};

use crate::angle_axis::{right_jacobian, rotation_from_angle_axis};
use crate::pose::PoseParameters;
use crate::problem::Problem;

/// Number of intrinsic parameters, in the `RADIAL` model's order `[f, cx, cy, k1, k2]`.
pub(crate) const INTRINSIC_COUNT: usize = dynview_camera::radial::PARAM_COUNT;

/// One image's pose prepared for projecting many points: `R`, `R Jr` and the centre.
#[derive(Debug, Clone, Copy)]
pub(crate) struct ImageFrame {
    camera_from_world: Matrix3<f64>,
    rotation_times_right_jacobian: Matrix3<f64>,
    center_world: Vector3<f64>,
}

impl ImageFrame {
    /// Precomputes the rotation and its right Jacobian.
    pub(crate) fn new(pose: &PoseParameters) -> Self {
        let angle_axis = Vector3::from(pose.angle_axis);
        let camera_from_world = rotation_from_angle_axis(&angle_axis);
        Self {
            camera_from_world,
            rotation_times_right_jacobian: camera_from_world * right_jacobian(&angle_axis),
            center_world: Vector3::from(pose.center_world),
        }
    }

    /// The point in this image's camera frame.
    pub(crate) fn point_camera(&self, point_world: &Vector3<f64>) -> Vector3<f64> {
        self.camera_from_world * (point_world - self.center_world)
    }
}

/// The pixel of a camera-frame point, or `None` when it is not in front of the camera (`Z <= 0`).
pub(crate) fn pixel_from_camera(camera: &Radial, point_camera: &Vector3<f64>) -> Option<Vector2<f64>> {
    if point_camera.z.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let normalized = [point_camera.x / point_camera.z, point_camera.y / point_camera.z];
    Some(Vector2::from(camera.pixel_from_normalized(normalized)))
}

/// Projects a world point into an image as the solver does (through the pose's angle-axis
/// parameters); `None` when the point is not in front of the camera.
pub fn pixel_from_world(camera: &Radial, camera_from_world: &Rigid3, point_world: &[f64; 3]) -> Option<[f64; 2]> {
    let point_camera = ImageFrame::new(&PoseParameters::from_rigid(camera_from_world)).point_camera(&Vector3::from(*point_world));
    pixel_from_camera(camera, &point_camera).map(|pixel| [pixel.x, pixel.y])
}

/// Per observation, the Euclidean reprojection error in pixels; `f64::INFINITY` when the point
/// is not in front of the camera and `f64::NAN` when the observation's indices are out of range.
pub fn reprojection_errors_px(problem: &Problem) -> Vec<f64> {
    let frames: Vec<ImageFrame> = problem.images.iter().map(|pose| ImageFrame::new(&PoseParameters::from_rigid(pose))).collect();
    problem
        .observations
        .iter()
        .map(|observation| {
            let (Some(frame), Some(camera), Some(point)) = (
                frames.get(observation.image),
                problem.image_camera.get(observation.image).and_then(|&camera| problem.cameras.get(camera)),
                problem.points_world.get(observation.point),
            ) else {
                return f64::NAN;
            };
            match pixel_from_camera(camera, &frame.point_camera(&Vector3::from(*point))) {
                Some(pixel) => (pixel - Vector2::from(observation.pixel)).norm(),
                None => f64::INFINITY,
            }
        })
        .collect()
}

/// The residual `projected - measured` of one observation and its Jacobians.
#[derive(Debug, Clone, Copy)]
pub(crate) struct ResidualJacobians {
    /// `pixel(parameters) - measured`, pixels.
    pub residual_px: Vector2<f64>,
    /// d residual / d angle_axis.
    pub d_angle_axis: Matrix2x3<f64>,
    /// d residual / d center_world (equals `-d_point`).
    pub d_center: Matrix2x3<f64>,
    /// d residual / d point_world.
    pub d_point: Matrix2x3<f64>,
    /// d residual / d `[f, cx, cy, k1, k2]`.
    pub d_intrinsics: SMatrix<f64, 2, INTRINSIC_COUNT>,
}

/// The residual and all its Jacobians; `None` when the point is not in front of the camera.
pub(crate) fn residual_jacobians(
    camera: &Radial,
    frame: &ImageFrame,
    point_world: &Vector3<f64>,
    measured_px: &Vector2<f64>,
) -> Option<ResidualJacobians> {
    let point_camera = frame.point_camera(point_world);
    let pixel = pixel_from_camera(camera, &point_camera)?;
    let inverse_depth = 1.0 / point_camera.z;
    let x = point_camera.x * inverse_depth;
    let y = point_camera.y * inverse_depth;
    let [[u_x, u_y], [v_x, v_y]] = camera.d_pixel_d_normalized([x, y]);
    let d_pixel_d_normalized = Matrix2::new(u_x, u_y, v_x, v_y);
    // d (x, y) / d point_camera.
    let d_normalized_d_camera = Matrix2x3::new(inverse_depth, 0.0, -x * inverse_depth, 0.0, inverse_depth, -y * inverse_depth);
    let d_pixel_d_camera = d_pixel_d_normalized * d_normalized_d_camera;
    let d_point = d_pixel_d_camera * frame.camera_from_world;
    let d_angle_axis = -(d_pixel_d_camera * point_camera.cross_matrix()) * frame.rotation_times_right_jacobian;
    let [u_params, v_params] = camera.d_pixel_d_params([x, y]);
    let d_intrinsics = SMatrix::<f64, 2, INTRINSIC_COUNT>::from_fn(|row, column| [u_params, v_params][row][column]);
    Some(ResidualJacobians { residual_px: pixel - measured_px, d_angle_axis, d_center: -d_point, d_point, d_intrinsics })
}

#[cfg(test)]
mod tests {
    use super::*;

    const STEP: f64 = 1e-6;

    /// The pose, point and camera of one observation's parameters flattened as
    /// `[angle_axis(3), center(3), point(3), intrinsics(5)]`.
    fn unpack(parameters: &[f64; 14]) -> (PoseParameters, Vector3<f64>, Radial) {
        let pose = PoseParameters {
            angle_axis: [parameters[0], parameters[1], parameters[2]],
            center_world: [parameters[3], parameters[4], parameters[5]],
        };
        let point = Vector3::new(parameters[6], parameters[7], parameters[8]);
        let camera = Radial { f: parameters[9], cx: parameters[10], cy: parameters[11], k1: parameters[12], k2: parameters[13] };
        (pose, point, camera)
    }

    fn residual_of(parameters: &[f64; 14], measured: &Vector2<f64>) -> Vector2<f64> {
        let (pose, point, camera) = unpack(parameters);
        pixel_from_camera(&camera, &ImageFrame::new(&pose).point_camera(&point)).map(|pixel| pixel - measured).unwrap_or_default()
    }

    fn check(parameters: [f64; 14]) {
        let measured = Vector2::new(310.0, 250.0);
        let (pose, point, camera) = unpack(&parameters);
        let jacobians = residual_jacobians(&camera, &ImageFrame::new(&pose), &point, &measured).expect("in front");
        assert!((jacobians.residual_px - residual_of(&parameters, &measured)).norm() < 1e-12);
        for index in 0..14 {
            // Relative step for the large focal length and principal point.
            let step = STEP * parameters[index].abs().max(1.0);
            let mut plus = parameters;
            plus[index] += step;
            let mut minus = parameters;
            minus[index] -= step;
            let numeric = (residual_of(&plus, &measured) - residual_of(&minus, &measured)) / (2.0 * step);
            let analytic = match index {
                0..3 => jacobians.d_angle_axis.column(index).into_owned(),
                3..6 => jacobians.d_center.column(index - 3).into_owned(),
                6..9 => jacobians.d_point.column(index - 6).into_owned(),
                _ => jacobians.d_intrinsics.column(index - 9).into_owned(),
            };
            let tolerance = 1e-6 * analytic.norm().max(1.0);
            assert!((numeric - analytic).norm() < tolerance, "parameter {index}: numeric {numeric:?} analytic {analytic:?}");
        }
    }

    #[test]
    fn jacobians_match_central_differences() {
        check([0.1, -0.2, 0.15, 0.3, -0.2, -4.0, 0.5, 0.4, 3.0, 800.0, 320.0, 240.0, -0.08, 0.02]);
        check([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -0.3, 0.2, 2.0, 500.0, 300.0, 200.0, 0.1, -0.03]);
        check([1e-7, 2e-7, -1e-7, 0.1, 0.0, -1.0, 0.1, 0.0, 1.0, 1000.0, 640.0, 360.0, 0.0, 0.0]);
        // A large rotation, with the point placed in front of the camera.
        let angle_axis = Vector3::new(2.0, 0.5, -1.0);
        let center = Vector3::new(1.0, 2.0, 3.0);
        let point = center + rotation_from_angle_axis(&angle_axis).transpose() * Vector3::new(0.3, -0.2, 4.0);
        check([2.0, 0.5, -1.0, 1.0, 2.0, 3.0, point.x, point.y, point.z, 700.0, 320.0, 240.0, -0.2, 0.05]);
    }

    #[test]
    fn jacobians_match_central_differences_for_a_point_at_the_far_side() {
        // A rotation of nearly pi about y looks back at the origin from +z.
        let parameters = [0.0, 3.0, 0.0, 0.2, -0.1, 5.0, 0.3, 0.1, 0.5, 900.0, 400.0, 300.0, -0.1, 0.01];
        let pose = PoseParameters { angle_axis: [0.0, 3.0, 0.0], center_world: [0.2, -0.1, 5.0] };
        let camera = Radial { f: 900.0, cx: 400.0, cy: 300.0, k1: -0.1, k2: 0.01 };
        assert!(pixel_from_world(&camera, &pose.to_rigid(), &[0.3, 0.1, 0.5]).is_some());
        check(parameters);
    }

    #[test]
    fn projection_follows_the_documented_model() {
        let camera = Radial { f: 500.0, cx: 320.0, cy: 240.0, k1: 0.1, k2: 0.01 };
        let pose = PoseParameters { angle_axis: [0.0; 3], center_world: [0.0, 0.0, -2.0] }.to_rigid();
        let pixel = pixel_from_world(&camera, &pose, &[0.2, -0.4, 2.0]).expect("in front");
        let (x, y) = (0.2 / 4.0, -0.4 / 4.0);
        let r2: f64 = x * x + y * y;
        let d = 1.0 + 0.1 * r2 + 0.01 * r2 * r2;
        assert!((pixel[0] - (500.0 * d * x + 320.0)).abs() < 1e-12);
        assert!((pixel[1] - (500.0 * d * y + 240.0)).abs() < 1e-12);
        assert!(pixel_from_world(&camera, &pose, &[0.0, 0.0, -3.0]).is_none());
        assert!(pixel_from_world(&camera, &pose, &[0.0, 0.0, -2.0]).is_none());
    }
}

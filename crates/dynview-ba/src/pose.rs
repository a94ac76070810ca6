//! How the optimiser parametrises an image's pose: the `camera_from_world` rotation as an
//! angle-axis vector and the camera centre, `X_cam = R(angle_axis) (X_world - center_world)`.
//! The problem's poses are [`Rigid3`]; they are converted on the way in and out of a solve
//! (`dynview_camera`'s nalgebra forms: nalgebra's angle-axis vector, `t = -R C`).

use dynview_camera::Rigid3;
use nalgebra::Vector3;

/// One image's pose as the optimiser's unknowns.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct PoseParameters {
    /// `camera_from_world` rotation as an angle-axis vector: direction is the axis, norm the
    /// angle in radians.
    pub angle_axis: [f64; 3],
    /// Camera centre in world coordinates.
    pub center_world: [f64; 3],
}

impl PoseParameters {
    /// The parameters of a `camera_from_world` pose.
    pub(crate) fn from_rigid(camera_from_world: &Rigid3) -> Self {
        Self { angle_axis: camera_from_world.angle_axis().into(), center_world: camera_from_world.center().into() }
    }

    /// The `camera_from_world` pose of these parameters.
    pub(crate) fn to_rigid(self) -> Rigid3 {
        Rigid3::from_angle_axis_center(Vector3::from(self.angle_axis), Vector3::from(self.center_world))
    }
}

//! The values being optimised, and how a step updates them.

use dynview_camera::Radial;
use nalgebra::Vector3;

use super::layout::{Layout, NodeKind};
use crate::pose::PoseParameters;
use crate::problem::Problem;

/// A copy of the problem's optimisable values.
#[derive(Debug, Clone)]
pub(crate) struct Parameters {
    /// Camera intrinsics.
    pub cameras: Vec<Radial>,
    /// Image poses, as the optimiser parametrises them.
    pub images: Vec<PoseParameters>,
    /// Points in world coordinates.
    pub points_world: Vec<[f64; 3]>,
}

/// The intrinsic with index `index` in `[f, cx, cy, k1, k2]`.
pub(crate) fn intrinsic_mut(camera: &mut Radial, index: usize) -> &mut f64 {
    match index {
        0 => &mut camera.f,
        1 => &mut camera.cx,
        2 => &mut camera.cy,
        3 => &mut camera.k1,
        _ => &mut camera.k2,
    }
}

impl Parameters {
    /// Copies the values out of a problem (the poses as angle-axis vectors and centres).
    pub(crate) fn from_problem(problem: &Problem) -> Self {
        Self {
            cameras: problem.cameras.clone(),
            images: problem.images.iter().map(PoseParameters::from_rigid).collect(),
            points_world: problem.points_world.clone(),
        }
    }

    /// Writes the values back into the problem. Only the poses whose parameters changed are
    /// converted back: the others (fixed, or not moved by the solve) keep their `Rigid3`
    /// exactly rather than taking a round trip through the angle-axis vector.
    pub(crate) fn write_to(self, problem: &mut Problem) {
        problem.cameras = self.cameras;
        for (pose, parameters) in problem.images.iter_mut().zip(self.images) {
            if parameters != PoseParameters::from_rigid(pose) {
                *pose = parameters.to_rigid();
            }
        }
        problem.points_world = self.points_world;
    }

    /// The values after adding a step: `delta_camera` in node order, `delta_points` per point group.
    pub(crate) fn stepped(&self, layout: &Layout, delta_camera: &[f64], delta_points: &[Vector3<f64>]) -> Self {
        let mut next = self.clone();
        for (node, kind) in layout.node_kind.iter().enumerate() {
            let delta = &delta_camera[layout.pattern.node_offset(node)..][..layout.pattern.node_size(node)];
            match *kind {
                NodeKind::Image(image) => {
                    let pose = &mut next.images[image];
                    for axis in 0..3 {
                        pose.angle_axis[axis] += delta[axis];
                        pose.center_world[axis] += delta[3 + axis];
                    }
                }
                NodeKind::Camera(camera) => {
                    for (&index, &change) in layout.free_intrinsics[camera].iter().zip(delta) {
                        *intrinsic_mut(&mut next.cameras[camera], index) += change;
                    }
                }
            }
        }
        for (group, delta) in layout.groups.iter().zip(delta_points).filter(|(g, _)| g.free) {
            for (value, change) in next.points_world[group.point].iter_mut().zip(delta.iter()) {
                *value += change;
            }
        }
        next
    }

    /// Euclidean norm of the stacked unknowns (for the parameter tolerance).
    pub(crate) fn unknown_norm(&self, layout: &Layout) -> f64 {
        let mut sum = 0.0;
        for kind in &layout.node_kind {
            match *kind {
                NodeKind::Image(image) => {
                    let pose = &self.images[image];
                    sum += pose.angle_axis.iter().chain(&pose.center_world).map(|v| v * v).sum::<f64>();
                }
                NodeKind::Camera(camera) => {
                    let mut copy = self.cameras[camera];
                    sum += layout.free_intrinsics[camera].iter().map(|&index| intrinsic_mut(&mut copy, index).powi(2)).sum::<f64>();
                }
            }
        }
        for group in layout.groups.iter().filter(|g| g.free) {
            sum += self.points_world[group.point].iter().map(|v| v * v).sum::<f64>();
        }
        sum.sqrt()
    }
}

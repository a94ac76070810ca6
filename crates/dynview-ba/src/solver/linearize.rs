//! Evaluation of the Gauss-Newton normal equations, split for the Schur complement.
//!
//! With the robust weights applied by iteratively reweighted least squares (each residual and
//! its Jacobian scaled by `sqrt(rho'(s))`, which is the Triggs correction for losses with
//! `rho'' <= 0` such as Huber and Cauchy), the normal equations are
//! `[U W; W^T V] [dc; dp] = -[g_c; g_p]`: `U` couples the camera-side nodes (reprojection terms
//! and the priors), `V` is block diagonal with one 3x3 block per free point, `W` couples points
//! and nodes.

use nalgebra::{Matrix2x3, Matrix3, Vector2, Vector3};

use super::layout::{Layout, POSE_UNKNOWNS, PointGroup};
use super::parameters::Parameters;
use crate::loss::Loss;
use crate::par;
use crate::problem::SmoothnessPrior;
use crate::projection::{INTRINSIC_COUNT, ImageFrame, residual_jacobians};

/// Point groups per parallel work item, at least.
const GROUPS_PER_CHUNK: usize = 256;
/// Upper bound on the scalars held by per-worker copies of the reduced system.
const MAX_ACCUMULATOR_VALUES: usize = 1 << 25;

/// The normal equations at one set of parameter values (undamped).
pub(crate) struct Linearization {
    /// `U` in the reduced system's value layout.
    pub hessian_camera: Vec<f64>,
    /// `g_c = J_c^T r` (weighted), in node order.
    pub gradient_camera: Vec<f64>,
    /// `V`, per point group (zero for fixed points).
    pub point_hessian: Vec<Matrix3<f64>>,
    /// `g_p`, per point group (zero for fixed points).
    pub point_gradient: Vec<Vector3<f64>>,
    /// `W`: per free point group, per node of the group, a `node size x 3` row-major block.
    pub coupling: Vec<f64>,
}

/// How many accumulating workers to use for `value_count` scalars of reduced system.
pub(crate) fn accumulator_chunks(layout: &Layout) -> Vec<std::ops::Range<usize>> {
    let budget = (MAX_ACCUMULATOR_VALUES / layout.pattern.value_count().max(1)).max(1);
    par::chunk_ranges(layout.groups.len(), par::worker_count().min(budget), GROUPS_PER_CHUNK)
}

/// Per-worker share of the normal equations.
struct Partial {
    hessian_camera: Vec<f64>,
    gradient_camera: Vec<f64>,
    point_hessian: Vec<Matrix3<f64>>,
    point_gradient: Vec<Vector3<f64>>,
    coupling: Vec<f64>,
}

/// Builds the normal equations.
pub(crate) fn linearize(layout: &Layout, parameters: &Parameters, priors: &[SmoothnessPrior], loss: &Loss) -> Linearization {
    let frames: Vec<ImageFrame> = parameters.images.iter().map(ImageFrame::new).collect();
    let chunks = accumulator_chunks(layout);
    let partials = par::map_range(chunks.len(), |chunk| {
        let groups = &layout.groups[chunks[chunk].clone()];
        let coupling_start = groups.first().map_or(0, |g| g.coupling_start);
        let coupling_end = groups.last().map_or(0, |g| g.coupling_start + group_coupling_len(layout, g));
        let mut partial = Partial {
            hessian_camera: vec![0.0; layout.pattern.value_count()],
            gradient_camera: vec![0.0; layout.pattern.dim()],
            point_hessian: Vec::with_capacity(groups.len()),
            point_gradient: Vec::with_capacity(groups.len()),
            coupling: vec![0.0; coupling_end - coupling_start],
        };
        for group in groups {
            accumulate_group(layout, parameters, &frames, loss, group, coupling_start, &mut partial);
        }
        partial
    });
    let mut linearization = Linearization {
        hessian_camera: vec![0.0; layout.pattern.value_count()],
        gradient_camera: vec![0.0; layout.pattern.dim()],
        point_hessian: Vec::with_capacity(layout.groups.len()),
        point_gradient: Vec::with_capacity(layout.groups.len()),
        coupling: Vec::with_capacity(layout.coupling_len),
    };
    for partial in partials {
        add_into(&mut linearization.hessian_camera, &partial.hessian_camera);
        add_into(&mut linearization.gradient_camera, &partial.gradient_camera);
        linearization.point_hessian.extend(partial.point_hessian);
        linearization.point_gradient.extend(partial.point_gradient);
        linearization.coupling.extend(partial.coupling);
    }
    add_priors(layout, parameters, priors, &mut linearization);
    linearization
}

fn add_into(target: &mut [f64], source: &[f64]) {
    for (t, s) in target.iter_mut().zip(source) {
        *t += s;
    }
}

/// Length of a group's coupling blocks.
pub(crate) fn group_coupling_len(layout: &Layout, group: &PointGroup) -> usize {
    layout.group_nodes[group.nodes.clone()].iter().map(|&n| layout.pattern.node_size(n) * 3).sum()
}

/// Adds one point group's observations to the partial normal equations.
fn accumulate_group(
    layout: &Layout,
    parameters: &Parameters,
    frames: &[ImageFrame],
    loss: &Loss,
    group: &PointGroup,
    coupling_base: usize,
    partial: &mut Partial,
) {
    let pattern = &layout.pattern;
    let nodes = &layout.group_nodes[group.nodes.clone()];
    // Offsets of the group's coupling blocks in the partial buffer.
    let mut block_offsets = Vec::with_capacity(nodes.len());
    let mut offset = group.coupling_start - coupling_base;
    for &node in nodes {
        block_offsets.push(offset);
        offset += pattern.node_size(node) * 3;
    }
    let point_world = Vector3::from(parameters.points_world[group.point]);
    let mut point_hessian = Matrix3::zeros();
    let mut point_gradient = Vector3::zeros();
    // Transposed weighted Jacobians of the camera-side nodes, row-major (unknowns x 2).
    let mut x_image = [0.0; POSE_UNKNOWNS * 2];
    let mut x_camera = [0.0; INTRINSIC_COUNT * 2];
    for observation in &layout.observations[group.observations.clone()] {
        let camera = &parameters.cameras[observation.camera];
        let free_intrinsics = &layout.free_intrinsics[observation.camera];
        let Some(jacobians) = residual_jacobians(camera, &frames[observation.image], &point_world, &observation.pixel) else {
            continue;
        };
        let sqrt_weight = loss.evaluate(jacobians.residual_px.norm_squared()).1.sqrt();
        let residual: Vector2<f64> = jacobians.residual_px * sqrt_weight;
        for t in 0..2 {
            for p in 0..3 {
                x_image[p * 2 + t] = sqrt_weight * jacobians.d_angle_axis[(t, p)];
                x_image[(3 + p) * 2 + t] = sqrt_weight * jacobians.d_center[(t, p)];
            }
            for (q, &index) in free_intrinsics.iter().enumerate() {
                x_camera[q * 2 + t] = sqrt_weight * jacobians.d_intrinsics[(t, index)];
            }
        }
        let x_camera = &x_camera[..free_intrinsics.len() * 2];
        let sides = [
            (observation.image_node, observation.image_local, &x_image[..]),
            (observation.camera_node, observation.camera_local, x_camera),
        ];
        for (node, _, x) in sides.iter().filter_map(|(n, l, x)| n.map(|n| (n, l, x))) {
            pattern.add_product(&mut partial.hessian_camera, node, node, x, x, 2, 1.0);
            let gradient = &mut partial.gradient_camera[pattern.node_offset(node)..];
            for (p, entry) in gradient.iter_mut().take(pattern.node_size(node)).enumerate() {
                *entry += x[p * 2] * residual.x + x[p * 2 + 1] * residual.y;
            }
        }
        if let (Some(image_node), Some(camera_node)) = (observation.image_node, observation.camera_node) {
            pattern.add_product(&mut partial.hessian_camera, camera_node, image_node, x_camera, &x_image, 2, 1.0);
        }
        if group.free {
            let d_point: Matrix2x3<f64> = jacobians.d_point * sqrt_weight;
            point_hessian += d_point.transpose() * d_point;
            point_gradient += d_point.transpose() * residual;
            for (local, x) in sides.iter().filter_map(|(_, l, x)| l.map(|l| (l, x))) {
                let size = pattern.node_size(nodes[local]);
                let block = &mut partial.coupling[block_offsets[local]..block_offsets[local] + size * 3];
                for p in 0..size {
                    for q in 0..3 {
                        block[p * 3 + q] += x[p * 2] * d_point[(0, q)] + x[p * 2 + 1] * d_point[(1, q)];
                    }
                }
            }
        }
    }
    partial.point_hessian.push(point_hessian);
    partial.point_gradient.push(point_gradient);
}

/// Adds the priors' plain squared terms: residual `[sqrt(w_r) (A_a - A_b); sqrt(w_c) (C_a - C_b)]`.
fn add_priors(layout: &Layout, parameters: &Parameters, priors: &[SmoothnessPrior], linearization: &mut Linearization) {
    let pattern = &layout.pattern;
    for prior in priors.iter().filter(|p| p.image_a != p.image_b) {
        let (a, b) = (&parameters.images[prior.image_a], &parameters.images[prior.image_b]);
        let scale = [prior.weight_rotation.sqrt(), prior.weight_center.sqrt()];
        let mut residual = [0.0; POSE_UNKNOWNS];
        for axis in 0..3 {
            residual[axis] = scale[0] * (a.angle_axis[axis] - b.angle_axis[axis]);
            residual[3 + axis] = scale[1] * (a.center_world[axis] - b.center_world[axis]);
        }
        // Transposed Jacobians (6 x 6, row-major): +diag(scale) for image a, -diag(scale) for image b.
        let jacobian_for = |sign: f64| {
            let mut x = [0.0; POSE_UNKNOWNS * POSE_UNKNOWNS];
            for p in 0..POSE_UNKNOWNS {
                x[p * POSE_UNKNOWNS + p] = sign * scale[p / 3];
            }
            x
        };
        let sides = [(layout.image_node[prior.image_a], jacobian_for(1.0)), (layout.image_node[prior.image_b], jacobian_for(-1.0))];
        for (i, (node_i, x_i)) in sides.iter().enumerate() {
            let Some(node_i) = *node_i else { continue };
            let gradient = &mut linearization.gradient_camera[pattern.node_offset(node_i)..][..POSE_UNKNOWNS];
            for (p, entry) in gradient.iter_mut().enumerate() {
                *entry += x_i[p * POSE_UNKNOWNS + p] * residual[p];
            }
            for (node_j, x_j) in sides.iter().take(i + 1).filter_map(|(n, x)| n.map(|n| (n, x))) {
                pattern.add_product(&mut linearization.hessian_camera, node_i, node_j, x_i, x_j, POSE_UNKNOWNS, 1.0);
            }
        }
    }
}

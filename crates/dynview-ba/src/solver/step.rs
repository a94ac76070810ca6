//! One Levenberg-Marquardt step: damp, eliminate the points (Schur complement), factorise the
//! reduced camera system, and back-substitute the points.

use nalgebra::{Matrix3, Vector3};

use super::block_cholesky::{NotPositiveDefinite, add_product_at};
use super::layout::Layout;
use super::linearize::{Linearization, accumulator_chunks, group_coupling_len};
use crate::par;

/// Smallest diagonal entry used for damping (Ceres' `min_lm_diagonal`), so that unknowns the
/// data does not constrain still get damped.
const MIN_DAMPING_DIAGONAL: f64 = 1e-6;
/// Largest diagonal entry used for damping (Ceres' `max_lm_diagonal`).
const MAX_DAMPING_DIAGONAL: f64 = 1e32;

/// A step and the decrease of the cost the linear model predicts for it.
pub(crate) struct Step {
    /// Change of the camera-side unknowns, in node order.
    pub delta_camera: Vec<f64>,
    /// Change of each point group's point (zero for fixed points).
    pub delta_points: Vec<Vector3<f64>>,
    /// `-2 g^T d - d^T H d` (the model's decrease of the cost), non-negative.
    pub model_decrease: f64,
    /// Euclidean norm of the whole step.
    pub norm: f64,
}

fn damping_diagonal(value: f64) -> f64 {
    value.clamp(MIN_DAMPING_DIAGONAL, MAX_DAMPING_DIAGONAL)
}

/// Per-worker share of the Schur complement.
struct Partial {
    reduced: Vec<f64>,
    rhs: Vec<f64>,
    point_inverse: Vec<Matrix3<f64>>,
}

/// The damped reduced camera system `S = U + lambda D - sum W V^-1 W^T` (not yet factorised),
/// its right-hand side `-g_c + sum W V^-1 g_p`, the camera-side damping diagonal `D`, and each
/// point group's damped inverse `V^-1`.
pub(crate) struct ReducedSystem {
    pub reduced: Vec<f64>,
    pub rhs: Vec<f64>,
    pub camera_damping: Vec<f64>,
    pub point_inverse: Vec<Matrix3<f64>>,
}

/// Eliminates the points of `(H + lambda D) d = -g` (the Schur complement).
pub(crate) fn reduced_system(layout: &Layout, linearization: &Linearization, lambda: f64) -> Result<ReducedSystem, NotPositiveDefinite> {
    let pattern = &layout.pattern;
    let chunks = accumulator_chunks(layout);
    let partials = par::map_range(chunks.len(), |chunk| {
        let mut partial = Partial {
            reduced: vec![0.0; pattern.value_count()],
            rhs: vec![0.0; pattern.dim()],
            point_inverse: Vec::with_capacity(chunks[chunk].len()),
        };
        let mut transformed = Vec::new();
        for index in chunks[chunk].clone() {
            let group = &layout.groups[index];
            if !group.free {
                partial.point_inverse.push(Matrix3::zeros());
                continue;
            }
            let mut damped = linearization.point_hessian[index];
            for axis in 0..3 {
                damped[(axis, axis)] += lambda * damping_diagonal(linearization.point_hessian[index][(axis, axis)]);
            }
            let inverse = damped.cholesky().ok_or(NotPositiveDefinite)?.inverse();
            partial.point_inverse.push(inverse);
            // T_k = W_k V^-1 for each node k of the point; S -= T_k W_l^T; rhs += T_k g_p.
            let nodes = &layout.group_nodes[group.nodes.clone()];
            let coupling = &linearization.coupling[group.coupling_start..group.coupling_start + group_coupling_len(layout, group)];
            transformed.clear();
            transformed.extend(coupling.chunks_exact(3).flat_map(|row| {
                let row = inverse * Vector3::new(row[0], row[1], row[2]);
                [row.x, row.y, row.z]
            }));
            let gradient = linearization.point_gradient[index];
            let mut offset_k = 0;
            for (k, &node_k) in nodes.iter().enumerate() {
                let size_k = pattern.node_size(node_k);
                let t_k = &transformed[offset_k..offset_k + size_k * 3];
                let rhs = &mut partial.rhs[pattern.node_offset(node_k)..][..size_k];
                for (p, entry) in rhs.iter_mut().enumerate() {
                    *entry += t_k[p * 3] * gradient.x + t_k[p * 3 + 1] * gradient.y + t_k[p * 3 + 2] * gradient.z;
                }
                let mut offset_l = 0;
                let slots = &layout.pair_slots[group.pairs_start + k * (k + 1) / 2..][..=k];
                for (&node_l, slot) in nodes[..=k].iter().zip(slots) {
                    let size_l = pattern.node_size(node_l);
                    if let Some(slot) = *slot {
                        add_product_at(&mut partial.reduced, slot, t_k, &coupling[offset_l..offset_l + size_l * 3], 3, -1.0);
                    }
                    offset_l += size_l * 3;
                }
                offset_k += size_k * 3;
            }
        }
        Ok(partial)
    });

    // S = U + lambda D - sum W V^-1 W^T, rhs = -g_c + sum W V^-1 g_p.
    let mut reduced = linearization.hessian_camera.clone();
    let mut rhs: Vec<f64> = linearization.gradient_camera.iter().map(|g| -g).collect();
    let mut camera_damping = vec![0.0; pattern.dim()];
    for node in 0..layout.node_kind.len() {
        for local in 0..pattern.node_size(node) {
            let index = pattern.diagonal_index(node, local);
            let damping = damping_diagonal(reduced[index]);
            camera_damping[pattern.node_offset(node) + local] = damping;
            reduced[index] += lambda * damping;
        }
    }
    let mut point_inverse = Vec::with_capacity(layout.groups.len());
    for partial in partials {
        let partial = partial?;
        for (target, value) in reduced.iter_mut().zip(&partial.reduced) {
            *target += value;
        }
        for (target, value) in rhs.iter_mut().zip(&partial.rhs) {
            *target += value;
        }
        point_inverse.extend(partial.point_inverse);
    }
    Ok(ReducedSystem { reduced, rhs, camera_damping, point_inverse })
}

/// Solves `(H + lambda D) d = -g`, `D` the clamped diagonal of `H`, by the Schur complement on the points.
pub(crate) fn compute_step(layout: &Layout, linearization: &Linearization, lambda: f64) -> Result<Step, NotPositiveDefinite> {
    let pattern = &layout.pattern;
    let ReducedSystem { mut reduced, rhs, camera_damping, point_inverse } = reduced_system(layout, linearization, lambda)?;
    pattern.factor(&mut reduced)?;
    let delta_camera = pattern.solve(&reduced, &rhs);
    if delta_camera.iter().any(|v| !v.is_finite()) {
        return Err(NotPositiveDefinite);
    }

    // dp = V^-1 (-g_p - W^T dc), per point.
    let delta_points = par::map_range(layout.groups.len(), |index| {
        let group = &layout.groups[index];
        if !group.free {
            return Vector3::zeros();
        }
        let mut right = -linearization.point_gradient[index];
        let mut offset = group.coupling_start;
        for &node in &layout.group_nodes[group.nodes.clone()] {
            let size = pattern.node_size(node);
            let delta = &delta_camera[pattern.node_offset(node)..][..size];
            let block = &linearization.coupling[offset..offset + size * 3];
            for (p, &change) in delta.iter().enumerate() {
                right -= Vector3::new(block[p * 3], block[p * 3 + 1], block[p * 3 + 2]) * change;
            }
            offset += size * 3;
        }
        point_inverse[index] * right
    });

    // With (H + lambda D) d = -g the model decrease -2 g^T d - d^T H d equals -g^T d + lambda d^T D d.
    let mut gradient_dot = 0.0;
    let mut damped_norm = 0.0;
    let mut squared_norm = 0.0;
    for ((delta, gradient), damping) in delta_camera.iter().zip(&linearization.gradient_camera).zip(&camera_damping) {
        gradient_dot += delta * gradient;
        damped_norm += damping * delta * delta;
        squared_norm += delta * delta;
    }
    for (index, delta) in delta_points.iter().enumerate().filter(|(i, _)| layout.groups[*i].free) {
        gradient_dot += delta.dot(&linearization.point_gradient[index]);
        for axis in 0..3 {
            damped_norm += damping_diagonal(linearization.point_hessian[index][(axis, axis)]) * delta[axis] * delta[axis];
        }
        squared_norm += delta.norm_squared();
    }
    let model_decrease = -gradient_dot + lambda * damped_norm;
    Ok(Step { delta_camera, delta_points, model_decrease, norm: squared_norm.sqrt() })
}

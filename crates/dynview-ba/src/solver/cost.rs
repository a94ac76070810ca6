//! The cost: robust reprojection terms plus the smoothness priors (Eqs. 1-2 of the paper).

use nalgebra::Vector3;

use super::layout::Layout;
use super::parameters::Parameters;
use crate::loss::Loss;
use crate::par;
use crate::problem::SmoothnessPrior;
use crate::projection::{ImageFrame, pixel_from_camera};

/// Observations per parallel work item when summing the cost.
const OBSERVATIONS_PER_CHUNK: usize = 4096;

/// The cost of one set of parameter values.
#[derive(Debug, Clone, Copy)]
pub(crate) struct CostSummary {
    /// `sum rho(||r||^2)` plus the prior terms.
    pub cost: f64,
    /// `sum ||r||^2` over the used observations (pixels squared), without the loss.
    pub squared_error_px2: f64,
}

/// `weight_center ||C_a - C_b||^2 + weight_rotation ||A_a - A_b||^2` summed over the priors.
pub(crate) fn prior_cost(parameters: &Parameters, priors: &[SmoothnessPrior]) -> f64 {
    priors
        .iter()
        .map(|prior| {
            let (a, b) = (&parameters.images[prior.image_a], &parameters.images[prior.image_b]);
            let center = Vector3::from(a.center_world) - Vector3::from(b.center_world);
            let rotation = Vector3::from(a.angle_axis) - Vector3::from(b.angle_axis);
            prior.weight_center * center.norm_squared() + prior.weight_rotation * rotation.norm_squared()
        })
        .sum()
}

/// The cost, or `None` when a used point is not in front of its camera (an invalid state).
pub(crate) fn evaluate_cost(layout: &Layout, parameters: &Parameters, priors: &[SmoothnessPrior], loss: &Loss) -> Option<CostSummary> {
    let frames: Vec<ImageFrame> = parameters.images.iter().map(ImageFrame::new).collect();
    let chunks = par::chunk_ranges(layout.observations.len(), usize::MAX, OBSERVATIONS_PER_CHUNK);
    let partial = par::map_range(chunks.len(), |chunk| {
        let mut cost = 0.0;
        let mut squared_error_px2 = 0.0;
        for observation in &layout.observations[chunks[chunk].clone()] {
            let point_camera = frames[observation.image].point_camera(&Vector3::from(parameters.points_world[observation.point]));
            let pixel = pixel_from_camera(&parameters.cameras[observation.camera], &point_camera)?;
            let squared = (pixel - observation.pixel).norm_squared();
            cost += loss.evaluate(squared).0;
            squared_error_px2 += squared;
        }
        Some((cost, squared_error_px2))
    });
    let mut summary = CostSummary { cost: prior_cost(parameters, priors), squared_error_px2: 0.0 };
    for part in partial {
        let (cost, squared) = part?;
        summary.cost += cost;
        summary.squared_error_px2 += squared;
    }
    summary.cost.is_finite().then_some(summary)
}

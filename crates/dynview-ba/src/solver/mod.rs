//! Levenberg-Marquardt bundle adjustment with the points eliminated by the Schur complement.
//!
//! The loop follows Ceres' trust-region Levenberg-Marquardt: the damping `lambda` scales the
//! clamped diagonal of the Gauss-Newton matrix; a step is accepted when the actual cost
//! decrease is at least [`MIN_RELATIVE_DECREASE`] of the decrease the linear model predicts,
//! after which `lambda` shrinks by `max(1/3, 1 - (2 rho - 1)^3)` (Nielsen); a rejected step (or
//! a failed factorisation) multiplies `lambda` by a growing factor.

mod block_cholesky;
mod cost;
mod covariance;
mod layout;
mod linearize;
mod ordering;
mod parameters;
mod step;

#[cfg(test)]
mod tests;

pub use covariance::{IntrinsicsStd, intrinsics_std};

use crate::error::BaError;
use crate::options::{Options, Report, Termination};
use crate::problem::Problem;
use cost::{CostSummary, evaluate_cost};
use layout::Layout;
use linearize::linearize;
use parameters::Parameters;
use step::compute_step;

/// Initial damping (Ceres' initial trust region radius of 1e4, inverted).
const INITIAL_LAMBDA: f64 = 1e-4;
/// Damping bounds (Ceres' trust region radius bounds, inverted).
const MIN_LAMBDA: f64 = 1e-16;
const MAX_LAMBDA: f64 = 1e32;
/// Smallest ratio of actual to predicted cost decrease for a step to be accepted.
const MIN_RELATIVE_DECREASE: f64 = 1e-3;

/// Minimises the cost of `problem` over its free poses, points and intrinsics, writing the
/// result back into `problem`.
///
/// Inputs are validated first ([`Problem::validate`], [`Options::validate`]); on an error the
/// problem is left unchanged. Observations whose point is not in front of the camera at the start
/// are left out (counted in [`Report::excluded_observations`]); steps that would put a used
/// point behind its camera are rejected.
pub fn solve(problem: &mut Problem, options: &Options) -> Result<Report, BaError> {
    problem.validate()?;
    options.validate()?;
    let layout = Layout::new(problem, options);
    let priors = problem.priors.clone();
    let mut parameters = Parameters::from_problem(problem);
    let initial = evaluate_cost(&layout, &parameters, &priors, &options.loss)
        .ok_or_else(|| BaError::Numerical { reason: "the initial cost is not finite".into() })?;
    let rms = |summary: &CostSummary| {
        if layout.observations.is_empty() { 0.0 } else { (summary.squared_error_px2 / layout.observations.len() as f64).sqrt() }
    };
    let mut report = Report {
        iterations: 0,
        accepted_steps: 0,
        initial_cost: initial.cost,
        final_cost: initial.cost,
        cost_history: vec![initial.cost],
        initial_rms_px: rms(&initial),
        final_rms_px: rms(&initial),
        termination: Termination::NothingToOptimize,
        camera_unknowns: layout.camera_unknowns(),
        point_unknowns: 3 * layout.free_points,
        excluded_observations: layout.excluded_observations,
    };
    if layout.camera_unknowns() == 0 && layout.free_points == 0 {
        return Ok(report);
    }

    let mut current = initial;
    let mut linearization = linearize(&layout, &parameters, &priors, &options.loss);
    let initial_gradient = gradient_max_norm(&layout, &linearization);
    let mut lambda = INITIAL_LAMBDA;
    let mut growth = 2.0;
    let mut factorised_once = false;
    let mut termination = (initial_gradient == 0.0).then_some(Termination::GradientTolerance);
    while termination.is_none() && report.iterations < options.max_iterations {
        report.iterations += 1;
        let step = match compute_step(&layout, &linearization, lambda) {
            Ok(step) => step,
            Err(_) => {
                lambda *= growth;
                growth *= 2.0;
                if lambda > MAX_LAMBDA {
                    if !factorised_once {
                        return Err(BaError::Numerical { reason: "the damped normal equations could not be factorised".into() });
                    }
                    termination = Some(Termination::DampingLimit);
                }
                continue;
            }
        };
        factorised_once = true;
        let parameter_norm = parameters.unknown_norm(&layout);
        if step.norm <= options.parameter_tolerance * (parameter_norm + options.parameter_tolerance) {
            termination = Some(Termination::ParameterTolerance);
            break;
        }
        let candidate = parameters.stepped(&layout, &step.delta_camera, &step.delta_points);
        let evaluated = evaluate_cost(&layout, &candidate, &priors, &options.loss);
        let ratio = match evaluated {
            Some(summary) if step.model_decrease > 0.0 => (current.cost - summary.cost) / step.model_decrease,
            _ => f64::NEG_INFINITY,
        };
        match evaluated {
            Some(summary) if ratio >= MIN_RELATIVE_DECREASE => {
                let decrease = current.cost - summary.cost;
                let previous_cost = current.cost;
                parameters = candidate;
                current = summary;
                report.accepted_steps += 1;
                report.cost_history.push(current.cost);
                lambda = (lambda * (1.0 / 3.0f64).max(1.0 - (2.0 * ratio - 1.0).powi(3))).max(MIN_LAMBDA);
                growth = 2.0;
                if decrease <= options.function_tolerance * previous_cost {
                    termination = Some(Termination::FunctionTolerance);
                    break;
                }
                linearization = linearize(&layout, &parameters, &priors, &options.loss);
                if gradient_max_norm(&layout, &linearization) <= options.gradient_tolerance * initial_gradient {
                    termination = Some(Termination::GradientTolerance);
                }
            }
            _ => {
                lambda *= growth;
                growth *= 2.0;
                if lambda > MAX_LAMBDA {
                    termination = Some(Termination::DampingLimit);
                }
            }
        }
    }
    report.termination = termination.unwrap_or(Termination::MaxIterations);
    report.final_cost = current.cost;
    report.final_rms_px = rms(&current);
    parameters.write_to(problem);
    Ok(report)
}

/// Max-norm of the gradient over all unknowns.
fn gradient_max_norm(layout: &Layout, linearization: &linearize::Linearization) -> f64 {
    let camera = linearization.gradient_camera.iter().fold(0.0f64, |m, g| m.max(g.abs()));
    layout.groups.iter().zip(&linearization.point_gradient).filter(|(g, _)| g.free).fold(camera, |m, (_, g)| m.max(g.amax()))
}

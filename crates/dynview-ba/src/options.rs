//! Solver options and the report of a solve.

use crate::error::BaError;
use crate::loss::Loss;

/// Default robust loss scale, pixels: observations beyond about this error are down-weighted.
pub const DEFAULT_LOSS_SCALE_PX: f64 = 1.0;
/// Default iteration limit (accepted and rejected Levenberg-Marquardt steps together).
pub const DEFAULT_MAX_ITERATIONS: usize = 100;
/// Default relative cost decrease below which an accepted step ends the solve.
pub const DEFAULT_FUNCTION_TOLERANCE: f64 = 1e-6;
/// Default gradient max-norm, relative to the initial one, below which the solve ends.
pub const DEFAULT_GRADIENT_TOLERANCE: f64 = 1e-10;
/// Default step norm, relative to the norm of the unknowns, below which the solve ends.
pub const DEFAULT_PARAMETER_TOLERANCE: f64 = 1e-8;

/// How [`crate::solve`] runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Options {
    /// Robust loss on the reprojection residuals (priors are always plain squares).
    /// Default: `Loss::Cauchy { scale_px: DEFAULT_LOSS_SCALE_PX }`, as COLMAP's robust bundle adjustment.
    pub loss: Loss,
    /// Refine each observed camera's focal length. Default: `true`.
    pub refine_focal: bool,
    /// Refine each observed camera's principal point. Default: `false` (poorly constrained).
    pub refine_principal_point: bool,
    /// Refine each observed camera's `k1` and `k2`. Default: `true`.
    pub refine_distortion: bool,
    /// Limit on Levenberg-Marquardt iterations, accepted and rejected. Default: 100.
    pub max_iterations: usize,
    /// Stop after an accepted step that lowers the cost by less than this fraction of it. Default: 1e-6.
    pub function_tolerance: f64,
    /// Stop when the gradient's max-norm falls below this fraction of its initial value. Default: 1e-10.
    pub gradient_tolerance: f64,
    /// Stop when a step's norm is below `parameter_tolerance * (|x| + parameter_tolerance)`, `x` the
    /// stacked unknowns (angle-axis, centres, free intrinsics, free points). Default: 1e-8.
    pub parameter_tolerance: f64,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            loss: Loss::Cauchy { scale_px: DEFAULT_LOSS_SCALE_PX },
            refine_focal: true,
            refine_principal_point: false,
            refine_distortion: true,
            max_iterations: DEFAULT_MAX_ITERATIONS,
            function_tolerance: DEFAULT_FUNCTION_TOLERANCE,
            gradient_tolerance: DEFAULT_GRADIENT_TOLERANCE,
            parameter_tolerance: DEFAULT_PARAMETER_TOLERANCE,
        }
    }
}

impl Options {
    /// Checks the loss scale and that the tolerances are finite and non-negative.
    pub fn validate(&self) -> Result<(), BaError> {
        self.loss.validate()?;
        for (field, value) in [
            ("options.function_tolerance", self.function_tolerance),
            ("options.gradient_tolerance", self.gradient_tolerance),
            ("options.parameter_tolerance", self.parameter_tolerance),
        ] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(BaError::InvalidValue { field: field.into(), value, reason: "tolerances must be finite and non-negative" });
            }
        }
        Ok(())
    }
}

/// Why the solve stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Termination {
    /// An accepted step lowered the cost by less than `function_tolerance` of it.
    FunctionTolerance,
    /// The gradient's max-norm fell below `gradient_tolerance` of its initial value (or to zero).
    GradientTolerance,
    /// The step became smaller than `parameter_tolerance` allows.
    ParameterTolerance,
    /// `max_iterations` were used up.
    MaxIterations,
    /// The damping grew to its limit without finding a step that lowers the cost (converged to
    /// the precision the arithmetic allows).
    DampingLimit,
    /// Nothing was free to change (every pose, point and intrinsic fixed or unobserved).
    NothingToOptimize,
}

/// What a solve did.
#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    /// Levenberg-Marquardt iterations run, accepted and rejected.
    pub iterations: usize,
    /// Iterations whose step was accepted.
    pub accepted_steps: usize,
    /// Cost before the solve: `sum rho(||r||^2)` plus the prior terms, pixels squared.
    pub initial_cost: f64,
    /// Cost after the solve.
    pub final_cost: f64,
    /// The cost before the solve and after each accepted step (`accepted_steps + 1` entries).
    pub cost_history: Vec<f64>,
    /// Root mean square reprojection error before the solve (pixels, without the loss), over the
    /// observations used.
    pub initial_rms_px: f64,
    /// Root mean square reprojection error after the solve, over the same observations.
    pub final_rms_px: f64,
    /// Why the solve stopped.
    pub termination: Termination,
    /// Unknowns in the reduced camera system (6 per free image plus the free intrinsics).
    pub camera_unknowns: usize,
    /// Unknowns eliminated by the Schur complement (3 per free, observed point).
    pub point_unknowns: usize,
    /// Observations left out because their point was not in front of the camera at the start.
    pub excluded_observations: usize,
}

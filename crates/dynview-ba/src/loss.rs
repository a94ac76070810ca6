//! Robust losses on the squared reprojection error.

use crate::error::BaError;

/// The robust loss `rho(s)` applied to each observation's squared reprojection error
/// `s = ||r||^2` (pixels squared). The conventions follow Ceres: `rho(s) ~ s` for small `s`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Loss {
    /// `rho(s) = s`: ordinary least squares.
    Squared,
    /// `rho(s) = s` for `s <= b^2`, else `2 b sqrt(s) - b^2`, with `b = scale_px`.
    Huber {
        /// The residual norm (pixels) where the loss turns from quadratic to linear.
        scale_px: f64,
    },
    /// `rho(s) = b^2 ln(1 + s / b^2)`, with `b = scale_px`.
    Cauchy {
        /// The residual norm (pixels) at which an observation's weight has halved.
        scale_px: f64,
    },
}

impl Loss {
    /// `(rho(s), rho'(s))` for the squared residual norm `s` in pixels squared.
    pub(crate) fn evaluate(&self, squared_norm_px2: f64) -> (f64, f64) {
        match *self {
            Loss::Squared => (squared_norm_px2, 1.0),
            Loss::Huber { scale_px } => {
                let scale_sq = scale_px * scale_px;
                if squared_norm_px2 <= scale_sq {
                    (squared_norm_px2, 1.0)
                } else {
                    let norm = squared_norm_px2.sqrt();
                    (2.0 * scale_px * norm - scale_sq, scale_px / norm)
                }
            }
            Loss::Cauchy { scale_px } => {
                let scale_sq = scale_px * scale_px;
                let ratio = squared_norm_px2 / scale_sq;
                (scale_sq * ratio.ln_1p(), 1.0 / (1.0 + ratio))
            }
        }
    }

    /// Checks that a robust loss has a positive, finite scale.
    pub(crate) fn validate(&self) -> Result<(), BaError> {
        let scale_px = match *self {
            Loss::Squared => return Ok(()),
            Loss::Huber { scale_px } | Loss::Cauchy { scale_px } => scale_px,
        };
        if scale_px.is_finite() && scale_px > 0.0 {
            Ok(())
        } else {
            Err(BaError::InvalidValue {
                field: "options.loss.scale_px".into(),
                value: scale_px,
                reason: "the loss scale must be positive and finite",
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn derivative_matches_central_differences_and_small_residuals_are_quadratic() {
        for loss in [Loss::Squared, Loss::Huber { scale_px: 1.5 }, Loss::Cauchy { scale_px: 2.0 }] {
            let (rho, slope) = loss.evaluate(1e-6);
            assert!((rho - 1e-6).abs() < 1e-12 && (slope - 1.0).abs() < 1e-6, "{loss:?}");
            for s in [0.1, 1.0, 2.0, 5.0, 100.0] {
                let step = 1e-6 * s;
                let numeric = (loss.evaluate(s + step).0 - loss.evaluate(s - step).0) / (2.0 * step);
                assert!((numeric - loss.evaluate(s).1).abs() < 1e-6, "{loss:?} at {s}");
            }
        }
        // Robust losses grow more slowly than the square for large residuals.
        assert!(Loss::Huber { scale_px: 1.0 }.evaluate(100.0).0 < 20.0);
        assert!(Loss::Cauchy { scale_px: 1.0 }.evaluate(100.0).0 < 5.0);
    }

    #[test]
    fn non_positive_scales_are_refused() {
        assert!(Loss::Huber { scale_px: 0.0 }.validate().is_err());
        assert!(Loss::Cauchy { scale_px: f64::NAN }.validate().is_err());
        assert!(Loss::Cauchy { scale_px: 1.0 }.validate().is_ok());
    }
}

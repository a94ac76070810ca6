//! `SIMPLE_RADIAL`: parameters `f, cx, cy, k` (COLMAP id 2), one radial term.
//!
//! For the normalized point `(x, y) = (X/Z, Y/Z)` and `r2 = x^2 + y^2`:
//! `d = 1 + k r2`, `u = f d x + cx`, `v = f d y + cy`.

use crate::model::{Model, params_array};
use crate::{CameraModel, Radial};

/// The pinhole model with one radial distortion term. Parameter order `f, cx, cy, k`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimpleRadial {
    /// Focal length, in pixels, both axes.
    pub f: f64,
    /// Principal point x, in pixels.
    pub cx: f64,
    /// Principal point y, in pixels.
    pub cy: f64,
    /// Radial distortion, `r^2` term.
    pub k: f64,
}

impl SimpleRadial {
    /// The same camera as `RADIAL` with `k2 = 0`, whose formulas it shares (`0 * r2^2` adds
    /// exactly zero, so the results are bit for bit those of `1 + k r2`).
    pub(crate) fn as_radial(&self) -> Radial {
        Radial { f: self.f, cx: self.cx, cy: self.cy, k1: self.k, k2: 0.0 }
    }
}

impl Model for SimpleRadial {
    const MODEL: CameraModel = CameraModel::SimpleRadial;

    fn from_params(params: &[f64]) -> Option<Self> {
        let [f, cx, cy, k] = params_array(params)?;
        Some(Self { f, cx, cy, k })
    }

    fn params(&self) -> Vec<f64> {
        vec![self.f, self.cx, self.cy, self.k]
    }

    fn distort(&self, normalized: [f64; 2]) -> [f64; 2] {
        self.as_radial().distort(normalized)
    }

    fn undistort(&self, distorted: [f64; 2]) -> [f64; 2] {
        self.as_radial().undistort(distorted)
    }

    fn pixel_from_normalized(&self, normalized: [f64; 2]) -> [f64; 2] {
        self.as_radial().pixel_from_normalized(normalized)
    }

    fn normalized_from_pixel(&self, pixel: [f64; 2]) -> [f64; 2] {
        self.as_radial().normalized_from_pixel(pixel)
    }
}

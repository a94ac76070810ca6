//! `SIMPLE_PINHOLE`: parameters `f, cx, cy` (COLMAP id 0), one focal length, no distortion.
//!
//! `u = f x + cx`, `v = f y + cy` for the normalized point `(x, y) = (X/Z, Y/Z)`.

use crate::model::{Model, params_array};
use crate::{CameraModel, Pinhole};

/// The pinhole model with equal focal lengths. Parameter order `f, cx, cy`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimplePinhole {
    /// Focal length, in pixels, both axes.
    pub f: f64,
    /// Principal point x, in pixels.
    pub cx: f64,
    /// Principal point y, in pixels.
    pub cy: f64,
}

impl SimplePinhole {
    /// The same camera as a [`Pinhole`] with `fx = fy = f`.
    pub fn to_pinhole(&self) -> Pinhole {
        Pinhole { fx: self.f, fy: self.f, cx: self.cx, cy: self.cy }
    }
}

impl Model for SimplePinhole {
    const MODEL: CameraModel = CameraModel::SimplePinhole;

    fn from_params(params: &[f64]) -> Option<Self> {
        let [f, cx, cy] = params_array(params)?;
        Some(Self { f, cx, cy })
    }

    fn params(&self) -> Vec<f64> {
        vec![self.f, self.cx, self.cy]
    }

    fn distort(&self, normalized: [f64; 2]) -> [f64; 2] {
        normalized
    }

    fn undistort(&self, distorted: [f64; 2]) -> [f64; 2] {
        distorted
    }

    fn pixel_from_normalized(&self, normalized: [f64; 2]) -> [f64; 2] {
        self.to_pinhole().pixel_from_normalized(normalized)
    }

    fn normalized_from_pixel(&self, pixel: [f64; 2]) -> [f64; 2] {
        self.to_pinhole().normalized_from_pixel(pixel)
    }
}

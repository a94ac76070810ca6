//! `SIMPLE_RADIAL`: parameters `f, cx, cy, k` (COLMAP id 2), one radial term.
//!
//! For the normalized point `(x, y) = (X/Z, Y/Z)` and `r2 = x^2 + y^2`:
//! `d = 1 + k r2`, `u = f d x + cx`, `v = f d y + cy`.

use crate::{CameraModel, Model, OpenCv, OpenCvDistortion, Pinhole, params_array, undistort_radial};

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
    /// The distortion factor `1 + k r2`.
    fn factor(&self, r2: f64) -> f64 {
        1.0 + self.k * r2
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
        let [x, y] = normalized;
        let d = self.factor(x * x + y * y);
        [d * x, d * y]
    }

    fn undistort(&self, distorted: [f64; 2]) -> [f64; 2] {
        if self.k == 0.0 {
            return distorted;
        }
        undistort_radial(distorted, |r2| self.factor(r2))
    }

    fn pixel_from_normalized(&self, normalized: [f64; 2]) -> [f64; 2] {
        let [x, y] = normalized;
        let scale = self.f * self.factor(x * x + y * y);
        [scale * x + self.cx, scale * y + self.cy]
    }

    fn normalized_from_pixel(&self, pixel: [f64; 2]) -> [f64; 2] {
        self.undistort([(pixel[0] - self.cx) / self.f, (pixel[1] - self.cy) / self.f])
    }

    fn to_opencv(&self) -> OpenCv {
        OpenCv {
            pinhole: Pinhole { fx: self.f, fy: self.f, cx: self.cx, cy: self.cy },
            distortion: OpenCvDistortion { k1: self.k, ..OpenCvDistortion::default() },
        }
    }
}

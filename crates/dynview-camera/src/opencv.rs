//! `OPENCV`: parameters `fx, fy, cx, cy, k1, k2, p1, p2` (COLMAP id 4), two radial and two
//! tangential terms (OpenCV's model without `k3`).
//!
//! For the normalized point `(x, y) = (X/Z, Y/Z)` and `r2 = x^2 + y^2`:
//! `radial = k1 r2 + k2 r2^2`,
//! `x' = x + x radial + 2 p1 x y + p2 (r2 + 2 x^2)`,
//! `y' = y + y radial + 2 p2 x y + p1 (r2 + 2 y^2)`,
//! `u = fx x' + cx`, `v = fy y' + cy`.

use crate::model::{Model, UNDISTORT_ITERATIONS, params_array};
use crate::{CameraModel, Pinhole, Radial, SimplePinhole, SimpleRadial};

/// OpenCV's distortion coefficients `k1, k2, p1, p2` (all zero: no distortion), acting on
/// normalized coordinates.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct OpenCvDistortion {
    /// Radial, `r^2` term.
    pub k1: f64,
    /// Radial, `r^4` term.
    pub k2: f64,
    /// Tangential p1.
    pub p1: f64,
    /// Tangential p2.
    pub p2: f64,
}

impl OpenCvDistortion {
    /// The coefficients in OpenCV's order `[k1, k2, p1, p2]`.
    pub fn to_array(self) -> [f64; 4] {
        [self.k1, self.k2, self.p1, self.p2]
    }

    /// Distortion from coefficients in OpenCV's order `[k1, k2, p1, p2]`.
    pub fn from_array([k1, k2, p1, p2]: [f64; 4]) -> Self {
        Self { k1, k2, p1, p2 }
    }

    /// True when every coefficient is zero (no distortion).
    pub fn is_zero(self) -> bool {
        self.to_array().iter().all(|&v| v == 0.0)
    }

    /// The displacement `(x' - x, y' - y)` the distortion adds to the normalized point.
    fn delta(&self, normalized: [f64; 2]) -> [f64; 2] {
        let [x, y] = normalized;
        let (xx, xy, yy) = (x * x, x * y, y * y);
        let r2 = xx + yy;
        let radial = self.k1 * r2 + self.k2 * r2 * r2;
        [x * radial + 2.0 * self.p1 * xy + self.p2 * (r2 + 2.0 * xx), y * radial + 2.0 * self.p2 * xy + self.p1 * (r2 + 2.0 * yy)]
    }

    /// Distorted normalized coordinates of the undistorted normalized point `normalized`.
    pub fn distort(&self, normalized: [f64; 2]) -> [f64; 2] {
        let delta = self.delta(normalized);
        [normalized[0] + delta[0], normalized[1] + delta[1]]
    }

    /// Undistorted normalized coordinates of `distorted`: the fixed-point iteration
    /// `p = (distorted - tangential(p)) / (1 + radial(p))` of OpenCV's `undistortPoints`.
    pub fn undistort(&self, distorted: [f64; 2]) -> [f64; 2] {
        if self.is_zero() {
            return distorted;
        }
        let mut p = distorted;
        for _ in 0..UNDISTORT_ITERATIONS {
            let [x, y] = p;
            let (xx, xy, yy) = (x * x, x * y, y * y);
            let r2 = xx + yy;
            let factor = 1.0 + self.k1 * r2 + self.k2 * r2 * r2;
            let tangential = [2.0 * self.p1 * xy + self.p2 * (r2 + 2.0 * xx), 2.0 * self.p2 * xy + self.p1 * (r2 + 2.0 * yy)];
            p = [(distorted[0] - tangential[0]) / factor, (distorted[1] - tangential[1]) / factor];
        }
        p
    }
}

/// The pinhole model with OpenCV's distortion. Parameter order `fx, fy, cx, cy, k1, k2, p1, p2`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OpenCv {
    /// Focal lengths and principal point (`fx, fy, cx, cy`).
    pub pinhole: Pinhole,
    /// Distortion (`k1, k2, p1, p2`).
    pub distortion: OpenCvDistortion,
}

impl Model for OpenCv {
    const MODEL: CameraModel = CameraModel::OpenCv;

    fn from_params(params: &[f64]) -> Option<Self> {
        let [fx, fy, cx, cy, k1, k2, p1, p2] = params_array(params)?;
        Some(Self { pinhole: Pinhole { fx, fy, cx, cy }, distortion: OpenCvDistortion { k1, k2, p1, p2 } })
    }

    fn params(&self) -> Vec<f64> {
        let mut params = self.pinhole.params();
        params.extend(self.distortion.to_array());
        params
    }

    fn distort(&self, normalized: [f64; 2]) -> [f64; 2] {
        self.distortion.distort(normalized)
    }

    fn undistort(&self, distorted: [f64; 2]) -> [f64; 2] {
        self.distortion.undistort(distorted)
    }

    fn pixel_from_normalized(&self, normalized: [f64; 2]) -> [f64; 2] {
        self.pinhole.pixel_from_normalized(self.distort(normalized))
    }

    fn normalized_from_pixel(&self, pixel: [f64; 2]) -> [f64; 2] {
        self.undistort(self.pinhole.normalized_from_pixel(pixel))
    }
}

// Every model is a special case of OpenCV's; the conversions live here, beside the type they
// make, so that the models themselves need not know it.

impl OpenCv {
    /// The model itself (every camera model has `to_opencv`).
    pub fn to_opencv(&self) -> OpenCv {
        *self
    }
}

impl Pinhole {
    /// The same camera as an [`OpenCv`] model, without distortion.
    pub fn to_opencv(&self) -> OpenCv {
        OpenCv { pinhole: *self, distortion: OpenCvDistortion::default() }
    }
}

impl SimplePinhole {
    /// The same camera as an [`OpenCv`] model, without distortion.
    pub fn to_opencv(&self) -> OpenCv {
        self.to_pinhole().to_opencv()
    }
}

impl Radial {
    /// The same camera as an [`OpenCv`] model (its `k1`, `k2`; no tangential terms).
    pub fn to_opencv(&self) -> OpenCv {
        OpenCv {
            pinhole: Pinhole { fx: self.f, fy: self.f, cx: self.cx, cy: self.cy },
            distortion: OpenCvDistortion { k1: self.k1, k2: self.k2, ..OpenCvDistortion::default() },
        }
    }
}

impl SimpleRadial {
    /// The same camera as an [`OpenCv`] model (its `k` as `k1`).
    pub fn to_opencv(&self) -> OpenCv {
        self.as_radial().to_opencv()
    }
}

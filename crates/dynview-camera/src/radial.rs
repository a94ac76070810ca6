//! `RADIAL`: parameters `f, cx, cy, k1, k2` (COLMAP id 3), two radial terms. This is the model
//! `dynview-ba` optimises, so it also gives the Jacobians of the pixel with respect to the
//! normalized point and to the parameters.
//!
//! For the normalized point `(x, y) = (X/Z, Y/Z)` and `r2 = x^2 + y^2`:
//! `d = 1 + k1 r2 + k2 r2^2`, `u = f d x + cx`, `v = f d y + cy`.

use crate::model::{Model, params_array, undistort_radial};
use crate::{CameraModel, Pinhole};

/// Number of parameters of the model, `f, cx, cy, k1, k2`.
pub const PARAM_COUNT: usize = 5;

/// The pinhole model with two radial distortion terms. Parameter order `f, cx, cy, k1, k2`.
///
/// With the feature `serde` it serializes as `{"focal_px", "cx_px", "cy_px", "k1", "k2"}`
/// (the names `dynview-sfm`'s work files and reports have always used).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Radial {
    /// Focal length, in pixels, both axes.
    #[cfg_attr(feature = "serde", serde(rename = "focal_px"))]
    pub f: f64,
    /// Principal point x, in pixels.
    #[cfg_attr(feature = "serde", serde(rename = "cx_px"))]
    pub cx: f64,
    /// Principal point y, in pixels.
    #[cfg_attr(feature = "serde", serde(rename = "cy_px"))]
    pub cy: f64,
    /// Radial distortion, `r^2` term.
    pub k1: f64,
    /// Radial distortion, `r^4` term.
    pub k2: f64,
}

impl Radial {
    /// A camera with its principal point at the centre of a `width x height` image (pixel
    /// centres at integers) and no distortion.
    pub fn centred(f: f64, width: u32, height: u32) -> Self {
        Self { f, cx: 0.5 * (f64::from(width) - 1.0), cy: 0.5 * (f64::from(height) - 1.0), k1: 0.0, k2: 0.0 }
    }

    /// A pinhole calibration as this model, without distortion (for undistorted frames). The
    /// model has one focal length: a calibration's `fx` and `fy` are averaged (they differ by
    /// a fraction of a pixel in real calibrations).
    pub fn from_pinhole(pinhole: &Pinhole) -> Self {
        Self { f: 0.5 * (pinhole.fx + pinhole.fy), cx: pinhole.cx, cy: pinhole.cy, k1: 0.0, k2: 0.0 }
    }

    /// The distortion factor `d = 1 + k1 r2 + k2 r2^2`.
    #[inline]
    fn factor(&self, r2: f64) -> f64 {
        1.0 + self.k1 * r2 + self.k2 * r2 * r2
    }

    /// `d pixel / d normalized` at the normalized point `normalized`: row `i` is pixel
    /// coordinate `i` (`u`, `v`), column `j` normalized coordinate `j` (`x`, `y`).
    #[inline]
    pub fn d_pixel_d_normalized(&self, normalized: [f64; 2]) -> [[f64; 2]; 2] {
        let [x, y] = normalized;
        let r2 = x * x + y * y;
        let d = self.factor(r2);
        let f = self.f;
        // d d / d r2.
        let d_factor = self.k1 + 2.0 * self.k2 * r2;
        let cross = f * 2.0 * x * y * d_factor;
        [[f * (d + 2.0 * x * x * d_factor), cross], [cross, f * (d + 2.0 * y * y * d_factor)]]
    }

    /// `d pixel / d params` at the normalized point `normalized`: row `i` is pixel coordinate
    /// `i` (`u`, `v`), columns in parameter order `f, cx, cy, k1, k2`.
    #[inline]
    pub fn d_pixel_d_params(&self, normalized: [f64; 2]) -> [[f64; PARAM_COUNT]; 2] {
        let [x, y] = normalized;
        let r2 = x * x + y * y;
        let r4 = r2 * r2;
        let d = self.factor(r2);
        let f = self.f;
        [[d * x, 1.0, 0.0, f * r2 * x, f * r4 * x], [d * y, 0.0, 1.0, f * r2 * y, f * r4 * y]]
    }
}

impl Model for Radial {
    const MODEL: CameraModel = CameraModel::Radial;

    fn from_params(params: &[f64]) -> Option<Self> {
        let [f, cx, cy, k1, k2] = params_array(params)?;
        Some(Self { f, cx, cy, k1, k2 })
    }

    fn params(&self) -> Vec<f64> {
        vec![self.f, self.cx, self.cy, self.k1, self.k2]
    }

    fn distort(&self, normalized: [f64; 2]) -> [f64; 2] {
        let [x, y] = normalized;
        let d = self.factor(x * x + y * y);
        [d * x, d * y]
    }

    fn undistort(&self, distorted: [f64; 2]) -> [f64; 2] {
        if self.k1 == 0.0 && self.k2 == 0.0 {
            return distorted;
        }
        undistort_radial(distorted, |r2| self.factor(r2))
    }

    /// `(f d) x + cx`: the focal length and distortion factor are multiplied first (the order
    /// bundle adjustment has always used, kept so that its results do not move).
    #[inline]
    fn pixel_from_normalized(&self, normalized: [f64; 2]) -> [f64; 2] {
        let [x, y] = normalized;
        let scale = self.f * self.factor(x * x + y * y);
        [scale * x + self.cx, scale * y + self.cy]
    }

    fn normalized_from_pixel(&self, pixel: [f64; 2]) -> [f64; 2] {
        self.undistort([(pixel[0] - self.cx) / self.f, (pixel[1] - self.cy) / self.f])
    }
}

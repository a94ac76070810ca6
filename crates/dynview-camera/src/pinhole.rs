//! `PINHOLE`: parameters `fx, fy, cx, cy` (COLMAP id 1), no distortion.
//!
//! `u = fx x + cx`, `v = fy y + cy` for the normalized point `(x, y) = (X/Z, Y/Z)`.

use crate::CameraModel;
use crate::model::{Model, params_array};

/// The pinhole model in pixels. Parameter order `fx, fy, cx, cy`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pinhole {
    /// Focal length along x, in pixels.
    pub fx: f64,
    /// Focal length along y, in pixels.
    pub fy: f64,
    /// Principal point x, in pixels.
    pub cx: f64,
    /// Principal point y, in pixels.
    pub cy: f64,
}

impl Pinhole {
    /// The pixel of a camera-frame point `[X, Y, Z]`, or `None` when `Z <= 0` (at or behind
    /// the camera plane).
    #[inline]
    pub fn pixel_from_camera(&self, point_camera: [f64; 3]) -> Option<[f64; 2]> {
        let [x, y, z] = point_camera;
        if z <= 0.0 {
            return None;
        }
        let inv_z = 1.0 / z;
        Some([self.fx * x * inv_z + self.cx, self.fy * y * inv_z + self.cy])
    }

    /// The camera-frame point of a pixel at z-depth `depth` (the inverse of
    /// [`Pinhole::pixel_from_camera`]).
    #[inline]
    pub fn camera_from_pixel(&self, pixel: [f64; 2], depth: f64) -> [f64; 3] {
        let [x, y] = self.normalized_from_pixel(pixel);
        [x * depth, y * depth, depth]
    }
}

impl Model for Pinhole {
    const MODEL: CameraModel = CameraModel::Pinhole;

    fn from_params(params: &[f64]) -> Option<Self> {
        let [fx, fy, cx, cy] = params_array(params)?;
        Some(Self { fx, fy, cx, cy })
    }

    fn params(&self) -> Vec<f64> {
        vec![self.fx, self.fy, self.cx, self.cy]
    }

    #[inline]
    fn distort(&self, normalized: [f64; 2]) -> [f64; 2] {
        normalized
    }

    #[inline]
    fn undistort(&self, distorted: [f64; 2]) -> [f64; 2] {
        distorted
    }

    #[inline]
    fn pixel_from_normalized(&self, normalized: [f64; 2]) -> [f64; 2] {
        [self.fx * normalized[0] + self.cx, self.fy * normalized[1] + self.cy]
    }

    #[inline]
    fn normalized_from_pixel(&self, pixel: [f64; 2]) -> [f64; 2] {
        [(pixel[0] - self.cx) / self.fx, (pixel[1] - self.cy) / self.fy]
    }
}

//! The [`Model`] trait every camera model implements (its COLMAP identity, parameters and the
//! mapping between normalized points and pixels), and the helpers the models share.

use crate::CameraModel;

/// Fixed-point iterations of the undistortion of the radial and OpenCV models. The iteration
/// contracts by about `|d distortion / d r| r`, far below one for real lenses, so 20 iterations
/// reach double precision.
pub const UNDISTORT_ITERATIONS: usize = 20;

/// One camera model: its COLMAP identity, its parameters in COLMAP's order and its mapping
/// between normalized image points and pixels.
pub trait Model: Copy + Sized {
    /// The COLMAP model this type implements.
    const MODEL: CameraModel;

    /// The model from its parameters in COLMAP's order; `None` unless `params` holds exactly
    /// [`CameraModel::param_count`] values.
    fn from_params(params: &[f64]) -> Option<Self>;

    /// The parameters in COLMAP's order.
    fn params(&self) -> Vec<f64>;

    /// Distorted normalized coordinates of the undistorted normalized point `normalized`.
    fn distort(&self, normalized: [f64; 2]) -> [f64; 2];

    /// Undistorted normalized coordinates of the distorted normalized point `distorted`
    /// (the inverse of [`Model::distort`]).
    fn undistort(&self, distorted: [f64; 2]) -> [f64; 2];

    /// The pixel of an undistorted normalized point: distortion, then focal lengths and
    /// principal point.
    fn pixel_from_normalized(&self, normalized: [f64; 2]) -> [f64; 2];

    /// The undistorted normalized point of a pixel (the inverse of
    /// [`Model::pixel_from_normalized`]).
    fn normalized_from_pixel(&self, pixel: [f64; 2]) -> [f64; 2];
}

/// `params` as an array of `N` values, or `None` when its length is not `N`.
pub(crate) fn params_array<const N: usize>(params: &[f64]) -> Option<[f64; N]> {
    params.try_into().ok()
}

/// `distorted / factor(p)` iterated from `p = distorted`: the inverse of a purely radial
/// distortion `p -> factor(p) p`.
pub(crate) fn undistort_radial(distorted: [f64; 2], factor: impl Fn(f64) -> f64) -> [f64; 2] {
    let mut p = distorted;
    for _ in 0..UNDISTORT_ITERATIONS {
        let r2 = p[0] * p[0] + p[1] * p[1];
        let d = factor(r2);
        p = [distorted[0] / d, distorted[1] / d];
    }
    p
}

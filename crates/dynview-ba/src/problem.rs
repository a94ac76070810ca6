//! The bundle adjustment problem: cameras, image poses, points, observations and priors, and
//! the validation that runs before any solve.
//!
//! A camera is COLMAP's `RADIAL` model ([`Radial`], which also computes the projection's
//! Jacobians), pixel centres at integer coordinates: with `(X, Y, Z)` the point in the camera
//! frame, `x_n = X/Z`, `y_n = Y/Z`, `r2 = x_n^2 + y_n^2`, `d = 1 + k1 r2 + k2 r2^2`,
//! `u = f d x_n + cx`, `v = f d y_n + cy`. Its intrinsics are listed, wherever they are, in
//! the order `[f, cx, cy, k1, k2]`. An image's pose is a [`Rigid3`] `camera_from_world`.

use dynview_camera::{Radial, Rigid3};

use crate::error::BaError;

/// One measured image position of one point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Observation {
    /// Index into [`Problem::images`].
    pub image: usize,
    /// Index into [`Problem::points_world`].
    pub point: usize,
    /// Measured pixel position `[u, v]`.
    pub pixel: [f64; 2],
}

/// The paper's smoothness prior between two images of one camera (Eqs. 1-2): adds
/// `weight_center * ||C_a - C_b||^2` (camera centres) and
/// `weight_rotation * ||A_a - A_b||^2` (angle-axis vectors of the `camera_from_world`
/// rotations) to the cost.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SmoothnessPrior {
    /// Index of the first image.
    pub image_a: usize,
    /// Index of the second image.
    pub image_b: usize,
    /// Weight of the centre term, in squared pixels per squared world unit; non-negative.
    pub weight_center: f64,
    /// Weight of the rotation term, in squared pixels per squared radian; non-negative.
    pub weight_rotation: f64,
}

/// Which intrinsics of one camera stay as they are, whatever [`crate::Options`] refines: those
/// the user gave (a calibration, or a focal length alone).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct HeldIntrinsics {
    /// Keep the focal length `f`.
    pub focal: bool,
    /// Keep the principal point `cx`, `cy`.
    pub principal_point: bool,
    /// Keep `k1` and `k2`.
    pub distortion: bool,
}

impl HeldIntrinsics {
    /// Every intrinsic held (a full calibration).
    pub const ALL: Self = Self { focal: true, principal_point: true, distortion: true };

    /// Whether the intrinsic with index `index` in `[f, cx, cy, k1, k2]` is held.
    pub fn holds(&self, index: usize) -> bool {
        match index {
            0 => self.focal,
            1 | 2 => self.principal_point,
            _ => self.distortion,
        }
    }
}

/// A bundle adjustment problem; [`crate::solve`] updates it in place.
///
/// The cost is `sum_obs rho(||pixel(obs) - observation.pixel||^2) + sum_priors (...)` with
/// `rho` from [`crate::Loss`] and the prior terms of [`SmoothnessPrior`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Problem {
    /// The physical cameras' intrinsics.
    pub cameras: Vec<Radial>,
    /// One pose per image, `camera_from_world`. A solve writes back the poses it changed; a
    /// fixed or unchanged image keeps its pose exactly.
    pub images: Vec<Rigid3>,
    /// For each image, the index of its camera in [`Problem::cameras`].
    pub image_camera: Vec<usize>,
    /// For each image, whether its pose is held constant.
    pub image_fixed: Vec<bool>,
    /// The 3D points in world coordinates.
    pub points_world: Vec<[f64; 3]>,
    /// For each point, whether it is held constant.
    pub point_fixed: Vec<bool>,
    /// The measurements.
    pub observations: Vec<Observation>,
    /// Smoothness priors between image poses.
    pub priors: Vec<SmoothnessPrior>,
    /// Per camera, the intrinsics held as they are; empty: none held (every camera refines
    /// what the options ask).
    pub held_intrinsics: Vec<HeldIntrinsics>,
}

impl Problem {
    /// What camera `camera` holds (nothing when `held_intrinsics` is empty).
    pub fn held(&self, camera: usize) -> HeldIntrinsics {
        self.held_intrinsics.get(camera).copied().unwrap_or_default()
    }
}

impl Problem {
    /// Checks lengths, indices and values; every error names the offending field.
    pub fn validate(&self) -> Result<(), BaError> {
        check_length("image_camera", self.image_camera.len(), "images", self.images.len())?;
        check_length("image_fixed", self.image_fixed.len(), "images", self.images.len())?;
        check_length("point_fixed", self.point_fixed.len(), "points_world", self.points_world.len())?;
        if !self.held_intrinsics.is_empty() {
            check_length("held_intrinsics", self.held_intrinsics.len(), "cameras", self.cameras.len())?;
        }
        for (index, camera) in self.cameras.iter().enumerate() {
            let values = [camera.f, camera.cx, camera.cy, camera.k1, camera.k2];
            for (name, value) in ["f", "cx", "cy", "k1", "k2"].iter().zip(values) {
                check_finite(|| format!("cameras[{index}].{name}"), value)?;
            }
            if camera.f <= 0.0 {
                return Err(BaError::InvalidValue {
                    field: format!("cameras[{index}].f"),
                    value: camera.f,
                    reason: "the focal length must be positive",
                });
            }
        }
        for (index, pose) in self.images.iter().enumerate() {
            for (row, values) in pose.rotation_rows().iter().enumerate() {
                for (column, &value) in values.iter().enumerate() {
                    check_finite(|| format!("images[{index}].rotation[{row}][{column}]"), value)?;
                }
            }
            for (axis, value) in pose.translation.to_array().into_iter().enumerate() {
                check_finite(|| format!("images[{index}].translation[{axis}]"), value)?;
            }
        }
        for (index, &camera) in self.image_camera.iter().enumerate() {
            check_index(|| format!("image_camera[{index}]"), camera, self.cameras.len(), "cameras")?;
        }
        for (index, point) in self.points_world.iter().enumerate() {
            for (axis, &value) in point.iter().enumerate() {
                check_finite(|| format!("points_world[{index}][{axis}]"), value)?;
            }
        }
        for (index, observation) in self.observations.iter().enumerate() {
            check_index(|| format!("observations[{index}].image"), observation.image, self.images.len(), "images")?;
            check_index(|| format!("observations[{index}].point"), observation.point, self.points_world.len(), "points")?;
            for (axis, &value) in observation.pixel.iter().enumerate() {
                check_finite(|| format!("observations[{index}].pixel[{axis}]"), value)?;
            }
        }
        for (index, prior) in self.priors.iter().enumerate() {
            check_index(|| format!("priors[{index}].image_a"), prior.image_a, self.images.len(), "images")?;
            check_index(|| format!("priors[{index}].image_b"), prior.image_b, self.images.len(), "images")?;
            for (name, value) in [("weight_center", prior.weight_center), ("weight_rotation", prior.weight_rotation)] {
                check_finite(|| format!("priors[{index}].{name}"), value)?;
                if value < 0.0 {
                    return Err(BaError::InvalidValue {
                        field: format!("priors[{index}].{name}"),
                        value,
                        reason: "prior weights must be non-negative",
                    });
                }
            }
        }
        Ok(())
    }
}

fn check_length(field: &'static str, actual: usize, reference: &'static str, expected: usize) -> Result<(), BaError> {
    if actual == expected { Ok(()) } else { Err(BaError::LengthMismatch { field, actual, reference, expected }) }
}

fn check_finite(field: impl FnOnce() -> String, value: f64) -> Result<(), BaError> {
    if value.is_finite() { Ok(()) } else { Err(BaError::NonFinite { field: field(), value }) }
}

fn check_index(field: impl FnOnce() -> String, index: usize, count: usize, items: &'static str) -> Result<(), BaError> {
    if index < count { Ok(()) } else { Err(BaError::IndexOutOfRange { field: field(), index, count, items }) }
}

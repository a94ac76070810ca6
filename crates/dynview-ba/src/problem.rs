//! The bundle adjustment problem: cameras, image poses, points, observations and priors, and
//! the validation that runs before any solve.

use crate::error::BaError;

/// Intrinsics of one physical camera, shared by all its images: COLMAP's `RADIAL` model
/// ([`dynview_camera::Radial`], which computes the projection and its Jacobians), pixel centres
/// at integer coordinates.
///
/// With `(X, Y, Z)` the point in the camera frame: `x_n = X/Z`, `y_n = Y/Z`,
/// `r2 = x_n^2 + y_n^2`, `d = 1 + k1 r2 + k2 r2^2`, `u = f d x_n + cx`, `v = f d y_n + cy`.
/// Parameter order wherever the intrinsics are listed: `[focal_px, cx_px, cy_px, k1, k2]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraIntrinsics {
    /// Focal length in pixels (same for both axes); must be positive.
    pub focal_px: f64,
    /// Principal point, horizontal pixel coordinate.
    pub cx_px: f64,
    /// Principal point, vertical pixel coordinate.
    pub cy_px: f64,
    /// First radial distortion coefficient (multiplies `r2`).
    pub k1: f64,
    /// Second radial distortion coefficient (multiplies `r2^2`).
    pub k2: f64,
}

impl From<CameraIntrinsics> for dynview_camera::Radial {
    fn from(k: CameraIntrinsics) -> Self {
        Self { f: k.focal_px, cx: k.cx_px, cy: k.cy_px, k1: k.k1, k2: k.k2 }
    }
}

impl From<dynview_camera::Radial> for CameraIntrinsics {
    fn from(k: dynview_camera::Radial) -> Self {
        Self { focal_px: k.f, cx_px: k.cx, cy_px: k.cy, k1: k.k1, k2: k.k2 }
    }
}

/// One image's pose: the camera_from_world rotation as an angle-axis vector (radians) and the
/// camera centre in the world: `X_cam = R(angle_axis) * (X_world - center_world)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImagePose {
    /// camera_from_world rotation as an angle-axis vector: direction is the axis, norm the angle in radians.
    pub angle_axis: [f64; 3],
    /// Camera centre in world coordinates.
    pub center_world: [f64; 3],
}

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
/// `weight_rotation * ||A_a - A_b||^2` (angle-axis vectors) to the cost.
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
    /// Keep `focal_px`.
    pub focal: bool,
    /// Keep `cx_px` and `cy_px`.
    pub principal_point: bool,
    /// Keep `k1` and `k2`.
    pub distortion: bool,
}

impl HeldIntrinsics {
    /// Every intrinsic held (a full calibration).
    pub const ALL: Self = Self { focal: true, principal_point: true, distortion: true };

    /// Whether the intrinsic with index `index` in `[focal_px, cx_px, cy_px, k1, k2]` is held.
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
    /// The physical cameras.
    pub cameras: Vec<CameraIntrinsics>,
    /// One pose per image.
    pub images: Vec<ImagePose>,
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
            let values = [camera.focal_px, camera.cx_px, camera.cy_px, camera.k1, camera.k2];
            for (name, value) in ["focal_px", "cx_px", "cy_px", "k1", "k2"].iter().zip(values) {
                check_finite(|| format!("cameras[{index}].{name}"), value)?;
            }
            if camera.focal_px <= 0.0 {
                return Err(BaError::InvalidValue {
                    field: format!("cameras[{index}].focal_px"),
                    value: camera.focal_px,
                    reason: "the focal length must be positive",
                });
            }
        }
        for (index, pose) in self.images.iter().enumerate() {
            for axis in 0..3 {
                check_finite(|| format!("images[{index}].angle_axis[{axis}]"), pose.angle_axis[axis])?;
                check_finite(|| format!("images[{index}].center_world[{axis}]"), pose.center_world[axis])?;
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

//! dynview's cameras: the pinhole model and the COLMAP distortion models dynview reads and
//! writes, one model per file with its parameter order documented, as COLMAP's
//! `src/colmap/sensor/models.h` does; and the one pose type every crate uses, [`Rigid3`]
//! (`camera_from_world` and the like, glam `f64`), with its [`rotation`] parameterisations.
//!
//! | [`CameraModel`] | COLMAP id | parameters | type |
//! |---|---|---|---|
//! | `SIMPLE_PINHOLE` | 0 | `f, cx, cy` | [`SimplePinhole`] |
//! | `PINHOLE` | 1 | `fx, fy, cx, cy` | [`Pinhole`] |
//! | `SIMPLE_RADIAL` | 2 | `f, cx, cy, k` | [`SimpleRadial`] |
//! | `RADIAL` | 3 | `f, cx, cy, k1, k2` | [`Radial`] (what `dynview-ba` optimises) |
//! | `OPENCV` | 4 | `fx, fy, cx, cy, k1, k2, p1, p2` | [`OpenCv`] |
//!
//! Every model maps a *normalized* image point `(x, y) = (X/Z, Y/Z)` of a camera-frame point
//! `(X, Y, Z)` to a pixel: [`Model::distort`] applies the lens distortion to normalized
//! coordinates, [`Model::pixel_from_normalized`] distorts and applies the focal lengths and
//! principal point; [`Model::undistort`] and [`Model::normalized_from_pixel`] invert them (by
//! fixed-point iteration where the distortion has no closed-form inverse).
//!
//! The models do not fix a pixel convention: the principal point is in whatever convention the
//! caller uses (dynview puts pixel centres at integers, COLMAP at `+0.5`; `dynview-interchange`'s
//! COLMAP conversions shift by half a pixel). [`Camera`] holds any model, built from COLMAP's
//! `(model, params)` pair; [`pixel_from_normalized`] projects with such a pair.
//!
//! ```
//! use dynview_camera::{CameraModel, Model, Radial, pixel_from_normalized};
//!
//! let radial = Radial { f: 500.0, cx: 320.0, cy: 240.0, k1: -0.1, k2: 0.01 };
//! let pixel = radial.pixel_from_normalized([0.2, -0.1]);
//! let back = radial.normalized_from_pixel(pixel);
//! assert!((back[0] - 0.2).abs() < 1e-12 && (back[1] + 0.1).abs() < 1e-12);
//! let same = pixel_from_normalized(CameraModel::Radial, &radial.params(), [0.2, -0.1]).unwrap();
//! assert!((same[0] - pixel[0]).abs() < 1e-9 && (same[1] - pixel[1]).abs() < 1e-9);
//! ```
//!
//! Depends on glam alone (pure Rust; builds for `wasm32`). Optional features:
//! - `nalgebra`: the nalgebra forms of [`Rigid3`] and [`Radial`] that `dynview-sfm` and
//!   `dynview-ba` compute with (rotation matrix, camera centre, angle-axis vector, pixels as
//!   vectors, [`PoseMatrices`]); every conversion between the two libraries is there;
//! - `serde`: `Serialize` and `Deserialize` for [`Radial`] and [`Rigid3`].

mod any;
mod model;
mod model_id;
#[cfg(feature = "nalgebra")]
mod nalgebra_forms;
pub mod opencv;
pub mod pinhole;
pub mod radial;
mod rigid;
pub mod rotation;
pub mod simple_pinhole;
pub mod simple_radial;

pub use any::{Camera, normalized_from_pixel, pixel_from_normalized};
pub use model::{Model, UNDISTORT_ITERATIONS};
pub use model_id::CameraModel;
#[cfg(feature = "nalgebra")]
pub use nalgebra_forms::{PoseMatrices, QUATERNION_ANGLE_RAD};
pub use opencv::{OpenCv, OpenCvDistortion};
pub use pinhole::Pinhole;
pub use radial::Radial;
pub use rigid::Rigid3;
pub use simple_pinhole::SimplePinhole;
pub use simple_radial::SimpleRadial;

#[cfg(test)]
mod tests;

//! Sparse bundle adjustment for dynview's structure-from-motion pipeline, in pure Rust.
//!
//! [`solve`] refines image poses ([`dynview_camera::Rigid3`], `camera_from_world`), 3D points
//! and per-camera intrinsics ([`dynview_camera::Radial`]: COLMAP's `RADIAL`, a pinhole with
//! radial distortion `k1`, `k2`) by Levenberg-Marquardt on the reprojection error, optionally
//! robustified ([`Loss`]) and with the paper's pose smoothness priors ([`SmoothnessPrior`],
//! Eqs. 1-2). The points are eliminated by the Schur complement, and the reduced camera system
//! is factorised by a block-sparse Cholesky with a minimum-degree ordering, so keyframe problems
//! with hundreds of images and ~100k points stay fast; with every point fixed the same code
//! refines poses alone (frame-to-frame pose refinement).
//!
//! Conventions: the optimiser's unknowns of a pose are the angle-axis vector of its rotation and
//! the camera centre, `X_cam = R(angle_axis) * (X_world - center_world)` (converted from and to
//! the problem's `Rigid3` at the start and end of a solve); pixel centres at integer
//! coordinates. All Jacobians are analytic and exact (tested against central differences).
//!
//! ```
//! use dynview_ba::{Observation, Options, Problem, solve, pixel_from_world};
//! use dynview_camera::{Radial, Rigid3};
//! use nalgebra::Vector3;
//!
//! let camera = Radial { f: 500.0, cx: 320.0, cy: 240.0, k1: 0.0, k2: 0.0 };
//! let points_world = vec![[0.0, 0.0, 5.0], [1.0, 0.5, 6.0], [-1.0, 0.3, 4.0], [0.5, -1.0, 5.5]];
//! let true_pose = Rigid3::IDENTITY;
//! let observations: Vec<Observation> = points_world
//!     .iter()
//!     .enumerate()
//!     .map(|(point, p)| Observation { image: 0, point, pixel: pixel_from_world(&camera, &true_pose, p).unwrap() })
//!     .collect();
//! let mut problem = Problem {
//!     cameras: vec![camera],
//!     images: vec![Rigid3::from_angle_axis_center(Vector3::new(0.01, -0.02, 0.0), Vector3::new(0.05, 0.0, -0.1))],
//!     image_camera: vec![0],
//!     image_fixed: vec![false],
//!     point_fixed: vec![true; points_world.len()],
//!     points_world,
//!     observations,
//!     priors: vec![],
//!     held_intrinsics: vec![],
//! };
//! let options = Options { refine_focal: false, refine_distortion: false, ..Options::default() };
//! let report = solve(&mut problem, &options).unwrap();
//! assert!(report.final_rms_px < 1e-6);
//! ```

mod angle_axis;
mod error;
mod loss;
mod options;
mod par;
mod pose;
mod problem;
mod projection;
mod solver;

pub use error::BaError;
pub use loss::Loss;
pub use options::{
    DEFAULT_FUNCTION_TOLERANCE, DEFAULT_GRADIENT_TOLERANCE, DEFAULT_LOSS_SCALE_PX, DEFAULT_MAX_ITERATIONS, DEFAULT_PARAMETER_TOLERANCE,
    Options, Report, Termination,
};
pub use problem::{HeldIntrinsics, Observation, Problem, SmoothnessPrior};
pub use projection::{pixel_from_world, reprojection_errors_px};
pub use solver::{IntrinsicsStd, intrinsics_std, solve};

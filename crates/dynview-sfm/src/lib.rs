//! dynview's preprocessing (`dynview prep`): a scene package from raw videos.
//!
//! [`run`] takes a folder with one video (or one image folder) per camera and writes a scene
//! package. The modules are grouped by role, as COLMAP's sources are, each folder using only
//! the ones above it in this list:
//! - [`error`] and [`work`]: the errors, and the work folder where each stage keeps its result
//!   so that a re-run skips what is finished;
//! - [`input`]: the cameras and their frames (videos decoded by OpenCV), and a calibration
//!   the user gives;
//! - [`estimators`]: two-view relative poses, PnP, focal lengths by self-calibration,
//!   triangulation and reprojection errors;
//! - [`features`]: SIFT, exhaustive matching with the ratio test and cross-check and MAGSAC++
//!   verification, matching guided by known poses, multi-view tracks;
//! - [`mapping`]: the keyframe reconstruction (incremental, with bundle adjustment by
//!   `dynview-ba`; cameras that stand still pooled), the frame-to-frame refinement of every
//!   other frame with the paper's smoothness priors, the adjustment over sampled time steps,
//!   and each time step's points triangulated across cameras (METHOD.md step 3);
//! - [`dense`]: PatchMatch densification of a time step's points (step 4), and the static
//!   points accumulated across time;
//! - [`pipeline`]: the driver: the stages in order ([`run`]), the per-timestep stage, and the
//!   package export of one run or of several range runs (`dynview merge`).
//!
//! Poses are `dynview_camera::Rigid3` (`camera_from_world`), intrinsics
//! `dynview_camera::Radial` (COLMAP's `RADIAL`, pixel centres at integers). Only this crate
//! (and the CLI) depend on OpenCV.

pub mod dense;
pub mod error;
pub mod estimators;
pub mod features;
pub mod input;
pub mod mapping;
pub mod pipeline;
pub mod work;

pub use error::{SfmError, SfmResult};
pub use pipeline::options::{PrepOptions, PrepReport, Stage};
pub use pipeline::prep::run;

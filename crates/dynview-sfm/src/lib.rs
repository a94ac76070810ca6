//! dynview's preprocessing (`dynview prep`): a scene package from raw videos.
//!
//! [`pipeline::run`] takes a folder with one video (or one image folder) per camera and
//! writes a scene package:
//! 1. [`input`]: cameras and frames (videos decoded by OpenCV);
//! 2. [`keyframes`]: SIFT ([`features`]) on every `kappa`-th frame, exhaustive matching with
//!    the ratio test and cross-check and MAGSAC++ verification ([`matching`]), focal lengths by
//!    self-calibration ([`focal`]), incremental reconstruction with bundle adjustment
//!    ([`incremental`], solved by `dynview-ba`);
//! 3. [`refine`]: every other frame matched only with its neighbour in time, posed with the
//!    keyframes fixed and the paper's smoothness priors;
//! 4. [`timesteps`]: per time step, the frames matched across cameras only and triangulated with
//!    the poses fixed ([`points`], METHOD.md step 3), PatchMatch stereo grows those points into
//!    a denser cloud ([`densify`], step 4), frames reduced to the working size;
//! 5. [`static_cloud`]: static points accumulated across time, lent to the steps whose frames
//!    agree with them;
//! 6. [`export`]: the scene package from the prepared steps of one run or of several range
//!    runs (`dynview merge`).
//!
//! Each stage's result is kept in the output's work folder ([`work`]), so a re-run skips what
//! is finished. Only this crate (and the CLI) depend on OpenCV.

pub mod calibration;
pub mod densify;
pub mod error;
pub mod export;
pub mod features;
pub mod focal;
pub mod geometry;
pub mod guided;
pub mod incremental;
pub mod input;
pub mod keyframes;
pub mod matching;
pub mod pipeline;
pub mod pnp;
pub mod points;
pub mod refine;
mod relative;
pub mod static_cloud;
pub mod step_adjust;
pub mod still;
pub mod timesteps;
pub mod tracks;
pub mod work;

pub use error::{SfmError, SfmResult};
pub use pipeline::{PrepOptions, PrepReport, Stage, run};

//! dynview's preprocessing, part 1: camera poses from raw videos.
//!
//! [`pipeline::run`] takes a folder with one video (or one image folder) per camera and
//! writes every frame's pose:
//! 1. [`input`]: cameras and frames (videos decoded by OpenCV);
//! 2. [`keyframes`]: SIFT ([`features`]) on every `kappa`-th frame, exhaustive matching with
//!    the ratio test and cross-check and MAGSAC++ verification ([`matching`]), focal lengths by
//!    self-calibration ([`focal`]), incremental reconstruction with bundle adjustment
//!    ([`incremental`], solved by `dynview-ba`);
//! 3. [`refine`]: every other frame matched only with its neighbour in time, posed with the
//!    keyframes fixed and the paper's smoothness priors;
//! 4. [`points`]: per time step, the frames matched across cameras only and triangulated with
//!    the poses fixed (the library part of METHOD.md step 3; not yet run by `prep`);
//! 5. [`densify`]: PatchMatch stereo grows those points into a denser cloud (METHOD.md step 4;
//!    library only).
//!
//! Each stage's result is kept in the output's work folder ([`work`]), so a re-run skips what
//! is finished. Only this crate (and the CLI) depend on OpenCV.

pub mod calibration;
pub mod densify;
pub mod error;
pub mod features;
pub mod focal;
pub mod geometry;
pub mod incremental;
pub mod input;
pub mod keyframes;
pub mod matching;
pub mod pipeline;
pub mod pnp;
pub mod points;
pub mod refine;
pub mod tracks;
pub mod work;

pub use error::{SfmError, SfmResult};
pub use pipeline::{PrepOptions, PrepReport, Stage, run};

/// Progress of a run: stage name, items done, items in the stage.
pub type Progress<'a> = &'a (dyn Fn(&str, u64, u64) + Sync);

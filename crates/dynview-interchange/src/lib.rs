//! dynview's interchange formats: how camera poses, paths and clouds come in from other tools
//! and go out to them. Nothing here is needed to render; the renderer and the scene package
//! live in `dynview-core`, which this crate builds on.
//!
//! - [`colmap`]: COLMAP sparse models, text and binary;
//! - [`poses`]: `poses.json`, the camera poses of a whole event, and its COLMAP conversions;
//! - [`camera_path`]: nerfstudio `camera_path.json` paths and dynview's own path format;
//! - [`ply`]: a time step's cloud as binary PLY;
//! - [`qualisys`]: Qualisys motion-capture calibrations (`.qca.txt`);
//! - [`middlebury`]: Middlebury multi-view stereo calibrations (`*_par.txt`);
//! - [`import`]: any of these calibrations (detected) as event poses.
//!
//! Pure Rust; builds for `wasm32` (the viewer reads camera paths).

pub mod camera_path;
pub mod colmap;
mod error;
#[cfg(not(target_family = "wasm"))]
pub mod import;
pub mod middlebury;
pub mod ply;
pub mod poses;
pub mod qualisys;

pub use error::ImportError;

//! dynview's core: everything the offline tools and the browser viewer share, in pure Rust.
//!
//! - [`camera`]: the OpenCV pinhole model, posed cameras, project / unproject with z-depth;
//!   rigid transforms ([`Rigid3`]) are `dynview-camera`'s, re-exported;
//! - [`rotation`]: quaternion and angle-axis conversions (`dynview_camera::rotation`,
//!   re-exported);
//! - [`look_at`]: virtual cameras as eye, target, up and field of view (the viewer's form);
//! - [`view_ranking`]: the paper's input-view score `r_F`;
//! - [`raster`]: pixel grids and 8-bit conversions;
//! - [`points`]: colored point clouds (a time step's sparse points);
//! - [`scene`]: the scene package (format v1: `scene.json`, `clouds.bin`, frames);
//! - [`depth_io`]: 16-bit depth images with a scale;
//! - [`display`]: render outputs as pictures (false-color depth, view weights, RGBA);
//! - [`render`]: the paper's renderer (CPU) and its baselines;
//! - [`metrics`]: PSNR, SSIM and flicker;
//! - [`par`]: data parallelism (rayon on native, serial in the browser);
//! - `fsutil` (native only): atomic file writes and staged output folders.
//!
//! Interchange with other tools (COLMAP, `poses.json`, camera paths, PLY) is in
//! `dynview-interchange`. No GPU, browser or OpenCV dependency lives here; the crate builds
//! for `wasm32`.

pub mod camera;
pub mod color_balance;
pub mod depth_io;
pub mod display;
#[cfg(not(target_family = "wasm"))]
pub mod fsutil;
pub mod look_at;
pub mod metrics;
pub mod par;
pub mod points;
pub mod raster;
pub mod render;
pub mod scene;
pub mod view_ranking;

pub use dynview_camera::rotation;

pub use camera::{Camera, Intrinsics, Rigid3};
pub use raster::{Raster, Rgb, RgbRaster, ScalarRaster};

/// Progress of a long run, reported as it goes: stage name, items done, items in the stage.
/// The synthetic event generator and `dynview prep` report through it; the CLI draws bars.
pub type StageProgress<'a> = &'a (dyn Fn(&str, u64, u64) + Sync);

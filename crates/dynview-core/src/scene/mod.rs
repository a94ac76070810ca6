//! The scene package (formats v1 and v2, specified in `docs/FORMAT.md`): `scene.json`,
//! `clouds.bin`, and the frames: one image file per camera per time step (v1, v2), or one video
//! per camera with a frame index (v2).

pub mod cloud;
pub mod cloud_coding;
pub mod cloud_encode;
pub mod cloud_grid;
pub mod error;
#[cfg(not(target_family = "wasm"))]
pub mod ffmpeg;
pub mod frame;
pub mod limits;
pub mod manifest;
#[cfg(not(target_family = "wasm"))]
pub mod package;
#[cfg(not(target_family = "wasm"))]
pub mod repack;
pub mod summary;
pub mod video;
#[cfg(not(target_family = "wasm"))]
pub mod video_files;
#[cfg(not(target_family = "wasm"))]
pub mod writer;
pub mod yuv;

pub use crate::points::PointCloud;
pub use cloud::CloudIndex;
pub use error::{SceneError, SceneResult};
pub use frame::{decode_frame, encode_frame};
pub use manifest::{Bounds, CameraEntry, CloudsEntry, FrameFormat, Manifest, PoseEntry, StartView};
#[cfg(not(target_family = "wasm"))]
pub use package::{ScenePackage, SceneWriter};
pub use summary::SceneSummary;

#[cfg(any(test, feature = "testing"))]
pub mod testing;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod video_tests;

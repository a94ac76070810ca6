//! The scene package (format v1, specified in `docs/FORMAT.md`): `scene.json`, `clouds.bin`
//! and one frame file per camera per time step.

pub mod cloud;
pub mod error;
pub mod frame;
pub mod limits;
pub mod manifest;
#[cfg(not(target_family = "wasm"))]
pub mod package;
pub mod summary;

pub use cloud::{CloudIndex, PointCloud};
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

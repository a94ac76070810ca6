//! The errors of synthetic generation.

use std::path::{Path, PathBuf};

/// Errors of synthetic generation.
#[derive(Debug, thiserror::Error)]
pub enum SynthError {
    /// A configuration value is out of range.
    #[error("synth option `{field}`: {problem}")]
    Config {
        /// The option.
        field: &'static str,
        /// What is wrong.
        problem: String,
    },
    /// Writing a file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// Encoding an image failed.
    #[error("{path}: {source}")]
    Image {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: image::ImageError,
    },
    /// Writing the scene package failed.
    #[error(transparent)]
    Scene(#[from] dynview_core::scene::SceneError),
    /// The output folder could not be staged or replaced.
    #[error(transparent)]
    Stage(#[from] dynview_core::fsutil::StageError),
    /// ffmpeg failed on a camera's frames.
    #[error("ffmpeg failed for camera {camera}: {message}")]
    Video {
        /// The camera.
        camera: String,
        /// ffmpeg's complaint.
        message: String,
    },
}

impl SynthError {
    pub(crate) fn io(path: &Path) -> impl FnOnce(std::io::Error) -> Self + '_ {
        move |source| Self::Io { path: path.to_path_buf(), source }
    }
}

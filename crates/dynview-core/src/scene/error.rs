//! Errors of the scene package: each names the file and, where there is one, the field.

use std::path::Path;

/// Everything that can go wrong reading or writing a scene package.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The operating system refused a read or write.
    #[error("{path}: {source}")]
    Io {
        /// The file or folder involved.
        path: String,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// `scene.json` is not JSON of the expected shape (serde names the field).
    #[error("{file}: {source}")]
    Json {
        /// The file involved.
        file: String,
        /// The underlying parse error (names the field and the line).
        #[source]
        source: serde_json::Error,
    },
    /// A field holds a value the format does not allow.
    #[error("{file}: field `{field}`: {problem}")]
    Invalid {
        /// The file involved.
        file: String,
        /// The offending field, as a path such as `cameras[2].poses[17].rotation`.
        field: String,
        /// What is wrong with it.
        problem: String,
    },
    /// Stored and computed checksums differ.
    #[error("{file}: field `{field}`: checksum mismatch (stored {stored:08x}, computed {computed:08x})")]
    Checksum {
        /// The file involved.
        file: String,
        /// The checksummed part, e.g. `steps[3].crc32`.
        field: String,
        /// The checksum in the file.
        stored: u32,
        /// The checksum of the bytes read.
        computed: u32,
    },
    /// A frame image could not be decoded or encoded.
    #[error("{file}: {source}")]
    Image {
        /// The file involved.
        file: String,
        /// The underlying codec error.
        #[source]
        source: image::ImageError,
    },
    /// The output folder exists and holds something other than a scene package.
    #[error("{path}: exists and is not a dynview scene package; refusing to replace it")]
    OutputNotAScene {
        /// The output folder.
        path: String,
    },
}

/// Shorthand for results of this module.
pub type SceneResult<T> = Result<T, SceneError>;

impl SceneError {
    /// An `Invalid` error.
    pub fn invalid(file: impl Into<String>, field: impl Into<String>, problem: impl Into<String>) -> Self {
        Self::Invalid { file: file.into(), field: field.into(), problem: problem.into() }
    }

    /// An `Io` error for `path`.
    pub fn io(path: &Path, source: std::io::Error) -> Self {
        Self::Io { path: path.display().to_string(), source }
    }
}

#[cfg(not(target_family = "wasm"))]
impl From<crate::fsutil::StageError> for SceneError {
    fn from(e: crate::fsutil::StageError) -> Self {
        use crate::fsutil::StageError;
        match e {
            StageError::NotReplaceable { path, .. } => Self::OutputNotAScene { path },
            StageError::Io { path, source } => Self::Io { path, source },
        }
    }
}

//! Errors of time alignment.

/// What can go wrong aligning cameras in time.
#[derive(Debug, thiserror::Error)]
pub enum SyncError {
    /// One camera's input cannot be used (no frames, no samples, timestamps out of order).
    #[error("camera {camera}: {problem}")]
    Camera {
        /// The camera's name.
        camera: String,
        /// What is wrong.
        problem: String,
    },
    /// The cameras do not share a stretch of time.
    #[error("no time covered by every camera: {0}")]
    NoOverlap(String),
    /// An option is out of range.
    #[error("option `{option}`: {problem}")]
    Option {
        /// The option.
        option: &'static str,
        /// What is wrong.
        problem: String,
    },
    /// The alignment could not be found.
    #[error("time alignment failed: {0}")]
    Failed(String),
}

/// Results of this crate.
pub type SyncResult<T> = Result<T, SyncError>;

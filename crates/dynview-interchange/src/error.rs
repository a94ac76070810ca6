//! The error of the calibration readers (Qualisys, Middlebury).

/// A calibration file that cannot be read or does not hold what its format promises; the
/// message names the file (and line where it has lines), the camera and the field.
#[derive(Debug, thiserror::Error)]
pub enum ImportError {
    /// The operating system refused a read.
    #[error("{path}: {source}")]
    Io {
        /// The file involved.
        path: String,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// The content breaks the format: the message starts with the file (and line) and names
    /// the field.
    #[error("{0}")]
    Invalid(String),
    /// The calibration was read but its cameras do not make valid event poses.
    #[error(transparent)]
    Poses(#[from] crate::poses::PosesError),
}

/// `ImportError::Invalid` from `format!` arguments.
macro_rules! invalid {
    ($($arg:tt)*) => {
        $crate::error::ImportError::Invalid(format!($($arg)*))
    };
}
pub(crate) use invalid;

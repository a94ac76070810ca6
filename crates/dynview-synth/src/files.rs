//! Files of a synth output.

use std::path::Path;

use dynview_core::fsutil::write_atomic;

use crate::error::SynthError;

/// Writes `value` as pretty JSON at `path`, atomically.
pub(crate) fn write_json<T: serde::Serialize>(path: &Path, value: &T) -> Result<(), SynthError> {
    let text =
        serde_json::to_string_pretty(value).map_err(|e| SynthError::Io { path: path.to_path_buf(), source: std::io::Error::other(e) })?;
    write_atomic(path, text.as_bytes()).map_err(SynthError::io(path))
}

//! The work folder: each stage's result is saved there with a marker naming the inputs and
//! options it was made from, so a re-run with the same inputs skips finished stages. Files are
//! written through a temporary file and a rename, so an interrupted run leaves no half-written
//! result.

use std::path::{Path, PathBuf};

use serde::Serialize;
use serde::de::DeserializeOwned;

use dynview_core::fsutil::write_atomic;

use crate::error::{SfmError, SfmResult};

/// A work folder under the output.
#[derive(Clone, Debug)]
pub struct WorkDir {
    root: PathBuf,
}

impl WorkDir {
    /// The work folder of output `out`: `out/work`.
    pub fn new(out: &Path) -> Self {
        Self { root: out.join("work") }
    }

    /// Its path.
    pub fn path(&self) -> &Path {
        &self.root
    }

    /// A path inside it.
    pub fn join(&self, rel: impl AsRef<Path>) -> PathBuf {
        self.root.join(rel)
    }

    /// Writes `value` as JSON, atomically.
    pub fn write_json<T: Serialize>(&self, rel: &str, value: &T) -> SfmResult<()> {
        let path = self.join(rel);
        let text = serde_json::to_vec(value).map_err(|e| SfmError::WorkFile { path: path.clone(), problem: e.to_string() })?;
        write_atomic(&path, &text).map_err(SfmError::io(&path))
    }

    /// Reads JSON written by [`WorkDir::write_json`].
    pub fn read_json<T: DeserializeOwned>(&self, rel: &str) -> SfmResult<T> {
        let path = self.join(rel);
        let bytes = std::fs::read(&path).map_err(SfmError::io(&path))?;
        serde_json::from_slice(&bytes).map_err(|e| SfmError::WorkFile { path, problem: e.to_string() })
    }

    /// Whether stage `name` finished with exactly this `key` (its inputs and options).
    pub fn is_done<K: Serialize>(&self, name: &str, key: &K) -> bool {
        let marker = self.join(format!("{name}.done.json"));
        let Ok(saved) = std::fs::read(&marker) else { return false };
        serde_json::to_vec(key).is_ok_and(|k| k == saved)
    }

    /// Marks stage `name` finished with `key`; call after its results are written.
    pub fn mark_done<K: Serialize>(&self, name: &str, key: &K) -> SfmResult<()> {
        self.write_json(&format!("{name}.done.json"), key)
    }
}

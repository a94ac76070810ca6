//! Writing outputs without losing what was there: files through a temporary file and a
//! rename, folders through a staging folder that replaces the target only when complete.

use std::fs::{self, File};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Errors of staged writes.
#[derive(Debug, thiserror::Error)]
pub enum StageError {
    /// The target exists and holds something this tool did not write.
    #[error("{path}: exists and is not {what}; refusing to replace it")]
    NotReplaceable {
        /// The target folder.
        path: String,
        /// What the target would have to be (e.g. "a dynview scene package").
        what: String,
    },
    /// A file-system operation failed.
    #[error("{path}: {source}")]
    Io {
        /// The path involved.
        path: String,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
}

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> StageError + '_ {
    move |source| StageError::Io { path: path.display().to_string(), source }
}

/// Writes `bytes` to `path` through a temporary file in the same folder and a rename, so a
/// reader never sees a half-written file and an old file is replaced only when the new one is
/// complete.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let parent = parent_or_dot(path);
    fs::create_dir_all(&parent)?;
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let tmp = parent.join(format!(".{name}.tmp-{}", std::process::id()));
    let result = (|| {
        let mut f = File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    result
}

fn parent_or_dot(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// A folder built under a hidden sibling name and moved onto its target by
/// [`StagedDir::commit`]. Dropped uncommitted, it deletes itself and the target is untouched.
#[derive(Debug)]
pub struct StagedDir {
    staging: PathBuf,
    target: PathBuf,
    committed: bool,
}

impl StagedDir {
    /// Starts a staged folder for `target`. The target may be missing, an empty folder, or a
    /// folder holding the file `marker` (an earlier output of the same kind, which `commit`
    /// replaces); anything else is refused. `what` describes such an output in errors.
    pub fn new(target: &Path, marker: &str, what: &str) -> Result<Self, StageError> {
        if target.exists() {
            let replaceable =
                target.is_dir() && (fs::read_dir(target).map_err(io_err(target))?.next().is_none() || target.join(marker).is_file());
            if !replaceable {
                return Err(StageError::NotReplaceable { path: target.display().to_string(), what: what.to_owned() });
            }
        }
        let parent = parent_or_dot(target);
        fs::create_dir_all(&parent).map_err(io_err(&parent))?;
        let leaf = target.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "output".into());
        let staging = parent.join(format!(".{leaf}.partial-{}", std::process::id()));
        if staging.exists() {
            fs::remove_dir_all(&staging).map_err(io_err(&staging))?;
        }
        fs::create_dir_all(&staging).map_err(io_err(&staging))?;
        Ok(Self { staging, target: target.to_path_buf(), committed: false })
    }

    /// The folder to write into.
    pub fn path(&self) -> &Path {
        &self.staging
    }

    /// The final location.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// Moves the staged folder onto the target. An existing target is moved aside first and
    /// deleted only once the new folder is in place; on failure it is put back.
    pub fn commit(mut self) -> Result<(), StageError> {
        if self.target.exists() {
            let aside = self.staging.with_extension("old");
            if aside.exists() {
                fs::remove_dir_all(&aside).map_err(io_err(&aside))?;
            }
            fs::rename(&self.target, &aside).map_err(io_err(&self.target))?;
            if let Err(e) = fs::rename(&self.staging, &self.target) {
                let _ = fs::rename(&aside, &self.target);
                return Err(io_err(&self.target)(e));
            }
            self.committed = true;
            fs::remove_dir_all(&aside).map_err(io_err(&aside))?;
        } else {
            fs::rename(&self.staging, &self.target).map_err(io_err(&self.target))?;
            self.committed = true;
        }
        Ok(())
    }
}

impl Drop for StagedDir {
    fn drop(&mut self) {
        if !self.committed {
            let _ = fs::remove_dir_all(&self.staging);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atomic_write_replaces_whole_file() {
        let tmp = tempfile::tempdir().unwrap();
        let path = tmp.path().join("a/b.txt");
        write_atomic(&path, b"one").unwrap();
        write_atomic(&path, b"two").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"two");
        assert_eq!(fs::read_dir(tmp.path().join("a")).unwrap().count(), 1);
    }

    #[test]
    fn staged_dir_commit_drop_and_refusal() {
        let tmp = tempfile::tempdir().unwrap();
        let target = tmp.path().join("out");
        let staged = StagedDir::new(&target, "marker", "an output").unwrap();
        fs::write(staged.path().join("marker"), "1").unwrap();
        staged.commit().unwrap();
        assert_eq!(fs::read_to_string(target.join("marker")).unwrap(), "1");

        // Replacing an earlier output; dropping an uncommitted one leaves the old in place.
        let staged = StagedDir::new(&target, "marker", "an output").unwrap();
        fs::write(staged.path().join("marker"), "2").unwrap();
        drop(staged);
        assert_eq!(fs::read_to_string(target.join("marker")).unwrap(), "1");
        let staged = StagedDir::new(&target, "marker", "an output").unwrap();
        fs::write(staged.path().join("marker"), "3").unwrap();
        staged.commit().unwrap();
        assert_eq!(fs::read_to_string(target.join("marker")).unwrap(), "3");
        assert_eq!(fs::read_dir(tmp.path()).unwrap().count(), 1);

        let other = tmp.path().join("docs");
        fs::create_dir(&other).unwrap();
        fs::write(other.join("notes.txt"), "mine").unwrap();
        assert!(matches!(StagedDir::new(&other, "marker", "an output"), Err(StageError::NotReplaceable { .. })));
    }
}

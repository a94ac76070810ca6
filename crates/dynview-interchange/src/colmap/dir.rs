//! A COLMAP model folder on disk (`sparse/0/` and the like), in either form.

use std::fs;
use std::path::Path;

use super::{ColmapError, ColmapFormat, ColmapModel};
use dynview_core::fsutil::write_atomic;

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> ColmapError + '_ {
    move |source| ColmapError::Io { path: path.display().to_string(), source }
}

/// Reads `dir/name`; a missing `points3D` file reads as empty (a model of poses only).
fn read_file(dir: &Path, name: &str, optional: bool) -> Result<Vec<u8>, ColmapError> {
    let path = dir.join(name);
    match fs::read(&path) {
        Err(e) if optional && e.kind() == std::io::ErrorKind::NotFound => Ok(Vec::new()),
        other => other.map_err(io_err(&path)),
    }
}

impl ColmapModel {
    /// The form of the model in `dir`: binary when `cameras.bin` is there (even if the text
    /// files are too, as COLMAP itself prefers), else text when `cameras.txt` is there.
    pub fn detect_format(dir: &Path) -> Result<ColmapFormat, ColmapError> {
        [ColmapFormat::Binary, ColmapFormat::Text]
            .into_iter()
            .find(|format| dir.join(format.file_names()[0]).is_file())
            .ok_or_else(|| ColmapError::NoModel { path: dir.display().to_string() })
    }

    /// Reads the model in folder `dir`, in the form [`ColmapModel::detect_format`] finds.
    /// `cameras` and `images` must exist; a missing `points3D` file means no points. Errors
    /// name the file by its path.
    pub fn read_dir(dir: &Path) -> Result<Self, ColmapError> {
        let format = Self::detect_format(dir)?;
        let names = format.file_names();
        let bytes = [read_file(dir, names[0], false)?, read_file(dir, names[1], false)?, read_file(dir, names[2], true)?];
        let paths = names.map(|name| dir.join(name).display().to_string());
        let files = [paths[0].as_str(), paths[1].as_str(), paths[2].as_str()];
        match format {
            ColmapFormat::Binary => Self::from_binary_named([&bytes[0], &bytes[1], &bytes[2]], files),
            ColmapFormat::Text => {
                let mut texts = Vec::with_capacity(3);
                for (bytes, file) in bytes.iter().zip(files) {
                    let text = std::str::from_utf8(bytes)
                        .map_err(|e| ColmapError::Inconsistent { file: file.to_owned(), problem: format!("not UTF-8 text: {e}") })?;
                    texts.push(text);
                }
                Self::from_text_named([texts[0], texts[1], texts[2]], files)
            }
        }
    }

    /// Writes the model into folder `dir` (created if missing) in `format`, each file
    /// atomically. `dir` may be missing, empty or hold a COLMAP model (which is replaced; the
    /// other form's files of an older model are removed so that they cannot shadow the new
    /// ones); any other non-empty folder is refused.
    pub fn write_dir(&self, dir: &Path, format: ColmapFormat) -> Result<(), ColmapError> {
        if dir.exists() {
            let empty = fs::read_dir(dir).map_err(io_err(dir))?.next().is_none();
            if !empty && Self::detect_format(dir).is_err() {
                return Err(ColmapError::NotAModelDir { path: dir.display().to_string() });
            }
        }
        let contents = match format {
            ColmapFormat::Text => [self.cameras_txt().into_bytes(), self.images_txt().into_bytes(), self.points3d_txt().into_bytes()],
            ColmapFormat::Binary => [self.cameras_bin(), self.images_bin(), self.points3d_bin()],
        };
        for (name, bytes) in format.file_names().into_iter().zip(contents) {
            let path = dir.join(name);
            write_atomic(&path, &bytes).map_err(io_err(&path))?;
        }
        let other = match format {
            ColmapFormat::Text => ColmapFormat::Binary,
            ColmapFormat::Binary => ColmapFormat::Text,
        };
        for name in other.file_names() {
            let path = dir.join(name);
            if let Err(e) = fs::remove_file(&path)
                && e.kind() != std::io::ErrorKind::NotFound
            {
                return Err(io_err(&path)(e));
            }
        }
        Ok(())
    }
}

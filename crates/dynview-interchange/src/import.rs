//! Any calibration dynview reads, detected from the path, as event poses (`poses.json`):
//! `dynview import` and `dynview prep --poses` go through [`read_event_poses`].
//!
//! | source | detected by |
//! | --- | --- |
//! | COLMAP model (`cameras`, `images`, `points3D` as `.bin` or `.txt`) | a folder |
//! | `poses.json` | a `.json` file |
//! | Qualisys calibration | a `.qca.txt` or `.qca` file, or XML with `<calibration` |
//! | Middlebury `*_par.txt` | a file named `*_par.txt`; image sizes read from the images beside it |

use std::path::Path;

use crate::colmap::ColmapModel;
use crate::error::{ImportError, invalid};
use crate::poses::EventPoses;
use crate::{middlebury, qualisys};

/// Largest calibration text file read, in bytes.
pub const MAX_CALIBRATION_BYTES: u64 = 64 << 20;

/// A calibration format [`read_event_poses`] understands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CalibrationFormat {
    /// A COLMAP sparse model folder.
    Colmap,
    /// dynview's own `poses.json`.
    PosesJson,
    /// A Qualisys `.qca.txt` calibration.
    Qualisys,
    /// A Middlebury `*_par.txt` calibration.
    Middlebury,
}

impl CalibrationFormat {
    /// The format's name in messages.
    pub fn name(self) -> &'static str {
        match self {
            Self::Colmap => "COLMAP model",
            Self::PosesJson => "poses.json",
            Self::Qualisys => "Qualisys calibration",
            Self::Middlebury => "Middlebury calibration",
        }
    }

    /// The format of `path`, from its kind, name and (for other text files) its first bytes.
    pub fn detect(path: &Path) -> Result<Self, ImportError> {
        if path.is_dir() {
            return Ok(Self::Colmap);
        }
        let name = path.file_name().map(|n| n.to_string_lossy().to_lowercase()).unwrap_or_default();
        if name.ends_with(".json") {
            return Ok(Self::PosesJson);
        }
        if name.ends_with("_par.txt") {
            return Ok(Self::Middlebury);
        }
        if name.ends_with(".qca.txt") || name.ends_with(".qca") || read_text(path)?.contains("<calibration") {
            return Ok(Self::Qualisys);
        }
        Err(invalid!(
            "{}: not a calibration dynview knows (a COLMAP model folder, poses.json, a Qualisys .qca.txt or a Middlebury *_par.txt)",
            path.display()
        ))
    }
}

/// Reads a text file of at most [`MAX_CALIBRATION_BYTES`].
fn read_text(path: &Path) -> Result<String, ImportError> {
    let io = |source| ImportError::Io { path: path.display().to_string(), source };
    let len = std::fs::metadata(path).map_err(io)?.len();
    if len > MAX_CALIBRATION_BYTES {
        return Err(invalid!("{}: {len} bytes, more than the {MAX_CALIBRATION_BYTES} a calibration may have", path.display()));
    }
    std::fs::read_to_string(path).map_err(io)
}

/// Reads the calibration at `path` (format detected, see the module documentation) as event
/// poses, checked as `poses.json` is.
pub fn read_event_poses(path: &Path) -> Result<EventPoses, ImportError> {
    let file = path.display().to_string();
    let poses = match CalibrationFormat::detect(path)? {
        CalibrationFormat::Colmap => {
            let model = ColmapModel::read_dir(path).map_err(|e| invalid!("{e}"))?;
            EventPoses::from_colmap(&model)?
        }
        CalibrationFormat::PosesJson => EventPoses::read(path)?,
        CalibrationFormat::Qualisys => qualisys::event_poses(&qualisys::parse_qualisys_calibration(&read_text(path)?, &file)?, None),
        CalibrationFormat::Middlebury => {
            let cameras = middlebury::parse_middlebury_par(&read_text(path)?, &file)?;
            let folder = path.parent().unwrap_or(Path::new("."));
            middlebury::event_poses(&cameras, |image| image_size_px(&folder.join(image)))?
        }
    };
    poses.validate()?;
    Ok(poses)
}

/// Width and height of an image file, from its header.
fn image_size_px(path: &Path) -> Result<(u32, u32), ImportError> {
    image::image_dimensions(path).map_err(|e| invalid!("{}: cannot read the image size the calibration needs: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn data(rel: &str) -> std::path::PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data").join(rel)
    }

    #[test]
    fn detects_each_format() {
        let dir = tempfile::tempdir().unwrap();
        assert_eq!(CalibrationFormat::detect(dir.path()).unwrap(), CalibrationFormat::Colmap);
        assert_eq!(CalibrationFormat::detect(&data("pose2sim-multiperson/Calib.qca.txt")).unwrap(), CalibrationFormat::Qualisys);
        assert_eq!(
            CalibrationFormat::detect(&data("middlebury-temple-sparse-ring/templeSR_par.txt")).unwrap(),
            CalibrationFormat::Middlebury
        );
        assert_eq!(CalibrationFormat::detect(Path::new("x/poses.json")).unwrap(), CalibrationFormat::PosesJson);
        let other = dir.path().join("notes.txt");
        std::fs::write(&other, "hello").unwrap();
        let err = CalibrationFormat::detect(&other).unwrap_err().to_string();
        assert!(err.contains("notes.txt") && err.contains("not a calibration"), "{err}");
    }

    #[test]
    fn reads_a_qualisys_calibration_as_event_poses() {
        let poses = read_event_poses(&data("pose2sim-multiperson/Calib.qca.txt")).unwrap();
        let names: Vec<&str> = poses.cameras.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, ["cam01", "cam02", "cam03", "cam04"]);
    }

    #[test]
    fn a_middlebury_calibration_needs_its_images() {
        let dir = tempfile::tempdir().unwrap();
        let par = dir.path().join("ring_par.txt");
        std::fs::write(&par, "1\na.png 500 0 320 0 500 240 0 0 1 1 0 0 0 1 0 0 0 1 0 0 1\n").unwrap();
        let err = read_event_poses(&par).unwrap_err().to_string();
        assert!(err.contains("a.png") && err.contains("image size"), "{err}");
        image::RgbImage::new(64, 48).save(dir.path().join("a.png")).unwrap();
        let poses = read_event_poses(&par).unwrap();
        assert_eq!((poses.cameras[0].name.as_str(), poses.cameras[0].width, poses.cameras[0].height), ("a", 64, 48));
    }
}

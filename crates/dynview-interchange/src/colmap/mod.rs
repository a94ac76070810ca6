//! COLMAP sparse models (`cameras`, `images`, `points3D`) in COLMAP's text and binary forms.
//!
//! - [`text`]: `cameras.txt`, `images.txt`, `points3D.txt`;
//! - [`binary`]: `cameras.bin`, `images.bin`, `points3D.bin`, byte for byte as COLMAP 3.8 writes
//!   them (little-endian);
//! - reading and writing a model folder in either form ([`ColmapModel::read_dir`],
//!   [`ColmapModel::write_dir`], native only).
//!
//! COLMAP puts the centre of the top-left pixel at `(0.5, 0.5)`; dynview at `(0, 0)`. The
//! conversion functions shift principal points and 2D points by half a pixel both ways.
//! Image poses are `camera_from_world` with the quaternion in `QW QX QY QZ` order.

pub mod binary;
#[cfg(not(target_family = "wasm"))]
mod dir;
#[cfg(test)]
pub(crate) mod tests;
pub mod text;

use std::collections::BTreeMap;

use dynview_camera::{Camera, Model, OpenCv, Pinhole};
use dynview_core::camera::{Intrinsics, Rigid3};

/// COLMAP's camera models, names and ids (the models themselves are `dynview_camera`'s).
pub use dynview_camera::CameraModel;
/// OpenCV-style distortion `k1, k2, p1, p2` (zero for pinhole models).
pub use dynview_camera::OpenCvDistortion as Distortion;

pub use binary::{parse_cameras_bin, parse_images_bin, parse_points3d_bin};
pub use text::{parse_cameras_txt, parse_images_txt, parse_points3d_txt};

/// Errors reading or writing a COLMAP model. Each names the file and, where there is one, the
/// entry and the field.
#[derive(Debug, thiserror::Error)]
pub enum ColmapError {
    /// A line of a text file does not parse.
    #[error("{file}:{line}: field `{field}`: {problem}")]
    Parse {
        /// File name.
        file: String,
        /// 1-based line number.
        line: usize,
        /// The field that failed.
        field: String,
        /// What is wrong.
        problem: String,
    },
    /// An entry of a binary file does not decode.
    #[error("{file}: {entry}: field `{field}`: {problem}")]
    Binary {
        /// File name.
        file: String,
        /// The entry, e.g. `image 3 (id 17)` (position in the file counted from 0, and the id
        /// once it is known), or `header`.
        entry: String,
        /// The field that failed, in COLMAP's names (`name`, `num_points2D`, ...).
        field: String,
        /// What is wrong.
        problem: String,
    },
    /// The model is inconsistent across files.
    #[error("{file}: {problem}")]
    Inconsistent {
        /// File name.
        file: String,
        /// What is wrong.
        problem: String,
    },
    /// A folder holds no COLMAP model (neither `cameras.bin` nor `cameras.txt`).
    #[error("{path}: no COLMAP model here (expected cameras.bin, images.bin, points3D.bin or the .txt files)")]
    NoModel {
        /// The folder.
        path: String,
    },
    /// The output folder exists, is not empty and holds no COLMAP model.
    #[error("{path}: exists, is not empty and is not a COLMAP model folder (no cameras.txt or cameras.bin); refusing to write into it")]
    NotAModelDir {
        /// The folder.
        path: String,
    },
    /// The operating system refused a read or write.
    #[error("{path}: {source}")]
    Io {
        /// The file or folder involved.
        path: String,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
}

/// The two on-disk forms of a COLMAP model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ColmapFormat {
    /// `cameras.txt`, `images.txt`, `points3D.txt`.
    Text,
    /// `cameras.bin`, `images.bin`, `points3D.bin`.
    Binary,
}

impl ColmapFormat {
    /// The extension of the model's files, without the dot (`txt` or `bin`).
    pub fn extension(self) -> &'static str {
        match self {
            Self::Text => "txt",
            Self::Binary => "bin",
        }
    }

    /// The names of the three files, in the order cameras, images, points.
    pub fn file_names(self) -> [&'static str; 3] {
        match self {
            Self::Text => ["cameras.txt", "images.txt", "points3D.txt"],
            Self::Binary => ["cameras.bin", "images.bin", "points3D.bin"],
        }
    }
}

impl std::fmt::Display for ColmapFormat {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Text => "text",
            Self::Binary => "binary",
        })
    }
}

/// A COLMAP camera (intrinsics shared by images).
#[derive(Clone, Debug, PartialEq)]
pub struct ColmapCamera {
    /// The model.
    pub model: CameraModel,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Parameters in COLMAP's order and pixel convention.
    pub params: Vec<f64>,
}

impl ColmapCamera {
    /// A `PINHOLE` camera from dynview intrinsics.
    pub fn pinhole(intrinsics: &Intrinsics, width: u32, height: u32) -> Self {
        Self { model: CameraModel::Pinhole, width, height, params: colmap_pinhole(intrinsics).params() }
    }

    /// An `OPENCV` camera from dynview intrinsics and distortion.
    pub fn opencv(intrinsics: &Intrinsics, distortion: Distortion, width: u32, height: u32) -> Self {
        let camera = OpenCv { pinhole: colmap_pinhole(intrinsics), distortion };
        Self { model: CameraModel::OpenCv, width, height, params: camera.params() }
    }

    /// True when `params` holds exactly the model's number of parameters (always so for
    /// cameras read from files; [`ColmapCamera::intrinsics`] needs it).
    pub fn has_valid_param_count(&self) -> bool {
        self.params.len() == self.model.param_count()
    }

    /// dynview intrinsics (pixel centres at integers) and distortion of this camera. Missing
    /// parameters (a hand-built camera with too few, see
    /// [`ColmapCamera::has_valid_param_count`]) read as zero.
    pub fn intrinsics(&self) -> (Intrinsics, Distortion) {
        let mut params = self.params.clone();
        params.resize(self.model.param_count(), 0.0);
        // Every model is a special case of OpenCV's; `params` now has the model's count.
        let (pinhole, distortion) = Camera::from_params(self.model, &params).map_or(
            (Pinhole { fx: 0.0, fy: 0.0, cx: 0.0, cy: 0.0 }, Distortion::default()),
            |camera| {
                let opencv = camera.to_opencv();
                (opencv.pinhole, opencv.distortion)
            },
        );
        (Intrinsics { cx: pinhole.cx - 0.5, cy: pinhole.cy - 0.5, ..pinhole.into() }, distortion)
    }
}

/// dynview intrinsics (pixel centres at integers) as a pinhole in COLMAP's convention.
fn colmap_pinhole(intrinsics: &Intrinsics) -> Pinhole {
    Pinhole { cx: intrinsics.cx + 0.5, cy: intrinsics.cy + 0.5, ..Pinhole::from(*intrinsics) }
}

/// One 2D observation of an image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Point2D {
    /// Position in COLMAP's pixel convention.
    pub xy: [f64; 2],
    /// The 3D point it observes, if any.
    pub point3d_id: Option<u64>,
}

/// A registered image.
#[derive(Clone, Debug, PartialEq)]
pub struct ColmapImage {
    /// Id of its camera.
    pub camera_id: u32,
    /// World-to-camera pose.
    pub camera_from_world: Rigid3,
    /// Name, e.g. `cam0/00012.png`.
    pub name: String,
    /// Its 2D points.
    pub points2d: Vec<Point2D>,
}

/// A 3D point with its track.
#[derive(Clone, Debug, PartialEq)]
pub struct ColmapPoint3D {
    /// World position.
    pub xyz: [f64; 3],
    /// Color.
    pub rgb: [u8; 3],
    /// Mean reprojection error in pixels.
    pub error: f64,
    /// `(image_id, point2d_index)` observations.
    pub track: Vec<(u32, u32)>,
}

/// A whole sparse model, keyed by COLMAP ids.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ColmapModel {
    /// Cameras by id.
    pub cameras: BTreeMap<u32, ColmapCamera>,
    /// Images by id.
    pub images: BTreeMap<u32, ColmapImage>,
    /// Points by id.
    pub points3d: BTreeMap<u64, ColmapPoint3D>,
}

/// Most entries of one kind accepted from a file (hostile-input guard).
pub const MAX_ENTRIES: usize = 50_000_000;

impl ColmapModel {
    /// Checks cross-references: every image's camera exists.
    pub fn check(&self) -> Result<(), ColmapError> {
        self.check_references("images.txt")
    }

    /// [`ColmapModel::check`], naming `images_file` in the error.
    pub(crate) fn check_references(&self, images_file: &str) -> Result<(), ColmapError> {
        for (id, image) in &self.images {
            if !self.cameras.contains_key(&image.camera_id) {
                return Err(ColmapError::Inconsistent {
                    file: images_file.into(),
                    problem: format!("image {id} ({}) uses missing camera {}", image.name, image.camera_id),
                });
            }
        }
        Ok(())
    }
}

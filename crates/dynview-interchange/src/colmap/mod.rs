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

use dynview_core::camera::{Intrinsics, Rigid3};

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

/// COLMAP camera models dynview understands. Parameter order as in COLMAP's `models.h`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CameraModel {
    /// `f, cx, cy`.
    SimplePinhole,
    /// `fx, fy, cx, cy`.
    Pinhole,
    /// `f, cx, cy, k`.
    SimpleRadial,
    /// `f, cx, cy, k1, k2`.
    Radial,
    /// `fx, fy, cx, cy, k1, k2, p1, p2`.
    OpenCv,
}

impl CameraModel {
    /// Every supported model.
    pub const ALL: [Self; 5] = [Self::SimplePinhole, Self::Pinhole, Self::SimpleRadial, Self::Radial, Self::OpenCv];

    /// COLMAP's name of the model.
    pub fn name(self) -> &'static str {
        match self {
            Self::SimplePinhole => "SIMPLE_PINHOLE",
            Self::Pinhole => "PINHOLE",
            Self::SimpleRadial => "SIMPLE_RADIAL",
            Self::Radial => "RADIAL",
            Self::OpenCv => "OPENCV",
        }
    }

    /// COLMAP's numeric id of the model (binary files).
    pub fn id(self) -> i32 {
        match self {
            Self::SimplePinhole => 0,
            Self::Pinhole => 1,
            Self::SimpleRadial => 2,
            Self::Radial => 3,
            Self::OpenCv => 4,
        }
    }

    /// The model with COLMAP name `name`.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }

    /// The model with COLMAP id `id`.
    pub fn from_id(id: i32) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.id() == id)
    }

    /// Number of parameters.
    pub fn param_count(self) -> usize {
        match self {
            Self::SimplePinhole => 3,
            Self::Pinhole => 4,
            Self::SimpleRadial => 4,
            Self::Radial => 5,
            Self::OpenCv => 8,
        }
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

/// OpenCV-style distortion `k1, k2, p1, p2` (zero for pinhole models).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Distortion {
    /// Radial k1.
    pub k1: f64,
    /// Radial k2.
    pub k2: f64,
    /// Tangential p1.
    pub p1: f64,
    /// Tangential p2.
    pub p2: f64,
}

impl Distortion {
    /// The coefficients in OpenCV's order `[k1, k2, p1, p2]`.
    pub fn to_array(self) -> [f64; 4] {
        [self.k1, self.k2, self.p1, self.p2]
    }

    /// Distortion from coefficients in OpenCV's order `[k1, k2, p1, p2]`.
    pub fn from_array([k1, k2, p1, p2]: [f64; 4]) -> Self {
        Self { k1, k2, p1, p2 }
    }

    /// True when every coefficient is zero (no distortion).
    pub fn is_zero(self) -> bool {
        self.to_array().iter().all(|&v| v == 0.0)
    }
}

impl ColmapCamera {
    /// A `PINHOLE` camera from dynview intrinsics.
    pub fn pinhole(intrinsics: &Intrinsics, width: u32, height: u32) -> Self {
        Self {
            model: CameraModel::Pinhole,
            width,
            height,
            params: vec![intrinsics.fx, intrinsics.fy, intrinsics.cx + 0.5, intrinsics.cy + 0.5],
        }
    }

    /// An `OPENCV` camera from dynview intrinsics and distortion.
    pub fn opencv(intrinsics: &Intrinsics, distortion: Distortion, width: u32, height: u32) -> Self {
        let mut params = Self::pinhole(intrinsics, width, height).params;
        params.extend(distortion.to_array());
        Self { model: CameraModel::OpenCv, width, height, params }
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
        let p = |i: usize| self.params.get(i).copied().unwrap_or(0.0);
        let (fx, fy, cx, cy, rest) = match self.model {
            CameraModel::SimplePinhole | CameraModel::SimpleRadial | CameraModel::Radial => (p(0), p(0), p(1), p(2), 3),
            CameraModel::Pinhole | CameraModel::OpenCv => (p(0), p(1), p(2), p(3), 4),
        };
        let distortion = match self.model {
            CameraModel::SimpleRadial => Distortion { k1: p(rest), ..Distortion::default() },
            CameraModel::Radial => Distortion { k1: p(rest), k2: p(rest + 1), ..Distortion::default() },
            CameraModel::OpenCv => Distortion { k1: p(rest), k2: p(rest + 1), p1: p(rest + 2), p2: p(rest + 3) },
            CameraModel::SimplePinhole | CameraModel::Pinhole => Distortion::default(),
        };
        (Intrinsics { fx, fy, cx: cx - 0.5, cy: cy - 0.5 }, distortion)
    }
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

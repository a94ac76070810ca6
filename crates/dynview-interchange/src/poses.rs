//! `poses.json`: the camera poses of a whole event, every camera and every frame, with each
//! camera's intrinsics and lens distortion. `dynview prep`'s pose stage writes it; `prep --poses`
//! reads it instead of running structure from motion; `import-colmap` and `export-colmap` convert
//! it from and to COLMAP models ([`EventPoses::from_colmap`], [`EventPoses::to_colmap`]).
//!
//! Conventions as in the scene package: OpenCV axes, `X_camera = R X_world + t`, pixel centres at
//! integers (COLMAP's half-pixel shift is applied by the conversions). Format in
//! `docs/FORMAT.md`.

#[cfg(test)]
mod tests;

use std::collections::{BTreeMap, BTreeSet};

use serde::{Deserialize, Serialize};

use crate::colmap::{ColmapCamera, ColmapImage, ColmapModel, Distortion};
use dynview_core::camera::{Intrinsics, Rigid3};
use dynview_core::scene::limits::{MAX_ABS_COORDINATE_M, MAX_IMAGE_SIDE_PX, MAX_NAME_CHARS, MAX_TIME_STEPS};
use dynview_core::scene::manifest::{FrameFormat, Manifest, PoseEntry, is_safe_name};

/// The file's usual name.
pub const POSES_FILE: &str = "poses.json";
/// Largest `poses.json` accepted, in bytes.
pub const MAX_POSES_BYTES: u64 = 256 << 20;
/// Most cameras in one file.
pub const MAX_POSE_CAMERAS: usize = 1024;
/// Most frames of one camera (as many as a scene package has time steps).
pub const MAX_FRAMES_PER_CAMERA: usize = MAX_TIME_STEPS as usize;
/// Longest frame file name, in bytes.
pub const MAX_FRAME_NAME_BYTES: usize = 255;
/// Tolerance on `R R^T = I` and `det R = 1` (largest entry of `R R^T - I`, and `|det R - 1|`).
pub const POSE_ROTATION_TOLERANCE: f64 = 1e-6;
/// How much the intrinsics of two COLMAP cameras of one camera folder may differ, relative to
/// the larger value (distortion coefficients also pass within [`DISTORTION_AGREEMENT_ABS`]).
pub const INTRINSICS_AGREEMENT_REL: f64 = 0.005;
/// Absolute agreement accepted between distortion coefficients of one camera folder.
pub const DISTORTION_AGREEMENT_ABS: f64 = 1e-4;
/// What errors of [`EventPoses::from_colmap`]'s final check call the source.
const COLMAP_SOURCE: &str = "COLMAP model";

/// Errors reading, checking or converting event poses; each names the file and the field.
#[derive(Debug, thiserror::Error)]
pub enum PosesError {
    /// The operating system refused a read or write.
    #[error("{path}: {source}")]
    Io {
        /// The file involved.
        path: String,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// The file is not JSON of the expected shape (serde names the field and the line).
    #[error("{file}: {source}")]
    Json {
        /// The file involved.
        file: String,
        /// The underlying parse error.
        #[source]
        source: serde_json::Error,
    },
    /// A field holds a value the format does not allow.
    #[error("{file}: {field}: {problem}")]
    Invalid {
        /// The file involved (or `COLMAP model` for a converted model).
        file: String,
        /// The offending field, e.g. `cameras[2].frames[17].camera_from_world`.
        field: String,
        /// What is wrong with it.
        problem: String,
    },
    /// An image of a COLMAP model cannot become a frame.
    #[error("COLMAP model: image {image_id} ({name}): {problem}")]
    ColmapImage {
        /// The image's COLMAP id.
        image_id: u32,
        /// The image's name.
        name: String,
        /// What is wrong (naming the other image where two disagree).
        problem: String,
    },
}

/// Camera poses of a whole event, every camera and every frame: what `dynview prep`'s pose stage writes as `poses.json`, what `prep --poses` and `import-colmap` read.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EventPoses {
    /// The cameras, each with its frames.
    pub cameras: Vec<CameraPoses>,
}

/// One camera of an event: its image size, intrinsics, distortion and one pose per frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CameraPoses {
    /// Camera (folder) name, rules as the scene package's camera names: 1 to 64 of
    /// `A-Z a-z 0-9 _ - .`, not starting with `.`; unique.
    pub name: String,
    /// Frame width in pixels, `1..=16384`.
    pub width: u32,
    /// Frame height in pixels, `1..=16384`.
    pub height: u32,
    /// Pinhole intrinsics at `width x height` (dynview convention: pixel centres at integers).
    pub intrinsics: Intrinsics,
    /// OpenCV distortion `k1, k2, p1, p2`; zeros = none.
    pub distortion: [f64; 4],
    /// One entry per frame, in time order.
    pub frames: Vec<FramePose>,
}

/// One frame of a camera.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FramePose {
    /// The frame's file name inside the camera's folder (no path separators), e.g. `00012.png`.
    pub file: String,
    /// The pose; `None` when the frame is not registered.
    pub camera_from_world: Option<PoseEntry>,
}

/// True for a frame file name: 1 to [`MAX_FRAME_NAME_BYTES`] bytes, not `.` or `..`, without
/// path separators, whitespace or control characters (COLMAP's `images.txt` cannot hold them).
pub fn is_valid_frame_file(file: &str) -> bool {
    !file.is_empty()
        && file.len() <= MAX_FRAME_NAME_BYTES
        && file != "."
        && file != ".."
        && !file.chars().any(|c| c == '/' || c == '\\' || c.is_whitespace() || c.is_control())
}

fn invalid(file: &str, field: String, problem: impl Into<String>) -> PosesError {
    PosesError::Invalid { file: file.to_owned(), field, problem: problem.into() }
}

fn validate_pose(pose: &PoseEntry, file: &str, field: String) -> Result<(), PosesError> {
    if pose.rotation.iter().flatten().chain(&pose.translation).any(|v| !v.is_finite()) {
        return Err(invalid(file, field, "non-finite entry"));
    }
    if pose.translation.iter().any(|v| v.abs() > MAX_ABS_COORDINATE_M) {
        return Err(invalid(file, field, format!("translation beyond {MAX_ABS_COORDINATE_M} in magnitude")));
    }
    if !pose.camera_from_world().is_proper_rigid(POSE_ROTATION_TOLERANCE) {
        return Err(invalid(file, field, format!("rotation is not orthonormal with determinant +1 (within {POSE_ROTATION_TOLERANCE})")));
    }
    Ok(())
}

impl CameraPoses {
    fn validate(&self, i: usize, file: &str) -> Result<(), PosesError> {
        let field = |name: &str| format!("cameras[{i}].{name}");
        if !is_safe_name(&self.name) {
            return Err(invalid(
                file,
                field("name"),
                format!("{:?} must be 1..={MAX_NAME_CHARS} of A-Z a-z 0-9 _ - . and not start with '.'", self.name),
            ));
        }
        for (name, side) in [("width", self.width), ("height", self.height)] {
            if side == 0 || side > MAX_IMAGE_SIDE_PX {
                return Err(invalid(file, field(name), format!("must be in 1..={MAX_IMAGE_SIDE_PX}, found {side}")));
            }
        }
        let k = &self.intrinsics;
        for (name, v) in [("fx", k.fx), ("fy", k.fy), ("cx", k.cx), ("cy", k.cy)] {
            if !v.is_finite() || v.abs() > MAX_ABS_COORDINATE_M {
                return Err(invalid(file, field(&format!("intrinsics.{name}")), format!("must be finite, found {v}")));
            }
        }
        if k.fx <= 0.0 || k.fy <= 0.0 {
            return Err(invalid(file, field("intrinsics"), "focal lengths must be positive"));
        }
        if let Some(v) = self.distortion.iter().find(|v| !v.is_finite()) {
            return Err(invalid(file, field("distortion"), format!("must be finite, found {v}")));
        }
        if self.frames.is_empty() || self.frames.len() > MAX_FRAMES_PER_CAMERA {
            return Err(invalid(
                file,
                field("frames"),
                format!("must hold 1..={MAX_FRAMES_PER_CAMERA} frames, found {}", self.frames.len()),
            ));
        }
        let mut files = BTreeSet::new();
        for (j, frame) in self.frames.iter().enumerate() {
            if !is_valid_frame_file(&frame.file) {
                return Err(invalid(
                    file,
                    field(&format!("frames[{j}].file")),
                    format!("{:?} must be a plain file name without separators or whitespace", frame.file),
                ));
            }
            if !files.insert(frame.file.as_str()) {
                return Err(invalid(file, field(&format!("frames[{j}].file")), format!("duplicate frame file {:?}", frame.file)));
            }
            if let Some(pose) = &frame.camera_from_world {
                validate_pose(pose, file, field(&format!("frames[{j}].camera_from_world")))?;
            }
        }
        Ok(())
    }

    fn colmap_camera(&self) -> ColmapCamera {
        let distortion = Distortion::from_array(self.distortion);
        if distortion.is_zero() {
            ColmapCamera::pinhole(&self.intrinsics, self.width, self.height)
        } else {
            ColmapCamera::opencv(&self.intrinsics, distortion, self.width, self.height)
        }
    }
}

impl EventPoses {
    /// Checks every field against the format's rules; the error names `poses.json` and the
    /// first offending field.
    pub fn validate(&self) -> Result<(), PosesError> {
        self.validate_as(POSES_FILE)
    }

    /// [`EventPoses::validate`], naming `file` in errors.
    fn validate_as(&self, file: &str) -> Result<(), PosesError> {
        if self.cameras.is_empty() || self.cameras.len() > MAX_POSE_CAMERAS {
            return Err(invalid(file, "cameras".into(), format!("must hold 1..={MAX_POSE_CAMERAS} cameras, found {}", self.cameras.len())));
        }
        for (i, camera) in self.cameras.iter().enumerate() {
            camera.validate(i, file)?;
            if self.cameras[..i].iter().any(|c| c.name == camera.name) {
                return Err(invalid(file, format!("cameras[{i}].name"), format!("duplicate camera name {:?}", camera.name)));
            }
        }
        Ok(())
    }

    /// Parses and validates `poses.json` bytes; `file_name` names the file in errors.
    pub fn from_json_bytes(bytes: &[u8], file_name: &str) -> Result<Self, PosesError> {
        if bytes.len() as u64 > MAX_POSES_BYTES {
            return Err(invalid(file_name, "(file)".into(), format!("larger than {MAX_POSES_BYTES} bytes")));
        }
        let poses: Self = serde_json::from_slice(bytes).map_err(|source| PosesError::Json { file: file_name.to_owned(), source })?;
        poses.validate_as(file_name)?;
        Ok(poses)
    }

    /// Pretty JSON.
    pub fn to_json_string(&self) -> String {
        // Plain numbers, strings and vectors always serialise.
        serde_json::to_string_pretty(self).unwrap_or_default()
    }

    /// Reads and validates the file at `path`.
    #[cfg(not(target_family = "wasm"))]
    pub fn read(path: &std::path::Path) -> Result<Self, PosesError> {
        use std::io::Read;
        let io = |source| PosesError::Io { path: path.display().to_string(), source };
        let mut bytes = Vec::new();
        std::fs::File::open(path).map_err(io)?.take(MAX_POSES_BYTES + 1).read_to_end(&mut bytes).map_err(io)?;
        Self::from_json_bytes(&bytes, &path.display().to_string())
    }

    /// Validates and writes the file at `path` atomically (a reader never sees half a file).
    #[cfg(not(target_family = "wasm"))]
    pub fn write(&self, path: &std::path::Path) -> Result<(), PosesError> {
        self.validate_as(&path.display().to_string())?;
        dynview_core::fsutil::write_atomic(path, self.to_json_string().as_bytes())
            .map_err(|source| PosesError::Io { path: path.display().to_string(), source })
    }

    /// The pose of frame `frame` of camera `camera`; `None` when out of range or not registered.
    pub fn camera_from_world(&self, camera: usize, frame: usize) -> Option<Rigid3> {
        self.cameras.get(camera)?.frames.get(frame)?.camera_from_world.map(|pose| pose.camera_from_world())
    }

    /// Number of frames over all cameras.
    pub fn frame_count(&self) -> usize {
        self.cameras.iter().map(|c| c.frames.len()).sum()
    }

    /// Number of time steps: the frames of the camera with the fewest (0 without cameras).
    pub fn time_step_count(&self) -> usize {
        self.cameras.iter().map(|c| c.frames.len()).min().unwrap_or(0)
    }

    /// Number of frames with a pose, over all cameras.
    pub fn registered_frame_count(&self) -> usize {
        self.cameras.iter().flat_map(|c| &c.frames).filter(|f| f.camera_from_world.is_some()).count()
    }

    /// The format of the image files [`EventPoses::from_manifest`] names: an image package's
    /// own; JPEG for a video package (the files `dynview export-colmap` writes of its frames).
    pub fn image_format_of(manifest: &Manifest) -> FrameFormat {
        if manifest.frame_format.is_video() { FrameFormat::Jpeg } else { manifest.frame_format }
    }

    /// The poses of a scene package: every camera, frame files `<t:05>.<ext>` in
    /// [`EventPoses::image_format_of`], no distortion (package frames are undistorted), every
    /// frame registered.
    pub fn from_manifest(manifest: &Manifest) -> Self {
        let extension = Self::image_format_of(manifest).extension();
        let cameras = manifest
            .cameras
            .iter()
            .map(|camera| CameraPoses {
                name: camera.name.clone(),
                width: camera.width,
                height: camera.height,
                intrinsics: camera.intrinsics,
                distortion: [0.0; 4],
                frames: (0..manifest.time_step_count)
                    .map(|t| FramePose { file: format!("{t:05}.{extension}"), camera_from_world: Some(camera.pose(t)) })
                    .collect(),
            })
            .collect();
        Self { cameras }
    }

    /// A COLMAP model of the registered frames: one camera per dynview camera (`PINHOLE` when
    /// the distortion is zero, else `OPENCV`; ids from 1 in order), one image per registered
    /// frame named `<camera>/<file>` (ids from 1, camera then frame order), no points.
    pub fn to_colmap(&self) -> ColmapModel {
        let mut model = ColmapModel::default();
        let mut image_id = 0;
        for (camera_id, camera) in (1..).zip(&self.cameras) {
            model.cameras.insert(camera_id, camera.colmap_camera());
            for frame in &camera.frames {
                let Some(pose) = &frame.camera_from_world else { continue };
                image_id += 1;
                model.images.insert(
                    image_id,
                    ColmapImage {
                        camera_id,
                        camera_from_world: pose.camera_from_world(),
                        name: format!("{}/{}", camera.name, frame.file),
                        points2d: Vec::new(),
                    },
                );
            }
        }
        model
    }

    /// The poses of a COLMAP model's images. Image names must be `<camera>/<frame file>`;
    /// cameras come sorted by name, frames by file name, all registered. Images of one camera
    /// folder may use different COLMAP cameras only if their sizes are equal and their
    /// intrinsics agree within [`INTRINSICS_AGREEMENT_REL`]; the camera then gets those of its
    /// first frame. `SIMPLE_PINHOLE`, `PINHOLE`, `SIMPLE_RADIAL`, `RADIAL` and `OPENCV` map to
    /// intrinsics and OpenCV distortion.
    pub fn from_colmap(model: &ColmapModel) -> Result<Self, PosesError> {
        let mut by_folder: BTreeMap<&str, Vec<(u32, &ColmapImage, &str)>> = BTreeMap::new();
        for (&image_id, image) in &model.images {
            let err = |problem: String| PosesError::ColmapImage { image_id, name: image.name.clone(), problem };
            let Some((folder, file)) = image.name.split_once('/') else {
                return Err(err("name must be <camera>/<frame file>".into()));
            };
            if !is_safe_name(folder) {
                return Err(err(format!(
                    "camera folder {folder:?} must be 1..={MAX_NAME_CHARS} of A-Z a-z 0-9 _ - . and not start with '.'"
                )));
            }
            if !is_valid_frame_file(file) {
                return Err(err(format!("frame file {file:?} must be a plain file name (name must be <camera>/<frame file>)")));
            }
            match model.cameras.get(&image.camera_id) {
                None => return Err(err(format!("uses missing camera {}", image.camera_id))),
                Some(camera) if !camera.has_valid_param_count() => {
                    return Err(err(format!(
                        "camera {} has {} parameters, {} needs {}",
                        image.camera_id,
                        camera.params.len(),
                        camera.model.name(),
                        camera.model.param_count()
                    )));
                }
                Some(_) => {}
            }
            by_folder.entry(folder).or_default().push((image_id, image, file));
        }
        let mut cameras = Vec::with_capacity(by_folder.len());
        for (folder, mut frames) in by_folder {
            frames.sort_by(|a, b| a.2.cmp(b.2));
            cameras.push(camera_from_colmap_images(model, folder, &frames)?);
        }
        let poses = Self { cameras };
        poses.validate_as(COLMAP_SOURCE)?;
        Ok(poses)
    }
}

/// One camera from the images of its folder, sorted by file name.
fn camera_from_colmap_images(model: &ColmapModel, folder: &str, frames: &[(u32, &ColmapImage, &str)]) -> Result<CameraPoses, PosesError> {
    let describe = |(id, image, _): (u32, &ColmapImage, &str)| format!("image {id} ({}, camera {})", image.name, image.camera_id);
    let err = |(id, image, _): (u32, &ColmapImage, &str), problem: String| PosesError::ColmapImage {
        image_id: id,
        name: image.name.clone(),
        problem,
    };
    for pair in frames.windows(2) {
        if pair[0].2 == pair[1].2 {
            return Err(err(pair[1], format!("same name as {}", describe(pair[0]))));
        }
    }
    let first = frames[0];
    let reference = &model.cameras[&first.1.camera_id];
    let (intrinsics, distortion) = reference.intrinsics();
    for &frame in &frames[1..] {
        if frame.1.camera_id == first.1.camera_id {
            continue;
        }
        let camera = &model.cameras[&frame.1.camera_id];
        if (camera.width, camera.height) != (reference.width, reference.height) {
            return Err(err(
                frame,
                format!("{}x{} pixels, but {} is {}x{}", camera.width, camera.height, describe(first), reference.width, reference.height),
            ));
        }
        let (k, d) = camera.intrinsics();
        let close = |a: f64, b: f64, abs: f64| (a - b).abs() <= (INTRINSICS_AGREEMENT_REL * a.abs().max(b.abs())).max(abs);
        let k_ok = [(k.fx, intrinsics.fx), (k.fy, intrinsics.fy), (k.cx + 0.5, intrinsics.cx + 0.5), (k.cy + 0.5, intrinsics.cy + 0.5)]
            .into_iter()
            .all(|(a, b)| close(a, b, 0.0));
        let d_ok = d.to_array().into_iter().zip(distortion.to_array()).all(|(a, b)| close(a, b, DISTORTION_AGREEMENT_ABS));
        if !(k_ok && d_ok) {
            return Err(err(
                frame,
                format!(
                    "intrinsics {k:?} {d:?} differ from those of {} ({intrinsics:?} {distortion:?}) by more than {}%",
                    describe(first),
                    INTRINSICS_AGREEMENT_REL * 100.0
                ),
            ));
        }
    }
    Ok(CameraPoses {
        name: folder.to_owned(),
        width: reference.width,
        height: reference.height,
        intrinsics,
        distortion: distortion.to_array(),
        frames: frames
            .iter()
            .map(|(_, image, file)| FramePose {
                file: (*file).to_owned(),
                camera_from_world: Some(PoseEntry::from(image.camera_from_world)),
            })
            .collect(),
    })
}

//! `scene.json`: the package manifest, its serde shape and its validation.

use serde::{Deserialize, Serialize};

use super::error::{SceneError, SceneResult};
use super::limits::*;
use crate::camera::{Camera, Intrinsics, Rigid3};
use crate::color_balance::{ColorTransform, MAX_GAIN, MAX_OFFSET, MIN_GAIN};
use crate::raster::RgbRaster;
use crate::render::InputView;

/// The manifest file's name inside a package.
pub const MANIFEST_FILE: &str = "scene.json";
/// The value of the `format` field.
pub const FORMAT_NAME: &str = "dynview-scene";
/// The format version this code writes; it reads this one and [`FORMAT_VERSION_V1`].
pub const FORMAT_VERSION: u32 = 2;
/// The first format version: image frames only, no `frames_index`.
pub const FORMAT_VERSION_V1: u32 = 1;
/// The frame index of a video package.
pub const FRAMES_INDEX_FILE: &str = "frames.idx";
/// The folder holding the input frames: `frames/<camera>/<t:05>.<ext>` (images) or
/// `frames/<camera>.ivf` (video).
pub const FRAMES_DIR: &str = "frames";
/// Folder of the cameras' background plates in a package.
pub const PLATES_DIR: &str = "plates";

/// A world-to-camera pose as stored: row-major rotation and translation (OpenCV convention).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PoseEntry {
    /// Rows of `R` in `X_c = R X_w + t`.
    pub rotation: [[f64; 3]; 3],
    /// `t` in `X_c = R X_w + t`, in metres (or the scene's unit).
    pub translation: [f64; 3],
}

impl From<Rigid3> for PoseEntry {
    fn from(camera_from_world: Rigid3) -> Self {
        Self { rotation: camera_from_world.rotation_rows(), translation: camera_from_world.translation.to_array() }
    }
}

impl PoseEntry {
    /// The pose as a `camera_from_world` transform.
    pub fn camera_from_world(&self) -> Rigid3 {
        Rigid3::from_rotation_rows(self.rotation, self.translation)
    }
}

/// One input camera: image size, intrinsics and a pose per time step.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CameraEntry {
    /// Name: 1 to 64 of `A-Z a-z 0-9 _ - .`, not starting with `.`; also the frame folder name.
    pub name: String,
    /// Width of the stored frames in pixels.
    pub width: u32,
    /// Height of the stored frames in pixels.
    pub height: u32,
    /// Pinhole intrinsics at `width x height` (frames are undistorted).
    pub intrinsics: Intrinsics,
    /// `camera_from_world` for every time step, or (format v2) one pose for all of them: a
    /// camera that stands still. Read them with [`CameraEntry::pose`].
    pub poses: Vec<PoseEntry>,
    /// The map of this camera's colors to the response all cameras share
    /// ([`crate::color_balance`]), applied to its frames before rendering; none: as stored.
    /// Optional in both format versions (readers that predate it ignore it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub color_balance: Option<ColorTransform>,
    /// Whether the package holds this camera's background plate, `plates/<name>.jpg` at
    /// `width x height` (a camera that stands still; issue 33). Optional in both format
    /// versions (readers that predate it ignore it).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub plate: bool,
}

impl CameraEntry {
    /// The pose at time step `t` (the one pose of a camera that stands still).
    pub fn pose(&self, t: u32) -> PoseEntry {
        let last = self.poses.len().saturating_sub(1);
        self.poses.get((t as usize).min(last)).copied().unwrap_or(PoseEntry::from(Rigid3::IDENTITY))
    }

    /// Stores one pose when every time step has the same one (format v2 only).
    pub fn compact_poses(&mut self) {
        if self.poses.windows(2).all(|w| w[0] == w[1]) {
            self.poses.truncate(1);
        }
    }
}

/// Axis-aligned bounds of the scene content.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Bounds {
    /// Smallest corner.
    pub min: [f64; 3],
    /// Largest corner.
    pub max: [f64; 3],
}

impl Bounds {
    /// The centre of the box.
    pub fn center(&self) -> [f64; 3] {
        std::array::from_fn(|i| 0.5 * (self.min[i] + self.max[i]))
    }

    /// The length of the box's diagonal.
    pub fn diagonal(&self) -> f64 {
        (0..3).map(|i| (self.max[i] - self.min[i]).powi(2)).sum::<f64>().sqrt()
    }
}

/// Where the per-timestep clouds live.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CloudsEntry {
    /// File name inside the package (`clouds.bin`).
    pub file: String,
    /// Exact size of that file in bytes.
    pub byte_length: u64,
}

/// Encoding of the frame files.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FrameFormat {
    /// `.jpg` files.
    Jpeg,
    /// `.png` files.
    Png,
    /// `.webp` files.
    Webp,
    /// One VP9 video per camera, `frames/<camera>.ivf`, indexed by `frames_index` (v2).
    Vp9,
}

impl FrameFormat {
    /// The file extension, without the dot.
    pub fn extension(self) -> &'static str {
        match self {
            Self::Jpeg => "jpg",
            Self::Png => "png",
            Self::Webp => "webp",
            Self::Vp9 => "ivf",
        }
    }

    /// Whether frames are stored as one video per camera rather than one image per frame.
    pub fn is_video(self) -> bool {
        self == Self::Vp9
    }
}

/// Where the frame index of a video package lives (format v2).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct FramesIndexEntry {
    /// File name inside the package (`frames.idx`).
    pub file: String,
    /// Exact size of that file in bytes.
    pub byte_length: u64,
    /// The keyframe interval the videos were written with (a hint; the index is the truth).
    pub keyframe_interval: u32,
}

/// A suggested first view for viewers.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct StartView {
    /// Time step to show first.
    pub time_step: u32,
    /// Virtual camera pose (`camera_from_world`).
    pub pose: PoseEntry,
    /// Vertical field of view in degrees.
    pub vertical_fov_deg: f64,
}

/// The whole `scene.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// Always `dynview-scene`.
    pub format: String,
    /// Format version, 1.
    pub version: u32,
    /// A human-readable name.
    pub name: String,
    /// Frames per second of the capture.
    pub fps: f64,
    /// Number of time steps `T`.
    pub time_step_count: u32,
    /// Bounds of the scene content (world coordinates).
    pub bounds: Bounds,
    /// The input cameras.
    pub cameras: Vec<CameraEntry>,
    /// The clouds file.
    pub clouds: CloudsEntry,
    /// Encoding of the frames under `frames/`.
    pub frame_format: FrameFormat,
    /// The frame index, present exactly when the frames are video (v2).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frames_index: Option<FramesIndexEntry>,
    /// A suggested first view.
    pub start_view: StartView,
}

impl Manifest {
    /// Parses and validates `scene.json` bytes. `file` names the file in errors.
    pub fn from_json_slice(bytes: &[u8], file: &str) -> SceneResult<Self> {
        if bytes.len() as u64 > MAX_MANIFEST_BYTES {
            return Err(SceneError::invalid(file, "(file)", format!("larger than {MAX_MANIFEST_BYTES} bytes")));
        }
        let manifest: Self = serde_json::from_slice(bytes).map_err(|source| SceneError::Json { file: file.to_owned(), source })?;
        manifest.validate(file)?;
        Ok(manifest)
    }

    /// Serialises to pretty JSON.
    pub fn to_json_pretty(&self) -> String {
        // A struct of plain numbers, strings and vectors always serialises.
        serde_json::to_string_pretty(self).unwrap_or_default()
    }

    /// Checks every field; the error names the first offending one.
    pub fn validate(&self, file: &str) -> SceneResult<()> {
        let bad = |field: &str, problem: String| Err(SceneError::invalid(file, field, problem));
        if self.format != FORMAT_NAME {
            return bad("format", format!("expected \"{FORMAT_NAME}\", found {:?}", self.format));
        }
        if self.version != FORMAT_VERSION && self.version != FORMAT_VERSION_V1 {
            return bad(
                "version",
                format!("unsupported version {} (this reader knows {FORMAT_VERSION_V1} and {FORMAT_VERSION})", self.version),
            );
        }
        match (&self.frames_index, self.frame_format.is_video()) {
            (Some(_), _) | (None, true) if self.version == FORMAT_VERSION_V1 => {
                return bad("frame_format", "video frames and `frames_index` need format version 2".into());
            }
            (None, true) => return bad("frames_index", "missing: video frames need their index".into()),
            (Some(_), false) => return bad("frames_index", "present, but the frames are images".into()),
            (Some(index), true) if !is_safe_file_name(&index.file) => {
                return bad("frames_index.file", format!("{:?} is not a plain file name", index.file));
            }
            (Some(index), true) if index.keyframe_interval == 0 || index.keyframe_interval > MAX_KEYFRAME_INTERVAL => {
                return bad(
                    "frames_index.keyframe_interval",
                    format!("must be in 1..={MAX_KEYFRAME_INTERVAL}, found {}", index.keyframe_interval),
                );
            }
            _ => {}
        }
        if self.name.chars().count() > 256 {
            return bad("name", "longer than 256 characters".into());
        }
        if !(self.fps.is_finite() && self.fps > 0.0 && self.fps <= 1000.0) {
            return bad("fps", format!("must be in (0, 1000], found {}", self.fps));
        }
        if self.time_step_count == 0 || self.time_step_count > MAX_TIME_STEPS {
            return bad("time_step_count", format!("must be in 1..={MAX_TIME_STEPS}, found {}", self.time_step_count));
        }
        validate_bounds(&self.bounds, file, "bounds")?;
        if self.cameras.is_empty() || self.cameras.len() > MAX_CAMERAS {
            return bad("cameras", format!("must hold 1..={MAX_CAMERAS} cameras, found {}", self.cameras.len()));
        }
        for (i, camera) in self.cameras.iter().enumerate() {
            self.validate_camera(camera, i, file)?;
            if self.cameras[..i].iter().any(|c| c.name == camera.name) {
                return bad(&format!("cameras[{i}].name"), format!("duplicate camera name {:?}", camera.name));
            }
        }
        if !is_safe_file_name(&self.clouds.file) {
            return bad("clouds.file", format!("{:?} is not a plain file name", self.clouds.file));
        }
        if self.start_view.time_step >= self.time_step_count {
            return bad("start_view.time_step", format!("{} is not below time_step_count", self.start_view.time_step));
        }
        validate_pose(&self.start_view.pose, file, "start_view.pose")?;
        let fov = self.start_view.vertical_fov_deg;
        if !(fov.is_finite() && fov > 1.0 && fov < 179.0) {
            return bad("start_view.vertical_fov_deg", format!("must be in (1, 179), found {fov}"));
        }
        Ok(())
    }

    fn validate_camera(&self, camera: &CameraEntry, i: usize, file: &str) -> SceneResult<()> {
        let field = |name: &str| format!("cameras[{i}].{name}");
        if !is_safe_name(&camera.name) {
            return Err(SceneError::invalid(
                file,
                field("name"),
                format!("{:?} must be 1..={MAX_NAME_CHARS} of A-Z a-z 0-9 _ - . and not start with '.'", camera.name),
            ));
        }
        for (name, side) in [("width", camera.width), ("height", camera.height)] {
            if side == 0 || side > MAX_IMAGE_SIDE_PX {
                return Err(SceneError::invalid(file, field(name), format!("must be in 1..={MAX_IMAGE_SIDE_PX}, found {side}")));
            }
        }
        let k = &camera.intrinsics;
        for (name, v) in [("fx", k.fx), ("fy", k.fy), ("cx", k.cx), ("cy", k.cy)] {
            if !v.is_finite() || v.abs() > MAX_ABS_COORDINATE_M {
                return Err(SceneError::invalid(file, field(&format!("intrinsics.{name}")), format!("must be finite, found {v}")));
            }
        }
        if k.fx <= 0.0 || k.fy <= 0.0 {
            return Err(SceneError::invalid(file, field("intrinsics"), "focal lengths must be positive"));
        }
        let one_for_all = camera.poses.len() == 1 && self.version != FORMAT_VERSION_V1;
        if camera.poses.len() != self.time_step_count as usize && !one_for_all {
            return Err(SceneError::invalid(
                file,
                field("poses"),
                format!(
                    "has {} poses, time_step_count is {} (format v2 also allows one pose for a camera that stands still)",
                    camera.poses.len(),
                    self.time_step_count
                ),
            ));
        }
        for (t, pose) in camera.poses.iter().enumerate() {
            validate_pose(pose, file, &field(&format!("poses[{t}]")))?;
        }
        if let Some(balance) = &camera.color_balance {
            for (k, (&gain, &offset)) in balance.gain.iter().zip(&balance.offset).enumerate() {
                if !(gain.is_finite() && (MIN_GAIN..=MAX_GAIN).contains(&gain)) {
                    let name = field(&format!("color_balance.gain[{k}]"));
                    return Err(SceneError::invalid(file, name, format!("must be in [{MIN_GAIN}, {MAX_GAIN}], found {gain}")));
                }
                if !(offset.is_finite() && offset.abs() <= MAX_OFFSET) {
                    let name = field(&format!("color_balance.offset[{k}]"));
                    return Err(SceneError::invalid(file, name, format!("must be in [-{MAX_OFFSET}, {MAX_OFFSET}], found {offset}")));
                }
            }
        }
        Ok(())
    }

    /// Camera `camera`'s frame at time step `t` as the renderer's input: its color balance
    /// applied, then its pyramid of `levels` levels built.
    pub fn input_view(&self, camera: usize, t: u32, mut frame: RgbRaster, levels: usize) -> InputView {
        if let Some(balance) = &self.cameras[camera].color_balance {
            balance.apply_to(&mut frame);
        }
        InputView::new(self.camera_at(camera, t), frame, levels)
    }

    /// Camera `camera`'s background plate as the renderer reads it: its color balance applied.
    pub fn balanced_plate(&self, camera: usize, mut plate: RgbRaster) -> RgbRaster {
        if let Some(balance) = &self.cameras[camera].color_balance {
            balance.apply_to(&mut plate);
        }
        plate
    }

    /// The posed camera `camera` at time step `t` (both must be in range).
    pub fn camera_at(&self, camera: usize, t: u32) -> Camera {
        let entry = &self.cameras[camera];
        Camera {
            intrinsics: entry.intrinsics,
            camera_from_world: entry.pose(t).camera_from_world(),
            width_px: entry.width,
            height_px: entry.height,
        }
    }

    /// Stores the frames as one VP9 video per camera with a keyframe at least every
    /// `keyframe_interval` frames (format v2; the index's size is filled in by the writer).
    pub fn set_video_frames(&mut self, keyframe_interval: u32) {
        self.frame_format = FrameFormat::Vp9;
        self.frames_index = Some(FramesIndexEntry { file: FRAMES_INDEX_FILE.into(), byte_length: 0, keyframe_interval });
    }

    /// Stores the frames as JPEG files, one per camera per time step.
    pub fn set_jpeg_frames(&mut self) {
        self.frame_format = FrameFormat::Jpeg;
        self.frames_index = None;
    }

    /// Relative path of a camera's video inside a video package: `frames/<camera>.ivf`.
    pub fn video_relative_path(&self, camera: usize) -> String {
        format!("{FRAMES_DIR}/{}.{}", self.cameras[camera].name, self.frame_format.extension())
    }

    /// Relative path of a camera's background plate: `plates/<camera>.jpg`.
    pub fn plate_relative_path(&self, camera: usize) -> String {
        format!("{PLATES_DIR}/{}.jpg", self.cameras[camera].name)
    }

    /// Relative path of a frame file inside an image package: `frames/<camera>/<t:05>.<ext>`.
    pub fn frame_relative_path(&self, camera: usize, t: u32) -> String {
        format!("{FRAMES_DIR}/{}/{t:05}.{}", self.cameras[camera].name, self.frame_format.extension())
    }
}

fn validate_bounds(bounds: &Bounds, file: &str, field: &str) -> SceneResult<()> {
    for axis in 0..3 {
        let (lo, hi) = (bounds.min[axis], bounds.max[axis]);
        let ok = lo.is_finite() && hi.is_finite() && lo <= hi && lo.abs() <= MAX_ABS_COORDINATE_M && hi.abs() <= MAX_ABS_COORDINATE_M;
        if !ok {
            return Err(SceneError::invalid(
                file,
                format!("{field}[axis {axis}]"),
                format!("min {lo} and max {hi} must be finite with min <= max"),
            ));
        }
    }
    Ok(())
}

fn validate_pose(pose: &PoseEntry, file: &str, field: &str) -> SceneResult<()> {
    if pose.rotation.iter().flatten().any(|v| !v.is_finite()) {
        return Err(SceneError::invalid(file, format!("{field}.rotation"), "non-finite entry"));
    }
    if pose.translation.iter().any(|v| !v.is_finite() || v.abs() > MAX_ABS_COORDINATE_M) {
        return Err(SceneError::invalid(
            file,
            format!("{field}.translation"),
            format!("entries must be finite and below {MAX_ABS_COORDINATE_M} in magnitude"),
        ));
    }
    if !pose.camera_from_world().is_proper_rigid(ROTATION_TOLERANCE) {
        return Err(SceneError::invalid(
            file,
            format!("{field}.rotation"),
            format!("not a rotation (R R^T != I or det R != 1 within {ROTATION_TOLERANCE})"),
        ));
    }
    Ok(())
}

/// True for a camera or folder name that is safe to use as a path component.
pub fn is_safe_name(name: &str) -> bool {
    !name.is_empty()
        && name.len() <= MAX_NAME_CHARS
        && !name.starts_with('.')
        && name.bytes().all(|b| b.is_ascii_alphanumeric() || matches!(b, b'_' | b'-' | b'.'))
}

fn is_safe_file_name(name: &str) -> bool {
    is_safe_name(name)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::testing::small_manifest;

    #[test]
    fn valid_manifest_round_trips_through_json() {
        let m = small_manifest(3, 4);
        let json = m.to_json_pretty();
        let back = Manifest::from_json_slice(json.as_bytes(), "scene.json").unwrap();
        assert_eq!(back, m);
        assert_eq!(back.frame_relative_path(1, 3), "frames/cam1/00003.png");
    }

    fn expect_field(m: &Manifest, field: &str) {
        let err = m.validate("scene.json").unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains(&format!("`{field}`")), "expected field {field} in: {msg}");
        assert!(msg.starts_with("scene.json"), "{msg}");
    }

    #[test]
    fn each_bad_field_is_named() {
        let base = small_manifest(2, 3);
        let mut m = base.clone();
        m.version = 3;
        expect_field(&m, "version");
        let mut m = base.clone();
        m.frame_format = FrameFormat::Vp9;
        expect_field(&m, "frames_index");
        let index = FramesIndexEntry { file: "frames.idx".into(), byte_length: 0, keyframe_interval: 30 };
        m.frames_index = Some(index.clone());
        m.version = FORMAT_VERSION_V1;
        expect_field(&m, "frame_format");
        m.version = FORMAT_VERSION;
        m.validate("scene.json").unwrap();
        m.frames_index = Some(FramesIndexEntry { file: "../x".into(), ..index.clone() });
        expect_field(&m, "frames_index.file");
        m.frames_index = Some(FramesIndexEntry { keyframe_interval: 0, ..index.clone() });
        expect_field(&m, "frames_index.keyframe_interval");
        let mut m = base.clone();
        m.frames_index = Some(index);
        expect_field(&m, "frames_index");
        let mut m = base.clone();
        m.format = "other".into();
        expect_field(&m, "format");
        let mut m = base.clone();
        m.fps = f64::NAN;
        expect_field(&m, "fps");
        let mut m = base.clone();
        m.time_step_count = MAX_TIME_STEPS + 1;
        expect_field(&m, "time_step_count");
        let mut m = base.clone();
        m.cameras[1].poses[2].rotation[0][0] = f64::NAN;
        expect_field(&m, "cameras[1].poses[2].rotation");
        let mut m = base.clone();
        m.cameras[1].poses[1].rotation[0][1] = 0.3;
        expect_field(&m, "cameras[1].poses[1].rotation");
        let mut m = base.clone();
        m.cameras[0].poses[0].translation[2] = f64::INFINITY;
        expect_field(&m, "cameras[0].poses[0].translation");
        let mut m = base.clone();
        m.cameras[0].poses.pop();
        expect_field(&m, "cameras[0].poses");
        let mut m = base.clone();
        m.cameras[0].poses.truncate(1);
        m.validate("scene.json").unwrap();
        assert_eq!(m.camera_at(0, 2).camera_from_world, base.camera_at(0, 2).camera_from_world);
        m.version = FORMAT_VERSION_V1;
        expect_field(&m, "cameras[0].poses");
        let mut m = base.clone();
        m.cameras[1].name = "../evil".into();
        expect_field(&m, "cameras[1].name");
        let mut m = base.clone();
        m.cameras[1].name = m.cameras[0].name.clone();
        expect_field(&m, "cameras[1].name");
        let mut m = base.clone();
        m.cameras[0].width = 0;
        expect_field(&m, "cameras[0].width");
        let mut m = base.clone();
        m.cameras[0].intrinsics.fx = -3.0;
        expect_field(&m, "cameras[0].intrinsics");
        let mut m = base.clone();
        m.bounds.min[1] = 5.0;
        expect_field(&m, "bounds[axis 1]");
        let mut m = base.clone();
        m.clouds.file = "/etc/passwd".into();
        expect_field(&m, "clouds.file");
        let mut m = base.clone();
        m.start_view.time_step = 3;
        expect_field(&m, "start_view.time_step");
        let mut m = base;
        m.cameras.clear();
        expect_field(&m, "cameras");
    }

    #[test]
    fn json_errors_name_the_field() {
        let m = small_manifest(1, 1);
        let mut value: serde_json::Value = serde_json::from_str(&m.to_json_pretty()).unwrap();
        value.as_object_mut().unwrap().remove("fps");
        let err = Manifest::from_json_slice(value.to_string().as_bytes(), "x/scene.json").unwrap_err();
        assert!(err.to_string().contains("fps"), "{err}");
        assert!(err.to_string().starts_with("x/scene.json"), "{err}");
        let err = Manifest::from_json_slice(b"{\"format\": 3", "scene.json").unwrap_err();
        assert!(matches!(err, SceneError::Json { .. }));
    }

    #[test]
    fn safe_names() {
        assert!(is_safe_name("cam_01.left-2"));
        for bad in ["", ".hidden", "a/b", "a\\b", "..", "caméra", &"x".repeat(65)] {
            assert!(!is_safe_name(bad), "{bad}");
        }
    }
}

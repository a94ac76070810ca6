//! Virtual camera paths: nerfstudio's `camera_path.json` and dynview's own path format.
//!
//! nerfstudio stores `camera_to_world` as a 4x4 matrix (flattened row-major, 16 numbers) in
//! OpenGL camera axes (x right, y up, z backward), a vertical `fov` in degrees, an `aspect`
//! ratio and a `render_time` in `[0, 1]`. dynview converts to OpenCV axes on reading:
//! `world_from_camera_cv = world_from_camera_gl * diag(1, -1, -1)`.
//!
//! dynview's own format (`"format": "dynview-path"`) stores OpenCV poses, full intrinsics and
//! time steps directly, for paths that need an off-centre principal point or exact steps.

use glam::{DMat3, DVec3};
use serde::{Deserialize, Serialize};

use dynview_core::camera::{Camera, Intrinsics, Rigid3};
use dynview_core::scene::manifest::PoseEntry;

/// Errors reading a camera path.
#[derive(Debug, thiserror::Error)]
pub enum PathError {
    /// Not JSON of either supported shape.
    #[error("{file}: {source}")]
    Json {
        /// The file involved.
        file: String,
        /// The parse error.
        #[source]
        source: serde_json::Error,
    },
    /// A field holds a value that cannot be used.
    #[error("{file}: field `{field}`: {problem}")]
    Invalid {
        /// The file involved.
        file: String,
        /// The offending field.
        field: String,
        /// What is wrong.
        problem: String,
    },
}

/// Longest path accepted (frames).
pub const MAX_PATH_FRAMES: usize = 1_000_000;
/// Largest render side accepted (pixels).
pub const MAX_RENDER_SIDE_PX: u32 = 16_384;

/// When a path frame is shown.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum PathTime {
    /// nerfstudio's `render_time` in `[0, 1]` over the whole event.
    Normalized(f64),
    /// An exact time step.
    Step(u32),
}

impl PathTime {
    /// The time step shown for an event of `time_step_count` steps (nearest step).
    pub fn time_step(self, time_step_count: u32) -> u32 {
        let last = time_step_count.saturating_sub(1);
        match self {
            Self::Normalized(u) => (u.clamp(0.0, 1.0) * f64::from(last)).round() as u32,
            Self::Step(t) => t.min(last),
        }
    }
}

/// One frame of a path: a posed camera with its image size, and a time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathFrame {
    /// The virtual camera (OpenCV axes).
    pub camera: Camera,
    /// When it looks.
    pub time: PathTime,
}

/// `camera_to_world` as nerfstudio writes it (flat) or as some tools write it (nested rows).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Matrix4Json {
    /// 16 numbers, row-major.
    Flat(Vec<f64>),
    /// 4 rows of 4 numbers.
    Rows(Vec<Vec<f64>>),
}

/// One keyframe of a nerfstudio path.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct NerfstudioKeyframe {
    /// World-from-camera, OpenGL camera axes.
    pub camera_to_world: Matrix4Json,
    /// Vertical field of view in degrees.
    pub fov: f64,
    /// Width over height.
    pub aspect: f64,
    /// Time in `[0, 1]`; absent for static scenes (taken as 0).
    #[serde(default)]
    pub render_time: Option<f64>,
}

/// nerfstudio's `camera_path.json` (the fields dynview reads and writes).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct NerfstudioPath {
    /// Only `perspective` is supported.
    #[serde(default = "default_camera_type")]
    pub camera_type: String,
    /// Output height in pixels.
    pub render_height: u32,
    /// Output width in pixels.
    pub render_width: u32,
    /// The frames, one per output image.
    pub camera_path: Vec<NerfstudioKeyframe>,
    /// Frames per second of the rendered video.
    #[serde(default = "default_fps")]
    pub fps: f64,
    /// Duration in seconds.
    #[serde(default)]
    pub seconds: f64,
}

fn default_camera_type() -> String {
    "perspective".into()
}

fn default_fps() -> f64 {
    30.0
}

/// One frame of dynview's own path format.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DynviewPathFrame {
    /// Time step shown.
    pub time_step: u32,
    /// `camera_from_world`, OpenCV axes.
    pub pose: PoseEntry,
    /// Intrinsics at `width x height`.
    pub intrinsics: Intrinsics,
    /// Output width in pixels.
    pub width: u32,
    /// Output height in pixels.
    pub height: u32,
}

/// dynview's own path format.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DynviewPath {
    /// Always `dynview-path`.
    pub format: String,
    /// Format version, 1.
    pub version: u32,
    /// The frames.
    pub frames: Vec<DynviewPathFrame>,
}

/// Flips between OpenGL and OpenCV camera axes (its own inverse).
const GL_FROM_CV: DMat3 = DMat3::from_cols(DVec3::X, DVec3::NEG_Y, DVec3::NEG_Z);

impl NerfstudioPath {
    /// Builds a path from OpenCV cameras (principal points are assumed centred) and times in
    /// `[0, 1]`; every camera must share the first one's image size.
    pub fn from_frames(frames: &[(Camera, f64)], fps: f64) -> Self {
        let (width, height) = frames.first().map(|(c, _)| (c.width_px, c.height_px)).unwrap_or((1, 1));
        let camera_path = frames
            .iter()
            .map(|(camera, time)| {
                let world_from_camera = camera.camera_from_world.inverse();
                let rotation_gl = world_from_camera.rotation * GL_FROM_CV;
                let t = world_from_camera.translation;
                let rows = [rotation_gl.row(0), rotation_gl.row(1), rotation_gl.row(2)];
                let mut flat = Vec::with_capacity(16);
                for (r, row) in rows.iter().enumerate() {
                    flat.extend_from_slice(&[row.x, row.y, row.z, t[r]]);
                }
                flat.extend_from_slice(&[0.0, 0.0, 0.0, 1.0]);
                NerfstudioKeyframe {
                    camera_to_world: Matrix4Json::Flat(flat),
                    fov: camera.intrinsics.vertical_fov_rad(camera.height_px).to_degrees(),
                    aspect: f64::from(camera.width_px) / f64::from(camera.height_px),
                    render_time: Some(*time),
                }
            })
            .collect::<Vec<_>>();
        Self {
            camera_type: default_camera_type(),
            render_height: height,
            render_width: width,
            seconds: camera_path.len() as f64 / fps,
            camera_path,
            fps,
        }
    }
}

fn invalid(file: &str, field: impl Into<String>, problem: impl Into<String>) -> PathError {
    PathError::Invalid { file: file.to_owned(), field: field.into(), problem: problem.into() }
}

fn rows_from_matrix(m: &Matrix4Json, file: &str, field: &str) -> Result<[[f64; 4]; 4], PathError> {
    let flat: Vec<f64> = match m {
        Matrix4Json::Flat(v) => v.clone(),
        Matrix4Json::Rows(rows) => {
            if rows.len() != 4 || rows.iter().any(|r| r.len() != 4) {
                return Err(invalid(file, field, "must be 4 rows of 4 numbers"));
            }
            rows.iter().flatten().copied().collect()
        }
    };
    if flat.len() != 16 {
        return Err(invalid(file, field, format!("must hold 16 numbers, found {}", flat.len())));
    }
    if flat.iter().any(|v| !v.is_finite()) {
        return Err(invalid(file, field, "non-finite entry"));
    }
    Ok(std::array::from_fn(|r| std::array::from_fn(|c| flat[r * 4 + c])))
}

fn check_render_size(width: u32, height: u32, file: &str, field: &str) -> Result<(), PathError> {
    if width == 0 || height == 0 || width > MAX_RENDER_SIDE_PX || height > MAX_RENDER_SIDE_PX {
        return Err(invalid(file, field, format!("{width}x{height} must be within 1..={MAX_RENDER_SIDE_PX}")));
    }
    Ok(())
}

/// Parses a path file of either format. `file` names it in errors. `size_override` replaces
/// the path's render size (intrinsics are rescaled).
pub fn parse_path(bytes: &[u8], file: &str, size_override: Option<(u32, u32)>) -> Result<Vec<PathFrame>, PathError> {
    let value: serde_json::Value = serde_json::from_slice(bytes).map_err(|source| PathError::Json { file: file.to_owned(), source })?;
    let is_dynview = value.get("format").and_then(|f| f.as_str()) == Some("dynview-path");
    let frames = if is_dynview {
        let path: DynviewPath = serde_json::from_value(value).map_err(|source| PathError::Json { file: file.to_owned(), source })?;
        frames_from_dynview(&path, file)?
    } else {
        let path: NerfstudioPath = serde_json::from_value(value).map_err(|source| PathError::Json { file: file.to_owned(), source })?;
        frames_from_nerfstudio(&path, file)?
    };
    if let Some((w, h)) = size_override {
        check_render_size(w, h, file, "(size override)")?;
        return Ok(frames.into_iter().map(|f| PathFrame { camera: f.camera.resized(w, h), ..f }).collect());
    }
    Ok(frames)
}

fn check_frame_count(n: usize, file: &str, field: &str) -> Result<(), PathError> {
    if n == 0 || n > MAX_PATH_FRAMES {
        return Err(invalid(file, field, format!("must hold 1..={MAX_PATH_FRAMES} frames, found {n}")));
    }
    Ok(())
}

fn frames_from_nerfstudio(path: &NerfstudioPath, file: &str) -> Result<Vec<PathFrame>, PathError> {
    if path.camera_type != "perspective" {
        return Err(invalid(file, "camera_type", format!("only \"perspective\" is supported, found {:?}", path.camera_type)));
    }
    check_frame_count(path.camera_path.len(), file, "camera_path")?;
    check_render_size(path.render_width, path.render_height, file, "render_width/render_height")?;
    let (width, height) = (path.render_width, path.render_height);
    path.camera_path
        .iter()
        .enumerate()
        .map(|(i, key)| {
            let field = |name: &str| format!("camera_path[{i}].{name}");
            let m = rows_from_matrix(&key.camera_to_world, file, &field("camera_to_world"))?;
            let rotation_gl = DMat3::from_cols(
                DVec3::new(m[0][0], m[1][0], m[2][0]),
                DVec3::new(m[0][1], m[1][1], m[2][1]),
                DVec3::new(m[0][2], m[1][2], m[2][2]),
            );
            let world_from_camera = Rigid3::new(rotation_gl * GL_FROM_CV, DVec3::new(m[0][3], m[1][3], m[2][3]));
            if !world_from_camera.is_proper_rigid(dynview_core::scene::limits::ROTATION_TOLERANCE) {
                return Err(invalid(file, field("camera_to_world"), "rotation part is not a rotation"));
            }
            if !(key.fov.is_finite() && key.fov > 0.1 && key.fov < 179.0) {
                return Err(invalid(file, field("fov"), format!("must be in (0.1, 179) degrees, found {}", key.fov)));
            }
            let time = key.render_time.unwrap_or(0.0);
            if !(0.0..=1.0).contains(&time) {
                return Err(invalid(file, field("render_time"), format!("must be in [0, 1], found {time}")));
            }
            // As nerfstudio does: square pixels from the vertical fov and the render height,
            // principal point at the centre; `aspect` only sizes its viewer's frustum.
            let intrinsics = Intrinsics::from_vertical_fov(key.fov.to_radians(), width, height);
            Ok(PathFrame {
                camera: Camera { intrinsics, camera_from_world: world_from_camera.inverse(), width_px: width, height_px: height },
                time: PathTime::Normalized(time),
            })
        })
        .collect()
}

fn frames_from_dynview(path: &DynviewPath, file: &str) -> Result<Vec<PathFrame>, PathError> {
    if path.version != 1 {
        return Err(invalid(file, "version", format!("unsupported version {}", path.version)));
    }
    check_frame_count(path.frames.len(), file, "frames")?;
    path.frames
        .iter()
        .enumerate()
        .map(|(i, f)| {
            let field = |name: &str| format!("frames[{i}].{name}");
            check_render_size(f.width, f.height, file, &field("width/height"))?;
            let pose = f.pose.camera_from_world();
            if !pose.is_proper_rigid(dynview_core::scene::limits::ROTATION_TOLERANCE) {
                return Err(invalid(file, field("pose"), "not a finite rigid transform"));
            }
            if !f.intrinsics.is_valid() {
                return Err(invalid(file, field("intrinsics"), "must be finite with positive focal lengths"));
            }
            Ok(PathFrame {
                camera: Camera { intrinsics: f.intrinsics, camera_from_world: pose, width_px: f.width, height_px: f.height },
                time: PathTime::Step(f.time_step),
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera() -> Camera {
        Camera {
            intrinsics: Intrinsics::from_vertical_fov(50f64.to_radians(), 320, 180),
            camera_from_world: Rigid3::camera_from_world_looking_at(DVec3::new(1.0, 1.5, 5.0), DVec3::ZERO, DVec3::Y),
            width_px: 320,
            height_px: 180,
        }
    }

    #[test]
    fn nerfstudio_round_trip() {
        let cam = camera();
        let path = NerfstudioPath::from_frames(&[(cam, 0.0), (cam, 1.0)], 30.0);
        let json = serde_json::to_vec(&path).unwrap();
        let frames = parse_path(&json, "camera_path.json", None).unwrap();
        assert_eq!(frames.len(), 2);
        let back = frames[0].camera;
        let d = back.camera_from_world.rotation - cam.camera_from_world.rotation;
        assert!(d.to_cols_array().iter().all(|v| v.abs() < 1e-12));
        assert!((back.center_world() - cam.center_world()).length() < 1e-12);
        assert!((back.intrinsics.fy - cam.intrinsics.fy).abs() < 1e-9);
        assert!((back.intrinsics.fx - cam.intrinsics.fx).abs() < 1e-9);
        assert_eq!(frames[1].time.time_step(30), 29);
    }

    #[test]
    fn opengl_axes_hand_checked() {
        // Identity camera_to_world in OpenGL axes looks down world -z with y up.
        let json = r#"{"render_height": 10, "render_width": 20, "camera_path": [
            {"camera_to_world": [1,0,0,0, 0,1,0,0, 0,0,1,2, 0,0,0,1], "fov": 90, "aspect": 2.0, "render_time": 0.5}]}"#;
        let frames = parse_path(json.as_bytes(), "p.json", None).unwrap();
        let cam = frames[0].camera;
        assert!((cam.center_world() - DVec3::new(0.0, 0.0, 2.0)).length() < 1e-12);
        // The world origin is straight ahead, 2 m away.
        let (px, depth) = cam.project_world(DVec3::ZERO).unwrap();
        assert!((depth - 2.0).abs() < 1e-12);
        assert!((px.x - 9.5).abs() < 1e-9 && (px.y - 4.5).abs() < 1e-9);
        // World +y is up in the image.
        assert!(cam.project_world(DVec3::new(0.0, 0.5, 0.0)).unwrap().0.y < px.y);
        assert_eq!(frames[0].time.time_step(11), 5);
    }

    #[test]
    fn nested_rows_and_size_override() {
        let json = r#"{"render_height": 10, "render_width": 20, "camera_path": [
            {"camera_to_world": [[1,0,0,0],[0,1,0,0],[0,0,1,2],[0,0,0,1]], "fov": 90, "aspect": 2.0}]}"#;
        let frames = parse_path(json.as_bytes(), "p.json", Some((40, 20))).unwrap();
        assert_eq!((frames[0].camera.width_px, frames[0].camera.height_px), (40, 20));
        assert_eq!(frames[0].time, PathTime::Normalized(0.0));
    }

    #[test]
    fn dynview_format_round_trip() {
        let cam = camera();
        let path = DynviewPath {
            format: "dynview-path".into(),
            version: 1,
            frames: vec![DynviewPathFrame {
                time_step: 7,
                pose: cam.camera_from_world.into(),
                intrinsics: cam.intrinsics,
                width: 320,
                height: 180,
            }],
        };
        let frames = parse_path(&serde_json::to_vec(&path).unwrap(), "p.json", None).unwrap();
        assert_eq!(frames[0].time.time_step(5), 4);
        assert_eq!(frames[0].time.time_step(50), 7);
        assert!((frames[0].camera.center_world() - cam.center_world()).length() < 1e-12);
    }

    #[test]
    fn bad_paths_name_the_field() {
        let cases = [
            (r#"{"render_height": 10, "render_width": 20, "camera_path": []}"#, "camera_path"),
            (
                r#"{"render_height": 0, "render_width": 20, "camera_path": [{"camera_to_world": [1,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1], "fov": 50, "aspect": 1}]}"#,
                "render_width/render_height",
            ),
            (
                r#"{"render_height": 10, "render_width": 20, "camera_path": [{"camera_to_world": [1,0,0], "fov": 50, "aspect": 1}]}"#,
                "camera_path[0].camera_to_world",
            ),
            (
                r#"{"render_height": 10, "render_width": 20, "camera_path": [{"camera_to_world": [2,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1], "fov": 50, "aspect": 1}]}"#,
                "camera_path[0].camera_to_world",
            ),
            (
                r#"{"render_height": 10, "render_width": 20, "camera_path": [{"camera_to_world": [1,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1], "fov": 500, "aspect": 1}]}"#,
                "camera_path[0].fov",
            ),
            (
                r#"{"render_height": 10, "render_width": 20, "camera_path": [{"camera_to_world": [1,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1], "fov": 50, "aspect": 1, "render_time": 2}]}"#,
                "camera_path[0].render_time",
            ),
        ];
        for (json, field) in cases {
            let err = parse_path(json.as_bytes(), "p.json", None).unwrap_err().to_string();
            assert!(err.contains(&format!("`{field}`")), "{field}: {err}");
        }
        assert!(matches!(parse_path(b"[1,2", "p.json", None), Err(PathError::Json { .. })));
    }
}

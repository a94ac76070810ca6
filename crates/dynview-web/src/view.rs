//! The page's description of a virtual camera (eye, target, up, vertical field of view) and
//! of the scene, as plain JS objects (serde), converted to and from dynview-core's cameras.

use dynview_core::camera::{Camera, Intrinsics, Rigid3};
use dynview_core::scene::Manifest;
use dynview_interchange::camera_path::{MAX_RENDER_SIDE_PX, PathFrame};
use glam::DVec3;
use serde::{Deserialize, Serialize};

/// A virtual camera as the page moves it: world-space eye, target and up, and a vertical field
/// of view. Image up is as close to `up` as the view direction allows.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct View {
    /// Camera centre (world).
    pub eye: [f64; 3],
    /// A point the camera looks at (world).
    pub target: [f64; 3],
    /// World direction that appears up.
    pub up: [f64; 3],
    /// Vertical field of view in degrees.
    pub vertical_fov_deg: f64,
}

impl View {
    /// Checks that the view defines a camera: finite, eye apart from target, up not along the
    /// view direction, field of view in (0, 180).
    pub fn validate(&self) -> Result<(), String> {
        let all = self.eye.iter().chain(&self.target).chain(&self.up).chain(std::iter::once(&self.vertical_fov_deg));
        if all.clone().any(|v| !v.is_finite()) {
            return Err("view: non-finite eye, target, up or vertical_fov_deg".into());
        }
        let forward = DVec3::from(self.target) - DVec3::from(self.eye);
        if forward.length() < 1e-9 {
            return Err("view: eye and target coincide".into());
        }
        if forward.normalize().cross(DVec3::from(self.up)).length() < 1e-6 {
            return Err("view: up is parallel to the view direction".into());
        }
        if !(self.vertical_fov_deg > 0.1 && self.vertical_fov_deg < 179.0) {
            return Err(format!("view: vertical_fov_deg {} is not in (0.1, 179)", self.vertical_fov_deg));
        }
        Ok(())
    }

    /// The camera of this view for an image of `width_px x height_px` (centred principal
    /// point).
    pub fn camera(&self, width_px: u32, height_px: u32) -> Result<Camera, String> {
        self.validate()?;
        if width_px == 0 || height_px == 0 || width_px > MAX_RENDER_SIDE_PX || height_px > MAX_RENDER_SIDE_PX {
            return Err(format!("render size {width_px}x{height_px} is not within 1..={MAX_RENDER_SIDE_PX}"));
        }
        Ok(Camera {
            intrinsics: Intrinsics::from_vertical_fov(self.vertical_fov_deg.to_radians(), width_px, height_px),
            camera_from_world: Rigid3::camera_from_world_looking_at(self.eye.into(), self.target.into(), self.up.into()),
            width_px,
            height_px,
        })
    }

    /// The view of `camera`, its target `distance` ahead (the vertical field of view comes
    /// from `fy`; an off-centre principal point is not kept).
    pub fn of_camera(camera: &Camera, distance: f64) -> Self {
        let world_from_camera = camera.camera_from_world.inverse();
        let eye = world_from_camera.translation;
        let forward = world_from_camera.transform_vector(DVec3::Z);
        let up = world_from_camera.transform_vector(DVec3::NEG_Y);
        Self {
            eye: eye.into(),
            target: (eye + forward * distance).into(),
            up: up.into(),
            vertical_fov_deg: camera.intrinsics.vertical_fov_rad(camera.height_px).to_degrees(),
        }
    }
}

/// One input camera, for the page's snap buttons.
#[derive(Debug, Serialize)]
pub struct CameraInfo {
    /// Its name.
    pub name: String,
    /// Frame width.
    pub width: u32,
    /// Frame height.
    pub height: u32,
}

/// What the page needs to know about an opened scene.
#[derive(Debug, Serialize)]
pub struct SceneInfo {
    /// Scene name.
    pub name: String,
    /// Frames per second of the capture.
    pub fps: f64,
    /// Number of time steps.
    pub time_step_count: u32,
    /// Input cameras.
    pub cameras: Vec<CameraInfo>,
    /// Centre of the scene bounds (world).
    pub center: [f64; 3],
    /// Diagonal of the scene bounds.
    pub diagonal: f64,
    /// The suggested first view.
    pub start_view: View,
    /// The suggested first time step.
    pub start_time_step: u32,
    /// The WebCodecs codec string of the frames' videos; `None` when the frames are images.
    pub video_codec: Option<String>,
}

/// Distance from `eye` along the view to the scene centre, at least a tenth of the diagonal:
/// where an orbit around a snapped camera should pivot.
pub fn pivot_distance(manifest: &Manifest, camera: &Camera) -> f64 {
    let center = DVec3::from(manifest.bounds.center());
    let ahead = camera.camera_from_world.transform_point(center).z;
    ahead.max(0.1 * manifest.bounds.diagonal())
}

impl SceneInfo {
    /// The info of `manifest`.
    pub fn new(manifest: &Manifest) -> Self {
        let start = &manifest.start_view;
        let start_camera = Camera {
            intrinsics: Intrinsics::from_vertical_fov(start.vertical_fov_deg.to_radians(), 16, 9),
            camera_from_world: start.pose.camera_from_world(),
            width_px: 16,
            height_px: 9,
        };
        Self {
            name: manifest.name.clone(),
            fps: manifest.fps,
            time_step_count: manifest.time_step_count,
            cameras: manifest.cameras.iter().map(|c| CameraInfo { name: c.name.clone(), width: c.width, height: c.height }).collect(),
            center: manifest.bounds.center(),
            diagonal: manifest.bounds.diagonal(),
            start_view: View {
                vertical_fov_deg: start.vertical_fov_deg,
                ..View::of_camera(&start_camera, pivot_distance(manifest, &start_camera))
            },
            start_time_step: start.time_step,
            video_codec: manifest.frame_format.is_video().then(|| dynview_core::scene::video::WEBCODECS_CODEC.to_owned()),
        }
    }
}

/// A frame of an imported camera path, as the page uses it.
#[derive(Debug, Serialize)]
pub struct PathView {
    /// The view.
    pub view: View,
    /// The time step shown.
    pub time_step: u32,
    /// Its render width.
    pub width: u32,
    /// Its render height.
    pub height: u32,
}

impl PathView {
    /// The page's form of a parsed path frame in a scene of `time_step_count` steps.
    pub fn new(frame: &PathFrame, manifest: &Manifest) -> Self {
        Self {
            view: View::of_camera(&frame.camera, pivot_distance(manifest, &frame.camera)),
            time_step: frame.time.time_step(manifest.time_step_count),
            width: frame.camera.width_px,
            height: frame.camera.height_px,
        }
    }
}

//! What the page is told about the scene and its views, as plain JS objects (serde). A view is
//! dynview-core's [`LookAtView`](dynview_core::look_at::LookAtView) (eye, target, up, vertical field of view), which converts to
//! and from cameras.

use dynview_core::camera::Camera;
pub use dynview_core::look_at::LookAtView as View;
use dynview_core::look_at::pivot_distance;
use dynview_core::scene::Manifest;
use dynview_interchange::camera_path::{MAX_RENDER_SIDE_PX, PathFrame};
use serde::Serialize;

/// The camera of `view` for an image of `width_px x height_px`, each side within the render
/// sizes camera paths allow.
pub(crate) fn view_camera(view: &View, width_px: u32, height_px: u32) -> Result<Camera, String> {
    view.camera(width_px, height_px, MAX_RENDER_SIDE_PX)
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

impl SceneInfo {
    /// The info of `manifest`.
    pub fn new(manifest: &Manifest) -> Self {
        Self {
            name: manifest.name.clone(),
            fps: manifest.fps,
            time_step_count: manifest.time_step_count,
            cameras: manifest.cameras.iter().map(|c| CameraInfo { name: c.name.clone(), width: c.width, height: c.height }).collect(),
            center: manifest.bounds.center(),
            diagonal: manifest.bounds.diagonal(),
            start_view: View::of_start_view(&manifest.start_view, &manifest.bounds),
            start_time_step: manifest.start_view.time_step,
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
            view: View::of_camera(&frame.camera, pivot_distance(&manifest.bounds, &frame.camera)),
            time_step: frame.time.time_step(manifest.time_step_count),
            width: frame.camera.width_px,
            height: frame.camera.height_px,
        }
    }
}

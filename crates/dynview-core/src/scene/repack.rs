//! Rewriting a package in another format: frames as video or images, format v2 or v1 (for
//! example a v1 package into a v2 one). Cameras, points and background plates are copied as they
//! are (a plate is encoded again, as JPEG).

use std::path::Path;

use super::error::SceneResult;
use super::ffmpeg::VideoSettings;
use super::manifest::{FORMAT_VERSION, FORMAT_VERSION_V1, Manifest};
use super::package::{ScenePackage, SceneWriter};

/// Writes `package` to `out` (replaced only when complete) with its frames as one video per
/// camera (`Some` settings) or as JPEG files (`None`), in format v2, or v1 with `format_v1`
/// (JPEG frames, every step's points in full). A v2 package's static cloud stays stored once
/// (in v2) or is lent to each step (in v1). `progress(done, total)` counts time steps. Returns
/// the new manifest.
pub fn repack(
    package: &ScenePackage,
    out: &Path,
    video: Option<VideoSettings>,
    format_v1: bool,
    mut progress: impl FnMut(u64, u64),
) -> SceneResult<Manifest> {
    let video = video.filter(|_| !format_v1);
    let mut manifest = package.manifest().clone();
    manifest.version = if format_v1 { FORMAT_VERSION_V1 } else { FORMAT_VERSION };
    let steps = package.time_step_count();
    for camera in &mut manifest.cameras {
        // Set again as each plate is written.
        camera.plate = false;
        // Every pose written out (v1), or one for a camera that stands still (v2).
        camera.poses = (0..steps).map(|t| camera.pose(t)).collect();
        if !format_v1 {
            camera.compact_poses();
        }
    }
    match video {
        Some(settings) => manifest.set_video_frames(settings.keyframe_interval),
        None => manifest.set_jpeg_frames(),
    }
    let mut writer = SceneWriter::create_with(out, manifest, video.unwrap_or_default())?;
    for c in 0..package.camera_count() {
        if let Some(plate) = package.stored_plate(c)? {
            writer.write_plate(c, &plate.to_rgb8())?;
        }
    }
    let statics = package.static_cloud()?;
    if writer.has_static_cloud() && !statics.is_empty() {
        writer.set_static_cloud(&statics)?;
    }
    for t in 0..steps {
        for c in 0..package.camera_count() {
            writer.write_frame(c, t, &package.read_frame(c, t)?.to_rgb8())?;
        }
        if writer.has_static_cloud() {
            let (own, borrowed) = package.read_cloud_parts(t)?;
            writer.push_cloud_borrowing(&own, &borrowed)?;
        } else {
            writer.push_cloud(&package.read_cloud(t)?)?;
        }
        progress(u64::from(t) + 1, u64::from(steps));
    }
    writer.finish()
}

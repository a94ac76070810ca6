//! Rewriting a package with its frames stored another way (images to video, or back), for
//! example to turn a format v1 package into a v2 one. Clouds and cameras are copied as they are.

use std::path::Path;

use super::error::SceneResult;
use super::ffmpeg::VideoSettings;
use super::manifest::{FORMAT_VERSION, FrameFormat, FramesIndexEntry, Manifest};
use super::package::{ScenePackage, SceneWriter};

/// The name of the frame index a repacked video package gets.
pub const FRAMES_INDEX_FILE: &str = "frames.idx";

/// Writes `package` to `out` (replaced only when complete) with its frames as one video per
/// camera (`Some` settings) or as JPEG files (`None`). `progress(done, total)` counts time
/// steps. Returns the new manifest.
pub fn repack(
    package: &ScenePackage,
    out: &Path,
    video: Option<VideoSettings>,
    mut progress: impl FnMut(u64, u64),
) -> SceneResult<Manifest> {
    let mut manifest = package.manifest().clone();
    manifest.version = FORMAT_VERSION;
    match video {
        Some(settings) => {
            manifest.frame_format = FrameFormat::Vp9;
            manifest.frames_index =
                Some(FramesIndexEntry { file: FRAMES_INDEX_FILE.into(), byte_length: 0, keyframe_interval: settings.keyframe_interval });
        }
        None => {
            manifest.frame_format = FrameFormat::Jpeg;
            manifest.frames_index = None;
        }
    }
    let steps = package.time_step_count();
    let mut writer = SceneWriter::create_with(out, manifest, video.unwrap_or_default())?;
    for t in 0..steps {
        for c in 0..package.camera_count() {
            writer.write_frame(c, t, &package.read_frame(c, t)?.to_rgb8())?;
        }
        writer.push_cloud(&package.read_cloud(t)?)?;
        progress(u64::from(t) + 1, u64::from(steps));
    }
    writer.finish()
}

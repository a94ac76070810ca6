//! The Panoptic basketball arc (`../shared/data/panoptic-basketball-arc`) as `dynview prep`
//! input: 8 calibrated cameras on an arc, image folders `cams/camNN/00000.jpg ...`, and a COLMAP
//! text model of the calibration (undistorted PINHOLE cameras on tripods).

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use dynview_interchange::import::read_event_poses;
use dynview_interchange::poses::EventPoses;

use crate::paths::shared_data;

/// The interior cameras the capture's README names for leave-one-out (neighbours on both sides).
pub const HELD_OUT: [&str; 3] = ["cam11", "cam08", "cam27"];

/// The capture's folder.
pub fn source_dir() -> PathBuf {
    shared_data().join("panoptic-basketball-arc")
}

/// The calibration with one pose per camera (the cameras stood still), `keep` only when given.
pub fn calibration(keep: Option<&[&str]>) -> anyhow::Result<EventPoses> {
    let path = source_dir().join("calibration");
    let mut poses = read_event_poses(&path).with_context(|| format!("reading {} (is ../shared/data there?)", path.display()))?;
    poses.cameras.retain(|c| keep.is_none_or(|keep| keep.contains(&c.name.as_str())));
    for camera in &mut poses.cameras {
        let Some(first) = camera.frames.first().cloned() else {
            bail!("{}: camera {} has no frame", path.display(), camera.name);
        };
        if camera.frames.iter().any(|f| f.camera_from_world != first.camera_from_world) {
            bail!("{}: camera {} moves; a fixed camera was expected", path.display(), camera.name);
        }
        camera.frames.truncate(1);
    }
    Ok(poses)
}

/// Copies the first `frames` frames of every camera into `out/<camera>/`, unless `out` already
/// holds that many per camera.
pub fn copy_first_frames(out: &Path, frames: u32) -> anyhow::Result<()> {
    for camera in calibration(None)?.cameras {
        let folder = out.join(&camera.name);
        let have = std::fs::read_dir(&folder).map(|d| d.filter_map(Result::ok).count()).unwrap_or(0);
        if have == frames as usize {
            continue;
        }
        let partial = folder.with_extension("partial");
        if partial.exists() {
            std::fs::remove_dir_all(&partial).with_context(|| format!("cannot remove {}", partial.display()))?;
        }
        std::fs::create_dir_all(&partial).with_context(|| format!("cannot create {}", partial.display()))?;
        let source = source_dir().join("cams").join(&camera.name);
        for t in 0..frames {
            let name = format!("{t:05}.jpg");
            let from = source.join(&name);
            if !from.is_file() {
                bail!("{}: frame {t} missing (the capture has fewer than {frames} frames)", from.display());
            }
            std::fs::copy(&from, partial.join(&name)).with_context(|| format!("cannot copy {}", from.display()))?;
        }
        if folder.exists() {
            std::fs::remove_dir_all(&folder).with_context(|| format!("cannot remove {}", folder.display()))?;
        }
        std::fs::rename(&partial, &folder).with_context(|| format!("cannot rename {} to {}", partial.display(), folder.display()))?;
    }
    Ok(())
}

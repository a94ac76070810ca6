//! The Panoptic basketball arcs (`../shared/data/panoptic-basketball-arc` and
//! `panoptic-basketball-arc2`) as `dynview prep` input: calibrated cameras on an arc, image
//! folders `cams/camNN/00000.jpg ...`, and a COLMAP text model of the calibration (undistorted
//! PINHOLE cameras on tripods).

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use dynview_interchange::import::read_event_poses;
use dynview_interchange::poses::EventPoses;

use crate::paths::shared_data;

/// Frames of every camera of either arc (frames 0-74 of the sequence).
pub const FRAMES: u32 = 75;

/// One of the two disjoint arcs of cameras of the Panoptic basketball capture.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PanopticArc {
    /// `panoptic-basketball-arc`: 8 cameras over about 120 degrees, neighbours 5-25 degrees apart.
    First,
    /// `panoptic-basketball-arc2`: 10 cameras over about 140 degrees, neighbours 1-36 degrees
    /// apart (two wide gaps).
    Second,
}

impl PanopticArc {
    /// The interior cameras the capture's README names for leave-one-out (neighbours on both
    /// sides).
    pub fn held_out(self) -> &'static [&'static str] {
        match self {
            Self::First => &["cam11", "cam08", "cam27"],
            Self::Second => &["cam09", "cam04", "cam07"],
        }
    }

    /// The arc's folder.
    pub fn source_dir(self) -> PathBuf {
        shared_data().join(match self {
            Self::First => "panoptic-basketball-arc",
            Self::Second => "panoptic-basketball-arc2",
        })
    }
}

/// The calibration of `arc` with one pose per camera (the cameras stood still), `keep` only when
/// given.
pub fn calibration(arc: PanopticArc, keep: Option<&[&str]>) -> anyhow::Result<EventPoses> {
    let path = arc.source_dir().join("calibration");
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

/// Copies the first `frames` frames of every camera of `arc` into `out/<camera>/`, unless `out`
/// already holds that many per camera.
pub fn copy_first_frames(arc: PanopticArc, out: &Path, frames: u32) -> anyhow::Result<()> {
    for camera in calibration(arc, None)?.cameras {
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
        let source = arc.source_dir().join("cams").join(&camera.name);
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

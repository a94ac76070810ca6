//! The Pose2Sim capture (`../shared/data/pose2sim-multiperson`) as `dynview prep` input: its
//! videos, the first frames of them as image folders, and its Qualisys calibration as a
//! `poses.json` with one pose per camera (the cameras stood on tripods).

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context, bail};
use dynview_interchange::qualisys::{QualisysCamera, event_poses, parse_qualisys_calibration};

use crate::paths::{command_line as describe, shared_data};

/// Working width of prep's frames for the portrait 1088x1920 videos (960 would keep them
/// nearly full size; 540 gives 540x953 frames).
pub const WORKING_WIDTH_PX: u32 = 540;

/// Frames of every camera's video.
pub const FRAMES: u32 = 100;

/// The capture's folder.
pub fn source_dir() -> PathBuf {
    shared_data().join("pose2sim-multiperson")
}

/// The folder of its videos (`cam01.mp4` ... `cam04.mp4`).
pub fn videos_dir() -> PathBuf {
    source_dir().join("videos")
}

/// The cameras of the Qualisys calibration.
pub fn calibration() -> anyhow::Result<Vec<QualisysCamera>> {
    let path = source_dir().join("calibration/Calib.qca.txt");
    let text = std::fs::read_to_string(&path).with_context(|| format!("cannot read {} (is ../shared/data there?)", path.display()))?;
    Ok(parse_qualisys_calibration(&text, &path.display().to_string())?)
}

/// Writes the calibration as `poses.json` (`dynview_interchange::qualisys::event_poses`) to `path` (validated; atomic).
pub fn write_calibrated_poses(path: &Path, keep: Option<&[&str]>) -> anyhow::Result<()> {
    let poses = event_poses(&calibration()?, keep);
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent).with_context(|| format!("cannot create {}", parent.display()))?;
    }
    poses.write(path).with_context(|| format!("writing {}", path.display()))
}

/// Extracts the first `frames` frames of every camera's video into `out/<camera>/<i:05>.jpg`
/// (best JPEG quality), unless `out` already holds that many per camera.
pub fn extract_first_frames(out: &Path, frames: u32) -> anyhow::Result<()> {
    for camera in calibration()? {
        let folder = out.join(&camera.serial);
        let have = std::fs::read_dir(&folder).map(|d| d.filter_map(Result::ok).count()).unwrap_or(0);
        if have == frames as usize {
            continue;
        }
        if folder.exists() {
            std::fs::remove_dir_all(&folder).with_context(|| format!("cannot remove {}", folder.display()))?;
        }
        std::fs::create_dir_all(&folder).with_context(|| format!("cannot create {}", folder.display()))?;
        let video = videos_dir().join(format!("{}.mp4", camera.serial));
        let mut cmd = Command::new("ffmpeg");
        cmd.args(["-v", "error", "-nostdin", "-y", "-i"])
            .arg(&video)
            .args(["-frames:v", &frames.to_string(), "-q:v", "1", "-start_number", "0"])
            .arg(folder.join("%05d.jpg"));
        println!("    {}", describe(&cmd));
        let status = cmd.status().with_context(|| format!("cannot start {} (is ffmpeg installed?)", describe(&cmd)))?;
        if !status.success() {
            bail!("{} failed ({status})", describe(&cmd));
        }
        let got = std::fs::read_dir(&folder)?.count();
        if got != frames as usize {
            bail!("{}: {got} frames extracted from {}, expected {frames}", folder.display(), video.display());
        }
    }
    Ok(())
}
